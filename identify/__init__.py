"""identify: crash-test recordings in, collision-model parameters out.

The glue between ``video`` (film -> measured motion) and ``sim`` (the collision model):
reading recordings, fitting, results and the command line (``identify.cli``).

    import identify
    ident = identify.fit("crash.mp4", "audi_a4")      # what `identify fit` does
    ident.parameters["k_compression"]                 # {"value": ..., "unit": ..., "std": ...}
"""

from identify.errors import UserError as UserError

# The rest is imported on first use (``identify.fit`` ...): the command line starts at once
# and can honour Ctrl-C while the heavy modules (JAX, OpenCV) load in its worker thread.
_LAZY = {
    "Identification": "identify.identification",
    "fit": "identify.identification",
    "Measurement": "identify.measurement",
    "load_recording": "identify.recording",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'identify' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
