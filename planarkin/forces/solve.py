"""Kinetostatics: the Lagrange multipliers of a kinematically driven mechanism and what follows
from them (reference forces-and-motion-laws.md §1).

With physical coordinates p = S z (S = diag(L, L, 1) per body: the model's length unit and
radians; z the solver's internal coordinates), the equations of motion M p'' + Phi_p^T lambda =
Q^A with Phi_p = Phi_z S^-1 give

    Phi_z^T lambda = S (Q^A - Q^in),

solved per grid point with the transposed Jacobian of the active (non-redundant) rows. Q^in is
the inertia force written at each body frame's origin, the centre of mass c being elsewhere:
Q^in_r = m a_c, Q^in_phi = J_c alpha + s_c x m a_c (s_c = A s'_c, a_c = r'' + alpha R s_c -
omega^2 s_c); it holds the quadratic-velocity term of the reference's coupled mass matrix.

The reaction of an element (its rows k) on body b is the generalised force -S_b^-1 Phi^k_{z_b}^T
lambda^k: a global force (fx, fy) and a moment about the body frame's origin, moved here to the
element's point P (`Kind.reaction_point`: the point sj of body j, for kinds that have it):
M_P = M_o - (P - r_b) x F.

Machine elements whose equations are not written at their contact (a cam as a motion law, a
gear pair or a belt as a ratio of angles) give their physical reaction W^k(lambda^k) instead
(`Kind.reaction`: the contact force where the contact is, on i and j only). It differs from
-Phi^k_z^T lambda^k by D^k, a generalised force that does no work on the motions the other
joints allow, so the equations of motion with the physical reactions,

    Phi_z^T lambda = S (Q^A - Q^in) + sum_k D^k(lambda^k),

have the same lambda^k on the machine elements' own rows, and the others (the bearings, the
guides) take D: lambda = lambda_0 + Phi_z^-T D(lambda_0). That lambda^k is unchanged is checked
(MACHINE_TOL); a model where it is not (a gear whose centre is not its bearing) is named.
"""

from __future__ import annotations

import numpy as np

from ..elements import JOINT_KINDS, KINDS
from ..elements.base import Kind, make_frame, pivots
from planarkin.solver.system import System
from .model import ForceModel, force_model

# what a joint of each kind transmits (the columns of forces.csv), as each kind states it
# (Kind.reaction_columns); the sign conventions are each kind's reaction_sign
JOINT_OUTPUT = {name: k.reaction_columns for name, k in JOINT_KINDS.items()}
# largest number of (point x coordinate^2) entries of a dense (N, n, n) stack solved at once
SOLVE_ENTRIES = 1 << 21
# up to this many coordinates one dense solve per point; beyond, the block-triangular form of
# the Jacobian (planarkin.solver.structure) is solved backwards, block by block: the transpose of a
# block lower-triangular matrix is block upper-triangular
DENSE_MAX = 60
BLOCK_MERGE = 12        # solve blocks of up to this many unknowns (as the path follower's)
MACHINE_TOL = 1e-9      # a machine element's own multipliers may change by this (relative to
                        # the largest) when its physical reaction replaces -Phi^T lambda
MACHINE_PASSES = 4      # corrections lambda_0 + Phi^-T D(lambda) at most (one suffices when
                        # the bearings alone take D, as they do in every example)


def physical_kind(kind) -> bool:
    """Whether the kind gives its own physical reaction (Kind.reaction is overridden)."""
    return type(kind).reaction is not Kind.reaction


def unplaced(cm) -> list:
    """[(element index, [names of its bodies whose centre is not known])] of the gear pairs and
    belts whose centres on their carrier are not known (their reaction setup's 'ok' is False:
    elements.gear.centre_on). Their reaction is the constraint's couples -Phi^T lambda, without
    the tooth force or the belt pull, which has no point to act at: the forces room warns."""
    piv = pivots(cm.groups)
    names = list(cm.body_names) + ["ground"]
    out = []
    for G in cm.groups:
        if not physical_kind(G.kind):
            continue
        setup = G.kind.reaction_setup(G, piv, cm.L)
        if not isinstance(setup, dict) or "ok" not in setup:
            continue
        for k in np.flatnonzero(~setup["ok"]):
            missing = [names[int(G.bodies[k, s])] for s, key in enumerate(("ci", "cj"))
                       if not np.isfinite(setup[key][k]).all()]
            out.append((int(cm.row_element[G.rows[k, 0]]), missing))
    return sorted(out)


class Kinetostatics:
    """The forces of a compiled model at given states.

    rows: the active rows (n of them; the redundant ones left out), default all. Call
    `solve(t, q, qd, qdd)` with user-unit arrays (N,), (N, 3 nb) x3; it returns a `Forces`.
    """

    def __init__(self, cm, rows=None, dense: bool | None = None):
        self.cm = cm
        self.fm: ForceModel = force_model(cm)
        self.system = System(cm)
        self.rows = np.arange(cm.m) if rows is None else np.asarray(rows, dtype=np.intp)
        if len(self.rows) != cm.n:
            raise ValueError(f"{len(self.rows)} active rows for {cm.n} coordinates")
        L = cm.L
        self.S = np.tile([L, L, 1.0], cm.nb + 1)          # physical per internal, ground too
        piv = pivots(cm.groups)
        self.setups = [G.kind.reaction_setup(G, piv, cm.L) for G in cm.groups]
        self.machine = [gi for gi, G in enumerate(cm.groups) if physical_kind(G.kind)]
        self.dense = cm.n <= DENSE_MAX if dense is None else dense
        self.blocked = None
        if self.dense:
            self._gather = self._transposed_gather()
        if not self.dense:
            S = System(cm, self.rows)
            S.build_blocks()
            self.blocked = S.merged(BLOCK_MERGE)

    @property
    def points_per_solve(self) -> int:
        """Grid points solved at once (bounds the memory of the dense stacks)."""
        cm = self.cm
        if self.dense:
            return max(16, SOLVE_ENTRIES // max(1, cm.m * (cm.n + 3)))
        return max(16, SOLVE_ENTRIES // max(1, 4 * (cm.n + 3)))

    # -- applied and inertia forces ---------------------------------------------------------------
    def generalised_forces(self, t, p, pd, pdd):
        """(Q^A, Q^in): two (N, 3 nb) arrays, physical units (force, force, torque), from the
        physical coordinates p, velocities pd and accelerations pdd (N, 3 nb; radians)."""
        fm = self.fm
        N = p.shape[0]
        nb = fm.nb
        phi, w, al = p[:, 2::3], pd[:, 2::3], pdd[:, 2::3]
        c, s = np.cos(phi), np.sin(phi)
        scx = c * fm.cm[:, 0] - s * fm.cm[:, 1]
        scy = s * fm.cm[:, 0] + c * fm.cm[:, 1]
        m = fm.mass
        acx = pdd[:, 0::3] - al * scy - w * w * scx
        acy = pdd[:, 1::3] + al * scx - w * w * scy
        Qin = np.empty((N, 3 * nb))
        Qin[:, 0::3] = m * acx
        Qin[:, 1::3] = m * acy
        Qin[:, 2::3] = fm.inertia * al + m * (scx * acy - scy * acx)
        QA = np.zeros((N, 3 * nb + 3))                     # ground columns collect, then dropped
        gx, gy = fm.gravity
        QA[:, 0:3 * nb:3] = m * gx
        QA[:, 1:3 * nb:3] = m * gy
        QA[:, 2:3 * nb:3] = m * (scx * gy - scy * gx)
        # extended pose: ground (index nb) at the origin, at rest
        z = np.zeros((N, 1))
        ce, se = np.hstack([c, z + 1]), np.hstack([s, z])
        X, Y = np.hstack([p[:, 0::3], z]), np.hstack([p[:, 1::3], z])
        VX, VY, W = np.hstack([pd[:, 0::3], z]), np.hstack([pd[:, 1::3], z]), np.hstack([w, z])
        for b, sp, (ffx, ffy) in zip(fm.force_body, fm.force_s, fm.force_f):
            Fx = np.broadcast_to(ffx(t), (N,))
            Fy = np.broadcast_to(ffy(t), (N,))
            sx = ce[:, b] * sp[0] - se[:, b] * sp[1]
            sy = se[:, b] * sp[0] + ce[:, b] * sp[1]
            QA[:, 3 * b] += Fx
            QA[:, 3 * b + 1] += Fy
            QA[:, 3 * b + 2] += sx * Fy - sy * Fx
        for b, f in zip(fm.torque_body, fm.torque_f):
            QA[:, 3 * b + 2] += np.broadcast_to(f(t), (N,))
        if len(fm.spring_i):
            self._springs(QA, ce, se, X, Y, VX, VY, W)
        return QA[:, :3 * nb], Qin

    def _springs(self, QA, ce, se, X, Y, VX, VY, W):
        fm = self.fm
        bi, bj = fm.spring_i, fm.spring_j
        pts = []
        for b, sp in ((bi, fm.spring_si), (bj, fm.spring_sj)):
            sx = ce[:, b] * sp[:, 0] - se[:, b] * sp[:, 1]
            sy = se[:, b] * sp[:, 0] + ce[:, b] * sp[:, 1]
            pts.append((sx, sy, X[:, b] + sx, Y[:, b] + sy,
                        VX[:, b] - W[:, b] * sy, VY[:, b] + W[:, b] * sx))
        (six, siy, px, py, vpx, vpy), (sjx, sjy, qx, qy, vqx, vqy) = pts
        dx, dy = qx - px, qy - py
        ell = np.hypot(dx, dy)
        with np.errstate(all="ignore"):
            ux, uy = dx / ell, dy / ell
        ldot = ux * (vqx - vpx) + uy * (vqy - vpy)
        T = fm.spring_k * (ell - fm.spring_l0) + fm.spring_c * ldot   # tension (N, S)
        Fx, Fy = T * ux, T * uy                                        # on i at P; minus on j
        for sign, b, sx, sy in ((1.0, bi, six, siy), (-1.0, bj, sjx, sjy)):
            for k in range(len(b)):
                col = 3 * int(b[k])
                QA[:, col] += sign * Fx[:, k]
                QA[:, col + 1] += sign * Fy[:, k]
                QA[:, col + 2] += sign * (sx[:, k] * Fy[:, k] - sy[:, k] * Fx[:, k])

    # -- the multipliers -------------------------------------------------------------------------
    def solve(self, t, q, qd, qdd, applied=None) -> "Forces":
        """Forces at the states (user units: lengths, the model's angle unit). applied: their
        (Q^A, Q^in) from generalised_forces when already computed (the refusal check's)."""
        cm = self.cm
        n = cm.n
        af = cm.angle_factor
        unit = np.tile([1.0, 1.0, af], cm.nb)
        p, pd, pdd = q * unit, qd * unit, qdd * unit
        t = np.asarray(t, dtype=float)
        N = len(t)
        QA, Qin = self.generalised_forces(t, p, pd, pdd) if applied is None else applied
        Qz = np.hstack([p / self.S[:n], np.zeros((N, 3))])
        F = self.system.frame(Qz)
        grads = [G.grad(F) for G in cm.groups]
        rhs = self.S[:n] * (QA - Qin)
        solve = (lambda r: self._dense(grads, r)) if self.dense else \
            (lambda r: self._blocks(F, r))
        lam0 = solve(rhs)
        lam, moved = self._machine(F, grads, lam0, solve)
        _, NU, _ = self.system.driver_values(t)
        return Forces(self, t, p, lam, NU, grads, QA, Qin, F, moved)

    def _machine(self, F, grads, lam0, solve):
        """(lambda, moved): the multipliers with the machine elements' physical reactions (module
        docstring), and {element index: (N,) rows} where its own multipliers moved by more than
        MACHINE_TOL (its reaction there is not what the bearings alone can take: refused, NaN)."""
        if not self.machine:
            return lam0, {}
        cm = self.cm
        N = lam0.shape[0]
        own = np.concatenate([cm.groups[gi].rows.ravel() for gi in self.machine])
        lam = lam0
        for _ in range(MACHINE_PASSES):
            D = np.zeros((N, cm.n + 3))
            for gi in self.machine:
                G = cm.groups[gi]
                L = lam[:, G.rows]                                  # (N, K, neq)
                W = G.kind.reaction(G, F, L, self.setups[gi])
                Wg = -np.einsum("nke,nkec->nkc", L, grads[gi])
                diff = W.reshape(Wg.shape) - Wg
                np.add.at(D, (slice(None), G.cols.ravel()), diff.reshape(N, -1))
            new = lam0 + solve(D[:, :cm.n])
            with np.errstate(invalid="ignore"):
                step = np.abs(new[:, own] - lam[:, own]).max(initial=0.0)
            lam = new
            if not step > MACHINE_TOL * max(np.abs(lam).max(initial=0.0), 1e-300):
                break
        with np.errstate(invalid="ignore"):
            scale = np.maximum(np.abs(lam).max(axis=1), 1e-300)
            off = np.abs(lam[:, own] - lam0[:, own]) > MACHINE_TOL * scale[:, None]
        moved: dict = {}
        for c in np.flatnonzero(off.any(axis=0)):
            e = int(cm.row_element[own[c]])
            moved[e] = moved.get(e, np.zeros(N, bool)) | off[:, c]
        return lam, moved


    def _transposed_gather(self) -> tuple:
        """(sizes, perm): the gradients of the groups (K, neq, nc) flattened and laid side by
        side, then a zero, hold every entry of Phi_z^T of the active rows and moving
        coordinates; perm (n * n,) says where each entry of that (n, n) matrix flattened
        (column c, active row i at c * n + i) is in them (the zero for structural zeros). Made
        once, so that each chunk's matrix is one copy of the gradients and one take (not a
        (N, m, n + 3) Jacobian filled by broadcast fancy indexing, then cut and transposed,
        which took several times as long; benchmarks/README.md, "Figures moved from the
        code's comments")."""
        cm = self.cm
        n = cm.n
        pos = np.full(cm.m, -1)
        pos[self.rows] = np.arange(n)
        sizes = [G.rows.size * G.cols.shape[1] for G in cm.groups]
        perm = np.full(n * n, sum(sizes))
        off = 0
        for G, size in zip(cm.groups, sizes):
            shape = G.rows.shape + (G.cols.shape[1],)
            r = np.broadcast_to(G.rows[:, :, None], shape).ravel()
            c = np.broadcast_to(G.cols[:, None, :], shape).ravel()
            keep = (pos[r] >= 0) & (c < n)
            perm[c[keep] * n + pos[r[keep]]] = off + np.flatnonzero(keep)
            off += size
        return sizes, perm

    def _dense(self, grads, rhs) -> np.ndarray:
        """lambda (N, m) from Phi_z^T lambda = rhs with the dense Jacobian of the active rows."""
        cm = self.cm
        N, n = rhs.shape
        sizes, perm = self._gather
        flat = np.empty((N, sum(sizes) + 1))
        off = 0
        for g, size in zip(grads, sizes):
            flat[:, off:off + size] = g.reshape(N, size)
            off += size
        flat[:, off] = 0.0
        At = np.take(flat, perm, axis=1).reshape(N, n, n)
        lam = np.zeros((N, cm.m))
        lam[:, self.rows] = np.linalg.solve(At, rhs[:, :, None])[..., 0]
        return lam

    def _blocks(self, F, rhs) -> np.ndarray:
        """The same by back substitution over the block-triangular form: the last block's
        columns only meet the last block's rows, so its multipliers come first; each solved
        block's rows are then taken out of the right-hand side of every column they touch."""
        S = self.blocked
        N, n = rhs.shape
        r = np.zeros((N, n + 3))
        r[:, :n] = rhs
        lam = np.zeros((N, self.cm.m))
        for B in reversed(S.blocks):
            grads = S.block_grads(B, F)
            M = S.block_matrix(B, grads)                       # rows B.rows, columns B.cols
            if len(B.cols) == 1:
                lb = r[:, B.cols] / M[:, 0, :]
            else:
                lb = np.linalg.solve(np.swapaxes(M, 1, 2), r[:, B.cols, None])[..., 0]
            lam[:, B.rows] = lb
            for p, g in zip(B.parts, grads):
                _, K, neq, nc = g.shape
                gr = g.reshape(N, K * neq, nc)[:, p.res_src]      # (N, rows of p, nc)
                cols = p.group.cols[p.res_src // neq]            # (rows of p, nc)
                vals = gr * lb[:, p.res_dst, None]
                np.add.at(r, (slice(None), cols.ravel()), -vals.reshape(N, -1))
        return lam


class Forces:
    """Forces at N states. lam: (N, m) multipliers (internal row units; zero on left-out rows).

    reaction(e, slot): (fx, fy, torque about the element's point) of element e (index into
    spec.elements) on its body in position slot (0: i, 1: j, 2: k), three (N,) arrays: for a
    machine element the physical contact force (Kind.reaction), for others -Phi^T lambda.
    contact(e): the signed normal contact force of a cam (positive pressing), else None.
    effort(d): the effort of driver d (index into drivers): -lambda in the row's physical unit:
    torque on j for angle drivers, force on j along the driven coordinate otherwise.
    power(d): effort times the driver's rate f'(t) (W when lengths are m).
    ground(): (fx, fy, torque about the origin) that all joints and drivers exert on the ground.
    moved: {element: (N,) rows} where its own multipliers changed when its physical reaction
    was put in (the reaction is then not one the bearings alone take, see the module docstring:
    its reaction there is NaN, and the forces room's row check refuses the row).
    """

    def __init__(self, K: Kinetostatics, t, p, lam, NU, grads, QA, Qin, F=None, moved=None):
        self.K = K
        self.t = t
        self.p = p
        self.lam = lam
        self.NU = NU
        self.QA = QA
        self.Qin = Qin
        self.moved = dict(moved or {})
        cm = K.cm
        if F is None:
            F = make_frame(np.hstack([p / K.S[:cm.n], np.zeros((len(t), 3))]))
        self.F = F
        self._where = {}
        for gi, G in enumerate(cm.groups):
            for k in range(len(G)):
                self._where[int(cm.row_element[G.rows[k, 0]])] = (gi, k)
        self._grads = grads
        self._cache: dict = {}

    def _group(self, gi: int):
        """(W (N, K, nbody, 3) generalised forces in physical units: fx, fy, moment about each
        body frame's origin; reaction points (x, y) (N, K) physical, or None)."""
        if gi not in self._cache:
            K = self.K
            G = K.cm.groups[gi]
            lam = self.lam[:, G.rows]                                     # (N, K, neq)
            W = G.kind.reaction(G, self.F, lam, K.setups[gi]) if gi in K.machine else None
            if W is None:
                W = -np.einsum("nke,nkec->nkc", lam, self._grads[gi])
            N = len(self.t)
            W = W.reshape(N, len(G), G.kind.nbody, 3) / K.S[G.cols].reshape(
                len(G), G.kind.nbody, 3)
            P = G.kind.reaction_point(G, self.F, K.setups[gi])
            if P is not None:
                P = (P[0] * K.cm.L, P[1] * K.cm.L)
            self._cache[gi] = (W, P)
        return self._cache[gi]

    def _general(self, e: int):
        """(N, nbody, 3) generalised force of element e on its bodies: fx, fy, moment about each
        body frame's origin (physical units), its group and index there."""
        gi, k = self._where[e]
        return self._group(gi)[0][:, k], self.K.cm.groups[gi], k

    def _pose(self, b: int):
        nb = self.K.cm.nb
        if b == nb:
            z = np.zeros(len(self.t))
            return z, z, z
        return self.p[:, 3 * b], self.p[:, 3 * b + 1], self.p[:, 3 * b + 2]

    def point(self, e: int):
        """Global (x, y) of element e's reaction point (Kind.reaction_point: its point sj on
        body j, a gear's centre; None for kinds without one: the moment is about j's frame
        origin)."""
        gi, k = self._where[e]
        P = self._group(gi)[1]
        return None if P is None else (P[0][:, k], P[1][:, k])

    def reaction(self, e: int, slot: int = 1):
        # forces.csv asks once per column (fx, fy, torque): the moment and the refusals once
        key = ("reaction", e, slot)
        if key not in self._cache:
            self._cache[key] = self._reaction(e, slot)
        return self._cache[key]

    def _reaction(self, e: int, slot: int):
        gen, G, k = self._general(e)
        fx, fy, mo = gen[:, slot, 0], gen[:, slot, 1], gen[:, slot, 2]
        P = self.point(e)
        if P is not None:
            x, y, _ = self._pose(int(G.bodies[k, slot]))
            mo = mo - ((P[0] - x) * fy - (P[1] - y) * fx)
        if e in self.moved:
            bad = self.moved[e]
            fx, fy, mo = (np.where(bad, np.nan, v) for v in (fx, fy, mo))
        return fx, fy, mo

    def contact(self, e: int):
        """(N,) the signed normal contact force of element e (physical units), positive while
        its parts press on each other, or None for kinds without one (Kind.contact_force)."""
        gi, k = self._where[e]
        K = self.K
        G = K.cm.groups[gi]
        f = G.kind.contact_force(G, self.F, self.lam[:, G.rows], K.setups[gi])
        return None if f is None else f[:, k] / K.cm.L

    def effort(self, d: int) -> np.ndarray:
        cm = self.K.cm
        r = int(cm.driver_rows[d])
        kind = KINDS[cm.element_of_row(r).kind]
        Lr = cm.L if kind.target_unit == "length" else 1.0
        return -self.lam[:, r] / Lr

    def power(self, d: int) -> np.ndarray:
        r = int(self.K.cm.driver_rows[d])
        return -self.lam[:, r] * self.NU[:, r]

    def ground(self):
        """Sum over every element touching the ground of its generalised force on the ground
        (the ground frame is the global frame: the moment is about the origin)."""
        cm = self.K.cm
        nb = cm.nb
        out = np.zeros((len(self.t), 3))
        for e in self._where:
            gen, G, k = self._general(e)
            for slot, b in enumerate(G.bodies[k]):
                if b == nb:
                    out += gen[:, slot]
        return out[:, 0], out[:, 1], out[:, 2]
