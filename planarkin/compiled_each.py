"""The compiled route's point-by-point solve, for design studies (see planarkin.compiled).

solve_each takes solve_points' arguments and results point by point: each point solves its
blocks to its own convergence, with its variant's element parameters (a row of a table) and
its grid time's driver row, and takes the studies' acceptance tests (studies.batch.Batch.accept
is the numpy reference) in the same pass.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from . import compiled_kinds as K
from .compiled import (BOOL, DBL, F64, HELPER, I64, INT, KFINE, KMAX, U8, dot6, fine_signs,
                       gauss_jordan, helper, jit, row_eval, sign_of)


@helper
def block_matrix(kb, brows, bo, rpos, gr, go, J):
    """The block's matrix from its rows' gradients gr[go:] (kb x 6); rpos (m x 6): where each
    gradient entry of a row goes in its block's row (-1: another block's column)."""
    for k in range(kb * kb):
        J[k] = 0.0
    for rp in range(kb):
        po = 6 * brows[bo + rp]
        for k in range(6):
            if rpos[po + k] >= 0:
                J[rp * kb + rpos[po + k]] = gr[go + rp * 6 + k]


ACCEPT = (INT, INT, INT, INT, INT, F64, F64, F64, F64, F64, numba.uint8, DBL, INT, I64, INT, I64,
          F64, F64, F64, BOOL, U8, F64)
# (its one text is compiled_kinds', which the generated study kernels compile too)
accept_point = numba.njit([ACCEPT], **HELPER)(getattr(K.accept_point, "py_func",
                                                      K.accept_point))


@helper
def invert_small(kb, J, M, mo, WK):
    """The block's inverse into M[mo:] as solve_each takes it (1 x 1 and 2 x 2 in closed form,
    as system.Small2): returns (sigma_min bound, determinant sign)."""
    if kb == 1:
        M[mo] = 1.0 / J[0]
        return abs(J[0]), sign_of(J[0])
    if kb == 2:
        det = J[0] * J[3] - J[1] * J[2]
        rd = 1.0 / det
        M[mo] = J[3] * rd
        M[mo + 1] = -J[1] * rd
        M[mo + 2] = -J[2] * rd
        M[mo + 3] = J[0] * rd
        nf = np.sqrt(J[0] * J[0] + J[1] * J[1] + J[2] * J[2] + J[3] * J[3]) * abs(rd)
        return (1.0 / nf if (math.isfinite(nf) and det != 0) else 0.0), sign_of(det)
    ok, sg = gauss_jordan(kb, J, 0, M, mo, WK)
    f = 0.0
    for a in range(kb * kb):
        f += M[mo + a] * M[mo + a]
    return (1.0 / np.sqrt(f) if ok else 0.0), sg


@jit
def solve_each(N, W, m, nb, nblk, ekind, ebi, ebj, rowel, roweq, bk, boff, baff, bcols, brows,
               Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, iters, conv, ratio, sign, smin, inblk,
               rcol, rpos, nfine, bfirst, bnf, bfo, bfs, has_v, vrow, prm, ne, has_t, trow, tg,
               sign0, test, good, perr):
    """solve_points' arguments and results, point by point (a design study, studies.batch):
    each point solves its blocks in order, each block by Newton until that point's own
    correction is at most tol (so a point's result does not depend on the other points of the
    batch), 1 x 1 and 2 x 2 blocks inverted in closed form (as system.Small2), then its
    velocities and accelerations as solve_points. The element parameters of point i: prm
    (E x 8) shared by all points, or with has_v the table prm (V x ne x 8) of parameter sets,
    row vrow[i] (a design study's variants). has_t: point i reads row trow[i] of T, NU and FDD
    (a study's grid times, the same for every variant), else row i. test: with the acceptance
    tests of every point (accept_point) into good and perr (accept_point's bounds are
    planarkin.acceptance's KAPPA and COND_WARN, compiled in)."""
    nbb = nb + 1
    n = W - 3
    total = 0
    for b in range(nblk):
        total += bk[b] * bk[b]
    nrow = boff[nblk - 1] + bk[nblk - 1]
    C = np.empty(nbb)
    S = np.empty(nbb)
    GR = np.empty(nrow * 6)
    MB = np.empty(max(total, 1))
    J = np.empty(KMAX * KMAX)
    WK = np.empty(2 * KMAX * KMAX)
    sub = np.empty(KFINE * KFINE)
    subinv = np.empty(KFINE * KFINE)
    r = np.empty(KMAX)
    keep = np.empty(nblk, dtype=np.bool_)
    mof = np.empty(nblk, dtype=np.int64)
    jerk = np.empty(max(n, 1))      # the last interval's dA
    jerk_ok = False                 # it is the one before
    # keep[b]: the block's Newton matrix is the one at the converged positions, exactly, and
    # serves the velocities and accelerations: an affine block (one iteration) whose rows'
    # gradients do not depend on its unknowns (revolute, x, y: on the angles only; angle:
    # constant) nor, for the revolute, x and y, on an angle among them
    mo = 0
    for b in range(nblk):
        keep[b] = baff[b] != 0
        mof[b] = mo
        mo += bk[b] * bk[b]
        for rp in range(bk[b]):
            if not keep[b]:
                break
            e = rowel[brows[boff[b] + rp]]
            kd = ekind[e]
            if kd != 3 and kd != 1 and kd != 4 and kd != 5:
                keep[b] = False
            elif kd != 3:
                for a in range(bk[b]):
                    c = bcols[boff[b] + a]
                    if c == 3 * ebi[e] + 2 or c == 3 * ebj[e] + 2:
                        keep[b] = False
    for i in range(N):
        qo = i * W
        ti = (trow[i] if has_t else i) * m
        pb = vrow[i] * 8 * ne if has_v else 0
        rat = 0.0
        its = 0
        ok = True
        for b in range(nbb):        # (the ground's angle is 0: no call)
            ph = Q[qo + 3 * b + 2]
            if ph == 0.0:
                C[b] = 1.0
                S[b] = 0.0
            else:
                C[b] = np.cos(ph)
                S[b] = np.sin(ph)
        # positions: block by block, Newton to this point's convergence
        for b in range(nblk):
            kb = bk[b]
            bo = boff[b]
            go = 6 * bo
            sz = np.inf
            for it in range(maxit):
                refactor = it == 0 or (full and not baff[b])
                for rp in range(kb):
                    row = brows[bo + rp]
                    e = rowel[row]
                    g, _ = row_eval(ekind[e], ebi[e], ebj[e], prm, pb + 8 * e, roweq[row], Q, qo,
                                    C, S, 0, Q, 3 if refactor else 1, GR, go + 6 * rp)
                    r[rp] = g - T[ti + row]
                if refactor:
                    block_matrix(kb, brows, bo, rpos, GR, go, J)
                    s0, sg = invert_small(kb, J, MB, mof[b], WK)
                    if it == 0:
                        smin[i * nblk + b] = s0
                        if bnf[b] == 1:
                            sign[i * nfine + bfirst[b]] = sg
                        else:           # a merged block: the signs of its fine blocks
                            fine_signs(kb, b, bfirst, bnf, bfo, bfs, J, sign, i * nfine, WK,
                                       sub, subinv)
                sz = 0.0
                for a in range(kb):
                    dx = 0.0
                    for k in range(kb):
                        dx += MB[mof[b] + a * kb + k] * r[k]
                    col = bcols[bo + a]
                    Q[qo + col] -= dx
                    ad = abs(dx)
                    if ad > sz or ad != ad:
                        sz = ad
                    # an angle that moved (one that did not keeps its cosine and sine, unless
                    # it is a zero, whose sine may be -0 and was taken as +0)
                    if col % 3 == 2 and (dx != 0.0 or Q[qo + col] == 0.0):
                        C[col // 3] = np.cos(Q[qo + col])
                        S[col // 3] = np.sin(Q[qo + col])
                if not math.isfinite(sz):
                    sz = np.inf
                if it == 0:
                    v = sz / smin[i * nblk + b] if smin[i * nblk + b] > 0 else np.inf
                    if v > rat or v != v:
                        rat = v
                if its < it + 1:
                    its = it + 1
                if baff[b]:
                    sz = 0.0 if math.isfinite(sz) else np.inf
                    break
                if sz <= tol:
                    break
            ok = ok and sz <= tol
        iters[i] = its
        conv[i] = 1 if ok else 0
        ratio[i] = rat
        # velocities, accelerations: forward substitution through the blocks with the
        # diagonal blocks at the converged positions (solve_points')
        for a in range(W):          # ground columns too
            Qd[qo + a] = 0.0
            Qdd[qo + a] = 0.0
        for lev in range(1, 3):
            X = Qd if lev == 1 else Qdd
            for b in range(nblk):
                kb = bk[b]
                bo = boff[b]
                go = 6 * bo
                M = mof[b]
                if lev == 1 and not keep[b]:
                    for rp in range(kb):
                        row = brows[bo + rp]
                        e = rowel[row]
                        row_eval(ekind[e], ebi[e], ebj[e], prm, pb + 8 * e, roweq[row], Q, qo, C,
                                 S, 0, Q, 2, GR, go + 6 * rp)
                    block_matrix(kb, brows, bo, rpos, GR, go, J)
                    if kb == 1:
                        MB[M] = 1.0 / J[0]
                    elif kb == 2:
                        rd = 1.0 / (J[0] * J[3] - J[1] * J[2])
                        MB[M] = J[3] * rd
                        MB[M + 1] = -J[1] * rd
                        MB[M + 2] = -J[2] * rd
                        MB[M + 3] = J[0] * rd
                    else:
                        gauss_jordan(kb, J, 0, MB, M, WK)
                for rp in range(kb):
                    row = brows[bo + rp]
                    e = rowel[row]
                    if lev == 1:
                        acc = NU[ti + row]
                    else:
                        _, gam = row_eval(ekind[e], ebi[e], ebj[e], prm, pb + 8 * e, roweq[row],
                                          Q, qo, C, S, 0, Qd, 4, GR, 0)
                        acc = gam + FDD[ti + row]
                    acc -= dot6(GR, go + 6 * rp, rcol, 6 * row, X, qo)
                    r[rp] = acc
                for a in range(kb):
                    x = 0.0
                    for k in range(kb):
                        x += MB[M + a * kb + k] * r[k]
                    X[qo + bcols[bo + a]] = x
        if test:
            jerk_ok = accept_point(i, W, n, nblk, nfine, Q, Qd, Qdd, smin, sign, conv[i],
                                   ratio[i], has_t, trow, has_v, vrow, tg, sign0, jerk,
                                   jerk_ok, good, perr)


# the entry points' one signature each, compiled (or loaded from the cache) when a job takes
# the route: kernel.Library.need
SIGNATURES = {
    "solve_each": (INT, INT, INT, INT, INT, I64, I64, I64, I64, I64, I64, I64, I64, I64, I64,
                   F64, F64, F64, F64, F64, F64, INT, DBL, INT, I64, U8, F64, F64, F64, U8, I64,
                   I64, INT, I64, I64, I64, I64, INT, I64, F64, INT, INT, I64, F64, F64, INT,
                   U8, F64),
}
