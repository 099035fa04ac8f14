"""Plain frozen dataclasses shared by the stages of ``video/`` (see CONVENTIONS.md).

Lengths in m, times in s, angles in rad, image positions in px.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class CarGeometry:
    """What the video stage knows of the vehicle (built by ``identify`` from its file).

    Attributes
    ----------
    length, height, wheelbase, front_overhang, wheel_radius, cg_height, cg_to_front_axle :
        float, m.
    silhouette_side : (N, 2) float64
        Closed side outline in the vehicle frame (x forward from the rear bumper, z up
        from the ground), m.
    windscreen_top : (2,) float64
        Vehicle-frame point of the roof edge at the top of the windscreen, m.
    mass : float
        Test mass, kg (the wheels' static loads: how far a tyre can unload).
    """

    length: float
    height: float
    wheelbase: float
    front_overhang: float
    wheel_radius: float
    cg_height: float
    cg_to_front_axle: float
    silhouette_side: np.ndarray
    windscreen_top: np.ndarray
    mass: float

    def static_wheel_load(self, which: str) -> float:
        """N on one ``front`` or ``rear`` wheel of the car at rest on level ground."""
        rear_share = self.cg_to_front_axle / self.wheelbase
        return 0.5 * 9.81 * self.mass * (rear_share if which == "rear" else 1.0 - rear_share)

    @property
    def x_cg(self) -> float:
        """CG position along the vehicle frame's x, m: ``length - front_overhang -
        cg_to_front_axle``."""
        return self.length - self.front_overhang - self.cg_to_front_axle

    @property
    def front_axle_x(self) -> float:
        """Front axle position along the vehicle frame's x, m."""
        return self.length - self.front_overhang

    @property
    def rear_axle_x(self) -> float:
        """Rear axle position along the vehicle frame's x, m."""
        return self.length - self.front_overhang - self.wheelbase


@dataclass(frozen=True)
class Tracks:
    """The result of the video stage: measured motion per frame with its uncertainty.

    Attributes
    ----------
    t : (n,) float64
        Time of each frame, s, 0 at first contact.
    channels : dict[str, (n,) float64]
        Measured values by ``tracks.csv`` column name (``x_m``, ``z_m``, ``pitch_rad``,
        ``crush_m``, wheel angles and heights, ``target<k>_u_px`` ...). NaN where not
        measured.
    sigma : dict[str, (n,) float64]
        One-standard-deviation uncertainty per sample, same keys as ``channels``; for the
        lengths (x, z, vx, crush) the tracked point's noise alone: the scale's error
        (``scale_sigma``) is common to every sample, not noise of each.
    events_ms : dict[str, float | None]
        Event times, ms after contact (``front_wheel_block`` ...).
    events_sigma_ms : dict[str, float]
        One-sigma of the events the film brackets rather than sees (a wheel's lift and
        touchdown, ``video.motion.FloorEvent``), ms.
    contact_frame : int
        Index of the first frame in which the bumper touches the barrier face.
    fps : float
        Recording rate, frames per second.
    scale_m_per_px, scale_sigma : float
        Scale in the car plane and its one-sigma uncertainty, m/px.
    impact_speed_mps : float
        Speed at contact, m/s.
    direction : int
        +1 if the car moves left-to-right in the image, -1 right-to-left.
    notes : list[str]
        Things a person should read (duplicated frames, lost targets ...).
    contact_offset_s : float
        Estimated instant of first contact relative to ``t = 0`` (the contact frame), s,
        in about (-1/fps, 0]: the sub-frame contact time, for comparing with a model
        whose clock starts at the contact instant.
    contact_sigma_s : float or None
        One-sigma of the contact instant when the picture shows it (the front end seen
        stopping at the barrier face, :mod:`video.contact_seen`), s; None when it comes
        from the deceleration onset of the measured motion itself.
    overlay : dict
        What the tracking report draws on the reference frame, px: ``frame`` (index),
        ``tapes`` (list of (2, 2) end points), ``targets_uv`` (K, 2), ``target_kinds``
        (K,), ``silhouette_px`` (N, 2) or None, ``cg_uv`` (2,).
    geometry : dict
        The car's dimensions as the film shows them (at the tape's scale), m, each with
        its one-sigma uncertainty, for checking the vehicle file: ``hub_spacing_m`` and
        ``hub_spacing_sigma_m`` (the hub targets' distance before contact: the
        wheelbase), ``outline_length_m`` and ``outline_length_sigma_m`` (the fitted
        silhouette's length). A key is absent when not measured.
    scale_source : str
        What ``scale_m_per_px`` was taken from: ``"checker tape"``, or ``"hub targets and
        wheelbase"`` when no tape was in view (the vehicle file's wheelbase then set the
        scale, so ``hub_spacing_m`` is absent: it would check the file against itself).
    """

    t: np.ndarray
    channels: dict
    sigma: dict
    events_ms: dict
    contact_frame: int
    fps: float
    scale_m_per_px: float
    scale_sigma: float
    impact_speed_mps: float
    direction: int
    notes: list = field(default_factory=list)
    contact_offset_s: float = 0.0
    contact_sigma_s: float | None = None
    overlay: dict = field(default_factory=dict)
    geometry: dict = field(default_factory=dict)
    scale_source: str = "checker tape"
    events_sigma_ms: dict = field(default_factory=dict)

    @property
    def contact_time_s(self) -> float:
        """First contact on the film's clock, s after frame 0 (the contact frame's time
        plus ``contact_offset_s``)."""
        return self.contact_frame / self.fps + self.contact_offset_s
