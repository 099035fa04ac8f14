"""The model's own error (identify/fitting/model_error.py) and its calibration
(benchmarks/calibrate_model_error.py), on hand-made numbers."""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from identify.fitting.model_error import KINDS, NONE, TABLE_FILE, ModelError, calibrate, kind_of, table

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from benchmarks.accuracy import CALIBRATION_SEED_BASE, SEED_BASE  # noqa: E402
from benchmarks.calibrate_model_error import errors_of, model_error_table, model_error_tables  # noqa: E402
from identify.fitting.collision_fit import CONTACT_FROM_MOTION  # noqa: E402


def test_calibrate_finds_the_spread_the_data_std_does_not_explain():
    """Errors drawn with a 5 % spread, each fit claiming 1 %: the model term is
    sqrt(5^2 - 1^2) = 4.90 %, to the sampling error of 4000 draws (1.1 %)."""
    rng = np.random.default_rng(11)
    errors = rng.normal(0.0, 0.05, 4000)
    assert calibrate(errors, np.full(4000, 0.01)) == pytest.approx(math.sqrt(0.05**2 - 0.01**2), rel=0.04)


def test_calibrate_weighs_each_error_by_its_own_std():
    """Two fits: one 0.1 off claiming 0.1 (z = 1 already), one 0.3 off claiming 0.1: the model
    term s solves 0.01 / (0.01 + s^2) + 0.09 / (0.01 + s^2) = 2, s^2 = 0.04."""
    assert calibrate([0.1, -0.3], [0.1, 0.1]) == pytest.approx(0.2, rel=1e-6)


def test_calibrate_adds_nothing_when_the_data_std_covers_the_errors():
    assert calibrate([0.01, -0.02, 0.005], [0.05, 0.05, 0.05]) == 0.0
    assert calibrate([0.0, 0.0], [0.0, 0.0]) == 0.0


def test_calibrate_refuses_what_it_cannot_weigh():
    with pytest.raises(ValueError):
        calibrate([], [])
    with pytest.raises(ValueError):
        calibrate([0.1, float("nan")], [0.1, 0.1])


def test_model_std_is_relative_absolute_or_nothing_and_adds_in_quadrature():
    me = ModelError(relative={"k_compression": 0.04}, absolute={"restitution": 0.01})
    assert me.std("k_compression", -2.0e6) == pytest.approx(8.0e4)
    assert me.std("restitution", 0.5) == 0.01
    assert me.std("stiffness_zone.depth", 0.3) == 0.0
    total, model = me.covering({"k_compression": 1e6, "restitution": 0.2, "x.y": 3.0},
                               {"k_compression": 3e4, "restitution": 0.0, "x.y": 0.5})
    assert total == pytest.approx({"k_compression": 5e4, "restitution": 0.01, "x.y": 0.5})
    assert model == pytest.approx({"k_compression": 4e4, "restitution": 0.01, "x.y": 0.0})
    assert NONE.covering({"k_compression": 1e6}, {"k_compression": 3e4})[0] == {"k_compression": 3e4}


@pytest.mark.parametrize("kind", KINDS)
def test_each_shipped_table_names_its_calibration_worlds_and_only_parameters_the_fit_has(kind):
    """Each kind's table was measured on calibration seeds, none the benchmark scores or a
    test uses, and lists only names the fit reports (a typo would silently add nothing)."""
    from identify.discover.candidates.engine_impact import CANDIDATE
    from identify.fitting.model import NUISANCE, base_parameters

    doc = json.loads(TABLE_FILE.read_text())["tables"][kind]
    assert doc["seeds"] and min(doc["seeds"]) >= CALIBRATION_SEED_BASE
    assert str(doc["seeds"][0]) in doc["source"]
    known = ({p.name for p in base_parameters()} | set(NUISANCE) | {p.name for p in CANDIDATE.parameters}
             | {CONTACT_FROM_MOTION})  # the error of where the fitted channels alone put a measured contact
    t = table(kind)
    assert set(t.relative) | set(t.absolute) <= known
    assert t.relative["k_compression"] > 0


def test_a_recording_of_positions_takes_the_film_table_one_of_accelerations_the_sensors_table():
    from identify.recordings.measurement import Measurement

    t = np.linspace(0.0, 0.1, 5)
    film = Measurement(t=t, channels={"x_m": t}, sigma={"x_m": np.full(5, 1e-3)})
    sensors = Measurement(t=t, channels={"x_m": t, "vx_mps": t}, sigma={"x_m": np.full(5, 1e-3), "vx_mps": np.full(5, 0.1)},
                          derived=("x_m",))
    assert kind_of(film) == "film" and kind_of(sensors) == "sensors"


def _row(seed, effect="clean", status="ok", not_identified=(), **params):
    return {"seed": seed, "effect": effect, "status": status, "format": "isomme",
            "speed_err_pct": 0.2, "speed_std_pct": 0.5, "speed_std_data_pct": 0.1,
            "params": {name: {"value": v, "err": e, "std": 10 * s, "std_data": s, "identified": name not in not_identified}
                       for name, (v, e, s) in params.items()},
            "engine": {"engine_impact.engine_mass": {"value": 150.0, "true": 200.0, "std": 9.0, "std_data": 4.0}},
            "measured_effects": ["engine_impact"]}


def test_calibration_rows_convert_to_fractions_of_the_truth_and_absolute_units():
    """k_compression fitted 1.05e6 (+5 %, so truth 1e6) +- 2e4: error 0.05, std 0.02 of the
    truth; the restitution in its own unit; speed and engine mass as fractions; the data's std,
    never the reported total."""
    out = errors_of(_row(CALIBRATION_SEED_BASE, k_compression=(1.05e6, 5.0, 2e4), restitution=(0.2, -0.01, 0.004)))
    assert out["k_compression"] == pytest.approx((0.05, 0.02))
    assert out["restitution"] == pytest.approx((-0.01, 0.004))
    assert out["impact_speed"] == pytest.approx((0.002, 0.001))
    assert out["engine_impact.engine_mass"] == pytest.approx((-0.25, 0.02))
    assert "contact_time" not in out  # a film's: the row of a film has the contact's error and std
    film = errors_of({**_row(CALIBRATION_SEED_BASE), "fit_contact_err_ms": 4.0, "contact_std_data_ms": 0.5,
                      "measured_effects": []})
    assert film["contact_time"] == pytest.approx((0.004, 0.0005))
    assert CONTACT_FROM_MOTION not in film  # the contact was fitted, not held: no estimate of the channels' own
    # held 4 ms late, where the film's contact and the channels' combined, the channels alone
    # putting it 1.5 ms later still, +- 0.3 ms
    held = {"prior": 0.0092, "prior_std": 0.0005, "value": 0.0115, "std": 0.002, "std_data": 0.0003, "held": True,
            "held_at": 0.010}
    film = errors_of({**_row(CALIBRATION_SEED_BASE), "fit_contact_err_ms": 4.0, "contact_std_data_ms": 0.5,
                      "measured_effects": [], "priors": {"contact_time": held}})
    assert film[CONTACT_FROM_MOTION] == pytest.approx((0.0055, 0.0003))
    # an engine discovery on a film of a clean world is a false discovery, not the base model's error
    assert "engine_impact.engine_mass" not in film


def test_calibration_counts_identified_values_of_clean_fitted_calibration_worlds_only():
    base = CALIBRATION_SEED_BASE
    rows = [_row(base, k_compression=(1.05e6, 5.0, 1e-9)), _row(base + 1, k_compression=(0.95e6, -5.0, 1e-9)),
            _row(base + 4, not_identified=("k_compression",), k_compression=(3e6, 200.0, 1e6)),  # data: 33 %
            _row(base + 2, effect="stiffness_zone", k_compression=(2e6, 100.0, 1e-9)),
            _row(base + 3, status="refused")]
    doc = model_error_table(rows)
    assert doc["relative"]["k_compression"] == pytest.approx(0.05, rel=1e-4)
    assert doc["measured"]["k_compression"]["worlds"] == 2 and doc["seeds"] == [base, base + 1, base + 4]
    with pytest.raises(SystemExit, match="not calibration seeds"):
        model_error_table(rows + [_row(SEED_BASE, k_compression=(1e6, 0.0, 1.0))])


def test_a_value_the_data_identify_counts_though_the_model_term_hid_it():
    """A table calibrated with one in place: a k_restitution reported not identified only
    because the table's model term put it beyond 20 % (its data's std 10 % of the value) still counts;
    one whose data's std is 30 % does not (fitting.NOT_IDENTIFIED's 20 %)."""
    base = CALIBRATION_SEED_BASE
    hid = errors_of(_row(base, not_identified=("k_restitution",), k_restitution=(1.2e6, 20.0, 1.2e5)))
    assert hid["k_restitution"] == pytest.approx((0.2, 0.12))  # 10 % of the value, 12 % of the truth
    unseen = errors_of(_row(base, not_identified=("k_restitution",), k_restitution=(1.2e6, 20.0, 3.6e5)))
    assert "k_restitution" not in unseen


def test_calibrating_one_kind_of_recording_keeps_the_other_kinds_table():
    base = CALIBRATION_SEED_BASE
    rows = [dict(_row(base, k_compression=(1.05e6, 5.0, 1e-9)), format="film")]
    before = {"tables": {"sensors": {"relative": {"k_compression": 0.01}}, "film": {"relative": {}}}}
    doc = model_error_tables(rows, before)
    assert doc["tables"]["sensors"] == before["tables"]["sensors"]
    assert doc["tables"]["film"]["relative"]["k_compression"] == pytest.approx(0.05, rel=1e-4)


def test_a_regimes_error_replaces_the_clean_worlds_where_larger_and_says_where_it_was_measured():
    from identify.fitting.model_error import REAR_LIFTED

    lifted = ModelError(relative={"k_compression": 0.05}, absolute={"dz_contact": 0.15}, source="8 lifting worlds")
    t = ModelError(relative={"k_compression": 0.1}, absolute={"dz_contact": 0.04}, source="clean",
                   regimes={REAR_LIFTED: lifted})
    values = {"k_compression": 1e6, "dz_contact": -0.2}
    here, where = t.in_regimes((REAR_LIFTED,), values)
    assert here.std("dz_contact", -0.2) == 0.15 and here.std("k_compression", 1e6) == pytest.approx(1e5)
    assert list(where) == ["dz_contact"] and "rear wheels lift" in where["dz_contact"] and "8 lifting worlds" in where["dz_contact"]
    for regimes in ((), ("a regime nobody measured",)):
        same, where = t.in_regimes(regimes, values)
        assert same.std("dz_contact", -0.2) == 0.04 and where == {}


def test_beyond_the_largest_misfit_it_was_measured_on_a_table_scales_by_the_ratio():
    t = ModelError(relative={"k_compression": 0.08}, absolute={"dz_contact": 0.007}, source="s", misfit_x_m=0.004)
    assert t.beyond_measured(0.012) == pytest.approx(3.0)
    assert t.beyond_measured(0.003) == 1.0 and t.beyond_measured(None) == 1.0 and t.beyond_measured(math.nan) == 1.0
    assert ModelError(relative={"k_compression": 0.08}).beyond_measured(0.012) == 1.0  # a table that does not say
    three = t.scaled(3.0)
    assert three.std("k_compression", 1e6) == pytest.approx(2.4e5) and three.std("dz_contact", -0.1) == pytest.approx(0.021)
    # a film calibration states the largest x misfit of the fits it used (rms_mm: the fit's x RMS)
    base = CALIBRATION_SEED_BASE
    rows = [dict(_row(base, k_compression=(1.05e6, 5.0, 1e-9)), format="film", rms_mm=1.2),
            dict(_row(base + 1, k_compression=(0.95e6, -5.0, 1e-9)), format="film", rms_mm=3.8),
            dict(_row(base + 2, effect="stiffness_zone", k_compression=(2e6, 100.0, 1e-9)), format="film", rms_mm=13.0)]
    assert model_error_table(rows)["misfit_x_m"] == pytest.approx(0.0038)
    assert "misfit_x_m" not in model_error_table([dict(r, format="isomme") for r in rows])
    assert table("film").misfit_x_m > 0 and table("sensors").misfit_x_m is None


def test_a_fit_is_in_the_rear_lifted_regime_when_its_model_lifts_the_rear_within_the_recording():
    from types import SimpleNamespace

    from identify.fitting.model_error import REAR_LIFTED, regimes_of

    t = np.linspace(-0.02, 0.3, 321)
    lifts_at_50ms = SimpleNamespace(t=t, rear_margin=np.where(t > 0.05, -0.01, 0.02))
    assert regimes_of(lifts_at_50ms, 0.3) == (REAR_LIFTED,)
    assert regimes_of(lifts_at_50ms, 0.04) == ()  # the recording ends before the lift
    assert regimes_of(SimpleNamespace(t=t, rear_margin=np.full(t.shape, 0.02)), 0.3) == ()


def test_a_regimes_table_is_measured_on_the_worlds_whose_fitted_model_is_in_it():
    base = CALIBRATION_SEED_BASE
    lift = dict(model_rear_lift_ms=40.0, format="film")
    rows = [dict(_row(base, effect="rear_axle_lift", dz_contact=(-0.2, 0.12, 1e-9), k_compression=(2e6, 100.0, 1e-9)),
                 **lift),
            dict(_row(base + 1, dz_contact=(-0.2, -0.12, 1e-9)), **lift),       # clean, its model lifting
            dict(_row(base + 2, effect="rear_axle_lift", dz_contact=(-0.2, 0.5, 1e-9)), format="film",
                 model_rear_lift_ms=None),                                        # its model never lifts
            dict(_row(base + 3, effect="stiffness_zone", dz_contact=(-0.2, 0.5, 1e-9)), **lift)]
    before = {"tables": {"film": {"relative": {"k_compression": 0.1}, "absolute": {"dz_contact": 0.04}, "source": "old"}}}
    doc = model_error_tables(rows, before)["tables"]["film"]
    lifted = doc["regimes"]["rear_lifted"]
    assert lifted["absolute"]["dz_contact"] == pytest.approx(0.12, rel=1e-4) and lifted["seeds"] == [base, base + 1]
    assert "lifts the rear wheels" in lifted["source"]
    assert "k_compression" not in lifted["relative"]  # a regime's table: the parameters the regime acts on
    # the clean worlds' table from the clean world among the rows
    assert doc["absolute"]["dz_contact"] == pytest.approx(0.12, rel=1e-4) and doc["seeds"] == [base + 1]
    # rows of the regime alone keep the clean worlds' table as it was
    doc = model_error_tables([rows[0]], before)["tables"]["film"]
    assert doc["absolute"] == {"dz_contact": 0.04} and doc["source"] == "old" and "rear_lifted" in doc["regimes"]
    assert table("film").regimes["rear_lifted"].absolute["dz_contact"] > table("film").absolute["dz_contact"]
