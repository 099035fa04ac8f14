"""Reading films: streaming, frame rates, folders of frames, duplicates, bad input."""

from __future__ import annotations


import cv2
import numpy as np
import pytest

from identify.recordings.synthetic import car_geometry, load_vehicle_dict
from video.errors import VideoError
from video.io import open_film
from synth.render import Renderer, write_film
from synth.scene import Effects, Motion, Scene, default_camera, default_tapes, default_targets

CAR = car_geometry(load_vehicle_dict("vw_golf_7"))


def renderer(n: int = 12, speed: float = 15.0, noise: float = 2.0, size=(320, 160)) -> Renderer:
    t = (np.arange(n) - 4) / 1000.0
    x = speed * t
    zeros = np.zeros(n)
    spin = x / CAR.wheel_radius
    cam = default_camera(CAR, 0.0, *size)
    scene = Scene(CAR, cam, default_targets(CAR), default_tapes(CAR), 0.0, 1, effects=Effects(noise_sigma=noise, seed=3))
    return Renderer(scene, Motion(t, x, zeros, zeros, spin, spin))


@pytest.fixture(scope="module")
def mp4(tmp_path_factory):
    path = tmp_path_factory.mktemp("films") / "crash.mp4"
    write_film(renderer(), path)
    return path


def one_line_error(excinfo, *fragments):
    msg = str(excinfo.value)
    assert "\n" not in msg
    for f in fragments:
        assert f in msg, msg


def test_streams_frames_with_container_rate(mp4):
    film = open_film(mp4)
    assert (film.n_frames, film.size, film.fps, film.fps_source) == (12, (320, 160), 1000.0, "container")
    frames = list(film)
    assert len(frames) == 12 and frames[0].shape == (160, 320) and frames[0].dtype == np.uint8
    # random access gives the frames the stream gives, forwards and backwards
    for i in (7, 2, 11, 0):
        np.testing.assert_array_equal(film[i], frames[i])
    assert film[-1].shape == (160, 320)
    assert not any("--fps" in n for n in film.notes)
    assert open_film(mp4, color=True)[3].shape == (160, 320, 3)
    with pytest.raises(VideoError) as e:
        film[12]
    one_line_error(e, "frame 12", "12 frames")
    film.close()


def test_iteration_yields_every_frame_as_random_access_reads_it(mp4):
    film = open_film(mp4)
    it = iter(film)
    np.testing.assert_array_equal(next(it), film[0])
    rest = list(it)
    assert len(rest) == len(film) - 1
    for k in (1, len(film) // 2, len(film) - 1):
        np.testing.assert_array_equal(rest[k - 1], film[k])


def test_a_film_that_fits_in_memory_is_read_from_the_opening_scan_and_stays_as_decoded(mp4, monkeypatch):
    import video.io

    kept = open_film(mp4)

    def no_decoding(*args):
        raise AssertionError("decoded again")

    monkeypatch.setattr(kept, "_open_capture", no_decoding)
    monkeypatch.setattr(kept, "_read_video", no_decoding)
    frames = list(kept)
    assert kept.in_memory  # what the tracker reads without a decoding thread
    # a film longer than the memory kept for it (five of its frames) is decoded again, to
    # the same frames
    monkeypatch.setattr(video.io, "KEEP_DECODED_BYTES", 5 * 320 * 160)
    decoded = open_film(mp4)
    assert not decoded.in_memory
    assert len(frames) == len(decoded) == 12
    for i in (7, 2, 11, 0):
        np.testing.assert_array_equal(kept[i], decoded[i])
    for a, b in zip(frames, decoded):
        np.testing.assert_array_equal(a, b)
    # every reader shares the frames kept: none can change them for the others
    with pytest.raises(ValueError):
        kept[3][0, 0] = 0
    monkeypatch.setattr(decoded, "_read_video", no_decoding)
    with pytest.raises(AssertionError, match="decoded again"):
        decoded[4]
    # closed, a film lets its frames go (the fit runs without them) and decodes them again
    kept.close()
    assert not kept.in_memory
    with pytest.raises(AssertionError, match="decoded again"):
        kept[4]


def test_publication_rate_gets_a_note_and_fps_overrides_it(tmp_path):
    path = tmp_path / "published.mp4"
    write_film(renderer(6), path, container_fps=30.0)
    film = open_film(path)
    assert film.fps == 30.0 and film.fps_source == "container"
    assert any("--fps 1000" in n for n in film.notes)
    film = open_film(path, fps=1000)
    assert film.fps == 1000.0 and film.fps_source == "user"
    assert film.times()[1] == pytest.approx(0.001)
    assert not any("publication" in n for n in film.notes)


def test_avi_and_mov_are_read(tmp_path):
    for name in ("c.avi", "c.mov"):
        write_film(renderer(5), tmp_path / name)
        film = open_film(tmp_path / name)
        assert film.n_frames == 5 and film.fps == 1000.0


def test_folder_of_frames_in_natural_order(tmp_path):
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(12):  # f0.png ... f11.png: a plain string sort would put f10 after f1
        cv2.imwrite(str(folder / f"f{i}.png"), np.full((20, 30), 10 * i, np.uint8))
    film = open_film(folder)
    assert film.n_frames == 12 and film.size == (30, 20)
    assert [int(f[0, 0]) for f in film] == [10 * i for i in range(12)]
    assert film.fps_source == "assumed" and any("--fps" in n for n in film.notes)
    assert open_film(folder, fps=500).fps == 500.0
    # sixteen-bit TIFF frames are read as 8 bit
    tif = tmp_path / "tif"
    tif.mkdir()
    for i in range(3):
        cv2.imwrite(str(tif / f"img_{i:03d}.tif"), np.full((8, 8), 256 * (50 + i), np.uint16))
    assert [int(f[0, 0]) for f in open_film(tif, fps=1000)] == [50, 51, 52]


def test_duplicated_frames_are_reported_in_png_and_mp4(tmp_path):
    r = renderer(12)
    write_film(r, tmp_path / "dup", duplicate=(3, 8))
    film = open_film(tmp_path / "dup", fps=1000)
    # frames written: 0 1 2 3 3' 4 5 6 7 8 8' 9 ...: copies at written index 4 and 10
    assert film.duplicates.tolist() == [4, 10]
    assert any("hardly differ" in n and "4" in n and "10" in n for n in film.notes)
    write_film(r, tmp_path / "dup.mp4", duplicate=(3, 8))
    assert open_film(tmp_path / "dup.mp4").duplicates.tolist() == [4, 10]


def test_still_scene_with_independent_noise_is_not_a_duplicate(tmp_path):
    """A car at rest (e.g. at maximum crush) still has fresh sensor noise each frame."""
    write_film(renderer(8, speed=0.0, noise=1.5), tmp_path / "still")
    film = open_film(tmp_path / "still", fps=1000)
    assert film.duplicates.size == 0
    assert np.all(film.noise > 1.0)


@pytest.mark.parametrize("fps", [0, -1000, float("nan"), 2e6, float("inf")])
def test_impossible_frame_rates(mp4, fps):
    with pytest.raises(VideoError) as e:
        open_film(mp4, fps=fps)
    one_line_error(e, "--fps")


def test_missing_file():
    with pytest.raises(VideoError) as e:
        open_film("/nonexistent/crash.mp4")
    one_line_error(e, "/nonexistent/crash.mp4", "does not exist")


def test_unreadable_empty_and_truncated_files(tmp_path, mp4):
    junk = tmp_path / "junk.mp4"
    junk.write_text("this is not a video\n" * 50)
    with pytest.raises(VideoError) as e:
        open_film(junk)
    one_line_error(e, "junk.mp4")
    empty = tmp_path / "empty.avi"
    empty.write_bytes(b"")
    with pytest.raises(VideoError) as e:
        open_film(empty)
    one_line_error(e, "empty.avi", "empty")
    cut = tmp_path / "cut.avi"
    write_film(renderer(12), cut)
    data = cut.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(VideoError) as e:
        open_film(cut)
    one_line_error(e, "cut.avi")
    cut_mp4 = tmp_path / "cut.mp4"
    cut_mp4.write_bytes(mp4.read_bytes()[: mp4.stat().st_size // 2])
    with pytest.raises(VideoError) as e:
        open_film(cut_mp4)
    one_line_error(e, "cut.mp4")


def test_colour_is_detected_and_kept_on_request(tmp_path, mp4):
    assert open_film(mp4).is_color is False  # grey film in a BGR container
    folder = tmp_path / "colour"
    folder.mkdir()
    for i in range(3):
        img = np.zeros((16, 24, 3), np.uint8)
        img[..., 2] = 200  # red
        cv2.imwrite(str(folder / f"f_{i}.png"), img)
    film = open_film(folder, fps=1000)
    assert film.is_color and film[0].ndim == 2
    colour = film.as_color()
    assert colour[1].shape == (16, 24, 3) and colour[1][0, 0, 2] == 200
    assert film[1].ndim == 2  # the original still gives grey


def test_a_single_image_is_not_a_film(tmp_path):
    cv2.imwrite(str(tmp_path / "frame_0001.png"), np.zeros((8, 8), np.uint8))
    with pytest.raises(VideoError) as e:
        open_film(tmp_path / "frame_0001.png")
    one_line_error(e, "single image", "folder")
    assert open_film(tmp_path, fps=1000).n_frames == 1  # the folder is fine


def test_folder_without_frames_and_with_mixed_sizes(tmp_path):
    empty = tmp_path / "none"
    empty.mkdir()
    (empty / "readme.txt").write_text("no frames here")
    with pytest.raises(VideoError) as e:
        open_film(empty)
    one_line_error(e, "no frames")
    mixed = tmp_path / "mixed"
    mixed.mkdir()
    for i in range(4):
        size = (20, 30) if i != 2 else (21, 30)
        cv2.imwrite(str(mixed / f"frame_{i}.png"), np.zeros(size, np.uint8))
    with pytest.raises(VideoError) as e:
        open_film(mixed)
    one_line_error(e, "frame_2.png", "30x21", "30x20")
    broken = tmp_path / "broken"
    broken.mkdir()
    cv2.imwrite(str(broken / "frame_0.png"), np.zeros((8, 8), np.uint8))
    (broken / "frame_1.png").write_bytes(b"not a png")
    with pytest.raises(VideoError) as e:
        open_film(broken)
    one_line_error(e, "frame_1.png")


def test_the_noise_of_a_byte_frame_is_that_of_the_same_values_in_16_bits():
    """``frame_noise_sigma`` takes a byte frame's second differences in 16 bits: exact to
    the extremes (0 beside 255 in every row: +-510), as the same values in uint16 give."""
    from video.io import frame_noise_sigma

    rng = np.random.default_rng(4)
    extreme = np.tile(np.array([0, 255, 0, 255, 255, 0], np.uint8), (40, 20))
    for frame in (extreme, rng.integers(0, 256, (48, 90)).astype(np.uint8),
                  np.clip(rng.normal(128, 3, (48, 90)), 0, 255).astype(np.uint8)):
        assert frame_noise_sigma(frame) == frame_noise_sigma(frame.astype(np.uint16)) > 0
