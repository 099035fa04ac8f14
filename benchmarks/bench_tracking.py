"""Accuracy of the video stage on the reference world's randomized films (run by hand:
``python benchmarks/bench_tracking.py --n 40 --jobs 2``).

Renders the films of the scored worlds (``benchmarks/accuracy.py``'s seeds from 910,000 and
its schedule of effects; tests use seeds below 1000), runs ``video.track.track_film`` on each
twice in the same process, as shipped and with one stage switched off as the baseline
(``--baseline stabilise``: no camera-shake correction; ``--baseline see_contact``: contact
from the deceleration onset alone; ``--baseline hub_scale``: a film without a tape refused
instead of scaled by its hub targets and the wheelbase; ``--baseline correct_yaw``: a camera
yawed against the car's plane not taken out), and scores both against the world's
truth with ``synth.scoring.tracking_errors``: body x RMS (mm, and in pixels of the film),
the share of frames from -15 to 250 ms with an x, the contact time's error (ms: the contact
frame's time plus the tracker's fraction of a frame, what the fit is given; whether the
contact frame is the one nearest the true contact; where the picture showed the contact,
its stated one-sigma and whether the error is within two of them), the impact speed's
error (%) and, where the hub targets are drawn, the wheel events' (front wheel blocked,
rear wheel lifted: ms on the film's clock; a missed event counts as outside). Prints a row
per film and the shares issue 14 asks for: x RMS within a third of a pixel, contact within
1 ms, impact speed within 0.3 %, 98 % of the frames measured, wheel events within 2 ms.
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing as mp
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from accuracy import SEED_BASE, world_plan  # noqa: E402

# the baselines: each the TrackerConfig field of its name switched off
BASELINES = {name: {name: False} for name in ("stabilise", "background_shake", "see_contact", "hub_scale",
                                              "correct_yaw", "tyre_deflection", "map_from_approach")}


def track_world(seed: int, effect: str, baseline: str) -> dict:
    """Render one world's film and score its tracking, as shipped and as the baseline."""
    from identify.identification import car_geometry_of
    from sim import load_vehicle
    from synth.scoring import tracking_errors
    from synth.world import make_world, write_world
    from video.errors import VideoError
    from video.io import open_film
    from video.track import TrackerConfig, track_film

    row = {"seed": seed, "effect": effect}
    with tempfile.TemporaryDirectory(prefix="tracking-") as tmp:
        folder = Path(tmp) / "world"
        truth = write_world(make_world(seed, effect, None, "film"), folder)
        spec = truth.get("footage", {}).get("spec", {})
        row.update(fps=truth["fps"], yaw_deg=spec.get("yaw_deg"), shake_px=spec.get("shake_px"))
        car = car_geometry_of(load_vehicle(folder / "vehicle.toml"))
        for name, config in (("shipped", TrackerConfig()),
                             ("baseline", dataclasses.replace(TrackerConfig(), **BASELINES[baseline]))):
            t0 = time.perf_counter()
            try:
                film = open_film(folder / truth["recording"], fps=truth["fps"])
                tracks = track_film(film, car, tape_segment_m=truth.get("tape_segment") or 0.1, config=config)
            except VideoError as err:
                row[name] = {"refused": str(err)}
                continue
            err = tracking_errors(tracks.channels["x_m"], tracks.contact_frame, truth,
                                  contact_time_s=tracks.contact_time_s)
            x_px = None if err["x_rms_mm"] is None else err["x_rms_mm"] / 1e3 / tracks.scale_m_per_px
            nominal = truth.get("footage", {}).get("m_per_px_car_plane")
            true_scale = scale_at_centre(truth.get("footage", {})) or nominal
            row[name] = {**err, "x_rms_px": x_px, "t_s": time.perf_counter() - t0,
                         "scale_source": tracks.scale_source,
                         "scale_err_pct": None if not true_scale else 100 * (tracks.scale_m_per_px / true_scale - 1),
                         "scale_err_nominal_pct": None if not nominal else 100 * (tracks.scale_m_per_px / nominal - 1),
                         "scale_sigma_pct": 100 * tracks.scale_sigma / tracks.scale_m_per_px,
                         "contact_sigma_ms": None if tracks.contact_sigma_s is None else 1e3 * tracks.contact_sigma_s,
                         "speed_err_pct": 100 * (tracks.impact_speed_mps * 3.6 / truth["v0_kmh"] - 1),
                         "event_err_ms": event_errors(tracks, truth, spec),
                         "event_sigma_ms": dict(tracks.events_sigma_ms),
                         "false_lifts": [k for k in ("front_wheel_lift", "rear_wheel_lift")
                                         if k in tracks.events_ms and truth["events_ms"].get(k) is None]}
    return row


def scale_at_centre(footage: dict) -> float | None:
    """The truth's scale as the tracker's map defines it, m/px: the car plane's metres per
    pixel of the recorded picture along its rows at the picture's centre, where
    ``video.calibrate.undistort_points`` (radial terms and tilt about that centre) leaves
    lengths unchanged. The world's ``m_per_px_car_plane`` is the nominal camera's (square
    to the car's plane, no lens); a camera yawed or pitched by a few degrees, and its
    principal point off the centre, make the picture's own scale at the centre differ by
    up to some 0.3 %, which no map about the centre can take out."""
    from synth.scene import rotation_matrix

    cam = footage.get("camera")
    if not cam:
        return None
    f, (cx, cy), dist = cam["focal_px"], cam["principal_point"], cam["distance_car_m"]
    d = footage.get("direction", 1)
    K = np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])
    M = np.array([[d, 0.0, -d * cam["centre_x_m"]], [0.0, -1.0, cam["centre_z_m"]], [0.0, 0.0, dist]])
    H = K @ rotation_matrix(cam["yaw_rad"], cam["pitch_rad"], cam["roll_rad"]) @ M

    def raw(q):
        p = H @ np.array([q[0], q[1], 1.0])
        x, y = (p[0] / p[2] - cx) / f, (p[1] / p[2] - cy) / f
        r2 = x * x + y * y
        g = 1.0 + cam["k1"] * r2 + cam["k2"] * r2 * r2
        return np.array([cx + f * x * g, cy + f * y * g])

    centre = np.array([(cam["width"] - 1) / 2.0, (cam["height"] - 1) / 2.0])
    q = np.linalg.solve(H, np.array([*centre, 1.0]))
    q = q[:2] / q[2]
    h = 1e-3
    for _ in range(20):
        J = np.column_stack([(raw(q + e) - raw(q - e)) / (2 * h) for e in (np.array([h, 0.0]), np.array([0.0, h]))])
        q = q - np.linalg.solve(J, raw(q) - centre)
    return float(1.0 / np.hypot(*J[:, 0]))


def event_errors(tracks, truth: dict, spec: dict) -> dict:
    """Wheel events the film can show (hub targets drawn, the world has the event): the
    tracked time minus the true one on the film's clock, ms (None where not found)."""
    out = {}
    if not spec.get("hubs_visible"):
        return out
    t0_ms = float(truth["series"]["t_ms"][0])  # the true contact stands -t0_ms after frame 0
    for key in ("front_wheel_block", "rear_wheel_lift"):
        true = truth["events_ms"].get(key)
        if true is None:
            continue
        got = tracks.events_ms.get(key)
        out[key] = None if got is None else \
            (tracks.contact_frame / tracks.fps * 1e3 + got) - (true - t0_ms)
    return out


def _work(args):
    return track_world(*args)


def _cell(v, fmt="{:+.1f}"):
    return "-" if v is None else fmt.format(v)


def summary(rows: list[dict], name: str) -> dict:
    runs = [r[name] for r in rows]
    ok = [r for r in runs if "refused" not in r and r.get("x_rms_px") is not None]
    share = (lambda xs: float(np.mean(xs)) if xs else float("nan"))
    return {"films": len(runs), "tracked": len(ok),
            "scaled_from_hubs": sum(r["scale_source"] != "checker tape" for r in ok),
            "scale_within_2_sigma": share([r["scale_err_pct"] is not None
                                           and abs(r["scale_err_pct"]) <= 2 * r["scale_sigma_pct"] for r in ok]),
            "scale_within_2_sigma_of_nominal": share([r["scale_err_nominal_pct"] is not None
                                                      and abs(r["scale_err_nominal_pct"]) <= 2 * r["scale_sigma_pct"]
                                                      for r in ok]),
            "x_within_third_px": share([r["x_rms_px"] <= 1 / 3 for r in ok]),
            "x_rms_mm_median": float(np.median([r["x_rms_mm"] for r in ok])) if ok else float("nan"),
            "contact_time_within_1ms": share([abs(r["video_contact_time_err_ms"]) <= 1.0 for r in ok]),
            # what the fit is told: a contact seen in the picture, within two of its sigmas
            "contact_seen": share([r.get("contact_sigma_ms") is not None for r in ok]),
            "contact_within_2_sigma": share([abs(r["video_contact_time_err_ms"]) <= 2.0 * r["contact_sigma_ms"]
                                             for r in ok if r.get("contact_sigma_ms") is not None]),
            "contact_frame_nearest": share([r["video_contact_err_ms"] == 0 for r in ok]),
            "speed_within_0p3pct": share([abs(r["speed_err_pct"]) <= 0.3 for r in ok]),
            "measured_share_98": share([r["measured_share"] >= 0.98 for r in ok]),
            **{f"{key}_within_2ms": share([e is not None and abs(e) <= 2.0 for r in ok
                                           for k, e in r["event_err_ms"].items() if k == key])
               for key in ("front_wheel_block", "rear_wheel_lift")},
            **{f"{key}_films": sum(key in r["event_err_ms"] for r in ok)
               for key in ("front_wheel_block", "rear_wheel_lift")},
            "films_claiming_a_lift_that_did_not_happen": sum(bool(r.get("false_lifts")) for r in ok),
            # a lift is bracketed (the tyre's deflection is not known): within its own 2 sigma
            "rear_wheel_lift_within_2_sigma": share([e is not None and abs(e) <= 2.0 * r.get("event_sigma_ms", {}).get(
                "rear_wheel_lift", 0.0) for r in ok for k, e in r["event_err_ms"].items() if k == "rear_wheel_lift"])}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=40, help="number of films (default 40)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--baseline", choices=sorted(BASELINES), default="stabilise",
                    help="the stage switched off in the baseline run")
    ap.add_argument("--first-seed", type=int, default=SEED_BASE,
                    help=f"first world's seed (default {SEED_BASE}, the scored films; development "
                         "seeds such as 960000 on debug without looking at them)")
    a = ap.parse_args(argv)
    plan = [(seed, effect, a.baseline) for seed, effect in world_plan(a.n, None, a.first_seed)]
    t0 = time.perf_counter()
    with mp.get_context("spawn").Pool(a.jobs) as pool:
        rows = []
        for row in pool.imap(_work, plan):
            rows.append(row)
            print(f"[{time.perf_counter() - t0:6.0f} s] film {row['seed']}", file=sys.stderr, flush=True)
    print("| seed | fps | yaw deg | shake px | x RMS mm (px), shipped | baseline | contact ms (sigma seen), shipped | baseline |"
          " speed %, shipped | baseline | scale error % (sigma %), shipped | against nominal % |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        cells = []
        for key, fmt in (("x", None), ("video_contact_time_err_ms", "{:+.1f}"), ("speed_err_pct", "{:+.2f}")):
            for name in ("shipped", "baseline"):
                run = r[name]
                if "refused" in run:
                    cells.append("refused")
                elif key == "x":
                    cells.append("-" if run["x_rms_mm"] is None else f"{run['x_rms_mm']:.2f} ({run['x_rms_px']:.2f})")
                elif key == "video_contact_time_err_ms" and run.get("contact_sigma_ms") is not None:
                    cells.append(f"{_cell(run[key], fmt)} ({run['contact_sigma_ms']:.1f})")
                else:
                    cells.append(_cell(run[key], fmt))
        run = r["shipped"]
        scale = "refused" if "refused" in run else \
            f"{_cell(run['scale_err_pct'], '{:+.2f}')} ({run['scale_sigma_pct']:.2f}){' hubs' if run['scale_source'] != 'checker tape' else ''}"
        nominal = "refused" if "refused" in run else _cell(run.get("scale_err_nominal_pct"), "{:+.2f}")
        print(f"| {r['seed']} | {r['fps']:g} | {_cell(r['yaw_deg'])} | {_cell(r['shake_px'], '{:.1f}')} | "
              + " | ".join(cells) + f" | {scale} | {nominal} |")
    print()
    shipped, baseline = summary(rows, "shipped"), summary(rows, "baseline")
    print(f"| share (of films tracked) | shipped | baseline (no {a.baseline}) |")
    print("| --- | --- | --- |")
    for key in shipped:
        fmt = "{:.0f}" if key in ("films", "tracked", "scaled_from_hubs", "films_claiming_a_lift_that_did_not_happen") \
            or key.endswith("_films") else ("{:.2f}" if key.endswith("median") else "{:.0%}")
        print(f"| {key} | {fmt.format(shipped[key])} | {fmt.format(baseline[key])} |")
    for name in ("shipped", "baseline"):
        false = [f"{r['seed']} ({', '.join(r[name]['false_lifts'])})" for r in rows if r[name].get("false_lifts")]
        print(f"{name}: films claiming a lift that did not happen: {', '.join(false) or 'none'}")
    print(f"\n{len(rows)} films in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
