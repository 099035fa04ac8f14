"""``identify vehicles``: list the vehicle files that ship."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("vehicles", help="list the vehicle files that ship", description=__doc__)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from sim import list_vehicles, load_vehicle

    rows = []
    for key in list_vehicles():
        v = load_vehicle(key)
        rows.append((key, v.name, f"{float(v.mass):.0f} kg", f"{float(v.length):.3f} m"))
    width = max(len(r[0]) for r in rows)
    print(f"{'name':<{width}}  {'mass':>8}  {'length':>8}  description")
    for key, name, mass, length in rows:
        print(f"{key:<{width}}  {mass:>8}  {length:>8}  {name}")
    return 0
