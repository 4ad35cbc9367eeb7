"""A smooth plane curve as circular arcs within a stated chordal tolerance: biarcs fitted greedily
to the exact curve, every fit checked against it.

The curve is a function c(theta) (mm) that can be evaluated anywhere in its range (a cam's
profile, computed exactly from its law). It is sampled on a uniform grid fine enough that the
polyline through the samples and their midpoints is within tol / 64 of the curve (the largest
midpoint sagitta, measured); the tangents at the grid points are central differences of those
samples. Between two grid points a biarc (two arcs meeting with a common tangent, ending on the
exact tangents: the equal-chord biarc) is accepted when

- every sample between them (grid points and midpoints) lies within 15/16 tol of the biarc
  (exact distances to the arcs), and
- every point of the biarc, sampled as finely as the curve, lies within 15/16 tol of the
  samples' polyline (the distance to the two segments about its nearest sample: an upper bound),

so the Hausdorff distance between the arcs and the curve is within tol. From each grid point the
fit takes the farthest grid point that passes (doubling, then bisection); a span of one grid step
always has a fit (a straight line is within the sagitta). Consecutive biarcs share their end
tangents: the chain is tangent-continuous wherever the curve is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

ACCEPT = 15.0 / 16.0     # of tol: what a fit may use; the rest covers the sampling
SAGITTA = 1.0 / 64.0     # of tol: the samples' polyline is this close to the curve
MAX_INTERVALS = 2 ** 20


class CurveError(ValueError):
    """The curve cannot be sampled finely enough (a cusp, a NaN: its law outside its domain)."""


@dataclass(frozen=True)
class Fit:
    """The arcs of a fitted curve: vertices (n, 2) mm and bulges (n,) of a polyline (DXF's
    LWPOLYLINE; closed: the last segment returns to the first vertex), max_deviation: the
    largest distance found by the checks (mm), samples: the check points used."""

    vertices: np.ndarray
    bulges: np.ndarray
    closed: bool
    tolerance: float
    max_deviation: float
    samples: int

    @property
    def arcs(self) -> int:
        return int(np.count_nonzero(self.bulges))


def _sample(curve, lo: float, hi: float, tol: float):
    """The check points S (2n + 1, 2): grid points at even indices, midpoints at odd ones."""
    n = 256
    while True:
        th = np.linspace(lo, hi, 2 * n + 1)
        S = np.asarray(curve(th), float)
        if not np.isfinite(S).all():
            raise CurveError(f"the curve is not defined at theta = {th[~np.isfinite(S).all(1)][0]}")
        P, M = S[0::2], S[1::2]
        sag = np.hypot(*(M - (P[:-1] + P[1:]) / 2.0).T).max()
        if sag <= SAGITTA * tol:
            return th, S
        if n >= MAX_INTERVALS:
            raise CurveError(f"{2 * n} samples are still {sag:.3g} mm off their chords")
        n *= 2


def _tangents(S: np.ndarray, closed: bool) -> np.ndarray:
    """Unit tangents (n + 1, 2) at the grid points S[0::2]: central differences over the
    midpoints on either side; at the ends of an open curve one-sided (second order)."""
    T = np.empty((len(S) // 2 + 1, 2))
    T[1:-1] = S[3::2] - S[1:-2:2]
    if closed:
        T[0] = T[-1] = S[1] - S[-2]
    else:
        T[0] = -3 * S[0] + 4 * S[1] - S[2]
        T[-1] = 3 * S[-1] - 4 * S[-2] + S[-3]
    norm = np.hypot(T[:, 0], T[:, 1])
    if not (norm > 0).all():
        raise CurveError("the curve stops (zero speed): it has a cusp")
    return T / norm[:, None]


def _angle(u, v) -> float:
    """Signed angle from u to v (rad)."""
    return math.atan2(u[0] * v[1] - u[1] * v[0], u[0] * v[0] + u[1] * v[1])


def biarc(p0, t0, p1, t1):
    """The equal-chord biarc from p0 (unit tangent t0) to p1 (tangent t1): (joint point,
    bulge of the first arc, bulge of the second), or None when it does not exist (the tangents
    point against the chord)."""
    v = p1 - p0
    t = t0 + t1
    vt, vv = v @ t, v @ v
    a = 2.0 * (1.0 - t0 @ t1)
    root = vt * vt + a * vv
    if root < 0 or vv == 0:
        return None
    den = vt + math.sqrt(root)       # d = (-vt + sqrt(root)) / a, without the cancellation
    if not den > 0:
        return None
    d = vv / den
    pm = (p0 + d * t0 + p1 - d * t1) / 2.0
    b1 = math.tan(_angle(t0, pm - p0) / 2.0)
    b2 = math.tan(_angle(p1 - pm, t1) / 2.0)
    return pm, b1, b2


def distance_to_segment(Q: np.ndarray, p0, p1, b: float) -> np.ndarray:
    """(m,) exact distance of the points Q (m, 2) to the segment from p0 to p1 with bulge b."""
    if b == 0.0:
        d = p1 - p0
        t = np.clip(((Q - p0) @ d) / max(d @ d, 1e-300), 0.0, 1.0)
        return np.hypot(*(Q - p0 - t[:, None] * d).T)
    d = p1 - p0
    c = math.hypot(*d)
    sweep = 4.0 * math.atan(b)
    r = c * (1.0 + b * b) / (4.0 * abs(b))
    centre = (p0 + p1) / 2.0 + np.array([-d[1], d[0]]) / c * (c / 2.0) * (1 - b * b) / (2 * b)
    rel = Q - centre
    a0 = math.atan2(p0[1] - centre[1], p0[0] - centre[0])
    aq = np.arctan2(rel[:, 1], rel[:, 0])
    along = ((aq - a0) * math.copysign(1.0, sweep)) % (2.0 * math.pi)
    on_arc = np.abs(np.hypot(rel[:, 0], rel[:, 1]) - r)
    ends = np.minimum(np.hypot(*(Q - p0).T), np.hypot(*(Q - p1).T))
    return np.where(along <= abs(sweep), on_arc, ends)


def _points_on(p0, p1, b: float, n: int) -> np.ndarray:
    """n + 1 points of the segment, ends included."""
    s = np.linspace(0.0, 1.0, n + 1)[:, None]
    if b == 0.0:
        return p0 + s * (p1 - p0)
    d = p1 - p0
    c = math.hypot(*d)
    sweep = 4.0 * math.atan(b)
    r = c * (1.0 + b * b) / (4.0 * abs(b))
    centre = (p0 + p1) / 2.0 + np.array([-d[1], d[0]]) / c * (c / 2.0) * (1 - b * b) / (2 * b)
    a = math.atan2(p0[1] - centre[1], p0[0] - centre[0]) + sweep * s[:, 0]
    return centre + r * np.c_[np.cos(a), np.sin(a)]


class _Checker:
    """The two checks of a candidate (module docstring) against the samples S."""

    def __init__(self, S: np.ndarray):
        from scipy.spatial import cKDTree
        self.S = S
        self.tree = cKDTree(S)

    def to_polyline(self, Q: np.ndarray) -> np.ndarray:
        """An upper bound of each point's distance to the samples' polyline."""
        S = self.S
        _, i = self.tree.query(Q)
        best = np.full(len(Q), np.inf)
        for lo in (i - 1, i):
            ok = (lo >= 0) & (lo + 1 < len(S))
            a, b = S[np.clip(lo, 0, len(S) - 2)], S[np.clip(lo + 1, 1, len(S) - 1)]
            d = b - a
            t = np.clip(np.einsum("ij,ij->i", Q - a, d) / np.maximum(
                np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
            g = np.hypot(*(Q - a - t[:, None] * d).T)
            best = np.where(ok, np.minimum(best, g), best)
        return best

    def deviation(self, ia: int, ib: int, segs) -> float:
        """The larger of the two checks for the segments segs [(p0, p1, bulge)] replacing the
        samples S[ia..ib]."""
        Q = self.S[ia:ib + 1]
        near = np.min([distance_to_segment(Q, *s) for s in segs], axis=0).max()
        n = max((ib - ia) // len(segs), 2)
        back = max(self.to_polyline(_points_on(*s, n)).max() for s in segs)
        return float(max(near, back))


def fit(curve, lo: float, hi: float, closed: bool, tol: float) -> Fit:
    """Arcs within tol (mm) of the curve c(theta), theta from lo to hi (closed: c(hi) = c(lo),
    the curve goes once around). curve: theta (N,) -> (N, 2) mm."""
    th, S = _sample(curve, lo, hi, tol)
    if closed:
        S[-1] = S[0]
    T = _tangents(S, closed)
    n = len(T) - 1
    check = _Checker(S)
    limit = ACCEPT * tol

    def attempt(a: int, b: int):
        """(segments, deviation) of the biarc over grid points a..b, or None."""
        p0, p1 = S[2 * a], S[2 * b]
        arcs = biarc(p0, T[a], p1, T[b])
        if arcs is None:
            return None
        pm, b1, b2 = arcs
        segs = [(p0, pm, b1), (pm, p1, b2)]
        dev = check.deviation(2 * a, 2 * b, segs)
        return (segs, dev) if dev <= limit else None

    verts, bulges, worst = [], [], 0.0
    a = 0
    while a < n:
        good, step = None, 1
        while a + step <= n:                       # doubling
            got = attempt(a, a + step)
            if got is None:
                break
            good = (a + step, got)
            if a + step == n:
                break
            step *= 2
        if good is None:                           # one grid step: a line is within the sagitta
            seg = (S[2 * a], S[2 * a + 2], 0.0)
            good = (a + 1, ([seg], check.deviation(2 * a, 2 * a + 2, [seg])))
        else:                                      # bisection between the last pass and a fail
            lo_b, hi_b = good[0], min(a + step, n + 1)
            while hi_b - lo_b > 1:
                mid = (lo_b + hi_b) // 2
                got = attempt(a, mid)
                if got is None:
                    hi_b = mid
                else:
                    lo_b, good = mid, (mid, got)
        b, (segs, dev) = good
        for p0, _, bulge in segs:
            verts.append(p0)
            bulges.append(bulge)
        worst = max(worst, dev)
        a = b
    if not closed:
        verts.append(S[-1])
        bulges.append(0.0)
    return Fit(np.array(verts), np.array(bulges), closed, float(tol), worst, len(S))
