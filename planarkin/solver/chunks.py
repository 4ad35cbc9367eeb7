"""Rows of a solver Chunk taken and joined: what the results, the writers and the studies share."""

from __future__ import annotations

import numpy as np

from planarkin.solver.grid import Chunk


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
