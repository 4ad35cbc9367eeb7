"""Synthesis: the design that makes a model do what its `design:` block asks.

In a full evaluation (`Synthesis.evaluate`: the design analysed over its whole cycle) the
unknowns x are the free parameters (in their units), for every motion target without
prescribed inputs one time per pose (s): the input values are the driver's values at those
times, and last the offsets (and steps) of targets whose inputs are relative to an unknown
offset (planarkin.synthesis.timing, in the driver's unit). A path target without inputs has
no time unknowns there: its times are projected
(`planarkin.synthesis.projection`: the nearest points of the path, in order), its residuals are
the signed normal distances to the targets, and their gradient n . dP/dp is exact because the
projected time is stationary (variable projection). Other residuals are weighted differences in
the model's units (point coordinates; angles wrapped to a half turn). A `turns:` constraint on a
four-bar loop adds one barrier row (planarkin.synthesis.margins), zero away from a change point.
The method:

1. a Latin hypercube (scipy.stats.qmc, seeded) of `starts` designs over the bounds (and the
   file's own values with search nominal: 1); a design whose four-bar loop cannot turn is
   refused from its compiled model alone (`screen`), the others are analysed over the whole
   range, starts.AHEAD at a time as the rows of one grid pass (planarkin.synthesis.starts),
   and a design that fails a step test there by the path follower (`Model.analyse`: validate
   with overrides, compile, solve), with the same results to rounding; designs that cannot be
   assembled, lock up or violate a constraint are rejected with their reason; the free times
   of the others are chosen on their grid (the nearest points, in order along the path, in
   either direction);
2. from the best `local` of them, a local run (planarkin.synthesis.local; `_run`: one cut
   by its per_local budget while it leads the search goes on from its end): scipy's
   least_squares (trust region, the exact Jacobian, the bounds by a change of variables) on
   trials solved at the target inputs only, every free time an unknown, the branch kept by
   continuation from the last accepted iterate; the run's result is then checked over its
   whole cycle (`evaluate(final=True)`: assembles everywhere, on its branch, every
   constraint), and if it fails, the last accepted iterate that passes (bisection over the
   run's trail), so every returned design is verified over its whole cycle;
3. the best `keep` distinct designs are kept (distinct: 1e-3 of a bound's range apart);
4. until the goal is met or a budget runs out (evaluations, counted; time, on `clock`), the
   next `starts` are drawn from the same seeded generator (Synthesis.draw) and 1-3 repeated,
   whatever became of the earlier draws; a local run leaves one evaluation of the budget for
   its full check, so the count ends at the budget. SynthResult.ended says what ended it.

With search batch: the starts are analysed a batch at a time, each batch's accepted run best
first, and the search ends at the first `keep` designs below the goal; with probe: a local
run is abandoned when it falls too slowly (planarkin.synthesis.local.probe_limits), and an
abandoned run is checked over its cycle only when it would be kept. The six collinear points
(straight-line.yaml) need that: about one local run in 650 from the Latin-hypercube starts
lands in the basin of an exact solution (the others slide down a valley, the linkage growing
until a bound stops it, SSE 1e-6 .. 1e-4 mm^2), and it shows by converging superlinearly, so
hundreds to a few thousand probed runs of ~30 trials replace 20 long ones
(benchmarks/bench_synth.py; benchmarks/README.md, "Figures moved from the code's comments").
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..output.directory import checkpoint
from . import projection, starts, timing
from .local import Local, probe_limits
from .margins import (angle_span, barrier, length_gradients, turning_loop,
                      worst_transmission)
from .problem import UNWORDED, Model, Rejected, State, wrap
from .runs import Ahead, run_from
from .settings import check_cost, search_options, settled
from .spec import design_of

DISTINCT = 1e-3       # designs closer than this (fraction of every bound range) are the same
STOP = 1e-6          # a local run stops at this fraction of the goal (converged for the goal)
IDLE_STARTS = 10_000  # starts in a row refused before any analysis end the search ('refused')
clock = time.perf_counter     # the time budget's clock (a test may replace it)


@dataclass
class Design:
    """One design: x (free parameters then free times), cost (sum of squared weighted
    residuals), residuals per target, margins per constraint, status 'ok' or the reason."""

    x: np.ndarray
    values: dict
    times: list
    cost: float
    residuals: list
    margins: dict
    state: State | None = None
    nfev: int = 0
    njev: int = 0
    message: str = ""
    where: list = field(default_factory=list)   # per target: its rows of the state's times


@dataclass
class SynthResult:
    status: int                 # 0 designs found, 1 none acceptable
    message: str
    designs: list
    rejected: dict              # reason -> count (global start)
    evaluations: int
    jacobians: int
    seconds: float
    design: object = None
    model: object = None
    starts: list = field(default_factory=list)
    analyses: int = 0           # of the evaluations, those analysing a design's whole cycle
    runs: int = 0               # local runs started
    interrupted: str | None = None      # the signal that stopped the search, if one did
    ended: str | None = None    # what ended it: goal, evaluations, time, refused (see _search)


class Synthesis:
    """The residuals of a model's design block and their exact Jacobian."""

    def __init__(self, path, overrides=None, analysis=None):
        from ..model.yamlread import read_file
        from ..model.compile import compile_model
        from ..model.validate import validate
        root = read_file(path)
        spec = compile_model(validate(root, str(path), overrides)).spec
        self.design = design_of(root, spec)
        self.model = Model(path, list(self.design.free), overrides, analysis)
        self.k = len(self.design.free)
        self.lo = np.array([b[0] for b in self.design.free.values()])
        self.hi = np.array([b[1] for b in self.design.free.values()])
        cm = self.model.nominal
        self.points = list(cm.point_names)
        self.bodies = list(cm.body_names)
        self.unit = cm.spec.angle_unit
        self.lunit = cm.spec.length_unit
        if self.design.shortest and turning_loop(cm, self.design.turns) is None:
            from ..diagnostics import Diagnostic, InputError
            raise InputError([Diagnostic(str(path), self.design.line, (
                f"design: constraints: turns: shortest: true needs '{self.design.turns}' to be "
                f"a link of a four-bar loop pinned to ground (it is not)"))])
        a = self.model.study.opts
        self.start, self.end = a.start, a.end
        # free times of a motion target without inputs: unknowns, one per pose; those of a path
        # target without inputs are projected (solved in evaluate: the nearest points in order)
        self.free_t = []                      # (target index, entry index)
        self.projected = []                   # target indices
        for i, tg in enumerate(self.design.targets):
            if tg.kind == "motion" and tg.free_timing:
                self.free_t += [(i, j) for j in range(len(tg))]
            elif tg.kind == "path" and tg.free_timing:
                self.projected.append(i)
        self.nt = len(self.free_t)
        # inputs relative to an unknown offset (and step): unknowns after the free times
        self.timing = timing.layout(self.design.targets)
        self.closed = any(tg.closed for tg in self.design.targets)   # see candidates
        self.nu = len(self.timing)
        self.project_solves = 0               # solves at target times of the projections
        self.wrap = False
        self.use_barrier = True
        self.band = self.design.search["band"]    # the barrier's band (margins.barrier)
        self._cache = None
        self.wall = None
        self.progress = None          # called by tick(evaluations, best sum of squares so far)
        self.best = math.inf          # of the designs evaluated over their whole cycle
        self.local = None             # the Local of the search (its trials are evaluations)
        self.runs = 0                 # local runs started
        self._draws = None            # [(n, seed), index, generator, starts] (see draw)
        self.starts_batch = False     # starts.batch_for's, built at the first starts analysed
        self.drawn = 0                # starts examined (over every draw)
        self.refusals = set()         # the reasons of the starts refused (full text, a draw)
        self.ended = None             # what ended the search: goal, evaluations, time, refused

    # -- layout ------------------------------------------------------------------------------
    def bounds(self):
        T = self.end - self.start
        tlo, thi = (self.start - T, self.end + T) if self.wrap else (self.start, self.end)
        ulo, uhi = self.timing_bounds()
        return (np.concatenate([self.lo, np.full(self.nt, tlo), ulo]),
                np.concatenate([self.hi, np.full(self.nt, thi), uhi]))

    def timing_bounds(self):
        """(lo, hi) of the offsets and steps (timing.bounds); in a model that returns to its
        start an offset may go a travel beyond them either side (its inputs wrap)."""
        lo, hi = timing.bounds(self)
        if self.wrap:
            for c, (_, name) in enumerate(self.timing):
                if name == "offset":
                    u0, u1 = timing.travel(self, self.model.nominal)
                    lo[c], hi[c] = lo[c] - abs(u1 - u0), hi[c] + abs(u1 - u0)
        return lo, hi

    def wrapped(self, t):
        if not self.wrap:
            return np.asarray(t, dtype=float)
        T = self.end - self.start
        return self.start + np.mod(np.asarray(t, dtype=float) - self.start, T)

    # -- evaluation --------------------------------------------------------------------------
    def evaluate(self, x, jac: bool = True, final: bool = False, analysed=None):
        """(residual vector, Jacobian or None, Design) or (None, None, Rejected). final: the
        order of free times is a constraint too (see below). analysed: the design's analysis
        (Model.analyse) when the caller has it already."""
        values = self.model.values(x[:self.k])
        out = analysed if analysed is not None else self.model.analyse(values)
        if isinstance(out, Rejected):
            return None, None, out
        cm, opts, res = out
        tfree = self.wrapped(x[self.k:self.k + self.nt])
        grid = self._grid_times(res) if self.projected else {}
        times, where = [], []
        for i, tg in enumerate(self.design.targets):
            if tg.inputs is not None or tg.timing is not None:
                tt = self.model.times_of(cm, res, tg.inputs) if tg.timing is None else \
                    timing.times(self, cm, res, i, x[self.k + self.nt:])
                if isinstance(tt, Rejected):
                    return None, None, tt
            elif i in grid:
                tt = projection.project(self, cm, res, tg, grid[i])
                if isinstance(tt, Rejected):
                    return None, None, tt
            else:
                tt = np.array([tfree[self.free_t.index((i, j))] for j in range(len(tg))])
            where.append(slice(len(times), len(times) + len(tt)))
            times += list(tt)
        # projected times may have stepped past the end of a cycle: solved where they are
        st = self.model.solve_at(cm, res, self.wrapped(np.array(times)), sens=False)
        if isinstance(st, Rejected):
            return None, None, st
        margins = self.margins(cm, res, tfree, st.t, where)
        # order is checked on the result only (final): a wall there would stop the steps of
        # two free times that pass each other on the way to their targets
        bad = [f"{k}: {m['value']:.6g} (needs {m['needs']})" for k, m in margins.items()
               if not m["ok"] and (final or k != "order")]
        if bad:
            return None, None, Rejected("constraint " + "; ".join(bad))
        per, r, cost = [], [], 0.0
        for i, tg in enumerate(self.design.targets):
            rr, _ = self.target_residuals(tg, i, st, where[i], None, False)
            per.append(rr)
            cost += float((rr * tg.weight).ravel() @ (rr * tg.weight).ravel())
            r.append((projection.normal(self, st, tg, where[i], rr) if i in self.projected
                      else rr.ravel())
                     * tg.weight)
        barrier = self.barrier(cm)
        r = np.concatenate(r + [[barrier[0]]] if barrier else r)
        d = Design(x=np.array(x, dtype=float), values=values,
                   times=[st.t[sl].tolist() for sl in where], cost=cost,
                   residuals=per, margins=margins, state=st)
        d.where = where
        d.barrier = barrier
        return r, (self.jacobian(d) if jac else None), d

    def score(self, values: dict, rest=()):
        """A given design checked as a returned one is (its whole cycle, on its branch, every
        constraint): its Design, or Rejected. values: the free parameters by name; rest: the
        unknowns after them (free times, offsets and steps). Free times wrap around the cycle
        as in a search (timing.settle_wrap)."""
        got = self.model.analyse(values)
        if isinstance(got, Rejected):
            return got
        timing.settle_wrap(self, got[2])
        x = np.array([values[n] for n in self.design.free] + list(rest), dtype=float)
        return self.evaluate(x, jac=False, final=True, analysed=got)[2]

    def jacobian(self, d: Design) -> np.ndarray:
        """The exact Jacobian of an evaluated design's residuals (len(r), k + nt)."""
        st = d.state
        self.model.add_sensitivities(st)
        J = []
        for i, tg in enumerate(self.design.targets):
            sl = d.where[i]
            dtdx = self.input_dtdx(st.cm, tg, i, st.t[sl], self.free_t)
            Jt = self.target_residuals(tg, i, st, sl, dtdx, True)[1]
            if i in self.projected:          # n . dP/dp (projection.normal)
                n = projection.directions(self, st, tg, sl, d.residuals[i])
                Jt = np.einsum("ec,eck->ek", n, Jt.reshape(len(n), 2, -1))
            J.append(Jt * tg.weight)
        if d.barrier:
            J.append(np.concatenate([self.barrier_gradient(st.cm, d.barrier),
                                     np.zeros(self.nt + self.nu)])[None, :])
        return np.concatenate(J)

    # -- the turns constraint's barrier row (planarkin.synthesis.margins) --------------------
    def barrier(self, cm):
        """(residual, loop) of the turns constraint's barrier row, or None (no four-bar loop
        named by turns:, or no barrier wanted)."""
        if self.design.turns is None or not self.use_barrier:
            return None
        loop = turning_loop(cm, self.design.turns, self.design.shortest)
        if loop is None:
            return None
        m = loop.margin()
        return (barrier(m, np.zeros(0), sum(loop.lengths), np.zeros(0), self.band)[0] if m > 0
                else 0.0), loop

    def barrier_gradient(self, cm, bar) -> np.ndarray:
        from ..studies.sensitivity import derivatives
        loop = bar[1]
        texts = self.model.study.texts()
        texts.update({k: float(v) for k, v in cm.spec.parameters.items() if k in self.model.free})
        D = derivatives(self.model.study.root, cm.spec.parameters, texts, self.model.free)
        dl = length_gradients(loop, cm, self.model.study.root, D)
        m = loop.margin()
        return barrier(m, loop.gradient(dl), sum(loop.lengths), dl.sum(axis=0),
                       self.band)[1]

    def input_dtdx(self, cm, tg, i, t, free_t):
        """(N, k + len(free_t) + nu) dt/dx of a target's inputs at their times t (prescribed:
        -f_p / f_t; relative to an unknown offset: timing.dtdx), None for free timing."""
        ncol = self.k + len(free_t) + self.nu
        if tg.timing is not None:
            return timing.dtdx(self, cm, i, t, ncol, self.k + len(free_t))
        return timing.prescribed_dtdx(self, cm, t, ncol) if tg.inputs is not None else None

    def target_residuals(self, tg, i, st, sl, dtdx, jac, free_t=None):
        """Residuals (N, c) of one target and their Jacobian rows (N c, k + len(free_t) + nu).
        free_t: the (target, entry) pairs whose times are unknowns (default: self.free_t;
        planarkin.synthesis.local makes a path target's times unknowns too); dtdx: the
        inputs' dt/dx (input_dtdx) or None (free times)."""
        free_t = self.free_t if free_t is None else free_t
        n = sl.stop - sl.start
        cols = []                  # per component: value (N,), d/dp (N, k), d/dt (N,)
        if tg.kind in ("path", "motion"):
            j = self.points.index(tg.point if tg.kind == "motion" else tg.name)
            vals = np.array(tg.values)
            for c in range(2):
                cols.append((st.p[sl, j, c] - vals[:, c],
                             st.dp[sl, j, c] if jac else None, st.pd[sl, j, c]))
        if tg.kind in ("function", "motion"):
            if tg.kind == "function":
                body, _, qty = tg.name.rpartition(".")
                vals = np.array(tg.values, dtype=float)
            else:
                body, qty = tg.name, "phi"
                vals = np.array(tg.values)[:, 2]
            col = 3 * self.bodies.index(body) + "xyz".index(qty[0]) if qty != "phi" else \
                3 * self.bodies.index(body) + 2
            d = st.q[sl, col] - vals
            if qty == "phi":
                d = wrap(d, self.unit)
            cols.append((d, st.dq[sl, col] if jac else None, st.qd[sl, col]))
        R = np.stack([c[0] for c in cols], axis=1)
        if not jac:
            return R, None
        J = np.zeros((n, len(cols), self.k + len(free_t) + self.nu))
        for c, (_, dp, dt) in enumerate(cols):
            J[:, c, :self.k] = dp
            if dtdx is not None:        # prescribed or relative inputs: the time moves with x
                J[:, c] += dt[:, None] * dtdx
            elif (i, 0) in free_t:              # free times: their own unknowns
                for e in range(n):
                    J[e, c, self.k + free_t.index((i, e))] = dt[e]
        return R, J.reshape(n * len(cols), -1)

    def margins(self, cm, res, tfree, t=None, where=None) -> dict:
        """Every constraint's margin: value, what it needs, ok. t, where: the solved target
        times and each target's slice of them (for the order of projected times)."""
        out = {}
        d = self.design
        if d.turns is not None:
            loop = turning_loop(cm, d.turns, d.shortest)
            if loop is not None:
                m = loop.margin()
                who = d.turns if d.shortest else f"{d.turns} or the ground"
                out["turns"] = {"value": m, "needs": f"> 0 (Grashof, {who} the shortest link)",
                                "unit": self.lunit, "ok": m > 0}
            else:
                turn = 360.0 if self.unit == "deg" else 2 * math.pi
                span = angle_span(res, 3 * self.bodies.index(d.turns) + 2)
                out["turns"] = {"value": span - turn, "needs": ">= 0 (a full turn)",
                                "unit": self.unit, "ok": span >= turn * (1 - 1e-9)}
        if d.transmission is not None:
            (b, c, dd), mn = d.transmission
            ib, ic, idd = (self.points.index(n) for n in (b, c, dd))
            worst = worst_transmission(res, ib, ic, idd, self.unit == "deg")
            out["transmission"] = {"value": worst - mn, "needs": f">= 0 (min {mn:g})",
                                   "unit": self.unit, "ok": worst >= mn}
        if getattr(cm, "shapes", ()):
            # the model's own clearance keys are a constraint of every design: no pair of
            # shapes closer than its limit over the whole cycle (planarkin.clearance)
            from ..clearance.cycle import least_margin
            least = least_margin(cm, res)
            if least is not None:
                value, pair = least
                out["clearance"] = {"value": value, "needs": f">= 0 (no contact; {pair} the "
                                    f"nearest its limit)", "unit": self.lunit, "ok": value >= 0}
        if d.order and (self.nt or self.projected):
            # in order along the path, in either direction (the same linkage with its input
            # driven the other way): the smaller margin of the two directions' best
            worst = math.inf
            for i, tg in enumerate(d.targets):
                if i in self.projected and t is not None:
                    tt = self.wrapped(t[where[i]])
                else:
                    idx = [self.free_t.index((i, j)) for j in range(len(tg))
                           if (i, j) in self.free_t]
                    tt = tfree[idx]
                if tg.repeat:       # the repeated first point: one turn after it, by the wrap
                    tt = tt[:-1]
                if len(tt) >= 2:
                    worst = min(worst, max(self._in_order(tt), self._in_order(tt[::-1])))
            if worst < math.inf:
                out["order"] = {"value": worst, "needs": ">= 0 (targets in order)",
                                "unit": "s", "ok": worst >= 0}
        return out

    def _in_order(self, t) -> float:
        """The smallest step (s) between consecutive times, negative when out of order; around
        the cycle (wrap) the steps are taken modulo its length and must add up to one cycle."""
        if not self.wrap:
            return float(np.diff(t).min())
        T = self.end - self.start
        steps = np.mod(np.diff(np.append(t, t[0])), T)
        return T - float(steps.sum()) if steps.sum() > T * (1 + 1e-9) else float(steps.min())

    # -- global start ------------------------------------------------------------------------
    def candidates(self, n: int, seed: int, nominal: bool = False, part=None, limit=None,
                   draw: int = 0, halt=None):
        """A seeded Latin hypercube of n designs, each analysed: (score, x, Design) of the
        accepted in order of score, the rejection reasons counted, and every accepted start's
        score. nominal: the file's own values (with its --set overrides) are a start too, when
        inside the bounds (a known design to refine). part: (first, end) rows of the hypercube
        (with the nominal first) to analyse, so a search can take its starts in batches and
        stop early. limit: only the best `limit` accepted are returned whole (a Design holds
        its grid: tens of kB each, gigabytes over 1e5 starts), the others by their score.
        draw: which draw of n from the seeded sequence (0 the first; draw d is the d-th call
        of the same seeded generator, so a seed gives the same starts whatever came before;
        the nominal only in draw 0). halt: called before each start; true ends the analysis
        (a budget ran out)."""
        import heapq
        X = self.draw(n, seed, draw)
        if nominal and draw == 0:
            p = np.array([float(self.model.spec.parameters[k]) for k in self.model.free])
            if np.all((self.lo <= p) & (p <= self.hi)):
                X = np.concatenate([p[None, :], X])
        if part is not None:
            X = X[part[0]:part[1]]
        heap, reasons, scores = [], {}, []      # heap: the best `limit`, worst on top
        ahead: dict = {}
        for e, xp in enumerate(X):
            if halt is not None and halt():
                break
            self.tick()
            if e not in ahead:
                ahead = starts.ahead(self, X, e)
            out = ahead[e]
            if out is None:
                out = self.model.analyse(self.model.values(xp))
            elif not isinstance(out, Rejected):
                self.model.evaluations += 1         # an analysis over the whole cycle
            if isinstance(out, Rejected):
                key = _kind(out.reason)
                reasons[key] = reasons.get(key, 0) + 1
                if len(self.refusals) < 2:      # one reason or more
                    self.refusals.add(self.worded(out, xp))
                continue
            cm, _, res = out
            if self.wrap is None:
                timing.settle_wrap(self, res)
            x = np.concatenate([xp, self.free_times(res), timing.start(self, cm, res)])
            # a start of a closed curve is not held to the order of its free times: its run
            # puts them in order, and its result is checked on it; held to it, nearly every
            # start was refused (ellipse.yaml: 47,432 of the 48,849 analysed). An open path's
            # starts out of order are few and poor (straight-line.yaml: searched without the
            # check, seed 7 took 43,684 evaluations instead of 259)
            r, _, d = self.evaluate(x, jac=False, final=not self.closed, analysed=out)
            if r is None:
                key = _kind(d.reason)
                reasons[key] = reasons.get(key, 0) + 1
                if len(self.refusals) < 2:      # one reason or more
                    self.refusals.add(d.reason)
                continue
            score = float(r @ r)
            scores.append(score)
            self.best = min(self.best, d.cost)
            heapq.heappush(heap, (-score, -e, x, d))
            if limit is not None and len(heap) > limit:
                heapq.heappop(heap)
        good = sorted(((-s, -e, x, d) for s, e, x, d in heap), key=lambda g: g[:2])
        return [(g[0], g[2], g[3]) for g in good], reasons, scores

    def draw(self, n: int, seed: int, d: int) -> np.ndarray:
        """(n, k) the d-th draw of n starts from the Latin hypercube seeded with seed (one
        generator, drawn in order; the last draw is kept, so the batches of a draw share it)."""
        from scipy.stats import qmc
        key = (n, seed)
        if self._draws is None or self._draws[0] != key or self._draws[1] > d:
            self._draws = [key, -1, qmc.LatinHypercube(d=self.k, seed=seed), None]
        while self._draws[1] < d:
            self._draws[3] = qmc.scale(self._draws[2].random(n), self.lo, self.hi)
            self._draws[1] += 1
        return self._draws[3]

    def tick(self) -> None:
        """Before each evaluation: a signal lost in a finalizer is raised again here, and the
        progress callback, if any, is called (it decides when to show a line)."""
        checkpoint()
        if self.progress is not None:
            self.progress(self.model.evaluations + self.local_evaluations(), self.best)

    def local_evaluations(self) -> int:
        return self.local.evaluations if self.local is not None else 0

    def screen(self, values):
        """Rejected when the design is invalid or its four-bar loop cannot turn (the turns
        margin, from the compiled model alone), else its compiled model, or None when that is
        left to the analysis (no turns constraint and an invalid design: the analysis refuses
        it, as an evaluation): an analysis over the cycle would refuse such a design anyway
        (lock-up, or the turns constraint), at many times the cost. Not an evaluation."""
        from ..diagnostics import InputError
        try:
            # the words of a refusal are wanted only while a draw's refusals may all be one
            # (`worded`), so the file is not validated here for each refused start
            cm = self.model.compiled(values, worded=False)
        except InputError as e:
            if self.design.turns is None:
                return None
            return Rejected("invalid: " + "; ".join(d.message for d in e.diagnostics
                                                     if d.severity == "error"))
        if self.design.turns is not None:
            loop = turning_loop(cm, self.design.turns, self.design.shortest)
            if loop is not None and not loop.margin() > 0:
                return Rejected(f"constraint turns: {loop.margin():.6g} (needs > 0)")
        return cm

    def worded(self, out: Rejected, xp) -> str:
        """The reason of a start's refusal in the validator's words: the screen's refusal of
        a design the arrays show invalid (Model.compiled(worded=False)) is worded here, when
        a draw's refusals still may all be one (the `same` end of _draws quotes it)."""
        from ..diagnostics import InputError
        if out.reason != "invalid: " + UNWORDED:
            return out.reason
        try:
            self.model.compiled(self.model.values(xp))
        except InputError as e:
            return "invalid: " + "; ".join(d.message for d in e.diagnostics
                                           if d.severity == "error")
        return out.reason

    def _grid_times(self, res) -> dict:
        """Free times on the grid: per target without inputs (index -> (N,) s), the grid
        points nearest its points, in order along the path from the point nearest the first,
        in either direction (the targets' order or its reverse, whichever is nearer; the order
        constraint takes both) (dynamic programming)."""
        out = {}
        tg_grid = res.t[:-1] if self.wrap else res.t
        for i, tg in enumerate(self.design.targets):
            if tg.kind == "function" or not tg.free_timing:
                continue
            j = self.points.index(tg.point if tg.kind == "motion" else tg.name)
            path = res.p[:len(tg_grid), j]
            goal = np.array(tg.values)[:, :2]
            D = ((path[None, :, :] - goal[:, None, :]) ** 2).sum(axis=2)     # (N, G)
            fwd, rev = self._in_order_grid(D, tg_grid), self._in_order_grid(D[::-1], tg_grid)
            out[i] = fwd[1] if fwd[0] <= rev[0] or not self.design.order else rev[1][::-1]
        return out

    def _in_order_grid(self, D, tg_grid):
        """(cost, (N,) times) of the grid points nearest the targets (rows of D) with times
        strictly increasing along the path (around the cycle from the point nearest the first
        target when it wraps)."""
        G = len(tg_grid)
        off = int(np.argmin(D[0])) if self.wrap else 0
        order = (np.arange(G) + off) % G
        Dr = D[:, order]
        cost = Dr[0].copy()
        back = np.zeros(D.shape, dtype=np.intp)
        for e in range(1, len(D)):          # strictly later along the path
            best = np.minimum.accumulate(cost)
            arg = np.zeros(G, dtype=np.intp)
            for g in range(1, G):
                arg[g] = g if cost[g] <= best[g - 1] else arg[g - 1]
            back[e, 1:] = arg[:-1]
            cost = np.concatenate([[np.inf], best[:-1]]) + Dr[e]
        g = int(np.argmin(cost))
        total = float(cost[g])
        idx = [g]
        for e in range(len(D) - 1, 0, -1):
            g = int(back[e][g])
            idx.append(g)
        idx = idx[::-1]
        return total, np.array([tg_grid[order[gi]] + (self.end - self.start if self.wrap and
                                                      order[gi] < off else 0.0) for gi in idx])

    def free_times(self, res) -> np.ndarray:
        """(nt,) the free-time unknowns' start on the grid (see _grid_times)."""
        grid = self._grid_times(res)
        return np.array([grid[i][e] for i, e in self.free_t])


def synthesize(path, overrides=None, analysis=None, progress=None, jobs: int = 1,
               **search) -> SynthResult:
    """Synthesis of a model's design block (see the module docstring). search: overrides of
    design: search: (starts, local, keep, seed, goal, evaluations). progress: called as
    progress(evaluations, best sum of squares so far) before each evaluation. jobs: processes
    for the local runs (planarkin.synthesis.runs.Ahead: the same result as 1). Raises
    InputError for invalid input, or for a search that would pass the study budget
    (planarkin.studies.budget: memory, time); returns a SynthResult (status 0 with designs,
    1 none acceptable). An interruption (KeyboardInterrupt) is raised again with the
    designs verified so far as its `partial` SynthResult (`interrupted` set)."""
    t0 = time.perf_counter()
    if isinstance(jobs, bool) or not isinstance(jobs, int) or not 1 <= jobs <= 1024:
        from ..diagnostics import Diagnostic, InputError
        raise InputError([Diagnostic(str(path), None, f"synthesize: jobs must be a whole "
                                                      f"number from 1 to 1024, not {jobs!r}")])
    syn = Synthesis(path, overrides, analysis)
    cfg = settled({**syn.design.search, **search_options(path, search)})
    syn.band = cfg["band"]
    total = cfg["starts"] + (1 if cfg["nominal"] else 0)
    size = cfg["batch"] or total
    check_cost(syn, cfg, total, size)
    syn.progress = progress
    local = syn.local = Local(syn)
    designs, rejected_local, scores, reasons = [], [], [], {}

    def result(status, msg, interrupted=None):
        return SynthResult(status=status, message=msg, designs=designs, rejected=reasons,
                           evaluations=syn.model.evaluations + local.evaluations,
                           analyses=syn.model.evaluations, jacobians=syn.model.jacobians,
                           seconds=time.perf_counter() - t0, design=syn.design, model=syn,
                           starts=sorted(scores), runs=syn.runs, interrupted=interrupted,
                           ended=syn.ended)

    try:
        _search(syn, local, cfg, total, size, designs, rejected_local, scores, reasons, jobs)
    except KeyboardInterrupt as e:
        designs.sort(key=lambda o: o.cost)
        del designs[cfg["keep"]:]
        from ..output.directory import signame
        e.partial = result(1, f"interrupted by {signame(e)} during the search after "
                              f"{syn.model.evaluations + local.evaluations} evaluations: "
                              + (f"the {len(designs)} design(s) verified so far, best sum of "
                                 f"squares {designs[0].cost:.3g}" if designs else
                                 "no design verified yet"), signame(e))
        raise
    del designs[cfg["keep"]:]
    ok = [o for o in designs if cfg["goal"] <= 0 or o.cost <= cfg["goal"]]
    if designs and ok:
        status, msg = 0, f"{len(designs)} design(s), best sum of squares {designs[0].cost:.3g}"
    elif designs:
        status, msg = 1, (f"no design reaches the goal {cfg['goal']:g}: the best sum of "
                          f"squares is {designs[0].cost:.3g}")
    else:
        status, msg = 1, ("no acceptable design: " + (", ".join(f"{n} {k}" for k, n in
                          sorted(reasons.items(), key=lambda kv: -kv[1])) + " among the "
                          f"{syn.drawn} starts" if reasons else "the local searches failed"))
    spent = syn.model.evaluations + local.evaluations
    msg += {"goal": "", "evaluations": f" (the evaluation budget ended the search: {spent:,} "
                                       f"of {cfg['evaluations']:,})",
            "time": f" (the time budget of {cfg['time']:g} s ended the search after {spent:,} "
                    f"evaluations)",
            "same": " (every start of a draw refused for the same reason: the file's, not "
                    "the designs')",
            "refused": f" (ended after {IDLE_STARTS:,} starts in a row refused before an "
                       f"analysis, {spent:,} of {cfg['evaluations']:,} evaluations)"
            }.get(syn.ended, "")
    return result(status, msg)


def _search(syn, local, cfg, total, size, designs, rejected_local, scores, reasons,
            jobs: int = 1) -> None:
    """The global start and the local runs (see the module docstring), filling designs (best
    first, in place, so that an interruption finds those verified so far), scores (of the
    accepted starts) and reasons (of the rejected); syn.runs counts the local runs. jobs > 1:
    the next runs' first legs computed in jobs - 1 worker processes (runs.Ahead)."""
    ahead = Ahead(syn, cfg, jobs) if jobs > 1 else None
    try:
        _draws(syn, local, cfg, size, designs, rejected_local, scores, reasons, ahead)
    finally:
        if ahead is not None:
            ahead.close()


def _draws(syn, local, cfg, size, designs, rejected_local, scores, reasons, ahead) -> None:
    """_search's draws of starts and their local runs (ahead: runs.Ahead, or None)."""
    if syn.nt or syn.projected or syn.nu:   # free times and offsets may wrap around a cycle
        timing.probe_wrap(syn)

    def box():
        """(lo, hi) of the unknowns and their spans (they depend on syn.wrap, which a first
        start may decide)."""
        span = np.concatenate([syn.hi - syn.lo, np.full(syn.nt, syn.end - syn.start),
                               np.subtract(*syn.timing_bounds()[::-1])])
        return syn.bounds(), span
    stop = cfg["goal"] * STOP if cfg["goal"] > 0 else 0.0
    probe = probe_limits(cfg["probe"], cfg["probe_cost"]) if cfg["probe"] else ()

    def spent():
        return syn.model.evaluations + local.evaluations

    t0 = clock()

    def ended():
        """The budget that has run out ('evaluations', 'time') or the goal met ('goal'), or
        None; recorded in syn.ended."""
        if cfg["goal"] > 0 and sum(o.cost <= cfg["goal"] for o in designs) >= cfg["keep"]:
            syn.ended = "goal"
        elif spent() >= cfg["evaluations"]:
            syn.ended = "evaluations"
        elif cfg["time"] > 0 and clock() - t0 >= cfg["time"]:
            syn.ended = "time"
        return syn.ended

    # draws of `starts` starts from one seeded generator, each in batches (batch: 0, all at
    # once), until the goal is met or a budget (evaluations, time) runs out: a batch's
    # accepted starts are run best first (at most `local` runs a draw), and the search stops
    # as soon as the goal is met, so a hit in the first batches spares the analyses of the
    # rest. Only the starts that can still be run are kept whole.
    draw, idle = 0, 0
    while not ended():
        runs, before, accepted, examined = 0, spent(), len(scores), syn.drawn
        syn.refusals = set()
        n = cfg["starts"] + (1 if cfg["nominal"] and draw == 0 else 0)
        for first in range(0, n, size):
            if ended() or runs >= cfg["local"]:
                break
            got = ahead.take_draw(draw, spent()) if ahead is not None and first == 0 else None
            good, why, sc = got or syn.candidates(
                cfg["starts"], cfg["seed"], bool(cfg["nominal"]), (first, first + size),
                limit=cfg["local"] - runs, draw=draw, halt=ended)
            if ahead is not None and size >= cfg["starts"]:
                ahead.plan_draw(draw + 1, (0, size))    # the next draw's starts, meanwhile
            syn.drawn += sum(why.values()) + len(sc)
            scores += sc
            for key, k in why.items():
                reasons[key] = reasons.get(key, 0) + k
            for i, (score, x0, d0) in enumerate(good):
                if ended() or runs >= cfg["local"]:
                    break
                # the run leaves one evaluation of the budget for its full check (local.verified)
                if cfg["evaluations"] - spent() - 1 < 1:
                    syn.ended = "evaluations"
                    break
                syn.runs += 1
                runs += 1
                leg = None
                if ahead is not None:
                    deadline = None if not cfg["time"] else \
                        time.perf_counter() + cfg["time"] - (clock() - t0)
                    ahead.plan([g[2] for g in good[i + 1:i + 1 + cfg["local"] - runs]], stop,
                               probe, box()[0], spent(), deadline, designs)
                    leg = ahead.take(d0, spent(), designs)
                d = run_from(syn, local, cfg, d0, stop, probe, box()[0], designs,
                             rejected_local, halt=lambda: ended() or (
                                 "evaluations" if spent() >= cfg["evaluations"] - 1 else None),
                             leg=leg)
                if d is None:
                    continue
                span = box()[1]
                norm = (d.x - 0) / np.where(span > 0, span, 1.0)
                if any(np.abs(norm - o.x / np.where(span > 0, span, 1.0))[:syn.k].max()
                       < DISTINCT for o in designs):
                    continue
                syn.best = min(syn.best, d.cost)
                designs.append(d)
                designs.sort(key=lambda o: o.cost)
                del designs[cfg["keep"]:]
            if ahead is not None:
                ahead.drop()            # legs of starts this batch will not run
        draw += 1
        # a draw whose every start was refused before an analysis spends nothing (no budget
        # would end the loop): IDLE_STARTS such starts in a row end it
        idle = idle + cfg["starts"] if spent() == before else 0
        if idle >= IDLE_STARTS and not syn.ended:
            syn.ended = "refused"
        # every start of a whole draw refused for one and the same reason, word for word (no
        # value in it that varies with the design, such as an input the driver never takes):
        # a cause of the file's, not of the designs drawn, so more draws would not help
        if (not syn.ended and len(scores) == accepted and len(syn.refusals) == 1 and
                syn.drawn - examined >= 2):
            syn.ended = "same"
            syn.same = next(iter(syn.refusals))


def _kind(reason: str) -> str:
    """A rejection's kind for counting ('lock-up', 'invalid', 'constraint turns', ...)."""
    return reason.split(" at t =")[0].split(":")[0]
