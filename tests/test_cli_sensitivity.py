"""``identify sensitivity`` end to end: from a fit's result.json (covariance) and from
--vehicle/--params with ranges; the files it writes; bad input in one line, exit 2, nothing
of the user's overwritten."""

import csv
import dataclasses
import json

import numpy as np
import pytest

from identify.cli import main
from identify.commands.sensitivity import parse_range, parse_times
from identify.errors import UserError

NAMES = ["k_compression", "k_restitution", "restitution", "dz_contact"]
# as identify fit writes them: the collision parameters, the nuisance speed and contact time,
# and a discovered mechanism's parameter
COV_NAMES = NAMES + ["impact_speed", "contact_time", "front_wheel_block.depth"]
STD = [20000.0, 15000.0, 0.01, 0.01, 0.05, 0.0002, 0.01]
CORR = np.eye(7)
CORR[0, 1] = CORR[1, 0] = 0.6
CORR[1, 2] = CORR[2, 1] = 0.2
CORR[2, 3] = CORR[3, 2] = -0.3
CORR[0, 4] = CORR[4, 0] = 0.4
FAST = ["--samples", "256", "--sobol-samples", "8", "--duration-ms", "100", "--quiet"]


def write_result(folder, covariance=True, vehicle="audi_a4"):
    """A result.json shaped as 'identify fit' writes it (docs/interface.md + covariance)."""
    folder.mkdir(parents=True, exist_ok=True)
    values = [970000.0, 600000.0, 0.17, -0.21]
    units = ["N/m^3", "N/m^3", "1", "m"]
    cov = CORR * np.outer(STD, STD)
    doc = {
        "vehicle": vehicle,
        "fps": 1000.0,
        "impact_speed_kmh": 56.3,
        "speed_mps": 56.3 / 3.6,
        "parameters": {n: {"value": v, "unit": u, "std": s, "identified": True}
                       for n, v, u, s in zip(NAMES, values, units, STD)},  # fmt: skip
        "fit": {"rms_m": 0.002, "model": "base+front_wheel_block"},
        "discoveries": [{"effect": "front_wheel_block", "explanation": "...", "window_ms": [46.0, 130.0],
                         "parameters": {"depth": {"value": 0.583, "unit": "m", "std": 0.01}}},
                        {"effect": "unexplained", "window_ms": [150.0, 200.0], "explanation": "..."}],  # fmt: skip
        "events_ms": {"front_wheel_block": 47.0},
    }
    doc["parameters"]["mu_slip"] = {"value": 0.8, "unit": "1", "std": None, "identified": False}
    doc["parameters"]["mu_face"] = {"value": 0.3, "unit": "1", "std": 0.15, "identified": False,
                                    "reason": "not identified: the fit barely narrows what was known before it"}
    doc["parameters"]["front_wheel_block.depth"] = {"value": 0.583, "unit": "m", "std": 0.01, "identified": True}
    if covariance:
        doc["covariance"] = {"names": COV_NAMES, "matrix": cov.tolist()}
        doc["correlation"] = {"names": COV_NAMES, "matrix": CORR.tolist()}
    (folder / "result.json").write_text(json.dumps(doc))
    return folder


@pytest.fixture(scope="module")
def result_run(tmp_path_factory):
    folder = write_result(tmp_path_factory.mktemp("fit") / "crash.identify")
    code = main(["sensitivity", str(folder), "--range", "mass=1600:1740", *FAST])
    return code, folder / "sensitivity"


def test_result_dir_run_writes_everything(result_run):
    code, out = result_run
    assert code == 0
    for name in ("sensitivity.json", "sensitivity.csv", "intervals.csv", "monte_carlo.csv", "tornado.png", "distributions.png",
                 "comparison_histories.png", "comparison_silhouettes.png"):  # fmt: skip
        assert (out / name).stat().st_size > 500, name
    doc = json.loads((out / "sensitivity.json").read_text())
    assert doc["vehicle"] == "audi_a4" and doc["speed_mps"] == pytest.approx(56.3 / 3.6)
    assert doc["source"]["sampling"] == "covariance"
    dist = {n: d["distribution"] for n, d in doc["inputs"].items()}
    assert dist["k_compression"] == {"kind": "normal", "mean": 970000.0, "std": pytest.approx(20000.0)}
    assert dist["mass"] == {"kind": "uniform", "low": 1600.0, "high": 1740.0}
    assert dist["speed"] == {"kind": "normal", "mean": pytest.approx(56.3 / 3.6), "std": pytest.approx(0.05)}
    assert dist["mu_slip"] == {"kind": "fixed"}
    # the discovered front-wheel blocking rides along: the block time is the model's at the
    # discovered depth (0.583 m, the paper's tyre line; the paper's V-SIM blocks at 47-48 ms,
    # this model, with the wheels' spin, 45.6 ms)
    from sim import FrontWheelBlock, events_ms, load_vehicle, named_params, simulate

    a4 = load_vehicle("audi_a4")
    blocked = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4),))
    block_ms = events_ms(simulate(blocked, a4, 56.3 / 3.6))["front_wheel_block"]
    assert 1e3 * doc["outputs"]["front_wheel_block_time"]["value"] == pytest.approx(block_ms, abs=0.5)
    assert doc["outputs"]["rear_wheel_touchdown_time"]["value"] is None
    mc = doc["monte_carlo"]["outputs"]["max_crush"]
    lo, hi = mc["interval_90"]
    # the input spreads are small: the 90 % interval is about 2 x 1.645 linear standard
    # deviations, sqrt(g' C g) from the written derivatives g and the covariance C this test
    # wrote (plus the uniform mass range's 140 / sqrt(12) kg); 256 samples estimate an
    # interval's width to ~10 %, and a uniform input's 90 % interval is 5 % narrower than a
    # normal one's. Measured: 0.0285 m against 0.0315 m
    deriv = doc["local"]["derivative"]["max_crush"]
    sampled = [n for n in COV_NAMES if dist.get({"impact_speed": "speed"}.get(n, n), {}).get("kind") == "normal"]
    g = np.array([deriv[{"impact_speed": "speed"}.get(n, n)] for n in sampled])
    idx = [COV_NAMES.index(n) for n in sampled]
    cov = (CORR * np.outer(STD, STD))[np.ix_(idx, idx)]
    linear_sd = np.sqrt(g @ cov @ g + (deriv["mass"] * 140.0 / np.sqrt(12.0)) ** 2)
    assert hi - lo == pytest.approx(2 * 1.645 * linear_sd, rel=0.2)
    assert lo < doc["outputs"]["max_crush"]["value"] < hi
    assert doc["monte_carlo"]["samples"] == 256
    assert doc["sobol"]["inputs"] == NAMES + ["speed", "mass"] and doc["sobol"]["runs"] == 8 * 8
    assert doc["local"]["elasticity"]["max_crush"]["dz_contact"] is None
    assert doc["local"]["linear_change"]["max_crush"]["k_compression"] == pytest.approx(
        doc["local"]["derivative"]["max_crush"]["k_compression"] * 20000.0)
    assert doc["comparison"]["reference"] == "vsim_default" and doc["comparison"]["peak_dx_m"] > 0.05
    notes = " ".join(doc["notes"])
    assert "independent" in notes and "contact_time" in notes and "'unexplained'" in notes


def test_csv_tables(result_run):
    _, out = result_run
    with open(out / "sensitivity.csv") as f:
        rows = list(csv.DictReader(f))
    outputs = {r["output"] for r in rows}
    assert len(rows) == len(outputs) * 9 and "max_crush" in outputs
    row = next(r for r in rows if r["output"] == "max_crush" and r["input"] == "speed")
    assert float(row["elasticity"]) == pytest.approx(1.0, abs=0.05) and float(row["sobol_ST"]) > 0.0
    row = next(r for r in rows if r["output"] == "max_crush" and r["input"] == "mu_slip")
    assert row["sobol_S1"] == "" and row["derivative"] != ""
    row = next(r for r in rows if r["output"] == "max_crush" and r["input"] == "k_compression")
    assert float(row["sobol_ST"]) > 0.0 and float(row["elasticity"]) < 0.0
    with open(out / "intervals.csv") as f:
        intervals = {r["output"]: r for r in csv.DictReader(f)}
    p05, p95 = float(intervals["max_crush"]["p05"]), float(intervals["max_crush"]["p95"])
    assert p05 < p95
    with open(out / "monte_carlo.csv") as f:
        runs = list(csv.DictReader(f))
    assert len(runs) == 256 and runs[0]["rear_wheel_touchdown_time"] == ""
    crush = np.array([float(r["max_crush"]) for r in runs])
    # intervals.csv reports the 5th and 95th percentiles of the samples monte_carlo.csv lists
    # (whether such intervals cover the truth: tests/test_sensitivity.py)
    assert (p05, p95) == pytest.approx((np.percentile(crush, 5), np.percentile(crush, 95)), rel=1e-3)
    assert len({r["k_compression"] for r in runs}) == 256 and len({r["mass"] for r in runs}) == 256


@pytest.mark.slow
def test_params_mode_with_ranges(tmp_path, capsys):
    out = tmp_path / "a4"
    code = main(["sensitivity", "--vehicle", "audi_a4", "--params", "paper_identified", "--range",
                 "restitution=0.1:0.25", "--range", "speed=50:60", "--fix", "mass", "--out", str(out), *FAST])  # fmt: skip
    assert code == 0
    doc = json.loads((out / "sensitivity.json").read_text())
    dist = {n: d["distribution"] for n, d in doc["inputs"].items()}
    assert dist["restitution"] == {"kind": "uniform", "low": 0.1, "high": 0.25}
    assert dist["speed"]["low"] == pytest.approx(50 / 3.6) and dist["mass"] == {"kind": "fixed"}
    assert dist["k_compression"]["low"] == pytest.approx(776e3)  # the documented default range
    assert doc["outputs"]["front_wheel_block_time"]["value"] is None  # no blocking asked for


def test_parse_range():
    assert parse_range("restitution=0.1:0.25") == ("restitution", 0.1, 0.25)
    assert parse_range("speed=36:72") == pytest.approx(("speed", 10.0, 20.0))
    for bad in ("restitution", "restitution=0.3", "foo=1:2", "restitution=a:b", "restitution=0.3:0.1"):
        with pytest.raises(UserError):
            parse_range(bad)


def test_help_states_the_default_ranges():
    from identify.commands.sensitivity import DEFAULT_RANGES_HELP
    from identify.sensitivity import DEFAULT_RANGES

    lines = DEFAULT_RANGES_HELP.splitlines()[1:-1]
    named = {w.strip(","): line for line in lines for w in line.split("value")[0].split()}
    assert set(named) == set(DEFAULT_RANGES)
    for name, (kind, amount) in DEFAULT_RANGES.items():
        line = named[name]
        if kind == "relative":
            assert f"+/- {amount * 100:g} %" in line, name
        elif name == "speed":
            assert f"+/- {amount * 3.6:g} km/h" in line
        else:
            assert f"+/- {amount:g}" in line, name


def test_parse_times():
    assert parse_times(None, 300.0) == pytest.approx((0.05, 0.1, 0.15, 0.2, 0.25, 0.3))
    assert parse_times(None, 120.0) == pytest.approx((0.05, 0.1))
    assert parse_times("75, 30", 300.0) == pytest.approx((0.03, 0.075))
    for bad in ("0", "400", "a,b", ""):
        with pytest.raises(UserError):
            parse_times(bad, 300.0)


def run_bad(argv, capsys):
    code = main(["sensitivity", *argv])
    err = capsys.readouterr().err.strip()
    return code, err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--vehicle", "audi_a4"], "RESULT_DIR"),
        (["--vehicle", "audi_a4", "--params", "nope"], "unknown parameter set"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--range", "stiffness=1:2"], "unknown input"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--samples", "5"], "--samples"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--sobol-samples", "100"], "power of 2"),
        (["/nonexistent/folder"], "no such results folder"),
        (["--vehicle", "audi_a4", "--params", "paper_identified", "--times-ms", "400"], "--times-ms"),
    ],
)
def test_bad_input_is_one_line_exit_2(argv, message, capsys):
    code, err = run_bad(argv, capsys)
    assert code == 2
    assert err.count("\n") == 0 and message in err and "Traceback" not in err


def test_result_without_uncertainty_and_bad_covariance(tmp_path, capsys):
    folder = write_result(tmp_path / "r1", covariance=False)
    doc = json.loads((folder / "result.json").read_text())
    for entry in doc["parameters"].values():
        del entry["std"]
    (folder / "result.json").write_text(json.dumps(doc))
    code, err = run_bad([str(folder)], capsys)
    assert code == 2 and "--range" in err
    folder = write_result(tmp_path / "r2")
    doc = json.loads((folder / "result.json").read_text())
    doc["covariance"]["matrix"][0][1] = doc["covariance"]["matrix"][1][0] = 1e12  # not positive definite
    (folder / "result.json").write_text(json.dumps(doc))
    code, err = run_bad([str(folder)], capsys)
    assert code == 2 and "positive semi-definite" in err
    (folder / "result.json").write_text("{not json")
    code, err = run_bad([str(folder)], capsys)
    assert code == 2 and "not valid JSON" in err
    for bad, message in (("soft", "must have a finite numeric value"), (-5.0e5, "k_compression")):
        doc["parameters"]["k_compression"]["value"] = bad
        (folder / "result.json").write_text(json.dumps(doc))
        code, err = run_bad([str(folder)], capsys)
        assert code == 2 and message in err and str(folder) in err and err.count("\n") == 0


def test_a_users_folder_is_never_overwritten(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    code, err = run_bad(["--vehicle", "audi_a4", "--params", "paper_identified", "--out", str(out), *FAST], capsys)
    assert code == 2 and "not a sensitivity folder" in err
    assert (out / "notes.txt").read_text() == "keep me"


def test_discovered_mechanisms_and_vehicle_changes_are_rebuilt(tmp_path):
    """A result with a discovered rear-axle stiffness and a stiffness zone: the study's
    vehicle and parameters are the discovered model's, not the base one's."""
    from identify.commands.sensitivity import load_result
    from sim import load_params, load_vehicle

    folder = write_result(tmp_path / "r")
    doc = json.loads((folder / "result.json").read_text())
    doc["parameters"]["rear_axle_lift.rear_axle_stiffness"] = {"value": 12345.0, "unit": "N/m", "std": 100.0}
    doc["parameters"]["stiffness_zone.depth"] = {"value": 0.4, "unit": "m", "std": 0.01}
    doc["parameters"]["stiffness_zone.k_zone"] = {"value": 2.5e6, "unit": "N/m^3", "std": 1e5}
    doc["discoveries"].append({"effect": "rear_axle_lift", "window_ms": [38.0, 300.0], "parameters": {}})
    # the base model's engine on its mounts, as 'identify fit' writes what it assumed
    from identify.discover.candidates import assumed_in_base, superset_template

    base = load_vehicle("audi_a4")
    doc["fit"]["assumed"] = assumed_in_base(superset_template(load_params("paper_identified"), base), set())
    (folder / "result.json").write_text(json.dumps(doc))
    notes = []
    vehicle, params, speed, *_ = load_result(folder, None, notes)
    engine = {m.effect: m for m in params.mechanisms}["engine_impact"]
    assert float(engine.engine_mass) == 205.0 and float(engine.gap) == 10.0
    assert float(vehicle.axle_stiffness[1]) == 12345.0 and float(vehicle.axle_stiffness[0]) == float(base.axle_stiffness[0])
    zone = {m.effect: m for m in params.mechanisms}["stiffness_zone"]
    assert float(zone.depth) == 0.4 and float(zone.k_zone) == 2.5e6
    assert not any("rear_axle_lift" in n and "left out" in n for n in notes), notes
    assert speed == pytest.approx(56.3 / 3.6)


def test_result_with_stds_alone_holds_what_is_no_input(tmp_path):
    # without a covariance the parameters' std are sampled; the barrier face's friction has a
    # std in result.json but is no input of the study: held at its value, and said so
    folder = write_result(tmp_path / "r", covariance=False)
    assert main(["sensitivity", str(folder), *FAST]) == 0
    doc = json.loads((folder / "sensitivity" / "sensitivity.json").read_text())
    assert doc["source"]["sampling"] == "std"
    assert any("mu_face" in note for note in doc["notes"])
