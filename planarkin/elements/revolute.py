"""Revolute joint (reference §2.5): point si of body i coincides with point sj of body j.

Haug's sign convention: g = r_i + s_i - r_j - s_j (two equations, x and y).
"""

from __future__ import annotations

import numpy as np

from . import jerk as J
from .base import Frame, Group, Param, PointLineKind, empty, rotate


class Revolute(PointLineKind):
    name = "revolute"
    equation = "revolute"             # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 1                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "sj")
    reaction_columns = ("fx", "fy")              # no moment about the pin
    neq = 2
    params = (
        Param("si", "point", "joint point on body i in its frame"),
        Param("sj", "point", "joint point on body j in its frame"),
    )
    at_form = "[x, y]: the joint's global position at the assembly pose"
    reaction_sign = (
        'fx, fy: the force of body i on body j at the pin (global); no moment about the pin. Body '
        'i gets minus it')
    summary = "pin joint: point si of i and point sj of j coincide (2 equations)"
    equations = "r_i + A_i s'_i - r_j - A_j s'_j = 0"

    def _s(self, G: Group, F: Frame):
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        si, sj = G.params["si"], G.params["sj"]
        return bi, bj, rotate(F, bi, si[:, 0], si[:, 1]), rotate(F, bj, sj[:, 0], sj[:, 1])

    def jerk(self, G, F):
        # g = r_i + s_i - r_j - s_j: jerk_g = -(s3_i - s3_j) (the origins' third derivatives
        # are all in g_q q-triple-dot)
        bi, bj, si, sj = self._s(G, F)
        ai, aj = J.third(F, bi, si), J.third(F, bj, sj)
        out = empty(F, len(G), 2)
        out[..., 0], out[..., 1] = aj[0] - ai[0], aj[1] - ai[1]
        return out

    def place(self, at, poses, given):
        return {"si": to_body(at, poses[0]), "sj": to_body(at, poses[1])}

    def draw(self, G, k, parts):
        """A pin at the joint (a pivot when one side is ground)."""
        bi, si, bj, sj = parts.joint_points(G, k)
        parts.pin(bi, si)
        parts.pin(bj, sj)


def to_body(point, pose):
    """Body-frame coordinates s' = A(phi)^T (P - r) of a global point P for a body at pose."""
    x, y, phi = pose
    c, s = np.cos(phi), np.sin(phi)
    dx, dy = point[0] - x, point[1] - y
    return np.array([c * dx + s * dy, -s * dx + c * dy])


def dir_to_body(vector, pose):
    """Body-frame direction A(phi)^T v of a global direction v."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([c * vector[0] + s * vector[1], -s * vector[0] + c * vector[1]])
