"""Point kinematics from body coordinates (reference section 0): positions, velocities,
accelerations and jerks of the model's points, internal units, batched over time points."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel



def point_kinematics(cm: CompiledModel, Q, Qd=None, Qdd=None):
    """Positions, velocities, accelerations of the model's points (internal units), (N, P, 2) each:
    r_P = r + s, v_P = rdot + w R s, a_P = rddot + alpha R s - w^2 s with s = A s' (reference §0)."""
    b = cm.point_body
    if len(b) == 0:
        z = np.zeros((Q.shape[0], 0, 2))
        return z, (z if Qd is not None else None), (z if Qdd is not None else None)
    phi = Q[:, 3 * b + 2]
    c, s = np.cos(phi), np.sin(phi)
    sx = c * cm.point_s[:, 0] - s * cm.point_s[:, 1]
    sy = s * cm.point_s[:, 0] + c * cm.point_s[:, 1]
    p = np.stack([Q[:, 3 * b] + sx, Q[:, 3 * b + 1] + sy], axis=-1)
    pd = pdd = None
    if Qd is not None:
        w = Qd[:, 3 * b + 2]
        pd = np.stack([Qd[:, 3 * b] - w * sy, Qd[:, 3 * b + 1] + w * sx], axis=-1)
        if Qdd is not None:
            a = Qdd[:, 3 * b + 2]
            pdd = np.stack([Qdd[:, 3 * b] - a * sy - w * w * sx,
                            Qdd[:, 3 * b + 1] + a * sx - w * w * sy], axis=-1)
    return p, pd, pdd


def point_jerk(cm: CompiledModel, Q, Qd, Qdd, Qddd):
    """Jerks of the model's points (internal units), (N, P, 2): with s = A s' (reference §0),
    j_P = r^(3) + phi^(3) R s - 3 omega alpha s - omega^3 R s."""
    b = cm.point_body
    if len(b) == 0:
        return np.zeros((Q.shape[0], 0, 2))
    phi = Q[:, 3 * b + 2]
    c, s = np.cos(phi), np.sin(phi)
    sx = c * cm.point_s[:, 0] - s * cm.point_s[:, 1]
    sy = s * cm.point_s[:, 0] + c * cm.point_s[:, 1]
    w, a, j = Qd[:, 3 * b + 2], Qdd[:, 3 * b + 2], Qddd[:, 3 * b + 2]
    k = j - w ** 3                      # coefficient of R s
    m = -3.0 * w * a                    # coefficient of s
    return np.stack([Qddd[:, 3 * b] - k * sy + m * sx, Qddd[:, 3 * b + 1] + k * sx + m * sy],
                    axis=-1)
