"""Scale in the car's plane (m/px) from the reference tapes of one frame."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .calibrate_lens import LensDistortion, estimate_lens, no_distortion, plausible_k1, undistort_points
from .calibrate_perspective import estimate_tilt
from .calibrate_profile import sample, to_gray
from .calibrate_tape import CheckerTapeDetector, Tape, TapeSearch, _fit_pitch
from .errors import NoTapeError, VideoError


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
    source : str
        What the scale was taken from: ``"checker tape"`` (the tape's segments:
        ``pitch_px`` is one segment's image length, ``tape_segment_m`` its length) or
        ``"hub targets and wheelbase"`` (:func:`scale_from_hubs`: ``pitch_px`` is the hub
        targets' image distance, ``tape_segment_m`` the vehicle file's wheelbase; no tape).
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
    source: str = "checker tape"

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


def _combined_pitch(pitches) -> tuple[float, float, np.ndarray, float]:
    """The tapes' segment pitches ((px, sigma) each) combined: (inverse-variance mean px, its
    sigma widened by the reduced chi-square when the tapes disagree beyond their sigmas, the
    weights, that reduced chi-square (0 for one tape))."""
    p = np.array([x[0] for x in pitches])
    wts = 1.0 / np.array([x[1] for x in pitches]) ** 2
    pitch = float(np.sum(wts * p) / np.sum(wts))
    psig = float(1.0 / np.sqrt(np.sum(wts)))
    chi2 = float(np.sum(wts * (p - pitch) ** 2) / (len(p) - 1)) if len(p) > 1 else 0.0
    return pitch, psig * math.sqrt(max(chi2, 1.0)), wts, chi2


def measure_scale(frame: np.ndarray, tape_segment_m: float, *, frame_index: int = 0,
                  focal_px: float | None = None, search: TapeSearch = TapeSearch(),
                  correct_lens: bool = True, correct_yaw: bool = True,
                  later_frames: list | None = None) -> ScaleEstimate:
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
    correct_yaw : bool
        Estimate and correct a camera yawed against the car's plane
        (:mod:`video.calibrate_perspective`; default True).
    later_frames : list of (H, W) or (H, W, 3) uint8, optional
        Frames after the car has moved (:func:`tapes_on_the_car`): a "tape" that stood
        still is the background's (a wall's grid makes chains of "segments"), not the
        car's, and is not used.

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
    found = CheckerTapeDetector(search, frame_index).detect(gray)
    tapes = found.found
    if not tapes:
        raise NoTapeError(f"no reference tape found in frame {frame_index}: no straight strip "
                         "of 8 or more alternating dark/light segments; give the scale with "
                         "a checker tape in view in that frame (segments 3 px or longer)")
    notes = []
    if later_frames:
        tapes, quality, note = tapes_on_the_car(tapes, found.quality, gray, later_frames, frame_index)
        if note:
            notes.append(note)
        if not tapes:
            raise NoTapeError(f"no reference tape on the car in frame {frame_index}: {note}")
    else:
        quality = found.quality
    # the tapes that agree on a pitch (within 5 %) with the most well-measured edges: a wall's
    # grid behind the car makes chains of "segments" too, longer at times, but their edges
    # scatter about an even pitch (quality, CheckerTapeDetector) where a tape's do not
    support = quality * np.array([len(t.edge_s) for t in tapes])
    pitch_of = np.array([t.pitch_px for t in tapes])
    agree = np.abs(pitch_of[None, :] / pitch_of[:, None] - 1.0) < 0.05
    ref = pitch_of[int(np.argmax(agree @ support))]
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
    # what the camera's map is not known to better than moves each tape's pitch: the
    # radial term's and the tilt's sigmas, corrected or not (an insignificant k1 or tilt
    # is left uncorrected, but it may be there)
    shifted = []
    if np.isfinite(lens.k1_sigma) and lens.k1_sigma > 0:
        # where the tapes cannot tell k1, what a crash camera's lens plausibly has
        shifted.append(replace(lens, k1=lens.k1 + min(lens.k1_sigma, plausible_k1(lens.radius_px, lens.centre)),
                               corrected=True))
    if correct_yaw:
        # a camera yawed against the car's plane: the tapes' segments evenly spaced
        yaw = estimate_tilt([(undistort_points(t.edge_points, lens), t.edge_index) for t in used], lens.centre)
        notes.append(yaw.note)
        if np.any(yaw.tilt != 0.0):
            lens = replace(lens, tilt=yaw.tilt, corrected=True)
            shifted = [replace(x, tilt=yaw.tilt) for x in shifted]
        if np.any(yaw.sigma_vector != 0.0):
            shifted.append(replace(lens, tilt=lens.tilt + yaw.sigma_vector, corrected=True))
    if lens.corrected:
        pitches = [_pitch_undistorted(t, lens) for t in used]
    else:
        pitches = [(t.pitch_px, t.pitch_sigma_px) for t in used]
    pitch, psig, wts, chi2 = _combined_pitch(pitches)
    if chi2 > 9.0:
        notes.append(f"the {len(pitches)} tapes disagree on the segment pitch "
                     f"({', '.join(f'{x[0]:.3f}' for x in pitches)} px): are they all in the "
                     "car's plane and of the same segment length? uncertainty inflated")
    # the map's uncertainty moves every tape's pitch together: the same combination of the
    # pitches measured through each shifted map, against the one through the map used
    if shifted:
        def combined(m):
            return float(np.sum(wts * np.array([_pitch_undistorted(t, m)[0] for t in used])) / np.sum(wts))

        base = combined(lens)
        psig = float(np.sqrt(psig ** 2 + sum((combined(x) - base) ** 2 for x in shifted)))
    m_per_px = tape_segment_m / pitch
    sigma = m_per_px * psig / pitch
    return ScaleEstimate(m_per_px=m_per_px, sigma=sigma, pitch_px=pitch, pitch_sigma_px=psig,
                         tape_segment_m=float(tape_segment_m), tapes=tuple(used),
                         ignored=tuple(ignored), lens=lens, notes=tuple(notes))


def rescaled(est: ScaleEstimate, lens: LensDistortion, k1_sigma: float = 0.0,
             tilt_sigma: np.ndarray = np.zeros(2), note: str = "") -> ScaleEstimate:
    """The tapes' scale measured again through another map of the camera (``lens``, e.g.
    :func:`video.calibrate_motion.map_from_approach`'s): each tape's pitch on its edges
    undistorted by ``lens``, combined as :func:`measure_scale` does; the map's one-sigma
    (``k1_sigma``, ``tilt_sigma`` per component) moves every tape's pitch together and is
    added to the pitch's sigma. An estimate without tapes (the hubs' scale) is returned
    with only its lens replaced."""
    if not est.tapes:
        return replace(est, lens=lens, notes=est.notes + ((note,) if note else ()))
    pitch, psig, wts, _ = _combined_pitch([_pitch_undistorted(t, lens) for t in est.tapes])
    shifted = []
    if np.isfinite(k1_sigma) and k1_sigma > 0:
        shifted.append(replace(lens, k1=lens.k1 + k1_sigma))
    for i in range(2):
        if np.isfinite(tilt_sigma[i]) and tilt_sigma[i] > 0:
            shifted.append(replace(lens, tilt=lens.tilt + np.eye(2)[i] * tilt_sigma[i]))
    for m in shifted:
        other = float(np.sum(wts * np.array([_pitch_undistorted(t, m)[0] for t in est.tapes])) / np.sum(wts))
        psig = float(np.hypot(psig, other - pitch))
    m_per_px = est.tape_segment_m / pitch
    return replace(est, m_per_px=m_per_px, sigma=m_per_px * psig / pitch, pitch_px=pitch, pitch_sigma_px=psig,
                   lens=lens, notes=est.notes + ((note,) if note else ()))


#: Largest change along a tape's centre line between frame 0 and a later frame (the mean
#: over the line), as a share of its dark-to-light contrast, for it to have stood still
#: (noise and compression change a few grey levels; a tape carried by a share q of its
#: pattern's period, q up to a half, changes by 2 q of its contrast; the median would miss
#: a shift under a quarter period, which changes less than half the line).
STILL_SHARE = 0.15


def tapes_on_the_car(tapes: list, quality: np.ndarray, frame0: np.ndarray, later: list,
                     frame_index: int = 0) -> tuple[list, np.ndarray, str]:
    """The tapes of ``frame0`` that the ``later`` frames show moved.

    A reference tape is on the car, which moves; a wall's grid or a pattern behind the car
    can make a chain of "segments" the tape detector takes for a tape (on reference world
    960429 a 32 px chain across a grid set the scale 69 % off). Where a tape stood still,
    its centre line shows the same greys in a later frame (within :data:`STILL_SHARE` of
    its contrast, the mean over the line); one carried by the car shows another phase of
    its pattern there, or the car's body. Three later frames, so a car that moved by about
    a whole period of the pattern in one (0.2 m in 13 ms at 55 km/h for 0.1 m segments) is
    not taken for still. Returns (the tapes kept,
    their qualities, a note or "")."""
    g0 = to_gray(frame0, frame_index=frame_index)
    grays = [to_gray(f, frame_index=frame_index) for f in later]

    def still(t) -> bool:
        # the tape's centre line, a sample a pixel, from its first edge to its last
        p0, p1 = t.edge_points[0], t.edge_points[-1]
        line = p0 + np.linspace(0.0, 1.0, max(int(np.hypot(*(p1 - p0))), 2))[:, None] * (p1 - p0)
        a = sample(g0, line)
        ok = np.isfinite(a)
        if ok.sum() < 8:
            return False
        contrast = float(np.percentile(a[ok], 90) - np.percentile(a[ok], 10))
        return all(float(np.nanmean(np.abs(sample(g, line)[ok] - a[ok]))) < STILL_SHARE * contrast
                   for g in grays)

    fixed = np.array([still(t) for t in tapes], bool)
    if not fixed.any():
        return tapes, quality, ""
    kept = [t for t, f in zip(tapes, fixed) if not f]
    note = (f"{int(fixed.sum())} tape-like pattern(s) stand still while the car moves "
            f"({', '.join(f'{t.pitch_px:.2f} px pitch' for t, f in zip(tapes, fixed) if f)}): the "
            "background's, not the car's; not used")
    return kept, quality[~fixed], note


#: How far a test car's distance between its hub centres may stand from the vehicle file's
#: wheelbase, m (a database value of the model, not a survey of this car; suspension
#: geometry at test mass moves it by a few mm).
WHEELBASE_SIGMA_M = 0.005

#: The hub targets' plane against the car side's, as a share of the scale: a target on a
#: hub cap sits some 5-6 cm inboard of the body side the tapes and body targets lie on, so
#: at a camera distance of about 10 m its image is ~0.6 % smaller (the scale comes out that
#: much too large). The distance is not known without a tape, so this is a sigma, not a
#: correction.
HUB_PLANE_REL_SIGMA = 0.006


def scale_from_spin(t: np.ndarray, centre_u_px: np.ndarray, angle_rad: np.ndarray, wheel_radius_m: float) -> float:
    """Scale (m/px) a freely rolling wheel implies: its hub travels ``wheel_radius_m`` times
    its spin (rad/s) per second, and its image centre ``|du/dt|`` px/s over the same frames
    (straight-line fits). A free wheel rolls on a radius a few per cent under the vehicle
    file's unloaded one, so this checks a scale rather than measures it; it depends on no
    tape and not on the wheelbase.

    Parameters
    ----------
    t : (n,) s
        Frame times (the approach: before contact).
    centre_u_px, angle_rad : (n,)
        The hub target's image column, px, and its pattern's unwrapped orientation, rad
        (NaN where not seen).
    wheel_radius_m : float
        The vehicle file's wheel radius, m.

    Returns
    -------
    float
        m/px; NaN with fewer than 5 frames seen or a hub that does not move.
    """
    ok = np.isfinite(centre_u_px) & np.isfinite(angle_rad) & np.isfinite(t)
    if ok.sum() < 5:
        return float("nan")
    spin = abs(np.polyfit(t[ok], angle_rad[ok], 1)[0])
    speed = abs(np.polyfit(t[ok], centre_u_px[ok], 1)[0])
    return float(wheel_radius_m * spin / speed) if speed > 0 else float("nan")


def scale_from_hubs(spacing_px: float, spacing_sigma_px: float, wheelbase_m: float,
                    lens: LensDistortion, why: str = "no tape being in view") -> ScaleEstimate:
    """Scale (m/px) in the car's plane from the hub targets' image distance and the
    vehicle's wheelbase, for a film without a reference tape.

    Parameters
    ----------
    spacing_px, spacing_sigma_px : float
        The front and rear hub targets' centre distance over the approach (before
        contact: the wheelbase is not yet crushed) and its one-sigma, px.
    wheelbase_m : float
        The vehicle file's wheelbase, m.
    lens : LensDistortion
        The lens model the centres were taken through (without a tape: none measured).
    why : str
        Why the scale is not the tape's, for the note.

    Returns
    -------
    ScaleEstimate
        ``source="hub targets and wheelbase"``; its sigma combines the spacing's, the
        wheelbase's (:data:`WHEELBASE_SIGMA_M`) and the hub plane's offset from the car
        side (:data:`HUB_PLANE_REL_SIGMA`).

    Raises
    ------
    VideoError
        A spacing or wheelbase that is not a positive length.
    """
    if not (np.isfinite(spacing_px) and spacing_px > 0 and np.isfinite(wheelbase_m) and wheelbase_m > 0):
        raise VideoError(f"cannot take the scale from the hub targets: their distance {spacing_px!r} px "
                         f"or the wheelbase {wheelbase_m!r} m is not a positive length")
    m_per_px = wheelbase_m / spacing_px
    rel = float(np.sqrt((spacing_sigma_px / spacing_px) ** 2 + (WHEELBASE_SIGMA_M / wheelbase_m) ** 2
                        + HUB_PLANE_REL_SIGMA ** 2))
    note = (f"scale {1e3 * m_per_px:.4f} +- {1e3 * m_per_px * rel:.4f} mm/px ({100 * rel:.2f} %) from the "
            f"hub targets' distance before contact ({spacing_px:.2f} px) and the vehicle file's wheelbase "
            f"({wheelbase_m:.3f} m), {why}: the sigma counts the hubs' plane a few cm inboard "
            f"of the car's side ({100 * HUB_PLANE_REL_SIGMA:.1f} %); the film's wheelbase cannot check the "
            "vehicle file (it set the scale), its outline's length still does")
    return ScaleEstimate(m_per_px=float(m_per_px), sigma=float(m_per_px * rel), pitch_px=float(spacing_px),
                         pitch_sigma_px=float(spacing_sigma_px), tape_segment_m=float(wheelbase_m), tapes=(),
                         ignored=(), lens=lens, notes=(note,), source="hub targets and wheelbase")
