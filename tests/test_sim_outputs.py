"""The scalar outputs of sim.outputs: the same numbers as sim.events_ms, nan where an event
does not happen, correct interpolation, the physics they should show, and derivatives
(vmap over a batch is exercised by tests/test_sensitivity.py's Monte Carlo)."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from sim import FrontWheelBlock, events_ms, named_params, simulate
from sim.outputs import (
    crossing_time,
    expert_outputs,
    max_crush,
    output_names,
    output_units,
    time_label,
    time_of_max_crush,
    x_at,
)

PAPER_SPEED = 56.3 / 3.6


@pytest.fixture(scope="module")
def blocked_run(a4):
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4),))
    return simulate(params, a4, PAPER_SPEED, duration=0.2)


@pytest.fixture(scope="module")
def outputs_jit():
    return jax.jit(lambda traj: expert_outputs(traj, times=(0.05, 0.1)))


def test_event_times_match_events_ms(blocked_run, outputs_jit):
    out = {k: float(v) for k, v in outputs_jit(blocked_run).items()}
    ev = events_ms(blocked_run)
    assert out["front_wheel_block_time"] * 1e3 == pytest.approx(ev["front_wheel_block"], abs=1e-9)
    assert out["front_wheel_unblock_time"] * 1e3 == pytest.approx(ev["front_wheel_unblock"], abs=1e-9)
    assert out["rear_wheel_lift_time"] * 1e3 == pytest.approx(ev["rear_wheel_lift"], abs=1e-9)
    # events_ms fits its parabola across the kink at the maximum: up to half a sample off
    assert out["time_of_max_crush"] * 1e3 == pytest.approx(ev["compression_end"], abs=0.6)
    # the paper's numbers (docs/physics.md): block near 47 ms, end of compression 66 +/- 3 ms
    assert 44.0 < out["front_wheel_block_time"] * 1e3 < 50.0
    assert 63.0 < out["time_of_max_crush"] * 1e3 < 69.0
    assert np.isnan(out["rear_wheel_touchdown_time"])  # lands at ~600 ms, after the 200 ms span


def test_max_crush_and_its_time_match_a_finely_sampled_run(a4_vsim):
    # the same run sampled every 0.2 ms (every integration step) against the 1 ms samples:
    # the loading-side vertex is unbiased (a parabola across the kink is off by ~0.4 ms)
    import dataclasses as dc

    from sim import Solver
    from sim.simulate import _run_jit

    params = dc.replace(named_params("paper_identified"), k_compression=jnp.asarray(950e3))
    coarse = _run_jit(params, a4_vsim, PAPER_SPEED, 81, Solver())
    fine = _run_jit(params, a4_vsim, PAPER_SPEED, 401, Solver(output_dt=2e-4))
    assert float(time_of_max_crush(coarse)) == pytest.approx(float(time_of_max_crush(fine)), abs=2e-6)
    assert float(max_crush(coarse)) == pytest.approx(float(max_crush(fine)), abs=2e-6)
    crush = np.asarray(coarse.crush)
    assert crush.max() <= float(max_crush(coarse)) < crush.max() + 1e-4
    assert float(max_crush(coarse)) == pytest.approx(0.65, abs=0.01)


def test_events_that_do_not_happen_are_nan(default_run, outputs_jit):
    out = outputs_jit(default_run)
    for name in ("front_wheel_block_time", "front_wheel_unblock_time", "rear_wheel_lift_time",
                 "rear_wheel_touchdown_time"):  # fmt: skip
        assert np.isnan(float(out[name])), name
    assert np.isfinite(float(out["max_crush"]))


def test_rebound_speed_is_restitution_times_impact_speed_with_force_through_cg(default_run, outputs_jit):
    # vsim_default has dz' = 0 and e = 0.2: a free body rebounds at e * v0 (README: within 0.5 %)
    assert float(outputs_jit(default_run)["rebound_speed"]) == pytest.approx(0.2 * PAPER_SPEED, rel=0.01)


def test_crush_still_growing_gives_nan(blocked_run, outputs_jit):
    short = jax.tree_util.tree_map(lambda a: a[:31], blocked_run)  # the first 30 ms
    out = outputs_jit(short)
    assert np.isnan(float(out["max_crush"])) and np.isnan(float(out["time_of_max_crush"]))
    assert np.isnan(float(out["rebound_speed"]))


def test_crossing_time_interpolates_and_differentiates():
    t = jnp.arange(11) * 0.01
    signal = 2.0 * (t - 0.037)  # crosses zero at 37 ms
    assert float(crossing_time(t, signal)) == pytest.approx(0.037, abs=1e-12)
    assert np.isnan(float(crossing_time(t, signal, after=0.05)))
    assert np.isnan(float(crossing_time(t, -signal)))
    # d t_cross / d signal[i]: t_c = t3 - s3 (t4 - t3) / (s4 - s3)
    g = np.asarray(jax.jit(jax.grad(lambda s: crossing_time(t, s)))(signal))
    s3, s4 = float(signal[3]), float(signal[4])
    dt = 0.01
    expect3 = -dt / (s4 - s3) - s3 * dt / (s4 - s3) ** 2
    expect4 = s3 * dt / (s4 - s3) ** 2
    assert g[3] == pytest.approx(expect3, rel=1e-12) and g[4] == pytest.approx(expect4, rel=1e-12)
    assert np.count_nonzero(g) == 2


def test_peak_of_a_sampled_parabola_with_a_kink_is_exact():
    # loading: a parabola peaking at 12.3 ms; after it the curve falls much faster (unloading)
    t = jnp.arange(21) * 1e-3
    up = 0.6 - 50.0 * (t - 0.0123) ** 2
    crush = jnp.where(t <= 0.0123, up, 0.6 - 5000.0 * (t - 0.0123) ** 2)
    crush_max = jnp.maximum.accumulate(crush)

    def traj_of(c):
        return type("T", (), {"t": t, "crush": c, "crush_max": jnp.maximum.accumulate(c)})()

    assert float(time_of_max_crush(traj_of(crush))) == pytest.approx(0.0123, abs=1e-12)
    assert float(max_crush(traj_of(crush))) == pytest.approx(0.6, abs=1e-12)
    assert np.all(np.asarray(crush_max)[13:] == float(crush[12]))
    grad = jax.jit(jax.grad(lambda c: max_crush(traj_of(c))))(crush)
    assert float(jnp.sum(grad)) == pytest.approx(1.0, abs=1e-9)  # shifting the curve up shifts the peak
    assert np.count_nonzero(np.asarray(grad)) == 3  # samples 10, 11, 12: the loading side only


def test_x_at_interpolates(blocked_run):
    t, x = np.asarray(blocked_run.t), np.asarray(blocked_run.x)
    assert float(x_at(blocked_run, 0.05)) == pytest.approx(x[50], abs=1e-12)
    assert float(x_at(blocked_run, 0.0505)) == pytest.approx(0.5 * (x[50] + x[51]), abs=1e-12)
    assert t[50] == pytest.approx(0.05)


def test_names_and_units():
    names = output_names((0.05, 0.1))
    assert names[:3] == ["max_crush", "time_of_max_crush", "rebound_speed"]
    assert time_label(0.05) == "x_at_50ms" and time_label(0.0125) == "x_at_12p5ms"
    units = output_units((0.05,))
    assert units["x_at_50ms"] == "m" and units["rebound_speed"] == "m/s" and units["rear_wheel_lift_time"] == "s"


def test_the_reported_motion_axle_loads_and_lifts_agree_with_each_other(a4, blocked_run):
    """The run's outputs against each other and the vehicle file: vz and pitch_rate are the
    time derivatives of z and pitch (central differences, to 1 % of their range; measured
    0.005 % and 0.34 %); at first contact the axles carry m g b / L and m g a / L (measured
    0.03 % off: the ramp smoothing); where the contact margin exceeds the
    20 N smoothing many times, the normal force is the margin; the front axle never lifts,
    the rear does (paper parameters), and carries nothing while it is more than 1 mm up."""
    run, dt = blocked_run, 1e-3
    for pos, vel in (("z", "vz"), ("pitch", "pitch_rate")):
        p, v = np.asarray(getattr(run, pos)), np.asarray(getattr(run, vel))
        central = (p[2:] - p[:-2]) / (2 * dt)
        assert np.abs(central - v[1:-1]).max() < 0.01 * np.ptp(v), vel
    m, a, b = float(a4.mass), float(a4.cg_to_front_axle), float(a4.cg_to_rear_axle)
    w = m * 9.80665
    assert float(run.front_normal[0]) == pytest.approx(w * b / (a + b), rel=2e-3)
    assert float(run.rear_normal[0]) == pytest.approx(w * a / (a + b), rel=2e-3)
    for end in ("front", "rear"):
        margin, normal = np.asarray(getattr(run, f"{end}_margin")), np.asarray(getattr(run, f"{end}_normal"))
        big = margin > 500.0
        assert big.any() and normal[big] == pytest.approx(margin[big], rel=1e-6, abs=1e-3)
    front_lift, rear_lift = np.asarray(run.front_lift), np.asarray(run.rear_lift)
    assert not np.any(front_lift) and rear_lift.max() > 0.005
    assert np.all(np.asarray(run.rear_normal)[rear_lift > 0.001] < 0.01 * w * a / (a + b))
