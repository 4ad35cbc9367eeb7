"""The equations of the point-and-line kinds (reference sections 1, 2 and 5), written once.

Each function gives every equation row of one element of its kind from the coordinates, cosines
and sines of its two bodies, its parameters and (for gamma) the bodies' velocities. The same
text serves both routes:

* numpy broadcasts it: the kinds' own g, grad and gamma (planarkin.elements.base.Kind) call it
  with (N, K) arrays, N states by K elements of a group;
* numba compiles it: the compiled route (planarkin.solver.compiled.helpers) registers the
  helpers below with numba, and the kernels generated per structure call the kind's function
  with scalars.

Nothing here imports numba: a small run never pays its start-up. The functions use only
arithmetic, ``np.hypot`` and ``if`` on the integer ``want`` (1: g, 2: the gradient, 4: gamma;
what is not wanted is returned as 0.0), so that both routes do the same operations in the same
order and round alike.

Arguments: want, then per body (i, then j) x, y, phi, cos phi, sin phi; the parameter slots
p0-p5 (p0, p1: s'_i; p2, p3: s'_j; p4, p5: v'_i, the body-frame vectors of planarkin.solver.
compiled.kernel.pack); then per body the velocities x', y', phi'. Returns a tuple with one row
per equation, each row (g, dg/dx_i, dg/dy_i, dg/dphi_i, dg/dx_j, dg/dy_j, dg/dphi_j, gamma_g).

CODES maps a kind's ``compiled_code`` (planarkin.elements.base.Kind) to its function's name.
"""

from __future__ import annotations

import numpy as np

CODES = {1: "revolute", 2: "translational", 3: "angle", 4: "xdistance", 5: "ydistance",
         6: "distance", 7: "pinslot", 8: "slide"}


def rotated(ci, si, cj, sj, p0, p1, p2, p3):
    """s_i = A_i s'_i, s_j = A_j s'_j (p0, p1: s'_i; p2, p3: s'_j)."""
    return ci * p0 - si * p1, si * p0 + ci * p1, cj * p2 - sj * p3, sj * p2 + cj * p3


def relative(want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj):
    """s_i, s_j (rotated), h = r_j + s_j - r_i - s_i, and with want & 4 its rate hd and
    kx, ky = w_j^2 s_j - w_i^2 s_i."""
    six, siy, sjx, sjy = rotated(ci, si, cj, sj, p0, p1, p2, p3)
    hx = xj + sjx - xi - six
    hy = yj + sjy - yi - siy
    hdx = hdy = kx = ky = 0.0
    if want & 4:
        hdx = vxj - wj * sjy - vxi + wi * siy
        hdy = vyj + wj * sjx - vyi - wi * six
        kx = wj * wj * sjx - wi * wi * six
        ky = wj * wj * sjy - wi * wi * siy
    return six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky


def revolute(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
             vxj, vyj, wj):
    """Revolute: r_i + s_i - r_j - s_j (rows x, y; h is not needed)."""
    six, siy, sjx, sjy = rotated(ci, si, cj, sj, p0, p1, p2, p3)
    g0 = g1 = gam0 = gam1 = 0.0
    a2 = a5 = b2 = b5 = 0.0
    if want & 1:
        g0 = xi + six - xj - sjx
        g1 = yi + siy - yj - sjy
    if want & 2:
        a2 = -siy
        a5 = sjy
        b2 = six
        b5 = -sjx
    if want & 4:
        gam0 = wi * wi * six - wj * wj * sjx
        gam1 = wi * wi * siy - wj * wj * sjy
    one = 1.0 if want & 2 else 0.0
    return ((g0, one, 0.0, a2, -one, 0.0, a5, gam0),
            (g1, 0.0, one, b2, 0.0, -one, b5, gam1))


def angle_row(want, pi, pj):
    """phi_j - phi_i (the angle kind, the translational joint's first row)."""
    g = 0.0
    if want & 1:
        g = pj - pi
    one = 1.0 if want & 2 else 0.0
    return (g, 0.0, 0.0, -one, 0.0, 0.0, one, 0.0)


def angle(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
          vxj, vyj, wj):
    """Angle: phi_j - phi_i."""
    return (angle_row(want, pi, pj),)


def xdistance(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
              wi, vxj, vyj, wj):
    """x of h."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    g = d2 = d5 = gam = 0.0
    if want & 1:
        g = hx
    if want & 2:
        d2 = siy
        d5 = -sjy
    if want & 4:
        gam = wj * wj * sjx - wi * wi * six
    one = 1.0 if want & 2 else 0.0
    return ((g, -one, 0.0, d2, one, 0.0, d5, gam),)


def ydistance(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
              wi, vxj, vyj, wj):
    """y of h."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    g = d2 = d5 = gam = 0.0
    if want & 1:
        g = hy
    if want & 2:
        d2 = -six
        d5 = sjx
    if want & 4:
        gam = wj * wj * sjy - wi * wi * siy
    one = 1.0 if want & 2 else 0.0
    return ((g, 0.0, -one, d2, 0.0, one, d5, gam),)


def distance(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi,
             wi, vxj, vyj, wj):
    """Distance |h| (unsquared: its gradient is a unit vector, reference 5.5c)."""
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
    return ((g, d0, d1, d2, d3, d4, d5, gam),)


def line_row(want, normal, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
             vyi, wi, vxj, vyj, wj):
    """The line of body i through s_i along u_i = A_i v'_i (p4, p5), n_i = R u_i: n_i^T h
    (normal: the pin-slot, the translational joint's second row) or u_i^T h (the slide)."""
    six, siy, sjx, sjy, hx, hy, hdx, hdy, kx, ky = relative(
        want, xi, yi, ci, si, xj, yj, cj, sj, p0, p1, p2, p3, vxi, vyi, wi, vxj, vyj, wj)
    ux = ci * p4 - si * p5
    uy = si * p4 + ci * p5
    nx = -uy
    ny = ux
    g = d0 = d1 = d2 = d3 = d4 = d5 = gam = 0.0
    if normal:
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
    else:
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
    return (g, d0, d1, d2, d3, d4, d5, gam)


def translational(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi,
                  vyi, wi, vxj, vyj, wj):
    """Translational: phi_j - phi_i (row 0), n_i^T h (row 1)."""
    return (angle_row(want, pi, pj),
            line_row(want, True, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj))


def pinslot(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
            vxj, vyj, wj):
    """Pin-slot: n_i^T h."""
    return (line_row(want, True, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj),)


def slide(want, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5, vxi, vyi, wi,
          vxj, vyj, wj):
    """Slide: u_i^T h."""
    return (line_row(want, False, xi, yi, pi, ci, si, xj, yj, pj, cj, sj, p0, p1, p2, p3, p4, p5,
                     vxi, vyi, wi, vxj, vyj, wj),)
