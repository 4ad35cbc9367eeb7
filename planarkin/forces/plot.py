"""forces.<fmt>: driver efforts and joint reaction magnitudes against time, and, with a single
driver, against its driven coordinate f(t) as well (matplotlib imported here only)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

DASHES = ("-", (0, (5, 2)), (0, (1.5, 1.5)), (0, (6, 2, 1.5, 2)))


def forces_plot(cm, X, info, out: Path, fmt: str = "png") -> list:
    """Write forces.<fmt> from the plot rows X of forces.csv; returns [path] (nothing without
    rows)."""
    from ..output.plots.render import save_figure

    if not len(X):
        return []
    return [save_figure(forces_figure(cm, X, info), Path(out) / f"forces.{fmt}")]


def same_curves(curves, rel=1e-9) -> list:
    """Curves [(label, values (N,))] grouped where they are equal (within rel of the largest
    finite value of all of them): [(labels, values)] in first-seen order. A massless link's two
    pins carry the same force: one curve named "a = b" instead of one hiding the other."""
    finite = [np.abs(v[np.isfinite(v)]) for _, v in curves]
    scale = max((float(f.max()) for f in finite if f.size), default=0.0)
    tol = rel * scale if scale > 0 else 0.0
    groups: list = []
    for label, v in curves:
        for labels, w in groups:
            with np.errstate(invalid="ignore"):
                if np.all((np.abs(v - w) <= tol) | (np.isnan(v) & np.isnan(w))):
                    labels.append(label)
                    break
        else:
            groups.append(([label], v))
    return groups


def forces_figure(cm, X, info):
    """forces.<fmt> as a Figure: driver efforts (upper row) and joint reaction magnitudes
    |(fx, fy)| of the force on body j (lower row) against time and, with a single driver,
    against its driven coordinate f(t) as well. Joints that only transmit a moment (angle,
    gear) are left out (their columns are in the table); curves equal to one drawn are named
    with it ("a = b"); each row's legend stands right of the axes, never on a curve."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    from ..output.plots.axes import add_axes
    from ..output.plots.history import finish_time_axes
    from ..output.plots.render import text_inches
    from ..output.plots.style import FONT, body_palette, plot_title, pretty, tick_label_width
    from .units import unit_names

    def _pretty(unit):
        return pretty(unit).replace("*", "\u00b7")

    header = _header_of(cm, X)
    t = X[:, 0]
    u = unit_names(cm.spec)
    efforts = same_curves([(h.split(" [", 1)[0], X[:, k]) for k, h, role in header
                           if role == "effort"])
    effort_units = sorted({h.split(" [", 1)[1].rstrip("]") for _, h, role in header
                           if role == "effort"})
    # reaction magnitudes: |(fx, fy)| per joint
    joints: dict[str, dict] = {}
    for k, h, role in header:
        if role == "reaction":
            name, comp = h.split(" [", 1)[0].rsplit(".", 1)
            joints.setdefault(name, {})[comp] = X[:, k]
    mags = same_curves([(name, np.hypot(c["fx"], c["fy"])) for name, c in joints.items()
                        if "fx" in c])
    rows = [[(" = ".join(labels), v) for labels, v in group] for group in (efforts, mags)]
    one = len(cm.spec.drivers) == 1
    ncol = 2 if one else 1
    # inches right of the axes: handle and pad (2.8 em), the widest label, a margin
    legend_w = 0.3 + 2.8 * FONT / 72 + text_inches([lab for row in rows for lab, _ in row], FONT)
    H = 6.6
    width = (5.6 * ncol if one else 7.0) + legend_w
    fig = Figure(figsize=(width, H))
    # grid, ticks and tick labels drawn by output.plots.axes.Ticks; the abscissa shared by
    # column, its tick labels in the lower row
    spec = fig.add_gridspec(2, ncol)
    axes = [[None] * ncol for _ in range(2)]
    for c in range(ncol):
        for r in range(2):
            axes[r][c] = add_axes(fig, spec[r, c], xlabels=r == 1, sharex=axes[0][c],
                                  grid=("0.88", 0.6))
    xs = [(t, "time t [s]")]
    if one:
        el = cm.spec.drivers[0]
        from ..elements import KINDS
        kind = KINDS[el.kind]
        unit = cm.spec.angle_unit if kind.target_unit == "angle" else cm.spec.length_unit
        f = np.broadcast_to(cm.driver_funcs[0](t), t.shape)
        what = "angle" if kind.target_unit == "angle" else "length"
        xs.append((f, f"{_driver_name(el)}: driven {what} f(t) [{_pretty(unit)}]"))
    colors = body_palette(max(len(rows[0]), len(rows[1]), 1))
    handles: list = [[], []]
    for c, (x, xlabel) in enumerate(xs):
        for r, row in enumerate(rows):
            ax = axes[r][c]
            for n, (label, v) in enumerate(row):
                # dashes cycle so that curves close to each other stay apart
                style = dict(color=colors[n % len(colors)], lw=1.4 if r == 0 else 1.3,
                             ls="-" if r == 0 else DASHES[n % len(DASHES)])
                ax.plot(x, v, **style)
                if c == 0:
                    handles[r].append(Line2D([], [], label=label, **style))
        axes[0][c].axhline(0, color="0.6", lw=0.6, zorder=1)
        axes[1][c].set_ylim(bottom=0)
        axes[1][c].set_xlabel(xlabel)
    for ax in axes[0]:
        ax.set_ylabel("driver effort" + (f" [{_pretty(', '.join(effort_units))}]"
                                         if effort_units else ""))
    for ax in axes[1]:
        ax.set_ylabel(f"joint reaction |F| [{_pretty(u['force'])}]")
    finish_time_axes([[axes[0][0]], [axes[1][0]]], _Data(t), info)
    fig.suptitle(plot_title(cm, "driver efforts and joint reactions (on body j of each "
                                  "joint)", info), fontsize=11, y=1 - 0.1 / H, va="top")
    # a fixed layout, in inches: constrained layout measured every text, a large part of the
    # time of this figure; the tick labels' widths come from the axes' locators and formatters
    room = [0.55 + max(tick_label_width(ax.yaxis, *ax.get_ylim()) for ax in col)
            for col in zip(*axes)]
    right = 0.2 + legend_w
    aw = (width - sum(room) - right) / ncol
    fig.subplots_adjust(left=room[0] / width, right=1 - right / width, top=1 - 0.45 / H,
                        bottom=0.55 / H, hspace=0.15 / 2.8,
                        wspace=room[-1] / aw if ncol > 1 else 0.2)
    ah = (H - 1.0 - 0.15) / 2                       # axes height, inches
    for c, col in enumerate(zip(*axes)):
        for ax in col:
            ax.yaxis.set_label_coords(-(room[c] - 0.4) / aw, 0.5)
            ax.xaxis.set_label_coords(0.5, -0.31 / ah)
    for r in range(2):
        if handles[r]:
            top = axes[r][-1].get_position().y1
            fig.legend(handles=handles[r], loc="upper left", frameon=False, fontsize=FONT,
                       bbox_to_anchor=(1 - (legend_w + 0.05) / width, top), borderaxespad=0)
    return fig


class _Data:
    def __init__(self, t):
        self.t = t


def _driver_name(el) -> str:
    from .layout import column_name
    return column_name(el)


def _header_of(cm, X):
    """(column index, header, role) of the forces table that X was computed for."""
    from .layout import columns, redundancy
    _, left_out, _ = redundancy(cm)
    cols = columns(cm, left_out)
    assert len(cols) + 1 == X.shape[1]
    return [(k, h, role) for k, (h, _, role) in enumerate(cols, start=1)]



