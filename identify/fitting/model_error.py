"""The collision model's own error, added to every fitted parameter's standard deviation.

The fit's covariance says how far the recording lets a parameter move *if the model were
the car*. It is not: on the reference world (``synth``, a richer car) the fitted
k_compression came out 3-5 % low with a fitted standard deviation of 1-2 %, a confident wrong
number. What a simpler model leaves out is a model-form error in the sense of ASME V&V 20
(validation of a model against what it did not make): it is measured by fitting recordings
whose truth is known and that the model did not make, and added in quadrature,

    std^2 = std_data^2 + std_model^2,   std_model = relative * |value|  or  absolute,

so each parameter reports ``std`` (total), ``std_data`` and ``std_model``. There is one table
per kind of recording (``KINDS``): what the error does to a parameter depends on what was
measured (positions on film, or accelerations), and a film's table also holds what the video
stage gets wrong systematically (its contact, its scale). The tables (``model_error.json``
beside this file) are written by ``benchmarks/calibrate_model_error.py`` from
``benchmarks/accuracy.py --calibration`` runs (their seeds are neither the scored benchmark's
nor any test's) and name the worlds they came from. A table may hold regimes' tables
(``REGIMES``): the error where the fitted model runs in a regime the clean worlds do not
show (the rear wheels lifting), measured on worlds where it does, and taken for a fit in that
regime where it is the larger (``ModelError.in_regimes``). A parameter a table does not list (a
discovered mechanism's) carries no model term: its std is the data's alone. It is the
reference world's model error: a real car may differ from our model more, never known to be
less. A film's table states the largest x misfit of the fits it was measured on
(``misfit_x_m``); a fit that misfits its recording by more has its model errors scaled by the
ratio (``ModelError.beyond_measured``), said in each parameter's ``std_model_measured``.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
from pathlib import Path

import numpy as np

TABLE_FILE = Path(__file__).with_name("model_error.json")
# what a recording measured: the car's position (a film, its tracks) or its accelerations
KINDS = ("film", "sensors")


@dataclasses.dataclass(frozen=True)
class ModelError:
    """Model-form standard deviation of each listed parameter.

    relative : name -> fraction of the value (stiffnesses, masses, the impact speed).
    absolute : name -> standard deviation in the parameter's own unit (restitution, m).
    source : where the numbers were measured (the calibration run's worlds).
    """

    relative: dict[str, float] = dataclasses.field(default_factory=dict)
    absolute: dict[str, float] = dataclasses.field(default_factory=dict)
    source: str = ""
    regimes: dict[str, "ModelError"] = dataclasses.field(default_factory=dict)
    misfit_x_m: float | None = None  # m, the largest x RMS misfit of the fits it was measured on (films)

    def std(self, name: str, value: float) -> float:
        """Model-form standard deviation of parameter ``name`` at ``value`` (its unit)."""
        if name in self.relative:
            return self.relative[name] * abs(value)
        return self.absolute.get(name, 0.0)

    def beyond_measured(self, rms_x_m: float | None) -> float:
        """The factor this table's errors are scaled by for a fit whose x misfits the
        recording by ``rms_x_m`` (m, RMS): ``rms_x_m / misfit_x_m`` where it exceeds the largest
        misfit of the fits the table was measured on, else 1 (and 1 for a table that does not
        say, or a fit without x). Beyond that misfit the table was not measured; the
        parameters' error is taken to grow in proportion to the misfit the model leaves, a
        first-order extrapolation. On development world 960025 (an engine that hit the
        barrier; nothing named) the fit missed x by 13.5 mm RMS, 3.5 times the calibration
        films' largest, 3.8 mm, and quoted dz_contact 0.104 m off at 11.5 sigma."""
        if not self.misfit_x_m or rms_x_m is None or not math.isfinite(rms_x_m):
            return 1.0
        return max(1.0, float(rms_x_m) / self.misfit_x_m)

    def scaled(self, factor: float) -> "ModelError":
        """This table with every error multiplied by ``factor`` (regimes dropped: the table of
        one fit's regimes, :meth:`in_regimes`)."""
        return dataclasses.replace(self, relative={k: v * factor for k, v in self.relative.items()},
                                   absolute={k: v * factor for k, v in self.absolute.items()}, regimes={})

    def in_regimes(self, names, values: dict[str, float]) -> tuple["ModelError", dict[str, str]]:
        """The table for a fit in the ``names`` regimes (:data:`REGIMES`) at ``values``: each
        parameter's error the larger of this table's and those measured in the regimes
        (:attr:`regimes`; a regime the table has not measured adds nothing), and, name ->
        the regime's description, the parameters whose error a regime set."""
        relative, absolute, where = dict(self.relative), dict(self.absolute), {}
        for regime in names:
            other = self.regimes.get(regime)
            if other is None:
                continue
            for name in (*other.relative, *other.absolute):
                if name in values and other.std(name, values[name]) > self.std(name, values[name]):
                    src, dst = (other.relative, relative) if name in other.relative else (other.absolute, absolute)
                    relative.pop(name, None)
                    absolute.pop(name, None)
                    dst[name] = src[name]
                    where[name] = f"that error measured with {REGIMES[regime]} ({other.source.split(' (')[0]})"
        return dataclasses.replace(self, relative=relative, absolute=absolute, regimes={}), where

    def covering(self, values: dict[str, float], std_data: dict[str, float]) -> tuple[dict, dict]:
        """(total std, model std), name -> value, for the fitted ``values`` with the data's
        ``std_data``: sqrt(std_data^2 + std_model^2)."""
        model = {k: self.std(k, v) for k, v in values.items()}
        return {k: math.hypot(std_data[k], model[k]) for k in std_data}, model


NONE = ModelError(source="none: the data's standard deviations alone")

# Regimes where the model's error differs from the clean worlds' (a table's "regimes"): what
# puts a fit in each, as said in a parameter's reason. The rear wheels off the ground: the
# base model lifts the rear on a spring from the vehicle file, the reference world's car
# on unsprung axles and tyres; on development worlds whose rear lifts (seeds 960000-960003,
# 2026-11-27) the fitted contact height came out 0.12-0.15 m above the truth, 2.8-3.6 of
# the clean worlds' standard deviations, while k_compression stayed within 4.1 %.
REAR_LIFTED = "rear_lifted"
REGIMES = {REAR_LIFTED: "the rear wheels lifting, as they do in this fit within the recording"}


def regimes_of(trajectory, t_end_s: float) -> tuple[str, ...]:
    """The :data:`REGIMES` a fitted model is in: ``trajectory`` (``sim`` output, model time
    from first contact, s) up to ``t_end_s`` (s after first contact: the recording's end).
    The lift is ``sim.outputs.rear_wheel_lift_time``, as result.json's model events give it."""
    from sim.outputs import rear_wheel_lift_time

    return (REAR_LIFTED,) if float(rear_wheel_lift_time(trajectory)) <= t_end_s else ()


def kind_of(measurement) -> str:
    """"film" when the recording measured the car's position (x_m fitted: a film or its
    tracks), "sensors" when the position was integrated from accelerometers or is absent."""
    return "film" if measurement.measures_position else "sensors"


@functools.cache
def table(kind: str, path: Path = TABLE_FILE) -> ModelError:
    """The calibrated table of recordings of ``kind`` (``KINDS``; read once)."""
    doc = json.loads(Path(path).read_text())["tables"][kind]
    return _table(doc, {name: _table(r, {}) for name, r in doc.get("regimes", {}).items()})


def _table(doc: dict, regimes: dict) -> ModelError:
    return ModelError(relative=dict(doc["relative"]), absolute=dict(doc["absolute"]), source=doc["source"],
                      regimes=regimes, misfit_x_m=doc.get("misfit_x_m"))


def calibrate(errors, std_data) -> float:
    """Model-form standard deviation s of a parameter from validation fits: the ``errors``
    (fitted - true) and the fits' own ``std_data`` (same unit, one per recording), chosen so
    that the errors in units of the combined standard deviation have a mean square of one,

        mean(e_i^2 / (std_i^2 + s^2)) = 1,

    0 when the data's standard deviations already account for the errors. Solved by
    bisection (the left side falls monotonically with s)."""
    e2 = np.square(np.asarray(errors, float))
    s2 = np.square(np.asarray(std_data, float))
    if e2.size == 0 or not np.all(np.isfinite(e2)) or not np.all(np.isfinite(s2)):
        raise ValueError("calibrate needs finite errors and standard deviations, one of each per fit")

    def excess(s):  # an error with no variance at all weighs infinitely
        d = s2 + s * s
        ratio = np.divide(e2, d, out=np.full_like(e2, np.inf), where=d > 0)
        return np.mean(np.where(e2 == 0.0, 0.0, ratio)) - 1.0

    if excess(0.0) <= 0.0:
        return 0.0
    lo, hi = 0.0, float(np.sqrt(e2.max())) * 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) > 0.0 else (lo, mid)
    return 0.5 * (lo + hi)
