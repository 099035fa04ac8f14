"""JAX's persistent compilation cache for the command line.

Compiling the collision model's fit, its discovery and its reports is most of a first run.
XLA's compiled programs are kept on disk, keyed by the program, the JAX version and the
machine, so a later run of the same model on a recording of the same length (a rerun after
a changed option, the same film again) skips those compiles: the README's first command on
the sample film took 75.5 s without the cache, 79.1 s filling it and 43.7 s reading it
(2026-11-27, 2 cores; the same numbers in result.json each time).

The cache lives in ``$XDG_CACHE_HOME/crash-identify/jax`` (``~/.cache/...``), a few MB. A
folder in ``JAX_COMPILATION_CACHE_DIR`` is used instead when set; ``IDENTIFY_NO_COMPILE_CACHE=1``
turns it off. A folder that cannot be written is no error: the run compiles as it would
without a cache.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DIR_VARIABLE = "JAX_COMPILATION_CACHE_DIR"
OFF_VARIABLE = "IDENTIFY_NO_COMPILE_CACHE"

# every compiled program is kept, however quick its compile (JAX keeps only those over 1 s by
# default; the fit's are many small ones: 85 compiles, 2 MB in all)
_SETTINGS = {"jax_persistent_cache_min_compile_time_secs": 0.0, "jax_persistent_cache_min_entry_size_bytes": 0}


def default_dir() -> Path:
    """The user's cache folder for compiled programs."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "crash-identify" / "jax"


def enable(directory: str | Path | None = None) -> Path | None:
    """Keep compiled programs in ``directory`` (default: ``JAX_COMPILATION_CACHE_DIR``, else
    :func:`default_dir`); returns the folder, or None when the cache is off or the folder
    cannot be made or written. Set before JAX is imported (through the environment JAX
    reads) or after (through its configuration)."""
    if os.environ.get(OFF_VARIABLE):
        return None
    folder = Path(directory or os.environ.get(DIR_VARIABLE) or default_dir()).expanduser()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if not os.access(folder, os.W_OK | os.X_OK):
        return None
    os.environ[DIR_VARIABLE] = str(folder)
    for name, value in _SETTINGS.items():  # what JAX reads when it is imported later
        os.environ.setdefault(name.upper(), str(value))
    if "jax" in sys.modules:
        import jax

        jax.config.update("jax_compilation_cache_dir", str(folder))
        for name, value in _SETTINGS.items():
            jax.config.update(name, value)
    return folder
