"""``identify.compile_cache``: where the command line keeps JAX's compiled programs, and that a
run's compiles are kept and read back."""

import os
import subprocess
import sys

import jax

from identify.compile_cache import DIR_VARIABLE, OFF_VARIABLE, default_dir, enable


def test_default_folder_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_dir() == tmp_path / "crash-identify" / "jax"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_dir() == tmp_path / "home" / ".cache" / "crash-identify" / "jax"


def test_off_or_unwritable_is_no_error_and_changes_nothing(monkeypatch, tmp_path):
    before, env_before = jax.config.jax_compilation_cache_dir, os.environ.get(DIR_VARIABLE)
    monkeypatch.setenv(OFF_VARIABLE, "1")
    assert enable(tmp_path / "c") is None and not (tmp_path / "c").exists()
    monkeypatch.delenv(OFF_VARIABLE)
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    assert enable(blocker / "c") is None  # cannot be made
    assert jax.config.jax_compilation_cache_dir == before and os.environ.get(DIR_VARIABLE) == env_before


def test_a_second_process_reads_the_first_ones_compiles(tmp_path):
    # the same jitted function in two fresh processes: the first writes the cache, the second
    # finds its program there (JAX counts the hit) and adds nothing
    folder = tmp_path / "cache"
    code = (
        "import sys, jax, jax.numpy as jnp\n"
        "from identify.compile_cache import enable\n"
        f"assert enable({str(folder)!r}) is not None\n"
        "from jax._src import monitoring\n"
        "hits = []\n"
        "monitoring.register_event_listener(lambda e, **kw: hits.append(e) if 'cache_hits' in e else None)\n"
        "print(float(jax.jit(lambda x: jnp.sin(x) * 2.0)(1.0)))\n"
        "print('hits', len(hits))\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in (DIR_VARIABLE, OFF_VARIABLE)}
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert first.returncode == 0, first.stderr
    files = sorted(p.name for p in folder.rglob("*") if p.is_file())
    assert files, "nothing was written to the cache"
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert second.returncode == 0, second.stderr
    assert "hits 0" in first.stdout and "hits 0" not in second.stdout, (first.stdout, second.stdout)
    assert sorted(p.name for p in folder.rglob("*") if p.is_file()) == files


def test_compiling_commands_keep_their_programs_in_the_users_cache(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in (DIR_VARIABLE, OFF_VARIABLE)}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    folder = tmp_path / "xdg" / "crash-identify" / "jax"
    listed = subprocess.run([sys.executable, "-m", "identify.cli", "vehicles"], capture_output=True, text=True,
                            env=env, timeout=120)
    assert listed.returncode == 0, listed.stderr
    assert not folder.exists()  # a command that compiles nothing makes no cache
    out = tmp_path / "run.csv"
    ran = subprocess.run([sys.executable, "-m", "identify.cli", "simulate", "--vehicle", "audi_a4", "--params",
                          "paper_identified", "--duration-ms", "50", "--out", str(out)],
                         capture_output=True, text=True, env=env, timeout=300)
    assert ran.returncode == 0, ran.stderr
    assert any(p.is_file() for p in folder.rglob("*"))
