"""What the path follower does when its steps collapse (reference section 7.4): a model with
consistent redundant constraints may switch which rows it leaves out (`reselect`); otherwise the
singular configuration met is classified from the singular vectors of the Jacobian (`classify`:
lock-up of a driver when the joints alone keep full rank, bifurcation when they lose rank, a
driver or joint not defined beyond the last node) and its time extrapolated from sigma_min
(`singular_time`); the near-singular passages it got through become warnings
(`near_singular_warnings`), and so do its loops' passages near a toggle
(planarkin.measures.loops). f: the planarkin.solver.grid.PathFollower (its model, systems, nodes,
options).
"""

from __future__ import annotations

import numpy as np

from .acceptance import COND_WARN, condition
from .assembly import DENSE_LIMIT
from .path import NODE_TOL, Event, path_block
from .system import System


def reselect(f, k: int) -> bool:
    """The equations solved (all but the redundant ones) became singular at node k: if the
    whole set is still regular there, solve from here on with another choice of the rows to
    leave out (the n most independent rows at node k). Returns True when switched."""
    cm, N = f.cm, f.nodes
    if cm.n > DENSE_LIMIT:
        return False
    S_all = System(cm)
    J = S_all.jacobian(S_all.ext(N.q[k][: cm.n]))[0]
    nrm = np.linalg.norm(J, axis=1)
    Jn = J / np.where(nrm > 0, nrm, 1)[:, None]
    sv = np.linalg.svd(Jn, compute_uv=False)
    if len(sv) < cm.n or sv[cm.n - 1] < 1e-4 * sv[0]:
        return False              # singular with every equation: a real singularity
    rows = independent_rows(Jn, cm.n)
    if set(rows.tolist()) == set(f.S.rows.tolist()):
        return False
    from .structure import StructurallySingular
    S = System(cm, np.sort(rows))
    try:
        S.build_blocks()
    except StructurallySingular:
        return False
    Sp = S.merged(path_block(cm.n))
    Q = S.ext(N.q[k][: cm.n])
    Qd = np.zeros_like(Q)
    Qdd = np.zeros_like(Q)
    info = Sp.solve_batch(np.array([N.t[k]]), Q, Qd, Qdd, policy="full", tol=NODE_TOL,
                          maxit=12)
    if not info.converged[0]:
        return False
    old = sorted(set(f.S.rows.tolist()) - set(rows.tolist()))
    new = sorted(set(range(cm.m)) - set(rows.tolist()))
    f.systems.append((S, Sp))
    f.seg = len(f.systems) - 1
    f.S = Sp
    N.add(N.t[k], Q[0], Qd[0], Qdd[0], info.sign[0], condition(info)[0], f.seg)
    f.warnings.append(Event(
        "redundant", N.t[k],
        f"at t = {N.t[k]:.6g} the equations left out as redundant were changed (now "
        f"{'; '.join(cm.row_label[r] for r in new)} instead of "
        f"{'; '.join(cm.row_label[r] for r in old) or 'none'}): the former set became "
        f"singular while the whole mechanism stays regular", cond=float(1 / (sv[cm.n - 1]
                                                                            / sv[0]))))
    return True

def classify(f, k: int) -> Event:
    """Classify why steps collapsed after node k (reference §7.4)."""
    cm, S, N = f.cm, f.S, f.nodes
    t = N.t[k]
    # a driver that is not defined beyond t?
    T, NU, FDD = S.driver_values(np.array([t + 4 * f.h_min]))
    bad = [r for r in cm.driver_rows if not (np.isfinite(T[0, r]) and np.isfinite(NU[0, r])
                                             and np.isfinite(FDD[0, r]))]
    if bad:
        el = cm.element_of_row(bad[0])
        return Event("driver", t, f"{el.label}: f = {el.f.text} or its derivatives are not "
                                  f"finite just after t = {t:.10g}")
    # a joint not defined beyond t (a pin driven past the end of an open curve-slot)?
    dt = max(1e-6 * f.span, 100 * f.h_min)
    ahead = S.residual(S.ext(N.q[k][: S.n] + dt * N.qd[k][: S.n]), t + dt)[0]
    lost = [r for r in S.rows if not np.isfinite(ahead[r]) and r < cm.m_joint]
    if lost and np.isfinite(N.q[k]).all():
        el = cm.element_of_row(lost[0])
        return Event("failure", t, f"{el.label} is not defined just after t = {t:.10g}"
                                   + (": the pin leaves the open curve at its end"
                                      if el.kind == "curve-slot" else ""))
    Q = S.ext(N.q[k][: S.n])
    if S.n > DENSE_LIMIT:
        # too large for a dense SVD: classify within the worst-conditioned solve block
        F = S.frame(Q)
        mats = [S.block_matrix(B, S.block_grads(B, F))[0] for B in S.blocks]
        b = int(np.argmin([np.linalg.svd(M, compute_uv=False)[-1] for M in mats]))
        J = np.zeros((len(S.blocks[b].rows), S.n))
        J[:, S.blocks[b].cols] = mats[b]
        rows_of = S.blocks[b].rows
    else:
        J = S.jacobian(Q)[0][S.rows]
        rows_of = S.rows
    nrm = np.linalg.norm(J, axis=1)
    Jn = J / np.where(nrm > 0, nrm, 1)[:, None]
    U, sv, Vt = np.linalg.svd(Jn, full_matrices=False)
    srel = sv[-1] / sv[0]
    cond = 1.0 / max(srel, 1e-300)
    if srel > 1e-4:
        return Event("failure", t,
                     f"the path cannot be continued after t = {t:.10g} although the "
                     f"Jacobian is regular (condition {cond:.3g}): the motion is not smooth "
                     f"there (a kink or jump in a driver function?)", cond=cond)
    u = np.abs(U[:, -1])
    big = [i for i in np.argsort(-u) if u[i] >= 0.3 * u.max()]
    rows = rows_of[np.array(big, dtype=np.intp)]
    labels = list(dict.fromkeys(cm.element_of_row(r).label for r in rows))[:5]
    v = np.abs(Vt[-1])
    per_body = v.reshape(-1, 3).max(axis=1)
    bodies = [cm.body_names[b] for b in np.nonzero(per_body >= 0.3 * per_body.max())[0]]
    kin = rows_of < cm.m_joint
    skrel = 1.0
    if kin.any():
        svk = np.linalg.svd(Jn[kin], compute_uv=False)
        kmin = svk[min(int(kin.sum()), Jn.shape[1]) - 1] if len(svk) else 1.0
        skrel = kmin / svk[0]
    unit = "s"
    if skrel < 1e-4:
        kind = "bifurcation"
        what = ("bifurcation of the mechanism (change point): the joints themselves become "
                "dependent and assembly branches cross")
        fix = ("; to follow the smooth branch through it, set analysis: {bifurcation: "
               "continue} (or --bifurcation continue)")
    else:
        kind = "lock-up"
        drv = [cm.element_of_row(r).label for r in rows if r >= cm.m_joint] or \
              [cm.element_of_row(r).label for r in cm.driver_rows]
        what = (f"lock-up of {', '.join(dict.fromkeys(drv))} (toggle / dead centre): the "
                f"mechanism cannot move the way the driver demands")
        fix = "; drive another link or limit the driver's range"
    ts = singular_time(f, k, kind)
    msg = (f"singular configuration at t = {ts:.10g} {unit}: {what}; constraints involved: "
           f"{'; '.join(labels)}; bodies: {', '.join(bodies)}; results are written up to "
           f"t = {t:.10g}{fix}")
    return Event(kind, ts, msg, cond=cond, constraints=labels, bodies=bodies)

def singular_time(f, k: int, kind: str) -> float:
    """Where sigma_min reaches zero, extrapolated from the last nodes: sigma_min is linear in
    time through a transversal crossing (bifurcation) and goes like the square root of the
    remaining time at a fold (lock-up)."""
    N = f.nodes
    tk, sk = N.t[k], 1.0 / N.cond[k]
    for j in range(k - 1, max(k - 30, -1), -1):
        sj = 1.0 / N.cond[j]
        if sj >= 2 * sk and N.t[j] < tk:
            p = 1 if kind == "bifurcation" else 2
            dt = (tk - N.t[j]) * sk ** p / (sj ** p - sk ** p)
            return tk + min(max(dt, 0.0), tk - N.t[j])
    return tk


def independent_rows(Jn: np.ndarray, n: int) -> np.ndarray:
    """n rows of a full-column-rank Jn chosen greedily by largest remaining norm (pivoted
    Gram-Schmidt): the best-conditioned square subsystem a greedy choice finds."""
    R = Jn.copy()
    chosen = []
    for _ in range(n):
        norms = np.linalg.norm(R, axis=1)
        norms[chosen] = -1
        i = int(np.argmax(norms))
        chosen.append(i)
        v = R[i] / norms[i]
        R -= np.outer(R @ v, v)
    return np.array(chosen, dtype=np.intp)


def near_singular_warnings(f, threshold: float = COND_WARN) -> None:
    """Local maxima of the condition estimate above threshold that the path got through, as
    warnings of the path follower f; then its four-bar and slider-crank loops' figures (f.loops)
    and their near-toggle passages (planarkin.measures.loops)."""
    _near_singular(f, threshold)
    try:
        from planarkin.derived import path_figures
        path_figures(f)
    except Exception as e:  # noqa: BLE001 - the figures are an extra: never lose the run to them
        f.loops = None
        f.warnings.append(Event("loops", float(f.nodes.t[-1]) if len(f.nodes) else 0.0,
                                f"the loops' transmission angles were not computed: "
                                f"{type(e).__name__}: {e} (please report)"))


def _near_singular(f, threshold: float) -> None:
    c = np.array(f.nodes.cond)
    t = np.array(f.nodes.t)
    if len(c) < 3:
        return
    stop_t = f.event.t if f.event else None
    peaks = [i for i in range(1, len(c) - 1) if c[i] >= c[i - 1] and c[i] >= c[i + 1]
             and c[i] > threshold]
    for i in peaks:
        if stop_t is not None and abs(t[i] - stop_t) < 1e-6 * f.span:
            continue
        f.warnings.append(Event(
            "near-singular", float(t[i]),
            f"near-singular configuration passed at t = {t[i]:.6g} (condition estimate "
            f"{c[i]:.3g}): the assembly branches come close here; results were followed "
            f"with smaller internal steps" + forces_note(f.cm), cond=float(c[i])))


def forces_note(cm) -> str:
    """The warning's sentence for models whose forces are computed (planarkin.forces)."""
    from planarkin.forces.model import has_forces
    return ("; joint reactions and driver efforts grow without bound near such a configuration "
            "(forces.csv)") if has_forces(cm) else ""
