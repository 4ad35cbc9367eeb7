"""A plain textbook kinematic solver, as written from Haug, "Computer-Aided Kinematics and
Dynamics of Mechanical Systems" (1989), ch. 3-4: the baseline of benchmarks/bench_speed.py.

Cartesian coordinates q = [x, y, phi] per body. Constraint functions are written generically,
one small object per element, each filling its rows of Phi, of the dense Jacobian Phi_q, of
nu = -Phi_t and of gamma = -(Phi_q qdot)_q qdot:

* revolute (Haug 3.3.4): r_i + A_i s'_i - r_j - A_j s'_j = 0
* translational (Haug 3.3.5, angle form): n_i^T (r_j + A_j s'_j - r_i - A_i s'_i) = 0 and
  phi_j - phi_i - c0 = 0, with n_i = A_i R v'_i the normal of the sliding axis
* angle driver (Haug 3.5): phi_j - phi_i - f(t) = 0

Per time step (Haug 3.6, kinematic analysis):

1. predictor: the quadratic Taylor expansion q_k + h qdot_k + h^2/2 qddot_k of the previous
   step (Haug's form; `predictor="previous"` starts from q_k instead);
2. Newton-Raphson on the full dense Jacobian: while ||Phi(q, t)||_inf > tol:
   solve Phi_q dq = -Phi with numpy.linalg.solve, q += dq (a new Jacobian every iteration);
3. velocity: Phi_q qdot = nu and acceleration: Phi_q qddot = gamma(q, qdot), with the same
   Jacobian evaluated once at the converged q (numpy.linalg.solve for each).

Nothing is vectorised across time steps and nothing exploits sparsity: this is the baseline that
people write, not a strawman either (Taylor predictor, residual test before each solve, so a
step whose predictor is already within tol costs no Newton solve at all).
"""

from __future__ import annotations

import math

import numpy as np


def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


_R90 = np.array([[0.0, -1.0], [1.0, 0.0]])


class _Element:
    neq = 0

    def _cols(self, b):
        return None if b is None else (3 * b, 3 * b + 1, 3 * b + 2)


class Revolute(_Element):
    neq = 2

    def __init__(self, i, j, si, sj):
        self.i, self.j = i, j
        self.si, self.sj = np.asarray(si, float), np.asarray(sj, float)

    def _body(self, q, b, s):
        if b is None:
            return np.zeros(2), s.copy(), np.zeros(2), 0.0    # r, A s', B s' (= R A s'), phi
        phi = q[3 * b + 2]
        As = _rot(phi) @ s
        return q[3 * b: 3 * b + 2], As, _R90 @ As, phi

    def phi(self, q, t, out):
        ri, Asi, _, _ = self._body(q, self.i, self.si)
        rj, Asj, _, _ = self._body(q, self.j, self.sj)
        out[:] = ri + Asi - rj - Asj

    def jac(self, q, J):
        _, _, Bsi, _ = self._body(q, self.i, self.si)
        _, _, Bsj, _ = self._body(q, self.j, self.sj)
        if self.i is not None:
            c = 3 * self.i
            J[:, c: c + 2] = np.eye(2)
            J[:, c + 2] = Bsi
        if self.j is not None:
            c = 3 * self.j
            J[:, c: c + 2] = -np.eye(2)
            J[:, c + 2] = -Bsj

    def nu(self, t, out):
        out[:] = 0.0

    def gamma(self, q, qd, t, out):
        _, Asi, _, _ = self._body(q, self.i, self.si)
        _, Asj, _, _ = self._body(q, self.j, self.sj)
        wi = 0.0 if self.i is None else qd[3 * self.i + 2]
        wj = 0.0 if self.j is None else qd[3 * self.j + 2]
        out[:] = Asi * wi * wi - Asj * wj * wj


class Translational(_Element):
    neq = 2

    def __init__(self, i, j, si, sj, vi, c0=0.0):
        self.i, self.j = i, j
        self.si, self.sj = np.asarray(si, float), np.asarray(sj, float)
        v = np.asarray(vi, float)
        self.vi = v / np.linalg.norm(v)
        self.c0 = c0

    def _state(self, q):
        def body(b, s):
            if b is None:
                return np.zeros(2), np.eye(2), 0.0
            return q[3 * b: 3 * b + 2], _rot(q[3 * b + 2]), q[3 * b + 2]
        ri, Ai, phii = body(self.i, self.si)
        rj, Aj, phij = body(self.j, self.sj)
        u = Ai @ self.vi
        n = _R90 @ u
        Asi, Asj = Ai @ self.si, Aj @ self.sj
        h = rj + Asj - ri - Asi
        return u, n, Asi, Asj, h, phii, phij

    def phi(self, q, t, out):
        u, n, Asi, Asj, h, phii, phij = self._state(q)
        out[0] = n @ h
        out[1] = phij - phii - self.c0

    def jac(self, q, J):
        u, n, Asi, Asj, h, _, _ = self._state(q)
        if self.i is not None:
            c = 3 * self.i
            J[0, c: c + 2] = -n
            J[0, c + 2] = -(u @ (h + Asi))
            J[1, c + 2] = -1.0
        if self.j is not None:
            c = 3 * self.j
            J[0, c: c + 2] = n
            J[0, c + 2] = u @ Asj
            J[1, c + 2] = 1.0

    def nu(self, t, out):
        out[:] = 0.0

    def gamma(self, q, qd, t, out):
        u, n, Asi, Asj, h, _, _ = self._state(q)
        wi = 0.0 if self.i is None else qd[3 * self.i + 2]
        wj = 0.0 if self.j is None else qd[3 * self.j + 2]
        rdi = np.zeros(2) if self.i is None else qd[3 * self.i: 3 * self.i + 2]
        rdj = np.zeros(2) if self.j is None else qd[3 * self.j: 3 * self.j + 2]
        hd = rdj + wj * (_R90 @ Asj) - rdi - wi * (_R90 @ Asi)
        out[0] = wi * wi * (n @ h) + 2.0 * wi * (u @ hd) + n @ (wj * wj * Asj - wi * wi * Asi)
        out[1] = 0.0


class AngleDriver(_Element):
    neq = 1

    def __init__(self, i, j, f, fd, fdd):
        self.i, self.j = i, j
        self.f, self.fd, self.fdd = f, fd, fdd

    def phi(self, q, t, out):
        pi = 0.0 if self.i is None else q[3 * self.i + 2]
        pj = 0.0 if self.j is None else q[3 * self.j + 2]
        out[0] = pj - pi - self.f(t)

    def jac(self, q, J):
        if self.i is not None:
            J[0, 3 * self.i + 2] = -1.0
        if self.j is not None:
            J[0, 3 * self.j + 2] = 1.0

    def nu(self, t, out):
        out[0] = self.fd(t)

    def gamma(self, q, qd, t, out):
        out[0] = self.fdd(t)


class System:
    """Phi, Phi_q (dense), nu and gamma of a list of elements."""

    def __init__(self, nb: int, elements):
        self.n = 3 * nb
        self.elements = list(elements)
        self.slices = []
        r = 0
        for e in self.elements:
            self.slices.append(slice(r, r + e.neq))
            r += e.neq
        self.m = r
        if self.m != self.n:
            raise ValueError(f"{self.m} equations for {self.n} coordinates: not square")

    @classmethod
    def from_mechanism(cls, mech) -> "System":
        els = [Revolute(*r) for r in mech.revolutes]
        els += [Translational(*tr) for tr in mech.translationals]
        els += [AngleDriver(*d) for d in mech.angle_drivers]
        return cls(mech.nb, els)

    def phi(self, q, t):
        out = np.empty(self.m)
        for e, s in zip(self.elements, self.slices):
            e.phi(q, t, out[s])
        return out

    def jacobian(self, q):
        J = np.zeros((self.m, self.n))
        for e, s in zip(self.elements, self.slices):
            e.jac(q, J[s])
        return J

    def nu(self, t):
        out = np.empty(self.m)
        for e, s in zip(self.elements, self.slices):
            e.nu(t, out[s])
        return out

    def gamma(self, q, qd, t):
        out = np.empty(self.m)
        for e, s in zip(self.elements, self.slices):
            e.gamma(q, qd, t, out[s])
        return out


class NotConverged(RuntimeError):
    pass


def solve(system: System, q0, t, tol=1e-10, maxit=20, predictor="taylor"):
    """Positions, velocities, accelerations at every time of t (K,), from the estimate q0 at
    t[0]. Returns (Q, Qd, Qdd, iterations), each (K, n) and (K,)."""
    t = np.asarray(t, dtype=float)
    K, n = len(t), system.n
    Q = np.empty((K, n))
    Qd = np.empty((K, n))
    Qdd = np.empty((K, n))
    its = np.zeros(K, dtype=np.int64)
    q = np.array(q0, dtype=float)
    qd = np.zeros(n)
    qdd = np.zeros(n)
    for k in range(K):
        tk = t[k]
        if k > 0 and predictor == "taylor":
            h = tk - t[k - 1]
            q = q + h * qd + 0.5 * h * h * qdd
        # Newton-Raphson, full dense Jacobian every iteration
        for it in range(maxit + 1):
            F = system.phi(q, tk)
            if np.abs(F).max() <= tol:
                break
            if it == maxit:
                raise NotConverged(f"Newton did not converge at t = {tk:.10g} "
                                   f"(|Phi| = {np.abs(F).max():.3g})")
            q = q - np.linalg.solve(system.jacobian(q), F)
        its[k] = it
        J = system.jacobian(q)
        qd = np.linalg.solve(J, system.nu(tk))
        qdd = np.linalg.solve(J, system.gamma(q, qd, tk))
        Q[k], Qd[k], Qdd[k] = q, qd, qdd
    return Q, Qd, Qdd, its


# -- self-check: Jacobian and gamma against finite differences --------------------------------

def _check(system: System, q, qd, t=0.3):
    h = 1e-7
    J = system.jacobian(q)
    Jfd = np.empty_like(J)
    for c in range(system.n):
        e = np.zeros(system.n)
        e[c] = h
        Jfd[:, c] = (system.phi(q + e, t) - system.phi(q - e, t)) / (2 * h)
    ej = np.abs(J - Jfd).max()
    # gamma = -(Phi_q qd)_q qd: the second directional derivative of the joint rows
    g = system.gamma(q, qd, t)
    d2 = (system.phi(q + h * 100 * qd, t) - 2 * system.phi(q, t)
          + system.phi(q - h * 100 * qd, t)) / (h * 100) ** 2
    jrows = np.ones(system.m, bool)
    for e, s in zip(system.elements, system.slices):
        if isinstance(e, AngleDriver):
            jrows[s] = False
    eg = np.abs(g[jrows] + d2[jrows]).max()
    return ej, eg


if __name__ == "__main__":
    import models
    rng = np.random.default_rng(1)
    for mech in (models.slider_crank_mechanism(), models.four_bar_mechanism(),
                 models.chain_mechanism(3)):
        S = System.from_mechanism(mech)
        ej, eg = _check(S, rng.normal(size=S.n), rng.normal(size=S.n))
        print(f"  {mech.name:14s} Jacobian vs FD {ej:.1e}, gamma vs FD {eg:.1e}")
        assert ej < 1e-6 and eg < 1e-4
    print("  textbook elements ok")
