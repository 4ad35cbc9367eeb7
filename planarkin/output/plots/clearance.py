"""clearance.<fmt> (issue 29): the distance between each pair of shapes against time, the
clearance limit drawn, each pair's minimum marked with its time and value, the overlaps shaded;
and the closest approach as mechanism.<fmt> and animation.gif mark it (`mark_closest`).

The numbers come from planarkin.clearance (the distances over the cycle and each pair's minimum
with its witness points); this module only draws them, in user units.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .style import FONT, body_palette, darker, styled

LIMIT_COLOR = "tab:red"        # the limit line, as cam.<fmt> draws its limits
MARK_COLOR = "#c1121f"         # the closest approach in the drawings
OVERLAP_COLOR = (0.84, 0.15, 0.16, 0.14)
RING = 15.0                    # the ring around a closest approach, points across


def pair_palette(n: int) -> list:
    """The pairs' colours: tab10 without its red (the limit's and the overlaps' colour), then
    the house's body palette."""
    if n <= 9:
        from matplotlib import colormaps
        return [colormaps["tab10"](k) for k in (0, 1, 2, 4, 5, 6, 7, 8, 9)[:n]]
    return body_palette(n)


def pair_label(a: str, b: str) -> str:
    """A pair's name in the legends: "crank \u2013 rocker"."""
    return f"{a} \u2013 {b}"


def draw(t, distances: dict, minima=None, limit: float | dict | None = None,
         out: Path = Path("."), fmt: str = "png", unit: str = "m", name: str = "") -> Path:
    """Write out/clearance.<fmt> (`clearance_figure`); returns its path."""
    from .render import save_figure

    fmt = fmt.lower().lstrip(".")
    fig = clearance_figure(t, distances, minima, limit, unit, name)
    return save_figure(fig, Path(out) / f"clearance.{fmt}")


@styled
def clearance_figure(t, distances: dict, minima=None, limit: float | dict | None = None,
                     unit: str = "m", name: str = ""):
    """The distances against time, one line per pair.

    t: (N,) s; distances: {(a, b): (N,) distance in unit} (a and b: the shapes' names; negative
    or zero where the shapes overlap; nan where not computed), in the order to draw them, at
    least one pair (ValueError otherwise);
    minima: objects with a, b, t (s) and d (unit), one per pair (`planarkin.clearance.cycle.
    minima`: exact, between rows); None: each pair's smallest value on the rows. limit: the
    model's `clearance: {min: ...}` in unit, or {(a, b): limit} for pairs with limits of their
    own (a pair left out has none; None: no limit line). name: the model's name, for the title.
    Each minimum is a dot labelled with its value and time; each limit a red dashed line
    (several: each named with its pairs); the times where a pair overlaps are shaded."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch
    from matplotlib.ticker import MaxNLocator

    from .history import arrange_time_grid, time_grid

    t = np.asarray(t, float)
    pairs = list(distances)
    if not pairs:
        raise ValueError("clearance_figure: no pairs of shapes to draw")
    D = [np.asarray(distances[p], float) for p in pairs]
    colors = pair_palette(max(len(pairs), 1))
    lows = _minima(t, pairs, D, minima)
    fig, axes = time_grid(1, 1)
    ax = axes[0][0]
    ax.yaxis.set_major_locator(MaxNLocator(nbins=6, steps=[1, 2, 2.5, 5, 10]))
    handles = []
    for p, d, c in zip(pairs, D, colors):
        line, = ax.plot(t, d, color=c, lw=1.5, zorder=3, label=pair_label(*p))
        handles.append(line)
    overlap = _overlap_spans(t, D)
    for t0, t1 in overlap:
        ax.axvspan(t0, t1, fc=OVERLAP_COLOR, ec="none", zorder=0.5)
    ax.axhline(0.0, color="0.35", lw=0.7, zorder=1.6)
    levels = _levels(pairs, limit)
    for value, which in levels.items():
        ax.axhline(value, color=LIMIT_COLOR, lw=1.1, ls=(0, (4, 2)), zorder=2)
        if len(levels) > 1:             # which pairs each line is for, above it at the right
            _limit_label(ax, value, f"{value:.4g} {unit}: " + ", ".join(
                pair_label(*pairs[k]) for k in which))
    if levels:
        handles.append(Line2D([], [], color=LIMIT_COLOR, lw=1.1, ls=(0, (4, 2)),
                              label=f"limit {next(iter(levels)):.4g} {unit}"
                              if len(levels) == 1 else "limits"))
    _limits(ax, t, D, lows, list(levels))
    _mark_minima(ax, lows, colors, unit)
    if lows:
        handles.append(Line2D([], [], ls="none", marker="o", ms=6, mfc="white", mec="0.2",
                              mew=1.5, label="minimum"))
    if overlap:
        handles.append(Patch(fc=OVERLAP_COLOR, ec="none", label="overlap"))
    ax.set_ylabel(f"distance [{unit}]")
    worst = min((m[2] for m in lows), default=None)
    what = "clearance between shapes"
    if worst is not None:
        what += f" (least {worst:.4g} {unit})" if worst > 0 else \
            f" (overlap, {-worst:.4g} {unit} deep)" if worst < 0 else " (touching)"
    arrange_time_grid(fig, axes, handles, f"{name}: {what}" if name else what, width=8.0,
                      row_height=3.2)
    return fig


def _minima(t, pairs, D, minima) -> list:
    """[(pair index, t, d)] of each pair's minimum: the given ones (matched by name, either
    order), else the smallest value on the rows."""
    out = []
    if minima is not None:
        index = {p: k for k, p in enumerate(pairs)}
        for m in minima:
            k = index.get((m.a, m.b), index.get((m.b, m.a)))
            if k is not None and math.isfinite(m.t) and math.isfinite(m.d):
                out.append((k, float(m.t), float(m.d)))
        return out
    for k, d in enumerate(D):
        if np.isfinite(d).any():
            i = int(np.nanargmin(d))
            out.append((k, float(t[i]), float(d[i])))
    return out


def _levels(pairs, limit) -> dict:
    """{limit value: [pair indices]}, in order of first use: one value for every pair, or each
    pair's from the dict {(a, b) (either order): value}; no finite value, no line."""
    out: dict = {}
    for k, (a, b) in enumerate(pairs):
        v = limit.get((a, b), limit.get((b, a))) if isinstance(limit, dict) else limit
        if v is not None and math.isfinite(v):
            out.setdefault(float(v), []).append(k)
    return out


def _limit_label(ax, y, text):
    """A limit line's name, right-aligned just above it (as cam.<fmt> names its limits)."""
    from matplotlib.transforms import blended_transform_factory
    ax.text(0.99, y, text, transform=blended_transform_factory(ax.transAxes, ax.transData),
            ha="right", va="bottom", fontsize=FONT - 0.5, color=LIMIT_COLOR, zorder=4,
            bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.5))


def _overlap_spans(t, D) -> list:
    """[(t0, t1)]: the time intervals where some pair's distance is zero or less (each from
    the row before to the row after, so that a single row shows)."""
    if not D or not len(t):
        return []
    with np.errstate(invalid="ignore"):
        hit = np.any([d <= 0 for d in D], axis=0)
    spans, k, n = [], 0, len(t)
    while k < n:
        if not hit[k]:
            k += 1
            continue
        j = k
        while j + 1 < n and hit[j + 1]:
            j += 1
        spans.append((float(t[max(k - 1, 0)]), float(t[min(j + 1, n - 1)])))
        k = j + 1
    return spans


def _limits(ax, t, D, lows, limits):
    """The time range of the run; distances from zero (or the deepest overlap) to the largest,
    the limits and the minima's labels inside."""
    if len(t) and t[-1] > t[0]:
        ax.set_xlim(float(t[0]), float(t[-1]))
    vals = [d[np.isfinite(d)] for d in D]
    vals = np.concatenate(vals) if vals else np.zeros(0)
    vals = np.r_[vals, [m[2] for m in lows], limits]
    lo = min(0.0, float(vals.min())) if len(vals) else 0.0
    hi = float(vals.max()) if len(vals) else 1.0
    span = hi - lo if hi > lo else max(abs(hi), 1.0)
    ax.set_ylim(lo - 0.06 * span if lo < 0 else lo, hi + 0.14 * span)


def _mark_minima(ax, lows, colors, unit):
    """Each minimum a dot in its pair's colour, labelled "1.234 mm at 0.412 s" where the label
    meets no other (`labels.place`), a leader line when pushed away."""
    from . import labels

    if not lows:
        return
    P = np.array([(tm, dm) for _, tm, dm in lows])
    ax.plot(P[:, 0], P[:, 1], ls="none", marker="o", ms=6, mfc="white", mec="0.2", mew=1.5,
            zorder=5)
    for (k, tm, dm), (x, y) in zip(lows, P):
        ax.plot([x], [y], ls="none", marker="o", ms=3.2, color=colors[k], zorder=5.1)
    texts = [f"{dm:.4g} {unit} at {tm:.3g} s".replace("-", "\u2212") for _, tm, dm in lows]
    offsets = labels.place(ax, [(s, p, False) for s, p in zip(texts, P)],
                           labels.pin_boxes(ax, P))
    box = dict(boxstyle=f"round,pad={labels.PAD}", fc="white", ec="none", alpha=0.85)
    for (k, _, _), s, p, (dx, dy) in zip(lows, texts, P, offsets):
        color = darker(colors[k])
        # a line to the dot only for a label pushed beyond the first ring of places
        near = labels.ROUNDS[0][0] + 0.5 * labels.text_box(s, False)[0]
        lead = dict(arrowstyle="-", color=color, lw=0.6, shrinkA=0, shrinkB=3) \
            if abs(dx) > near + 1 or abs(dy) > labels.ROUNDS[0][1] + 1 else None
        ax.annotate(s, p, xytext=(dx, dy), textcoords="offset points", ha="center",
                    va="center", fontsize=FONT, color=color, bbox=box, zorder=6,
                    arrowprops=lead)


def notable(minima) -> list:
    """The closest approaches worth marking in a drawing, in the order given: the least of
    them, and every one closer than its limit (an attribute `limit`, where the objects have
    it); not those far apart at the instant they are nearest."""
    ms = [m for m in minima or () if math.isfinite(m.t) and math.isfinite(m.d)]
    if not ms:
        return []
    worst = min(ms, key=lambda m: m.d)
    return [m for m in ms if m is worst or m.d < (getattr(m, "limit", None) or -math.inf)]


def mark_closest(ax, minima, unit: str, zorder: float = 30.0, animated: bool = False,
                 obstacles=()) -> list:
    """Closest approaches in a drawing of the mechanism, each (m: a, b, d, pa, pb, world
    coordinates, unit) a line from pa to pb with a dot at each end, a ring around it where it
    is short on paper (a gap of a tenth of a millimetre is no line) and its value beside it ("crank \u2013 rocker:
    1.23 mm"; "overlap" where d < 0), the labels placed clear of each other, the rings and
    obstacles (boxes in points, `labels.place`). Call it once the axes' limits are final.
    Returns the artists."""
    from . import labels

    artists, items, rings = [], [], []
    grow = 0.5 * RING - labels.PIN
    for m in minima:
        pa, pb = np.asarray(m.pa, float), np.asarray(m.pb, float)
        mid = 0.5 * (pa + pb)
        d = float(m.d)
        value = f"{d:.3g} {unit}" if d > 0 else f"overlap {-d:.3g} {unit}" if d < 0 \
            else "touching"
        items.append((f"{pair_label(m.a, m.b)}: {value}", mid, False))
        artists += ax.plot([pa[0], pb[0]], [pa[1], pb[1]], color=MARK_COLOR, lw=1.4,
                           marker="o", ms=3.0, solid_capstyle="butt", zorder=zorder,
                           animated=animated)
        ends = labels.to_points(ax, [pa, pb])
        if np.hypot(*(ends[1] - ends[0])) < RING:       # short on paper: ringed
            artists += ax.plot([mid[0]], [mid[1]], ls="none", marker="o", ms=RING,
                               mfc="none", mec=MARK_COLOR, mew=1.3, zorder=zorder,
                               animated=animated)
            x0, y0, x1, y1 = labels.pin_boxes(ax, mid[None])[0]
            rings.append((x0 - grow, y0 - grow, x1 + grow, y1 + grow))
    offsets = labels.place(ax, items, list(obstacles) + rings) if items else []
    box = dict(boxstyle=f"round,pad={labels.PAD}", fc="white", ec="none", alpha=0.85)
    for (text, mid, _), (dx, dy) in zip(items, offsets):
        # a label pushed away from its mark gets a thin line to it (as the body names do)
        w, h = labels.text_box(text, False)
        gap = max(abs(dx) - 0.5 * w, abs(dy) - 0.5 * h)         # points, box to mark
        lead = dict(arrowstyle="-", color=MARK_COLOR, lw=0.6, shrinkA=0, shrinkB=0.5 * RING) \
            if gap > 0.5 * RING + 4 else None
        artists.append(ax.annotate(text, mid, xytext=(dx, dy), textcoords="offset points",
                                   ha="center", va="center", fontsize=FONT, color=MARK_COLOR,
                                   zorder=zorder + 10, bbox=box, animated=animated,
                                   arrowprops=lead))
    return artists


def nearest_row(t, when: float) -> int:
    """The row of t (sorted, s) nearest the time when."""
    t = np.asarray(t, float)
    i = int(np.clip(np.searchsorted(t, when), 1, max(len(t) - 1, 1)))
    return i - 1 if len(t) < 2 or abs(t[i - 1] - when) <= abs(t[i] - when) else i
