"""The local phase of synthesis (planarkin.synthesis.local): trials at the target inputs only,
their exact Jacobian against central differences per target kind, the branch kept by the
predictor, and a straight-line design reached exactly and verified over its whole cycle."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from planarkin.synthesis.local import Local
from planarkin.synthesis.problem import Rejected
from planarkin.synthesis.synth import Synthesis, synthesize

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "mechanisms" / "synthesis"
LINE = EX / "straight-line.yaml"
# Hoeken's straight-line linkage (crank 1, coupler = rocker 2.5, ground 2, P on the coupler
# line 5 from B), scaled by 8 and turned so that its straight stretch runs along x = 20 mm
HOEKEN = {"x0": 52.0, "y0": 16.5, "th0": 1.5707963267948966, "a": 8, "b": 20, "c": 20,
          "d": 16, "px": 40, "py": 0}


def _anchored(path, x, wrap=False):
    syn = Synthesis(path)
    syn.wrap = wrap
    r, _, d = syn.evaluate(np.asarray(x, dtype=float), jac=False, final=True)
    assert r is not None, d
    loc = Local(syn)
    loc.anchor(d)
    return syn, loc


def _check(loc, x, tol=1e-6):
    """The trial's exact Jacobian against central differences of its residuals, at x (near
    the anchor: every trial is solved from the anchor's predictor)."""
    r, st, bar = loc.evaluate(x)
    assert r is not None, st
    J = loc.jacobian(st, bar)
    Jn = np.zeros_like(J)
    for i in range(len(x)):
        h = 1e-6 * max(1.0, abs(x[i]))
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        Jn[:, i] = (loc.evaluate(xp)[0] - loc.evaluate(xm)[0]) / (2 * h)
    scale = np.abs(J).max()
    assert np.abs(J - Jn).max() <= tol * scale, np.abs(J - Jn).max(axis=0) / scale


def test_trial_jacobian_path_free_timing():
    """The six crank times are unknowns of a trial (the full formulation): 12 residuals, the
    coordinates of P - T, and the turns barrier row; 15 columns, dP/dp for the 9 parameters
    and dP/dt = Pdot for the six times (each time its own point only)."""
    syn, loc = _anchored(LINE, [0, 0, 0.3, 10, 40, 30, 40, 20, 20], wrap=True)
    assert loc.nt == 6
    x = loc.ref[0] + 1e-3 * np.arange(15) / 15
    r, st, bar = loc.evaluate(x)
    assert len(r) == 13 and bar is not None
    J = loc.jacobian(st, bar)
    assert J.shape == (13, 15)
    # a time moves its own point only
    assert np.all(J[2:, 9] == 0) and np.all(J[:2, 9] != 0)
    _check(loc, x)


def test_trial_jacobian_prescribed_inputs_and_motion(tmp_path):
    """Prescribed inputs (the time moves with p: dt*/dp = -f_p / f_t) and a motion target's
    free times, through the trial's own Newton solve."""
    syn, loc = _anchored(EX / "four-bar-path.yaml", [0.041, 0.119, 0.101, 0.099])
    assert loc.nt == 0
    _check(loc, loc.ref[0] + np.array([1e-4, -2e-4, 1e-4, 1e-4]))
    text = (EX / "four-bar-function.yaml").read_text()
    old = text[text.index("    - function: rocker.phi"):text.index("  constraints:")]
    p = tmp_path / "m.yaml"
    p.write_text(text.replace(old, "    - motion: coupler\n      point: P\n      poses: "
                                   "[[0.03, 0.07, 50], [0.04, 0.1, 20], [0.0, 0.1, 10]]\n"))
    syn, loc = _anchored(p, [0.121, 0.099, 0.101, 0.05, 0.3, 0.6])
    assert loc.nt == 3
    _check(loc, loc.ref[0] + 1e-4)


def test_a_trial_that_leaves_the_branch_is_refused():
    """A step that the first-order predictor cannot follow (Newton's correction larger than
    local.JUMP, here the crank turned half a turn at the same times) is a refused trial, as a
    design that does not assemble: a local run never silently changes branch."""
    syn, loc = _anchored(LINE, [0, 0, 0.3, 10, 40, 30, 40, 20, 20], wrap=True)
    x = loc.ref[0].copy()
    assert loc.evaluate(x)[0] is not None
    x[2] += np.pi
    r, st, _ = loc.evaluate(x)
    assert r is None and isinstance(st, Rejected)


def test_grid_start_in_order_either_direction():
    """Hoeken's path passes the targets with the crank time decreasing: the grid's nearest
    points in order are found in that direction (they used to be forced forwards, which
    scrambled the start: order margin -1)."""
    syn = Synthesis(LINE, overrides=HOEKEN)
    syn.wrap = True
    out = syn.model.analyse(syn.model.values(np.array(list(HOEKEN.values()), dtype=float)))
    t = syn._grid_times(out[2])[0]
    assert np.all(np.diff(t) < 0)
    r, _, d = syn.evaluate(np.array(list(HOEKEN.values()), dtype=float), jac=False, final=True)
    assert r is not None, d
    assert d.margins["order"]["ok"] and d.cost < 0.05


def test_straight_line_reaches_1e_12_from_a_known_linkage_and_is_verified():
    """The six collinear points from Hoeken's linkage (the file's values, search nominal: 1):
    the local run reaches SSE < 1e-12 mm^2 in a few dozen trials, and the returned design is
    the full check's: analysed over its whole cycle on its branch, crank turning (Grashof),
    targets in order, each target at its nearest point of the path."""
    res = synthesize(LINE, overrides=HOEKEN, starts=1, local=1, nominal=1, evaluations=200)
    assert res.status == 0, res.message
    d = res.designs[0]
    assert d.cost < 1e-12
    assert res.evaluations <= 200 and res.analyses <= 5
    assert d.margins["turns"]["ok"] and d.margins["order"]["ok"]
    assert d.state.result.t[-1] == res.model.end
    # again from scratch: a fresh analysis of the design over the cycle gives the same cost
    syn = Synthesis(LINE)
    syn.wrap = True
    r, _, again = syn.evaluate(d.x, jac=False, final=True)
    assert r is not None, again
    assert again.cost < 1e-12
    P = again.state.p[:, syn.points.index("P")]
    assert np.abs(P - np.array(syn.design.targets[0].values)).max() < 1e-6



def test_probe_limits_are_the_documented_checkpoints():
    from planarkin.synthesis.local import probe_limits
    assert probe_limits(30, 3e-2) == [(30, 3e-2), (40, 3e-2 * 1e-2), (60, 3e-2 * 1e-4)]


def test_a_probed_run_that_falls_too_slowly_is_abandoned():
    """With a checkpoint no run can pass (cost 0 after 5 trials) the run stops at its first
    accepted iterate from the fifth trial on, says so, and returns its best iterate; without
    it the same run goes on."""
    syn, loc = _anchored(LINE, [0, 0, 0.3, 10, 40, 30, 40, 20, 20], wrap=True)
    _, _, d = syn.evaluate(np.array([0, 0, 0.3, 10, 40, 30, 40, 20, 20.0]), jac=False,
                           final=True)
    e0 = loc.evaluations
    x, msg, trail = loc.run(d, 100, 0.0, [(5, 0.0)])
    assert msg.startswith("abandoned: sum of squares") and "trials" in msg
    assert 5 <= loc.evaluations - e0 < 20
    r = loc.evaluate(x)[0]
    assert abs(float(r @ r) - loc.last_cost) <= 1e-9 * loc.last_cost
    e0 = loc.evaluations
    _, msg, _ = loc.run(d, 20, 0.0)
    assert not msg.startswith("abandoned") and loc.evaluations - e0 >= 19


def test_starts_in_batches_end_at_the_first_design_below_the_goal():
    """four-bar-path.yaml in batches of two starts: its first local run reaches the goal, so
    the search analyses only the first batch (the starts it took are the batch's accepted)
    and gives the same design as all starts at once."""
    once = synthesize(EX / "four-bar-path.yaml", starts=8, local=8)
    batched = synthesize(EX / "four-bar-path.yaml", starts=8, local=8, batch=2)
    assert once.status == batched.status == 0
    assert batched.runs == 1 and len(batched.starts) <= 2 < len(once.starts)
    assert batched.analyses < once.analyses
    assert batched.designs[0].cost < 1e-20


def test_a_start_out_of_order_is_run_but_never_returned():
    """The starts of a closed curve are not held to the order of their free times (a local
    run puts the points in order); a run that reaches no design in order returns nothing, not
    its start (local.verified). An open path's starts are."""
    from planarkin.synthesis.local import verified
    syn = Synthesis(EX / "ellipse.yaml")          # a closed curve: most starts out of order
    syn.wrap = True
    good, why, scores = syn.candidates(30, 1)
    assert "constraint order" not in why
    out = [d for _, _, d in good if not d.margins["order"]["ok"]]
    assert out, "no start out of order among the accepted"
    first = out[0]
    local = Local(syn)
    x = local.unknowns(first)
    lo, hi = syn.bounds()
    rejected = []
    got = verified(syn, local, x, [x], lo, hi, rejected, first)
    assert isinstance(got, Rejected) and "order" in got.reason, got
    assert rejected and "order" in rejected[0]
    line = Synthesis(EX / "straight-line.yaml")
    assert syn.closed and not line.closed


def test_a_trial_the_file_would_refuse_is_refused_without_validating_the_file(monkeypatch):
    """A trial whose numbers fail the validator's checks (here ph3's acos out of its domain)
    is refused from the design's arrays: a local run only needs to know, so the file is not
    validated for the words (the start's screen and the full check still word it)."""
    import pytest

    from planarkin.diagnostics import InputError
    syn, loc = _anchored(LINE, [0, 0, 0.3, 10, 40, 30, 40, 20, 20], wrap=True)
    x = loc.ref[0].copy()
    x[3:7] = [5, 5, 5, 60]             # a, b, c, d: the coupler and rocker cannot close
    values = syn.model.values(x[:loc.k])
    with pytest.raises(InputError, match="ph3"):
        syn.model.compiled(values)                      # worded: the validator's message

    def validated(*args, **kw):
        raise AssertionError("the file was validated")
    monkeypatch.setattr(syn.model.study, "model", validated)
    r, st, bar = loc.evaluate(x)
    assert r is None and bar is None and isinstance(st, Rejected)
    assert st.reason.startswith("invalid: ")
