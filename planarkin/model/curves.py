"""The mapping forms of a curve-slot's ``curve:`` (a list of points is read by the validator):

    curve: {circle: {centre: [x, y], radius: r}}
    curve: {segments: [{line: {from: [x, y], to: [x, y]}},
                       {arc: {centre: [x, y], radius: r, from: angle, to: angle}}, ...]}
    curve: {table: FILE.csv}   or   {table: {file: FILE.csv, x: COLUMN, y: COLUMN}}

Circles and segments become an exact `elements.path.PathCurve` (user lengths, radians); a table
becomes the list of points of the spline form, read by the reader of driver tables
(planarkin.functions.inputtable), every problem of the file a FILE:LINE diagnostic.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..diagnostics import Diagnostic
from ..elements.path import Arc, Line, PathCurve, joints

MAX_SEGMENTS = 1000
MAX_ARC = 1e50      # a point curve's arc length, user unit (its fifth power stays finite)


def lost_step(pts) -> tuple[int, str] | None:
    """(k, why) when the step from point k - 1 to point k (0-based) is lost to rounding in the
    arc length the spline is parameterised by (the cumulative sum of the chords, as
    elements.curve.Curve builds it): a point far from the others (1e100 among points of 0.3)
    makes the sum stop growing, and the spline's knots repeat. None when every step counts."""
    import numpy as np
    P = np.asarray(pts, dtype=float)
    d = np.hypot(*np.diff(P, axis=0).T)
    a = np.concatenate([[0.0], np.cumsum(d)])
    bad = np.flatnonzero(~(np.diff(a) > 0))
    far = int(np.argmax(np.abs(P).max(axis=1)))
    where = (f"point {far + 1} at [{P[far, 0]:.6g}, {P[far, 1]:.6g}] is far from the others; "
             f"give the points of one curve at a common scale")
    if len(bad):
        k = int(bad[0]) + 1
        return k, (f"point {k + 1} is {d[k - 1]:.3g} from point {k}, a step lost to rounding in "
                   f"the curve's arc length so far ({a[k - 1]:.3g}): {where}")
    if not a[-1] <= MAX_ARC:    # the spline's collocation takes powers up to the fifth
        k = int(np.argmax(a > MAX_ARC))
        return k, (f"the curve's arc length reaches {a[k]:.3g} at point {k + 1}, too long for "
                   f"its quintic spline (at most {MAX_ARC:g}): {where}")
    return None


def curve_form(V, node, what: str):
    """A PathCurve or a tuple of points from the mapping node, or None (diagnostics in V)."""
    forms = ("circle", "segments", "table")
    if not V.keys(node, forms, what):
        return None
    given = [k for k in forms if k in node.value]
    if len(given) != 1:
        V.err(node, f"{what}: give one of circle, segments and table"
                    + (f", not {' and '.join(given)}" if given else ""))
        return None
    key = given[0]
    v = node.value[key]
    if key == "table":
        return _table(V, v, f"{what}: table")
    if key == "circle":
        arc = _arc(V, v, f"{what}: circle", full=True)
        return None if arc is None else PathCurve([arc], closed=True)
    return _segments(V, v, f"{what}: segments")


def _arc(V, node, what: str, full: bool = False):
    keys = ("centre", "radius") if full else ("centre", "radius", "from", "to")
    if not V.keys(node, keys, what):
        return None
    v = node.value
    missing = [k for k in keys if k not in v]
    if missing:
        hint = ("centre: [x, y], radius: r" if full else
                "centre: [x, y], radius: r, from: ANGLE, to: ANGLE (angles of the ends seen from "
                "the centre; to > from: counter-clockwise)")
        V.err(node, f"{what}: missing {' and '.join(missing)} ({hint})")
        return None
    c = V.vector(v["centre"], f"{what}: centre")
    r = V.number(v["radius"], f"{what}: radius")
    if r is not None and not r > 0:
        V.err(v["radius"], f"{what}: radius must be positive, not {r:g}")
        r = None
    if full:
        return None if c is None or r is None else Arc(c, r, 0.0, 2 * math.pi)
    af = math.pi / 180.0 if getattr(V, "angle_unit", "rad") == "deg" else 1.0
    a, b = (V.number(v[k], f"{what}: {k}") for k in ("from", "to"))
    if None in (c, r, a, b):
        return None
    turn = 360.0 if af != 1.0 else 2 * math.pi
    if a == b or abs(b - a) > turn * (1 + 1e-15):
        V.err(v["to"], f"{what}: from and to must differ by more than 0 and at most a full turn "
                       f"({turn:g}), not {a:g} and {b:g}")
        return None
    return Arc(c, r, a * af, b * af)


def _line(V, node, what: str):
    if not V.keys(node, ("from", "to"), what):
        return None
    v = node.value
    if "from" not in v or "to" not in v:
        V.err(node, f"{what}: missing {'from' if 'from' not in v else 'to'} (a line is "
                    f"{{from: [x, y], to: [x, y]}})")
        return None
    p0, p1 = V.vector(v["from"], f"{what}: from"), V.vector(v["to"], f"{what}: to")
    if p0 is None or p1 is None:
        return None
    if p0 == p1:
        V.err(node, f"{what}: from and to are the same point; a line needs two")
        return None
    return Line(p0, p1)


def _segments(V, node, what: str):
    if node.kind != "seq" or not node.value:
        V.err(node, f"{what} must be a non-empty list of {{line: {{from, to}}}} and {{arc: "
                    f"{{centre, radius, from, to}}}}")
        return None
    if len(node.value) > MAX_SEGMENTS:
        V.err(node, f"{what}: at most {MAX_SEGMENTS} segments (longer curves: a table)")
        return None
    segs, ok = [], True
    for k, item in enumerate(node.value, start=1):
        sw = f"{what}: segment {k}"
        if not V.keys(item, ("line", "arc"), sw):
            ok = False
            continue
        if len(item.value) != 1:
            V.err(item, f"{sw}: give exactly one of line and arc")
            ok = False
            continue
        (kind, sub), = item.value.items()
        if kind not in ("line", "arc"):         # reported by keys
            ok = False
            continue
        seg = _line(V, sub, f"{sw}: line") if kind == "line" else _arc(V, sub, f"{sw}: arc")
        ok = ok and seg is not None
        segs.append(seg)
    if not ok:
        return None
    scale = max(max(abs(x) for s in segs for x in (s.p0 + s.p1 if isinstance(s, Line) else
                                                   s.centre + (s.r,))), 1e-300)
    closed, problems = joints(segs, scale)
    for j, msg in problems:
        V.err(node.value[j - 1], f"{what}: {msg}")
    return None if problems else PathCurve(segs, closed)


def _table(V, node, what: str):
    from planarkin.functions.inputtable import MAX_CURVE_POINTS, TableError, read_columns
    ref = V.table_ref(node, what, ("x", "y"), (), " of x, y points")
    if ref is None:
        return None
    fname, cols, v = ref
    path = Path(V.file).parent / fname
    shown = str(path)
    owner = what.rsplit(": curve", 1)[0]
    try:
        (x, y), lines = read_columns(path, [(cols.get("x"), 0, "x"), (cols.get("y"), 1, "y")],
                                     increasing=False, min_rows=6, max_rows=MAX_CURVE_POINTS)
    except TableError as exc:
        V.table_errors(exc, node, what, shown, f"the curve of {owner}")
        return None
    pts = list(zip(x.tolist(), y.tolist()))
    for k in range(1, len(pts)):
        if pts[k] == pts[k - 1]:
            V.C.items.append(Diagnostic(shown, lines[k], f"point {k + 1} repeats point {k} (line "
                                                         f"{lines[k - 1]}); the points of a curve "
                                                         f"must be distinct in succession (the "
                                                         f"curve of {owner})"))
            return None
    if len(pts) > 6 and pts[0] == pts[-1]:
        pts = pts[:-1]          # a closed curve may repeat its first point, as in a list
    lost = lost_step(pts)
    if lost is not None:
        V.C.items.append(Diagnostic(shown, lines[lost[0]], f"{lost[1]} (the curve of {owner})"))
        return None
    return tuple(pts)
