"""Local runs and later draws' starts computed ahead in worker processes (synthesize(jobs=N),
planarkin.synthesis.runs): the serial search's result, design for design and count for count,
whatever the budget."""

import numpy as np
import pytest

from planarkin.diagnostics import InputError
from planarkin.synthesis.synth import synthesize


def _same(a, b):
    assert (a.status, a.message, a.ended, a.rejected) == (b.status, b.message, b.ended, b.rejected)
    assert (a.evaluations, a.analyses, a.jacobians, a.runs) == \
        (b.evaluations, b.analyses, b.jacobians, b.runs)
    assert a.starts == b.starts
    assert len(a.designs) == len(b.designs) > 0
    for d, e in zip(a.designs, b.designs):
        assert np.array_equal(d.x, e.x) and d.cost == e.cost
        assert (d.nfev, d.njev, d.message) == (e.nfev, e.njev, e.message)


@pytest.mark.parametrize("path, search", [
    # runs cut by per_local that go on while they lead, legs the budget then left makes
    # another run's (run here again), a budget that ends the search
    ("mechanisms/synthesis/five-point-curve.yaml",
     {"evaluations": 700, "seed": 1, "per_local": 60, "starts": 60}),
    # probed runs abandoned behind the design kept (not checked over the cycle), the goal met
    ("mechanisms/synthesis/straight-line.yaml", {"seed": 7}),
    # one run a draw: the next draws' starts analysed in the worker meanwhile, the last one
    # past the budget analysed here
    ("mechanisms/synthesis/four-bar-function.yaml",
     {"seed": 1, "starts": 6, "local": 1, "goal": 0, "evaluations": 100}),
])
def test_runs_in_worker_processes_give_the_serial_search(path, search):
    serial = synthesize(path, **search)
    _same(serial, synthesize(path, jobs=2, **search))


def test_a_budget_too_small_for_legs_ahead_runs_them_here():
    # 130 evaluations: less than two legs' worth (per_local 100 + margin): nothing is sent
    search = {"evaluations": 130, "per_local": 100, "seed": 2}
    path = "mechanisms/synthesis/five-point-curve.yaml"
    _same(synthesize(path, **search), synthesize(path, jobs=3, **search))


def test_a_draw_ahead_that_decides_the_cycles_wrapping_gives_the_serial_search():
    """ellipse.yaml with its own d out of the bounds and its midpoint no linkage: neither
    decides whether its free times go round the cycle, and seed 11's first draw of 4 starts is
    refused whole, so the next draw, analysed in a worker, decides it (Synthesis.wrap): taken
    here with it, and the legs run in the workers with it."""
    search = {"seed": 11, "starts": 4, "local": 1, "evaluations": 200, "per_local": 40}
    path = "mechanisms/synthesis/ellipse.yaml"
    serial = synthesize(path, overrides={"d": 90}, **search)
    assert serial.model.wrap is True and serial.designs
    parallel = synthesize(path, overrides={"d": 90}, jobs=2, **search)
    _same(serial, parallel)
    assert parallel.model.wrap is True


@pytest.mark.parametrize("jobs", [0, -1, 1.5, True, "2", 2000])
def test_jobs_must_be_a_whole_number_of_processes(jobs):
    with pytest.raises(InputError, match="jobs must be a whole number from 1 to 1024"):
        synthesize("mechanisms/synthesis/four-bar-path.yaml", jobs=jobs)
