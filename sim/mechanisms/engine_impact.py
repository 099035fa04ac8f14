"""A second body: the engine on its mounts, reaching the barrier after a gap."""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp

from sim.mechanisms.base import Mechanism
from sim.smooth import smooth_step


def _crush_force(d, d_max, rate, k, e):
    """N, a crushable contact of loading stiffness ``k`` (N/m) at crush ``d`` (m) with its
    largest crush so far ``d_max`` and crush rate ``rate`` (m/s): k d while loading, else the
    line of slope k / e^2 from (d_max, k d_max), which gives back e^2 of the energy."""
    e2 = jnp.maximum(e, 1e-3) ** 2
    loading = (d >= d_max) & (rate > 0.0)
    return jnp.where(loading, k * d, k / e2 * jnp.maximum(d - d_max * (1.0 - e2), 0.0))


class EngineImpact(Mechanism):
    """The engine (powertrain) is a second mass m_e that moves along x on its own.

    The cabin keeps the rest of the vehicle's mass, m - m_e, in x (z and pitch keep the whole
    car's mass and inertia: the engine rides up and down with the body). With u = x_e - x
    the engine's displacement relative to the cabin (m, forward positive) and w its rate:

    - mounts: F_m = (1 - b) (k_m u + c_m w), c_m = 2 * 0.3 * sqrt(k_m m_e); they let go for
      good (b: 0 -> 1, a latched logistic step over 2 % of the force) once |k_m u + c_m w|
      exceeds ``mount_break_force``;
    - ahead of the engine: once it has moved ``stop_forward`` forward of its place on the
      cabin, the mounts' travel limiters (snubbers) take it along: F_s = max(0, k_s (u -
      stop_forward) + c_s w) while u > stop_forward, k_s = ``STOP_STIFFNESS``, c_s = 2 * 0.3 *
      sqrt(k_s m_e). An engine whose mounts have let go is thus carried by the cabin and
      reaches the barrier only when the crush does (not flying on alone: without the stop a
      cabin decelerating at 30 g leaves a free engine 0.9 m ahead within 80 ms);
    - behind the engine: once it has moved ``stop_back`` back towards the firewall, the
      parts between them crush, c = max(0, -u - stop_back), with force k_rear c on the
      loading curve and a steep unloading line giving back ``RESTITUTION_REAR``^2 of the energy
      (the crush is plastic: the engine does not spring forward again);
    - barrier: the engine's front is ``gap`` behind the barrier face at first contact, so it
      meets the barrier when its own displacement x_e exceeds ``gap`` (with the engine at
      rest on its mounts, when the structure has crushed by ``gap``). Its crush
      d_e = max(0, x_e - gap) loads F_e = k_engine d_e; it unloads on the line of slope
      k_engine / e_e^2 from its largest crush, giving back e_e^2 of the energy it absorbed.

    The cabin feels F_m + F_s - F_r (forward positive); the engine -F_m - F_s + F_r - F_e; the barrier
    feels the structure's force plus F_e. ``engine_mass`` = 0 switches it off exactly (the
    engine then moves with the cabin and carries no force).

    Attributes
    ----------
    engine_mass : kg, m_e (part of the vehicle's mass).
    gap : m, structure crush at which the engine meets the barrier.
    k_engine : N/m, engine block against the barrier (loading).
    k_rear : N/m, the parts behind the engine crushed between it and the firewall.
    restitution_engine : 1, e_e in (0, 1].
    mount_stiffness : N/m, k_m, all mounts together along x.
    mount_break_force : N, mount force at which the mounts let go.
    stop_forward : m, engine travel forwards before the mounts' limiters carry it.
    stop_back : m, engine travel backwards before the parts behind it crush (static).
    """

    effect = "engine_impact"
    explanation = (
        "The engine is a separate mass on its mounts: once the front structure has crushed by "
        "the gap, the engine block hits the barrier and is stopped hard while the cabin is still "
        "moving, so the barrier feels a force peak that the cabin's accelerometers barely show."
    )
    units = {"engine_mass": "kg", "gap": "m", "k_engine": "N/m", "k_rear": "N/m", "restitution_engine": "1",
             "mount_stiffness": "N/m", "mount_break_force": "N", "stop_forward": "m"}

    engine_mass: jnp.ndarray
    gap: jnp.ndarray
    k_engine: jnp.ndarray
    k_rear: jnp.ndarray
    restitution_engine: jnp.ndarray
    mount_stiffness: jnp.ndarray
    mount_break_force: jnp.ndarray
    stop_forward: jnp.ndarray = 0.05
    stop_back: float = eqx.field(static=True, default=0.05)

    DAMPING_RATIO = 0.3
    STOP_STIFFNESS = 3.0e6  # N/m, a hard contact, as the engine block's default k_engine
    TYPICAL_MOUNT_STIFFNESS = 8.0e5  # N/m, all mounts together along x
    TYPICAL_MOUNT_BREAK_G = 25.0  # the mounts let go at this deceleration of the engine (g)
    RESTITUTION_REAR = 0.1

    @classmethod
    def defaults(cls, engine_mass, gap, **overrides) -> "EngineImpact":
        """An engine of ``engine_mass`` (kg) at ``gap`` (m) with typical mounts and block:
        k_engine 3 MN/m, k_rear 1 MN/m, e_e 0.1, k_m 0.8 MN/m, mounts letting go at 25 g on
        the engine, forward stop 0.05 m ahead (as far as ``stop_back`` behind)."""
        values = dict(engine_mass=engine_mass, gap=gap, k_engine=3.0e6, k_rear=1.0e6, restitution_engine=0.1,
                      mount_stiffness=cls.TYPICAL_MOUNT_STIFFNESS,
                      mount_break_force=cls.TYPICAL_MOUNT_BREAK_G * 9.81 * jnp.asarray(engine_mass, dtype=float),
                      stop_forward=0.05)
        values.update(overrides)
        return cls(**{k: jnp.asarray(v, dtype=float) for k, v in values.items()})

    # -- the second body's hooks (see Mechanism) --

    has_body = True

    def detached_mass(self):
        return jnp.maximum(self.engine_mass, 0.0)

    def body_init(self, speed):
        zero = jnp.zeros_like(speed)
        # x_e (m), v_e (m/s, half step), b (broken fraction), d_e max (m), rear crush max (m)
        return jnp.stack([zero, speed + zero, zero, zero, zero])

    def body_forces(self, state, q, v):
        active = self.engine_mass > 0.0
        m_e = jnp.where(active, self.engine_mass, 1.0)
        x_e, v_e, broken = state[0], state[1], state[2]
        u, w = x_e - q[0], v_e - v[0]
        c_m = 2.0 * self.DAMPING_RATIO * jnp.sqrt(self.mount_stiffness * m_e)
        elastic = self.mount_stiffness * u + c_m * w
        f_mount = (1.0 - broken) * elastic
        ahead = u - self.stop_forward
        c_s = 2.0 * self.DAMPING_RATIO * jnp.sqrt(self.STOP_STIFFNESS * m_e)
        f_stop = jnp.where(ahead > 0.0, jnp.maximum(self.STOP_STIFFNESS * ahead + c_s * w, 0.0), 0.0)
        rear = jnp.maximum(-u - self.stop_back, 0.0)
        f_rear = _crush_force(rear, state[4], -w, self.k_rear, self.RESTITUTION_REAR)
        d_e = jnp.maximum(x_e - self.gap, 0.0)
        f_engine = _crush_force(d_e, state[3], v_e, self.k_engine, self.restitution_engine)
        f_cabin = jnp.where(active, f_mount + f_stop - f_rear, 0.0)
        f_barrier = jnp.where(active, f_engine, 0.0)
        broken_new = jnp.maximum(
            broken, smooth_step(jnp.abs(elastic) - self.mount_break_force, 0.02 * self.mount_break_force))
        return f_cabin, f_barrier, (m_e, broken_new, active)

    def body_advance(self, state, forces, aux, q_new, v_new, dt):
        f_cabin, f_barrier = forces
        m_e, broken_new, active = aux
        v_e = state[1] + dt * (-f_cabin - f_barrier) / m_e
        x_e = state[0] + dt * v_e
        rear = jnp.maximum(q_new[0] - x_e - self.stop_back, 0.0)
        return jnp.stack([
            jnp.where(active, x_e, q_new[0]),
            jnp.where(active, v_e, v_new[0]),
            jnp.where(active, broken_new, 0.0),
            jnp.maximum(state[3], jnp.where(active, jnp.maximum(x_e - self.gap, 0.0), 0.0)),
            jnp.maximum(state[4], jnp.where(active, rear, 0.0)),
        ])

    def body_observed(self, state, new_state, f_barrier):
        return dict(engine_x=state[0], engine_vx=0.5 * (state[1] + new_state[1]), engine_force=f_barrier,
                    engine_crush=jnp.maximum(state[0] - self.gap, 0.0), mounts_broken=state[2])
