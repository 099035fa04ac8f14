"""A loading force that grows with the crush rate (``sim.mechanisms.RateDependence``). Its
coefficient 0 switches it off (a fit that cannot tell it from 0 is no finding) and a
negative one, a structure softer when crushed fast, is not physical."""

from __future__ import annotations

from identify.discover.candidates.base import Candidate, differs_from_zero, parameter
from sim import RateDependence

NAME = "rate_dependence.rate_coefficient"
#: The coefficient's range, s/m (|c| below it, tanh). A range is the fit's room, not a
#: prior: a structure stiffer by (1 + c v) at v = 15 m/s up to 5.5 times. At 0.1 s/m the
#: fit of development film 960005 ended at the bound, and the candidate was ruled out for it
#: (the reference world draws up to 0.15 s/m).
RANGE_S_PER_M = 0.3


def not_physical_or_zero(fr, vehicle) -> str:
    if fr.values[NAME] <= 0:
        return ("a rate coefficient of 0 or below is no finding: 0 changes nothing, and a negative one (the "
                "structure softer when crushed fast) is not physical")
    return differs_from_zero(fr, NAME)


CANDIDATE = Candidate(
    "rate_dependence", RateDependence,
    (parameter("rate_dependence", "rate_coefficient", "s/m", "tanh", scale=RANGE_S_PER_M),),
    {"rate_coefficient": 0.0},
    ({"rate_coefficient": 0.0},),
    {"rate_coefficient": "rate_coefficient_s_per_m"},
    implausible=not_physical_or_zero,
)
