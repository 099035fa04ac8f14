"""The roof edge at the top of the windscreen, tracked through the film.

The roof edge does not deform in a frontal crash. Its corner is the intersection of two
straight edges fitted to sub-pixel edge points: the roof line and the windscreen line;
the roof line's angle turns with the car's pitch. Positions are image px (u right,
v down).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from .calibrate_profile import edge_centroids, sample, to_gray
from .errors import VideoError


SYSTEMATIC_PX = 0.1  # px, added in quadrature to the corner's uncertainty


@dataclass(frozen=True)
class Corner:
    """The roof-edge corner in one frame.

    Attributes
    ----------
    uv : (2,) px
        Sub-pixel corner position (NaN if not found).
    cov : (2, 2) px^2
        Its covariance.
    roof_dir, screen_dir : (2,) unit vectors
        Fitted directions of the roof and windscreen edges, pointing away from the corner.
    n_points : int
        Edge points used.
    roof_angle_sigma, screen_angle_sigma : float
        One-sigma uncertainties of the two edges' directions, rad.
    """

    uv: np.ndarray
    cov: np.ndarray
    roof_dir: np.ndarray
    screen_dir: np.ndarray
    n_points: int
    roof_angle_sigma: float = float("nan")
    screen_angle_sigma: float = float("nan")

    @property
    def found(self) -> bool:
        """Whether the corner was found in this frame."""
        return bool(np.all(np.isfinite(self.uv)))


@dataclass(frozen=True)
class EdgeTrack:
    """A point tracked through frames.

    Attributes
    ----------
    uv : (n, 2) px
        Position per frame; NaN where lost.
    sigma : (n, 2) px
        One-sigma uncertainty of u and v per frame; NaN where lost.
    lost : (n,) bool
    notes : tuple of str
    angle, angle_sigma : (n,) rad or None
        For the roof edge: the image angle of the roof line (``atan2(dv, du)`` of its
        direction leaving the corner) in the first frame, plus the body's turn since
        then (the weighted mean of the roof line's and the windscreen line's turns; it
        follows the car's pitch), and its sigma. NaN where lost.
    """

    uv: np.ndarray
    sigma: np.ndarray
    lost: np.ndarray
    notes: tuple
    angle: np.ndarray | None = None
    angle_sigma: np.ndarray | None = None


def _edge_points(gray: np.ndarray, corner: np.ndarray, direction: np.ndarray,
                 other: np.ndarray, reach: float, half_width: float) -> np.ndarray:
    """Sub-pixel points (N, 2) px of a straight edge leaving ``corner`` along
    ``direction``, from where the other edge (leaving along ``other``) is out of the
    search window, every px for ``reach`` px."""
    normal = np.array([-direction[1], direction[0]])
    step = 0.25
    t = np.arange(-half_width, half_width + step, step)
    sin_a = max(abs(direction[0] * other[1] - direction[1] * other[0]), 0.2)
    start = max(3.0, (half_width + 2.0) / sin_a)
    ds = np.arange(start, start + reach + 1e-9, 1.0)
    grid = (corner[None, None, :] + ds[:, None, None] * direction[None, None, :]
            + t[None, :, None] * normal[None, None, :])
    prof = sample(gray, grid)
    ok = ~np.isnan(prof).any(axis=1)
    if ok.sum() < 3:
        return np.empty((0, 2))
    ds, prof = ds[ok], prof[ok]
    g = np.abs(np.gradient(prof, step, axis=1))
    g[:, :4] = 0.0  # an edge must lie inside the window, not at its border
    g[:, -4:] = 0.0
    i_peak = np.argmax(g, axis=1)
    strength = g[np.arange(len(ds)), i_peak]
    pos = edge_centroids(t, g, i_peak, 16)
    keep = np.isfinite(pos)
    if keep.sum() < 3:
        return np.empty((0, 2))
    ds, pos, strength = ds[keep], pos[keep], strength[keep]
    p = corner + ds[:, None] * direction + pos[:, None] * normal
    return p[strength > 0.4 * np.median(strength)]


def _fit_line(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Total least squares with one outlier pass: (point, unit dir, rms, kept points)."""
    for _ in range(2):
        m = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - m, full_matrices=False)
        res = (pts - m) @ vt[1]
        mad = 1.4826 * np.median(np.abs(res))
        keep = np.abs(res) <= max(3 * mad, 0.2)
        if keep.all() or keep.sum() < 5:
            break
        pts = pts[keep]
    m = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - m, full_matrices=False)
    res = (pts - m) @ vt[1]
    rms = float(np.sqrt(np.sum(res ** 2) / max(len(pts) - 2, 1)))
    return m, vt[0], rms, pts


def locate_corner(frame: np.ndarray, guess: np.ndarray, roof_dir: np.ndarray,
                  screen_dir: np.ndarray, *, reach_px: float = 40.0,
                  search_px: float = 6.0, frame_index: int = 0) -> Corner:
    """Sub-pixel position of the roof edge at the top of the windscreen in one frame.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
    guess : (2,) px
        Approximate corner (within ``search_px`` of the edges).
    roof_dir, screen_dir : (2,)
        Approximate directions of the roof edge and of the windscreen edge, pointing
        away from the corner (from the silhouette fit).
    reach_px : float
        Length of each edge used, px (longer is better: a short line's tilt error moves
        the corner; :func:`roof_edge_start` suggests one).
    search_px : float
        How far across each edge it is looked for, px.
    frame_index : int
        For messages.

    Returns
    -------
    Corner
        NaN position when either edge shows fewer than 6 points or is not straight
        (RMS scatter over 1 px).
    """
    gray = to_gray(frame, frame_index=frame_index)
    c = np.asarray(guess, float)
    dirs = [np.asarray(roof_dir, float), np.asarray(screen_dir, float)]
    dirs = [d / np.linalg.norm(d) for d in dirs]
    nan = Corner(np.full(2, np.nan), np.full((2, 2), np.nan), dirs[0], dirs[1], 0)
    for _ in range(3):  # re-centre on the found corner, then measure again
        lines = []
        for d, o in ((dirs[0], dirs[1]), (dirs[1], dirs[0])):
            pts = _edge_points(gray, c, d, o, reach_px, search_px)
            if len(pts) < 6:
                return nan
            lines.append(_fit_line(pts))
        (m1, d1, r1, p1), (m2, d2, r2, p2) = lines
        if max(r1, r2) > 1.0:  # not two straight edges: something else is there
            return nan
        n1, n2 = np.array([-d1[1], d1[0]]), np.array([-d2[1], d2[0]])
        nmat = np.array([n1, n2])
        if abs(np.linalg.det(nmat)) < 0.1:
            return nan
        new = np.linalg.solve(nmat, np.array([n1 @ m1, n2 @ m2]))
        # keep the directions pointing away from the corner
        dirs = [d1 if d1 @ dirs[0] > 0 else -d1, d2 if d2 @ dirs[1] > 0 else -d2]
        c = new

    # edge points 1 px apart share background texture and pixels: count about one
    # independent point per 4 px (variances x 4)
    corr = 4.0

    def offset_var(m, d, rms, pts):
        s = (pts - m) @ d
        sc = (c - m) @ d
        return corr * max(rms, 0.05) ** 2 * (1.0 / len(pts)
                                             + sc ** 2 / max(np.sum(s ** 2), 1e-9))

    ninv = np.linalg.inv(nmat)
    cov = ninv @ np.diag([offset_var(m1, d1, r1, p1), offset_var(m2, d2, r2, p2)]) @ ninv.T
    # plus a floor for what the residuals do not show: edges placed ~0.1 px off by the
    # pixel grid and the background just outside them (measured on rendered films)
    cov = cov + SYSTEMATIC_PX ** 2 * np.eye(2)
    s1 = (p1 - m1) @ d1
    ang_sig = np.sqrt(corr) * max(r1, 0.05) / np.sqrt(max(np.sum(s1 ** 2), 1e-9))
    s2 = (p2 - m2) @ d2
    ang_sig2 = np.sqrt(corr) * max(r2, 0.05) / np.sqrt(max(np.sum(s2 ** 2), 1e-9))
    return Corner(c, cov, dirs[0], dirs[1], len(p1) + len(p2), float(ang_sig),
                  float(ang_sig2))


def roof_edge_start(polygon_px: np.ndarray, windscreen_top_px: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Start of the roof-edge track from a fitted outline.

    Parameters
    ----------
    polygon_px : (N, 2) px
        Fitted outline (``SilhouetteFit.polygon_px``).
    windscreen_top_px : (2,) px
        Its windscreen-top point (a vertex of the outline).

    Returns
    -------
    guess : (2,) px
    roof_dir, screen_dir : (2,) unit vectors
        Directions of the outline's edges leaving that vertex: the flatter one is the
        roof, the steeper the windscreen.
    reach_px : float
        Length of edge to use on each side (most of the shorter of the two outline
        edges, after the part next to the corner that is skipped), px.
    """
    poly = np.asarray(polygon_px, float)
    i = int(np.argmin(np.linalg.norm(poly - windscreen_top_px, axis=1)))
    a = poly[i - 1] - poly[i]
    b = poly[(i + 1) % len(poly)] - poly[i]
    la, lb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    a, b = a / la, b / lb
    roof, screen = (a, b) if abs(a[1]) < abs(b[1]) else (b, a)
    reach = max(10.0, 0.85 * min(la, lb) - 16.0)
    return poly[i].copy(), roof, screen, reach


def track_roof_edge(frames: Iterable[np.ndarray], guess: np.ndarray, roof_dir: np.ndarray,
                    screen_dir: np.ndarray, *, reach_px: float = 40.0,
                    search_px: float = 6.0, first_index: int = 0) -> EdgeTrack:
    """Track the roof-edge corner (top of the windscreen) through frames.

    Parameters
    ----------
    frames : iterable of (H, W) or (H, W, 3) uint8
        Consecutive frames, streamed.
    guess : (2,) px
        Approximate corner in the first frame (:func:`roof_edge_start`).
    roof_dir, screen_dir : (2,)
        Approximate edge directions leaving the corner.
    reach_px, search_px : float
        See :func:`locate_corner`.
    first_index : int
        Film index of the first frame, for notes.

    Returns
    -------
    EdgeTrack
        Lost frames are NaN and listed in a note; the track resumes from the last
        known position when the corner shows again.
    """
    uv, sig, lost, ang = [], [], [], []
    pos = np.asarray(guess, float)
    vel = np.zeros(2)
    dirs = (np.asarray(roof_dir, float), np.asarray(screen_dir, float))
    last = None
    for k, frame in enumerate(frames):
        pred = pos + vel
        c = locate_corner(frame, pred, dirs[0], dirs[1], reach_px=reach_px,
                          search_px=search_px, frame_index=first_index + k)
        if c.found and np.linalg.norm(c.uv - pred) < 2 * search_px:
            if last is not None:
                vel = c.uv - last
            last = c.uv
            pos = c.uv
            dirs = (c.roof_dir, c.screen_dir)
            uv.append(c.uv)
            sig.append(np.sqrt(np.diag(c.cov)))
            lost.append(False)
            ang.append((np.arctan2(c.roof_dir[1], c.roof_dir[0]), c.roof_angle_sigma,
                        np.arctan2(c.screen_dir[1], c.screen_dir[0]), c.screen_angle_sigma))
        else:
            uv.append(np.full(2, np.nan))
            sig.append(np.full(2, np.nan))
            lost.append(True)
            ang.append((np.nan,) * 4)
            pos = pred
    if not uv:
        raise VideoError("no frames given to track the roof edge; pass the film's frames")
    lost = np.array(lost)
    notes = ()
    if lost.any():
        idx = np.flatnonzero(lost) + first_index
        notes = (f"roof edge lost in {lost.sum()} frame(s) ({ranges_text(idx)}): NaN there",)
    angle, angle_sigma = _body_turn(np.array(ang))
    return EdgeTrack(np.array(uv), np.array(sig), lost, notes, angle, angle_sigma)


def _body_turn(ang: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roof-line angle per frame, its turn since the first frame refined by the
    windscreen line's turn (both turn with the body): weighted mean of the two turns.

    ``ang`` (n, 4): roof angle, its sigma, windscreen angle, its sigma (NaN rows: lost).
    Returns (angle, sigma), rad."""
    out = np.full(len(ang), np.nan)
    sig = np.full(len(ang), np.nan)
    ok = np.isfinite(ang).all(axis=1)
    if not ok.any():
        return out, sig
    roof = np.unwrap(ang[ok, 0])
    screen = np.unwrap(ang[ok, 2])
    w1, w2 = 1.0 / ang[ok, 1] ** 2, 1.0 / ang[ok, 3] ** 2
    turn = (w1 * (roof - roof[0]) + w2 * (screen - screen[0])) / (w1 + w2)
    out[ok] = roof[0] + turn
    sig[ok] = 1.0 / np.sqrt(w1 + w2)
    return out, sig


def ranges_text(idx: np.ndarray) -> str:
    """'3-7, 12' for [3, 4, 5, 6, 7, 12]."""
    out, start = [], idx[0]
    for a, b in zip(idx[:-1], idx[1:]):
        if b != a + 1:
            out.append(f"{start}-{a}" if a != start else f"{start}")
            start = b
    out.append(f"{start}-{idx[-1]}" if idx[-1] != start else f"{start}")
    return ", ".join(out)
