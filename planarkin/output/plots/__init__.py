"""Plots of a run: time histories, point paths, the mechanism at several instants, an animation.

Called by `output.writer.DirectoryWriter.finish` with the decimated plot buffer (a `Chunk` of at
most a few thousand rows, user units). matplotlib is imported inside the functions only, and only
through its object-oriented API (``matplotlib.figure.Figure``, rendered by Agg): no pyplot, no backend
switch, no windows, no global state (rcParams only inside rc_context: the axes style while a
figure is built and drawn, `styled`, and an svg id salt while it is saved, `save_figure`).

Files (``<fmt>`` is png at 150 dpi, svg or pdf):

- ``bodies.<fmt>``: x, y and phi of every body frame against time, with their derivatives as far
  as the run computed them (rows position / velocity / acceleration; columns translation,
  rotation);
- ``points.<fmt>`` and ``trajectories.<fmt>`` (models with points): the same for the points of
  interest, and their paths in the plane;
- ``mechanism.<fmt>``: the mechanism at a few instants and the paths of its joints and points;
- ``animation.gif`` (`write_animation`): the mechanism moving, paths growing;
- ``clearance.<fmt>`` (`clearance.draw`, models with shapes): the distance between each pair
  of shapes against time, with the limit and each pair's minimum.

A model with shapes (issue 29) has its bodies drawn as those shapes (`outline`: plates with
their holes), its frame obstacles hatched, and its closest approaches marked.

A failed run marks its stopping time in the time histories (red dashed line); near-singular
passages are thin orange lines, bifurcations stepped over are purple.

Modules: `style` (sizes, colours, labels), `axes` (fast ticks), `render` (saving), `history`
(bodies, points), `scene` (the mechanism's geometry, from each kind's `draw` hook), `outline`
(the shapes' boundaries), `plane` (mechanism, trajectories), `animation`, `clearance`.
"""

from __future__ import annotations

from pathlib import Path

from .animation import write_animation
from .axes import Ticks, add_axes
from .history import Selection, XAxis, bodies_figure, finish_time_axes, points_figure, tidy_ylim
from .plane import instant_count, mechanism_figure, trajectories_figure
from .render import TEXTS, renderer_class, save_figure, write_png
from .scene import Scene
from .style import DPI, FONT, STYLE, body_palette, darker, pretty, styled


def figure_names(cm) -> list[str]:
    """The figures write_plots draws for this model, in order (file stems)."""
    return ["bodies"] + (["points", "trajectories"] if len(cm.point_names) else []) + \
        ["mechanism"]


@styled
def write_plots(cm, data, info, out: Path, fmt: str = "png", only=None,
                x: str = "time", minima=()) -> list[Path]:
    """Write bodies, points, trajectories and mechanism plots into directory out.

    cm: CompiledModel; data: Chunk (user units; qd/qdd/pd/pdd may be None); info: RunInfo (status,
    event and warnings are marked on the time axes; None is allowed); only: a subset of
    figure_names(cm) to draw (default all);
    x: abscissa of bodies and points, "time" or "driver" (model.spec.X_AXES); minima: the
    shapes' closest approaches to mark in mechanism.<fmt> (`mechanism_figure`).
    Returns the files written (points and trajectories only when the model has points; nothing
    when data has no rows).
    """
    out = Path(out)
    fmt = fmt.lower().lstrip(".")
    if not len(data.t):
        return []
    names = [n for n in figure_names(cm) if only is None or n in only]
    scene = Scene(cm, data) if set(names) & {"trajectories", "mechanism"} else None
    build = {"bodies": lambda: bodies_figure(cm, data, info, x),
             "points": lambda: points_figure(cm, data, info, x),
             "trajectories": lambda: trajectories_figure(cm, scene),
             "mechanism": lambda: mechanism_figure(cm, scene, minima=minima)}
    return [save_figure(build[n](), out / f"{n}.{fmt}") for n in names]


__all__ = ["DPI", "FONT", "STYLE", "TEXTS", "Scene", "Selection", "Ticks", "XAxis", "add_axes",
           "bodies_figure", "darker", "figure_names", "finish_time_axes", "instant_count",
           "mechanism_figure", "body_palette", "points_figure", "pretty", "renderer_class",
           "save_figure", "styled", "tidy_ylim", "trajectories_figure", "write_animation",
           "write_plots", "write_png"]
