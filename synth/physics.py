"""The reference world's crash simulator: a richer, independent planar model of a frontal
rigid-barrier test (side view), used to make data the fit model (``sim``) did not make.

Never imports ``sim``, ``identify`` or ``video``. NumPy/SciPy only: ``solve_ivp`` (LSODA)
between terminal events that switch the discrete state (structure loading/unloading, engine
contact branch, engine mounts letting go, front wheels jamming/releasing).

What it has that the base model lacks: a cabin whose mass and CG exclude the engine and the
unsprung wheels; an engine on breakable mounts that can itself hit the barrier; unsprung
axles with unilateral tyres and spinning wheels (slip-dependent friction, rolling
resistance); a non-linear unloading curve (exponent n) that still returns e^2 of the
absorbed energy; optional stiffness zone and strain-rate dependence; vertical friction of the
crushed front on the barrier face. See :mod:`synth.physics_dynamics` for the equations,
:mod:`synth.physics_laws` for the force laws, :mod:`synth.physics_params` for the parameters.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from synth.physics_dynamics import (I_JB, I_JG, I_PF, I_PR, I_TH, I_V, I_WALL, I_WSTR, I_X, I_Z, I_ZF, I_ZR,
                                    N_STATE, Mode, _off, crush_and_engine, engine_force, events_for,
                                    initial_state, rhs, structure_force, switch)
from synth.physics_params import Model, RefParams, crush_estimate, default_engine_gap, derive
from synth.vehicle import Car, SynthError

__all__ = ["RefParams", "RefMotion", "simulate_reference", "random_params", "derive", "EFFECTS"]

EFFECTS = ("clean", "stiffness_zone", "front_wheel_block", "rate_dependence", "engine_impact", "rear_axle_lift")
MAX_SEGMENTS = 2000
FINE_DT = 5e-5  # s, grid on which event times are located (then interpolated linearly)


@dataclass(frozen=True)
class RefMotion:
    """A simulated crash, sampled at 1/fps from first contact (t = 0).

    All arrays are (n,) float64. Positions are those of the vehicle file's CG point carried by
    the cabin, from where it was at t = 0 (x towards the barrier, z up), pitch nose-down
    positive: the interface's tracks.csv convention.

    Attributes
    ----------
    t : s
    x, z : m;  pitch : rad
    crush : m, the structure's crush at its contact point, >= 0
    front_wheel_angle, rear_wheel_angle : rad, wheel spin relative to the body (0 at t = 0,
        forward rolling positive; a jammed wheel keeps its angle). Absolute = this + pitch.
    front_wheel_dz, rear_wheel_dz : m, wheel-centre height minus the body's axle point
        (axle_x, wheel_radius) carried by the cabin
    front_wheel_height, rear_wheel_height : m, wheel-centre height above its t = 0 height
    cabin_accel_x : m/s^2, ground-frame x acceleration of the rear-seat crossmember point
        (x = rear_axle_x + 0.35 wheelbase, z = 0.35 m), forward positive
    engine_accel_x : m/s^2, the engine CG's, same convention
    engine_dx : m, engine travel relative to the cabin along body x (forward positive)
    force_structure, force_engine, force_barrier : N, compressive positive, barrier = sum
    events_ms : dict of ms or None: compression_end (time of the maximum crush, i.e. the
        last switch from loading to unloading: an engine on its stop can push the structure
        back onto its loading curve for a few tenths of a ms), separation (barrier force 0
        for good), front_wheel_block, front_wheel_unblock (first jam and the release after
        it), rear_wheel_lift, rear_wheel_touchdown (rear tyre compression crosses 0),
        engine_contact (engine front reaches the barrier face), plus mount_break
    v0 : m/s;  max_crush : m
    normal_front, normal_rear, ground_x_front, ground_x_rear : N per axle, ground forces
    momentum_x : N s, x momentum of cabin + engine + unsprung masses
    impulse_barrier, impulse_ground : N s, time integrals of the barrier's (-force_barrier)
        and the ground's x forces on the car from t = 0
    kinetic, gravity_pe : J;  work_nonconservative : J, work of every non-gravity force
        (springs included) from t = 0, integrated as its own state
    work_structure : J, work of the structure's horizontal force on the car
    mass_total : kg (cabin + engine + wheels = the file's test mass)
    """

    t: np.ndarray
    x: np.ndarray
    z: np.ndarray
    pitch: np.ndarray
    crush: np.ndarray
    front_wheel_angle: np.ndarray
    rear_wheel_angle: np.ndarray
    front_wheel_dz: np.ndarray
    rear_wheel_dz: np.ndarray
    front_wheel_height: np.ndarray
    rear_wheel_height: np.ndarray
    cabin_accel_x: np.ndarray
    engine_accel_x: np.ndarray
    engine_dx: np.ndarray
    force_structure: np.ndarray
    force_engine: np.ndarray
    force_barrier: np.ndarray
    events_ms: dict
    v0: float
    max_crush: float
    normal_front: np.ndarray = None
    normal_rear: np.ndarray = None
    ground_x_front: np.ndarray = None
    ground_x_rear: np.ndarray = None
    momentum_x: np.ndarray = None
    impulse_barrier: np.ndarray = None
    impulse_ground: np.ndarray = None
    kinetic: np.ndarray = None
    gravity_pe: np.ndarray = None
    work_nonconservative: np.ndarray = None
    work_structure: np.ndarray = None
    mass_total: float = 0.0
    extra: dict = field(default_factory=dict)


def _integrate(mod: Model, v0: float, duration: float, rtol: float, max_step: float):
    """Segments ``(t0, t1, dense, mode)`` from 0 to ``duration`` and the switches
    ``[(t, name)]``."""
    y = initial_state(mod, v0)
    mode, t = Mode(), 0.0
    segments, switches = [], []
    atol = np.full(N_STATE, 1e-8)
    atol[I_V:I_V + 6] = 1e-7
    atol[12:16] = 1e-6
    atol[16:] = 1e-3
    while t < duration - 1e-12:
        if len(segments) >= MAX_SEGMENTS:
            raise SynthError(f"reference simulation chattered: {len(segments)} mode switches by {t * 1e3:.1f} ms")
        evs = events_for(mod, mode)
        sol = solve_ivp(lambda tt, yy, md=mode: rhs(tt, yy, mod, md), (t, duration), y, method="LSODA", events=evs,
                        dense_output=True,
                        rtol=rtol, atol=atol, max_step=max_step)
        if sol.status < 0:
            raise SynthError(f"reference simulation failed at {sol.t[-1] * 1e3:.1f} ms: {sol.message}")
        t1 = float(sol.t[-1])
        segments.append((t, t1, sol.sol, mode))
        if sol.status != 1:
            break
        fired = [(float(te[0]), k) for k, te in enumerate(sol.t_events) if len(te)]
        te, k = min(fired)
        name = evs[k].name
        switches.append((te, name))
        mode, y = switch(mod, mode, name, sol.y_events[k][0])
        t = te
    return segments, switches


def _eval(segments, times: np.ndarray) -> tuple[np.ndarray, list]:
    """States (N_STATE, n) and the mode at each time (the later segment at a switch)."""
    out = np.empty((N_STATE, len(times)))
    modes = [None] * len(times)
    for j, (t0, t1, dense, mode) in enumerate(segments):
        last = j == len(segments) - 1
        sel = np.nonzero((times >= t0) & ((times < t1) | (last & (times <= t1 + 1e-12))))[0]
        if len(sel):
            out[:, sel] = dense(np.clip(times[sel], t0, t1)) if t1 > t0 else np.repeat(dense(t0)[:, None], len(sel), 1)
            for i in sel:
                modes[i] = mode
    return out, modes


def _crossing(t: np.ndarray, g: np.ndarray, direction: int, after: float = -1.0) -> float | None:
    """First time > ``after`` where ``g`` crosses 0 upwards (+1) or downwards (-1), s."""
    s = np.sign(g) * direction
    idx = np.nonzero((s[:-1] < 0) & (s[1:] >= 0) & (t[1:] > after))[0]
    if not len(idx):
        return None
    i = idx[0]
    return float(t[i] + (t[i + 1] - t[i]) * (0 - g[i]) / (g[i + 1] - g[i]))


def simulate_reference(car: Car, params: RefParams, v0: float, duration: float = 0.3, fps: float = 1000.0,
                       rtol: float = 1e-7, max_step: float = 5e-4) -> RefMotion:
    """Simulate a frontal rigid-barrier impact at ``v0`` (m/s) for ``duration`` (s) after
    first contact, sampled at ``fps`` (Hz). See :class:`RefMotion` for the outputs.

    Raises
    ------
    SynthError
        Non-physical input (see :func:`synth.physics_params.derive`), a failed integration.
    """
    if not (v0 > 0 and duration > 0 and fps > 0):
        raise SynthError(f"v0, duration and fps must be positive, got {v0}, {duration}, {fps}")
    mod = derive(car, params)
    segments, switches = _integrate(mod, float(v0), float(duration), rtol, max_step)
    n = int(math.floor(duration * fps + 1e-9)) + 1
    t = np.arange(n) / fps
    ys, modes = _eval(segments, t)
    diags = []
    for i in range(n):
        dg = {}
        rhs(t[i], ys[:, i], mod, modes[i], dg)
        diags.append(dg)

    def col(key):
        return np.array([dg[key] for dg in diags])

    c, sn = np.cos(ys[I_TH]), np.sin(ys[I_TH])
    fx, fz = _off(*mod.file_cg, c, sn)
    x = ys[I_X] + fx - mod.file_cg[0]
    z = ys[I_Z] + fz - (mod.cab_cg[1] + mod.file_cg[1])
    d, _, de, _ = crush_and_engine(mod, ys)
    axle_z = [ys[I_Z] + _off(*mod.axle[i], c, sn)[1] for i in range(2)]

    # events on a fine grid (linear interpolation between its points)
    tf = np.arange(0.0, duration + 0.5 * FINE_DT, FINE_DT)
    yf, mf = _eval(segments, tf)
    df, ddf, def_, _ = crush_and_engine(mod, yf)
    fb = np.array([structure_force(mod, mf[i], df[i], ddf[i]) + engine_force(mod, mf[i], def_[i])
                   for i in range(len(tf))])
    events = dict.fromkeys(("compression_end", "separation", "front_wheel_block", "front_wheel_unblock",
                            "rear_wheel_lift", "rear_wheel_touchdown", "engine_contact", "mount_break"))
    ms = lambda v: None if v is None else 1e3 * v  # noqa: E731
    ends = [te for te, name in switches if name == "compression_end"]
    events["compression_end"] = ms(ends[-1]) if ends else None
    for key, name in (("front_wheel_block", "jam"), ("mount_break", "mount_break")):
        hit = [te for te, nm in switches if nm == name]
        events[key] = ms(hit[0]) if hit else None
    if events["front_wheel_block"] is not None:
        rel = [te for te, nm in switches if nm == "unjam" and te * 1e3 > events["front_wheel_block"]]
        events["front_wheel_unblock"] = ms(rel[0]) if rel else None
    lift = _crossing(tf, mod.r0[1] - yf[I_ZR], -1)
    events["rear_wheel_lift"] = ms(lift)
    if lift is not None:
        events["rear_wheel_touchdown"] = ms(_crossing(tf, mod.r0[1] - yf[I_ZR], 1, after=lift))
    if mod.m_e > 0:
        events["engine_contact"] = ms(_crossing(tf, def_, 1))
    pos = np.nonzero(fb > 0)[0]
    if len(pos) and pos[-1] < len(tf) - 1:
        events["separation"] = ms(float(tf[pos[-1] + 1]))

    f_s, f_e = col("force_structure"), col("force_engine")
    return RefMotion(
        t=t, x=x, z=z, pitch=ys[I_TH].copy(), crush=np.maximum(d, 0.0),
        front_wheel_angle=ys[I_PF].copy(), rear_wheel_angle=ys[I_PR].copy(),
        front_wheel_dz=ys[I_ZF] - axle_z[0], rear_wheel_dz=ys[I_ZR] - axle_z[1],
        front_wheel_height=ys[I_ZF] - mod.radius, rear_wheel_height=ys[I_ZR] - mod.radius,
        cabin_accel_x=col("cabin_accel_x"), engine_accel_x=col("engine_accel_x"), engine_dx=ys[3].copy(),
        force_structure=f_s, force_engine=f_e, force_barrier=f_s + f_e, events_ms=events, v0=float(v0),
        max_crush=float(max(np.max(df), 0.0)),
        normal_front=col("normal_front"), normal_rear=col("normal_rear"), ground_x_front=col("ground_x_front"),
        ground_x_rear=col("ground_x_rear"), momentum_x=col("momentum_x"), impulse_barrier=ys[I_JB].copy(),
        impulse_ground=ys[I_JG].copy(), kinetic=col("kinetic"), gravity_pe=col("gravity_pe"),
        work_nonconservative=ys[I_WALL].copy(), work_structure=ys[I_WSTR].copy(), mass_total=float(car.mass),
        extra={"engine_penetration": de, "switches": [(1e3 * te, nm) for te, nm in switches],
               "engine_gap": mod.engine_gap, "cabin_mass": mod.m_c, "cabin_inertia": mod.i_c})


def rear_lifts(car: Car, params: RefParams, v0: float, duration: float = 0.3) -> bool:
    """Whether the rear tyres unload fully (wheels leave the ground) within ``duration`` (s)
    at ``v0`` (m/s); checked on a 0.5 ms grid."""
    mod = derive(car, params)
    segments, _ = _integrate(mod, float(v0), float(duration), 1e-6, 1e-3)
    ys, _ = _eval(segments, np.arange(0.0, duration, 5e-4))
    return bool(np.any(ys[I_ZR] > mod.r0[1]))


def random_params(rng: np.random.Generator, car: Car, effect: str, v0: float | None = None,
                  speed_range_kmh: tuple = (40.0, 64.0)) -> RefParams:
    """A plausible hidden car for ``effect``; the effect is visible (and every other one
    absent) for any impact speed in ``speed_range_kmh`` (or at ``v0`` m/s if given).

    Every world (uniform draws): k_compression 0.6-1.4 MN/m^3; k_restitution 0.4-1.0 x k_c;
    restitution 0.08-0.30; dz_contact -0.30..0.05 m; unloading exponent 1.5-3; mu_face
    0.1-0.4; engine 10-20 % of the test mass at height 0.40-0.60 m, CG 0.25-0.35 m behind its
    front face, mounts 0.5-1.2 MN/m (damping ratio 0.1-0.3) letting go at 15-40 g of engine
    load; engine contact 2-5 MN/m, restitution 0.1-0.4; wheel 35-50 kg, tyre 200-300 kN/m and
    1.0-1.3 kg m^2 spin inertia per wheel; rolling resistance 0.010-0.020; mu_peak 0.85-0.95,
    mu_slide 0.05-0.15 lower. Engine gap out of reach (>= 1.3 x the point-mass crush at the
    top speed + forward stop travel + 5 cm), no zone, no rate, no jam; if the rear lifts at
    the top speed, dz_contact is raised in 0.03 m steps until it does not (then 0.05 m at
    most; checked by simulation).

    Effects (each turns on its one thing):
    - ``stiffness_zone``: zone at 0.25-0.5 m (at most 0.7 x the crush estimate at the lowest
      speed), k_zone 1.8-3 x k_c (stiffening, 3 in 4) or 0.4-0.6 x k_c (softening).
    - ``front_wheel_block``: jam at front_overhang - wheel_radius +- 0.05 m (at most 0.85 x
      the crush estimate at the lowest speed), release margin 0.02-0.08 m.
    - ``rate_dependence``: rate_coefficient 0.05-0.15 s/m.
    - ``engine_impact``: engine gap 0.3-0.5 m (at most 0.75 x the crush estimate at the
      lowest speed).
    - ``rear_axle_lift``: dz_contact -0.35..-0.25 m, lowered in 0.03 m steps (to -0.5 m at
      most) until the rear lifts at the lowest speed (checked by simulation).
    """
    if effect not in EFFECTS:
        raise SynthError(f"unknown effect {effect!r}; choose one of {', '.join(EFFECTS)}")
    v_lo, v_hi = (v0, v0) if v0 is not None else (speed_range_kmh[0] / 3.6, speed_range_kmh[1] / 3.6)
    u = rng.uniform
    k_c = u(0.6e6, 1.4e6)
    m = car.mass
    m_e = u(0.10, 0.20) * m
    k_m = u(0.5e6, 1.2e6)
    mu_peak = u(0.85, 0.95)
    p = RefParams(
        k_compression=k_c, k_restitution=k_c * u(0.4, 1.0), restitution=u(0.08, 0.30), dz_contact=u(-0.30, 0.05),
        unloading_exponent=u(1.5, 3.0), mu_face=u(0.1, 0.4), engine_mass=m_e, engine_z=u(0.40, 0.60),
        engine_half_length=u(0.25, 0.35), mount_stiffness=k_m, mount_damping=2 * u(0.1, 0.3) * math.sqrt(k_m * m_e),
        mount_break_force=u(15.0, 40.0) * m_e * 9.81, engine_stiffness=u(2e6, 5e6), engine_restitution=u(0.1, 0.4),
        wheel_mass=u(35.0, 50.0), tyre_stiffness=u(200e3, 300e3), wheel_spin_inertia=u(1.0, 1.3),
        rolling_resistance=u(0.010, 0.020), mu_peak=mu_peak, mu_slide=mu_peak - u(0.05, 0.15),
        release_margin=u(0.02, 0.08))
    gap = default_engine_gap(car, k_c, p.engine_stop_forward, v_hi)
    d_lo = crush_estimate(car, k_c, v_lo)
    if effect == "stiffness_zone":
        kz = u(1.8, 3.0) if rng.uniform() < 0.75 else u(0.4, 0.6)
        p = dataclasses.replace(p, zone_depth=min(u(0.25, 0.5), 0.7 * d_lo), k_zone=kz * k_c)
    elif effect == "front_wheel_block":
        jam = car.front_overhang - car.wheel_radius + u(-0.05, 0.05)
        p = dataclasses.replace(p, jam_depth=min(jam, 0.85 * d_lo))
    elif effect == "rate_dependence":
        p = dataclasses.replace(p, rate_coefficient=u(0.05, 0.15))
    elif effect == "engine_impact":
        gap = min(u(0.3, 0.5), 0.75 * d_lo)
    p = dataclasses.replace(p, engine_gap=gap, engine_x=car.front_x - gap - p.engine_half_length)
    if effect == "rear_axle_lift":
        p = dataclasses.replace(p, dz_contact=u(-0.35, -0.25))
        while not rear_lifts(car, p, v_lo) and p.dz_contact > -0.5:
            p = dataclasses.replace(p, dz_contact=p.dz_contact - 0.03)
    else:
        while rear_lifts(car, p, v_hi) and p.dz_contact < 0.05:
            p = dataclasses.replace(p, dz_contact=min(p.dz_contact + 0.03, 0.05))
    return p
