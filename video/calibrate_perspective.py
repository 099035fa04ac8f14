"""A camera yawed against the car's plane, from the perspective of the reference tapes.

A camera whose optical axis is not square to the car's side sees that plane through a
homography: the far end of the car is smaller in the picture than the near end, so a
metre of travel is fewer pixels there. For a yaw ``a`` and a focal length ``f`` px, an
image point at ``d`` px from the image centre (lens distortion removed) maps to the
car's plane, up to one scale, as ``d / (1 - t . d)`` with ``t = tan(a) / f`` along the
image direction of the car's plane that recedes: a "tilt" of 1e-5 to 5e-5 per px for
1-3 degrees, some 0.5-2 % of the scale from one end of a car's travel to the other.
Centred anywhere else the same map differs by an affine one, which the tape's scale
and the camera's roll (found from the level approach) take up.

A tape's segments are equal on the car, so after the right map their edges are evenly
spaced: the tilt along the tapes' direction is the value that makes them so. Across the
tapes (the camera's pitch against the plane) it is not measured: the car moves along
them, and its vertical travel is a few centimetres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

#: Largest scale change from the image centre to a corner a yawed camera plausibly shows (a
#: 10 degree yaw with a 30 degree half field of view): an uneven spacing that says more
#: comes from something else (a tape's edges biased, a lens the tapes do not show).
TILT_PLAUSIBLE = 0.10

#: Per-edge noise floor of a tape's edge positions, px (as :func:`video.calibrate_tape._fit_pitch`).
EDGE_NOISE_FLOOR_PX = 0.02


def rectify(points: np.ndarray, centre: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """Image points (N, 2) px, lens distortion removed, mapped square to the car's plane:
    ``centre + d / (1 - tilt . d)`` with ``d = p - centre``."""
    d = np.asarray(points, float) - centre
    return centre + d / (1.0 - d @ np.asarray(tilt, float))[..., None]


def unrectify(points: np.ndarray, centre: np.ndarray, tilt: np.ndarray) -> np.ndarray:
    """The inverse of :func:`rectify`: ``centre + d / (1 + tilt . d)``."""
    d = np.asarray(points, float) - centre
    return centre + d / (1.0 + d @ np.asarray(tilt, float))[..., None]


def _spacing_residuals(points: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Residuals of a tape's edges about even spacing along their own line,
    ``s = a + p i + b (-1)^i`` (the alternating term: light and dark segments' edges
    bleed differently)."""
    m = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - m, full_matrices=False)
    s = (points - m) @ vt[0]
    alt = np.where(index % 2 == 0, 1.0, -1.0)
    x = np.column_stack([np.ones_like(s), index.astype(float), alt])
    coef, *_ = np.linalg.lstsq(x, s, rcond=None)
    return s - x @ coef


@dataclass(frozen=True)
class TiltEstimate:
    """A camera's yaw against the car's plane as the tapes show it.

    Attributes
    ----------
    tilt : (2,) 1/px
        What :func:`rectify` takes out: zero when it does not stand out of its noise
        (3 sigma) or was not measured.
    along, sigma : float
        The fitted tilt along the tapes' mean direction and its one-sigma, 1/px (sigma
        NaN when not measured).
    axis : (2,) unit vector
        The tapes' mean image direction.
    note : str
        One sentence for the user.
    """

    tilt: np.ndarray
    along: float
    sigma: float
    axis: np.ndarray
    note: str

    @property
    def sigma_vector(self) -> np.ndarray:
        """One sigma of the tilt along the tapes, as a (2,) vector (zero when not measured)."""
        return (self.sigma if np.isfinite(self.sigma) else 0.0) * self.axis


def estimate_tilt(tapes: list[tuple[np.ndarray, np.ndarray]], centre: np.ndarray) -> TiltEstimate:
    """The tilt along the tapes that spaces their edges evenly, and whether it shows.

    Parameters
    ----------
    tapes : list of (points (n, 2) px, index (n,) int)
        Each tape's segment edges on its centre line, lens distortion removed, with
        their edge numbers.
    centre : (2,) px
        Centre of the map: the image centre (its distance from the corner, the image's
        half-diagonal, bounds a plausible tilt).

    Returns
    -------
    TiltEstimate
    """
    tapes = [(np.asarray(p, float), np.asarray(i, int)) for p, i in tapes if len(p) >= 6]
    zero = np.zeros(2)
    if not tapes:
        return TiltEstimate(zero, 0.0, float("nan"), np.array([1.0, 0.0]),
                            "camera yaw not measured: no tape with 6 or more edges")
    axes = []
    for p, i in tapes:
        a = p[np.argmax(i)] - p[np.argmin(i)]
        a = a / np.hypot(*a)
        axes.append(a if a[0] >= 0 else -a)
    axis = np.mean(axes, axis=0)
    axis /= np.hypot(*axis)
    span = max(float(np.ptp((p - centre) @ axis)) for p, _ in tapes)

    def residuals(c):
        t = c[0] * axis
        return np.concatenate([_spacing_residuals(rectify(p, centre, t), i) for p, i in tapes])

    n = sum(len(p) for p, _ in tapes)
    dof = n - 3 * len(tapes) - 1
    if dof < 3:
        return TiltEstimate(zero, 0.0, float("nan"), axis, f"camera yaw not measured: too few tape edges ({n})")
    # the parameter in units of the tapes' span (a tilt of 1/span doubles the scale)
    sol = least_squares(lambda q: residuals(q / span), np.zeros(1), x_scale=0.01, diff_step=1e-4)
    s2 = max(float(np.sum(sol.fun ** 2)) / dof, EDGE_NOISE_FLOOR_PX ** 2)
    jtj = float(sol.jac[:, 0] @ sol.jac[:, 0])
    value = float(sol.x[0]) / span
    sigma = float(np.sqrt(s2 / jtj)) / span if jtj > 0 else float("inf")
    # the scale's change across the tapes' span, the effect a person can weigh
    change = 100.0 * abs(value) * span
    corner = float(np.hypot(*(np.asarray(centre, float) + 0.5)))
    if abs(value) * corner > TILT_PLAUSIBLE:
        return TiltEstimate(zero, value, float("nan"), axis,
                            f"camera yaw not corrected: the tape's segments shrink by {change:.2f} % across its "
                            f"{span:.0f} px, {100 * abs(value) * corner:.0f} % from the image centre to a corner, "
                            "more than a yawed camera shows: the spacing is uneven for another reason")
    if not np.isfinite(sigma) or abs(value) <= 3.0 * sigma:
        return TiltEstimate(zero, value, sigma, axis,
                            f"camera yaw against the car's plane not significant (scale change across the "
                            f"tape {change:.2f} %, {abs(value) / sigma:.1f} sigma); not corrected (its "
                            "uncertainty counted in the scale's)")
    return TiltEstimate(value * axis, value, sigma, axis,
                        f"camera yaw against the car's plane taken out: the tape's segments shrink by "
                        f"{change:.2f} % across its {span:.0f} px (tilt {value:.3g} +- {sigma:.2g} /px, "
                        f"{abs(value) / sigma:.0f} sigma)")
