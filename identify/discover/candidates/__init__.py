"""The library of candidate mechanisms that discovery tries, and the superset model that
lets one compiled fit try them all.

Every candidate is one module of this package (``identify.discover.candidates.base.Candidate``: its
``sim.mechanisms`` class, free parameters, starting guesses, evidence check, where it acts
and what makes a fit of it implausible); ``REGISTRY`` lists them, one line each, in the
order discovery tries them. Adding one is a new module and a line here.

The superset template carries every candidate's mechanism at its neutral value (a blocking
or zone depth of 10 m is never reached; a progression or rate coefficient of 0 changes
nothing), so fits that free different candidates differ only in which parameters are held
(data, not code): one compile serves them all (``identify.fitting.collision_fit.fit(..., held=...)``).
"""

from __future__ import annotations

import dataclasses
import importlib

import jax
import jax.numpy as jnp

from identify.discover.candidates.base import NEVER_REACHED, Candidate
from identify.fitting.model import base_parameters, vehicle_value
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

__all__ = ["BY_EFFECT", "CANDIDATES", "NEVER_REACHED", "Candidate", "accepted_mechanisms", "held_for",
           "measured_effects", "neutral_values", "priors_for", "starting_guesses", "superset_spec",
           "superset_template"]


def measured_effects(measurement) -> tuple[str, ...]:
    """Candidates the recording measures directly, so they belong to the base model rather
    than to discovery: ``engine_impact`` when the engine's own motion was recorded."""
    return ("engine_impact",) if {"engine_x_m", "engine_vx_mps"} & set(measurement.channels) else ()


def priors_for(active, vehicle) -> dict[str, tuple[float, float]]:
    """The priors of the candidates named in ``active`` (``Candidate.priors``)."""
    out = {}
    for effect in active:
        c = BY_EFFECT[effect]
        if c.priors is not None:
            out.update(c.priors(vehicle))
    return out


def superset_template(params: Params) -> Params:
    """``params`` with every candidate's mechanism appended at its neutral value (and any
    mechanism it already had dropped: the candidates cover them)."""
    mechanisms = tuple(
        c.mechanism(**{f: jnp.asarray(float(v), dtype=jnp.float64) for f, v in c.neutral.items()})
        for c in CANDIDATES if c.mechanism is not None
    )
    # plain float64 leaves (a fit's Params may hold weakly typed ones, which would make the
    # compiled fit's signature differ and recompile it)
    params = jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=jnp.float64), params)
    return dataclasses.replace(params, mechanisms=mechanisms)


def superset_spec(base_names) -> tuple:
    """The base parameters named in ``base_names`` (a base fit's ``names``, in the model's
    order) followed by every candidate's parameters: the compiled fit's parameter vector."""
    base = tuple(p for p in base_parameters(face_friction=True) if p.name in set(base_names))
    return base + tuple(p for c in CANDIDATES for p in c.parameters)


def neutral_values(vehicle) -> dict[str, float]:
    """``effect.field`` -> the value that switches the mechanism off, for every candidate."""
    out = {}
    for c in CANDIDATES:
        for name in c.names:
            v = c.neutral[name.split(".", 1)[1]]
            out[name] = vehicle_value(vehicle, name) if v == "vehicle" else float(v)
    return out


def held_for(active, vehicle) -> dict[str, float]:
    """The held values when the candidates named in ``active`` are fitted: all others off."""
    active = set(active)
    return {k: v for k, v in neutral_values(vehicle).items() if k.split(".", 1)[0] not in active}


def starting_guesses(candidate: Candidate, fr, vehicle, analysis=None, measured=False) -> list[dict[str, float]]:
    """The candidate's starting guesses in physical units (``effect.field`` -> value): its
    ``starts`` (and its ``measured_starts`` when ``measured``: the recording measures the
    body itself), each rule evaluated on the current fit ``fr`` (None before any fit), the
    vehicle and the current residual analysis."""
    starts = (*candidate.starts, *candidate.measured_starts) if measured else candidate.starts
    return [{f"{candidate.effect}.{field}": float(value(fr, vehicle, analysis) if callable(value) else value)
             for field, value in start.items()} for start in starts]


def accepted_mechanisms(values: dict[str, float], effects) -> tuple:
    """The sim mechanisms of the accepted ``effects`` with their fitted ``values`` (effects
    that change the vehicle have none)."""
    out = []
    for effect in effects:
        c = BY_EFFECT[effect]
        if c.mechanism is None:
            continue
        fields = {f: jnp.asarray(float(v)) for f, v in c.neutral.items()}
        fields.update({name.split(".", 1)[1]: jnp.asarray(float(values[name])) for name in c.names})
        out.append(c.mechanism(**fields))
    return tuple(out)
