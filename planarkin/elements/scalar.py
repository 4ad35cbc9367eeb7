"""Single-equation kinds (reference §1, §2.1-2.4, §5): relative angle, x, y and distance.

With i = ground these are the absolute constraints. Each is a joint (g = c) or a driver
(g = f(t)): nu = f' and gamma = gamma_g + f'' are added by the system, not here.
"""

from __future__ import annotations

import numpy as np

from . import jerk as J
from .base import Param, PointLineKind, rotate

_POINTS = (
    Param("si", "point", "point on body i in its frame"),
    Param("sj", "point", "point on body j in its frame"),
)


class Angle(PointLineKind):
    name = "angle"
    equation = "angle"                # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 3                 # planarkin.elements.pointline.CODES
    compiled_params = ()
    reaction_columns = ("torque",)               # a pure moment
    driver = True
    params = ()
    target = "c"
    target_unit = "angle"
    reaction_sign = (
        'torque: the moment body i exerts on body j (counter-clockwise positive), a pure moment; '
        "i gets minus it. As a driver (.torque) the actuator's torque on j")
    summary = "relative angle: phi_j - phi_i = c (1 equation)"
    equations = "phi_j - phi_i - c = 0"
    driver_equations = "phi_j - phi_i - f(t) = 0"

    def jerk(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 1))

    def draw(self, G, k, parts):
        """Nothing of its own: the bodies are drawn by their other joints."""
        parts.joint_points(G, k)


def _pair_chain(G, F):
    """Chain (jerk.pair) of h = P_j - P_i of the instances' points si, sj."""
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    pi_, pj = G.params["si"], G.params["sj"]
    return J.pair(F, bi, rotate(F, bi, pi_[:, 0], pi_[:, 1]), bj,
                  rotate(F, bj, pj[:, 0], pj[:, 1]))


class _Component(PointLineKind):
    """x or y component of h = P_j - P_i (reference §2.1, §2.2)."""

    driver = True
    params = _POINTS
    target = "c"
    target_unit = "length"
    axis = 0

    def jerk(self, G, F):
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        pi_, pj = G.params["si"], G.params["sj"]
        ai = J.third(F, bi, rotate(F, bi, pi_[:, 0], pi_[:, 1]))
        aj = J.third(F, bj, rotate(F, bj, pj[:, 0], pj[:, 1]))
        return (ai[self.axis] - aj[self.axis])[..., None]

    def draw(self, G, k, parts):
        """Its two points on the bodies' outlines, nothing between them."""
        parts.joint_points(G, k)


class XDistance(_Component):
    name = "x"
    equation = "xdistance"            # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 4                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "sj")
    reaction_columns = ("fx", "fy")
    axis = 0
    reaction_sign = (
        'fx: the force on j at P_j along the global x axis (fy = 0); i gets minus it at P_i (a '
        "couple about P_j when the points differ in y). As a driver (.force) the actuator's force "
        'on j along +x')
    summary = "x of P_j - P_i = c (1 equation); with i: ground, the absolute x of a point"
    equations = "x_j + (A_j s'_j)_x - x_i - (A_i s'_i)_x - c = 0"
    driver_equations = "x_j + (A_j s'_j)_x - x_i - (A_i s'_i)_x - f(t) = 0"


class YDistance(_Component):
    name = "y"
    equation = "ydistance"            # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 5                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "sj")
    reaction_columns = ("fx", "fy")
    axis = 1
    reaction_sign = (
        'fy: the force on j at P_j along the global y axis (fx = 0); i gets minus it at P_i. As a '
        "driver (.force) the actuator's force on j along +y")
    summary = "y of P_j - P_i = c (1 equation); with i: ground, the absolute y of a point"
    equations = "y_j + (A_j s'_j)_y - y_i - (A_i s'_i)_y - c = 0"
    driver_equations = "y_j + (A_j s'_j)_y - y_i - (A_i s'_i)_y - f(t) = 0"


class Distance(PointLineKind):
    """|P_j - P_i| = c, unsquared (reference §5.5c): its gradient is a unit vector, so the row is
    as well scaled as a revolute row; c > 0 (a zero distance is a revolute joint)."""

    name = "distance"
    equation = "distance"             # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 6                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "sj")
    at_points = 2
    target_from_at = True
    between = True
    positive_target = True
    reaction_columns = ("fx", "fy")              # along the line between the points
    driver = True
    params = _POINTS
    target = "c"
    target_unit = "length"
    at_form = "[[x1, y1], [x2, y2]]: global positions of the point on i and the point on j"
    reaction_sign = (
        'fx, fy: the force on j at P_j, along the line P_i -> P_j (pointing from P_i to P_j '
        "when the link pushes j away, in compression); i gets minus it at P_i. As a driver "
        "(.force) the actuator's force on j along P_i -> P_j, positive pushing apart")
    summary = "distance |P_j - P_i| = c, a massless link pinned at both ends (1 equation)"
    equations = "|r_j + A_j s'_j - r_i - A_i s'_i| - c = 0"
    driver_equations = "|r_j + A_j s'_j - r_i - A_i s'_i| - f(t) = 0   (f > 0)"

    def validate(self, V, params, given, what):
        c = params.get("c")
        if c is not None and c <= 0:
            V.err(given["c"], f"{what}: the distance c must be positive, not {c:g} (for a zero "
                              f"distance use a revolute joint)")

    def jerk(self, G, F):
        # |h|''' = e^T h''' + 3 h'^T H h'' + T[h', h', h'] with H = (I - e e^T) / d the Hessian
        # of |h| and T[v, v, v] = -3 (e^T v)(v^T v - (e^T v)^2) / d^2 its third derivative
        h, h1, h2, h3 = _pair_chain(G, F)
        d = np.hypot(*h)
        ex, ey = h[0] / d, h[1] / d
        e1 = ex * h1[0] + ey * h1[1]
        e2 = ex * h2[0] + ey * h2[1]
        hess = (h1[0] * h2[0] + h1[1] * h2[1] - e1 * e2) / d
        third = -3.0 * e1 * (h1[0] ** 2 + h1[1] ** 2 - e1 * e1) / (d * d)
        return -(ex * h3[0] + ey * h3[1] + 3.0 * hess + third)[..., None]

    def place(self, at, poses, given):
        from .revolute import to_body

        p, q = np.asarray(at[0], float), np.asarray(at[1], float)
        out = {"si": to_body(p, poses[0]), "sj": to_body(q, poses[1])}
        if "c" not in given:
            out["c"] = float(np.hypot(*(q - p)))
        return out

    def draw(self, G, k, parts):
        """A thin link between two pins (pivots on ground)."""
        bi, si, bj, sj = parts.joint_points(G, k)
        parts.pin(bi, si)
        parts.pin(bj, sj)
        parts.link(bi, si, bj, sj)
