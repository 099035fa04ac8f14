"""The axles against the numbers of the vehicle file and statics worked on paper: at rest the
axles carry the car's weight split by its CG position (m g b / L front, m g a / L rear) and
hold it still; a heave of dz changes each axle's force by -k dz and a heave rate of dz/dt by
-c dz/dt, with the vehicle file's k and c; a nose-down pitch loads the front axle and unloads
the rear; a moving, pitched car's lifts, margins, axle speeds and pitch moment agree with the
rigid-body positions of its axle and ground points, written out in the test (virtual work).
(The smoothing of the unilateral contact is 20 N wide: negligible at these loads.)"""

import jax.numpy as jnp
import numpy as np
import pytest

from sim import Solver, named_params
from sim.ground import ground_forces, wheel_centre_rise
from sim.vehicle import GRAVITY
from sim.wheels import axle_jacobians

PARAMS = named_params("paper_identified")


def axles(a4, q, v):
    force, normal, margin, _ = ground_forces(jnp.asarray(q, dtype=float), jnp.asarray(v, dtype=float), a4, PARAMS,
                                                jnp.asarray(0.0), Solver())
    return np.asarray(force), np.asarray(normal)


def test_at_rest_the_axles_carry_the_weight_split_by_the_cg_and_hold_the_car_still(a4):
    force, normal = axles(a4, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    m, a, length = float(a4.mass), float(a4.cg_to_front_axle), float(a4.wheelbase)
    w = m * GRAVITY
    assert normal == pytest.approx([w * (length - a) / length, w * a / length], rel=1e-4)
    assert abs(force[1]) < 1e-3 * w and abs(force[2]) < 1e-3 * w * length  # no net heave force, no pitch moment


def test_heave_changes_each_axle_force_by_k_times_the_rise(a4):
    _, rest = axles(a4, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    _, up = axles(a4, [0.0, 0.01, 0.0], [0.0, 0.0, 0.0])
    assert rest - up == pytest.approx(0.01 * np.asarray(a4.axle_stiffness), rel=1e-3)


def test_heave_rate_changes_each_axle_force_by_c_times_the_rate(a4):
    _, rest = axles(a4, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    _, rising = axles(a4, [0.0, 0.0, 0.0], [0.0, 0.1, 0.0])
    assert rest - rising == pytest.approx(0.1 * np.asarray(a4.axle_damping), rel=1e-3)


def test_a_nose_down_pitch_loads_the_front_axle_and_unloads_the_rear(a4):
    _, rest = axles(a4, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    moment, pitched = axles(a4, [0.0, 0.0, 0.01], [0.0, 0.0, 0.0])  # 0.01 rad nose down
    a, b = float(a4.cg_to_front_axle), float(a4.cg_to_rear_axle)
    k = np.asarray(a4.axle_stiffness)
    # the front axle point drops by about a * 0.01 m, the rear rises by b * 0.01 m
    assert pitched - rest == pytest.approx([k[0] * a * 0.01, -k[1] * b * 0.01], rel=0.05)
    # and the springs pitch it back, nose up: -(k_f a^2 + k_r b^2) * 0.01 (the weight's lever,
    # the axle loads times (h - r) * 0.01, is a few per cent of it)
    assert moment[2] == pytest.approx(-(k[0] * a**2 + k[1] * b**2) * 0.01, rel=0.1)


@pytest.mark.parametrize("speed", [0.0, 0.25, 0.5, 5.0])
def test_blocked_front_tyres_slide_on_the_stribeck_curve_and_the_rear_ones_roll(a4, speed):
    """Blocked front wheels, the car level, moving at ``speed``: each front tyre pushes back
    with mu_block(v) N, mu_block(v) = mu_slip + (mu_adhesion - mu_slip) exp(-(v / 0.5 m/s)^2)
    (docs/physics.md's friction jump, with the Stribeck drop), the rear with the rolling
    resistance; both times tanh(v / 0.02 m/s), the sign's smoothing."""
    solver = Solver()
    force, normal, *_ = ground_forces(jnp.zeros(3), jnp.asarray([speed, 0.0, 0.0]), a4, PARAMS, jnp.asarray(1.0), solver)
    mu_s, mu_a, rr = (float(getattr(PARAMS, n)) for n in ("mu_slip", "mu_adhesion", "rolling_resistance"))
    mu_front = mu_s + (mu_a - mu_s) * np.exp(-(speed / solver.stribeck_speed) ** 2)
    sign = np.tanh(speed / solver.friction_speed_width)
    expected = -(mu_front * float(normal[0]) + rr * float(normal[1])) * sign
    assert float(force[0]) == pytest.approx(expected, rel=1e-9, abs=1e-9)
    if speed > 0:
        assert float(force[0]) < -rr * float(np.sum(normal)) * sign  # more than rolling alone


def body_point(q, px, pz):
    """World (X, Z) of the body point (px, pz) (m, from the CG, body axes) when the CG is at
    (x, z) and the body pitched by theta nose down: the rotation written out, apart from
    sim/ground.py's expressions."""
    x, z, theta = q
    rot = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
    return np.array([x, z]) + rot @ np.array([px, pz])


def rate(f, q, v, h=1e-7):
    """d f(q(t)) / dt along the velocity v, by a central difference."""
    q, v = np.asarray(q, float), np.asarray(v, float)
    return (f(q + h * v) - f(q - h * v)) / (2 * h)


@pytest.mark.parametrize("lifted", [0, 1])  # which axle is off the ground: front, rear
def test_axle_geometry_and_the_virtual_work_of_the_one_axle_on_the_ground(a4, lifted):
    """A moving, rising, pitched car with one wheel pair in the air. Against the rigid-body
    positions of the axle points (px, r - h) and of the ground points below them (px, -h):
    each axle's lift is its rise above the height where its wheel just touches, its contact
    margin k (delta0 - rise) - c d(rise)/dt, its horizontal speed that of its axle point; the
    axle that touches carries the whole generalised force of the ground, so the pitch moment
    is its normal force times dZ/dtheta of its axle point plus its tyre force times
    dX/dtheta of its ground point (virtual work), and the tyre force is the whole x force."""
    theta = 0.08 if lifted == 1 else -0.08  # nose down lifts the rear, nose up the front
    q = np.array([0.3, 0.02, theta])
    v = np.array([6.0, 0.4, 3.0 if lifted == 1 else -3.0])
    force, normal, margin, lift = (np.asarray(o) for o in ground_forces(
        jnp.asarray(q), jnp.asarray(v), a4, PARAMS, jnp.asarray(1.0), Solver()))
    axle_speed = np.asarray(axle_jacobians(jnp.asarray(q), a4)) @ v  # the wheels' spin rolls against it (sim.wheels)
    a, b = float(a4.cg_to_front_axle), float(a4.cg_to_rear_axle)
    h, r = float(a4.cg_height), float(a4.wheel_radius)
    k, c = np.asarray(a4.axle_stiffness), np.asarray(a4.axle_damping)
    delta0 = np.asarray(a4.static_axle_loads) / k
    on = 1 - lifted
    for i, px in enumerate((a, -b)):
        axle = lambda qq, px=px: body_point(qq, px, r - h)  # noqa: E731
        rise = axle(q)[1] - axle(np.zeros(3))[1]
        assert margin[i] == pytest.approx(k[i] * (delta0[i] - rise) - c[i] * rate(axle, q, v)[1], rel=1e-6)
        assert lift[i] == pytest.approx(max(rise - delta0[i], 0.0), abs=1e-9)
        assert axle_speed[i] == pytest.approx(rate(axle, q, v)[0], rel=1e-6)
    assert lift[lifted] > 0.01 and lift[on] == 0.0 and normal[lifted] < 1e-6 * normal[on]
    px = (a, -b)[on]
    d_dtheta = lambda f: (f(q + [0, 0, 1e-7]) - f(q - [0, 0, 1e-7])) / 2e-7  # noqa: E731
    dz_axle = d_dtheta(lambda qq: body_point(qq, px, r - h))[1]
    dx_ground = d_dtheta(lambda qq: body_point(qq, px, -h))[0]
    tyre = force[0]
    assert tyre < 0.0  # moving forward: the tyre pushes back
    assert force[2] == pytest.approx(normal[on] * dz_axle + tyre * dx_ground, rel=1e-6)
    assert force[1] == pytest.approx(normal[on] - float(a4.mass) * GRAVITY, rel=1e-9)


def test_a_wheel_centre_rises_with_its_axle_point_from_its_last_sample_on_the_floor():
    """On the floor (margin >= 0) the centre stands at 0; off it, it rises as the axle point
    does from where that point was at the last sample on the floor, never below the floor;
    landing and leaving again starts from the new last sample on the floor, and a wheel off
    the floor from the start rises from its first sample."""
    axle = np.array([0.0, 0.01, 0.03, 0.06, 0.02, -0.01, 0.05, 0.04, 0.08, 0.09])
    margin = np.array([1.0, 1.0, -1.0, -1.0, -1.0, -1.0, 1.0, -1.0, -1.0, 0.0])
    np.testing.assert_allclose(np.asarray(wheel_centre_rise(axle, margin)),
                               [0.0, 0.0, 0.02, 0.05, 0.01, 0.0, 0.0, 0.0, 0.03, 0.0], atol=1e-15)
    np.testing.assert_allclose(np.asarray(wheel_centre_rise(axle[2:5], -np.ones(3))), [0.0, 0.03, 0.0],
                               atol=1e-15)
