"""One synthetic crash test of the reference world, from a seed: the car, its hidden
physics, the concealed effect, the lab's camera or sensors; written as the recording a
user would hand ``identify fit``, its ``vehicle.toml`` and ``truth.json``.

    world = make_world(seed=7, effect="stiffness_zone")
    truth = write_world(world, Path("world7"))            # world7/crash.mp4, vehicle.toml, truth.json

Random streams: the seed's physics and its footage come from separate children of one
``numpy.random.SeedSequence``, so a change to the footage code never changes the physics
of a seed, and the other way round.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from synth.vehicle import Car, SynthError, car_to_toml, known_vehicles, load_car

EFFECTS = ("clean", "stiffness_zone", "front_wheel_block", "rate_dependence", "engine_impact", "rear_axle_lift")
FORMATS = ("film", "isomme", "motion")
SPEED_RANGE_KMH = (48.0, 64.0)
DURATION_S = 0.3          # simulated time after first contact
SENSOR_RATE_HZ = 10000.0  # ISO-MME sampling rate
MOTION_RATE_HZ = 1000.0   # the world's own motion (format "motion"), sampled as a 1000 fps film
MOTION_FRAMES_BEFORE = 20  # its samples of the free approach before first contact
# the sigmas a motion recording states (no noise is added): a good film's tracking of x and z
# and its pitch, the hubs' angles (interface units)
MOTION_SIGMA = {"x_m": 2e-4, "z_m": 2e-4, "pitch_rad": 5e-4, "front_wheel_angle_rad": 0.01,
                "rear_wheel_angle_rad": 0.01}

# the interface's names (docs/interface.md) of the quantities the fit reports
INTERFACE_PARAMS = ("k_compression", "k_restitution", "restitution", "dz_contact")
# what each effect's truth reports of its own parameters (RefParams field names)
EFFECT_PARAMS = {
    "stiffness_zone": ("zone_depth", "k_zone"),
    "front_wheel_block": ("jam_depth", "release_margin"),
    "rate_dependence": ("rate_coefficient",),
    "engine_impact": ("engine_mass", "engine_gap", "engine_stiffness", "engine_restitution"),
    "rear_axle_lift": ("dz_contact",),
}


@dataclass(frozen=True)
class World:
    """A reference-world crash test before it is written.

    Attributes
    ----------
    seed : int
    effect : str
        One of :data:`EFFECTS` (``random`` already drawn).
    fmt : str
        ``film`` or ``isomme``.
    car : Car
        The car as the lab's vehicle file describes it (written as ``vehicle.toml``).
    vehicle_source : str
        The shipped vehicle (or file) it was drawn from.
    params : synth.physics.RefParams
        The hidden physics (truth).
    v0 : float
        Impact speed, m/s.
    footage : synth.footage.FootageSpec or None
        The camera, targets, tapes, degradations and file format (films only).
    """

    seed: int
    effect: str
    fmt: str
    car: Car
    vehicle_source: str
    params: object
    v0: float
    footage: object = None

    @property
    def rate_hz(self) -> float:
        """Sampling rate of the recording: the film's frame rate, the sensors' or the motion's."""
        if self.footage is not None:
            return float(self.footage.fps)
        return MOTION_RATE_HZ if self.fmt == "motion" else SENSOR_RATE_HZ


def _streams(seed: int) -> tuple[np.random.Generator, np.random.Generator, np.random.Generator]:
    """(world, physics, footage) generators of a seed, independent of each other."""
    children = np.random.SeedSequence([int(seed), 0x5EED]).spawn(3)
    return tuple(np.random.default_rng(c) for c in children)


def perturbed_car(rng: np.random.Generator, car: Car) -> Car:
    """A car like ``car`` as another lab would weigh and measure it: test mass +-5 %, CG
    position +-3 % (height +-5 %), pitch inertia +-10 %, suspension +-15 %."""
    u = lambda width: 1.0 + rng.uniform(-width, width)  # noqa: E731
    return car.replace(
        name=f"{car.name} (reference-world variant)",
        mass=car.mass * u(0.05),
        cg_to_front_axle=car.cg_to_front_axle * u(0.03),
        cg_height=car.cg_height * u(0.05),
        pitch_inertia=car.pitch_inertia * u(0.10),
        axle_stiffness=tuple(k * u(0.15) for k in car.axle_stiffness),
        axle_damping=tuple(c * u(0.15) for c in car.axle_damping),
    )


def make_world(seed: int, effect: str = "clean", vehicle: str | Path | None = None, fmt: str = "film",
               footage_overrides: dict | None = None) -> World:
    """Draw a world from ``seed``.

    Parameters
    ----------
    seed : int
        >= 0.
    effect : str
        One of :data:`EFFECTS` or ``random`` (drawn from the seed).
    vehicle : str or Path, optional
        A shipped vehicle name or a TOML path, used as it is; default: a shipped vehicle
        drawn from the seed, perturbed as another lab's test car would be.
    fmt : str
        ``film``, ``isomme`` or ``motion`` (the simulated motion itself as a ``tracks.csv``:
        what the model alone gets wrong, with no camera or tracker in between).
    footage_overrides : dict, optional
        FootageSpec fields to set instead of drawing them (tests that need an easy film).

    Raises
    ------
    SynthError
        Negative seed, unknown effect or format, a bad vehicle.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise SynthError(f"--seed must be a whole number >= 0, got {seed!r}")
    if effect != "random" and effect not in EFFECTS:
        raise SynthError(f"unknown effect {effect!r}; choose one of {', '.join(EFFECTS)} or random")
    if fmt not in FORMATS:
        raise SynthError(f"unknown format {fmt!r}; choose film, isomme or motion")
    from synth.physics import random_params

    rng_world, rng_phys, rng_foot = _streams(int(seed))
    if effect == "random":
        effect = str(rng_world.choice(EFFECTS))
    if vehicle is None:
        source = str(rng_world.choice(known_vehicles()))
        car = perturbed_car(rng_world, load_car(source))
    else:
        source = str(vehicle)
        car = load_car(vehicle)
    v0 = float(rng_world.uniform(*SPEED_RANGE_KMH)) / 3.6
    params = random_params(rng_phys, car, effect, v0=v0)
    footage = None
    if fmt == "film":
        from synth.footage import random_footage

        footage = random_footage(rng_foot, car)
        if footage_overrides:
            footage = dataclasses.replace(footage, **footage_overrides)
    return World(seed=int(seed), effect=effect, fmt=fmt, car=car, vehicle_source=source, params=params,
                 v0=v0, footage=footage)


def _clean(v):
    """JSON-ready: numpy to Python, non-finite floats to None, dataclasses to dicts."""
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return {f.name: _clean(getattr(v, f.name)) for f in dataclasses.fields(v)}
    if isinstance(v, np.ndarray):
        return _clean(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    return v


def effects_truth(world: World) -> list[dict]:
    """The concealed effects of a world as ``[{"name", "parameters"}]`` (empty when clean)."""
    if world.effect == "clean":
        return []
    names = EFFECT_PARAMS[world.effect]
    return [{"name": world.effect, "parameters": {n: _clean(getattr(world.params, n)) for n in names}}]


def _series(motion, v0: float, frames_before: int) -> dict:
    """The truth's motion on the recording's clock: ``frames_before`` samples of constant-
    speed approach, then the simulated motion (interface conventions)."""
    t = np.asarray(motion.t, dtype=float)
    dt = float(np.median(np.diff(t)))
    tb = -dt * np.arange(frames_before, 0, -1)
    zeros = np.zeros(frames_before)
    return {
        "t_ms": np.round(1e3 * np.concatenate([tb, t]), 6),
        "x_m": np.concatenate([v0 * tb, motion.x]),
        "z_m": np.concatenate([zeros, motion.z]),
        "pitch_rad": np.concatenate([zeros, motion.pitch]),
        "crush_m": np.concatenate([zeros, motion.crush]),
    }


def write_motion_tracks(path: Path, series: dict, motion, wheel_radius: float) -> None:
    """The simulated motion as a ``tracks.csv`` (``docs/interface.md``): the truth's
    ``series`` (:func:`_series`: the free approach, then x, z and pitch as simulated) and the
    wheels' angles (rolling on ``wheel_radius``, m, before contact, then as simulated), exact,
    each with the sigma of ``MOTION_SIGMA`` (a good film's tracking; no noise is added)."""
    before = len(series["t_ms"]) - len(motion.t)
    rolled = np.asarray(series["x_m"][:before]) / wheel_radius
    columns = {
        **{name: series[name] for name in ("x_m", "z_m", "pitch_rad")},
        "front_wheel_angle_rad": np.concatenate([rolled, motion.front_wheel_angle]),
        "rear_wheel_angle_rad": np.concatenate([rolled, motion.rear_wheel_angle]),
    }
    header = ["t_ms"] + [c for name in columns for c in (name, f"{name}_sigma")]
    rows = [header]
    for k, t_ms in enumerate(series["t_ms"]):
        rows.append([f"{t_ms:.6f}"] + [v for name, values in columns.items()
                                       for v in (f"{values[k]:.9g}", f"{MOTION_SIGMA[name]:g}")])
    path.write_text("".join(",".join(r) + "\n" for r in rows))


def film_name(fmt: str) -> str:
    """The recording's file (or frame folder) name inside a world's folder for a film format."""
    return {"mp4": "crash.mp4", "avi": "crash.avi", "png": "crash_frames", "tiff16": "crash_frames"}[fmt]


def check_out_folder(out: Path) -> None:
    """Raise SynthError unless ``out`` is free for a world: absent, or an empty folder."""
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise SynthError(f"{out} exists and is not an empty folder; choose a new --out (nothing was changed)")


def write_world(world: World, out: Path, progress=None, workdir: Path | None = None) -> dict:
    """Simulate the world and write its folder: the recording, ``vehicle.toml`` and
    ``truth.json``; return the truth.

    The folder is built under a temporary name beside ``out`` and renamed, so a failure
    leaves nothing half-written; ``out`` must not exist, or be an empty folder.
    ``workdir``, an empty folder beside ``out`` made by the caller (who can then remove it
    on Ctrl-C), is used as that temporary folder instead of a new one.

    Raises
    ------
    SynthError
        ``out`` exists and is not an empty folder, or cannot be written.
    """
    from synth.physics import simulate_reference

    out = Path(out)
    check_out_folder(out)
    parent = out.resolve().parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(workdir) if workdir is not None else Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=parent))
    except OSError as err:
        raise SynthError(f"cannot write in {parent}: {err.strerror or err}") from None
    try:
        say = progress or (lambda msg: None)
        say(f"simulating the reference car ({world.effect}, {3.6 * world.v0:.1f} km/h)")
        motion = simulate_reference(world.car, world.params, world.v0, duration=DURATION_S, fps=world.rate_hz)
        (tmp / "vehicle.toml").write_text(car_to_toml(
            world.car, f"reference world seed {world.seed}: the lab's vehicle file (from {world.vehicle_source})"))
        truth = {
            "seed": world.seed,
            "format": world.fmt,
            "vehicle": "vehicle.toml",
            "vehicle_source": world.vehicle_source,
            "params": {n: float(getattr(world.params, n)) for n in INTERFACE_PARAMS},
            "effects": effects_truth(world),
            "v0_kmh": 3.6 * world.v0,
            "events_ms": dict(motion.events_ms),
            "max_crush_m": float(motion.max_crush),
            "hidden": _clean(world.params),
        }
        if world.fmt == "film":
            from synth.footage import render_film

            spec = world.footage
            name = film_name(spec.format)
            say(f"rendering {len(motion.t) + spec.frames_before} frames ({spec.format}, {spec.fps:g} fps)")
            frames = {k: np.asarray(getattr(motion, k)) for k in
                      ("t", "x", "z", "pitch", "crush", "front_wheel_angle", "rear_wheel_angle",
                       "front_wheel_dz", "rear_wheel_dz")}
            frames["v0"] = world.v0
            meta = render_film(world.car, frames, spec, tmp / name)
            truth.update(recording=name, fps=float(spec.fps), tape_segment=spec.tape_segment,
                         series=_series(motion, world.v0, spec.frames_before), footage=meta)
        elif world.fmt == "motion":
            name = "motion.tracks.csv"
            series = _series(motion, world.v0, MOTION_FRAMES_BEFORE)
            write_motion_tracks(tmp / name, series, motion, world.car.wheel_radius)
            truth.update(recording=name, fps=MOTION_RATE_HZ, tape_segment=None, series=series)
        else:
            from synth.isomme import write_isomme

            rng = np.random.default_rng(np.random.SeedSequence([world.seed, 0x150]))
            folder = tmp / "crash_isomme"
            folder.mkdir()
            meta = write_isomme(folder, f"SYN{world.seed:05d}", motion, world.car.mass, rng,
                                title=f"reference world seed {world.seed}, {world.effect}")
            truth.update(recording=f"crash_isomme/{meta['mme']}", fps=meta["rate_hz"], tape_segment=None,
                         series=_series(motion, world.v0, int(round(meta["pre_trigger_s"] * meta["rate_hz"]))),
                         sensors=meta)
            truth["series"]["cabin_accel_x_mps2"] = np.concatenate(
                [np.zeros(len(truth["series"]["t_ms"]) - len(motion.t)), motion.cabin_accel_x])
            truth["series"]["force_barrier_n"] = np.concatenate(
                [np.zeros(len(truth["series"]["t_ms"]) - len(motion.t)), motion.force_barrier])
        (tmp / "truth.json").write_text(json.dumps(_clean(truth), indent=1))
        _publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return _clean(truth)


def _publish(tmp: Path, out: Path) -> None:
    """Rename the finished temporary folder to ``out`` with the user's umask applied
    (``mkdtemp`` makes it 0700)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o777 & ~umask)
    if out.exists():  # an empty folder, checked above
        out.rmdir()
    os.replace(tmp, out)


def read_truth(folder: str | Path) -> dict:
    """A world's ``truth.json`` with its series as numpy arrays."""
    truth = json.loads((Path(folder) / "truth.json").read_text())
    truth["series"] = {k: np.asarray(v, dtype=float) for k, v in truth["series"].items()}
    return truth
