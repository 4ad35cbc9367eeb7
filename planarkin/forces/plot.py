"""forces.<fmt>: driver efforts and joint reaction magnitudes against time, and, with a single
driver, against its driven coordinate f(t) as well (matplotlib imported here only)."""

from __future__ import annotations


from pathlib import Path

import numpy as np


DASHES = ("-", (0, (5, 2)), (0, (1.5, 1.5)), (0, (6, 2, 1.5, 2)))


def forces_plot(cm, X, info, out: Path, fmt: str = "png") -> list:
    """Write forces.<fmt> from the plot rows X of forces.csv; returns [path] (nothing without
    rows). Reactions are drawn as magnitudes |(fx, fy)| of the force on body j; joints that only
    transmit a moment (angle, gear) are left out of the plot (their columns are in the table)."""
    from matplotlib.figure import Figure

    from ..output.plots import (add_axes, finish_time_axes, body_palette, pretty as _pretty2,
                                save_figure, tick_label_width, plot_title)

    def pretty(unit):
        return _pretty2(unit).replace("*", "\u00b7")
    from .model import unit_names

    if not len(X):
        return []
    header = _header_of(cm, X)
    t = X[:, 0]
    u = unit_names(cm.spec.length_unit)
    efforts = [(k, h) for k, h, role in header if role == "effort"]
    # reaction magnitudes: |(fx, fy)| per joint, |torque| for moment-only kinds
    joints: dict[str, dict] = {}
    for k, h, role in header:
        if role == "reaction":
            name, comp = h.split(" [", 1)[0].rsplit(".", 1)
            joints.setdefault(name, {})[comp] = X[:, k]
    mags = []
    for name, c in joints.items():
        if "fx" in c:
            mags.append((name, np.hypot(c["fx"], c["fy"])))
    one = len(cm.spec.drivers) == 1
    ncol = 2 if one else 1
    fig = Figure(figsize=(6.4 * ncol if one else 7.5, 6.6))
    # grid, ticks and tick labels drawn by output.plots._Ticks; the abscissa shared by column,
    # its tick labels in the lower row
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
        xs.append((f, f"{_driver_name(el)}: driven {what} f(t) [{pretty(unit)}]"))
    colors = body_palette(max(len(efforts), len(mags), 1))
    for c, (x, xlabel) in enumerate(xs):
        ax = axes[0][c]
        for n, (k, h) in enumerate(efforts):
            name, rest = h.split(" [", 1)
            ax.plot(x, X[:, k], color=colors[n], lw=1.4, label=name)
        units = sorted({h.split(" [", 1)[1].rstrip("]") for _, h in efforts})
        ax.set_ylabel("driver effort" + (f" [{pretty(', '.join(units))}]" if units else ""))
        ax.axhline(0, color="0.6", lw=0.6, zorder=1)
        if efforts:
            ax.legend(fontsize=9, loc="best", frameon=False)
        ax = axes[1][c]
        for n, (name, v) in enumerate(mags):
            # dashes cycle so that coinciding curves (a massless link's two pins) stay visible
            ax.plot(x, v, color=colors[n % len(colors)], lw=1.3, ls=DASHES[n % len(DASHES)],
                    label=name)
        ax.set_ylabel(f"joint reaction |F| [{pretty(u['force'])}]")
        ax.set_ylim(bottom=0)
        if mags:
            ax.legend(fontsize=9, loc="best", frameon=False, ncol=1 if len(mags) < 5 else 2)
        ax.set_xlabel(xlabel)
    finish_time_axes([[axes[0][0]], [axes[1][0]]], _Data(t), info)
    fig.suptitle(plot_title(cm, "driver efforts and joint reactions (on body j of each joint)",
                        info), fontsize=11, y=1 - 0.1 / 6.6, va="top")
    # a fixed layout, in inches: constrained layout measured every text, half of the time of
    # this figure; the tick labels' widths come from the axes' locators and formatters
    width = fig.get_figwidth()
    room = [0.55 + max(tick_label_width(ax.yaxis, *ax.get_ylim()) for ax in col)
            for col in zip(*axes)]
    aw = (width - sum(room) - 0.2) / ncol
    fig.subplots_adjust(left=room[0] / width, right=1 - 0.2 / width, top=1 - 0.45 / 6.6,
                        bottom=0.55 / 6.6, hspace=0.15 / 2.8,
                        wspace=room[-1] / aw if ncol > 1 else 0.2)
    ah = (6.6 - 1.0 - 0.15) / 2                     # axes height, inches
    for c, col in enumerate(zip(*axes)):
        for ax in col:
            ax.yaxis.set_label_coords(-(room[c] - 0.4) / aw, 0.5)
            ax.xaxis.set_label_coords(0.5, -0.31 / ah)
    return [save_figure(fig, Path(out) / f"forces.{fmt}")]


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



