"""When a solved point is taken: the one step-acceptance rule and its bounds.

A point solved by Newton from a prediction (a path step's candidate, a grid point, a warm start's
corrected node, a design study's row) is accepted as a step of the path only when

* Newton converged (for the 'fixed' policy: a set number of iterations, finite results);
* its first correction is at most KAPPA of the smallest singular value's lower bound of every
  block (a Kantorovich-style radius: Newton cannot have reached another root from there);
* its positions, velocities and accelerations (those given) are finite;
* its condition estimate is at most the bound given: COND_SINGULAR where the path follower
  can report what it passes, COND_WARN where no follower runs (a warm start, a study's rows:
  a near-singular passage then takes the follower, which warns);
* the determinant sign of every fine diagonal block is the expected one (the same assembly
  branch: crossing to another flips a sign);

and, between consecutive points of a path, the Taylor predictor error forwards and backwards
(`taylor_error`) is within path_tol. The path follower, the grid pass, studies.warm and
studies.batch all call `accepted` and `taylor_error`; the compiled route's
planarkin.solver.compiled.helpers.accept_point takes the same bounds from here.
"""

from __future__ import annotations

import numpy as np

from .linalg import rowmax

KAPPA = 0.25          # accepted first Newton correction, as a fraction of sigma_min
# Past this condition estimate the path is taken to be at a singular configuration: there
# velocities lose ~6 digits and accelerations (error ~ cond^2 eps) are no longer meaningful, so
# neither are the predictions built from them.
COND_SINGULAR = 1e6
COND_WARN = 1e3       # near-singular passages above this are reported
# points from which a row's largest value is taken column by column (linalg.rowmax: a grid
# chunk's or a study's many rows); a path step's few candidates take numpy's reductions
ROWMAX_FROM = 256


def condition(info) -> np.ndarray:
    """Per-point condition estimate: the worst diagonal block's 1/sigma_min bound (the blocks
    are scaled, so their norms are of order one); the compiled route computes it with the
    solve (BatchInfo.cond)."""
    if info.cond is not None:
        return info.cond
    with np.errstate(divide="ignore"):
        return 1.0 / np.maximum(-_rowmax(-info.smin), 1e-300)


def accepted(info, sign=None, arrays=(), *, cond_max: float = COND_SINGULAR,
             converged: bool = True) -> np.ndarray:
    """(N,) which points of a solve (its BatchInfo) pass the rule above: converged (converged
    False: the 'fixed' policy, finite positions only), first correction within KAPPA,
    every array of arrays ((N, k) each) finite, condition at most cond_max, fine-block signs
    equal to sign ((N, nfine) or (nfine,); None: not compared)."""
    ok = info.ratio <= KAPPA
    if converged:
        ok &= info.converged
    big = len(ok) >= ROWMAX_FROM
    for a in arrays:
        ok &= np.isfinite(rowmax(np.abs(a))) if big else np.isfinite(a).all(axis=1)
    if cond_max < np.inf:
        ok &= condition(info) <= cond_max
    if sign is not None:
        ok &= rowmax(np.abs(info.sign - sign)) == 0 if big else (info.sign == sign).all(axis=1)
    return ok


def _rowmax(a: np.ndarray) -> np.ndarray:
    """a.max(axis=1): for the few points of a path step directly (one call), for a grid's or a
    study's many rows column by column (linalg.rowmax, several times faster there)."""
    return rowmax(a) if len(a) >= ROWMAX_FROM else a.max(axis=1)



def taylor_error(h, q0, qd0, qdd0, j3, q1, qd1, qdd1, pred=None) -> np.ndarray:
    """The path follower's step error of steps h ((M, 1)) from states q0, qd0, qdd0 (with the
    jerk estimate j3 from the step before, zero for none; (M, n) or (n,) each) to the solved
    q1, qd1, qdd1 ((M, n) each): the larger of the Taylor predictor's error forwards and of
    the backward prediction of q0 from q1, whose jerk is the step's own change of
    acceleration. pred: the forward prediction when the caller has it (the path's Newton
    start, these operations). Returns (M,), the largest over the n columns."""
    hh = 0.5 * h * h
    h3 = h ** 3 / 6.0
    ef = np.abs(q1 - (q0 + h * qd0 + hh * qdd0 + h3 * j3 if pred is None else pred))
    eb = np.abs(q1 - h * qd1 + hh * qdd1 - h3 * ((qdd1 - qdd0) / h) - q0)
    return np.maximum(_rowmax(ef), _rowmax(eb))


def path_errors(T, Q, Qd, Qdd, n) -> np.ndarray:
    """(..., K-1) taylor_error of every interval of paths at times T (K,): Q, Qd, Qdd (..., K,
    n + 3) (one path, or many variants' on the same times), the first n columns compared; the
    first interval has no jerk estimate, every other the change of acceleration over the
    interval before."""
    Q, Qd, Qdd = Q[..., :n], Qd[..., :n], Qdd[..., :n]
    lead = Q.shape[:-2]
    K = Q.shape[-2]
    h = np.diff(T)[:, None]
    j3 = np.zeros_like(Q[..., 1:, :])
    j3[..., 1:, :] = (Qdd[..., 1:-1, :] - Qdd[..., :-2, :]) / h[:-1]
    flat = lambda a: a.reshape(-1, n)       # noqa: E731 - (paths x intervals, n)
    hs = np.broadcast_to(h, lead + (K - 1, 1)).reshape(-1, 1)
    err = taylor_error(hs, flat(Q[..., :-1, :]), flat(Qd[..., :-1, :]), flat(Qdd[..., :-1, :]),
                       flat(j3), flat(Q[..., 1:, :]), flat(Qd[..., 1:, :]),
                       flat(Qdd[..., 1:, :]))
    return err.reshape(lead + (K - 1,))
