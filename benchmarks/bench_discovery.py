"""Benchmark of the discovery of missing physics (run by hand:
``python benchmarks/bench_discovery.py [FILM ...]``, default: the demonstration films).

For each film, in one process: reading and tracking the film, the base fit through the
superset model (``identify.discover.loop.fit_base``, includes the one compile that every later
fit shares), then ``discover`` (candidate fits, held-out checks, residual analysis), and
the same discovery on a second call (everything compiled) as the steady-state figure.
Printed as wall times and as the ratio of the discovery to the 60 s budget of the issue
(2 cores). Also prints what was found, to check the numbers belong to a correct run.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from identify.discover.loop import discover, fit_base  # noqa: E402
from identify.identification import car_geometry_of, free_parameters  # noqa: E402
from identify.recordings.load import load_recording  # noqa: E402
from sim import load_vehicle  # noqa: E402

BUDGET_S = 60.0
DEFAULT = ["a4_zone_and_block", "a4_zone", "a4_wheel_block", "a4_plain"]


def main(argv) -> int:
    films = [Path(a) for a in argv] or [ROOT / "data" / "demos" / f"{n}.mp4" for n in DEFAULT]
    vehicle = load_vehicle("audi_a4")
    for film in films:
        t0 = time.perf_counter()
        m = load_recording(film, car_geometry_of(vehicle)).measurement
        t1 = time.perf_counter()
        free, _ = free_parameters(m, None)
        base = fit_base(m, vehicle, free=free)
        t2 = time.perf_counter()
        result = discover(m, vehicle, base)
        t3 = time.perf_counter()
        discover(m, vehicle, base)
        t4 = time.perf_counter()
        print(f"{film.name}: track {t1 - t0:.1f} s, base fit {t2 - t1:.1f} s, discovery {t3 - t2:.1f} s "
              f"({(t3 - t2) / BUDGET_S:.2f} of the {BUDGET_S:.0f} s budget), again {t4 - t3:.1f} s; "
              f"{result.status}; rms {1e3 * base.rms_m:.2f} -> {1e3 * result.final.rms_m:.2f} mm")
        for d in result.discoveries:
            params = ", ".join(f"{k} {v['value']:.4g}" for k, v in d["parameters"].items())
            print(f"    {d['effect']}: {d['window_ms'][0]:.0f}-{d['window_ms'][1]:.0f} ms, {params}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
