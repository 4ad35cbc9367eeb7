"""A pin following a curve of another body: a curved slot or a track (issue 8, item 4).

The curve is a table of points in the frame of body i, interpolated by a quintic spline in the
chord-length parameter (periodic for a closed curve; not-a-knot ends for an open one): C4, so
positions, velocities, accelerations (and jerks) of the pin are continuous, and every derivative
used is an exact derivative of the interpolant. Quintic rather than cubic because the
acceleration of a pin on a curve depends on the curve's curvature, which a cubic spline of a
circle through 2160 points gets right only to 7e-7 and the quintic to 2e-10.

Formulation without an extra coordinate (reference §4 adds the curve parameter alpha as a
generalised coordinate; the model has exactly 3 per body): the pin p' = A_i^T (r_j + A_j s'_j -
r_i), seen in body i, must have zero signed distance to the curve,

    g = d(p') = n(alpha*)^T (p' - c(alpha*)),   alpha* the closest point's parameter,

with n = R t the left normal of the unit tangent t. The signed distance has the exact gradient
n(alpha*) and Hessian -kappa / (1 - kappa d) t t^T (kappa the signed curvature at alpha*), so
Phi_q and gamma are exact expressions of the interpolant at alpha*; alpha* itself is found by
Newton's method on (c - p')^T c' = 0 to machine precision (d is stationary in alpha there, so
its error is second order in that of alpha*). An open curve ends: a pin whose closest point is
an end of the table is off the curve, and g is NaN (the run stops there with a failure).
"""

from __future__ import annotations

import numpy as np

from . import jerk as J
from .base import Kind, Param, body_velocity, omega, rotate


class Curve:
    """Quintic spline through points (M, 2) (internal units, body frame); closed: periodic."""

    SAMPLES = 512                       # coarse samples along the curve for the projection
    CANDIDATES = 4                      # nearest samples by the k-d tree, compared exactly

    def __init__(self, points, closed: bool):
        from scipy.interpolate import make_interp_spline

        P = np.asarray(points, dtype=float)
        self.points, self.closed = P, bool(closed)
        if closed:
            P = np.vstack([P, P[:1]])
        a = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(P, axis=0).T))])
        self.a0, self.a1 = 0.0, float(a[-1])
        spline = make_interp_spline(a, P, k=5, bc_type="periodic" if closed else None)
        # the same spline as polynomial pieces: Taylor coefficients c^(v)(x_m) / v! at each
        # piece's start, so that c, c', c'' come from one vectorised Horner pass
        x = np.unique(np.clip(spline.t, 0.0, self.a1))
        fact = np.array([1.0, 1.0, 2.0, 6.0, 24.0, 120.0])
        self.breaks = x
        self.coef = np.stack([spline(x[:-1], v) / fact[v] for v in range(6)])   # (6, pieces, 2)
        # at least two per table interval: Newton starts within half an interval of the answer
        self.grid = np.linspace(0.0, self.a1, max(self.SAMPLES, 2 * (len(P) - 1)) + 1)
        self.samples = self.eval(self.grid)[0]

    def scaled(self, factor: float) -> "Curve":
        return Curve(self.points * factor, self.closed)

    def eval(self, a):
        """c, c', c'' at parameters a (n,): three (n, 2) arrays."""
        a = np.asarray(a, dtype=float)
        if self.closed:
            a = np.mod(a, self.a1)
        m = np.clip(np.searchsorted(self.breaks, a, side="right") - 1, 0, len(self.breaks) - 2)
        h = (a - self.breaks[m])[:, None]
        C = self.coef[:, m, :]
        c0 = ((((C[5] * h + C[4]) * h + C[3]) * h + C[2]) * h + C[1]) * h + C[0]
        c1 = (((5 * C[5] * h + 4 * C[4]) * h + 3 * C[3]) * h + 2 * C[2]) * h + C[1]
        c2 = ((20 * C[5] * h + 12 * C[4]) * h + 6 * C[3]) * h + 2 * C[2]
        return c0, c1, c2

    def third(self, a):
        """c''' at parameters a (n,): (n, 2) (the jerk of a pin on the curve needs the
        derivative of its curvature)."""
        a = np.asarray(a, dtype=float)
        if self.closed:
            a = np.mod(a, self.a1)
        m = np.clip(np.searchsorted(self.breaks, a, side="right") - 1, 0, len(self.breaks) - 2)
        h = (a - self.breaks[m])[:, None]
        C = self.coef[:, m, :]
        return (60 * C[5] * h + 24 * C[4]) * h + 6 * C[3]

    def nearest_sample(self, p) -> np.ndarray:
        """Index of the sample nearest to each of p (n, 2), the first of equals: what the
        argmin over every sample's squared distance gives, found through a k-d tree of the
        samples. A table of every distance grows as the pins times the samples (a curve of
        10,000 points has 20,000 samples, a grid chunk thousands of pins); the tree's few
        nearest are compared by that same formula, so Newton's method starts where it did."""
        if getattr(self, "_tree", None) is None:
            from scipy.spatial import cKDTree
            self._tree = cKDTree(self.samples)
        n, k = len(p), min(self.CANDIDATES, len(self.samples))
        fin = np.isfinite(p).all(axis=1)
        out = np.zeros(n, dtype=np.intp)      # a point not finite: the first, as argmin gives
        if not fin.any():
            return out
        q = p[fin]
        _, idx = self._tree.query(q, k=k)
        idx = np.asarray(idx, dtype=np.intp).reshape(len(q), k)
        d2 = ((q[:, None, :] - self.samples[idx]) ** 2).sum(axis=2)
        # among the nearest, the lowest index (argmin over all samples breaks ties so)
        low = d2.min(axis=1, keepdims=True)
        tied = np.where(d2 == low, idx, len(self.samples))
        out[fin] = np.where(np.isfinite(low[:, 0]), tied.min(axis=1), 0)   # all inf: the first
        return out

    def project(self, p):
        """Closest points of p (n, 2): (alpha (n,), c, c', c'' (n, 2), off (n,) bool: beyond an
        end of an open curve)."""
        p = np.asarray(p, dtype=float)
        a = self.grid[self.nearest_sample(p)]
        step = self.a1 / (len(self.grid) - 1)
        last = False
        for _ in range(30):
            c, c1, c2 = self.eval(a)
            e = c - p
            f = (e * c1).sum(axis=1)
            fp = (c1 * c1).sum(axis=1) + (e * c2).sum(axis=1)
            fp = np.where(fp > 0, fp, (c1 * c1).sum(axis=1))     # keep going downhill
            da = np.clip(-f / fp, -step, step)
            a = a + da
            if not self.closed:
                a = np.clip(a, self.a0, self.a1)
            if last:
                break
            # quadratic convergence: one more step after 1e-12 reaches the rounding floor
            last = bool(np.all(np.abs(da) <= 1e-12 * self.a1))
        c, c1, c2 = self.eval(a)
        off = np.zeros(len(a), bool) if self.closed else (a <= self.a0) | (a >= self.a1)
        return a, c, c1, c2, off

    def __repr__(self) -> str:
        return f"Curve({len(self.points)} points, {'closed' if self.closed else 'open'})"


def _geometry(G, F):
    """Per state and instance: the pin in body i (p'), its closest point, unit tangent and normal
    (global), curvature, signed distance; plus s_j and Delta = r_j + s_j - r_i (global)."""
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    sj = G.params["sj"]
    sjx, sjy = rotate(F, bj, sj[:, 0], sj[:, 1])
    Dx = F.q[:, 3 * bj] + sjx - F.q[:, 3 * bi]
    Dy = F.q[:, 3 * bj + 1] + sjy - F.q[:, 3 * bi + 1]
    ci, si = F.c[:, bi], F.s[:, bi]
    px, py = ci * Dx + si * Dy, -si * Dx + ci * Dy          # A_i^T Delta
    N, K = px.shape
    tx, ty, kap, d = (np.empty((N, K)) for _ in range(4))
    curves = G.params["curve"]
    for cv in {id(x): x for x in curves}.values():
        cols = [k for k, x in enumerate(curves) if x is cv]
        P = np.stack([px[:, cols], py[:, cols]], axis=-1).reshape(-1, 2)
        _, c, c1, c2, off = cv.project(P)
        sp = np.hypot(c1[:, 0], c1[:, 1])
        ux, uy = c1[:, 0] / sp, c1[:, 1] / sp
        dist = -uy * (P[:, 0] - c[:, 0]) + ux * (P[:, 1] - c[:, 1])
        dist[off] = np.nan
        k_ = (c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]) / sp**3
        shape = (N, len(cols))
        tx[:, cols], ty[:, cols] = ux.reshape(shape), uy.reshape(shape)
        kap[:, cols], d[:, cols] = k_.reshape(shape), dist.reshape(shape)
    gx, gy = rotate(F, bi, tx, ty)                          # global tangent
    return d, gx, gy, -gy, gx, kap, sjx, sjy, Dx, Dy


class CurveSlot(Kind):
    name = "curve-slot"
    reaction_columns = ("fx", "fy", "torque")
    sampled_zeros = False     # straight pieces, dwells: zeros on whole regions
    params = (
        Param("sj", "point", "the pin on body j in its frame"),
        Param("curve", "curve", "the curve in the frame of body i: a list of points [[x, y], ...] "
              "(at least 6; a closed curve does not repeat its first point), {table: FILE.csv} "
              "(x, y columns), or exact: {circle: {centre, radius}} or {segments: [{line: {from, "
              "to}}, {arc: {centre, radius, from, to}}, ...]} joined tangentially"),
        Param("closed", "flag", "true: a closed table curve (a periodic spline); a circle or a "
              "chain of segments is closed by its geometry", required=False, default=False),
    )
    reaction_sign = (
        'fx, fy: the force of the curve (body i) on the pin j, normal to the curve at the pin (no '
        'friction); no moment about the pin. Body i gets minus it')
    summary = ("pin sj of j follows a curve of body i (a curved slot, a track): exact lines and "
               "arcs, or a table of points interpolated by a quintic spline (1 equation)")
    equations = "signed distance of A_i^T (r_j + A_j s'_j - r_i) to the curve = 0"

    def validate(self, V, params, given, what):
        if hasattr(params.get("curve"), "segments") and params.get("closed") \
                and not params["curve"].closed:
            V.err(given["closed"], f"{what}: closed: true, but the curve's last segment does "
                                   f"not end where its first starts (a circle or a chain of "
                                   f"segments is closed by its geometry; drop closed)")

    def diagnose(self, arrays, L, af, lu, au):
        cv = arrays["curve"]
        return cv.problems(L, lu) if hasattr(cv, "problems") else []

    def g(self, G, F):
        return _geometry(G, F)[0][..., None]

    def grad(self, G, F):
        d, tx, ty, nx, ny, kap, sjx, sjy, Dx, Dy = _geometry(G, F)
        out = np.empty((F.q.shape[0], len(G), 1, 6))
        # n^T R v = -n_x v_y + n_y v_x
        out[..., 0, 0] = -nx
        out[..., 0, 1] = -ny
        out[..., 0, 2] = -(ny * Dx - nx * Dy)
        out[..., 0, 3] = nx
        out[..., 0, 4] = ny
        out[..., 0, 5] = ny * sjx - nx * sjy
        return out

    def gamma(self, G, F):
        d, tx, ty, nx, ny, kap, sjx, sjy, Dx, Dy = _geometry(G, F)
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        wi, wj = omega(F, bi), omega(F, bj)
        vxi, vyi = body_velocity(F, bi)
        vxj, vyj = body_velocity(F, bj)
        ddx = vxj - wj * sjy - vxi                          # Delta-dot
        ddy = vyj + wj * sjx - vyi
        # gamma = n^T (2 w_i R Delta' + w_i^2 Delta + w_j^2 s_j) + kappa/(1 - kappa d) (t^T
        # (Delta' - w_i R Delta))^2 (derivation in the module docstring's terms)
        lin = (nx * (2 * wi * -ddy + wi * wi * Dx + wj * wj * sjx)
               + ny * (2 * wi * ddx + wi * wi * Dy + wj * wj * sjy))
        rel = tx * (ddx + wi * Dy) + ty * (ddy - wi * Dx)
        return (lin + kap / (1.0 - kap * d) * rel * rel)[..., None]

    def jerk(self, G, F):
        # Along the motion, the pin's closest point moves at the arc-length rate
        # beta = u / (1 - kappa d) with u = t^T W1 (from (p' - c)^T c' = 0), and
        #   d'   = n^T W1,   d'' = n^T W2 - kappa beta u,
        #   d''' = n^T W3 - kappa beta t^T W2 - (kappa_s beta^2 u + kappa beta' u + kappa beta u')
        # with u' = kappa beta d' + t^T W2, kappa_s = dkappa/ds, and W1, W2, W3 the body-i-frame
        # derivatives of Delta seen globally: W1 = Delta' - w_i R Delta, W(k+1) = Wk' - w_i R Wk.
        d, tx, ty, nx, ny, kap, sjx, sjy, Dx, Dy = _geometry(G, F)
        ks = _curvature_rate(G, F)
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        D = J.add(J.point(F, bj, (sjx, sjy)), J.origin(F, bi), -1.0)
        wi, ai = omega(F, bi), J.alpha(F, bi)
        R = lambda v: (-v[1], v[0])                              # noqa: E731
        lin = lambda *terms: (sum(c * v[0] for c, v in terms), sum(c * v[1] for c, v in terms))
        W1 = lin((1.0, D[1]), (-wi, R(D[0])))
        W2 = lin((1.0, D[2]), (-ai, R(D[0])), (-2.0 * wi, R(D[1])), (-wi * wi, D[0]))
        # W3 without q''': W2' - w R W2, with Delta''' -> its part s3_j, and phi_i'''
        # R Delta left out
        W3 = lin((1.0, D[3]), (-3.0 * ai, R(D[1])), (-2.0 * wi, R(D[2])), (-2.0 * wi * ai, D[0]),
                 (-wi * wi, D[1]), (-wi, R(W2)))
        tdot = lambda v: tx * v[0] + ty * v[1]                  # noqa: E731
        ndot = lambda v: nx * v[0] + ny * v[1]                  # noqa: E731
        u = tdot(W1)
        d1 = ndot(W1)
        m = 1.0 - kap * d
        beta = u / m
        tW2 = tdot(W2)
        u1 = kap * beta * d1 + tW2
        beta1 = (u1 * m + u * (ks * beta * d + kap * d1)) / (m * m)
        d3 = (ndot(W3) - kap * beta * tW2
              - (ks * beta * beta * u + kap * beta1 * u + kap * beta * u1))
        return -d3[..., None]

    def draw(self, G, k, parts):
        """The slot or track itself, its whole length, on body i (a line on the frame, dashed
        on a moving body); the pin's path shows only the part it runs along."""
        parts.joint_points(G, k)
        cv = G.params["curve"][k]
        parts.outline(parts.body(G, k, 0), cv.eval(np.linspace(cv.a0, cv.a1, 241))[0] * parts.L)


def _curvature_rate(G, F):
    """(N, K) dkappa/ds at every pin's closest point: (c' x c''') / sigma^4 - 3 (c' x c'')
    (c' . c'') / sigma^6, sigma = |c'|."""
    bi, bj = G.bodies[:, 0], G.bodies[:, 1]
    sj = G.params["sj"]
    sjx, sjy = rotate(F, bj, sj[:, 0], sj[:, 1])
    Dx = F.q[:, 3 * bj] + sjx - F.q[:, 3 * bi]
    Dy = F.q[:, 3 * bj + 1] + sjy - F.q[:, 3 * bi + 1]
    ci, si = F.c[:, bi], F.s[:, bi]
    px, py = ci * Dx + si * Dy, -si * Dx + ci * Dy
    N, K = px.shape
    out = np.empty((N, K))
    curves = G.params["curve"]
    for cv in {id(x): x for x in curves}.values():
        cols = [k for k, x in enumerate(curves) if x is cv]
        P = np.stack([px[:, cols], py[:, cols]], axis=-1).reshape(-1, 2)
        a, _, c1, c2, _ = cv.project(P)
        c3 = cv.third(a)
        sp2 = (c1 * c1).sum(axis=1)
        x2 = c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]
        x3 = c1[:, 0] * c3[:, 1] - c1[:, 1] * c3[:, 0]
        dot = (c1 * c2).sum(axis=1)
        out[:, cols] = (x3 / sp2 ** 2 - 3.0 * x2 * dot / sp2 ** 3).reshape(N, len(cols))
    return out
