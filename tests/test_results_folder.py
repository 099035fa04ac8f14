"""Results folders (``identify.report.results``): written atomically, a manifest of what the tool
wrote, a re-run replaces only that, the user's files are never touched, modes from the umask."""

import json
import os
import stat

import pytest

from identify.errors import UserError
from identify.report.results import MANIFEST, ResultsFolder, discard_temporaries, write_text_atomic

NAMES = ("result.json", "report.md", "plot.png")


def run(out, files, command="fit"):
    with ResultsFolder(out, command=command, names=NAMES) as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text)
    return out


def temporaries(folder):
    return [p.name for p in folder.iterdir() if p.name.startswith(".")]


def test_new_folder_gets_its_files_and_a_manifest(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1", "report.md": "a"})
    assert sorted(p.name for p in out.iterdir()) == sorted(["result.json", "report.md", MANIFEST])
    files = json.loads((out / MANIFEST).read_text())["files"]
    assert files == {"report.md": "fit", "result.json": "fit"}
    assert temporaries(tmp_path) == []


def test_rerun_replaces_only_its_own_files_and_keeps_the_users(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1", "report.md": "a", "plot.png": "p"})
    (out / "notes.txt").write_text("mine")
    (out / "sensitivity").mkdir()
    (out / "sensitivity" / "sensitivity.json").write_text("{}")
    run(out, {"result.json": "2", "report.md": "b"})  # no plot this time: the stale one goes
    assert (out / "result.json").read_text() == "2" and (out / "report.md").read_text() == "b"
    assert not (out / "plot.png").exists()
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "sensitivity" / "sensitivity.json").read_text() == "{}"
    assert set(json.loads((out / MANIFEST).read_text())["files"]) == {"result.json", "report.md"}
    assert temporaries(tmp_path) == []


def test_a_foreign_file_with_one_of_our_names_is_refused_up_front(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1"})
    (out / "report.md").write_text("the user's own report")
    with pytest.raises(UserError, match="report.md is not a file this tool wrote"):
        ResultsFolder(out, names=NAMES)
    assert (out / "report.md").read_text() == "the user's own report"
    assert temporaries(tmp_path) == []


def test_a_folder_that_is_not_ours_is_refused_naming_a_file(tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "thesis.docx").write_text("x")
    with pytest.raises(UserError, match=r"other files in it \(e.g. thesis.docx\)"):
        ResultsFolder(mine, names=NAMES)
    (tmp_path / "file").write_text("x")
    with pytest.raises(UserError, match="is a file, not a folder"):
        ResultsFolder(tmp_path / "file", names=NAMES)
    with pytest.raises(UserError, match="does not exist"):
        ResultsFolder(tmp_path / "no" / "such", names=NAMES)


def test_a_results_folder_from_before_manifests_is_adopted(tmp_path):
    old = tmp_path / "old"
    old.mkdir()
    (old / "result.json").write_text("old")
    (old / "notes.txt").write_text("mine")
    run(old, {"result.json": "new", "report.md": "r"})
    assert (old / "result.json").read_text() == "new" and (old / "notes.txt").read_text() == "mine"
    assert "notes.txt" not in json.loads((old / MANIFEST).read_text())["files"]


def test_other_commands_files_are_kept_and_stay_theirs(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1"})
    with ResultsFolder(out, command="track", names=("tracks.csv",)) as tmp:
        (tmp / "tracks.csv").write_text("t")
    run(out, {"result.json": "2"})  # fit again: track's file is not fit's to remove
    assert (out / "tracks.csv").read_text() == "t"
    assert json.loads((out / MANIFEST).read_text())["files"]["tracks.csv"] == "track"


def test_an_error_while_writing_leaves_the_old_results(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1"})
    with pytest.raises(RuntimeError):
        with ResultsFolder(out, names=NAMES) as tmp:
            (tmp / "result.json").write_text("half")
            raise RuntimeError("boom")
    assert (out / "result.json").read_text() == "1"
    assert temporaries(tmp_path) == []


def test_the_temporary_sibling_exists_from_the_start_and_ctrl_c_removes_it(tmp_path):
    folder = ResultsFolder(tmp_path / "r", names=NAMES)
    assert folder.tmp.exists() and folder.tmp.parent == tmp_path
    (folder.tmp / "result.json").write_text("half")
    discard_temporaries()  # what the command line does on Ctrl-C
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("mask", [0o022, 0o002, 0o077])
def test_modes_follow_the_umask(tmp_path, mask):
    old = os.umask(mask)
    try:
        out = run(tmp_path / "r", {"result.json": "1"})
        write_text_atomic(tmp_path / "run.csv", "t_ms\n")
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o777 & ~mask
    assert stat.S_IMODE((out / "result.json").stat().st_mode) == 0o666 & ~mask
    assert stat.S_IMODE((out / MANIFEST).stat().st_mode) == 0o666 & ~mask
    assert stat.S_IMODE((tmp_path / "run.csv").stat().st_mode) == 0o666 & ~mask


def test_an_existing_results_folder_that_cannot_be_written_is_refused_up_front(tmp_path):
    import subprocess

    out = run(tmp_path / "r", {"result.json": "1"})
    out.chmod(0o555)
    immutable = os.geteuid() == 0 and subprocess.run(["chattr", "+i", str(out)], capture_output=True).returncode == 0
    try:
        if os.geteuid() == 0 and not immutable:
            pytest.skip("running as root without chattr: cannot make a folder unwritable")
        with pytest.raises(UserError, match="cannot write in"):
            ResultsFolder(out, names=NAMES)
        assert temporaries(tmp_path) == []
    finally:
        if immutable:
            subprocess.run(["chattr", "-i", str(out)], check=True)
        out.chmod(0o755)


def test_a_users_file_that_appears_during_the_run_is_kept_and_the_run_refused(tmp_path):
    out = run(tmp_path / "r", {"result.json": "1"})
    with pytest.raises(UserError, match="report.md is not a file this tool wrote"):
        with ResultsFolder(out, names=NAMES) as tmp:
            (tmp / "report.md").write_text("ours")
            (out / "report.md").write_text("the user's, written while we worked")
    assert (out / "report.md").read_text() == "the user's, written while we worked"
    assert (out / "result.json").read_text() == "1" and temporaries(tmp_path) == []
