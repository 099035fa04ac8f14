"""Each optional mechanism is off by default and changes the force law as its equation says."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from conftest import PAPER_SPEED
from sim import MECHANISMS, ProgressiveStiffness, RateDependence, StiffnessZone, named_params, simulate
from sim.contact import loading_force


def test_every_effect_of_the_interface_is_a_mechanism_with_an_explanation():
    assert {"front_wheel_block", "stiffness_zone", "progressive_stiffness", "rate_dependence"} <= set(MECHANISMS)
    for cls in MECHANISMS.values():
        assert cls.explanation.endswith(".") and len(cls.explanation) > 40
        assert cls.units


def test_base_params_have_no_mechanisms():
    assert named_params("paper_identified").mechanisms == ()


def test_stiffness_zone_changes_slope_past_its_depth(a4):
    base = named_params("paper_identified")
    zoned = dataclasses.replace(base, mechanisms=(StiffnessZone(depth=jnp.asarray(0.4), k_zone=jnp.asarray(2e6)),))
    area = float(a4.contact_area)
    d = jnp.array([0.2, 0.35, 0.5, 0.6])
    f0 = np.asarray(loading_force(d, 0.0, base, a4))
    f1 = np.asarray(loading_force(d, 0.0, zoned, a4))
    np.testing.assert_allclose(f1[:2], f0[:2], rtol=1e-6)
    slope = (f1[3] - f1[2]) / 0.1
    assert slope == pytest.approx(2e6 * area, rel=1e-3)
    # the energy balance: the structure absorbs about the same energy E = k_c A d0^2 / 2 with
    # or without the zone (the rest goes to the wheels and the pitch, a fraction of a per
    # cent), so the zoned car stops where the area under its two-slope curve reaches E:
    # k_c A D^2 / 2 + k_c A D s + k_zone A s^2 / 2 = E, D = 0.4 m
    run0 = simulate(base, a4, PAPER_SPEED)
    run1 = simulate(zoned, a4, PAPER_SPEED)
    kc, depth = float(base.k_compression) * area, 0.4
    energy = 0.5 * kc * float(run0.crush.max()) ** 2
    qa, qb, qc = 0.5 * 2e6 * area, kc * depth, 0.5 * kc * depth**2 - energy
    expected = depth + (-qb + np.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa)  # 0.611 m against 0.648 m
    assert float(run1.crush.max()) == pytest.approx(expected, abs=0.002)


def test_stiffness_zone_explains_itself_as_stiffer_or_softer():
    base = named_params("paper_identified")  # k_compression 970 kN/m^3
    stiffer = StiffnessZone(depth=jnp.asarray(0.4), k_zone=jnp.asarray(2e6))
    softer = StiffnessZone(depth=jnp.asarray(0.1), k_zone=jnp.asarray(5e5))
    assert stiffer.explain(base) == StiffnessZone.explanation and "faster" in stiffer.explain(base)
    assert softer.explain(base) == StiffnessZone.softer_explanation and "more slowly" in softer.explain(base)
    assert ProgressiveStiffness(progression=jnp.asarray(1.0)).explain(base) == ProgressiveStiffness.explanation


def test_progressive_and_rate_dependent_forces(a4):
    base = named_params("paper_identified")
    prog = dataclasses.replace(base, mechanisms=(ProgressiveStiffness(progression=jnp.asarray(0.5)),))
    rate = dataclasses.replace(base, mechanisms=(RateDependence(rate_coefficient=jnp.asarray(0.01)),))
    f0 = float(loading_force(0.4, 10.0, base, a4))
    assert float(loading_force(0.4, 10.0, prog, a4)) == pytest.approx(f0 * 1.2)
    assert float(loading_force(0.4, 10.0, rate, a4)) == pytest.approx(f0 * 1.1)
    assert float(loading_force(0.4, -3.0, rate, a4)) == pytest.approx(f0)  # no effect while unloading


def test_a_rate_dependent_structure_pushes_back_by_1_plus_c_times_the_crush_rate_in_the_run(a4):
    """Through simulate, not only the force law: while the structure is loaded the run's
    barrier force is k_c A crush (1 + c rate), the crush rate that of the contact point
    (dz' = 0 here: the CG's vx). The run reports vx at mid-step and the step uses the rate at
    its start, 0.1 ms apart: measured 0.02 % of the force at most; the tolerance is 0.2 %."""
    c = 0.01
    base = dataclasses.replace(named_params("paper_identified"), dz_contact=jnp.asarray(0.0))
    rate = dataclasses.replace(base, mechanisms=(RateDependence(rate_coefficient=jnp.asarray(c)),))
    run = simulate(rate, a4, 15.0, duration=0.03)
    crush, vx, force = (np.asarray(getattr(run, n))[5:30] for n in ("crush", "vx", "force"))
    law = float(base.k_compression) * float(a4.contact_area) * crush
    assert force == pytest.approx(law * (1.0 + c * vx), rel=0.002)
    assert np.all(force > 1.05 * law)  # the rate term matters here (c vx >= 0.1)


def test_a_car_without_an_engine_body_reports_the_engine_moving_with_the_cabin(a4):
    """One body: the Trajectory's engine fields say the engine is the cabin (same position
    and velocity), feels no barrier force and is never crushed or torn from its mounts."""
    run = simulate(named_params("paper_identified"), a4, 15.0, duration=0.05)
    assert np.array_equal(np.asarray(run.engine_x), np.asarray(run.x))
    assert np.array_equal(np.asarray(run.engine_vx), np.asarray(run.vx))
    for name in ("engine_force", "engine_crush", "mounts_broken"):
        out = np.asarray(getattr(run, name))
        assert out.shape == np.asarray(run.x).shape and not np.any(out)
