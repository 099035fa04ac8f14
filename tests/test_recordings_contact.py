"""First contact from a barrier's load cells, as a measurement with an uncertainty: pulses
with a known onset (a ramp, a square and a cube law of time, slopes 1-100 kN/ms, noise
0.2-2 kN, 10 kHz: the reference here is the onset the test put in, not the program) go
through the CFC 180 filter and ``find_onset``; ``onset_sigma`` must cover the error it makes
as a one-sigma should."""

import numpy as np
import pytest

from identify.recordings.motion import filter_cfc, find_onset, onset_sigma

FS = 10_000.0
T = np.arange(-0.05, 0.15, 1 / FS)


def pulse(shape, rate, t0):
    """N: a force that begins at t0 (s) and reaches rate x 5 ms after 5 ms (rate N/s),
    growing as (t - t0)^1, ^2 or ^3, capped at 600 kN."""
    p = {"ramp": 1, "square": 2, "cube": 3}[shape]
    return np.minimum(rate * 0.005 * (np.maximum(T - t0, 0.0) / 0.005) ** p, 6e5)


def onset_errors(shapes=("ramp", "square", "cube"), rates=(1e6, 1e7, 1e8), noises=(200.0, 2000.0), draws=6, seed=7):
    rng = np.random.default_rng(seed)
    out = []
    for shape in shapes:
        for rate in rates:
            for noise in noises:
                for _ in range(draws):
                    t0 = rng.uniform(-5e-4, 5e-4)
                    filtered = filter_cfc(pulse(shape, rate, t0) + rng.normal(0.0, noise, len(T)), FS, 180)
                    onset = find_onset(T, filtered)
                    out.append((onset - t0, onset_sigma(T, filtered, onset, 180), shape, rate, noise))
    return out


def test_the_onset_sigma_covers_the_onset_error_as_a_one_sigma_should():
    errors = onset_errors()
    z = np.array([abs(e) / s for e, s, *_ in errors])
    # measured over these 108 draws: 0.79 within one sigma, 0.98 within two (the misses: a
    # cube law at 1 kN/ms under 2 kN of noise, a start too soft to see)
    assert 0.55 <= np.mean(z < 1.0) <= 0.9
    assert np.mean(z < 2.0) >= 0.9


def test_the_onset_sigma_is_the_filters_time_constant_for_a_sharp_onset_and_grows_with_a_soft_one():
    sharp = onset_errors(shapes=("ramp",), rates=(1e8,), noises=(200.0,), draws=3)
    soft = onset_errors(shapes=("cube",), rates=(1e6,), noises=(2000.0,), draws=3)
    tau = 1.0 / (2 * np.pi * 300.0)  # CFC 180: -3 dB at 300 Hz
    for _, s, *_ in sharp:
        assert s == pytest.approx(tau, rel=0.1)
    assert min(s for _, s, *_ in soft) > 2 * tau  # measured 1.2 ms and more
