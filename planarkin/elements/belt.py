"""Belt or chain drive between two pulleys on fixed centres or a common carrier k.

An open belt turns both pulleys the same way: ri (phi_i - phi_k) - rj (phi_j - phi_k) = c; a
crossed belt (``crossed: true``) turns them opposite ways, ri (phi_i - phi_k) + rj (phi_j -
phi_k) = c, the gear relation of §3.1 with positive radii. ri, rj are the pitch radii of the
pulleys (sprockets); c is fixed by the given body angles. The belt's run and the centre distance
do not enter the kinematics (a belt that does not slip is a ratio); assembly checks that the
pulleys do not overlap.
"""

from __future__ import annotations

import numpy as np

from .base import Param, force_at, gradient_force
from .gear import Gear, carrier_centres, carrier_pairs, centre_gap, global_point


class Belt(Gear):
    """The gear relation (g, grad, gamma of `Gear`) with the sign of rj set by `crossed`."""

    name = "belt"
    reaction_columns = ("fx", "fy", "torque")    # the tight run's pull, its moment about j
    nbody = 3
    params = (
        Param("ri", "length", "pitch radius of pulley i, > 0"),
        Param("rj", "length", "pitch radius of pulley j, > 0"),
        Param("crossed", "flag", "true: a crossed belt (the pulleys turn opposite ways)",
              required=False, default=False),
        Param("pretension", "real", "tension of both runs at rest, >= 0 (force: N with lengths "
              "in m); only the forces on the shafts depend on it", required=False, default=0.0),
    )
    summary = ("belt or chain drive on fixed centres or a common carrier k (default ground); "
               "`crossed: true` for a crossed belt (1 equation)")
    equations = ("ri (phi_i - phi_k) -+ rj (phi_j - phi_k) - c0 = 0 (- open, + crossed; c0 from "
                 "the given body angles)")

    reaction_sign = (
        "fx, fy: the pull of both runs on pulley j (global), each along its run towards pulley "
        "i: the tension difference dT = |T_j| / rj (T_j the belt's torque on j) is split as "
        "slack = max(pretension - dT/2, 0), tight = slack + dT (without pretension the slack run "
        "carries nothing and the tight one dT); torque: their moment about j's centre (its "
        "revolute joint to the carrier k), counter-clockwise positive. Pulley i gets minus the "
        "force with the same moment about that point; the carrier nothing")

    def check_pose(self, G, F, pivots, L, lu):
        out = []
        for k, ci, cj in carrier_pairs(G, pivots):
            d = centre_gap(F, G, k, ci, cj)
            r = float(G.params["ri"][k] + G.params["rj"][k])
            if not d > r:
                out.append((k, "error", f"the pulleys overlap: their centres are {d * L:.6g} {lu} "
                                        f"apart, not more than ri + rj = {r * L:.6g} {lu}"))
        return out

    def validate(self, V, params, given, what):
        for key in ("ri", "rj"):
            if params.get(key) is not None and params[key] < 0:
                V.err(given[key], f"{what}: {key} must be positive, not {params[key]:g} (the "
                                  f"pulley's pitch radius; for a crossed belt write crossed: "
                                  f"true)")

    def diagnose(self, arrays, L, af, lu, au):
        T0 = float(arrays["pretension"])
        if not T0 >= 0:
            return [f"pretension must not be negative, not {T0:g} (the tension of both runs at "
                    f"rest)"]
        return []

    def reaction(self, G, F, lam, setup):
        """Each run's tension along its tangent line, on i and j only (reaction_sign). Of the
        two runs (tangent lines of the pitch circles: outer for an open belt, crossing for a
        crossed one) the tight one is the run whose pull turns pulley j the way the belt's
        torque on j does."""
        out = gradient_force(G, F, lam)
        ok = setup["ok"]
        if not ok.any():
            return out
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        xi, yi = global_point(F, bi, np.nan_to_num(setup["ci"]))
        xj, yj = global_point(F, bj, np.nan_to_num(setup["cj"]))
        ri, rj = G.params["ri"], G.params["rj"]
        crossed = G.params["crossed"] > 0.5
        sig = np.where(crossed, -1.0, 1.0)                  # side of j's tangent point
        dx, dy = xj - xi, yj - yi
        dist = np.hypot(dx, dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            ex, ey = dx / dist, dy / dist
            sb = np.where(crossed, ri + rj, ri - rj) / dist
        cb = np.sqrt(np.maximum(1.0 - sb * sb, 0.0))
        Mj = -lam[..., 0] * self._radii(G)[1]               # the belt's torque on j
        phys = np.zeros_like(out)
        # the + run (m = cb R e + sb e): its pull -T t on j at c_j + sig rj m has the moment
        # -T sig rj (m x t) about c_j; m x t = -1 for this run
        mu_plus = sig * 1.0
        tight = np.where(mu_plus * Mj >= 0, 1.0, -1.0)
        dT = np.abs(Mj) / rj
        slack = np.maximum(setup["pretension"] - 0.5 * dT, 0.0)
        for side, T in ((tight, slack + dT), (-tight, slack)):
            mx, my = -side * cb * ey + sb * ex, side * cb * ex + sb * ey
            tix, tiy = xi + ri * mx, yi + ri * my
            tjx, tjy = xj + sig * rj * mx, yj + sig * rj * my
            run = np.hypot(tjx - tix, tjy - tiy)
            fx, fy = -T * (tjx - tix) / run, -T * (tjy - tiy) / run
            force_at(F, bj, tjx, tjy, fx, fy, phys, 1)
            force_at(F, bi, tix, tiy, fx, fy, phys, 0, -1.0)
        return np.where(ok[None, :, None, None], phys, out)

    def reaction_setup(self, G, pivots, L):
        out = carrier_centres(G, pivots)
        out["pretension"] = G.params["pretension"] * L          # internal force units
        return out

    @staticmethod
    def _radii(G):
        """The gear relation's coefficients: -rj for an open belt, +rj for a crossed one."""
        return G.params["ri"], np.where(G.params["crossed"] > 0.5, 1.0, -1.0) * G.params["rj"]

    def prepare(self, arrays, poses):
        pi_, pj, pk = (p[2] for p in poses)
        rj = (1.0 if arrays["crossed"] > 0.5 else -1.0) * arrays["rj"]
        return {}, [arrays["ri"] * (pi_ - pk) + rj * (pj - pk)]

    def draw(self, G, k, parts):
        """The pulleys' pitch circles and, on the frame, the two straight runs between the
        pulleys' ground pivots (on a moving carrier the runs are not drawn)."""
        super().draw(G, k, parts)
        ground = parts.ground
        if parts.body(G, k, 2) != ground:
            return
        c = [parts.pivot(ground, parts.body(G, k, col), origin=False) for col in (0, 1)]
        if c[0] is None or c[1] is None:
            return
        r1, r2 = parts.point(G, k, "ri"), parts.point(G, k, "rj")
        crossed = G.params["crossed"][k] > 0.5
        d = np.hypot(*(c[1] - c[0]))
        sb = ((r1 + r2) if crossed else (r1 - r2)) / d
        if not d > 0 or abs(sb) >= 1:
            return
        e = (c[1] - c[0]) / d
        n = np.array([-e[1], e[0]])
        for side in (1.0, -1.0):
            m = side * n * np.sqrt(1 - sb * sb) + e * sb
            parts.outline(ground, np.array([c[0] + r1 * m, c[1] + (-r2 if crossed else r2) * m]))
