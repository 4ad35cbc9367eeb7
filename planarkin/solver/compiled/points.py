"""The compiled route's small entry points over points (see planarkin.solver.compiled.kernel): a chunk's
user-unit arrays (layout) and the design studies' cubic prediction, apart from the solves
generated per structure (planarkin.solver.compiled.gen; they write the grid's Hermite predictions
themselves, planarkin.solver.compiled.helpers.hermite_row).
"""

from __future__ import annotations

import numba
import numpy as np

from planarkin.solver.compiled import jitcache

CACHE = jitcache.prepare()       # the checked cache directory, or None: no disk cache
if CACHE is not None:             # numba imported before: its configuration read then
    numba.config.CACHE_DIR = str(CACHE)

jit = numba.njit(cache=CACHE is not None, error_model="numpy", nogil=True)
F64, I64 = numba.float64[::1], numba.int64[::1]
INT, DBL = numba.int64, numba.float64


# -- the grid pass's layout; the studies' cubic ----------------------------------
@jit
def cubic(q0, q1, q2, q3, out):
    """A design study's prediction along a repeated parameter step (studies.batch): the cubic
    q0 + 3 (q0 - q1) - 3 (q1 - q2) + (q2 - q3) through the last four solutions, element by
    element in the order of the numpy lines it replaces (the same bits)."""
    for k in range(len(out)):
        r = (q0[k] - q1[k]) * 3.0
        r += q0[k]
        r -= (q1[k] - q2[k]) * 3.0
        r += q2[k] - q3[k]
        out[k] = r


@jit
def layout(N, W, n, P, order, unit, L, pbody, ps, Q, Qd, Qdd, q, qd, qdd, p, pd, pdd):
    """A chunk's rows in user units, written once: q, qd, qdd (N, n) = the first n numbers of
    each row of Q, Qd, Qdd times unit (n); the points' positions, velocities and accelerations
    (N, P, 2), point k on body pbody[k] at ps[2 k], ps[2 k + 1], times L: the operations of
    planarkin.solver.kinematics.point_kinematics in its order (then times L). order 0: positions only,
    1: with velocities, 2: with accelerations (qd, pd, qdd, pdd unused above the order)."""
    for i in range(N):
        o = i * W
        for a in range(n):
            q[i * n + a] = Q[o + a] * unit[a]
        if order >= 1:
            for a in range(n):
                qd[i * n + a] = Qd[o + a] * unit[a]
        if order >= 2:
            for a in range(n):
                qdd[i * n + a] = Qdd[o + a] * unit[a]
        for k in range(P):
            b = pbody[k]
            x = (i * P + k) * 2
            c = np.cos(Q[o + 3 * b + 2])
            s = np.sin(Q[o + 3 * b + 2])
            sx = c * ps[2 * k] - s * ps[2 * k + 1]
            sy = s * ps[2 * k] + c * ps[2 * k + 1]
            p[x] = (Q[o + 3 * b] + sx) * L
            p[x + 1] = (Q[o + 3 * b + 1] + sy) * L
            if order < 1:
                continue
            w = Qd[o + 3 * b + 2]
            pd[x] = (Qd[o + 3 * b] - w * sy) * L
            pd[x + 1] = (Qd[o + 3 * b + 1] + w * sx) * L
            if order < 2:
                continue
            al = Qdd[o + 3 * b + 2]
            pdd[x] = (Qdd[o + 3 * b] - al * sy - w * w * sx) * L
            pdd[x + 1] = (Qdd[o + 3 * b + 1] + al * sx - w * w * sy) * L


# the entry points' one signature each, compiled (or loaded from the cache) when a job takes
# the route: kernel.Library.need
SIGNATURES = {
    "cubic": (F64, F64, F64, F64, F64),
    "layout": (INT, INT, INT, INT, INT, F64, DBL, I64, F64, F64, F64, F64, F64, F64, F64, F64, F64,
               F64),
}
