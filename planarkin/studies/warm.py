"""Variants started from a neighbour's solution instead of a path followed from scratch.

A design study solves the same structure many times, and for a 360-step run most of the time
goes into following the path (dozens of adaptive steps, each a few Newton solves at candidate
points). A neighbouring variant's internal nodes are an excellent prediction: here they are
corrected to the variant all at once (one batched Newton solve over every node, the same call
the grid pass makes over time points), and the corrected nodes are accepted only if they pass
every test the path follower applies to a step it takes:

* Newton converged at every node, its first correction small against the smallest singular
  value (KAPPA), finite velocities and accelerations, condition below COND_SINGULAR;
* the determinant sign of every fine block equal at every node to the neighbour's (no other
  assembly branch) and node 0 equal to the variant's own assembled pose (the branch a plain
  run of the variant would take);
* between consecutive nodes the Taylor predictor error, forwards and backwards, within
  path_tol (so the nodes are as dense as the follower would have made them);
* no node above COND_WARN (a near-singular passage gets the full follower and its warnings).

Anything else (a neighbour that stopped, redundant constraints, a failed test) falls back to
the ordinary path follower, so a variant's results are those of `planarkin run` with its
parameters to rounding (the grid pass then solves every grid point as usual). Which neighbour
starts which variant depends only on the variant's position in its chain (see `chains`), never
on how the chains are distributed over processes: parallel runs equal the serial run bit for bit.
"""

from __future__ import annotations

import numpy as np

from ..solver import (COND_SINGULAR, COND_WARN, KAPPA, NODE_TOL, PATH_POLICY, Analysis, cond_of,
                      hermite5)

CHAIN = 32      # variants per chain: the first starts cold, each next from its predecessor
REFINE = 6      # rounds of interval splitting before falling back to the follower


class Start:
    """What a solved variant hands to its neighbour: its nodes (internal units) and signs."""

    def __init__(self, an: Analysis):
        self.L = an.cm.L
        self.T = an.Tn.copy()
        self.Q, self.Qd, self.Qdd = an.Qn.copy(), an.Qdn.copy(), an.Qddn.copy()
        self.sign = np.array(an.follower.nodes.sign)

    @staticmethod
    def usable(an: Analysis) -> bool:
        return (an.event is None and not an.follower.warnings and not an.A.redundant_rows
                and len(an.Tn) > 1 and not an.seg.any())


def warm_follow(an: Analysis, start: Start) -> bool:
    """Fill an's nodes from the neighbour's, corrected to an's model; False (an untouched)
    when any acceptance test fails."""
    f = an.follower
    cm = an.cm
    if an.A.redundant_rows or start.Q.shape[1] != cm.n + 3 or \
            start.T[0] != an.opts.start or start.T[-1] != an.opts.end:
        return False
    S = f.S
    n = S.n
    Q, Qd, Qdd = start.Q.copy(), start.Qd.copy(), start.Qdd.copy()
    if start.L != cm.L:             # another power-of-two length scale: rescale the lengths
        r = start.L / cm.L
        for A in (Q, Qd, Qdd):
            A[:, 0:n:3] *= r
            A[:, 1:n:3] *= r
    T = start.T
    with np.errstate(all="ignore"):
        info = S.solve_batch(T, Q, Qd, Qdd, policy=PATH_POLICY, tol=NODE_TOL, maxit=12, order=2)
        if not _accept(info, Q, Qd, Qdd, start.sign):
            return False
        # the variant's own assembly: node 0 must be its assembled pose (its branch)
        if np.abs(Q[0, :n] - an.A.q[:n]).max() > 1e-8:
            return False
        sign, cond = info.sign, cond_of(info)
        for _ in range(REFINE):
            bad = predictor_error(T, Q, Qd, Qdd, n) > an.opts.path_tol
            if not bad.any():
                break
            # split the intervals the follower would not have accepted, as it splits a step
            i = np.nonzero(bad)[0]
            h = (T[i + 1] - T[i])[:, None]
            tm = T[i] + 0.5 * h[:, 0]
            args = (np.full_like(h, 0.5), h, Q[i], Qd[i], Qdd[i], Q[i + 1], Qd[i + 1], Qdd[i + 1])
            Qm, Qdm, Qddm = hermite5(*args), hermite5(*args, deriv=1), hermite5(*args, deriv=2)
            im = S.solve_batch(tm, Qm, Qdm, Qddm, policy=PATH_POLICY, tol=NODE_TOL, maxit=12,
                               order=2)
            if not _accept(im, Qm, Qdm, Qddm, sign[i]):
                return False
            at = i + 1
            T = np.insert(T, at, tm)
            Q, Qd, Qdd = (np.insert(A, at, B, axis=0) for A, B in ((Q, Qm), (Qd, Qdm),
                                                                   (Qdd, Qddm)))
            sign = np.insert(sign, at, im.sign, axis=0)
            cond = np.insert(cond, at, cond_of(im))
        else:
            return False
    N = f.nodes
    for i in range(len(T)):
        N.add(T[i], Q[i], Qd[i], Qdd[i], sign[i], cond[i], 0)
    an.Tn = T.copy()
    an.Qn, an.Qdn, an.Qddn = Q, Qd, Qdd
    an.Cn = np.array(N.cond)
    an.seg = np.zeros(len(T), dtype=np.intp)
    an.crossing = np.zeros(len(T), dtype=bool)
    an.signs = {0: np.array(N.sign)}
    an.event = None
    an.t_stop = an.opts.end
    return True


def _accept(info, Q, Qd, Qdd, sign) -> bool:
    """The follower's per-node tests (see the module docstring)."""
    return bool(info.converged.all() and (info.ratio <= KAPPA).all()
                and np.isfinite(Q).all() and np.isfinite(Qd).all() and np.isfinite(Qdd).all()
                and (cond_of(info) <= min(COND_SINGULAR, COND_WARN)).all()
                and (info.sign == sign).all())


def predictor_error(T, Q, Qd, Qdd, n) -> np.ndarray:
    """(K-1,) the follower's step error per interval: the Taylor prediction (with the jerk from
    the previous node) against the next node, forwards and backwards."""
    h = np.diff(T)[:, None]
    j3 = np.zeros_like(Q[:-1])
    j3[1:] = (Qdd[1:-1] - Qdd[:-2]) / h[:-1]
    pred = Q[:-1] + h * Qd[:-1] + 0.5 * h * h * Qdd[:-1] + h ** 3 / 6.0 * j3
    ef = np.abs(Q[1:, :n] - pred[:, :n]).max(axis=1)
    j3c = (Qdd[1:] - Qdd[:-1]) / h
    back = Q[1:] - h * Qd[1:] + 0.5 * h * h * Qdd[1:] - h ** 3 / 6.0 * j3c
    eb = np.abs(back[:, :n] - Q[:-1, :n]).max(axis=1)
    return np.maximum(ef, eb)


def analyse(cm, opts, start: Start | None = None):
    """Like planarkin.results.analyse (in memory), started from a neighbour when one is given.
    Returns (info, result, Start for the next variant or None, warm: whether it was used)."""
    import time
    from ..assembly import assemble
    from ..chunks import concat
    from ..results import Result, run_info
    t0 = time.perf_counter()
    A = assemble(cm)
    an = Analysis(cm, A, opts)
    an.timings["assembly"] = time.perf_counter() - t0
    warm = start is not None and warm_follow(an, start)
    if not warm:
        an.follow()
    parts = list(an.chunks())
    info = run_info(an)
    res = Result(cm, concat(parts) if parts else None, info)
    return info, res, (Start(an) if Start.usable(an) else None), warm


def chains(n: int, size: int = CHAIN) -> list[range]:
    """The variant indices 0..n-1 cut into chains of `size`: the unit of work of a process."""
    return [range(a, min(a + size, n)) for a in range(0, n, size)]
