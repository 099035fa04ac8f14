"""The camera's own motion measured on the static background (wall, floor, barrier): the
shake an impact gives the camera, where the film has no fixed target to measure it on.

    bg = BackgroundMotion.start(frame0, car_rows=(v_top, v_bottom))   # None: no background to use
    for frame in frames: bg.keep(frame)                                 # in the tracker's pass
    stab = bg.stabilise(uv, sigma_px)                                   # video.motion.Stabilised or None

The frames are kept reduced (:data:`REDUCE`: a sixteenth of their pixels, 8-bit grey) and
the corners followed through them only when ``stabilise`` is asked for: the tracker asks
only where no fixed target is in view, and on the other films following them would cost
more than the rest of the tracking pass. Past :data:`KEEP_BYTES` of them (a long film) the
frames kept are measured at once and every later one as it comes.

Corners of the background outside the car's rows (``cv2.goodFeaturesToTrack``) are followed
from the first frame into each frame (pyramidal Lucas-Kanade, ``cv2.calcOpticalFlowPyrLK``,
from the last frame's motion on), and the rigid motion (shift and roll,
``video.motion.rigid_fit``) taking them there is fitted to the points that agree with it
(RANSAC, ``cv2.estimateAffinePartial2D``): a camera turned by a shake moves every image
point by nearly the same shift and roll, whatever its depth. Debris, an occluder or a
person crossing the background are the points that disagree. The car's rows (with the room
its rear rises into) are left out whole: nothing that moves with the car is background.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from video.motion import SHAKE_MIN_PX, SIGNIFICANT, Stabilised, rigid_fit, take_out_camera_motion
from video.targets import to_gray

__all__ = ["BackgroundMotion"]

#: Fewest background corners the motion is measured from (fewer: not measured).
MIN_POINTS = 20
#: Corners looked for, and their least spacing, px.
MAX_POINTS, MIN_DISTANCE_PX = 300, 12
#: A corner agrees with the fitted motion within this distance, px (RANSAC).
INLIER_PX = 0.5
#: Image edge left out, px: a shaken camera's picture brings new content in there.
EDGE_PX = 16
#: The film's first frames, where the camera has not been shaken yet (crash films start 20 ms
#: or more before contact): the measured motion's wander there is its noise.
STILL_FRAMES = 15
#: Grey level (0-255) from which a pixel counts as saturated.
SATURATED = 250
#: The frames are measured reduced this many times (a quarter of the pixels to follow the
#: corners in: the shift of 300 corners is still known to a few hundredths of a pixel).
REDUCE = 4
#: Lucas-Kanade window and pyramid levels above the reduced image, px.
WINDOW, LEVELS = (11, 11), 1
#: Most bytes of reduced frames kept to be measured later (a 1280x1024 film's 3200 frames);
#: beyond it, each frame is measured as it comes.
KEEP_BYTES = 256 << 20


@dataclass
class BackgroundMotion:
    """The background corners of the first frame and, per frame measured, the camera's shift
    (px, at the corners' centroid), roll (rad) and their one-sigmas (NaN where not measured).

    Attributes
    ----------
    ref : (P, 2) float32, the corners in the first frame, px of the reduced image (:data:`REDUCE`).
    gray0 : the first frame, grey (uint8), reduced.
    shift, roll, shift_sigma, roll_sigma, centre : lists per frame measured.
    kept : the frames kept (:meth:`keep`) and not yet measured, grey (uint8), reduced.
    """

    ref: np.ndarray
    gray0: np.ndarray
    kept: list = field(default_factory=list)
    shift: list = field(default_factory=list)
    roll: list = field(default_factory=list)
    shift_sigma: list = field(default_factory=list)
    roll_sigma: list = field(default_factory=list)
    centre: list = field(default_factory=list)
    _last: np.ndarray | None = None
    _level0: tuple | None = None
    _rows: np.ndarray | None = None

    @classmethod
    def start(cls, frame0: np.ndarray, car_rows: tuple[float, float]) -> "BackgroundMotion | None":
        """Corners of ``frame0`` outside ``car_rows`` (v from, v to, px) and the image edge;
        None when fewer than :data:`MIN_POINTS` are found (no background to measure on)."""
        gray = _gray8(frame0)
        h, w = gray.shape
        mask = np.zeros_like(gray)
        e = EDGE_PX // REDUCE
        mask[e:h - e, e:w - e] = 255
        lo, hi = int(max(np.floor(car_rows[0] / REDUCE), 0)), int(min(np.ceil(car_rows[1] / REDUCE), h))
        mask[lo:hi] = 0
        # saturated parts (lamps, an overexposed wall): their edges move with the light's flicker
        mask[cv2.dilate((gray >= SATURATED).astype(np.uint8), np.ones((9, 9), np.uint8)) > 0] = 0
        pts = cv2.goodFeaturesToTrack(gray, MAX_POINTS, 0.01, MIN_DISTANCE_PX / REDUCE, mask=mask, blockSize=5)
        if pts is None or len(pts) < MIN_POINTS:
            return None
        pts = cv2.cornerSubPix(gray, pts.astype(np.float32), (5, 5), (-1, -1),
                               (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        return cls(ref=pts.reshape(-1, 2), gray0=gray)

    def keep(self, frame: np.ndarray) -> None:
        """Keep the next frame, reduced, to be measured if the shake is asked for (past
        :data:`KEEP_BYTES` of them, measured now)."""
        self.kept.append(_gray8(frame))
        # once past KEEP_BYTES (frames measured already), every frame is measured as it comes
        if self.shift or len(self.kept) * self.kept[0].nbytes > KEEP_BYTES:
            self._measure_kept()

    def _measure_kept(self) -> None:
        """Measure the frames kept, in order, and let them go."""
        for gray in self.kept:
            self._measure(gray)
        self.kept.clear()

    def _measure(self, gray: np.ndarray) -> None:
        """Append the camera motion of a frame kept (grey, reduced) against the first frame
        (NaN: not measured). The frame's brightness is first matched to the first frame's
        over the background (gain and offset: lights flicker, and Lucas-Kanade takes a
        change of brightness across a corner's slope for a shift)."""
        gray = self._matched(gray)
        guess = self.ref if self._last is None else self._last
        cur, ok, _ = cv2.calcOpticalFlowPyrLK(self.gray0, gray, self.ref.reshape(-1, 1, 2),
                                              guess.reshape(-1, 1, 2).copy(), winSize=WINDOW, maxLevel=LEVELS,
                                              flags=cv2.OPTFLOW_USE_INITIAL_FLOW,
                                              criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 30, 0.01))
        cur, ok = cur.reshape(-1, 2), ok.ravel().astype(bool)
        nan2 = np.full(2, np.nan)
        if ok.sum() < MIN_POINTS:
            self._append(nan2, np.nan, np.nan, np.nan, nan2)
            return
        _, inl = cv2.estimateAffinePartial2D(self.ref[ok], cur[ok], method=cv2.RANSAC,
                                             ransacReprojThreshold=INLIER_PX / REDUCE, maxIters=200, confidence=0.99)
        keep = np.flatnonzero(ok)[inl.ravel().astype(bool)] if inl is not None else np.array([], int)
        if len(keep) < MIN_POINTS:
            self._append(nan2, np.nan, np.nan, np.nan, nan2)
            return
        r, c = self.ref[keep].astype(float), cur[keep].astype(float)
        phi, rc, cc, resid = rigid_fit(r, c)
        s = float(np.sqrt(np.sum(resid**2) / max(2 * len(keep) - 3, 1)))  # per axis, px
        self._last = np.where(ok[:, None], cur, guess).astype(np.float32)
        self._append(REDUCE * (cc - rc), phi, REDUCE * s / np.sqrt(len(keep)), s / np.sqrt(np.sum((r - rc) ** 2)),
                     REDUCE * cc + (REDUCE - 1) / 2)

    def _matched(self, gray: np.ndarray) -> np.ndarray:
        """``gray`` with the mean and spread of its background rows matched to the first frame's."""
        if self._level0 is None:
            self._rows = np.unique(np.clip(np.round(self.ref[:, 1]).astype(int), 0, gray.shape[0] - 1))
            self._level0 = _level(self.gray0[self._rows])
        m, sd = _level(gray[self._rows])
        m0, sd0 = self._level0
        if not sd > 0:
            return gray
        return np.clip((gray.astype(np.float32) - m) * (sd0 / sd) + m0 + 0.5, 0, 255).astype(np.uint8)

    def _append(self, shift, roll, shift_sigma, roll_sigma, centre) -> None:
        self.shift.append(np.asarray(shift, float))
        self.roll.append(float(roll))
        self.shift_sigma.append(float(shift_sigma))
        self.roll_sigma.append(float(roll_sigma))
        self.centre.append(np.asarray(centre, float))

    def stabilise(self, uv: np.ndarray, sigma_px: np.ndarray) -> Stabilised | None:
        """Target centres ``uv`` (n, K, 2) px with the measured camera motion taken out, their
        sigmas ``sigma_px`` (n, K) with the correction's added in quadrature; None when the
        camera did not shake (no frame moved by more than ``SHAKE_MIN_PX`` and
        ``SIGNIFICANT`` of its sigmas: a still camera's correction would add only noise).
        Frames not measured are left as they are (shift NaN). The frames kept are
        measured first (and let go)."""
        self._measure_kept()
        n = uv.shape[0]
        shift, roll, s_sig, r_sig, centre = (_padded(np.array(v[:n], float), n) for v in
                                             (self.shift, self.roll, self.shift_sigma, self.roll_sigma, self.centre))
        # the corners' errors move together (a compressed frame's blocks, the light, the car's
        # shadow): each sigma at least the series' own frame-to-frame scatter
        # (:func:`series_noise`) and its wander over the first frames, before any impact
        still = slice(1, STILL_FRAMES + 1)
        s_sig = np.maximum(s_sig, max(series_noise(shift[:, 0]), series_noise(shift[:, 1]),
                                      float(np.sqrt(np.nanmean(shift[still] ** 2)))))
        r_sig = np.maximum(r_sig, max(series_noise(roll), float(np.sqrt(np.nanmean(roll[still] ** 2)))))
        size = np.hypot(*shift.T)
        with np.errstate(divide="ignore", invalid="ignore"):  # the first frame: no shift, no sigma
            beyond_noise = np.nan_to_num(size / s_sig) > SIGNIFICANT
        if not np.any((np.nan_to_num(size) > SHAKE_MIN_PX) & beyond_noise):
            return None
        return take_out_camera_motion(uv, sigma_px, shift, np.nan_to_num(roll), centre, s_sig, np.nan_to_num(r_sig))


def _padded(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` (m, ...) with NaN rows appended up to ``n`` (frames not measured)."""
    return np.concatenate([a, np.full((n - len(a),) + a.shape[1:], np.nan)]) if len(a) < n else a


def series_noise(x: np.ndarray) -> float:
    """One-sigma noise of a series sampled each frame, from its second differences (robust:
    their median absolute deviation; white noise gives them sqrt(6) times its sigma, while a
    shake, tens of frames to a period, hardly shows in them); 0 for fewer than 5 values."""
    x = np.asarray(x, float)
    d2 = np.diff(x[np.isfinite(x)], 2)
    if len(d2) < 3:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def _level(rows: np.ndarray) -> tuple[float, float]:
    """Mean and standard deviation of the unsaturated pixels of ``rows`` (grey levels)."""
    v = rows[rows < SATURATED].astype(np.float32)
    return (float(v.mean()), float(v.std())) if v.size else (0.0, 0.0)


def _gray8(frame: np.ndarray) -> np.ndarray:
    """The frame as 8-bit grey (``video.targets.to_gray``'s [0, 1] scaled to 0-255; an 8-bit
    grey frame as it is), reduced :data:`REDUCE` times (pixel areas averaged)."""
    small = cv2.resize(np.asarray(frame), None, fx=1 / REDUCE, fy=1 / REDUCE, interpolation=cv2.INTER_AREA)
    if small.dtype == np.uint8 and small.ndim == 2:
        return small
    return np.clip(to_gray(small) * 255.0 + 0.5, 0, 255).astype(np.uint8)
