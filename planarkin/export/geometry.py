"""Plane geometry of the drawings, in millimetres: the shapes a drawing holds (polylines whose
segments are straight or circular by their bulge, circles, lines), the plate around a link's
pins, the arcs' centres and extents, distances to a polyline and rigid placements. numpy only.

A segment's bulge is DXF's: tan(sweep / 4), the sweep signed (positive counter-clockwise), so
that 0 is a straight segment, 1 a half circle turning left; LWPOLYLINE stores exactly that, and
an arc so stored is exact (no chords).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

OUTLINE, HOLES, CENTRES, PITCH, TEXT = "OUTLINE", "HOLES", "CENTRES", "PITCH", "TEXT"
LAYERS = {  # name -> (ACI colour, what it holds)
    OUTLINE: (7, "the part's cut outline: plate, cam working surface, gear blank, roller"),
    HOLES: (1, "pin holes (pin diameter + clearance)"),
    CENTRES: (8, "pin centres and marked points: a small cross"),
    PITCH: (3, "reference curves, not cut: cam pitch curves, gear pitch circles"),
    TEXT: (5, "part name, thickness, hole diameter, tolerance, notes"),
}


@dataclass(frozen=True)
class Shape:
    """One entity of a drawing, mm. kind 'poly': points (n, 2) vertices, bulges (n,) the bulge
    of the segment from vertex k to k + 1 (the last one's, closing, only when closed); 'circle':
    points (1, 2) the centre, r the radius; 'line': points (2, 2)."""

    kind: str
    layer: str
    points: np.ndarray
    bulges: np.ndarray | None = None
    closed: bool = False
    r: float = 0.0


@dataclass(frozen=True)
class Text:
    """One line of text, mm: its insertion point (left end of the baseline) and height."""

    at: tuple
    height: float
    text: str


@dataclass
class Part:
    """One part's drawing in its body frame, mm. name: its file stem and label; body: the
    model's body (None for a part that is not one, a cam's roller); kind: link, cam, gear or
    roller; holes: (h, 2) the hole centres; hole: their diameter; notes: the text lines under
    it; fits: per fitted curve, what planarkin.export.biarcs measured."""

    name: str
    body: str | None
    kind: str
    shapes: list = field(default_factory=list)
    holes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    hole: float = 0.0
    notes: list = field(default_factory=list)
    fits: list = field(default_factory=list)


def circle(c, r: float, layer: str) -> Shape:
    return Shape("circle", layer, np.asarray(c, float).reshape(1, 2), r=float(r))


def line(p, q, layer: str) -> Shape:
    return Shape("line", layer, np.array([p, q], float))


def cross(c, size: float) -> list[Shape]:
    """A centre mark: two lines of length 2 size through c (layer CENTRES)."""
    x, y = (float(v) for v in c)
    return [line((x - size, y), (x + size, y), CENTRES), line((x, y - size), (x, y + size),
                                                              CENTRES)]


# -- the plate around pins --------------------------------------------------------------------

def unique_points(P: np.ndarray, tol: float) -> np.ndarray:
    """P (n, 2) without repeats: a point within tol of an earlier one is that one."""
    out: list = []
    for p in np.asarray(P, float).reshape(-1, 2):
        if not any(math.hypot(*(p - q)) <= tol for q in out):
            out.append(p)
    return np.array(out, float).reshape(-1, 2)


def convex_hull(P: np.ndarray) -> np.ndarray:
    """The convex hull's vertices of distinct points P (n, 2), counter-clockwise, without the
    points on its edges (Andrew's monotone chain)."""
    pts = sorted(map(tuple, np.asarray(P, float)))
    if len(pts) <= 2:
        return np.array(pts, float).reshape(-1, 2)

    def turn(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def chain(seq):
        h: list = []
        for p in seq:
            while len(h) >= 2 and turn(h[-2], h[-1], p) <= 0:
                h.pop()
            h.append(p)
        return h

    lower, upper = chain(pts), chain(reversed(pts))
    return np.array(lower[:-1] + upper[:-1], float)


def _straight_vertices(H: np.ndarray) -> np.ndarray:
    """H without the vertices where the hull does not turn (collinear within rounding: a pin a
    few ulps off the line of two others would leave an arc of no length)."""
    if len(H) <= 2:
        return H
    keep = []
    for i in range(len(H)):
        a, b = H[i] - H[i - 1], H[(i + 1) % len(H)] - H[i]
        sin = (a[0] * b[1] - a[1] * b[0]) / (math.hypot(*a) * math.hypot(*b))
        if not (abs(sin) < 1e-12 and a @ b > 0):
            keep.append(i)
    return H[keep]


def plate(centres: np.ndarray, r: float) -> Shape:
    """The outline of a plate of width 2 r around the points centres (n, 2): the convex hull of
    the circles of radius r about them, as one closed polyline of arcs (radius r, about the hull's
    vertices) and the lines tangent to two of them. Two points: a capsule (two half circles and
    two lines); one: a circle."""
    H = _straight_vertices(convex_hull(centres))
    if len(H) == 1:
        return circle(H[0], r, OUTLINE)
    verts, bulges = [], []
    m = len(H)
    for i in range(m):
        p, e_in, e_out = H[i], H[i] - H[i - 1], H[(i + 1) % m] - H[i]
        n_in = np.array([e_in[1], -e_in[0]]) / math.hypot(*e_in)        # outward: right side
        n_out = np.array([e_out[1], -e_out[0]]) / math.hypot(*e_out)
        sweep = math.atan2(e_in[0] * e_out[1] - e_in[1] * e_out[0], e_in @ e_out)
        if sweep <= 0.0:            # two points: back along the same line, a half turn left
            sweep += 2.0 * math.pi
        verts += [p + r * n_in, p + r * n_out]
        bulges += [math.tan(sweep / 4.0), 0.0]
    return Shape("poly", OUTLINE, np.array(verts), np.array(bulges), closed=True)


# -- arcs -------------------------------------------------------------------------------------

def arc_of(p0, p1, b: float):
    """(centre (2,), radius, sweep) of the arc from p0 to p1 with bulge b != 0."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    d = p1 - p0
    c = math.hypot(*d)
    sweep = 4.0 * math.atan(b)
    r = c * (1.0 + b * b) / (4.0 * abs(b))
    n = np.array([-d[1], d[0]]) / c                      # left of the chord
    centre = (p0 + p1) / 2.0 + n * (c / 2.0) * (1.0 - b * b) / (2.0 * b)
    return centre, r, sweep


def segments(s: Shape):
    """(p0, p1, bulge) of every segment of a polyline, the closing one included."""
    P, B = s.points, s.bulges
    n = len(P)
    for k in range(n if s.closed else n - 1):
        yield P[k], P[(k + 1) % n], float(B[k])


def sample(s: Shape, step: float) -> np.ndarray:
    """Points (m, 2) along a shape (poly or circle) at most `step` mm apart, ends included."""
    if s.kind == "circle":
        n = max(int(math.ceil(2 * math.pi * s.r / step)), 8)
        a = np.linspace(0.0, 2 * math.pi, n + 1)
        return s.points[0] + s.r * np.c_[np.cos(a), np.sin(a)]
    if s.kind == "line":
        return s.points.copy()
    out = [s.points[:1]]
    for p0, p1, b in segments(s):
        if b == 0.0:
            n = max(int(math.ceil(math.hypot(*(p1 - p0)) / step)), 1)
            t = np.linspace(0.0, 1.0, n + 1)[1:, None]
            out.append(p0 + t * (p1 - p0))
        else:
            c, r, sweep = arc_of(p0, p1, b)
            n = max(int(math.ceil(abs(sweep) * r / step)), 2)
            a0 = math.atan2(*(p0 - c)[::-1])
            a = a0 + np.linspace(0.0, sweep, n + 1)[1:]
            pts = c + r * np.c_[np.cos(a), np.sin(a)]
            pts[-1] = p1
            out.append(pts)
    return np.vstack(out)


def _extent(s: Shape) -> tuple:
    """(xmin, ymin, xmax, ymax) of one shape, exact for arcs (their ends and the quadrant points
    they pass)."""
    if s.kind == "circle":
        (x, y), r = s.points[0], s.r
        return x - r, y - r, x + r, y + r
    pts = [s.points]
    if s.kind == "poly":
        for p0, p1, b in segments(s):
            if b == 0.0:
                continue
            c, r, sweep = arc_of(p0, p1, b)
            a0 = math.atan2(*(p0 - c)[::-1])
            for k in range(4):                            # 0, 90, 180, 270 degrees
                q = k * math.pi / 2.0
                rel = ((q - a0) if sweep > 0 else (a0 - q)) % (2.0 * math.pi)
                if rel <= abs(sweep):
                    pts.append((c + r * np.array([math.cos(q), math.sin(q)]))[None, :])
    P = np.vstack(pts)
    return P[:, 0].min(), P[:, 1].min(), P[:, 0].max(), P[:, 1].max()


def extent(shapes) -> tuple:
    """(xmin, ymin, xmax, ymax) of shapes."""
    E = np.array([_extent(s) for s in shapes])
    return E[:, 0].min(), E[:, 1].min(), E[:, 2].max(), E[:, 3].max()


def moved(s: Shape, angle: float, offset) -> Shape:
    """s turned by angle (rad) about the origin, then moved by offset (mm): a rigid motion keeps
    every bulge."""
    c, sn = math.cos(angle), math.sin(angle)
    A = np.array([[c, -sn], [sn, c]])
    P = s.points @ A.T + np.asarray(offset, float)
    return Shape(s.kind, s.layer, P, s.bulges, s.closed, s.r)


def placed_points(P: np.ndarray, angle: float, offset) -> np.ndarray:
    """Points P (n, 2) turned by angle about the origin, then moved by offset: as `moved`."""
    c, sn = math.cos(angle), math.sin(angle)
    return np.asarray(P, float) @ np.array([[c, -sn], [sn, c]]).T + np.asarray(offset, float)


# -- distances --------------------------------------------------------------------------------

def distance_to_polyline(Q: np.ndarray, P: np.ndarray) -> np.ndarray:
    """(m,) distance of each point of Q (m, 2) to the polyline through P (n, 2) (n >= 2),
    segment by segment, in blocks (memory m x block)."""
    Q = np.asarray(Q, float)
    A, B = P[:-1], P[1:]
    D = B - A
    L2 = np.maximum(np.einsum("ij,ij->i", D, D), 1e-300)
    out = np.full(len(Q), np.inf)
    block = max(1, 2_000_000 // max(len(Q), 1))
    for k in range(0, len(A), block):
        a, d, l2 = A[k:k + block], D[k:k + block], L2[k:k + block]
        rel = Q[:, None, :] - a[None, :, :]
        t = np.clip(np.einsum("mkj,kj->mk", rel, d) / l2, 0.0, 1.0)
        gap = rel - t[..., None] * d[None, :, :]
        out = np.minimum(out, np.sqrt(np.einsum("mkj,mkj->mk", gap, gap)).min(axis=1))
    return out
