"""Synthetic crash-test film with known truth, for tests, demos and the reference world.

Frames are grayscale ``(H, W)`` (uint8 from :meth:`Renderer.render`, float from
:meth:`Renderer.render_float` for 16-bit output). Body, wheels, tapes, barrier and
background are polygons of planes parallel to the car's side (each mapped to the image by
its homography) drawn at ``scene.supersample`` times the resolution and averaged down;
quadrant targets are drawn analytically: every one of ``TARGET_SUBSAMPLES`` x
``TARGET_SUBSAMPLES`` sub-samples of a pixel is carried back onto the target's plane and
the disc and quadrants are evaluated there. Lens distortion and camera shake (a rotation
of the camera after contact) resample the finished image once, so a target's truth centre
(the projection of its 3-D centre, with distortion and shake) is what the pixels show to a
small fraction of a pixel.

Example
-------
>>> renderer = Renderer(scene, motion)                         # doctest: +SKIP
>>> for frame, row in renderer.frames(): ...                   # doctest: +SKIP
>>> write_film(renderer, "crash.mp4")                          # doctest: +SKIP
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path
from typing import Iterator

import cv2
import numpy as np

from synth.vehicle import SynthError
from synth.scene import (
    Motion,
    Scene,
    Target,
    body_to_plane,
    cg_x_at_contact,
    clip_at_face,
    clip_at_floor,
    project,
    rotation_matrix,
    unproject,
)

TARGET_SUBSAMPLES = 3
_SHIFT = 4  # cv2 fractional bits for polygon vertices


def _texture(shape: tuple[int, int], rng: np.random.Generator, scale: float) -> np.ndarray:
    """Smooth random texture, float32 in about [-1, 1]."""
    h, w = shape
    small = rng.standard_normal((max(2, int(h / scale)) + 1, max(2, int(w / scale)) + 1)).astype(np.float32)
    big = cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)
    return big / (np.std(big) + 1e-6)


def inset_polygon(poly: np.ndarray, d: float) -> np.ndarray:
    """Move every edge of a closed polygon inwards by ``d`` (mitred vertices).

    Parameters
    ----------
    poly : (N, 2) float
        Vertices in either orientation (repeated consecutive vertices allowed).
    d : float
        Inward distance, same unit as ``poly``.

    Returns
    -------
    (M, 2) float
        The inset polygon (repeated vertices dropped; a vertex's shift is limited to
        ``4 d`` at sharp corners).
    """
    p = np.asarray(poly, dtype=float)
    keep = np.ones(len(p), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(p, axis=0)) > 1e-9, axis=1)
    p = p[keep]
    if len(p) > 1 and np.all(np.abs(p[0] - p[-1]) <= 1e-9):
        p = p[:-1]
    if len(p) < 3:
        return p
    x, y = p[:, 0], p[:, 1]
    area2 = np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    if area2 == 0.0:
        return p
    e = np.roll(p, -1, axis=0) - p  # edge i: p[i] -> p[i+1]
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    # inward normal: for a counter-clockwise polygon (area2 > 0) it is the left normal
    n = np.stack([-e[:, 1], e[:, 0]], axis=1) * np.sign(area2)
    n_prev = np.roll(n, 1, axis=0)
    m = n + n_prev
    denom = 1.0 + np.sum(n * n_prev, axis=1, keepdims=True)
    shift = np.where(denom > 1e-6, d * m / np.maximum(denom, 1e-6), d * n)
    norm = np.linalg.norm(shift, axis=1, keepdims=True)
    shift = np.where(norm > 4 * d, shift * (4 * d / np.maximum(norm, 1e-12)), shift)
    return p + shift


def inset_quads(quads: np.ndarray, d: float) -> np.ndarray:
    """:func:`inset_polygon` for K non-degenerate polygons of equal vertex count at once.

    Parameters
    ----------
    quads : (K, N, 2) float
    d : float

    Returns
    -------
    (K, N, 2) float
    """
    p = np.asarray(quads, dtype=float)
    x, y = p[..., 0], p[..., 1]
    area2 = np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
    e = np.roll(p, -1, axis=1) - p
    e /= np.maximum(np.linalg.norm(e, axis=2, keepdims=True), 1e-12)
    n = np.stack([-e[..., 1], e[..., 0]], axis=2) * np.sign(area2)[:, None, None]
    n_prev = np.roll(n, 1, axis=1)
    denom = 1.0 + np.sum(n * n_prev, axis=2, keepdims=True)
    shift = d * (n + n_prev) / np.maximum(denom, 0.25)
    return p + shift


class Renderer:
    """Renders the frames of ``motion`` in ``scene`` and their truth.

    Parameters
    ----------
    scene : Scene
    motion : Motion

    Attributes
    ----------
    x_cg0 : float
        Car-plane X of the CG at first contact, m.
    contact_frame : int
    impact_speed : float
        Speed at contact from the frames before it (backward difference of x), m/s.
    """

    def __init__(self, scene: Scene, motion: Motion):
        if scene.direction not in (1, -1):
            raise SynthError(f"scene.direction must be +1 or -1, got {scene.direction}")
        n = motion.n
        for name in ("x", "z", "pitch", "front_wheel_angle", "rear_wheel_angle"):
            arr = np.asarray(getattr(motion, name), dtype=float)
            if arr.shape != (n,) or not np.all(np.isfinite(arr)):
                raise SynthError(f"motion.{name} must be {n} finite values, got shape {arr.shape}")
        self.scene = scene
        self.motion = motion
        cam = scene.camera
        self.cam = cam
        self.ss = int(scene.supersample)
        self.x_cg0 = cg_x_at_contact(scene.car, scene.x_barrier)
        self.contact_frame = motion.contact_frame
        self._origin = np.zeros(2)  # final-image px of the canvas' top-left pixel
        self.background = self._background()
        lo = self.background.copy()
        if not self._barrier_behind:
            self._fill(lo, self._barrier_layer, float(scene.barrier_grey))
        self.background_lo = self._downsample(lo)
        self._maps = self._distortion_maps() if (cam.k1 or cam.k2) else None
        self._pixel_grid = None  # (u, v) float32 maps of the output pixels, made when needed
        self.impact_speed = self._impact_speed()
        self._debris = self._debris_particles()
        self._gain = self._flicker_gains()

    # ------------------------------------------------------------------ static parts
    def _hi(self, uv: np.ndarray) -> np.ndarray:
        """Undistorted px -> fixed-point coordinates of the supersampled canvas."""
        ss = self.ss
        return np.round(((uv + 0.5) * ss - 0.5) * (1 << _SHIFT)).astype(np.int32)

    def _proj(self, XZ: np.ndarray, distance: float) -> np.ndarray:
        return project(self.cam, XZ, distance, self.scene.direction, distort=False)

    def _background(self) -> np.ndarray:
        """Wall, floor and barrier at the supersampled resolution, uint8."""
        cam, sc, ss = self.cam, self.scene, self.ss
        H, W = cam.height * ss, cam.width * ss
        rng = np.random.default_rng(sc.texture_seed)
        tex = _texture((H, W), rng, sc.texture_scale * ss)
        fine = _texture((H, W), rng, 3.0 * ss)
        img = sc.wall_grey + sc.wall_texture * tex + 5.0 * fine
        d_bg = cam.distance_background
        corners = np.array([[0, 0], [cam.width - 1, 0], [0, cam.height - 1], [cam.width - 1, cam.height - 1]], float)
        wall = unproject(cam, corners, d_bg, sc.direction)
        X0, X1 = float(wall[:, 0].min()), float(wall[:, 0].max())
        # tiles on the wall, up to 4 m: faint dark lines every tile_m
        if sc.tile_m > 0:
            step = sc.tile_m
            for X in np.arange(np.floor(X0 / step) * step, X1 + step, step):
                a, b = self._hi(self._proj(np.array([[X, 0.0], [X, 4.0]]), d_bg))
                cv2.line(img, tuple(map(int, a)), tuple(map(int, b)), 60.0, max(1, ss), cv2.LINE_AA, _SHIFT)
            for Z in np.arange(step, 4.0, step):
                a, b = self._hi(self._proj(np.array([[X0 - 1, Z], [X1 + 1, Z]]), d_bg))
                cv2.line(img, tuple(map(int, a)), tuple(map(int, b)), 60.0, max(1, ss), cv2.LINE_AA, _SHIFT)
        ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
        circle = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        for X, Z, rad in sc.lamps:
            self._fill(img, self._proj(np.array([X, Z]) + rad * circle, d_bg), 255.0)
        # floor: everything below the wall's base line, lighter, with lines along the travel
        a, b = self._proj(np.array([[X0 - 5.0, 0.0], [X1 + 5.0, 0.0]]), d_bg)
        near = self._proj(np.array([[0.5 * (X0 + X1), 0.0]]), 0.5 * cam.distance_car)[0]
        nrm = np.array([-(b - a)[1], (b - a)[0]])
        sgn = 1.0 if np.dot(near - a, nrm) > 0 else -1.0
        uu = (np.arange(W, dtype=np.float32) + 0.5) / ss - 0.5
        vv = (np.arange(H, dtype=np.float32) + 0.5) / ss - 0.5
        floor = (sgn * (nrm[0] * (uu[None, :] - a[0]) + nrm[1] * (vv[:, None] - a[1]))) > 0
        img[floor] = sc.floor_grey + 8.0 * fine[floor]
        for d in np.linspace(cam.distance_car - 0.5, d_bg, 6):
            ends = unproject(cam, corners, d, sc.direction)[:, 0]
            a, b = self._hi(self._proj(np.array([[ends.min() - 5.0, 0.0], [ends.max() + 5.0, 0.0]]), d))
            cv2.line(img, tuple(map(int, a)), tuple(map(int, b)), sc.floor_grey - 20.0, max(1, ss), cv2.LINE_AA, _SHIFT)
        self._barrier_layer = self._barrier_polygon()
        if cam.distance_barrier >= cam.distance_car:
            self._fill(img, self._barrier_layer, float(sc.barrier_grey))
            self._barrier_behind = True
        else:
            self._barrier_behind = False
        return np.clip(img, 0, 255).astype(np.uint8)

    def _barrier_polygon(self) -> np.ndarray:
        sc = self.scene
        Xb = sc.x_barrier
        poly = np.array([[Xb, 0.0], [Xb + 3.0, 0.0], [Xb + 3.0, 1.6], [Xb, 1.6]])
        return self._proj(poly, self.cam.distance_barrier)

    def _fill(self, img: np.ndarray, uv: np.ndarray, value: float) -> None:
        """Fill a polygon given in final-image px on the supersampled canvas.

        ``cv2.fillPoly`` also paints the pixels its boundary passes through, which
        widens a shape by one canvas pixel; the polygon is first moved inwards by half a
        canvas pixel so that edges land where the geometry puts them.
        """
        ss = self.ss
        hi = inset_polygon((np.asarray(uv, dtype=float) - self._origin + 0.5) * ss - 0.5, 0.5)
        pts = np.round(hi * (1 << _SHIFT)).astype(np.int32)
        cv2.fillPoly(img, [pts.reshape(-1, 1, 2)], value, cv2.LINE_8, _SHIFT)

    def _fill_quads(self, img: np.ndarray, uv: np.ndarray, value: float) -> None:
        """Fill K convex quadrilaterals (K, 4, 2) final-image px, inset like :meth:`_fill`."""
        ss = self.ss
        hi = inset_quads((uv - self._origin + 0.5) * ss - 0.5, 0.5)
        pts = np.round(hi * (1 << _SHIFT)).astype(np.int32)
        cv2.fillPoly(img, list(pts.reshape(-1, 4, 1, 2)), value, cv2.LINE_8, _SHIFT)

    def _tape_quads(self, tape) -> np.ndarray:
        """(K, 4, 2) vehicle-frame corners of a tape's segments."""
        n_seg = int(round((tape.x1 - tape.x0) / tape.segment))
        xa = tape.x0 + tape.segment * np.arange(n_seg)
        xb = xa + tape.segment
        z0 = np.full(n_seg, tape.z)
        z1 = z0 + tape.height
        return np.stack([np.stack([xa, z0], 1), np.stack([xb, z0], 1), np.stack([xb, z1], 1), np.stack([xa, z1], 1)], axis=1)

    def _distortion_maps(self) -> tuple[np.ndarray, np.ndarray]:
        """For every pixel of the distorted output, where to sample the undistorted one."""
        cam = self.cam
        f = cam.focal_px
        cx, cy = cam.principal_point
        K = np.array([[f, 0, cx], [0, f, cy], [0, 0, 1]], dtype=np.float64)
        dist = np.array([cam.k1, cam.k2, 0.0, 0.0], dtype=np.float64)
        u, v = np.meshgrid(np.arange(cam.width, dtype=np.float64), np.arange(cam.height, dtype=np.float64))
        pts = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        und = cv2.undistortPoints(pts, K, dist, P=K, criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9))
        und = und.reshape(cam.height, cam.width, 2).astype(np.float32)
        return und[..., 0].copy(), und[..., 1].copy()

    def shake_rotation(self, i: float) -> np.ndarray | None:
        """Extra rotation (3x3) of the camera at frame ``i`` from the shake after contact,
        or None (no shake, or before contact)."""
        e = self.scene.effects
        if not (e.shake_px or e.shake_roll):
            return None
        t = (i - self.contact_frame) / self.motion_fps
        if t < 0:
            return None
        env = math.exp(-t / max(e.shake_decay_s, 1e-6))
        a = env * math.sin(2 * math.pi * e.shake_hz * t)
        b = env * math.sin(2 * math.pi * 1.37 * e.shake_hz * t)
        f = self.cam.focal_px
        du, dv = e.shake_px * a * math.cos(e.shake_angle), e.shake_px * a * math.sin(e.shake_angle)
        return rotation_matrix(math.atan(du / f), -math.atan(dv / f), e.shake_roll * b)

    def _sample_maps(self, i: int) -> tuple | None:
        """Where each output pixel of frame ``i`` samples the rendered (undistorted,
        unshaken) image: lens distortion, then the shake's homography, as ``cv2.remap``'s
        (map1, map2); None: nowhere else."""
        Rs = self.shake_rotation(i)
        if Rs is None:
            return self._maps
        if self._maps is not None:
            mu, mv = self._maps
        else:
            if self._pixel_grid is None:
                u, v = np.meshgrid(np.arange(self.cam.width, dtype=np.float32), np.arange(self.cam.height, dtype=np.float32))
                self._pixel_grid = (u, v)
            mu, mv = self._pixel_grid
        K = self.cam.K
        Hb = K @ Rs.T @ np.linalg.inv(K)  # shaken undistorted px -> rendered px
        pts = cv2.perspectiveTransform(cv2.merge([mu, mv]).reshape(-1, 1, 2), Hb)
        return pts.reshape(mu.shape[0], mu.shape[1], 2), None  # one two-channel map

    def _impact_speed(self) -> float:
        m, c = self.motion, self.contact_frame
        t = np.asarray(m.t, dtype=float)
        x = np.asarray(m.x, dtype=float)
        if 1 <= c < m.n:
            return float((x[c] - x[c - 1]) / (t[c] - t[c - 1]))
        if c == 0 and m.n > 1:
            return float((x[1] - x[0]) / (t[1] - t[0]))
        return float("nan")

    def _flicker_gains(self) -> np.ndarray:
        e = self.scene.effects
        n = self.motion.n
        if not e.flicker:
            return np.ones(n)
        rng = np.random.default_rng(e.seed + 1)
        t = np.asarray(self.motion.t, dtype=float)
        return 1.0 + e.flicker * (np.sin(2 * np.pi * e.flicker_hz * t) + rng.uniform(-1, 1, n))

    def _debris_particles(self) -> np.ndarray | None:
        """(k, 6): launch frame offset, X0, Z0, vX, vZ, size (m, m/s)."""
        e = self.scene.effects
        if e.debris <= 0:
            return None
        rng = np.random.default_rng(e.seed + 2)
        k = e.debris
        v0 = abs(self.impact_speed) if np.isfinite(self.impact_speed) else 10.0
        return np.stack(
            [
                rng.uniform(0, 20, k),  # frames after contact
                np.full(k, self.scene.x_barrier - 0.02),
                rng.uniform(0.2, 0.9, k),
                -rng.uniform(0.05, 0.5, k) * v0,
                rng.uniform(-0.2, 0.4, k) * v0,
                rng.uniform(0.01, 0.04, k),
            ],
            axis=1,
        )

    # ------------------------------------------------------------------- per frame
    def pose(self, f: float) -> dict:
        """Pose at fractional frame ``f`` (see :meth:`Motion.at`); ``crush`` computed
        from the silhouette when the motion has none."""
        pose = self.motion.at(f)
        if pose["crush"] is None:
            car = self.scene.car
            P = body_to_plane(car.silhouette_side, car, pose, self.x_cg0)
            pose["crush"] = float(max(P[:, 0].max() - self.scene.x_barrier, 0.0))
        return pose

    def wheel_centres(self, pose: dict) -> dict:
        """Car-plane ``[X, Z]`` (2,) of each wheel centre, m: the axle point of the body
        plus the wheel's vertical offset."""
        car = self.scene.car
        axles = np.array([[car.front_axle_x, car.wheel_radius], [car.rear_axle_x, car.wheel_radius]])
        P = body_to_plane(axles, car, pose, self.x_cg0)
        P[0, 1] += pose["front_wheel_dz"]
        P[1, 1] += pose["rear_wheel_dz"]
        return {"front": P[0], "rear": P[1]}

    def target_plane(self, target: Target, pose: dict) -> tuple[np.ndarray, float, float]:
        """Car-plane centre (2,) m, orientation (rad, counter-clockwise with Z up) and
        the depth (m) of a target for a pose."""
        cam = self.cam
        if target.kind == "body":
            P = body_to_plane(np.array([[target.x, target.z]]), self.scene.car, pose, self.x_cg0)[0]
            return P, -pose["pitch"] + target.angle, cam.distance_car
        if target.kind == "deform":
            crush = pose["crush"]
            P = body_to_plane(np.array([[target.x - target.follow * crush, target.z]]), self.scene.car, pose, self.x_cg0)[0]
            return P, -pose["pitch"] + target.angle + target.turn * crush, cam.distance_car
        if target.kind in ("front_hub", "rear_hub"):
            which = target.kind.split("_")[0]
            return self.wheel_centres(pose)[which], -pose[f"{which}_wheel_angle"] + target.angle, cam.distance_car
        if target.kind == "fixed":
            depth = cam.distance_barrier if target.depth is None else target.depth
            return np.array([target.x, target.z]), target.angle, depth
        raise SynthError(f"target {target.name}: unknown kind {target.kind!r} (body, deform, front_hub, rear_hub, fixed)")

    def _downsample(self, canvas: np.ndarray) -> np.ndarray:
        """Supersampled canvas -> final resolution, float32 (box average)."""
        ss = self.ss
        h, w = canvas.shape[0] // ss, canvas.shape[1] // ss
        if ss == 1:
            return canvas.astype(np.float32)
        return cv2.resize(canvas, (w, h), interpolation=cv2.INTER_AREA).astype(np.float32)

    def _draw_car(self, pose: dict) -> np.ndarray:
        """Background with the car (body, wheels, tapes) and barrier: float32 (H, W).

        Only the car's bounding box is drawn at the supersampled resolution; the rest is
        the static background, averaged down once."""
        sc, cam, ss = self.scene, self.cam, self.ss
        car = sc.car
        d = cam.distance_car
        body = self._proj(clip_at_floor(clip_at_face(body_to_plane(car.silhouette_side, car, pose, self.x_cg0), sc.x_barrier)), d)
        ang = np.linspace(0, 2 * np.pi, 48, endpoint=False)
        circle = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        # wheels are pushed back by the barrier like the body: clipped at its face
        wheels = [(self._proj(clip_at_face(c + car.wheel_radius * circle, sc.x_barrier), d),
                   self._proj(clip_at_face(c + 0.62 * car.wheel_radius * circle, sc.x_barrier), d))
                  for c in self.wheel_centres(pose).values()]
        pts = np.vstack([body] + [w[0] for w in wheels])
        u0 = int(max(np.floor(pts[:, 0].min()) - 2, 0))
        v0 = int(max(np.floor(pts[:, 1].min()) - 2, 0))
        u1 = int(min(np.ceil(pts[:, 0].max()) + 3, cam.width))
        v1 = int(min(np.ceil(pts[:, 1].max()) + 3, cam.height))
        out = self.background_lo.copy()
        if u1 <= u0 or v1 <= v0:
            return out
        self._origin = np.array([u0, v0], dtype=float)
        try:
            canvas = self.background[v0 * ss : v1 * ss, u0 * ss : u1 * ss].copy()
            self._fill(canvas, body, float(sc.body_grey))
            for tyre, rim in wheels:
                self._fill(canvas, tyre, float(sc.tyre_grey))
                self._fill(canvas, rim, float(sc.rim_grey))
            if sc.hubcap_grey is not None:
                for c in self.wheel_centres(pose).values():
                    self._fill(canvas, self._proj(clip_at_face(c + 0.3 * car.wheel_radius * circle, sc.x_barrier), d),
                               float(sc.hubcap_grey))
            self._draw_tapes(canvas, pose)
            if not self._barrier_behind:
                self._fill(canvas, self._barrier_layer, float(sc.barrier_grey))
        finally:
            self._origin = np.zeros(2)
        out[v0:v1, u0:u1] = self._downsample(canvas)
        return out

    def _draw_tapes(self, canvas: np.ndarray, pose: dict) -> None:
        sc = self.scene
        car = sc.car
        d = self.cam.distance_car
        # tapes: segments alternating dark/light, all quads of a tape transformed at once
        for tape in sc.tapes:
            quads = self._tape_quads(tape)  # (K, 4, 2) vehicle frame
            K = len(quads)
            P = body_to_plane(quads.reshape(-1, 2), car, pose, self.x_cg0).reshape(K, 4, 2)
            past = (P[:, :, 0] > sc.x_barrier).any(axis=1) | (P[:, :, 1] < 0.0).any(axis=1)
            uv = self._proj(P.reshape(-1, 2), d).reshape(K, 4, 2)
            for parity, grey in ((0, sc.tape_dark), (1, sc.tape_light)):
                sel = (np.arange(K) % 2 == parity) & ~past
                if sel.any():
                    self._fill_quads(canvas, uv[sel], float(grey))
                for k in np.flatnonzero((np.arange(K) % 2 == parity) & past):
                    Pk = clip_at_floor(clip_at_face(P[k], sc.x_barrier))
                    self._fill(canvas, self._proj(Pk, d), float(grey))

    def _draw_target(self, img: np.ndarray, target: Target, pose: dict) -> None:
        """Composite a quadrant target into ``img`` (float32, final resolution, undistorted).

        Each of ``TARGET_SUBSAMPLES`` x ``TARGET_SUBSAMPLES`` sub-samples of a pixel is
        carried back onto the target's plane (the plane's inverse homography) and the disc
        and quadrants are evaluated there, with an edge as soft as one sub-sample."""
        sc, cam = self.scene, self.cam
        centre, angle, dist = self.target_plane(target, pose)
        Hm = cam.homography(dist, sc.direction)
        p = Hm @ np.array([centre[0], centre[1], 1.0])
        uv = p[:2] / p[2]
        # Jacobian of the plane -> image map at the centre (px per m)
        J = (Hm[:2, :2] - np.outer(uv, Hm[2, :2])) / p[2]
        px_m = 1.0 / math.sqrt(abs(np.linalg.det(J)))  # m per px on that plane, near the target
        Rm = 0.5 * target.diameter
        R = Rm * float(np.linalg.svd(J, compute_uv=False)[0])  # largest radius, px
        u0, v0 = int(np.floor(uv[0] - R - 2)), int(np.floor(uv[1] - R - 2))
        u1, v1 = int(np.ceil(uv[0] + R + 2)), int(np.ceil(uv[1] + R + 2))
        H, W = img.shape
        if u1 < 0 or v1 < 0 or u0 >= W or v0 >= H:
            return
        u0c, v0c, u1c, v1c = max(u0, 0), max(v0, 0), min(u1, W - 1), min(v1, H - 1)
        k = TARGET_SUBSAMPLES
        offs = (np.arange(k) + 0.5) / k - 0.5
        uu = np.arange(u0c, u1c + 1)[None, :, None, None] + offs[None, None, None, :]
        vv = np.arange(v0c, v1c + 1)[:, None, None, None] + offs[None, None, :, None]
        uu, vv = np.broadcast_arrays(uu, vv)
        Hi = np.linalg.inv(Hm)
        w = Hi[2, 0] * uu + Hi[2, 1] * vv + Hi[2, 2]
        dX = (Hi[0, 0] * uu + Hi[0, 1] * vv + Hi[0, 2]) / w - centre[0]
        dZ = (Hi[1, 0] * uu + Hi[1, 1] * vv + Hi[1, 2]) / w - centre[1]
        c, s = math.cos(angle), math.sin(angle)
        lx = c * dX + s * dZ
        lz = -s * dX + c * dZ
        h = px_m / k  # sub-sample width on the plane, m
        r = np.sqrt(dX * dX + dZ * dZ)
        disc = np.clip((Rm - r) / h + 0.5, 0.0, 1.0)
        s1 = np.clip(lx / h + 0.5, 0.0, 1.0)
        s2 = np.clip(lz / h + 0.5, 0.0, 1.0)
        dark = disc * (s1 * s2 + (1 - s1) * (1 - s2))
        disc = disc.mean(axis=(2, 3))
        dark = dark.mean(axis=(2, 3))
        light_g = sc.target_light if target.light is None else target.light
        dark_g = sc.target_dark if target.dark is None else target.dark
        patch = img[v0c : v1c + 1, u0c : u1c + 1]
        patch *= 1.0 - disc
        patch += (disc - dark) * light_g + dark * dark_g

    def _occluder_state(self, i: float) -> list[tuple[np.ndarray, float, str, float]]:
        """Occluder blobs active at frame ``i``: (car-plane centre, radius m, target,
        depth m: the target's)."""
        out = []
        for occ in self.scene.occluders:
            if not occ.start <= i < occ.stop:
                continue
            tgt = self._target_by_name(occ.target)
            centre, _, depth = self.target_plane(tgt, self.pose(i))
            a = (i - occ.start) / max(occ.stop - occ.start - 1, 1)
            offset = (-2.0 + 4.0 * a) * occ.radius
            out.append((centre + np.array([offset, 0.0]), occ.radius, occ.target, depth))
        return out

    def _target_by_name(self, name: str) -> Target:
        for t in self.scene.targets:
            if t.name == name:
                return t
        raise SynthError(f"occluder refers to target {name!r}, which is not in the scene")

    def _draw_clean(self, f: float) -> np.ndarray:
        """One sub-frame at fractional frame ``f``: float32 (H, W), undistorted."""
        pose = self.pose(f)
        img = self._draw_car(pose)
        for target in self.scene.targets:
            self._draw_target(img, target, pose)
        d = self.cam.distance_car
        for centre, radius, _, depth in self._occluder_state(f):
            uv = self._proj(centre[None, :], depth)[0]
            r_px = radius / self.cam.scale_at(depth)
            cv2.ellipse(img, (int(round(uv[0] * 16)), int(round(uv[1] * 16))),
                        (int(round(r_px * 16)), int(round(0.8 * r_px * 16))), 20.0, 0, 360, 20.0, -1, cv2.LINE_AA, 4)
        if self._debris is not None:
            age = (f - self.contact_frame - self._debris[:, 0]) / self.motion_fps
            live = age >= 0
            if live.any():
                a, p = age[live], self._debris[live]
                XZ = np.stack([p[:, 1] + p[:, 3] * a, p[:, 2] + p[:, 4] * a - 4.9 * a * a], axis=1)
                uvs = self._proj(XZ, d - 0.3)
                for uv, size in zip(uvs, p[:, 5]):
                    r_px = max(size / self.cam.scale_at(d), 0.7)
                    cv2.circle(img, (int(round(uv[0] * 16)), int(round(uv[1] * 16))), int(round(r_px * 16)),
                               30.0 if size < 0.025 else 200.0, -1, cv2.LINE_AA, 4)
        return img

    @property
    def motion_fps(self) -> float:
        """Frame rate of the motion, frames per second (from its time step)."""
        t = np.asarray(self.motion.t, dtype=float)
        return float(np.round(1.0 / np.median(np.diff(t)), 6)) if len(t) > 1 else 1000.0

    def render_float(self, i: int) -> np.ndarray:
        """Frame ``i`` as float32 (H, W) grey levels 0-255 with every effect of the scene
        applied except the final rounding (and JPEG): for 16-bit output."""
        e = self.scene.effects
        nsub = max(int(e.blur_substeps), 1)
        if nsub == 1:
            img = self._draw_clean(float(i))
        else:
            offs = (np.arange(nsub) + 0.5) / nsub - 0.5
            img = np.zeros((self.cam.height, self.cam.width), np.float32)
            for o in offs:
                img += self._draw_clean(i + e.exposure * o)
            img /= nsub
        maps = self._sample_maps(i)
        if maps is not None:
            img = cv2.remap(img, maps[0], maps[1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if e.flicker:
            img *= float(self._gain[i])
        if e.gain != 1.0:
            img *= float(e.gain)
        if e.noise_sigma > 0:
            noise = np.empty_like(img)
            cv2.setRNGSeed(int((e.seed * 100003 + i) % 2147483647))
            cv2.randn(noise, 0.0, float(e.noise_sigma))
            img += noise
        return np.clip(img, 0.0, 255.0, out=img)

    def render(self, i: int) -> np.ndarray:
        """Frame ``i`` as uint8 (H, W) with every effect of the scene applied."""
        e = self.scene.effects
        out = (self.render_float(i) + 0.5).astype(np.uint8)
        if e.jpeg_quality is not None:
            ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(e.jpeg_quality)])
            out = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
        return out

    # ------------------------------------------------------------------------ truth
    def truth_row(self, i: int) -> dict:
        """Truth of frame ``i``: time, pose, crush, wheel angles, every target's pixel
        centre (with lens distortion) and whether an occluder covers it."""
        m = self.motion
        pose = self.pose(float(i))
        row = {
            "frame": i,
            "t_s": float(m.t[i]),
            "x_m": pose["x"],
            "z_m": pose["z"],
            "pitch_rad": pose["pitch"],
            "crush_m": self.crush(i),
            "front_wheel_angle_rad": pose["front_wheel_angle"],
            "rear_wheel_angle_rad": pose["rear_wheel_angle"],
            "front_wheel_dz_m": pose["front_wheel_dz"],
            "rear_wheel_dz_m": pose["rear_wheel_dz"],
        }
        wheels = self.wheel_centres(pose)
        row["front_wheel_height_m"] = float(wheels["front"][1] - self.scene.car.wheel_radius)
        row["rear_wheel_height_m"] = float(wheels["rear"][1] - self.scene.car.wheel_radius)
        occl = self._occluder_state(float(i))
        Rs = self.shake_rotation(i)
        for t in self.scene.targets:
            centre, _, dist = self.target_plane(t, pose)
            u, v = project(self.cam, centre[None, :], dist, self.scene.direction, distort=True, extra_rotation=Rs)[0]
            row[f"{t.name}_u_px"] = float(u)
            row[f"{t.name}_v_px"] = float(v)
            covered = any(np.hypot(*(c - centre)) < r + 0.5 * t.diameter for c, r, name, _ in occl)
            row[f"{t.name}_occluded"] = int(covered)
        return row

    def crush(self, i: int) -> float:
        """Crush at frame ``i``, m: the motion's own if given, else how far the
        unclipped silhouette passes the barrier face (>= 0)."""
        if self.motion.crush is not None:
            return float(np.asarray(self.motion.crush, dtype=float)[i])
        return float(self.pose(float(i))["crush"])

    def truth_meta(self) -> dict:
        """Film-level truth: scale, contact frame, impact speed, camera, targets."""
        sc, cam = self.scene, self.cam
        return {
            "fps": self.motion_fps,
            "n_frames": self.motion.n,
            "contact_frame": self.contact_frame,
            "impact_speed_mps": self.impact_speed,
            "direction": sc.direction,
            "m_per_px_car_plane": cam.m_per_px,
            "m_per_px_barrier_plane": cam.scale_at(cam.distance_barrier),
            "m_per_px_background": cam.scale_at(cam.distance_background),
            "x_barrier_m": sc.x_barrier,
            "x_cg_at_contact_m": self.x_cg0,
            "barrier_face_u_px": float(project(cam, np.array([[sc.x_barrier, 0.5]]), cam.distance_barrier, sc.direction)[0, 0]),
            "camera": {
                "width": cam.width, "height": cam.height, "focal_px": cam.focal_px,
                "principal_point": list(cam.principal_point), "centre_x_m": cam.centre_x,
                "centre_z_m": cam.centre_z, "distance_car_m": cam.distance_car,
                "distance_barrier_m": cam.distance_barrier, "distance_background_m": cam.distance_background,
                "k1": cam.k1, "k2": cam.k2, "yaw_rad": cam.yaw, "pitch_rad": cam.pitch, "roll_rad": cam.roll,
                "principal_offset_px": [cam.pp_du, cam.pp_dv],
            },
            "targets": [{"name": t.name, "kind": t.kind, "x_m": t.x, "z_m": t.z, "diameter_m": t.diameter,
                         "angle_rad": t.angle, "deforms": t.kind == "deform",
                         "depth_m": (self.target_plane(t, self.pose(0.0))[2]),
                         "follow": t.follow, "turn_rad_per_m": t.turn,
                         "dark_grey": sc.target_dark if t.dark is None else t.dark,
                         "light_grey": sc.target_light if t.light is None else t.light} for t in sc.targets],
            "tapes": [{"name": t.name, "x0_m": t.x0, "x1_m": t.x1, "z_m": t.z, "segment_m": t.segment, "height_m": t.height} for t in sc.tapes],
            "effects": {k: getattr(sc.effects, k) for k in sc.effects.__dataclass_fields__},
        }

    def frames(self) -> Iterator[tuple[np.ndarray, dict]]:
        """Yield ``(frame, truth_row)`` for every frame in order."""
        for i in range(self.motion.n):
            yield self.render(i), self.truth_row(i)


# ---------------------------------------------------------------------------- writers


def write_film(renderer: Renderer, path: str | Path, container_fps: float | None = None,
               duplicate: tuple = ()) -> dict:
    """Render every frame to a film and write the truth beside it.

    Parameters
    ----------
    renderer : Renderer
    path : str or Path
        ``*.mp4`` (codec mp4v), ``*.avi`` (MJPG), ``*.mov`` (mp4v), or a folder path
        without suffix (numbered PNG frames ``frame_00000.png`` ...).
    container_fps : float, optional
        Rate written into the container (default: the true rate); e.g. 30 to mimic a
        film re-encoded for publication.
    duplicate : tuple of int
        Frame indices written twice (mimics re-encoding duplicates); the truth lists
        the frames as written.

    Returns
    -------
    dict
        The film-level truth (also in ``<stem>.truth.json``); per-frame truth in
        ``<stem>.truth.csv``.
    """
    path = Path(path)
    fps = renderer.motion_fps if container_fps is None else float(container_fps)
    cam = renderer.cam
    suffix = path.suffix.lower()
    writer = None
    if suffix in (".mp4", ".mov", ".avi"):
        fourcc = cv2.VideoWriter_fourcc(*("MJPG" if suffix == ".avi" else "mp4v"))
        path.parent.mkdir(parents=True, exist_ok=True)
        writer = cv2.VideoWriter(str(path), fourcc, fps, (cam.width, cam.height), True)
        if not writer.isOpened():
            raise SynthError(f"cannot write video {path} (no encoder for {suffix}); write a folder of PNG frames instead")
    elif suffix == "":
        path.mkdir(parents=True, exist_ok=True)
        if any(path.glob("frame_*.png")):
            raise SynthError(f"folder {path} already holds frames; write the film to a new folder")
    else:
        raise SynthError(f"cannot write {path}: use .mp4, .avi, .mov or a folder name without suffix")
    rows = []
    k = 0
    try:
        for frame, row in renderer.frames():
            copies = 2 if row["frame"] in duplicate else 1
            for _ in range(copies):
                out_row = dict(row, written_index=k)
                rows.append(out_row)
                if writer is not None:
                    writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR))
                else:
                    cv2.imwrite(str(path / f"frame_{k:05d}.png"), frame)
                k += 1
    finally:
        if writer is not None:
            writer.release()
    meta = renderer.truth_meta()
    meta["container_fps"] = fps
    meta["duplicated_frames_written"] = sorted(int(d) for d in duplicate)
    write_truth(path, meta, rows)
    return meta


def truth_paths(film_path: str | Path) -> tuple[Path, Path]:
    """``(<stem>.truth.json, <stem>.truth.csv)`` beside a film (or a frames folder)."""
    p = Path(film_path)
    base = p.with_suffix("") if p.suffix else p
    return base.parent / (base.name + ".truth.json"), base.parent / (base.name + ".truth.csv")


def _json_clean(v):
    """JSON-ready copy: numpy scalars to Python, non-finite floats to None."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: _json_clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_clean(x) for x in v]
    return v


def update_truth(film_path: str | Path, extra: dict) -> dict:
    """Add ``extra`` to the film-level truth JSON beside ``film_path``; return it all."""
    jpath, _ = truth_paths(film_path)
    meta = json.loads(jpath.read_text())
    meta.update(_json_clean(extra))
    jpath.write_text(json.dumps(meta, indent=2))
    return meta


def write_truth(film_path: str | Path, meta: dict, rows: list[dict]) -> None:
    """Write film-level truth (JSON) and per-frame truth (CSV) beside ``film_path``."""
    jpath, cpath = truth_paths(film_path)
    jpath.write_text(json.dumps(_json_clean(meta), indent=2))
    if rows:
        with cpath.open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_truth(film_path: str | Path) -> tuple[dict, dict]:
    """Read the truth written by :func:`write_film`.

    Returns
    -------
    meta : dict
    columns : dict[str, (n,) float64]
    """
    jpath, cpath = truth_paths(film_path)
    if not jpath.exists() or not cpath.exists():
        raise SynthError(f"no truth files beside {film_path} ({jpath.name}, {cpath.name}); render the film with synth.render.write_film")
    meta = json.loads(jpath.read_text())
    with cpath.open() as fh:
        rows = list(csv.DictReader(fh))
    columns = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]} if rows else {}
    return meta, columns
