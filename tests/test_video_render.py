"""The synthetic-film renderer draws what its truth says."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from identify.recordings.synthetic import car_geometry, load_vehicle_dict
from synth.vehicle import SynthError
from synth.render import Renderer, read_truth, write_film
from synth.scene import (
    Effects,
    Motion,
    Occluder,
    Scene,
    Target,
    body_to_plane,
    clip_at_face,
    default_camera,
    default_tapes,
    default_targets,
    project,
)

CAR = car_geometry(load_vehicle_dict("audi_a4"))
V0 = 15.64


def crash_motion(n: int = 40, before: int = 10, fps: float = 1000.0) -> Motion:
    """Constant speed before contact, a half-sine pulse after (x = v0 sin(w t) / w)."""
    t = (np.arange(n) - before) / fps
    w = np.pi / 0.2
    after = t >= 0
    x = np.where(after, V0 * np.sin(w * t) / w, V0 * t)
    pitch = np.where(after, 0.1 * np.sin(w * t), 0.0)
    z = np.where(after, 0.02 * np.sin(w * t), 0.0)
    fw = V0 * (t - t[0]) / CAR.wheel_radius
    return Motion(t=t, x=x, z=z, pitch=pitch, front_wheel_angle=fw, rear_wheel_angle=0.7 * fw)


def make_scene(direction: int = 1, width: int = 640, height: int = 480, **effects) -> Scene:
    cam = default_camera(CAR, 0.0, width, height)
    fixed = Target("barrier_mark", "fixed", 0.35, 1.0, 0.12)
    return Scene(CAR, cam, default_targets(CAR) + (fixed,), default_tapes(CAR), 0.0, direction,
                 effects=Effects(**effects))


def centroid(img: np.ndarray, u: float, v: float, half: int, ground: float) -> np.ndarray:
    """Centroid of |I - ground| in a square window around (u, v) (window centred on
    the rounded position, so a wrong truth shows)."""
    ui, vi = int(round(u)), int(round(v))
    win = img[vi - half : vi + half + 1, ui - half : ui + half + 1].astype(float)
    w = ground - win  # linear in the coverage (|.| would bias mixed pixels)
    vv, uu = np.mgrid[vi - half : vi + half + 1, ui - half : ui + half + 1]
    return np.array([(w * uu).sum() / w.sum(), (w * vv).sum() / w.sum()])


def target_errors(renderer: Renderer, i: int, names=("roof_rail", "b_pillar", "door", "sill", "front_hub", "rear_hub")):
    img = renderer.render(i)
    row = renderer.truth_row(i)
    sc = renderer.scene
    errs = []
    for t in sc.targets:
        if t.name not in names:
            continue
        half = int(np.ceil(0.5 * t.diameter / sc.camera.m_per_px)) + 3
        ground = sc.rim_grey if t.kind.endswith("hub") else sc.body_grey
        c = centroid(img, row[f"{t.name}_u_px"], row[f"{t.name}_v_px"], half, ground)
        errs.append(c - [row[f"{t.name}_u_px"], row[f"{t.name}_v_px"]])
    return np.array(errs)


@pytest.mark.parametrize("direction", [1, -1])
def test_target_centroid_matches_truth_on_clean_frames(direction):
    r = Renderer(make_scene(direction), crash_motion())
    errs = np.concatenate([target_errors(r, i) for i in (0, 17, 33)])
    assert np.abs(errs).max() < 0.05, errs


def test_pose_formula_nose_down_positive_and_rigid():
    car = CAR
    pts = np.array([[car.x_cg + 1.0, car.cg_height], [car.x_cg, car.cg_height + 1.0], [car.x_cg, car.cg_height]])
    th = 0.1
    P = body_to_plane(pts, car, {"x": 0.2, "z": -0.01, "pitch": th}, 5.0)
    # the CG only translates; a point 1 m ahead of it goes down by sin(theta)
    np.testing.assert_allclose(P[2], [5.2, car.cg_height - 0.01])
    np.testing.assert_allclose(P[0], [5.2 + np.cos(th), car.cg_height - 0.01 - np.sin(th)])
    np.testing.assert_allclose(P[1], [5.2 + np.sin(th), car.cg_height - 0.01 + np.cos(th)])


def test_rendered_body_moves_rigidly_at_the_true_scale():
    """Measured distances between body-target centroids, times the true m/px, equal
    their vehicle-frame distances, whatever the pitch."""
    r = Renderer(make_scene(1), crash_motion())
    sc = r.scene
    body = [t for t in sc.targets if t.kind == "body"]
    true_d = np.hypot(body[0].x - body[2].x, body[0].z - body[2].z)
    for i in (0, 35):
        img = r.render(i)
        row = r.truth_row(i)
        cs = [centroid(img, row[f"{t.name}_u_px"], row[f"{t.name}_v_px"], 9, sc.body_grey) for t in (body[0], body[2])]
        d = np.hypot(*(cs[0] - cs[1])) * sc.camera.m_per_px
        assert abs(d - true_d) / sc.camera.m_per_px < 0.03, (i, d, true_d)  # px
    assert abs(r.truth_row(35)["pitch_rad"]) > 0.03  # the check above ran on a pitched body


def test_direction_flip_mirrors_the_truth():
    m = crash_motion()
    a = Renderer(make_scene(1), m)
    b = Renderer(make_scene(-1), m)
    W = a.cam.width
    for i in (0, 30):
        ra, rb = a.truth_row(i), b.truth_row(i)
        for t in a.scene.targets:
            assert rb[f"{t.name}_u_px"] == pytest.approx(W - 1 - ra[f"{t.name}_u_px"], abs=1e-9)
            assert rb[f"{t.name}_v_px"] == pytest.approx(ra[f"{t.name}_v_px"], abs=1e-9)
    # the car moves right-to-left with direction -1: the door target's u decreases
    assert b.truth_row(9)["door_u_px"] < b.truth_row(0)["door_u_px"] - 10


def test_tape_segments_give_the_true_scale():
    r = Renderer(make_scene(1, width=800, height=400), crash_motion())
    img = r.render(0).astype(float)
    tape = [t for t in r.scene.tapes if t.name == "sill_tape"][0]
    P = body_to_plane(np.array([[tape.x0 + 0.25, tape.z + 0.5 * tape.height]]), CAR, r.pose(0), r.x_cg0)
    u0, v = project(r.cam, P, r.cam.distance_car, 1)[0]
    row = img[int(round(v))]
    mid = 0.5 * (r.scene.tape_dark + r.scene.tape_light)
    lo = int(u0) - 10
    hi = int(project(r.cam, body_to_plane(np.array([[tape.x1 - 0.05, tape.z]]), CAR, r.pose(0), r.x_cg0), r.cam.distance_car, 1)[0, 0])
    seg = row[lo:hi] - mid
    above = seg > 0
    k = np.flatnonzero(above[:-1] != above[1:])
    crossings = lo + k + seg[k] / (seg[k] - seg[k + 1])
    spacing = np.diff(crossings)
    m_per_px = tape.segment / np.mean(spacing)
    assert len(crossings) > 10
    assert m_per_px == pytest.approx(r.cam.m_per_px, rel=0.005)


def test_front_end_is_drawn_at_the_barrier_face():
    m = crash_motion(60, 10)
    r = Renderer(make_scene(1), m)
    i = 45
    assert r.truth_row(i)["crush_m"] > 0.2
    # silhouette clipped to the face: no vertex beyond it, some on it
    P = clip_at_face(body_to_plane(CAR.silhouette_side, CAR, r.pose(i), r.x_cg0), 0.0)
    assert P[:, 0].max() == pytest.approx(0.0)
    # in the image: at bumper height the body grey ends at the face's column
    img = r.render(i)
    u_face, v = project(r.cam, np.array([[0.0, 0.5]]), r.cam.distance_car, 1)[0]
    line = img[int(round(v))].astype(float)
    ui = int(round(u_face))
    assert abs(line[ui - 3] - r.scene.body_grey) < 3
    assert abs(line[ui + 3] - r.scene.body_grey) > 20


def test_noise_blur_and_distortion_keep_truth():
    m = crash_motion()
    clean = Renderer(make_scene(1), m)
    noisy = Renderer(make_scene(1, noise_sigma=3.0, seed=4), m)
    diff = noisy.render(5).astype(float) - clean.render(5)
    assert np.std(diff) == pytest.approx(3.0, rel=0.1)
    blurred = Renderer(make_scene(1, blur_substeps=5, exposure=1.0), m)
    assert np.abs(blurred.render(5).astype(float) - clean.render(5)).max() > 30
    # before contact the motion is linear: the blur is symmetric, the centre unchanged
    assert np.abs(target_errors(blurred, 5, ("roof_rail", "door"))).max() < 0.1
    sc = make_scene(1)
    dist = Renderer(replace(sc, camera=replace(sc.camera, k1=-0.25)), m)
    row = dist.truth_row(5)
    ref = clean.truth_row(5)
    moved = max(abs(row[f"{t.name}_u_px"] - ref[f"{t.name}_u_px"]) for t in sc.targets)
    assert moved > 3.0  # the distortion moves targets away from the pinhole projection
    assert np.abs(target_errors(dist, 5, ("roof_rail", "door", "front_hub"))).max() < 0.1


def test_occluder_covers_its_target_and_truth_says_so():
    m = crash_motion()
    sc = replace(make_scene(1), occluders=(Occluder("door", 10, 21, 0.08),))
    r = Renderer(sc, m)
    flags = [r.truth_row(i)["door_occluded"] for i in range(m.n)]
    assert flags[15] == 1 and flags[5] == 0 and flags[25] == 0
    row = r.truth_row(15)
    img = r.render(15)
    win = img[int(row["door_v_px"]) - 2 : int(row["door_v_px"]) + 3, int(row["door_u_px"]) - 2 : int(row["door_u_px"]) + 3]
    assert win.max() < 60  # dark blob over the target's centre


def test_write_png_folder_and_truth(tmp_path):
    m = crash_motion(12, 4)
    r = Renderer(make_scene(1, width=320, height=240), m)
    out = tmp_path / "film"
    meta = write_film(r, out, duplicate=(6,))
    files = sorted(out.glob("frame_*.png"))
    assert len(files) == 13
    meta2, cols = read_truth(out)
    assert meta2["contact_frame"] == 4 == meta["contact_frame"]
    assert meta2["impact_speed_mps"] == pytest.approx(V0, rel=1e-6)
    assert meta2["m_per_px_car_plane"] == pytest.approx(r.cam.m_per_px)
    assert cols["frame"].tolist() == [0, 1, 2, 3, 4, 5, 6, 6, 7, 8, 9, 10, 11]
    assert cols["x_m"][4] == pytest.approx(0.0, abs=1e-12)


# ------------------------------------------------------------ glue (identify.recordings.synthetic)

from identify.errors import UserError  # noqa: E402
from identify.recordings.synthetic import analytic_trajectory, render_crash  # noqa: E402


def test_car_geometry_from_vehicle_file_and_bad_files():
    raw = load_vehicle_dict("audi_a4")
    car = car_geometry(raw)
    assert car.x_cg == pytest.approx(4.703 - 0.903 - 1.18)
    assert car.silhouette_side.shape == (len(raw["silhouette_side"]), 2)
    np.testing.assert_allclose(car.windscreen_top, [2.389, 1.417])
    with pytest.raises(UserError, match="wheelbase"):
        car_geometry({k: v for k, v in raw.items() if k != "wheelbase"})
    with pytest.raises(UserError, match="positive"):
        car_geometry(dict(raw, length=-1.0))
    with pytest.raises(UserError, match="silhouette_side"):
        car_geometry(dict(raw, silhouette_side=[[0, 0], [1, 1]]))
    with pytest.raises(UserError, match="unknown vehicle"):
        load_vehicle_dict("no_such_car")


def test_render_crash_prepends_a_constant_speed_approach(tmp_path):
    traj = analytic_trajectory(speed=12.0, duration=0.02)
    meta = render_crash("audi_a4", traj, tmp_path / "c", frames_before=8, width=320, height=160, direction=-1, speed=12.0)
    meta2, cols = read_truth(tmp_path / "c")
    assert meta["contact_frame"] == meta2["contact_frame"] == 8
    assert meta2["direction"] == -1
    assert meta2["impact_speed_mps"] == pytest.approx(12.0, rel=1e-6)
    assert len(list((tmp_path / "c").glob("*.png"))) == 8 + 21
    np.testing.assert_allclose(np.diff(cols["x_m"][:9]), 12.0 * 0.001, rtol=1e-9)
    np.testing.assert_allclose(cols["t_s"][8:], traj["t"], atol=1e-12)
    np.testing.assert_allclose(cols["x_m"][8:], traj["x"], atol=1e-12)
    # wheels: 0 at the first frame, rolling at v / r during the approach
    assert cols["front_wheel_angle_rad"][0] == pytest.approx(0.0, abs=1e-12)
    assert cols["front_wheel_angle_rad"][8] == pytest.approx(12.0 * 0.008 / CAR.wheel_radius)
    assert np.all(cols["front_wheel_height_m"] >= -1e-12)
    # a fixed target on the barrier stays where it is
    render_crash("audi_a4", traj, tmp_path / "f", frames_before=2, width=320, height=160, barrier_target=True)
    _, cols = read_truth(tmp_path / "f")
    assert np.ptp(cols["barrier_u_px"]) == 0.0 and np.ptp(cols["door_u_px"]) > 5.0
    with pytest.raises(SynthError, match="already holds frames"):
        render_crash("audi_a4", traj, tmp_path / "f", frames_before=2, width=320, height=160)
    # without a given speed, the approach speed is the trajectory's initial velocity
    meta = render_crash("audi_a4", traj, tmp_path / "e", frames_before=3, width=320, height=160)
    assert meta["impact_speed_mps"] == pytest.approx(12.0, rel=1e-4)
    with pytest.raises(UserError, match="t = 0"):
        render_crash("audi_a4", dict(traj, t=traj["t"] + 0.01), tmp_path / "d")


@pytest.mark.slow
def test_simulate_and_render_matches_the_model(tmp_path):
    from identify.recordings.synthetic import simulate_and_render

    meta = simulate_and_render("audi_a4", "paper_identified", 56.3, tmp_path / "a4.mp4", duration=0.05,
                               frames_before=5, width=320, height=128)
    _, cols = read_truth(tmp_path / "a4.mp4")
    assert meta["contact_frame"] == 5 and len(cols["x_m"]) == 5 + 51
    assert meta["impact_speed_mps"] == pytest.approx(56.3 / 3.6, rel=1e-9)
    assert cols["crush_m"][5] == pytest.approx(0.0, abs=1e-9) and cols["crush_m"][-1] > 0.3
    # the rear wheel is drawn on the floor until the model lifts it
    lift_ms = meta["events_ms"]["rear_wheel_lift"]
    # inside the 50 ms rendered (a precondition of the checks below, not a claim about when)
    assert lift_ms is not None and 0 < lift_ms < 50
    t_ms = cols["t_s"] * 1000
    up = t_ms[cols["rear_wheel_height_m"] > 1e-9]
    assert up.size and abs(up[0] - lift_ms) <= 1.0
    np.testing.assert_allclose(cols["rear_wheel_height_m"][t_ms < lift_ms - 1.0], 0.0, atol=1e-9)


def test_polygon_edges_land_where_the_geometry_puts_them():
    """cv2.fillPoly alone widens shapes by a canvas pixel; the renderer's fill does not."""
    import cv2

    r = Renderer(make_scene(1, width=160, height=120), crash_motion())
    ss = r.ss
    rng = np.random.default_rng(0)
    errs = []
    for _ in range(40):
        u0, v0 = rng.uniform(8, 12, 2)
        u1, v1 = u0 + rng.uniform(15, 25), v0 + rng.uniform(10, 20)
        canvas = np.zeros((120 * ss, 160 * ss), np.float32)
        r._fill(canvas, np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]]), 1.0)
        img = cv2.resize(canvas, (160, 120), interpolation=cv2.INTER_AREA)
        row, col = img[int((v0 + v1) / 2)], img[:, int((u0 + u1) / 2)]
        errs.append([row.sum() - (u1 - u0), col.sum() - (v1 - v0),
                     (row * np.arange(160)).sum() / row.sum() - (u0 + u1) / 2])
    errs = np.array(errs)
    assert np.abs(errs.mean(axis=0)).max() < 0.03, errs.mean(axis=0)  # no bias, px
    assert errs.std(axis=0).max() < 0.15


def test_flicker_debris_and_jpeg_change_only_what_they_should():
    m = crash_motion(30, 10)
    clean = Renderer(make_scene(1), m)
    flick = Renderer(make_scene(1, flicker=0.05, seed=2), m)
    gains = [flick.render(i).astype(float).mean() / clean.render(i).astype(float).mean() for i in (3, 4, 5)]
    np.testing.assert_allclose(gains, flick._gain[[3, 4, 5]], rtol=0.01)
    assert np.ptp(gains) > 0.005
    debris = Renderer(make_scene(1, debris=40, seed=5), m)
    np.testing.assert_array_equal(debris.render(9), clean.render(9))  # nothing before contact
    changed = np.flatnonzero((debris.render(29) != clean.render(29)).any(axis=0))
    assert changed.size > 0
    # debris flies in a plane 0.3 m nearer the camera, thrown back from the barrier face
    u_face = project(debris.cam, np.array([[0.0, 0.5]]), debris.cam.distance_car - 0.3, 1)[0, 0]
    assert changed.max() < u_face + 6
    jpeg = Renderer(make_scene(1, jpeg_quality=40), m)
    d = jpeg.render(3).astype(float) - clean.render(3)
    assert 0.3 < np.abs(d).mean() < 5.0
