import os
import signal

import pytest
from hypothesis import HealthCheck, settings

# Plain `pytest` (README's fast lane) and CI draw the same examples on every run (derandomized: a seed from each
# test), so a suite is red for a reason, not for a draw; CI (the CI variable set) draws more of them.
# HYPOTHESIS_PROFILE=explore draws fresh random examples, as a developer hunting for new hard cases wants
# (docs/testing.md, "Random examples").
_QUIET = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("ci", max_examples=200, derandomize=True, **_QUIET)
settings.register_profile("dev", max_examples=50, derandomize=True, **_QUIET)
settings.register_profile("explore", max_examples=200, **_QUIET)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if os.environ.get("CI") else "dev"))


def pytest_addoption(parser):
    parser.addoption("--zoo-starts", default=None, help="random starts per zoo system and method (default 200)")


@pytest.fixture(autouse=True)
def _first_class_unless_marked_inlined(request, monkeypatch):
    """The step loop's user functions first-class (``GEOMINT_INLINE=0``) except in tests marked ``inlined``.

    Inlined, every system a test module defines gets kernels compiled for it (seconds each, ~25 minutes for the
    suite on an empty cache); first-class, one compilation serves every system of a form.  The kernels' code is
    the same either way: the tests marked ``inlined`` (``tests/test_handles.py``: a method of each engine, the
    same bits inlined and first-class; user functions that raise; ensembles against ``solve``) show the inlined
    loop gives the same bits and the same failures."""
    if request.node.get_closest_marker("inlined") is None:
        monkeypatch.setenv("GEOMINT_INLINE", "0")


@pytest.fixture
def sigint_raises():
    """SIGINT answered as Python answers it by default, for one test, even where the runner ignores it (a job
    started in the background by a non-interactive shell ignores SIGINT, and geomint then leaves it ignored)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)
