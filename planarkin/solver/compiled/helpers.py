"""The small functions of the compiled route, and the element equations registered with numba.

The element equations are planarkin.elements.pointline's (one text for both routes): that module
does not import numba, so its helpers (rotated, relative, angle_row, line_row) are registered with
numba (numba.extending.register_jitable, inlined into their callers in numba's IR) for the kernels
generated per mechanism structure (planarkin.solver.compiled.gen, gen_each), which compile each
kind's function apart, for one signature.

Here also what those kernels share beyond the equations: a determinant's sign, NaN-propagating
maximum, a dense block's inverse (Gauss-Jordan), the quintic Hermite prediction of a grid row
and the studies' acceptance tests of a point. Every function is inlined into its caller by numba
(inline="always") when another of these calls it; the generated kernels compile each one they call
apart, as they compile the kinds (gen.helper_lines). With NUMBA_DISABLE_JIT=1 they run as Python.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba.extending import register_jitable

from planarkin.elements import pointline
from planarkin.solver.acceptance import COND_WARN, KAPPA

inline = numba.njit(inline="always", error_model="numpy", _nrt=False)

for _helper in (pointline.rotated, pointline.relative, pointline.angle_row, pointline.line_row):
    register_jitable(inline="always", error_model="numpy", _nrt=False)(_helper)


@inline
def sign_of(x):
    """The sign of x as a float: 1, -1, 0, nan for nan (a block's determinant)."""
    if x > 0:
        return 1.0
    if x < 0:
        return -1.0
    return np.nan if x != x else 0.0


@inline
def nanmax(a, v):
    """NaN-propagating maximum, as numpy's max."""
    return v if (v > a or v != v) else a


@inline
def ratio_of(size, smin):
    """A first Newton step's size over sigma_min (inf where sigma_min is not positive)."""
    return size / smin if smin > 0 else np.inf


@inline
def inf_unless_finite(x):
    """x, or inf where it is not finite (nan too): a step's size."""
    return x if math.isfinite(x) else np.inf


@inline
def gauss_jordan(k, J, jo, inv, io, A):
    """Inverse of the k x k matrix J[jo:] (row-major) into inv[io:] by Gauss-Jordan with partial
    pivoting, as planarkin.solver.linalg's Gauss-Jordan inverse: returns (True, the determinant's
    sign), or (False, 0.0) when singular (inverse nan). A (>= 2 k k): the workspace. The
    generated kernels (planarkin.solver.compiled.gen, gen_each) compile it apart, for one
    signature: one text of the dense blocks' factorisation."""
    w = 2 * k
    scale = 0.0
    sg = 1.0
    for i in range(k):
        for j in range(k):
            A[i * w + j] = J[jo + i * k + j]
            A[i * w + k + j] = 1.0 if i == j else 0.0
            a = abs(J[jo + i * k + j])
            if a > scale or a != a:
                scale = a
    tiny = (scale if scale > 0 else 1.0) * 1e-300
    ok = True
    for col in range(k):
        pr = col
        for r in range(col + 1, k):
            if abs(A[r * w + col]) > abs(A[pr * w + col]):
                pr = r
        if pr != col:
            for j in range(w):
                t = A[col * w + j]
                A[col * w + j] = A[pr * w + j]
                A[pr * w + j] = t
            sg = -sg
        piv = A[col * w + col]
        if not (abs(piv) > tiny):
            ok = False
            piv = 1.0
        sg *= (1.0 if piv > 0 else 0.0) - (1.0 if piv < 0 else 0.0)
        for j in range(w):
            A[col * w + j] /= piv
        for r in range(k):
            if r == col:
                continue
            f = A[r * w + col]
            if f != 0.0:
                for j in range(w):
                    A[r * w + j] -= f * A[col * w + j]
    for i in range(k):
        for j in range(k):
            inv[io + i * k + j] = A[i * w + k + j] if ok else np.nan
    return ok, (sg if ok else 0.0)


@inline
def hermite_row(ti, k, W, Tn, Qn, Qdn, Qddn, Q, qo):
    """One grid row's prediction into Q[qo:qo + W]: quintic Hermite interpolation at time ti
    between path nodes k and k + 1 (rows of W numbers of the flat Qn, Qdn, Qddn), the
    operations of planarkin.solver.path.hermite5 in its order (the same bits). Called inside
    the generated grid kernels (planarkin.solver.compiled.gen)."""
    h = Tn[k + 1] - Tn[k]
    s = (ti - Tn[k]) / h
    s2 = s * s
    s3 = s2 * s
    s4 = s3 * s
    s5 = s3 * s2
    H0 = 1 - 10 * s3 + 15 * s4 - 6 * s5
    H1 = s - 6 * s3 + 8 * s4 - 3 * s5
    H2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5
    H3 = 10 * s3 - 15 * s4 + 6 * s5
    H4 = -4 * s3 + 7 * s4 - 3 * s5
    H5 = 0.5 * s3 - s4 + 0.5 * s5
    h1 = H1 * h
    h2 = H2 * h * h
    h4 = H4 * h
    h5 = H5 * h * h
    o0 = k * W
    o1 = o0 + W
    for c in range(W):
        Q[qo + c] = (H0 * Qn[o0 + c] + h1 * Qdn[o0 + c] + h2 * Qddn[o0 + c]
                     + H3 * Qn[o1 + c] + h4 * Qdn[o1 + c] + h5 * Qddn[o1 + c])


@inline
def accept_point(i, W, n, nblk, nfine, Q, Qd, Qdd, smin, sign, conv, ratio, has_t, trow,
                 has_v, vrow, tg, sign0, jerk, jerk_ok, good, perr):
    """studies.batch's acceptance tests of point i (Batch.accept is the numpy reference), while
    its numbers are at hand: good[i] = converged, finite q, qd, qdd (W columns: the point's
    rows of the results, the rows before them the point before's), first correction at most
    KAPPA sigma_min, 1 / min(smin) at most COND_WARN (the bounds of planarkin.solver.acceptance, the
    studies' rule acceptance.accepted with cond_max=COND_WARN, compiled in) and every
    fine-block sign equal to sign0's; perr[i] = the Taylor predictor error
    (acceptance.taylor_error, forwards and backwards, first n columns) of the interval from
    the point before when that is the same variant (vrow) at the grid time before (times tg,
    indexed by trow), else 0. jerk: the last interval's change of acceleration, carried from
    point to point, valid when jerk_ok.
    Returns the new jerk_ok."""
    o = i * W
    g = conv != 0 and ratio <= KAPPA
    c = 0
    while c < W and g:
        g = (math.isfinite(Q[o + c]) and math.isfinite(Qd[o + c])
             and math.isfinite(Qdd[o + c]))
        c += 1
    lo = np.inf
    for c in range(nblk):
        v = smin[i * nblk + c]
        if v < lo or v != v:
            lo = v
    if lo != lo:
        g = False
    elif g:
        g = 1.0 / (lo if lo > 1e-300 else 1e-300) <= COND_WARN
    c = 0
    while c < nfine and g:
        g = sign[i * nfine + c] == sign0[i * nfine + c]
        c += 1
    good[i] = 1 if g else 0
    k1 = trow[i] if has_t else i
    k0 = (trow[i - 1] if has_t else i - 1) if i > 0 else 0
    if i > 0 and k1 == k0 + 1 and (not has_v or vrow[i] == vrow[i - 1]):
        h = tg[k1] - tg[k0]
        hh = 0.5 * h * h
        h3 = h * h * h / 6.0
        p = o - W
        nan = False
        e = 0.0
        for c in range(n):
            dA = (Qdd[o + c] - Qdd[p + c]) / h
            j3 = jerk[c] if jerk_ok else 0.0
            ef = abs(Q[o + c] - (Q[p + c] + h * Qd[p + c] + hh * Qdd[p + c] + h3 * j3))
            eb = abs(Q[o + c] - h * Qd[o + c] + hh * Qdd[o + c] - h3 * dA - Q[p + c])
            x = ef if ef > eb else eb
            jerk[c] = dA
            e = x if x > e else e
            nan = nan or ef != ef or eb != eb
        perr[i] = np.nan if nan else e
        return True
    perr[i] = 0.0
    return False
