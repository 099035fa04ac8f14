"""The collision model reproduces the paper's numbers (docs/physics.md) and keeps its books, on
the car as the paper's V-SIM models it (``a4_vsim``: wheels without spin inertia)."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from conftest import PAPER_SPEED
from sim import FrontWheelBlock, events_ms, named_params, simulate


def test_identified_compression_and_crush(identified_run):
    ev = events_ms(identified_run)
    assert 63.0 <= ev["compression_end"] <= 69.0
    assert 0.62 <= float(identified_run.crush.max()) <= 0.70


def test_free_car_rebounds_at_restitution_times_impact_speed(a4_vsim):
    # A car whose contact force passes through its CG (dz' = 0) does not pitch: it leaves
    # the barrier at e * v0 (docs/physics.md), less the little its tyres take.
    params = dataclasses.replace(named_params("paper_identified"), dz_contact=jnp.asarray(0.0))
    run = simulate(params, a4_vsim, PAPER_SPEED)
    sep = events_ms(run)["separation"]
    v_rebound = -float(np.interp(sep, np.asarray(run.t) * 1e3, np.asarray(run.vx)))
    assert v_rebound == pytest.approx(0.17 * PAPER_SPEED, rel=0.02)


@pytest.mark.parametrize("run_name", ["identified_run", "default_run"])
def test_energy_returned_is_restitution_squared(run_name, request):
    run = request.getfixturevalue(run_name)
    e = 0.17 if run_name == "identified_run" else float(named_params("vsim_default").restitution)
    work = np.asarray(run.contact_work)
    absorbed = work.max()
    returned = absorbed - work[-1]
    assert float(run.force[-1]) == 0.0, "the car must have left the barrier"
    assert returned / absorbed == pytest.approx(e**2, rel=0.01)
    assert float(run.energy_absorbed[-1]) == pytest.approx(absorbed, rel=0.01)


@pytest.mark.parametrize("run_name", ["identified_run", "default_run"])
def test_contact_impulse_equals_momentum_change(run_name, request, a4_vsim):
    run = request.getfixturevalue(run_name)
    momentum_change = float(a4_vsim.mass) * (PAPER_SPEED - float(run.vx[-1]))
    assert float(run.contact_impulse[-1]) == pytest.approx(momentum_change, rel=0.005)


def test_default_parameters_position_error_as_in_fig6(identified_run, default_run):
    diff = np.abs(np.asarray(default_run.x) - np.asarray(identified_run.x))
    t_ms = np.asarray(identified_run.t) * 1e3
    # docs/physics.md: "peaking at about 0.1 m near 75-85 ms", "dX = 0.099 m near 75 ms". The
    # difference has a flat top (it changes by < 2 % over 75-90 ms), so where exactly its
    # maximum falls says little: the test asks that the maximum be reached, to 1 %, within
    # the paper's window, and the paper's value at 75 ms
    assert diff.max() == pytest.approx(0.1, abs=0.01)
    window = (t_ms >= 75.0) & (t_ms <= 85.0)
    assert diff[window].max() >= 0.99 * diff.max()
    assert diff[75] == pytest.approx(0.099, abs=0.005)


def test_front_wheels_block_and_unblock_with_crush(a4_vsim):
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4_vsim),))
    ev = events_ms(simulate(params, a4_vsim, PAPER_SPEED))
    assert 47.0 - 1.0 <= ev["front_wheel_block"] <= 48.0 + 1.0  # the paper's 47-48 ms, one film frame either side
    assert ev["front_wheel_unblock"] > ev["front_wheel_block"]


@pytest.mark.xfail(strict=True, reason="the model unblocks the front wheels at 129.3 ms, the paper's film at "
                   "117-121 ms (README, 'What it reproduces of the paper'); strict: passing means the model changed")
def test_front_wheels_unblock_when_the_paper_says(a4_vsim):
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4_vsim),))
    ev = events_ms(simulate(params, a4_vsim, PAPER_SPEED))
    assert 117.0 - 1.0 <= ev["front_wheel_unblock"] <= 121.0 + 1.0


def test_blocked_wheel_stops_turning(a4_vsim):
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4_vsim),))
    run = simulate(params, a4_vsim, PAPER_SPEED)
    front = np.asarray(run.front_wheel_angle)
    rear = np.asarray(run.rear_wheel_angle)
    # 50-64 ms: the car still moves forward (~40 mm); the front wheels are blocked from ~47 ms
    assert abs(front[64] - front[50]) < 0.005
    assert rear[64] - rear[50] > 0.05


def test_rear_wheels_lift_and_land_with_low_contact_plane(a4_vsim):
    # Rear lift and landing with dz' = -0.21 m and the default suspension. Our times:
    # lift 38 ms, touchdown 596 ms; the paper's film: 69 ms and 210 ms (see README).
    run = simulate(named_params("paper_identified"), a4_vsim, PAPER_SPEED, duration=1.0)
    ev = events_ms(run)
    assert ev["rear_wheel_lift"] is not None
    assert ev["rear_wheel_touchdown"] is not None and ev["rear_wheel_touchdown"] > ev["rear_wheel_lift"] + 50.0
    airborne = np.asarray(run.rear_airborne)
    assert airborne[int(ev["rear_wheel_lift"]) + 5] and not airborne[-1]


@pytest.mark.xfail(strict=True, reason="the model lifts the rear at 38 ms and lands it at 596 ms, the paper's film "
                   "at 69 and 210 ms: a restoring effect the model leaves out (README); strict: passing means the model changed")
def test_rear_wheels_lift_and_land_when_the_paper_says(a4_vsim):
    ev = events_ms(simulate(named_params("paper_identified"), a4_vsim, PAPER_SPEED, duration=1.0))
    assert ev["rear_wheel_lift"] == pytest.approx(69.0, abs=2.0)
    assert ev["rear_wheel_touchdown"] == pytest.approx(210.0, abs=2.0)


def test_no_rear_lift_with_force_through_cg(default_run):
    assert events_ms(default_run)["rear_wheel_lift"] is None
    assert abs(float(default_run.pitch.max())) < 1e-3
