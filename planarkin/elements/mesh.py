"""Gear pair with moving centres and a disc rolling on a disc (reference §3.2).

Gear (disc) i has its centre at si and signed pitch radius ri, gear j at sj with rj (negative
for the ring of an internal pair); d = r_j + A_j s'_j - r_i - A_i s'_i is the line of centres
and S = ri + rj. Rolling without slip of the pitch circles is S theta - ri phi_i - rj phi_j = c
with theta the direction of d. The smooth (perpendicular) form of §3.2 writes it without atan2:
theta* = (ri phi_i + rj phi_j + c) / S, e = (cos theta*, sin theta*), and the line of centres
must point along e. c is fixed by the estimated poses (the gears mesh as drawn), stored as the
derived parameter `phase`; with S < 0 (an internal pair drawn with the ring as i) d points along
-e, so that the two-equation form d = S e holds.

`gear-mesh`: e_perp^T d = 0 (1 equation), the centre distance comes from other joints (planet on
a carrier). `roll-disc`: d - S e = 0 (2 equations), also the centre distance |S|: a disc rolling
on a disc, outside (both radii positive) or inside (the outer one negative).
"""

from __future__ import annotations

import math

import numpy as np

from . import jerk as J
from .base import Kind, Param, force_at, gradient_force, relative_point, relative_velocity, omega
from .gear import PRESSURE_ANGLE, centre_gap, check_pressure_angle, mesh_check, pressure_tan

_PARAMS = (
    Param("si", "point", "centre of gear (disc) i on body i in its frame"),
    Param("sj", "point", "centre of gear (disc) j on body j in its frame"),
    Param("ri", "length", "signed pitch radius of i (negative for an internal ring gear)"),
    Param("rj", "length", "signed pitch radius of j (negative for an internal ring gear)"),
)
_PHASE = (Param("phase", "real", "c of S theta - ri phi_i - rj phi_j = c, from the estimates"),)


def _theta(G, F):
    """theta* (N, K), its rate (N, K) (when F.qd is given) and S (K,)."""
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    ri, rj = G.params["ri"], G.params["rj"]
    S = ri + rj
    th = (ri * F.q[:, 3 * bi + 2] + rj * F.q[:, 3 * bj + 2] + G.params["phase"]) / S
    thd = None if F.qd is None else (ri * omega(F, bi) + rj * omega(F, bj)) / S
    return th, thd, S


def _chains(G, F):
    """Chains (planarkin.elements.jerk) of e(theta*) and of the line of centres d, and S: e
    turns at theta*' = (ri omega_i + rj omega_j) / S, theta*'' likewise from the alphas."""
    th, thd, S = _theta(G, F)
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    thdd = (G.params["ri"] * J.alpha(F, bi) + G.params["rj"] * J.alpha(F, bj)) / S
    six, siy, sjx, sjy, _, _ = relative_point(G, F)
    e = J.turning((np.cos(th), np.sin(th)), thd, thdd)
    return e, J.pair(F, bi, (six, siy), bj, (sjx, sjy)), S


def _phase(arrays, poses):
    (xi, yi, pi_), (xj, yj, pj) = poses[0], poses[1]
    a, b = arrays["si"], arrays["sj"]
    dx = xj + math.cos(pj) * b[0] - math.sin(pj) * b[1] - xi - (math.cos(pi_) * a[0]
                                                               - math.sin(pi_) * a[1])
    dy = yj + math.sin(pj) * b[0] + math.cos(pj) * b[1] - yi - (math.sin(pi_) * a[0]
                                                               + math.cos(pi_) * a[1])
    S = float(arrays["ri"] + arrays["rj"])
    theta0 = math.atan2(dy, dx) if S > 0 else math.atan2(-dy, -dx)
    return np.float64(S * theta0 - arrays["ri"] * pi_ - arrays["rj"] * pj)


class GearMesh(Kind):
    name = "gear-mesh"
    reaction_columns = ("fx", "fy", "torque")
    derived = _PHASE
    summary = ("gear pair with moving centres (planet gears): the pitch circles of i and j roll "
               "without slip; the centre distance comes from other joints (1 equation)")
    equations = ("e_perp(theta*)^T (P_j - P_i) = 0, theta* = (ri phi_i + rj phi_j + c0) / "
                 "(ri + rj), c0 as drawn")
    params = _PARAMS + (PRESSURE_ANGLE,)
    reaction_sign = (
        "fx, fy: the tooth force on gear j (global), along the line of action through the pitch "
        "point: the tangential part (the constraint's own force) and the radial part |F_t| tan"
        "(pressure_angle) pushing the gears apart; torque: its moment about j's centre sj, "
        "counter-clockwise positive. Gear i gets minus the force at the same point")

    def check_pose(self, G, F, pivots, L, lu):
        out = []
        for k in range(len(G)):
            d = centre_gap(F, G, k, G.params["si"][k], G.params["sj"][k])
            out += mesh_check(k, d, float(G.params["ri"][k]), float(G.params["rj"][k]), L, lu)
        return out

    def validate(self, V, params, given, what):
        if params.get("ri") is not None and params.get("rj") is not None \
                and params["ri"] + params["rj"] == 0:
            V.err(given["rj"], f"{what}: ri + rj must not be zero (the centre distance "
                               f"|ri + rj| of the pair)")

    def diagnose(self, arrays, L, af, lu, au):
        return check_pressure_angle(arrays, af, au)

    def reaction(self, G, F, lam, setup):
        """The constraint's force is the tangential tooth force at the pitch point P_j - rj e;
        the radial part, along e on j, is carried by the joints that hold the centre distance."""
        out = gradient_force(G, F, lam)
        th, _, _ = _theta(G, F)
        ex, ey = np.cos(th), np.sin(th)
        six, siy, sjx, sjy, _, _ = relative_point(G, F)
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        rj = G.params["rj"]
        px = F.q[:, 3 * bj] + sjx - rj * ex
        py = F.q[:, 3 * bj + 1] + sjy - rj * ey
        fr = np.hypot(out[:, :, 1, 0], out[:, :, 1, 1]) * pressure_tan(G)
        force_at(F, bj, px, py, fr * ex, fr * ey, out, 1)
        force_at(F, bi, px, py, fr * ex, fr * ey, out, 0, -1.0)
        return out

    def g(self, G, F):
        th, _, _ = _theta(G, F)
        hx, hy = relative_point(G, F)[4:]
        return (-np.sin(th) * hx + np.cos(th) * hy)[..., None]

    def grad(self, G, F):
        th, _, S = _theta(G, F)
        six, siy, sjx, sjy, hx, hy = relative_point(G, F)
        ex, ey = np.cos(th), np.sin(th)
        px, py = -ey, ex                       # e_perp = R e
        ed = ex * hx + ey * hy
        out = np.zeros((F.q.shape[0], len(G), 1, 6))
        # e_perp^T R s = -px s_y + py s_x
        out[..., 0, 0] = -px
        out[..., 0, 1] = -py
        out[..., 0, 2] = (px * siy - py * six) - ed * G.params["ri"] / S
        out[..., 0, 3] = px
        out[..., 0, 4] = py
        out[..., 0, 5] = (py * sjx - px * sjy) - ed * G.params["rj"] / S
        return out

    def gamma(self, G, F):
        th, thd, S = _theta(G, F)
        six, siy, sjx, sjy, hx, hy = relative_point(G, F)
        wi, wj, hdx, hdy = relative_velocity(F, G.bodies[:, 0], G.bodies[:, 1], six, siy, sjx, sjy)
        ex, ey = np.cos(th), np.sin(th)
        px, py = -ey, ex
        kx = wj * wj * sjx - wi * wi * six
        ky = wj * wj * sjy - wi * wi * siy
        out = thd * thd * (px * hx + py * hy) + 2.0 * thd * (ex * hdx + ey * hdy) + px * kx + py * ky
        return out[..., None]

    def jerk(self, G, F):
        e, d, _ = _chains(G, F)
        perp = tuple((-v[1], v[0]) for v in e)          # e_perp = R e, R constant
        return -J.dot(perp, d)[..., None]

    def prepare(self, arrays, poses):
        return {"phase": _phase(arrays, poses)}, [0.0]

    def draw(self, G, k, parts):
        """Both pitch circles with a radius mark that shows the rotation."""
        draw_discs(G, k, parts)


class RollDisc(Kind):
    name = "roll-disc"
    reaction_columns = ("fx", "fy", "torque")
    neq = 2
    params = _PARAMS
    derived = _PHASE
    reaction_sign = (
        'fx, fy: the contact force of disc i on disc j at their contact point (global): the '
        'normal part along the line of centres and the tangential traction; torque: its moment '
        "about j's centre sj. Disc i gets minus it at the same point")
    summary = ("disc j rolls without slipping on disc i, outside (ri, rj > 0) or inside (the "
               "outer radius negative); also keeps the centre distance |ri + rj| (2 equations)")
    equations = "P_j - P_i - (ri + rj) e(theta*) = 0, theta* as for gear-mesh"

    def validate(self, V, params, given, what):
        if params.get("ri") is not None and params.get("rj") is not None \
                and params["ri"] + params["rj"] == 0:
            V.err(given["rj"], f"{what}: ri + rj must not be zero (the centre distance "
                               f"|ri + rj| of the pair)")

    def g(self, G, F):
        th, _, S = _theta(G, F)
        hx, hy = relative_point(G, F)[4:]
        return np.stack([hx - S * np.cos(th), hy - S * np.sin(th)], axis=-1)

    def grad(self, G, F):
        th, _, S = _theta(G, F)
        six, siy, sjx, sjy, hx, hy = relative_point(G, F)
        ex, ey = np.cos(th), np.sin(th)
        ri, rj = G.params["ri"], G.params["rj"]
        out = np.zeros((F.q.shape[0], len(G), 2, 6))
        # d/dphi of -S e(theta*) = -S R e dtheta*/dphi = -r R e; R e = (-ey, ex)
        out[..., 0, 0] = -1.0
        out[..., 0, 2] = siy + ri * ey
        out[..., 0, 3] = 1.0
        out[..., 0, 5] = -sjy + rj * ey
        out[..., 1, 1] = -1.0
        out[..., 1, 2] = -six - ri * ex
        out[..., 1, 4] = 1.0
        out[..., 1, 5] = sjx - rj * ex
        return out

    def gamma(self, G, F):
        th, thd, S = _theta(G, F)
        six, siy, sjx, sjy, hx, hy = relative_point(G, F)
        wi2 = omega(F, G.bodies[:, 0]) ** 2
        wj2 = omega(F, G.bodies[:, 1]) ** 2
        c = S * thd * thd
        return np.stack([wj2 * sjx - wi2 * six - c * np.cos(th),
                         wj2 * sjy - wi2 * siy - c * np.sin(th)], axis=-1)

    def jerk(self, G, F):
        e, d, S = _chains(G, F)
        return -np.stack([d[3][0] - S * e[3][0], d[3][1] - S * e[3][1]], axis=-1)

    def prepare(self, arrays, poses):
        return {"phase": _phase(arrays, poses)}, [0.0, 0.0]

    def draw(self, G, k, parts):
        """Both discs with a radius mark that shows the rotation."""
        draw_discs(G, k, parts)


def draw_discs(G, k, parts) -> None:
    """gear-mesh, roll-disc: both pitch circles with a radius mark that shows the rotation."""
    from .drawing import circle_with_mark   # (a leaf module: numpy only)
    for col, (s, r) in ((0, ("si", "ri")), (1, ("sj", "rj"))):
        circle_with_mark(parts.body(G, k, col), parts.point(G, k, s), parts.point(G, k, r), parts)
