"""``identify frames``: a film split into numbered PNG images."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from identify.cli import main
from identify.recordings.synthetic import car_geometry, load_vehicle_dict
from synth.render import Renderer, write_film
from synth.scene import Effects, Motion, Scene, default_camera, default_tapes, default_targets

CAR = car_geometry(load_vehicle_dict("audi_a4"))


def film(path, n=10, size=(480, 240), fps=None):
    t = (np.arange(n) - 3) / 1000.0
    x = 15.0 * t
    zeros = np.zeros(n)
    cam = default_camera(CAR, 0.0, *size)
    scene = Scene(CAR, cam, default_targets(CAR), default_tapes(CAR), 0.0, 1, effects=Effects(noise_sigma=1.0))
    write_film(Renderer(scene, Motion(t, x, zeros, zeros, x / 0.32, x / 0.32)), path, container_fps=fps)
    return cam


def test_splits_every_frame_then_every_nth(tmp_path):
    film(tmp_path / "c.mp4")
    assert main(["frames", str(tmp_path / "c.mp4"), "--out", str(tmp_path / "all"), "--quiet"]) == 0
    names = sorted(p.name for p in (tmp_path / "all").iterdir())
    assert names == [f"frame_{i:05d}.png" for i in range(10)]
    img = cv2.imread(str(tmp_path / "all" / "frame_00004.png"), cv2.IMREAD_UNCHANGED)
    assert img.shape == (240, 480)
    assert main(["frames", str(tmp_path / "c.mp4"), "--out", str(tmp_path / "third"), "--every", "3", "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "third").iterdir()) == [f"frame_{i:05d}.png" for i in (0, 3, 6, 9)]
    assert not (tmp_path / "third.partial").exists()


def test_folder_input_keeps_pixels(tmp_path):
    film(tmp_path / "src")
    assert main(["frames", str(tmp_path / "src"), "--out", str(tmp_path / "out"), "--every", "5", "--quiet"]) == 0
    a = cv2.imread(str(tmp_path / "src" / "frame_00005.png"), cv2.IMREAD_UNCHANGED)
    b = cv2.imread(str(tmp_path / "out" / "frame_00005.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(a, b)


def test_scaled_frames_have_the_requested_pixel_size_and_labels(tmp_path):
    cam = film(tmp_path / "c.mp4", n=4, size=(640, 320))
    out = tmp_path / "scaled"
    rc = main(["frames", str(tmp_path / "c.mp4"), "--out", str(out), "--scaled", "--mm-per-px", "20",
               "--contact-frame", "3", "--quiet"])
    assert rc == 0
    img = cv2.imread(str(out / "frame_00000.png"), cv2.IMREAD_COLOR)
    ratio = 0.020 / cam.m_per_px
    # the scale is measured from the tapes (not the truth): within a pixel of the size
    assert abs(img.shape[0] - 320 / ratio) <= 1.0 and abs(img.shape[1] - 640 / ratio) <= 1.0
    # the time label (yellow text) and the white scale bar are drawn
    yellow = (img[..., 2] > 200) & (img[..., 1] > 200) & (img[..., 0] < 80)
    assert yellow[: img.shape[0] // 4].sum() > 20
    assert (img[-20:, :100] == 255).all(axis=2).sum() > 20


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["frames", "/nonexistent/film.mp4", "--out", "OUT"], "does not exist"),
        (["frames", "FILM", "--out", "OUT", "--every", "0"], "--every"),
        (["frames", "FILM", "--out", "OUT", "--fps", "-5"], "--fps"),
        (["frames", "JUNK", "--out", "OUT"], "cannot open video"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, argv, fragment):
    film(tmp_path / "f.mp4", n=3, size=(240, 120))
    (tmp_path / "junk.mp4").write_text("not a film")
    subst = {"FILM": str(tmp_path / "f.mp4"), "JUNK": str(tmp_path / "junk.mp4"), "OUT": str(tmp_path / "out")}
    argv = [subst.get(a, a) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("identify frames: error:") and fragment in err[0], err
    assert not (tmp_path / "out").exists()


def test_refuses_a_non_empty_output_folder(tmp_path, capsys):
    film(tmp_path / "f.mp4", n=3, size=(240, 120))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    assert main(["frames", str(tmp_path / "f.mp4"), "--out", str(tmp_path / "out")]) == 2
    assert "not empty" in capsys.readouterr().err
    assert (tmp_path / "out" / "keep.txt").read_text() == "mine"


@pytest.mark.slow
def test_scaled_frames_count_time_from_the_measured_contact(tmp_path, capsys):
    from identify.recordings.synthetic import analytic_trajectory, render_crash

    meta = render_crash("audi_a4", analytic_trajectory(speed=15.0, duration=0.03), tmp_path / "c.mp4",
                        frames_before=12, width=640, height=320)
    rc = main(["frames", str(tmp_path / "c.mp4"), "--out", str(tmp_path / "s"), "--scaled",
               "--vehicle", "audi_a4", "--every", "10"])
    assert rc == 0
    err = capsys.readouterr().err
    measured = int(err.split("first contact measured at frame ")[1].split()[0])
    assert abs(measured - meta["contact_frame"]) <= 1
    assert len(list((tmp_path / "s").glob("frame_*.png"))) == 5


def test_colour_films_give_colour_images(tmp_path):
    src = tmp_path / "src"
    src.mkdir()
    for i in range(4):
        img = np.zeros((12, 16, 3), np.uint8)
        img[..., 1] = 30 * i + 50  # green, changing
        cv2.imwrite(str(src / f"img{i}.png"), img)
    assert main(["frames", str(src), "--out", str(tmp_path / "out"), "--every", "2", "--quiet"]) == 0
    out = cv2.imread(str(tmp_path / "out" / "frame_00002.png"), cv2.IMREAD_UNCHANGED)
    assert out.shape == (12, 16, 3) and out[0, 0].tolist() == [0, 110, 0]
