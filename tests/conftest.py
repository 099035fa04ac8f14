"""Test set-up shared by every test module: float64 on (as the entry points do), the command
line's compilation cache off, and the simulations that several tests read, run once per
session (JAX compiles take seconds)."""

import os

import jax

jax.config.update("jax_enable_x64", True)

import pytest  # noqa: E402

# the command line keeps its compiled programs in the user's cache (identify.compile_cache):
# not the tests', which never read or fill it (measured: a run-wide cache shared by the
# workers did not shorten the suite, 670 s against 593-636 s); test_compile_cache turns it on
os.environ["IDENTIFY_NO_COMPILE_CACHE"] = "1"


# files whose tests compile the same programs (the same recording, model and fit settings: a
# compile is most of a fit, ~35-55 s against ~1 s of solving): one worker runs them all, so
# only the first compiles
SHARED_COMPILES = {
    "test_end_to_end.py": "the sample film", "test_bad_input.py": "the sample film",
    "test_discovery.py": "the paper's synthetic recording", "test_cli_fit.py": "the paper's synthetic recording",
}


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist's own, which reads the groups
def pytest_collection_modifyitems(config, items):
    """Each test in its file's group (``--dist loadgroup``, the README's: a file's module
    fixtures are computed once, on one worker), files that compile the same programs in one
    group (``SHARED_COMPILES``); and the files that hold slow end-to-end tests first, in their
    own order: the workers take the groups in this order, so the long ones start at once and
    the short ones fill in at the end, instead of one worker running a long file alone while
    the other has finished."""
    for item in items:
        item.add_marker(pytest.mark.xdist_group(SHARED_COMPILES.get(item.path.name, item.path.name)))
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)  # stable: the order within each part stays


PAPER_SPEED = 56.3 / 3.6  # m/s, the paper's impact speed


@pytest.fixture(scope="session")
def a4():
    from sim import load_vehicle

    return load_vehicle("audi_a4")


@pytest.fixture(scope="session")
def identified_run(a4):
    from sim import named_params, simulate

    return simulate(named_params("paper_identified"), a4, PAPER_SPEED)


@pytest.fixture(scope="session")
def default_run(a4):
    from sim import named_params, simulate

    return simulate(named_params("vsim_default"), a4, PAPER_SPEED)


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
