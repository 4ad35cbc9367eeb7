"""An optional compiled kernel for the grid pass of systems of small blocks (issue 12 item 3).

The grid pass of planarkin.system solves, per time point, Newton on each small diagonal block,
then the velocity and acceleration systems. In numpy that is a few dozen array passes per block
and chunk, whose cost per point (3-4 us for the slider-crank and the four-bar) is 4-7 times
that of a compiled special-purpose library. This module holds the same algorithm as
System._solve_batch, the reference pass, written in C over points: the same Newton iterations
block by block (a block iterates until every point of the batch has converged, as the
reference does, so the iteration counts agree), the same determinant signs and sigma_min bounds
(1 / ||J^-1||_F; Gauss-Jordan with partial pivoting, 1x1 and 2x2 blocks in closed form as the
fused numpy pass), and after each block, per point, its rows of the velocity and acceleration
systems with the gradients and gamma at the converged positions (the earlier blocks' rates
known). An affine block (one exact Newton step) finishes each point in one pass, reusing the
step's gradients and inverse where they do not depend on the block's unknowns, as the
reference does. The kernel also returns what the grid pass would otherwise reduce in numpy:
each point's largest residual and condition estimate, converged False where a result is not
finite; pk_layout writes a chunk's user-unit arrays and point kinematics in one pass.

It covers the kinds whose equations are the point-and-line formulas of reference §1-2
(revolute, translational, pin-slot, slide, angle, x, y, distance), fine blocks of up to KFINE
unknowns and solve blocks (the path follower's merged ones) of up to KMAX; any other kind or a
larger block keeps the numpy passes (pack returns None).

No dependency: the source below is compiled once with the system's C compiler (``cc``) into a
per-user cache (PLANARKIN_CACHE, else $XDG_CACHE_HOME/planarkin or ~/.cache/planarkin), keyed
by the source's hash, and loaded with ctypes. The first run on a machine that meets a system the
kernel covers compiles it before solving anything (about 0.7 s of CPU, once per machine and
source version), so the route a run takes depends on the machine only (a working compiler),
never on what earlier runs left in the cache: identical input gives identical bytes on one
machine. A compiler that fails leaves a marker (``.failed``, with its message) so that later
runs do not try again. Without a compiler, with an unwritable cache or with PLANARKIN_KERNEL=0
the numpy passes run instead: same results to rounding (tests/test_perstep.py).

For design studies (studies.batch: variants x grid times as one batch) pk_rows takes
per-point element parameters, an index per point into a table of parameter sets; pk_rows
solves point by point, each to its own convergence, and takes the study's acceptance tests in
the same pass (solve_rows).
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

HELPERS = r"""
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define KMAX 64   /* largest solve block */
#define KFINE 6   /* largest fine block */
#if defined(__GNUC__)
#define INLINE static inline __attribute__((always_inline))
#else
#define INLINE static inline
#endif

/* one equation row of element e: value g, gradient over (x_i, y_i, phi_i, x_j, y_j, phi_j),
   gamma_g (needs qd); want: 1 g, 2 gradient, 4 gamma (reference sections 1, 2, 5) */
INLINE void row_eval(int kind, int bi, int bj, const double *p, int eq, const double *q,
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
    default:  /* (pack admits no other kind: every output is written on every path) */
        if (want & 1) *g = NAN;
        if (want & 4) *gam = NAN;
        return;
    }
}

/* inverse of the k x k matrix J (row-major) by Gauss-Jordan with partial pivoting, as
   planarkin.linalg._inv_gauss_jordan: returns 1 and the determinant's sign, or 0 (singular:
   inverse nan, sign 0). A (k x 2k, row-major): the workspace. Inlined per small size (the
   grid's blocks have 1-6 unknowns), so that the loops unroll; the operations and their order
   are the same for every size. */
INLINE int gauss_jordan(int k, const double *J, double *inv, double *sign, double *A)
{
    int w = 2 * k, i, j, r, col;
    double scale = 0.0, sg = 1.0;
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++) {
            A[i * w + j] = J[i * k + j]; A[i * w + k + j] = (i == j);
            double a = fabs(J[i * k + j]);
            if (a > scale || a != a) scale = a;
        }
    double tiny = (scale > 0 ? scale : 1.0) * 1e-300;
    int ok = 1;
    for (col = 0; col < k; col++) {
        int pr = col;
        for (r = col + 1; r < k; r++) if (fabs(A[r * w + col]) > fabs(A[pr * w + col])) pr = r;
        if (pr != col) {
            for (j = 0; j < w; j++) {
                double t = A[col * w + j]; A[col * w + j] = A[pr * w + j]; A[pr * w + j] = t;
            }
            sg = -sg;
        }
        double piv = A[col * w + col];
        if (!(fabs(piv) > tiny)) { ok = 0; piv = 1.0; }
        sg *= (piv > 0) - (piv < 0);
        for (j = 0; j < w; j++) A[col * w + j] /= piv;
        for (r = 0; r < k; r++) {
            if (r == col) continue;
            double f = A[r * w + col];
            if (f != 0.0) for (j = 0; j < w; j++) A[r * w + j] -= f * A[col * w + j];
        }
    }
    for (i = 0; i < k; i++) for (j = 0; j < k; j++) inv[i * k + j] = ok ? A[i * w + k + j] : NAN;
    *sign = ok ? sg : 0.0;
    return ok;
}

static int invert(int k, const double *J, double *inv, double *sign, double *work)
{
    switch (k) {
    case 2: return gauss_jordan(2, J, inv, sign, work);
    case 3: return gauss_jordan(3, J, inv, sign, work);
    case 4: return gauss_jordan(4, J, inv, sign, work);
    default: return gauss_jordan(k, J, inv, sign, work);
    }
}

/* NaN-propagating maximum, as numpy's max */
INLINE double nanmax(double a, double v) { return (v > a || v != v) ? v : a; }

/* studies.batch's acceptance tests of point i (Batch.accept is the numpy reference), while its
   numbers are at hand: good[i] = converged, finite q, qd, qdd (W columns: the point's rows of the
   results, the rows before them the point before's), first correction at most kappa sigma_min,
   1 / min(sm) at most cond_max and every fine-block sign sgn equal to sign0's; perr[i] = the
   Taylor predictor error (studies.warm._predictor_error, forwards and backwards, first n
   columns) of the interval from the point before when that is the same variant (vrow) at the
   grid time before (times tg, indexed by trow), else 0. jerk, jerk_ok: the last interval's
   change of acceleration, carried from point to point. Shared by pk_rows and kernelgen's
   pk_gen (the same bits). */
INLINE void accept_point(int i, int W, int n, int nblk, int nfine, const double *q,
                         const double *qd, const double *qdd, const double *sm, const double *sgn,
                         int conv, double ratio, const int32_t *trow, const int32_t *vrow,
                         const double *tg, const double *sign0, double kappa, double cond_max,
                         double *jerk, int *jerk_ok, uint8_t *good, double *perr)
{
    int g = conv && ratio <= kappa, c;
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
            double dA = (qdd[c] - a0[c]) / h, j3 = *jerk_ok ? jerk[c] : 0.0;
            double ef = fabs(q[c] - (q0[c] + h * d0[c] + hh * a0[c] + h3 * j3));
            double eb = fabs(q[c] - h * qd[c] + hh * qdd[c] - h3 * dA - q0[c]);
            double x = ef > eb ? ef : eb;
            jerk[c] = dA;
            e = x > e ? x : e;
            nan |= (ef != ef) | (eb != eb);
        }
        *jerk_ok = 1;
        perr[i] = nan ? NAN : e;
    } else {
        *jerk_ok = 0;
        perr[i] = 0.0;
    }
}

"""

# the rest of the kernel (kernelgen compiles HELPERS with its own function)
SOURCE = HELPERS + r"""
/* One equation row of a block, unpacked once per block and call; rc: the columns of its
   gradient entries */
typedef struct {
    int kind, bi, bj, eq, row;
    const double *p;
    int rc[6];
} Row;

/* gradient x rates of one row, summed in pairs (a chain of six dependent subtractions was
   a tenth of the kernel's time) */
INLINE double dot6(const double *g, const int *rc, const double *X)
{
    return (g[0] * X[rc[0]] + g[1] * X[rc[1]]) + (g[2] * X[rc[2]] + g[3] * X[rc[3]])
           + (g[4] * X[rc[4]] + g[5] * X[rc[5]]);
}

/* the block's matrix (kb x kb) from its rows' gradients gr (kb x 6): nj entries, J[dst[e]] =
   gr[src[e]] in order (of a repeated position the last counts, as System.block_matrix); then
   its inverse Mi, determinant sign and sigma_min bound 1 / ||J^-1||_F (as _invert) */
INLINE double factor(int kb, int nj, const int *src, const int *dst, const double *gr, double *J,
                     double *Mi, double *sg, double *WK)
{
    int k;
    for (k = 0; k < kb * kb; k++) J[k] = 0.0;
    for (k = 0; k < nj; k++) J[dst[k]] = gr[src[k]];
    if (kb == 1) {
        Mi[0] = 1.0 / J[0];
        *sg = (J[0] > 0) - (J[0] < 0);
        if (J[0] != J[0]) *sg = NAN;
        return fabs(J[0]);
    }
    if (kb == 2) {   /* closed form, as System._invert_small (the fused numpy pass) */
        double a = J[0], b = J[1], c = J[2], d = J[3], det = a * d - b * c;
        int ok2 = isfinite(det) && det != 0;
        double inv = 1.0 / (ok2 ? det : NAN);
        Mi[0] = d * inv; Mi[1] = -b * inv; Mi[2] = -c * inv; Mi[3] = a * inv;
        *sg = ok2 ? (det > 0) - (det < 0) : 0.0;
        return ok2 ? fabs(det) / sqrt(a * a + b * b + c * c + d * d) : 0.0;
    }
    int ok = invert(kb, J, Mi, sg, WK);
    double f = 0.0;
    for (k = 0; k < kb * kb; k++) f += Mi[k] * Mi[k];
    return ok ? 1.0 / sqrt(f) : 0.0;
}

/* x = Mi r into the block's columns of X */
INLINE void apply(int kb, const double *Mi, const double *r, const int32_t *cols, double *X)
{
    int a, k;
    if (kb == 1) { X[cols[0]] = r[0] * Mi[0]; return; }
    for (a = 0; a < kb; a++) {
        double x = 0.0;
        for (k = 0; k < kb; k++) x += Mi[a * kb + k] * r[k];
        X[cols[a]] = x;
    }
}

/* the same for a 2x2 block from its matrix J: Cramer's rule, as the fused numpy pass's
   _forward (one rounding less than through the inverse's entries; tests/test_sketch_exact.py
   holds the Jansen leg's accelerations to 1e-14 of the exact linkage: 9.6e-15 so, 1.003e-14
   through the inverse) */
INLINE void solve2(const double *J, const double *r, const int32_t *cols, double *X)
{
    double det = J[0] * J[3] - J[1] * J[2];
    X[cols[0]] = (J[3] * r[0] - J[1] * r[1]) / det;
    X[cols[1]] = (J[0] * r[1] - J[2] * r[0]) / det;
}

/* One point's block rows at its converged positions: residuals |Phi - target| into Ri, then
   with order >= 1 the velocities (Phi_q qd = nu, the earlier blocks' columns known) and with
   order >= 2 the accelerations (Phi_q qdd = gamma + f''). gr, Mi: the rows' gradients and the
   block's inverse at the converged positions (have: already there, else evaluated here) */
INLINE void rates(int kb, const Row *rw, const int32_t *cols, int nj, const int *src,
                  const int *dst, int order, int have, const double *q, const double *c,
                  const double *s, double *qd, double *qdd, const double *t, const double *nu,
                  const double *fdd, double *Ri, double *gr, double *Mi, double *J, double *WK)
{
    double r[KMAX], gm[KMAX], g = 0.0, gam = 0.0, sg;
    int rp;
    if (!have) {
        for (rp = 0; rp < kb; rp++) {
            const Row *w = rw + rp;
            row_eval(w->kind, w->bi, w->bj, w->p, w->eq, q, c, s, 0, 3, &g, gr + 6 * rp, 0);
            Ri[w->row] = fabs(g - t[w->row]);
        }
        factor(kb, nj, src, dst, gr, J, Mi, &sg, WK);
    }
    for (rp = 0; rp < kb; rp++) {
        const Row *w = rw + rp;
        r[rp] = nu[w->row] - dot6(gr + 6 * rp, w->rc, qd);
    }
    if (kb == 2) solve2(J, r, cols, qd);
    else apply(kb, Mi, r, cols, qd);
    if (have)        /* the residuals, and gamma at the same time (the same terms; unused
                        below order 2) */
        for (rp = 0; rp < kb; rp++) {
            const Row *w = rw + rp;
            row_eval(w->kind, w->bi, w->bj, w->p, w->eq, q, c, s, qd, 5, &g, 0, gm + rp);
            Ri[w->row] = fabs(g - t[w->row]);
        }
    if (order < 2) return;
    for (rp = 0; rp < kb; rp++) {
        const Row *w = rw + rp;
        if (have) gam = gm[rp];
        else row_eval(w->kind, w->bi, w->bj, w->p, w->eq, q, c, s, qd, 4, 0, 0, &gam);
        r[rp] = (gam + fdd[w->row]) - dot6(gr + 6 * rp, w->rc, qdd);
    }
    if (kb == 2) solve2(J, r, cols, qdd);
    else apply(kb, Mi, r, cols, qdd);
}

/* One solve block for all points (specialised below for 1 and 2 unknowns). Newton block by
   block as System._solve_batch: the block iterates until every point of the batch has
   converged (so the iteration counts agree with the reference); an affine block takes exactly
   one step, which is exact, so each point is finished (rates included) in one pass. */
INLINE void block(int kb, int b, int N, int W, int m, int nbb, int nblk, int nfine, const Row *rw,
                  const int32_t *cols, int nj, const int *src, const int *dst, int affine,
                  int fixed, int maxit, double tol, int full, int order, double *Q, double *Qd,
                  double *Qdd, double *C, double *S, const double *T, const double *NU,
                  const double *FDD, int64_t *iters, uint8_t *conv, double *ratio, double *sign,
                  double *smin, double *R, int bfirst, int bnf, const int32_t *fs, double *MI,
                  double *SZ, double *GB, double *J, double *WK)
{
    int i, it, rp, a;
    for (it = 0; it < maxit; it++) {
        int refactor = (it == 0) || (full && !affine);
        int all_small = 1;
        for (i = 0; i < N; i++) {
            double *q = Q + (size_t)i * W, *c = C + (size_t)i * nbb, *s = S + (size_t)i * nbb;
            const double *t = T + (size_t)i * m;
            double *Mi = MI + (size_t)i * kb * kb, *gr = GB;
            double r[KMAX], sg = 0.0, sm;
            if (refactor) {
                for (rp = 0; rp < kb; rp++) {
                    const Row *w = rw + rp;
                    row_eval(w->kind, w->bi, w->bj, w->p, w->eq, q, c, s, 0, 3, r + rp,
                             gr + 6 * rp, 0);
                }
                sm = factor(kb, nj, src, dst, gr, J, Mi, &sg, WK);
                if (it == 0) {
                    smin[(size_t)i * nblk + b] = sm;
                    if (bnf == 1) sign[(size_t)i * nfine + bfirst] = sg;
                    else {   /* a merged block: the signs of its fine blocks */
                        int f, o = 0;
                        for (f = 0; f < bnf; f++) {
                            int sz = fs[f], u, v;
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
                            sign[(size_t)i * nfine + bfirst + f] = sf;
                            o += sz;
                        }
                    }
                }
            } else {
                for (rp = 0; rp < kb; rp++) {
                    const Row *w = rw + rp;
                    row_eval(w->kind, w->bi, w->bj, w->p, w->eq, q, c, s, 0, 1, r + rp, 0, 0);
                }
            }
            for (rp = 0; rp < kb; rp++) r[rp] -= t[rw[rp].row];
            double sz = 0.0;
            for (a = 0; a < kb; a++) {
                double dx = 0.0;
                int k;
                for (k = 0; k < kb; k++) dx += Mi[a * kb + k] * r[k];
                q[cols[a]] -= dx;
                double ad = fabs(dx);
                if (ad > sz || ad != ad) sz = ad;
                if (cols[a] % 3 == 2 && dx != 0.0) {      /* an angle that moved */
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
            if (affine) {
                /* one step is exact: converged unless not finite; the point is done */
                conv[i] = conv[i] && isfinite(sz);
                if (order >= 1)
                    rates(kb, rw, cols, nj, src, dst, order, fixed, q, c, s,
                          Qd + (size_t)i * W, Qdd + (size_t)i * W, t, NU + (size_t)i * m,
                          FDD + (size_t)i * m, R + (size_t)i * m, gr, Mi, J, WK);
                continue;
            }
            SZ[i] = sz;
            if (!(sz <= tol)) all_small = 0;
        }
        if (affine || all_small) break;
    }
    if (affine) return;
    for (i = 0; i < N; i++) conv[i] = conv[i] && (SZ[i] <= tol);
    if (order < 1) return;
    for (i = 0; i < N; i++)
        rates(kb, rw, cols, nj, src, dst, order, 0, Q + (size_t)i * W, C + (size_t)i * nbb,
              S + (size_t)i * nbb, Qd + (size_t)i * W, Qdd + (size_t)i * W, T + (size_t)i * m,
              NU + (size_t)i * m, FDD + (size_t)i * m, R + (size_t)i * m,
              GB, MI + (size_t)i * kb * kb, J, WK);
}

/* all points of one batch; arrays row-major per point. inblk (m): the row is in a block; R
   (N, m): |Phi| of every row at the results; rcol (m x 6): the columns of each row's gradient
   entries; rpos (m x 6): where each gradient entry of a row goes in its block's row (-1:
   another block's column); sign (N, nfine) per fine block: solve block b holds bnf[b] fine
   blocks, the first numbered bfirst[b], their sizes bfs[bfo[b]...]. bfix (nblk): the block's
   whole gradient does not depend on its own unknowns (System Block.fixed_grad: the rates reuse
   the Newton step's gradients and inverse, as the reference does). Outputs besides: rmax (N)
   the largest |Phi| of each point (numpy's R.max(axis=1)), cond (N) its condition estimate
   (planarkin.solver._cond: the largest 1 / max(smin, 1e-300) over the blocks); conv[i] is 0 where
   a coordinate of the result is not finite. Returns 0, or -1 when out of memory. */
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
             const int32_t *bfs, const int32_t *bfix, double *rmax, double *cond)
{
    int nbb = nb + 1, i, b, rp, a, k;
    int n = W - 3;
    int kmax = 1;
    for (b = 0; b < nblk; b++) if (bk[b] > kmax) kmax = bk[b];
    double *C = malloc(sizeof(double) * (size_t)N * nbb);
    double *S = malloc(sizeof(double) * (size_t)N * nbb);
    double *MI = malloc(sizeof(double) * (size_t)N * kmax * kmax);
    double *GB = malloc(sizeof(double) * KMAX * 6);
    double *SZ = malloc(sizeof(double) * (size_t)N);
    /* the block matrix, the Gauss-Jordan workspace and the rows on the heap: up to 64 unknowns
       they would take 100 KB of stack, more than some threads have */
    double *J = malloc(sizeof(double) * KMAX * KMAX);
    double *WK = malloc(sizeof(double) * 2 * KMAX * KMAX);
    Row *rw = malloc(sizeof(Row) * KMAX);
    int *src = malloc(sizeof(int) * KMAX * 6), *dst = malloc(sizeof(int) * KMAX * 6);
    if (!C || !S || !MI || !GB || !SZ || !J || !WK || !rw || !src || !dst) {
        free(C); free(S); free(MI); free(GB); free(SZ); free(J); free(WK); free(rw); free(src);
        free(dst);
        return -1;
    }
    for (i = 0; i < N; i++) {
        double *q = Q + (size_t)i * W;
        for (b = 0; b < nbb; b++) {
            double phi = q[3 * b + 2];
            if (phi == 0.0 && !signbit(phi)) {     /* the ground, bodies that do not turn */
                C[(size_t)i * nbb + b] = 1.0;
                S[(size_t)i * nbb + b] = 0.0;
            } else {
                C[(size_t)i * nbb + b] = cos(phi);
                S[(size_t)i * nbb + b] = sin(phi);
            }
        }
        iters[i] = 0; conv[i] = 1; ratio[i] = 0.0;
        if (order >= 1) for (a = 0; a < n; a++) Qd[(size_t)i * W + a] = 0.0;
        if (order >= 2) for (a = 0; a < n; a++) Qdd[(size_t)i * W + a] = 0.0;
    }
    for (b = 0; b < nblk; b++) {
        int kb = bk[b], nj = 0;
        const int32_t *cols = bcols + boff[b], *rows = brows + boff[b];
        for (rp = 0; rp < kb; rp++) {
            int row = rows[rp], e = rowel[row];
            Row *w = rw + rp;
            w->kind = ekind[e]; w->bi = ebi[e]; w->bj = ebj[e]; w->eq = roweq[row];
            w->row = row; w->p = eprm + 8 * e;
            for (k = 0; k < 6; k++) {
                w->rc[k] = rcol[6 * row + k];
                if (rpos[6 * row + k] >= 0) {
                    src[nj] = 6 * rp + k;
                    dst[nj++] = rp * kb + rpos[6 * row + k];
                }
            }
        }
#define BLOCK(K) block(K, b, N, W, m, nbb, nblk, nfine, rw, cols, nj, src, dst, baff[b], \
                       bfix[b], maxit, tol, full, order, Q, Qd, Qdd, C, S, T, NU, FDD, iters, \
                       conv, ratio, sign, smin, R, bfirst[b], bnf[b], bfs + bfo[b], MI, SZ, GB, \
                       J, WK)
        switch (kb) {
        case 1: BLOCK(1); break;
        case 2: BLOCK(2); break;
        default: BLOCK(kb); break;
        }
#undef BLOCK
    }
    /* per point: |Phi| of the rows outside the blocks (left out as redundant), and with order 0
       of all; the largest residual, the condition estimate, and no convergence where a
       coordinate is not finite */
    for (i = 0; i < N; i++) {
        double *q = Q + (size_t)i * W, *c = C + (size_t)i * nbb, *s = S + (size_t)i * nbb;
        double *Ri = R + (size_t)i * m, mx, cd = 0.0;
        int row;
        for (row = 0; row < m; row++) {
            if (inblk[row] && order >= 1) continue;
            double g = 0.0;
            int e = rowel[row];
            row_eval(ekind[e], ebi[e], ebj[e], eprm + 8 * e, roweq[row], q, c, s, 0, 1, &g, 0, 0);
            Ri[row] = fabs(g - T[(size_t)i * m + row]);
        }
        mx = Ri[0];
        for (row = 1; row < m; row++) mx = nanmax(mx, Ri[row]);
        rmax[i] = mx;
        for (b = 0; b < nblk; b++) {
            double v = smin[(size_t)i * nblk + b];
            v = 1.0 / ((v >= 1e-300 || v != v) ? v : 1e-300);
            cd = b == 0 ? v : nanmax(cd, v);
        }
        cond[i] = cd;
        for (a = 0; a < W; a++) if (!isfinite(q[a])) { conv[i] = 0; break; }
    }
    free(C); free(S); free(MI); free(GB); free(SZ); free(J); free(WK); free(rw); free(src);
    free(dst);
    return 0;
}

/* a design study's prediction along a repeated parameter step (studies.batch): the cubic
   q0 + 3 (q0 - q1) - 3 (q1 - q2) + (q2 - q3) through the last four solutions, element by
   element in the order of the numpy lines it replaces (the same bits) */
void pk_cubic(int64_t n, const double *q0, const double *q1, const double *q2, const double *q3,
              double *out)
{
    int64_t k;
    for (k = 0; k < n; k++) {
        double r = (q0[k] - q1[k]) * 3.0;
        r += q0[k];
        r -= (q1[k] - q2[k]) * 3.0;
        r += q2[k] - q3[k];
        out[k] = r;
    }
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

/* a chunk's rows in user units, written once: q, qd, qdd (N, n) = the first n numbers of each
   row of Q, Qd, Qdd times unit (n); the points' positions, velocities and accelerations
   (N, P, 2), point k on body pbody[k] at ps[2 k], ps[2 k + 1], times L: the operations of
   planarkin.solver.point_kinematics in its order (then times L). order 0: positions only,
   1: with velocities, 2: with accelerations (qd, pd, qdd, pdd unused above the order). */
void pk_layout(int N, int W, int n, int P, int order, const double *unit, double L,
               const int32_t *pbody, const double *ps, const double *Q, const double *Qd,
               const double *Qdd, double *q, double *qd, double *qdd, double *p, double *pd,
               double *pdd)
{
    int i, a, k;
    for (i = 0; i < N; i++) {
        const double *Qi = Q + (size_t)i * W, *Qdi = Qd + (size_t)i * W, *Qddi = Qdd + (size_t)i * W;
        for (a = 0; a < n; a++) q[(size_t)i * n + a] = Qi[a] * unit[a];
        if (order >= 1) for (a = 0; a < n; a++) qd[(size_t)i * n + a] = Qdi[a] * unit[a];
        if (order >= 2) for (a = 0; a < n; a++) qdd[(size_t)i * n + a] = Qddi[a] * unit[a];
        for (k = 0; k < P; k++) {
            int b = pbody[k];
            size_t o = ((size_t)i * P + k) * 2;
            double c = cos(Qi[3 * b + 2]), s = sin(Qi[3 * b + 2]);
            double sx = c * ps[2 * k] - s * ps[2 * k + 1], sy = s * ps[2 * k] + c * ps[2 * k + 1];
            p[o] = (Qi[3 * b] + sx) * L;
            p[o + 1] = (Qi[3 * b + 1] + sy) * L;
            if (order < 1) continue;
            double w = Qdi[3 * b + 2];
            pd[o] = (Qdi[3 * b] - w * sy) * L;
            pd[o + 1] = (Qdi[3 * b + 1] + w * sx) * L;
            if (order < 2) continue;
            double al = Qddi[3 * b + 2];
            pdd[o] = (Qddi[3 * b] - al * sy - w * w * sx) * L;
            pdd[o + 1] = (Qddi[3 * b + 1] + al * sx - w * w * sy) * L;
        }
    }
}

/* pk_rows (below) builds a block's matrix from its rows' gradients */
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
                    /* an angle that moved (one that did not keeps its cosine and sine,
                       unless it is a zero, whose sine may be -0 and was taken as +0) */
                    if (cols[a] % 3 == 2 && (dx != 0.0 || q[cols[a]] == 0.0)) {
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
        accept_point(i, W, n, nblk, nfine, q, qd, qdd, sm, sgn, conv[i], ratio[i], trow, vrow, tg,
                     sign0, kappa, cond_max, jerk, &jerk_ok, good, perr);
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


# -ffp-contract=off: no fused multiply-adds where the target has them (the operations are
# those of the numpy passes, rounded as they are); -fno-math-errno: sqrt inline (errno is
# never read), the same results
CFLAGS = ("-O2", "-ffp-contract=off", "-fno-math-errno")


def tag(source: str) -> str:
    """A kernel's name in the cache: the hash of its source and flags."""
    return hashlib.sha256((source + " ".join(CFLAGS)).encode()).hexdigest()[:16]


_TAG = tag(SOURCE)


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
    # the arguments pk_solve and pk_rows share (up to bfs), then each one's own
    shared = ([ctypes.c_int] * 5 + [ctypes.c_void_p] * 11 + [ctypes.c_void_p] * 6
              + [ctypes.c_int, ctypes.c_double, ctypes.c_int, ctypes.c_int]
              + [ctypes.c_void_p] * 9 + [ctypes.c_int] + [ctypes.c_void_p] * 4)
    fn.argtypes = shared + [ctypes.c_void_p] * 3                   # bfix, rmax, cond
    lib.pk_rows.restype = ctypes.c_int
    lib.pk_rows.argtypes = (shared + [ctypes.c_void_p] * 2 + [ctypes.c_int]  # vrow, vprm, ne
                            + [ctypes.c_void_p] * 3 + [ctypes.c_double] * 2
                            + [ctypes.c_void_p] * 2)
    lib.pk_cubic.restype = None
    lib.pk_cubic.argtypes = [ctypes.c_int64] + [ctypes.c_void_p] * 5
    lib.pk_hermite.restype = None
    lib.pk_hermite.argtypes = [ctypes.c_int] * 2 + [ctypes.c_void_p] * 7
    lib.pk_layout.restype = None
    lib.pk_layout.argtypes = ([ctypes.c_int] * 5 + [ctypes.c_void_p, ctypes.c_double]
                              + [ctypes.c_void_p] * 11)
    _state["lib"] = lib
    return lib


def _failed_marker(path: Path) -> Path:
    return path.with_suffix(".failed")


def _compile(path: Path, source: str = SOURCE) -> bool:
    """cc -O2 of source (the kernel's; kernelgen's adds a specialised pk_rows) into a temporary
    file beside path, renamed into place (concurrent runs). A
    compiler that exists but fails leaves the marker, with its message, so that every later
    run does not pay for trying again (delete it to retry); no compiler at all costs nothing."""
    import subprocess
    import tempfile
    cc = os.environ.get("CC", "cc")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(dir=path.parent) as tmp:
            src = Path(tmp) / "kernel.c"
            src.write_text(source)
            out = Path(tmp) / path.name
            r = subprocess.run([cc, *CFLAGS, "-fPIC", "-shared", "-o",
                                str(out), str(src), "-lm"],
                               capture_output=True, timeout=120)
            if r.returncode != 0 or not out.exists():
                _failed_marker(path).write_bytes(b"%s exited %d:\n" % (cc.encode(), r.returncode)
                                                 + r.stderr[-4000:])
                return False
            os.replace(out, path)
        _prune(path)
        return True
    except (OSError, subprocess.SubprocessError):
        return False


# Another source version's kernel (or marker) compiled longer ago than this is removed when a
# new version is compiled: every planarkin version leaves one file, and nothing else removes
# them. Younger ones stay, so that two installed versions used in turn do not compile each
# other's away at every run (at most one recompile a week each).
PRUNE_AFTER = 7 * 24 * 3600


def _prune(path: Path, now: float | None = None) -> list[Path]:
    """Remove the kernels and markers of other source versions in path's directory whose file
    is older than PRUNE_AFTER (their modification time: when they were compiled). Returns the
    files removed; a file that cannot be removed is left."""
    import time
    now = time.time() if now is None else now
    gone = []
    for f in path.parent.glob("kernel-*"):
        if f.name in (path.name, _failed_marker(path).name) or f.suffix not in (".so", ".failed"):
            continue
        try:
            if now - f.stat().st_mtime > PRUNE_AFTER:
                f.unlink()
                gone.append(f)
        except OSError:
            pass
    return gone


class Packed:
    """A System's elements and blocks as the kernel's int32 / float64 arrays."""

    def __init__(self, ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows, inblk,
                 rcol, rpos, nfine, bfirst, bnf, bfo, bfs, fixed):
        self.arrays = (ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows)
        self.nblk = len(bk)
        self.tail = (inblk, rcol, rpos)
        self.nfine = nfine
        self.fine = (bfirst, bnf, bfo, bfs)
        self.fixed = fixed


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
                  i32([z for B in S.blocks for z in B.sizes]),
                  i32([B.fixed_grad for B in S.blocks]))


def solve(lib, S, P: Packed, Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order):
    """System.solve_batch by the kernel: Q, Qd, Qdd (N, n + 3) updated in place. Returns
    (iterations, converged, ratio, sign, smin) as BatchInfo wants them (converged False where a
    coordinate is not finite), the residual |Phi| (N, m) of every equation at the results
    (redundant ones included), its largest value per point (N,) and the condition estimate
    (N,) of solver._cond."""
    N, W = Q.shape
    nblk = P.nblk
    iters = np.empty(N, dtype=np.int64)
    conv = np.empty(N, dtype=bool)
    ratio = np.empty(N)
    sign = np.zeros((N, P.nfine))
    smin = np.empty((N, nblk))
    R = np.empty((N, S.cm.m))
    rmax = np.empty(N)
    cond = np.empty(N)
    work = [np.ascontiguousarray(X, dtype=float) for X in (Q, Qd, Qdd)]
    drv = [np.ascontiguousarray(X, dtype=float) for X in (T, NU, FDD)]
    ptr = lambda a: a.ctypes.data                                  # noqa: E731
    rc = lib.pk_solve(N, W, S.cm.m, S.nb, nblk, *[ptr(a) for a in P.arrays],
                      *[ptr(a) for a in work], *[ptr(a) for a in drv], int(maxit), float(tol),
                      int(policy == "full"), int(order), ptr(iters), ptr(conv), ptr(ratio),
                      ptr(sign), ptr(smin), ptr(P.tail[0]), ptr(R), ptr(P.tail[1]),
                      ptr(P.tail[2]), P.nfine, *[ptr(a) for a in P.fine], ptr(P.fixed), ptr(rmax),
                      ptr(cond))
    if rc != 0:
        raise MemoryError("planarkin kernel: out of memory")
    for X, Wk in zip((Q, Qd, Qdd), work):
        if Wk is not X:
            X[...] = Wk
    return iters, conv, ratio, sign, smin, R, rmax, cond


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


def _rows(rows, table, N, P):
    if rows is None:
        return None, None
    rows = np.ascontiguousarray(rows, dtype=np.int32)
    table = np.ascontiguousarray(table, dtype=float)
    if rows.shape != (N,) or table.shape[1:] != P.arrays[3].shape or (
            N and not 0 <= rows.min() <= rows.max() < len(table)):
        raise ValueError("planarkin kernel: per-point parameter rows out of the table")
    return rows, table


def _buffer(work, name, shape, dtype=float):
    """An array for a result: from work (a dict kept by the caller between calls) when it has
    one of this shape and type, else a new one (kept there)."""
    if work is None:
        return np.empty(shape, dtype=dtype)
    a = work.get(name)
    if a is None or a.shape != shape or a.dtype != dtype:
        a = work[name] = np.empty(shape, dtype=dtype)
    return a


def solve_rows(lib, S, P: Packed, Q, T, NU, FDD, tol, maxit, rows=None, table=None,
               trow=None, accept=None, gen=None, hist=None, work=None, out=None):
    """pk_rows: full Newton for the positions of N points from the predictions Q (N, n + 3),
    each point to its own convergence, then velocities and accelerations. T, NU, FDD: the
    drivers' targets, nu and f'' (N, m), or with trow (N,) int32 tables (K, m) of which point
    i reads row trow[i]; rows, table: per-point element parameters as for `solve`. Returns
    (Q, Qd, Qdd, iterations, converged, ratio, sign, smin, good, perr), Q the array given when
    it is contiguous float64 (updated in place), else a copy. accept: (tg, sign0, kappa,
    cond_max), the acceptance tests of studies.batch (see pk_rows): good (N,) bool and perr
    (N,), the path error of the interval from the point before (grid times tg, indexed as
    T); None: not tested (good, perr None). gen: pk_rows specialised to S's structure
    (kernelgen.function), the same results bit for bit where it applies (it takes the ground's
    coordinates as +0, as they are in every study: a point with other bits there is not
    converged and not good). hist: (H0, H1, H2, H3, cub), four arrays shaped as Q (the last
    four solutions, newest first) and cub (N,) bool: the prediction of point i is then the
    cubic of pk_cubic through the rows of H0-H3 where cub[i], else Q's row, and Q is not
    written (the positions are a new array). work: a dict the caller keeps between calls, whose
    arrays then hold the diagnostics (iterations to perr: valid until the next call with it;
    fresh arrays and page faults of half a megabyte each per call otherwise); out: arrays
    (N, W) for the positions (with hist), velocities and accelerations."""
    N, W = Q.shape
    if maxit < 1:
        raise ValueError("planarkin kernel: at least one Newton iteration")
    rows, table = _rows(rows, table, N, P)
    Q = np.ascontiguousarray(Q, dtype=float)
    if hist is not None:
        cub = np.ascontiguousarray(hist[4], dtype=np.uint8)
        hist = [np.ascontiguousarray(h, dtype=float) for h in hist[:4]]
        if any(h.shape != Q.shape for h in hist) or cub.shape != (N,):
            raise ValueError("planarkin kernel: four history arrays shaped as Q and a flag "
                             "per point wanted")
        hist.append(cub)
    if out is not None and all(a.shape == (N, W) and a.dtype == float and a.flags.c_contiguous
                               and not any(np.may_share_memory(a, x) for x in [Q, *(hist or [])])
                               for a in out) and len({a.ctypes.data for a in out}) == 3:
        Qo, Qd, Qdd = out
    else:
        Qo = np.empty((N, W)) if hist is not None else None
        Qd, Qdd = np.empty((N, W)), np.empty((N, W))
    # (pk_rows writes every column)
    drv = [np.ascontiguousarray(X, dtype=float) for X in (T, NU, FDD)]
    if trow is not None:
        trow = np.ascontiguousarray(trow, dtype=np.int32)
        if trow.shape != (N,) or (N and not 0 <= trow.min() <= trow.max() < len(drv[0])):
            raise ValueError("planarkin kernel: driver rows out of the tables")
    elif len(drv[0]) != N:
        raise ValueError("planarkin kernel: one driver row per point wanted")
    iters = _buffer(work, "iters", (N,), np.int64)
    conv = _buffer(work, "conv", (N,), np.uint8)
    ratio = _buffer(work, "ratio", (N,))
    sign = _buffer(work, "sign", (N, P.nfine))
    smin = _buffer(work, "smin", (N, P.nblk))
    good = perr = sign0 = tg = None
    kappa = cond_max = 0.0
    if accept is not None:
        tg, sign0, kappa, cond_max = accept
        tg = np.ascontiguousarray(tg, dtype=float)
        sign0 = np.ascontiguousarray(sign0, dtype=float)
        if sign0.shape != (N, P.nfine) or len(tg) != len(drv[0]):
            raise ValueError("planarkin kernel: acceptance arrays do not match")
        good = _buffer(work, "good", (N,), np.uint8)
        perr = _buffer(work, "perr", (N,))
    ptr = lambda a: None if a is None else a.ctypes.data         # noqa: E731
    out = Q if hist is None else Qo
    if gen is not None and W == S.cm.n + 3:
        rc = gen(N, ptr(P.arrays[3]), ptr(rows), ptr(table), P.arrays[3].shape[0], ptr(trow),
                 *[ptr(a) for a in drv], ptr(Q), *(ptr(h) for h in hist or (None,) * 5),
                 ptr(out), ptr(Qd), ptr(Qdd), int(maxit), float(tol), ptr(iters), ptr(conv),
                 ptr(ratio), ptr(sign), ptr(smin), ptr(tg), ptr(sign0), float(kappa),
                 float(cond_max), ptr(good), ptr(perr))
        return (out, Qd, Qdd, iters, conv.view(bool), ratio, sign, smin,
                None if good is None else good.view(bool), perr)
    if hist is not None:
        lib.pk_cubic(out.size, *(ptr(h) for h in hist[:4]), ptr(out))
        keep = ~hist[4].view(bool)
        out[keep] = Q[keep]
    Q = out
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


def layout(lib, cm, Q, Qd, Qdd, order: int, unit, out=None):
    """A chunk's user-unit arrays from its internal (N, n + 3) rows, in one pass: q, qd, qdd
    (N, n) (None above order) and the points' p, pd, pdd (N, P, 2), as solver._chunk computes
    them with point_kinematics. out: those six arrays (C-contiguous, float) to write into."""
    N, W = Q.shape
    n = cm.n
    P = len(cm.point_body)
    arrs = [np.ascontiguousarray(a, dtype=float) for a in (Q, Qd, Qdd)]
    if out is None:
        out = tuple(np.empty((N, n)) if k <= order else None for k in range(3)) \
            + tuple(np.empty((N, P, 2)) if k <= order else None for k in range(3))
    q, qd, qdd, p, pd, pdd = out
    pbody = np.ascontiguousarray(cm.point_body, dtype=np.int32)
    ps = np.ascontiguousarray(cm.point_s, dtype=float).reshape(P, 2)
    unit = np.ascontiguousarray(unit, dtype=float)
    dummy = q.ctypes.data
    lib.pk_layout(N, W, n, P, int(order), unit.ctypes.data, float(cm.L), pbody.ctypes.data,
                  ps.ctypes.data, *[a.ctypes.data for a in arrs],
                  *[dummy if a is None else a.ctypes.data for a in (q, qd, qdd)],
                  *[p.ctypes.data if a is None else a.ctypes.data for a in (p, pd, pdd)])
    return q, qd, qdd, p, pd, pdd
