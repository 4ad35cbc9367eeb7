"""The `turns` constraint of a four-bar loop as a smooth margin with its exact gradient.

A driven link of a four-bar loop (ground, p, c, r: planarkin.measures.grashof) turns fully when
the loop is Grashof with it or the ground the shortest link. With x that link and the other
three y, the margin

    m_x = sum(y) - 2 max(y) - x        (= p + q - s - l when x is the shortest s)

is positive exactly then: x + max(y) < sum(y) - max(y) forces x below every y (a y below x
would give x + max(y) > y + max(y) >= the two others). The constraint's margin is
max(m_crank, m_ground), in the model's length unit (m_crank alone with `shortest: true`).
The lengths are distances between the joints' body-frame points si, sj, so their gradients
are exact by the chain rule through the file's expressions
(studies.sensitivity.ParameterDerivatives).

The constraints measured on the analysed cycle take their extremes between the grid rows as
every figure does (planarkin.measures.extremes.extreme, from the exact rates and
accelerations): `angle_span` for `turns` without a four-bar loop (a driven angle's max - min)
and `worst_transmission` for `transmission` (the smallest of mu and 180 deg - mu).

Search near a margin of zero (a change point: the loop folds flat, the analysis stops at a
bifurcation) is steered off it by one residual row, zero above BAND of the loop's length sum
and rising as (m0 - m)^2 / m below it (C1 at m0; infinite at m = 0), so that a local solve
slides along the wall instead of stepping into it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..measures.extremes import extreme

BAND = 0.01        # the barrier acts below this fraction of the loop's length sum (the
#                    default of search: band; see barrier)


@dataclass
class TurnLoop:
    links: tuple        # (ground, p, c, r) body names
    lengths: tuple      # user length unit
    pins: tuple         # per length: ((element, 'si'|'sj', point), (element, key, point)): the
    #                     ends' points in their bodies' frames, user units (from the arrays)
    driven: int         # index of the driven link in links (1 or 3)
    shortest: bool = False      # the driven link must be the shortest (not the ground)

    def margin(self) -> float:
        if self.shortest:
            return self._margin(self.driven)[0]
        return max(self._margin(self.driven)[0], self._margin(0)[0])

    def _margin(self, x):
        y = [i for i in range(4) if i != x]
        big = max(y, key=lambda i: self.lengths[i])
        m = sum(self.lengths[i] for i in y) - 2 * self.lengths[big] - self.lengths[x]
        coef = np.zeros(4)
        coef[y] = 1.0
        coef[big] -= 2.0
        coef[x] -= 1.0
        return m, coef

    def gradient(self, dlengths: np.ndarray) -> np.ndarray:
        """d(margin)/dp from dlengths (4, k): the active branch's linear combination."""
        a, b = self._margin(self.driven), self._margin(0)
        return (a if self.shortest or a[0] >= b[0] else b)[1] @ dlengths


def turning_loop(cm, body: str, shortest: bool = False):
    """The four-bar loop in which `body` is a link pinned to ground, or None. shortest: its
    margin is m_body alone (the body the shortest link, a crank-rocker or a double crank with
    the driven link shortest; not a drag link with the ground shortest)."""
    pins = {}
    for g in cm.groups:
        if g.kind.name != "revolute":
            continue
        for k in range(len(g)):
            a, b = int(g.bodies[k, 0]), int(g.bodies[k, 1])
            el = cm.element_of_row(int(g.rows[k][0]))
            sa, sb = tuple(g.params["si"][k]), tuple(g.params["sj"][k])
            ua, ub = g.params["si"][k] * cm.L, g.params["sj"][k] * cm.L
            pins.setdefault((a, b), (sa, sb, (el, "si", ua), (el, "sj", ub)))
            pins.setdefault((b, a), (sb, sa, (el, "sj", ub), (el, "si", ua)))
    G = cm.nb
    if body not in cm.body_names:
        return None
    p = cm.body_names.index(body)
    if (G, p) not in pins:
        return None
    for c in {b for (a, b) in pins if a == p and b not in (G, p)}:
        for r in {b for (a, b) in pins if a == c and b not in (G, p, c)}:
            if (G, r) not in pins:
                continue
            gp, pg, ngp, npg = pins[(G, p)]
            gr, rg, ngr, nrg = pins[(G, r)]
            pc, cp, npc, ncp = pins[(p, c)]
            cr, rc, ncr, nrc = pins[(c, r)]
            L = cm.L
            lengths = (math.dist(gp, gr) * L, math.dist(pg, pc) * L, math.dist(cp, cr) * L,
                       math.dist(rc, rg) * L)
            return TurnLoop(links=("ground", body, cm.body_names[c], cm.body_names[r]),
                            lengths=lengths, driven=1, shortest=shortest,
                            pins=((ngp, ngr), (npg, npc), (ncp, ncr), (nrc, nrg)))
    return None


def length_gradients(loop: TurnLoop, cm, root, D) -> np.ndarray:
    """(4, k) exact d(length)/dp of the loop's links. root: the file's node tree; D: a
    studies.sensitivity.ParameterDerivatives for the free parameters."""
    joints = root.value["joints"].value
    out = np.zeros((4, len(D.wrt)))
    for i, ((e1, k1, v1), (e2, k2, v2)) in enumerate(loop.pins):
        g1 = _point_gradient(D, joints[e1.index - 1].value.get(k1))
        g2 = _point_gradient(D, joints[e2.index - 1].value.get(k2))
        d = v1 - v2
        norm = float(np.hypot(*d))
        if norm > 0:
            out[i] = (d / norm) @ (g1 - g2)
    return out


def _point_gradient(D, node) -> np.ndarray:
    """(2, k) derivative of a point [x, y] of the file (zero when absent: the origin)."""
    if node is None or node.kind != "seq":
        return np.zeros((2, len(D.wrt)))
    return np.stack([D.number(n) for n in node.value])


def barrier(m: float, dm: np.ndarray, total: float, dtotal: np.ndarray, band: float = BAND):
    """(residual, (k,) gradient) of the margin's barrier row: (m0 - m)^2 / m below
    m0 = band total (total: the loop's length sum), zero above. The band trades: wide (1 %),
    it holds the local runs well off the change points, which the probed runs of the straight
    line need (with 1e-4, some of its seeds took more evaluations, one of them far more);
    narrow (1e-4), it lets them reach designs that lie near the wall, as the literature's half
    circle and eighteen points do (lower sums of squares there; benchmarks/README.md,
    "Figures moved from the code's comments")."""
    m0, dm0 = band * total, band * dtotal
    if m >= m0:
        return 0.0, np.zeros_like(dm)
    r = (m0 - m) ** 2 / m
    return r, (2 * (m0 - m) * (dm0 - dm) * m - (m0 - m) ** 2 * dm) / m ** 2


def angle_span(res, k: int) -> float:
    """max - min of body coordinate k of a Result (a link's angle, for `turns` without a
    four-bar loop), both refined between the grid rows from the exact rate and acceleration."""
    cols = [None if a is None else a[:, k] for a in (res.q, res.qd, res.qdd)]
    return float(extreme(res.t, *cols, 1.0)[1] - extreme(res.t, *cols, -1.0)[1])


def transmission_angle(res, b: int, c: int, d: int, deg: bool) -> tuple:
    """(mu, mu', mu'') (N,) of a Result: the angle at point c between c->b and c->d in [0,
    180] deg (deg; else [0, pi]), with its exact rate and acceleration by the chain rule from
    the points' velocities and accelerations (None where the run has none)."""
    P = (res.p, res.pd, res.pdd)
    u = [None if X is None else X[:, b] - X[:, c] for X in P]
    w = [None if X is None else X[:, d] - X[:, c] for X in P]
    cross = lambda x, y: x[:, 0] * y[:, 1] - x[:, 1] * y[:, 0]     # noqa: E731
    dot = lambda x, y: x[:, 0] * y[:, 0] + x[:, 1] * y[:, 1]      # noqa: E731
    cr, dt = cross(u[0], w[0]), dot(u[0], w[0])
    sc = np.where(cr < 0, -1.0, 1.0)
    mu = np.arctan2(sc * cr, dt)
    f = 180 / math.pi if deg else 1.0
    if u[1] is None:
        return mu * f, None, None
    r2 = cr * cr + dt * dt
    c1 = sc * (cross(u[1], w[0]) + cross(u[0], w[1]))
    d1 = dot(u[1], w[0]) + dot(u[0], w[1])
    num = dt * c1 - sc * cr * d1
    if u[2] is None:
        return mu * f, num / r2 * f, None
    c2 = sc * (cross(u[2], w[0]) + 2 * cross(u[1], w[1]) + cross(u[0], w[2]))
    d2 = dot(u[2], w[0]) + 2 * dot(u[1], w[1]) + dot(u[0], w[2])
    r21 = 2 * (sc * cr * c1 + dt * d1)
    mu2 = (dt * c2 - sc * cr * d2) / r2 - num * r21 / (r2 * r2)
    return mu * f, num / r2 * f, mu2 * f


def worst_transmission(res, b: int, c: int, d: int, deg: bool) -> float:
    """The smallest of mu and 180 deg - mu over the run (`transmission_angle`), mu's extremes
    refined between the grid rows."""
    mu, mu1, mu2 = transmission_angle(res, b, c, d, deg)
    half = 180.0 if deg else math.pi
    return float(min(extreme(res.t, mu, mu1, mu2, -1.0)[1],
                     half - extreme(res.t, mu, mu1, mu2, 1.0)[1]))
