"""The video stage: film -> scale -> targets -> tracks -> motion (``track_film``).

``track_film`` is a short pipeline over named stages, each a function of this module:
``_film_rate`` (enough frames, a crash's frame rate), ``_scale`` (the tapes; the lens;
without a tape, ``_scale_from_hubs`` after the roles: the hub targets and the wheelbase),
``_first_targets`` (detection in frame 0), ``_follow`` (``video.follow.track_targets``,
repeated frames, the lens taken out), ``_roles`` (fixed, hub, body targets; the camera's
shake taken out on the fixed ones), ``_reference`` (the first frame with every body
target), ``_cg`` (hub targets, else the vehicle outline), ``_pose`` (the passenger
cell's x, z, pitch in the car's plane), ``_contact`` (deceleration onset, then the
contact seen in the picture), ``_speed``, ``_channels`` (displacement from the contact
frame with sigmas, velocity, crush), ``_wheels`` (spin angles, heights, events).

Example
-------
>>> from video.io import open_film                                    # doctest: +SKIP
>>> tracks = track_film(open_film("crash.mp4", fps=1000), car)        # doctest: +SKIP
>>> tracks.channels["x_m"], tracks.sigma["x_m"], tracks.events_ms     # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from video.contact_seen import NOSE_BAND_M, SeenContact, not_seen, outline_lag_m, see_contact, settle_contact
from video.errors import NoTapeError, VideoError
from video.filters import velocity
from video.follow import Progress, TargetTracks, TrackerConfig, prefetch, track_targets
from video.targets import QuadrantTargetDetector
from video.types import CarGeometry, Tracks

__all__ = ["TrackerConfig", "track_film"]

#: Lowest frame rate the video stage accepts, frames per second (a crash lasts ~0.1 s).
MIN_FPS = 200.0

#: How far into the film the frames lie that tell the car's tapes from the background's
#: patterns (they moved with the car by then: 10 ms at 15 m/s is 0.15 m), s; the second
#: and third 1.3 and 1.7 times as far (:func:`video.calibrate_scale.tapes_on_the_car`).
LATER_S = 0.010

#: SAE J211 class of the velocity channel derived from the film's displacement.
VELOCITY_CFC = 60


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
            notes, tyre_deflection: bool = True) -> tuple[dict, dict]:
    """Wheel spin angles and heights from the hub targets, their events (ms).

    Adds ``<front|rear>_wheel_angle_rad`` and ``<front|rear>_wheel_height_m`` (with
    sigma) to ``channels``/``sigma`` and sentences to ``notes``; returns the events,
    ``<wheel>_wheel_block``, ``_unblock``, ``_lift``, ``_touchdown`` in ms after contact,
    and the one-sigma of those bracketed (lift, touchdown), ms; ``tyre_deflection``
    (``TrackerConfig``) False: a rigid tyre.
    """
    from video.motion import (TYRE_STIFFNESS_N_PER_M, block_time, floor_heights, lift_time, to_car_plane,
                              touchdown_time, tyre_unloading_m, unblock_time)

    events: dict = {}
    events_sigma: dict = {}
    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    hubs = [(w, k) for w, k in (("front", kf), ("rear", kr)) if k is not None]
    for which in ("front", "rear"):
        if which not in dict(hubs):
            notes.append(f"no {which} hub target: {which} wheel angle and height not measured")
    if not hubs:
        return events, events_sigma
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
        load = car.static_wheel_load(which)
        least, most = unloading = tyre_unloading_m(load) if tyre_deflection else (0.0, 0.0)
        tyre = (f"{least * 1e3:.0f}-{most * 1e3:.0f} mm: {load:.0f} N on a tyre of"
                f" {TYRE_STIFFNESS_N_PER_M[0] / 1e3:.0f}-{TYRE_STIFFNESS_N_PER_M[1] / 1e3:.0f} kN/m")
        lift = lift_time(t, h, sh, 0.0, fps, unloading_m=unloading)
        if lift is not None:
            events[f"{which}_wheel_lift"], events_sigma[f"{which}_wheel_lift"] = lift.time_s * 1e3, lift.sigma_s * 1e3
            notes.append(f"{which} wheel off the floor at {lift.time_s * 1e3:.1f} +- {lift.sigma_s * 1e3:.1f} ms:"
                         f" between {lift.earliest_s * 1e3:.1f} and {lift.latest_s * 1e3:.1f} ms its hub rose through"
                         f" its tyre's possible static deflection ({tyre}), where the tyre lets go")
            down = touchdown_time(t, h, sh, lift.latest_s, fps, unloading_m=unloading)
            if down is not None:
                events[f"{which}_wheel_touchdown"] = down.time_s * 1e3
                events_sigma[f"{which}_wheel_touchdown"] = down.sigma_s * 1e3
                notes.append(f"{which} wheel back on the floor at {down.time_s * 1e3:.1f} +- {down.sigma_s * 1e3:.1f}"
                             f" ms (between {down.earliest_s * 1e3:.1f} and {down.latest_s * 1e3:.1f} ms)")
        elif np.nanmax(np.where(t > 0, h, np.nan), initial=-np.inf) > 0.002:
            notes.append(f"{which} hub rose up to {np.nanmax(np.where(t > 0, h, np.nan)) * 1e3:.0f} mm, not beyond its"
                         f" tyre's possible static deflection ({tyre}): not seen to leave the floor")
    notes.append("wheel heights: the hub centres' rise above the path they rolled along "
                 "before contact (the floor line, fitted in the image)")
    return events, events_sigma


def _measured_geometry(uv, sigma_px, kf, kr, cf, s, s_sig, sil, car, hubs_measure: bool = True) -> dict:
    """The car's wheelbase and length as the film shows them (``Tracks.geometry``).

    Wheelbase: the median distance of the two hub targets over the frames before contact
    (undistorted positions at the tape's scale); its sigma combines one frame's centre
    sigmas (tracking errors of neighbouring frames are alike, so averaging is not credited)
    with the scale's. Length: the fitted silhouette is the vehicle file's outline scaled
    to the film's edges, so the film's length is the file's times tape scale over
    silhouette scale, with both scales' sigmas. ``hubs_measure`` False: the scale came from
    the hub targets and the file's wheelbase, so their spacing measures nothing (absent)."""
    out: dict = {}
    if hubs_measure and kf is not None and kr is not None:
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


def _contact_in_picture(film, frame_t, pose, cg_uv, axes: np.ndarray, car: CarGeometry, s: float, d: int,
                        onset_s: float, lens, stab) -> SeenContact:
    """First contact in the picture (:mod:`video.contact_seen`), the nose placed by
    :func:`nose_in_picture` (the picture's own front may stand a few px off it)."""
    from video.calibrate import undistort_points

    def to_pose(i: int, p: np.ndarray) -> np.ndarray:
        p = undistort_points(np.asarray(p, float), lens) if lens.corrected else np.asarray(p, float)
        return p if stab is None else stab.correct(i, p)

    placed = nose_in_picture(car, cg_uv, axes, s)
    if isinstance(placed, str):
        return not_seen(placed)
    nose, rows, row_lag_px = placed
    return see_contact(film.__getitem__, frame_t, pose, nose, rows, d, onset_s, to_pose=to_pose,
                       row_lag_px=row_lag_px, vanish_u=float(to_pose(0, lens.centre[None])[0, 0]))


def nose_in_picture(car: CarGeometry, cg_uv: np.ndarray, axes: np.ndarray, s: float):
    """The undeformed nose in the picture, from the CG and the vehicle's outline along the
    car plane's axes in the image (a camera rolled by 3 degrees moves the nose of a car
    2 m ahead of its CG by 10 cm up or down, against the image's own axes).

    Parameters
    ----------
    car : CarGeometry
    cg_uv : (2,) px
        The CG in the picture.
    axes : (2, 2)
        Image unit vectors of car-plane X (travel) and Z (up), :func:`video.motion.travel_axes`.
    s : float
        Scale, m/px.

    Returns
    -------
    (nose, rows, row_lag_px) or str
        The nose's middle (2,) px; the band of rows (top, bottom) px where the outline
        stands within :data:`video.contact_seen.NOSE_BAND_M` of its tip; and
        ``row_lag_px(v)``, how far the outline at rows ``v`` stands behind the tip, px. A
        sentence saying why when the band is under 5 rows high.
    """
    sil = np.asarray(car.silhouette_side, float)
    z = np.arange(sil[:, 1].min(), sil[:, 1].max(), 0.25 * s)
    band = z[outline_lag_m(sil, z) <= NOSE_BAND_M]
    if band.size == 0:
        return "the vehicle outline has no front within its height"
    ex, ez = np.asarray(axes, float)
    tip = np.asarray(cg_uv, float) + ex * (sil[:, 0].max() - car.x_cg) / s

    def at_height(zz):
        return tip + np.multiply.outer(np.asarray(zz, float) - car.cg_height, ez) / s

    top, bottom = sorted((float(at_height(band.max())[1]), float(at_height(band.min())[1])))
    if bottom - top + 2.0 < 5.0:
        return "the vehicle outline's front is under 5 rows high at this scale"

    def row_lag_px(v: np.ndarray) -> np.ndarray:
        return outline_lag_m(sil, car.cg_height + (np.asarray(v, float) - tip[1]) * s / ez[1]) / s

    return at_height(0.5 * (band.min() + band.max())), (top - 1.0, bottom + 1.0), row_lag_px


# ------------------------------------------------------------------------ stages


def _film_rate(film) -> tuple[int, float, str]:
    """(frames, fps, the film's name); VideoError for a film too short or too slow."""
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
    return n, fps, where


def _scale(frame0, later, tape_segment_m: float, notes: list, config: TrackerConfig):
    """The tapes' scale estimate (``video.calibrate.measure_scale``): m/px, sigma, lens and
    camera yaw, from the tapes that moved by the ``later`` frames (on the car); None when no
    tape is in view (the scale then comes from the hub targets, ``_scale_from_hubs``, unless
    ``config.hub_scale`` is off: then the NoTapeError)."""
    from video.calibrate import measure_scale

    try:
        est = measure_scale(frame0, tape_segment_m, frame_index=0, correct_yaw=config.correct_yaw,
                            later_frames=later)
    except NoTapeError as err:
        if not config.hub_scale:
            raise
        notes.append(f"{err}: the scale is taken from the hub targets and the wheelbase instead")
        return None
    notes.extend(est.notes)
    return est


def _no_lens(frame0):
    """The lens model of a film without a tape: nothing corrected, and why."""
    from video.calibrate import no_distortion

    h, w = np.asarray(frame0).shape[:2]
    return no_distortion((w, h), "lens distortion and camera yaw not measured (no tape in view, whose "
                                 "straightness and even segments measure them): not corrected")


def _approach(uv, sigma_px, roles, ref: int, fps: float, stab=None) -> np.ndarray:
    """Frames of the approach, (n,) bool: before the body targets' deceleration onset (in
    px, so before any scale is known; a share of the camera's shake taken out, ``stab``,
    fitted with it), less two frames."""
    from video.motion import body_pose, contact_time

    pose = body_pose(uv, sigma_px, roles.body, uv[ref, roles.body].mean(axis=0), ref)
    frame_t = np.arange(len(uv)) / fps
    x_px = roles.direction * (pose.point[:, 0] - pose.point[ref, 0])
    onset, _ = contact_time(frame_t, x_px, pose.point_sigma, fps, shake=_shake_along_x(stab, roles.direction, 1.0))
    before = np.zeros(len(uv), bool)
    before[:max(int(onset * fps) - 2, 3)] = True
    return before


def _scale_from_hubs(uv, sigma_px, roles, approach, car: CarGeometry, lens, where: str,
                     notes: list, why: str = "no tape being in view"):
    """The scale of a film without a tape (``video.calibrate.scale_from_hubs``): the hub
    targets' median distance over the ``approach`` (:func:`_approach`: the wheelbase is not
    crushed yet), against the vehicle file's wheelbase. VideoError when the film has no
    front and rear hub target (then it has no scale reference), or no approach to take
    their distance over (``approach`` is then the VideoError that said why)."""
    from video.calibrate import scale_from_hubs

    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    if kf is None or kr is None:
        raise VideoError(f"no scale reference in {where}: no checker tape in frame 0 and no "
                         f"{'front' if kf is None else 'rear'} hub target to take the scale from the "
                         "wheelbase; film a tape in the car's plane or targets on both hubs")
    if isinstance(approach, VideoError):
        raise approach
    both = approach & np.isfinite(uv[:, kf, 0]) & np.isfinite(uv[:, kr, 0])
    if both.sum() < 3:
        raise VideoError(f"no scale reference in {where}: no checker tape in frame 0, and the hub "
                         f"targets are seen together in {int(both.sum())} frame(s) before contact "
                         "(3 needed to take the scale from the wheelbase)")
    spacing = np.hypot(*(uv[both, kf] - uv[both, kr]).T)
    # one frame's sigma: tracking errors of neighbouring frames are alike, so the median
    # over the approach is not credited with averaging them out
    sig = float(np.nanmedian(np.hypot(sigma_px[both, kf], sigma_px[both, kr])))
    est = scale_from_hubs(float(np.median(spacing)), sig if np.isfinite(sig) else 0.0,
                          float(car.wheelbase), lens, why)
    notes.extend(est.notes + (lens.note,))
    return est


#: A hub target turns with its wheel as the car rolls towards the barrier: one that turns by
#: less than this over the approach (rad) and only after contact is on a part that deforms
#: (on scored film 910038 a target on the crushing front turned 0.00 rad before contact and
#: 0.62 after, and was taken for the front hub; real hubs turned 1-2 rad over 20-45 ms).
HUB_APPROACH_TURN = 0.25


def _rolling_hubs(roles, tt, approach, notes: list):
    """``roles`` with each hub target that does not turn over the ``approach``
    (:func:`_approach`) by :data:`HUB_APPROACH_TURN` made an "other" target, said in the
    notes; unchanged where the approach cannot be told (``approach`` a VideoError: no
    deceleration onset in px, a short film)."""
    hubs = [k for k, kind in enumerate(roles.kind) if kind in ("front_hub", "rear_hub")]
    if not hubs or isinstance(approach, VideoError):
        return roles
    kind = list(roles.kind)
    for k in hubs:
        a = tt.angle[approach, k]
        turn = float(np.nanmax(a) - np.nanmin(a)) if np.isfinite(a).sum() >= 2 else 0.0
        if turn < HUB_APPROACH_TURN:
            notes.append(f"target{k} turns only after contact (by {turn:.2f} rad over the approach, where a wheel "
                         f"rolls): on a part that deforms, not a {kind[k].replace('_', ' ')}")
            kind[k] = "other"
    return replace(roles, kind=tuple(kind))


#: A tape's scale a factor of this or more from the hub targets' distance against the vehicle
#: file's wheelbase is a misread tape (its period read as two or three segments) or a wrong
#: ``--tape-segment``, not a vehicle file's wheelbase off (a few per cent for the wrong model
#: year, 30 % between a city car and a limousine): the wheels' spin decides.
TAPE_HUB_CONFLICT = 1.5
#: ... backing the scale it comes within this share of (a free wheel's rolling radius is 2-3 %
#: under its unloaded one; a tape misread is 50 % off or more).
SPIN_BACKS = 0.15


def _tape_checked_by_hubs(est, uv, sigma_px, tt, roles, approach, fps: float, car: CarGeometry, where: str,
                          notes: list):
    """The tape's scale ``est``, or the hub targets' where the two are a factor
    :data:`TAPE_HUB_CONFLICT` apart and the wheels' spin over the approach (their rolling
    speed, :func:`video.calibrate.scale_from_spin`) backs the hubs' and not the tape's.
    VideoError when it backs neither; the tape's stands where there are no hubs to check it
    (or the spin backs it: then the vehicle file is doubtful, which the CG's note says)."""
    from video.calibrate import scale_from_spin

    if est.source != "checker tape" or roles.index("front_hub") is None or roles.index("rear_hub") is None:
        return est
    try:
        hubs = _scale_from_hubs(uv, sigma_px, roles, approach, car, est.lens, where, [], "the tape being misread")
    except VideoError:
        return est
    factor = est.m_per_px / hubs.m_per_px
    if max(factor, 1.0 / factor) < TAPE_HUB_CONFLICT:
        return est
    t = np.arange(len(uv)) / fps
    spins = [scale_from_spin(t[approach], uv[approach, k, 0], tt.angle[approach, k], float(car.wheel_radius))
             for k in (roles.index("front_hub"), roles.index("rear_hub"))]
    spin = float(np.nanmedian(spins)) if np.isfinite(spins).any() else float("nan")
    said = (f"the checker tape's scale ({1e3 * est.m_per_px:.3f} mm/px for a {est.tape_segment_m:g} m segment) "
            f"is {factor:.2f} times the hub targets' distance against the vehicle file's wheelbase "
            f"({1e3 * hubs.m_per_px:.3f} mm/px)")
    if abs(spin / hubs.m_per_px - 1.0) < SPIN_BACKS:
        notes.append(f"{said}; the wheels' spin over the approach backs the hubs' ({1e3 * spin:.3f} mm/px with the "
                     f"wheel radius {float(car.wheel_radius):.3f} m): the tape is misread or its segment is not "
                     f"{est.tape_segment_m:g} m, so the scale is taken from the hub targets")
        notes.extend(hubs.notes)
        return hubs
    if abs(spin / est.m_per_px - 1.0) < SPIN_BACKS:
        return est
    spun = (f"the wheels' spin backs neither ({1e3 * spin:.3f} mm/px)" if np.isfinite(spin)
            else "the wheels' spin is not measured over the approach to decide")
    raise VideoError(f"no scale to trust in {where}: {said}, and {spun}; check --tape-segment and the vehicle file")


def _first_targets(frame0, config: TrackerConfig, where: str):
    """The quadrant targets of frame 0; VideoError when fewer than two."""
    first = QuadrantTargetDetector(config.detect).detect(frame0).found
    if len(first) < 2:
        raise VideoError(f"{len(first)} quadrant target(s) found in frame 0 of {where}; at "
                         "least two on the passenger cell are needed (check the targets are "
                         f"in view and {2 * config.detect.min_radius_px:g}-{2 * config.detect.max_radius_px:g} px across)")
    return first


def _background(frame0, later):
    """The background's corners to measure a shaken camera on
    (``video.background_motion.BackgroundMotion``), or None: the car's rows are those where
    ``later`` (a frame before contact) differs from ``frame0`` in 3 % of the columns or more
    (the car has moved between them), with a third of their height above for the rear's rise
    in the crash and a tenth below."""
    import cv2

    from video.background_motion import BackgroundMotion
    from video.targets import to_gray

    diff = np.abs(cv2.GaussianBlur(to_gray(later), (0, 0), 2) - cv2.GaussianBlur(to_gray(frame0), (0, 0), 2))
    rows = np.flatnonzero((diff > 10 / 255).mean(axis=1) >= 0.03)
    if not len(rows):
        return None
    top, bottom = float(rows.min()), float(rows.max())
    return BackgroundMotion.start(frame0, (top - (bottom - top) / 3, bottom + (bottom - top) / 10))


def _kept(frames, bg):
    """The frames as they are, each kept by ``bg`` (``BackgroundMotion``) on the way."""
    for f in frames:
        bg.keep(f)
        yield f


def _follow(film, n: int, first, lens, config: TrackerConfig, progress, notes: list, bg=None):
    """Every target through the film: (tracks as found, undistorted centres (n, K, 2) px,
    frames blanked as repeats); ``bg`` (``BackgroundMotion``) keeps each frame on the way."""
    noise = getattr(film, "noise", None)
    noise = None if noise is None or len(noise) != n else np.asarray(noise, float) / 255.0
    # a decoding thread overlaps decoding with tracking; frames in memory need none (the
    # thread's hand-over then only costs the tracker the GIL)
    frames = iter(film) if getattr(film, "in_memory", False) else prefetch(iter(film))
    tt = track_targets(frames if bg is None else _kept(frames, bg), n, first, noise, config, progress)
    dropped = _drop_repeated_frames(tt, getattr(film, "duplicates", ()), notes)
    return tt, _undistorted(tt.uv, lens), dropped


def _undistorted(uv_raw: np.ndarray, lens) -> np.ndarray:
    """The centres ``uv_raw`` (n, K, 2) px, as recorded, mapped through ``lens`` when it is
    applied (``lens.corrected``), NaN kept; a new array."""
    from video.calibrate import undistort_points

    uv = np.array(uv_raw, dtype=float)
    if lens.corrected:
        flat = uv.reshape(-1, 2)
        ok = np.isfinite(flat[:, 0])
        flat[ok] = undistort_points(flat[ok], lens)
    return uv


def _camera_map(tt: TargetTracks, uv, lens, est, fps: float, dropped, notes: list):
    """The lens's radial distortion and the camera's yaw and pitch against the car's plane
    fitted to the approach (``video.calibrate_motion.map_from_approach``: the targets on the
    car, body and hub centres, move together at a constant speed before contact), replacing
    the tapes' map when the fit is made; the centres undistorted again and the tapes' scale
    measured again through it. Returns (lens, centres, scale estimate or None)."""
    from video.calibrate_motion import map_from_approach
    from video.calibrate_scale import rescaled
    from video.motion import classify_targets

    roles = classify_targets(uv, tt.angle)
    moving = [k for k, kind in enumerate(roles.kind) if kind in ("body", "front_hub", "rear_hub")]
    try:
        approach = _approach(uv, tt.sigma_px, roles, _reference(uv, roles.body), fps)
    except VideoError as why:
        notes.append(f"camera map not fitted to the approach: {why}")
        return lens, uv, est
    # a repeated frame shifts the clock of the frames after it: only those after the last
    last = max([int(i) for i in dropped if approach[int(i)]], default=-1)
    approach[: last + 1] = False
    fit = map_from_approach(tt.uv, tt.sigma_px, approach, moving, lens)
    notes.append(fit.note)
    if not fit.used:
        return lens, uv, est
    if est is not None:
        est = rescaled(est, fit.lens, fit.k1_sigma, fit.tilt_sigma)
    return fit.lens, _undistorted(tt.uv, fit.lens), est


def _roles(uv, tt: TargetTracks, config: TrackerConfig, notes: list, bg=None, principal_px=None):
    """Fixed, hub and body targets (``video.motion.classify_targets``) and the camera's
    shake taken out, measured on the fixed targets or, with none in view, on the
    background's corners (``bg``, a ``video.background_motion.BackgroundMotion``): (roles,
    centres, their sigmas, the correction or None); the hubs are checked afterwards
    (:func:`_rolling_hubs`), then the roles said (:func:`_say_targets`). With the lens's
    centre ``principal_px`` (px) the fixed targets' motion is taken out as the camera's turn
    where they tell it from a shift and roll (``video.motion.fit_camera_turn``)."""
    from video.motion import classify_targets, stabilise_on_fixed

    roles = classify_targets(uv, tt.angle)
    for k in roles.copies:
        notes.append(f"target{k} follows the target another track follows (a detection in frame 0 that was not "
                     "a target, taken up by a neighbouring one): neither fixed, nor a hub, nor on the cell")
    sigma_px = tt.sigma_px
    fixed = np.flatnonzero(np.array(roles.kind) == "fixed")
    # the background only where no fixed target is in view: with one (or more) the fixed
    # targets measured the shake better on the development films (x RMS 0.38-1.17 mm against
    # 0.90-3.76 mm on 960016, 960026, 960032, 960039)
    if not config.stabilise:
        return roles, uv, sigma_px, None
    if len(fixed):
        if bg is not None:
            bg.kept.clear()  # the fixed targets measure the shake: the background's frames are let go
        stab, source, lost = (stabilise_on_fixed(uv, sigma_px, fixed, principal_px), f"{len(fixed)} fixed target(s)",
                              "where no fixed target is seen")
    elif bg is not None:
        stab, source, lost = (bg.stabilise(uv, sigma_px), f"{len(bg.ref)} corners of the background",
                              "where too few of them were followed")
    else:
        notes.append("no fixed target (barrier, floor) in view: a camera shaken by the impact could not be "
                     "taken out of the tracks")
        return roles, uv, sigma_px, None
    if stab is None:
        if not len(fixed):
            notes.append("no fixed target (barrier, floor) in view, and the background's corners show no shake")
        return roles, uv, sigma_px, None
    worst = int(np.nanargmax(np.hypot(*stab.shift_px.T)))
    unseen = np.flatnonzero(~np.isfinite(stab.shift_px[:, 0]))
    notes.append(f"camera motion taken out of every track from {source}: up to "
                 f"{np.hypot(*stab.shift_px[worst]):.2f} px (frame {worst}), roll up to "
                 f"{np.degrees(np.max(np.abs(stab.roll))):.3f} deg"
                 + (f"; not corrected in frame(s) {_runs_text(unseen)}, {lost}" if len(unseen) else "")
                 + (f"; as the camera's turn, the focal length fitted to their motion {stab.turn.focal_px:.0f} px"
                    if stab.turn is not None else ""))
    return roles, stab.uv, stab.sigma_px, stab


def _say_targets(uv, roles, notes: list) -> None:
    """The notes of what each target was taken for, and where each one was lost."""
    for k in range(uv.shape[1]):
        miss = np.flatnonzero(~np.isfinite(uv[:, k, 0]))
        if len(miss):
            notes.append(f"target{k} ({roles.kind[k]}) lost in {len(miss)} frame(s): "
                         f"{_runs_text(miss)} (occluded, smeared or out of view): NaN there, "
                         "not interpolated")
    notes.append("targets: " + ", ".join(f"target{k}={roles.kind[k]}" for k in range(uv.shape[1])))


def _reference(uv, body) -> int:
    """The first frame where every body target is seen; VideoError when none is."""
    seen = np.all(np.isfinite(uv[:, body, 0]), axis=1)
    if not seen.any():
        raise VideoError("no frame shows every body target at once; cannot set the reference")
    return int(np.flatnonzero(seen)[0])


def _cg(film, uv, tt: TargetTracks, roles, ref: int, car: CarGeometry, est, notes: list):
    """The CG in the reference frame's image: from the hub targets and the vehicle
    geometry, else from the fitted outline, else the body targets' centroid. Returns
    (cg (2,) px, its source or None, the fitted outline or None)."""
    from video.calibrate import compare_scales, fit_silhouette, undistort_points
    from video.motion import cg_from_hubs

    d = roles.direction
    s, lens = est.m_per_px, est.lens
    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    sil = None
    try:
        sil = fit_silhouette(film[ref], car, scale_hint=s, direction=d, frame_index=ref,
                             inside_px=tt.uv[ref, roles.body])
        notes.append(compare_scales(s, est.sigma, sil, "tape" if est.tapes else "hub").note)
    except VideoError as err:
        notes.append(f"silhouette not fitted ({err})")
    if kf is not None and kr is not None and np.isfinite(uv[ref, kf, 0]) \
            and np.isfinite(uv[ref, kr, 0]):
        cg_uv, _ = cg_from_hubs(uv[ref, kf], uv[ref, kr], d, s, car.x_cg - car.rear_axle_x,
                                car.cg_height - car.wheel_radius)
        hub_wb = np.hypot(*(uv[ref, kf] - uv[ref, kr])) * s
        if est.tapes and abs(hub_wb / car.wheelbase - 1.0) > 0.02:
            notes.append(f"hub targets are {hub_wb:.3f} m apart, the wheelbase is "
                         f"{car.wheelbase:.3f} m: scale or hub targets doubtful")
        src = "hub targets and the vehicle geometry"
    elif sil is not None:
        p = sil.to_image(np.array([[car.x_cg, car.cg_height]]))[0]
        cg_uv = undistort_points(p[None], lens)[0] if lens.corrected else p
        src = "the fitted silhouette"
    else:
        cg_uv = uv[ref, roles.body].mean(axis=0)
        src = None
        notes.append("CG position unknown (no hub targets, no silhouette): x, z follow the "
                     "centroid of the body targets")
    if src:
        notes.append(f"CG located from {src}")
    return cg_uv, src, sil


@dataclass(frozen=True)
class _Pose:
    """The passenger cell in the car's plane, frame by frame (film clock)."""

    pose: object          # video.motion.BodyPose (image px)
    XZ: np.ndarray        # (n, 2) m from the reference frame, camera roll taken out
    axes: np.ndarray      # the car plane's axes in the image
    pitch: np.ndarray     # (n,) rad, nose up positive
    pos_sig: np.ndarray   # (n,) m, one point's sigma
    frame_t: np.ndarray   # (n,) s from frame 0
    onset_guess_s: float  # deceleration onset on the image axes, s from frame 0
    x_sig_extra: np.ndarray | None = None  # (n,) m, x's sigma beyond the point's (a shake's share taken out)


def _pose(uv, sigma_px, body, cg_uv, ref: int, d: int, s: float, fps: float, notes: list,
          dropped=(), stab=None) -> _Pose:
    """The cell's rigid motion (``video.motion.body_pose``) in the car's plane, the camera's
    roll found from the level approach and taken out. The first guess of the contact is
    fitted after the last repeated frame (``dropped``) before the deceleration: a repeat
    shifts the clock of the frames after it, a step the onset fit may take for the contact
    (on the test film repeating frame 12 it did, at 12-13 ms, the contact being at 31 ms);
    with the camera's shake taken out (``stab``), a share of it left in x is fitted with it
    (:func:`_shake_along_x`)."""
    from video.motion import body_pose, contact_time, deceleration_start, to_car_plane, travel_axes

    n = len(uv)
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
    x0 = XZ[:, 0].copy()
    if len(dropped):
        slows = deceleration_start(frame_t, x0)
        cut = max([int(i) for i in dropped if i < slows * fps - 3], default=-1)
        if cut >= 0 and np.isfinite(x0[cut + 1:]).sum() >= 10:
            x0[: cut + 1] = np.nan
    tc0, _ = contact_time(frame_t, x0, pos_sig, fps, shake=_shake_along_x(stab, d, s))
    axes, roll = travel_axes(pose.point, max(int(tc0 * fps) - 1, 2), d)
    if abs(roll) > np.radians(0.05):
        notes.append(f"camera roll {np.degrees(roll):+.2f} deg (from the level approach) "
                     "taken out of x, z")
    XZ = to_car_plane(pose.point - pose.point[ref], d, s, axes)
    return _Pose(pose=pose, XZ=XZ, axes=axes, pitch=d * pose.phi, pos_sig=pos_sig, frame_t=frame_t,
                 onset_guess_s=float(tc0))


#: A share of the camera's shake left in x is taken out where it stands this many of its own
#: sigmas from zero.
SHAKE_SHARE_SIGMAS = 3.0


def _take_out_shake_left(p: _Pose, x_fit, tc: float, stab, d: int, s: float, notes: list):
    """``p`` and ``x_fit`` with the share of the camera's shake correction still left in x
    (``video.motion.shake_left_in_x``, fitted with the onset at the contact ``tc``) taken
    out of every frame, its uncertainty in x's sigma (``_Pose.x_sig_extra``); as they
    are where no shake was taken out, its share is within :data:`SHAKE_SHARE_SIGMAS` of
    zero, or beyond what a camera's turn leaves (``video.motion.MAX_SHAKE_SHARE``). A
    camera that turns moves the picture's edges more than its middle: on
    development films 960080 and 960093 the correction measured at the barrier left 21 and
    13 % of a 3.5-3.8 px shake in the car's x (3.5 and 4.0 mm at most); with the share
    fitted at the onset taken out, x's RMS error against the truth (``synth.scoring``'s)
    fell from 0.91 and 1.40 mm to 0.14 and 0.16 mm."""
    from video.motion import MAX_SHAKE_SHARE, shake_left_in_x

    shake = _shake_along_x(stab, d, s, p.axes)
    if shake is None:
        return p, x_fit
    try:
        found = shake_left_in_x(p.frame_t, x_fit, p.pos_sig, tc, shake)
    except VideoError:
        return p, x_fit
    if found is None:
        return p, x_fit
    share, share_sig = found
    if abs(share) > MAX_SHAKE_SHARE:
        notes.append(f"the camera's shake left in x: {100 * share:+.1f} +- {100 * share_sig:.1f} % of its correction,"
                     " more than a camera's turn leaves (the correction may not be the camera's motion): not taken out")
        return p, x_fit
    if not abs(share) > SHAKE_SHARE_SIGMAS * share_sig:
        notes.append(f"the camera's shake left in x: {100 * share:+.1f} +- {100 * share_sig:.1f} % of its correction,"
                     " not beyond its sigma: not taken out")
        return p, x_fit
    XZ = p.XZ.copy()
    XZ[:, 0] -= share * shake
    notes.append(f"the camera's shake left in x ({100 * share:+.1f} +- {100 * share_sig:.1f} % of its correction, fitted"
                 f" with the deceleration's onset: up to {1e3 * np.max(np.abs(share * shake)):.2f} mm) taken out of x")
    return replace(p, XZ=XZ, x_sig_extra=share_sig * np.abs(shake)), x_fit - share * shake


def _shake_along_x(stab, d: int, s: float, axes=None) -> np.ndarray | None:
    """The camera motion taken out of the tracks (``video.motion.Stabilised.shift_px``) as it
    bears on the car-plane x, m per frame (``video.motion.to_car_plane``: image axes unless
    ``axes``); None when no shake was taken out. The onset's fit takes a share of it as
    left in x (``video.motion.contact_time``)."""
    from video.motion import to_car_plane

    if stab is None:
        return None
    return to_car_plane(np.nan_to_num(stab.shift_px), d, s, axes)[:, 0]


def _contact(film, p: _Pose, dropped, cg_uv, cg_src, car, s, d, lens, stab, fps, n,
             config: TrackerConfig, notes: list):
    """First contact: the deceleration onset, replaced by the contact seen in the picture
    when it is seen. Returns (time s from frame 0, its sigma or None, the contact frame,
    the x series the onset was fitted on)."""
    from video.motion import contact_time

    # a repeated frame before contact may have shifted the frames after it by one
    # interval: fit only the frames after the last one
    x_fit = p.XZ[:, 0].copy()
    cut = max([i for i in dropped if i < p.onset_guess_s * fps - 3], default=-1)
    if cut >= 0:
        x_fit[: cut + 1] = np.nan
    shake = _shake_along_x(stab, d, s, p.axes)
    try:
        tc, how = contact_time(p.frame_t, x_fit, p.pos_sig, fps, shake=shake)
    except VideoError:
        x_fit = p.XZ[:, 0]
        tc, how = contact_time(p.frame_t, x_fit, p.pos_sig, fps, shake=shake)
    notes.append(f"{how}: {tc * 1e3:.2f} ms after frame 0")
    seen = None
    if config.see_contact:  # the nose is placed from the CG: without one it is not looked for, and said
        seen = _contact_in_picture(film, p.frame_t, p.pose, cg_uv, p.axes, car, s, d, tc, lens, stab) if cg_src \
            else not_seen("not looked for: the CG is not located (no hub targets, no fitted silhouette), so the"
                          " nose cannot be placed")
    tc_sigma = None
    if seen is not None:
        tc, tc_sigma, note = settle_contact(tc, seen)
        notes.append(note)
    # first frame at or after the contact; a contact within 0.2 frame after a frame is
    # taken as that frame (the onset fit's precision: frame-aligned contacts stay put)
    cf = min(max(int(np.ceil(tc * fps - 0.2)), 1), n - 1)
    notes.append(f"contact frame {cf}")
    return tc, tc_sigma, cf, x_fit


def _speed(p: _Pose, x_fit, cf: int, s: float, s_sig: float, speed_mps, notes: list) -> float:
    """Impact speed, m/s: the given one, else the approach's (``video.motion.impact_speed``);
    VideoError when the car moves away from the barrier."""
    from video.motion import impact_speed

    v_meas, v_sig = impact_speed(p.frame_t, x_fit, p.pos_sig, cf)
    v_sig = float(np.hypot(v_sig, v_meas * s_sig / s))
    if v_meas < 0:
        raise VideoError("the car moves away from the barrier before contact; check the film")
    if speed_mps is None:
        return float(v_meas)
    notes.append(f"impact speed given: {speed_mps:.3f} m/s; measured {v_meas:.3f} "
                 f"+- {v_sig:.3f} m/s")
    return float(speed_mps)


def _channels(p: _Pose, x_fit, tc: float, cf: int, s: float, fps: float,
              car: CarGeometry, notes: list) -> tuple[dict, dict]:
    """x, z (m from the contact frame), pitch, vx and crush with their sigmas."""
    from video.motion import crush_from_pose

    XZ = p.XZ
    if not np.all(np.isfinite(XZ[cf])):
        raise VideoError(f"the car's position is not measured in the contact frame {cf} "
                         f"(body targets lost there); x, z have no reference")
    x = XZ[:, 0] - XZ[cf, 0]
    z = XZ[:, 1] - XZ[cf, 1]
    # the tracked point's noise; the scale's error is one number common to every length of
    # the film (``Tracks.scale_sigma``), not noise of each sample, and is left out here
    sx = np.sqrt(p.pose.point_sigma**2 + p.pose.point_sigma[cf] ** 2) * s
    sxx = sx if p.x_sig_extra is None else np.hypot(sx, p.x_sig_extra)
    channels = {"x_m": x, "z_m": z, "pitch_rad": p.pitch}
    sigma = {"x_m": sxx, "z_m": sx.copy(), "pitch_rad": p.pose.phi_sigma}
    try:
        vx = velocity(x, fps, VELOCITY_CFC, sigma_m=sxx)
    except VideoError as err:
        notes.append(f"no vx_mps: {err}")
    else:
        channels["vx_mps"] = vx.values
        sigma["vx_mps"] = vx.sigma
        notes.append(f"vx_mps: derivative of x_m filtered with SAE J211 CFC {vx.cfc}")
    # crush: the rigid outline past the front end's position at contact, where the CG
    # was at the contact instant: on the approach line (uniform motion)
    okp = np.isfinite(x_fit[:cf])
    if okp.sum() >= 3:
        line = np.polyfit(p.frame_t[:cf][okp], x_fit[:cf][okp], 1)
        x_at_tc = float(np.polyval(line, tc) - XZ[cf, 0])
    else:
        x_at_tc = 0.0
    front_ahead = float(np.max(car.silhouette_side[:, 0])) - car.x_cg
    channels["crush_m"] = crush_from_pose(x, p.pitch, car.silhouette_side, car.x_cg,
                                          car.cg_height, front_ahead + x_at_tc)
    sigma["crush_m"] = sx.copy()
    notes.append("crush from the rigid passenger cell's travel past its position at "
                 "contact (the undeformed outline), not from the deformed front end")
    return channels, sigma


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
    n, fps, where = _film_rate(film)
    notes: list[str] = list(getattr(film, "notes", []))
    frame0 = film[0]
    if progress is not None:
        progress(0, n, "calibrating")
    later = [film[min(max(int(s * fps), k), n - 1)] for s, k in ((LATER_S, 5), (1.3 * LATER_S, 7),
                                                                 (1.7 * LATER_S, 9))]
    est = _scale(frame0, later, tape_segment_m, notes, config)
    lens = est.lens if est is not None else _no_lens(frame0)
    first = _first_targets(frame0, config, where)
    bg = _background(frame0, later[-1]) if config.stabilise and config.background_shake else None
    tt, uv, dropped = _follow(film, n, first, lens, config, progress, notes, bg)
    if config.map_from_approach:
        lens, uv, est = _camera_map(tt, uv, lens, est, fps, dropped, notes)
    roles, uv, sigma_px, stab = _roles(uv, tt, config, notes, bg, lens.centre)
    d = roles.direction
    ref = _reference(uv, roles.body)
    try:
        approach = _approach(uv, sigma_px, roles, ref, fps, stab)
    except VideoError as why:  # the hubs are then not checked, nor the scale taken from them
        approach = why
    roles = _rolling_hubs(roles, tt, approach, notes)
    _say_targets(uv, roles, notes)
    if est is None:
        est = _scale_from_hubs(uv, sigma_px, roles, approach, car, lens, where, notes)
    else:
        est = _tape_checked_by_hubs(est, uv, sigma_px, tt, roles, approach, fps, car, where, notes)
    s, s_sig = est.m_per_px, est.sigma
    cg_uv, cg_src, sil = _cg(film, uv, tt, roles, ref, car, est, notes)
    p = _pose(uv, sigma_px, roles.body, cg_uv, ref, d, s, fps, notes, dropped, stab)
    tc, tc_sigma, cf, x_fit = _contact(film, p, dropped, cg_uv, cg_src, car, s, d, lens, stab,
                                       fps, n, config, notes)
    p, x_fit = _take_out_shake_left(p, x_fit, tc, stab, d, s, notes)
    v_imp = _speed(p, x_fit, cf, s, s_sig, speed_mps, notes)
    channels, sigma = _channels(p, x_fit, tc, cf, s, fps, car, notes)
    t = (np.arange(n) - cf) / fps
    events, events_sigma = _wheels(uv, tt, roles, ref, cf, t, fps, s, s_sig, d, p.axes, car, channels, sigma,
                                   notes, config.tyre_deflection)
    for k in range(len(first)):
        for axis, col in (("u", 0), ("v", 1)):
            channels[f"target{k}_{axis}_px"] = tt.uv[:, k, col]
            sigma[f"target{k}_{axis}_px"] = tt.sigma_px[:, k]
    for key in channels:
        sigma[key] = np.where(~np.isfinite(channels[key]), np.nan, sigma[key])
    kf, kr = roles.index("front_hub"), roles.index("rear_hub")
    overlay = {
        "frame": ref,
        "tapes": [np.asarray(tp.ends, float) for tp in est.tapes],
        "targets_uv": tt.uv[ref].copy(),
        "target_radii": tt.radius.copy(),
        "target_kinds": list(roles.kind),
        "silhouette_px": None if sil is None else np.asarray(sil.polygon_px, float),
        "cg_uv": np.asarray(cg_uv, float),
    }
    return Tracks(t=t, channels=channels, sigma=sigma, events_ms=events, events_sigma_ms=events_sigma, contact_frame=cf,
                  fps=fps, scale_m_per_px=float(s), scale_sigma=float(s_sig),
                  impact_speed_mps=v_imp, direction=int(d), notes=notes,
                  contact_offset_s=float(tc - cf / fps), contact_sigma_s=tc_sigma, overlay=overlay,
                  geometry=_measured_geometry(uv, tt.sigma_px, kf, kr, cf, s, s_sig, sil, car,
                                              hubs_measure=bool(est.tapes)),
                  scale_source=est.source)
