"""Evidence checks: what a candidate mechanism implies for a channel the recording measures
directly, set against what that channel shows. A candidate's fit can lower the chi-square
where no channel can refute it (blocked wheels while the car stands still at maximum
crush); these checks refuse it there, refuse it where the channel contradicts it, and say
when the claim is only inferred from the body's motion.

Each check takes the candidate's fit (``identify.fitting.FitResult``), the vehicle and the
window (ms, measurement clock) where the fitted mechanism acts, and returns
``(reason, evidence)``: ``reason`` is '' when the candidate may stand, else why not;
``evidence`` is one line for the report ("seen: ...", "inferred, not seen: ...").
"""

from __future__ import annotations

import numpy as np

FRONT_ANGLE = "front_wheel_angle_rad"
DECISIVE_CHI2 = 9.0  # a chi-square difference of 9: three standard deviations


def front_wheels_blocked(fr, vehicle, window_ms) -> tuple[str, str]:
    """Blocked front wheels stand still while the car moves; rolling ones turn by the body's
    displacement over the wheel radius. The measured front wheel angle in the window is set
    against both (each with its own constant offset, fitted): the claim stands only when the
    two differ by more than ``DECISIVE_CHI2`` over the window (else no channel can check it)
    and standing still does not fit worse than rolling by more than that.
    """
    m = fr.measurement
    t_ms = np.asarray(m.t) * 1e3
    inside = (t_ms >= window_ms[0]) & (t_ms <= window_ms[1])
    span = f"{window_ms[0]:.0f}-{window_ms[1]:.0f} ms"
    ok = inside & m.valid(FRONT_ANGLE) if FRONT_ANGLE in m.channels else np.zeros_like(inside)
    if ok.sum() < 3:
        return "", f"inferred, not seen: the recording does not show the front wheels in {span}"
    sigma = np.asarray(m.sigma[FRONT_ANGLE])[ok]
    rolling = np.asarray(fr.predictions["x_m"])[ok] / float(vehicle.wheel_radius)  # rad, up to a constant
    angle = np.asarray(m.channels[FRONT_ANGLE])[ok]

    def chi2_about_a_constant(r):
        w = 1.0 / sigma**2
        return float(np.sum(w * (r - np.sum(w * r) / np.sum(w)) ** 2))

    separable = chi2_about_a_constant(rolling)  # what telling rolling from blocked is worth here
    if separable < DECISIVE_CHI2:
        return (f"the front wheels would be blocked only where the car barely moves ({span}): rolling would turn "
                f"them by {np.ptp(rolling):.3f} rad, which the hub angle (sigma {np.median(sigma):.3f} rad) cannot "
                "tell from standing still, so no channel can check it"), ""
    blocked, turning = chi2_about_a_constant(angle), chi2_about_a_constant(angle - rolling)
    if blocked - turning > DECISIVE_CHI2:
        return (f"the recording shows the front wheels turning in {span} (turned {np.ptp(angle):.2f} rad; rolling "
                f"{np.ptp(rolling):.2f} rad), where the candidate has them blocked (chi2 {blocked:.0f} standing "
                f"against {turning:.0f} rolling)"), ""
    return "", (f"seen: the front hub angle stands still in {span} (chi2 {blocked:.0f} standing against "
                f"{turning:.0f} rolling, over {int(ok.sum())} samples)")
