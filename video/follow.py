"""The frame-to-frame target tracker: the targets found in the first frame followed
through the film (``track_targets``).

Each target's position is predicted from its last positions (constant velocity; after a
gap, from the displacement of the target that moved most like it; without a velocity of
its own, from its nearest neighbour's), the saddle response is searched in a window
around the prediction, the centre refined (``video.targets.refine_centre``: gradient
orthogonality, then point symmetry) and the detection checked (radius, contrast,
quadrant symmetry). A detection that fails the checks is not used: the target is lost
in that frame (NaN, and a note names the frames), never interpolated. The pattern's
orientation is unwrapped over frames (hub targets: the wheel's spin angle). The targets of
a frame are refined and checked together (``follow_targets``), each in its own crop of
the frame, as each would be alone.
"""

from __future__ import annotations

import queue
import threading
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator

import cv2
import numpy as np

from video.errors import VideoError
from video.targets import (
    Detections,
    TargetConfig,
    centre_sigma,
    orientations,
    refine_centres_and_symmetry,
    saddle_response,
    symmetry_errors_each,
    target_radii,
    to_gray,
)

__all__ = ["TrackerConfig", "TargetTracks", "follow_targets", "track_targets", "prefetch"]

Progress = Callable[[int, int, str], None]

#: Floor of a centre's sigma (drawing, sampling and model errors that noise does not
#: show), px.
SIGMA_FLOOR_PX = 0.025


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
        Take a camera shaken by the impact out of the tracks, measured on the background
        (``video.background_motion``) or with the fixed targets
        (``video.motion.stabilise_on_fixed``); off only to measure what it does.
    background_shake : bool
        With no fixed target in view, measure the shake on the background's corners; off
        only to measure what it does (the fixed targets alone).
    see_contact : bool
        Look for first contact in the picture, the front end stopping at the barrier
        (``video.contact_seen``); off only to measure what it does (the deceleration
        onset alone).
    hub_scale : bool
        Without a tape in view, take the scale from the hub targets' distance and the
        vehicle's wheelbase (``video.calibrate.scale_from_hubs``); off only to measure what
        it does (a film without a tape is then refused).
    correct_yaw : bool
        Take a camera yawed against the car's plane out of every point, measured from the
        tapes' segments (``video.calibrate_perspective``); off only to measure what it does.
    tyre_deflection : bool
        Allow for the tyre's unknown static deflection when a wheel leaves or meets the
        floor (``video.motion.lift_time``: the event bracketed); off only to measure what
        it does (the lift at the hub's first rise, as a rigid tyre would have it).
    map_from_approach : bool
        Fit the lens's radial distortion and the camera's yaw and pitch against the car's
        plane to the targets' approach (``video.calibrate_motion``: a common uniform
        translation) and use that map instead of the tapes'; off only to measure what it
        does.
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
    background_shake: bool = True
    see_contact: bool = True
    hub_scale: bool = True
    correct_yaw: bool = True
    tyre_deflection: bool = True
    map_from_approach: bool = True


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


def follow_targets(grays, preds: np.ndarray, radii: np.ndarray, contrasts: np.ndarray,
                   search_px: np.ndarray, config: TrackerConfig
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Find K known targets near their predicted positions, each in its own image.

    Parameters
    ----------
    grays : sequence of K (H, W) float32
        Frame (or a crop of it around the target) of each target, grey levels in [0, 1].
    preds : (K, 2) float
        Predicted centres, each in its own image's pixel coordinates, px.
    radii, contrasts : (K,) float
        The targets' radii (px) and contrasts in the first frame.
    search_px : (K,) float
        Search half-width around each prediction, px.
    config : TrackerConfig

    Returns
    -------
    centres (K, 2) px, contrasts now (K,), orientations (K,) rad in (-pi/2, pi/2]; NaN
    where a target is not found or fails a check. The predictions are refined first,
    all together; where that fails, candidates are the saddle-response maxima within
    ``search_px`` of the prediction, nearest first (at most four are checked).
    """
    preds = np.asarray(preds, dtype=float)
    radii, contrasts, search_px = (np.asarray(a, dtype=float) for a in (radii, contrasts, search_px))
    # a good prediction (smooth motion) is refined directly; the search is the fallback
    c, con = _check(grays, preds, radii, contrasts, config)
    held = np.hypot(*(c - preds).T) < np.minimum(search_px, 0.3 * radii)
    for k in np.flatnonzero(~held):
        c[k], con[k] = _search(grays[k], preds[k], radii[k], contrasts[k], search_px[k], config)
    angle = np.full(len(c), np.nan)
    found = np.flatnonzero(np.isfinite(c[:, 0]))
    if found.size:
        angle[found] = orientations([grays[k] for k in found], c[found], radii[found])
    return c, con, angle


def _search(gray: np.ndarray, pred: np.ndarray, radius: float, contrast: float,
            search_px: float, config: TrackerConfig) -> tuple[np.ndarray, float]:
    """The first of the saddle-response maxima within ``search_px`` (px) of ``pred`` (px),
    nearest first (at most four), that passes :func:`_check`: (centre (2,) px, contrast),
    NaN where none does."""
    none = np.full(2, np.nan), np.nan
    H, W = gray.shape
    half = search_px + 1.2 * radius + 3
    u0, v0 = int(np.floor(pred[0] - half)), int(np.floor(pred[1] - half))
    u1, v1 = int(np.ceil(pred[0] + half)) + 1, int(np.ceil(pred[1] + half)) + 1
    if u1 <= 0 or v1 <= 0 or u0 >= W or v0 >= H:
        return none
    u0c, v0c, u1c, v1c = max(u0, 0), max(v0, 0), min(u1, W), min(v1, H)
    roi = gray[v0c:v1c, u0c:u1c]
    if roi.shape[0] < 5 or roi.shape[1] < 5:
        return none
    resp = saddle_response(roi, max(1.5, min(0.2 * radius, 3.0)))
    ys = np.arange(v0c, v1c)[:, None]
    xs = np.arange(u0c, u1c)[None, :]
    d2 = (xs - pred[0]) ** 2 + (ys - pred[1]) ** 2
    thr = 0.05 * (contrast / np.pi) ** 2
    peaks = (resp >= cv2.dilate(resp, np.ones((3, 3), np.uint8))) & (resp > thr) \
        & (d2 <= search_px**2 + 2)
    pv, pu = np.nonzero(peaks)
    order = np.argsort(d2[pv, pu])[:4]
    if not order.size:
        return none
    starts = np.stack([pu[order] + u0c, pv[order] + v0c], axis=1).astype(float)
    n = len(starts)
    c, con = _check([gray] * n, starts, np.full(n, radius), np.full(n, contrast), config)
    passed = np.flatnonzero(np.isfinite(c[:, 0]))
    return (c[passed[0]], con[passed[0]]) if passed.size else none


def _check(grays, starts: np.ndarray, radii: np.ndarray, contrasts: np.ndarray,
           config: TrackerConfig) -> tuple[np.ndarray, np.ndarray]:
    """Refine K candidate centres (K, 2) px, each in its own image, and check each is its
    target (radius, contrast, symmetry against its first frame's ``radii`` px and
    ``contrasts``): centres (K, 2) px and contrasts (K,), NaN where rejected."""
    c, errors = refine_centres_and_symmetry(grays, starts, radii)
    con = np.full(len(c), np.nan)
    ok = np.flatnonzero(np.hypot(*(c - starts).T) <= 0.5 * radii)
    if ok.size:
        r, con_ok = target_radii([grays[k] for k in ok], c[ok], config.detect, expected=radii[ok])
        con[ok] = con_ok
        ok = ok[(np.abs(r / radii[ok] - 1.0) <= config.radius_tolerance)
                & (con_ok >= config.min_contrast_ratio * contrasts[ok])]
    unmeasured = ok[np.isnan(errors[ok, 0])]
    if unmeasured.size:
        errors[unmeasured] = symmetry_errors_each([grays[k] for k in unmeasured], c[unmeasured], radii[unmeasured])
    ok = ok[(errors[ok, 0] <= config.max_point_error) & (errors[ok, 1] <= config.max_quarter_error)]
    rejected = np.ones(len(c), bool)
    rejected[ok] = False
    c[rejected], con[rejected] = np.nan, np.nan
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
    if not _has_velocity(uv, k, L):
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


def _has_velocity(uv: np.ndarray, k: int, L: int) -> bool:
    """Whether target ``k``, last seen in frame ``L``, was seen in frame ``L - 1`` too (a
    velocity of its own; without one, :func:`_predict` moves it with a neighbour found in
    the frame being tracked)."""
    return L >= 1 and bool(np.isfinite(uv[L - 1, k, 0]))


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


def _job(frame: np.ndarray, uv: np.ndarray, angle: np.ndarray, i: int, k: int, last: np.ndarray,
         first: Detections, config: TrackerConfig):
    """Target ``k``'s search in frame ``i``: (k, grey crop of the frame around its
    prediction, the crop's origin (2,) px, the prediction in the crop (2,) px, the search
    half-width px, the predicted orientation rad); None where the prediction is unknown or
    the crop is under 8 px."""
    pred, a_pred, gap = _predict(uv, angle, i, k, last)
    if not np.all(np.isfinite(pred)):
        return None
    H, W = frame.shape[:2]
    search = min(config.search_px + config.search_growth_px * (gap - 1), config.max_search_px)
    half = int(np.ceil(search + 2.2 * first.radii[k] + 8))
    u0, v0 = max(int(pred[0]) - half, 0), max(int(pred[1]) - half, 0)
    u1, v1 = min(int(pred[0]) + half + 1, W), min(int(pred[1]) + half + 1, H)
    if u1 - u0 < 8 or v1 - v0 < 8:
        return None
    off = np.array([u0, v0], dtype=float)
    return k, to_gray(frame[v0:v1, u0:u1]), off, pred - off, search, a_pred


def _follow_jobs(jobs: list, first: Detections, config: TrackerConfig) -> list:
    """:func:`follow_targets` on the :func:`_job` s of one frame: (k, centre (2,) px in the
    frame, contrast, orientation rad, predicted orientation rad) of each job, NaN where
    the target was not found."""
    ks = np.array([j[0] for j in jobs])
    c, con, a = follow_targets([j[1] for j in jobs], np.array([j[3] for j in jobs]), first.radii[ks],
                               first.contrasts[ks], np.array([j[4] for j in jobs]), config)
    return [(j[0], c[n] + j[2], con[n], a[n], j[5]) for n, j in enumerate(jobs)]


def _record(found: list, i: int, uv: np.ndarray, sig: np.ndarray, angle: np.ndarray, last: np.ndarray,
            unit_noise: np.ndarray, first: Detections) -> None:
    """Write what :func:`_follow_jobs` found in frame ``i`` into the tracks ``uv``, ``sig``,
    ``angle`` (orientation unwrapped against its prediction) and ``last``; ``unit_noise``
    (K,) px: each centre's sigma at its first frame's contrast."""
    for k, c, con, a, a_pred in found:
        if not np.isfinite(c[0]):
            continue
        uv[i, k] = c
        sig[i, k] = np.hypot(unit_noise[k] * first.contrasts[k] / max(con, 1e-6), SIGMA_FLOOR_PX)
        angle[i, k] = a_pred + _wrap_half(a - a_pred)
        last[k] = i


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
        # targets are followed together, except that one moving with a neighbour waits
        # for the targets before it (its prediction may take theirs in this frame)
        jobs: list = []
        for k in range(K):
            if jobs and not _has_velocity(uv, k, last[k]):
                _record(_follow_jobs(jobs, first, config), i, uv, sig, ang, last, unit * nz, first)
                jobs = []
            job = _job(frame, uv, ang, i, k, last, first, config)
            if job is not None:
                jobs.append(job)
        if jobs:
            _record(_follow_jobs(jobs, first, config), i, uv, sig, ang, last, unit * nz, first)
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
