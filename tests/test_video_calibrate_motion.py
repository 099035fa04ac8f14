"""The camera's map from the car's approach (video.calibrate_motion)."""

import numpy as np
from dataclasses import replace

from video.calibrate import distort_points, no_distortion, undistort_points
from video.calibrate_motion import map_from_approach


def _approach(lens, n=30, noise=0.03, seed=0):
    """Six targets on a car crossing a 1024x768 picture at 12 px a frame, seen through ``lens``."""
    rng = np.random.default_rng(seed)
    start = np.array([[250.0, 250], [400, 260], [550, 300], [300, 420], [480, 430], [620, 440]])
    ideal = start[None] + np.arange(n)[:, None, None] * np.array([12.0, 0.3])
    seen = distort_points(ideal.reshape(-1, 2), lens).reshape(ideal.shape)
    return seen + rng.normal(0, noise, seen.shape), np.full((n, 6), noise)


def test_barrel_lens_yaw_and_pitch_recovered():
    base = no_distortion((1024, 768), "")
    true = replace(base, k1=-0.05, tilt=np.array([4e-5, -2e-5]), corrected=True)
    uv, sig = _approach(true)
    fit = map_from_approach(uv, sig, np.ones(len(uv), bool), range(6), base)
    assert fit.used
    assert abs(fit.k1 - true.k1) < 3 * fit.k1_sigma + 1e-3
    assert np.all(np.abs(fit.tilt - true.tilt) < 3 * fit.tilt_sigma + 1e-6)
    # a metre of travel the same number of corrected px at both ends of the picture
    a = undistort_points(np.array([[100.0, 380], [160, 380]]), fit.lens)
    b = undistort_points(np.array([[860.0, 380], [920, 380]]), fit.lens)
    ta = undistort_points(np.array([[100.0, 380], [160, 380]]), true)
    tb = undistort_points(np.array([[860.0, 380], [920, 380]]), true)
    ratio = np.hypot(*(b[1] - b[0])) / np.hypot(*(a[1] - a[0]))
    true_ratio = np.hypot(*(tb[1] - tb[0])) / np.hypot(*(ta[1] - ta[0]))
    assert abs(ratio / true_ratio - 1) < 2e-3


def test_square_camera_gets_a_map_near_identity():
    base = no_distortion((1024, 768), "")
    uv, sig = _approach(base, seed=1)
    fit = map_from_approach(uv, sig, np.ones(len(uv), bool), range(6), base)
    assert fit.used
    assert abs(fit.k1) < 3 * fit.k1_sigma + 1e-3
    assert np.all(np.abs(fit.tilt) < 3 * fit.tilt_sigma + 1e-6)


def test_too_short_an_approach_keeps_the_given_map():
    base = no_distortion((1024, 768), "")
    uv, sig = _approach(base, n=5)
    fit = map_from_approach(uv, sig, np.ones(len(uv), bool), range(6), base)
    assert not fit.used and fit.lens is base
    assert "not fitted" in fit.note
