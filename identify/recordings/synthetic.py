"""Synthetic crash films with known truth: vehicle file -> CarGeometry, trajectory ->
film (``synth.render``, the reference world's renderer), and, with the collision model,
simulate-and-render.

This lives in ``identify`` (not ``synth`` or ``video``) because it calls ``sim``; ``video``
reads footage and never makes it, and ``synth`` never imports ``sim``.

Example
-------
>>> from identify.recordings.synthetic import render_crash, analytic_trajectory
>>> traj = analytic_trajectory(speed=15.64)                        # doctest: +SKIP
>>> render_crash("audi_a4", traj, "crash.mp4")                     # doctest: +SKIP
"""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np

from identify.errors import UserError
from sim._paths import VEHICLE_DIR
from sim.ground import wheel_centre_rise
from video.types import CarGeometry

_GEOMETRY_KEYS = ("length", "height", "wheelbase", "front_overhang", "wheel_radius", "cg_height", "cg_to_front_axle",
                  "mass")
TRAJECTORY_FIELDS = ("t", "x", "z", "pitch", "crush", "front_wheel_angle", "rear_wheel_angle")


def _unit(key: str) -> str:
    return "kilograms" if key == "mass" else "metres"


def car_geometry(vehicle: dict) -> CarGeometry:
    """Build the video stage's :class:`CarGeometry` from a parsed vehicle TOML dict.

    Parameters
    ----------
    vehicle : dict
        As ``tomllib.load`` returns it for ``data/vehicles/<name>.toml`` (lengths in m).

    Returns
    -------
    CarGeometry

    Raises
    ------
    UserError
        A missing or non-positive dimension, or a silhouette that is not a polygon.
    """
    name = vehicle.get("name", "vehicle file")
    values = {}
    for key in _GEOMETRY_KEYS:
        if key not in vehicle:
            raise UserError(f"{name}: '{key}' is missing from the vehicle file; add it ({_unit(key)})")
        try:
            v = float(vehicle[key])
        except (TypeError, ValueError):
            raise UserError(f"{name}: '{key}' = {vehicle[key]!r} is not a number") from None
        if not np.isfinite(v) or v <= 0:
            raise UserError(f"{name}: '{key}' = {v} must be positive ({_unit(key)})")
        values[key] = v
    sil = np.asarray(vehicle.get("silhouette_side", []), dtype=float)
    if sil.ndim != 2 or sil.shape[1] != 2 or sil.shape[0] < 3 or not np.all(np.isfinite(sil)):
        raise UserError(f"{name}: 'silhouette_side' must be a list of at least 3 [x, z] points in metres")
    if "windscreen_top" in vehicle:
        top = np.asarray(vehicle["windscreen_top"], dtype=float)
        if top.shape != (2,):
            raise UserError(f"{name}: 'windscreen_top' must be one [x, z] point in metres")
    else:
        top = sil[np.argmax(sil[:, 1])]
    return CarGeometry(silhouette_side=sil, windscreen_top=top, **values)


def reference_car(vehicle):
    """The renderer's car (:class:`synth.vehicle.Car`) of a vehicle name, TOML path or
    parsed TOML dict; a car object (``Car`` or ``CarGeometry``) is returned as it is, and
    so is the geometry of a dict that has only the dimensions the film needs.

    Raises
    ------
    UserError
        Unknown vehicle, or a file that is not a valid vehicle.
    """
    from synth.vehicle import SynthError, car_from_dict

    if isinstance(vehicle, (str, Path)):
        vehicle = load_vehicle_dict(vehicle)
    if not isinstance(vehicle, dict):
        return vehicle
    geometry = car_geometry(vehicle)  # the same checks and messages as the video stage's
    try:
        return car_from_dict(vehicle, str(vehicle.get("name", "vehicle file")))
    except SynthError:
        return geometry  # no mass, inertia ...: the renderer needs only the geometry


def load_vehicle_dict(name_or_path: str | Path) -> dict:
    """Parse a vehicle TOML by name (``data/vehicles/<name>.toml``) or path."""
    p = Path(name_or_path)
    if not p.suffix:
        p = VEHICLE_DIR / f"{name_or_path}.toml"
    if not p.exists():
        known = ", ".join(sorted(q.stem for q in VEHICLE_DIR.glob("*.toml")))
        raise UserError(f"unknown vehicle {name_or_path!r}: no file {p}; known: {known}")
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except tomllib.TOMLDecodeError as err:
        raise UserError(f"vehicle file {p} is not valid TOML: {err}") from None


def _field(traj, name: str):
    if isinstance(traj, dict):
        return traj.get(name)
    return getattr(traj, name, None)


def analytic_trajectory(speed: float = 15.64, duration: float = 0.3, fps: float = 1000.0,
                        pulse_s: float = 0.12, max_pitch: float = 0.06, max_lift: float = 0.03,
                        wheel_radius: float = 0.32) -> dict:
    """A crash-like trajectory from closed forms, for tests without ``sim``.

    ``x = v0 sin(w t) / w`` (a half-sine deceleration pulse of ``pulse_s`` to maximum
    crush, then rebound), pitch and lift rising and falling with it.

    Parameters
    ----------
    speed : float
        Impact speed, m/s.
    duration : float
        Time after contact, s.
    fps : float
        Samples per second.
    pulse_s : float
        Time from contact to maximum crush, s.
    max_pitch : float
        Peak pitch, rad (nose-down positive).
    max_lift : float
        Peak CG lift, m.
    wheel_radius : float
        For the wheel angles (rolling without slip), m.

    Returns
    -------
    dict of (n,) float64
        ``t, x, z, pitch, crush, front_wheel_angle, rear_wheel_angle`` (t from 0).
    """
    t = np.arange(int(round(duration * fps)) + 1) / fps
    w = np.pi / (2.0 * pulse_s)
    x = speed * np.sin(w * t) / w
    shape = np.sin(np.clip(w * t, 0, np.pi)) ** 2
    spin = x / wheel_radius
    return {"t": t, "x": x, "z": max_lift * shape, "pitch": max_pitch * shape, "crush": x.copy(),
            "front_wheel_angle": spin, "rear_wheel_angle": spin.copy()}


def wheel_offsets(axle_z: np.ndarray, margin: np.ndarray, wheel_radius: float) -> np.ndarray:
    """Vertical offset of a wheel centre from its body axle point, frame by frame: on the
    floor (centre at ``wheel_radius``) while the model's contact margin is >= 0, else
    raised with the axle point (``sim.ground.wheel_centre_rise``).

    Parameters
    ----------
    axle_z : (n,) float
        Car-plane Z of the body's axle point (at wheel-radius height in the vehicle
        frame), m.
    margin : (n,) float
        The model's axle contact margin (N; negative: wheel off the ground).
    wheel_radius : float
        m.

    Returns
    -------
    (n,) float
        Offset to add to the axle point's Z, m.
    """
    axle_z = np.asarray(axle_z, dtype=float)
    return wheel_radius + np.asarray(wheel_centre_rise(axle_z, margin)) - axle_z


def render_crash(vehicle, trajectory, out_path: str | Path, *, frames_before: int = 30,
                 speed: float | None = None, width: int = 640, height: int = 480,
                 m_per_px: float | None = None, direction: int = 1, effects=None,
                 container_fps: float | None = None, wheels_on_floor: bool = True,
                 tape_segment: float = 0.1, occluders: tuple = (), duplicate: tuple = (),
                 camera_kwargs: dict | None = None, barrier_target: bool = False) -> dict:
    """Render a crash film with known truth: constant-speed approach, then ``trajectory``.

    Parameters
    ----------
    vehicle : str, Path, dict, synth.vehicle.Car or CarGeometry
        A name from ``data/vehicles``, a vehicle TOML path, a parsed TOML dict, or a car
        (anything with the geometry of :class:`synth.vehicle.Car`).
    trajectory : mapping or object with fields ``t, x, z, pitch, front_wheel_angle,
        rear_wheel_angle`` (and optionally ``crush``), each (n,), sampled at a constant
        step from ``t = 0`` at first contact (SI units, pitch nose-down positive), e.g. a
        ``sim.Trajectory``.
    out_path : str or Path
        ``.mp4`` / ``.avi`` / ``.mov`` file, or a folder for numbered PNG frames; the
        truth goes beside it (``<stem>.truth.json``, ``<stem>.truth.csv``).
    frames_before : int
        Frames of constant-speed approach before contact.
    speed : float, optional
        Approach speed, m/s; default: the trajectory's velocity at t = 0 (one-sided
        second-order difference of x).
    width, height : int
        Image size, px.
    m_per_px : float, optional
        Scale in the car plane; default: the scene fits the width.
    direction : int
        +1 left-to-right, -1 right-to-left.
    effects : synth.scene.Effects, optional
    container_fps : float, optional
        Rate written into the container (default the true rate).
    wheels_on_floor : bool
        Without ``front_margin``/``rear_margin`` in the trajectory: lift a wheel onto the
        floor where its body axle point would put it below (the suspension compressing);
        otherwise wheels stay at their axle points. With them (a ``sim.Trajectory``),
        see :func:`wheel_offsets`.
    tape_segment : float
        Checker-tape segment length, m.
    occluders, duplicate : tuple
        See :class:`synth.scene.Occluder` and :func:`synth.render.write_film`.
    camera_kwargs : dict, optional
        Other :class:`synth.scene.Camera` fields (distances, k1, k2, yaw, pitch, roll ...).
    barrier_target : bool
        Add a fixed quadrant target (0.12 m) on the barrier's side face, 0.2 m past its
        face and 1.0 m above the floor.

    Returns
    -------
    dict
        Film-level truth (contact frame, impact speed, m/px ...).
    """
    from synth.render import Renderer, write_film
    from synth.scene import Effects, Motion, Scene, Target, body_to_plane, default_camera, default_tapes, default_targets

    car = reference_car(vehicle)
    arr = {}
    for name in ("t", "x", "z", "pitch", "front_wheel_angle", "rear_wheel_angle", "crush"):
        v = _field(trajectory, name)
        if v is None:
            if name == "crush":
                continue
            raise UserError(f"trajectory has no '{name}'; give t, x, z, pitch, front_wheel_angle, rear_wheel_angle")
        arr[name] = np.asarray(v, dtype=float).ravel()
    n = arr["t"].size
    if n < 2 or any(a.size != n for a in arr.values()):
        raise UserError("trajectory fields must all have the same length (at least 2 samples)")
    dt = float(np.median(np.diff(arr["t"])))
    if not dt > 0 or not np.allclose(np.diff(arr["t"]), dt, rtol=1e-6, atol=1e-9):
        raise UserError("trajectory must be sampled at a constant, positive time step")
    if abs(arr["t"][0]) > 1e-9:
        raise UserError(f"trajectory must start at contact (t = 0), it starts at t = {arr['t'][0]}")
    if speed is None:  # one-sided second-order difference at t = 0
        x = arr["x"]
        v0 = float((-3 * x[0] + 4 * x[1] - x[2]) / (2 * dt)) if n >= 3 else float((x[1] - x[0]) / dt)
    else:
        v0 = float(speed)
    k = int(frames_before)
    tb = -dt * np.arange(k, 0, -1)
    t = np.concatenate([tb, arr["t"]])
    x = np.concatenate([v0 * tb, arr["x"]])
    z = np.concatenate([np.zeros(k), arr["z"]])
    pitch = np.concatenate([np.zeros(k), arr["pitch"]])
    roll0 = v0 * k * dt / car.wheel_radius
    fw = np.concatenate([roll0 + v0 * tb / car.wheel_radius, roll0 + arr["front_wheel_angle"]])
    rw = np.concatenate([roll0 + v0 * tb / car.wheel_radius, roll0 + arr["rear_wheel_angle"]])
    crush = np.concatenate([np.zeros(k), arr["crush"]]) if "crush" in arr else None
    fdz = rdz = None
    axles = np.array([[car.front_axle_x, car.wheel_radius], [car.rear_axle_x, car.wheel_radius]])
    Zs = np.array([body_to_plane(axles, car, {"x": a, "z": b, "pitch": c}, 0.0)[:, 1] for a, b, c in zip(x, z, pitch)])
    margins = [_field(trajectory, "front_margin"), _field(trajectory, "rear_margin")]
    if all(v is not None for v in margins):
        fdz, rdz = (wheel_offsets(Zs[:, j], np.concatenate([np.ones(k), np.asarray(margins[j], dtype=float).ravel()]),
                                  car.wheel_radius) for j in (0, 1))
    elif wheels_on_floor:
        fdz = np.maximum(car.wheel_radius - Zs[:, 0], 0.0)
        rdz = np.maximum(car.wheel_radius - Zs[:, 1], 0.0)
    motion = Motion(t=t, x=x, z=z, pitch=pitch, front_wheel_angle=fw, rear_wheel_angle=rw,
                    front_wheel_dz=fdz, rear_wheel_dz=rdz, crush=crush)
    approach = v0 * k * dt + max(0.0, -float(np.min(arr["x"]))) + 0.05
    camera = default_camera(car, 0.0, width, height, m_per_px=m_per_px, approach_m=approach, **(camera_kwargs or {}))
    targets = default_targets(car)
    if barrier_target:
        targets = targets + (Target("barrier", "fixed", 0.2, 1.0, 0.12),)
    scene = Scene(car, camera, targets, default_tapes(car, segment=tape_segment), 0.0, direction,
                  occluders=tuple(occluders), effects=effects if effects is not None else Effects())
    meta = write_film(Renderer(scene, motion), out_path, container_fps=container_fps, duplicate=tuple(duplicate))
    return meta


def simulate_and_render(vehicle: str = "audi_a4", params: str = "paper_identified", speed_kmh: float = 56.3,
                        out_path: str | Path = "crash.mp4", duration: float = 0.3, **render_kwargs) -> dict:
    """Simulate a crash with the base model (``sim`` with ``params`` and the engine on its
    mounts that ``identify fit``'s base model holds, ``identify.discover.candidates.with_base_mechanisms``)
    and render it (:func:`render_crash`).

    Parameters
    ----------
    vehicle : str
        Vehicle name or TOML path.
    params : str
        Named parameter set or JSON path (as ``identify simulate --params``).
    speed_kmh : float
        Impact speed, km/h.
    out_path : str or Path
        Film to write (truth beside it).
    duration : float
        Simulated time after contact, s.
    **render_kwargs
        Passed to :func:`render_crash`.

    Returns
    -------
    dict
        Film-level truth, with ``vehicle``, ``params`` and the simulated events added to
        the JSON beside the film.

    Notes
    -----
    Turns on JAX float64 (``sim`` needs it), as the command line's entry points do.
    """
    import jax

    jax.config.update("jax_enable_x64", True)
    from identify.discover.candidates import with_base_mechanisms
    from sim import events_ms, load_params, load_vehicle, simulate

    veh = load_vehicle(vehicle)
    p = with_base_mechanisms(load_params(params), veh)
    v0 = speed_kmh / 3.6
    traj = simulate(p, veh, speed=v0, duration=duration)
    arrays = {name: np.asarray(getattr(traj, name)) for name in TRAJECTORY_FIELDS + ("front_margin", "rear_margin")}
    render_crash(vehicle, arrays, out_path, speed=v0, **render_kwargs)
    from synth.render import update_truth

    events = {k: (None if v is None else float(v)) for k, v in events_ms(traj).items()}
    return update_truth(out_path, {"vehicle": str(vehicle), "params": str(params),
                                   "impact_speed_kmh": float(speed_kmh), "events_ms": events})
