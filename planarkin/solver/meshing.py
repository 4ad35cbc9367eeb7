"""The assembled pose's checks beyond the equations (checked by planarkin.solver.assembly once the pose
is found): each kind's own (Kind.check_pose: a gear pair's centre distance that the teeth can
take, belt pulleys that do not overlap)."""

from __future__ import annotations

import numpy as np

from planarkin.diagnostics import Diagnostic
from planarkin.elements.base import make_frame, pivots


def centre_distances(cm, q: np.ndarray) -> list[Diagnostic]:
    """Diagnostics (errors and warnings, at the element's line) of every instance whose kind
    finds fault with the assembled pose q (n,), internal units."""
    F = make_frame(np.concatenate([q, np.zeros(3)])[None, :])
    where = pivots(cm.groups)
    out = []
    for G in cm.groups:
        for k, severity, msg in G.kind.check_pose(G, F, where, cm.L, cm.spec.length_unit):
            el = cm.element_of_row(int(G.rows[k, 0]))
            out.append(Diagnostic(cm.spec.file, el.line, f"{el.label}: {msg}", severity))
    return out
