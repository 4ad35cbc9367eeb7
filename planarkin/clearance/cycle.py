"""Clearance over the cycle: the distance of every pair of shapes that can touch at every grid
row, its exact rate and acceleration, its minimum refined between the rows, and the first
instant a pair comes closer than its limit or a joint leaves its travel range.

clearance.csv (`columns`, `Clearance.table`): ``t [s]``, then ``clearance [L]`` (the smallest
distance of all pairs at the row; its rate and acceleration are the closest pair's), then per
pair ``A|B [L]``, ``A|B.rate [L/s]``, ``A|B.accel [L/s^2]`` (negative: overlapping by that
much), then per limited joint its travel ``J [unit]`` with rate and acceleration (the relative
angle phi_j - phi_i of a revolute, the slide of a translational joint, as measures' joint:).
A column's rate and acceleration follow measures.csv's names, so a study's metric
``min:clearance`` or ``min:crank|wall`` is refined between the rows as run's figures are.

Between two rows the minimum is the root of the distance's rate, found by the measures room's
refinement (planarkin.measures.extremes: the quintic Hermite polynomial through the exact
distance, rate and acceleration at both rows); the closest points at that instant come from
the pose there (each coordinate's quintic through its exact q, q', q''). Where two feature
pairs are equally close (a kink of the distance, not a root of its rate) the minimum is the
interpolant's, which is exact to the interpolation's order only where one pair of features is
the closest at both rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..measures.extremes import extreme, hermite
from .build import pairs as shape_pairs
from .geometry import Motion, Separation, core, separation, signature, stack

SUFFIX = ("", ".rate", ".accel")
PER = ("", "/s", "/s^2")
BISECT = 60                         # halvings of an interval: below rounding of any row's time
MEMO_ROWS = 500_000                 # pair-rows of distances kept for the pass (about 28 MB)


@dataclass(frozen=True)
class Minimum:
    """The closest approach of a pair over a result: a, b the shapes' names (body names where
    the shape is named after its body), t (s) and d (user length unit; negative: overlapping)
    of the refined minimum, pa and pb (2,) the closest points on A and B at t (world, user
    length unit), limit the smallest clearance allowed, distance (N,) the distance at every
    row, contact the first instant (s) the pair comes closer than limit, or None."""

    a: str
    b: str
    t: float
    d: float
    pa: np.ndarray
    pb: np.ndarray
    limit: float
    distance: np.ndarray
    contact: float | None = None


class Clearance:
    """The pairs and limited joints of a compiled model, evaluated on chunks (anything with t,
    q, qd, qdd in user units: a Chunk or a Result)."""

    def __init__(self, cm):
        self.cm = cm
        self.pairs = shape_pairs(cm)
        L = cm.L
        self.cores = [core(np.asarray(s.points) * L, s.radius * L, s.closed) for s in cm.shapes]
        spec = cm.spec.clearance
        self.limits = tuple(spec.limits) if spec is not None else ()
        self.on_contact = spec.on_contact if spec is not None else "warning"
        self._memo: list | None = None      # [(q, t, separations)] of the pass so far

    def __bool__(self) -> bool:
        return bool(self.pairs or self.limits)

    # -- kinematics --------------------------------------------------------------------------
    def motions(self, ch) -> dict:
        """body index -> Motion (user lengths, radians) of the bodies that carry a shape."""
        cm, af = self.cm, self.cm.angle_factor
        N = len(ch.t)
        out = {}
        for b in {s.body for s in cm.shapes}:
            if b == cm.nb:
                z2, z = np.zeros((N, 2)), np.zeros(N)
                out[b] = Motion(z2, z, z2, z, z2, z)
                continue
            c = 3 * b

            def get(X, k):
                return None if X is None else X[:, c + k]
            v = None if ch.qd is None else ch.qd[:, c:c + 2]
            a = None if ch.qdd is None else ch.qdd[:, c:c + 2]
            out[b] = Motion(ch.q[:, c:c + 2], ch.q[:, c + 2] * af, v,
                            None if ch.qd is None else get(ch.qd, 2) * af, a,
                            None if ch.qdd is None else get(ch.qdd, 2) * af)
        return out

    def separations(self, ch) -> list:
        """[Separation] per pair over chunk ch (the last chunk's are kept: the row check and
        the table share them)."""
        hit = self._recall(ch)
        if hit is not None:
            return hit
        M = self.motions(ch)
        N = len(ch.t)
        out: list = [None] * len(self.pairs)
        # pairs of alike shapes are measured together: one pass of array operations over
        # (pairs x rows), not one per pair (benchmarks/bench_clearance.py)
        for idx, A, B, MA, MB in self._groups(M, N):
            s = separation(A, MA, B, MB)
            for g, k in enumerate(idx):
                sl = slice(g * N, (g + 1) * N)
                out[k] = Separation(s.d[sl], None if s.d1 is None else s.d1[sl],
                                    None if s.d2 is None else s.d2[sl], s.pa[sl], s.pb[sl])
        self._remember(ch, out)
        return out

    def _recall(self, ch):
        """The separations of rows seen before: the last chunk's (the run's table after its
        check), or of every chunk of the pass so far at once (solve()'s result written after
        its chunks were checked); compared by value (a copy is cheaper than the distances)."""
        memo = self._memo or []
        N = len(ch.t)
        for part in (memo[-1:], memo):
            if not part or sum(len(m[1]) for m in part) != N:
                continue
            t = np.concatenate([m[1] for m in part]) if len(part) > 1 else part[0][1]
            if not np.array_equal(t, ch.t):
                continue
            q = np.concatenate([m[0] for m in part]) if len(part) > 1 else part[0][0]
            if not np.array_equal(q, ch.q):
                continue
            if len(part) == 1:
                return part[0][2]
            return [Separation(*(None if any(getattr(m[2][k], f) is None for m in part) else
                                 np.concatenate([getattr(m[2][k], f) for m in part])
                                 for f in ("d", "d1", "d2", "pa", "pb")))
                    for k in range(len(self.pairs))]
        return None

    def _remember(self, ch, out) -> None:
        memo = self._memo or []
        rows = sum(len(m[1]) for m in memo)
        if memo and len(ch.t) and ch.t[0] > memo[-1][1][-1] and \
                (rows + len(ch.t)) * max(len(self.pairs), 1) <= MEMO_ROWS:
            memo.append((np.array(ch.q), np.array(ch.t), out))
        else:
            memo = [(np.array(ch.q), np.array(ch.t), out)]
        self._memo = memo

    def _groups(self, M, N):
        """(pair indices, stacked cores of A and B, stacked motions) per group of pairs whose
        shapes are alike (geometry.signature)."""
        shapes = self.cm.shapes
        groups: dict = {}
        for k, p in enumerate(self.pairs):
            key = (signature(self.cores[p.a]), signature(self.cores[p.b]))
            groups.setdefault(key, []).append(k)
        for idx in groups.values():
            ps = [self.pairs[k] for k in idx]
            if len(idx) == 1:
                p = ps[0]
                yield idx, self.cores[p.a], self.cores[p.b], M[shapes[p.a].body], \
                    M[shapes[p.b].body]
                continue
            A = stack([self.cores[p.a] for p in ps], N)
            B = stack([self.cores[p.b] for p in ps], N)
            yield idx, A, B, _joined_motion([M[shapes[p.a].body] for p in ps]), \
                _joined_motion([M[shapes[p.b].body] for p in ps])

    def travel(self, ch) -> list:
        """[(value, rate, accel)] per limited joint (user units; rate/accel None above the
        chunk's order)."""
        if not self.limits:
            return []
        from ..measures import evaluate
        from ..measures.units import MeasureSpec
        rows = ch
        if ch.qd is None or ch.qdd is None:
            # the formulas take q' and q''; the columns that would need the missing ones are
            # left out of the table (as measures.csv's)
            z = np.zeros_like(ch.q)
            rows = Rows(ch.t, ch.q, ch.qd if ch.qd is not None else z, z)
        out = []
        for lim in self.limits:
            val = evaluate(self.cm, rows, MeasureSpec(lim.joint, "joint", (lim.joint,), lim.line),
                           {})
            out.append((val[0], None if ch.qd is None else val[1],
                        None if ch.qdd is None else val[2]))
        return out

    # -- the table ---------------------------------------------------------------------------
    def columns(self, order: int) -> list[str]:
        cm = self.cm
        lu, au = cm.spec.length_unit, cm.spec.angle_unit
        k = min(order, 2) + 1
        head = ["t [s]"]
        if self.pairs:
            head += [f"clearance{SUFFIX[d]} [{lu}{PER[d]}]" for d in range(k)]
        for p in self.pairs:
            head += [f"{p.name}{SUFFIX[d]} [{lu}{PER[d]}]" for d in range(k)]
        for lim in self.limits:
            u = au if lim.kind == "revolute" else lu
            head += [f"{lim.joint}{SUFFIX[d]} [{u}{PER[d]}]" for d in range(k)]
        return head

    def table(self, ch, order: int) -> np.ndarray:
        """(N, columns) clearance.csv rows of chunk ch."""
        k = min(order, 2) + 1
        N = len(ch.t)
        cols = [np.asarray(ch.t, dtype=float)]
        seps = self.separations(ch) if self.pairs else []
        if seps:
            D = np.stack([s.d for s in seps], axis=1)
            j = np.argmin(D, axis=1)
            rows = np.arange(N)
            cols.append(D[rows, j])
            for attr in ("d1", "d2")[:k - 1]:
                X = np.stack([_or_nan(getattr(s, attr), N) for s in seps], axis=1)
                cols.append(X[rows, j])
        for s in seps:
            cols += [s.d, _or_nan(s.d1, N), _or_nan(s.d2, N)][:k]
        for val in self.travel(ch):
            cols += [val[0], _or_nan(val[1], N), _or_nan(val[2], N)][:k]
        return np.column_stack(cols) if N else np.zeros((0, len(cols)))

    # -- the closest approach ----------------------------------------------------------------
    def closest(self, ch, p, t: float):
        """(d, pa, pb) of pair p at time t in [ch.t[0], ch.t[-1]]: the pose there interpolated
        between the rows around it (quintic through q, q', q''; at a row: the row's)."""
        T = np.asarray(ch.t, dtype=float)
        j = int(np.clip(np.searchsorted(T, t, side="right") - 1, 0, max(len(T) - 2, 0)))
        one = _at(ch, j, t)
        s = separation(self.cores[p.a], self.motions(one)[self.cm.shapes[p.a].body],
                       self.cores[p.b], self.motions(one)[self.cm.shapes[p.b].body])
        return float(s.d[0]), s.pa[0].copy(), s.pb[0].copy()


def _joined_motion(ms: list) -> Motion:
    """The motions one after the other, as the rows of one Motion (each body's cos and sin
    computed once)."""
    for m in ms:
        m.turn()

    def cat(name):
        parts = [getattr(m, name) for m in ms]
        return None if any(x is None for x in parts) else np.concatenate(parts)
    return Motion(cat("r"), cat("phi"), cat("v"), cat("w"), cat("a"), cat("al"), cat("cos"),
                  cat("sin"))


class Rows:
    """t, q, qd, qdd arrays: a chunk's kinematics alone."""

    def __init__(self, t, q, qd, qdd):
        self.t, self.q, self.qd, self.qdd = t, q, qd, qdd
        self.qddd = None


def _or_nan(x, N):
    return np.full(N, np.nan) if x is None else x


def _at(ch, j: int, t: float):
    """A one-row chunk at time t between rows j and j + 1 of ch (at a row: that row)."""
    T = np.asarray(ch.t, dtype=float)
    if len(T) == 1 or t == T[j] or ch.qd is None:
        k = j if (len(T) == 1 or abs(t - T[j]) <= abs(t - T[min(j + 1, len(T) - 1)])) \
            else j + 1
        sl = slice(k, k + 1)
        return Rows(T[sl], ch.q[sl], None if ch.qd is None else ch.qd[sl],
                     None if ch.qdd is None else ch.qdd[sl])
    h = T[j + 1] - T[j]
    s = (t - T[j]) / h
    acc = ch.qdd if ch.qdd is not None else np.full_like(ch.q, np.nan)
    args = (ch.q[j], ch.qd[j], acc[j], ch.q[j + 1], ch.qd[j + 1], acc[j + 1])
    q = hermite(s, h, *args)
    return Rows(np.array([t]), q[None, :], None, None)


def refined_minimum(t, d, d1=None, d2=None):
    """(time, value) of the smallest distance of columns d (N,) at times t, refined between
    the rows from the exact rate d1 and acceleration d2 (planarkin.measures.extremes)."""
    if d1 is not None and not np.isfinite(d1).any():
        d1 = None
    tm, dm = extreme(t, d, d1, d2, sense=-1.0)
    return float(tm), float(dm)


def first_below(t, y, y1, y2, limit: float, value_at=None):
    """The first instant (s) column y (N,) at times t falls below limit, or None: the first row
    below it, or, before that, a dip between two rows (a refined local minimum below it), the
    instant found on the interval's quintic (bisection: y is above the limit at the interval's
    start and below it at the instant sought). Where the interval's end has no rate (two
    outlines overlap there: their distance has no derivative) the bisection evaluates
    value_at(t), the column at the pose interpolated between the rows (the signed distance is
    continuous), when given; else the instant is the row's."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    below = y < limit
    first = int(np.argmax(below)) if below.any() else len(y)
    if first == 0:
        return float(t[0]) if len(y) else None
    cand = None
    if y1 is not None and first > 1:
        v = np.asarray(y1[:first], dtype=float)
        js = np.flatnonzero((v[:-1] < 0) & (v[1:] > 0))
        if len(js):
            # only a dip that can reach the limit: the interval's interpolant falls below the
            # smaller end by at most h (|y0'| + |y1'|) + h^2 (|y0''| + |y1''|) (as in extremes)
            h = t[js + 1] - t[js]
            reach = h * (np.abs(v[js]) + np.abs(v[js + 1]))
            if y2 is not None:
                a_ = np.asarray(y2, dtype=float)
                reach = reach + np.where(np.isfinite(a_[js]) & np.isfinite(a_[js + 1]),
                                         h * h * (np.abs(a_[js]) + np.abs(a_[js + 1])), 0.0)
            js = js[np.minimum(y[js], y[js + 1]) - reach < limit]
        if len(js):
            a = None if y2 is None else np.asarray(y2, dtype=float)
            T2 = np.stack([t[js], t[js + 1]], axis=1)
            Y2 = np.stack([y[js], y[js + 1]], axis=1)
            V2 = np.stack([v[js], v[js + 1]], axis=1)
            A2 = None if a is None else np.stack([a[js], a[js + 1]], axis=1)
            tm, ym = extreme(T2, Y2, V2, A2, sense=-1.0)
            hit = np.flatnonzero(ym < limit)
            if len(hit):
                cand = (int(js[hit[0]]), float(tm[hit[0]]))
    if cand is None:
        if first == len(y):
            return None
        j, t_end = first - 1, float(t[first])
    else:
        j, t_end = cand
    if y1 is None:
        return t_end
    h = t[j + 1] - t[j]
    a0 = np.nan if y2 is None else y2[j]
    a1 = np.nan if y2 is None else y2[j + 1]
    smooth = np.isfinite(y1[j]) and np.isfinite(y1[j + 1])
    if not smooth and value_at is None:
        return t_end
    lo, hi = 0.0, (t_end - t[j]) / h
    for _ in range(BISECT):
        mid = 0.5 * (lo + hi)
        v = hermite(mid, h, y[j], y1[j], a0, y[j + 1], y1[j + 1], a1) if smooth else \
            value_at(float(t[j] + mid * h))
        if float(v) < limit:
            hi = mid
        else:
            lo = mid
    return float(t[j] + hi * h)


def minima(cm, result, C: Clearance | None = None) -> list[Minimum]:
    """The closest approach of every pair of shapes that can touch, over a result (a
    planarkin.results.Result, or a chunk: t, q, qd, qdd in user units): one Minimum per pair
    (see Minimum), in pair order (planarkin.clearance.build.pairs). [] for a model without
    pairs or a result without rows. C: the model's Clearance when the caller has it."""
    C = Clearance(cm) if C is None else C
    if not C.pairs or not len(result.t):
        return []
    out = []
    shapes = cm.shapes
    for p, s in zip(C.pairs, C.separations(result)):
        t, d = refined_minimum(result.t, s.d, s.d1, s.d2)
        d_at, pa, pb = C.closest(result, p, t)
        contact = first_below(result.t, s.d, s.d1, s.d2, p.limit,
                              lambda tt, p=p: C.closest(result, p, tt)[0])
        out.append(Minimum(shapes[p.a].name, shapes[p.b].name, t, d, pa, pb, p.limit,
                           s.d.copy(), contact))
    return out


def least_margin(cm, result):
    """(margin, pair) of the pair nearest its limit over a result: the smallest refined
    distance less the pair's limit (user length unit; negative: a contact), and the pair's
    name; None without pairs or rows. The synthesis' `clearance` constraint."""
    C = Clearance(cm)
    found = minima(cm, result, C)
    if not found:
        return None
    worst = min(zip(found, C.pairs), key=lambda mp: mp[0].d - mp[1].limit)
    return worst[0].d - worst[1].limit, worst[1].name
