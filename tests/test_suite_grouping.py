"""The suite's own scheduling (``tests/conftest.py``): under the README's ``-n 2 --dist
loadgroup`` the files of a ``SHARED_COMPILES`` group, and each file's tests, run on one
worker. When this silently stopped (pytest 9.2 ignores xdist_group marks) every module
fixture ran once per worker and the suite took 838 s instead of 555 s."""

import shutil
import subprocess
import sys
from pathlib import Path

from conftest import SHARED_COMPILES

PROBE = '''import os, pathlib


def test_{k}():
    pathlib.Path(r"{out}", "{name}_{k}").write_text(os.environ["PYTEST_XDIST_WORKER"])
'''


def test_a_shared_compiles_group_runs_on_one_worker(tmp_path):
    group = next(iter(set(SHARED_COMPILES.values())))
    files = [f for f, g in SHARED_COMPILES.items() if g == group] + ["test_alone.py"]
    suite, out = tmp_path / "tests", tmp_path / "ran"
    suite.mkdir(), out.mkdir()
    shutil.copy(Path(__file__).with_name("conftest.py"), suite / "conftest.py")
    for name in files:
        (suite / name).write_text("\n".join(PROBE.format(k=k, out=out, name=name) for k in range(4)))
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadgroup",
                          "-p", "no:cacheprovider", str(suite)], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stdout + run.stderr
    worker = {p.name: p.read_text() for p in out.iterdir()}
    assert len(worker) == 4 * len(files)
    grouped = {w for n, w in worker.items() if not n.startswith("test_alone")}
    alone = {w for n, w in worker.items() if n.startswith("test_alone")}
    assert len(grouped) == 1 and len(alone) == 1, worker
