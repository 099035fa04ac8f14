"""Front wheels blocked by the crushed structure (``sim.mechanisms.FrontWheelBlock``).

Evidence: blocked front wheels stand still while the car moves; rolling ones turn by the
body's displacement over the wheel radius. Where the recording measures the front hub's
angle the claim is set against it; a blocking window where the car barely moves (around
maximum crush) is no finding, since no channel can check it there.
"""

from __future__ import annotations

import numpy as np

from identify.discover.candidates.base import (DECISIVE_CHI2, NEVER_REACHED, SEEN, Candidate, parameter, samples_in_window,
                                      signal_chi2s)
from sim import FrontWheelBlock

FRONT_ANGLE = "front_wheel_angle_rad"


def wheels_stop_turning(fr, vehicle, analysis) -> float:
    """Starting depth (m): the current model's crush where the strongest misfit window of the
    front wheel angle starts (the wheels stop turning there), else where the crush reaches
    the tyre (front overhang minus wheel radius)."""
    from identify.fitting.residuals import model_crush

    depth = float(vehicle.front_overhang - vehicle.wheel_radius)
    windows = [w for w in (analysis.windows if analysis is not None else [])
               if w.channel == FRONT_ANGLE and w.start_ms > 0]
    if windows and fr is not None:
        crush = float(model_crush(fr, np.array([windows[0].start_ms / 1e3]))[0])
        if crush > 0.05:
            depth = crush
    return depth


def where_seen_blocked(fr, vehicle, analysis) -> float:
    """Starting depth (m): the current model's crush when the recording saw the front wheels
    blocked (``Measurement.events_ms["front_wheel_block"]``: the film's hub angle stopped
    turning), else as :func:`wheels_stop_turning`. A start beyond the crush the model reaches
    never blocks the wheels, so no step of the fit moves it (development world 960003: from
    0.55 m, the misfit window's rule, the fit stayed there, BIC +4.2; the film saw the block)."""
    from identify.fitting.residuals import model_crush

    seen = (fr.measurement.events_ms or {}).get("front_wheel_block") if fr is not None else None
    if seen is not None and np.isfinite(seen):
        crush = float(model_crush(fr, np.array([seen / 1e3]))[0])
        if crush > 0.05:
            return crush
    return wheels_stop_turning(fr, vehicle, analysis)


def front_wheels_blocked(fr, vehicle, window_ms) -> tuple[str, str]:
    """The measured front wheel angle in the window set against standing still and against
    rolling (each with its own constant offset, fitted): the claim stands only when the two
    differ by more than ``DECISIVE_CHI2`` over the window (else no channel can check it) and
    standing still does not fit worse than rolling by more than that. It is seen only where
    standing still fits better than rolling by that much; between the two the hub angle does
    not decide, and the claim is inferred.
    """
    m = fr.measurement
    ok, span = samples_in_window(fr, FRONT_ANGLE, window_ms)
    if ok.sum() < 3:
        return "", f"inferred, not seen: the recording does not show the front wheels in {span}"
    sigma = np.asarray(m.sigma[FRONT_ANGLE])[ok]
    rolling = np.asarray(fr.predictions["x_m"])[ok] / float(vehicle.wheel_radius)  # rad, up to a constant
    angle = np.asarray(m.channels[FRONT_ANGLE])[ok]
    separable, blocked, turning = signal_chi2s(angle, rolling, sigma)  # standing still, or rolling
    if separable < DECISIVE_CHI2:
        return (f"the front wheels would be blocked only where the car barely moves ({span}): rolling would turn "
                f"them by {np.ptp(rolling):.3f} rad, which the hub angle (sigma {np.median(sigma):.3f} rad) cannot "
                "tell from standing still, so no channel can check it"), ""
    if blocked - turning > DECISIVE_CHI2:
        return (f"the recording shows the front wheels turning in {span} (turned {np.ptp(angle):.2f} rad; rolling "
                f"{np.ptp(rolling):.2f} rad), where the candidate has them blocked (chi2 {blocked:.0f} standing "
                f"against {turning:.0f} rolling)"), ""
    if turning - blocked < DECISIVE_CHI2:
        return "", (f"inferred, not seen: the front hub angle in {span} fits standing still and rolling alike (chi2 "
                    f"{blocked:.0f} standing against {turning:.0f} rolling)")
    return "", (SEEN + f"the front hub angle stands still in {span} (chi2 {blocked:.0f} standing against "
                f"{turning:.0f} rolling, over {int(ok.sum())} samples)")


CANDIDATE = Candidate(
    "front_wheel_block", FrontWheelBlock,
    (parameter("front_wheel_block", "depth", "m", "logit", lower=0.05, upper=1.2),),
    {"depth": NEVER_REACHED},
    ({"depth": wheels_stop_turning}, {"depth": where_seen_blocked}),
    {"depth": "depth_m"},
    evidence=front_wheels_blocked,
    active=lambda fr: np.asarray(fr.trajectory.front_blocked) > 0.5,
)
