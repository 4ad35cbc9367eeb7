"""planarkin.clearance.check: contacts and travel limits as findings (the first instant, the
bodies, the points), as warnings or, with on_contact: error, a failed run (exit 1); overlaps
at the assembled pose in `planarkin check` (issue 29)."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

import planarkin
from planarkin.clearance.check import overlaps

# a crank (a capsule 80 long, 12 wide, from its pivot) turning towards a wall at y = 84: its
# plate's edge reaches y = 86 at theta = 90 deg, 2 past the wall; it touches the wall where
# 80 sin(theta) + 6 = 84
CRANK = """
name: crank-wall
units: {{length: mm, angle: deg}}
bodies:
  crank: {{q: [0, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0], name: O}}
drivers:
  - {{type: angle, body: crank, f: "360*t"}}
points:
  T: {{body: crank, s: [80, 0]}}
shapes:
  crank: {{plate: 12, pins: [T]}}
  wall:  {{body: ground, polyline: [[-100, 84], [100, 84]]}}
{extra}
analysis: {{start: 0, end: 1, steps: 72}}
"""
T_TOUCH = math.degrees(math.asin(78 / 80)) / 360


def model(extra=""):
    return planarkin.load("crank-wall.yaml", text=CRANK.format(extra=extra))


def test_a_contact_is_a_warning_with_the_first_instant_the_bodies_and_the_points():
    res = planarkin.solve(model())
    assert res.status == 0
    (w,) = res.warnings
    assert w.kind == "contact" and w.bodies == ["crank", "ground"]
    assert w.t == pytest.approx(T_TOUCH, rel=1e-9)
    th = math.radians(360 * T_TOUCH)
    x = 80 * math.cos(th)
    assert w.message == (
        f"clearance: shapes 'crank' and 'wall' (on ground) touch at t = {w.t:.10g} s, at "
        f"({x:.6g}, 84) on 'crank' and ({x:.6g}, 84) on 'wall'")


def test_on_contact_error_stops_the_run_at_the_first_contact():
    res = planarkin.solve(model("clearance: {min: 3, on_contact: error}"))
    assert res.status == 1 and res.event.kind == "contact"
    t_near = math.degrees(math.asin(75 / 80)) / 360       # 80 sin + 6 = 84 - 3
    assert f"t = {t_near:.10g} s" in res.message
    assert "come within 3 mm, the least clearance allowed, at t" in res.message
    assert res.t[-1] < t_near <= res.t[-1] + 1 / 72 + 1e-12


def test_a_pair_limit_replaces_the_models_own():
    res = planarkin.solve(model("clearance: {min: 1, pairs: [{between: [wall, crank], min: 3}]}"))
    (w,) = res.warnings
    assert "come within 3 mm, the least" in w.message


def test_a_shape_in_another_layer_is_never_checked():
    cm = planarkin.load("crank-wall.yaml", text=CRANK.format(extra="").replace(
        "[100, 84]]}", "[100, 84]], layer: 2}"))
    res = planarkin.solve(cm)
    assert res.warnings == [] and res.status == 0
    from planarkin.derived import derived_tables
    assert "clearance.csv" not in [d.filename for d in derived_tables(cm, res.info.options)]


def test_a_joint_past_its_travel_range_is_a_finding():
    res = planarkin.solve(model("limits: {O: [-10, 30]}"))
    kinds = [w.kind for w in res.warnings]
    assert kinds == ["limit", "contact"]
    lim = res.warnings[0]
    assert lim.t == pytest.approx(30 / 360, rel=1e-9)
    assert lim.bodies == ["ground", "crank"]
    assert "joint 'O' reaches the upper end 30 deg of its travel range [-10, 30] deg" in \
        lim.message
    res = planarkin.solve(model("limits: {O: [-10, 30]}\nclearance: {on_contact: error}"))
    assert res.status == 1 and res.event.kind == "limit"


def test_overlaps_at_the_assembled_pose():
    cm = planarkin.load("crank-wall.yaml", text=CRANK.format(extra="").replace(
        "q: [0, 0, 0]", "q: [0, 0, 90]").replace("360*t", "90 + 360*t"))
    res = planarkin.solve(cm, steps=2)
    (d,) = overlaps(cm, np.array([0.0, 0.0, math.pi / 2]) / np.array([cm.L, cm.L, 1]))
    assert d.severity == "warning" and d.line == 13
    assert "shapes 'crank' and 'wall' (on ground) overlap by 2 mm at the assembled pose" in \
        d.message
    del res


def test_check_reports_overlaps_at_the_assembled_pose(tmp_path):
    from planarkin.cli import main
    path = tmp_path / "m.yaml"
    path.write_text(CRANK.format(extra="").replace("q: [0, 0, 0]", "q: [0, 0, 90]")
                    .replace("360*t", "90 + 360*t"))
    r = CliRunner().invoke(main, ["check", str(path)])
    assert r.exit_code == 0
    assert f"{path}:13: warning: shapes 'crank' and 'wall' (on ground) overlap by 2 mm at the " \
           f"assembled pose, at (0, 86) on 'crank' and (0, 84) on 'wall'" in r.output
