"""The README's main command end to end (slow: the video stage, the fit with its compile, a
results folder), and what reads its results. The sensor recording's end-to-end fit is in
``test_nhtsa.py``: on a module of its own worker (``pytest -n 2 --dist loadgroup``), the two
longest fits run side by side."""

import csv
import json

import numpy as np
import pytest

from conftest import SAMPLE_FILM


@pytest.mark.slow
def test_sample_film_gives_the_parameters_it_was_made_with(sample_results):
    from sim import named_params

    truth_doc = json.loads(SAMPLE_FILM.with_suffix(".truth.json").read_text())
    truth = named_params(truth_doc["params"])
    doc = json.loads((sample_results / "result.json").read_text())
    p = doc["parameters"]
    tolerance = {"k_compression": ("rel", 0.03), "k_restitution": ("rel", 0.03),
                 "restitution": ("abs", 0.02), "dz_contact": ("abs", 0.03)}  # fmt: skip
    for name, (kind, tol) in tolerance.items():
        true = float(getattr(truth, name))
        err = p[name]["value"] - true
        assert abs(err) <= (tol * abs(true) if kind == "rel" else tol), (name, p[name]["value"], true)
        assert abs(err) <= 2 * p[name]["std_data"], (name, err, p[name]["std_data"])  # its own model: no model error
        # the model's own error on other cars' recordings: k_restitution's outweighs the data
        assert p[name]["identified"] is (name != "k_restitution"), (name, p[name])
    # the contact height's error is the one measured where the rear wheels lift (the sample's model lifts them at 38 ms)
    assert "rear wheels lift" in p["dz_contact"]["std_model_measured"]
    assert doc["impact_speed_kmh"] == pytest.approx(truth_doc["impact_speed_kmh"], rel=0.005)
    # Fit RMS at the level of the tracking noise: the tracker's own x sigma.
    with open(sample_results / "tracks.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    x_sigma = np.median([float(r["x_sigma_m"]) for r in rows])
    assert doc["fit"]["rms_m"] < 2.0 * x_sigma
    for name in ("tracks.csv", "displacement_velocity.png", "residuals.png", "silhouettes.png", "overlay.png",
                 "discovery_residuals.png", "discovery_force_deflection.png", "report.md"):
        assert (sample_results / name).stat().st_size > 100, name
    # nothing is hidden in the sample film: discovery tries the candidates and accepts none
    assert doc["discoveries"] == [] and doc["fit"]["model"] == "base"
    # the base model's engine on its mounts (the sample was made with it) is said to be assumed, with its mass
    (assumed,) = doc["fit"]["assumed"]
    assert assumed["effect"] == "engine_impact" and assumed["parameters"]["engine_mass"]["value"] == 205.0
    assert "Assumed, not fitted (`engine_impact`)" in (sample_results / "report.md").read_text()
    assert not any(t["accepted"] for r in doc["discovery_rounds"] for t in r)
    assert doc["discovery_status"].startswith("no missing physics")
    # issue 16: the report counts the 5 starts of the fit (not the 1 of discovery's refit),
    # and the film agrees with the vehicle file: no warning
    assert doc["fit"]["starts"] == 5 and " of 5 starting points reached the best fit" in (sample_results / "report.md").read_text()
    assert "warnings" not in doc
    # the barrier face's friction is fitted (identify fit's default); the sample, drawn by our model
    # without it, slides its nose down the face and the fit finds none (a wiring check, not accuracy)
    face = doc["parameters"]["mu_face"]
    assert 0.0 <= face["value"] < 0.01 and face["std"] > 0 and face["note"].startswith("at its physical floor")


@pytest.mark.slow
@pytest.mark.parametrize("source", ["predictions.csv", "re-simulated from result.json"])
def test_notebook_on_the_sample_fit(sample_results, tmp_path, source):
    """notebooks/residuals.ipynb (tests/test_notebook.py) on the sample's results folder, with
    the model from its predictions.csv and, for a folder without one, re-simulated from
    result.json: the same RMS as the fit's. (Here, beside the other readers of the sample's
    fit, so that one worker of ``pytest -n 2 --dist loadgroup`` fits the sample once.)"""
    import shutil

    folder = sample_results
    if source != "predictions.csv":
        folder = tmp_path / "no_predictions.identify"
        shutil.copytree(sample_results, folder)
        (folder / "predictions.csv").unlink()
    from test_notebook import outputs, run_notebook

    nb, summary = run_notebook(folder, tmp_path / "summary.json")
    doc = json.loads((folder / "result.json").read_text())
    assert summary["model_source"] == source
    assert set(summary["channels"]) == set(doc["fit"]["rms_by_channel"])
    for c, ref in doc["fit"]["rms_by_channel"].items():
        s = summary["channels"][c]
        assert s["rms"] == pytest.approx(ref, rel=1e-4), c
        assert s["windows"]["all"]["rms"] == pytest.approx(s["rms"], rel=1e-12)
        assert 0.2 < s["std_norm"] < 2.0, c  # residuals of the order of the tracker's sigma
    assert not summary["channels"]["vx_mps"]["fitted"] and summary["channels"]["x_m"]["fitted"]
    comp_end = summary["windows_ms"]["compression"][1]
    assert comp_end == pytest.approx(doc["model_events_ms"]["compression_end"])
    assert 60 < comp_end < 70  # the paper's set compresses for about 65 ms
    assert len([o for o in outputs(nb, "display_data") if "image/png" in o.data]) == 3
    assert not outputs(nb, "error")
