"""A path started from a neighbour's solution instead of followed from scratch: the warm start
of an analysis (`Analysis(cm, A, opts, warm=Start)`), for design studies' variants.

A design study solves the same structure many times, and for a 360-step run most of the time
goes into following the path (dozens of adaptive steps, each a few Newton solves at candidate
points). A neighbouring variant's internal nodes are an excellent prediction: `warm_nodes`
corrects them to the model all at once (one batched Newton solve over every node, the same call
the grid pass makes over time points), and the corrected nodes are taken only if they pass every
test the path follower applies to a step it takes:

* the step-acceptance rule at every node (planarkin.solver.acceptance: Newton converged, its first
  correction small against the smallest singular value, finite positions, velocities and
  accelerations, the determinant sign of every fine block the neighbour's), with the condition
  bound COND_WARN (no follower runs to report a near-singular passage: such a model gets the
  full follower and its warnings);
* node 0 the model's own assembled pose (the branch a plain run takes);
* between consecutive nodes the Taylor predictor error, forwards and backwards, within
  path_tol (acceptance.path_errors: the nodes are as dense as the follower would have made
  them; intervals that fail are split, up to REFINE times).

Anything else (a neighbour that stopped or warned, redundant constraints, a driver breakpoint
inside the run, another time range, a failed test) gives None: the analysis follows the path
as usual, so its results are those of a cold run to rounding.
"""

from __future__ import annotations

import numpy as np

from .acceptance import COND_WARN, accepted, condition, path_errors
from .path import NODE_TOL, PATH_POLICY, Nodes, hermite5

REFINE = 6      # rounds of interval splitting before falling back to the follower


class Start:
    """What a solved analysis hands to its neighbour: its nodes (internal units), their
    fine-block signs and the model's length scale L."""

    def __init__(self, an):
        self.L = an.cm.L
        self.T = an.Tn.copy()
        self.Q, self.Qd, self.Qdd = an.Qn.copy(), an.Qdn.copy(), an.Qddn.copy()
        self.sign = np.array(an.follower.nodes.sign)

    @staticmethod
    def usable(an) -> bool:
        """Whether an's path can start a neighbour: it reached the end without warnings (no
        near-singular passage, breakpoint or switch of redundant rows) on one segment."""
        return (an.event is None and not an.follower.warnings and not an.A.redundant_rows
                and len(an.Tn) > 1 and not an.seg.any())

    @classmethod
    def of(cls, an) -> "Start | None":
        return cls(an) if cls.usable(an) else None


def warm_nodes(S, A, opts, kinks, start: Start) -> Nodes | None:
    """The path nodes of the model of System S (the path follower's; A its assembly, opts its
    options, kinks its drivers' breakpoints) from the neighbour's start, corrected to it; None
    when any test of the module docstring fails."""
    n = S.n
    if A.redundant_rows or start.Q.shape[1] != n + 3 or start.T[0] != opts.start \
            or start.T[-1] != opts.end or any(opts.start < k.t < opts.end for k in kinks):
        return None
    Q, Qd, Qdd = start.Q.copy(), start.Qd.copy(), start.Qdd.copy()
    if start.L != S.cm.L:             # another power-of-two length scale: rescale the lengths
        r = start.L / S.cm.L
        for X in (Q, Qd, Qdd):
            X[:, 0:n:3] *= r
            X[:, 1:n:3] *= r
    T = start.T
    with np.errstate(all="ignore"):
        info = S.solve_batch(T, Q, Qd, Qdd, policy=PATH_POLICY, tol=NODE_TOL, maxit=12, order=2)
        if not _taken(info, Q, Qd, Qdd, start.sign):
            return None
        # the model's own assembly: node 0 must be its assembled pose (its branch)
        if np.abs(Q[0, :n] - A.q[:n]).max() > 1e-8:
            return None
        sign, cond = info.sign, condition(info)
        for _ in range(REFINE):
            bad = path_errors(T, Q, Qd, Qdd, n) > opts.path_tol
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
            if not _taken(im, Qm, Qdm, Qddm, sign[i]):
                return None
            at = i + 1
            T = np.insert(T, at, tm)
            Q, Qd, Qdd = (np.insert(X, at, Y, axis=0) for X, Y in ((Q, Qm), (Qd, Qdm),
                                                                   (Qdd, Qddm)))
            sign = np.insert(sign, at, im.sign, axis=0)
            cond = np.insert(cond, at, condition(im))
        else:
            return None
    nodes = Nodes()
    for i in range(len(T)):
        nodes.add(T[i], Q[i], Qd[i], Qdd[i], sign[i], cond[i], 0)
    return nodes


def _taken(info, Q, Qd, Qdd, sign) -> bool:
    """Every node passes the step-acceptance rule (without a follower: bound COND_WARN)."""
    return bool(accepted(info, sign, (Q, Qd, Qdd), cond_max=COND_WARN).all())
