"""Accuracy of the whole chain on the reference world (run by hand:
``python benchmarks/accuracy.py [--n 40] [--jobs 2] [--format film|isomme|motion]``).

For each world (``synth``: an independent car model and randomized footage, fixed seeds
from ``SEED_BASE`` on, which no test uses), write the film (or ISO-MME recording), run
``identify.fit`` on it the way a user would (the vehicle file, the tape segment and the
true frame rate the lab would know; discovery on), and compare with the truth:

- tracking: body x RMS error (frames -15..250 ms, after the best time shift within 1 ms),
  the share of those frames measured, and the contact time (the video stage's, to a
  fraction of a frame, and the fit's) against the true first contact;
- impact speed error, %;
- each collision parameter's error in % (restitution and dz_contact in their own units)
  and in reported standard deviations; "at bound / not identified" counted apart;
- discoveries against the concealed effect: right name, wrong name, "unexplained",
  nothing.

``--format motion`` fits the world's simulated motion itself (a ``tracks.csv`` of x, z, pitch
and the wheels' angles, exact, at a good film's stated sigmas): what the model alone gets
wrong, to set beside the film's error, which adds the camera's and the tracker's.

The baseline, in the same run: V-SIM's default parameters (what an expert would type in
without the tool), their error against the same truth.

Summary: false-discovery rate on clean worlds, right-name and wrong-name rates on worlds
with one concealed effect ("unexplained" apart), coverage of the 1- and 2-sigma intervals
of each parameter, refusals (a film the tool could not read, with its one-line reason).
``--json FILE`` keeps every world's row.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import multiprocessing as mp
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

from synth.world import EFFECTS

SEED_BASE = 910_000   # benchmark seeds; tests use seeds below 1000
CALIBRATION_SEED_BASE = 950_000   # the worlds identify/fitting/model_error.json is calibrated on (--calibration)
DEVELOPMENT_SEED_BASE = 960_000   # the worlds a new rule is tried on before it is scored (--development)
# 40 worlds: clean and each effect, interleaved so that a short run (--n) sees a mix
SCHEDULE = ("clean", "stiffness_zone", "clean", "front_wheel_block", "clean", "rate_dependence",
            "clean", "engine_impact", "rear_axle_lift")
PARAMS = ("k_compression", "k_restitution", "restitution", "dz_contact")
VSIM_DEFAULTS = {"k_compression": 730e3, "k_restitution": 730e3, "restitution": 0.2, "dz_contact": 0.0}
ABSOLUTE = ("restitution", "dz_contact")  # errors in their own units, not in %


def world_plan(n: int, effect: str | None = None, base: int = SEED_BASE) -> list[tuple[int, str]]:
    """(seed, effect) of the first ``n`` worlds from seed ``base`` (all of ``effect`` when given)."""
    return [(base + i, effect or SCHEDULE[i % len(SCHEDULE)]) for i in range(n)]


# the engine's fitted parameters (a second measured body, or a discovery) vs the world's truth
ENGINE = {"engine_impact.engine_mass": "engine_mass", "engine_impact.gap": "engine_gap"}


def run_world(seed: int, effect: str, fmt: str, keep: Path | None, face_friction: bool = True) -> dict:
    """Make one world, fit it, score it; never raises (a failure is a row). ``face_friction``
    False: as ``identify fit --no-face-friction``."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import identify
    from identify.cli import _bad_input_types as bad_input_types
    from identify.identification import FIT_OPTIONS
    from synth.scoring import judge_discoveries, tracking_errors
    from synth.world import make_world, write_world

    row = {"seed": seed, "effect": effect, "format": fmt}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="accuracy-") as tmpdir:
        folder = (keep / f"world_{seed}") if keep else Path(tmpdir) / "world"
        try:
            world = make_world(seed, effect, None, fmt)
            truth = write_world(world, folder)
        except Exception as err:  # the reference world itself failed: a bug to see
            row.update(status="synth failed", error=f"{type(err).__name__}: {err}", trace=traceback.format_exc(limit=3))
            return row
        row.update(vehicle=truth["vehicle_source"], v0_kmh=truth["v0_kmh"], truth=truth["params"],
                   footage={k: truth.get("footage", {}).get("spec", {}).get(k) for k in
                            ("format", "fps", "tape_segment", "yaw_deg", "image_size")})
        row["t_synth_s"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        fps = truth["fps"] if fmt == "film" else None  # the lab knows its camera's rate
        try:
            ident = identify.fit(folder / truth["recording"], folder / "vehicle.toml", fps=fps,
                                 tape_segment=truth.get("tape_segment") or 0.1, write=False, discover=True,
                                 options=dataclasses.replace(FIT_OPTIONS, face_friction=face_friction))
        except bad_input_types() as err:  # what the command line answers with one line and exit 2
            row.update(status="refused", error=str(err), t_fit_s=time.perf_counter() - t1)
            return row
        except Exception as err:
            row.update(status="crashed", error=f"{type(err).__name__}: {err}", trace=traceback.format_exc(limit=4),
                       t_fit_s=time.perf_counter() - t1)
            return row
        row["t_fit_s"] = time.perf_counter() - t1
        doc = ident.document
        row["status"] = "ok"
        if ident.recording.tracks is not None:
            tracks = ident.recording.tracks
            row["tracking"] = tracking_errors(tracks.channels["x_m"], tracks.contact_frame, truth,
                                              contact_time_s=tracks.contact_time_s)
            # the fit's contact time counts from the contact frame
            row["fit_contact_err_ms"] = (row["tracking"]["video_contact_time_err_ms"] - 1e3 * tracks.contact_offset_s
                                         + doc["contact_time_ms"])
            row["contact_notes"] = [n for n in tracks.notes if "contact" in n]  # seen, or why not
            contact = doc.get("nuisance", {}).get("contact_time", {})
            if contact.get("std_data"):
                row["contact_std_data_ms"] = 1e3 * contact["std_data"]
        row["speed_err_pct"] = 100.0 * (doc["impact_speed_kmh"] / truth["v0_kmh"] - 1.0)
        row["speed_std_pct"] = 100.0 * doc.get("impact_speed_std_kmh", 0.0) / truth["v0_kmh"]
        speed = doc.get("nuisance", {}).get("impact_speed", {})
        row["speed_std_data_pct"] = (100.0 * 3.6 * speed["std_data"] / truth["v0_kmh"] if "std_data" in speed
                                     else row["speed_std_pct"])
        params = {}
        for name in PARAMS:
            p, true = doc["parameters"][name], truth["params"][name]
            err = p["value"] - true
            entry = {"value": p["value"], "std": p.get("std"), "std_data": p.get("std_data", p.get("std")),
                     "identified": bool(p.get("identified", True)),
                     "err": err if name in ABSOLUTE else 100.0 * err / true,
                     "default_err": (VSIM_DEFAULTS[name] - true) if name in ABSOLUTE else 100.0 * (VSIM_DEFAULTS[name] / true - 1)}
            if p.get("std"):
                entry["z"] = err / p["std"]
            if entry["std_data"]:
                entry["z_data"] = err / entry["std_data"]
            params[name] = entry
        row["params"] = params
        engine = {}
        for name, true_name in ENGINE.items():
            p = doc["parameters"].get(name)
            if p is not None and p.get("std"):
                true = truth["hidden"][true_name]
                engine[name] = {"value": p["value"], "std": p["std"], "std_data": p.get("std_data", p["std"]), "true": true,
                                "identified": bool(p.get("identified", True)), "z": (p["value"] - true) / p["std"]}
        if engine:
            row["engine"] = engine
        row["discovered"] = [d["effect"] for d in doc.get("discoveries", [])]
        # a second body the recording measured (engine accelerometers) is modelled, not discovered
        row["measured_effects"] = [e for e in doc["fit"]["model"].split("+")[1:] if e not in row["discovered"]]
        # an effect the fitted base model shows by itself and no measured channel contradicts (the
        # rear wheels lifted by the force plane) is named as a discovery is, right or wrong alike
        row["shown"] = [e["effect"] for e in doc.get("shown_by_model", []) if not e["contradicted"]]
        row["shown_evidence"] = [e["evidence"] for e in doc.get("shown_by_model", [])]
        row["verdict"] = judge_discoveries(row["discovered"] + row["shown"], [e["name"] for e in truth["effects"]])
        # candidates whose fit ended worse than the model they extend: never asked (``Trial.settled``)
        row["unsettled"] = sorted({t["effect"] for r in doc.get("discovery_rounds", []) for t in r
                                   if not t.get("settled", True)})
        # each round's candidates and why each was or was not accepted, to read a miss by
        row["rounds"] = [[{k: t.get(k) for k in ("effect", "delta_bic", "accepted", "reason")} for t in r]
                         for r in doc.get("discovery_rounds", [])]
        row["rms_mm"] = 1e3 * doc["fit"]["rms_m"]
        # when the fitted model lifts the rear wheels (ms after first contact; None: never), and the truth
        row["model_rear_lift_ms"] = (doc.get("model_events_ms") or {}).get("rear_wheel_lift")
        row["true_rear_lift_ms"] = truth.get("events_ms", {}).get("rear_wheel_lift")
        # what was known before the fit (the contact seen, the approach's speed), and how far the fit pulled it
        row["priors"] = {name: {k: p.get(k) for k in ("prior", "prior_std", "value", "std", "std_data", "pull", "held", "held_at", "at_bound")}
                         for name, p in doc.get("priors", {}).items()}
    return row


def _cell(v, fmt="{:+.1f}"):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v)


def print_table(rows: list[dict]) -> None:
    print("| seed | effect | vehicle | video | x err mm | share | contact ms (video/fit) | speed % | "
          "k_c % (z) | k_r % (z) | e (z) | dz' m (z) | found | verdict | fit s |")
    print("|" + "---|" * 15)
    for r in rows:
        if r["status"] != "ok":
            print(f"| {r['seed']} | {r['effect']} | {r.get('vehicle', '-')} | {_footage(r)} | "
                  f"{r['status']}: {r.get('error', '')[:90]} |" + " |" * 10)
            continue
        tr = r.get("tracking", {})
        cells = []
        for name in PARAMS:
            p = r["params"][name]
            f = "{:+.1f}" if name not in ABSOLUTE else ("{:+.3f}")
            z = _cell(p.get("z"), "{:+.1f}")
            cells.append(f"{_cell(p['err'], f)} ({z}){'' if p['identified'] else ' n.i.'}")
        found = r["discovered"] + [e + " (model)" for e in r.get("shown", [])]  # shown by the base model itself
        print(f"| {r['seed']} | {r['effect']} | {r['vehicle']} | {_footage(r)} | {_cell(tr.get('x_rms_mm'), '{:.2f}')} | "
              f"{_cell(tr.get('measured_share'), '{:.2f}')} | {_cell(tr.get('video_contact_time_err_ms'))}/"
              f"{_cell(r.get('fit_contact_err_ms'))} | {_cell(r['speed_err_pct'], '{:+.2f}')} | "
              + " | ".join(cells) + f" | {','.join(found) or '-'} | {r['verdict']} | {r['t_fit_s']:.0f} |")


def _footage(r: dict) -> str:
    f = r.get("footage") or {}
    if not f or f.get("format") is None:
        return r.get("format", "-")
    tape = f.get("tape_segment")
    return f"{f['format']} {f.get('fps') or 0:g}fps tape {'none' if not tape else f'{1e3 * tape:g}mm'}"


def summary(rows: list[dict]) -> dict:
    """The figures the issues take their acceptance from."""
    ok = [r for r in rows if r["status"] == "ok"]
    clean = [r for r in ok if r["effect"] == "clean"]
    effect = [r for r in ok if r["effect"] != "clean"]
    out = {"worlds": len(rows), "fitted": len(ok),
           "refused": sum(r["status"] == "refused" for r in rows),
           "crashed": sum(r["status"] in ("crashed", "synth failed") for r in rows)}
    if clean:
        out["clean_false_discovery_rate"] = float(np.mean([r["verdict"] in ("wrong", "right+wrong") for r in clean]))
        out["clean_unexplained_rate"] = float(np.mean([r["verdict"] == "unexplained" for r in clean]))
    if effect:
        out["effect_right_name_rate"] = float(np.mean([r["verdict"] in ("right", "right+wrong") for r in effect]))
        out["effect_wrong_name_rate"] = float(np.mean([r["verdict"] in ("wrong", "right+wrong") for r in effect]))
        out["effect_unexplained_rate"] = float(np.mean([r["verdict"] == "unexplained" for r in effect]))
        out["effect_nothing_rate"] = float(np.mean([r["verdict"] == "none" for r in effect]))
    if ok:  # the share of fitted worlds where discovery could not ask the recording about a candidate
        out["unsettled_candidate_rate"] = float(np.mean([bool(r.get("unsettled")) for r in ok]))
    tr = [r["tracking"] for r in ok if r.get("tracking") and r["tracking"]["x_rms_mm"] is not None]
    if tr:
        out["tracking_x_rms_mm_median"] = float(np.median([t["x_rms_mm"] for t in tr]))
        out["tracking_x_rms_mm_p90"] = float(np.percentile([t["x_rms_mm"] for t in tr], 90))
        timed = [t["video_contact_time_err_ms"] for t in tr if "video_contact_time_err_ms" in t]  # not in older --json rows
        out["video_contact_within_1ms"] = float(np.mean(np.abs(timed) <= 1.0)) if timed else float("nan")
        out["measured_share_median"] = float(np.median([t["measured_share"] for t in tr]))
    fc = [r["fit_contact_err_ms"] for r in ok if r.get("fit_contact_err_ms") is not None]
    if fc:
        out["fit_contact_within_1ms"] = float(np.mean(np.abs(fc) <= 1.0))
    if ok:
        sp = np.abs([r["speed_err_pct"] for r in ok])
        out["speed_within_0p5pct"] = float(np.mean(sp <= 0.5))
        out["speed_abs_err_pct_median"] = float(np.median(sp))
    if clean:
        for label, key in (("", "speed_std_pct"), ("_data", "speed_std_data_pct")):
            zs = np.array([r["speed_err_pct"] / r[key] for r in clean if r.get(key)])
            out[f"clean_speed_cover_1sigma{label}"] = float(np.mean(np.abs(zs) <= 1)) if zs.size else None
            out[f"clean_speed_cover_2sigma{label}"] = float(np.mean(np.abs(zs) <= 2)) if zs.size else None
    per = {}
    for name in PARAMS:
        ps = [r["params"][name] for r in clean]
        zs = np.array([p["z"] for p in ps if p.get("z") is not None and p["identified"]])
        errs = np.array([p["err"] for p in ps])
        tol = {"k_compression": 3.0, "k_restitution": 10.0, "restitution": 0.02, "dz_contact": 0.03}[name]
        per[name] = {
            "clean_within_tol": float(np.mean(np.abs(errs) <= tol)) if errs.size else None, "tol": tol,
            "clean_abs_err_median": float(np.median(np.abs(errs))) if errs.size else None,
            "default_abs_err_median": float(np.median(np.abs([p["default_err"] for p in ps]))) if ps else None,
            "cover_1sigma": float(np.mean(np.abs(zs) <= 1)) if zs.size else None,
            "cover_2sigma": float(np.mean(np.abs(zs) <= 2)) if zs.size else None,
            "not_identified": int(sum(not p["identified"] for p in ps)),
            **_coverage(ps, "z", "_all"), **_coverage(ps, "z_data", "_data"),
        }
    out["parameters_on_clean_worlds"] = per
    eng = [r["engine"] for r in ok if r.get("engine")]
    if eng:
        out["engine"] = {name: {"worlds": len([e for e in eng if name in e]),
                                "within_1sigma": float(np.mean([abs(e[name]["z"]) <= 1 for e in eng if name in e])),
                                "within_2sigma": float(np.mean([abs(e[name]["z"]) <= 2 for e in eng if name in e])),
                                "within_2sigma_data": float(np.mean([abs(e[name]["value"] - e[name]["true"])
                                                                     <= 2 * e[name].get("std_data", e[name]["std"])
                                                                     for e in eng if name in e])),
                                "identified": int(sum(e[name].get("identified", True) for e in eng if name in e)),
                                "abs_err_median": float(np.median([abs(e[name]["value"] - e[name]["true"])
                                                                   for e in eng if name in e]))}
                         for name in ENGINE}
    return out


def _coverage(ps: list[dict], key: str, label: str) -> dict:
    """Share of the entries ``ps`` whose error lies within 1 and 2 of the standard deviations
    ``key`` names ("z": the reported, "z_data": the data's alone), identified or not."""
    zs = np.array([p[key] for p in ps if p.get(key) is not None])
    return {f"cover_1sigma{label}": float(np.mean(np.abs(zs) <= 1)) if zs.size else None,
            f"cover_2sigma{label}": float(np.mean(np.abs(zs) <= 2)) if zs.size else None}


def print_summary(s: dict) -> None:
    print()
    print(f"worlds {s['worlds']}: fitted {s['fitted']}, refused {s['refused']}, crashed {s['crashed']}")
    for k in ("clean_false_discovery_rate", "clean_unexplained_rate", "effect_right_name_rate", "effect_wrong_name_rate",
              "effect_unexplained_rate", "effect_nothing_rate", "tracking_x_rms_mm_median", "tracking_x_rms_mm_p90",
              "measured_share_median", "video_contact_within_1ms", "fit_contact_within_1ms", "speed_within_0p5pct",
              "speed_abs_err_pct_median", "clean_speed_cover_1sigma", "clean_speed_cover_2sigma",
              "clean_speed_cover_1sigma_data", "clean_speed_cover_2sigma_data"):
        if s.get(k) is not None:
            print(f"  {k:32s} {s[k]:.3f}")
    print()
    print("| parameter (clean worlds) | within tol | tol | median abs err | V-SIM default median abs err (baseline) | "
          "1/2-sigma cover, identified | 1/2-sigma cover, all | 1/2-sigma cover, data std alone | not identified |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, p in s["parameters_on_clean_worlds"].items():
        unit = "" if name in ABSOLUTE else " %"
        print(f"| {name} | {_cell(p['clean_within_tol'], '{:.2f}')} | {p['tol']:g}{unit} | "
              f"{_cell(p['clean_abs_err_median'], '{:.3g}')}{unit} | {_cell(p['default_abs_err_median'], '{:.3g}')}{unit} | "
              f"{_cell(p['cover_1sigma'], '{:.2f}')} / {_cell(p['cover_2sigma'], '{:.2f}')} | "
              f"{_cell(p.get('cover_1sigma_all'), '{:.2f}')} / {_cell(p.get('cover_2sigma_all'), '{:.2f}')} | "
              f"{_cell(p.get('cover_1sigma_data'), '{:.2f}')} / {_cell(p.get('cover_2sigma_data'), '{:.2f}')} | "
              f"{p['not_identified']} |")
    for name, e in s.get("engine", {}).items():
        print(f"engine {name}: {e['worlds']} worlds ({e.get('identified', '-')} identified), within 1 sigma "
              f"{e['within_1sigma']:.2f}, within 2 sigma {e['within_2sigma']:.2f} (data std alone "
              f"{_cell(e.get('within_2sigma_data'), '{:.2f}')}), median abs error {e['abs_err_median']:.3g}")


def _work(args):
    return run_world(*args)


# A worker's compiled fits pile up over the worlds it runs (5.4 GB after 20 development worlds,
# when LLVM then failed to allocate and the worker died): a pool of fresh workers gets this many
# worlds per worker (``in_workers``), then is replaced
MAX_WORLDS_PER_WORKER = 8
# a world unfinished when a worker died (which one killed it cannot be told) is run again in a
# fresh pool this many times, then is a crashed row
WORKER_DEATHS_ALLOWED = 2


def in_workers(plan: list, jobs: int):
    """Rows of ``run_world`` over ``plan`` in ``jobs`` spawned processes, as they finish.

    The worlds go to fresh pools of ``jobs`` workers, ``jobs * MAX_WORLDS_PER_WORKER`` at a
    time (``max_tasks_per_child`` deadlocks on Python 3.11-3.13 once a worker has reached it
    with worlds still queued, CPython gh-115634: a run of 20 scored worlds stopped after 8 on
    2026-11-28). A worker that dies (killed for memory, a crash in compiled code) breaks the
    pool: the worlds not finished then are run again in a fresh pool (a world whose worker
    died more than ``WORKER_DEATHS_ALLOWED`` times is a row with status "crashed"), where a
    ``multiprocessing.Pool`` waited for them for ever."""
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    pending, deaths = list(plan), {}
    while pending:
        batch, pending = pending[:jobs * MAX_WORLDS_PER_WORKER], pending[jobs * MAX_WORLDS_PER_WORKER:]
        again = []
        with ProcessPoolExecutor(jobs, mp_context=mp.get_context("spawn")) as pool:
            futures = {pool.submit(_work, item): item for item in batch}
            for fut in as_completed(futures):
                item = futures[fut]
                try:
                    yield fut.result()
                except BrokenProcessPool:
                    deaths[item[0]] = deaths.get(item[0], 0) + 1
                    if deaths[item[0]] > WORKER_DEATHS_ALLOWED:
                        yield {"seed": item[0], "effect": item[1], "format": item[2], "status": "crashed",
                               "error": "its worker process died (out of memory, or a crash in compiled code)"}
                    else:
                        again.append(item)
        if again:
            print(f"a worker died: {len(again)} world(s) run again in a fresh pool", file=sys.stderr, flush=True)
            pending = again + pending


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=40, help="number of worlds (default 40)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (each compiles the fit once)")
    ap.add_argument("--format", choices=("film", "isomme", "motion"), default="film",
                    help="film (default), isomme (sensors), or motion (the world's own motion: the model's share)")
    ap.add_argument("--effect", default=None, choices=EFFECTS, help="every world with this one effect")
    ap.add_argument("--calibration", action="store_true",
                    help=f"the calibration worlds (seeds from {CALIBRATION_SEED_BASE}) instead of the scored ones")
    ap.add_argument("--development", action="store_true",
                    help=f"the development worlds (seeds from {DEVELOPMENT_SEED_BASE}), to try a rule on before scoring it")
    ap.add_argument("--json", type=Path, default=None, help="write every row and the summary here")
    ap.add_argument("--keep", type=Path, default=None, help="keep the worlds' folders here")
    ap.add_argument("--face-friction", action=argparse.BooleanOptionalAction, default=True,
                    help="fit the barrier face's friction, as 'identify fit' does (default); --no-face-friction as"
                         " 'identify fit --no-face-friction'")
    ap.add_argument("--table", type=Path, default=None, help="only print the table and summary of a --json file")
    ap.add_argument("--only", default=None,
                    help="only these seeds of the plan, comma-separated (to re-measure some worlds after a change)")
    a = ap.parse_args(argv)
    if a.table:
        rows = json.loads(a.table.read_text())["rows"]
        print_table(rows)
        print_summary(summary(rows))
        return 0
    if a.keep:
        a.keep.mkdir(parents=True, exist_ok=True)
    if a.calibration and a.development:
        ap.error("--calibration and --development are two different sets of worlds: give one")
    base = CALIBRATION_SEED_BASE if a.calibration else DEVELOPMENT_SEED_BASE if a.development else SEED_BASE
    plan = [(seed, effect, a.format, a.keep, a.face_friction) for seed, effect in world_plan(a.n, a.effect, base)]
    if a.only:
        try:
            only = {int(s) for s in a.only.split(",")}
        except ValueError:
            ap.error(f"--only takes seeds separated by commas, got {a.only!r}")
        if only - {p[0] for p in plan}:
            ap.error(f"--only: seeds {sorted(only - {p[0] for p in plan})} are not among the plan's {plan[0][0]}-{plan[-1][0]}")
        plan = [p for p in plan if p[0] in only]
    t0 = time.perf_counter()
    rows = []
    partial = a.json.with_suffix(".partial.jsonl") if a.json else None

    def keep_row(row):
        rows.append(row)
        if partial:
            with partial.open("a") as fh:
                fh.write(json.dumps(row, default=float) + "\n")

    # one process's compiled fits pile up over the worlds (LLVM failed to allocate after 20 scored
    # worlds run in one process on 2026-11-28): more worlds than a worker runs go to workers
    if a.jobs > 1 or len(plan) > MAX_WORLDS_PER_WORKER:
        for row in in_workers(plan, a.jobs):
            keep_row(row)
            print(f"[{time.perf_counter() - t0:7.1f} s] world {row['seed']} {row['effect']}: {row['status']}",
                  file=sys.stderr, flush=True)
        rows.sort(key=lambda r: r["seed"])
    else:
        for item in plan:
            keep_row(run_world(*item))
            print(f"[{time.perf_counter() - t0:7.1f} s] world {item[0]} {item[1]}: {rows[-1]['status']}",
                  file=sys.stderr, flush=True)
    print_table(rows)
    s = summary(rows)
    print_summary(s)
    print(f"\n{len(rows)} worlds in {time.perf_counter() - t0:.0f} s")
    if a.json:
        a.json.write_text(json.dumps({"rows": rows, "summary": s}, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    sys.exit(main())
