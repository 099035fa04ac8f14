"""Randomized synthetic footage (synth.footage): the pixels show what the truth says,
whatever the camera, direction, format and degradations."""

from __future__ import annotations

import dataclasses
import json

import cv2
import numpy as np
import pytest

from synth.footage import FootageSpec, build_motion, build_scene, random_footage, render_film
from synth.render import Renderer, read_truth
from synth.vehicle import SynthError, load_car

CAR = load_car("audi_a4")
V0 = 15.6


def crash(fps: float = 1000.0, n: int = 60, v0: float = V0) -> dict:
    """A crash from first contact: half-sine deceleration to maximum crush at 80 ms,
    pitch and lift with it; wheels roll with the body."""
    t = np.arange(n) / fps
    w = np.pi / (2 * 0.08)
    x = v0 * np.sin(np.minimum(w * t, np.pi / 2)) / w
    shape = np.sin(np.clip(w * t / 2, 0, np.pi)) ** 2
    spin = x / CAR.wheel_radius
    return dict(t=t, x=x, z=0.02 * shape, pitch=0.05 * shape, crush=x.copy(), front_wheel_angle=spin,
                rear_wheel_angle=spin.copy(), front_wheel_dz=np.zeros(n), rear_wheel_dz=np.zeros(n), v0=v0)


def spec(**kw) -> FootageSpec:
    """A clean small film unless told otherwise."""
    base = dict(width=640, height=480, sensor_width=640, sensor_height=480, frames_before=5, fill=0.62, barrier_visible=0.9,
                target_diameter=0.12, barrier_targets=((0.5, 1.0),), deform_targets=((0.4, 0.3),),
                floor_targets=((0.5, 0.8),))
    base.update(kw)
    return FootageSpec(**base)


def renderer(s: FootageSpec, n: int = 60) -> Renderer:
    m = build_motion(CAR, crash(s.fps, n), s)
    return Renderer(build_scene(CAR, m, s)[0], m)


def symmetric_centre(img: np.ndarray, u: float, v: float, radius: float, iters: int = 12) -> np.ndarray:
    """Centre of a quadrant target near (u, v): the point about which the image inside
    ``0.8 radius`` is point-symmetric (opposite quadrants have the same colour), by
    Gauss-Newton on ``I(c + d) - I(c - d)`` with bilinear sampling; the background around
    the target plays no part."""
    img = img.astype(np.float32)
    gu = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=1) * 0.5
    gv = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=1) * 0.5
    rho = 0.8 * radius
    k = np.arange(-rho, rho + 1e-9, 0.5)
    du, dv = np.meshgrid(k, k)
    keep = (du**2 + dv**2 <= rho**2) & ((dv > 0) | ((dv == 0) & (du > 0)))
    du, dv = du[keep].astype(np.float32), dv[keep].astype(np.float32)
    c = np.array([round(u), round(v)], dtype=float)

    def at(a, uu, vv):
        return cv2.remap(a, uu.reshape(1, -1), vv.reshape(1, -1), cv2.INTER_LINEAR).ravel()

    for _ in range(iters):
        pu, pv = (c[0] + du).astype(np.float32), (c[1] + dv).astype(np.float32)
        mu, mv = (c[0] - du).astype(np.float32), (c[1] - dv).astype(np.float32)
        r = at(img, pu, pv) - at(img, mu, mv)
        J = np.stack([at(gu, pu, pv) - at(gu, mu, mv), at(gv, pu, pv) - at(gv, mu, mv)], 1)
        step = np.linalg.lstsq(J.astype(float), -r.astype(float), rcond=None)[0]
        c += np.clip(step, -1.0, 1.0)
        if np.abs(step).max() < 1e-4:
            break
    return c


def centre_errors(r: Renderer, i: int, kinds=("body", "deform", "fixed")) -> dict:
    img = r.render_float(i)
    row = r.truth_row(i)
    out = {}
    for t in r.scene.targets:
        if t.kind in kinds:
            uv = np.array([row[f"{t.name}_u_px"], row[f"{t.name}_v_px"]])
            radius = 0.5 * t.diameter / r.cam.m_per_px
            out[t.name] = symmetric_centre(img, *uv, radius) - uv
    return out


@pytest.mark.parametrize("camera", [
    dict(yaw_deg=2.8, pitch_deg=-1.7, roll_deg=2.2, pp_du_frac=0.025, pp_dv_frac=-0.02, direction=1),
    dict(yaw_deg=-2.5, pitch_deg=1.5, roll_deg=-2.8, k1=-0.12, k2=0.01, direction=-1, target_rot45=True),
])
def test_target_centres_read_from_the_pixels_match_the_truth(camera):
    r = renderer(spec(**camera))
    names = {t.name for t in r.scene.targets}
    assert {"roof_rail", "door", "barrier0", "floor0"} <= names and any(t.kind == "deform" for t in r.scene.targets)
    c = r.contact_frame
    errs = {}
    for i in (0, c + 45):
        for name, e in centre_errors(r, i).items():
            errs[(i, name)] = e
    worst = max(np.abs(e).max() for e in errs.values())
    assert worst < 0.1, errs
    # the direction shows: the door target moves left for direction -1
    u0, u1 = r.truth_row(0)["door_u_px"], r.truth_row(c)["door_u_px"]
    assert np.sign(u1 - u0) == camera["direction"] and abs(u1 - u0) > 3


def test_a_turned_camera_projects_as_a_pinhole_camera():
    """The truth of a fixed target is the pinhole projection written out here: camera
    coordinates of the point, turned by yaw (about the vertical), then pitch, then roll."""
    r = renderer(spec(yaw_deg=3.0, pitch_deg=-2.0, roll_deg=1.5, pp_du_frac=0.02, pp_dv_frac=-0.01))
    cam = r.cam
    t = next(t for t in r.scene.targets if t.name == "barrier0")
    y, p, q = np.radians([3.0, -2.0, 1.5])
    c = np.array([t.x - cam.centre_x, -(t.z - cam.centre_z), t.depth])
    c = np.array([[np.cos(y), 0, np.sin(y)], [0, 1, 0], [-np.sin(y), 0, np.cos(y)]]) @ c
    c = np.array([[1, 0, 0], [0, np.cos(p), -np.sin(p)], [0, np.sin(p), np.cos(p)]]) @ c
    c = np.array([[np.cos(q), -np.sin(q), 0], [np.sin(q), np.cos(q), 0], [0, 0, 1]]) @ c
    f = cam.distance_car / cam.m_per_px
    uv = [(640 - 1) / 2 + 0.02 * 640 + f * c[0] / c[2], (480 - 1) / 2 - 0.01 * 480 + f * c[1] / c[2]]
    row = r.truth_row(0)
    np.testing.assert_allclose([row["barrier0_u_px"], row["barrier0_v_px"]], uv, atol=1e-9)
    # a perspective view: the car's length spans more pixels on the side nearer the camera
    a, b = renderer(spec()), r
    wb = [abs(x.truth_row(0)["front_hub_u_px"] - x.truth_row(0)["rear_hub_u_px"]) for x in (a, b)]
    assert abs(wb[0] - wb[1]) > 0.2


def test_deforming_targets_move_against_the_body_and_are_flagged(tmp_path):
    s = spec(frames_before=3)
    meta = render_film(CAR, crash(n=50), s, tmp_path / "f")
    _, cols = read_truth(tmp_path / "f")
    flags = {t["name"]: t["deforms"] for t in meta["targets"]}
    deform = [n for n, f in flags.items() if f]
    assert deform and not flags["door"]
    # before contact a deforming target keeps its distance to the door; after, it closes in
    d = np.hypot(cols[f"{deform[0]}_u_px"] - cols["door_u_px"], cols[f"{deform[0]}_v_px"] - cols["door_v_px"])
    assert np.ptp(d[:4]) < 1e-6 and d[0] - d[-1] > 2.0
    assert meta["hubs_visible"] is True and {"front_hub", "rear_hub"} <= set(flags)
    assert [t["name"] for t in meta["fixed_targets"]] == ["barrier0", "floor0"]


def test_hidden_hubs_have_hubcaps_and_no_hub_targets():
    r = renderer(spec(hubs_visible=False, hubcap_grey=190))
    assert not any(t.kind.endswith("hub") for t in r.scene.targets)
    img = r.render(0)
    wc = r.wheel_centres(r.pose(0))["front"]
    from synth.scene import project

    u, v = project(r.cam, wc[None], r.cam.distance_car, 1)[0]
    assert abs(float(img[int(round(v)), int(round(u))]) - 190) < 3


def test_tiff16_folder_reads_back_as_uint16(tmp_path):
    s = spec(format="tiff16", noise_sigma=1.0, frames_before=2)
    meta = render_film(CAR, crash(n=3), s, tmp_path / "frames")
    files = sorted((tmp_path / "frames").glob("frame_*.tif"))
    assert len(files) == 5 and meta["format"] == "tiff16"
    img = cv2.imread(str(files[0]), cv2.IMREAD_UNCHANGED)
    assert img.dtype == np.uint16 and img.shape == (480, 640)
    assert np.any(img % 257 != 0)  # finer than 8 bits


@pytest.mark.parametrize("fmt,suffix", [("mp4", ".mp4"), ("avi", ".avi")])
def test_container_fps_tag_is_written_while_the_truth_keeps_the_true_rate(tmp_path, fmt, suffix):
    s = spec(format=fmt, container_fps=25.0, fps=500.0, frames_before=2, mp4_bpp=0.05)
    path = tmp_path / f"crash{suffix}"
    meta = render_film(CAR, crash(fps=500.0, n=6), s, path)
    cap = cv2.VideoCapture(str(path))
    assert cap.get(cv2.CAP_PROP_FPS) == pytest.approx(25.0)
    n = 0
    while cap.read()[0]:
        n += 1
    assert n == 8
    meta2 = json.loads(path.with_name("crash.truth.json").read_text())
    assert meta2["fps"] == meta["fps"] == 500.0 and meta2["container_fps"] == 25.0
    assert meta2["spec"]["fps"] == 500.0


def test_random_footage_is_reproducible_and_varies():
    a = random_footage(np.random.default_rng(3), CAR)
    b = random_footage(np.random.default_rng(3), CAR)
    assert a == b
    specs = [random_footage(np.random.default_rng(s), CAR) for s in range(40)]
    assert len({s.to_dict().__repr__() for s in specs}) == 40
    for key in ("format", "direction", "fps", "tape_segment", "hubs_visible", "target_style", "sensor_width"):
        assert len({getattr(s, key) for s in specs}) > 1, key
    for s in specs:
        assert s.width <= 1024 and s.width % 2 == 0 and s.height % 2 == 0
        assert max(abs(s.yaw_deg), abs(s.pitch_deg), abs(s.roll_deg)) <= 3.0
        assert -0.6 <= s.barrier_offset <= 0.4 and 0.05 <= s.target_diameter <= 0.15
        mpp = CAR.length / (s.fill * s.width)
        assert 8.0 - 1e-9 <= s.target_diameter / mpp <= 40.0 + 1e-9
        json.dumps(s.to_dict())


def test_random_films_render_and_start_at_constant_speed(tmp_path):
    for seed in (0, 5):
        s = dataclasses.replace(random_footage(np.random.default_rng(seed), CAR), format="png")
        meta = render_film(CAR, crash(s.fps, 4), s, tmp_path / f"f{seed}")
        _, cols = read_truth(tmp_path / f"f{seed}")
        k = s.frames_before
        assert meta["contact_frame"] == k and meta["spec"] == s.to_dict()
        np.testing.assert_allclose(np.diff(cols["x_m"][: k + 1]), V0 / s.fps, rtol=1e-9)
        assert cols["t_s"][k] == pytest.approx(0.0, abs=1e-12)
        assert np.all(cols["crush_m"][:k] == 0.0)
        assert len(list((tmp_path / f"f{seed}").glob("frame_*.png"))) == k + 4


def test_camera_shake_moves_fixed_targets_after_contact_only():
    s = spec(shake_px=3.0, shake_hz=25.0, shake_decay_s=0.05, shake_angle=0.7, shake_roll_deg=0.1,
             deform_targets=(), floor_targets=())
    r = renderer(s, n=40)
    c = r.contact_frame
    u = np.array([r.truth_row(i)["barrier0_u_px"] for i in range(r.motion.n)])
    v = np.array([r.truth_row(i)["barrier0_v_px"] for i in range(r.motion.n)])
    assert np.ptp(u[: c + 1]) == 0.0 and np.ptp(v[: c + 1]) == 0.0
    moved = np.hypot(u - u[0], v - v[0])
    assert 1.0 < moved[c + 1 :].max() < 4.0
    # and the pixels show the shaken position
    i = c + 1 + int(np.argmax(moved[c + 1 :]))
    e = centre_errors(r, i, kinds=("fixed",))["barrier0"]
    assert np.abs(e).max() < 0.1, e


def test_bad_motion_is_refused():
    s = spec()
    with pytest.raises(SynthError, match="spec.fps"):
        build_motion(CAR, crash(fps=500.0, n=10), s)
    m = crash(n=10)
    del m["v0"]
    with pytest.raises(SynthError, match="v0"):
        build_motion(CAR, m, s)
