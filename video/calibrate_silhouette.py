"""Fit the vehicle's side outline to a frame (chamfer matching) and cross-check the scale.

The outline (``CarGeometry.silhouette_side``, vehicle frame: x forward from the rear
bumper, z up from the ground, m) is placed in the image by a similarity transform

    [u, v] = origin + k R(roll) [direction * x, -z]

with ``k`` px per m, ``direction`` +1 when the car faces (and moves) to the image's right,
``roll`` the small rotation of the car's x axis in the image (camera roll plus pitch, rad,
positive clockwise on screen). The transform is found by matching the outline's edges to
the frame's Canny edges: a coarse search over scales and positions by template matching
on the distance transform, a robust least-squares chamfer refinement, then a sub-pixel
refinement on gradient-centroid edge points along the outline's normals (Canny puts
edges on whole pixels, which makes the outline about half a pixel too fat).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.optimize import least_squares

from .calibrate_profile import edge_centroids, sample, to_gray
from .errors import VideoError

_TRUNC = 8.0  # px: distances beyond this count as "no edge here"


@dataclass(frozen=True)
class SilhouetteFit:
    """Where the vehicle's side outline lies in a frame.

    Positions are in the frame's own (recorded, not undistorted) pixels.

    Attributes
    ----------
    m_per_px, sigma : float
        Scale of the outline, m/px, and its one-sigma uncertainty (the fit's noise and
        the outline's tolerance, see :func:`fit_silhouette`).
    origin_px : (2,) px
        Image position of the vehicle frame's origin (rear bumper x = 0, ground z = 0).
    direction : int
        +1 if the car faces the image's right (moves left-to-right), -1 otherwise.
    roll_rad : float
        Rotation of the car's x axis in the image, rad (clockwise on screen positive).
    polygon_px : (N, 2) px
        The fitted outline in the image.
    windscreen_top_px : (2,) px
        The roof edge at the top of the windscreen.
    front_px : (2,) px
        The outline's most forward point (front bumper).
    rms_px : float
        RMS distance of the matched outline points from image edges, px.
    matched_fraction : float
        Fraction of the outline within 2 px of an image edge.
    """

    m_per_px: float
    sigma: float
    origin_px: np.ndarray
    direction: int
    roll_rad: float
    polygon_px: np.ndarray
    windscreen_top_px: np.ndarray
    front_px: np.ndarray
    rms_px: float
    matched_fraction: float

    def to_image(self, points_m: np.ndarray) -> np.ndarray:
        """Image positions (N, 2) px of vehicle-frame points (N, 2) m under this fit."""
        return _to_image(np.asarray(points_m, float), self.origin_px, 1.0 / self.m_per_px,
                         self.direction, self.roll_rad)


@dataclass(frozen=True)
class ScaleComparison:
    """Tape scale against silhouette scale (the paper's parallax check).

    Attributes
    ----------
    tape_m_per_px, tape_sigma, silhouette_m_per_px, silhouette_sigma : float
        The two scales and their one-sigma uncertainties, m/px.
    relative_difference : float
        silhouette / tape - 1.
    n_sigma : float
        |difference| over the combined uncertainty.
    agree : bool
        True when ``n_sigma <= 3``.
    note : str
        One sentence for the user.
    """

    tape_m_per_px: float
    tape_sigma: float
    silhouette_m_per_px: float
    silhouette_sigma: float
    relative_difference: float
    n_sigma: float
    agree: bool
    note: str


def _to_image(pts: np.ndarray, origin: np.ndarray, k: float, direction: int,
              roll: float) -> np.ndarray:
    c, s = np.cos(roll), np.sin(roll)
    a = np.column_stack([direction * pts[:, 0], -pts[:, 1]]) * k
    return origin + np.column_stack([c * a[:, 0] - s * a[:, 1], s * a[:, 0] + c * a[:, 1]])


def _densify(poly: np.ndarray, step: float) -> np.ndarray:
    """Points every ``step`` (polygon units) along a closed polygon's edges."""
    out = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / step)))
        t = (np.arange(n) + 0.5) / n
        out.append(a + t[:, None] * (b - a))
    return np.concatenate(out)


def edge_distance(gray: np.ndarray) -> np.ndarray:
    """Distance (px, float32, truncated at 8 px) from each pixel to the nearest Canny edge.

    Parameters
    ----------
    gray : (H, W) float32

    Returns
    -------
    (H, W) float32
    """
    g8 = np.clip(gray, 0, 255).astype(np.uint8)
    g8 = cv2.GaussianBlur(g8, (0, 0), 1.5)
    gx = cv2.Sobel(g8, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(g8, cv2.CV_32F, 0, 1)
    mag = np.hypot(gx, gy)
    # only the strong edges: the body against the background, not wall texture
    hi = max(40.0, float(np.percentile(mag, 98)))
    edges = cv2.Canny(g8, 0.5 * hi, hi, L2gradient=True)
    dt = cv2.distanceTransform(255 - edges, cv2.DIST_L2, 5)
    dt = cv2.GaussianBlur(np.minimum(dt, _TRUNC), (0, 0), 0.7)
    return dt.astype(np.float32)


def _coarse(dt: np.ndarray, poly: np.ndarray, scales_px_per_m: np.ndarray,
            directions: tuple, inside_px: np.ndarray | None = None) -> tuple[float, int, np.ndarray, float]:
    """Best (k, direction, origin, cost) over scales and translations, by template
    matching of the outline drawn at each scale against the distance transform; with
    ``inside_px`` (M, 2), only placements whose bounding box holds those points."""
    h, w = dt.shape
    ds = max(1, int(round(max(w, h) / 320)))
    dts = cv2.resize(dt, (w // ds, h // ds), interpolation=cv2.INTER_AREA)
    best = (np.inf, None)
    for d in directions:
        for k in scales_px_per_m:
            img_pts = _to_image(poly, np.zeros(2), k / ds, d, 0.0)
            lo = img_pts.min(axis=0)
            pts = img_pts - lo + 1
            tw, th = int(np.ceil(pts[:, 0].max())) + 2, int(np.ceil(pts[:, 1].max())) + 2
            if tw >= dts.shape[1] or th >= dts.shape[0] or tw < 8:
                continue
            tpl = np.zeros((th, tw), np.uint8)
            cv2.polylines(tpl, [np.round(pts * 16).astype(np.int32)], True, 1, 1,
                          cv2.LINE_8, 4)
            tplf = tpl.astype(np.float32)
            n = tplf.sum()
            res = cv2.matchTemplate(dts, tplf, cv2.TM_CCORR) / n
            if inside_px is not None:  # the template's box [loc, loc + (tw, th)] must hold them
                p = np.asarray(inside_px, float) / ds
                cols, rows = np.arange(res.shape[1]), np.arange(res.shape[0])
                ok_x = (cols >= p[:, 0].max() - (tw - 1)) & (cols <= p[:, 0].min())
                ok_y = (rows >= p[:, 1].max() - (th - 1)) & (rows <= p[:, 1].min())
                if not (ok_x.any() and ok_y.any()):
                    continue
                res = np.where(ok_y[:, None] & ok_x[None, :], res, np.float32(np.inf))
            mn, _, loc, _ = cv2.minMaxLoc(res)
            if mn < best[0]:
                origin = (np.array(loc, float) - lo + 1) * ds
                best = (mn, (k, d, origin))
    if best[1] is None:
        held = "" if inside_px is None else (" around the body targets (they spread wider than the car's outline"
                                             " at every scale tried: are they all on the car?)")
        raise VideoError("the vehicle outline does not fit in the frame at any scale tried" + held
                         + "; check the vehicle file and the scale")
    k, d, origin = best[1]
    return k, d, origin, best[0] * ds


def fit_silhouette(frame: np.ndarray, car, *, scale_hint: float | None = None,
                   direction: int | None = None, outline_tolerance_m: float = 0.01,
                   frame_index: int = 0, inside_px: np.ndarray | None = None) -> SilhouetteFit:
    """Fit the vehicle's side outline to a frame: scale, position, direction of travel.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
        A frame showing the whole car side-on (grayscale or BGR).
    car : video.types.CarGeometry
        Needs ``silhouette_side`` (N, 2) m and ``windscreen_top`` (2,) m.
    scale_hint : float, optional
        Expected scale, m/px (e.g. the tape's); the search then spans +-12 % around it.
        Without it the car may span 20-95 % of the frame width.
    direction : +1 or -1, optional
        Direction of travel if known; otherwise both are tried.
    outline_tolerance_m : float
        How well the vehicle file's outline matches this car over its length, m (a
        database outline, not a survey of the test car): it sets a floor on the
        silhouette scale's uncertainty (``outline_tolerance_m / length``).
    frame_index : int
        For messages.
    inside_px : (M, 2) float, optional
        Image points on the car's side in this frame (its body targets), px: the outline
        is looked for only where its bounding box holds them, and a fitted outline that
        leaves one of them more than 2 px outside is refused (a grid or a lamp on the wall
        can match the outline's shape better than the car's own edges do).

    Returns
    -------
    SilhouetteFit

    Raises
    ------
    VideoError
        If the outline matches the image's edges nowhere (no car side-on in the frame).
    """
    gray = to_gray(frame, frame_index=frame_index)
    h, w = gray.shape
    poly = np.asarray(car.silhouette_side, float)
    if poly.ndim != 2 or poly.shape[1] != 2 or len(poly) < 3:
        raise VideoError(f"vehicle outline has shape {poly.shape}, expected (N, 2) with N >= 3;"
                         " check silhouette_side in the vehicle file")
    length = float(np.ptp(poly[:, 0]))
    dt = edge_distance(gray)
    if scale_hint is not None:
        if not (np.isfinite(scale_hint) and scale_hint > 0):
            raise VideoError(f"scale hint {scale_hint!r} m/px is not a positive number")
        scales = (1.0 / scale_hint) * np.exp(np.linspace(np.log(0.88), np.log(1.12), 13))
    else:
        scales = np.exp(np.arange(np.log(0.2 * w / length), np.log(0.95 * w / length), 0.03))
    dirs = (direction,) if direction in (1, -1) else (1, -1)
    inside = None if inside_px is None else np.asarray(inside_px, float).reshape(-1, 2)
    if inside is not None:
        inside = inside[np.all(np.isfinite(inside), axis=1)]
    k0, d, origin0, _ = _coarse(dt, poly, scales, dirs, inside if inside is not None and len(inside) else None)
    # refine on points ~1.5 px apart, in px-sized unknowns: du, dv, dlength, droll
    pts_m = _densify(poly, 1.5 / k0)
    half_len_px = 0.5 * length * k0

    def place(x):
        k = k0 * np.exp(x[2] / (2 * half_len_px))
        roll = x[3] / half_len_px
        return origin0 + x[:2], k, roll

    def residuals(x):
        o, k, roll = place(x)
        vals = sample(dt, _to_image(pts_m, o, k, d, roll))
        return np.where(np.isfinite(vals), vals, _TRUNC)

    x = np.zeros(4)
    for f_scale in (3.0, 1.0):
        # finite differences over the piecewise-linear distance map: ~0.3 px steps
        sol = least_squares(residuals, x, loss="soft_l1", f_scale=f_scale, diff_step=0.3,
                            x_scale=1.0, method="trf", max_nfev=200)
        x = sol.x
    o, k, roll = place(x)
    res = residuals(x)
    inl = res < 2.0
    matched = float(np.mean(inl))
    if matched < 0.25:
        raise VideoError(f"vehicle outline not found in frame {frame_index}: only "
                         f"{100 * matched:.0f} % of it lies on image edges; check the vehicle "
                         "file and that the whole car is in view side-on")
    # sub-pixel refinement: Canny puts edges on whole pixels (the outline comes out about
    # half a pixel fat); refine on gradient-centroid edge points along the normals
    o, k, roll, sig_len_rel, rms = _refine_subpixel(gray, poly, o, k, d, roll)
    m_per_px = 1.0 / k
    sigma = m_per_px * float(np.hypot(sig_len_rel, outline_tolerance_m / length))
    polygon = _to_image(poly, o, k, d, roll)
    if inside is not None and len(inside):
        contour = polygon.astype(np.float32).reshape(-1, 1, 2)
        out = [p for p in inside if cv2.pointPolygonTest(contour, (float(p[0]), float(p[1])), True) < -2.0]
        if out:
            raise VideoError(f"the vehicle outline found in frame {frame_index} leaves {len(out)} of the "
                             f"{len(inside)} body targets outside it: it matched other edges")
    ws = _to_image(np.asarray(car.windscreen_top, float)[None, :], o, k, d, roll)[0]
    front = polygon[np.argmax(poly[:, 0])]
    return SilhouetteFit(m_per_px=float(m_per_px), sigma=float(sigma), origin_px=o,
                         direction=int(d), roll_rad=float(roll), polygon_px=polygon,
                         windscreen_top_px=ws, front_px=front,
                         rms_px=rms, matched_fraction=matched)


def _outline_samples(poly: np.ndarray, step_m: float, skip_m: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Points every ``step_m`` along a closed polygon's edges, not within ``skip_m`` of a
    vertex, and each point's edge direction (unit, vehicle frame)."""
    pts, dirs = [], []
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        ln = float(np.linalg.norm(b - a))
        if ln <= 2 * skip_m:
            continue
        s = np.arange(skip_m, ln - skip_m + 1e-12, step_m)
        u = (b - a) / ln
        pts.append(a + s[:, None] * u)
        dirs.append(np.repeat(u[None, :], len(s), axis=0))
    return np.concatenate(pts), np.concatenate(dirs)


def _refine_subpixel(gray: np.ndarray, poly: np.ndarray, origin: np.ndarray, k: float,
                     direction: int, roll: float, iterations: int = 4
                     ) -> tuple[np.ndarray, float, float, float, float]:
    """Gauss-Newton on sub-pixel edge offsets along the outline's normals.

    Returns (origin, k, roll, relative sigma of k, rms px)."""
    pts_m, dirs_m = _outline_samples(poly, 2.0 / k, 3.0 / k)
    step = 0.25
    t = np.arange(-4.0, 4.0 + step, step)
    x = np.zeros(4)  # du, dv (px), dlog k, droll (rad)
    rel_sig, rms = float("nan"), float("nan")
    for _ in range(iterations):
        o, kk, rr = origin + x[:2], k * np.exp(x[2]), roll + x[3]
        p = _to_image(pts_m, o, kk, direction, rr)
        tip = _to_image(pts_m + dirs_m, o, kk, direction, rr) - p
        tip /= np.linalg.norm(tip, axis=1, keepdims=True)
        nrm = np.column_stack([-tip[:, 1], tip[:, 0]])
        grid = p[:, None, :] + t[None, :, None] * nrm[:, None, :]
        prof = sample(gray, grid)
        ok = ~np.isnan(prof).any(axis=1)
        g = np.abs(np.gradient(np.nan_to_num(prof), step, axis=1))
        g[:, :3] = 0.0
        g[:, -3:] = 0.0
        ip = np.argmax(g, axis=1)
        st = g[np.arange(len(g)), ip]
        off = np.where(ok, edge_centroids(t, g, ip, 8), np.nan)
        good = np.isfinite(off) & (st > 0.3 * np.nanmedian(st[ok]))
        # d p / d params: translation, scale about the origin, rotation about the origin
        rel = p - o
        jp = np.stack([np.tile([1.0, 0.0], (len(p), 1)), np.tile([0.0, 1.0], (len(p), 1)),
                       rel, np.column_stack([-rel[:, 1], rel[:, 0]])], axis=2)  # (N, 2, 4)
        jn = np.einsum("ni,nij->nj", nrm, jp)
        r = off
        med = np.nanmedian(r[good])
        mad = 1.4826 * np.nanmedian(np.abs(r[good] - med))
        good &= np.abs(r - med) <= max(3.0 * mad, 0.3)
        if good.sum() < 20:
            break
        jg, rg = jn[good], r[good]
        dx, *_ = np.linalg.lstsq(jg, rg, rcond=None)
        x = x + dx
        res = rg - jg @ dx
        rms = float(np.sqrt(np.mean(res ** 2)))
        # neighbouring samples (2 px apart) see the same pixels: ~1 independent per 4 px
        cov = max(rms, 0.05) ** 2 * 2.0 * np.linalg.inv(jg.T @ jg)
        rel_sig = float(np.sqrt(cov[2, 2]))
        if np.max(np.abs(dx[:2])) < 1e-3 and abs(dx[2]) < 1e-6:
            break
    return origin + x[:2], k * np.exp(x[2]), roll + x[3], rel_sig, rms


def compare_scales(tape_m_per_px: float, tape_sigma: float,
                   silhouette: SilhouetteFit, source: str = "tape") -> ScaleComparison:
    """Compare the tape's scale with the silhouette's (the parallax check).

    Parameters
    ----------
    tape_m_per_px, tape_sigma : float
        Tape scale and its one-sigma uncertainty, m/px.
    silhouette : SilhouetteFit
    source : str
        What the first scale came from, for the note (``"tape"``, or ``"hub"`` for
        :func:`video.calibrate_scale.scale_from_hubs`).

    Returns
    -------
    ScaleComparison
        ``agree`` is False, with a note, when they differ by more than three combined
        sigmas.
    """
    diff = silhouette.m_per_px / tape_m_per_px - 1.0
    comb = float(np.hypot(tape_sigma, silhouette.sigma))
    n_sigma = abs(silhouette.m_per_px - tape_m_per_px) / comb if comb > 0 else float("inf")
    agree = n_sigma <= 3.0
    t_mm, s_mm = 1e3 * tape_m_per_px, 1e3 * silhouette.m_per_px
    if agree:
        note = (f"{source} and silhouette scales agree: {t_mm:.4f} and {s_mm:.4f} mm/px "
                f"({100 * diff:+.2f} %, {n_sigma:.1f} sigma)")
    else:
        note = (f"{source} and silhouette scales disagree: {source} {t_mm:.4f} +- {1e3 * tape_sigma:.4f} "
                f"mm/px, silhouette {s_mm:.4f} +- {1e3 * silhouette.sigma:.4f} mm/px "
                f"({100 * diff:+.2f} %, {n_sigma:.1f} sigma): the {source} may not lie in the "
                "plane of the outline (parallax) or the vehicle outline differs from this "
                f"car; the {source} scale is used")
    return ScaleComparison(float(tape_m_per_px), float(tape_sigma),
                           float(silhouette.m_per_px), float(silhouette.sigma), float(diff),
                           float(n_sigma), bool(agree), note)
