"""Rack-and-pinion and a disc rolling on a line (reference §3.3).

Rack (or line) body i: a point si of the pitch line and its direction vi (unit u_i, normal
n_i = R u_i); pinion (or disc) body j: its centre sj and pitch radius r; h = r_j + A_j s'_j -
r_i - A_i s'_i runs from the pitch-line point to the centre. sigma = +1 when the centre lies on
the +n_i side of the line, -1 otherwise; it is read from the body estimates when the model is
compiled (a centre drawn exactly on the line counts as the + side).

Rolling without slip: u_i^T h + sigma r (phi_j - phi_i) = c, c fixed by the estimates (the
parts mesh as drawn). Sign check of §3.3: a fixed rack along +x with the pinion above it: a
pinion rolling by +dx turns by -dx / r (clockwise).

`rack-pinion` is that one equation: the centre distance comes from other joints (the common
case: pinion on a revolute, rack on a translational joint). `roll-line` adds n_i^T h = sigma r,
the disc touching the line: a wheel on a road, or a pinion held on its rack by nothing else.
"""

from __future__ import annotations

import numpy as np

from .base import (Kind, Param, check_positive, force_at, gradient_force, gradient_row,
                   point_line_arguments, rotate)
from .gear import PRESSURE_ANGLE, check_pressure_angle, pressure_tan
from .pointline import line_row
from .translational import along_jerk, normal_jerk


def _line(G, F, want, normal):
    """n_i^T h (normal) or u_i^T h of the pitch line: a row of planarkin.elements.pointline."""
    return line_row(want, normal, *point_line_arguments(G, F, want))


def _along(G, F, want):
    """The row of u_i^T h + sigma r (phi_j - phi_i): the slide's, plus the linear angle term
    (its gamma is the slide's, reference 5.6)."""
    g, d0, d1, d2, d3, d4, d5, gam = _line(G, F, want, False)
    sr = G.params["side"] * G.params["r"]
    if want & 1:
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        g = g + sr * (F.q[:, 3 * bj + 2] - F.q[:, 3 * bi + 2])
    if want & 2:
        d2, d5 = d2 - sr, d5 + sr
    return g, d0, d1, d2, d3, d4, d5, gam


def _estimate(arrays, poses):
    """(sigma, u^T h0, n^T h0) at the estimated poses (internal units)."""
    (xi, yi, pi_), (xj, yj, pj) = poses[0], poses[1]
    ci, si_ = np.cos(pi_), np.sin(pi_)
    cj, sj_ = np.cos(pj), np.sin(pj)
    a, b, v = arrays["si"], arrays["sj"], arrays["vi"]
    hx = xj + cj * b[0] - sj_ * b[1] - xi - (ci * a[0] - si_ * a[1])
    hy = yj + sj_ * b[0] + cj * b[1] - yi - (si_ * a[0] + ci * a[1])
    ux, uy = ci * v[0] - si_ * v[1], si_ * v[0] + ci * v[1]
    un, nn = ux * hx + uy * hy, -uy * hx + ux * hy
    return (1.0 if nn >= 0 else -1.0), un, nn


_PARAMS = (
    Param("si", "point", "a point of the pitch line (rolling line) on body i in its frame"),
    Param("vi", "vector", "direction of the pitch line on body i in its frame"),
    Param("sj", "point", "centre of the pinion (disc) on body j in its frame"),
    Param("r", "length", "pitch radius of the pinion (radius of the disc), > 0"),
)
_SIDE = (Param("side", "real", "+1: centre on the +n_i side of the pitch line, -1: the other"),)


class RackPinion(Kind):
    name = "rack-pinion"
    reaction_columns = ("fx", "fy", "torque")    # the contact force on j, its moment about sj
    derived = _SIDE
    summary = ("rack-and-pinion, rolling only: rack i, pinion j of pitch radius r; the centre "
               "distance comes from other joints (1 equation)")
    equations = ("u_i^T (P_j - P_i) + sigma r (phi_j - phi_i) - c0 = 0 (sigma: the pinion's side "
                 "of the pitch line, c0: as drawn)")
    params = _PARAMS + (PRESSURE_ANGLE,)
    reaction_sign = (
        "fx, fy: the tooth force on the pinion j (global), along the line of action through the "
        "pitch point (on the pitch line below the pinion's centre): its part along the rack "
        "(the constraint's own force) and |F_t| tan(pressure_angle) pushing the pinion away "
        "from the rack; torque: its moment about the pinion's centre sj, counter-clockwise "
        "positive. The rack i gets minus the force at the same point")

    def validate(self, V, params, given, what):
        check_positive(V, params, given, what, ("r",))

    def diagnose(self, arrays, L, af, lu, au):
        return check_pressure_angle(arrays, af, au)

    def reaction(self, G, F, lam, setup):
        """The constraint's force is the tooth force along the pitch line at the pitch point
        P_j - sigma r n_i; the radial part, along sigma n_i on the pinion, is carried by the
        joints that hold the centre distance (pinion bearing, rack guide)."""
        out = gradient_force(G, F, lam)
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        ux, uy = rotate(F, bi, G.params["vi"][:, 0], G.params["vi"][:, 1])
        nx, ny = -uy, ux
        sjx, sjy = rotate(F, bj, G.params["sj"][:, 0], G.params["sj"][:, 1])
        sr = G.params["side"] * G.params["r"]
        px = F.q[:, 3 * bj] + sjx - sr * nx
        py = F.q[:, 3 * bj + 1] + sjy - sr * ny
        fr = np.hypot(out[:, :, 1, 0], out[:, :, 1, 1]) * pressure_tan(G) * G.params["side"]
        force_at(F, bj, px, py, fr * nx, fr * ny, out, 1)
        force_at(F, bi, px, py, fr * nx, fr * ny, out, 0, -1.0)
        return out

    def g(self, G, F):
        return _along(G, F, 1)[0][..., None]

    def grad(self, G, F):
        out = np.empty((F.q.shape[0], len(G), 1, 6))
        gradient_row(out, 0, _along(G, F, 2))
        return out

    def gamma(self, G, F):
        return _along(G, F, 4)[7][..., None]

    def jerk(self, G, F):
        return along_jerk(G, F)[..., None]

    def prepare(self, arrays, poses):
        side, un, _ = _estimate(arrays, poses)
        c = un + side * arrays["r"] * (poses[1][2] - poses[0][2])
        return {"side": np.float64(side)}, [c]

    def draw(self, G, k, parts):
        """The pinion's pitch circle (the rack is drawn by its slide)."""
        draw_pinion(G, k, parts)


class RollLine(Kind):
    name = "roll-line"
    reaction_columns = ("fx", "fy", "torque")
    neq = 2
    params = _PARAMS
    derived = _SIDE
    reaction_sign = (
        'fx, fy: the contact force of the line (body i) on the disc j at the contact point '
        '(global): its normal part along sigma n_i (positive pressing the disc away from the '
        'line) and its tangential part (the traction that keeps it rolling); torque: its moment '
        "about the disc's centre sj. The line gets minus it at the same point")
    summary = ("disc j of radius r rolls without slipping on a line of body i (a wheel on a "
               "road; a rack and pinion that also keeps the centre distance) (2 equations)")
    equations = ("n_i^T (P_j - P_i) - sigma r = 0; u_i^T (P_j - P_i) + sigma r (phi_j - phi_i) "
                 "- c0 = 0")

    def validate(self, V, params, given, what):
        check_positive(V, params, given, what, ("r",))

    def g(self, G, F):
        return np.stack([_line(G, F, 1, True)[0], _along(G, F, 1)[0]], axis=-1)

    def grad(self, G, F):
        out = np.empty((F.q.shape[0], len(G), 2, 6))
        gradient_row(out, 0, _line(G, F, 2, True))
        gradient_row(out, 1, _along(G, F, 2))
        return out

    def gamma(self, G, F):
        return np.stack([_line(G, F, 4, True)[7], _along(G, F, 4)[7]], axis=-1)

    def jerk(self, G, F):
        return np.stack([normal_jerk(G, F), along_jerk(G, F)], axis=-1)

    def prepare(self, arrays, poses):
        side, un, _ = _estimate(arrays, poses)
        c = un + side * arrays["r"] * (poses[1][2] - poses[0][2])
        return {"side": np.float64(side)}, [side * arrays["r"], c]

    def draw(self, G, k, parts):
        """The disc (the line is drawn by its slide)."""
        draw_pinion(G, k, parts)


def draw_pinion(G, k, parts) -> None:
    """rack-pinion, roll-line: the pinion's (disc's) pitch circle with a radius mark."""
    from .drawing import circle_with_mark   # (a leaf module: numpy only)
    circle_with_mark(parts.body(G, k, 1), parts.point(G, k, "sj"), parts.point(G, k, "r"), parts)
