"""The project's own promises: README's commands and CI agree."""

import subprocess
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
    # .ci/run's own line that picks the command, run here as CI runs it, gives README's line 2
    pick = next(line for line in ci.splitlines() if line.startswith("test_command="))
    out = subprocess.run(["bash", "-c", pick + '\nprintf %s "$test_command"'], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    assert out == readme_test
    assert 'eval "$test_command"' in ci
