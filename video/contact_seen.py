"""First contact seen in the picture: the car's front end stopping at the barrier.

Before contact the front end (the bumper's leading edge in the outline) moves with the
passenger cell. From first contact on, the bumper stands against the barrier face while the
cell goes on: the visible front end stops in the image, sharply (at 15 m/s it moves 2-3 px a
frame at 1000 fps, then not at all), long before the cell's deceleration rises out of the
noise (a force growing with the crush moves the cell by less than 1 mm in the first 5-8 ms).
The contact is the instant at which the front end carried rigidly with the cell reaches the
column where the visible front end stands after the stop (:func:`stop_time`), taken back to
the nose's tip where the rows that show the front stand behind it (a rounded nose, a lower
bumper as grey as the floor: :func:`back_to_the_tip`). Debris flung from the contact
towards the camera shows beyond the face and joins the front in a few rows: where the rows'
most forward share stands ahead of where the car can be, their median is followed. Where the
front followed stood ahead of where the car can be before the stop it shows (or before it
fell behind the rigid path, with no clean stop), what stopped is not the car's front alone:
the contact is bracketed by the frames before (:func:`joined_bracket`), its sigma the
bracket's.

Both are measured in the car's own plane, whatever the barrier's depth. The barrier's edge
in the picture is not the face: with the camera short of the face, as usual, a barrier side
face 0.6 m nearer the camera than the car's side shows its edge about 0.14 m beyond the
face (the nose touches the face short of the edge and stops there, in view); a barrier
farther away shows it short of the face (the nose passes in front of it and stops beyond).
Only where the face stands short of the column the depth direction vanishes to (a camera
looking back at the face) does a nearer edge show short of the face, and hide the nose
before it touches: a stop at an edge of frame 0 is not taken there. The front end is found
against the background as the film's first frames show it (each pixel's median over
:data:`BACKGROUND_FRAMES`), ahead of where the car stood in them (:func:`front_column`), so
wall texture and the barrier's own edges do not count, nor the blocks of a first frame
coded before the video's rate control settled; and in the nose's rows where the car stands
out of that background (a floor or a wall as grey as the body hides it in the others).

Positions are image px (undistorted, with the camera shake taken out, as the body pose);
times s on the film's clock (0 at frame 0).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .detector import Candidates, Detector
from .motion import BodyPose

#: The nose's rows: the vehicle outline within this distance of its front-most point, m.
NOSE_BAND_M = 0.03
#: Samples (0.5 px; 6 px) of background that end the car's run of columns in a row.
GAP_SAMPLES = 12
#: Samples behind the car's last sample above the threshold whose median is the car's grey
#: at the front (0.5 px each, from the first up to the last: 1 to 4.5 px behind it)
COVER_BEHIND = (2, 10)
#: Told apart by the grey (``min_contrast``), the car's run ends at this many samples (0.5 px)
#: without the car, of which END_TOLD are told background: debris a few px ahead of the
#: front is not joined to it, and background as grey as the car does not end it
END_SAMPLES = 6
END_TOLD = 4
#: Floor of a front column's one-sigma, px (compression blocks, the rows' quantile).
FRONT_FLOOR_PX = 0.3
#: Which of the rows' front columns stands for the front end (quantile in the travel direction).
FORWARD_QUANTILE = 0.8
#: The front end is followed from this long before the deceleration onset's first guess, s.
WINDOW_BEFORE_S = 0.030
#: The picture's front is placed against the outline's nose, and the car's contrast against
#: the background measured, in the first frame from this long before the onset's guess on
#: where the car has moved clear of its place in frame 0, s (the frames before it are
#: followed too).
LEVEL_BEFORE_S = 0.020
#: ... to this long after it, s.
WINDOW_AFTER_S = 0.015
#: Frames the visible front end must be followed on each side of the stop.
MIN_FRAMES_EACH_SIDE = 4
#: The background the front end is told from: each pixel's median over this many of the
#: film's first frames (odd; the car's nose in the middle one is where it stood in them).
BACKGROUND_FRAMES = 3
#: Frames before and after a candidate stop that judge it.
FRAMES_BEFORE = 10
FRAMES_AFTER = 6
#: Debris comes with the contact: a front that stood ahead of where the car can be counts
#: as something joined to it from this many frames before the stop its most forward rows
#: show on (which such a fragment, a few px ahead, makes that many frames late)
JOINED_FRAMES = 3
#: Seen frames in a row in which the front must stand ahead of where the car can be to
#: count as something joined to it before its stop (:func:`_first_ahead`)
AHEAD_FRAMES = 2
#: A frame further than this many sigmas from the stop model is an outlier ...
OUTLIER = 3.0
#: ... and a window with more than this share of outliers is no stop.
MAX_OUTLIER_SHARE = 0.25
#: How much better (chi-square) a stop must explain the front end than no stop at all.
MIN_CHI2_GAIN = 25.0
#: The car's front must differ from the background by this many times the noise, and
#: by at least CONTRAST_MIN grey levels, to be seen stopping ...
CONTRAST_NOISES = 3.0
CONTRAST_MIN = 6.0
#: ... in at least this many of the nose's rows: the rows where it does not (the car as
#: grey as the floor or the wall behind it there) are left out of the front end.
MIN_CONTRAST_ROWS = 3
#: Floor of a seen contact's one-sigma, in frame intervals. On the reference world's films
#: (development seeds 960000-960039, which no test and no benchmark scores) the contact was
#: seen on 24 at 1000 fps: within 0.3 ms of the truth on 20, and -0.82, +0.50, +1.04 and
#: +1.67 ms (RMS 0.46 ms; the largest at an edge of frame 0); on 5 at 500 fps: within 0.2 ms
#: on 4, and +1.79 ms. Half a frame covers 21 of the 24 at one sigma and 22 at two; a whole
#: frame (as before) let the fit move the contact by 2-3 ms (k_compression by 10-15 %)
#: towards what the model prefers, whose car has no engine moving on its mounts.
SEEN_FLOOR_FRAMES = 0.5
#: One-sigma of the time from the nose's tip reaching the face to the seen rows reaching
#: it, as a share of that time (the vehicle file's outline near the nose is known to a few
#: mm, and the car's speed over that time to a few per cent)
TIP_LAG_REL_SIGMA = 0.25
#: Fixed-point steps inverting the lens's and shake's correction (each shrinks the error
#: by the correction's relative change across it, 0.1 or less)
TO_RAW_STEPS = 4
#: A stop where frame 0 steps by more than the threshold, one way, in this share of the rows
#: from two nose heights above to two below, is at the edge of something nearer the camera.
EDGE_ROWS_SHARE = 0.6
#: How far beyond the column the depth direction vanishes to a stop at such an edge must
#: lie to be the contact, as a share of the picture's width: the principal point a few per
#: cent off the picture's centre, and a camera yawed by up to 5 degrees against the car's
#: plane (f tan 5 deg, f up to 1.2 widths), move that column by up to this much
VANISH_MARGIN = 0.15
#: A stop is seen only within this many frame intervals of a frame that showed the front
#: end moving with the cell: across a longer run of frames without it (the front as grey
#: as what is behind it, debris at the face) the stop's time is the rigid path extrapolated
#: to a column where something else may stand (on development film 960005 debris flung
#: from the face, 3.8 frames after the front was last seen: a stop 7.6 ms late; on 960016
#: the barrier's edge, 17 frames after: 8 ms late)
MAX_UNSEEN_FRAMES = 3.0
#: The front end is followed in frames where the rigid nose stands at least twice this far
#: beyond its place in frame 0 (the outline's nose, set right by the picture's front to
#: within NOSE_OFF_PX), looked for from half-way there, or from ``search_px + 2`` px beyond
#: it once the car is that far on, px (the car's grey is measured 1 to 4.5 px behind its
#: front: COVER_BEHIND)
FRAME0_CLEAR_PX = 5.0
#: How far ahead of the vehicle outline's nose the picture's front end is looked for, px.
LOCATE_PX = 40.0
#: A picture's front further than this from the outline's nose moves the nose the front
#: end is searched around, and is said in the note, px.
NOSE_OFF_PX = 2.0


#: Frames of the approach whose measured pose carries the car's pose to a frame where it is
#: not measured (the background's middle frame): the nearest this many, all before the
#: onset's guess less LEVEL_BEFORE_S (at least 2 of them).
APPROACH_POSE_FRAMES = 8


@dataclass(frozen=True)
class SeenContact:
    """What the picture says of the instant of first contact.

    Attributes
    ----------
    kind : str
        ``"seen"`` (the front end stopped in view: ``time_s`` is the contact) or
        ``"not_seen"``.
    time_s, sigma_s : float
        Film-clock time of the stop and its one-sigma, s (NaN when not seen).
    stop_u_px, stop_sigma_px : float
        Column where the visible front end stood after the stop and its one-sigma, px.
    note : str
        One sentence for the notes.
    """

    kind: str
    time_s: float
    sigma_s: float
    stop_u_px: float
    stop_sigma_px: float
    note: str


def not_seen(why: str) -> SeenContact:
    """A :class:`SeenContact` of kind ``not_seen``, saying why."""
    nan = float("nan")
    return SeenContact("not_seen", nan, nan, nan, nan, f"first contact not seen in the picture: {why}")


def stop_time(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
              step_s: float) -> tuple[float, float, float, float] | None:
    """When a front end carried rigidly stops being the visible one.

    Model: the visible front end ``u_seen`` is the rigid one ``u_rigid`` (linearly
    interpolated between frames) plus a constant ``c`` until ``ts``, and stands at
    ``u_rigid(ts) + c`` from then on (``c``: where the vehicle file's outline puts the
    front against where the picture shows it). Each ``ts`` on a grid of ``step_s`` is
    judged on the frames from :data:`FRAMES_BEFORE` frames before it to
    :data:`FRAMES_AFTER` after it (what happens in front of the car later, debris or a
    rebound, does not move the stop), by a robust reduced chi-square: ``c`` the window's
    median offset, each frame's term capped at :data:`OUTLIER` squared. A best window with
    more than :data:`MAX_OUTLIER_SHARE` of outliers is no stop; the others are left out
    of ``c``, the sigma and the gain.

    Parameters
    ----------
    t : (n,) s
        Frame times, increasing.
    u_rigid, u_seen, sigma : (n,) px
        The rigidly carried front end, the one seen, and the seen one's one-sigma.
    step_s : float
        Grid step, s.

    Returns
    -------
    (ts, ts_sigma, u_stop, chi2_gain, reduced_chi2) or None
        Stop time (s) and its one-sigma from the chi-square profile on the best window's
        frames (a sixth of the width where it rises by 9, scaled by the reduced
        chi-square when above 1), the stop column px, and how much the stop lowers the
        chi-square on those frames against a front end that never stops, and the reduced
        chi-square of the stop on them (outliers left out). None when no
        window has :data:`MIN_FRAMES_EACH_SIDE` seen frames on either side of the stop that
        its model does not call outliers, the frames next to it among them, or the best has
        too many outliers.
    """
    ok = np.isfinite(u_rigid) & np.isfinite(u_seen) & np.isfinite(sigma) & (sigma > 0)
    if ok.sum() < 2 * MIN_FRAMES_EACH_SIDE:
        return None
    tt, ur, us, w = t[ok], u_rigid[ok], u_seen[ok], 1.0 / sigma[ok] ** 2
    dt = float(np.median(np.diff(t)))
    grid = np.arange(tt[0], tt[-1], step_s)
    stop_u = np.interp(grid, tt, ur)
    early = tt[None, :] < grid[:, None]
    res = us[None, :] - np.where(early, ur[None, :], stop_u[:, None])
    inside = (tt[None, :] >= grid[:, None] - FRAMES_BEFORE * dt) & (tt[None, :] < grid[:, None] + FRAMES_AFTER * dt)
    n_in = np.sum(inside, axis=1)
    # robustly: c the window's median offset, every frame's chi-square capped at OUTLIER^2
    # (debris in front of the car, a row of background that changed)
    c = np.nanmedian(np.where(inside, res, np.nan), axis=1)
    z2 = w[None, :] * (res - c[:, None]) ** 2
    # a stop is shown by frames on its model on each side of it, outliers not counted (two
    # frames after it that fall behind the rigid path, a codec's smeared edge, the front lost
    # after them, are no front standing still), the two next to it among them: they place it
    kept = inside & (z2 <= OUTLIER**2)
    n_before = np.sum(early, axis=1)
    rows = np.arange(len(grid))
    valid = ((np.sum(kept & early, axis=1) >= MIN_FRAMES_EACH_SIDE) & (np.sum(kept & ~early, axis=1) >= MIN_FRAMES_EACH_SIDE)
             & kept[rows, np.maximum(n_before - 1, 0)] & kept[rows, np.minimum(n_before, len(tt) - 1)])
    if not valid.any():
        return None
    score = np.where(valid, np.sum(np.minimum(z2, OUTLIER**2) * inside, axis=1) / np.maximum(n_in - 2, 1), np.inf)
    j = int(np.argmin(score))
    mask = kept[j]
    if np.sum(inside[j] & ~mask) > MAX_OUTLIER_SHARE * n_in[j]:
        return None  # the frames do not look like a front end that stops
    # the profile on the best window's frames, outliers left out
    wm = w * mask
    cm = np.sum(wm[None, :] * res, axis=1) / np.sum(wm)
    prof = np.sum(wm[None, :] * (res - cm[:, None]) ** 2, axis=1)
    r0 = us - ur
    chi2_none = float(np.sum(wm * (r0 - np.sum(wm * r0) / np.sum(wm)) ** 2))
    reduced = float(prof[j]) / max(int(mask.sum()) - 2, 1)
    scale = max(1.0, reduced)
    # a sixth of the width of the three-sigma interval (the profile is not a parabola: the
    # stop moves in steps between frames, and the one-sigma width alone came out too narrow)
    near = np.abs(grid - grid[j]) <= FRAMES_AFTER * dt
    within = grid[near & (prof <= prof[j] + 9.0 * scale)]
    sigma_ts = float(within.max() - within.min()) / 6.0 if len(within) > 1 else step_s
    return float(grid[j]), max(sigma_ts, step_s), float(stop_u[j] + cm[j]), chi2_none - float(prof[j]), reduced


def front_column(gray: np.ndarray, background: np.ndarray, rows: np.ndarray, u_from: float,
                 u_to: float, threshold: float, bg_shift: np.ndarray | None = None,
                 min_contrast: float | None = None) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The car's front column in a band of rows: where it stops differing from the background.

    In each row that starts on the car at ``u_from`` (behind the front), the end of the
    run of columns towards ``u_to`` (ahead) whose difference from the background exceeds
    ``threshold`` (it ends where :data:`GAP_SAMPLES` samples in a row do not; with
    ``min_contrast``, where :data:`END_SAMPLES` do, and it goes on over background of
    another grey, :func:`_run_on`), refined to where the car covers half a pixel
    (:func:`_half_covered`); then the rows' :data:`FORWARD_QUANTILE` in the direction of
    travel (the nose's most forward rows: :func:`front_of_rows`).

    Parameters
    ----------
    gray, background : (H, W) float
        The frame and the same view without the car there (an earlier frame).
    rows : (R,) float
        Rows to look at, px.
    u_from, u_to : float
        Search from behind the front to ahead of it, px (either order of columns).
    threshold : float
        Grey levels: half the car's own difference from the background.
    bg_shift : (2,) px, optional
        The camera's image shift of ``gray`` relative to ``background``.
    min_contrast : float, optional
        Grey levels: the least difference between the car and the background at which
        a sample is told one or the other; with it the run goes on past the threshold's
        end over background of another grey (:func:`_run_on`).

    Returns
    -------
    (u, sigma, front_rows, row_u)
        The column px (NaN when fewer than three rows show the front), its one-sigma from
        the rows' scatter (at least :data:`FRONT_FLOOR_PX`), the rows that showed it (px)
        and each one's front column (px). With ``min_contrast`` a row whose front the cover cannot place (the car and
        the background too alike there, or the run ending within the first 5 px) is left
        out; without it the fixed threshold places it.
    """
    from .calibrate_profile import sample

    step = 0.5 if u_to > u_from else -0.5
    us = np.arange(u_from, u_to + step / 2, step)
    grid = _band(us, rows)
    shift = np.zeros(2) if bg_shift is None else np.asarray(bg_shift, float)
    seen, behind = sample(gray, grid), sample(background, grid - shift)
    diff = np.abs(seen - behind)
    above = np.nan_to_num(diff, nan=0.0) > threshold
    # the car's region runs on from ``u_from`` until the background shows for GAP samples
    # (debris or a changed patch of background further ahead are not the car); a sample
    # of background as grey as the car there is neither, and does not end it
    gap, end = np.ones(GAP_SAMPLES, int), np.ones(END_SAMPLES, int)
    found, front_rows = [], []
    for r in range(len(rows)):
        if not above[r, 0]:
            continue
        window = gap if min_contrast is None else end
        starts = np.flatnonzero(np.convolve((~above[r]).astype(int), window, mode="valid") == len(window))
        if len(starts) == 0:
            continue
        j = starts[0] - 1  # the car's last sample above the threshold
        if min_contrast is not None:
            j = _run_on(seen[r], behind[r], j, min_contrast)
            if j is None:
                continue  # the row goes on over background as grey as the car: its front unseen
        if not np.all(np.isfinite(diff[r, max(j, 0):j + GAP_SAMPLES + 1])):
            continue  # the run ends at the picture's border, not at the car's front
        edge = _half_covered(seen[r], behind[r], j, threshold if min_contrast is None else min_contrast)
        if edge is None and min_contrast is not None:
            continue  # the front stands on background as grey as the car: not seen in this row
        if edge is None:  # no car grey to measure the cover with: the fixed threshold
            a, b = diff[r, j], diff[r, j + 1]
            edge = j + ((a - threshold) / (a - b) if a > b else 0.5)
        found.append(us[0] + step * edge)
        front_rows.append(rows[r])
    found = np.asarray(found, float)
    return front_of_rows(found, int(np.sign(step))) + (np.asarray(front_rows, float), found)


def front_of_rows(row_u: np.ndarray, direction: int, quantile: float = FORWARD_QUANTILE) -> tuple[float, float]:
    """The front end from the rows' front columns ``row_u`` (px): their ``quantile`` in the
    direction of travel, and its one-sigma from their scatter (at least
    :data:`FRONT_FLOOR_PX`), px; NaN when fewer than three rows show it.

    The nose's most forward rows touch first; the rows behind them go on until they reach
    the face too, so the rows' median stops late (:func:`back_to_the_tip` takes it back)
    but moves less with debris joined to a few rows.
    """
    row_u = np.asarray(row_u, float)
    if len(row_u) < 3:
        return float("nan"), float("nan")
    u = float(np.quantile(row_u * direction, quantile) * direction)
    spread = 1.4826 * float(np.median(np.abs(row_u - np.median(row_u))))
    return u, float(max(spread / np.sqrt(len(row_u)), FRONT_FLOOR_PX))


def _run_on(seen: np.ndarray, behind: np.ndarray, j: int, min_contrast: float) -> int | None:
    """The car's last sample along one row, from ``j`` (the end of its run above a fixed
    threshold) on, told from the background sample by sample by its grey.

    The fixed threshold is half the car's difference from the background just behind its
    front. Ahead of it the background may change (a wall, then the barrier it passes in
    front of), and where the car differs from it by less than the threshold the car's
    run seems to end though the car goes on. Here a sample is the car's where it is
    nearer the car's grey (measured just behind ``j``) than the background's, told only
    where the two differ by ``min_contrast``; samples where they do not are neither and
    do not end the run, which ends at :data:`END_SAMPLES` samples without the car of
    which :data:`END_TOLD` are told background. None when it never ends.
    """
    car = _car_grey(seen, j)
    if car is None:
        return j
    contrast = car - behind[j:]
    told = np.nan_to_num(np.abs(contrast), nan=0.0) > min_contrast
    with np.errstate(divide="ignore", invalid="ignore"):
        cover = np.where(told, (seen[j:] - behind[j:]) / contrast, np.nan)
    is_car = told & (cover >= 0.5)
    is_bg = told & (cover < 0.5)
    end = np.ones(END_SAMPLES, int)
    ends = np.flatnonzero((np.convolve(is_car.astype(int), end, mode="valid") == 0)
                          & (np.convolve(is_bg.astype(int), end, mode="valid") >= END_TOLD))
    if len(ends) == 0:
        return None
    last = np.flatnonzero(is_car[:ends[0]])
    return j + (int(last[-1]) if len(last) else 0)


def _car_grey(seen: np.ndarray, j: int) -> float | None:
    """The car's grey along a row just behind its sample ``j``: the median of the samples
    :data:`COVER_BEHIND` behind it (None where the row starts closer)."""
    lo, hi = j - COVER_BEHIND[1], j - COVER_BEHIND[0]
    return None if lo < 0 else float(np.median(seen[lo:hi]))


def _half_covered(seen: np.ndarray, behind: np.ndarray, j: int, threshold: float) -> float | None:
    """Where the car covers half a pixel along one row, in samples (fractional index).

    A pixel the front end covers by a share ``f`` reads ``f car + (1 - f) background``,
    so ``f = (seen - background) / (car - background)`` with the car's grey measured just
    behind the front (samples :data:`COVER_BEHIND` behind ``j``, the car's last sample
    above the threshold) and the background's at the pixel itself (frame 0). Its 0.5
    crossing is the edge whatever the background's texture and grey, where a fixed
    threshold moves the edge by up to half a pixel with the contrast ahead (a wall
    before contact, the barrier after it). None where the car and the background differ
    by less than ``threshold`` at the samples around the crossing.
    """
    car = _car_grey(seen, j)
    if car is None:
        return None
    k = np.arange(max(j - 3, 0), min(j + 4, len(seen)))
    contrast = car - behind[k]
    if not np.all(np.abs(contrast) > threshold):
        return None
    cover = (seen[k] - behind[k]) / contrast
    cross = np.flatnonzero((cover[:-1] >= 0.5) & (cover[1:] < 0.5))
    if len(cross) == 0:
        return None
    m = cross[-1]
    a, b = cover[m], cover[m + 1]
    return float(k[m] + (a - 0.5) / (a - b))


class FrontEndDetector(Detector):
    """The car's front end in one frame (:func:`front_column`), as a :class:`video.detector.Detector`.

    Set up for one frame's search: the background (the view before the car got there),
    the nose's rows, the columns from behind the front to ahead of it, the threshold and
    the camera's shift against the background. One candidate (or none): the front's
    column at the rows' middle; ``quality`` the share of the rows that showed it;
    ``found`` is ``(u, sigma, front_rows, row_u)`` as :func:`front_column` returns it.
    """

    kind = "front end"

    def __init__(self, background: np.ndarray, rows: np.ndarray, u_from: float, u_to: float,
                 threshold: float, bg_shift: np.ndarray | None = None, min_contrast: float | None = None):
        self.background, self.rows = background, np.asarray(rows, float)
        self.u_from, self.u_to, self.threshold, self.bg_shift = u_from, u_to, threshold, bg_shift
        self.min_contrast = min_contrast

    def detect(self, frame: np.ndarray) -> Candidates:
        found = front_column(frame, self.background, self.rows, self.u_from, self.u_to,
                             self.threshold, self.bg_shift, self.min_contrast)
        u, _, front_rows, _ = found
        if not np.isfinite(u):
            return self._candidates(np.zeros((0, 2)), np.zeros(0), found)
        return self._candidates([u, float(np.mean(self.rows))], [len(front_rows) / len(self.rows)], found)


def see_contact(frame_at: Callable[[int], np.ndarray], t: np.ndarray, pose: BodyPose,
                nose_ref: np.ndarray, rows_ref: tuple[float, float], direction: int,
                guess_s: float, *, to_pose: Callable[[int, np.ndarray], np.ndarray] | None = None,
                search_px: float = 10.0,
                row_lag_px: Callable[[np.ndarray], np.ndarray] | None = None,
                vanish_u: float | None = None) -> SeenContact:
    """Look for the first contact in the picture (see the module's docstring).

    The rows that show the front end are not always the nose's first point: a bumper's
    lower edge as grey as the floor behind it, or a rounded nose whose rows stand a few mm
    behind its tip. Such a row stops when the crush reaches its own distance behind the
    tip, after the contact. With ``row_lag_px`` the stop is taken back by that distance
    along the rigid front end's path (:func:`back_to_the_tip`).

    The background is each pixel's median over the film's first :data:`BACKGROUND_FRAMES`
    frames, where the car has not yet reached the columns searched in more than half of
    them (frames whose search would reach back to the nose's place in the middle one are
    skipped); the front end is followed in the nose's rows where the car differs from it by
    :data:`CONTRAST_NOISES` times the noise and :data:`CONTRAST_MIN` grey levels, at least
    :data:`MIN_CONTRAST_ROWS` of them.

    Parameters
    ----------
    frame_at : callable
        ``frame_at(i)`` -> frame ``i`` of the film (read once each, in increasing order).
    t : (n,) s
        Film clock of every frame.
    pose : BodyPose
        The passenger cell's pose per frame, px.
    nose_ref : (2,) px
        The undeformed front end (bumper's leading edge) in the pose's reference frame,
        in the pose's coordinates.
    rows_ref : (v_top, v_bottom) px
        Band of rows of the front end in the reference frame; it is moved with the nose.
    direction : +1 or -1
        Direction of travel in the image.
    guess_s : float
        First guess of the contact (the deceleration onset), film clock s.
    to_pose : callable, optional
        ``to_pose(i, uv)`` -> raw image points (M, 2) of frame ``i`` in the pose's
        coordinates (lens and camera shake taken out); identity when None.
    search_px : float
        How far behind and ahead of the predicted front end to look, px.
    row_lag_px : callable, optional
        ``row_lag_px(v)`` -> how far the outline at rows ``v`` (the reference frame's, px)
        stands behind the nose's tip, px (NaN where the outline has no front); None: the
        rows' front is the tip.
    vanish_u : float, optional
        Column (pose coordinates, px) that the car plane's normal vanishes to: the
        principal point of a camera square to the car's plane. A stop at an edge of frame 0
        beyond it by :data:`VANISH_MARGIN` of the width (in the travel direction) is the
        contact; None: such a stop is not taken.

    Returns
    -------
    SeenContact
    """
    from .calibrate_profile import sample, to_gray

    n = len(t)
    fps = 1.0 / float(np.median(np.diff(t)))
    i0 = max(int(np.floor((guess_s - WINDOW_BEFORE_S) * fps)), 1)
    i1 = min(int(np.ceil((guess_s + WINDOW_AFTER_S) * fps)), n - 1)
    if i1 - i0 < 2 * MIN_FRAMES_EACH_SIDE + 1:
        return not_seen("too few frames around the deceleration onset")
    to_pose = to_pose or (lambda i, uv: np.asarray(uv, float))
    nose_ref = np.asarray(nose_ref, float)
    d = direction

    def to_raw(i, p):
        return raw_points(to_pose, i, p)

    # the background: each pixel's median over the film's first frames (a video's first
    # frame, coded before its rate control settles, can be blocky where the next ones are
    # not). Ahead of where the car's nose stood in the middle one, the car covers a pixel in
    # fewer than half of them: the median there is the background
    j_last = min(BACKGROUND_FRAMES, n) - 1
    j0 = j_last // 2
    if not np.isfinite(pose.point[j0, 0]):
        pose = pose_on_the_approach(pose, t, j0, guess_s - LEVEL_BEFORE_S)
        if pose is None:
            return not_seen(f"the car's pose is not measured in frame {j0}, whose picture is part of the "
                            f"background, nor in {APPROACH_POSE_FRAMES} frames before the onset's guess to "
                            "carry it there")
    idx = np.arange(i0, i1 + 1)
    # the frames read once, in order (a video is decoded from its start again whenever a
    # frame before the last one read is asked for)
    cache = {}
    for i in [*range(j_last + 1), *idx]:
        if i not in cache:
            cache[int(i)] = frame_at(int(i))
    frame_at = cache.__getitem__
    background = np.median([to_gray(frame_at(j)) for j in range(j_last + 1)], axis=0)
    v0, v1 = sorted(rows_ref)
    nose0 = to_raw(j0, pose.transform(j0, nose_ref[None]))[0]
    # the picture's front against the outline's nose (a vehicle file's outline or CG may
    # stand a few cm off the car's), once, in the first frame where the car has left its
    # place in the background's frames far enough; the nose is moved by it
    near = idx[idx >= int(np.floor((guess_s - LEVEL_BEFORE_S) * fps))]
    if not len(near):
        return not_seen("too few frames around the deceleration onset")
    located = _locate_front(frame_at, near, pose, nose_ref, nose0, (v0, v1), d, background, to_pose, search_px)
    if isinstance(located, str):
        return not_seen(located)
    if abs(located) > NOSE_OFF_PX:  # within it the search's margins hold the front
        nose_ref = nose_ref + np.array([located, 0.0])
        nose0 = to_raw(j0, pose.transform(j0, nose_ref[None]))[0]
    placed = [(k, int(i)) + _nose_in_frame(pose, i, nose_ref, (v0, v1), to_pose)
              for k, i in enumerate(idx) if np.isfinite(pose.point[i, 0])]
    # the car's own difference from the background just behind its front, and the
    # background's own noise ahead of it (:func:`noise_ahead`), in the first frame from
    # LEVEL_BEFORE_S before the onset's guess on where the car has left behind it a band
    # that frame 0 shows without the car
    first = next((p for p in placed if d * (p[3][0] - nose0[0]) >= 2.0 * search_px + 2.0
                  and p[1] >= near[0]), None)
    if first is None:
        return not_seen(f"the car does not move {2.0 * search_px + 2.0:g} px from where it stood in frame {j0} "
                        f"within frames {idx[0]}-{idx[-1]}: no background to see its front against")
    _, i, nose, raw, rows, shift = first
    gray = _frame_against(frame_at, i, background, rows, raw[0] + d * (search_px + 2.0), d, shift)
    behind = _band(raw[0] - d * np.arange(4.0, 16.0), rows)
    row_level = _row_median(np.abs(sample(gray, behind) - sample(background, behind - shift)))
    noise = noise_ahead(gray, background, raw[0], rows, d, search_px, shift)
    if not (np.isfinite(row_level).any() and np.isfinite(noise)):
        return not_seen(f"the car's front is not in the picture in frame {i}")
    min_contrast = max(CONTRAST_NOISES * noise, CONTRAST_MIN)
    told = row_level > min_contrast
    if told.sum() < MIN_CONTRAST_ROWS:
        return not_seen(f"the car's front differs from the background by {float(np.nanmedian(row_level)):.1f} "
                        f"grey levels (noise {noise:.1f}), by more than {min_contrast:.1f} in {int(told.sum())} "
                        f"of its {len(rows)} rows in frame {i}: too little to see it stop")
    level = float(np.median(row_level[told]))
    threshold = 0.5 * level
    # the rows where the car stands out of the background, as offsets in the reference frame
    told_ref = rows[told] - (raw[1] - nose_ref[1])
    u_rigid = np.full(len(idx), np.nan)
    # the front end per frame, its sigma and how far the rows that showed it stand behind
    # the tip (px): as the rows' most forward share shows it, and as their median does
    # (debris joined to the front in a few rows moves the one and not the other)
    series = {q: (np.full(len(idx), np.nan), np.full(len(idx), np.nan), np.full(len(idx), np.nan))
              for q in (FORWARD_QUANTILE, 0.5)}
    last = None  # the last frame where the front end was found
    for k, i, nose, raw, rows, shift in placed:
        u_rigid[k] = nose[0]
        band, rows = rows, _rows_told(rows, raw[1] - nose_ref[1], told_ref)
        moved = d * (raw[0] - nose0[0])
        if moved < 2.0 * FRAME0_CLEAR_PX:
            continue  # the front end may still stand where the car stood in the background's frames
        # from ahead of where the car stood there (the background behind that shows the
        # car) to a little ahead of the rigid front end: the visible front end is the most
        # forward column that differs from the background
        u_from = nose0[0] + d * min(search_px + 2.0, 0.5 * moved)
        gray = _frame_against(frame_at, i, background, rows, raw[0] + d * (search_px + 2.0), d, shift)
        front = FrontEndDetector(background, rows, u_from, raw[0] + d * search_px, threshold, shift,
                                 min_contrast).detect(gray)
        if not len(front):
            continue
        _, _, front_rows, row_u = front.found
        lags = (np.asarray(row_lag_px(front_rows - (raw[1] - nose_ref[1])), float) if row_lag_px is not None
                else np.full(len(front_rows), np.nan))
        for q, (u_q, s_q, lag_q) in series.items():
            u, s_q[k] = front_of_rows(row_u, d, q)
            u_q[k] = float(to_pose(i, np.array([[u, raw[1]]]))[0, 0])
            if np.isfinite(lags).any():
                # the rows that stand for the front: their lags at the same quantile
                lag_q[k] = float(np.nanquantile(lags, 1.0 - q))
        last = (int(i), gray, rows, band, shift, float(nose[1]))
    u_seen, s_seen, lag = series[FORWARD_QUANTILE]
    found = stop_time(t[idx], u_rigid, u_seen, s_seen, 0.02 / fps)
    median = series[0.5]
    by_median = stop_time(t[idx], u_rigid, median[0], median[1], 0.02 / fps)
    ahead_px, late_s = 0.0, 0.0
    if found is None:
        joined = "; the rows' median front is followed, their most forward ones showing no clean stop"
    else:
        ahead_px, t_ahead = _joined_ahead(t[idx], u_rigid, u_seen, s_seen, found[0], d)
        stood = (f"; in a frame the front's most forward rows stood {ahead_px:.1f} px ahead of where the car can "
                 "be (debris, or something else joined to it)")
        joined = f"{stood}: the rows' median front is followed" if ahead_px else ""
        if (not ahead_px and by_median is not None and by_median[3] >= MIN_CHI2_GAIN
                and by_median[0] < found[0] - max(1.0 / fps, 3.0 * np.hypot(found[1], by_median[1]))):
            # the rows' median, which stands behind the tip and stops after it, stopped
            # first: the most forward rows went on past where the front stood (debris
            # joined to them short of where the cell's nose is by then)
            joined = (f"; the rows' median front stopped {(found[0] - by_median[0]) * 1e3:.2f} ms before their "
                      "most forward ones, which went on past where it stood (debris, or something else joined "
                      "to them): the median is followed")
    if joined:
        # something joined the front in its most forward rows, ahead of where the car
        # can be (debris flung towards the camera shows beyond the face): the median row
        if by_median is not None and by_median[3] < MIN_CHI2_GAIN and found is not None:
            by_median = None  # the median rows do not stop: as if no clean stop
        last_moving = (None if by_median is None or found is None or not by_median[0] > t_ahead + 1.0 / fps
                       else _last_moving(t[idx], u_rigid, u_seen, s_seen, t_ahead))
        if last_moving is not None:
            # what joined the front reached its median rows too, which stop after the first
            # frame that showed it; it came with the contact: the contact lies between the
            # last frame where the front moved with the cell and that one
            ts = 0.5 * (last_moving + t_ahead)
            stop_u = float(np.interp(ts, t[idx][np.isfinite(u_rigid)], u_rigid[np.isfinite(u_rigid)])
                           + np.median((u_seen - u_rigid)[np.isfinite(u_seen) & (t[idx] <= last_moving)]))
            found = (ts, (t_ahead - last_moving) / np.sqrt(12.0), stop_u, by_median[3], by_median[4])
            joined = (f"{stood}, and in their median too, which stopped {(by_median[0] - t_ahead) * 1e3:.2f} ms after "
                      f"the first frame that showed it: the contact lies between the last frame where the front "
                      f"moved with the cell ({last_moving * 1e3:.2f} ms) and that one ({t_ahead * 1e3:.2f} ms)")
        elif by_median is not None or found is None:
            u_seen, s_seen, lag = median
            found = by_median
        else:
            # no clean stop in the median rows: the most forward rows' stop stands, its
            # sigma widened: what joined the front came with the contact or after it, so
            # the contact lies before the first frame that shows it (or a frame before)
            late_s = max(found[0] - t_ahead, 0.0) + 1.0 / fps
            joined = (f"{stood}, and their median shows no clean stop: the stop may be up to "
                      f"{late_s * 1e3:.2f} ms late, which the sigma counts")
    which = ", neither in its most forward rows nor in their median" if joined else ""
    # the front followed stood ahead of where the car can be before the stop it shows (or,
    # with no clean stop, before it stood behind the rigid path): what stopped there is not
    # the car's front alone; the contact is bracketed from the frames before instead
    stop = found is not None and found[3] >= MIN_CHI2_GAIN
    t_joined = None
    if not late_s:
        t_joined = _first_ahead(t[idx], u_rigid, u_seen, s_seen, d, found[0] if stop else np.inf)
        if t_joined is not None and not stop and not stands_behind(t[idx], u_rigid, u_seen, s_seen, d, t_joined):
            t_joined = None
    if t_joined is None:
        if found is None:
            return not_seen(f"the front end, followed in {int(np.isfinite(u_seen).sum())} of {len(idx)} frames "
                            f"around the deceleration onset, shows no clean stop{which} (too few frames on one "
                            "side of it, or more than a quarter of them off a stop)")
        ts, ts_sig, stop_u, gain, reduced = found
        if gain < MIN_CHI2_GAIN:
            return not_seen(f"the front end does not stop in frames {i0}-{i1}{which} (chi-square gain {gain:.1f})")
    else:
        pre = np.isfinite(lag) & (t[idx] < t_joined) & (t[idx] >= t_joined - FRAMES_BEFORE / fps)
        lag_px = float(np.median(lag[pre])) if pre.any() and np.median(lag[pre]) > 0.0 else 0.0
        bracket = joined_bracket(t[idx], u_rigid, u_seen, s_seen, d, t_joined, lag_px)
        if bracket is None:
            return not_seen(f"the front end stood ahead of where the car can be from {t_joined * 1e3:.2f} ms on "
                            "(debris, or something else joined to it), and was not seen within "
                            f"{MAX_UNSEEN_FRAMES:g} frames before: the contact is not bracketed")
        t_lo, t_hi, stop_u = bracket
        ts, ts_sig = 0.5 * (t_lo + t_hi), (t_hi - t_lo) / np.sqrt(12.0)
        reduced = found[4] if stop else float("nan")
        after = "before the stop it showed" if stop else "before it stood behind the rigid path, with no clean stop"
        joined += (f"; from {t_joined * 1e3:.2f} ms on, {after}, the front followed stood ahead of where the car "
                   f"can be (debris, or something else joined to it): its rows reached the face between "
                   f"{t_lo * 1e3:.2f} ms (the rigid path at the column they were last seen at) and "
                   f"{t_hi * 1e3:.2f} ms (the nose's tip at the face by the first frame that showed it)")
    moving = _last_seen_moving(t[idx], u_rigid, u_seen, s_seen, ts, stop_u) if t_joined is None else ts
    if moving is None or ts - moving > MAX_UNSEEN_FRAMES / fps:
        since = "" if moving is None else f", {(ts - moving) * 1e3:.2f} ms after the last frame that showed it moving"
        return not_seen(f"the front end stops at {ts * 1e3:.2f} ms at column {stop_u:.1f} px{since} with the cell: "
                        f"across more than {MAX_UNSEEN_FRAMES:g} frames unseen the stop is the rigid path extrapolated "
                        "to what stands there (debris at the face, an edge), not the front seen stopping")
    # a stop where the car would not have stood out of the background had it gone on (the
    # car as grey as the barrier it passes in front of) cannot be told from passing on
    i_last, gray, rows, band, shift, v_nose = last
    stop_raw = to_raw(i_last, np.array([[stop_u, v_nose]]))[0, 0]
    car = np.nanmedian(sample(gray, _band(stop_raw - d * np.arange(2.0, 7.0), rows)), axis=1)
    beyond = np.nanmedian(sample(background, _band(stop_raw + d * np.arange(2.0, 9.0), rows) - shift), axis=1)
    if not np.mean(np.abs(car - beyond) > min_contrast) >= 0.5:
        return not_seen(f"the front end stops at column {stop_u:.1f} px, but beyond it the car would not stand "
                        "out of what is behind it there (as grey as the barrier it would pass in front of): "
                        "a stop cannot be told from passing on")
    # a stop at a straight edge of frame 0 running far above and below the nose: a barrier's
    # edge nearer the camera than the car's side hides the nose before it touches the face
    # where the face stands short of the column the depth direction vanishes to (the edge
    # shows short of the face there); beyond that column the nearer edge shows beyond the
    # face and a farther one is drawn behind the car, so a stop at an edge there is the
    # face in the car's plane. A textured background's edges do not run on.
    tall = np.arange(max(band[0] - 2 * len(band), 2), min(band[-1] + 2 * len(band), background.shape[0] - 3) + 1)
    step = (np.nanmedian(sample(background, _band(stop_raw + d * np.arange(2.0, 7.0), tall) - shift), axis=1)
            - np.nanmedian(sample(background, _band(stop_raw - d * np.arange(2.0, 7.0), tall) - shift), axis=1))
    step = step[np.isfinite(step)]
    at_edge = len(step) >= len(band) and max(np.mean(step > threshold), np.mean(step < -threshold)) >= EDGE_ROWS_SHARE
    margin = VANISH_MARGIN * background.shape[1]
    if at_edge and not (vanish_u is not None and d * (stop_u - vanish_u) > margin):
        where = ("not well beyond the column the depth direction vanishes to" if vanish_u is not None
                 else "the column the depth direction vanishes to not being known")
        return not_seen(f"the front end stops at column {stop_u:.1f} px, where frame 0 shows an edge, {where} "
                        "(a barrier edge nearer the camera than the car's side hides the nose there before it "
                        "touches the face): a stop cannot be told from going behind it")
    after = np.isfinite(u_seen) & (t[idx] >= ts)
    stop_sig = float(np.sqrt(1.0 / np.sum(1.0 / s_seen[after] ** 2))) if after.any() else float("nan")
    ts_sig = float(np.sqrt(ts_sig**2 + (SEEN_FLOOR_FRAMES / fps) ** 2 + late_s**2))
    off = (f" (the picture's front stood {abs(located):.1f} px {'ahead of' if d * located > 0 else 'behind'} "
           "the vehicle outline's nose)" if abs(located) > NOSE_OFF_PX else "")
    stopped = (f"the front end stopped at {ts * 1e3:.2f} ms at column {stop_u:.1f} px, in the car's own plane{off}"
               if t_joined is None else f"the front end's rows reached the face at {ts * 1e3:.2f} ms, the middle of "
               f"a bracket, at column {stop_u:.1f} px or beyond, in the car's own plane{off}")
    if at_edge:
        stopped += (", at an edge of frame 0 beyond the column the depth direction vanishes to (the barrier's "
                    "face in the car's plane)")
    stopped += joined
    before = np.isfinite(lag) & (t[idx] < ts) & (t[idx] >= ts - FRAMES_BEFORE / fps)
    if before.any() and np.median(lag[before]) > 0.0:
        lag_px = float(np.median(lag[before]))
        tc = back_to_the_tip(t[idx], u_rigid, d, ts, lag_px)
        ts_sig = float(np.hypot(ts_sig, TIP_LAG_REL_SIGMA * (ts - tc)))
        stopped += (f"; its rows stand {lag_px:.1f} px behind the outline's tip, which reached the face "
                    f"{(ts - tc) * 1e3:.2f} ms earlier")
        ts = tc
    return SeenContact("seen", ts, ts_sig, stop_u, stop_sig,
                       f"first contact seen at {ts * 1e3:.2f} +- {ts_sig * 1e3:.2f} ms: {stopped}"
                       + (f"; reduced chi-square {reduced:.1f}" if np.isfinite(reduced) else ""))


def pose_on_the_approach(pose: BodyPose, t: np.ndarray, j: int, before_s: float) -> BodyPose | None:
    """``pose`` with frame ``j``'s pose, not measured there, carried from the approach.

    Before contact the passenger cell moves in a uniform translation (the car rolls at a
    constant speed, level): its point in frame ``j`` is the straight line (px against s)
    fitted by least squares to the :data:`APPROACH_POSE_FRAMES` measured frames nearest
    ``j`` among those before ``before_s`` (s, film clock), and its rotation their median
    (rad). A video's first frames, coded before its rate control settles, can lose every
    target (development film 960042, 0.02 bit per pixel: frames 1-2), where the picture
    still serves as background.

    Parameters
    ----------
    pose : BodyPose
        The cell's pose per frame, px (NaN where not measured).
    t : (n,) s
        Film clock of every frame.
    j : int
        The frame to carry the pose to.
    before_s : float
        Only frames before this time are the approach, s.

    Returns
    -------
    BodyPose or None
        A copy with frame ``j``'s point, rotation and their sigmas filled in (the sigma the
        fit's at ``t[j]``, px, and the frames' median, rad); None with fewer than 2
        measured frames of the approach.
    """
    ok = np.flatnonzero(np.isfinite(pose.point[:, 0]) & np.isfinite(pose.phi) & (t < before_s))
    if len(ok) < 2:
        return None
    near = np.sort(ok[np.argsort(np.abs(ok - j), kind="stable")[:APPROACH_POSE_FRAMES]])
    tt = t[near] - t[j]
    A = np.stack([np.ones_like(tt), tt], axis=1)
    coef, *_ = np.linalg.lstsq(A, pose.point[near], rcond=None)
    point, phi = pose.point.copy(), pose.phi.copy()
    point_sigma, phi_sigma = pose.point_sigma.copy(), pose.phi_sigma.copy()
    point[j], phi[j] = coef[0], float(np.median(pose.phi[near]))
    # the line's sigma at t[j] from the frames' own sigma (the intercept's, t[j] at 0)
    cov = np.linalg.pinv(A.T @ A) * float(np.nanmedian(pose.point_sigma[near])) ** 2
    point_sigma[j], phi_sigma[j] = float(np.sqrt(cov[0, 0])), float(np.nanmedian(pose.phi_sigma[near]))
    return replace(pose, point=point, phi=phi, point_sigma=point_sigma, phi_sigma=phi_sigma)


def noise_ahead(gray: np.ndarray, background: np.ndarray, u_front: float, rows: np.ndarray, direction: int,
                search_px: float, shift: np.ndarray) -> float:
    """The background's own noise (sensor, compression) ahead of the car's front: one-sigma
    of the frame's difference from the background (their median absolute difference) over
    12 px from ``search_px + 2`` px beyond ``u_front``, where the brightness is matched too
    and the car is not, grey levels. Not nearer: the moving front's own edge stands there,
    which a low-bitrate video codes again frame by frame with the wall's blocks around it
    (development film 960000, 0.057 bit per pixel: 4-19 grey levels from 2 to 13 px ahead of
    the front, none beyond; its noise measured 3-9 px ahead, 12 grey levels, hid the car
    where it stood 16 levels darker than the barrier)."""
    from .calibrate_profile import sample

    ahead = _band(u_front + direction * np.arange(search_px + 2.0, search_px + 14.0), rows)
    return 1.4826 * float(np.nanmedian(np.abs(sample(gray, ahead) - sample(background, ahead - shift))))


def _joined_ahead(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                  ts: float, direction: int) -> tuple[float, float]:
    """Where the front seen stood ahead of the rigidly carried front end, where the car
    cannot be, from :data:`JOINED_FRAMES` frames before the stop at ``ts`` to the end of
    the frames that judge it: by more than :data:`OUTLIER` sigmas and a pixel beyond the
    offset the frames before the stop show. The most it did, px, and the first frame's
    time, s; (0, NaN) when it never did."""
    dt = float(np.median(np.diff(t)))
    inside = (t >= ts - FRAMES_BEFORE * dt) & (t < ts + FRAMES_AFTER * dt) & np.isfinite(u_seen) \
        & np.isfinite(u_rigid)
    c = _offset_before(t, u_rigid, u_seen, ts)
    if c is None:
        return 0.0, float("nan")
    ahead = direction * (u_seen - u_rigid - c)
    bad = inside & (t >= ts - JOINED_FRAMES * dt) & (ahead > OUTLIER * sigma + 1.0)
    return (float(np.max(ahead[bad])), float(t[bad][0])) if bad.any() else (0.0, float("nan"))


def _offset_before(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, t_ref: float) -> float | None:
    """Where the seen front end stood against the rigidly carried one in the
    :data:`FRAMES_BEFORE` frames before ``t_ref`` (s): their median offset, px; None when
    neither was measured in any of them."""
    dt = float(np.median(np.diff(t)))
    pre = np.isfinite(u_seen) & np.isfinite(u_rigid) & (t >= t_ref - FRAMES_BEFORE * dt) & (t < t_ref)
    return float(np.median(u_seen[pre] - u_rigid[pre])) if pre.any() else None


def _first_ahead(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                 direction: int, t_before: float) -> float | None:
    """The first frame before ``t_before`` (s) from which the seen front end stood ahead of
    where the car can be in :data:`AHEAD_FRAMES` seen frames in a row, s; None when none did.

    Ahead: beyond the offset the :data:`FRAMES_BEFORE` frames before it show against the
    rigidly carried front end by more than :data:`OUTLIER` sigmas and a pixel (the car's
    front never stands ahead of its rigid path: the crush only takes it back). One frame
    alone is not taken: a camera shaken by a few px puts a frame's front a px or two off
    (development film 960061, shake 2.3 px: 2.1 px ahead 11 frames before the contact),
    where debris flung from the face stays in view for several frames (it flies back at
    most half the car's speed).
    """
    seen = np.flatnonzero(np.isfinite(u_seen) & np.isfinite(u_rigid) & np.isfinite(sigma) & (t < t_before))
    run = 0
    for k in seen:
        c = _offset_before(t, u_rigid, u_seen, float(t[k]))
        ahead = c is not None and direction * (u_seen[k] - u_rigid[k] - c) > OUTLIER * sigma[k] + 1.0
        run = run + 1 if ahead else 0
        if run == AHEAD_FRAMES:
            return float(t[seen[np.flatnonzero(seen == k)[0] - AHEAD_FRAMES + 1]])
    return None


def stands_behind(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                  direction: int, t_from: float) -> bool:
    """Whether the seen front end fell behind the rigidly carried one from ``t_from`` (s)
    on, as a front end stopped at the face does while the cell goes on: in at least
    :data:`MIN_FRAMES_EACH_SIDE` of the seen frames among the :data:`FRAMES_BEFORE` from
    ``t_from``, and in at least half of them, by more than :data:`OUTLIER` sigmas and a
    pixel beyond the offset the frames before ``t_from`` show (px). A front end that goes
    on with the cell (a frame or two off it, a camera shaken by a few px) does not."""
    dt = float(np.median(np.diff(t)))
    c = _offset_before(t, u_rigid, u_seen, t_from)
    win = np.isfinite(u_seen) & np.isfinite(u_rigid) & np.isfinite(sigma) & (t >= t_from) \
        & (t < t_from + FRAMES_BEFORE * dt)
    if c is None or not win.any():
        return False
    behind = direction * (u_rigid[win] + c - u_seen[win]) > OUTLIER * sigma[win] + 1.0
    return bool(behind.sum() >= MIN_FRAMES_EACH_SIDE and behind.mean() >= 0.5)


def _rigid_time(t: np.ndarray, u_rigid: np.ndarray, direction: int, column: float) -> float:
    """When the rigidly carried front end (px, advancing in ``direction``; NaN where not
    measured) reached ``column`` (px), s: linear between frames, NaN outside them."""
    ok = np.isfinite(u_rigid)
    ahead = np.maximum.accumulate(direction * u_rigid[ok])
    x = direction * column
    if not ahead[0] <= x <= ahead[-1]:
        return float("nan")
    return float(np.interp(x, ahead, t[ok]))


def joined_bracket(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                   direction: int, t_joined: float, lag_px: float = 0.0) -> tuple[float, float, float] | None:
    """When the rows followed reached the face, from the frames before something joined
    the front ahead of where the car can be at ``t_joined`` (s).

    Lower bound: the rows stood at ``u_last`` in the last frame seen before ``t_joined``;
    moving or stopped there, they had not reached the face before the rigidly carried
    front end (with the offset the frames before show) came to that column, less
    :data:`OUTLIER` of that frame's sigmas. Upper bound: what joined the front came with
    the contact (debris flung from the face), so the nose's tip touched by ``t_joined``;
    the rows, ``lag_px`` (px) behind the tip, when the rigid path had gone ``lag_px`` on
    from there.

    Returns
    -------
    (t_lo, t_hi, u_last) or None
        The bracket, s, and the column the rows were last seen at, px; None when the last
        frame seen lies more than :data:`MAX_UNSEEN_FRAMES` frame intervals before
        ``t_joined`` or the bracket falls outside the frames followed.
    """
    dt = float(np.median(np.diff(t)))
    ok = np.flatnonzero(np.isfinite(u_seen) & np.isfinite(u_rigid) & np.isfinite(sigma) & (t < t_joined))
    c = _offset_before(t, u_rigid, u_seen, t_joined)
    if not len(ok) or c is None or t_joined - t[ok[-1]] > MAX_UNSEEN_FRAMES * dt:
        return None
    k = ok[-1]
    t_lo = _rigid_time(t, u_rigid, direction, u_seen[k] - c - direction * OUTLIER * sigma[k])
    at_joined = float(np.interp(t_joined, t[np.isfinite(u_rigid)], u_rigid[np.isfinite(u_rigid)]))
    t_hi = _rigid_time(t, u_rigid, direction, at_joined + direction * lag_px)
    if not (np.isfinite(t_lo) and np.isfinite(t_hi)) or t_hi <= t_lo:
        return None
    return t_lo, t_hi, float(u_seen[k])


def _last_moving(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                 t_ahead: float) -> float | None:
    """The last frame before ``t_ahead`` where the seen front end stood where the rigidly
    carried one puts it (within :data:`OUTLIER` sigmas and a pixel of the offset the
    :data:`FRAMES_BEFORE` frames before show), s; None when no frame did."""
    dt = float(np.median(np.diff(t)))
    c = _offset_before(t, u_rigid, u_seen, t_ahead)
    if c is None:
        return None
    ok = np.isfinite(u_seen) & np.isfinite(u_rigid) & (t < t_ahead - 0.5 * dt)
    moving = ok & (np.abs(u_seen - u_rigid - c) <= OUTLIER * sigma + 1.0)
    return float(t[moving][-1]) if moving.any() else None


def _last_seen_moving(t: np.ndarray, u_rigid: np.ndarray, u_seen: np.ndarray, sigma: np.ndarray,
                      ts: float, stop_u: float) -> float | None:
    """The last frame before the stop at ``ts`` (s, at column ``stop_u`` px) that shows the
    front end moving with the cell: where the stop model puts the front (the rigid one plus
    the offset ``stop_u - u_rigid(ts)``) within :data:`OUTLIER` sigmas and a pixel, and
    further than :data:`OUTLIER` sigmas from the stop column (a frame whose front stands
    there already does not tell moving from stopped), s; None when no frame does."""
    ok = np.isfinite(u_seen) & np.isfinite(u_rigid) & np.isfinite(sigma) & (t < ts)
    if not ok.any():
        return None
    c = stop_u - float(np.interp(ts, t[np.isfinite(u_rigid)], u_rigid[np.isfinite(u_rigid)]))
    moving = ok & (np.abs(u_seen - u_rigid - c) <= OUTLIER * sigma + 1.0) & (np.abs(u_seen - stop_u) > OUTLIER * sigma)
    return float(t[moving][-1]) if moving.any() else None


def back_to_the_tip(t: np.ndarray, u_rigid: np.ndarray, direction: int, ts: float, lag_px: float) -> float:
    """When the nose's tip reached the column where rows ``lag_px`` behind it stopped at
    ``ts``: the time at which the rigidly carried front end stood ``lag_px`` short of
    where it was at ``ts`` (linear between frames), s.

    Parameters
    ----------
    t : (n,) s
        Frame times, increasing.
    u_rigid : (n,) px
        The rigidly carried front end (NaN where not measured).
    direction : +1 or -1
        Direction of travel in the image.
    ts : float
        Time at which the rows stopped, s.
    lag_px : float
        How far those rows stand behind the tip, px (>= 0).

    Returns
    -------
    float
        The tip's contact, s; ``ts`` itself when the crossing lies before the frames of
        ``u_rigid`` (nothing to interpolate).
    """
    ok = np.isfinite(u_rigid) & (t <= ts + 2.0 * float(np.median(np.diff(t))))
    tt, ahead = t[ok], direction * u_rigid[ok]
    at_stop = float(np.interp(ts, tt, ahead))
    # before the contact the car advances every frame; after it, the cell slows but goes on
    ahead = np.maximum.accumulate(ahead)
    if not at_stop - lag_px >= ahead[0]:
        return ts  # the tip's crossing lies before the frames followed: no correction
    return float(min(np.interp(at_stop - lag_px, ahead, tt), ts))


def _locate_front(frame_at, idx, pose, nose_ref, nose0, rows_ref, d, background, to_pose,
                  search_px) -> float | str:
    """The column shift (px, pose coordinates) from the outline's nose to the picture's
    front end: in the first frame of ``idx`` where the nose has moved at least
    ``2 * search_px + 4`` px from ``nose0`` (its place in the background's middle frame), the
    end of the run of columns that differ from the background, searched from half-way
    between ``nose0`` and now (columns the car covers in this frame and did not there) up to
    :data:`LOCATE_PX` ahead, in the rows where the car differs from the background by more
    than :data:`CONTRAST_MIN` (at least :data:`MIN_CONTRAST_ROWS`). A sentence saying why
    when it cannot be found."""
    from .calibrate_profile import sample

    for i in idx:
        if not np.isfinite(pose.point[i, 0]):
            continue
        nose, raw, rows, shift = _nose_in_frame(pose, i, nose_ref, rows_ref, to_pose)
        moved = d * (raw[0] - nose0[0])
        if moved < 2 * search_px + 4:
            continue
        gray = _frame_against(frame_at, i, background, rows, raw[0] + d * LOCATE_PX, d, shift)
        mid = 0.5 * (raw[0] + nose0[0])
        new = _band(mid + d * np.linspace(-0.25, 0.25, 9) * moved, rows)
        diff = np.abs(sample(gray, new) - sample(background, new - shift))
        if not np.isfinite(diff).any():
            return (f"the nose, placed from the CG and the scale, falls outside the picture in frame {i} "
                    "(or the camera's shake there is not measured)")
        row_level = _row_median(diff)
        told = row_level > CONTRAST_MIN
        if told.sum() < MIN_CONTRAST_ROWS:
            return (f"the car's front differs from the background by {float(np.nanmedian(diff)):.1f} grey levels "
                    f"in frame {i}, by more than {CONTRAST_MIN:g} in {int(told.sum())} of its {len(rows)} rows: "
                    "too little to see it stop")
        level = float(np.median(row_level[told]))
        front = FrontEndDetector(background, rows[told], mid, raw[0] + d * LOCATE_PX, 0.5 * level,
                                 shift).detect(gray)
        if not len(front):
            return (f"the car's front end not found in frame {i} within {LOCATE_PX:g} px ahead of the "
                    "vehicle outline's nose")
        return float(to_pose(i, np.array([[front.found[0], raw[1]]]))[0, 0] - nose[0])
    return (f"the car does not move {2 * search_px + 4:g} px from where it stood at the film's start within frames "
            f"{idx[0]}-{idx[-1]} around the deceleration onset: no background to see its front against")


def _nose_in_frame(pose: BodyPose, i: int, nose_ref: np.ndarray, rows_ref: tuple[float, float],
                   to_pose: Callable[[int, np.ndarray], np.ndarray]) -> tuple:
    """Where the rigidly carried nose is in frame ``i``: (nose in pose coordinates, the
    same in the raw picture, the nose's rows there (the raw picture's: the reference
    frame's band moved to the raw nose, as every column is sampled in the raw picture; a
    lens or tilt taken out moves a nose near the picture's edge by a few rows), and the
    camera's shake since frame 0 at that point (the lens's correction cancels)), px."""
    nose = pose.transform(i, nose_ref[None])[0]
    raw = raw_points(to_pose, i, nose[None])[0]
    v0, v1 = rows_ref
    dv = raw[1] - nose_ref[1]
    rows = np.arange(np.ceil(v0 + dv), np.floor(v1 + dv) + 1)
    shift = to_pose(0, raw[None])[0] - to_pose(i, raw[None])[0]
    return nose, raw, rows, shift


def _row_median(diff: np.ndarray) -> np.ndarray:
    """Each row's median of a band of differences (R, U), NaN for a row without one."""
    diff = np.asarray(diff, float)
    ok = np.isfinite(diff).any(axis=1)
    out = np.full(len(diff), np.nan)
    out[ok] = np.nanmedian(diff[ok], axis=1)
    return out


def _rows_told(rows: np.ndarray, dv: float, told_ref: np.ndarray) -> np.ndarray:
    """The rows of a frame's nose band (px) that stand, moved back by the nose's rise
    ``dv`` (px) since the reference frame, within half a row of one of ``told_ref`` (the
    reference frame's rows where the car stands out of the background)."""
    rows = np.asarray(rows, float)
    near = np.abs((rows - dv)[:, None] - np.asarray(told_ref, float)[None, :]).min(axis=1) <= 0.5
    return rows[near]


def _frame_against(frame_at, i: int, background: np.ndarray, rows: np.ndarray, ratio_from: float,
                   direction: int, shift: np.ndarray) -> np.ndarray:
    """Frame ``i`` in grey, brought to the background's brightness (measured from the
    column ``ratio_from`` px on, where the car is not)."""
    from .calibrate_profile import to_gray

    gray = to_gray(frame_at(int(i)))
    return gray / _brightness_ratio(gray, background, rows, ratio_from, direction, shift)


def outline_lag_m(outline: np.ndarray, z: np.ndarray) -> np.ndarray:
    """How far a side outline's front stands behind its most forward point at heights ``z``.

    Parameters
    ----------
    outline : (N, 2) m
        Closed polygon ``(x, z)``, x forward.
    z : (M,) m
        Heights.

    Returns
    -------
    (M,) m
        The tip's x minus the outline's most forward crossing at each height (NaN where
        no edge crosses it).
    """
    p = np.asarray(outline, float)
    a, b = p, np.roll(p, -1, axis=0)
    z = np.asarray(z, float)[:, None]
    lo, hi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    dz = b[:, 1] - a[:, 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(dz != 0, (z - a[:, 1]) / dz, 0.0)
    x = np.where((z >= lo) & (z <= hi), a[:, 0] + f * (b[:, 0] - a[:, 0]), -np.inf)
    front = x.max(axis=1)
    return np.where(np.isfinite(front), p[:, 0].max() - front, np.nan)


def raw_points(to_pose: Callable[[int, np.ndarray], np.ndarray], i: int, p: np.ndarray) -> np.ndarray:
    """The raw image points (M, 2) px of frame ``i`` that ``to_pose`` takes to ``p``: its
    inverse by :data:`TO_RAW_STEPS` fixed-point steps (a strong lens moves a point by 20 px,
    and one step alone leaves 2-3 px of it)."""
    p = np.asarray(p, float)
    raw = p.copy()
    for _ in range(TO_RAW_STEPS):
        raw = raw - (to_pose(i, raw) - p)
    return raw


def _band(us: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Sample points (R, U, 2) of columns ``us`` in ``rows``."""
    return np.stack(np.broadcast_arrays(np.asarray(us, float)[None, :], np.asarray(rows, float)[:, None]), axis=-1)


def _brightness_ratio(gray: np.ndarray, background: np.ndarray, rows: np.ndarray, u_from: float,
                      direction: int, shift: np.ndarray, width_px: float = 40.0) -> float:
    """The frame's brightness against the background's (lamp flicker, exposure), from the
    median ratio of the ``width_px`` columns ahead of ``u_from``, where the car is not;
    1 where they are out of the picture or dark."""
    from .calibrate_profile import sample

    pts = _band(u_from + direction * np.arange(0.0, width_px, 2.0), rows)
    a, b = sample(gray, pts), sample(background, pts - shift)
    ok = np.isfinite(a) & np.isfinite(b) & (b > 10.0)
    if ok.sum() < 20:
        return 1.0
    return float(np.median(a[ok] / b[ok]))


#: The deceleration onset's one-sigma as a contact time, s: the RMS of its error (4.3 ms)
#: on 20 tracked reference-world films, seeds 960000-960028 (no test or benchmark scores
#: them), for judging a disagreement.
ONSET_SIGMA_S = 0.0043


def settle_contact(onset_s: float, seen: SeenContact) -> tuple[float, float | None, str]:
    """The film's first contact from the deceleration onset and the picture.

    A contact seen in the picture is the contact, a measurement apart from the motion the
    fit fits (it comes with its sigma), unless the onset disagrees with it beyond three
    combined sigmas: two measurements of one instant that far apart leave it unmeasured,
    and the onset stands without a sigma, as where nothing was seen (it is the fitted
    motion's own), the disagreement said. Development film 960042 (low-bitrate frames,
    no fixed target): a stop seen at -12.0 +- 1.3 ms from the true contact, 21 ms before
    the onset, was held by the fit and cut the approach's speed 0.94 % short; the onset
    alone is +9.0 ms off, with no sigma claimed. The onset has been 2.6-4.1 ms late on a
    film of NHTSA 10146's real pulse, far inside the 13 ms this takes.

    Returns
    -------
    (time_s, sigma_s or None, note)
    """
    if seen.kind != "seen":
        return onset_s, None, f"{seen.note}; contact from the deceleration onset alone"
    diff = onset_s - seen.time_s
    note = f"{seen.note}; the deceleration onset says {onset_s * 1e3:.2f} ms ({diff * 1e3:+.2f} ms)"
    if abs(diff) > 3.0 * np.hypot(seen.sigma_s, ONSET_SIGMA_S):
        return onset_s, None, note + (": the picture and the motion disagree beyond three sigmas (a front end"
                                      " that stopped for another reason, debris, or a pulse that rises late), so"
                                      " neither is a measurement: contact from the deceleration onset, no sigma")
    return seen.time_s, seen.sigma_s, note
