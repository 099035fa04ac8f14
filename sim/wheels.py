"""The wheels' spin: each axle's wheels turn on their bearings, and the tyre's grip on the
floor spins them down (or up) towards rolling.

A rolling wheel's spin is momentum the crash must stop too: the tyre's friction that keeps
it rolling while the car decelerates pushes the car forward, an effective mass I / r^2 per
axle (about 2-3 % of a car's). Where the grip cannot keep up (an axle unloaded by the
pitch), the wheel slips and keeps spinning; its tyre then pushes at most mu N.

The grip is a velocity-level Coulomb friction impulse at each axle's patch (Moreau's, as the
barrier face's in ``sim.contact``): the impulse that would make the patch roll, held within
mu N dt by a tanh, stable at any step and smooth in the parameters. The tyre's force acts
on the body at the axle (the wheel turns freely on its bearing); its torque turns the wheel.

Units: N s, m/s, rad/s, kg m^2.
"""

from __future__ import annotations

import jax.numpy as jnp


def axle_jacobians(q, vehicle):
    """(2, 3) dX_axle/dq: how each axle's centre (front, rear) moves along x with [x, z,
    pitch] (pitch nose-down positive; the axle ``wheel_radius`` above the ground, the CG
    ``cg_height``)."""
    s, c = jnp.sin(q[2]), jnp.cos(q[2])
    px = jnp.stack([vehicle.cg_to_front_axle, -vehicle.cg_to_rear_axle])
    lever = -px * s + (vehicle.wheel_radius - vehicle.cg_height) * c
    return jnp.stack([jnp.ones_like(lever), jnp.zeros_like(lever), lever], axis=-1)


def spin_impulses(v_trial, omega, inv_mass, jac_axle, normal, grip, inertia, radius, dt):
    """The tyres' impulses on the body and the wheels' new spins after one step.

    Parameters
    ----------
    v_trial : (3,) m/s, m/s, rad/s, the body's velocity at the step's end without them.
    omega : (2,) rad/s, front and rear wheel spin, forward rolling positive.
    inv_mass : (3,) the inverse of the body's diagonal mass matrix.
    jac_axle : (2, 3) :func:`axle_jacobians`.
    normal : (2,) N, each axle's normal force (>= 0).
    grip : (2,) 1, each axle's friction coefficient (0 for a wheel that does not turn).
    inertia : (2,) kg m^2, each axle's spin inertia (both wheels); 0: wheels without it (as
        V-SIM's), which roll with their axle and take nothing from the car.
    radius : m, the rolling radius.
    dt : s, the step.

    Returns
    -------
    (v, omega): the body's velocity and the wheels' spins after the impulses, front first
    then rear (each axle sees the other's change). An axle's impulse P (forward on the body
    at the axle, backward on the tyre's patch) is P_max tanh(P_roll / P_max), P_max = grip
    normal dt, P_roll the impulse that makes the patch roll (its speed over the ground,
    v_axle - omega r, zero): it sticks a slow patch and slides a fast one.
    """
    v, spins = v_trial, []
    for i in range(2):
        jac = jac_axle[i]
        spinning = inertia[i] > 0.0
        inv_inertia = jnp.where(spinning, 1.0 / jnp.where(spinning, inertia[i], 1.0), 0.0)
        cap = jnp.where(spinning, grip[i] * normal[i] * dt, 0.0)
        patch = jac @ v - omega[i] * radius
        rolling = -patch * inertia[i] / (inertia[i] * (jac @ (inv_mass * jac)) + radius**2)
        positive = cap > 1e-12
        safe_cap = jnp.where(positive, cap, 1.0)
        impulse = jnp.where(positive, safe_cap * jnp.tanh(rolling / safe_cap), 0.0)
        v = v + inv_mass * jac * impulse
        spins.append(jnp.where(spinning, omega[i] - impulse * radius * inv_inertia, (jac @ v) / radius))
    return v, jnp.stack(spins)
