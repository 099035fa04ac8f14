"""The fit, as round trips: recordings made with ``sim`` (the fit's own model) plus noise go in,
and the fit must give back the parameters they were made with, with honest uncertainty, and
say what it cannot see. Round trips show the least squares, the covariance and the
identifiability rules work; accuracy on crashes the model did not make is measured on the
reference world (``benchmarks/accuracy.py``) and the NHTSA test (``tests/test_nhtsa.py``).
On its own recordings the model's own error is zero by construction, so these fits add none
(``model_error=NONE``); the last test checks the calibrated one is added."""

import dataclasses
import math

import numpy as np
import pytest

from helpers import synthetic_measurement, with_heave_the_model_cannot_follow
from identify.fitting.collision_fit import FitOptions, fit, log_scale_identifiability
from identify.fitting.model_error import NONE, table
from sim import named_params

TRUTH = {"k_compression": 970e3, "k_restitution": 600e3, "restitution": 0.17, "dz_contact": -0.21}


@pytest.fixture(scope="module")
def paper_measurement(a4):
    return synthetic_measurement(a4, named_params("paper_identified"))


@pytest.fixture(scope="module")
def paper_fit(a4, paper_measurement):
    return fit(paper_measurement, a4, model_error=NONE)


def test_recovers_the_papers_parameters_within_two_sigma(paper_fit):
    v, s = paper_fit.values, paper_fit.std
    assert v["k_compression"] == pytest.approx(970e3, rel=0.03)
    assert v["k_restitution"] == pytest.approx(600e3, rel=0.03)
    assert v["restitution"] == pytest.approx(0.17, abs=0.02)
    assert v["dz_contact"] == pytest.approx(-0.21, abs=0.03)
    for name, truth in TRUTH.items():
        assert abs(v[name] - truth) < 2 * s[name], name
        assert s[name] > 0
    assert abs(v["contact_time"] - 0.0004) < 3 * s["contact_time"]  # s; how fine: the next test
    assert all(ok for ok, _ in paper_fit.identified.values())
    assert "mu_face" not in paper_fit.values  # V-SIM's model unless asked for (FitOptions.face_friction)
    assert "length_scale" not in paper_fit.values  # no scale's uncertainty given: no scale fitted


def test_contact_time_is_resolved_to_a_tenth_of_a_millisecond_at_film_noise(a4):
    """At the sample film's tracking noise (0.3 mm) the contact time is fixed to about 0.04 ms:
    a fit that returned 0 for a contact 0.4 ms after the clock's zero would be 9 sigma off."""
    noise = {"x_m": 0.0003, "z_m": 0.0003, "pitch_rad": 0.0004, "front_wheel_angle_rad": 0.002,
             "rear_wheel_angle_rad": 0.002}
    r = fit(synthetic_measurement(a4, named_params("paper_identified"), noise=noise, contact_time=0.0004), a4, model_error=NONE)
    assert r.std["contact_time"] < 0.0001
    assert abs(r.values["contact_time"] - 0.0004) < 3 * r.std["contact_time"]


FILM_NOISE = {"x_m": 0.0003, "z_m": 0.0003, "pitch_rad": 0.0004, "front_wheel_angle_rad": 0.002,
              "rear_wheel_angle_rad": 0.002}


def test_a_films_scale_is_held_where_measured_its_error_carried_and_the_channels_estimate_shown(a4):
    """A film whose tape scale is 0.4 % long, measured to 0.5 %: every length it measures (x,
    z) is 0.4 % long, its wheel angles are not. The scale is a measurement, held where it was
    measured (1) with its sigma carried into the others: the impact speed (which the wheels'
    angles fix here) and the stiffness stay within two of their standard deviations, which the
    scale's share widens. Where the fitted channels alone would put it (the wheels' angles against x:
    near 1.004) is reported beside it with its pull. Fitted instead as a nuisance with the
    measurement as its prior (``hold_measured_scale`` off) the channels find it."""
    m = synthetic_measurement(a4, named_params("paper_identified"), noise=FILM_NOISE, contact_time=0.0004)
    long = {k: v * 1.004 if k in ("x_m", "z_m") else v for k, v in m.channels.items()}
    film = dataclasses.replace(m, channels=long, impact_speed_mps=None, impact_speed_sigma=None,
                               length_scale_sigma=0.005)
    r = fit(film, a4, model_error=NONE)
    assert r.values["length_scale"] == 1.0 and r.std["length_scale"] == pytest.approx(0.005)
    p = r.pulls()["length_scale"]
    assert p["held"] and (p["held_at"], p["held_std"]) == (1.0, 0.005)
    assert abs(p["value"] - 1.004) < 2 * p["std"] and p["std"] < 0.001
    assert p["pull"] == pytest.approx((p["value"] - 1.0) / math.hypot(0.005, p["std"]))
    speed = 56.3 / 3.6
    for name, truth in (("impact_speed", speed), ("k_compression", 970e3)):
        assert abs(r.values[name] - truth) < 2 * r.std[name]
    # the scale's error is carried into what depends on it (measured: the speed held at the
    # approach line, its std 0.080 m/s with the scale's 0.5 %, 0.078 of it the scale's share;
    # correlations -0.98 and -0.97)
    i = r.names.index("length_scale")
    assert r.correlation[i, r.names.index("impact_speed")] < -0.9  # held 1 sigma long, the speed 1 sigma fast
    assert abs(r.correlation[i, r.names.index("dz_contact")]) > 0.9
    from identify.report.markdown import prior_lines

    line = next(x for x in prior_lines(r.pulls()) if x.startswith("the film's scale"))
    assert "measured 1 +- 0.005, the fitted channels alone 1.00" in line
    assert line.endswith("held where the recording measured it, 1 +- 0.005") and "conflict" not in line
    free = fit(film, a4, model_error=NONE, options=dataclasses.replace(FitOptions(), hold_measured_scale=False))
    assert abs(free.values["length_scale"] - 1.004) < 2 * free.std["length_scale"] and free.std["length_scale"] < 0.001
    assert free.pulls()["length_scale"]["pull"] == pytest.approx((free.values["length_scale"] - 1.0) / 0.005)
    without = fit(dataclasses.replace(film, length_scale_sigma=None), a4, model_error=NONE)
    assert "length_scale" not in without.values and "length_scale" not in without.pulls()


def test_fit_rms_is_the_noise_level(paper_fit):
    assert paper_fit.rms["x_m"] == pytest.approx(0.002, rel=0.15)
    assert paper_fit.reduced_chi2 == pytest.approx(1.0, abs=0.2)
    assert paper_fit.converged and paper_fit.starts_at_best >= 2


def test_starting_from_elsewhere_reaches_the_same_minimum(paper_fit):
    # The first start is V-SIM's defaults; the others are random; most must agree.
    assert paper_fit.starts_at_best >= paper_fit.starts - 2


def test_restitution_not_identified_when_film_ends_in_compression(a4, paper_measurement, paper_fit):
    # Same shapes (so the compiled fit is reused): samples after 55 ms are marked unmeasured.
    m = paper_measurement
    late = m.t > 0.055
    short = dataclasses.replace(m, sigma={k: np.where(late, np.nan, v) for k, v in m.sigma.items()})
    r = fit(short, a4, model_error=NONE)
    assert r.identified["k_compression"][0]
    for name in ("k_restitution", "restitution"):
        ok, reason = r.identified[name]
        assert not ok and "restitution phase" in reason, reason


@pytest.mark.slow
def test_force_height_not_identified_from_compression_alone_without_pitch(a4, paper_measurement):
    # With wheel angles or the rebound in the data, dz' shows (the axle speeds carry the
    # pitch rate; the rebound loses energy to pitch). With x alone, during compression,
    # it does not.
    m = paper_measurement.window(-0.02, 0.060)
    flat = dataclasses.replace(m, channels={"x_m": m.channels["x_m"]}, sigma={"x_m": m.sigma["x_m"]})
    r = fit(flat, a4, model_error=NONE)
    assert r.identified["k_compression"][0]
    ok, reason = r.identified["dz_contact"]
    assert not ok and "no pitch or height channel" in reason, reason


def test_autocorrelation_time_is_one_for_white_noise_and_grows_with_correlation():
    from video.filters import integrated_autocorrelation_time

    rng = np.random.default_rng(3)
    white = rng.normal(size=2000)
    assert integrated_autocorrelation_time(white) == pytest.approx(1.0, abs=0.3)
    ar = np.zeros(2000)
    for i in range(1, 2000):  # AR(1), rho = 0.8: tau = (1 + rho) / (1 - rho) = 9
        ar[i] = 0.8 * ar[i - 1] + white[i]
    assert integrated_autocorrelation_time(ar) == pytest.approx(9.0, rel=0.3)


def test_correlated_tracking_errors_widen_the_intervals(a4, paper_measurement, paper_fit):
    # The same measurement with its x noise replaced by a slowly wandering error of the same
    # size: n correlated samples are worth fewer independent ones, and the fit must say so.
    m = paper_measurement
    rng = np.random.default_rng(5)
    e = np.zeros(len(m.t))
    for i in range(1, len(e)):
        e[i] = 0.9 * e[i - 1] + rng.normal(0.0, 0.002 * np.sqrt(1 - 0.81))
    wandering = dataclasses.replace(m, channels={**m.channels, "x_m": m.channels["x_m"] - _white_part(m) + e})
    r = fit(wandering, a4, model_error=NONE)
    assert r.correlation_time["x_m"] > 5 and paper_fit.correlation_time["x_m"] < 1.5
    assert r.std_data["k_compression"] > 1.5 * paper_fit.std_data["k_compression"]
    # 20 frames before contact cannot tell their own correlation time (1.8 here, against 19):
    # the covariance takes the crash's, so the speed is not claimed closer than they measure it
    assert r.correlation_time["x_m before contact"] == r.correlation_time["x_m"]
    assert r.std_data["impact_speed"] > 1.3 * paper_fit.std_data["impact_speed"]


def _white_part(m):
    """The Gaussian noise synthetic_measurement added to x_m (its first draw with seed 0)."""
    from helpers import NOISE

    rng = np.random.default_rng(0)
    return rng.normal(0.0, NOISE["x_m"], len(m.t))


def test_a_channel_only_shown_or_a_renamed_car_runs_the_same_compiled_programs(a4, paper_measurement, paper_fit):
    """A channel the recording derives (shown, not fitted) stays in the compiled fit with
    weight 0: the fit runs the programs of the same recording with it fitted (a compile is
    30-55 s, the solve ~1 s), and the channel counts nowhere in the fit. A car's names and
    outline are no part of them either."""
    import identify.fitting.collision_fit as collision_fit
    from identify.fitting.collision_fit import FitOptions

    compiled = collision_fit._solve_jit._cache_size(), collision_fit._finish_jit._cache_size()
    shown = dataclasses.replace(paper_measurement, derived=("front_wheel_angle_rad",))
    r = fit(shown, a4, model_error=NONE, options=FitOptions(starts=1))
    assert (collision_fit._solve_jit._cache_size(), collision_fit._finish_jit._cache_size()) == compiled
    assert "front_wheel_angle_rad" not in r.rms and "front_wheel_angle_rad" not in r.correlation_time
    n = len(paper_measurement.t)
    assert r.dof == paper_fit.dof - n  # its samples are no residuals
    assert r.rms["x_m"] == pytest.approx(paper_fit.rms["x_m"], rel=0.05)
    # nor does the same car under another name compile anything (a vehicle's names are static)
    renamed = dataclasses.replace(a4, key="a4_copy", name="the same car")
    fit(paper_measurement, renamed, model_error=NONE, options=FitOptions(starts=1))
    assert (collision_fit._solve_jit._cache_size(), collision_fit._finish_jit._cache_size()) == compiled


def test_a_fit_that_does_not_converge_is_one_clear_error(a4, paper_measurement, paper_fit, monkeypatch):
    # A solver that stops where it started, unconverged (as one Levenberg-Marquardt step from
    # V-SIM's defaults does), leaves the fit far from the data. Stood in for by one that does
    # not move: the real one with another step limit would be compiled again (30 s).
    import jax.numpy as jnp

    import identify.fitting.collision_fit as collision_fit
    from identify.errors import UserError
    from identify.fitting.collision_fit import FitOptions

    def stays(spec, channels, n_out, options, data, u0):
        r = collision_fit._finish_jit(spec, channels, n_out, options, data, u0)[0]
        return u0, jnp.sum(r * r), jnp.asarray(False)

    monkeypatch.setattr(collision_fit, "_solve_jit", stays)
    with pytest.raises(UserError, match="did not converge"):
        fit(paper_measurement, a4, options=FitOptions(starts=1))


def test_a_solves_cost_is_the_sum_of_squares_at_the_point_it_returns(a4, paper_measurement, monkeypatch):
    """The cost the starts are ranked by is read from the solver's state (its last accepted
    point's residuals), not simulated again: it must be the residuals' sum of squares at the
    point returned."""
    import identify.fitting.collision_fit as collision_fit
    from identify.fitting.collision_fit import FitOptions

    real, seen = collision_fit._solve_jit, []

    def checked(spec, channels, n_out, options, data, u0):
        u, cost, ok = real(spec, channels, n_out, options, data, u0)
        r = collision_fit._finish_jit(spec, channels, n_out, options, data, u)[0]
        seen.append((float(cost), float(np.sum(np.square(r)))))
        return u, cost, ok

    monkeypatch.setattr(collision_fit, "_solve_jit", checked)
    fit(paper_measurement, a4, model_error=NONE, options=FitOptions(starts=2))
    assert len(seen) >= 2
    for cost, at_u in seen:
        assert cost == pytest.approx(at_u, rel=1e-9)


@pytest.mark.parametrize("transform, kw, value, words", [
    ("logit", {"lower": 0.05, "upper": 1.2}, 0.0511, "at its lower bound 0.05"),
    ("logit", {"lower": 0.05, "upper": 1.2}, 1.19, "at its upper bound 1.2"),
    ("logit", {"lower": 0.05, "upper": 1.2}, 0.07, ""),
    ("tanh", {"scale": 0.010}, -0.0099, "at its lower bound -0.01"),
    ("tanh", {"scale": 0.010}, 0.0097, ""),
    ("log", {"scale": 1e6}, 3e6, ""),
    ("log", {"scale": 1e6}, 9.7e12, "far outside any plausible value (9.7e+12 m, 9.7e+06 times its scale)"),
    ("log", {"scale": 1e6}, 1e-3, "far outside any plausible value"),
    ("log", {"scale": 1e6}, 0.9e9, ""),
])
def test_a_value_within_one_percent_of_a_bound_is_at_its_bound(transform, kw, value, words):
    from identify.fitting.model import FreeParameter

    where = FreeParameter("p", "m", transform, **kw).at_bound(value)
    assert (where.startswith(words) if words else where == ""), where


def test_a_start_at_a_bound_is_moved_inside_where_the_fit_can_still_move_it():
    """A fit started from an earlier one that ended at a bound must not inherit a flat
    transform (a logit at 17: slope 4e-8); every start of the fit is moved within 1 % of the
    range from the bound, and a start inside is kept as it is."""
    import jax

    from identify.fitting.collision_fit import FitOptions, _starting_points
    from identify.fitting.model import FreeParameter

    mu = FreeParameter("mu_face", "1", "logit", lower=0.0, upper=1.0, floor_is_physical=True)
    dz = FreeParameter("dz_contact", "m", "tanh", scale=0.6)
    k = FreeParameter("k_compression", "N/m^3", "log", scale=1e6)
    starts = _starting_points((mu, dz, k), {"mu_face": 1.0 - 2e-8, "dz_contact": -0.6, "k_compression": 1e-3},
                              FitOptions(starts=1))[0]
    assert float(mu.to_physical(starts[0])) == pytest.approx(0.99)
    assert float(jax.grad(mu.to_physical)(starts[0])) > 5e-3
    assert float(dz.to_physical(starts[1])) == pytest.approx(-0.588)
    assert float(k.to_physical(starts[2])) == pytest.approx(1e-3)  # no bound: as given
    inside = _starting_points((mu, dz), {"mu_face": 0.3, "dz_contact": 0.1}, FitOptions(starts=1))[0]
    assert [float(mu.to_physical(inside[0])), float(dz.to_physical(inside[1]))] == pytest.approx([0.3, 0.1])
    # a physical floor is an answer, not a stop: a friction of 0 starts at 0
    assert float(mu.to_physical(_starting_points((mu,), {"mu_face": 0.0}, FitOptions(starts=1))[0][0])) < 1e-8
    floor = dataclasses.replace(mu, floor_is_physical=False)  # a range's floor is a stop
    assert float(floor.to_physical(_starting_points((floor,), {"mu_face": 0.0}, FitOptions(starts=1))[0][0])) == \
        pytest.approx(0.01)


def test_a_log_scale_parameter_known_to_no_better_than_20_percent_is_not_identified():
    from identify.fitting.model import FreeParameter

    free = (FreeParameter("engine_impact.k_rear", "N/m", "log", scale=1e6),
            FreeParameter("engine_impact.k_engine", "N/m", "log", scale=1e6),
            FreeParameter("k_compression", "N/m^3", "log", scale=1e6),  # judged by its own rule
            FreeParameter("engine_impact.gap", "m", "logit", lower=0.05, upper=1.2))
    values = {"engine_impact.k_rear": 1.7e5, "engine_impact.k_engine": 1.2e6, "k_compression": 1e6,
              "engine_impact.gap": 0.15}
    std = {"engine_impact.k_rear": 1.18e5, "engine_impact.k_engine": 0.2e6, "k_compression": 5e5,
           "engine_impact.gap": 0.1}
    out = log_scale_identifiability(free, values, std)
    assert list(out) == ["engine_impact.k_rear"]  # 69 %; k_engine 17 % is identified
    assert out["engine_impact.k_rear"] == (False, "not identified (std 69 %): the recorded motion barely changes"
                                                  " when it changes")
    std["engine_impact.k_engine"] = float("nan")
    assert "engine_impact.k_engine" in log_scale_identifiability(free, values, std)


def test_a_second_reason_not_to_identify_keeps_the_first():
    from types import SimpleNamespace

    from identify.fitting.collision_fit import FitResult

    fr = SimpleNamespace(identified={"k_restitution": (False, "not identified (std 108 %): the motion barely changes")})
    FitResult.mark_not_identified(fr, "k_compression", "not identified: it depends on the model")
    FitResult.mark_not_identified(fr, "k_restitution", "not identified: at its upper bound, where the fit stopped it")
    assert fr.identified == {
        "k_compression": (False, "not identified: it depends on the model"),
        "k_restitution": (False, "not identified (std 108 %): the motion barely changes; and at its upper bound,"
                                 " where the fit stopped it")}


def test_a_contact_time_the_bound_stopped_is_reported_not_identified(a4, paper_measurement):
    """The recording's clock 25 ms off (contact at -25 ms, the model allows +-10 ms): the fit
    parks the contact time at its bound, and must not report that value as measured."""
    from identify.fitting.collision_fit import FitOptions

    # on the same clock as the others (one compile), the model's contact 24.6 ms before t = 0;
    # one fit: the misfit-weighted refits, which report the bound alike, took 39 of this
    # test's 86 s (run alone, the machine loaded)
    late = synthetic_measurement(a4, named_params("paper_identified"), contact_time=-0.0246)
    r = fit(late, a4, model_error=NONE, options=FitOptions(starts=1, misfit_weights=False))
    assert "contact_time" in r.at_bound and "bound" in r.at_bound["contact_time"]
    ok, reason = r.identified["contact_time"]
    assert not ok and "where the fit stopped it" in reason
    from identify.identification import fit_warnings

    assert any(w.startswith("contact_time ended at its ") and "bound" in w and "the fit's range, not the recording" in w
               for w in fit_warnings(r))


def test_a_measured_contact_is_held_and_the_measured_speed_is_a_prior_their_pulls_reported(
        a4, paper_measurement, paper_fit):
    from identify.fitting.collision_fit import FitOptions

    """A recording that measures first contact apart from the motion (load cells) gives t = 0
    a sigma: the fit does not turn it as a knob, it holds it where the measurement and the
    fitted channels' own estimate combine (inverse-variance weights; here without the model's
    own error, so the channels weigh more), carries its sigma into the other parameters, and
    reports where the channels alone put it; a contact 5 ms off against a 1 ms sigma is a
    conflict between model and recording, and then not combined: held where measured. The
    measured impact speed (one sigma off in the
    synthetic recording) is a prior, its pull reported."""
    speed = paper_fit.pulls()["impact_speed"]
    assert speed["prior"] == pytest.approx(paper_measurement.impact_speed_mps)
    assert abs(speed["pull"]) < 3 and not speed["conflict"]
    assert "contact_time" not in paper_fit.pulls()  # no independent measurement of contact: no prior
    # the synthetic recording's t = 0 is 5 ms before the model's contact; its load cells are
    # said to put contact at t = 0 +- 1 ms
    off = dataclasses.replace(synthetic_measurement(a4, named_params("paper_identified"), contact_time=0.005),
                              contact_time_sigma=0.001)
    # the model's own error only where the channels' contact can be weighed against the measured one
    # (a film's table has it; measured 0 there), so the channels weigh by their data alone
    from identify.fitting.collision_fit import CONTACT_FROM_MOTION
    from identify.fitting.model_error import ModelError

    contact_only = ModelError(absolute={CONTACT_FROM_MOTION: 0.0})
    r = fit(off, a4, model_error=contact_only)
    pull = r.pulls()["contact_time"]
    assert pull["held"] and pull["prior"] == 0.0 and pull["prior_std"] == 0.001
    # the channels alone put it 4.47 ms late (measured; 4.32 ms with the wheels' spin, and 5.04 ms
    # from a start at 4.7 ms: two basins); a start at the measured contact alone stays there
    assert 0.004 < pull["value"] < 0.0055
    assert pull["conflict"] and pull["pull"] == pytest.approx(pull["value"] / np.hypot(0.001, pull["std"]))
    assert pull["std"] == pytest.approx(pull["std_data"])
    # two estimates that far apart are not combined: held where measured
    assert (pull["held_at"], pull["held_std"]) == (0.0, 0.001)
    assert r.values["contact_time"] == 0.0 and r.std["contact_time"] == pytest.approx(0.001)
    # the report and the console say it in the reader's units, the measurements first
    from identify.report.markdown import prior_lines

    lines = prior_lines(r.pulls())
    assert lines[0].startswith("first contact: measured 0 +- 1 ms, the fitted channels alone 4.")
    assert "held where the recording measured it, 0 +- 1 ms" in lines[0] and "conflict" in lines[0]
    assert lines[1].startswith("impact speed: measured") and "km/h" in lines[1] and "conflict" not in lines[1]
    # and the result's warnings say it before any number
    from identify.identification import fit_warnings

    warned = fit_warnings(r)
    assert len(warned) == 1 and warned[0].startswith("contact_time: the fitted channels alone put it at 0.004")
    assert "from where the recording measured it (0 +- 0.001)" in warned[0] and "disagree there" in warned[0]
    assert "held where the recording measured it, 0" in warned[0]
    assert fit_warnings(paper_fit) == []
    # a contact measured 4.7 ms after t = 0 (a film's sub-frame contact seen in the picture)
    # is where the prior sits: the same motion then agrees with it
    # a table that cannot weigh the channels' contact (a sensor recording's): the measured contact
    # stays a prior, which the motion outweighs (4.86 ms measured; 4.26 before the model had the
    # wheels' spin, whose angles now say more of the contact): near the channels' own, as above
    prior = fit(off, a4, model_error=NONE, options=FitOptions(starts=1)).pulls()["contact_time"]
    assert "held" not in prior and 0.004 < prior["value"] < 0.0055 and prior["conflict"]
    seen = fit(dataclasses.replace(off, contact_time_s=0.0047), a4, model_error=contact_only)
    pull = seen.pulls()["contact_time"]
    assert pull["prior"] == 0.0047 and not pull["conflict"] and abs(pull["pull"]) < 1.0
    assert seen.values["contact_time"] == pytest.approx(seen.pulls()["contact_time"]["held_at"], abs=1e-9)
    # held where the two combine, weighted by their inverse variances
    w_seen, w_model = 0.001**-2, pull["std"] ** -2
    assert pull["held_at"] == pytest.approx((0.0047 * w_seen + pull["value"] * w_model) / (w_seen + w_model))
    assert seen.std["contact_time"] == pytest.approx((w_seen + w_model) ** -0.5)
    assert "held at the two combined" in prior_lines(seen.pulls())[0]
    # within half the measurement's sigma of it: 5.11 ms measured
    # (the model with the wheels' spin puts the true 5.0 ms a little later than 4.7; 4.70 before)
    assert abs(seen.values["contact_time"] - 0.0047) < 0.0005
    # the contact's sigma is carried into the parameters that depend on it
    i, k = seen.names.index("contact_time"), seen.names.index("k_compression")
    assert abs(seen.correlation[i, k]) > 0.5
    assert seen.covariance[i, i] == pytest.approx(seen.pulls()["contact_time"]["held_std"] ** 2)


def test_where_the_channels_alone_run_to_the_contacts_bound_it_is_said_and_not_combined(a4):
    """The channels' own contact estimate that the fit's range stopped (here the model's
    contact 13 ms after the one measured, the range +-10 ms) is the range's, not a measurement:
    it is not combined with the measured contact (held where measured), and the pull, the
    warning and the report say it ran to the bound."""
    from identify.fitting.collision_fit import CONTACT_FROM_MOTION, FitOptions
    from identify.fitting.model_error import ModelError
    from identify.identification import fit_warnings
    from identify.report.markdown import prior_lines

    off = dataclasses.replace(synthetic_measurement(a4, named_params("paper_identified"), contact_time=0.013),
                              contact_time_sigma=0.001)
    r = fit(off, a4, model_error=ModelError(absolute={CONTACT_FROM_MOTION: 0.0}),
            options=FitOptions(starts=1, misfit_weights=False))
    pull = r.pulls()["contact_time"]
    assert pull["held"] and "upper bound" in pull["at_bound"] and pull["value"] > 0.0098
    assert pull["held_at"] == 0.0 and pull["held_std"] == 0.001
    assert r.values["contact_time"] == 0.0 and r.std["contact_time"] == pytest.approx(0.001)
    assert pull["conflict"]  # 10 ms at least, against 1 ms: a conflict however far beyond the bound it lies
    warned = [w for w in fit_warnings(r) if w.startswith("contact_time: the fitted channels alone ran at its upper")]
    assert len(warned) == 1 and "cannot place it within the fit's range" in warned[0]
    assert "disagree there" in warned[0] and "held where the recording measured it, 0 +- 0.001" in warned[0]
    line = prior_lines(r.pulls())[0]
    assert "ran at its upper bound" in line and "held where measured, 0 +- 1 ms" in line


def test_a_channel_the_model_cannot_follow_no_longer_moves_what_the_others_measure(a4, paper_measurement):
    """A heave and a pitch the model cannot follow (``with_heave_the_model_cannot_follow``),
    added to a recording whose contact was seen to 0.3 ms. Fitted with
    the recording's sigmas, their misfit drags the contact 1.4 ms from where it was seen,
    k_compression 4 % and the speed 1.4 %; weighted by each channel's own misfit
    (``FitOptions.misfit_weights``, the default), x and the seen contact decide them again,
    and the seen contact's sigma is not widened by the other channels' misfit."""
    from identify.fitting.collision_fit import FitOptions

    m = with_heave_the_model_cannot_follow(paper_measurement)
    # the seen contact a prior, not held where it was seen, so that the misfit can move it
    plain = fit(m, a4, model_error=NONE, options=FitOptions(starts=1, misfit_weights=False, hold_measured_contact=False))
    weighted = fit(m, a4, model_error=NONE, options=FitOptions(starts=1, hold_measured_contact=False))
    speed = 56.3 / 3.6
    # measured 2026-11-25: plain contact -1.00 ms, k -3.8 %, speed +1.37 %; weighted 0.36 ms, +0.05 %, +0.15 %
    assert abs(plain.values["contact_time"] - 0.0004) > 0.001 and abs(plain.speed / speed - 1) > 0.01
    assert abs(plain.values["k_compression"] / TRUTH["k_compression"] - 1) > 0.03
    assert plain.sigma_widened == {}
    assert abs(weighted.values["contact_time"] - 0.0004) < 0.00015
    assert abs(weighted.values["k_compression"] / TRUTH["k_compression"] - 1) < 0.01
    assert abs(weighted.speed / speed - 1) < 0.003
    for name in ("k_compression", "restitution", "contact_time"):
        truth = 0.0004 if name == "contact_time" else TRUTH[name]
        assert abs(weighted.values[name] - truth) < 2 * weighted.std[name], name
    assert weighted.std["contact_time"] < 0.0003  # the seen contact's own sigma, not widened
    assert weighted.sigma_widened["z_m"] > 10 and weighted.sigma_widened["pitch_rad"] > 10
    assert weighted.sigma_widened["x_m"] < 1.5 and weighted.misfit["x_m"] < 1.5
    assert weighted.misfit["z_m"] > 10  # the covariance widens z by its misfit, in the recording's sigmas
    assert weighted.converged
    # the plain fit's std with each channel widened by its own misfit at its own optimum (what
    # discovery judges a candidate's determinacy by): x no longer spread by the heave's misfit,
    # about the weighted fit's (measured: k_compression 9.1e3 against 2.8e4 widened as a whole,
    # 8.6e3 weighted; contact 0.26 ms against 0.77 ms, 0.24 ms weighted)
    assert weighted.std_data_by_channel == {}
    for name in ("k_compression", "contact_time"):
        own = plain.std_data_by_channel[name]
        assert own < 0.5 * plain.std_data[name] and 1 / 1.5 < own / weighted.std_data[name] < 1.5, name


def test_the_approach_keeps_its_own_weight_when_the_crash_is_missed(a4, monkeypatch):
    """An x the model cannot follow after contact (a 6 mm wobble), at a film's noise, with no
    measured speed to lean on: weighted by misfit, x's sigma widens 20-fold, and the frames
    before contact, which the model follows exactly, must not widen with it (they measure
    the speed). Measured: speed +0.023 % (std 0.106 %, the approach's correlation time floored
    by the crash's in the covariance); with the approach in x's one group, +0.087 % (0.135 %)."""
    import identify.fitting.collision_fit as collision_fit
    from identify.fitting.collision_fit import BEFORE_CONTACT, FitOptions

    # x, z and pitch fitted; the wheels' angles only shown, so that the fit runs the programs
    # compiled for the others (``_stack``: one compile)
    wheels = ("front_wheel_angle_rad", "rear_wheel_angle_rad")
    noise = {"x_m": 3e-4, "z_m": 3e-4, "pitch_rad": 5e-4, **{c: 0.02 for c in wheels}}
    m = synthetic_measurement(a4, named_params("paper_identified"), noise=noise, speed_sigma=0.0)
    t = m.t
    wobble = 0.006 * np.where(t > 0, np.sin(2 * np.pi * t / 0.06) * np.exp(-t / 0.08), 0.0)
    m = dataclasses.replace(m, channels={**m.channels, "x_m": m.channels["x_m"] + wobble}, derived=wheels)
    assert m.impact_speed_sigma == 0.0  # no prior: the frames alone measure the speed
    speed = 56.3 / 3.6

    fitted = FitOptions(starts=1, hold_measured_speed=False)  # the speed fitted, as where the option is off
    fr = fit(m, a4, model_error=NONE, options=fitted)
    assert fr.sigma_widened["x_m"] > 10 and fr.sigma_widened.get("x_m" + BEFORE_CONTACT, 1.0) < 2.0
    monkeypatch.setattr(collision_fit, "MIN_BEFORE_CONTACT", 10**9)  # the approach in x's one group
    one = fit(m, a4, model_error=NONE, options=fitted)
    assert "x_m" + BEFORE_CONTACT not in one.sigma_widened
    assert abs(fr.speed / speed - 1) < 0.0004 < 0.0006 < abs(one.speed / speed - 1)
    assert abs(fr.speed - speed) < fr.std["impact_speed"] < one.std["impact_speed"]


def test_a_films_speed_is_held_at_its_approach_line_not_where_the_crash_would_put_it(a4):
    """A film (no header speed) whose x runs ahead after contact by 3 cm/s, a speed its approach
    does not show, as a model's misreading of the crash can: fitted, the speed took it up and
    was reported +0.22 % at 0.055 % (3.9 sigma off, scored world 910028's failure); held at
    the approach line (``FitOptions.hold_measured_speed``) it stays there, -0.053 % at 0.094 %,
    and where the channels alone would put it is reported beside it with its pull."""
    from identify.fitting.collision_fit import approach_speed

    wheels = ("front_wheel_angle_rad", "rear_wheel_angle_rad")
    noise = {"x_m": 3e-4, "z_m": 3e-4, "pitch_rad": 5e-4, **{c: 0.02 for c in wheels}}
    m = synthetic_measurement(a4, named_params("paper_identified"), noise=noise, speed_sigma=0.0)
    ahead = 0.03 * np.where(m.t > 0, m.t, 0.0)
    m = dataclasses.replace(m, channels={**m.channels, "x_m": m.channels["x_m"] + ahead}, derived=wheels,
                            impact_speed_sigma=None)
    speed = 56.3 / 3.6
    line, white = approach_speed(m)
    held = fit(m, a4, model_error=NONE, options=FitOptions(starts=1))
    assert held.values["impact_speed"] == pytest.approx(line, rel=1e-12) and held.speed == pytest.approx(line, rel=1e-12)
    assert abs(held.speed - speed) < 2 * held.std["impact_speed"] and held.std["impact_speed"] >= white
    p = held.pulls()["impact_speed"]
    assert p["held"] and p["prior"] == p["held_at"] == pytest.approx(line, rel=1e-12)
    assert p["prior_std"] == pytest.approx(held.std["impact_speed"], rel=1e-9)
    assert p["value"] > line and p["pull"] == pytest.approx((p["value"] - line) / math.hypot(p["prior_std"], p["std"]))
    fitted = fit(m, a4, model_error=NONE, options=FitOptions(starts=1, hold_measured_speed=False))
    assert "impact_speed" not in fitted.held_measured
    assert abs(fitted.speed - speed) > 3 * fitted.std["impact_speed"] and abs(fitted.speed - speed) > abs(held.speed - speed)


def test_a_films_contact_seen_in_the_picture_enters_the_fit_as_a_measurement():
    """``measurement_from_tracks``: a contact the picture showed comes with its sigma and its
    sub-frame instant; one from the deceleration onset (the fitted motion's own) adds none."""
    from identify.recordings.load import measurement_from_tracks
    from video.types import Tracks

    t = np.arange(-10, 40) / 1000.0
    base = dict(t=t, channels={"x_m": 15.0 * np.minimum(t, 0.0)}, sigma={"x_m": np.full(len(t), 1e-3)},
                events_ms={}, contact_frame=10, fps=1000.0, scale_m_per_px=0.005, scale_sigma=1e-6,
                impact_speed_mps=15.0, direction=1, contact_offset_s=-0.0003)
    m = measurement_from_tracks(Tracks(**base, contact_sigma_s=0.001), "film.mp4")
    assert (m.contact_time_s, m.contact_time_sigma) == (-0.0003, 0.001)
    m = measurement_from_tracks(Tracks(**base), "film.mp4")
    assert (m.contact_time_s, m.contact_time_sigma) == (0.0, None)


def test_the_calibrated_model_error_is_added_in_quadrature_and_can_decide_identifiability(a4, paper_measurement,
                                                                                         paper_fit):
    """By default the fit adds the calibrated model error (``identify/fitting/model_error.json``) to the
    data's std and to the covariance's diagonal, and a parameter whose model error exceeds its
    limit is not identified, saying so, however well the data fix it (k_restitution). The
    paper's model lifts the rear wheels at 38 ms: the table measured where the rear lifts sets
    the contact height's error, and says so."""
    r = fit(paper_measurement, a4)
    me, where = table("film").in_regimes(("rear_lifted",), r.values)  # the recording measured positions
    assert r.model_error_where == where and "with the rear wheels lifting" in where["dz_contact"]
    ok, reason = r.identified["k_restitution"]
    assert not ok and "the model's own error" in reason, reason
    assert r.std_data == pytest.approx(paper_fit.std_data, rel=1e-6)
    for name in r.names:
        model = me.std(name, r.values[name])
        assert r.std_model[name] == pytest.approx(model)
        assert r.std[name] == pytest.approx(np.hypot(r.std_data[name], model), rel=1e-9)
        assert r.covariance[r.names.index(name), r.names.index(name)] == pytest.approx(r.std[name] ** 2, rel=1e-9)
    assert r.std_model["k_compression"] > 3 * r.std_data["k_compression"]  # the data alone would claim ~0.1 %
    assert r.std_model["contact_time"] == me.absolute["contact_time"] > 0  # a film's contact: absolute, s
    ok, reason = r.identified["k_restitution"]
    assert me.relative["k_restitution"] > 0.2 and not ok and "model's own error" in reason, reason


def test_a_fit_missing_x_beyond_any_calibration_fit_has_the_model_error_scaled_by_the_ratio(a4, paper_measurement,
                                                                                            paper_fit):
    """A table that says the fits it was measured on missed x by at most ``misfit_x_m``: a fit
    missing it by more has every model error scaled by the ratio, and says so; within it,
    the table as it is."""
    from identify.fitting.model_error import ModelError
    from identify.identification import fit_warnings

    rms = paper_fit.rms["x_m"]
    for limit, factor in ((rms / 3.0, 3.0), (2.0 * rms, 1.0)):
        me = ModelError(relative={"k_compression": 0.05}, absolute={"restitution": 0.004}, source="t", misfit_x_m=limit)
        r = fit(paper_measurement, a4, model_error=me)
        assert r.std_model["k_compression"] == pytest.approx(0.05 * factor * r.values["k_compression"], rel=1e-6)
        assert r.std_model["restitution"] == pytest.approx(0.004 * factor, rel=1e-6)
        assert r.std["restitution"] == pytest.approx(np.hypot(r.std_data["restitution"], 0.004 * factor), rel=1e-9)
        scaled = [n for n, w in r.model_error_where.items() if "scaled by 3" in w]
        assert scaled == (["k_compression", "restitution"] if factor > 1 else [])
        # and the user is warned, once
        warned = [w for w in fit_warnings(r) if w.startswith("every parameter's model error scaled by 3")]
        assert len(warned) == (1 if factor > 1 else 0) and all("mm RMS" in w for w in warned)
