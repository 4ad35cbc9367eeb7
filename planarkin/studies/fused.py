"""One Newton pass over the whole system for many (variant, time) rows at once.

`System.solve_batch` solves block by block: per block it evaluates the elements with rows in
that block (an element with rows in two blocks twice), inverts the block, iterates to
convergence, then refactors it for the velocity and acceleration systems. For the batched study
(`studies.batch`: tens of thousands of rows, blocks of one or two unknowns) that is a few hundred
small numpy calls per block and most of the cost. Here every element group is evaluated once per
Newton iteration over all rows (its value and its gradient, giving the whole Jacobian), and the
Newton correction J dq = Phi is solved by forward substitution through the same block-triangular
form (the rows of block b reach only the columns of blocks up to b): the diagonal blocks are
inverted in closed form (1 x 1 and 2 x 2) or by linalg.inv_batched. That is Newton's method on
the whole system, so it converges quadratically from a good prediction (a neighbour's solution)
to the same solution. The velocities and accelerations are then the exact linear systems
Phi_q qdot = nu and Phi_q qddot = gamma with the Jacobian at the converged positions, solved by
the same substitution (the last Newton iteration's factorisation where that iteration's
correction was at rounding level, REUSE: from a prediction of third order in the parameter step
one correction reaches the solution and the next only confirms it).

Per row the diagnostics the path follower's step tests read are kept: the determinant sign of
every fine block and a lower bound of its smallest singular value at the prediction, the first
correction of every block against that bound (KAPPA), and convergence (the last correction at
most tol). A row that has converged is not updated again; once only a quarter of the rows is
still iterating, those iterate alone (a chain whose parameter step repeats no earlier one needs a
few more iterations than its lockstep neighbours).

Applies when every solve block is one fine block, small (dense), the system square and its
gradient entries at most MAX_ENTRIES per row; otherwise the caller keeps System.solve_batch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..elements.base import Frame
from ..linalg import inv_batched, sigma_min_lower


# A last Newton correction at most this (internal units: lengths / L, radians) leaves the
# Jacobian it was taken with within rounding of the one at the solution, so that factorisation
# serves the velocity and acceleration systems (relative change of the order of REUSE).
REUSE = 1e-14
# The whole Jacobian is held per row (its gradient entries, 8 bytes each): above this many a
# large mechanism keeps System.solve_batch, whose per-block arrays stay small.
MAX_ENTRIES = 1024


def _select(mask, a, b):
    """Per row: a where mask, else b, through the nested tuples of factor()'s output."""
    if a is None:
        return None
    if isinstance(a, (tuple, list)):
        return type(a)(_select(mask, x, y) for x, y in zip(a, b))
    return np.where(mask.reshape((-1,) + (1,) * (a.ndim - 1)), a, b)


def rowmax(a: np.ndarray) -> np.ndarray:
    """(N, k) -> (N,) largest entry of each row, NaN if any is: a.max(axis=1), column by
    column (numpy reduces a short trailing axis several times slower than it takes the
    elementwise maximum of a few columns)."""
    if a.shape[1] > 32 or a.shape[1] == 0:
        return a.max(axis=1)
    m = a[:, 0].copy()
    for i in range(1, a.shape[1]):
        np.maximum(m, a[:, i], out=m)
    return m


def _put(a, rows, b) -> None:
    """a[rows] = b through the nested tuples of factor()'s output (in place)."""
    if a is None:
        return
    if isinstance(a, (tuple, list)):
        for x, y in zip(a, b):
            _put(x, rows, y)
        return
    a[rows] = b


def _take(G, rows, keys):
    """The group G with its per-row parameters (the names keys) restricted to rows."""
    from ..elements.base import Group
    p = {k: (np.asarray(v)[rows].view(type(v)) if k in keys else v)
         for k, v in G.params.items()}
    return Group(G.kind, G.bodies, G.cols, p, G.rows)


@dataclass
class FusedInfo:
    """Per-row diagnostics, as System.solve_batch's BatchInfo (arrays of length N)."""

    iterations: np.ndarray
    converged: np.ndarray
    ratio: np.ndarray
    sign: np.ndarray        # (N, nfine)
    smin: np.ndarray        # (N, nblocks)


class Fused:
    """The substitution plan of a System (fixed per structure): per block, where its matrix, its
    right-hand side's coupling to earlier blocks and its unknowns are."""

    def __init__(self, S):
        self.S = S
        self.n = S.n
        self.m = S.cm.m
        # every gradient entry of every element: (row, column) -> its index in the
        # concatenation of the groups' flattened gradients (rows belong to one element each)
        where, off = {}, 0
        for G in S.cm.groups:
            K, neq, nc = len(G), G.kind.neq, G.cols.shape[1]
            for k in range(K):
                for e in range(neq):
                    for c in range(nc):
                        key = (int(G.rows[k, e]), int(G.cols[k, c]))
                        where[key] = off + (k * neq + e) * nc + c
            off += K * neq * nc
        self.width = off + 1                # the last column: a structural zero
        at = lambda r, c: where.get((int(r), int(c)), off)
        earlier: list[int] = []
        self.plan = []
        for B in S.blocks:
            rows, cols = np.asarray(B.rows), np.asarray(B.cols)
            k = len(cols)
            # columns of earlier blocks that the block's rows reach
            dep = np.array(sorted({c for (r, c) in where if r in set(rows.tolist())}
                                  & set(earlier)), dtype=np.intp)
            diag = np.array([at(r, c) for r in rows for c in cols], dtype=np.intp)
            offd = np.array([at(r, c) for r in rows for c in dep], dtype=np.intp)
            self.plan.append((rows, cols, k, dep, diag, offd, B.first))
            earlier += cols.tolist()
        self.nfine = S.nfine
        self.unknowns = np.concatenate([p[1] for p in self.plan])
        self.block_of = np.concatenate([np.full(p[2], b) for b, p in enumerate(self.plan)])

    @staticmethod
    def applies(S) -> bool:
        entries = sum(len(G) * G.kind.neq * G.cols.shape[1] for G in S.cm.groups)
        return (S.blocks is not None and len(S.rows) == S.cm.m == S.n
                and entries <= MAX_ENTRIES
                and all(len(B.sizes) == 1 and not S.is_large(B) for B in S.blocks))

    # -- evaluations over all rows ---------------------------------------------------------------
    def residual(self, groups, F: Frame, T: np.ndarray) -> np.ndarray:
        N = F.q.shape[0]
        out = np.empty((N, self.m))
        for G in groups:
            out[:, G.rows.ravel()] = G.g(F).reshape(N, -1)
        out -= T
        return out

    def jacobian(self, groups, F: Frame) -> np.ndarray:
        """(N, width) every element's gradient entries (where's order), then a zero."""
        N = F.q.shape[0]
        J = np.empty((N, self.width))
        o = 0
        for G in groups:
            g = G.grad(F).reshape(N, -1)
            J[:, o:o + g.shape[1]] = g
            o += g.shape[1]
        J[:, o] = 0.0
        return J

    def gamma(self, groups, F: Frame, FDD: np.ndarray) -> np.ndarray:
        N = F.q.shape[0]
        out = np.empty((N, self.m))
        for G in groups:
            out[:, G.rows.ravel()] = G.gamma(F).reshape(N, -1)
        out += FDD
        return out

    def factor(self, J: np.ndarray, want: bool):
        """Per block: (inverse, couplings) and, with want, (sign, smin) per block."""
        N = J.shape[0]
        fac, sign, smin = [], np.empty((N, self.nfine)), np.empty((N, len(self.plan)))
        with np.errstate(all="ignore"):
            for b, (rows, cols, k, dep, diag, off, first) in enumerate(self.plan):
                M = J[:, diag]
                C = J[:, off].reshape(N, k, len(dep)) if len(dep) else None
                if k == 1:
                    j = M[:, 0]
                    inv = 1.0 / j
                    if want:
                        sign[:, first] = np.sign(j)
                        smin[:, b] = np.abs(j)
                elif k == 2:
                    a, bb, c, d = M[:, 0], M[:, 1], M[:, 2], M[:, 3]
                    det = a * d - bb * c
                    r = 1.0 / det
                    inv = (d * r, -bb * r, -c * r, a * r)
                    if want:
                        sign[:, first] = np.sign(det)
                        # 1 / ||J^-1||_F, as linalg.sigma_min_lower
                        nf = np.sqrt(a * a + bb * bb + c * c + d * d) * np.abs(r)
                        smin[:, b] = np.where(np.isfinite(nf) & (det != 0), 1.0 / nf, 0.0)
                else:
                    Minv, sg, ok = inv_batched(M.reshape(N, k, k))
                    inv = Minv
                    if want:
                        sign[:, first] = sg
                        smin[:, b] = np.where(ok, sigma_min_lower(Minv), 0.0)
                fac.append((inv, C))
        return fac, sign, smin

    def substitute(self, fac, R: np.ndarray, X: np.ndarray) -> None:
        """X[:, :n] = the solution of Phi_q X = R (N, m), block by block (X (N, n + 3))."""
        for (rows, cols, k, dep, _, _, _), (inv, C) in zip(self.plan, fac):
            r = R[:, rows]
            if C is not None:
                r = r - np.einsum("nkd,nd->nk", C, X[:, dep])
            if k == 1:
                X[:, cols[0]] = r[:, 0] * inv
            elif k == 2:
                X[:, cols[0]] = inv[0] * r[:, 0] + inv[1] * r[:, 1]
                X[:, cols[1]] = inv[2] * r[:, 0] + inv[3] * r[:, 1]
            else:
                X[:, cols] = np.einsum("nij,nj->ni", inv, r)

    # -- the solve -------------------------------------------------------------------------------
    def solve(self, groups, Q, Qd, Qdd, T, NU, FDD, *, tol, maxit, rowkeys=None):
        """Positions (Newton from the predictions Q), velocities and accelerations of N rows, in
        place. groups: the model's element groups, some parameters per row (first axis N):
        rowkeys, per group the names of those (None: none); T, NU, FDD (N, m): the drivers'
        targets, nu and f'' per row. Returns FusedInfo."""
        N = Q.shape[0]
        rowkeys = rowkeys or [()] * len(groups)
        n = self.n
        phi = Q[:, 2::3]
        F = Frame(Q, np.cos(phi), np.sin(phi))
        iters = np.zeros(N, dtype=np.int64)
        done = np.zeros(N, dtype=bool)
        size = np.full(N, np.inf)
        dx = np.zeros((N, n + 3))
        rows = None                     # the rows still iterating, once they are few
        with np.errstate(all="ignore"):
            for it in range(maxit):
                if rows is None and it and 4 * (~done).sum() <= N:
                    # the few rows left (a step that repeats no earlier one) iterate alone
                    rows = np.nonzero(~done)[0]
                    sub = [_take(G, rows, ks) for G, ks in zip(groups, rowkeys)]
                    Qs = Q[rows]
                    Fs = Frame(Qs, np.cos(Qs[:, 2::3]), np.sin(Qs[:, 2::3]))
                    Ts = T[rows]
                    dxs = np.zeros((len(rows), n + 3))
                if rows is not None:
                    facs, _, _ = self.factor(self.jacobian(sub, Fs), want=False)
                    self.substitute(facs, self.residual(sub, Fs, Ts), dxs)
                    step = np.full(N, np.inf)
                    step[rows] = rowmax(np.abs(dxs[:, :n]))
                    step[~np.isfinite(step)] = np.inf
                    live = ~done
                    Qs[live[rows], :n] -= dxs[live[rows], :n]
                    np.cos(Qs[:, 2::3], out=Fs.c)
                    np.sin(Qs[:, 2::3], out=Fs.s)
                else:
                    fac, sg, sm = self.factor(self.jacobian(groups, F), want=it == 0)
                    if it == 0:
                        sign, smin = sg, sm
                    self.substitute(fac, self.residual(groups, F, T), dx)
                    step = rowmax(np.abs(dx[:, :n]))
                    step[~np.isfinite(step)] = np.inf
                    if it == 0:
                        # every block's first correction against its sigma_min bound
                        ratio = rowmax(np.abs(dx[:, self.unknowns]) / smin[:, self.block_of])
                        ratio[~np.isfinite(ratio)] = np.inf
                    live = ~done
                    if live.all():
                        Q[:, :n] -= dx[:, :n]
                    else:
                        Q[live, :n] -= dx[live, :n]
                    # rows whose Jacobian of this iteration is the one at their solution: those
                    # converged before (not moved) and those whose correction was at rounding
                    near = ~live | (step <= REUSE)
                    np.cos(phi, out=F.c)
                    np.sin(phi, out=F.s)
                size = np.where(live, step, size)
                iters[live] = it + 1
                done |= live & (step <= tol)
                if done.all():
                    break
            if rows is not None:
                Q[rows] = Qs
                np.cos(phi, out=F.c)
                np.sin(phi, out=F.s)
                near[rows] = False      # moved since the last iteration over all rows
            # velocities and accelerations: exact linear systems at the converged positions;
            # the rows whose last factorisation is not at their solution get a new one
            if not near.all():
                need = np.nonzero(~near)[0]
                if 4 * len(need) <= N:
                    Qn = Q[need]
                    Fn = Frame(Qn, F.c[need], F.s[need])
                    sub = [_take(G, need, ks) for G, ks in zip(groups, rowkeys)]
                    fresh, _, _ = self.factor(self.jacobian(sub, Fn), want=False)
                    _put(fac, need, fresh)
                else:
                    fresh, _, _ = self.factor(self.jacobian(groups, F), want=False)
                    fac = _select(near, fac, fresh) if near.any() else fresh
            Qd[:, :n] = 0.0
            self.substitute(fac, NU, Qd)
            Qdd[:, :n] = 0.0
            self.substitute(fac, self.gamma(groups, Frame(Q, F.c, F.s, Qd), FDD), Qdd)
        conv = done & (size <= tol) & np.isfinite(rowmax(np.abs(Q)))
        return FusedInfo(iters, conv, ratio, sign, smin)
