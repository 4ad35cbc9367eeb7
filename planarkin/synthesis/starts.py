"""The starts of a search analysed together: designs as the rows of one grid pass.

Every start of a search is analysed over its whole cycle before it is refined
(`Synthesis.candidates`). One at a time that is the path follower's analysis (`analyse`) per
design, most of its time the same numpy calls on a few numbers. Here a batch of designs
is marched over the grid together:

* the numbers the free parameters reach are evaluated for every design at once from the file's
  expressions (`studies.batch.Batch.numbers`, in the nominal model's internal units), and the
  grid pass's System reads them as per-row parameters (`Batch.system`);
* each design starts from its own compiled pose estimate at the first grid time and is marched
  over NODES intervals of the grid, all designs in one call of the grid pass's Newton
  (`System.solve_batch`, full Newton) per step, from each design's Taylor prediction
  (position, velocity, acceleration and the jerk of the step before); a design whose step
  fails a test takes as many substeps as its Taylor error asks for (up to MAX_SUBSTEPS), as
  the path follower shortens its step;
* every step is held to the tests the path follower applies to a step
  (`planarkin.solver.acceptance`): converged, the first correction within KAPPA of the smallest
  singular value, finite velocities and accelerations, the condition under COND_WARN, every fine
  block's determinant sign the one at the start (the same assembly branch), and the Taylor
  predictor's error forwards and backwards within path_tol;
* then every grid row of every design is solved in one call from the quintic Hermite
  interpolant of its nodes and held to the same step tests, as the path follower fills the
  grid between its own nodes.

A design that fails any test, or whose driver has a breakpoint in the range (where the follower
splits its path and takes one-sided rates), is left to the path follower (None in its place), which accepts it
or refuses it with its reason; so a start is never refused here. An accepted design's Result has
the path follower's rows (the grid times) in user units, to rounding.
"""

from __future__ import annotations

import numpy as np

from ..results import Result
from ..results.runinfo import RunInfo
from ..solver.acceptance import COND_WARN, accepted, condition, taylor_error
from ..solver.chunks import Chunk
from ..solver.kinematics import point_kinematics
from ..solver.path import driver_breakpoints, hermite5
from .problem import Rejected

AHEAD = 64           # starts analysed together
MIN_BATCH = 5        # fewer designs: the path follower, one by one (quicker; benchmarks/README.md)
NODES = 32           # grid intervals marched over (every grid row is then solved at once)
MAX_SUBSTEPS = 64    # steps between two nodes, at most (then the path follower decides)


def ahead(syn, X, first: int) -> dict:
    """Starts X[first:] of a Synthesis screened until AHEAD pass (Synthesis.screen), and those
    analysed together: start index -> Rejected (the screen's), (cm, opts, Result) (an analysis
    over the whole cycle, not yet counted), or None (the path follower's, one by one:
    Model.analyse)."""
    from ..options import Options
    out, designs, where = {}, [], []
    for e in range(first, len(X)):
        if len(designs) >= AHEAD:
            break
        values = syn.model.values(X[e])
        got = syn.screen(values)
        out[e] = got if isinstance(got, Rejected) else None
        if got is not None and not isinstance(got, Rejected):
            designs.append((values, got))
            where.append(e)
    if syn.starts_batch is False:                       # not built yet
        syn.starts_batch = batch_for(syn.model)
    if syn.starts_batch is None or not designs:
        return out
    opts_of = lambda cm: Options.from_model(cm, **syn.model.analysis)  # noqa: E731
    for e, (_, cm), res in zip(where, designs, march(syn.starts_batch, designs, opts_of)):
        if res is not None:
            out[e] = (cm, res.info.options, res)
    return out


def batch_for(model):
    """The batched form of the synthesis Model's study for its free parameters
    (Model.batch), or None when the model does not take it (the starts are then analysed one
    by one): also when the file asks for an assembly branch (`assembly: branch:`), which the
    follower's assembly switches to and a march from the drawn pose would not."""
    return None if model.study.nominal.spec.branch else model.batch()


def march(B, designs, opts_of) -> list:
    """Results of designs analysed together, None where the path follower must decide.

    B: batch_for's Batch; designs: (values dict, compiled model) per design; opts_of: cm ->
    the Options its analysis would use. Returns a list of Result or None, in order."""
    out = [None] * len(designs)
    if len(designs) < MIN_BATCH:
        return out
    num = B.numbers([v for v, _ in designs])
    nominal = B.cm
    n = nominal.n
    unit = _user(nominal)                                   # nominal internal -> user
    Q0 = np.zeros((len(designs), n + 3))
    for i, (_, cm) in enumerate(designs):
        Q0[i, :n] = cm.q0 * _user(cm) / unit
    grid = B.grid
    # a driver's breakpoint splits the follower's path there and sets its rows' one-sided
    # rates (SIDE_RULE): such a design is left to the follower
    smooth = np.array([not driver_breakpoints(cm, grid[0], grid[-1]) for _, cm in designs])
    go = np.nonzero(num[4] & np.isfinite(Q0).all(axis=1) & smooth)[0]
    if len(go) < MIN_BATCH:
        return out
    stride = max(1, (len(grid) - 1) // NODES)
    at = np.unique(np.append(np.arange(0, len(grid), stride), len(grid) - 1))
    M = _Marcher(B, B.take(num, go), Q0[go], grid[at])
    # a design whose pose estimate is rough (the file's q, not an exact pose) fails the first
    # solve's tests, which hold it to a step's; it starts from the follower's own assembly
    # there (planarkin.solver.assembly.assemble), as the follower does
    rough = np.setdiff1d(np.arange(len(go)), M.live)
    if len(rough):
        for j in rough:
            cm = designs[go[j]][1]
            q = _assembled(cm, grid[0])
            if q is not None:
                Q0[go[j], :n] = q * _user(cm) / unit
        M = _Marcher(B, B.take(num, go), Q0[go], grid[at])
    for k in range(1, len(at)):
        if not M.interval(k):
            break
    got = M.fill(grid) if len(M.live) else None
    if got is None:
        return out
    live, (Q, Qd, Qdd), iters, cond = got
    for j, i in enumerate(go[live]):
        out[i] = _result(designs[i][1], opts_of(designs[i][1]), grid, Q[j], Qd[j], Qdd[j],
                         unit, iters[j], cond[j])
    return out


class _Marcher:
    """Designs marched over nodes of the grid (times T), each interval in one step or, for the
    designs whose step fails a test there, in equal substeps (`interval`); then every grid row
    solved at once from the nodes' interpolant (`fill`)."""

    def __init__(self, B, num, Q0, T):
        self.B, self.num, self.T = B, num, T
        o = B.study.opts
        self.tol, self.maxit, self.path_tol = o.tol, max(o.iterations, 8), o.path_tol
        V, K = len(Q0), len(T)
        self.Q, self.Qd, self.Qdd = (np.zeros((V, K, Q0.shape[1])) for _ in range(3))
        rows = np.arange(V)
        got = self.solve(rows, np.full(V, T[0]), Q0.copy(), np.zeros_like(Q0),
                         np.zeros_like(Q0), None)
        good, (q, qd, qdd), info = got
        self.live = rows[good]
        self.sign = info.sign[good]                 # each design's branch at the start
        self.Q[self.live, 0], self.Qd[self.live, 0], self.Qdd[self.live, 0] = \
            q[good], qd[good], qdd[good]
        self.j3 = np.zeros((V, Q0.shape[1]))        # the jerk of each design's last step

    def solve(self, rows, t, P, Pd, Pdd, sign):
        """Solve designs rows (indices into num) at one time (t: (len(rows),), all equal)
        from the predictions P, Pd, Pdd (solved in place): (accepted, (P, Pd, Pdd), info)."""
        B = self.B
        groups, targets, _, env, _ = self.num
        S = B.system([{name: a[rows] for name, a in g.items()} for g in groups])
        T, NU, FDD = B.drivers(targets[rows], {k: v[rows] for k, v in env.items()}, t[:1])
        drivers = (T[:, 0], NU[:, 0], FDD[:, 0])
        with np.errstate(all="ignore"):
            info = S.solve_batch(t, P, Pd, Pdd, policy="full", tol=self.tol, maxit=self.maxit,
                                 order=2, drivers=drivers, fused=False)
        return accepted(info, sign, (Pd, Pdd), cond_max=COND_WARN), (P, Pd, Pdd), info

    def interval(self, k: int) -> bool:
        """Advance every live design from node k - 1 to node k; False when none is left. A
        design whose step fails a test is tried again in more substeps: as many as its Taylor
        error asks for (the error falls as the fourth power of the step), at least twice as
        many, up to MAX_SUBSTEPS."""
        a, b = self.T[k - 1], self.T[k]
        subs = np.ones(len(self.live), dtype=int)   # per live design
        todo = np.arange(len(self.live))            # positions in self.live
        done = np.zeros(len(self.live), dtype=bool)
        while len(todo):
            for sub in np.unique(subs[todo]):
                pos = todo[subs[todo] == sub]
                ok, err = self._steps(k, a, b, int(sub), pos)
                done[pos[ok]] = True
                with np.errstate(all="ignore"):
                    need = np.ceil(1.25 * (err[~ok] / self.path_tol) ** 0.25)
                more = np.where(np.isfinite(need), np.maximum(need, 2), 4)
                subs[pos[~ok]] = sub * 2 ** np.ceil(np.log2(more)).astype(int)
            todo = todo[~done[todo] & (subs[todo] <= MAX_SUBSTEPS)]
        self.live, self.sign = self.live[done], self.sign[done]
        return len(self.live) > 0

    def _steps(self, k, a, b, sub, pos):
        """Designs self.live[pos] from node k - 1 to k in sub equal steps, kept at node k where
        every step passes. Returns (passed, the largest Taylor error of each's steps)."""
        n = self.B.cm.n
        rows = self.live[pos]
        q, qd, qdd = (A[rows, k - 1].copy() for A in (self.Q, self.Qd, self.Qdd))
        j3 = self.j3[rows].copy()
        ok = np.ones(len(rows), dtype=bool)
        worst = np.zeros(len(rows))
        h = (b - a) / sub
        for s in range(sub):
            ts = b if s == sub - 1 else a + (s + 1) * h
            pred = q + h * qd + 0.5 * h * h * qdd + h ** 3 / 6.0 * j3
            P, Pd, Pdd = pred.copy(), qd + h * qdd, qdd.copy()
            good, _, info = self.solve(rows, np.full(len(rows), ts), P, Pd, Pdd,
                                       self.sign[pos])
            with np.errstate(all="ignore"):
                err = taylor_error(np.full((len(rows), 1), h), q[:, :n], qd[:, :n],
                                   qdd[:, :n], j3[:, :n], P[:, :n], Pd[:, :n], Pdd[:, :n],
                                   pred[:, :n])
            worst = np.maximum(worst, np.where(good, err, np.nan))
            ok &= good & (err <= self.path_tol)
            j3 = (Pdd - qdd) / h
            q, qd, qdd = P, Pd, Pdd
        for A, v in ((self.Q, q), (self.Qd, qd), (self.Qdd, qdd)):
            A[rows[ok], k] = v[ok]
        self.j3[rows[ok]] = j3[ok]
        return ok, worst

    def fill(self, grid):
        """Every grid row of the live designs solved in one call from the quintic Hermite
        interpolant of their nodes and held to the step tests (the branch of the start), as
        the path follower fills the grid between its nodes. Returns (the designs that pass,
        indices into num; (Q, Qd, Qdd) (V, K, n + 3); iterations (V, K); condition (V, K)),
        or None when none passes."""
        B, live, T = self.B, self.live, self.T
        V, K = len(live), len(grid)
        k = np.clip(np.searchsorted(T, grid, side="right") - 1, 0, len(T) - 2)
        h = (T[k + 1] - T[k])[None, :, None]
        s = (grid - T[k])[None, :, None] / h
        Q, Qd, Qdd = self.Q[live], self.Qd[live], self.Qdd[live]
        P = hermite5(s, h, Q[:, k], Qd[:, k], Qdd[:, k], Q[:, k + 1], Qd[:, k + 1],
                     Qdd[:, k + 1])
        P, Pd, Pdd = P.reshape(V * K, -1), np.zeros((V * K, P.shape[2])), \
            np.zeros((V * K, P.shape[2]))
        groups, targets, _, env, _ = self.num
        S = B.system([{name: np.repeat(a[live], K, axis=0) for name, a in g.items()}
                      for g in groups])
        drivers = tuple(a.reshape(V * K, -1) for a in
                        B.drivers(targets[live], {x: v[live] for x, v in env.items()}, grid))
        with np.errstate(all="ignore"):
            info = S.solve_batch(np.tile(grid, V), P, Pd, Pdd, policy="full", tol=self.tol,
                                 maxit=self.maxit, order=2, drivers=drivers, fused=False)
        ok = accepted(info, np.repeat(self.sign, K, axis=0), (Pd, Pdd),
                      cond_max=COND_WARN).reshape(V, K).all(axis=1)
        arrays = tuple(a.reshape(V, K, -1) for a in (P, Pd, Pdd))
        if not ok.any():
            return None
        return (live[ok], tuple(a[ok] for a in arrays),
                info.iterations.reshape(V, K)[ok], condition(info).reshape(V, K)[ok])


def _user(cm) -> np.ndarray:
    """(n,) the factors from cm's internal units to its user units (x, y, phi per body)."""
    return np.tile([cm.L, cm.L, 1.0 / cm.angle_factor], cm.nb)


def _assembled(cm, t0):
    """The pose the path follower starts from (internal units of cm), or None when the
    assembly refuses the design (the follower then says why)."""
    from ..diagnostics import InputError
    from ..solver.assembly import assemble
    try:
        return assemble(cm, t0).q
    except InputError:
        return None


def _result(cm, opts, grid, Q, Qd, Qdd, unit, iterations, cond) -> Result:
    """The Result of one marched design in its own model's units (the path follower's rows)."""
    n = cm.n
    own = _user(cm)
    q, qd, qdd = (a[:, :n] * unit for a in (Q, Qd, Qdd))
    ext = lambda a: np.concatenate([a / own, np.zeros((len(a), 3))], axis=1)  # noqa: E731
    order = opts.order
    P, Pd, Pdd = point_kinematics(cm, ext(q), ext(qd), ext(qdd) if order >= 2 else None)
    chunk = Chunk(grid.copy(), q, qd, qdd if order >= 2 else None, P * cm.L, Pd * cm.L,
                  Pdd * cm.L if order >= 2 else None, iterations, cond,
                  np.zeros(len(grid)))
    info = RunInfo(status=0, message="", options=opts, event=None, warnings=[], assembly={},
                   internal_steps=0, rejected_steps=0, fallbacks=0)
    return Result(cm, chunk, info)
