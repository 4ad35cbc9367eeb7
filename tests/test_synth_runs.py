"""A local run's allocation (planarkin.synthesis.runs.run_from): a run cut by its own budget
(per_local) goes on from its verified end while it leads the search, until it converges, falls
by less than 0.1 % over per_local trials, falls behind the designs kept or the search's budget
runs out. Fakes stand for the local runs, so the rule is checked by counts, not by a search."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from planarkin.synthesis import runs as synth

CUT = "The maximum number of function evaluations is exceeded."
DONE = "`xtol` termination condition is satisfied."


class _Design:
    def __init__(self, cost, message=""):
        self.cost, self.message = cost, message


class _Local:
    """Each run ends at the next of `ends` (cost, message) after all the trials it is given."""

    def __init__(self, ends):
        self.ends = iter(ends)
        self.evaluations = 0
        self.last_cost = None
        self.calls = []

    def run(self, first, n, stop, probe, halt=None):
        self.calls.append((first.cost, n))
        self.evaluations += n
        cost, message = next(self.ends)
        self.last_cost = cost
        return cost, message, [cost]


@pytest.fixture
def verified(monkeypatch):
    """local.verified: the run's end passes the full check (a Design of its cost)."""
    monkeypatch.setattr(synth, "verified", lambda syn, local, x, trail, lo, hi, rejected,
                        first: _Design(x))


def _run(local, designs=(), evaluations=10_000):
    syn = SimpleNamespace(model=SimpleNamespace(evaluations=0, jacobians=0))
    cfg = {"evaluations": evaluations, "per_local": 100, "keep": 1}
    return synth.run_from(syn, local, cfg, _Design(1.0), 0.0, (), (None, None), list(designs), [],
                      halt=None)


def test_a_leading_run_cut_by_its_budget_goes_on_until_it_converges(verified):
    local = _Local([(1e-3, CUT), (1e-5, CUT), (1e-6, DONE), (1e-9, DONE)])
    d = _run(local)
    assert local.calls == [(1.0, 100), (1e-3, 100), (1e-5, 100)]
    assert d.cost == 1e-6 and d.nfev == 300 and d.message == DONE


def test_a_run_behind_the_designs_kept_is_not_continued(verified):
    local = _Local([(1e-3, CUT), (1e-5, CUT)])
    d = _run(local, designs=[_Design(1e-4)])
    assert local.calls == [(1.0, 100)] and d.cost == 1e-3


def test_a_run_that_stops_falling_is_not_continued(verified):
    local = _Local([(1e-3, CUT), (1e-3, CUT), (1e-4, CUT)])
    d = _run(local)
    assert len(local.calls) == 2 and d.cost == 1e-3


def test_a_crawling_run_gives_the_budget_back(verified):
    """A run falling by less than FALL (0.1 %) of its sum of squares over per_local trials (a
    crawl along a valley) stops at the end of that stretch; 0.2 % goes on."""
    assert synth.FALL == 1e-3
    local = _Local([(1e-3, CUT), (0.998e-3, CUT), (0.9975e-3, CUT), (1e-9, DONE)])
    d = _run(local)
    assert len(local.calls) == 3 and d.cost == 0.9975e-3


def test_continuing_runs_leave_one_evaluation_for_the_full_check(verified):
    """The search's budget ends a continued run as it ends any run: each segment is given
    at most the budget less one evaluation, and none starts without one trial to spend."""
    local = _Local([(1e-3, CUT), (1e-5, CUT), (1e-6, CUT)])
    d = _run(local, evaluations=150)
    assert local.calls == [(1.0, 100), (1e-3, 49)] and d.cost == 1e-5 and d.nfev == 149


def test_a_run_whose_end_fails_the_full_check_is_not_continued(monkeypatch):
    """A run whose end failed the full check returns the last iterate that passes (its message
    says so): the valley it followed left the branch, so it stops there."""
    monkeypatch.setattr(synth, "verified", lambda syn, local, x, trail, lo, hi, rejected,
                        first: _Design(x, "the end of the local run failed the full check"))
    local = _Local([(1e-3, CUT), (1e-5, CUT)])
    d = _run(local)
    assert len(local.calls) == 1 and d.message.startswith("the end of the local run failed")
