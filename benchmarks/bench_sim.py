"""Benchmark of the collision model (run by hand: ``python benchmarks/bench_sim.py``).

Prints, in one run: compile time; one 300 ms simulation; its Jacobian with respect to 4
parameters; throughput of a vmapped batch of 10,000 parameter sets; and the same
simulation as a NumPy/solve_ivp loop (``numpy_model.py``) as the baseline, as ratios.
Targets (2 cores): simulation + Jacobian < 50 ms; batch > 2,000 simulations/s; >= 20x the
baseline.
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from numpy_model import simulate_numpy, vehicle_numbers  # noqa: E402

from sim import Solver, load_vehicle, named_params  # noqa: E402
from sim.simulate import _run_jit  # noqa: E402

SPEED = 56.3 / 3.6
N_OUT = 301  # 300 ms at 1 ms
BATCH = 10_000


def best_of(fn, repeats):
    """Median wall time (s) of ``fn()`` over ``repeats`` calls."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    vehicle = load_vehicle("audi_a4")
    params = named_params("paper_identified")
    solver = Solver()

    def run(p):
        return _run_jit(p, vehicle, SPEED, N_OUT, solver)

    t0 = time.perf_counter()
    run(params).x.block_until_ready()
    compile_s = time.perf_counter() - t0
    one_s = best_of(lambda: run(params).x.block_until_ready(), 20)

    def outputs(theta):
        p = dataclasses.replace(
            params, k_compression=theta[0], k_restitution=theta[1], restitution=theta[2], dz_contact=theta[3]
        )
        r = run(p)
        return jnp.concatenate([r.x, r.z, r.pitch])

    jac = jax.jit(jax.jacfwd(outputs))
    theta = jnp.array([970e3, 600e3, 0.17, -0.21])
    t0 = time.perf_counter()
    jac(theta).block_until_ready()
    jac_compile_s = time.perf_counter() - t0
    jac_s = best_of(lambda: jac(theta).block_until_ready(), 10)

    batch_fn = jax.jit(jax.vmap(lambda k: run(dataclasses.replace(params, k_compression=k)).x))
    ks = jnp.linspace(700e3, 1300e3, BATCH)
    batch_fn(ks).block_until_ready()
    batch_s = best_of(lambda: batch_fn(ks).block_until_ready(), 3)

    veh = vehicle_numbers(vehicle)
    base_s = best_of(lambda: simulate_numpy(970e3, 600e3, 0.17, -0.21, SPEED, veh), 3)
    _, x_np, _, pitch_np = simulate_numpy(970e3, 600e3, 0.17, -0.21, SPEED, veh)
    ref = run(params)
    dx = np.abs(np.asarray(ref.x) - x_np).max()
    dpitch = np.abs(np.asarray(ref.pitch) - pitch_np).max()

    print(f"compile (first 300 ms simulation)      {compile_s * 1e3:9.1f} ms")
    print(f"one 300 ms simulation (jitted)          {one_s * 1e3:9.2f} ms")
    print(f"its Jacobian w.r.t. 4 parameters        {jac_s * 1e3:9.2f} ms   (compile {jac_compile_s:.1f} s)")
    print(f"simulation + Jacobian                   {(one_s + jac_s) * 1e3:9.2f} ms   target < 50 ms")
    print(f"vmapped batch of {BATCH}                {BATCH / batch_s:9.0f} simulations/s   target > 2000")
    print(f"NumPy/solve_ivp baseline, one run       {base_s * 1e3:9.1f} ms")
    print(f"speed-up, one simulation                {base_s / one_s:9.1f} x   target >= 20")
    print(f"speed-up, batch (per simulation)        {base_s / (batch_s / BATCH):9.0f} x")
    print(f"agreement with the baseline: max |dx| {dx * 1e3:.3f} mm, max |dpitch| {np.degrees(dpitch):.4f} deg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
