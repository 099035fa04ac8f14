"""Scene description of a synthetic frontal barrier crash test seen from the side.

Frozen dataclasses only, plus the geometry the renderer and its truth share: where a
body point is in the car plane for a pose (CONVENTIONS.md formula), and where a point of
a plane parallel to the car's side at a given depth lands in the image: a pinhole camera
with a small yaw, pitch and roll about its centre, an off-centre principal point and
radial distortion k1, k2. Each such plane maps to the undistorted image by a homography
(:meth:`Camera.homography`), so polygons stay polygons.

Coordinates: car plane X (towards the barrier), Z (up from the floor), m; depth D from
the camera's centre along the normal of the car's side, m; image u, v px with (0, 0) the
centre of the top-left pixel; a film where the car moves right-to-left has X growing to
the image's left (``direction = -1``).

``car`` arguments are :class:`synth.vehicle.Car` (or any object with the same geometry
attributes: ``x_cg, front_axle_x, rear_axle_x, wheelbase, wheel_radius, cg_height,
height, silhouette_side, windscreen_top``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from synth.vehicle import Car, SynthError

# ----------------------------------------------------------------------------- parts


@dataclass(frozen=True)
class Target:
    """A quadrant target: a disc of ``diameter`` m split into four quadrants.

    ``kind`` is ``"body"`` (``x, z`` in the vehicle frame, moves with the body),
    ``"deform"`` (on a part that deforms, bonnet or front wing: a body point that also
    moves rearwards in the vehicle frame by ``follow`` times the crush and turns by
    ``turn`` rad per m of crush), ``"front_hub"`` / ``"rear_hub"`` (on a wheel centre,
    turns with the wheel; ``x, z`` ignored) or ``"fixed"`` (``x, z`` are car-plane X, Z of
    a fixed point at depth ``depth``, default the barrier's side face).

    ``angle`` turns the quadrant pattern in its plane (rad, e.g. pi/4 for a target stuck
    on at 45 deg); ``dark`` / ``light`` override the scene's target greys (e.g. a
    black/yellow target is dark 15, light about 200 in a grayscale film).
    """

    name: str
    kind: str
    x: float = 0.0
    z: float = 0.0
    diameter: float = 0.1
    angle: float = 0.0
    depth: float | None = None
    follow: float = 0.0
    turn: float = 0.0
    dark: int | None = None
    light: int | None = None


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


@functools.lru_cache(maxsize=256)
def rotation_matrix(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """3x3 rotation of camera coordinates (x right, y down, z along the optical axis):
    ``R = Rz(roll) @ Rx(pitch) @ Ry(yaw)``, angles in rad. A point with nominal camera
    coordinates ``p`` is seen at ``R @ p``; a positive yaw moves the scene to the image's
    right, a positive pitch moves it up, a positive roll turns it clockwise (v down)."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    Rz = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    R = Rz @ Rx @ Ry
    R.flags.writeable = False  # cached: shared by every caller
    return R


@dataclass(frozen=True)
class Camera:
    """Pinhole camera whose nominal optical axis is perpendicular to the car's side,
    turned about its centre by small ``yaw``, ``pitch`` and ``roll``.

    Attributes
    ----------
    width, height : int
        Image size, px.
    m_per_px : float
        Scale in the car plane (at ``distance_car``) on the nominal axis, m/px; the focal
        length is ``distance_car / m_per_px`` px.
    centre_x, centre_z : float
        Car-plane point on the nominal optical axis, m (the camera's centre is at that X
        and height Z, ``distance_car`` from the car's side).
    distance_car : float
        Camera to car-side plane, m.
    distance_barrier : float
        Camera to the barrier's side face, m (different from the car plane: parallax).
    distance_background : float
        Camera to the background wall, m.
    k1, k2 : float
        Radial distortion of the normalised image coordinates, applied to the rendered
        image: ``x_d = x (1 + k1 r^2 + k2 r^4)``.
    yaw, pitch, roll : float
        Rotation of the camera about its centre, rad (:func:`rotation_matrix`); 0: the
        optical axis is perpendicular to the car's side.
    pp_du, pp_dv : float
        Offset of the principal point from the image centre, px.
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
    yaw: float = 0.0
    pitch: float = 0.0
    roll: float = 0.0
    pp_du: float = 0.0
    pp_dv: float = 0.0

    @property
    def focal_px(self) -> float:
        """Focal length, px."""
        return self.distance_car / self.m_per_px

    @property
    def principal_point(self) -> tuple[float, float]:
        """(cx, cy) px: the image centre plus ``(pp_du, pp_dv)``."""
        return (self.width - 1) / 2.0 + self.pp_du, (self.height - 1) / 2.0 + self.pp_dv

    @property
    def K(self) -> np.ndarray:
        """3x3 intrinsic matrix."""
        f = self.focal_px
        cx, cy = self.principal_point
        return np.array([[f, 0.0, cx], [0.0, f, cy], [0.0, 0.0, 1.0]])

    def rotation(self) -> np.ndarray:
        """3x3 rotation of the camera (:func:`rotation_matrix`)."""
        return rotation_matrix(self.yaw, self.pitch, self.roll)

    def homography(self, distance: float, direction: int, extra_rotation: np.ndarray | None = None) -> np.ndarray:
        """3x3 homography from ``[X, Z, 1]`` of the plane at ``distance`` m (parallel to
        the car's side) to homogeneous undistorted pixels; ``extra_rotation`` (3x3) turns
        the camera further (camera shake)."""
        M = np.array([[direction, 0.0, -direction * self.centre_x],
                      [0.0, -1.0, self.centre_z],
                      [0.0, 0.0, distance]])
        R = self.rotation()
        if extra_rotation is not None:
            R = extra_rotation @ R
        return self.K @ R @ M

    def scale_at(self, distance: float) -> float:
        """m/px of a plane at ``distance`` m from the camera (undistorted, on the nominal
        axis)."""
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
    gain : float
        Exposure gain applied before clipping at 255 (> 1: overexposed, light parts
        saturate).
    shake_px : float
        Camera shake after contact: amplitude of the image translation, px (a rotation
        of the camera about its centre, so every depth moves alike).
    shake_hz : float
        Shake frequency, Hz.
    shake_decay_s : float
        Time constant of the shake's exponential decay, s.
    shake_angle : float
        Direction of the shake's translation in the image, rad from the u axis.
    shake_roll : float
        Amplitude of the shake's roll, rad (at 1.37 times ``shake_hz``).
    """

    noise_sigma: float = 0.0
    blur_substeps: int = 1
    exposure: float = 0.5
    flicker: float = 0.0
    flicker_hz: float = 100.0
    jpeg_quality: int | None = None
    debris: int = 0
    seed: int = 0
    gain: float = 1.0
    shake_px: float = 0.0
    shake_hz: float = 20.0
    shake_decay_s: float = 0.05
    shake_angle: float = 0.0
    shake_roll: float = 0.0


@dataclass(frozen=True)
class Scene:
    """Everything static in a synthetic crash film.

    Attributes
    ----------
    car : Car
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
    wall_grey, wall_texture, floor_grey : float
        Background: mean grey of the wall, amplitude of its smooth texture, floor grey.
    texture_scale : float
        Size of the wall texture's blobs, px.
    tile_m : float
        Spacing of the faint tile lines on the wall, m (0: none).
    texture_seed : int
        Seed of the background texture.
    hubcap_grey : int or None
        Draw a hubcap disc of this grey on each wheel (hubs without targets).
    lamps : tuple of (X, Z, radius) m
        Saturated lamps on the background wall.
    """

    car: Car
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
    wall_grey: float = 85.0
    wall_texture: float = 14.0
    floor_grey: float = 120.0
    texture_scale: float = 14.0
    tile_m: float = 0.5
    texture_seed: int = 12345
    hubcap_grey: int | None = None
    lamps: tuple = ()


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
        front_wheel_angle, rear_wheel_angle, front_wheel_dz, rear_wheel_dz`` and
        ``crush`` (None without ``self.crush``).

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
            "crush": None if self.crush is None else lerp(self.crush),
        }


# -------------------------------------------------------------------------- geometry


def front_x(car: Car) -> float:
    """Vehicle-frame x of the front-most silhouette point, m."""
    return float(np.max(np.asarray(car.silhouette_side)[:, 0]))


def cg_x_at_contact(car: Car, x_barrier: float) -> float:
    """Car-plane X of the CG at first contact (bumper at the barrier face, pitch 0), m."""
    return x_barrier - (front_x(car) - car.x_cg)


def body_to_plane(points: np.ndarray, car: Car, pose: dict, x_cg0: float) -> np.ndarray:
    """Car-plane positions of vehicle-frame body points for a pose.

    Parameters
    ----------
    points : (N, 2) float
        Vehicle-frame points (x forward from the rear bumper, z up), m.
    car : Car
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


def project(camera: Camera, XZ: np.ndarray, distance: float, direction: int, distort: bool = True,
            extra_rotation: np.ndarray | None = None) -> np.ndarray:
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
    extra_rotation : (3, 3) float, optional
        A further rotation of the camera (camera shake), applied after its own.

    Returns
    -------
    (N, 2) float
        ``[u, v]`` px.
    """
    XZ = np.asarray(XZ, dtype=float).reshape(-1, 2)
    f = camera.focal_px
    cx, cy = camera.principal_point
    c = np.stack([direction * (XZ[:, 0] - camera.centre_x), -(XZ[:, 1] - camera.centre_z),
                  np.full(len(XZ), float(distance))], axis=0)
    R = camera.rotation()
    if extra_rotation is not None:
        R = extra_rotation @ R
    if extra_rotation is not None or camera.yaw or camera.pitch or camera.roll:
        c = R @ c
    xn, yn = c[0] / c[2], c[1] / c[2]
    if distort and (camera.k1 or camera.k2):
        r2 = xn * xn + yn * yn
        g = 1.0 + camera.k1 * r2 + camera.k2 * r2 * r2
        xn, yn = xn * g, yn * g
    return np.stack([cx + f * xn, cy + f * yn], axis=1)


def unproject(camera: Camera, uv: np.ndarray, distance: float, direction: int,
              extra_rotation: np.ndarray | None = None) -> np.ndarray:
    """Inverse of :func:`project` without distortion: car-plane ``[X, Z]`` (N, 2) m of
    undistorted image points ``uv`` (N, 2) px on the plane at ``distance`` m."""
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    Hi = np.linalg.inv(camera.homography(distance, direction, extra_rotation))
    p = Hi @ np.vstack([uv.T, np.ones(len(uv))])
    return (p[:2] / p[2]).T


# ------------------------------------------------------------------ default layout


def _inside(car: Car, x: float, z: float, margin: float) -> bool:
    poly = np.asarray(car.silhouette_side, dtype=np.float32)
    d = cv2.pointPolygonTest(poly.reshape(-1, 1, 2), (float(x), float(z)), True)
    return d >= margin


def default_targets(car: Car, diameter: float = 0.1, hub_diameter: float = 0.12) -> tuple:
    """Quadrant targets where crash labs stick them: roof rail, B-pillar, door, sill,
    and one on each wheel hub.

    Returns
    -------
    tuple[Target, ...]

    Raises
    ------
    SynthError
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
            raise SynthError(f"default target {t.name} at ({t.x:.3f}, {t.z:.3f}) m is not inside the silhouette; give targets explicitly")
    hubs = [Target("front_hub", "front_hub", diameter=hub_diameter), Target("rear_hub", "rear_hub", diameter=hub_diameter)]
    return tuple(body + hubs)


def default_tapes(car: Car, segment: float = 0.1, height: float = 0.03) -> tuple:
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


def default_camera(car: Car, x_barrier: float, width: int = 640, height: int = 480,
                   m_per_px: float | None = None, approach_m: float = 0.5, **kwargs) -> Camera:
    """A camera that sees the whole car from ``approach_m`` before contact to the
    barrier, with a margin; ``m_per_px`` chosen to fit if not given.

    Parameters
    ----------
    car : Car
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
