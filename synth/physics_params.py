"""Parameters of the reference world (:class:`RefParams`) and the quantities derived from
them and the vehicle file (:class:`Model`: cabin mass and inertia, body points, suspension
split). No ``sim``, ``identify`` or ``video`` import.

Frames: vehicle frame x forward from the rear bumper, z up from the ground (m). Body
offsets ``(u, w)`` are measured from the cabin's own CG along the body's x and z axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from synth.vehicle import Car, SynthError

G = 9.81  # m/s^2


@dataclass(frozen=True)
class RefParams:
    """Hidden physics of one reference world. ``None`` fields take car-dependent defaults
    (see :func:`derive`).

    Attributes
    ----------
    k_compression, k_restitution : float
        Structure stiffness per unit contact area, loading and unloading, N/m^3.
    restitution : float
        e (1): the structure gives back e^2 of the energy it absorbed.
    dz_contact : float
        Height of the structure's force relative to the vehicle file's CG, m (negative = below).
    unloading_exponent : float
        n (1) of the unloading curve ``F_s ((d - d_p)/delta)^n``.
    zone_depth : float or None
        m, crush where the stiffness changes to ``k_zone`` (N/m^3); None = no zone.
    rate_coefficient : float
        s/m, loading force times ``1 + c max(d_dot, 0)``.
    mu_face : float
        1, vertical friction of the crushed front (and of the engine) on the barrier face.
    engine_mass : float or None
        kg; default 0.14 x test mass. 0 = no engine degree of freedom (rigid with the cabin).
    engine_x, engine_z : float or None
        Vehicle-frame position of the engine's CG at rest, m. Defaults: ``engine_z`` 0.5 m,
        ``engine_x`` = ``front_x - engine_gap - engine_half_length``.
    engine_gap : float or None
        m, structure crush at which the engine's front meets the barrier with the engine at
        rest on its mounts (its front face is at vehicle-frame x ``front_x - engine_gap``,
        at height ``engine_z``). Default: out of reach, ``1.3 v sqrt(m/(k_c A)) + stop + 0.05``
        at 64 km/h.
    engine_half_length : float
        m, engine CG to its front face, used only for the default ``engine_x``.
    mount_stiffness, mount_damping, mount_break_force, mount_friction : float
        N/m, N s/m (default damping ratio 0.2), N (default 25 m_e g), N (sliding friction
        after the mounts let go, default 0.2 m_e g).
    engine_stop_forward, engine_stop_back : float
        m, engine travel relative to the cabin (along body x) before it hits a stop.
    engine_stop_stiffness : float
        N/m of those stops (damping ratio 0.3 on the engine mass).
    engine_stiffness : float
        N/m, engine block against the barrier (loading).
    engine_restitution : float
        1, the engine contact gives back its square of the absorbed energy.
    wheel_mass : float
        kg per wheel (unsprung; two wheels per axle).
    tyre_stiffness, tyre_damping : float
        Per wheel, radial, N/m and N s/m; unilateral (never pulls).
    wheel_spin_inertia : float
        kg m^2 per wheel (spinning parts only).
    rolling_resistance, mu_peak, mu_slide : float
        1: rolling resistance coefficient; adhesion peak and full-slide friction.
    jam_depth : float or None
        m, crush at which the front wheels jam (stop turning); None = never.
    release_margin : float
        m, the jam lets go when the crush falls below ``jam_depth - release_margin``.
    bump_travel, droop_travel : float
        m, suspension compression / extension from rest before a stop (stop stiffness
        ``susp_stop_stiffness`` N/m per axle).
    """

    k_compression: float
    k_restitution: float
    restitution: float
    dz_contact: float
    unloading_exponent: float = 2.0
    zone_depth: float | None = None
    k_zone: float | None = None
    rate_coefficient: float = 0.0
    mu_face: float = 0.25
    engine_mass: float | None = None
    engine_x: float | None = None
    engine_z: float | None = None
    engine_gap: float | None = None
    engine_half_length: float = 0.3
    mount_stiffness: float = 8.0e5
    mount_damping: float | None = None
    mount_break_force: float | None = None
    mount_friction: float | None = None
    engine_stop_forward: float = 0.05
    engine_stop_back: float = 0.10
    engine_stop_stiffness: float = 3.0e6
    engine_stiffness: float = 3.0e6
    engine_restitution: float = 0.2
    wheel_mass: float = 40.0
    tyre_stiffness: float = 250.0e3
    tyre_damping: float = 300.0
    wheel_spin_inertia: float = 1.0
    rolling_resistance: float = 0.015
    mu_peak: float = 0.9
    mu_slide: float = 0.8
    jam_depth: float | None = None
    release_margin: float = 0.05
    bump_travel: float = 0.08
    droop_travel: float = 0.10
    susp_stop_stiffness: float = 5.0e5


def crush_estimate(car: Car, k_c: float, v0: float) -> float:
    """Point-mass maximum crush for a linear structure, ``v0 sqrt(m / (k_c A))``, m."""
    return v0 * math.sqrt(car.mass / (k_c * car.contact_area))


def default_engine_gap(car: Car, k_c: float, stop_forward: float, v_max: float = 64.0 / 3.6) -> float:
    """An engine gap out of reach at ``v_max`` (m/s): 1.3 x the crush estimate plus the
    engine's forward stop travel plus 5 cm, m."""
    return 1.3 * crush_estimate(car, k_c, v_max) + stop_forward + 0.05


@dataclass(frozen=True)
class Model:
    """Everything the equations of motion need, derived from a car and its parameters.

    Masses kg, inertia kg m^2, offsets ``(u, w)`` m from the cabin CG in body axes, per-axle
    values as (front, rear) tuples.
    """

    p: RefParams
    area: float            # m^2
    m_total: float
    m_c: float             # cabin (sprung, without engine)
    i_c: float             # cabin pitch inertia about its own CG
    m_e: float             # engine (0: none)
    m_wa: tuple            # unsprung mass per axle
    i_wa: tuple            # spin inertia per axle
    cab_cg: tuple          # vehicle-frame (x, z) of the cabin CG
    contact: tuple         # body offsets of the structure contact point
    engine: tuple          # engine CG at rest
    engine_front: tuple    # engine front face at rest
    axle: tuple            # ((u, w) front, (u, w) rear): body axle points (axle_x, wheel_radius)
    file_cg: tuple         # the vehicle file's CG point
    accel_point: tuple     # rear-seat crossmember point
    radius: float          # rolling radius, m
    r0: tuple              # unloaded tyre radius per axle, m
    k_s: tuple             # suspension spring per axle, N/m
    c_s: tuple             # suspension damper per axle, N s/m
    k_t: tuple             # tyre radial stiffness per axle, N/m
    c_t: tuple             # tyre damping per axle, N s/m
    f_s0: tuple            # suspension preload at rest per axle, N
    mount_c: float
    mount_break: float
    mount_friction: float
    stop_c: float
    engine_gap: float


def derive(car: Car, p: RefParams) -> Model:
    """Cabin mass properties and every body point, from the file (whole car) and ``p``.

    The cabin's mass is the test mass minus engine and four wheels; its CG follows from the
    file CG; its pitch inertia is the file's (whole car about the file CG) minus the
    parallel-axis terms of engine, wheels and cabin (kept >= 25 % of the file value).
    The file's axle stiffness is split so that suspension and tyre in series give it back:
    ``k_s = 1/(1/k_axle - 1/k_tyre)``; the suspension damper ``c_axle ((k_s + k_t)/k_t)^2``.

    Raises
    ------
    SynthError
        Masses that leave no cabin, an engine whose front would be behind its CG, a tyre
        softer than the file's whole axle.
    """
    m = car.mass
    area = car.contact_area
    k_c = p.k_compression
    m_e = 0.14 * m if p.engine_mass is None else float(p.engine_mass)
    gap = default_engine_gap(car, k_c, p.engine_stop_forward) if p.engine_gap is None else float(p.engine_gap)
    x_front_face = car.front_x - gap
    x_e = x_front_face - p.engine_half_length if p.engine_x is None else float(p.engine_x)
    z_e = 0.5 if p.engine_z is None else float(p.engine_z)
    if m_e > 0 and x_front_face - x_e < 0.05:
        raise SynthError(f"engine front ({x_front_face:.3f} m) must be ahead of its CG ({x_e:.3f} m)")
    m_w = float(p.wheel_mass)
    r = car.wheel_radius
    xf, xr = car.front_axle_x, car.rear_axle_x
    x_cg, h = car.x_cg, car.cg_height
    m_c = m - m_e - 4.0 * m_w
    if m_c < 0.5 * m:
        raise SynthError(f"engine and wheels ({m_e + 4 * m_w:.0f} kg) leave too little cabin of {m:.0f} kg")
    x_c = (m * x_cg - m_e * x_e - 2 * m_w * (xf + xr)) / m_c
    z_c = (m * h - m_e * z_e - 4 * m_w * r) / m_c

    def d2(x, z):
        return (x - x_cg) ** 2 + (z - h) ** 2

    i_c = car.pitch_inertia - m_c * d2(x_c, z_c) - m_e * d2(x_e, z_e) - 2 * m_w * (d2(xf, r) + d2(xr, r))
    i_c = max(i_c, 0.25 * car.pitch_inertia)

    def off(x, z):
        return (x - x_c, z - z_c)

    # static axle loads of the whole car, tyre compression and suspension preload
    n_f = m * G * (x_cg - xr) / car.wheelbase
    n_r = m * G * (xf - x_cg) / car.wheelbase
    k_t = (2 * p.tyre_stiffness, 2 * p.tyre_stiffness)
    k_s, c_s = [], []
    for i in range(2):
        k_ax, c_ax = car.axle_stiffness[i], car.axle_damping[i]
        if k_t[i] <= 1.2 * k_ax:
            raise SynthError(f"tyres ({k_t[i]:.0f} N/m per axle) must be stiffer than the file's axle ({k_ax:.0f} N/m)")
        ks = 1.0 / (1.0 / k_ax - 1.0 / k_t[i])
        k_s.append(ks)
        c_s.append(c_ax * ((ks + k_t[i]) / k_t[i]) ** 2)
    f_s0 = (n_f - 2 * m_w * G, n_r - 2 * m_w * G)
    r0 = (r + n_f / k_t[0], r + n_r / k_t[1])
    mount_c = 2 * 0.2 * math.sqrt(p.mount_stiffness * max(m_e, 1e-9)) if p.mount_damping is None else p.mount_damping
    return Model(
        p=p, area=area, m_total=m, m_c=m_c, i_c=i_c, m_e=m_e, m_wa=(2 * m_w, 2 * m_w),
        i_wa=(2 * p.wheel_spin_inertia, 2 * p.wheel_spin_inertia), cab_cg=(x_c, z_c),
        contact=off(car.front_x, h + p.dz_contact), engine=off(x_e, z_e),
        engine_front=off(x_front_face, z_e), axle=(off(xf, r), off(xr, r)), file_cg=off(x_cg, h),
        accel_point=off(xr + 0.35 * car.wheelbase, 0.35), radius=r, r0=r0, k_s=tuple(k_s),
        c_s=tuple(c_s), k_t=k_t, c_t=(2 * p.tyre_damping, 2 * p.tyre_damping), f_s0=f_s0,
        mount_c=mount_c,
        mount_break=25 * m_e * G if p.mount_break_force is None else p.mount_break_force,
        mount_friction=0.2 * m_e * G if p.mount_friction is None else p.mount_friction,
        stop_c=2 * 0.3 * math.sqrt(p.engine_stop_stiffness * max(m_e, 1e-9)), engine_gap=gap)
