"""Variants started from a neighbour's nodes: the same results as a cold run, or a fallback."""

import numpy as np

from planarkin.solver import Options
from planarkin.studies import warm
from planarkin.studies.variants import Study

FB = "mechanisms/four-bar.yaml"


def _solve(study, start, **values):
    cm = study.model(values)
    return warm.analyse(cm, Options.from_model(cm, **study.analysis), start)


def test_a_neighbour_start_gives_the_cold_results_to_rounding():
    study = Study(FB, analysis={"steps": 90})
    info0, _, start, used = _solve(study, None, a=0.04)
    assert info0.status == 0 and start is not None and not used
    info, res, nxt, used = _solve(study, start, a=0.0405, b=0.121)
    assert used and info.status == 0 and info.fallbacks == 0 and nxt is not None
    cold = study.solve({"a": 0.0405, "b": 0.121})[1]
    for a, b in ((res.q, cold.q), (res.qd, cold.qd), (res.qdd, cold.qdd), (res.p, cold.p)):
        assert np.abs(a - b).max() <= 1e-13 * np.abs(b).max()


def test_a_start_that_would_change_the_result_falls_back_to_the_follower():
    study = Study(FB, analysis={"steps": 36})
    _, _, start, _ = _solve(study, None, a=0.04)
    # non-Grashof: the crank locks up; the neighbour's nodes cannot be corrected past it
    info, _, nxt, used = _solve(study, start, a=0.17)
    assert not used and info.status == 1 and info.event.kind == "lock-up" and nxt is None
    # the other assembly branch (the coupler's estimate mirrored): its own assembly decides
    text = open(FB).read().replace("coupler: {q: [0.04, 0, 55]}", "coupler: {q: [0.04, 0, -55]}") \
        .replace("rocker:  {q: [0.1, 0, 85]}", "rocker:  {q: [0.1, 0, -85]}")
    import planarkin
    other = planarkin.load(FB, text=text)
    info, res, _, used = warm.analyse(other, Options.from_model(other, steps=36), start)
    assert not used and info.status == 0
    assert res.body("rocker")["phi"][0] < 0
