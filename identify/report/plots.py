"""Figures of a fit, in the style of the paper's Figs. 4-7 (PNG, matplotlib Agg).

- ``displacement_velocity.png`` (Fig. 6): measured and fitted x(t) and v(t), with the
  V-SIM default parameters for comparison;
- ``residuals.png``: residual of every fitted channel over time with the +-2 sigma band of
  the measurement;
- ``silhouettes.png`` (Figs. 5, 7): the car's outline at chosen times, measured pose vs
  fitted model vs V-SIM defaults, in the car's plane; with a film, ``overlay.png``: the
  fitted model's outline drawn over the film's frames (Figs. 4, 5).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

CHANNEL_LABELS = {
    "x_m": ("x", "mm", 1e3),
    "z_m": ("z", "mm", 1e3),
    "pitch_rad": ("pitch", "deg", 180 / np.pi),
    "vx_mps": ("v", "m/s", 1.0),
    "front_wheel_angle_rad": ("front wheel angle", "deg", 180 / np.pi),
    "rear_wheel_angle_rad": ("rear wheel angle", "deg", 180 / np.pi),
}


def _measured_velocity(t, x, sigma):
    """Velocity from displacement: the CFC 180 derivative the video stage provides."""
    from video.filters import velocity

    fs = 1.0 / float(np.median(np.diff(t)))
    return velocity(np.asarray(x, float), fs, cfc=180, sigma_m=np.asarray(sigma, float)).values


def plot_displacement_velocity(result, default_traj, path: Path) -> Path:
    """Fig. 6: x(t) and v(t), measured vs fitted vs V-SIM defaults."""
    m = result.measurement
    tr = result.trajectory
    t_model = (np.asarray(tr.t) + result.contact_time) * 1e3
    # the default run starts at its own contact: put it on the recording's clock as the fit is
    t_default = (np.asarray(default_traj.t) + result.contact_time) * 1e3 if default_traj is not None else None
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    if "x_m" in m.channels:
        ax1.plot(m.t * 1e3, m.channels["x_m"], ".", ms=2, color="0.3", label="measured")
        ax1.plot(m.t * 1e3, result.predictions["x_m"], color="tab:blue", lw=2, label=f"fitted ({result.model})")
    if default_traj is not None:
        ax1.plot(t_default, np.asarray(default_traj.x), "--", color="tab:red",
                 label="V-SIM default parameters")  # fmt: skip
    ax1.set_ylabel("displacement x (m)")
    ax1.legend(loc="lower right")
    ax1.grid(alpha=0.3)
    if "vx_mps" in m.channels:
        ax2.plot(m.t * 1e3, m.channels["vx_mps"], ".", ms=2, color="0.3", label="measured")
    elif "x_m" in m.channels:
        v = _measured_velocity(m.t, m.channels["x_m"], m.sigma["x_m"])
        ax2.plot(m.t * 1e3, v, color="0.3", lw=1, label="measured (CFC 180 derivative of x)")
    ax2.plot(t_model, np.asarray(tr.vx), color="tab:blue", lw=2, label=f"fitted ({result.model})")
    if default_traj is not None:
        ax2.plot(t_default, np.asarray(default_traj.vx), "--", color="tab:red",
                 label="V-SIM default parameters")  # fmt: skip
    ax2.set_ylabel("velocity v (m/s)")
    ax2.set_xlabel("time since first contact (ms)")
    ax2.legend(loc="upper right")
    ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


WINDOW_COLOURS = ("tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink")


def plot_residuals(result, path: Path, windows=(), before=None, title: str = "") -> Path:
    """Residual (measured - fitted) of each channel of ``result`` with its +-2 sigma band.

    ``windows``: (label, t0_ms, t1_ms) spans to shade (discoveries); ``before``: a fit of
    the same measurement drawn too (the base model before discovery); ``title``: above all."""
    m = result.measurement
    names = list(result.predictions)
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.9 * len(names) + 0.6), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        label, unit, scale = CHANNEL_LABELS.get(name, (name, "", 1.0))
        ok = m.valid(name)
        ax.fill_between(m.t[ok] * 1e3, -2 * m.sigma[name][ok] * scale, 2 * m.sigma[name][ok] * scale,
                        color="0.85", label="measurement +-2 sigma")  # fmt: skip
        for fit, colour in ((before, "tab:red"), (result, "tab:blue")):
            if fit is not None:
                res = (m.channels[name] - fit.predictions[name]) * scale
                ax.plot(m.t[ok] * 1e3, res[ok], lw=0.8, color=colour, label=f"{fit.model}: RMS {fit.rms[name] * scale:.3g} {unit}")
        ax.set_ylabel(f"{label} ({unit})")
        ax.set_title(f"{label}: RMS {result.rms[name] * scale:.3g} {unit}", fontsize=9, loc="left")
        for k, (_, t0, t1) in enumerate(windows):
            ax.axvspan(t0, t1, color=WINDOW_COLOURS[k % len(WINDOW_COLOURS)], alpha=0.2)
        ax.grid(alpha=0.3)
    for k, (wlabel, t0, t1) in enumerate(windows):  # each window named once, above the top panel, centred
        axes[0, 0].annotate(wlabel, xy=(0.5 * (t0 + t1), 1.0), xycoords=("data", "axes fraction"), ha="center",
                            va="bottom", fontsize=7, color=WINDOW_COLOURS[k % len(WINDOW_COLOURS)])
    axes[0, 0].legend(loc="lower right", fontsize=7)  # names the grey band: the measurement's +-2 sigma
    axes[-1, 0].set_xlabel("time since first contact (ms); grey band: the measurement's +-2 sigma")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def outline_at(vehicle, x, z, pitch, crush=0.0):
    """(N, 2) outline of ``vehicle`` in the car plane (X from the CG at contact, Z up) at
    pose (x, z, pitch), its front clipped at the barrier face when crushed."""
    sil = np.asarray(vehicle.silhouette_side, float)
    x_cg = float(vehicle.length - vehicle.front_overhang - vehicle.cg_to_front_axle)
    h = float(vehicle.cg_height)
    px, pz = sil[:, 0] - x_cg, sil[:, 1] - h
    c, s = np.cos(pitch), np.sin(pitch)
    X = x + px * c + pz * s
    Z = h + z - px * s + pz * c
    face = float(vehicle.length - x_cg)  # the barrier face, CG frame at contact
    X = np.minimum(X, face)
    return np.stack([X, Z], axis=1)


def plot_silhouettes(result, vehicle, default_traj, path: Path, times_ms=(0, 50, 100, 150, 200, 300)) -> Path:
    """Figs. 5 and 7: outlines at chosen times: measured pose, fitted model, V-SIM defaults."""
    m = result.measurement
    tr = result.trajectory
    t_model = np.asarray(tr.t) + result.contact_time
    times = [t for t in times_ms if t / 1e3 <= float(m.t.max()) + 1e-9]
    fig, axes = plt.subplots(len(times), 1, figsize=(8, 1.6 * len(times) + 0.4), sharex=True, squeeze=False)
    face = float(vehicle.front_overhang + vehicle.cg_to_front_axle)
    for ax, t_ms in zip(axes[:, 0], times):
        t = t_ms / 1e3
        pose = [float(np.interp(t, t_model, np.asarray(getattr(tr, k)))) for k in ("x", "z", "pitch")]
        fitted = outline_at(vehicle, *pose)
        ax.fill(fitted[:, 0], fitted[:, 1], color="tab:blue", alpha=0.25, label="fitted model")
        if all(c in m.channels for c in ("x_m", "z_m", "pitch_rad")):
            i = int(np.argmin(np.abs(m.t - t)))
            meas = outline_at(vehicle, m.channels["x_m"][i], m.channels["z_m"][i], m.channels["pitch_rad"][i])
            ax.plot(*np.vstack([meas, meas[:1]]).T, color="k", lw=1, label="measured pose")
        if default_traj is not None:
            pose_d = [float(np.interp(t, np.asarray(default_traj.t) + result.contact_time, np.asarray(getattr(default_traj, k))))
                      for k in ("x", "z", "pitch")]  # fmt: skip
            dflt = outline_at(vehicle, *pose_d)
            ax.plot(*np.vstack([dflt, dflt[:1]]).T, "--", color="tab:red", lw=1, label="V-SIM defaults")
        ax.axvline(face, color="0.2", lw=3)
        ax.set_aspect("equal")
        ax.set_ylabel(f"{t_ms} ms")
        ax.set_yticks([])
        ax.tick_params(labelbottom=True)  # every panel has its X scale, not only the bottom one
    axes[0, 0].legend(loc="upper left", fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("X (m), car plane; the thick line is the barrier face")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_overlay(result, vehicle, recording, path: Path, times_ms=(0, 50, 100, 150, 200, 300)) -> Path | None:
    """Figs. 4 and 5: the fitted model's outline drawn over film frames (needs the film's
    scale, direction and the CG's pixel position at contact from the tracks). Returns None
    when the recording is not a film."""
    tracks, film = recording.tracks, recording.film
    if tracks is None or film is None or "cg_uv" not in tracks.overlay:
        return None
    cg_uv = np.asarray(tracks.overlay["cg_uv"], float)
    k = float(tracks.scale_m_per_px)
    direction = int(tracks.direction)
    t_frames = np.asarray(tracks.t)
    times = [t for t in times_ms if t / 1e3 <= float(t_frames.max())]
    cols = 3
    rows = int(np.ceil(len(times) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(12, 3.2 * rows), squeeze=False)
    ref = int(tracks.overlay.get("frame", tracks.contact_frame))
    pred = result.predictions
    zeros = np.zeros(len(t_frames))
    x_p, z_p, p_p = (pred.get(c, zeros) for c in ("x_m", "z_m", "pitch_rad"))
    for ax, t_ms in zip(axes.ravel(), times):
        i = int(np.argmin(np.abs(t_frames - t_ms / 1e3)))
        frame = np.asarray(film[i])
        ax.imshow(frame if frame.ndim == 2 else frame[..., ::-1], cmap="gray")
        outline = outline_at(vehicle, x_p[i] - x_p[ref], z_p[i] - z_p[ref], p_p[i])
        h = float(vehicle.cg_height)
        u = cg_uv[0] + direction * outline[:, 0] / k
        v = cg_uv[1] - (outline[:, 1] - h) / k
        ax.plot(np.append(u, u[0]), np.append(v, v[0]), color="tab:cyan", lw=1.2)
        ax.set_title(f"{t_frames[i] * 1e3:.0f} ms", fontsize=9)
        ax.axis("off")
    for ax in axes.ravel()[len(times):]:
        ax.axis("off")
    fig.suptitle("fitted model's outline over the film", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
