"""Force laws of the reference world, pure functions of scalars (no state, no ``sim``).

Units: crush and lengths in m, stiffness per unit of contact area in N/m^3 (a force
``k * A * d`` as in V-SIM), point stiffness in N/m, forces in N, energy in J.
"""

from __future__ import annotations

import math


def structure_loading_force(d: float, k_c: float, area: float, zone_depth: float | None = None,
                            k_zone: float | None = None) -> float:
    """Front-structure force on its loading (virgin) curve at crush ``d`` (m), N.

    ``k_c * A * d`` below ``zone_depth``; past it ``k_c A zone_depth + k_zone A (d - zone_depth)``
    (continuous, a kink at ``zone_depth``). No rate factor here; 0 for ``d <= 0``.
    """
    if d <= 0.0:
        return 0.0
    if zone_depth is None or k_zone is None or d <= zone_depth:
        return k_c * area * d
    return k_c * area * zone_depth + k_zone * area * (d - zone_depth)


def rate_factor(d_dot: float, rate_coefficient: float) -> float:
    """Strain-rate multiplier of the loading force, ``1 + c * max(d_dot, 0)`` (c in s/m)."""
    return 1.0 + rate_coefficient * max(d_dot, 0.0)


def unloading_branch(d_max: float, e_abs: float, restitution: float, k_r: float, area: float,
                     exponent: float) -> tuple[float, float, float]:
    """The unloading curve left at a compression end.

    Parameters
    ----------
    d_max : float
        Maximum crush reached, m.
    e_abs : float
        Energy absorbed on the loading curve up to ``d_max``, J.
    restitution, k_r, area, exponent
        e (1), k_restitution (N/m^3), contact area (m^2), unloading exponent n (1).

    Returns
    -------
    (d_p, delta, f_s) : residual crush (m), elastic spring-back ``d_max - d_p`` (m) and the
    force at ``d_max`` on the unloading curve (N). ``delta = sqrt(2 e^2 E_abs / (k_r A))``;
    ``F(d) = f_s ((d - d_p)/delta)^n`` with ``f_s = (n+1) e^2 E_abs / delta``, so the energy
    given back is exactly ``e^2 E_abs`` (for a linear loading ``delta = e d_max sqrt(k_c/k_r)``,
    the V-SIM value).
    """
    returned = restitution ** 2 * e_abs
    if returned <= 0.0 or d_max <= 0.0:
        return d_max, 0.0, 0.0
    delta = math.sqrt(2.0 * returned / (k_r * area))
    f_s = (exponent + 1.0) * returned / delta
    return d_max - delta, delta, f_s


def unloading_force(d: float, d_p: float, delta: float, f_s: float, exponent: float) -> float:
    """Force on the unloading/re-loading curve at crush ``d`` (m), N (0 below ``d_p``)."""
    if delta <= 0.0 or d <= d_p:
        return 0.0
    return f_s * ((d - d_p) / delta) ** exponent


def engine_contact_force(d_e: float, loading: bool, d_emax: float, k_e: float, e_e: float) -> float:
    """Engine-on-barrier force at engine penetration ``d_e`` (m), N, compressive >= 0.

    Loading: ``k_e d_e``. Unloading from ``d_emax`` on a line of slope ``k_e / e_e^2`` that
    starts at the loading force (continuous), ending at ``d_emax (1 - e_e^2)``: the energy
    given back is ``e_e^2`` times the energy absorbed.
    """
    if loading:
        return k_e * d_e if d_e > 0.0 else 0.0
    k_u = k_e / max(e_e, 1e-3) ** 2
    return max(0.0, k_e * d_emax - k_u * (d_emax - d_e))


def tyre_mu(slip: float, mu_peak: float, mu_slide: float, s_peak: float = 0.12,
            s_decay: float = 0.15) -> float:
    """Longitudinal friction coefficient at slip ``s = (omega r - v)/v_ref`` (odd in s).

    Rises as ``mu_peak sin(pi/2 |s|/s_peak)`` to ``mu_peak`` at ``s_peak``, then falls
    exponentially (scale ``s_decay``) to ``mu_slide``: at full slide (|s| = 1) it is
    mu_slide within 0.3 %.
    """
    a = abs(slip)
    if a <= s_peak:
        g = mu_peak * math.sin(0.5 * math.pi * a / s_peak)
    else:
        g = mu_slide + (mu_peak - mu_slide) * math.exp(-(a - s_peak) / s_decay)
    return math.copysign(g, slip)


def smooth_sign(v: float, v_ref: float = 0.05) -> float:
    """``tanh(v / v_ref)``: a sign that is smooth through 0 (v, v_ref in m/s)."""
    return math.tanh(v / v_ref)
