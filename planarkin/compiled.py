"""The compiled route of the grid pass: the kernel's algorithms in Python, compiled by numba.

System._solve_batch (the reference pass) solves per time point Newton on each small diagonal
block, then the velocity and acceleration systems. This module holds the same algorithm over
points, written as plain loops so that numba compiles it (issue 17): the same Newton iterations
block by block (solve_points: a block iterates until every point of the batch has converged, as
the reference does, so the iteration counts agree), the same determinant signs and sigma_min
bounds (1 / ||J^-1||_F; Gauss-Jordan with partial pivoting, 1x1 and 2x2 blocks in closed form as
the reference, system.Small2), and after each block, per point, its rows of the velocity and
acceleration systems with the gradients and gamma at the converged positions. solve_each
solves point by point, each to its own convergence, with per-point element parameters and the
design studies' acceptance tests (studies.batch). The element equations are
planarkin.compiled_kinds' (one function per kind, shared with the generated kernels of
planarkin.compiled_gen); the predictions and the layout are in planarkin.compiled_points.

Every function is one Python text: compiled by numba (no fastmath: the operations are rounded
as written, in the order written, with no contraction into fused multiply-adds, as the numpy
passes round them), or run as it is with NUMBA_DISABLE_JIT=1 (for debugging: the same results,
slowly). Arrays are flat (row-major, offsets computed as the C kernel this replaces did) and of
fixed types (int32 structure, float64 numbers, uint8 flags, int64 iteration counts), so that
each entry point is compiled for one signature. error_model="numpy": a division by zero gives
inf or nan, as in numpy, instead of raising.

Imported only by planarkin.kernel, when a job takes the compiled route: importing this module
imports numba and compiles the entry points (or loads them from numba's disk cache, whose
directory planarkin.jitcache prepared and checked before numba was imported).
"""

from __future__ import annotations

import math

from . import compiled_kinds as kinds
from . import jitcache

CACHE = jitcache.prepare()       # the checked cache directory, or None: no disk cache

import numba                      # noqa: E402  (after the cache directory is set)
import numpy as np                # noqa: E402

if CACHE is not None:             # numba imported before: its configuration read then
    numba.config.CACHE_DIR = str(CACHE)

KMAX = 64             # largest solve block (the path's merged blocks)
KFINE = 6             # largest fine block (of the grid pass: larger ones are J5's dense/sparse LU)

OPTS = dict(cache=CACHE is not None, error_model="numpy", nogil=True)
# The helpers allocate nothing: without numba's reference counting (its atomic increments and
# decrements of the array arguments at every call made a point 9 us, 10 times the C's). numba
# does not inline one compiled function into another; inline="always" does, in its IR: the
# element equations and the small helpers so (a point 1.9 us, the C 0.9 us:
# benchmarks/bench_route.py --micro). Inlining rates and factor too gives 1.1 us, but the first
# compile then takes 77 s instead of 18 s (both on this 2-core machine, shared).
HELPER = dict(OPTS, _nrt=False)
jit = numba.njit(**OPTS)
helper = numba.njit(**HELPER)
inline = numba.njit(**HELPER, inline="always")

# signatures: arrays flat and C-contiguous. The compiled helpers called with constants get one
# too: numba would otherwise compile them once per combination of literal arguments (row_eval,
# before it was inlined, 7 times at about a second each)
F64, U8, I64 = numba.float64[::1], numba.uint8[::1], numba.int64[::1]
INT, DBL, BOOL = numba.int64, numba.float64, numba.boolean
I64x2 = numba.int64[:, ::1]


# -- the elements' equations ---------------------------------------------------------------------
@inline
def row_eval(kind, bi, bj, p, po, eq, q, qo, c, s, co, qd, want, gr, go):
    """One equation row of an element (compiled_kinds.row): returns (g, gamma_g); with want & 2
    its gradient over (x_i, y_i, phi_i, x_j, y_j, phi_j) into gr[go:go + 6]. want: 1 g, 2
    gradient, 4 gamma (needs qd, read at the offset qo as q). p[po:po + 8]: si, sj, vi
    (reference sections 1, 2, 5); q[qo:], qd[qo:] the point's coordinates, c[co:], s[co:] its
    bodies' cos and sin."""
    wi = vxi = vyi = wj = vxj = vyj = 0.0
    if want & 4:
        vxi = qd[qo + 3 * bi]
        vyi = qd[qo + 3 * bi + 1]
        wi = qd[qo + 3 * bi + 2]
        vxj = qd[qo + 3 * bj]
        vyj = qd[qo + 3 * bj + 1]
        wj = qd[qo + 3 * bj + 2]
    g, d0, d1, d2, d3, d4, d5, gam = kinds.row(
        kind, eq, want, q[qo + 3 * bi], q[qo + 3 * bi + 1], q[qo + 3 * bi + 2], c[co + bi],
        s[co + bi], q[qo + 3 * bj], q[qo + 3 * bj + 1], q[qo + 3 * bj + 2], c[co + bj],
        s[co + bj], p[po], p[po + 1], p[po + 2], p[po + 3], p[po + 4], p[po + 5], vxi, vyi, wi,
        vxj, vyj, wj)
    if want & 2:
        gr[go] = d0
        gr[go + 1] = d1
        gr[go + 2] = d2
        gr[go + 3] = d3
        gr[go + 4] = d4
        gr[go + 5] = d5
    return g, gam


# -- small dense linear algebra ------------------------------------------------------------------
sign_of = kinds.sign_of


# (the one text of the small Gauss-Jordan, shared with the generated kernels: compiled here
# for its one signature)
gauss_jordan = numba.njit([(INT, F64, INT, F64, INT, F64)], **HELPER)(
    getattr(kinds.gauss_jordan, "py_func", kinds.gauss_jordan))


@helper
def factor(kb, nj, src, dst, gr, J, Mi, mo, WK):
    """The block's matrix J (kb x kb) from its rows' gradients gr (kb x 6): nj entries,
    J[dst[e]] = gr[src[e]] in order (of a repeated position the last counts, as
    System.block_matrix); then its inverse into Mi[mo:]. Returns (sigma_min bound
    1 / ||J^-1||_F, determinant sign), as System._invert."""
    for k in range(kb * kb):
        J[k] = 0.0
    for k in range(nj):
        J[dst[k]] = gr[src[k]]
    if kb == 1:
        Mi[mo] = 1.0 / J[0]
        return abs(J[0]), sign_of(J[0])
    if kb == 2:        # closed form, as system.Small2 (the reference pass)
        a = J[0]
        b = J[1]
        c = J[2]
        d = J[3]
        det = a * d - b * c
        ok2 = math.isfinite(det) and det != 0
        inv = 1.0 / (det if ok2 else np.nan)
        Mi[mo] = d * inv
        Mi[mo + 1] = -b * inv
        Mi[mo + 2] = -c * inv
        Mi[mo + 3] = a * inv
        if not ok2:
            return 0.0, 0.0
        return abs(det) / np.sqrt(a * a + b * b + c * c + d * d), sign_of(det)
    ok, sg = gauss_jordan(kb, J, 0, Mi, mo, WK)
    f = 0.0
    for k in range(kb * kb):
        f += Mi[mo + k] * Mi[mo + k]
    return (1.0 / np.sqrt(f) if ok else 0.0), sg


@inline
def apply(kb, Mi, mo, r, cols, co, X, xo):
    """x = Mi r into the block's columns cols[co:co + kb] of X[xo:]."""
    if kb == 1:
        X[xo + cols[co]] = r[0] * Mi[mo]
        return
    for a in range(kb):
        x = 0.0
        for k in range(kb):
            x += Mi[mo + a * kb + k] * r[k]
        X[xo + cols[co + a]] = x


@inline
def solve2(J, r, cols, co, X, xo):
    """The same for a 2x2 block from its matrix J: Cramer's rule, as the reference's
    Small2.solve (one rounding less than through the inverse's entries; tests/test_sketch_exact.py
    holds the Jansen leg's accelerations to 1e-14 of the exact linkage)."""
    det = J[0] * J[3] - J[1] * J[2]
    X[xo + cols[co]] = (J[3] * r[0] - J[1] * r[1]) / det
    X[xo + cols[co + 1]] = (J[0] * r[1] - J[2] * r[0]) / det


@inline
def dot6(g, go, rc, ro, X, xo):
    """Gradient g[go:go + 6] x rates of one row (its columns rc[ro:ro + 6]), summed in pairs
    (a chain of six dependent subtractions was a tenth of the C kernel's time)."""
    return ((g[go] * X[xo + rc[ro]] + g[go + 1] * X[xo + rc[ro + 1]])
            + (g[go + 2] * X[xo + rc[ro + 2]] + g[go + 3] * X[xo + rc[ro + 3]])
            + (g[go + 4] * X[xo + rc[ro + 4]] + g[go + 5] * X[xo + rc[ro + 5]]))


@helper
def fine_signs(kb, b, bfirst, bnf, bfo, bfs, J, sign, so, WK, sub, subinv):
    """A merged block's fine-block determinant signs from its matrix J into sign[so:]."""
    o = 0
    for f in range(bnf[b]):
        sz = bfs[bfo[b] + f]
        if sz == 1:
            sf = sign_of(J[o * kb + o])
        else:
            for u in range(sz):
                for v in range(sz):
                    sub[u * sz + v] = J[(o + u) * kb + o + v]
            _, sf = gauss_jordan(sz, sub, 0, subinv, 0, WK)
        sign[so + bfirst[b] + f] = sf
        o += sz


# -- solve_points: all points block by block (System.solve_batch) ------------------------------
# a block's rows, unpacked once per block: rw[rp] = kind, bi, bj, eq, row, 8 e

@numba.njit([(INT, I64x2, I64, INT, INT, I64, I64, INT, BOOL, F64, INT, F64, F64, INT, F64, F64,
              F64, INT, F64, F64, F64, F64, F64, INT, F64, F64, F64, F64, F64, I64)], **HELPER)
def rates(kb, rw, cols, co, nj, src, dst, order, have, q, qo, c, s, cso, qd, qdd, t, to, nu,
          fdd, R, gr, Mi, mo, J, WK, r, gm, prm, rcol):
    """One point's block rows at its converged positions: residuals |Phi - target| into R,
    then with order >= 1 the velocities (Phi_q qd = nu, the earlier blocks' columns known) and
    with order >= 2 the accelerations (Phi_q qdd = gamma + f''). gr, Mi[mo:]: the rows'
    gradients and the block's inverse at the converged positions (have: already there, else
    evaluated here)."""
    if not have:
        for rp in range(kb):
            g, _ = row_eval(rw[rp, 0], rw[rp, 1], rw[rp, 2], prm, rw[rp, 5], rw[rp, 3], q, qo,
                            c, s, cso, q, 3, gr, 6 * rp)
            R[to + rw[rp, 4]] = abs(g - t[to + rw[rp, 4]])
        factor(kb, nj, src, dst, gr, J, Mi, mo, WK)
    for rp in range(kb):
        r[rp] = nu[to + rw[rp, 4]] - dot6(gr, 6 * rp, rcol, 6 * rw[rp, 4], qd, qo)
    if kb == 2:
        solve2(J, r, cols, co, qd, qo)
    else:
        apply(kb, Mi, mo, r, cols, co, qd, qo)
    if have:        # the residuals, and gamma at the same time (the same terms)
        for rp in range(kb):
            g, gam = row_eval(rw[rp, 0], rw[rp, 1], rw[rp, 2], prm, rw[rp, 5], rw[rp, 3], q, qo,
                              c, s, cso, qd, 5, gr, 0)
            gm[rp] = gam
            R[to + rw[rp, 4]] = abs(g - t[to + rw[rp, 4]])
    if order < 2:
        return
    for rp in range(kb):
        if have:
            gam = gm[rp]
        else:
            _, gam = row_eval(rw[rp, 0], rw[rp, 1], rw[rp, 2], prm, rw[rp, 5], rw[rp, 3], q, qo,
                              c, s, cso, qd, 4, gr, 0)
        r[rp] = (gam + fdd[to + rw[rp, 4]]) - dot6(gr, 6 * rp, rcol, 6 * rw[rp, 4], qdd, qo)
    if kb == 2:
        solve2(J, r, cols, co, qdd, qo)
    else:
        apply(kb, Mi, mo, r, cols, co, qdd, qo)


@helper
def block(kb, b, N, W, m, nbb, nblk, nfine, rw, cols, co, nj, src, dst, affine, fixed, maxit,
          tol, full, order, Q, Qd, Qdd, C, S, T, NU, FDD, iters, conv, ratio, sign, smin, R,
          bfirst, bnf, bfo, bfs, MI, SZ, GB, J, WK, r, gm, sub, subinv, prm, rcol):
    """One solve block for all points. Newton block by block as System._solve_batch: the block
    iterates until every point of the batch has converged (so the iteration counts agree with
    the reference); an affine block takes exactly one step, which is exact, so each point is
    finished (rates included) in one pass."""
    for it in range(maxit):
        refactor = it == 0 or (full and not affine)
        all_small = True
        for i in range(N):
            qo = i * W
            cso = i * nbb
            to = i * m
            mo = i * kb * kb
            if refactor:
                for rp in range(kb):
                    r[rp], _ = row_eval(rw[rp, 0], rw[rp, 1], rw[rp, 2], prm, rw[rp, 5],
                                        rw[rp, 3], Q, qo, C, S, cso, Q, 3, GB, 6 * rp)
                sm, sg = factor(kb, nj, src, dst, GB, J, MI, mo, WK)
                if it == 0:
                    smin[i * nblk + b] = sm
                    if bnf[b] == 1:
                        sign[i * nfine + bfirst[b]] = sg
                    else:               # a merged block: the signs of its fine blocks
                        fine_signs(kb, b, bfirst, bnf, bfo, bfs, J, sign, i * nfine, WK, sub,
                                   subinv)
            else:
                for rp in range(kb):
                    r[rp], _ = row_eval(rw[rp, 0], rw[rp, 1], rw[rp, 2], prm, rw[rp, 5],
                                        rw[rp, 3], Q, qo, C, S, cso, Q, 1, GB, 0)
            for rp in range(kb):
                r[rp] -= T[to + rw[rp, 4]]
            sz = 0.0
            for a in range(kb):
                dx = 0.0
                for k in range(kb):
                    dx += MI[mo + a * kb + k] * r[k]
                col = cols[co + a]
                Q[qo + col] -= dx
                ad = abs(dx)
                if ad > sz or ad != ad:
                    sz = ad
                if col % 3 == 2 and dx != 0.0:          # an angle that moved
                    C[cso + col // 3] = np.cos(Q[qo + col])
                    S[cso + col // 3] = np.sin(Q[qo + col])
            if not math.isfinite(sz):
                sz = np.inf
            if it == 0:
                sm0 = smin[i * nblk + b]
                v = sz / sm0 if sm0 > 0 else np.inf
                if v > ratio[i] or v != v:
                    ratio[i] = v
            if iters[i] < it + 1:
                iters[i] = it + 1
            if affine:
                # one step is exact: converged unless not finite; the point is done
                conv[i] = 1 if (conv[i] and math.isfinite(sz)) else 0
                if order >= 1:
                    rates(kb, rw, cols, co, nj, src, dst, order, fixed, Q, qo, C, S, cso, Qd,
                          Qdd, T, to, NU, FDD, R, GB, MI, mo, J, WK, r, gm, prm, rcol)
                continue
            SZ[i] = sz
            if not (sz <= tol):
                all_small = False
        if affine or all_small:
            break
    if affine:
        return
    for i in range(N):
        conv[i] = 1 if (conv[i] and SZ[i] <= tol) else 0
    if order < 1:
        return
    for i in range(N):
        rates(kb, rw, cols, co, nj, src, dst, order, False, Q, i * W, C, S, i * nbb, Qd, Qdd,
              T, i * m, NU, FDD, R, GB, MI, i * kb * kb, J, WK, r, gm, prm, rcol)


@inline
def nanmax(a, v):
    """NaN-propagating maximum, as numpy's max."""
    return v if (v > a or v != v) else a


@helper
def unpack(b, bk, boff, bcols, brows, rowel, roweq, ekind, ebi, ebj, rpos, rw, src, dst):
    """Block b's rows into rw and its matrix entries into src, dst; returns their number."""
    kb = bk[b]
    nj = 0
    for rp in range(kb):
        row = brows[boff[b] + rp]
        e = rowel[row]
        rw[rp, 0] = ekind[e]
        rw[rp, 1] = ebi[e]
        rw[rp, 2] = ebj[e]
        rw[rp, 3] = roweq[row]
        rw[rp, 4] = row
        rw[rp, 5] = 8 * e
        for k in range(6):
            if rpos[6 * row + k] >= 0:
                src[nj] = 6 * rp + k
                dst[nj] = rp * kb + rpos[6 * row + k]
                nj += 1
    return nj


@jit
def solve_points(N, W, m, nb, nblk, ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols,
                 brows, Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, order, iters, conv, ratio,
                 sign, smin, inblk, R, rcol, rpos, nfine, bfirst, bnf, bfo, bfs, bfix, rmax,
                 cond):
    """System.solve_batch for N points (kernel.solve). Arrays row-major per point, flat.
    inblk (m): the row is in a block; R (N, m): |Phi| of every row at the results; rcol (m x 6):
    the columns of each row's gradient entries; rpos (m x 6): where each gradient entry of a row
    goes in its block's row (-1: another block's column); sign (N, nfine) per fine block: solve
    block b holds bnf[b] fine blocks, the first numbered bfirst[b], their sizes bfs[bfo[b]...].
    bfix (nblk): the block's whole gradient does not depend on its own unknowns (System
    Block.fixed_grad: the rates reuse the Newton step's gradients and inverse, as the reference
    does). Outputs besides: rmax (N) the largest |Phi| of each point (numpy's R.max(axis=1)),
    cond (N) its condition estimate (planarkin.acceptance.condition: the largest
    1 / max(smin, 1e-300) over the blocks); conv[i] is 0 where a coordinate of the result is not finite."""
    nbb = nb + 1
    n = W - 3
    kmax = 1
    for b in range(nblk):
        if bk[b] > kmax:
            kmax = bk[b]
    C = np.empty(N * nbb)
    S = np.empty(N * nbb)
    MI = np.empty(N * kmax * kmax)
    GB = np.empty(KMAX * 6)
    SZ = np.empty(N)
    J = np.empty(KMAX * KMAX)
    WK = np.empty(2 * KMAX * KMAX)
    r = np.empty(KMAX)
    gm = np.empty(KMAX)
    sub = np.empty(KFINE * KFINE)
    subinv = np.empty(KFINE * KFINE)
    rw = np.empty((KMAX, 6), dtype=np.int64)
    src = np.empty(KMAX * 6, dtype=np.int64)
    dst = np.empty(KMAX * 6, dtype=np.int64)
    for i in range(N):
        for b in range(nbb):
            phi = Q[i * W + 3 * b + 2]
            if phi == 0.0 and math.copysign(1.0, phi) > 0:   # the ground, bodies that do not turn
                C[i * nbb + b] = 1.0
                S[i * nbb + b] = 0.0
            else:
                C[i * nbb + b] = np.cos(phi)
                S[i * nbb + b] = np.sin(phi)
        iters[i] = 0
        conv[i] = 1
        ratio[i] = 0.0
        if order >= 1:
            for a in range(n):
                Qd[i * W + a] = 0.0
        if order >= 2:
            for a in range(n):
                Qdd[i * W + a] = 0.0
    for b in range(nblk):
        kb = bk[b]
        nj = unpack(b, bk, boff, bcols, brows, rowel, roweq, ekind, ebi, ebj, rpos, rw, src,
                    dst)
        block(kb, b, N, W, m, nbb, nblk, nfine, rw, bcols, boff[b], nj, src, dst, baff[b] != 0,
              bfix[b] != 0, maxit, tol, full != 0, order, Q, Qd, Qdd, C, S, T, NU, FDD, iters,
              conv, ratio, sign, smin, R, bfirst, bnf, bfo, bfs, MI, SZ, GB, J, WK, r, gm, sub,
              subinv, eprm, rcol)
    # per point: |Phi| of the rows outside the blocks (left out as redundant), and with order 0
    # of all; the largest residual, the condition estimate, and no convergence where a
    # coordinate is not finite
    for i in range(N):
        for row in range(m):
            if inblk[row] and order >= 1:
                continue
            e = rowel[row]
            g, _ = row_eval(ekind[e], ebi[e], ebj[e], eprm, 8 * e, roweq[row], Q, i * W, C, S,
                            i * nbb, Q, 1, GB, 0)
            R[i * m + row] = abs(g - T[i * m + row])
        mx = R[i * m]
        for row in range(1, m):
            mx = nanmax(mx, R[i * m + row])
        rmax[i] = mx
        cd = 0.0
        for b in range(nblk):
            v = smin[i * nblk + b]
            v = 1.0 / (v if (v >= 1e-300 or v != v) else 1e-300)
            cd = v if b == 0 else nanmax(cd, v)
        cond[i] = cd
        for a in range(W):
            if not math.isfinite(Q[i * W + a]):
                conv[i] = 0
                break


# the entry points' one signature each, compiled (or loaded from the cache) when a job takes
# the route: kernel.Library.need
SIGNATURES = {
    "solve_points": (INT, INT, INT, INT, INT, I64, I64, I64, F64, I64, I64, I64, I64, I64, I64,
                     I64, F64, F64, F64, F64, F64, F64, INT, DBL, INT, INT, I64, U8, F64, F64,
                     F64, U8, F64, I64, I64, INT, I64, I64, I64, I64, I64, F64, F64),
}
