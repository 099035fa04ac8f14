"""Equations of motion of the reference world: a pitching cabin, an engine sliding along the
body's x axis on breakable mounts, two unsprung axles with spinning wheels, a hysteretic front
structure and an engine block against a rigid barrier. Written from first principles
(Lagrange with point-mass Jacobians); no ``sim``, ``identify`` or ``video`` import.

Generalized coordinates ``q = [X, Z, theta, s]`` (cabin CG in the ground frame, m; pitch,
nose-down positive, rad; engine travel along body x relative to the cabin, m), plus the wheel
centre heights ``z_f, z_r`` (m) and wheel spins ``omega_f, omega_r`` (rad/s, absolute,
forward rolling positive). A body offset ``(u, w)`` (forward, up) sits in the ground frame at
``(u cos th + w sin th, -u sin th + w cos th)`` from the cabin CG.

State vector (see the ``I_*`` indices): q, z_f, z_r, their rates, spins, relative wheel angles
(spin relative to the body), then bookkeeping integrals: energy absorbed on the structure's
loading curve (J), barrier and ground impulses (N s), work of every non-gravity force (J) and
of the structure's horizontal force (J).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from synth.physics_laws import (engine_contact_force, rate_factor, smooth_sign, structure_loading_force,
                                tyre_mu, unloading_branch, unloading_force)
from synth.physics_params import G, Model

I_X, I_Z, I_TH, I_S, I_ZF, I_ZR = range(6)
I_V = 6                      # rates of the six above start here
I_WF, I_WR, I_PF, I_PR = 12, 13, 14, 15
I_EABS, I_JB, I_JG, I_WALL, I_WSTR = 16, 17, 18, 19, 20
N_STATE = 21
V_SLIP = 0.5                 # m/s, floor of the slip's reference speed
V_SMOOTH = 0.05              # m/s, smooth-sign scale of sliding friction
EPS_RELOAD = 1e-5            # m, re-loading starts this far past the previous maximum (no chatter at a switch)


@dataclass
class Mode:
    """Discrete state between events: structure and engine branch, mounts, front-wheel jam."""

    loading: bool = True         # structure on its loading curve
    d_max: float = 0.0           # m, unloading branch (set at a compression end)
    d_p: float = 0.0
    delta: float = 0.0
    f_s: float = 0.0             # N
    eng_loading: bool = True
    d_emax: float = 0.0          # m
    intact: bool = True          # engine mounts hold
    jammed: bool = False         # front wheels jammed

    def copy(self) -> "Mode":
        return Mode(**self.__dict__)


def _off(u: float, w: float, c: float, s: float) -> tuple[float, float]:
    """Ground-frame offset of body offset (u, w) at pitch cos/sin (c, s)."""
    return u * c + w * s, -u * s + w * c


def initial_state(mod: Model, v0: float) -> np.ndarray:
    """Static equilibrium at rest heights, everything moving forward at ``v0`` (m/s), wheels
    rolling (omega = v0 / r)."""
    y = np.zeros(N_STATE)
    y[I_Z] = mod.cab_cg[1]
    y[I_ZF] = y[I_ZR] = mod.radius
    y[I_V + I_X] = v0
    y[I_WF] = y[I_WR] = v0 / mod.radius
    return y


def barrier_x(mod: Model) -> float:
    """Barrier face X (ground frame): the contact point at t = 0 (cabin CG at X = 0)."""
    return mod.contact[0]


def crush_and_engine(mod: Model, y: np.ndarray) -> tuple[float, float, float, float]:
    """(d, d_dot, d_e, d_e_dot): structure crush and engine penetration (m) and rates (m/s);
    vectorizes over the last axis of ``y``."""
    th, s = y[I_TH], y[I_S]
    c, sn = np.cos(th), np.sin(th)
    thd, sd = y[I_V + I_TH], y[I_V + I_S]
    xb = barrier_x(mod)
    ox, oz = _off(*mod.contact, c, sn)
    d = y[I_X] + ox - xb
    dd = y[I_V + I_X] + thd * oz
    oxf, ozf = _off(mod.engine_front[0] + s, mod.engine_front[1], c, sn)
    de = y[I_X] + oxf - xb
    ded = y[I_V + I_X] + thd * ozf + sd * c
    return d, dd, de, ded


def structure_force(mod: Model, mode: Mode, d: float, dd: float) -> float:
    """Structure force (N, >= 0) at crush d (m), crush rate dd (m/s) on the current branch."""
    p = mod.p
    if mode.loading:
        return structure_loading_force(d, p.k_compression, mod.area, p.zone_depth, p.k_zone) * \
            rate_factor(dd, p.rate_coefficient)
    return unloading_force(d, mode.d_p, mode.delta, mode.f_s, p.unloading_exponent)


def engine_force(mod: Model, mode: Mode, de: float) -> float:
    """Engine-on-barrier force, N (0 without an engine)."""
    if mod.m_e <= 0.0:
        return 0.0
    return engine_contact_force(de, mode.eng_loading, mode.d_emax, mod.p.engine_stiffness, mod.p.engine_restitution)


def rhs(t: float, y: np.ndarray, mod: Model, mode: Mode, diag: dict | None = None) -> np.ndarray:
    """dy/dt. With ``diag`` a dict, also fills it with forces (N), accelerations (m/s^2,
    rad/s^2) and the system's momentum (N s)."""
    p = mod.p
    th, s = y[I_TH], y[I_S]
    xd, zd, thd, sd = y[I_V], y[I_V + 1], y[I_V + 2], y[I_V + 3]
    c, sn = math.cos(th), math.sin(th)
    q = [0.0, 0.0, 0.0, 0.0]          # generalized forces on X, Z, theta, s
    q_w = [0.0, 0.0]                  # on z_f, z_r
    power = 0.0                       # of every non-gravity force, W
    xb = barrier_x(mod)
    has_engine = mod.m_e > 0.0

    # structure at the contact point
    ox, oz = _off(*mod.contact, c, sn)
    d = y[I_X] + ox - xb
    vx, vz = xd + thd * oz, zd - thd * ox
    f_s = structure_force(mod, mode, d, vx)
    fx, fz = -f_s, -p.mu_face * f_s * smooth_sign(vz, V_SMOOTH)
    q[0] += fx
    q[1] += fz
    q[2] += fx * oz - fz * ox
    power += fx * vx + fz * vz
    p_struct = fx * vx
    de_abs = f_s * vx if (mode.loading and d > 0.0) else 0.0

    # engine: contact at its front face, mounts/stops along s, gravity, convective terms
    f_e = 0.0
    oxe = oze = 0.0
    if has_engine:
        oxf, ozf = _off(mod.engine_front[0] + s, mod.engine_front[1], c, sn)
        de = y[I_X] + oxf - xb
        vxf, vzf = xd + thd * ozf + sd * c, zd - thd * oxf - sd * sn
        f_e = engine_force(mod, mode, de)
        fx, fz = -f_e, -p.mu_face * f_e * smooth_sign(vzf, V_SMOOTH)
        q[0] += fx
        q[1] += fz
        q[2] += fx * ozf - fz * oxf
        q[3] += fx * c - fz * sn
        power += fx * vxf + fz * vzf
        if mode.intact:
            f_m = -p.mount_stiffness * s - mod.mount_c * sd
        else:
            f_m = -mod.mount_friction * smooth_sign(sd, V_SMOOTH)
        if s > p.engine_stop_forward:
            f_m += min(0.0, -p.engine_stop_stiffness * (s - p.engine_stop_forward) - mod.stop_c * sd)
        elif s < -p.engine_stop_back:
            f_m += max(0.0, p.engine_stop_stiffness * (-p.engine_stop_back - s) - mod.stop_c * sd)
        q[3] += f_m
        power += f_m * sd
        oxe, oze = _off(mod.engine[0] + s, mod.engine[1], c, sn)
        ge = -mod.m_e * G
        q[1] += ge
        q[2] += -oxe * ge
        q[3] += -sn * ge
        cx = -thd * thd * oxe - 2 * thd * sd * sn
        cz = -thd * thd * oze - 2 * thd * sd * c
        q[0] -= mod.m_e * cx
        q[1] -= mod.m_e * cz
        q[2] -= mod.m_e * (oze * cx - oxe * cz)
        q[3] -= mod.m_e * (c * cx - sn * cz)
    q[1] -= mod.m_c * G

    # axles: suspension, tyre (unilateral), longitudinal tyre force, spin
    dy = np.zeros(N_STATE)
    f_x = [0.0, 0.0]
    n_t = [0.0, 0.0]
    susp = [0.0, 0.0]
    oza_i = [0.0, 0.0]
    for i in range(2):
        oxa, oza = _off(*mod.axle[i], c, sn)
        vxa, vza = xd + thd * oza, zd - thd * oxa
        zw, zwd = y[I_ZF + i], y[I_V + I_ZF + i]
        ext = y[I_Z] + oza - zw
        ext_d = vza - zwd
        f_sp = max(0.0, mod.f_s0[i] - mod.k_s[i] * ext) - mod.c_s[i] * ext_d
        if -ext > p.bump_travel:
            f_sp += p.susp_stop_stiffness * (-ext - p.bump_travel)
        elif ext > p.droop_travel:
            f_sp -= p.susp_stop_stiffness * (ext - p.droop_travel)
        q[1] += f_sp
        q[2] += -oxa * f_sp
        q_w[i] -= f_sp
        power += f_sp * ext_d
        comp = mod.r0[i] - zw
        f_t = max(0.0, mod.k_t[i] * comp - mod.c_t[i] * zwd) if comp > 0.0 else 0.0
        q_w[i] += f_t - mod.m_wa[i] * G
        power += f_t * zwd
        omega = y[I_WF + i]
        r = mod.radius
        if i == 0 and mode.jammed:
            lever = oza - r * c                       # contact patch as a body point
            v_patch = xd + thd * lever
            fxi = -p.mu_slide * f_t * smooth_sign(v_patch, V_SMOOTH)
            q[0] += fxi
            q[2] += fxi * lever
            power += fxi * v_patch
        else:
            slip = (omega * r - vxa) / max(abs(vxa), abs(omega * r), V_SLIP)
            fxi = tyre_mu(slip, p.mu_peak, p.mu_slide) * f_t
            torque = -fxi * r - p.rolling_resistance * f_t * r * smooth_sign(omega * r, 0.1)
            q[0] += fxi
            q[2] += fxi * oza
            power += fxi * vxa + torque * omega
            dy[I_WF + i] = torque / mod.i_wa[i]
            dy[I_PF + i] = omega - thd
        conv = -thd * thd * oxa
        q[0] -= mod.m_wa[i] * conv
        q[2] -= mod.m_wa[i] * oza * conv
        oza_i[i] = oza
        f_x[i], n_t[i], susp[i] = fxi, f_t, f_sp

    m_mat = mass_matrix(mod, c, sn, oxe, oze, oza_i)
    if has_engine:
        qdd = np.linalg.solve(m_mat, q)
    else:
        qdd = np.zeros(4)
        qdd[:3] = np.linalg.solve(m_mat[:3, :3], q[:3])
    dy[:6] = y[I_V:I_V + 6]
    dy[I_V:I_V + 4] = qdd
    dy[I_V + I_ZF] = q_w[0] / mod.m_wa[0]
    dy[I_V + I_ZR] = q_w[1] / mod.m_wa[1]
    dy[I_EABS] = de_abs
    dy[I_JB] = -(f_s + f_e)
    dy[I_JG] = f_x[0] + f_x[1]
    dy[I_WALL] = power
    dy[I_WSTR] = p_struct
    if diag is not None:
        xdd, thdd, sdd = qdd[0], qdd[2], qdd[3]
        oxp, ozp = _off(*mod.accel_point, c, sn)
        vxe = xd + thd * oze + sd * c
        diag.update(
            force_structure=f_s, force_engine=f_e, ground_x_front=f_x[0], ground_x_rear=f_x[1],
            normal_front=n_t[0], normal_rear=n_t[1], susp_front=susp[0], susp_rear=susp[1],
            cabin_accel_x=xdd + thdd * ozp - thd * thd * oxp,
            engine_accel_x=(xdd + thdd * oze + sdd * c - thd * thd * oxe - 2 * thd * sd * sn) if has_engine
            else xdd + thdd * ozp - thd * thd * oxp,
            momentum_x=mod.m_c * xd + mod.m_e * vxe + sum(
                mod.m_wa[i] * (xd + thd * _off(*mod.axle[i], c, sn)[1]) for i in range(2)),
            kinetic=kinetic_energy(mod, y, m_mat),
            gravity_pe=G * (mod.m_c * y[I_Z] + mod.m_e * (y[I_Z] + oze) + mod.m_wa[0] * y[I_ZF]
                            + mod.m_wa[1] * y[I_ZR]),
        )
    return dy


def mass_matrix(mod: Model, c: float, sn: float, oxe: float, oze: float, oza: list) -> np.ndarray:
    """4x4 mass matrix of (X, Z, theta, s): cabin, engine (point mass at offset (oxe, oze),
    sliding along body x) and the unsprung masses' x motion (carried at the axle points,
    vertical offsets ``oza``): ``sum m J^T J`` in closed form, kg / kg m / kg m^2."""
    me, (mf, mr) = mod.m_e, mod.m_wa
    mxt = me * oze + mf * oza[0] + mr * oza[1]
    mtt = mod.i_c + me * (oze * oze + oxe * oxe) + mf * oza[0] ** 2 + mr * oza[1] ** 2
    mts = me * (oze * c + oxe * sn)
    return np.array([[mod.m_c + me + mf + mr, 0.0, mxt, me * c],
                     [0.0, mod.m_c + me, -me * oxe, -me * sn],
                     [mxt, -me * oxe, mtt, mts],
                     [me * c, -me * sn, mts, me]])


def kinetic_energy(mod: Model, y: np.ndarray, m_mat: np.ndarray) -> float:
    """Kinetic energy (J) of cabin, engine, unsprung masses and wheel spin."""
    v = y[I_V:I_V + 4]
    t = 0.5 * float(v @ m_mat @ v)
    t += 0.5 * (mod.m_wa[0] * y[I_V + I_ZF] ** 2 + mod.m_wa[1] * y[I_V + I_ZR] ** 2)
    t += 0.5 * (mod.i_wa[0] * y[I_WF] ** 2 + mod.i_wa[1] * y[I_WR] ** 2)
    return t


def switch(mod: Model, mode: Mode, name: str, y: np.ndarray) -> tuple[Mode, np.ndarray]:
    """The mode and state just after event ``name`` (jumps: a jammed wheel's spin energy is
    booked as work lost, its spin restarts at the body's pitch rate on release)."""
    new, y = mode.copy(), y.copy()
    d, dd, de, ded = crush_and_engine(mod, y)
    p = mod.p
    if name == "compression_end":
        new.loading = False
        new.d_max = float(d)
        new.d_p, new.delta, new.f_s = unloading_branch(float(d), float(y[I_EABS]), p.restitution, p.k_restitution,
                                                        mod.area, p.unloading_exponent)
    elif name == "reload":
        new.loading = True
    elif name == "engine_unload":
        new.eng_loading, new.d_emax = False, float(de)
    elif name == "engine_reload":
        new.eng_loading = True
    elif name == "mount_break":
        new.intact = False
    elif name == "jam":
        new.jammed = True
        y[I_WALL] -= 0.5 * mod.i_wa[0] * y[I_WF] ** 2
        y[I_WF] = 0.0
    elif name == "unjam":
        new.jammed = False
        y[I_WF] = y[I_V + I_TH]
        y[I_WALL] += 0.5 * mod.i_wa[0] * y[I_WF] ** 2
    return new, y


def events_for(mod: Model, mode: Mode) -> list:
    """Terminal event functions (with ``.name``) that end the current mode."""
    p = mod.p
    evs = []

    def make(name, fun, direction):
        fun.terminal, fun.direction, fun.name = True, direction, name
        evs.append(fun)

    if mode.loading:
        make("compression_end", lambda t, y: crush_and_engine(mod, y)[1], -1)
    else:
        make("reload", lambda t, y: crush_and_engine(mod, y)[0] - mode.d_max - EPS_RELOAD, 1)
    if mod.m_e > 0:
        if mode.eng_loading:
            def eng_unload(t, y):
                _, _, de, ded = crush_and_engine(mod, y)
                return ded if de > 0 else 1.0
            make("engine_unload", eng_unload, -1)
        else:
            make("engine_reload", lambda t, y: crush_and_engine(mod, y)[2] - mode.d_emax - EPS_RELOAD, 1)
        if mode.intact:
            make("mount_break", lambda t, y: abs(p.mount_stiffness * y[I_S] + mod.mount_c * y[I_V + I_S])
                 - mod.mount_break, 1)
    if p.jam_depth is not None:
        if mode.jammed:
            make("unjam", lambda t, y: crush_and_engine(mod, y)[0] - (p.jam_depth - p.release_margin), -1)
        else:
            make("jam", lambda t, y: crush_and_engine(mod, y)[0] - p.jam_depth, 1)
    return evs
