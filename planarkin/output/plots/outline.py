"""The link shapes of issue 29 (`planarkin.clearance.shape.Shape`) as the figures draw them:
each shape's boundary as one closed curve in its body's frame, user units, computed once per
figure (the drawings move it with the body, as every other body-fixed vertex). numpy only.

A shape is the set of points within `radius` of a polygon (closed) or a polyline (open); its
boundary is the offset curve: every edge moved out by radius, joined at a convex corner by an arc
about the vertex and at a reflex corner by the two offset edges' intersection. A polyline is
walked there and back, so that its two sides and its two round caps (its ends are U-turns) come
out of the same walk; a single point is a circle, two points a capsule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ARC_STEP = math.radians(4.0)    # arcs sampled at most this far apart: chord sag < 6.1e-4 radius
HOLE_VERTICES = 48              # a hole's circle (sag 2.1e-3 of its radius)


@dataclass(frozen=True)
class Plate:
    """One shape ready to draw, user units. body: the body's index (nb: ground, a frame
    obstacle); name: the shape's name; outline: (m, 2) body-frame vertices of its boundary,
    counter-clockwise, not repeated at the end (a polyline of radius 0: its vertices, drawn as
    a line); filled: whether outline encloses a region; holes: (h, HOLE_VERTICES, 2) body-frame
    circles; level: rank of the shape's layer among the model's layers (0 lowest), for the
    drawing order."""

    body: int
    name: str
    outline: np.ndarray
    filled: bool
    holes: np.ndarray
    level: int = 0


def rounded_outline(points, radius: float, closed: bool = True,
                    step: float = ARC_STEP) -> np.ndarray:
    """(m, 2) boundary of the points within radius of the polygon through points (closed) or of
    the polyline through them (open): offset edges joined by arcs (convex corners, sampled at
    most step radians apart, both ends exact) and by their intersections (reflex corners).
    Counter-clockwise, not repeated at the end. Every vertex is at distance radius from the
    polygon or polyline (at a reflex corner, when its two edges are at least as long as the
    corner's mitre reaches). radius 0: the polygon (counter-clockwise) or the polyline itself."""
    P = _distinct(np.asarray(points, float).reshape(-1, 2), closed)
    r = float(radius)
    if not r > 0:
        if closed and len(P) >= 3 and _signed_area(P) < 0:
            return P[::-1].copy()
        return P
    if len(P) == 1:
        a = np.linspace(0.0, 2 * np.pi, max(8, math.ceil(2 * np.pi / step)), endpoint=False)
        return P[0] + r * np.c_[np.cos(a), np.sin(a)]
    if closed and len(P) >= 3:
        loop = P if _signed_area(P) >= 0 else P[::-1]
    else:
        loop = np.r_[P, P[-2:0:-1]]         # there and back: both sides, a U-turn at each end
    d = np.roll(loop, -1, axis=0) - loop    # edge k runs from vertex k to vertex k+1
    d /= np.hypot(d[:, 0], d[:, 1])[:, None]
    n = np.c_[d[:, 1], -d[:, 0]]            # outward (right-hand) normals of a CCW walk
    out = []
    for k, v in enumerate(loop):
        d0, d1, n0, n1 = d[k - 1], d[k], n[k - 1], n[k]
        cross = d0[0] * d1[1] - d0[1] * d1[0]
        dot = float(d0 @ d1)
        if cross < -1e-12 and 1.0 + dot > 1e-6:     # reflex: the offset edges meet
            out.append(v + r * (n0 + n1) / (1.0 + dot))
        elif abs(cross) <= 1e-12 and dot > 0:       # straight on
            out.append(v + r * n0)
        elif cross < 0:                             # a reflex spike: both edges' ends
            out += [v + r * n0, v + r * n1]
        else:                                       # convex corner or U-turn: an arc
            sweep = math.atan2(cross, dot) if cross > 1e-12 else math.pi
            a0 = math.atan2(n0[1], n0[0])
            # an even number of intervals: the arc's middle is a vertex (a cap's tip is
            # exactly radius beyond its end point)
            m = 2 * max(1, math.ceil(0.5 * sweep / step))
            a = a0 + np.linspace(0.0, sweep, m + 1)
            arc = v + r * np.c_[np.cos(a), np.sin(a)]
            arc[0], arc[-1] = v + r * n0, v + r * n1     # exact ends: on the offset edges
            out += list(arc)
    return np.array(out)


def hole_circles(holes, scale: float) -> np.ndarray:
    """(h, HOLE_VERTICES, 2) circles of the holes ((x, y, diameter), ...), times scale."""
    a = np.linspace(0.0, 2 * np.pi, HOLE_VERTICES, endpoint=False)
    ring = np.c_[np.cos(a), np.sin(a)]
    H = np.asarray(holes, float).reshape(-1, 3) * scale
    return H[:, None, :2] + 0.5 * H[:, None, 2:3] * ring[None]


def plates(cm) -> list:
    """The model's shapes (cm.shapes; none before the model has them) as Plates, in the order
    given, user units (the shapes are in internal length units, as CompiledModel.point_s)."""
    shapes = getattr(cm, "shapes", ()) or ()
    levels = sorted({float(s.layer[0]) for s in shapes})
    out = []
    for s in shapes:
        V = rounded_outline(np.asarray(s.points, float) * cm.L, s.radius * cm.L, s.closed)
        filled = (s.radius > 0 or s.closed) and len(V) >= 3
        out.append(Plate(int(s.body), s.name, V, filled, hole_circles(s.holes, cm.L),
                         levels.index(float(s.layer[0]))))
    return out


def place(V, x: float, y: float, phi: float) -> np.ndarray:
    """(k, 2) world coordinates of body-frame vertices V of a body at pose (x, y, phi rad)."""
    c, s = math.cos(phi), math.sin(phi)
    V = np.asarray(V, float).reshape(-1, 2)
    return np.c_[x + c * V[:, 0] - s * V[:, 1], y + s * V[:, 0] + c * V[:, 1]]


def _distinct(P: np.ndarray, closed: bool) -> np.ndarray:
    """P without consecutive repeats (nor, closed, a last point equal to the first), relative
    1e-12."""
    if len(P) < 2:
        return P
    tol = 1e-12 * max(float(np.abs(P).max()), 1e-300)
    keep = np.r_[True, np.abs(np.diff(P, axis=0)).max(axis=1) > tol]
    P = P[keep]
    if closed and len(P) > 1 and np.abs(P[-1] - P[0]).max() <= tol:
        P = P[:-1]
    return P


def _signed_area(P: np.ndarray) -> float:
    x, y = P[:, 0], P[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
