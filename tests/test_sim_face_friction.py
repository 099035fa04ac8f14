"""Friction on the barrier face (``Params.mu_face``, ``sim.contact.face_friction_impulse``):
the crushed front pressed into the face slides up or down it only as far as friction lets
it; at 0 the model is V-SIM's."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sim import make_params, simulate
from sim.contact import face_friction_impulse

SPEED = 56.3 / 3.6
DURATION = 0.12  # s: the compression and the start of the rebound


def _params(mu_face):
    return make_params(k_compression=970e3, k_restitution=600e3, restitution=0.17, dz_contact=-0.21, mu_face=mu_face)


def _contact_point_vz(traj, params, vehicle):
    """m/s, the contact point's vertical speed (l_f ahead of the CG, dz' above it)."""
    l_f = float(vehicle.cg_to_front_axle + vehicle.front_overhang)
    th, dz = np.asarray(traj.pitch), float(params.dz_contact)
    return np.asarray(traj.vz) - (l_f * np.cos(th) + dz * np.sin(th)) * np.asarray(traj.pitch_rate)


def test_no_friction_is_the_default_and_changes_nothing(a4):
    base = make_params(k_compression=970e3, k_restitution=600e3, restitution=0.17, dz_contact=-0.21)
    assert float(base.mu_face) == 0.0
    a = simulate(base, a4, SPEED, duration=DURATION)
    b = simulate(_params(0.0), a4, SPEED, duration=DURATION)
    np.testing.assert_array_equal(np.asarray(a.pitch), np.asarray(b.pitch))


def test_a_front_pressed_into_the_face_sticks_to_it(a4):
    # without friction the force below the CG pitches the nose down the face at metres a
    # second; with a coefficient of 0.3 the point holds while the force presses it
    free, held = (simulate(_params(mu), a4, SPEED, duration=DURATION) for mu in (0.0, 0.3))
    loaded = np.asarray(held.force) > 0.2 * float(np.max(np.asarray(held.force)))
    slide_free = np.max(np.abs(_contact_point_vz(free, _params(0.0), a4)[loaded]))
    slide_held = np.max(np.abs(_contact_point_vz(held, _params(0.3), a4)[loaded]))
    assert slide_free > 0.5
    assert slide_held < 0.05 * slide_free
    # holding the nose keeps the car from pitching as far, and the friction does not stop it
    assert float(np.max(np.asarray(held.pitch))) < 0.6 * float(np.max(np.asarray(free.pitch)))
    assert float(np.max(np.asarray(held.crush))) == pytest.approx(float(np.max(np.asarray(free.crush))), rel=0.03)


def test_the_impulse_stops_a_slow_point_and_is_capped_against_a_fast_one():
    inv_mass = jnp.array([1 / 1500.0, 1 / 1500.0, 1 / 2500.0])
    jac_z = jnp.array([0.0, 1.0, -2.5])
    m_eff = 1.0 / float(jac_z @ (inv_mass * jac_z))
    force, mu, dt = 2e5, 0.3, 2e-4
    cap = mu * force * dt
    slow = jnp.array([15.0, 0.0, 1e-3])  # point moving down at 2.5 mm/s
    p = float(face_friction_impulse(slow, inv_mass, jac_z, force, mu, dt))
    after = slow + inv_mass * jac_z * p
    # stopped, but for tanh's cubic term: (m_eff v / P_max)^2 / 3 of it, here 1.4e-3
    assert abs(float(jac_z @ after)) < 3e-3 * abs(float(jac_z @ slow))
    assert p > 0  # upward, against the downward slide
    fast = jnp.array([15.0, 0.0, 4.0])  # 10 m/s down the face
    p = float(face_friction_impulse(fast, inv_mass, jac_z, force, mu, dt))
    assert p == pytest.approx(cap, rel=1e-9)  # Coulomb's limit, mu F dt
    assert m_eff * 10.0 > 10 * cap  # (it would have taken far more to stop it)
    assert float(face_friction_impulse(fast, inv_mass, jac_z, 0.0, mu, dt)) == 0.0  # no force, no friction


def test_the_motion_is_differentiable_in_the_face_friction(a4):
    # a nose that slides (a small coefficient) is where the motion depends on it
    def pitch_at_end(mu):
        p = dataclasses.replace(_params(0.0), mu_face=mu)
        return simulate(p, a4, SPEED, duration=0.06).pitch[-1]

    grad = float(jax.grad(pitch_at_end)(jnp.asarray(0.01)))
    h = 1e-5
    fd = (float(pitch_at_end(0.01 + h)) - float(pitch_at_end(0.01 - h))) / (2 * h)
    assert grad < 0  # more friction, less nose-down pitch
    assert grad == pytest.approx(fd, rel=1e-4)
