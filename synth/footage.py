"""Randomized crash-test footage: what crash labs vary, drawn from a seed.

:func:`random_footage` draws a :class:`FootageSpec` (every knob of one film: sensor size,
camera pose and lens, scale, barrier depth, background, targets and tapes, direction,
frame rate, file format, degradations); :func:`render_film` renders a car's motion with
it and writes the film and its truth beside it (``<stem>.truth.json`` with the spec,
camera, targets, scale...; ``<stem>.truth.csv`` per frame: pose, crush, wheel angles and
heights, every target's pixel centre (lens distortion and camera shake included) and
whether an occluder covers it).

Example
-------
>>> rng = np.random.default_rng(7)                                      # doctest: +SKIP
>>> spec = random_footage(rng, load_car("audi_a4"))                     # doctest: +SKIP
>>> # simulate at spec.fps from first contact, then:
>>> meta = render_film(car, motion, spec, "crash.mp4")                  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from synth.film_writer import FORMATS, FilmWriter
from synth.render import Renderer, _json_clean, write_truth
from synth.scene import (
    Camera,
    Effects,
    Motion,
    Occluder,
    Scene,
    Target,
    cg_x_at_contact,
    default_tapes,
    front_x,
)
from synth.vehicle import Car, SynthError

SENSORS = ((1024, 1024), (1280, 1024), (1024, 768), (800, 600))
MAX_RENDER_WIDTH = 1024
_DEFORM_XS = (0.0, -0.35, 0.3, 0.15)  # candidate positions of deforming-part targets from the front axle, m
MOTION_FIELDS = ("t", "x", "z", "pitch", "crush", "front_wheel_angle", "rear_wheel_angle",
                 "front_wheel_dz", "rear_wheel_dz")


@dataclass(frozen=True)
class FootageSpec:
    """Every knob of one synthetic film (SI units; angles in degrees where named ``_deg``).

    Image and timing: ``sensor_width, sensor_height`` (the camera's), ``width, height``
    (rendered, at most :data:`MAX_RENDER_WIDTH` wide by default), ``fps`` (true rate: the
    caller simulates at it), ``container_fps`` (None: the true rate; else e.g. 25, a film
    re-encoded for publication), ``frames_before`` (constant-speed approach frames),
    ``format`` (mp4, avi, png, tiff16), ``mp4_bpp`` (MP4 bits per pixel per frame),
    ``mjpeg_quality``.

    Camera: ``direction`` (+1 left-to-right), ``fill`` (fraction of the width the car's
    length covers), ``distance_car`` m, ``barrier_offset`` m (barrier side face minus car
    side plane depth, -0.6 nearer to +0.4 farther), ``background_offset`` m,
    ``view_z`` (car-plane height at the image centre, m), ``barrier_visible`` (barrier
    side face in view past its face, m), ``yaw_deg, pitch_deg, roll_deg``,
    ``pp_du_frac, pp_dv_frac`` (principal point offset, fraction of width/height),
    ``k1, k2``, ``supersample``.

    Scene: ``wall_grey, wall_texture, texture_scale, tile_m, floor_grey, texture_seed,
    body_grey, barrier_grey, lamps`` (tuple of (fraction across the view, Z m, radius m)).

    Targets: ``target_diameter`` m, ``target_style`` ("black_white" or "black_yellow"),
    ``target_light`` (grey of the light quadrants), ``target_rot45``, ``hubs_visible``,
    ``hubcap_grey``, ``deform_targets`` (tuple of (follow, turn rad/m) per target on the
    bonnet/wing), ``barrier_targets`` (tuple of (fraction along the free side face, Z m)),
    ``floor_targets`` (tuple of (fraction along the free floor strip, depth offset m,
    nearer the camera)), ``tape_segment`` (m or None), ``tape_height`` m.

    Degradations: ``noise_sigma``, ``exposure`` (shutter fraction, motion blur),
    ``blur_substeps``, ``flicker``, ``flicker_hz``, ``gain`` (overexposure), ``debris``,
    ``occluders`` (tuple of (target name, first frame, number of frames)), ``shake_px``,
    ``shake_hz``, ``shake_decay_s``, ``shake_angle``, ``shake_roll_deg``, ``noise_seed``.
    """

    sensor_width: int = 1024
    sensor_height: int = 1024
    width: int = 1024
    height: int = 1024
    fps: float = 1000.0
    container_fps: float | None = None
    frames_before: int = 30
    format: str = "png"
    mp4_bpp: float = 0.15
    mjpeg_quality: int = 80
    direction: int = 1
    fill: float = 0.6
    distance_car: float = 8.0
    barrier_offset: float = -0.3
    background_offset: float = 4.0
    view_z: float = 0.9
    barrier_visible: float = 0.6
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0
    roll_deg: float = 0.0
    pp_du_frac: float = 0.0
    pp_dv_frac: float = 0.0
    k1: float = 0.0
    k2: float = 0.0
    supersample: int = 3
    wall_grey: float = 85.0
    wall_texture: float = 14.0
    texture_scale: float = 14.0
    tile_m: float = 0.5
    floor_grey: float = 120.0
    texture_seed: int = 12345
    body_grey: int = 175
    barrier_grey: int = 120
    lamps: tuple = ()
    target_diameter: float = 0.1
    target_style: str = "black_white"
    target_light: int = 245
    target_rot45: bool = False
    hubs_visible: bool = True
    hubcap_grey: int = 150
    deform_targets: tuple = ()
    barrier_targets: tuple = ()
    floor_targets: tuple = ()
    tape_segment: float | None = 0.1
    tape_height: float = 0.04
    noise_sigma: float = 0.0
    exposure: float = 0.0
    blur_substeps: int = 1
    flicker: float = 0.0
    flicker_hz: float = 100.0
    gain: float = 1.0
    debris: int = 0
    occluders: tuple = ()
    shake_px: float = 0.0
    shake_hz: float = 20.0
    shake_decay_s: float = 0.05
    shake_angle: float = 0.0
    shake_roll_deg: float = 0.0
    noise_seed: int = 0

    def to_dict(self) -> dict:
        """The spec as JSON-ready plain values (tuples as lists)."""
        return _plain(dataclasses.asdict(self))


def _plain(v):
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def render_size(sensor_width: int, sensor_height: int, max_width: int = MAX_RENDER_WIDTH) -> tuple[int, int]:
    """Rendered size of a sensor: scaled down to at most ``max_width`` wide, both even."""
    s = min(1.0, max_width / sensor_width)
    return 2 * int(round(sensor_width * s / 2)), 2 * int(round(sensor_height * s / 2))


def random_footage(rng: np.random.Generator, car: Car, max_width: int = MAX_RENDER_WIDTH) -> FootageSpec:
    """Draw every knob of a film from ``rng`` (reproducible from its seed).

    Parameters
    ----------
    rng : numpy.random.Generator
    car : Car
        The vehicle filmed (its length sets the scale, hence the target sizes).
    max_width : int
        Render at most this wide (the sensor size is kept in the spec).

    Returns
    -------
    FootageSpec
    """
    u = rng.uniform
    sw, sh = SENSORS[int(rng.integers(len(SENSORS)))]
    w, h = render_size(sw, sh, max_width)
    fps = float(rng.choice([500.0, 1000.0], p=[0.3, 0.7]))
    frames_before = int(rng.integers(15, 41) if fps == 1000.0 else rng.integers(10, 26))
    fill = float(u(0.5, 0.72))
    mpp = car.length / (fill * w)  # m/px in the car plane (before any zoom-out at render time)
    d_lo, d_hi = max(0.05, 8.0 * mpp), min(0.15, 40.0 * mpp)
    diameter = float(u(d_lo, d_hi)) if d_hi > d_lo else float(np.clip(0.5 * (d_lo + d_hi), 0.05, 0.15))
    style = str(rng.choice(["black_white", "black_yellow"], p=[0.6, 0.4]))
    light = int(rng.integers(235, 251)) if style == "black_white" else int(rng.integers(190, 216))
    n_deform = int(rng.choice([0, 1, 2], p=[0.4, 0.35, 0.25]))
    deform = tuple((float(u(0.25, 0.6)), float(u(-0.5, 0.5))) for _ in range(n_deform))
    fixed_mode = int(rng.integers(4))  # 0 none, 1 barrier, 2 floor, 3 both
    n_bar = int(rng.integers(1, 3)) if fixed_mode in (1, 3) else 0
    n_floor = int(rng.integers(1, 3)) if fixed_mode in (2, 3) else 0
    barrier_targets = tuple((float(u(0, 1)), float(u(0.3, 1.3))) for _ in range(n_bar))
    floor_targets = tuple((float(u(0, 1)), float(u(0.3, 1.5))) for _ in range(n_floor))
    barrier_visible = float(u(0.35, 0.8))
    distance_car, barrier_offset = float(u(5.0, 14.0)), float(u(-0.6, 0.4))
    if n_bar:  # room on the barrier's side face, which a nearer barrier shows smaller
        half_view = 0.5 * car.length / fill
        barrier_visible = max(barrier_visible, 0.4 + diameter + half_view * max(0.0, -barrier_offset) / distance_car)
    tape = rng.choice([0, 1, 2], p=[0.45, 0.4, 0.15])
    tape_segment = (0.1, 0.05, None)[int(tape)]
    fmt = str(rng.choice(list(FORMATS), p=[0.45, 0.2, 0.2, 0.15]))
    container_fps = float(rng.choice([25.0, 30.0])) if fmt in ("mp4", "avi") and rng.uniform() < 0.3 else None
    n_lamps = int(rng.integers(0, 4))
    lamps = tuple((float(u(0.05, 0.95)), float(u(1.9, 3.2)), float(u(0.08, 0.25))) for _ in range(n_lamps))
    exposure = float(u(0.0, 0.6))
    body_names = ["roof_rail", "b_pillar", "door", "sill"]
    occluders = []
    for _ in range(int(rng.choice([0, 1, 2], p=[0.5, 0.35, 0.15]))):
        start = int(rng.integers(0, frames_before + 150))
        occluders.append((str(rng.choice(body_names)), start, int(rng.integers(4, 16))))
    shake = bool(rng.uniform() < 0.6)
    gain = float(u(1.05, 1.35)) if rng.uniform() < 0.3 else 1.0
    k1 = float(u(-0.15, 0.05)) if rng.uniform() < 0.7 else 0.0
    return FootageSpec(
        sensor_width=sw, sensor_height=sh, width=w, height=h, fps=fps, container_fps=container_fps,
        frames_before=frames_before, format=fmt, mp4_bpp=float(u(0.02, 0.12)),
        mjpeg_quality=int(rng.integers(40, 91)), direction=int(rng.choice([1, -1])), fill=fill,
        distance_car=distance_car, barrier_offset=barrier_offset,
        background_offset=float(u(2.0, 8.0)), view_z=float(u(0.5, 1.3)), barrier_visible=barrier_visible,
        yaw_deg=float(u(-3, 3)), pitch_deg=float(u(-3, 3)), roll_deg=float(u(-3, 3)),
        pp_du_frac=float(u(-0.03, 0.03)), pp_dv_frac=float(u(-0.03, 0.03)),
        k1=k1, k2=float(u(-0.02, 0.02)) if k1 else 0.0,
        supersample=3,
        wall_grey=float(u(45, 150)), wall_texture=float(u(4, 22)), texture_scale=float(u(6, 30)),
        tile_m=float(rng.choice([0.0, 0.25, 0.5, 1.0])), floor_grey=min(float(u(70, 170)), 215.0 / gain),
        texture_seed=int(rng.integers(2**31)), body_grey=min(int(rng.integers(90, 215)), int(225 / gain)),
        barrier_grey=int(rng.integers(70, 170)), lamps=lamps,
        target_diameter=diameter, target_style=style, target_light=light,
        target_rot45=bool(rng.uniform() < 0.3), hubs_visible=bool(rng.uniform() < 0.75),
        hubcap_grey=int(rng.integers(120, 200)), deform_targets=deform, barrier_targets=barrier_targets,
        floor_targets=floor_targets, tape_segment=tape_segment, tape_height=float(u(0.03, 0.05)),
        noise_sigma=float(u(0.3, 4.0)), exposure=exposure, blur_substeps=1 if exposure < 0.15 else (2 if exposure < 0.35 else 3),
        flicker=float(u(0.0, 0.04)) if rng.uniform() < 0.5 else 0.0, flicker_hz=float(rng.choice([100.0, 120.0])),
        gain=gain,
        debris=int(rng.integers(0, 80)) if rng.uniform() < 0.6 else 0, occluders=tuple(occluders),
        shake_px=float(u(0.5, 4.0)) if shake else 0.0, shake_hz=float(u(10, 40)),
        shake_decay_s=float(u(0.02, 0.12)), shake_angle=float(u(0, 2 * np.pi)),
        shake_roll_deg=float(u(0.0, 0.15)) if shake else 0.0, noise_seed=int(rng.integers(2**31)),
    )


# ------------------------------------------------------------------------ rendering


def _inside(car, x: float, z: float, margin: float) -> bool:
    poly = np.asarray(car.silhouette_side, dtype=np.float32)
    return cv2.pointPolygonTest(poly.reshape(-1, 1, 2), (float(x), float(z)), True) >= margin


def build_motion(car: Car, motion: dict, spec: FootageSpec) -> Motion:
    """The film's :class:`Motion`: ``spec.frames_before`` frames at the constant speed
    ``motion["v0"]``, then ``motion`` (arrays from t = 0 at ``spec.fps``).

    Raises
    ------
    SynthError
        Missing or ragged fields, a motion not starting at t = 0 or not sampled at
        ``spec.fps``.
    """
    arr = {}
    for name in MOTION_FIELDS:
        if name not in motion:
            raise SynthError(f"motion has no '{name}'; give {', '.join(MOTION_FIELDS)} and v0")
        arr[name] = np.asarray(motion[name], dtype=float).ravel()
    if "v0" not in motion:
        raise SynthError("motion has no 'v0' (approach speed, m/s)")
    n = arr["t"].size
    if n < 2 or any(a.size != n for a in arr.values()) or not all(np.all(np.isfinite(a)) for a in arr.values()):
        raise SynthError("motion fields must be finite and all of the same length (at least 2 samples)")
    dt = 1.0 / float(spec.fps)
    if abs(arr["t"][0]) > 1e-9 or not np.allclose(np.diff(arr["t"]), dt, rtol=1e-6, atol=1e-9):
        raise SynthError(f"motion must start at t = 0 and be sampled at spec.fps = {spec.fps:g} "
                         f"(got t[0] = {arr['t'][0]:g}, step {np.median(np.diff(arr['t'])):g} s)")
    v0 = float(motion["v0"])
    k = int(spec.frames_before)
    tb = -dt * np.arange(k, 0, -1)
    r = car.wheel_radius
    x_app = arr["x"][0] + v0 * tb
    roll0 = v0 * k * dt / r

    def pre(name):
        return np.concatenate([np.full(k, arr[name][0]), arr[name]])

    fw = np.concatenate([(x_app - x_app[0]) / r if k else np.zeros(0), roll0 + arr["front_wheel_angle"] - arr["front_wheel_angle"][0]])
    rw = np.concatenate([(x_app - x_app[0]) / r if k else np.zeros(0), roll0 + arr["rear_wheel_angle"] - arr["rear_wheel_angle"][0]])
    return Motion(t=np.concatenate([tb, arr["t"]]), x=np.concatenate([x_app, arr["x"]]), z=pre("z"),
                  pitch=pre("pitch"), front_wheel_angle=fw, rear_wheel_angle=rw,
                  front_wheel_dz=pre("front_wheel_dz"), rear_wheel_dz=pre("rear_wheel_dz"),
                  crush=np.concatenate([np.zeros(k), np.maximum(arr["crush"], 0.0)]))


def build_scene(car: Car, m: Motion, spec: FootageSpec) -> tuple[Scene, dict]:
    """The :class:`Scene` of a spec for a motion, and what the truth says of the layout
    (scale, zoom-out, fixed-target placement)."""
    if spec.direction not in (1, -1):
        raise SynthError(f"spec.direction must be +1 or -1, got {spec.direction}")
    W, H = int(spec.width), int(spec.height)
    xb = 0.0
    x_cg0 = cg_x_at_contact(car, xb)
    sil = np.asarray(car.silhouette_side, dtype=float)
    rear_first = x_cg0 + float(np.min(m.x)) - car.x_cg + float(sil[:, 0].min())
    D = spec.target_diameter
    floor_strip = len(spec.floor_targets) * (D + 0.2)
    right = xb + spec.barrier_visible
    left = rear_first - 0.15 - floor_strip
    mpp = car.length / (spec.fill * W)
    zoomed = False
    if (right - left) > 0.97 * W * mpp:
        mpp = (right - left) / (0.97 * W)
        zoomed = True
    x_mid = right - 0.5 * W * mpp + 0.015 * W * mpp
    d_car = spec.distance_car
    cam0 = Camera(width=W, height=H, m_per_px=mpp, centre_x=0.0, centre_z=0.0, distance_car=d_car,
                  distance_barrier=d_car + spec.barrier_offset, distance_background=d_car + spec.background_offset,
                  k1=spec.k1, k2=spec.k2, yaw=math.radians(spec.yaw_deg), pitch=math.radians(spec.pitch_deg),
                  roll=math.radians(spec.roll_deg), pp_du=spec.pp_du_frac * W, pp_dv=spec.pp_dv_frac * H)
    # the image centre sees (x_mid, view_z) in the car plane whatever the rotation and principal point
    Hi = np.linalg.inv(cam0.homography(d_car, spec.direction))
    p = Hi @ np.array([(W - 1) / 2.0, (H - 1) / 2.0, 1.0])
    X0, Z0 = p[:2] / p[2]
    cam = dataclasses.replace(cam0, centre_x=x_mid - X0, centre_z=spec.view_z - Z0)
    R = 0.5 * D
    tapes = default_tapes(car, segment=spec.tape_segment, height=spec.tape_height) if spec.tape_segment else ()
    # body targets where labs stick them (those that fit inside the silhouette)
    rear, wb, hgt = car.rear_axle_x, car.wheelbase, car.height
    top = np.asarray(car.windscreen_top, dtype=float)
    rot = math.pi / 4 if spec.target_rot45 else 0.0
    dark = 15
    light = int(spec.target_light)
    body = [("roof_rail", top[0] - 0.7, top[1] - 0.12 - max(0.0, R - 0.05)),
            ("b_pillar", rear + 0.52 * wb, 0.5 * (top[1] + 0.62 * hgt) - 0.1),
            ("door", rear + 0.72 * wb, 0.47 * hgt),
            ("sill", rear + 0.42 * wb, 0.2 * hgt + max(0.0, R - 0.05))]
    targets = [Target(n, "body", float(x), float(z), D, rot, dark=dark, light=light)
               for n, x, z in body if _inside(car, x, z, R + 0.01)]
    # targets on deforming parts (front wing above the wheel arch, bonnet edge): in the
    # middle of the body's height there, at least 0.55 m behind the front
    fa, fx = car.front_axle_x, front_x(car)
    missing = []  # asked for, but no room
    k = 0
    for follow, turn in spec.deform_targets:
        while k < len(_DEFORM_XS):
            x = min(fa + _DEFORM_XS[k], fx - 0.55 - R)
            k += 1
            zs = np.array([z for z in np.arange(2.0 * car.wheel_radius + R + 0.03, hgt, 0.01)
                           if _inside(car, x, z, R + 0.01)])
            if not zs.size:
                continue
            mid = 0.5 * (zs[0] + zs[-1])
            # clear of the tapes' heights (the target slides rearwards along the body)
            zs = [z for z in zs if all(z < tp.z - R - 0.02 or z > tp.z + tp.height + R + 0.02 for tp in tapes)]
            if not zs:
                continue
            z = min(zs, key=lambda q: abs(q - mid))
            if all(abs(x - t.x) > 2.5 * R or abs(z - t.z) > 2.5 * R for t in targets):
                targets.append(Target(f"deform{k}", "deform", float(x), float(z), D, rot,
                                      follow=float(follow), turn=float(turn), dark=dark, light=light))
                break
        else:
            missing.append("deform")
    if spec.hubs_visible:
        targets += [Target("front_hub", "front_hub", diameter=min(D * 1.2, 0.8 * car.wheel_radius), angle=rot,
                           dark=dark, light=light),
                    Target("rear_hub", "rear_hub", diameter=min(D * 1.2, 0.8 * car.wheel_radius), angle=rot,
                           dark=dark, light=light)]
    # fixed targets: on the barrier's side face, and on floor-standing plates behind the car
    d_bar = cam.distance_barrier
    edge = xb + spec.barrier_visible  # the view's right end in the car plane, seen on the barrier's plane:
    edge = min(edge, cam.centre_x + (edge - cam.centre_x) * d_bar / d_car)
    lo, hi = xb + 0.3 + R, edge - R - 0.05
    for j, (frac, z) in enumerate(spec.barrier_targets):
        if hi < lo:
            missing.append(f"barrier{j}")
        else:
            targets.append(Target(f"barrier{j}", "fixed", float(lo + frac * (hi - lo)), float(z), D, rot,
                                  depth=d_bar, dark=dark, light=light))
    # (placed where a car-plane point of the free strip behind the car is seen: a plate
    # nearer the camera than the car's side is drawn larger and farther from the centre)
    lo, hi = left + 0.05 + R, rear_first - 0.2 - R
    for j, (frac, off) in enumerate(spec.floor_targets):
        if hi < lo:
            missing.append(f"floor{j}")
        else:
            depth = max(d_car - off, 0.5 * d_car)
            x = cam.centre_x + (lo + frac * (hi - lo) - cam.centre_x) * depth / d_car
            targets.append(Target(f"floor{j}", "fixed", float(x), R + 0.03, D, rot,
                                  depth=float(depth), dark=dark, light=light))
    names = {t.name for t in targets}
    occluders = tuple(Occluder(n, int(s), int(s) + int(k_), radius=max(0.06, 0.8 * D))
                      for n, s, k_ in spec.occluders if n in names)
    # lamps on the wall, across the view
    d_bg = cam.distance_background
    span_bg = W * mpp * d_bg / d_car
    lamps = tuple((float(cam.centre_x + spec.direction * (f - 0.5) * span_bg), float(z), float(r))
                  for f, z, r in spec.lamps)
    effects = Effects(noise_sigma=spec.noise_sigma, blur_substeps=int(spec.blur_substeps), exposure=spec.exposure,
                      flicker=spec.flicker, flicker_hz=spec.flicker_hz, debris=int(spec.debris),
                      seed=int(spec.noise_seed), gain=spec.gain, shake_px=spec.shake_px, shake_hz=spec.shake_hz,
                      shake_decay_s=spec.shake_decay_s, shake_angle=spec.shake_angle,
                      shake_roll=math.radians(spec.shake_roll_deg))
    scene = Scene(car, cam, tuple(targets), tuple(tapes), xb, spec.direction, occluders=occluders, effects=effects,
                  supersample=int(spec.supersample), body_grey=int(spec.body_grey),
                  barrier_grey=int(spec.barrier_grey), target_dark=dark, target_light=light,
                  wall_grey=spec.wall_grey, wall_texture=spec.wall_texture, floor_grey=spec.floor_grey,
                  texture_scale=spec.texture_scale, tile_m=spec.tile_m, texture_seed=int(spec.texture_seed),
                  hubcap_grey=None if spec.hubs_visible else int(spec.hubcap_grey), lamps=lamps)
    layout = {"m_per_px_car_plane": mpp, "zoomed_out": zoomed, "front_x_m": front_x(car),
              "targets_not_placed": missing}
    return scene, layout


def render_film(car: Car, motion: dict, spec: FootageSpec, out_path, progress=None) -> dict:
    """Render a crash film with ``spec`` and write it with its truth.

    Parameters
    ----------
    car : Car
    motion : dict
        (n,) arrays from t = 0 (first contact) at ``spec.fps``: ``t, x, z, pitch, crush,
        front_wheel_angle, rear_wheel_angle, front_wheel_dz, rear_wheel_dz`` (CONVENTIONS
        pose; wheel dz: wheel-centre height minus the body's axle point), and scalar
        ``v0`` (approach speed, m/s).
    spec : FootageSpec
    out_path : str or Path
        ``*.mp4`` / ``*.avi`` file or a folder (png, tiff16), as ``spec.format`` says;
        the truth goes beside it (``<stem>.truth.json``, ``<stem>.truth.csv``).
    progress : callable, optional
        Called with a message every 100 frames.

    Returns
    -------
    dict
        Film-level truth (also in the JSON): true ``fps``, ``container_fps``,
        ``contact_frame``, ``impact_speed_mps``, scale, camera, ``targets`` (with
        ``deforms``), ``hubs_visible``, ``tape_segment``, ``shake_px``, ``encoder``,
        ``spec`` (every knob).
    """
    if spec.format not in FORMATS:
        raise SynthError(f"spec.format must be one of {', '.join(FORMATS)}, got {spec.format!r}")
    out_path = Path(out_path)
    m = build_motion(car, motion, spec)
    scene, layout = build_scene(car, m, spec)
    renderer = Renderer(scene, m)
    container_fps = float(spec.fps if spec.container_fps is None else spec.container_fps)
    bitrate = spec.mp4_bpp * spec.width * spec.height * container_fps
    rows = []
    with FilmWriter(out_path, spec.format, spec.width, spec.height, container_fps, bitrate=bitrate,
                    quality=spec.mjpeg_quality) as writer:
        for i in range(m.n):
            frame = renderer.render_float(i)
            writer.write(frame)
            rows.append(dict(renderer.truth_row(i), written_index=i))
            if progress is not None and i % 100 == 99:
                progress(f"{i + 1}/{m.n} frames")
        encoder = writer.encoder
    meta = renderer.truth_meta()
    meta.update(
        fps=float(spec.fps), container_fps=container_fps, format=spec.format, encoder=encoder,
        mp4_bitrate=bitrate if spec.format == "mp4" else None, frames_before=int(spec.frames_before),
        sensor_size=[spec.sensor_width, spec.sensor_height], hubs_visible=bool(spec.hubs_visible),
        tape_segment=spec.tape_segment, shake_px=float(spec.shake_px), shake_hz=float(spec.shake_hz),
        zoomed_out=layout["zoomed_out"], targets_not_placed=layout["targets_not_placed"],
        duplicated_frames_written=[],
        fixed_targets=[t for t in meta["targets"] if t["kind"] == "fixed"],
        occluders=[{"target": o.target, "start": o.start, "stop": o.stop, "radius_m": o.radius}
                   for o in scene.occluders],
        lamps=[list(x) for x in scene.lamps], spec=spec.to_dict(),
    )
    write_truth(out_path, meta, rows)
    return _json_clean(meta)
