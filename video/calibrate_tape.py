"""Reference tapes: find checker tape(s) in a frame and measure the segment pitch.

A reference tape is a straight strip of alternating dark and light segments of known
length glued along the car's side. It is found as a chain of similar blobs (the
segments of one shade) with collinear, equally spaced centroids; its segment edges are
then located to sub-pixel along the tape's axis and the pitch is the slope of a line fit
of edge position against edge number.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from .calibrate_profile import find_edge, line_profile, sample, to_gray
from .detector import Candidates, Detector


@dataclass(frozen=True)
class Tape:
    """One reference tape found in a frame.

    Attributes
    ----------
    origin : (2,) px
        A point on the tape's centre line.
    axis : (2,) unit vector
        Direction of the tape (u, v), pointing along growing edge number.
    ends : (2, 2) px
        Image positions of the first and last segment edge on the centre line.
    width_px : float
        Tape width, px.
    edge_s : (n,) px
        Sub-pixel positions of the segment edges along ``axis`` from ``origin``.
    edge_index : (n,) int
        Edge number of each (consecutive edges differ by one segment).
    edge_points : (n, 2) px
        The edges' image positions on the centre line.
    centre_points : (m, 2) px
        Sub-pixel centres of segments measured across the tape (from its two long
        borders); they lie on a straight line unless the lens distorts.
    pitch_px, pitch_sigma_px : float
        Segment length in the image and its one-sigma uncertainty, px.
    rms_px : float
        RMS residual of the edge positions about the fitted uniform pitch, px.
    even_edge_sign : int
        Sign of the intensity change along ``axis`` at the even-numbered edges (the odd
        ones have the other sign).
    """

    origin: np.ndarray
    axis: np.ndarray
    ends: np.ndarray
    width_px: float
    edge_s: np.ndarray
    edge_index: np.ndarray
    edge_points: np.ndarray
    centre_points: np.ndarray
    pitch_px: float
    pitch_sigma_px: float
    rms_px: float
    even_edge_sign: int = 1


@dataclass(frozen=True)
class TapeSearch:
    """Settings of the tape search.

    Attributes
    ----------
    min_segments_per_shade : int
        Fewest segments of one shade in a chain (the tape then shows at least twice
        as many edges).
    min_area_px : float
        Smallest segment blob, px^2 (segments must be at least ~3 px long).
    block_sizes : tuple of int
        Neighbourhood sizes (px, odd) of the local thresholds that split the frame into
        dark and light blobs; several, so that tapes of any size are found.
    contrast : float
        Difference from the local mean (intensity levels) for a pixel to be dark/light.
    spacing_tolerance : float
        Allowed relative deviation of a centroid from its predicted position.
    min_amplitude : float
        Smallest difference between dark and light segments (intensity levels).
    """

    min_segments_per_shade: int = 4
    min_area_px: float = 8.0
    block_sizes: tuple = (15, 41, 101)
    contrast: float = 6.0
    spacing_tolerance: float = 0.12
    min_amplitude: float = 20.0


def _blobs(gray: np.ndarray, cfg: TapeSearch) -> list[tuple[np.ndarray, np.ndarray]]:
    """Dark and light blobs of every threshold scale: list of (centroids (M,2), areas)."""
    h, w = gray.shape
    out = []
    max_area = h * w / 50.0
    for bs in cfg.block_sizes:
        mean = cv2.blur(gray, (bs, bs), borderType=cv2.BORDER_REPLICATE)
        for mask in (gray < mean - cfg.contrast, gray > mean + cfg.contrast):
            n, _, stats, cent = cv2.connectedComponentsWithStats(mask.astype(np.uint8), 4)
            area = stats[1:, cv2.CC_STAT_AREA].astype(float)
            bw = stats[1:, cv2.CC_STAT_WIDTH].astype(float)
            bh = stats[1:, cv2.CC_STAT_HEIGHT].astype(float)
            fill = area / (bw * bh)
            ok = (area >= cfg.min_area_px) & (area <= max_area) & (fill >= 0.3)
            out.append((cent[1:][ok].astype(float), area[ok]))
    return out


def _chains(cent: np.ndarray, area: np.ndarray, cfg: TapeSearch) -> list[np.ndarray]:
    """Chains of similar blobs with collinear, equally spaced centroids (index arrays)."""
    m = len(cent)
    if m < cfg.min_segments_per_shade:
        return []
    tree = cKDTree(cent)
    ii, jj = _flatten(tree.query_ball_point(cent, 6.0 * np.sqrt(area)))
    if ii.size == 0:
        return []
    ratio = area[jj] / area[ii]
    keep = (jj > ii) & (ratio > 0.6) & (ratio < 1.67)
    if not keep.any():
        return []
    pairs = np.column_stack([ii[keep], jj[keep]])
    ci, cj = cent[pairs[:, 0]], cent[pairs[:, 1]]
    step = np.linalg.norm(cj - ci, axis=1)
    d, k = tree.query(2 * cj - ci)
    good = (d < cfg.spacing_tolerance * step) & (step > 0)
    # a pair with a similar blob between them skips it: not neighbours
    cand = np.flatnonzero(good)
    owner, q = _flatten(tree.query_ball_point(0.5 * (ci[cand] + cj[cand]), 0.4 * step[cand]))
    n = cand[owner]
    i, j = pairs[n, 0], pairs[n, 1]
    good[n[(q != i) & (q != j) & (0.6 < area[q] / area[j]) & (area[q] / area[j] < 1.67)]] = False
    good &= (area[k] / area[pairs[:, 1]] > 0.6) & (area[k] / area[pairs[:, 1]] < 1.67)
    used = np.zeros(m, bool)
    chains = []
    order = np.argsort(-area[pairs[:, 0]])
    for p in order[good[order]]:
        i, j = pairs[p]
        if used[i] or used[j] or used[k[p]]:
            continue
        chain = _grow(tree, cent, area, used, [i, j, int(k[p])], cfg)
        if len(chain) >= cfg.min_segments_per_shade:
            chain = np.array(chain)
            used[chain] = True
            chains.append(chain)
    return chains


def _flatten(lists) -> tuple[np.ndarray, np.ndarray]:
    """The members of n lists of indices (``cKDTree.query_ball_point``'s answer) one list
    after another, and the list each came from: (owner, member) int arrays."""
    lengths = np.fromiter(map(len, lists), dtype=int, count=len(lists))
    members = np.fromiter(itertools.chain.from_iterable(lists), dtype=int, count=int(lengths.sum()))
    return np.repeat(np.arange(len(lists)), lengths), members


def _grow(tree: cKDTree, cent: np.ndarray, area: np.ndarray, used: np.ndarray, chain: list,
          cfg: TapeSearch) -> list:
    """A chain of three blob indices (equally spaced centroids ``cent``, px) grown at both
    ends, one step at a time, by the unused blob of similar ``area`` (px^2) nearest to
    where the next step lands (one missing blob, clutter touching the tape, bridged)."""
    steps = {b: s for s, b in enumerate(chain)}
    for direction in (1, -1):
        while True:
            a, b = (chain[-2], chain[-1]) if direction == 1 else (chain[1], chain[0])
            st = cent[b] - cent[a]
            if abs(steps[a] - steps[b]) == 2:  # the last step bridged a gap
                st = st / 2
            dd, kk = tree.query(cent[b] + np.outer((1, 2), st))
            reach = cfg.spacing_tolerance * np.sqrt(st @ st)
            nxt = -1
            for jump in (1, 2):
                c = int(kk[jump - 1])
                if (dd[jump - 1] <= reach * jump and c not in chain and not used[c]
                        and 0.6 < area[c] / area[b] < 1.67):
                    steps[c] = steps[b] + direction * jump
                    nxt = c
                    break
            if nxt < 0:
                break
            if direction == 1:
                chain.append(nxt)
            else:
                chain.insert(0, nxt)
    return chain


def _fit_pitch(edge_s: np.ndarray, idx: np.ndarray) -> tuple[float, float, float, float]:
    """Least-squares ``s = a + p * idx + b * (-1)**idx``; returns (a, p, sigma_p, rms)."""
    alt = np.where(idx % 2 == 0, 1.0, -1.0)
    x = np.column_stack([np.ones_like(edge_s), idx.astype(float), alt])
    coef, *_ = np.linalg.lstsq(x, edge_s, rcond=None)
    res = edge_s - x @ coef
    dof = max(len(edge_s) - 3, 1)
    rms = float(np.sqrt(np.sum(res ** 2) / dof))
    # a floor for the per-edge noise: bilinear interpolation and pixel quantisation
    # leave ~0.02 px even on a perfect image
    s2 = max(rms, 0.02) ** 2
    cov = s2 * np.linalg.inv(x.T @ x)
    return float(coef[0]), float(coef[1]), float(np.sqrt(cov[1, 1])), rms


def _measure_chain(gray: np.ndarray, cent: np.ndarray, area: np.ndarray,
                   min_amplitude: float) -> Tape | None:
    """Sub-pixel edges, pitch and centre points of the tape a blob chain belongs to."""
    mean = cent.mean(axis=0)
    _, _, vt = np.linalg.svd(cent - mean)
    axis = vt[0] / np.linalg.norm(vt[0])
    if axis[0] < 0 or (abs(axis[0]) < 1e-9 and axis[1] < 0):
        axis = -axis
    normal = np.array([-axis[1], axis[0]])
    proj = (cent - mean) @ axis
    lateral = (cent - mean) @ normal
    order = np.argsort(proj)
    proj, lateral, area = proj[order], lateral[order], area[order]
    spacing = np.median(np.diff(proj))
    if spacing <= 0 or np.max(np.abs(lateral)) > 0.1 * spacing:
        return None
    seg = spacing / 2.0
    width = float(np.median(area)) / seg
    idx0 = np.round((proj - proj[0]) / spacing).astype(int)
    c0, spacing = np.polynomial.polynomial.polyfit(idx0, proj, 1)
    seg = spacing / 2.0
    step = 0.25
    reach = 4  # blobs searched beyond each end of the chain (a chain broken by clutter)
    s = np.arange(c0 - (reach + 1) * spacing, c0 + (idx0[-1] + reach + 1) * spacing + step,
                  step)
    offsets = np.linspace(-0.3, 0.3, max(3, int(0.6 * width) + 1)) * width
    prof = line_profile(gray, mean, axis, s, offsets)
    if np.isnan(prof).all():
        return None
    filled = np.nan_to_num(prof, nan=float(np.nanmean(prof)))
    # blobs are one shade; decide which from the profile at their centres
    at_blob = np.interp(proj, s, filled)
    between = np.interp((proj[:-1] + proj[1:]) / 2, s, filled)
    amplitude = abs(np.median(at_blob) - np.median(between))
    if amplitude < min_amplitude:
        return None
    dark = np.median(at_blob) < np.median(between)
    half = max(2, int(round(seg / 3 / step)))

    def edges_of(ik):
        out = []
        pk = c0 + ik * spacing
        for side in (-1, 1):
            # entering a dark blob the profile falls, leaving it rises
            sign = side if dark else -side
            centre = pk + side * seg / 2
            pos, st = find_edge(s, prof, sign, (centre - seg / 3, centre + seg / 3), half)
            out.append((pos, 2 * ik + (0 if side < 0 else 1), st))
        return out

    found = {}
    for ik in range(0, idx0[-1] + 1):
        for pos, ie, st in edges_of(ik):
            if np.isfinite(pos):
                found[ie] = (pos, st)
    if len(found) < 8:
        return None
    typical = np.median([v[1] for v in found.values()])
    for direction in (-1, 1):
        ik = 0 if direction < 0 else idx0[-1]
        for _ in range(reach):
            ik += direction
            ok = True
            for pos, ie, st in edges_of(ik):
                pred = c0 + (ie / 2.0 - 0.25) * spacing
                if np.isfinite(pos) and st > 0.5 * typical and abs(pos - pred) < seg / 6:
                    found[ie] = (pos, st)
                else:
                    ok = False
            if not ok:
                break
    index = np.array(sorted(found))
    edges = np.array([found[i][0] for i in index])
    strength = np.array([found[i][1] for i in index])
    if len(edges) < 8:
        return None
    keep = strength > 0.3 * np.median(strength)
    edges, index = edges[keep], index[keep]
    if len(edges) < 8:
        return None
    a, p, sp, rms = _fit_pitch(edges, index)
    # one pass of outlier rejection (an edge hidden by a target or a scratch)
    alt = np.where(index % 2 == 0, 1.0, -1.0)
    coef = np.linalg.lstsq(np.column_stack([np.ones_like(edges), index, alt]), edges,
                           rcond=None)[0]
    res = edges - (coef[0] + coef[1] * index + coef[2] * alt)
    mad = 1.4826 * np.median(np.abs(res - np.median(res)))
    ok = np.abs(res) <= max(5 * mad, 0.15)
    if ok.sum() >= 8 and ok.sum() < len(edges):
        edges, index = edges[ok], index[ok]
        a, p, sp, rms = _fit_pitch(edges, index)
    # a real tape's edges follow a smooth progression (uniform, or slowly varying under
    # lens distortion) to a small fraction of the pitch; clutter does not
    i_c = (index - index.mean()) / max(np.ptp(index), 1)
    alt = np.where(index % 2 == 0, 1.0, -1.0)
    x = np.column_stack([np.ones_like(i_c), i_c, i_c ** 2, i_c ** 3, alt])
    smooth = edges - x @ np.linalg.lstsq(x, edges, rcond=None)[0]
    rms_smooth = float(np.sqrt(np.sum(smooth ** 2) / max(len(edges) - 5, 1)))
    if rms_smooth > 0.02 * p + 0.1 or width < 1.5:
        return None
    pts = mean[None, :] + edges[:, None] * axis[None, :]
    cpts = _segment_centres(gray, mean, axis, edges, index, width)
    return Tape(even_edge_sign=-1 if dark else 1,
                origin=mean, axis=axis, ends=pts[[0, -1]], width_px=width, edge_s=edges,
                edge_index=index, edge_points=pts, centre_points=cpts, pitch_px=p,
                pitch_sigma_px=sp, rms_px=rms)


def _segment_centres(gray: np.ndarray, origin: np.ndarray, axis: np.ndarray,
                     edges: np.ndarray, index: np.ndarray, width: float) -> np.ndarray:
    """Sub-pixel centres (m, 2) px of the segments across the tape, from its two long
    borders, for the segments that stand out from what surrounds the tape (these lie on
    a straight line unless the lens distorts)."""
    normal = np.array([-axis[1], axis[0]])
    step = 0.25
    t = np.arange(-1.5 * width, 1.5 * width + step, step)
    cpts = []
    for e0, e1, i0, i1 in zip(edges[:-1], edges[1:], index[:-1], index[1:]):
        if i1 != i0 + 1:
            continue
        c = origin + 0.5 * (e0 + e1) * axis
        ln = min(0.6 * (e1 - e0), 0.6 * width)
        pr = line_profile(gray, c, normal, t, np.linspace(-0.5, 0.5, 5) * ln)
        if np.isnan(pr).any():
            continue
        inside = np.mean(pr[np.abs(t) < 0.25 * width])
        outside = np.mean(np.concatenate([pr[t < -width], pr[t > width]]))
        if abs(inside - outside) < 10.0:
            continue
        sg = 1 if inside > outside else -1  # the profile rises into a lighter segment
        lo, _ = find_edge(t, pr, sg, (-0.9 * width - 2, -0.1 * width))
        hi, _ = find_edge(t, pr, -sg, (0.1 * width, 0.9 * width + 2))
        if np.isfinite(lo) and np.isfinite(hi) and 0.5 * width < hi - lo < 1.5 * width:
            cpts.append(c + 0.5 * (lo + hi) * normal)
    return np.array(cpts).reshape(-1, 2)


def _alternates(gray: np.ndarray, cent: np.ndarray, min_amplitude: float) -> bool:
    """Quick test of a chain: are all its blobs of one shade and all the gaps between
    consecutive blobs of the other, by at least half ``min_amplitude``?"""
    order = np.argsort((cent - cent[0]) @ (cent[-1] - cent[0]))
    c = cent[order]
    at = sample(gray, c)
    gap = sample(gray, 0.5 * (c[1:] + c[:-1]))
    if np.isnan(at).any() or np.isnan(gap).any():
        return True  # near the border: let the full measurement decide
    half = 0.5 * min_amplitude
    return bool(at.max() < gap.min() - half or at.min() > gap.max() + half)


def _relation(a: Tape, b: Tape) -> str:
    """'same' (one strip found twice), 'pieces' (two stretches of one strip, e.g. split
    by a target stuck on it) or 'other'."""
    if abs(a.axis @ b.axis) < 0.99 or abs(b.pitch_px / a.pitch_px - 1) > 0.03:
        return "other"
    normal = np.array([-a.axis[1], a.axis[0]])
    if abs((b.origin - a.origin) @ normal) > max(a.width_px, b.width_px):
        return "other"
    sa = sorted((a.ends - a.origin) @ a.axis)
    sb = sorted((b.ends - a.origin) @ a.axis)
    return "same" if min(sa[1], sb[1]) > max(sa[0], sb[0]) else "pieces"


def _merge(a: Tape, b: Tape) -> Tape | None:
    """One tape from two collinear stretches: edges numbered on a common count, the
    pitch refitted over both (None if their edges do not fall on one uniform pitch)."""
    pts = np.concatenate([a.edge_points, b.edge_points])
    mean = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - mean, full_matrices=False)
    axis = vt[0] if vt[0] @ a.axis > 0 else -vt[0]
    sa, sb = (a.edge_points - mean) @ axis, (b.edge_points - mean) @ axis
    a0 = np.median(sa - a.pitch_px * a.edge_index)
    real = float(np.median((sb - a0) / a.pitch_px - b.edge_index))
    # the parity of an edge's number tells a rising from a falling edge: keep it
    sign_a = a.even_edge_sign * np.sign(a.axis @ axis)
    sign_b = b.even_edge_sign * np.sign(b.axis @ axis)
    parity = 0 if sign_a == sign_b else 1
    shift = int(np.floor(real))
    if shift % 2 != parity:
        shift = shift + 1 if abs(shift + 1 - real) < abs(shift - 1 - real) else shift - 1
    if abs(shift - real) > 0.5 + 0.25:
        return None
    idx = np.concatenate([a.edge_index, b.edge_index + shift])
    s = np.concatenate([sa, sb])
    idx, first = np.unique(idx, return_index=True)
    s = s[first]
    _, p, sp, rms = _fit_pitch(s, idx)
    if rms > max(3 * max(a.rms_px, b.rms_px), 0.05 * p):
        return None
    edge_points = mean + s[:, None] * axis
    return Tape(even_edge_sign=int(sign_a * np.sign(a.axis @ axis)) or 1,
                origin=mean, axis=axis, ends=edge_points[[0, -1]],
                width_px=0.5 * (a.width_px + b.width_px), edge_s=s, edge_index=idx,
                edge_points=edge_points,
                centre_points=np.concatenate([a.centre_points, b.centre_points]),
                pitch_px=p, pitch_sigma_px=sp, rms_px=rms)


class CheckerTapeDetector(Detector):
    """The reference tapes in a frame (:func:`find_tapes`), as a :class:`video.detector.Detector`.

    ``centres`` are the middles of the tapes' measured stretches; ``quality`` is
    ``1 - rms_px / QUALITY_RMS_PX``, the edges' scatter about an even pitch against half
    a pixel (edges that scattered, the pitch barely shows). ``found`` is the list of
    :class:`Tape`, longest first.
    """

    kind = "checker tape"
    QUALITY_RMS_PX = 0.5

    def __init__(self, search: TapeSearch = TapeSearch(), frame_index: int = 0):
        self.search, self.frame_index = search, frame_index

    def detect(self, frame: np.ndarray) -> Candidates:
        tapes = find_tapes(frame, frame_index=self.frame_index, search=self.search)
        return self._candidates([t.ends.mean(axis=0) for t in tapes],
                                [1.0 - t.rms_px / self.QUALITY_RMS_PX for t in tapes], tapes)


def find_tapes(frame: np.ndarray, *, frame_index: int = 0,
               search: TapeSearch = TapeSearch()) -> list[Tape]:
    """Find the reference tapes in a frame.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
        Grayscale or BGR image.
    frame_index : int
        Index of the frame in the film (for messages).
    search : TapeSearch
        Search settings.

    Returns
    -------
    list of Tape
        Longest first; empty if none.
    """
    gray = to_gray(frame, frame_index=frame_index)
    found: list[Tape] = []
    for cent, area in _blobs(gray, search):
        for chain in _chains(cent, area, search):
            if not _alternates(gray, cent[chain], search.min_amplitude):
                continue
            tape = _measure_chain(gray, cent[chain], area[chain], search.min_amplitude)
            if tape is None:
                continue
            for k, f in enumerate(found):
                rel = _relation(f, tape)
                if rel == "same":
                    if len(tape.edge_s) > len(f.edge_s):
                        found[k] = tape
                    break
                if rel == "pieces":
                    merged = _merge(f, tape)
                    if merged is not None:
                        found[k] = merged
                        break
            else:
                found.append(tape)
    found.sort(key=lambda t: -len(t.edge_s))
    return found
