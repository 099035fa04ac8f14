"""The rear wheels leaving the ground after another suspension travel than the vehicle
file's: this candidate changes the vehicle (its rear axle's stiffness, with the force
plane dz' below the CG that lifts the rear) instead of adding a mechanism. It starts at,
and is no finding within 3 standard deviations of, the vehicle file's stiffness; it acts
where the rear axle's contact margin is negative."""

from __future__ import annotations

import numpy as np

from identify.candidates.base import Candidate, parameter
from identify.model import VEHICLE_OVERRIDES

NAME = "rear_axle_lift.rear_axle_stiffness"


def vehicle_file_stiffness(fr, vehicle, analysis=None) -> float:
    """N/m: the vehicle file's rear axle stiffness."""
    field, index = VEHICLE_OVERRIDES[NAME]
    return float(np.asarray(getattr(vehicle, field))[index])


def same_as_vehicle_file(fr, vehicle) -> str:
    if abs(fr.values[NAME] - vehicle_file_stiffness(fr, vehicle)) < 3 * fr.std[NAME]:
        return "the rear axle's stiffness does not differ from the vehicle file's"
    return ""


CANDIDATE = Candidate(
    "rear_axle_lift", None,
    (parameter("rear_axle_lift", "rear_axle_stiffness", "N/m", "log", scale=1e5),),
    {"rear_axle_stiffness": "vehicle"},
    ({"rear_axle_stiffness": vehicle_file_stiffness},),
    {"rear_axle_stiffness": "rear_axle_stiffness_N_per_m"},
    "The force below the centre of gravity tips the car forward and the rear axle lifts off "
    "after a suspension travel the vehicle file does not give (its rear spring is stiffer or "
    "softer than assumed), so the rear rises, leaves the ground and lands at other times.",
    active=lambda fr: np.asarray(fr.trajectory.rear_margin) < 0.0,
    implausible=same_as_vehicle_file,
)
