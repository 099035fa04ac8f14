"""Tests of video.calibrate: tape scale, lens distortion, silhouette fit and scale check."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from video.calibrate import (LensDistortion, compare_scales, distort_points, estimate_lens,
                             find_tapes, fit_silhouette, measure_scale, undistort_points)
from video.errors import NoTapeError, VideoError

SS = 4  # supersampling of the synthetic drawings


def _canvas(h, w, clutter, seed=0, bg=128):
    big = np.full((h * SS, w * SS), bg, np.uint8)
    if clutter:
        rng = np.random.default_rng(seed)
        for _ in range(30):
            c = tuple(int(x) for x in rng.uniform(0, [w * SS, h * SS]))
            cv2.circle(big, c, int(rng.uniform(5, 30) * SS), int(rng.uniform(0, 255)), -1)
        for _ in range(15):
            p = tuple(int(x) for x in rng.uniform(0, [w * SS, h * SS]))
            q = tuple(int(x) for x in rng.uniform(0, [w * SS, h * SS]))
            cv2.line(big, p, q, int(rng.uniform(0, 255)), int(rng.uniform(1, 4) * SS))
    return big


def _fill(big, poly_px, value):
    pb = (np.asarray(poly_px) + 0.5) * SS - 0.5
    cv2.fillPoly(big, [np.round(pb * 16).astype(np.int32)], value, cv2.LINE_AA, 4)


def _tape(big, centre, angle_deg, seg_px, width_px, n_seg, bg=128):
    """A tape of ``n_seg`` segments centred at ``centre`` on a plain strip of body."""
    a = np.deg2rad(angle_deg)
    ax = np.array([np.cos(a), np.sin(a)])
    nm = np.array([-ax[1], ax[0]])
    st = np.asarray(centre, float) - 0.5 * n_seg * seg_px * ax
    half, L = 1.5 * width_px, n_seg * seg_px
    _fill(big, [st - half * nm - width_px * ax, st + (L + width_px) * ax - half * nm,
                st + (L + width_px) * ax + half * nm, st + half * nm - width_px * ax], bg)
    for k in range(n_seg):
        p0, p1 = st + k * seg_px * ax, st + (k + 1) * seg_px * ax
        _fill(big, [p0 - nm * width_px / 2, p1 - nm * width_px / 2, p1 + nm * width_px / 2,
                    p0 + nm * width_px / 2], 30 if k % 2 == 0 else 220)


def _finish(big, blur=0.7, noise=2.0, seed=0):
    h, w = big.shape[0] // SS, big.shape[1] // SS
    img = cv2.resize(big.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    if blur:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    img = img + np.random.default_rng(seed).normal(0, noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("size,angle,seg_px,width_px", [
    ((480, 640), 0.0, 12.5, 10.0),     # 50 mm segments at 4 mm/px
    ((480, 640), 17.0, 6.3, 6.0),      # small: 50 mm at 8 mm/px
    ((480, 640), -73.0, 25.0, 12.0),   # steep, any direction
    ((1024, 1280), 135.0, 40.0, 20.0),  # 100 mm at 2.5 mm/px, reversed direction
])
def test_scale_from_synthetic_tape_within_0p3_percent(size, angle, seg_px, width_px):
    h, w = size
    big = _canvas(h, w, clutter=True, seed=3)
    n_seg = int(0.6 * min(h, w) / seg_px) if abs(np.sin(np.deg2rad(angle))) > 0.3 else int(0.6 * w / seg_px)
    _tape(big, (w / 2 + 0.3, h / 2 + 0.7), angle, seg_px, width_px, n_seg)
    img = _finish(big)
    seg_m = 0.05
    est = measure_scale(img, seg_m)
    truth = seg_m / seg_px
    err = est.m_per_px / truth - 1
    assert abs(err) < 0.003
    # the reported uncertainty is honest: error within 4 sigma (+ a 0.05 % floor)
    assert abs(est.m_per_px - truth) < 4 * est.sigma + 5e-4 * truth
    tape = est.tapes[0]
    assert abs(abs(tape.axis @ [np.cos(np.deg2rad(angle)), np.sin(np.deg2rad(angle))]) - 1) < 1e-3
    assert tape.edge_points.shape[1] == 2 and len(tape.edge_points) >= 8


def test_two_tapes_in_bgr_frame_are_both_found_and_combined():
    h, w = 480, 640
    big = _canvas(h, w, clutter=False)
    _tape(big, (320.2, 150.6), 2.0, 12.5, 8.0, 30)
    _tape(big, (300.7, 330.1), 2.0, 12.5, 8.0, 20)
    img = cv2.cvtColor(_finish(big), cv2.COLOR_GRAY2BGR)
    est = measure_scale(img, 0.1)
    assert len(est.tapes) == 2
    assert abs(est.pitch_px / 12.5 - 1) < 0.003
    # the combined pitch is more precise than either tape alone (their own noise: the
    # camera map's uncertainty, which moves both together, left out)
    alone = measure_scale(img, 0.1, correct_lens=False, correct_yaw=False)
    assert alone.pitch_sigma_px <= min(t.pitch_sigma_px for t in alone.tapes) * 1.01
    # and that uncertainty is counted when the map is estimated
    assert est.pitch_sigma_px > alone.pitch_sigma_px


def test_tape_split_by_a_target_is_measured_as_one():
    big = _canvas(480, 640, clutter=True, seed=3)
    _tape(big, (320.3, 240.7), 4.0, 12.5, 10.0, 36)
    cv2.circle(big, (320 * SS, 240 * SS), 16 * SS, 0, -1)  # a dark disc over 3 segments
    tapes = find_tapes(_finish(big))
    assert len(tapes) == 1
    t = tapes[0]
    assert np.ptp(t.edge_index) >= 33 and len(t.edge_s) < np.ptp(t.edge_index) + 1
    assert abs(t.pitch_px / 12.5 - 1) < 0.001


def test_two_row_checker_tape():
    big = _canvas(480, 640, clutter=False)
    for k in range(30):
        for row in (0, 1):
            p0 = np.array([130.3 + k * 12.5, 230.2 + row * 10.0])
            _fill(big, [p0, p0 + [12.5, 0], p0 + [12.5, 10], p0 + [0, 10]],
                  30 if (k + row) % 2 == 0 else 220)
    est = measure_scale(_finish(big), 0.05)
    assert abs(est.pitch_px / 12.5 - 1) < 0.003


def test_no_tape_is_one_clear_error():
    img = _finish(_canvas(480, 640, clutter=True, seed=5))
    with pytest.raises(VideoError, match=r"^no reference tape found in frame 7: .*scale") as e:
        measure_scale(img, 0.1, frame_index=7)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), 50.0])
def test_impossible_segment_length_raises(bad):
    img = _finish(_canvas(48, 64, clutter=False))
    with pytest.raises(VideoError, match="segment"):
        measure_scale(img, bad)


def _lens(k1, w, h, f):
    return LensDistortion(k1, 0.0, 0.0, 0.0, np.array([(w - 1) / 2, (h - 1) / 2]), f, True,
                          0.0, 0.0, "")


def _distort_image(img, lens):
    h, w = img.shape
    uu, vv = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    src = undistort_points(np.stack([uu, vv], -1).reshape(-1, 2), lens).reshape(h, w, 2)
    src = src.astype(np.float32)
    return cv2.remap(img, src[..., 0], src[..., 1], cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)


def test_undistort_inverts_distort():
    lens = _lens(-0.12, 1280, 1024, 1500.0)
    pts = np.random.default_rng(1).uniform([0, 0], [1280, 1024], (50, 2))
    back = undistort_points(distort_points(pts, lens), lens)
    assert np.max(np.abs(back - pts)) < 1e-6
    assert np.max(np.abs(distort_points(pts, lens) - pts)) > 5.0  # it does distort


def test_undistort_inverts_distort_with_a_tilt():
    from dataclasses import replace
    lens = replace(_lens(-0.12, 1280, 1024, 1500.0), tilt=np.array([3e-5, -1e-5]))
    pts = np.random.default_rng(2).uniform([0, 0], [1280, 1024], (50, 2))
    back = undistort_points(distort_points(pts, lens), lens)
    assert np.max(np.abs(back - pts)) < 1e-6
    flat = replace(lens, k1=0.0)   # the tilt alone
    assert np.max(np.abs(undistort_points(distort_points(pts, flat), flat) - pts)) < 1e-9
    assert np.max(np.abs(undistort_points(pts, flat) - pts)) > 5.0


def _receding_tape(tilt_true, n=41, pitch=12.0, u0=-250.0, noise=0.05, seed=0):
    """Edges of an evenly segmented tape seen through the inverse of ``rectify``: the
    points a camera yawed by ``tilt_true`` (1/px, along u) records, with edge noise."""
    from video.calibrate_perspective import unrectify
    rng = np.random.default_rng(seed)
    i = np.arange(n)
    even = np.column_stack([u0 + pitch * i, np.full(n, 40.0)])
    seen = unrectify(even, np.zeros(2), np.array([tilt_true, 0.0]))
    return seen + rng.normal(0.0, noise, seen.shape), i


def test_camera_yaw_from_the_tapes_uneven_segments():
    from video.calibrate_perspective import estimate_tilt
    tilt_true = 3e-5            # 3 degrees at f = 1750 px
    pulls = []
    for seed in range(20):
        pts, i = _receding_tape(tilt_true, seed=seed)
        yaw = estimate_tilt([(pts, i)], np.zeros(2))
        assert yaw.tilt[0] == pytest.approx(yaw.along, rel=1e-3) and "taken out" in yaw.note
        pulls.append((yaw.along - tilt_true) / yaw.sigma)
    # the sigma is honest: pulls of unit scatter about zero
    assert abs(np.mean(pulls)) < 0.6 and 0.5 < np.std(pulls) < 1.6


def test_an_evenly_spaced_tape_shows_no_yaw():
    from video.calibrate_perspective import estimate_tilt
    found = 0
    for seed in range(20):
        pts, i = _receding_tape(0.0, seed=seed)
        yaw = estimate_tilt([(pts, i)], np.zeros(2))
        found += bool(np.any(yaw.tilt != 0.0))
        assert np.any(yaw.tilt != 0.0) or "not significant" in yaw.note
    assert found <= 1              # 3 sigma: about 1 in 370 by chance


def test_uneven_spacing_beyond_any_yaw_is_not_taken_for_one():
    from video.calibrate_perspective import estimate_tilt, unrectify
    centre = np.array([399.5, 299.5])             # an 800 x 600 picture
    i = np.arange(31)
    even = np.column_stack([250.0 + 12.0 * i, np.full(31, 340.0)])
    for tilt_true, taken in ((5e-5, True), (5e-4, False)):   # 2.5 % and 25 % at the corner
        seen = unrectify(even, centre, np.array([tilt_true, 0.0]))
        yaw = estimate_tilt([(seen, i)], centre)
        assert bool(np.any(yaw.tilt != 0.0)) is taken
        assert yaw.along == pytest.approx(tilt_true, rel=0.02)
    assert "more than a yawed camera shows" in yaw.note and not np.isfinite(yaw.sigma)


def test_a_k1_beyond_any_crash_cameras_lens_is_not_applied():
    # lines bent as a lens of k1 = -0.4 at the half-diagonal would (40 % at the corners):
    # tapes that say so do not show the lens
    w, h = 800, 600
    lens = LensDistortion(-0.4, 0.0, 0.0, 0.0, np.array([(w - 1) / 2, (h - 1) / 2]), 500.0, True, 0.0, 0.0, "")
    u = np.linspace(150, 650, 40)
    lines = [distort_points(np.column_stack([u, np.full(40, v)]), lens) for v in (120.0, 480.0)]
    est = estimate_lens(lines, (w, h))
    assert not est.corrected and est.k1 == 0.0
    assert "more than 10 %" in est.note
    mild = LensDistortion(-0.05, 0.0, 0.0, 0.0, lens.centre, 500.0, True, 0.0, 0.0, "")
    est = estimate_lens([distort_points(np.column_stack([u, np.full(40, v)]), mild) for v in (120.0, 480.0)], (w, h))
    assert est.corrected and est.k1 == pytest.approx(-0.05, abs=0.005)


def test_lens_distortion_estimated_from_tape_straightness():
    w, h, f, k1 = 1024, 768, 1000.0, -0.08
    big = _canvas(h, w, clutter=False)
    _tape(big, (512.3, 600.4), 0.3, 20.0, 12.0, 40)
    _tape(big, (500.1, 150.2), 0.3, 20.0, 12.0, 30)
    img = _distort_image(_finish(big), _lens(k1, w, h, f))
    est = measure_scale(img, 0.1, focal_px=f)
    assert est.lens.corrected
    assert abs(est.lens.k1 - k1) < max(3 * est.lens.k1_sigma, 0.01)
    assert est.lens.rms_after_px < 0.5 * est.lens.rms_before_px
    # the scale is measured on undistorted points: 20 px per segment again
    assert abs(est.pitch_px / 20.0 - 1) < 0.003
    uncorrected = measure_scale(img, 0.1, focal_px=f, correct_lens=False)
    assert abs(uncorrected.pitch_px / 20.0 - 1) > abs(est.pitch_px / 20.0 - 1)


def test_tape_through_the_centre_says_distortion_not_corrected():
    w, h = 640, 480
    big = _canvas(h, w, clutter=False)
    _tape(big, (319.5, 239.5), 0.0, 12.5, 8.0, 36)
    est = measure_scale(_finish(big), 0.05)
    assert not est.lens.corrected
    assert any("not corrected" in n for n in est.notes)
    pts = np.array([[3.0, 4.0], [600.0, 470.0]])
    assert np.array_equal(undistort_points(pts, est.lens), pts)  # nothing is applied


def test_estimate_lens_without_points_says_not_corrected():
    lens = estimate_lens([np.zeros((2, 2))], (640, 480))
    assert not lens.corrected and "not corrected" in lens.note
    pts = np.array([[10.0, 20.0], [300.0, 400.0]])
    assert np.array_equal(undistort_points(pts, lens), pts)


# ---------------------------------------------------------------- rendered frames

def _render(direction=1, seg=0.1, size=(640, 480), k1=0.0, noise=2.0, car_name="audi_a4"):
    from identify.recordings.synthetic import car_geometry, load_vehicle_dict
    from synth.render import Renderer
    from synth.scene import (Effects, Motion, Scene, default_camera, default_tapes,
                             default_targets)
    car = car_geometry(load_vehicle_dict(car_name))
    cam = default_camera(car, 0.0, width=size[0], height=size[1], k1=k1)
    z = np.zeros(1)
    motion = Motion(t=np.array([-0.01]), x=np.array([-0.15]), z=z, pitch=z,
                    front_wheel_angle=z, rear_wheel_angle=z)
    scene = Scene(car=car, camera=cam, targets=default_targets(car),
                  tapes=default_tapes(car, seg), x_barrier=0.0, direction=direction,
                  effects=Effects(noise_sigma=noise))
    r = Renderer(scene, motion)
    return r.render(0), car, cam, r


@pytest.mark.parametrize("direction,seg,size", [(1, 0.1, (640, 480)), (-1, 0.05, (640, 480)),
                                                (1, 0.05, (1280, 1024))])
def test_scale_on_rendered_frame_within_0p3_percent(direction, seg, size):
    img, car, cam, _ = _render(direction, seg, size)
    est = measure_scale(img, seg)
    assert abs(est.m_per_px / cam.m_per_px - 1) < 0.003
    # sill and belt line; at 5 x 3 px segments (50 mm at 9 mm/px) the shorter may be missed
    assert len(est.tapes) >= (1 if seg / cam.m_per_px < 6 else 2)


@pytest.mark.parametrize("k1", [-0.05, 0.08])
def test_scale_and_lens_on_rendered_frame_with_distortion(k1):
    img, car, cam, _ = _render(1, 0.1, (1024, 768), k1=k1)
    est = measure_scale(img, 0.1, focal_px=cam.focal_px)
    assert abs(est.m_per_px / cam.m_per_px - 1) < 0.003  # measured 0.02 %
    assert est.lens.corrected
    assert abs(est.lens.k1 - k1) < 3 * est.lens.k1_sigma + 0.005


@pytest.mark.parametrize("yaw_deg", [2.5, -2.5])
def test_scale_on_a_rendered_frame_from_a_yawed_camera(yaw_deg):
    import math
    from dataclasses import replace
    from synth.render import Renderer
    _, car, cam, r = _render(1, 0.1, (1280, 1024), noise=1.0)
    cam = replace(cam, yaw=math.radians(yaw_deg))
    r = Renderer(replace(r.scene, camera=cam), r.motion)
    est = measure_scale(r.render(0), 0.1, focal_px=cam.focal_px)
    # the tape's segments shrink along it; taken out, its scale is the one on the
    # camera's axis (a tilt about the image centre keeps the scale there)
    assert est.lens.corrected and abs(est.lens.tilt[0]) == pytest.approx(
        math.tan(math.radians(abs(yaw_deg))) / cam.focal_px, rel=0.15)
    assert abs(est.m_per_px / cam.m_per_px - 1) < 0.003


@pytest.mark.parametrize("direction", [1, -1])
def test_silhouette_fit_on_rendered_frame(direction):
    from synth.scene import body_to_plane, project
    img, car, cam, r = _render(direction, 0.1, (640, 480))
    sil = fit_silhouette(img, car)  # no scale hint: searched over a wide range
    assert sil.direction == direction
    assert abs(sil.m_per_px / cam.m_per_px - 1) < 0.002  # measured 0.04 %
    ws = project(cam, body_to_plane(np.array([car.windscreen_top]), car, r.pose(0.0), r.x_cg0),
                 cam.distance_car, direction)[0]
    assert np.linalg.norm(sil.windscreen_top_px - ws) < 0.3  # measured 0.06 px
    assert sil.matched_fraction > 0.7 and sil.rms_px < 0.5
    est = measure_scale(img, 0.1)
    cmp = compare_scales(est.m_per_px, est.sigma, sil)
    assert cmp.agree, cmp.note


def test_scale_disagreement_is_reported():
    img, car, cam, _ = _render(1, 0.1, (640, 480))
    sil = fit_silhouette(img, car, scale_hint=cam.m_per_px)
    wrong = cam.m_per_px * 1.05  # a tape in another plane: 5 % off
    cmp = compare_scales(wrong, 1e-3 * wrong, sil)
    assert not cmp.agree
    assert "disagree" in cmp.note and "parallax" in cmp.note


def test_outline_of_another_car_is_reported():
    from identify.recordings.synthetic import car_geometry, load_vehicle_dict
    img, car, cam, _ = _render(1, 0.1, (640, 480))
    golf = car_geometry(load_vehicle_dict("vw_golf_7"))  # the film shows an Audi A4
    est = measure_scale(img, 0.1)
    cmp = compare_scales(est.m_per_px, est.sigma, fit_silhouette(img, golf,
                                                                 scale_hint=est.m_per_px))
    assert not cmp.agree and "outline differs" in cmp.note


def test_silhouette_not_found_raises():
    from identify.recordings.synthetic import car_geometry, load_vehicle_dict
    car = car_geometry(load_vehicle_dict("audi_a4"))
    img = np.full((480, 640), 100, np.uint8)
    with pytest.raises(VideoError, match="outline"):
        fit_silhouette(img, car)


def test_find_tapes_ignores_plain_frame():
    assert find_tapes(np.full((120, 160), 90, np.uint8)) == []


def test_an_outline_drawn_elsewhere_is_not_taken_for_the_car_when_its_targets_are_known():
    """Reference world seed 910019: the outline matched the wall's grid 1.2 m above the car
    (the car has no hub targets, so its CG came from that outline: x off by 1.2 m x pitch,
    13 mm). Here a copy of the car's outline, drawn 130 px higher in hard black on white,
    beats the car's own edges; the body targets' positions (points inside the true outline)
    put the fit back on the car, and points no outline can hold are refused."""
    from synth.scene import body_to_plane, project
    img, car, cam, r = _render(1, 0.1, (640, 480))
    true_poly = project(cam, body_to_plane(np.asarray(car.silhouette_side), car, r.pose(0.0), r.x_cg0),
                        cam.distance_car, 1)
    decoy = img.copy()
    cv2.polylines(decoy, [np.round((true_poly - [0, 130]) * 16).astype(np.int32)], True, 255, 5, cv2.LINE_AA, 4)
    cv2.polylines(decoy, [np.round((true_poly - [0, 130]) * 16).astype(np.int32)], True, 0, 2, cv2.LINE_AA, 4)
    ws = project(cam, body_to_plane(np.array([car.windscreen_top]), car, r.pose(0.0), r.x_cg0),
                 cam.distance_car, 1)[0]
    fooled = fit_silhouette(decoy, car, scale_hint=cam.m_per_px, direction=1)
    assert np.linalg.norm(fooled.windscreen_top_px - ws) > 100  # the decoy wins without the targets
    centre = true_poly.mean(axis=0)
    inside = centre + 0.5 * (true_poly[::4] - centre)  # points well inside the car's outline
    sil = fit_silhouette(decoy, car, scale_hint=cam.m_per_px, direction=1, inside_px=inside)
    assert np.linalg.norm(sil.windscreen_top_px - ws) < 0.5
    with pytest.raises(VideoError, match="leaves 1 of the 2 body targets outside it"):
        fit_silhouette(img, car, scale_hint=cam.m_per_px, direction=1,
                       inside_px=np.array([centre, centre + [0.0, 0.45 * np.ptp(true_poly[:, 1])]]))


def test_the_checker_tape_detector_says_where_and_how_clean():
    from video.calibrate_tape import CheckerTapeDetector
    big = _canvas(480, 640, clutter=False)
    _tape(big, (320.2, 150.6), 0.0, 12.5, 8.0, 30)
    found = CheckerTapeDetector().detect(_finish(big))
    assert found.kind == "checker tape" and len(found) == 1
    # the middle of the measured stretch: the tape's centre, within a segment
    assert np.hypot(*(found.centres[0] - [320.2, 150.6])) < 12.5
    assert found.found[0].pitch_px == pytest.approx(12.5, rel=0.003)
    noisy = CheckerTapeDetector().detect(_finish(big, noise=12.0, seed=4))
    assert 0 <= noisy.quality[0] < found.quality[0] <= 1
    assert len(CheckerTapeDetector().detect(_finish(_canvas(120, 160, clutter=False)))) == 0


def _frames_with_a_moving_tape(shifts, background_tape=True, car_tape=True):
    """Frames where a tape on a wall stands still and one on the car moves by ``shifts`` px."""
    frames = []
    for k, du in enumerate(shifts):
        big = _canvas(480, 640, clutter=False)
        if background_tape:
            _tape(big, (320.4, 90.3), 0.0, 15.0, 10.0, 36)          # the wall's: 15 px pitch
        if car_tape:
            _tape(big, (240.2 + du, 330.6), 0.0, 12.5, 8.0, 20)     # the car's: 12.5 px
        frames.append(_finish(big, seed=k))
    return frames


def test_a_tape_that_stands_still_while_the_car_moves_is_the_backgrounds():
    frames = _frames_with_a_moving_tape([0.0, 4.1, 9.3, 13.1])
    alone = measure_scale(frames[0], 0.1)
    assert alone.pitch_px == pytest.approx(15.0, rel=0.003)   # the longer chain wins on its own
    est = measure_scale(frames[0], 0.1, later_frames=frames[1:])
    assert est.pitch_px == pytest.approx(12.5, rel=0.003)
    assert any("stand still while the car moves (15.00 px pitch)" in n for n in est.notes)
    only_wall = _frames_with_a_moving_tape([0.0, 4.1, 9.3, 13.1], car_tape=False)
    with pytest.raises(NoTapeError, match="no reference tape on the car"):
        measure_scale(only_wall[0], 0.1, later_frames=only_wall[1:])
    # a car tape carried by exactly its pattern's period (25 px) in one later frame is
    # still seen to move in another; and one carried by a sixth of it (less than half its
    # line changes: a median over the line would say it stood still) is seen to move
    for shifts in ([0.0, 25.0, 31.2], [0.0, 4.1, 4.2]):
        frames = _frames_with_a_moving_tape(shifts, background_tape=False)
        est = measure_scale(frames[0], 0.1, later_frames=frames[1:])
        assert est.pitch_px == pytest.approx(12.5, rel=0.003) and not any("stand still" in n for n in est.notes)
