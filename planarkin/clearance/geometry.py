"""Exact distance between two rounded point sets (planarkin.clearance.shape.Shape), at many
poses at once, with its exact first and second time derivatives.

A shape's core is a point, a segment, a filled simple polygon (closed) or a polyline (open);
the shape is every point within `radius` of its core. The distance between two shapes is the
distance between their cores less both radii. Between two disjoint cores the closest pair is
always a vertex of one against an edge of the other (an edge of one point for a circle), so
the distance is the smallest of every vertex-edge distance: found exactly, by closest features,
never by sampling an outline. The cores overlap where two edges cross or one closed core holds
a vertex of the other (the crossing number); the signed distance is then minus the depth of the
overlap, exact where both cores are convex (the separating-axis minimum over the edges'
normals), and 0 less the radii for a non-convex core (the overlap itself is exact).

The derivatives follow the closest features, both body-fixed: a vertex against a vertex, d =
|p - q|, d' = r.r'/d, d'' = (r'.r' + r.r'' - d'^2)/d; a vertex against an edge's interior,
d = n.(p - a) with the edge's unit normal n turning with its body (n' = w R n, n'' = al R n -
w^2 n). Both equal n.(v_pb - v_pa) at first order: no finite differences. Overlapping rows have
no derivative (nan): their distance is no smooth function to refine.

Arrays: N poses; lengths in the user's unit; angles in radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TINY = 1e-300


@dataclass(frozen=True)
class Core:
    """A shape's core in its body frame: points (k, 2), edges (e, 2) vertex index pairs (a
    point: one edge (0, 0)), closed (a filled polygon of k >= 3 points), convex, radius.
    Batched (`stack`): points (N, k, 2) and radius (N,), one shape per row, alike in k,
    closed and convex."""

    points: np.ndarray
    edges: np.ndarray
    closed: bool
    convex: bool
    radius: float


def core(points, radius: float, closed: bool) -> Core:
    """The Core of a rounded point set (points (k, 2), user length unit)."""
    P = np.asarray(points, dtype=float).reshape(-1, 2)
    k = len(P)
    if k == 1:
        E = np.array([[0, 0]])
    elif k == 2:
        E = np.array([[0, 1]])
    else:
        idx = np.arange(k)
        E = np.stack([idx, (idx + 1) % k], axis=1) if closed else \
            np.stack([idx[:-1], idx[1:]], axis=1)
    filled = bool(closed and k >= 3)
    convex = k <= 2 or (filled and is_convex(P))
    return Core(P, E, filled, convex, float(radius))


def stack(cores: list, n: int) -> Core:
    """One Core holding each of `cores` (alike in k, closed and convex) for n rows in turn:
    points (len(cores) n, k, 2), radius (len(cores) n,)."""
    c0 = cores[0]
    P = np.repeat(np.stack([c.points for c in cores]), n, axis=0)
    R = np.repeat(np.array([c.radius for c in cores], dtype=float), n)
    return Core(P, c0.edges, c0.closed, c0.convex, R)


def signature(c: Core) -> tuple:
    """What Cores must share to be stacked."""
    return (len(c.points), c.closed, c.convex)


def is_convex(P: np.ndarray) -> bool:
    """Whether the closed polygon through P (k >= 3, in order) is convex (either orientation)."""
    d = np.roll(P, -1, axis=0) - P
    c = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    scale = np.max(np.abs(d)) ** 2
    nz = c[np.abs(c) > 1e-12 * scale]
    return bool(len(nz) == 0 or (nz > 0).all() or (nz < 0).all())


def self_crossing(P) -> tuple[int, int] | None:
    """(i, j) of two non-adjacent edges of the closed polygon through P that meet, or None (a
    simple polygon); points (k, 2), k >= 3."""
    P = np.asarray(P, dtype=float)
    k = len(P)
    for i in range(k):
        a, b = P[i], P[(i + 1) % k]
        for j in range(i + 1, k):
            if j == i + 1 or (i == 0 and j == k - 1):
                # neighbours share a vertex; they cross only when they fold back on each other
                shared = b if j == i + 1 else a
                other_i = a if j == i + 1 else b
                other_j = P[(j + 1) % k] if j == i + 1 else P[j]
                u, w = other_i - shared, other_j - shared
                if abs(u[0] * w[1] - u[1] * w[0]) <= 1e-12 * (u @ u + w @ w) and u @ w > 0:
                    return i, j
                continue
            if _segments_meet(a, b, P[j], P[(j + 1) % k]):
                return i, j
    return None


def _segments_meet(a, b, c, d) -> bool:
    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    def on(p, q, r):
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and \
            min(p[1], q[1]) <= r[1] <= max(p[1], q[1])
    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if o1 * o2 < 0 and o3 * o4 < 0:
        return True
    return (o1 == 0 and on(a, b, c)) or (o2 == 0 and on(a, b, d)) or \
        (o3 == 0 and on(c, d, a)) or (o4 == 0 and on(c, d, b))


def convex_hull(P) -> np.ndarray:
    """The convex hull of points P (k, 2), counter-clockwise, collinear points dropped
    (Andrew's monotone chain); one or two points for degenerate sets."""
    pts = sorted(set(map(tuple, np.asarray(P, dtype=float))))
    if len(pts) <= 2:
        return np.array(pts, dtype=float).reshape(-1, 2)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1], dtype=float)


@dataclass
class Motion:
    """A body's motion at N poses: r (N, 2) origin, phi (N,) radians, their rates v (N, 2), w
    (N,) and accelerations a (N, 2), al (N,) (None: not computed)."""

    r: np.ndarray
    phi: np.ndarray
    v: np.ndarray | None = None
    w: np.ndarray | None = None
    a: np.ndarray | None = None
    al: np.ndarray | None = None
    cos: np.ndarray | None = None       # cos(phi), sin(phi) when known (a body's, computed
    sin: np.ndarray | None = None       # once for every pair it is in)

    def turn(self):
        """(cos phi, sin phi) (N,)."""
        if self.cos is None:
            self.cos, self.sin = np.cos(self.phi), np.sin(self.phi)
        return self.cos, self.sin

    def place(self, P: np.ndarray) -> np.ndarray:
        """World positions (N, k, 2) of body-frame points P (k, 2), or (N, k, 2): each row's
        own points (pairs of shapes batched row by row)."""
        c, s = np.cos(self.phi)[:, None], np.sin(self.phi)[:, None]
        return np.stack([self.r[:, None, 0] + c * P[..., 0] - s * P[..., 1],
                         self.r[:, None, 1] + s * P[..., 0] + c * P[..., 1]], axis=2)


@dataclass
class Separation:
    """Distance of two shapes at N poses: d (N,) signed (negative: overlapping), d1 and d2 its
    exact rate and acceleration (nan where overlapping, None above the motions' order), pa and
    pb (N, 2) the points of closest approach on the outlines of A and B (where overlapping:
    the deepest points along the separating axis)."""

    d: np.ndarray
    d1: np.ndarray | None
    d2: np.ndarray | None
    pa: np.ndarray
    pb: np.ndarray


def inside(X, V, E):
    """(N,) whether points X (N, 2) lie inside the closed polygons V (N, k, 2) with edges E
    (the crossing number)."""
    a, b = V[:, E[:, 0]], V[:, E[:, 1]]
    y = X[:, None, 1]
    up = (a[..., 1] <= y) != (b[..., 1] <= y)
    with np.errstate(invalid="ignore", divide="ignore"):
        xc = a[..., 0] + (y - a[..., 1]) * (b[..., 0] - a[..., 0]) / (b[..., 1] - a[..., 1])
    return ((up & (X[:, None, 0] < xc)).sum(axis=1) % 2) == 1


def _depth(xa, ya, A: Core, xb, yb, B: Core):
    """(depth, axis x, axis y (from A towards B), the deepest point of B x, y), arrays (n,),
    of convex cores that overlap, given their vertices componentwise: the smallest overlap of
    their projections on every edge normal (the separating axes)."""
    n = len(xa[0])
    best = np.full(n, np.inf)
    ax_, ay_ = np.ones(n), np.zeros(n)
    for xs, ys, C in ((xa, ya, A), (xb, yb, B)):
        for i0, i1 in C.edges:
            if i0 == i1:
                continue
            ex, ey = xs[i1] - xs[i0], ys[i1] - ys[i0]
            le = np.hypot(ex, ey)
            with np.errstate(invalid="ignore", divide="ignore"):
                nx, ny = -ey / le, ex / le
            pa = [nx * x + ny * y for x, y in zip(xa, ya)]
            pb = [nx * x + ny * y for x, y in zip(xb, yb)]
            amax, amin = np.maximum.reduce(pa), np.minimum.reduce(pa)
            bmax, bmin = np.maximum.reduce(pb), np.minimum.reduce(pb)
            fwd, back = amax - bmin, bmax - amin         # B pushed along +n, along -n
            over = np.minimum(fwd, back)
            sign = np.where(fwd <= back, 1.0, -1.0)
            better = (over < best) & (le > 0)
            best = np.where(better, over, best)
            ax_ = np.where(better, sign * nx, ax_)
            ay_ = np.where(better, sign * ny, ay_)
    best = np.where(np.isfinite(best), best, 0.0)           # two coincident points
    proj = np.stack([ax_ * x + ay_ * y for x, y in zip(xb, yb)])
    k = np.argmin(proj, axis=0)
    rows = np.arange(n)
    deep_x, deep_y = np.stack(xb)[k, rows], np.stack(yb)[k, rows]
    return best, ax_, ay_, deep_x, deep_y

def _world(C: Core, M: Motion):
    """The core's world vertices at M's poses: lists (k) of x and of y arrays (N,)."""
    c, s = M.turn()
    P = np.asarray(C.points)
    xs, ys = [], []
    for i in range(P.shape[-2]):
        px, py = P[..., i, 0], P[..., i, 1]
        xs.append(M.r[:, 0] + c * px - s * py)
        ys.append(M.r[:, 1] + s * px + c * py)
    return xs, ys


def _closest(xa, ya, A: Core, xb, yb, B: Core, N: int):
    """Every vertex of one core against every edge of the other, the closest kept per row:
    (squared distance, b_side (the vertex is B's), vertex x, y, edge ends x0, y0, x1, y1, the
    parameter s along the edge), componentwise arrays (N,)."""
    best = np.full(N, np.inf)
    keep = [np.zeros(N, dtype=bool)] + [np.zeros(N) for _ in range(7)]
    for vx, vy, ex, ey, E, flag in ((xb, yb, xa, ya, A.edges, True),
                                    (xa, ya, xb, yb, B.edges, False)):
        for i in range(len(vx)):
            for j0, j1 in E:
                x0, y0, x1, y1 = ex[j0], ey[j0], ex[j1], ey[j1]
                if j0 == j1:
                    s = np.zeros(N)
                    fx, fy = x0 - vx[i], y0 - vy[i]
                else:
                    dx, dy = x1 - x0, y1 - y0
                    L2 = dx * dx + dy * dy
                    with np.errstate(invalid="ignore", divide="ignore"):
                        s = ((vx[i] - x0) * dx + (vy[i] - y0) * dy) / L2
                    s = np.where(L2 > 0, np.clip(s, 0.0, 1.0), 0.0)
                    fx, fy = x0 + s * dx - vx[i], y0 + s * dy - vy[i]
                d2 = fx * fx + fy * fy
                better = d2 < best          # ties: the first found (B's vertices first)
                best = np.where(better, d2, best)
                for k, val in enumerate((flag, vx[i], vy[i], x0, y0, x1, y1, s)):
                    keep[k] = np.where(better, val, keep[k])
    return (best, *keep)


def _overlap(xa, ya, A: Core, xb, yb, B: Core, N: int):
    """(N,) whether the cores overlap beyond touching: two edges crossing, or a vertex of one
    inside the other's filled polygon (the crossing number)."""
    over = np.zeros(N, dtype=bool)
    if len(xa) > 1 and len(xb) > 1:
        for i0, i1 in A.edges:
            ax, ay, bx, by = xa[i0], ya[i0], xa[i1], ya[i1]
            for j0, j1 in B.edges:
                cx, cy, dx, dy = xb[j0], yb[j0], xb[j1], yb[j1]
                o1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
                o2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
                o3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
                o4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
                over |= (o1 * o2 < 0) & (o3 * o4 < 0)
    for C, xs, ys, px, py in ((A, xa, ya, xb[0], yb[0]), (B, xb, yb, xa[0], ya[0])):
        if not C.closed:
            continue
        odd = np.zeros(N, dtype=bool)
        for i0, i1 in C.edges:
            x0, y0, x1, y1 = xs[i0], ys[i0], xs[i1], ys[i1]
            up = (y0 <= py) != (y1 <= py)
            with np.errstate(invalid="ignore", divide="ignore"):
                xc = x0 + (py - y0) * (x1 - x0) / (y1 - y0)
            odd ^= up & (px < xc)
        over |= odd
    return over


def separation(A: Core, MA: Motion, B: Core, MB: Motion) -> Separation:
    """The Separation of shapes A and B moving with MA and MB (see the module's text).
    Componentwise over the rows (x and y arrays of each vertex): the cores have a few points
    each, the rows are many (benchmarks/bench_clearance.py)."""
    N = len(MA.phi)
    xa, ya = _world(A, MA)
    xb, yb = _world(B, MB)
    d2, b_side, vx, vy, x0, y0, x1, y1, s = _closest(xa, ya, A, xb, yb, B, N)
    dist = np.sqrt(d2)
    fx, fy = x0 + s * (x1 - x0), y0 + s * (y1 - y0)          # the foot on the edge
    over = (dist <= 0) | _overlap(xa, ya, A, xb, yb, B, N)
    # the closest points on the cores, as A's and B's, and the unit vector from A to B
    cax, cay = np.where(b_side, fx, vx), np.where(b_side, fy, vy)
    cbx, cby = np.where(b_side, vx, fx), np.where(b_side, vy, fy)
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = 1.0 / np.maximum(dist, TINY)
    ux, uy = (cbx - cax) * inv, (cby - cay) * inv
    ra, rb = np.asarray(A.radius, dtype=float), np.asarray(B.radius, dtype=float)
    rr = ra + rb
    d = dist - rr
    if over.any():
        k = np.flatnonzero(over)
        if A.convex and B.convex:
            depth, nx, ny, deep_x, deep_y = _depth([x[k] for x in xa], [y[k] for y in ya], A,
                                                   [x[k] for x in xb], [y[k] for y in yb], B)
        else:
            depth, nx, ny = np.zeros(len(k)), np.ones(len(k)), np.zeros(len(k))
            deep_x, deep_y = cbx[k], cby[k]
        d[k] = -depth - (rr[k] if rr.ndim else rr)
        ux[k], uy[k] = nx, ny
        cbx[k], cby[k] = deep_x, deep_y
        cax[k], cay[k] = deep_x + depth * nx, deep_y + depth * ny
    pa = np.stack([cax + ra * ux, cay + ra * uy], axis=1)
    pb = np.stack([cbx - rb * ux, cby - rb * uy], axis=1)
    degenerate = (x0 == x1) & (y0 == y1)
    at_end = (s <= 0.0) | (s >= 1.0) | degenerate
    d1, d2_ = _rates(MA, MB, b_side, vx, vy, fx, fy, at_end, dist)
    if d1 is not None:
        d1[over] = np.nan
    if d2_ is not None:
        d2_[over] = np.nan
    return Separation(d, d1, d2_, pa, pb)


def _rates(MA, MB, b_side, vx, vy, fx, fy, at_end, dist):
    """d' and d'' (N,) of the closest pair's distance (d'' None without accelerations): the
    vertex p against the closest point c of the other core's edge (its foot, or an end), c
    taken as fixed to the edge's body. With u = (p - c) / d and r' = p' - c', r'' = p'' - c''
    (body-fixed points' velocities and accelerations), d' = u.r' in both cases (the foot
    slides along the edge, at right angles to u); d'' = u.r'' + |r' - (u.r') u|^2 / d against
    an end (the distance of two points), u.r'' + 2 w_e (R u).r' - w_e^2 d against the edge's
    interior (the distance to the line, whose normal u turns with the edge's body at w_e,
    u' = w_e R u, u'' = al_e R u - w_e^2 u, with (R u).(p - c) = 0). Component-
    wise arithmetic on each row's two bodies, chosen once: no indexing by rows."""
    if MA.v is None or MB.v is None:
        return None, None
    acc = MA.a is not None and MB.a is not None

    def pick(x, y):                     # the vertex body's (b_side: B's) and the edge body's
        return np.where(b_side, y, x), np.where(b_side, x, y)
    (rvx, rex), (rvy, rey) = pick(MA.r[:, 0], MB.r[:, 0]), pick(MA.r[:, 1], MB.r[:, 1])
    (vvx, vex), (vvy, vey) = pick(MA.v[:, 0], MB.v[:, 0]), pick(MA.v[:, 1], MB.v[:, 1])
    wv, we = pick(MA.w, MB.w)
    gpx, gpy = vx - rvx, vy - rvy                   # p from its body's origin
    gcx, gcy = fx - rex, fy - rey                   # c from its body's origin
    r1x = (vvx - wv * gpy) - (vex - we * gcy)
    r1y = (vvy + wv * gpx) - (vey + we * gcx)
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = 1.0 / dist
        ux, uy = (vx - fx) * inv, (vy - fy) * inv      # nan where the cores touch
    d1 = ux * r1x + uy * r1y
    if not acc:
        return d1, None
    (avx, aex), (avy, aey) = pick(MA.a[:, 0], MB.a[:, 0]), pick(MA.a[:, 1], MB.a[:, 1])
    alv, ale = pick(MA.al, MB.al)
    wv2, we2 = wv * wv, we * we
    r2x = (avx - alv * gpy - wv2 * gpx) - (aex - ale * gcy - we2 * gcx)
    r2y = (avy + alv * gpx - wv2 * gpy) - (aey + ale * gcx - we2 * gcy)
    tx, ty = r1x - d1 * ux, r1y - d1 * uy             # r' across u
    end = (tx * tx + ty * ty) * inv
    # d = u.r with u turning at w_e: d'' = u.r'' + 2 u'.r' + u''.r, u' = w_e R u, u''.r = -w_e^2 d
    line = 2.0 * we * (ux * r1y - uy * r1x) - we2 * dist
    return d1, ux * r2x + uy * r2y + np.where(at_end, end, line)
