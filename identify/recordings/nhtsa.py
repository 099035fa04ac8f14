"""NHTSA's "EV5 ASCII X-Y" export of a vehicle crash test.

A test is a header ``vNNNNN.EV5`` and one file a channel, ``vNNNNN.CCC`` (CCC = curve
number, 3 digits or more), two tab-separated columns: time (s) and the value in the
header's units.

The header is a set of sections, each opened by a line ``----- NAME -----`` (``EV5``,
``TEST``, ``VEHICLE``, ``BARRIER``, ``OCCUPANT``, ``RESTRAINT``, ``INSTRUMENTATION``,
``END``); ``#`` lines are comments; a row's fields are separated by ``|``. Fields read here
(1-based):

- TEST: 2 title, 15 closing speed (km/h).
- VEHICLE: 1 vehicle number, 11 test mass (kg), 42 impact speed (km/h).
- INSTRUMENTATION, one row a channel: 1 vehicle number (0 = barrier), 2 curve number,
  3 sensor type (AC accelerometer, LC load cell, ...), 4 occupant location (NA for the
  structure), 5 sensor attachment (FLLR/FLRR left/right rear-seat crossmember, ENGN engine,
  LCxxxx a barrier load cell, ...), 6 axis (XG/XL = X global/local, ...), 7 time units,
  8 value units (G'S, NWT, ...), 15 first sample and 16 last sample (integers, in units of
  field 17), 17 sample interval (microseconds), 18 data status (AM = as measured; CF with a
  comment "No valid data ..." = failed; NO = not installed), 19 P primary / R redundant,
  20 description. Other fields are kept as text in :attr:`Ev5Channel.fields`.

Sign conventions of the export: vehicle X accelerations are positive forward (the crash
pulse is negative), which is this package's x; barrier load cells read compression as
negative Fx, which the reader turns into a positive force. Engine X accelerometers
(attachment ENGN) use the vehicle's convention.

Data status. ``AM`` (as measured) is the only status whose data are used whole
(``VALID_STATUS``). ``CF`` is NHTSA's "channel failed": the lab found the sensor's data
wrong from some time on, and says from when in the row's description. ``"No valid data"``
alone means none is usable (the barrier's curves 347 and 500 of test 10146 have no file at
all); ``"No valid data after 67ms"`` means the samples before 67 ms are good and the lab cut
the file there (curve 96 of 10146: the header's last sample is 669, i.e. 66.9 ms, and the
file holds exactly those 1170 samples). Vehicle-motion channels must be ``AM``: they are
averaged over the whole recording, and a crossmember channel that stops at 67 ms could not
be. An engine channel marked ``CF`` with "No valid data after N ms" is used up to N ms
(``Ev5Channel.valid_until_s``; samples after N ms are dropped if the file has any), like a
channel that simply ends early: ``identify.recordings.motion.usable_engine_channels`` then
skips it when another engine channel covers the recording, and otherwise the engine's
motion is measured until N ms only.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from identify.errors import UserError
from sim._text import read_text
from identify.recordings.motion import G0, Channel, SensorTest, usable_engine_channels

__all__ = ["Ev5Channel", "Ev5Header", "read_ev5_header", "load_ev5_channel",
           "vehicle_motion_channels", "engine_channels", "barrier_force_channels", "read_nhtsa",
           "MOTION_ATTACHMENTS", "ENGINE_ATTACHMENTS", "VALID_STATUS"]

# Sensor attachments whose X acceleration is the motion of the rigid passenger cell.
MOTION_ATTACHMENTS = {
    "FLLR": "left rear-seat crossmember",
    "FLRR": "right rear-seat crossmember",
    "VECG": "vehicle CG",
    "CGCG": "vehicle CG",
}
# Sensor attachments whose X acceleration is the engine's (the second measured body).
ENGINE_ATTACHMENTS = {"ENGN": "engine"}
VALID_STATUS = ("AM",)
FAILED_AFTER = re.compile(r"no valid data after\s*([0-9]+(?:\.[0-9]*)?)\s*ms", re.IGNORECASE)
UNIT_SCALE = {"G'S": ("acceleration", G0), "MPS2": ("acceleration", 1.0),
              "NWT": ("force", 1.0), "KN": ("force", 1e3)}


@dataclass(frozen=True)
class Ev5Channel:
    """One INSTRUMENTATION row of an EV5 header.

    Attributes
    ----------
    vehicle : int
        Test-object number (1 = the vehicle, 0 = the barrier).
    curve : int
        Curve number, the channel file's extension.
    sensor_type, location, attachment, axis, units : str
        Fields 3, 4, 5, 6 and 8 as written (``AC``, ``NA``, ``FLLR``, ``XG``, ``G'S``).
    first_sample, last_sample : int
        Index of the first and last sample (time = index * dt).
    dt : float
        Sample interval, s.
    status : str
        Data status (``AM`` as measured; anything else is not used).
    primary : bool
        False for a redundant sensor (``R``).
    description : str
        Field 20.
    fields : tuple of str
        The whole row.
    """

    vehicle: int
    curve: int
    sensor_type: str
    location: str
    attachment: str
    axis: str
    units: str
    first_sample: int
    last_sample: int
    dt: float
    status: str
    primary: bool
    description: str
    fields: tuple[str, ...]

    @property
    def valid(self) -> bool:
        """True when the header marks the data as usable."""
        return self.status in VALID_STATUS

    @property
    def valid_until_s(self) -> float | None:
        """Until when the data are usable, s on the recording's clock: ``inf`` for a valid
        status; N ms for a ``CF`` row whose description says "No valid data after N ms";
        None (nothing usable) otherwise. See the module's notes on data status."""
        if self.valid:
            return float("inf")
        m = FAILED_AFTER.search(self.description)
        if self.status == "CF" and m:
            return float(m.group(1)) * 1e-3
        return None

    @property
    def n_samples(self) -> int:
        """Number of samples the header announces."""
        return self.last_sample - self.first_sample + 1

    def label(self) -> str:
        """``curve 93 (LEFT REAR SEAT CROSSMEMBER X)``, for messages."""
        return f"curve {self.curve} ({self.description})"


@dataclass(frozen=True)
class Ev5Header:
    """What an EV5 header says about a test.

    Attributes
    ----------
    path : Path
        The ``.EV5`` file.
    title : str
    speed_kmh : float
        Impact speed, km/h (the vehicle's, else the test's closing speed).
    mass_kg : float or None
        Test mass of vehicle 1, kg.
    channels : tuple of Ev5Channel
        Every INSTRUMENTATION row, in file order.
    """

    path: Path
    title: str
    speed_kmh: float
    mass_kg: float | None
    channels: tuple[Ev5Channel, ...]

    def channel_path(self, ch: Ev5Channel) -> Path:
        """File of channel ``ch``: the header's stem with the curve number as extension."""
        return self.path.with_suffix(f".{ch.curve:03d}")


def _sections(lines: list[str], path: Path) -> dict[str, list[list[str]]]:
    out: dict[str, list[list[str]]] = {}
    current = None
    for line in lines:
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        m = re.fullmatch(r"-{3,}\s*([A-Z0-9 ]+?)\s*-{3,}", s)
        if m:
            current = m.group(1)
            out.setdefault(current, [])
            continue
        if current is None:
            raise UserError(f"{path}: not an EV5 header (no '----- SECTION -----' line before data)")
        out[current].append(s.split("|"))
    return out


def _float(text: str, what: str, path: Path) -> float:
    try:
        value = float(text)
    except ValueError:
        raise UserError(f"{path}: {what} is {text!r}, not a number") from None
    if not np.isfinite(value):
        raise UserError(f"{path}: {what} is {text!r}, not a finite number")
    return value


def _channel_row(row: list[str], path: Path, lineno: int) -> Ev5Channel:
    if len(row) < 20:
        raise UserError(f"{path}: INSTRUMENTATION row {lineno} has {len(row)} fields, an EV5 channel row has 20")
    try:
        ch = Ev5Channel(
            vehicle=int(row[0]), curve=int(row[1]), sensor_type=row[2].strip(),
            location=row[3].strip(), attachment=row[4].strip(), axis=row[5].strip(),
            units=row[7].strip(), first_sample=int(row[14]), last_sample=int(row[15]),
            dt=float(row[16]) * 1e-6, status=row[17].strip(), primary=row[18].strip() != "R",
            description=row[19].strip(), fields=tuple(row))
    except ValueError:
        raise UserError(
            f"{path}: INSTRUMENTATION row {lineno} ({'|'.join(row[:6])}...) has a non-numeric "
            f"vehicle, curve, sample or interval field") from None
    if not (np.isfinite(ch.dt) and ch.dt > 0) or ch.curve < 0 or ch.n_samples < 1:
        raise UserError(f"{path}: INSTRUMENTATION row {lineno} ({'|'.join(row[:6])}...) needs a positive sample "
                        "interval, a curve number >= 0 and last sample >= first sample")
    return ch


def read_ev5_header(path: str | Path) -> Ev5Header:
    """Parse an EV5 header.

    Parameters
    ----------
    path : str or Path
        The ``.EV5`` file.

    Returns
    -------
    Ev5Header
    """
    path = Path(path)
    text = read_text(path, "EV5 header", encoding="latin-1", error=UserError)
    sec = _sections(text.splitlines(), path)
    for name in ("TEST", "INSTRUMENTATION"):
        if not sec.get(name):
            raise UserError(f"{path}: not an EV5 header (no {name} section)")
    test = sec["TEST"][0]
    title = test[1].strip() if len(test) > 1 else ""
    speed = None
    mass = None
    for row in sec.get("VEHICLE", []):
        if row and row[0].strip() == "1":
            if len(row) > 10 and row[10].strip():
                mass = _float(row[10], "the test mass (VEHICLE field 11)", path)
            if len(row) > 41 and row[41].strip():
                speed = _float(row[41], "the impact speed (VEHICLE field 42)", path)
    if not speed and len(test) > 14:
        speed = _float(test[14], "the closing speed (TEST field 15)", path)
    if not speed or speed <= 0:
        raise UserError(f"{path}: the header gives no impact speed (VEHICLE field 42 or TEST field 15)")
    channels = tuple(_channel_row(r, path, i + 1) for i, r in enumerate(sec["INSTRUMENTATION"]))
    return Ev5Header(path=path, title=title, speed_kmh=speed, mass_kg=mass, channels=channels)


def load_ev5_channel(header: Ev5Header, ch: Ev5Channel) -> tuple[np.ndarray, np.ndarray]:
    """Read one channel file and check it against its header row.

    Returns
    -------
    t : (n,) float64
        s.
    values : (n,) float64
        In the header's units, as written.

    Raises
    ------
    UserError
        The file is missing or unreadable, not two numeric columns, or its time base
        disagrees with the header (sample interval, first sample, number of samples).
    """
    p = header.channel_path(ch)
    try:
        found = p.is_file()
    except OSError:  # a name too long for the file system
        found = False
    if not found:
        raise UserError(f"missing channel file {p.name} for {ch.label()}: it must lie beside {header.path.name}")
    lines = [ln for ln in read_text(p, "EV5 channel file", encoding="latin-1", error=UserError).splitlines()
             if ln.strip()]
    tokens = " ".join(lines).split()
    if len(tokens) != 2 * len(lines) or len(lines) < 2:
        raise UserError(f"{p}: a channel file must hold two columns (time in s, value) on every line")
    try:
        data = np.array(tokens, dtype=float).reshape(-1, 2)
    except ValueError:
        raise UserError(f"{p}: a value is not a number") from None
    t, y = data[:, 0], data[:, 1]
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise UserError(f"{p}: times must increase")
    file_dt = float(np.median(dt))
    if not np.isclose(file_dt, ch.dt, rtol=1e-3):
        raise UserError(
            f"{p}: samples are {file_dt * 1e3:g} ms apart ({1 / file_dt:g} Hz) but the header says "
            f"{ch.dt * 1e3:g} ms ({1 / ch.dt:g} Hz) for {ch.label()}: mismatched sample rates")
    if np.max(np.abs(dt - file_dt)) > 0.01 * file_dt:
        raise UserError(f"{p}: the sample interval is not constant")
    if abs(t[0] - ch.first_sample * ch.dt) > 0.5 * ch.dt:
        raise UserError(f"{p}: starts at {t[0]:g} s, the header says {ch.first_sample * ch.dt:g} s")
    if len(t) != ch.n_samples:
        raise UserError(f"{p}: has {len(t)} samples, the header announces {ch.n_samples}")
    return t, y


def vehicle_motion_channels(header: Ev5Header) -> tuple[list[Ev5Channel], list[str]]:
    """The valid X accelerometers on the rigid passenger cell (rear-seat crossmembers or
    CG, ``MOTION_ATTACHMENTS``), and notes on the ones skipped as invalid.

    Raises UserError when there is none.
    """
    chosen, notes = [], []
    for ch in header.channels:
        if not (ch.vehicle == 1 and ch.sensor_type == "AC" and ch.axis.startswith("X")
                and ch.attachment in MOTION_ATTACHMENTS):
            continue
        if not ch.valid:
            notes.append(f"skipped {ch.label()}: header marks its data {ch.status!r}")
            continue
        if ch.units not in UNIT_SCALE:
            raise UserError(f"{header.path}: {ch.label()} is in {ch.units!r}; known units: {', '.join(UNIT_SCALE)}")
        chosen.append(ch)
    if not chosen:
        raise UserError(
            f"{header.path}: no valid vehicle X accelerometer on the rear-seat crossmember or the CG "
            f"(sensor attachment {' / '.join(MOTION_ATTACHMENTS)}, sensor type AC, axis X); "
            f"the vehicle's motion cannot be measured")
    # a CG accelerometer, where there is one, is the motion itself
    cg = [c for c in chosen if MOTION_ATTACHMENTS[c.attachment] == "vehicle CG"]
    return (cg or chosen), notes


def engine_channels(header: Ev5Header) -> tuple[list[Ev5Channel], list[str]]:
    """The engine's X accelerometers (vehicle 1, sensor type AC, attachment ENGN, axis X)
    whose data are usable at least in part (``Ev5Channel.valid_until_s``), and notes on the
    ones skipped (invalid status, units that are not an acceleration). Empty when the
    engine was not instrumented."""
    chosen, notes = [], []
    for ch in header.channels:
        if not (ch.vehicle == 1 and ch.sensor_type == "AC" and ch.axis.startswith("X")
                and ch.attachment in ENGINE_ATTACHMENTS):
            continue
        if ch.valid_until_s is None:
            notes.append(f"skipped engine {ch.label()}: header marks its data {ch.status!r}")
        elif UNIT_SCALE.get(ch.units, ("",))[0] != "acceleration":
            notes.append(f"skipped engine {ch.label()}: its units {ch.units!r} are not an acceleration")
        else:
            chosen.append(ch)
    return chosen, notes


def _engine_channel(header: Ev5Header, ch: Ev5Channel, notes: list[str]) -> Channel | None:
    """Channel ``ch`` cut at its ``valid_until_s``, or None and a note when its file is
    missing or disagrees with the header (an engine channel is never worth an error)."""
    try:
        c = _to_channel(header, ch, 1.0)
    except UserError as err:
        notes.append(f"skipped engine {ch.label()}: {err}")
        return None
    keep = c.t <= ch.valid_until_s + 0.25 * ch.dt
    if np.count_nonzero(keep) < 2:
        notes.append(f"skipped engine {ch.label()}: no valid data (header status {ch.status!r})")
        return None
    return Channel(c.code, c.name, c.t[keep], c.values[keep], c.quantity, c.redundant)


def barrier_force_channels(header: Ev5Header) -> tuple[list[Ev5Channel], list[str]]:
    """The valid X-force load cells of the barrier (vehicle 0, LC, axis X, force units)
    and notes on the ones skipped as invalid. Empty when the barrier had none."""
    chosen, notes = [], []
    for ch in header.channels:
        if not (ch.vehicle == 0 and ch.sensor_type == "LC" and ch.axis.startswith("X")
                and UNIT_SCALE.get(ch.units, ("",))[0] == "force"):
            continue
        if not ch.valid:
            notes.append(f"skipped barrier {ch.label()}: header marks its data {ch.status!r}")
            continue
        chosen.append(ch)
    return chosen, notes


def _to_channel(header: Ev5Header, ch: Ev5Channel, sign: float) -> Channel:
    t, y = load_ev5_channel(header, ch)
    quantity, scale = UNIT_SCALE[ch.units]
    return Channel(code=str(ch.curve), name=ch.description, t=t, values=sign * scale * y,
                   quantity=quantity, redundant=not ch.primary)


def read_nhtsa(path: str | Path, barrier: bool = True, progress=None) -> SensorTest:
    """Read an NHTSA EV5 test: the vehicle-motion accelerometers and the barrier load cells.

    Parameters
    ----------
    path : str or Path
        The ``.EV5`` header (channel files beside it).
    barrier : bool
        Also read the barrier's X load cells (for ``identify.report.force_check``).
    progress : callable, optional
        ``progress(done, total, stage)`` after each channel file (a full load-cell barrier
        has nearly 200).

    Returns
    -------
    SensorTest
        Accelerations in m/s^2 forward positive; barrier forces in N, compressive positive;
        ``engine`` the usable engine X accelerometers (see the module's notes on data
        status: curve 96 of 10146 ends at 67 ms and is skipped, curve 95 covers the test),
        engine channels that cannot be used skipped with a note.

    Raises
    ------
    UserError
        Unreadable header, no vehicle channels, a missing channel file, a time base that
        disagrees with the header, channels to combine at different sample rates.

    Examples
    --------
    >>> test = read_nhtsa("data/nhtsa-10146/v10146.EV5")  # doctest: +SKIP
    >>> [c.code for c in test.vehicle]  # doctest: +SKIP
    ['93', '94', '99', '100']
    """
    header = read_ev5_header(path)
    motion, notes = vehicle_motion_channels(header)
    engine, enotes = engine_channels(header)
    notes += enotes
    chosen: list[Ev5Channel] = []
    if barrier:
        chosen, bnotes = barrier_force_channels(header)
        notes += bnotes
    todo = [(c, "vehicle") for c in motion] + [(c, "engine") for c in engine] + [(c, "barrier") for c in chosen]
    loaded: dict[str, list] = {"vehicle": [], "engine": [], "barrier": []}
    for k, (ch, kind) in enumerate(todo):
        if kind == "engine":
            loaded[kind].append(_engine_channel(header, ch, notes))
        else:
            loaded[kind].append(_to_channel(header, ch, -1.0 if kind == "barrier" else 1.0))
        if progress is not None:
            progress(k + 1, len(todo), "reading channels")
    vehicle, cells = tuple(loaded["vehicle"]), tuple(loaded["barrier"])
    rows = {str(c.curve): c for c in engine}
    kept, skipped = usable_engine_channels(vehicle[0].t, [c for c in loaded["engine"] if c is not None],
                                           label=lambda c: rows[c.code].label())
    notes += skipped
    for c in kept:
        row = rows[c.code]
        if not row.valid:
            notes.append(f"engine {row.label()}: header marks its data {row.status!r} (channel failed) with no "
                         f"valid data after {row.valid_until_s * 1e3:g} ms; its samples up to "
                         f"{c.t[-1] * 1e3:.1f} ms are used")
    if cells:
        notes.append(f"barrier force: sum of {len(cells)} X load cell(s)")
    return SensorTest(source=str(header.path), impact_speed_mps=header.speed_kmh / 3.6,
                      mass_kg=header.mass_kg, vehicle=vehicle, barrier=cells,
                      title=header.title, notes=tuple(notes), engine=kept)
