"""The rules that decide what the user is told about the engine (issue 15): priors from the
vehicle file, pulls beyond 3 sigma reported as conflicts and never accepted as discoveries,
and a recording without engine accelerometers saying what it cannot tell."""

from types import SimpleNamespace

import numpy as np
import pytest

from identify.candidates import ENGINE_GAP_M, ENGINE_MASS_FRACTION, engine_priors, measured_effects
from identify.discovery import _plausible
from identify.fitting import FitResult
from identify.identification import _second_body_notes


def fake_fit(values, std, priors, channels=("x_m", "vx_mps")):
    fr = SimpleNamespace(values=values, std=std, priors=priors, PULL_CONFLICT=FitResult.PULL_CONFLICT,
                         trajectory=SimpleNamespace(crush=np.array([0.0, 0.5]), engine_force=np.array([0.0, 1e5])),
                         measurement=SimpleNamespace(channels={c: None for c in channels}))
    fr.pulls = lambda: FitResult.pulls(fr)
    return fr


def test_engine_priors_come_from_the_vehicle_file_else_from_stated_typical_values(a4):
    p = engine_priors(a4)  # data/vehicles/audi_a4.toml gives engine_mass 205 kg, engine_gap 0.35 m
    assert p["engine_impact.engine_mass"] == (205.0, pytest.approx(0.3 * 205.0))
    assert p["engine_impact.gap"] == (0.35, 0.1)
    bare = SimpleNamespace(engine_mass=None, engine_gap=None, mass=1500.0)
    p = engine_priors(bare)
    assert p["engine_impact.engine_mass"][0] == pytest.approx(ENGINE_MASS_FRACTION * 1500.0)
    assert p["engine_impact.gap"][0] == ENGINE_GAP_M


def test_a_pull_beyond_three_sigma_is_a_conflict_and_within_it_is_not():
    priors = {"engine_impact.engine_mass": (230.0, 69.0)}
    far = fake_fit({"engine_impact.engine_mass": 230.0 + 3.2 * 69.0}, {"engine_impact.engine_mass": 20.0}, priors)
    near = fake_fit({"engine_impact.engine_mass": 230.0 - 2.8 * 69.0}, {"engine_impact.engine_mass": 20.0}, priors)
    assert far.pulls()["engine_impact.engine_mass"]["pull"] == pytest.approx(3.2)
    assert far.pulls()["engine_impact.engine_mass"]["conflict"] is True
    assert near.pulls()["engine_impact.engine_mass"]["pull"] == pytest.approx(-2.8)
    assert near.pulls()["engine_impact.engine_mass"]["conflict"] is False


def test_a_candidate_that_pushes_a_prior_into_conflict_is_not_a_discovery(a4):
    priors = {"engine_impact.engine_mass": (230.0, 69.0)}
    values = {"engine_impact.engine_mass": 680.0, "rate_dependence.rate_coefficient": 0.02}
    std = {"engine_impact.engine_mass": 200.0, "rate_dependence.rate_coefficient": 0.002}
    why = _plausible("rate_dependence", fake_fit(values, std, priors), a4)
    assert "beyond 3 sigma" in why and "engine_impact.engine_mass" in why
    values["engine_impact.engine_mass"] = 300.0
    assert _plausible("rate_dependence", fake_fit(values, std, priors), a4) == ""


def test_an_engine_that_never_reaches_the_barrier_is_not_a_discovery(a4):
    names = ("engine_mass", "gap", "k_engine", "k_rear")
    values = {f"engine_impact.{n}": v for n, v in zip(names, (230.0, 0.4, 3e6, 1e6))}
    std = {k: 0.1 * v for k, v in values.items()}
    fr = fake_fit(values, std, {})
    assert _plausible("engine_impact", fr, a4) == ""
    fr.trajectory.engine_force = np.zeros(2)
    assert "never reaches the barrier" in _plausible("engine_impact", fr, a4)


def test_a_sensor_recording_without_engine_channels_says_what_it_cannot_tell():
    sensors = SimpleNamespace(sensor_test=object())
    without = fake_fit({}, {}, {})
    notes = _second_body_notes(without, sensors)
    assert len(notes) == 1 and "engine's own motion is not measured" in notes[0] and "not identified" in notes[0]
    assert measured_effects(without.measurement) == ()
    with_engine = fake_fit({}, {}, {}, channels=("x_m", "vx_mps", "engine_x_m", "engine_vx_mps"))
    assert _second_body_notes(with_engine, sensors) == []
    assert measured_effects(with_engine.measurement) == ("engine_impact",)
    assert _second_body_notes(without, SimpleNamespace(sensor_test=None)) == []  # a film says nothing of it
