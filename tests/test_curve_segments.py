"""Exact curves for curve-slot: circles, lines and arcs (planarkin/elements/path.py), and curve
tables read from files.

Closed forms: a pin in a circular slot against a link to the circle's centre (derived by hand),
a four-bar whose rocker is replaced by a circular slot about the rocker's pivot (held-out: the
slot must reproduce the revolute's mechanism), a stadium-shaped track (lines and arcs) against
the piecewise closed form. Plus reference §10 (finite-difference gradient, gamma three ways) on
exact curves, and the jerk right-hand side against a finite difference in time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import planarkin
from planarkin.elements import KINDS
from planarkin.elements.base import group, make_frame
from planarkin.elements.path import Arc, Line, PathCurve
from closedforms import rel, run

TOL = 1e-12
TWO_PI = 2 * math.pi


CIRCLE_SLOT = """
units: {{length: m, angle: rad}}
parameters: {{Cx: 0.3, Cy: 0.2, R: 0.5}}
bodies: {{block: {{q: [0.3, 0.7, 0]}}}}
joints:
  - {{type: angle, i: ground, j: block, c: 0}}
  - {{type: curve-slot, i: ground, j: block, sj: [0, 0], curve: {curve}}}
drivers:
  - {{type: x, i: ground, j: block, f: "Cx + 0.4*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 50}}
"""


@pytest.mark.parametrize("curve", [
    "{circle: {centre: [Cx, Cy], radius: R}}",
    # the upper half as one arc (counter-clockwise from 0 to pi): the pin stays within it
    "{segments: [{arc: {centre: [Cx, Cy], radius: R, from: 0, to: pi}}]}",
    # the same half clockwise, split in two arcs joined at the top
    "{segments: [{arc: {centre: [Cx, Cy], radius: R, from: pi, to: pi/2}}, "
    "{arc: {centre: [Cx, Cy], radius: R, from: pi/2, to: 0}}]}",
])
def test_pin_in_a_circular_slot_equals_a_link_to_the_centre(curve):
    """A block (no rotation) whose origin runs in a circular slot (centre C, radius R), driven by
    x = Cx + 0.4 sin(2 pi t): a link of length R pinned at C, y = Cy + w, w = sqrt(R^2 - u^2),
    u = x - Cx; y' = -u u'/w; y'' = -(u'^2 + u u'')/w - u^2 u'^2/w^3. The exact circle meets it
    to 1e-12 (the quintic table of 720 points: only 2e-9 in accelerations)."""
    res = run(CIRCLE_SLOT.format(curve=curve))
    t = res.t
    u = 0.4 * np.sin(TWO_PI * t)
    ud = 0.4 * TWO_PI * np.cos(TWO_PI * t)
    udd = -0.4 * TWO_PI**2 * np.sin(TWO_PI * t)
    w = np.sqrt(0.25 - u * u)
    b = res.body("block")
    assert rel(b["y"], 0.2 + w) < TOL
    assert rel(b["vy"], -u * ud / w) < TOL
    assert rel(b["ay"], -(ud * ud + u * udd) / w - u * u * ud * ud / w**3) < TOL


FOUR_BAR = """
units: {{length: m, angle: rad}}
bodies:
  crank: {{q: [0, 0, 0]}}
  coupler: {{q: [0.1, 0, 0.9479697413828937]}}
{rocker_body}
joints:
  - {{type: revolute, i: ground, j: crank, at: [0, 0]}}
  - {{type: revolute, i: crank, j: coupler, si: [0.1, 0], sj: [0, 0]}}
{rest}
drivers:
  - {{type: angle, body: crank, f: "2*pi*t + 0.3*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 60}}
"""


@pytest.mark.parametrize("slot", [
    "{circle: {centre: [0.4, 0], radius: 0.3}}",
    # the slot a designer would cut: the arc the rocker's end sweeps (1.77 to 2.47 rad), with
    # a margin, clockwise
    "{segments: [{arc: {centre: [0.4, 0], radius: 0.3, from: 2.6, to: 1.6}}]}",
])
def test_four_bar_rocker_replaced_by_a_circular_slot_is_the_same_mechanism(slot):
    """Crank 0.1, coupler 0.35, rocker 0.3 pivoted at C = (0.4, 0): the coupler's end B in a
    circular slot of radius 0.3 about C is kinematically the rocker (a revolute at the slot's
    centre). Held-out: the crank and coupler coordinates of both models, P, V and A, agree to
    1e-12 relative to each quantity's largest value over the turn."""
    link = run(FOUR_BAR.format(
        rocker_body="  rocker: {q: [0.4, 0, 1.8959394827657874]}",
        rest="  - {type: revolute, i: coupler, j: rocker, si: [0.35, 0], sj: [0.3, 0]}\n"
             "  - {type: revolute, i: ground, j: rocker, at: [0.4, 0]}"))
    cut = run(FOUR_BAR.format(
        rocker_body="", rest="  - {type: curve-slot, i: ground, j: coupler, sj: [0.35, 0], "
                             f"curve: {slot}}}"))
    for arr in ("q", "qd", "qdd"):
        x, y = getattr(cut, arr)[:, :6], getattr(link, arr)[:, :6]
        for c in range(6):
            assert rel(x[:, c], y[:, c], max(np.max(np.abs(y[:, c])), 1e-300) if
                       np.max(np.abs(y[:, c])) > 1e-9 else 1.0) < TOL, (arr, c)


STADIUM = """
units: {length: m, angle: deg}
bodies: {pin: {q: [0.5, 0.0, 0]}}
joints:
  - {type: angle, i: ground, j: pin, c: 0}
  # a stadium track: bottom line, right half circle, top line, left half circle
  - type: curve-slot
    i: ground
    j: pin
    sj: [0, 0]
    curve:
      segments:
        - line: {from: [0, 0], to: [1, 0]}
        - arc: {centre: [1, 0.5], radius: 0.5, from: -90, to: 90}
        - line: {from: [1, 1], to: [0, 1]}
        - arc: {centre: [0, 0.5], radius: 0.5, from: 90, to: 270}
drivers:
  - {type: x, body: pin, f: "0.5 + 0.9*sin(2*pi*t)"}
analysis: {end: 1, steps: 80}
"""


def test_stadium_track_lines_and_arcs():
    """The pin's x is driven over [-0.4, 1.4]: on the bottom line y = 0 for 0 <= x <= 1; on the
    end arcs y = 0.5 - sqrt(0.25 - e^2), e = x - 1 (right) or x (left), so y' = e e'/w,
    y'' = (e'^2 + e e'')/w + e^2 e'^2/w^3 with w = sqrt(0.25 - e^2). The acceleration jumps where
    line meets arc (the curvature does); rows on either side match their piece."""
    res = run(STADIUM)
    t = res.t
    x = 0.5 + 0.9 * np.sin(TWO_PI * t)
    xd = 0.9 * TWO_PI * np.cos(TWO_PI * t)
    xdd = -0.9 * TWO_PI**2 * np.sin(TWO_PI * t)
    e = np.where(x > 1, x - 1, np.where(x < 0, x, 0.0))
    w = np.sqrt(0.25 - e * e)
    y = 0.5 - w
    yd = e * xd / w
    ydd = np.where(e != 0, (xd * xd + e * xdd) / w + e * e * xd * xd / w**3, 0.0)
    b = res.body("pin")
    assert np.any(x > 1.2) and np.any(x < -0.2)
    assert rel(b["y"], y, 0.5) < TOL
    assert rel(b["vy"], yd, np.max(np.abs(xd))) < TOL
    assert rel(b["ay"], ydd, np.max(np.abs(xdd))) < TOL


def test_an_arc_too_small_for_the_model_is_refused():
    """An arc of radius 1e-300 in a model of size 0.5 m would overflow its curvature terms."""
    with pytest.raises(planarkin.InputError) as exc:
        planarkin.load("tiny.yaml", text=CIRCLE_SLOT.format(curve="{circle: {centre: [0, 0], "
                                                                 "radius: 1e-300}}"))
    assert str(exc.value) == ("tiny.yaml:7: error: joint 2 (curve-slot ground-block): curve: "
                              "circle: the arc's radius 1e-300 m is too small for a model of size "
                              "0.5 m (at least 1e-9 of it)")


# -- curve tables from files ---------------------------------------------------------------------

def test_curve_table_from_a_file_equals_the_inline_table(tmp_path):
    """`curve: {table: FILE}` reads the points with the driver-table reader (header, '#'
    comments, named columns): the run equals the inline list's to the last bit."""
    a = np.linspace(0.0, TWO_PI, 90, endpoint=False)
    pts = np.c_[0.3 + 0.5 * np.cos(a), 0.2 + 0.5 * np.sin(a)]
    rows = "\n".join(f"{i},{float(x)!r},{float(y)!r}" for i, (x, y) in enumerate(pts))
    (tmp_path / "slot.csv").write_text(f"# a circular slot, 4 degrees apart\nk,x [m],y [m]\n{rows}\n")
    inline = "[" + ", ".join(f"[{float(x)!r}, {float(y)!r}]" for x, y in pts) + "]"
    text = CIRCLE_SLOT.replace("curve: {curve}}}", "closed: true, curve: {curve}}}").replace(
        "steps: 50", "steps: 12")
    path = tmp_path / "m.yaml"
    path.write_text(text.format(curve="{table: {file: slot.csv, x: 'x [m]', y: 'y [m]'}}"))
    got = planarkin.solve(planarkin.load(path))
    want = run(text.format(curve=inline))
    assert got.status == 0
    assert np.array_equal(got.q, want.q) and np.array_equal(got.qdd, want.qdd)


@pytest.mark.parametrize("content, message", [
    ("x,y\n0,0\n1,0\n2,oops\n", "{csv}:4: error: 'oops' is not a number (the curve of joint 2 "
                                "(curve-slot ground-block))"),
    ("0,0\n1,0\n1,0\n2,1\n3,1\n4,0\n5,0\n", "{csv}:3: error: point 3 repeats point 2 (line 2); the "
                                            "points of a curve must be distinct in succession (the "
                                            "curve of joint 2 (curve-slot ground-block))"),
    ("0,0\n1,0\n", "{yaml}:7: error: joint 2 (curve-slot ground-block): curve: table: {csv}: the "
                   "table needs at least 6 rows of numbers, found 2"),
])
def test_bad_curve_tables_are_file_line_errors(tmp_path, content, message):
    (tmp_path / "slot.csv").write_text(content)
    path = tmp_path / "m.yaml"
    path.write_text(CIRCLE_SLOT.format(curve="{table: slot.csv}"))
    with pytest.raises(planarkin.InputError) as exc:
        planarkin.load(path)
    want = message.format(csv=tmp_path / "slot.csv", yaml=path)
    assert want in str(exc.value), str(exc.value)


# -- reference §10 on exact curves ---------------------------------------------------------------

NB = 3
K = 12


def exact_curves():
    """A circle, a closed stadium and an open line running into a quarter arc, placed so that
    the random pins (within a few units of the origin) are far from centres of curvature and
    from points with two closest points, and project inside the open curve."""
    circle = PathCurve([Arc((9.0, 2.0), 7.0, 0.0, TWO_PI)], True)
    st = [Line((-4, 4), (4, 4)), Arc((4, 10), 6, -math.pi / 2, math.pi / 2),
          Line((4, 16), (-4, 16)), Arc((-4, 10), 6, math.pi / 2, 1.5 * math.pi)]
    s_curve = [Line((-30, 0), (-8, 0)), Arc((-8, 8), 8, -math.pi / 2, 0.0)]
    return [circle, PathCurve(st, True), PathCurve(s_curve, False)]


def instances(rng):
    kind = KINDS["curve-slot"]
    curves = exact_curves()
    bodies = []
    while len(bodies) < K:
        b = rng.integers(0, NB + 1, size=2)
        if b[0] != b[1]:
            bodies.append(b)
    cv = np.empty(K, dtype=object)
    for k in range(K):
        cv[k] = curves[k % 3]
    params = {"sj": rng.normal(size=(K, 2)), "curve": cv, "closed": np.zeros(K)}
    return group(kind, np.array(bodies), params)


def ext(x):
    return np.concatenate([x, np.zeros((x.shape[0], 3))], axis=1)


def directional(G, q, qd):
    J = G.grad(make_frame(q))
    return np.einsum("nkec,nkc->nke", J, qd[:, G.cols])


def test_exact_curve_gradient_and_gamma_against_finite_differences():
    rng = np.random.default_rng(11)
    kind = KINDS["curve-slot"]
    for _ in range(12):
        G = instances(rng)
        q = ext(rng.normal(size=(1, 3 * NB)) * 0.8)
        qd, qdd = (ext(rng.normal(size=(1, 3 * NB))) for _ in range(2))
        J = G.grad(make_frame(q))
        for c in range(3 * NB):
            dq = np.zeros_like(q)
            dq[0, c] = 1e-6
            fd = (G.g(make_frame(q + dq)) - G.g(make_frame(q - dq))) / 2e-6
            an = np.zeros_like(fd)
            for loc in range(6):
                hit = G.cols[:, loc] == c
                an[:, hit, :] += J[..., loc][:, hit, :]
            np.testing.assert_allclose(an, fd, rtol=1e-7, atol=1e-7)
        gam = G.gamma(make_frame(q, qd))
        e = 1e-5
        b1 = -(directional(G, q + e * qd, qd) - directional(G, q - e * qd, qd)) / (2 * e)
        np.testing.assert_allclose(gam, b1, rtol=1e-6, atol=1e-6)
        e2 = 1e-4
        g = lambda x: G.g(make_frame(x))
        d2 = (g(q + e2 * qd) - 2 * g(q) + g(q - e2 * qd)) / e2**2
        np.testing.assert_allclose(gam, -d2, rtol=2e-5, atol=2e-5)
        path = lambda s: q + s * qd + 0.5 * s * s * qdd
        d2p = (g(path(e2)) - 2 * g(path(0.0)) + g(path(-e2))) / e2**2
        np.testing.assert_allclose(directional(G, q, qdd) - gam, d2p, rtol=2e-5, atol=2e-5)
    assert kind.name == "curve-slot"


def test_arc_derivatives_are_those_of_the_circle():
    """c', c'', c''' of an arc in arc length against the closed form of the circle: unit
    tangent, curvature sense / r, and c''' = -c' / r^2."""
    arc = Arc((1.0, 2.0), 0.7, 2.5, -1.0)            # clockwise
    u = np.linspace(0.0, arc.length, 7)
    c, c1, c2, c3 = arc.eval(u, 3)
    assert np.allclose(np.hypot(*(c - [1.0, 2.0]).T), 0.7, rtol=1e-15, atol=0)
    assert np.allclose(np.hypot(*c1.T), 1.0, rtol=1e-15, atol=0)
    kappa = c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]
    assert np.allclose(kappa, -1 / 0.7, rtol=1e-15, atol=0)
    assert np.allclose(c3, -c1 / 0.49, rtol=1e-14, atol=0)
    # central differences of c'' agree with c''' (a check independent of the cycling formula)
    h = 1e-5
    fd = (arc.eval(u[1:-1] + h, 2)[2] - arc.eval(u[1:-1] - h, 2)[2]) / (2 * h)
    assert np.allclose(fd, c3[1:-1], rtol=1e-8, atol=1e-9)


def test_chain_third_derivative_against_differences():
    """PathCurve.third (the jerk of a pin needs dkappa/ds) against central differences of c''
    along the stadium, away from its joints (where c'' jumps from line to arc)."""
    cv = exact_curves()[1]
    a = np.array([1.0, 3.0, 9.0, 12.0, 20.0, 30.0])
    a = a[np.all(np.abs(a[:, None] - cv.starts[None, :]) > 1e-3, axis=1)]
    h = 1e-5
    fd = (cv.eval(a + h)[2] - cv.eval(a - h)[2]) / (2 * h)
    assert np.allclose(cv.third(a), fd, rtol=1e-7, atol=1e-9)
    assert np.abs(cv.third(a)).max() > 1e-3       # the arcs' c''' is not zero


def test_exact_curve_jerk_against_a_third_difference_in_time():
    """jerk_g = g_q q''' - d3g/ds3 along q + s q' + s^2/2 q'' + s^3/6 q''' (the jerk interface
    of issue 8 item 5). curve-slot's jerk comes with the jerk work on the kinds (another
    branch); until it is merged this test skips, afterwards it checks it on exact curves."""
    from planarkin.elements.base import Frame
    rng = np.random.default_rng(12)
    for _ in range(10):
        G = instances(rng)
        q = ext(rng.normal(size=(1, 3 * NB)) * 0.8)
        qd, qdd, qddd = (ext(rng.normal(size=(1, 3 * NB))) for _ in range(3))
        phi = q[:, 2::3]
        F = Frame(q, np.cos(phi), np.sin(phi), qd, qdd)
        jerk = G.kind.jerk(G, F)
        path = lambda s: q + s * qd + s * s / 2 * qdd + s**3 / 6 * qddd   # noqa: E731
        g = lambda s: G.g(make_frame(path(s)))                           # noqa: E731
        h = 2e-3
        d3 = (g(2 * h) - 2 * g(h) + 2 * g(-h) - g(-2 * h)) / (2 * h**3)
        np.testing.assert_allclose(directional(G, q, qddd) - d3, jerk, rtol=1e-4, atol=1e-4)
