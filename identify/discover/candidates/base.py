"""What a candidate mechanism is to discovery, and the rules several candidates share.

A candidate is one module of this package defining ``CANDIDATE = Candidate(...)``: the
``sim.mechanisms`` class with its equation and explanation, its free parameters with their
transforms, the values that switch it off, its starting guesses, what it implies for the
channels a recording measures directly (its evidence check), where it acts in a fitted
model and the rules that refuse a fit of it as implausible. ``identify.discover.candidates`` lists
the modules (one line each); ``identify.discover.loop`` calls only these hooks, never a
candidate by name.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import jax.numpy as jnp
import numpy as np

from identify.fitting.model import FreeParameter

NEVER_REACHED = 10.0  # m: a depth the crush never reaches (the mechanism stays off)
SEEN = "seen: "  # how an evidence line starts when a measured channel shows the mechanism
DECISIVE_CHI2 = 9.0  # a chi-square difference of 9: three standard deviations


class _UnitArea:
    """Stands in for a Vehicle in mechanism hooks evaluated per unit contact area."""

    contact_area = 1.0


def loading_force_differs(fr, mechanism) -> np.ndarray:
    """Output samples of fit ``fr`` where ``mechanism`` changes the loading force from the base
    law k_compression * crush by more than 2 % of its largest change (loading only): the
    default of :attr:`Candidate.active`."""
    tr = fr.trajectory
    crush = np.asarray(tr.crush)
    rate = np.gradient(crush, np.asarray(tr.t))
    loading = (crush >= np.asarray(tr.crush_max) - 1e-9) & (rate > 0)
    f0 = float(fr.params.k_compression) * crush  # N/m^2: the base law per unit contact area
    extra = np.asarray(mechanism.loading_force(jnp.asarray(f0), jnp.asarray(crush), jnp.asarray(rate),
                                               fr.params, _UnitArea())) - f0
    extra = np.where(loading, np.abs(extra), 0.0)
    return extra > 0.02 * extra.max() if extra.max() > 0 else np.zeros_like(extra, bool)


def samples_in_window(fr, channel: str, window_ms) -> tuple[np.ndarray, str]:
    """The samples of ``channel`` an evidence check may use: a bool mask over the recording,
    valid samples inside ``window_ms`` (ms, measurement clock; none when the recording lacks
    the channel), and the window as text ("34-100 ms")."""
    m = fr.measurement
    t_ms = np.asarray(m.t) * 1e3
    inside = (t_ms >= window_ms[0]) & (t_ms <= window_ms[1])
    ok = inside & m.valid(channel) if channel in m.channels else np.zeros_like(inside)
    return ok, f"{window_ms[0]:.0f}-{window_ms[1]:.0f} ms"


def chi2_about_a_constant(r: np.ndarray, sigma: np.ndarray) -> float:
    """Chi-square of the series ``r`` about its own weighted mean (weights 1 / sigma^2): how
    far it is from a constant, whatever the constant (an evidence check's unknown offset)."""
    w = 1.0 / np.asarray(sigma) ** 2
    return float(np.sum(w * (r - np.sum(w * r) / np.sum(w)) ** 2))


def signal_chi2s(measured: np.ndarray, signal: np.ndarray, sigma: np.ndarray) -> tuple[float, float, float]:
    """An evidence check's three chi-squares, each about its own constant
    (:func:`chi2_about_a_constant`): of the ``signal`` a mechanism implies for a measured
    channel (what telling its presence from its absence is worth), of the ``measured``
    channel as it is (the signal absent) and of ``measured - signal`` (the signal present)."""
    return (chi2_about_a_constant(signal, sigma), chi2_about_a_constant(measured, sigma),
            chi2_about_a_constant(measured - signal, sigma))


def differs_from_zero(fr, name: str) -> str:
    """'' when parameter ``name``, whose value 0 switches its mechanism off, differs from 0 by
    2 standard deviations, else why not: a fit that cannot tell it from 0 has not found the
    mechanism (it has spent a parameter on a combination the others already fix)."""
    value, sd = fr.values[name], fr.std[name]
    if abs(value) < 2 * sd:
        return f"{name} ({value:.3g} +- {sd:.2g}) does not differ from 0, where it changes nothing"
    return ""


def _no_rule(fr, vehicle) -> str:
    return ""


def _nothing_unseen(fr) -> dict[str, str]:
    return {}


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One candidate mechanism.

    effect : effect name (``docs/interface.md``), the mechanism's ``effect``.
    mechanism : the sim mechanism class, or None for a candidate that changes the vehicle
        (``identify.fitting.model.VEHICLE_OVERRIDES``).
    parameters : its fitted fields, as FreeParameter named ``effect.field``.
    neutral : field -> the value it has when discovery has not added it (physical units): one
        that switches it off, or, for a candidate ``in_base``, one that keeps it out of the
        barrier's way; ``"vehicle"``: the vehicle file's own value; a callable(vehicle) ->
        value: a value that depends on the vehicle (an engine's typical mass).
    starts : starting guesses, each field -> a value or a rule ``(fit, vehicle, analysis) ->
        value`` (``fit`` the current model's FitResult, or None before any fit; ``analysis``
        its ``identify.fitting.residuals.ResidualAnalysis``, or None).
    report : field -> name of the parameter in the discovery's report (``depth_m``).
    text : the one-sentence explanation when there is no mechanism class.
    priors : callable(vehicle) -> {``effect.field``: (value, sigma)}: what is known of its
        parameters before any fit (``identify.fitting.collision_fit.fit``'s ``priors``), or None.
    evidence : callable(fit, vehicle, window_ms) -> (reason, evidence) checking what the
        mechanism implies for a channel measured directly against what that channel shows:
        ``reason`` '' when the candidate may stand, else why not; ``evidence`` one line for
        the report (starting with :data:`SEEN` where a measured channel shows the mechanism
        acting, "inferred, not seen: ..." where none can). None: no channel shows it.
    active : callable(fit) -> bool per output sample of ``fit.trajectory``: where the fitted
        mechanism acts; None: where it changes the loading force (:func:`loading_force_differs`).
    implausible : callable(fit, vehicle) -> '' or why a fit of this candidate is not a
        finding, beyond the rules every candidate meets (``identify.discover.loop``).
    unseen : callable(fit) -> {``effect.field``: reason}: its parameters the recorded crash
        cannot show in this fit (an engine that never reaches the barrier shows nothing of its
        gap but that it is larger), reported not identified with the reason.
    measured_starts : further starting guesses (as ``starts``) when the recording measures
        this body itself and it is fitted as part of the base model.
    fixed_when_measured : fields held at their ``neutral`` value, not fitted, when the
        recording measures this body itself (an engine's mounts' break force: freed there, the
        fit of NHTSA 10146's engine let the mounts go at 240 N and put the engine at 40 kg).
    in_base : '' for a candidate whose neutral state is its absence; else its neutral state is
        part of the base model (the engine on its mounts, out of the barrier's reach: every
        car has one), every fitted model keeps it, and this is the sentence that says so in
        reports; discovery's candidate is then what the neutral state leaves out (the engine
        reaching the barrier).
    shown_in_base : '' for a candidate only discovery can add; else the base model can show its
        effect by itself (the rear wheels lifted by a contact force below the centre of
        gravity), and this is the sentence that says so: a fitted model where it acts reports
        it, with its window and its evidence check, as an effect the model shows
        (``identify.discover.shown``), not as a discovery.
    """

    effect: str
    mechanism: type | None
    parameters: tuple[FreeParameter, ...]
    neutral: dict[str, float | str]
    starts: tuple[dict[str, float | Callable], ...]
    report: dict[str, str]
    text: str = ""
    priors: Callable | None = None
    evidence: Callable | None = None
    active: Callable | None = None
    implausible: Callable = _no_rule
    unseen: Callable = _nothing_unseen
    measured_starts: tuple[dict[str, float | Callable], ...] = ()
    fixed_when_measured: tuple[str, ...] = ()
    in_base: str = ""
    shown_in_base: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def explanation(self) -> str:
        return self.mechanism.explanation if self.mechanism is not None else self.text

    def acting(self, fr) -> np.ndarray:
        """Bool per output sample of ``fr.trajectory``: where the fitted mechanism acts."""
        if self.active is not None:
            return np.asarray(self.active(fr), bool)
        return loading_force_differs(fr, next(m for m in fr.params.mechanisms if m.effect == self.effect))


def parameter(effect: str, field: str, unit: str, transform: str, **kw) -> FreeParameter:
    """The candidate's free parameter ``effect.field`` (``identify.fitting.model.FreeParameter``)."""
    return FreeParameter(f"{effect}.{field}", unit, transform, **kw)
