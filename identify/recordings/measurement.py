"""The measured motion that every recording produces (film or sensors) and the fit reads.

A :class:`Measurement` is a set of channels sampled at times ``t`` (s, 0 = first contact),
each with a one-sigma uncertainty per sample (NaN where a sample was not measured). Channel
names and units:

| name | unit | meaning |
| --- | --- | --- |
| ``x_m`` | m | CG displacement from first contact, towards the barrier |
| ``z_m`` | m | CG displacement, up |
| ``pitch_rad`` | rad | pitch, nose-down positive |
| ``vx_mps`` | m/s | CG velocity towards the barrier |
| ``crush_m`` | m | front-end crush |
| ``front_wheel_angle_rad``, ``rear_wheel_angle_rad`` | rad | wheel spin, forward positive |
| ``engine_x_m`` | m | engine CG displacement from first contact, towards the barrier |
| ``engine_vx_mps`` | m/s | engine CG velocity towards the barrier |

Other channels may ride along (``force_N`` for a barrier's summed load cells); the fit uses
those it knows.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path

import numpy as np

from identify.errors import UserError
from video.report import LENGTH_SCALE_COLUMN

KNOWN_CHANNELS = {
    "x_m": "m",
    "z_m": "m",
    "pitch_rad": "rad",
    "vx_mps": "m/s",
    "crush_m": "m",
    "front_wheel_angle_rad": "rad",
    "rear_wheel_angle_rad": "rad",
    "front_wheel_height_m": "m",  # the hubs' rise above the path they rolled along: evidence, not fitted
    "rear_wheel_height_m": "m",
    "engine_x_m": "m",
    "engine_vx_mps": "m/s",
    "force_N": "N",
}



@dataclasses.dataclass(frozen=True)
class Measurement:
    """Measured motion of the car in a frontal barrier test.

    Attributes
    ----------
    t : (n,) s, 0 at first contact, increasing.
    channels : name -> (n,) values in the unit of ``KNOWN_CHANNELS``.
    sigma : name -> (n,) one-sigma uncertainty (same unit); NaN where not measured.
    impact_speed_mps : measured impact speed, or None.
    impact_speed_sigma : its one-sigma uncertainty (m/s), or None.
    contact_time_sigma : s, one-sigma uncertainty of t = 0 as the instant of first contact
        when the recording measures it apart from the fitted channels (a barrier's load
        cells, the front end seen stopping at the barrier in a film), or None (t = 0 found
        from the fitted motion itself).
    contact_time_s : s, that measured instant on the clock of ``t`` (t = 0 is the sample at
        or just after it, so it lies within one sample interval before 0); used with
        ``contact_time_sigma``.
    length_scale_sigma : relative one-sigma uncertainty of the scale every length of the
        recording was measured with (a film's tape or hub scale: one error common to all its
        lengths, which the fit carries as the nuisance ``length_scale``,
        ``identify.fitting.model.LENGTH_CHANNELS``), or None (sensors; lengths whose sigma
        already holds it). A length channel's ``sigma`` is then its noise alone.
    source : what the recording was (a file name), for reports.
    events_ms : events seen in the recording (e.g. ``front_wheel_block``), ms after contact.
    notes : things a person should read about the recording.
    derived : channels shown in plots but not fitted: computed from another channel of the
        same recording (a velocity differentiated from ``x_m``, a displacement integrated
        from ``vx_mps``), as their errors are not independent of their source's; or left out
        of the fit for a stated reason (a measured engine the cabin's motion does not bear
        out as a second body, ``identify.identification``).
    fitted_until_ms : channel -> ms after contact: the channel is fitted only up to then, its
        samples after it left out (sigma NaN) with a note (a wheel spinning on ahead of
        rolling, ``identify.fitting.wheel_spin``); result.json's ``fit.fitted_until_ms``.
    """

    t: np.ndarray
    channels: dict[str, np.ndarray]
    sigma: dict[str, np.ndarray]
    impact_speed_mps: float | None = None
    impact_speed_sigma: float | None = None
    contact_time_sigma: float | None = None
    contact_time_s: float = 0.0
    length_scale_sigma: float | None = None
    source: str = ""
    events_ms: dict[str, float] = dataclasses.field(default_factory=dict)
    notes: tuple[str, ...] = ()
    derived: tuple[str, ...] = ()
    fitted_until_ms: dict[str, float] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise UserError(f"{self.source or 'measurement'}: times must be a finite, increasing series")
        if set(self.channels) != set(self.sigma):
            raise UserError(f"{self.source or 'measurement'}: every channel needs a sigma and vice versa")
        for name, values in self.channels.items():
            if np.shape(values) != t.shape or np.shape(self.sigma[name]) != t.shape:
                raise UserError(f"{self.source or 'measurement'}: channel {name!r} has a different length than t")
            s = np.asarray(self.sigma[name], dtype=float)
            ok = np.isfinite(s)
            if np.any(s[ok] <= 0):
                raise UserError(f"{self.source or 'measurement'}: channel {name!r} has a sigma <= 0")
        if self.impact_speed_mps is not None and not (
            math.isfinite(self.impact_speed_mps) and self.impact_speed_mps > 0
        ):
            raise UserError(f"{self.source or 'measurement'}: impact speed must be > 0 m/s")
        if self.contact_time_sigma is not None and not (
            math.isfinite(self.contact_time_sigma) and self.contact_time_sigma > 0
        ):
            raise UserError(f"{self.source or 'measurement'}: the contact time's sigma must be > 0 s")
        if self.length_scale_sigma is not None and not (
            math.isfinite(self.length_scale_sigma) and self.length_scale_sigma > 0
        ):
            raise UserError(f"{self.source or 'measurement'}: the length scale's relative sigma must be > 0")
        object.__setattr__(self, "t", t)

    @property
    def fps(self) -> float:
        """Samples per second (median of the sample intervals)."""
        return float(1.0 / np.median(np.diff(self.t)))

    @property
    def measures_position(self) -> bool:
        """Whether the car's position x was measured (a film, its tracks), not integrated from
        accelerometers (a sensor recording) or absent."""
        return "x_m" in self.channels and "x_m" not in self.derived

    def valid(self, name: str) -> np.ndarray:
        """(n,) bool, True where channel ``name`` has a value and a finite sigma."""
        return np.isfinite(self.channels[name]) & np.isfinite(self.sigma[name])

    def window(self, t_min: float, t_max: float) -> "Measurement":
        """The samples with t_min <= t <= t_max (s)."""
        keep = (self.t >= t_min) & (self.t <= t_max)
        return dataclasses.replace(
            self,
            t=self.t[keep],
            channels={k: np.asarray(v)[keep] for k, v in self.channels.items()},
            sigma={k: np.asarray(v)[keep] for k, v in self.sigma.items()},
        )


def measurement_from_tracks_csv(path: Path, sigma_floor: float = 1e-4) -> Measurement:
    """Read a ``tracks.csv`` (``docs/interface.md``: ``t_ms`` first, channel columns, and
    ``<name>_sigma`` or ``<stem>_sigma_<unit>`` columns where the video stage wrote them).

    A channel without a sigma column gets ``sigma_floor`` in its unit: say so in notes. A
    ``length_scale_sigma`` column (the video stage's, one value) is the film's scale
    uncertainty (``Measurement.length_scale_sigma``).
    With both ``x_m`` and ``vx_mps``, the velocity is taken as derived from the displacement
    (as the video stage derives it) and not fitted; the engine's likewise.
    """
    path = Path(path)
    import io

    from sim._text import read_text

    text = read_text(path, "tracks file", error=UserError).removeprefix("\ufeff")  # Excel's byte-order mark
    try:
        rows = list(csv.reader(io.StringIO(text, newline="")))
    except csv.Error as err:
        raise UserError(f"{path}: not a CSV file ({err})") from None
    if len(rows) < 3 or not rows[0] or rows[0][0] != "t_ms":
        raise UserError(f"{path}: not a tracks.csv (its first column must be t_ms, with at least two rows)")
    header = rows[0]
    rows = [r for r in rows if r]  # blank lines
    short = next((i for i, r in enumerate(rows) if len(r) != len(header)), None)
    if short is not None:
        raise UserError(f"{path}: line {short + 1} has {len(rows[short])} values, the header names {len(header)} columns")
    try:
        data = np.array([[float(v) if v != "" else np.nan for v in r] for r in rows[1:]], dtype=float)
    except ValueError:
        raise UserError(f"{path}: a value is not a number") from None
    cols = {name: data[:, i] for i, name in enumerate(header)}
    channels, sigma, notes = {}, {}, []
    for name in KNOWN_CHANNELS:
        if name not in cols:
            continue
        stem, _, unit = name.rpartition("_")
        for sname in (f"{name}_sigma", f"{stem}_sigma_{unit}"):
            if sname in cols:
                sigma[name] = cols[sname]
                break
        else:
            sigma[name] = np.full(len(data), sigma_floor)
            notes.append(f"{name}: no sigma column, {sigma_floor:g} assumed")
        channels[name] = cols[name]
    derived = tuple(v for x, v in (("x_m", "vx_mps"), ("engine_x_m", "engine_vx_mps")) if {x, v} <= set(channels))
    scale_sigma = None
    if LENGTH_SCALE_COLUMN in cols:  # the video stage's: its lengths' sigmas are then their noise alone
        finite = cols[LENGTH_SCALE_COLUMN][np.isfinite(cols[LENGTH_SCALE_COLUMN])]
        scale_sigma = float(finite[0]) if len(finite) else None
    return Measurement(t=cols["t_ms"] / 1000.0, channels=channels, sigma=sigma, source=str(path), notes=tuple(notes),
                       derived=derived, length_scale_sigma=scale_sigma)
