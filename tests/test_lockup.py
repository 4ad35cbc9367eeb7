"""Four-bar loops that lock up mid-run (issue 21 item 8): `check` and `run` warn with the limit
angle and the time the driver reaches it; a change-point loop is found when one of its pins is
carried by three links.

Closed form (independent of planarkin's code): with the driven link of length a pivoted at A,
the ground line of length g to the other pivot, the coupler b and the other link c, the far pin
of the driven link is at BD^2 = a^2 + g^2 - 2 a g cos(theta) from the other pivot, theta the
driven link's angle from the ground line, and the loop closes only for |b - c| <= BD <= b + c.
"""

import json
import math
import re

import pytest
from click.testing import CliRunner

from planarkin.cli import main


def _circles(p, r1, q, r2, upper=True):
    """The intersection of circle (p, r1) and circle (q, r2), left of p -> q when upper."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = math.hypot(dx, dy)
    x = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    h = math.sqrt(r1 * r1 - x * x)
    s = 1 if upper else -1
    return (p[0] + (x * dx - s * h * dy) / d, p[1] + (x * dy + s * h * dx) / d)


def _sketch(a, b, c, d, start_deg, driven="crank", f=None, end=1.0):
    """A four-bar in sketch form: crank A-B (length a), coupler B-C (b), rocker D-C (c), ground
    A-D (d) along x; the driven link at start_deg (its angle from +x)."""
    A, D = (0.0, 0.0), (d, 0.0)
    th = math.radians(start_deg)
    if driven == "crank":
        B = (a * math.cos(th), a * math.sin(th))
        C = _circles(B, b, D, c, upper=False)
    else:
        C = (d + c * math.cos(th), c * math.sin(th))
        B = _circles(A, a, C, b, upper=True)
    fmt = lambda p: f"[{p[0]!r}, {p[1]!r}]"
    return f"""\
name: lock
units: {{length: m, angle: deg}}
points:
  A: {{at: [0, 0], ground: true}}
  D: {{at: [{d!r}, 0], ground: true}}
  B: {{at: {fmt(B)}}}
  C: {{at: {fmt(C)}}}
links:
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {{type: angle, link: {driven}, f: "{f}"}}
analysis: {{start: 0, end: {end}, steps: 360}}
"""


def _limit(a, b, c, g, theta0, up):
    """The driven link's angle (deg, from the ground line seen from its pivot) where the loop
    locks when turned up (or down) from theta0, by the closed form; None if it turns fully."""
    c1 = (a * a + g * g - (b + c) ** 2) / (2 * a * g)      # stretched: BD = b + c
    c2 = (a * a + g * g - (b - c) ** 2) / (2 * a * g)      # folded: BD = |b - c|
    st = math.degrees(math.acos(c1)) if c1 > -1 else None
    fo = math.degrees(math.acos(c2)) if c2 < 1 else None
    # the limits met turning from theta0 in (0, 180): stretched ones at +-st (+360 k), folded
    # ones at +-fo (+360 k)
    cands = [x + k * 360 for x in ([st, -st] if st is not None else []) +
             ([fo, -fo] if fo is not None else []) for k in (-1, 0, 1)]
    cands = [x for x in cands if (x > theta0 if up else x < theta0)]
    if not cands:
        return None
    return min(cands) if up else max(cands)


def _check(tmp_path, text):
    p = tmp_path / "lock.yaml"
    p.write_text(text)
    return CliRunner().invoke(main, ["check", str(p)])


CASES = [
    # a, b, c, d, start, speed (deg/s), driven
    (0.09, 0.09, 0.10, 0.12, 30.0, 360.0, "crank"),     # non-Grashof, stretched at 129 deg
    (0.09, 0.09, 0.10, 0.12, 30.0, -360.0, "crank"),    # the other way: past 0 to -129 deg
    (0.10, 0.05, 0.12, 0.10, 60.0, -100.0, "crank"),    # double-rocker: folded at 41 deg
    (0.10, 0.05, 0.12, 0.10, 60.0, 100.0, "crank"),     # stretched at 116 deg
    (0.09, 0.09, 0.10, 0.12, 120.0, 200.0, "rocker"),   # the loop's other grounded link
    (0.09, 0.09, 0.10, 0.12, 120.0, -200.0, "rocker"),
]


@pytest.mark.parametrize("a, b, c, d, start, w, driven", CASES)
def test_check_and_run_warn_of_a_lock_up_with_the_limit_angle(tmp_path, a, b, c, d, start, w,
                                                              driven):
    f = f"{start!r} + {w!r}*t"
    text = _sketch(a, b, c, d, start, driven, f)
    if driven == "crank":
        theta0, link, other = start, (a, b, c), "rocker"
    else:   # the rocker's angle from the line D -> A is its angle from +x minus 180 deg
        theta0, link, other = start - 180.0, (c, b, a), "crank"
    lim = _limit(*link, d, theta0, w > 0)
    want = lim + (start - theta0)                    # in the driver's coordinate
    t_lock = (want - start) / w
    assert 0 < t_lock < 1
    r = _check(tmp_path, text)
    assert r.exit_code == 0, r.output
    warn = [x for x in r.output.splitlines() if "warning:" in x]
    assert len(warn) == 1, r.output
    assert (f"lock.yaml:13: warning: driver 1 (angle ground-{driven}): the four-bar loop "
            f"ground-crank-coupler-rocker (") in warn[0]
    assert f"locks where {driven} reaches {want:.6g} deg of this driver" in warn[0]
    assert f"which the driver reaches at t = {t_lock:.6g} s" in warn[0]
    assert f"coupler and {other} " in warn[0]
    # the run warns the same at its start, then stops at that time
    p = tmp_path / "lock.yaml"
    r = CliRunner().invoke(main, ["run", str(p), "--out", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 1, r.output
    # once, before the run's failure
    assert r.output.count(warn[0]) == 1
    assert r.output.index(warn[0]) < r.output.index("singular configuration")
    s = json.loads((tmp_path / "out" / "lock" / "summary.json").read_text())
    assert warn[0].split("warning: ", 1)[1] in json.dumps(s)
    assert f"at t = {t_lock:.6f}" in r.output


@pytest.mark.parametrize("a, b, c, d, f", [
    (0.04, 0.12, 0.10, 0.10, "30 + 360*t"),          # Grashof crank-rocker: the crank turns
    (0.09, 0.09, 0.10, 0.12, "30 + 90*sin(360*t)"),  # within -60 .. 120 deg of 129 deg limits
    (0.09, 0.09, 0.10, 0.12, "30 + 90*t"),           # ends at 120 deg, before the limit
])
def test_no_warning_while_the_driver_stays_within_the_limits(tmp_path, a, b, c, d, f):
    r = _check(tmp_path, _sketch(a, b, c, d, 30.0, "crank", f))
    assert r.exit_code == 0 and ": warning:" not in r.output, r.output


def test_a_body_form_driver_written_the_other_way_round(tmp_path):
    # phi_ground - phi_crank = f: the crank turns by -f
    text = _sketch(0.09, 0.09, 0.10, 0.12, 30.0, "crank", "x").replace(
        '{type: angle, link: crank, f: "x"}', '{type: angle, i: crank, j: ground, '
                                              'f: "-30 - 360*t"}')
    lim = _limit(0.09, 0.09, 0.10, 0.12, 30.0, True)
    r = _check(tmp_path, text)
    assert r.exit_code == 0, r.output
    assert f"reaches {-lim:.6g} deg of this driver" in r.output
    assert f"t = {(lim - 30) / 360:.6g} s" in r.output


# A parallelogram A-B-C-D (crank 0.04, coupler 0.1 = ground, rocker 0.04: a change point) whose
# pin B is also carried by a dyad B-F-G to ground; `arm` is listed first, so the sketch form
# pins arm to crank and arm to coupler at B (no crank-coupler joint).
PARALLELOGRAM = """\
name: para
units: {length: m, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.1, 0], ground: true}
  G: {at: [0.05, -0.1], ground: true}
  B: {at: [0.02, 0.034641016151377546]}
  C: {at: [0.12, 0.034641016151377546]}
  F: {at: [0.08, -0.05]}
links:
  arm: [B, F]
  link2: [F, G]
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "60+90*t"}
analysis: {start: 0, end: 1, steps: 90}
"""


def test_a_change_point_loop_with_a_pin_carried_by_three_links(tmp_path):
    r = _check(tmp_path, PARALLELOGRAM)
    assert r.exit_code == 0, r.output
    assert ("four-bar loop ground-crank-coupler-rocker: change point (s + l = p + q: the loop "
            "can fold flat); s + l = 0.14 = p + q = 0.14 m (ground 0.1, crank 0.04, coupler "
            "0.1, rocker 0.04)") in r.output
    # the dyad's loop through the arm, as before
    dyad = math.dist((0.02, 0.034641016151377546), (0.08, -0.05))
    assert "four-bar loop ground-link2-arm-crank: crank-rocker (crank turns fully)" in r.output
    assert f"arm {dyad:.6g}" in r.output


# -- slider-crank loops (issue 31 item 3) ---------------------------------------------------------
# Closed form: a crank a pivoted at the origin, its pin B = a (cos theta, sin theta), drives a
# rod b to a slider whose pin runs on the line y = e: the rod reaches it only while
# |e - a sin(theta)| <= b, so the crank, turned from theta0, locks at the first angle where
# |e - a sin(theta)| = b (the rod perpendicular to the guide) -- found here by bracketing and
# bisection of that condition, independent of planarkin's arcs.

def _slider_crank(a, b, e, w):
    """A slider-crank in body form, the crank at 0 rad at t = 0 turning at w rad/s."""
    xc = a + math.sqrt(b * b - e * e)
    return f"""\
name: short
units: {{length: m, angle: rad}}
bodies:
  crank:  {{q: [0, 0, 0]}}
  rod:    {{q: [{a!r}, 0, {math.atan2(e, xc - a)!r}]}}
  slider: {{q: [{xc!r}, {e!r}, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, i: crank, j: rod, si: [{a!r}, 0], sj: [0, 0]}}
  - {{type: revolute, i: rod, j: slider, si: [{b!r}, 0], sj: [0, 0]}}
  - {{type: translational, i: ground, j: slider, si: [0, {e!r}], sj: [0, 0], vi: [1, 0],
     vj: [1, 0]}}
drivers:
  - {{type: angle, body: crank, f: "{w!r}*t"}}
analysis: {{start: 0, end: 1, steps: 360}}
"""


def _slider_lock(a, b, e, up):
    """The first crank angle from 0 (turning up or down) where |e - a sin(theta)| = b."""
    g = lambda th: b - abs(e - a * math.sin(th))
    s = 1 if up else -1
    step = 1e-3
    th = 0.0
    while g(s * (th + step)) > 0:
        th += step
        if th > 2 * math.pi:
            return None
    lo, hi = th, th + step
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if g(s * mid) > 0 else (lo, mid)
    return s * hi


@pytest.mark.parametrize("a, b, e, w", [
    (0.1, 0.04, 0.0, 2 * math.pi),        # the rod shorter than the crank: locks at asin(b / a)
    (0.1, 0.04, 0.0, -2 * math.pi),       # the other way
    (0.1, 0.05, 0.02, -2 * math.pi),      # offset: sin(theta) >= (e - b) / a down
    (0.1, 0.05, 0.02, 2 * math.pi),       # and <= (e + b) / a up
    (0.1, 0.12, 0.05, -2 * math.pi),      # the rod longer than the crank, but a + |e| > b
    (0.1, 0.12, 0.05, 2 * math.pi),       # up: over the top, locking beyond 180 deg
    (0.1, 0.12, -0.05, 2 * math.pi),      # the offset on the other side
])
def test_check_and_run_warn_of_a_slider_crank_lock_up(tmp_path, a, b, e, w):
    assert b < a + abs(e)
    p = tmp_path / "short.yaml"
    p.write_text(_slider_crank(a, b, e, w))
    lim = _slider_lock(a, b, e, w > 0)
    t_lock = lim / w
    assert 0 < t_lock < 1
    r = CliRunner().invoke(main, ["check", str(p)])
    assert r.exit_code == 0, r.output                  # as a four-bar's: a warning, exit 0
    warn = [x for x in r.output.splitlines() if "warning:" in x]
    assert len(warn) == 1, r.output
    assert (f"short.yaml:14: warning: driver 1 (angle ground-crank): the slider-crank loop "
            f"ground-crank-rod-slider (rod {b:.6g} m < crank {a:.6g} + |offset| {abs(e):.6g} m: "
            f"the crank cannot turn fully) locks where crank reaches {lim:.6g} rad of this "
            f"driver (rod perpendicular to the guide of slider), which the driver reaches at "
            f"t = {t_lock:.6g} s") in warn[0]
    assert f"lengthen the rod to at least {a + abs(e):.6g} m" in warn[0]
    r = CliRunner().invoke(main, ["run", str(p), "--out", str(tmp_path / "out"), "--no-plots"])
    assert r.exit_code == 1, r.output
    assert r.output.count(warn[0]) == 1
    at = re.search(r"singular configuration at t = ([0-9.e+-]+) s: lock-up of driver 1", r.output)
    assert at is not None, r.output
    assert abs(float(at.group(1)) - t_lock) < 1e-6
    assert "toggle:" not in r.output and "passes near a toggle" not in r.output
    s = json.loads((tmp_path / "out" / "short" / "summary.json").read_text())
    assert warn[0].split("warning: ", 1)[1] in json.dumps(s)


@pytest.mark.parametrize("a, b, e", [(0.1, 0.3, 0.0), (0.1, 0.3, 0.15), (0.1, 0.16, -0.05)])
def test_a_slider_crank_whose_crank_turns_fully_gets_no_lock_up(tmp_path, a, b, e):
    assert b >= a + abs(e)
    r = _check(tmp_path, _slider_crank(a, b, e, 2 * math.pi))
    assert r.exit_code == 0 and "warning" not in r.output, r.output
