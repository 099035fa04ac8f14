"""Default versus identified parameters side by side: the paper's Figs. 6 and 7 for any vehicle.

Two simulations of the same impact (same vehicle, same speed) with two parameter sets
(typically the simulator's defaults, ``vsim_default``, and the identified set) give

- :func:`compare_runs`: the position difference dX(t) between them, its peak and its value at
  the silhouette instants;
- :func:`plot_histories`: displacement X and velocity V histories of both (Fig. 6);
- :func:`plot_silhouettes`: the side silhouettes of both at 50, 100, ..., 300 ms (Fig. 7),
  placed with the pose formula of ``video/CONVENTIONS.md``.

    runs = simulate_pair(vehicle, identified, default, speed=15.64)
    summary = compare_runs(*runs)
"""

from __future__ import annotations

import numpy as np

SILHOUETTE_TIMES = (0.05, 0.1, 0.15, 0.2, 0.25, 0.3)  # s
COLOURS = ("tab:blue", "tab:red")  # identified, default: the paper's Fig. 7


def simulate_pair(vehicle, params_a, params_b, speed: float, duration: float = 0.3):
    """Two trajectories of the same impact (``speed`` m/s, ``duration`` s) with two sets."""
    from sim import simulate

    return simulate(params_a, vehicle, speed, duration), simulate(params_b, vehicle, speed, duration)


def compare_runs(run_a, run_b, times=SILHOUETTE_TIMES) -> dict:
    """Position difference between two runs sampled at the same times.

    Returns
    -------
    dict: ``peak_dx_m`` (largest |x_b - x_a|, m), ``peak_time_s`` (s), ``dx_at`` ({time in ms
    as a string: x_b - x_a in m} at ``times`` inside the span), ``dvx_at`` (same for vx, m/s).
    """
    t = np.asarray(run_a.t)
    dx = np.asarray(run_b.x) - np.asarray(run_a.x)
    dvx = np.asarray(run_b.vx) - np.asarray(run_a.vx)
    k = int(np.argmax(np.abs(dx)))
    inside = [s for s in times if s <= t[-1] + 1e-12]
    return {
        "peak_dx_m": float(abs(dx[k])),
        "peak_time_s": float(t[k]),
        "dx_at": {f"{s * 1e3:g}": float(np.interp(s, t, dx)) for s in inside},
        "dvx_at": {f"{s * 1e3:g}": float(np.interp(s, t, dvx)) for s in inside},
    }


def body_outline(vehicle, x: float, z: float, pitch: float) -> np.ndarray:
    """(N, 2) car-plane points (X, Z) of the vehicle's side silhouette at a pose.

    The pose formula of ``video/CONVENTIONS.md`` with the CG at first contact placed where
    the vehicle frame has it (``X_cg0 = x_cg``), so the barrier face is at X = length.
    A vehicle without a silhouette is drawn as its length-by-height box.

    Parameters
    ----------
    vehicle : sim.Vehicle.
    x, z : m, CG displacement from first contact; pitch : rad, nose-down positive.
    """
    length, h = float(vehicle.length), float(vehicle.cg_height)
    x_cg = length - float(vehicle.front_overhang) - float(vehicle.cg_to_front_axle)
    pts = np.asarray(vehicle.silhouette_side, dtype=float)
    if pts.size == 0:
        height = float(vehicle.height)
        pts = np.array([[0.0, 0.2], [length, 0.2], [length, height], [0.0, height]])
    return _pose(pts, x_cg, h, x, z, pitch)


def _pose(pts, x_cg, h, x, z, pitch):
    c, s = np.cos(pitch), np.sin(pitch)
    dx, dz = pts[:, 0] - x_cg, pts[:, 1] - h
    return np.stack([x_cg + x + dx * c + dz * s, h + z - dx * s + dz * c], axis=1)


def plot_histories(run_a, run_b, labels, path, title="") -> None:
    """The paper's Fig. 6: displacement X (a) and velocity V (b) of both runs against time,
    with the position difference on a second axis. Writes a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t_ms = np.asarray(run_a.t) * 1e3
    fig, (ax_x, ax_v) = plt.subplots(1, 2, figsize=(11, 4.2))
    for run, label, colour in zip((run_a, run_b), labels, COLOURS):
        ax_x.plot(t_ms, np.asarray(run.x), color=colour, label=label)
        ax_v.plot(t_ms, np.asarray(run.vx), color=colour, label=label)
    dx = np.asarray(run_b.x) - np.asarray(run_a.x)
    twin = ax_x.twinx()
    twin.plot(t_ms, dx, color="0.4", ls=":", label=f"dX = {labels[1]} - {labels[0]}")
    twin.set_ylabel("position difference dX [m]")
    k = int(np.argmax(np.abs(dx)))
    twin.annotate(f"|dX| max {abs(dx[k]):.3f} m at {t_ms[k]:.0f} ms", (t_ms[k], dx[k]), fontsize=8,
                  xytext=(5, 5), textcoords="offset points")  # fmt: skip
    ax_x.set(xlabel="t [ms]", ylabel="displacement X [m]", title="(a) displacement")
    ax_v.set(xlabel="t [ms]", ylabel="velocity V [m/s]", title="(b) velocity")
    ax_x.legend(loc="lower right", fontsize=8)
    ax_v.legend(loc="upper right", fontsize=8)
    twin.legend(loc="center right", fontsize=8)
    ax_v.axhline(0.0, color="k", lw=0.5)
    for ax in (ax_x, ax_v):
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_silhouettes(vehicle, run_a, run_b, labels, path, times=SILHOUETTE_TIMES, title="") -> None:
    """The paper's Fig. 7: both silhouettes at each of ``times`` (s) in front of the barrier,
    with the roof edge at the top of the windscreen marked. Writes a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon, Rectangle

    t = np.asarray(run_a.t)
    times = [s for s in times if s <= t[-1] + 1e-12]
    cols = 3
    rows = max(1, int(np.ceil(len(times) / cols)))
    fig, axes = plt.subplots(rows, cols, figsize=(5.0 * cols, 2.6 * rows), squeeze=False)
    length, height = float(vehicle.length), float(vehicle.height)
    x_cg = length - float(vehicle.front_overhang) - float(vehicle.cg_to_front_axle)
    for ax in axes.ravel()[len(times):]:
        ax.axis("off")
    for ax, s, letter in zip(axes.ravel(), times, "abcdefghijkl"):
        ax.add_patch(Rectangle((length, -0.1), 0.4, height + 0.6, color="0.75", hatch="//", zorder=3, label="barrier"))
        for run, label, colour in zip((run_a, run_b), labels, COLOURS):
            x, z, pitch = (float(np.interp(s, t, np.asarray(getattr(run, a)))) for a in ("x", "z", "pitch"))
            ax.add_patch(Polygon(body_outline(vehicle, x, z, pitch), closed=True, fill=False, ec=colour, lw=1.2,
                                 label=label))  # fmt: skip
            if vehicle.windscreen_top is not None:
                roof = _pose(np.asarray([vehicle.windscreen_top]), x_cg, float(vehicle.cg_height), x, z, pitch)
                ax.plot(roof[:, 0], roof[:, 1], "o", color=colour, ms=3, label=f"{label}: top of the windscreen")
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlim(-0.3, length + 0.5)
        ax.set_ylim(-0.1, height + 0.5)
        ax.set_aspect("equal")
        ax.set_title(f"({letter}) t = {s * 1e3:.0f} ms", fontsize=9)
        ax.set_xlabel("X (m)", fontsize=7)
        ax.set_ylabel("Z (m)", fontsize=7)
        ax.tick_params(labelsize=7)
    axes.ravel()[0].legend(loc="upper left", fontsize=6)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
