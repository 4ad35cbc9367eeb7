"""Drivers whose velocity or acceleration jumps: the path is followed piece by piece.

The solver is tested against the interface of planarkin.functions.expr.TimeFunction (breakpoints(start,
end) and derivatives(t, side)) through `Piecewise`, a small driver function written here: a
polynomial per piece with exact derivatives, so these tests do not depend on the expression
parser's piecewise support. The mechanism is an in-line slider-crank (crank r, rod l) whose crank
angle is the driver f(t); its closed form: tests/closedforms.py (slider_crank).

Checked: velocities and accelerations on both sides of each kink equal the closed form with the
one-sided f', f'' (the two nodes at the breakpoint; grid rows there take the right-hand limit,
a row at the end time the left-hand one), positions are continuous, no internal node interval
straddles a breakpoint, the warning names the time and the jumps, summary.json states the
convention; a position jump, an undeclared kink and non-finite derivatives are refused.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import planarkin  # noqa: E402
from closedforms import slider_crank  # noqa: E402
from planarkin.solver.assembly import assemble  # noqa: E402
from planarkin.functions.expr import Breakpoint  # noqa: E402
from planarkin.solver.grid import Analysis, Options  # noqa: E402

R, L = 0.1, 0.3
TWO_PI = 2 * math.pi


class Piecewise:
    """f(t) = pieces[k](t) on [cuts[k-1], cuts[k]) (numpy poly1d per piece), the same interface
    as TimeFunction: __call__, derivatives(t, side), breakpoints(start, end). At a cut, side 0
    gives the right piece's rule (what a where(t < c, ...) written by hand gives), -1 the left
    piece, +1 the right. declare=False: breakpoints() returns [] (an undeclared kink)."""

    def __init__(self, cuts, pieces, declare=True, nan_at=None):
        self.cuts = list(cuts)
        self.pieces = [np.poly1d(p) for p in pieces]
        self.declare = declare
        self.nan_at = nan_at
        self.text = "piecewise test function"

    def _piece(self, t, side):
        k = np.searchsorted(self.cuts, t, side="left" if side < 0 else "right")
        return k

    def __call__(self, t):
        return self.derivatives(t)[0]

    def derivatives(self, t, side: int = 0):
        t = np.asarray(t, dtype=float)
        k = self._piece(t, side)
        out = []
        for order in range(3):
            v = np.zeros_like(t)
            for i, p in enumerate(self.pieces):
                v = np.where(k == i, np.polyder(p, order)(t) if order else p(t), v)
            if self.nan_at is not None:
                v = np.where(t == self.nan_at, np.nan, v) if order else v
            out.append(v if t.ndim else float(v))
        return tuple(out)

    def breakpoints(self, start, end):
        if not self.declare:
            return []
        out = []
        for c in self.cuts:
            if start <= c <= end:
                left = self.derivatives(np.array([c]), -1)
                right = self.derivatives(np.array([c]), +1)
                out.append(Breakpoint(c, tuple(float(r[0] - l[0]) for l, r in zip(left, right))))
        return out


def slider_crank_text(steps=100, end=1.0):
    return f"""\
name: kinked
units: {{length: m, angle: rad}}
bodies:
  crank:  {{q: [0, 0, {math.pi}]}}
  rod:    {{q: [{-R}, 0.01, -0.05]}}
  slider: {{q: [{L - R}, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, i: crank, j: rod, si: [{R}, 0], sj: [0, 0]}}
  - {{type: revolute, i: rod, j: slider, si: [{L}, 0], sj: [0, 0]}}
  - {{type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{type: angle, body: crank, f: "2*pi*t"}}
analysis: {{start: 0, end: {end}, steps: {steps}}}
"""


def model_with(f, **kw):
    cm = planarkin.load("kinked.yaml", text=slider_crank_text(**kw))
    return dataclasses.replace(cm, driver_funcs=(f,))


def closed_form(th, d1, d2):
    """Slider x, vx, ax for crank angle th and the driver's f', f'' (closedforms.slider_crank)."""
    return slider_crank(th, d1, d2, R, L)[3:]


# f = pi + 2 pi |t - 1/2|: the crank turns back, then forward (velocity jump 4 pi, accel 0 -> 0)
KINK = Piecewise([0.5], [[-TWO_PI, 2 * math.pi], [TWO_PI, 0.0]])
# f = pi + 2 pi t + 3 (t - 1/2)|t - 1/2|: the acceleration jumps by 12 rad/s^2 at t = 1/2
ACCEL = Piecewise([0.5], [[-3.0, TWO_PI + 3.0, math.pi - 0.75], [3.0, TWO_PI - 3.0, math.pi + 0.75]])
def chain(f0, cuts, slopes):
    """Continuous Piecewise with f(0) = f0 whose f' on piece k is the polynomial slopes[k]."""
    pieces = []
    for k, d in enumerate(slopes):
        p = np.polyint(np.poly1d(d))
        at = 0.0 if k == 0 else cuts[k - 1]
        value = f0 if k == 0 else pieces[-1](at)
        pieces.append(p + (value - p(at)))
    return Piecewise(cuts, [q.coeffs for q in pieces])


# two kinks: at 0.3 (f' -3 -> 5) and at 0.7 (f' 5 -> 2t - 0.4, i.e. 1 -> f'' 0 -> 2)
TWO = chain(math.pi, [0.3, 0.7], [[-3.0], [5.0], [2.0, -0.4]])


def analysis(f, steps=100, end=1.0):
    cm = model_with(f, steps=steps, end=end)
    an = Analysis(cm, assemble(cm), Options.from_model(cm))
    an.follow()
    return cm, an


@pytest.mark.parametrize("f", (KINK, ACCEL, TWO), ids=("kink", "accel", "two"))
def test_nodes_land_on_breakpoints_and_restart(f):
    cm, an = analysis(f)
    assert an.event is None, an.event.message
    Tn = an.Tn
    slider = 3 * cm.body_names.index("slider")
    for c in f.cuts:
        at = np.nonzero(Tn == c)[0]
        assert len(at) == 2 and at[1] == at[0] + 1, (c, Tn[max(at[0] - 2, 0):at[0] + 3])
        # no node interval straddles a breakpoint
        assert not ((Tn[:-1] < c) & (Tn[1:] > c)).any()
        left, right = at
        assert np.array_equal(an.Qn[left], an.Qn[right])         # positions continuous
        for k, side in ((left, -1), (right, +1)):
            th, d1, d2 = (float(v[0]) for v in f.derivatives(np.array([c]), side))
            x, vx, ax = closed_form(th, d1, d2)
            Lc = cm.L                                   # nodes are in internal units
            assert abs(Lc * an.Qn[k][slider] - x) <= 1e-12
            assert abs(Lc * an.Qdn[k][slider] - vx) <= 1e-11 * max(1, abs(vx)), (side, vx)
            assert abs(Lc * an.Qddn[k][slider] - ax) <= 1e-10 * max(1, abs(ax)), (side, ax)
            assert an.Qdn[k][3 * cm.body_names.index("crank") + 2] == pytest.approx(d1, abs=1e-13)
            assert an.Qddn[k][3 * cm.body_names.index("crank") + 2] == pytest.approx(d2, abs=1e-12)


@pytest.mark.parametrize("f", (KINK, ACCEL, TWO), ids=("kink", "accel", "two"))
@pytest.mark.parametrize("steps", (4, 10, 100, 7))
def test_grid_rows_against_closed_form(f, steps):
    """Every grid row (the breakpoints are rows for steps 4, 10, 100 and not for 7) equals the
    closed form; a row at a breakpoint takes the right-hand limit, the end row the left-hand."""
    res = planarkin.solve(model_with(f, steps=steps))
    assert res.status == 0, res.message
    t = res.t
    side = np.where(t == 1.0, -1, +1)
    th = np.empty_like(t)
    d1 = np.empty_like(t)
    d2 = np.empty_like(t)
    for sd in (-1, 1):
        m = side == sd
        th[m], d1[m], d2[m] = f.derivatives(t[m], sd)
    x, vx, ax = closed_form(th, d1, d2)
    s = res.body("slider")
    assert np.abs(s["x"] - x).max() <= 1e-12
    assert np.abs(s["vx"] - vx).max() <= 1e-11
    assert np.abs(s["ax"] - ax).max() <= 1e-9
    c = res.body("crank")
    assert np.abs(c["omega"] - d1).max() <= 1e-12
    assert np.abs(c["alpha"] - d2).max() <= 1e-11
    for cut in f.cuts:
        if (t == cut).any():          # the right-hand value, not the rule's or the left's
            i = int(np.nonzero(t == cut)[0][0])
            assert c["omega"][i] == pytest.approx(float(f.derivatives(np.array([cut]), 1)[1][0]))


def test_warning_names_time_and_jumps(tmp_path):
    res = planarkin.solve(model_with(KINK, steps=10))
    assert res.status == 0
    w = [w for w in res.warnings if w.kind == "breakpoint"]
    assert len(w) == 1 and w[0].t == 0.5
    assert w[0].message == (
        "driver 1 (angle ground-crank): f = 2*pi*t has a breakpoint at t = 0.5 s: its velocity "
        "jumps by 12.5664 rad/s and its acceleration by 0 rad/s^2; the path is followed piece by "
        "piece and grid rows at this time take the right-hand limit")
    summary = res.write(tmp_path / "out", plots=None)
    on_disk = json.loads((tmp_path / "out" / "summary.json").read_text())
    for sm in (summary, on_disk):
        bp = sm["breakpoints"]
        assert bp["times"] == [0.5]
        assert bp["rows_at_breakpoints"].startswith("right-hand limit (t+)")
        assert bp["jumps"][0]["velocity"] == pytest.approx(4 * math.pi, abs=1e-12)
        assert bp["jumps"][0]["unit"] == "rad"
        assert any(x["kind"] == "breakpoint" for x in sm["warnings"])


def test_smooth_driver_reports_no_breakpoints():
    res = planarkin.solve(planarkin.load("smooth.yaml", text=slider_crank_text(steps=10)))
    assert res.status == 0 and res.info.breakpoints["times"] == []
    assert not [w for w in res.warnings if w.kind == "breakpoint"]


def test_position_jump_refused():
    """f jumps by 0.2 rad at t = 0.5: the run stops there with status 1 and says so."""
    f = Piecewise([0.5], [[TWO_PI, math.pi], [TWO_PI, math.pi + 0.2]])
    res = planarkin.solve(model_with(f, steps=10))
    assert res.status == 1
    assert res.info.event.kind == "driver" and res.info.event.t == 0.5
    assert "jumps by 0.2 rad at t = 0.5: a position jump cannot be followed" in res.message
    assert res.t[-1] == 0.5 and len(res.t) == 6


def test_undeclared_kink_refused():
    """A kink that breakpoints() does not declare (what the expression language gave for
    2*pi*abs(t-0.5) before it had piecewise support) is never stepped over: refused with its
    time, located by bisection on the driver."""
    f = Piecewise(KINK.cuts, [p.coeffs for p in KINK.pieces], declare=False)
    res = planarkin.solve(model_with(f, steps=10))
    assert res.status == 1, "stepped over an undeclared kink"
    ev = res.info.event
    assert ev.kind == "driver" and abs(ev.t - 0.5) <= 1e-12, ev.t
    assert "jumps near t = 0.5 s (f' changes by about 12.5664 rad/s" in ev.message
    assert res.t[-1] < 0.5
    assert np.isfinite(res.qd).all()


def test_non_finite_derivative_at_a_grid_row_refused():
    """f' is NaN exactly at t = 0.5 (sqrt((t-0.5)**2) differentiated as written): the row at
    0.5 is refused with the driver and the time, never a NaN row beside 'ok'."""
    f = Piecewise([], [[TWO_PI, math.pi]], nan_at=0.5)
    res = planarkin.solve(model_with(f, steps=10))
    assert res.status == 1
    assert res.info.event.t == 0.5
    assert res.message.startswith("driver 1 (angle ground-crank): f = 2*pi*t or its derivatives "
                                  "are not finite at t = 0.5 (a grid row)")
    assert len(res.t) == 5 and np.isfinite(res.qd).all() and np.isfinite(res.qdd).all()


@pytest.mark.parametrize("text", ("pi + 2*pi*abs(t-0.5)", "pi + sqrt((t-0.5)**2)"))
def test_expression_kinks_right_or_refused(text):
    """Whatever the expression language declares for these: never NaN or a stepped-over kink
    with status ok. Either refused at t = 0.5, or ok and equal to the closed form."""
    src = slider_crank_text(steps=10).replace('f: "2*pi*t"', f'f: "{text}"')
    res = planarkin.solve(planarkin.load("e.yaml", text=src))
    if res.status != 0:
        assert abs(res.info.event.t - 0.5) <= 1e-9, res.message
        assert np.isfinite(res.qd).all() and np.isfinite(res.qdd).all()
        return
    slope = TWO_PI if "2*pi" in text else 1.0
    f = Piecewise([0.5], [[-slope, math.pi + slope / 2], [slope, math.pi - slope / 2]])
    t = res.t
    side = np.where(t == 1.0, -1, 1)
    d1 = np.where(side > 0, f.derivatives(t, 1)[1], f.derivatives(t, -1)[1])
    assert np.abs(res.body("crank")["omega"] - d1).max() <= 1e-12


@pytest.mark.parametrize("order", (0, 1, 2))
def test_interpolated_grid_and_orders_at_breakpoints(order):
    """interpolate: true reads the rows from the nodes' Hermite interpolants: a row at the
    breakpoint is the right-hand node itself, rows on either side interpolate within their
    piece (to the interpolation accuracy, not across the jump)."""
    res = planarkin.solve(model_with(KINK, steps=10), interpolate=True,
                         up_to=("position", "velocity", "acceleration")[order])
    assert res.status == 0, res.message
    t = res.t
    side = np.where(t == 1.0, -1, 1)
    th = np.where(side > 0, KINK.derivatives(t, 1)[0], KINK.derivatives(t, -1)[0])
    d1 = np.where(side > 0, KINK.derivatives(t, 1)[1], KINK.derivatives(t, -1)[1])
    x, vx, ax = closed_form(th, d1, 0 * t)
    s = res.body("slider")
    assert np.abs(s["x"] - x).max() <= 1e-6
    if order >= 1:
        assert np.abs(s["vx"] - vx).max() <= 1e-5 * np.abs(vx).max()
        assert res.body("crank")["omega"][5] == pytest.approx(TWO_PI, abs=1e-12)   # t = 0.5: t+
    if order >= 2:
        assert np.abs(s["ax"] - ax).max() <= 1e-3 * np.abs(ax).max()
