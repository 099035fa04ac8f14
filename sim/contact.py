"""The hysteretic barrier contact (``docs/physics.md``).

Crush depth d = max(0, X_c - X_barrier): X_c = x + l_f + dz' sin(pitch) is the horizontal
position of the contact point, at the front bumper (l_f ahead of the CG) on the line of
action of the force, dz' above the CG in the body frame; the barrier face is where that
point was at first contact. The line of action stays at dz' from the CG, so the force's
moment about the CG is -dz' * F * cos(pitch) (~ -dz' * F): nose down for dz' < 0.

- loading (d at its running maximum and increasing): F = k_compression * A * d, then each
  mechanism's ``loading_force`` hook in order;
- unloading: the straight line F = k_restitution * A * (d - d_p), ending at the residual
  crush d_p, with d_max - d_p = e * sqrt(2 E_abs / (k_restitution * A)) so that the energy
  given back is e^2 times the energy E_abs absorbed on the loading curve (for the linear law
  this is the paper's d_max - d_p = e * d_max * sqrt(k_c / k_r)). F >= 0 always, 0 without
  contact.

The force acts horizontally on the body at the contact point, away from the barrier.

Friction on the barrier face (``Params.mu_face``, 0 in V-SIM): as the car pitches, the
contact point, l_f ahead of the CG, slides up or down the face, and friction opposes it with
a vertical force of at most mu_face * F. It is applied per step as an impulse on the
point's vertical velocity (Moreau's velocity-level Coulomb friction): the impulse that would
stop the point's sliding, held within mu_face * F * dt by a tanh, so a sticking point (the
usual case: a crushed front pressed into the face) holds at the model's step where a force
law mu F sign(v) would need a far smaller one. The tanh is not a clamp: near the limit of
sticking the point creeps (at half the limit, by 5 % of the speed the capped impulse would
take away), so friction there acts a little weaker than mu_face. The lever arm is the
undeformed front's, l_f, not l_f minus the crush (as the reference world's is too).
"""

from __future__ import annotations

import jax.numpy as jnp


def contact_geometry(q, dz_contact):
    """Crush depth and the contact point's horizontal Jacobian.

    Parameters
    ----------
    q : (3,) [x (m), z (m), pitch (rad, nose-down positive)], CG displacement from first contact.
    dz_contact : m, contact-point height above the CG.

    Returns
    -------
    crush : m, >= 0.
    jac : (3,) dX_c/dq; the crush rate is ``jac @ v`` and a force F on the body pushing it
        away from the barrier has generalised force ``-F * jac``.
    """
    s, c = jnp.sin(q[2]), jnp.cos(q[2])
    crush = jnp.maximum(q[0] + dz_contact * s, 0.0)
    jac = jnp.stack([jnp.ones_like(s), jnp.zeros_like(s), dz_contact * c])
    return crush, jac


def loading_force(crush, crush_rate, params, vehicle):
    """N, barrier force on the loading curve at crush (m) and crush rate (m/s)."""
    force = params.k_compression * vehicle.contact_area * crush
    for mechanism in params.mechanisms:
        force = mechanism.loading_force(force, crush, crush_rate, params, vehicle)
    return force


def unloading_force(crush, crush_max, energy_absorbed, params, vehicle):
    """N, barrier force on the unloading line.

    Parameters
    ----------
    crush : m, current crush.
    crush_max : m, largest crush so far.
    energy_absorbed : J, work done on the loading curve so far.
    """
    k_r = params.k_restitution * vehicle.contact_area
    elastic = params.restitution * jnp.sqrt(jnp.maximum(2.0 * energy_absorbed / k_r, 1e-30))
    residual_crush = crush_max - elastic
    in_contact = crush > 0.0
    return jnp.where(in_contact, k_r * jnp.maximum(crush - residual_crush, 0.0), 0.0)


def face_point_jacobian(q, dz_contact, front_to_cg):
    """(3,) dZ_c/dq: how the contact point's height moves with [x, z, pitch].

    The point is ``front_to_cg`` (m) ahead of the CG and ``dz_contact`` (m) above it in the
    body frame; with pitch nose-down positive, Z_c = z - l_f sin(pitch) + dz' cos(pitch).
    """
    s, c = jnp.sin(q[2]), jnp.cos(q[2])
    return jnp.stack([jnp.zeros_like(s), jnp.ones_like(s), -front_to_cg * c - dz_contact * s])


def face_friction_impulse(v_trial, inv_mass, jac_z, force, mu_face, dt):
    """N s, the vertical friction impulse the barrier face gives the contact point in a step.

    Parameters
    ----------
    v_trial : (3,) m/s, m/s, rad/s, the velocity at the step's end without face friction.
    inv_mass : (3,) the inverse of the diagonal mass matrix (1/kg, 1/kg, 1/(kg m^2)).
    jac_z : (3,) :func:`face_point_jacobian`.
    force : N, the barrier's (horizontal) contact force in the step, >= 0.
    mu_face : 1, the face's friction coefficient.
    dt : s, the step.

    Returns
    -------
    The impulse P (N s, up positive) on the contact point: -P_max tanh(m_eff v_c / P_max)
    with P_max = mu_face * force * dt, v_c = jac_z @ v_trial and m_eff the point's effective
    mass; it stops a slow point (sticking) and is P_max against a fast one (sliding).
    """
    cap = mu_face * force * dt
    m_eff = 1.0 / (jac_z @ (inv_mass * jac_z))
    stopping = m_eff * (jac_z @ v_trial)
    positive = cap > 1e-12
    safe_cap = jnp.where(positive, cap, 1.0)
    return jnp.where(positive, -safe_cap * jnp.tanh(stopping / safe_cap), 0.0)
