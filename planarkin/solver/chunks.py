"""A solver Chunk (the results at a slice of the grid) and its rows taken and joined: what the
results, the writers and the studies share."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Chunk:
    """Results at a slice of the grid, user units.

    t: (N,) seconds; q, qd, qdd: (N, n) body coordinates per body x, y, phi (length, angle units;
    None above the requested order); p, pd, pdd: (N, P, 2) point positions, velocities and
    accelerations; iterations: (N,) Newton iterations; cond: (N,) condition estimate;
    residual: (N,) max |Phi| over all equations, internal units (relative to the model length L).
    qddd (N, n), pddd (N, P, 2): jerks (length/s^3, angle/s^3), None unless up_to: jerk.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None
    p: np.ndarray
    pd: np.ndarray | None
    pdd: np.ndarray | None
    iterations: np.ndarray
    cond: np.ndarray
    residual: np.ndarray
    qddd: np.ndarray | None = None
    pddd: np.ndarray | None = None


def take(ch: Chunk, sel) -> Chunk:
    """The rows sel of a chunk (an index array or a slice)."""
    g = lambda a: None if a is None else a[sel]
    return Chunk(ch.t[sel], ch.q[sel], g(ch.qd), g(ch.qdd), ch.p[sel], g(ch.pd), g(ch.pdd),
                 ch.iterations[sel], ch.cond[sel], ch.residual[sel], g(ch.qddd), g(ch.pddd))


def concat(parts: list[Chunk]) -> Chunk:
    """The chunks' rows in order, as one chunk."""
    def cat(name):
        arrays = [getattr(p, name) for p in parts]
        return None if arrays[0] is None else np.concatenate(arrays)
    return Chunk(*(cat(f) for f in ("t", "q", "qd", "qdd", "p", "pd", "pdd", "iterations", "cond",
                                    "residual", "qddd", "pddd")))
