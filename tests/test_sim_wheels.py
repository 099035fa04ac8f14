"""The wheels' spin (``sim.wheels``) against cases solved on paper: a wheel the tyre keeps
rolling adds I / r^2 to the mass the barrier must stop; one the tyre cannot hold slides, its
spin's momentum passing to the car only as far as mu N allows; and what the car and wheels
lose, the barrier took."""

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sim import named_params, simulate
from sim.outputs import expert_outputs
from sim.wheels import axle_jacobians

V0 = 56.0 / 3.6


def _point_mass(mu_adhesion):
    """The paper's car with its force through the CG (no pitch) and no rolling resistance."""
    return dataclasses.replace(named_params("paper_identified"), dz_contact=0.0, rolling_resistance=0.0,
                               mu_adhesion=mu_adhesion)


@pytest.fixture(scope="module")
def gripping(a4):
    return simulate(_point_mass(2.0), a4, V0, 0.12)


def test_rolling_wheels_add_their_spin_inertia_to_the_mass(a4, gripping):
    """With grip to spare (mu 2: the wheels need about 8 kN an axle at the peak, the tyres
    hold 16), the wheels roll throughout and the car crushes as a point mass of
    m + sum(I) / r^2: d_max = v0 sqrt(m_eff / (k A)), about 1.3 % deeper than without them."""
    m_eff = float(a4.mass) + float(jnp.sum(a4.wheel_spin_inertia)) / float(a4.wheel_radius) ** 2
    k_a = float(_point_mass(2.0).k_compression) * float(a4.contact_area)
    d_max = float(expert_outputs(gripping)["max_crush"])
    assert d_max == pytest.approx(V0 * math.sqrt(m_eff / k_a), rel=2e-3)
    assert d_max > 1.01 * V0 * math.sqrt(float(a4.mass) / k_a)
    # and they roll: spin times radius is the axle's speed (the grip, below the CG, pitches the car a little)
    q = np.stack([np.asarray(gripping.x), np.asarray(gripping.z), np.asarray(gripping.pitch)], axis=-1)
    v = np.stack([np.asarray(gripping.vx), np.asarray(gripping.vz), np.asarray(gripping.pitch_rate)], axis=-1)
    axle_speed = np.einsum("nij,nj->ni", np.asarray(jax.vmap(lambda qq: axle_jacobians(qq, a4))(jnp.asarray(q))), v)
    for i, spin in enumerate((gripping.front_wheel_spin, gripping.rear_wheel_spin)):
        np.testing.assert_allclose(np.asarray(spin) * float(a4.wheel_radius), axle_speed[:, i], atol=0.1)


def test_what_the_car_and_its_wheels_lose_the_barrier_took(a4, gripping):
    """m dv + sum(I dw) / r = -impulse to the integration error."""
    r = float(a4.wheel_radius)
    wheels = sum(float(i) * (V0 / r - float(np.asarray(w)[-1])) / r
                 for i, w in zip(a4.wheel_spin_inertia, (gripping.front_wheel_spin, gripping.rear_wheel_spin)))
    lost = float(a4.mass) * (V0 - float(np.asarray(gripping.vx)[-1])) + wheels
    assert lost == pytest.approx(float(np.asarray(gripping.contact_impulse)[-1]), rel=1e-3)
    assert wheels > 0.01 * float(a4.mass) * V0  # the wheels gave the car a share worth counting


def test_a_tyre_that_cannot_hold_its_wheel_lets_it_spin_on(a4):
    """A little grip (mu 0.05) cannot stop the wheels with the car: they spin on, slowed at
    mu N r / I, while the car stops as the point mass it nearly is."""
    traj = simulate(_point_mass(0.05), a4, V0, 0.12)
    spin = np.asarray(traj.front_wheel_spin)
    t = np.asarray(traj.t)
    normal = np.asarray(traj.front_normal)
    slowed = V0 / float(a4.wheel_radius) - np.cumsum(0.05 * normal * float(a4.wheel_radius)
                                                     / float(a4.wheel_spin_inertia[0])) * float(t[1] - t[0])
    assert spin[-1] > 0.5 * V0 / float(a4.wheel_radius)  # still spinning forward
    np.testing.assert_allclose(spin[1:], slowed[:-1], rtol=0.02)
    assert float(np.asarray(traj.vx)[-1]) < 0.0  # while the car rebounds


def test_a_heavier_wheel_set_is_a_heavier_car(a4, gripping):
    """The vehicle file's ``wheel_spin_inertia`` is what the model uses: twice the inertia,
    twice the added mass (d_max grows with sqrt(m_eff))."""
    heavy = eqx.tree_at(lambda v: v.wheel_spin_inertia, a4, 2.0 * a4.wheel_spin_inertia)
    d = [float(expert_outputs(run)["max_crush"]) for run in (gripping, simulate(_point_mass(2.0), heavy, V0, 0.12))]
    added = float(jnp.sum(a4.wheel_spin_inertia)) / float(a4.wheel_radius) ** 2
    m = float(a4.mass)
    assert d[1] / d[0] == pytest.approx(math.sqrt((m + 2 * added) / (m + added)), rel=5e-4)
