"""Tests of video.edges: roof-edge corner, front end, barrier face, crush."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage.draw import polygon as fill_polygon

from video.edges import (crush_from_body, find_barrier_face, locate_corner, locate_front_end,
                         roof_edge_start, track_front_end, track_roof_edge)
from video.errors import VideoError

SS = 8
ROOF = np.array([-1.0, -0.0125])           # roof runs back, nearly level
SCREEN = np.array([0.857, 0.515])          # windscreen runs forward and down (31 deg)


def _background(h, w, seed=0):
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur(rng.normal(0, 1, (h, w)).astype(np.float32), (0, 0), 3.0)
    return 85.0 + 14.0 * tex / tex.std()


def _draw(h, w, polys, bg, blur=0.0, noise=0.0, seed=0, direction=1):
    """Exact-coverage drawing: polygons (px, small image) filled at SS x SS sub-samples
    (a sub-pixel is in when its centre is) and averaged, over a smooth background."""
    big = cv2.resize(bg.astype(np.float32), (w * SS, h * SS), interpolation=cv2.INTER_LINEAR)
    for poly, value in polys:
        p = (np.asarray(poly, float) + 0.5) * SS - 0.5
        rr, cc = fill_polygon(p[:, 1], p[:, 0], big.shape)
        big[rr, cc] = value
    img = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
    if blur:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise:
        img = img + np.random.default_rng(seed).normal(0, noise, img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def _car_top(corner, direction=1):
    """Body outline around a windscreen-top corner: roof back, windscreen forward-down."""
    c = np.asarray(corner, float)
    d = np.array([direction, 1.0])
    roof_end = c + 80 * ROOF * d
    screen_end = c + 80 * SCREEN * d
    return [c, screen_end, screen_end + [0, 60], roof_end + [0, 80], roof_end]


@pytest.mark.parametrize("direction", [1, -1])
@pytest.mark.parametrize("textured,limit", [(False, 0.05), (True, 0.2)])
def test_corner_subpixel_on_clean_frames(direction, textured, limit):
    rng = np.random.default_rng(2)
    errs = []
    bg = _background(120, 200) if textured else np.full((120, 200), 85.0)
    for k in range(5):
        corner = np.array([100.0, 40.0]) + rng.uniform(-0.5, 0.5, 2)
        img = _draw(120, 200, [(_car_top(corner, direction), 175.0)], bg)
        d = np.array([direction, 1.0])
        c = locate_corner(img, corner + [1.5, -1.0], ROOF * d, SCREEN * d)
        assert c.found
        errs.append(c.uv - corner)
    rms = np.sqrt(np.mean(np.sum(np.square(errs), axis=1)))
    assert rms < limit, rms


def test_corner_with_noise_and_blur_within_0p3_px_and_honest_sigma():
    rng = np.random.default_rng(4)
    bg = _background(120, 200, seed=1)
    errs, sig = [], []
    for k in range(6):
        corner = np.array([100.0, 40.0]) + rng.uniform(-0.5, 0.5, 2)
        img = _draw(120, 200, [(_car_top(corner), 175.0)], bg, blur=1.0, noise=3.0, seed=k)
        c = locate_corner(img, corner + [-1.0, 1.0], ROOF, SCREEN)
        errs.append(c.uv - corner)
        sig.append(np.sqrt(np.diag(c.cov)))
    errs, sig = np.array(errs), np.array(sig)
    assert np.sqrt(np.mean(np.sum(errs ** 2, axis=1))) < 0.3
    assert np.all(np.abs(errs) < 5 * sig + 0.1)


def test_corner_not_found_on_a_plain_frame():
    img = np.full((80, 120), 120, np.uint8)
    c = locate_corner(img, np.array([60.0, 40.0]), ROOF, SCREEN)
    assert not c.found and np.all(np.isnan(c.uv))


def test_track_roof_edge_follows_motion_and_reports_lost_frames():
    bg = _background(120, 260)
    n = 8
    truth = np.array([[80.0 + 4.3 * k, 40.0 + 0.35 * k] for k in range(n)])
    frames = [_draw(120, 260, [(_car_top(c), 175.0)], bg) for c in truth]
    frames[5] = np.full_like(frames[5], 120)  # a flash: nothing to see in frame 5
    tr = track_roof_edge(frames, truth[0] + [1.0, 1.0], ROOF, SCREEN, reach_px=55.0,
                         first_index=100)
    ok = ~tr.lost
    assert list(np.flatnonzero(tr.lost)) == [5]
    assert np.all(np.isnan(tr.uv[5]))
    assert tr.notes and "105" in tr.notes[0]
    err = tr.uv[ok] - truth[ok]
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 0.3
    # the body does not turn here; a lost frame leaves the others' angles intact
    assert np.isnan(tr.angle[5]) and np.all(np.isfinite(tr.angle[ok]))
    assert np.max(np.abs(tr.angle[ok] - tr.angle[0])) < 0.005


def test_roof_edge_start_picks_roof_and_windscreen_edges():
    poly = np.array([[0.0, 100.0], [50.0, 60.0], [150.0, 58.0], [230.0, 100.0], [230.0, 150.0],
                     [0.0, 150.0]])
    guess, roof, screen, reach = roof_edge_start(poly, np.array([150.2, 58.1]))
    assert np.allclose(guess, [150.0, 58.0])
    assert roof[0] < -0.99 and screen[0] > 0.8 and screen[1] > 0.4
    assert 40 < reach < 0.85 * 90


def _front(u_front, v_top=30.0, v_bot=70.0, direction=1):
    """A body whose front face is vertical at column u_front between two rows."""
    back = u_front - direction * 120
    return [[back, v_top - 20], [u_front - direction * 10, v_top - 20], [u_front, v_top],
            [u_front, v_bot], [u_front - direction * 5, v_bot + 10], [back, v_bot + 10]]


@pytest.mark.parametrize("direction", [1, -1])
def test_front_end_within_0p3_px(direction):
    bg = _background(100, 240, seed=3)
    for u in (150.3, 151.77, 152.5):
        uf = u if direction == 1 else 240 - u
        img = _draw(100, 240, [(_front(uf, direction=direction), 175.0)], bg, noise=2.0)
        fe = locate_front_end(img, direction, (35, 65), uf - direction * 4)
        assert fe.found and abs(fe.u - uf) < 0.3
        assert 0 < fe.sigma < 1.0 and 30 <= fe.v <= 70


def test_track_front_end_moves_with_the_car():
    bg = _background(100, 240, seed=3)
    truth = 120.0 + 3.7 * np.arange(6)
    frames = [_draw(100, 240, [(_front(u), 175.0)], bg, noise=2.0) for u in truth]
    tr = track_front_end(frames, 1, (35, 65), truth[0] + 2)
    assert not tr.lost.any()
    assert np.max(np.abs(tr.uv[:, 0] - truth)) < 0.3


def test_front_end_bad_direction_raises():
    with pytest.raises(VideoError, match="direction"):
        locate_front_end(np.zeros((50, 50), np.uint8), 0, (10, 20), 25.0)


def test_barrier_face_found_to_subpixel():
    bg = _background(100, 240, seed=5)
    img = _draw(100, 240, [(_front(120.0), 175.0), ([[201.4, 0], [240, 0], [240, 100],
                                                      [201.4, 100]], 140.0)], bg, noise=2.0)
    face = find_barrier_face(img, 1, (20, 80), 125.0)
    assert abs(face.u - 201.4) < 0.2 and 0 < face.sigma < 0.5
    with pytest.raises(VideoError, match="barrier"):
        find_barrier_face(np.full((100, 240), 90, np.uint8), 1, (20, 80), 125.0)


def _track(u, angle=None):
    from video.edges import EdgeTrack
    n = len(u)
    uv = np.column_stack([u, np.full(n, 50.0)])
    return EdgeTrack(uv, np.full((n, 2), 0.1), ~np.isfinite(u), (),
                     None if angle is None else np.asarray(angle, float),
                     None if angle is None else np.full(n, 1e-4))


def test_crush_from_body_carries_the_front_with_the_body():
    body = _track(np.array([10.0, 14.0, 18.0, 21.0, 23.0, 24.0, np.nan]))
    c = crush_from_body(body, np.array([300.0, 150.0]), 0.2, 0, 308.0, 0.1, 0.005, 1e-6, 1)
    # front at 300, 304, 308, 311, 313, 314: crush 0, 0, 0, 3, 5, 6 px
    assert np.allclose(c.crush_m[:6], 0.005 * np.array([0, 0, 0, 3, 5, 6]))
    assert np.allclose(c.signed_m[:2], 0.005 * np.array([-8, -4]))
    assert np.isnan(c.crush_m[6]) and np.all(c.sigma_m[:6] > 0)
    left = crush_from_body(_track(-body.uv[:, 0]), np.array([300.0, 150.0]), 0.2, 0, 292.0,
                           0.1, 0.005, 1e-6, -1)
    assert np.allclose(left.crush_m[:6], c.crush_m[:6])


def test_crush_turns_the_front_with_the_body():
    # body point at (10, 50), front 290 px ahead and 100 px below; the body turns 0.1 rad
    body = _track(np.array([10.0, 10.0]), angle=[0.0, 0.1])
    c = crush_from_body(body, np.array([300.0, 150.0]), 0.2, 0, 290.0, 0.1, 0.01, 0.0, 1)
    expected_u = 10.0 + np.cos(0.1) * 290.0 - np.sin(0.1) * 100.0
    assert np.isclose(c.signed_m[1], 0.01 * (expected_u - 290.0))


def test_crush_needs_the_body_in_the_reference_frame():
    with pytest.raises(VideoError, match="reference frame 1"):
        crush_from_body(_track(np.array([1.0, np.nan])), np.array([5.0, 5.0]), 0.1, 1, 9.0,
                        0.1, 0.01, 0.0, 1)


# ---------------------------------------------------------------- rendered film

@pytest.fixture(scope="module")
def film():
    """A short rendered crash: 8 frames of approach at 15.6 m/s, then 14 of crush with
    the nose pitching down to 0.05 rad."""
    from identify.synthetic import car_geometry, load_vehicle_dict
    from synth.render import Renderer
    from synth.scene import (Effects, Motion, Scene, default_camera, default_tapes,
                             default_targets)
    car = car_geometry(load_vehicle_dict("audi_a4"))
    cam = default_camera(car, 0.0, width=640, height=480)
    n, n0 = 22, 8
    t = (np.arange(n) - n0) * 1e-3
    wn = 2 * np.pi / 0.2
    x = np.where(t < 0, 15.6 * t, 15.6 * np.sin(wn * t) / wn)
    pitch = np.where(t < 0, 0.0, 0.05 * np.sin(wn * t / 2) ** 2 / np.sin(wn * 0.013 / 2) ** 2)
    z = np.zeros(n)
    motion = Motion(t=t, x=x, z=z, pitch=pitch, front_wheel_angle=z, rear_wheel_angle=z)
    out = {}
    for direction in (1, -1):
        scene = Scene(car=car, camera=cam, targets=default_targets(car),
                      tapes=default_tapes(car), x_barrier=0.0, direction=direction,
                      effects=Effects(noise_sigma=1.0))
        r = Renderer(scene, motion)
        out[direction] = (r, [r.render(i) for i in range(n)])
    return car, cam, n0, out


def _truth_uv(r, car, cam, pts, i, direction):
    from synth.scene import body_to_plane, project
    return project(cam, body_to_plane(pts, car, r.pose(float(i)), r.x_cg0), cam.distance_car,
                   direction)


@pytest.mark.slow
@pytest.mark.parametrize("direction", [1, -1])
def test_roof_edge_front_end_and_crush_on_rendered_film(film, direction):
    from video.calibrate import fit_silhouette, measure_scale
    from synth.scene import front_x
    car, cam, n0, out = film
    r, frames = out[direction]
    est = measure_scale(frames[0], 0.1)
    sil = fit_silhouette(frames[0], car, scale_hint=est.m_per_px)
    guess, roof, screen, reach = roof_edge_start(sil.polygon_px, sil.windscreen_top_px)
    tr = track_roof_edge(frames, guess, roof, screen, reach_px=reach)
    truth = np.array([_truth_uv(r, car, cam, car.windscreen_top[None, :], i, direction)[0]
                      for i in range(len(frames))])
    err = tr.uv - truth
    assert not tr.lost.any()
    # the renderer's polygons are ~0.2 px fat (cv2 anti-aliased fill at 2x): 0.35 px
    assert np.sqrt(np.mean(np.sum(err ** 2, axis=1))) < 0.35
    # the roof line turns with the pitch (image angle, clockwise positive for +1)
    turn = (tr.angle - tr.angle[0]) * direction
    assert np.max(np.abs(turn - r.motion.pitch)) < 0.005  # measured 1-3 mrad

    # front end before contact, within 1 px
    rows = sil.to_image(np.array([[front_x(car), 0.62], [front_x(car), 0.33]]))[:, 1]
    fe = track_front_end(frames[:n0], direction, tuple(rows), sil.front_px[0])
    front_truth = np.array([_truth_uv(r, car, cam, car.silhouette_side, i, direction)[:, 0]
                            for i in range(n0)])
    front_truth = front_truth.max(axis=1) if direction == 1 else front_truth.min(axis=1)
    assert np.max(np.abs(fe.uv[:, 0] - front_truth)) < 1.0
    assert np.sqrt(np.mean((fe.uv[:, 0] - front_truth) ** 2)) < 0.3  # measured 0.1

    # crush: the front carried with the roof edge past the car-plane contact position
    contact_u = _truth_uv(r, car, cam, np.array([[front_x(car), 0.45]]), n0, direction)[0, 0]
    crush = crush_from_body(tr, fe.uv[0], fe.sigma[0, 0], 0, contact_u, 0.2, est.m_per_px,
                            est.sigma, direction)
    true_crush = np.array([r.crush(i) for i in range(len(frames))])
    assert np.max(np.abs(crush.crush_m - true_crush)) < 3 * est.m_per_px
    assert np.all(crush.crush_m[:n0] == 0) and crush.crush_m[-1] > 0.1


@pytest.mark.parametrize("direction", [1, -1])
def test_barrier_face_on_rendered_frame(film, direction):
    from video.calibrate import fit_silhouette
    car, cam, n0, out = film
    r, frames = out[direction]
    sil = fit_silhouette(frames[0], car)
    wall_rows = sil.to_image(np.array([[0.0, 1.5], [0.0, 1.0]]))[:, 1]
    face = find_barrier_face(frames[0], direction, tuple(wall_rows),
                             sil.front_px[0] + 3 * direction)
    assert abs(face.u - r.truth_meta()["barrier_face_u_px"]) < 0.3
