"""``identify sensitivity``: how much a reconstruction depends on the inputs an expert typed in.

    identify sensitivity RESULT_DIR [--samples N] [--out DIR]
    identify sensitivity --vehicle audi_a4 --params paper_identified [--range restitution=0.1:0.25]

With RESULT_DIR the inputs vary as the fit's covariance says (``result.json``:
``"covariance": {"names": [...], "matrix": [[...]]}``, or the parameters' ``std`` when there
is no covariance); with --vehicle/--params they vary over ranges: ``--range NAME=LOW:HIGH``
(in the input's SI unit, except speed in km/h like --speed), and the documented default
ranges (``identify.sensitivity.DEFAULT_RANGES``) for every input without one, unless
``--fix NAME`` holds it.

Writes into the output folder (atomically: a temporary folder renamed at the end):
``sensitivity.json``, ``sensitivity.csv`` (one row per output and input: derivative,
elasticity, linearised spread, Sobol indices), ``intervals.csv`` (Monte Carlo distribution of
each output), ``monte_carlo.csv`` (every run's inputs and outputs), ``tornado.png``, ``distributions.png``, ``comparison_histories.png`` and
``comparison_silhouettes.png`` (the default parameter set against the reconstruction's, the
paper's Figs. 6 and 7).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from identify.errors import UserError

DEFAULT_SPEED_KMH = 56.3
DEFAULT_SAMPLES = 10_000
DEFAULT_SOBOL_SAMPLES = 512
# identify.sensitivity.DEFAULT_RANGES in words (kept here so that --help needs no JAX import;
# tests/test_cli_sensitivity.py checks that the two agree)
DEFAULT_RANGES_HELP = """default ranges with --vehicle/--params (each input without --range or --fix):
  k_compression, k_restitution  value +/- 20 %
  restitution                   value +/- 0.05
  dz_contact                    value +/- 0.05 m
  mu_slip, mu_adhesion          value +/- 10 %
  rolling_resistance            value +/- 50 %
  mass                          value +/- 5 %
  speed                         value +/- 1 km/h
with RESULT_DIR the fit's covariance sets the spread of the parameters it holds; --range adds others."""


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sensitivity",
        help="sensitivity of the reconstruction to its inputs, Monte Carlo intervals, default vs identified",
        description="Local sensitivities (autodiff), Monte Carlo distributions and Sobol indices of the outputs "
        "an expert reads off (maximum crush and its time, rebound speed, positions, wheel-block and rear-lift "
        "times) with respect to the inputs (stiffnesses, restitution, dz', friction, mass, speed); and the "
        "default parameter set compared with the reconstruction's (the paper's Figs. 6 and 7).",
        epilog=DEFAULT_RANGES_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("result_dir", nargs="?", type=Path, default=None,
                   help="results folder of 'identify fit' (reads result.json; samples from its covariance)")  # fmt: skip
    p.add_argument("--vehicle", help="vehicle name or .toml (without RESULT_DIR)")
    p.add_argument("--params", help="named parameter set or JSON file (without RESULT_DIR)")
    p.add_argument("--speed", type=float, default=None,
                   help=f"impact speed in km/h (default: the result's, else {DEFAULT_SPEED_KMH})")  # fmt: skip
    p.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                   help=f"Monte Carlo simulations (default {DEFAULT_SAMPLES})")  # fmt: skip
    p.add_argument("--sobol-samples", type=int, default=DEFAULT_SOBOL_SAMPLES,
                   help="Sobol base sample size N, a power of 2; runs N * (inputs + 2) simulations; 0 skips "
                   f"(default {DEFAULT_SOBOL_SAMPLES})")  # fmt: skip
    p.add_argument("--range", action="append", default=[], metavar="NAME=LOW:HIGH",
                   help="uniform range of an input (SI units; speed in km/h); repeatable")  # fmt: skip
    p.add_argument("--fix", action="append", default=[], metavar="NAME",
                   help="hold an input at its value (with --params: no default range; with RESULT_DIR the "
                   "covariance of the others is conditioned on it); repeatable")  # fmt: skip
    p.add_argument("--block-front-wheels", action="store_true",
                   help="add front-wheel blocking when the crush reaches the tyre (as 'identify simulate')")  # fmt: skip
    p.add_argument("--compare-with", default="vsim_default",
                   help="parameter set drawn against the reconstruction's (default vsim_default)")  # fmt: skip
    p.add_argument("--duration-ms", type=float, default=300.0, help="simulated time after contact (default 300)")
    p.add_argument("--times-ms", default=None, metavar="T1,T2,...",
                   help="instants at which the CG position x is reported (default 50,100,...,300 within the span)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", type=Path, default=None,
                   help="output folder (default: RESULT_DIR/sensitivity, else <vehicle>_<params>.sensitivity)")  # fmt: skip
    p.add_argument("--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=run, compiles=True)  # keeps its compiled programs (identify.compile_cache)


def parse_range(text: str, speed_in_kmh: bool = True) -> tuple[str, float, float]:
    """``NAME=LOW:HIGH`` -> (name, low, high) in SI (speed given in km/h is converted)."""
    from identify.sensitivity import INPUTS

    name, sep, bounds = text.partition("=")
    name = name.strip()
    lo_text, colon, hi_text = bounds.partition(":")
    if not sep or not colon:
        raise UserError(f"--range {text!r}: expected NAME=LOW:HIGH, e.g. restitution=0.1:0.25")
    if name not in INPUTS:
        raise UserError(f"--range {text!r}: unknown input {name!r}; known: {', '.join(INPUTS)}")
    try:
        lo, hi = float(lo_text), float(hi_text)
    except ValueError:
        raise UserError(f"--range {text!r}: LOW and HIGH must be numbers") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise UserError(f"--range {text!r}: needs finite LOW < HIGH")
    if name == "speed" and speed_in_kmh:
        lo, hi = lo / 3.6, hi / 3.6
    return name, lo, hi


def parse_times(text, duration_ms: float) -> tuple:
    """``"50,100,150"`` (ms) -> (0.05, 0.1, 0.15) s; default 50, 100, ... 300 ms within the span."""
    if text is None:
        return tuple(s / 1000.0 for s in range(50, 301, 50) if s <= duration_ms + 1e-9)
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UserError(f"--times-ms {text!r}: expected numbers separated by commas, e.g. 50,100,150") from None
    bad = [v for v in values if not (math.isfinite(v) and 0 < v <= duration_ms)]
    if not values or bad:
        raise UserError(f"--times-ms {text!r}: every time must be in (0, {duration_ms:g}] ms (the simulated span)")
    return tuple(sorted(set(v / 1000.0 for v in values)))


def load_result(result_dir: Path, speed_kmh, notes):
    """(vehicle, params, speed m/s, Uncertainty of the normal part) from ``result.json``."""
    import json

    import numpy as np

    from identify.sensitivity import INPUTS, Uncertainty
    from identify.report.results import model_from_result
    from sim import load_vehicle
    from sim.errors import ConfigError
    from sim.params import UNITS

    path = result_dir / "result.json"
    if not path.is_file():
        raise UserError(f"{result_dir}: no result.json in it (run 'identify fit' first, or give --vehicle and --params)")
    from sim._text import read_text

    text = read_text(path, "results file", error=UserError)
    try:
        doc = json.loads(text)
    except RecursionError:
        raise UserError(f"{path}: not valid JSON (nested too deeply)") from None
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg}, line {err.lineno})") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("parameters"), dict):
        raise UserError(f"{path}: no \"parameters\" object")
    vehicle_ref = doc.get("vehicle")
    if not isinstance(vehicle_ref, str):
        raise UserError(f"{path}: \"vehicle\" must be a vehicle name or path")
    local = result_dir / vehicle_ref
    vehicle = load_vehicle(local if vehicle_ref.endswith(".toml") and local.is_file() else vehicle_ref)
    table = {name: entry for name, entry in doc["parameters"].items() if name in UNITS}
    stds = {}
    for name, entry in table.items():
        std = entry.get("std") if isinstance(entry, dict) else None
        if isinstance(std, (int, float)) and math.isfinite(std) and std > 0:
            if name in INPUTS:
                stds[name] = float(std)
            else:  # a parameter of the fitted model that is no input here (the barrier face's friction)
                notes.append(f"{name} is not an input of the sensitivity study: held at its fitted value")
    try:
        params, vehicle = model_from_result(doc, vehicle, path, notes)
    except ConfigError as err:
        raise UserError(str(err)) from None
    values = {name: float(getattr(params, name)) for name in table}

    if speed_kmh is not None:
        speed = speed_kmh / 3.6
    elif isinstance(doc.get("speed_mps"), (int, float)):
        speed = float(doc["speed_mps"])
    elif isinstance(doc.get("impact_speed_kmh"), (int, float)):
        speed = float(doc["impact_speed_kmh"]) / 3.6
    else:
        speed = DEFAULT_SPEED_KMH / 3.6
        notes.append(f"result.json gives no impact speed: {DEFAULT_SPEED_KMH} km/h used")

    cov_doc = doc.get("covariance")
    baseline = {**values, "speed": speed, "mass": float(vehicle.mass)}
    if isinstance(cov_doc, dict):
        names = cov_doc.get("names")
        matrix = np.asarray(cov_doc.get("matrix"), dtype=float) if cov_doc.get("matrix") is not None else None
        if not isinstance(names, list) or matrix is None or matrix.shape != (len(names), len(names)):
            raise UserError(f"{path}: \"covariance\" must hold \"names\" and a square \"matrix\" of that size")
        names = ["speed" if n in ("speed_mps", "impact_speed") else n for n in names]
        keep = [i for i, n in enumerate(names) if n in INPUTS and n in baseline]
        dropped = [n for i, n in enumerate(names) if i not in keep]
        if dropped:
            notes.append(f"covariance entries {dropped} are not inputs of the sensitivity study: marginalised out "
                         "(mechanism parameters stay at their fitted values)")  # fmt: skip
        kept = tuple(names[i] for i in keep)
        cov = matrix[np.ix_(keep, keep)]
        mode = "covariance"
    elif stds:
        kept = tuple(stds)
        cov = np.diag([stds[n] ** 2 for n in kept])
        notes.append("result.json has no covariance: independent normals from the parameters' std")
        mode = "std"
    else:
        raise UserError(f"{path}: neither a \"covariance\" nor parameter std to sample from; "
                        "give ranges instead: --vehicle ... --params ... --range NAME=LOW:HIGH")  # fmt: skip
    if not kept:
        raise UserError(f"{path}: the covariance names none of the inputs")
    try:
        normal = Uncertainty(normal_names=kept, mean=np.array([baseline[n] for n in kept]), covariance=cov)
    except UserError as err:
        raise UserError(f"{path}: {err}") from None
    return vehicle, params, speed, normal, mode, vehicle_ref


def _jsonable(value):
    """Floats with nan/inf -> None, numpy types -> Python, recursively."""
    import numpy as np

    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def _csv_rows(local, spread, sobol, units):
    import csv
    import io

    from identify.sensitivity import INPUTS

    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["output", "output_unit", "output_value", "input", "input_unit", "input_value", "derivative",
                "elasticity", "input_spread", "linear_change", "sobol_S1", "sobol_S1_conf", "sobol_ST",
                "sobol_ST_conf"])  # fmt: skip

    def fmt(v):
        return "" if v is None or not math.isfinite(v) else f"{v:.6g}"

    for i, out in enumerate(local.output_names):
        so = (sobol or {}).get("outputs", {}).get(out, {})
        for j, name in enumerate(local.input_names):
            s = spread.get(name)
            k = sobol["inputs"].index(name) if sobol and "S1" in so and name in sobol["inputs"] else None
            w.writerow([out, units[out], fmt(local.outputs[i]), name, INPUTS[name][0], fmt(local.inputs[j]),
                        fmt(local.derivative[i, j]), fmt(local.elasticity[i, j]), fmt(s),
                        fmt(local.derivative[i, j] * s if s is not None else None),
                        *(fmt(so[key][k]) if k is not None else "" for key in ("S1", "S1_conf", "ST", "ST_conf"))])  # fmt: skip
    return buf.getvalue()


def _summary_table(local, summary, spread, units) -> str:
    """Plain-text table for the terminal: each output's value, 90 % interval and the two
    varied inputs that move it most (linearised change over each input's spread)."""
    import numpy as np

    lines = [f"{'output':<26} {'value':>10} {'90 % interval':>23}  most sensitive to (linear change)"]
    for i, name in enumerate(local.output_names):
        s = summary[name]
        if not np.isfinite(local.outputs[i]) and s["n"] == 0:
            lines.append(f"{name:<26} {'-':>10} {'(does not happen)':>23}")
            continue
        interval = "{:.4g} .. {:.4g}".format(*s["interval_90"]) if "interval_90" in s else "-"
        change = {n: abs(local.derivative[i, j] * spread[n]) for j, n in enumerate(local.input_names) if n in spread}
        top = sorted((v, n) for n, v in change.items() if np.isfinite(v))[::-1][:2]
        drivers = ", ".join(f"{n} {v:.2g}" for v, n in top)
        value = f"{local.outputs[i]:.4g}" if np.isfinite(local.outputs[i]) else "-"
        lines.append(f"{name + ' [' + units[name] + ']':<26} {value:>10} {interval:>23}  {drivers}")
    return "\n".join(lines)


def _runs_csv(inputs, outputs, names):
    """One row per Monte Carlo run: its inputs (SI, speed in m/s) and outputs (empty where an
    event did not happen)."""
    import numpy as np

    from identify.sensitivity import INPUT_NAMES

    header = ",".join(["run", *INPUT_NAMES, *names])
    lines = [header]
    table = np.concatenate([inputs, outputs], axis=1)
    for k, row in enumerate(table):
        lines.append(",".join([str(k), *("" if not np.isfinite(v) else f"{v:.9g}" for v in row)]))
    return "\n".join(lines) + "\n"


def _intervals_csv(summary, units):
    lines = ["output,unit,fraction_happening,mean,std,median,p05,p95,p2.5,p97.5"]

    def fmt(v):
        return "" if v is None else f"{v:.6g}"

    for name, s in summary.items():
        i90, i95 = s.get("interval_90", [None, None]), s.get("interval_95", [None, None])
        lines.append(",".join([name, units[name], f"{s['fraction_happening']:.4f}",
                               *(fmt(s.get(k)) for k in ("mean", "std", "median")),
                               fmt(i90[0]), fmt(i90[1]), fmt(i95[0]), fmt(i95[1])]))  # fmt: skip
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    from identify.report.results import SENSITIVITY_FILES, ResultsFolder

    if args.result_dir is not None and (args.vehicle or args.params):
        raise UserError("give either RESULT_DIR or --vehicle and --params, not both")
    if args.result_dir is None and not (args.vehicle and args.params):
        raise UserError("give a results folder (RESULT_DIR) or both --vehicle and --params")
    if args.result_dir is not None and not args.result_dir.is_dir():
        raise UserError(f"{args.result_dir}: no such results folder")
    if args.out is None:
        out = (args.result_dir / "sensitivity") if args.result_dir is not None else Path(
            f"{Path(args.vehicle).stem}_{Path(args.params).stem}.sensitivity")
    else:
        out = args.out
    # the output's temporary sibling is made before anything heavy loads: an unwritable
    # place fails within the first second
    folder = ResultsFolder(out, command="sensitivity", names=SENSITIVITY_FILES, marker="sensitivity.json",
                           kind="sensitivity")
    try:
        return _checked_run(args, folder)
    except BaseException:
        folder.discard()
        raise


def _checked_run(args, folder) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    from identify import sensitivity as sens

    # ---- check every option before any work
    if args.speed is not None and not (math.isfinite(args.speed) and 0 < args.speed <= 360):
        raise UserError(f"--speed must be in (0, 360] km/h, got {args.speed}")
    if not (math.isfinite(args.duration_ms) and 100 <= args.duration_ms <= 2000):
        raise UserError(f"--duration-ms must be in [100, 2000] (the outputs need the impact), got {args.duration_ms}")
    if args.samples < 100:
        raise UserError(f"--samples must be at least 100, got {args.samples}")
    if args.sobol_samples and (args.sobol_samples < 8 or args.sobol_samples & (args.sobol_samples - 1)):
        raise UserError(f"--sobol-samples must be 0 or a power of 2 >= 8, got {args.sobol_samples}")
    ranges = [parse_range(r) for r in args.range]
    times = parse_times(args.times_ms, args.duration_ms)
    for name in args.fix:
        if name not in sens.INPUTS:
            raise UserError(f"--fix {name!r}: unknown input; known: {', '.join(sens.INPUTS)}")
    return _run(args, folder, ranges, times)


def _run(args, folder, ranges, times) -> int:
    import dataclasses
    import json
    import sys

    from identify.report import comparison as cmp
    from identify import sensitivity as sens
    from sim import FrontWheelBlock, load_params, load_vehicle, n_samples

    out = folder.out

    notes: list[str] = []
    duration = args.duration_ms / 1000.0
    n_samples(duration)
    if args.result_dir is not None:
        vehicle, params, speed, normal, mode, vehicle_ref = load_result(args.result_dir, args.speed, notes)
        ranged = {r[0] for r in ranges}
        clash = ranged & set(normal.normal_names)
        if clash:
            raise UserError(f"--range {sorted(clash)[0]}: that input already varies with the fit's covariance")
        uncertainty = sens.Uncertainty(normal.normal_names, normal.mean, normal.covariance,
                                       uniform=tuple(ranges)).holding(args.fix)  # fmt: skip
        if set(args.fix) & set(normal.normal_names):
            notes.append(f"held fixed: {sorted(set(args.fix) & set(normal.normal_names))}; the covariance of the "
                         "other parameters is conditioned on them")  # fmt: skip
        source = {"result_dir": str(args.result_dir), "sampling": mode}
    else:
        vehicle_ref = args.vehicle
        vehicle = load_vehicle(args.vehicle)
        params = load_params(args.params)
        speed = (DEFAULT_SPEED_KMH if args.speed is None else args.speed) / 3.6
        uncertainty = None
        source = {"params": args.params, "sampling": "ranges"}
    if args.block_front_wheels and not any(isinstance(m, FrontWheelBlock) for m in params.mechanisms):
        params = dataclasses.replace(params, mechanisms=params.mechanisms + (FrontWheelBlock.at_tyre(vehicle),))
    case = sens.Case(params, vehicle, float(speed), duration=duration, times=times)
    theta0 = sens.baseline_inputs(case)
    if uncertainty is None:
        given = {r[0]: r for r in ranges}
        defaults = {r[0]: r for r in sens.default_ranges(theta0)}
        uniform = tuple(given.get(n, defaults.get(n)) for n in sens.INPUT_NAMES
                        if n not in args.fix and (n in given or n in defaults))  # fmt: skip
        uncertainty = sens.Uncertainty(uniform=uniform)
    if not uncertainty.varied:
        raise UserError("no input varies (everything is fixed)")
    default_params = load_params(args.compare_with)

    # ---- the work
    say = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    say(f"{vehicle.name} at {speed * 3.6:.1f} km/h; varying {', '.join(uncertainty.varied)}")
    say("local sensitivities (autodiff) ...")
    local = sens.local_sensitivity(case)
    evaluate = sens.batch_evaluator(case, batch=min(2048, max(256, args.samples)))
    say("compiling the batched simulation ...")
    evaluate.compile()
    mc = sens.monte_carlo(case, uncertainty, args.samples, seed=args.seed, evaluate=evaluate,
                          progress=sens.Progress("Monte Carlo", args.quiet))  # fmt: skip
    if mc.rejected:
        notes.append(f"{mc.rejected} physically invalid draws were rejected and redrawn (truncated distribution)")
    names, units = case.output_names, case.output_units
    summary = sens.summarise(mc.outputs, names)
    sobol = None
    if args.sobol_samples:
        sobol = sens.sobol_indices(case, uncertainty, base_n=args.sobol_samples, seed=args.seed, evaluate=evaluate,
                                   progress=sens.Progress("Sobol design", args.quiet))  # fmt: skip
        if len(uncertainty.normal_names) > 1:
            notes.append("Sobol indices treat the inputs as independent (the covariance's correlations are left out)")
    run_id, run_def = cmp.simulate_pair(vehicle, params, default_params, speed, duration)
    comparison = cmp.compare_runs(run_id, run_def)
    spread = uncertainty.spread()
    # inputs held fixed still get a tornado bar over their documented default range
    for name, lo, hi in sens.default_ranges(theta0):
        spread.setdefault(name, 0.5 * (hi - lo))

    dist = {}
    for j, name in enumerate(sens.INPUT_NAMES):
        if name in uncertainty.normal_names:
            k = uncertainty.normal_names.index(name)
            dist[name] = {"kind": "normal", "mean": uncertainty.mean[k], "std": math.sqrt(uncertainty.covariance[k, k])}
        elif name in [u[0] for u in uncertainty.uniform]:
            _, lo, hi = next(u for u in uncertainty.uniform if u[0] == name)
            dist[name] = {"kind": "uniform", "low": lo, "high": hi}
        else:
            dist[name] = {"kind": "fixed"}
    report = {
        "vehicle": vehicle_ref,
        "speed_mps": speed,
        "impact_speed_kmh": speed * 3.6,
        "duration_s": duration,
        "source": source,
        "inputs": {n: {"value": theta0[j], "unit": sens.INPUTS[n][0], "distribution": dist[n]}
                   for j, n in enumerate(sens.INPUT_NAMES)},  # fmt: skip
        "outputs": {n: {"value": local.outputs[i], "unit": units[n]} for i, n in enumerate(names)},
        "local": {
            "definition": "derivative: d(output)/d(input) in output unit per input unit (forward-mode autodiff); "
            "elasticity: d ln(output)/d ln(input), null where not meaningful (signed inputs such as dz_contact, "
            "events that do not happen); linear_change: derivative * input spread (sigma or half-range; for "
            "inputs held fixed, half their documented default range, a what-if)",
            "input_spread": spread,
            "derivative": {n: dict(zip(sens.INPUT_NAMES, local.derivative[i])) for i, n in enumerate(names)},
            "elasticity": {n: dict(zip(sens.INPUT_NAMES, local.elasticity[i])) for i, n in enumerate(names)},
            "linear_change": {n: {m: local.derivative[i, j] * spread[m] for j, m in enumerate(sens.INPUT_NAMES)
                                  if m in spread} for i, n in enumerate(names)},  # fmt: skip
        },
        "monte_carlo": {"samples": args.samples, "seed": args.seed, "rejected": mc.rejected,
                        "seconds": mc.seconds, "outputs": summary},  # fmt: skip
        "sobol": sobol,
        "comparison": {"reference": args.compare_with, **comparison},
        "notes": notes,
    }

    def write(folder: Path):
        (folder / "sensitivity.json").write_text(json.dumps(_jsonable(report), indent=2) + "\n")
        (folder / "sensitivity.csv").write_text(_csv_rows(local, spread, sobol, units))
        (folder / "intervals.csv").write_text(_intervals_csv(summary, units))
        (folder / "monte_carlo.csv").write_text(_runs_csv(mc.inputs, mc.outputs, names))
        sens.plot_tornado(local, spread, folder / "tornado.png", units, fixed=set(spread) - set(uncertainty.varied))
        sens.plot_distributions(mc.outputs, names, units, summary, folder / "distributions.png")
        labels = (Path(str(args.params)).stem if args.params else "identified", args.compare_with)
        title = f"{vehicle.name}, {speed * 3.6:.1f} km/h"
        cmp.plot_histories(run_id, run_def, labels, folder / "comparison_histories.png", title=title)
        cmp.plot_silhouettes(vehicle, run_id, run_def, labels, folder / "comparison_silhouettes.png", title=title)

    with folder as tmp:
        write(tmp)
    say(_summary_table(local, summary, uncertainty.spread(), units))
    s = summary["max_crush"]
    if "interval_90" in s:
        lo, hi = s["interval_90"]
        say(f"max crush {local.outputs[0]:.3f} m, 90 % interval {lo:.3f} .. {hi:.3f} m; "
            f"default vs reconstruction: |dX| peaks at {comparison['peak_dx_m']:.3f} m at "
            f"{comparison['peak_time_s'] * 1e3:.0f} ms")  # fmt: skip
    say(f"wrote {out}")
    return 0
