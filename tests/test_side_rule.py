"""One rule at breakpoints and knots (issue 21, item 2; expr.SIDE_RULE): a grid time within
8 ulp of a driver's breakpoint, and a cam angle within 8 ulp of its law's knot, is at it, and
there velocity, acceleration and jerk are the right-hand limits, for every form of law."""

from __future__ import annotations

import math

import numpy as np
import pytest

import planarkin
from planarkin.elements.cam import Law
from planarkin.functions.expr import TimeFunction

CRANK = """
name: kinked
units: {{length: m, angle: deg}}
bodies:
  crank: {{q: [0, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, at: [0, 0]}}
drivers:
  - {{type: angle, body: crank, f: "where(t < 0.9, 60*t, 54 + 120*(t - 0.9))"}}
analysis: {{start: 0, end: {end}, steps: {steps}}}
"""


def test_a_row_one_ulp_before_a_breakpoint_takes_the_breakpoints_rule():
    # 0 + 3 * (1.2 / 4) = 0.8999999999999999, one ulp below the breakpoint 0.9
    near = planarkin.solve(planarkin.load("k.yaml", text=CRANK.format(end=1.2, steps=4)))
    at = planarkin.solve(planarkin.load("k.yaml", text=CRANK.format(end=1.8, steps=2)))
    assert near.success and at.success
    assert near.t[3] == 0.8999999999999999 and at.t[1] == 0.9
    assert at.body("crank")["omega"][1] == pytest.approx(120.0, abs=1e-9)
    assert near.body("crank")["omega"][3] == pytest.approx(120.0, abs=1e-9)


@pytest.mark.parametrize("x", [0.9, 0.8999999999999999, 0.9000000000000001,
                               0.9 * (1 - 7 * 2 ** -53)])
def test_driver_function_within_8_ulp_of_its_breakpoint(x):
    f = TimeFunction("where(t < 0.9, 60*t, 54 + 120*(t - 0.9)) + 5*abs(t - 0.9)**3", {})
    right = f.derivatives(np.array([0.9]), +1)
    got = f.derivatives(np.array([x]))
    assert got[1][0] == pytest.approx(right[1][0], rel=1e-12)
    assert f.third(np.array([x]))[0] == pytest.approx(f.third(np.array([0.9]), +1)[0], abs=1e-6)


KNOT = 120.0
SEGMENTS = ("{motion: {segments: [{rise: 8, in: 120, law: harmonic}, {dwell: 60}, "
            "{return: 8, in: 120, law: harmonic}, {dwell: 60}]}}")


def cam_law(text):
    cm = planarkin.load("c.yaml", text=CAM.format(s=text))
    G = next(G for G in cm.groups if G.kind.name == "cam")
    return G.params["s"][0]


CAM = """
name: cam-knot
units: {{length: mm, angle: deg}}
bodies:
  cam:  {{q: [0, 0, 0]}}
  stem: {{q: [0, 36, 0]}}
joints:
  - {{type: revolute, i: ground, j: cam, at: [0, 0]}}
  - {{type: translational, i: ground, j: stem, at: [0, 36], axis: [0, 1]}}
  - {{name: valve, type: cam, i: cam, j: stem, sk: [0, 0], vk: [0, 1], sj: [0, 0], base: 30,
     roller: 6, s: {s}}}
drivers:
  - {{type: angle, body: cam, f: "360*t"}}
analysis: {{start: 0, end: 1, steps: 360}}
"""


@pytest.mark.parametrize("form", ["motion", "expression"])
def test_cam_law_at_and_beside_a_knot_takes_the_right_hand_limit(form):
    # harmonic rise of 8 in 120 deg, then a dwell: s'' jumps from -8/2 (pi/120)^2 to 0 at 120,
    # the jerk from 0 (pi/120)^3-ish to 0; right-hand: the dwell's 0 for both
    xs = np.array([KNOT, np.nextafter(KNOT, 0), np.nextafter(KNOT, 200), KNOT * (1 + 6e-16)])
    if form == "motion":
        law = cam_law(SEGMENTS).fn
        d = law.derivatives(xs)
        third = law.third(xs)
    else:
        law = Law("8*harmonic(theta/120)", {})
        d = law(xs, (0, 1, 2))
        third = law(xs, (3,))[3]
    assert np.all(np.abs(d[0] - 8.0) <= 1e-13)
    assert np.all(np.abs(d[1]) <= 1e-15) and np.all(d[2] == 0.0) and np.all(third == 0.0)
    # just before the knot's rounding zone: the rise's own values
    x = np.array([KNOT * (1 - 1e-12)])
    a = law.derivatives(x)[2][0] if form == "motion" else law(x, (2,))[2][0]
    assert a == pytest.approx(-4 * (math.pi / 120) ** 2, rel=1e-9)


def test_cam_row_at_the_knot_takes_the_right_hand_limit():
    res = planarkin.solve(planarkin.load("c.yaml", text=CAM.format(s=SEGMENTS)))
    assert res.success, res.message
    k = 120                                           # the row at theta = 120 deg
    ay = res.body("stem")["ay"]
    assert abs(ay[k]) <= 1e-9 * np.abs(ay).max()
    assert ay[k - 1] < -0.5 * np.abs(ay).max()


# The row at the end time takes the left-hand limit of a driver's breakpoint there, also when
# the end is within 8 units in the last place of it (SIDE_RULE): f = 360 t + 100 max(t - 0.9, 0)
# deg has omega 360 deg/s before t = 0.9 and 460 after; an end 1 to 5 ulp off 0.9 is at 0.9.
@pytest.mark.parametrize("end", ["0.9", "0.8999999999999999", "0.9000000000000001",
                                 "0.9000000000000004", "0.8999999999999995"])
def test_the_end_row_within_8_ulp_of_a_breakpoint_takes_the_left_hand_limit(end):
    text = """
name: bp
units: {length: m, angle: deg}
bodies:
  crank: {q: [0, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, at: [0, 0]}
drivers:
  - {type: angle, body: crank, f: "360*t + 100*max(t - 0.9, 0)"}
analysis: {start: 0, end: END, steps: 9}
""".replace("END", end)
    r = planarkin.solve(planarkin.load("bp.yaml", text=text))
    assert r.success and r.t[-1] == float(end)
    assert r.body("crank")["omega"][-1] == 360.0
    assert r.body("crank")["alpha"][-1] == 0.0


@pytest.mark.parametrize("page", ["docs/how-to/cams.md", "docs/reference/expressions.md"])
def test_the_pages_that_speak_of_knots_state_the_rule_the_code_follows(page):
    # cams.md once said a row at a jump of s'' takes the mean of the two sides, while the
    # code took the right-hand limit: each page states SIDE_RULE word for word, and no other
    from planarkin.functions.expr.core import SIDE_RULE
    from clitools import ROOT
    text = " ".join((ROOT / page).read_text(encoding="utf-8").split())
    assert " ".join(SIDE_RULE.split()) in text
    assert "mean of the two" not in text
