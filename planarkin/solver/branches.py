"""Assembly modes (reference §7.4, point 3): the sign of each diagonal block's determinant (a
dyad's elbow, a loop's open or crossed form), the branches asked by `assembly: branch:`, the
branches a sketch draws, and the words `check` puts to each mode. Called by
`planarkin.solver.assembly` once a pose satisfies the equations."""

from __future__ import annotations

from typing import TYPE_CHECKING

import math
from dataclasses import dataclass, replace

import numpy as np

from planarkin.diagnostics import Diagnostic, InputError
from .kinematics import point_kinematics
from .system import System
from .tolerances import ASSEMBLED

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel



@dataclass
class Mode:
    """Assembly mode of one diagonal block: its bodies and the sign of its determinant."""

    bodies: tuple
    sign: int
    key: str                        # body named in assembly: branch:
    block: int = -1                 # index of the loop's own diagonal block in System.blocks


def diag(cm: CompiledModel, row: int | None, msg: str, severity="error") -> Diagnostic:
    line = cm.element_of_row(row).line if row is not None else None
    return Diagnostic(cm.spec.file, line, msg, severity)


def fmt_res(cm: CompiledModel, row: int, value: float) -> str:
    el = cm.element_of_row(row)
    from planarkin.elements import KINDS
    kind = KINDS[el.kind]
    if kind.row_unit(row - first_row(cm, row)) == "angle":
        v = value / cm.angle_factor
        return f"{abs(v):.3g} {cm.spec.angle_unit}"
    return f"{abs(value) * cm.L:.3g} {cm.spec.length_unit}"


def first_row(cm: CompiledModel, row: int) -> int:
    el = cm.row_element[row]
    return int(np.nonzero(cm.row_element == el)[0][0])


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


def apply_branch_hints(cm: CompiledModel, A) -> None:
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
            raise InputError([diag(cm, int(B.rows[0]),
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
                                     f"{fmt_res(cm, row, r[row])}")])
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


def describe_modes(cm: CompiledModel, A, limit: int = DESCRIBED_MODES) -> list[str]:
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


def moved_points(cm, Q, tol: float | None = None) -> list:
    """Warnings for the points placed by global coordinates (sketch pins, ``at:`` points) that
    the assembly moved: the sketch did not satisfy every joint and driver at t = start (e.g. a
    driver's f(start) differs from the sketched crank angle). Q: (n + 3,) assembled coordinates
    with the ground's, internal units. One warning per point moved by more than the model's
    `assembly: sketch_tolerance` (default 1e-9 of the model's length scale; tol, when given, in
    its place), at its line."""
    spec = cm.spec
    p, _, _ = point_kinematics(cm, Q[None, :])
    out = []
    for k, pt in enumerate(spec.points):
        if pt.at is None:
            continue
        d = math.hypot(p[0, k, 0] * cm.L - pt.at[0], p[0, k, 1] * cm.L - pt.at[1])
        if d > (tol if tol is not None else spec.sketch_tolerance
                if spec.sketch_tolerance is not None else 1e-9 * cm.L):
            out.append(Diagnostic(spec.file, pt.line, f"point '{pt.name}': the sketched position "
                                  f"[{pt.at[0]:.10g}, {pt.at[1]:.10g}] is not consistent with the "
                                  f"joints and drivers at t = start; assembled {d:.3g} "
                                  f"{spec.length_unit} away, at [{p[0, k, 0] * cm.L:.10g}, "
                                  f"{p[0, k, 1] * cm.L:.10g}]", "warning"))
    return out


def keep_drawn_branches(cm, A) -> None:
    """A rough sketch is assembled on the branches it draws. When the assembly moved a sketched
    point, every loop with two assemblies (a diagonal block's determinant sign, as
    `assembly: branch:` reads it) is compared with its sign at the sketch's own poses (cm.q0:
    each link's frame at its drawn pins); a loop that the assembly closed the other way is
    re-assembled the drawn way, unless `assembly: branch:` names it. Raises InputError, at the
    loop's first link, when the lengths and drivers cannot close it the drawn way at t = start.
    A: the Assembly, updated in place (q, residual, modes)."""
    spec = cm.spec
    Q = A.system.ext(A.q[None, :])[0]
    if not moved_points(cm, Q, 1e-9 * cm.L):
        return                       # the sketch is the pose: its branches are the drawn ones
    drawn = {md.block: md for md in block_modes(cm, A.system, cm.q0)}
    asked = {md.block for md in A.modes if set(md.bodies) & set(spec.branch)}
    hints = {md.key: drawn[md.block].sign for md in A.modes
             if md.block in drawn and md.block not in asked and md.sign != drawn[md.block].sign}
    if not hints:
        return
    lines = {b.name: b.line for b in spec.bodies}
    cm2 = replace(cm, spec=replace(spec, branch={**hints, **spec.branch},
                                   branch_lines={**{k: lines.get(k) for k in hints},
                                                 **spec.branch_lines}))
    try:
        apply_branch_hints(cm2, A)
    except InputError as e:
        key = next(iter(hints))
        loop = next(md for md in A.modes if md.key == key)
        raise InputError([Diagnostic(spec.file, lines.get(key),
                                     f"the sketch draws the loop {'+'.join(loop.bodies)} on "
                                     f"branch {'+' if hints[key] > 0 else '-'}, but with its "
                                     f"lengths and drivers it closes at t = "
                                     f"{spec.analysis.start:g} only the other way; redraw it "
                                     f"({e.diagnostics[0].message})")]) from None
    A.modes = block_modes(cm, A.system, A.q)
