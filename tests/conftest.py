"""Test set-up shared by every test module: float64 on (as the entry points do), the command
line's compilation cache off, and the simulations that several tests read, run once per
session (JAX compiles take seconds)."""

import os

# two workers share the two cores (the README's `-n 2`): XLA's intra-op thread pool would put
# each on both, where its threads mostly wait (the NHTSA fit: 83 s on one core, 83 s on two
# with 132 s of CPU), and the other worker waits for them
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false").strip()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import pytest  # noqa: E402

# the command line keeps its compiled programs in the user's cache (identify.compile_cache):
# not the tests', which never read or fill it (measured: a run-wide cache shared by the
# workers did not shorten the suite, 670 s against 593-636 s); test_compile_cache turns it on
os.environ["IDENTIFY_NO_COMPILE_CACHE"] = "1"


# files whose tests compile the same programs (the same recording, model and fit settings: a
# compile is most of a fit, ~17-25 s against ~1 s of solving): one worker runs them all, so
# only the first compiles
SHARED_COMPILES = {
    "test_end_to_end.py": "the sample film", "test_bad_input.py": "the sample film",
    "test_discovery.py": "the paper's synthetic recording", "test_cli_fit.py": "the paper's synthetic recording",
}


def work_unit(nodeid: str) -> str:
    """The unit of work one worker runs whole: the test's file, or its ``SHARED_COMPILES`` group."""
    path = nodeid.split("::", 1)[0]
    return SHARED_COMPILES.get(path.rsplit("/", 1)[-1], path)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadgroup`` (the README's): each :func:`work_unit` on one worker, so a file's
    module fixtures are computed once and the files of a ``SHARED_COMPILES`` group compile
    once; the units in collection order (:func:`pytest_collection_modifyitems`), not by size.

    Done here rather than with ``xdist_group`` marks: pytest-xdist groups those by appending
    the group to the test's node id, which pytest 9.2 no longer lets it change, so the marks
    are silently ignored and the tests dealt out one by one (pytest-xdist issue 1386; on this
    suite each module fixture then ran once per worker and the suite took 838 s)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ByWorkUnit(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            return work_unit(nodeid)

    config.option.loadscopereorder = False
    return ByWorkUnit(config, log)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """The files that hold slow end-to-end tests first, in their own order: the workers take
    the work units in this order (:func:`pytest_xdist_make_scheduler`), so the long ones
    start at once and the short ones fill in at the end, instead of one worker running a long
    file alone while the other has finished."""
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)  # stable: the order within each part stays


PAPER_SPEED = 56.3 / 3.6  # m/s, the paper's impact speed


@pytest.fixture(scope="session")
def a4():
    from sim import load_vehicle

    return load_vehicle("audi_a4")


@pytest.fixture(scope="session")
def a4_vsim(a4):
    """The A4 as the paper's V-SIM models it: wheels without spin inertia (``sim.wheels``).
    What is compared with the paper's figures runs on it."""
    import equinox as eqx
    import jax.numpy as jnp

    return eqx.tree_at(lambda v: v.wheel_spin_inertia, a4, jnp.zeros(2))


@pytest.fixture(scope="session")
def identified_run(a4_vsim):
    from sim import named_params, simulate

    return simulate(named_params("paper_identified"), a4_vsim, PAPER_SPEED)


@pytest.fixture(scope="session")
def default_run(a4_vsim):
    from sim import named_params, simulate

    return simulate(named_params("vsim_default"), a4_vsim, PAPER_SPEED)


SAMPLE_FILM = __import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "samples" / "a4_paper.mp4"


@pytest.fixture(scope="session")
def sample_results(tmp_path_factory):
    """The results folder of the README's main command, ``identify fit`` on the bundled
    sample film, run once per session (the slow end-to-end tests share it)."""
    from identify.cli import main

    out = tmp_path_factory.mktemp("sample") / "a4_paper.identify"
    assert main(["fit", str(SAMPLE_FILM), "--vehicle", "audi_a4", "--out", str(out), "--quiet"]) == 0
    return out


NHTSA_10146 = __import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "nhtsa-10146" / "v10146.EV5"


@pytest.fixture(scope="session")
def test10146():
    """The real NHTSA test 10146 as read (vehicle, engine and barrier channels), shared by
    the recording, engine and force-check tests."""
    from identify.recordings import read_nhtsa

    return read_nhtsa(NHTSA_10146)


@pytest.fixture(scope="session")
def motion(test10146):
    """10146's measured motion (``measurement_from_test``)."""
    from identify.recordings import measurement_from_test

    return measurement_from_test(test10146)


@pytest.fixture()
def figures(monkeypatch):
    """Every matplotlib figure saved during the test, in order (still written to disk): plots
    are checked for what they show, not for their file size."""
    import matplotlib.figure

    saved = []
    original = matplotlib.figure.Figure.savefig

    def savefig(self, *args, **kwargs):
        saved.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    return saved
