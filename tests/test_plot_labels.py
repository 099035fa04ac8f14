"""The figures say what they show (issue 16): the force-deflection plot's curves have
distinct labels, every silhouette panel has its X scale, the residual plot names its grey
band; and every plot of a fit, a force check, a sensitivity study and a comparison: axes
with their units (the curves drawn in them), each curve named distinctly, as many curves,
panels and bars as inputs."""

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
    from identify.discover.plots import _force_deflection

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
    from identify.report.plots import plot_silhouettes

    plot_silhouettes(fake_fit, a4, None, tmp_path / "s.png")
    fig = figures[-1]
    fig.canvas.draw()
    assert len(fig.axes) > 1
    for ax in fig.axes:
        assert any(t.get_visible() and t.get_text() for t in ax.get_xticklabels()), ax.get_ylabel()


def test_the_residual_plots_grey_band_is_named(fake_fit, tmp_path, figures):
    from identify.report.plots import plot_residuals

    plot_residuals(fake_fit, tmp_path / "r.png")
    fig = figures[-1]
    assert "measurement +-2 sigma" in legend_texts(fig.axes[0])
    assert "grey band" in fig.axes[-1].get_xlabel()


def test_force_crush_shows_each_body_of_a_two_body_model(tmp_path, figures):
    """Force vs crush of a two-body model: the whole barrier force, the structure's against
    the cabin's crush and the engine block's against its own crush, each named, with axis
    units; a one-body model draws only the whole force."""
    from identify.report.force_check import plot_force_crush

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


def lines_by_label(ax):
    """The axes' labelled curves (matplotlib's own ``_child`` names left out), label -> Line2D."""
    return {line.get_label(): line for line in ax.get_lines() if not line.get_label().startswith("_")}


def drawn_axes(fig):
    """The panels that show something (a grid's unused cells are switched off)."""
    return [ax for ax in fig.axes if ax.axison]


# ---------------------------------------------------------------- identify.report.plots


def test_displacement_velocity_names_each_curve_with_units(fake_fit, default_run, tmp_path, figures):
    """Fig. 6: x over v, each panel's measured, fitted and V-SIM default curves named, the
    axes in m, m/s and ms (the curves drawn in those units); without a default run, no
    default curve."""
    from identify.report.plots import plot_displacement_velocity

    shifted = SimpleNamespace(**{**vars(fake_fit), "contact_time": 0.003})  # contact 3 ms into the recording
    plot_displacement_velocity(shifted, default_run, tmp_path / "dv.png")
    ax_x, ax_v = figures[-1].axes
    assert ax_x.get_ylabel() == "displacement x (m)" and ax_v.get_ylabel() == "velocity v (m/s)"
    assert ax_v.get_xlabel() == "time since first contact (ms)"
    x_curves, v_curves = lines_by_label(ax_x), lines_by_label(ax_v)
    assert list(x_curves) == legend_texts(ax_x) == ["measured", "fitted (base)", "V-SIM default parameters"]
    # no vx channel in the measurement: the measured velocity is said to be derived from x
    assert list(v_curves) == legend_texts(ax_v) == ["measured (CFC 180 derivative of x)", "fitted (base)",
                                                    "V-SIM default parameters"]  # fmt: skip
    m = fake_fit.measurement
    np.testing.assert_allclose(x_curves["measured"].get_xdata(), m.t * 1e3)  # ms
    np.testing.assert_allclose(x_curves["measured"].get_ydata(), m.channels["x_m"])  # m
    # both model runs start at their own contact: drawn on the recording's clock
    np.testing.assert_allclose(v_curves["fitted (base)"].get_xdata(), (np.asarray(fake_fit.trajectory.t) + 0.003) * 1e3)
    np.testing.assert_allclose(v_curves["V-SIM default parameters"].get_xdata(), (np.asarray(default_run.t) + 0.003) * 1e3)
    np.testing.assert_allclose(v_curves["V-SIM default parameters"].get_ydata(), np.asarray(default_run.vx))

    plot_displacement_velocity(fake_fit, None, tmp_path / "dv1.png")
    ax_x, ax_v = figures[-1].axes
    assert legend_texts(ax_x) == ["measured", "fitted (base)"] and len(legend_texts(ax_v)) == 2


def test_residual_panels_carry_their_units_and_name_both_fits(fake_fit, tmp_path, figures):
    """One panel per fitted channel, its axis in the channel's plotting unit (mm, deg) and
    the residual drawn in it; with a ``before`` fit both fits are named with their RMS; the
    discovery windows are named; the title is shown."""
    from identify.report.plots import plot_residuals

    before = SimpleNamespace(**{**vars(fake_fit), "model": "base before", "rms": {c: 0.002 for c in fake_fit.rms}})
    windows = [("engine block", 40.0, 60.0), ("stiffness zone", 100.0, 120.0)]
    plot_residuals(fake_fit, tmp_path / "r.png", windows=windows, before=before, title="a4, 56.3 km/h")
    fig = figures[-1]
    units = {"x_m": "x (mm)", "z_m": "z (mm)", "pitch_rad": "pitch (deg)",
             "front_wheel_angle_rad": "front wheel angle (deg)", "rear_wheel_angle_rad": "rear wheel angle (deg)"}
    assert [ax.get_ylabel() for ax in fig.axes] == [units[c] for c in fake_fit.predictions]
    assert fig.axes[0].get_title(loc="left") == "x: RMS 1 mm" and fig.axes[2].get_title(loc="left").endswith(" deg")
    assert fig.axes[-1].get_xlabel().startswith("time since first contact (ms)")
    assert fig.get_suptitle() == "a4, 56.3 km/h"
    assert legend_texts(fig.axes[0]) == ["measurement +-2 sigma", "base before: RMS 2 mm", "base: RMS 1 mm"]
    for ax in fig.axes:  # both fits' residual curves in every panel
        assert len(lines_by_label(ax)) == 2
    m = fake_fit.measurement
    mm = lines_by_label(fig.axes[0])["base: RMS 1 mm"].get_ydata()
    np.testing.assert_allclose(mm, m.channels["x_m"][m.valid("x_m")] * 1e3)  # drawn in mm, as labelled
    assert [t.get_text() for t in fig.axes[0].texts] == ["engine block", "stiffness zone"]


def test_silhouettes_panels_are_the_measured_times_and_name_three_outlines(fake_fit, a4, default_run, tmp_path,
                                                                          figures):  # fmt: skip
    """One panel per requested time inside the measurement, each named by its time; the
    legend names the fitted, measured and V-SIM default outlines; X in metres."""
    from identify.report.plots import plot_silhouettes

    plot_silhouettes(fake_fit, a4, default_run, tmp_path / "s.png", times_ms=(0, 100, 250, 400))
    fig = figures[-1]
    assert [ax.get_ylabel() for ax in fig.axes] == ["0 ms", "100 ms", "250 ms"]  # 400 ms is past the film
    assert legend_texts(fig.axes[0]) == ["fitted model", "measured pose", "V-SIM defaults"]
    assert fig.axes[-1].get_xlabel().startswith("X (m)")
    for ax in fig.axes:
        assert len(ax.patches) == 1 and set(lines_by_label(ax)) == {"measured pose", "V-SIM defaults"}
    plot_silhouettes(fake_fit, a4, None, tmp_path / "s1.png")
    assert legend_texts(figures[-1].axes[0]) == ["fitted model", "measured pose"]


# ---------------------------------------------------------------- identify.report.force_check


def test_force_time_names_measured_predicted_and_comparison_curves(tmp_path, figures):
    """Measured and predicted force named, in kN against ms; the rigid-body and base-model
    curves named (the base model by ``base_label``) when given; the comparison's scores and
    the title above."""
    from identify.report.force_check import plot_force_time

    t = np.linspace(0.0, 120.0, 121)
    measured = 3e5 * np.sin(np.pi * t / 120.0)
    predicted, base, rigid = 0.9 * measured, 0.7 * measured, 1.1 * measured
    plot_force_time(tmp_path / "a.png", t, measured, predicted)
    ax = figures[-1].axes[0]
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("time after first contact (ms)", "contact force (kN)")
    curves = lines_by_label(ax)
    assert list(curves) == legend_texts(ax) == ["measured (barrier load cells, CFC 60)", "predicted (model, same CFC)"]
    np.testing.assert_allclose(curves["measured (barrier load cells, CFC 60)"].get_ydata(), measured / 1e3)  # kN
    np.testing.assert_allclose(curves["predicted (model, same CFC)"].get_xdata(), t)
    assert ax.get_title() == ""

    comparison = SimpleNamespace(peak_error=-0.1, impulse_error=0.05, iso18571=SimpleNamespace(overall=0.8))
    plot_force_time(tmp_path / "b.png", t, measured, predicted, comparison, title="10146", rigid=(t, rigid),
                    base=(t, base), base_label="one-body model")  # fmt: skip
    ax = figures[-1].axes[0]
    labels = legend_texts(ax)
    assert len(labels) == len(set(labels)) == 4 == len(lines_by_label(ax))
    assert "test mass x measured deceleration (a rigid car, CFC 60)" in labels
    assert "one-body model (same CFC)" in labels
    np.testing.assert_allclose(lines_by_label(ax)["one-body model (same CFC)"].get_ydata(), base / 1e3)
    assert ax.get_title() == "10146\npeak -10.0%, impulse +5.0%, ISO 18571 rating 0.80"
    plot_force_time(tmp_path / "c.png", t, measured, predicted, base=(t, base))  # the default label
    assert "base model, before discovery (same CFC)" in legend_texts(figures[-1].axes[0])
    two = 0.95 * measured
    plot_force_time(tmp_path / "d.png", t, measured, predicted, two_body=(t, two), two_body_label="cabin + engine")
    curves = lines_by_label(figures[-1].axes[0])
    assert list(curves) == legend_texts(figures[-1].axes[0]) == [
        "cabin + engine", "measured (barrier load cells, CFC 60)", "predicted (model, same CFC)"]
    np.testing.assert_allclose(curves["cabin + engine"].get_ydata(), two / 1e3)


def test_force_crush_draws_in_the_units_it_names(tmp_path, figures):
    """Force against crush: the curves in kN and m as the axes say, the title shown."""
    from identify.report.force_check import plot_force_crush

    d = np.linspace(0.0, 0.6, 50)
    plot_force_crush(tmp_path / "fc.png", d, 8e5 * d, 0.9 * d, 7e5 * d, title="10146")
    ax = figures[-1].axes[0]
    curves = lines_by_label(ax)
    assert list(curves) == legend_texts(ax) == ["measured (barrier load cells)", "predicted, whole barrier"]
    np.testing.assert_allclose(curves["measured (barrier load cells)"].get_ydata(), 8e2 * d)
    np.testing.assert_allclose(curves["predicted, whole barrier"].get_xdata(), 0.9 * d)
    assert ax.get_title() == "10146"


# ---------------------------------------------------------------- identify.sensitivity


@pytest.fixture(scope="module")
def fake_local():
    """A LocalSensitivity with made-up derivatives; one output that does not happen."""
    from identify.sensitivity import INPUT_NAMES, LocalSensitivity
    from sim.outputs import output_names

    names = tuple(output_names())
    rng = np.random.default_rng(1)
    outputs = rng.uniform(0.1, 1.0, len(names))
    outputs[names.index("rear_wheel_touchdown_time")] = np.nan
    derivative = rng.normal(size=(len(names), len(INPUT_NAMES)))
    return LocalSensitivity(INPUT_NAMES, names, np.ones(len(INPUT_NAMES)), outputs, derivative,
                            np.full_like(derivative, np.nan))  # fmt: skip


def test_tornado_has_one_labelled_bar_pair_per_input(fake_local, tmp_path, figures):
    """A panel per asked output that happens, titled with its name and value; in each, one
    -/+ bar pair per input given a spread, labelled with the input (fixed ones said so), of
    length derivative x spread, the largest on top; the legend names + and - spread."""
    from identify.sensitivity import plot_tornado

    spread = {n: 0.5 + k for k, n in enumerate(fake_local.input_names) if n != "rolling_resistance"}
    shown = ["max_crush", "rebound_speed", "x_at_100ms"]
    units = {"max_crush": "m", "rebound_speed": "m/s", "x_at_100ms": "m", "rear_wheel_touchdown_time": "s"}
    plot_tornado(fake_local, spread, tmp_path / "t.png", units, outputs=shown + ["rear_wheel_touchdown_time"],
                 fixed={"mass"})
    panels = drawn_axes(figures[-1])
    assert [ax.get_title().split(" = ")[0] for ax in panels] == shown
    assert legend_texts(panels[0]) == ["+ spread", "- spread"]
    for ax, name in zip(panels, shown):
        i = fake_local.output_names.index(name)
        assert ax.get_title() == f"{name} = {fake_local.outputs[i]:.4g} {units[name]}"
        assert ax.get_xlabel() == f"{name} [{units[name]}]"
        ticks = [t.get_text() for t in ax.get_yticklabels()]
        expected = {n + (" (fixed)" if n == "mass" else "") for n in spread}
        assert len(ticks) == len(expected) and set(ticks) == expected
        assert len(ax.patches) == 2 * len(spread)
        change = {n: fake_local.derivative[i, fake_local.input_names.index(n)] * s for n, s in spread.items()}
        plus = ax.containers[0]
        for tick, bar in zip(ticks, plus):  # bars at the ticks' heights, in tick order
            assert bar.get_width() == pytest.approx(change[tick.removesuffix(" (fixed)")])
        assert ticks[-1].removesuffix(" (fixed)") == max(change, key=lambda n: abs(change[n]))
        assert {round(b.get_alpha(), 2) for b, tick in zip(plus, ticks) if tick == "mass (fixed)"} == {0.3}


def test_distributions_have_a_panel_per_output_with_its_unit(tmp_path, figures):
    """A histogram per output seen more than once, titled with its name, unit and (if it
    does not always happen) how often; the median and 90 % interval marked at their values."""
    from identify.sensitivity import plot_distributions, summarise

    names = ["max_crush", "time_of_max_crush", "rebound_speed", "rear_wheel_lift_time"]
    units = {"max_crush": "m", "time_of_max_crush": "s", "rebound_speed": "m/s", "rear_wheel_lift_time": "s"}
    rng = np.random.default_rng(2)
    outputs = rng.normal([0.6, 0.07, 2.0, 0.1], [0.02, 0.003, 0.1, 0.01], size=(200, 4))
    outputs[:, 3] = np.nan  # never happens: no panel
    outputs[::2, 2] = np.nan  # happens in half the runs
    summary = summarise(outputs, names)
    plot_distributions(outputs, names, units, summary, tmp_path / "d.png")
    fig = figures[-1]
    panels = drawn_axes(fig)
    assert [ax.get_title() for ax in panels] == ["max_crush [m]", "time_of_max_crush [s]",
                                                 "rebound_speed [m/s], happens in 50 %"]  # fmt: skip
    for ax, name in zip(panels, names):
        assert len(ax.patches) == 60  # the histogram
        marks = sorted(line.get_xdata()[0] for line in ax.get_lines())
        lo, hi = summary[name]["interval_90"]
        np.testing.assert_allclose(marks, [lo, summary[name]["median"], hi])
    assert "median and 90 % interval" in fig.get_suptitle()


# ---------------------------------------------------------------- identify.report.comparison


def test_comparison_histories_name_both_runs_with_units(identified_run, default_run, tmp_path, figures):
    """X and V of both runs, each curve named by its run, axes in ms, m and m/s; the
    position difference on its own axis, named as b - a, in m."""
    from identify.report.comparison import plot_histories

    plot_histories(identified_run, default_run, ("identified", "default"), tmp_path / "h.png", title="A4")
    fig = figures[-1]
    ax_x, ax_v, twin = fig.axes
    assert (ax_x.get_xlabel(), ax_x.get_ylabel()) == ("t [ms]", "displacement X [m]")
    assert (ax_v.get_xlabel(), ax_v.get_ylabel()) == ("t [ms]", "velocity V [m/s]")
    assert twin.get_ylabel() == "position difference dX [m]"
    assert legend_texts(ax_x) == ["identified", "default"] and list(lines_by_label(ax_x)) == ["identified", "default"]
    assert legend_texts(ax_v) == ["identified", "default"]
    assert list(lines_by_label(ax_v)) == ["identified", "default"]
    assert legend_texts(twin) == ["dX = default - identified"]
    dx = lines_by_label(twin)["dX = default - identified"]
    np.testing.assert_allclose(dx.get_ydata(), np.asarray(default_run.x) - np.asarray(identified_run.x))
    np.testing.assert_allclose(dx.get_xdata(), np.asarray(identified_run.t) * 1e3)  # ms, as labelled
    assert [ax.get_title() for ax in (ax_x, ax_v)] == ["(a) displacement", "(b) velocity"]
    assert fig.get_suptitle() == "A4"


def test_comparison_silhouettes_a_panel_per_time_with_both_runs(a4, identified_run, default_run, tmp_path, figures):
    """One panel per time inside the runs, titled with it; both runs' outlines in each,
    named by their runs in the legend."""
    from matplotlib.patches import Polygon

    from identify.report.comparison import plot_silhouettes

    plot_silhouettes(a4, identified_run, default_run, ("identified", "default"), tmp_path / "c.png",
                     times=(0.05, 0.15, 0.3, 0.5), title="A4")  # fmt: skip
    fig = figures[-1]
    panels = drawn_axes(fig)
    assert [ax.get_title() for ax in panels] == ["(a) t = 50 ms", "(b) t = 150 ms", "(c) t = 300 ms"]
    assert sorted(legend_texts(panels[0])) == sorted(["identified", "default", "barrier", "identified: top of the windscreen",
                                                      "default: top of the windscreen"])
    for ax in panels:
        outlines = [p.get_label() for p in ax.patches if isinstance(p, Polygon)]
        assert outlines == ["identified", "default"]
        assert ax.get_xlabel() == "X (m)" and ax.get_ylabel() == "Z (m)"
    assert fig.get_suptitle() == "A4"
