"""Loop figures for every run: the transmission angle and the velocity ratio (mechanical
advantage) of every four-bar and slider-crank loop, found from the joints as `planarkin check`
finds them (planarkin.measures.grashof), without a `measures:` block; and a warning for every
passage within the toggle margins below.

Each loop has an input (the grounded link the motion comes in by: the driven one, or one moved
by a loop or a gear or belt already resolved; when none is, the link that turns fully, else the
first grounded link: `input_from` says which) and an output (its other grounded link, or the
slider). With A, D the ground pivots of the crank-side link p and of the other link r, B and C
the coupler's pins on p and on r (a slider-crank: C the rod-slider pin, u the guide's unit axis,
n = u turned by +90 deg, a = |A B| the crank):

    transmission angle mu   the angle at the output's coupler pin between the coupler and the
                            output link, in [0, 180] deg (output r: at C between C->B and C->D;
                            output p, or the crank of a slider-driven slider-crank: at B
                            between B->C and B->A); a slider output: the acute angle between
                            the rod and the normal n to the guide, in [0, 90] deg. 90 deg is
                            ideal; 0 (or 180) is the toggle, where the coupler pulls straight
                            through the output's pivot and the output cannot be driven.
    velocity ratio R        output speed over input speed from the positions alone (the
                            instant-centre relation of the rigid coupler, (v_C - v_B).(C - B)
                            = 0): four-bar R = omega_r / omega_p = (B - A) x (C - B) /
                            ((C - D) x (C - B)) (its inverse when r drives); slider-crank
                            R = v_slider / (a omega_crank) = (B - A) x (C - B) / (a u.(C - B))
                            (its inverse when the slider drives). It equals the ratio of the
                            solved rates wherever the input moves, and stays defined where the
                            input stops (a dwell, a turning point).
    mechanical advantage    1 / R: the ideal output torque (force) over the input's.

Figures over the path followed (the path follower's nodes: exact solutions with exact rates):
the smallest and largest mu and the largest |R| (with the smallest mechanical advantage),
each with its time. Between nodes an extreme is located by Newton's method on its exact rate
(mu' and R' from the velocities, mu'' and R'' from the accelerations), every trial time solved
exactly on the path's branch: the values reported are values of solved poses, at their times.

Margins (a machine designer's): the classic rule calls a transmission angle outside 40-140 deg
poor (`poor` in the figures, no warning: four-bar.yaml's crank-rocker runs down to 29.9 deg);
a passage is a near-toggle, and warned of, when mu comes within TOGGLE_MARGIN_DEG of 0 or 180
deg or |R| exceeds RATIO_LIMIT (an output 50 times faster than its input: 1/50 of the input
torque reaches it; 1 deg from the toggle a four-bar's ratio is about 57 (a/c) sin(gamma), gamma
the input's own transmission angle, so the two margins agree in the common case).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TOGGLE_MARGIN_DEG = 1.0        # mu within this of 0 or 180 deg: a near-toggle passage (warned)
RATIO_LIMIT = 50.0             # |velocity ratio| output / input above this: warned
CLASSIC_RANGE_DEG = (40.0, 140.0)   # the classic good range of mu (outside: poor, not warned)
MAX_LOOPS = 64                 # loops analysed (in the order check lists them)
CANDIDATES = 4                 # local extremes per figure located exactly (the most extreme)
WATCH = 3.0                    # node estimates within WATCH x the margins are located exactly
FLAT = 1e-13                   # extremes that move less than this (of the figure's size) from
                               # the best node are not located (the node is the extreme)
MAX_NEWTON = 60                # Newton-bisection iterations per extreme (bisection alone: ~50)
GUIDE = ("gear", "belt", "gear-mesh", "rack-pinion", "roll-disc", "roll-line")
# joint kinds that tie one body's motion to another's (an input resolved through them)


@dataclass(frozen=True)
class LoopSpec:
    """One loop as the figures see it (internal units)."""

    kind: str           # 'four-bar' or 'slider-crank'
    links: tuple        # (ground, p, c, r) or (ground, crank, rod, slider) body names
    cls: str            # Grashof class (a slider-crank's: 'crank turns fully' when b > a + |e|,
                        # 'change point' at equality, else 'crank rocks')
    mode: int           # 0: p drives r; 1: r drives p; 2: the crank drives the slider;
                        # 3: the slider drives the crank
    input_from: str     # 'driver', 'loop' (moved by a resolved loop, gear or belt), 'assumed'
    p: int              # body index of p (the crank)
    r: int              # body index of r (the slider)
    A: tuple            # ground pivot of p, ground frame
    B: tuple            # p's pin to the coupler, p's frame
    C: tuple            # r's (the slider's) pin to the coupler, its frame
    D: tuple            # ground pivot of r, ground frame (a slider-crank: A)
    gb: int             # the body carrying the guide's axis (a four-bar: ground)
    vi: tuple           # the guide's unit axis in gb's frame (a four-bar: (1, 0))
    a: float            # |A B|, p's length
    sc: object = None   # the grashof.SliderCrank of a slider-crank loop

    @property
    def input(self) -> str:
        return self.links[1] if self.mode in (0, 2) else self.links[3]

    @property
    def output(self) -> str:
        return self.links[3] if self.mode in (0, 2) else self.links[1]

    def where(self) -> str:
        """Where its transmission angle is measured."""
        g, p, c, r = self.links
        if self.mode == 0:
            return f"at the {c}-{r} pin, between {c} and {r}"
        if self.mode == 2:
            return f"between {c} and the normal to the guide of {r}"
        return f"at the {p}-{c} pin, between {c} and {p}"


# -- the loops and their inputs ------------------------------------------------------------------

def loop_specs(cm) -> list[LoopSpec]:
    """Every four-bar loop, then every slider-crank loop of cm (at most MAX_LOOPS), each with its
    input resolved; computed once per compiled model."""
    got = cm.__dict__.get("_loop_specs")
    if got is None:
        got = _specs(cm)
        object.__setattr__(cm, "_loop_specs", got)
    return got


def _specs(cm) -> list[LoopSpec]:
    from .grashof import four_bar_loops, slider_crank_loops
    G = cm.nb
    fbs = [lp for lp in four_bar_loops(cm) if lp.bodies]
    scs = slider_crank_loops(cm)
    # bodies whose motion is given: driven relative to ground; ties: drivers between two
    # moving bodies and the joints of GUIDE kinds (one moving gives the other)
    known: set = set()
    ties: dict[int, set] = {}
    idx = {n: k for k, n in enumerate(cm.body_names)}
    idx["ground"] = G
    for el in cm.spec.drivers:
        moving = [idx[b] for b in el.bodies[:2] if b in idx and idx[b] != G]
        if len(moving) == 1:
            known.add(moving[0])
        elif len(moving) == 2:
            ties.setdefault(moving[0], set()).add(moving[1])
            ties.setdefault(moving[1], set()).add(moving[0])
    for g in cm.groups:
        if g.kind.name in GUIDE:
            for k in range(len(g)):
                a, b = (int(x) for x in g.bodies[k, :2])
                if G not in (a, b):
                    ties.setdefault(a, set()).add(b)
                    ties.setdefault(b, set()).add(a)
    loops = [(lp.bodies[1], lp.bodies[3]) for lp in fbs] + \
            [(sc.bodies[1], sc.bodies[3]) for sc in scs]
    by_body: dict[int, list] = {}
    for k, (p, r) in enumerate(loops):
        by_body.setdefault(p, []).append(k)
        by_body.setdefault(r, []).append(k)
    first = {b: "driver" for b in known}
    side: dict[int, int] = {}            # loop -> 0 (p drives) or 1 (r drives)
    work = list(known)
    while work:
        b = work.pop()
        for nb in ties.get(b, ()):
            if nb not in first:
                first[nb] = "loop"
                work.append(nb)
        for k in by_body.get(b, ()):
            if k in side:
                continue
            p, r = loops[k]
            side[k] = 0 if b == p else 1
            other = r if b == p else p
            if other not in first:
                first[other] = "loop"
                work.append(other)
    out = []
    for k, lp in enumerate(fbs):
        G_, p, c, r = lp.bodies
        gp, gr, pg, pc, rg, rc = lp.pins
        s = side.get(k)
        how = first.get(p if s == 0 else r, "driver") if s is not None else "assumed"
        if s is None:
            s = 1 if lp.kind == "crank-rocker" and lp.crank == lp.links[3] else 0
        out.append(LoopSpec("four-bar", lp.links, lp.kind, s, how, p, r, gp, pc, rc, gr, G,
                            (1.0, 0.0), math.dist(pg, pc)))
    for k, sc in enumerate(scs, start=len(fbs)):
        G_, p, c, s_ = sc.bodies
        gp, pg, pc, spin = sc.pins
        s = side.get(k)
        how = first.get(p if s == 0 else s_, "driver") if s is not None else "assumed"
        out.append(LoopSpec("slider-crank", sc.links, "", 2 if s in (None, 0) else 3, how, p,
                            s_, gp, pc, spin, gp, sc.guide[0], sc.guide[1], sc.a, sc))
    return out[:MAX_LOOPS]


# -- exact kinematics, vectorised over poses and loops -------------------------------------------

class _Arrays:
    """The loops' indices and points as arrays (L,) and (L, 2)."""

    def __init__(self, specs, remap=None):
        m = remap or (lambda b: b)
        self.p = np.array([m(s.p) for s in specs], dtype=np.intp)
        self.r = np.array([m(s.r) for s in specs], dtype=np.intp)
        self.gb = np.array([m(s.gb) for s in specs], dtype=np.intp)
        self.A = np.array([s.A for s in specs], float)
        self.B = np.array([s.B for s in specs], float)
        self.C = np.array([s.C for s in specs], float)
        self.D = np.array([s.D for s in specs], float)
        self.vi = np.array([s.vi for s in specs], float)
        self.a = np.array([s.a for s in specs], float)
        self.mode = np.array([s.mode for s in specs], dtype=np.intp)


def _points(Q, Qd, Qdd, b, s):
    """Position, velocity and acceleration (K, L, 2) of the points s (L, 2) of bodies b (L,),
    from extended Q, Qd, Qdd (K, columns): ground's columns are zero."""
    x, y, ph = Q[:, 3 * b], Q[:, 3 * b + 1], Q[:, 3 * b + 2]
    c, sn = np.cos(ph), np.sin(ph)
    gx = c * s[:, 0] - sn * s[:, 1]
    gy = sn * s[:, 0] + c * s[:, 1]
    w, al = Qd[:, 3 * b + 2], Qdd[:, 3 * b + 2]
    P = np.stack([x + gx, y + gy], -1)
    V = np.stack([Qd[:, 3 * b] - w * gy, Qd[:, 3 * b + 1] + w * gx], -1)
    Acc = np.stack([Qdd[:, 3 * b] - al * gy - w * w * gx,
                    Qdd[:, 3 * b + 1] + al * gx - w * w * gy], -1)
    return P, V, Acc


def _sub(X, Y):
    return tuple(x - y for x, y in zip(X, Y))


def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _dot(a, b):
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def _product(f, u, w):
    """f(u, w) of a bilinear f with its first and second time derivatives."""
    return (f(u[0], w[0]), f(u[1], w[0]) + f(u[0], w[1]),
            f(u[2], w[0]) + 2 * f(u[1], w[1]) + f(u[0], w[2]))


def _angle(u, w, acute, signed=False):
    """The unsigned angle between u and w, [0, pi] (acute: between their lines, [0, pi/2];
    signed: from u to w, (-pi, pi], acute (-pi/2, pi/2]), with its first and second time
    derivatives."""
    c, c1, c2 = _product(_cross, u, w)
    d, d1, d2 = _product(_dot, u, w)
    sc = 1.0 if signed else np.where(c < 0, -1.0, 1.0)
    sd = np.where(acute & (d < 0), -1.0, 1.0)
    c, c1, c2, d, d1, d2 = sc * c, sc * c1, sc * c2, sd * d, sd * d1, sd * d2
    r2 = c * c + d * d
    num = d * c1 - c * d1
    th1 = num / r2
    th2 = (d * c2 - c * d2) / r2 - num * 2 * (c * c1 + d * d1) / (r2 * r2)
    return np.arctan2(c, d), th1, th2


def _ratio(X, Y):
    """X / Y with its first and second time derivatives."""
    R = X[0] / Y[0]
    R1 = (X[1] - R * Y[1]) / Y[0]
    R2 = (X[2] - 2 * R1 * Y[1] - R * Y[2]) / Y[0]
    return R, R1, R2


def kinematics(arr: _Arrays, Q, Qd, Qdd):
    """(mu, mu', mu''), (R, R', R'') and (psi, psi', psi''), each (K, L): the transmission
    angle (radians) and the velocity ratio of every loop at every pose (internal units,
    extended arrays), and a slider-crank's signed angle psi from the guide's axis to the rod,
    (-pi/2, pi/2] (a slider output's mu = pi/2 - |psi|, largest, with a kink, where psi = 0)."""
    G = Q.shape[1] // 3 - 1
    g = np.full(len(arr.p), G, dtype=np.intp)
    with np.errstate(all="ignore"):
        A = _points(Q, Qd, Qdd, g, arr.A)
        B = _points(Q, Qd, Qdd, arr.p, arr.B)
        C = _points(Q, Qd, Qdd, arr.r, arr.C)
        D = _points(Q, Qd, Qdd, g, arr.D)
        # the guide's axis u = A(phi) vi on body gb and the normal n = k x u
        ph, w, al = Q[:, 3 * arr.gb + 2], Qd[:, 3 * arr.gb + 2], Qdd[:, 3 * arr.gb + 2]
        cs, sn = np.cos(ph), np.sin(ph)
        u = np.stack([cs * arr.vi[:, 0] - sn * arr.vi[:, 1],
                      sn * arr.vi[:, 0] + cs * arr.vi[:, 1]], -1)
        n = np.stack([-u[..., 1], u[..., 0]], -1)
        U = (u, w[..., None] * n, al[..., None] * n - (w * w)[..., None] * u)
        Nn = (n, -w[..., None] * u, -al[..., None] * u - (w * w)[..., None] * n)
        CB = _sub(C, B)
        BC = tuple(-x for x in CB)
        mode = arr.mode
        at_r = _angle(BC, _sub(D, C), False)          # mode 0
        at_p = _angle(CB, _sub(A, B), False)          # modes 1, 3
        at_s = _angle(BC, Nn, True)                   # mode 2
        psi = _angle(U, BC, True, signed=True)
        mu = tuple(np.where(mode == 0, x, np.where(mode == 2, z, y))
                   for x, y, z in zip(at_r, at_p, at_s))
        num = _product(_cross, _sub(B, A), CB)
        four = _product(_cross, _sub(C, D), CB)
        slide = tuple(arr.a * x for x in _product(_dot, U, CB))
        den = tuple(np.where(mode <= 1, x, y) for x, y in zip(four, slide))
        fwd = mode % 2 == 0
        X = tuple(np.where(fwd, x, y) for x, y in zip(num, den))
        Y = tuple(np.where(fwd, y, x) for x, y in zip(num, den))
        R = _ratio(X, Y)
    return mu, R, psi


def _targets(mu, R):
    """The three figures to minimise, (value, rate, acceleration) each (K, L): mu (its
    minimum), -mu (its maximum) and -|R| (the largest ratio)."""
    sg = np.where(R[0] < 0, -1.0, 1.0)
    return [mu, tuple(-x for x in mu), tuple(-sg * x for x in R)]


# -- the figures of a path -----------------------------------------------------------------------

class LoopFigures:
    """The loop figures of one path follower's path (built at the end of its run: `follow`);
    as_dict() is summary.json's ``loops``, computed when first asked (the design studies, which
    never ask, pay only the screening of the nodes for the warnings). t_stop (set by the
    analysis): the last time the run's rows reach; the figures stop there."""

    def __init__(self, f, specs):
        self.cm = f.cm
        self.specs = specs
        self._f = f
        self._dict = None
        self.t_stop = None
        self.exact: dict = {}                # loop -> [(y, t, how)] x 3 figures
        N = f.nodes
        self.T = np.array(N.t)
        self.seg = np.array(N.seg, dtype=np.intp)
        K = len(self.T)
        # the columns of the bodies the loops use (and ground's, last): nodes of a large model
        # are not copied whole
        bodies = sorted({b for s in specs for b in (s.p, s.r, s.gb)} - {f.cm.nb})
        self.cols = np.array([3 * b + k for b in bodies for k in range(3)]
                             + [3 * f.cm.nb + k for k in range(3)], dtype=np.intp)
        pos = {b: i for i, b in enumerate(bodies)}
        pos[f.cm.nb] = len(bodies)
        self.arr = _Arrays(specs, lambda b: pos[b])
        take = lambda X: np.array([x[self.cols] for x in X]) if K else \
            np.zeros((0, len(self.cols)))
        mu, R, self.Z = kinematics(self.arr, take(N.q), take(N.qd), take(N.qdd))
        self.Y = _targets(mu, R)
        # intervals a located extreme may lie in: of positive length, on one set of equations,
        # no branch crossing inside (bifurcation: continue)
        same = self.seg[1:] == self.seg[:-1] if K > 1 else np.zeros(0, bool)
        flips = np.array([bool((np.asarray(N.sign[i]) != np.asarray(N.sign[i + 1])).any())
                          if same[i] else True for i in range(K - 1)], dtype=bool)
        self.open = (np.diff(self.T) > 0) & same & ~flips if K > 1 else np.zeros(0, bool)
        self.stopped = f.event is not None
        # a slider-crank's offset e (constant: the slider does not turn), from the first pose
        self.offsets = {l: s.sc.offset(N.q[0]) for l, s in enumerate(specs)
                        if s.sc is not None and K}

    # -- candidates and their location ------------------------------------------------------

    def _usable(self) -> int:
        """Nodes within the run's rows (all, until the analysis says where the rows stop)."""
        if self.t_stop is None:
            return len(self.T)
        return max(1, int(np.searchsorted(self.T, self.t_stop * (1 + 1e-15) + 1e-300,
                                          side="right")))

    def _candidates(self, q: int, l: int, K: int):
        """(best node index, its value), and the brackets [(estimate, interval, s*, o)] of the
        local minima of figure q of loop l between nodes, most extreme first: o = 0 a smooth
        one (its rate's zero), o = +-1 the kink of a slider output's largest mu (psi's zero,
        psi rising for o = 1)."""
        y, y1, _ = (x[:K, l] for x in self.Y[q])
        with np.errstate(invalid="ignore"):
            y_ok = np.where(np.isfinite(y), y, np.inf)
        i0 = int(np.argmin(y_ok))
        if K < 2:
            return i0, float(y_ok[i0]), []
        h = np.diff(self.T[:K])
        d0, d1 = y1[:-1], y1[1:]
        with np.errstate(all="ignore"):
            br = self.open[:K - 1] & (d0 < 0) & (d1 > 0) & np.isfinite(y[:-1]) & \
                np.isfinite(y[1:])
            k = np.flatnonzero(br)
            s = -d0[k] / (d1[k] - d0[k])
            # cubic Hermite of the values and rates at the ends, at the rate's linear zero
            hh = h[k]
            s2, s3 = s * s, s * s * s
            est = ((2 * s3 - 3 * s2 + 1) * y[k] + (s3 - 2 * s2 + s) * hh * d0[k]
                   + (-2 * s3 + 3 * s2) * y[k + 1] + (s3 - s2) * hh * d1[k])
            est = np.minimum(est, np.minimum(y[k], y[k + 1]))
            found = [(float(e), int(i), float(x), 0) for e, i, x in zip(est, k, s)]
            if q == 1 and self.specs[l].mode == 2:
                # mu = pi/2 - |psi| peaks with a kink where psi crosses zero: located there
                z = self.Z[0][:K, l]
                kinks = np.flatnonzero(self.open[:K - 1] & (z[:-1] * z[1:] <= 0))
                at_kink = set(kinks.tolist())
                found = [b for b in found if b[1] not in at_kink]
                found += [(-math.pi / 2, int(i), float(z[i] / (z[i] - z[i + 1])),
                           1 if z[i] < 0 else -1) for i in kinks if z[i] != z[i + 1]]
        # a bracket that cannot improve on the best node beyond rounding (a figure that does
        # not change: a parallelogram's ratio of 1) is not worth its solves
        fin = y[np.isfinite(y)]
        floor = float(y_ok[i0]) - FLAT * (float(np.abs(fin).max() + np.ptp(fin)) if len(fin)
                                          else 0.0)
        found = sorted((b for b in found if b[0] < floor), key=lambda x: x[0])
        return i0, float(y_ok[i0]), found[:CANDIDATES]

    def estimate(self, l: int):
        """The three figures of loop l estimated from the nodes alone (no solve)."""
        K = self._usable()
        out = []
        for q in range(3):
            _, best, brackets = self._candidates(q, l, K)
            out.append(min([best] + [b[0] for b in brackets]))
        return out

    def locate(self, loops) -> None:
        """The three figures of every loop in loops located exactly (self.exact)."""
        loops = [l for l in loops if l not in self.exact]
        if not loops:
            return
        K = self._usable()
        tasks = []          # (loop, figure, interval, s*, o)
        base = {}
        for l in loops:
            for q in range(3):
                i0, best, brackets = self._candidates(q, l, K)
                how = "end" if i0 in (0, K - 1) else "node"
                base[l, q] = (best, float(self.T[i0]), how)
                tasks += [(l, q) + b[1:] for b in brackets]
        found = self._newton(tasks) if tasks else {}
        for l in loops:
            self.exact[l] = []
            for q in range(3):
                y, t, how = base[l, q]
                for (ll, qq, _), (yy, tt) in found.items():
                    if ll == l and qq == q and yy < y:
                        y, t, how = yy, tt, "turning point"
                self.exact[l].append((y, t, how))

    def _newton(self, tasks) -> dict:
        """Newton's method on the exact rate (a kink: on psi), safeguarded by bisection, for
        every task's interval at once: {(loop, figure, interval): (smallest value solved, its
        time)}."""
        from planarkin.solver.acceptance import accepted
        from planarkin.solver.path import NODE_TOL, hermite5
        f, N = self._f, self._f.nodes
        # the grid rows' Newton tolerance (the tables' rows pass it): near a toggle a tighter
        # one meets the rounding of the corrections (eps x condition) and is never reached
        tol = max(NODE_TOL, f.opts.tol)
        M = len(tasks)
        L_idx = np.array([x[0] for x in tasks], dtype=np.intp)
        q_idx = np.array([x[1] for x in tasks], dtype=np.intp)
        i_idx = np.array([x[2] for x in tasks], dtype=np.intp)
        o_idx = np.array([x[4] for x in tasks], dtype=float)
        ta, tb = self.T[i_idx].copy(), self.T[i_idx + 1].copy()
        t = ta + np.array([x[3] for x in tasks]) * (tb - ta)
        best = np.full(M, np.inf)
        best_t = np.full(M, np.nan)
        active = np.ones(M, dtype=bool)
        span = max(abs(self.T[-1]), abs(self.T[0]), self.T[-1] - self.T[0], 1e-300)
        ncols = len(N.q[0])
        chunk = max(1, min(512, 4_000_000 // max(ncols, 1)))
        for _ in range(MAX_NEWTON):
            act = np.flatnonzero(active)
            if not len(act):
                break
            y = np.full(M, np.nan)
            y1 = np.full(M, np.nan)
            y2 = np.full(M, np.nan)
            ok = np.zeros(M, dtype=bool)
            for lo in range(0, len(act), chunk):
                sel = act[lo:lo + chunk]
                for u in np.unique(self.seg[i_idx[sel]]):
                    part = sel[self.seg[i_idx[sel]] == u]
                    i = i_idx[part]
                    q0 = np.array([N.q[k] for k in i])
                    q1 = np.array([N.q[k + 1] for k in i])
                    h = (self.T[i + 1] - self.T[i])[:, None]
                    s = (t[part][:, None] - self.T[i][:, None]) / h
                    Q = hermite5(s, h, q0, np.array([N.qd[k] for k in i]),
                                 np.array([N.qdd[k] for k in i]), q1,
                                 np.array([N.qd[k + 1] for k in i]),
                                 np.array([N.qdd[k + 1] for k in i]))
                    Qd = np.zeros_like(Q)
                    Qdd = np.zeros_like(Q)
                    S = f.systems[int(u)][1]
                    tt = t[part].copy()
                    info = S.solve_batch(tt, Q, Qd, Qdd, policy="full", tol=tol, maxit=12,
                                         order=2, drivers=S.driver_values(tt))
                    sign = np.array([N.sign[k] for k in i])
                    good = accepted(info, sign, (Qd, Qdd))
                    mu, R, Z = kinematics(self.arr, Q[:, self.cols], Qd[:, self.cols],
                                          Qdd[:, self.cols])
                    Y = _targets(mu, R)
                    rows = np.arange(len(part))
                    at = (rows, L_idx[part])
                    o = o_idx[part]
                    for j, (yy, yy1, yy2) in enumerate(Y):
                        m = q_idx[part] == j
                        y[part[m]] = yy[at][m]
                        # the function whose zero is the extreme, rising through it
                        y1[part[m]] = np.where(o == 0, yy1[at], o * Z[0][at])[m]
                        y2[part[m]] = np.where(o == 0, yy2[at], o * Z[1][at])[m]
                    ok[part] = good & np.isfinite(y[part]) & np.isfinite(y1[part])
            active &= ok
            better = active & (y < best)
            best[better], best_t[better] = y[better], t[better]
            tiny = 4 * np.finfo(float).eps * span
            with np.errstate(all="ignore"):
                ta = np.where(active & (y1 < 0), t, ta)
                tb = np.where(active & (y1 > 0), t, tb)
                step = y1 / y2
                tn = t - step
                bis = ~(np.isfinite(tn) & (y2 > 0) & (tn > ta) & (tn < tb))
                # Newton's step within rounding of t: t is the turning point (the rate there
                # is rounding; bisecting away from it would only walk back)
                # or the figure cannot change by more than its rounding within the bracket
                done = (y1 == 0) | ((y2 > 0) & (np.abs(step) <= tiny)) | (tb - ta <= tiny) | \
                    (np.abs(y1) * (tb - ta) <= 4 * np.finfo(float).eps * np.abs(y))
                tn = np.where(bis, 0.5 * (ta + tb), tn)
            active &= ~done
            t = np.where(active, tn, t)
        return {tuple(tasks[k][:3]): (float(best[k]), float(best_t[k]))
                for k in range(M) if np.isfinite(best[k])}

    # -- warnings and the summary -----------------------------------------------------------

    def _past(self, l: int, y) -> list:
        """The margins figures y (mu_min, -mu_max, -|R|max) of loop l pass, with their times:
        [(what, time)]."""
        m = math.radians(TOGGLE_MARGIN_DEG)
        out = []
        if y[0][0] <= m:
            out.append(("low", y[0][1]))
        if self.specs[l].mode != 2 and -y[1][0] >= math.pi - m:
            out.append(("high", y[1][1]))
        if -y[2][0] >= RATIO_LIMIT:
            out.append(("ratio", y[2][1]))
        return out

    def warnings(self) -> list:
        """An Event ('toggle') for every loop whose path passes within the margins: screened
        on the nodes, decided on the located extremes."""
        from planarkin.solver.path import Event
        m = math.radians(TOGGLE_MARGIN_DEG)
        watch = []
        for l, sp in enumerate(self.specs):
            e = self.estimate(l)
            if e[0] <= WATCH * m or (sp.mode != 2 and -e[1] >= math.pi - WATCH * m) or \
                    -e[2] >= RATIO_LIMIT / WATCH:
                watch.append(l)
        if not watch:
            return []
        self.locate(watch)
        out = []
        t_end = float(self.T[-1])
        for l in watch:
            y = [(v, t) for v, t, _ in self.exact[l]]
            past = self._past(l, y)
            if self.stopped:
                # the path stopped at a singular configuration: what it ran into there is the
                # run's failure already
                past = [(w, t) for w, t in past if t < t_end - 1e-9 * max(abs(t_end), 1.0)]
            if past:
                out.append(Event("toggle", min(t for _, t in past),
                                 self._message(l, y, {w for w, _ in past}),
                                 bodies=list(self.specs[l].links[1:])))
        return out

    def _message(self, l: int, y, past: set) -> str:
        sp = self.specs[l]
        au = self.cm.spec.angle_unit
        deg = 180 / math.pi if au == "deg" else 1.0
        shown = lambda x: f"{x * deg:.4g} {au}" + (f" ({math.degrees(x):.4g} deg)"
                                                   if au != "deg" else "")
        parts = []
        if "low" in past:
            parts.append(f"the transmission angle {sp.where()} comes down to {shown(y[0][0])} "
                         f"at t = {y[0][1]:.6g} s")
        if "high" in past:
            parts.append(f"the transmission angle {sp.where()} reaches {shown(-y[1][0])}, "
                         f"{shown(math.pi + y[1][0])} short of 180 deg, at t = {y[1][1]:.6g} s")
        ratio = -y[2][0]
        parts.append(f"the velocity ratio {self._ratio_words(sp)} reaches {ratio:.4g} "
                     f"(mechanical advantage {1 / ratio:.3g}) at t = {y[2][1]:.6g} s")
        return (f"{sp.kind} loop {'-'.join(sp.links)} ({sp.input} driving {sp.output}): passes "
                f"near a toggle: " + "; ".join(parts) + f" (the warning margins: a transmission "
                f"angle within {TOGGLE_MARGIN_DEG:g} deg of 0 or 180 deg, a velocity ratio above "
                f"{RATIO_LIMIT:g}): there {sp.output} moves far faster than {sp.input}, and the "
                f"effort to drive it and the joint reactions rise steeply toward the toggle; "
                f"keep the transmission angle within {CLASSIC_RANGE_DEG[0]:g}-"
                f"{CLASSIC_RANGE_DEG[1]:g} deg (or stop the motion short of the toggle)")

    @staticmethod
    def _ratio_words(sp) -> str:
        g, p, c, r = sp.links
        if sp.mode == 0:
            return f"|{r}' / {p}'|"
        if sp.mode == 1:
            return f"|{p}' / {r}'|"
        if sp.mode == 2:
            return f"|{r} speed / {p} pin speed|"
        return f"|{p} pin speed / {r} speed|"

    def as_dict(self) -> list:
        """summary.json's ``loops``: one record per loop (see the module docstring)."""
        if self._dict is None:
            try:
                self.locate(range(len(self.specs)))
                self._dict = [self._record(l) for l in range(len(self.specs))]
            except Exception as e:  # noqa: BLE001 - the run's results must not be lost to it
                self._dict = [{"error": f"loop figures not computed: {type(e).__name__}: {e} "
                                        f"(please report)"}]
            self._f = None
        return self._dict

    def _record(self, l: int) -> dict:
        sp = self.specs[l]
        cm = self.cm
        au = cm.spec.angle_unit
        deg = 180 / math.pi if au == "deg" else 1.0
        (y0, t0, h0), (y1, t1, h1), (y2, t2, h2) = self.exact[l]
        mu_lo, mu_hi, ratio = y0, -y1, -y2
        lo, hi = (math.radians(x) for x in CLASSIC_RANGE_DEG)
        past = self._past(l, [(y0, t0), (y1, t1), (y2, t2)])
        cls = sp.cls
        if sp.sc is not None:
            e = self.offsets.get(l, 0.0)
            e = 0.0 if abs(e) <= 1e-12 * (sp.sc.a + sp.sc.b) else e
            gap = sp.sc.b - (sp.sc.a + abs(e))
            cls = "change point" if abs(gap) <= 1e-12 * (sp.sc.a + sp.sc.b) else \
                "crank turns fully" if gap > 0 else "crank rocks"
        rec = {"kind": sp.kind, "loop": "-".join(sp.links), "class": cls,
               "input": sp.input, "output": sp.output, "input_from": sp.input_from,
               "transmission_angle": {
                   "unit": au, "where": sp.where(),
                   "min": {"value": mu_lo * deg, "t": t0, "found": h0},
                   "max": {"value": mu_hi * deg, "t": t1, "found": h1},
                   "poor": bool(mu_lo < lo or (sp.mode != 2 and mu_hi > hi))},
               "velocity_ratio": {"definition": self._ratio_words(sp),
                                  "max": {"value": ratio, "t": t2, "found": h2}},
               "mechanical_advantage": {"min": {"value": 1 / ratio if ratio else math.inf,
                                                "t": t2}},
               "near_toggle": bool(past)}
        if sp.sc is not None:
            L = cm.L
            rec["lengths"] = {"crank": sp.sc.a * L, "rod": sp.sc.b * L, "offset": e * L,
                              "unit": cm.spec.length_unit}
        return rec

    def __getstate__(self):
        # sent to another process (a study's result): the figures travel, not the path
        self.as_dict()
        return {"cm": None, "specs": self.specs, "_dict": self._dict, "_f": None,
                "t_stop": self.t_stop, "exact": self.exact}

    def __setstate__(self, state):
        self.__dict__.update(state)


def follow(f) -> None:
    """At the end of a path follower's run (planarkin.solver.singular): its loop figures as f.loops
    (None without loops) and a 'toggle' warning for every near-toggle passage."""
    specs = loop_specs(f.cm)
    if not specs or not len(f.nodes):
        f.loops = None
        return
    fig = LoopFigures(f, specs)
    f.loops = fig
    f.warnings.extend(fig.warnings())


MARGINS_NOTE = (f"transmission angle within {TOGGLE_MARGIN_DEG:g} deg of 0 or 180 deg, or velocity "
                f"ratio above {RATIO_LIMIT:g}: warned; outside {CLASSIC_RANGE_DEG[0]:g}-"
                f"{CLASSIC_RANGE_DEG[1]:g} deg: poor")
