"""Whether the compiled route can be tested here: numba is a dependency, but the suite must pass
without it too (issue 17), where the numpy passes run. Tests of the compiled route itself are
marked `needs_numba` and skip only where numba is not installed, with NO_NUMBA as the reason;
.ci/run fails when that reason appears in the run with numba installed, so the route-equality
tests can never skip silently there, and runs the suite a second time with numba uninstalled."""

import importlib.util

import pytest

# find_spec, not an import: collecting the tests must not import numba (a test checks that a
# small run never does, and the import costs ~0.3 s per worker)
HAVE_NUMBA = importlib.util.find_spec("numba") is not None
NO_NUMBA = "numba is not installed: the compiled route is not there to test"
needs_numba = pytest.mark.skipif(not HAVE_NUMBA, reason=NO_NUMBA)


def skip_without_numba() -> None:
    """In a fixture or helper that every compiled-route test calls: skip where numba is
    missing (the reason NO_NUMBA)."""
    if not HAVE_NUMBA:
        pytest.skip(NO_NUMBA)
