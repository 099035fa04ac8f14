"""Quadrant targets: find them in a frame, refine their centres to a fraction of a pixel,
measure their radius and the rotation of their quadrant pattern.

A quadrant target is a disc split into four quadrants of alternating dark and light
(black/white or black/yellow). Its centre is the saddle point of the image intensity:

- **detection**: the scale-normalised saddle response ``-det(H) sigma^4`` of the
  Gaussian-smoothed image (large and positive only at X-shaped corners), local maxima
  above a threshold, then a check that the neighbourhood is point-symmetric and
  anti-symmetric under a quarter turn (what a quadrant pattern is and a tape edge,
  a T-junction or a blob is not);
- **sub-pixel centre**: the point ``c`` that makes the image gradients inside the disc
  orthogonal to ``q - c`` (every gradient of an ideal X-corner points across a line
  through the centre), solved in closed form, re-weighted and iterated
  (``refine_gradient``, on the image smoothed by ``0.3 * radius``, at most 1.5 px), then
  polished to the disc's best point symmetry, which blur keeps and the gradients'
  orthogonality does not (``refine_symmetric``; both: ``refine_centre``, what the tracker
  uses). ``refine_saddle`` (stationary point of a quadratic fitted to the smoothed image)
  and OpenCV's ``cornerSubPix`` are kept for comparison (``benchmarks/bench_video.py``):
  on targets of radius 5-20 px, centre / gradient / saddle / OpenCV give 0.012 / 0.017 /
  0.075 / 0.048 px RMS clean and 0.041 / 0.082 / 0.087 / 0.139 px RMS with 5 px motion
  blur, defocus and noise (3 % of full scale);
- **radius and orientation**: on rings around the centre, the second angular harmonic
  ``c2 = sum_j I(theta_j) exp(-2i theta_j)`` of the intensity is large inside the disc and
  small outside (radius), and its phase gives the rotation of the pattern modulo pi
  (``orientation = -arg(c2) / 2``, image angle: positive is clockwise on the screen).

All positions are image pixels ``(u, v)`` (u right, v down, (0, 0) the centre of the
top-left pixel), as ``(N, 2)`` float64 arrays.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from video.detector import Candidates, Detector
from video.errors import VideoError

__all__ = [
    "TargetConfig",
    "Detections",
    "QuadrantTargetDetector",
    "to_gray",
    "saddle_response",
    "detect_targets",
    "refine_gradient",
    "refine_gradients",
    "refine_symmetric",
    "refine_symmetric_each",
    "refine_centre",
    "refine_centre_and_symmetry",
    "refine_centres_and_symmetry",
    "refine_saddle",
    "refine_opencv",
    "ring_profile",
    "target_radius",
    "target_radii",
    "orientation",
    "orientations",
    "symmetry_errors",
    "symmetry_errors_each",
    "centre_sigma",
    "gradient_smoothing",
]


@dataclass(frozen=True)
class TargetConfig:
    """Settings of the target detector.

    Attributes
    ----------
    min_radius_px, max_radius_px : float
        Range of target radii to look for, px (a 60 mm target at 10 mm/px has a radius of
        3 px, a 150 mm target at 2 mm/px one of 38 px; a 73 mm target at 9 mm/px, 4.0 px).
    sigmas_px : tuple of float
        Gaussian scales of the saddle response, px; the response is the maximum over them.
    min_contrast : float
        Smallest dark-to-light difference of a target, in grey levels of [0, 1].
    max_symmetry_error : float
        Largest accepted relative error of point symmetry and of quarter-turn
        anti-symmetry (0 for a perfect quadrant pattern, about 1 or more for anything else).
    max_candidates : int
        Most response maxima examined per frame (strongest first). Only frame 0 is searched
        whole: on a reference-world film (scored seed 910038) a wall's grid and the checker
        tapes' junctions gave 8190 maxima, the 7 targets (light quadrants as grey as the car)
        ranked 554-591, and 300 found none; 3000 took 1.1 s there.
    refine_iterations : int
        Iterations of the gradient-orthogonality centre refinement.
    """

    min_radius_px: float = 3.0
    max_radius_px: float = 40.0
    sigmas_px: tuple = (1.5, 2.5)
    min_contrast: float = 0.15
    max_symmetry_error: float = 0.35
    max_candidates: int = 3000
    refine_iterations: int = 6


@dataclass(frozen=True)
class Detections:
    """Quadrant targets found in one frame.

    Attributes
    ----------
    centres : (N, 2) float64
        Sub-pixel centres ``[u, v]``, px.
    radii : (N,) float64
        Radius of each target's disc, px.
    orientations : (N,) float64
        Rotation of each quadrant pattern, rad, modulo pi (image angle, clockwise positive).
    contrasts : (N,) float64
        Light-minus-dark difference, grey levels in [0, 1].
    symmetry : (N,) float64
        Largest of the two symmetry errors (smaller is a cleaner target).
    """

    centres: np.ndarray
    radii: np.ndarray
    orientations: np.ndarray
    contrasts: np.ndarray
    symmetry: np.ndarray

    def __len__(self) -> int:
        return len(self.centres)


def to_gray(frame: np.ndarray) -> np.ndarray:
    """Return a frame as a float32 grey image in [0, 1].

    Parameters
    ----------
    frame : (H, W) or (H, W, C) array, uint8, uint16 or float
        Colour frames are averaged over their first three channels (so RGB and BGR give
        the same grey, and yellow stays light).

    Returns
    -------
    (H, W) float32
    """
    a = np.asarray(frame)
    if a.ndim == 3:
        a = a[..., :3].astype(np.float32).mean(axis=2)
        scale = 255.0 if np.asarray(frame).dtype == np.uint8 else (
            65535.0 if np.asarray(frame).dtype == np.uint16 else 1.0)
    elif a.ndim == 2:
        scale = 255.0 if a.dtype == np.uint8 else (65535.0 if a.dtype == np.uint16 else 1.0)
        a = a.astype(np.float32)
    else:
        raise VideoError(f"a frame must be a 2-D grey or 3-D colour image, got shape {a.shape}")
    return a / np.float32(scale) if scale != 1.0 else a


def saddle_response(gray: np.ndarray, sigma: float) -> np.ndarray:
    """Scale-normalised saddle response ``-det(H) sigma^4`` of the smoothed image.

    Parameters
    ----------
    gray : (H, W) float32
        Grey image.
    sigma : float
        Gaussian scale, px.

    Returns
    -------
    (H, W) float32
        Positive at saddle points (X-corners), negative at blobs.
    """
    k = int(2 * np.ceil(3 * sigma) + 1)
    g = cv2.GaussianBlur(gray, (k, k), sigma, borderType=cv2.BORDER_REFLECT)
    ixx = cv2.Sobel(g, cv2.CV_32F, 2, 0, ksize=3, scale=1.0)
    iyy = cv2.Sobel(g, cv2.CV_32F, 0, 2, ksize=3, scale=1.0)
    ixy = cv2.Sobel(g, cv2.CV_32F, 1, 1, ksize=3, scale=0.25)
    return (ixy * ixy - ixx * iyy) * np.float32(sigma**4)


def _sample(gray: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``gray`` at float positions ``u, v`` (any equal shapes)."""
    mu = np.ascontiguousarray(u, dtype=np.float32)
    mv = np.ascontiguousarray(v, dtype=np.float32)
    shape = mu.shape
    cols = max(shape[-1] if mu.ndim > 1 else mu.size, 1)  # a map's rows as the last axis: each side under 32767
    out = cv2.remap(gray, mu.reshape(-1, cols), mv.reshape(-1, cols), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(shape)


def _sample_each(grays, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear samples of each image ``grays[k]`` at its own float positions ``u[k], v[k]``
    (px, arrays of shape (K, rows, cols), each side under 32767), as float64 (K, rows,
    cols). Each image is sampled in its own pixel frame, so a target gets the very samples
    it gets alone."""
    mu = np.asarray(u, dtype=np.float32)
    mv = np.asarray(v, dtype=np.float32)
    return np.array([cv2.remap(g, a, b, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
                     for g, a, b in zip(grays, mu, mv)], dtype=float)


def _as_targets(centres, radii) -> tuple[np.ndarray, np.ndarray]:
    """Centres (K, 2) float64 px and radii (K,) float64 px of K targets (one (2,) centre
    and a scalar radius make K = 1)."""
    return np.asarray(centres, dtype=float).reshape(-1, 2), np.asarray(radii, dtype=float).reshape(-1)


def _ring_points(centres: np.ndarray, radii: np.ndarray, n_angles: int) -> tuple[np.ndarray, np.ndarray]:
    """Positions (u, v), px, of ``n_angles`` samples on each ring of ``radii`` (px) around
    ``centres`` (``[u, v]`` on the last axis): shape ``centres.shape[:-1] + radii.shape +
    (n_angles,)`` where ``radii`` is (R,), and (K, R, n_angles) where it is (K, R), one row
    of rings per centre. float32, what ``cv2.remap`` takes: summed in float64 and rounded
    once, with no float64 copy of the (often millions of) positions."""
    cos, sin, _ = _ring_angles(n_angles)
    c = np.asarray(centres, dtype=float)
    r = np.asarray(radii, dtype=float)[..., None]
    shape = np.broadcast_shapes(c.shape[:-1] + (1, 1), r.shape[:-1] + cos.shape)
    return tuple(np.add(c[..., i, None, None], r * trig, out=np.empty(shape, np.float32), casting="same_kind")
                 for i, trig in ((0, cos), (1, sin)))


def _harmonic(vals: np.ndarray) -> np.ndarray:
    """``mean_j vals_j exp(-2i theta_j)`` over the last axis (samples evenly round a ring)."""
    _, _, phasor = _ring_angles(vals.shape[-1])
    # real products: a complex one over thousands of rings took 40 times as long
    return vals @ phasor.real + 1j * (vals @ phasor.imag)


def ring_profile(gray: np.ndarray, centre: np.ndarray, radii: np.ndarray,
                 n_angles: int = 48) -> np.ndarray:
    """Second angular harmonic of the intensity on rings around ``centre``.

    Parameters
    ----------
    gray : (H, W) float32
    centre : (2,) or (N, 2) float
        ``[u, v]``, px: one centre, or N sampled together.
    radii : (R,) float
        Ring radii, px.
    n_angles : int
        Samples per ring.

    Returns
    -------
    (R,) or (N, R) complex128
        ``c2 = mean_j I(theta_j) exp(-2i theta_j)`` per ring. For a quadrant pattern of
        contrast C its modulus is ``C * 2 / pi`` inside the disc (ideal edges).
    """
    return _harmonic(_sample(gray, *_ring_points(centre, radii, n_angles)).astype(float))


def _ring_profile_each(grays, centres: np.ndarray, radii: np.ndarray, n_angles: int) -> np.ndarray:
    """:func:`ring_profile` of each of K targets in its own image ``grays[k]``, on its own
    rings ``radii[k]`` ((K, R) px): (K, R) complex128."""
    return _harmonic(_sample_each(grays, *_ring_points(centres, radii, n_angles)))


@lru_cache(maxsize=8)
def _ring_angles(n_angles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """cos and sin of ``n_angles`` angles evenly round a circle, and ``exp(-2i theta) /
    n_angles`` (the second harmonic's mean as one product)."""
    th = np.arange(n_angles) * (2 * np.pi / n_angles)
    return np.cos(th), np.sin(th), np.exp(-2j * th) / n_angles


def target_radius(gray: np.ndarray, centre: np.ndarray, config: TargetConfig = TargetConfig(),
                  expected: float | None = None) -> tuple[float, float]:
    """Radius and contrast of the quadrant disc centred at ``centre``.

    Rings from 1 px to ``1.3 * config.max_radius_px`` are examined, or from 0.3 to 1.6
    times ``expected`` (px) when the radius is known roughly (tracking).

    Returns
    -------
    radius : float
        Ring radius where the quadrant harmonic falls to half its maximum, px (NaN if
        the pattern does not reach ``config.min_radius_px``).
    contrast : float
        Light-minus-dark difference estimated from the harmonic's maximum, [0, 1].
    """
    radius, contrast = target_radii([gray], centre, config, None if expected is None else [expected])
    return float(radius[0]), float(contrast[0])


def target_radii(grays, centres: np.ndarray, config: TargetConfig = TargetConfig(),
                 expected: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`target_radius` of K targets together, each in its own image ``grays[k]``.

    Parameters
    ----------
    grays : sequence of K (H, W) float32
    centres : (K, 2) float, px
    config : TargetConfig
    expected : (K,) float, optional
        Each target's rough radius, px.

    Returns
    -------
    radius, contrast : (K,) float64
        px (NaN where the pattern does not reach ``config.min_radius_px``), and [0, 1].
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    if not len(centres):
        return np.zeros(0), np.zeros(0)
    rough = [None] * len(centres) if expected is None else np.asarray(expected, dtype=float).reshape(-1)
    rows = [_search_radii(config, e) for e in rough]
    counts = np.array([len(r) for r in rows])
    missing = np.arange(counts.max())[None, :] >= counts[:, None]
    # rows padded with rings of radius 0 (sampled, then left out)
    radii = np.zeros(missing.shape)
    radii[~missing] = np.concatenate(rows)
    amp = np.abs(_ring_profile_each(grays, centres, radii, 48))
    amp[missing] = np.nan
    return _radius_from_rings(amp, radii, config)


def _search_radii(config: TargetConfig, expected: float | None) -> np.ndarray:
    """The ring radii :func:`target_radius` examines, px."""
    if expected is None:
        return np.arange(1.0, config.max_radius_px * 1.3 + 1.0, 0.5)
    return np.arange(max(1.0, 0.3 * expected), 1.6 * expected + 0.5, 0.5)


def _radius_from_rings(amp: np.ndarray, radii: np.ndarray, config: TargetConfig) -> tuple[np.ndarray, np.ndarray]:
    """Radius (px; NaN where the harmonic never falls to half its maximum beyond it, or
    the radius is under ``config.min_radius_px``) and contrast of each of N candidates from
    the modulus ``amp`` (N, R) of their quadrant harmonic on rings ``radii`` ((R,) or
    (N, R), px): see :func:`target_radius`. NaN in ``amp`` marks a row's missing rings."""
    n = np.arange(len(amp))
    k = np.nanargmax(amp, axis=1)
    peak = amp[n, k]
    below = (np.arange(amp.shape[1])[None, :] >= k[:, None]) & (amp < 0.5 * peak[:, None])
    j = np.argmax(below, axis=1)  # the first ring beyond the peak below half of it (j > k)
    # linear interpolation of the half-maximum crossing between radii[j-1] and radii[j]
    a0, a1 = amp[n, j - 1], amp[n, j]
    frac = (a0 - 0.5 * peak) / np.maximum(a0 - a1, 1e-12)
    rr = np.broadcast_to(radii, amp.shape)
    radius = rr[n, j - 1] + frac * (rr[n, j] - rr[n, j - 1])
    radius = np.where(below.any(axis=1) & (radius >= config.min_radius_px), radius, np.nan)
    return radius, peak * np.pi / 2


def _radii_of_many(gray: np.ndarray, starts: np.ndarray, config: TargetConfig,
                   chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """:func:`target_radius` (radius unknown) at each of the (N, 2) ``starts``, px: the
    rings of many candidates sampled together (a frame's thousands of candidates,
    most of which this first look rejects)."""
    radii = _search_radii(config, None)
    out_r, out_c = [], []
    for a in range(0, len(starts), chunk):
        r, con = _radius_from_rings(np.abs(ring_profile(gray, starts[a:a + chunk], radii)), radii, config)
        out_r.append(r)
        out_c.append(con)
    if not out_r:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(out_r), np.concatenate(out_c)


def orientation(gray: np.ndarray, centre: np.ndarray, radius: float) -> float:
    """Rotation of the quadrant pattern, rad in (-pi/2, pi/2].

    Parameters
    ----------
    gray : (H, W) float32
    centre : (2,) float, px
    radius : float
        Disc radius, px; rings between 0.35 and 0.75 of it are used.

    Returns
    -------
    float
        The image angle of the boundary at which a light quadrant begins, going
        clockwise on the screen: ``-arg(c2) / 2 - pi / 4``. Turning the pattern clockwise
        by ``a`` adds ``a`` (modulo pi: a quarter turn swaps dark and light).
    """
    return float(orientations([gray], centre, radius)[0])


def orientations(grays, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """:func:`orientation` of K targets together, each in its own image ``grays[k]``
    (centres (K, 2) px, radii (K,) px): (K,) rad in (-pi/2, pi/2]."""
    centres, radii = _as_targets(centres, radii)
    rings = np.linspace(0.35, 0.75, 5)[None, :] * radii[:, None]
    c2 = _ring_profile_each(grays, centres, rings, 64).sum(axis=1)
    a = -np.angle(c2) / 2.0 - np.pi / 4
    return np.where(a <= -np.pi / 2, a + np.pi, a)


@lru_cache(maxsize=64)
def _symmetry_grid(h: float, n: int = 9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sample offsets (n, n) px of half-width ``h`` and the disc mask inside it."""
    s = np.linspace(-h, h, n)
    du, dv = np.meshgrid(s, s)
    return du, dv, (du**2 + dv**2) <= h * h


def symmetry_errors(gray: np.ndarray, centre: np.ndarray, radius: float,
                    extent: float = 0.9) -> tuple[float, float]:
    """Relative errors of point symmetry and quarter-turn anti-symmetry inside the disc.

    Samples a 9 x 9 grid of half-width ``extent * radius`` around ``centre``, inside
    that circle; with ``A`` the samples minus their mean, returns
    ``|A - rot180(A)|^2 / |A|^2 / 2`` and ``|A + rot90(A)|^2 / |A|^2 / 2`` (each 0 for a
    quadrant pattern, about 1 for unstructured texture, 2 for a blob or a pattern
    symmetric under a quarter turn). Motion blur keeps the point symmetry (its kernel
    is symmetric) but breaks the quarter-turn one; debris or an occluder over the disc
    breaks both. Clean, noisy, blurred or compressed targets give a point error below
    0.02 (99 % of the rendered test films' samples).
    """
    e = symmetry_errors_each([gray], centre, radius, extent)[0]
    return float(e[0]), float(e[1])


def symmetry_errors_each(grays, centres: np.ndarray, radii: np.ndarray,
                         extent: float = 0.9) -> np.ndarray:
    """:func:`symmetry_errors` of K targets together, each in its own image ``grays[k]``
    (centres (K, 2) px, radii (K,) px): (K, 2) point and quarter-turn errors."""
    centres, radii = _as_targets(centres, radii)
    if not len(centres):
        return np.zeros((0, 2))
    grids = [_symmetry_grid(h) for h in np.round(np.maximum(2.0, extent * radii), 2)]
    du, dv, mask = (np.stack(g) for g in zip(*grids))
    patch = _sample_each(grays, centres[:, 0, None, None] + du, centres[:, 1, None, None] + dv)
    mean = (patch * mask).sum(axis=(1, 2)) / mask.sum(axis=(1, 2))
    a = np.where(mask, patch - mean[:, None, None], 0.0)
    norm = np.maximum((a * a).sum(axis=(1, 2)), 1e-12)
    e_point = ((a - a[:, ::-1, ::-1]) ** 2).sum(axis=(1, 2)) / norm / 2
    e_quarter = ((a + a.transpose(0, 2, 1)[:, ::-1]) ** 2).sum(axis=(1, 2)) / norm / 2  # a quarter turn
    return np.stack([e_point, e_quarter], axis=1)


@lru_cache(maxsize=64)
def _pair_offsets(h: float, n: int = 11) -> tuple[np.ndarray, np.ndarray]:
    """One offset of each point-symmetric pair ``(d, -d)`` of the ``n x n`` disc grid of
    half-width ``h`` (the centre left out), px, padded with ``d = 0`` to ``(n * n - 1) / 2``
    (every half-width gives the same length; the pair ``(0, 0)`` adds nothing to a
    symmetry error: ``I(c) - I(c)``)."""
    du, dv, mask = _symmetry_grid(h, n)
    one = mask.copy()
    one[n // 2 + 1:, :] = False
    one[n // 2, n // 2:] = False
    pad = (n * n - 1) // 2 - int(one.sum())
    return np.pad(du[one], (0, pad)), np.pad(dv[one], (0, pad))


def refine_symmetric(gray: np.ndarray, centre: np.ndarray, radius: float,
                     iterations: int = 5, extent: float = 0.9) -> np.ndarray:
    """Sub-pixel centre as the point of the disc's best point symmetry, px.

    A quadrant target is symmetric under a half turn about its centre, and so is it
    blurred by motion (a symmetric kernel), defocused, or sampled by a sensor. Gauss-Newton
    on the differences ``I(c + d) - I(c - d)`` over pairs of points of an 11 x 11 grid
    inside ``extent * radius`` (bilinear samples of the picture smoothed by
    ``gradient_smoothing``; derivatives by central differences of half a pixel). ``refine_gradient``'s orthogonality condition is not kept by blur: on
    blurred targets of radius 4-6 px it stops where it started within about a third of a
    pixel (reference-world films: 0.17-0.22 px RMS from starts 0.5 px off, this 0.04-0.14
    px). Use it after ``refine_gradient`` (start within about ``radius / 4``); steps are
    limited to 1 px.

    Returns
    -------
    (2,) float64
        Refined ``[u, v]``, or NaNs if the equations are degenerate (a flat patch).
    """
    return refine_symmetric_each([gray], centre, radius, iterations, extent)[0]


def _symmetric_window(gray: np.ndarray, centre: np.ndarray, radius: float, extent: float):
    """What :func:`refine_symmetric` samples for one target: the picture around ``centre``
    smoothed by ``gradient_smoothing`` (a crop leaving room for the centre to move), the
    crop's origin (2,) px, and the pair offsets (du, dv) (m,) px (:func:`_pair_offsets`);
    None where the crop is under 5 px."""
    h = round(max(2.0, extent * radius), 2)
    du, dv = _pair_offsets(h)
    # bilinear samples of a sharp picture lock to pixels: sample it smoothed (a symmetric
    # kernel keeps the symmetry), in a crop that leaves room for the centre to move
    sm = gradient_smoothing(radius)
    pad = int(np.ceil(h + 4 * sm + 3))
    iu, iv = round(float(centre[0])), round(float(centre[1]))
    u0, v0 = max(iu - pad, 0), max(iv - pad, 0)
    crop = gray[v0: iv + pad + 1, u0: iu + pad + 1]
    if crop.shape[0] < 5 or crop.shape[1] < 5:
        return None
    smooth = cv2.GaussianBlur(np.ascontiguousarray(crop, dtype=np.float32), (0, 0), sm)
    return smooth, np.array([u0, v0], dtype=float), du, dv


def refine_symmetric_each(grays, centres: np.ndarray, radii: np.ndarray,
                          iterations: int = 5, extent: float = 0.9) -> np.ndarray:
    """:func:`refine_symmetric` of K targets together, each in its own image ``grays[k]``
    (centres (K, 2) px, radii (K,) px): (K, 2) px, NaN rows where degenerate. The
    Gauss-Newton steps of all targets are taken together; each stops on its own."""
    centres, radii = _as_targets(centres, radii)
    out = np.full((len(centres), 2), np.nan)
    windows = [_symmetric_window(g, c, r, extent) for g, c, r in zip(grays, centres, radii)]
    idx = np.array([k for k, w in enumerate(windows) if w is not None], dtype=int)
    if not idx.size:
        return out
    smooth = [windows[k][0] for k in idx]
    origin = np.array([windows[k][1] for k in idx])
    du = np.array([windows[k][2] for k in idx])
    dv = np.array([windows[k][3] for k in idx])
    eu = np.array([0.0, 0.5, -0.5, 0.0, 0.0])
    ev = np.array([0.0, 0.0, 0.0, 0.5, -0.5])
    su = np.concatenate([du[:, None, :] + eu[:, None], -du[:, None, :] + eu[:, None]], axis=1)  # (n, 10, m)
    sv = np.concatenate([dv[:, None, :] + ev[:, None], -dv[:, None, :] + ev[:, None]], axis=1)
    c = centres[idx] - origin
    going = np.arange(len(idx))
    for _ in range(iterations):
        f = _sample_each([smooth[j] for j in going], c[going, 0, None, None] + su[going],
                         c[going, 1, None, None] + sv[going])
        plus, minus = f[:, :5], f[:, 5:]
        r = plus[:, 0] - minus[:, 0]
        jac = np.stack([(plus[:, 1] - plus[:, 2]) - (minus[:, 1] - minus[:, 2]),
                        (plus[:, 3] - plus[:, 4]) - (minus[:, 3] - minus[:, 4])], axis=-1)
        step = np.clip(_solve_normal(jac, -r), -1.0, 1.0)
        c[going] += step  # a degenerate step makes the centre NaN
        moving = np.hypot(step[:, 0], step[:, 1]) >= 1e-3
        going = going[moving]
        if not going.size:
            break
    out[idx] = c + origin
    return out


def _solve_normal(jac: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """The least-squares steps ``(J^T J)^-1 J^T rhs`` of two-parameter Gauss-Newtons
    (``jac`` (..., m, 2), ``rhs`` (..., m)): (..., 2), NaN where ``J^T J`` is singular or
    its condition number exceeds 1e8 (in closed form: 2 x 2 systems, where
    ``numpy.linalg`` spent most of its time checking its arguments)."""
    (a00, a01), (_, a11) = np.einsum("...mi,...mj->ij...", jac, jac)
    b0, b1 = np.einsum("...mi,...m->i...", jac, rhs)
    trace = a00 + a11
    with np.errstate(divide="ignore", invalid="ignore"):
        # both sides divided by the trace: the determinant neither under- nor overflows
        a00, a01, a11, b0, b1 = a00 / trace, a01 / trace, a11 / trace, b0 / trace, b1 / trace
        half_gap = np.hypot(0.5 * (a00 - a11), a01)
        largest, least = 0.5 + half_gap, 0.5 - half_gap
        ok = (trace > 0.0) & (least * 1e8 >= largest) & (least > 0.0)
        det = a00 * a11 - a01 * a01
        step = np.stack([(a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det], axis=-1)
    return np.where(ok[..., None], step, np.nan)


def refine_centre(gray: np.ndarray, centre: np.ndarray, radius: float,
                  iterations: int = 6) -> np.ndarray:
    """A target's sub-pixel centre, px: ``refine_gradient`` from the start, then
    ``refine_symmetric`` from there (from the start when the gradients ran off, as under
    strong blur), kept where it stays within ``radius / 4`` and makes the disc more
    point-symmetric; otherwise the gradient centre. NaNs where the gradients are
    degenerate (a covered target's flat patch is perfectly point-symmetric: no centre
    is made of it)."""
    return refine_centre_and_symmetry(gray, centre, radius, iterations)[0]


def refine_centre_and_symmetry(gray: np.ndarray, centre: np.ndarray, radius: float,
                               iterations: int = 6) -> tuple[np.ndarray, tuple[float, float] | None]:
    """:func:`refine_centre`, and the :func:`symmetry_errors` at the centre it returns
    where it measured them on the way (None where it did not)."""
    c, errors = refine_centres_and_symmetry([gray], centre, radius, iterations)
    return c[0], None if np.isnan(errors[0, 0]) else (float(errors[0, 0]), float(errors[0, 1]))


def refine_centres_and_symmetry(grays, centres: np.ndarray, radii: np.ndarray,
                                iterations: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """:func:`refine_centre_and_symmetry` of K targets together, each in its own image
    ``grays[k]`` (centres (K, 2) px, radii (K,) px): centres (K, 2) px (NaN rows where
    the gradients are degenerate) and the symmetry errors (K, 2) at them, NaN where not
    measured on the way."""
    centres, radii = _as_targets(centres, radii)
    c = refine_gradients(grays, centres, radii, iterations)
    errors = np.full((len(c), 2), np.nan)
    idx = np.flatnonzero(np.isfinite(c).all(axis=1))
    if not idx.size:
        return c, errors
    near = np.hypot(*(c[idx] - centres[idx]).T) <= 0.3 * radii[idx]
    start = np.where(near[:, None], c[idx], centres[idx])
    p = refine_symmetric_each([grays[k] for k in idx], start, radii[idx])
    kept = np.isfinite(p).all(axis=1) & (np.hypot(*(p - start).T) <= 0.25 * radii[idx])
    # near: the more point-symmetric of the two; else the symmetric one wherever kept
    both = np.flatnonzero(kept & near)
    if both.size:
        at = symmetry_errors_each([grays[idx[j]] for j in both] * 2, np.concatenate([p[both], c[idx[both]]]),
                                  np.tile(radii[idx[both]], 2))
        at_p, at_c = at[:len(both)], at[len(both):]
        p_wins = ~(at_p[:, 0] >= at_c[:, 0])
        c[idx[both]] = np.where(p_wins[:, None], p[both], c[idx[both]])
        errors[idx[both]] = np.where(p_wins[:, None], at_p, at_c)
    alone = np.flatnonzero(kept & ~near)
    c[idx[alone]] = p[alone]
    return c, errors


def gradient_smoothing(radius: float) -> float:
    """Gaussian pre-smoothing of ``refine_gradient`` for a target radius, px:
    ``clip(0.3 * radius, 0.7, 1.5)``. More smoothing lowers the error on clean and on
    blurred noisy targets a little more (to 3 px: 0.012 / 0.072 px RMS instead of
    0.017 / 0.082) but spreads an occluder's edge into the window: a partly covered
    target then passes the symmetry check with its centre 0.5 px off (0.06 px here)."""
    return min(max(0.3 * float(radius), 0.7), 1.5)


def refine_gradient(gray: np.ndarray, centre: np.ndarray, radius: float,
                    iterations: int = 6, smooth_sigma: float | None = None) -> np.ndarray:
    """Sub-pixel centre from gradient orthogonality, px.

    Minimises ``sum_q w_q (g_q . (q - c))^2`` over the centre ``c``: every gradient of an
    ideal X-corner is orthogonal to the line from the centre, so
    ``c = (sum w g g^T)^-1 sum w g g^T q``. The weights are a Gaussian of width
    ``0.35 * radius`` around the current estimate, cut off at ``0.75 * radius`` so that
    the disc's outer edge (whose gradients point at the centre) is left out; iterated.

    Parameters
    ----------
    gray : (H, W) float32
    centre : (2,) float
        Starting point within about ``radius / 3`` of the true centre, px.
    radius : float
        Disc radius, px.
    iterations : int
    smooth_sigma : float, optional
        Gaussian pre-smoothing of the patch, px (reduces noise, keeps the saddle); 0 for
        none; default :func:`gradient_smoothing`.

    Returns
    -------
    (2,) float64
        Refined ``[u, v]``, or NaNs if the window leaves the image or is degenerate.
    """
    return refine_gradients([gray], centre, radius, iterations, smooth_sigma)[0]


def _gradient_patch(gray: np.ndarray, centre: np.ndarray, radius: float, smooth_sigma: float):
    """The smoothed patch :func:`refine_gradient` differentiates for one target: (patch
    (2 r + 3, 2 r + 3) float32 around pixel (iu, iv), iu, iv, r) with ``r`` its half-width
    less one, px; None where it leaves the image."""
    h = int(np.ceil(0.75 * radius)) + 2
    m = max(3, int(np.ceil(0.35 * radius)))  # room for the window to move
    H, W = gray.shape
    iu, iv = round(float(centre[0])), round(float(centre[1]))
    r = h + m
    if iu - r - 1 < 0 or iv - r - 1 < 0 or iu + r + 2 > W or iv + r + 2 > H:
        return None
    patch = gray[iv - r - 1: iv + r + 2, iu - r - 1: iu + r + 2]
    if smooth_sigma > 0:
        patch = cv2.GaussianBlur(patch, (0, 0), smooth_sigma)
    return patch, iu, iv, r


def _normal_terms(patches: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The five terms ``g_u g_u, g_u g_v, g_v g_v, (g g^T q)_u, (g g^T q)_v`` of
    :func:`refine_gradient`'s normal equations at each pixel ``q`` of K windows
    (:func:`_gradient_patch` s), centred in one square of the largest, side s: (K, 5,
    s * s), zero outside each window's own square; and the square's columns ``q_u`` and
    rows ``q_v``, (K, s) px each."""
    big = max(p[3] for p in patches)
    stack = np.zeros((len(patches), 2 * big + 3, 2 * big + 3), np.float32)
    inside = np.zeros((len(patches), 2 * big + 1, 2 * big + 1))
    for j, (patch, _, _, r) in enumerate(patches):
        a = big - r
        stack[j, a: a + 2 * r + 3, a: a + 2 * r + 3] = patch
        inside[j, a: a + 2 * r + 1, a: a + 2 * r + 1] = 1.0
    gu = ((stack[:, 1:-1, 2:] - stack[:, 1:-1, :-2]) * 0.5).astype(float) * inside
    gv = ((stack[:, 2:, 1:-1] - stack[:, :-2, 1:-1]) * 0.5).astype(float) * inside
    s = np.arange(-big, big + 1, dtype=float)
    qu = s[None, None, :] + np.array([p[1] for p in patches], dtype=float)[:, None, None]
    qv = s[None, :, None] + np.array([p[2] for p in patches], dtype=float)[:, None, None]
    guu, guv, gvv = gu * gu, gu * gv, gv * gv
    terms = np.stack([guu, guv, gvv, guu * qu + guv * qv, guv * qu + gvv * qv], axis=1)
    return terms.reshape(len(patches), 5, -1), qu[:, 0, :], qv[:, :, 0]


def refine_gradients(grays, centres: np.ndarray, radii: np.ndarray, iterations: int = 6,
                     smooth_sigma: float | None = None) -> np.ndarray:
    """:func:`refine_gradient` of K targets together, each in its own image ``grays[k]``
    (centres (K, 2) px, radii (K,) px): (K, 2) px, NaN rows where the window leaves the
    image or is degenerate. Windows of similar size (:func:`_size_groups`) are refined
    together, the iterations of a group's targets taken together; each stops on its own."""
    centres, radii = _as_targets(centres, radii)
    out = np.full((len(centres), 2), np.nan)
    patches = [_gradient_patch(g, c, r, gradient_smoothing(r) if smooth_sigma is None else smooth_sigma)
               for g, c, r in zip(grays, centres, radii)]
    idx = np.array([k for k, p in enumerate(patches) if p is not None], dtype=int)
    for group in _size_groups(np.array([patches[k][3] for k in idx], dtype=int)):
        k = idx[group]
        out[k] = _refine_group([patches[j] for j in k], centres[k], radii[k], iterations)
    return out


def _size_groups(half_widths: np.ndarray) -> list[np.ndarray]:
    """Indices into the (K,) ``half_widths`` (px) of :func:`_gradient_patch` windows, in
    groups of similar size, smallest first: a group's largest square is at most twice
    the area of its smallest (:func:`_normal_terms` pads a group to its largest; the
    candidates of one frame had radii from 7 to 50 px)."""
    order = np.argsort(half_widths, kind="stable")
    area = (2 * half_widths[order] + 3) ** 2
    groups, start = [], 0
    for j in range(1, len(order) + 1):
        if j == len(order) or area[j] > 2 * area[start]:
            groups.append(order[start:j])
            start = j
    return groups


def _refine_group(patches: list, centres: np.ndarray, radii: np.ndarray, iterations: int) -> np.ndarray:
    """:func:`refine_gradients` of n targets from their windows ``patches``
    (:func:`_gradient_patch` s) and starts ``centres`` (n, 2) px, radii (n,) px: (n, 2)
    px, NaN rows where degenerate or run off."""
    terms, qu, qv = _normal_terms(patches)
    middle = np.array([p[1:3] for p in patches], dtype=float)
    room = np.maximum(3, np.ceil(0.35 * radii))  # how far the window may move, px
    sw2 = 2 * (0.35 * radii) ** 2
    cut2 = (0.75 * radii) ** 2
    c = centres.copy()
    going = np.arange(len(c))
    for _ in range(iterations):
        away = (np.abs(c[going] - middle[going]) > room[going, None]).any(axis=1)
        c[going[away]] = np.nan
        going = going[~away]
        if not going.size:
            break
        d2 = (((qv[going] - c[going, 1, None]) ** 2)[:, :, None]
              + ((qu[going] - c[going, 0, None]) ** 2)[:, None, :]).reshape(len(going), -1)
        w = np.zeros_like(d2)
        np.exp(-d2 / sw2[going, None], out=w, where=d2 <= cut2[going, None])
        a00, a01, a11, b0, b1 = (terms[going] @ w[:, :, None])[:, :, 0].T
        det = a00 * a11 - a01 * a01
        flat = ~np.isfinite(det) | (det <= 1e-12 * np.maximum((a00 + a11) ** 2, 1e-30))
        with np.errstate(divide="ignore", invalid="ignore"):
            new = np.stack([(a11 * b0 - a01 * b1) / det, (a00 * b1 - a01 * b0) / det], axis=1)
        new[flat] = np.nan
        step = np.hypot(*(new - c[going]).T)
        c[going] = new
        going = going[~flat & ~(step < 2e-3)]
        if not going.size:
            break
    return c


def refine_saddle(gray: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Sub-pixel centre as the stationary point of a quadratic fitted to the smoothed image.

    The image is smoothed with a Gaussian of ``0.3 * radius`` px; ``I = a + b u + c v +
    d u^2 + e u v + f v^2`` is fitted by least squares on the pixels within
    ``0.4 * radius`` of the start, and its stationary point returned (iterated twice).

    Returns
    -------
    (2,) float64
        ``[u, v]`` px, or NaNs if the window leaves the image or the fit is no saddle.
    """
    c = np.asarray(centre, dtype=float).copy()
    sigma = max(0.8, 0.3 * radius)
    h = max(2, int(np.ceil(0.4 * radius)))
    pad = int(np.ceil(3 * sigma))
    H, W = gray.shape
    for _ in range(2):
        iu, iv = int(round(c[0])), int(round(c[1]))
        r = h + pad
        if iu - r < 0 or iv - r < 0 or iu + r + 1 > W or iv + r + 1 > H:
            return np.full(2, np.nan)
        patch = cv2.GaussianBlur(gray[iv - r: iv + r + 1, iu - r: iu + r + 1], (0, 0), sigma)
        z = patch[pad: pad + 2 * h + 1, pad: pad + 2 * h + 1].astype(float).ravel()
        ys, xs = np.mgrid[-h: h + 1, -h: h + 1]
        x = xs.ravel().astype(float)
        y = ys.ravel().astype(float)
        m = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=1)
        p, *_ = np.linalg.lstsq(m, z, rcond=None)
        hess = np.array([[2 * p[3], p[4]], [p[4], 2 * p[5]]])
        if np.linalg.det(hess) >= 0:
            return np.full(2, np.nan)
        off = np.linalg.solve(hess, -p[1:3])
        if np.hypot(*off) > h:
            return np.full(2, np.nan)
        c = np.array([iu + off[0], iv + off[1]])
    return c


def refine_opencv(gray: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """Sub-pixel centre by ``cv2.cornerSubPix`` with a window inside the disc (comparison).

    Returns
    -------
    (2,) float64
        ``[u, v]`` px.
    """
    h = max(2, int(0.6 * radius))
    pts = np.asarray(centre, dtype=np.float32).reshape(1, 1, 2).copy()
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 1e-4)
    out = cv2.cornerSubPix(gray, pts, (h, h), (-1, -1), crit)
    return out.reshape(2).astype(float)


def _local_maxima(resp: np.ndarray, threshold: float, min_distance: int) -> np.ndarray:
    """(K, 2) integer ``[u, v]`` of local maxima of ``resp`` above ``threshold``,
    strongest first."""
    k = 2 * min_distance + 1
    dil = cv2.dilate(resp, np.ones((k, k), np.uint8))
    vs, us = np.nonzero((resp >= dil) & (resp > threshold))
    order = np.argsort(-resp[vs, us])
    return np.stack([us[order], vs[order]], axis=1)


def _examine(gray: np.ndarray, starts: np.ndarray, radius: np.ndarray, contrast: np.ndarray,
             config: TargetConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Refine and check N candidates together: each step is taken by the candidates still
    alive, those failing it dropped.

    Parameters
    ----------
    gray : (H, W) float32
    starts : (N, 2) float
        Candidate positions ``[u, v]``, px.
    radius, contrast : (N,) float
        :func:`target_radius` at ``starts`` (the first look), px and [0, 1].
    config : TargetConfig

    Returns
    -------
    centres : (N, 2) float64
        Refined centres, px; NaN rows for the candidates rejected.
    radius, contrast, symmetry : (N,) float64
        Each target's radius (px), contrast ([0, 1]) and larger symmetry error at its
        centre (NaN where rejected).
    """
    n = len(starts)
    centres = np.full((n, 2), np.nan)
    out_r, out_con, sym = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    alive = np.flatnonzero(np.isfinite(radius) & (contrast >= config.min_contrast))
    c = refine_gradients([gray] * alive.size, starts[alive], radius[alive], config.refine_iterations)
    ok = np.isfinite(c).all(axis=1)
    ok[ok] = np.hypot(*(c[ok] - starts[alive[ok]]).T) <= 0.5 * radius[alive[ok]]
    alive, c = alive[ok], c[ok]
    r, con = target_radii([gray] * alive.size, c, config)
    ok = np.isfinite(r)
    ok[ok] = (r[ok] >= config.min_radius_px) & (r[ok] <= config.max_radius_px) & (con[ok] >= config.min_contrast)
    alive, c, r, con = alive[ok], c[ok], r[ok], con[ok]
    c, errors = refine_centres_and_symmetry([gray] * alive.size, c, r, config.refine_iterations)
    ok = np.isfinite(c).all(axis=1)
    alive, c, r, con, errors = alive[ok], c[ok], r[ok], con[ok], errors[ok]
    unmeasured = np.flatnonzero(np.isnan(errors[:, 0]))
    errors[unmeasured] = symmetry_errors_each([gray] * unmeasured.size, c[unmeasured], r[unmeasured])
    worst = errors.max(axis=1)
    ok = ~(worst > config.max_symmetry_error)
    alive = alive[ok]
    centres[alive], out_r[alive], out_con[alive], sym[alive] = c[ok], r[ok], con[ok], worst[ok]
    return centres, out_r, out_con, sym


def detect_targets(frame: np.ndarray, config: TargetConfig = TargetConfig(),
                   roi: tuple[int, int, int, int] | None = None) -> Detections:
    """Find the quadrant targets in a frame.

    Parameters
    ----------
    frame : (H, W) or (H, W, C) array
        A frame (grey or colour, any of uint8, uint16, float in [0, 1]).
    config : TargetConfig
    roi : (u0, v0, u1, v1), optional
        Look only inside this pixel rectangle (positions are still full-frame).

    Returns
    -------
    Detections
        Every target found, sorted by ``v`` then ``u``; possibly empty.
    """
    gray = to_gray(frame)
    u0 = v0 = 0
    if roi is not None:
        u0, v0, u1, v1 = (int(x) for x in roi)
        u0, v0 = max(u0, 0), max(v0, 0)
        sub = gray[v0:v1, u0:u1]
    else:
        sub = gray
    if sub.size == 0:
        return _empty()
    resp = np.max([saddle_response(sub, s) for s in config.sigmas_px], axis=0)
    # an ideal X-corner of contrast C gives about (C / (2 pi))^2 * 4 at any scale;
    # accept a fifth of that for the weakest contrast we look for
    threshold = 0.2 * (config.min_contrast / np.pi) ** 2
    cand = _local_maxima(resp, threshold, max(2, int(config.min_radius_px)))[: config.max_candidates]
    starts = cand.astype(float) + np.array([u0, v0], dtype=float)
    # the first look at every candidate at once; most are the background's corners
    radius, contrast = _radii_of_many(gray, starts, config)
    centres, radius, contrast, sym = _examine(gray, starts, radius, contrast, config)
    kept = _first_of_each(starts, centres, radius)
    if not kept.size:
        return _empty()
    order = kept[np.lexsort((centres[kept, 0], centres[kept, 1]))]
    return Detections(
        centres=centres[order],
        radii=radius[order],
        orientations=orientations([gray] * order.size, centres[order], radius[order]),
        contrasts=contrast[order],
        symmetry=sym[order],
    )


def _first_of_each(starts: np.ndarray, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """Indices of the targets kept, strongest candidate first: a candidate whose start
    (px) or refined centre (px) lies within ``max(2, radius / 2)`` of a target kept
    before it is the same target; NaN ``centres`` rows are rejected candidates."""
    kept: list[int] = []
    for k in range(len(starts)):
        if not np.isfinite(centres[k, 0]):
            continue
        if kept:
            reach = np.maximum(2.0, 0.5 * radii[kept])
            if (np.hypot(*(starts[k] - centres[kept]).T) < reach).any() or \
                    (np.hypot(*(centres[k] - centres[kept]).T) < reach).any():
                continue
        kept.append(k)
    return np.array(kept, dtype=int)


class QuadrantTargetDetector(Detector):
    """Quadrant targets in a frame (:func:`detect_targets`), as a :class:`video.detector.Detector`.

    ``quality`` is ``1 - symmetry / config.max_symmetry_error``: 1 for a perfect quadrant
    pattern, 0 for one at the edge of acceptance. ``found`` is the :class:`Detections`.
    """

    kind = "quadrant target"

    def __init__(self, config: TargetConfig = TargetConfig(), roi: tuple[int, int, int, int] | None = None):
        self.config, self.roi = config, roi

    def detect(self, frame: np.ndarray) -> Candidates:
        det = detect_targets(frame, self.config, self.roi)
        return self._candidates(det.centres, 1.0 - det.symmetry / self.config.max_symmetry_error, det)


def _empty() -> Detections:
    z = np.zeros(0)
    return Detections(np.zeros((0, 2)), z, z.copy(), z.copy(), z.copy())


def _gradient_kernels(smooth_sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Kernels K_u, K_v with ``g_u(q) = sum_p n_p K_u(q - p)``: Gaussian smoothing then
    the central difference of ``refine_gradient`` (odd-sized, centred)."""
    r = int(np.ceil(4 * smooth_sigma)) + 1
    x = np.arange(-r, r + 1, dtype=float)
    g = np.exp(-0.5 * (x / smooth_sigma) ** 2)
    g /= g.sum()
    dg = np.zeros_like(g)
    dg[:-1] += 0.5 * g[1:]   # G(t + 1) / 2
    dg[1:] -= 0.5 * g[:-1]   # - G(t - 1) / 2
    return np.outer(g, dg), np.outer(dg, g)


def centre_sigma(gray: np.ndarray, centre: np.ndarray, radius: float, noise_sigma: float,
                 smooth_sigma: float | None = None, floor_px: float = 0.01) -> float:
    """One-sigma uncertainty of a ``refine_gradient`` centre per image axis, px.

    Linearises the gradient-orthogonality solution ``A c = b`` in the image noise:
    ``dc = A^-1 sum_q w_q (e_q I + g_q (q - c)^T) dg_q`` with ``e_q = g_q . (q - c)``,
    and each smoothed gradient ``dg_q`` a known linear filter of the pixel noise, so the
    variance is ``noise^2 sum_p F(p)^2`` with ``F`` the filters correlated with the
    weight fields (first order, smoothing correlations included), times ``1 + 1.5 /
    radius`` for the iterated window. Returns ``sqrt(trace(cov) / 2)`` combined with a
    floor for the drawing's own error.

    Parameters
    ----------
    gray : (H, W) float32
        Grey image in [0, 1].
    centre : (2,) float
        Refined centre, px.
    radius : float
        Disc radius, px.
    noise_sigma : float
        Image noise (white), grey levels of [0, 1].
    smooth_sigma : float, optional
        The pre-smoothing ``refine_gradient`` used, px (default the same as its).
    floor_px : float
        Added in quadrature, px.

    Returns
    -------
    float
        px (NaN if the window leaves the image).
    """
    if smooth_sigma is None:
        smooth_sigma = gradient_smoothing(radius)
    c = np.asarray(centre, dtype=float)
    h = int(np.ceil(0.75 * radius)) + 2
    H, W = gray.shape
    iu, iv = int(round(c[0])), int(round(c[1]))
    if iu - h - 1 < 0 or iv - h - 1 < 0 or iu + h + 2 > W or iv + h + 2 > H:
        return float("nan")
    patch = gray[iv - h - 1: iv + h + 2, iu - h - 1: iu + h + 2]
    patch = cv2.GaussianBlur(patch, (0, 0), smooth_sigma)
    gu = ((patch[1:-1, 2:] - patch[1:-1, :-2]) * 0.5).astype(float)
    gv = ((patch[2:, 1:-1] - patch[:-2, 1:-1]) * 0.5).astype(float)
    ys, xs = np.mgrid[-h: h + 1, -h: h + 1]
    du = xs + iu - c[0]
    dv = ys + iv - c[1]
    d2 = du * du + dv * dv
    sw = 0.35 * radius
    w = np.exp(-d2 / (2 * sw * sw)) * (d2 <= (0.75 * radius) ** 2)
    a = np.array([[np.sum(w * gu * gu), np.sum(w * gu * gv)],
                  [np.sum(w * gu * gv), np.sum(w * gv * gv)]])
    try:
        ai = np.linalg.inv(a)
    except np.linalg.LinAlgError:
        return float("nan")
    e = gu * du + gv * dv
    # N(q) = w (e I + g (q - c)^T): rows i, columns j (the gradient component)
    n = {(0, 0): w * (e + gu * du), (0, 1): w * gu * dv,
         (1, 0): w * gv * du, (1, 1): w * (e + gv * dv)}
    ku, kv = _gradient_kernels(smooth_sigma)
    pad = ku.shape[0] // 2 + 1
    var = 0.0
    for i in range(2):
        f = np.zeros((2 * (h + pad) + 1,) * 2)
        for j, k in ((0, ku), (1, kv)):
            pij = ai[i, 0] * n[(0, j)] + ai[i, 1] * n[(1, j)]
            big = np.zeros_like(f)
            big[pad:-pad, pad:-pad] = pij
            f += cv2.filter2D(big, -1, k, borderType=cv2.BORDER_CONSTANT)
        var += float(np.sum(f * f))
    # the re-centred weight window adds a little (Monte Carlo on synthetic targets of
    # radius 5-30 px; tests/test_video_targets.py)
    s = (1.0 + 1.5 / radius) * noise_sigma * np.sqrt(var / 2.0)
    return float(np.hypot(s, floor_px))
