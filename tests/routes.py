"""Whether the compiled route can be tested here: numba is a dependency, but the suite must pass
without it too (issue 17), where the numpy passes run. Tests of the compiled route itself are
marked `needs_numba` and skip only where numba is not installed, with NO_NUMBA as the reason.
.ci/run sets PLANARKIN_REQUIRE_NUMBA=1 for its run with numba installed, which turns that skip
into a failure (so the route-equality tests can never skip silently there), then runs the suite
a second time with numba uninstalled."""

import importlib.util
import os

import pytest

# find_spec, not an import: collecting the tests must not import numba (a test checks that a
# small run never does, and the import costs ~0.3 s per worker)
HAVE_NUMBA = importlib.util.find_spec("numba") is not None
REQUIRED = os.environ.get("PLANARKIN_REQUIRE_NUMBA") == "1"
NO_NUMBA = "numba is not installed: the compiled route is not there to test"
# required and missing: the tests run, and fail on numba's import
needs_numba = pytest.mark.skipif(not HAVE_NUMBA and not REQUIRED, reason=NO_NUMBA)


def skip_without_numba() -> None:
    """In a fixture or helper that every compiled-route test calls: skip where numba is
    missing (the reason NO_NUMBA), fail there when PLANARKIN_REQUIRE_NUMBA=1."""
    if not HAVE_NUMBA:
        if REQUIRED:
            pytest.fail("PLANARKIN_REQUIRE_NUMBA=1 but numba is not installed")
        pytest.skip(NO_NUMBA)
