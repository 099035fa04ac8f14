"""Bad input of every kind ends in one clear line on stderr and exit 2, never a traceback,
never before a long wait, and never with a file of the user's changed (issue 16)."""

import os
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from identify.cli import main

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "data" / "samples" / "a4_paper.mp4"
A4_TOML = ROOT / "data" / "vehicles" / "audi_a4.toml"


def one_line(capfd, code, *fragments):
    """Exit 2 and exactly one line on stderr (file descriptor level: libpng and FFmpeg
    print there too), holding every fragment."""
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1, err
    assert "Traceback" not in err[0] and ": error: " in err[0], err
    for f in fragments:
        assert f in err[0], err[0]
    return err[0]


@pytest.fixture()
def readonly(tmp_path):
    """A folder nobody can write in (root ignores modes: the immutable attribute then)."""
    folder = tmp_path / "readonly"
    folder.mkdir()
    shutil.copy(SAMPLE, folder / "crash.mp4")
    folder.chmod(0o555)
    immutable = False
    if os.geteuid() == 0:
        immutable = subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode == 0
        if not immutable:
            folder.chmod(0o755)
            pytest.skip("running as root without chattr: cannot make a folder unwritable")
    yield folder
    if immutable:
        subprocess.run(["chattr", "-i", str(folder)], check=True)
    folder.chmod(0o755)


# ------------------------------------------------------------------ unwritable places, at once


def test_fit_out_in_a_folder_that_cannot_be_written_fails_at_once(readonly, capfd):
    t0 = time.perf_counter()
    code = main(["fit", str(SAMPLE), "--vehicle", "audi_a4", "--out", str(readonly / "res"), "--quiet"])
    one_line(capfd, code, "cannot write in", str(readonly))
    assert time.perf_counter() - t0 < 5.0  # before any reading, tracking or fitting
    assert sorted(p.name for p in readonly.iterdir()) == ["crash.mp4"]


def test_fit_default_out_beside_a_film_in_a_read_only_folder(readonly, capfd):
    t0 = time.perf_counter()
    code = main(["fit", str(readonly / "crash.mp4"), "--vehicle", "audi_a4", "--quiet"])
    one_line(capfd, code, "cannot write in", "--out")
    assert time.perf_counter() - t0 < 5.0


def test_track_and_sensitivity_out_unwritable(readonly, capfd):
    code = main(["track", str(SAMPLE), "--vehicle", "audi_a4", "--out", str(readonly / "res"), "--quiet"])
    one_line(capfd, code, "cannot write in")
    code = main(["sensitivity", "--vehicle", "audi_a4", "--params", "paper_identified", "--samples", "100",
                 "--sobol-samples", "0", "--out", str(readonly / "sens"), "--quiet"])  # fmt: skip
    one_line(capfd, code, "cannot write in")
    code = main(["frames", str(SAMPLE), "--out", str(readonly / "frames"), "--quiet"])
    one_line(capfd, code, "cannot write in")


def test_simulate_out_unwritable_or_a_folder(readonly, tmp_path, capfd):
    base = ["simulate", "--vehicle", "audi_a4", "--params", "paper_identified", "--duration-ms", "20"]
    one_line(capfd, main(base + ["--out", str(readonly / "run.csv")]), "cannot write in")
    one_line(capfd, main(base + ["--out", str(tmp_path)]), "is a folder")


def test_simulate_never_replaces_a_users_file_without_force(tmp_path, capfd):
    base = ["simulate", "--vehicle", "audi_a4", "--params", "paper_identified", "--duration-ms", "20"]
    thesis = tmp_path / "thesis.docx"
    thesis.write_bytes(b"PK\x03\x04 my thesis")
    one_line(capfd, main(base + ["--out", str(thesis)]), "--force", "thesis.docx")
    assert thesis.read_bytes() == b"PK\x03\x04 my thesis"
    notes = tmp_path / "notes.csv"  # a CSV, but not ours
    notes.write_text("a,b\n1,2\n")
    one_line(capfd, main(base + ["--out", str(notes)]), "--force")
    assert notes.read_text() == "a,b\n1,2\n"
    run = tmp_path / "run.csv"  # our own CSV is replaced by a re-run
    assert main(base + ["--out", str(run)]) == 0
    first = run.read_text()
    assert main(base + ["--speed", "40", "--out", str(run)]) == 0
    assert run.read_text() != first and run.read_text().startswith("t_ms,x_m")
    assert main(base + ["--out", str(thesis), "--force"]) == 0  # --force: the user asked for it
    assert thesis.read_text().startswith("t_ms,x_m")
    capfd.readouterr()


# ------------------------------------------------------------------ undecodable files


def test_vehicle_toml_of_binary_bytes(tmp_path, capfd):
    car = tmp_path / "car.toml"
    car.write_bytes(b"name = \"x\"\nmass = 1670.0\n\x89\xfe\xff\x00binary" * 3)
    code = main(["simulate", "--vehicle", str(car), "--params", "paper_identified"])
    one_line(capfd, code, "car.toml", "line 3", "not UTF-8")
    code = main(["fit", str(SAMPLE), "--vehicle", str(car), "--out", str(tmp_path / "res"), "--quiet"])
    one_line(capfd, code, "car.toml", "line 3")
    assert not (tmp_path / "res").exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_params_json_and_tracks_csv_of_binary_bytes(tmp_path, capfd):
    params = tmp_path / "p.json"
    params.write_bytes(b"{\n\xff\xfe}")
    one_line(capfd, main(["simulate", "--vehicle", "audi_a4", "--params", str(params)]), "p.json", "line 2")
    tracks = tmp_path / "tracks.csv"
    tracks.write_bytes(b"t_ms,x_m\n0,0\n\x00\x01\x02")
    one_line(capfd, main(["fit", str(tracks), "--vehicle", "audi_a4", "--out", str(tmp_path / "r"), "--quiet"]),
             "tracks.csv", "line 3")  # fmt: skip


def test_ev5_and_isomme_of_binary_bytes_name_the_file_and_line(tmp_path, capfd):
    ev5 = tmp_path / "v1.EV5"
    ev5.write_bytes(b"----- EV5 -----\n----- TEST -----\nV5|x\x00\x01|\n")
    one_line(capfd, main(["fit", str(ev5), "--vehicle", "audi_a4", "--out", str(tmp_path / "r"), "--quiet"]),
             "v1.EV5", "line 3", "binary")  # fmt: skip
    mme = tmp_path / "iso" / "T.mme"
    mme.parent.mkdir()
    mme.write_bytes(b"Title :x\nVelocity test object 1 :15\n\x00\x00\x00\x07\x08")
    one_line(capfd, main(["fit", str(mme), "--vehicle", "audi_a4", "--out", str(tmp_path / "r"), "--quiet"]),
             "T.mme", "line 3", "binary")  # fmt: skip


def _png_claiming(path: Path, width: int, height: int) -> None:
    ok, buf = cv2.imencode(".png", np.zeros((8, 8), np.uint8))
    data = bytearray(buf.tobytes())
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])) & 0xFFFFFFFF)
    path.write_bytes(bytes(data))


def test_frames_whose_headers_claim_40000_px_are_refused_before_decoding(tmp_path, capfd):
    folder = tmp_path / "frames"
    folder.mkdir()
    for i in range(12):
        _png_claiming(folder / f"f{i:03d}.png", 40000, 40000)
    for command in ("fit", "track", "frames"):
        extra = [] if command == "frames" else ["--vehicle", "audi_a4"]
        code = main([command, str(folder), *extra, "--out", str(tmp_path / f"out_{command}"), "--quiet"])
        one_line(capfd, code, "40000x40000", "limit", "16384")
        assert not (tmp_path / f"out_{command}").exists()


def test_damaged_png_is_our_one_line_without_libpngs(tmp_path, capfd):
    folder = tmp_path / "frames"
    folder.mkdir()
    ok, buf = cv2.imencode(".png", (np.random.default_rng(0).random((40, 60)) * 255).astype(np.uint8))
    good = buf.tobytes()
    for i in range(12):
        data = bytearray(good)
        if i == 5:
            data[60] ^= 0xFF  # inside the compressed data: libpng complains on fd 2
        (folder / f"f{i:03d}.png").write_bytes(bytes(data))
    code = main(["track", str(folder), "--vehicle", "audi_a4", "--out", str(tmp_path / "o"), "--quiet"])
    one_line(capfd, code, "f005.png", "cannot be read")


def test_damaged_video_is_our_one_line_without_ffmpegs(tmp_path):
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"\x00\x00\x00\x18ftypmp42" + b"\x01 not an mp4 file" * 100)
    r = subprocess.run([sys.executable, "-m", "identify.cli", "frames", str(bad), "--out", str(tmp_path / "f"),
                        "--quiet"], capture_output=True, text=True, timeout=120)  # fmt: skip
    err = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(err) == 1 and "cannot open video" in err[0], r.stderr


# ------------------------------------------------------------------ the film contradicts the vehicle file


def test_wrong_vehicle_file_stops_before_the_fit(tmp_path, capfd):
    t0 = time.perf_counter()
    code = main(["fit", str(SAMPLE), "--vehicle", "vw_golf_7", "--out", str(tmp_path / "res"), "--quiet"])
    line = one_line(capfd, code, "the film's wheelbase 2.808 m contradicts vw_golf_7's 2.637 m (+6.5 %",
                    "wrong vehicle file? --force to fit anyway")
    assert "sigma" in line
    assert time.perf_counter() - t0 < 60  # tracking only: no fit
    assert not (tmp_path / "res").exists() and not list(tmp_path.iterdir())
    code = main(["track", str(SAMPLE), "--vehicle", "vw_golf_7", "--out", str(tmp_path / "res"), "--quiet"])
    one_line(capfd, code, "contradicts vw_golf_7's", "--force to track anyway")


def test_consistency_thresholds():
    from identify.recordings.consistency import contradictions

    geo = {"hub_spacing_m": 2.808, "hub_spacing_sigma_m": 0.0002, "outline_length_m": 4.70,
           "outline_length_sigma_m": 0.01}  # fmt: skip
    assert contradictions(geo, 2.808, 4.703, "audi_a4") == []
    assert contradictions(geo, 2.78, 4.703, "x") == []  # 1 %: within the 2 % allowed
    found = contradictions(geo, 2.637, 4.703, "vw_golf_7")
    assert len(found) == 1 and "wheelbase 2.808 m contradicts vw_golf_7's 2.637 m (+6.5 %" in found[0]
    noisy = dict(geo, hub_spacing_sigma_m=0.1)  # 6.5 % but under 3 sigma: not a contradiction
    assert contradictions(noisy, 2.637, 4.703, "x") == []
    assert "length" in contradictions(geo, 2.808, 4.40, "x")[0]
    assert contradictions({}, 2.637, 4.0, "x") == []  # nothing measured, nothing to say


def test_the_wheelbase_decides_and_an_outline_length_alone_only_warns():
    # the outline's length is the silhouette fit's, which a background can fool: beside a
    # wheelbase that agrees it is a warning; it stops the run only where no hubs were seen and
    # it is more than LENGTH_ALONE_DECIDES off
    from types import SimpleNamespace

    from identify.recordings.consistency import check_film_against_vehicle
    from identify.errors import UserError

    veh = SimpleNamespace(wheelbase=2.808, length=4.703)
    good_hubs = {"hub_spacing_m": 2.808, "hub_spacing_sigma_m": 0.0005}
    short_outline = {"outline_length_m": 3.985, "outline_length_sigma_m": 0.01}
    warned = check_film_against_vehicle(SimpleNamespace(geometry={**good_hubs, **short_outline}), veh, "audi_a4")
    assert len(warned) == 1 and "length 3.985 m" in warned[0] and "outline fit is suspect" in warned[0]
    # without hubs, 15 % short (as a fooled outline fit came out) warns; 30 % short stops the run
    warned = check_film_against_vehicle(SimpleNamespace(geometry=short_outline), veh, "audi_a4")
    assert len(warned) == 1 and "length 3.985 m contradicts" in warned[0] and "no hub targets" in warned[0]
    with pytest.raises(UserError, match="length 3.292 m contradicts"):
        check_film_against_vehicle(SimpleNamespace(geometry={**short_outline, "outline_length_m": 3.292}), veh,
                                   "audi_a4")
    with pytest.raises(UserError, match="wheelbase"):
        check_film_against_vehicle(SimpleNamespace(geometry={**short_outline, "hub_spacing_m": 2.637,
                                                             "hub_spacing_sigma_m": 0.0005}), veh, "audi_a4")
    assert check_film_against_vehicle(SimpleNamespace(geometry=good_hubs), veh, "audi_a4") == []


@pytest.mark.slow
def test_wrong_vehicle_with_force_fits_and_carries_the_warning(tmp_path, capfd):
    # an A4 file with a wheelbase 3 % short: contradicted, and a fit that still converges fast
    car = tmp_path / "a4_short.toml"
    car.write_text(A4_TOML.read_text().replace("wheelbase = 2.808", "wheelbase = 2.72"))
    assert "wheelbase = 2.72" in car.read_text()
    out = tmp_path / "res"
    code = main(["fit", str(SAMPLE), "--vehicle", str(car), "--force", "--no-discover", "--starts", "1",
                 "--out", str(out), "--quiet"])  # fmt: skip
    captured = capfd.readouterr()
    assert code == 0, captured.err
    assert "warning: the film's wheelbase 2.808 m contradicts a4_short's 2.720 m (+3.2 %" in captured.err
    import json

    doc = json.loads((out / "result.json").read_text())
    assert any("contradicts a4_short's 2.720 m" in w and "--force" in w for w in doc["warnings"])
    report = (out / "report.md").read_text()
    assert "**Warning:** the film's wheelbase 2.808 m contradicts" in report


# ------------------------------------------------------------------ Ctrl-C


@pytest.mark.parametrize("delay", [2.5, 7.0])
def test_ctrl_c_is_honoured_within_2_s_and_leaves_nothing(tmp_path, delay):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    # Ctrl-C as in a terminal: a test runner started in the background (`&`, some CI shells)
    # hands its children SIGINT ignored, and Python keeps it so; the child restores
    # Python's own handler first (no preexec_fn: forking a multithreaded JAX process is unsafe)
    start = ("import runpy, signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
             "sys.argv = ['identify'] + sys.argv[1:]; runpy.run_module('identify.cli', run_name='__main__')")
    p = subprocess.Popen([sys.executable, "-c", start, "fit", str(SAMPLE), "--vehicle", "audi_a4",
                          "--out", str(tmp_path / "res")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, env=env)  # fmt: skip
    time.sleep(delay)  # importing, tracking or compiling
    assert p.poll() is None, p.communicate()
    t0 = time.perf_counter()
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=10)
    finally:
        if p.poll() is None:
            p.kill()
    latency = time.perf_counter() - t0
    assert p.returncode == 130, err
    assert latency < 2.0, latency
    assert err.strip().splitlines()[-1].endswith("interrupted") and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []  # no results folder, no temporary sibling


def test_progress_into_a_file_is_whole_lines_without_carriage_returns():
    import io

    from identify.sensitivity import Progress

    stream = io.StringIO()  # not a terminal: what `2> log.txt` or a pipe gets
    progress = Progress("Monte Carlo", stream=stream)
    for done in range(0, 10001, 100):
        progress(done, 10000)
    text = stream.getvalue()
    assert "\r" not in text and text.endswith("\n") and len(text.splitlines()) <= 5


def test_an_internal_error_is_one_line_exit_1_not_a_traceback(monkeypatch, capfd):
    # a bug is not bad input: exit 1 (not 2) with one line asking for a report
    import identify.commands.vehicles as vehicles

    def broken(args):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(vehicles, "run", broken)
    code = main(["vehicles"])
    err = capfd.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1
    assert "unexpected ZeroDivisionError" in err[0] and "a bug" in err[0] and "Traceback" not in err[0]


@pytest.mark.parametrize("suffix", [".webm", ".WMV"])
def test_fit_opens_every_film_format_the_video_stage_opens(tmp_path, capfd, suffix):
    """One list of film formats (video.io.VIDEO_SUFFIXES): ``fit`` hands a .webm to the video
    stage like ``frames`` does, and a damaged one is the video stage's one line, not 'not a
    recording this tool reads'."""
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(b"\x1a\x45\xdf\xa3 not a webm file" * 100)
    code = main(["fit", str(bad), "--vehicle", "audi_a4", "--out", str(tmp_path / "o"), "--quiet"])
    one_line(capfd, code, "cannot open video")
