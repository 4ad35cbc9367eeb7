"""planarkin.clearance.cycle against closed forms: the minimum distance of two shapes over the
cycle and its instant, refined between the grid rows (issue 29), to 1e-9 relative."""

import math

import numpy as np
import pytest

import planarkin
from planarkin.clearance.cycle import Clearance, first_below, minima

REL = 1e-9


def solve(text, steps=100, **opts):
    cm = planarkin.load("model.yaml", text=text)
    return cm, planarkin.solve(cm, steps=steps, **opts)


# two capsules of length a, radius r, turning about pivots D apart in mirror image: their tips
# meet on the x axis when theta = w t - p0 = 0, at d = D - 2a - 2r
MIRROR = """
name: mirror
parameters: {D: 0.3, a: 0.1, r: 0.01, w: 6.283185307179586, p0: 1.234}
bodies:
  left:  {q: [0, 0, -1.234]}
  right: {q: [0.3, 0, 4.375592653589793]}
joints:
  - {type: revolute, i: ground, j: left, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: ground, j: right, si: [D, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: left, f: "w*t - p0"}
  - {type: angle, body: right, f: "pi - (w*t - p0)"}
points:
  T: {body: left, s: [a, 0]}
shapes:
  left:  {plate: 2*r, pins: [T]}
  right: {polyline: [[0, 0], [a, 0]], radius: r}
analysis: {start: 0, end: 1, steps: 100}
"""


def test_two_capsules_turning_about_fixed_pivots_meet_at_the_closed_form_instant():
    cm, res = solve(MIRROR)
    D, a, r, w, p0 = 0.3, 0.1, 0.01, 2 * math.pi, 1.234
    (m,) = minima(cm, res)
    assert (m.a, m.b) == ("left", "right")
    assert m.d == pytest.approx(D - 2 * a - 2 * r, rel=REL)
    assert m.t == pytest.approx(p0 / w, rel=REL)
    assert np.allclose(m.pa, [a + r, 0], rtol=0, atol=1e-10)
    assert np.allclose(m.pb, [D - a - r, 0], rtol=0, atol=1e-10)
    # at every row: the tips (or, turned away, the closest ends) by the closed form
    th = w * res.t - p0
    tip = np.stack([a * np.cos(th), a * np.sin(th)], axis=1)
    other = np.stack([D - a * np.cos(th), a * np.sin(th)], axis=1)
    near = np.abs(th - np.round(th / (2 * np.pi)) * 2 * np.pi) < 0.5
    d = np.hypot(*(other - tip).T) - 2 * r
    assert np.allclose(m.distance[near], d[near], rtol=0, atol=1e-14)


def test_the_tables_rate_and_acceleration_are_the_distances_exact_derivatives():
    cm, res = solve(MIRROR)
    X = res.table("clearance.csv")
    D, a, r, w, p0 = 0.3, 0.1, 0.01, 2 * math.pi, 1.234
    th = w * res.t - p0
    near = np.abs(th - np.round(th / (2 * np.pi)) * 2 * np.pi) < 0.5
    # d = D - 2 a cos(th) - 2 r while the tips face each other
    assert np.allclose(X["left|right"][near], (D - 2 * a * np.cos(th) - 2 * r)[near], atol=1e-14)
    assert np.allclose(X["left|right.rate"][near], (2 * a * w * np.sin(th))[near], atol=1e-12)
    assert np.allclose(X["left|right.accel"][near], (2 * a * w * w * np.cos(th))[near],
                       atol=1e-10)
    assert np.array_equal(X["clearance"], X["left|right"])


# a crank's plate (a capsule from its pivot) sweeping past a wall whose normal is at beta:
# the distance n.c - a cos(theta - beta) - r is least at theta = beta
WALL = """
name: wall
units: {{length: mm}}
parameters: {{a: 80, r: 6, w: 6.283185307179586, p0: 0.3}}
bodies:
  crank: {{q: [0, 0, 0.3]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, body: crank, f: "w*t + p0"}}
points:
  T: {{body: crank, s: [a, 0]}}
shapes:
  crank: {{plate: 2*r, pins: [T]}}
  wall:  {{body: ground, polyline: [{p}, {q}], layer: [0, 1]}}
analysis: {{start: 0, end: 1, steps: 360}}
"""


@pytest.mark.parametrize("beta", [math.pi / 2, 1.1, -2.5])
def test_a_cranks_plate_sweeping_past_a_wall(beta):
    c, h, L = 100.0, 0.0, 300.0
    n = np.array([math.cos(beta), math.sin(beta)])
    along = np.array([-n[1], n[0]])
    P, Q = c * n - L * along, c * n + L * along
    text = WALL.format(p=f"[{float(P[0])!r}, {float(P[1])!r}]", q=f"[{float(Q[0])!r}, {float(Q[1])!r}]")
    cm, res = solve(text, steps=360)
    (m,) = minima(cm, res)
    a, r, w, p0 = 80.0, 6.0, 2 * math.pi, 0.3
    t0 = ((beta - p0) / w) % 1.0
    assert m.d == pytest.approx(c - a - r, rel=REL)
    assert m.t == pytest.approx(t0, rel=REL)
    assert np.allclose(m.pa, (a + r) * n, rtol=0, atol=REL * c)
    assert np.allclose(m.pb, c * n, rtol=0, atol=REL * c)
    del h


# a slider (a block 20 long, rounded by 1) driven x = 50 sin(w t) towards a stop (a disc of
# diameter 10 at x = 90): least clearance 90 - 5 - (50 + 10 + 1) = 24 at w t = pi/2
SLIDER = """
name: slider-stop
units: {length: mm}
parameters: {w: 5.0}
bodies:
  block: {q: [0, 0, 0]}
joints:
  - {type: translational, i: ground, j: block, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: x, body: block, f: "50*sin(w*t)"}
shapes:
  block: {polygon: [[-10, -4], [10, -4], [10, 4], [-10, 4]], radius: 1}
  stop:  {body: ground, circle: 10, centre: [90, 0]}
limits:
  block-guide: [-45, 45]
analysis: {start: 0, end: 1, steps: 40}
"""


def test_a_slider_against_a_stop():
    text = SLIDER.replace("vj: [1, 0]}", "vj: [1, 0], name: block-guide}")
    cm, res = solve(text, steps=40)
    (m,) = minima(cm, res)
    w = 5.0
    assert m.d == pytest.approx(24.0, rel=REL)
    assert m.t == pytest.approx(math.pi / 2 / w, rel=REL)
    assert m.pb == pytest.approx([85.0, 0.0], abs=REL * 85)
    assert m.pa == pytest.approx([61.0, 0.0], abs=REL * 85)
    # the guide's travel leaves [-45, 45] first where 50 sin(w t) = 45
    assert res.warnings[0].kind == "limit"
    assert res.warnings[0].t == pytest.approx(math.asin(0.9) / w, rel=REL)


def test_first_below_finds_a_dip_between_two_rows():
    # y = (t - 0.55)^2 + 0.1 sampled at 0.5 and 0.6: both rows above 0.1005, the dip below
    t = np.array([0.4, 0.5, 0.6, 0.7])
    y = (t - 0.55) ** 2 + 0.1
    y1, y2 = 2 * (t - 0.55), np.full(4, 2.0)
    tf = first_below(t, y, y1, y2, 0.1005)
    assert tf == pytest.approx(0.55 - math.sqrt(0.0005), rel=1e-12)
    assert first_below(t, y, y1, y2, 0.09) is None
    assert first_below(t, y, y1, y2, 0.2) == 0.4


def test_the_summary_holds_each_pairs_minimum_and_the_first_contact(tmp_path):
    cm, res = solve(MIRROR.replace("analysis:", "clearance: {min: 0.09}\nanalysis:"))
    summary = res.write(tmp_path / "out", plots=None)
    pair = summary["clearance"]["pairs"]["left|right"]
    D, a, r, w, p0 = 0.3, 0.1, 0.01, 2 * math.pi, 1.234
    assert pair["min"] == pytest.approx(D - 2 * a - 2 * r, rel=REL)
    assert pair["t"] == pytest.approx(p0 / w, rel=REL)
    # first below 0.09: D - 2a cos(th) - 2r = 0.09, th < 0
    th = -math.acos((D - 2 * r - 0.09) / (2 * a))
    assert pair["contact"] == pytest.approx((th + p0) / w, rel=REL)
    assert summary["clearance"]["contacts"] == 1
    assert [w_["kind"] for w_ in summary["warnings"]] == ["contact"]
    assert "left" in summary["warnings"][0]["message"]


def test_chunks_give_the_figures_of_one_pass(tmp_path):
    cm, res = solve(MIRROR)
    whole = minima(cm, res)[0]
    from planarkin.clearance.summary import ClearanceFigures
    C = Clearance(cm)
    F = ClearanceFigures(C, C.columns(2))
    X = C.table(res, 2)
    for k in range(0, len(X), 7):           # chunks of seven rows, the minimum in the seam
        F.add(X[k:k + 7])
    got = F.as_dict()["pairs"]["left|right"]
    assert got["min"] == pytest.approx(whole.d, rel=1e-14)
    assert got["t"] == pytest.approx(whole.t, rel=1e-14)


def test_a_model_without_shapes_has_no_table_and_no_check():
    from planarkin.clearance import derived_tables, row_checks
    cm = planarkin.load("mechanisms/four-bar.yaml")
    opts = planarkin.solve(cm, steps=4).info.options
    assert cm.shapes == () and derived_tables(cm, opts) == [] and row_checks(cm, opts) == []


@pytest.mark.slow
def test_a_model_without_shapes_imports_nothing_of_the_room_but_its_door():
    import subprocess
    import sys
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent
    code = ("import sys, planarkin; res = planarkin.solve(planarkin.load("
            "'mechanisms/four-bar.yaml')); res.write(sys.argv[1], plots=None);"
            "print(sorted(m for m in sys.modules if m.startswith('planarkin.clearance')))")
    import tempfile
    with tempfile.TemporaryDirectory() as out:
        r = subprocess.run([sys.executable, "-c", code, out], capture_output=True, text=True,
                           cwd=str(root))
    assert r.stdout.strip() == "['planarkin.clearance']", r.stderr


# a bar on a turning body (its edge 100 from the pivot) past a fixed disc 60 from the pivot:
# the distance 100 - 60 sin(beta - theta) - 5 is least, 35, at theta = beta - 90 deg (the
# edge turns: its normal's rate and acceleration enter the distance's)
BAR = """
name: bar
units: {length: mm}
parameters: {w: 6.283185307179586, p0: 0.3, beta: 2.2}
bodies:
  arm: {q: [0, 0, 0.3]}
joints:
  - {type: revolute, i: ground, j: arm, si: [0, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: arm, f: "w*t + p0 + 0.4*sin(w*t)"}
shapes:
  arm:  {polyline: [[-300, 100], [300, 100]]}
  disc: {body: ground, circle: 10, centre: [60*cos(beta), 60*sin(beta)]}
analysis: {start: 0, end: 1, steps: 360}
"""


def test_a_turning_edge_past_a_fixed_disc():
    cm, res = solve(BAR, steps=360)
    (m,) = minima(cm, res)
    beta, p0, w = 2.2, 0.3, 2 * math.pi
    assert m.d == pytest.approx(35.0, rel=REL)
    # theta(t) = w t + p0 + 0.4 sin(w t) = beta - pi/2 (mod 2 pi): one root in [0, 1)
    from scipy.optimize import brentq
    f = lambda t: (w * t + p0 + 0.4 * math.sin(w * t) - (beta - math.pi / 2)) % (2 * math.pi)
    g = lambda t: math.remainder(f(t), 2 * math.pi)
    ts = np.linspace(0, 1, 721)
    k = next(i for i in range(720) if g(ts[i]) * g(ts[i + 1]) < 0 and abs(g(ts[i])) < 1)
    assert m.t == pytest.approx(brentq(g, ts[k], ts[k + 1], xtol=1e-15), rel=REL)
    assert np.allclose(m.pb, 60 * np.array([math.cos(beta), math.sin(beta)])
                       + 5 * np.array([math.cos(beta), math.sin(beta)]), atol=REL * 100)


# a press: crank 40, rod 120, a ram 40 long whose front reaches 40 cos(th) + sqrt(120^2 -
# (40 sin th)^2) + 40, against a die 2 mm inside that reach, both sharp-cornered (radius 0)
PRESS = """
name: press
units: {length: mm, angle: deg}
bodies:
  crank: {q: [0, 0, 180]}
  rod:   {q: [-40, 0, 0]}
  ram:   {q: [80, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, at: [0, 0]}
  - {type: revolute, i: crank, j: rod, si: [40, 0], sj: [0, 0]}
  - {type: revolute, i: rod, j: ram, si: [120, 0], sj: [0, 0]}
  - {type: translational, i: ground, j: ram, at: [80, 0], axis: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "180 + 360*t"}
shapes:
  ram: {polygon: [[0, -15], [40, -15], [40, 15], [0, 15]]}
  die: {body: ground, polygon: [[198, -25], [230, -25], [230, 25], [198, 25]]}
clearance: {min: 0}
analysis: {start: 0, end: 1, steps: 72}
"""


def test_a_contact_of_sharp_outlines_is_dated_between_the_rows():
    """The row after the contact has the outlines crossing (no rate there): the instant comes
    from the distance at poses interpolated between the rows, not from the row (0.4583 s)."""
    from scipy.optimize import brentq
    cm, res = solve(PRESS, steps=72)
    (m,) = minima(cm, res)
    th = lambda t: math.radians(180 + 360 * t)
    front = lambda t: 40 * math.cos(th(t)) + math.sqrt(120**2 - (40 * math.sin(th(t)))**2) + 40
    exact = brentq(lambda t: front(t) - 198, 0.3, 0.5, xtol=1e-15)
    assert m.contact == pytest.approx(exact, rel=REL)
    assert res.warnings[0].t == pytest.approx(exact, rel=REL)
