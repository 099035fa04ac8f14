"""The engine as a second mass that reaches the barrier after a gap (``sim.mechanisms.EngineImpact``),
shared with the two-body base model when a recording measures the engine's own motion.

Every car has an engine on mounts, so the base model has one too (``Candidate.in_base``): of
the vehicle file's engine mass (else 13 % of the car's), on typical mounts (0.8 MN/m, letting
go at 25 g), never reaching the barrier. It lags the cabin at first, which a rigid car does
not: on reference-world films (engines of 10-20 % on 0.5-1.2 MN/m mounts) a rigid model fitted
the contact 2-4.5 ms early and k_compression 10-17 % low to the same motion. Discovery's
candidate is the engine reaching the barrier.
What is known of it before a fit (its mass; its gap when the vehicle file gives one) enters
as priors; it is no finding when the engine never reaches the barrier in the recorded crash,
and a measured engine that never reaches it leaves its gap and block stiffness not identified.
A fit starts at the typical gap and where the current fit's engine just reaches the barrier;
a measured engine's also out of the barrier's reach (a candidate that never reaches it is no
finding, so discovery does not try that start). Discovery tries each gap twice: with the
mounts letting go at the typical force, and with mounts that hold (:data:`MOUNTS_HOLD_N`).
Whether the mounts let go is a switch the recording's motion cannot be walked across: the
break is latched, and near its force a fit's misfit jumps back and forth with the engine's
parameters (on development world 960016, an engine that hit the barrier and whose mounts
held, gaps 0, 1 and 3 mm longer gave x chi-squares of 486, 10,188 and 970, the mounts'
latched break at 9, 6 and 2 %), so a fit started on the wrong side of it stops in a poor minimum.
On that world's true motion (no film; x and pitch, 0.3 mm of noise), fitted from gaps of 0.6,
0.7 and 0.8 of the crush: with the typical break, x RMS 1.0-21 mm against the base model's
1.7; with mounts that hold, 0.35 mm from each start and k_compression within 1 % (the base
model's +22 %). On 960007, whose mounts let go at 36 ms, the other way round: 0.38 and 0.48 mm
from two of the three starts with the typical break, 6.0-6.4 mm with mounts that hold.
An engine the recording measures keeps the base model's break (``fixed_when_measured``).
"""

from __future__ import annotations

import numpy as np

from identify.discover.candidates.base import NEVER_REACHED, Candidate, parameter
from sim import EngineImpact

ENGINE_MASS_FRACTION = 0.13  # of the test mass, when the vehicle file gives no engine_mass
ENGINE_GAP_M = 0.35  # m, when the vehicle file gives no engine_gap
ENGINE_MASS_REL_SIGMA = 0.3
ENGINE_GAP_SIGMA_M = 0.1
GAP_OUT_OF_REACH_M = 1.15  # m, a measured engine's second start: beyond any crash test's crush (near the range's top)
# N, mounts that hold: 100 times the scale of the break force's fit, beyond any force the mounts
# carry (about 0.1 MN when the engine is stopped by the barrier), where the latched break's
# logistic is below 1e-20 and a fit started there stays there
MOUNTS_HOLD_N = 5.0e6


def typical_engine_mass(vehicle) -> float:
    """kg, the vehicle file's engine mass, else 13 % of the car's."""
    return float(vehicle.engine_mass if vehicle.engine_mass is not None else ENGINE_MASS_FRACTION * float(vehicle.mass))


def on_its_mounts(vehicle) -> EngineImpact:
    """The base model's engine: of :func:`typical_engine_mass`, on ``EngineImpact.defaults``'
    typical mounts, its gap out of the barrier's reach."""
    return EngineImpact.defaults(typical_engine_mass(vehicle), NEVER_REACHED)


def engine_typical(vehicle) -> dict[str, float]:
    """Where the engine fit starts: the vehicle file's engine mass and gap, else 13 % of the
    mass and 0.35 m."""
    gap = vehicle.engine_gap if vehicle.engine_gap is not None else ENGINE_GAP_M
    return {"engine_impact.engine_mass": typical_engine_mass(vehicle), "engine_impact.gap": float(gap)}


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


def reaches_the_barrier(fr) -> bool:
    """Whether the fitted engine carries any barrier force in the recorded crash."""
    return float(np.max(np.asarray(fr.trajectory.engine_force))) > 0.0


def mounts_let_go(fr) -> bool:
    """Whether the fitted engine's mounts let go (half broken or more) in the recorded crash."""
    return float(np.max(np.asarray(fr.trajectory.mounts_broken))) >= 0.5


def unseen(fr) -> dict[str, str]:
    """The engine's parameters the fitted crash cannot show: its barrier parameters when it
    never touched the barrier (the gap is then only known to exceed how far the engine came,
    its largest travel, m; the block's stiffness is not seen at all), and the mounts' break
    force when they never let go (only known to exceed what they carried)."""
    out = {}
    if not mounts_let_go(fr):
        out["engine_impact.mount_break_force"] = (
            "not identified: the mounts never let go in the recorded crash; their strength is only known to exceed"
            " the force they carried")
    if reaches_the_barrier(fr):
        return out
    reached = float(np.max(np.asarray(fr.trajectory.engine_x)))
    why = "not identified: the engine never reached the barrier in the recorded crash"
    return {**out, "engine_impact.gap": f"{why}; its gap is only known to exceed the {reached:.3f} m it travelled",
            "engine_impact.k_engine": why}


TYPICAL_START = {"engine_mass": lambda fr, vehicle, analysis: engine_typical(vehicle)["engine_impact.engine_mass"],
                 "gap": lambda fr, vehicle, analysis: engine_typical(vehicle)["engine_impact.gap"],
                 "k_engine": 3e6, "k_rear": 1e6, "stop_forward": 0.05,
                 "mount_break_force": lambda fr, vehicle, analysis: float(on_its_mounts(vehicle).mount_break_force)}


def just_reaching(fr, vehicle, analysis=None) -> float:
    """m: a gap the current fit's engine just reaches (1 cm short of the farthest it came),
    else the typical gap. A fit from there starts next to the current model, the engine
    touching the barrier lightly at the largest crush, and moves only as far as the recording
    asks; from the typical gap alone, the engine's fit ended worse than the model without it
    on 2 of 4 development worlds (BIC +958 on a clean one, +41,000 on one whose engine hit),
    and the recording was not asked."""
    if fr is None or fr.trajectory is None:
        return engine_typical(vehicle)["engine_impact.gap"]
    return float(np.clip(np.max(np.asarray(fr.trajectory.engine_x)) - 0.01, 0.06, 1.15))


def never_reaches_the_barrier(fr, vehicle) -> str:
    if not reaches_the_barrier(fr):
        return "the engine never reaches the barrier in the recorded crash"
    return ""


CANDIDATE = Candidate(
    "engine_impact", EngineImpact,
    (parameter("engine_impact", "engine_mass", "kg", "logit", lower=20.0, upper=700.0),
     parameter("engine_impact", "gap", "m", "logit", lower=0.05, upper=1.2),
     parameter("engine_impact", "k_engine", "N/m", "log", scale=1e6),
     parameter("engine_impact", "k_rear", "N/m", "log", scale=1e6),
     parameter("engine_impact", "stop_forward", "m", "logit", lower=0.01, upper=0.6),
     parameter("engine_impact", "mount_break_force", "N", "log", scale=5e4)),
    # the base model's engine: EngineImpact.defaults' typical mounts and block, never reaching the barrier
    {field: (lambda vehicle, field=field: float(getattr(on_its_mounts(vehicle), field))) for field in EngineImpact.units},
    tuple({**TYPICAL_START, **gap, **mounts} for mounts in ({}, {"mount_break_force": MOUNTS_HOLD_N})
          for gap in ({}, {"gap": just_reaching})),
    {"engine_mass": "engine_mass_kg", "gap": "gap_m", "k_engine": "k_engine_N_per_m",
     "k_rear": "k_rear_N_per_m", "stop_forward": "stop_forward_m", "mount_break_force": "mount_break_force_N"},
    priors=engine_priors,
    implausible=never_reaches_the_barrier,
    unseen=unseen,
    measured_starts=({**TYPICAL_START, "gap": GAP_OUT_OF_REACH_M},),
    fixed_when_measured=("mount_break_force",),
    in_base=("Every car has an engine on mounts, which lags the cabin when the crash begins: the base model"
             " holds one (the vehicle file's engine mass, else 13 % of the car's, on typical mounts),"
             " assumed, not fitted, that never reaches the barrier (discovery's engine_impact is one that does)."),
)
