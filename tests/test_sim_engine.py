"""The engine as a second body (``sim.mechanisms.EngineImpact``): invariants of the model
against itself (switching off, momentum, when the engine touches the barrier, gradients).
Its accuracy on data it did not make is tested with the reference world's recordings."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from conftest import PAPER_SPEED
from sim import EngineImpact, make_params, simulate

DURATION = 0.15  # s: the whole impact at 56 km/h and a little rebound


@pytest.fixture(scope="module")
def base():
    return make_params(k_compression=700e3, k_restitution=2e6, restitution=0.2, dz_contact=0.0, rolling_resistance=0.0)


def with_engine(params, **kw):
    return dataclasses.replace(params, mechanisms=(EngineImpact.defaults(**kw),))


@pytest.fixture(scope="module")
def runs(base, a4):
    plain = simulate(base, a4, PAPER_SPEED, DURATION)
    engine = simulate(with_engine(base, engine_mass=250.0, gap=0.3), a4, PAPER_SPEED, DURATION)
    return plain, engine


def test_an_engine_of_no_mass_changes_nothing(base, a4, runs):
    plain, _ = runs
    off = simulate(with_engine(base, engine_mass=0.0, gap=0.3), a4, PAPER_SPEED, DURATION)
    for field in ("x", "vx", "z", "pitch", "force", "crush"):
        np.testing.assert_array_equal(np.asarray(getattr(off, field)), np.asarray(getattr(plain, field)))
    np.testing.assert_array_equal(np.asarray(off.engine_x), np.asarray(plain.x))
    assert float(np.max(np.abs(np.asarray(off.engine_force)))) == 0.0


def test_the_barrier_impulse_is_the_momentum_both_bodies_lose(a4, runs):
    """m_c dv_c + m_e dv_e + the wheels' I dw / r = -impulse: with rolling resistance 0 the
    only other x force is the tyres' grip on the ground, which takes from the car what it
    gives the wheels' spin (``sim.wheels``), so the balance must close to the integration
    error (well under 0.1 %)."""
    _, run = runs
    m, m_e = float(a4.mass), 250.0
    spin = np.asarray(a4.wheel_spin_inertia) / float(a4.wheel_radius)
    wheels = sum(i * (PAPER_SPEED / float(a4.wheel_radius) - np.asarray(w))
                 for i, w in zip(spin, (run.front_wheel_spin, run.rear_wheel_spin)))
    lost = m * PAPER_SPEED - (m - m_e) * np.asarray(run.vx) - m_e * np.asarray(run.engine_vx) + wheels
    impulse = np.asarray(run.contact_impulse)
    k = len(impulse) - 1
    assert lost[k] == pytest.approx(impulse[k], rel=1e-3)
    assert impulse[k] > m * PAPER_SPEED  # it rebounds


def test_the_engine_touches_the_barrier_only_after_the_gap(runs):
    """Before the structure has crushed by the gap the engine carries no barrier force (its
    mounts hold it where it was, within their millimetres of travel); after, it does, and the
    barrier then feels more than the structure alone."""
    _, run = runs
    crush, f_e = np.asarray(run.crush), np.asarray(run.engine_force)
    assert np.all(f_e[crush < 0.3 - 0.01] == 0.0)
    hit = np.flatnonzero(f_e > 0)[0]
    assert 0.3 - 0.01 < crush[hit] < 0.3 + 0.05
    assert np.max(f_e) > 100e3
    np.testing.assert_allclose(np.asarray(run.force) - f_e >= 0, True)


def test_the_engine_takes_its_share_of_the_energy_and_the_barrier_peaks_earlier(runs):
    """The engine's own crush against the barrier and the parts behind it absorb part of the
    kinetic energy, so the structure crushes less than in a one-body car of the same
    structure; the barrier's peak comes with the engine's hit, earlier than the one-body
    car's, and the mounts have let go."""
    plain, run = runs
    assert float(run.crush.max()) < float(plain.crush.max()) - 0.02
    assert float(run.t[np.argmax(run.force)]) < float(plain.t[np.argmax(plain.force)])
    assert float(run.mounts_broken[-1]) == pytest.approx(1.0)


def test_an_engine_whose_mounts_let_go_is_carried_by_its_forward_stop(base, a4):
    """Mounts letting go at once (at 1 N) and an engine out of the barrier's reach: the engine
    runs ahead of the decelerating cabin only until its forward stop (0.05 m), where the
    stop's spring holds it: beyond by at most its load over the stiffness (the engine's mass
    times the cabin's peak deceleration, plus the damper's share, bounded here by a factor 2).
    Without the stop it would run 0.5 a t^2, most of a metre, ahead."""
    m_e = 200.0
    run = simulate(with_engine(base, engine_mass=m_e, gap=2.0, mount_break_force=1.0), a4, PAPER_SPEED, DURATION)
    ahead = np.asarray(run.engine_x) - np.asarray(run.x)
    assert float(run.mounts_broken[-1]) == pytest.approx(1.0)
    assert float(np.max(np.asarray(run.engine_force))) == 0.0  # never at the barrier
    decel = float(np.max(-np.gradient(np.asarray(run.vx), np.asarray(run.t))))
    stop = EngineImpact.defaults(engine_mass=m_e, gap=2.0).stop_forward
    assert 0.05 < float(np.max(ahead)) < stop + 2.0 * m_e * decel / EngineImpact.STOP_STIFFNESS
    assert float(np.max(ahead)) > stop + 0.2 * m_e * decel / EngineImpact.STOP_STIFFNESS  # it does lean on it


def test_gradients_through_the_engine_match_finite_differences(base, a4):
    def peak_impulse(mass, gap):
        run = simulate(with_engine(base, engine_mass=mass, gap=gap), a4, PAPER_SPEED, 0.06)
        return run.contact_impulse[40] + 0.1 * run.engine_x[45]

    grad = jax.grad(peak_impulse, argnums=(0, 1))(250.0, 0.3)
    for i, h in enumerate((1e-2, 1e-5)):  # small steps: the impulse bends sharply with the gap
        args_hi = [250.0, 0.3]
        args_lo = [250.0, 0.3]
        args_hi[i] += h
        args_lo[i] -= h
        fd = (float(peak_impulse(*args_hi)) - float(peak_impulse(*args_lo))) / (2 * h)
        assert float(grad[i]) == pytest.approx(fd, rel=1e-3)


def test_a_batch_of_engines_runs_under_vmap(base, a4):
    masses = jnp.array([150.0, 250.0])

    def peak(mass):
        return jnp.max(simulate(with_engine(base, engine_mass=mass, gap=0.3), a4, PAPER_SPEED, 0.06).engine_force)

    batch = np.asarray(jax.vmap(peak)(masses))
    one = [float(peak(m)) for m in masses]
    np.testing.assert_allclose(batch, one, rtol=1e-9)
    assert batch[1] > batch[0]  # a heavier engine hits harder
