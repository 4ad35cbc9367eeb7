"""The local phase of synthesis: least squares on the residuals at the target inputs only.

A full evaluation (planarkin.synthesis.synth.Synthesis.evaluate) analyses the design over its
whole cycle (most of its time the path follower; benchmarks/README.md, "Figures moved from
the code's comments") to learn where the target inputs are on the branch. A local run does
not need that at every trial: its trials are small steps from a design already on the
branch. Here a trial is

* the model validated and compiled with the trial's values (Study.model);
* the poses at the target inputs only, by Newton (Model.solve_from, planarkin's own residual
  and constraint Jacobian) from a first-order predictor off the last accepted iterate,
  q + dq/dp dp + qdot dt: a correction larger than JUMP means the trial left the branch, and
  the trial is refused (a wall, as a design that does not assemble);
* the turns constraint of a four-bar loop by its margin (refused at or below zero) and its
  barrier row (planarkin.synthesis.margins), both exact and cheap;
* on request the exact Jacobian: dq/dp from Phi_q dq/dp = -Phi_p (studies.sensitivity), and
  dq/dt = qdot for every free time.

Every target without prescribed inputs has its times as unknowns here, a path target's too
(the smooth full formulation: 12 residuals and 15 unknowns for six points of a four-bar with
9 free parameters), instead of the projection of the full evaluation: the projected distance
is not smooth where the nearest point of the path jumps, and a projection costs several solves.

What the cheap trial leaves out (the whole cycle: assembly everywhere, no lock-up, the branch
kept between the targets, the targets in order, a transmission angle, a turn of a loop that is
not a four-bar) is checked when the run ends, by the full evaluation of its result
(Synthesis.evaluate(final=True)), so every returned design is still verified over its whole
cycle on its branch.
"""

from __future__ import annotations

import numpy as np

from ..diagnostics import InputError
from . import timing
from .margins import turning_loop
from .problem import Rejected

JUMP = 0.05        # largest Newton correction of a predicted pose (internal units: L, rad)


class _Done(Exception):
    """Raised inside least_squares once an accepted iterate reaches the stop value."""


class _Halted(Exception):
    """Raised inside least_squares when the search's budget runs out (see Local.run)."""


class _Abandoned(Exception):
    """Raised inside least_squares when a probed run falls too slowly (see Local.run)."""


def probe_limits(probe: int, cost: float) -> list:
    """(trials, largest sum of squares) checkpoints of a probed local run: cost after probe
    trials, then a hundredth of it after a third more, a ten-thousandth after twice as many.
    Why: measured on the six collinear points (seeds 5 and 6, 438 runs of 100 trials), a run
    in the basin of an exact solution converges superlinearly (8e-4 .. 5e-3 mm^2 after 30
    trials, 2e-5 .. 3e-5 after 40, 3e-9 .. 6e-8 after 60), while a run sliding down a valley
    crawls: 22 % of them pass 3e-2 after 30 trials, 5 % 3e-4 after 40, none 1e-6 after 60."""
    return [(probe, cost), (probe + probe // 3, cost * 1e-2), (2 * probe, cost * 1e-4)]


class Local:
    """Cheap residuals and exact Jacobian of a Synthesis at the target inputs (see module)."""

    def __init__(self, syn):
        self.syn = syn
        tgs = syn.design.targets
        self.free_t = [(i, j) for i, tg in enumerate(tgs)
                       if tg.kind in ("path", "motion") and tg.free_timing
                       for j in range(len(tg))]
        self.nt = len(self.free_t)
        self.k = syn.k
        self.evaluations = 0        # trials at the target inputs (no analysis over the cycle)
        self.ref = None             # the last accepted iterate: (x, times, State with dq)
        self.last_cost = np.inf     # the best sum of squares of the last run

    # -- layout ------------------------------------------------------------------------------
    def unknowns(self, d) -> np.ndarray:
        """The local unknowns (free parameters, every free time, then the offsets and steps
        of synthesis.timing) of a full Design."""
        return np.concatenate([d.x[:self.k], [d.times[i][j] for i, j in self.free_t],
                               d.x[self.k + self.syn.nt:]])

    def full(self, x) -> np.ndarray:
        """The full evaluation's unknowns (free parameters, the motion targets' times, the
        offsets and steps)."""
        t = x[self.k:self.k + self.nt]
        return np.concatenate([x[:self.k], [t[self.free_t.index(ij)] for ij in self.syn.free_t],
                               x[self.k + self.nt:]])

    def anchor(self, d) -> None:
        """Start a continuation from a fully evaluated design d (its state on the branch)."""
        st = d.state
        if st.dq is None:
            self.syn.model.add_sensitivities(st)
        self.ref = (self.unknowns(d), st.t.copy(), st)

    # -- one trial ---------------------------------------------------------------------------
    def evaluate(self, x):
        """(residuals, State, barrier) at x, or (None, Rejected, None)."""
        syn, model = self.syn, self.syn.model
        syn.tick()
        self.evaluations += 1
        try:
            cm = model.compiled(model.values(x[:self.k]), worded=False)   # (words unused)
        except InputError as e:
            return None, Rejected("invalid: " + "; ".join(d.message for d in e.diagnostics
                                                         if d.severity == "error")), None
        if syn.design.turns is not None:
            loop = turning_loop(cm, syn.design.turns, syn.design.shortest)
            if loop is not None and not loop.margin() > 0:
                return None, Rejected("constraint turns"), None
        times, where = [], []
        tfree = x[self.k:self.k + self.nt]
        grid = _Grid(np.linspace(syn.start, syn.end, 1 + int(model.study.opts.steps)))
        for i, tg in enumerate(syn.design.targets):
            if tg.inputs is not None or tg.timing is not None:
                tt = model.times_of(cm, grid, tg.inputs) if tg.timing is None else \
                    timing.times(syn, cm, grid, i, x[self.k + self.nt:])
                if isinstance(tt, Rejected):
                    return None, tt, None
            else:
                tt = np.array([tfree[self.free_t.index((i, j))] for j in range(len(tg))])
            where.append(slice(len(times), len(times) + len(tt)))
            times += list(tt)
        times = np.array(times)
        x0, t0, st0 = self.ref
        dp = x[:self.k] - x0[:self.k]
        q = st0.q + st0.dq @ dp + st0.qd * (times - t0)[:, None]
        to_int = np.tile([1 / cm.L, 1 / cm.L, cm.angle_factor], cm.nb)
        st = model.solve_from(cm, times, q * to_int, JUMP, sens=False)
        if isinstance(st, Rejected):
            return None, st, None
        st.where = where
        r = []
        for i, tg in enumerate(syn.design.targets):
            rr, _ = syn.target_residuals(tg, i, st, where[i], None, False, self.free_t)
            r.append(rr.ravel() * tg.weight)
        bar = syn.barrier(cm)
        if bar:
            r.append([bar[0]])
        return np.concatenate(r), st, bar

    def jacobian(self, st, bar) -> np.ndarray:
        """The exact Jacobian (len(r), k + nt) of an evaluated trial."""
        syn = self.syn
        if st.dq is None:
            syn.model.add_sensitivities(st)
        J = []
        for i, tg in enumerate(syn.design.targets):
            sl = st.where[i]
            dtdx = syn.input_dtdx(st.cm, tg, i, st.t[sl], self.free_t)
            J.append(syn.target_residuals(tg, i, st, sl, dtdx, True, self.free_t)[1] * tg.weight)
        if bar:
            J.append(np.concatenate([syn.barrier_gradient(st.cm, bar),
                                     np.zeros(self.nt + syn.nu)])[None, :])
        return np.concatenate(J)

    # -- one local run -----------------------------------------------------------------------
    def run(self, d, max_nfev: int, stop: float = 0.0, probe=(), halt=None):
        """Least squares from the fully evaluated design d. Returns (x, message, trail): x in
        the local layout (self.full(x) for Synthesis.evaluate), trail the accepted iterates in
        order (d's first), from which the caller takes the last that passes the full check
        when x does not. stop: an accepted iterate with a sum of squares at or below it ends
        the run (it has converged for the caller). probe: (trials, cost) checkpoints
        (probe_limits): the run is abandoned (message 'abandoned: ...') when its best sum of
        squares is above cost once it has used that many trials: many short runs find an
        exact basin sooner than a few long ones. halt: called before each trial; true ends the
        run at its best accepted iterate (message 'halted: ...': a budget of the search ran
        out)."""
        from scipy.optimize import least_squares
        syn = self.syn
        self.anchor(d)
        xa = self.ref[0]
        # the bounds by a change of variables, x = mid + half sin z (exact chain rule), for the
        # parameters and for times that cannot wrap; times around a full cycle are free (the
        # trial solves at any time, the final evaluation wraps them). least_squares' own
        # bounds (reflective) did no better on the straight line: from seed 0's best starts
        # both ended in the same valley (benchmarks/README.md, "Figures moved from the code's
        # comments")
        ulo, uhi = timing.bounds(syn)
        lo = np.concatenate([syn.lo, np.full(self.nt, syn.start), ulo])
        hi = np.concatenate([syn.hi, np.full(self.nt, syn.end), uhi])
        boxed = np.ones(len(xa), dtype=bool)
        if syn.wrap:        # times and offsets around a full cycle: unbounded (they wrap)
            boxed[self.k:self.k + self.nt] = False
            boxed[self.k + self.nt:] = [name != "offset" for _, name in syn.timing]
        mid, half = (lo + hi) / 2, (hi - lo) / 2

        def X(z):
            return np.where(boxed, mid + half * np.sin(z), z)

        def dX(z):
            return np.where(boxed, half * np.cos(z), 1.0)

        z0 = np.where(boxed, np.arcsin(np.clip((xa - mid) / np.where(boxed, half, 1.0),
                                               -1.0, 1.0)), xa)
        r0 = self.evaluate(X(z0))[0]
        if r0 is None:
            return xa, "the start does not solve at the target inputs", [xa]
        wall = np.full(len(r0), 1e6 * (1.0 + float(np.linalg.norm(r0))))
        cache = {}
        best = [X(z0), float(r0 @ r0)]
        trail = [X(z0)]
        e0 = self.evaluations - 1
        limits = sorted(probe)

        def fun(z):
            key = z.tobytes()
            if key not in cache:
                cache.clear()
                if halt is not None and halt():
                    raise _Halted
                cache[key] = self.evaluate(X(z))
                used = self.evaluations - e0
                if any(used >= n and best[1] > lim for n, lim in limits):
                    raise _Abandoned
            r = cache[key][0]
            return wall if r is None else r

        def jac(z):         # least_squares asks at the point it has just accepted
            r = fun(z)
            _, st, bar = cache[z.tobytes()]
            if isinstance(st, Rejected):
                return np.zeros((len(wall), len(z)))
            J = self.jacobian(st, bar) * dX(z)
            x = X(z)
            self.ref = (x, st.t.copy(), st)           # the next trials' predictor
            trail.append(x)
            c = float(r @ r)
            if c < best[1]:
                best[:] = [x, c]
            if c <= stop:
                raise _Done
            used = self.evaluations - e0
            if any(used >= n and best[1] > lim for n, lim in limits):
                raise _Abandoned
            return J

        try:
            sol = least_squares(fun, z0, jac=jac, method="trf", ftol=1e-15, xtol=1e-15,
                                gtol=1e-15, max_nfev=max_nfev)
            x, msg = X(sol.x), sol.message
            r = fun(sol.x)
            if float(r @ r) > best[1]:
                x = best[0]
        except _Done:
            x, msg = best[0], "the sum of squares reached the goal"
        except _Halted:
            x, msg = best[0], (f"halted: the search's {halt()} budget ran out after "
                               f"{self.evaluations - e0} trials")
        except _Abandoned:
            x, msg = best[0], (f"abandoned: sum of squares {best[1]:.3g} after "
                               f"{self.evaluations - e0} trials")
        self.last_cost = best[1]
        return x, msg, trail


def verified(syn, local, x, trail, lo, hi, rejected, first):
    """The fully evaluated design at the end x of a local run, or, when it fails the full
    check (the whole cycle, on the branch, every constraint: the guarantee of a returned
    design; a local trial checks only the target inputs), the last accepted iterate of the
    run that passes it, found by bisection over the trail (its first entry is the run's start,
    the fully evaluated design `first`), or Rejected when none does; the reason of the failure
    appended to rejected."""
    r, _, d = syn.evaluate(np.clip(local.full(x), lo, hi), jac=False, final=True)
    if r is not None:
        return d
    rejected.append(d.reason)
    good, bad, best = 0, len(trail), None
    while bad - good > 1:
        mid = (good + bad) // 2
        r, _, dm = syn.evaluate(np.clip(local.full(trail[mid]), lo, hi), jac=False, final=True)
        if r is None:
            bad = mid
        else:
            good, best = mid, dm
    if best is None:
        # the start itself, when it passes: a start is not held to the order of free times
        # (Synthesis.candidates), which its run may not have reached
        if not all(m["ok"] for m in first.margins.values()):
            return Rejected(f"the local run did not reach a design that passes the full check "
                            f"({d.reason})")
        best = first
    best.message = (f"the end of the local run failed the full check ({d.reason}); the last "
                    f"accepted iterate that passes it")
    return best


class _Grid:
    """A grid's times only (Model.times_of brackets a prescribed input on them)."""

    def __init__(self, t):
        self.t = t
