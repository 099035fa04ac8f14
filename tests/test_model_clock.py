"""The model seen on the measurement's clock (``identify.fitting.model.predict``), against functions
whose values between samples are known exactly: a velocity read between the model's 1 ms
samples must be accurate to its curvature's third order and smooth in the time shift, or a
fitted contact time is drawn to a whole millisecond (on NHTSA 10146 it ended at 1.0000 ms
with linear interpolation, at 0.93 ms with this one)."""

from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

from identify.fitting.model import predict

H = 1e-3  # s, the model's output interval
S = np.arange(0, 201) * H  # model times of the samples


def trajectory(v):
    """A trajectory whose velocity is v(s) (m/s) and position its integral from 0."""
    fine = np.linspace(0, S[-1], 200_001)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (v(fine[1:]) + v(fine[:-1])) * np.diff(fine))])
    return SimpleNamespace(vx=jnp.asarray(v(S)), x=jnp.asarray(np.interp(S, fine, x)))


def velocity(t, traj, contact_time, speed=15.0):
    return np.asarray(predict(traj, "vx_mps", jnp.asarray(t), speed, contact_time, 0.3, H))


def test_a_velocity_between_samples_is_accurate_to_third_order():
    # 15 m/s falling as a 60 Hz cosine pulse: 5.6 km/s^2, the scale of a crash pulse
    v = lambda s: 15.0 - 5.0 * (1 - np.cos(2 * np.pi * 30 * s))  # noqa: E731
    traj = trajectory(v)
    t = np.linspace(0.0105, 0.1895, 400)  # between and on samples, away from the ends
    err = np.abs(velocity(t, traj, 0.0) - v(t)).max()
    # linear interpolation misses by h^2/8 |v''| = 22 mm/s here (measured 22); this 0.54 mm/s
    assert err < 1e-3


def test_the_velocity_is_smooth_in_the_time_shift():
    """The fitted contact time moves the model along the clock: the misfit must change
    smoothly with it, with no kink at the model's samples (a kink is a minimum a fit can stop
    in). Across a model sample the one-sided slopes of the predicted velocity, taken over a
    step d, differ by O(d) when it is smooth and by a fixed jump when it has a kink."""
    v = lambda s: 15.0 - 5.0 * (1 - np.cos(2 * np.pi * 30 * s))  # noqa: E731
    traj = trajectory(v)
    t = np.array([0.0417])  # a shift of 0.7 ms puts the model's sample at 41 ms here

    def slope_jump(d):
        at = velocity(t, traj, 0.0007)[0]
        return (velocity(t, traj, 0.0007 + d)[0] - at) / d - (at - velocity(t, traj, 0.0007 - d)[0]) / d

    # smooth: 10x smaller step, 10x smaller jump (measured 0.023 and 0.0023 m/s^2); linear
    # interpolation jumps by 22 m/s^2 whatever the step (measured)
    assert abs(slope_jump(1e-7)) < 0.2 * abs(slope_jump(1e-6)) + 1e-3
    assert abs(slope_jump(1e-6)) < 5.0
