"""The columns of bodies.csv and points.csv: which a run writes and how they are filled from a
chunk ('model only what a scene requires'). What the results, the writers, the plots and the
studies share; the CSV writers themselves are planarkin.output.tables.

bodies.csv: ``t [s]``, then per body (file order) ``<b>.x <b>.y <b>.phi <b>.vx <b>.vy <b>.omega
<b>.ax <b>.ay <b>.alpha`` (and with up_to: jerk ``<b>.jx <b>.jy <b>.jphi``) with units in
brackets; points.csv: ``t [s]``, then per point ``<p>.x <p>.y <p>.vx <p>.vy <p>.ax <p>.ay`` (and
``<p>.jx <p>.jy``).
"""

from __future__ import annotations

import numpy as np


BODY_QUANTITIES = (("x", "y", "phi"), ("vx", "vy", "omega"), ("ax", "ay", "alpha"),
                   ("jx", "jy", "jphi"))


POINT_QUANTITIES = (("x", "y"), ("vx", "vy"), ("ax", "ay"), ("jx", "jy"))


def units(length: str, angle: str, order: int, time: str = "s"):
    """Unit labels of (translation, rotation) for derivative order 0, 1, 2, 3."""
    suffix = ("", f"/{time}", f"/{time}^2", f"/{time}^3")[order]
    return length + suffix, angle + suffix


class Layout:
    """Which columns a run writes ('model only what a scene requires') and how to fill them.

    bodies/points: indices of the selected bodies and points; order: highest derivative written.
    """

    def __init__(self, cm, order: int, bodies=None, points=None):
        self.cm = cm
        self.order = order
        names = list(cm.body_names)
        self.bodies = [names.index(b) for b in bodies] if bodies is not None else \
            list(range(len(names)))
        pnames = list(cm.point_names)
        self.points = [pnames.index(p) for p in points] if points is not None else \
            list(range(len(pnames)))
        L, A = cm.spec.length_unit, cm.spec.angle_unit
        self.body_header = ["t [s]"]
        for b in self.bodies:
            for o in range(order + 1):
                lu, au = units(L, A, o)
                qx, qy, qphi = BODY_QUANTITIES[o]
                name = cm.body_names[b]
                self.body_header += [f"{name}.{qx} [{lu}]", f"{name}.{qy} [{lu}]",
                                     f"{name}.{qphi} [{au}]"]
        self.point_header = ["t [s]"]
        for p in self.points:
            for o in range(order + 1):
                lu, _ = units(L, A, o)
                qx, qy = POINT_QUANTITIES[o]
                name = cm.point_names[p]
                self.point_header += [f"{name}.{qx} [{lu}]", f"{name}.{qy} [{lu}]"]

    def body_table(self, ch) -> np.ndarray:
        """(N, columns) array of a Chunk in body_header order."""
        N = len(ch.t)
        per = 3 * (self.order + 1)
        out = np.empty((N, 1 + per * len(self.bodies)))
        out[:, 0] = ch.t
        arrays = (ch.q, ch.qd, ch.qdd, ch.qddd)
        for k, b in enumerate(self.bodies):
            base = 1 + per * k
            for o in range(self.order + 1):
                out[:, base + 3 * o: base + 3 * o + 3] = arrays[o][:, 3 * b: 3 * b + 3]
        return out

    def point_table(self, ch) -> np.ndarray:
        N = len(ch.t)
        per = 2 * (self.order + 1)
        out = np.empty((N, 1 + per * len(self.points)))
        out[:, 0] = ch.t
        arrays = (ch.p, ch.pd, ch.pdd, ch.pddd)
        for k, p in enumerate(self.points):
            base = 1 + per * k
            for o in range(self.order + 1):
                out[:, base + 2 * o: base + 2 * o + 2] = arrays[o][:, p, :]
        return out
