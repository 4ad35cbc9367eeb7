"""The element equations of the compiled route, one function per kind (issue 17 item 2).

Each kind function gives one equation row of one element from scalars: the coordinates,
cosines and sines of the element's two bodies, its parameters, and (for gamma) their rates;
it returns (g, the gradient over x_i, y_i, phi_i, x_j, y_j, phi_j, gamma_g). want says what is
needed: 1 g, 2 the gradient, 4 gamma (the others are returned as 0). The formulas are those of
reference sections 1, 2 and 5, in the operations and order of the numpy elements
(planarkin/elements), so that both routes round alike.

The compiled route takes its equations from here and nowhere else: the kernels generated
per mechanism structure (planarkin.solver.compiled.gen and compiled_gen_each) name the kind's
function with its equation and `want` as constants, so that numba keeps only that row's
terms. Every function is inlined into its caller by numba (inline="always"); with
NUMBA_DISABLE_JIT=1 they run as Python.

The numpy elements (planarkin/elements/*.py) are still a second text of these formulas (issue
17 item 2 asks for one); the route-equality tests hold the two to 1e-15.

KINDS maps the kind codes of planarkin.solver.compiled.kernel.pack to the functions' names.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from planarkin.solver.acceptance import COND_WARN, KAPPA

inline = numba.njit(inline="always", error_model="numpy", _nrt=False)

# kind code (a kind class's compiled_code, planarkin.elements.base.Kind) -> its function here
KINDS = {1: "revolute", 2: "translational", 3: "angle", 4: "xdistance", 5: "ydistance",
         6: "distance", 7: "pinslot", 8: "slide"}


@inline
def relative(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj):
    """s_i = A_i s'_i, s_j = A_j s'_j (p0, p1: s'_i; p2, p3: s'_j), h = r_j + s_j - r_i - s_i,
    and with want & 4 its rate hd and kx, ky = w_j^2 s_j - w_i^2 s_i."""
    six = ci * p0 - si * p1
    siy = si * p0 + ci * p1
    sjx = cj * p2 - sj * p3
    sjy = sj * p2 + cj * p3
    hx = xj + sjx - xi - six
    hy = yj + sjy - yi - siy
    hdx = hdy = kx = ky = 0.0
    if want & 4:
        hdx = vxj - wj * sjy - vxi + wi * siy
        hdy = vyj + wj * sjx - vyi - wi * six
        kx = wj * wj * sjx - wi * wi * six
        ky = wj * wj * sjy - wi * wi * siy
    return six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky


@inline
def revolute(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
             vyi, wi, vxj, vyj, wj):
    """Revolute: r_i + s_i - r_j - s_j, row eq (0: x, 1: y)."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    g = d0 = d1 = d2 = d3 = d4 = d5 = gam = 0.0
    if eq == 0:
        if want & 1:
            g = xi + six - xj - sjx
        if want & 2:
            d0 = 1.0
            d2 = -siy
            d3 = -1.0
            d5 = sjy
        if want & 4:
            gam = wi * wi * six - wj * wj * sjx
    else:
        if want & 1:
            g = yi + siy - yj - sjy
        if want & 2:
            d1 = 1.0
            d2 = six
            d4 = -1.0
            d5 = -sjx
        if want & 4:
            gam = wi * wi * siy - wj * wj * sjy
    return g, d0, d1, d2, d3, d4, d5, gam


@inline
def angle(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
          wi, vxj, vyj, wj):
    """Angle: phi_j - phi_i (also the translational joint's first row)."""
    g = d2 = d5 = 0.0
    if want & 1:
        g = pj - pi
    if want & 2:
        d2 = -1.0
        d5 = 1.0
    return g, 0.0, 0.0, d2, 0.0, 0.0, d5, 0.0


@inline
def xdistance(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
              vyi, wi, vxj, vyj, wj):
    """x of h."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    g = d0 = d2 = d3 = d5 = gam = 0.0
    if want & 1:
        g = hx
    if want & 2:
        d0 = -1.0
        d2 = siy
        d3 = 1.0
        d5 = -sjy
    if want & 4:
        gam = wj * wj * sjx - wi * wi * six
    return g, d0, 0.0, d2, d3, 0.0, d5, gam


@inline
def ydistance(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
              vyi, wi, vxj, vyj, wj):
    """y of h."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    g = d1 = d2 = d4 = d5 = gam = 0.0
    if want & 1:
        g = hy
    if want & 2:
        d1 = -1.0
        d2 = -six
        d4 = 1.0
        d5 = sjx
    if want & 4:
        gam = wj * wj * sjy - wi * wi * siy
    return g, 0.0, d1, d2, 0.0, d4, d5, gam


@inline
def distance(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
             vyi, wi, vxj, vyj, wj):
    """Distance |h|."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    d = np.hypot(hx, hy)
    ex = hx / d
    ey = hy / d
    g = d0 = d1 = d2 = d3 = d4 = d5 = gam = 0.0
    if want & 1:
        g = d
    if want & 2:
        d0 = -ex
        d1 = -ey
        d2 = ex * siy - ey * six
        d3 = ex
        d4 = ey
        d5 = ey * sjx - ex * sjy
    if want & 4:
        ehd = ex * hdx + ey * hdy
        gam = -(hdx * hdx + hdy * hdy - ehd * ehd) / d + ex * kx + ey * ky
    return g, d0, d1, d2, d3, d4, d5, gam


@inline
def along(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi, vxj,
          vyj, wj):
    """Slide: u_i^T h, u_i = A_i v_i (p4, p5: v'_i) along the line of body i through s_i."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    ux = ci * p4 - si * p5
    uy = si * p4 + ci * p5
    nx = -uy
    ny = ux
    g = d0 = d1 = d2 = d3 = d4 = d5 = gam = 0.0
    if want & 1:
        g = ux * hx + uy * hy
    if want & 2:
        d0 = -ux
        d1 = -uy
        d2 = nx * (hx + six) + ny * (hy + siy)
        d3 = ux
        d4 = uy
        d5 = -(nx * sjx + ny * sjy)
    if want & 4:
        gam = (wi * wi * (ux * hx + uy * hy) - 2.0 * wi * (nx * hdx + ny * hdy)
               + ux * kx + uy * ky)
    return g, d0, d1, d2, d3, d4, d5, gam


@inline
def normal(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi, vxj,
           vyj, wj):
    """n_i^T h, n_i = R u_i: the line of body i through s_i along u_i = A_i v_i."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    ux = ci * p4 - si * p5
    uy = si * p4 + ci * p5
    nx = -uy
    ny = ux
    g = d0 = d1 = d2 = d3 = d4 = d5 = gam = 0.0
    if want & 1:
        g = nx * hx + ny * hy
    if want & 2:
        d0 = -nx
        d1 = -ny
        d2 = -(ux * (hx + six) + uy * (hy + siy))
        d3 = nx
        d4 = ny
        d5 = ux * sjx + uy * sjy
    if want & 4:
        gam = (wi * wi * (nx * hx + ny * hy) + 2.0 * wi * (ux * hdx + uy * hdy)
               + nx * kx + ny * ky)
    return g, d0, d1, d2, d3, d4, d5, gam


@inline
def translational(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
                  vyi, wi, vxj, vyj, wj):
    """Translational: phi_j - phi_i (row 0), n_i^T h (row 1)."""
    if eq == 0:
        return angle(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj)
    return normal(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
                  vxj, vyj, wj)


@inline
def pinslot(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
            wi, vxj, vyj, wj):
    """Pin-slot: n_i^T h."""
    return normal(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
                  vxj, vyj, wj)


@inline
def slide(eq, want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
          wi, vxj, vyj, wj):
    """Slide: u_i^T h."""
    return along(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
                 vxj, vyj, wj)


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
    pivoting, as planarkin.solver.linalg._inv_gauss_jordan: returns (True, the determinant's sign), or
    (False, 0.0) when singular (inverse nan). A (>= 2 k k): the workspace. The generated kernels
    (planarkin.solver.compiled.gen, compiled_gen_each) compile it apart, for one signature: one text
    of the dense blocks' factorisation."""
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
    operations of planarkin.solver.path.hermite5 in its order (the same bits). Called by
    compiled_points.hermite and inside the generated grid kernels (compiled_gen)."""
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
