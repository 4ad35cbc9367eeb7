"""Curves that are exact where engineers draw them exactly: straight lines and circular arcs.

A slot or a track is usually drawn as a circle, or as lines and arcs joined tangentially. Given
so (``curve: {circle: ...}`` or ``curve: {segments: [...]}``), the curve of a curve-slot is that
geometry itself, not a spline through samples of it: positions, tangents, curvatures and their
derivatives are closed forms, and the closest point of a pin is found in closed form too (a dot
product on a line, an angle on an arc). A pin in a circular slot then moves exactly as a pin on
a link to the circle's centre (to rounding), where the best spline of a circle is off by its
interpolation error in curvature (see the README, "Curves for curve-slot").

`PathCurve` has the interface of `curve.Curve` that `curve.CurveSlot` uses: eval, third,
project, scaled, closed, a0, a1; the parameter alpha is the arc length from the first segment's start.
Where a line meets an arc the curvature jumps (so does the pin's acceleration, as in the real
slot); tangents must agree at every joint (checked when the curve is built from YAML).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class Line:
    """A straight segment from p0 to p1 (2-tuples; internal units once compiled)."""

    p0: tuple
    p1: tuple

    @property
    def length(self) -> float:
        return math.hypot(self.p1[0] - self.p0[0], self.p1[1] - self.p0[1])

    def ends(self):
        """(start point, start unit tangent, end point, end unit tangent)."""
        L = self.length
        u = ((self.p1[0] - self.p0[0]) / L, (self.p1[1] - self.p0[1]) / L)
        return self.p0, u, self.p1, u

    def scaled(self, factor: float, angle: float) -> "Line":
        return Line((self.p0[0] * factor, self.p0[1] * factor),
                    (self.p1[0] * factor, self.p1[1] * factor))

    def eval(self, u, order: int):
        """Derivatives 0..order with respect to arc length at local arc lengths u (n,)."""
        L = self.length
        tx, ty = (self.p1[0] - self.p0[0]) / L, (self.p1[1] - self.p0[1]) / L
        out = [np.stack([self.p0[0] + u * tx, self.p0[1] + u * ty], axis=-1),
               np.broadcast_to([tx, ty], u.shape + (2,)).copy()]
        out += [np.zeros(u.shape + (2,)) for _ in range(order - 1)]
        return out

    def closest(self, p):
        """Local arc length (n,) of the closest points of p (n, 2) on the segment."""
        L = self.length
        tx, ty = (self.p1[0] - self.p0[0]) / L, (self.p1[1] - self.p0[1]) / L
        return np.clip((p[:, 0] - self.p0[0]) * tx + (p[:, 1] - self.p0[1]) * ty, 0.0, L)


@dataclass(frozen=True)
class Arc:
    """A circular arc about centre of radius r from angle a (rad, seen from the centre) to angle
    b: counter-clockwise when b > a, clockwise when b < a; |b - a| <= 2 pi."""

    centre: tuple
    r: float
    a: float
    b: float

    @property
    def sense(self) -> float:
        return 1.0 if self.b > self.a else -1.0

    @property
    def length(self) -> float:
        return self.r * abs(self.b - self.a)

    def ends(self):
        (x0, y0), s = self.centre, self.sense
        p = lambda t: (x0 + self.r * math.cos(t), y0 + self.r * math.sin(t))
        tan = lambda t: (-s * math.sin(t), s * math.cos(t))
        return p(self.a), tan(self.a), p(self.b), tan(self.b)

    def scaled(self, factor: float, angle: float) -> "Arc":
        return Arc((self.centre[0] * factor, self.centre[1] * factor), self.r * factor,
                   self.a * angle, self.b * angle)

    def eval(self, u, order: int):
        """Derivatives 0..order with respect to arc length at local arc lengths u (n,): with
        t = a + s u / r (s the sense) and e(t) = (cos t, sin t), c = C + r e(t) and
        c^(m) = r (s / r)^m e^(m)(t), each derivative of e turning it by +90 degrees."""
        s, r = self.sense, self.r
        t = self.a + s * u / r
        ct, st = np.cos(t), np.sin(t)
        # e(t) = (cos, sin) and its derivatives cycle through (-sin, cos), (-cos, -sin), (sin, -cos)
        cyc = [(ct, st), (-st, ct), (-ct, -st), (st, -ct)]
        out = [np.stack([self.centre[0] + r * ct, self.centre[1] + r * st], axis=-1)]
        for m in range(1, order + 1):
            f = r * (s / r) ** m
            ex, ey = cyc[m % 4]
            out.append(np.stack([f * ex, f * ey], axis=-1))
        return out

    def closest(self, p):
        """Local arc length (n,) of the closest points of p (n, 2) on the arc (an end when the
        radial projection falls outside it; the nearer end by angle)."""
        span = abs(self.b - self.a)
        phi = np.arctan2(p[:, 1] - self.centre[1], p[:, 0] - self.centre[0])
        u = np.mod(self.sense * (phi - self.a), TWO_PI)        # angle travelled from a
        if span >= TWO_PI:
            return u * self.r
        beyond = u > span
        to_end = np.where(u - span < TWO_PI - u, span, 0.0)     # nearer end by angle
        return np.where(beyond, to_end, u) * self.r


class PathCurve:
    """A chain of `Line` and `Arc` segments (internal units, body frame), joined end to start
    (tangentially, checked by `joints`); closed when the last ends where the first starts."""

    def __init__(self, segments, closed: bool):
        self.segments = tuple(segments)
        self.closed = bool(closed)
        lengths = np.array([s.length for s in self.segments])
        self.starts = np.concatenate([[0.0], np.cumsum(lengths)])
        self.a0, self.a1 = 0.0, float(self.starts[-1])

    def scaled(self, factor: float, angle: float = 1.0) -> "PathCurve":
        """The same curve with lengths times factor and arc angles times angle (user units to
        internal: factor = 1/L, angle = radians per user angle unit)."""
        return PathCurve([s.scaled(factor, angle) for s in self.segments], self.closed)

    def problems(self, L: float, unit: str) -> list[str]:
        """Arcs too small for the model's scale L (this curve in internal units): their
        curvature derivatives 1/r^m would overflow or swamp everything else."""
        out = []
        for k, seg in enumerate(self.segments, start=1):
            if isinstance(seg, Arc) and not seg.r > 1e-9:
                what = "circle" if len(self.segments) == 1 and self.closed else f"segment {k}"
                out.append(f"curve: {what}: the arc's radius {seg.r * L:.3g} {unit} is too "
                           f"small for a model of size {L:.3g} {unit} (at least 1e-9 of it)")
        return out

    def _locate(self, a):
        a = np.asarray(a, dtype=float)
        if self.closed:
            a = np.mod(a, self.a1)
        m = np.clip(np.searchsorted(self.starts, a, side="right") - 1, 0, len(self.segments) - 1)
        return a, m

    def eval(self, a, order: int = 2):
        """c, c', ..., c^(order) (derivatives in arc length) at parameters a (n,): (n, 2) arrays
        (three by default, as curve.Curve.eval)."""
        a, m = self._locate(a)
        out = [np.empty(a.shape + (2,)) for _ in range(order + 1)]
        for k in np.unique(m):
            sel = m == k
            for o, v in enumerate(self.segments[k].eval(a[sel] - self.starts[k], order)):
                out[o][sel] = v
        return tuple(out)

    def third(self, a):
        """The third derivative c'(3) at parameters a (n,): (n, 2) (the jerk of a pin)."""
        return self.eval(a, 3)[3]

    def project(self, p):
        """Closest points of p (n, 2), as curve.Curve.project: (alpha (n,), c, c', c'' (n, 2),
        off (n,) bool: the closest point is an end of an open curve)."""
        p = np.asarray(p, dtype=float)
        best = np.full(len(p), np.inf)
        alpha = np.zeros(len(p))
        for k, seg in enumerate(self.segments):
            u = seg.closest(p)
            c = seg.eval(u, 0)[0]
            d2 = ((p - c) ** 2).sum(axis=1)
            better = d2 < best
            best = np.where(better, d2, best)
            alpha = np.where(better, self.starts[k] + u, alpha)
        c, c1, c2 = self.eval(alpha)
        off = np.zeros(len(p), bool) if self.closed else (alpha <= self.a0) | (alpha >= self.a1)
        return alpha, c, c1, c2, off

    def __repr__(self) -> str:
        kinds = ", ".join(type(s).__name__.lower() for s in self.segments)
        return f"PathCurve([{kinds}], {'closed' if self.closed else 'open'})"


def joints(segments, scale: float) -> tuple:
    """Whether a chain (user units, angles in radians) closes, and its problems: (closed, [(j,
    message)]) for joints where segment j does not start where the one before ends (a gap
    larger than 1e-10 * scale) or the tangent turns there (a corner, more than 1e-10 rad).
    The chain is closed when the last segment ends within that gap of the first one's start;
    the joint there must then be tangent too."""
    tol = 1e-10 * scale
    problems = []
    for k in range(len(segments) - 1):
        _, _, e, te = segments[k].ends()
        s, ts, _, _ = segments[k + 1].ends()
        problems += _joint(k + 1, k + 2, e, te, s, ts, tol)
    first, tf, _, _ = segments[0].ends()
    _, _, last, tl = segments[-1].ends()
    closed = math.hypot(last[0] - first[0], last[1] - first[1]) <= tol
    if closed:
        problems += _joint(len(segments), 1, last, tl, first, tf, tol)
    return closed, problems


def _joint(k, j, e, te, s, ts, tol):
    gap = math.hypot(s[0] - e[0], s[1] - e[1])
    if gap > tol:
        return [(j, f"segment {j} starts at [{s[0]:.6g}, {s[1]:.6g}], {gap:.3g} away from the "
                    f"end of segment {k} at [{e[0]:.6g}, {e[1]:.6g}]; segments must join end to "
                    f"start")]
    turn = math.atan2(te[0] * ts[1] - te[1] * ts[0], te[0] * ts[0] + te[1] * ts[1])
    if abs(turn) > 1e-10:
        return [(j, f"segments {k} and {j} meet at a corner (the tangent turns by "
                    f"{math.degrees(turn):.4g} deg); join them tangentially (a pin cannot "
                    f"follow a corner smoothly; round it with an arc)")]
    return []
