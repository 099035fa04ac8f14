"""The library of candidate mechanisms that discovery tries, and the superset model that
lets one compiled fit try them all.

Every candidate is one module of this package (``identify.discover.candidates.base.Candidate``: its
``sim.mechanisms`` class, free parameters, starting guesses, evidence check, where it acts
and what makes a fit of it implausible); ``REGISTRY`` lists them, one line each, in the
order discovery tries them. Adding one is a new module and a line here.

The superset template carries every candidate's mechanism at its neutral value (a blocking
or zone depth of 10 m is never reached; a progression or rate coefficient of 0 changes
nothing; the engine rides on its mounts and never reaches the barrier, which is part of the
base model: ``Candidate.in_base``), so fits that free different candidates differ only in
which parameters are held (data, not code): one compile serves them all
(``identify.fitting.collision_fit.fit(..., held=...)``).
"""

from __future__ import annotations

import dataclasses
import importlib

import jax
import jax.numpy as jnp

from identify.discover.candidates.base import NEVER_REACHED, SEEN, Candidate
from identify.fitting.model import LENGTH_SCALE, base_parameters, vehicle_value
from sim import Params

REGISTRY = (
    "front_wheel_block",
    "stiffness_zone",
    "progressive_stiffness",
    "rate_dependence",
    "rear_axle_lift",
    "engine_impact",
)

CANDIDATES: tuple[Candidate, ...] = tuple(importlib.import_module(f"{__name__}.{m}").CANDIDATE for m in REGISTRY)
BY_EFFECT = {c.effect: c for c in CANDIDATES}

__all__ = ["BY_EFFECT", "CANDIDATES", "NEVER_REACHED", "SEEN", "Candidate", "assumed_in_base", "base_mechanisms", "held_for",
           "kept_mechanisms", "measured_effects", "neutral_values", "priors_for", "starting_guesses", "superset_spec",
           "superset_template", "with_base_mechanisms"]


def measured_effects(measurement) -> tuple[str, ...]:
    """Candidates the recording measures directly, so they belong to the base model rather
    than to discovery: ``engine_impact`` when the engine's own motion was recorded and is
    fitted (not only shown: ``Measurement.derived``)."""
    fitted = set(measurement.channels) - set(measurement.derived)
    return ("engine_impact",) if {"engine_x_m", "engine_vx_mps"} & fitted else ()


def priors_for(active, vehicle) -> dict[str, tuple[float, float]]:
    """The priors of the candidates named in ``active`` (``Candidate.priors``)."""
    out = {}
    for effect in active:
        c = BY_EFFECT[effect]
        if c.priors is not None:
            out.update(c.priors(vehicle))
    return out


def _neutral(c: Candidate, field: str, vehicle) -> float:
    """Candidate ``c``'s neutral value of ``field`` for ``vehicle`` (``Candidate.neutral``)."""
    v = c.neutral[field]
    if callable(v):
        return float(v(vehicle))
    return vehicle_value(vehicle, f"{c.effect}.{field}") if v == "vehicle" else float(v)


def _neutral_mechanism(c: Candidate, vehicle):
    return c.mechanism(**{f: jnp.asarray(_neutral(c, f, vehicle), dtype=jnp.float64) for f in c.neutral})


def base_mechanisms(vehicle) -> tuple:
    """The mechanisms every fitted model holds at their neutral state (``Candidate.in_base``:
    the engine on its mounts, out of the barrier's reach), for ``vehicle``."""
    return tuple(_neutral_mechanism(c, vehicle) for c in CANDIDATES if c.in_base)


def with_base_mechanisms(params: Params, vehicle) -> Params:
    """``params`` with the base model's mechanisms (:func:`base_mechanisms`) it lacks added:
    the motion the base model gives those collision parameters (at most one second body:
    an engine already there stays as it is)."""
    effects = {m.effect for m in params.mechanisms}
    body = any(m.has_body for m in params.mechanisms)
    extra = tuple(m for m in base_mechanisms(vehicle) if m.effect not in effects and not (m.has_body and body))
    return dataclasses.replace(params, mechanisms=params.mechanisms + extra)


def assumed_in_base(params: Params, fitted) -> list[dict]:
    """The base model's mechanisms in ``params`` that the fit did not fit (their effect not
    among ``fitted``): result.json's ``fit.assumed``, each with its effect, the sentence that
    says what it is (``Candidate.in_base``) and its parameters ({name: {value, unit}})."""
    return [{"effect": m.effect, "explanation": BY_EFFECT[m.effect].in_base,
             "parameters": {n: {"value": v, "unit": u} for n, (v, u) in m.parameter_values().items()}}
            for m in params.mechanisms if BY_EFFECT[m.effect].in_base and m.effect not in set(fitted)]


def superset_template(params: Params, vehicle) -> Params:
    """``params`` with every candidate's mechanism appended at its neutral value for
    ``vehicle`` (and any mechanism it already had dropped: the candidates cover them)."""
    mechanisms = tuple(_neutral_mechanism(c, vehicle) for c in CANDIDATES if c.mechanism is not None)
    # plain float64 leaves (a fit's Params may hold weakly typed ones, which would make the
    # compiled fit's signature differ and recompile it)
    params = jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=jnp.float64), params)
    return dataclasses.replace(params, mechanisms=mechanisms)


def superset_spec(base_names) -> tuple:
    """The base parameters named in ``base_names`` (a base fit's ``names``, in the model's
    order) followed by every candidate's parameters: the compiled fit's parameter vector."""
    base = tuple(p for p in (*base_parameters(face_friction=True), LENGTH_SCALE) if p.name in set(base_names))
    return base + tuple(p for c in CANDIDATES for p in c.parameters)


def neutral_values(vehicle) -> dict[str, float]:
    """``effect.field`` -> its value when discovery has not added the candidate (off, or for
    a candidate ``in_base`` out of the barrier's way), for every candidate's free parameter."""
    return {name: _neutral(c, name.split(".", 1)[1], vehicle) for c in CANDIDATES for name in c.names}


def held_for(active, vehicle, measured=()) -> dict[str, float]:
    """The held values when the candidates named in ``active`` are fitted: all others neutral,
    and of those the recording measures (``measured``), their ``fixed_when_measured`` fields."""
    active = set(active)
    fixed = {f"{e}.{f}" for e in measured for f in BY_EFFECT[e].fixed_when_measured}
    return {k: v for k, v in neutral_values(vehicle).items() if k.split(".", 1)[0] not in active or k in fixed}


def starting_guesses(candidate: Candidate, fr, vehicle, analysis=None, measured=False) -> list[dict[str, float]]:
    """The candidate's starting guesses in physical units (``effect.field`` -> value): its
    ``starts`` (and its ``measured_starts`` when ``measured``: the recording measures the
    body itself), each rule evaluated on the current fit ``fr`` (None before any fit), the
    vehicle and the current residual analysis; a guess that repeats an earlier one (a rule
    that falls back on the typical value) is tried once."""
    starts = (*candidate.starts, *candidate.measured_starts) if measured else candidate.starts
    fixed = set(candidate.fixed_when_measured) if measured else set()
    guesses = [{f"{candidate.effect}.{field}": float(value(fr, vehicle, analysis) if callable(value) else value)
                for field, value in start.items() if field not in fixed} for start in starts]
    return [g for i, g in enumerate(guesses) if g not in guesses[:i]]


def kept_mechanisms(params: Params, accepted) -> tuple:
    """The mechanisms of a superset model's ``params`` that its fitted model holds: those of
    the ``accepted`` effects and those in the base model (``Candidate.in_base``), with the
    values the fit gave them; the others are switched off and dropped (the trajectory is
    the same)."""
    return tuple(m for m in params.mechanisms if m.effect in set(accepted) or BY_EFFECT[m.effect].in_base)
