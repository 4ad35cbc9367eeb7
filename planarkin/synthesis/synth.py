"""Synthesis: the design that makes a model do what its `design:` block asks.

The unknowns x are the free parameters (in their units) and, for every path or motion target
without prescribed inputs, one time per target point (s): the input values are the driver's
values at those times. Residuals are weighted differences in the model's units (point
coordinates; angles wrapped to a half turn). The method:

1. a Latin hypercube (scipy.stats.qmc, seeded) of `starts` designs over the bounds, each analysed
   over the whole range through the Study (validate with overrides, compile, solve); designs that
   cannot be assembled, lock up or violate a constraint are rejected with their reason; the free
   times of the others are chosen on their grid (the nearest points, in order along the path);
2. from the best `local` of them, scipy.optimize.least_squares (trust region, jac= the exact
   Jacobian of planarkin.synthesis.problem, the bounds by a change of variables); a trial design that is
   rejected returns a residual larger than any acceptable one (a wall), so every accepted step
   stays assemblable over the whole cycle, on its branch, within the constraints;
3. the best `keep` distinct designs are kept (distinct: 1e-3 of a bound's range apart).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .problem import Model, Rejected, State, wrap
from .spec import design_of

WALL = 1e6            # residual entries of a rejected design, times the start's residual norm
DISTINCT = 1e-3       # designs closer than this (fraction of every bound range) are the same


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
        a = self.model.study.opts
        self.start, self.end = a.start, a.end
        # free times: one per target point of a path / motion target without inputs
        self.free_t = []                      # (target index, entry index)
        for i, tg in enumerate(self.design.targets):
            if tg.kind != "function" and tg.inputs is None:
                self.free_t += [(i, j) for j in range(len(tg))]
        self.nt = len(self.free_t)
        self.wrap = False
        self._cache = None
        self.wall = None

    # -- layout ------------------------------------------------------------------------------
    def bounds(self):
        T = self.end - self.start
        tlo, thi = (self.start - T, self.end + T) if self.wrap else (self.start, self.end)
        return (np.concatenate([self.lo, np.full(self.nt, tlo)]),
                np.concatenate([self.hi, np.full(self.nt, thi)]))

    def wrapped(self, t):
        if not self.wrap:
            return np.asarray(t, dtype=float)
        T = self.end - self.start
        return self.start + np.mod(np.asarray(t, dtype=float) - self.start, T)

    # -- evaluation --------------------------------------------------------------------------
    def evaluate(self, x, jac: bool = True, final: bool = False):
        """(residual vector, Jacobian or None, Design) or (None, None, Rejected). final: the
        order of free times is a constraint too (see below)."""
        values = self.model.values(x[:self.k])
        out = self.model.analyse(values)
        if isinstance(out, Rejected):
            return None, None, out
        cm, opts, res = out
        tfree = self.wrapped(x[self.k:])
        times, where, inputs = [], [], []
        for i, tg in enumerate(self.design.targets):
            if tg.inputs is not None:
                tt = self.model.times_of(cm, res, tg.inputs)
                if isinstance(tt, Rejected):
                    return None, None, tt
                inputs.append(i)
            else:
                tt = np.array([tfree[self.free_t.index((i, j))] for j in range(len(tg))])
            where.append(slice(len(times), len(times) + len(tt)))
            times += list(tt)
        st = self.model.solve_at(cm, res, np.array(times), sens=False)
        if isinstance(st, Rejected):
            return None, None, st
        margins = self.margins(cm, res, tfree)
        # order is checked on the result only (final): a wall there would stop the steps of
        # two free times that pass each other on the way to their targets
        bad = [f"{k}: {m['value']:.6g} (needs {m['needs']})" for k, m in margins.items()
               if not m["ok"] and (final or k != "order")]
        if bad:
            return None, None, Rejected("constraint " + "; ".join(bad))
        per, r = [], []
        for i, tg in enumerate(self.design.targets):
            rr, _ = self._target(tg, i, st, where[i], None, False)
            per.append(rr)
            r.append(rr.ravel() * tg.weight)
        r = np.concatenate(r)
        d = Design(x=np.array(x, dtype=float), values=values,
                   times=[st.t[sl].tolist() for sl in where], cost=float(r @ r),
                   residuals=per, margins=margins, state=st)
        d.where = where
        return r, (self.jacobian(d) if jac else None), d

    def jacobian(self, d: Design) -> np.ndarray:
        """The exact Jacobian of an evaluated design's residuals (len(r), k + nt)."""
        st = d.state
        self.model.add_sensitivities(st)
        J = []
        for i, tg in enumerate(self.design.targets):
            sl = d.where[i]
            dtdp = self.model.input_dtdp(st.cm, st.t[sl]) if tg.inputs is not None else None
            J.append(self._target(tg, i, st, sl, dtdp, True)[1] * tg.weight)
        return np.concatenate(J)

    def _target(self, tg, i, st, sl, dtdp, jac):
        """Residuals (N, c) of one target and their Jacobian rows (N c, k + nt)."""
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
        J = np.zeros((n, len(cols), self.k + self.nt))
        for c, (_, dp, dt) in enumerate(cols):
            J[:, c, :self.k] = dp
            if dtdp is not None:              # prescribed inputs: the time moves with p
                J[:, c, :self.k] += dt[:, None] * dtdp
            elif tg.kind != "function":
                for e in range(n):
                    J[e, c, self.k + self.free_t.index((i, e))] = dt[e]
        return R, J.reshape(n * len(cols), -1)

    def margins(self, cm, res, tfree) -> dict:
        """Every constraint's margin: value, what it needs, ok."""
        out = {}
        d = self.design
        if d.turns is not None:
            from ..measures.grashof import four_bar_loops
            loop = next((lp for lp in four_bar_loops(cm) if d.turns in lp.links[1:]), None)
            if loop is not None:
                s, lg = min(loop.lengths), max(loop.lengths)
                pq = sum(loop.lengths) - s - lg
                crank = loop.crank == d.turns or loop.kind == "double-crank"
                out["turns"] = {"value": pq - s - lg if crank else -abs(pq - s - lg),
                                "needs": f"> 0 (Grashof, {d.turns} a crank)",
                                "unit": self.lunit, "ok": crank and pq - s - lg > 0}
            else:
                phi = res.q[:, 3 * self.bodies.index(d.turns) + 2]
                turn = 360.0 if self.unit == "deg" else 2 * math.pi
                span = float(phi.max() - phi.min())
                out["turns"] = {"value": span - turn, "needs": ">= 0 (a full turn)",
                                "unit": self.unit, "ok": span >= turn * (1 - 1e-9)}
        if d.transmission is not None:
            (b, c, dd), mn = d.transmission
            P = res.p
            ib, ic, idd = (self.points.index(n) for n in (b, c, dd))
            u, w = P[:, ib] - P[:, ic], P[:, idd] - P[:, ic]
            mu = np.arctan2(np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]),
                            (u * w).sum(axis=1))
            mu = mu * (180 / math.pi if self.unit == "deg" else 1.0)
            half = 180.0 if self.unit == "deg" else math.pi
            worst = float(np.minimum(mu, half - mu).min())
            out["transmission"] = {"value": worst - mn, "needs": f">= 0 (min {mn:g})",
                                   "unit": self.unit, "ok": worst >= mn}
        if d.order and self.nt:
            # in order along the path, in either direction (the same linkage with its input
            # driven the other way): the smaller margin of the two directions' best
            worst = math.inf
            for i, tg in enumerate(d.targets):
                idx = [self.free_t.index((i, j)) for j in range(len(tg)) if (i, j) in self.free_t]
                if len(idx) >= 2:
                    t = tfree[idx]
                    worst = min(worst, max(self._in_order(t), self._in_order(t[::-1])))
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
    def candidates(self, n: int, seed: int):
        """A seeded Latin hypercube of n designs, each analysed: (x, score) of the accepted in
        order of score, and the rejection reasons counted."""
        from scipy.stats import qmc
        X = qmc.scale(qmc.LatinHypercube(d=self.k, seed=seed).random(n), self.lo, self.hi)
        good, reasons = [], {}
        for xp in X:
            out = self.model.analyse(self.model.values(xp))
            if isinstance(out, Rejected):
                key = _kind(out.reason)
                reasons[key] = reasons.get(key, 0) + 1
                continue
            cm, _, res = out
            t = self._grid_times(res)
            x = np.concatenate([xp, t])
            r, _, d = self.evaluate(x, jac=False, final=True)
            self.model.evaluations -= 1        # evaluate analysed the design again
            if r is None:
                key = _kind(d.reason)
                reasons[key] = reasons.get(key, 0) + 1
                continue
            good.append((float(r @ r), x))
        good.sort(key=lambda g: g[0])
        return good, reasons

    def _grid_times(self, res) -> np.ndarray:
        """Free times on the grid: per target, the grid points nearest its points, in order
        along the path from the point nearest the first (dynamic programming)."""
        out = np.zeros(self.nt)
        tg_grid = res.t[:-1] if self.wrap else res.t
        for i, tg in enumerate(self.design.targets):
            if tg.kind == "function" or tg.inputs is not None:
                continue
            j = self.points.index(tg.point if tg.kind == "motion" else tg.name)
            path = res.p[:len(tg_grid), j]
            goal = np.array(tg.values)[:, :2]
            D = ((path[None, :, :] - goal[:, None, :]) ** 2).sum(axis=2)     # (N, G)
            G = len(tg_grid)
            off = int(np.argmin(D[0])) if self.wrap else 0
            order = (np.arange(G) + off) % G
            Dr = D[:, order]
            cost = Dr[0].copy()
            back = np.zeros(D.shape, dtype=np.intp)
            for e in range(1, len(goal)):         # strictly later along the path
                best = np.minimum.accumulate(cost)
                arg = np.zeros(G, dtype=np.intp)
                for g in range(1, G):
                    arg[g] = g if cost[g] <= best[g - 1] else arg[g - 1]
                back[e, 1:] = arg[:-1]
                cost = np.concatenate([[np.inf], best[:-1]]) + Dr[e]
            g = int(np.argmin(cost))
            idx = [g]
            for e in range(len(goal) - 1, 0, -1):
                g = int(back[e][g])
                idx.append(g)
            idx = idx[::-1]
            for e, gi in enumerate(idx):
                out[self.free_t.index((i, e))] = tg_grid[order[gi]] + \
                    (self.end - self.start if self.wrap and order[gi] < off else 0.0)
        return out


def synthesize(path, overrides=None, analysis=None, **search) -> SynthResult:
    """Synthesis of a model's design block (see the module docstring). search: overrides of
    design: search: (starts, local, keep, seed, goal, evaluations). Raises InputError for
    invalid input; returns a SynthResult (status 0 with designs, 1 none acceptable)."""
    from scipy.optimize import least_squares
    t0 = time.perf_counter()
    syn = Synthesis(path, overrides, analysis)
    cfg = {**syn.design.search, **{k: v for k, v in search.items() if v is not None}}
    first = syn.model.analyse(syn.model.values((syn.lo + syn.hi) / 2))
    if not isinstance(first, Rejected):
        syn.wrap = syn.model.periodic(first[2])
    good, reasons = syn.candidates(cfg["starts"], cfg["seed"])
    lo, hi = syn.bounds()
    designs, rejected_local = [], []
    span = np.concatenate([syn.hi - syn.lo, np.full(syn.nt, syn.end - syn.start)])
    for score, x0 in good[:cfg["local"]]:
        if syn.model.evaluations >= cfg["evaluations"]:
            break
        x0 = np.clip(x0, lo, hi)
        r0, _, _ = syn.evaluate(x0, jac=False)
        wall = np.full(len(r0), WALL * (1.0 + float(np.linalg.norm(r0))))
        cache = {}
        # the bounds by a change of variables, x = mid + half sin z (exact chain rule): on the
        # straight-line benchmark the local runs ended lower in fewer evaluations than with
        # least_squares' own bounds (reflective steps crawl near an active bound)
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        X = lambda z: mid + half * np.sin(z)          # noqa: E731

        def fun(z):
            key = z.tobytes()
            if key not in cache:
                cache.clear()
                cache[key] = syn.evaluate(X(z), jac=False)
            r = cache[key][0]
            return wall if r is None else r

        def jac(z):         # least_squares asks at the point it has just evaluated
            fun(z)
            r, _, d = cache[z.tobytes()]
            if r is None:
                return np.zeros((len(wall), len(z)))
            return syn.jacobian(d) * (half * np.cos(z))

        budget = max(1, cfg["evaluations"] - syn.model.evaluations)
        e0, j0 = syn.model.evaluations, syn.model.jacobians
        z0 = np.arcsin(np.clip((x0 - mid) / half, -1.0, 1.0))
        sol = least_squares(fun, z0, jac=jac, method="trf", ftol=1e-15, xtol=1e-15,
                            gtol=1e-15, max_nfev=min(budget, cfg["per_local"]))
        sol.x = X(sol.x)
        r, _, d = syn.evaluate(sol.x, final=True)
        if r is None:
            rejected_local.append(d.reason)
            continue
        d.nfev, d.njev = syn.model.evaluations - e0, syn.model.jacobians - j0
        d.message = sol.message
        norm = (d.x - 0) / np.where(span > 0, span, 1.0)
        if any(np.abs(norm - o.x / np.where(span > 0, span, 1.0))[:syn.k].max() < DISTINCT
               for o in designs):
            continue
        designs.append(d)
        designs.sort(key=lambda o: o.cost)
        if cfg["goal"] > 0 and sum(o.cost <= cfg["goal"] for o in designs) >= cfg["keep"]:
            break
    designs = designs[:cfg["keep"]]
    ok = [o for o in designs if cfg["goal"] <= 0 or o.cost <= cfg["goal"]]
    if designs and ok:
        status, msg = 0, f"{len(designs)} design(s), best sum of squares {designs[0].cost:.3g}"
    elif designs:
        status, msg = 1, (f"no design reaches the goal {cfg['goal']:g}: the best sum of "
                          f"squares is {designs[0].cost:.3g}")
    else:
        status, msg = 1, ("no acceptable design: " + (", ".join(f"{n} {k}" for k, n in
                          sorted(reasons.items(), key=lambda kv: -kv[1])) + " among the "
                          f"{cfg['starts']} starts" if reasons else "the local searches failed"))
    return SynthResult(status=status, message=msg, designs=designs, rejected=reasons,
                       evaluations=syn.model.evaluations, jacobians=syn.model.jacobians,
                       seconds=time.perf_counter() - t0, design=syn.design, model=syn,
                       starts=[s for s, _ in good])


def _kind(reason: str) -> str:
    """A rejection's kind for counting ('lock-up', 'invalid', 'constraint turns', ...)."""
    return reason.split(" at t =")[0].split(":")[0]
