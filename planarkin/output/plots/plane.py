"""The mechanism in the plane: mechanism.<fmt> (a few instants and every path) and
trajectories.<fmt> (the paths of the points of interest)."""

from __future__ import annotations

import numpy as np

from . import labels
from .axes import add_axes
from .render import renderer_class
from .scene import Scene
from .style import (CROWD, DPI, FONT, GROUND_Z, darker, styled, text_width, tick_label_width,
                    with_alpha)


class Drawing:
    """The artists of the mechanism at one row; set_row moves them (the animation reuses them).

    color: one colour for every body (instants of mechanism.png) or body_colors=True for each
    body's own colour (as in bodies.<fmt>)."""

    def __init__(self, ax, scene: Scene, row: int, color=None, body_colors=False, alpha=1.0,
                 fill=0.25, zorder=10.0, labels=False, width=4.5, surfaces=True):
        from matplotlib.lines import Line2D
        from matplotlib.patches import Polygon

        def line(**kw):
            # Line2D and add_line: ax.plot parses its arguments and cycles properties, a third
            # of the cost of an empty line
            return ax.add_line(Line2D([], [], **kw))

        self.scene = scene
        self.ax = ax
        cm = scene.cm
        col = (lambda b: scene.colors[b]) if body_colors else (lambda b: color)
        self.parts = []                 # (artist, body, vertices, kind)
        outlines = {id(poly) for poly in scene.surfaces}
        for b in range(scene.nb):
            c = col(b)
            if scene.fills[b] is not None:
                patch = Polygon(scene.fills[b], closed=True, fc=with_alpha(c, fill * alpha),
                                ec=with_alpha(c, alpha), lw=2.0, zorder=zorder)
                ax.add_artist(patch)    # (the drawing's bounds set the limits)
                self.parts.append((patch, b, scene.fills[b], "fill"))
            if scene.bars[b] is not None:
                self.parts.append((line(color=c, lw=width, alpha=alpha, solid_capstyle="round",
                                        zorder=zorder), b, scene.bars[b], "line"))
            for poly in scene.dashed[b]:
                # a cam's profile and its roller are working surfaces: drawn solid, as a part
                # drawing does; pitch circles and slots stay dashed
                surface = id(poly) in outlines
                if surface and not surfaces:
                    continue
                self.parts.append((line(color=c, lw=1.6 if surface else 1.0,
                                        ls="-" if surface else "--", alpha=alpha,
                                        zorder=zorder + 0.1), b, poly, "line"))
            for poly in scene.faces[b]:
                self.parts.append((line(color=c, lw=0.75 * width, alpha=alpha,
                                        solid_capstyle="butt", zorder=zorder + 0.15), b, poly,
                                   "line"))
        self._plates(col, alpha, fill, zorder)
        edge = color if color is not None else "0.15"
        self.links = [line(color=edge, lw=1.2, alpha=alpha, zorder=zorder + 0.2)
                      for _ in scene.links]
        self.pins = line(ls="none", marker="o", ms=5.5, mfc="white", mec=edge, mew=1.3,
                         alpha=alpha, zorder=zorder + 0.5)
        self.points = [line(ls="none", marker="D", ms=5, mfc=scene.point_colors[k], mec=edge,
                            mew=0.8, alpha=alpha, zorder=zorder + 0.6)
                       for k in range(scene.named)]
        # the points after the named ones: one artist of small markers
        self.crowd = line(ls="none", marker="o", ms=2.5, mfc=CROWD, mec="none", alpha=alpha,
                          zorder=zorder + 0.55) if len(cm.point_names) > scene.named else None
        self.artists = ([a for a, _, _, _ in self.parts] + self.links + [self.pins]
                        + self.points + ([self.crowd] if self.crowd is not None else []))
        self.set_row(row)
        if labels:
            self._annotate(row)

    def _plates(self, col, alpha, fill, zorder):
        """The moving bodies' shapes (Scene.plates; ground's are drawn with the ground): a
        light fill, translucent so that overlaps show, in the body's colour, the lower layers
        first (and below), each hole a white circle with its outline."""
        from matplotlib.lines import Line2D
        from matplotlib.patches import Polygon

        sc = self.scene
        for p in sorted((p for p in sc.plates if p.body != sc.nb), key=lambda p: p.level):
            c = col(p.body)
            z = zorder + 0.02 * min(p.level, 4)
            if p.filled:
                patch = Polygon(p.outline, closed=True, fc=with_alpha(c, fill * alpha),
                                ec=with_alpha(c, alpha), lw=1.5, zorder=z)
                self.ax.add_artist(patch)
                self.parts.append((patch, p.body, p.outline, "fill"))
            else:
                line = self.ax.add_line(Line2D([], [], color=c, lw=2.0, alpha=alpha, zorder=z))
                self.parts.append((line, p.body, p.outline, "line"))
            for H in p.holes:
                hole = Polygon(H, closed=True, fc=with_alpha("white", alpha),
                               ec=with_alpha(darker(c), alpha), lw=0.9, zorder=z + 0.01)
                self.ax.add_artist(hole)
                self.parts.append((hole, p.body, H, "fill"))

    def set_row(self, i: int) -> None:
        sc = self.scene
        for artist, b, V, kind in self.parts:
            xy = sc.at(b, V, i)
            if kind == "fill":
                artist.set_xy(xy)
            else:
                artist.set_data(xy[:, 0], xy[:, 1])
        for line, (bi, si, bj, sj) in zip(self.links, sc.links):
            ends = np.r_[sc.at(bi, si, i), sc.at(bj, sj, i)]
            line.set_data(ends[:, 0], ends[:, 1])
        if sc.pins:
            pins = np.concatenate([sc.at(b, s, i) for b, s in sc.pins])
            self.pins.set_data(pins[:, 0], pins[:, 1])
        for m, xy in zip(self.points, sc.traces):      # the points' paths come first
            m.set_data(xy[i:i + 1, 0], xy[i:i + 1, 1])
        if self.crowd is not None:
            xy = sc.point_xy[i, sc.named:]
            self.crowd.set_data(xy[:, 0], xy[:, 1])

    def _annotate(self, i):
        """Body names (beside each body's centre) and point names at row i, placed clear of the
        pins, the ground pivots and each other (`labels.place`)."""
        sc = self.scene
        box = dict(boxstyle=f"round,pad={labels.PAD}", fc="white", ec="none", alpha=0.75)
        items, colors = [], []
        for b, name in enumerate(sc.names):
            V = sc.fills[b] if sc.fills[b] is not None else sc.bars[b]
            if V is None:       # a body drawn as its shapes: the first one's centre
                V = next((p.outline for p in sc.plates if p.body == b), None)
            if V is None:       # a cam or a gear (its frame at its pivot) or a lone point
                V = sc.dashed[b][0] if sc.dashed[b] and b not in sc.shaped else np.zeros((1, 2))
            items.append((name, sc.at(b, V, i).mean(axis=0), True))
            colors.append(darker(sc.colors[b]))
        for k, name in enumerate(sc.cm.point_names[:sc.named]):
            items.append((name, sc.traces[k][i], False))
            colors.append(darker(sc.point_colors[k]))
        pins = [sc.at(b, s, i)[0] for b, s in sc.pins] + list(sc.pivots) + \
            [sc.traces[k][i] for k in range(sc.named)]
        pins = [p for p in pins if np.isfinite(p).all()]
        obstacles = labels.pin_boxes(self.ax, np.array(pins)) + \
            labels.pivot_boxes(self.ax, sc.pivots, 0.55 * sc.size)
        offsets = labels.place(self.ax, items, obstacles)
        for (name, p, body), color, (dx, dy) in zip(items, colors, offsets):
            lead = dict(arrowstyle="-", color=color, lw=0.6, shrinkA=0, shrinkB=0) \
                if np.hypot(dx, dy) > labels.LEADER else None
            self.ax.annotate(name, p, xytext=(dx, dy), textcoords="offset points", ha="center",
                             va="center", fontsize=FONT, color=color,
                             fontweight="bold" if body else "normal", bbox=box, zorder=40,
                             arrowprops=lead)

    def legend_handles(self):
        from matplotlib.patches import Patch
        sc = self.scene
        return [Patch(fc=with_alpha(sc.colors[b], 0.35), ec=sc.colors[b], label=name)
                for b, name in enumerate(sc.names)]


def plane_figure(cm, scene: Scene, width, beside, dpi=DPI, ground_alpha=1.0):
    """Figure with one equal-aspect axes for drawings of the mechanism, sized to the drawing.

    width: figure width and beside: room right of the axes (legend), inches. The height follows
    the drawing's aspect ratio (within limits: the equal aspect widens the other range). Returns
    (figure, axes, upper-left corner of the room beside the axes in figure coordinates)."""
    from matplotlib.figure import Figure

    fig = Figure(dpi=dpi)
    ax = add_axes(fig, (0, 0, 1, 1))
    _mechanism_axes(ax, cm, scene, ground_alpha)
    x0, x1, y0, y1 = scene.bounds
    label_w = tick_label_width(ax.yaxis, y0, y1)
    left = label_w + 0.5
    bottom, top = 0.55, 0.45
    aw = width - left - beside
    ah = float(np.clip(aw * (y1 - y0) / (x1 - x0), 2.4, 6.8)) if x1 > x0 else aw
    height = ah + bottom + top
    fig.set_size_inches(width, height)
    ax.set_position((left / width, bottom / height, aw / width, ah / height))
    # the axis labels at fixed places, as in the time histories (arrange_time_grid)
    ax.yaxis.set_label_coords(-(label_w + 0.15) / aw, 0.5)
    ax.xaxis.set_label_coords(0.5, -0.29 / ah)
    return fig, ax, ((left + aw + 0.15) / width, (bottom + ah) / height)


def _mechanism_axes(ax, cm, scene: Scene, ground_alpha=1.0):
    """Equal-aspect axes in the length unit, with the ground pivots and slide axes drawn."""
    from matplotlib.patches import Polygon, Rectangle

    unit = cm.spec.length_unit
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    x0, x1, y0, y1 = scene.bounds
    ax.update_datalim([(x0, y0), (x1, y1)])     # limits stay automatic: the equal aspect
    ax.margins(0.0)                             # widens whichever range the axes need
    ax.set_aspect("equal", adjustable="datalim")
    h = 0.55 * scene.size
    for p in scene.pivots:
        px, py = p
        # above the bodies (which pass over their pivots), with a pin of its own on top
        ax.add_patch(Polygon([(px, py), (px - 0.6 * h, py - h), (px + 0.6 * h, py - h)],
                             closed=True, fc="0.85", ec="0.25", lw=1.0, alpha=ground_alpha,
                             zorder=GROUND_Z))
        ax.add_patch(Rectangle((px - 0.9 * h, py - 1.35 * h), 1.8 * h, 0.35 * h, fc="none",
                               ec="0.35", lw=0.0, hatch="/////", alpha=ground_alpha,
                               zorder=GROUND_Z))
    if scene.pivots:
        P = np.array(scene.pivots)
        ax.plot(P[:, 0], P[:, 1], ls="none", marker="o", ms=5.5, mfc="white", mec="0.15",
                mew=1.3, alpha=ground_alpha, zorder=GROUND_Z + 0.5)
    for seg in scene.axes:
        ax.plot(seg[:, 0], seg[:, 1], color="0.3", lw=1.0, ls=(0, (6, 3)), alpha=ground_alpha,
                zorder=7)
    _obstacles(ax, scene, ground_alpha)


def _obstacles(ax, scene: Scene, alpha=1.0):
    """The shapes on ground (frame obstacles: walls, housings), hatched as a section of the
    frame, under the paths and the bodies; a polyline without radius as a thick line."""
    from matplotlib.patches import Polygon

    for p in scene.plates:
        if p.body != scene.nb:
            continue
        if p.filled:
            ax.add_patch(Polygon(p.outline, closed=True, fc="0.9", ec="0.3", lw=1.0,
                                 hatch="////", alpha=alpha, zorder=3))
        else:
            ax.plot(p.outline[:, 0], p.outline[:, 1], color="0.3", lw=2.0, alpha=alpha,
                    solid_capstyle="butt", zorder=3)
        for H in p.holes:
            ax.add_patch(Polygon(H, closed=True, fc="white", ec="0.3", lw=0.9, alpha=alpha,
                                 zorder=3.1))


@styled
def trajectories_figure(cm, scene: Scene):
    """Paths of the points of interest, start dots, direction arrows, the mechanism faint at
    t = start."""
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D
    from matplotlib.transforms import Affine2D

    fig, ax, _ = plane_figure(cm, scene, 8.0, 0.25, ground_alpha=0.5)
    Drawing(ax, scene, 0, color="0.6", alpha=0.45, zorder=9)
    handles, heads, tips, colors = [], [], [], []
    crowd = _crowd(ax, scene, zorder=11)
    for k, name in enumerate(cm.point_names[:scene.named]):
        xy = scene.traces[k]
        c = scene.point_colors[k]
        line, = ax.plot(xy[:, 0], xy[:, 1], color=c, lw=1.6, zorder=12, label=name)
        ax.plot(xy[0, 0], xy[0, 1], "o", color=c, ms=6, zorder=13)
        if not np.nanmax(np.ptp(xy, axis=0)) > 1e-6 * scene.span:
            continue        # a point that does not move (a ground pin): no path to name
        handles.append(line)
        for a, b in _arrow_spots(xy, 0.04 * scene.span):
            heads.append(_arrow_head(np.subtract(b, a)))
            tips.append(b)
            colors.append(c)
    if heads:
        # the direction marks: filled heads of 5.2 by 5.2 points at the arrows' ends (what
        # FancyArrowPatch(arrowstyle="-|>", mutation_scale=13, lw=0) draws), in one
        # collection; on the equal-aspect axes a direction in the data is the same on paper
        ax.add_collection(PolyCollection(heads, offsets=tips, offset_transform=ax.transData,
                                         transform=Affine2D().scale(1 / 72)
                                         + fig.dpi_scale_trans, facecolors=colors,
                                         edgecolors="none", linewidths=0, zorder=13),
                          autolim=False)
    handles += crowd
    handles += [Line2D([], [], ls="none", marker="o", color="0.2", ms=6, label="start"),
                Line2D([], [], ls="none", marker=">", color="0.2", ms=6, label="direction"),
                Line2D([], [], color="0.6", lw=3, alpha=0.6, label=f"mechanism at t = "
                                                                   f"{scene.t[0]:.4g} s")]
    ncol = 1 if len(handles) <= 12 else 2
    ax.legend(handles=handles, loc=_quiet_corner(ax, scene, handles, ncol), fontsize=FONT,
              ncol=ncol, framealpha=0.85)
    ax.set_title(f"{cm.spec.name}: paths of the points "
                 f"(t = {scene.t[0]:.4g} to {scene.t[-1]:.4g} s)", fontsize=12, y=1.0)
    return fig


def _crowd(ax, scene: Scene, zorder) -> list:
    """The paths of the points after the named ones as one collection (Scene.crowd); returns
    its legend handle ([] when there are none)."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    paths = scene.crowd()
    if not paths:
        return []
    ax.add_collection(LineCollection(paths, colors=CROWD, linewidths=0.7, zorder=zorder),
                      autolim=False)
    return [Line2D([], [], color=CROWD, lw=1.2, label=f"{len(paths)} more points")]


def _arrow_head(d, length=5.2, half_width=2.6, shrink=2.0) -> np.ndarray:
    """(3, 2) vertices in points of an arrow head pointing along d, its tip shrink points
    short of the origin (the arrow's end)."""
    u = np.asarray(d, float) / np.hypot(*d)
    n = np.array([-u[1], u[0]])
    tip = -shrink * u
    base = tip - length * u
    return np.array([tip, base + half_width * n, base - half_width * n])


def _quiet_corner(ax, scene, handles, ncol=1) -> str:
    """The corner of the axes where a legend of these handles covers the fewest points of the
    paths and of the drawing (loc="best" without matplotlib's search, which lays the legend
    out and tests every vertex of every artist at each of nine places: a sixth of the time of
    this figure). The legend's size is estimated from its labels; the axes' limits are the
    drawing's bounds widened to the axes' aspect ratio, as the equal aspect widens them."""
    x0, x1, y0, y1 = scene.bounds
    pos = ax.get_position()
    W, H = ax.figure.get_size_inches()
    aw, ah = pos.width * W, pos.height * H
    if not (x1 > x0 and y1 > y0 and aw > 0 and ah > 0):
        return "upper right"
    k = max((x1 - x0) / aw, (y1 - y0) / ah)          # data units per inch
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    x0, x1, y0, y1 = cx - 0.5 * k * aw, cx + 0.5 * k * aw, cy - 0.5 * k * ah, cy + 0.5 * k * ah
    em = FONT / 72.0
    rows = -(-len(handles) // ncol)
    lw = ncol * (text_width([h.get_label() for h in handles]) + 3.6 * em) + 0.8 * em
    lh = rows * 1.5 * em + 0.8 * em
    pad = 0.5 * em
    # the paths, the ground pivots and the edges of the bodies at the first instant (drawn)
    edges = []
    drawn = [(b, V) for b in range(scene.nb) for V in (scene.fills[b], scene.bars[b])
             if V is not None] + [(p.body, p.outline) for p in scene.plates]
    for b, V in drawn:
        G = scene.at(b, V, 0)
        G = np.r_[G, G[:1]] if len(G) > 2 else G
        f = np.linspace(0.0, 1.0, 16)[:, None, None]
        edges.append((G[:-1] + f * (G[1:] - G[:-1])).reshape(-1, 2))
    P = np.concatenate([np.asarray(xy, float).reshape(-1, 2) for xy in scene.traces]
                       + [np.asarray(scene.pivots, float).reshape(-1, 2)] + edges)
    P = P[np.isfinite(P).all(axis=1)]
    u, v = (P[:, 0] - x0) / k, (P[:, 1] - y0) / k     # inches from the lower left corner
    best, where = None, "upper right"
    for loc, (left, bottom) in (("upper right", (aw - pad - lw, ah - pad - lh)),
                                ("upper left", (pad, ah - pad - lh)),
                                ("lower left", (pad, pad)),
                                ("lower right", (aw - pad - lw, pad))):
        n = int(np.count_nonzero((u >= left) & (u <= left + lw) & (v >= bottom)
                                 & (v <= bottom + lh)))
        if best is None or n < best:
            best, where = n, loc
    return where


def _arrow_spots(xy, length, fractions=(0.1, 0.4, 0.7)):
    """Arrow (tail, head) pairs at the given fractions of a path's length, tangent to it (not
    symmetric about 0.5, so that a path run there and back does not get opposite arrows on the
    same spot)."""
    ok = np.all(np.isfinite(xy), axis=1)
    xy = xy[ok]
    if len(xy) < 2:
        return []
    seg = np.hypot(*np.diff(xy, axis=0).T)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] <= 0:
        return []
    out = []
    for f in fractions:
        i = min(int(np.searchsorted(s, f * s[-1])), len(xy) - 2)
        j0, j1 = max(i - 2, 0), min(i + 3, len(xy) - 1)
        d = xy[j1] - xy[j0]
        nd = np.hypot(*d)
        if nd <= 0:
            continue
        d = d / nd * length
        out.append((tuple(xy[i] - 0.5 * d), tuple(xy[i] + 0.5 * d)))
    return out


def instant_count(cm) -> int:
    """Instants drawn in mechanism.<fmt> by default: four for up to three moving bodies, three
    beyond (a six-bar drawn six times over is a tangle)."""
    return 4 if cm.nb <= 3 else 3


@styled
def mechanism_figure(cm, scene: Scene, instants: int | None = None, minima=()):
    """The mechanism at a few instants and every path of the run.

    Every body in its own colour (as in bodies.<fmt>), named in that colour at the first
    instant, which is drawn solid; the later instants fade (the legend gives their times). A run
    that is not a full cycle always shows its final pose; instants with the same pose are drawn
    once.

    minima: each pair of shapes' closest approach (objects with a, b, t, d, pa, pb, user units;
    limit where known: `planarkin.clearance.cycle.minima`): the instant nearest the least of
    them is drawn too, and it and those closer than their limit are marked where their instant
    is drawn (`clearance.notable`, `clearance.mark_closest`)."""
    from matplotlib.lines import Line2D

    from .clearance import MARK_COLOR

    # plates cover more of the page than bars: one instant fewer
    plated = any(p.body != scene.nb for p in scene.plates)
    rows = scene.instants(instants or instant_count(cm) - plated)
    rows, closest, marked = _closest_instant(scene, rows, minima)
    times = [f"t = {scene.t[i]:.4g} s" for i in rows]
    if len(rows) > 1:
        times[0] += " (named)"
    alphas = [1.0] + list(np.linspace(0.5, 0.22, len(rows) - 1))
    if closest is not None:
        times[closest] += " (closest approach)"
        alphas[closest] = max(alphas[closest], 0.7)
    # a centrode's label on two lines: a long one would narrow the drawing
    npts = len(cm.point_names)
    crowd = f"{npts - scene.named} more points"
    entries = times + [s[0] for k, (s, xy) in enumerate(zip(scene.trace_styles, scene.traces))
                       if not scene.named <= k < npts
                       and (not s[1] or np.nanmax(np.ptp(xy, axis=0)) > 1e-6 * scene.span)] + \
        ([crowd] if npts > scene.named else []) + \
        [w for j, _ in scene.centrodes for w in ("fixed centrode", f"of {scene.names[j]}")] + \
        [w for j, _ in scene.moving for w in ("moving centrode", f"of {scene.names[j]}")] + \
        (["closest approach"] if marked else [])
    fig, ax, beside = plane_figure(cm, scene, 9.0, 0.65 + text_width(entries))
    handles, seen = [], set()
    tol = 1e-6 * scene.span
    for k, (xy, (label, is_point, c, w)) in enumerate(zip(scene.traces, scene.trace_styles)):
        if scene.named <= k < npts:
            continue            # the crowd: one collection, after the named paths
        line, = ax.plot(xy[:, 0], xy[:, 1], color=c, lw=w, zorder=5,
                        ls="-" if is_point else (0, (4, 2)))
        if is_point and not np.nanmax(np.ptp(xy, axis=0)) > tol:
            continue        # a point that does not move (a ground pin): no path to name
        if label not in seen:
            seen.add(label)
            line.set_label(label)
            handles.append(line)
    handles += _crowd(ax, scene, zorder=4.5)
    # output: centres: each floating body's fixed centrode, light, in the body's colour
    for j, xy in scene.centrodes:
        line, = ax.plot(xy[:, 0], xy[:, 1], color=scene.colors[j], lw=1.5, alpha=0.8,
                        ls=(0, (1, 1.5)), zorder=4,
                        label=f"fixed centrode\nof {scene.names[j]}")
        handles.append(line)
    if scene.moving:
        from planarkin.measures.centres import draw_moving
        handles += draw_moving(ax, scene, rows[0])
    # later instants below the first, fainter the later they are; a cam's profile at the
    # first only (turned copies of it overlapped into a tangle: cam.png draws the profile)
    for k in range(len(rows) - 1, -1, -1):
        Drawing(ax, scene, rows[k], body_colors=True, alpha=alphas[k],
                 fill=0.22 if k == 0 else 0.12, zorder=20 - k, labels=(k == 0),
                 width=4.5 if k == 0 else 3.0, surfaces=(k == 0))
    handles += [Line2D([], [], color="0.2", lw=4 if k == 0 else 3, alpha=a, label=tt)
                for k, (tt, a) in enumerate(zip(times, alphas))]
    if marked:
        mark_approaches(ax, scene, marked)
        handles.append(Line2D([], [], color=MARK_COLOR, lw=1.4, marker="o", ms=3.5,
                              label="closest approach"))
    legend = fig.legend(handles=handles, loc="upper left", bbox_to_anchor=beside,
                        fontsize=FONT, frameon=False, borderaxespad=0)
    fit_legend(fig, legend, ax, beside)
    ax.set_title(f"{cm.spec.name}: mechanism at {len(rows)} instant{'s' * (len(rows) > 1)}, "
                 f"paths over t = {scene.t[0]:.4g} to {scene.t[-1]:.4g} s", fontsize=12, y=1.0)
    return fig


def mark_approaches(ax, scene: Scene, minima, animated=False) -> list:
    """Mark the closest approaches (`clearance.mark_closest`), their labels clear of the pins
    at their rows and of the ground pivots; returns the artists."""
    from .clearance import mark_closest, nearest_row

    rows = sorted({nearest_row(scene.t, m.t) for m in minima})
    pins = [scene.at(b, s, r)[0] for r in rows for b, s in scene.pins] + list(scene.pivots)
    pins = np.array([p for p in pins if np.isfinite(p).all()]).reshape(-1, 2)
    return mark_closest(ax, minima, scene.cm.spec.length_unit, animated=animated,
                        obstacles=labels.pin_boxes(ax, pins))


def _closest_instant(scene: Scene, rows, minima):
    """(rows, k, marked): the instants to draw with the row nearest the least of the minima
    added (k: its index in rows; None without minima) and the minima whose nearest row is
    drawn, to mark."""
    from .clearance import nearest_row, notable

    minima = notable(minima)
    if not minima or not len(scene.t):
        return rows, None, []
    worst = min(minima, key=lambda m: m.d)
    r = nearest_row(scene.t, worst.t)
    rows = np.unique(np.r_[np.asarray(rows, int), r])
    drawn = set(rows.tolist())
    return rows, int(np.searchsorted(rows, r)), [m for m in minima
                                                  if nearest_row(scene.t, m.t) in drawn]


def fit_legend(fig, legend, ax, anchor):
    """Widen the figure until the legend beside the axes fits (the width of its texts is only
    estimated when the figure is laid out), keeping the axes' size and place in inches; the
    legend's upper-left corner is at anchor (figure fraction before widening)."""

    W, H = fig.get_size_inches()
    dpi = fig.dpi
    box = legend.get_window_extent(renderer_class()(int(W * dpi), int(H * dpi), dpi))
    extra = box.x1 / dpi + 0.08 - W                   # inches past the right edge
    if extra <= 0:
        return
    pos = ax.get_position()
    k = W / (W + extra)
    fig.set_size_inches(W + extra, H)
    ax.set_position((pos.x0 * k, pos.y0, pos.width * k, pos.height))
    legend.set_bbox_to_anchor((anchor[0] * k, anchor[1]), transform=fig.transFigure)


