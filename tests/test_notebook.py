"""notebooks/residuals.ipynb runs on a results folder and computes what it says it does.

The notebook is executed with nbclient (kernel ``python3`` from ipykernel), its parameters
injected in a cell after the one tagged ``parameters`` (papermill's convention); it writes
its statistics to ``SUMMARY_JSON``, which the tests read.
"""

import json
import math
from pathlib import Path

import nbclient
import nbformat
import numpy as np
import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "notebooks" / "residuals.ipynb"


def run_notebook(results: Path, summary: Path):
    """Execute the notebook on ``results``; return (executed notebook, summary dict)."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    i = next(i for i, c in enumerate(nb.cells) if "parameters" in c.metadata.get("tags", []))
    injected = nbformat.v4.new_code_cell(f"RESULTS = {str(results)!r}\nSUMMARY_JSON = {str(summary)!r}")
    injected.metadata["tags"] = ["injected-parameters"]
    nb.cells.insert(i + 1, injected)
    client = nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})  # fmt: skip
    client.execute()
    return nb, json.loads(summary.read_text())


def outputs(nb, kind):
    return [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == kind]


def test_committed_notebook_is_clean_and_parametrised():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(not c.outputs and c.execution_count is None for c in code), "clear the outputs before committing"
    params = [c for c in code if "parameters" in c.metadata.get("tags", [])]
    assert len(params) == 1 and "RESULTS =" in params[0].source and "SUMMARY_JSON =" in params[0].source
    assert sum(c.cell_type == "markdown" for c in nb.cells) >= 6  # says what to look at, section by section


def _synthetic_results(folder: Path, rng) -> dict:
    """A results folder whose residuals are known: x white N(0, 1) sigmas, pitch AR(1) with
    phi = 0.8, z white plus a +2 sigma bias during compression; per-sample sigmas vary; one
    x sample is unmeasured. The model comes as predictions.csv."""
    folder.mkdir()
    t_ms = np.arange(-20.0, 201.0)
    n = len(t_ms)
    comp_end, sep = 65.0, 150.0
    sig = {"x_m": 1e-3 * (1 + 0.5 * np.sin(t_ms / 7)), "z_m": np.full(n, 2e-3), "pitch_rad": np.full(n, 3e-3)}
    ar = np.zeros(n)
    e = rng.normal(0, math.sqrt(1 - 0.8**2), n)
    ar[0] = rng.normal()
    for k in range(1, n):
        ar[k] = 0.8 * ar[k - 1] + e[k]
    z_norm = rng.normal(0, 1, n) + np.where((t_ms >= 0) & (t_ms < comp_end), 2.0, 0.0)
    norm = {"x_m": rng.normal(0, 1, n), "z_m": z_norm, "pitch_rad": ar}
    measured = {"x_m": 15.6 * t_ms / 1e3, "z_m": 0.01 * np.sin(t_ms / 40), "pitch_rad": 0.1 * np.sin(t_ms / 60)}
    model = {c: measured[c] - norm[c] * sig[c] for c in measured}
    measured["x_m"][5] = np.nan
    cols = {"t_ms": t_ms, **measured, "x_sigma_m": sig["x_m"], "z_sigma_m": sig["z_m"], "pitch_sigma_rad": sig["pitch_rad"]}
    write = lambda path, d: path.write_text(  # noqa: E731
        ",".join(d) + "\n" + "\n".join(",".join(f"{v:.12g}" for v in row) for row in zip(*d.values())) + "\n"
    )
    write(folder / "tracks.csv", cols)
    write(folder / "predictions.csv", {"t_ms": t_ms, **model})
    valid = {c: np.isfinite(measured[c]) for c in measured}
    rms = {c: float(np.sqrt(np.mean(((measured[c] - model[c])[valid[c]]) ** 2))) for c in measured}
    doc = {
        "vehicle": "audi_a4", "vehicle_name": "synthetic", "recording": "synthetic", "recording_kind": "tracks",
        "impact_speed_kmh": 56.2, "speed_mps": 56.2 / 3.6, "contact_time_ms": 0.0,
        "parameters": {"k_compression": {"value": 970e3, "unit": "N/m^3", "std": 1e3}},
        "fit": {"model": "base", "rms_by_channel": rms, "reduced_chi2": 1.0, "dof": 3 * n - 7},
        "model_events_ms": {"compression_end": comp_end, "separation": sep},
    }  # fmt: skip
    (folder / "result.json").write_text(json.dumps(doc))
    return {"t_ms": t_ms, "rms": rms, "valid": valid, "pitch_norm": ar}


def test_statistics_on_known_residuals(tmp_path):
    truth = _synthetic_results(tmp_path / "synthetic.identify", np.random.default_rng(1))
    nb, summary = run_notebook(tmp_path / "synthetic.identify", tmp_path / "summary.json")
    assert summary["model_source"] == "predictions.csv"
    ch = summary["channels"]
    for c, rms in truth["rms"].items():
        assert ch[c]["rms"] == pytest.approx(rms, rel=1e-8)
        assert ch[c]["fitted"]
        # the windows split the measured samples without overlap or loss
        assert sum(ch[c]["windows"][w]["n"] for w in ("before contact", "compression", "restitution",
                                                       "after separation")) == truth["valid"][c].sum()  # fmt: skip
    t = truth["t_ms"]
    assert ch["z_m"]["windows"]["before contact"]["n"] == np.sum(t < 0)
    assert ch["z_m"]["windows"]["compression"]["n"] == np.sum((t >= 0) & (t < 65))
    assert ch["z_m"]["windows"]["after separation"]["n"] == np.sum(t >= 150)
    # white residual: unit spread in sigmas (with per-sample sigma), no correlation
    assert ch["x_m"]["std_norm"] == pytest.approx(1.0, abs=0.12)
    assert ch["x_m"]["tau"] < 1.6 and abs(ch["x_m"]["lag1"]) < 0.2
    # AR(1), phi 0.8: the series' own lag-1 autocorrelation; correlation time near (1 + phi) / (1 - phi) = 9
    r = truth["pitch_norm"] - truth["pitch_norm"].mean()
    assert ch["pitch_rad"]["lag1"] == pytest.approx(float(r[:-1] @ r[1:] / (r @ r)), rel=1e-6)
    assert ch["pitch_rad"]["lag1"] > 0.5 and ch["pitch_rad"]["tau"] > 4
    # the bias shows in its window only
    zw = ch["z_m"]["windows"]
    assert zw["compression"]["mean_norm"] == pytest.approx(2.0, abs=0.35)
    for w in ("before contact", "restitution", "after separation"):
        assert abs(zw[w]["mean_norm"]) < 0.5, w
    assert zw["compression"]["rms_norm"] > 1.8 > zw["restitution"]["rms_norm"]
    assert len([o for o in outputs(nb, "display_data") if "image/png" in o.data]) == 3


def test_a_folder_that_is_not_a_results_folder_is_named_in_one_line(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(nbclient.exceptions.CellExecutionError) as info:
        run_notebook(tmp_path / "empty", tmp_path / "summary.json")
    assert "is not a results folder (no result.json)" in str(info.value)
    assert not (tmp_path / "summary.json").exists()
