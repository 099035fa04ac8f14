"""The video stage: film -> scale -> targets -> tracks -> motion (``track_film``), and
the frame-to-frame target tracker (``track_targets``).

Tracking: the targets found in the first frame are followed through the film. Each
target's position is predicted from its last positions (constant velocity; after a
gap, from the displacement of the target that moved most like it), the saddle response
is searched in a window around the prediction, the centre refined
(``video.targets.refine_centre``: gradient orthogonality, then point symmetry) and the detection checked (radius, contrast,
quadrant symmetry). A detection that fails the checks is not used: the target is lost
in that frame (NaN, and a note names the frames), never interpolated. The pattern's
orientation is unwrapped over frames (hub targets: the wheel's spin angle).

Example
-------
>>> from video.io import open_film                                    # doctest: +SKIP
>>> tracks = track_film(open_film("crash.mp4", fps=1000), car)        # doctest: +SKIP
>>> tracks.channels["x_m"], tracks.sigma["x_m"], tracks.events_ms     # doctest: +SKIP
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator

import cv2
import numpy as np

from video.contact_seen import NOSE_BAND_M, SeenContact, not_seen, see_contact, settle_contact
from video.errors import VideoError
from video.filters import velocity
from video.targets import (
    Detections,
    TargetConfig,
    centre_sigma,
    detect_targets,
    orientation,
    refine_centre,
    saddle_response,
    symmetry_errors,
    target_radius,
    to_gray,
)
from video.types import CarGeometry, Tracks

__all__ = ["TrackerConfig", "TargetTracks", "follow_target", "track_targets", "track_film",
           "prefetch"]

Progress = Callable[[int, int, str], None]

#: Floor of a centre's sigma (drawing, sampling and model errors that noise does not
#: show), px.
SIGMA_FLOOR_PX = 0.025

#: Lowest frame rate the video stage accepts, frames per second (a crash lasts ~0.1 s).
MIN_FPS = 200.0

#: SAE J211 class of the velocity channel derived from the film's displacement.
VELOCITY_CFC = 60


@dataclass(frozen=True)
class TrackerConfig:
    """Settings of the frame-to-frame tracker.

    Attributes
    ----------
    search_px : float
        Half-width of the search window around the prediction, px (grows by
        ``search_growth_px`` per frame of a gap).
    search_growth_px : float
    max_search_px : float
    max_point_error : float
        Largest accepted point-symmetry error within 0.9 of the radius (see
        ``video.targets.symmetry_errors``): clean, noisy, blurred, compressed or
        flickering targets stay below 0.02; debris or an occluder over part of a target
        raises it and shifts its centre (on rendered films, accepted centres stay within
        0.16 px of the truth with 0.05).
    max_quarter_error : float
        Largest accepted quarter-turn anti-symmetry error (motion blur raises it; a blob
        or a plain corner gives about 1-2).
    min_contrast_ratio : float
        Smallest accepted contrast, as a fraction of the target's contrast in the first
        frame (flicker changes it; an occluder or a smear lowers it more).
    radius_tolerance : float
        Largest accepted relative change of the radius.
    detect : TargetConfig
        Settings of the first frame's detection.
    stabilise : bool
        Take a camera shaken by the impact out of the tracks with the fixed targets
        (``video.motion.stabilise_on_fixed``); off only to measure what it does.
    see_contact : bool
        Look for first contact in the picture, the front end stopping at the barrier
        (``video.contact_seen``); off only to measure what it does (the deceleration
        onset alone).
    """

    search_px: float = 8.0
    search_growth_px: float = 2.0
    max_search_px: float = 40.0
    max_point_error: float = 0.05
    max_quarter_error: float = 0.3
    min_contrast_ratio: float = 0.4
    radius_tolerance: float = 0.25
    detect: TargetConfig = field(default_factory=TargetConfig)
    stabilise: bool = True
    see_contact: bool = True


@dataclass(frozen=True)
class TargetTracks:
    """Every target followed through the film.

    Attributes
    ----------
    uv : (n, K, 2) float
        Centres, px; NaN where the target was lost.
    sigma_px : (n, K) float
        One-sigma uncertainty of each centre per axis, px.
    angle : (n, K) float
        Unwrapped pattern orientation, rad (image angle, clockwise positive).
    radius : (K,) float
        Radius in the first frame, px.
    contrast : (K,) float
        Contrast in the first frame, grey levels of [0, 1].
    lost : list of (k, first, last)
        Runs of frames (inclusive) in which target ``k`` was not found.
    """

    uv: np.ndarray
    sigma_px: np.ndarray
    angle: np.ndarray
    radius: np.ndarray
    contrast: np.ndarray
    lost: list


def prefetch(frames: Iterable[np.ndarray], depth: int = 4) -> Iterator[np.ndarray]:
    """Yield the frames of ``frames`` while a background thread decodes the next ones.

    Decoding (OpenCV, which releases the GIL) then overlaps with the tracking of the
    current frame on a second core. An exception raised while decoding (a damaged frame:
    VideoError) is raised here, at the frame where it happened.
    """
    q: queue.Queue = queue.Queue(maxsize=depth)
    stop = threading.Event()
    done = object()

    def work():
        try:
            for f in frames:
                while not stop.is_set():
                    try:
                        q.put(f, timeout=0.1)
                        break
                    except queue.Full:
                        continue
                if stop.is_set():
                    return
            q.put(done)
        except BaseException as err:  # handed to the consumer, re-raised there
            q.put(err)

    th = threading.Thread(target=work, name="frame-prefetch", daemon=True)
    th.start()
    try:
        while True:
            item = q.get()
            if item is done:
                return
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()


def _wrap_half(a: float) -> float:
    """Wrap an angle difference to (-pi/2, pi/2]."""
    return float((a + np.pi / 2) % np.pi - np.pi / 2)


def follow_target(gray: np.ndarray, pred: np.ndarray, radius: float, contrast: float,
                  search_px: float, config: TrackerConfig
                  ) -> tuple[np.ndarray, float, float] | None:
    """Find one known target near its predicted position.

    Parameters
    ----------
    gray : (H, W) float32
        Frame (or a crop of it around the target), grey levels in [0, 1].
    pred : (2,) float
        Predicted centre in ``gray``'s pixel coordinates, px.
    radius, contrast : float
        The target's radius (px) and contrast in the first frame.
    search_px : float
        Search half-width around ``pred``, px.
    config : TrackerConfig

    Returns
    -------
    (centre (2,) px, contrast now, orientation rad in (-pi/2, pi/2]) or None if the
    target is not found or fails a check. The prediction itself is refined first; if
    that fails, candidates are the saddle-response maxima within ``search_px`` of the
    prediction, nearest first (at most four are checked).
    """
    H, W = gray.shape
    # a good prediction (smooth motion) is refined directly; the search is the fallback
    got = _check(gray, np.asarray(pred, float), radius, contrast, config)
    if got is not None and np.hypot(*(got[0] - pred)) < min(search_px, 0.3 * radius):
        return got[0], got[1], orientation(gray, got[0], radius)
    half = search_px + 1.2 * radius + 3
    u0, v0 = int(np.floor(pred[0] - half)), int(np.floor(pred[1] - half))
    u1, v1 = int(np.ceil(pred[0] + half)) + 1, int(np.ceil(pred[1] + half)) + 1
    if u1 <= 0 or v1 <= 0 or u0 >= W or v0 >= H:
        return None
    u0c, v0c, u1c, v1c = max(u0, 0), max(v0, 0), min(u1, W), min(v1, H)
    roi = gray[v0c:v1c, u0c:u1c]
    if roi.shape[0] < 5 or roi.shape[1] < 5:
        return None
    resp = saddle_response(roi, max(1.5, min(0.2 * radius, 3.0)))
    ys = np.arange(v0c, v1c)[:, None]
    xs = np.arange(u0c, u1c)[None, :]
    d2 = (xs - pred[0]) ** 2 + (ys - pred[1]) ** 2
    thr = 0.05 * (contrast / np.pi) ** 2
    peaks = (resp >= cv2.dilate(resp, np.ones((3, 3), np.uint8))) & (resp > thr) \
        & (d2 <= search_px**2 + 2)
    pv, pu = np.nonzero(peaks)
    order = np.argsort(d2[pv, pu])[:4]
    for j in order:
        start = np.array([pu[j] + u0c, pv[j] + v0c], dtype=float)
        got = _check(gray, start, radius, contrast, config)
        if got is not None:
            c, con = got
            return c, con, orientation(gray, c, radius)
    return None


def _check(gray: np.ndarray, start: np.ndarray, radius: float, contrast: float,
           config: TrackerConfig) -> np.ndarray | None:
    """Refine a candidate centre and check it is the target: (centre, contrast) or None."""
    c = refine_centre(gray, start, radius)
    if not np.all(np.isfinite(c)) or np.hypot(*(c - start)) > 0.5 * radius:
        return None
    r, con = target_radius(gray, c, config.detect, expected=radius)
    if not np.isfinite(r) or abs(r / radius - 1.0) > config.radius_tolerance:
        return None
    if con < config.min_contrast_ratio * contrast:
        return None
    e1, e2 = symmetry_errors(gray, c, radius)
    if e1 > config.max_point_error or e2 > config.max_quarter_error:
        return None
    return c, con


def _predict(uv: np.ndarray, angle: np.ndarray, i: int, k: int, last: np.ndarray
             ) -> tuple[np.ndarray, float, int]:
    """Predicted centre and orientation of target ``k`` in frame ``i``; and the gap
    (frames since it was last seen).

    Constant velocity from its last two positions; after a gap, the displacement of the
    target that moved most like it before the gap. A target without a velocity of its
    own (seen in one frame before a gap, or only in frame 0) moves as the target nearest
    to it in the picture did since it was last seen (neighbouring targets share the body
    they are on; a fixed neighbour predicts it standing still, as the fallback does)."""
    L = last[k]
    gap = i - L
    p1 = uv[L, k]
    a1 = angle[L, k]
    prev = L - 1
    if not (prev >= 0 and np.isfinite(uv[prev, k, 0])):
        return p1 + _neighbour_displacement(uv, i, k, L), a1, gap
    vel = p1 - uv[prev, k]
    spin = angle[L, k] - angle[prev, k]
    if gap > 1:
        # the target that moved most like this one, seen in L and i - 1
        best, best_d = None, np.inf
        for j in range(uv.shape[1]):
            if j == k or not (np.isfinite(uv[L, j, 0]) and np.isfinite(uv[i - 1, j, 0])):
                continue
            if np.isfinite(uv[prev, j, 0]):
                d = np.hypot(*((uv[L, j] - uv[prev, j]) - vel))
                if d < best_d:
                    best, best_d = j, d
        if best is not None and best_d < 2.0 + 0.2 * np.hypot(*vel):
            j = best
            step = uv[i - 1, j] - uv[i - 2, j] if i - 2 >= 0 and np.isfinite(uv[i - 2, j, 0]) else vel
            return p1 + (uv[i - 1, j] - uv[L, j]) + step, a1 + spin * gap, gap
    return p1 + vel * gap, a1 + spin * gap, gap


def _neighbour_displacement(uv: np.ndarray, i: int, k: int, L: int) -> np.ndarray:
    """Displacement from frame ``L`` to frame ``i`` of the target nearest to ``k`` in frame
    ``L`` among those seen in ``L`` and since (in ``i`` itself when it was found there
    already, else in ``i - 1`` plus its last step), px; zero when there is none."""
    best, best_d = None, np.inf
    for j in range(uv.shape[1]):
        if j == k or not np.isfinite(uv[L, j, 0]):
            continue
        if not (np.isfinite(uv[i, j, 0]) or np.isfinite(uv[i - 1, j, 0])):
            continue
        d = float(np.hypot(*(uv[L, j] - uv[L, k])))
        if d < best_d:
            best, best_d = j, d
    if best is None:
        return np.zeros(2)
    j = best
    if np.isfinite(uv[i, j, 0]):
        return uv[i, j] - uv[L, j]
    step = uv[i - 1, j] - uv[i - 2, j] if i - 2 >= 0 and np.isfinite(uv[i - 2, j, 0]) else 0.0
    return uv[i - 1, j] - uv[L, j] + step


def track_targets(frames: Iterable[np.ndarray], n_frames: int, first: Detections,
                  noise: np.ndarray | None = None, config: TrackerConfig = TrackerConfig(),
                  progress: Progress | None = None) -> TargetTracks:
    """Follow the targets of the first frame through every frame.

    Parameters
    ----------
    frames : iterable of (H, W) or (H, W, 3) arrays
        The film's frames in order, starting with the frame ``first`` was found in.
    n_frames : int
        Number of frames (for the arrays and the progress display).
    first : Detections
        Targets found in the first frame.
    noise : (n,) float, optional
        Image noise of each frame, grey levels of [0, 1] (default: 0.5 / 255).
    config : TrackerConfig
    progress : callable, optional
        ``progress(done, total, stage)``.

    Returns
    -------
    TargetTracks
    """
    K = len(first)
    uv = np.full((n_frames, K, 2), np.nan)
    sig = np.full((n_frames, K), np.nan)
    ang = np.full((n_frames, K), np.nan)
    last = np.zeros(K, int)
    step = max(1, n_frames // 100)
    unit = np.zeros(K)  # centre sigma per unit of noise and of contrast ratio, px
    i = -1
    for i, frame in enumerate(frames):
        if i >= n_frames:
            break
        nz = (0.5 / 255.0) if noise is None else float(noise[i])
        if i == 0:
            gray = to_gray(frame)
            uv[0] = first.centres
            ang[0] = first.orientations
            unit = np.array([centre_sigma(gray, c, r, 1.0, floor_px=0.0)
                             for c, r in zip(first.centres, first.radii)])
            sig[0] = np.hypot(unit * nz, SIGMA_FLOOR_PX)
            continue
        H, W = frame.shape[:2]
        for k in range(K):
            pred, a_pred, gap = _predict(uv, ang, i, k, last)
            if not np.all(np.isfinite(pred)):
                continue
            search = min(config.search_px + config.search_growth_px * (gap - 1),
                         config.max_search_px)
            R = first.radii[k]
            half = int(np.ceil(search + 2.2 * R + 8))
            u0, v0 = max(int(pred[0]) - half, 0), max(int(pred[1]) - half, 0)
            u1, v1 = min(int(pred[0]) + half + 1, W), min(int(pred[1]) + half + 1, H)
            if u1 - u0 < 8 or v1 - v0 < 8:
                continue
            crop = to_gray(frame[v0:v1, u0:u1])
            off = np.array([u0, v0], dtype=float)
            found = follow_target(crop, pred - off, R, first.contrasts[k], search, config)
            if found is None:
                continue
            c, con, a = found
            uv[i, k] = c + off
            sig[i, k] = np.hypot(unit[k] * nz * first.contrasts[k] / max(con, 1e-6),
                                 SIGMA_FLOOR_PX)
            ang[i, k] = a_pred + _wrap_half(a - a_pred)
            last[k] = i
        if progress is not None and (i % step == 0 or i == n_frames - 1):
            progress(i + 1, n_frames, "tracking")
    if i + 1 < n_frames:
        raise VideoError(f"the film gave {i + 1} frames, {n_frames} were expected")
    lost = []
    for k in range(K):
        miss = ~np.isfinite(uv[:, k, 0])
        d = np.diff(np.concatenate([[0], miss.astype(int), [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            lost.append((k, int(a), int(b - 1)))
    return TargetTracks(uv=uv, sigma_px=sig, angle=ang, radius=first.radii.copy(),
                        contrast=first.contrasts.copy(), lost=lost)


# ------------------------------------------------------------------------ pipeline


def _runs_text(idx: np.ndarray) -> str:
    """'3-7, 12' for frame indices [3, 4, 5, 6, 7, 12]."""
    if len(idx) == 0:
        return ""
    out, start, prev = [], int(idx[0]), int(idx[0])
    for i in idx[1:]:
        i = int(i)
        if i != prev + 1:
            out.append(f"{start}-{prev}" if prev != start else f"{start}")
            start = i
        prev = i
    out.append(f"{start}-{prev}" if prev != start else f"{start}")
    return ", ".join(out)


def _angle_sigma(spin: np.ndarray, rolling: np.ndarray, stop: int) -> float:
    """Scatter of a wheel's spin angle about rolling over the frames before ``stop``, rad."""
    ok = np.isfinite(spin[:stop]) & np.isfinite(rolling[:stop])
    if ok.sum() < 5:
        return 0.01
    A = np.stack([np.ones(ok.sum()), rolling[:stop][ok]], axis=1)
    coef, *_ = np.linalg.lstsq(A, spin[:stop][ok], rcond=None)
    r = spin[:stop][ok] - A @ coef
    return max(float(np.std(r)) * np.sqrt(ok.sum() / max(ok.sum() - 2, 1)), 1e-3)


def _drop_repeated_frames(tt: TargetTracks, duplicates, notes: list,
                          min_motion_px: float = 0.5, still_share: float = 0.25) -> list:
    """Blank (NaN) the target samples of frames that repeat the frame before while the
    targets move (a re-encoding artefact: the true frame is missing), in place.

    ``Film.duplicates`` lists frames whose picture hardly differs from the one before;
    on a low-noise film compressed hard, where the car fills a small part of the picture,
    that includes real frames. So the targets decide: a flagged frame ``i`` is a repeat
    when they move around it (median over targets of ``min_motion_px`` px a frame or
    more, from frame ``i - 3`` to ``i + 3``) but not from ``i - 1`` to ``i`` (less than
    ``still_share`` of that motion: a copy shows them where they were). A car at rest
    films the same picture twice and is kept, and so is a frame where they moved.
    Returns the indices blanked.
    """
    dropped = []
    n = tt.uv.shape[0]
    flagged = [int(i) for i in np.asarray(duplicates, dtype=int) if 1 <= i < n]
    for i in flagged:
        lo, hi = max(i - 3, 0), min(i + 3, n - 1)
        around = np.hypot(*(tt.uv[hi] - tt.uv[lo]).T) / (hi - lo)
        here = np.hypot(*(tt.uv[i] - tt.uv[i - 1]).T)
        ok = np.isfinite(around) & np.isfinite(here)
        if not ok.any():
            continue
        motion = float(np.median(around[ok]))
        if motion >= min_motion_px and float(np.median(here[ok])) < still_share * motion:
            dropped.append(i)
    for i in dropped:
        tt.uv[i] = np.nan
        tt.sigma_px[i] = np.nan
        tt.angle[i] = np.nan
    kept = len(flagged) - len(dropped)
    if dropped:
        notes.append(f"frame(s) {_runs_text(np.array(dropped))} repeat the frame before while "
                     "the car moves (re-encoding): not measurements, NaN there; frames "
                     "around a repeat may be a frame off in time")
    if kept:
        notes.append(f"{kept} frame(s) that hardly differ from the one before show the targets "
                     "moved (or a car at rest): kept as measurements")
    return dropped


def _wheels(uv, tt, roles, ref, cf, t, fps, s, s_sig, d, axes, car, channels, sigma,
            notes) -> dict:
    """Wheel spin angles and heights from the hub targets, their events (ms).

    Adds ``<front|rear>_wheel_angle_rad`` and ``<front|rear>_wheel_height_m`` (with
    sigma) to ``channels``/``sigma`` and sentences to ``notes``; returns the events:
    ``<wheel>_wheel_block``, ``_unblock``, ``_lift``, ``_touchdown`` in ms after contact.
    """
    from video.motion import (block_time, floor_heights, lift_time, to_car_plane,
                              touchdown_time, unblock_time)

    events: dict = {}
    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    hubs = [(w, k) for w, k in (("front", kf), ("rear", kr)) if k is not None]
    for which in ("front", "rear"):
        if which not in dict(hubs):
            notes.append(f"no {which} hub target: {which} wheel angle and height not measured")
    if not hubs:
        return events
    heights, _ = floor_heights([uv[:, k] for _, k in hubs], cf, s)
    for (which, k), h in zip(hubs, heights):
        hub_xz = to_car_plane(uv[:, k] - uv[ref, k], d, s, axes)
        spin = d * (tt.angle[:, k] - tt.angle[ref, k])
        rolling = hub_xz[:, 0] / car.wheel_radius
        a_sig = np.where(np.isfinite(spin), _angle_sigma(spin, rolling, cf), np.nan)
        channels[f"{which}_wheel_angle_rad"] = spin
        sigma[f"{which}_wheel_angle_rad"] = a_sig
        scatter = np.nanstd(h[:cf]) if np.isfinite(h[:cf]).sum() > 3 else 0.0
        sh = np.sqrt((tt.sigma_px[:, k] * s) ** 2 + scatter**2
                     + (np.abs(uv[:, k, 1] - uv[ref, k, 1]) * s_sig) ** 2)
        channels[f"{which}_wheel_height_m"] = h
        sigma[f"{which}_wheel_height_m"] = sh
        tb = block_time(t, spin, a_sig, rolling, 0.0, fps)
        if tb is not None:
            events[f"{which}_wheel_block"] = tb * 1e3
            tu = unblock_time(t, spin, a_sig, rolling, tb, fps)
            if tu is not None:
                events[f"{which}_wheel_unblock"] = tu * 1e3
        tl = lift_time(t, h, sh, 0.0, fps)
        if tl is not None:
            events[f"{which}_wheel_lift"] = tl * 1e3
            td = touchdown_time(t, h, sh, tl, fps)
            if td is not None:
                events[f"{which}_wheel_touchdown"] = td * 1e3
    notes.append("wheel heights: the hub centres' rise above the path they rolled along "
                 "before contact (the floor line, fitted in the image)")
    return events


def _measured_geometry(uv, sigma_px, kf, kr, cf, s, s_sig, sil, car) -> dict:
    """The car's wheelbase and length as the film shows them (``Tracks.geometry``).

    Wheelbase: the median distance of the two hub targets over the frames before contact
    (undistorted positions at the tape's scale); its sigma combines one frame's centre
    sigmas (tracking errors of neighbouring frames are alike, so averaging is not credited)
    with the scale's. Length: the fitted silhouette is the vehicle file's outline scaled
    to the film's edges, so the film's length is the file's times tape scale over
    silhouette scale, with both scales' sigmas."""
    out: dict = {}
    if kf is not None and kr is not None:
        pre = np.zeros(len(uv), bool)
        pre[:max(int(cf), 1)] = True
        both = pre & np.isfinite(uv[:, kf, 0]) & np.isfinite(uv[:, kr, 0])
        if both.any():
            spacing = np.hypot(*(uv[both, kf] - uv[both, kr]).T) * s
            value = float(np.median(spacing))
            centre = float(np.nanmedian(np.hypot(sigma_px[both, kf], sigma_px[both, kr]))) * s
            centre = centre if np.isfinite(centre) else 0.0
            out["hub_spacing_m"] = value
            out["hub_spacing_sigma_m"] = float(np.hypot(centre, value * s_sig / s))
    if sil is not None and sil.m_per_px > 0:
        length = float(car.length) * s / sil.m_per_px
        out["outline_length_m"] = length
        out["outline_length_sigma_m"] = float(length * np.hypot(s_sig / s, sil.sigma / sil.m_per_px))
    return out


def _contact_in_picture(film, frame_t, pose, cg_uv, car: CarGeometry, s: float, d: int, onset_s: float,
                        lens, stab) -> SeenContact:
    """First contact in the picture (:mod:`video.contact_seen`), the nose placed from the CG
    and the vehicle's outline (the picture's own front may stand a few px off it)."""
    from video.calibrate import undistort_points

    def to_pose(i: int, p: np.ndarray) -> np.ndarray:
        p = undistort_points(np.asarray(p, float), lens) if lens.corrected else np.asarray(p, float)
        if stab is not None and np.isfinite(stab.shift_px[i, 0]):
            p = p - stab.shift_px[i]
        return p

    sil = np.asarray(car.silhouette_side, float)
    front = sil[sil[:, 0] >= sil[:, 0].max() - NOSE_BAND_M]
    z_lo, z_hi = float(front[:, 1].min()), float(front[:, 1].max())
    cg_v = float(cg_uv[1])
    rows = (cg_v - (z_hi - car.cg_height) / s - 1.0, cg_v - (z_lo - car.cg_height) / s + 1.0)
    if rows[1] - rows[0] < 5:
        return not_seen("the vehicle outline's front is under 5 rows high at this scale")
    nose = np.array([cg_uv[0] + d * (sil[:, 0].max() - car.x_cg) / s, 0.5 * sum(rows)])
    return see_contact(film.__getitem__, frame_t, pose, nose, rows, d, onset_s, to_pose=to_pose)


def track_film(film, car: CarGeometry, tape_segment_m: float = 0.1,
               speed_mps: float | None = None, progress: Progress | None = None,
               config: TrackerConfig = TrackerConfig()) -> Tracks:
    """Measure the car's motion in a film: read -> scale -> detect -> track -> motion.

    Parameters
    ----------
    film : video.io.Film
        An opened film (``video.io.open_film``): ``fps``, ``n_frames``, ``noise``,
        ``notes``, ``path``, indexable and iterable over frames.
    car : CarGeometry
        The vehicle (CG, axles, wheel radius, outline).
    tape_segment_m : float
        Length of one reference-tape segment, m.
    speed_mps : float, optional
        Impact speed if known, m/s (the measured one is then only compared).
    progress : callable, optional
        ``progress(done, total, stage)``, e.g. a progress bar on stderr.
    config : TrackerConfig

    Returns
    -------
    Tracks
        ``t`` (s, 0 at the contact frame), channels ``x_m, z_m, pitch_rad, crush_m``,
        ``front_wheel_angle_rad``, ``rear_wheel_angle_rad``, ``front_wheel_height_m``,
        ``rear_wheel_height_m`` (those whose hub target is tracked) and
        ``target<k>_u_px, target<k>_v_px``, each with a sigma; events in ms.

    Raises
    ------
    VideoError
        No tape, no or too few targets, no contact in the film, ...
    """
    from video.calibrate import compare_scales, fit_silhouette, measure_scale, undistort_points
    from video.motion import (
        body_pose,
        cg_from_hubs,
        classify_targets,
        contact_time,
        crush_from_pose,
        impact_speed,
        stabilise_on_fixed,
        to_car_plane,
        travel_axes,
    )

    n = int(film.n_frames)
    fps = float(film.fps)
    where = getattr(film, "path", "the film")
    if n < 10:
        raise VideoError(f"{where} has {n} frames; the video stage needs at least 10 "
                         "(the approach and the impact)")
    if not fps >= MIN_FPS:
        src = getattr(film, "fps_source", "")
        raise VideoError(f"{where} runs at {fps:g} fps{f' ({src})' if src else ''}; measuring a "
                         f"crash needs at least {MIN_FPS:g} fps: if it was filmed faster and "
                         "re-encoded, give the true rate with --fps (e.g. --fps 1000)")
    notes: list[str] = list(getattr(film, "notes", []))
    frame0 = film[0]

    # --- scale and lens
    if progress is not None:
        progress(0, n, "calibrating")
    est = measure_scale(frame0, tape_segment_m, frame_index=0)
    s, s_sig = est.m_per_px, est.sigma
    notes.extend(est.notes)
    lens = est.lens

    # --- targets in the first frame
    first = detect_targets(frame0, config.detect)
    if len(first) < 2:
        raise VideoError(f"{len(first)} quadrant target(s) found in frame 0 of {where}; at "
                         "least two on the passenger cell are needed (check the targets are "
                         f"in view and {2 * config.detect.min_radius_px:g}-{2 * config.detect.max_radius_px:g} px across)")

    # --- follow them
    noise = getattr(film, "noise", None)
    noise = None if noise is None or len(noise) != n else np.asarray(noise, float) / 255.0
    tt = track_targets(prefetch(iter(film)), n, first, noise, config, progress)
    dropped = _drop_repeated_frames(tt, getattr(film, "duplicates", ()), notes)
    uv = tt.uv.copy()
    if lens.corrected:
        flat = uv.reshape(-1, 2)
        ok = np.isfinite(flat[:, 0])
        flat[ok] = undistort_points(flat[ok], lens)
        uv = flat.reshape(uv.shape)

    roles = classify_targets(uv, tt.angle)
    d = roles.direction
    sigma_px = tt.sigma_px
    fixed = np.flatnonzero(np.array(roles.kind) == "fixed")
    stab = stabilise_on_fixed(uv, sigma_px, fixed) if config.stabilise else None
    if stab is not None:
        uv, sigma_px = stab.uv, stab.sigma_px
        worst = int(np.nanargmax(np.hypot(*stab.shift_px.T)))
        unseen = np.flatnonzero(~np.isfinite(stab.shift_px[:, 0]))
        notes.append(f"camera motion taken out of every track from {len(fixed)} fixed target(s): up to "
                     f"{np.hypot(*stab.shift_px[worst]):.2f} px (frame {worst}), roll up to "
                     f"{np.degrees(np.max(np.abs(stab.roll))):.3f} deg"
                     + (f"; not corrected in frame(s) {_runs_text(unseen)}, where no fixed target is seen"
                        if len(unseen) else ""))
    elif config.stabilise and not len(fixed):
        notes.append("no fixed target (barrier, floor) in view: a camera shaken by the impact could not be "
                     "taken out of the tracks")
    name = {k: f"target{k}" for k in range(len(first))}
    for k in range(len(first)):
        miss = np.flatnonzero(~np.isfinite(uv[:, k, 0]))
        if len(miss):
            notes.append(f"{name[k]} ({roles.kind[k]}) lost in {len(miss)} frame(s): "
                         f"{_runs_text(miss)} (occluded, smeared or out of view): NaN there, "
                         "not interpolated")
    notes.append("targets: " + ", ".join(f"{name[k]}={roles.kind[k]}"
                                         for k in range(len(first))))

    # --- reference frame: the first where every body target is seen
    body = roles.body
    seen = np.all(np.isfinite(uv[:, body, 0]), axis=1)
    ref = int(np.flatnonzero(seen)[0]) if seen.any() else None
    if ref is None:
        raise VideoError("no frame shows every body target at once; cannot set the reference")

    # --- the CG in the reference frame's image
    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    sil = None
    try:
        sil = fit_silhouette(film[ref], car, scale_hint=s, direction=d, frame_index=ref, inside_px=tt.uv[ref, body])
        cmp = compare_scales(s, s_sig, sil)
        notes.append(cmp.note)
    except VideoError as err:
        notes.append(f"silhouette not fitted ({err})")
    if kf is not None and kr is not None and np.isfinite(uv[ref, kf, 0]) \
            and np.isfinite(uv[ref, kr, 0]):
        cg_uv, _ = cg_from_hubs(uv[ref, kf], uv[ref, kr], d, s, car.x_cg - car.rear_axle_x,
                                car.cg_height - car.wheel_radius)
        hub_wb = np.hypot(*(uv[ref, kf] - uv[ref, kr])) * s
        if abs(hub_wb / car.wheelbase - 1.0) > 0.02:
            notes.append(f"hub targets are {hub_wb:.3f} m apart, the wheelbase is "
                         f"{car.wheelbase:.3f} m: scale or hub targets doubtful")
        cg_src = "hub targets and the vehicle geometry"
    elif sil is not None:
        p = sil.to_image(np.array([[car.x_cg, car.cg_height]]))[0]
        cg_uv = undistort_points(p[None], lens)[0] if lens.corrected else p
        cg_src = "the fitted silhouette"
    else:
        cg_uv = uv[ref, body].mean(axis=0)
        cg_src = None
        notes.append("CG position unknown (no hub targets, no silhouette): x, z follow the "
                     "centroid of the body targets")
    if cg_src:
        notes.append(f"CG located from {cg_src}")

    pose = body_pose(uv, sigma_px, body, cg_uv, ref)
    few = np.flatnonzero(pose.n_targets < 2)
    if len(few):
        notes.append(f"fewer than two body targets in frame(s) {_runs_text(few)}: "
                     "x, z, pitch are NaN there")
    # camera roll: the car approaches level, so its path before contact is car-plane X
    # (first guess of the contact from the image axes, then again with the axes found)
    frame_t = np.arange(n) / fps
    pos_sig = pose.point_sigma * s
    XZ = to_car_plane(pose.point - pose.point[ref], d, s)
    tc0, _ = contact_time(frame_t, XZ[:, 0], pos_sig, fps)
    axes, roll = travel_axes(pose.point, max(int(tc0 * fps) - 1, 2), d)
    if abs(roll) > np.radians(0.05):
        notes.append(f"camera roll {np.degrees(roll):+.2f} deg (from the level approach) "
                     "taken out of x, z")
    XZ = to_car_plane(pose.point - pose.point[ref], d, s, axes)
    pitch = d * pose.phi
    pitch_sig = pose.phi_sigma

    # --- contact and impact speed; a repeated frame before contact may have shifted the
    # frames after it by one interval: fit only the frames after the last one
    x_fit = XZ[:, 0].copy()
    cut = max([i for i in dropped if i < tc0 * fps - 3], default=-1)
    if cut >= 0:
        x_fit[: cut + 1] = np.nan
    try:
        tc, how = contact_time(frame_t, x_fit, pos_sig, fps)
    except VideoError:
        x_fit = XZ[:, 0]
        tc, how = contact_time(frame_t, x_fit, pos_sig, fps)
    notes.append(f"{how}: {tc * 1e3:.2f} ms after frame 0")
    seen = _contact_in_picture(film, frame_t, pose, cg_uv, car, s, d, tc, lens, stab) \
        if cg_src and config.see_contact else None
    tc_sigma = None
    if seen is not None:
        tc, tc_sigma, note = settle_contact(tc, seen)
        notes.append(note)
    # first frame at or after the contact; a contact within 0.2 frame after a frame is
    # taken as that frame (the onset fit's precision: frame-aligned contacts stay put)
    cf = int(np.ceil(tc * fps - 0.2))
    cf = min(max(cf, 1), n - 1)
    notes.append(f"contact frame {cf}")
    v_meas, v_sig = impact_speed(frame_t, x_fit, pos_sig, cf)
    v_sig = float(np.hypot(v_sig, v_meas * s_sig / s))
    if speed_mps is not None:
        notes.append(f"impact speed given: {speed_mps:.3f} m/s; measured {v_meas:.3f} "
                     f"+- {v_sig:.3f} m/s")
        v_imp = float(speed_mps)
    else:
        v_imp = v_meas
    if v_meas < 0:
        raise VideoError("the car moves away from the barrier before contact; check the film")

    # --- displacement from the contact frame, with sigma
    if not np.all(np.isfinite(XZ[cf])):
        raise VideoError(f"the car's position is not measured in the contact frame {cf} "
                         f"(body targets lost there); x, z have no reference")
    t = (np.arange(n) - cf) / fps
    x = XZ[:, 0] - XZ[cf, 0]
    z = XZ[:, 1] - XZ[cf, 1]
    sx = np.sqrt(pose.point_sigma**2 + pose.point_sigma[cf] ** 2) * s
    sig_x = np.hypot(sx, np.abs(x) * s_sig / s)
    sig_z = np.hypot(sx, np.abs(z) * s_sig / s)
    channels = {"x_m": x, "z_m": z, "pitch_rad": pitch}
    sigma = {"x_m": sig_x, "z_m": sig_z, "pitch_rad": pitch_sig}
    try:
        vx = velocity(x, fps, VELOCITY_CFC, sigma_m=sx)
    except VideoError as err:
        notes.append(f"no vx_mps: {err}")
    else:
        channels["vx_mps"] = vx.values
        sigma["vx_mps"] = np.hypot(vx.sigma, np.abs(vx.values) * s_sig / s)
        notes.append(f"vx_mps: derivative of x_m filtered with SAE J211 CFC {vx.cfc}")

    # --- crush: the rigid outline past the front end's position at contact
    # where the CG was at the contact instant: on the approach line (uniform motion)
    okp = np.isfinite(x_fit[:cf])
    if okp.sum() >= 3:
        line = np.polyfit(frame_t[:cf][okp], x_fit[:cf][okp], 1)
        x_at_tc = float(np.polyval(line, tc) - XZ[cf, 0])
    else:
        x_at_tc = 0.0
    front_ahead = float(np.max(car.silhouette_side[:, 0])) - car.x_cg
    channels["crush_m"] = crush_from_pose(x, pitch, car.silhouette_side, car.x_cg,
                                          car.cg_height, front_ahead + x_at_tc)
    sigma["crush_m"] = sig_x.copy()
    notes.append("crush from the rigid passenger cell's travel past its position at "
                 "contact (the undeformed outline), not from the deformed front end")

    # --- wheels
    events = _wheels(uv, tt, roles, ref, cf, t, fps, s, s_sig, d, axes, car, channels, sigma,
                     notes)

    # --- per-target columns
    for k in range(len(first)):
        channels[f"{name[k]}_u_px"] = tt.uv[:, k, 0]
        channels[f"{name[k]}_v_px"] = tt.uv[:, k, 1]
        sigma[f"{name[k]}_u_px"] = tt.sigma_px[:, k]
        sigma[f"{name[k]}_v_px"] = tt.sigma_px[:, k]
    for key in channels:
        bad = ~np.isfinite(channels[key])
        sigma[key] = np.where(bad, np.nan, sigma[key])

    geometry = _measured_geometry(uv, tt.sigma_px, kf, kr, cf, s, s_sig, sil, car)

    overlay = {
        "frame": ref,
        "tapes": [np.asarray(tp.ends, float) for tp in est.tapes],
        "targets_uv": tt.uv[ref].copy(),
        "target_radii": tt.radius.copy(),
        "target_kinds": list(roles.kind),
        "silhouette_px": None if sil is None else np.asarray(sil.polygon_px, float),
        "cg_uv": np.asarray(cg_uv, float),
    }
    return Tracks(t=t, channels=channels, sigma=sigma, events_ms=events, contact_frame=cf,
                  fps=fps, scale_m_per_px=float(s), scale_sigma=float(s_sig),
                  impact_speed_mps=float(v_imp), direction=int(d), notes=notes,
                  contact_offset_s=float(tc - cf / fps), contact_sigma_s=tc_sigma, overlay=overlay,
                  geometry=geometry)
