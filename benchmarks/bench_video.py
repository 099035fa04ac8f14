"""Benchmark of the video stage (run by hand: ``python benchmarks/bench_video.py``).

Renders a 1280x1024, 300-frame crash film with known truth (an Audi A4 at 56.3 km/h,
right-to-left, sensor noise and motion blur) into a temporary folder, then times

- reading alone: ``open_film`` (its checking pass) plus streaming every frame once,
- one bare decoding pass over the frames (``cv2.imread`` / ``VideoCapture``),
- the whole video stage: ``open_film`` + ``track_film`` (scale, detection, tracking,
  motion, events), and the share of each,

and prints frames per second (after comparing the sub-pixel centre refiners of
``video.targets`` on synthetic targets), the ratio of the stage to reading alone (target < 3x) and to
the bare pass, and the accuracy against the truth: target centres (px RMS), x (mm RMS),
pitch (deg RMS), contact frame, impact speed, wheel block and rear lift times.

Options: ``--format png|mp4`` (default png), ``--frames N`` (default 300), ``--clean``
(no noise or blur), ``--random SEED``: instead, a randomized film of the same crash from
the reference world's footage (``synth.footage.random_footage``: camera turned a few
degrees, other scale, targets, tapes, format, frame rate, degradations), so the stage is
measured on a film unlike the one it was tuned on.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from identify.recordings.synthetic import car_geometry  # noqa: E402
from video.errors import VideoError  # noqa: E402
from video.io import open_film  # noqa: E402
from synth.render import Renderer, read_truth, write_film  # noqa: E402
from synth.scene import Effects, Motion, Scene, default_camera, default_tapes, \
    default_targets  # noqa: E402
from video.track import track_film  # noqa: E402

SPEED = 56.3 / 3.6
T_BLOCK, T_LIFT, T_FLIGHT = 0.047, 0.069, 0.140


def crash_motion(car, n, n_pre=60, omega=24.0, e=0.2, fps=1000.0):
    """Approach, linear-spring compression, rebound at ``e`` times the impact speed; the
    front wheels block at 47 ms, the rear wheel lifts at 69 ms (its tyre unloaded over the
    30 ms before) and lands again at 209 ms."""
    t = (np.arange(n) - n_pre) / fps
    tp = np.maximum(t, 0.0)
    tm = np.pi / (2 * omega)
    xmax = SPEED / omega
    w2 = omega / e
    s = np.maximum(tp - tm, 0.0)
    sb = np.pi / (2 * w2)
    x = np.where(t < 0, SPEED * t, np.where(
        tp < tm, SPEED / omega * np.sin(omega * tp),
        xmax - e * SPEED / w2 * (1 - np.cos(np.minimum(w2 * s, np.pi / 2)))
        - e * SPEED * np.maximum(s - sb, 0.0)))
    bump = np.sin(np.clip(np.pi * tp / 0.16, 0, np.pi))
    pitch = 0.07 * bump
    z = -0.012 * bump
    r = car.wheel_radius
    roll = (x - x[0]) / r
    front = np.where(t < T_BLOCK, roll, np.interp(T_BLOCK, t, roll))

    def axle_z(px):
        return car.cg_height + z - (px - car.x_cg) * np.sin(pitch) \
            + (r - car.cg_height) * np.cos(pitch)

    # the rear tyre (250 kN/m) unloads over the 30 ms before it leaves the floor (its hub
    # rises by the static deflection, which the video stage brackets the lift by) and loads
    # again over the 30 ms after it lands
    defl = car.static_wheel_load("rear") / 250e3
    landed = T_LIFT + T_FLIGHT
    tyre = defl * np.where(t < landed, np.clip((t - T_LIFT + 0.03) / 0.03, 0.0, 1.0) ** 2,
                           1.0 - np.clip((t - landed) / 0.03, 0.0, 1.0) ** 2)
    # in flight from the speed the unloading left it with, down again at 209 ms
    tau = np.clip(t - T_LIFT, 0.0, T_FLIGHT)
    lift = tyre + 2.0 * defl / 0.03 * tau * (1.0 - tau / T_FLIGHT)
    return Motion(t=t, x=x, z=z, pitch=pitch, front_wheel_angle=front, rear_wheel_angle=roll,
                  front_wheel_dz=r - axle_z(car.front_axle_x),
                  rear_wheel_dz=r + lift - axle_z(car.rear_axle_x))


def draw_target(shape, centre, radius, angle, ss=8):
    """One quadrant target (light 0.95 / dark 0.05 on 0.5 grey), anti-aliased by
    ``ss`` x ``ss`` supersampling; float32 image."""
    H, W = shape
    ys, xs = np.mgrid[0: H * ss, 0: W * ss]
    du = (xs + 0.5) / ss - 0.5 - centre[0]
    dv = (ys + 0.5) / ss - 0.5 - centre[1]
    q = np.floor((np.arctan2(dv, du) - angle) / (np.pi / 2)).astype(int) % 2
    big = np.where(du * du + dv * dv <= radius * radius, np.where(q == 0, 0.95, 0.05), 0.5)
    return big.reshape(H, ss, W, ss).mean(axis=(1, 3)).astype(np.float32)


def compare_refiners(n: int = 60, seed: int = 0) -> None:
    """Centre error (px RMS) of the sub-pixel refiners on random targets of radius 5-20 px,
    clean and with 5 px motion blur, defocus and noise ("centre", the tracker's
    ``refine_centre``: the gradient one, then point symmetry)."""
    from video.targets import refine_centre, refine_gradient, refine_opencv, refine_saddle

    rng = np.random.default_rng(seed)
    errs = {name: {"clean": [], "noisy": []} for name in ("centre", "gradient", "saddle", "opencv")}
    for _ in range(n):
        c = np.array([32.0, 32.0]) + rng.uniform(-0.5, 0.5, 2)
        r = rng.uniform(5.0, 20.0)
        img = draw_target((64, 64), c, r, rng.uniform(0, np.pi))
        noisy = cv2.GaussianBlur(cv2.filter2D(img, -1, np.full((1, 5), 0.2, np.float32)),
                                 (0, 0), 0.8)
        noisy = (0.8 * noisy + rng.normal(0, 0.03, img.shape)).astype(np.float32)
        start = c + rng.uniform(-1.0, 1.0, 2)
        for cond, im in (("clean", img), ("noisy", noisy)):
            for name, f in (("centre", refine_centre), ("gradient", refine_gradient),
                            ("saddle", refine_saddle), ("opencv", refine_opencv)):
                errs[name][cond].append(np.hypot(*(f(im, start, r) - c)))
    for name, e in errs.items():
        print(f"refiner {name:9s} clean {np.sqrt(np.nanmean(np.square(e['clean']))):.3f} px "
              f"RMS, blurred+noisy {np.sqrt(np.nanmean(np.square(e['noisy']))):.3f} px RMS")


def bare_pass(path: Path) -> int:
    """Decode every frame once, nothing else; return the count."""
    if path.is_dir():
        files = sorted(path.glob("frame_*.*"))
        for f in files:
            cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
        return len(files)
    cap = cv2.VideoCapture(str(path))
    n = 0
    while cap.read()[0]:
        n += 1
    cap.release()
    return n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--format", choices=("png", "mp4"), default="png")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--clean", action="store_true")
    ap.add_argument("--random", type=int, default=None, metavar="SEED",
                    help="render a randomized film (synth.footage) from this seed instead")
    args = ap.parse_args()
    if args.random is not None:
        return main_random(args)
    compare_refiners()

    with open(ROOT / "data" / "vehicles" / "audi_a4.toml", "rb") as fh:
        car = car_geometry(tomllib.load(fh))
    effects = Effects() if args.clean else Effects(noise_sigma=2.0, blur_substeps=3,
                                                   exposure=0.5, seed=7)
    cam = default_camera(car, 2.0, width=1280, height=1024, m_per_px=0.004, approach_m=0.25)
    scene = Scene(car=car, camera=cam, targets=default_targets(car), tapes=default_tapes(car),
                  x_barrier=2.0, direction=-1, effects=effects)
    motion = crash_motion(car, args.frames)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / ("crash" if args.format == "png" else "crash.mp4")
        t0 = time.perf_counter()
        write_film(Renderer(scene, motion), path)
        print(f"rendered {args.frames} frames 1280x1024 ({args.format}) in "
              f"{time.perf_counter() - t0:.1f} s")
        meta, truth = read_truth(path)

        t0 = time.perf_counter()
        n = bare_pass(path)
        t_bare = time.perf_counter() - t0

        t0 = time.perf_counter()
        film = open_film(path, fps=1000.0)
        for _ in film:
            pass
        t_read = time.perf_counter() - t0

        t0 = time.perf_counter()
        film = open_film(path, fps=1000.0)
        t_open = time.perf_counter() - t0
        tracks = track_film(film, car)
        t_stage = time.perf_counter() - t0

    report(n, t_bare, t_read, t_stage, t_open, tracks, meta, truth)


def report(n, t_bare, t_read, t_stage, t_open, tracks, meta, truth) -> None:
    """Print speeds and the accuracy of the tracks against the truth."""
    t_track = t_stage - t_open
    print(f"bare decoding pass      {n / t_bare:8.1f} frames/s")
    print(f"reading (open + stream) {n / t_read:8.1f} frames/s")
    print(f"video stage             {n / t_stage:8.1f} frames/s")
    print(f"ratio stage / reading   {t_stage / t_read:8.2f}x   (target < 3x)")
    print(f"ratio stage / bare pass {t_stage / t_bare:8.2f}x")
    print(f"  of which open_film's checking pass {t_open / t_bare:.2f}x, track_film "
          f"{t_track / t_bare:.2f}x (its own decoding pass, calibration, tracking, motion)")

    cf = tracks.contact_frame
    names = [t["name"] for t in meta["targets"]]
    errs = []
    k = 0
    while f"target{k}_u_px" in tracks.channels:
        u, v = tracks.channels[f"target{k}_u_px"], tracks.channels[f"target{k}_v_px"]
        d = [np.hypot(u[0] - truth[f"{m}_u_px"][0], v[0] - truth[f"{m}_v_px"][0]) for m in names]
        m = names[int(np.argmin(d))]
        e = np.hypot(u - truth[f"{m}_u_px"], v - truth[f"{m}_v_px"])
        errs.append(e[np.isfinite(e)])
        k += 1
    x_true = truth["x_m"] - truth["x_m"][cf]
    x_err = tracks.channels["x_m"] - x_true
    p_err = np.degrees(tracks.channels["pitch_rad"] - truth["pitch_rad"])
    t0_ms = truth["t_s"][cf] * 1e3
    print(f"target centres          {np.sqrt(np.mean(np.concatenate(errs) ** 2)):.3f} px RMS")
    print(f"x                       {1e3 * np.sqrt(np.nanmean(x_err ** 2)):.2f} mm RMS "
          f"(scale {tracks.scale_m_per_px * 1e3:.4f} mm/px)")
    print(f"pitch                   {np.sqrt(np.nanmean(p_err ** 2)):.4f} deg RMS")
    print(f"contact frame           {cf} (truth {meta['contact_frame']})")
    print(f"impact speed            {tracks.impact_speed_mps:.4f} m/s (truth {SPEED:.4f}, "
          f"{100 * (tracks.impact_speed_mps / SPEED - 1):+.3f} %)")
    for key, truth_s in (("front_wheel_block", T_BLOCK), ("rear_wheel_lift", T_LIFT),
                         ("rear_wheel_touchdown", T_LIFT + T_FLIGHT)):
        got = tracks.events_ms.get(key)
        want = truth_s * 1e3 - t0_ms
        print(f"{key:23s} " + (f"{got:.2f} ms (truth {want:.2f} ms)" if got is not None
                                else f"not found (truth {want:.2f} ms)"))


def main_random(args) -> None:
    """Render, read and track a randomized film of the same crash (``--random SEED``)."""
    from synth.footage import random_footage, render_film
    from synth.scene import body_to_plane, cg_x_at_contact
    from synth.vehicle import load_car

    with open(ROOT / "data" / "vehicles" / "audi_a4.toml", "rb") as fh:
        car = car_geometry(tomllib.load(fh))
    spec = random_footage(np.random.default_rng(args.random), load_car("audi_a4"))
    n_after = max(args.frames - spec.frames_before, 10)
    m = crash_motion(car, n_after, n_pre=0, fps=spec.fps)
    x_cg0 = cg_x_at_contact(car, 0.0)
    crush = np.array([max(body_to_plane(np.asarray(car.silhouette_side), car, {"x": x, "z": z, "pitch": p},
                                        x_cg0)[:, 0].max(), 0.0) for x, z, p in zip(m.x, m.z, m.pitch)])
    motion = {"t": m.t, "x": m.x, "z": m.z, "pitch": m.pitch, "crush": crush,
              "front_wheel_angle": m.front_wheel_angle, "rear_wheel_angle": m.rear_wheel_angle,
              "front_wheel_dz": m.front_wheel_dz, "rear_wheel_dz": m.rear_wheel_dz, "v0": SPEED}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / {"mp4": "crash.mp4", "avi": "crash.avi"}.get(spec.format, "crash")
        t0 = time.perf_counter()
        meta = render_film(load_car("audi_a4"), motion, spec, path)
        print(f"seed {args.random}: rendered {spec.frames_before + n_after} frames {spec.width}x{spec.height} "
              f"({spec.format}, {spec.fps:g} fps, container {meta['container_fps']:g} fps, direction "
              f"{spec.direction:+d}, yaw/pitch/roll {spec.yaw_deg:.1f}/{spec.pitch_deg:.1f}/{spec.roll_deg:.1f} deg, "
              f"tape {spec.tape_segment}, shake {spec.shake_px:.1f} px) in {time.perf_counter() - t0:.1f} s")
        _, truth = read_truth(path)
        t0 = time.perf_counter()
        n = bare_pass(path)
        t_bare = time.perf_counter() - t0
        t0 = time.perf_counter()
        for _ in open_film(path, fps=spec.fps):
            pass
        t_read = time.perf_counter() - t0
        t0 = time.perf_counter()
        film = open_film(path, fps=spec.fps)
        t_open = time.perf_counter() - t0
        try:
            tracks = track_film(film, car, tape_segment_m=spec.tape_segment or 0.1)
        except VideoError as err:  # what the stage cannot read yet is a result too
            print(f"video stage failed: {err}")
            return
        t_stage = time.perf_counter() - t0
    report(n, t_bare, t_read, t_stage, t_open, tracks, meta, truth)


if __name__ == "__main__":
    main()
