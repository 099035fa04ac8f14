"""The reference world's car: the vehicle file read on its own (no ``sim``, ``identify``
or ``video`` import), plus what a vehicle file never says (engine, unsprung masses, tyres).

Vehicle frame as in ``shared/docs/interface.md``: x forward from the rear bumper, z up from
the ground; lengths in m, mass in kg, inertia in kg m^2.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

VEHICLES_DIR = Path(__file__).resolve().parent.parent / "data" / "vehicles"

# Fields every vehicle file must have (interface.md), all positive numbers.
REQUIRED = ("mass", "length", "width", "height", "wheelbase", "front_overhang", "cg_height",
            "cg_to_front_axle", "pitch_inertia", "wheel_radius", "contact_area")


class SynthError(ValueError):
    """Bad input to the reference world: one line a person can act on."""


@dataclass(frozen=True)
class Car:
    """A vehicle as its file describes it.

    Attributes
    ----------
    name : str
    mass : float
        Test mass, kg.
    length, width, height, wheelbase, front_overhang, cg_height, cg_to_front_axle,
    wheel_radius : float
        m.
    pitch_inertia : float
        About the CG, kg m^2.
    contact_area : float
        Crush-zone face that meets the barrier, m^2.
    axle_stiffness, axle_damping : tuple[float, float]
        Per axle, front then rear, suspension and tyre in series: N/m and N s/m.
    silhouette_side : (N, 2) float
        Closed side outline, vehicle frame, m.
    windscreen_top : (2,) float
        Roof edge at the top of the windscreen, vehicle frame, m.
    """

    name: str
    mass: float
    length: float
    width: float
    height: float
    wheelbase: float
    front_overhang: float
    cg_height: float
    cg_to_front_axle: float
    pitch_inertia: float
    wheel_radius: float
    contact_area: float
    axle_stiffness: tuple
    axle_damping: tuple
    silhouette_side: np.ndarray
    windscreen_top: np.ndarray

    @property
    def x_cg(self) -> float:
        """CG along the vehicle frame's x, m."""
        return self.length - self.front_overhang - self.cg_to_front_axle

    @property
    def front_axle_x(self) -> float:
        """Front axle along the vehicle frame's x, m."""
        return self.length - self.front_overhang

    @property
    def rear_axle_x(self) -> float:
        """Rear axle along the vehicle frame's x, m."""
        return self.length - self.front_overhang - self.wheelbase

    @property
    def front_x(self) -> float:
        """Front-most silhouette point along the vehicle frame's x, m."""
        return float(np.max(np.asarray(self.silhouette_side)[:, 0]))

    def replace(self, **changes) -> "Car":
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


def _default_axles(d: dict) -> tuple[tuple, tuple]:
    """Ride frequency 1.4/1.6 Hz and damping ratio 0.3 on the static axle loads (the
    defaults documented in data/README.md) when the file gives none."""
    m, a, l = d["mass"], d["cg_to_front_axle"], d["wheelbase"]
    axle_mass = np.array([m * (l - a) / l, m * a / l])
    k = axle_mass * (2 * np.pi * np.array([1.4, 1.6])) ** 2
    c = 2 * 0.3 * np.sqrt(k * axle_mass)
    return tuple(map(float, k)), tuple(map(float, c))


def car_from_dict(d: dict, source: str = "vehicle file") -> Car:
    """Build a :class:`Car` from a parsed vehicle TOML.

    Raises
    ------
    SynthError
        A missing or non-positive field, or a silhouette that is not a polygon.
    """
    values = {}
    for key in REQUIRED:
        if key not in d:
            raise SynthError(f"{source}: '{key}' is missing")
        try:
            v = float(d[key])
        except (TypeError, ValueError):
            raise SynthError(f"{source}: '{key}' = {d[key]!r} is not a number") from None
        if not math.isfinite(v) or v <= 0:
            raise SynthError(f"{source}: '{key}' = {v} must be positive")
        values[key] = v
    sil = np.asarray(d.get("silhouette_side", []), dtype=float)
    if sil.ndim != 2 or sil.shape[1] != 2 or sil.shape[0] < 3 or not np.all(np.isfinite(sil)):
        raise SynthError(f"{source}: 'silhouette_side' must be at least 3 [x, z] points")
    top = np.asarray(d["windscreen_top"], dtype=float) if "windscreen_top" in d else sil[np.argmax(sil[:, 1])]
    k_def, c_def = _default_axles(values)
    k = tuple(float(v) for v in d.get("axle_stiffness", k_def))
    c = tuple(float(v) for v in d.get("axle_damping", c_def))
    if len(k) != 2 or len(c) != 2 or min(k) <= 0 or min(c) < 0:
        raise SynthError(f"{source}: axle_stiffness and axle_damping must be [front, rear] pairs, stiffness > 0")
    return Car(name=str(d.get("name", source)), axle_stiffness=k, axle_damping=c,
               silhouette_side=sil, windscreen_top=top, **values)


def vehicle_path(name_or_path: str | Path) -> Path:
    """``data/vehicles/<name>.toml`` for a bare name, else the path itself."""
    p = Path(name_or_path)
    return VEHICLES_DIR / f"{name_or_path}.toml" if not p.suffix else p


def known_vehicles() -> list[str]:
    """Names of the vehicle files that ship."""
    return sorted(q.stem for q in VEHICLES_DIR.glob("*.toml"))


def load_car(name_or_path: str | Path) -> Car:
    """Read a vehicle by name (``data/vehicles/<name>.toml``) or TOML path.

    Raises
    ------
    SynthError
        Unknown name, unreadable or invalid file.
    """
    p = vehicle_path(name_or_path)
    if not p.is_file():
        raise SynthError(f"unknown vehicle {str(name_or_path)!r}: no file {p}; known: {', '.join(known_vehicles())}")
    try:
        d = tomllib.loads(p.read_bytes().decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise SynthError(f"vehicle file {p} is not valid UTF-8 TOML: {err}") from None
    return car_from_dict(d, str(p))


def car_to_toml(car: Car, comment: str = "") -> str:
    """The vehicle file text of ``car`` (readable back by :func:`load_car` and by
    ``identify``'s own reader)."""
    def num(v):
        return repr(float(v))

    lines = [f"# {line}" for line in comment.splitlines()] if comment else []
    lines.append(f"name = {json_str(car.name)}")
    for key in REQUIRED:
        lines.append(f"{key} = {num(getattr(car, key))}")
    lines.append(f"axle_stiffness = [{num(car.axle_stiffness[0])}, {num(car.axle_stiffness[1])}]")
    lines.append(f"axle_damping = [{num(car.axle_damping[0])}, {num(car.axle_damping[1])}]")
    pts = ", ".join(f"[{x:.4f}, {z:.4f}]" for x, z in np.asarray(car.silhouette_side))
    lines.append(f"silhouette_side = [{pts}]")
    lines.append(f"windscreen_top = [{car.windscreen_top[0]:.4f}, {car.windscreen_top[1]:.4f}]")
    return "\n".join(lines) + "\n"


def json_str(s: str) -> str:
    """A TOML basic string (JSON escaping is valid TOML)."""
    import json

    return json.dumps(s)
