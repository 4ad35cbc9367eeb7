"""An optional compiled kernel for the grid pass of systems of small blocks (issue 12 item 3).

The grid pass of planarkin.system solves, per time point, Newton on each small diagonal block,
then the velocity and acceleration systems. In numpy that is a few dozen array passes per block
and chunk, whose cost per point (3-4 us for the slider-crank and the four-bar) is 4-7 times
that of a compiled special-purpose library. This module holds the same algorithm as
System._solve_batch, the reference pass, written in C over points: the same Newton iterations
block by block (a block iterates until every point of the batch has converged, as the
reference does, so the iteration counts agree), the same determinant signs and sigma_min bounds
(Gauss-Jordan with partial pivoting, 1 / ||J^-1||_F), then per point the velocity and
acceleration systems by forward substitution through the blocks, with the gradients and gamma
at the converged positions.

It covers the kinds whose equations are the point-and-line formulas of reference §1-2
(revolute, translational, pin-slot, slide, angle, x, y, distance), fine blocks of up to KFINE
unknowns and solve blocks (the path follower's merged ones) of up to KMAX; any other kind or a
larger block keeps the numpy passes (pack returns None).

For design studies (studies.batch: variants x grid times as one batch) pk_solve and pk_rows
take per-point element parameters, an index per point into a table of parameter sets; pk_rows
solves point by point, each to its own convergence, and takes the study's acceptance tests in
the same pass (solve_rows).

No dependency: the source below is compiled once with the system's C compiler (``cc``) into a
per-user cache (PLANARKIN_CACHE, else $XDG_CACHE_HOME/planarkin or ~/.cache/planarkin), keyed
by the source's hash, and loaded with ctypes. The first run on a machine that meets a system the
kernel covers compiles it before solving anything (about 0.7 s of CPU, once per machine and
source version), so the route a run takes depends on the machine only (a working compiler),
never on what earlier runs left in the cache: identical input gives identical bytes on one
machine. A compiler that fails leaves a marker (``.failed``, with its message) so that later
runs do not try again. Without a compiler, with an unwritable cache or with PLANARKIN_KERNEL=0
the numpy passes run instead: same results to rounding (tests/test_perstep.py).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import numpy as np

KMAX = 64             # largest solve block (the path's merged blocks)
KFINE = 6             # largest fine block (of the grid pass: larger ones are J5's dense/sparse LU)

# kind codes of the C source; the kinds are matched by class, not by name
_CODES = {"Revolute": 1, "Translational": 2, "Angle": 3, "XDistance": 4, "YDistance": 5,
          "Distance": 6, "PinSlot": 7, "Slide": 8}
# parameter slots: p[0:2] si, p[2:4] sj, p[4:6] vi
_PARAMS = {1: ("si", "sj"), 2: ("si", "sj", "vi", "vj"), 3: (), 4: ("si", "sj"),
           5: ("si", "sj"), 6: ("si", "sj"), 7: ("si", "vi", "sj"), 8: ("si", "vi", "sj")}

SOURCE = r"""
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define KMAX 64   /* largest solve block */
#define KFINE 6   /* largest fine block */

/* one equation row of element e: value g, gradient over (x_i, y_i, phi_i, x_j, y_j, phi_j),
   gamma_g (needs qd); want: 1 g, 2 gradient, 4 gamma (reference sections 1, 2, 5) */
static void row_eval(int kind, int bi, int bj, const double *p, int eq, const double *q,
                     const double *c, const double *s, const double *qd, int want,
                     double *g, double *gr, double *gam)
{
    double ci = c[bi], si_ = s[bi], cj = c[bj], sj_ = s[bj];
    double six = ci * p[0] - si_ * p[1], siy = si_ * p[0] + ci * p[1];
    double sjx = cj * p[2] - sj_ * p[3], sjy = sj_ * p[2] + cj * p[3];
    double xi = q[3 * bi], yi = q[3 * bi + 1], xj = q[3 * bj], yj = q[3 * bj + 1];
    double hx = xj + sjx - xi - six, hy = yj + sjy - yi - siy;
    double wi = 0, wj = 0, hdx = 0, hdy = 0, kx = 0, ky = 0;
    if (want & 4) {
        wi = qd[3 * bi + 2]; wj = qd[3 * bj + 2];
        hdx = qd[3 * bj] - wj * sjy - qd[3 * bi] + wi * siy;
        hdy = qd[3 * bj + 1] + wj * sjx - qd[3 * bi + 1] - wi * six;
        kx = wj * wj * sjx - wi * wi * six;
        ky = wj * wj * sjy - wi * wi * siy;
    }
    int k;
    if (want & 2) for (k = 0; k < 6; k++) gr[k] = 0.0;
    switch (kind) {
    case 1:  /* revolute: r_i + s_i - r_j - s_j */
        if (eq == 0) {
            if (want & 1) *g = xi + six - xj - sjx;
            if (want & 2) { gr[0] = 1.0; gr[2] = -siy; gr[3] = -1.0; gr[5] = sjy; }
            if (want & 4) *gam = wi * wi * six - wj * wj * sjx;
        } else {
            if (want & 1) *g = yi + siy - yj - sjy;
            if (want & 2) { gr[1] = 1.0; gr[2] = six; gr[4] = -1.0; gr[5] = -sjx; }
            if (want & 4) *gam = wi * wi * siy - wj * wj * sjy;
        }
        return;
    case 3:  /* angle */
    angle:
        if (want & 1) *g = q[3 * bj + 2] - q[3 * bi + 2];
        if (want & 2) { gr[2] = -1.0; gr[5] = 1.0; }
        if (want & 4) *gam = 0.0;
        return;
    case 4:  /* x of h */
        if (want & 1) *g = hx;
        if (want & 2) { gr[0] = -1.0; gr[2] = siy; gr[3] = 1.0; gr[5] = -sjy; }
        if (want & 4) *gam = wj * wj * sjx - wi * wi * six;
        return;
    case 5:  /* y of h */
        if (want & 1) *g = hy;
        if (want & 2) { gr[1] = -1.0; gr[2] = -six; gr[4] = 1.0; gr[5] = sjx; }
        if (want & 4) *gam = wj * wj * sjy - wi * wi * siy;
        return;
    case 6: {  /* distance |h| */
        double d = hypot(hx, hy), ex = hx / d, ey = hy / d;
        if (want & 1) *g = d;
        if (want & 2) { gr[0] = -ex; gr[1] = -ey; gr[2] = ex * siy - ey * six; gr[3] = ex;
                        gr[4] = ey; gr[5] = ey * sjx - ex * sjy; }
        if (want & 4) { double ehd = ex * hdx + ey * hdy;
                        *gam = -(hdx * hdx + hdy * hdy - ehd * ehd) / d + ex * kx + ey * ky; }
        return; }
    case 2:  /* translational: the angle row, then the normal row */
        if (eq == 0) goto angle;
        /* fall through */
    case 7:
    case 8: {  /* line of body i through s_i along u_i = A_i v_i, normal n_i = R u_i */
        const double *v = (kind == 2) ? p + 4 : p + 4;
        double ux = ci * v[0] - si_ * v[1], uy = si_ * v[0] + ci * v[1], nx = -uy, ny = ux;
        if (kind == 8) {  /* slide: u^T h */
            if (want & 1) *g = ux * hx + uy * hy;
            if (want & 2) { gr[0] = -ux; gr[1] = -uy; gr[2] = nx * (hx + six) + ny * (hy + siy);
                            gr[3] = ux; gr[4] = uy; gr[5] = -(nx * sjx + ny * sjy); }
            if (want & 4) *gam = wi * wi * (ux * hx + uy * hy) - 2.0 * wi * (nx * hdx + ny * hdy)
                                 + ux * kx + uy * ky;
        } else {         /* n^T h */
            if (want & 1) *g = nx * hx + ny * hy;
            if (want & 2) { gr[0] = -nx; gr[1] = -ny; gr[2] = -(ux * (hx + six) + uy * (hy + siy));
                            gr[3] = nx; gr[4] = ny; gr[5] = ux * sjx + uy * sjy; }
            if (want & 4) *gam = wi * wi * (nx * hx + ny * hy) + 2.0 * wi * (ux * hdx + uy * hdy)
                                 + nx * kx + ny * ky;
        }
        return; }
    }
}

/* inverse of the k x k matrix J (row-major) by Gauss-Jordan with partial pivoting, as
   planarkin.linalg._inv_gauss_jordan: returns 1 and the determinant's sign, or 0 (singular:
   inverse nan, sign 0) */
static int invert(int k, const double *J, double *inv, double *sign, double *work)
{
    double (*A)[2 * KMAX] = (double (*)[2 * KMAX])work;   /* KMAX x 2 KMAX, on the heap */
    int i, j, r, col;
    double scale = 0.0, sg = 1.0;
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++) {
            A[i][j] = J[i * k + j]; A[i][k + j] = (i == j);
            double a = fabs(J[i * k + j]);
            if (a > scale || a != a) scale = a;
        }
    double tiny = (scale > 0 ? scale : 1.0) * 1e-300;
    int ok = 1;
    for (col = 0; col < k; col++) {
        int pr = col;
        for (r = col + 1; r < k; r++) if (fabs(A[r][col]) > fabs(A[pr][col])) pr = r;
        if (pr != col) {
            for (j = 0; j < 2 * k; j++) { double t = A[col][j]; A[col][j] = A[pr][j]; A[pr][j] = t; }
            sg = -sg;
        }
        double piv = A[col][col];
        if (!(fabs(piv) > tiny)) { ok = 0; piv = 1.0; }
        sg *= (piv > 0) - (piv < 0);
        for (j = 0; j < 2 * k; j++) A[col][j] /= piv;
        for (r = 0; r < k; r++) {
            if (r == col) continue;
            double f = A[r][col];
            if (f != 0.0) for (j = 0; j < 2 * k; j++) A[r][j] -= f * A[col][j];
        }
    }
    for (i = 0; i < k; i++) for (j = 0; j < k; j++) inv[i * k + j] = ok ? A[i][k + j] : NAN;
    *sign = ok ? sg : 0.0;
    return ok;
}

/* The block's matrix from its rows' gradients gr (kb x 6); rpos (m x 6): where each gradient
   entry of a row goes in its block's row (-1: another block's column) */
static void block_matrix(int kb, const int32_t *rows, const int32_t *rpos, const double *gr,
                         double *J)
{
    int rp, k;
    for (k = 0; k < kb * kb; k++) J[k] = 0.0;
    for (rp = 0; rp < kb; rp++) {
        const int32_t *pos = rpos + 6 * rows[rp];
        for (k = 0; k < 6; k++) if (pos[k] >= 0) J[rp * kb + pos[k]] = gr[rp * 6 + k];
    }
}

/* the element parameters of point i: eprm (E x 8) shared by all points, or with vrow (N) the
   table vprm (V x ne x 8) of parameter sets, row vrow[i] (a design study's variants) */
#define EPRM(i) (vrow ? vprm + (size_t)vrow[i] * 8 * ne : eprm)

/* all points of one batch; arrays row-major per point. inblk (m): the row is in a block; R
   (N, m): |Phi| of every row at the results; rcol (m x 6): the columns of each row's gradient
   entries; rpos: see block_matrix; sign (N, nfine) per fine block: solve block b holds bnf[b]
   fine blocks, the first numbered bfirst[b], their sizes bfs[bfo[b]...]. Returns 0, or -1
   when out of memory. */
int pk_solve(int N, int W, int m, int nb, int nblk,
             const int32_t *ekind, const int32_t *ebi, const int32_t *ebj, const double *eprm,
             const int32_t *rowel, const int32_t *roweq,
             const int32_t *bk, const int32_t *boff, const int32_t *baff,
             const int32_t *bcols, const int32_t *brows,
             double *Q, double *Qd, double *Qdd, const double *T, const double *NU,
             const double *FDD, int maxit, double tol, int full, int order,
             int64_t *iters, uint8_t *conv, double *ratio, double *sign, double *smin,
             const uint8_t *inblk, double *R, const int32_t *rcol, const int32_t *rpos,
             int nfine, const int32_t *bfirst, const int32_t *bnf, const int32_t *bfo,
             const int32_t *bfs, const int32_t *vrow, const double *vprm, int ne)
{
    int nbb = nb + 1, i, b, it, rp, a, k;
    int n = W - 3;
    double *C = malloc(sizeof(double) * (size_t)N * nbb);
    double *S = malloc(sizeof(double) * (size_t)N * nbb);
    int kmax = 1;
    for (b = 0; b < nblk; b++) if (bk[b] > kmax) kmax = bk[b];
    double *MI = malloc(sizeof(double) * (size_t)N * kmax * kmax);
    double *SZ = malloc(sizeof(double) * (size_t)N);
    int total = 0;
    for (b = 0; b < nblk; b++) total += bk[b] * bk[b];
    int nrow = boff[nblk - 1] + bk[nblk - 1];
    double *GR = malloc(sizeof(double) * (size_t)nrow * 6);
    double *MB = malloc(sizeof(double) * (size_t)(total > 0 ? total : 1));
    /* the block matrix and the Gauss-Jordan workspace on the heap: up to 64 unknowns they
       would take 100 KB of stack, more than some threads have */
    double *J = malloc(sizeof(double) * KMAX * KMAX);
    double *WK = malloc(sizeof(double) * 2 * KMAX * KMAX);
    if (!C || !S || !MI || !SZ || !GR || !MB || !J || !WK) {
        free(C); free(S); free(MI); free(SZ); free(GR); free(MB); free(J); free(WK);
        return -1;
    }
    for (i = 0; i < N; i++) {
        for (b = 0; b < nbb; b++) {
            C[(size_t)i * nbb + b] = cos(Q[(size_t)i * W + 3 * b + 2]);
            S[(size_t)i * nbb + b] = sin(Q[(size_t)i * W + 3 * b + 2]);
        }
        iters[i] = 0; conv[i] = 1; ratio[i] = 0.0;
    }
    /* positions: Newton block by block, every point of the batch (System._solve_batch) */
    for (b = 0; b < nblk; b++) {
        int kb = bk[b];
        const int32_t *cols = bcols + boff[b], *rows = brows + boff[b];
        int32_t rel[KMAX], req[KMAX];
        for (rp = 0; rp < kb; rp++) { rel[rp] = rowel[rows[rp]]; req[rp] = roweq[rows[rp]]; }
        for (i = 0; i < N; i++) SZ[i] = 0.0;
        for (it = 0; it < maxit; it++) {
            int refactor = (it == 0) || (full && !baff[b]);
            int all_small = 1;
            for (i = 0; i < N; i++) {
                double *q = Q + (size_t)i * W, *c = C + (size_t)i * nbb, *s = S + (size_t)i * nbb;
                double *Mi = MI + (size_t)i * kb * kb;
                double r[KMAX], gr[KMAX * 6], sg, sm;
                if (refactor) {
                    for (rp = 0; rp < kb; rp++) {
                        int e = rel[rp];
                        row_eval(ekind[e], ebi[e], ebj[e], EPRM(i) + 8 * e, req[rp], q, c, s, 0, 3,
                                 r + rp, gr + 6 * rp, 0);
                    }
                    block_matrix(kb, rows, rpos, gr, J);
                    if (kb == 1) {           /* as planarkin.system._invert */
                        Mi[0] = 1.0 / J[0];
                        sg = (J[0] > 0) - (J[0] < 0);
                        if (J[0] != J[0]) sg = NAN;
                        sm = fabs(J[0]);
                    } else {
                        int ok = invert(kb, J, Mi, &sg, WK);
                        double f = 0.0;
                        for (a = 0; a < kb * kb; a++) f += Mi[a] * Mi[a];
                        sm = ok ? 1.0 / sqrt(f) : 0.0;
                    }
                    if (it == 0) {
                        smin[(size_t)i * nblk + b] = sm;
                        if (bnf[b] == 1) sign[(size_t)i * nfine + bfirst[b]] = sg;
                        else {   /* a merged block: the signs of its fine blocks */
                            int f, o = 0;
                            for (f = 0; f < bnf[b]; f++) {
                                int sz = bfs[bfo[b] + f], u, v;
                                double sub[KFINE * KFINE], subinv[KFINE * KFINE], sf;
                                if (sz == 1) {
                                    double j = J[o * kb + o];
                                    sf = (j > 0) - (j < 0);
                                    if (j != j) sf = NAN;
                                } else {
                                    for (u = 0; u < sz; u++) for (v = 0; v < sz; v++)
                                        sub[u * sz + v] = J[(o + u) * kb + o + v];
                                    invert(sz, sub, subinv, &sf, WK);
                                }
                                sign[(size_t)i * nfine + bfirst[b] + f] = sf;
                                o += sz;
                            }
                        }
                    }
                }
                for (rp = 0; rp < kb; rp++) {
                    if (!refactor) {
                        int e = rel[rp];
                        row_eval(ekind[e], ebi[e], ebj[e], EPRM(i) + 8 * e, req[rp], q, c, s, 0, 1,
                                 r + rp, 0, 0);
                    }
                    r[rp] -= T[(size_t)i * m + rows[rp]];
                }
                double sz = 0.0;
                for (a = 0; a < kb; a++) {
                    double dx = 0.0;
                    for (k = 0; k < kb; k++) dx += Mi[a * kb + k] * r[k];
                    q[cols[a]] -= dx;
                    double ad = fabs(dx);
                    if (ad > sz || ad != ad) sz = ad;
                    if (cols[a] % 3 == 2) {
                        c[cols[a] / 3] = cos(q[cols[a]]);
                        s[cols[a] / 3] = sin(q[cols[a]]);
                    }
                }
                if (!isfinite(sz)) sz = INFINITY;
                if (it == 0) {
                    double sm0 = smin[(size_t)i * nblk + b];
                    double v = sm0 > 0 ? sz / sm0 : INFINITY;
                    if (v > ratio[i] || v != v) ratio[i] = v;
                }
                if (iters[i] < it + 1) iters[i] = it + 1;
                if (baff[b]) sz = isfinite(sz) ? 0.0 : INFINITY;
                SZ[i] = sz;
                if (!(sz <= tol)) all_small = 0;
            }
            if (baff[b] || all_small) break;
        }
        for (i = 0; i < N; i++) conv[i] = conv[i] && (SZ[i] <= tol);
    }
    /* velocities, accelerations: per point, forward substitution through the blocks with the
       diagonal blocks at the converged positions */
    for (i = 0; i < N; i++) {
        double *q = Q + (size_t)i * W, *c = C + (size_t)i * nbb, *s = S + (size_t)i * nbb;
        double *qd = Qd + (size_t)i * W, *qdd = Qdd + (size_t)i * W;
        int lev, mo, row;
        /* |Phi| of the rows outside the blocks (left out as redundant), and with order 0 of all */
        for (row = 0; row < m; row++) {
            if (inblk[row] && order >= 1) continue;
            double g;
            int e = rowel[row];
            row_eval(ekind[e], ebi[e], ebj[e], EPRM(i) + 8 * e, roweq[row], q, c, s, 0, 1, &g, 0,
                     0);
            R[(size_t)i * m + row] = fabs(g - T[(size_t)i * m + row]);
        }
        if (order < 1) continue;
        for (a = 0; a < n; a++) qd[a] = 0.0;
        if (order >= 2) for (a = 0; a < n; a++) qdd[a] = 0.0;
        for (lev = 1; lev <= (order >= 2 ? 2 : 1); lev++) {
            double *X = lev == 1 ? qd : qdd;
            mo = 0;
            for (b = 0; b < nblk; b++) {
                int kb = bk[b];
                const int32_t *cols = bcols + boff[b], *rows = brows + boff[b];
                int32_t rel[KMAX];
                double *gr = GR + 6 * boff[b], *Mi = MB + mo, r[KMAX], sg, gam;
                for (rp = 0; rp < kb; rp++) rel[rp] = rowel[rows[rp]];
                if (lev == 1) {
                    for (rp = 0; rp < kb; rp++) {
                        int e = rel[rp], row = rows[rp];
                        double g;
                        row_eval(ekind[e], ebi[e], ebj[e], EPRM(i) + 8 * e, roweq[row], q, c, s,
                                 0, 3, &g, gr + 6 * rp, 0);
                        R[(size_t)i * m + row] = fabs(g - T[(size_t)i * m + row]);
                    }
                    block_matrix(kb, rows, rpos, gr, J);
                    if (kb == 1) Mi[0] = 1.0 / J[0];
                    else invert(kb, J, Mi, &sg, WK);
                }
                for (rp = 0; rp < kb; rp++) {
                    int e = rel[rp], row = rows[rp];
                    double acc;
                    if (lev == 1) acc = NU[(size_t)i * m + row];
                    else {
                        row_eval(ekind[e], ebi[e], ebj[e], EPRM(i) + 8 * e, roweq[row], q, c, s, qd,
                                 4, 0, 0, &gam);
                        acc = gam + FDD[(size_t)i * m + row];
                    }
                    const int32_t *rc = rcol + 6 * row;
                    for (k = 0; k < 6; k++) acc -= gr[6 * rp + k] * X[rc[k]];
                    r[rp] = acc;
                }
                for (a = 0; a < kb; a++) {
                    double x = 0.0;
                    if (kb == 1) x = r[0] * Mi[0];
                    else for (k = 0; k < kb; k++) x += Mi[a * kb + k] * r[k];
                    X[cols[a]] = x;
                }
                mo += kb * kb;
            }
        }
    }
    free(C); free(S); free(MI); free(SZ); free(GR); free(MB); free(J); free(WK);
    return 0;
}

/* the grid pass's predictions: quintic Hermite interpolation (planarkin.solver.hermite5, same
   operations in the same order) between path nodes idx[i] and idx[i] + 1, rows of W numbers */
void pk_hermite(int N, int W, const double *t, const int64_t *idx, const double *Tn,
                const double *Qn, const double *Qdn, const double *Qddn, double *Q)
{
    int i, c;
    for (i = 0; i < N; i++) {
        int64_t k = idx[i];
        double h = Tn[k + 1] - Tn[k], s = (t[i] - Tn[k]) / h;
        double s2 = s * s, s3 = s2 * s, s4 = s3 * s, s5 = s3 * s2;
        double H0 = 1 - 10 * s3 + 15 * s4 - 6 * s5, H1 = s - 6 * s3 + 8 * s4 - 3 * s5;
        double H2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5, H3 = 10 * s3 - 15 * s4 + 6 * s5;
        double H4 = -4 * s3 + 7 * s4 - 3 * s5, H5 = 0.5 * s3 - s4 + 0.5 * s5;
        double h1 = H1 * h, h2 = H2 * h * h, h4 = H4 * h, h5 = H5 * h * h;
        const double *y0 = Qn + k * W, *d0 = Qdn + k * W, *a0 = Qddn + k * W;
        const double *y1 = y0 + W, *d1 = d0 + W, *a1 = a0 + W;
        double *q = Q + (size_t)i * W;
        for (c = 0; c < W; c++)
            q[c] = H0 * y0[c] + h1 * d0[c] + h2 * a0[c] + H3 * y1[c] + h4 * d1[c] + h5 * a1[c];
    }
}

/* pk_solve's arguments and results, point by point (a design study, studies.batch): each point
   solves its blocks in order, each block by Newton until that point's own correction is at
   most tol (so a point's result does not depend on the other points of the batch), 1 x 1 and
   2 x 2 blocks inverted in closed form (as studies.fused), then its velocities and
   accelerations as pk_solve. Always order 2; R: |Phi| of the rows outside the blocks only (or
   NULL: none). trow (N): the row of T, NU and FDD that point i reads (a study's grid times,
   the same for every variant), NULL: row i.
   With good (N) not NULL, studies.batch's acceptance tests of every point (Batch.accept is
   the numpy reference), while its numbers are at hand: good[i] = converged, finite Q, Qd, Qdd
   (W columns), first correction at most kappa sigma_min, 1 / min(smin) at most cond_max and
   every fine-block sign equal to sign0's (N, nfine); perr[i] = the Taylor predictor error
   (studies.warm._predictor_error, forwards and backwards, first n columns) of the interval
   from the point before, when that is the same variant (vrow) at the grid time before
   (times tg, indexed as T), else 0. */
int pk_rows(int N, int W, int m, int nb, int nblk,
            const int32_t *ekind, const int32_t *ebi, const int32_t *ebj, const double *eprm,
            const int32_t *rowel, const int32_t *roweq,
            const int32_t *bk, const int32_t *boff, const int32_t *baff,
            const int32_t *bcols, const int32_t *brows,
            double *Q, double *Qd, double *Qdd, const double *T, const double *NU,
            const double *FDD, int maxit, double tol, int full, int order,
            int64_t *iters, uint8_t *conv, double *ratio, double *sign, double *smin,
            const uint8_t *inblk, double *R, const int32_t *rcol, const int32_t *rpos,
            int nfine, const int32_t *bfirst, const int32_t *bnf, const int32_t *bfo,
            const int32_t *bfs, const int32_t *vrow, const double *vprm, int ne,
            const int32_t *trow, const double *tg, const double *sign0, double kappa,
            double cond_max, uint8_t *good, double *perr)
{
    int nbb = nb + 1, i, b, it, rp, a, k, mo;
    int n = W - 3, total = 0;
    for (b = 0; b < nblk; b++) total += bk[b] * bk[b];
    int nrow = boff[nblk - 1] + bk[nblk - 1];
    double *C = malloc(sizeof(double) * nbb), *S = malloc(sizeof(double) * nbb);
    double *GR = malloc(sizeof(double) * (size_t)nrow * 6);
    double *MB = malloc(sizeof(double) * (size_t)(total > 0 ? total : 1));
    double *J = malloc(sizeof(double) * KMAX * KMAX);
    double *WK = malloc(sizeof(double) * 2 * KMAX * KMAX);
    int *keep = malloc(sizeof(int) * nblk), *mof = malloc(sizeof(int) * nblk);
    double *jerk = malloc(sizeof(double) * (n > 0 ? n : 1));  /* the last interval's dA */
    int jerk_ok = 0;                                           /* it is the one before */
    if (!C || !S || !GR || !MB || !J || !WK || !keep || !mof || !jerk) {
        free(C); free(S); free(GR); free(MB); free(J); free(WK); free(keep); free(mof);
        free(jerk);
        return -1;
    }
    (void)order;
    /* keep[b]: the block's Newton matrix is the one at the converged positions, exactly, and
       serves the velocities and accelerations: an affine block (one iteration) whose rows'
       gradients do not depend on its unknowns (revolute, x, y: on the angles only; angle:
       constant) nor, for the revolute, x and y, on an angle among them */
    for (b = 0, mo = 0; b < nblk; b++) {
        keep[b] = baff[b];
        mof[b] = mo;
        mo += bk[b] * bk[b];
        for (rp = 0; rp < bk[b] && keep[b]; rp++) {
            int e = rowel[brows[boff[b] + rp]], kd = ekind[e];
            if (kd != 3 && kd != 1 && kd != 4 && kd != 5) keep[b] = 0;
            else if (kd != 3)
                for (a = 0; a < bk[b]; a++) {
                    int c = bcols[boff[b] + a];
                    if (c == 3 * ebi[e] + 2 || c == 3 * ebj[e] + 2) keep[b] = 0;
                }
        }
    }
    for (i = 0; i < N; i++) {
        double *q = Q + (size_t)i * W, *qd = Qd + (size_t)i * W, *qdd = Qdd + (size_t)i * W;
        size_t ti = (size_t)(trow ? trow[i] : i) * m;
        const double *ep = EPRM(i), *t = T + ti;
        double *sgn = sign + (size_t)i * nfine, *sm = smin + (size_t)i * nblk;
        double rat = 0.0;
        int its = 0, ok = 1, row, lev;
        for (b = 0; b < nbb; b++) {   /* (the ground's angle is 0: no call) */
            double ph = q[3 * b + 2];
            if (ph == 0.0) { C[b] = 1.0; S[b] = 0.0; } else { C[b] = cos(ph); S[b] = sin(ph); }
        }
        /* positions: block by block, Newton to this point's convergence */
        for (b = 0; b < nblk; b++) {
            int kb = bk[b];
            const int32_t *cols = bcols + boff[b], *rows = brows + boff[b];
            double r[KMAX], *gr = GR + 6 * boff[b], *Mi = MB + mof[b], sz = INFINITY;
            for (it = 0; it < maxit; it++) {
                int refactor = (it == 0) || (full && !baff[b]);
                for (rp = 0; rp < kb; rp++) {
                    int e = rowel[rows[rp]];
                    row_eval(ekind[e], ebi[e], ebj[e], ep + 8 * e, roweq[rows[rp]], q, C, S, 0,
                             refactor ? 3 : 1, r + rp, gr + 6 * rp, 0);
                    r[rp] -= t[rows[rp]];
                }
                if (refactor) {
                    double sg, s0;
                    block_matrix(kb, rows, rpos, gr, J);
                    if (kb == 1) {
                        Mi[0] = 1.0 / J[0];
                        sg = (J[0] > 0) - (J[0] < 0);
                        if (J[0] != J[0]) sg = NAN;
                        s0 = fabs(J[0]);
                    } else if (kb == 2) {
                        double det = J[0] * J[3] - J[1] * J[2], rd = 1.0 / det;
                        Mi[0] = J[3] * rd; Mi[1] = -J[1] * rd; Mi[2] = -J[2] * rd;
                        Mi[3] = J[0] * rd;
                        sg = (det > 0) - (det < 0);
                        if (det != det) sg = NAN;
                        double nf = sqrt(J[0] * J[0] + J[1] * J[1] + J[2] * J[2] + J[3] * J[3])
                                    * fabs(rd);
                        s0 = (isfinite(nf) && det != 0) ? 1.0 / nf : 0.0;
                    } else {
                        int okk = invert(kb, J, Mi, &sg, WK);
                        double f = 0.0;
                        for (a = 0; a < kb * kb; a++) f += Mi[a] * Mi[a];
                        s0 = okk ? 1.0 / sqrt(f) : 0.0;
                    }
                    if (it == 0) {
                        sm[b] = s0;
                        if (bnf[b] == 1) sgn[bfirst[b]] = sg;
                        else {   /* a merged block: the signs of its fine blocks */
                            int f, o = 0;
                            for (f = 0; f < bnf[b]; f++) {
                                int sz_ = bfs[bfo[b] + f], u, v;
                                double sub[KFINE * KFINE], subinv[KFINE * KFINE], sf;
                                if (sz_ == 1) {
                                    double j = J[o * kb + o];
                                    sf = (j > 0) - (j < 0);
                                    if (j != j) sf = NAN;
                                } else {
                                    for (u = 0; u < sz_; u++) for (v = 0; v < sz_; v++)
                                        sub[u * sz_ + v] = J[(o + u) * kb + o + v];
                                    invert(sz_, sub, subinv, &sf, WK);
                                }
                                sgn[bfirst[b] + f] = sf;
                                o += sz_;
                            }
                        }
                    }
                }
                sz = 0.0;
                for (a = 0; a < kb; a++) {
                    double dx = 0.0;
                    for (k = 0; k < kb; k++) dx += Mi[a * kb + k] * r[k];
                    q[cols[a]] -= dx;
                    double ad = fabs(dx);
                    if (ad > sz || ad != ad) sz = ad;
                    if (cols[a] % 3 == 2) {
                        C[cols[a] / 3] = cos(q[cols[a]]);
                        S[cols[a] / 3] = sin(q[cols[a]]);
                    }
                }
                if (!isfinite(sz)) sz = INFINITY;
                if (it == 0) {
                    double v = sm[b] > 0 ? sz / sm[b] : INFINITY;
                    if (v > rat || v != v) rat = v;
                }
                if (its < it + 1) its = it + 1;
                if (baff[b]) { sz = isfinite(sz) ? 0.0 : INFINITY; break; }
                if (sz <= tol) break;
            }
            ok = ok && (sz <= tol);
        }
        iters[i] = its; conv[i] = ok; ratio[i] = rat;
        /* |Phi| of the rows outside the blocks (left out as redundant); nan: not computed */
        for (row = 0; row < m && R; row++) {
            if (inblk[row]) { R[(size_t)i * m + row] = NAN; continue; }
            double g;
            int e = rowel[row];
            row_eval(ekind[e], ebi[e], ebj[e], ep + 8 * e, roweq[row], q, C, S, 0, 1, &g, 0, 0);
            R[(size_t)i * m + row] = fabs(g - t[row]);
        }
        /* velocities, accelerations: forward substitution through the blocks with the
           diagonal blocks at the converged positions (pk_solve's) */
        for (a = 0; a < W; a++) { qd[a] = 0.0; qdd[a] = 0.0; }   /* ground columns too */
        for (lev = 1; lev <= 2; lev++) {
            double *X = lev == 1 ? qd : qdd;
            for (b = 0; b < nblk; b++) {
                int kb = bk[b];
                const int32_t *cols = bcols + boff[b], *rows = brows + boff[b];
                double *gr = GR + 6 * boff[b], *M = MB + mof[b], r[KMAX], sg, gam;
                if (lev == 1 && !keep[b]) {
                    for (rp = 0; rp < kb; rp++) {
                        int e = rowel[rows[rp]];
                        double g;
                        row_eval(ekind[e], ebi[e], ebj[e], ep + 8 * e, roweq[rows[rp]], q, C, S,
                                 0, 2, &g, gr + 6 * rp, 0);
                    }
                    block_matrix(kb, rows, rpos, gr, J);
                    if (kb == 1) M[0] = 1.0 / J[0];
                    else if (kb == 2) {
                        double rd = 1.0 / (J[0] * J[3] - J[1] * J[2]);
                        M[0] = J[3] * rd; M[1] = -J[1] * rd; M[2] = -J[2] * rd; M[3] = J[0] * rd;
                    } else invert(kb, J, M, &sg, WK);
                }
                for (rp = 0; rp < kb; rp++) {
                    int row = rows[rp], e = rowel[row];
                    double acc;
                    if (lev == 1) acc = NU[ti + row];
                    else {
                        row_eval(ekind[e], ebi[e], ebj[e], ep + 8 * e, roweq[row], q, C, S, qd,
                                 4, 0, 0, &gam);
                        acc = gam + FDD[ti + row];
                    }
                    const int32_t *rc = rcol + 6 * row;
                    const double *g6 = gr + 6 * rp;
                    acc -= (g6[0] * X[rc[0]] + g6[1] * X[rc[1]]) + (g6[2] * X[rc[2]]
                           + g6[3] * X[rc[3]]) + (g6[4] * X[rc[4]] + g6[5] * X[rc[5]]);
                    r[rp] = acc;
                }
                for (a = 0; a < kb; a++) {
                    double x = 0.0;
                    for (k = 0; k < kb; k++) x += M[a * kb + k] * r[k];
                    X[cols[a]] = x;
                }
            }
        }
        if (!good) continue;
        /* the acceptance tests of the point, and of the interval from the point before */
        {
            int g = conv[i] && ratio[i] <= kappa, c;
            double lo = INFINITY, e = 0.0;
            for (c = 0; c < W && g; c++) g = isfinite(q[c]) && isfinite(qd[c]) && isfinite(qdd[c]);
            for (c = 0; c < nblk; c++) if (sm[c] < lo || sm[c] != sm[c]) lo = sm[c];
            if (lo != lo) g = 0;
            else if (g) g = 1.0 / (lo > 1e-300 ? lo : 1e-300) <= cond_max;
            for (c = 0; c < nfine && g; c++) g = sgn[c] == sign0[(size_t)i * nfine + c];
            good[i] = g;
            size_t k1 = trow ? trow[i] : i, k0 = i > 0 ? (trow ? trow[i - 1] : i - 1) : 0;
            if (i > 0 && k1 == k0 + 1 && (!vrow || vrow[i] == vrow[i - 1])) {
                double h = tg[k1] - tg[k0], hh = 0.5 * h * h, h3 = h * h * h / 6.0;
                const double *q0 = q - W, *d0 = qd - W, *a0 = qdd - W;
                int nan = 0;
                for (c = 0; c < n; c++) {
                    double dA = (qdd[c] - a0[c]) / h, j3 = jerk_ok ? jerk[c] : 0.0;
                    double ef = fabs(q[c] - (q0[c] + h * d0[c] + hh * a0[c] + h3 * j3));
                    double eb = fabs(q[c] - h * qd[c] + hh * qdd[c] - h3 * dA - q0[c]);
                    double x = ef > eb ? ef : eb;
                    jerk[c] = dA;
                    e = x > e ? x : e;
                    nan |= (ef != ef) | (eb != eb);
                }
                jerk_ok = 1;
                perr[i] = nan ? NAN : e;
            } else {
                jerk_ok = 0;
                perr[i] = 0.0;
            }
        }
    }
    free(C); free(S); free(GR); free(MB); free(J); free(WK); free(keep); free(mof); free(jerk);
    return 0;
}

"""

_state: dict = {}        # "lib": the loaded library; "failed": compiling did not work


def _cache_dir() -> Path:
    env = os.environ.get("PLANARKIN_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "planarkin"


_TAG = hashlib.sha256(SOURCE.encode()).hexdigest()[:16]


def _path() -> Path:
    return _cache_dir() / f"kernel-{_TAG}-{sys.platform}.so"


def disabled() -> bool:
    """PLANARKIN_KERNEL=0: the numpy passes only."""
    return os.environ.get("PLANARKIN_KERNEL", "1") == "0"


def unavailable() -> bool:
    """Known not to load in this process: disabled, or compiling failed (here or, by the
    marker, on an earlier run), so that callers need not pack a system for it."""
    return disabled() or bool(_state.get("failed")) or (
        "lib" not in _state and _failed_marker(_path()).exists())


def library(build: bool = True):
    """The compiled kernel (a ctypes library), or None: disabled (PLANARKIN_KERNEL=0), not yet
    compiled and build False, or no working C compiler. build: compile it when missing (about a
    second, once per machine and source version; tried once per process, and never again on a
    machine where it failed: the marker file)."""
    if disabled():
        return None
    if "lib" in _state:
        return _state["lib"]
    path = _path()
    if not path.exists():
        if not build or _state.get("failed") or _failed_marker(path).exists():
            return None
        if not _compile(path):
            _state["failed"] = True
            return None
    import ctypes
    try:
        lib = ctypes.CDLL(str(path))
        fn = lib.pk_solve
    except (OSError, AttributeError):
        _state["failed"] = True
        return None
    fn.restype = ctypes.c_int
    fn.argtypes = ([ctypes.c_int] * 5 + [ctypes.c_void_p] * 11 + [ctypes.c_void_p] * 6
                   + [ctypes.c_int, ctypes.c_double, ctypes.c_int, ctypes.c_int]
                   + [ctypes.c_void_p] * 9 + [ctypes.c_int] + [ctypes.c_void_p] * 4
                   + [ctypes.c_void_p] * 2 + [ctypes.c_int])
    lib.pk_rows.restype = ctypes.c_int
    lib.pk_rows.argtypes = (fn.argtypes + [ctypes.c_void_p] * 3 + [ctypes.c_double] * 2
                            + [ctypes.c_void_p] * 2)
    lib.pk_hermite.restype = None
    lib.pk_hermite.argtypes = [ctypes.c_int] * 2 + [ctypes.c_void_p] * 7
    _state["lib"] = lib
    return lib


def _failed_marker(path: Path) -> Path:
    return path.with_suffix(".failed")


def _compile(path: Path) -> bool:
    """cc -O2 into a temporary file beside path, renamed into place (concurrent runs). A
    compiler that exists but fails leaves the marker, with its message, so that every later
    run does not pay for trying again (delete it to retry); no compiler at all costs nothing."""
    import subprocess
    import tempfile
    cc = os.environ.get("CC", "cc")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
            src = Path(tmp) / "kernel.c"
            src.write_text(SOURCE)
            out = Path(tmp) / path.name
            r = subprocess.run([cc, "-O2", "-fPIC", "-shared", "-o", str(out), str(src), "-lm"],
                               capture_output=True, timeout=120)
            if r.returncode != 0 or not out.exists():
                _failed_marker(path).write_bytes(b"%s exited %d:\n" % (cc.encode(), r.returncode)
                                                 + r.stderr[-4000:])
                return False
            os.replace(out, path)
        return True
    except (OSError, subprocess.SubprocessError):
        return False


class Packed:
    """A System's elements and blocks as the kernel's int32 / float64 arrays."""

    def __init__(self, ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows, inblk,
                 rcol, rpos, nfine, bfirst, bnf, bfo, bfs):
        self.arrays = (ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows)
        self.nblk = len(bk)
        self.tail = (inblk, rcol, rpos)
        self.nfine = nfine
        self.fine = (bfirst, bnf, bfo, bfs)


def pack(S) -> Packed | None:
    """The kernel's description of System S, or None when it does not apply: a kind the kernel
    does not know, a solve block of more than KMAX unknowns or a fine block of more than KFINE,
    an element on one body twice."""
    if not S.blocks or any(len(B.cols) > KMAX or max(B.sizes) > KFINE or S.is_large(B)
                           for B in S.blocks):
        return None
    cm = S.cm
    ekind, ebi, ebj, eprm = [], [], [], []
    rowel = np.full(cm.m, -1, dtype=np.int32)
    roweq = np.zeros(cm.m, dtype=np.int32)
    for G in cm.groups:
        code = _CODES.get(type(G.kind).__name__)
        if code is None or G.kind.nbody != 2 or set(G.params) - set(_PARAMS[code]):
            return None
        for k in range(len(G)):
            bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
            if bi == bj:
                return None
            p = np.zeros(8)
            for slot, name in enumerate(_PARAMS[code]):
                # slot order si, sj, vi(, vj) for the revolute-like kinds; pin-slot and slide
                # list si, vi, sj: keep si in 0:2, sj in 2:4, vi in 4:6 for all
                at = {"si": 0, "sj": 2, "vi": 4, "vj": 6}[name]
                p[at:at + 2] = G.params[name][k]
            e = len(ekind)
            ekind.append(code)
            ebi.append(bi)
            ebj.append(bj)
            eprm.append(p)
            for q, r in enumerate(G.rows[k]):
                rowel[r] = e
                roweq[r] = q
    bk, boff, baff, bcols, brows = [], [], [], [], []
    if (rowel < 0).any():
        return None
    for B in S.blocks:
        boff.append(len(bcols))
        bk.append(len(B.cols))
        baff.append(int(B.affine))
        bcols.extend(int(c) for c in B.cols)
        brows.extend(int(r) for r in B.rows)
    rcol = np.zeros((cm.m, 6), dtype=np.int32)
    rpos = np.full((cm.m, 6), -1, dtype=np.int32)
    for r in range(cm.m):
        e = rowel[r]
        rcol[r] = [3 * ebi[e], 3 * ebi[e] + 1, 3 * ebi[e] + 2, 3 * ebj[e], 3 * ebj[e] + 1,
                   3 * ebj[e] + 2]
    for B in S.blocks:
        pos = {int(c): j for j, c in enumerate(B.cols)}
        for r in B.rows:
            rpos[r] = [pos.get(int(c), -1) for c in rcol[r]]
    i32 = lambda v: np.ascontiguousarray(v, dtype=np.int32)       # noqa: E731
    return Packed(i32(ekind), i32(ebi), i32(ebj),
                  np.ascontiguousarray(np.array(eprm).reshape(-1, 8), dtype=float),
                  i32(rowel), i32(roweq), i32(bk), i32(boff), i32(baff), i32(bcols), i32(brows),
                  np.isin(np.arange(cm.m), brows).astype(np.uint8), i32(rcol), i32(rpos),
                  S.nfine, i32([B.first for B in S.blocks]), i32([len(B.sizes) for B in S.blocks]),
                  i32(np.cumsum([0] + [len(B.sizes) for B in S.blocks])[:-1]),
                  i32([z for B in S.blocks for z in B.sizes]))


def table(cm, params) -> np.ndarray:
    """(V, E, 8) element parameters of V parameter sets in pack's layout: params holds, per
    group of cm.groups (in order), the arrays name -> (V, K, 2) of its K instances' 2-vectors
    (si, sj, vi, vj), the model's own where a name is missing."""
    V = next((a.shape[0] for p in params for a in p.values()), 1)
    parts = []
    for G, p in zip(cm.groups, params):
        code = _CODES[type(G.kind).__name__]
        out = np.zeros((V, len(G), 8))
        for name in _PARAMS[code]:
            at = {"si": 0, "sj": 2, "vi": 4, "vj": 6}[name]
            out[:, :, at:at + 2] = p.get(name, G.params[name])
        parts.append(out)
    return np.concatenate(parts, axis=1)


def solve(lib, S, P: Packed, Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order, rows=None,
          table=None):
    """System.solve_batch by the kernel: Q, Qd, Qdd (N, n + 3) updated in place. Returns
    (iterations, converged, ratio, sign, smin) as BatchInfo wants them and the residual
    |Phi| (N, m) of every equation at the results (redundant ones included). rows (N,) int32
    with table (V, E, 8) (see `table`): point i solves with the element parameters
    table[rows[i]] instead of the system's own (a design study's variants, studies.batch)."""
    N, W = Q.shape
    rows, table = _rows(rows, table, N, P)
    nblk = P.nblk
    iters = np.zeros(N, dtype=np.int64)
    conv = np.zeros(N, dtype=np.uint8)
    ratio = np.zeros(N)
    sign = np.zeros((N, P.nfine))
    smin = np.zeros((N, nblk))
    R = np.empty((N, S.cm.m))
    work = [np.ascontiguousarray(X, dtype=float) for X in (Q, Qd, Qdd)]
    drv = [np.ascontiguousarray(X, dtype=float) for X in (T, NU, FDD)]
    ptr = lambda a: a.ctypes.data                                  # noqa: E731
    rc = lib.pk_solve(N, W, S.cm.m, S.nb, nblk, *[ptr(a) for a in P.arrays],
                      *[ptr(a) for a in work], *[ptr(a) for a in drv], int(maxit), float(tol),
                      int(policy == "full"), int(order), ptr(iters), ptr(conv), ptr(ratio),
                      ptr(sign), ptr(smin), ptr(P.tail[0]), ptr(R), ptr(P.tail[1]),
                      ptr(P.tail[2]), P.nfine, *[ptr(a) for a in P.fine],
                      None if rows is None else ptr(rows), None if rows is None else ptr(table),
                      P.arrays[3].shape[0])
    if rc != 0:
        raise MemoryError("planarkin kernel: out of memory")
    for X, Wk in zip((Q, Qd, Qdd), work):
        if Wk is not X:
            X[...] = Wk
    return iters, conv.astype(bool), ratio, sign, smin, R


def _rows(rows, table, N, P):
    if rows is None:
        return None, None
    rows = np.ascontiguousarray(rows, dtype=np.int32)
    table = np.ascontiguousarray(table, dtype=float)
    if rows.shape != (N,) or table.shape[1:] != P.arrays[3].shape or (
            N and not 0 <= rows.min() <= rows.max() < len(table)):
        raise ValueError("planarkin kernel: per-point parameter rows out of the table")
    return rows, table


def solve_rows(lib, S, P: Packed, Q, T, NU, FDD, tol, maxit, rows=None, table=None,
               trow=None, accept=None):
    """pk_rows: full Newton for the positions of N points from the predictions Q (N, n + 3),
    each point to its own convergence, then velocities and accelerations. T, NU, FDD: the
    drivers' targets, nu and f'' (N, m), or with trow (N,) int32 tables (K, m) of which point
    i reads row trow[i]; rows, table: per-point element parameters as for `solve`. Returns
    (Q, Qd, Qdd, iterations, converged, ratio, sign, smin, good, perr), Q the array given when
    it is contiguous float64 (updated in place), else a copy. accept: (tg, sign0, kappa,
    cond_max), the acceptance tests of studies.batch (see pk_rows): good (N,) bool and perr
    (N,), the path error of the interval from the point before (grid times tg, indexed as
    T); None: not tested (good, perr None)."""
    N, W = Q.shape
    if maxit < 1:
        raise ValueError("planarkin kernel: at least one Newton iteration")
    rows, table = _rows(rows, table, N, P)
    Q = np.ascontiguousarray(Q, dtype=float)
    Qd, Qdd = np.empty((N, W)), np.empty((N, W))         # pk_rows writes every column
    drv = [np.ascontiguousarray(X, dtype=float) for X in (T, NU, FDD)]
    if trow is not None:
        trow = np.ascontiguousarray(trow, dtype=np.int32)
        if trow.shape != (N,) or (N and not 0 <= trow.min() <= trow.max() < len(drv[0])):
            raise ValueError("planarkin kernel: driver rows out of the tables")
    elif len(drv[0]) != N:
        raise ValueError("planarkin kernel: one driver row per point wanted")
    iters = np.empty(N, dtype=np.int64)
    conv = np.empty(N, dtype=np.uint8)
    ratio = np.empty(N)
    sign = np.empty((N, P.nfine))
    smin = np.empty((N, P.nblk))
    good = perr = sign0 = tg = None
    kappa = cond_max = 0.0
    if accept is not None:
        tg, sign0, kappa, cond_max = accept
        tg = np.ascontiguousarray(tg, dtype=float)
        sign0 = np.ascontiguousarray(sign0, dtype=float)
        if sign0.shape != (N, P.nfine) or len(tg) != len(drv[0]):
            raise ValueError("planarkin kernel: acceptance arrays do not match")
        good = np.empty(N, dtype=np.uint8)
        perr = np.empty(N)
    ptr = lambda a: None if a is None else a.ctypes.data         # noqa: E731
    rc = lib.pk_rows(N, W, S.cm.m, S.nb, P.nblk, *[ptr(a) for a in P.arrays],
                     ptr(Q), ptr(Qd), ptr(Qdd), *[ptr(a) for a in drv], int(maxit), float(tol),
                     1, 2, ptr(iters), ptr(conv), ptr(ratio), ptr(sign), ptr(smin),
                     ptr(P.tail[0]), None, ptr(P.tail[1]), ptr(P.tail[2]), P.nfine,
                     *[ptr(a) for a in P.fine], ptr(rows), ptr(table), P.arrays[3].shape[0],
                     ptr(trow), ptr(tg), ptr(sign0), float(kappa), float(cond_max), ptr(good),
                     ptr(perr))
    if rc != 0:
        raise MemoryError("planarkin kernel: out of memory")
    return (Q, Qd, Qdd, iters, conv.view(bool), ratio, sign, smin,
            None if good is None else good.view(bool), perr)


def hermite(lib, t, idx, Tn, Qn, Qdn, Qddn) -> np.ndarray:
    """solver.hermite5's positions at times t (N,) between nodes idx (N,) and idx + 1: (N, W)."""
    t = np.ascontiguousarray(t, dtype=float)
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    nodes = [np.ascontiguousarray(a, dtype=float) for a in (Tn, Qn, Qdn, Qddn)]
    Q = np.empty((len(t), Qn.shape[1]))
    lib.pk_hermite(len(t), Qn.shape[1], t.ctypes.data, idx.ctypes.data,
                   *[a.ctypes.data for a in nodes], Q.ctypes.data)
    return Q

