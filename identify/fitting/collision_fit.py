"""Fit the collision model to a measurement: parameters, uncertainty, identifiability.

Weighted least squares: every residual is (model - measured) / sigma, so the solver's
tolerances and the final chi-square mean something. The solver is optimistix's
Levenberg-Marquardt with exact forward-mode Jacobians through the JAX simulation, run from
several starting points at once (vmap) so that a local minimum is not taken for the answer.
Parameters move in an unconstrained space (``identify.fitting.model.FreeParameter``); the
covariance comes from the Jacobian at the optimum, mapped to physical units, with each
channel's weight divided by its residuals' integrated autocorrelation time (n correlated
samples carry the information of n / tau independent ones) and widened for a misfit beyond
the noise (``least_squares``).

A channel the model misses by far more than its noise (a richer car's heave and pitch) would
otherwise steer the fit: with ``FitOptions.misfit_weights`` (the default) the fit is run
again from its optimum with each channel's sigma widened by that channel's own misfit,
sqrt(tau * max(1, chi2/dof)), so the channels the model can follow (x) and the measured
contact decide what they measure, instead of being traded against what the model cannot
follow; its covariance widens each channel by its own misfit and keeps a prior's sigma.
A channel's samples before the measured first contact are weighted apart from the rest
(:func:`weighting_groups`): the model follows the free approach exactly, so the crash's
misfit does not widen the frames that measure the impact speed. Without it (discovery's
candidate fits) the covariance is widened as a whole by the reduced chi-square.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from identify.errors import UserError
from identify.recordings.measurement import Measurement
from identify.fitting.model_error import ModelError, kind_of, regimes_of
from identify.fitting.model_error import table as model_error_table
from identify.fitting.least_squares import (
    channel_residuals,
    channel_variance_factors,
    held_at_measurement,
    parameter_covariance,
    prior_residuals,
    weighted_offset,
)
from identify.fitting.model import (
    FACE_FRICTION_PRIOR,
    FACE_FRICTION_START,
    LENGTH_CHANNELS,
    LENGTH_SCALE,
    OFFSET_FREE,
    FreeParameter,
    assemble,
    base_parameters,
    predict,
    vehicle_with,
)
from sim import Params, Solver, Vehicle, make_params
from sim.simulate import _run
from video.motion import weighted_line

FIT_CHANNELS = ("x_m", "z_m", "pitch_rad", "vx_mps", "front_wheel_angle_rad", "rear_wheel_angle_rad",
                "engine_x_m", "engine_vx_mps")

# When a parameter's standard deviation exceeds this, the data do not constrain it.
NOT_IDENTIFIED = {
    "k_compression": ("relative", 0.2),
    "k_restitution": ("relative", 0.2),
    "restitution": ("absolute", 0.05),
    "dz_contact": ("absolute", 0.10),
}
LOG_SCALE_NOT_IDENTIFIED = 0.2  # relative std beyond which any other log-scale parameter is not identified
# the fit weighted by each channel's misfit (``_weighted_by_misfit``): at most this many
# reweighted fits, each given at most WEIGHTED_SOLVES runs of the solver (max_steps each)
MISFIT_ROUNDS = 3
WEIGHTED_SOLVES = 5
BEFORE_CONTACT = " before contact"  # a channel's weighting group of samples before the measured first contact
MIN_BEFORE_CONTACT = 5  # fewer samples before contact stay in the channel's one group
# the model-error table's entry for the contact the fitted channels alone put (s): what a
# held measured contact is compared with (``FitResult.pulls``)
CONTACT_FROM_MOTION = "contact_time_from_motion"
MOTION_CONTACT_STARTS_S = (0.0, -0.003, 0.003)  # where that estimate starts, from the held contact (s)
HOLD_MOVED = 0.05  # the combined contact this many measurement sigmas from the measured one: the fit continued there

# Random starting points are drawn from these physical ranges (log-uniform for "log").
START_RANGES = {
    "k_compression": (3e5, 3e6),
    "k_restitution": (2e5, 3e6),
    "restitution": (0.05, 0.4),
    "dz_contact": (-0.3, 0.1),
}


@dataclasses.dataclass(frozen=True)
class FitOptions:
    """Settings of the fit.

    starts : number of starting points (the first is V-SIM's defaults).
    max_steps : Levenberg-Marquardt iterations per start.
    rtol, atol : optimistix tolerances on the unconstrained parameters and the cost.
    seed : random seed of the extra starting points.
    solver : sim.Solver of the simulations.
    misfit_weights : after the search, fit again from its best with each channel's sigma
        widened by its own misfit, sqrt(tau * max(1, reduced chi-square)), and widen the
        covariance channel by channel, the priors at their own sigmas (module doc); the
        reported chi-square stays in the recording's own sigmas. False: the recording's
        sigmas, and the covariance widened as a whole by max(1, chi2/dof) (discovery's
        candidate fits, whose rules were set against that: ``identify.discover.loop``).
    face_friction : the default free set (``base_parameters``) fits the barrier face's friction
        (``mu_face``); off, it is V-SIM's 0, as a fit of V-SIM's own model is here by default.
        ``identify fit`` fits it (``identify.identification.FIT_OPTIONS``; README, "How the fit
        works").
    hold_measured_contact : a first contact the recording measured apart from the fitted
        channels (seen in the film, the load cells' onset) is held, not fitted: a measured
        fact, not a knob (:func:`fit`), where the model-error table has measured how far the
        channels' own contact can be off (``CONTACT_FROM_MOTION``: a film's). Otherwise, and
        off, it is a prior of the fit.
    held_from_channels : with a held measurement, fit on from the optimum with it free and
        no prior, to find where the fitted channels alone put it, reported in
        ``FitResult.held_measured`` and ``FitResult.pulls``: a held contact is then held
        where the two combined put it (inverse-variance mean, the channels' estimate with the
        model's own error, ``CONTACT_FROM_MOTION``), a held scale or speed stays where it was
        measured; off, both are held where they were measured, not compared (the fits after
        the base one, whose measured contact is where the base fit held it: one solve fewer
        each).
    hold_measured_scale : a film's scale (its tape, or its hub targets and the wheelbase) is
        held at its measurement, its sigma carried into the others' covariance, not fitted:
        the approach frames fix speed times scale, so the fit could move the scale only by
        what the model makes of the crash, trading it against what the model cannot explain
        (development films 960007, 960008, 960017: the scale at its 5 % bound, 7.9 to 90
        sigma from the measurement; held, 960008's x RMS 8.4 -> 1.7 mm and k_compression
        +11.1 -> -0.2 %, 960007's speed +3.6 -> +0.5 %). Where the fitted channels alone would
        put it is reported beside it (``FitResult.held_measured``, ``FitResult.pulls``). Off,
        it is a nuisance of the fit with the measurement as its prior.
    hold_measured_speed : a film's impact speed is held where its approach frames put it (a
        line through x before the measured contact, :func:`approach_speed`), its sigma (the
        line's, widened by those frames' own misfit and correlation time, and the scale's,
        tied to it: the approach measures speed times scale) carried into the others'
        covariance: fitted, the crash's samples outnumber the approach's 15 to 1 and moved it
        where the model's reading of the crash wanted it (scored world 910028: +1.38 +- 0.36 %,
        3.8 sigma off). Where the fitted channels alone would put it is reported beside it.
        A header's speed (sensors) stays a prior; off, the film's speed is fitted.
    """

    starts: int = 5
    max_steps: int = 150
    rtol: float = 1e-6
    atol: float = 1e-6
    seed: int = 0
    solver: Solver = Solver()
    misfit_weights: bool = True
    face_friction: bool = False
    hold_measured_contact: bool = True
    held_from_channels: bool = True
    hold_measured_scale: bool = True
    hold_measured_speed: bool = True


@dataclasses.dataclass
class FitResult:
    """The outcome of a fit (physical units; see ``names`` and ``units``).

    values, std : name -> value, one-sigma uncertainty: the data's and the model's own error
        in quadrature (``identify.fitting.model_error``); std_data, std_model : the two parts.
    covariance : (p, p) in the order of ``names``, the model's error added to its diagonal;
    correlation : the data's (what the recording ties together), same order.
    identified : name -> (bool, reason) for the collision parameters, for other log-scale
        parameters known no better than ``LOG_SCALE_NOT_IDENTIFIED``, and for any fitted
        quantity that ended at a bound of its transform (:meth:`mark_not_identified`).
    at_bound : name -> which bound, for fitted quantities within 1 % of a bound of their
        transform's range (``FreeParameter.at_bound``).
    rms : channel -> RMS residual in the channel's unit; rms_m the x channel's (m).
    chi2, dof : sum of squares weighted by the recording's sigmas, degrees of freedom.
    misfit : channel -> the factor its variance was widened by in the covariance: max(1,
        the channel's reduced chi-square) (``least_squares.channel_variance_factors``), or
        the whole fit's when the fit was not weighted by misfit (``FitOptions.misfit_weights``);
        a weighted fit's has a channel's samples before contact apart, "x_m before contact"
        (:func:`weighting_groups`), as its ``correlation_time`` and ``sigma_widened`` have.
    sigma_widened : channel -> the factor the fit's weights multiplied the channel's sigma by,
        for the channels widened (``FitOptions.misfit_weights``; empty when the fit used the
        recording's sigmas, also when the weighted fit did not converge).
    model_choice : name -> how far the mechanisms discovery added moved a base parameter
        from the base model's fit (its unit), counted in ``std_model``
        (``identify.discover.loop.with_model_choice``); empty without discoveries.
    held_measured : name -> {measured, sigma[, model, model_std_data, model_std, held_at, held_std,
        model_at_bound]}
        for a measured quantity the fit held, not fitted (the contact seen:
        ``FitOptions.hold_measured_contact``; a film's scale: ``FitOptions.hold_measured_scale``;
        its speed: ``FitOptions.hold_measured_speed``, sigma with the scale's share),
        in ``values`` where it was held with its sigma carried into the others' covariance;
        model: where the fitted channels alone put it, model_std that estimate's std with the
        model's own error, model_std_data without; held_at, held_std: where it was held (the
        contact: the measurement and that estimate combined, ``FitOptions.held_from_channels``;
        without, and the scale and speed, at the measurement); model_at_bound:
        which bound of its range stopped that estimate (then not combined: held at the
        measurement).
    model_error_where : name -> where its ``std_model`` was measured, for the parameters whose
        model error is a regime's (``identify.fitting.model_error.REGIMES``: the fitted model
        lifts the rear wheels within the recording) rather than the clean worlds', or was
        scaled beyond the misfit the table was measured on.
    model_error_scaled : '' or why every model error was scaled
        (``identify.fitting.model_error.ModelError.beyond_measured``): "scaled by 3.5: this
        fit misses x by 13.5 mm RMS, beyond the 3.8 mm of any fit ...".
    std_data_by_channel : name -> the data's standard deviation (its unit) from the same
        residuals and Jacobian at the same optimum with each channel's rows widened by that
        channel's own misfit and correlation time (``least_squares.parameter_covariance``,
        ``per_channel=True``, the groups of the fit weighted by misfit), for a fit whose
        covariance was widened as a whole (``FitOptions.misfit_weights`` False); empty when
        it was not (``std_data`` is that already). Discovery judges whether a candidate's
        parameters are determined by it (``identify.discover.loop.by_own_misfit``).
    converged : the best start converged; starts_at_best : how many starts reached it;
    other_minima : costs of distinct worse minima found.
    params, speed, contact_time : the fitted model (sim.Params, m/s, s).
    trajectory : sim.Trajectory of the fitted model.
    predictions : channel -> (n,) model on the measurement's clock (offsets removed as
    the fit removes them).
    """

    names: tuple[str, ...]
    units: dict[str, str]
    values: dict[str, float]
    std: dict[str, float]
    covariance: np.ndarray
    correlation: np.ndarray
    identified: dict[str, tuple[bool, str]]
    rms: dict[str, float]
    chi2: float
    dof: int
    converged: bool
    starts: int
    starts_at_best: int
    other_minima: list[float]
    params: Params
    speed: float
    contact_time: float
    trajectory: object
    predictions: dict[str, np.ndarray]
    measurement: Measurement
    model: str = "base"
    correlation_time: dict[str, float] = dataclasses.field(default_factory=dict)
    priors: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    at_bound: dict[str, str] = dataclasses.field(default_factory=dict)
    std_data: dict[str, float] = dataclasses.field(default_factory=dict)
    std_model: dict[str, float] = dataclasses.field(default_factory=dict)
    misfit: dict[str, float] = dataclasses.field(default_factory=dict)
    sigma_widened: dict[str, float] = dataclasses.field(default_factory=dict)
    model_choice: dict[str, float] = dataclasses.field(default_factory=dict)
    held_measured: dict[str, dict] = dataclasses.field(default_factory=dict)
    model_error_where: dict[str, str] = dataclasses.field(default_factory=dict)
    std_data_by_channel: dict[str, float] = dataclasses.field(default_factory=dict)
    model_error_scaled: str = ""

    PULL_CONFLICT = 3.0  # |pull| beyond this: the recording contradicts what was known before

    def mark_not_identified(self, name: str, reason: str) -> None:
        """Record that ``name`` is not identified, ``reason`` reading "not identified: ...";
        a reason it already had is kept, the new one added after it."""
        ok, before = self.identified.get(name, (True, ""))
        self.identified[name] = (False, reason if ok else f"{before}; and {reason.removeprefix('not identified: ')}")

    def pulls(self) -> dict[str, dict]:
        """name -> {prior, prior_std, value, std, unit, pull, conflict} for each fitted quantity
        that had a prior: pull = (fitted - prior) / prior sigma; beyond ``PULL_CONFLICT``
        sigma the model and the recording disagree with the prior knowledge. A measured
        quantity the fit held (``held_measured``: the contact seen) has ``held`` True, its value
        where the fitted channels alone would put it, std that estimate's (std_data without the
        model's own error), pull their difference over both sigmas in quadrature, and held_at,
        held_std where the fit held it (the two combined); at_bound which bound of the fit's
        range stopped the channels' estimate ('' when none): it then says no more than that
        they put it at least that far off, a pull and a conflict at least that large."""
        out = {}
        for name, h in self.held_measured.items():
            if "model" not in h:  # not compared (``FitOptions.held_from_channels``)
                continue
            pull = (h["model"] - h["measured"]) / math.hypot(h["sigma"], h["model_std"])
            out[name] = {"prior": h["measured"], "prior_std": h["sigma"], "value": h["model"], "std": h["model_std"],
                         "std_data": h["model_std_data"], "unit": self.units.get(name, ""), "pull": pull,
                         "conflict": bool(abs(pull) > self.PULL_CONFLICT), "held": True,
                         "held_at": h["held_at"], "held_std": h["held_std"], "at_bound": h.get("model_at_bound", "")}
        for name, (mu, sigma) in self.priors.items():
            if name in self.values:
                pull = (self.values[name] - mu) / sigma
                out[name] = {"prior": mu, "prior_std": sigma, "value": self.values[name], "std": self.std[name],
                             "unit": self.units.get(name, ""), "pull": pull,
                             "conflict": bool(abs(pull) > self.PULL_CONFLICT)}
        return out

    def measured(self) -> dict[str, tuple[float, float]]:
        """name -> (value, sigma), its units, of each fitted quantity measured before the fit:
        a held measurement where it was held and how well (``held_measured``), a prior
        (``priors``); what discovery's alternatives must not move (``identify.discover``)."""
        out = {n: (h.get("held_at", h["measured"]), h.get("held_std", h["sigma"])) for n, h in self.held_measured.items()}
        out.update(self.priors)
        return {n: (float(mu), float(sd)) for n, (mu, sd) in out.items() if sd > 0 and n in self.values}

    @property
    def rms_m(self) -> float:
        return self.rms.get("x_m", float("nan"))

    @property
    def reduced_chi2(self) -> float:
        return self.chi2 / max(self.dof, 1)


def _approach_samples(measurement: Measurement) -> np.ndarray:
    """Mask of the valid x samples before the measured first contact (t < 0): the free approach."""
    if "x_m" not in measurement.channels:
        return np.zeros(len(measurement.t), bool)
    return (np.asarray(measurement.t) < 0) & measurement.valid("x_m")


def approach_speed(measurement: Measurement) -> tuple[float, float]:
    """(m/s, m/s): the car's speed from a line fitted to x over the samples before contact,
    each weighted by its sigma, and the line's standard deviation were those sigmas right
    and the samples independent (:func:`fit` widens it by the approach's own misfit and
    correlation time, as the fit weighs those samples).

    Raises UserError when there are fewer than 5 such samples."""
    before = _approach_samples(measurement)
    if np.sum(before) < MIN_BEFORE_CONTACT:
        raise UserError(
            f"{measurement.source}: the impact speed is unknown and fewer than {MIN_BEFORE_CONTACT} samples precede"
            " contact; give it with --speed (km/h)"
        )
    slope, sd, _ = weighted_line(np.asarray(measurement.t)[before], np.asarray(measurement.channels["x_m"])[before],
                                 np.asarray(measurement.sigma["x_m"])[before])
    if not slope > 0:
        raise UserError(f"{measurement.source}: the car does not move towards the barrier before contact")
    return slope, sd


def _stack(measurement: Measurement):
    """(channels, y, w, fitted): every ``FIT_CHANNELS`` channel the measurement has valid
    samples of, its values and weights 1/sigma stacked (channels, n), and the fitted ones. A
    derived channel (shown, not fitted: ``Measurement.derived``) is in the stack with weight
    0, so that a fit that only shows a channel another fits (the cabin alone against the
    cabin and its engine) runs the same compiled programs (a compile is 30-55 s, the solve ~1 s)."""
    channels = tuple(c for c in FIT_CHANNELS if c in measurement.channels and measurement.valid(c).any())
    fitted = tuple(c for c in channels if c not in measurement.derived)
    if "x_m" not in fitted and "vx_mps" not in fitted:
        raise UserError(f"{measurement.source}: no x_m or vx_mps channel to fit (the car's motion towards the barrier)")
    y = np.stack([np.where(measurement.valid(c), measurement.channels[c], 0.0) for c in channels])
    w = np.stack([np.where(measurement.valid(c) & (c in fitted), 1.0 / np.asarray(measurement.sigma[c]), 0.0)
                  for c in channels])
    return channels, y, w, fitted


def _values(spec, u, data):
    """Physical values of ``spec``: fitted ones from u, held ones (mask 0) from ``data["held"]``.

    The mask and the held values are data, not part of the compiled function: fits that free
    different subsets of one superset ``spec`` share one compile (discovery's candidates)."""
    return {
        p.name: jnp.where(data["mask"][i] > 0, p.to_physical(u[i]), data["held"][i]) for i, p in enumerate(spec)
    }


def model_on_clock(values, data, channels, n_out: int, solver: Solver):
    """The model with physical ``values`` (name -> value, ``identify.fitting.model`` names) seen on
    the measurement's clock (pure, jit-able; ``model_on_clock_jit`` is the compiled one).

    data : dict with ``template`` (sim.Params the values go into), ``speed_guess`` (m/s,
        the impact speed when ``values`` has none), ``vehicle`` (sim.Vehicle) and ``t``
        ((n,) s, measurement times).
    Returns (trajectory, [(n,) prediction of each of ``channels``], impact speed m/s)."""
    params, speed, contact_time = assemble(data["template"], values, data["speed_guess"])
    vehicle = vehicle_with(data["vehicle"], values)
    traj = _run(params, vehicle, speed, n_out, solver)
    preds = [in_recording_lengths(predict(traj, c, data["t"], speed, contact_time, vehicle.wheel_radius,
                                          solver.output_dt), c, values) for c in channels]
    return traj, preds, speed


def in_recording_lengths(pred, channel: str, values):
    """The model's ``channel`` as the recording measures it: a length (``LENGTH_CHANNELS``)
    times the fitted ``length_scale`` when ``values`` has one (a film's scale error)."""
    if channel in LENGTH_CHANNELS and "length_scale" in values:
        return pred * values["length_scale"]
    return pred


model_on_clock_jit = jax.jit(model_on_clock, static_argnames=("channels", "n_out", "solver"))


def _residual_fn(spec, channels, n_out, solver, with_model: bool = False):
    """Build r(u, data) -> (m,) weighted residuals (pure, jit-able); ``with_model``: r(u,
    data) -> (r, (r, trajectory, [prediction of each channel])), for ``jax.jacfwd``'s
    ``has_aux``."""

    def residuals(u, data):
        values = _values(spec, u, data)
        traj, preds, _ = model_on_clock(values, data, channels, n_out, solver)
        out = [channel_residuals(pred, data["y"][c], data["w"][c], name in OFFSET_FREE)
               for c, (name, pred) in enumerate(zip(channels, preds))]
        out.append(prior_residuals(jnp.stack([values[p.name] for p in spec]), data["prior_mu"], data["prior_w"]))
        r = jnp.concatenate(out)
        return (r, (r, traj, preds)) if with_model else r

    return residuals


def _forward_jacobian(fn):
    """``fn(u, data)`` whose derivative in u is its Jacobian materialised by ``jax.jacfwd``
    (one vectorised forward pass, the simulation run once with every tangent), not the
    ``jax.linearize`` optimistix takes by default, which stores every step's intermediates
    of the simulation for a second, tangent pass: 2.2 times slower a Jacobian on the
    collision model and a larger program to compile (measured 2026-11-28). ``data`` is
    never differentiated."""

    @jax.custom_jvp
    def wrapped(u, data):
        return fn(u, data)

    @wrapped.defjvp
    def _jvp(primals, tangents):
        u, data = primals
        jac, r = jax.jacfwd(lambda v: (fn(v, data),) * 2, has_aux=True)(u)
        return r, jac @ tangents[0]

    return wrapped


def _solve(spec, channels, n_out, options, data, u0):
    """One Levenberg-Marquardt run from ``u0``: (u, cost, converged). The cost is the
    residuals the solver holds for its last accepted point, which ``sol.value`` is (optimistix'
    Gauss-Newton state keeps them together), not a simulation run once more."""
    fn = _forward_jacobian(_residual_fn(spec, channels, n_out, options.solver))
    solver = optx.LevenbergMarquardt(rtol=options.rtol, atol=options.atol)
    sol = optx.least_squares(fn, solver, u0, args=data, max_steps=options.max_steps, throw=False)
    r = sol.state.f_info.residual
    return sol.value, jnp.sum(r * r), sol.result == optx.RESULTS.successful


# Starts run one after another through one compiled solve: vmapping the solver's loop over
# starts multiplies its compile time several-fold for a run time of ~0.3 s a start.
_solve_jit = jax.jit(_solve, static_argnames=("spec", "channels", "n_out", "options"))


def _finish(spec, channels, n_out, options, data, u):
    """At the optimum u: residuals, their Jacobian (unconstrained space), the transforms'
    derivatives, the fitted trajectory and the model on the measurement's clock."""
    fn = _residual_fn(spec, channels, n_out, options.solver, with_model=True)
    jac_u, (r, traj, preds) = jax.jacfwd(fn, has_aux=True)(u, data)  # one simulation in the program
    dvalue_du = jnp.stack([jax.grad(p.to_physical)(u[i]) for i, p in enumerate(spec)])
    return r, jac_u, dvalue_du, traj, jnp.stack(preds)


_finish_jit = jax.jit(_finish, static_argnames=("spec", "channels", "n_out", "options"))


def weighting_groups(channels, w: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
    """The groups of residual rows that the fit weighted by misfit widens together
    (``FitOptions.misfit_weights``): group name -> indices of its valid rows in the stacked
    residual (channel c's sample i at c * len(t) + i). Each channel's samples before the
    measured first contact (t < 0: the free approach, which the model follows exactly) are a
    group of their own, "<channel> before contact", when there are at least
    ``MIN_BEFORE_CONTACT``; the channel's other samples are the channel's group. Widened
    with the crash's misfit, a film's approach frames weighed too little, and the fitted
    speed took up what the model could not follow after contact (on 13 development films,
    0.6-0.75 % off on 4 where the approach alone measured it within 0.32 %)."""
    n = len(t)
    out = {}
    for c, name in enumerate(channels):
        valid = np.flatnonzero(w[c] > 0)
        if not len(valid):  # shown, not fitted (``_stack``)
            continue
        before = valid[np.asarray(t)[valid] < 0.0]
        if len(before) >= MIN_BEFORE_CONTACT:
            out[name] = c * n + np.setdiff1d(valid, before)
            out[name + BEFORE_CONTACT] = c * n + before
        else:
            out[name] = c * n + valid
    return out


def approach_tau_floor(groups) -> dict[str, str]:
    """Each "<channel> before contact" group -> its channel's group, whose residuals' correlation
    time is a floor for its own in the covariance (``least_squares.parameter_covariance``): a
    film's tracking errors may be correlated alike before contact and after, and a few dozen
    approach frames cannot tell their correlation time (20 samples of noise correlated over 19
    gave 1.8), which would overstate what they measure of the speed. The fit's weights use
    the group's own (on 13 development films the speed came within 0.5 % on 12, largest
    error 0.50 %; with the floor in the weights too, 0.70 % on the 11 of them run; without
    the groups, 0.75 %)."""
    return {g: g[: -len(BEFORE_CONTACT)] for g in groups if g.endswith(BEFORE_CONTACT)}


def measured_covariance(names, variances: dict, measurement: Measurement, speed: float, speed_white: float,
                        r: np.ndarray, own: dict, n_fitted: int) -> np.ndarray:
    """(h, h) covariance of the measured quantities ``names`` a fit held (their units): the
    ``variances`` given (the contact's), a film's scale its measured sigma (relative), and
    its speed (m/s, ``speed``) the approach line's ``speed_white`` widened by the approach
    frames' own misfit and correlation time (at the optimum's residuals ``r``, in the
    recording's sigmas, of groups ``own``: ``weighting_groups``), with the scale's error in
    it: the approach measures speed times scale, so a scale held 1 sigma high holds the speed
    1 sigma (relative) high, cov(speed, scale) = -speed sigma_scale^2.

    Not floored by the crash's correlation time as the fitted speed's covariance is
    (:func:`approach_tau_floor`: there the crash's samples measure the speed too): on 23
    development films (960000-960023) the approach line's error over this sigma (the scale's
    share in it) was within 1 on 20 and within 2 on all, largest 1.84 (960018, +0.055 %);
    the crash's correlation time, dominated by what the model misses, would have widened it
    3 to 6 times."""
    var = dict(variances)
    scale_var = float(measurement.length_scale_sigma or 0.0) ** 2 if "length_scale" in names else 0.0
    if "length_scale" in names:
        var["length_scale"] = scale_var
    if "impact_speed" in names:
        tau, misfit = channel_variance_factors(r, own, n_fitted)
        g = "x_m" + BEFORE_CONTACT if "x_m" + BEFORE_CONTACT in own else "x_m"
        var["impact_speed"] = speed_white**2 * tau[g] * misfit[g] + speed**2 * scale_var
    s = np.diag([var[name] for name in names])
    if "impact_speed" in names and "length_scale" in names:
        i, j = names.index("impact_speed"), names.index("length_scale")
        s[i, j] = s[j, i] = -speed * scale_var
    return s


def _estimate_from_channels(spec, channels, n_out, options, data, weights, u, idx, held: dict, starts,
                            groups, n_res: int, per_channel: bool):
    """Where the fitted channels alone put the held quantities ``spec[i]``, i in ``idx`` (one
    index or several, estimated together): the fit continued from the held fit's optimum
    ``u`` in ``weights`` with them free and no prior on them (``data``: the fit's, their mask 1
    and their prior weight 0), from their held values, the first's plus each of ``starts``
    (its unit): the channels may have a second basin some way off (a contact held 5 ms early
    was a local optimum of its own, chi-square 17 % above the true one); the lowest.

    Returns, one per index, (value, its std from the data (the covariance at that optimum, as
    the fit's own), which bound of its range stopped it or ''), or None when no start gave a
    finite cost."""
    idx = [int(i) for i in np.atleast_1d(idx)]
    for i in idx:
        u = u.at[i].set(spec[i].to_unconstrained(held[spec[i].name]))
    first = idx[0]
    trial = {**data, "w": jnp.asarray(weights)}
    best_u, best_cost = None, np.inf
    for shift in starts:
        start = u.at[first].set(spec[first].to_unconstrained(held[spec[first].name] + shift))
        u1, cost, _ = _solve_jit(spec, channels, n_out, options, trial, start)
        if float(cost) < best_cost:
            best_u, best_cost = u1, float(cost)
    if not np.isfinite(best_cost):
        return None
    fitted = [k for k, p in enumerate(spec) if p.name not in held or k in idx]
    r, jac, dvalue, _, _ = (np.asarray(a) for a in _finish_jit(spec, channels, n_out, options, data, best_u))
    unc = parameter_covariance(r, jac[:, fitted], dvalue[fitted], np.array([spec[k].typical for k in fitted]), groups,
                               n_res, per_channel=per_channel, tau_at_least=approach_tau_floor(groups))
    out = []
    for i in idx:
        value = float(spec[i].to_physical(best_u[i]))
        out.append((value, float(unc.std[fitted.index(i)]), spec[i].at_bound(value)))
    return out


def _held_at_combined_contact(spec, channels, n_out, options, data, weights, u, i_c: int, held: dict, sigma: float,
                              groups, n_res: int, per_channel: bool, model_std: float):
    """The contact measured apart from the fitted channels (``held["contact_time"]``, s, of
    standard deviation ``sigma``) combined with where the fitted channels
    alone put it (:func:`_estimate_from_channels`, its std the data's and ``model_std``, the
    model's own error of that estimate, in quadrature): the inverse-variance mean, where the
    fit is then held (``held`` updated, the fit continued from ``u`` in ``weights``): the
    nearer the measurement's sigma is to the channels', the more the channels move it. An
    estimate the contact's range stopped (``FreeParameter.at_bound``) is the range's, not the
    channels': it is reported (``model_at_bound``) and not combined, the contact held where
    it was measured. Nor is one that contradicts the measurement (a pull beyond
    ``FitResult.PULL_CONFLICT``): two estimates that far apart are not two readings of one
    contact, and their mean is neither; the picture's is a measurement, the channels' the
    model's reading of the crash, which a mechanism the model leaves out moves (with the film's
    speed held, scored worlds 910014 and 910023, rate dependence: the channels 6.0 and 5.6 ms
    early, pulls -5.0 and -4.4, the seen contact within 0.2 ms; combined, the fit's contact
    came 0.9 ms early). The conflict is reported (``FitResult.pulls``, a warning).

    ``data``: the fit's, its contact's mask 1 (free) and no prior on it. Returns (u, the
    combined sigma, {model, model_std_data, model_std, held_at, held_std[, model_at_bound]});
    without a finite estimate from the channels, (u, the measurement's sigma, {})."""
    seen = held["contact_time"]
    estimate = _estimate_from_channels(spec, channels, n_out, options, data, weights, u, i_c, held,
                                       MOTION_CONTACT_STARTS_S, groups, n_res, per_channel)
    if estimate is None:
        return u, sigma, {}
    (model, std_data, bound), = estimate
    std = math.hypot(std_data, model_std)
    compared = {"model": model, "model_std_data": std_data, "model_std": std, "held_at": seen, "held_std": sigma}
    if bound:
        return u, sigma, {**compared, "model_at_bound": bound}
    if abs(model - seen) > FitResult.PULL_CONFLICT * math.hypot(sigma, std):
        return u, sigma, compared
    w_seen, w_model = sigma**-2, std**-2
    at, at_std = (seen * w_seen + model * w_model) / (w_seen + w_model), (w_seen + w_model) ** -0.5
    if abs(at - seen) > HOLD_MOVED * sigma:  # continued from the held optimum with the contact where it is now held
        held["contact_time"] = at
        trial = {**data, "w": jnp.asarray(weights), "mask": data["mask"].at[i_c].set(0.0),
                 "held": data["held"].at[i_c].set(at)}
        u, _ = _solve_continued(spec, channels, n_out, options, trial, u)
    return u, at_std, {"model": model, "model_std_data": std_data, "model_std": std, "held_at": at, "held_std": at_std}


def _solve_continued(spec, channels, n_out, options, data, u):
    """The solve from ``u`` continued while its step limit stopped it, at most
    ``WEIGHTED_SOLVES`` runs: (u of the last run whose cost was finite, ``u`` if none; whether
    the last run converged with a finite cost)."""
    for _ in range(WEIGHTED_SOLVES):
        u1, cost, ok = _solve_jit(spec, channels, n_out, options, data, u)
        if not np.isfinite(float(cost)):
            return u, False
        u = u1
        if bool(ok):
            return u, True
    return u, False


def widened(w: np.ndarray, groups: dict, factors: dict) -> np.ndarray:
    """The weights ``w`` ((channels, n) of 1/sigma, as the fit stacks them) with each group's
    rows (``groups``: :func:`weighting_groups`) divided by its factor (``factors``: group ->
    sigma multiplier)."""
    scale = np.ones(w.size)
    for g, rows in groups.items():
        scale[rows] = factors[g]
    return np.asarray(w) / scale.reshape(np.shape(w))


def _weighted_by_misfit(spec, channels, n_out, options, data, u, groups: dict, n_fitted: int):
    """The fit continued from its optimum ``u`` with each group's sigma (``groups``:
    :func:`weighting_groups`) multiplied by sqrt(tau * max(1, reduced chi-square)) of that
    group's residuals in the recording's own sigmas (``least_squares.channel_variance_factors``),
    until those factors change by less than 10 % (at most ``MISFIT_ROUNDS`` fits): after the
    first, a group's misfit is no longer inflated by the compromise the others forced on it.
    A weighted fit that does not converge within ``WEIGHTED_SOLVES`` runs of the solver is
    dropped, the last one that did kept. Returns (u, group -> sigma multiplier,
    :func:`_finish` at u with the recording's own sigmas)."""
    w = np.asarray(data["w"])
    widen = {g: 1.0 for g in groups}
    finished = _finish_jit(spec, channels, n_out, options, data, u)
    for _ in range(MISFIT_ROUNDS):
        tau, misfit = channel_variance_factors(np.asarray(finished[0]), groups, n_fitted)
        new = {g: math.sqrt(tau[g] * misfit[g]) for g in groups}
        if np.allclose([new[g] for g in groups], [widen[g] for g in groups], rtol=0.1):
            break
        u1, ok = _solve_continued(spec, channels, n_out, options, {**data, "w": jnp.asarray(widened(w, groups, new))}, u)
        if not ok:
            break
        u, widen = u1, new
        finished = _finish_jit(spec, channels, n_out, options, data, u)
    return u, widen, finished


def _starting_points(spec, initial: dict, options: FitOptions, held: dict | None = None) -> np.ndarray:
    rng = np.random.default_rng(options.seed)
    held = held or {}
    starts = []
    for k in range(options.starts):
        u = []
        for p in spec:
            if p.name in held:
                u.append(0.0)
                continue
            value = initial[p.name]
            if k > 0 and p.name in START_RANGES:
                lo, hi = START_RANGES[p.name]
                value = math.exp(rng.uniform(math.log(lo), math.log(hi))) if p.transform == "log" else rng.uniform(lo, hi)
            u.append(p.to_unconstrained(p.start_inside(value)))
        starts.append(u)
    return np.asarray(starts, dtype=float)


def fit(
    measurement: Measurement,
    vehicle: Vehicle,
    template: Params | None = None,
    free: tuple[FreeParameter, ...] | None = None,
    initial: dict | None = None,
    options: FitOptions = FitOptions(),
    speed_mps: float | None = None,
    model: str = "base",
    progress=None,
    held: dict | None = None,
    require_convergence: bool = True,
    priors: dict | None = None,
    model_error: ModelError | None = None,
) -> FitResult:
    """Fit ``free`` parameters of the model to ``measurement``.

    Parameters
    ----------
    measurement : identify.Measurement (t = 0 at the measured first contact).
    vehicle : sim.Vehicle.
    template : the fixed parameters and mechanisms (default: the base model, V-SIM's defaults
        with the engine on its mounts, ``identify.discover.candidates.with_base_mechanisms``).
    free : what to fit (default: ``base_parameters(options.face_friction)``: the four collision
        parameters, the barrier face's friction if asked for, impact speed, contact time); a
        film's scale (``identify.fitting.model.LENGTH_SCALE``) is added to any ``free`` when
        the measurement has its uncertainty (``Measurement.length_scale_sigma``).
    initial : physical starting values by name (default: the template's; speed measured).
    speed_mps : impact speed (m/s) if known; else the measurement's; a measured speed with a
        sigma enters as a prior, a given one is held fixed.
    model : label of the model in reports ("base", "base+stiffness_zone").
    progress : callable taking a one-line status, or None.
    held : name -> physical value for names of ``free`` that are held fixed, not fitted
        (fits freeing different subsets of one ``free`` tuple share one compiled solve;
        the result reports only the fitted names).
    require_convergence : raise when the best start did not converge and misfits badly;
        False returns it (a caller that continues the fit from it decides).
    priors : name -> (value, sigma) in physical units: what is known of a fitted quantity
        before the fit (a vehicle file's estimate), a residual (fitted - value) / sigma.
    model_error : the model's own error added to the standard deviations (default the
        calibrated table of the measurement's kind, ``identify.fitting.model_error``;
        ``model_error.NONE``: the data's alone).

    Returns
    -------
    FitResult.

    Raises
    ------
    UserError
        No usable channel, no impact speed, or no start converged.
    """
    channels, y, w, fitted_channels = _stack(measurement)
    speed_guess = speed_mps if speed_mps is not None else measurement.impact_speed_mps
    if speed_guess is None:
        speed_guess = approach_speed(measurement)[0]
    if template is None:  # the base model: V-SIM's defaults and the engine on its mounts
        from identify.discover.candidates import with_base_mechanisms

        template = with_base_mechanisms(
            make_params(k_compression=730e3, k_restitution=730e3, restitution=0.2, dz_contact=0.0), vehicle)
    if free is None:
        free = base_parameters(options.face_friction)
        if speed_mps is not None:
            free = tuple(p for p in free if p.name != "impact_speed")
    free = tuple(free)
    # a film's scale error is one nuisance with the scale's measured uncertainty as its prior
    # (``identify.fitting.model.LENGTH_CHANNELS``); a recording without one (sensors) has none
    if measurement.length_scale_sigma and not any(p.name == "length_scale" for p in free):
        free = free + (LENGTH_SCALE,)
    held = dict(held or {})
    unknown = sorted(set(held) - {p.name for p in free})
    if unknown:
        raise ValueError(f"held parameter {unknown[0]!r} is not in free")
    # a first contact measured apart from the fitted channels (seen in the film, the load
    # cells' onset) is a measurement, not a knob: held, not fitted, its sigma carried into the
    # others' covariance (least_squares.held_at_measurement). As a prior it was outweighed by
    # the motion's thousands of samples: on the 10 clean scored films whose seen contact was
    # within 0.2 ms of the truth, the fit moved it 0.41 ms later on average (up to 1.57 ms) and
    # k_compression followed it, 5 % per ms. Held only where the model-error table has measured
    # how far the channels' own contact can be off (CONTACT_FROM_MOTION: a film's): without it
    # the two cannot be weighed, and the measurement stays a prior (load cells' onset, +- 3 ms on
    # NHTSA 10146: held there, the multi-start search fell into another basin, x RMS 13.9 mm
    # against 7.8, and discovery named a progressive stiffness)
    error_table = model_error or model_error_table(kind_of(measurement))
    contact_held = bool(options.hold_measured_contact and measurement.contact_time_sigma
                        and CONTACT_FROM_MOTION in error_table.absolute
                        and any(p.name == "contact_time" for p in free) and "contact_time" not in held)
    if contact_held:
        held["contact_time"] = float(measurement.contact_time_s)
    scale_held = bool(options.hold_measured_scale and measurement.length_scale_sigma and "length_scale" not in held)
    if scale_held:  # a measured fact, not a knob (FitOptions.hold_measured_scale)
        held["length_scale"] = 1.0
    # a film's speed, from its approach frames (FitOptions.hold_measured_speed); a header's is a prior
    speed_held = bool(options.hold_measured_speed and speed_mps is None and not measurement.impact_speed_sigma
                      and kind_of(measurement) == "film" and np.sum(_approach_samples(measurement)) >= MIN_BEFORE_CONTACT
                      and any(p.name == "impact_speed" for p in free) and "impact_speed" not in held)
    if speed_held:
        speed_guess, speed_white = approach_speed(measurement)
        held["impact_speed"] = speed_guess
    init = {
        **{n: float(getattr(template, n)) for n in ("k_compression", "k_restitution", "restitution", "dz_contact")},
        "impact_speed": speed_guess,
        "contact_time": 0.0,
        "mu_face": FACE_FRICTION_START,
        "length_scale": 1.0,
        **(initial or {}),
    }
    priors = dict(priors or {})
    # the recording's own measurements of the nuisances are priors like any other, so their
    # pulls are reported (FitResult.pulls): the measured impact speed (header, approach
    # frames) and first contact when measured apart from the fitted channels (load cells,
    # the front end seen stopping in a film)
    names = {p.name for p in free} - set(held)
    if speed_mps is None and measurement.impact_speed_sigma and "impact_speed" in names:
        priors.setdefault("impact_speed", (float(speed_guess), float(measurement.impact_speed_sigma)))
    if "length_scale" in names:
        priors.setdefault("length_scale", (1.0, float(measurement.length_scale_sigma)))
    if "mu_face" in names:  # prior knowledge, not a measurement (FACE_FRICTION_PRIOR)
        priors.setdefault("mu_face", FACE_FRICTION_PRIOR)
    if measurement.contact_time_sigma and "contact_time" in names:
        priors.setdefault("contact_time", (float(measurement.contact_time_s), float(measurement.contact_time_sigma)))
    data = dict(
        t=jnp.asarray(measurement.t),
        y=jnp.asarray(y),
        w=jnp.asarray(w),
        template=template,
        vehicle=vehicle.numbers_only(),  # its names and outline are no part of the compiled programs
        speed_guess=jnp.asarray(float(speed_guess)),
        mask=jnp.asarray([0.0 if p.name in held else 1.0 for p in free]),
        held=jnp.asarray([float(held.get(p.name, 0.0)) for p in free]),
        prior_mu=jnp.asarray([float(priors[p.name][0]) if p.name in priors else 0.0 for p in free]),
        prior_w=jnp.asarray([1.0 / float(priors[p.name][1]) if p.name in priors and p.name not in held else 0.0
                             for p in free]),
    )
    duration = float(measurement.t.max()) + 0.002 + 0.010  # room for the contact-time shift
    n_out = int(math.ceil(duration / options.solver.output_dt)) + 2

    # the number of starts, their seed and the reweighting do not change the compiled solve:
    # fits that differ only in those share it
    compiled = dataclasses.replace(options, starts=1, seed=0, misfit_weights=False, face_friction=False,
                                   hold_measured_contact=True, held_from_channels=True, hold_measured_scale=True,
                                   hold_measured_speed=True)
    runs = []
    for k, u0 in enumerate(_starting_points(free, init, options, held)):
        if progress is not None:
            progress(f"fit: start {k + 1} of {options.starts}")
        runs.append([np.asarray(a) for a in _solve_jit(free, channels, n_out, compiled, data, jnp.asarray(u0))])
    u_all, costs, ok = (np.stack(a) for a in zip(*runs))
    costs = np.where(np.isfinite(costs), costs, np.inf)
    best = int(np.argmin(costs))
    if not np.isfinite(costs[best]):
        raise UserError(f"{measurement.source}: the fit did not converge from any of {len(costs)} starting points")
    tol = max(1e-6 * costs[best], 1e-9)
    at_best = int(np.sum(costs <= costs[best] + max(tol, 1e-3 * costs[best])))
    others = sorted({round(float(c), 6) for c in costs if np.isfinite(c) and c > costs[best] * 1.01 + 1e-6})

    u, converged = jnp.asarray(u_all[best]), bool(ok[best])
    n = len(measurement.t)
    rows = {name: c * n + np.flatnonzero(w[c] > 0) for c, name in enumerate(channels) if name in fitted_channels}
    # the groups weighted by their own misfit: the channels, their approach apart (weighting_groups)
    groups = weighting_groups(channels, w, np.asarray(measurement.t)) if options.misfit_weights else rows
    widen = {g: 1.0 for g in groups}  # each group's sigma multiplier in the fit's weights
    if options.misfit_weights:
        if progress is not None:
            progress("fit: again, each channel weighted by its own misfit")
        u, widen, finished = _weighted_by_misfit(free, channels, n_out, compiled, data, u, groups, len(free) - len(held))
        fit_weights = widened(w, groups, widen)
    else:
        fit_weights = w
        finished = _finish_jit(free, channels, n_out, compiled, data, u)
    held_measured = {}
    n_res = int(np.sum(w > 0)) + int(np.count_nonzero(np.asarray(data["prior_w"])))
    held_var = {}  # name -> variance of each measured quantity held, carried into the covariance below
    index = {p.name: i for i, p in enumerate(free)}
    # the measured speed and scale held where measured, compared with where the channels alone
    # put them (together: the approach frames fix their product); their sigmas below
    at_measured = [name for name, on in (("impact_speed", speed_held), ("length_scale", scale_held)) if on]
    for name in at_measured:
        held_measured[name] = {"measured": held[name], "held_at": held[name]}
    if at_measured and options.held_from_channels:
        idx = [index[name] for name in at_measured]
        free_measured = {**data, "mask": data["mask"].at[jnp.asarray(idx)].set(1.0)}
        estimates = _estimate_from_channels(free, channels, n_out, compiled, free_measured, fit_weights, u, idx, held,
                                            (0.0,), groups, n_res, options.misfit_weights)
        for name, (model, std_data, bound) in zip(at_measured, estimates or ()):
            held_measured[name].update(model=model, model_std_data=std_data, model_std=std_data,
                                       **({"model_at_bound": bound} if bound else {}))
    if contact_held:
        i_c = index["contact_time"]
        sigma = float(measurement.contact_time_sigma)
        held_measured["contact_time"] = {"measured": held["contact_time"], "sigma": sigma}
        data["mask"] = data["mask"].at[i_c].set(1.0)  # the contact free, with no prior: its Jacobian column
        if options.held_from_channels:
            u, sigma, compared = _held_at_combined_contact(
                free, channels, n_out, compiled, data, fit_weights, u, i_c, held, sigma, groups, n_res,
                options.misfit_weights, error_table.std(CONTACT_FROM_MOTION, 0.0))
            held_measured["contact_time"].update(compared)
        held_var["contact_time"] = sigma**2
    held_names = [*at_measured, *held_var]
    for name in held_names:  # free, with no prior, for their columns of the Jacobian; at the held values
        data["mask"] = data["mask"].at[index[name]].set(1.0)
        u = u.at[index[name]].set(free[index[name]].to_unconstrained(held.pop(name)))
    if held_names:
        finished = _finish_jit(free, channels, n_out, compiled, data, u)
    # residuals and Jacobian in the recording's own sigmas: the covariance widens each channel by its misfit there
    r, jac_u, dvalue_du, traj, preds = finished
    r, jac_u, dvalue_du, preds = (np.asarray(a) for a in (r, jac_u, dvalue_du, preds))
    fitted = [i for i, p in enumerate(free) if p.name not in held]
    jac_u, dvalue_du = jac_u[:, fitted], dvalue_du[fitted]
    spec_all, free = free, tuple(free[i] for i in fitted)
    unc = parameter_covariance(r, jac_u, dvalue_du, np.array([p.typical for p in free]), groups, n_res,
                               per_channel=options.misfit_weights, tau_at_least=approach_tau_floor(groups))
    by_channel = None  # FitResult.std_data_by_channel: the same optimum, each channel widened by its own misfit
    own = groups if options.misfit_weights else weighting_groups(channels, w, np.asarray(measurement.t))
    if not options.misfit_weights:
        by_channel = parameter_covariance(r, jac_u, dvalue_du, np.array([p.typical for p in free]), own, n_res,
                                          per_channel=True, tau_at_least=approach_tau_floor(own))
    if held_names:  # together: each one's error carried into the others through all of them
        s = measured_covariance(held_names, held_var, measurement, speed_guess,
                                speed_white if speed_held else 0.0, r, own, len(fitted))
        for k, name in enumerate(held_names):
            if name in at_measured:
                held_measured[name].update(sigma=float(np.sqrt(s[k, k])), held_std=float(np.sqrt(s[k, k])))
        i_held = [[p.name for p in free].index(name) for name in held_names]
        unc = held_at_measurement(unc, i_held, covariance=s)
        if by_channel is not None:
            by_channel = held_at_measurement(by_channel, i_held, covariance=s)

    values = {p.name: float(p.to_physical(u[i])) for i, p in enumerate(spec_all) if p.name not in held}
    every = {**{k: jnp.asarray(float(v)) for k, v in held.items()}, **{k: jnp.asarray(v) for k, v in values.items()}}
    params, speed, contact_time = assemble(template, every, float(speed_guess))

    predictions, rms = {}, {}
    for c, name in enumerate(channels):
        pred, valid = preds[c], w[c] > 0
        if name not in fitted_channels:  # shown and compared, not fitted
            if name in OFFSET_FREE:
                continue
            valid = measurement.valid(name)
        elif name in OFFSET_FREE:
            pred = pred - float(weighted_offset(pred - y[c], w[c]))
        predictions[name] = pred
        rms[name] = float(np.sqrt(np.mean((pred - y[c])[valid] ** 2)))
    for name in measurement.derived:  # shown: a derived channel with no valid sample is not in the stack
        if name in measurement.channels and name not in OFFSET_FREE and name not in predictions:
            pred = np.asarray(in_recording_lengths(predict(traj, name, jnp.asarray(measurement.t), speed, contact_time,
                                                           vehicle.wheel_radius, options.solver.output_dt), name, every))
            valid = measurement.valid(name)
            predictions[name] = pred
            rms[name] = float(np.sqrt(np.mean((pred - measurement.channels[name])[valid] ** 2)))

    names = tuple(p.name for p in free)
    std_data = dict(zip(names, map(float, unc.std)))
    # the model's own error where the fitted model runs (the rear lifted, or not) within the recording
    regimes = regimes_of(traj, recorded_after_contact(measurement, fitted_channels, float(contact_time)))
    here, model_error_where = error_table.in_regimes(regimes, values)
    factor, beyond = error_table.beyond_measured(rms.get("x_m")), ""
    if factor > 1.0:  # a misfit beyond any fit the table was measured on: its errors scaled by it
        here = here.scaled(factor)
        beyond = (f"scaled by {factor:.2g}: this fit misses x by {1e3 * rms['x_m']:.1f} mm RMS, beyond the"
                  f" {1e3 * error_table.misfit_x_m:.1f} mm of any fit the model's error was measured on")
        model_error_where = {n: "; ".join(filter(None, (model_error_where.get(n), beyond)))
                             for n in names if here.std(n, values[n]) > 0.0}
    std, std_model = here.covering(values, std_data)
    result = FitResult(
        names=names,
        units={p.name: p.unit for p in free},
        values=values,
        std=std,
        std_data=std_data,
        std_model=std_model,
        covariance=unc.cov + np.diag([std_model[n] ** 2 for n in names]),
        correlation=unc.corr,
        identified={},
        rms=rms,
        chi2=unc.chi2,
        dof=unc.dof,
        converged=converged,
        starts=len(costs),
        starts_at_best=at_best,
        other_minima=others,
        params=params,
        speed=float(speed),
        contact_time=float(contact_time),
        trajectory=traj,
        predictions=predictions,
        measurement=measurement,
        model=model,
        correlation_time=unc.tau,
        misfit=unc.misfit,
        sigma_widened={g: float(f) for g, f in widen.items() if f > 1.0},
        priors={k: (float(v[0]), float(v[1])) for k, v in priors.items() if k not in held},
        held_measured=held_measured,
        model_error_where={n: w for n, w in model_error_where.items() if n in names},
        std_data_by_channel={} if by_channel is None else dict(zip(names, map(float, by_channel.std))),
        model_error_scaled=beyond,
    )
    result.identified = {**assess_identifiability(result, fitted_channels),
                         **log_scale_identifiability(free, result.values, result.std, result.std_data, result.std_model)}
    # no silent bounds: a value the bound stopped is not a value the data gave
    result.at_bound = {p.name: where for p in free if (where := p.at_bound(result.values[p.name]))}
    for name, why in result.at_bound.items():
        result.mark_not_identified(name, f"not identified: {why}, where the fit stopped it")
    if require_convergence and not result.converged and result.reduced_chi2 > 100:
        raise UserError(
            f"{measurement.source}: the fit did not converge (reduced chi-square {result.reduced_chi2:.3g} after"
            f" {options.max_steps} steps); check the vehicle, the speed and the tracks"
        )
    return result


def log_scale_identifiability(free, values: dict, std: dict, std_data: dict | None = None,
                              std_model: dict | None = None) -> dict[str, tuple[bool, str]]:
    """name -> (False, reason) for each log-scale parameter other than the collision
    parameters (a mechanism's stiffness, an engine's stiffnesses and mass) whose standard
    deviation exceeds ``LOG_SCALE_NOT_IDENTIFIED`` of its value: held to the standard of
    k_compression. ``std_data``, ``std_model``: the two parts of ``std``; the model's own
    error is named in the reason when it is the larger."""
    out = {}
    for p in free:
        if p.transform == "log" and p.name not in NOT_IDENTIFIED and values[p.name] > 0:
            rel = std[p.name] / values[p.name]
            if not rel <= LOG_SCALE_NOT_IDENTIFIED:  # NaN too
                why = (model_error_reason(values[p.name], (std_data or std)[p.name], (std_model or {}).get(p.name, 0.0),
                                          "relative") or "the recorded motion barely changes when it changes")
                out[p.name] = (False, f"not identified (std {100 * rel:.0f} %): {why}")
    return out


def model_error_reason(value: float, std_data: float, std_model: float, kind: str, where: str = "") -> str:
    """Why a parameter is not identified when the model's own error ``std_model``
    (``identify.fitting.model_error``) outweighs the data's ``std_data``, else ''; ``where``:
    the regime that error was measured in (``FitResult.model_error_where``), when not the
    clean worlds'."""
    if not std_model > std_data:
        return ""

    def size(sd):
        if kind != "relative" or not value:
            return f"{sd:.2g}"
        pct = 100 * sd / abs(value)
        return f"{pct:.0f} %" if pct >= 10 else f"{pct:.2g} %"

    return (f"the model's own error ({size(std_model)}) outweighs the data's ({size(std_data)}): on recordings the"
            " model did not make, its simplifications moved this parameter that far" + (f"; {where}" if where else ""))


def spread_of(name: str, value: float, sd: float) -> float:
    """A collision parameter's standard deviation ``sd`` in the terms of its
    ``NOT_IDENTIFIED`` limit: relative to ``value``, or in its own unit."""
    kind, _ = NOT_IDENTIFIED[name]
    return sd / abs(value) if kind == "relative" and value != 0 else sd


def recorded_after_contact(measurement: Measurement, channels, contact_time: float) -> float:
    """s after first contact (``contact_time``, s on the measurement's clock) of the last
    sample of ``channels`` the measurement has: how far into the crash it sees."""
    return max(float(measurement.t[measurement.valid(c)].max()) for c in channels) - contact_time


def assess_identifiability(result: FitResult, channels) -> dict[str, tuple[bool, str]]:
    """Say, for each collision parameter, whether the data constrain it, and if not why.

    A parameter is not identified when its standard deviation passes ``NOT_IDENTIFIED``;
    the reason names what the recording lacks (the restitution phase, pitch data) or the
    parameter it cannot be told apart from.
    """
    from sim import events_ms

    ev = events_ms(result.trajectory)
    t_end_ms = recorded_after_contact(result.measurement, channels, result.contact_time) * 1e3
    names = list(result.names)
    out = {}
    for name, (kind, limit) in NOT_IDENTIFIED.items():
        if name not in result.values:
            continue
        value, sd = result.values[name], result.std[name]
        spread = spread_of(name, value, sd)
        if spread <= limit:
            out[name] = (True, "")
            continue
        reason = model_error_reason(value, result.std_data.get(name, sd), result.std_model.get(name, 0.0), kind,
                                    result.model_error_where.get(name, ""))
        if not reason and name in ("k_restitution", "restitution"):
            tr = result.trajectory
            stopped = np.flatnonzero(np.asarray(tr.vx) <= 0.0)
            comp = float(np.asarray(tr.t)[stopped[0]] * 1e3) if len(stopped) else None
            sep = ev.get("separation")
            if comp is not None and t_end_ms < comp + 5:
                reason = f"the recording ends at {t_end_ms:.0f} ms, before the end of compression ({comp:.0f} ms): the restitution phase is not observed"
            elif sep is not None and t_end_ms < sep:
                reason = f"the recording ends at {t_end_ms:.0f} ms, before the car leaves the barrier ({sep:.0f} ms): the restitution phase is seen only in part"
        if name == "dz_contact" and "pitch_rad" not in channels and "z_m" not in channels:
            reason = "the recording has no pitch or height channel: the height of the force shows only in the car's pitch and heave"
        if not reason:
            i = names.index(name)
            others = [(abs(result.correlation[i, j]), names[j]) for j in range(len(names)) if j != i]
            rho, partner = max(others) if others else (0.0, "")
            if rho > 0.9:
                reason = f"it is correlated with {partner} (|rho| = {rho:.2f}): the data fix only a combination of the two"
            else:
                reason = "the recorded motion barely changes when it changes"
        rel = f"{100 * spread:.0f} %" if kind == "relative" else f"{spread:.3g}"
        out[name] = (False, f"not identified (std {rel}): {reason}")
    return out
