"""The barrier-force check: summed load cells of NHTSA test 10146 against the model's force."""

import csv
from pathlib import Path

import numpy as np
import pytest

from helpers import cfc_scipy, last_above, raw_10146, raw_ev5_channel
from identify.errors import UserError
from identify.report.force_check import (_dtw_path, check_forces, compare_forces, end_of_contact,
                                  engine_mass_matching_the_barrier, force_check_document, iso18571,
                                  measured_force, momentum_check, rigid_body_force, two_body_force)
from identify.recordings import Channel, SensorTest, contact_time, measurement_from_test, read_isomme, read_nhtsa

DATA = Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146"


@pytest.fixture(scope="module")
def force(test10146):
    return measured_force(test10146)


@pytest.fixture(scope="module")
def raw():
    """The independent reference: 10146's raw channel files processed with numpy and scipy
    (tests/helpers.py, ``Raw10146``), on the recording's clock (NHTSA's t = 0)."""
    return raw_10146()


@pytest.fixture(scope="module")
def contact_s(test10146):
    """The program's first contact on the recording's clock (s): its force-check times count
    from it (-0.03 ms here; within 1 ms of NHTSA's contact switch, tests/test_nhtsa.py)."""
    return contact_time(test10146)[0]


@pytest.fixture(scope="module")
def camry_run(test10146):
    """The Camry at the test's speed with a hand-chosen parameter set (not fitted)."""
    from sim import load_vehicle, make_params, simulate

    p = make_params(k_compression=1.1e6, k_restitution=9e5, restitution=0.15, dz_contact=-0.1)
    return simulate(p, load_vehicle("toyota_camry_2018"), speed=test10146.impact_speed_mps, duration=0.2)


def test_measured_force_of_10146(force, raw, contact_s):
    assert force.cfc == 60 and force.n_cells == 1
    # Reference: channel 900 (the raw sum of the 174 cells) less its pre-impact mean, sign
    # turned, filtered with scipy's J211 CFC 60: peak 678.03 kN at 35.0 ms, contact ends at
    # 109.1 ms. The program's curve is that curve: 2e-7 N apart away from the record's ends
    # (within 20 ms of the ends the two filters' end paddings differ, by up to 745 N).
    assert np.allclose(force.t + contact_s, raw.t, rtol=0, atol=1e-9)
    inner = (raw.t >= -0.03) & (raw.t <= 0.28)
    np.testing.assert_allclose(force.force[inner], raw.force60[inner], rtol=0, atol=1.0)
    i = np.argmax(force.force)
    assert force.force[i] == pytest.approx(raw.peak_N, rel=1e-6)
    assert force.t[i] + contact_s == pytest.approx(raw.peak_s, abs=1e-6)
    pos = force.t >= 0
    assert end_of_contact(force.t[pos], force.force[pos]) + contact_s == pytest.approx(raw.contact_end_s, abs=1e-6)
    # offset-free before contact
    assert abs(np.mean(force.force[force.t < -0.005])) < 50.0


def test_impulse_matches_momentum_change(force, motion, test10146, raw, contact_s):
    check = momentum_check(force, test10146.mass_kg, motion.t, motion.channels["vx_mps"])
    # Reference, from the raw files (tests/helpers.py): the trapezoid of the unfiltered
    # summed force from NHTSA's t = 0 to the end of contact (109.1 ms), 32801.1 N s; the
    # header's 1719 kg times the change of velocity of the raw crossmember mean integrated
    # from 57.09 km/h, 18.4909 m/s; impulse / momentum change - 1 = +0.031939. The program
    # (CFC 60 force, CFC 180 accelerations) gives 32800.5 N s and +0.031964. Tolerances 5e-4
    # (relative, and absolute on the ratio): the filters account for the 2e-5 and 3e-5
    # measured; ending the pre-impact window at 0 instead of -5 ms would move the ratio by
    # 9.6e-4 (how well the recording knows it; see Raw10146).
    t_end = raw.contact_end_s
    assert check["t_end_ms"] + contact_s * 1e3 == pytest.approx(t_end * 1e3, abs=0.1)
    assert check["impulse_Ns"] == pytest.approx(raw.impulse(0.0, t_end), rel=5e-4)
    assert check["momentum_change_Ns"] == pytest.approx(raw.mass_kg * raw.delta_v(t_end), rel=5e-4)
    assert check["error"] == pytest.approx(raw.momentum_error(), abs=5e-4)


@pytest.mark.xfail(strict=True, reason="the recording's own momentum balance is +3.2 %: the impulse of the "
                   "174 load cells is 3.2 % above 1719 kg times the crossmembers' change of velocity, "
                   "computed from the raw files (test_impulse_matches_momentum_change)")
def test_momentum_balance_within_3_percent(force, motion, test10146):
    check = momentum_check(force, test10146.mass_kg, motion.t, motion.channels["vx_mps"])
    assert abs(check["error"]) < 0.03


def test_identical_curves_score_one(force):
    c = compare_forces(force.t, force.force, force.t, force.force)
    assert c.peak_error == 0.0 and c.impulse_error == 0.0
    r = c.iso18571
    assert (r.corridor, r.phase, r.magnitude, r.slope, r.overall) == (1.0, 1.0, 1.0, 1.0, 1.0)


def test_shifted_curve_loses_phase_and_corridor(force):
    c = compare_forces(force.t, force.force, force.t + 0.005, force.force)
    r = c.iso18571
    assert r.shift_s == pytest.approx(0.005, abs=2e-4)
    assert r.phase < 1.0 and r.corridor < 1.0 and r.overall < 1.0
    assert r.magnitude > 0.99 and r.slope > 0.95  # once shifted back, the curves are one
    assert c.peak_time_predicted_ms - c.peak_time_measured_ms == pytest.approx(5.0, abs=0.2)


def test_scaled_curve_loses_magnitude(force):
    c = compare_forces(force.t, force.force, force.t, 0.8 * force.force)
    r = c.iso18571
    assert c.peak_error == pytest.approx(-0.2) and c.impulse_error == pytest.approx(-0.2)
    assert r.phase == 1.0 and r.shift_s == 0.0
    assert r.magnitude < 0.95 and r.corridor < 0.9 and r.slope == pytest.approx(0.9, abs=0.01)
    worse = compare_forces(force.t, force.force, force.t, 0.6 * force.force).iso18571
    assert worse.overall < r.overall < 1.0


def test_iso_scores_by_hand():
    t = np.arange(0, 0.1, 1e-4)
    ref = np.sin(np.pi * t / 0.1)
    # a constant offset of 0.1 (inside the outer corridor 0.5, outside the inner 0.05)
    r = iso18571(ref, ref + 0.1)
    assert r.corridor == pytest.approx(((0.5 - 0.1) / (0.5 - 0.05)) ** 2)
    assert r.slope == 1.0 or r.slope == pytest.approx(1.0)
    assert r.phase == 1.0
    assert r.overall == pytest.approx(0.4 * r.corridor + 0.2 * r.phase + 0.2 * r.magnitude + 0.2 * r.slope)
    with pytest.raises(UserError, match="zero everywhere"):
        iso18571(np.zeros(100), ref[:100])


def _dtw_cost_brute(x, y, band):
    n = len(x)
    D = np.full((n + 1, n + 1), np.inf)
    D[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(max(1, i - band), min(n, i + band) + 1):
            D[i, j] = (x[i - 1] - y[j - 1]) ** 2 + min(D[i - 1, j], D[i, j - 1], D[i - 1, j - 1])
    return D[n, n]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_banded_dtw_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.standard_normal(60))
    y = np.cumsum(rng.standard_normal(60))
    for band in (3, 10, 59):
        pi, pj = _dtw_path(x, y, band)
        assert pi[0] == pj[0] == 0 and pi[-1] == pj[-1] == 59
        steps = np.stack([np.diff(pi), np.diff(pj)], axis=1)
        assert set(map(tuple, steps)) <= {(0, 1), (1, 0), (1, 1)}
        assert np.max(np.abs(pi - pj)) <= band
        assert np.sum((x[pi] - y[pj]) ** 2) == pytest.approx(_dtw_cost_brute(x, y, band))


def test_model_prediction_against_the_barrier(force, camry_run):
    tp, fp = np.asarray(camry_run.t), np.asarray(camry_run.force)
    c = compare_forces(force.t, force.force, tp, fp)
    r = c.iso18571
    assert 0.0 < r.overall < 0.9  # a linear spring does not have the test's early peak
    assert c.peak_time_measured_ms < 40.0 < c.peak_time_predicted_ms
    # the model's impulse is its own momentum change (a check of compare_forces' integral)
    vx = np.asarray(camry_run.vx)
    i_end = np.searchsorted(tp, c.window_ms[1] / 1e3)
    assert c.impulse_predicted_Ns == pytest.approx(1719.0 * (vx[0] - vx[i_end]), rel=0.03)
    # the model against itself scores 1, shifted by 5 ms it scores lower
    same = compare_forces(tp, fp, tp, fp).iso18571
    late = compare_forces(tp, fp, tp + 0.005, fp).iso18571
    assert same.overall == pytest.approx(1.0) and late.overall < same.overall


def test_check_forces_writes_csv_and_plots(force, camry_run, motion, tmp_path):
    c = check_forces(force, camry_run, motion, tmp_path, title="10146, hand-chosen parameters")
    with open(tmp_path / "forces.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t_ms", "measured_N", "predicted_N"]
    assert len(rows) == 1 + min(len(camry_run.t), 300)
    data = np.array(rows[1:], dtype=float)
    assert data[0, 0] == 0.0 and data[1, 0] == pytest.approx(1.0)
    k = int(np.argmax(data[:, 1]))
    assert data[k, 1] == pytest.approx(c.peak_measured_N, rel=0.01)
    # The prediction goes through the load cells' CFC 60 too (forces compared at the same class).
    from identify.recordings.motion import filter_cfc

    predicted = filter_cfc(np.asarray(camry_run.force), 1000.0, 60)
    np.testing.assert_allclose(data[:, 2], predicted[: len(data)], atol=0.06)
    assert np.max(np.abs(predicted - np.asarray(camry_run.force))) > 1e3  # the filter did something
    # a model whose contact comes 2 ms after the measurement's is drawn 2 ms later
    check_forces(force, camry_run, motion, tmp_path, contact_time_s=0.002)
    with open(tmp_path / "forces.csv") as f:
        later = np.array(list(csv.reader(f))[1:], dtype=float)
    assert later[2, 2] == pytest.approx(0.0, abs=0.06)
    assert later[12, 2] == pytest.approx(float(camry_run.force[10]), rel=1e-6)
    for name in ("force_time.png", "force_crush.png"):
        assert (tmp_path / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert set(c.to_dict()["iso18571"]) == {"corridor", "phase", "magnitude", "slope", "overall", "shift_s"}


def test_no_barrier_channels(tmp_path):
    t = read_nhtsa(DATA / "v10146.EV5", barrier=False)
    with pytest.raises(UserError, match="no barrier load cells"):
        measured_force(t)


def test_force_check_document_is_json_ready(test10146, motion, camry_run, tmp_path, raw):
    import json

    doc = force_check_document(test10146, motion, camry_run, tmp_path)
    back = json.loads(json.dumps(doc))
    assert back["load_cells"] == 1 and back["cfc"] == 60
    # the raw files' momentum balance (test_impulse_matches_momentum_change)
    assert back["momentum_check"]["error"] == pytest.approx(raw.momentum_error(), abs=5e-4)
    assert 0 < back["iso18571"]["overall"] < 1
    assert (tmp_path / "forces.csv").exists()


def test_the_camry_is_not_rigid(test10146, motion, camry_run, tmp_path, raw, contact_s):
    """Test mass x the crossmembers' deceleration against the load cells: the right impulse
    and peak size, but the engine's hit at 30-35 ms reaches the barrier, not the cabin."""
    doc = force_check_document(test10146, motion, camry_run, tmp_path)
    rb = doc["rigid_body"]
    c_ms = contact_s * 1e3  # the program's times count from its contact: add it back
    # Reference: the header's 1719 kg times the raw crossmember mean deceleration, both it and
    # the barrier sum filtered with scipy's CFC 60, on the recording's clock.
    rigid = -raw.mass_kg * cfc_scipy(raw.mean_accel, raw.fs, 60)
    pos = raw.t >= 0
    # compare_forces' window: contact to 10 ms after the later end of contact (the rigid
    # body's, 112.7 ms): 122.7 ms
    t1 = max(raw.contact_end_s, last_above(raw.t[pos], rigid[pos])) + 0.010
    assert rb["window_ms"][1] + c_ms == pytest.approx(t1 * 1e3, abs=0.1)
    # Impulse error: 1719 kg x the raw change of velocity over the window / the raw impulse
    # over it - 1 = -0.03070 (the momentum balance over this longer window, mirrored); the
    # program -0.03049 (its CFC 60 curves spread the onset of the force before t = 0: 2e-4).
    assert rb["impulse_error"] == pytest.approx(raw.mass_kg * raw.delta_v(t1) / raw.impulse(0.0, t1) - 1.0, abs=5e-4)
    # Peaks: 702.97 kN at 64.2 ms against 678.03 kN at 35.0 ms, +3.678 %; the program +3.682 %
    # (the same curves interpolated on its 10 kHz grid, shifted by its contact, -0.03 ms).
    k = int(np.argmax(rigid))
    assert rb["peak_error"] == pytest.approx(rigid[k] / raw.peak_N - 1.0, abs=5e-4)
    assert rb["peak_time_predicted_ms"] + c_ms == pytest.approx(raw.t[k] * 1e3, abs=0.1)
    assert rb["peak_time_measured_ms"] + c_ms == pytest.approx(raw.peak_s * 1e3, abs=0.1)
    # The physical argument: the barrier's peak is the engine block's hit (curve 095, top of
    # engine, CFC 60: its peak deceleration at 29 ms), which the cabin feels only later, so a
    # rigid car moving as the cabin does peaks more than 10 ms after the barrier (64.2 - 35.0 ms).
    _, engine = raw_ev5_channel(95)
    t_engine = raw.t[int(np.argmin(cfc_scipy(engine - engine[raw.t <= -0.005].mean(), raw.fs, 60)))]
    assert abs(raw.peak_s - t_engine) < 0.010 < raw.t[k] - t_engine
    assert rb["peak_time_predicted_ms"] - rb["peak_time_measured_ms"] > 10.0
    # ISO 18571: the scores of the reference curves over the window (the rating itself is
    # checked against objective_rating_metrics in test_iso18571_agrees_with_a_reference_
    # implementation; measured differences up to 1.4e-4, from the program's shifted grid) ...
    w = (raw.t >= -1e-9) & (raw.t <= t1 + 1e-9)
    ref = iso18571(raw.force60[w], rigid[w], 1.0 / raw.fs)
    for key in ("corridor", "phase", "magnitude", "slope", "overall"):
        assert rb["iso18571"][key] == pytest.approx(getattr(ref, key), abs=2e-3), key
    # ... below ISO/TS 18571's class "good" (R > 0.80): no good prediction of the barrier force
    assert rb["iso18571"]["overall"] < 0.80
    t, f = rigid_body_force(test10146)
    force = measured_force(test10146)
    at = np.interp([0.030, 0.035], t, f)
    barrier = np.interp([0.030, 0.035], force.t, force.force)
    assert np.all(at < 0.5 * barrier)
    # each accelerometer alone: its raw file's momentum balance (+2.30 to +4.01 %), to the
    # tolerance of test_impulse_matches_momentum_change (measured differences up to 5e-5)
    each = doc["momentum_check"]["per_accelerometer"]
    assert set(each) == {"93", "94", "99", "100"}
    for code, error in each.items():
        assert error == pytest.approx(raw.momentum_error(raw.accel[code]), abs=5e-4), code


def _rigid_test(mass=1500.0, peak=4e5, mass_in_header=True):
    """A synthetic sensor test of a rigid car: the barrier force is exactly mass x deceleration
    (sin^2 pulse over 90 ms), two accelerometers, one reading 2 % high."""
    t = np.round(np.arange(-0.05, 0.3, 1e-4), 10)
    pulse = np.where((t >= 0) & (t <= 0.09), peak * np.sin(np.pi * np.clip(t, 0, 0.09) / 0.09) ** 2, 0.0)
    accel = -pulse / mass
    vehicle = (Channel("1", "left", t, accel, "acceleration"), Channel("2", "right", t, 1.02 * accel, "acceleration"))
    barrier = (Channel("9", "cells", t, pulse, "force"),)
    return SensorTest(source="synthetic", impact_speed_mps=15.0, mass_kg=mass if mass_in_header else None,
                      vehicle=vehicle, barrier=barrier)


def test_rigid_body_force_of_a_rigid_car_is_the_barrier_force(tmp_path):
    test = _rigid_test()
    force = measured_force(test)
    t, f = rigid_body_force(test)
    c = compare_forces(force.t, force.force, t, f)
    # the mean of the two accelerometers reads 1 % high
    assert c.impulse_error == pytest.approx(0.01, abs=2e-3)
    assert c.peak_error == pytest.approx(0.01, abs=2e-3)
    assert c.iso18571.overall > 0.97
    motion = measurement_from_test(test)
    from sim import load_vehicle, make_params, simulate

    run = simulate(make_params(k_compression=1e6, k_restitution=9e5, restitution=0.1, dz_contact=0.0),
                   load_vehicle("toyota_camry_2018"), speed=15.0, duration=0.2)
    doc = force_check_document(test, motion, run, tmp_path)
    each = doc["momentum_check"]["per_accelerometer"]
    assert each["1"] == pytest.approx(0.0, abs=2e-3) and each["2"] == pytest.approx(1 / 1.02 - 1, abs=2e-3)
    assert doc["rigid_body"]["iso18571"]["overall"] > 0.97


def _two_body_test(mass=1500.0, engine_kg=250.0, engine_ends_s=None):
    """A synthetic sensor test of a car of two rigid bodies: the cabin decelerates over 90 ms;
    the engine (``engine_kg`` of ``mass``) is stopped hard between 10 and 40 ms and catches up
    with the cabin by 70 ms. The barrier force is exactly -(m - m_e) a_cabin - m_e a_engine;
    two cabin and two engine accelerometers, without noise; the engine's may end early."""
    t = np.round(np.arange(-0.05, 0.3, 1e-4), 10)
    cabin = np.where((t >= 0) & (t <= 0.09), -150.0 * np.sin(np.pi * np.clip(t, 0, 0.09) / 0.09) ** 2, 0.0)
    relative = np.where((t >= 0.01) & (t <= 0.07), -400.0 * np.sin(2 * np.pi * np.clip(t - 0.01, 0, 0.06) / 0.06), 0.0)
    engine = cabin + relative
    barrier = -(mass - engine_kg) * cabin - engine_kg * engine
    te = t if engine_ends_s is None else t[t <= engine_ends_s]
    return SensorTest(
        source="synthetic", impact_speed_mps=15.0, mass_kg=mass,
        vehicle=(Channel("1", "left", t, cabin, "acceleration"), Channel("2", "right", t, cabin, "acceleration")),
        barrier=(Channel("9", "cells", t, barrier, "force"),),
        engine=(Channel("5", "engine top", te, engine[: len(te)], "acceleration"),))


def test_two_body_force_of_a_car_of_two_bodies_is_the_barrier_force(tmp_path):
    """The engine's mass is found back from the load cells, the two-body curve at it is the
    barrier force (up to the CFC 60 filtering both get alike), and an engine mass of 0 is the
    rigid car."""
    test = _two_body_test()
    t_contact = contact_time(test)[0]
    force = measured_force(test, t_contact)
    c = compare_forces(force.t, force.force, *two_body_force(test, 250.0, t_contact))
    assert c.nrmse < 1e-3 and abs(c.impulse_error) < 1e-3
    wrong = compare_forces(force.t, force.force, *two_body_force(test, 150.0, t_contact))
    assert wrong.nrmse > 10 * c.nrmse
    t0, rigid0 = two_body_force(test, 0.0, t_contact)
    t1, rigid1 = rigid_body_force(test, t_contact)
    np.testing.assert_allclose(np.interp(t1, t0, rigid0), rigid1, rtol=0, atol=1e-6 * np.max(rigid1))
    best, best_nrmse = engine_mass_matching_the_barrier(force, test, t_contact, (0.0, 0.1))
    assert best == pytest.approx(250.0, rel=1e-3) and best_nrmse < 1e-3
    run = _camry_at(15.0)
    doc = force_check_document(test, measurement_from_test(test), run, tmp_path, engine_mass=(200.0, "a guess"))
    two = doc["two_body"]
    assert two["engine_mass_kg"] == 200.0 and two["engine_mass_source"] == "a guess"
    assert two["window_ms"] == doc["window_ms"]  # scored where the fitted model is
    assert two["best_engine_mass_kg"] == pytest.approx(250.0, rel=1e-3)
    assert two["best_nrmse"] < 1e-3 < two["nrmse"]


def test_no_two_body_reference_when_the_engine_channel_ends_before_the_contact(tmp_path):
    test = _two_body_test(engine_ends_s=0.05)
    motion, run = measurement_from_test(test), _camry_at(15.0)
    doc = force_check_document(test, motion, run, tmp_path, engine_mass=(250.0, "a guess"))
    assert doc["two_body"] == {"not_computed": "the engine channels end 50.0 ms after contact, before the"
                                               f" comparison's {doc['window_ms'][1]:.1f} ms"}
    assert "two_body" not in force_check_document(_two_body_test(), motion, run, tmp_path)  # no engine mass given


def _camry_at(speed):
    from sim import load_vehicle, make_params, simulate

    return simulate(make_params(k_compression=1e6, k_restitution=9e5, restitution=0.1, dz_contact=0.0),
                    load_vehicle("toyota_camry_2018"), speed=speed, duration=0.2)


@pytest.mark.parametrize("seed", [301, 304])
def test_the_reference_worlds_load_cells_are_its_two_bodies_moving_as_measured(seed, tmp_path):
    """On the reference world (its own car model: an engine on mounts, stops, pitch, tyres;
    its accelerometers with 0.3 g noise and offsets), the two-body curve at the world's true
    engine mass is its barrier force to 0.7-1.0 % of the peak (measured, seeds 301-304; the
    rigid car: 7-13 %), and the mass that matches the load cells is the true one to 0.2-0.7 %
    (the rest: the tyres' forces and the body's pitch, which neither curve has). Asserted:
    2 % and 2 %, and a rigid car at least 5 times worse."""
    from synth.world import make_world, write_world

    truth = write_world(make_world(seed, "engine_impact", None, "isomme"), tmp_path / "world")
    test = read_isomme(tmp_path / "world" / truth["recording"])
    t_contact = contact_time(test)[0]
    force = measured_force(test, t_contact)
    engine_kg = truth["hidden"]["engine_mass"]
    two = compare_forces(force.t, force.force, *two_body_force(test, engine_kg, t_contact))
    rigid = compare_forces(force.t, force.force, *rigid_body_force(test, t_contact))
    assert two.nrmse < 0.02 and rigid.nrmse > 5 * two.nrmse
    best, _ = engine_mass_matching_the_barrier(force, test, t_contact, (0.0, two.window_ms[1] / 1e3))
    assert best == pytest.approx(engine_kg, rel=0.02)


def test_no_two_body_model_fitting_10146s_motion_comes_nearer_its_load_cells(test10146, motion, camry_run, tmp_path):
    """The floor the report states, checked by brute force on the real test: over engine masses
    0-800 kg every 20 kg, no two-body curve scores a smaller RMS error over the same window
    than the least-squares mass does."""
    doc = force_check_document(test10146, motion, camry_run, tmp_path, engine_mass=(230.0, "the vehicle file's"))
    two = doc["two_body"]
    t_contact = contact_time(test10146)[0]
    force = measured_force(test10146, t_contact)
    window = tuple(w / 1e3 for w in two["window_ms"])
    scan = [compare_forces(force.t, force.force, *two_body_force(test10146, m, t_contact), window_s=window).nrmse
            for m in range(0, 801, 20)]
    assert two["best_nrmse"] <= min(scan) + 1e-9
    at_230 = compare_forces(force.t, force.force, *two_body_force(test10146, 230.0, t_contact), window_s=window)
    assert two["nrmse"] == pytest.approx(at_230.nrmse, rel=1e-12)
    assert two["nrmse"] < doc["rigid_body"]["nrmse"]


def test_rigid_body_force_needs_the_test_mass():
    with pytest.raises(UserError, match="no test mass"):
        rigid_body_force(_rigid_test(mass_in_header=False))


def _pulse(t):
    """A crash-like pulse: 100 ms, 600 kN peak, with a 50 Hz ripple."""
    tc = np.clip(t, 0.0, 0.1)
    return np.where(t < 0.1, np.sin(np.pi * tc / 0.1) ** 2 * (1 + 0.3 * np.sin(2 * np.pi * t / 0.02)), 0.0) * 6e5


@pytest.mark.parametrize("case,expected", [
    # (corridor, phase, magnitude, slope, overall) of objective_rating_metrics 1.3 (PyPI, an
    # independent ISO/TS 18571 implementation), run once on the same curves
    ("shift5", (0.7419389, 0.7918401, 1.0, 1.0, 0.8551436)),
    ("scale08", (0.8634821, 1.0, 0.8628777, 0.9, 0.8979684)),
    ("ripple", (1.0, 1.0, 0.9685556, 0.6902972, 0.9317706)),
])
def test_iso18571_agrees_with_a_reference_implementation(case, expected):
    grid = np.arange(0, 0.12 + 5e-5, 1e-4)
    ref = _pulse(grid)
    cmp_ = {"shift5": _pulse(grid - 0.005), "scale08": 0.8 * ref,
            "ripple": ref + 2e4 * np.sin(grid * 900)}[case]
    r = iso18571(ref, cmp_)
    assert (r.corridor, r.phase, r.magnitude, r.slope, r.overall) == pytest.approx(expected, abs=1e-6)
