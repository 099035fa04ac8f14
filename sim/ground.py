"""Axles and tyres: one spring-damper per axle with unilateral ground contact, and the
tyres' longitudinal forces.

Each axle is a body point (px, pz) relative to the CG (front: (a, r - h), rear:
(-b, r - h)), joined to the ground by a linear spring-damper (suspension and tyre in
series) that can push but never pull:

    N = R(k * (delta0 - dZ) - c * dZ_dot),

dZ the axle point's rise from its static height, delta0 = static load / k, R a ramp
smoothed over ``ground_force_width`` (N). The argument of R is the axle's *contact
margin*: when it is negative the wheel is off the ground.

Each tyre's longitudinal force acts at the ground below its axle, against the sliding
direction of that point:

    T = -mu * N * tanh(v_g / friction_speed_width),
    mu = rolling_resistance + blocked * (mu_block(v_g) - rolling_resistance),
    mu_block(v) = mu_slip + (mu_adhesion - mu_slip) * exp(-(v / stribeck_speed)^2),

so a rolling wheel resists with the rolling-resistance coefficient and a blocked wheel
slides with the slip coefficient, rising to the adhesive one as it comes to rest.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from sim.smooth import smooth_relu, smooth_sign
from sim.vehicle import GRAVITY


def ground_forces(q, v, vehicle, params, front_blocked, solver):
    """Generalised force of gravity, axles and tyres (their rolling resistance and a blocked
    wheel's sliding; the rolling wheels' spin is ``sim.wheels``), and what the outputs need.

    Parameters
    ----------
    q, v : (3,) coordinates [x, z, pitch] and velocities [m/s, m/s, rad/s].
    vehicle : sim.Vehicle; params : sim.Params.
    front_blocked : fraction 0..1 by which the front wheels are blocked.
    solver : sim.Solver (smoothing widths).

    Returns
    -------
    force : (3,) generalised force [N, N, N m].
    normal : (2,) N, front and rear axle normal forces (>= 0).
    margin : (2,) N, contact margins (negative: wheel off the ground).
    lift : (2,) m, how far each axle is above the height where its wheel just touches.
    """
    x_dot, z_dot, pitch_rate = v[0], v[1], v[2]
    s, c = jnp.sin(q[2]), jnp.cos(q[2])
    h = vehicle.cg_height
    px = jnp.stack([vehicle.cg_to_front_axle, -vehicle.cg_to_rear_axle])
    pz = vehicle.wheel_radius - h

    rise = axle_rise(q[1], q[2], vehicle)
    rise_rate = z_dot - (px * c + pz * s) * pitch_rate
    k, damping = vehicle.axle_stiffness, vehicle.axle_damping
    static_deflection = vehicle.static_axle_loads / k
    margin = k * (static_deflection - rise) - damping * rise_rate
    normal = smooth_relu(margin, solver.ground_force_width)
    lift = jnp.maximum(rise - static_deflection, 0.0)

    ground_lever = -px * s - h * c  # dX/dpitch of the ground point below each axle
    ground_speed = x_dot + ground_lever * pitch_rate
    mu_block = params.mu_slip + (params.mu_adhesion - params.mu_slip) * jnp.exp(
        -((ground_speed / solver.stribeck_speed) ** 2)
    )
    blocked = jnp.stack([front_blocked, jnp.zeros_like(front_blocked)])
    mu = params.rolling_resistance + blocked * (mu_block - params.rolling_resistance)
    traction = -mu * normal * smooth_sign(ground_speed, solver.friction_speed_width)

    force = jnp.stack(
        [
            jnp.sum(traction),
            jnp.sum(normal) - vehicle.mass * GRAVITY,
            jnp.sum(normal * (-px * c - pz * s)) + jnp.sum(traction * ground_lever),
        ]
    )
    return force, normal, margin, lift


def axle_rise(z, pitch, vehicle):
    """m, (..., 2): each axle point's (front, rear) rise from its height with the car at rest
    on its wheels, for the CG's heave ``z`` (m) and pitch ``pitch`` (rad, nose-down positive),
    of any one shape."""
    z, pitch = jnp.asarray(z)[..., None], jnp.asarray(pitch)[..., None]
    px = jnp.stack([vehicle.cg_to_front_axle, -vehicle.cg_to_rear_axle])
    pz = vehicle.wheel_radius - vehicle.cg_height
    return z - px * jnp.sin(pitch) + pz * (jnp.cos(pitch) - 1.0)


def wheel_centre_rise(axle_z, margin):
    """m, per sample: how far a wheel's centre stands above the floor, from its axle point's
    height ``axle_z`` (m, any fixed origin) and the axle's contact margin ``margin`` (N),
    both (n,). 0 while the margin is >= 0 (the tyre on the floor); where it is negative the
    wheel has left the floor and rises with the axle point from the height that point had
    at the last sample on the floor (the first sample, for a wheel off the floor from the
    start), never below the floor. How a film's hub target moves: what the renderer of our
    own films draws (``identify.recordings.synthetic``) and what a lifted rear hub is set
    against (``identify.discover.candidates.rear_axle_lift``)."""
    axle_z, margin = jnp.asarray(axle_z), jnp.asarray(margin)
    grounded = margin >= 0.0
    last = jax.lax.cummax(jnp.where(grounded, jnp.arange(axle_z.shape[0]), 0))
    return jnp.where(grounded, 0.0, jnp.maximum(axle_z - axle_z[last], 0.0))
