"""Outputs of the video stage: ``tracks.csv`` and the tracking report (PNG).

``tracks.csv`` (docs/interface.md): one row per frame; ``t_ms`` first (0 = first
contact), then ``x_m, z_m, pitch_rad``, the other channels (crush, wheel angles and
heights, per-target pixel centres), then one sigma column per channel named with
``_sigma`` before the unit (``x_sigma_m``, ``pitch_sigma_rad``, ``target0_u_sigma_px``).
Values that were not measured (a lost target) are written ``nan``. Last, the column
``length_scale_sigma``: the scale's relative one-sigma uncertainty (the same in every row),
an error common to every length of the film, which the length channels' own sigmas leave out.

The report (``tracking_report.png``): the reference frame with the tapes, the targets
(labelled with what they were found to be), the fitted silhouette and the CG drawn on
it; below, the measured channels over time with their +-2 sigma band and the events.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from video.types import Tracks

__all__ = ["FIXED_COLUMNS", "LENGTH_SCALE_COLUMN", "sigma_name", "column_order", "tracks_csv", "write_tracks_csv",
           "write_report"]

FIXED_COLUMNS = ("x_m", "z_m", "pitch_rad")
LENGTH_SCALE_COLUMN = "length_scale_sigma"  # the scale's relative sigma, after the sigma columns
_PREFERRED = ("crush_m", "vx_mps", "front_wheel_angle_rad", "rear_wheel_angle_rad",
              "front_wheel_height_m", "rear_wheel_height_m")


def sigma_name(column: str) -> str:
    """Name of the sigma column of a channel: ``x_m`` -> ``x_sigma_m``."""
    base, _, unit = column.rpartition("_")
    return f"{base}_sigma_{unit}" if base else f"{column}_sigma"


def column_order(tracks: Tracks) -> list[str]:
    """Channel names in file order: fixed ones, the usual extras, then the rest (targets)."""
    names = [c for c in FIXED_COLUMNS if c in tracks.channels]
    names += [c for c in _PREFERRED if c in tracks.channels]
    names += [c for c in tracks.channels if c not in names]
    return names


def tracks_csv(tracks: Tracks) -> str:
    """The text of ``tracks.csv`` for ``tracks``.

    Returns
    -------
    str
        Header line and one line per frame; ``t_ms`` to 1e-6 ms, values to 9
        significant digits, ``nan`` where not measured.
    """
    names = column_order(tracks)
    cols = [np.asarray(tracks.t, float) * 1e3]
    cols += [np.asarray(tracks.channels[c], float) for c in names]
    cols += [np.asarray(tracks.sigma.get(c, np.full(len(tracks.t), np.nan)), float)
             for c in names]
    cols.append(np.full(len(tracks.t), tracks.scale_sigma / tracks.scale_m_per_px))
    header = ["t_ms"] + names + [sigma_name(c) for c in names] + [LENGTH_SCALE_COLUMN]
    buf = io.StringIO()
    buf.write(",".join(header) + "\n")
    data = np.stack(cols, axis=1)
    for row in data:
        buf.write(f"{row[0]:.6f}," + ",".join("nan" if not np.isfinite(v) else f"{v:.9g}"
                                               for v in row[1:]) + "\n")
    return buf.getvalue()


def write_tracks_csv(tracks: Tracks, path: str | Path) -> Path:
    """Write ``tracks.csv`` to ``path`` (the caller makes it atomic); return the path."""
    path = Path(path)
    path.write_text(tracks_csv(tracks))
    return path


_KIND_COLOUR = {"body": "tab:green", "front_hub": "tab:orange", "rear_hub": "tab:orange",
                "fixed": "tab:blue", "other": "tab:red"}


def write_report(tracks: Tracks, out_dir: str | Path, film=None, car=None) -> Path:
    """Draw the tracking report into ``out_dir/tracking_report.png``.

    Parameters
    ----------
    tracks : Tracks
        With ``overlay`` filled by ``video.track.track_film``.
    out_dir : str or Path
        Folder to write into.
    film : video.io.Film, optional
        For the reference frame's picture (left out if None).
    car : CarGeometry, optional
        Unused by the drawing; accepted so callers pass what they have.

    Returns
    -------
    Path
        The PNG written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir) / "tracking_report.png"
    ov = tracks.overlay or {}
    t_ms = np.asarray(tracks.t) * 1e3
    panels = [("x_m", "x [m]"), ("z_m", "z [m]"), ("pitch_rad", "pitch [deg]"),
              ("crush_m", "crush [m]")]
    wheel = [c for c in ("front_wheel_angle_rad", "rear_wheel_angle_rad") if c in tracks.channels]
    height = [c for c in ("front_wheel_height_m", "rear_wheel_height_m") if c in tracks.channels]
    fig = plt.figure(figsize=(13, 12), dpi=90)
    gs = fig.add_gridspec(4, 2, height_ratios=[1.6, 1, 1, 1])
    ax0 = fig.add_subplot(gs[0, :])
    if film is not None:
        frame = film[int(ov.get("frame", 0))]
        ax0.imshow(frame, cmap="gray", vmin=0, vmax=255)
    for ends in ov.get("tapes", []):
        ends = np.asarray(ends)
        ax0.plot(ends[:, 0], ends[:, 1], "-", color="magenta", lw=2, label="tape")
    sil = ov.get("silhouette_px")
    if sil is not None:
        p = np.vstack([sil, sil[:1]])
        ax0.plot(p[:, 0], p[:, 1], "-", color="cyan", lw=1, label="fitted silhouette")
    uv = ov.get("targets_uv")
    if uv is not None:
        radii = ov.get("target_radii", np.full(len(uv), 10.0))
        for k, (c, kind) in enumerate(zip(uv, ov.get("target_kinds", ["?"] * len(uv)))):
            if not np.all(np.isfinite(c)):
                continue
            ax0.add_patch(plt.Circle(c, radii[k] * 1.4, fill=False,
                                     color=_KIND_COLOUR.get(kind, "yellow"), lw=1.5))
            ax0.text(c[0] + radii[k] * 1.5, c[1] - radii[k] * 1.5, f"target{k} {kind}",
                     color=_KIND_COLOUR.get(kind, "yellow"), fontsize=8)
    cg = ov.get("cg_uv")
    if cg is not None:
        ax0.plot([cg[0]], [cg[1]], "+", color="red", ms=14, mew=2, label="CG")
    ax0.set_title(f"frame {ov.get('frame', 0)}: scale {tracks.scale_m_per_px * 1e3:.4f} "
                  f"+- {tracks.scale_sigma * 1e3:.4f} mm/px ({tracks.scale_source}), contact frame "
                  f"{tracks.contact_frame}, impact {tracks.impact_speed_mps:.3f} m/s "
                  f"({tracks.impact_speed_mps * 3.6:.2f} km/h)", fontsize=10)
    ax0.axis("off")
    h, l = ax0.get_legend_handles_labels()
    if h:
        uniq = dict(zip(l, h))
        ax0.legend(uniq.values(), uniq.keys(), loc="lower left", fontsize=8)

    def band(ax, key, scale=1.0, label=None):
        y = np.asarray(tracks.channels[key], float) * scale
        s = np.asarray(tracks.sigma.get(key, np.zeros_like(y)), float) * scale
        line, = ax.plot(t_ms, y, lw=1.2, label=label or key)
        ax.fill_between(t_ms, y - 2 * s, y + 2 * s, color=line.get_color(), alpha=0.25, lw=0)

    axes = [fig.add_subplot(gs[1 + i // 2, i % 2]) for i in range(6)]
    for ax, (key, lab) in zip(axes[:4], panels):
        if key in tracks.channels:
            band(ax, key, 180 / np.pi if key == "pitch_rad" else 1.0)
        ax.set_ylabel(lab)
    for key in wheel:
        band(axes[4], key, label=key.replace("_rad", ""))
    axes[4].set_ylabel("wheel spin [rad]")
    for key in height:
        band(axes[5], key, 1e3, label=key.replace("_m", ""))
    axes[5].set_ylabel("wheel height [mm]")
    for ax in axes:
        ax.axvline(0.0, color="k", lw=0.8, ls=":")
        for name, ms in tracks.events_ms.items():
            if ms is not None:
                ax.axvline(ms, color="tab:red", lw=0.8, ls="--")
        ax.set_xlabel("t [ms] (0 = first contact)")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0] and ax in axes[4:]:
            ax.legend(fontsize=8)
    if tracks.events_ms:
        ev = ", ".join(f"{k} {v:.1f} ms" for k, v in tracks.events_ms.items() if v is not None)
        fig.suptitle(f"events (dashed): {ev}", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(out)
    plt.close(fig)
    return out
