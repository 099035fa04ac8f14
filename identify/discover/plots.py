"""Figures of a discovery (PNG, matplotlib Agg).

- ``discovery_residuals.png``: each channel's residual before discovery (base model) and
  after (every accepted mechanism), with the measurement's +-2 sigma band and each
  discovery's window shaded and labelled (``identify.report.plots.plot_residuals``);
- ``discovery_force_deflection.png``: the force-deflection curve the recording implies
  (F = -m a, a the smoothed second derivative of the measured x; crush from the measured
  x and pitch on the fitted force line) against the base model's and the final model's;
  with an unexplained effect, its estimated force over time below.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from identify.report.plots import WINDOW_COLOURS, plot_residuals  # noqa: E402


def implied_force_deflection(fr, vehicle):
    """(crush (m), force (N)) implied by the measured motion, contact samples only.

    Force from the measured x: F = -m a, a the second derivative of x from a cubic
    Savitzky-Golay filter over ~11 ms; crush = x + dz' sin(pitch) with the fitted dz'
    (when pitch is recorded; else crush = x)."""
    from scipy.signal import savgol_filter

    m = fr.measurement
    if "x_m" not in m.channels:
        return np.zeros(0), np.zeros(0)
    ok = m.valid("x_m")
    t, x = np.asarray(m.t)[ok], np.asarray(m.channels["x_m"])[ok]
    dt = float(np.median(np.diff(t)))
    win = max(5, int(round(0.011 / dt)) | 1)  # ~11 ms: passes the crash pulse, not the noise
    acc = savgol_filter(x, win, 3, deriv=2, delta=dt)
    x_c = x
    if "pitch_rad" in m.channels:
        pitch = np.interp(t, m.t[m.valid("pitch_rad")], np.asarray(m.channels["pitch_rad"])[m.valid("pitch_rad")])
        x_c = x + float(fr.params.dz_contact) * np.sin(pitch)
    keep = (t > 0.002) & (-acc > 0) & (x_c > 0)
    return np.where(keep, x_c, np.nan), np.where(keep, -float(vehicle.mass) * acc, np.nan)


def plot_discovery(result, out_dir, vehicle=None) -> list[str]:
    """Write the discovery figures into ``out_dir``; return their file names.

    Parameters
    ----------
    result : identify.discover.loop.DiscoveryResult.
    out_dir : folder (created if missing).
    vehicle : sim.Vehicle for the implied force (its mass); default: the force-deflection
        figure uses the mass implied by the fitted model (the A4's when unknown).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = [_residuals(result, out / "discovery_residuals.png").name]
    names.append(_force_deflection(result, out / "discovery_force_deflection.png", vehicle).name)
    return names


def _residuals(result, path: Path) -> Path:
    windows = [(d["effect"], *d["window_ms"]) for d in result.discoveries]
    return plot_residuals(result.final, path, windows=windows, before=result.start,
                          title=f"Residuals (measured - model): {result.status}")


def _force_deflection(result, path: Path, vehicle) -> Path:
    if vehicle is None:
        from sim import load_vehicle

        vehicle = load_vehicle("audi_a4")
    extra = result.missing is not None
    fig, axes = plt.subplots(2 if extra else 1, 1, figsize=(8, 8 if extra else 5), squeeze=False)
    ax = axes[0, 0]
    crush, force = implied_force_deflection(result.final, vehicle)
    ax.plot(crush, force / 1e3, ".", ms=2, color="0.3", label="implied by the recording (-m a)")
    curves = [(result.final, "tab:blue", f"fitted model ({result.final.model})")]
    if result.final.model != result.start.model or result.discoveries:
        curves.insert(0, (result.start, "tab:red", f"{result.start.model} model before discovery"))
    for fr, colour, label in curves:
        tr = fr.trajectory
        ax.plot(np.asarray(tr.crush), np.asarray(tr.force) / 1e3, color=colour, lw=1.5, label=label)
    for k, d in enumerate(result.discoveries):
        lo, hi = d.get("crush_window_m", [np.nan, np.nan])
        if np.isfinite(lo):
            ax.axvspan(lo, hi, color=WINDOW_COLOURS[k % len(WINDOW_COLOURS)], alpha=0.12, label=f"{d['effect']} (crush range)")
    ax.set_xlabel("crush (m)")
    ax.set_ylabel("barrier force (kN)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("Force-deflection: recording vs model", fontsize=9)
    if extra:
        mf = result.missing
        ax2 = axes[1, 0]
        ax2.fill_between(mf.t_ms, (mf.force_n - 2 * mf.force_std_n) / 1e3, (mf.force_n + 2 * mf.force_std_n) / 1e3,
                         color="tab:pink", alpha=0.3, label="+-2 sigma")
        ax2.plot(mf.t_ms, mf.force_n / 1e3, color="tab:pink", label="unexplained force (towards the barrier > 0)")
        ax2.axvspan(*mf.window_ms, color="tab:pink", alpha=0.1)
        ax2.set_xlabel("time after first contact (ms)")
        ax2.set_ylabel("force (kN)")
        ax2.grid(alpha=0.3)
        ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
