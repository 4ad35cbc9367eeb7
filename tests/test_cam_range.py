"""A cam law given over a `range:` is refused where the cam turns past it (issue 21, item 4):
its profile (pressure angle, undercut) was checked over the range only, as a full-turn law is
checked over the whole turn and refused when it does not close."""

from __future__ import annotations

import planarkin

RANGE = """
name: cam-range
units: {{length: mm, angle: deg}}
bodies:
  cam:  {{q: [0, 0, 0]}}
  stem: {{q: [0, 36, 0]}}
joints:
  - {{type: revolute, i: ground, j: cam, at: [0, 0]}}
  - {{type: translational, i: ground, j: stem, at: [0, 36], axis: [0, 1]}}
  - {{name: valve, type: cam, i: cam, j: stem, sk: [0, 0], vk: [0, 1], sj: [0, 0], base: 30,
     roller: 6, range: [0, 180], s: {law}}}
drivers:
  - {{type: angle, body: cam, f: "360*t"}}
analysis: {{start: 0, end: {end}, steps: {steps}}}
"""
MOTION = "{motion: {segments: [{rise: 8, in: 180, law: cycloidal}]}}"
EXPR = '"8*(theta/180 - sin(2*pi*theta/180)/(2*pi))"'


def test_a_cam_driven_past_its_range_is_refused_there():
    for law in (MOTION, EXPR):
        res = planarkin.solve(planarkin.load("m.yaml", text=RANGE.format(law=law, end=1,
                                                                           steps=360)))
        assert res.status == 1
        assert ("joint 'valve' (cam cam-stem-ground): the cam angle theta = 181 deg at t = "
                "0.5027777778 s is outside the law's range [0, 180] deg") in res.message
        assert len(res.t) == 181 and res.t[-1] == 0.5


def test_a_cam_within_its_range_runs():
    res = planarkin.solve(planarkin.load("m.yaml", text=RANGE.format(law=MOTION, end=0.5,
                                                                       steps=180)))
    assert res.success, res.message
    assert len(res.t) == 181
