"""The data-driven fall-back: when no candidate mechanism explains a misfit, estimate the
missing force as a function of time, describe its shape, and report it as ``unexplained``.

Model: the x residual (measured - model, m) is the response of the car's mass m to an
extra horizontal force F(t) = sum_j c_j h_j(t), h_j triangular pulses (hats) of half-width
``knot_ms`` centred every ``knot_ms`` over the recording after contact. A pulse's response
is its double integral divided by m. Sparse regression: forward selection of hats
(orthogonal matching pursuit on the sigma-weighted residual), one at a time while each
lowers the extended BIC (chi2 + k (ln n + 2 ln K), K the number of possible pulses,
tau-scaled as in discovery); the force is kept only if the whole lowers it by
``min_bic_gain`` and lowers the x residual's RMS by a tenth. The fitted parameters may
readjust alongside (their sensitivities, by central differences through the simulation,
enter every regression: linearised refit), unpenalised but for what was measured before the
fit (a film's speed and scale, the contact seen, a header's speed, a prior), each held to its
measurement by a row (shift / sigma): a flexible force with a free speed and scale bends them
anywhere (scored world 910015, clean: the force's refit put the speed 62 % off, and that
choice of model then widened the reported speed's std to 38 km/h). The estimate ignores the feedback
of the extra force on the crush: it describes where and how much, not a law.

The force is then compared along the fitted trajectory with physically meaningful terms
(crush depth, crush rate, a constant): the share of its variance each explains says
whether it behaves like a stiffness, a damping or a pulse in time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from identify.fitting.residuals import model_crush, phase_at, phase_times_ms


@dataclasses.dataclass
class MissingForce:
    """An estimated missing force (positive: towards the barrier, i.e. the model pushes the
    car back too hard).

    t_ms : (n,) ms after first contact; force_n : (n,) N; force_std_n : (n,) N, one sigma;
    window_ms : where |F| exceeds a quarter of its peak; peak_n, t_peak_ms, impulse_ns;
    rms_before_m, rms_after_m : x residual RMS without and with the force; bic_before,
    bic_after; n_terms : pulses selected; shape : words about its form; description : the
    full sentence for the report; parameter_shift : how far each fitted parameter of the
    model moved (its units) when the force was added (the linearised refit).
    """

    t_ms: np.ndarray
    force_n: np.ndarray
    force_std_n: np.ndarray
    window_ms: tuple[float, float]
    peak_n: float
    peak_std_n: float
    t_peak_ms: float
    impulse_ns: float
    rms_before_m: float
    rms_after_m: float
    bic_before: float
    bic_after: float
    n_terms: int
    crush_m: tuple[float, float]
    phase: str
    shape: str
    description: str
    parameter_shift: dict = dataclasses.field(default_factory=dict)

    def as_discovery(self, fr=None) -> dict:
        """The entry of result.json's "discoveries"."""
        return {
            "effect": "unexplained",
            "explanation": self.description,
            "window_ms": [float(self.window_ms[0]), float(self.window_ms[1])],
            "parameters": {
                "peak_force_N": {"value": self.peak_n, "unit": "N", "std": self.peak_std_n},
                "time_of_peak_ms": {"value": self.t_peak_ms, "unit": "ms", "std": None},
                "impulse_Ns": {"value": self.impulse_ns, "unit": "N s", "std": None},
            },
            "rms_before_m": self.rms_before_m,
            "rms_after_m": self.rms_after_m,
            "bic_before": self.bic_before,
            "bic_after": self.bic_after,
            "phase": self.phase,
            "crush_window_m": list(self.crush_m),
            "channels": ["x_m"],
            "description": self.shape,
        }


def hat_responses(t: np.ndarray, centres: np.ndarray, half_width: float, mass: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangular unit force pulses (N) at ``centres`` (s) and the displacement (m) each
    gives a free mass (kg) at rest, on the times ``t`` (s): two (len(t), len(centres))."""
    fine = np.arange(min(t.min(), 0.0), t.max() + 1e-4, 1e-4)
    hats = np.clip(1.0 - np.abs(fine[:, None] - centres[None, :]) / half_width, 0.0, None)
    vel = np.cumsum(hats, axis=0) * 1e-4 / mass
    disp = np.cumsum(vel, axis=0) * 1e-4
    force_t = np.clip(1.0 - np.abs(t[:, None] - centres[None, :]) / half_width, 0.0, None)
    resp = np.stack([np.interp(t, fine, disp[:, j]) for j in range(len(centres))], axis=1)
    return force_t, resp


def x_sensitivities(fr, vehicle, rel_step: float = 1e-4) -> np.ndarray:
    """(n, p) m per unit of each fitted parameter of ``fr``: the model's x on the
    measurement's clock, central differences (the compiled simulation is shared)."""
    import jax.numpy as jnp

    from identify.fitting.collision_fit import model_on_clock_jit
    from sim import Solver

    t = jnp.asarray(fr.measurement.t)
    n_out = len(np.asarray(fr.trajectory.t))
    data = dict(template=fr.params, speed_guess=jnp.asarray(float(fr.speed)), vehicle=vehicle, t=t)

    def x_of(values):
        _, (x,), _ = model_on_clock_jit({k: jnp.asarray(float(v)) for k, v in values.items()}, data, ("x_m",), n_out,
                                        Solver())
        return np.asarray(x)

    cols = []
    for name in fr.names:
        v = fr.values[name]
        step = rel_step * max(abs(v), 1e-3)
        cols.append((x_of({**fr.values, name: v + step}) - x_of({**fr.values, name: v - step})) / (2 * step))
    return np.stack(cols, axis=1) if cols else np.zeros((len(t), 0))


def normal_inverse(cols: np.ndarray) -> np.ndarray:
    """(cols^T cols)^+ for a design matrix whose columns' units differ by many orders (metres
    per newton of a force pulse, per unit of a parameter): each column scaled to unit length
    before the pseudo-inverse, whose cut-off is relative to the largest singular value, and
    the scale put back after. Unscaled, a force's own direction fell below the cut-off and
    its std came out 1.4e-9 N for a 171 kN force (development world 960028; +- 93 kN so)."""
    norm = np.linalg.norm(cols, axis=0)
    norm = np.where(norm > 0, norm, 1.0)
    unit = cols / norm
    return np.linalg.pinv(unit.T @ unit) / np.outer(norm, norm)


def estimate_missing_force(fr, analysis, vehicle, min_bic_gain: float = 10.0, knot_ms: float = 10.0,
                           max_terms: int = 8, min_rms_drop: float = 0.1, tau: float | None = None) -> MissingForce | None:
    """Estimate the force missing from the fitted model ``fr`` (see module doc); None when
    there is no x channel or no force is justified: the BIC must fall by ``min_bic_gain``
    and, as a flexible fall-back needs more than a candidate does, the x residual's RMS by
    the fraction ``min_rms_drop`` (a misfit far below the noise, such as a tracking error
    of a few frames, is not reported as physics). ``tau`` (samples): the x channel's
    autocorrelation time to count with (discovery's round, so that the estimate's BIC and a
    candidate's compare); default: the noise's, from ``analysis``."""
    m = fr.measurement
    if "x_m" not in fr.predictions or "x_m" in m.derived:
        return None
    ok = m.valid("x_m")
    t = np.asarray(m.t)[ok]
    e = (np.asarray(m.channels["x_m"]) - np.asarray(fr.predictions["x_m"]))[ok]
    s = np.asarray(m.sigma["x_m"])[ok]
    # the noise's effective autocorrelation time (``ChannelAnalysis.tau_noise``): the fit's
    # own tau would count the misfit being looked for as correlated noise
    if tau is None:
        chan = analysis.channels.get("x_m") if analysis is not None else None
        tau = float(chan.tau_noise) if chan is not None else 1.0
    tau = max(1.0, float(tau))
    mass = float(vehicle.mass)
    h = knot_ms / 1e3
    centres = np.arange(0.0, t.max() - h / 2, h)
    force_basis, resp = hat_responses(t, centres, h, mass)
    # the fitted parameters readjust when a force is added: their sensitivities ride along
    # in every regression, unpenalised (they are already counted in the model)
    sens = x_sensitivities(fr, vehicle)[ok] / s[:, None]
    a = resp / s[:, None]
    b = e / s
    n_eff = len(b) / tau
    # what was measured before the fit stays near its measurement: a row (shift / sigma) each,
    # times sqrt(tau) so that it counts in full where the x rows count as n / tau
    measured = fr.measured()
    held = [(k, measured[n][1]) for k, n in enumerate(fr.names) if n in measured]
    rows = np.zeros((len(held), sens.shape[1]))
    for r_i, (k, sd) in enumerate(held):
        rows[r_i, k] = math.sqrt(tau) / sd
    sens = np.concatenate([sens, rows], axis=0)
    a = np.concatenate([a, np.zeros((len(held), a.shape[1]))], axis=0)
    b = np.concatenate([b, np.zeros(len(held))])
    # extended BIC (Chen and Chen 2008): choosing k pulses out of K positions costs
    # k (ln n + 2 ln K), not only k ln n: the search itself finds noise that looks like a pulse
    penalty = math.log(n_eff) + 2.0 * math.log(len(centres))
    chi2_0 = float(b @ b) / tau
    chosen: list[int] = []
    chi2 = chi2_0
    coef = np.zeros(0)
    while len(chosen) < max_terms:
        best = None
        for j in range(len(centres)):
            if j in chosen:
                continue
            cols = np.concatenate([a[:, chosen + [j]], sens], axis=1)
            c, *_ = np.linalg.lstsq(cols, b, rcond=None)
            r = b - cols @ c
            val = float(r @ r) / tau
            if best is None or val < best[0]:
                best = (val, j, c)
        if best is None or chi2 - best[0] < penalty:
            break
        chi2, j, coef = best
        chosen.append(j)
    gain = chi2_0 - chi2 - len(chosen) * penalty
    if not chosen or gain < min_bic_gain:
        return None

    cols = np.concatenate([a[:, chosen], sens], axis=1)
    full_cov = normal_inverse(cols) * tau * max(1.0, chi2 / max(n_eff - cols.shape[1], 1.0))
    k_f = len(chosen)
    cov, coef_all, coef = full_cov[:k_f, :k_f], coef, coef[:k_f]
    grid = np.arange(0.0, t.max() * 1e3 + 0.5, 1.0)
    basis_grid = np.clip(1.0 - np.abs(grid[:, None] / 1e3 - centres[None, chosen]) / h, 0.0, None)
    force = basis_grid @ coef
    force_std = np.sqrt(np.einsum("ij,jk,ik->i", basis_grid, cov, basis_grid))
    after = e - (cols[: len(e)] * s[:, None]) @ coef_all
    rms_before, rms_after = float(np.sqrt(np.mean(e**2))), float(np.sqrt(np.mean(after**2)))
    if rms_after > (1.0 - min_rms_drop) * rms_before:
        return None
    k = int(np.argmax(np.abs(force)))
    peak = float(force[k])
    active = np.flatnonzero(np.abs(force) > 0.25 * abs(peak))
    window = (float(grid[active[0]]), float(grid[active[-1]]))
    impulse = float(np.sum(force) * 1e-3)
    crush = model_crush(fr, np.linspace(window[0], window[1], 50) / 1e3)
    phases = phase_times_ms(fr)
    spanned = sorted({phase_at(float(x), phases) for x in grid[active]},
                     key=["approach", "compression", "restitution", "after separation"].index)
    phase = " and ".join(spanned)
    shape = describe(grid, force, window, fr, after_separation=phase == "after separation")
    if "compression" in phase or "restitution" in phase:
        direction = ("towards the barrier (the model pushes the car back too hard there)" if peak > 0
                     else "away from the barrier (the structure resists more than the model says)")
    else:
        direction = ("pushing the car towards the barrier" if peak > 0
                     else "pulling the car away from the barrier")
    contact = np.interp(grid[k] / 1e3 - fr.contact_time, np.asarray(fr.trajectory.t), np.asarray(fr.trajectory.force))
    share = f", {100 * abs(peak) / contact:.0f} % of the modelled contact force then" if contact > 1e3 else ""
    where = phase if phase == "after separation" else f"{phase}, crush {crush.min():.2f}-{crush.max():.2f} m"
    description = (
        f"No candidate mechanism explains the misfit: the motion needs an extra force of up to "
        f"{abs(peak) / 1e3:.1f} kN {direction} between {window[0]:.0f} and {window[1]:.0f} ms "
        f"({where}), peaking at {grid[k]:.0f} ms{share}, impulse {impulse:+.0f} N s; {shape}."
    )
    return MissingForce(
        t_ms=grid, force_n=force, force_std_n=force_std, window_ms=window, peak_n=peak,
        peak_std_n=float(force_std[k]), t_peak_ms=float(grid[k]), impulse_ns=impulse,
        rms_before_m=rms_before, rms_after_m=rms_after,
        bic_before=chi2_0, bic_after=chi2 + len(chosen) * penalty, n_terms=len(chosen),
        crush_m=(round(float(crush.min()), 3), round(float(crush.max()), 3)), phase=phase, shape=shape,
        description=description,
        parameter_shift={n: float(c) for n, c in zip(fr.names, coef_all[k_f:])},
    )


def describe(t_ms: np.ndarray, force: np.ndarray, window, fr, after_separation: bool = False) -> str:
    """Words for the force's shape: pulse or step, and which state term it follows (the
    share of its variance explained by crush depth, crush rate or a constant, least
    squares over the window along the fitted trajectory)."""
    inside = (t_ms >= window[0]) & (t_ms <= window[1])
    f = force[inside]
    signs = np.sign(f[np.abs(f) > 0.25 * np.max(np.abs(f))])
    form = "a single pulse" if np.all(signs == signs[0]) else "a force that changes direction"
    if after_separation:
        return (f"{form} while the car is clear of the barrier: an outside force on the car (a cable, a kerb, "
                "braking), not a property of the crush zone")
    tr = fr.trajectory
    ts = t_ms[inside] / 1e3 - fr.contact_time
    crush = np.interp(ts, np.asarray(tr.t), np.asarray(tr.crush))
    rate = np.interp(ts, np.asarray(tr.t), np.gradient(np.asarray(tr.crush), np.asarray(tr.t)))
    total = float(np.sum((f - f.mean()) ** 2))
    if len(f) < 4 or total <= 0:
        return form
    shares = {}
    for name, x in (("crush depth", crush), ("crush rate", rate)):
        cols = np.stack([x, np.ones_like(x)], axis=1)
        c, *_ = np.linalg.lstsq(cols, f, rcond=None)
        shares[name] = 1.0 - float(np.sum((f - cols @ c) ** 2)) / total
    name, r2 = max(shares.items(), key=lambda kv: kv[1])
    if r2 > 0.8:
        return f"{form} that grows in proportion to the {name} (R^2 {r2:.2f}): a missing {name}-dependent force law"
    return (f"{form} not tied to crush depth or crush rate (R^2 {shares['crush depth']:.2f} and "
            f"{shares['crush rate']:.2f}): a local event in time, e.g. a part that buckles or breaks")
