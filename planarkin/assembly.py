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

from dataclasses import dataclass, field

import numpy as np

from .diagnostics import Diagnostic, InputError
from .model.compile import CompiledModel
from .closure import short_loops
from .linalg import one_blas_thread
from .meshing import centre_distances
from .system import System

ASSEMBLED = 1e-10        # largest |Phi| (internal units) of an assembled pose
RANK_TOL = 1e-8          # relative singular value / R diagonal below which a direction is lost
DENSE_LIMIT = 3000       # largest n for dense SVD / QR
# From this many coordinates a square model is first assembled block by block (Newton on each
# diagonal block, as above DENSE_LIMIT) and the dense checks (Levenberg-Marquardt, two SVDs,
# least squares on the whole m x n Jacobian: 19.5 s of the 1,500-coordinate arch's 36 s) run
# only when that does not settle the model clearly: every block regular with sigma_min at
# least BLOCKS_CLEAR (a hundred times RANK_TOL), converged to ASSEMBLED. A square Jacobian with
# regular diagonal blocks has full rank, so the dense rank analysis could only confirm it.
SPARSE_ASSEMBLY = 1000
BLOCKS_CLEAR = 1e-6


@dataclass
class Mode:
    """Assembly mode of one diagonal block: its bodies and the sign of its determinant."""

    bodies: tuple
    sign: int
    key: str                        # body named in assembly: branch:
    block: int = -1                 # index of the loop's own diagonal block in System.blocks


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


def _diag(cm: CompiledModel, row: int | None, msg: str, severity="error") -> Diagnostic:
    line = cm.element_of_row(row).line if row is not None else None
    return Diagnostic(cm.spec.file, line, msg, severity)


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
        # further dense least-squares solves (27 ms each at 300 coordinates) change nothing
        if stalled or np.abs(step).max() <= 4 * np.finfo(float).eps * (1 + np.abs(q).max()):
            break
    return q, it


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
    # a busy second core made OpenBLAS's threads take 50 times longer (linalg.one_blas_thread)
    with np.errstate(all="ignore"), one_blas_thread():
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
            if el.kind == "distance" and not T[0, r] > 0:
                raise InputError([Diagnostic(spec.file, line,
                                             f"{el.label}: f must be a positive distance, but "
                                             f"f({t0:g}) = {T[0, r] * cm.L:g}")])
    # an element that cannot be differentiated at the estimates (the two points of a distance
    # on top of each other) would poison every step of the assembly
    bad_rows = _undifferentiable_rows(S_all, cm.q0)
    if bad_rows.size:
        raise InputError([_diag(cm, int(r), f"{cm.element_of_row(r).label}: its two points "
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
        raise InputError([_diag(cm, row, f"{cm.element_of_row(row).label} has no direction at "
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
            problems.append(_diag(cm, d, f"{cm.row_label[d]} is redundant: it repeats what the "
                                         f"other joints already impose"))
        for d in drv:
            problems.append(_diag(cm, d, f"{cm.element_of_row(d).label} does not drive a free "
                                         f"degree of freedom: it repeats what the joints and "
                                         f"other drivers impose"))
        raise InputError(problems)
    for d in drv:
        problems.append(_diag(cm, d, f"{cm.element_of_row(d).label} is one driver too many: the "
                                     f"joints leave {_plural(dof, 'degree')} of freedom and "
                                     f"{_plural(ndrv, 'driver')} {'is' if ndrv == 1 else 'are'} "
                                     f"given; remove a driver"))
    if problems:
        raise InputError(problems)
    warnings = [_diag(cm, d, f"{cm.row_label[d]} is redundant (consistent with the other joints "
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
            return [_diag(cm, worst, f"{spec.elements[e].label} is redundant and contradicts the "
                                     f"other constraints: without it the mechanism assembles, "
                                     f"and there it is violated by "
                                     f"{_fmt_res(cm, worst, r2[worst])}; remove it or correct its "
                                     f"dimensions")]
    worst = np.argsort(-np.abs(np.nan_to_num(r, nan=np.inf)))
    named: list[int] = []
    for row in worst:
        if len(named) == 3 or abs(r[row]) <= ASSEMBLED:
            break
        if int(cm.row_element[row]) not in {int(cm.row_element[k]) for k in named}:
            named.append(int(row))
    parts = [f"{cm.row_label[k]} is violated by {_fmt_res(cm, k, r[k])}" for k in named]
    return [_diag(cm, named[0], f"cannot assemble the mechanism at t = {t0:g} ({its} iterations "
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
    worst = [f"{cm.row_label[d]} by {_fmt_res(cm, d, r[d])}" for d in cm.driver_rows
             if abs(r[d]) > ASSEMBLED]
    return [_diag(cm, int(cm.driver_rows[-1]),
                  f"{_plural(nd, 'driver')} for {_plural(dof, 'degree')} of freedom, and they "
                  f"contradict each other at t = {cm.spec.analysis.start:g}: "
                  f"{', '.join(labels[:-1])} and {labels[-1]} cannot all hold (at the closest "
                  f"pose: {'; '.join(worst) or 'violated'}); remove the driver{'s' if nd - dof > 1 else ''} "
                  f"you do not mean ({_plural(nd - dof, 'too many')})")]


def _fmt_res(cm: CompiledModel, row: int, value: float) -> str:
    el = cm.element_of_row(row)
    from .elements import KINDS
    kind = KINDS[el.kind]
    if kind.target_unit == "angle" or (el.kind == "translational" and row == _first_row(cm, row)):
        v = value / cm.angle_factor
        return f"{abs(v):.3g} {cm.spec.angle_unit}"
    return f"{abs(value) * cm.L:.3g} {cm.spec.length_unit}"


def _first_row(cm: CompiledModel, row: int) -> int:
    el = cm.row_element[row]
    return int(np.nonzero(cm.row_element == el)[0][0])


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
    _apply_branch_hints(cm, A)
    A.modes = block_modes(cm, S, A.q)
    if sketched:
        from .model.sketch import keep_drawn_branches, moved_points
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
        raise InputError([_diag(cm, r, f"{cm.row_label[r]} cannot be matched to a free coordinate:"
                                       f" the model is over-constrained here and under-"
                                       f"constrained elsewhere") for r in rows])
    t0 = spec.analysis.start
    Q, r, info = _newton_by_blocks(cm, S)
    if not info.converged[0] or np.abs(r).max() > ASSEMBLED:
        row = int(np.argmax(np.abs(np.nan_to_num(r, nan=np.inf))))
        raise InputError([_diag(cm, row, f"cannot assemble the mechanism at t = {t0:g}: "
                                         f"{cm.row_label[row]} is violated by "
                                         f"{_fmt_res(cm, row, r[row])}; check its dimensions and "
                                         f"the body estimates q")])
    if (info.smin[0] <= RANK_TOL).any():
        b = int(np.argmin(info.smin[0]))
        row = int(S.blocks[b].rows[0])
        raise InputError([_diag(cm, row, f"the Jacobian is singular at the assembly pose near "
                                         f"{cm.row_label[row]}: redundant constraints or a missing "
                                         f"driver")])
    A = Assembly(q=Q[0, : cm.n].copy(), residual=float(np.abs(r).max()), iterations=int(
        info.iterations[0]), active_rows=S.rows, redundant_rows=[], dof=cm.n - cm.m_joint,
        system=S)
    _apply_branch_hints(cm, A)
    A.modes = block_modes(cm, S, A.q)
    return A


def block_modes(cm: CompiledModel, S: System, q: np.ndarray) -> list[Mode]:
    """Sign of det of every diagonal block that is not affine in its own unknowns (the blocks
    where more than one assembly is possible), keyed by the first of its bodies in file order."""
    Q = S.ext(q)
    F = S.frame(Q)
    out = []
    for b, B in enumerate(S.blocks):
        if B.affine:              # one solution: nothing to choose
            continue
        out.append(_mode(cm, S, B, b, F))
    return out


def _mode(cm: CompiledModel, S: System, B, b: int, F) -> Mode:
    grads = S.block_grads(B, F)
    if S.is_large(B):             # no dense matrix for a large block: the sign from its LU
        sign = int(S.block_lu(B, grads).sign[0])
    else:
        sign = int(np.sign(np.linalg.det(S.block_matrix(B, grads)[0])))
    bodies = tuple(sorted({int(c) // 3 for c in B.cols}))
    names = tuple(cm.body_names[k] for k in bodies)
    return Mode(names, sign, names[0], b)


def _block_sign(S: System, B, Q: np.ndarray) -> int:
    grads = S.block_grads(B, S.frame(Q))
    if S.is_large(B):
        return int(S.block_lu(B, grads).sign[0])
    return int(np.sign(np.linalg.det(S.block_matrix(B, grads)[0])))


def _newton_block(S: System, B, Q: np.ndarray, T: np.ndarray, maxit: int = 25) -> bool:
    """Newton on one diagonal block's own unknowns, the earlier blocks' coordinates held
    (block-triangular order: the later ones do not enter). Q (1, n + 3) is updated in place.
    True when converged to rounding error."""
    for _ in range(maxit):
        F = S.frame(Q)
        r = S.block_residual(B, F, T)[0]
        J = S.block_matrix(B, S.block_grads(B, F))[0]
        if not (np.isfinite(r).all() and np.isfinite(J).all()):
            return False
        try:
            dx = np.linalg.solve(J, r)
        except np.linalg.LinAlgError:
            return False
        Q[0, B.cols] -= dx
        if np.abs(dx).max() <= 1e-13 * (1 + np.abs(Q[0, B.cols]).max()):
            break
    r = S.block_residual(B, S.frame(Q), T)[0]
    return bool(np.isfinite(Q).all() and np.abs(r).max() <= 1e-12)


def _search_block(S: System, B, Q: np.ndarray, T: np.ndarray, want: int, rng,
                  trials: int = 120):
    """A solution of block B alone with determinant sign want, from deterministic random starts
    around Q (angles anywhere on the circle, positions within a few model lengths); Q itself is
    not changed. Returns the new (1, n + 3) array or None."""
    cols = B.cols
    ang = cols % 3 == 2
    for trial in range(trials):
        Qt = Q.copy()
        scale = 0.3 * (1 + trial // 30)
        dq = rng.normal(size=len(cols)) * scale
        dq[ang] = rng.uniform(-np.pi, np.pi, size=int(ang.sum()))
        Qt[0, cols] += dq
        if _newton_block(S, B, Qt, T) and _block_sign(S, B, Qt) == want:
            return Qt
    return None


def _apply_branch_hints(cm: CompiledModel, A: Assembly) -> None:
    """Re-assemble to the loops' signs asked by `assembly: branch:` or raise InputError.

    Each hint names a body; its loop is the first non-affine diagonal block holding one of the
    body's coordinates (a body closed by a distance joint has its x and y in affine 1x1 blocks:
    those are skipped, the sign is that of the loop's own block). From the first block whose sign
    must change, the blocks are solved one by one in block-triangular order: a requested block
    by a deterministic multi-start search for its sign, every later block by Newton from the
    previous pose and, when that fails or lands on another sign (a downstream link that must
    move a long way, like the lower leg of a Jansen linkage), by the same search for the sign it
    had (or else the other). At the end every requested sign is checked again."""
    hints = cm.spec.branch
    if not hints:
        return
    S = A.system
    spec = cm.spec
    t0 = spec.analysis.start
    T = S.driver_values(np.array([t0]))[0]
    rng = np.random.default_rng(2024)
    modes = block_modes(cm, S, A.q)
    wanted: dict[int, tuple] = {}
    for name, want in hints.items():
        mode = next((md for md in modes if name in md.bodies), None)
        line = spec.branch_lines.get(name)
        if mode is None:
            raise InputError([Diagnostic(spec.file, line,
                                         f"assembly: branch: body '{name}' is not part of a loop "
                                         f"with more than one assembly; nothing to choose "
                                         f"(loops: {', '.join('+'.join(md.bodies) for md in modes) or 'none'})")])
        if mode.block in wanted and wanted[mode.block][0] != want:
            other = wanted[mode.block][1]
            raise InputError([Diagnostic(spec.file, line,
                                         f"assembly: branch: {name} and {other} are in the same "
                                         f"loop {'+'.join(mode.bodies)} but ask for different "
                                         f"signs; give one of them")])
        wanted.setdefault(mode.block, (want, name, line))
    current = {md.block: md.sign for md in modes}
    flips = [b for b, w in wanted.items() if current[b] != w[0]]
    if not flips:
        return
    Q = S.ext(A.q)
    for b in range(min(flips), len(S.blocks)):
        B = S.blocks[b]
        Qn = Q.copy()
        ok = _newton_block(S, B, Qn, T)
        if B.affine:
            if ok:
                Q = Qn
                continue
            raise InputError([_diag(cm, int(B.rows[0]),
                                    f"assembly: branch: after changing the loop's branch, "
                                    f"{cm.row_label[int(B.rows[0])]} cannot be satisfied")])
        want = wanted[b][0] if b in wanted else current[b]
        if ok and _block_sign(S, B, Qn) == want:
            Q = Qn
            continue
        found = _search_block(S, B, Q, T, want, rng)
        other = None
        if found is None:
            other = Qn if ok else _search_block(S, B, Q, T, -want, rng)
        if found is None and (b in wanted or other is None):
            names = '+'.join(_mode(cm, S, B, b, S.frame(Q)).bodies)
            before = [f"{w[1]}: {'+' if w[0] > 0 else '-'}" for bb, w in sorted(wanted.items())
                      if bb < b]
            line = wanted[b][2] if b in wanted else next(iter(wanted.values()))[2]
            if other is None:
                raise InputError([Diagnostic(spec.file, line,
                                             f"assembly: branch: the loop {names} cannot be "
                                             f"closed at t = {t0:g} on either branch once "
                                             f"{', '.join(before) or 'the loops before it'} "
                                             f"{'is' if len(before) == 1 else 'are'} reached: "
                                             f"these branches do not fit together")])
            raise InputError([Diagnostic(spec.file, line,
                                         f"assembly: branch: no assembly with sign "
                                         f"{'+' if want > 0 else '-'} found for the loop "
                                         f"{names} (only {'-' if want > 0 else '+'})")])
        Q = found if found is not None else other    # downstream, not asked for: either sign
    q = Q[0, : cm.n].copy()
    # the same pose with each angle the turn nearest the user's estimate
    phi = q[2::3]
    q[2::3] = phi - 2 * np.pi * np.round((phi - cm.q0[2::3]) / (2 * np.pi))
    S_all = System(cm)
    r = S_all.residual(S_all.ext(q), t0)[0]
    if not np.abs(r).max() <= ASSEMBLED:
        row = int(np.argmax(np.abs(np.nan_to_num(r, nan=np.inf))))
        raise InputError([Diagnostic(spec.file, next(iter(wanted.values()))[2],
                                     f"assembly: branch: on the requested branches "
                                     f"{cm.row_label[row]} is violated by "
                                     f"{_fmt_res(cm, row, r[row])}")])
    # the loop's own block, not one that merely shares a body, must have the sign asked for
    got = {md.block: md.sign for md in block_modes(cm, S, q)}
    for b, (want, name, line) in wanted.items():
        if got.get(b) != want:
            raise InputError([Diagnostic(spec.file, line,
                                         f"assembly: branch: {name}: the assembly reached has "
                                         f"sign {'+' if got.get(b, 0) > 0 else '-'}, not the "
                                         f"{'+' if want > 0 else '-'} requested")])
    A.q = q
    A.residual = float(np.abs(r).max())


DESCRIBED_MODES = 12     # `check` puts words to the first loops only (each costs a search)


def describe_modes(cm: CompiledModel, A: Assembly, limit: int = DESCRIBED_MODES) -> list[str]:
    """For each of A.modes, what its sign means geometrically at t = start, in words: the side
    of the loop's knee (a pin or distance end that moves to its mirror image on the other branch)
    relative to the line through two points the loop hangs from (points that stay put). Found by
    solving the loop's block on its other branch (the earlier blocks held); '' when the other
    branch does not close there or no pin/distance point describes it, and for the loops after
    the first `limit`."""
    S = A.system
    t0 = cm.spec.analysis.start
    T = S.driver_values(np.array([t0]))[0]
    Q = S.ext(A.q)
    col_block = {}
    for b, B in enumerate(S.blocks):
        for c in B.cols.tolist():
            col_block[c] = b
    names = list(cm.body_names) + ["ground"]
    # every pin and distance end: (label, body index, s (internal), elements' bodies, rows)
    pts = []
    for G in cm.groups:
        if G.kind.name not in ("revolute", "distance") or "si" not in G.params:
            continue
        for k in range(len(G)):
            bi, bj = (int(x) for x in G.bodies[k, :2])
            rows = set(int(r) for r in np.ravel(G.rows[k]))
            if G.kind.name == "revolute":
                pts.append((f"the {names[bi]}-{names[bj]} pin", bi, G.params["si"][k], (bi, bj),
                            rows))
            else:
                for b_, s_ in ((bi, G.params["si"][k]), (bj, G.params["sj"][k])):
                    pts.append((f"the {names[b_]} end of the {names[bi]}-{names[bj]} distance",
                                b_, s_, (bi, bj), rows))
    rng = np.random.default_rng(7)
    out = []
    for md in A.modes:
        if len(out) >= limit:
            out.append("")
            continue
        B = S.blocks[md.block]
        alt = _search_block(S, B, Q, T, -md.sign, rng, trials=60)
        if alt is None:
            out.append("")
            continue
        own = {int(c) // 3 for c in B.cols}

        def settled(b):          # ground, or a body fixed by the blocks before this one
            return b == cm.nb or all(col_block.get(3 * b + i, -1) < md.block for i in range(3))

        def where(Qx, b, s):
            x, y, ph = Qx[0, 3 * b], Qx[0, 3 * b + 1], Qx[0, 3 * b + 2]
            c, sn = np.cos(ph), np.sin(ph)
            return np.array([x + c * s[0] - sn * s[1], y + sn * s[0] + c * s[1]])

        fixed, knees = [], []
        for label, b, s, bodies, rows in pts:
            if not any(x in own for x in bodies) or not (b in own or settled(b)):
                continue
            p0, p1 = where(Q, b, s), where(alt, b, s)
            if np.hypot(*(p1 - p0)) <= 1e-9:
                if all(np.hypot(*(p0 - f[1])) > 1e-9 for f in fixed):
                    fixed.append((label, p0))
            elif rows & set(B.rows.tolist()):
                knees.append((label, p0, p1))
        words = ""
        if len(fixed) >= 2 and knees:
            (la, a), (lb, b) = max(((f, g) for i, f in enumerate(fixed) for g in fixed[i + 1:]),
                                   key=lambda fg: np.hypot(*(fg[0][1] - fg[1][1])))
            d = b - a
            best = None
            for lk, k0, k1 in knees:
                c0 = d[0] * (k0 - a)[1] - d[1] * (k0 - a)[0]
                c1 = d[0] * (k1 - a)[1] - d[1] * (k1 - a)[0]
                if np.sign(c0) == -np.sign(c1) != 0 and (best is None or abs(c0) > best[0]):
                    best = (abs(c0), lk, int(np.sign(c0)))
            if best is not None:
                _, lk, side = best
                here = "left of" if side > 0 else "right of"
                there = "right of" if side > 0 else "left of"
                mine, other = ("+", "-") if md.sign > 0 else ("-", "+")
                words = (f"{mine}: {lk} {here} the line from {la} to {lb}; {other}: {there} it")
        elif len(fixed) == 1 and knees:
            # one point to hang from (a slider's rod): say on which side of it, along the axis
            # on which the knee's two positions differ most
            (la, a), (lk, k0, k1) = fixed[0], max(knees, key=lambda k: np.hypot(*(k[1] - k[2])))
            ax = int(np.argmax(np.abs(k0 - k1)))
            if np.sign(k0[ax] - a[ax]) == -np.sign(k1[ax] - a[ax]) != 0:
                xy = "xy"[ax]
                here = "larger" if k0[ax] > a[ax] else "smaller"
                there = "smaller" if here == "larger" else "larger"
                mine, other = ("+", "-") if md.sign > 0 else ("-", "+")
                words = f"{mine}: {lk} at {here} {xy} than {la}; {other}: at {there} {xy}"
        out.append(words)
    return out
