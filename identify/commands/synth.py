"""``identify synth``: a crash test of the reference world, with its truth.

The reference world (``synth/``) is a crash simulator and a footage renderer that share
nothing with ``sim`` and ``video``: what ``identify fit`` gets right on its films and
recordings is measured, not assumed. A lab can also use it to see what its camera set-up
can measure before it films a crash.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from identify.errors import UserError


def register(sub: argparse._SubParsersAction) -> None:
    from synth.world import EFFECTS

    p = sub.add_parser(
        "synth",
        help="make a synthetic crash test (film or ISO-MME recording) with known truth",
        description="Simulate a frontal barrier crash with the reference world's independent car model and write "
        "it as a randomized crash-test film (or an ISO-MME sensor recording), the vehicle file the fit should "
        "use (vehicle.toml) and the truth (truth.json: parameters, concealed effects, impact speed, motion, events).",
    )
    p.add_argument("--out", type=Path, required=True, help="folder to create (must not exist, or be empty)")
    p.add_argument("--seed", type=int, default=0, help="world seed, >= 0 (default 0): the same seed gives the same test")
    p.add_argument("--effect", default="clean", metavar="EFFECT",
                   help=f"concealed physics: {', '.join(EFFECTS)} or random (default clean)")
    p.add_argument("--vehicle", default=None,
                   help="vehicle name or .toml path (default: a shipped vehicle drawn from the seed and perturbed)")
    p.add_argument("--format", default="film", metavar="FORMAT",
                   help="film (default), isomme, or motion (the simulated motion itself as a tracks.csv:"
                        " what the model alone gets wrong, with no camera)")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from synth.vehicle import SynthError
    from synth.world import check_out_folder, make_world, write_world

    t0 = time.perf_counter()

    def progress(msg: str) -> None:
        if not args.quiet:
            print(f"[{time.perf_counter() - t0:6.1f} s] {msg}", file=sys.stderr, flush=True)

    from identify.report.results import make_temp_dir, remove_temp

    out = args.out
    try:
        check_out_folder(out)  # before the world's simulations: fail in the first second
        world = make_world(args.seed, args.effect, args.vehicle, args.format)
    except SynthError as err:
        raise UserError(str(err)) from None
    # built in a temporary sibling that Ctrl-C removes (identify.report.results keeps the list)
    tmp = make_temp_dir(out.absolute().parent, out.name)
    try:
        truth = write_world(world, out, progress=progress, workdir=tmp)
    except SynthError as err:
        raise UserError(str(err)) from None
    finally:
        remove_temp(tmp)
    effects = ", ".join(e["name"] for e in truth["effects"]) or "none (clean)"
    p = truth["params"]
    print(f"{world.car.name}, {truth['v0_kmh']:.2f} km/h, concealed: {effects}")
    print(f"  k_compression {p['k_compression']:.0f} N/m^3, k_restitution {p['k_restitution']:.0f} N/m^3, "
          f"restitution {p['restitution']:.3f}, dz_contact {p['dz_contact']:+.3f} m")
    print(f"  max crush {truth['max_crush_m']:.3f} m; recording {args.out / truth['recording']}")
    extra = " --tape-segment {:g}".format(truth["tape_segment"]) if truth.get("tape_segment") else ""
    footage = truth.get("footage", {})
    if footage and (footage.get("format") in ("png", "tiff16") or abs(footage["container_fps"] - truth["fps"]) > 1e-6):
        extra += f" --fps {truth['fps']:g}"  # frame folders carry no rate; a re-encoded film a wrong one
    print(f"fit it: identify fit {args.out / truth['recording']} --vehicle {args.out / 'vehicle.toml'}{extra}")
    return 0
