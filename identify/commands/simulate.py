"""``identify simulate``: one simulation to CSV, the way an expert tries a parameter set."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from identify.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "simulate",
        help="run one simulation and write it as CSV",
        description="Simulate a frontal rigid-barrier impact with a vehicle and a parameter set; "
        "write t_ms, x_m, z_m, pitch_rad, crush_m, force_N, front_wheel_blocked, "
        "rear_wheel_airborne and more to CSV, and print the event times.",
    )
    p.add_argument("--vehicle", required=True, help="vehicle name (see 'identify vehicles') or path to a .toml")
    p.add_argument(
        "--params", required=True,
        help="named set (vsim_default, paper_identified) or a JSON file; an 'identify fit' result.json brings its "
        "model along (the engine it assumed, the mechanisms and vehicle changes it discovered)")
    p.add_argument("--speed", type=float, default=None,
                   help="impact speed in km/h (default: a result.json's fitted speed, else 56.3, the paper's)")
    p.add_argument("--duration-ms", type=float, default=300.0, help="simulated time after contact (default 300)")
    p.add_argument(
        "--block-front-wheels",
        action="store_true",
        help="add front-wheel blocking when the crush reaches the tyre (front overhang minus wheel radius)",
    )
    p.add_argument("--out", type=Path, default=None,
                   help="CSV file to write (default: stdout); an existing file is replaced only when it is a CSV "
                   "this command wrote, unless --force")
    p.add_argument("--force", action="store_true", help="replace --out even when it is not one of our CSVs")
    p.set_defaults(func=run, compiles=True)  # keeps its compiled programs (identify.compile_cache)


DEFAULT_SPEED_KMH = 56.3


def is_our_csv(path: Path) -> bool:
    """True when ``path`` starts with the header line ``identify simulate`` writes."""
    from identify.report.trajectory_csv import COLUMNS

    try:
        with open(path, "rb") as f:
            head = f.read(4096).split(b"\n", 1)[0]
    except OSError:
        return False
    return head.decode("ascii", "replace").startswith(",".join(c[0] for c in COLUMNS))


def check_simulate_out(out: Path, force: bool) -> None:
    """Refuse, before simulating, an --out that names a folder, an unwritable place, or a
    file that is not one of our CSVs (unless ``force``)."""
    from identify.report.results import check_writable_file

    check_writable_file(out)
    if out.exists() and not force:
        if not out.is_file():
            raise UserError(f"--out: {out} exists and is not a file; choose another --out")
        if not is_our_csv(out):
            raise UserError(f"--out: {out} exists and is not a CSV written by 'identify simulate'; "
                            "choose another name, or --force to replace it")


def simulated_model(name_or_path: str, vehicle):
    """(Params, vehicle, impact speed km/h or None, notes) to simulate: a named set or
    parameter file (``sim.load_params``; no speed), or a result.json of ``identify fit`` (it
    has a ``"fit"``) with the model it fitted: its collision parameters, the base model's
    engine it assumed and the mechanisms it discovered
    (``identify.report.results.mechanisms_from_result``), the vehicle changed as discovered,
    and its fitted impact speed; ``notes`` says what was rebuilt or left out."""
    import json

    from identify.report.results import model_from_result
    from sim import load_params

    path = Path(name_or_path)
    doc = None
    if path.suffix == ".json" and path.is_file():
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError, RecursionError):
            doc = None  # load_params says what is wrong with it
    if not (isinstance(doc, dict) and isinstance(doc.get("fit"), dict) and isinstance(doc.get("parameters"), dict)):
        return load_params(name_or_path), vehicle, None, []
    notes: list[str] = []
    params, vehicle = model_from_result(doc, vehicle, path, notes)
    if params.mechanisms:
        notes.append(f"{path.name}: simulated with "
                     + ", ".join(m.effect.replace("_", " ") for m in params.mechanisms) + " as the fit had them")
    speed = doc.get("impact_speed_kmh")
    speed = float(speed) if isinstance(speed, (int, float)) and not isinstance(speed, bool) else None
    return params, vehicle, speed, notes


def run(args: argparse.Namespace) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    import dataclasses
    import sys

    from identify.report.results import write_text_atomic
    from sim import FrontWheelBlock, events_ms, load_vehicle, simulate
    from identify.report.trajectory_csv import trajectory_csv

    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 360):
        raise UserError(f"--speed must be in (0, 360] km/h, got {args.speed}")
    if not (math.isfinite(args.duration_ms) and 1 <= args.duration_ms <= 10000):
        raise UserError(f"--duration-ms must be in [1, 10000], got {args.duration_ms}")
    if args.out is not None:
        check_simulate_out(args.out, args.force)

    vehicle = load_vehicle(args.vehicle)
    params, vehicle, fitted_kmh, notes = simulated_model(args.params, vehicle)
    speed_kmh = args.speed if args.speed is not None else fitted_kmh if fitted_kmh is not None else DEFAULT_SPEED_KMH
    if args.speed is None and fitted_kmh is not None:
        if not (math.isfinite(fitted_kmh) and 0 < fitted_kmh <= 360):
            raise UserError(f"--params {args.params}: its impact_speed_kmh {fitted_kmh} is not in (0, 360] km/h")
        notes.append(f"at the fitted impact speed, {fitted_kmh:.2f} km/h (--speed to change it)")
    for note in notes:
        print(f"note: {note}", file=sys.stderr)
    if args.block_front_wheels:
        params = dataclasses.replace(params, mechanisms=params.mechanisms + (FrontWheelBlock.at_tyre(vehicle),))
    traj = simulate(params, vehicle, speed_kmh / 3.6, duration=args.duration_ms / 1000.0)
    text = trajectory_csv(traj)
    if args.out is None:
        sys.stdout.write(text)
    else:
        write_text_atomic(args.out, text)
    events = {k: v for k, v in events_ms(traj).items() if v is not None}
    summary = ", ".join(f"{k} {v:.1f} ms" for k, v in events.items())
    print(
        f"{vehicle.name} at {speed_kmh:g} km/h: max crush {float(traj.crush.max()):.3f} m; {summary}",
        file=sys.stderr,
    )
    return 0
