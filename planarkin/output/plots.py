"""Plots of a run: time histories, point paths, the mechanism at several instants, an animation.

Called by `output.writer.DirectoryWriter.finish` with the decimated plot buffer (a `Chunk` of at most a
few thousand rows, user units). matplotlib is imported inside the functions only, and only through
its object-oriented API (``matplotlib.figure.Figure``, rendered by Agg): no pyplot, no backend
switch, no windows, no global state (rcParams only inside rc_context: the axes style while a
figure is built and drawn, `_styled`, and an svg id salt while it is saved, `save_figure`).

Files (``<fmt>`` is png at 150 dpi, svg or pdf):

- ``bodies.<fmt>``: x, y and phi of every body frame against time, with their derivatives as far
  as the run computed them (rows position / velocity / acceleration; columns translation,
  rotation);
- ``points.<fmt>`` and ``trajectories.<fmt>`` (models with points): the same for the points of
  interest, and their paths in the plane;
- ``mechanism.<fmt>``: the mechanism at six instants and the paths of its joints and points;
- ``animation.gif`` (`write_animation`): the mechanism moving, paths growing.

A failed run marks its stopping time in the time histories (red dashed line); near-singular
passages are thin orange lines, bifurcations stepped over are purple.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..layout import BODY_QUANTITIES, POINT_QUANTITIES, units

DPI = 150                      # raster output (png)
ANIM_FRAMES = 80               # frames of animation.gif (fewer when the run has fewer rows)
ANIM_FPS = 20
ANIM_DPI = 100                 # 6.4 in wide -> 640 px
FONT = 9                       # legends, annotations (ticks and labels use matplotlib's 10 pt)
# Axes style, set through rcParams for the duration of each figure (`_styled`), read by `_Ticks`
# (which draws every axes' grid, ticks and tick labels: matplotlib's own grid is off). The
# titles' y is fixed so that matplotlib does not measure the tick labels to place them.
STYLE = {"axes.grid": False, "grid.color": "0.88", "grid.linewidth": 0.6,
         "xtick.labelsize": 9, "ytick.labelsize": 9, "axes.titley": 1.0}
GROUND_Z = 25                  # ground pivots above every drawn instant (zorders 10 to 20)
ROW_NAMES = ("position", "velocity", "acceleration", "jerk")


def _styled(fn):
    """Run fn (a figure builder or writer) with STYLE in effect: rcParams are read when artists
    are created and when ticks are drawn, so both happen inside."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import matplotlib as mpl
        with mpl.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


# -- public API ----------------------------------------------------------------------------------

def figure_names(cm) -> list[str]:
    """The figures write_plots draws for this model, in order (file stems)."""
    return ["bodies"] + (["points", "trajectories"] if len(cm.point_names) else []) + \
        ["mechanism"]


@_styled
def write_plots(cm, data, info, out: Path, fmt: str = "png", only=None,
                x: str = "time") -> list[Path]:
    """Write bodies, points, trajectories and mechanism plots into directory out.

    cm: CompiledModel; data: Chunk (user units; qd/qdd/pd/pdd may be None); info: RunInfo (status,
    event and warnings are marked on the time axes; None is allowed); only: a subset of
    figure_names(cm) to draw (default all);
    x: abscissa of bodies and points, "time" or "driver" (model.spec.X_AXES).
    Returns the files written (points and trajectories only when the model has points; nothing
    when data has no rows).
    """
    out = Path(out)
    fmt = fmt.lower().lstrip(".")
    if not len(data.t):
        return []
    names = [n for n in figure_names(cm) if only is None or n in only]
    scene = _Scene(cm, data) if set(names) & {"trajectories", "mechanism"} else None
    build = {"bodies": lambda: _bodies_figure(cm, data, info, x),
             "points": lambda: _points_figure(cm, data, info, x),
             "trajectories": lambda: _trajectories_figure(cm, scene),
             "mechanism": lambda: _mechanism_figure(cm, scene)}
    return [save_figure(build[n](), out / f"{n}.{fmt}") for n in names]


@_styled
def write_animation(cm, data, out: Path, fps: int | None = None,
                    width: int | None = None) -> Path:
    """Write out/animation.gif: the mechanism moving over the run (bodies in their plot colours,
    joint and point paths growing), up to ANIM_FRAMES frames at fps frames per second (default
    ANIM_FPS), width pixels wide (default 640; the height follows the drawing, the legend
    beside it is never cut: the image widens for it).

    Frames are blitted: the axes, ground and legend are rendered once, each frame redraws only
    the moving artists on that background (a full matplotlib redraw per frame costs ten times
    more), and every frame is mapped onto one shared palette before Pillow writes the GIF."""
    from matplotlib.animation import PillowWriter
    from PIL import Image

    path = Path(out) / "animation.gif"
    scene = _Scene(cm, data)
    N = len(data.t)
    rows = np.unique(np.linspace(0, max(N - 1, 0), min(ANIM_FRAMES, max(N, 1))).round().astype(int))
    fps = int(fps or ANIM_FPS)
    fig, ax, beside = _plane_figure(cm, scene, (width or 640) / ANIM_DPI,
                                    0.7 + _text_width(cm.body_names), dpi=ANIM_DPI)
    traces = [ax.plot([], [], color=c, lw=w, zorder=5)[0] for _, _, c, w in scene.trace_styles]
    drawing = _Drawing(ax, scene, rows[-1], body_colors=True, zorder=10)
    stamp = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=FONT,
                    bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8),
                    zorder=30)
    legend = fig.legend(handles=drawing.legend_handles(), loc="upper left",
                        bbox_to_anchor=beside, fontsize=FONT, frameon=False)
    _fit_legend(fig, legend, ax, beside)
    ax.set_title(f"{cm.spec.name}: motion", fontsize=11, y=1.0)
    moving = traces + drawing.artists + [stamp]
    for a in moving:
        a.set_animated(True)
    w, h = (int(round(v * ANIM_DPI)) for v in fig.get_size_inches())
    renderer = _renderer_class()(w, h, ANIM_DPI)
    fig.draw(renderer)                      # everything that does not move
    background = renderer.copy_from_bbox(fig.bbox)

    def render(i) -> "Image.Image":
        drawing.set_row(i)
        for line, xy in zip(traces, scene.traces):
            line.set_data(xy[: i + 1, 0], xy[: i + 1, 1])
        stamp.set_text(f"t = {data.t[i]:.4g} s")
        renderer.restore_region(background)
        for a in moving:
            a.draw(renderer)
        return Image.frombuffer("RGBA", (w, h), renderer.buffer_rgba(), "raw", "RGBA", 0,
                                1).convert("RGB")

    class BlitWriter(PillowWriter):
        """PillowWriter whose frames come from render(); one palette for the whole GIF (taken
        from the last frame, where every path is complete)."""

        def setup(self, fig, outfile, dpi=None):
            super().setup(fig, outfile, dpi=dpi)
            self.images = []

        def grab_frame(self, **savefig_kwargs):
            self.images.append(render(self.row))

        def finish(self):
            dither = Image.Dither.NONE
            palette = self.images[-1].quantize(255, method=Image.Quantize.MEDIANCUT,
                                               dither=dither)
            # Pillow maps colours to the palette through a cache of 4-level cells: white
            # would become a near-white neighbour, so those all become white
            colors = np.array(palette.getpalette(), dtype=np.uint8).reshape(-1, 3)
            colors[colors.min(axis=1) >= 248] = 255
            palette.putpalette(colors.ravel().tolist())
            frames = [im.quantize(palette=palette, dither=dither) for im in self.images]
            frames[0].save(self.outfile, save_all=True, append_images=frames[1:],
                           duration=int(1000 / self.fps), loop=0)

    writer = BlitWriter(fps=fps)
    writer.setup(fig, path, ANIM_DPI)       # (not writer.saving(): it changes rcParams)
    for i in rows:
        writer.row = i
        writer.grab_frame()
    writer.finish()
    return path


# -- time histories ------------------------------------------------------------------------------

@_styled
def _bodies_figure(cm, data, info, x: str = "time"):
    """3 x 2 grid (rows that exist): frame origins x, y (left) and angles (right) against time.

    Curves constant over the run (a frame pinned to ground) or identical to one already drawn
    are left out and named, with their value, in a note under the legend (an axes whose curves
    are all constant keeps them)."""
    series = [a for a in (data.q, data.qd, data.qdd, data.qddd) if a is not None]
    colors = body_palette(cm.nb)
    xa = _XAxis(cm, x)
    X = xa(data.t)
    fig, axes = _time_grid(len(series), 2, xa.label)
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    T = _duration(data, info)
    sel = _Selection()
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
    _arrange_time_grid(fig, axes, handles, title, width=10.0, row_height=1.75,
                       note=sel.note())
    return fig


@_styled
def _points_figure(cm, data, info, x: str = "time"):
    """One column: x, y of every point (and their derivatives) against time; constant and
    repeated curves left out as in bodies.<fmt>."""
    series = [a for a in (data.p, data.pd, data.pdd, data.pddd) if a is not None]
    colors = _point_palette(len(cm.point_names))
    xa = _XAxis(cm, x)
    X = xa(data.t)
    fig, axes = _time_grid(len(series), 1, xa.label)
    T = _duration(data, info)
    sel = _Selection()
    for o, arr in enumerate(series):
        tu, _ = (pretty(u) for u in units(cm.spec.length_unit, cm.spec.angle_unit, o))
        qx, qy = POINT_QUANTITIES[o]
        ax = axes[o][0]
        curves = [(arr[:, k, c], colors[k], ls, f"{name}.{q}", (k, c))
                  for k, name in enumerate(cm.point_names)
                  for c, q, ls in ((0, qx, "-"), (1, qy, "--"))]
        sel.draw(ax, X, curves, cm.L / T ** o, tu, o)
        ax.set_ylabel(f"{qx}, {qy} [{tu}]")
    handles = _style_handles([("-", "x"), ("--", "y")]) + _name_handles(
        cm.point_names, colors, sel.drawn)
    finish_time_axes(axes, data, info, xa)
    title = plot_title(cm, "points: " + ", ".join(ROW_NAMES[:len(series)]) + xa.against, info)
    _arrange_time_grid(fig, axes, handles, title, width=7.0, row_height=1.7, note=sel.note())
    return fig


class _Selection:
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
        _tidy_ylim(ax, *[c[0] for c in keep], ref=ref)
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


class _XAxis:
    """The abscissa of the time histories: t [s], or (kind "driver") the coordinate of the
    model's first driver, f(t) in the file's units: the crank angle of a crank-driven linkage.
    Calling it maps times (s) to abscissae."""

    def __init__(self, cm, kind: str = "time"):
        self.f = None
        self.degrees = False
        self.label, self.against = "t [s]", ""
        if kind == "driver":
            from ..elements import KINDS
            from ..model.spec import spec_drivers
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


def _time_grid(nrows, ncols, xlabel="t [s]"):
    """Figure and (nrows, ncols) axes sharing the abscissa; sized by _arrange_time_grid."""
    from matplotlib.figure import Figure

    from matplotlib.ticker import MaxNLocator

    fig = Figure()
    grid = fig.add_gridspec(nrows, ncols)
    # the abscissa shared through sharex= (subplots(sharex=True) hides the upper rows' tick
    # labels through matplotlib's tick objects, which _Ticks replaces)
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


def _arrange_time_grid(fig, axes, handles, title, width, row_height, note=""):
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
    per_row = max(1, min(len(handles), int((width - 0.6) / _entry_width(handles))))
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
    _XAxis) maps the times to the abscissa."""
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


def _tidy_ylim(ax, *arrays, ref):
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


def _text_width(labels) -> float:
    """Generous width in inches of the longest label at FONT pt."""
    return 0.08 * max(len(s) for s in labels)


def _entry_width(handles) -> float:
    """Width of one legend entry in inches at FONT pt (handle, text, column spacing)."""
    return 0.5 + _text_width([h.get_label() for h in handles])


def tick_label_width(axis, lo, hi) -> float:
    """Rough width in inches of the widest tick label the axis shows for the range lo..hi."""
    ticks = np.asarray(axis.get_major_locator().tick_values(min(lo, hi), max(lo, hi)))
    eps = 1e-9 * abs(hi - lo)
    ticks = ticks[(ticks >= min(lo, hi) - eps) & (ticks <= max(lo, hi) + eps)]
    return _text_width(axis.get_major_formatter().format_ticks(ticks) if len(ticks) else ["0"])


def add_axes(fig, where, xlabels=True, sharex=None, grid=None):
    """fig.add_subplot(where) (a subplot spec) or fig.add_axes(where) (a rectangle), its grid,
    ticks and labels drawn by `_Ticks`; xlabels: whether the x tick labels are drawn; grid:
    (colour, line width) of the grid lines (default: rcParams grid.color, grid.linewidth).
    Its axis labels are drawn where set_label_coords puts them (the figure's layout)."""
    kw = dict(axes_class=_axes_class(), sharex=sharex)
    ax = fig.add_axes(where, **kw) if isinstance(where, tuple) else fig.add_subplot(where, **kw)
    _Ticks.make(ax, xlabels=xlabels, grid=grid)
    return ax


_AXES = []


def _axes_class():
    """Axes whose axes make no matplotlib tick objects when they are created or cleared (two
    of them per axis, a third of the time of making an axes): `_Ticks` draws their ticks. Ticks
    asked for (get_xticklabels, ...) are still made then, as in any axes."""
    if _AXES:
        return _AXES[0]
    from matplotlib.axes import Axes
    from matplotlib.axis import Axis, XAxis, YAxis

    def reset_ticks(self):
        self.majorTicks, self.minorTicks = [], []

    def _get_ticks_position(self):
        # matplotlib <= 3.10 reads the first tick object to place an axes title
        return Axis._get_ticks_position(self) if self.majorTicks else "default"

    attrs = {"reset_ticks": reset_ticks, "_get_ticks_position": _get_ticks_position}
    light = {XAxis: type("XAxis", (XAxis,), attrs), YAxis: type("YAxis", (YAxis,), attrs)}

    class PlotAxes(Axes):
        def _init_axis(self):
            super()._init_axis()
            for axis in (self.xaxis, self.yaxis):
                axis.__class__ = light[type(axis)]
                axis.reset_ticks()

        def clear(self):
            super().clear()
            for spine in self.spines.values():
                spine.get_position()    # places the spine (the first tick object did that)

    _AXES.append(PlotAxes)
    return PlotAxes


class _Ticks:
    """Grid, tick marks, tick labels and axis labels of one axes, drawn by one artist in one pass
    (`add_axes` makes it).

    matplotlib builds an object of three lines and two texts for every tick, copies the first
    tick's properties into each new one and measures every tick label at each draw: in the time
    histories that was four fifths of the drawing. Here the axes' own locator and formatter give
    the ticks (`get_xticks` and the labels are matplotlib's), and the grid, the tick marks and
    the labels are drawn directly: one path each for the grid and the marks, one text object
    per axis moved from label to label. The axes' labels are drawn where `set_label_coords`
    put them (the figure's layout places them; their axis is hidden)."""

    _cls = None

    @classmethod
    def make(cls, ax, xlabels=True, ylabels=True, grid=None):
        if cls._cls is None:
            cls._cls = _ticks_class()
        return cls._cls(ax, xlabels, ylabels, grid)


def _ticks_class():
    import matplotlib as mpl
    from matplotlib.artist import Artist
    from matplotlib.path import Path as MPath
    from matplotlib.text import Text
    from matplotlib.transforms import IdentityTransform

    class Ticks(Artist):
        zorder = 1.5        # where matplotlib draws an axis (axes.axisbelow: "line")

        def __init__(self, ax, xlabels, ylabels, grid):
            super().__init__()
            rc = mpl.rcParams
            self._ax = ax
            self.show = (xlabels, ylabels)
            self.grid_style = (*(grid or (rc["grid.color"], rc["grid.linewidth"])),
                               rc["grid.alpha"])
            self.tick_style = [(rc[f"{a}tick.major.size"], rc[f"{a}tick.major.width"],
                                rc[f"{a}tick.major.pad"], rc[f"{a}tick.color"])
                               for a in "xy"]
            color = [rc[f"{a}tick.labelcolor"] for a in "xy"]
            color = [rc[f"{a}tick.color"] if c == "inherit" else c for a, c in zip("xy", color)]
            ident = IdentityTransform()
            self.texts = [Text(0, 0, "", fontsize=rc["xtick.labelsize"], color=color[0],
                               ha="center", va="top", transform=ident),
                          Text(0, 0, "", fontsize=rc["ytick.labelsize"], color=color[1],
                               ha="right", va="center_baseline", transform=ident)]
            self.offset = [Text(0, 0, "", fontsize=rc["xtick.labelsize"], color=color[0],
                                ha="right", va="top", transform=ident),
                           Text(0, 0, "", fontsize=rc["ytick.labelsize"], color=color[1],
                                ha="left", va="baseline", transform=ident)]
            for t in self.texts + self.offset:
                t.set_figure(ax.figure)
            ax.xaxis.set_visible(False)
            ax.yaxis.set_visible(False)
            ax.add_artist(self)
            self.set_clip_on(False)

        @staticmethod
        def _locs(axis):
            """Tick values inside the view, their labels (formatted with all of the locator's
            values, as matplotlib does) and the axis' offset text."""
            locs = np.asarray(axis.get_majorticklocs(), float)
            labels = axis.get_major_formatter().format_ticks(locs)
            lo, hi = sorted(axis.get_view_interval())
            tr = axis.get_transform()
            a, b = tr.transform([lo, hi])
            eps = 1e-10 * abs(b - a)        # as matplotlib's own test
            keep = [k for k, v in enumerate(tr.transform(locs)) if a - eps <= v <= b + eps]
            return locs[keep], [labels[k] for k in keep], axis.get_major_formatter().get_offset()

        def draw(self, renderer):
            if not self.get_visible():
                return
            ax = self._ax
            renderer.open_group("ticks", gid=self.get_gid())
            pt = renderer.points_to_pixels(1.0)
            x0, y0, x1, y1 = ax.bbox.extents
            xl, xs, xoff = self._locs(ax.xaxis)
            yl, ys, yoff = self._locs(ax.yaxis)
            X = ax.transData.transform(np.c_[xl, np.zeros(len(xl))])[:, 0] if len(xl) else xl
            Y = ax.transData.transform(np.c_[np.zeros(len(yl)), yl])[:, 1] if len(yl) else yl
            ident = IdentityTransform()

            def segments(verts, color, width, alpha=None, cap="butt"):
                if not len(verts):
                    return
                gc = renderer.new_gc()
                gc.set_foreground(color)
                gc.set_linewidth(width)
                gc.set_capstyle(cap)
                if alpha is not None:
                    gc.set_alpha(alpha)
                codes = np.tile([MPath.MOVETO, MPath.LINETO], len(verts) // 2)
                renderer.draw_path(gc, MPath(np.asarray(verts, float), codes), ident)
                gc.restore()

            c, w, a = self.grid_style
            segments([p for x in X for p in ((x, y0), (x, y1))]
                     + [p for y in Y for p in ((x0, y), (x1, y))], c, w, a, cap="projecting")
            (xsize, xw, xpad, xc), (ysize, yw, ypad, yc) = self.tick_style
            segments([p for x in X for p in ((x, y0), (x, y0 - xsize * pt))], xc, xw)
            segments([p for y in Y for p in ((x0, y), (x0 - ysize * pt, y))], yc, yw)
            tx, ty = self.texts
            if self.show[0]:
                for x, s in zip(X, xs):
                    tx.set_text(s)
                    tx.set_position((x, y0 - (xsize + xpad) * pt))
                    tx.draw(renderer)
                if xoff:
                    o = self.offset[0]
                    o.set_text(xoff)
                    o.set_position((x1, y0 - (xsize + xpad + 1.2 * tx.get_fontsize() + 3) * pt))
                    o.draw(renderer)
            if self.show[1]:
                for y, s in zip(Y, ys):
                    ty.set_text(s)
                    ty.set_position((x0 - (ysize + ypad) * pt, y))
                    ty.draw(renderer)
                if yoff:
                    o = self.offset[1]
                    o.set_text(yoff)
                    o.set_position((x0, y1 + 3 * pt))
                    o.draw(renderer)
            for axis in (ax.xaxis, ax.yaxis):
                if axis.label.get_text():
                    axis.label.draw(renderer)
            renderer.close_group("ticks")
            self.stale = False

    return Ticks


def _duration(data, info) -> float:
    opts = getattr(info, "options", None)
    T = (opts.end - opts.start) if opts is not None else float(data.t[-1] - data.t[0])
    return T if T > 0 and math.isfinite(T) else 1.0


def plot_title(cm, what, info=None) -> str:
    s = f"{cm.spec.name}: {what}"
    if info is not None and info.status == 1 and getattr(info, "event", None) is not None:
        s += f"\nrun stopped at t = {info.event.t:.6g} s ({info.event.kind})"
    return s


def pretty(unit: str) -> str:
    return unit.replace("^2", "\u00b2").replace("^3", "\u00b3")


# -- the mechanism in the plane ------------------------------------------------------------------

class _Scene:
    """Geometry of the mechanism over the run, user units.

    Each moving body is drawn from body-fixed vertices: a translucent polygon (the convex hull
    of its frame origin, joint points and points of interest), a thick bar when those are
    collinear, or a block oriented along its slide when they are a single point; plus dashed
    body-fixed lines (slots, gear pitch circles). Ground carries pivots (revolute and distance
    points on ground) and slide axes (translational, pin-slot and slide lines on ground). The
    paths (traces) are those of the points of interest and of every moving joint point.
    """

    def __init__(self, cm, data):
        self.cm = cm
        self.t = data.t
        self.nb = cm.nb
        self.names = cm.body_names
        self.colors = body_palette(cm.nb)
        self.point_colors = _point_palette(len(cm.point_names))
        q = data.q
        self.x, self.y = q[:, 0::3], q[:, 1::3]
        phi = self.phi = q[:, 2::3] * cm.angle_factor
        self.c, self.s = np.cos(phi), np.sin(phi)
        attach, joint_pts, slides, slide_dir, revolutes, gears = self._elements(cm)

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

        self._shapes(attach, slide_dir, revolutes, gears)
        self._slides(slides)
        self._traces(data, joint_pts)
        self._bounds()
        self.centrodes = self._centrodes(cm, data) if cm.spec.output.centres else []
        # output: {centres: moving}: planarkin.centres draws them at every instant
        from ..centres import moving_centrodes
        self.moving = moving_centrodes(cm, data, [j for j, _ in self.centrodes]) \
            if cm.spec.output.moving_centrodes else []

    def _elements(self, cm):
        """Walk the elements: attachment points per body (body frame, user units), joint points
        to trace, pins, ground pivots, distance links, slides, slide directions, gears."""
        L, ground = cm.L, cm.nb
        attach = [[np.zeros(2)] for _ in range(cm.nb)]
        joint_pts = []                                  # (body, s')
        self.pins = []                                  # (body, s')
        self.pivots = []                                # global points on ground
        self.links = []                                 # distance: (bi, si, bj, sj)
        slides = []                                     # (bi, si, vi, bj, sj)
        slide_dir = {}                                  # body -> body-frame slide direction
        revolutes, gears = [], []
        self.outlines = []                              # (body, body-frame dashed polyline)
        self.faces_out = []                             # (body, body-frame solid line)
        for G in sorted(cm.groups, key=lambda G: G.kind.name in MACHINE_OUTLINES):
            kind = G.kind.name
            par = G.params
            for k in range(len(G)):
                bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
                si = par["si"][k] * L if "si" in par else None
                sj = par["sj"][k] * L if "sj" in par else None
                for b, s in ((bi, si), (bj, sj)):
                    if s is not None and b != ground:
                        attach[b].append(s)
                        joint_pts.append((b, s))
                if kind in ("revolute", "distance"):
                    for b, s in ((bi, si), (bj, sj)):
                        (self.pivots.append(s) if b == ground else self.pins.append((b, s)))
                if kind == "revolute":
                    revolutes.append((bi, si, bj, sj))
                elif kind == "distance":
                    self.links.append((bi, si, bj, sj))
                elif kind in ("translational", "pin-slot", "slide"):
                    vi = par["vi"][k]
                    slides.append((bi, si, vi, bj, sj))
                    if kind == "translational":
                        if bj != ground:
                            slide_dir.setdefault(bj, par["vj"][k])
                        elif bi != ground:
                            slide_dir.setdefault(bi, vi)
                    if kind == "pin-slot" and bj != ground:
                        self.pins.append((bj, sj))
                elif kind in ("gear", "belt"):
                    bk = int(G.bodies[k, 2])
                    gears += [(bi, par["ri"][k] * L, bk), (bj, par["rj"][k] * L, bk)]
                if kind in MACHINE_OUTLINES:
                    self.outlines += MACHINE_OUTLINES[kind](G, k, L, revolutes, ground)
                face = MACHINE_FACES[kind](G, k, L, self.phi) if kind in MACHINE_FACES else None
                if face is not None:
                    self.faces_out.append(face)
        for b, s in zip(cm.point_body, cm.point_s):
            if int(b) != ground:
                attach[int(b)].append(np.asarray(s) * L)
        return attach, joint_pts, slides, slide_dir, revolutes, gears

    def _shapes(self, attach, slide_dir, revolutes, gears):
        """Body-frame outlines: fills (polygons), bars (thick lines), dashed (gear circles)."""
        nb, size = self.nb, self.size
        self.fills = [None] * nb                        # (k, 2) polygon vertices
        self.bars = [None] * nb                         # (2, 2) thick line
        self.dashed = [[] for _ in range(nb)]           # body-fixed dashed polylines
        self.faces = [[] for _ in range(nb)]            # body-fixed solid lines (flat faces)
        geared = {b for b, _, _ in gears}
        for b, P in enumerate(attach):
            if len(P) == 1:
                if b not in geared:                     # a block along the slide
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
        for b, r, bk in gears:
            if b == nb or not r:
                continue
            centre = np.zeros(2)                        # the gear's pivot on its carrier
            for i, si, j, sj in revolutes:
                if {i, j} == {b, bk}:
                    centre = si if i == b else sj
                    break
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
        allp = np.concatenate(parts)
        lo, hi = np.nanmin(allp, axis=0) - 0.6 * size, np.nanmax(allp, axis=0) + 0.6 * size
        self.bounds = (lo[0], hi[0], lo[1], hi[1])

    def _centrodes(self, cm, data) -> list:
        """[(body, (N, 2) path)]: the fixed centrode (instant centre relative to ground, from the
        exact velocities: planarkin.centres) of every body whose centre moves -- not a body
        pinned to ground (a fixed point) nor a slider (at infinity) -- cut where it leaves the
        drawing's bounds: near a parallel position it runs to infinity, and following it even
        part of the way would shrink the mechanism. nan breaks the line."""
        if getattr(data, "qd", None) is None or len(self.t) < 2:
            return []
        from ..centres import compute, pairs
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


class _Drawing:
    """The artists of the mechanism at one row; set_row moves them (the animation reuses them).

    color: one colour for every body (instants of mechanism.png) or body_colors=True for each
    body's own colour (as in bodies.<fmt>)."""

    def __init__(self, ax, scene: _Scene, row: int, color=None, body_colors=False, alpha=1.0,
                 fill=0.25, zorder=10.0, labels=False, width=4.5):
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
        for b in range(scene.nb):
            c = col(b)
            if scene.fills[b] is not None:
                patch = Polygon(scene.fills[b], closed=True, fc=_with_alpha(c, fill * alpha),
                                ec=_with_alpha(c, alpha), lw=2.0, zorder=zorder)
                ax.add_artist(patch)    # (the drawing's bounds set the limits)
                self.parts.append((patch, b, scene.fills[b], "fill"))
            if scene.bars[b] is not None:
                self.parts.append((line(color=c, lw=width, alpha=alpha, solid_capstyle="round",
                                        zorder=zorder), b, scene.bars[b], "line"))
            for poly in scene.dashed[b]:
                self.parts.append((line(color=c, lw=1.0, ls="--", alpha=alpha,
                                        zorder=zorder + 0.1), b, poly, "line"))
            for poly in scene.faces[b]:
                self.parts.append((line(color=c, lw=0.75 * width, alpha=alpha,
                                        solid_capstyle="butt", zorder=zorder + 0.15), b, poly,
                                   "line"))
        edge = color if color is not None else "0.15"
        self.links = [line(color=edge, lw=1.2, alpha=alpha, zorder=zorder + 0.2)
                      for _ in scene.links]
        self.pins = line(ls="none", marker="o", ms=5.5, mfc="white", mec=edge, mew=1.3,
                         alpha=alpha, zorder=zorder + 0.5)
        self.points = [line(ls="none", marker="D", ms=5, mfc=scene.point_colors[k], mec=edge,
                            mew=0.8, alpha=alpha, zorder=zorder + 0.6)
                       for k in range(len(cm.point_names))]
        self.artists = ([a for a, _, _, _ in self.parts] + self.links + [self.pins]
                        + self.points)
        self.set_row(row)
        if labels:
            self._annotate(row)

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

    def _annotate(self, i):
        """Body names (and point names) at row i, beside each body's centre."""
        sc = self.scene
        box = dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.75)
        placed = []
        for b, name in enumerate(sc.names):
            V = sc.fills[b] if sc.fills[b] is not None else sc.bars[b]
            if V is None:
                V = sc.dashed[b][0] if sc.dashed[b] else np.zeros((1, 2))
            p = sc.at(b, V, i).mean(axis=0)
            # labels of nearby bodies alternate above and below, further out each time
            near = sum(np.hypot(*(p - q)) < 0.12 * sc.span for q in placed)
            placed.append(p)
            dy = (9 + 12 * (near // 2)) * (1 if near % 2 == 0 else -1.6)
            self.ax.annotate(name, p, xytext=(0, dy), textcoords="offset points", ha="center",
                             va="center", fontsize=FONT, color=_darker(sc.colors[b]),
                             fontweight="bold", bbox=box, zorder=40)
        for k, name in enumerate(sc.cm.point_names):
            self.ax.annotate(name, sc.traces[k][i], xytext=(6, -12), textcoords="offset points",
                             fontsize=FONT, color=_darker(sc.point_colors[k]), bbox=box,
                             zorder=40)

    def legend_handles(self):
        from matplotlib.patches import Patch
        sc = self.scene
        return [Patch(fc=_with_alpha(sc.colors[b], 0.35), ec=sc.colors[b], label=name)
                for b, name in enumerate(sc.names)]


def _plane_figure(cm, scene: _Scene, width, beside, dpi=DPI, ground_alpha=1.0):
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
    # the axis labels at fixed places, as in the time histories (_arrange_time_grid)
    ax.yaxis.set_label_coords(-(label_w + 0.15) / aw, 0.5)
    ax.xaxis.set_label_coords(0.5, -0.29 / ah)
    return fig, ax, ((left + aw + 0.15) / width, (bottom + ah) / height)


def _mechanism_axes(ax, cm, scene: _Scene, ground_alpha=1.0):
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


@_styled
def _trajectories_figure(cm, scene: _Scene):
    """Paths of the points of interest, start dots, direction arrows, the mechanism faint at
    t = start."""
    from matplotlib.collections import PolyCollection
    from matplotlib.lines import Line2D
    from matplotlib.transforms import Affine2D

    fig, ax, _ = _plane_figure(cm, scene, 8.0, 0.25, ground_alpha=0.5)
    _Drawing(ax, scene, 0, color="0.6", alpha=0.45, zorder=9)
    handles, heads, tips, colors = [], [], [], []
    for k, name in enumerate(cm.point_names):
        xy = scene.traces[k]
        c = scene.point_colors[k]
        line, = ax.plot(xy[:, 0], xy[:, 1], color=c, lw=1.6, zorder=12, label=name)
        ax.plot(xy[0, 0], xy[0, 1], "o", color=c, ms=6, zorder=13)
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
    lw = ncol * (_text_width([h.get_label() for h in handles]) + 3.6 * em) + 0.8 * em
    lh = rows * 1.5 * em + 0.8 * em
    pad = 0.5 * em
    # the paths, the ground pivots and the edges of the bodies at the first instant (drawn)
    edges = []
    for b in range(scene.nb):
        for V in (scene.fills[b], scene.bars[b]):
            if V is not None:
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


@_styled
def _mechanism_figure(cm, scene: _Scene, instants: int | None = None):
    """The mechanism at a few instants and every path of the run.

    Every body in its own colour (as in bodies.<fmt>), named in that colour at the first
    instant, which is drawn solid; the later instants fade (the legend gives their times). A run
    that is not a full cycle always shows its final pose; instants with the same pose are drawn
    once."""
    from matplotlib.lines import Line2D

    rows = scene.instants(instants or instant_count(cm))
    times = [f"t = {scene.t[i]:.4g} s" for i in rows]
    if len(rows) > 1:
        times[0] += " (named)"
    alphas = [1.0] + list(np.linspace(0.5, 0.22, len(rows) - 1))
    # a centrode's label on two lines: a long one would narrow the drawing
    labels = times + [s[0] for s, xy in zip(scene.trace_styles, scene.traces)
                      if not s[1] or np.nanmax(np.ptp(xy, axis=0)) > 1e-6 * scene.span] + \
        [w for j, _ in scene.centrodes for w in ("fixed centrode", f"of {scene.names[j]}")] + \
        [w for j, _ in scene.moving for w in ("moving centrode", f"of {scene.names[j]}")]
    fig, ax, beside = _plane_figure(cm, scene, 9.0, 0.65 + _text_width(labels))
    handles, seen = [], set()
    tol = 1e-6 * scene.span
    for xy, (label, is_point, c, w) in zip(scene.traces, scene.trace_styles):
        line, = ax.plot(xy[:, 0], xy[:, 1], color=c, lw=w, zorder=5,
                        ls="-" if is_point else (0, (4, 2)))
        if is_point and not np.nanmax(np.ptp(xy, axis=0)) > tol:
            continue        # a point that does not move (a ground pin): no path to name
        if label not in seen:
            seen.add(label)
            line.set_label(label)
            handles.append(line)
    # output: centres: each floating body's fixed centrode, light, in the body's colour
    for j, xy in scene.centrodes:
        line, = ax.plot(xy[:, 0], xy[:, 1], color=scene.colors[j], lw=1.5, alpha=0.8,
                        ls=(0, (1, 1.5)), zorder=4,
                        label=f"fixed centrode\nof {scene.names[j]}")
        handles.append(line)
    if scene.moving:
        from ..centres import draw_moving
        handles += draw_moving(ax, scene, rows[0])
    # later instants below the first, fainter the later they are
    for k in range(len(rows) - 1, -1, -1):
        _Drawing(ax, scene, rows[k], body_colors=True, alpha=alphas[k],
                 fill=0.22 if k == 0 else 0.12, zorder=20 - k, labels=(k == 0),
                 width=4.5 if k == 0 else 3.0)
    handles += [Line2D([], [], color="0.2", lw=4 if k == 0 else 3, alpha=a, label=tt)
                for k, (tt, a) in enumerate(zip(times, alphas))]
    legend = fig.legend(handles=handles, loc="upper left", bbox_to_anchor=beside,
                        fontsize=FONT, frameon=False, borderaxespad=0)
    _fit_legend(fig, legend, ax, beside)
    ax.set_title(f"{cm.spec.name}: mechanism at {len(rows)} instant{'s' * (len(rows) > 1)}, "
                 f"paths over t = {scene.t[0]:.4g} to {scene.t[-1]:.4g} s", fontsize=12, y=1.0)
    return fig


def _fit_legend(fig, legend, ax, anchor):
    """Widen the figure until the legend beside the axes fits (the width of its texts is only
    estimated when the figure is laid out), keeping the axes' size and place in inches; the
    legend's upper-left corner is at anchor (figure fraction before widening)."""

    W, H = fig.get_size_inches()
    dpi = fig.dpi
    box = legend.get_window_extent(_renderer_class()(int(W * dpi), int(H * dpi), dpi))
    extra = box.x1 / dpi + 0.08 - W                   # inches past the right edge
    if extra <= 0:
        return
    pos = ax.get_position()
    k = W / (W + extra)
    fig.set_size_inches(W + extra, H)
    ax.set_position((pos.x0 * k, pos.y0, pos.width * k, pos.height))
    legend.set_bbox_to_anchor((anchor[0] * k, anchor[1]), transform=fig.transFigure)


# -- small helpers -------------------------------------------------------------------------------

def save_figure(fig, path: Path) -> Path:
    """Save a figure: png at DPI (drawn by `_renderer_class`, encoded by `_write_png`); svg and
    pdf without a date and (svg) with fixed element ids, so that the same run gives
    byte-identical files."""
    from contextlib import nullcontext

    import matplotlib as mpl

    fmt = path.suffix[1:]
    meta = {"svg": {"Date": None}, "pdf": {"CreationDate": None}}.get(fmt)
    # svg ids are salted with a random uuid unless this rcParam is set: the only rcParams use,
    # for the duration of one save
    salt = mpl.rc_context({"svg.hashsalt": "planarkin"}) if fmt == "svg" else nullcontext()
    if fmt == "png":
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        fig.set_dpi(DPI)
        FigureCanvasAgg(fig)                    # (the figure's canvas, as savefig makes it)
        w, h = fig.bbox.size
        renderer = _renderer_class()(int(w), int(h), DPI)
        fig.draw(renderer)
        _write_png(path, renderer.buffer_rgba(), DPI)
        return path
    with salt:
        fig.savefig(path, format=fmt, dpi=DPI, metadata=meta)
    # no fig.clear(): tearing the artists down costs a tenth of the drawing; dropping the last
    # reference frees them as well
    return path


def _write_png(path: Path, rgba, dpi: int) -> None:
    """Write an opaque RGBA buffer (h, w, 4) as an RGB png: rows unfiltered, zlib level 1, the
    resolution in a pHYs chunk. Half of the time of Pillow's encoder at level 1 (which tries
    every row filter), and the files are a few per cent smaller: plots are mostly runs of one
    colour, which the filters do not shorten."""
    import struct
    import zlib

    a = np.asarray(rgba)
    h, w = a.shape[:2]
    rows = np.empty((h, 3 * w + 1), np.uint8)
    rows[:, 0] = 0                                  # filter type None
    rows[:, 1:].reshape(h, w, 3)[...] = a[:, :, :3]
    z = zlib.compressobj(1)
    data = z.compress(rows) + z.flush()

    def chunk(tag: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    ppm = round(dpi / 0.0254)                       # pixels per metre
    with open(path, "wb") as f:
        f.write(b"".join([b"\x89PNG\r\n\x1a\n",
                          chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)),
                          chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1)),
                          chunk(b"IDAT", data), chunk(b"IEND", b"")]))


_RENDERER = []
_TEXTS: dict = {}             # (string, font, dpi, antialiased) -> _Rasterised, this process
_TEXTS_MAX = 4096             # entries kept (a few kB each); the cache is emptied when full


class _Rasterised:
    """One string laid out and rasterised by FreeType: its width, height and descent (pixels)
    and its bitmap with the bitmap's offset (FreeType's 1/64 pixels)."""
    __slots__ = ("whd", "image", "offset")

    def __init__(self, font, s, flags, antialiased):
        font.set_text(s, 0.0, flags=flags)
        w, h = font.get_width_height()
        self.whd = (w / 64.0, h / 64.0, font.get_descent() / 64.0)
        font.draw_glyphs_to_bitmap(antialiased=antialiased)
        self.image = font.get_image()
        self.offset = font.get_bitmap_offset()


def _renderer_class():
    """RendererAgg, laying out and rasterising each distinct string once per process when this
    matplotlib draws texts glyph by glyph (3.11: a Python loop over the glyphs, each with its own
    transform and image; and FreeType lays the string out again for the drawing after the
    measuring, 0.4 ms each time): the string is laid out and rasterised in one call and drawn
    as one image, as matplotlib up to 3.10 did, and the result is kept for the next time the
    same string is measured or drawn in the same font (tick labels, legends and axis labels
    repeat from figure to figure). A string's bitmap does not depend on where it is drawn
    (whole pixels, as up to 3.10), so a figure is the same whether its texts were cached or
    not. Math text and anything else go to matplotlib's own methods."""
    if _RENDERER:
        return _RENDERER[0]
    from matplotlib.backends import backend_agg
    from matplotlib.backends.backend_agg import RendererAgg

    cls = RendererAgg
    if hasattr(RendererAgg, "_draw_text_glyphs_and_boxes"):
        hinting = backend_agg.get_hinting_flag

        class TextRenderer(RendererAgg):
            def _text(self, s, prop, antialiased=True):
                key = (s, tuple(prop.get_family()), prop.get_style(), prop.get_variant(),
                       prop.get_weight(), prop.get_stretch(), prop.get_size_in_points(),
                       prop.get_file(), self.dpi, bool(antialiased))
                r = _TEXTS.get(key)
                if r is None:
                    if len(_TEXTS) >= _TEXTS_MAX:
                        _TEXTS.clear()
                    r = _TEXTS[key] = _Rasterised(self._prepare_font(prop), s, hinting(),
                                                  antialiased)
                return r

            def get_text_width_height_descent(self, s, prop, ismath):
                if ismath:
                    return super().get_text_width_height_descent(s, prop, ismath)
                return self._text(s, prop).whd

            def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
                if ismath:
                    return super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
                r = self._text(s, prop, gc.get_antialiased())
                # the bitmap is drawn unrotated at angle 0, rotated by draw_text_image
                a = math.radians(angle)
                d = r.whd[2]
                x = round(x + r.offset[0] / 64.0 + d * math.sin(a))
                y = round(y + r.offset[1] / 64.0 + d * math.cos(a))
                self._renderer.draw_text_image(r.image, x, y + 1, angle, gc)

        cls = TextRenderer
    _RENDERER.append(cls)
    return cls


def body_palette(n: int) -> list:
    """Body colours: tab10, tab20 beyond ten bodies, then evenly spaced hues."""
    from matplotlib import colormaps
    if n <= 10:
        return [colormaps["tab10"](k) for k in range(n)]
    if n <= 20:
        return [colormaps["tab20"](k) for k in range(n)]
    return [colormaps["turbo"](v) for v in np.linspace(0.05, 0.95, n)]


def _point_palette(n: int) -> list:
    """Point colours: Dark2, the hues least like the first body colours (tab10 blue, orange,
    green, red) first, then tab20."""
    from matplotlib import colormaps
    if n <= 8:
        return [colormaps["Dark2"](k) for k in (0, 3, 5, 6, 2, 4, 1, 7)[:n]]
    return body_palette(n)


def _darker(color, f=0.7):
    """The colour darkened (light palette entries as legible text)."""
    from matplotlib.colors import to_rgb
    return tuple(f * v for v in to_rgb(color))


def _with_alpha(color, alpha):
    from matplotlib.colors import to_rgba
    return to_rgba(color, alpha)


def _unique(points, tol=1e-9) -> np.ndarray:
    """(k, 2) distinct points (relative tolerance), in first-seen order."""
    P = np.asarray(points, float).reshape(-1, 2)
    scale = max(np.abs(P).max(), 1e-300)
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


# -- outlines of the machine-element kinds (pitch circles, cam profiles), body frame, user units --

def _circle(centre, r, n=61):
    a = np.linspace(0.0, 2 * np.pi, n)
    return np.asarray(centre, float) + abs(r) * np.c_[np.cos(a), np.sin(a)]


def _discs(G, k, L, revolutes, ground):
    """gear-mesh, roll-disc: both pitch circles with a radius mark that shows the rotation."""
    out = []
    for col, pr in ((0, ("si", "ri")), (1, ("sj", "rj"))):
        c, r = G.params[pr[0]][k] * L, G.params[pr[1]][k] * L
        b = int(G.bodies[k, col])
        out += [(b, _circle(c, r)), (b, np.array([c, c + (abs(r), 0.0)]))]
    return out


def _pinion(G, k, L, revolutes, ground):
    """rack-pinion, roll-line: the pinion's (disc's) pitch circle."""
    c, r = G.params["sj"][k] * L, G.params["r"][k] * L
    b = int(G.bodies[k, 1])
    return [(b, _circle(c, r)), (b, np.array([c, c + (r, 0.0)]))]


def _cam(G, k, L, revolutes, ground):
    """cam, cam-rocker: the working surface over the law's range on the cam, the roller."""
    from ..elements.cam import instance, profile
    par = instance(G, k)
    bi, bj, bk = (int(b) for b in G.bodies[k])
    lo, hi = par["range"]
    if not np.isfinite(lo):
        lo, hi = 0.0, 2 * np.pi
    P = profile(G.kind.name, par, np.linspace(lo, hi, 181))
    centre = np.zeros(2)
    for i, si, j, sj in revolutes:
        if {i, j} == {bi, bk}:
            centre = si if i == bi else sj
            break
    out = [(bi, centre + np.c_[P["surface_x"], P["surface_y"]] * L)]
    roller = float(par["roller"]) * L
    if roller > 0:
        out.append((bj, _circle(G.params["sj"][k] * L, roller, 31)))
    return out


def _belt(G, k, L, revolutes, ground):
    """belt on the frame: the two straight runs between the pulleys' ground pivots (global)."""
    if int(G.bodies[k, 2]) != ground:
        return []                                   # on a moving carrier: runs not drawn
    c = []
    for col in (0, 1):
        b = int(G.bodies[k, col])
        c.append(next((si if i == ground else sj for i, si, j, sj in revolutes
                       if {i, j} == {b, ground}), None))
    if c[0] is None or c[1] is None:
        return []
    r1, r2 = G.params["ri"][k] * L, G.params["rj"][k] * L
    crossed = G.params["crossed"][k] > 0.5
    d = np.hypot(*(c[1] - c[0]))
    sb = ((r1 + r2) if crossed else (r1 - r2)) / d
    if not d > 0 or abs(sb) >= 1:
        return []
    e = (c[1] - c[0]) / d
    n = np.array([-e[1], e[0]])
    out = []
    for side in (1.0, -1.0):
        m = side * n * np.sqrt(1 - sb * sb) + e * sb
        out.append((ground, np.array([c[0] + r1 * m, c[1] + (-r2 if crossed else r2) * m])))
    return out


def _slot(G, k, L, revolutes, ground):
    """curve-slot: the slot or track itself, its whole length, on body i (a line on the frame,
    dashed on a moving body); the pin's path shows only the part it runs along."""
    cv = G.params["curve"][k]
    P = cv.eval(np.linspace(cv.a0, cv.a1, 241))[0] * L
    return [(int(G.bodies[k, 0]), P)]


MACHINE_OUTLINES = {"belt": _belt, "gear-mesh": _discs, "roll-disc": _discs, "rack-pinion": _pinion,
                    "roll-line": _pinion, "cam": _cam, "cam-rocker": _cam, "curve-slot": _slot}


def _face(G, k, L, phi):
    """cam, cam-rocker with flat: true: the follower's flat face, a solid line on it (body
    frame, user units) over every point of contact of the law's range, with a margin, and the
    face's own point sj (a corner of the body's outline); None for other followers. The
    contact point c and the face's point w (the pitch point of the profile) both lie on the
    face: its position along the face, seen from the cam, is (c - w)^T e for the face's
    direction e there. phi: the bodies' angles (rad) at the grid times (a translating
    follower's face direction on its body: the angle between it and the frame its axis is
    given in, constant)."""
    from ..elements.cam import instance, profile
    par = instance(G, k)
    if not par.get("flat", 0.0) > 0.5:
        return None
    bj, bk = int(G.bodies[k, 1]), int(G.bodies[k, 2])
    lo, hi = par["range"]
    if not np.isfinite(lo):
        lo, hi = 0.0, 2 * np.pi
    th = np.linspace(lo, hi, 361)
    P = profile(G.kind.name, par, th)
    dx, dy = P["surface_x"] - P["pitch_x"], P["surface_y"] - P["pitch_y"]   # cam frame
    ang = lambda b: phi[0, b] if b < phi.shape[1] else 0.0              # noqa: E731 - ground
    if G.kind.name == "cam-rocker":
        a = np.asarray(par["sj"], float) - np.asarray(par["pj"], float)
        f = np.asarray(par["face"], float)
        f = a / np.hypot(*a) if not np.isfinite(f).all() else f / np.hypot(*f)
        e = par["rest"] + par["psi"](th)[0] + np.arctan2(f[1], f[0]) - th     # e's angle
    else:       # the face perpendicular to the travel u: along R u, on j at a fixed angle
        u = np.asarray(par["vk"], float)
        rel = ang(bk) - ang(bj)
        n = np.array([-u[1], u[0]]) / np.hypot(*u)
        f = np.array([np.cos(rel) * n[0] - np.sin(rel) * n[1],
                      np.sin(rel) * n[0] + np.cos(rel) * n[1]])
        e = np.arctan2(n[1], n[0]) - th
    xi = dx * np.cos(e) + dy * np.sin(e)
    if not np.isfinite(xi).all():
        return None
    a0, a1 = xi.min(), xi.max()
    pad = 0.15 * (a1 - a0) + 0.05 * np.hypot(*np.c_[P["surface_x"], P["surface_y"]].T).max()
    a0, a1 = min(a0 - pad, 0.0), max(a1 + pad, 0.0)     # from the face's point on: the body
    sj = np.asarray(par["sj"], float)
    return bj, np.array([sj + a0 * f, sj + a1 * f]) * L


MACHINE_FACES = {"cam": _face, "cam-rocker": _face}
