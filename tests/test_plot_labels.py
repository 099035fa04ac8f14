"""The figures say what they show (issue 16): the force-deflection plot's curves have
distinct labels, every silhouette panel has its X scale, the residual plot names its grey
band."""

from types import SimpleNamespace

import numpy as np
import pytest

from helpers import synthetic_measurement
from sim import named_params


@pytest.fixture(scope="module")
def fake_fit(a4, identified_run):
    m = synthetic_measurement(a4, named_params("paper_identified"))
    return SimpleNamespace(measurement=m, predictions={c: np.zeros_like(v) for c, v in m.channels.items()},
                           rms={c: 0.001 for c in m.channels}, model="base", trajectory=identified_run,
                           contact_time=0.0, params=named_params("paper_identified"))  # fmt: skip


def legend_texts(ax):
    legend = ax.get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend is not None else []


def test_force_deflection_curves_have_distinct_labels(fake_fit, a4, tmp_path, figures):
    from identify.discovery_plots import _force_deflection

    final = SimpleNamespace(**{**vars(fake_fit), "model": "base+stiffness_zone"})
    found = SimpleNamespace(final=final, start=fake_fit, discoveries=[], missing=None)
    _force_deflection(found, tmp_path / "a.png", a4)
    labels = legend_texts(figures[-1].axes[0])
    assert "base model before discovery" in labels and "fitted model (base+stiffness_zone)" in labels
    assert len(set(labels)) == len(labels)
    nothing = SimpleNamespace(final=fake_fit, start=fake_fit, discoveries=[], missing=None)
    _force_deflection(nothing, tmp_path / "b.png", a4)  # nothing discovered: one model curve
    labels = legend_texts(figures[-1].axes[0])
    assert labels.count("fitted model (base)") == 1 and not any("before discovery" in t for t in labels)


def test_every_silhouette_panel_has_x_ticks(fake_fit, a4, tmp_path, figures):
    from identify.plots import plot_silhouettes

    plot_silhouettes(fake_fit, a4, None, tmp_path / "s.png")
    fig = figures[-1]
    fig.canvas.draw()
    assert len(fig.axes) > 1
    for ax in fig.axes:
        assert any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()), ax.get_ylabel()


def test_the_residual_plots_grey_band_is_named(fake_fit, tmp_path, figures):
    from identify.plots import plot_residuals

    plot_residuals(fake_fit, tmp_path / "r.png")
    fig = figures[-1]
    assert "measurement +-2 sigma" in legend_texts(fig.axes[0])
    assert "grey band" in fig.axes[-1].get_xlabel()


def test_force_crush_shows_each_body_of_a_two_body_model(tmp_path, figures):
    """Force vs crush of a two-body model: the whole barrier force, the structure's against
    the cabin's crush and the engine block's against its own crush, each named, with axis
    units; a one-body model draws only the whole force."""
    from identify.force_check import plot_force_crush

    d = np.linspace(0.0, 0.6, 50)
    f_e = np.where(d > 0.3, 2e6 * (d - 0.3), 0.0)
    f_s = 8e5 * d
    plot_force_crush(tmp_path / "two.png", d, f_s + f_e, d, f_s + f_e, engine=(np.maximum(d - 0.3, 0.0), f_e, f_s))
    ax = figures[-1].axes[0]
    labels = legend_texts(ax)
    assert len(labels) == 4 and len(set(labels)) == 4
    assert any("engine" in t for t in labels) and any("structure" in t for t in labels)
    assert ax.get_xlabel() == "crush (m)" and "(kN)" in ax.get_ylabel()
    engine_line = next(line for line in ax.get_lines() if "engine" in line.get_label())
    assert np.all(np.asarray(engine_line.get_xdata()) > 0)  # drawn only where the engine touches
    plot_force_crush(tmp_path / "one.png", d, f_s, d, f_s)
    assert len(legend_texts(figures[-1].axes[0])) == 2
