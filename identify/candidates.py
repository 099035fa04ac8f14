"""The library of candidate mechanisms that discovery tries, and the superset model that
lets one compiled fit try them all.

Every candidate is a ``sim.mechanisms`` class (its equation and one-sentence explanation
live there) plus what the fit needs: its free parameters with their transforms, the value
that switches it off (``neutral``), and a few starting guesses. One candidate changes the
vehicle instead of adding a mechanism: ``rear_axle_lift`` fits the rear axle's stiffness
(the suspension travel before the rear wheels leave the ground, with the force plane dz'
below the CG that lifts them), neutral at the vehicle file's value. The superset template
carries every candidate's mechanism at its neutral value (a blocking or zone depth of
10 m is never reached; a progression or rate coefficient of 0 changes nothing), so fits
that free different candidates differ only in which parameters are held (data, not code):
one compile serves them all (``identify.fitting.fit(..., held=...)``).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from identify.evidence import front_wheels_blocked
from identify.model import FreeParameter, base_parameters
from sim import EngineImpact, FrontWheelBlock, Params, ProgressiveStiffness, RateDependence, StiffnessZone

NEVER_REACHED = 10.0  # m: a depth the crush never reaches (the mechanism stays off)


@dataclasses.dataclass(frozen=True)
class Candidate:
    """One candidate mechanism.

    effect : effect name (``docs/interface.md``), the mechanism's ``effect``.
    mechanism : the sim mechanism class, or None for a candidate that changes the vehicle
        (``identify.model.VEHICLE_OVERRIDES``).
    parameters : its fitted fields, as FreeParameter named ``effect.field``.
    neutral : field -> value that switches the mechanism off (physical units), or
        ``"vehicle"``: the vehicle file's own value.
    starts : starting guesses, each field -> value or a rule (:func:`starting_guesses`).
    report : field -> name of the parameter in the discovery's report (``depth_m``).
    text : the one-sentence explanation when there is no mechanism class.
    priors : callable(vehicle) -> {``effect.field``: (value, sigma)}: what is known of its
        parameters before any fit (``identify.fitting.fit``'s ``priors``), or None.
    typical : callable(vehicle) -> {``effect.field``: value}: typical values a start may use
        (``"typical"`` in ``starts``), or None.
    evidence : callable(fit, vehicle, window_ms) -> (reason, evidence) checking what the
        mechanism implies for a channel measured directly (``identify.evidence``), or None.
    """

    effect: str
    mechanism: type | None
    parameters: tuple[FreeParameter, ...]
    neutral: dict[str, float | str]
    starts: tuple[dict[str, float], ...]
    report: dict[str, str]
    text: str = ""
    priors: object = None
    evidence: object = None
    typical: object = None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def explanation(self) -> str:
        return self.mechanism.explanation if self.mechanism is not None else self.text


def _p(effect, field, unit, transform, **kw):
    return FreeParameter(f"{effect}.{field}", unit, transform, **kw)


CANDIDATES: tuple[Candidate, ...] = (
    Candidate(
        "front_wheel_block", FrontWheelBlock,
        (_p("front_wheel_block", "depth", "m", "logit", lower=0.05, upper=1.2),),
        {"depth": NEVER_REACHED},
        ({"depth": "wheel_window"},),
        {"depth": "depth_m"},
        evidence=front_wheels_blocked,
    ),
    Candidate(
        "stiffness_zone", StiffnessZone,
        (_p("stiffness_zone", "depth", "m", "logit", lower=0.05, upper=1.2),
         _p("stiffness_zone", "k_zone", "N/m^3", "log", scale=1e6)),
        {"depth": NEVER_REACHED, "k_zone": 1e6},
        ({"depth": "half_crush", "k_zone": 2.0},),
        {"depth": "depth_m", "k_zone": "k_zone"},
    ),
    Candidate(
        "progressive_stiffness", ProgressiveStiffness,
        (_p("progressive_stiffness", "progression", "1/m", "tanh", scale=5.0),),
        {"progression": 0.0},
        ({"progression": 0.0},),
        {"progression": "progression_per_m"},
    ),
    Candidate(
        "rate_dependence", RateDependence,
        (_p("rate_dependence", "rate_coefficient", "s/m", "tanh", scale=0.1),),
        {"rate_coefficient": 0.0},
        ({"rate_coefficient": 0.0},),
        {"rate_coefficient": "rate_coefficient_s_per_m"},
    ),
    Candidate(
        "rear_axle_lift", None,
        (_p("rear_axle_lift", "rear_axle_stiffness", "N/m", "log", scale=1e5),),
        {"rear_axle_stiffness": "vehicle"},
        ({"rear_axle_stiffness": "vehicle"},),
        {"rear_axle_stiffness": "rear_axle_stiffness_N_per_m"},
        "The force below the centre of gravity tips the car forward and the rear axle lifts off "
        "after a suspension travel the vehicle file does not give (its rear spring is stiffer or "
        "softer than assumed), so the rear rises, leaves the ground and lands at other times.",
    ),
)

ENGINE_MASS_FRACTION = 0.13  # of the test mass, when the vehicle file gives no engine_mass
ENGINE_GAP_M = 0.35  # m, when the vehicle file gives no engine_gap
ENGINE_MASS_REL_SIGMA = 0.3
ENGINE_GAP_SIGMA_M = 0.1


def engine_typical(vehicle) -> dict[str, float]:
    """Where the engine fit starts: the vehicle file's engine mass and gap, else 13 % of the
    mass and 0.35 m."""
    mass = vehicle.engine_mass if vehicle.engine_mass is not None else ENGINE_MASS_FRACTION * float(vehicle.mass)
    gap = vehicle.engine_gap if vehicle.engine_gap is not None else ENGINE_GAP_M
    return {"engine_impact.engine_mass": float(mass), "engine_impact.gap": float(gap)}


def engine_priors(vehicle) -> dict[str, tuple[float, float]]:
    """What is known of the engine before the fit (``data/README.md``): its mass, the vehicle
    file's or else 13 % of the car's (engines and gearboxes weigh 10-20 %), +-30 %; its gap
    only when the vehicle file states it (+-0.1 m). A typical gap is no measurement: it would
    pull the fit of a car whose engine never reaches the barrier towards one that does."""
    typical = engine_typical(vehicle)
    mass = typical["engine_impact.engine_mass"]
    out = {"engine_impact.engine_mass": (mass, ENGINE_MASS_REL_SIGMA * mass)}
    if vehicle.engine_gap is not None:
        out["engine_impact.gap"] = (float(vehicle.engine_gap), ENGINE_GAP_SIGMA_M)
    return out


CANDIDATES = CANDIDATES + (
    Candidate(
        "engine_impact", EngineImpact,
        (_p("engine_impact", "engine_mass", "kg", "logit", lower=20.0, upper=700.0),
         _p("engine_impact", "gap", "m", "logit", lower=0.05, upper=1.2),
         _p("engine_impact", "k_engine", "N/m", "log", scale=1e6),
         _p("engine_impact", "k_rear", "N/m", "log", scale=1e6)),
        {"engine_mass": 0.0, "gap": NEVER_REACHED, "k_engine": 3e6, "k_rear": 1e6, "restitution_engine": 0.1,
         "mount_stiffness": 8e5, "mount_break_force": 5e4},
        ({"engine_mass": "typical", "gap": "typical", "k_engine": 3e6, "k_rear": 1e6},),
        {"engine_mass": "engine_mass_kg", "gap": "gap_m", "k_engine": "k_engine_N_per_m",
         "k_rear": "k_rear_N_per_m"},
        priors=engine_priors,
        typical=engine_typical,
    ),
)

BY_EFFECT = {c.effect: c for c in CANDIDATES}


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


def superset_spec(base_names) -> tuple[FreeParameter, ...]:
    """The base parameters named in ``base_names`` (a base fit's ``names``, in the model's
    order) followed by every candidate's parameters: the compiled fit's parameter vector."""
    base = tuple(p for p in base_parameters() if p.name in set(base_names))
    return base + tuple(p for c in CANDIDATES for p in c.parameters)


def neutral_values(vehicle) -> dict[str, float]:
    """``effect.field`` -> the value that switches the mechanism off, for every candidate."""
    from identify.model import VEHICLE_OVERRIDES

    out = {}
    for c in CANDIDATES:
        for name in c.names:
            v = c.neutral[name.split(".", 1)[1]]
            if v == "vehicle":
                field, index = VEHICLE_OVERRIDES[name]
                v = np.asarray(getattr(vehicle, field))[index]
            out[name] = float(v)
    return out


def held_for(active, vehicle) -> dict[str, float]:
    """The held values when the candidates named in ``active`` are fitted: all others off."""
    active = set(active)
    return {k: v for k, v in neutral_values(vehicle).items() if k.split(".", 1)[0] not in active}


def starting_guesses(candidate: Candidate, fr, vehicle, analysis=None) -> list[dict[str, float]]:
    """The candidate's starting guesses in physical units (``effect.field`` -> value).

    Rules: ``k_zone`` is a factor of the current k_compression; ``"half_crush"`` is half the
    current model's maximum crush; ``"wheel_window"`` the current model's crush where the
    strongest misfit window of the front wheel angle starts (the wheels stop turning
    there), else where the crush reaches the tyre (front overhang minus wheel radius);
    ``"typical"`` the candidate's typical value (:func:`engine_typical`).
    """
    from identify.residuals import model_crush

    out = []
    for start in candidate.starts:
        guess = {}
        for field, value in start.items():
            if value == "wheel_window":
                value = float(vehicle.front_overhang - vehicle.wheel_radius)
                windows = [w for w in (analysis.windows if analysis is not None else [])
                           if w.channel == "front_wheel_angle_rad" and w.start_ms > 0]
                if windows:
                    crush = float(model_crush(fr, np.array([windows[0].start_ms / 1e3]))[0])
                    if crush > 0.05:
                        value = crush
            elif value == "vehicle":
                value = neutral_values(vehicle)[f"{candidate.effect}.{field}"]
            elif value == "typical":
                value = candidate.typical(vehicle)[f"{candidate.effect}.{field}"]
            elif value == "half_crush":
                value = 0.5 * float(np.max(np.asarray(fr.trajectory.crush)))
            elif field == "k_zone":
                value = float(value) * float(fr.params.k_compression)
            guess[f"{candidate.effect}.{field}"] = float(value)
        out.append(guess)
    return out


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
