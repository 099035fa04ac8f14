"""How much a reconstruction depends on its inputs: local autodiff sensitivities, Monte Carlo
distributions of the outputs, and Sobol indices.

The inputs an expert types into a simulator (``INPUTS``: the collision parameters, the mass
and the impact speed) go into :func:`sim.simulate`; the outputs an expert reads off
(:mod:`sim.outputs`: maximum crush, its time, rebound speed, positions at chosen times,
wheel-block and rear-lift times) come out. Three views of the dependence:

- :func:`local_sensitivity`: the Jacobian d(output)/d(input) by forward-mode autodiff at the
  baseline, with the elasticity d ln(output) / d ln(input) where both are ratio-scale;
- :func:`monte_carlo`: inputs drawn from an :class:`Uncertainty` (a fit's covariance and/or
  ranges), simulated in vmapped batches; :func:`summarise` gives each output's mean, spread
  and intervals;
- :func:`sobol_indices`: first-order and total Sobol indices (SALib's Saltelli design and
  estimators) with bootstrap confidence intervals.

    from identify.sensitivity import Case, Uncertainty, default_ranges, local_sensitivity
    case = Case(named_params("paper_identified"), load_vehicle("audi_a4"), speed=15.64)
    local = local_sensitivity(case)            # local.elasticity[i, j]: d ln out_i / d ln in_j

Units are SI everywhere (speed in m/s, times in s).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Callable

import numpy as np

from sim.outputs import DEFAULT_TIMES, output_names as _output_names, output_units as _output_units

# name -> (unit, ratio-scale (a relative change means something), where it lives)
INPUTS = {
    "k_compression": ("N/m^3", True, "params"),
    "k_restitution": ("N/m^3", True, "params"),
    "restitution": ("1", True, "params"),
    "dz_contact": ("m", False, "params"),
    "mu_slip": ("1", True, "params"),
    "mu_adhesion": ("1", True, "params"),
    "rolling_resistance": ("1", True, "params"),
    "mass": ("kg", True, "vehicle"),
    "speed": ("m/s", True, "speed"),
}
INPUT_NAMES = tuple(INPUTS)

# Documented default ranges of the inputs for ``identify sensitivity --vehicle ... --params``
# when the user gives none: (kind, amount) with kind "relative" (value * (1 -/+ amount)) or
# "absolute" (value -/+ amount, in the input's unit). They are what an expert typically does
# not know better than: stiffness from a generic class +/- 20 %, restitution +/- 0.05,
# force height +/- 5 cm, tyre friction +/- 10 %, rolling resistance +/- 50 %, mass +/- 5 %
# (occupants, fuel, cargo), impact speed +/- 1 km/h (a film or an EDR measures it about so).
DEFAULT_RANGES = {
    "k_compression": ("relative", 0.20),
    "k_restitution": ("relative", 0.20),
    "restitution": ("absolute", 0.05),
    "dz_contact": ("absolute", 0.05),
    "mu_slip": ("relative", 0.10),
    "mu_adhesion": ("relative", 0.10),
    "rolling_resistance": ("relative", 0.50),
    "mass": ("relative", 0.05),
    "speed": ("absolute", 1.0 / 3.6),
}

# Physical bounds (closed): a sample outside them is rejected (Monte Carlo) or clipped (Sobol).
BOUNDS = {
    "k_compression": (1.0, math.inf),
    "k_restitution": (1.0, math.inf),
    "restitution": (0.0, 1.0),
    "dz_contact": (-1.0, 1.0),
    "mu_slip": (0.0, 2.0),
    "mu_adhesion": (0.0, 2.0),
    "rolling_resistance": (0.0, 2.0),
    "mass": (1.0, math.inf),
    "speed": (0.01, 100.0),
}

INTERVAL_LEVELS = (0.90, 0.95)


@dataclasses.dataclass(frozen=True)
class Case:
    """One reconstruction: the baseline inputs and what is read off.

    Attributes
    ----------
    params : sim.Params (its mechanisms ride along, held fixed).
    vehicle : sim.Vehicle.
    speed : m/s, impact speed.
    duration : s, simulated span.
    times : s, instants at which the CG position x is reported.
    """

    params: object
    vehicle: object
    speed: float
    duration: float = 0.3
    times: tuple = DEFAULT_TIMES

    @property
    def output_names(self) -> list[str]:
        return _output_names(self.times)

    @property
    def output_units(self) -> dict[str, str]:
        return _output_units(self.times)


def baseline_inputs(case: Case) -> np.ndarray:
    """(n_inputs,) the baseline values of ``INPUT_NAMES`` in their units."""
    values = []
    for name, (_, _, where) in INPUTS.items():
        if where == "params":
            values.append(float(getattr(case.params, name)))
        elif where == "vehicle":
            values.append(float(getattr(case.vehicle, name)))
        else:
            values.append(float(case.speed))
    return np.asarray(values)


def apply_inputs(theta, case: Case):
    """(params, vehicle, speed) with the inputs ``theta`` ((n_inputs,), ``INPUT_NAMES``
    order, JAX or NumPy) put in place of the baseline's."""
    th = dict(zip(INPUT_NAMES, [theta[i] for i in range(len(INPUT_NAMES))]))
    params = dataclasses.replace(case.params, **{n: th[n] for n, spec in INPUTS.items() if spec[2] == "params"})
    vehicle = dataclasses.replace(case.vehicle, mass=th["mass"])
    return params, vehicle, th["speed"]


def output_function(case: Case) -> Callable:
    """Return ``f(theta) -> (n_outputs,)``: the outputs of a run with inputs ``theta``
    ((n_inputs,) array, ``INPUT_NAMES`` order). Pure JAX: jit, vmap and jacfwd it."""
    from sim import Solver, n_samples
    from sim.outputs import output_vector
    from sim.simulate import _run_jit

    n_out = n_samples(case.duration)
    solver = Solver()

    def f(theta):
        params, vehicle, speed = apply_inputs(theta, case)
        traj = _run_jit(params, vehicle, speed, n_out, solver)
        return output_vector(traj, case.times)

    return f


# ---------------------------------------------------------------- local sensitivities


@dataclasses.dataclass(frozen=True)
class LocalSensitivity:
    """Derivatives of the outputs with respect to the inputs at the baseline.

    Attributes
    ----------
    input_names, output_names : tuple of str.
    inputs : (n_in,) baseline input values.
    outputs : (n_out,) baseline outputs (``nan`` where an event does not happen).
    derivative : (n_out, n_in) d(output)/d(input), output unit per input unit.
    elasticity : (n_out, n_in) d ln(output) / d ln(input) = derivative * input / output,
        ``nan`` where not meaningful (an input that is a signed offset such as dz', a zero
        input, an output that is not positive).
    """

    input_names: tuple
    output_names: tuple
    inputs: np.ndarray
    outputs: np.ndarray
    derivative: np.ndarray
    elasticity: np.ndarray


def elasticities(derivative, inputs, outputs) -> np.ndarray:
    """(n_out, n_in) d ln(out)/d ln(in) where meaningful (ratio-scale non-zero input,
    positive finite output), ``nan`` elsewhere."""
    derivative = np.asarray(derivative, dtype=float)
    ratio = np.array([INPUTS[n][1] for n in INPUT_NAMES]) & (np.asarray(inputs) != 0.0)
    out = np.asarray(outputs, dtype=float)
    good_out = np.isfinite(out) & (out > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = derivative * np.asarray(inputs)[None, :] / out[:, None]
    return np.where(good_out[:, None] & ratio[None, :], e, np.nan)


def local_sensitivity(case: Case) -> LocalSensitivity:
    """Forward-mode Jacobian of every output with respect to every input at the baseline."""
    import jax

    f = output_function(case)
    theta0 = baseline_inputs(case)
    values, jac = jax.jit(lambda th: (f(th), jax.jacfwd(f)(th)))(theta0)
    values, jac = np.asarray(values), np.asarray(jac)
    jac = np.where(np.isfinite(values)[:, None], jac, np.nan)
    return LocalSensitivity(
        input_names=INPUT_NAMES,
        output_names=tuple(case.output_names),
        inputs=theta0,
        outputs=values,
        derivative=jac,
        elasticity=elasticities(jac, theta0, values),
    )


# ---------------------------------------------------------------- input uncertainty


@dataclasses.dataclass(frozen=True)
class Uncertainty:
    """How the inputs vary around the baseline.

    A joint normal over ``normal_names`` (``mean`` (k,), ``covariance`` (k, k), physical
    units: a fit's covariance) and independent uniforms ``uniform`` ((name, low, high), ...).
    Inputs in neither are held at their baseline.
    """

    normal_names: tuple = ()
    mean: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    covariance: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, 0)))
    uniform: tuple = ()

    def __post_init__(self):
        from identify.errors import UserError

        names = list(self.normal_names) + [u[0] for u in self.uniform]
        unknown = [n for n in names if n not in INPUTS]
        if unknown:
            raise UserError(f"unknown input {unknown[0]!r}; known inputs: {', '.join(INPUT_NAMES)}")
        if len(set(names)) != len(names):
            raise UserError("an input is given both a covariance and a range; give it one of them")
        cov = np.asarray(self.covariance, dtype=float)
        k = len(self.normal_names)
        if cov.shape != (k, k) or np.asarray(self.mean).shape != (k,):
            raise UserError(f"covariance must be {k}x{k} and mean of length {k} for {k} names")
        if k and (not np.all(np.isfinite(cov)) or np.linalg.eigvalsh(0.5 * (cov + cov.T)).min() < -1e-9 * np.abs(cov).max()):
            raise UserError("the covariance matrix is not symmetric positive semi-definite")
        for name, lo, hi in self.uniform:
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise UserError(f"range of {name!r} must have low < high, got {lo:g}:{hi:g}")

    @property
    def varied(self) -> tuple:
        """Names of the inputs that vary, normal ones first."""
        return tuple(self.normal_names) + tuple(u[0] for u in self.uniform)

    def holding(self, names) -> "Uncertainty":
        """The uncertainty with ``names`` held at their values: uniform ones drop out, and
        the joint normal is conditioned on the held ones at their means (its covariance
        becomes the Schur complement: what the others are still free to do)."""
        names = set(names)
        cov = np.asarray(self.covariance, dtype=float)
        keep = [i for i, n in enumerate(self.normal_names) if n not in names]
        held = [i for i, n in enumerate(self.normal_names) if n in names]
        if held:
            c_kh = cov[np.ix_(keep, held)]
            cov = cov[np.ix_(keep, keep)] - c_kh @ np.linalg.pinv(cov[np.ix_(held, held)]) @ c_kh.T
        else:
            cov = cov[np.ix_(keep, keep)]
        return Uncertainty(
            normal_names=tuple(self.normal_names[i] for i in keep),
            mean=np.asarray(self.mean, dtype=float)[keep],
            covariance=0.5 * (cov + cov.T),
            uniform=tuple(u for u in self.uniform if u[0] not in names),
        )

    def spread(self) -> dict[str, float]:
        """name -> one-sigma (normal) or half-range (uniform), in the input's unit."""
        cov = np.asarray(self.covariance, dtype=float)
        out = {n: float(np.sqrt(max(cov[i, i], 0.0))) for i, n in enumerate(self.normal_names)}
        out.update({n: 0.5 * (hi - lo) for n, lo, hi in self.uniform})
        return out


def default_ranges(theta0, names=INPUT_NAMES) -> tuple:
    """((name, low, high), ...) of ``DEFAULT_RANGES`` around the baseline ``theta0``
    ((n_inputs,), ``INPUT_NAMES`` order), clipped to the physical ``BOUNDS``."""
    base = dict(zip(INPUT_NAMES, np.asarray(theta0, dtype=float)))
    out = []
    for name in names:
        kind, amount = DEFAULT_RANGES[name]
        v = base[name]
        half = abs(v) * amount if kind == "relative" else amount
        lo, hi = max(v - half, BOUNDS[name][0]), min(v + half, BOUNDS[name][1])
        if hi > lo:
            out.append((name, lo, hi))
    return tuple(out)


def valid_mask(thetas) -> np.ndarray:
    """(n,) True where a row of inputs ((n, n_inputs)) is physically valid: inside
    ``BOUNDS`` and restitution^2 <= k_restitution / k_compression (see sim.params)."""
    thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
    ok = np.all(np.isfinite(thetas), axis=1)
    for i, name in enumerate(INPUT_NAMES):
        lo, hi = BOUNDS[name]
        ok &= (thetas[:, i] >= lo) & (thetas[:, i] <= hi)
    kc, kr, e = (thetas[:, INPUT_NAMES.index(n)] for n in ("k_compression", "k_restitution", "restitution"))
    with np.errstate(divide="ignore", invalid="ignore"):
        ok &= e**2 <= kr / kc
    return ok


def _draw(uncertainty: Uncertainty, theta0, n, rng) -> np.ndarray:
    thetas = np.repeat(np.asarray(theta0, dtype=float)[None, :], n, axis=0)
    k = len(uncertainty.normal_names)
    if k:
        cov = 0.5 * (uncertainty.covariance + uncertainty.covariance.T)
        w, v = np.linalg.eigh(cov)
        root = v * np.sqrt(np.clip(w, 0.0, None))
        draws = np.asarray(uncertainty.mean)[None, :] + rng.standard_normal((n, k)) @ root.T
        for j, name in enumerate(uncertainty.normal_names):
            thetas[:, INPUT_NAMES.index(name)] = draws[:, j]
    for name, lo, hi in uncertainty.uniform:
        thetas[:, INPUT_NAMES.index(name)] = rng.uniform(lo, hi, n)
    return thetas


def sample_inputs(uncertainty: Uncertainty, theta0, n: int, rng) -> tuple[np.ndarray, int]:
    """Draw ``n`` valid input rows ((n, n_inputs)); invalid draws are rejected and redrawn
    (a truncated distribution). Returns the rows and the number rejected.

    Raises UserError when fewer than 1 in 20 draws is valid (the uncertainty puts most of
    its weight on impossible inputs)."""
    from identify.errors import UserError

    rows, rejected, drawn = [], 0, 0
    need = n
    while need > 0:
        batch = _draw(uncertainty, theta0, max(2 * need, 64), rng)
        idx = np.flatnonzero(valid_mask(batch))[:need]
        used = idx[-1] + 1 if len(idx) == need else len(batch)  # draws consumed, in order
        drawn += used
        rejected += int(used - len(idx))
        rows.append(batch[idx])
        need -= len(idx)
        if need > 0 and drawn > 20 * n + 1000:
            raise UserError(
                f"only {n - need} of {drawn} drawn input sets are physically valid: narrow the ranges "
                "(restitution in [0, 1], restitution^2 <= k_restitution/k_compression, positive stiffness)"
            )
    return np.concatenate(rows, axis=0), rejected


# ---------------------------------------------------------------- batched evaluation


def batch_evaluator(case: Case, batch: int = 2048, workers: int | None = None) -> Callable:
    """Return ``evaluate(thetas, progress=None) -> (n, n_outputs)``: runs the rows of
    ``thetas`` ((n, n_inputs)) in vmapped, jitted batches of ``batch`` (the last one padded,
    so one compilation serves every call), ``workers`` batches at a time in threads (XLA
    runs one batch on one core; default: one worker per core, at most 4);
    ``progress(done, total)`` is called as batches finish. ``evaluate.compile()`` compiles
    ahead of the first call."""
    import os
    from concurrent.futures import ThreadPoolExecutor, as_completed

    import jax

    f = jax.jit(jax.vmap(output_function(case)))
    workers = workers or max(1, min(4, os.cpu_count() or 1))
    compiled = []

    def compile_batch():
        """Compile for the batch shape now (ahead of time), so that progress rates and
        timings that follow are of simulation alone."""
        if not compiled:
            compiled.append(f.lower(jax.ShapeDtypeStruct((batch, len(INPUT_NAMES)), np.float64)).compile())
        return compiled[0]

    def run_chunk(chunk):
        return np.asarray(compiled[0](chunk))

    def evaluate(thetas, progress=None):
        thetas = np.asarray(thetas, dtype=float)
        n = len(thetas)
        if n == 0:
            return np.zeros((0, len(case.output_names)))
        compile_batch()
        chunks = []
        for start in range(0, n, batch):
            chunk = thetas[start : start + batch]
            m = len(chunk)
            if m < batch:
                chunk = np.concatenate([chunk, np.repeat(chunk[:1], batch - m, axis=0)])
            chunks.append((chunk, m))
        results = [None] * len(chunks)
        done = 0
        with ThreadPoolExecutor(max_workers=min(workers, len(chunks))) as pool:
            futures = {pool.submit(run_chunk, chunk): k for k, (chunk, _) in enumerate(chunks)}
            for future in as_completed(futures):
                k = futures[future]
                results[k] = future.result()[: chunks[k][1]]
                done += chunks[k][1]
                if progress is not None:
                    progress(done, n)
        return np.concatenate(results, axis=0)

    evaluate.compile = compile_batch
    return evaluate


class Progress:
    """A one-line progress display on stderr: ``label: done/total simulations (rate, eta)``;
    silent when ``quiet``."""

    def __init__(self, label: str, quiet: bool = False, stream=None):
        import sys

        self.label, self.quiet = label, quiet
        self.stream = sys.stderr if stream is None else stream
        self.t0 = time.perf_counter()
        try:  # a terminal gets one line redrawn with \r; a file or pipe whole lines every 25 %
            self.tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.tty = False
        self.quarter = -1

    def __call__(self, done: int, total: int) -> None:
        if self.quiet:
            return
        elapsed = time.perf_counter() - self.t0
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else 0.0
        text = f"{self.label}: {done:,}/{total:,} simulations, {rate:,.0f}/s, {elapsed:.0f} s elapsed, {eta:.0f} s left"
        if self.tty:
            end = "\n" if done >= total else ""
            self.stream.write(f"\r{text}   {end}")
        else:
            quarter = int(4 * done / total) if total else 4
            if quarter <= self.quarter:
                return
            self.quarter = quarter
            self.stream.write(text + "\n")
        self.stream.flush()


# ---------------------------------------------------------------- Monte Carlo


@dataclasses.dataclass(frozen=True)
class MonteCarlo:
    """Monte Carlo runs: ``inputs`` (n, n_inputs) in ``INPUT_NAMES`` order, ``outputs``
    (n, n_outputs) (``nan`` where an event did not happen), ``rejected`` draws that were
    physically invalid, ``seconds`` of simulation wall time."""

    inputs: np.ndarray
    outputs: np.ndarray
    rejected: int
    seconds: float


def monte_carlo(case: Case, uncertainty: Uncertainty, n: int, seed: int = 0, evaluate=None, progress=None) -> MonteCarlo:
    """Simulate ``n`` input sets drawn from ``uncertainty`` around the baseline of ``case``.

    ``evaluate`` is a :func:`batch_evaluator` of ``case`` (pass one to reuse its
    compilation); ``progress(done, total)`` is called after each batch.
    """
    from identify.errors import UserError

    if n < 2:
        raise UserError(f"--samples must be at least 2, got {n}")
    evaluate = evaluate or batch_evaluator(case)
    rng = np.random.default_rng(seed)
    thetas, rejected = sample_inputs(uncertainty, baseline_inputs(case), n, rng)
    t0 = time.perf_counter()
    outputs = evaluate(thetas, progress)
    return MonteCarlo(inputs=thetas, outputs=outputs, rejected=rejected, seconds=time.perf_counter() - t0)


def summarise(outputs, names, levels=INTERVAL_LEVELS) -> dict:
    """Per output: mean, std, median, equal-tailed intervals at ``levels`` (over the runs in
    which it exists) and the fraction of runs in which it exists (an event may not happen).

    Parameters
    ----------
    outputs : (n, n_outputs).
    names : output names.
    """
    outputs = np.asarray(outputs, dtype=float)
    summary = {}
    for k, name in enumerate(names):
        col = outputs[:, k]
        ok = col[np.isfinite(col)]
        entry = {"n": int(len(ok)), "fraction_happening": float(len(ok) / len(col)) if len(col) else 0.0}
        if len(ok):
            entry.update(mean=float(ok.mean()), std=float(ok.std(ddof=1)) if len(ok) > 1 else 0.0,
                         median=float(np.median(ok)))  # fmt: skip
            for level in levels:
                lo, hi = np.quantile(ok, [0.5 - level / 2, 0.5 + level / 2])
                entry[f"interval_{round(level * 100)}"] = [float(lo), float(hi)]
        summary[name] = entry
    return summary


# ---------------------------------------------------------------- Sobol indices


def _marginal_columns(uncertainty: Uncertainty, unit) -> np.ndarray:
    """Map unit-hypercube samples ((n, n_varied)) to input values through each varied
    input's marginal: normal(mean, sigma) by its quantile function, uniform(low, high)."""
    from scipy.stats import norm

    unit = np.clip(unit, 1e-12, 1 - 1e-12)
    cols = []
    cov = np.asarray(uncertainty.covariance, dtype=float)
    for j, name in enumerate(uncertainty.normal_names):
        cols.append(norm.ppf(unit[:, j], loc=uncertainty.mean[j], scale=np.sqrt(max(cov[j, j], 1e-300))))
    k = len(uncertainty.normal_names)
    for j, (name, lo, hi) in enumerate(uncertainty.uniform):
        cols.append(lo + unit[:, k + j] * (hi - lo))
    return np.stack(cols, axis=1)


def project_valid(thetas) -> tuple[np.ndarray, int]:
    """Clip rows of inputs ((n, n_inputs)) into ``BOUNDS`` and restitution to
    sqrt(k_restitution / k_compression); returns the rows and how many were changed."""
    thetas = np.array(thetas, dtype=float)
    before = thetas.copy()
    for i, name in enumerate(INPUT_NAMES):
        thetas[:, i] = np.clip(thetas[:, i], *BOUNDS[name])
    ik, ir, ie = (INPUT_NAMES.index(n) for n in ("k_compression", "k_restitution", "restitution"))
    thetas[:, ie] = np.minimum(thetas[:, ie], np.sqrt(thetas[:, ir] / thetas[:, ik]))
    return thetas, int(np.any(thetas != before, axis=1).sum())


def sobol_indices(case: Case, uncertainty: Uncertainty, base_n: int = 512, seed: int = 0, evaluate=None,
                  progress=None) -> dict:  # fmt: skip
    """First-order (S1) and total (ST) Sobol indices of every output for the varied inputs.

    Saltelli's design (SALib ``sobol.sample``, ``base_n * (d + 2)`` runs for ``d`` varied
    inputs) and estimators (SALib ``sobol.analyze``, 95 % bootstrap confidence half-widths).
    Inputs are treated as independent with the marginals of ``uncertainty`` (a covariance's
    correlations are left out: Sobol indices assume independent inputs); draws outside the
    physical bounds are clipped onto them.

    Returns
    -------
    dict with ``inputs`` (varied names), ``runs``, ``clipped`` and, per output, ``S1``,
    ``S1_conf``, ``ST``, ``ST_conf`` (lists in ``inputs`` order) or ``null`` with a
    ``reason`` when the output does not exist in every run or does not vary.
    """
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    from identify.errors import UserError

    varied = uncertainty.varied
    d = len(varied)
    if d < 1:
        raise UserError("no input varies: give a covariance or at least one range")
    if base_n < 8 or base_n & (base_n - 1):
        raise UserError(f"the Sobol base sample size must be a power of 2 >= 8, got {base_n}")
    problem = {"num_vars": d, "names": list(varied), "bounds": [[0.0, 1.0]] * d}
    unit = sobol_sample.sample(problem, base_n, calc_second_order=False, seed=seed)
    thetas = np.repeat(baseline_inputs(case)[None, :], len(unit), axis=0)
    cols = _marginal_columns(uncertainty, unit)
    for j, name in enumerate(varied):
        thetas[:, INPUT_NAMES.index(name)] = cols[:, j]
    thetas, clipped = project_valid(thetas)
    evaluate = evaluate or batch_evaluator(case)
    outputs = evaluate(thetas, progress)
    result = {"inputs": list(varied), "runs": int(len(thetas)), "clipped": clipped, "outputs": {}}
    for k, name in enumerate(case.output_names):
        y = outputs[:, k]
        if not np.all(np.isfinite(y)):
            result["outputs"][name] = {"reason": "the output does not exist in every run (an event that sometimes does not happen)"}
            continue
        if np.std(y) <= 1e-12 * max(np.abs(y).max(), 1e-300):
            result["outputs"][name] = {"reason": "the output does not vary"}
            continue
        si = sobol_analyze.analyze(problem, y, calc_second_order=False, num_resamples=100, seed=seed)
        result["outputs"][name] = {key: [float(v) for v in si[key]] for key in ("S1", "S1_conf", "ST", "ST_conf")}
    return result


# ---------------------------------------------------------------- plots


def plot_tornado(local: LocalSensitivity, spread: dict, path, units: dict, outputs=None, fixed=()) -> None:
    """Tornado plot: per output, the linearised change of the output when each input moves
    by -/+ its spread (``spread``: name -> sigma or half-range), largest bar on top.

    Parameters
    ----------
    local : LocalSensitivity.
    spread : input name -> spread in the input's unit (inputs absent are left out).
    path : PNG file to write.
    units : output name -> its unit (the panel's title and axis).
    outputs : names of the outputs to draw (default: all that exist at the baseline).
    fixed : inputs held fixed in the Monte Carlo (drawn pale, labelled "fixed"), whose
        spread is only a what-if (their default range).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in (outputs or local.output_names) if np.isfinite(local.outputs[local.output_names.index(n)])]
    inputs = [n for n in local.input_names if n in spread]
    cols = 3
    rows = max(1, math.ceil(len(names) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 0.32 * len(inputs) * rows + 1.2 * rows), squeeze=False)
    for ax in axes.ravel()[len(names):]:
        ax.axis("off")
    for ax, name in zip(axes.ravel(), names):
        i = local.output_names.index(name)
        base = local.outputs[i]
        deltas = np.array([local.derivative[i, local.input_names.index(n)] * spread[n] for n in inputs])
        order = np.argsort(np.abs(np.nan_to_num(deltas)))
        ys = np.arange(len(order))
        d = np.nan_to_num(deltas[order])
        alpha = [0.3 if inputs[j] in fixed else 0.85 for j in order]
        up = ax.barh(ys, d, left=base, color="tab:red", label="+ spread")
        down = ax.barh(ys, -d, left=base, color="tab:blue", label="- spread")
        for bars in (up, down):
            for bar, a in zip(bars, alpha):
                bar.set_alpha(a)
        ax.axvline(base, color="k", lw=0.8)
        ax.set_yticks(ys, [inputs[j] + (" (fixed)" if inputs[j] in fixed else "") for j in order], fontsize=8)
        ax.set_title(f"{name} = {base:.4g} {units[name]}", fontsize=9)
        ax.set_xlabel(f"{name} [{units[name]}]", fontsize=8)
        ax.tick_params(axis="x", labelsize=8)
    axes.ravel()[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Linearised change of each output for each input moved by -/+ its spread (sigma or half-range;"
                 " pale: inputs held fixed, moved over their default range)", fontsize=10)  # fmt: skip
    fig.tight_layout(rect=(0, 0, 1, 0.98))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_distributions(outputs, names, units, summary, path) -> None:
    """Histograms of the Monte Carlo outputs ((n, n_outputs)) with the median and the 90 %
    interval marked; outputs that never exist are left out. Writes a PNG to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    show = [k for k, n in enumerate(names) if summary[n]["n"] > 1]
    cols = 4
    rows = max(1, math.ceil(len(show) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 2.8 * rows), squeeze=False)
    for ax in axes.ravel()[len(show):]:
        ax.axis("off")
    for ax, k in zip(axes.ravel(), show):
        name = names[k]
        col = outputs[:, k]
        col = col[np.isfinite(col)]
        s = summary[name]
        ax.hist(col, bins=60, color="0.6")
        lo, hi = s["interval_90"]
        for v, style in ((s["median"], "-"), (lo, "--"), (hi, "--")):
            ax.axvline(v, color="tab:red", ls=style, lw=1)
        note = "" if s["fraction_happening"] >= 1 else f", happens in {100 * s['fraction_happening']:.0f} %"
        ax.set_title(f"{name} [{units[name]}]{note}", fontsize=9)
        ax.tick_params(labelsize=7)
    fig.suptitle("Monte Carlo distributions of the outputs (median and 90 % interval in red)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=110)
    plt.close(fig)
