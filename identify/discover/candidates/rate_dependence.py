"""A loading force that grows with the crush rate (``sim.mechanisms.RateDependence``). Its
coefficient 0 switches it off (a fit that cannot tell it from 0 is no finding) and a
negative one, a structure softer when crushed fast, is not physical."""

from __future__ import annotations

from identify.discover.candidates.base import Candidate, differs_from_zero, parameter
from sim import RateDependence

NAME = "rate_dependence.rate_coefficient"


def not_physical_or_zero(fr, vehicle) -> str:
    if fr.values[NAME] <= 0:
        return ("a rate coefficient of 0 or below is no finding: 0 changes nothing, and a negative one (the "
                "structure softer when crushed fast) is not physical")
    return differs_from_zero(fr, NAME)


CANDIDATE = Candidate(
    "rate_dependence", RateDependence,
    (parameter("rate_dependence", "rate_coefficient", "s/m", "tanh", scale=0.1),),
    {"rate_coefficient": 0.0},
    ({"rate_coefficient": 0.0},),
    {"rate_coefficient": "rate_coefficient_s_per_m"},
    implausible=not_physical_or_zero,
)
