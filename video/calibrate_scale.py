"""Scale in the car's plane (m/px) from the reference tapes of one frame."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .calibrate_lens import LensDistortion, estimate_lens, no_distortion, undistort_points
from .calibrate_profile import to_gray
from .calibrate_tape import Tape, TapeSearch, find_tapes, _fit_pitch
from .errors import VideoError


@dataclass(frozen=True)
class ScaleEstimate:
    """Metres per pixel in the car's side plane, from the reference tape(s).

    Attributes
    ----------
    m_per_px, sigma : float
        Scale and its one-sigma uncertainty, m/px. They apply to undistorted pixel
        coordinates (:func:`video.calibrate.undistort_points` with ``lens``) when
        ``lens.corrected``, else to the raw pixels.
    pitch_px, pitch_sigma_px : float
        Image length of one tape segment (combined over the tapes used), px.
    tape_segment_m : float
        The segment length given, m.
    tapes : tuple of Tape
        The tapes used (line, edge points, per-tape pitch).
    ignored : tuple of Tape
        Tapes found but not used (a different pitch: another segment length or plane).
    lens : LensDistortion
        Radial distortion estimated from the tapes' straightness.
    notes : tuple of str
        Sentences for the user.
    """

    m_per_px: float
    sigma: float
    pitch_px: float
    pitch_sigma_px: float
    tape_segment_m: float
    tapes: tuple
    ignored: tuple
    lens: LensDistortion
    notes: tuple

    @property
    def relative_sigma(self) -> float:
        """sigma / m_per_px (dimensionless)."""
        return self.sigma / self.m_per_px


def _pitch_undistorted(tape: Tape, lens: LensDistortion) -> tuple[float, float]:
    """Pitch of a tape (px, sigma) after removing the lens distortion from its edges."""
    pts = undistort_points(tape.edge_points, lens)
    m = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - m, full_matrices=False)
    s = (pts - m) @ vt[0]
    if np.corrcoef(s, tape.edge_index)[0, 1] < 0:
        s = -s
    _, p, sp, _ = _fit_pitch(s, tape.edge_index)
    return p, sp


def measure_scale(frame: np.ndarray, tape_segment_m: float, *, frame_index: int = 0,
                  focal_px: float | None = None, search: TapeSearch = TapeSearch(),
                  correct_lens: bool = True) -> ScaleEstimate:
    """Scale (m/px) in the car's plane from the checker tape(s) in a frame.

    Finds every reference tape (a straight strip of alternating dark and light
    segments, any direction, anywhere), locates its segment edges to sub-pixel along
    its axis and fits a uniform pitch to them; estimates radial lens distortion from
    the tapes' straightness and, when it is significant, measures the pitch on
    undistorted points.

    Parameters
    ----------
    frame : (H, W) or (H, W, 3) uint8
        A film frame (grayscale or BGR), usually the first.
    tape_segment_m : float
        Length of one tape segment, m (commonly 0.05 or 0.1).
    frame_index : int
        Index of the frame in the film, for messages.
    focal_px : float, optional
        Focal length in px if known (the lens model's normalising radius).
    search : TapeSearch
        Settings of the tape search.
    correct_lens : bool
        Estimate and correct radial distortion (default True).

    Returns
    -------
    ScaleEstimate

    Raises
    ------
    VideoError
        If the segment length is not a positive length or no tape is found.

    Examples
    --------
    >>> est = measure_scale(first_frame, 0.1)          # doctest: +SKIP
    >>> est.m_per_px, est.sigma                        # doctest: +SKIP
    (0.004, 2e-06)
    """
    if not (np.isfinite(tape_segment_m) and 0.001 <= tape_segment_m <= 2.0):
        raise VideoError(f"tape segment length {tape_segment_m!r} m makes no sense; give the "
                         "length of one tape segment in metres, e.g. --tape-segment 0.1")
    gray = to_gray(frame, frame_index=frame_index)
    h, w = gray.shape
    tapes = find_tapes(gray, frame_index=frame_index, search=search)
    if not tapes:
        raise VideoError(f"no reference tape found in frame {frame_index}: no straight strip "
                         "of 8 or more alternating dark/light segments; give the scale with "
                         "a checker tape in view in that frame (segments 3 px or longer)")
    notes = []
    ref = tapes[0].pitch_px
    used = [t for t in tapes if abs(t.pitch_px / ref - 1.0) < 0.05]
    ignored = [t for t in tapes if abs(t.pitch_px / ref - 1.0) >= 0.05]
    if ignored:
        notes.append(f"{len(ignored)} tape(s) with a different segment pitch ignored "
                     f"({', '.join(f'{t.pitch_px:.2f}' for t in ignored)} px vs {ref:.2f} px): "
                     "another segment length or another plane")
    if correct_lens:
        lens = estimate_lens([t.centre_points for t in used], (w, h), radius_px=focal_px)
    else:
        lens = no_distortion((w, h), "lens distortion not corrected (not requested)", focal_px)
    notes.append(lens.note)
    if lens.corrected:
        pitches = [_pitch_undistorted(t, lens) for t in used]
        # the uncertainty of k1 moves the undistorted edges: add its effect on the pitch
        shifted = replace(lens, k1=lens.k1 + lens.k1_sigma)
        pitches = [(p, float(np.hypot(sp, _pitch_undistorted(t, shifted)[0] - p)))
                   for (p, sp), t in zip(pitches, used)]
    else:
        pitches = [(t.pitch_px, t.pitch_sigma_px) for t in used]
    p = np.array([x[0] for x in pitches])
    sp = np.array([x[1] for x in pitches])
    wts = 1.0 / sp ** 2
    pitch = float(np.sum(wts * p) / np.sum(wts))
    psig = float(1.0 / np.sqrt(np.sum(wts)))
    if len(p) > 1:
        chi2 = float(np.sum(wts * (p - pitch) ** 2) / (len(p) - 1))
        if chi2 > 1.0:
            psig *= np.sqrt(chi2)
        if chi2 > 9.0:
            notes.append(f"the {len(p)} tapes disagree on the segment pitch "
                         f"({', '.join(f'{x:.3f}' for x in p)} px): are they all in the "
                         "car's plane and of the same segment length? uncertainty inflated")
    m_per_px = tape_segment_m / pitch
    sigma = m_per_px * psig / pitch
    return ScaleEstimate(m_per_px=m_per_px, sigma=sigma, pitch_px=pitch, pitch_sigma_px=psig,
                         tape_segment_m=float(tape_segment_m), tapes=tuple(used),
                         ignored=tuple(ignored), lens=lens, notes=tuple(notes))
