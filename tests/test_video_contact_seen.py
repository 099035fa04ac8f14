"""First contact seen in the picture (``video.contact_seen``): the front end's stop in a
series whose stop is known, the front column against a textured background with debris
ahead of it, and the whole search on drawn frames of a car that stops at a known instant."""

from __future__ import annotations

import re

import numpy as np
import pytest

from video.contact_seen import (
    MIN_CHI2_GAIN,
    ONSET_SIGMA_S,
    SeenContact,
    back_to_the_tip,
    front_column,
    noise_ahead,
    not_seen,
    outline_lag_m,
    pose_on_the_approach,
    raw_points,
    see_contact,
    settle_contact,
    stop_time,
)
from video.motion import BodyPose

FPS = 1000.0


def _series(ts=0.0124, v=-2.3, c=3.0, noise=0.3, n=36, t0=0.0, seed=1):
    """A front end moving at ``v`` px/frame that stops at ``ts`` s, seen ``c`` px off the
    rigid one, with Gaussian noise of ``noise`` px."""
    rng = np.random.default_rng(seed)
    t = t0 + np.arange(n) / FPS
    rigid = 500.0 + v * FPS * (t - t0)
    seen = np.where(t < ts, rigid, np.interp(ts, t, rigid)) + c + rng.normal(0, noise, n)
    return t, rigid, seen, np.full(n, noise)


def test_the_stop_is_found_between_frames_with_an_honest_sigma():
    errs, sigs = [], []
    for seed in range(40):
        ts_true = 0.0124 + 0.00037 * (seed % 7)
        t, rigid, seen, sig = _series(ts=ts_true, seed=seed)
        ts, ts_sig, stop_u, gain, _ = stop_time(t, rigid, seen, sig, 0.02 / FPS)
        errs.append(ts - ts_true)
        sigs.append(ts_sig)
        assert gain > MIN_CHI2_GAIN
        assert stop_u == pytest.approx(np.interp(ts_true, t, rigid) + 3.0, abs=0.5)
    errs, sigs = np.array(errs), np.array(sigs)
    assert np.sqrt(np.mean(errs**2)) < 0.15e-3
    # the profile's sigma neither hides nor swamps the error
    assert 0.5 < np.mean(np.abs(errs) <= sigs) <= 0.95
    assert np.mean(np.abs(errs) <= 2 * sigs) >= 0.9


def test_a_front_end_that_never_stops_gains_nothing():
    t, rigid, _, sig = _series()
    seen = rigid + 2.0 + np.random.default_rng(3).normal(0, 0.3, len(t))
    assert stop_time(t, rigid, seen, sig, 0.02 / FPS) is None  # no window has frames on a stop after it


def test_debris_ahead_of_the_stopped_front_end_does_not_move_the_stop():
    t, rigid, seen, sig = _series(ts=0.0124)
    seen[16:18] -= 9.0  # two frames where something ahead was taken for the front end
    ts = stop_time(t, rigid, seen, sig, 0.02 / FPS)[0]
    assert ts == pytest.approx(0.0124, abs=0.25e-3)


def test_too_few_frames_after_the_stop_say_nothing():
    t, rigid, seen, sig = _series(ts=0.0335, n=36)
    found = stop_time(t[:12], rigid[:12], seen[:12], sig[:12], 0.02 / FPS)
    assert found is None or found[3] < MIN_CHI2_GAIN


def test_a_stop_shown_by_two_frames_among_outliers_is_none():
    """A codec's smeared edge (development film 960032): the front followed with the cell
    up to its last frames, two of which fall 1-2 px behind the rigid path, and lost after
    them. Only two of the four frames after any stop there lie on it: no stop."""
    t, rigid, seen, sig = _series(ts=1.0, n=24, v=1.25, noise=0.3, seed=5)
    seen[19:21] -= [2.4, 1.6]  # 1.6 and 0.9 px behind where the picture's front had stood
    seen[21:] = np.nan
    found = stop_time(t, rigid, seen, sig, 0.02 / FPS)
    assert found is None
    # four frames after it on the stop, two outliers among them, are one; unless an outlier
    # is the frame next to the stop, which places it
    t, rigid, seen, sig = _series(ts=0.0185, n=26, v=1.25, noise=0.3, seed=5)
    seen[[20, 22]] += 1.5
    found = stop_time(t, rigid, seen, sig, 0.02 / FPS)
    assert found is not None and found[0] == pytest.approx(0.0185, abs=0.5e-3)


def test_a_stop_is_not_placed_after_a_frame_that_shows_the_front_stopped():
    """Development film 960011 (500 fps, contact at 28 ms): the most forward rows' front
    against the rigidly carried one. The frame at 30 ms shows the front 5 px ahead of the
    rigid path (it has stopped); the front then scatters by +-5 px (the crushing nose, debris).
    A stop at 30.9 ms fits the scattered frames after it as well, with the 30 ms frame an
    outlier: no stop may be placed after the frame next to it that contradicts it."""
    t = np.arange(2.0, 46.0, 2.0) * 1e-3
    rigid = np.array([219.77, 213.85, 207.89, 201.94, 195.96, 190.02, 184.06, 178.09, 172.14, 166.18, 160.22,
                      154.27, 148.32, 142.35, 136.47, 130.58, 124.68, 118.83, 113.08, 107.54, 101.98, 96.48])
    seen = np.array([np.nan, np.nan, 208.39, 202.89, 197.03, 191.20, 184.86, 178.98, 173.01, 167.02, 161.04,
                     155.20, 149.43, 143.31, 142.27, 139.47, 130.25, 132.00, 133.74, 135.51, 135.38, 131.46])
    sig = np.array([np.nan, np.nan, *[0.3] * 15, 1.18, 0.85, 0.93, 0.47, 0.90])
    found = stop_time(t, rigid, seen, sig, 0.02 / 500.0)
    assert found is None or found[0] < 0.030


def _background(h=60, w=200, seed=0):
    rng = np.random.default_rng(seed)
    tex = rng.uniform(60, 160, (h // 4 + 1, w // 4 + 1))
    return np.kron(tex, np.ones((4, 4)))[:h, :w]


def _with_car(bg, front, grey=110.0, direction=1, debris=None):
    """``bg`` with a car of uniform ``grey`` behind the sub-pixel column ``front``."""
    img = bg.copy()
    u = np.arange(bg.shape[1])
    cover = np.clip(direction * (front - u) + 0.5, 0.0, 1.0)  # pixel coverage
    img = cover * grey + (1 - cover) * img
    if debris is not None:
        u0, rows = debris
        img[rows, u0:u0 + 3] = 250.0
    return img


@pytest.mark.parametrize("direction", [1, -1])
def test_the_front_column_against_a_textured_background(direction):
    bg = _background()
    front = 101.3 if direction == 1 else 98.7
    # debris 10 px ahead of the front end, past the 6 px of background that end the car
    img = _with_car(bg, front, direction=direction, debris=(int(front) + 10 * direction, slice(10, 30)))
    rows = np.arange(5.0, 55.0)
    u_from = front - direction * 30
    u, sig, used, _ = front_column(img, bg, rows, u_from, front + direction * 15, threshold=10.0)
    assert len(used) >= 10  # rows that start on a patch of background as grey as the car are skipped
    # the car's colour is the texture's mean: only the difference from the background shows it
    # (a fixed threshold against a background of varying grey: up to half a pixel)
    assert u == pytest.approx(front, abs=0.5)
    assert sig >= 0.1


def _drawn_film(stop_frame=20.4, v=-2.5, n=50, direction=-1, barrier_from=None, occluder_from=None,
                debris_rows=None, bg=None, debris_from=None):
    """Frames of a car (uniform grey) whose front moves at ``v`` px/frame and stops at the
    fractional frame ``stop_frame``, over a textured background (left of the column
    ``barrier_from``: a barrier as grey as the car; left of ``occluder_from``: a darker
    barrier nearer the camera, in front of the car), with a body pose that keeps moving
    (the passenger cell goes on after contact). ``debris_rows``: from the frame after the
    stop (or from frame ``debris_from``), a dark fragment in those rows joined to the
    front, 4.5 px ahead of it (flung towards the camera, it shows beyond the face). ``bg``:
    the background (default a textured one, 80 x 300)."""
    bg = _background(h=80, w=300, seed=4) if bg is None else bg
    if barrier_from is not None:
        bg[:, :barrier_from] = 115.0
    nose0 = 230.0
    frames, point = [], np.zeros((n, 2))
    for i in range(n):
        rigid = nose0 + v * i
        front = rigid if i < stop_frame else nose0 + v * stop_frame
        img = _with_car(bg, front, grey=115.0, direction=direction)
        if debris_rows is not None and i > stop_frame and (debris_from is None or i >= debris_from):
            fragment = _with_car(bg, front + direction * 4.5, grey=30.0, direction=direction)
            img[debris_rows] = _with_car(fragment, front, grey=115.0, direction=direction)[debris_rows]
        if occluder_from is not None:
            img[:, :occluder_from] = 60.0
        frames.append(np.clip(img, 0, 255).astype(np.uint8))
        point[i] = (rigid + 100.0, 40.0)
    pose = BodyPose(point=point, point_sigma=np.full(n, 0.05), phi=np.zeros(n), phi_sigma=np.full(n, 1e-4),
                    rms_px=np.zeros(n), n_targets=np.full(n, 3), ref_frame=0)
    return frames, pose, np.array([nose0, 40.0])


def _see_drawn(guess_s, **kwargs):
    """``see_contact`` on a :func:`_drawn_film` (its keyword arguments) over the nose's rows
    20-60, the car travelling to the left; ``vanish_u`` goes to ``see_contact``."""
    vanish_u = kwargs.pop("vanish_u", None)
    frames, pose, nose = _drawn_film(**kwargs)
    t = np.arange(len(frames)) / FPS
    return see_contact(frames.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=guess_s, vanish_u=vanish_u)


def test_a_car_seen_stopping_gives_the_contact_between_frames():
    seen = _see_drawn(0.024)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    # a sharp stop: its sigma is the floor, half a frame (SEEN_FLOOR_FRAMES, what the seen
    # contacts of the reference world's films came within), not a whole frame, which let the
    # fit move the contact by 2-3 ms
    assert 0.5e-3 <= seen.sigma_s <= 0.6e-3
    assert "first contact seen" in seen.note


def test_debris_joined_to_the_front_in_a_third_of_the_rows_does_not_move_the_contact():
    # rows 22-35 of 20-60 show a fragment 4.5 px ahead of the stopped front: the rows' most
    # forward share would stop where the fragment stands (frame 22.2); 3 px ahead of the
    # rigid front end in frame 21, where the car cannot be, it is told and the rows'
    # median followed
    seen = _see_drawn(0.024, debris_rows=slice(22, 36), bg=np.full((80, 300), 60.0))
    assert seen.kind == "seen" and "debris, or something else joined to it" in seen.note
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)


def test_debris_joined_to_the_front_in_most_rows_brackets_the_contact():
    # rows 20-51 of 20-60 show the fragment from the frame after the stop (frame 21): their
    # median too stops where the fragment stands, 1.8 frames late; the fragment came with the
    # contact, which lies between the last frame the front moved with the cell (20) and 21
    seen = _see_drawn(0.024, debris_rows=slice(20, 52), bg=np.full((80, 300), 60.0))
    assert seen.kind == "seen" and "the contact lies between the last frame" in seen.note
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    assert abs(seen.time_s - 0.0204) <= seen.sigma_s


def test_debris_joined_to_the_most_forward_rows_short_of_the_cells_nose_does_not_delay_the_stop():
    # the fragment shows from frame 23, 2.6 frames after the stop, when the cell's nose has
    # gone 6.5 px on: 4.5 px ahead of the stopped front it stands where the car can be, and
    # the most forward rows seem to stop where it stands, 1.8 frames late, but the frame
    # next to that stop contradicts it (no clean stop there): the rows' median is followed,
    # which stands behind the tip and stops with it
    seen = _see_drawn(0.024, debris_rows=slice(22, 36), bg=np.full((80, 300), 60.0), debris_from=23)
    assert seen.kind == "seen" and "median front is followed" in seen.note
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)


@pytest.mark.parametrize("median_says", ["no clean stop", "no gain"])
def test_debris_with_no_clean_stop_in_the_median_rows_widens_the_sigma(monkeypatch, median_says):
    # the median rows showing no clean stop, or a "stop" that explains them no better than
    # none (the second search): the most forward rows' stop stands, 1.8 ms late (the
    # fragment 4.5 px ahead at 2.5 px a frame), and its sigma counts the time since the
    # first frame that showed the fragment
    import video.contact_seen as cs

    calls = []

    def median_without_stop(*args):
        calls.append(1)
        if len(calls) == 2:
            return None if median_says == "no clean stop" else (0.030, 1e-4, 150.0, 0.5, 1.0)
        return cs.stop_time.__wrapped__(*args)

    median_without_stop.__wrapped__ = cs.stop_time
    monkeypatch.setattr(cs, "stop_time", median_without_stop)
    seen = _see_drawn(0.024, debris_rows=slice(22, 36), bg=np.full((80, 300), 60.0))
    assert len(calls) == 2 and seen.kind == "seen" and "may be up to" in seen.note
    assert seen.time_s == pytest.approx(0.0222, abs=0.3e-3)
    assert seen.sigma_s >= 0.0016 and abs(seen.time_s - 0.0204) <= 1.5 * seen.sigma_s


def test_a_deceleration_onset_guessed_19_ms_late_still_frames_the_stop():
    # a soft front's deceleration rises late: the front end is followed from 30 ms before
    # the guess, so the stop at frame 20.4 has its frames of moving with the cell before it
    seen = _see_drawn(0.039)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)


def test_an_onset_guessed_past_the_frames_is_not_seen_without_an_error():
    # 50 frames; an onset guessed at 70.5 ms leaves frames 40-49 around it, none of them
    # from 20 ms before the guess on, where the nose is placed
    seen = _see_drawn(0.0705)
    assert seen.kind == "not_seen" and "too few frames" in seen.note


def test_a_nose_placed_outside_the_picture_is_not_seen_and_said_so():
    # a wrong scale or CG puts the nose's rows below the picture: no grey levels to compare
    frames, pose, nose = _drawn_film()
    seen = see_contact(frames.__getitem__, np.arange(len(frames)) / FPS, pose, nose, (200.0, 240.0), -1,
                       guess_s=0.024)
    assert seen.kind == "not_seen" and "falls outside the picture" in seen.note


def test_a_car_as_grey_as_the_background_is_not_seen():
    frames, pose, nose = _drawn_film()
    flat = [np.full_like(f, 110) for f in frames]
    seen = see_contact(flat.__getitem__, np.arange(len(flat)) / FPS, pose, nose, (20.0, 60.0), -1, guess_s=0.024)
    assert seen.kind == "not_seen" and "differs from the background" in seen.note


def test_a_car_as_grey_as_the_background_in_most_of_its_rows_is_seen_in_the_others():
    # rows 20-43 of the nose's 20-60 stand against a background of the car's own grey (a
    # floor or a wall as grey as the body): the front end is told, and seen stopping, in
    # the rows 44-60 where it stands out (the band's median difference is nought)
    bg = _background(h=80, w=300, seed=4)
    bg[:44] = 115.0
    seen = _see_drawn(0.024, bg=bg)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    # in no row: not seen, and said
    bg[:] = 115.0
    seen = _see_drawn(0.024, bg=bg)
    assert seen.kind == "not_seen" and "by more than" in seen.note and "of its" in seen.note


def test_a_blocky_first_frame_does_not_hide_the_stop():
    # a video's first frame, coded before the rate control settles: the background in 8 px
    # blocks each brightened or darkened by up to 30 grey levels, where the frames after it
    # are clean; the background is each pixel's median over the first frames
    frames, pose, nose = _drawn_film()
    blocks = np.random.default_rng(7).uniform(-30.0, 30.0, (80 // 8, 300 // 8 + 1))
    first = frames[0] + np.kron(blocks, np.ones((8, 8)))[:80, :300]
    frames[0] = np.clip(first, 0, 255).astype(np.uint8)
    seen = see_contact(frames.__getitem__, np.arange(len(frames)) / FPS, pose, nose, (20.0, 60.0), -1,
                       guess_s=0.024)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)


def test_a_pose_lost_in_the_backgrounds_frames_is_carried_from_the_approach():
    # a video's first frames, coded before its rate control settles, can lose every target
    # (frames 1-2 of development film 960042): the pose there is the approach's straight
    # line, and the contact is seen as with the pose measured
    frames, pose, nose = _drawn_film()
    point = pose.point.copy()
    point[1:3] = np.nan
    lost = BodyPose(point=point, point_sigma=pose.point_sigma, phi=pose.phi, phi_sigma=pose.phi_sigma,
                    rms_px=pose.rms_px, n_targets=pose.n_targets, ref_frame=0)
    t = np.arange(len(frames)) / FPS
    carried = pose_on_the_approach(lost, t, 1, 0.015)
    assert carried.point[1] == pytest.approx(pose.point[1], abs=1e-6)
    assert np.isnan(carried.point[2, 0]) and np.isnan(lost.point[1, 0])  # the one frame asked, on a copy
    assert 0 < carried.point_sigma[1] < 0.05
    seen = see_contact(frames.__getitem__, t, lost, nose, (20.0, 60.0), -1, guess_s=0.024)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    # no frame of the approach measured before the onset's guess: not seen, and said
    point[:] = np.nan
    point[30:] = pose.point[30:]
    assert pose_on_the_approach(lost, t, 1, 0.015) is None
    seen = see_contact(frames.__getitem__, t, lost, nose, (20.0, 60.0), -1, guess_s=0.024)
    assert seen.kind == "not_seen" and "not measured in frame 1" in seen.note


def test_settling_the_contact_prefers_the_picture_unless_the_motion_disagrees():
    seen = SeenContact("seen", 0.0200, 0.0005, 100.0, 0.2, "first contact seen at 20.00 +- 0.50 ms")
    tc, sig, note = settle_contact(0.0210, seen)
    assert (tc, sig) == (0.0200, 0.0005) and "disagree" not in note
    near = 0.0200 + 2.8 * np.hypot(0.0005, ONSET_SIGMA_S)
    tc, sig, note = settle_contact(near, seen)
    assert (tc, sig) == (0.0200, 0.0005) and "disagree" not in note
    # development film 960042: a stop seen 21 ms before the onset is no measurement of the contact
    late = 0.0200 + 3.2 * np.hypot(0.0005, ONSET_SIGMA_S)
    tc, sig, note = settle_contact(late, seen)
    assert (tc, sig) == (late, None) and "disagree" in note and "no sigma" in note
    tc, sig, note = settle_contact(0.0210, not_seen("too dark"))
    assert (tc, sig) == (0.0210, None) and "onset alone" in note


def test_a_front_end_at_the_pictures_border_is_not_taken_for_the_front():
    bg = _background()
    img = _with_car(bg, 250.0, grey=200.0)  # a car lighter than any background covers it to its right border
    u, _, used, _ = front_column(img, bg, np.arange(5.0, 55.0), 150.0, 215.0, threshold=10.0)
    assert len(used) == 0 and np.isnan(u)


def test_a_stop_without_frames_of_the_front_end_moving_before_it_is_not_seen():
    # the front end can be told from frame 0's background only once it has moved past where
    # it stood there: a stop 6 px on leaves no frame of it moving with the cell
    seen = _see_drawn(0.006, stop_frame=2.4)
    assert seen.kind == "not_seen"


def test_a_stop_soon_after_the_front_end_clears_its_place_in_frame_0_is_seen():
    # a car 1.2 px a frame on a far camera reaches the face 18 frames (21.6 px) after frame
    # 0: the frames from 10 px beyond where it stood in the background's middle frame
    # (frame 1) show the front end moving with the cell
    seen = _see_drawn(0.020, stop_frame=18.0, v=-1.2)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.018, abs=0.3e-3)


def test_a_flickering_lamp_does_not_hide_the_stop():
    frames, pose, nose = _drawn_film()
    gain = 1.0 + 0.15 * np.sin(np.arange(len(frames)) * 2.1)  # the whole picture's brightness
    lit = [np.clip(f * g, 0, 255).astype(np.uint8) for f, g in zip(frames, gain)]
    t = np.arange(len(lit)) / FPS
    seen = see_contact(lit.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)


def test_a_camera_shaken_by_the_impact_is_taken_out_of_the_front_end():
    import cv2

    frames, pose, nose = _drawn_film()
    n = len(frames)
    shake = np.zeros((n, 2))
    after = np.arange(n) >= 19  # the camera starts shaking with the impact
    shake[after] = np.stack([3.0 * np.sin(0.9 * np.arange(n)), 1.5 * np.cos(1.3 * np.arange(n))], axis=1)[after]
    shaken = [cv2.warpAffine(f, np.float32([[1, 0, dx], [0, 1, dy]]), (f.shape[1], f.shape[0]),
                             flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
              for f, (dx, dy) in zip(frames, shake)]
    t = np.arange(n) / FPS
    seen = see_contact(shaken.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024,
                       to_pose=lambda i, uv: np.asarray(uv, float) - shake[i])
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    assert seen.stop_u_px == pytest.approx(230.0 - 2.5 * 20.4, abs=0.5)


def test_a_car_passing_in_front_of_a_barrier_as_grey_as_it_is_not_seen_stopping():
    # the front end vanishes into the barrier's grey at column 175 (frame 22) and goes on
    seen = _see_drawn(0.024, stop_frame=np.inf, barrier_from=175)
    # the car is followed on over the barrier's grey where it differs from it, and lost where
    # it does not: no stop is claimed at the barrier's edge
    assert seen.kind == "not_seen" and "shows no clean stop" in seen.note


def test_the_noise_ahead_of_the_front_is_the_backgrounds_not_the_moving_edges():
    # the wall's blocks over the 10 px searched ahead of the moving front coded again (10
    # grey levels from block to block), the background beyond them as it was (sensor noise 1)
    rng = np.random.default_rng(6)
    bg = _background()
    front = 101.3
    img = _with_car(bg, front) + rng.normal(0.0, 1.0, bg.shape)
    blocks = rng.normal(0.0, 10.0, (bg.shape[0] // 4 + 1, 3))
    img[:, 102:114] += np.kron(blocks, np.ones((4, 4)))[:bg.shape[0], :12]
    rows = np.arange(5.0, 55.0)
    assert noise_ahead(img, bg, front, rows, 1, 10.0, np.zeros(2)) == pytest.approx(1.0, abs=0.25)
    # the picture's left to right: the same, mirrored
    assert noise_ahead(img[:, ::-1], bg[:, ::-1], bg.shape[1] - 1 - front, rows, -1, 10.0,
                       np.zeros(2)) == pytest.approx(1.0, abs=0.25)


@pytest.mark.parametrize("vanish_u", [None, 60.0, 200.0])
def test_a_car_going_behind_a_barrier_nearer_the_camera_is_not_seen_stopping(vanish_u):
    # the barrier's edge (column 175) hides the front end from frame 22 on: in the picture
    # it stops there, though it never touched anything. A nearer edge can show short of the
    # face only where the face stands short of the column the depth direction vanishes to
    # (the car travels to the left: a column left of 175, or within the margin of it)
    seen = _see_drawn(0.024, stop_frame=np.inf, occluder_from=175, vanish_u=vanish_u)
    assert seen.kind == "not_seen" and "cannot be told from going behind it" in seen.note


def test_a_stop_at_an_edge_beyond_the_column_the_depth_direction_vanishes_to_is_the_contact():
    # the same picture with the depth direction vanishing well to the right of the edge
    # (the camera square to the car's plane at column 260 of 300): a nearer barrier's edge
    # would show beyond the face there, so the front end standing at the edge is the face
    # in the car's plane, reached at frame (230 - 175) / 2.5 = 22
    seen = _see_drawn(0.024, stop_frame=np.inf, occluder_from=175, vanish_u=260.0)
    assert seen.kind == "seen" and "at an edge of frame 0" in seen.note
    assert seen.time_s == pytest.approx(0.022, abs=0.3e-3)


@pytest.mark.parametrize("off", [12.0, -6.0])
def test_a_vehicle_outline_whose_nose_stands_off_the_pictures_is_set_right_by_the_picture(off):
    # the outline's nose 12 px behind (or 6 px ahead of) the car's front in the picture: the
    # front end is looked for around the picture's front, and the note says how far off
    frames, pose, nose = _drawn_film()
    t = np.arange(len(frames)) / FPS
    seen = see_contact(frames.__getitem__, t, pose, nose + np.array([off, 0.0]), (20.0, 60.0), -1, guess_s=0.024)
    assert seen.kind == "seen"
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    stood = re.search(r"front stood ([\d.]+) px (ahead of|behind) the vehicle outline's nose", seen.note)
    assert stood and stood.group(2) == ("ahead of" if off > 0 else "behind")
    # it centres a search 10 px either side: a pixel is plenty (the textured background's
    # fixed-threshold bias is up to half a pixel at each of the two fronts it compares)
    assert float(stood.group(1)) == pytest.approx(abs(off), abs=1.0)


def test_points_are_taken_back_to_the_raw_picture_through_a_strong_lens():
    # barrel distortion that moves a point near the corner of a 1024 x 820 picture by about
    # 20 px (as on a reference-world film): the inverse must land within 0.05 px
    centre, k1, r0 = np.array([512.0, 410.0]), 0.08, 656.0

    def to_pose(i, uv):
        q = (np.asarray(uv, float) - centre) / r0
        return centre + r0 * q * (1 + k1 * np.sum(q**2, axis=-1, keepdims=True))

    p = np.array([[960.0, 470.0], [100.0, 60.0], [512.0, 410.0]])
    raw = raw_points(to_pose, 0, p)
    assert np.max(np.abs(to_pose(0, raw) - p)) < 0.05
    assert np.max(np.abs(raw - p)) > 15.0  # the lens does move them


def test_the_front_end_detector_finds_the_front_or_nothing():
    from video.contact_seen import FrontEndDetector
    bg = _background()
    rows = np.arange(5.0, 55.0)
    img = _with_car(bg, 101.3)
    found = FrontEndDetector(bg, rows, 71.3, 116.3, 10.0).detect(img)
    assert found.kind == "front end" and len(found) == 1
    assert found.centres[0] == pytest.approx([found.found[0], 29.5])
    assert found.centres[0, 0] == pytest.approx(101.3, abs=0.5)
    assert 0.2 <= found.quality[0] <= 1.0
    assert len(FrontEndDetector(bg, rows, 71.3, 116.3, 10.0).detect(bg)) == 0   # no car


def test_the_outline_lag_is_the_distance_behind_the_tip_at_each_height():
    # a box 4 m long with a nose: tip at (4.0, 0.5), sloping back to 3.9 m at 0.3 and 0.8 m
    outline = np.array([[0.0, 0.2], [3.9, 0.2], [3.9, 0.3], [4.0, 0.5], [3.9, 0.8], [0.0, 1.0]])
    lag = outline_lag_m(outline, np.array([0.5, 0.4, 0.65, 0.25, 1.2]))
    np.testing.assert_allclose(lag[:4], [0.0, 0.05, 0.05, 0.1], atol=1e-12)
    assert np.isnan(lag[4])  # above the outline


def test_the_stop_of_rows_behind_the_tip_is_taken_back_to_the_tip():
    t = np.arange(30) / FPS
    rigid = 400.0 - 2.5 * FPS * t  # moving left at 2.5 px a frame
    # rows 1.5 px behind the tip stop 0.6 frame after the tip touched
    assert back_to_the_tip(t, rigid, -1, 0.0126, 1.5) == pytest.approx(0.0120, abs=1e-9)
    assert back_to_the_tip(t, -rigid, 1, 0.0126, 1.5) == pytest.approx(0.0120, abs=1e-9)
    assert back_to_the_tip(t, rigid, -1, 0.0126, 0.0) == pytest.approx(0.0126, abs=1e-9)


def test_rows_standing_behind_the_tip_give_the_tips_contact():
    # the rows the picture shows stand 2 px behind the outline's tip (a rounded nose, or a
    # lower bumper as grey as the floor): they stop 0.8 frame after the tip touched
    frames, pose, nose = _drawn_film(stop_frame=20.4 + 2.0 / 2.5)
    t = np.arange(len(frames)) / FPS
    late = see_contact(frames.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024)
    seen = see_contact(frames.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024,
                       row_lag_px=lambda v: np.full(np.shape(v), 2.0))
    assert late.time_s == pytest.approx(0.0212, abs=0.3e-3)
    assert seen.time_s == pytest.approx(0.0204, abs=0.3e-3)
    assert "stand 2.0 px behind the outline's tip" in seen.note
    # the correction's own uncertainty widens the sigma
    assert seen.sigma_s > late.sigma_s
    # the front stands for the rows' most forward share: the least lags of the rows seen
    spread = see_contact(frames.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024,
                         row_lag_px=lambda v: 1.0 + 2.0 * (np.asarray(v) - 20.0) / 40.0)
    # (lags from 1 to 3 px down the rows: the fifth of the rows seen standing furthest
    # forward, not the fifth furthest back at 2.6 px; rows whose background is as grey as
    # the car are not seen)
    stood = float(re.search(r"stand ([\d.]+) px behind the outline's tip", spread.note).group(1))
    assert 1.0 <= stood <= 1.6


def _car_over(bg, front, car=150.0):
    """``bg`` with a car of grey ``car`` left of the sub-pixel column ``front`` (travelling right)."""
    u = np.arange(bg.shape[1])
    cover = np.clip(front - u + 0.5, 0.0, 1.0)
    return cover * car + (1 - cover) * bg


def test_the_front_is_followed_over_background_of_another_grey():
    # a dark wall, then from column 100 on a barrier only 15 grey levels darker than the car:
    # half the car's difference from the wall (45) would end the car at the barrier's edge
    bg = np.full((40, 200), 60.0)
    bg[:, 100:] = 135.0
    img = _car_over(bg, 112.3)
    rows = np.arange(5.0, 35.0)
    u, _, used, _ = front_column(img, bg, rows, 40.0, 140.0, threshold=45.0, min_contrast=9.0)
    assert len(used) == len(rows) and u == pytest.approx(112.3, abs=0.1)
    u_fixed, _, _, _ = front_column(img, bg, rows, 40.0, 140.0, threshold=45.0)
    assert u_fixed == pytest.approx(100.0, abs=0.6)  # the fixed threshold stops at the edge


def test_debris_a_few_pixels_ahead_is_not_joined_to_the_front():
    bg = _background(h=40, w=200, seed=2) * 0.3 + 40.0  # a dark textured wall (58-88)
    img = _car_over(bg, 101.3)
    img[:, 105:109] = 250.0  # bright debris 4 px ahead of the front, in every row
    rows = np.arange(5.0, 35.0)
    u, _, _, _ = front_column(img, bg, rows, 40.0, 130.0, threshold=40.0, min_contrast=9.0)
    assert u == pytest.approx(101.3, abs=0.1)
    u_gap, _, _, _ = front_column(img, bg, rows, 40.0, 130.0, threshold=40.0)
    assert u_gap > 107.0  # six pixels of background are needed to end the run without it


def test_the_front_is_where_the_car_covers_half_a_pixel_whatever_the_texture():
    # the car (200) differs from the texture (60-160) by 40 to 140 grey levels: a fixed
    # threshold of 45 would put the edge where the car covers 0.3 to 1.1 of a pixel (up to
    # half a pixel off); the cover's 0.5 crossing is within the 0.5 px samples' resolution
    errs = []
    for seed in range(6):
        bg = _background(h=60, w=200, seed=seed)
        for front in (100.2, 100.5, 100.8):
            img = _car_over(bg, front, car=200.0)
            for minc in (None, 6.0):
                u, _, _, _ = front_column(img, bg, np.arange(5.0, 55.0), 40.0, 130.0, threshold=45.0, min_contrast=minc)
                errs.append(u - front)
    assert np.max(np.abs(errs)) < 0.1


def test_a_tip_crossing_before_the_frames_followed_is_not_made_up():
    t = np.arange(10) / FPS
    rigid = 400.0 - 2.5 * FPS * t
    # 30 px behind the tip: the crossing lies 12 frames back, before the first frame
    assert back_to_the_tip(t, rigid, -1, 0.0050, 30.0) == pytest.approx(0.0050)


def test_a_film_whose_cg_is_not_located_says_its_contact_was_not_looked_for_in_the_picture():
    """The nose is placed from the CG; a film with no hub targets and no fitted outline has
    none (reference world 960493), so the contact comes from the deceleration onset alone,
    without a sigma, and the notes say why the picture was not asked (it had been silent)."""
    from video.follow import TrackerConfig
    from video.track import _contact, _Pose

    t = np.arange(60) / FPS
    tc_true, v, jerk = 0.0304, 15.6, 2e4  # s, m/s, m/s^3 (a force growing from zero, 300 m/s^2 after 15 ms)
    x = v * t - jerk / 6.0 * np.clip(t - tc_true, 0.0, None) ** 3 + np.random.default_rng(3).normal(0, 2e-4, len(t))
    sig = np.full(len(t), 2e-4)
    pose = _Pose(pose=None, XZ=np.column_stack([x, np.zeros_like(x)]), axes=np.eye(2), pitch=np.zeros_like(x),
                 pos_sig=sig, frame_t=t, onset_guess_s=0.03)
    notes = []
    tc, tc_sigma, cf, _ = _contact(None, pose, [], np.zeros(2), None, None, 1e-3, 1, None, None, FPS, len(t),
                                   TrackerConfig(), notes)
    assert tc_sigma is None and tc == pytest.approx(tc_true, abs=1e-3) and abs(cf - tc_true * FPS) < 1.0
    said = [n for n in notes if n.startswith("first contact not seen in the picture: not looked for")]
    assert len(said) == 1 and "the CG is not located" in said[0] and "deceleration onset alone" in said[0], notes


def test_the_last_frame_that_shows_the_front_moving_is_neither_unseen_nor_at_the_stop():
    from video.contact_seen import MAX_UNSEEN_FRAMES, _last_seen_moving

    t = np.arange(30) / FPS
    rigid = 500.0 + 2.0 * np.arange(30)
    seen = rigid + 0.5
    # moving with the cell up to frame 10, unseen 11-16, then at the stop column from 17 on
    seen[11:17] = np.nan
    stop_u = rigid[15] + 0.5
    seen[17:] = stop_u
    sig = np.full(30, 0.3)
    assert _last_seen_moving(t, rigid, seen, sig, t[15], stop_u) == pytest.approx(t[10])
    assert (t[15] - t[10]) * FPS > MAX_UNSEEN_FRAMES
    # frames already standing at the stop column do not show it moving (a barrier's edge)
    edge = np.where(np.arange(30) >= 5, stop_u, np.nan)
    assert _last_seen_moving(t, rigid, edge, sig, t[15], stop_u) is None


def test_a_single_frame_ahead_of_the_car_is_noise_two_in_a_row_are_something_joined():
    from video.contact_seen import _first_ahead

    t, rigid, seen, _ = _series(ts=0.0204, v=2.3, noise=0.0, n=36)
    sig = np.full(len(t), 0.3)
    shaken = seen.copy()
    shaken[9] += 2.5  # one frame a camera shaken by a few px puts 2.5 px ahead
    assert _first_ahead(t, rigid, shaken, sig, 1, np.inf) is None
    joined = shaken.copy()
    joined[22:24] += 10.0  # debris flung from the face shows ahead in frames 22 and 23
    assert _first_ahead(t, rigid, joined, sig, 1, np.inf) == pytest.approx(t[22])
    assert _first_ahead(t, rigid, joined, sig, 1, t[22]) is None  # only frames before the stop count


def test_a_front_standing_behind_the_rigid_path_is_told_from_one_going_on_with_the_cell():
    from video.contact_seen import stands_behind

    t, rigid, seen, sig = _series(ts=0.0204, v=2.3, noise=0.2, n=36)
    assert stands_behind(t, rigid, seen, sig, 1, t[21])
    assert not stands_behind(t, rigid, seen, sig, 1, t[10])  # before the stop: on the path
    assert not stands_behind(t, rigid, rigid + 3.0, sig, 1, t[21])


def test_a_contact_hidden_by_debris_is_bracketed_by_the_frames_before_it():
    from video.contact_seen import joined_bracket

    # the rows stand 1.5 px behind the tip: the tip touches at 20.0 ms, the rows at 20.65 ms
    # (2.3 px a frame); debris shows ahead from frame 22 on and hides where they stopped
    t, rigid, seen, _ = _series(ts=0.0200 + 1.5 / 2.3e3, v=2.3, noise=0.0, n=36)
    sig = np.full(len(t), 0.3)
    seen[22:] = np.nan
    t_lo, t_hi, u_last = joined_bracket(t, rigid, seen, sig, 1, t[22], lag_px=1.5)
    assert u_last == pytest.approx(seen[21])
    # the rows were last seen at the stop column (frame 21): they reached it no earlier
    # than the rigid path did, less three sigmas; the tip no later than frame 22
    assert t_lo == pytest.approx(0.0200 + (1.5 - 0.9) / 2.3e3, abs=1e-6)
    assert t_hi == pytest.approx(0.0220 + 1.5 / 2.3e3, abs=1e-6)
    assert t_lo <= 0.0200 + 1.5 / 2.3e3 <= t_hi
    # the front last seen more than MAX_UNSEEN_FRAMES before the debris: no bracket
    seen[17:22] = np.nan
    assert joined_bracket(t, rigid, seen, sig, 1, t[22], lag_px=1.5) is None


@pytest.mark.parametrize("stops", ["median rows", "neither"])
def test_debris_ahead_of_the_car_before_the_median_rows_stop_brackets_the_contact(monkeypatch, stops):
    # the fragment stands 8 px ahead of the stopped front in every row from frame 21: in
    # frames 21 and 22 ahead of where the car can be, then both series stop where it
    # stands (frame 23.6). With the most forward rows showing no clean stop, the rows'
    # median is followed: its stop is the fragment's, 3.2 ms late; the frames before the
    # fragment bracket the contact (frame 20 moving, the fragment by frame 21). With no
    # clean stop in either, the front standing behind the rigid path after the fragment
    # showed brackets it the same way
    import video.contact_seen as cs

    calls = []

    def forward_rows_without_stop(*args):
        calls.append(1)
        return None if len(calls) == 1 or stops == "neither" else cs.stop_time.__wrapped__(*args)

    forward_rows_without_stop.__wrapped__ = cs.stop_time
    monkeypatch.setattr(cs, "stop_time", forward_rows_without_stop)
    frames, pose, nose = _drawn_film(debris_rows=slice(0, 80), bg=np.full((80, 300), 60.0))
    for i in range(21, len(frames)):  # the fragment 8 px ahead instead of 4.5
        img = _with_car(np.full((80, 300), 60.0), 179.0 - 8.0, grey=30.0, direction=-1)
        frames[i] = np.clip(_with_car(img, 179.0, grey=115.0, direction=-1), 0, 255).astype(np.uint8)
    t = np.arange(len(frames)) / FPS
    seen = see_contact(frames.__getitem__, t, pose, nose, (20.0, 60.0), -1, guess_s=0.024)
    assert len(calls) == 2 and seen.kind == "seen" and "the middle of a bracket" in seen.note, seen.note
    assert abs(seen.time_s - 0.0204) <= seen.sigma_s
    assert seen.sigma_s <= 1.0e-3
