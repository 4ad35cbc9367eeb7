"""The extremes of a column sampled on the grid, refined between the rows from its exact
derivatives: the one function behind every largest or smallest value planarkin reports (run's
cycle figures, the studies' metrics and their sensitivities, the synthesis margins).

Between two rows t0 and t1 = t0 + h a column y is the quintic Hermite polynomial p(s), t = t0 +
s h, that matches y, y' and y'' (the exact rate and acceleration of the solve) at both rows, or
the cubic matching y and y' where the column has no acceleration. Its error is O(h^6) (cubic:
O(h^4)) of the grid step, where the grid's own extreme is O(h^2) off. The largest value is the
grid's largest unless, in an interval where the exact rate falls from positive to negative,
p has a larger maximum: the root of p' there (a bracketed Newton iteration on the polynomial,
to rounding) is the refined time, p at it the refined value. Only intervals that can beat the
grid's largest are refined (p exceeds the larger of its two end values by at most
h (|y0'| + |y1'|) + h^2 (|y0''| + |y1''|)), so a column costs a few array passes however long the
run. A refined value within rounding (TIE) of the grid's largest leaves the grid row: among equal
values the first row wins, as argmax does, also when the rows arrive chunk by chunk (`better`).

The smallest value is the largest of -y. Without a rate column the grid's extreme is the answer.
"""

from __future__ import annotations

import numpy as np

TIE = 16 * np.finfo(float).eps      # refined values within this (relative) of the grid's tie
NEWTON = 100                        # iterations at most (bisection alone needs ~53)
GRID_ONLY = ("ratio", "advantage")  # measure kinds kept at the grid's extremes: infinite at a
                                    # dead point, their extremes are no smooth turning points

# the derivative columns of a table column, by the name's last part (bodies.csv, points.csv and
# measures.csv): a position's rate and acceleration, a rate's acceleration. The jerk is never
# used, so a column is refined alike whether or not a run computed it (the studies' batched
# solve does not).
RATES = {"x": ("vx", "ax"), "y": ("vy", "ay"), "phi": ("omega", "alpha"),
         "vx": ("ax", None), "vy": ("ay", None), "omega": ("alpha", None),
         "": ("rate", "accel"), "rate": ("accel", None)}


def derivative_columns(names: list[str], k: int) -> tuple[int | None, int | None]:
    """(rate, acceleration) column indices of column k of a table with these column names
    (without units), each None where the table has none."""
    owner, dot, q = names[k].rpartition(".")
    if not dot:
        owner, q = names[k], ""
    elif q not in RATES:
        return None, None
    at = {n: i for i, n in enumerate(names)}
    return tuple(None if d is None else at.get(f"{owner}.{d}") for d in RATES[q])


def _coefficients(h, y0, v0, a0, y1, v1, a1):
    """(c1, ..., c5) of p(s) - y0 = c1 s + ... + c5 s^5 on [0, 1]: the quintic Hermite
    polynomial where both accelerations are finite, else the cubic one."""
    D = y1 - y0
    d0, d1 = h * v0, h * v1
    quintic = np.isfinite(a0) & np.isfinite(a1)
    A0 = np.where(quintic, h * h * a0, 0.0)
    A1 = np.where(quintic, h * h * a1, 0.0)
    c2 = np.where(quintic, 0.5 * A0, 3 * D - 2 * d0 - d1)
    c3 = np.where(quintic, 10 * D - 6 * d0 - 4 * d1 - 1.5 * A0 + 0.5 * A1, -2 * D + d0 + d1)
    c4 = np.where(quintic, -15 * D + 8 * d0 + 7 * d1 + 1.5 * A0 - A1, 0.0)
    c5 = np.where(quintic, 6 * D - 3 * d0 - 3 * d1 - 0.5 * A0 + 0.5 * A1, 0.0)
    return d0, c2, c3, c4, c5


def _peak(h, y0, v0, a0, y1, v1, a1):
    """(s, value) of the maximum of p on (0, 1) where p'(0) = h v0 > 0 > p'(1) = h v1:
    Newton on p' kept inside the bracket of its sign change (bisection where it leaves it)."""
    c1, c2, c3, c4, c5 = _coefficients(h, y0, v0, a0, y1, v1, a1)
    lo, hi = np.zeros_like(h), np.ones_like(h)
    s = v0 / (v0 - v1)                  # where the rate's chord crosses zero
    live = np.ones(len(h), dtype=bool)
    for _ in range(NEWTON):
        x = s[live]
        k = (c1[live], c2[live], c3[live], c4[live], c5[live])
        f = k[0] + x * (2 * k[1] + x * (3 * k[2] + x * (4 * k[3] + x * 5 * k[4])))
        df = 2 * k[1] + x * (6 * k[2] + x * (12 * k[3] + x * 20 * k[4]))
        up = f > 0                      # the maximum is to the right of x
        lo[live] = np.where(up, x, lo[live])
        hi[live] = np.where(up, hi[live], x)
        with np.errstate(divide="ignore", invalid="ignore"):
            nx = x - f / df
        a, b = lo[live], hi[live]
        nx = np.where((nx > a) & (nx < b), nx, 0.5 * (a + b))
        nx = np.where(f == 0, x, nx)
        s[live] = nx
        done = (np.abs(nx - x) <= 4 * np.finfo(float).eps) | (b - a <= 4 * np.finfo(float).eps)
        idx = np.flatnonzero(live)
        live[idx[done]] = False
        if not live.any():
            break
    value = y0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
    return s, value


def hermite(s, h, y0, v0, a0, y1, v1, a1):
    """The interpolant p at s in [0, 1] (t = t0 + s h) between rows (y0, v0, a0) and (y1, v1,
    a1): quintic with finite accelerations, else cubic (arrays broadcast)."""
    c1, c2, c3, c4, c5 = _coefficients(*np.broadcast_arrays(h, y0, v0, a0, y1, v1, a1))
    return y0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))


def extreme(t, y, v=None, a=None, sense: float = 1.0):
    """The refined largest (sense +1) or smallest (sense -1) value of columns sampled at times
    t (N,) (or one row of times per column, (..., N)): y (..., N) the values, v and a their
    exact rate and acceleration (or None). Returns (time, value), each of y's shape without
    its last axis (nan for a column without a finite value)."""
    y = np.asarray(y, dtype=float)
    lead, N = y.shape[:-1], y.shape[-1]
    Y = sense * y.reshape(-1, N)
    L = Y.shape[0]
    t = np.asarray(t, dtype=float)
    t = t if t.ndim == 1 else np.broadcast_to(t, y.shape).reshape(L, N)
    at = (lambda li, j: t[j]) if t.ndim == 1 else (lambda li, j: t[li, j])
    out_t, out_y = np.full(L, np.nan), np.full(L, np.nan)
    if N == 0 or L == 0:
        return out_t.reshape(lead), out_y.reshape(lead)
    nan = np.isnan(Y)
    if nan.any():
        has = ~nan.all(axis=1)
        i = np.argmax(np.where(nan, -np.inf, Y), axis=1)
    else:
        has, i = np.ones(L, dtype=bool), np.argmax(Y, axis=1)
    rows = np.arange(L)
    best = Y[rows, i]
    out_t[has], out_y[has] = at(rows[has], i[has]), best[has]
    if v is not None and N > 1:
        V = sense * np.asarray(v, dtype=float).reshape(L, N)
        # the intervals where the rate falls through zero, then those that can beat the grid
        li, j = np.nonzero((V[:, :-1] > 0) & (V[:, 1:] < 0))
        if len(li):
            A = None if a is None else np.asarray(a, dtype=float).reshape(L, N)
            y0, y1, v0, v1 = Y[li, j], Y[li, j + 1], V[li, j], V[li, j + 1]
            a0, a1 = (np.full(len(li), np.nan),) * 2 if A is None else \
                (sense * A[li, j], sense * A[li, j + 1])
            hj = at(li, j + 1) - at(li, j)
            with np.errstate(invalid="ignore", over="ignore"):
                reach = hj * (np.abs(v0) + np.abs(v1)) + np.where(
                    np.isfinite(a0) & np.isfinite(a1), hj * hj * (np.abs(a0) + np.abs(a1)), 0.0)
                keep = np.isfinite(y0) & np.isfinite(y1) & \
                    (np.maximum(y0, y1) + reach >= best[li])
            li, j, hj = li[keep], j[keep], hj[keep]
        if len(li):
            s, val = _peak(hj, y0[keep], v0[keep], a0[keep], y1[keep], v1[keep], a1[keep])
            order = np.lexsort((j, -val, li))   # per column: the largest, the first of equals
            first = order[np.r_[True, li[order][1:] != li[order][:-1]]]
            c = li[first]
            win = first[better(val[first], best[c])]
            out_t[li[win]] = at(li[win], j[win]) + s[win] * hj[win]
            out_y[li[win]] = val[win]
    return out_t.reshape(lead), (sense * out_y).reshape(lead)


def better(new, old):
    """Whether a largest value `new` replaces `old` (found earlier, nan: none): larger beyond
    rounding (TIE of their size)."""
    new, old = np.asarray(new, dtype=float), np.asarray(old, dtype=float)
    with np.errstate(invalid="ignore"):
        return ~np.isnan(new) & (np.isnan(old) | (new > old + TIE * np.maximum(np.abs(new),
                                                                                np.abs(old))))
