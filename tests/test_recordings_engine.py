"""The engine's X accelerometers as a second measured body: ``SensorTest.engine`` and the
Measurement's ``engine_x_m`` / ``engine_vx_mps``, on the real NHTSA test 10146 (curve 095,
top of engine, valid; curve 096, bottom of engine, failed after 67 ms), on ISO-MME files
written by identify and by the reference world, and on bad input. No fit: fast."""

import dataclasses
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from identify.errors import UserError
from identify.recordings import (Channel, contact_time, measurement_from_test, read_isomme,
                                 read_nhtsa, write_isomme)
from identify.recordings.isomme import is_engine_motion
from identify.recordings.motion import G0, combine

DATA = Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146"
HEADER = DATA / "v10146.EV5"
WORLD_SEED = 137  # below 1000 (the benchmark's seeds start at 910,000), used by no other test
ENGINE = ("engine_x_m", "engine_vx_mps")


def _copy(tmp_path, edit=None, curves=(93, 94, 95, 96, 99, 100, 900)):
    """The trimmed test copied into tmp_path; ``edit(fields)`` may change an INSTRUMENTATION
    row's fields (a list, field 2 = curve) in place, or return "drop" to leave the row out."""
    rows = []
    for line in HEADER.read_text(encoding="latin-1").splitlines():
        f = line.split("|")
        if edit is not None and len(f) == 20 and edit(f) == "drop":
            continue
        rows.append("|".join(f))
    (tmp_path / "v10146.EV5").write_text("\n".join(rows) + "\n", encoding="latin-1")
    for c in curves:
        shutil.copy(DATA / f"v10146.{c:03d}", tmp_path)
    return tmp_path / "v10146.EV5"


def _note(notes, *words):
    found = [n for n in notes if all(w in n for w in words)]
    assert found, f"no note with {words} in {notes}"
    return found[0]


def _at(m, ms):
    """Index of the Measurement sample at ``ms`` after contact."""
    return int(np.argmin(np.abs(m.t - ms / 1e3)))


# ------------------------------------------------------------------ the real test 10146


def test_095_is_read_and_096_is_skipped_where_it_ends(test10146, motion):
    assert [c.code for c in test10146.engine] == ["95"]
    ch = test10146.engine[0]
    raw = np.loadtxt(DATA / "v10146.095")
    np.testing.assert_allclose(ch.t, raw[:, 0])
    np.testing.assert_allclose(ch.values, G0 * raw[:, 1])  # G'S -> m/s^2, forward positive kept
    note = _note(test10146.notes, "skipped engine curve 96")
    assert re.search(r"end at 66\.9 ms", note) and "curve 95" in note and "covers the whole recording" in note
    assert _note(motion.notes, "engine motion from the mean of 1 engine X accelerometer(s) (95)", "CFC 180")
    # 095 covers the test: the engine is measured to the end, with positive sigmas
    for name in ENGINE:
        assert motion.valid(name).all() and np.all(motion.sigma[name] > 0)
    assert motion.channels["engine_x_m"][0] == 0.0
    assert motion.channels["engine_vx_mps"][0] == pytest.approx(test10146.impact_speed_mps)


def test_engine_slows_far_more_than_the_cabin_while_it_hits_the_barrier(test10146, motion):
    v_e, v_c = motion.channels["engine_vx_mps"], motion.channels["vx_mps"]
    i15, i40 = _at(motion, 15), _at(motion, 40)
    drop_engine, drop_cabin = v_e[i15] - v_e[i40], v_c[i15] - v_c[i40]
    # The bound, from the barrier's load cells (data the engine channel never sees): the
    # barrier's impulse J over 15-40 ms took momentum out of the whole car, J = sum m_i dv_i
    # = M dv_cabin + sum m_i (dv_i - dv_cabin). So J / M - dv_cabin is the extra drop beyond
    # the cabin's averaged over the whole test mass M; only the parts that move apart from the
    # cabin (the engine, which the barrier force's peak at 36 ms is the hit of, and the
    # structure ahead of it, a fraction of M) carry it, so theirs is larger than this mean.
    t0, _ = contact_time(test10146)
    t, force = combine(test10146.barrier, "sum", "barrier forces")
    window = (t >= t0 + 0.015) & (t <= t0 + 0.040)
    impulse = np.trapezoid(force[window], t[window])
    mean_extra = impulse / test10146.mass_kg - drop_cabin
    assert mean_extra > 0.0  # the barrier took more than the cabin's momentum: the bound says something
    assert drop_engine - drop_cabin >= mean_extra
    # at 40 ms the engine has been stopped by the barrier while the cabin still moves on; it
    # may bounce back, but slower than 0.2 x the impact speed (3 m/s: an engine hitting a
    # rigid wall through the crushed front end restitutes little)
    assert -0.2 * test10146.impact_speed_mps < v_e[i40] < 0.2 * v_c[i40]


def test_engine_moves_with_the_car_after_the_crash(motion):
    """After the car has left the barrier (separation ~110 ms) the engine, held in the car,
    moves at the car's speed: the velocities agree within their measurement error. The
    displacements do *not* agree absolutely: the barrier stopped the engine at about 0.45 m
    while the cabin went on to 0.75 m, so the engine bay between them was crushed and the
    engine sits further back in the car for good (the cabin's lead d = x - engine_x is that
    permanent set). What staying in the car means for displacement is that d stops
    changing, up to the velocity error integrated (0.5 m/s over the 0.15 s is 7.5 cm)."""
    assert motion.events_ms["separation"] < 150.0
    late = motion.t >= 0.150
    v_e, v_c = motion.channels["engine_vx_mps"], motion.channels["vx_mps"]
    sigma = np.hypot(motion.sigma["engine_vx_mps"], motion.sigma["vx_mps"])
    assert np.all(sigma[late] < 0.5)  # the check below is not empty
    assert np.all(np.abs(v_e - v_c)[late] <= 3.0 * sigma[late])
    assert abs(np.mean((v_e - v_c)[late])) < 0.5
    d = motion.channels["x_m"] - motion.channels["engine_x_m"]
    i150 = _at(motion, 150)
    assert np.all(np.abs(d[late] - d[i150]) < 0.5 * 0.15)
    max_crush = motion.channels["x_m"].max()
    assert 0.0 < d[i150] < max_crush  # pushed back into the car, by less than the car was crushed


def test_cabin_is_unchanged_by_the_engine(test10146, motion):
    alone = measurement_from_test(dataclasses.replace(test10146, engine=()))
    assert set(alone.channels) == {"x_m", "vx_mps"}
    assert not any("engine motion" in n for n in alone.notes)
    for name in ("x_m", "vx_mps"):
        np.testing.assert_array_equal(alone.channels[name], motion.channels[name])
        np.testing.assert_array_equal(alone.sigma[name], motion.sigma[name])
    assert alone.events_ms == motion.events_ms


def test_engine_is_processed_exactly_as_the_cabin(test10146):
    """An engine accelerometer that reads what a crossmember one reads, plus a zero offset
    of 0.5 g, gives the cabin's motion and sigma: same offset removal, filter, contact time,
    start speed and uncertainty model."""
    cabin = test10146.vehicle[0]
    twin = Channel("twin", "engine reading the crossmember", cabin.t, cabin.values + 0.5 * G0, "acceleration")
    m = measurement_from_test(dataclasses.replace(test10146, vehicle=(cabin,), engine=(twin,)))
    for engine, body in (("engine_x_m", "x_m"), ("engine_vx_mps", "vx_mps")):
        np.testing.assert_allclose(m.channels[engine], m.channels[body], rtol=0, atol=1e-9)
        np.testing.assert_allclose(m.sigma[engine], m.sigma[body], rtol=1e-9, atol=0)


def test_sensor_recording_marks_the_engine_displacement_derived():
    from identify.recordings.load import load_recording

    m = load_recording(HEADER, car_geometry=None).measurement  # geometry: films only
    # both displacements are integrals of the fitted velocities: plotted, not fitted twice
    assert m.derived == ("x_m", "engine_x_m")


# ------------------------------------------------------------------ ISO-MME


@pytest.mark.parametrize("code,engine", [
    ("10ENGNTO0000ACX0", True), ("10ENGNBO0000ACXP", True), ("10ENGNTO0000ACZ0", False),
    ("20ENGNTO0000ACX0", False), ("10SECMLERE00ACXP", False), ("10ENGN0000ACX0", False)])
def test_engine_codes(code, engine):
    assert is_engine_motion(code) is engine


def test_isomme_round_trip_keeps_the_engine(test10146, tmp_path):
    back = read_isomme(write_isomme(test10146, tmp_path / "iso", number="10146"))
    assert [c.code for c in back.engine] == ["10ENGNTO0000ACXP"]
    a, b = test10146.engine[0], back.engine[0]
    assert b.name == a.name and b.quantity == "acceleration"
    np.testing.assert_allclose(b.t, a.t, atol=1e-9)
    np.testing.assert_allclose(b.values, a.values, rtol=1e-9, atol=1e-9)  # 10 digits in g
    m1, m2 = measurement_from_test(test10146), measurement_from_test(back)
    for name in ENGINE:
        np.testing.assert_allclose(m2.channels[name], m1.channels[name], atol=1e-6)


def test_isomme_round_trip_keeps_a_short_engine_channel(tmp_path):
    (tmp_path / "ev5").mkdir()
    test = read_nhtsa(_copy(tmp_path / "ev5", lambda f: "drop" if f[1] == "95" else None))
    assert [c.code for c in test.engine] == ["96"]
    back = read_isomme(write_isomme(test, tmp_path / "iso"))
    assert [c.code for c in back.engine] == ["10ENGNBO0000ACXP"]
    assert len(back.engine[0].t) == 1170
    np.testing.assert_allclose(back.engine[0].values, test.engine[0].values, rtol=1e-9, atol=1e-9)
    m = measurement_from_test(back)
    assert np.isnan(m.channels["engine_vx_mps"][-1]) and np.isfinite(m.channels["engine_vx_mps"][50])


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    from synth.world import make_world, write_world

    w = make_world(WORLD_SEED, "engine_impact", fmt="isomme")
    folder = tmp_path_factory.mktemp("world") / "sensors"
    truth = write_world(w, folder)
    return w, folder, truth


def _true_engine_velocity(w, folder, truth):
    """The reference world's engine velocity (m/s) on its clock (s, 0 = contact): from
    truth.json when it carries the engine, else from the world's own simulation run again
    (``write_world`` makes the recording from exactly this call; it is deterministic)."""
    from synth.world import DURATION_S, read_truth

    series = read_truth(folder)["series"]
    if "engine_vx_mps" in series:
        return series["t_ms"] / 1e3, series["engine_vx_mps"]
    from synth.physics import simulate_reference

    ref = simulate_reference(w.car, w.params, w.v0, duration=DURATION_S, fps=truth["fps"])
    a, t = np.asarray(ref.engine_accel_x), np.asarray(ref.t)
    return t, w.v0 + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))])


def test_reference_world_engine_is_measured(world):
    w, folder, truth = world
    test = read_isomme(folder / truth["recording"])
    assert [c.code for c in test.engine] == ["10ENGNTO0000ACX0", "10ENGNBO0000ACX0"]
    m = measurement_from_test(test)
    _note(m.notes, "engine motion from the mean of 2 engine X accelerometer(s)")
    # it decelerates harder than the cabin: it hits the barrier (engine_impact)
    v_e, v_c = m.channels["engine_vx_mps"], m.channels["vx_mps"]
    hit = truth["events_ms"]["engine_contact"]
    i0, i1 = _at(m, hit), _at(m, hit + 15.0)
    assert (v_e[i0] - v_e[i1]) > 2.0 * (v_c[i0] - v_c[i1])
    # ... and as the world moved it: within the Measurement's sigma and the speed trap's
    t0, _ = contact_time(test)
    t_true, v_true = _true_engine_velocity(w, folder, truth)
    ok = m.t + t0 <= t_true[-1]
    err = m.channels["engine_vx_mps"][ok] - np.interp(m.t[ok] + t0, t_true, v_true)
    sigma = np.hypot(m.sigma["engine_vx_mps"][ok], m.impact_speed_sigma)
    assert np.all(np.abs(err) <= 3.0 * sigma), np.max(np.abs(err) / sigma)


# ------------------------------------------------------------------ bad input


def _no_engine_after(m, end_s, t0):
    """The engine channels are NaN (value and sigma) from ``end_s`` (recording time) on and
    finite before."""
    gone = m.t + t0 > end_s
    assert gone.any() and (~gone).sum() > 20
    for name in ENGINE:
        assert np.all(np.isnan(m.channels[name][gone])) and np.all(np.isnan(m.sigma[name][gone]))
        assert np.all(np.isfinite(m.channels[name][~gone][:-1]))


def test_invalid_engine_channel_is_skipped_and_the_short_one_is_kept(tmp_path):
    def fail_95(f):
        if f[1] == "95":
            f[17] = "NO"

    test = read_nhtsa(_copy(tmp_path, fail_95))
    assert re.search(r"skipped engine curve 95 .*'NO'", _note(test.notes, "curve 95"))
    # 096 alone: "CF" with "No valid data after 67ms" -> its 66.9 ms are used
    assert [c.code for c in test.engine] == ["96"] and test.engine[0].t[-1] == pytest.approx(0.0669)
    assert "66.9 ms are used" in _note(test.notes, "curve 96", "'CF'")
    m = measurement_from_test(test)
    t0, _ = contact_time(test)
    _no_engine_after(m, 0.0669, t0)
    note = _note(m.notes, "engine is not measured from")
    assert re.search(r"from 6\d\.\d ms after contact on: its accelerometer\(s\) \(96\) end at 66\.9 ms", note)
    assert m.valid("engine_vx_mps").any()  # what exists is there for the fit


def test_engine_channel_at_another_rate_is_skipped(tmp_path):
    def halve_95(f):
        if f[1] == "95":
            f[14], f[15], f[16] = "-250", "1499", "200"

    path = _copy(tmp_path, halve_95)
    np.savetxt(tmp_path / "v10146.095", np.loadtxt(DATA / "v10146.095")[::2], fmt="%.6f", delimiter="\t")
    test = read_nhtsa(path)
    assert "sampled at 5000 Hz, the vehicle channels at 10000 Hz" in _note(test.notes, "skipped engine curve 95")
    assert [c.code for c in test.engine] == ["96"]


def test_engine_file_shorter_than_its_header_is_skipped_a_vehicle_one_is_an_error(tmp_path):
    path = _copy(tmp_path)
    lines = (DATA / "v10146.095").read_text().splitlines()
    (tmp_path / "v10146.095").write_text("\n".join(lines[:3000]) + "\n")
    test = read_nhtsa(path)
    assert "has 3000 samples, the header announces 3500" in _note(test.notes, "skipped engine curve 95")
    assert [c.code for c in test.engine] == ["96"]
    (tmp_path / "v10146.094").write_text("\n".join((DATA / "v10146.094").read_text().splitlines()[:3000]) + "\n")
    with pytest.raises(UserError, match=r"v10146\.094: has 3000 samples, the header announces 3500"):
        read_nhtsa(path)


def _iso_with_two_engine_channels(test10146, tmp_path):
    """ISO-MME folder of 10146 with 095 written twice (channels 006 top, 007 bottom)."""
    ch = test10146.engine[0]
    bottom = Channel("95b", "BOTTOM OF ENGINE X", ch.t, ch.values, ch.quantity)
    return write_isomme(dataclasses.replace(test10146, engine=(ch, bottom)), tmp_path / "iso", number="T")


def _edit(path: Path, key: str, value: str):
    text = path.read_text(encoding="latin-1")
    new, n = re.subn(rf"(?m)^({re.escape(key)}\s*:).*$", rf"\g<1>{value}", text)
    assert n == 1
    path.write_text(new, encoding="latin-1")


@pytest.mark.parametrize("key,value,says", [
    ("Data status", "defect", "data status 'defect'"),
    ("Sampling interval", "0.0002", "sampled at 5000 Hz, the vehicle channels at 10000 Hz"),
    ("Unit", "N", "expected a unit of acceleration"),
    ("Number of samples", "3000", "has 3500 samples, its header announces 3000")])
def test_isomme_bad_engine_channel_is_skipped(test10146, tmp_path, key, value, says):
    mme = _iso_with_two_engine_channels(test10146, tmp_path)
    _edit(mme.parent / "Channel" / "T.007", key, value)
    test = read_isomme(mme)
    assert [c.code for c in test.engine] == ["10ENGNTO0000ACXP"]
    assert says in _note(test.notes, "skipped engine channel 007 10ENGNBO0001ACXP")
    assert measurement_from_test(test).valid("engine_vx_mps").all()


def test_isomme_engine_channel_ending_in_novalue_ends_early(test10146, tmp_path):
    mme = _iso_with_two_engine_channels(test10146, tmp_path)
    for k in ("006", "007"):  # both fail at 80 ms: no channel covers the test
        f = mme.parent / "Channel" / f"T.{k}"
        lines = f.read_text(encoding="latin-1").splitlines()
        first = next(i for i, s in enumerate(lines) if ":" not in s)
        cut = first + 500 + 800  # -50 ms + 1300 samples: the first sample missing is at 80 ms
        f.write_text("\n".join(lines[:cut] + ["NOVALUE"] * (len(lines) - cut)) + "\n", encoding="latin-1")
    test = read_isomme(mme)
    assert len(test.engine) == 2 and test.engine[0].t[-1] == pytest.approx(0.0799)
    m = measurement_from_test(test)
    _no_engine_after(m, 0.0799, contact_time(test)[0])
    assert "end at 79.9 ms recording time" in _note(m.notes, "engine is not measured from")


def test_sensor_test_built_directly(test10146):
    """Engine channels handed over without a reader are checked as a reader checks them."""
    ch = test10146.engine[0]
    slow = Channel("slow", "engine at 5 kHz", ch.t[::2], ch.values[::2], "acceleration")
    late = Channel("late", "engine started late", ch.t[10:], ch.values[10:], "acceleration")
    force = Channel("force", "engine mount force", ch.t, ch.values, "force")
    m = measurement_from_test(dataclasses.replace(test10146, engine=(slow, late, force)))
    assert not set(ENGINE) & set(m.channels)
    assert "sampled at 5000 Hz" in _note(m.notes, "skipped engine channel slow")
    assert "not one clock" in _note(m.notes, "skipped engine channel late")
    assert "not an acceleration" in _note(m.notes, "skipped engine channel force")
    short = Channel("short", "engine until 80 ms", ch.t[ch.t <= 0.08], ch.values[ch.t <= 0.08], "acceleration")
    test = dataclasses.replace(test10146, engine=(short,))
    m = measurement_from_test(test)
    _no_engine_after(m, 0.08, contact_time(test)[0])
    _note(m.notes, "engine is not measured from", "(short)")
    # the short one is dropped when a channel covers the test, whatever the order
    m = measurement_from_test(dataclasses.replace(test10146, engine=(short, ch)))
    assert m.valid("engine_vx_mps").all()
    assert "end at 80.0 ms" in _note(m.notes, "skipped engine channel short")
    assert "mean of 1 engine" in _note(m.notes, "engine motion")


def test_tracks_csv_engine_velocity_is_derived(tmp_path):
    from identify.recordings.measurement import measurement_from_tracks_csv

    p = tmp_path / "tracks.csv"
    t = np.arange(5)
    rows = ["t_ms,x_m,vx_mps,engine_x_m,engine_vx_mps"] + [f"{k},{k * 0.01},10,{k * 0.01},10" for k in t]
    p.write_text("\n".join(rows) + "\n")
    m = measurement_from_tracks_csv(p)
    assert set(m.channels) == {"x_m", "vx_mps", "engine_x_m", "engine_vx_mps"}
    assert m.derived == ("vx_mps", "engine_vx_mps")
