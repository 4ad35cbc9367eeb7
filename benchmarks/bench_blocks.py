"""Dense batched inverses against one sparse LU per point, by block size (system.SPARSE_BLOCK).

    python benchmarks/bench_blocks.py [--points 1000] [--sizes 10 16 22 30 50 100]

For arches of N links (one irreducible block of 3 N - 2 unknowns, benchmarks/bigmodels.py) the
block matrix at --points perturbed poses is factored both ways, on one BLAS thread:

* dense: planarkin.solver.linalg.inv_batched (Gauss-Jordan over the batch up to k = 5, else numpy's
  stacked LAPACK inverse plus slogdet for the sign), then one solve (a matrix-vector product);
* sparse: planarkin.solver.linalg.SparseLU (SuperLU with the block's column order computed once, the
  sign from the pivots, Hager's 1-norm estimate for sigma_min), then one solve.

Printed: CPU microseconds per point of each (best of 3) and the dense / sparse ratio; the
crossover decides SPARSE_BLOCK.

    python benchmarks/bench_blocks.py --medium [--points 1000] [--k 4 6 8 12 ...]

The medium dense blocks' candidates for "one LU per block and point" (issue 12), on --points
random well-conditioned k x k matrices, one BLAS thread, CPU microseconds per matrix: numpy's
stacked inv + slogdet (what the solver does where it needs the determinant's sign), inv alone
(the velocity systems: no sign needed), linalg's Gauss-Jordan over the batch (inverse and sign
from one elimination; up to k = 24, it is memory-bound beyond), SciPy's LAPACK getrf + getri in
a Python loop (one LU per point, the sign from its pivots, the inverse from the same LU) and
SciPy's batched lu_factor + lu_solve of the identity.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import bigmodels  # noqa: E402
import common  # noqa: E402
import numpy as np  # noqa: E402

import planarkin  # noqa: E402
from planarkin.solver import linalg  # noqa: E402
from planarkin.solver.assembly import assemble  # noqa: E402


def best_cpu(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        c0 = time.process_time()
        fn()
        best = min(best, time.process_time() - c0)
    return best


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 16, 22, 30, 50, 100])
    ap.add_argument("--medium", action="store_true", help="the dense candidates by k")
    ap.add_argument("--k", type=int, nargs="+", default=[4, 6, 8, 12, 16, 24, 32, 48, 64, 80])
    a = ap.parse_args(argv)
    common.print_header(common.machine_info(), "planarkin block factorisation benchmark")
    if a.medium:
        return medium(a.points, a.k)
    print(f"{'links':>6s} {'k':>5s} {'dense us/pt':>12s} {'sparse us/pt':>13s} {'dense/sparse':>13s}")
    for N in a.sizes:
        cm = planarkin.load("arch.yaml", text=bigmodels.arch_yaml(N))
        A = assemble(cm)
        S = A.system
        B = max(S.blocks, key=lambda b: len(b.cols))
        k = len(B.cols)
        P = a.points
        Q = np.repeat(S.ext(A.q[None]), P, axis=0)
        Q[:, B.cols] += 1e-3 * linalg.noise(P * k, 5).reshape(P, k)
        grads = S.block_grads(B, S.frame(Q))
        r = linalg.noise(P * k, 9).reshape(P, k)

        def dense():
            J = S.block_matrix(B, grads)
            Minv, sg, ok = linalg.inv_batched(J)
            linalg.sigma_min_lower(Minv)
            return linalg.matvec(Minv, r)

        def sparse():
            return S.block_lu(B, grads).solve(r)

        with linalg.one_blas_thread():
            x1, x2 = dense(), sparse()
            assert np.allclose(x1, x2, rtol=1e-8, atol=1e-10)
            td = best_cpu(dense) if k <= 400 else np.nan
            ts = best_cpu(sparse)
        print(f"{N:6d} {k:5d} {td / P * 1e6:12.1f} {ts / P * 1e6:13.1f} {td / ts:13.2f}",
              flush=True)


def medium(P, sizes):
    import scipy.linalg as sl
    from scipy.linalg import lapack
    print(f"{'k':>4s} {'inv+slogdet':>12s} {'inv':>8s} {'GJ':>8s} {'getrf+getri':>12s} "
          f"{'lu_factor+solve':>16s}   us per matrix")
    for k in sizes:
        J = 3 * np.eye(k)[None] + linalg.noise(P * k * k, k).reshape(P, k, k)
        eye = np.broadcast_to(np.eye(k), J.shape)

        def loop():
            out = np.empty_like(J)
            sign = np.empty(P)
            for n in range(P):
                lu, piv, _ = lapack.dgetrf(J[n])
                sign[n] = np.prod(np.sign(lu.diagonal())) * (
                    -1.0 if np.count_nonzero(piv != np.arange(k)) % 2 else 1.0)
                out[n], _ = lapack.dgetri(lu, piv)
            return out, sign

        with linalg.one_blas_thread():
            t = [best_cpu(lambda: (np.linalg.slogdet(J), np.linalg.inv(J))),
                 best_cpu(lambda: np.linalg.inv(J)),
                 best_cpu(lambda: linalg._inv_gauss_jordan(J)) if k <= 24 else np.nan,
                 best_cpu(loop),
                 best_cpu(lambda: sl.lu_solve(sl.lu_factor(J, check_finite=False), eye,
                                              check_finite=False))]
        t = [x / P * 1e6 for x in t]
        print(f"{k:4d} {t[0]:12.1f} {t[1]:8.1f} {t[2]:8.1f} {t[3]:12.1f} {t[4]:16.1f}",
              flush=True)


if __name__ == "__main__":
    main()
