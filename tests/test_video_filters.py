"""SAE J211 CFC filters checked against J211's definition."""

from __future__ import annotations

import numpy as np
import pytest

from video.errors import VideoError
from video.filters import cfc_filter, frequency_response, j211_coefficients, velocity


@pytest.mark.parametrize("cfc,fs", [(60, 1e5), (180, 1e5), (600, 1e6), (1000, 1e6)])
def test_gain_is_minus_3_db_at_five_thirds_of_the_class(cfc, fs):
    gain = frequency_response(cfc, fs, np.array([0.0, cfc, 5.0 * cfc / 3.0]))
    assert gain[0] == pytest.approx(1.0, abs=1e-9)
    # J211 pass band: within +0.5 / -1 dB up to the class frequency
    assert -1.0 < 20 * np.log10(gain[1]) <= 0.5
    assert 20 * np.log10(gain[2]) == pytest.approx(-3.0, abs=0.05)


def test_bilinear_warping_at_1000_fps_matches_the_prewarped_corner():
    # -3 dB where tan(pi f / fs) = 0.8022 tan(pi 2.0775 CFC / fs) (4-pole Butterworth)
    fs = 1000.0
    for cfc in (60, 180):
        f3 = np.arctan((np.sqrt(2.0) - 1.0) ** 0.25 * np.tan(np.pi * 2.0775 * cfc / fs)) \
            * fs / np.pi
        assert 20 * np.log10(frequency_response(cfc, fs, np.array([f3]))[0]) == \
            pytest.approx(-3.0103, abs=1e-6)
    assert 20 * np.log10(frequency_response(60, fs, np.array([100.0]))[0]) == \
        pytest.approx(-3.0, abs=0.25)


def test_filtered_sine_at_the_corner_keeps_its_phase_and_loses_3_db():
    fs, cfc = 20000.0, 60
    f = 100.0  # 5/3 * 60
    t = np.arange(8000) / fs
    x = np.sin(2 * np.pi * f * t)
    y = cfc_filter(x, fs, cfc).values
    mid = slice(2000, 6000)
    # least-squares amplitude of the sine and cosine components in the middle
    basis = np.stack([np.sin(2 * np.pi * f * t[mid]), np.cos(2 * np.pi * f * t[mid])], 1)
    (s, c), *_ = np.linalg.lstsq(basis, y[mid], rcond=None)
    assert np.hypot(s, c) == pytest.approx(10 ** (-3 / 20), abs=0.01)
    assert abs(np.arctan2(c, s)) < 1e-3  # zero phase


def test_symmetric_pulse_stays_symmetric_and_in_place():
    x = np.maximum(0.0, 1.0 - np.abs(np.arange(401) - 200) / 15.0)  # triangle at 200
    y = cfc_filter(x, 1000.0, 180).values
    assert int(np.argmax(y)) == 200
    np.testing.assert_allclose(y[150:201], y[200:251][::-1], atol=1e-9)


def test_one_pass_is_the_j211_recursion():
    b, a = j211_coefficients(180, 1000.0)
    x = np.random.default_rng(0).normal(size=50)
    y = np.zeros_like(x)
    for t in range(len(x)):
        xm1 = x[t - 1] if t >= 1 else 0.0
        xm2 = x[t - 2] if t >= 2 else 0.0
        ym1 = y[t - 1] if t >= 1 else 0.0
        ym2 = y[t - 2] if t >= 2 else 0.0
        y[t] = b[0] * x[t] + b[1] * xm1 + b[2] * xm2 - a[1] * ym1 - a[2] * ym2
    from scipy.signal import lfilter

    np.testing.assert_allclose(lfilter(b, a, x), y, atol=1e-12)


def test_velocity_of_uniform_motion_is_exact_to_the_ends():
    fs = 1000.0
    t = np.arange(300) / fs
    v = velocity(2.0 + 15.6 * t, fs, 60)
    np.testing.assert_allclose(v.values, 15.6, atol=1e-9)
    assert v.cfc == 60 and v.quantity == "velocity"


def test_velocity_of_constant_deceleration():
    fs = 1000.0
    t = np.arange(400) / fs
    x = 15.0 * t - 0.5 * 200.0 * t**2
    v = velocity(x, fs, 180)
    np.testing.assert_allclose(v.values[20:-20], 15.0 - 200.0 * t[20:-20], atol=1e-3)


def test_sigma_matches_the_scatter_of_filtered_noise():
    fs = 1000.0
    rng = np.random.default_rng(5)
    noise = rng.normal(0.0, 0.002, (200, 600))
    out = np.array([velocity(n, fs, 60, sigma_m=np.full(600, 0.002)).values for n in noise])
    pred = velocity(noise[0], fs, 60, sigma_m=np.full(600, 0.002)).sigma
    emp = out[:, 200:400].std()
    assert pred[300] == pytest.approx(emp, rel=0.1)


def test_nan_gap_splits_the_channel_and_stays_nan():
    x = np.linspace(0.0, 1.0, 200)
    x[90:100] = np.nan
    y = cfc_filter(x, 1000.0, 60)
    assert np.all(np.isnan(y.values[90:100]))
    assert np.all(np.isfinite(y.values[:90])) and np.all(np.isfinite(y.values[100:]))
    np.testing.assert_allclose(y.values[:90], x[:90], atol=1e-9)  # a line passes unchanged


def test_impossible_class_for_the_sample_rate_raises():
    with pytest.raises(VideoError, match="CFC 600"):
        velocity(np.zeros(100), 1000.0, 600)
    with pytest.raises(VideoError, match="unknown filter class"):
        cfc_filter(np.zeros(100), 1000.0, 100)
