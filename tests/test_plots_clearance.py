"""The figures of issue 29 (planarkin.output.plots.outline, .clearance and the shapes in
mechanism.<fmt> and animation.gif): the shapes' outlines (exact offset geometry, the body-frame
to world transform, the units), the drawing of plates, obstacles and the closest approach, and
clearance.<fmt>."""

import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import planarkin
from planarkin.clearance.shape import Shape
from planarkin.output import plots
from planarkin.output.plots import clearance as cl
from planarkin.output.plots.outline import (ARC_STEP, hole_circles, place, rounded_outline)

FOUR_BAR_MM = """\
name: four-bar-plates
units: {length: mm, angle: deg}
parameters: {a: 40, b: 120, c: 100, d: 100}
bodies:
  crank:   {q: [0, 0, 0]}
  coupler: {q: [40, 0, 55]}
  rocker:  {q: [100, 0, 85]}
joints:
  - {type: revolute, i: ground, j: crank,   si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank,  j: coupler, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [b, 0], sj: [c, 0]}
  - {type: revolute, i: ground, j: rocker,  si: [d, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: crank, f: "360*t"}
points:
  P: {body: coupler, s: [60, 45]}
analysis: {start: 0, end: 1, steps: 120}
"""


def _segment_distance(X, a, b):
    """Distance of the points X (k, 2) from the segment a-b."""
    ab = b - a
    s = np.clip(((X - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.hypot(*(X - (a + s[:, None] * ab)).T)


def _distance_to_polyline(X, P, closed):
    edges = list(zip(P, np.roll(P, -1, axis=0))) if closed else list(zip(P[:-1], P[1:]))
    return np.min([_segment_distance(X, a, b) for a, b in edges], axis=0)


def _signed_area(V):
    x, y = V[:, 0], V[:, 1]
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def with_shapes(cm, shapes):
    return dataclasses.replace(cm, shapes=tuple(shapes))


# --- outline geometry ------------------------------------------------------------------------

def test_a_rounded_convex_plate_is_exactly_radius_from_its_hull():
    """Every vertex of the offset curve (the straight edges' ends and the arcs) is at exactly
    radius from the polygon, outside it; counter-clockwise whichever way the points run; the
    arcs are sampled at most ARC_STEP apart."""
    P = np.array([[0.0, 0.0], [3.0, -0.5], [4.0, 1.5], [1.0, 2.5], [-0.5, 1.2]])
    r = 0.35
    for pts in (P, P[::-1]):
        V = rounded_outline(pts, r, closed=True)
        assert _signed_area(V) > 0
        d = _distance_to_polyline(V, P, closed=True)
        assert np.allclose(d, r, rtol=0, atol=1e-12)
        chords = np.hypot(*np.diff(np.r_[V, V[:1]], axis=0).T)
        arcs = chords[chords < 0.5 * r]             # the arcs' chords (edges are longer)
        assert arcs.max() <= 2 * r * math.sin(0.5 * ARC_STEP) + 1e-12
        # the region: area of the polygon + perimeter * r + pi r^2 (Steiner), to the sampling
        perimeter = np.hypot(*np.diff(np.r_[P, P[:1]], axis=0).T).sum()
        exact = abs(_signed_area(P)) + perimeter * r + math.pi * r * r
        assert _signed_area(V) == pytest.approx(exact, rel=2e-4)


@pytest.mark.parametrize("theta", [0.0, 0.3, 2.0, -2.9])
def test_a_capsule_reaches_radius_beyond_its_ends_and_beside_its_axis(theta):
    a, length, r = np.array([1.0, 2.0]), 3.0, 0.4
    u = np.array([math.cos(theta), math.sin(theta)])
    n = np.array([-u[1], u[0]])
    for closed in (True, False):                 # two points: a capsule either way
        V = rounded_outline([a, a + length * u], r, closed=closed)
        along, across = (V - a) @ u, (V - a) @ n
        assert along.min() == pytest.approx(-r, abs=1e-12)
        assert along.max() == pytest.approx(length + r, abs=1e-12)
        assert np.abs(across).max() == pytest.approx(r, abs=1e-12)
        d = _distance_to_polyline(V, np.array([a, a + length * u]), closed=False)
        assert np.allclose(d, r, atol=1e-12)


def test_one_point_is_a_circle_and_radius_zero_is_the_polygon_itself():
    V = rounded_outline([[2.0, -1.0]], 0.5)
    assert np.allclose(np.hypot(*(V - (2.0, -1.0)).T), 0.5, atol=1e-15)
    assert len(V) >= 2 * math.pi / ARC_STEP
    square_cw = np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]])
    V = rounded_outline(square_cw, 0.0)
    assert _signed_area(V) == pytest.approx(1.0)
    assert {tuple(p) for p in V} == {tuple(p) for p in square_cw}
    wall = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]]
    assert np.array_equal(rounded_outline(wall, 0.0, closed=False), wall)


def test_a_polyline_has_both_sides_round_caps_and_mitred_inner_corners():
    """A wall of three points rounded by r: every vertex at r from the polyline (the inner
    corner is the offset edges' intersection, the outer one an arc); the caps' tips are r
    beyond the ends along the end edges."""
    W = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])
    r = 0.25
    V = rounded_outline(W, r, closed=False)
    assert np.allclose(_distance_to_polyline(V, W, closed=False), r, atol=1e-12)
    assert any(np.allclose(v, [4.0 - r, r]) for v in V)            # the mitre, inside
    assert any(np.allclose(v, [-r, 0.0]) for v in V)               # the first cap's tip
    assert any(np.allclose(v, [4.0, 3.0 + r]) for v in V)          # the last cap's tip
    assert V[:, 0].max() == pytest.approx(4.0 + r, abs=1e-12)


def test_a_concave_plate_is_mitred_at_its_reflex_corner():
    L_shape = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 1.0], [1.0, 1.0], [1.0, 3.0], [0.0, 3.0]])
    r = 0.2
    V = rounded_outline(L_shape, r)
    assert _signed_area(V) > 0
    assert np.allclose(_distance_to_polyline(V, L_shape, closed=True), r, atol=1e-12)
    assert any(np.allclose(v, [1.0 + r, 1.0 + r]) for v in V)


def test_place_rotates_then_translates():
    V = np.array([[1.0, 0.0], [0.0, 2.0], [3.0, -1.0]])
    W = place(V, 5.0, -2.0, math.pi / 2)
    assert np.allclose(W, [[5.0, -1.0], [3.0, -2.0], [6.0, 1.0]], atol=1e-15)
    # lengths are kept
    assert np.allclose(np.hypot(*np.diff(W, axis=0).T), np.hypot(*np.diff(V, axis=0).T))


def test_holes_are_circles_of_half_their_diameter():
    H = hole_circles([(1.0, 2.0, 0.5), (0.0, 0.0, 2.0)], 10.0)
    assert H.shape[0] == 2
    assert np.allclose(np.hypot(*(H[0] - (10.0, 20.0)).T), 2.5)
    assert np.allclose(np.hypot(*H[1].T), 10.0)


# --- the shapes in the scene -----------------------------------------------------------------

@pytest.fixture(scope="module")
def four_bar():
    m = planarkin.load("four-bar-plates.yaml", text=FOUR_BAR_MM)
    return m, planarkin.solve(m)


def _shapes(cm):
    """Plates for the four-bar (mm), a wall and a housing with a hole on ground."""
    L = cm.L

    def S(body, name, pts, radius, closed=True, holes=(), layer=(0.0, 0.0)):
        return Shape(body, name, np.asarray(pts, float) / L, radius / L, closed,
                     tuple((x / L, y / L, d / L) for x, y, d in holes), layer)

    return [S(0, "crank", [[0, 0], [40, 0]], 9, holes=[(0, 0, 8), (40, 0, 8)]),
            S(1, "coupler", [[0, 0], [120, 0], [60, 45]], 9,
              holes=[(0, 0, 8), (120, 0, 8)], layer=(1.0, 1.0)),
            S(2, "rocker", [[0, 0], [100, 0]], 9, holes=[(0, 0, 8), (100, 0, 8)]),
            S(3, "wall", [[-60, -40], [20, -40], [40, -60]], 3, closed=False),
            S(3, "housing", [[150, -30], [190, -30], [190, 60], [150, 60]], 0,
              holes=[(170, 40, 10)])]


def test_shapes_are_drawn_in_user_units_and_move_with_their_bodies(four_bar):
    m, r = four_bar
    cm = with_shapes(m, _shapes(m))
    sc = plots.Scene(cm, r._chunk)
    crank, coupler, rocker, wall, housing = sc.plates
    assert [p.name for p in sc.plates] == ["crank", "coupler", "rocker", "wall", "housing"]
    # internal units times cm.L: the crank's capsule is 40 + 2 * 9 mm long, 18 mm wide
    assert np.ptp(crank.outline, axis=0) == pytest.approx([58.0, 18.0], abs=1e-9)
    assert np.allclose(np.hypot(*(crank.holes[1] - (40.0, 0.0)).T), 4.0)
    assert (coupler.level, crank.level) == (1, 0) and crank.filled and housing.filled
    assert not wall.filled or wall.outline.shape[0] > 3
    # the plates replace the bars; the drawing's bounds hold the obstacles
    assert all(sc.bars[b] is None and sc.fills[b] is None for b in range(3))
    x0, x1, y0, y1 = sc.bounds
    assert x1 >= 190 and y0 <= -63
    # at every row the plate is where its body is: the body-frame outline turned by phi (deg)
    for i in (0, 17, 60):
        phi = math.radians(r.body("coupler")["phi"][i])
        q = (r.body("coupler")["x"][i], r.body("coupler")["y"][i])
        assert np.allclose(sc.at(1, coupler.outline, i), place(coupler.outline, *q, phi))
        # the crank's outer hole follows the pin B, which the coupler's first hole also holds
        assert np.allclose(sc.at(0, crank.holes[1], i).mean(axis=0),
                           sc.at(1, coupler.holes[0], i).mean(axis=0), atol=1e-9)


def _minima(sc):
    """Closest approaches found on the outlines' vertices (enough for the drawings)."""
    out = []
    P = {p.name: p for p in sc.plates}
    for a, b in (("crank", "wall"), ("coupler", "housing")):
        best = None
        for i in range(len(sc.t)):
            A, B = sc.at(P[a].body, P[a].outline, i), sc.at(P[b].body, P[b].outline, i)
            D = np.hypot(A[:, None, 0] - B[None, :, 0], A[:, None, 1] - B[None, :, 1])
            k = np.unravel_index(np.argmin(D), D.shape)
            if best is None or D[k] < best[0]:
                best = (float(D[k]), i, A[k[0]], B[k[1]])
        out.append(SimpleNamespace(a=a, b=b, t=float(sc.t[best[1]]), d=best[0],
                                   pa=best[2], pb=best[3]))
    return out


def test_mechanism_figure_draws_the_plates_and_marks_the_closest_approach(four_bar):
    from matplotlib.patches import Polygon

    m, r = four_bar
    cm = with_shapes(m, _shapes(m))
    sc = plots.Scene(cm, r._chunk)
    minima = _minima(sc)
    worst = min(minima, key=lambda q: q.d)
    fig = plots.mechanism_figure(cm, sc, minima=minima)
    ax = fig.axes[0]
    labels = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
    closest = [s for s in labels if s.endswith("(closest approach)")]
    assert closest == [f"t = {worst.t:.4g} s (closest approach)"]
    assert "closest approach" in labels
    # one instant fewer than bars would get (3 bodies: 4 - 1), plus the closest approach
    assert sum(s.startswith("t = ") for s in labels) == 4
    # each instant draws three plates and six holes; the ground draws its housing and hole
    white = [p for p in ax.patches if isinstance(p, Polygon) and p.get_facecolor()[:3] == (1, 1, 1)]
    assert len(white) == 4 * 6 + 1
    hatched = [p for p in ax.patches if p.get_hatch() == "////" and isinstance(p, Polygon)]
    assert len(hatched) == 2                    # the wall and the housing
    # the mark: a line from pa to pb and its value
    marks = [ln for ln in ax.lines if ln.get_color() == cl.MARK_COLOR and len(ln.get_xdata()) == 2]
    assert any(np.allclose(np.c_[ln.get_xdata(), ln.get_ydata()], [worst.pa, worst.pb])
               for ln in marks)
    texts = [t.get_text() for t in ax.texts]
    assert f"crank \u2013 wall: {worst.d:.3g} mm" in texts


def test_a_model_without_shapes_draws_what_it_drew(four_bar, tmp_path):
    """No shapes, no minima: the same files as the figures drawn without the arguments (and
    the bars, no plates)."""
    m, r = four_bar
    sc = plots.Scene(m, r._chunk)
    assert sc.plates == []
    assert all(sc.bars[b] is not None or sc.fills[b] is not None for b in range(3))
    a = plots.save_figure(plots.mechanism_figure(m, sc), tmp_path / "a.png").read_bytes()
    b = plots.save_figure(plots.mechanism_figure(with_shapes(m, ()), plots.Scene(
        with_shapes(m, ()), r._chunk), minima=()), tmp_path / "b.png").read_bytes()
    assert a == b


def test_the_animation_draws_the_plates_and_holds_on_each_closest_approach(four_bar,
                                                                            tmp_path):
    from PIL import Image

    from planarkin.output.plots.animation import HOLD

    m, r = four_bar
    cm = with_shapes(m, _shapes(m))
    minima = _minima(plots.Scene(cm, r._chunk))
    path = plots.write_animation(cm, r._chunk, tmp_path, minima=minima)
    with Image.open(path) as im:
        durations = []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
    # the least approach only (these have no limit to be closer than)
    held = [k for k, d in enumerate(durations) if d != 50]
    assert len(held) == 1 and durations[held[0]] == int(1000 * HOLD)


def test_the_approaches_marked_are_the_least_and_those_closer_than_their_limit():
    M = [SimpleNamespace(a="a", b="b", t=0.1, d=5.0, limit=6.0),
         SimpleNamespace(a="a", b="c", t=0.2, d=2.0, limit=1.0),
         SimpleNamespace(a="b", b="c", t=0.3, d=9.0, limit=1.0),
         SimpleNamespace(a="b", b="d", t=float("nan"), d=float("nan"), limit=1.0)]
    assert [(m.a, m.b) for m in cl.notable(M)] == [("a", "b"), ("a", "c")]
    assert cl.notable([]) == []


# --- clearance.<fmt> -------------------------------------------------------------------------

def _curves():
    t = np.linspace(0.0, 2.0, 241)
    return t, {("crank", "rocker"): 12 + 9 * np.cos(2 * np.pi * t),
               ("coupler", "wall"): 6 + 8 * np.sin(2 * np.pi * t + 0.5)}


def test_clearance_figure_lines_limit_minima_and_overlaps():
    t, D = _curves()
    given = [SimpleNamespace(a="rocker", b="crank", t=0.5, d=3.0),
             SimpleNamespace(a="coupler", b="wall", t=0.6722, d=-2.0)]
    fig = cl.clearance_figure(t, D, given, limit=4.0, unit="mm", name="four-bar")
    ax = fig.axes[0]
    labels = [t_.get_text() for lg in fig.legends for t_ in lg.get_texts()]
    assert sorted(s for s in labels if s.strip()) == sorted([
        "crank \u2013 rocker", "coupler \u2013 wall", "limit 4 mm", "minimum", "overlap"])
    limit = [ln for ln in ax.lines if ln.get_color() == cl.LIMIT_COLOR]
    assert len(limit) == 1 and np.all(np.asarray(limit[0].get_ydata()) == 4.0)
    dots = [ln for ln in ax.lines if ln.get_marker() == "o" and len(ln.get_xdata()) == 2]
    assert np.allclose(np.c_[dots[0].get_xdata(), dots[0].get_ydata()],
                       [[0.5, 3.0], [0.6722, -2.0]])
    texts = {t_.get_text() for t_ in ax.texts}
    assert {"3 mm at 0.5 s", "\u22122 mm at 0.672 s"} <= texts
    assert "overlap, 2 mm deep" in fig._suptitle.get_text()
    # the overlap of coupler-wall (d <= 0 once a cycle) is shaded, from row to row
    spans = cl._overlap_spans(t, list(D.values()))
    assert len(spans) == 2
    for t0, t1 in spans:
        inside = (t > t0) & (t < t1)
        assert np.all(D[("coupler", "wall")][inside] <= 1e-12)
    assert ax.get_ylim()[0] < -2.0 < 0.0 < 21.0 < ax.get_ylim()[1]


def test_clearance_minima_default_to_the_rows_and_files_are_deterministic(tmp_path):
    t, D = _curves()
    fig = cl.clearance_figure(t, {("crank", "rocker"): D[("crank", "rocker")]})
    texts = {t_.get_text() for t_ in fig.axes[0].texts}
    assert texts == {"3 m at 0.5 s"}
    assert "limit" not in " ".join(t_.get_text() for lg in fig.legends for t_ in lg.get_texts())
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a, b = (cl.draw(t, D, None, 4.0, tmp_path / d, "svg", "mm", "x") for d in "ab")
    assert a.name == "clearance.svg" and a.read_bytes() == b.read_bytes()
    png = cl.draw(t, D, None, 4.0, tmp_path, "png", "mm", "x")
    assert png.read_bytes().startswith(b"\x89PNG")


def test_pairs_with_limits_of_their_own_get_a_line_each_named():
    t, D = _curves()
    fig = cl.clearance_figure(t, D, None, {("rocker", "crank"): 4.0, ("coupler", "wall"): 6.0},
                              unit="mm")
    ax = fig.axes[0]
    limit = sorted(float(ln.get_ydata()[0]) for ln in ax.lines
                   if ln.get_color() == cl.LIMIT_COLOR)
    assert limit == [4.0, 6.0]
    texts = {t_.get_text() for t_ in ax.texts}
    assert {"4 mm: crank \u2013 rocker", "6 mm: coupler \u2013 wall"} <= texts
    assert "limits" in [t_.get_text() for lg in fig.legends for t_ in lg.get_texts()]


def test_a_clearance_figure_needs_a_pair_and_takes_rows_without_values():
    with pytest.raises(ValueError, match="no pairs"):
        cl.clearance_figure(np.linspace(0.0, 1.0, 5), {})
    fig = cl.clearance_figure(np.linspace(0.0, 1.0, 5), {("a", "b"): np.full(5, np.nan)},
                              limit=1.0)
    assert [t.get_text() for t in fig.axes[0].texts] == []


def test_nearest_row():
    t = np.array([0.0, 0.1, 0.2, 0.3])
    assert [cl.nearest_row(t, w) for w in (-1.0, 0.04, 0.06, 0.25001, 9.0)] == [0, 0, 1, 3, 3]
    assert cl.nearest_row(np.array([0.5]), 3.0) == 0


def test_shapes_from_the_model_file_are_drawn(tmp_path):
    """A run of a model with `shapes:` writes mechanism.png with its plates and clearance.png;
    the closest approach of planarkin.clearance.cycle.minima is marked."""
    from planarkin.clearance.cycle import minima

    text = FOUR_BAR_MM + """\
shapes:
  crank:   {plate: 18, hole: 8}
  coupler: {plate: 18, hole: 8, layer: 1}
  rocker:  {plate: 18, hole: 8}
  wall:    {body: ground, polyline: [[-60, -40], [20, -40]], radius: 3}
"""
    m = planarkin.load(tmp_path / "m.yaml", text=text)
    r = planarkin.solve(m, steps=60)
    sc = plots.Scene(m, r._chunk)
    assert sorted(p.name for p in sc.plates) == ["coupler", "crank", "rocker", "wall"]
    lows = minima(m, r)
    worst = min(lows, key=lambda q: q.d)
    fig = plots.mechanism_figure(m, sc, minima=lows)
    assert any(t.get_text().startswith(f"{worst.a} \u2013 {worst.b}: ")
               for t in fig.axes[0].texts)
    files = plots.write_plots(m, r._chunk, None, tmp_path, only=["mechanism"], minima=lows)
    assert files == [tmp_path / "mechanism.png"] and Path(files[0]).stat().st_size > 10_000
    written = r.write(tmp_path / "run", plots="png")
    names = {Path(f).name for f in written["files"]} | set(written.get("plots", []))
    assert {"mechanism.png", "clearance.png"} <= names
