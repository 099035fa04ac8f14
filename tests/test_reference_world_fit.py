"""Identification on data our model did not make: a clean ISO-MME recording of the reference
world (``synth``: its own car model, with an engine on mounts that does not reach the
barrier, accelerometers with noise and offsets, a speed trap), fitted as a user would.

The rule it guards is the brief's first: no number said with confidence that the truth
contradicts. Every collision parameter the result calls identified lies within 3 of its
reported standard deviations of the world's truth, and the measured impact speed within 3
of its own. Fitted as a second body, this world's measured engine does not explain the
cabin's motion better than the base model's engine assumed on typical mounts, and it put
k_compression 17 % low: the result must say so and quote the number no closer than the two
models agree (3.4 of its own standard deviations off without that). And discovery, run as
the command line runs it, names nothing on this clean world. Seed 300 (tests use seeds
below 1000; the accuracy benchmark scores on seeds from 910,000)."""

from __future__ import annotations

import math

import pytest

from identify.identification import COLLISION_PARAMETERS

SEED = 300
Z_MAX = 3.0


@pytest.fixture(scope="module")
def clean_world_fit(tmp_path_factory):
    import identify
    from synth.world import make_world, write_world

    folder = tmp_path_factory.mktemp("reference") / "world"
    truth = write_world(make_world(SEED, "clean", None, "isomme"), folder)
    ident = identify.fit(folder / truth["recording"], folder / "vehicle.toml", write=False, discover=True)
    return ident, truth


@pytest.mark.slow
def test_no_identified_parameter_contradicts_the_truth(clean_world_fit):
    ident, truth = clean_world_fit
    doc = ident.document
    identified = {n: p for n, p in doc["parameters"].items() if n in COLLISION_PARAMETERS and p["identified"]}
    assert identified, "the test needs something identified to check"
    for name, p in identified.items():
        z = (p["value"] - truth["params"][name]) / p["std"]
        assert abs(z) < Z_MAX, (name, p, truth["params"][name])
    for name, p in doc["parameters"].items():
        assert p["identified"] or p["reason"], name  # what is not identified says why
    z_speed = (doc["impact_speed_kmh"] - truth["v0_kmh"]) / doc["impact_speed_std_kmh"]
    assert abs(z_speed) < Z_MAX


@pytest.mark.slow
def test_discovery_names_no_physics_the_world_does_not_have(clean_world_fit):
    # the world is clean (no zone, no wheel block, no rate dependence, no rear lift, the engine
    # never reaches the barrier); it is richer than the model (its engine rides on mounts, its
    # unloading is curved), which discovery may call "unexplained", never by a wrong name
    ident, _ = clean_world_fit
    named = [d["effect"] for d in ident.document["discoveries"] if d["effect"] != "unexplained"]
    assert named == [], ident.document["discovery_status"]
    tried = {t["effect"] for r in ident.document["discovery_rounds"] for t in r}
    assert "stiffness_zone" in tried and "front_wheel_block" in tried  # it did look


@pytest.mark.slow
def test_the_cabin_alone_fit_follows_the_cabin_and_widens_what_the_two_body_fit_says(clean_world_fit):
    # the base model on the cabin's channels alone, its engine assumed on typical mounts and
    # the measured one shown, follows the cabin's x to 0.8 mm RMS here (0.7 and 1.4 mm on
    # development worlds 960700-960701), where a rigid car's best fit misses by 5.1 mm (6.2
    # and 8.2); fitted as a second body, the measured engine came out at 445 kg (prior
    # 174 +- 52), the cabin's x missed by 8.7 mm and k_compression 17 % low: the cabin does
    # not bear it out, and the two-body fit's numbers are quoted no closer than the two agree
    ident, truth = clean_world_fit
    one, fr, doc = ident.one_body, ident.fit, ident.document
    assert one is not None and "engine_vx_mps" in one.measurement.derived
    assert [m.effect for m in one.params.mechanisms] == ["engine_impact"] and one.rms["x_m"] < 2.5e-3
    checked = [n for n in COLLISION_PARAMETERS if n in one.values and one.identified.get(n, (True, ""))[0]]
    assert "k_compression" in checked
    for name in checked:
        assert abs(one.values[name] - truth["params"][name]) < Z_MAX * one.std[name], name
    assert any("does not explain the cabin's motion better" in w for w in doc["warnings"])
    shift = abs(fr.values["k_compression"] - one.values["k_compression"])
    # with how far the models discovery did not adopt put it (here a rate dependence, BIC -3.1,
    # which the measured engine's mass prior, pulled by the base model itself, had refuted
    # until 2026-11-29), in quadrature
    from identify.discover.loop import Alternative, alternatives_shift

    alts = [Alternative(a["label"], a["delta_bic"], a["values"]) for a in doc["discovery_alternatives"]]
    moved = alternatives_shift(fr, alts).get("k_compression", 0.0)
    assert fr.model_choice["k_compression"] == pytest.approx(math.hypot(shift, moved), rel=1e-4)
    assert fr.std["k_compression"] > max(shift, moved)


@pytest.mark.slow
def test_the_gap_of_an_engine_that_never_reaches_the_barrier_is_not_identified(clean_world_fit):
    ident, truth = clean_world_fit
    gap = ident.document["parameters"]["engine_impact.gap"]
    assert not gap["identified"], gap
    # with a measured second body the reported fit keeps the recording's sigmas: weighted by
    # each channel's misfit, the engine's channel freed its parameters to absorb the cabin's
    # misfit, and the second body came out "borne out" with this gap identified
    assert ident.fit.sigma_widened == {} and ident.document["fit"]["sigma_widened_by_channel"] == {}
