"""The time histories: bodies.<fmt> and points.<fmt> (and the layout, event lines and abscissa
that forces.<fmt> shares)."""

from __future__ import annotations

import math

import numpy as np

from planarkin.solver.layout import BODY_QUANTITIES, POINT_QUANTITIES, units
from .axes import add_axes
from .style import (FONT, NAMED_POINTS, ROW_NAMES, body_palette, duration, entry_width, plot_title,
                    point_palette, pretty, styled, tick_label_width)


@styled
def bodies_figure(cm, data, info, x: str = "time"):
    """3 x 2 grid (rows that exist): frame origins x, y (left) and angles (right) against time.

    Curves constant over the run (a frame pinned to ground) or identical to one already drawn
    are left out and named, with their value, in a note under the legend (an axes whose curves
    are all constant keeps them)."""
    series = [a for a in (data.q, data.qd, data.qdd, data.qddd) if a is not None]
    colors = body_palette(cm.nb)
    xa = XAxis(cm, x)
    X = xa(data.t)
    fig, axes = time_grid(len(series), 2, xa.label)
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    T = duration(data, info)
    sel = Selection()
    for o, arr in enumerate(series):
        tu, ru = (pretty(u) for u in units(lu, au, o))
        qx, qy, qphi = BODY_QUANTITIES[o]
        left, right = axes[o]
        lin = [(arr[:, 3 * b + k], colors[b], ls, f"{name}.{q}", (b, k))
               for b, name in enumerate(cm.body_names) for k, q, ls in ((0, qx, "-"),
                                                                        (1, qy, "--"))]
        ang = [(arr[:, 3 * b + 2], colors[b], "-", f"{name}.{qphi}", (b, 2))
               for b, name in enumerate(cm.body_names)]
        sel.draw(left, X, lin, cm.L / T ** o, tu, o)
        sel.draw(right, X, ang, 1.0 / cm.angle_factor / T ** o, ru, o)
        left.set_ylabel(f"{qx}, {qy} [{tu}]")
        right.set_ylabel(f"{qphi} [{ru}]")
    axes[0][0].set_title("translation of the body frames", fontsize=10, y=1.0)
    axes[0][1].set_title("rotation", fontsize=10, y=1.0)
    handles = _style_handles([("-", "x, phi"), ("--", "y")]) + _name_handles(
        cm.body_names, colors, sel.drawn)
    finish_time_axes(axes, data, info, xa)
    title = plot_title(cm, "body frames: " + ", ".join(ROW_NAMES[:len(series)]) + xa.against,
                   info)
    arrange_time_grid(fig, axes, handles, title, width=10.0, row_height=1.75,
                       note=sel.note())
    return fig


@styled
def points_figure(cm, data, info, x: str = "time"):
    """One column: x, y of every point (and their derivatives) against time; constant and
    repeated curves left out as in bodies.<fmt>."""
    series = [a for a in (data.p, data.pd, data.pdd, data.pddd) if a is not None]
    names = list(cm.point_names[:NAMED_POINTS])        # the rest: in points.csv only
    colors = point_palette(len(names))
    xa = XAxis(cm, x)
    X = xa(data.t)
    fig, axes = time_grid(len(series), 1, xa.label)
    T = duration(data, info)
    sel = Selection()
    for o, arr in enumerate(series):
        tu, _ = (pretty(u) for u in units(cm.spec.length_unit, cm.spec.angle_unit, o))
        qx, qy = POINT_QUANTITIES[o]
        ax = axes[o][0]
        curves = [(arr[:, k, c], colors[k], ls, f"{name}.{q}", (k, c))
                  for k, name in enumerate(names)
                  for c, q, ls in ((0, qx, "-"), (1, qy, "--"))]
        sel.draw(ax, X, curves, cm.L / T ** o, tu, o)
        ax.set_ylabel(f"{qx}, {qy} [{tu}]")
    handles = _style_handles([("-", "x"), ("--", "y")]) + _name_handles(
        names, colors, sel.drawn)
    finish_time_axes(axes, data, info, xa)
    title = plot_title(cm, "points: " + ", ".join(ROW_NAMES[:len(series)]) + xa.against, info)
    note = sel.note()
    if len(cm.point_names) > len(names):
        note = "; ".join(([note] if note else []) + [
            f"the points after the first {len(names)} ({len(cm.point_names) - len(names)} "
            f"more) are not drawn: points.csv has every point"])
    arrange_time_grid(fig, axes, handles, title, width=7.0, row_height=1.7, note=note)
    return fig


class Selection:
    """Which curves of a time-history figure are drawn.

    A curve is constant when its range is within 1e-9 of its axes' scale (ref: model length /
    duration^order, or one radian), identical to another when they differ by no more than that
    everywhere. The derivatives of a coordinate constant in position are not named again."""

    def __init__(self):
        self.drawn = set()              # indices (first element of a curve's key) drawn
        self.constant = []              # "name = value unit"
        self.same = []                  # "name = other"
        self.still = set()              # keys constant in position

    def draw(self, ax, t, curves, ref, unit, order):
        """Plot the curves to keep against t (N,) s; curves: (values (N,), colour, line style,
        label, key (index, coordinate)); ref: the axes' scale; unit: for the note."""
        tol = 1e-9 * (ref if ref > 0 and math.isfinite(ref) else 1.0)
        const, moving = [], []
        for c in curves:
            v = c[0][np.isfinite(c[0])]
            scale = max(tol, 1e-9 * float(np.abs(v).max())) if len(v) else tol
            (const if not len(v) or np.ptp(v) <= scale else moving).append(c)
        keep = moving if moving else const
        shown = []
        for c in keep:
            twin = next((d for d in shown if _same(c[0], d[0], tol)), None)
            if twin is not None:
                self.same.append(f"{c[3]} = {twin[3]}")
                continue
            shown.append(c)
            self.drawn.add(c[4][0])
        for v, color, ls, label, key in shown:
            ax.plot(t, v, color=color, lw=1.4, ls=ls)
        tidy_ylim(ax, *[c[0] for c in keep], ref=ref)
        if moving:
            for v, _, _, label, key in const:
                if order > 0 and key in self.still:
                    continue
                if order == 0:
                    self.still.add(key)
                f = v[np.isfinite(v)]
                val = float(np.median(f)) if len(f) else float("nan")
                val = 0.0 if abs(val) <= tol else val
                self.constant.append(f"{label} = {val:.4g} {unit}")

    def note(self) -> str:
        parts = []
        if self.constant:
            parts.append("constant, not drawn: " + ", ".join(self.constant))
        if self.same:
            parts.append("equal to a curve drawn: " + ", ".join(self.same))
        return "; ".join(parts)


def _same(a, b, tol) -> bool:
    with np.errstate(invalid="ignore"):
        d = np.abs(a - b)
    return bool(np.all((d <= tol) | (np.isnan(a) & np.isnan(b))))


def _style_handles(styles):
    from matplotlib.lines import Line2D
    return [Line2D([], [], color="0.25", lw=1.4, ls=ls, label=label) for ls, label in styles]


def _name_handles(names, colors, drawn):
    """One legend entry per body (point) that has a curve drawn, in its colour."""
    from matplotlib.lines import Line2D
    return [Line2D([], [], color=colors[k], lw=2.5, label=n) for k, n in enumerate(names)
            if k in drawn]


class XAxis:
    """The abscissa of the time histories: t [s], or (kind "driver") the coordinate of the
    model's first driver, f(t) in the file's units: the crank angle of a crank-driven linkage.
    Calling it maps times (s) to abscissae."""

    def __init__(self, cm, kind: str = "time"):
        self.f = None
        self.degrees = False
        self.label, self.against = "t [s]", ""
        if kind == "driver":
            from ...elements import KINDS
            from ...model.spec import spec_drivers
            el = spec_drivers(cm.spec)[0]
            unit = {"angle": cm.spec.angle_unit, "length": cm.spec.length_unit}.get(
                KINDS[el.kind].target_unit, "")
            who = el.name or "-".join(b for b in el.bodies if b != "ground")
            self.f = el.f
            self.degrees = unit == "deg"
            self.label = f"{who} {el.kind}" + (f" [{pretty(unit)}]" if unit else "")
            self.against = f" against the {who} {el.kind}"

    def __call__(self, t):
        t = np.asarray(t, float)
        if self.f is None:
            return t
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(self.f(t), float), t.shape).copy()


def time_grid(nrows, ncols, xlabel="t [s]"):
    """Figure and (nrows, ncols) axes sharing the abscissa; sized by arrange_time_grid."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    fig = Figure()
    grid = fig.add_gridspec(nrows, ncols)
    # the abscissa shared through sharex= (subplots(sharex=True) hides the upper rows' tick
    # labels through matplotlib's tick objects, which Ticks replaces)
    axes, first = [], None
    for r in range(nrows):
        row = []
        for c in range(ncols):
            ax = add_axes(fig, grid[r, c], xlabels=r == nrows - 1, sharex=first)
            first = first or ax
            # at most five intervals on each y axis (1.7 in high)
            ax.yaxis.set_major_locator(MaxNLocator(nbins=5, steps=[1, 2, 2.5, 5, 10]))
            row.append(ax)
        axes.append(row)
    for ax in axes[-1]:
        ax.set_xlabel(xlabel)
    return fig, axes


def arrange_time_grid(fig, axes, handles, title, width, row_height, note=""):
    """Size the figure and place axes, title, legend and note, in inches.

    A fixed layout computed here costs nothing, where matplotlib's constrained layout measures
    every text (a third of the time of writing these figures). Tick-label widths come from the
    axes' own locators and formatters. The legend below the axes is a table read row by row, as
    many entries per row as fit the width; the note (curves not drawn) is wrapped under it.
    """
    import textwrap

    from matplotlib.lines import Line2D

    nrows, ncols = len(axes), len(axes[0])
    label_w = [max(tick_label_width(ax.yaxis, *ax.get_ylim()) for ax in col)
               for col in zip(*axes)]
    room = [w + 0.5 for w in label_w]           # tick labels, ticks, y label (inches)
    right = 0.2
    gap_h = 0.12
    per_row = max(1, min(len(handles), int((width - 0.6) / entry_width(handles))))
    blank = Line2D([], [], alpha=0.0, label=" ")
    cells = list(handles) + [blank] * (-len(handles) % per_row)
    legend_rows = len(cells) // per_row
    # matplotlib fills legend columns first: transpose the row-major table
    ordered = [cells[r * per_row + c] for c in range(per_row) for r in range(legend_rows)]
    lines = textwrap.wrap(note, int((width - 0.4) / 0.068)) if note else []
    top = 0.12 + 0.21 * (title.count("\n") + 1) + 0.12 + (0.22 if axes[0][0].get_title() else 0)
    bottom = 0.6 + 0.2 * legend_rows + (0.16 * len(lines) + 0.08 if lines else 0.0)
    height = top + bottom + nrows * row_height + (nrows - 1) * gap_h
    fig.set_size_inches(width, height)
    aw = (width - sum(room) - right) / ncols
    fig.subplots_adjust(left=room[0] / width, right=1 - right / width, bottom=bottom / height,
                        top=1 - top / height, hspace=gap_h / row_height,
                        wspace=(room[1] / aw) if ncols > 1 else 0.2)
    # the axis labels at fixed places: placing them, matplotlib measures every tick label of
    # the column at each draw (a tenth of the drawing); so placed, a column's labels line up
    # (the empty x labels of the upper rows too)
    for c, col in enumerate(zip(*axes)):
        for ax in col:
            ax.yaxis.set_label_coords(-(label_w[c] + 0.15) / aw, 0.5)
            ax.xaxis.set_label_coords(0.5, -0.29 / row_height)
    below = (0.16 * len(lines) + 0.1) / height if lines else 0.0
    fig.legend(handles=ordered, ncol=per_row, loc="lower center", bbox_to_anchor=(0.5, below),
               fontsize=FONT, frameon=False, handlelength=2.2, columnspacing=1.4)
    if lines:
        fig.text(0.5, 0.1 / height, "\n".join(lines), ha="center", va="bottom",
                 fontsize=FONT - 1, color="0.3", linespacing=1.25)
    fig.suptitle(title, fontsize=12, y=1 - 0.12 / height, va="top")


def finish_time_axes(axes, data, info, xa=None):
    """Time range (the planned one, so that a failed run shows where it stopped) and the event
    lines: the stop (red dashed), near-singular passages (thin orange), bifurcations stepped
    over (purple); each kind labelled once, beside its first line, in the top row. xa (an
    XAxis) maps the times to the abscissa."""
    from matplotlib.transforms import blended_transform_factory

    lo, hi = float(data.t[0]), float(data.t[-1])
    opts = getattr(info, "options", None)
    if opts is not None:
        lo, hi = min(lo, opts.start), max(hi, opts.end)
    marks = []          # (times, style, label)
    event = getattr(info, "event", None)
    if info is not None and info.status == 1 and event is not None and math.isfinite(event.t):
        what = "singular" if event.kind in ("lock-up", "bifurcation") else "stopped"
        marks.append(([event.t], dict(color="red", ls="--", lw=1.5), f"{what} ({event.kind})"))
        lo, hi = min(lo, event.t), max(hi, event.t)
    warnings = getattr(info, "warnings", None) or []
    for kind, style, label in (
            ("near-singular", dict(color="tab:orange", ls="-", lw=0.8), "near-singular"),
            ("bifurcation", dict(color="tab:purple", ls="-.", lw=1.0), "bifurcation passed")):
        ts = sorted({w.t for w in warnings if w.kind == kind and math.isfinite(w.t)
                     and lo <= w.t <= hi})
        if ts:
            marks.append((ts, style, label))
    if xa is not None and xa.f is not None:
        # the driver's range over the planned time range, the events where the driver was then
        span = xa(np.r_[np.linspace(lo, hi, 257), data.t])
        span = span[np.isfinite(span)]
        marks = [(list(xa(np.array(ts))), style, label) for ts, style, label in marks]
        lo, hi = (float(span.min()), float(span.max())) if len(span) else (lo, hi)
    for r, row in enumerate(axes):
        for ax in row:
            for ts, style, label in marks:
                for t in ts:
                    ax.axvline(t, zorder=1.5, **style)
                if r == 0:
                    # on the empty side of a stop line: after it, unless the run ends there
                    right = ts[0] < lo + 0.85 * (hi - lo)
                    ax.annotate(label, (ts[0], 0.97), xytext=(3 if right else -3, 0),
                                textcoords="offset points", rotation=90, va="top",
                                ha="left" if right else "right", fontsize=FONT,
                                color=style["color"], zorder=20,
                                xycoords=blended_transform_factory(ax.transData, ax.transAxes))
    if hi > lo:
        axes[0][0].set_xlim(lo, hi)
        if xa is not None and xa.degrees:       # angles in degrees: ticks at 15, 30, 45, 90...
            from matplotlib.ticker import MultipleLocator
            step = next((s for s in (15, 30, 45, 90, 180, 360, 720) if (hi - lo) / s <= 8),
                        None)
            if step is not None and (hi - lo) / step >= 2:
                axes[0][0].xaxis.set_major_locator(MultipleLocator(step))


def tidy_ylim(ax, *arrays, ref):
    """A quantity constant over the run, up to rounding noise (a slider's y of 1e-17 m), would
    be drawn on a 1e-17 scale: show it on the scale of the model instead (ref: model length /
    duration^order, or one radian in the angle unit)."""
    values = np.concatenate([np.ravel(a) for a in arrays])
    values = values[np.isfinite(values)]
    if not len(values) or not ref > 0 or not math.isfinite(ref):
        return
    lo, hi = values.min(), values.max()
    if hi - lo <= 1e-9 * max(ref, abs(lo), abs(hi)):
        c = 0.5 * (lo + hi)
        if abs(c) < 1e-9 * ref:
            c = 0.0
        d = max(0.1 * abs(c), 0.1 * ref)
        ax.set_ylim(c - d, c + d)


