"""Measure the collision model's own error on calibration worlds and write
``identify/fitting/model_error.json`` (run by hand):

    python benchmarks/accuracy.py --calibration --effect clean --n 16 --format isomme --json cal.json
    python benchmarks/accuracy.py --calibration --effect clean --n 24 --format film --json cal_film.json
    python benchmarks/accuracy.py --calibration --effect rear_axle_lift --n 8 --format film --json cal_lift.json
    python benchmarks/calibrate_model_error.py cal.json cal_film.json cal_lift.json [--dry-run]

One table per kind of recording (film, sensors: ``identify.fitting.model_error.KINDS``); a kind the
given runs do not have keeps the table it had. Each kind's table holds its regimes' tables
(``identify.fitting.model_error.REGIMES``: a fit whose model lifts the rear wheels), measured
on the clean worlds and the worlds of that regime's effect (:data:`REGIME_EFFECTS`) where the
fitted model is in the regime; a regime the given runs do not have keeps the table it had, and
so does the clean worlds' table when the runs have no clean world.

For each parameter of ``SCALE_OF``, the fits' errors against the world's truth and the fits'
own standard deviations (the data's alone, ``std_data``) give the model-form standard
deviation that makes the errors' mean square one combined standard deviation
(``identify.fitting.model_error.calibrate``): relative for a stiffness, a mass and the speed,
absolute for the restitution and the engine's gap. Only values the fit reported identified
count (the term is to make what the tool claims cover the truth), only clean worlds fitted
without a refusal (a concealed effect is discovery's to find, not the model error's to hide),
and only calibration seeds (``accuracy.CALIBRATION_SEED_BASE`` on): the benchmark's scored
seeds and the tests' never calibrate what they score. Printed: per parameter, the worlds,
the RMS error, the RMS of the data's standard deviations, the model term.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from benchmarks.accuracy import CALIBRATION_SEED_BASE, SEED_BASE  # noqa: E402
from identify.fitting.collision_fit import CONTACT_FROM_MOTION, NOT_IDENTIFIED, spread_of  # noqa: E402
from identify.fitting.model_error import REAR_LIFTED, REGIMES, TABLE_FILE, calibrate  # noqa: E402

FORMAT_KIND = {"film": "film", "isomme": "sensors"}  # accuracy.py's --format -> model_error.KINDS

# name -> "relative" (error / truth) or "absolute" (error in the parameter's unit)
SCALE_OF = {"k_compression": "relative", "k_restitution": "relative", "restitution": "absolute",
         "dz_contact": "absolute", "impact_speed": "relative", "contact_time": "absolute",
         "engine_impact.engine_mass": "relative", "engine_impact.gap": "absolute", CONTACT_FROM_MOTION: "absolute"}


def identified_by_the_data(name: str, p: dict) -> bool:
    """Whether the fit would have called a collision parameter identified on its data alone:
    reported identified, or not identified with a data std within ``NOT_IDENTIFIED``'s limit
    (only the model term put it beyond: a table calibrated with one in place must not drop
    the parameters that table itself hides)."""
    if p.get("identified", True):
        return True
    std = p.get("std_data")
    return bool(name in NOT_IDENTIFIED and std and spread_of(name, p["value"], std) <= NOT_IDENTIFIED[name][1])


def errors_of(row: dict) -> dict[str, tuple[float, float]]:
    """name -> (error, data std) of one world's row of ``accuracy.py --json``, in ``SCALE_OF``'
    terms (fractions of the truth, or the parameter's unit). Absent: parameters held fixed,
    and those the data alone leave not identified (``identified_by_the_data``: the model term
    covers what the tool would claim), and the engine's unless the recording measured it. A row
    from before the model's error was added has only ``std``: the data's."""
    out = {}
    for name, p in row.get("params", {}).items():
        std = p.get("std_data", p.get("std"))
        if name not in SCALE_OF or not std or not identified_by_the_data(name, p):
            continue
        if SCALE_OF[name] == "relative":
            true = p["value"] / (1.0 + p["err"] / 100.0)
            out[name] = (p["err"] / 100.0, std / true)
        else:
            out[name] = (p["err"], std)
    speed_std = row.get("speed_std_data_pct", row.get("speed_std_pct"))
    if speed_std:
        out["impact_speed"] = (row["speed_err_pct"] / 100.0, speed_std / 100.0)
    if row.get("fit_contact_err_ms") is not None and row.get("contact_std_data_ms"):  # a film's, s
        out["contact_time"] = (row["fit_contact_err_ms"] / 1e3, row["contact_std_data_ms"] / 1e3)
        # a contact held, not fitted: the error of where the fitted channels alone put it (the
        # fit's contact is where it was held); one the fit's range stopped measured the range
        held = row.get("priors", {}).get("contact_time") or {}
        if held.get("held") and held.get("std_data") and not held.get("at_bound"):
            out[CONTACT_FROM_MOTION] = (row["fit_contact_err_ms"] / 1e3 + held["value"] - held["held_at"],
                                        held["std_data"])
    # a measured engine's parameters (the base model's); an engine discovery named on a clean
    # world is a false discovery, not the base model's error
    engine = row.get("engine") if "engine_impact" in row.get("measured_effects", ()) else None
    for name, e in (engine or {}).items():
        std = e.get("std_data", e.get("std"))
        if name in SCALE_OF and std and e.get("identified", True):
            scale = e["true"] if SCALE_OF[name] == "relative" else 1.0
            out[name] = ((e["value"] - e["true"]) / scale, std / scale)
    return out


def model_error_tables(rows: list[dict], before: dict | None = None) -> dict:
    """The ``model_error.json`` document: one table per kind of recording among ``rows``
    (``FORMAT_KIND``), with its regimes' tables (:func:`in_regime`); what the rows do not
    measure (a kind, its clean worlds' table, a regime) kept from ``before`` (the file as it was)."""
    tables = dict((before or {}).get("tables", {}))
    for fmt, kind in FORMAT_KIND.items():
        mine = [r for r in rows if r.get("format") == fmt]
        if not mine:
            continue
        _refuse_scored_seeds(mine)
        old = tables.get(kind, {})
        clean = any(r["status"] == "ok" and r["effect"] == "clean" for r in mine)
        if not clean and not old:
            raise SystemExit(f"calibrate_model_error: no clean {fmt} world was fitted in these runs")
        table = model_error_table(mine) if clean else {k: v for k, v in old.items() if k != "regimes"}
        regimes = dict(old.get("regimes", {}))
        for regime in REGIMES:
            if any(r["status"] == "ok" and in_regime(r, regime) for r in mine):
                regimes[regime] = model_error_table(mine, regime)
        if regimes:
            table["regimes"] = regimes
        tables[kind] = table
    return {"tables": tables}


# the worlds each regime's table is measured on: clean worlds and those whose concealed effect
# is that regime (the reference world's "rear_axle_lift" is a contact force low enough to lift
# the rear, which the base model can do too: no mechanism it lacks), each where the fitted
# model is in the regime, as the tool tells it (``identify.fitting.model_error.regimes_of``)
REGIME_EFFECTS = {REAR_LIFTED: ("clean", "rear_axle_lift")}
REGIME_WORLDS = {REAR_LIFTED: "reference worlds whose fitted model lifts the rear wheels"}
# the parameters a regime's table holds: those the regime acts on. The rear's lift is the
# pitch the force's height gives (dz_contact) and takes energy into pitch at the rebound
# (restitution); on the 7 lifting calibration films of 2026-11-27 k_compression's error was
# the clean worlds' (11.5 % against 11.4 %), and k_restitution's was one fit's at its range's
# end (2.9e10 N/m^3, 22,000 times the truth, with a data std of 1 %)
REGIME_PARAMETERS = {REAR_LIFTED: ("dz_contact", "restitution")}


def in_regime(row: dict, regime: str) -> bool:
    """Whether a world's row counts for ``regime``'s table (:data:`REGIME_EFFECTS`)."""
    return row["effect"] in REGIME_EFFECTS[regime] and row.get("model_rear_lift_ms") is not None


def _refuse_scored_seeds(rows: list[dict]) -> None:
    scored = [r["seed"] for r in rows if r["seed"] < CALIBRATION_SEED_BASE]
    if scored:
        raise SystemExit(f"calibrate_model_error: seeds {scored[:5]} are not calibration seeds "
                         f"(>= {CALIBRATION_SEED_BASE}; the benchmark scores {SEED_BASE} on): refusing")


def model_error_table(rows: list[dict], regime: str | None = None) -> dict:
    """One kind of recording's table from its calibration rows: the clean worlds fitted, or
    with ``regime`` the worlds of that regime (:func:`in_regime`)."""
    _refuse_scored_seeds(rows)
    if regime is None:
        used, worlds = [r for r in rows if r["status"] == "ok" and r["effect"] == "clean"], "clean reference worlds"
    else:
        used, worlds = [r for r in rows if r["status"] == "ok" and in_regime(r, regime)], REGIME_WORLDS[regime]
    if not used:
        raise SystemExit(f"calibrate_model_error: no {worlds.replace('reference worlds', 'world')} was fitted in these runs")
    by_name: dict[str, list[tuple[float, float]]] = {}
    for r in used:
        for name, pair in errors_of(r).items():
            if regime is None or name in REGIME_PARAMETERS[regime]:
                by_name.setdefault(name, []).append(pair)
    doc = {"relative": {}, "absolute": {}, "measured": {}}
    for name, pairs in sorted(by_name.items()):
        err, std = np.array(pairs).T
        s = calibrate(err, std)
        doc[SCALE_OF[name]][name] = round(float(s), 5)
        doc["measured"][name] = {"worlds": len(pairs), "kind": SCALE_OF[name], "rms_error": float(np.sqrt(np.mean(err ** 2))),
                                 "mean_error": float(np.mean(err)), "rms_std_data": float(np.sqrt(np.mean(std ** 2))),
                                 "model_std": float(s)}
    formats = sorted({r.get("format", "?") for r in used})
    # a film's clean table says how far the fits it was measured on missed x at most: beyond that
    # a fit's model errors are scaled (identify.fitting.model_error.ModelError.beyond_measured;
    # the clean table's, whatever the regime)
    misfit = [r["rms_mm"] / 1e3 for r in used if r.get("format") == "film" and r.get("rms_mm") is not None]
    if misfit and regime is None:
        doc["misfit_x_m"] = round(float(max(misfit)), 6)
    seeds = sorted(r["seed"] for r in used)
    doc["source"] = (f"{len(used)} {worlds} ({', '.join(formats)}; seeds {seeds[0]}-{seeds[-1]}), "
                     f"benchmarks/calibrate_model_error.py, {datetime.date.today().isoformat()}")
    doc["seeds"] = seeds
    return doc


def read_rows(path: Path) -> list[dict]:
    """The world rows of an ``accuracy.py --json`` file, or of its ``.partial.jsonl`` (one row
    per line, written as the run goes)."""
    if path.suffix == ".jsonl":
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    return json.loads(path.read_text())["rows"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="accuracy.py --json files (or their .partial.jsonl) of calibration worlds")
    ap.add_argument("--out", type=Path, default=TABLE_FILE)
    ap.add_argument("--dry-run", action="store_true", help="print the table, write nothing")
    a = ap.parse_args(argv)
    rows = [row for path in a.runs for row in read_rows(path)]
    before = json.loads(a.out.read_text()) if a.out.exists() else None
    doc = model_error_tables(rows, before)
    for kind, table in doc["tables"].items():
        for label, t in ((kind, table), *((f"{kind}, {r}", t) for r, t in table.get("regimes", {}).items())):
            print(f"\n{label}: {t['source']}")
            print("| parameter | worlds | kind | RMS error | mean error | RMS data std | model std |")
            print("|---|---|---|---|---|---|---|")
            for name, m in t["measured"].items():
                print(f"| {name} | {m['worlds']} | {m['kind']} | {m['rms_error']:.4g} | {m['mean_error']:+.4g} | "
                      f"{m['rms_std_data']:.3g} | {m['model_std']:.3g} |")
    if not a.dry_run:
        a.out.write_text(json.dumps(doc, indent=1) + "\n")
        print(f"written: {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
