"""An experiment for issue 32 item 3 (not on the route): one generic numba kernel for the grid
pass that reads the structure from arrays once per block and loops over the points inside
(rows outer, points inner), where the generic engine of 2026-12-07 morning
(generic-engine.patch) read it at every point.

The algorithm and the arithmetic are the generated kernels' (planarkin.solver.compiled.gen),
operation for operation: the blocks in order; an affine block one exact Newton step per point
(the points in tiles of TILE, every block of a run of affine blocks over a tile before the next
tile, so that a tile's numbers stay in cache); any other block Newton for all points together
until every correction is at most tol; the residuals, velocities and accelerations by the same
substitutions summed in the same pairs; the same kind functions (planarkin.elements.pointline).
Covered: blocks of 1 and 2 unknowns (the generated kernels' closed forms; no dense block), the
grid's order 2. `each` is the studies' point-by-point solve (gen_each's algorithm: each point to
its own convergence, its variant's parameters from a table, then the velocities, the
accelerations and the studies' acceptance tests), rows outer likewise.
bench_rows_outer.py compares both with the generated kernels, bits and time.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from planarkin.elements import pointline as E
from planarkin.solver.compiled import helpers as K

sign_of, nanmax, ratio_of, inf_unless_finite = K.sign_of, K.nanmax, K.ratio_of, K.inf_unless_finite
ROWSIG = (numba.int64,) + (numba.float64,) * 22
_opts = dict(error_model="numpy", _nrt=False, cache=True)
k_rev = numba.njit([ROWSIG], **_opts)(E.revolute)
k_tra = numba.njit([ROWSIG], **_opts)(E.translational)
k_ang = numba.njit([ROWSIG], **_opts)(E.angle)
k_xd = numba.njit([ROWSIG], **_opts)(E.xdistance)
k_yd = numba.njit([ROWSIG], **_opts)(E.ydistance)
k_di = numba.njit([ROWSIG], **_opts)(E.distance)
k_ps = numba.njit([ROWSIG], **_opts)(E.pinslot)
k_sl = numba.njit([ROWSIG], **_opts)(E.slide)

inline = numba.njit(inline="always", error_model="numpy", _nrt=False)


@inline
def row(kd, eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
        wi, vxj, vyj, wj):
    if kd == 1:
        return k_rev(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 2:
        return k_tra(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 3:
        return k_ang(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 4:
        return k_xd(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                    vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 5:
        return k_yd(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                    vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 6:
        return k_di(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                    vxi, vyi, wi, vxj, vyj, wj)[eq]
    if kd == 7:
        return k_ps(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                    vxi, vyi, wi, vxj, vyj, wj)[eq]
    return k_sl(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                vxi, vyi, wi, vxj, vyj, wj)[eq]


@inline
def at(kd, eq, want, i, a, b, p, Q, C, S, Qd, rates):
    """Row (kind kd, equation eq) of element e on bodies a, b at point i."""
    vxi = vyi = wi = vxj = vyj = wj = 0.0
    if rates:
        vxi, vyi, wi = Qd[i, 3 * a], Qd[i, 3 * a + 1], Qd[i, 3 * a + 2]
        vxj, vyj, wj = Qd[i, 3 * b], Qd[i, 3 * b + 1], Qd[i, 3 * b + 2]
    return row(kd, eq, want, Q[i, 3 * a], Q[i, 3 * a + 1], Q[i, 3 * a + 2], C[i, a], S[i, a],
               Q[i, 3 * b], Q[i, 3 * b + 1], Q[i, 3 * b + 2], C[i, b], S[i, b],
               p[0], p[1], p[2], p[3], p[4], p[5], vxi, vyi, wi, vxj, vyj, wj)


@inline
def _add(a, ha, b, hb):
    if not ha:
        return b, hb
    if not hb:
        return a, ha
    return a + b, True


@inline
def pairs(d, kn, rc, X, i):
    """((t0 + t1) + (t2 + t3)) + (t4 + t5), t_k = d[k] X[i, rc[k]] where kn[k], the others
    left out; (sum, any)."""
    t0 = d[0] * X[i, rc[0]] if kn[0] else 0.0
    t1 = d[1] * X[i, rc[1]] if kn[1] else 0.0
    t2 = d[2] * X[i, rc[2]] if kn[2] else 0.0
    t3 = d[3] * X[i, rc[3]] if kn[3] else 0.0
    t4 = d[4] * X[i, rc[4]] if kn[4] else 0.0
    t5 = d[5] * X[i, rc[5]] if kn[5] else 0.0
    a, ha = _add(t0, kn[0] != 0, t1, kn[1] != 0)
    b, hb = _add(t2, kn[2] != 0, t3, kn[3] != 0)
    c, hc = _add(t4, kn[4] != 0, t5, kn[5] != 0)
    ab, hab = _add(a, ha, b, hb)
    return _add(ab, hab, c, hc)


@inline
def rhs_of(base, d, kn, rc, X, i):
    s, h = pairs(d, kn, rc, X, i)
    return base - s if h else base


@inline
def entries(src, d0, d1):
    """The 2 x 2 (or 1 x 1) block matrix's entries from the rows' gradients d0, d1."""
    J0 = d0[src[0]] if src[0] >= 0 else 0.0
    J1 = 0.0
    J2 = 0.0
    J3 = 0.0
    if src[1] >= 0:
        J1 = d0[src[1]]
    if src[2] >= 0:
        J2 = d1[src[2]]
    if src[3] >= 0:
        J3 = d1[src[3]]
    return J0, J1, J2, J3


@inline
def rates(kb, have, i, B, d0, d1, JJ, A):
    """gen.Writer.rates: velocities, accelerations (and with have the residuals) of a block at
    its converged positions, d0, d1 the rows' gradients and JJ the block matrix."""
    Q, Qd, Qdd, C, S, T, NU, FDD, R = A
    (_, _, _, _, _, bi, _, rc0, kn0, rc1, kn1, p0, p1) = B
    r0, kd0, eq0, a0, b0, c0, r1, kd1, eq1, a1, b1, c1 = bi
    J0, J1, J2, J3 = JJ
    g0 = d0[1:7]
    g1 = d1[1:7]
    vr0 = rhs_of(NU[i, r0], g0, kn0, rc0, Qd, i)
    if kb == 1:
        Qd[i, c0] = vr0 * (1.0 / J0)
    else:
        vr1 = rhs_of(NU[i, r1], g1, kn1, rc1, Qd, i)
        vdet = J0 * J3 - J1 * J2
        Qd[i, c0] = (J3 * vr0 - J1 * vr1) / vdet
        Qd[i, c1] = (J0 * vr1 - J2 * vr0) / vdet
    if have:
        h = at(kd0, eq0, 5, i, a0, b0, p0, Q, C, S, Qd, True)
        R[i, r0] = abs(h[0] - T[i, r0])
        gm0 = h[7]
        gm1 = 0.0
        if kb == 2:
            h = at(kd1, eq1, 5, i, a1, b1, p1, Q, C, S, Qd, True)
            R[i, r1] = abs(h[0] - T[i, r1])
            gm1 = h[7]
    else:
        gm0 = at(kd0, eq0, 4, i, a0, b0, p0, Q, C, S, Qd, True)[7]
        gm1 = 0.0
        if kb == 2:
            gm1 = at(kd1, eq1, 4, i, a1, b1, p1, Q, C, S, Qd, True)[7]
    ar0 = rhs_of(gm0 + FDD[i, r0], g0, kn0, rc0, Qdd, i)
    if kb == 1:
        Qdd[i, c0] = ar0 * (1.0 / J0)
    else:
        ar1 = rhs_of(gm1 + FDD[i, r1], g1, kn1, rc1, Qdd, i)
        adet = J0 * J3 - J1 * J2
        Qdd[i, c0] = (J3 * ar0 - J1 * ar1) / adet
        Qdd[i, c1] = (J0 * ar1 - J2 * ar0) / adet


@inline
def block_of(blk, BL, RW, RC, KN, SRC, prm):
    """What the passes over points read of block blk, read once."""
    kb = BL[blk, 0]
    w0 = BL[blk, 5]
    r0, kd0, eq0, a0, b0, e0 = RW[w0, 0], RW[w0, 1], RW[w0, 2], RW[w0, 3], RW[w0, 4], RW[w0, 5]
    w1 = BL[blk, 6]
    r1, kd1, eq1, a1, b1, e1 = RW[w1, 0], RW[w1, 1], RW[w1, 2], RW[w1, 3], RW[w1, 4], RW[w1, 5]
    p0 = (prm[e0, 0], prm[e0, 1], prm[e0, 2], prm[e0, 3], prm[e0, 4], prm[e0, 5])
    p1 = (prm[e1, 0], prm[e1, 1], prm[e1, 2], prm[e1, 3], prm[e1, 4], prm[e1, 5])
    bi = (r0, kd0, eq0, a0, b0, BL[blk, 7], r1, kd1, eq1, a1, b1, BL[blk, 8])
    src = (SRC[blk, 0], SRC[blk, 1], SRC[blk, 2], SRC[blk, 3])
    rc0 = (RC[r0, 0], RC[r0, 1], RC[r0, 2], RC[r0, 3], RC[r0, 4], RC[r0, 5])
    rc1 = (RC[r1, 0], RC[r1, 1], RC[r1, 2], RC[r1, 3], RC[r1, 4], RC[r1, 5])
    kn0 = (KN[r0, 0], KN[r0, 1], KN[r0, 2], KN[r0, 3], KN[r0, 4], KN[r0, 5])
    kn1 = (KN[r1, 0], KN[r1, 1], KN[r1, 2], KN[r1, 3], KN[r1, 4], KN[r1, 5])
    return (kb, BL[blk, 1] != 0, BL[blk, 2] != 0, BL[blk, 3], BL[blk, 4], bi, src,
            rc0, kn0, rc1, kn1, p0, p1)


@inline
def evaluate(kb, i, B, Q, C, S, Qd):
    """The block's rows at point i with their gradients, and the block matrix."""
    (_, _, _, _, _, bi, src, _, _, _, _, p0, p1) = B
    r0, kd0, eq0, a0, b0, c0, r1, kd1, eq1, a1, b1, c1 = bi
    d0 = at(kd0, eq0, 3, i, a0, b0, p0, Q, C, S, Qd, False)
    d1 = d0
    if kb == 2:
        d1 = at(kd1, eq1, 3, i, a1, b1, p1, Q, C, S, Qd, False)
    return d0, d1, entries(src, d0[1:7], d1[1:7])


@inline
def invert(kb, JJ):
    """The block matrix's inverse entries, sigma_min bound and determinant sign (closed
    forms)."""
    J0, J1, J2, J3 = JJ
    if kb == 1:
        return 1.0 / J0, 0.0, 0.0, 0.0, abs(J0), sign_of(J0)
    det = J0 * J3 - J1 * J2
    ok2 = math.isfinite(det) and det != 0
    inv = 1.0 / (det if ok2 else np.nan)
    sm = abs(det) / np.sqrt(J0 * J0 + J1 * J1 + J2 * J2 + J3 * J3) if ok2 else 0.0
    return J3 * inv, -J1 * inv, -J2 * inv, J0 * inv, sm, sign_of(det) if ok2 else 0.0


@inline
def step(kb, i, B, g0, g1, M0, M1, M2, M3, Q, C, S, T):
    """dx = M r applied to the block's columns (their angles' cosines and sines too); the
    largest |dx| (inf where not finite)."""
    bi = B[5]
    r0, c0, r1, c1 = bi[0], bi[5], bi[6], bi[11]
    rr0 = g0 - T[i, r0]
    if kb == 1:
        dx0 = M0 * rr0
        q = Q[i, c0] - dx0
        Q[i, c0] = q
        if c0 % 3 == 2:
            C[i, c0 // 3] = np.cos(q)
            S[i, c0 // 3] = np.sin(q)
        return inf_unless_finite(abs(dx0))
    rr1 = g1 - T[i, r1]
    dx0 = M0 * rr0 + M1 * rr1
    q = Q[i, c0] - dx0
    Q[i, c0] = q
    if c0 % 3 == 2:
        C[i, c0 // 3] = np.cos(q)
        S[i, c0 // 3] = np.sin(q)
    dx1 = M2 * rr0 + M3 * rr1
    q = Q[i, c1] - dx1
    Q[i, c1] = q
    if c1 % 3 == 2:
        C[i, c1 // 3] = np.cos(q)
        S[i, c1 // 3] = np.sin(q)
    return inf_unless_finite(nanmax(abs(dx0), abs(dx1)))


@inline
def signs(i, blk, B, sm, sg, JJ, sign, smin):
    smin[i, blk] = sm
    if B[4] == 1:
        sign[i, B[3]] = sg
    else:
        sign[i, B[3]] = sign_of(JJ[0])
        sign[i, B[3] + 1] = sign_of(JJ[3])


@inline
def residuals(kb, i, B, d0, d1, T, R):
    bi = B[5]
    R[i, bi[0]] = abs(d0[0] - T[i, bi[0]])
    if kb == 2:
        R[i, bi[6]] = abs(d1[0] - T[i, bi[6]])


@inline
def affine(blk, lo, hi, B, A, iters, conv, ratio, sign, smin):
    """An affine block (one Newton step, exact) at points lo..hi, then its rates."""
    Q, Qd, Qdd, C, S, T, NU, FDD, R = A
    kb = B[0]
    have = B[2]
    for i in range(lo, hi):
        d0, d1, JJ = evaluate(kb, i, B, Q, C, S, Qd)
        M0, M1, M2, M3, sm, sg = invert(kb, JJ)
        sz = step(kb, i, B, d0[0], d1[0], M0, M1, M2, M3, Q, C, S, T)
        signs(i, blk, B, sm, sg, JJ, sign, smin)
        ratio[i] = nanmax(ratio[i], ratio_of(sz, sm))
        if not math.isfinite(sz):
            conv[i] = 0
        if not have:
            d0, d1, JJ = evaluate(kb, i, B, Q, C, S, Qd)
            residuals(kb, i, B, d0, d1, T, R)
        rates(kb, have, i, B, d0, d1, JJ, A)
        iters[i] = max(iters[i], 1)


@inline
def newton(blk, N, B, A, maxit, tol, full, iters, conv, ratio, sign, smin, MI, SZ):
    """A block that is not affine: Newton for all points together until every point's
    correction is at most tol, then per point its convergence, residuals and rates."""
    Q, Qd, Qdd, C, S, T, NU, FDD, R = A
    kb = B[0]
    bi = B[5]
    for it in range(maxit):
        small = True
        for i in range(N):
            if it == 0 or full != 0:
                d0, d1, JJ = evaluate(kb, i, B, Q, C, S, Qd)
                g0 = d0[0]
                g1 = d1[0]
                M0, M1, M2, M3, sm, sg = invert(kb, JJ)
                MI[i, 0] = M0
                MI[i, 1] = M1
                MI[i, 2] = M2
                MI[i, 3] = M3
                if it == 0:
                    signs(i, blk, B, sm, sg, JJ, sign, smin)
            else:
                g0 = at(bi[1], bi[2], 1, i, bi[3], bi[4], B[11], Q, C, S, Qd, False)[0]
                g1 = 0.0
                if kb == 2:
                    g1 = at(bi[7], bi[8], 1, i, bi[9], bi[10], B[12], Q, C, S, Qd, False)[0]
                M0, M1, M2, M3 = MI[i, 0], MI[i, 1], MI[i, 2], MI[i, 3]
            sz = step(kb, i, B, g0, g1, M0, M1, M2, M3, Q, C, S, T)
            if it == 0:
                ratio[i] = nanmax(ratio[i], ratio_of(sz, smin[i, blk]))
            iters[i] = max(iters[i], it + 1)
            SZ[i] = sz
            small = small & (sz <= tol)
        if small:
            break
    for i in range(N):
        conv[i] = 1 if (conv[i] != 0 and SZ[i] <= tol) else 0
        d0, d1, JJ = evaluate(kb, i, B, Q, C, S, Qd)
        residuals(kb, i, B, d0, d1, T, R)
        rates(kb, False, i, B, d0, d1, JJ, A)


TILE = 256


@numba.njit(error_model="numpy", _nrt=False, cache=True, nogil=True)
def grid(N, n, nb, Q, Qd, Qdd, C, S, T, NU, FDD, prm, maxit, tol, full, iters, conv, ratio,
         sign, smin, R, rmax, cond, MI, SZ, BL, RW, RC, KN, SRC, LEFT, pred):
    """BL (nblk, 9): k, affine, fixed, first fine, fine count, rows (2), columns (2).
    RW (rows, 6): row, kind, eq, a, b, e. RC, KN (m, 6): each row's gradient columns and
    whether they are known (earlier blocks'). SRC (nblk, 4): the block matrix entries'
    gradient positions (row rp's k, -1 none)."""
    W = n + 3
    havep, t, idx, Tn, Qn, Qdn, Qddn, Qf = pred
    for i in range(N):
        if havep != 0:
            K.hermite_row(t[i], idx[i], W, Tn, Qn, Qdn, Qddn, Qf, i * W)
        for b in range(nb):
            C[i, b] = np.cos(Q[i, 3 * b + 2])
            S[i, b] = np.sin(Q[i, 3 * b + 2])
        C[i, nb] = 1.0
        S[i, nb] = 0.0
        iters[i] = 0
        conv[i] = 1
        ratio[i] = 0.0
        for a in range(W):
            Qd[i, a] = 0.0
            Qdd[i, a] = 0.0
    A = (Q, Qd, Qdd, C, S, T, NU, FDD, R)
    nblk = BL.shape[0]
    b = 0
    while b < nblk:
        if BL[b, 1] != 0:
            e = b
            while e < nblk and BL[e, 1] != 0:
                e += 1
            for lo in range(0, N, TILE):
                hi = min(lo + TILE, N)
                for blk in range(b, e):
                    B = block_of(blk, BL, RW, RC, KN, SRC, prm)
                    affine(blk, lo, hi, B, A, iters, conv, ratio, sign, smin)
            b = e
        else:
            B = block_of(b, BL, RW, RC, KN, SRC, prm)
            newton(b, N, B, A, maxit, tol, full, iters, conv, ratio, sign, smin, MI, SZ)
            b += 1
    m = R.shape[1]
    for i in range(N):
        for w in range(LEFT.shape[0]):
            r, kd, eq, a, bb, e = (LEFT[w, 0], LEFT[w, 1], LEFT[w, 2], LEFT[w, 3], LEFT[w, 4],
                                   LEFT[w, 5])
            p = (prm[e, 0], prm[e, 1], prm[e, 2], prm[e, 3], prm[e, 4], prm[e, 5])
            g = at(kd, eq, 1, i, a, bb, p, Q, C, S, Qd, False)[0]
            R[i, r] = abs(g - T[i, r])
        mx = R[i, 0]
        for k in range(1, m):
            mx = nanmax(mx, R[i, k])
        rmax[i] = mx
        x = smin[i, 0]
        cd = 1.0 / (x if (x >= 1e-300 or x != x) else 1e-300)
        for k in range(1, nblk):
            x = smin[i, k]
            cd = nanmax(cd, 1.0 / (x if (x >= 1e-300 or x != x) else 1e-300))
        cond[i] = cd
        for a in range(n):
            if not math.isfinite(Q[i, a]):
                conv[i] = 0


def arrays(P, n, m, nb):
    """The structure arrays of packed system P for grid (blocks of at most 2 unknowns)."""
    ekind, ebi, ebj, _, rowel, roweq, bk, boff, baff, bcols, brows = P.arrays
    _, rcol, rpos = P.tail
    bfirst, bnf = P.fine[0], P.fine[1]
    nblk = len(bk)
    assert int(bk.max()) <= 2
    colblock = np.full(n + 3, nblk, dtype=np.int64)
    for b in range(nblk):
        colblock[bcols[boff[b]:boff[b] + bk[b]]] = b
    rowblock = np.full(m, -1, dtype=np.int64)
    for b in range(nblk):
        rowblock[brows[boff[b]:boff[b] + bk[b]]] = b
    RC = np.ascontiguousarray(rcol, dtype=np.int64)
    KN = np.zeros((m, 6), dtype=np.int64)
    for r in range(m):
        b = rowblock[r]
        if b >= 0:
            KN[r] = [(c < n and colblock[c] < b) for c in RC[r]]
    RW = np.zeros((m, 6), dtype=np.int64)
    for r in range(m):
        e = rowel[r]
        RW[r] = [r, ekind[e], roweq[r], ebi[e], ebj[e], e]
    BL = np.zeros((nblk, 9), dtype=np.int64)
    SRC = np.full((nblk, 4), -1, dtype=np.int64)
    for b in range(nblk):
        kb = int(bk[b])
        rows = brows[boff[b]:boff[b] + kb]
        cols = bcols[boff[b]:boff[b] + kb]
        BL[b] = [kb, baff[b], P.fixed[b], bfirst[b], bnf[b], rows[0], rows[-1], cols[0],
                 cols[-1]]
        for rp, r in enumerate(rows):
            for k in range(6):
                pos = int(rpos[r, k])
                if pos >= 0:
                    SRC[b, rp * kb + pos] = k
    left = [r for r in range(m) if rowblock[r] < 0]
    LEFT = RW[left] if left else np.zeros((0, 6), dtype=np.int64)
    return BL, RW, RC, KN, SRC, np.ascontiguousarray(LEFT)


_NF = np.zeros(0)
_NI = np.zeros(0, dtype=np.int64)
NO_PRED = (0, _NF, _NI, _NF, _NF, _NF, _NF, _NF)   # no predictions written by the kernel


def drop_in(P, W, m, nb):
    """A function with the generated kernel's signature (kernels.solve calls it) that runs
    grid: for the whole-solve comparison."""
    ST = arrays(P, W - 3, m, nb)
    kept = {}

    def fn(N, Q, Qd, Qdd, T, NU, FDD, prm, maxit, tol, full, order, iters, conv, ratio, sign,
           smin, R, rmax, cond, havep, t, idx, Tn, Qn, Qdn, Qddn, Qf):
        bufs = kept.get(N)
        if bufs is None:
            bufs = kept[N] = (np.empty((N, nb + 1)), np.empty((N, nb + 1)),
                              np.empty((N, 4)), np.empty(N))
        C, Sn, MI, SZ = bufs
        grid(N, W - 3, nb, Q, Qd, Qdd, C, Sn, T, NU, FDD, prm, maxit, tol, full, iters, conv,
             ratio, sign, smin, R, rmax, cond, MI, SZ, *ST,
             (havep, t, idx, Tn, Qn, Qdn, Qddn, Qf))
    return fn


# -- the studies' point-by-point solve (gen_each's algorithm), rows outer ----------------------

@inline
def at_each(kd, eq, want, o, a, b, nb, p, Q, C, S, i, V, vo, rates):
    """Row (kind kd, equation eq) at flat point offset o (Q, V flat rows of W), element
    parameters p; the ground's coordinates and rates zero, its cosine 1 and sine 0."""
    xi = yi = pi = xj = yj = pj = 0.0
    vxi = vyi = wi = vxj = vyj = wj = 0.0
    if a != nb:
        xi, yi, pi = Q[o + 3 * a], Q[o + 3 * a + 1], Q[o + 3 * a + 2]
        if rates:
            vxi, vyi, wi = V[vo + 3 * a], V[vo + 3 * a + 1], V[vo + 3 * a + 2]
    if b != nb:
        xj, yj, pj = Q[o + 3 * b], Q[o + 3 * b + 1], Q[o + 3 * b + 2]
        if rates:
            vxj, vyj, wj = V[vo + 3 * b], V[vo + 3 * b + 1], V[vo + 3 * b + 2]
    return row(kd, eq, want, xi, yi, pi, C[i, a], S[i, a], xj, yj, pj, C[i, b], S[i, b],
               p[0], p[1], p[2], p[3], p[4], p[5], vxi, vyi, wi, vxj, vyj, wj)


@inline
def params(prm, pb, e):
    o = pb + 8 * e
    return (prm[o], prm[o + 1], prm[o + 2], prm[o + 3], prm[o + 4], prm[o + 5])


@inline
def each_rows(kb, i, B, Q, C, S, prm, pb, o, nb, want):
    """The block's rows at point i (gradients with want & 2) and its matrix."""
    bi, src = B[5], B[6]
    d0 = at_each(bi[1], bi[2], want, o, bi[3], bi[4], nb, params(prm, pb, B[11]), Q, C, S, i,
                 Q, 0, False)
    d1 = d0
    if kb == 2:
        d1 = at_each(bi[7], bi[8], want, o, bi[9], bi[10], nb, params(prm, pb, B[12]), Q, C, S,
                     i, Q, 0, False)
    return d0, d1, entries(src, d0[1:7], d1[1:7])


@inline
def each_block_of(blk, BL, RW, RC, KN, SRC):
    """block_of for the studies' solve: the elements' indices, not their parameters (each
    point reads its variant's)."""
    kb = BL[blk, 0]
    w0 = BL[blk, 5]
    w1 = BL[blk, 6]
    r0, kd0, eq0, a0, b0, e0 = RW[w0, 0], RW[w0, 1], RW[w0, 2], RW[w0, 3], RW[w0, 4], RW[w0, 5]
    r1, kd1, eq1, a1, b1, e1 = RW[w1, 0], RW[w1, 1], RW[w1, 2], RW[w1, 3], RW[w1, 4], RW[w1, 5]
    bi = (r0, kd0, eq0, a0, b0, BL[blk, 7], r1, kd1, eq1, a1, b1, BL[blk, 8])
    src = (SRC[blk, 0], SRC[blk, 1], SRC[blk, 2], SRC[blk, 3])
    rc0 = (RC[r0, 0], RC[r0, 1], RC[r0, 2], RC[r0, 3], RC[r0, 4], RC[r0, 5])
    rc1 = (RC[r1, 0], RC[r1, 1], RC[r1, 2], RC[r1, 3], RC[r1, 4], RC[r1, 5])
    kn0 = (KN[r0, 0], KN[r0, 1], KN[r0, 2], KN[r0, 3], KN[r0, 4], KN[r0, 5])
    kn1 = (KN[r1, 0], KN[r1, 1], KN[r1, 2], KN[r1, 3], KN[r1, 4], KN[r1, 5])
    return (kb, BL[blk, 1] != 0, BL[blk, 2] != 0, BL[blk, 3], BL[blk, 4], bi, src,
            rc0, kn0, rc1, kn1, e0, e1)


@inline
def pairs_flat(d, kn, rc, X, o):
    """pairs over a flat row: ((t0 + t1) + (t2 + t3)) + (t4 + t5), t_k = d[k] X[o + rc[k]]."""
    t0 = d[0] * X[o + rc[0]] if kn[0] else 0.0
    t1 = d[1] * X[o + rc[1]] if kn[1] else 0.0
    t2 = d[2] * X[o + rc[2]] if kn[2] else 0.0
    t3 = d[3] * X[o + rc[3]] if kn[3] else 0.0
    t4 = d[4] * X[o + rc[4]] if kn[4] else 0.0
    t5 = d[5] * X[o + rc[5]] if kn[5] else 0.0
    a, ha = _add(t0, kn[0] != 0, t1, kn[1] != 0)
    b, hb = _add(t2, kn[2] != 0, t3, kn[3] != 0)
    c, hc = _add(t4, kn[4] != 0, t5, kn[5] != 0)
    ab, hab = _add(a, ha, b, hb)
    return _add(ab, hab, c, hc)


@inline
def each_inverse(kb, JJ):
    """gen_each's inverse with newton: entries, sigma_min's bound, the determinant's sign."""
    J0, J1, J2, J3 = JJ
    if kb == 1:
        return 1.0 / J0, 0.0, 0.0, 0.0, abs(J0), sign_of(J0)
    det = J0 * J3 - J1 * J2
    rd = 1.0 / det
    nf = np.sqrt(J0 * J0 + J1 * J1 + J2 * J2 + J3 * J3) * abs(rd)
    s0 = 1.0 / nf if (math.isfinite(nf) and det != 0) else 0.0
    return J3 * rd, -J1 * rd, -J2 * rd, J0 * rd, s0, sign_of(det)


@inline
def each_position(blk, i, B, Q, C, S, T, prm, pb, o, ti, nb, nblk, nfine, maxit, tol, full,
                  smin, sign, st):
    """Block blk at point i, Newton to the point's own convergence (gen_each.position);
    st: (rat, its, ok) in, out."""
    kb, aff = B[0], B[1]
    bi = B[5]
    rat, its, ok = st
    sz = np.inf
    M0 = M1 = M2 = M3 = 0.0
    for it in range(1 if aff else maxit):
        d0, d1, JJ = each_rows(kb, i, B, Q, C, S, prm, pb, o, nb, 3)
        r0 = d0[0] - T[ti + bi[0]]
        r1 = d1[0] - T[ti + bi[6]] if kb == 2 else 0.0
        if aff or it == 0 or full != 0:
            M0, M1, M2, M3, s0, sg = each_inverse(kb, JJ)
            if it == 0:
                smin[i * nblk + blk] = s0
                if B[4] == 1:
                    sign[i * nfine + B[3]] = sg
                else:
                    sign[i * nfine + B[3]] = sign_of(JJ[0])
                    sign[i * nfine + B[3] + 1] = sign_of(JJ[3])
        sz = 0.0
        c0 = bi[5]
        dx = 0.0 + M0 * r0 + M1 * r1 if kb == 2 else 0.0 + M0 * r0
        q = Q[o + c0] - dx
        Q[o + c0] = q
        sz = nanmax(sz, abs(dx))
        if c0 % 3 == 2 and (dx != 0.0 or q == 0.0):
            C[i, c0 // 3] = np.cos(q)
            S[i, c0 // 3] = np.sin(q)
        if kb == 2:
            c1 = bi[11]
            dx = 0.0 + M2 * r0 + M3 * r1
            q = Q[o + c1] - dx
            Q[o + c1] = q
            sz = nanmax(sz, abs(dx))
            if c1 % 3 == 2 and (dx != 0.0 or q == 0.0):
                C[i, c1 // 3] = np.cos(q)
                S[i, c1 // 3] = np.sin(q)
        sz = inf_unless_finite(sz)
        if it == 0:
            rat = nanmax(rat, ratio_of(sz, smin[i * nblk + blk]))
        its = max(its, it + 1)
        if aff:
            sz = 0.0 if sz < np.inf else np.inf
            break
        if sz <= tol:
            break
    return rat, its, ok and sz <= tol


@inline
def each_rate(i, B, Q, C, S, X, base0, base1, prm, pb, o, nb, keep, fresh):
    """Block B's rows of the velocity or acceleration system at point i (gen_each.rate): the
    gradient and inverse at the converged positions (the same bits as the Newton step's where
    gen_each keeps those), rhs minus the known columns' terms, through the inverse. fresh:
    evaluate them and keep them in keep[i] (the velocities), else read them there (the
    accelerations)."""
    kb = B[0]
    bi = B[5]
    if fresh:
        d0, d1, JJ = each_rows(kb, i, B, Q, C, S, prm, pb, o, nb, 2)
        g0 = d0[1:7]
        g1 = d1[1:7]
        J0, J1, J2, J3 = JJ
        for k in range(6):
            keep[i, k] = g0[k]
            keep[i, 6 + k] = g1[k]
        keep[i, 12] = J0
        keep[i, 13] = J1
        keep[i, 14] = J2
        keep[i, 15] = J3
    else:
        g0 = (keep[i, 0], keep[i, 1], keep[i, 2], keep[i, 3], keep[i, 4], keep[i, 5])
        g1 = (keep[i, 6], keep[i, 7], keep[i, 8], keep[i, 9], keep[i, 10], keep[i, 11])
        J0, J1, J2, J3 = keep[i, 12], keep[i, 13], keep[i, 14], keep[i, 15]
    s, h = pairs_flat(g0, B[8], B[7], X, o)
    x0 = base0 - s if h else base0
    if kb == 1:
        X[o + bi[5]] = 0.0 + (1.0 / J0) * x0
        return
    s, h = pairs_flat(g1, B[10], B[9], X, o)
    x1 = base1 - s if h else base1
    rd = 1.0 / (J0 * J3 - J1 * J2)
    M0, M1, M2, M3 = J3 * rd, -J1 * rd, -J2 * rd, J0 * rd
    X[o + bi[5]] = 0.0 + M0 * x0 + M1 * x1
    X[o + bi[11]] = 0.0 + M2 * x0 + M3 * x1


@numba.njit(error_model="numpy", _nrt=False, cache=True, nogil=True)
def each(N, n, nb, Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, iters, conv, ratio, sign, smin,
         has_v, vrow, prm, ne, has_t, trow, tg, sign0, test, good, perr, C, S, jerk, KEEP,
         ST):
    """gen_each's solve, rows outer: the positions block by block over all points (each point
    to its own convergence), then the velocities, then the accelerations, then the studies'
    acceptance per point."""
    BL, RW, RC, KN, SRC, _ = ST
    W = n + 3
    m = RC.shape[0]
    nblk = BL.shape[0]
    nfine = sign.shape[0] // max(N, 1)
    for i in range(N):
        o = i * W
        for b in range(nb):
            q = Q[o + 3 * b + 2]
            if q == 0.0:
                C[i, b] = 1.0
                S[i, b] = 0.0
            else:
                C[i, b] = np.cos(q)
                S[i, b] = np.sin(q)
        C[i, nb] = 1.0
        S[i, nb] = 0.0
        ratio[i] = 0.0
        iters[i] = 0
        conv[i] = 1
        for c in range(W):
            Qd[o + c] = 0.0
            Qdd[o + c] = 0.0
    for blk in range(nblk):
        B = each_block_of(blk, BL, RW, RC, KN, SRC)
        for i in range(N):
            o = i * W
            ti = (trow[i] if has_t != 0 else i) * m
            pb = vrow[i] * 8 * ne if has_v != 0 else 0
            rat, its, ok = each_position(blk, i, B, Q, C, S, T, prm, pb, o, ti, nb, nblk,
                                         nfine, maxit, tol, full, smin, sign,
                                         (ratio[i], iters[i], conv[i] != 0))
            ratio[i] = rat
            iters[i] = its
            conv[i] = 1 if ok else 0
    for blk in range(nblk):
        B = each_block_of(blk, BL, RW, RC, KN, SRC)
        bi = B[5]
        for i in range(N):
            o = i * W
            ti = (trow[i] if has_t != 0 else i) * m
            pb = vrow[i] * 8 * ne if has_v != 0 else 0
            each_rate(i, B, Q, C, S, Qd, NU[ti + bi[0]], NU[ti + bi[6]], prm, pb, o, nb,
                      KEEP[blk], True)
    for blk in range(nblk):
        B = each_block_of(blk, BL, RW, RC, KN, SRC)
        bi = B[5]
        kb = B[0]
        for i in range(N):
            o = i * W
            ti = (trow[i] if has_t != 0 else i) * m
            pb = vrow[i] * 8 * ne if has_v != 0 else 0
            g0 = at_each(bi[1], bi[2], 4, o, bi[3], bi[4], nb, params(prm, pb, B[11]), Q, C,
                         S, i, Qd, o, True)[7]
            g1 = 0.0
            if kb == 2:
                g1 = at_each(bi[7], bi[8], 4, o, bi[9], bi[10], nb, params(prm, pb, B[12]), Q,
                             C, S, i, Qd, o, True)[7]
            each_rate(i, B, Q, C, S, Qdd, g0 + FDD[ti + bi[0]], g1 + FDD[ti + bi[6]], prm, pb,
                      o, nb, KEEP[blk], False)
    if test != 0:
        jerk_ok = False
        for i in range(N):
            jerk_ok = K.accept_point(i, W, n, nblk, nfine, Q, Qd, Qdd, smin, sign, conv[i],
                                     ratio[i], has_t, trow, has_v, vrow, tg, sign0, jerk,
                                     jerk_ok, good, perr)


def drop_in_each(P, W, m, nb):
    """A function with gen_each's signature (kernel.solve_rows calls it) that runs each."""
    ST = arrays(P, W - 3, m, nb)
    kept = {}

    def fn(N, Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, iters, conv, ratio, sign, smin, has_v,
           vrow, prm, ne, has_t, trow, tg, sign0, test, good, perr):
        bufs = kept.get(N)
        if bufs is None:
            bufs = kept[N] = (np.empty((N, nb + 1)), np.empty((N, nb + 1)),
                              np.empty(max(W - 3, 1)), np.empty((P.nblk, N, 16)))
        C, S, jerk, keep = bufs
        each(N, W - 3, nb, Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, iters, conv, ratio, sign,
             smin, has_v, vrow, prm, ne, has_t, trow, tg, sign0, test, good, perr, C, S, jerk,
             keep, ST)
    return fn
