"""Gears and belts at the assembled pose: centre distances that the teeth or the belt can take
(checked by planarkin.assembly once the pose is found)."""

from __future__ import annotations

import numpy as np

from .diagnostics import Diagnostic


def _diag(cm, row: int, msg: str, severity="error") -> Diagnostic:
    return Diagnostic(cm.spec.file, cm.element_of_row(row).line, msg, severity)


MESH_WARN = 1e-6      # relative centre-distance error of a gear pair that is worth a warning
MESH_ERROR = 0.1      # ... and that no tooth form can take up: an error


def centre_distances(cm, q: np.ndarray) -> list[Diagnostic]:
    """Gears and belts at the assembled pose q: a gear pair's centre distance must be |ri + rj|
    (a warning above MESH_WARN relative, an error above MESH_ERROR: the teeth cannot mesh),
    belt pulleys must not overlap (an error). The centres of the kinds on a carrier (gear,
    belt) are their revolute joints to the carrier k; a pair without them is not checked."""
    from .elements.base import make_frame, rotate
    L, lu = cm.L, cm.spec.length_unit
    F = make_frame(np.concatenate([q, np.zeros(3)])[None, :])
    pivots = {}
    for G in cm.groups:
        if G.kind.name == "revolute":
            for (bi, bj), si, sj in zip(G.bodies, G.params["si"], G.params["sj"]):
                pivots.setdefault((int(bi), int(bj)), si)
                pivots.setdefault((int(bj), int(bi)), sj)

    def centre(b, s):
        x, y = rotate(F, np.array([b]), s[0], s[1])
        return np.array([F.q[0, 3 * b] + x[0, 0], F.q[0, 3 * b + 1] + y[0, 0]])

    out = []
    for G in cm.groups:
        name = G.kind.name
        if name not in ("gear", "gear-mesh", "belt"):
            continue
        for k in range(len(G)):
            bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
            if name == "gear-mesh":
                ci, cj = G.params["si"][k], G.params["sj"][k]
            else:
                bk = int(G.bodies[k, 2])
                ci, cj = pivots.get((bi, bk)), pivots.get((bj, bk))
                if ci is None or cj is None:
                    continue
            d = float(np.hypot(*(centre(bj, cj) - centre(bi, ci))))
            ri, rj = float(G.params["ri"][k]), float(G.params["rj"][k])
            row = int(G.rows[k, 0])
            label = cm.element_of_row(row).label
            if name == "belt":
                if not d > ri + rj:
                    out.append(_diag(cm, row, f"{label}: the pulleys overlap: their centres are "
                                              f"{d * L:.6g} {lu} apart, not more than ri + rj = "
                                              f"{(ri + rj) * L:.6g} {lu}"))
                continue
            want = abs(ri + rj)
            dev = abs(d - want) / want
            if dev > MESH_WARN:
                grossly = dev > MESH_ERROR
                out.append(_diag(cm, row, f"{label}: the centre distance is {d * L:.6g} {lu} but "
                                          f"the pitch radii give |ri + rj| = {want * L:.6g} {lu}"
                                          + (" (more than 10% off: the teeth cannot mesh); "
                                             "correct the radii or the centres" if grossly else
                                             "; the gears turn at the ratio of the radii all the "
                                             "same"), "error" if grossly else "warning"))
    return out
