"""``identify track``: the video stage alone.

Reads a film, measures the car's motion (``video.track.track_film``) and writes
``tracks.csv`` and a tracking report into the results folder. Nothing is fitted.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from identify.errors import UserError


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``track`` parser to ``subparsers`` and set ``func=run``."""
    p = subparsers.add_parser(
        "track",
        help="measure the car's motion from a film (tracks.csv + tracking report)",
        description="The video stage alone: film in, tracks.csv and a tracking report out.",
    )
    p.add_argument("video", help="video file or folder of numbered frames")
    p.add_argument("--vehicle", required=True,
                   help="vehicle name from data/vehicles/ or a path to a vehicle TOML file")
    p.add_argument("--fps", type=float, default=None,
                   help="true recording rate when the container's is wrong")
    p.add_argument("--tape-segment", type=float, default=0.1,
                   help="length of one reference-tape segment in metres (default 0.1)")
    p.add_argument("--speed", type=float, default=None,
                   help="impact speed in km/h if known (default: measured)")
    p.add_argument("--out", default=None,
                   help="results folder (default: <video stem>.identify/ beside the video)")
    p.add_argument("--force", action="store_true",
                   help="write the tracks even when the film contradicts the vehicle file (wheelbase, length)")
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run)


def _check_vehicle(tracks, args) -> list[str]:
    """The film's wheelbase and length against the vehicle file's (``identify.recordings.consistency``)."""
    from identify.recordings.consistency import check_film_against_vehicle
    from identify.identification import vehicle_label
    from sim import load_vehicle

    return check_film_against_vehicle(tracks, load_vehicle(args.vehicle), vehicle_label(args.vehicle),
                                      force=args.force, verb="track")


def load_car_geometry(name_or_path: str):
    """Build a ``video.types.CarGeometry`` from a vehicle name or TOML path.

    ``sim.load_vehicle`` resolves the name and validates the file (ConfigError, one line);
    ``identify.recordings.synthetic.car_geometry`` builds the video stage's geometry from it.
    """
    from identify.recordings.synthetic import car_geometry
    from sim import load_vehicle, read_vehicle_file

    load_vehicle(name_or_path)
    return car_geometry(read_vehicle_file(name_or_path))


def _progress(quiet: bool):
    """Return a progress callback ``(done, total, stage)`` drawing on stderr, or None.

    On a terminal one line is redrawn; otherwise a line is written every 10 %.
    """
    if quiet:
        return None
    tty = sys.stderr.isatty()
    shown = {"stage": None, "tenth": -1}

    def show(done: int, total: int | None, stage: str = "") -> None:
        if tty:
            end = "\n" if total and done >= total else ""
            tot = f"/{total}" if total else ""
            print(f"\r{stage}: frame {done}{tot}   ", end=end, file=sys.stderr, flush=True)
            return
        tenth = int(10 * done / total) if total else 0
        if stage != shown["stage"] or tenth > shown["tenth"]:
            shown["stage"], shown["tenth"] = stage, tenth
            print(f"{stage}: frame {done}/{total or '?'}", file=sys.stderr, flush=True)

    return show


def run(args: argparse.Namespace) -> int:
    """Track the film ``args.video`` and write tracks.csv + report; return 0."""
    from identify.report.results import RESULT_FILE, TRACK_FILES, ResultsFolder
    from video.io import open_film
    from video.report import write_report, write_tracks_csv
    from video.track import track_film

    video = Path(args.video)
    if not video.exists():
        raise UserError(f"video {video} does not exist")
    if args.fps is not None and not args.fps > 0:
        raise UserError(f"--fps must be positive, got {args.fps}")
    if not args.tape_segment > 0:
        raise UserError(f"--tape-segment must be positive (metres), got {args.tape_segment}")
    if args.speed is not None and not args.speed > 0:
        raise UserError(f"--speed must be positive (km/h), got {args.speed}")
    car = load_car_geometry(args.vehicle)
    out = Path(args.out) if args.out else video.parent / f"{video.stem}.identify"
    # the results' temporary sibling is made before any work: an unwritable place fails now;
    # files of other stages (result.json ...) already there are kept
    folder = ResultsFolder(out, command="track", names=TRACK_FILES, marker=RESULT_FILE, adopt_legacy=False)
    with folder as tmp:
        film = open_film(str(video), fps=args.fps)
        tracks = track_film(
            film, car, tape_segment_m=args.tape_segment,
            speed_mps=None if args.speed is None else args.speed / 3.6,
            progress=_progress(args.quiet),
        )
        warnings = _check_vehicle(tracks, args)
        write_tracks_csv(tracks, tmp / "tracks.csv")
        write_report(tracks, tmp, film=film, car=car)
    for w in warnings:
        print(f"warning: {w}", file=sys.stderr)
    if not args.quiet:
        print(f"wrote {out / 'tracks.csv'} and {out / 'tracking_report.png'}", file=sys.stderr)
        print(f"contact frame {tracks.contact_frame}, impact speed "
              f"{tracks.impact_speed_mps * 3.6:.2f} km/h, scale "
              f"{tracks.scale_m_per_px * 1e3:.4f} mm/px (from the {tracks.scale_source})", file=sys.stderr)
        if tracks.events_ms:
            print("events: " + ", ".join(f"{k} {v:.1f} ms" for k, v in tracks.events_ms.items()
                                         if v is not None), file=sys.stderr)
        for note in tracks.notes:
            print(f"note: {note}", file=sys.stderr)
    return 0
