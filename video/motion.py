"""From tracked target centres to the car's motion in metres and seconds.

Steps, each a pure function over arrays:

- ``classify_targets``: which targets are fixed (barrier, floor), which turn with a wheel
  (their pattern spins), which form the rigid passenger cell (moving targets whose mutual
  distances stay constant), and the direction of travel in the image;
- ``rigid_fit``: least-squares rigid (Procrustes) fit of the body targets of a frame to
  their positions in the reference frame: rotation and translation, residual;
- ``stabilise_on_fixed``: a camera shaken by the impact taken out of every track, from the
  fixed targets' common motion;
- ``body_pose``: image position of the CG and body rotation in every frame, with a
  one-sigma uncertainty from the detection noise and the fit residuals;
- ``cg_from_hubs``: the CG's image position from the hub centres and the vehicle file;
- ``travel_axes`` / ``to_car_plane``: car-plane axes from the level approach (camera
  roll taken out), pixels to car-plane metres;
- ``contact_time``: the start of the deceleration, by fitting ``x = a + b (t - tc)
  - c max(0, t - tc)^p`` (uniform motion, then the onset of a barrier force growing
  with crush) on a fine grid of ``tc``; ``impact_speed``: line fit before contact;
- ``kink_time`` / wheel events: the time a wheel stops turning (its spin angle leaves the
  rolling angle the body's travel implies), turns again, leaves the floor (its centre
  rises above the line it rolled along, ``floor_heights``) or lands again;
- ``crush_from_pose``: crush as the rigid outline's travel past the contact position.

Image positions are px ``(u, v)`` (v down); car-plane X is towards the barrier, Z up;
pitch is nose-down positive; angles rad; times s.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from video.errors import VideoError
from video.filters import integrated_autocorrelation_time

__all__ = [
    "Roles",
    "classify_targets",
    "rigid_fit",
    "Stabilised",
    "stabilise_on_fixed",
    "take_out_camera_motion",
    "BodyPose",
    "body_pose",
    "cg_from_hubs",
    "to_car_plane",
    "travel_axes",
    "contact_time",
    "impact_speed",
    "kink_time",
    "block_time",
    "unblock_time",
    "TYRE_STIFFNESS_N_PER_M",
    "tyre_unloading_m",
    "FloorEvent",
    "lift_time",
    "touchdown_time",
    "crush_from_pose",
    "floor_heights",
]


# ----------------------------------------------------------------- classification


@dataclass(frozen=True)
class Roles:
    """What each tracked target is.

    Attributes
    ----------
    kind : tuple of str
        Per target: ``"body"``, ``"front_hub"``, ``"rear_hub"``, ``"fixed"`` or
        ``"other"`` (moves but not rigidly with the body, e.g. on a crushing part; or a
        second track of another track's target, :func:`duplicate_tracks`).
    direction : int
        +1 if the car moves to the image's right, -1 to its left.
    body : (B,) int
        Indices of the body targets.
    copies : tuple of int
        Indices of the tracks that follow another track's target (:func:`duplicate_tracks`).
    """

    kind: tuple
    direction: int
    body: np.ndarray
    copies: tuple = ()

    def index(self, kind: str) -> int | None:
        """Index of the (first) target of ``kind``, or None."""
        return self.kind.index(kind) if kind in self.kind else None


def classify_targets(uv: np.ndarray, angle: np.ndarray, *, fixed_px: float = 8.0,
                     spin_rad: float = 0.5, rigid_px: float = 0.6,
                     rigid_rel: float = 0.002) -> Roles:
    """Separate fixed, hub and rigid-body targets from their tracks (a track that follows
    another's target, :func:`duplicate_tracks`, is none of them: "other").

    Parameters
    ----------
    uv : (n, K, 2) float
        Target centres per frame, px (NaN where lost).
    angle : (n, K) float
        Unwrapped pattern orientation per frame, rad (NaN where lost).
    fixed_px : float
        A target seen in at least half the frames whose centre never moves further than
        this from its median is fixed, px: wide enough for a camera shaken by the impact (a
        few px), far below the car's travel (its approach and crush: tens of px at least).
    spin_rad : float
        A moving target whose pattern turns through more than this (beyond what the
        body turns) is on a wheel hub, rad.
    rigid_px, rigid_rel : float
        Two targets are rigidly connected when the scatter (std) of their distance is
        below ``rigid_px + rigid_rel * distance``, px.

    Returns
    -------
    Roles

    Raises
    ------
    VideoError
        If no target moves, or fewer than two move rigidly together.
    """
    uv = np.asarray(uv, dtype=float)
    n, K, _ = uv.shape
    # a second track of another's target is neither fixed, nor a hub, nor on the cell
    copies = duplicate_tracks(uv)
    med = np.nanmedian(uv, axis=0)
    spread = np.nanmax(np.hypot(*(uv - med).transpose(2, 0, 1)), axis=0)
    seen = np.mean(np.isfinite(uv[:, :, 0]), axis=0)
    # a target seen only briefly (a car target lost early) can move little while it is seen
    moving = ((spread > fixed_px) | (seen < 0.5)) & ~copies
    if not moving.any():
        raise VideoError("no target moves during the film: the car is not tracked; "
                         "check that the film shows the approach and the crash")
    first = np.array([uv[np.flatnonzero(np.isfinite(uv[:, k, 0]))[0], k] for k in range(K)])
    # direction: the way the moving targets go during the first part of the film
    du = []
    for k in np.flatnonzero(moving):
        ok = np.flatnonzero(np.isfinite(uv[:, k, 0]))
        early = ok[: max(2, len(ok) // 4)]
        du.append(uv[early[-1], k, 0] - uv[early[0], k, 0])
    direction = 1 if np.nanmedian(du) >= 0 else -1
    turn = np.nanmax(angle, axis=0) - np.nanmin(angle, axis=0)
    body_turn = np.nanmedian(turn[moving])
    hub = moving & (turn > spin_rad + min(body_turn, spin_rad))
    cand = np.flatnonzero(moving & ~hub)
    # rigid pairs among the candidates
    rigid = np.zeros((K, K), bool)
    for i, j in combinations(cand, 2):
        d = np.hypot(*(uv[:, i] - uv[:, j]).T)
        d = d[np.isfinite(d)]
        if len(d) >= 3 and np.std(d) < rigid_px + rigid_rel * np.mean(d):
            rigid[i, j] = rigid[j, i] = True
    best = _largest_clique(cand, rigid)
    if len(best) < 2:
        raise VideoError(f"fewer than two targets move rigidly together (moving targets: "
                         f"{int(moving.sum())}, of them on wheels: {int(hub.sum())}); the "
                         "passenger cell needs at least two quadrant targets in view")
    kind = ["other"] * K
    for k in range(K):
        if not moving[k] and not copies[k]:
            kind[k] = "fixed"
    for k in best:
        kind[k] = "body"
    hubs = np.flatnonzero(hub)
    if len(hubs):
        # front = further along the direction of travel
        pos = direction * np.array([first[k, 0] for k in hubs])
        order = hubs[np.argsort(-pos)]
        kind[order[0]] = "front_hub"
        if len(order) > 1:
            kind[order[-1]] = "rear_hub"
    return Roles(kind=tuple(kind), direction=direction, body=np.array(best, dtype=int),
                 copies=tuple(int(k) for k in np.flatnonzero(copies)))


#: Two tracks whose centres stand within this distance of each other, px, in at least
#: DUPLICATE_SHARE of the frames where both are seen (and DUPLICATE_MIN_FRAMES or more)
#: follow the same target: quadrant targets are 10 px across or more and never overlap.
DUPLICATE_PX = 1.0
DUPLICATE_SHARE = 0.9
DUPLICATE_MIN_FRAMES = 10


def duplicate_tracks(uv: np.ndarray) -> np.ndarray:
    """Which tracks follow another track's target, (K,) bool.

    A spurious detection in frame 0 (between two fixed targets a few px apart: on
    development film 960055 one midway between two floor targets 17 px apart) is lost,
    then taken up by a neighbouring target and followed with it: two tracks of one target.
    The copy turns and moves from its first place to the target's (8 px and 1.5 rad
    there), like a hub, and was taken for the rear hub (the wheelbase 1.57 times too long,
    the film refused). Of two tracks within :data:`DUPLICATE_PX` px of each other in
    :data:`DUPLICATE_SHARE` of the frames both are seen, the copy is the one that came to
    the target the other was on: whose own path jumped more (the largest change of its
    velocity between consecutive seen frames, px per frame, up to the frame after they
    first coincide; the target's own path is smooth).

    Parameters
    ----------
    uv : (n, K, 2) float
        Target centres per frame, px (NaN where lost).
    """
    K = uv.shape[1]
    copies = np.zeros(K, bool)
    seen = np.isfinite(uv[:, :, 0])
    for i, j in combinations(range(K), 2):
        both = seen[:, i] & seen[:, j]
        if both.sum() < DUPLICATE_MIN_FRAMES or copies[i] or copies[j]:
            continue
        close = np.hypot(*(uv[both, i] - uv[both, j]).T) <= DUPLICATE_PX
        if close.mean() < DUPLICATE_SHARE:
            continue
        came = int(np.flatnonzero(both)[np.argmax(close)])  # the first frame they coincide
        jerk = [_largest_jerk(uv[: came + 2, k]) for k in (i, j)]
        copies[j if jerk[1] >= jerk[0] else i] = True
    return copies


def _largest_jerk(uv: np.ndarray) -> float:
    """The largest change of a track's velocity between its consecutive seen frames,
    px per frame (0 with fewer than three seen)."""
    f = np.flatnonzero(np.isfinite(uv[:, 0]))
    if len(f) < 3:
        return 0.0
    vel = np.diff(uv[f], axis=0) / np.diff(f)[:, None]
    return float(np.max(np.hypot(*np.diff(vel, axis=0).T)))


def _largest_clique(cand: np.ndarray, linked: np.ndarray, exact_up_to: int = 12) -> tuple:
    """Largest set of candidates all pairwise linked: exhaustive for up to
    ``exact_up_to`` candidates, else greedy (most-linked first)."""
    cand = [int(c) for c in cand]
    if len(cand) <= exact_up_to:
        for size in range(len(cand), 1, -1):
            for sub in combinations(cand, size):
                if all(linked[i, j] for i, j in combinations(sub, 2)):
                    return sub
        return ()
    order = sorted(cand, key=lambda i: -int(linked[i, cand].sum()))
    best: tuple = ()
    for seed in order[:5]:
        group = [seed]
        for j in order:
            if j not in group and all(linked[j, g] for g in group):
                group.append(j)
        if len(group) > len(best):
            best = tuple(sorted(group))
    return best if len(best) >= 2 else ()


# ------------------------------------------------------------------- rigid fitting


def rigid_fit(ref: np.ndarray, cur: np.ndarray, weights: np.ndarray | None = None
              ) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares rotation and translation taking ``ref`` points onto ``cur``.

    Parameters
    ----------
    ref, cur : (N, 2) float
        Matching points (N >= 2), px.
    weights : (N,) float, optional
        Weights (inverse variances).

    Returns
    -------
    phi : float
        Rotation, rad (image angle: positive turns ``+u`` towards ``+v``, clockwise on
        the screen).
    ref_c, cur_c : (2,) float
        Weighted centroids: ``cur ~ cur_c + R(phi) (ref - ref_c)``.
    residuals : (N, 2) float
        ``cur - fitted``, px.
    """
    w = np.ones(len(ref)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    rc = w @ ref
    cc = w @ cur
    a = ref - rc
    b = cur - cc
    cross = np.sum(w * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]))
    dot = np.sum(w * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]))
    phi = float(np.arctan2(cross, dot))
    R = _rot(phi)
    fitted = cc + a @ R.T
    return phi, rc, cc, cur - fitted


@dataclass(frozen=True)
class Stabilised:
    """Target centres with the camera's own motion taken out (:func:`stabilise_on_fixed`).

    Attributes
    ----------
    uv : (n, K, 2) float
        Centres as an unmoving camera would have seen them, px.
    sigma_px : (n, K) float
        Their one-sigma uncertainty, the fixed targets' own added in quadrature, px.
    shift_px : (n, 2) float
        The camera's image motion removed per frame (at the fixed targets' centroid), px;
        NaN where no fixed target was seen.
    roll : (n,) float
        The camera's roll removed per frame, rad (0 with one fixed target).
    centre_px : (n, 2) float
        Where the points the motion was measured on had their centroid in each frame, px:
        the roll turns about it (NaN where not measured).
    """

    uv: np.ndarray
    sigma_px: np.ndarray
    shift_px: np.ndarray
    roll: np.ndarray
    centre_px: np.ndarray
    turn: CameraTurn | None = None

    def correct(self, i: int, points: np.ndarray) -> np.ndarray:
        """Image points (M, 2) px of frame ``i`` as the unmoving camera would have seen them
        (as they are where frame ``i``'s motion was not measured)."""
        points = np.asarray(points, float)
        if not np.isfinite(self.shift_px[i, 0]):
            return points
        if self.turn is not None:
            return self.turn.correct(i, points)
        c = self.centre_px[i]
        return c - self.shift_px[i] + (points - c) @ _rot(self.roll[i])  # R(roll)^-1 applied to each row


@dataclass(frozen=True)
class CameraTurn:
    """A shaken camera's motion as the small turn of a pinhole camera it is.

    The camera turning by ``pan``, ``tilt`` and ``roll`` (rad, small) moves an image point
    ``(x, y)`` px from the principal point by (:func:`turn_field`)
    ``pan (f + x^2/f, x y/f) + tilt (x y/f, f + y^2/f) + roll (-y, x)``: a point far off
    the axis moves more than one on it, by ``1 + x^2/f^2`` (a third more at ``x = 0.6 f``).
    A shift and roll (:func:`rigid_fit`) is the limit of a long lens (``f`` large).

    Attributes
    ----------
    focal_px : float
        Focal length, px.
    principal_px : (2,) px
        Principal point (the lens's centre).
    angles : (n, 3) rad
        Pan, tilt, roll per frame (NaN where not measured).
    """

    focal_px: float
    principal_px: np.ndarray
    angles: np.ndarray

    def correct(self, i: int, points: np.ndarray) -> np.ndarray:
        """Points (M, 2) px of frame ``i`` where the unturned camera saw them: the motion
        field taken out, evaluated where the point stood (one fixed-point step; the field
        changes by a hundredth of itself across a shake of a few px)."""
        points = np.asarray(points, float)
        a = self.angles[i]
        if not np.all(np.isfinite(a)):
            return points
        out = points - turn_field(points - self.principal_px, self.focal_px) @ a
        return points - turn_field(out - self.principal_px, self.focal_px) @ a


def turn_field(xy: np.ndarray, f: float) -> np.ndarray:
    """The image motion (M, 2, 3) px per rad of pan, tilt and roll of a pinhole camera of
    focal length ``f`` px at points ``xy`` (M, 2) px from the principal point; ``f``
    infinite: a shift (``pan f``, ``tilt f`` px, reported per unit of ``f``) and a roll."""
    xy = np.asarray(xy, float)
    x, y = xy[:, 0], xy[:, 1]
    if np.isinf(f):
        one, zero = np.ones_like(x), np.zeros_like(x)
        return np.stack([np.stack([one, zero, -y], axis=1), np.stack([zero, one, x], axis=1)], axis=1)
    return np.stack([np.stack([f + x * x / f, x * y / f, -y], axis=1),
                     np.stack([x * y / f, f + y * y / f, x], axis=1)], axis=1)


#: Fixed targets moving together by less than this are taken to stand still: no correction, px.
SHAKE_MIN_PX = 0.3
#: ... or by less than this many of their own standard deviations (shift, and roll apart).
SIGNIFICANT = 6.0


def stabilise_on_fixed(uv: np.ndarray, sigma_px: np.ndarray, fixed: np.ndarray,
                       principal_px: np.ndarray | None = None) -> Stabilised | None:
    """Take a shaking camera's motion out of every target's track, using the fixed targets.

    A camera shaken by the impact turns a little (a few tenths of a degree): every image
    point moves by nearly the same shift and roll, whatever its depth, so the fixed targets'
    (barrier, floor) motion in each frame is the camera's. Their reference positions are
    their medians over the film; in each frame the rigid motion (rotation and translation,
    :func:`rigid_fit`; translation alone with one fixed target) taking the reference onto
    the seen fixed targets is inverted and applied to every target. Only a shake counts:
    the fixed targets must move together by more than :data:`SHAKE_MIN_PX` and
    :data:`SIGNIFICANT` times their shift's noise in some frame, and the roll is taken out
    only when it too stands that far out of its noise (fixed targets close together measure
    it poorly). The correction's noise enters every corrected centre in quadrature: the
    shift's (the fixed targets' sigma over the square root of their number) and, with the
    roll, the roll's times the distance from the fixed targets' centroid.

    Parameters
    ----------
    uv : (n, K, 2) float
        Target centres per frame, px (NaN where lost).
    sigma_px : (n, K) float
        Their one-sigma uncertainty per axis, px.
    fixed : (F,) int
        Indices of the fixed targets (``Roles.kind == "fixed"``).
    principal_px : (2,) px, optional
        The principal point: with it, the camera's motion is taken out as the turn it is
        where the fixed targets tell it from a shift and roll (:func:`fit_camera_turn`).

    Returns
    -------
    Stabilised or None
        None when there is no fixed target, or no shake (a still camera: correcting it would
        only add the fixed targets' noise). Frames without a fixed target in view are left as
        they are (shift NaN).
    """
    uv = np.asarray(uv, dtype=float)
    sigma_px = np.asarray(sigma_px, dtype=float)
    fixed = np.asarray(fixed, dtype=int)
    if len(fixed) == 0:
        return None
    n = uv.shape[0]
    ref = np.nanmedian(uv[:, fixed], axis=0)
    shift = np.full((n, 2), np.nan)
    roll = np.full(n, np.nan)
    shift_sig = np.full(n, np.nan)  # one-sigma of the shift per axis, px
    roll_sig = np.full(n, np.nan)  # of the roll, rad
    centre = np.full((n, 2), np.nan)
    for i in range(n):
        seen = np.all(np.isfinite(uv[i, fixed]), axis=1) & np.all(np.isfinite(ref), axis=1)
        if not seen.any():
            continue
        r, c = ref[seen], uv[i, fixed[seen]]
        s_rms = float(np.sqrt(np.nanmean(sigma_px[i, fixed[seen]] ** 2)))
        if seen.sum() >= 2:
            phi, rc, cc, _ = rigid_fit(r, c)
            roll[i], roll_sig[i] = phi, s_rms / np.sqrt(np.sum((r - rc) ** 2))
        else:
            rc, cc = r[0], c[0]
        shift[i], shift_sig[i], centre[i] = (cc - rc), s_rms / np.sqrt(seen.sum()), cc
    if not np.isfinite(shift_sig).any():
        return None
    size = np.hypot(*shift.T)
    # a shake: the fixed targets move together by more than SHAKE_MIN_PX and far beyond their noise
    if not (np.nanmax(size) > SHAKE_MIN_PX and np.nanmax(size / shift_sig) > SIGNIFICANT):
        return None
    # the roll only when it stands out of its own noise somewhere (close fixed targets
    # measure it poorly, and its error grows with the distance to every other target)
    use_roll = bool(np.max(np.nan_to_num(np.abs(roll) / roll_sig), initial=0.0) > SIGNIFICANT)
    roll = np.where(np.isfinite(roll) & use_roll, roll, 0.0)
    turn = None if principal_px is None else fit_camera_turn(uv, sigma_px, fixed, ref, principal_px)
    return take_out_camera_motion(uv, sigma_px, shift, roll, centre, shift_sig,
                                  np.nan_to_num(roll_sig) if use_roll else np.zeros(n), turn)


#: Focal lengths tried for a camera's turn, as multiples of twice the principal point's
#: column (the picture's width): from a wide lens to a long one.
TURN_FOCAL_WIDTHS = np.geomspace(0.2, 20.0, 121)
#: How far apart (px) the turn's growth off the axis must move the fixed targets at the
#: largest shake for the turn to be told: on development film 960059 two floor targets 24 px
#: apart, 300 px off the axis, moved 0.03 px apart (f = 782 px, 1.5 px of shake), which the
#: tracking's own errors of a few hundredths of a px took for f = 505 px (x RMS 0.59 -> 1.13
#: mm); on 960044 the barrier and floor targets moved 2.6 px apart (f fitted 577, true 643).
MIN_TURN_SPREAD_PX = 0.5
#: How much better (chi-square over the frames' correlation time, scaled by the best fit's
#: reduced chi-square when above 1) the turn of a camera of finite focal length must explain
#: the fixed targets' motion than a shift and roll (its long-lens limit) to be taken. Counted
#: without the correlation time, development film 960032's tracking errors (alike over
#: frames) bought a turn of f = 331 px (true 575) by a chi-square of 125 over 490 frames;
#: the contact was then seen 3.4 ms early with a sigma of 0.6 ms.
MIN_TURN_GAIN = 25.0


def _frames_correlation_time(res: np.ndarray, seen: np.ndarray) -> float:
    """The median over columns (a target's coordinate) of the correlation time of its
    residuals from frame to frame (:func:`video.filters.integrated_autocorrelation_time`,
    frames where it is seen), samples; 1 without a column of 10 seen frames."""
    taus = [integrated_autocorrelation_time(res[seen[:, j], j]) for j in range(res.shape[1]) if seen[:, j].sum() >= 10]
    return float(np.median(taus)) if taus else 1.0


def fit_camera_turn(uv: np.ndarray, sigma_px: np.ndarray, fixed: np.ndarray, ref: np.ndarray,
                    principal_px: np.ndarray) -> CameraTurn | None:
    """The shaken camera's turn per frame and its focal length, from the fixed targets.

    The fixed targets' motion from their reference places ``ref`` is fitted, frame by
    frame, as the camera's pan, tilt and roll (:func:`turn_field`, weighted least squares;
    frames with two fixed targets or more), for every focal length of
    :data:`TURN_FOCAL_WIDTHS` and for a shift and roll; the focal length with the least
    chi-square summed over the frames wins where it beats the shift and roll by
    :data:`MIN_TURN_GAIN`, the gain divided by the residuals' correlation time over the
    frames (fixed targets spread across the picture tell the two apart; a
    shake measured at a picture's edge and taken out of a car near its middle as a shift
    overshoots it by ``x^2/f^2``: on development film 960044, f = 643 px, barrier targets
    470 px off the axis, by a quarter, 1.2 px or 10 mm at the shake's peak, and the
    deceleration onset came out 20 ms early). Frames with one fixed target seen: pan and
    tilt only.

    Parameters
    ----------
    uv : (n, K, 2) px
        Target centres per frame (undistorted), NaN where lost.
    sigma_px : (n, K) px
        Their one-sigma per axis.
    fixed : (F,) int
        The fixed targets.
    ref : (F, 2) px
        Their places with the camera still.
    principal_px : (2,) px
        The principal point (the lens's centre).

    Returns
    -------
    CameraTurn or None
        None with fewer than two fixed targets, or where a shift and roll does as well.
    """
    fixed = np.asarray(fixed, int)
    if len(fixed) < 2:
        return None
    c = np.asarray(principal_px, float)
    seen = np.all(np.isfinite(uv[:, fixed]), axis=2) & np.isfinite(sigma_px[:, fixed]) & \
        np.all(np.isfinite(ref), axis=1)[None, :]
    frames = np.flatnonzero(seen.sum(axis=1) >= 2)
    if not len(frames):
        return None

    # the frames' rows at once: (frames, 2F, 3) design, (frames, 2F) motions, weights 0 where unseen
    b = (uv[frames][:, fixed] - ref[None]).reshape(len(frames), -1)
    w = np.repeat(np.where(seen[frames], 1.0 / np.maximum(np.nan_to_num(sigma_px[frames][:, fixed]), 1e-3), 0.0),
                  2, axis=1)
    b = np.nan_to_num(b)
    m = int(2 * seen[frames].sum() - 3 * len(frames))

    def residuals(f):
        """(frames, 2F) weighted residuals of every frame's best pan, tilt and roll at focal
        length ``f`` px (0 where a target is unseen)."""
        A = np.nan_to_num(turn_field(ref - c, f).reshape(-1, 3))[None] * w[:, :, None]
        coef = np.einsum("nij,nj->ni", np.linalg.pinv(np.einsum("nri,nrj->nij", A, A)),
                         np.einsum("nri,nr->ni", A, b * w))
        return np.einsum("nri,ni->nr", A, coef) - b * w

    def chi2(f):
        return float(np.sum(residuals(f) ** 2))

    focal = TURN_FOCAL_WIDTHS * 2.0 * max(float(c[0]), 1.0)
    scores = [chi2(f) for f in focal]
    k = int(np.argmin(scores))
    rigid = chi2(np.inf)
    # frames' tracking errors are alike from one frame to the next: the gain counts
    # len(frames) / tau independent frames (tau the median over the targets' coordinates)
    gain = (rigid - scores[k]) / _frames_correlation_time(residuals(focal[k]), w > 0)
    if not gain > MIN_TURN_GAIN * max(1.0, scores[k] / max(m, 1)):
        return None
    # the turn shows only between fixed targets at different distances from the axis: their
    # spread of (x^2 + y^2) / f^2 times the largest shake is how far apart it moves them
    r2 = np.sum((ref[np.all(np.isfinite(ref), axis=1)] - c) ** 2, axis=1) / float(focal[k]) ** 2
    shake = float(np.max(np.hypot(b[:, 0::2], b[:, 1::2]) * (w[:, 0::2] > 0)))
    if (r2.max() - r2.min()) * shake < MIN_TURN_SPREAD_PX:
        return None
    f = float(focal[k])
    if 0 < k < len(focal) - 1:  # between the grid's steps (4 %): the parabola through the best three, in log f
        y0, y1, y2 = scores[k - 1], scores[k], scores[k + 1]
        step = float(np.log(focal[k + 1] / focal[k]))
        curve = y0 - 2.0 * y1 + y2
        if curve > 0:
            f *= float(np.exp(0.5 * step * (y0 - y2) / curve))
    angles = np.full((len(uv), 3), np.nan)
    for i in np.flatnonzero(seen.sum(axis=1) >= 1):
        A_i, b_i, w_i = _turn_rows(uv[i, fixed], sigma_px[i, fixed], ref, seen[i], c, f)
        free = slice(0, 3) if seen[i].sum() >= 2 else slice(0, 2)  # one target: no roll
        coef, *_ = np.linalg.lstsq(A_i[:, free] * w_i[:, None], b_i * w_i, rcond=None)
        angles[i] = 0.0
        angles[i, free] = coef
    return CameraTurn(focal_px=f, principal_px=c, angles=angles)


def _turn_rows(cur: np.ndarray, sigma: np.ndarray, ref: np.ndarray, seen: np.ndarray, c: np.ndarray,
               f: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One frame's least-squares rows of the camera's turn: design (2m, 3), motions (2m,)
    px and weights (2m,) 1/px, of the ``seen`` fixed targets."""
    A = turn_field(ref[seen] - c, f).reshape(-1, 3)
    b = (cur[seen] - ref[seen]).reshape(-1)
    w = np.repeat(1.0 / np.maximum(sigma[seen], 1e-3), 2)
    return A, b, w


def take_out_camera_motion(uv: np.ndarray, sigma_px: np.ndarray, shift: np.ndarray, roll: np.ndarray,
                           centre: np.ndarray, shift_sigma: np.ndarray, roll_sigma: np.ndarray,
                           turn: CameraTurn | None = None) -> Stabilised:
    """Target centres ``uv`` (n, K, 2) px as an unmoving camera would have seen them: in each
    frame whose ``shift`` (n, 2) px is measured, the camera's motion (that shift of the
    points measured, their centroid now at ``centre`` (n, 2), and a ``roll`` (n,) rad about
    it; with ``turn``, the camera's turn instead, :class:`CameraTurn`) inverted and applied
    to every centre; ``sigma_px`` (n, K) with the correction's noise added in quadrature
    (``shift_sigma`` (n,) px, and ``roll_sigma`` (n,) rad times the distance from
    ``centre``). Frames with no shift measured are left as they are."""
    motion = Stabilised(uv=np.array(uv, float, copy=True), sigma_px=np.array(sigma_px, float, copy=True),
                        shift_px=shift, roll=roll, centre_px=centre, turn=turn)
    for i in np.flatnonzero(np.isfinite(shift[:, 0])):
        motion.uv[i] = motion.correct(i, uv[i])
        lever = np.hypot(*(uv[i] - centre[i]).T)
        motion.sigma_px[i] = np.sqrt(sigma_px[i] ** 2 + shift_sigma[i] ** 2 + (roll_sigma[i] * lever) ** 2)
    return motion


def _rot(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


@dataclass(frozen=True)
class BodyPose:
    """The passenger cell's image pose per frame.

    Attributes
    ----------
    point : (n, 2) float
        Image position of the tracked body point (the CG), px; NaN where fewer than two
        body targets were seen.
    point_sigma : (n,) float
        One-sigma uncertainty of ``point`` per axis, px.
    phi : (n,) float
        Body rotation from the reference frame, rad (image angle, clockwise positive).
    phi_sigma : (n,) float
        Its one-sigma uncertainty, rad.
    rms_px : (n,) float
        RMS residual of the rigid fit, px.
    n_targets : (n,) int
        Body targets used in each frame.
    ref_frame : int
        Frame whose target positions are the reference.
    """

    point: np.ndarray
    point_sigma: np.ndarray
    phi: np.ndarray
    phi_sigma: np.ndarray
    rms_px: np.ndarray
    n_targets: np.ndarray
    ref_frame: int

    def transform(self, i: int, p_ref: np.ndarray) -> np.ndarray:
        """Where body points ``p_ref`` (M, 2) px of the reference frame are in frame ``i``."""
        return self.point[i] + (np.asarray(p_ref) - self._ref_point) @ _rot(self.phi[i]).T

    @property
    def _ref_point(self) -> np.ndarray:
        return self.point[self.ref_frame]


def body_pose(uv: np.ndarray, sigma_px: np.ndarray, body: np.ndarray, point_ref: np.ndarray,
              ref_frame: int) -> BodyPose:
    """Rigid fit of the body targets in every frame; follow one body point.

    Parameters
    ----------
    uv : (n, K, 2) float
        Target centres, px (NaN where lost).
    sigma_px : (n, K) float
        One-sigma detection uncertainty per centre and axis, px.
    body : (B,) int
        Indices of the body targets (B >= 2).
    point_ref : (2,) float
        The followed body point (the CG) in the reference frame's image, px.
    ref_frame : int
        Reference frame; every body target must be seen in it.

    Returns
    -------
    BodyPose
        Frames with fewer than two body targets are NaN.
    """
    n = uv.shape[0]
    ref = uv[ref_frame, body]
    if not np.all(np.isfinite(ref)):
        raise VideoError(f"a body target is not seen in the reference frame {ref_frame}")
    point = np.full((n, 2), np.nan)
    psig = np.full(n, np.nan)
    phi = np.full(n, np.nan)
    phis = np.full(n, np.nan)
    rms = np.full(n, np.nan)
    used = np.zeros(n, int)
    for i in range(n):
        cur = uv[i, body]
        ok = np.all(np.isfinite(cur), axis=1) & np.isfinite(sigma_px[i, body])
        m = int(ok.sum())
        used[i] = m
        if m < 2:
            continue
        s = np.maximum(sigma_px[i, body][ok], 1e-3)
        w = 1.0 / s**2
        p, rc, cc, res = rigid_fit(ref[ok], cur[ok], w)
        phi[i] = p
        point[i] = cc + _rot(p) @ (point_ref - rc)
        r2 = float(np.sum(res**2))
        dof = 2 * m - 3
        s_det = float(np.sqrt(np.mean(s**2)))
        s_fit = np.sqrt(r2 / dof) / np.sqrt(2.0) if dof > 0 else 0.0
        s_pt = max(s_det, s_fit)
        a = ref[ok] - rc
        spread = float(np.sum(a**2))
        phis[i] = s_pt / np.sqrt(spread)
        lever = float(np.hypot(*(point_ref - rc)))
        psig[i] = np.sqrt(s_pt**2 / m + (lever * phis[i]) ** 2)
        rms[i] = np.sqrt(r2 / m)
    return BodyPose(point=point, point_sigma=psig, phi=phi, phi_sigma=phis, rms_px=rms,
                    n_targets=used, ref_frame=ref_frame)


def cg_from_hubs(front_uv: np.ndarray, rear_uv: np.ndarray, direction: int, m_per_px: float,
                 x_cg_from_rear_axle: float, cg_above_axles: float) -> tuple[np.ndarray, np.ndarray]:
    """Image position of the CG from the two hub centres of one frame.

    Parameters
    ----------
    front_uv, rear_uv : (2,) float
        Hub centres, px (wheel centres at the axles: car at rest on level ground).
    direction : int
        +1 or -1 (travel to the image's right or left).
    m_per_px : float
        Scale in the car plane, m/px.
    x_cg_from_rear_axle : float
        CG ahead of the rear axle, m.
    cg_above_axles : float
        CG height above the axle line (cg_height - wheel_radius), m.

    Returns
    -------
    cg_uv : (2,) float
        px.
    axes : (2, 2) float
        Image unit vectors of the vehicle frame's x (forward) and z (up).
    """
    ex = np.asarray(front_uv, float) - np.asarray(rear_uv, float)
    ex = ex / np.hypot(*ex)
    ez = direction * np.array([ex[1], -ex[0]])
    cg = np.asarray(rear_uv, float) + (x_cg_from_rear_axle * ex + cg_above_axles * ez) / m_per_px
    return cg, np.stack([ex, ez])


def to_car_plane(duv: np.ndarray, direction: int, m_per_px: float,
                 axes: np.ndarray | None = None) -> np.ndarray:
    """Image displacements to car-plane displacements.

    Parameters
    ----------
    duv : (..., 2) float
        Displacements in the image, px.
    direction : int
        +1 (travel to the image's right) or -1.
    m_per_px : float
        Scale, m/px.
    axes : (2, 2) float, optional
        Image unit vectors of car-plane X (travel) and Z (up), e.g. from
        :func:`travel_axes`; default: the image axes (``X = direction * u``, ``Z = -v``).

    Returns
    -------
    (..., 2) float
        ``[dX, dZ]``, m.
    """
    duv = np.asarray(duv, dtype=float)
    if axes is None:
        return np.stack([direction * duv[..., 0], -duv[..., 1]], axis=-1) * m_per_px
    return np.stack([duv @ axes[0], duv @ axes[1]], axis=-1) * m_per_px


#: The approach sets the car plane's axes when the direction fitted to it is this sure (its
#: standard error, rad); otherwise the image's axes stand. Before, a path shorter than 20 px
#: was never used: on reference world 960609 (17 px of approach in 13 frames, the camera
#: rolled 2.21 degrees, the fitted direction 2.17 +- 0.07) the crash's x then leaked into z:
#: 18 mm RMS against the truth over -15..250 ms, 1.3 mm with the approach's direction.
MAX_ROLL_SE_RAD = float(np.radians(0.25))


def travel_axes(points: np.ndarray, stop: int, direction: int) -> tuple[np.ndarray, float]:
    """Car-plane axes in the image from the approach: the car runs level before contact.

    A straight line is fitted (total least squares) to a body point's image positions in
    the frames before ``stop``; its direction, pointing the way the car travels, is
    car-plane X; Z is perpendicular to it, upwards. This removes the camera's roll.

    Parameters
    ----------
    points : (n, 2) float
        A body point per frame (e.g. the CG), px; NaN where not measured.
    stop : int
        First frame not used (contact).
    direction : int
        +1 or -1.

    Returns
    -------
    axes : (2, 2) float
        Unit vectors of X and Z in the image.
    roll : float
        Camera roll, rad (image angle of the travel direction against the image's u
        axis, clockwise positive).
    """
    p = np.asarray(points, float)[:stop]
    p = p[np.all(np.isfinite(p), axis=1)]
    ex = np.array([float(direction), 0.0])  # the image's own axes, when the approach cannot tell
    if len(p) >= 5:
        c = p - p.mean(axis=0)
        _, sv, vt = np.linalg.svd(c, full_matrices=False)
        # the direction's standard error: the points' scatter across the line over their
        # spread along it
        if sv[0] > 0.0 and sv[1] / np.sqrt(len(p) - 2) / sv[0] <= MAX_ROLL_SE_RAD:
            ex = vt[0] / np.hypot(*vt[0])
            if ex[0] * direction < 0:
                ex = -ex
    ez = direction * np.array([ex[1], -ex[0]])
    roll = float(np.arctan2(direction * ex[1], direction * ex[0]))
    return np.stack([ex, ez]), roll


# ----------------------------------------------------------------------- contact


def weighted_line(t: np.ndarray, x: np.ndarray, sigma: np.ndarray) -> tuple[float, float, float]:
    """A straight line fitted to ``x`` against ``t``, each point weighted by 1 / ``sigma``.

    Returns (slope (x unit per t unit), its standard deviation were the sigmas right and the
    points independent, the reduced chi-square of the residuals (at least 1))."""
    ss = np.maximum(sigma, 1e-9)
    design = np.stack([np.ones_like(t), t - t.mean()], axis=1) / ss[:, None]
    coef, *_ = np.linalg.lstsq(design, x / ss, rcond=None)
    cov = np.linalg.inv(design.T @ design)
    res = (x - (coef[0] + coef[1] * (t - t.mean()))) / ss
    chi = max(1.0, float(np.sum(res**2)) / max(len(t) - 2, 1))
    return float(coef[1]), float(np.sqrt(cov[1, 1])), chi


def impact_speed(t: np.ndarray, x: np.ndarray, sigma: np.ndarray, stop: int
                 ) -> tuple[float, float]:
    """Speed from a weighted line fit to ``x`` over the frames before ``stop``
    (:func:`weighted_line`, its sigma widened by the residuals' reduced chi-square).

    Parameters
    ----------
    t, x, sigma : (n,) float
        Time s, displacement m, its one-sigma m.
    stop : int
        First frame not used (the contact frame).

    Returns
    -------
    speed, speed_sigma : float
        m/s.
    """
    ok = np.isfinite(x[:stop]) & np.isfinite(sigma[:stop])
    if ok.sum() < 3:
        raise VideoError(f"only {int(ok.sum())} frames before contact have the car's position; "
                         "the impact speed needs at least 3 (give --speed)")
    speed, sd, chi = weighted_line(t[:stop][ok], x[:stop][ok], sigma[:stop][ok])
    return speed, float(sd * np.sqrt(chi))


#: Exponent of the onset model ``x = a + b (t - tc) - c max(0, t - tc)^p``: 3, a force growing
#: from zero with the crush (a = j (t - tc)), as the real barrier force of NHTSA 10146 does
#: (2.6, 9.2, 26, 94 kN at 0, 2, 5, 10 ms after its onset) and the reference world's. A force
#: that jumps at contact (2), tried beside it, fitted the slow first milliseconds better with a
#: later onset: on a film made from 10146's real pulse (0.3 mm of noise) the onset came 8.6-9.5
#: ms late with it, 2.6-4.1 ms late without it; on the reference world's development films
#: (960000-960039) within 1 ms on 11 of 40 with it, 16 without it (calibration 14 -> 19 of 36).
ONSET_EXPONENT = 3.0


#: The onset fit's residuals are alike from frame to frame once the car decelerates (the
#: tracked x wanders by 0.1-1 mm over several frames against the truth on development films
#: 960000-960039, a lag-one correlation of 0.3-0.9 after contact, about 0 before it): least
#: squares that counts each frame as independent takes that wander for the onset's curvature.
#: The fit is therefore made on rows with the residuals' lag-one correlation ``phi`` taken out
#: (``r_i - phi r_{i-1}``, an AR(1) error; Cochrane-Orcutt: ``phi`` from the residuals of the
#: fit before, until it changes by less than ONSET_CORRELATION_TOL or ONSET_ITERATIONS fits).
#: Measured on 960000-960039 (the x series the tracker gave the onset fit): onset error RMS
#: 1.49 -> 1.29 ms, within 1 ms on the 7 films whose contact the picture did not show 3 -> 6
#: (960032: -3.9 -> -0.4 ms); on the film of 10146's real pulse 2.6-4.1 -> 2.6-4.0 ms late.
#: Confirmed on 960040-960079 (chosen on the first 40 only): RMS 2.35 -> 2.22 ms, within 1 ms
#: 57 -> 62 % of the films (960043: +2.6 -> +0.3 ms). What is left is mostly the tracked x's
#: own error (on 960000-960039's true x with white noise the onset is within 1 ms on 93 %, and
#: 0.4 ms early on average: the pulse grows less than linearly over the 20-28 ms the fit spans).
#: ``phi`` is kept in [0, ONSET_MAX_CORRELATION]: a negative one (a repeated frame, a
#: re-encoding's alternation) is not the slow wander this is about, and 1 would leave no rows.
ONSET_MAX_CORRELATION = 0.95
ONSET_CORRELATION_TOL = 0.005
ONSET_ITERATIONS = 20


def _onset_design(t, tc, p, shake=None):
    """The onset model's columns at ``tc``: 1, t - tc, -max(0, t - tc)^p, and ``shake`` (the
    camera's motion taken out of x, m) when given."""
    d = np.maximum(t - tc, 0.0) ** p
    cols = [np.ones_like(t), t - tc, -d] + ([] if shake is None else [shake])
    return np.stack(cols, axis=1)


def _onset_rows(t, x, w, tc, p, phi=0.0, shake=None):
    """The onset model's weighted rows at ``tc`` and their right-hand side, with the rows'
    lag-one correlation ``phi`` taken out: (A, y)."""
    A = _onset_design(t, tc, p, shake) * w[:, None]
    y = x * w
    if phi:
        A, y = A[1:] - phi * A[:-1], y[1:] - phi * y[:-1]
    return A, y


def _onset_sse(t, x, w, tc, p, phi=0.0, shake=None):
    """Weighted least squares of the onset model at ``tc`` on rows whose lag-one correlation
    ``phi`` is taken out: (chi-square of those rows, coefficients a, b, c[, the shake's])."""
    A, y = _onset_rows(t, x, w, tc, p, phi, shake)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = A @ coef - y
    return float(r @ r), coef


def _lag_one_correlation(r: np.ndarray) -> float:
    """Lag-one autocorrelation of ``r`` (1), clipped to [0, ONSET_MAX_CORRELATION]."""
    r = r - r.mean()
    den = float(r @ r)
    if len(r) < 3 or den <= 0:
        return 0.0
    return float(np.clip(float(r[1:] @ r[:-1]) / den, 0.0, ONSET_MAX_CORRELATION))


def deceleration_start(t: np.ndarray, x: np.ndarray) -> float:
    """Where the speed (differences of ``x`` over 5 frames) falls 2 % below the approach
    speed and stays there for 10 samples, s (a repeated frame makes a dip of only 5):
    :func:`contact_time`'s first guess, at or after the onset. VideoError when the car
    does not move towards the barrier at first, or never decelerates."""
    ok = np.isfinite(x)
    if ok.sum() < 10:
        raise VideoError("fewer than 10 frames with the car's position; cannot find the contact")
    tt, xx = t[ok], x[ok]
    lag = 5
    v = (xx[lag:] - xx[:-lag]) / (tt[lag:] - tt[:-lag])
    n0 = max(3, len(v) // 8)
    v0 = float(np.median(v[:n0]))
    if not v0 > 0:
        raise VideoError("the car does not move towards the barrier at the start of the film; "
                         "the film must begin before contact")
    slow = _first_run(v < 0.98 * v0, 2 * lag)
    if slow is None:
        raise VideoError("the car never decelerates in the film: no contact with the barrier "
                         "found; check that the film includes the impact")
    # v[j] is the speed between samples j and j + lag, centred at j + lag / 2
    return float(tt[min(slow + lag, len(tt) - 1)])


#: A camera motion taken out of x counts in the onset's fit where it reaches this many of
#: x's own sigmas in the fitted window, m/m.
SHAKE_IN_ONSET_SIGMAS = 1.0
#: The largest share of the shake's correction a camera's turn can leave in x: a point u px
#: off the axis moves (1 + u^2/f^2) times what one on it does, and within a crash camera's
#: field of view (up to 70 degrees across, u/f <= 0.7) the car's and the fixed targets'
#: factors differ by less than half. A larger share is not the turn's (development film
#: 960053, whose x was already 9.4 mm off: -100 %, and the onset went 7.7 ms early with it).
MAX_SHAKE_SHARE = 0.5


def contact_time(t: np.ndarray, x: np.ndarray, sigma: np.ndarray, fps: float,
                 window_after_s: float = 0.012, shake: np.ndarray | None = None) -> tuple[float, str]:
    """Time at which the car's deceleration starts, s (sub-frame).

    A first guess is where the speed (differences of ``x`` over 5 frames) falls 2 %
    below the approach speed and stays there for 10 samples; the onset model ``x = a + b (t - tc) - c max(0, t -
    tc)^p`` (p = :data:`ONSET_EXPONENT`) is then fitted for every ``tc`` on a grid of 0.02
    frame around it, by weighted linear least squares in ``a, b, c``; the best ``tc`` wins.
    The residuals' lag-one correlation is then taken out of the rows and the grid searched
    again, until that correlation settles (Cochrane-Orcutt, :data:`ONSET_MAX_CORRELATION`):
    a tracked x that wanders over several frames is not taken for the onset's curvature.

    With ``shake``, the camera's motion that was taken out of x (a shake measured on fixed
    targets or the background, which the impact sets off), a multiple of it is fitted with
    the onset (a fourth column) where it exceeds x's sigma in the window, and dropped again
    where it comes out beyond :data:`MAX_SHAKE_SHARE`: a camera that turns moves the
    picture's edges more than its middle (by x^2/f^2), so a shake measured at the
    barrier and taken out of the car leaves a share of it in x, starting with the contact.
    Fitted as an onset, that share moved it: on development films 960080 and 960093 (3.5 and
    3.8 px of shake, 21 and 13 % of it left in x: up to 3.5 and 4.0 mm) the onset came out
    18.9 and 12.1 ms early, and the contact was looked for in the picture around it; with the
    column, 0.9 ms early and on time.

    Parameters
    ----------
    t, x, sigma : (n,) float
        Frame times s, CG displacement towards the barrier m, its one-sigma m.
    fps : float
        Frames per second.
    window_after_s : float
        How far past the first guess the fit reaches, s.
    shake : (n,) float, optional
        The camera's motion taken out of ``x`` per frame, in x's units (m; NaN or 0 where
        none was).

    Returns
    -------
    tc : float
        Contact time, s, on the clock of ``t``.
    how : str
        A short description for the notes.
    """
    guess, ts, xs, ws, cam = _onset_window(t, x, sigma, window_after_s, shake)
    grid = np.arange(guess - 0.03, guess + 2.0 / fps, 0.02 / fps)
    how = "contact from the onset of deceleration (a force growing from zero with the crush"
    tc, phi, coef = _fitted_onset(grid, ts, xs, ws, cam)
    if cam is not None and abs(coef[3]) > MAX_SHAKE_SHARE:
        how += (f"; the camera's shake correction not fitted with it: {100 * coef[3]:+.0f} % of it came out left in x,"
                " more than a camera's turn leaves")
        tc, phi, coef = _fitted_onset(grid, ts, xs, ws, None)
    elif cam is not None:
        how += f"; {100 * abs(coef[3]):.0f} % of the camera's shake fitted as left in x"
    return float(tc), how + (f"; its residuals' frame-to-frame correlation {phi:.2f} taken out)" if phi else ")")


def _fitted_onset(grid, ts, xs, ws, cam):
    """The onset model's best ``tc`` over ``grid`` (s) on the frames ``ts, xs, ws`` (and the
    shake column ``cam``, or None), the residuals' lag-one correlation taken out until it
    settles: (tc s, the correlation the last fit's rows took out, its coefficients)."""
    new = 0.0
    for _ in range(ONSET_ITERATIONS):
        phi = new  # the correlation this fit's rows have taken out (what the note says)
        tc, _ = _coarse_to_fine(grid, lambda tc: _onset_sse(ts, xs, ws, tc, ONSET_EXPONENT, phi, cam)[0])
        _, coef = _onset_sse(ts, xs, ws, tc, ONSET_EXPONENT, phi, cam)
        new = _lag_one_correlation((xs - _onset_design(ts, tc, ONSET_EXPONENT, cam) @ coef) * ws)
        if abs(new - phi) < ONSET_CORRELATION_TOL:
            break
    return tc, phi, coef


def _onset_window(t, x, sigma, window_after_s, shake):
    """The frames the onset is fitted on: (the first guess s, their times s, x m, weights
    1/m, and the camera's shake taken out of x there, m, or None where it stays below x's
    sigma in the window: :data:`SHAKE_IN_ONSET_SIGMAS`)."""
    ok = np.isfinite(x)
    guess = deceleration_start(t, x)
    tt, xx = t[ok], x[ok]
    ss = np.maximum(np.where(np.isfinite(sigma[ok]), sigma[ok], np.nanmedian(sigma)), 1e-7)
    sel = (tt >= guess - 0.06) & (tt <= guess + window_after_s)
    if sel.sum() < 8:
        raise VideoError("too few frames around the contact to locate it")
    ws = 1.0 / ss[sel]
    cam = None
    if shake is not None:
        cam = np.nan_to_num(np.asarray(shake, float)[ok][sel])
        if not np.max(np.abs(cam) * ws, initial=0.0) > SHAKE_IN_ONSET_SIGMAS:
            cam = None  # no shake in the window (or one below x's noise): nothing to take out
    return guess, tt[sel], xx[sel], ws, cam


def shake_left_in_x(t: np.ndarray, x: np.ndarray, sigma: np.ndarray, tc: float, shake: np.ndarray,
                    window_after_s: float = 0.012) -> tuple[float, float] | None:
    """The share of the camera's shake correction ``shake`` (m per frame) left in ``x`` (m),
    fitted with the onset model at the contact ``tc`` (s) on :func:`contact_time`'s frames:
    (share, its one-sigma; the residuals' lag-one correlation taken out and the sigma scaled
    by their reduced chi-square when above 1), or None when the shake stays below x's sigma
    there. A share beyond :data:`MAX_SHAKE_SHARE` is returned as found: not the turn's, the
    caller leaves x as it is. The window is where the car's motion has a model (the
    approach, the onset of the force); the share found there stands for the whole film's (a
    camera turn's growth off the axis, ``fit_camera_turn``, is the same in every frame)."""
    _, ts, xs, ws, cam = _onset_window(t, x, sigma, window_after_s, shake)
    if cam is None:
        return None
    _, coef = _onset_sse(ts, xs, ws, tc, ONSET_EXPONENT, 0.0, cam)
    phi = _lag_one_correlation((xs - _onset_design(ts, tc, ONSET_EXPONENT, cam) @ coef) * ws)
    A, y = _onset_rows(ts, xs, ws, tc, ONSET_EXPONENT, phi, cam)
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = A @ coef - y
    reduced = float(r @ r) / max(len(y) - A.shape[1], 1)
    cov = np.linalg.pinv(A.T @ A) * max(reduced, 1.0)
    return float(coef[3]), float(np.sqrt(cov[3, 3]))


# ------------------------------------------------------------------- wheel events


def kink_time(t: np.ndarray, y: np.ndarray, sigma: np.ndarray, model, grid: np.ndarray
              ) -> tuple[float, float]:
    """Best break time of a model with linear parameters.

    Parameters
    ----------
    t, y, sigma : (m,) float
        Samples (NaN-free) and their one-sigma.
    model : callable
        ``model(t, tb) -> (m, P)`` design matrix for break time ``tb``.
    grid : (G,) float
        Candidate break times, s.

    Returns
    -------
    tb : float
        Break time with the least weighted squared residual, s.
    sse : float
        That residual sum (chi-square).
    """
    w = 1.0 / np.maximum(sigma, 1e-12)
    grid = np.asarray(grid, dtype=float)

    def sse_at(tb):
        A = model(t, tb) * w[:, None]
        coef, *_ = np.linalg.lstsq(A, y * w, rcond=None)
        r = A @ coef - y * w
        return float(r @ r)

    return _coarse_to_fine(grid, sse_at)


def _coarse_to_fine(grid: np.ndarray, f, stride: int = 10) -> tuple[float, float]:
    """Minimum of ``f`` over ``grid``: every ``stride``-th point first, then every point
    within ``stride`` of the best (``f`` is smooth in the break time at this scale)."""
    if len(grid) == 0:
        return float("nan"), float("inf")
    coarse = np.arange(0, len(grid), stride)
    vals = np.array([f(grid[i]) for i in coarse])
    k = int(coarse[int(np.argmin(vals))])
    lo, hi = max(0, k - stride), min(len(grid), k + stride + 1)
    fine = np.array([f(grid[i]) for i in range(lo, hi)])
    j = int(np.argmin(fine))
    return float(grid[lo + j]), float(fine[j])


def _linear_fit(A: np.ndarray, y: np.ndarray, sigma: np.ndarray) -> tuple[np.ndarray, float]:
    """Weighted least squares ``y ~ A coef``: (coef, chi-square)."""
    w = 1.0 / np.maximum(sigma, 1e-12)
    coef, *_ = np.linalg.lstsq(A * w[:, None], y * w, rcond=None)
    r = (A @ coef - y) * w
    return coef, float(r @ r)


#: Smallest drop of chi-square that a break (event) must bring over the model without it.
MIN_EVENT_CHI2 = 25.0


def _finite(*arrs):
    ok = np.ones(len(arrs[0]), bool)
    for a in arrs:
        ok &= np.isfinite(a)
    return ok


def block_time(t: np.ndarray, spin: np.ndarray, spin_sigma: np.ndarray, rolling: np.ndarray,
               t_from: float, fps: float) -> float | None:
    """When a wheel stops turning (after ``t_from``), s; None if it never does.

    Parameters
    ----------
    t : (n,) float
        s.
    spin : (n,) float
        Measured wheel spin angle, rad (forward positive).
    spin_sigma : (n,) float
        Its one-sigma, rad.
    rolling : (n,) float
        The angle a rolling wheel would have turned (hub travel / wheel radius), rad.
    t_from : float
        Look only after this time (contact), s.
    fps : float

    Notes
    -----
    Guesses: frames after ``t_from`` where the wheel turns less than a quarter of the
    rolling rate while rolling would have turned it by at least 8 of the angle's sigmas,
    over 3 frames, or over 5, 8 or 12 when the car is too slow for that in 3 (a car
    slowed by the crush, a noisy hub angle). Each guess, earliest first, is refined by
    fitting ``spin = a + k rolling(min(t, tb))`` for ``tb`` on a 0.02-frame grid and kept
    when that beats rolling throughout by ``MIN_EVENT_CHI2`` with ``k`` near 1 (so one
    guess that noise made does not hide a block seen later).
    """
    ok = _finite(spin, rolling, spin_sigma)
    i = np.flatnonzero(ok & (t >= t_from))
    if len(i) < 6:
        return None
    noise = 4 * np.median(spin_sigma[ok])
    guesses: dict = {}  # frame -> the shortest lag that made it a guess
    for lag in (3, 5, 8, 12):
        if len(i) <= lag:
            break
        ds = spin[i[lag:]] - spin[i[:-lag]]
        dr = rolling[i[lag:]] - rolling[i[:-lag]]
        thr = np.maximum(0.25 * np.abs(dr), noise)
        for j in i[np.flatnonzero((np.abs(ds) < thr) & (np.abs(dr) > 2 * thr))]:
            guesses.setdefault(int(j), lag)
    dt = 1.0 / fps
    tr, rr = t[ok], rolling[ok]

    def model(tq, tb):
        return np.stack([np.ones_like(tq), np.interp(np.minimum(tq, tb), tr, rr)], axis=1)

    tried = -np.inf
    for j in sorted(guesses):
        guess = t[j]
        if guess - tried < 5 * dt:  # a run of guesses is one candidate
            continue
        tried = guess
        lag = guesses[j]  # the stop lies within the lag's frames after the guess
        sel = ok & (t >= guess - 15 * dt) & (t <= guess + (12 + lag) * dt)
        ts, ys, ss = t[sel], spin[sel], spin_sigma[sel]
        grid = np.arange(guess - 6 * dt, guess + (1 + lag) * dt, 0.02 * dt)
        tb, chi = kink_time(ts, ys, ss, model, grid)
        coef, _ = _linear_fit(model(ts, tb), ys, ss)
        _, chi0 = _linear_fit(model(ts, ts[-1] + 1.0), ys, ss)  # rolling throughout
        if 0.5 < coef[1] < 1.5 and chi0 - chi >= MIN_EVENT_CHI2:
            return tb
    return None


def unblock_time(t: np.ndarray, spin: np.ndarray, spin_sigma: np.ndarray, rolling: np.ndarray,
                 t_block: float, fps: float) -> float | None:
    """When a blocked wheel turns again (after ``t_block``), s; None if it does not.

    First guess: the first frame after the block where the angle has left its blocked
    value by more than 5 sigma and 0.02 rad and keeps leaving it; refined by fitting
    ``spin = a + k (rolling(max(t, tu)) - rolling(tu))``.
    """
    ok = _finite(spin, rolling, spin_sigma)
    dt = 1.0 / fps
    after = ok & (t >= t_block + 3 * dt)
    i = np.flatnonzero(after)
    if len(i) < 6:
        return None
    held = np.median(spin[i[:3]])
    tol = np.maximum(5 * spin_sigma[i], 0.02)
    away = np.abs(spin[i] - held) > tol
    run = np.flatnonzero(away[:-2] & away[1:-1] & away[2:])
    if len(run) == 0:
        return None
    guess = t[i[run[0]]]
    sel = ok & (t >= max(t_block + dt, guess - 15 * dt)) & (t <= guess + 10 * dt)
    ts, ys, ss = t[sel], spin[sel], spin_sigma[sel]
    tr, rr = t[ok], rolling[ok]

    def model(tq, tu):
        base = np.interp(tu, tr, rr)
        return np.stack([np.ones_like(tq), np.interp(np.maximum(tq, tu), tr, rr) - base], axis=1)

    grid = np.arange(guess - 10 * dt, guess + 2 * dt, 0.02 * dt)
    tu, chi = kink_time(ts, ys, ss, model, grid)
    coef, _ = _linear_fit(model(ts, tu), ys, ss)
    _, chi0 = _linear_fit(np.ones((len(ts), 1)), ys, ss)  # blocked throughout
    if abs(coef[1]) < 0.2 or chi0 - chi < MIN_EVENT_CHI2:
        return None
    return tu


#: Vertical stiffness of a passenger car's radial tyre, N/m (low, high): a wheel of 35-50 kg
#: on 90-390 kN/m has the 8-14 Hz wheel-hop frequency of passenger cars. A wheel still on the
#: floor rises as its tyre unloads, by its static deflection, load / stiffness, and leaves
#: the floor when it has risen that far.
TYRE_STIFFNESS_N_PER_M = (150e3, 400e3)


def tyre_unloading_m(static_load_n: float) -> tuple[float, float]:
    """How far a wheel's centre rises before its tyre leaves the floor, m (least, most): the
    static deflection under ``static_load_n`` (N) of the stiffest and the softest tyre of
    :data:`TYRE_STIFFNESS_N_PER_M`."""
    lo_k, hi_k = TYRE_STIFFNESS_N_PER_M
    return float(static_load_n) / hi_k, float(static_load_n) / lo_k


@dataclass(frozen=True)
class FloorEvent:
    """A wheel seen leaving the floor or landing on it again (:func:`lift_time`,
    :func:`touchdown_time`), bracketed in time because its tyre's deflection is not known, s.

    earliest_s, latest_s : the bracket (see each function for what bounds it).
    time_s, sigma_s : the event as the bracket's middle, and its one-sigma (the bracket's
        width over sqrt(12): anywhere in it alike).
    """

    earliest_s: float
    latest_s: float

    @property
    def time_s(self) -> float:
        return 0.5 * (self.earliest_s + self.latest_s)

    @property
    def sigma_s(self) -> float:
        return (self.latest_s - self.earliest_s) / np.sqrt(12.0)


def lift_time(t: np.ndarray, height: np.ndarray, sigma: np.ndarray, t_from: float, fps: float,
              unloading_m: tuple[float, float] = (0.0, 0.0), min_lift_m: float = 0.002) -> FloorEvent | None:
    """When a wheel leaves the floor (after ``t_from``), s, bracketed; None if it is not seen to.

    A wheel's centre rises before the wheel leaves the floor: its tyre unloads as the car
    pitches, and lets go when the centre has risen by the tyre's static deflection, which
    the film does not show; ``unloading_m`` (least, most), m, bounds it
    (:func:`tyre_unloading_m`; on reference-world films the rear hub rose 12 mm over the
    40 ms before its tyre left the floor). The bracket (:class:`FloorEvent`): from the
    later of the rise's start and the centre's rising through the least deflection, to its
    rising through the most (staying above it by 2 sigma for 5 frames), each interpolated
    between two frames; a centre that never rises through the most is not seen to leave the
    floor (None). ``(0, 0)``: a rigid tyre, the lift at the rise's start.

    The rise's start: the first frame after ``t_from`` from which the wheel centre stays
    higher than ``max(min_lift_m, 5 sigma)`` above the floor for 5 frames, refined by
    fitting ``h = a + b tau``, ``a + c tau^2`` or ``a + b tau + c tau^2``, ``tau = max(0,
    t - tl)``, on a 0.02-frame grid, the one with the least BIC: the centre starts up with
    a jump of its upward speed, of its upward acceleration, or both.
    """
    ok = _finite(height, sigma)
    i = np.flatnonzero(ok & (t >= t_from))
    if len(i) < 8:
        return None
    k = _first_run(height[i] > np.maximum(min_lift_m, 5 * sigma[i]))
    if k is None:
        return None
    guess = t[i[k]]
    dt = 1.0 / fps
    sel = ok & (t >= max(t_from - 10 * dt, guess - 40 * dt)) & (t <= guess + 8 * dt)
    ts, ys, ss = t[sel], height[sel], sigma[sel]
    grid = np.arange(max(t_from - 2 * dt, guess - 35 * dt), guess + dt, 0.02 * dt)

    best = (np.inf, None, None)
    for powers in ((1,), (2,), (1, 2)):
        def model(tq, tb, powers=powers):
            tau = np.maximum(tq - tb, 0.0)
            return np.stack([np.ones_like(tq)] + [tau**p for p in powers], axis=1)

        tb, chi = kink_time(ts, ys, ss, model, grid)
        bic = chi + (len(powers) + 2) * np.log(len(ts))
        if bic < best[0]:
            best = (bic, tb, model)
    _, tb, model = best
    coef, chi = _linear_fit(model(ts, tb), ys, ss)
    _, chi0 = _linear_fit(np.ones((len(ts), 1)), ys, ss)  # on the floor throughout
    if model(ts[-1:], tb)[0, 1:] @ coef[1:] <= 0 or chi0 - chi < MIN_EVENT_CHI2:
        return None
    least, most = unloading_m
    j = np.flatnonzero(ok & (t >= tb))
    latest = _rises_through(t[j], height[j], most, height[j] - 2 * sigma[j]) if most > 0 else float(tb)
    if latest is None:
        return None
    earliest = _rises_through(t[j], height[j], least) if least > 0 else None
    earliest = float(tb) if earliest is None else max(float(tb), earliest)
    return FloorEvent(min(earliest, latest), latest)


def _rises_through(t: np.ndarray, height: np.ndarray, level: float, low: np.ndarray | None = None) -> float | None:
    """When ``height`` rises through ``level`` for good: the first of 5 frames in a row whose
    ``low`` (default: the height itself) stands above it, the crossing interpolated between
    the frame before and that one; None if it never does."""
    k = _first_run((height if low is None else low) > level)
    if k is None:
        return None
    if k > 0 and height[k - 1] < level < height[k]:
        return float(t[k - 1] + (level - height[k - 1]) / (height[k] - height[k - 1]) * (t[k] - t[k - 1]))
    return float(t[k])


def _first_run(flags: np.ndarray, run: int = 5) -> int | None:
    """Index of the first of ``run`` consecutive True values of ``flags``, or None."""
    k = np.flatnonzero(np.convolve(np.asarray(flags, int), np.ones(run, int), mode="valid") == run)
    return int(k[0]) if len(k) else None


def touchdown_time(t: np.ndarray, height: np.ndarray, sigma: np.ndarray, t_lift: float, fps: float,
                   unloading_m: tuple[float, float] = (0.0, 0.0), min_lift_m: float = 0.002) -> FloorEvent | None:
    """When a lifted wheel is back on the floor (after ``t_lift``, s), bracketed; None if it
    stays up. Its tyre touches the floor when its centre comes down to the tyre's static
    deflection above the floor path, between the ``unloading_m`` bounds (least, most, m:
    :func:`lift_time`): the earliest is the centre coming down through the most, the latest
    through the least; with no least (a rigid tyre), the first frame at or below ``max(
    min_lift_m, 5 sigma)`` after having been above it, the last descent extrapolated to the
    floor path. Each crossing interpolated between the frames around it."""
    ok = _finite(height, sigma)
    i = np.flatnonzero(ok & (t > t_lift))
    if len(i) < 3:
        return None
    ti, hi = t[i], height[i]
    least, most = unloading_m
    if least > 0:
        latest = _comes_down_through(ti, hi, least)
    else:
        b = _first_down(hi > np.maximum(min_lift_m, 5 * sigma[i]))
        if b is None:
            return None
        h0, h1 = hi[b - 1], hi[b]
        # the floor is where the height returns to zero: extrapolate the last descent
        latest = float(ti[b - 1] + np.clip(h0 / (h0 - h1), 0.0, 1.5) * (ti[b] - ti[b - 1])) if h0 > h1 else float(ti[b])
    if latest is None:
        return None
    earliest = _comes_down_through(ti, hi, most) if most > 0 else None
    return FloorEvent(latest if earliest is None else min(earliest, latest), latest)


def _comes_down_through(t: np.ndarray, height: np.ndarray, level: float) -> float | None:
    """When ``height`` first comes down through ``level`` after having been above it,
    interpolated; None if it never does."""
    b = _first_down(height > level)
    if b is None:
        return None
    h0, h1 = height[b - 1], height[b]
    return float(t[b - 1] + (h0 - level) / (h0 - h1) * (t[b] - t[b - 1]))


def _first_down(up: np.ndarray) -> int | None:
    """Index of the first False of ``up`` after its first True (a coming down), or None."""
    if not up.any():
        return None
    first_up = int(np.flatnonzero(up)[0])
    down = np.flatnonzero(~up[first_up:])
    return first_up + int(down[0]) if len(down) else None


# ------------------------------------------------------------------------- floor


def floor_heights(hubs_uv: list, before: int, m_per_px: float) -> tuple[list, np.ndarray]:
    """Heights of wheel centres above the path they roll along, m.

    Before contact the wheels roll on the floor: their centres trace one image curve,
    the "floor line" of the hub centres (straight for a level floor and an ideal lens;
    tilted by camera roll, bent by uncorrected lens distortion). A polynomial
    ``v = p(u)`` (degree 2 when the hubs cover more than 300 px of ``u``, else 1) is
    fitted to every hub centre of the frames before ``before``, each hub with its own
    offset; a hub's height is how far above that curve it is.

    Parameters
    ----------
    hubs_uv : list of (n, 2) float
        Centres of each hub target per frame, px (NaN where lost).
    before : int
        First frame not used for the fit (the contact frame).
    m_per_px : float
        Scale, m/px.

    Returns
    -------
    heights : list of (n,) float
        Per hub, m (0 on the floor, positive up).
    coef : (deg + 1,) float
        The floor line's polynomial (numpy.polyval order, shared part), px.
    """
    us, vs, which = [], [], []
    for j, uv in enumerate(hubs_uv):
        ok = np.isfinite(uv[:before, 0])
        us.append(uv[:before, 0][ok])
        vs.append(uv[:before, 1][ok])
        which.append(np.full(int(ok.sum()), j))
    u = np.concatenate(us)
    v = np.concatenate(vs)
    w = np.concatenate(which)
    if len(u) < 3:
        return [np.full(len(h), np.nan) for h in hubs_uv], np.zeros(2)
    deg = 2 if np.ptp(u) > 300 else 1
    uc = np.mean(u)
    cols = [(u - uc) ** p for p in range(deg, 0, -1)]
    cols += [(w == j).astype(float) for j in range(len(hubs_uv))]
    A = np.stack(cols, axis=1)
    coef, *_ = np.linalg.lstsq(A, v, rcond=None)
    out = []
    for j, uv in enumerate(hubs_uv):
        curve = sum(coef[i] * (uv[:, 0] - uc) ** (deg - i) for i in range(deg)) + coef[deg + j]
        out.append((curve - uv[:, 1]) * m_per_px)
    return out, coef[:deg]


# ------------------------------------------------------------------------- crush


def crush_from_pose(x: np.ndarray, pitch: np.ndarray, silhouette: np.ndarray, x_cg: float,
                    cg_height: float, x_front_at_contact: float) -> np.ndarray:
    """Crush from the rigid passenger cell's pose, m.

    The undeformed silhouette is carried with the body; crush is how far its front-most
    point has passed the position the front end had at first contact (the barrier
    face): ``max(0, x + max_i[(px_i - x_cg) cos th + (pz_i - h) sin th] - x_front0)``,
    with ``x_front0`` the front end's distance ahead of the CG at contact.

    Parameters
    ----------
    x, pitch : (n,) float
        CG displacement from contact (m) and pitch (rad, nose-down positive).
    silhouette : (N, 2) float
        Vehicle-frame side outline, m.
    x_cg, cg_height : float
        CG in the vehicle frame, m.
    x_front_at_contact : float
        Front end ahead of the CG at contact, car-plane X, m (displacement reference).

    Returns
    -------
    (n,) float
        >= 0, NaN where ``x`` or ``pitch`` is NaN.
    """
    sil = np.asarray(silhouette, float)
    c, s = np.cos(pitch)[:, None], np.sin(pitch)[:, None]
    reach = ((sil[:, 0] - x_cg)[None, :] * c + (sil[:, 1] - cg_height)[None, :] * s).max(axis=1)
    out = np.maximum(x + reach - x_front_at_contact, 0.0)
    out[~(np.isfinite(x) & np.isfinite(pitch))] = np.nan
    return out
