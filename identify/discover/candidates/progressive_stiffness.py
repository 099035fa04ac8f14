"""A loading force that stiffens (or softens) with crush (``sim.mechanisms.ProgressiveStiffness``).
Its progression 0 switches it off: a fit that cannot tell it from 0 is no finding."""

from __future__ import annotations

from identify.discover.candidates.base import Candidate, differs_from_zero, parameter
from sim import ProgressiveStiffness

CANDIDATE = Candidate(
    "progressive_stiffness", ProgressiveStiffness,
    (parameter("progressive_stiffness", "progression", "1/m", "tanh", scale=5.0),),
    {"progression": 0.0},
    ({"progression": 0.0},),
    {"progression": "progression_per_m"},
    implausible=lambda fr, vehicle: differs_from_zero(fr, "progressive_stiffness.progression"),
)
