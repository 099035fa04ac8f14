"""``identify track`` through ``identify.cli.main``: tracks.csv as the interface defines
it, the report, atomic output, and one clear line with exit 2 for bad input."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path

import numpy as np
import pytest

from identify.cli import main
from identify.recordings.synthetic import car_geometry
from synth.render import Renderer, write_film
from synth.scene import Motion, Scene, default_camera, default_tapes, default_targets

ROOT = Path(__file__).resolve().parents[1]


def _golf():
    with open(ROOT / "data" / "vehicles" / "vw_golf_7.toml", "rb") as fh:
        return car_geometry(tomllib.load(fh))


def _motion(n_pre, n_post, v=15.0, omega=24.0):
    t = (np.arange(n_pre + n_post) - n_pre) / 1000.0
    tp = np.maximum(t, 0.0)
    x = np.where(t < 0, v * t, v / omega * np.sin(omega * tp))
    zero = np.zeros_like(t)
    roll = (x - x[0]) / 0.316
    return Motion(t=t, x=x, z=zero, pitch=0.02 * (1 - np.cos(omega * tp)) / 2,
                  front_wheel_angle=roll, rear_wheel_angle=roll)


def _film(folder: Path, n_pre=30, n_post=24, targets=True, tapes=True, hubs=True) -> Path:
    car = _golf()
    cam = default_camera(car, 2.0, width=1280, height=440, m_per_px=0.004)
    shown = tuple(t for t in default_targets(car) if hubs or "hub" not in t.kind) if targets else ()
    scene = Scene(car=car, camera=cam, targets=shown,
                  tapes=default_tapes(car) if tapes else (), x_barrier=2.0)
    write_film(Renderer(scene, _motion(n_pre, n_post)), folder)
    return folder


@pytest.fixture(scope="module")
def film(tmp_path_factory):
    return _film(tmp_path_factory.mktemp("film") / "crash")


def _one_error_line(capsys, code, *fragments):
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1, err
    assert err[0].startswith("identify track: error:")
    for f in fragments:
        assert f in err[0], err[0]


def test_track_writes_tracks_csv_and_report(film, tmp_path, capsys):
    out = tmp_path / "res"
    out.mkdir()
    (out / "tracks.csv").write_text("stale\n")                # from an earlier run
    (out / "result.json").write_text("{}")                    # another stage's file
    code = main(["track", str(film), "--vehicle", "vw_golf_7", "--fps", "1000",
                 "--out", str(out), "--quiet"])
    assert code == 0
    assert capsys.readouterr().err == ""                      # --quiet
    assert sorted(p.name for p in out.iterdir()) == ["result.json", "tracking_report.png",
                                                     "tracks.csv"]
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp left
    with open(out / "tracks.csv") as fh:
        rows = list(csv.reader(fh))
    head = rows[0]
    assert head[:4] == ["t_ms", "x_m", "z_m", "pitch_rad"]
    for col in ("crush_m", "front_wheel_angle_rad", "rear_wheel_height_m", "target0_u_px",
                "x_sigma_m", "z_sigma_m", "pitch_sigma_rad", "target0_u_sigma_px"):
        assert col in head
    assert len(rows) == 1 + 54
    data = np.array([[float(v) for v in r] for r in rows[1:]])
    t = data[:, 0]
    assert np.allclose(np.diff(t), 1.0)
    k0 = int(np.flatnonzero(t == 0.0)[0])
    assert abs(k0 - 30) <= 1                                  # contact frame
    x = data[:, head.index("x_m")]
    assert x[k0] == 0.0 and x[-1] > 0.3 and x[0] < -0.4      # towards the barrier
    assert np.all(data[:, head.index("x_sigma_m")] > 0)


def test_missing_video(tmp_path, capsys):
    code = main(["track", str(tmp_path / "nope.mp4"), "--vehicle", "vw_golf_7", "--quiet"])
    _one_error_line(capsys, code, "does not exist")


def test_unknown_vehicle(film, capsys):
    code = main(["track", str(film), "--vehicle", "trabant_601", "--quiet"])
    _one_error_line(capsys, code, "trabant_601")


@pytest.mark.parametrize("opt,value", [("--tape-segment", "-0.1"), ("--fps", "0"),
                                       ("--speed", "-5")])
def test_bad_numbers(film, capsys, opt, value):
    code = main(["track", str(film), "--vehicle", "vw_golf_7", opt, value, "--quiet"])
    _one_error_line(capsys, code, opt)


def test_publication_frame_rate_asks_for_the_true_rate(film, capsys):
    code = main(["track", str(film), "--vehicle", "vw_golf_7", "--fps", "30", "--quiet"])
    _one_error_line(capsys, code, "30 fps", "--fps")


def test_film_without_targets(tmp_path, capsys):
    folder = _film(tmp_path / "plain", n_pre=8, n_post=4, targets=False)
    code = main(["track", str(folder), "--vehicle", "vw_golf_7", "--fps", "1000", "--quiet",
                 "--out", str(tmp_path / "res")])
    _one_error_line(capsys, code, "target", "frame 0")
    assert not (tmp_path / "res").exists()                    # nothing half-written


def test_film_without_tape_or_hub_targets(tmp_path, capsys):
    # without a tape the scale comes from the hub targets and the wheelbase
    # (test_video_track); without them too, nothing gives it
    folder = _film(tmp_path / "notape", n_pre=8, n_post=4, tapes=False, hubs=False)
    code = main(["track", str(folder), "--vehicle", "vw_golf_7", "--fps", "1000", "--quiet"])
    _one_error_line(capsys, code, "no scale reference", "tape", "hub target")


def test_tracks_csv_writes_lost_samples_as_nan_and_sigma_columns_after_values():
    from video.report import tracks_csv
    from video.types import Tracks

    t = np.array([-0.001, 0.0, 0.001])
    ch = {"target0_u_px": np.array([1.0, np.nan, 3.0]), "pitch_rad": np.zeros(3),
          "x_m": np.array([-0.01, 0.0, 0.01]), "z_m": np.zeros(3)}
    sg = {k: np.full(3, 0.5) for k in ch}
    tr = Tracks(t=t, channels=ch, sigma=sg, events_ms={}, contact_frame=1, fps=1000.0,
                scale_m_per_px=0.004, scale_sigma=1e-6, impact_speed_mps=10.0, direction=1)
    rows = list(csv.reader(tracks_csv(tr).splitlines()))
    assert rows[0] == ["t_ms", "x_m", "z_m", "pitch_rad", "target0_u_px", "x_sigma_m",
                       "z_sigma_m", "pitch_sigma_rad", "target0_u_sigma_px", "length_scale_sigma"]
    assert rows[2][0] == "0.000000" and rows[2][4] == "nan"
    assert [float(r[-1]) for r in rows[1:]] == pytest.approx([1e-6 / 0.004] * 3)  # the scale's, relative
    assert float(rows[1][0]) == -1.0


def test_tracks_csv_carries_the_scales_uncertainty_back_to_the_fit(tmp_path):
    """The scale's error is common to every length of a film, not in the length channels'
    sigmas: tracks.csv keeps it in its own column and a fit of the file reads it back."""
    from identify.recordings.measurement import measurement_from_tracks_csv
    from video.report import write_tracks_csv
    from video.types import Tracks

    t = np.arange(-5, 5) / 1000.0
    ch = {"x_m": 15.0 * t, "z_m": np.zeros(10), "pitch_rad": np.zeros(10)}
    tr = Tracks(t=t, channels=ch, sigma={k: np.full(10, 2e-4) for k in ch}, events_ms={}, contact_frame=5,
                fps=1000.0, scale_m_per_px=0.004, scale_sigma=2e-5, impact_speed_mps=15.0, direction=1)
    m = measurement_from_tracks_csv(write_tracks_csv(tr, tmp_path / "tracks.csv"))
    assert m.length_scale_sigma == pytest.approx(0.005)
    assert np.allclose(m.sigma["x_m"], 2e-4)
    hand_made = tmp_path / "hand.csv"
    hand_made.write_text("t_ms,x_m,x_sigma_m\n-1,-0.015,0.001\n0,0,0.001\n1,0.015,0.001\n")
    assert measurement_from_tracks_csv(hand_made).length_scale_sigma is None
