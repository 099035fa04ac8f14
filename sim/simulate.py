"""``simulate``: a car hitting a rigid barrier, side view, as a pure JAX function.

Planar rigid body with coordinates q = [x, z, pitch] (CG displacement from first contact,
x towards the barrier, z up; pitch nose-down positive) and diagonal mass matrix
diag(m, m, I). Forces: the hysteretic barrier contact (``sim.contact``), axles and tyres
(``sim.ground``), the wheels' spin held towards rolling by the tyres' grip (``sim.wheels``),
the barrier face's friction (``Params.mu_face``), gravity, and the optional mechanisms of
``Params.mechanisms``.

Integration: fixed-step symplectic (semi-implicit) Euler, velocities living at half
steps (leapfrog: positions are second-order accurate), ``Solver.dt`` substeps inside a
``lax.scan`` over output samples every ``Solver.output_dt``. The barrier force jumps when
the crush stops growing (loading -> unloading); the step in which that happens applies
the loading force for the fraction of the step before the crush rate reaches zero and the
unloading force after, so the discrete trajectory stays continuous in the parameters.

Everything is float64, jit-compiled, differentiable with respect to every leaf of
``Params``, ``Vehicle`` and the speed (forward and reverse mode), and vmap-able.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp

from sim.contact import contact_geometry, face_friction_impulse, face_point_jacobian, loading_force, unloading_force
from sim.errors import ConfigError
from sim.ground import ground_forces
from sim.wheels import axle_jacobians, spin_impulses
from sim.params import Params, validate_params
from sim.vehicle import Vehicle


@dataclasses.dataclass(frozen=True)
class Solver:
    """Integration and smoothing settings (static: a new Solver recompiles).

    Attributes
    ----------
    dt : s, integration step.
    output_dt : s, interval between output samples (a whole number of steps).
    ground_force_width : N, smoothing of the axles' unilateral contact.
    friction_speed_width : m/s, smoothing of the tyre force's sign at zero sliding speed.
    stribeck_speed : m/s, sliding speed over which a blocked tyre's friction falls from
        the adhesive to the slip coefficient.
    """

    dt: float = 2e-4
    output_dt: float = 1e-3
    ground_force_width: float = 20.0
    friction_speed_width: float = 0.02
    stribeck_speed: float = 0.5

    @property
    def substeps(self) -> int:
        n = round(self.output_dt / self.dt)
        if n < 1 or abs(n * self.dt - self.output_dt) > 1e-9 * self.output_dt:
            raise ConfigError(f"Solver.output_dt ({self.output_dt}) must be a whole multiple of dt ({self.dt})")
        return n


class Trajectory(eqx.Module):
    """Simulated motion, one value per output sample (shape (n,), or (batch, n) under vmap).

    t (s, 0 at first contact); x, z (m, CG displacement from first contact); pitch (rad,
    nose-down positive); vx, vz (m/s), pitch_rate (rad/s); crush (m) and crush_max (m);
    force (N, barrier contact force); front_normal, rear_normal (N, axle normal forces);
    front_margin, rear_margin (N, axle contact margins, negative while the wheel is off
    the ground); front_lift, rear_lift (m, axle height above the wheel-touching height);
    front_blocked (0..1); front_wheel_angle, rear_wheel_angle (rad, forward rolling
    positive) and front_wheel_spin, rear_wheel_spin (rad/s, ``sim.wheels``); contact_impulse
    (N s, of the whole barrier force) and contact_work (J, integral of the structure's F dd:
    rises while crushing, falls by the energy given back) and energy_absorbed (J, the
    structure's work on the loading curve), all cumulative from t = 0.
    """

    t: jnp.ndarray
    x: jnp.ndarray
    z: jnp.ndarray
    pitch: jnp.ndarray
    vx: jnp.ndarray
    vz: jnp.ndarray
    pitch_rate: jnp.ndarray
    crush: jnp.ndarray
    crush_max: jnp.ndarray
    force: jnp.ndarray
    engine_x: jnp.ndarray
    engine_vx: jnp.ndarray
    engine_force: jnp.ndarray
    engine_crush: jnp.ndarray
    mounts_broken: jnp.ndarray
    front_normal: jnp.ndarray
    rear_normal: jnp.ndarray
    front_margin: jnp.ndarray
    rear_margin: jnp.ndarray
    front_lift: jnp.ndarray
    rear_lift: jnp.ndarray
    front_blocked: jnp.ndarray
    front_wheel_angle: jnp.ndarray
    rear_wheel_angle: jnp.ndarray
    front_wheel_spin: jnp.ndarray
    rear_wheel_spin: jnp.ndarray
    contact_impulse: jnp.ndarray
    contact_work: jnp.ndarray
    energy_absorbed: jnp.ndarray

    @property
    def rear_airborne(self):
        """True where the rear wheels are off the ground."""
        return self.rear_margin < 0.0


class _State(NamedTuple):
    q: jnp.ndarray  # (3,) m, m, rad
    v: jnp.ndarray  # (3,) m/s, m/s, rad/s, at the half step before the current time
    crush_max: jnp.ndarray  # m
    energy_absorbed: jnp.ndarray  # J
    wheel_angle: jnp.ndarray  # (2,) rad
    wheel_spin: jnp.ndarray  # (2,) rad/s
    impulse: jnp.ndarray  # N s
    work: jnp.ndarray  # J
    bodies: tuple  # each body mechanism's own state (sim.mechanisms.Mechanism.body_init)


def _front_blocked(crush, params, vehicle):
    blocked = jnp.zeros_like(crush)
    for mechanism in params.mechanisms:
        blocked = mechanism.front_blocked(blocked, crush, vehicle)
    return blocked


def _bodies(params: Params):
    return tuple(m for m in params.mechanisms if m.has_body)


def _step(state: _State, params: Params, vehicle: Vehicle, solver: Solver):
    """One integration step; returns the new state and the observations at its start."""
    dt = solver.dt
    q, v = state.q, state.v
    bodies = _bodies(params)
    cabin_mass = vehicle.mass - sum(b.detached_mass() for b in bodies)
    inv_mass = jnp.stack([1.0 / cabin_mass, 1.0 / vehicle.mass, 1.0 / vehicle.pitch_inertia])

    crush, jac = contact_geometry(q, params.dz_contact)
    crush_rate = jac @ v
    blocked = _front_blocked(crush, params, vehicle)
    other, normal, margin, lift = ground_forces(q, v, vehicle, params, blocked, solver)
    body_out = [b.body_forces(s, q, v) for b, s in zip(bodies, state.bodies)]
    body_barrier = sum((f_barrier for _, f_barrier, _ in body_out), jnp.zeros_like(crush))
    other = other + jnp.stack([sum((f for f, _, _ in body_out), jnp.zeros_like(crush)), 0.0 * crush, 0.0 * crush])
    accel_other = other * inv_mass
    accel_per_newton = -jac * inv_mass

    f_load = loading_force(crush, crush_rate, params, vehicle)
    f_unload = unloading_force(crush, state.crush_max, state.energy_absorbed, params, vehicle)
    loading = (crush >= state.crush_max) & (crush_rate > 0.0)
    rate_if_loaded = jac @ (v + dt * (accel_other + f_load * accel_per_newton))
    reverses = rate_if_loaded < 0.0
    safe_den = jnp.where(reverses, crush_rate - rate_if_loaded, 1.0)
    load_fraction = jnp.where(loading, jnp.where(reverses, crush_rate / safe_den, 1.0), 0.0)
    force = load_fraction * f_load + (1.0 - load_fraction) * f_unload

    v_new = v + dt * (accel_other + force * accel_per_newton)
    rolling = jnp.stack([1.0 - blocked, jnp.ones_like(blocked)])  # a blocked wheel neither grips nor turns
    v_new, spin = spin_impulses(v_new, state.wheel_spin, inv_mass, axle_jacobians(q, vehicle), normal,
                                params.mu_adhesion * rolling, vehicle.wheel_spin_inertia, vehicle.wheel_radius, dt)
    spin = spin * rolling
    jac_z = face_point_jacobian(q, params.dz_contact, vehicle.cg_to_front_axle + vehicle.front_overhang)
    v_new = v_new + inv_mass * jac_z * face_friction_impulse(v_new, inv_mass, jac_z, force, params.mu_face, dt)
    v_mid = 0.5 * (v + v_new)  # the velocity at the current time (leapfrog)
    q_new = q + dt * v_new
    crush_new, jac_new = contact_geometry(q_new, params.dz_contact)
    grows = loading & (crush_new > crush)
    f_load_new = loading_force(crush_new, jac_new @ v_new, params, vehicle)
    absorbed = jnp.where(grows, 0.5 * (f_load + f_load_new) * (crush_new - crush), 0.0)

    new_bodies = tuple(b.body_advance(s, out[:2], out[2], q_new, v_new, dt)
                       for b, s, out in zip(bodies, state.bodies, body_out))
    engine = dict(engine_x=q[0], engine_vx=v_mid[0], engine_force=jnp.zeros_like(crush),
                  engine_crush=jnp.zeros_like(crush), mounts_broken=jnp.zeros_like(crush))
    for b, s, s_new, out in zip(bodies, state.bodies, new_bodies, body_out):
        engine = b.body_observed(s, s_new, out[1])
    new_state = _State(
        q=q_new,
        v=v_new,
        crush_max=jnp.maximum(state.crush_max, crush_new),
        energy_absorbed=state.energy_absorbed + absorbed,
        wheel_angle=state.wheel_angle + dt * spin,
        wheel_spin=spin,
        impulse=state.impulse + dt * (force + body_barrier),
        work=state.work + dt * force * (jac @ v_mid),
        bodies=new_bodies,
    )
    observed = dict(
        x=q[0], z=q[1], pitch=q[2], vx=v_mid[0], vz=v_mid[1], pitch_rate=v_mid[2],
        crush=crush, crush_max=state.crush_max, force=force + body_barrier, **engine,
        front_normal=normal[0], rear_normal=normal[1],
        front_margin=margin[0], rear_margin=margin[1],
        front_lift=lift[0], rear_lift=lift[1], front_blocked=blocked,
        front_wheel_angle=state.wheel_angle[0], rear_wheel_angle=state.wheel_angle[1],
        front_wheel_spin=state.wheel_spin[0], rear_wheel_spin=state.wheel_spin[1],
        contact_impulse=state.impulse, contact_work=state.work,
        energy_absorbed=state.energy_absorbed,
    )  # fmt: skip
    return new_state, observed


def _run(params: Params, vehicle: Vehicle, speed, n_out: int, solver: Solver) -> Trajectory:
    zero = jnp.zeros_like(jnp.asarray(speed, dtype=float))
    state = _State(
        q=jnp.stack([zero, zero, zero]),
        v=jnp.stack([speed + zero, zero, zero]),
        crush_max=zero,
        energy_absorbed=zero,
        wheel_angle=jnp.stack([zero, zero]),
        wheel_spin=jnp.stack([zero, zero]) + speed / vehicle.wheel_radius,
        impulse=zero,
        work=zero,
        bodies=tuple(b.body_init(speed + zero) for b in _bodies(params)),
    )
    substeps = solver.substeps
    # the step's code appears once in the program: each output sample runs all its substeps
    # through one scan and keeps the first one's observations (unrolling that first step
    # doubled the program XLA compiles, most of a fit's first run)
    shapes = jax.eval_shape(lambda s: _step(s, params, vehicle, solver)[1], state)
    nothing = jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), shapes)

    def substep(carry, first):
        state, kept = carry
        state, observed = _step(state, params, vehicle, solver)
        kept = jax.tree.map(lambda k, o: jnp.where(first, o, k), kept, observed)
        return (state, kept), None

    firsts = jnp.arange(substeps) == 0

    def sample(state, _):
        (state, observed), _ = jax.lax.scan(substep, (state, nothing), firsts)
        return state, observed

    _, observed = jax.lax.scan(sample, state, None, length=n_out)
    t = jnp.arange(n_out) * solver.output_dt
    return Trajectory(t=t, **observed)


_run_jit = jax.jit(_run, static_argnames=("n_out", "solver"))


def n_samples(duration: float, solver: Solver = Solver()) -> int:
    """Number of output samples of a run of ``duration`` seconds (both ends included)."""
    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and 0 < duration <= 10.0):
        raise ConfigError(f"duration must be in (0, 10] s, got {duration!r}")
    return int(round(duration / solver.output_dt)) + 1


def simulate(
    params: Params,
    vehicle: Vehicle,
    speed,
    duration: float = 0.3,
    solver: Solver = Solver(),
) -> Trajectory:
    """Simulate a frontal rigid-barrier impact from first contact.

    Parameters
    ----------
    params : sim.Params (a single set; use ``jax.vmap`` over a batch).
    vehicle : sim.Vehicle.
    speed : m/s, impact speed (a float or a JAX array; differentiable).
    duration : s, simulated span after first contact (static: a new value recompiles).
    solver : sim.Solver (static).

    Returns
    -------
    Trajectory sampled every ``solver.output_dt`` from t = 0 to ``duration``.

    Raises
    ------
    ConfigError
        float64 not enabled, an invalid parameter or speed (checked when the inputs are
        concrete; inside jit/vmap the caller validates).
    """
    if not jax.config.jax_enable_x64:
        raise ConfigError(
            "sim needs float64: call jax.config.update('jax_enable_x64', True) before using it"
            " (the command line and the tests do)"
        )
    validate_params(params)
    if not isinstance(speed, jax.core.Tracer):
        s = float(jnp.max(jnp.asarray(speed))) if jnp.size(speed) else float("nan")
        smin = float(jnp.min(jnp.asarray(speed))) if jnp.size(speed) else float("nan")
        if not (math.isfinite(s) and math.isfinite(smin) and 0.0 < smin and s <= 100.0):
            raise ConfigError(f"impact speed must be in (0, 100] m/s, got {speed!r}")
    return _run_jit(params, vehicle, jnp.asarray(speed, dtype=float), n_samples(duration, solver), solver)
