"""Batched small dense linear algebra: many k-by-k systems at once (one per time point).

The block-triangular solver (`planarkin.system`) factors one small diagonal block per time point;
with thousands of time points per call a Python loop is out of the question, and numpy's stacked
``linalg.inv`` costs 0.5-2.5 us per matrix for k = 4..9 (measured on 100,000 random matrices
while writing this module). Gauss-Jordan
elimination with partial pivoting written over the batch axis (structure of arrays: every matrix
entry is a contiguous vector over the batch) does the same work in a handful of large numpy calls
and also yields what the solver monitors: the sign of the determinant (branch tracking) and the
norms for a condition estimate.
"""

from __future__ import annotations

import numpy as np

# Below this batch size numpy's LAPACK loop is faster than our vectorised elimination.
_SMALL_BATCH = 48
# Above this size LAPACK's loop wins again (measured at 4096 matrices per call: k = 4 takes
# 0.31 us per matrix here against 0.49 us, k = 6 about 1.0 us for both).
_GJ_MAX_K = 5


def inv_batched(J: np.ndarray):
    """Invert a stack of matrices.

    J: (N, k, k). Returns (Jinv (N, k, k), detsign (N,) in {-1, 0, +1}, ok (N,) bool).
    Where a matrix is numerically singular (a zero pivot), ok is False, detsign is 0 and that
    Jinv holds nan; the other matrices are unaffected.
    """
    N, k, _ = J.shape
    if N == 0:
        return np.empty_like(J), np.zeros(0), np.zeros(0, bool)
    if N < _SMALL_BATCH or k > _GJ_MAX_K:
        return _inv_lapack(J)
    return _inv_gauss_jordan(J)


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
    (numpy.random costs 15 ms of start-up; these tests only need values with no special
    relation between them.)"""
    k = np.arange(1, n + 1, dtype=float)
    return np.sin(k * 12.9898 + seed * 78.233) * 43758.5453 % 2.0 - 1.0
