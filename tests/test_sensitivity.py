"""identify.sensitivity: autodiff sensitivities against finite differences and physics,
input sampling (covariance, ranges, rejection), Monte Carlo summaries, Sobol indices, and
the coverage of the Monte Carlo intervals (slow)."""

import dataclasses

import numpy as np
import pytest

from helpers import central_difference_jacobian
from identify.errors import UserError
from identify.sensitivity import (
    INPUT_NAMES,
    Case,
    Uncertainty,
    baseline_inputs,
    batch_evaluator,
    default_ranges,
    elasticities,
    local_sensitivity,
    monte_carlo,
    output_function,
    project_valid,
    sample_inputs,
    sobol_indices,
    summarise,
    valid_mask,
)
from sim import FrontWheelBlock, named_params

PAPER_SPEED = 56.3 / 3.6
IDX = {n: i for i, n in enumerate(INPUT_NAMES)}


@pytest.fixture(scope="module")
def case(a4):
    params = dataclasses.replace(named_params("paper_identified"), mechanisms=(FrontWheelBlock.at_tyre(a4),))
    # 200 ms holds every output but the rear touchdown (~600 ms): block, unblock, separation
    return Case(params, a4, PAPER_SPEED, duration=0.2, times=(0.05, 0.1, 0.2))


@pytest.fixture(scope="module")
def local(case):
    return local_sensitivity(case)


@pytest.fixture(scope="module")
def short_case(case):
    # 100 ms: enough for the maximum crush (65 ms); cheap for the Monte Carlo tests
    return dataclasses.replace(case, duration=0.1, times=(0.05, 0.1))


@pytest.fixture(scope="module")
def evaluate(short_case):
    return batch_evaluator(short_case, batch=512)


def test_autodiff_agrees_with_central_differences(case, local):
    import jax

    f = jax.jit(output_function(case))
    fd = central_difference_jacobian(lambda th: np.asarray(f(th)), local.inputs, rel_step=1e-5)
    ad = local.derivative
    exists = np.isfinite(local.outputs)
    assert exists.sum() == len(local.outputs) - 1  # all but the rear touchdown
    # entries that matter: a change of the output of at least 1e-6 of its value for a change of
    # the input of its own size (0.1 m for dz'); relative agreement 1e-4 there
    scale = np.abs(local.outputs)[:, None] / np.maximum(np.abs(local.inputs), 0.1)[None, :]
    matters = exists[:, None] & (np.abs(fd) > 1e-6 * scale)
    assert matters.sum() > 60
    rel = np.abs(ad[matters] - fd[matters]) / np.abs(fd[matters])
    assert rel.max() < 1e-4
    tiny = exists[:, None] & ~matters
    assert np.all(np.abs(ad[tiny] - fd[tiny]) <= 1e-6 * scale[tiny])
    assert np.all(np.isnan(ad[~exists]))


def test_elasticities_show_the_physics(local):
    e = dict(zip(local.output_names, local.elasticity))
    # a linear spring stopped from speed v: d_max = v sqrt(m / (k A)), so the elasticities of
    # the maximum crush are ~ +1 (speed), -1/2 (stiffness), +1/2 (mass); the pitch and the
    # tyres take a little of it
    assert e["max_crush"][IDX["speed"]] == pytest.approx(1.0, abs=0.05)
    assert e["max_crush"][IDX["k_compression"]] == pytest.approx(-0.5, abs=0.05)
    assert e["max_crush"][IDX["mass"]] == pytest.approx(0.5, abs=0.05)
    # the end of compression comes earlier for a stiffer car and (a quarter period of a
    # linear oscillator) hardly depends on the speed
    assert -0.5 < e["time_of_max_crush"][IDX["k_compression"]] < -0.2
    assert abs(e["time_of_max_crush"][IDX["speed"]]) < 0.05
    # the unloading does not act before the maximum crush (only on the sample after it that the
    # parabolic vertex reads)
    assert abs(e["max_crush"][IDX["k_restitution"]]) < 1e-4
    # rebound grows with restitution; dz' is a signed offset: no elasticity
    assert e["rebound_speed"][IDX["restitution"]] > 0.8
    assert np.all(np.isnan(local.elasticity[:, IDX["dz_contact"]]))


def test_elasticity_rules():
    d = np.ones((3, len(INPUT_NAMES)))
    x = np.ones(len(INPUT_NAMES)) * 2.0
    x[IDX["mu_slip"]] = 0.0
    e = elasticities(d, x, np.array([4.0, -1.0, np.nan]))
    assert e[0, IDX["k_compression"]] == pytest.approx(0.5)
    assert np.isnan(e[0, IDX["dz_contact"]]) and np.isnan(e[0, IDX["mu_slip"]])
    assert np.all(np.isnan(e[1:]))


def test_default_ranges_and_bounds(case):
    theta0 = baseline_inputs(case)
    assert theta0[IDX["k_compression"]] == 970e3 and theta0[IDX["speed"]] == PAPER_SPEED
    ranges = {n: (lo, hi) for n, lo, hi in default_ranges(theta0)}
    assert ranges["k_compression"] == pytest.approx((776e3, 1164e3))
    assert ranges["restitution"] == pytest.approx((0.12, 0.22))
    assert ranges["speed"] == pytest.approx((55.3 / 3.6, 57.3 / 3.6))
    low_e = theta0.copy()
    low_e[IDX["restitution"]] = 0.02
    assert dict((n, (lo, hi)) for n, lo, hi in default_ranges(low_e))["restitution"] == pytest.approx((0.0, 0.07))


def test_invalid_inputs_are_rejected_and_counted(case):
    theta0 = baseline_inputs(case)
    # restitution^2 <= k_r / k_c = 600/970 allows e <= 0.786: about half of 0.5..0.99 is invalid
    u = Uncertainty(uniform=(("restitution", 0.5, 0.99),))
    rows, rejected = sample_inputs(u, theta0, 2000, np.random.default_rng(1))
    assert rows.shape == (2000, len(INPUT_NAMES)) and np.all(valid_mask(rows))
    assert 0.35 < rejected / (rejected + 2000) < 0.55
    assert rows[:, IDX["restitution"]].max() <= np.sqrt(600 / 970)
    clipped, n = project_valid(np.array([theta0, np.where(np.arange(len(theta0)) == IDX["restitution"], 0.95, theta0)]))
    assert n == 1 and clipped[1, IDX["restitution"]] == pytest.approx(np.sqrt(600 / 970))
    with pytest.raises(UserError, match="physically valid"):
        sample_inputs(Uncertainty(uniform=(("restitution", 0.9, 0.99),)), theta0, 100, np.random.default_rng(0))


def test_covariance_sampling_reproduces_the_covariance(case):
    theta0 = baseline_inputs(case)
    names = ("k_compression", "restitution", "dz_contact")
    cov = np.array([[2.5e9, 1.0e2, 0.0], [1.0e2, 1.0e-4, -5e-5], [0.0, -5e-5, 1e-4]])
    mean = theta0[[IDX[n] for n in names]]
    u = Uncertainty(normal_names=names, mean=mean, covariance=cov)
    rows, rejected = sample_inputs(u, theta0, 40000, np.random.default_rng(2))
    assert rejected == 0
    sub = rows[:, [IDX[n] for n in names]]
    np.testing.assert_allclose(sub.mean(axis=0), mean, rtol=1e-3, atol=2e-4)
    got = np.cov(sub.T)
    sd = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(got / np.outer(sd, sd), cov / np.outer(sd, sd), atol=0.03)
    others = [i for n, i in IDX.items() if n not in names]
    assert np.all(rows[:, others] == theta0[others])
    assert u.spread()["restitution"] == pytest.approx(0.01)


def test_holding_an_input_conditions_the_covariance():
    cov = np.array([[4.0, 1.2, 0.0], [1.2, 1.0, 0.0], [0.0, 0.0, 9.0]])  # correlation 0.6 between the first two
    u = Uncertainty(normal_names=("k_compression", "speed", "restitution"), mean=np.array([1.0, 2.0, 0.2]),
                    covariance=cov, uniform=(("mass", 1600.0, 1700.0),))  # fmt: skip
    held = u.holding(["speed", "mass"])
    assert held.normal_names == ("k_compression", "restitution") and held.uniform == ()
    # var(k | speed) = 4 (1 - 0.6^2) = 2.56; the uncorrelated restitution keeps its 9
    np.testing.assert_allclose(held.covariance, [[2.56, 0.0], [0.0, 9.0]], atol=1e-12)
    np.testing.assert_allclose(held.mean, [1.0, 0.2])
    assert u.holding([]).varied == u.varied


def test_uncertainty_rejects_bad_input():
    with pytest.raises(UserError, match="unknown input"):
        Uncertainty(uniform=(("stiffness", 1.0, 2.0),))
    with pytest.raises(UserError, match="positive semi-definite"):
        Uncertainty(normal_names=("restitution", "dz_contact"), mean=np.zeros(2), covariance=np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises(UserError, match="low < high"):
        Uncertainty(uniform=(("restitution", 0.3, 0.2),))
    with pytest.raises(UserError, match="both"):
        Uncertainty(normal_names=("restitution",), mean=np.zeros(1), covariance=np.eye(1), uniform=(("restitution", 0.1, 0.2),))


def test_summarise_known_sample():
    y = np.column_stack([np.linspace(0.0, 1.0, 100001), np.r_[np.full(50001, np.nan), np.ones(50000)]])
    s = summarise(y, ["a", "b"])
    assert s["a"]["interval_90"] == pytest.approx([0.05, 0.95], abs=1e-9)
    assert s["a"]["interval_95"] == pytest.approx([0.025, 0.975], abs=1e-9)
    assert s["a"]["median"] == pytest.approx(0.5) and s["a"]["mean"] == pytest.approx(0.5)
    assert s["b"]["fraction_happening"] == pytest.approx(0.5, abs=1e-4) and s["b"]["std"] == 0.0


def test_monte_carlo_matches_the_linearisation(short_case, evaluate, local):
    # small input spreads: the output's spread is the linear one, sqrt(sum (J_ij sigma_j)^2)
    theta0 = baseline_inputs(short_case)
    names = ("k_compression", "restitution", "speed")
    sd = np.array([0.02 * 970e3, 0.005, 0.05])
    u = Uncertainty(normal_names=names, mean=theta0[[IDX[n] for n in names]], covariance=np.diag(sd**2))
    mc = monte_carlo(short_case, u, 2048, seed=3, evaluate=evaluate)
    assert mc.outputs.shape == (2048, len(short_case.output_names)) and mc.rejected == 0
    # four batches ran in threads: each row's outputs are still those of its own inputs
    np.testing.assert_array_equal(evaluate(mc.inputs[[1500, 5]]), mc.outputs[[1500, 5]])
    # the maximum crush (65 ms) is the same in the 200 ms run of ``local``
    linear_sd = np.sqrt(np.sum((local.derivative[0, [IDX[n] for n in names]] * sd) ** 2))
    summary = summarise(mc.outputs, short_case.output_names)["max_crush"]
    assert summary["std"] == pytest.approx(linear_sd, rel=0.08)
    lo, hi = summary["interval_90"]
    assert hi - lo == pytest.approx(2 * 1.645 * linear_sd, rel=0.1)


def test_sobol_indices_rank_the_inputs(short_case, evaluate):
    theta0 = baseline_inputs(short_case)
    u = Uncertainty(uniform=default_ranges(theta0, names=("k_compression", "k_restitution", "mass", "speed")))
    result = sobol_indices(short_case, u, base_n=128, seed=4, evaluate=evaluate)
    assert result["runs"] == 128 * 6 and result["inputs"] == ["k_compression", "k_restitution", "mass", "speed"]
    s = result["outputs"]["max_crush"]
    st = dict(zip(result["inputs"], s["ST"]))
    # stiffness +/-20 % moves d_max by ~ -/+10 %, mass +/-5 % by 2.5 %, speed +/-1 km/h by 1.8 %
    assert st["k_compression"] > 0.8
    assert st["k_compression"] > st["mass"] > 0.005 and st["speed"] > 0.005
    assert abs(st["k_restitution"]) < 1e-3  # the unloading does not act before the maximum crush
    assert sum(s["S1"]) == pytest.approx(1.0, abs=0.15)  # nearly additive
    with pytest.raises(UserError, match="power of 2"):
        sobol_indices(short_case, u, base_n=100, evaluate=evaluate)


@pytest.mark.slow
def test_monte_carlo_intervals_cover_the_truth(short_case):
    """1,000 synthetic reconstructions: the true inputs are fixed; a fit's estimate scatters
    around them with a known covariance; the 90 % Monte Carlo interval of the maximum crush
    drawn around each estimate must contain the true maximum crush in 90 +/- 3 % of them."""
    evaluate = batch_evaluator(short_case, batch=4096)  # 199,000 runs: big batches
    rng = np.random.default_rng(7)
    theta0 = baseline_inputs(short_case)
    names = ("k_compression", "k_restitution", "restitution", "dz_contact", "speed")
    cols = [IDX[n] for n in names]
    sd = np.array([0.05 * 970e3, 0.05 * 600e3, 0.01, 0.02, 0.2])
    corr = np.eye(5)
    corr[0, 1] = corr[1, 0] = 0.5
    cov = corr * np.outer(sd, sd)
    truth = evaluate(theta0[None, :])[0, 0]
    reps, per = 1000, 199
    root = np.linalg.cholesky(cov)
    estimates = theta0[cols][None, :] + rng.standard_normal((reps, 5)) @ root.T
    rows = []
    for est in estimates:
        u = Uncertainty(normal_names=names, mean=est, covariance=cov)
        rows.append(sample_inputs(u, theta0, per, rng)[0])
    crush = evaluate(np.concatenate(rows))[:, 0].reshape(reps, per)
    lo, hi = np.quantile(crush, [0.05, 0.95], axis=1)
    coverage = np.mean((lo <= truth) & (truth <= hi))
    assert 0.87 <= coverage <= 0.93, coverage


# ---------------------------------------------------------------- identify.report.comparison


def test_comparison_reproduces_the_papers_position_difference(identified_run, default_run, tmp_path):
    from identify.report.comparison import compare_runs, plot_histories

    c = compare_runs(identified_run, default_run)
    # docs/physics.md (the paper): default vs identified peak at dX = 0.099 m; where, and the
    # values at the silhouette times, against the two runs' x read directly
    dx = np.asarray(default_run.x) - np.asarray(identified_run.x)
    t = np.asarray(identified_run.t)
    assert c["peak_dx_m"] == pytest.approx(0.099, abs=0.002)
    assert c["peak_dx_m"] == pytest.approx(np.abs(dx).max(), rel=1e-12)
    assert c["peak_time_s"] == pytest.approx(t[np.argmax(np.abs(dx))], abs=1e-12)
    assert list(c["dx_at"]) == ["50", "100", "150", "200", "250", "300"]
    assert c["dx_at"]["100"] == pytest.approx(dx[np.argmin(np.abs(t - 0.1))], abs=1e-12)
    plot_histories(identified_run, default_run, ("identified", "default"), tmp_path / "h.png")
    assert (tmp_path / "h.png").stat().st_size > 10_000


def test_body_outline_follows_the_pose_formula(a4):
    from identify.report.comparison import body_outline

    rest = body_outline(a4, 0.0, 0.0, 0.0)
    np.testing.assert_allclose(rest, np.asarray(a4.silhouette_side), atol=1e-12)
    moved = body_outline(a4, 0.3, -0.02, 0.1)
    # a rigid motion: distances between outline points are kept
    d0 = np.linalg.norm(rest[:, None] - rest[None], axis=-1)
    d1 = np.linalg.norm(moved[:, None] - moved[None], axis=-1)
    np.testing.assert_allclose(d1, d0, atol=1e-12)
    # nose-down pitch: the front bumper (largest x) drops, the rear rises
    front, rear = np.argmax(rest[:, 0]), np.argmin(rest[:, 0])
    assert moved[front, 1] < rest[front, 1] - 0.02 and moved[rear, 1] > rest[rear, 1]
    # the CG moves by exactly (x, z)
    x_cg = float(a4.length - a4.front_overhang - a4.cg_to_front_axle)
    cg = body_outline(dataclasses.replace(a4, silhouette_side=((x_cg, float(a4.cg_height)),) * 3), 0.3, -0.02, 0.1)
    np.testing.assert_allclose(cg[0], [x_cg + 0.3, float(a4.cg_height) - 0.02], atol=1e-12)
