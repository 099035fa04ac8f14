"""Radial lens distortion from the straightness of reference tapes.

Model (Brown, radial terms only, as OpenCV's): an undistorted image point ``p_u`` is seen
at ``p_d = c + (p_u - c) (1 + k1 r^2 + k2 r^4)`` with ``r = |p_u - c| / radius_px``,
``c`` the distortion centre (the image centre unless given) and ``radius_px`` the
normalising radius (the focal length in px when known, so that k1, k2 are OpenCV's;
otherwise half the image diagonal).

Points of a straight tape lie on a straight line once undistorted; k1 (and k2 on request)
is the value that makes them straightest. One tape constrains k1 weakly, and a tape
through the image centre not at all: the estimate comes with its uncertainty and a
verdict on whether it is significant (|k1| > 3 sigma); an insignificant one is not
applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from .calibrate_perspective import rectify, unrectify
from .errors import VideoError


#: Largest radial distortion a crash camera's lens plausibly has at the image's corners (a
#: share of the radius): a k1 the tapes say is larger comes from tapes too short or too near
#: the image centre to show it, not from the lens.
CORNER_DISTORTION_PLAUSIBLE = 0.10


def plausible_k1(radius_px: float, centre: np.ndarray) -> float:
    """The largest |k1| (for ``radius_px``) that distorts the corners of an image centred at
    ``centre`` by :data:`CORNER_DISTORTION_PLAUSIBLE`."""
    corner = float(np.hypot(*(np.asarray(centre, float) + 0.5)))
    return CORNER_DISTORTION_PLAUSIBLE * (radius_px / corner) ** 2


@dataclass(frozen=True)
class LensDistortion:
    """Radial distortion of the camera and how sure we are of it.

    Attributes
    ----------
    k1, k2 : float
        Radial coefficients (dimensionless, for ``radius_px``) that
        :func:`undistort_points` removes: 0 when the distortion is not corrected (the
        insignificant estimate is then in ``note``).
    k1_sigma, k2_sigma : float
        One-sigma uncertainties of the estimate (NaN if not estimated; k2 is 0 with NaN
        sigma when only k1 was fitted).
    centre : (2,) px
        Distortion centre.
    radius_px : float
        Normalising radius, px.
    corrected : bool
        True if the distortion (|k1| > 3 sigma) or the tilt is significant and
        :func:`undistort_points` should be applied; False means "lens distortion not
        corrected".
    rms_before_px, rms_after_px : float
        RMS distance of the tape points from their straight lines before and after the
        correction (the same when not corrected), px.
    note : str
        One sentence for the user.
    tilt : (2,) 1/px
        A camera yawed against the car's plane (:mod:`video.calibrate_perspective`):
        after the radial terms, :func:`undistort_points` maps a point at ``d`` from
        ``centre`` to ``centre + d / (1 - tilt . d)``, square to the car's plane. Zero
        when not measured or not significant.
    """

    k1: float
    k2: float
    k1_sigma: float
    k2_sigma: float
    centre: np.ndarray
    radius_px: float
    corrected: bool
    rms_before_px: float
    rms_after_px: float
    note: str
    tilt: np.ndarray = field(default_factory=lambda: np.zeros(2))


def no_distortion(image_size: tuple[int, int], note: str,
                  radius_px: float | None = None) -> LensDistortion:
    """A lens model that corrects nothing, with the reason in its note.

    Parameters
    ----------
    image_size : (width, height) px
    note : str
        Why the distortion was not estimated.
    radius_px : float, optional
        Normalising radius (default half the diagonal).
    """
    w, h = image_size
    centre = np.array([(w - 1) / 2.0, (h - 1) / 2.0])
    r = float(radius_px) if radius_px else 0.5 * float(np.hypot(w, h))
    return LensDistortion(0.0, 0.0, float("nan"), float("nan"), centre, r, False,
                          float("nan"), float("nan"), note)


def distort_points(points: np.ndarray, lens: LensDistortion) -> np.ndarray:
    """Where undistorted image points are seen through the lens.

    Parameters
    ----------
    points : (N, 2) px, undistorted
    lens : LensDistortion

    Returns
    -------
    (N, 2) px, as recorded by the camera.
    """
    p = np.asarray(points, float)
    if np.any(lens.tilt != 0.0):
        p = unrectify(p, lens.centre, lens.tilt)
    d = p - lens.centre
    r2 = np.sum(d ** 2, axis=-1, keepdims=True) / lens.radius_px ** 2
    return lens.centre + d * (1.0 + lens.k1 * r2 + lens.k2 * r2 ** 2)


def undistort_points(points: np.ndarray, lens: LensDistortion) -> np.ndarray:
    """Remove the lens's radial distortion from image points.

    Parameters
    ----------
    points : (N, 2) px, as recorded (distorted)
    lens : LensDistortion
        From :func:`estimate_lens` (a lens with ``k1 = k2 = 0`` returns the points).

    Returns
    -------
    (N, 2) px
        The points a distortion-free pinhole camera would have recorded, square to the
        car's plane when the lens has a tilt.
    """
    p = np.asarray(points, float)
    tilted = bool(np.any(lens.tilt != 0.0))
    if lens.k1 == 0.0 and lens.k2 == 0.0:
        return rectify(p, lens.centre, lens.tilt) if tilted else p.copy()
    d = p - lens.centre
    u = d.copy()
    for _ in range(50):  # fixed point of u = d / (1 + k1 r(u)^2 + k2 r(u)^4)
        r2 = np.sum(u ** 2, axis=-1, keepdims=True) / lens.radius_px ** 2
        f = 1.0 + lens.k1 * r2 + lens.k2 * r2 ** 2
        if np.any(f <= 0.05):
            raise VideoError("lens distortion too strong to invert at some points "
                             f"(k1={lens.k1:.3g}, k2={lens.k2:.3g}); check the lens estimate")
        nu = d / f
        if np.max(np.abs(nu - u)) < 1e-9:
            u = nu
            break
        u = nu
    return rectify(lens.centre + u, lens.centre, lens.tilt) if tilted else lens.centre + u


def _line_residuals(pts: np.ndarray) -> np.ndarray:
    """Perpendicular distances of points from their total-least-squares line, px."""
    m = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - m, full_matrices=False)
    return (pts - m) @ vt[1]


def estimate_lens(lines: list[np.ndarray], image_size: tuple[int, int], *,
                  radius_px: float | None = None, centre: np.ndarray | None = None,
                  fit_k2: bool = False, min_points: int = 6) -> LensDistortion:
    """Radial distortion that makes points known to be collinear straightest.

    Parameters
    ----------
    lines : list of (n_i, 2) px
        Each array: image points of one straight feature (a tape's segment centres).
    image_size : (width, height) px
    radius_px : float, optional
        Normalising radius (the focal length in px if known; default half the diagonal).
    centre : (2,) px, optional
        Distortion centre (default the image centre).
    fit_k2 : bool
        Fit k2 too (default False: tapes along the car's side rarely reach far enough
        from the centre to tell k2 from k1, and a free k2 then biases k1).
    min_points : int
        Fewest points a line needs to count.

    Returns
    -------
    LensDistortion
        ``corrected`` is True only when |k1| exceeds three times its uncertainty.
    """
    base = no_distortion(image_size, "", radius_px)
    c = base.centre if centre is None else np.asarray(centre, float)
    r0 = base.radius_px
    lines = [np.asarray(p, float) for p in lines if len(p) >= min_points]
    if not lines:
        return no_distortion(image_size, "lens distortion not corrected: no straight tape "
                             f"with {min_points} or more measured points", radius_px)
    n_par = 2 if fit_k2 else 1
    n_pts = sum(len(p) for p in lines)
    dof = n_pts - 2 * len(lines) - n_par
    if dof < 3:
        return no_distortion(image_size, "lens distortion not corrected: too few tape points "
                             f"({n_pts}) to estimate it", radius_px)

    def model(k):
        return LensDistortion(k[0], k[1] if fit_k2 else 0.0, 0, 0, c, r0, True, 0, 0, "")

    def residuals(k):
        lens = model(k)
        return np.concatenate([_line_residuals(undistort_points(p, lens)) for p in lines])

    before = residuals(np.zeros(n_par))
    sol = least_squares(residuals, np.zeros(n_par), x_scale=0.05, diff_step=1e-4)
    res = sol.fun
    s2 = max(np.sum(res ** 2) / dof, 0.02 ** 2)
    try:
        cov = s2 * np.linalg.inv(sol.jac.T @ sol.jac)
        sig = np.sqrt(np.diag(cov))
    except np.linalg.LinAlgError:
        sig = np.full(n_par, np.inf)
    k1, k1s = float(sol.x[0]), float(sig[0])
    k2, k2s = (float(sol.x[1]), float(sig[1])) if fit_k2 else (0.0, float("nan"))
    rms_b = float(np.sqrt(np.mean(before ** 2)))
    rms_a = float(np.sqrt(np.mean(res ** 2)))
    if not np.isfinite(k1s) or k1s > 1.0:
        return LensDistortion(0.0, 0.0, k1s, k2s, c, r0, False, rms_b, rms_b,
                              "lens distortion not corrected: the tape(s) run too close to "
                              "the image centre or are too short to show it "
                              f"(k1 = {k1:.3g} +- {k1s:.2g})")
    if abs(k1) > plausible_k1(r0, c):
        return LensDistortion(0.0, 0.0, k1s, k2s, c, r0, False, rms_b, rms_b,
                              f"lens distortion not corrected: the tapes' k1 = {k1:.3g} +- {k1s:.2g} "
                              f"(radius {r0:.0f} px) would distort the corners by more than "
                              f"{100 * CORNER_DISTORTION_PLAUSIBLE:.0f} %, which a crash camera's lens does not: "
                              "the tape(s) run too close to the image centre or are too short to show it")
    if abs(k1) <= 3.0 * k1s:
        return LensDistortion(0.0, 0.0, k1s, k2s, c, r0, False, rms_b, rms_b,
                              f"lens distortion not significant (k1 = {k1:.3g} +- {k1s:.2g} "
                              f"for radius {r0:.0f} px); not corrected")
    return LensDistortion(k1, k2, k1s, k2s, c, r0, True, rms_b, rms_a,
                          f"lens distortion corrected: k1 = {k1:.3g} +- {k1s:.2g}"
                          + (f", k2 = {k2:.3g} +- {k2s:.2g}" if fit_k2 else "")
                          + f" (radius {r0:.0f} px); tape straightness {rms_b:.2f} -> "
                          f"{rms_a:.2f} px RMS")
