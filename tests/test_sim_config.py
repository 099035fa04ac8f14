"""Vehicle files and parameter sets: what ships loads, bad configuration fails loudly."""

import math
import tomllib

import jax.numpy as jnp
import numpy as np
import pytest

from sim import ConfigError, list_param_sets, list_vehicles, load_params, load_vehicle, make_params, simulate
from sim._paths import VEHICLE_DIR
from sim.simulate import Solver, n_samples
from sim.vehicle import vehicle_from_dict

A4_FILE = VEHICLE_DIR / "audi_a4.toml"


def a4_dict():
    with open(A4_FILE, "rb") as f:
        return tomllib.load(f)


def test_shipped_vehicles_load_with_consistent_outlines():
    names = list_vehicles()
    assert {"audi_a4", "toyota_camry_2018"} <= set(names) and len(names) >= 4
    for name in names:
        v = load_vehicle(name)
        outline = np.asarray(v.silhouette_side)
        assert outline.shape[0] >= 10
        assert outline[:, 0].max() == pytest.approx(float(v.length), abs=0.01)
        assert outline[:, 1].max() == pytest.approx(float(v.height), abs=0.01)
        assert 0.0 < v.windscreen_top[0] < float(v.length)
        loads = np.asarray(v.static_axle_loads)
        assert loads.sum() == pytest.approx(float(v.mass) * 9.81)


def test_named_parameter_sets_are_the_papers_table_1():
    assert {"vsim_default", "paper_identified"} <= set(list_param_sets())
    p = load_params("paper_identified")
    assert float(p.k_compression) == 970e3 and float(p.k_restitution) == 600e3
    assert float(p.restitution) == 0.17 and float(p.dz_contact) == -0.21
    d = load_params("vsim_default")
    assert float(d.k_compression) == float(d.k_restitution) == 730e3 and float(d.dz_contact) == 0.0


@pytest.mark.parametrize(
    "edit, field",
    [
        ({"mass": -1670.0}, "mass"),
        ({"pitch_inertia": 0.0}, "pitch_inertia"),
        ({"contact_area": "big"}, "contact_area"),
        ({"cg_to_front_axle": 3.0}, "cg_to_front_axle"),
        ({"axle_stiffness": [95000.0]}, "axle_stiffness"),
        ({"axle_damping": [-1.0, 5000.0]}, "axle_damping"),
        ({"wheel_spin_inertia": [2.2, -0.1]}, "wheel_spin_inertia"),
        ({"wheel_spin_inertia": 2.2}, "wheel_spin_inertia"),
        ({"wheel_radius": math.nan}, "wheel_radius"),
    ],
)
def test_bad_vehicle_field_is_named(edit, field):
    d = {**a4_dict(), **edit}
    with pytest.raises(ConfigError, match=field):
        vehicle_from_dict(d, source="test.toml")


def test_missing_vehicle_field_is_named(tmp_path):
    d = a4_dict()
    del d["wheelbase"]
    text = "\n".join(f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"' for k, v in d.items())
    path = tmp_path / "car.toml"
    path.write_text(text.replace("(", "[").replace(")", "]"))
    with pytest.raises(ConfigError, match="missing field 'wheelbase'"):
        load_vehicle(path)


def test_unknown_vehicle_lists_known_ones():
    with pytest.raises(ConfigError, match="unknown vehicle 'audi_a5'.*audi_a4"):
        load_vehicle("audi_a5")


def test_wheel_spin_inertia_is_the_files_or_a_passenger_cars_wheels():
    """Two wheels of 1.1 kg m^2 an axle unless the file says (data/README.md); 0 is V-SIM's."""
    d = a4_dict()
    d.pop("wheel_spin_inertia", None)
    np.testing.assert_allclose(np.asarray(vehicle_from_dict(d).wheel_spin_inertia), [2.2, 2.2])
    np.testing.assert_allclose(np.asarray(vehicle_from_dict({**d, "wheel_spin_inertia": [3.0, 0.0]}).wheel_spin_inertia),
                               [3.0, 0.0])


def test_optional_suspension_defaults_follow_ride_frequency():
    d = a4_dict()
    del d["axle_stiffness"], d["axle_damping"]
    v = vehicle_from_dict(d)
    axle_mass = np.asarray(v.static_axle_loads) / 9.81
    freq = np.sqrt(np.asarray(v.axle_stiffness) / axle_mass) / (2 * np.pi)
    np.testing.assert_allclose(freq, [1.4, 1.6])


@pytest.mark.parametrize(
    "values, field",
    [
        ({"restitution": 1.2}, "restitution"),
        ({"restitution": -0.1}, "restitution"),
        ({"k_compression": -5.0}, "k_compression"),
        ({"k_restitution": 0.0}, "k_restitution"),
        ({"mu_slip": math.inf}, "mu_slip"),
        ({"restitution": 0.9, "k_restitution": 300e3}, "restitution"),  # line would end below 0
    ],
)
def test_bad_parameter_is_named_not_clamped(values, field):
    base = {"k_compression": 970e3, "k_restitution": 600e3, "restitution": 0.17, "dz_contact": -0.21}
    with pytest.raises(ConfigError, match=f"'{field}'"):
        make_params(**{**base, **values})


def test_unknown_or_missing_parameter_in_file(tmp_path):
    path = tmp_path / "p.json"
    path.write_text('{"parameters": {"k_compression": {"value": 9e5}, "stifness": 1}}')
    with pytest.raises(ConfigError, match="unknown parameter 'stifness'"):
        load_params(path)
    path.write_text('{"parameters": {"k_compression": {"value": 9e5}}}')
    with pytest.raises(ConfigError, match="missing parameter 'k_restitution'"):
        load_params(path)


def test_result_json_shaped_file_loads(tmp_path):
    path = tmp_path / "result.json"
    path.write_text(
        '{"vehicle": "audi_a4", "parameters": {"k_compression": {"value": 970000.0, "unit": "N/m^3", "std": 5000.0},'
        ' "k_restitution": {"value": 600000.0}, "restitution": {"value": 0.17}, "dz_contact": {"value": -0.21}}}'
    )
    p = load_params(path)
    assert float(p.k_compression) == 970e3 and float(p.mu_slip) == 0.8


def test_simulate_rejects_bad_speed(a4):
    p = load_params("paper_identified")
    for speed in (0.0, -3.0, math.nan, 500.0):
        with pytest.raises(ConfigError, match="impact speed"):
            simulate(p, a4, speed)


def test_simulate_speed_bounds_are_inclusive_at_100_and_cover_every_batch_member(a4, monkeypatch):
    # The compiled run is replaced by a recorder (the checks are what is tested): 100 m/s and
    # a tiny positive speed are accepted, one bad member of a batch is enough to refuse it,
    # an empty batch is refused.
    import importlib

    ran = []
    monkeypatch.setattr(importlib.import_module("sim.simulate"), "_run_jit", lambda params, vehicle, speed, n, solver: ran.append(speed))
    p = load_params("paper_identified")
    for speed in (100.0, 1e-3, jnp.array([1e-3, 100.0])):
        simulate(p, a4, speed, duration=0.002)
    assert len(ran) == 3
    for speed in (jnp.array([10.0, -1.0]), jnp.array([10.0, 100.5]), jnp.array([10.0, math.nan]), jnp.array([])):
        with pytest.raises(ConfigError, match="impact speed"):
            simulate(p, a4, speed, duration=0.002)


def test_n_samples_counts_both_ends_and_refuses_spans_outside_0_to_10_s():
    assert n_samples(0.3) == 301
    assert n_samples(10.0) == 10001  # the longest span accepted
    assert n_samples(0.3, Solver(output_dt=2e-3)) == 151
    assert n_samples(1) == 1001  # an int is a span too
    for bad in (0.0, -0.1, 10.001, math.nan, math.inf, "0.3", None):
        with pytest.raises(ConfigError, match="duration"):
            n_samples(bad)


def test_the_solvers_output_interval_sets_the_runs_samples(a4):
    run = simulate(load_params("paper_identified"), a4, 15.0, duration=0.01, solver=Solver(output_dt=2e-3))
    assert np.asarray(run.t) == pytest.approx([0.0, 0.002, 0.004, 0.006, 0.008, 0.010])
    # 2 ms at 15 m/s before the structure has slowed the car much
    assert float(run.x[1]) == pytest.approx(0.030, rel=0.01)


def test_batch_validation_names_the_bad_member():
    from sim import validate_params

    p = make_params(k_compression=970e3, k_restitution=600e3, restitution=0.17, dz_contact=-0.21)
    import dataclasses

    batch = dataclasses.replace(p, restitution=jnp.array([0.1, 1.5]))
    with pytest.raises(ConfigError, match="restitution.*1.5"):
        validate_params(batch)
