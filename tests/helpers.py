"""Helpers for the tests: a central finite-difference Jacobian to check autodiff against."""

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
    """A Measurement of a simulated crash: the model seen on a 1000 fps clock whose t = 0 is
    ``contact_time`` (s) before the model's contact, with Gaussian noise of ``noise`` (channel
    -> sigma in its unit) and a measured impact speed off by one sigma."""
    import jax.numpy as jnp

    from identify.measurement import Measurement
    from identify.model import predict
    from sim import simulate

    t = np.arange(t_ms[0], t_ms[1] + 1) * 1e-3
    traj = simulate(params, vehicle, speed, duration=t_ms[1] / 1e3 + 0.02)
    rng = np.random.default_rng(seed)
    channels, sigma = {}, {}
    for name, s in noise.items():
        clean = np.asarray(predict(traj, name, jnp.asarray(t), speed, contact_time, vehicle.wheel_radius, 1e-3))
        channels[name] = clean + rng.normal(0.0, s, len(t))
        sigma[name] = np.full(len(t), s)
    return Measurement(t=t, channels=channels, sigma=sigma, impact_speed_mps=speed + speed_sigma,
                       impact_speed_sigma=speed_sigma, source="synthetic")  # fmt: skip
