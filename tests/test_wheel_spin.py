"""Wheels that spin on ahead of the car's travel are fitted only until they do
(identify/fitting/wheel_spin.py), on hand-made series."""

import numpy as np
import pytest

from identify.recordings.measurement import Measurement
from identify.fitting.wheel_spin import SPIN_ON_RAD, spin_on_time, without_spinning_wheels

R = 0.3  # m, wheel radius
T = np.arange(-0.03, 0.2, 0.001)


def _x():
    """A car at 15 m/s that stops at 30 g from t = 0 (m)."""
    v0, a = 15.0, 300.0
    t_stop = v0 / a
    tc = np.clip(T, 0.0, t_stop)
    return np.where(T < 0, v0 * T, v0 * tc - 0.5 * a * tc**2)


def _measurement(front, rear, x=None, derived=()):
    x = _x() if x is None else x
    rng = np.random.default_rng(3)
    noisy = {k: v + rng.normal(0.0, s, len(T)) for k, v, s in
             (("x_m", x, 3e-4), ("front_wheel_angle_rad", front, 5e-3), ("rear_wheel_angle_rad", rear, 5e-3))}
    sig = {"x_m": np.full(len(T), 3e-4), "front_wheel_angle_rad": np.full(len(T), 5e-3),
           "rear_wheel_angle_rad": np.full(len(T), 5e-3)}
    return Measurement(t=T, channels=noisy, sigma=sig, derived=derived)


def test_rolling_and_blocked_wheels_are_kept_whole():
    """A wheel rolling with the car (offset 1.3 rad) and one that stops at 20 ms while the car
    moves on (falling behind: what the blocking candidate looks for) are fitted throughout."""
    x = _x()
    blocked = np.where(T < 0.02, x, x[np.searchsorted(T, 0.02)]) / R
    m = _measurement(x / R + 1.3, blocked)
    assert spin_on_time(T, m.channels["front_wheel_angle_rad"], m.sigma["front_wheel_angle_rad"], m.channels["x_m"],
                        m.sigma["x_m"], R) is None
    assert without_spinning_wheels(m, R) is m


def test_a_wheel_turning_on_after_the_car_stops_is_cut_where_it_began_to_lead():
    """The rear wheel keeps its approach spin rate decaying over 60 ms after 10 ms while the
    car stops by 50 ms: it leads rolling by well over 0.1 rad from about 20 ms; the cut starts
    where the lead began (after 10 ms, before the threshold), and only that wheel is cut."""
    x = _x()
    i10 = np.searchsorted(T, 0.010)
    omega = 15.0 / R
    tt = np.clip(T - 0.010, 0.0, None)
    spinning = np.where(T < 0.010, x / R, x[i10] / R + omega * (tt - tt**2 / (2 * 0.06)) * (tt < 0.06)
                        + omega * 0.03 * (tt >= 0.06))
    m = _measurement(x / R, spinning)
    onset = spin_on_time(T, m.channels["rear_wheel_angle_rad"], m.sigma["rear_wheel_angle_rad"], m.channels["x_m"],
                         m.sigma["x_m"], R)
    lead = spinning - x / R
    crossed = T[np.flatnonzero(lead > SPIN_ON_RAD)[0]]
    assert 0.010 <= onset < crossed
    out = without_spinning_wheels(m, R)
    rear = out.sigma["rear_wheel_angle_rad"]
    assert np.all(np.isnan(rear[T > onset])) and np.all(np.isfinite(rear[T <= onset]))
    assert np.array_equal(out.sigma["front_wheel_angle_rad"], m.sigma["front_wheel_angle_rad"])
    assert any("rear wheel turns on ahead" in n for n in out.notes)
    assert out.channels is m.channels  # the samples stay; only their weight goes
    assert out.fitted_until_ms == {"rear_wheel_angle_rad": pytest.approx(1e3 * onset)}  # result.json says where


def test_a_recording_whose_position_is_derived_is_left_alone():
    x = _x()
    m = _measurement(x / R, x / R + np.where(T > 0.02, 1.0, 0.0), derived=("x_m",))
    assert without_spinning_wheels(m, R) is m


@pytest.mark.parametrize("lead", [0.05, 0.5])
def test_the_threshold_is_a_tenth_of_a_radian(lead):
    """A wheel leading by 0.05 rad is within what an axle's pitch can add; by 0.5 rad it spins on."""
    x = _x()
    m = _measurement(x / R, x / R + np.where(T > 0.05, lead, 0.0))
    found = spin_on_time(T, m.channels["rear_wheel_angle_rad"], m.sigma["rear_wheel_angle_rad"], m.channels["x_m"],
                         m.sigma["x_m"], R)
    assert (found is not None) is (lead > SPIN_ON_RAD)


def test_a_wheel_that_slips_ahead_and_is_then_blocked_did_not_spin_on():
    """As on development world 960003: the front wheel slips ahead of rolling by 0.15 rad
    over 10-30 ms, is blocked from 30 ms (the car moves on: it falls behind) and, released at
    120 ms, turns on 0.4 rad ahead once the car rebounds. The slip is no spin-on (the angle
    fell back behind rolling, which only a wheel turning slower than the car does): the wheel
    is fitted through the blocking and cut only where the lead that stays began, after 120 ms."""
    x = _x()
    ramp = 0.15 * np.clip((T - 0.010) / 0.020, 0.0, 1.0)
    i30 = np.searchsorted(T, 0.030)
    angle = np.where(T < 0.030, x / R + ramp, x[i30] / R + 0.15)
    angle = angle + np.where(T > 0.120, 0.4 + (x - x[i30]) / R, 0.0) * np.clip((T - 0.120) / 0.02, 0.0, 1.0)
    m = _measurement(x / R, angle)
    blocked_only = np.where(T < 0.120, angle, angle[np.searchsorted(T, 0.120)])
    assert spin_on_time(T, blocked_only, m.sigma["rear_wheel_angle_rad"], m.channels["x_m"], m.sigma["x_m"], R) is None
    onset = spin_on_time(T, m.channels["rear_wheel_angle_rad"], m.sigma["rear_wheel_angle_rad"], m.channels["x_m"],
                         m.sigma["x_m"], R)
    assert onset is not None and 0.100 <= onset <= 0.125
