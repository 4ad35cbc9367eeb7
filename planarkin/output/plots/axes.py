"""Axes whose grid, ticks and tick labels are drawn by one artist (`Ticks`): matplotlib's tick
objects cost four fifths of drawing a time history."""

from __future__ import annotations

import numpy as np


def add_axes(fig, where, xlabels=True, sharex=None, grid=None):
    """fig.add_subplot(where) (a subplot spec) or fig.add_axes(where) (a rectangle), its grid,
    ticks and labels drawn by `Ticks`; xlabels: whether the x tick labels are drawn; grid:
    (colour, line width) of the grid lines (default: rcParams grid.color, grid.linewidth).
    Its axis labels are drawn where set_label_coords puts them (the figure's layout)."""
    kw = dict(axes_class=axes_class(), sharex=sharex)
    ax = fig.add_axes(where, **kw) if isinstance(where, tuple) else fig.add_subplot(where, **kw)
    Ticks.make(ax, xlabels=xlabels, grid=grid)
    return ax


_AXES = []


def axes_class():
    """Axes whose axes make no matplotlib tick objects when they are created or cleared (two
    of them per axis, a third of the time of making an axes): `Ticks` draws their ticks. Ticks
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


class Ticks:
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


