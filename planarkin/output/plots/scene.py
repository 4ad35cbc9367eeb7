"""The geometry of the mechanism over the run (user units), from each kind's `draw` hook
(planarkin.elements.drawing): what mechanism.<fmt>, trajectories.<fmt> and animation.gif draw."""

from __future__ import annotations

import numpy as np

from ...elements.base import pivots
from ...elements.drawing import Parts
from .outline import plates
from .style import CROWD, CROWD_VERTICES, NAMED_POINTS, body_palette, point_palette


UNIQUE_PAIRS = 64       # attachment points of one body compared pair by pair (_unique)


class Scene:
    """Geometry of the mechanism over the run, user units.

    Each moving body is drawn from body-fixed vertices: a translucent polygon (the convex hull
    of its frame origin, joint points and points of interest), a thick bar when those are
    collinear, or a block oriented along its slide when they are a single point; plus dashed
    body-fixed lines (slots, gear pitch circles). Ground carries pivots (revolute and distance
    points on ground) and slide axes (translational, pin-slot and slide lines on ground). The
    paths (traces) are those of the points of interest and of every moving joint point.
    A body the model gives shapes to (issue 29: plates) is drawn as those instead of its hull
    or bar; shapes on ground are frame obstacles.
    """

    def __init__(self, cm, data):
        self.cm = cm
        self.t = data.t
        self.nb = cm.nb
        self.names = cm.body_names
        self.colors = body_palette(cm.nb)
        # the first NAMED_POINTS points are drawn one by one in their colours; the rest (the
        # crowd) as one grey collection
        npts = len(cm.point_names)
        self.named = min(npts, NAMED_POINTS)
        self.point_colors = point_palette(self.named) + [CROWD] * (npts - self.named)
        self.point_xy = data.p                          # (N, points, 2)
        q = data.q
        self.x, self.y = q[:, 0::3], q[:, 1::3]
        phi = self.phi = q[:, 2::3] * cm.angle_factor
        self.c, self.s = np.cos(phi), np.sin(phi)
        attach, joint_pts, slides, slide_dir, discs = self._elements(cm)

        # the drawing's scale: extent of all attachment points over the run
        attach = [_unique(a) for a in attach]
        X, Y = (np.concatenate([g[k].ravel() for g in (self.to_global(b, a)
                                                       for b, a in enumerate(attach))])
                for k in (0, 1))
        span = max(np.nanmax(X) - np.nanmin(X), np.nanmax(Y) - np.nanmin(Y))
        self.span = span if span > 1e-12 * cm.L else cm.L
        self.size = 0.07 * self.span                    # slider blocks, ground pivots
        # every attachment point, not only the frame origins (a boom pinned at its origin)
        first = np.concatenate([self.at(b, a, 0) for b, a in enumerate(attach)])
        last = np.concatenate([self.at(b, a, -1) for b, a in enumerate(attach)])
        self.closed = len(self.t) > 2 and np.nanmax(np.abs(first - last)) <= 1e-6 * self.span

        self._shapes(attach, slide_dir, discs)
        # the shapes the model gives (issue 29): a body's plates replace its hull or bar
        self.plates = plates(cm)
        for p in self.plates:
            if p.body != self.nb:
                self.fills[p.body] = self.bars[p.body] = None
        self._slides(slides)
        self._traces(data, joint_pts)
        self._bounds()
        self.centrodes = self._centrodes(cm, data) if cm.spec.output.centres else []
        # output: {centres: moving}: planarkin.measures.centres draws them at every instant
        from planarkin.measures.centres import moving_centrodes
        self.moving = moving_centrodes(cm, data, [j for j, _ in self.centrodes]) \
            if cm.spec.output.moving_centrodes else []

    def _elements(self, cm):
        """Walk the elements: each kind's `draw` hook (planarkin.elements.drawing.Parts) gives
        attachment points per body (body frame, user units), joint points to trace, pins,
        ground pivots, distance links, slides, slide directions, pitch circles, outlines and
        faces; the points of interest are attachment points of their bodies as well."""
        L, ground = cm.L, cm.nb
        parts = Parts(cm.nb, L, pivots(cm.groups), self.phi)
        for G in cm.groups:
            for k in range(len(G)):
                G.kind.draw(G, k, parts)
        for b, s in zip(cm.point_body, cm.point_s):
            if int(b) != ground:
                parts.attach[int(b)].append(np.asarray(s) * L)
        self.pins, self.pivots, self.links = parts.pins, parts.pivots_drawn, parts.links
        self.outlines, self.faces_out = parts.outlines, parts.faces
        self.surfaces = parts.surfaces
        self.shaped = parts.shaped
        return parts.attach, parts.joints, parts.slides, parts.slide_dir, parts.discs

    def _shapes(self, attach, slide_dir, discs):
        """Body-frame outlines: fills (polygons), bars (thick lines), dashed (gear circles)."""
        nb, size = self.nb, self.size
        self.fills = [None] * nb                        # (k, 2) polygon vertices
        self.bars = [None] * nb                         # (2, 2) thick line
        self.dashed = [[] for _ in range(nb)]           # body-fixed dashed polylines
        self.faces = [[] for _ in range(nb)]            # body-fixed solid lines (flat faces)
        for b, P in enumerate(attach):
            if len(P) == 1:
                if b not in self.shaped:                     # a block along the slide
                    u = np.asarray(slide_dir.get(b, (1.0, 0.0)), float)
                    n = np.array([-u[1], u[0]])
                    w, h = 0.6 * size, 0.38 * size
                    self.fills[b] = P[0] + np.array([w * u + h * n, -w * u + h * n,
                                                     -w * u - h * n, w * u - h * n])
                continue
            hull = _hull(P)
            ext = np.ptp(P, axis=0).max()
            if len(hull) >= 3 and _area(hull) > 1e-3 * ext * ext:
                self.fills[b] = hull
            else:
                d = P[np.argmax(np.hypot(*(P - P[0]).T))] - P[0]
                proj = (P - P[0]) @ d
                self.bars[b] = np.array([P[np.argmin(proj)], P[np.argmax(proj)]])
        for b, centre, r in discs:
            if b == nb or not r:
                continue
            a = np.linspace(0.0, 2 * np.pi, 61)
            self.dashed[b].append(centre + abs(r) * np.c_[np.cos(a), np.sin(a)])
            self.dashed[b].append(np.array([centre, centre + (abs(r), 0.0)]))

        for b, poly in self.outlines:
            if b != nb:
                self.dashed[b].append(poly)
        for b, poly in self.faces_out:
            if b != nb:
                self.faces[b].append(poly)

    def _slides(self, slides):
        """Slide axes on ground (self.axes, global) and slots on moving bodies (dashed), along
        the range the sliding point covers."""
        ground = self.nb
        self.axes = [poly for b, poly in self.outlines if b == ground]   # + belt runs
        for bi, si, vi, bj, sj in slides:
            u = vi / np.hypot(*vi)
            xy = self.at_all(bj, sj)
            if bi != ground:                            # in body i's frame
                dx, dy = xy[:, 0] - self.x[:, bi], xy[:, 1] - self.y[:, bi]
                ci, sn = self.c[:, bi], self.s[:, bi]
                xy = np.c_[ci * dx + sn * dy, -sn * dx + ci * dy]
            proj = (xy - si) @ u
            proj = proj[np.isfinite(proj)]
            lo, hi = (proj.min(), proj.max()) if len(proj) else (0.0, 0.0)
            pad = 0.15 * (hi - lo) + self.size
            seg = np.array([si + (lo - pad) * u, si + (hi + pad) * u])
            (self.axes if bi == ground else self.dashed[bi]).append(seg)

    def _traces(self, data, joint_pts):
        """Paths: the points of interest (coloured), then each moving joint point once (grey).
        trace_styles: (legend label, is a point, colour, line width) of each."""
        self.traces, self.trace_styles = [], []
        for k, name in enumerate(self.cm.point_names):
            self.traces.append(data.p[:, k, :])
            self.trace_styles.append((name, True, self.point_colors[k], 1.3))
        tol = 1e-6 * self.span
        for b, s in joint_pts:
            xy = self.at_all(b, s)
            if np.nanmax(np.ptp(xy, axis=0)) <= tol:
                continue                                # does not move
            if any(np.nanmax(np.abs(xy - other)) <= tol for other in self.traces):
                continue                                # the other side of a revolute, ...
            self.traces.append(xy)
            self.trace_styles.append(("joint paths", False, "0.55", 0.8))

    def _bounds(self):
        """(x0, x1, y0, y1): everything drawn over the run, with a margin."""
        size = self.size
        parts = [np.asarray(p, float).reshape(-1, 2) for p in self.axes + self.traces]
        parts += [np.array([p - (size, 1.6 * size), p + (size, 0.0)]) for p in self.pivots]
        for b in range(self.nb):
            for V in [self.fills[b], self.bars[b]] + self.dashed[b] + self.faces[b]:
                if V is not None:
                    X, Y = self.to_global(b, V)
                    parts.append(np.c_[X.ravel(), Y.ravel()])
        for p in self.plates:
            if p.body == self.nb:
                parts.append(p.outline)
            else:
                X, Y = self.to_global(p.body, p.outline)
                parts.append(np.c_[X.ravel(), Y.ravel()])
        allp = np.concatenate(parts)
        lo, hi = np.nanmin(allp, axis=0) - 0.6 * size, np.nanmax(allp, axis=0) + 0.6 * size
        self.bounds = (lo[0], hi[0], lo[1], hi[1])

    def _centrodes(self, cm, data) -> list:
        """[(body, (N, 2) path)]: the fixed centrode (instant centre relative to ground, from the
        exact velocities: planarkin.measures.centres) of every body whose centre moves -- not a body
        pinned to ground (a fixed point) nor a slider (at infinity) -- cut where it leaves the
        drawing's bounds: near a parallel position it runs to infinity, and following it even
        part of the way would shrink the mechanism. nan breaks the line."""
        if getattr(data, "qd", None) is None or len(self.t) < 2:
            return []
        from planarkin.measures.centres import compute, pairs
        X = compute(cm, data)
        x0, x1, y0, y1 = self.bounds
        m = 0.0                # the drawing keeps the size it has without them
        out = []
        for k, (i, j) in enumerate(pairs(cm)):
            if i != cm.nb:
                continue
            xy = X[:, 1 + 3 * k:3 + 3 * k].copy()
            fin = np.isfinite(xy).all(axis=1)
            if fin.sum() < 2 or np.ptp(xy[fin], axis=0).max() <= 1e-9 * self.span:
                continue
            far = ~((xy[:, 0] >= x0 - m) & (xy[:, 0] <= x1 + m) & (xy[:, 1] >= y0 - m)
                    & (xy[:, 1] <= y1 + m))
            xy[far] = np.nan
            if np.isfinite(xy).all(axis=1).sum() >= 2:
                out.append((j, xy))
        return out

    def crowd(self, upto: int | None = None) -> list:
        """The paths of the points after the first NAMED_POINTS ((k, 2) each, rows 0..upto),
        every stride-th row and the last, so that all of them have at most CROWD_VERTICES."""
        P = self.point_xy[:, self.named:, :] if self.point_xy is not None else np.zeros((0, 0, 2))
        if not P.shape[1]:
            return []
        rows = len(self.t) if upto is None else upto + 1
        stride = max(1, -(-(P.shape[1] * rows) // CROWD_VERTICES))
        sel = np.unique(np.r_[np.arange(0, rows, stride), rows - 1])
        return list(np.swapaxes(P[sel], 0, 1))

    def instants(self, n: int) -> np.ndarray:
        """Up to n rows evenly spread over the run, the first and (unless the run is a full
        cycle, whose end is its start) the last among them; a row whose pose repeats one
        already chosen (a motion there and back) is left out."""
        N = len(self.t)
        if self.closed and N > n:
            rows = np.unique(np.linspace(0, N - 1, n + 1)[:-1].round().astype(int))
        else:
            rows = np.unique(np.linspace(0, N - 1, min(n, N)).round().astype(int))
        tol = 1e-6 * self.span
        out = []
        for i in rows:
            if not any(np.nanmax(np.abs(self.x[i] - self.x[j])) <= tol
                       and np.nanmax(np.abs(self.y[i] - self.y[j])) <= tol
                       and np.nanmax(np.abs(self.c[i] - self.c[j])) <= 1e-6
                       and np.nanmax(np.abs(self.s[i] - self.s[j])) <= 1e-6 for j in out):
                out.append(int(i))
        return np.array(out, dtype=int)

    def to_global(self, b: int, S, rows=slice(None)):
        """Global x, y (N, k) of body-fixed points S (k, 2) of body b at the given rows."""
        S = np.asarray(S, float).reshape(-1, 2)
        c, s = self.c[rows, b][:, None], self.s[rows, b][:, None]
        return (self.x[rows, b][:, None] + c * S[:, 0] - s * S[:, 1],
                self.y[rows, b][:, None] + s * S[:, 0] + c * S[:, 1])

    def at(self, b: int, S, i: int) -> np.ndarray:
        """(k, 2) global positions of body-fixed points S of body b at row i (ground: S)."""
        if b == self.nb:
            return np.asarray(S, float).reshape(-1, 2)
        X, Y = self.to_global(b, S, [i])
        return np.c_[X[0], Y[0]]

    def at_all(self, b: int, s) -> np.ndarray:
        """(N, 2) global path of one body-fixed point s of body b (ground: s at every row)."""
        if b == self.nb:
            return np.tile(np.asarray(s, float), (len(self.t), 1))
        X, Y = self.to_global(b, s)
        return np.c_[X[:, 0], Y[:, 0]]


def _unique(points, tol=1e-9) -> np.ndarray:
    """(k, 2) distinct points (relative tolerance), in first-seen order. Beyond UNIQUE_PAIRS
    points (a body carrying thousands of points of interest), those that round to the same
    cell of that tolerance, in one sort rather than each against every other kept."""
    P = np.asarray(points, float).reshape(-1, 2)
    scale = max(np.abs(P).max(), 1e-300)
    if len(P) > UNIQUE_PAIRS:
        _, first = np.unique(np.round(P / (tol * scale)), axis=0, return_index=True)
        return P[np.sort(first)]
    out = []
    for p in P:
        if not any(np.abs(p - o).max() <= tol * scale for o in out):
            out.append(p)
    return np.array(out)


def _hull(P: np.ndarray) -> np.ndarray:
    """Convex hull (counter-clockwise, Andrew's monotone chain) of (k, 2) points."""
    pts = sorted(map(tuple, P))
    if len(pts) < 3:
        return np.array(pts)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def _area(V: np.ndarray) -> float:
    x, y = V[:, 0], V[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

