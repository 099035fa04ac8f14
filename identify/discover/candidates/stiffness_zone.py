"""A zone of different stiffness beyond a crush depth (``sim.mechanisms.StiffnessZone``):
the engine block or a cross member reached. It starts at half the current model's maximum
crush with twice its stiffness, and is no finding when the zone's stiffness does not
differ from the base stiffness."""

from __future__ import annotations

import numpy as np

from identify.discover.candidates.base import NEVER_REACHED, Candidate, parameter
from sim import StiffnessZone


def half_the_crush(fr, vehicle, analysis) -> float:
    """m: half the current model's maximum crush."""
    return 0.5 * float(np.max(np.asarray(fr.trajectory.crush)))


def twice_the_stiffness(fr, vehicle, analysis) -> float:
    """N/m^3: twice the current model's k_compression."""
    return 2.0 * float(fr.params.k_compression)


def same_as_base(fr, vehicle) -> str:
    k0 = fr.values.get("k_compression", float(fr.params.k_compression))
    if abs(fr.values["stiffness_zone.k_zone"] - k0) < 2 * fr.std["stiffness_zone.k_zone"]:
        return "the zone's stiffness does not differ from the base stiffness"
    return ""


CANDIDATE = Candidate(
    "stiffness_zone", StiffnessZone,
    (parameter("stiffness_zone", "depth", "m", "logit", lower=0.05, upper=1.2),
     parameter("stiffness_zone", "k_zone", "N/m^3", "log", scale=1e6)),
    {"depth": NEVER_REACHED, "k_zone": 1e6},
    ({"depth": half_the_crush, "k_zone": twice_the_stiffness},),
    {"depth": "depth_m", "k_zone": "k_zone"},
    implausible=same_as_base,
)
