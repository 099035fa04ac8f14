"""The vehicle: mass, geometry, inertia and suspension, read from a vehicle file.

A vehicle file (``data/vehicles/<name>.toml``, format in ``docs/interface.md``) gives
lengths in m, mass in kg, inertia in kg m^2. ``load_vehicle`` validates every field and
returns a :class:`Vehicle`, a pytree whose numbers are JAX arrays (so a simulation can be
differentiated or vmapped with respect to mass, inertia or geometry) and whose name and
outline are static metadata.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from sim._paths import VEHICLE_DIR
from sim.errors import ConfigError

GRAVITY = 9.81  # m/s^2

# Defaults of the optional suspension fields, used when a vehicle file leaves them out:
# per axle k = m_axle (2 pi f)^2 with ride frequency f = 1.4 Hz front, 1.6 Hz rear, and
# damping ratio 0.3, c = 2 * 0.3 * sqrt(k m_axle). These are the textbook ride
# frequencies of passenger cars (Gillespie, Fundamentals of Vehicle Dynamics, ch. 6).
DEFAULT_RIDE_FREQUENCY_HZ = (1.4, 1.6)
DEFAULT_DAMPING_RATIO = 0.3
# kg m^2 per wheel: a passenger car's wheel, tyre, hub and brake disc (16-17 inch; a 225/55 R16
# tyre of 10 kg near the rolling radius and a 9 kg rim make 1.0-1.3 kg m^2). Two per axle.
DEFAULT_WHEEL_SPIN_INERTIA = 1.1

_POSITIVE_FIELDS = (
    "mass",
    "length",
    "width",
    "height",
    "wheelbase",
    "front_overhang",
    "cg_height",
    "cg_to_front_axle",
    "pitch_inertia",
    "wheel_radius",
    "contact_area",
)


class Vehicle(eqx.Module):
    """A car seen from the side, as the collision model needs it.

    Numbers are float64 JAX arrays (pytree leaves); ``key``, ``name``, ``silhouette_side``
    and ``windscreen_top`` are static metadata.

    Attributes
    ----------
    mass : kg
    pitch_inertia : kg m^2, about the CG's lateral axis.
    cg_height : m above the ground.
    cg_to_front_axle : m, horizontal, CG to front axle (``a``).
    wheelbase : m (``a + b``).
    front_overhang : m, front axle to front bumper.
    length, width, height : m, overall.
    wheel_radius : m.
    contact_area : m^2, the crush-zone face that meets the barrier; a stiffness per unit
        area (N/m^3) times this gives a stiffness in N/m.
    axle_stiffness : (2,) N/m, front then rear: suspension and tyre in series, per axle.
    axle_damping : (2,) N s/m, front then rear.
    wheel_spin_inertia : (2,) kg m^2, front then rear: each axle's two wheels about their
        spin axis (``sim.wheels``; 0: none, as in V-SIM's model).
    silhouette_side : ((x, z), ...) m, side outline, x forward from the rear bumper, z up.
    windscreen_top : (x, z) m, the roof edge at the top of the windscreen, or None.
    engine_mass : kg, the engine and gearbox (the second body of
        ``sim.mechanisms.EngineImpact``), or None when the file does not say.
    engine_gap : m, structure crush at which the engine meets the barrier, or None.
    """

    mass: jnp.ndarray
    pitch_inertia: jnp.ndarray
    cg_height: jnp.ndarray
    cg_to_front_axle: jnp.ndarray
    wheelbase: jnp.ndarray
    front_overhang: jnp.ndarray
    length: jnp.ndarray
    width: jnp.ndarray
    height: jnp.ndarray
    wheel_radius: jnp.ndarray
    contact_area: jnp.ndarray
    axle_stiffness: jnp.ndarray
    axle_damping: jnp.ndarray
    wheel_spin_inertia: jnp.ndarray
    key: str = eqx.field(static=True)
    name: str = eqx.field(static=True)
    silhouette_side: tuple = eqx.field(static=True, default=())
    windscreen_top: tuple | None = eqx.field(static=True, default=None)
    engine_mass: float | None = eqx.field(static=True, default=None)
    engine_gap: float | None = eqx.field(static=True, default=None)

    def numbers_only(self) -> "Vehicle":
        """This vehicle with its static metadata blanked (key, name, outline, windscreen, the
        engine's estimates): what the simulation computes with. Static fields are part of a
        compiled program's key, so cars that differ only in them (the same car under another
        name) run the same compiled programs through this."""
        return dataclasses.replace(self, key="", name="", silhouette_side=(), windscreen_top=None, engine_mass=None,
                                   engine_gap=None)

    @property
    def cg_to_rear_axle(self):
        """m, horizontal, CG to rear axle (``b``)."""
        return self.wheelbase - self.cg_to_front_axle

    @property
    def cg_to_front_bumper(self):
        """m, horizontal, CG to the front bumper."""
        return self.cg_to_front_axle + self.front_overhang

    @property
    def static_axle_loads(self):
        """(2,) N, front and rear axle loads of the car at rest on level ground."""
        b = self.cg_to_rear_axle
        a = self.cg_to_front_axle
        w = self.mass * GRAVITY
        return jnp.stack([w * b / self.wheelbase, w * a / self.wheelbase])


def list_vehicles() -> list[str]:
    """Names of the vehicle files that ship in ``data/vehicles/``, sorted."""
    return sorted(p.stem for p in VEHICLE_DIR.glob("*.toml"))


def vehicle_path(name_or_path: str | Path) -> Path:
    """Resolve a vehicle name (``audi_a4``) or a path to a TOML file.

    Raises ConfigError naming the known vehicles when neither exists.
    """
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.parent != Path("."):
        if not candidate.is_file():
            raise ConfigError(f"vehicle file {candidate} does not exist")
        return candidate
    shipped = VEHICLE_DIR / f"{name_or_path}.toml"
    if shipped.is_file():
        return shipped
    raise ConfigError(
        f"unknown vehicle {str(name_or_path)!r}; known vehicles: {', '.join(list_vehicles())}"
        " (or give a path to a vehicle .toml file)"
    )


def read_vehicle_file(name_or_path: str | Path) -> dict:
    """Return the parsed TOML of a vehicle file (a name or a path), unvalidated."""
    from sim._text import read_text

    path = vehicle_path(name_or_path)
    text = read_text(path, "vehicle file", binary_check=False)  # TOML refuses control characters itself
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"vehicle file {path}: not valid TOML ({err})") from None
    except RecursionError:
        raise ConfigError(f"vehicle file {path}: not valid TOML (nested too deeply)") from None
    except ValueError as err:  # tomllib's own, e.g. an integer of more than 4300 digits
        raise ConfigError(f"vehicle file {path}: not valid TOML ({str(err).split(';')[0]})") from None


def load_vehicle(name_or_path: str | Path) -> Vehicle:
    """Read and validate a vehicle file; return a :class:`Vehicle`.

    Parameters
    ----------
    name_or_path : a name from ``data/vehicles/`` (e.g. ``"audi_a4"``) or a path to a
        ``.toml`` file.

    Raises
    ------
    ConfigError
        Unknown name, missing file, a missing or non-numeric field, a non-positive length,
        mass or inertia, or geometry that does not fit together; the message names the field.
    """
    path = vehicle_path(name_or_path)
    return vehicle_from_dict(read_vehicle_file(path), key=path.stem, source=str(path))


def vehicle_from_dict(d: dict, key: str = "vehicle", source: str = "vehicle") -> Vehicle:
    """Validate a parsed vehicle dictionary (the TOML's fields) and build a Vehicle.

    ``source`` names the file in error messages.
    """

    def number(field: str) -> float:
        if field not in d:
            raise ConfigError(f"{source}: missing field {field!r}")
        value = d[field]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"{source}: field {field!r} must be a finite number, got {value!r}")
        return float(value)

    values = {f: number(f) for f in _POSITIVE_FIELDS}
    for field, value in values.items():
        if value <= 0.0:
            raise ConfigError(f"{source}: field {field!r} must be > 0, got {value}")
    if values["cg_to_front_axle"] >= values["wheelbase"]:
        raise ConfigError(
            f"{source}: field 'cg_to_front_axle' ({values['cg_to_front_axle']}) must be less than"
            f" 'wheelbase' ({values['wheelbase']}): the CG lies between the axles"
        )
    if values["wheelbase"] + values["front_overhang"] >= values["length"]:
        raise ConfigError(
            f"{source}: 'wheelbase' + 'front_overhang' ({values['wheelbase'] + values['front_overhang']})"
            f" must be less than 'length' ({values['length']})"
        )
    if values["wheel_radius"] >= values["cg_height"] * 2:
        raise ConfigError(f"{source}: field 'wheel_radius' ({values['wheel_radius']}) is implausibly large")

    mass, a, wheelbase = values["mass"], values["cg_to_front_axle"], values["wheelbase"]
    axle_mass = np.array([mass * (wheelbase - a) / wheelbase, mass * a / wheelbase])
    default_k = axle_mass * (2 * np.pi * np.array(DEFAULT_RIDE_FREQUENCY_HZ)) ** 2
    stiffness = _axle_pair(d, "axle_stiffness", default_k, source)
    default_c = 2 * DEFAULT_DAMPING_RATIO * np.sqrt(stiffness * axle_mass)
    damping = _axle_pair(d, "axle_damping", default_c, source, allow_zero=True)
    spin_inertia = _axle_pair(d, "wheel_spin_inertia", np.full(2, 2 * DEFAULT_WHEEL_SPIN_INERTIA), source,
                              allow_zero=True)

    silhouette = _polygon(d.get("silhouette_side", ()), source)
    top = d.get("windscreen_top")
    if top is not None:
        top = _polygon([top], source, field="windscreen_top", min_points=1)[0]

    engine = {}
    for field in ("engine_mass", "engine_gap"):
        if field in d:
            engine[field] = number(field)
    if "engine_mass" in engine and not 0.0 < engine["engine_mass"] < 0.4 * values["mass"]:
        raise ConfigError(f"{source}: field 'engine_mass' ({engine['engine_mass']}) must be between 0 and 40 % of"
                          f" 'mass' ({values['mass']})")
    if "engine_gap" in engine and not 0.0 < engine["engine_gap"] < values["front_overhang"] + values["cg_to_front_axle"]:
        raise ConfigError(f"{source}: field 'engine_gap' ({engine['engine_gap']}) must be > 0 and less than the"
                          f" distance from the front bumper to the CG")

    name = d.get("name", key)
    if not isinstance(name, str):
        raise ConfigError(f"{source}: field 'name' must be a string, got {name!r}")
    return Vehicle(
        **{f: jnp.asarray(v, dtype=float) for f, v in values.items()},
        axle_stiffness=jnp.asarray(stiffness, dtype=float),
        axle_damping=jnp.asarray(damping, dtype=float),
        wheel_spin_inertia=jnp.asarray(spin_inertia, dtype=float),
        key=key,
        name=name,
        silhouette_side=silhouette,
        windscreen_top=top,
        **engine,
    )


def _axle_pair(d, field, default, source, allow_zero=False):
    if field not in d:
        return np.asarray(default, dtype=float)
    value = d[field]
    ok = (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    )
    if not ok:
        raise ConfigError(f"{source}: field {field!r} must be two numbers [front, rear], got {value!r}")
    arr = np.asarray(value, dtype=float)
    if np.any(arr < 0) or (not allow_zero and np.any(arr == 0)):
        bound = ">= 0" if allow_zero else "> 0"
        raise ConfigError(f"{source}: field {field!r} must be {bound}, got {value!r}")
    return arr


def _polygon(points, source, field="silhouette_side", min_points=3):
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{source}: field {field!r} must be a list of [x, z] pairs") from None
    if arr.size == 0 and field == "silhouette_side":
        return ()
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < min_points or not np.all(np.isfinite(arr)):
        raise ConfigError(f"{source}: field {field!r} must be a list of at least {min_points} [x, z] pairs")
    return tuple((float(x), float(z)) for x, z in arr)
