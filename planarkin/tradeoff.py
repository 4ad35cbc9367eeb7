"""`planarkin tradeoff`: what each solver setting costs and buys, measured on the user's model.

Every setting is run on the same grid and compared with a tight reference run (full Newton,
tol 1e-14, dense internal nodes). Errors are relative: the largest deviation of any body or
point column of a derivative order, divided by the largest magnitude of that kind of column
(lengths and angles separately). Times are the best of a few in-process runs of the whole
analysis (assembly, path, grid), so they include everything but start-up and file writing.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .model.compile import CompiledModel
from .analysis import analyse
from .options import Options

REFERENCE = dict(newton="full", tol=1e-14, path_tol=1e-7, iterations=20)

# (label, options): every option here is also an analysis: key and a `planarkin run` option
SETTINGS = [
    ("default (reuse, tol 1e-10)", dict()),
    ("full Newton, tol 1e-10", dict(newton="full")),
    ("reuse, tol 1e-6", dict(tol=1e-6)),
    ("reuse, tol 1e-3", dict(tol=1e-3)),
    ("fixed, 1 iteration", dict(newton="fixed", iterations=1)),
    ("fixed, 2 iterations", dict(newton="fixed", iterations=2)),
    ("interpolate, path_tol 1e-7", dict(interpolate=True, path_tol=1e-7)),
    ("interpolate, path_tol 1e-5", dict(interpolate=True, path_tol=1e-5)),
    ("interpolate, path_tol 1e-3", dict(interpolate=True, path_tol=1e-3)),
    ("interpolate, path_tol 1e-2", dict(interpolate=True, path_tol=1e-2)),
]


@dataclass
class Row:
    label: str
    options: dict
    seconds: float
    us_per_step: float
    errors: tuple            # (position, velocity, acceleration); nan when not computed
    status: int


def _columns(res, order):
    """(lengths, angles) column blocks of one derivative order."""
    arr = (res.q, res.qd, res.qdd)[order]
    pts = (res.p, res.pd, res.pdd)[order]
    lengths = [arr[:, 0::3], arr[:, 1::3]]
    if pts is not None and pts.size:
        lengths.append(pts.reshape(len(res.t), -1))
    return np.concatenate(lengths, axis=1), arr[:, 2::3]


def relative_errors(res, ref) -> tuple:
    out = []
    for order in range(3):
        if (res.q, res.qd, res.qdd)[order] is None:
            out.append(float("nan"))
            continue
        worst = 0.0
        for a, b in zip(_columns(res, order), _columns(ref, order)):
            scale = np.abs(b).max()
            if scale > 0:
                worst = max(worst, float(np.abs(a - b).max() / scale))
        out.append(worst)
    return tuple(out)


def _timed(cm, opts, repeats):
    best = float("inf")
    res = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        _, res = analyse(cm, opts)
        best = min(best, time.perf_counter() - t0)
    return best, res


class ReferenceFailed(Exception):
    """The tight reference run failed (an analysis failure, exit status 1, not invalid input)."""


def run_tradeoff(cm: CompiledModel, outdir: Path, base: Options | None = None,
                 plot: bool = True, repeats: int = 3, settings=SETTINGS):
    """Run every setting on top of `base` (the model's options; steps default to at least
    20000); write tradeoff.csv (and tradeoff.png); return the table as text."""
    base = base if base is not None else Options.from_model(cm)
    if base.sources.get("steps") in (None, "yaml"):
        base = base.with_(steps=max(base.steps, 20000))
    steps = base.steps
    ref_opts = base.with_(**REFERENCE, interpolate=False)
    _, ref = analyse(cm, ref_opts)
    if ref.status != 0:
        raise ReferenceFailed(f"the reference run failed, so the trade-off cannot be measured: "
                              f"{ref.message}")
    rows = []
    for label, extra in settings:
        opts = base.with_(**extra)
        secs, res = _timed(cm, opts, repeats)
        n = len(ref.t)
        errs = relative_errors(res, ref) if len(res.t) == n else (float("nan"),) * 3
        rows.append(Row(label, extra, secs, secs / n * 1e6, errs, res.status))
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    _write_csv(outdir / "tradeoff.csv", rows, steps)
    if plot:
        _plot(cm, rows, outdir / "tradeoff.png", steps)
    return format_table(cm, rows, steps)


def _write_csv(path: Path, rows, steps):
    keys = ("newton", "tol", "iterations", "path_tol", "interpolate", "max_step")
    lines = ["setting,newton,tol,iterations,path_tol,interpolate,max_step,steps,time [s],"
             "time per step [us],error position,error velocity,error acceleration,status"]
    for r in rows:
        o = {**{k: "" for k in keys}, **r.options}
        vals = [f'"{r.label}"'] + [str(o[k]) for k in keys] + [
            str(steps), repr(r.seconds), repr(r.us_per_step)] + [repr(e) for e in r.errors] + [
            str(r.status)]
        lines.append(",".join(vals))
    path.write_text("\n".join(lines) + "\n")


def format_table(cm, rows, steps) -> str:
    head = (f"{cm.spec.name}: {steps} steps; errors relative to a reference run "
            f"(full Newton, tol 1e-14, path_tol 1e-7)\n")
    w = max(len(r.label) for r in rows)
    out = [head, f"{'setting':<{w}}  {'time':>9}  {'us/step':>8}  {'position':>9}  "
                 f"{'velocity':>9}  {'accel.':>9}"]
    for r in rows:
        e = ["{:9.1e}".format(x) if np.isfinite(x) else "        -" for x in r.errors]
        out.append(f"{r.label:<{w}}  {r.seconds * 1e3:7.1f}ms  {r.us_per_step:8.2f}  "
                   f"{e[0]}  {e[1]}  {e[2]}" + ("" if r.status == 0 else "  (failed)"))
    return "\n".join(out)


def _plot(cm, rows, path: Path, steps):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter
    fig = Figure(figsize=(8, 5.5))
    ax = fig.add_subplot()
    marks = (("position", "o", "C0"), ("velocity", "s", "C1"), ("acceleration", "^", "C2"))
    floor = 1e-17
    for k, (name, m, c) in enumerate(marks):
        pts = [(r.us_per_step, max(r.errors[k], floor), r.label) for r in rows
               if np.isfinite(r.errors[k])]
        if not pts:
            continue
        x, y, _ = zip(*pts)
        ax.scatter(x, y, marker=m, color=c, label=name, zorder=3)
        front = _pareto(list(zip(x, y)))
        if len(front) > 1:
            fx, fy = zip(*front)
            ax.step(fx, fy, where="post", color=c, alpha=0.5, lw=1)
    ax.set_xscale("log")
    ax.set_yscale("log")
    # 20, 30, 50, not 3 x 10^1; minor ticks named at 2, 3 and 5 only, so that names never touch
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(FuncFormatter(
        lambda v, _: f"{v:g}" if f"{v:.0e}"[0] in "235" else ""))
    ax.set_xlabel("time per step [us] (whole analysis, in process)")
    ax.set_ylabel("max relative error against the reference")
    ax.set_title(f"{cm.spec.name}: speed against accuracy ({steps} steps)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper right")
    fig.tight_layout()
    canvas = FigureCanvasAgg(fig)
    _label_points(ax, canvas.get_renderer(),
                  [(r.us_per_step, max(r.errors[0], floor), r.label) for r in rows
                   if np.isfinite(r.errors[0])])
    fig.savefig(path, dpi=150)
    return path


def _label_points(ax, renderer, pts, fontsize=7):
    """Name each point (x, y, text) beside it without two names overlapping each other, a
    marker, the legend or the axes' edge: settings that cost and buy the same (the Newton
    variants) sit on one spot, so their names stack above and below it, tied to it by a thin
    line. Greedy, in order of x: the first free spot of a fixed list of offsets."""
    from matplotlib.text import Text
    from matplotlib.transforms import Bbox
    frame = ax.get_window_extent(renderer)
    taken = []
    for coll in ax.collections:                           # the markers
        for xy in ax.transData.transform(coll.get_offsets()):
            taken.append(Bbox.from_bounds(xy[0] - 4, xy[1] - 4, 8, 8))
    legend = ax.get_legend()
    if legend is not None:
        taken.append(legend.get_window_extent(renderer))
    offsets = [(dx, dy) for step in range(12) for dy in ((0,) if step == 0 else
                                                          (10 * step, -10 * step))
               for dx in (6, -6)]
    for x, y, text in sorted(pts):
        ann = None
        for dx, dy in offsets:
            ann = ax.annotate(text, (x, y), xytext=(dx, dy), textcoords="offset points",
                              ha="left" if dx > 0 else "right", va="center", fontsize=fontsize,
                              arrowprops=dict(arrowstyle="-", color="0.55", lw=0.5,
                                              shrinkA=0, shrinkB=3) if dy else None)
            ann.update_positions(renderer)
            box = Text.get_window_extent(ann, renderer)     # the text, not its leader line
            if (frame.contains(box.x0, box.y0) and frame.contains(box.x1, box.y1)
                    and not any(box.overlaps(b) for b in taken)):
                break
            ann.remove()
            ann = None
        if ann is None:       # no free spot: beside the point all the same
            ann = ax.annotate(text, (x, y), xytext=(6, 0), textcoords="offset points",
                              va="center", fontsize=fontsize)
            ann.update_positions(renderer)
            box = Text.get_window_extent(ann, renderer)
        taken.append(box)


def _pareto(points):
    """Points not dominated in (time, error), sorted by time."""
    pts = sorted(points)
    out = []
    best = float("inf")
    for x, y in pts:
        if y < best:
            out.append((x, y))
            best = y
    return out
