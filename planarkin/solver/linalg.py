"""Batched small dense linear algebra: many k-by-k systems at once (one per time point).

The block-triangular solver (`planarkin.solver.system`) factors one small diagonal block per time point;
with thousands of time points per call a Python loop is out of the question, and numpy's stacked
``linalg.inv`` has a cost per matrix for k = 4..9 that adds up over them (measured while writing
this module: benchmarks/README.md, "Figures moved from the code's comments"). Gauss-Jordan
elimination with partial pivoting written over the batch axis (structure of arrays: every matrix
entry is a contiguous vector over the batch) does the same work in a handful of large numpy calls
and also yields what the solver monitors: the sign of the determinant (branch tracking) and the
norms for a condition estimate.
"""

from __future__ import annotations

import sys

import numpy as np

# Below this batch size numpy's LAPACK loop is faster than our vectorised elimination.
_SMALL_BATCH = 48
# Above this size LAPACK's loop wins again (benchmarks/bench_blocks.py; the figures:
# benchmarks/README.md, "Figures behind the code's limits").
_GJ_MAX_K = 5


def inv_batched(J: np.ndarray, want_sign: bool = True):
    """Invert a stack of matrices.

    J: (N, k, k). Returns (Jinv (N, k, k), detsign (N,) in {-1, 0, +1}, ok (N,) bool).
    Where a matrix is numerically singular (a zero pivot), ok is False, detsign is 0 and that
    Jinv holds nan; the other matrices are unaffected. want_sign False: detsign is not computed
    (zeros) where that costs a second factorisation (numpy's LAPACK route: slogdet is a quarter
    of inv + slogdet from k = 6 to 80, benchmarks/bench_blocks.py --medium).
    """
    N, k, _ = J.shape
    if N == 0:
        return np.empty_like(J), np.zeros(0), np.zeros(0, bool)
    if N < _SMALL_BATCH or k > _GJ_MAX_K:
        return _inv_lapack(J) if want_sign else _inv_only(J)
    return _inv_gauss_jordan(J)


def _inv_only(J):
    """_inv_lapack without the determinant: numpy's stacked inverse, which refuses the whole
    stack when one matrix is exactly singular (then matrix by matrix)."""
    N = J.shape[0]
    if np.isfinite(J).all():
        try:
            out = np.linalg.inv(J)
        except np.linalg.LinAlgError:
            pass
        else:
            ok = np.isfinite(out).all(axis=(1, 2))
            if not ok.all():
                out[~ok] = np.nan
            return out, np.zeros(N), ok
    out, _, ok = _inv_lapack(J)
    return out, np.zeros(N), ok


def _inv_lapack(J):
    N, k, _ = J.shape
    sign, logdet = np.linalg.slogdet(J)
    ok = np.isfinite(logdet) & (sign != 0)
    out = np.full_like(J, np.nan)
    if ok.all():
        out = np.linalg.inv(J)
    else:
        for n in np.nonzero(ok)[0]:
            out[n] = np.linalg.inv(J[n])
        sign = np.where(ok, sign, 0.0)
    # singular in floating point but with a tiny nonzero determinant: still flagged by callers
    # through the condition estimate
    return out, sign, ok


def _inv_gauss_jordan(J):
    N, k, _ = J.shape
    A = np.empty((k, 2 * k, N))
    A[:, :k, :] = J.transpose(1, 2, 0)
    A[:, k:, :] = np.eye(k)[:, :, None]
    sign = np.ones(N)
    ok = np.ones(N, dtype=bool)
    scale = np.abs(J).max(axis=(1, 2))
    tiny = np.where(scale > 0, scale, 1.0) * 1e-300
    for c in range(k):
        if c < k - 1:
            p = np.abs(A[c:, c, :]).argmax(axis=0) + c
            idx = np.nonzero(p != c)[0]
            if idx.size:
                pr = p[idx]
                tmp = A[c, :, idx].copy()
                A[c, :, idx] = A[pr, :, idx]
                A[pr, :, idx] = tmp
                sign[idx] = -sign[idx]
        piv = A[c, c, :].copy()
        bad = ~(np.abs(piv) > tiny)
        if bad.any():
            ok &= ~bad
            piv[bad] = 1.0
        sign *= np.sign(piv)
        A[c] /= piv
        f = A[:, c, :].copy()
        f[c] = 0.0
        A -= f[:, None, :] * A[c][None, :, :]
    out = np.ascontiguousarray(A[:, k:, :].transpose(2, 0, 1))
    if not ok.all():
        out[~ok] = np.nan
        sign[~ok] = 0.0
    return out, sign, ok


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


def matvec(M: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(N, k, k) @ (N, k) -> (N, k)."""
    return np.einsum("nij,nj->ni", M, x)


def sigma_min_lower(Minv: np.ndarray) -> np.ndarray:
    """(N,) lower bound of the smallest singular value: 1/||J^-1||_F <= sigma_min(J)."""
    return 1.0 / np.sqrt(np.einsum("nij,nij->n", Minv, Minv))


def cond_1(J: np.ndarray, Minv: np.ndarray) -> np.ndarray:
    """(N,) 1-norm condition number ||J||_1 ||J^-1||_1 from the explicit inverse."""
    return np.abs(J).sum(axis=1).max(axis=1) * np.abs(Minv).sum(axis=1).max(axis=1)


def noise(n: int, seed: int) -> np.ndarray:
    """n deterministic pseudo-random numbers in (-1, 1): generic states for structural tests.
    (importing numpy.random costs start-up; these tests only need values with no special
    relation between them.)"""
    k = np.arange(1, n + 1, dtype=float)
    return np.sin(k * 12.9898 + seed * 78.233) * 43758.5453 % 2.0 - 1.0


# -- large blocks: one sparse LU per matrix -------------------------------------------------------

class SparseLU:
    """Sparse LU factorisations (SuperLU, via scipy.sparse.linalg.splu) of a batch of k x k
    matrices that share one sparsity pattern: the large irreducible blocks of a mechanism whose
    constraint graph does not split (an arch, a truss), where a dense k x k inverse per time
    point costs k^3 time and k^2 memory and a sparse factorisation costs about its fill.

    values: (N, nnz) the entries in compressed-column order of the pattern (indices, indptr),
    whose column j is column order[j] of the matrix (a fill-reducing order chosen once per
    pattern; order_sign: its sign), factored without further column ordering. want: also compute the determinant signs and the sigma_min bounds (at the first Newton
    iterate only; the factorisations for the velocity systems need neither).
    Attributes: sign (N,) in {-1, 0, +1}; smin (N,) an estimate of sigma_min, 1 / ||J^-1||_1
    (0 where singular); ok (N,) bool. scipy is imported here only: small models never pay its start-up.
    """

    def __init__(self, values: np.ndarray, indices: np.ndarray, indptr: np.ndarray,
                 order: np.ndarray, order_sign: float = 1.0, want: bool = True):
        from scipy.sparse import csc_matrix
        from scipy.sparse.linalg import splu
        values = np.ascontiguousarray(values)       # each point's entries one C vector
        N = values.shape[0]
        k = len(order)
        self.k = k
        self.order = order
        self.lus: list = [None] * N
        self.sign = np.zeros(N)
        self.smin = np.zeros(N)
        self.ok = np.zeros(N, dtype=bool)
        finite = np.isfinite(values).all(axis=1)
        parity: dict[bytes, float] = {}
        # one matrix object, its entries replaced per point: building a csc_matrix checks its
        # indices every time, which costs as much as factoring a mid-sized block
        A = csc_matrix((np.zeros(values.shape[1]), indices, indptr), shape=(k, k))
        for n in range(N):
            if not finite[n]:
                continue
            A.data = values[n]
            try:
                lu = splu(A, permc_spec="NATURAL")
            except RuntimeError:            # exactly singular
                continue
            self.lus[n] = lu
            self.ok[n] = True
            if want:
                d = lu.U.diagonal()
                sg = float(np.prod(np.sign(d)))
                sg *= _parity(lu.perm_r, parity) * _parity(lu.perm_c, parity) * order_sign
                self.sign[n] = sg
                inv1 = _inv_norm1_estimate(lu, k)
                # 1 / ||J^-1||_1: an estimate of sigma_min, not a bound as the dense blocks'
                # 1 / ||J^-1||_F (that needs the inverse); ||J^-1||_1 and ||J^-1||_F lie within
                # sqrt(k) of each other, and within a factor 2 on the arch and the ladder of
                # benchmarks/bigmodels.py, so the condition thresholds keep their meaning
                self.smin[n] = 1.0 / inv1 if inv1 > 0 else 0.0
                if not (np.isfinite(self.smin[n]) and sg != 0):
                    self.ok[n] = False
                    self.sign[n] = 0.0
                    self.smin[n] = 0.0

    def solve(self, R: np.ndarray) -> np.ndarray:
        """(N, k) right-hand sides -> (N, k) solutions (nan where the matrix was singular)."""
        out = np.full(R.shape, np.nan)
        order = self.order
        for n, lu in enumerate(self.lus):
            if lu is not None:
                out[n, order] = lu.solve(R[n])
        return out


def _parity(p: np.ndarray, cache: dict) -> float:
    """permutation_sign, remembered per permutation (pivoting rarely changes along a path)."""
    key = p.tobytes()
    if key not in cache:
        cache[key] = permutation_sign(p)
    return cache[key]


def permutation_sign(p: np.ndarray) -> float:
    """Sign (+1 / -1) of the permutation p: (-1)^(k - number of cycles)."""
    seen = np.zeros(len(p), dtype=bool)
    pl = p.tolist()
    cycles = 0
    for i in range(len(pl)):
        if not seen[i]:
            cycles += 1
            j = i
            while not seen[j]:
                seen[j] = True
                j = pl[j]
    return -1.0 if (len(pl) - cycles) % 2 else 1.0


def _inv_norm1_estimate(lu, k: int, maxit: int = 3) -> float:
    """Hager's estimate (Higham's refinement, as LAPACK's dlacon) of ||A^-1||_1 from the LU
    factors: a few solves with A and A^T, a lower bound of the true norm that is exact in most
    cases."""
    x = np.full(k, 1.0 / k)
    # Higham's alternative vector guards against the estimator's known bad cases; it is solved
    # with the first iterate, in one call (a two-column solve costs about one: SuperLU's
    # per-call overhead dominates at these sizes)
    b = np.where(np.arange(k) % 2, -1.0, 1.0) * (1.0 + np.arange(k) / max(k - 1, 1))
    yb = lu.solve(np.stack([x, b], axis=1))
    alt = 2.0 * np.abs(yb[:, 1]).sum() / (3.0 * k)
    est = 0.0
    j_old = -1
    for it in range(maxit):
        y = yb[:, 0] if it == 0 else lu.solve(x)
        est_new = np.abs(y).sum()
        if not np.isfinite(est_new):
            return np.inf
        if it > 0 and est_new <= est:
            break
        est = est_new
        z = lu.solve(np.where(y >= 0, 1.0, -1.0), trans="T")
        j = int(np.argmax(np.abs(z)))
        if it > 0 and (j == j_old or np.abs(z[j]) <= z @ x):
            break
        x = np.zeros(k)
        x[j] = 1.0
        j_old = j
    return max(est, alt)


# -- BLAS threads ---------------------------------------------------------------------------------

_blas_cache: list = [-1, None]        # [len(sys.modules) when scanned, ThreadpoolController]


def blas_controller():
    """threadpoolctl's controller of every BLAS loaded in this process (numpy's and, once
    imported, scipy's OpenBLAS); rescanned only when modules were imported since (a scan
    costs far more than pinning through the controller)."""
    if _blas_cache[0] != len(sys.modules):
        from threadpoolctl import ThreadpoolController      # small models never import it
        _blas_cache[:] = [len(sys.modules), ThreadpoolController().select(user_api="blas")]
    return _blas_cache[1]


class one_blas_thread:
    """Context: the BLAS libraries run on one thread inside (restored on exit). The solver's
    linear algebra is many small factorisations; with the threads of OpenBLAS spinning on a core
    that another process holds, the same run took many times longer (issue 12;
    benchmarks/README.md, "Figures moved from the code's comments"). An environment variable
    would have to be set before numpy loads, which a library called from someone's program
    cannot do: threadpoolctl sets the libraries' own thread counts."""

    def __enter__(self):
        self.limiter = blas_controller().limit(limits=1)
        return self

    def __exit__(self, *exc):
        self.limiter.restore_original_limits()
        return False
