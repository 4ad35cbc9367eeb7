"""A group of chains of variants solved in lockstep (planarkin.studies.batch.Batch.run_group).

Each chain's variants are solved one after another from their predecessor's solution, all the
chains of the group at once: predictions by the cubic through the four previous solutions when
the parameter step repeated three times, the quadratic through three or the secant through two
when twice or once (a sweep along one parameter, the substeps), else (a head, a factorial's
next row) to first order in the step with the nominal's exact sensitivities (the predecessor's
solution itself where those do not apply); a step that fails is retried in SUBSTEPS equal
steps. A variant that fails every retry is solved by the ordinary per-variant path.
"""

from __future__ import annotations

import numpy as np

from .outcome import Outcome

SUBSTEPS = (4, 16)  # a failed parameter step is retried in this many equal steps


class Lockstep:
    """The state of a group of C chains: per chain its current solution (state, sign), the
    last three solutions before it and the parameter steps between them (a ring: entry j, 0 the
    newest, in slot (nh - 1 - j) % 3, nh of them pushed so far; hq[slot] one (C, T, n + 3)
    array: when every chain moves, the state before the step becomes the slot's array), its
    parameter vector (here) and whether it is still solved together (alive)."""

    def __init__(self, batch, chains_values: list[list[dict]]):
        self.b = batch
        self.chains = chains_values
        C = self.C = len(chains_values)
        self.keys = batch.varied
        self.nominal_p = np.array([batch.study.parameters[k] for k in self.keys])
        Q0, Qd0, Qdd0, sg0 = batch.nominal
        rep = lambda a: np.repeat(a[None], C, axis=0)
        self.state = [rep(Q0), rep(Qd0), rep(Qdd0)]
        self.sign = rep(sg0)
        self.hq = [np.zeros((C,) + Q0.shape) for _ in range(3)]
        self.hdp = np.zeros((C, 3, len(self.keys)))
        self.nh = np.zeros(C, dtype=int)
        self.back = np.arange(2, -1, -1)             # oldest first: entries 2, 1, 0
        self.here = np.repeat(self.nominal_p[None], C, axis=0)
        self.alive = np.ones(C, dtype=bool)
        # the kernel's buffers: its diagnostics (work), and arrays of the state and history
        # that a step dropped (spare), for the next step's results: a fresh half megabyte
        # costs its page faults at every step
        self.work, self.spare = {}, []
        # the numbers of every variant of the group, evaluated once; chain c's variant j is
        # row first[c] + j
        self.pre = batch.numbers([v for ch in chains_values for v in ch])
        self.first = np.cumsum([0] + [len(ch) for ch in chains_values[:-1]])

    def run(self) -> list[list[Outcome]]:
        nan = float("nan")
        chains, keys, C = self.chains, self.keys, self.C
        heads = np.array([[ch[0][k] for k in keys] for ch in chains])
        live = list(range(C))
        ok, sol, s = self.advance(live, heads, self.first)
        self.alive[:] = ok
        live = [c for c in live if self.alive[c]]
        out: list[list] = [[None] * len(ch) for ch in chains]
        if live:
            met = self.b.metrics(*(a[live] for a in sol), s[live])
            for i, c in enumerate(live):
                out[c][0] = Outcome("ok", "", nan, "", tuple(float(x) for x in met[i]))
        length = max(len(ch) for ch in chains)
        for j in range(1, length):
            live = [c for c in range(C) if self.alive[c] and j < len(chains[c])]
            if not live:
                break
            tg = np.array([[chains[c][j][k] for k in keys] for c in live])
            ok, sol, s = self.advance(live, tg, self.first[live] + j)
            met = self.b.metrics(*sol, s)
            for i, c in enumerate(live):
                if ok[i]:
                    out[c][j] = Outcome("ok", "", nan, "", tuple(float(x) for x in met[i]))
        # the rest variant by variant: the ordinary path, exact as `planarkin run`
        for c, ch in enumerate(chains):
            for j, v in enumerate(ch):
                if out[c][j] is None:
                    out[c][j] = self.b.study.solve(v)[0]
        return out

    def advance(self, live, targets, at):
        """Step chains live to targets (the group's variants at: rows of pre); those that fail
        retry in SUBSTEPS equal parameter steps each (as the path follower splits a step).
        Returns ok (len(live),), the solutions and point offsets of the last attempt at the
        targets."""
        live = list(live)
        ok, sol, s = self.step(live, targets, at)
        if not ok.all():        # the substeps' results go into these
            sol = [a.copy() for a in sol]
        for nsub in SUBSTEPS:
            bad = [i for i in range(len(live)) if not ok[i]]
            if not bad:
                break
            cs = [live[i] for i in bad]
            start_p = np.array([self.here[c] for c in cs])
            goal = targets[bad]
            keep = np.ones(len(bad), dtype=bool)
            for k in range(1, nsub + 1):
                idx = np.nonzero(keep)[0]
                if not len(idx):
                    break
                tg = start_p[idx] + (goal[idx] - start_p[idx]) * (k / nsub)
                if k == nsub:
                    tg = goal[idx]
                okk, solk, sk = self.step([cs[i] for i in idx], tg)
                keep[idx[~okk]] = False
                if k == nsub:
                    for j, i in enumerate(idx):
                        if okk[j]:
                            ok[bad[i]] = True
                            for a, b in zip(sol, solk):
                                a[bad[i]] = b[j]
                            s[bad[i]] = sk[j]
        return ok, sol, s

    def step(self, live, targets, at=None):
        """Solve chains `live` at parameter vectors `targets` from their current state; at: the
        targets' rows in the group's numbers (pre), when they are variants."""
        b, C = self.b, self.C
        k = b.kernel()
        live = np.asarray(live, dtype=int)
        every = len(live) == C and (live == np.arange(C)).all()
        dp = targets - self.here[live]
        pred, hist = self._predict(live, dp, every, k)
        vals = None if at is not None else [dict(zip(self.keys, map(float, p)))
                                            for p in targets]
        spare = self.spare
        out = [spare.pop() for _ in range(3)] if every and len(spare) >= 3 else None
        Qn, Qdn, Qddn, sgn, ok, s = b.solve(vals, *pred, self.sign if every else self.sign[live],
                                            num=None if at is None else b.take(self.pre, at),
                                            hist=hist, k=k, work=self.work, out=out)
        self._record(live, np.nonzero(ok)[0], targets, dp, (Qn, Qdn, Qddn, sgn), k)
        return ok, (Qn, Qdn, Qddn), s

    def _predict(self, live, dp, every, k):
        """The predictions (positions; velocities and accelerations None: every route solves
        them afresh) of chains live for parameter steps dp, and the history the compiled route
        predicts the cubic chains from itself (or None)."""
        C, hq, nh, back, state = self.C, self.hq, self.nh, self.back, self.state
        pred = [None, None, None]
        # same[:, j]: the step repeats history step 2 - j (to rounding; that one not zero)
        slots = (nh[live][:, None] - 1 - back[None]) % 3
        v = self.hdp[live[:, None], slots]
        same = (np.any(v != 0, axis=-1)
                & np.all(np.abs(dp[:, None] - v) <= 1e-9 * np.abs(v), axis=-1)
                & (back[None] < nh[live][:, None]))
        # polynomial extrapolation along a repeated parameter step: the error of the cubic is
        # fourth order in the step, so that one Newton correction, at most tol, reaches
        # rounding (the quadratic's third order leaves a second one)
        cubic = same.all(axis=1)
        quad = ~cubic & same[:, 1] & same[:, 2]
        sec = ~cubic & ~quad & same[:, 2]
        rest = ~(cubic | quad | sec)
        lockstep = every and (slots == slots[0]).all()

        def h(i, j):
            """History entry j of chains i (live positions): the slot's array itself when they
            are all the chains, in lockstep."""
            if lockstep and len(i) == C:
                return hq[slots[0, 2 - j]]
            return np.stack([hq[slots[a, 2 - j]][live[a]] for a in i])

        def rows(mask):
            """The live positions of mask: a slice when it is all of them (no copies)."""
            return slice(None) if mask.all() else np.nonzero(mask)[0]

        def index(i):
            return np.arange(len(live)) if isinstance(i, slice) else i

        hist = None
        if k is not None and lockstep and cubic.any():
            # the usual case, the chains in lockstep: the cubic chains' predictions computed
            # on the compiled route (kernel.solve_rows, points.cubic: the operations of the
            # numpy lines below, the same bits), the others' below into q
            base = state[0]
            hist = [base] + [hq[slots[0, 2 - j]] for j in range(3)] + [
                np.repeat(cubic, base.shape[1])]
            q = pred[0] = base
            if not cubic.all():         # the others start as the state, as below
                q = pred[0] = np.empty_like(base)
                q[~cubic] = base[~cubic]
        else:
            q = base = pred[0] = state[0].copy() if every else state[0][live]
            if cubic.any() and lockstep:
                # the chains in lockstep: views of the history, no copies (the chains whose
                # step is another get their prediction below)
                q1, q2, q3 = (hq[slots[0, 2 - j]] for j in range(3))
                r = np.subtract(q, q1)
                r *= 3
                r += q                              # q0 + 3 (q0 - q1), as below
                t = np.subtract(q1, q2)
                t *= 3
                r -= t
                np.subtract(q2, q3, out=t)
                r += t
                np.copyto(q, r, where=cubic[:, None, None])
            elif cubic.any():
                i = np.nonzero(cubic)[0]
                q0, q1, q2 = q[i], h(i, 0), h(i, 1)
                q[i] = q0 + 3 * (q0 - q1) - 3 * (q1 - q2) + (q2 - h(i, 2))
        if quad.any():
            i = rows(quad)
            q[i] = 3 * (base[i] - h(index(i), 0)) + h(index(i), 1)
        if sec.any():
            i = rows(sec)
            q[i] = 2 * base[i] - h(index(i), 0)
        if rest.any() and self.b.tangent is not None:
            # any other step (a chain's head, a factorial's next row): first order in the step,
            # with the nominal's exact sensitivities
            i = rows(rest)
            q[i] = base[i] + self.b.first_order(dp[i])
        return pred, hist

    def _record(self, live, got, targets, dp, new, k) -> None:
        """The solved chains (got: positions in live) move: their state before the step goes
        into the history, the step into the steps', the solutions become the state."""
        C, hq, nh, state = self.C, self.hq, self.nh, self.state
        Qn, Qdn, Qddn, sgn = new
        cs = live[got]
        moved = len(cs) == C and (cs == np.arange(C)).all()
        if moved and (nh == nh[0]).all():
            self.spare.append(hq[nh[0] % 3])
            hq[nh[0] % 3] = state[0]        # (not written into after: see below)
        else:
            for c in cs:
                hq[nh[c] % 3][c] = state[0][c]
        self.hdp[cs, nh[cs] % 3] = dp[got]
        nh[cs] += 1
        self.here[cs] = targets[got]
        if moved:
            # every chain moved: the solutions are the new state (not written into after: a
            # later step copies into the state, and the solutions are read before that)
            if k is not None:           # (the others' results are not written into spares)
                self.spare.extend(state[1:])
            state[:] = Qn, Qdn, Qddn
            self.sign[...] = sgn
        else:
            for a, new_ in zip(state + [self.sign], (Qn, Qdn, Qddn, sgn)):
                a[cs] = new_[got]
