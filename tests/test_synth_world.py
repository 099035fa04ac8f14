"""The reference world as a user meets it: ``identify synth`` and the folder it writes
(recording, vehicle.toml, truth.json), checked against independent readers (the video
stage, identify's ISO-MME reader) and against ``sim``, which it must not be.

Seeds here are below 1000; the accuracy benchmark scores on seeds from 910,000 on.
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from synth.scoring import judge_discoveries, tracking_errors
from synth.vehicle import SynthError, load_car
from synth.world import EFFECTS, make_world, read_truth, write_world

# The film test's seed: its randomized footage as `identify synth --seed 17` draws it (PNG
# frames, 800x600 at 500 fps, 50 mm tapes, about 10 mm per pixel, a camera yawed, pitched
# and rolled by up to 3 degrees, lens distortion, camera shake after impact, motion blur,
# noise), small enough to render and track in seconds. The benchmark scores the tracker
# over many seeds; this test checks that a world's truth and the tracker agree on time and
# x origins, signs and scale.
FILM_SEED = 17


def run_cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "identify.cli", "synth", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def film_world(tmp_path_factory):
    folder = tmp_path_factory.mktemp("synth") / "clean_film"
    r = run_cli("--out", folder, "--seed", FILM_SEED, "--effect", "clean", "--quiet")
    assert r.returncode == 0, r.stderr
    return folder, read_truth(folder), r.stdout


def test_film_world_tracks_to_its_own_truth(film_world, monkeypatch):
    # the bar: x within 3 mm RMS after a time shift of at most 1 ms (the truth's
    # x is referred to the measured contact frame, so a contact found a few frames off
    # does not enter). A wrong time or x origin, sign or scale in the truth breaks it: one
    # frame at 15 m/s is 15 mm, a 1 % scale error 6 mm at 0.6 m of travel.
    from identify.identification import car_geometry_of
    from identify.recordings.load import load_recording
    from sim import load_vehicle

    folder, truth, stdout = film_world
    # the command line tells the user what to give `identify fit`: tape and frame rate
    assert f"--tape-segment {truth['tape_segment']:g}" in stdout and f"--fps {truth['fps']:g}" in stdout
    veh = load_vehicle(folder / "vehicle.toml")
    rec = load_recording(folder / truth["recording"], car_geometry_of(veh), fps=truth["fps"],
                         tape_segment_m=truth["tape_segment"])
    err = tracking_errors(rec.tracks.channels["x_m"], rec.tracks.contact_frame, truth)
    assert err["x_rms_mm"] is not None and err["x_rms_mm"] < 3.0, err
    assert abs(err["shift_ms"]) <= 1.0
    # the speed the film shows before contact is the truth's (1 %: 0.15 m/s)
    assert rec.tracks.impact_speed_mps == pytest.approx(truth["v0_kmh"] / 3.6, rel=0.01)
    # tracked, the film let go of the frames its opening kept (the fit runs without them):
    # a frame the report draws is decoded again
    decoded = []
    for reader in ("_read_video", "_read_file"):
        monkeypatch.setattr(rec.film, reader, lambda i, read=getattr(rec.film, reader): decoded.append(i) or read(i))
    assert rec.film[3].shape[:2] == rec.film[0].shape[:2] and decoded == [3, 0]


def test_truth_series_conventions(film_world):
    folder, truth, _ = film_world
    s = truth["series"]
    t = s["t_ms"]
    c = int(np.argmin(np.abs(t)))
    assert t[c] == 0.0 and s["x_m"][c] == 0.0
    dt = np.diff(t)
    assert np.allclose(dt, 1e3 / truth["fps"])
    # constant-speed approach at v0, x towards the barrier
    v_before = np.diff(s["x_m"][:c]) / (dt[:c - 1] / 1e3)
    assert np.allclose(v_before, truth["v0_kmh"] / 3.6, rtol=1e-9)
    # then a crash: the car slows, crushes and comes back
    assert 0.3 < truth["max_crush_m"] < 1.2
    assert truth["events_ms"]["compression_end"] is not None
    assert set(truth["params"]) == {"k_compression", "k_restitution", "restitution", "dz_contact"}
    assert truth["effects"] == []
    for name in ("vehicle.toml", "truth.json", truth["recording"]):
        assert (folder / name).exists()
    assert truth["footage"]["spec"]["fps"] == truth["fps"] and truth["tape_segment"] == truth["footage"]["spec"]["tape_segment"]


def test_reference_model_is_not_sim(tmp_path):
    # sim with the truth's own parameters (the fit's model, as `identify simulate` runs
    # it) must differ from the truth's motion by >= 2 mm RMS over 0-250 ms: the reference
    # car is another model (engine on mounts, unsprung wheels, a curved unloading law,
    # face friction), not sim/ again.
    from sim import load_vehicle, simulate
    from sim.params import make_params
    from synth.physics import simulate_reference
    from synth.vehicle import car_to_toml

    for seed in (3, 4):
        world = make_world(seed, "clean", fmt="isomme")
        ref = simulate_reference(world.car, world.params, world.v0, duration=0.25, fps=1000.0)
        path = tmp_path / f"car{seed}.toml"
        path.write_text(car_to_toml(world.car))
        params = make_params(**{n: getattr(world.params, n) for n in
                                ("k_compression", "k_restitution", "restitution", "dz_contact")})
        traj = simulate(params, load_vehicle(path), world.v0, duration=0.25)
        x_sim = np.interp(ref.t, np.asarray(traj.t), np.asarray(traj.x))
        rms = float(np.sqrt(np.mean((x_sim - ref.x) ** 2)))
        assert rms >= 2e-3, (seed, rms)


def test_isomme_world_reads_back_with_identify(tmp_path):
    from identify.recordings.isomme import read_isomme

    folder = tmp_path / "sensors"
    truth = write_world(make_world(21, "engine_impact", fmt="isomme"), folder)
    test = read_isomme(folder / truth["recording"])
    # header speed: the speed trap's error is 0.1 km/h (1 sigma)
    assert abs(test.impact_speed_mps * 3.6 - truth["v0_kmh"]) < 0.5
    assert test.mass_kg == pytest.approx(load_car(folder / "vehicle.toml").mass, rel=1e-3)
    assert len(test.vehicle) == 2 and len(test.barrier) == 4
    series = read_truth(folder)["series"]
    # the crossmembers' mean, integrated, gives the truth's change of velocity (noise 0.3 g
    # white at 10 kHz integrates to ~1 mm/s; offsets of 0.05 g give ~0.15 m/s over 0.3 s)
    acc = np.mean([c.values for c in test.vehicle], axis=0)
    t = test.vehicle[0].t
    dv_meas = np.trapezoid(acc, t)
    dv_true = np.trapezoid(series["cabin_accel_x_mps2"], series["t_ms"] / 1e3)
    assert abs(dv_meas - dv_true) < 0.3
    assert dv_true < -15.0  # the car stops and rebounds
    force = np.sum([c.values for c in test.barrier], axis=0)
    peak = series["force_barrier_n"].max()
    assert np.sqrt(np.mean((force - series["force_barrier_n"]) ** 2)) < 0.02 * peak
    # the engine's own accelerometers are there for the two-body work
    chn = (folder / truth["recording"]).parent / "Channel"
    codes = " ".join(p.read_text(encoding="latin-1") for p in chn.glob("*.chn"))
    assert "10ENGNTO0000ACX0" in codes and "10ENGNBO0000ACX0" in codes
    assert truth["effects"][0]["name"] == "engine_impact"
    assert truth["events_ms"]["engine_contact"] is not None


def test_a_motion_world_is_its_simulated_motion_as_identify_reads_a_tracks_csv(tmp_path):
    """Format "motion": the world's own motion, exact, as a tracks.csv at 1000 Hz with a good
    film's sigmas: the same physics as the film world of the seed (its own random streams)."""
    from identify.fitting.collision_fit import approach_speed
    from identify.recordings.measurement import measurement_from_tracks_csv
    from synth.world import MOTION_FRAMES_BEFORE, MOTION_SIGMA

    world = make_world(21, "clean", fmt="motion")
    assert world.params == make_world(21, "clean", fmt="film").params and world.rate_hz == 1000.0
    truth = write_world(world, tmp_path / "motion")
    m = measurement_from_tracks_csv(tmp_path / "motion" / truth["recording"])
    series = read_truth(tmp_path / "motion")["series"]
    np.testing.assert_allclose(m.t * 1e3, series["t_ms"], atol=1e-9)
    for name in ("x_m", "z_m", "pitch_rad"):
        np.testing.assert_allclose(m.channels[name], series[name], rtol=1e-8, atol=1e-12)
        assert np.all(m.sigma[name] == MOTION_SIGMA[name])
    assert np.sum(m.t < 0) == MOTION_FRAMES_BEFORE and m.t[MOTION_FRAMES_BEFORE] == 0.0
    assert approach_speed(m)[0] == pytest.approx(truth["v0_kmh"] / 3.6, rel=1e-9)
    # the wheels roll on the file's radius before contact and turn on continuously through it
    r = load_car(tmp_path / "motion" / "vehicle.toml").wheel_radius
    angle = m.channels["front_wheel_angle_rad"]
    np.testing.assert_allclose(np.diff(angle[:MOTION_FRAMES_BEFORE + 2]), truth["v0_kmh"] / 3.6 / 1000.0 / r, rtol=1e-3)


def test_worlds_are_reproducible_and_vary():
    a, b, c = make_world(5, "random"), make_world(5, "random"), make_world(6, "random")
    assert a.params == b.params and a.footage == b.footage and a.v0 == b.v0
    assert a.params != c.params and a.footage != c.footage
    effects = {make_world(s, "random", fmt="isomme").effect for s in range(5)}
    assert len(effects) >= 3 and effects <= set(EFFECTS)  # "random" draws the effect from the seed


def test_bad_world_input_is_refused():
    with pytest.raises(SynthError, match="seed"):
        make_world(-1)
    with pytest.raises(SynthError, match="effect"):
        make_world(1, "wobble")
    with pytest.raises(SynthError, match="format"):
        make_world(1, fmt="mp3")


@pytest.mark.parametrize("args, words", [
    (["--effect", "wobble"], "unknown effect"),
    (["--seed", "-3"], "seed"),
    (["--format", "mp3"], "unknown format"),
    (["--vehicle", "no_such_car"], "unknown vehicle"),
])
def test_cli_bad_input_one_line_exit_2(tmp_path, args, words):
    r = run_cli("--out", tmp_path / "w", *args)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and "Traceback" not in r.stderr
    assert not (tmp_path / "w").exists()


def test_cli_never_overwrites_and_fails_on_unwritable_out(tmp_path):
    # a folder with the user's files in it is left alone
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    r = run_cli("--out", out, "--format", "isomme", "--quiet")
    assert r.returncode == 2 and "not an empty folder" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert (out / "notes.txt").read_text() == "mine" and len(list(out.iterdir())) == 1
    # a place that cannot be a folder (under a file): one line, exit 2 (root can write
    # anywhere, so a read-only folder would not test this here)
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    r = run_cli("--out", blocker / "w", "--format", "isomme", "--quiet")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr
    assert blocker.read_text() == "x"


def test_cli_writes_an_isomme_world(tmp_path):
    out = tmp_path / "w"
    r = run_cli("--out", out, "--seed", "8", "--effect", "stiffness_zone", "--format", "isomme", "--quiet")
    assert r.returncode == 0, r.stderr
    truth = json.loads((out / "truth.json").read_text())
    assert truth["effects"][0]["name"] == "stiffness_zone"
    assert {"zone_depth", "k_zone"} == set(truth["effects"][0]["parameters"])
    assert "identify fit" in r.stdout and str(out / "vehicle.toml") in r.stdout
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folder left


def test_scoring_rules():
    assert judge_discoveries([], []) == "none"
    assert judge_discoveries(["front_wheel_block"], []) == "wrong"
    assert judge_discoveries(["stiffness_zone"], ["stiffness_zone"]) == "right"
    assert judge_discoveries(["stiffness_zone", "rate_dependence"], ["stiffness_zone"]) == "right+wrong"
    assert judge_discoveries(["unexplained"], ["engine_impact"]) == "unexplained"
    # a measurement late by one frame at 15 m/s is 15 mm off unless the shift absorbs it
    t = np.arange(-20, 200) * 1e-3
    x = np.where(t < 0, 15 * t, 15 * t - 40 * t ** 2)
    truth = {"fps": 1000.0, "series": {"t_ms": t * 1e3, "x_m": x}}
    exact = tracking_errors(x, 20, truth)
    assert exact["x_rms_mm"] < 1e-9 and exact["video_contact_err_ms"] == 0
    # contact 0.4 frame after frame 20 (the truth's frame 0 is 20.4 ms before it), measured
    # as frame 21 less 0.3 ms: 0.3 ms late; the frame label, 21 against the nearest 20, 1 ms
    sub = {"fps": 1000.0, "series": {"t_ms": (t - 0.4e-3) * 1e3, "x_m": x}}
    err = tracking_errors(x, 21, sub, contact_time_s=0.021 - 0.0003)
    assert err["video_contact_time_err_ms"] == pytest.approx(0.3) and err["video_contact_err_ms"] == 1.0
    late = tracking_errors(np.interp(t + 1e-3, t, x) - np.interp(1e-3, t, x), 20, truth)
    assert late["x_rms_mm"] < 0.05 and late["shift_ms"] == pytest.approx(1.0)
    wrong = tracking_errors(np.interp(t + 3e-3, t, x) - np.interp(3e-3, t, x), 20, truth)
    assert wrong["x_rms_mm"] > 1.0
