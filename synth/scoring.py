"""Scoring a measurement against a reference world's truth (pure functions of arrays and
names, shared by the accuracy benchmark and the tests)."""

from __future__ import annotations

import math

import numpy as np


def tracking_errors(x_measured, contact_frame: int, truth: dict, max_shift_s: float = 1e-3,
                    window_s: tuple[float, float] = (-0.015, 0.250),
                    contact_time_s: float | None = None) -> dict:
    """Body-x error of a tracked film against its truth, frame for frame.

    Measured x is the CG displacement from where it was at the *measured* contact frame;
    the truth's from the true first contact. Frame i's measured x is compared with
    ``x_true(t_i + s) - x_true(t_c + s)`` (t_c the measured contact frame's true time),
    ``s`` the best shift within ``max_shift_s`` (sub-frame timing of the film).

    Parameters
    ----------
    x_measured : (n,) float
        Measured x per film frame, m (NaN where not measured).
    contact_frame : int
        The frame the measurement calls first contact.
    truth : dict
        A world's truth (``series`` with ``t_ms`` and ``x_m`` per frame, ``fps``).
    max_shift_s : float
        Largest time shift tried, s.
    window_s : (float, float)
        True-time window scored, s.
    contact_time_s : float, optional
        The measured first contact to a fraction of a frame, s after frame 0 (the contact
        frame's time plus the tracker's sub-frame offset): what the fit is given.

    Returns
    -------
    dict
        ``x_rms_mm`` (None when fewer than 10 frames were measured), ``shift_ms``,
        ``measured_share`` (frames of the window with an x), ``video_contact_err_ms``
        (measured contact frame minus the frame nearest the true contact, in ms: a label
        rounded to whole frames) and, with ``contact_time_s``, ``video_contact_time_err_ms``
        (measured contact time minus the true one, ms).
    """
    tt = np.asarray(truth["series"]["t_ms"], dtype=float) / 1e3
    xt = np.asarray(truth["series"]["x_m"], dtype=float)
    c_true = int(np.argmin(np.abs(tt)))
    xm = np.asarray(x_measured, dtype=float)
    n = min(xm.size, tt.size)
    xm, tf = xm[:n], tt[:n]
    c_meas = int(contact_frame)
    window = (tf >= window_s[0]) & (tf <= window_s[1])
    ok = window & np.isfinite(xm)
    out = {"x_rms_mm": None, "shift_ms": None,
           "measured_share": float(np.mean(np.isfinite(xm[window]))) if window.any() else float("nan"),
           "video_contact_err_ms": (c_meas - c_true) / float(truth["fps"]) * 1e3}
    if contact_time_s is not None:  # the truth's frame 0 stands -tt[0] s before contact
        out["video_contact_time_err_ms"] = (float(contact_time_s) + float(tt[0])) * 1e3
    if ok.sum() < 10 or not 0 <= c_meas < n:
        return out
    best = (math.inf, 0.0)
    for s in np.linspace(-max_shift_s, max_shift_s, 41):
        ref = np.interp(tf + s, tt, xt) - np.interp(tf[c_meas] + s, tt, xt)
        best = min(best, (float(np.sqrt(np.mean((xm[ok] - ref[ok]) ** 2))), float(s)))
    out.update(x_rms_mm=1e3 * best[0], shift_ms=1e3 * best[1])
    return out


def judge_discoveries(found: list[str], truth_effects: list[str]) -> str:
    """What discovery said against what the world concealed.

    Returns
    -------
    str
        ``right`` (a concealed effect named, nothing else), ``wrong`` (only effects the
        world does not have), ``right+wrong``, ``unexplained`` (no name, a misfit
        reported as unexplained) or ``none``.
    """
    named = [f for f in found if f != "unexplained"]
    right = any(f in truth_effects for f in named)
    wrong = any(f not in truth_effects for f in named)
    if right and wrong:
        return "right+wrong"
    if right:
        return "right"
    if wrong:
        return "wrong"
    return "unexplained" if "unexplained" in found else "none"
