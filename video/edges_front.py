"""The car's front end, the barrier face and the crush.

The front end is the most forward sub-pixel edge of the outline in a band of rows below
the bonnet; it cannot be seen past the barrier face (it folds there), so the crush is
measured by carrying the undeformed front with the rigid passenger cell (the roof edge).
Positions are image px; the crush is in m.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np

from .calibrate_profile import edge_centroids, find_edge, sample, to_gray
from .edges_roof import SYSTEMATIC_PX, EdgeTrack, ranges_text
from .errors import VideoError


@dataclass(frozen=True)
class FrontEnd:
    """The car's front end in one frame.

    Attributes
    ----------
    u : float
        Sub-pixel column of the most forward point, px (NaN if not found).
    v : float
        Row of that point, px (between rows when the nose's flanks were intersected).
    sigma : float
        One-sigma uncertainty of ``u``, px.
    """

    u: float
    v: float
    sigma: float

    @property
    def found(self) -> bool:
        """Whether the front end was found."""
        return bool(np.isfinite(self.u))


@dataclass(frozen=True)
class BarrierFace:
    """The barrier face's column in the image.

    Attributes
    ----------
    u, sigma : float
        Sub-pixel column and its one-sigma uncertainty, px.
    step : float
        Intensity step across the face (levels).
    """

    u: float
    sigma: float
    step: float


def locate_front_end(frame: np.ndarray, direction: int, rows: tuple[float, float],
                     guess_u: float, *, search_px: float = 15.0, polarity: int = 0,
                     frame_index: int = 0) -> FrontEnd:
    """The car's front end in one frame: its most forward outline edge in a band of rows.

    Before contact this is the bumper's leading edge. From contact on, the visible front
    is where the car meets the barrier face (or the barrier's own edge where the barrier
    stands nearer the camera): use :func:`crush_from_body` for the crush. Choose the
    band wide enough for the nose to stay in it as the car pitches.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
    direction : +1 or -1
        Direction of travel in the image (+1 to the right).
    rows : (v_top, v_bottom) px
        Band of rows between the bonnet's front and the bumper's bottom.
    guess_u : float
        Approximate front position, px.
    search_px : float
        Half-width of the search window around the guess, px.
    polarity : +1, -1 or 0
        Sign of the intensity change crossing the front end in the travel direction
        (-1: light body against a darker background); 0 takes the strongest edge.
    frame_index : int
        For messages.

    Returns
    -------
    FrontEnd
        NaN when fewer than three rows show an edge.
    """
    if direction not in (1, -1):
        raise VideoError(f"direction {direction!r} must be +1 (left-to-right) or -1")
    gray = to_gray(frame, frame_index=frame_index)
    v0, v1 = sorted(rows)
    vs = np.arange(np.ceil(v0), np.floor(v1) + 1)
    s = np.arange(-search_px, search_px + 0.25, 0.25)
    grid = np.stack(np.broadcast_arrays(guess_u + direction * s[None, :], vs[:, None]), axis=-1)
    prof = sample(gray, grid)
    g = np.gradient(np.nan_to_num(prof), 0.25, axis=1)
    g = np.abs(g) if polarity == 0 else polarity * g
    g[:, :4] = 0.0
    g[:, -4:] = 0.0
    ip = np.argmax(g, axis=1)
    st = g[np.arange(len(vs)), ip]
    pos = edge_centroids(s, g, ip, 16)
    st = np.where(np.isnan(prof).any(axis=1) | ~np.isfinite(pos), 0.0, st)
    us = np.where(st > 0, guess_u + direction * pos, np.nan)
    ok = np.isfinite(us) & (st > 0.4 * np.max(st)) if np.any(st > 0) else np.zeros(len(vs), bool)
    if ok.sum() < 3:
        return FrontEnd(float("nan"), float("nan"), float("nan"))
    u, v = us[ok], vs[ok]
    med = np.array([np.median(u[max(0, i - 1):i + 2]) for i in range(len(u))])
    j = int(np.argmax(direction * med))
    noise = float(np.median(np.abs(np.diff(u))) * 1.4826 / np.sqrt(2)) if len(u) > 3 else 0.1
    apex = _apex(direction * u, v, j)
    if apex is not None:
        f, va, res = apex
        # the flank fits' scatter over the ~4 rows each side, and a 0.1 px floor
        sigma = float(np.hypot(res / np.sqrt(4.0), SYSTEMATIC_PX))
        return FrontEnd(float(direction * f), float(va), sigma)
    return FrontEnd(float(med[j]), float(v[j]), float(np.hypot(noise, SYSTEMATIC_PX)))


def _apex(f: np.ndarray, v: np.ndarray, j: int, k: int = 4
          ) -> tuple[float, float, float] | None:
    """The nose's most forward point between rows: where a line through the rows above
    the most forward row meets a line through the rows below it.

    ``f`` is the forward coordinate per row (larger is further forward). Returns
    (forward coordinate, row, RMS residual of the flank fits), or None when the flanks
    do not make a nose within a row of ``v[j]`` (a flat face: the row value stands)."""
    lo, hi = max(0, j - k), min(len(v), j + k + 1)
    if j - lo < 2 or hi - j < 3:
        return None
    b1, a1 = np.polyfit(v[lo:j + 1], f[lo:j + 1], 1)
    b2, a2 = np.polyfit(v[j:hi], f[j:hi], 1)
    if not (b1 > 0.05 and b2 < -0.05):
        return None
    vs = (a2 - a1) / (b1 - b2)
    if abs(vs - v[j]) > 1.0:
        return None
    res = np.concatenate([f[lo:j + 1] - (a1 + b1 * v[lo:j + 1]), f[j:hi] - (a2 + b2 * v[j:hi])])
    return a1 + b1 * vs, vs, float(np.sqrt(np.mean(res ** 2)))


def track_front_end(frames: Iterable[np.ndarray], direction: int, rows: tuple[float, float],
                    guess_u: float, *, search_px: float = 15.0, polarity: int = 0,
                    first_index: int = 0) -> EdgeTrack:
    """The front end's column through frames (constant-velocity prediction).

    Parameters
    ----------
    frames : iterable of (H, W) or (H, W, 3) uint8
    direction, rows, search_px, polarity
        See :func:`locate_front_end`.
    guess_u : float
        Approximate front column in the first frame, px.
    first_index : int
        Film index of the first frame, for notes.

    Returns
    -------
    EdgeTrack
        ``uv[:, 0]`` the front column, ``uv[:, 1]`` the row it was found on;
        ``sigma[:, 1]`` is NaN (the row is not a measurement).
    """
    out, sig, lost = [], [], []
    u_last, vel = float(guess_u), 0.0
    for k, frame in enumerate(frames):
        pred = u_last + vel
        fe = locate_front_end(frame, direction, rows, pred, search_px=search_px,
                              polarity=polarity, frame_index=first_index + k)
        u, v, s = fe.u, fe.v, fe.sigma
        if np.isfinite(u):
            if k > 0 and not lost[-1]:
                vel = u - u_last
            u_last = u
            out.append((u, v))
            sig.append((s, np.nan))
            lost.append(False)
        else:
            out.append((np.nan, np.nan))
            sig.append((np.nan, np.nan))
            lost.append(True)
            u_last = pred
    lost = np.array(lost)
    notes = ()
    if lost.any():
        notes = (f"front end lost in {lost.sum()} frame(s) "
                 f"({ranges_text(np.flatnonzero(lost) + first_index)}): NaN there",)
    return EdgeTrack(np.array(out), np.array(sig), lost, notes)


def find_barrier_face(frame: np.ndarray, direction: int, rows: tuple[float, float],
                      u_from: float, *, frame_index: int = 0) -> BarrierFace:
    """Column of the barrier's face: the strongest vertical edge ahead of the car.

    The face seen in the image lies in the barrier's plane; if that is not the car's
    plane, its column differs from the car-plane contact position (parallax).

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
    direction : +1 or -1
        Direction of travel (the barrier is on that side).
    rows : (v_top, v_bottom) px
        Rows where the barrier shows (e.g. the bumper's band).
    u_from : float
        Column from which to search in the travel direction (the car's front), px.
    frame_index : int

    Returns
    -------
    BarrierFace

    Raises
    ------
    VideoError
        If no vertical edge is found ahead of the car.
    """
    gray = to_gray(frame, frame_index=frame_index)
    h, w = gray.shape
    v0, v1 = sorted(rows)
    band = gray[int(max(0, np.floor(v0))):int(min(h, np.ceil(v1) + 1)), :]
    prof = band.mean(axis=0)
    u = np.arange(w, dtype=float)
    lo, hi = (u_from + 2, w - 2) if direction == 1 else (1, u_from - 2)
    if hi - lo < 4:
        raise VideoError(f"no room for a barrier ahead of the car in frame {frame_index}; "
                         "check the direction of travel")
    # the face is a step between two levels, not a thin line (wall tiles, cables):
    # rank columns by the difference of the means 2-6 px either side
    c = np.concatenate([[0.0], np.cumsum(prof)])
    cols = np.arange(6, w - 7)
    step = np.abs((c[cols + 7] - c[cols + 2]) - (c[cols - 1] - c[cols - 6])) / 5.0
    sel = (cols >= lo) & (cols <= hi)
    if not sel.any():
        raise VideoError(f"no room for a barrier ahead of the car in frame {frame_index}; "
                         "check the direction of travel")
    best = cols[sel][np.argmax(step[sel])]
    pos, _ = find_edge(u, prof, 0, (best - 3, best + 3), half=12)
    if not np.isfinite(pos) or np.max(step[sel]) < 8.0:
        raise VideoError(f"no barrier face found in frame {frame_index} ahead of column "
                         f"{u_from:.0f}; check that the barrier is in view")
    # uncertainty from the scatter of the face's column row by row
    vs = np.arange(np.ceil(max(v0, 0)), np.floor(min(v1, h - 1)) + 1)
    t = np.arange(-4.0, 4.25, 0.25)
    grid = np.stack(np.broadcast_arrays(pos + t[None, :], vs[:, None]), axis=-1)
    g = np.abs(np.gradient(np.nan_to_num(sample(gray, grid)), 0.25, axis=1))
    g[:, :2] = 0.0
    g[:, -2:] = 0.0
    per_row = edge_centroids(t, g, np.argmax(g, axis=1), 12)
    per_row = per_row[np.isfinite(per_row)]
    if len(per_row) >= 3:
        spread = 1.4826 * float(np.median(np.abs(per_row - np.median(per_row))))
        sigma = float(np.hypot(spread / np.sqrt(len(per_row)), SYSTEMATIC_PX))
    else:
        sigma = 1.0
    return BarrierFace(float(pos), sigma, float(np.max(step[sel])))


@dataclass(frozen=True)
class Crush:
    """Crush of the front end per frame.

    Attributes
    ----------
    crush_m : (n,) m
        How far the undeformed front end has passed the barrier face, >= 0 (0 before
        contact); NaN where the body was not measured.
    signed_m : (n,) m
        The same without the floor: negative values are the gap before contact.
    sigma_m : (n,) m
        One-sigma uncertainty.
    """

    crush_m: np.ndarray
    signed_m: np.ndarray
    sigma_m: np.ndarray


def crush_from_body(body: EdgeTrack, front_ref: np.ndarray, front_sigma_ref: float,
                    ref: int, barrier_u: float, barrier_sigma: float, m_per_px: float,
                    m_per_px_sigma: float, direction: int) -> Crush:
    """Crush from the motion of the rigid body and the front end's position before contact.

    The front end cannot be seen past the barrier face (it folds there), so the
    undeformed front is carried with the rigid passenger cell: its offset from a body
    point (the roof edge) measured in frame ``ref`` before contact is moved with that
    point and turned with the body's rotation (the roof line's angle, i.e. the pitch).
    Crush is how far the carried front is past the barrier face, in m.

    Parameters
    ----------
    body : EdgeTrack
        The roof-edge track (:func:`track_roof_edge`); its ``angle`` turns the offset
        (without ``angle`` the body is taken not to rotate).
    front_ref : (2,) px
        Front end (column, row) measured in frame ``ref`` (:func:`locate_front_end`).
    front_sigma_ref : float
        Its sigma along u, px.
    ref : int
        Index into the track of that frame (before contact).
    barrier_u, barrier_sigma : float
        Column of the barrier face in the car's plane and its sigma, px. The front
        end's column at the contact frame is the right value; the barrier's own image
        edge (:func:`find_barrier_face`) lies in the barrier's plane and differs from it
        by parallax when the planes differ.
    m_per_px, m_per_px_sigma : float
        Scale, m/px.
    direction : +1 or -1

    Returns
    -------
    Crush
        NaN where the body was lost.
    """
    uv = np.asarray(body.uv, float)
    if not np.all(np.isfinite(uv[ref])):
        raise VideoError(f"the roof edge is lost in reference frame {ref}; "
                         "choose a frame before contact where it is seen")
    offset = np.asarray(front_ref, float) - uv[ref]
    if body.angle is not None:
        dth = np.asarray(body.angle, float) - body.angle[ref]
        dth_sig = np.hypot(np.asarray(body.angle_sigma, float), body.angle_sigma[ref])
    else:
        dth = np.zeros(len(uv))
        dth_sig = np.zeros(len(uv))
    c, s = np.cos(dth), np.sin(dth)
    front_u = uv[:, 0] + c * offset[0] - s * offset[1]
    px = direction * (front_u - barrier_u)
    signed = px * m_per_px
    su = np.asarray(body.sigma, float)[:, 0]
    var_px = (su ** 2 + su[ref] ** 2 + front_sigma_ref ** 2 + barrier_sigma ** 2
              + (np.linalg.norm(offset) * dth_sig) ** 2)
    sigma = np.sqrt(var_px * m_per_px ** 2 + (px * m_per_px_sigma) ** 2)
    crush = np.where(np.isfinite(signed), np.maximum(signed, 0.0), np.nan)
    return Crush(crush, signed, sigma)
