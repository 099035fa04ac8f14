"""NHTSA EV5 reader and the acceleration-to-motion stage, on the real test 10146
(``data/nhtsa-10146/``: a trimmed copy, see its README)."""

import csv
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from helpers import integrate_from, raw_10146
from identify.cli import main
from identify.errors import UserError
from identify.recordings import crash_facts, measurement_from_test, read_nhtsa
from identify.recordings.motion import combine, find_onset
from identify.recordings.nhtsa import (barrier_force_channels, load_ev5_channel, read_ev5_header,
                                       vehicle_motion_channels)

DATA = Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146"
HEADER = DATA / "v10146.EV5"


@pytest.fixture(scope="module")
def raw():
    """The independent reference: the raw channel files integrated with numpy and scipy
    (tests/helpers.py, ``Raw10146``), on the recording's clock."""
    return raw_10146()


def _copy(tmp_path, curves=(93, 94, 99, 100, 900), edit=None):
    """A copy of the trimmed test in tmp_path, header rows edited by ``edit(fields)``."""
    lines = HEADER.read_text(encoding="latin-1").splitlines()
    out = []
    for line in lines:
        f = line.split("|")
        if edit is not None and len(f) == 20:
            f = edit(f)
            if f is None:
                continue
        out.append("|".join(f))
    (tmp_path / "v10146.EV5").write_text("\n".join(out) + "\n", encoding="latin-1")
    for c in curves:
        shutil.copy(DATA / f"v10146.{c:03d}", tmp_path / f"v10146.{c:03d}")
    return tmp_path / "v10146.EV5"


def test_header_fields():
    h = read_ev5_header(HEADER)
    assert h.title.startswith("NCAP - 2018 TOYOTA CAMRY")
    assert h.speed_kmh == pytest.approx(57.09)
    assert h.mass_kg == pytest.approx(1719.0)
    by_curve = {c.curve: c for c in h.channels}
    assert sorted(by_curve) == [93, 94, 95, 96, 99, 100, 900]
    assert by_curve[93].attachment == "FLLR" and by_curve[93].units == "G'S"
    assert by_curve[93].dt == pytest.approx(1e-4) and by_curve[93].n_samples == 3500
    assert not by_curve[96].valid and by_curve[96].n_samples == 1170
    assert by_curve[95].attachment == "ENGN" and by_curve[95].valid_until_s == float("inf")
    # "CF" (channel failed) with "No valid data after 67ms": usable up to 67 ms
    assert by_curve[96].valid_until_s == pytest.approx(0.067)
    assert not by_curve[99].primary and by_curve[93].primary


def test_short_invalid_channel_reads_to_its_last_sample():
    h = read_ev5_header(HEADER)
    t, y = load_ev5_channel(h, next(c for c in h.channels if c.curve == 96))
    assert len(t) == 1170 and t[-1] == pytest.approx(0.0669)


def test_channel_selection(test10146):
    assert [c.code for c in test10146.vehicle] == ["93", "94", "99", "100"]
    assert [c.redundant for c in test10146.vehicle] == [False, False, True, True]
    assert [c.code for c in test10146.barrier] == ["900"]
    assert test10146.impact_speed_mps == pytest.approx(57.09 / 3.6)
    # G'S -> m/s^2 keeps the sign: the crash pulse of a forward-positive sensor is negative
    ch = test10146.vehicle[0]
    pulse = (ch.t >= 0) & (ch.t <= 0.12)
    assert -20.0 < np.trapezoid(ch.values[pulse], ch.t[pulse]) < -16.0  # m/s: the change of velocity
    # barrier compression is negative Fx in the export and positive here
    assert test10146.barrier[0].values.max() > 6e5


def _contact_ms(m):
    """The Measurement's first contact (recording time, ms), as its note reports it."""
    note = next(n for n in m.notes if n.startswith("first contact"))
    return float(note.split(" at ")[1].split(" ")[0])


def test_crush_and_timing_of_10146(motion, raw):
    # Reference: the four raw crossmember accelerations, offsets removed, averaged, g ->
    # m/s^2, integrated by trapezoid from the header's 57.09 km/h at NHTSA's t = 0 (the
    # contact switch), unfiltered: 0.74089 m at 73.4 ms. The program (CFC 180, integration
    # from the sample nearest its own contact time, -0.03 ms, i.e. the same sample; the
    # Measurement resampled to 1 kHz) gives 0.74085 m at 73.0 ms. Tolerances: 1 mm (the CFC
    # 180 filter alone moves the crush by 0.01 mm, a contact one sample (0.1 ms) off would move
    # it by v0 x 0.1 ms = 1.6 mm) and the Measurement's 1 ms grid.
    facts = crash_facts(motion)
    assert facts["max_crush_m"] == pytest.approx(raw.max_crush_m, abs=1e-3)
    assert facts["max_crush_ms"] == pytest.approx(raw.max_crush_s * 1e3, abs=1.0)
    # compression_end is found at the recording's 10 kHz: the reference's sample (73.4 ms)
    assert motion.events_ms["compression_end"] == pytest.approx(raw.max_crush_s * 1e3, abs=0.15)


def test_rebound_of_10146(motion, raw):
    facts = crash_facts(motion)
    # Separation: the last time the summed barrier force, filtered with a scipy CFC 60
    # (J211's corner), is above 2 % of its peak: 109.1 ms recording time. The program's
    # times count from its contact (-0.03 ms recording time): add it back; one 10 kHz
    # sample of tolerance.
    assert facts["separation_ms"] + _contact_ms(motion) == pytest.approx(raw.contact_end_s * 1e3, abs=0.1)
    # Rebound: the mean backward speed of the raw integration after that: 2.4436 m/s; the
    # program (CFC 180, its 1 kHz Measurement, samples from 110 ms) gives 2.4433 m/s.
    # Tolerance 3 mm/s (10x that difference; the choice of the pre-impact window alone, t <= -5
    # ms or t < 0, moves the reference by 30 mm/s, see Raw10146).
    assert facts["rebound_mps"] == pytest.approx(raw.rebound_mps, abs=3e-3)
    assert facts["delta_v_mps"] == pytest.approx(raw.v0 + raw.rebound_mps, abs=3e-3)


def test_measurement_shape_and_sigma(motion, test10146):
    assert motion.t[0] == 0.0 and motion.fps == pytest.approx(1000.0)
    assert motion.t[-1] == pytest.approx(0.2999, abs=2e-3)
    assert set(motion.channels) == {"x_m", "vx_mps", "engine_x_m", "engine_vx_mps"}  # 095: the engine
    assert motion.channels["vx_mps"][0] == pytest.approx(test10146.impact_speed_mps)
    assert motion.channels["x_m"][0] == 0.0
    sx, sv = motion.sigma["x_m"], motion.sigma["vx_mps"]
    assert np.all(sx > 0) and np.all(sv > 0)
    # integration drift: the uncertainty grows with time since contact
    assert sx[250] > sx[100] > sx[20] and sv[100] > sv[10]
    # ... but stays small against the crush it measures
    assert sx[74] < 0.02
    assert motion.impact_speed_sigma > 0


def test_contact_time_from_barrier_force_matches_nhtsa_time_zero(motion):
    # NHTSA's time zero is the contact switch; the summed force starts within a ms of it,
    # and within the onset's own sigma (3.1 ms: the force climbs slowly out of the noise)
    ms = _contact_ms(motion)
    assert abs(ms) < 1.0 and abs(ms) < motion.contact_time_sigma * 1e3
    note = next(n for n in motion.notes if n.startswith("first contact"))
    assert f"+- {motion.contact_time_sigma * 1e3:.2f} ms" in note


def test_contact_from_vehicle_pulse_alone_lags_the_bumper(tmp_path, raw):
    t = read_nhtsa(HEADER, barrier=False)
    assert t.barrier == ()
    m = measurement_from_test(t)
    note = next(n for n in m.notes if n.startswith("first contact"))
    ms = _contact_ms(m)
    assert 1.0 < ms < 6.0 and "vehicle deceleration" in note
    # contact from the same accelerometers the fit sees: no independent measurement, no sigma
    assert m.contact_time_sigma is None
    # The later zero loses the bumper's first centimetres of crush: the raw integration
    # started at that time (3.1 ms, the nearest sample) gives 0.69195 m, the program
    # 0.69191 m (1 mm as in test_crush_and_timing_of_10146) ...
    _, _, x_late = integrate_from(raw.t, raw.mean_accel, ms / 1e3, raw.v0)
    crush = crash_facts(m)["max_crush_m"]
    assert crush == pytest.approx(float(np.max(x_late)), abs=1e-3)
    # ... which is the crush from NHTSA's t = 0 less the travel at the impact speed during
    # the lag (v0 x 3.1 ms = 49.2 mm; measured loss 49.0 mm: the car has hardly slowed yet)
    lag = float(raw.t[np.argmin(np.abs(raw.t - ms / 1e3))])
    assert raw.max_crush_m - crush == pytest.approx(raw.v0 * lag, abs=1e-3)


def test_find_onset_of_a_ramp():
    t = np.arange(-0.05, 0.1, 1e-4)
    rng = np.random.default_rng(0)
    pulse = np.where(t > 0.01, (t - 0.01) * 1000.0, 0.0) + 0.01 * rng.standard_normal(len(t))
    assert find_onset(t, pulse) == pytest.approx(0.01, abs=5e-4)


def test_invalid_vehicle_channel_is_skipped(tmp_path):
    def mark(f):
        if f[1] == "93":
            f[17] = "CF"
        return f

    t = read_nhtsa(_copy(tmp_path, curves=(94, 99, 100, 900), edit=mark))
    assert [c.code for c in t.vehicle] == ["94", "99", "100"]
    assert any("curve 93" in n and "'CF'" in n for n in t.notes)


def test_redundant_average_removes_offsets(test10146):
    t, a = combine(test10146.vehicle, "mean", "vehicle accelerations")
    pre = t <= -0.005
    assert abs(a[pre].mean()) < 1e-12
    manual = np.mean([c.values - c.values[pre].mean() for c in test10146.vehicle], axis=0)
    np.testing.assert_allclose(a, manual)


def test_raw_load_cells_are_summed_and_invalid_ones_skipped(tmp_path):
    cells = read_ev5_header(DATA / "cells" / "v10146.EV5")
    chosen, notes = barrier_force_channels(cells)
    assert [c.curve for c in chosen] == [131, 260, 263, 275, 287]
    assert any("curve 347" in n for n in notes) and any("curve 500" in n for n in notes)
    # a test made of the vehicle rows and the five raw cells
    lines = (DATA / "cells" / "v10146.EV5").read_text(encoding="latin-1").splitlines()
    rows = lines[lines.index("----- INSTRUMENTATION -----") + 1:lines.index("----- END -----")]
    keep = [line for line in HEADER.read_text(encoding="latin-1").splitlines() if not line.startswith("0|900|")]
    end = keep.index("----- END -----")
    (tmp_path / "v10146.EV5").write_text("\n".join(keep[:end] + rows + keep[end:]) + "\n", encoding="latin-1")
    for c in (93, 94, 99, 100):
        shutil.copy(DATA / f"v10146.{c:03d}", tmp_path)
    for c in (131, 260, 263, 275, 287):
        shutil.copy(DATA / "cells" / f"v10146.{c:03d}", tmp_path)
    t = read_nhtsa(tmp_path / "v10146.EV5")
    assert len(t.barrier) == 5
    raw = sum(np.loadtxt(DATA / "cells" / f"v10146.{c:03d}")[:, 1] for c in (131, 260, 263, 275, 287))
    tt, total = combine(t.barrier, "sum", "barrier forces")
    pre = tt <= -0.005
    np.testing.assert_allclose(total, -(raw - raw[pre].mean()), atol=1e-6)


def test_missing_channel_file(tmp_path):
    with pytest.raises(UserError, match=r"missing channel file v10146\.094 for curve 94"):
        read_nhtsa(_copy(tmp_path, curves=(93, 99, 100, 900)))


def test_header_without_vehicle_channels():
    with pytest.raises(UserError, match="no valid vehicle X accelerometer"):
        read_nhtsa(DATA / "cells" / "v10146.EV5")


def test_file_rate_disagrees_with_header(tmp_path):
    path = _copy(tmp_path)
    data = np.loadtxt(DATA / "v10146.094")
    data[:, 0] = data[0, 0] + 2e-4 * np.arange(len(data))
    np.savetxt(tmp_path / "v10146.094", data, fmt="%.6f", delimiter="\t")
    with pytest.raises(UserError, match="mismatched sample rates"):
        read_nhtsa(path)


def test_channels_at_different_rates_cannot_be_averaged(tmp_path):
    def halve(f):
        if f[1] == "94":
            f[14], f[15], f[16] = "-250", "1499", "200"
        return f

    path = _copy(tmp_path, edit=halve)
    data = np.loadtxt(DATA / "v10146.094")[::2]
    np.savetxt(tmp_path / "v10146.094", data, fmt="%.6f", delimiter="\t")
    t = read_nhtsa(path)  # each file agrees with its own header row
    with pytest.raises(UserError, match="mismatched sample rates.*channel 94"):
        measurement_from_test(t)


def test_not_an_ev5_header(tmp_path):
    p = tmp_path / "x.EV5"
    p.write_text("hello|world\n")
    with pytest.raises(UserError, match="not an EV5 header"):
        read_nhtsa(p)


def test_vehicle_selection_prefers_cg(tmp_path):
    def add_cg(f):
        if f[1] == "93":
            f[4] = "VECG"
        return f

    h = read_ev5_header(_copy(tmp_path, edit=add_cg))
    chosen, _ = vehicle_motion_channels(h)
    assert [c.curve for c in chosen] == [93]


def test_progress_is_reported_per_channel_file():
    calls = []
    read_nhtsa(HEADER, progress=lambda done, total, stage: calls.append((done, total)))
    assert calls == [(k, 7) for k in range(1, 8)]  # 4 crossmember, 2 engine, 1 barrier


@pytest.mark.slow
def test_nhtsa_test_is_fitted_from_motion_and_checked_against_the_load_cells(tmp_path):
    out = tmp_path / "v10146.identify"
    ev5 = HEADER
    assert main(["fit", str(ev5), "--vehicle", "toyota_camry_2018", "--out", str(out), "--quiet"]) == 0
    doc = json.loads((out / "result.json").read_text())
    assert doc["recording_kind"] == "sensors" and doc["vehicle"] == "toyota_camry_2018"
    assert doc["impact_speed_kmh"] == pytest.approx(57.1, abs=0.5)
    assert doc["parameters"]["dz_contact"]["identified"] is False
    assert "no pitch or height channel" in doc["parameters"]["dz_contact"]["reason"]
    check = doc["force_check"]
    # the recording's momentum balance, as computed from the raw files with numpy and scipy
    # (tests/helpers.py; +0.03194, the program +0.03196; tolerance of tests/test_force_check.py)
    assert check["load_cells"] >= 1
    assert check["momentum_check"]["error"] == pytest.approx(raw_10146().momentum_error(), abs=5e-4)
    for key in ("peak_error", "impulse_error"):
        assert np.isfinite(check[key])
    assert 0.0 < check["iso18571"]["overall"] <= 1.0
    with open(out / "forces.csv", newline="") as f:
        header = next(csv.reader(f))
    assert header == ["t_ms", "measured_N", "predicted_N"]
    for name in ("force_time.png", "force_crush.png"):
        assert (out / name).stat().st_size > 100
    assert "force_time.png" in (out / "report.md").read_text()
    # the engine's accelerometer (curve 095) makes the engine a second measured body: its
    # velocity is fitted, its mass and gap start from the vehicle file's estimates (priors)
    assert "engine_impact" in doc["fit"]["model"] and "engine_vx_mps" in doc["fit"]["fitted_channels"]
    assert doc["priors"]["engine_impact.engine_mass"]["prior"] == 230.0  # data/vehicles/toyota_camry_2018.toml
    assert doc["priors"]["engine_impact.gap"]["prior"] == 0.4
    # discovery ran on the motion: every other candidate tried is listed with its verdict
    tried = {t["effect"] for r in doc["discovery_rounds"] for t in r}
    assert tried == {"front_wheel_block", "stiffness_zone", "progressive_stiffness", "rate_dependence", "rear_axle_lift"}
    assert all(t["accepted"] or t["reason"] for r in doc["discovery_rounds"] for t in r)
    for d in doc["discoveries"]:
        assert d["rms_after_m"] < d["rms_before_m"]
    # the load cells (never fitted) see the engine block hit the barrier at 35 ms: a one-body
    # model's force (mass x the cabin's deceleration) cannot peak there; the two-body model's
    # does, and its curve is closer to the load cells' (ISO 18571) than the one-body model's
    # and than a rigid car moving as measured. The peak's height is not asserted: it depends
    # on which of the fit's minima the random starts reach (README, 'Not met': from -5.5 % to
    # +16 % over 21 runs with other seeds or the Jacobian's rounding; within issue 15's 8 % on 14)
    base, rigid = check["base_model"], check["rigid_body"]
    assert base["label"] == "base model on the cabin alone"
    assert abs(check["peak_time_predicted_ms"] - check["peak_time_measured_ms"]) <= 5.0
    assert abs(base["peak_time_predicted_ms"] - check["peak_time_measured_ms"]) > 5.0
    assert check["iso18571"]["overall"] > max(base["iso18571"]["overall"], rigid["iso18571"]["overall"])
    assert check["nrmse"] < base["nrmse"]
    report = (out / "report.md").read_text()
    assert "base model on the cabin alone" in report and "a rigid car moving exactly as measured" in report
    assert "two bodies" in report
    # the floor under any two-body model fitting the motion: the vehicle file's engine mass,
    # scored where the fitted model is, and the least-squares mass no other mass beats
    # (tests/test_force_check.py checks that floor by brute force); the report names both
    two = check["two_body"]
    assert two["engine_mass_kg"] == 230.0 and two["engine_mass_source"] == "the vehicle file's"
    assert two["window_ms"] == check["window_ms"] and two["best_nrmse"] <= two["nrmse"]
    assert "a cabin and an engine moving exactly as measured (engine 230 kg, the vehicle file's)" in report
    assert f"nearest the load cells is {two['best_engine_mass_kg']:.0f} kg (the fit, from the motion alone:" in report
    # five random starts and the engine's second (out of the barrier's reach)
    assert doc["fit"]["starts"] == 6 and " of 6 starting points reached the best fit of the base model" in report
