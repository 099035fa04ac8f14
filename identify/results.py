"""Writing results without ever leaving a half-written file or folder.

A results folder (``docs/interface.md``) is written into a temporary sibling folder and
renamed into place at the end; a previous results folder of ours at the same place is
replaced only then, and a folder that is not ours is never touched.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

from identify.errors import UserError

RESULT_FILE = "result.json"


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file in the same folder and an atomic
    rename: a crash leaves either the old file or the new one, never half of one."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


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


def check_output_folder(out: Path) -> None:
    """Raise UserError unless ``out`` can take a results folder: it must not exist, be
    empty, or be a previous results folder (it holds a result.json)."""
    out = Path(out)
    if not out.parent.exists():
        raise UserError(f"--out: folder {out.parent} does not exist")
    if out.exists():
        if not out.is_dir():
            raise UserError(f"--out: {out} is a file, not a folder")
        if any(out.iterdir()) and not (out / RESULT_FILE).exists():
            raise UserError(f"--out: {out} is a folder with other files in it; name a new or empty folder")


class ResultsFolder:
    """Context manager: ``with ResultsFolder(out) as tmp: ...write into tmp...``; on success
    ``tmp`` replaces ``out``; on any error ``tmp`` is removed and ``out`` is untouched."""

    def __init__(self, out: Path):
        self.out = Path(out)
        check_output_folder(self.out)
        self.tmp: Path | None = None

    def __enter__(self) -> Path:
        self.tmp = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.", suffix=".tmp", dir=self.out.parent))
        return self.tmp

    def __exit__(self, exc_type, exc, tb):
        assert self.tmp is not None
        if exc_type is not None:
            shutil.rmtree(self.tmp, ignore_errors=True)
            return False
        old = None
        if self.out.exists():
            old = self.out.with_name(f".{self.out.name}.old-{os.getpid()}")
            os.replace(self.out, old)
        os.replace(self.tmp, self.out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        return False
