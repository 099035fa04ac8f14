"""Benchmark of ``identify.sensitivity`` (run by hand: ``python benchmarks/bench_sensitivity.py``).

Prints, in one run:

1. Monte Carlo: 100,000 simulations of 300 ms (Audi A4, paper_identified, every input over
   its documented default range) in vmapped batches, with all expert outputs; wall time
   (target < 60 s on 2 cores) and CPU time, against the NumPy/solve_ivp loop of
   ``numpy_model.py`` (a few runs, extrapolated) as the baseline ratio;
2. local sensitivities: the autodiff Jacobian (13 outputs x 9 inputs) against central
   finite differences: time and the largest relative difference (target < 1e-4);
3. coverage: 1,000 synthetic reconstructions with known input distributions; how often the
   90 % Monte Carlo interval of the maximum crush contains the truth (target 90 +/- 3 %).

``--quick`` runs 20,000 simulations and 300 repetitions instead.
"""

from __future__ import annotations

import dataclasses
import os
import resource
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from helpers import central_difference_jacobian  # noqa: E402
from numpy_model import simulate_numpy, vehicle_numbers  # noqa: E402

from identify.sensitivity import (  # noqa: E402
    INPUT_NAMES,
    Case,
    Progress,
    Uncertainty,
    baseline_inputs,
    batch_evaluator,
    default_ranges,
    local_sensitivity,
    output_function,
    sample_inputs,
    summarise,
)
from sim import FrontWheelBlock, load_vehicle, named_params  # noqa: E402

SPEED = 56.3 / 3.6


def cpu_seconds() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bench_monte_carlo(case, n, batch):
    theta0 = baseline_inputs(case)
    u = Uncertainty(uniform=default_ranges(theta0))
    thetas, rejected = sample_inputs(u, theta0, n, np.random.default_rng(0))
    evaluate = batch_evaluator(case, batch=batch)
    t0 = time.perf_counter()
    evaluate.compile()
    compile_s = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), cpu_seconds()
    outputs = evaluate(thetas, Progress("Monte Carlo"))
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    summary = summarise(outputs, case.output_names)["max_crush"]

    veh = vehicle_numbers(case.vehicle)
    runs = 5
    t0 = time.perf_counter()
    for row in thetas[:runs]:
        th = dict(zip(INPUT_NAMES, row))
        simulate_numpy(th["k_compression"], th["k_restitution"], th["restitution"], th["dz_contact"], th["speed"],
                       {**veh, "mass": th["mass"]}, mu_roll=th["rolling_resistance"])  # fmt: skip
    base_per_run = (time.perf_counter() - t0) / runs
    print(f"Monte Carlo, {n:,} simulations of 300 ms (batches of {batch} in {os.cpu_count()} threads; "
          f"{rejected} invalid draws redrawn)")  # fmt: skip
    print(f"  compile                                {compile_s:8.1f} s")
    print(f"  wall time                              {wall:8.1f} s   target < 60 s   ({n / wall:,.0f} simulations/s)")
    print(f"  CPU time                               {cpu:8.1f} s   (CPU/wall {cpu / wall:.2f}; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")  # fmt: skip
    print(f"  NumPy/solve_ivp baseline, one run      {base_per_run * 1e3:8.1f} ms   -> {n:,} runs "
          f"{base_per_run * n / 60:.0f} min")  # fmt: skip
    print(f"  speed-up over the baseline             {base_per_run * n / wall:8.0f} x")
    lo, hi = summary["interval_90"]
    print(f"  max crush: median {summary['median']:.4f} m, 90 % interval {lo:.4f} .. {hi:.4f} m")


def bench_local(case):
    t0 = time.perf_counter()
    local = local_sensitivity(case)
    first = time.perf_counter() - t0
    f = jax.jit(output_function(case))
    f(local.inputs)
    jac = jax.jit(jax.jacfwd(output_function(case)))
    jac(local.inputs).block_until_ready()
    t0 = time.perf_counter()
    for _ in range(5):
        jac(local.inputs).block_until_ready()
    second = (time.perf_counter() - t0) / 5
    t0 = time.perf_counter()
    fd = central_difference_jacobian(lambda th: np.asarray(f(th)), local.inputs, rel_step=1e-5)
    fd_s = time.perf_counter() - t0
    exists = np.isfinite(local.outputs)
    scale = np.abs(local.outputs)[:, None] / np.maximum(np.abs(local.inputs), 0.1)[None, :]
    matters = exists[:, None] & (np.abs(fd) > 1e-6 * scale)
    rel = np.abs(local.derivative[matters] - fd[matters]) / np.abs(fd[matters])
    print(f"Local sensitivities, {exists.sum()} outputs x {len(local.inputs)} inputs")
    print(f"  local_sensitivity (compile + run)      {first:8.1f} s")
    print(f"  autodiff Jacobian, compiled            {second * 1e3:8.1f} ms")
    print(f"  central differences ({2 * len(local.inputs)} runs)        {fd_s:7.2f} s")
    print(f"  largest relative difference            {rel.max():8.1e}   target < 1e-4 ({matters.sum()} entries)")
    i = local.output_names.index("max_crush")
    el = ", ".join(f"{n} {e:+.3f}" for n, e in zip(local.input_names, local.elasticity[i]) if np.isfinite(e))
    print(f"  elasticities of max crush: {el}")


def bench_coverage(case, reps, per):
    theta0 = baseline_inputs(case)
    idx = {n: i for i, n in enumerate(INPUT_NAMES)}
    names = ("k_compression", "k_restitution", "restitution", "dz_contact", "speed")
    cols = [idx[n] for n in names]
    sd = np.array([0.05 * 970e3, 0.05 * 600e3, 0.01, 0.02, 0.2])
    corr = np.eye(5)
    corr[0, 1] = corr[1, 0] = 0.5
    cov = corr * np.outer(sd, sd)
    short = dataclasses.replace(case, duration=0.1, times=(0.05, 0.1))
    evaluate = batch_evaluator(short, batch=4096)
    truth = evaluate(theta0[None, :])[0, 0]
    rng = np.random.default_rng(7)
    estimates = theta0[cols][None, :] + rng.standard_normal((reps, 5)) @ np.linalg.cholesky(cov).T
    rows = [sample_inputs(Uncertainty(names, est, cov), theta0, per, rng)[0] for est in estimates]
    t0 = time.perf_counter()
    crush = evaluate(np.concatenate(rows), Progress("coverage"))[:, 0].reshape(reps, per)
    wall = time.perf_counter() - t0
    lo, hi = np.quantile(crush, [0.05, 0.95], axis=1)
    coverage = np.mean((lo <= truth) & (truth <= hi))
    print(f"Coverage, {reps} synthetic reconstructions x {per} Monte Carlo runs of 100 ms ({wall:.0f} s)")
    print(f"  90 % interval of max crush contains the truth in {100 * coverage:.1f} %   target 90 +/- 3 %"
          f"   (binomial sd {100 * np.sqrt(0.09 / reps):.1f} %)")  # fmt: skip


def main() -> int:
    quick = "--quick" in sys.argv
    vehicle = load_vehicle("audi_a4")
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(vehicle),))
    case = Case(params, vehicle, SPEED, duration=0.3)
    bench_monte_carlo(case, 20_000 if quick else 100_000, batch=4096)
    bench_local(case)
    bench_coverage(case, 300 if quick else 1000, 199)
    return 0


if __name__ == "__main__":
    sys.exit(main())
