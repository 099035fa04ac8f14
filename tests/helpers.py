"""Helpers for the tests: a central finite-difference Jacobian to check autodiff against, a
synthetic Measurement, and NHTSA test 10146 computed from its raw files (the independent
reference of the EV5 reader, motion and force-check tests)."""

import dataclasses
import functools
from pathlib import Path

import numpy as np


def central_difference_jacobian(f, x0, rel_step=1e-6):
    """Jacobian of ``f: (p,) -> (n,)`` at ``x0`` by central differences, steps
    ``rel_step * max(|x0_i|, 1)``; returns (n, p)."""
    x0 = np.asarray(x0, dtype=float)
    cols = []
    for i in range(len(x0)):
        h = rel_step * max(abs(x0[i]), 1.0)
        up, down = x0.copy(), x0.copy()
        up[i] += h
        down[i] -= h
        cols.append((np.asarray(f(up)) - np.asarray(f(down))) / (2 * h))
    return np.stack(cols, axis=1)


NOISE = {"x_m": 0.002, "z_m": 0.002, "pitch_rad": 0.0035, "front_wheel_angle_rad": 0.02, "rear_wheel_angle_rad": 0.02}


def synthetic_measurement(vehicle, params, speed=56.3 / 3.6, contact_time=0.0004, seed=0, t_ms=(-20, 300),
                          noise=NOISE, speed_sigma=0.08):
    """A Measurement of a simulated crash: the base model (``params`` with the engine on its
    mounts the base model holds, unless ``params`` has an engine) seen on a 1000 fps clock
    whose t = 0 is ``contact_time`` (s) before the model's contact, with Gaussian noise of
    ``noise`` (channel -> sigma in its unit) and a measured impact speed off by one sigma."""
    import jax.numpy as jnp

    from identify.discover.candidates import with_base_mechanisms
    from identify.recordings.measurement import Measurement
    from identify.fitting.model import predict
    from sim import simulate

    t = np.arange(t_ms[0], t_ms[1] + 1) * 1e-3
    traj = simulate(with_base_mechanisms(params, vehicle), vehicle, speed, duration=t_ms[1] / 1e3 + 0.02)
    rng = np.random.default_rng(seed)
    channels, sigma = {}, {}
    for name, s in noise.items():
        clean = np.asarray(predict(traj, name, jnp.asarray(t), speed, contact_time, vehicle.wheel_radius, 1e-3))
        channels[name] = clean + rng.normal(0.0, s, len(t))
        sigma[name] = np.full(len(t), s)
    return Measurement(t=t, channels=channels, sigma=sigma, impact_speed_mps=speed + speed_sigma,
                       impact_speed_sigma=speed_sigma, source="synthetic")  # fmt: skip


def with_heave_the_model_cannot_follow(m, contact_s=0.0004, contact_sigma_s=0.0003):
    """``m`` with a heave and a pitch no collision model parameter can give (Gaussian bumps
    of 30 mm at 60 ms and 0.06 rad at 90 ms: a richer car's, 15 and 17 sigma of ``NOISE``
    at their peaks) added to z and pitch, and its first contact seen at ``contact_s`` +-
    ``contact_sigma_s`` (a film's contact seen in the picture)."""
    t, channels = m.t, dict(m.channels)
    channels["z_m"] = channels["z_m"] + 0.03 * np.exp(-0.5 * ((t - 0.06) / 0.025) ** 2)
    channels["pitch_rad"] = channels["pitch_rad"] + 0.06 * np.exp(-0.5 * ((t - 0.09) / 0.03) ** 2)
    return dataclasses.replace(m, channels=channels, contact_time_s=contact_s, contact_time_sigma=contact_sigma_s)


# ---------------------------------------------------------------------------------------------
# NHTSA test 10146 straight from its raw files, with numpy and scipy only: the independent
# reference of the tests of identify's EV5 reader, motion stage and force check (none of
# identify's readers, offsets, filters or integrators is used here).

NHTSA_10146_DIR = Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146"
G_STANDARD = 9.80665  # m/s^2: "G'S" of the export (J211's g)
PRE_IMPACT_END_S = -0.005  # s: zero offsets are the mean of the samples up to here (see raw_10146)
CONTACT_LEVEL = 0.02  # end of contact: the force stays below this fraction of its peak


def ev5_mass_and_speed(header):
    """(test mass kg, impact speed km/h) of vehicle 1: fields 11 and 42 of its VEHICLE row."""
    section = None
    for line in Path(header).read_text(encoding="latin-1").splitlines():
        if line.startswith("-----"):
            section = line.strip("- ")
        elif section == "VEHICLE" and line.split("|")[0] == "1":
            fields = line.split("|")
            return float(fields[10]), float(fields[41])
    raise ValueError(f"{header}: no VEHICLE row of vehicle 1")


def raw_ev5_channel(curve, folder=NHTSA_10146_DIR):
    """(time s, value in the header's unit) of channel file ``v10146.NNN``, as written."""
    data = np.loadtxt(Path(folder) / f"v10146.{curve:03d}")
    return data[:, 0], data[:, 1]


def cfc_scipy(x, fs, cfc):
    """SAE J211 CFC filter by scipy: J211 Appendix C's pass is the 2-pole Butterworth made
    by the bilinear transform with its corner 2.0775 CFC pre-warped, which is what
    ``scipy.signal.butter(2, 2.0775 CFC, fs=fs)`` designs; run forward and backward
    (``filtfilt``, scipy's own end padding)."""
    from scipy.signal import butter, filtfilt

    b, a = butter(2, 2.0775 * cfc, fs=fs)
    return filtfilt(b, a, np.asarray(x, dtype=float))


def integrate_from(t, a, t0, v0):
    """Velocity and displacement by the trapezoid rule from the sample nearest ``t0`` (where
    v = v0, x = 0); returns (time since that sample, v, x)."""
    from scipy.integrate import cumulative_trapezoid

    i0 = int(np.argmin(np.abs(t - t0)))
    tau = t[i0:] - t[i0]
    v = v0 + cumulative_trapezoid(a[i0:], tau, initial=0.0)
    return tau, v, cumulative_trapezoid(v, tau, initial=0.0)


def last_above(t, f, level=CONTACT_LEVEL):
    """Last time at which ``f`` is above ``level`` times its peak."""
    return float(t[np.flatnonzero(f > level * np.max(f))[-1]])


class Raw10146:
    """Test 10146 from the raw files (recording time: NHTSA's t = 0 is the contact switch).

    Offsets: each channel's mean over the pre-trigger samples up to -5 ms. The window is a
    choice (the program documents the same one); ending it at 0 instead moves the
    accelerometers' mean offset by 0.015 g, which over the 0.3 s record changes the rebound
    speed by 0.03 m/s, the change of velocity over the contact by 0.016 m/s (the momentum
    balance by 9.6e-4) and the crush by 0.4 mm: how well the recording itself knows them.
    """

    def __init__(self, folder=NHTSA_10146_DIR):
        self.mass_kg, speed_kmh = ev5_mass_and_speed(Path(folder) / "v10146.EV5")
        self.v0 = speed_kmh / 3.6
        self.t, f = raw_ev5_channel(900, folder)  # the sum of the 174 valid Fx cells (README)
        self.fs = 1.0 / float(np.median(np.diff(self.t)))
        pre = self.t <= PRE_IMPACT_END_S + 1e-9
        self.force = -(f - f[pre].mean())  # N, the export's compression is negative Fx
        self.force60 = cfc_scipy(self.force, self.fs, 60)
        self.accel = {}  # code -> m/s^2, forward positive, offset-free, unfiltered
        for curve in (93, 94, 99, 100):
            t, a = raw_ev5_channel(curve, folder)
            assert np.allclose(t, self.t)
            self.accel[str(curve)] = (a - a[pre].mean()) * G_STANDARD
        self.mean_accel = np.mean(list(self.accel.values()), axis=0)
        i = int(np.argmax(self.force60))
        self.peak_N, self.peak_s = float(self.force60[i]), float(self.t[i])
        self.contact_end_s = last_above(self.t, self.force60)
        self.tau, self.v, self.x = integrate_from(self.t, self.mean_accel, 0.0, self.v0)
        k = int(np.argmax(self.x))
        self.max_crush_m, self.max_crush_s = float(self.x[k]), float(self.tau[k])
        self.rebound_mps = float(-np.mean(self.v[self.tau >= self.contact_end_s]))

    def impulse(self, t0, t1):
        """Integral of the unfiltered force over [t0, t1] (recording time), N s."""
        w = (self.t >= t0 - 1e-9) & (self.t <= t1 + 1e-9)
        return float(np.trapezoid(self.force[w], self.t[w]))

    def delta_v(self, t1, accel=None):
        """Change of velocity from the contact switch (t = 0) to t1, m/s, positive."""
        tau, v, _ = integrate_from(self.t, self.mean_accel if accel is None else accel, 0.0, self.v0)
        return float(self.v0 - np.interp(t1, tau, v))

    def momentum_error(self, accel=None):
        """Impulse over the contact / (test mass x change of velocity) - 1."""
        t1 = self.contact_end_s
        return self.impulse(0.0, t1) / (self.mass_kg * self.delta_v(t1, accel)) - 1.0


@functools.cache
def raw_10146():
    """``Raw10146()``, read once per session."""
    return Raw10146()
