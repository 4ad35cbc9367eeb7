"""Sliding kinds (reference §2.6, §2.8): translational joint and pin-in-slot.

Both use the line through point si of body i along the unit direction u_i = A_i u'_i, with
normal n_i = R u_i, and h = r_j + s_j - r_i - s_i. The translational joint adds the parallelism
equation in its linear form phi_j - phi_i - c (reference §2.6 note: it cannot snap to the
anti-parallel root); c is fixed when the model is compiled from vi, vj and the body estimates.
"""

from __future__ import annotations

import math

import numpy as np

from . import jerk as J
from .base import Frame, Group, Param, PointLineKind, relative_point, rotate
from .revolute import dir_to_body, to_body


def slide_line(G: Group, F: Frame):
    """(u, n, s_i, s_j, h) of the slide line of body i, each as x, y arrays (N, K)."""
    six, siy, sjx, sjy, hx, hy = relative_point(G, F)
    v = G.params["vi"]
    ux, uy = rotate(F, G.bodies[:, 0], v[:, 0], v[:, 1])
    return ux, uy, -uy, ux, six, siy, sjx, sjy, hx, hy


def _line_chains(G: Group, F: Frame):
    """Chains (planarkin.elements.jerk) of u_i, n_i and h of the slide line."""
    ux, uy, nx, ny, six, siy, sjx, sjy, hx, hy = slide_line(G, F)
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    return (J.fixed(F, bi, (ux, uy)), J.fixed(F, bi, (nx, ny)),
            J.pair(F, bi, (six, siy), bj, (sjx, sjy)))


def normal_jerk(G: Group, F: Frame):
    _, n, h = _line_chains(G, F)
    return -J.dot(n, h)


def along_jerk(G: Group, F: Frame):
    """jerk_g of u_i^T h (the slide; a rolling constraint adds only a linear angle term)."""
    u, _, h = _line_chains(G, F)
    return -J.dot(u, h)


class Translational(PointLineKind):
    name = "translational"
    equation = "translational"        # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 2                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "sj", "vi", "vj")
    at_axis = True
    reaction_columns = ("fx", "fy", "torque")
    neq = 2
    params = (
        Param("si", "point", "a point of the sliding axis on body i in its frame"),
        Param("sj", "point", "a point of the sliding axis on body j in its frame"),
        Param("vi", "vector", "axis direction on body i in its frame"),
        Param("vj", "vector", "axis direction on body j in its frame"),
    )
    at_form = "[x, y] with axis: [dx, dy]: a global point of the sliding axis and its direction"
    reaction_sign = (
        'fx, fy: the force of body i on body j (global), normal to the axis (no friction); '
        "torque: the moment of i on j about j's point sj, counter-clockwise positive. Body i gets "
        'minus both')
    summary = "prismatic joint: j slides along an axis of i without relative rotation (2 equations)"
    equations = "phi_j - phi_i - c0 = 0 (c0 from vi, vj); n_i^T (r_j + A_j s'_j - r_i - A_i s'_i) = 0"

    def row_unit(self, k):
        return "angle" if k == 0 else "length"        # phi_j - phi_i = c0; n_i^T h = 0

    def prepare(self, arrays, poses):
        return {}, [parallel_constant(arrays["vi"], arrays["vj"], poses[0][2], poses[1][2]), 0.0]

    def jerk(self, G, F):
        out = np.zeros((F.q.shape[0], len(G), 2))
        out[..., 1] = normal_jerk(G, F)
        return out

    def place(self, at, poses, given):
        axis = given["axis"]
        return {"si": to_body(at, poses[0]), "sj": to_body(at, poses[1]),
                "vi": dir_to_body(axis, poses[0]), "vj": dir_to_body(axis, poses[1])}

    def draw(self, G, k, parts):
        """The slide: an axis on ground or a slot on a moving guide; a lone block along it."""
        bi, si, bj, sj = parts.axis_points(G, k)
        vi = G.params["vi"][k]
        parts.slide(bi, si, vi, bj, sj)
        if bj != parts.ground:
            parts.slide_direction(bj, G.params["vj"][k])
        elif bi != parts.ground:
            parts.slide_direction(bi, vi)


class PinSlot(PointLineKind):
    name = "pin-slot"
    equation = "pinslot"              # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 7                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "vi", "sj")
    at_axis = True
    target_default = 0.0              # the pin on the slot's line
    reaction_columns = ("fx", "fy")              # normal to the slot, no moment about the pin
    params = (
        Param("si", "point", "a point of the slot's centre line on body i in its frame"),
        Param("vi", "vector", "slot direction on body i in its frame"),
        Param("sj", "point", "the pin on body j in its frame"),
    )
    target = "c"
    target_unit = "length"
    at_form = "[x, y] with axis: [dx, dy]: the pin's global position and the slot direction"
    reaction_sign = (
        'fx, fy: the force of the slot (body i) on the pin (body j), normal to the slot line; no '
        'moment about the pin. Body i gets minus it')
    summary = ("pin-in-slot (revolute-translational composite): pin sj of j stays on the slot line "
               "of i, at signed offset c (default 0) (1 equation)")
    equations = "n_i^T (r_j + A_j s'_j - r_i - A_i s'_i) - c = 0"

    def jerk(self, G, F):
        return normal_jerk(G, F)[..., None]

    def place(self, at, poses, given):
        axis = given["axis"]
        return {"si": to_body(at, poses[0]), "sj": to_body(at, poses[1]),
                "vi": dir_to_body(axis, poses[0])}

    def draw(self, G, k, parts):
        """The slot (an axis on ground) and the pin running in it."""
        bi, si, bj, sj = parts.joint_points(G, k)
        parts.slide(bi, si, G.params["vi"][k], bj, sj)
        if bj != parts.ground:
            parts.pin(bj, sj)


class Slide(PointLineKind):
    """Slide of a translational joint (reference §5.6): u_i^T h = f(t), the displacement of the
    point sj of j along the axis of i measured from si. Drives a slider or a linear actuator."""

    name = "slide"
    equation = "slide"                # g, grad, gamma: planarkin.elements.pointline
    compiled_code = 8                 # planarkin.elements.pointline.CODES
    compiled_params = ("si", "vi", "sj")
    joint = False
    driver = True
    params = (
        Param("si", "point", "origin of the slide on body i in its frame"),
        Param("vi", "vector", "slide direction on body i in its frame"),
        Param("sj", "point", "the sliding point on body j in its frame"),
    )
    target = "c"
    target_unit = "length"
    reaction_sign = (
        'driver only: effort (.force): what the actuator exerts on body j along the slide axis '
        'u_i, positive along +u_i; the actuator pushes i back as much')
    summary = "slide along an axis: u_i^T (P_j - P_i) = f(t) (1 equation)"
    driver_equations = "u_i^T (r_j + A_j s'_j - r_i - A_i s'_i) - f(t) = 0"

    def draw(self, G, k, parts):
        """The slide's line and the point sliding on it."""
        bi, si, bj, sj = parts.joint_points(G, k)
        parts.slide(bi, si, G.params["vi"][k], bj, sj)

    def jerk(self, G, F):
        return along_jerk(G, F)[..., None]


def parallel_constant(vi, vj, phi_i, phi_j) -> float:
    """c of phi_j - phi_i = c making A_i vi parallel to A_j vj, the multiple of pi nearest the
    estimates (an axis given anti-parallel on one body still means the same slide line)."""
    base = math.atan2(vi[1], vi[0]) - math.atan2(vj[1], vj[0])
    k = round(((phi_j - phi_i) - base) / math.pi)
    return base + k * math.pi
