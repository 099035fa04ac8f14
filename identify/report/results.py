"""Writing results without ever leaving a half-written file or folder, and without ever
touching a file of the user's.

A results folder (``docs/interface.md``) is written into a temporary sibling folder that
is created before any work starts (so a place the user cannot write fails in the first
second), and moved into place at the end. The folder carries a manifest
(:data:`MANIFEST`) naming every file the tool wrote there and which command wrote it: a
re-run replaces only those (and removes those of its own it no longer writes) and keeps
everything else (the user's notes, ``identify sensitivity``'s ``sensitivity/`` folder). A
folder holding files that are not ours is refused up front, naming the first one, when
one of them has a name the command would write, or when the folder is not a results
folder at all.

Files and folders are created with the user's umask (colleagues on a shared drive can
read them when the umask lets them).

Temporary paths alive at any moment are registered here; ``discard_temporaries`` (called
by the command line on Ctrl-C) removes them, after waiting for a commit in progress to
finish, so an interrupted run leaves either the old results or the new ones.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
import threading
from pathlib import Path

from identify.errors import UserError

RESULT_FILE = "result.json"
MANIFEST = "identify-manifest.json"

#: Names ``identify fit`` / ``identify track`` may write in a results folder (a superset:
#: discovery and force plots appear only when there is something to show).
FIT_FILES = (
    "result.json", "tracks.csv", "predictions.csv", "report.md", "forces.csv",
    "displacement_velocity.png", "residuals.png", "silhouettes.png", "overlay.png",
    "discovery_residuals.png", "discovery_force_deflection.png", "force_time.png", "force_crush.png",
    "tracking_report.png",
)  # fmt: skip
#: Names ``identify sensitivity`` writes in its folder.
SENSITIVITY_FILES = (
    "sensitivity.json", "sensitivity.csv", "intervals.csv", "monte_carlo.csv", "tornado.png", "distributions.png",
    "comparison_histories.png", "comparison_silhouettes.png",
)  # fmt: skip
#: Names ``identify track`` writes.
TRACK_FILES = ("tracks.csv", "tracking_report.png")

# ------------------------------------------------------------------ umask and temporaries


def current_umask() -> int:
    """The process's umask (read by setting and restoring it: there is no getter)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask

_LOCK = threading.RLock()
_LIVE: set[Path] = set()


def _register(path: Path) -> None:
    with _LOCK:
        _LIVE.add(Path(path))


def _unregister(path: Path) -> None:
    with _LOCK:
        _LIVE.discard(Path(path))


def discard_temporaries(timeout: float = 1.5) -> None:
    """Remove every temporary file or folder of a write in progress (Ctrl-C). Waits up to
    ``timeout`` s for a commit that is moving files into place, so that it completes."""
    got = _LOCK.acquire(timeout=timeout)
    try:
        for p in list(_LIVE):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p, ignore_errors=True)
            else:
                try:
                    p.unlink()
                except OSError:
                    pass
            _LIVE.discard(p)
    finally:
        if got:
            _LOCK.release()


def _why(err: OSError) -> str:
    return err.strerror or err.__class__.__name__


def make_temp_dir(parent: Path, name: str, what: str = "--out") -> Path:
    """A new empty folder ``parent/.name.XXXX.tmp``, mode from the umask, registered for
    cleanup. Raises UserError (one line) when ``parent`` is missing or not writable."""
    parent = Path(parent)
    if not parent.exists():
        raise UserError(f"{what}: folder {parent} does not exist")
    if not parent.is_dir():
        raise UserError(f"{what}: {parent} is not a folder")
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".tmp", dir=parent))
    except OSError as err:
        raise UserError(f"{what}: cannot write in {parent} ({_why(err)}); choose a folder you can write, "
                        "e.g. --out ~/results/crash.identify") from None
    _register(tmp)
    os.chmod(tmp, 0o777 & ~current_umask())
    return tmp


def remove_temp(path: Path) -> None:
    """Remove a temporary made by :func:`make_temp_dir` or :func:`write_text_atomic`."""
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)
    _unregister(path)


def check_writable_file(path: Path, what: str = "--out") -> None:
    """Raise UserError unless a file can be created at ``path`` (by creating and removing a
    temporary sibling): missing folder, a folder given for a file, no permission."""
    path = Path(path)
    if path.is_dir():
        raise UserError(f"{what}: {path} is a folder; give a file name, e.g. {path / 'run.csv'}")
    parent = path.parent
    if not parent.is_dir():
        raise UserError(f"{what}: folder {parent} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=parent)
    except OSError as err:
        raise UserError(f"{what}: cannot write in {parent} ({_why(err)}); choose a folder you can write") from None
    os.close(fd)
    os.unlink(tmp)
    if path.exists() and not os.access(path, os.W_OK) and not os.access(parent, os.W_OK):
        raise UserError(f"{what}: {path} is read-only")


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and an atomic
    rename: a crash leaves either the old file or the new one, never half of one. The file
    gets the user's umask."""
    path = Path(path)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as err:
        raise UserError(f"cannot write {path} ({_why(err)})") from None
    _register(Path(tmp))
    try:
        with os.fdopen(fd, "w", newline="") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~current_umask())
        with _LOCK:
            os.replace(tmp, path)
            _unregister(Path(tmp))
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        _unregister(Path(tmp))
        raise


# ------------------------------------------------------------------ JSON


def json_clean(obj):
    """Make ``obj`` JSON-safe: NaN and infinities become null, numpy scalars plain numbers."""
    if isinstance(obj, dict):
        return {str(k): json_clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_clean(v) for v in obj]
    if hasattr(obj, "tolist") and not isinstance(obj, (str, bytes)):
        return json_clean(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(doc: dict) -> str:
    """``doc`` as indented, strictly valid JSON text."""
    return json.dumps(json_clean(doc), indent=2, allow_nan=False) + "\n"


# ------------------------------------------------------------------ results folders


def default_output_folder(recording_path: Path) -> Path:
    """``<stem>.identify/`` beside the recording (a folder of frames: beside the folder)."""
    p = Path(recording_path)
    stem = p.name if p.is_dir() else p.stem
    return p.parent / f"{stem}.identify"


def read_manifest(folder: Path) -> dict[str, str] | None:
    """``{file name: command}`` of the files the tool wrote in ``folder``; None when the
    folder has no (readable) manifest."""
    p = Path(folder) / MANIFEST
    if not p.is_file():
        return None
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
        files = doc["files"]
        if isinstance(files, dict) and all(isinstance(k, str) and isinstance(v, str) for k, v in files.items()):
            return {k: v for k, v in files.items() if k and "/" not in k and k not in (".", "..")}
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def _ours(out: Path, names: tuple[str, ...], marker: str | None) -> dict[str, str]:
    """Files of ``out`` the tool wrote: its manifest, or for a results folder written before
    manifests existed (it holds ``marker``), the names this command writes."""
    manifest = read_manifest(out)
    if manifest is not None:
        return manifest
    if marker and (out / marker).is_file():
        return {n: "legacy" for n in names if (out / n).exists()}
    return {}


def check_output_folder(out: Path, names: tuple[str, ...] = FIT_FILES, marker: str | None = RESULT_FILE,
                        what: str = "--out", kind: str = "results") -> None:
    """Raise UserError unless ``out`` can take this command's results: it does not exist, is
    empty, or is a results folder of ours whose files not in the manifest do not collide
    with the names this command writes (they are kept)."""
    out = Path(out)
    if not out.parent.exists():
        raise UserError(f"{what}: folder {out.parent} does not exist")
    if out.exists() and not out.is_dir():
        raise UserError(f"{what}: {out} is a file, not a folder")
    if not out.exists():
        return
    try:
        entries = sorted(p.name for p in out.iterdir())
    except OSError as err:
        raise UserError(f"{what}: cannot read folder {out} ({_why(err)})") from None
    if not entries:
        return
    ours = _ours(out, names, marker)
    if not ours and MANIFEST not in entries:
        raise UserError(f"{what}: {out} is a folder with other files in it (e.g. {entries[0]}), not a {kind} "
                        "folder of ours; name a new or empty folder")
    for name in entries:
        if name in names and name not in ours:
            raise UserError(f"{what}: {out / name} is not a file this tool wrote, and this run would replace it; "
                            "move it away or choose another --out")


class ResultsFolder:
    """A results folder written atomically and without touching the user's files.

    ``folder = ResultsFolder(out, command, names)`` checks ``out`` and creates the temporary
    sibling at once (UserError, one line, when the place cannot be written). Write into
    ``folder.tmp``; ``folder.commit()`` moves the files into place, or ``folder.discard()``
    removes them. As a context manager (``with ResultsFolder(out) as tmp:``) it commits on
    success and discards on error.
    """

    def __init__(self, out: Path, command: str = "fit", names: tuple[str, ...] = FIT_FILES,
                 marker: str | None = RESULT_FILE, what: str = "--out", adopt_legacy: bool = True,
                 kind: str = "results"):
        self.kind = kind
        self.adopt_legacy = adopt_legacy  # write a manifest into a results folder made before manifests
        self.out = Path(out)
        self.command = command
        self.names = tuple(names)
        self.marker = marker
        check_output_folder(self.out, self.names, marker, what, kind)
        if self.out.is_dir():  # a re-run moves files into it: it must take them, known now
            try:
                fd, probe = tempfile.mkstemp(prefix=".probe.", suffix=".tmp", dir=self.out)
                os.close(fd)
                os.unlink(probe)
            except OSError as err:
                raise UserError(f"{what}: cannot write in {self.out} ({_why(err)}); choose another --out") from None
        self.tmp: Path | None = make_temp_dir(self.out.parent, self.out.name, what)

    def __enter__(self) -> Path:
        assert self.tmp is not None
        return self.tmp

    def __exit__(self, exc_type, exc, tb):
        if exc_type is not None:
            self.discard()
            return False
        try:
            self.commit()
        except BaseException:
            self.discard()
            raise
        return False

    def discard(self) -> None:
        if self.tmp is not None:
            remove_temp(self.tmp)
            self.tmp = None

    def _fix_modes(self) -> None:
        """Temporary files and folders are made private (0600/0700); give the results the
        modes the user's umask gives any new file."""
        mask = current_umask()
        os.chmod(self.tmp, 0o777 & ~mask)
        for root, dirs, files in os.walk(self.tmp):
            for d in dirs:
                os.chmod(os.path.join(root, d), 0o777 & ~mask)
            for f in files:
                os.chmod(os.path.join(root, f), 0o666 & ~mask)

    def commit(self) -> Path:
        """Move the new files into place; keep every file the manifest does not name."""
        assert self.tmp is not None, "commit after discard"
        tmp = self.tmp
        self._fix_modes()
        written = sorted(p.name for p in tmp.iterdir())
        with _LOCK:
            if not self.out.exists():
                files = {n: self.command for n in written}
                (tmp / MANIFEST).write_text(json.dumps({"tool": "identify", "files": files}, indent=2) + "\n")
                os.chmod(tmp / MANIFEST, 0o666 & ~current_umask())
                os.replace(tmp, self.out)
                _unregister(tmp)
                self.tmp = None
                return self.out
            # merge: check again (the user may have added files while we worked)
            check_output_folder(self.out, self.names, self.marker, kind=self.kind)
            had_manifest = read_manifest(self.out) is not None
            ours = _ours(self.out, self.names, self.marker)
            foreign = [n for n in written if (self.out / n).exists() and n not in ours]
            if foreign:
                raise UserError(f"--out: {self.out / foreign[0]} is not a file this tool wrote; "
                                "move it away or choose another --out")
            for name in written:
                target = self.out / name
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target)
                os.replace(tmp / name, target)
            stale = [n for n, cmd in ours.items() if cmd in (self.command, "legacy") and n not in written]
            for name in stale:
                target = self.out / name
                if target.is_dir() and not target.is_symlink():
                    shutil.rmtree(target, ignore_errors=True)
                elif target.exists() or target.is_symlink():
                    target.unlink()
            files = {n: c for n, c in ours.items() if n not in stale and (self.out / n).exists()}
            files.update({n: self.command for n in written})
            files = {n: (c if c != "legacy" else self.command) for n, c in sorted(files.items())}
            if had_manifest or self.adopt_legacy:
                write_text_atomic(self.out / MANIFEST, json.dumps({"tool": "identify", "files": files}, indent=2) + "\n")
            shutil.rmtree(tmp, ignore_errors=True)
            _unregister(tmp)
            self.tmp = None
        return self.out


def mechanisms_from_result(doc: dict, notes: list[str]) -> tuple:
    """Rebuild the mechanisms of a result.json (``doc``) that ``sim.MECHANISMS`` knows: from the fitted
    ``"parameters"`` named ``effect.field`` (as ``identify fit`` writes them), else from each
    discovery's own ``"parameters"`` (``field`` or ``field_<unit>``); and the base model's
    parts the fit assumed (``"fit"``'s ``"assumed"``: the engine on its mounts). What cannot
    be rebuilt is left out, with a line in ``notes``."""
    import jax.numpy as jnp

    from sim import MECHANISMS

    fields: dict[str, dict] = {}
    fit = doc.get("fit") if isinstance(doc.get("fit"), dict) else {}
    for part in fit.get("assumed") or []:
        if isinstance(part, dict) and part.get("effect") in MECHANISMS:
            fields[part["effect"]] = {n: jnp.asarray(float(e["value"])) for n, e in (part.get("parameters") or {}).items()
                                      if isinstance(e, dict) and isinstance(e.get("value"), (int, float))}
    for key, entry in (doc.get("parameters") or {}).items():
        effect, dot, field = key.partition(".")
        value = entry.get("value") if isinstance(entry, dict) else entry
        if dot and effect in MECHANISMS and isinstance(value, (int, float)) and not isinstance(value, bool):
            fields.setdefault(effect, {})[field] = jnp.asarray(float(value))
    from identify.fitting.model import VEHICLE_OVERRIDES

    vehicle_effects = {name.split(".", 1)[0] for name in VEHICLE_OVERRIDES}  # applied to the vehicle instead
    for disc in doc.get("discoveries") or []:
        effect = disc.get("effect") if isinstance(disc, dict) else disc
        if effect in vehicle_effects:
            continue
        if effect not in MECHANISMS:
            notes.append(f"discovered effect {effect!r} has no simulation mechanism: left out of the study")
            continue
        if effect in fields:
            continue
        units = MECHANISMS[effect].units
        for name, entry in (disc.get("parameters") or {}).items():
            value = entry.get("value") if isinstance(entry, dict) else entry
            field = name.split(".")[-1]
            field = field if field in units else field.rsplit("_", 1)[0]
            if field in units and isinstance(value, (int, float)) and not isinstance(value, bool):
                fields.setdefault(effect, {})[field] = jnp.asarray(float(value))
    out = []
    for effect, values in fields.items():
        try:
            out.append(MECHANISMS[effect](**values))
        except (TypeError, ValueError) as err:
            notes.append(f"effect {effect!r} left out: its parameters {sorted(values)} do not build the mechanism ({err})")
    return tuple(out)


def vehicle_from_result(doc: dict, vehicle, notes: list[str]):
    """``vehicle`` with the changes a result.json (``doc``) discovered in it (the fitted
    ``rear_axle_lift.rear_axle_stiffness`` in its ``"parameters"``: ``identify.fitting.model.
    VEHICLE_OVERRIDES``), a line in ``notes`` saying so; ``vehicle`` itself when none."""
    import jax.numpy as jnp

    from identify.fitting.model import VEHICLE_OVERRIDES, vehicle_with

    table = doc.get("parameters") if isinstance(doc.get("parameters"), dict) else {}
    overrides = {}
    for name in VEHICLE_OVERRIDES:
        entry = table.get(name)
        value = entry.get("value") if isinstance(entry, dict) else entry
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
            overrides[name] = jnp.asarray(float(value))
    if not overrides:
        return vehicle
    notes.append("vehicle changed as discovered: " + ", ".join(f"{k} = {float(v):.6g}" for k, v in overrides.items()))
    return vehicle_with(vehicle, overrides)


def model_from_result(doc: dict, vehicle, path, notes: list[str]):
    """(Params, vehicle) of the model a result.json (``doc``, read from ``path``) fitted: its
    collision parameters (validated by ``sim.params.params_from_table``: ConfigError naming
    ``path`` and the field), the engine it assumed and the mechanisms it discovered
    (:func:`mechanisms_from_result`), and ``vehicle`` changed as discovered
    (:func:`vehicle_from_result`); ``notes`` gets what was rebuilt or left out."""
    from sim.params import UNITS, params_from_table

    table = {name: entry for name, entry in doc["parameters"].items() if name in UNITS}
    params = params_from_table(table, path, mechanisms_from_result(doc, notes))
    return params, vehicle_from_result(doc, vehicle, notes)
