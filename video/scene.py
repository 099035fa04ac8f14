"""Scene description of a synthetic frontal barrier crash test seen from the side.

Frozen dataclasses only, plus the geometry the renderer and its truth share: where a
body point is in the car plane for a pose (CONVENTIONS.md formula), and where a point of
a plane at a given depth lands in the image (pinhole camera looking perpendicular to the
car's side, optional radial distortion k1, k2).

Coordinates: car plane X (towards the barrier), Z (up from the floor), m; image u, v px
with (0, 0) the centre of the top-left pixel; a film where the car moves right-to-left
has X growing to the image's left (``direction = -1``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from video.types import CarGeometry

# ----------------------------------------------------------------------------- parts


@dataclass(frozen=True)
class Target:
    """A quadrant target: a disc of ``diameter`` m split into four quadrants.

    ``kind`` is ``"body"`` (``x, z`` in the vehicle frame, moves with the body),
    ``"front_hub"`` / ``"rear_hub"`` (on a wheel centre, turns with the wheel; ``x, z``
    ignored) or ``"fixed"`` (``x, z`` are car-plane X, Z of a point on the barrier's side
    face, which lies at the barrier's depth).
    """

    name: str
    kind: str
    x: float = 0.0
    z: float = 0.0
    diameter: float = 0.1


@dataclass(frozen=True)
class Tape:
    """A checker tape on the body, along the vehicle frame's x at height ``z`` (its lower
    edge), from ``x0`` to ``x1`` (m), ``height`` m tall, segments of ``segment`` m
    alternating dark/light starting with dark at ``x0``."""

    name: str
    x0: float
    x1: float
    z: float
    segment: float = 0.1
    height: float = 0.03


@dataclass(frozen=True)
class Camera:
    """Pinhole camera looking perpendicular to the car's side.

    Attributes
    ----------
    width, height : int
        Image size, px.
    m_per_px : float
        Scale in the car plane (at ``distance_car``), m/px; the focal length is
        ``distance_car / m_per_px`` px.
    centre_x, centre_z : float
        Car-plane point on the optical axis, m.
    distance_car : float
        Camera to car-side plane, m.
    distance_barrier : float
        Camera to the barrier's side face, m (different from the car plane: parallax).
    distance_background : float
        Camera to the background wall, m.
    k1, k2 : float
        Radial distortion of the normalised image coordinates, applied to the rendered
        image: ``x_d = x (1 + k1 r^2 + k2 r^4)``.
    """

    width: int = 640
    height: int = 480
    m_per_px: float = 0.01
    centre_x: float = 0.0
    centre_z: float = 0.8
    distance_car: float = 8.0
    distance_barrier: float = 7.7
    distance_background: float = 12.0
    k1: float = 0.0
    k2: float = 0.0

    @property
    def focal_px(self) -> float:
        """Focal length, px."""
        return self.distance_car / self.m_per_px

    @property
    def principal_point(self) -> tuple[float, float]:
        """(cx, cy) px: the image centre."""
        return (self.width - 1) / 2.0, (self.height - 1) / 2.0

    def scale_at(self, distance: float) -> float:
        """m/px of a plane at ``distance`` m from the camera (undistorted)."""
        return distance / self.focal_px


@dataclass(frozen=True)
class Occluder:
    """A dark blob (radius ``radius`` m in the car plane) that sweeps across target
    ``target`` from frame ``start`` to frame ``stop`` (exclusive), moving horizontally
    from ``2 * radius`` before it to ``2 * radius`` past it."""

    target: str
    start: int
    stop: int
    radius: float = 0.08


@dataclass(frozen=True)
class Effects:
    """Image degradations, all off by default.

    Attributes
    ----------
    noise_sigma : float
        Gaussian noise, grey levels (0-255).
    blur_substeps : int
        Motion blur: number of sub-frame positions averaged (1 = no blur).
    exposure : float
        Fraction of the frame interval the shutter is open (motion blur length).
    flicker : float
        Relative amplitude of the per-frame gain (lights on mains: 100 Hz sine plus a
        random part of the same size).
    flicker_hz : float
        Flicker frequency, Hz.
    jpeg_quality : int or None
        Compress each frame as JPEG with this quality (0-100) and decode it.
    debris : int
        Number of debris particles thrown from the contact point after contact.
    seed : int
        Random seed of noise, flicker and debris (films are reproducible).
    """

    noise_sigma: float = 0.0
    blur_substeps: int = 1
    exposure: float = 0.5
    flicker: float = 0.0
    flicker_hz: float = 100.0
    jpeg_quality: int | None = None
    debris: int = 0
    seed: int = 0


@dataclass(frozen=True)
class Scene:
    """Everything static in a synthetic crash film.

    Attributes
    ----------
    car : CarGeometry
    camera : Camera
    targets : tuple[Target, ...]
    tapes : tuple[Tape, ...]
    x_barrier : float
        Car-plane X of the barrier face, m.
    direction : int
        +1: the car moves left-to-right in the image; -1: right-to-left.
    occluders : tuple[Occluder, ...]
    effects : Effects
    supersample : int
        Polygons (body, wheels, tapes, barrier) are drawn at this many times the
        resolution and averaged down (anti-aliasing); targets are drawn analytically.
    body_grey, tyre_grey, rim_grey, barrier_grey, tape_dark, tape_light, target_dark, target_light : int
        Grey levels 0-255 of the parts.
    """

    car: CarGeometry
    camera: Camera
    targets: tuple = ()
    tapes: tuple = ()
    x_barrier: float = 0.0
    direction: int = 1
    occluders: tuple = ()
    effects: Effects = field(default_factory=Effects)
    supersample: int = 4
    body_grey: int = 175
    tyre_grey: int = 35
    rim_grey: int = 95
    barrier_grey: int = 120
    tape_dark: int = 25
    tape_light: int = 235
    target_dark: int = 15
    target_light: int = 245


@dataclass(frozen=True)
class Motion:
    """The car's motion, one value per frame (CONVENTIONS.md).

    Attributes
    ----------
    t : (n,) float
        Time of each frame, s, 0 at first contact (negative before).
    x, z : (n,) float
        CG displacement from its position at first contact, m (x towards the barrier).
    pitch : (n,) float
        Nose-down positive, rad.
    front_wheel_angle, rear_wheel_angle : (n,) float
        Wheel spin angles, rad, positive for forward rolling (absolute rotation in the
        car plane).
    front_wheel_dz, rear_wheel_dz : (n,) float
        Vertical offset of each wheel centre from its axle point on the body, m.
    crush : (n,) float or None
        Crush, m, as the model defines it; None: computed from the drawn silhouette.
    """

    t: np.ndarray
    x: np.ndarray
    z: np.ndarray
    pitch: np.ndarray
    front_wheel_angle: np.ndarray
    rear_wheel_angle: np.ndarray
    front_wheel_dz: np.ndarray | None = None
    rear_wheel_dz: np.ndarray | None = None
    crush: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of frames."""
        return int(np.asarray(self.t).shape[0])

    @property
    def contact_frame(self) -> int:
        """First frame with ``t >= 0`` (to within a microsecond)."""
        idx = np.flatnonzero(np.asarray(self.t) >= -1e-6)
        return int(idx[0]) if idx.size else self.n

    def at(self, f: float) -> dict:
        """Pose at a fractional frame index ``f``: dict with ``x, z, pitch,
        front_wheel_angle, rear_wheel_angle, front_wheel_dz, rear_wheel_dz``.

        Linear interpolation between frames, and linear extrapolation of the first and
        last intervals for sub-frame times outside the film (motion blur of the first
        and last frames stays centred on them)."""
        n = self.n
        if n == 1:
            i0 = i1 = 0
            a = 0.0
        else:
            i0 = int(min(max(np.floor(f), 0), n - 2))
            i1 = i0 + 1
            a = f - i0

        def lerp(arr):
            if arr is None:
                return 0.0
            arr = np.asarray(arr, dtype=float)
            return float((1 - a) * arr[i0] + a * arr[i1])

        return {
            "x": lerp(self.x),
            "z": lerp(self.z),
            "pitch": lerp(self.pitch),
            "front_wheel_angle": lerp(self.front_wheel_angle),
            "rear_wheel_angle": lerp(self.rear_wheel_angle),
            "front_wheel_dz": lerp(self.front_wheel_dz),
            "rear_wheel_dz": lerp(self.rear_wheel_dz),
        }


# -------------------------------------------------------------------------- geometry


def front_x(car: CarGeometry) -> float:
    """Vehicle-frame x of the front-most silhouette point, m."""
    return float(np.max(np.asarray(car.silhouette_side)[:, 0]))


def cg_x_at_contact(car: CarGeometry, x_barrier: float) -> float:
    """Car-plane X of the CG at first contact (bumper at the barrier face, pitch 0), m."""
    return x_barrier - (front_x(car) - car.x_cg)


def body_to_plane(points: np.ndarray, car: CarGeometry, pose: dict, x_cg0: float) -> np.ndarray:
    """Car-plane positions of vehicle-frame body points for a pose.

    Parameters
    ----------
    points : (N, 2) float
        Vehicle-frame points (x forward from the rear bumper, z up), m.
    car : CarGeometry
    pose : dict
        ``x, z, pitch`` (m, m, rad nose-down positive).
    x_cg0 : float
        Car-plane X of the CG at first contact, m.

    Returns
    -------
    (N, 2) float
        ``[X, Z]`` in the car plane, m (CONVENTIONS.md pose formula).
    """
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    th = pose["pitch"]
    c, s = np.cos(th), np.sin(th)
    dx = p[:, 0] - car.x_cg
    dz = p[:, 1] - car.cg_height
    X = x_cg0 + pose["x"] + dx * c + dz * s
    Z = car.cg_height + pose["z"] - dx * s + dz * c
    return np.stack([X, Z], axis=1)


def clip_at_floor(poly: np.ndarray, z_floor: float = 0.0) -> np.ndarray:
    """Draw a closed polygon's points that would go below the floor on the floor.

    Like :func:`clip_at_face` for ``Z >= z_floor``: (N, 2) car-plane m in, (M, 2) out.
    """
    flipped = np.asarray(poly, dtype=float)[:, ::-1] * -1.0
    return (clip_at_face(flipped, -z_floor) * -1.0)[:, ::-1]


def clip_at_face(poly: np.ndarray, x_face: float) -> np.ndarray:
    """Draw a closed polygon's points that pass the barrier face at the face.

    Edges crossing ``X = x_face`` are split at the crossing, then every point beyond
    the face is moved onto it (same Z).

    Parameters
    ----------
    poly : (N, 2) float
        Car-plane polygon, m.
    x_face : float
        Barrier face X, m.

    Returns
    -------
    (M, 2) float
    """
    poly = np.asarray(poly, dtype=float)
    out = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        out.append(a)
        da, db = a[0] - x_face, b[0] - x_face
        if da * db < 0:
            s = da / (da - db)
            out.append(a + s * (b - a))
    out = np.array(out)
    out[:, 0] = np.minimum(out[:, 0], x_face)
    return out


def project(camera: Camera, XZ: np.ndarray, distance: float, direction: int, distort: bool = True) -> np.ndarray:
    """Image position of points of a plane parallel to the car's side.

    Parameters
    ----------
    camera : Camera
    XZ : (N, 2) float
        Car-plane coordinates ``[X, Z]``, m, of points in the plane at ``distance``.
    distance : float
        Camera to that plane, m.
    direction : int
        +1 (X grows to the image's right) or -1.
    distort : bool
        Apply the camera's radial distortion.

    Returns
    -------
    (N, 2) float
        ``[u, v]`` px.
    """
    XZ = np.asarray(XZ, dtype=float).reshape(-1, 2)
    f = camera.focal_px
    cx, cy = camera.principal_point
    xn = direction * (XZ[:, 0] - camera.centre_x) / distance
    yn = -(XZ[:, 1] - camera.centre_z) / distance
    if distort and (camera.k1 or camera.k2):
        r2 = xn * xn + yn * yn
        g = 1.0 + camera.k1 * r2 + camera.k2 * r2 * r2
        xn, yn = xn * g, yn * g
    return np.stack([cx + f * xn, cy + f * yn], axis=1)


def unproject(camera: Camera, uv: np.ndarray, distance: float, direction: int) -> np.ndarray:
    """Inverse of :func:`project` without distortion: car-plane ``[X, Z]`` (N, 2) m of
    undistorted image points ``uv`` (N, 2) px on the plane at ``distance`` m."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    f = camera.focal_px
    cx, cy = camera.principal_point
    X = camera.centre_x + direction * (uv[:, 0] - cx) * distance / f
    Z = camera.centre_z - (uv[:, 1] - cy) * distance / f
    return np.stack([X, Z], axis=1)


# ------------------------------------------------------------------ default layout


def _inside(car: CarGeometry, x: float, z: float, margin: float) -> bool:
    poly = np.asarray(car.silhouette_side, dtype=np.float32)
    d = cv2.pointPolygonTest(poly.reshape(-1, 1, 2), (float(x), float(z)), True)
    return d >= margin


def default_targets(car: CarGeometry, diameter: float = 0.1, hub_diameter: float = 0.12) -> tuple:
    """Quadrant targets where crash labs stick them: roof rail, B-pillar, door, sill,
    and one on each wheel hub.

    Returns
    -------
    tuple[Target, ...]

    Raises
    ------
    ValueError
        If a default position falls outside the silhouette (an unusual body shape:
        place the targets yourself).
    """
    rear = car.rear_axle_x
    wb = car.wheelbase
    roof_z = float(car.windscreen_top[1])
    body = [
        Target("roof_rail", "body", float(car.windscreen_top[0]) - 0.7, roof_z - 0.12, diameter),
        Target("b_pillar", "body", rear + 0.52 * wb, 0.5 * (roof_z + 0.62 * car.height) - 0.1, diameter),
        Target("door", "body", rear + 0.72 * wb, 0.47 * car.height, diameter),
        Target("sill", "body", rear + 0.42 * wb, 0.2 * car.height, 0.8 * diameter),
    ]
    for t in body:
        if not _inside(car, t.x, t.z, 0.5 * t.diameter):
            raise ValueError(f"default target {t.name} at ({t.x:.3f}, {t.z:.3f}) m is not inside the silhouette; give targets explicitly")
    hubs = [Target("front_hub", "front_hub", diameter=hub_diameter), Target("rear_hub", "rear_hub", diameter=hub_diameter)]
    return tuple(body + hubs)


def default_tapes(car: CarGeometry, segment: float = 0.1, height: float = 0.03) -> tuple:
    """A checker tape along the sill (between the wheel arches) and one along the belt
    line, both on the undeforming passenger cell.

    Returns
    -------
    tuple[Tape, ...]
    """
    r = car.wheel_radius
    x0 = car.rear_axle_x + r + 0.15
    x1 = car.front_axle_x - r - 0.15
    n_sill = int((x1 - x0) // segment)
    sill = Tape("sill_tape", x0, x0 + n_sill * segment, 0.29 * car.height, segment, height)
    b0 = car.rear_axle_x + 0.05
    n_belt = int((car.front_axle_x - 0.35 - b0) // segment)
    zb = 0.6 * car.height
    # shorten the belt tape until it lies inside the body (the bonnet slopes down)
    while n_belt > 0 and not all(_inside(car, b0 + n_belt * segment, z, 0.02) for z in (zb, zb + height)):
        n_belt -= 1
    belt = Tape("belt_tape", b0, b0 + n_belt * segment, zb, segment, height)
    tapes = []
    for tape in (sill, belt):
        ok = all(_inside(car, x, z, 0.0) for x in (tape.x0, tape.x1) for z in (tape.z, tape.z + tape.height))
        if ok and tape.x1 - tape.x0 >= 4 * segment:
            tapes.append(tape)
    return tuple(tapes)


def default_camera(car: CarGeometry, x_barrier: float, width: int = 640, height: int = 480,
                   m_per_px: float | None = None, approach_m: float = 0.5, **kwargs) -> Camera:
    """A camera that sees the whole car from ``approach_m`` before contact to the
    barrier, with a margin; ``m_per_px`` chosen to fit if not given.

    Parameters
    ----------
    car : CarGeometry
    x_barrier : float
        Barrier face X, m.
    width, height : int
        Image size, px.
    m_per_px : float, optional
        Scale in the car plane; default: the whole scene fits the width.
    approach_m : float
        How far back the car's rear is at the first frame, m.
    **kwargs
        Other :class:`Camera` fields (distances, k1, k2).
    """
    span = front_x(car) + approach_m + 0.7  # car + approach + barrier margin
    left = x_barrier - front_x(car) - approach_m - 0.1
    if m_per_px is None:
        m_per_px = max(span / width, (car.height + 0.3) / height)
    centre_x = left + 0.5 * width * m_per_px
    centre_z = max(0.5 * height * m_per_px - 0.15, 0.5 * (car.height + 0.1))
    return Camera(width=width, height=height, m_per_px=m_per_px, centre_x=centre_x, centre_z=centre_z, **kwargs)
