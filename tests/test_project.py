"""The project's own promises: README's commands and CI agree."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_readme_starts_with_install_run_and_test_commands():
    lines = (ROOT / "README.md").read_text().splitlines()
    install, test = lines[0].strip(), lines[1].strip()
    assert "pip install -e ." in install and "identify " in install
    assert "python -m pytest" in test


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text()
    readme_test = (ROOT / "README.md").read_text().splitlines()[1].split("#")[0].strip()
    # .ci/run takes the README's first line that runs pytest and evaluates it.
    assert "grep -m1 'python -m pytest' README.md" in ci and "eval" in ci
    first = next(line for line in (ROOT / "README.md").read_text().splitlines() if "python -m pytest" in line)
    assert re.sub(r"\s*#.*$", "", first.strip()) == readme_test
