"""The free times of a path target without inputs (Synthesis.projected): the nearest points of
the path to the target's points, in order, and the residuals measured from them (the signed
distances along the path's normal, or to an open run's end), with their exact gradient
directions. Variable projection: at the nearest point the time is stationary, so the distance's
derivative with respect to the parameters needs no derivative of the time."""

from __future__ import annotations

import numpy as np

from .problem import Rejected

PROJECT_STEPS = 30    # Gauss-Newton steps of a projected time (see project)
PROJECT_TOL = 1e-12   # ... until the tangential offset is below this (times the targets' size)


def project(syn, cm, res, tg, t0):
    """The times of a path target's points without inputs: from the grid's nearest points
    in order (t0), the nearest points of the path, h(t) = pd . (P - T) = 0, by Newton with
    h' = |pd|^2 + pdd . (P - T) on the exact position, velocity and acceleration (Gauss-
    Newton, h' = |pd|^2, where h' <= 0), each step at most two grid steps; done when the
    point's tangential offset is below PROJECT_TOL of the targets' size. Rejected when a
    solve fails or it does not converge in PROJECT_STEPS."""
    j = syn.points.index(tg.name)
    T = np.array(tg.values)
    tol = PROJECT_TOL * max(1.0, float(np.abs(T).max()))
    t = np.array(t0, dtype=float)
    most = 2 * float(np.diff(res.t).max())
    for _ in range(PROJECT_STEPS):
        st = syn.model.solve_at(cm, res, syn.wrapped(t), sens=False, accel=True)
        syn.project_solves += 1
        if isinstance(st, Rejected):
            return st
        P, V, A = st.p[:, j], st.pd[:, j], st.pdd[:, j]
        vv = (V * V).sum(axis=1)
        if not (vv > 0).all():
            return Rejected("the path point stands still at a target time")
        h = ((P - T) * V).sum(axis=1)
        done = np.abs(h) <= tol * np.sqrt(vv)
        if not syn.wrap:       # an end of the run, the path's nearest point beyond it:
            done |= ((t <= syn.start) & (h > 0)) | ((t >= syn.end) & (h < 0))   # the end
        if np.all(done):
            return t
        hd = vv + ((P - T) * A).sum(axis=1)
        t = t - np.clip(h / np.where(hd > 0, hd, vv), -most, most)
        if not syn.wrap:       # an open run's path ends where the run does
            t = np.clip(t, syn.start, syn.end)
    return Rejected("the nearest points of the path did not converge")


def directions(syn, st, tg, sl, rr):
    """(N, 2) unit vectors along which a projected target's residuals are measured: the
    path's normal where the time is the nearest point's (P - T is normal there), and at an
    end of an open run, where the nearest point of the run's path is the end itself and
    P - T is not normal, the direction of P - T (signed as the normal's, so the residual is
    the distance |P - T| with the side the normal gives it)."""
    V = st.pd[sl, syn.points.index(tg.name)]
    n = np.stack([-V[:, 1], V[:, 0]], axis=1) / np.hypot(V[:, 0], V[:, 1])[:, None]
    t = st.t[sl]
    end = ((t <= syn.start) | (t >= syn.end)) if not syn.wrap else np.zeros(len(t), bool)
    dist = np.hypot(rr[:, 0], rr[:, 1])
    end &= dist > 0
    if end.any():
        side = np.where((rr * n).sum(axis=1) < 0, -1.0, 1.0)
        n = np.where(end[:, None], side[:, None] * rr / np.where(dist > 0, dist, 1.0)[:, None],
                     n)
    return n


def normal(syn, st, tg, sl, rr):
    """(N,) signed distances along the path's normal at projected times: at the nearest
    point (P - T) is normal to the path, so |distance| = |P - T| and, the time being
    stationary, d(distance)/dp = n . dP/dp exactly (the tangential part drops out). At an
    end of an open run the time is held there (an active bound): the distance along
    P - T itself, and d(distance)/dp = e . dP/dp (directions)."""
    return (rr * directions(syn, st, tg, sl, rr)).sum(axis=1)
