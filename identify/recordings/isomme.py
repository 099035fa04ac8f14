"""ISO-MME (ISO/TS 13499) crash-test data: reader, and a writer to convert other tests.

Our own small parser, not pyisomme: pyisomme 1.1.0 (the maintained reader on PyPI)
requires numpy ~1.26, scipy ~1.12 and matplotlib ~3.7, and installing it would downgrade
the numpy 2 / scipy / matplotlib that JAX and the rest of this project need.

Layout read (ISO/TS 13499, "RED A" edition 1.6):

    <root>/<TEST>.mme              test information, one ``Key :value`` a line
    <root>/Channel/<TEST>.chn      ``Number of channels``, ``Name of channel NNN :<code> / <text>``
    <root>/Channel/<TEST>.NNN      channel NNN: ``Key :value`` header lines, then one value a line

Keys used: in the .mme, ``Laboratory test ref. number``, ``Title``, ``Velocity test
object 1`` (m/s) and ``Mass test object 1`` (kg); in a channel file, ``Name of the
channel``, ``Channel code``, ``Unit``, ``Time of first sample`` (s), ``Sampling interval``
(s), ``Number of samples`` and ``Data status`` (``ok``, or missing, means usable; anything
else, such as ``defect`` or ``questionable``, is skipped). ``NOVALUE`` means no value.

A 16-character channel code is test object (1), position (1), main location (4), three
fine locations (2 each), physical dimension (2), direction (1), filter class (1). Vehicle
motion: test object ``1``, ``AC``, direction ``X``, at the CG (``VEHC`` with fine location
``CG``; preferred when present) or on a rear seat crossmember (main location ``SECM``,
``CRME`` or ``SEAT`` with a fine location ``RE``). Barrier forces: test object ``B`` (fixed
barrier), ``FO``, direction ``X`` (a load-cell matrix is main location ``LOMA``). A rigid
barrier can only be pushed: the summed force is oriented so that its largest excursion is
positive (compressive), and the notes say when that flipped the file's sign. Engine motion
(the second measured body): test object ``1``, main location ``ENGN``, ``AC``, direction
``X`` (``10ENGNTO0000ACX0``, ``10ENGNBO0000ACX0``: top and bottom of the engine), forward
positive like the vehicle's. An engine channel that cannot be used (status not ok, a unit
that is not an acceleration, a file that disagrees with its header, another sample rate
than the vehicle's) is skipped with a note, never an error; trailing ``NOVALUE`` samples of
an engine channel (a sensor that failed during the crash) end it early
(``identify.recordings.motion.usable_engine_channels`` says what happens then).
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from pathlib import Path

import numpy as np

from identify.errors import UserError
from sim._text import read_text
from identify.recordings.motion import G0, Channel, SensorTest, usable_engine_channels

__all__ = ["read_isomme", "write_isomme", "parse_info", "find_mme", "is_vehicle_motion",
           "is_engine_motion", "is_barrier_force"]

UNITS = {"g": ("acceleration", G0), "m/s**2": ("acceleration", 1.0), "m/(s*s)": ("acceleration", 1.0),
         "m/s^2": ("acceleration", 1.0), "m/s2": ("acceleration", 1.0),
         "n": ("force", 1.0), "kn": ("force", 1e3)}
MOTION_MAIN = ("SECM", "CRME", "SEAT")
# beyond any crash recording, in SI units (10,000 g; 100 MN, a hundred times a full-width
# barrier's peak): a value past it is a damaged file, not a measurement (a fuzzed 1e300 in g
# overflowed to inf on conversion and into the motion's arithmetic)
PHYSICAL_LIMIT = {"acceleration": 1e5, "force": 1e8}
SI_UNIT = {"acceleration": "m/s^2", "force": "N"}
_LINE = re.compile(r"([^:]*[^:\s])\s*:(.*)")


def parse_info(lines: list[str], path: Path) -> tuple[dict[str, str], int]:
    """Parse ``Key :value`` lines up to the first line that is not one.

    Returns
    -------
    info : dict
        Keys lower-cased and stripped -> value stripped (``NOVALUE`` kept as written).
    end : int
        Index of the first line that is not ``Key :value`` (len(lines) if none).
    """
    info: dict[str, str] = {}
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        m = _LINE.fullmatch(s)
        if m is None:
            return info, i
        info[m.group(1).strip().lower()] = m.group(2).strip()
    return info, len(lines)


def _value(info: dict[str, str], key: str) -> str | None:
    v = info.get(key.lower())
    return None if v is None or v.upper() == "NOVALUE" or v == "" else v


def _number(info, key, path) -> float | None:
    v = _value(info, key)
    if v is None:
        return None
    try:
        value = float(v)
    except ValueError:
        raise UserError(f"{path}: {key!r} is {v!r}, not a number") from None
    if not np.isfinite(value):
        raise UserError(f"{path}: {key!r} is {v!r}, not a finite number")
    return value


def find_mme(path: str | Path) -> Path:
    """The ``.mme`` file of an ISO-MME test given the file itself or its folder."""
    p = Path(path)
    if p.is_dir():
        found = sorted(q for q in p.iterdir() if q.suffix.lower() == ".mme")
        if len(found) != 1:
            raise UserError(f"{p}: expected one .mme file in the folder, found {len(found)}")
        return found[0]
    if not p.exists():
        raise UserError(f"cannot read {p}: no such file")
    return p


def _find_ci(folder: Path, name: str) -> Path | None:
    """``folder/name`` matched without regard to case (ISO-MME files come from Windows)."""
    if not folder.is_dir():
        return None
    exact = folder / name
    try:
        if exact.exists():
            return exact
    except OSError:  # a name too long for the file system
        return None
    for q in folder.iterdir():
        if q.name.lower() == name.lower():
            return q
    return None


def is_vehicle_motion(code: str) -> str | None:
    """``"cg"``, ``"crossmember"`` or None: is ``code`` an X acceleration of the passenger cell."""
    c = code.upper()
    if len(c) != 16 or c[0] != "1" or c[12:14] != "AC" or c[14] != "X":
        return None
    main, fine = c[2:6], (c[6:8], c[8:10], c[10:12])
    if main == "VEHC" and "CG" in fine:
        return "cg"
    if main in MOTION_MAIN and "RE" in fine:
        return "crossmember"
    return None


def is_engine_motion(code: str) -> bool:
    """Is ``code`` an X acceleration of the engine (test object 1, main location ENGN)."""
    c = code.upper()
    return len(c) == 16 and c[0] == "1" and c[2:6] == "ENGN" and c[12:14] == "AC" and c[14] == "X"


def is_barrier_force(code: str) -> bool:
    """Is ``code`` an X force of the fixed barrier."""
    c = code.upper()
    return len(c) == 16 and c[0] == "B" and c[12:14] == "FO" and c[14] == "X"


def _read_channel(path: Path, code: str, label: str,
                  trailing_novalue: bool = False) -> tuple[dict[str, str], np.ndarray, np.ndarray]:
    """Header, times (s) and values of one channel file; ``trailing_novalue``: samples
    without a value at the end are dropped (the channel ends early) instead of refused."""
    lines = read_text(path, "ISO-MME channel file", encoding="latin-1", error=UserError).splitlines()
    info, end = parse_info(lines, path)
    try:
        values = np.array([float(s) if s.strip().upper() != "NOVALUE" else np.nan
                           for s in lines[end:] if s.strip()], dtype=float)
    except ValueError:
        raise UserError(f"{path}: a sample of {label} is not a number") from None
    n = _number(info, "Number of samples", path)
    if n is not None and int(n) != len(values):
        raise UserError(f"{path}: has {len(values)} samples, its header announces {int(n)}")
    if trailing_novalue and np.any(np.isfinite(values)):
        values = values[:int(np.flatnonzero(np.isfinite(values))[-1]) + 1]
    dt = _number(info, "Sampling interval", path)
    if dt is None or dt <= 0:
        raise UserError(f"{path}: no positive 'Sampling interval' for {label}")
    t0 = _number(info, "Time of first sample", path)
    t0 = 0.0 if t0 is None else t0
    if len(values) < 2 or not np.all(np.isfinite(values)):
        raise UserError(f"{path}: {label} needs at least two samples, all with a value")
    return info, t0 + dt * np.arange(len(values)), values


def read_isomme(path: str | Path, barrier: bool = True, progress=None) -> SensorTest:
    """Read an ISO-MME test: vehicle-motion accelerometers and barrier X forces.

    Parameters
    ----------
    path : str or Path
        The ``.mme`` file or the folder holding it.
    barrier : bool
        Also read the fixed barrier's X forces.
    progress : callable, optional
        ``progress(done, total, stage)`` after each channel file.

    Returns
    -------
    SensorTest
        Accelerations in m/s^2 forward positive, barrier forces in N compressive positive.

    Raises
    ------
    UserError
        No .mme or .chn file, no speed, no vehicle-motion channel, a missing channel file,
        a channel whose samples disagree with its header, unknown units.

    Examples
    --------
    >>> test = read_isomme("10146/10146.mme")  # doctest: +SKIP
    """
    mme = find_mme(path)
    info, _ = parse_info(read_text(mme, "ISO-MME file", encoding="latin-1", error=UserError).splitlines(), mme)
    number = _value(info, "Laboratory test ref. number") or mme.stem
    speed = _number(info, "Velocity test object 1", mme)
    if speed is None or speed <= 0:
        raise UserError(f"{mme}: no 'Velocity test object 1' (impact speed, m/s)")
    mass = _number(info, "Mass test object 1", mme)
    chdir = _find_ci(mme.parent, "Channel")
    chn = _find_ci(chdir, f"{mme.stem}.chn") if chdir else None
    if chn is None:
        raise UserError(f"{mme}: no channel list Channel/{mme.stem}.chn beside it")
    chinfo, _ = parse_info(read_text(chn, "ISO-MME channel list", encoding="latin-1", error=UserError).splitlines(), chn)
    entries = []
    for key, val in chinfo.items():
        m = re.fullmatch(r"name of channel (\d+)", key)
        if m:
            code = val.split("/")[0].strip()
            text = val.split("/", 1)[1].strip() if "/" in val else code
            entries.append((m.group(1), code, text))
    motion = [(e, is_vehicle_motion(e[1])) for e in entries]
    motion = [(e, kind) for e, kind in motion if kind]
    if any(kind == "cg" for _, kind in motion):
        motion = [(e, kind) for e, kind in motion if kind == "cg"]
    engine = [e for e in entries if is_engine_motion(e[1])]
    cells = [e for e in entries if barrier and is_barrier_force(e[1])]
    if not motion:
        raise UserError(
            f"{chn}: no vehicle X acceleration at the CG or a rear seat crossmember (codes 1?VEHCCG....ACX., "
            f"1?SECM..RE..ACX.); the vehicle's motion cannot be measured")

    notes: list[str] = []

    def load(entry, quantity_wanted, trailing_novalue=False) -> Channel | None:
        num, code, text = entry
        f = _find_ci(chdir, f"{mme.stem}.{num}")
        label = f"channel {num} {code} ({text})"
        if f is None:
            raise UserError(f"missing channel file Channel/{mme.stem}.{num} for {label}")
        cinfo, t, y = _read_channel(f, code, label, trailing_novalue)
        status = _value(cinfo, "Data status")
        if status is not None and not status.lower().startswith("ok"):
            notes.append(f"skipped {'engine ' if trailing_novalue else ''}{label}: data status {status!r}")
            return None
        unit = (_value(cinfo, "Unit") or "").strip()
        if unit.lower() not in UNITS or UNITS[unit.lower()][0] != quantity_wanted:
            raise UserError(f"{f}: {label} is in {unit!r}, expected a unit of {quantity_wanted} "
                            f"({', '.join(k for k, v in UNITS.items() if v[0] == quantity_wanted)})")
        with np.errstate(over="ignore"):
            values = y * UNITS[unit.lower()][1]
        if not np.all(np.abs(values) <= PHYSICAL_LIMIT[quantity_wanted]):
            worst = float(np.max(np.abs(values)))
            raise UserError(f"{f}: {label} reaches {worst:.3g} {SI_UNIT[quantity_wanted]}, beyond any crash "
                            f"recording's {PHYSICAL_LIMIT[quantity_wanted]:.0e}: a damaged file?")
        return Channel(code=code, name=_value(cinfo, "Name of the channel") or text, t=t, values=values,
                       quantity=quantity_wanted)

    def load_engine(entry) -> Channel | None:
        try:
            return load(entry, "acceleration", trailing_novalue=True)
        except UserError as err:  # an engine channel is never worth an error
            notes.append(f"skipped engine channel {entry[0]} {entry[1]} ({entry[2]}): {err}")
            return None

    todo = ([(e, "vehicle") for e, _ in motion] + [(e, "engine") for e in engine]
            + [(e, "barrier") for e in cells])
    loaded: dict[str, list] = {"vehicle": [], "engine": [], "barrier": []}
    for k, (e, kind) in enumerate(todo):
        loaded[kind].append(load_engine(e) if kind == "engine" else
                            load(e, "force" if kind == "barrier" else "acceleration"))
        if progress is not None:
            progress(k + 1, len(todo), "reading channels")
    vehicle = tuple(c for c in loaded["vehicle"] if c is not None)
    if not vehicle:
        raise UserError(f"{chn}: every vehicle-motion channel is marked invalid")
    numbers = {e[1]: e[0] for e in engine}
    kept, skipped = usable_engine_channels(vehicle[0].t, [c for c in loaded["engine"] if c is not None],
                                           label=lambda c: f"channel {numbers.get(c.code, '?')} {c.code} ({c.name})")
    notes += skipped
    forces = tuple(c for c in loaded["barrier"] if c is not None)
    if forces:
        total = np.sum([c.values for c in forces], axis=0) if len({len(c.values) for c in forces}) == 1 else None
        if total is not None and abs(total.min()) > abs(total.max()):
            forces = tuple(Channel(c.code, c.name, c.t, -c.values, c.quantity, c.redundant) for c in forces)
            notes.append("barrier forces: the file counts compression negative; turned positive")
        notes.append(f"barrier force: sum of {len(forces)} X force channel(s)")
    return SensorTest(source=str(mme), impact_speed_mps=speed, mass_kg=mass, vehicle=vehicle,
                      barrier=forces, title=_value(info, "Title") or number, notes=tuple(notes),
                      engine=kept)


def _side(name: str) -> str:
    n = name.upper()
    return "LE" if "LEFT" in n else "RI" if "RIGHT" in n else "00"


def _position(name: str) -> str:
    n = name.upper()
    return "TO" if "TOP" in n else "BO" if "BOTTOM" in n else "00"


def write_isomme(test: SensorTest, folder: str | Path, number: str = "TEST") -> Path:
    """Write ``test`` as an ISO-MME folder (vehicle and engine accelerations in g, barrier
    forces in N, compressive positive), atomically: a half-written folder never appears.

    Vehicle channels are coded ``10SECM<side>RE<nn>ACXP`` (side LE/RI from the channel's
    name), barrier channels ``B0LOMA<nnnn>00FOXP``, engine channels ``10ENGN<pos>00<nn>ACXP``
    (pos TO/BO for a name with TOP/BOTTOM, else 00), numbered after the barrier's.

    Parameters
    ----------
    test : SensorTest
    folder : str or Path
        Created; must not exist yet.
    number : str
        Test number: the file stem.

    Returns
    -------
    Path
        The ``.mme`` file.
    """
    folder = Path(folder)
    if folder.exists():
        raise UserError(f"{folder} exists already; choose a new folder")
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".isomme-", dir=folder.parent))
    try:
        from identify.report.results import current_umask

        os.chmod(tmp, 0o777 & ~current_umask())  # mkdtemp's 0700 would hide it from colleagues
        (tmp / "Channel").mkdir()
        mme = [f"{'Data format edition number':<28}:1.6",
               f"{'Laboratory test ref. number':<28}:{number}",
               f"{'Title':<28}:{test.title or number}",
               f"{'Number of test objects':<28}:2",
               f"{'Velocity test object 1':<28}:{test.impact_speed_mps:.6f}",
               f"{'Mass test object 1':<28}:{test.mass_kg if test.mass_kg is not None else 'NOVALUE'}",
               f"{'Comments':<28}:converted from {Path(test.source).name}"]
        (tmp / f"{number}.mme").write_text("\n".join(mme) + "\n", encoding="latin-1")
        rows, k = [], 0
        for i, ch in enumerate(test.vehicle):
            rows.append((f"10SECM{_side(ch.name)}RE{i:02d}ACXP", ch, "g", 1.0 / G0))
        for j, ch in enumerate(test.barrier):
            rows.append((f"B0LOMA{j:04d}00FOXP", ch, "N", 1.0))
        for i, ch in enumerate(test.engine):
            rows.append((f"10ENGN{_position(ch.name)}00{i:02d}ACXP", ch, "g", 1.0 / G0))
        chn = [f"{'Instrumentation standard':<28}:ISO 6487", f"{'Number of channels':<28}:{len(rows)}"]
        for k, (code, ch, unit, scale) in enumerate(rows, start=1):
            chn.append(f"{'Name of channel ' + format(k, '03d'):<28}:{code} / {ch.name}")
            dt = float(np.median(np.diff(ch.t)))
            head = [f"{'Name of the channel':<28}:{ch.name}",
                    f"{'Laboratory channel code':<28}:{ch.code}",
                    f"{'Channel code':<28}:{code}",
                    f"{'Direction':<28}:X",
                    f"{'Unit':<28}:{unit}",
                    f"{'Channel frequency class':<28}:NOVALUE",
                    f"{'Data status':<28}:ok",
                    f"{'Time of first sample':<28}:{ch.t[0]:.6f}",
                    f"{'Sampling interval':<28}:{dt:.8f}",
                    f"{'Number of samples':<28}:{len(ch.t)}"]
            body = "\n".join(f"{v:.10g}" for v in np.asarray(ch.values) * scale)
            (tmp / "Channel" / f"{number}.{k:03d}").write_text("\n".join(head) + "\n" + body + "\n",
                                                               encoding="latin-1")
        (tmp / "Channel" / f"{number}.chn").write_text("\n".join(chn) + "\n", encoding="latin-1")
        os.replace(tmp, folder)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return folder / f"{number}.mme"
