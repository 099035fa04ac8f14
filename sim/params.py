"""Collision parameters: what a simulator such as V-SIM asks the expert to type in.

Meaning of each (``docs/physics.md``): barrier stiffness per unit contact area in the
compression and restitution phases, restitution coefficient, height of the contact force
relative to the CG, and the tyre friction coefficients. Optional mechanisms ride along in
``mechanisms``. Named sets live in ``data/params/<name>.json``, shaped like result.json's
"parameters" (``{"k_compression": {"value": 970000.0, "unit": "N/m^3"}, ...}``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp

from sim._paths import PARAMS_DIR
from sim.errors import ConfigError
from sim.mechanisms import Mechanism

UNITS = {
    "k_compression": "N/m^3",
    "k_restitution": "N/m^3",
    "restitution": "1",
    "dz_contact": "m",
    "mu_slip": "1",
    "mu_adhesion": "1",
    "rolling_resistance": "1",
    "mu_face": "1",
}
REQUIRED = ("k_compression", "k_restitution", "restitution", "dz_contact")
# Table 1 of the paper gives the same tyre coefficients for default and identified data.
TYRE_DEFAULTS = {"mu_slip": 0.8, "mu_adhesion": 0.9, "rolling_resistance": 0.015}
# V-SIM's contact force is horizontal: no friction on the barrier face unless one is given.
FACE_DEFAULTS = {"mu_face": 0.0}


class Params(eqx.Module):
    """Collision parameters (float64 arrays; a batch of sets is the same with a leading axis).

    Attributes
    ----------
    k_compression : N/m^3, barrier stiffness per unit contact area while crushing.
    k_restitution : N/m^3, slope per unit area of the unloading line.
    restitution : 1, in [0, 1]; the unloading gives back restitution^2 of the energy absorbed.
    dz_contact : m, height of the contact force above the CG (dz' < 0: below).
    mu_slip : 1, friction coefficient of a sliding (blocked) tyre.
    mu_adhesion : 1, friction coefficient of a blocked tyre at vanishing sliding speed.
    rolling_resistance : 1, rolling-resistance coefficient of a turning wheel.
    mu_face : 1, Coulomb friction coefficient between the crushed front and the barrier
        face: a vertical force at the contact point, at most mu_face times the barrier force,
        opposing the point's sliding along the face (``sim.contact.face_friction_impulse``);
        0 in V-SIM and the paper.
    mechanisms : tuple of :class:`sim.mechanisms.Mechanism`, applied in order.
    """

    k_compression: jnp.ndarray
    k_restitution: jnp.ndarray
    restitution: jnp.ndarray
    dz_contact: jnp.ndarray
    mu_slip: jnp.ndarray
    mu_adhesion: jnp.ndarray
    rolling_resistance: jnp.ndarray
    mu_face: jnp.ndarray = 0.0
    mechanisms: tuple[Mechanism, ...] = ()


def make_params(mechanisms: tuple[Mechanism, ...] = (), **values: float) -> Params:
    """Build a validated Params from numbers (tyre coefficients default to Table 1's, the
    barrier face's friction to none).

    Raises ConfigError on a missing, unknown or invalid field.
    """
    unknown = sorted(set(values) - set(UNITS))
    if unknown:
        raise ConfigError(f"unknown parameter {unknown[0]!r}; known: {', '.join(UNITS)}")
    missing = [name for name in REQUIRED if name not in values]
    if missing:
        raise ConfigError(f"missing parameter {missing[0]!r}")
    full = {**TYRE_DEFAULTS, **FACE_DEFAULTS, **values}
    params = Params(**{k: jnp.asarray(full[k], dtype=float) for k in UNITS}, mechanisms=tuple(mechanisms))
    validate_params(params)
    return params


def validate_params(params: Params) -> None:
    """Raise ConfigError if a parameter is outside its physical range.

    Checks concrete values only (inside jit or vmap the arrays are tracers and are skipped);
    works on single sets and on batches (every member must be valid).
    """
    leaves = {name: getattr(params, name) for name in UNITS}
    if any(isinstance(v, jax.core.Tracer) for v in leaves.values()):
        return
    v = {name: jnp.asarray(x) for name, x in leaves.items()}

    def bad(name, mask, rule):
        if bool(jnp.any(mask)):
            values = jnp.ravel(v[name])[jnp.ravel(mask)] if jnp.ndim(v[name]) else v[name]
            raise ConfigError(f"parameter {name!r} = {_fmt(values)} {rule}")

    for name in UNITS:
        bad(name, ~jnp.isfinite(v[name]), "is not a finite number")
    bad("k_compression", v["k_compression"] <= 0, "must be > 0 N/m^3")
    bad("k_restitution", v["k_restitution"] <= 0, "must be > 0 N/m^3")
    bad("restitution", (v["restitution"] < 0) | (v["restitution"] > 1), "is outside [0, 1]")
    bad("dz_contact", jnp.abs(v["dz_contact"]) > 1.0, "is more than 1 m from the CG")
    for name in ("mu_slip", "mu_adhesion", "rolling_resistance", "mu_face"):
        bad(name, (v[name] < 0) | (v[name] > 2), "is outside [0, 2]")
    too_elastic = v["restitution"] ** 2 > v["k_restitution"] / v["k_compression"]
    bad(
        "restitution",
        too_elastic,
        "is too large for k_restitution/k_compression: the unloading line would end below zero"
        " crush (needs restitution^2 <= k_restitution / k_compression)",
    )


def _fmt(values) -> str:
    flat = [float(x) for x in jnp.ravel(jnp.asarray(values))]
    return f"{flat[0]:g}" if len(flat) == 1 else "[" + ", ".join(f"{x:g}" for x in flat[:3]) + ", ...]"


def list_param_sets() -> list[str]:
    """Names of the parameter sets that ship in ``data/params/``, sorted."""
    return sorted(p.stem for p in PARAMS_DIR.glob("*.json"))


def load_params(name_or_path: str | Path, mechanisms: tuple[Mechanism, ...] = ()) -> Params:
    """A named set (``vsim_default``, ``paper_identified``) or a JSON file shaped like
    result.json's "parameters" (a result.json itself works too); returns validated Params.

    Each entry is ``{"value": number, ...}`` or a bare number. Raises ConfigError naming
    the file and field when something is missing, unknown or invalid.
    """
    candidate = Path(name_or_path)
    if candidate.suffix == ".json" or candidate.parent != Path("."):
        path = candidate
        if not path.is_file():
            raise ConfigError(f"parameter file {path} does not exist")
    else:
        path = PARAMS_DIR / f"{name_or_path}.json"
        if not path.is_file():
            raise ConfigError(
                f"unknown parameter set {str(name_or_path)!r}; known sets: {', '.join(list_param_sets())}"
                " (or give a path to a JSON file)"
            )
    from sim._text import read_text

    text = read_text(path, "parameter file")
    try:
        doc = json.loads(text)
    except RecursionError:
        raise ConfigError(f"parameter file {path}: not valid JSON (nested too deeply)") from None
    except json.JSONDecodeError as err:
        raise ConfigError(f"parameter file {path}: not valid JSON ({err.msg}, line {err.lineno})") from None
    table = doc.get("parameters", doc) if isinstance(doc, dict) else None
    if not isinstance(table, dict):
        raise ConfigError(f"parameter file {path}: expected an object of parameters")
    return params_from_table(table, path, mechanisms)


def params_from_table(table: dict, path, mechanisms: tuple[Mechanism, ...] = ()) -> Params:
    """Validated Params from a parameter table (name -> ``{"value": number, ...}`` or a bare
    number) read from ``path``; ConfigError naming the file and field otherwise."""
    values = {}
    for name, entry in table.items():
        value = entry.get("value") if isinstance(entry, dict) else entry
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"parameter file {path}: {name!r} must have a finite numeric value, got {value!r}")
        values[name] = float(value)
    try:
        return make_params(mechanisms=mechanisms, **values)
    except ConfigError as err:
        raise ConfigError(f"parameter file {path}: {err}") from None


def named_params(name: str) -> Params:
    """A parameter set shipped in ``data/params/`` by name (see :func:`list_param_sets`)."""
    return load_params(name)
