"""Starts of a search analysed together (planarkin.synthesis.starts): every design the march
accepts is one the path follower accepts, on the same rows to rounding; the others are left to
the follower; a search's starts score and count the same either way."""

from __future__ import annotations

import numpy as np
import pytest

from clitools import ROOT
from planarkin.options import Options
from planarkin.synthesis import starts
from planarkin.synthesis.problem import Rejected
from planarkin.synthesis.synth import Synthesis

FIVE = ROOT / "mechanisms" / "synthesis" / "five-point-curve.yaml"
# rough pose estimates in the file (not the exact pose): the march starts from the follower's
# assembly
FUNCTION = ROOT / "mechanisms" / "synthesis" / "four-bar-function.yaml"


def _designs(syn, n, seed=0):
    """Designs of the file's hypercube that its screen passes: (values, compiled model)."""
    out = []
    for xp in syn.draw(n, seed, 0):
        v = syn.model.values(xp)
        got = syn.screen(v)
        if got is not None and not isinstance(got, Rejected):
            out.append((v, got))
    return out


def _rel(a, b):
    return np.abs(a - b).max() / max(1e-300, np.abs(a).max())


def _march(syn, designs):
    B = starts.batch_for(syn.model)
    assert B is not None
    return starts.march(B, designs, lambda cm: Options.from_model(cm, **syn.model.analysis))


@pytest.mark.parametrize("path,n", [(FIVE, 48), (FUNCTION, 16)],
                         ids=["exact-estimates", "rough-estimates"])
def test_a_marched_design_has_the_followers_rows_to_rounding(path, n):
    syn = Synthesis(path)
    designs = _designs(syn, n)
    assert len(designs) >= 8
    marched = _march(syn, designs)
    assert sum(r is not None for r in marched) >= 0.9 * len(designs)
    for (v, _), res in zip(designs, marched):
        ref = syn.model.analyse(v)
        if res is None:
            continue
        assert not isinstance(ref, Rejected), ref
        got = ref[2]
        assert np.array_equal(res.t, got.t)
        for name in ("q", "qd", "p", "pd"):
            assert _rel(getattr(got, name), getattr(res, name)) <= 1e-12, name
        assert res.qdd is None and got.qdd is None       # synthesis analyses up to velocity


def test_designs_the_follower_refuses_are_never_accepted(tmp_path):
    """Without the turns constraint most designs of the hypercube lock up or fold: the march
    leaves every one of those to the follower (None), and accepts some that turn."""
    text = FIVE.read_text().replace("  constraints: {turns: crank}\n", "")
    path = tmp_path / "free.yaml"
    path.write_text(text)
    syn = Synthesis(path)
    designs = _designs(syn, 40, seed=3)
    marched = _march(syn, designs)
    verdicts = [syn.model.analyse(v) for v, _ in designs]
    refused = [isinstance(r, Rejected) for r in verdicts]
    assert sum(refused) >= 5 and sum(not r for r in refused) >= 4
    for res, no in zip(marched, refused):
        assert not (no and res is not None)
    assert any(res is not None for res in marched)


@pytest.mark.parametrize("path,n", [(FIVE, 60), (FUNCTION, 16)],
                         ids=["exact-estimates", "rough-estimates"])
def test_a_search_scores_its_starts_as_one_by_one(monkeypatch, path, n):
    """candidates with the march and without it (every start through Model.analyse): the same
    accepted starts, scores to 1e-9, rejections and evaluations counted alike."""
    runs = []
    for batched in (True, False):
        syn = Synthesis(path)
        if not batched:
            monkeypatch.setattr(starts, "batch_for", lambda model: None)
        good, why, scores = syn.candidates(n, 7)
        runs.append((good, why, scores, syn.model.evaluations))
        monkeypatch.undo()
    (g1, w1, s1, e1), (g2, w2, s2, e2) = runs
    assert w1 == w2 and e1 == e2 and len(s1) == len(s2) >= 8
    assert np.allclose(s1, s2, rtol=1e-9, atol=1e-18)
    assert [tuple(np.round(x, 9)) for _, x, _ in g1] == [tuple(np.round(x, 9)) for _, x, _ in g2]


def test_few_designs_or_a_model_the_batch_cannot_take_go_one_by_one(monkeypatch):
    syn = Synthesis(FIVE)
    designs = _designs(syn, 40)[:starts.MIN_BATCH - 1]
    assert _march(syn, designs) == [None] * len(designs)
    called = []
    real = syn.model.analyse
    monkeypatch.setattr(starts, "batch_for", lambda model: None)
    monkeypatch.setattr(syn.model, "analyse", lambda v: called.append(v) or real(v))
    good, why, scores = syn.candidates(30, 1)
    assert len(called) == syn.model.evaluations >= len(scores) > 0


def test_the_starts_ahead_do_not_change_the_search(monkeypatch):
    """MIN_BATCH starts analysed together at a time: the scores of one by one."""
    monkeypatch.setattr(starts, "AHEAD", starts.MIN_BATCH)
    syn = Synthesis(FIVE)
    good, why, scores = syn.candidates(40, 2)
    monkeypatch.setattr(starts, "batch_for", lambda model: None)
    ref = Synthesis(FIVE).candidates(40, 2)
    assert why == ref[1] and np.allclose(scores, ref[2], rtol=1e-9, atol=1e-18)


def test_a_driver_with_a_breakpoint_is_left_to_the_follower(tmp_path):
    """The follower splits its path at a driver's breakpoint and takes one-sided rates there
    (SIDE_RULE); the march does not, so such designs go to the follower."""
    text = FIVE.read_text().replace('f: "2*pi*t"', 'f: "2*pi*t + 0.1*abs(t - 0.5)"')
    path = tmp_path / "kink.yaml"
    path.write_text(text)
    syn = Synthesis(path)
    designs = _designs(syn, 100)
    assert len(designs) >= starts.MIN_BATCH
    assert _march(syn, designs) == [None] * len(designs)


def test_a_file_that_asks_for_a_branch_is_left_to_the_follower(tmp_path):
    """The follower's assembly switches to the branch `assembly: branch:` asks for; a march
    from the drawn pose kept the other one (rocker.phi +87.5 deg where the follower gives
    -87.5 on four-bar-function with {rocker: '+'}). Such a file's starts go one by one."""
    text = (ROOT / "mechanisms" / "synthesis" / "four-bar-function.yaml").read_text().replace(
        "analysis: {start: 0", "assembly: {branch: {rocker: '+'}}\nanalysis: {start: 0")
    path = tmp_path / "branch.yaml"
    path.write_text(text)
    syn = Synthesis(path)
    assert starts.batch_for(syn.model) is None
