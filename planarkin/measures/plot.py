"""measures.png: each measure (value and rate) against time; matplotlib imported here only."""

from __future__ import annotations

from pathlib import Path


def plot_measures(cm, X, out: Path, fmt: str = "png") -> list:
    """Write measures.<fmt> (one row per measure, its rate on a second axis) from the plot rows
    X of measures.csv; returns [path]. matplotlib's object-oriented API only (no pyplot, no
    backend switch: an API caller's matplotlib state is left alone)."""
    from matplotlib.figure import Figure

    from ..output.plots.render import save_figure
    measures = cm.spec.measures
    from .units import columns
    names = [n for n in (h.split(" [", 1)[0] for h in _header(cm, X))]
    cols = [c for c in columns(cm, measures, 2) if c[0] in names]
    index = {name: names.index(name) for name, _, _, _ in cols}
    units = {name: u for name, u, _, _ in cols}
    n = len(measures)
    fig = Figure(figsize=(8, 2.2 * n + 0.6), layout="constrained")
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)
    t = X[:, 0]
    for ax, m in zip(axes[:, 0], measures):
        if m.name not in index:             # a ratio without velocities
            ax.set_axis_off()
            continue
        k = index[m.name]
        ax.plot(t, X[:, k], color="tab:blue", label=f"{m.name} [{units[m.name]}]")
        ax.set_ylabel(f"{m.name} [{units[m.name]}]", color="tab:blue")
        ax.grid(alpha=0.3)
        r = index.get(f"{m.name}.rate")
        ax2 = ax.twinx() if r is not None else None
        if r is not None:
            ax2.plot(t, X[:, r], color="tab:orange", lw=1, ls="--")
            ax2.set_ylabel(f"rate [{units[m.name + '.rate']}]", color="tab:orange")
        title = f"{m.name}: {m.kind} {' '.join(m.refs)}"
        if m.kind in ("ratio", "advantage"):
            # a ratio is infinite at a dead point: show the body of the curve, say so
            import numpy as np
            for axis, col in ((ax, X[:, k]),) + (((ax2, X[:, r]),) if r is not None else ()):
                fin = col[np.isfinite(col)]
                if fin.size:
                    lo, hi = np.percentile(fin, [5, 95])
                    pad = 0.5 * (hi - lo) + 1e-300
                    if fin.min() < lo - pad or fin.max() > hi + pad:
                        axis.set_ylim(lo - pad, hi + pad)
                        title += " (clipped near dead points)" if axis is ax else ""
        ax.set_title(title, fontsize=9, loc="left")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(f"{cm.spec.name}: measures (solid) and their rates (dashed)")
    return [save_figure(fig, Path(out) / f"measures.{fmt}")]


def _header(cm, X):
    """The header of the measures table X, rebuilt from its width (order 0, 1 or 2)."""
    from .units import columns
    for order in (2, 1, 0):
        cols = columns(cm, cm.spec.measures, order)
        if len(cols) + 1 == X.shape[1]:
            return ["t [s]"] + [f"{n} [{u}]" for n, u, _, _ in cols]
    raise ValueError("measures table of an unexpected width")
