"""Plots of design studies (matplotlib imported only here, only when plotting).

sweep.png: each metric against the swept parameter (one parameter), a heat map per metric over
the grid of two parameters, otherwise each metric against each parameter as a scatter. Variants
that failed or were invalid are marked, never left out silently.
tolerance.png: histograms of the Monte-Carlo outputs with the nominal value, the percentiles and
the first-order (sensitivity) normal density.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _figure(nrows: int, ncols: int, figsize):
    """A Figure (constrained layout) and its (nrows, ncols) axes: matplotlib's object-oriented
    API, no pyplot and no backend switch (an API caller's matplotlib state is left alone)."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, squeeze=False)


def sweep_plot(path: Path, names: list[str], P: np.ndarray, status: list[str], labels: list[str],
               M: np.ndarray, grid: list | None, title: str) -> Path:
    """P: (V, p) parameter values; M: (V, m) metrics (nan unless ok); grid: the values of each
    parameter for a factorial (None for sampled variants)."""
    from matplotlib import colormaps
    nm = max(len(labels), 1)
    ok = np.array([s == "ok" for s in status])
    heat = grid is not None and len(names) == 2
    ncol = 1 if (len(names) == 1 or heat) else len(names)
    fig, axes = _figure(nm, ncol, (6.4 if ncol == 1 else 3.6 * ncol, 3.2 * nm))
    for i in range(nm):
        lab = labels[i] if labels else "status"
        for j in range(ncol):
            ax = axes[i, j]
            if heat:
                gx, gy = grid
                Z = M[:, i].reshape(len(gx), len(gy)).T if labels else \
                    ok.reshape(len(gx), len(gy)).T.astype(float)
                cmap = colormaps["viridis"].with_extremes(bad="#d0d0d0")
                im = ax.pcolormesh(_edges(gx), _edges(gy), np.ma.masked_invalid(Z), cmap=cmap,
                                   shading="flat", **({} if labels else dict(vmin=0, vmax=1)))
                bar = fig.colorbar(im, ax=ax, label=lab)
                if not labels:      # no metric: whether each variant ran, not a number
                    bar.set_ticks([0, 1], labels=["failed", "ok"])
                bad = ~ok.reshape(len(gx), len(gy)).T
                if bad.any():
                    X, Y = np.meshgrid(gx, gy)
                    ax.plot(X[bad], Y[bad], "x", color="#b00000", ms=5,
                            label="failed or invalid (grey)")
                    ax.legend(loc="upper right", fontsize=8, framealpha=0.85)
                ax.set_xlabel(names[0])
                ax.set_ylabel(names[1])
                continue
            x = P[:, j]
            order = np.argsort(x, kind="stable")
            y = M[:, i] if labels else ok.astype(float)
            if grid is not None and len(names) == 1:
                ax.plot(x[order], y[order], "-", color="#1f5fa8", lw=1.2)
            ax.plot(x[ok], y[ok], "o", color="#1f5fa8", ms=3.5, label="ok")
            if (~ok).any():
                # along the bottom edge: a failed variant has no value to plot
                ax.plot(x[~ok], np.full((~ok).sum(), 0.03), "x", color="#b00000", ms=6,
                        transform=ax.get_xaxis_transform(), clip_on=False,
                        label="failed or invalid (no value)")
                ax.legend(fontsize=8, framealpha=0.85)
            if not labels:          # no metric: whether each variant ran, not a number
                ax.set_yticks([0, 1], ["failed", "ok"])
                ax.set_ylim(-0.3, 1.3)
            ax.set_xlabel(names[j])
            ax.set_ylabel(lab)
            ax.grid(True, alpha=0.3)
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=110)
    return path


def _edges(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if len(v) == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def tolerance_plot(path: Path, labels: list[str], Y: np.ndarray, nominal: list[float],
                   predicted_sd: list[float], pct: dict, title: str) -> Path:
    """Y: (N, k) Monte-Carlo outputs (nan for failed samples); predicted_sd: first-order standard
    deviations (nan when not available)."""
    k = len(labels)
    ncol = min(k, 2)
    nrow = math.ceil(k / ncol)
    fig, axes = _figure(nrow, ncol, (5.2 * ncol, 3.4 * nrow))
    for i, lab in enumerate(labels):
        ax = axes[i // ncol, i % ncol]
        y = Y[:, i][np.isfinite(Y[:, i])]
        if len(y) == 0:
            ax.set_title(f"{lab}: no successful sample", fontsize=9)
            continue
        ax.hist(y, bins=min(40, max(8, len(y) // 20)), density=True, color="#9bb8d8",
                edgecolor="#4a6f96", lw=0.5, label=f"Monte-Carlo, {len(y)} samples")
        ax.axvline(nominal[i], color="k", lw=1.2, label="nominal")
        for q in (5, 95):
            ax.axvline(pct[q][i], color="#555555", lw=0.9, ls="--",
                       label="5th / 95th percentile" if q == 5 else None)
        sd = predicted_sd[i]
        if math.isfinite(sd) and sd > 0:
            xs = np.linspace(min(y.min(), nominal[i] - 4 * sd), max(y.max(), nominal[i] + 4 * sd),
                             300)
            ax.plot(xs, np.exp(-0.5 * ((xs - nominal[i]) / sd) ** 2) / (sd * math.sqrt(2 * math.pi)),
                    color="#c0392b", lw=1.3, label="first order (sensitivities)")
        ax.set_xlabel(lab)
        ax.set_ylabel("probability density")
        ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, 4), useOffset=True)
        ax.legend(fontsize=7, framealpha=0.85)
        ax.grid(True, alpha=0.3)
    for i in range(k, nrow * ncol):
        axes[i // ncol, i % ncol].set_visible(False)
    fig.suptitle(title, fontsize=11)
    fig.savefig(path, dpi=110)
    return path
