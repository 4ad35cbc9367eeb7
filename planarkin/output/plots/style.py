"""The house style of every figure: sizes, fonts, colours, unit labels and titles (no matplotlib
at import; each helper imports what it needs)."""

from __future__ import annotations

import math

import numpy as np

DPI = 150                      # raster output (png)
ANIM_FRAMES = 80               # frames of animation.gif (fewer when the run has fewer rows)
ANIM_FPS = 20
ANIM_DPI = 100                 # 6.4 in wide -> 640 px
FONT = 9                       # legends, annotations (ticks and labels use matplotlib's 10 pt)
# Axes style, set through rcParams for the duration of each figure (`styled`), read by `Ticks`
# (which draws every axes' grid, ticks and tick labels: matplotlib's own grid is off). The
# titles' y is fixed so that matplotlib does not measure the tick labels to place them.
STYLE = {"axes.grid": False, "grid.color": "0.88", "grid.linewidth": 0.6,
         "xtick.labelsize": 9, "ytick.labelsize": 9, "axes.titley": 1.0}
GROUND_Z = 25                  # ground pivots above every drawn instant (zorders 10 to 20)
# Points drawn one by one (a line, a marker, a legend entry and a placed name each; their time
# histories compared pairwise): the first NAMED_POINTS. The paths of the rest are one grey
# collection (CROWD) of at most CROWD_VERTICES vertices, their time histories left out with a
# note; points.csv has every point.
NAMED_POINTS = 24
CROWD = "0.62"
CROWD_VERTICES = 400_000
ROW_NAMES = ("position", "velocity", "acceleration", "jerk")


def styled(fn):
    """Run fn (a figure builder or writer) with STYLE in effect: rcParams are read when artists
    are created and when ticks are drawn, so both happen inside."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import matplotlib as mpl
        with mpl.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


def text_width(labels) -> float:
    """Generous width in inches of the longest label at FONT pt."""
    return 0.08 * max(len(s) for s in labels)

def entry_width(handles) -> float:
    """Width of one legend entry in inches at FONT pt (handle, text, column spacing)."""
    return 0.5 + text_width([h.get_label() for h in handles])

def tick_label_width(axis, lo, hi) -> float:
    """Rough width in inches of the widest tick label the axis shows for the range lo..hi."""
    ticks = np.asarray(axis.get_major_locator().tick_values(min(lo, hi), max(lo, hi)))
    eps = 1e-9 * abs(hi - lo)
    ticks = ticks[(ticks >= min(lo, hi) - eps) & (ticks <= max(lo, hi) + eps)]
    return text_width(axis.get_major_formatter().format_ticks(ticks) if len(ticks) else ["0"])

def duration(data, info) -> float:
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

def body_palette(n: int) -> list:
    """Body colours: tab10, tab20 beyond ten bodies, then evenly spaced hues."""
    from matplotlib import colormaps
    if n <= 10:
        return [colormaps["tab10"](k) for k in range(n)]
    if n <= 20:
        return [colormaps["tab20"](k) for k in range(n)]
    return [colormaps["turbo"](v) for v in np.linspace(0.05, 0.95, n)]

def point_palette(n: int) -> list:
    """Point colours: Dark2, the hues least like the first body colours (tab10 blue, orange,
    green, red) first, then tab20."""
    from matplotlib import colormaps
    if n <= 8:
        return [colormaps["Dark2"](k) for k in (0, 3, 5, 6, 2, 4, 1, 7)[:n]]
    return body_palette(n)

def darker(color, f=0.7):
    """The colour darkened (light palette entries as legible text)."""
    from matplotlib.colors import to_rgb
    return tuple(f * v for v in to_rgb(color))

def with_alpha(color, alpha):
    from matplotlib.colors import to_rgba
    return to_rgba(color, alpha)

