"""The camera's map from the car's own approach: lens distortion and a camera turned
against the car's plane, from the targets' tracks before contact.

Before contact the car rolls level at a constant speed: every target on it (the passenger
cell's, the hubs' centres) moves along a straight line in the car's plane, the same
distance each frame, all of them together. Through a lens with radial distortion and a
camera yawed or pitched against that plane the picture bends and stretches those tracks:
a barrel lens shrinks a metre of travel towards the picture's edges, a yaw shrinks it
towards the far side, a pitch shrinks it above (or below) the centre row, so targets at
different heights cross the picture at different pixel speeds. The map that makes the
tracks parallel, straight and evenly spaced in time, alike for every target, is the
camera's (up to one scale and rotation, which the tape or wheelbase and the level
approach take up).

The tapes measure the same map from one frame (straightness, even segments), but only
along their own line and only where they are: a tape across the middle of the picture
does not show a barrel lens (the development films' tapes found k1 insignificant on every
film with k1 = -0.09 to -0.14), and its even segments then read the lens's stretch as a
yaw. A crash moves the cell some 0.3-0.8 m past where the approach and the tape were, and
an uncorrected map there is a length-scale error of the crash's travel (-0.4 to -1.2 % on
the development films) while the impact speed, measured where the tape is, stays right.

Model: :class:`video.calibrate_lens.LensDistortion` with ``k1`` (for its ``radius_px``,
about its ``centre``) and a two-component ``tilt`` (yaw along u, pitch along v); k2 and the
distortion centre are not fitted (the approach covers too little of the picture to tell
them; a principal point a few per cent off the centre is taken up by the tilt to first
order).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import least_squares

from .calibrate_lens import LensDistortion, plausible_k1, undistort_points
from .calibrate_perspective import TILT_PLAUSIBLE

#: Per-sample floor of a target centre's sigma in the fit, px (a tracker's stated sigma of a
#: sharp target can be smaller than its centre's frame-to-frame scatter).
CENTRE_SIGMA_FLOOR_PX = 0.03

#: Fewest approach frames, and targets seen in them, for the map to be fitted.
MIN_FRAMES = 8
MIN_TARGETS = 2


@dataclass(frozen=True)
class MotionMap:
    """What the approach says of the camera's map.

    Attributes
    ----------
    lens : LensDistortion
        The lens given, with ``k1`` and ``tilt`` from the approach when ``used`` (its
        ``k2``, centre and radius unchanged).
    used : bool
        True when the fit was made and is to replace the tapes' map.
    k1, k1_sigma : float
        Fitted radial coefficient and its one-sigma (NaN when not fitted).
    tilt, tilt_sigma : (2,) 1/px
        Fitted tilt and its one-sigma.
    rms_before_px, rms_after_px : float
        RMS of the tracks about a common uniform translation through the tapes' map and
        through the fitted one, px.
    note : str
        One sentence for the user.
    """

    lens: LensDistortion
    used: bool
    k1: float
    k1_sigma: float
    tilt: np.ndarray
    tilt_sigma: np.ndarray
    rms_before_px: float
    rms_after_px: float
    note: str


def _translation_residuals(Q: np.ndarray, ok: np.ndarray, t: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted residuals of points ``Q`` (n, K, 2) (where ``ok``) about ``a_k + v t``: a
    start per target and one velocity for all, fitted by linear least squares."""
    rows = np.argwhere(ok)
    K = Q.shape[1]
    A = np.zeros((len(rows), K + 1))
    A[np.arange(len(rows)), rows[:, 1]] = 1.0
    A[:, K] = t[rows[:, 0]]
    sw = w[ok]
    Aw = A * sw[:, None]
    out = []
    for c in range(2):
        y = Q[:, :, c][ok] * sw
        coef, *_ = np.linalg.lstsq(Aw, y, rcond=None)
        out.append(y - Aw @ coef)
    return np.concatenate(out)


def map_from_approach(uv_raw: np.ndarray, sigma_px: np.ndarray, frames: np.ndarray, targets,
                      lens: LensDistortion) -> MotionMap:
    """Fit ``k1`` and the 2-D tilt that make the targets' approach a common uniform translation.

    Parameters
    ----------
    uv_raw : (n, K, 2) px
        Target centres as recorded (lens distortion in), NaN where not measured.
    sigma_px : (n, K) px
        Their one-sigma.
    frames : (n,) bool
        Frames of the approach (level, constant speed: before contact, no repeated frame
        in between that would shift the clock).
    targets : sequence of int
        The targets that move with the car (body, hub centres).
    lens : LensDistortion
        The tapes' map (or none measured): its centre and radius are kept; it is the
        fallback.

    Returns
    -------
    MotionMap
        ``used`` False (and ``lens`` unchanged) when the approach has too few frames or
        targets, or the fit is implausible for a crash camera.

    A weak prior holds each parameter to zero at a third of what a crash camera plausibly
    has (:func:`video.calibrate_lens.plausible_k1`,
    :data:`video.calibrate_perspective.TILT_PLAUSIBLE`), so a parameter the tracks cannot
    tell stays near zero instead of taking up their noise.
    """
    targets = np.asarray(list(targets), int)
    idx = np.flatnonzero(frames)
    none = MotionMap(lens, False, float("nan"), float("nan"), np.zeros(2), np.full(2, np.nan),
                     float("nan"), float("nan"), "")
    if len(targets) < MIN_TARGETS or len(idx) < MIN_FRAMES:
        return replace(none, note=f"camera map not fitted to the approach: {len(idx)} approach frame(s), "
                                  f"{len(targets)} target(s) on the car ({MIN_FRAMES} and {MIN_TARGETS} needed)")
    P = np.asarray(uv_raw, float)[np.ix_(idx, targets)]
    S = np.asarray(sigma_px, float)[np.ix_(idx, targets)]
    ok = np.all(np.isfinite(P), axis=2) & np.isfinite(S)
    seen = ok.sum(axis=0) >= MIN_FRAMES
    P, S, ok = P[:, seen], S[:, seen], ok[:, seen]
    if P.shape[1] < MIN_TARGETS:
        return replace(none, note="camera map not fitted to the approach: fewer than "
                                  f"{MIN_TARGETS} targets seen in {MIN_FRAMES} approach frames")
    t = (idx - idx[0]).astype(float)
    w = np.where(ok, 1.0 / np.maximum(np.nan_to_num(S, nan=1.0), CENTRE_SIGMA_FLOOR_PX), 0.0)
    flat_ok = ok.reshape(-1)
    c, r0 = lens.centre, lens.radius_px
    corner = float(np.hypot(*(np.asarray(c, float) + 0.5)))
    k1_prior = plausible_k1(r0, c) / 3.0
    tilt_prior = TILT_PLAUSIBLE / corner / 3.0
    scale = np.array([k1_prior, tilt_prior, tilt_prior])

    def mapped(q):
        m = replace(lens, k1=float(q[0]), k2=0.0, tilt=np.array(q[1:3]),
                    corrected=True)
        Q = np.full(P.shape, np.nan)
        flat = P.reshape(-1, 2)
        Q.reshape(-1, 2)[flat_ok] = undistort_points(flat[flat_ok], m)
        return Q

    def residuals(z):
        q = z * scale
        return np.concatenate([_translation_residuals(mapped(q), ok, t, w), z])

    n_obs = 2 * int(ok.sum())
    dof = n_obs - 2 * (P.shape[1] + 1) - 3
    if dof < 5:
        return replace(none, note=f"camera map not fitted to the approach: too few target positions ({n_obs // 2})")
    start = np.array([lens.k1, *lens.tilt]) / scale
    before = _translation_residuals(mapped(np.array([lens.k1, *lens.tilt])), ok, t, w)
    sol = least_squares(residuals, start, diff_step=1e-4)
    data = sol.fun[:-3]
    chi2 = max(float(np.sum(data ** 2)) / dof, 1.0)
    try:
        cov = chi2 * np.linalg.inv(sol.jac.T @ sol.jac)
        sig = np.sqrt(np.diag(cov)) * scale
    except np.linalg.LinAlgError:
        return replace(none, note="camera map not fitted to the approach: the fit is singular")
    q = sol.x * scale
    # the residuals in px (unweighted), for the note
    wts = np.tile(w[ok], 2)
    rms_b = float(np.sqrt(np.mean((before / wts) ** 2)))
    rms_a = float(np.sqrt(np.mean((data / wts) ** 2)))
    k1, tilt = float(q[0]), np.array(q[1:3])
    if abs(k1) > plausible_k1(r0, c) or float(np.hypot(*tilt)) * corner > TILT_PLAUSIBLE:
        return replace(none, k1=k1, k1_sigma=float(sig[0]), tilt=tilt, tilt_sigma=sig[1:3],
                       rms_before_px=rms_b, rms_after_px=rms_a,
                       note=f"camera map from the approach implausible (k1 = {k1:.3g}, tilt {tilt[0]:.3g}, "
                            f"{tilt[1]:.3g} /px): the tapes' map kept")
    new = replace(lens, k1=k1, k2=0.0, k1_sigma=float(sig[0]), k2_sigma=float("nan"), tilt=tilt, corrected=True)
    note = (f"camera map from the approach (the targets' tracks a common uniform translation): k1 = {k1:.3g} "
            f"+- {sig[0]:.2g} (radius {r0:.0f} px), tilt {tilt[0]:.3g} +- {sig[1]:.2g} (yaw), {tilt[1]:.3g} "
            f"+- {sig[2]:.2g} /px (pitch); tracks about a uniform translation {rms_b:.3f} -> {rms_a:.3f} px RMS")
    return MotionMap(new, True, k1, float(sig[0]), tilt, sig[1:3], rms_b, rms_a, note)
