"""Assembly at t = start, and the checks that decide whether a model can be analysed at all.

1. Damped Gauss-Newton (Levenberg-Marquardt) from the user's rough estimates, polished by
   Newton-Raphson to rounding error (reference §7.2).
2. Counting and rank (reference §7.4): the scaled Jacobian's rank at the assembled pose gives the
   free degrees of freedom and the redundant equations (a row that depends on earlier rows, file
   order, drivers last). Free DOF, an over-driven mechanism, contradicting redundant constraints
   and a pose that cannot be assembled are input errors (exit 2) that name the elements; a
   consistent redundancy (a parallelogram with a third crank) is removed from the solve with a
   warning and watched at every step.
3. Assembly mode: the sign of each diagonal block's determinant (a dyad's elbow, a loop's open or
   crossed form). `assembly: {branch: {body: +|-}}` in the model asks for the other sign.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import contextlib
from dataclasses import dataclass, field

import numpy as np

from planarkin.diagnostics import Diagnostic, InputError
from planarkin.elements import KINDS
from .closure import short_loops
from .linalg import one_blas_thread
from .meshing import centre_distances
from .system import PIN_BLAS_FROM, System
from .branches import apply_branch_hints, block_modes, fmt_res, diag
from .tolerances import ASSEMBLED

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel

RANK_TOL = 1e-8          # relative singular value / R diagonal below which a direction is lost
DENSE_LIMIT = 3000       # largest n for dense SVD / QR
# From this many coordinates a square model is first assembled block by block (Newton on each
# diagonal block, as above DENSE_LIMIT) and the dense checks (Levenberg-Marquardt, two SVDs,
# least squares on the whole m x n Jacobian: most of a large arch's assembly, bench_big.py) run
# only when that does not settle the model clearly: every block regular with sigma_min at
# least BLOCKS_CLEAR (a hundred times RANK_TOL), converged to ASSEMBLED. A square Jacobian with
# regular diagonal blocks has full rank, so the dense rank analysis could only confirm it.
SPARSE_ASSEMBLY = 1000
BLOCKS_CLEAR = 1e-6


@dataclass
class Assembly:
    q: np.ndarray                   # (n,) assembled pose, internal units
    residual: float                 # max |Phi| over all rows at q (internal units)
    iterations: int
    active_rows: np.ndarray         # rows kept for the solve
    redundant_rows: list            # consistent redundant rows removed (watched during the run)
    dof: int                        # degrees of freedom of the joints alone (n - rank Phi^K_q)
    system: System = None
    modes: list = field(default_factory=list)
    warnings: list = field(default_factory=list)   # Diagnostic (severity warning)


def _levenberg_marquardt(S: System, q: np.ndarray, t0: float, maxit: int = 300, rows=None):
    """Minimise |Phi(q, t0)|^2 (over rows, default all) from q; then Newton (minimum norm) to
    rounding. Returns (q, iterations)."""
    sel = slice(None) if rows is None else rows
    # the drivers' targets at t0 once: evaluating every driver function per residual cost the
    # 300-coordinate arch (98 drivers) a third of its assembly
    T0 = S.driver_values(np.array([float(t0)]))[0]

    def res(x):
        return S.residual(S.ext(x), t0, T0)[0][sel]

    def jac(x):
        return S.jacobian(S.ext(x))[0][sel]

    r = res(q)
    cost = r @ r
    mu = 1e-3
    it = 0
    for it in range(1, maxit + 1):
        if not np.isfinite(cost) or np.abs(r).max() <= 1e-14:
            break
        J = jac(q)
        if not np.isfinite(J).all():
            break
        A = J.T @ J
        g = J.T @ r
        d = np.diag(A).copy()
        d = np.maximum(d, 1e-9 * (d.max() if d.size else 1.0) + 1e-15)
        improved = False
        for _ in range(30):
            try:
                step = np.linalg.solve(A + mu * np.diag(d), -g)
            except np.linalg.LinAlgError:
                mu *= 10
                continue
            r_new = res(q + step)
            c_new = r_new @ r_new
            if np.isfinite(c_new) and c_new < cost:
                q, r, cost = q + step, r_new, c_new
                mu = max(mu / 5, 1e-15)
                improved = True
                break
            mu *= 4
            if mu > 1e16:
                break
        if not improved or np.abs(step).max() <= 1e-16 * (1 + np.abs(q).max()):
            break
    # Newton polish (quadratic convergence near a regular solution)
    for _ in range(8):
        J = jac(q)
        if not (np.isfinite(J).all() and np.isfinite(r).all()):
            break
        try:
            step = -np.linalg.lstsq(J, r, rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        r_new = res(q + step)
        if not (r_new @ r_new <= cost or np.abs(r_new).max() <= 1e-14):
            break
        stalled = not (r_new @ r_new < 0.25 * cost) and np.abs(r_new).max() <= 1e-12
        q, r, cost = q + step, r_new, r_new @ r_new
        it += 1
        # at rounding level the residual stops shrinking while the steps stay at cond * eps:
        # further dense least-squares solves (each O(m n^2)) change nothing
        if stalled or np.abs(step).max() <= 4 * np.finfo(float).eps * (1 + np.abs(q).max()):
            break
    return q, it


def _joints_regain_rank(S: System, q: np.ndarray, t0: float, mk: int) -> bool:
    """Whether the joint equations, short of rank at the assembled pose q, are of full rank at
    poses of the joints a little away from it: then q is a singular pose of the joints (a
    four-bar folded flat at a change point), not a joint that repeats the others everywhere.

    Whether the smallest singular value at q falls under RANK_TOL depends on how near the fold
    the assembly converged, which varies with the BLAS and the processor; a step of 1e-2 (of
    the largest coordinate) along each direction the joints leave free, back onto the joints,
    moves a change point's smallest singular value to ~1e-3, a repeated joint's stays at
    rounding: far from that noise on either side."""
    rows = np.arange(mk)
    Jk = _row_normalised(S.jacobian(S.ext(q))[0][:mk])
    _, sv, Vt = np.linalg.svd(Jk)
    rank = int((sv > RANK_TOL * max(sv[0], 1e-300)).sum())
    h = 1e-2 * (1.0 + np.abs(q).max())
    for v in Vt[rank:]:
        for sign in (1.0, -1.0):
            q1, _ = _levenberg_marquardt(S, q + sign * h * v, t0, rows=rows)
            r1 = S.residual(S.ext(q1), t0)[0][:mk]
            if not np.abs(r1).max() <= ASSEMBLED:
                continue
            J1 = _row_normalised(S.jacobian(S.ext(q1))[0][:mk])
            s1 = np.linalg.svd(J1, compute_uv=False)
            if s1[-1] > 1e-6 * max(s1[0], 1e-300):
                return True
    return False


def _row_normalised(J: np.ndarray) -> np.ndarray:
    nrm = np.linalg.norm(J, axis=1)
    return J / np.where(nrm > 0, nrm, 1.0)[:, None]


def _dependent_rows(J: np.ndarray) -> list[int]:
    """Rows (in file order, drivers last) that are linear combinations of earlier rows.

    Gram-Schmidt over the normalised rows, orthogonalising twice: a row whose remainder is below
    RANK_TOL is dependent. Keeping the first rows and naming the later ones matches how users
    read a model (the third crank of a parallelogram is the redundant one)."""
    Jn = _row_normalised(J)
    basis = np.zeros((0, J.shape[1]))
    out = []
    for i, row in enumerate(Jn):
        v = row - basis.T @ (basis @ row)
        v = v - basis.T @ (basis @ v)
        nv = np.linalg.norm(v)
        if nv <= RANK_TOL or basis.shape[0] == J.shape[1]:
            out.append(i)
        else:
            basis = np.vstack([basis, v / nv])
    return out


def _bodies_of(cm: CompiledModel, vec: np.ndarray, frac: float = 0.3) -> list[str]:
    mag = np.abs(vec)
    if mag.max() == 0:
        return []
    per_body = mag.reshape(-1, 3).max(axis=1)
    idx = np.nonzero(per_body >= frac * per_body.max())[0]
    return [cm.body_names[i] for i in idx]


def assemble(cm: CompiledModel, start: float | None = None) -> Assembly:
    """Assemble the model at t = start (default: its analysis: start; a run whose start is set
    on the command line or in the API assembles there) and check its degrees of freedom; raise
    InputError when it cannot be analysed."""
    sketched = True           # the sketch is the pose at the model's own start time only
    if start is not None and start != cm.spec.analysis.start:
        from dataclasses import replace
        cm = replace(cm, spec=replace(cm.spec, analysis=replace(cm.spec.analysis, start=start)))
        sketched = False
    # dense SVDs and least squares of up to DENSE_LIMIT columns: on one BLAS thread, because
    # a busy second core made OpenBLAS's threads take many times longer (linalg.one_blas_thread);
    # below PIN_BLAS_FROM coordinates OpenBLAS does not thread them (as for the solver's blocks)
    pin = one_blas_thread() if cm.n >= PIN_BLAS_FROM else contextlib.nullcontext()
    with np.errstate(all="ignore"), pin:
        return _assemble(cm, sketched)


def _assemble(cm: CompiledModel, sketched: bool = True) -> Assembly:
    spec = cm.spec
    t0 = spec.analysis.start
    S_all = System(cm)
    n, m = cm.n, cm.m
    problems: list[Diagnostic] = []

    # driver functions must be defined at t0, and distances positive
    if cm.driver_funcs:
        T, NU, FDD = S_all.driver_values(np.array([t0]))
        for r in cm.driver_rows:
            el = cm.element_of_row(r)
            line = el.param_lines.get("f", el.line)
            if not (np.isfinite(T[0, r]) and np.isfinite(NU[0, r]) and np.isfinite(FDD[0, r])):
                raise InputError([Diagnostic(spec.file, line,
                                             f"{el.label}: f or its derivatives are not finite at "
                                             f"t = start = {t0:g} (f = {el.f.text})")])
            if KINDS[el.kind].positive_target and not T[0, r] > 0:
                raise InputError([Diagnostic(spec.file, line,
                                             f"{el.label}: f must be a positive distance, but "
                                             f"f({t0:g}) = {T[0, r] * cm.L:g}")])
    # an element that cannot be differentiated at the estimates (the two points of a distance
    # on top of each other) would poison every step of the assembly
    bad_rows = _undifferentiable_rows(S_all, cm.q0)
    if bad_rows.size:
        raise InputError([diag(cm, int(r), f"{cm.element_of_row(r).label}: its two points "
                                           f"coincide at the body estimates q, where the "
                                           f"distance has no direction; move the estimates "
                                           f"apart (a distance of zero is a revolute joint)")
                          for r in bad_rows[:1]])
    if n > DENSE_LIMIT:
        return _assemble_large(cm, S_all)
    if n >= SPARSE_ASSEMBLY and m == n:
        A = _assemble_blocks(cm, S_all, sketched)
        if A is not None:
            return A

    q, its = _levenberg_marquardt(S_all, cm.q0.copy(), t0)
    r = S_all.residual(S_all.ext(q), t0)[0]
    if not (np.abs(r).max() <= ASSEMBLED):
        raise InputError(_not_assembled(cm, S_all, q, r, its))
    J = S_all.jacobian(S_all.ext(q))[0]
    if not np.isfinite(J).all():
        row = int(np.nonzero(~np.isfinite(J).all(axis=1))[0][0])
        raise InputError([diag(cm, row, f"{cm.element_of_row(row).label} has no direction at "
                                        f"the assembled pose (its two points coincide); a "
                                        f"distance of zero is a revolute joint")])
    Jn = _row_normalised(J)
    sv = np.linalg.svd(Jn, compute_uv=False) if m else np.zeros(0)
    rank = int((sv > RANK_TOL * (sv[0] if sv.size else 1.0)).sum())
    mk = cm.m_joint
    rank_k = 0
    if mk:
        svk = np.linalg.svd(Jn[:mk], compute_uv=False)
        rank_k = int((svk > RANK_TOL * max(svk[0], 1e-300)).sum())
    dof = n - rank_k
    free = n - rank
    dependent = _dependent_rows(J) if rank < m else []
    ndrv = len(cm.driver_rows)
    drv = [d for d in dependent if d >= mk]
    kin = [d for d in dependent if d < mk]
    line = spec.section_lines.get("drivers", spec.section_lines.get("joints"))

    if free > 0:
        _, _, Vt = np.linalg.svd(Jn) if m else (None, None, np.eye(n))
        null = Vt[rank:] if m else np.eye(n)
        moving = _bodies_of(cm, np.abs(null).max(axis=0))
        useful = ndrv - len(drv)
        if rank_k < mk and ndrv >= n - mk and not drv and _joints_regain_rank(S_all, q, t0, mk):
            dof = n - mk        # the joints' rank was lost at this pose only
            rank_k = mk
        if rank_k == mk and ndrv >= dof and not drv:
            # enough drivers by count, the joints independent, yet a direction left free: the
            # drivers lose their hold at this pose only (a four-bar folded flat at t = start)
            raise InputError([Diagnostic(spec.file, line, (
                f"at t = start = {t0:g} the mechanism is at a dead point or a change point: the "
                f"joints leave {_plural(dof, 'degree')} of freedom and "
                f"{_plural(ndrv, 'driver')} {'is' if ndrv == 1 else 'are'} given, but in this "
                f"pose {', '.join(moving)} can move while the driver{'s stand' if ndrv > 1 else ' stands'} "
                f"still (their pins "
                f"are in line); start where the links are not in line (another analysis: "
                f"start, or an offset in the driver's f) or change the dimensions"))])
        msg = (f"the mechanism has {_plural(dof, 'degree')} of freedom but "
               f"{_plural(useful, 'independent driver') if drv else _plural(ndrv, 'driver')}, so "
               f"its motion is not determined: add {_plural(free, 'driver')} (bodies free to "
               f"move: {', '.join(moving)}); {_plural(mk, 'joint equation')} and "
               f"{_plural(ndrv, 'driver')} for {cm.nb} bodies ({n} coordinates)")
        problems.append(Diagnostic(spec.file, line, msg))
        for d in kin:
            problems.append(diag(cm, d, f"{cm.row_label[d]} is redundant: it repeats what the "
                                        f"other joints already impose"))
        for d in drv:
            problems.append(diag(cm, d, f"{cm.element_of_row(d).label} does not drive a free "
                                        f"degree of freedom: it repeats what the joints and "
                                        f"other drivers impose"))
        raise InputError(problems)
    for d in drv:
        problems.append(diag(cm, d, f"{cm.element_of_row(d).label} is one driver too many: the "
                                    f"joints leave {_plural(dof, 'degree')} of freedom and "
                                    f"{_plural(ndrv, 'driver')} {'is' if ndrv == 1 else 'are'} "
                                    f"given; remove a driver"))
    if problems:
        raise InputError(problems)
    warnings = [diag(cm, d, f"{cm.row_label[d]} is redundant (consistent with the other joints "
                            f"at the assembly pose): it is left out of the solve and checked at "
                            f"every step", severity="warning") for d in kin]
    redundant = kin
    meshing = centre_distances(cm, q)
    if any(d.severity == "error" for d in meshing):
        raise InputError([d for d in meshing if d.severity == "error"])
    warnings += meshing

    active = np.array([k for k in range(m) if k not in set(redundant)], dtype=np.intp)
    S = System(cm, active)
    S.build_blocks()
    A = Assembly(q=q, residual=float(np.abs(r).max()), iterations=its, active_rows=active,
                 redundant_rows=redundant, dof=dof, system=S, warnings=warnings)
    return _finish(cm, S, A, sketched)


def _undifferentiable_rows(S: System, q: np.ndarray) -> np.ndarray:
    """Sorted rows whose gradient has a non-finite entry at q (ground columns excluded), read
    element by element: the dense m x n Jacobian of an 18,003-coordinate chain would need 2.6 GB
    where this needs the elements' own entries."""
    F = S.frame(S.ext(q))
    bad = []
    n = S.n
    with np.errstate(all="ignore"):
        for G in S.cm.groups:
            g = G.grad(F)[0]                                   # (K, neq, nc)
            own = (G.cols < n)[:, None, :]
            rows = G.rows[~(np.isfinite(g) | ~own).all(axis=2)]
            bad.extend(int(r) for r in rows.ravel())
    return np.array(sorted(bad), dtype=np.intp)


def _plural(k: int, word: str) -> str:
    return f"{k} {word}{'' if k == 1 else 's'}"


def _not_assembled(cm: CompiledModel, S_all: System, q, r, its) -> list[Diagnostic]:
    """Why the pose could not be assembled: a redundant constraint that contradicts the others
    (found by leaving one element out at a time: without it the rest assembles and it is still
    redundant there), or geometry that does not close (the most violated constraints)."""
    spec = cm.spec
    t0 = spec.analysis.start
    n, m = cm.n, cm.m
    short = short_loops(cm)        # links too short (or one too long) to close their loop
    if short:
        return short
    if n <= 300 and m >= n and len(spec.elements) <= 60:
        # later elements first: of a redundant set, the one written last is the one named
        violated = [e for e in range(len(spec.elements))
                    if not np.abs(r[cm.row_element == e]).max() <= ASSEMBLED]
        drivers = _contradicting_drivers(cm, S_all, q, r)
        if drivers is not None:
            return drivers
        for tries, e in enumerate(reversed(violated)):
            if tries >= 8:
                break
            keep = np.nonzero(cm.row_element != e)[0]
            q2, _ = _levenberg_marquardt(S_all, q.copy(), t0, rows=keep)
            r2 = S_all.residual(S_all.ext(q2), t0)[0]
            if not np.abs(r2[keep]).max() <= ASSEMBLED:
                continue
            J2 = S_all.jacobian(S_all.ext(q2))[0]
            if not np.isfinite(J2).all():
                continue
            Jk = _row_normalised(J2[keep])
            sv = np.linalg.svd(Jk, compute_uv=False)
            rows_e = np.nonzero(cm.row_element == e)[0]
            if (sv > RANK_TOL * sv[0]).sum() + len(rows_e) <= n:
                continue      # e only takes away freedom the others leave: not redundant
            worst = int(rows_e[np.argmax(np.abs(r2[rows_e]))])
            return [diag(cm, worst, f"{spec.elements[e].label} is redundant and contradicts the "
                                    f"other constraints: without it the mechanism assembles, "
                                    f"and there it is violated by "
                                    f"{fmt_res(cm, worst, r2[worst])}; remove it or correct its "
                                    f"dimensions")]
    worst = np.argsort(-np.abs(np.nan_to_num(r, nan=np.inf)))
    named: list[int] = []
    for row in worst:
        if len(named) == 3 or abs(r[row]) <= ASSEMBLED:
            break
        if int(cm.row_element[row]) not in {int(cm.row_element[k]) for k in named}:
            named.append(int(row))
    parts = [f"{cm.row_label[k]} is violated by {fmt_res(cm, k, r[k])}" for k in named]
    return [diag(cm, named[0], f"cannot assemble the mechanism at t = {t0:g} ({its} iterations "
                               f"from the body estimates): {'; '.join(parts)}; check the "
                               f"dimensions and the estimates q")]


def _contradicting_drivers(cm: CompiledModel, S_all: System, q, r) -> list | None:
    """More drivers than the joints leave degrees of freedom, and they contradict each other at
    t = start: name every driver (not only the one written last, which need not be the wrong
    one), or None when the drivers are not the problem."""
    mk, nd = cm.m_joint, len(cm.driver_rows)
    if not nd:
        return None
    J = S_all.jacobian(S_all.ext(q))[0]
    if not np.isfinite(J).all():
        return None
    sv = np.linalg.svd(_row_normalised(J[:mk]), compute_uv=False) if mk else np.zeros(0)
    dof = cm.n - int((sv > RANK_TOL * (sv[0] if sv.size else 1.0)).sum())
    if nd <= dof:
        return None
    labels = [cm.element_of_row(d).label for d in cm.driver_rows]
    worst = [f"{cm.row_label[d]} by {fmt_res(cm, d, r[d])}" for d in cm.driver_rows
             if abs(r[d]) > ASSEMBLED]
    return [diag(cm, int(cm.driver_rows[-1]),
                 f"{_plural(nd, 'driver')} for {_plural(dof, 'degree')} of freedom, and they "
                 f"contradict each other at t = {cm.spec.analysis.start:g}: "
                 f"{', '.join(labels[:-1])} and {labels[-1]} cannot all hold (at the closest "
                 f"pose: {'; '.join(worst) or 'violated'}); remove the driver{'s' if nd - dof > 1 else ''} "
                 f"you do not mean ({_plural(nd - dof, 'too many')})")]


def _newton_by_blocks(cm: CompiledModel, S: System):
    """Newton on each diagonal block in block order from the estimates at t = start: (Q (1,
    n + 3), residual (m,), BatchInfo)."""
    t0 = cm.spec.analysis.start
    Q = S.ext(cm.q0.copy())
    Qd = np.zeros_like(Q)
    Qdd = np.zeros_like(Q)
    info = S.solve_batch(np.array([t0]), Q, Qd, Qdd, policy="full", tol=1e-13, maxit=50, order=0)
    return Q, S.residual(Q, t0)[0], info


def _assemble_blocks(cm: CompiledModel, S_all: System, sketched: bool) -> Assembly | None:
    """A square model of SPARSE_ASSEMBLY to DENSE_LIMIT coordinates assembled without a dense
    matrix, or None when the blocks do not settle it clearly (structurally singular, Newton not
    converged, a block with sigma_min below BLOCKS_CLEAR, a gear pair that cannot mesh): the
    dense checks then decide and name the problem. Gives what the dense route gives for such a
    model: no redundant rows, dof = n - joint equations (the joint rows of a regular square
    Jacobian are independent), the meshing and sketch warnings."""
    from .structure import StructurallySingular
    S = System(cm)
    try:
        S.build_blocks()
    except StructurallySingular:
        return None
    Q, r, info = _newton_by_blocks(cm, S)
    if not (info.converged[0] and np.abs(r).max() <= ASSEMBLED
            and (info.smin[0] >= BLOCKS_CLEAR).all()):
        return None
    q = Q[0, : cm.n].copy()
    meshing = centre_distances(cm, q)
    if any(d.severity == "error" for d in meshing):
        return None
    A = Assembly(q=q, residual=float(np.abs(r).max()), iterations=int(info.iterations[0]),
                 active_rows=S.rows, redundant_rows=[], dof=cm.n - cm.m_joint, system=S,
                 warnings=meshing)
    return _finish(cm, S, A, sketched)


def _finish(cm: CompiledModel, S: System, A: Assembly, sketched: bool) -> Assembly:
    """What every assembly route ends with: the requested branches, the assembly modes and,
    for a sketch, its drawn branches kept and the pins it moved named."""
    apply_branch_hints(cm, A)
    A.modes = block_modes(cm, S, A.q)
    if sketched:
        from .branches import keep_drawn_branches, moved_points
        keep_drawn_branches(cm, A)
        A.warnings += moved_points(cm, S.ext(A.q[None, :])[0])
    return A


def _assemble_large(cm: CompiledModel, S_all: System) -> Assembly:
    """Large models (n > DENSE_LIMIT): the system must be square and structurally regular; each
    diagonal block is assembled by Newton in block order (the structure replaces dense SVD)."""
    from .structure import StructurallySingular
    spec = cm.spec
    if cm.m != cm.n:
        raise InputError([Diagnostic(spec.file, None,
                                     f"{spec.name}: {cm.m} equations for {cm.n} coordinates: a "
                                     f"model this large must have exactly one equation per "
                                     f"coordinate (add drivers or remove redundant joints)")])
    S = System(cm)
    try:
        S.build_blocks()
    except StructurallySingular as e:
        rows = e.rows_left[:3]
        raise InputError([diag(cm, r, f"{cm.row_label[r]} cannot be matched to a free "
                                        f"coordinate: the model is over-constrained here and "
                                        f"under-constrained elsewhere") for r in rows]) from None
    t0 = spec.analysis.start
    Q, r, info = _newton_by_blocks(cm, S)
    if not info.converged[0] or np.abs(r).max() > ASSEMBLED:
        row = int(np.argmax(np.abs(np.nan_to_num(r, nan=np.inf))))
        raise InputError([diag(cm, row, f"cannot assemble the mechanism at t = {t0:g}: "
                                        f"{cm.row_label[row]} is violated by "
                                        f"{fmt_res(cm, row, r[row])}; check its dimensions and "
                                        f"the body estimates q")])
    if (info.smin[0] <= RANK_TOL).any():
        b = int(np.argmin(info.smin[0]))
        row = int(S.blocks[b].rows[0])
        raise InputError([diag(cm, row, f"the Jacobian is singular at the assembly pose near "
                                        f"{cm.row_label[row]}: redundant constraints or a missing "
                                        f"driver")])
    A = Assembly(q=Q[0, : cm.n].copy(), residual=float(np.abs(r).max()), iterations=int(
        info.iterations[0]), active_rows=S.rows, redundant_rows=[], dof=cm.n - cm.m_joint,
        system=S)
    apply_branch_hints(cm, A)
    A.modes = block_modes(cm, S, A.q)
    return A


