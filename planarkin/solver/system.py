"""The numeric system Phi(q, t) = 0 of a compiled model, evaluated for batches of time points.

Two views of the same equations:

* dense, whole system (assembly, rank and singularity analysis): `residual`, `jacobian`;
* block-triangular (the time-stepping solver): the active equations are permuted into small
  square diagonal blocks (`planarkin.solver.structure`) and `solve_batch` runs Newton-Raphson for
  positions, then the velocity and acceleration systems, block by block, each block for a whole
  batch of time points at once. The Newton iterations reuse one factorisation per block and
  point (taken at the prediction, "reuse" policy); the velocity and acceleration systems use the
  diagonal block at the converged positions, factored once for both, so they are the exact linear
  systems Phi_q qdot = nu and Phi_q qddot = gamma, solved to rounding error.

All arrays are in internal units (length / L, radians, seconds).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from dataclasses import dataclass

import numpy as np

from planarkin.elements.base import Frame, Group
from .linalg import (SparseLU, inv_batched, matvec, noise, one_blas_thread, permutation_sign,
                     sigma_min_lower)
from .structure import Blocks, block_triangular

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel

EPS = np.finfo(float).eps
# Irreducible blocks of at least this many unknowns are factored by sparse LU, one per time
# point, instead of dense batched inverses (k^3 time, k^2 memory per point): the crossover
# measured on the arch's blocks by benchmarks/bench_blocks.py (benchmarks/README.md, "Large
# blocks").
SPARSE_BLOCK = 80
# Systems with a block of at least this many unknowns are solved on one BLAS thread
# (linalg.one_blas_thread): there OpenBLAS may thread inside a factorisation and its threads
# fight a busy core. Pinning has a cost per call (openblas_set_num_threads) that shows in a
# short four-bar run's many calls (benchmarks/README.md, "Figures moved from the code's comments"),
# so small systems (which never reach BLAS's threaded sizes) are left alone.
PIN_BLAS_FROM = 32
# Models with at least this many drivers evaluate them all in one expression pass
# (System._driver_values_joint); below, each driver's own TimeFunction.derivatives.
JOINT_DRIVERS = 16


@dataclass(frozen=True)
class Part:
    """The instances of one kind that have rows in a block, and where their numbers go."""

    group: Group
    res_src: np.ndarray     # flat indices into (K * neq) of the rows in this block
    res_dst: np.ndarray     # their positions in the block
    jac_src: np.ndarray     # flat indices into (K * neq * nc) that land in the block matrix
    jac_dst: np.ndarray     # flat indices into (kb * kb)


@dataclass(frozen=True)
class Block:
    """A solve block: consecutive fine blocks of the block-triangular form, in order."""

    rows: np.ndarray        # (kb,) global rows
    cols: np.ndarray        # (kb,) coordinate columns
    phis: np.ndarray        # bodies whose angle is one of cols
    parts: tuple
    sizes: tuple = (1,)     # sizes of the fine blocks it holds
    first: int = 0          # index of its first fine block
    # affine: the equations are affine in the block's own unknowns (one Newton step is exact);
    # fixed_grad: their whole gradient does not depend on the own unknowns either, so the
    # Jacobian taken at the prediction is the one at the solution (no re-evaluation)
    affine: bool = False
    fixed_grad: bool = False


@dataclass
class BatchInfo:
    """Per-point diagnostics of one `solve_batch` call (all arrays of length N)."""

    iterations: np.ndarray            # Newton iterations used (max over blocks)
    converged: np.ndarray             # bool
    ratio: np.ndarray                 # max over blocks of first correction / sigma_min bound
    sign: np.ndarray                  # (N, nfine) sign of det of each fine diagonal block
    smin: np.ndarray                  # (N, nblocks) lower bound of each solve block's sigma_min
    # (N, m) |Phi| of every equation at the results, where the pass computed it (the kernel),
    # and its largest value per point (N,)
    residual: np.ndarray | None = None
    residual_max: np.ndarray | None = None
    # (N,) the condition estimate (acceptance.condition), where the pass computed it (the kernel)
    cond: np.ndarray | None = None


class System:
    """Equations of a compiled model restricted to the active rows (redundant rows removed)."""

    def __init__(self, cm: CompiledModel, rows=None, merge_to: int = 1):
        self.cm = cm
        self.nb = cm.nb
        self.n = cm.n
        self.rows = np.arange(cm.m) if rows is None else np.asarray(rows, dtype=np.intp)
        self.merge_to = merge_to
        self.blocks: tuple[Block, ...] | None = None
        self._csc: dict = {}

    # -- helpers -----------------------------------------------------------------------------
    def ext(self, q: np.ndarray) -> np.ndarray:
        """(N, n) -> (N, n + 3) with the ground's zero coordinates appended."""
        q = np.atleast_2d(q)
        return np.concatenate([q, np.zeros((q.shape[0], 3))], axis=1)

    def frame(self, Q: np.ndarray, Qd: np.ndarray | None = None) -> Frame:
        phi = Q[:, 2::3]
        return Frame(Q, np.cos(phi), np.sin(phi), Qd)

    def driver_values(self, t: np.ndarray, side: int = 0):
        """Targets, nu and f'' for every row: three (N, m) arrays (internal units). side: 0 the
        drivers' derivative rules as written, -1 / +1 their limits from the left / right (they
        differ only at a driver's breakpoint, see TimeFunction.breakpoints)."""
        cm = self.cm
        if len(cm.driver_funcs) >= JOINT_DRIVERS:
            return self._driver_values_joint(t, side)
        t = np.atleast_1d(np.asarray(t, dtype=float))
        N = t.shape[0]
        T = np.empty((N, cm.m))
        T[:] = cm.targets
        NU = np.zeros((N, cm.m))
        FDD = np.zeros((N, cm.m))
        with np.errstate(all="ignore"):
            for r, f, sc in zip(cm.driver_rows, cm.driver_funcs, cm.driver_scale):
                v, d1, d2 = f.derivatives(t, side) if side else f.derivatives(t)
                # (a constant function's values are scalars: the assignments broadcast them)
                T[:, r] += sc * v
                NU[:, r] = sc * d1
                FDD[:, r] = sc * d2
        return T, NU, FDD

    def driver_third(self, t: np.ndarray, side: int = 0) -> np.ndarray:
        """f''' for every row (N, m), internal units (zero for joints): the exact symbolic third
        derivative of every driver function, side as in driver_values."""
        cm = self.cm
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.shape[0], cm.m))
        with np.errstate(all="ignore"):
            for r, f, sc in zip(cm.driver_rows, cm.driver_funcs, cm.driver_scale):
                out[:, r] = sc * np.broadcast_to(f.third(t, side), t.shape)
        return out

    def _driver_values_joint(self, t: np.ndarray, side: int = 0):
        """driver_values for a model of many drivers (the arch's 98): every driver's f, f' and
        f'' in one evaluation of all their expression trees, which shares the set-up and the
        common subexpressions (sin(2 pi t) once, not 98 times): a fraction of the time per
        call (benchmarks/README.md, "Figures moved from the code's comments"). Values identical
        to the drivers' own derivatives(t, side): at a switch the side-0 average re-evaluates
        every tree from the left, and (a + a) / 2 is a."""
        from planarkin.functions.expr.core import evaluate_all
        cm = self.cm
        t = np.atleast_1d(np.asarray(t, dtype=float))
        N = t.shape[0]
        T = np.empty((N, cm.m))
        T[:] = cm.targets
        NU = np.zeros((N, cm.m))
        FDD = np.zeros((N, cm.m))
        funcs = cm.driver_funcs
        with np.errstate(all="ignore"):
            out = evaluate_all(tuple(e for f in funcs for e in (f.expr, f.first, f.second)),
                            {"t": t}, side)
            for i, (r, sc) in enumerate(zip(cm.driver_rows, cm.driver_scale)):
                T[:, r] = T[:, r] + sc * np.broadcast_to(out[3 * i], (N,))
                NU[:, r] = sc * np.broadcast_to(out[3 * i + 1], (N,))
                FDD[:, r] = sc * np.broadcast_to(out[3 * i + 2], (N,))
        return T, NU, FDD

    # -- dense whole-system view -----------------------------------------------------------------
    def residual(self, Q: np.ndarray, t, T: np.ndarray | None = None) -> np.ndarray:
        """Phi for all m rows: (N, m). Q extended (N, n + 3); T: the targets at t when already
        computed (driver_values), to skip evaluating the driver functions again."""
        F = self.frame(Q)
        if T is None:
            T, _, _ = self.driver_values(np.broadcast_to(t, (Q.shape[0],)))
        out = np.empty((Q.shape[0], self.cm.m))
        for G in self.cm.groups:
            out[:, G.rows.ravel()] = G.g(F).reshape(Q.shape[0], -1)
        return out - T

    def residual_jacobian(self, Q: np.ndarray, T: np.ndarray) -> tuple:
        """(residual(Q, t, T), jacobian(Q)) from one evaluation of each group (g_grad: the
        numbers g and grad give, with the work they share done once), T the targets at t
        (driver_values): a Newton step's."""
        F = self.frame(Q)
        N = Q.shape[0]
        out = np.empty((N, self.cm.m))
        J = np.zeros((N, self.cm.m, self.n + 3))
        for G in self.cm.groups:
            g, grad = G.g_grad(F)
            out[:, G.rows.ravel()] = g.reshape(N, -1)
            J[:, G.rows[:, :, None], G.cols[:, None, :]] = grad
        return out - T, J[:, :, : self.n]

    def jacobian(self, Q: np.ndarray) -> np.ndarray:
        """Phi_q for all m rows: (N, m, n)."""
        F = self.frame(Q)
        N = Q.shape[0]
        J = np.zeros((N, self.cm.m, self.n + 3))
        for G in self.cm.groups:
            # the index arrays broadcast to g's (K, neq, nc) by themselves
            J[:, G.rows[:, :, None], G.cols[:, None, :]] = G.grad(F)
        return J[:, :, : self.n]

    def gamma(self, Q: np.ndarray, Qd: np.ndarray, t) -> np.ndarray:
        F = self.frame(Q, Qd)
        _, _, FDD = self.driver_values(np.broadcast_to(t, (Q.shape[0],)))
        out = np.empty((Q.shape[0], self.cm.m))
        for G in self.cm.groups:
            out[:, G.rows.ravel()] = G.gamma(F).reshape(Q.shape[0], -1)
        return out + FDD

    def jerk(self, Q: np.ndarray, Qd: np.ndarray, Qdd: np.ndarray, t) -> np.ndarray:
        """The jerk right-hand side of all m rows (N, m): jerk_g + f'''."""
        F = Frame(Q, np.cos(Q[:, 2::3]), np.sin(Q[:, 2::3]), Qd, Qdd)
        out = np.empty((Q.shape[0], self.cm.m))
        for G in self.cm.groups:
            out[:, G.rows.ravel()] = G.jerk(F).reshape(Q.shape[0], -1)
        return out + self.driver_third(np.broadcast_to(t, (Q.shape[0],)))

    # -- block structure -----------------------------------------------------------------------
    def build_blocks(self) -> Blocks:
        """Block-triangular form of the active rows (must be square). The sparsity pattern is the
        union of nonzero gradient entries at a few random states (zeros that hold for every state,
        like the phi column of a pin at a body's origin, are structural); it is read per element,
        so it costs O(equations), never a dense m x n matrix. The fine blocks are kept (`fine`);
        solve blocks merge consecutive fine blocks up to ``merge_to`` unknowns."""
        n = self.n
        states = np.stack([self.cm.q0 + noise(n, 1 + k) for k in range(3)])
        F = self.frame(self.ext(states))
        active = np.zeros(self.cm.m, dtype=bool)
        active[self.rows] = True
        pattern: dict[int, list[int]] = {}
        for G in self.cm.groups:
            nz = self.pattern(G, F)                             # (K, neq, nc)
            for k in range(len(G)):
                for e in range(G.kind.neq):
                    r = int(G.rows[k, e])
                    if active[r]:
                        pattern[r] = [int(c) for c, z in zip(G.cols[k], nz[k, e]) if z and c < n]
        pat = [pattern[int(r)] for r in self.rows]
        fine = block_triangular(pat, n, merge_to=1)
        self.fine = Blocks(tuple(self.rows[r] for r in fine.rows), fine.cols)
        self._merge()
        return self.fine

    @staticmethod
    def pattern(G: Group, F: Frame) -> np.ndarray:
        """(K, neq, nc) which gradient entries of group G may be nonzero: those nonzero at one of
        the states F (a few random ones), or all of them for a kind whose zeros are not
        structural (Kind.sampled_zeros)."""
        g = G.grad(F)
        if not G.kind.sampled_zeros:
            return np.ones(g.shape[1:], dtype=bool)
        return (g != 0).any(axis=0)

    def merged(self, merge_to: int) -> "System":
        """The same equations and fine structure, solved in blocks of up to merge_to unknowns."""
        S = System(self.cm, self.rows, merge_to)
        S.fine = self.fine
        S._merge()
        return S

    def _merge(self) -> None:
        groups: list[list[int]] = []
        size = 0
        for k, cols in enumerate(self.fine.cols):
            if groups and size + len(cols) <= self.merge_to:
                groups[-1].append(k)
                size += len(cols)
            else:
                groups.append([k])
                size = len(cols)
        # where each equation lives: row -> (group, instance, equation)
        where = {}
        for gi, G in enumerate(self.cm.groups):
            for k in range(len(G)):
                for e in range(G.kind.neq):
                    where[int(G.rows[k, e])] = (gi, k, e)
        base = _ClassifyState(self)
        blocks = []
        for g in groups:
            rows = np.concatenate([self.fine.rows[k] for k in g])
            cols = np.concatenate([self.fine.cols[k] for k in g])
            B = self._block(rows, cols, tuple(len(self.fine.cols[k]) for k in g), g[0], where)
            blocks.append(base.classify(B))
        self.blocks = tuple(blocks)
        # the fast routes read the model's element groups (cm.groups), not the blocks' parts:
        # a copy whose blocks were replaced (studies.batch: per-row parameters) keeps the
        # reference pass
        self._built = self.blocks
        self.nfine = len(self.fine.cols)

    def _block(self, grows: np.ndarray, cols: np.ndarray, sizes: tuple, first: int,
               where: dict) -> Block:
        rowpos = {r: k for k, r in enumerate(grows.tolist())}
        colpos = {c: k for k, c in enumerate(cols.tolist())}
        kb = len(cols)
        per_group: dict[int, list[int]] = {}
        for r in rowpos:
            gi, k, _ = where[r]
            per_group.setdefault(gi, [])
            if k not in per_group[gi]:
                per_group[gi].append(k)
        parts = []
        for gi in sorted(per_group):
            sub = self.cm.groups[gi].take(sorted(per_group[gi]))
            neq = sub.kind.neq
            nc = sub.cols.shape[1]
            res_src, res_dst, jac_src, jac_dst = [], [], [], []
            for k in range(len(sub)):
                for e in range(neq):
                    r = int(sub.rows[k, e])
                    if r not in rowpos:
                        continue
                    rp = rowpos[r]
                    res_src.append(k * neq + e)
                    res_dst.append(rp)
                    for c in range(nc):
                        col = int(sub.cols[k, c])
                        if col in colpos:
                            jac_src.append((k * neq + e) * nc + c)
                            jac_dst.append(rp * kb + colpos[col])
            parts.append(Part(sub, np.array(res_src, np.intp), np.array(res_dst, np.intp),
                              np.array(jac_src, np.intp), np.array(jac_dst, np.intp)))
        phis = np.array(sorted({c // 3 for c in cols.tolist() if c % 3 == 2}), dtype=np.intp)
        return Block(grows, cols, phis, tuple(parts), sizes, first)

    @staticmethod
    def _rows_of(B: Block, grads):
        """The gradient entries of the block's rows only (an element may have other rows)."""
        out = []
        for p, g in zip(B.parts, grads):
            N, K, neq, nc = g.shape
            out.append(g.reshape(N, K * neq, nc)[:, p.res_src])
        return out

    def fine_signs(self, B: Block, J: np.ndarray, sign: np.ndarray | None = None) -> np.ndarray:
        """(N, len(B.sizes)) determinant signs of the fine diagonal blocks inside solve block B."""
        if len(B.sizes) == 1 and sign is not None:
            return sign[:, None]
        out = np.empty((J.shape[0], len(B.sizes)))
        o = 0
        for k, sz in enumerate(B.sizes):
            sub = J[:, o:o + sz, o:o + sz]
            out[:, k] = np.sign(sub[:, 0, 0] if sz == 1 else np.linalg.det(sub))
            o += sz
        return out

    def point_bytes(self) -> int:
        """Estimated working set of one time point in solve_batch and the grid pass around it,
        bytes: 12 numbers per coordinate and per equation (predictions, Hermite terms, results,
        driver values, residuals, user-unit copies; measured 11 on the 6,003-coordinate chain),
        plus the largest block's factorisation: dense, the matrix, its inverse and the
        elimination's 2 k^2 workspace and copies (8 k^2 numbers); sparse, 32 numbers per entry
        of the block's pattern (its values, the gradients they come from, SuperLU's fill and
        bookkeeping: measured 30 on the 300-coordinate arch, of which SuperLU's objects 9-14)."""
        base = 12 * (self.n + 3 + self.cm.m)
        work = base
        for B in self.blocks or ():
            kb = len(B.cols)
            if self.is_large(B):
                work = max(work, base + 32 * sum(len(p.jac_dst) for p in B.parts))
            else:
                work = max(work, base + 8 * kb * kb)
        return 8 * work

    # -- block evaluations ---------------------------------------------------------------------
    @staticmethod
    def _gather(B: Block, N: int, pieces) -> np.ndarray:
        """Rows of the block from per-part (N, K*neq) arrays."""
        if len(pieces) == 1 and len(B.parts[0].res_src) == len(B.rows) \
                and (B.parts[0].res_dst == np.arange(len(B.rows))).all():
            return pieces[0][:, B.parts[0].res_src]
        out = np.empty((N, len(B.rows)))
        for p, v in zip(B.parts, pieces):
            out[:, p.res_dst] = v[:, p.res_src]
        return out

    def block_residual(self, B: Block, F: Frame, T: np.ndarray) -> np.ndarray:
        N = F.q.shape[0]
        g = self._gather(B, N, [p.group.g(F).reshape(N, -1) for p in B.parts])
        return g - T[:, B.rows]

    def block_grads(self, B: Block, F: Frame):
        return [p.group.grad(F) for p in B.parts]

    def block_residual_grads(self, B: Block, F: Frame, T: np.ndarray):
        """block_residual and block_grads at one state, each part's g and grad in one pass
        (Group.g_grad)."""
        N = F.q.shape[0]
        both = [p.group.g_grad(F) for p in B.parts]
        g = self._gather(B, N, [v.reshape(N, -1) for v, _ in both])
        return g - T[:, B.rows], [d for _, d in both]

    def block_matrix(self, B: Block, grads) -> np.ndarray:
        N = grads[0].shape[0]
        kb = len(B.cols)
        J = np.zeros((N, kb * kb))
        for p, g in zip(B.parts, grads):
            J[:, p.jac_dst] = g.reshape(N, -1)[:, p.jac_src]
        return J.reshape(N, kb, kb)

    @staticmethod
    def is_large(B: Block) -> bool:
        """Factored by sparse LU (an irreducible block of SPARSE_BLOCK unknowns or more)."""
        return len(B.cols) >= SPARSE_BLOCK and len(B.sizes) == 1

    def block_pattern(self, B: Block):
        """The large block's compressed-column pattern, columns in fill-reducing order: (sel,
        indices, indptr, order, order_sign). sel indexes the concatenated per-part gradient
        entries (block_values) in that order; column j of the stored matrix is the block's
        column order[j]; order_sign is the sign of that permutation. The ordering (COLAMD on the
        pattern) is computed once per block here: SuperLU then factors every time point with
        its NATURAL ordering: for the 298-unknown arch a COLAMD pass per point costs more
        than the factorisation itself (benchmarks/README.md, "Large blocks")."""
        key = (B.first, len(B.cols))
        if key not in self._csc:
            from scipy.sparse import csc_matrix
            from scipy.sparse.linalg import splu
            kb = len(B.cols)
            dst = np.concatenate([p.jac_dst for p in B.parts])
            # block_matrix assigns, so of a repeated position the last entry counts
            last = {int(d): i for i, d in enumerate(dst.tolist())}
            keep = np.fromiter(last.values(), dtype=np.intp, count=len(last))
            rows, cols = dst[keep] // kb, dst[keep] % kb
            try:
                lu = splu(csc_matrix((1.5 + noise(len(keep), 7), (rows, cols)), shape=(kb, kb)),
                          permc_spec="COLAMD")
                newpos = np.asarray(lu.perm_c, dtype=np.intp)
            except RuntimeError:                  # singular by accident: keep the order
                newpos = np.arange(kb)
            order = np.argsort(newpos)
            newcol = newpos[cols]
            srt = np.lexsort((rows, newcol))
            indptr = np.concatenate([[0], np.cumsum(np.bincount(newcol, minlength=kb))])
            self._csc[key] = (keep[srt], rows[srt].astype(np.int32), indptr.astype(np.int32),
                              order, permutation_sign(order))
        return self._csc[key]

    def block_values(self, B: Block, grads) -> np.ndarray:
        """(N, nnz) the block matrix's entries in compressed-column order (block_pattern): the
        sparse counterpart of block_matrix, without the dense (N, kb, kb) array."""
        sel = self.block_pattern(B)[0]
        N = grads[0].shape[0]
        vals = np.concatenate([g.reshape(N, -1)[:, p.jac_src] for p, g in zip(B.parts, grads)],
                              axis=1)
        return vals[:, sel]

    def block_lu(self, B: Block, grads, want: bool = True) -> SparseLU:
        _, indices, indptr, order, osign = self.block_pattern(B)
        return SparseLU(self.block_values(B, grads), indices, indptr, order, osign, want)

    def block_product(self, B: Block, grads, Qd: np.ndarray) -> np.ndarray:
        """Rows of Phi_q qdot for the block's equations (all columns, not only the block's)."""
        N = Qd.shape[0]
        return self._gather(B, N, [np.einsum("nkec,nkc->nke", g, Qd[:, p.group.cols])
                                   .reshape(N, -1) for p, g in zip(B.parts, grads)])

    def block_gamma(self, B: Block, F: Frame) -> np.ndarray:
        N = F.q.shape[0]
        return self._gather(B, N, [p.group.gamma(F).reshape(N, -1) for p in B.parts])

    def block_jerk(self, B: Block, F: Frame) -> np.ndarray:
        N = F.q.shape[0]
        return self._gather(B, N, [p.group.jerk(F).reshape(N, -1) for p in B.parts])

    # -- the batched solver ----------------------------------------------------------------------
    def solve_batch(self, t, Q, Qd, Qdd, *, policy="reuse", tol=1e-10, maxit=8, order=2,
                    drivers=None, Qddd=None, third=None, fused=None, compiled=None,
                    predict=None, R=None):
        """Positions, velocities and accelerations (and jerks) at times t, block by block.

        t: (N,); Q, Qd, Qdd: (N, n + 3) predictions (ground columns zero), overwritten in place
        with the solution. policy: 'reuse' (Jacobian factored once, at the prediction), 'full'
        (refactored every iteration) or 'fixed' (exactly maxit iterations, reused Jacobian).
        order: 0 positions only, 1 with velocities, 2 with accelerations, 3 with jerks (into
        Qddd, (N, n + 3), ground columns zero). drivers: the (T, NU, FDD) of driver_values(t)
        when the caller already has them; third: the drivers' f''' (driver_third) likewise.
        fused: False, the reference pass (the numpy solve that defines the results); True or
        None, the compiled route (compiled: the planarkin.solver.compiled.kernel Library a large job took, see
        kernel.route) where it applies (policies reuse and full), else the reference pass; both
        give the same results to rounding.
        Systems whose blocks were replaced after building, and jerks (order 3), take the
        reference pass (route_of says which).
        predict: (t, idx, Tn, Qn, Qdn, Qddn), on the compiled route only: Q is not read but
        written with the Hermite predictions between the path's nodes idx and idx + 1, in the
        kernel's first pass over the points (the grid pass: one pass fewer). R: an (N, m)
        array the compiled route may keep the residuals in (a caller's buffer).
        Returns BatchInfo.
        """
        args = (t, Q, Qd, Qdd, policy, tol, maxit, order, drivers, Qddd, third)
        k = self.route_of(compiled, policy, order, fused)
        if k is not None:
            return self._solve_kernel(k, t, Q, Qd, Qdd, policy, tol, maxit, order, drivers,
                                      predict, R)
        if predict is not None:
            raise ValueError("System.solve_batch: predictions in the solve need the compiled "
                             "route")
        if max(len(B.cols) for B in self.blocks) < PIN_BLAS_FROM:
            return self._solve_batch(*args)
        with one_blas_thread():
            return self._solve_batch(*args)

    def _batch_start(self, t, Q, drivers):
        """What the reference pass starts from: the points, the blocks, the drivers' (T, NU, FDD),
        the angles' cos and sin and their Frame (updated in place as Q moves), and the
        per-point diagnostics (iterations, ratio, converged, fine-block signs, sigma_min)."""
        N = Q.shape[0]
        nblk = len(self.blocks)
        T, NU, FDD = self.driver_values(t) if drivers is None else drivers
        phi = Q[:, 2::3]
        c = np.cos(phi)
        s = np.sin(phi)
        return (N, nblk, T, NU, FDD, c, s, Frame(Q, c, s), np.zeros(N, dtype=np.int64),
                np.zeros(N), np.ones(N, dtype=bool), np.zeros((N, self.nfine)),
                np.zeros((N, nblk)))

    def _solve_batch(self, t, Q, Qd, Qdd, policy, tol, maxit, order, drivers, Qddd=None,
                     third=None):
        N, nblk, T, NU, FDD, c, s, F, iters, ratio, conv, sign, smin = \
            self._batch_start(t, Q, drivers)
        with np.errstate(all="ignore"):
            for b, B in enumerate(self.blocks):
                cols = B.cols
                one = len(cols) == 1           # the common case: a scalar equation
                large = self.is_large(B)
                pcol = 3 * B.phis + 2
                Minv = None
                size = np.zeros(N)
                for it in range(maxit):
                    if Minv is None or (policy == "full" and not B.affine):
                        r, grads0 = self.block_residual_grads(B, F, T)
                        if large:
                            Minv = self.block_lu(B, grads0, want=it == 0)
                            J, sg, sm = None, Minv.sign, Minv.smin
                        else:
                            J = self.block_matrix(B, grads0)
                            Minv, sg, sm = _invert(J, one, want=it == 0)
                        if it == 0:
                            sign[:, B.first:B.first + len(B.sizes)] = self.fine_signs(B, J, sg)
                            smin[:, b] = sm
                    else:
                        r = self.block_residual(B, F, T)
                    dx = _apply(Minv, r, one)
                    Q[:, cols] -= dx
                    if len(pcol):
                        c[:, B.phis] = np.cos(Q[:, pcol])
                        s[:, B.phis] = np.sin(Q[:, pcol])
                    size = np.abs(dx[:, 0]) if one else np.abs(dx).max(axis=1)
                    size[~np.isfinite(size)] = np.inf
                    if it == 0:
                        ratio = np.maximum(ratio, np.where(smin[:, b] > 0, size / smin[:, b],
                                                           np.inf))
                    iters = np.maximum(iters, it + 1)
                    if B.affine and policy != "fixed":
                        size = np.where(np.isfinite(size), 0.0, np.inf)   # one step is exact
                        break
                    if policy != "fixed" and (size <= tol).all():
                        break
                if policy != "fixed":
                    conv &= size <= tol
                else:
                    conv &= np.isfinite(size)
                if order < 1:
                    continue
                # velocities and accelerations: the diagonal block at the converged positions,
                # factored exactly, and the known columns moved to the right-hand side
                if B.fixed_grad and (policy != "full" or B.affine):
                    grads = grads0                 # the same Jacobian as at the prediction
                else:
                    grads = self.block_grads(B, F)
                    if large:
                        Minv = self.block_lu(B, grads, want=False)
                    else:
                        Minv, _, _ = _invert(self.block_matrix(B, grads), one, want=False)
                self._direct(B, grads, Minv, one, NU[:, B.rows], Qd)
                if order < 2:
                    continue
                rhs = self.block_gamma(B, Frame(Q, c, s, Qd)) + FDD[:, B.rows]
                self._direct(B, grads, Minv, one, rhs, Qdd)
                if order < 3:
                    continue
                # jerks: the same factorised block, the right-hand side jerk_g + f'''
                if third is None:
                    third = self.driver_third(t)
                rhs = self.block_jerk(B, Frame(Q, c, s, Qd, Qdd)) + third[:, B.rows]
                self._direct(B, grads, Minv, one, rhs, Qddd)
        return BatchInfo(iters, conv & np.isfinite(Q).all(axis=1), ratio, sign, smin)

    def kernel(self, lib):
        """(lib, packed system) for the compiled route (lib: a planarkin.solver.compiled.kernel Library), or
        None where it does not apply (kernel.pack: kinds or blocks it does not cover)."""
        from planarkin.solver.compiled import kernel
        if lib is None:
            return None
        if "kernel" not in self._csc:      # once per system: a few ms; None: not for the kernel
            self._csc["kernel"] = kernel.pack(self)
        P = self._csc["kernel"]
        return None if P is None else (lib, P)

    def route_of(self, compiled, policy, order, fused=None):
        """(lib, packed system) when solve_batch takes the compiled route (compiled: a
        planarkin.solver.compiled.kernel Library, fused not False, policy reuse or full, order <= 2, the
        blocks as built), else None: the reference pass."""
        if fused is False or compiled is None or policy == "fixed" or order > 2 or \
                self.blocks is not getattr(self, "_built", None):
            return None
        return self.kernel(compiled)

    def _solve_kernel(self, k, t, Q, Qd, Qdd, policy, tol, maxit, order, drivers, predict=None,
                      R=None):
        from planarkin.solver.compiled import kernel
        T, NU, FDD = self.driver_values(t) if drivers is None else drivers
        iters, conv, ratio, sign, smin, R, rmax, cond = kernel.solve(
            k[0], self, k[1], Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order, predict, R)
        return BatchInfo(iters, conv, ratio, sign, smin, R, rmax, cond)

    def _direct(self, B: Block, grads, Minv, one: bool, rhs, X) -> None:
        """Block rows of Phi_q x = rhs solved for the block's columns of X (in place), the other
        columns of X known (earlier blocks)."""
        X[:, B.cols] = 0.0
        r = rhs - self.block_product(B, grads, X)
        X[:, B.cols] = _apply(Minv, r, one, exact=True)


class _ClassifyState:
    """Decides whether a block's equations are affine in its own unknowns (and whether their
    whole gradient ignores them), by comparing gradients at a random state and at the same state
    with only the block's unknowns moved: a generic test, the functions being analytic. The
    random state's frame is computed once for all blocks."""

    def __init__(self, S: "System"):
        self.S = S
        self.Q = S.ext(S.cm.q0 + noise(S.n, 10))
        self.F = S.frame(self.Q)

    def classify(self, B: Block) -> Block:
        from dataclasses import replace
        S = self.S
        if any(not p.group.kind.sampled_zeros for p in B.parts):
            # piecewise geometry (a slot's straight piece, a cam's dwell): affine near one
            # state says nothing of the next piece
            return replace(B, affine=False, fixed_grad=False)
        Q2 = self.Q.copy()
        Q2[0, B.cols] += noise(len(B.cols), 20 + int(B.cols[0]))
        c, s = self.F.c.copy(), self.F.s.copy()
        if len(B.phis):
            c[:, B.phis] = np.cos(Q2[:, 3 * B.phis + 2])
            s[:, B.phis] = np.sin(Q2[:, 3 * B.phis + 2])
        g1 = S.block_grads(B, self.F)
        g2 = S.block_grads(B, Frame(Q2, c, s))
        mat = S.block_values if S.is_large(B) else S.block_matrix
        affine = bool(np.allclose(mat(B, g1), mat(B, g2), rtol=1e-13, atol=1e-13))
        fixed = affine and all(np.allclose(a, b, rtol=1e-13, atol=1e-13)
                               for a, b in zip(S._rows_of(B, g1), S._rows_of(B, g2)))
        return replace(B, affine=affine, fixed_grad=fixed)


class Small2:
    """A batch of 2 x 2 diagonal blocks J (N, 2, 2) in closed form (no batched linalg call: the
    grid chunks' common case, the four-bar's and the Jansen leg's blocks): the entries of the
    inverse (row-major, nan where singular), the determinant's sign (0 where singular) and the
    sigma_min lower bound 1 / ||J^-1||_F = |det| / ||J||_F (0 where singular). The same
    operations in the same order as the compiled route (planarkin.solver.compiled.gen's 1 x 1 and
    2 x 2 blocks)."""

    def __init__(self, J: np.ndarray):
        a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
        self.J = (a, b, c, d)
        self.det = det = a * d - b * c
        ok = np.isfinite(det) & (det != 0)
        inv = 1.0 / np.where(ok, det, np.nan)
        self.inv = (d * inv, -b * inv, -c * inv, a * inv)
        self.sign = np.where(ok, np.sign(det), 0.0)
        self.smin = np.where(ok, np.abs(det) / np.sqrt(a * a + b * b + c * c + d * d), 0.0)

    def newton(self, r: np.ndarray) -> np.ndarray:
        """J^-1 r (N, 2) through the inverse's entries (a Newton correction)."""
        m0, m1, m2, m3 = self.inv
        return np.stack([m0 * r[:, 0] + m1 * r[:, 1], m2 * r[:, 0] + m3 * r[:, 1]], axis=1)

    def solve(self, r: np.ndarray) -> np.ndarray:
        """The solution of J x = r (N, 2) by Cramer's rule: one rounding less than through the
        inverse's entries (the velocity and acceleration systems; tests/test_sketch_exact.py
        holds the Jansen leg's accelerations to 1e-14 of the exact linkage)."""
        a, b, c, d = self.J
        return np.stack([(d * r[:, 0] - b * r[:, 1]) / self.det,
                         (a * r[:, 1] - c * r[:, 0]) / self.det], axis=1)


def _apply(Minv, r: np.ndarray, one: bool, exact: bool = False) -> np.ndarray:
    """The solution of J x = r for each point, from _invert's inverse, a Small2 or a SparseLU;
    exact (the velocity and acceleration systems): a Small2 by Cramer's rule."""
    if one:
        return r * Minv
    if isinstance(Minv, Small2):
        return Minv.solve(r) if exact else Minv.newton(r)
    if isinstance(Minv, SparseLU):
        return Minv.solve(r)
    return matvec(Minv, r)


def _invert(J: np.ndarray, one: bool, want: bool = True):
    """(inverse, det sign, sigma_min lower bound) of a batch of diagonal blocks; for 1x1 blocks
    the inverse is returned as an (N, 1) array, 2x2 blocks as a Small2 (closed form). want
    False (the velocity and acceleration systems, whose sign and sigma_min nobody reads): sign
    and bound are None, and the dense route skips its second factorisation (slogdet) and the
    norms."""
    if one:
        j = J[:, 0, :]
        return 1.0 / j, np.sign(j[:, 0]), np.abs(j[:, 0])
    if J.shape[1] == 2:
        M = Small2(J)
        return M, M.sign, M.smin
    Minv, sg, ok = inv_batched(J, want_sign=want)
    if not want:
        return Minv, None, None
    return Minv, sg, np.where(ok, sigma_min_lower(Minv), 0.0)
