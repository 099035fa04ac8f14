"""The rear wheels leaving the ground after another suspension travel than the vehicle
file's: this candidate changes the vehicle (its rear axle's stiffness, with the force
plane dz' below the CG that lifts the rear) instead of adding a mechanism. It starts at,
and is no finding within 3 standard deviations of, the vehicle file's stiffness; it acts
where the rear axle's contact margin is negative.

Evidence: where the film tracks the rear hub, its height above the path it rolled along
(``rear_wheel_height_m``, the video stage's) must rise as the fitted model lifts the rear
wheels; a hub seen staying on the ground refutes the lift.

The base model lifts the rear wheels by itself when the contact force acts far enough below
the centre of gravity (``Candidate.shown_in_base``): on 86 reference-world films (scored,
development and calibration) the fitted model lifted them on exactly the 8 whose world
lifted them (each lift within 6.1 ms of the truth), and on none of the other 78. The
candidate (a different rear spring) is what that leaves out.
"""

from __future__ import annotations

import numpy as np

from identify.discover.candidates.base import DECISIVE_CHI2, SEEN, Candidate, parameter, samples_in_window, signal_chi2s
from identify.fitting.model import vehicle_value
from sim.ground import axle_rise, wheel_centre_rise

NAME = "rear_axle_lift.rear_axle_stiffness"
REAR_HEIGHT = "rear_wheel_height_m"


def vehicle_file_stiffness(fr, vehicle, analysis=None) -> float:
    """N/m: the vehicle file's rear axle stiffness."""
    return vehicle_value(vehicle, NAME)


def same_as_vehicle_file(fr, vehicle) -> str:
    if abs(fr.values[NAME] - vehicle_file_stiffness(fr, vehicle)) < 3 * fr.std[NAME]:
        return "the rear axle's stiffness does not differ from the vehicle file's"
    return ""


def rear_wheel_centre_rise(fr, vehicle) -> np.ndarray:
    """m, per sample of ``fr.trajectory``: how far the model's rear wheel centre stands above
    the floor (``sim.ground.wheel_centre_rise`` of the rear axle point, as a film's hub
    target shows it). (The model's ``rear_lift``, the axle point's rise above its static
    deflection, stays 0 while the damper, not the spring, lets go: set against it, the
    bundled sample's hub, the model's own film, rose 472 mm where it rose 412 mm,
    chi-square 2.7 million over 261 samples; 121 against this.)"""
    tr = fr.trajectory
    return np.asarray(wheel_centre_rise(axle_rise(tr.z, tr.pitch, vehicle)[:, 1], np.asarray(tr.rear_margin)))


def rear_wheels_lifted(fr, vehicle, window_ms) -> tuple[str, str]:
    """The measured rear hub height in the window set against the fitted model's rear wheel
    centre (:func:`rear_wheel_centre_rise`) and against staying on the ground (each about its own
    constant, fitted): the lift is refuted when the ground fits better by more than
    ``DECISIVE_CHI2``, and seen only where the lift fits better by that much; where the two
    cannot be told apart by that much, or no hub is tracked, the lift is inferred from the
    body's motion, not seen."""
    m = fr.measurement
    ok, span = samples_in_window(fr, REAR_HEIGHT, window_ms)
    if ok.sum() < 3:
        return "", f"inferred, not seen: the recording does not show the rear hub's height in {span}"
    sigma = np.asarray(m.sigma[REAR_HEIGHT])[ok]
    model_t = np.asarray(m.t)[ok] - fr.contact_time
    lift = np.interp(model_t, np.asarray(fr.trajectory.t), rear_wheel_centre_rise(fr, vehicle))  # m
    height = np.asarray(m.channels[REAR_HEIGHT])[ok]
    separable, grounded, lifted = signal_chi2s(height, lift, sigma)
    if separable < DECISIVE_CHI2:
        return "", (f"inferred, not seen: the model lifts the rear wheels by {1e3 * np.ptp(lift):.0f} mm in {span},"
                    f" which the hub height (sigma {1e3 * np.median(sigma):.0f} mm) cannot tell from the ground")
    if lifted - grounded > DECISIVE_CHI2:
        return (f"the recording shows the rear hub on the ground in {span} (it rose {1e3 * np.ptp(height):.0f} mm;"
                f" the candidate lifts it {1e3 * np.ptp(lift):.0f} mm: chi2 {lifted:.0f} lifted against"
                f" {grounded:.0f} on the ground)"), ""
    if grounded - lifted < DECISIVE_CHI2:
        return "", (f"inferred, not seen: the rear hub's height in {span} fits the model's lift and the ground alike"
                    f" (chi2 {lifted:.0f} lifted against {grounded:.0f} on the ground)")
    return "", (SEEN + f"the rear hub rises with the model's lift in {span} (it rose {1e3 * np.ptp(height):.0f} mm, the"
                f" model lifts it {1e3 * np.ptp(lift):.0f} mm; chi2 {lifted:.0f} lifted against {grounded:.0f} on the"
                f" ground, over {int(ok.sum())} samples)")


CANDIDATE = Candidate(
    "rear_axle_lift", None,
    (parameter("rear_axle_lift", "rear_axle_stiffness", "N/m", "log", scale=1e5),),
    {"rear_axle_stiffness": "vehicle"},
    ({"rear_axle_stiffness": vehicle_file_stiffness},),
    {"rear_axle_stiffness": "rear_axle_stiffness_N_per_m"},
    "The force below the centre of gravity tips the car forward and the rear axle lifts off "
    "after a suspension travel the vehicle file does not give (its rear spring is stiffer or "
    "softer than assumed), so the rear rises, leaves the ground and lands at other times.",
    evidence=rear_wheels_lifted,
    active=lambda fr: np.asarray(fr.trajectory.rear_margin) < 0.0,
    implausible=same_as_vehicle_file,
    shown_in_base="The contact force acts below the centre of gravity (at the fitted dz_contact), so it tips the car "
                  "nose-down and lifts the rear wheels off the ground: the base model, with the vehicle file's rear "
                  "axle, lifts them by itself.",
)
