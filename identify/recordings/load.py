"""From a file the user names to a :class:`~identify.recordings.measurement.Measurement`.

What the path is decides the reader:

- a video file (MP4, AVI, MOV, ...) or a folder of numbered frames: the video stage
  (``video.io.open_film`` -> ``video.track.track_film``);
- a ``tracks.csv`` written by ``identify track`` (or by hand): read as it is;
- a sensor recording, NHTSA's EV5 export or ISO-MME (``identify.recordings``): the
  vehicle's accelerometers integrated to motion; its barrier load cells stay out of the
  measurement (they are the independent check of ``identify.report.force_check``).

The result keeps what the reports need besides the measurement: the tracks of a film
(scale, contact frame, overlay) and the film itself.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from identify.errors import UserError
from identify.recordings.measurement import KNOWN_CHANNELS, Measurement, measurement_from_tracks_csv


@dataclasses.dataclass
class Recording:
    """A recording read for fitting.

    measurement : the motion the fit uses.
    kind : "film", "tracks", "sensors".
    path : the file or folder given.
    tracks : video.types.Tracks for a film, else None.
    film : the opened video.io.Film for a film (frames for the overlay plots), else None.
    sensor_test : identify.recordings.SensorTest of a sensor recording, else None.
    """

    measurement: Measurement
    kind: str
    path: Path
    tracks: object = None
    film: object = None
    sensor_test: object = None


def measurement_from_tracks(tracks, source: str) -> Measurement:
    """The fit's view of a film's tracks: the known channels with their sigmas; the
    measured impact speed rides along (its uncertainty comes from the approach frames,
    which the fit sees itself, so it enters without a prior); first contact enters as a
    measurement when the picture showed it (the front end stopping at the barrier, apart
    from the fitted motion), not when it came from the motion's deceleration onset. The
    scale's uncertainty is one error common to every length (``Measurement.length_scale_sigma``),
    the length channels' sigmas their noise alone."""
    channels = {k: np.asarray(v, float) for k, v in tracks.channels.items() if k in KNOWN_CHANNELS}
    sigma = {k: np.asarray(tracks.sigma[k], float) for k in channels}
    speed = float(tracks.impact_speed_mps) if np.isfinite(tracks.impact_speed_mps) else None
    events = {k: float(v) for k, v in tracks.events_ms.items() if v is not None}
    return Measurement(
        t=np.asarray(tracks.t, float),
        channels=channels,
        sigma=sigma,
        impact_speed_mps=speed,
        contact_time_sigma=tracks.contact_sigma_s,
        contact_time_s=float(tracks.contact_offset_s) if tracks.contact_sigma_s else 0.0,
        length_scale_sigma=float(tracks.scale_sigma / tracks.scale_m_per_px),
        source=source,
        events_ms=events,
        notes=tuple(tracks.notes),
        derived=("vx_mps",) if "vx_mps" in channels and "x_m" in channels else (),
    )


def load_recording(
    path: str | Path,
    car_geometry,
    fps: float | None = None,
    tape_segment_m: float = 0.1,
    speed_mps: float | None = None,
    progress=None,
) -> Recording:
    """Read a recording: a film (file or frame folder) or a tracks.csv.

    Parameters
    ----------
    path : the file or folder.
    car_geometry : video.types.CarGeometry of the vehicle (for the video stage).
    fps : the true frame rate if the container's is wrong.
    tape_segment_m : m, length of one reference-tape segment.
    speed_mps : impact speed if known (the video stage then only compares its own).
    progress : ``progress(done, total, stage)`` or None.

    Raises
    ------
    UserError / video.errors.VideoError
        Missing path, unknown kind of file, or what the reader finds wrong.
    """
    path = Path(path)
    if not path.exists():
        raise UserError(f"{path} does not exist")
    if path.is_file() and path.suffix.lower() == ".csv":
        return Recording(measurement_from_tracks_csv(path), "tracks", path)
    from identify.recordings import is_recording, measurement_from_test, read_recording

    if is_recording(path):
        test = read_recording(path, progress=progress)
        measurement = measurement_from_test(test)
        # displacements are integrated from the velocities: plotted, not fitted twice
        derived = tuple(n for n in ("x_m", "engine_x_m") if n in measurement.channels)
        measurement = dataclasses.replace(measurement, derived=derived)
        return Recording(measurement, "sensors", path, sensor_test=test)
    from video.io import VIDEO_SUFFIXES, open_film  # the one list of film formats the video stage opens

    if path.is_dir() or path.suffix.lower() in VIDEO_SUFFIXES:
        from video.track import track_film

        film = open_film(path, fps=fps)
        tracks = track_film(film, car_geometry, tape_segment_m=tape_segment_m, speed_mps=speed_mps, progress=progress)
        film.close()  # the fit runs without the frames the opening scan kept; the report decodes the few it draws
        return Recording(measurement_from_tracks(tracks, str(path)), "film", path, tracks=tracks, film=film)
    raise UserError(
        f"{path}: not a recording this tool reads (a video file {', '.join(sorted(VIDEO_SUFFIXES))},"
        " a folder of numbered frames, a tracks.csv, an NHTSA .EV5 header or an ISO-MME .mme file)"
    )
