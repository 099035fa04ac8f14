"""Forward- and reverse-mode derivatives of the simulation agree with finite differences,
for every parameter, with every mechanism switched on; and vmap equals a loop."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import central_difference_jacobian
from sim import FrontWheelBlock, ProgressiveStiffness, RateDependence, StiffnessZone, Solver, make_params
from sim.params import UNITS
from sim.simulate import _run_jit

NAMES = [
    "k_compression", "k_restitution", "restitution", "dz_contact", "mu_slip", "mu_adhesion",
    "rolling_resistance", "block_depth", "zone_depth", "k_zone", "progression", "rate_coefficient",
    "speed", "mass", "pitch_inertia",
]  # fmt: skip
X0 = np.array([970e3, 600e3, 0.17, -0.21, 0.8, 0.9, 0.015, 0.583, 0.45, 1.3e6, 0.2, 0.004, 15.64, 1670.0, 2800.0])
N_OUT = 111  # 110 ms: compression, the force drop at maximum crush, and early restitution


@pytest.fixture(scope="module")
def outputs_of(a4):
    def f(theta):
        th = dict(zip(NAMES, theta))
        params = dataclasses.replace(
            make_params(**{k: 1.0 for k in ("k_compression", "k_restitution", "restitution", "dz_contact")}),
            **{k: th[k] for k in NAMES[:7]},
            mechanisms=(
                FrontWheelBlock(depth=th["block_depth"]),
                StiffnessZone(depth=th["zone_depth"], k_zone=th["k_zone"]),
                ProgressiveStiffness(progression=th["progression"]),
                RateDependence(rate_coefficient=th["rate_coefficient"]),
            ),
        )
        vehicle = dataclasses.replace(a4, mass=th["mass"], pitch_inertia=th["pitch_inertia"])
        run = _run_jit(params, vehicle, th["speed"], N_OUT, Solver())
        pick = slice(10, None, 20)
        return jnp.concatenate([run.x[pick], 10 * run.z[pick], 10 * run.pitch[pick], run.front_wheel_angle[pick]])

    return jax.jit(f)


def _column_errors(jac, ref):
    return np.linalg.norm(jac - ref, axis=0) / np.linalg.norm(ref, axis=0)


def test_forward_mode_matches_finite_differences(outputs_of):
    ref = central_difference_jacobian(lambda x: outputs_of(jnp.asarray(x)), X0)
    jac = np.asarray(jax.jacfwd(outputs_of)(jnp.asarray(X0)))
    assert np.all(np.linalg.norm(ref, axis=0) > 0), "every parameter must move the outputs"
    errors = _column_errors(jac, ref)
    assert np.all(errors < 1e-5), dict(zip(NAMES, errors))


def test_reverse_mode_matches_forward_mode(outputs_of):
    x = jnp.asarray(X0)
    fwd = np.asarray(jax.jacfwd(outputs_of)(x))
    rev = np.asarray(jax.jacrev(outputs_of)(x))
    assert np.all(_column_errors(rev, fwd) < 1e-9)


def test_vmap_over_parameter_sets_equals_single_runs(a4):
    from sim import simulate

    ks = jnp.array([800e3, 970e3, 1200e3])
    base = make_params(k_compression=970e3, k_restitution=600e3, restitution=0.17, dz_contact=-0.21)
    batch = dataclasses.replace(
        base, k_compression=ks, **{k: jnp.full(3, getattr(base, k)) for k in UNITS if k != "k_compression"}
    )
    runs = jax.vmap(lambda p: _run_jit(p, a4, 15.64, N_OUT, Solver()))(batch)
    for i, k in enumerate(ks):
        single = simulate(dataclasses.replace(base, k_compression=k), a4, 15.64, duration=0.11)
        np.testing.assert_allclose(np.asarray(runs.x[i]), np.asarray(single.x), rtol=1e-12, atol=1e-12)
    assert float(runs.crush.max(axis=1)[0]) > float(runs.crush.max(axis=1)[2])  # softer crushes deeper
