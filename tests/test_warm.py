"""Variants started from a neighbour's nodes: the same results as a cold run, or a fallback."""

import numpy as np

from planarkin.solver.grid import Options
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


def test_the_warm_start_is_an_option_of_the_analysis():
    # planarkin.analysis.analyse(..., warm=Start): the analysis itself takes the neighbour's
    # path (nothing written into it from outside), and gives the cold run's results
    from planarkin.analysis import analyse, prepare
    from planarkin.solver.warmstart import Start
    study = Study(FB, analysis={"steps": 90})
    near = study.model({"a": 0.0405, "b": 0.121})
    opts = Options.from_model(near, **study.analysis)
    start = Start.of(prepare(study.model({"a": 0.04}), opts))
    an = prepare(near, opts, warm=start)
    assert start is not None and an.warmed and an.follower.rejected == 0
    cold = prepare(near, opts)
    assert not cold.warmed and len(an.Tn) < len(cold.Tn) + 8
    _, res = analyse(near, opts, warm=start)
    _, ref = analyse(near, opts)
    for a, b in ((res.q, ref.q), (res.qd, ref.qd), (res.qdd, ref.qdd), (res.p, ref.p)):
        assert np.abs(a - b).max() <= 1e-13 * np.abs(b).max()


# -- a study's variants are refused where `planarkin run` refuses them ------------------------

W_MODEL = open(FB).read().replace("d: 0.10 ", "d: 0.10\n  w: 360 ").replace(
    'f: "360*t"', 'f: "w*t"').replace("steps: 360}", "steps: 180, max_nodes: 2000}")


def _run_refusal(path, tmp_path, setting):
    """`planarkin run` of the model with --set setting (in process): exit code and output."""
    from click.testing import CliRunner
    from planarkin.cli import main
    r = CliRunner().invoke(main, ["run", str(path), "--set", setting, "--no-plots",
                                  "--out", str(tmp_path / "out")])
    return r.exit_code, r.output


def test_a_variant_over_the_budget_is_refused_as_run_refuses_it(tmp_path):
    # w = 1e6 deg/s: 17,453 rad in the run, past the 2,000 steps of max_nodes. `run` refuses
    # it before the path starts (budget.preflight, exit 2); the study's variant is invalid
    # with that message, whether it is solved alone (warm chain) or batched with others
    path = tmp_path / "fb.yaml"
    path.write_text(W_MODEL)
    code, out = _run_refusal(path, tmp_path, "w=1e6")
    assert code == 2 and "the path would need more than 2000 internal steps" in out
    study = Study(str(path))
    expect = out.split(": error: ", 1)[1].splitlines()[0]
    alone = study.solve({"w": 1e6}, None, warm=True)[0]
    assert (alone.status, alone.message) == ("invalid", expect)
    variants = [{"w": 360.0}, {"w": 360.5}, {"w": 1e6}, {"w": 361.0}]
    assert study.batch(variants) is not None         # the batch takes it, with preflight
    out = study.run(variants)
    assert [o.status for o in out] == ["ok", "ok", "invalid", "ok"]
    assert out[2].message == expect


def test_a_variant_with_a_non_finite_row_is_refused_as_run_refuses_it(monkeypatch):
    # a non-finite acceleration at the grid row t = 0.5 (as an overflow would give): `run`
    # refuses that row and the rows after (analysis.refuse: status 1, 'non-finite'); so does
    # the study's variant, cold or warm started
    from planarkin.solver import system
    from planarkin.analysis import analyse
    real = system.System.solve_batch

    def poisoned(self, t, Q, Qd, Qdd, **kw):
        info = real(self, t, Q, Qd, Qdd, **kw)
        if Q.shape[0] > 8 and (t == 0.5).any():
            Qdd[int(np.nonzero(t == 0.5)[0][0]), 2] = np.nan
        return info

    study = Study(FB, analysis={"steps": 90})
    _, _, start, _ = _solve(study, None, a=0.04)
    monkeypatch.setattr(system.System, "solve_batch", poisoned)
    cm = study.model({"a": 0.0405})
    info, res = analyse(cm, Options.from_model(cm, **study.analysis))
    assert info.status == 1 and info.event.kind == "non-finite" and len(res.t) == 45
    for o in (study.solve({"a": 0.0405})[0], study.solve({"a": 0.0405}, start, warm=True)[0]):
        assert (o.status, o.kind, o.t, o.message) == ("failed", "non-finite", 0.5,
                                                      info.message)
