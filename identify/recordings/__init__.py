"""recordings: from a file the user names to the Measurement the fit reads.

    film (video.track) ─┐
    tracks.csv ─────────┼──load.load_recording──▶ Recording(measurement, tracks, film, sensor_test)
    EV5 / ISO-MME ──────┘   (sensor tests: read_nhtsa / read_isomme -> SensorTest
                             -> measurement_from_test)
        ──consistency──▶ does the film show the car the vehicle file describes?

- ``measurement``: the :class:`Measurement` type (channels, sigma per sample, t = 0 at contact).
- ``load``: ``load_recording(path, ...)``: the reader chosen by what the path is.
- ``nhtsa``, ``isomme``, ``motion``: sensor recordings (below).
- ``consistency``: the film's wheelbase and length against the vehicle file's.
- ``synthetic``: films drawn from a trajectory with known truth (tests, ``identify track``).

Sensor recordings:

    from identify.recordings import read_nhtsa, measurement_from_test
    test = read_nhtsa("data/nhtsa-10146/v10146.EV5")       # or read_isomme("test/TEST.mme")
    measurement = measurement_from_test(test)               # x_m, vx_mps from t = 0 at contact

Readers (``read_nhtsa`` for NHTSA's EV5 ASCII export, ``read_isomme`` for ISO-MME /
ISO/TS 13499) return a :class:`SensorTest`: the vehicle's X accelerations, the engine's X
accelerations (``engine``, when the engine was instrumented) and the barrier's X load cells
in SI units (acceleration forward positive, barrier force compressive positive), invalid
channels skipped with a note. ``measurement_from_test`` filters (SAE J211 CFC 180), finds
first contact and integrates to the :class:`identify.recordings.measurement.Measurement` that the fit
reads: ``x_m``, ``vx_mps`` and, from the engine's accelerometers, ``engine_x_m``,
``engine_vx_mps``. ``read_recording`` / ``is_recording`` pick the reader by file type.

The barrier force is deliberately not in the Measurement: it is the independent check of
``identify.report.force_check`` (``force_check_document(test, measurement, fitted_trajectory,
out_dir, contact_time_s)`` after the fit).
"""

from identify.recordings.isomme import read_isomme as read_isomme, write_isomme as write_isomme
from identify.recordings.motion import (
    Channel as Channel,
    MotionOptions as MotionOptions,
    SensorTest as SensorTest,
    contact_time as contact_time,
    crash_facts as crash_facts,
    measurement_from_test as measurement_from_test,
)
from identify.recordings.nhtsa import read_nhtsa as read_nhtsa


def is_recording(path) -> bool:
    """True for what ``read_recording`` reads: an ``.EV5`` or ``.mme`` file, or a folder
    holding a ``.mme`` file (a folder of film frames is not one)."""
    from pathlib import Path

    p = Path(path)
    if p.suffix.lower() in (".ev5", ".mme"):
        return True
    return p.is_dir() and any(q.suffix.lower() == ".mme" for q in p.iterdir())


def read_recording(path, progress=None) -> SensorTest:
    """Read a sensor recording by its file type: ``.EV5`` (NHTSA) or ``.mme`` / a folder
    holding one (ISO-MME); ``progress(done, total, stage)`` after each channel file."""
    from pathlib import Path

    from identify.errors import UserError

    p = Path(path)
    if not is_recording(p):
        raise UserError(f"{p}: not a sensor recording (expected an NHTSA .EV5 header, or an ISO-MME "
                        f".mme file or a folder holding one)")
    if p.suffix.lower() == ".ev5":
        return read_nhtsa(p, progress=progress)
    return read_isomme(p, progress=progress)
