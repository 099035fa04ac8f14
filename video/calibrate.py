"""Calibration of a crash film: scale in the car's plane from the reference tapes, radial
lens distortion from their straightness, and the vehicle outline fitted to a frame as a
cross-check of the scale (the paper's parallax warning).

Public surface (the modules behind it are ``calibrate_*.py``)::

    est = measure_scale(frame0, tape_segment_m=0.1)    # ScaleEstimate: m_per_px, sigma, tapes, lens
    pts = undistort_points(uv, est.lens)               # (N, 2) px, before applying est.m_per_px
    sil = fit_silhouette(frame0, car, scale_hint=est.m_per_px)
    cmp = compare_scales(est.m_per_px, est.sigma, sil) # cmp.agree, cmp.note
    est = scale_from_hubs(spacing_px, sigma_px, wheelbase_m, lens)  # no tape in view
    s = scale_from_spin(t, hub_u_px, hub_angle_rad, wheel_radius_m)  # a rolling wheel's, m/px

Units: m, px; images are uint8 (H, W) grayscale or (H, W, 3) BGR.
"""

from .calibrate_lens import (LensDistortion as LensDistortion,
                             distort_points as distort_points,
                             estimate_lens as estimate_lens,
                             no_distortion as no_distortion,
                             undistort_points as undistort_points)
from .calibrate_scale import (ScaleEstimate as ScaleEstimate, measure_scale as measure_scale,
                              scale_from_hubs as scale_from_hubs, scale_from_spin as scale_from_spin)
from .calibrate_silhouette import (ScaleComparison as ScaleComparison,
                                   SilhouetteFit as SilhouetteFit,
                                   compare_scales as compare_scales,
                                   fit_silhouette as fit_silhouette)
from .calibrate_tape import Tape as Tape, TapeSearch as TapeSearch, find_tapes as find_tapes

__all__ = ["LensDistortion", "ScaleComparison", "ScaleEstimate", "SilhouetteFit", "Tape",
           "TapeSearch", "compare_scales", "distort_points", "estimate_lens", "find_tapes",
           "fit_silhouette", "measure_scale", "no_distortion", "scale_from_hubs", "scale_from_spin",
           "undistort_points"]
