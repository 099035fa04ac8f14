"""What the fit moves and how the model is compared with a measurement.

- :class:`FreeParameter`: one fitted quantity, a name, a unit and a transform from an
  unconstrained number u (what the solver moves) to its physical value (positivity and
  ranges by reparametrisation: log, logistic, tanh).
- :func:`assemble`: physical values -> (sim.Params, impact speed, contact time), from a
  template Params whose fixed fields and mechanisms stay as they are. Names are Params
  fields (``k_compression``) or ``effect.field`` for a mechanism's field
  (``stiffness_zone.depth``), plus the nuisance parameters ``impact_speed`` (m/s) and
  ``contact_time`` (s: when the model's first contact happens on the measurement's clock).
  Names in ``VEHICLE_OVERRIDES`` change the vehicle instead (:func:`vehicle_with`).
- :func:`predict`: a simulated trajectory seen on the measurement's clock, channel by channel.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from sim import Params

NUISANCE = ("impact_speed", "contact_time", "length_scale")
CONTACT_TIME_RANGE = 0.010  # s: the model's contact may differ from the measured one by this much
# A film's lengths are its pixels times one scale (the tape's, or the hubs' spacing over the
# wheelbase), so the scale's error is one number common to every length the film measures,
# not noise of each sample: the fit carries it as the nuisance ``length_scale`` (the
# recording's lengths over the true ones) with the scale's measured uncertainty as its
# prior (``Measurement.length_scale_sigma``); these channels are multiplied by it.
LENGTH_CHANNELS = ("x_m", "z_m", "vx_mps", "crush_m", "engine_x_m", "engine_vx_mps")
LENGTH_SCALE_RANGE = 0.05  # the fitted scale error stays within +-5 % (tanh)


@dataclasses.dataclass(frozen=True)
class FreeParameter:
    """A fitted quantity.

    value = transform(u): ``log``: scale * exp(u) (> 0); ``logit``: lower + (upper - lower) *
    sigmoid(u); ``tanh``: centre + scale * tanh(u) (|value - centre| < scale); ``linear``:
    centre + scale * u. ``floor_is_physical``: the lower bound is a law of physics, not a
    range the fit was given (a friction coefficient is >= 0), so a value there is what the
    recording says (none), not a value the bound stopped (:meth:`at_bound`).
    """

    name: str
    unit: str
    transform: str
    scale: float = 1.0
    centre: float = 0.0
    lower: float = 0.0
    upper: float = 1.0
    floor_is_physical: bool = False

    @property
    def typical(self) -> float:
        """A typical magnitude of the value (the covariance is computed in these units)."""
        if self.transform == "logit":
            return 0.1 * (self.upper - self.lower)
        if self.transform == "tanh":
            return 0.25 * self.scale
        return self.scale

    def to_physical(self, u):
        if self.transform == "log":
            return self.scale * jnp.exp(u)
        if self.transform == "logit":
            return self.lower + (self.upper - self.lower) * jax.nn.sigmoid(u)
        if self.transform == "tanh":
            return self.centre + self.scale * jnp.tanh(u)
        return self.centre + self.scale * u

    @property
    def bounds(self) -> tuple[float, float] | None:
        """(lower, upper) of the values the transform can reach, or None (``log``, ``linear``)."""
        if self.transform == "logit":
            return self.lower, self.upper
        if self.transform == "tanh":
            return self.centre - self.scale, self.centre + self.scale
        return None

    AT_BOUND = 0.01  # within this share of its range of a bound, a value is "at its bound"
    RUNAWAY = 1e3  # a log-transformed value this many times its scale (or 1/this) has run away

    def at_bound(self, value: float) -> str:
        """'' when ``value`` lies inside its transform's range, else which bound it sits at
        (within ``AT_BOUND`` of the range): a fit that ends there was stopped by the bound,
        not by the data. A ``log`` transform has no bound, but a value ``RUNAWAY`` times its
        scale or less than 1/``RUNAWAY`` of it has run off towards one (on a reference
        world an engine's rear stiffness reached 9.7e12 N/m, 1e7 times its scale); a
        ``linear`` one has none."""
        if self.transform == "log":
            ratio = float(value) / self.scale
            if ratio >= self.RUNAWAY or ratio <= 1.0 / self.RUNAWAY:
                return f"far outside any plausible value ({float(value):.3g} {self.unit}, {ratio:.2g} times its scale)"
            return ""
        if self.bounds is None:
            return ""
        lo, hi = self.bounds
        share = (float(value) - lo) / (hi - lo)
        if share <= self.AT_BOUND and not self.floor_is_physical:
            return f"at its lower bound {lo:.4g} {self.unit}"
        if share >= 1.0 - self.AT_BOUND:
            return f"at its upper bound {hi:.4g} {self.unit}"
        return ""

    def at_physical_floor(self, value: float) -> bool:
        """Whether ``value`` sits at a lower bound that is a law of physics
        (``floor_is_physical``), within ``AT_BOUND`` of the range: where :meth:`at_bound`
        says nothing, the recording having asked for none."""
        return (self.floor_is_physical and self.transform == "logit"
                and float(value) - self.lower <= self.AT_BOUND * (self.upper - self.lower))

    def start_inside(self, value: float) -> float:
        """``value`` as a fit's start: a bounded value within ``AT_BOUND`` of a bound of its
        range moved to that margin. A start taken from an earlier fit that ended at a bound
        (a logit at 17, where the sigmoid's slope is 4e-8) would hold the parameter there in
        every later fit, whatever they add: on development world 960028 the base fit's face
        friction ended at 1 and every candidate's fit inherited it, each then refused for
        pulling the friction 4.7 sigma from its prior. A physical floor (``floor_is_physical``)
        is the recording's answer, not a stop, and a start there stays: moved up, every later
        fit of the bundled sample (a nose that slides, friction 0) ran its logit down again
        and stopped at the step limit (the whole command 120 s against 64)."""
        if self.bounds is None:
            return float(value)
        lo, hi = self.bounds
        margin = self.AT_BOUND * (hi - lo)
        floor = -math.inf if self.floor_is_physical else lo + margin
        return float(min(max(float(value), floor), hi - margin))

    def to_unconstrained(self, value: float) -> float:
        if self.transform == "log":
            return math.log(value / self.scale)
        if self.transform == "logit":
            p = (value - self.lower) / (self.upper - self.lower)
            p = min(max(p, 1e-9), 1 - 1e-9)
            return math.log(p / (1 - p))
        if self.transform == "tanh":
            r = (value - self.centre) / self.scale
            return math.atanh(min(max(r, -1 + 1e-9), 1 - 1e-9))
        return (value - self.centre) / self.scale


SPEED_SCALE = 10.0  # m/s; a fixed scale keeps the compiled fit the same for every recording

# What is known of the barrier face's friction coefficient before a fit (value, sigma): dry
# steel on concrete, steel or plywood, the faces of crash barriers, slides at 0.2-0.6. A
# crushed front pressed into the face sticks wherever the coefficient exceeds the few
# hundredths that hold it (reference worlds: 0.02-0.03), so above that the motion barely
# tells one value from another and this prior keeps the fit from wandering; a recording of a
# car whose nose slides freely pulls it towards 0.
FACE_FRICTION_PRIOR = (0.3, 0.15)
# Every start's face friction (1): a nose sliding on the face decides it, one that sticks
# barely does, so a fit started high on a sliding nose finds no way down, while one started
# low climbs to sticking where the motion asks for it and the prior carries it on; V-SIM's 0
# would start the logit where it is flat.
FACE_FRICTION_START = 0.01


def base_parameters(face_friction: bool = False) -> tuple[FreeParameter, ...]:
    """The four collision parameters of the paper, with ``face_friction`` the barrier face's
    friction (``mu_face``, with the prior ``FACE_FRICTION_PRIOR``; ``FitOptions.face_friction``),
    and the two nuisance parameters (a film's third, its scale, the fit adds: ``LENGTH_SCALE``)."""
    face = (FreeParameter("mu_face", "1", "logit", lower=0.0, upper=1.0, floor_is_physical=True),)
    return (
        FreeParameter("k_compression", "N/m^3", "log", scale=1e6),
        FreeParameter("k_restitution", "N/m^3", "log", scale=1e6),
        FreeParameter("restitution", "1", "logit", lower=0.0, upper=1.0),
        FreeParameter("dz_contact", "m", "tanh", scale=0.6),
        *(face if face_friction else ()),
        FreeParameter("impact_speed", "m/s", "log", scale=SPEED_SCALE),
        FreeParameter("contact_time", "s", "tanh", scale=CONTACT_TIME_RANGE),
    )


# The film's scale error (``LENGTH_CHANNELS``): the fit adds it to what it moves for a recording
# with a scale's uncertainty (``Measurement.length_scale_sigma``), with that as its prior.
LENGTH_SCALE = FreeParameter("length_scale", "1", "tanh", scale=LENGTH_SCALE_RANGE, centre=1.0)


def assemble(template: Params, values: dict, default_speed):
    """Physical values -> (Params, impact speed (m/s), contact time (s)).

    ``values`` maps names (see module doc) to scalars; names not present keep the
    template's value; the speed defaults to ``default_speed`` and the contact time to 0.
    """
    base = {k: v for k, v in values.items() if "." not in k and k not in NUISANCE}
    params = dataclasses.replace(template, **base)
    mech_values = {k: v for k, v in values.items() if "." in k and k not in VEHICLE_OVERRIDES}
    if mech_values:
        mechanisms = list(params.mechanisms)
        for name, value in mech_values.items():
            effect, field = name.split(".", 1)
            i = next(i for i, m in enumerate(mechanisms) if m.effect == effect)
            mechanisms[i] = dataclasses.replace(mechanisms[i], **{field: value})
        params = dataclasses.replace(params, mechanisms=tuple(mechanisms))
    speed = values.get("impact_speed", default_speed)
    contact_time = values.get("contact_time", 0.0)
    return params, speed, contact_time


# Fitted quantities that change the vehicle rather than Params (a candidate of discovery):
# name -> (Vehicle field, index in it).
VEHICLE_OVERRIDES = {"rear_axle_lift.rear_axle_stiffness": ("axle_stiffness", 1)}


def vehicle_value(vehicle, name: str) -> float:
    """The vehicle file's own value of ``name``, one of ``VEHICLE_OVERRIDES``."""
    field, index = VEHICLE_OVERRIDES[name]
    return float(np.asarray(getattr(vehicle, field))[index])


def vehicle_with(vehicle, values: dict):
    """``vehicle`` with the fields named in ``VEHICLE_OVERRIDES`` set from ``values``
    (others unchanged; jit-able)."""
    for name, (field, index) in VEHICLE_OVERRIDES.items():
        if name in values:
            arr = getattr(vehicle, field)
            vehicle = dataclasses.replace(vehicle, **{field: arr.at[index].set(values[name])})
    return vehicle


def _hermite(values, slopes, s, h):
    """Cubic Hermite interpolation of samples ``values`` (spacing h, first at s = 0) with
    derivatives ``slopes`` at times s (clamped to the sampled span)."""
    n = values.shape[0]
    pos = jnp.clip(s / h, 0.0, n - 1.000001)
    i = jnp.floor(pos).astype(int)
    u = pos - i
    y0, y1 = values[i], values[i + 1]
    m0, m1 = slopes[i] * h, slopes[i + 1] * h
    u2, u3 = u * u, u * u * u
    return (2 * u3 - 3 * u2 + 1) * y0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * y1 + (u3 - u2) * m1


def _smooth(values, s, h):
    """Cubic Hermite interpolation of samples ``values`` (spacing h, first at s = 0) whose
    slopes are their centred differences (one-sided at the ends): smooth in ``s``, where
    linear interpolation has a kink at every sample, so that a fitted time shift is not drawn
    to a multiple of the model's output interval."""
    inner = (values[2:] - values[:-2]) / (2 * h)
    slopes = jnp.concatenate([(values[1:2] - values[:1]) / h, inner, (values[-1:] - values[-2:-1]) / h])
    return _hermite(values, slopes, s, h)


def _linear(values, s, h):
    n = values.shape[0]
    pos = jnp.clip(s / h, 0.0, n - 1.000001)
    i = jnp.floor(pos).astype(int)
    u = pos - i
    return (1 - u) * values[i] + u * values[i + 1]


# channel -> (trajectory value, trajectory slope or None, value before contact per unit of
# speed * time); before first contact the car rolls at the impact speed.
def predict(traj, channel: str, t, speed, contact_time, wheel_radius, h: float):
    """The model's value of ``channel`` at measurement times ``t`` (s).

    Model time is ``t - contact_time``; before the model's first contact the car moves at
    ``speed`` with its wheels rolling. ``x_m`` is the displacement from where the car was at
    the measurement's t = 0 (the tracks.csv definition), ``engine_x_m`` likewise for the
    engine (``sim.mechanisms.EngineImpact``; without it the engine moves with the cabin); other channels are returned as they
    are (the fit removes their constant offsets).
    """
    s = t - contact_time

    def ext(s_):
        before = s_ < 0
        if channel == "x_m":
            after = _hermite(traj.x, traj.vx, s_, h)
            return jnp.where(before, speed * s_, after)
        if channel == "vx_mps":
            return jnp.where(before, speed, _smooth(traj.vx, s_, h))
        if channel == "engine_x_m":
            return jnp.where(before, speed * s_, _hermite(traj.engine_x, traj.engine_vx, s_, h))
        if channel == "engine_vx_mps":
            return jnp.where(before, speed, _smooth(traj.engine_vx, s_, h))
        if channel == "z_m":
            return jnp.where(before, 0.0, _hermite(traj.z, traj.vz, s_, h))
        if channel == "pitch_rad":
            return jnp.where(before, 0.0, _hermite(traj.pitch, traj.pitch_rate, s_, h))
        if channel == "crush_m":
            return jnp.where(before, 0.0, _linear(traj.crush, s_, h))
        if channel == "force_N":
            return jnp.where(before, 0.0, _linear(traj.force, s_, h))
        if channel == "front_wheel_angle_rad":
            return jnp.where(before, speed * s_ / wheel_radius, _linear(traj.front_wheel_angle, s_, h))
        if channel == "rear_wheel_angle_rad":
            return jnp.where(before, speed * s_ / wheel_radius, _linear(traj.rear_wheel_angle, s_, h))
        raise ValueError(f"no model prediction for channel {channel!r}")

    value = ext(s)
    if channel in ("x_m", "engine_x_m"):
        value = value - ext(-contact_time)
    return value


# Channels whose constant offset the fit removes (their zero is arbitrary or set by a single
# noisy frame); x keeps its zero, which pins the contact time.
OFFSET_FREE = ("z_m", "pitch_rad", "front_wheel_angle_rad", "rear_wheel_angle_rad")
