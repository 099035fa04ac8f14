"""Sub-pixel intensity profiles and edge positions along lines (shared by the tape,
silhouette, roof-edge and front-end measurements).

All positions are image pixels (u right, v down, (0, 0) the centre of the top-left
pixel), distances along a line in px.
"""

from __future__ import annotations

import cv2
import numpy as np

from .errors import VideoError


def to_gray(frame: np.ndarray, *, frame_index: int | None = None) -> np.ndarray:
    """Return a frame as a float32 grayscale image.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8 (BGR) or float array
        The image.
    frame_index : int, optional
        Used in the error message only.

    Returns
    -------
    (H, W) float32
        Intensity, in the frame's units (0-255 for uint8).
    """
    where = f"frame {frame_index}" if frame_index is not None else "the frame"
    a = np.asarray(frame)
    if a.ndim == 3 and a.shape[2] == 3:
        a = cv2.cvtColor(a if a.dtype == np.uint8 else a.astype(np.float32),
                         cv2.COLOR_BGR2GRAY)
    elif a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    if a.ndim != 2:
        raise VideoError(f"{where} has shape {np.shape(frame)}, expected (H, W) grayscale "
                         "or (H, W, 3) BGR; pass one image at a time")
    if a.shape[0] < 8 or a.shape[1] < 8:
        raise VideoError(f"{where} is only {a.shape[1]}x{a.shape[0]} px; "
                         "pass the full film frame")
    return a.astype(np.float32)


def sample(gray: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear samples of an image at sub-pixel points.

    Parameters
    ----------
    gray : (H, W) float32
    points : (..., 2) float array of [u, v], px

    Returns
    -------
    (...) float32
        Intensities; points outside the image read NaN.
    """
    p = np.asarray(points, dtype=np.float32)
    shape = p.shape[:-1]
    flat = p.reshape(-1, 2)
    n = len(flat)
    cols = 4096  # cv2.remap takes maps narrower than 32767
    rows = max(1, -(-n // cols))
    maps = np.full((rows * cols, 2), -10.0, np.float32)
    maps[:n] = flat
    mu = np.ascontiguousarray(maps[:, 0]).reshape(rows, cols)
    mv = np.ascontiguousarray(maps[:, 1]).reshape(rows, cols)
    out = cv2.remap(np.ascontiguousarray(gray, dtype=np.float32), mu, mv, cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT, borderValue=float("nan"))
    h, w = gray.shape
    outside = (flat[:, 0] < 0) | (flat[:, 0] > w - 1) | (flat[:, 1] < 0) | (flat[:, 1] > h - 1)
    out = out.reshape(-1)[:n].copy()
    out[outside] = np.nan
    return out.reshape(shape)


def line_profile(gray: np.ndarray, origin: np.ndarray, axis: np.ndarray, s: np.ndarray,
                 offsets: np.ndarray) -> np.ndarray:
    """Mean intensity along a line, averaged over parallel lines.

    Parameters
    ----------
    gray : (H, W) float32
    origin : (2,) px
        A point of the line.
    axis : (2,) unit vector
        Direction of the line; the parallel lines are offset along its normal
        ``[-axis[1], axis[0]]``.
    s : (n,) px
        Positions along the line where the profile is sampled.
    offsets : (m,) px
        Normal offsets of the parallel lines averaged.

    Returns
    -------
    (n,) float
        Mean intensity at each ``s`` (NaN where any sample falls outside the image).
    """
    axis = np.asarray(axis, float)
    normal = np.array([-axis[1], axis[0]])
    pts = (np.asarray(origin, float)[None, None, :]
           + np.asarray(s, float)[None, :, None] * axis[None, None, :]
           + np.asarray(offsets, float)[:, None, None] * normal[None, None, :])
    vals = sample(gray, pts)
    return vals.mean(axis=0)


def edge_centroid(s: np.ndarray, grad: np.ndarray, i_peak: int, half: int) -> float:
    """Sub-pixel position of an edge: the centroid of its gradient peak.

    The window is centred on the middle of the peak's half-maximum span and symmetric
    (a clean anti-aliased edge spreads its gradient over ~2 px; a blurred one over its
    half-maximum width), so that texture on one side of the edge does not pull it.

    Parameters
    ----------
    s : (n,) px
        Sample positions (uniform step).
    grad : (n,)
        Derivative of the profile, with the sign chosen so that the edge is a positive
        peak.
    i_peak : int
        Index of the peak sample.
    half : int
        Largest half-width of the window, samples.

    Returns
    -------
    float
        Edge position, px along ``s``; NaN if the peak is not positive.
    """
    peak = grad[i_peak]
    if not np.isfinite(peak) or peak <= 0:
        return float("nan")
    step = s[1] - s[0]
    a = i_peak
    while a - 1 >= 0 and grad[a - 1] > 0.5 * peak:
        a -= 1
    b = i_peak
    while b + 1 < len(s) and grad[b + 1] > 0.5 * peak:
        b += 1
    mid = 0.5 * (a + b)
    hw = min(max(1.5 / step, 1.0 * (b - a) + 1.0 / step), max(half, 1))
    lo = max(0, int(np.ceil(mid - hw)))
    hi = min(len(s) - 1, int(np.floor(mid + hw)))
    w = grad[lo:hi + 1]
    tot = w.sum()
    if tot <= 0.2 * peak * step:
        return float(s[i_peak])
    return float(np.sum(w * s[lo:hi + 1]) / tot)


def find_edge(s: np.ndarray, profile: np.ndarray, sign: int, window: tuple[float, float],
              half: int | None = None) -> tuple[float, float]:
    """The strongest edge of a given sign in a window of a profile, to sub-pixel.

    Parameters
    ----------
    s : (n,) px, uniform step
    profile : (n,)
        Intensity along ``s``.
    sign : +1, -1 or 0
        +1 for dark-to-light with growing ``s``, -1 light-to-dark, 0 either.
    window : (lo, hi) px
        Range of ``s`` searched.
    half : int, optional
        Half-width of the centroid window, samples (default: a quarter of the window).

    Returns
    -------
    position : float
        px along ``s`` (NaN if no edge).
    strength : float
        Gradient at the peak, intensity per px (>= 0).
    """
    step = s[1] - s[0]
    g = np.gradient(profile, step)
    if sign == 0:
        g = np.abs(g)
    else:
        g = sign * g
    sel = np.flatnonzero((s >= window[0]) & (s <= window[1]) & np.isfinite(g))
    if sel.size < 3:
        return float("nan"), 0.0
    i = sel[np.argmax(g[sel])]
    if half is None:
        half = max(2, sel.size // 4)
    pos = edge_centroid(s, np.nan_to_num(g, nan=0.0), int(i), half)
    return pos, float(max(g[i], 0.0))



def edge_centroids(s: np.ndarray, grad: np.ndarray, i_peak: np.ndarray,
                   half: int) -> np.ndarray:
    """:func:`edge_centroid` for many profiles at once.

    Parameters
    ----------
    s : (n,) px, uniform step
    grad : (R, n)
        Derivatives, the edge a positive peak in each row.
    i_peak : (R,) int
        Peak index per row.
    half : int
        Largest half-width of the window, samples.

    Returns
    -------
    (R,) px
        Edge positions (NaN where the peak is not positive).
    """
    g = np.asarray(grad, float)
    r, n = g.shape
    rows = np.arange(r)
    ip = np.asarray(i_peak, int)
    peak = g[rows, ip]
    step = s[1] - s[0]
    idx = np.arange(n)[None, :]
    below = g <= 0.5 * peak[:, None]
    a = np.where(below & (idx < ip[:, None]), idx, -1).max(axis=1) + 1
    b = np.where(below & (idx > ip[:, None]), idx, n).min(axis=1) - 1
    mid = 0.5 * (a + b)
    hw = np.minimum(np.maximum(1.5 / step, (b - a) + 1.0 / step), max(half, 1))
    lo = np.maximum(0, np.ceil(mid - hw)).astype(int)
    hi = np.minimum(n - 1, np.floor(mid + hw)).astype(int)
    win = (idx >= lo[:, None]) & (idx <= hi[:, None])
    w = np.where(win, g, 0.0)
    tot = w.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        pos = (w * s[None, :]).sum(axis=1) / tot
    pos = np.where(tot <= 0.2 * peak * step, s[ip], pos)
    return np.where(np.isfinite(peak) & (peak > 0), pos, np.nan)
