"""identify: crash-test recordings in, collision-model parameters out.

The glue between ``video`` (film -> measured motion) and ``sim`` (the collision model).
``identification.fit`` runs the flow, one subpackage a stage:

    recordings ──▶ Measurement ──fitting──▶ FitResult ──discover──▶ discoveries ──report──▶ result.json,
    (film, tracks.csv,           (parameters,            (named mechanisms               report.md,
     EV5, ISO-MME)                uncertainty)            or "unexplained")               figures

``sensitivity`` (``identify sensitivity``) asks how a reconstruction depends on its inputs;
``cli`` and ``commands/`` are the command line.

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
    "Measurement": "identify.recordings.measurement",
    "load_recording": "identify.recordings.load",
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
