"""The collision model written the way a user would without this project: NumPy right-hand
side, integrated by ``scipy.integrate.solve_ivp``. The baseline of the benchmarks.

Same equations as ``sim`` (docs/physics.md): planar rigid body, hysteretic barrier contact
with the unloading line set by the energy absorbed, one unilateral spring-damper per axle,
rolling resistance, each axle's wheels spinning on their bearings and held towards rolling by
the tyre's grip (a Coulomb friction regularized over ``slip_width``, where ``sim`` takes a
friction impulse per step: two ways of writing the same law). The hysteresis is carried as two extra states (maximum crush, energy
absorbed) that grow only while the crush is at its maximum and increasing.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

G = 9.81


def vehicle_numbers(vehicle) -> dict:
    """Plain floats of a ``sim.Vehicle`` (the baseline uses no JAX)."""
    names = ("mass", "pitch_inertia", "cg_height", "cg_to_front_axle", "wheelbase", "wheel_radius", "contact_area")
    out = {n: float(getattr(vehicle, n)) for n in names}
    out["axle_stiffness"] = np.asarray(vehicle.axle_stiffness, dtype=float)
    out["axle_damping"] = np.asarray(vehicle.axle_damping, dtype=float)
    out["wheel_spin_inertia"] = np.asarray(vehicle.wheel_spin_inertia, dtype=float)
    return out


def simulate_numpy(k_c, k_r, e, dz, speed, veh: dict, duration=0.3, mu_roll=0.015, rtol=1e-8, atol=1e-10,
                   mu_grip=0.9, slip_width=0.01):
    """Simulate with solve_ivp (RK45); return (t (n,), x (n,), z (n,), pitch (n,)) every 1 ms.
    ``mu_grip``: the tyres' grip on the wheels' spin (``Params.mu_adhesion``); ``slip_width``
    (m/s): the patch speed over which it rises to mu N."""
    m, inertia, h = veh["mass"], veh["pitch_inertia"], veh["cg_height"]
    a = veh["cg_to_front_axle"]
    b = veh["wheelbase"] - a
    px = np.array([a, -b])
    pz = veh["wheel_radius"] - h
    k, c = veh["axle_stiffness"], veh["axle_damping"]
    static = m * G * np.array([b, a]) / veh["wheelbase"]
    kc_area, kr_area = k_c * veh["contact_area"], k_r * veh["contact_area"]

    spin_inertia, r = veh["wheel_spin_inertia"], veh["wheel_radius"]

    def rhs(t, y):
        x, z, th, vx, vz, w, d_max, e_abs = y[:8]
        spin = np.asarray(y[8:10])
        s, co = np.sin(th), np.cos(th)
        crush = max(x + dz * s, 0.0)
        rate = vx + dz * co * w
        loading = crush >= d_max - 1e-12 and rate > 0.0
        if loading:
            force = kc_area * crush
        else:
            d_p = d_max - e * np.sqrt(max(2.0 * e_abs / kr_area, 0.0))
            force = kr_area * max(crush - d_p, 0.0) if crush > 0.0 else 0.0
        rise = z - px * s + pz * (co - 1.0)
        rise_rate = vz - (px * co + pz * s) * w
        normal = np.maximum(k * (static / k - rise) - c * rise_rate, 0.0)
        lever = -px * s - h * co
        traction = -mu_roll * normal * np.tanh((vx + lever * w) / 0.02)
        axle_lever = -px * s + pz * co  # the tyre's grip acts on the body at the axle
        grip = -mu_grip * normal * np.tanh((vx + axle_lever * w - spin * r) / slip_width)
        fx = traction.sum() + grip.sum() - force
        fz = normal.sum() - m * G
        mom = (np.sum(normal * (-px * co - pz * s)) + np.sum(traction * lever) + np.sum(grip * axle_lever)
               - force * dz * co)
        grow = rate if loading else 0.0
        return [vx, vz, w, fx / m, fz / m, mom / inertia, grow, force * grow, *(-grip * r / spin_inertia)]

    t_eval = np.arange(int(round(duration * 1000)) + 1) * 1e-3
    sol = solve_ivp(rhs, (0.0, duration), [0, 0, 0, speed, 0, 0, 0, 0, speed / r, speed / r], t_eval=t_eval,
                    rtol=rtol, atol=atol, max_step=5e-4)  # fmt: skip
    return sol.t, sol.y[0], sol.y[1], sol.y[2]
