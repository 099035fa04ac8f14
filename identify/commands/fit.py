"""``identify fit``: the main job, from a crash-test recording to the simulation's parameters."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from identify.errors import UserError
from identify.report.markdown import discovery_values, prior_lines, window_words


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fit",
        help="identify the collision parameters from a crash-test film or sensor recording",
        description="Track the car in a crash-test film (or read an NHTSA EV5 / ISO-MME sensor recording), "
        "fit the collision model to its motion and write result.json, tracks.csv, plots and report.md to a "
        "results folder. With barrier load cells, the fitted model's force is checked against them.",
    )
    p.add_argument("recording", type=Path, metavar="VIDEO", help="video file, folder of numbered frames, tracks.csv, NHTSA .EV5 header or ISO-MME .mme")
    p.add_argument("--vehicle", required=True, help="vehicle name (see 'identify vehicles') or path to a .toml")
    p.add_argument("--fps", type=float, default=None, help="true recording rate if the container's is wrong")
    p.add_argument("--tape-segment", type=float, default=0.1, help="reference-tape segment length, m (default 0.1)")
    p.add_argument("--speed", type=float, default=None, help="impact speed in km/h if known (else measured)")
    p.add_argument("--out", type=Path, default=None, help="results folder (default: <video stem>.identify/ beside it)")
    p.add_argument("--no-discover", action="store_true", help="fit the base model only")
    p.add_argument("--face-friction", action=argparse.BooleanOptionalAction, default=True,
                   help="fit the friction of the crushed front on the barrier face (default); --no-face-friction"
                        " holds it at V-SIM's 0")
    p.add_argument("--starts", type=int, default=5, help="starting points of the fit (default 5)")
    p.add_argument("--force", action="store_true",
                   help="fit even when the film contradicts the vehicle file (wheelbase, length); the result "
                   "and report then carry the warning")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=run, compiles=True)  # keeps its compiled programs (identify.compile_cache)


def run(args: argparse.Namespace) -> int:
    if args.fps is not None and not (math.isfinite(args.fps) and 0 < args.fps <= 1e6):
        raise UserError(f"--fps must be a positive frame rate, got {args.fps}")
    if not (math.isfinite(args.tape_segment) and 0.005 <= args.tape_segment <= 1.0):
        raise UserError(f"--tape-segment must be a length in metres (0.005-1), got {args.tape_segment}")
    if not 1 <= args.starts <= 50:
        raise UserError(f"--starts must be in 1..50, got {args.starts}")

    from identify.report.results import ResultsFolder, default_output_folder

    if not args.recording.exists():
        raise UserError(f"{args.recording} does not exist")
    # the results' temporary sibling is made before anything heavy loads: an unwritable
    # place fails within the first second
    folder = ResultsFolder(args.out if args.out is not None else default_output_folder(args.recording))
    try:
        return _run(args, folder)
    except BaseException:
        folder.discard()
        raise


def _run(args: argparse.Namespace, folder) -> int:
    import dataclasses

    import identify
    from identify.identification import FIT_OPTIONS

    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        if not args.quiet:
            print(f"[{time.perf_counter() - t0:6.1f} s] {msg}", file=sys.stderr, flush=True)

    ident = identify.fit(
        args.recording,
        args.vehicle,
        fps=args.fps,
        tape_segment=args.tape_segment,
        speed_kmh=args.speed,
        out=folder,
        discover=not args.no_discover,
        options=dataclasses.replace(FIT_OPTIONS, starts=args.starts, face_friction=args.face_friction),
        progress=progress,
        force=args.force,
    )
    doc = ident.document
    for line in summary_lines(doc):
        print(line)
    for warning in doc.get("warnings") or []:
        print(f"warning: {warning}", file=sys.stderr)
    print(f"results: {ident.out}")
    return 0


def summary_lines(doc: dict) -> list[str]:
    """What ``identify fit`` prints of a result.json document: the car, speed and fit RMS;
    each parameter with its std (or why it is not identified); what was measured before the
    fit and how far the fit pulled it; discovery's status and each discovery (its window and
    parameters), and each effect the base model shows by itself."""
    out = [f"{doc['vehicle_name']}, {doc['impact_speed_kmh']:.2f} km/h, fit RMS {1e3 * doc['fit']['rms_m']:.2f} mm"]
    for name, p in doc["parameters"].items():
        std = f" +- {p['std']:.3g}" if p.get("std") is not None else ""
        if p.get("std_model"):
            std += f" (data alone +- {p['std_data']:.3g})"
        flag = f"   ({p['reason']})" if not p.get("identified", True) else f"   ({p['note']})" if p.get("note") else ""
        out.append(f"  {name:15s} {p['value']:.6g}{std} {p['unit']}{flag}")
    out += [f"  {line}" for line in prior_lines(doc.get("priors") or {})]
    if doc.get("discovery_status"):
        out.append(f"discovery: {doc['discovery_status']}")
    for d in doc.get("discoveries") or []:
        values = discovery_values(d)
        w = d.get("window_ms")
        out.append(f"  {d['effect'].replace('_', ' ')}" + (f", {w[0]:.0f}-{w[1]:.0f} ms" if w else "")
                   + (f": {values}" if values else ""))
    for e in doc.get("shown_by_model") or []:
        out.append(f"  {e['effect'].replace('_', ' ')}, shown by the base model itself (no mechanism added), "
                   f"{window_words(e)}" + (f"; contradicted by the recording: {e['evidence']}" if e["contradicted"]
                                           else f"; {e['evidence']}"))
    return out
