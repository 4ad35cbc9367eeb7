"""Position, velocity and acceleration analysis over the time grid (reference §7).

Two passes, so that a coarse grid changes the cost and never the answer:

1. Path following (`PathFollower`): adaptive internal steps from t = start along the assembled
   branch. A step is accepted only when Newton converged from a Taylor predictor built from
   q, qdot, qddot (and a third-derivative estimate), the correction agrees with the predictor
   both forward and backward within ``path_tol``, the correction is small against the
   Jacobian's smallest singular value (a Kantorovich-style radius: Newton cannot reach another
   root from there), and the sign of every diagonal block's determinant is unchanged (crossing
   to another assembly branch flips it); poses whose condition estimate exceeds COND_SINGULAR
   are not accepted (their accelerations would be meaningless): the one step-acceptance rule
   of planarkin.solver.acceptance. Failing steps are subdivided.
   When steps shrink below ``h_min`` the path has met a singular configuration, approached by
   this very process (bisection in effect); its time is extrapolated from sigma_min and it is
   classified from the singular vectors: lock-up of a driver (toggle, dead centre) when the
   joints alone keep full rank, bifurcation (change point) when they lose rank. A model with
   consistent redundant constraints may first switch which rows it leaves out (both in
   planarkin.solver.singular). A warm start (`Analysis(..., warm=Start)`, planarkin.solver.warmstart: a
   neighbouring model's path corrected to this one, for design studies) replaces the follower
   when its corrected nodes pass the same rule. The drivers'
   breakpoints (TimeFunction.breakpoints: kinks and steps of f' or f'') are landed on exactly
   and the path restarts there from the right-hand limits: that node appears twice, so no
   step and no interpolant spans a jump; a kink a driver does not declare is refused.
2. Dense output (`Analysis.chunks`): every grid point is solved by Newton-Raphson from the
   quintic Hermite interpolant of the bracketing nodes (q, qdot, qddot at both ends), then the
   velocity and acceleration systems are solved exactly. Every point is checked like a path step
   (acceptance.accepted: convergence, Kantorovich radius, condition, determinant signs); a point that fails is solved by
   following the path from its left node. Rows exactly at a breakpoint take the right-hand
   limit (the end row the left-hand one); a non-finite driver value at a row refuses it.

Results are streamed in chunks of grid points, so memory does not grow with the number of steps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import time

import numpy as np

from .acceptance import COND_WARN, accepted, condition, taylor_error
from .assembly import Assembly
from planarkin.solver.compiled import kernel
from .budget import node_limit, point_row_bytes
from .kinematics import point_jerk, point_kinematics
from .tolerances import NODE_TOL
from planarkin.options import Options
from .path import (KINK_TOL, PATH_POLICY, ROWS_AT_BREAKPOINTS, Event, Kink, Nodes,
                   driver_breakpoints, hermite5, path_block)
from .singular import classify, near_singular_warnings, reselect
from .chunks import Chunk
from .system import System
from .warmstart import warm_nodes

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel

# Bound of a grid chunk's estimated working set (Analysis.chunks), bytes. The CLI keeps freed
# memory on its heap (cli._tune_malloc), so its peak is a few chunks above the interpreter,
# numpy, scipy and the path nodes: measured 205-222 MB for the 300-coordinate arch at 1,000 and
# 3,000 steps (128 MB gave 385-397 MB)
CHUNK_BYTES = 64 << 20
# A model of many small solve blocks (the N-four-bar chain: 5,003) pays every block's per-call
# Python overhead once per chunk, far more than a block's work per point: 58-point chunks
# (64 MB at 6,003 coordinates) made its grid pass much slower than 232-point ones
# (benchmarks/README.md, "Figures moved from the code's comments"). Such a model
# (CHUNK_MANY_BLOCKS solve blocks or more) gets chunks of at least CHUNK_MIN_POINTS points
# while their estimated working set stays under CHUNK_BYTES_MANY.
CHUNK_MANY_BLOCKS = 64
CHUNK_MIN_POINTS = 256
CHUNK_BYTES_MANY = 256 << 20
class PathFollower:
    """Adaptive continuation along the assembled branch; see the module docstring."""

    def __init__(self, cm: CompiledModel, A: Assembly, opts: Options, systems=None, seg=0,
                 kinks=()):
        self.cm = cm
        # drivers' breakpoints strictly inside the run: the path lands on each and restarts
        self.kinks = [k for k in kinks if opts.start < k.t < opts.end]
        self.A = A
        # systems[seg] = (fine blocks for the grid, merged blocks for the path). Few large blocks
        # on the path: at a handful of candidate points per call, Python overhead per block
        # dominates, so the path is solved in blocks of up to 64 unknowns (the whole system for
        # small models); determinant signs are still those of the fine blocks.
        self.systems = systems if systems is not None else [
            (A.system, A.system.merged(path_block(cm.n)))]
        self.seg = seg
        self.S: System = self.systems[seg][1]
        self.opts = opts
        span = opts.end - opts.start
        self.span = span
        self.h_min = 1e-11 * max(span, 1e-300)
        self.h_max = min(span, opts.max_step or span)
        self.nodes = Nodes()
        self.max_nodes = node_limit(cm, opts)
        self.rejected = 0
        self.evaluations = 0
        self.warnings: list[Event] = []
        self.event: Event | None = None
        self.ok_signs_flip = False
        # (number of nodes, f', f'') of the driver rows at the last node, internal units
        self.drv_last: tuple | None = None

    # -- one batch of candidate steps -------------------------------------------------------
    def _candidates(self, k: int, hs: np.ndarray, check_sign: bool = True, jerk=True, tol=None,
                    land: float | None = None):
        """Try steps hs from node k. Returns (ok mask, err, Q, Qd, Qdd, info); tol: predictor
        error allowed (default path_tol). land: a time (breakpoint or end) that the step
        hs == land - t_k reaches exactly, not up to rounding. Drivers are evaluated as left-hand
        limits: every candidate lies after node k and at most at the next breakpoint."""
        N = self.nodes
        t0, q0, qd0, qdd0, sg0 = N.t[k], N.q[k], N.qd[k], N.qdd[k], N.sign[k]
        j3 = np.zeros_like(q0)
        if jerk and k > 0 and N.t[k] > N.t[k - 1]:
            j3 = (qdd0 - N.qdd[k - 1]) / (N.t[k] - N.t[k - 1])
        h = hs[:, None]
        Qp = q0 + h * qd0 + 0.5 * h * h * qdd0 + h ** 3 / 6.0 * j3
        Q = Qp.copy()
        Qd = qd0 + h * qdd0 + 0.5 * h * h * j3
        Qdd = qdd0 + h * j3
        t = t0 + hs
        if land is not None:
            t[hs == land - t0] = land
        self.evaluations += len(hs)
        drivers = self.S.driver_values(t, side=-1)
        self._last_drivers = drivers
        info = self.S.solve_batch(t, Q, Qd, Qdd, policy=PATH_POLICY, tol=NODE_TOL, maxit=12,
                                  order=2, drivers=drivers)
        n = self.S.n
        err = taylor_error(h, q0[:n], qd0[:n], qdd0[:n], j3[:n], Q[:, :n], Qd[:, :n],
                           Qdd[:, :n], Qp[:, :n])
        ok = accepted(info, sg0 if check_sign else None, (Qd, Qdd))
        ok &= err <= (self.opts.path_tol if tol is None else tol)
        return ok, err, Q, Qd, Qdd, info

    def start(self, q: np.ndarray) -> bool:
        """Node 0 at t = start from the assembled pose. False if velocities are undefined."""
        S = self.S
        t0 = self.opts.start
        Q = S.ext(q)
        Qd = np.zeros_like(Q)
        Qdd = np.zeros_like(Q)
        drivers = S.driver_values(np.array([t0]), side=+1)
        info = S.solve_batch(np.array([t0]), Q, Qd, Qdd, policy="full", tol=NODE_TOL, maxit=12,
                             drivers=drivers)
        self.nodes.add(t0, Q[0], Qd[0], Qdd[0], info.sign[0], condition(info)[0], self.seg)
        self._keep_drv(drivers, 0)
        return bool(info.converged[0] and np.isfinite(Qdd).all())

    def _keep_drv(self, drivers, j: int) -> None:
        rows = self.cm.driver_rows
        self.drv_last = (len(self.nodes), drivers[1][j, rows].copy(), drivers[2][j, rows].copy())

    def run(self) -> Event | None:
        """Follow the path to t = end (or to a singular configuration). Returns the stopping event
        (None when the end was reached)."""
        N = self.nodes
        end = self.opts.end
        k = len(N) - 1
        qd_scale = np.abs(N.qd[k][: self.S.n]).max()
        h = min(self.h_max, self.span / 64,
                0.05 / qd_scale if qd_scale > 0 else self.span)
        while N.t[-1] < end:
            k = len(N) - 1
            t = N.t[k]
            remaining = end - t
            if remaining <= 1e-14 * max(abs(end), 1.0):
                N.t[-1] = end   # rounding of the accumulated steps
                break
            # the next breakpoint is landed on exactly: no step crosses it
            kink = next((kk for kk in self.kinks if kk.t > t), None)
            land = kink.t if kink is not None and kink.t - t < remaining else end
            cap = min(land - t, self.h_max)
            # sorted distinct candidates (np.unique would import numpy.ma: start-up a run skips)
            hs = np.array(sorted({min(f * h, cap) for f in (0.25, 0.5, 1.0, 2.0)}))
            ok, err, Q, Qd, Qdd, info = self._candidates(k, hs, land=land)
            if ok.any():
                j = int(np.nonzero(ok)[0][-1])
                hj = hs[j]
                tn = land if hj == land - t else t + hj
                undeclared = self._undeclared_kink(k, tn, j)
                if undeclared is not None:
                    return self._stop(undeclared)
                N.add(tn, Q[j], Qd[j], Qdd[j], info.sign[j], condition(info)[j], self.seg)
                self._keep_drv(self._last_drivers, j)
                if tn == land and land < end:
                    ev = self._restart_at(kink)
                    if ev is not None:
                        return self._stop(ev)
                self.rejected += int((~ok[: j + 1]).sum())
                grow = 4.0 if err[j] == 0 else min(4.0, max(0.3, 0.8 * (self.opts.path_tol
                                                                          / err[j]) ** 0.25))
                h = min(hj * grow, self.h_max) if hj < land - t else max(h, hj)
                if len(N) > self.max_nodes:
                    return self._stop(Event("budget", N.t[-1],
                                            f"more than {self.max_nodes} internal steps before "
                                            f"t = {N.t[-1]:.6g}: the motion is too fast for the "
                                            f"time range (raise analysis: max_nodes, shorten "
                                            f"the time range or raise path_tol)"))
                continue
            self.rejected += len(hs)
            h = hs[0] / 8.0
            if h < self.h_min:
                if self.A.redundant_rows and reselect(self, k):
                    h = max(self.span * 1e-6, self.h_min * 100)
                    continue
                ev = classify(self, k)
                if ev.kind == "bifurcation" and self.opts.bifurcation == "continue":
                    if self._step_over(ev):
                        self.warnings.append(ev)
                        h = max(self.span * 1e-6, self.h_min * 100)
                        continue
                    ev.message += "; stepping over it on the smooth branch failed"
                return self._stop(ev)
        near_singular_warnings(self)
        return None

    def _restart_at(self, kink: Kink) -> Event | None:
        """The path has landed on a driver breakpoint (the node holds the left-hand limits):
        refuse a jump of a driver's position; otherwise add the node again with velocities and
        accelerations re-solved from the drivers' right-hand limits (the node appears twice, so
        no interpolation spans the jump) and warn with the size of every jump."""
        cm, N = self.cm, self.nodes
        parts = []
        for r, bp in kink.jumps:
            el = cm.element_of_row(r)
            unit = self._driver_unit(r)
            if bp.jump[0] != 0:
                return Event("driver", kink.t,
                             f"{el.label}: f = {el.f.text} jumps by {bp.jump[0]:.6g} {unit} at "
                             f"t = {kink.t:.10g}: a position jump cannot be followed; results "
                             f"are written up to t = {kink.t:.10g}")
            parts.append(f"{el.label}: f = {el.f.text} has a breakpoint at t = {kink.t:.10g} s: "
                         f"its velocity jumps by {bp.jump[1]:.6g} {unit}/s and its acceleration "
                         f"by {bp.jump[2]:.6g} {unit}/s^2")
        S = self.S
        Q = N.q[-1][None, :].copy()
        Qd = np.zeros_like(Q)
        Qdd = np.zeros_like(Q)
        drivers = S.driver_values(np.array([kink.t]), side=+1)
        info = S.solve_batch(np.array([kink.t]), Q, Qd, Qdd, policy="full", tol=NODE_TOL,
                             maxit=12, drivers=drivers)
        if not (info.converged[0] and np.isfinite(Qd).all() and np.isfinite(Qdd).all()):
            bad = [r for r, _ in kink.jumps]
            return Event("driver", kink.t,
                         f"{cm.element_of_row(bad[0]).label}: velocities or accelerations "
                         f"after its breakpoint at t = {kink.t:.10g} cannot be solved "
                         f"(right-hand limits of f not finite?)")
        # the same pose on both sides (Newton above moved it by rounding at most)
        N.add(kink.t, N.q[-1].copy(), Qd[0], Qdd[0], info.sign[0], condition(info)[0], self.seg)
        self._keep_drv(drivers, 0)
        self.warnings.append(Event(
            "breakpoint", kink.t, "; ".join(parts) + "; the path is followed piece by piece "
            "and grid rows at this time take the right-hand limit"))
        return None

    def _driver_unit(self, r: int) -> str:
        from planarkin.elements import KINDS
        el = self.cm.element_of_row(r)
        u = KINDS[el.kind].target_unit
        return self.cm.spec.angle_unit if u == "angle" else self.cm.spec.length_unit

    def _rate_floor(self) -> np.ndarray:
        """Per driver (internal units): 1e-6 of its largest |f'| + span |f''| over the run,
        sampled once; the trapezoid check's scale never falls below it."""
        if getattr(self, "_floor", None) is None:
            cm, o = self.cm, self.opts
            tt = np.linspace(o.start, o.end, 257)
            fl = []
            with np.errstate(all="ignore"):
                for f, sc in zip(cm.driver_funcs, cm.driver_scale):
                    _, d, a = (np.broadcast_to(np.asarray(v, dtype=float), tt.shape)
                               for v in f.derivatives(tt))
                    m = np.nanmax(np.abs(d)) + (o.end - o.start) * np.nanmax(np.abs(a))
                    fl.append(abs(sc) * (m if np.isfinite(m) else 0.0))
            self._floor = 1e-6 * np.array(fl) + 1e-300
        return self._floor

    def _undeclared_kink(self, k: int, tn: float, j: int) -> Event | None:
        """A driver whose derivative jumps inside the step from node k to tn although its
        breakpoints do not say so: the trapezoid rule for f' = integral f'' fails there (see
        KINK_TOL). Located by bisection on the driver alone and refused: the solver never steps
        over a jump silently."""
        if self.drv_last is None or self.drv_last[0] != k + 1 or not len(self.cm.driver_rows):
            return None        # the last node's driver values are not at hand (a switch node)
        _, d0, a0 = self.drv_last
        d1, a1 = self._last_drivers[1][j, self.cm.driver_rows], \
            self._last_drivers[2][j, self.cm.driver_rows]
        t0 = self.nodes.t[k]
        h = tn - t0
        mis = np.abs(d1 - d0 - 0.5 * h * (a0 + a1))
        # relative to the rates here, and to the driver's rates over the run: where a motion
        # law meets a dwell, f' and f'' are both near 0 and rounding alone would fail the rule
        scale = np.abs(d0) + np.abs(d1) + h * (np.abs(a0) + np.abs(a1)) + self._rate_floor()
        bad = np.nonzero(~(mis <= KINK_TOL * scale) & np.isfinite(mis))[0]
        if not len(bad):
            return None
        i = int(bad[0])
        r = int(self.cm.driver_rows[i])
        f = self.cm.driver_funcs[i]

        def miss(a, b):
            (_, da, aa), (_, db, ab) = (f.derivatives(np.array([x])) for x in (a, b))
            da, aa, db, ab = (float(np.ravel(v)[0]) for v in (da, aa, db, ab))
            return abs(db - da - 0.5 * (b - a) * (aa + ab))

        a, b = t0, tn
        for _ in range(80):
            m = 0.5 * (a + b)
            if not a < m < b:
                break
            if miss(a, m) >= miss(m, b):
                b = m
            else:
                a = m
        # f' on either side, a little away from the kink itself (where the rule as written
        # may give neither side's value, or none)
        off = 1e-6 * h
        (_, da, _), (_, db, _) = (f.derivatives(np.array([x])) for x in (max(t0, a - off),
                                                                          min(tn, b + off)))
        jump = float(np.ravel(db)[0] - np.ravel(da)[0])
        # a real jump stays as the bracket shrinks; the trapezoid rule's error on a smooth but
        # fast-changing f'' (a motion law's jerk) goes away: then this was no kink
        fl = self._rate_floor()[i] / abs(self.cm.driver_scale[i])
        if not abs(jump) > 1e-6 * (abs(float(np.ravel(da)[0])) + abs(float(np.ravel(db)[0]))) + fl:
            return None
        el = self.cm.element_of_row(r)
        unit = self._driver_unit(r)
        return Event("driver", 0.5 * (a + b),
                     f"{el.label}: the derivative of f = {el.f.text} jumps near t = "
                     f"{0.5 * (a + b):.10g} s (f' changes by about {jump:.6g} {unit}/s across "
                     f"it) but the function declares no breakpoint there, so the path cannot be "
                     f"followed piece by piece; results are written up to t = {t0:.10g}")

    def _stop(self, ev: Event) -> Event:
        self.event = ev
        near_singular_warnings(self)
        return ev

    def _step_over(self, ev: Event) -> bool:
        """Continue on the smooth branch past a bifurcation at ev.t: from an earlier node where the
        Jacobian is well conditioned, predict to a time past the singular point and accept the
        step only if it really crossed (a fine block's determinant sign flipped) onto a well
        conditioned pose. The nodes in between are dropped: the grid points of the crossing
        interval are interpolated from the two ends."""
        N = self.nodes
        ts = ev.t
        k_last = len(N) - 1
        for k in range(k_last, max(k_last - 60, -1), -1):
            d = ts - N.t[k]
            if d <= 0 or N.cond[k] > 10 * COND_WARN:
                continue
            # never across a driver's breakpoint: step over the crossing only within the piece
            kink = next((kk.t for kk in self.kinks if kk.t > N.t[k]), self.opts.end)
            hs = np.array(sorted({min(f * d, kink - N.t[k]) for f in (1.5, 2, 3, 4)}))
            hs = hs[hs > d]
            if not len(hs):
                continue
            ok, err, Q, Qd, Qdd, info = self._candidates(k, hs, check_sign=False, jerk=False,
                                                         tol=np.inf, land=kink)
            # a larger step than path_tol allows, so smoothness is judged against the motion:
            # the other branch through the singular point leaves it with a different tangent,
            # a deviation of the order of the step itself
            moved = np.abs(Q[:, : self.S.n] - N.q[k][: self.S.n]).max(axis=1)
            crossed = (info.sign != N.sign[k]).any(axis=1)
            good = ok & crossed & (err <= np.maximum(self.opts.path_tol, 1e-2 * moved)) \
                & (condition(info) <= 10 * COND_WARN)
            if good.any():
                j = int(np.nonzero(good)[0][0])
                N.truncate(k)
                tn = kink if hs[j] == kink - N.t[k] else N.t[k] + hs[j]
                N.add(tn, Q[j], Qd[j], Qdd[j], info.sign[j], condition(info)[j], self.seg)
                self._keep_drv(self._last_drivers, j)
                if tn == kink and kink < self.opts.end:
                    k_obj = next(kk for kk in self.kinks if kk.t == kink)
                    if self._restart_at(k_obj) is not None:
                        return False
                # the run goes on: what the stop message says about written results is void
                ev.message = ev.message.split("; results are written up to")[0] + (
                    f"; continued on the smooth branch (bifurcation: continue): results between "
                    f"t = {N.t[k]:.6g} and {N.t[-1]:.6g} are interpolated across the crossing and "
                    f"less accurate")
                return True
        return False


def _distinct(a: np.ndarray) -> np.ndarray:
    """Sorted distinct small non-negative integers (np.unique imports numpy.ma: start-up)."""
    return np.flatnonzero(np.bincount(a)) if len(a) else a


class Analysis:
    """One analysis of a compiled model: assembly, path following, dense output in chunks."""

    def __init__(self, cm: CompiledModel, A: Assembly, opts: Options, warm=None,
                 session=False):
        """warm: a warmstart.Start (a neighbouring model's path, a design study's previous
        variant) to start the path from, or None: the path is followed from the assembly.
        session: a solve of the Python API (planarkin.solve), whose large jobs of one structure
        add up towards the compiled route (kernel.route); a command's run, a study's variant
        or a design's analysis takes its route by its own size."""
        self.cm = cm
        self.warm = warm
        self.warmed = False         # the path came from the warm start (follow())
        self.A = A
        self.S_all = System(cm)
        self.opts = opts
        self.kinks = driver_breakpoints(cm, opts.start, opts.end)
        self.follower = PathFollower(cm, A, opts, kinks=self.kinks)
        self.event: Event | None = None
        self.t_stop = opts.end
        self.fallbacks = 0
        self.timings: dict[str, float] = {}
        self.third = None           # drivers' third derivatives at the chunk's rows (up_to: jerk)
        self._Qddd = None           # the chunk's jerks (internal units) while it is assembled
        self.out = None             # analysis.Collect: where the kernel lays chunks out (solve())
        # the compiled route (planarkin.solver.compiled.kernel.Library) when the grid, or the
        # session's large solves of this structure with it, repay numba's start-up, else None:
        # the numpy passes (the same results to 1e-15, kernel.route)
        self.compiled = kernel.route(opts.rows,
                                     structure=kernel.structure_key(cm) if session else None)

    def follow(self) -> Event | None:
        t0 = time.perf_counter()
        f = self.follower
        nodes = None if self.warm is None else warm_nodes(f.S, self.A, self.opts, self.kinks,
                                                          self.warm)
        self.warmed = nodes is not None
        if nodes is not None:
            f.nodes = nodes                 # the corrected neighbour's path, to the end
        elif not f.start(self.A.q):
            ts = self.opts.start
            _, NU, FDD = self.S_all.driver_values(np.array([ts]), side=+1)
            bad = [r for r in self.cm.driver_rows
                   if not (np.isfinite(NU[0, r]) and np.isfinite(FDD[0, r]))]
            if bad:
                el = self.cm.element_of_row(int(bad[0]))
                self.event = Event("driver", ts, f"{el.label}: the derivatives of f = "
                                                 f"{el.f.text} are not finite just after t = "
                                                 f"start = {ts:.10g}")
            else:
                self.event = Event("failure", ts,
                                   "velocities or accelerations are undefined at t = start "
                                   "(singular Jacobian at the assembly pose)")
            self.t_stop = self.opts.start
        else:
            self.event = f.run()
            if self.event is not None:
                self.t_stop = f.nodes.t[-1]
        N = f.nodes
        self.Tn = np.array(N.t)
        self.Qn, self.Qdn, self.Qddn = np.array(N.q), np.array(N.qd), np.array(N.qdd)
        self.Cn = np.array(N.cond)
        self.seg = np.array(N.seg, dtype=np.intp)
        # per interval [node i, node i+1]: the sign of a fine block flips inside (a bifurcation
        # passed with bifurcation: continue); intervals between segments have zero length
        self.crossing = np.array([N.seg[i] == N.seg[i + 1] and bool(
            (np.asarray(N.sign[i]) != np.asarray(N.sign[i + 1])).any())
            for i in range(len(N) - 1)] + [False], dtype=bool)
        # node signs as one array per segment (rows of other segments are never compared)
        self.signs = {}
        for u in set(N.seg):
            width = len(next(sg for sg, su in zip(N.sign, N.seg) if su == u))
            self.signs[u] = np.array([sg if su == u else np.zeros(width)
                                      for sg, su in zip(N.sign, N.seg)])
        self.timings["path"] = time.perf_counter() - t0
        return self.event

    def grid(self) -> np.ndarray:
        """Grid times up to the stopping time (s); the whole grid at once: for small runs."""
        return np.concatenate(list(self._grid_chunks())) if self.opts.rows else np.zeros(0)

    def _grid_chunks(self):
        """Grid times chunk by chunk, up to the stopping time; the grid itself is never held
        whole (a 10^9-step grid is 8 GB). A chunk's working set is kept under CHUNK_BYTES
        (System.point_bytes: coordinates and the largest block's factorisation), so memory does
        not grow with the number of steps: the 300-coordinate arch solves 130 points per chunk,
        the slider-crank the default 8192; a model of many solve blocks up to CHUNK_MIN_POINTS
        within CHUNK_BYTES_MANY (the 6,003-coordinate chain 232)."""
        per_point = max(S.point_bytes() for S, _ in self.follower.systems) \
            + point_row_bytes(self.cm)
        size = CHUNK_BYTES // per_point
        if max(len(S.blocks) for S, _ in self.follower.systems) >= CHUNK_MANY_BLOCKS:
            size = max(size, min(CHUNK_MIN_POINTS, CHUNK_BYTES_MANY // per_point))
        size = max(16, min(self.opts.chunk, size))
        for a in range(0, self.opts.rows, size):
            g = self.opts.times(a, a + size)
            if self.event is not None:
                g = g[g <= self.t_stop]
            if len(g):
                yield g
            if len(g) < size:
                return

    def chunks(self):
        """Yield Chunk objects over the grid (up to the stopping time); a grid point that fails
        (an event set here) ends the stream after the rows before it."""
        ev = self.event
        for g in self._grid_chunks():
            ch = self._dense(g)
            if ch is not None and len(ch.t):
                yield ch
            if ch is None or self.event is not ev:
                return

    def breakpoint_info(self) -> dict:
        """summary.json's account of the drivers' breakpoints in [start, end]."""
        cm = self.cm
        return {"rows_at_breakpoints": ROWS_AT_BREAKPOINTS,
                "times": [k.t for k in self.kinks],
                "jumps": [{"t": k.t, "driver": cm.element_of_row(r).label,
                           "position": bp.jump[0], "velocity": bp.jump[1],
                           "acceleration": bp.jump[2],
                           "unit": self.follower._driver_unit(r)}
                          for k in self.kinks for r, bp in k.jumps]}

    def _driver_values(self, t: np.ndarray):
        """Driver targets and derivatives at grid times t, one-sided at breakpoints (right-hand
        limit, at the end time left-hand: ROWS_AT_BREAKPOINTS). A non-finite value or
        derivative refuses the row: returns (drivers, index of the first bad row or None)."""
        S = self.S_all
        drivers = S.driver_values(t)
        T, NU, FDD = drivers
        # SIDE_RULE: a row within 8 ulp of a breakpoint is at it (right-hand limit); the row at
        # the end time takes the left-hand limit of a breakpoint there (within 8 ulp, as the
        # side-0 evaluation snaps; side -1 changes nothing away from a switch)
        end = t == self.opts.end
        for k in self.kinks:
            at = np.nonzero((np.abs(t - k.t) <= 8 * np.spacing(max(abs(k.t), 1.0))) & ~end)[0]
            if len(at):
                T[at], NU[at], FDD[at] = S.driver_values(t[at], side=+1)
        if end.any():
            T[end], NU[end], FDD[end] = S.driver_values(t[end], side=-1)
        rows = self.cm.driver_rows
        if self.opts.order >= 3:
            # f''' one-sided at every row: at a knot of a law or a table where only f''' jumps
            # (no breakpoint of the path) a row takes the side rows at a breakpoint take
            self.third = S.driver_third(t, side=+1)
            if end.any():
                self.third[end] = S.driver_third(t[end], side=-1)
        if not len(rows):
            return drivers, None
        used = [T[:, rows]] + ([NU[:, rows]] if self.opts.order >= 1 else []) \
            + ([FDD[:, rows]] if self.opts.order >= 2 else []) \
            + ([self.third[:, rows]] if self.opts.order >= 3 else [])
        good = np.logical_and.reduce([np.isfinite(u).all(axis=1) for u in used])
        bad = np.nonzero(~good)[0]
        return drivers, (int(bad[0]) if len(bad) else None)

    def _dense(self, t: np.ndarray) -> Chunk | None:
        opts = self.opts
        Tn, Qn, Qdn, Qddn, Cn = self.Tn, self.Qn, self.Qdn, self.Qddn, self.Cn
        K = len(Tn)
        N = len(t)
        lib = None        # the compiled kernel, when it solves this chunk (and lays it out)
        if K == 1:
            idx = np.zeros(N, dtype=np.intp)
            Q = np.repeat(Qn[:1], N, axis=0)
            Qd = np.repeat(Qdn[:1], N, axis=0)
            Qdd = np.repeat(Qddn[:1], N, axis=0)
        elif (lib := self._chunk_kernel(idx := np.clip(
                np.searchsorted(Tn, t, side="right") - 1, 0, K - 2))) is not None:
            # the compiled route solves this chunk and writes its predictions (solve_batch's
            # predict) into arrays kept from chunk to chunk (kernel.chunk_buffers)
            Q, Qd, Qdd, Rbuf = kernel.chunk_buffers(self.__dict__, N, Qn.shape[1], self.cm.m)
        else:
            h = (Tn[idx + 1] - Tn[idx])[:, None]
            s = (t[:, None] - Tn[idx][:, None]) / h
            args = (s, h, Qn[idx], Qdn[idx], Qddn[idx], Qn[idx + 1], Qdn[idx + 1], Qddn[idx + 1])
            Q = hermite5(*args)
            # the solver computes velocities and accelerations from scratch: their
            # interpolated values are needed only where no solve happens
            if opts.interpolate or self.crossing[idx].any():
                Qd = hermite5(*args, deriv=1)
                Qdd = hermite5(*args, deriv=2)
            else:
                Qd = np.zeros_like(Q)
                Qdd = np.zeros_like(Q)
        # jerks: solved at every solved row; rows kept interpolated inside a bifurcation
        # crossing (bifurcation: continue) take the interpolant's, like their velocities
        Qddd = None
        if opts.order >= 3:
            Qddd = hermite5(*args, deriv=3) if K > 1 and self.crossing[idx].any() \
                else np.zeros_like(Q)
        iters = np.zeros(N, dtype=np.int64)
        cond = np.maximum(Cn[idx], Cn[np.minimum(idx + 1, K - 1)])
        segs = self.seg[idx]
        drivers, bad = self._driver_values(t)          # shared by the solve and the residual
        if bad is not None:
            i = bad
            rows = self.cm.driver_rows
            which = next(r for r in rows if not all(np.isfinite(d[i, r]) for d in (
                drivers[:1 + min(opts.order, 2)] + ((self.third,) if opts.order >= 3 else ()))))
            el = self.cm.element_of_row(int(which))
            self.event = Event("driver", float(t[i]),
                               f"{el.label}: f = {el.f.text} or its derivatives are not finite at "
                               f"t = {t[i]:.10g} (a grid row): the velocities or accelerations "
                               f"there do not exist; results are written up to the row before")
            self.t_stop = float(t[i])
            if i == 0:
                return None
            t, Q, Qd, Qdd, idx, cond, segs = t[:i], Q[:i], Qd[:i], Qdd[:i], idx[:i], cond[:i], \
                segs[:i]
            iters = iters[:i]
            drivers = tuple(d[:i] for d in drivers)
            if Qddd is not None:
                Qddd, self.third = Qddd[:i], self.third[:i]
            N = i
        self._Qddd = Qddd
        if opts.interpolate:
            return self._chunk(t, Q, Qd, Qdd, iters, cond, segs, drivers[0])
        # points between nodes on either side of a bifurcation passed with bifurcation: continue
        # keep their interpolated values: the Jacobian is singular somewhere in that interval
        solve = ~self.crossing[idx]
        R = Rmax = None   # |Phi| at the results when the solve computed it for every row
        for u in _distinct(segs[solve]):
            sel = np.nonzero(solve & (segs == u))[0]
            whole = len(sel) == N
            tq = t if whole else t[sel]
            Qs, Qds, Qdds = (Q, Qd, Qdd) if whole else (Q[sel], Qd[sel], Qdd[sel])
            Qddds = third = None
            if Qddd is not None:
                Qddds, third = (Qddd, self.third) if whole else (Qddd[sel], self.third[sel])
            info = self.follower.systems[u][0].solve_batch(
                tq, Qs, Qds, Qdds, policy=opts.newton, tol=opts.tol, maxit=opts.iterations,
                order=opts.order, drivers=drivers if whole else tuple(d[sel] for d in drivers),
                Qddd=Qddds, third=third, compiled=self.compiled,
                predict=None if lib is None else (tq, idx, Tn, Qn, Qdn, Qddn),
                R=None if lib is None else Rbuf[:len(tq)])
            ok = self._accepted(info, Qs, u, idx, sel, whole)
            if not whole:
                Q[sel], Qd[sel], Qdd[sel] = Qs, Qds, Qdds
                if Qddd is not None:
                    Qddd[sel] = Qddds
            iters[sel] = info.iterations
            cond[sel] = condition(info)
            if whole and (ok is True or ok.all()):
                R, Rmax = info.residual, info.residual_max
            for i in (() if ok is True else sel[~ok]):
                self.fallbacks += 1
                res = self._follow_to(int(idx[i]), float(t[i]))
                if res is None:
                    self.event = Event("failure", float(t[i]),
                                       f"a grid point at t = {t[i]:.10g} could not be solved on "
                                       f"the branch followed so far")
                    keep = t < t[i]
                    if Qddd is not None:
                        self._Qddd = Qddd[keep]
                    return self._chunk(t[keep], Q[keep], Qd[keep], Qdd[keep], iters[keep],
                                       cond[keep], segs[keep], drivers[0][keep]) \
                        if keep.any() else None
                Q[i], Qd[i], Qdd[i], iters[i], cond[i] = res
                if Qddd is not None:
                    Qddd[i] = self._jerk_at(u, t[i], Q[i], Qd[i], Qdd[i], self.third[i])
        return self._chunk(t, Q, Qd, Qdd, iters, cond, segs, drivers[0], R, Rmax, lib)

    def _signs_one(self, u: int):
        """The determinant signs all nodes of segment u share (the common case: no branch
        changes), or None: a chunk's rows then compare with that one row, not with a row
        gathered per point. Kept with the signs array it was read from."""
        signs = self.signs[u]
        got = self.__dict__.setdefault("_one", {}).get(u)
        if got is None or got[0] is not signs:
            mine = signs[self.seg == u]
            got = self._one[u] = (signs, mine[0] if len(mine) and (mine == mine[0]).all()
                                  else None)
        return got[1]

    def _accepted(self, info, Qs, u: int, idx, sel, whole: bool):
        """Which solved grid points are accepted as a path step would be (acceptance.accepted:
        converged, first correction within KAPPA of sigma_min, finite positions, condition at
        most COND_SINGULAR, the determinant signs of the bracketing node). A bool array over
        sel, or True when all are (the kernel's chunks, checked by a few whole-array
        reductions: its converged flags say finite already)."""
        K = len(self.Tn)
        if whole and info.cond is not None and self.opts.newton != "fixed":
            one = self._signs_one(u) if K > 1 else None
            if (K == 1 or one is not None) and accepted(info, one).all():
                return True
        return accepted(info, self.signs[u][idx[sel]] if K > 1 else None, (Qs,),
                        converged=self.opts.newton != "fixed")

    def _chunk_kernel(self, idx):
        """The compiled library when the chunk at node intervals idx is solved (not
        interpolated), whole (on one segment without a passed bifurcation), by the compiled
        route (System.route_of); else None."""
        segs = self.seg[idx]
        u = int(segs[0])
        if self.opts.interpolate or (segs != u).any() or self.crossing[idx].any():
            return None
        k = self.follower.systems[u][0].route_of(self.compiled, self.opts.newton,
                                                 self.opts.order)
        return None if k is None else k[0]



    def _jerk_at(self, u: int, t: float, q, qd, qdd, third) -> np.ndarray:
        """The jerk at a row solved by path following (a fallback): the jerk system of its
        segment's equations at the converged q, qd, qdd (only the jerk solve is new: the
        position, velocity and acceleration solves repeat the converged values)."""
        Q, Qd, Qdd = q[None].copy(), qd[None].copy(), qdd[None].copy()
        Qddd = np.zeros_like(Q)
        self.follower.systems[u][0].solve_batch(np.array([t]), Q, Qd, Qdd, policy="full",
                                                tol=NODE_TOL, maxit=2, order=3,
                                                Qddd=Qddd, third=third[None])
        return Qddd[0]

    def _follow_to(self, k: int, t_target: float):
        """Solve one grid point by path following from node k (a dense-pass fallback)."""
        src = self.follower.nodes
        f = PathFollower(self.cm, self.A, self.opts, self.follower.systems, src.seg[k])
        if k > 0 and src.seg[k - 1] == src.seg[k]:
            f.nodes.copy_from(src, k - 1)          # for the third-derivative estimate
        f.nodes.copy_from(src, k)
        f.opts = self.opts.with_(end=t_target)
        f.span = max(t_target - src.t[k], 1e-300)
        f.h_max = f.span
        f.h_min = self.follower.h_min
        if t_target > src.t[k] and f.run() is not None:
            return None
        n = f.nodes
        return n.q[-1], n.qd[-1], n.qdd[-1], 0, n.cond[-1]

    def _chunk(self, t, Q, Qd, Qdd, iters, cond, segs, T, R=None, Rmax=None,
               lib=None) -> Chunk:
        """Residual of every equation (redundant ones included) at the results, user units.
        T: the equations' targets at t; R: their |Phi| (N, m) when the solve computed it, Rmax
        its largest value per row when computed too. lib: the compiled kernel that solved the
        chunk, which then writes the user-unit arrays in one pass (kernel.layout)."""
        cm, S_all = self.cm, self.S_all
        n = cm.n
        if R is None:
            R = np.abs(S_all.residual(Q, t, T)) if cm.m else np.zeros((len(t), 1))
            Rmax = None
        residual = R.max(axis=1) if Rmax is None else Rmax
        if self.A.redundant_rows and self.event is None:
            # the rows left out of the solve must stay satisfied
            left_out = np.zeros_like(R)
            for u in _distinct(segs):
                out = np.setdiff1d(np.arange(cm.m), self.follower.systems[u][0].rows)
                left_out[np.ix_(segs == u, out)] = R[np.ix_(segs == u, out)]
            worst = left_out.max(axis=1)
            bad = np.nonzero(worst > 1e-8)[0]
            if bad.size:
                i = int(bad[0])
                row = int(np.argmax(left_out[i]))
                self.event = Event("redundant", float(t[i]),
                                   f"{cm.row_label[row]}, redundant at the assembly pose, is "
                                   f"violated at t = {t[i]:.10g} (by {worst[i] * cm.L:.3g} "
                                   f"{cm.spec.length_unit}): the redundancy holds only at some "
                                   f"poses; remove the joint")
                self.t_stop = float(t[i])
                keep = slice(0, i)
                t, Q, Qd, Qdd, iters, cond, residual = (
                    t[keep], Q[keep], Qd[keep], Qdd[keep], iters[keep], cond[keep],
                    residual[keep])
                if self._Qddd is not None:
                    self._Qddd = self._Qddd[keep]
        order = self.opts.order
        L, af = cm.L, cm.angle_factor
        unit = np.tile([L, L, 1.0 / af], cm.nb)
        if lib is not None and order <= 2:
            out = None if self.out is None else self.out.reserve(len(t), n, len(cm.point_body),
                                                                 order)
            q, qd, qdd, p, pd, pdd = kernel.layout(lib, cm, Q, Qd, Qdd, order, unit, out)
            return Chunk(t, q, qd, qdd, p, pd, pdd, iters, cond, residual)
        q = Q[:, :n] * unit
        qd = Qd[:, :n] * unit if order >= 1 else None
        qdd = Qdd[:, :n] * unit if order >= 2 else None
        p, pd, pdd = point_kinematics(cm, Q, Qd if order >= 1 else None,
                                      Qdd if order >= 2 else None)
        qddd = pddd = None
        if order >= 3:
            Qddd = self._Qddd
            qddd = Qddd[:, :n] * unit
            pddd = point_jerk(cm, Q, Qd, Qdd, Qddd) * L
        return Chunk(t, q, qd, qdd, p * L, None if pd is None else pd * L,
                     None if pdd is None else pdd * L, iters, cond, residual, qddd, pddd)
