"""Results of an analysis: the arrays (SciPy-style result object) and the streaming writers.

`solve()` collects every chunk into a `Result`; `planarkin run` streams the chunks straight to the
CSV files and folds them into the summary, so memory stays bounded for millions of steps. Both
consume the same `Analysis.chunks()` and write through the same `DirectoryWriter`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .model.compile import CompiledModel
from .output.summary import ColumnStats, StepStats, error_estimates, write_json
from .output.tables import CsvWriter, Layout
from .derived import derived_tables
from .solver import Analysis, Chunk, Event, Options

PLOT_ROWS = 4000    # rows kept for plots (the tables keep every row)


@dataclass
class RunInfo:
    """Everything about a run except the arrays: status, events, counters, timings."""

    status: int                      # 0 ok, 1 analysis failure
    message: str
    options: Options
    event: Event | None
    warnings: list
    assembly: dict
    internal_steps: int
    rejected_steps: int
    fallbacks: int
    timings: dict = field(default_factory=dict)
    diagnostics: list = field(default_factory=list)   # assembly warnings (FILE:LINE: warning)

    @property
    def success(self) -> bool:
        return self.status == 0


def run_info(an: Analysis) -> RunInfo:
    f = an.follower
    ev = an.event
    if ev is None:
        status, msg = 0, "analysis completed"
    else:
        status, msg = 1, ev.message
    A = an.A
    cm = an.cm
    asm = {
        "iterations": A.iterations,
        "residual": A.residual,
        "modes": [{"bodies": list(md.bodies), "branch": "+" if md.sign > 0 else "-",
                   "hint": f"assembly: {{branch: {{{md.key}: {'-' if md.sign > 0 else '+'}}}}} "
                           f"selects the other branch"} for md in A.modes],
        "redundant": [cm.row_label[r] for r in A.redundant_rows],
    }
    return RunInfo(status, msg, an.opts, ev, list(f.warnings), asm, len(f.nodes), f.rejected,
                   an.fallbacks, dict(an.timings), list(A.warnings))


class PlotBuffer:
    """Every k-th row of the run (and the last), enough for plots of any run length."""

    def __init__(self, total_rows: int):
        self.stride = max(1, math.ceil(total_rows / PLOT_ROWS))
        self.seen = 0
        self.parts: list[Chunk] = []
        self.last: Chunk | None = None

    def add(self, ch: Chunk) -> None:
        n = len(ch.t)
        first = (-self.seen) % self.stride
        sel = np.arange(first, n, self.stride)
        self.parts.append(_take(ch, sel))
        self.last = _take(ch, np.array([n - 1])) if n else self.last
        self.seen += n

    def chunk(self) -> Chunk | None:
        parts = self.parts
        if self.last is not None and (not parts or not len(parts[-1].t)
                                      or parts[-1].t[-1] != self.last.t[0]):
            parts = parts + [self.last]
        parts = [p for p in parts if len(p.t)]
        return _concat(parts) if parts else None


class TableSink:
    """One CSV table with its column statistics (and a room's accumulator), fed block by block."""

    def __init__(self, path: Path, header: list[str], accumulator=None):
        self.csv = CsvWriter(path, header)
        self.stats = ColumnStats(header)
        self.extra = accumulator() if accumulator is not None else None
        self.busy = 0.0

    def add(self, X: np.ndarray) -> None:
        t0 = time.perf_counter()
        self.csv.write(X)
        self.stats.add(X)
        if self.extra is not None:
            self.extra.add(X)
        self.busy += time.perf_counter() - t0

    def close(self):
        """(column statistics, the accumulator's dict or None, seconds busy)"""
        self.csv.close()
        return self.stats, (self.extra.as_dict() if self.extra is not None else None), self.busy


def _sink_process(path: Path, header: list[str], accumulator, inbox, outbox) -> None:
    """Body of a writer process: blocks of rows in, statistics out."""
    try:
        sink = TableSink(path, header, accumulator)
        while True:
            X = inbox.get()
            if X is None:
                break
            sink.add(X)
        outbox.put(("ok", sink.close()))
    except BaseException as e:  # noqa: BLE001 - reported by the parent
        outbox.put(("error", f"{type(e).__name__}: {e}"))


class ProcessSink:
    """A TableSink in a forked process: add() hands the block to a bounded queue and returns
    at once, so formatting runs in parallel with the solver."""

    def __init__(self, ctx, path: Path, header: list[str], accumulator=None):
        self.inbox = ctx.Queue(maxsize=3)
        self.outbox = ctx.Queue()
        self.proc = ctx.Process(target=_sink_process, daemon=True,
                                args=(path, header, accumulator, self.inbox, self.outbox))
        self.proc.start()

    def add(self, X: np.ndarray) -> None:
        self.inbox.put(X)

    def close(self):
        self.inbox.put(None)
        status, payload = self.outbox.get()
        self.proc.join()
        if status != "ok":
            raise RuntimeError(f"writing a table failed: {payload}")
        return payload


class DirectoryWriter:
    """Streams chunks into DIR/bodies.csv and DIR/points.csv, and writes summary.json and the
    plots at the end.

    With background=True (where fork exists), each table is formatted and written by its own
    forked process while this one solves the next chunk: CSV formatting costs about as much per
    step as solving, so on two cores the writing hides behind the solve. Threads would not help:
    both sides spend much of their time in the interpreter, under the GIL. Blocks travel through
    bounded queues (a few chunks in flight) and each table is written in order by one process,
    so the files are identical either way.
    """

    def __init__(self, cm: CompiledModel, out: Path, opts: Options, plots: str | None = "png",
                 animate: bool = False, background: bool = False, x: str | None = None):
        self.cm = cm
        self.out = Path(out)
        self.out.mkdir(parents=True, exist_ok=True)
        spec = cm.spec.output
        self.layout = Layout(cm, opts.order, spec.bodies, spec.points)
        self.steps = StepStats()
        self.plots = plots
        self.animate = animate
        self.x = x or cm.spec.output.x          # abscissa of the time histories
        self.buffer = PlotBuffer(opts.steps + 1) if (plots or animate) else None
        self.t_write = 0.0
        ctx = None
        if background:
            import multiprocessing as mp
            try:
                ctx = mp.get_context("fork")
            except ValueError:      # no fork on this platform: write in this process
                ctx = None
        self.background = ctx is not None

        def sink(name, header, accumulator=None):
            path = self.out / name
            return ProcessSink(ctx, path, header, accumulator) if ctx else \
                TableSink(path, header, accumulator)
        self.bodies = sink("bodies.csv", self.layout.body_header)
        self.points = sink("points.csv", self.layout.point_header) \
            if self.layout.points else None
        self.derived = derived_tables(cm, opts)
        self.derived_sinks = [sink(d.filename, d.header, d.accumulator) for d in self.derived]

    def add(self, ch: Chunk) -> None:
        t0 = time.perf_counter()
        self.bodies.add(self.layout.body_table(ch))
        if self.points is not None:
            self.points.add(self.layout.point_table(ch))
        for d, s in zip(self.derived, self.derived_sinks):
            s.add(d.compute(ch))
        self.steps.add(ch)
        if self.buffer is not None:
            self.buffer.add(ch)
        self.t_write += time.perf_counter() - t0

    def _close_tables(self):
        body_stats, _, busy = self.bodies.close()
        point_stats = None
        if self.points is not None:
            point_stats, _, busy2 = self.points.close()
            busy = max(busy, busy2) if self.background else busy + busy2
        derived = []
        for s in self.derived_sinks:
            stats, extra, busy2 = s.close()
            derived.append((stats, extra))
            busy = max(busy, busy2) if self.background else busy + busy2
        return body_stats, point_stats, derived, busy

    def finish(self, info: RunInfo, started: float | None = None) -> dict:
        """Close the tables, write summary.json (wall time since `started`, a perf_counter
        value) and the plots; returns the summary."""
        data = self.buffer.chunk() if self.buffer is not None else None
        sent = False
        if data is not None and self.background:
            # the CLI's plot server (if it started one) draws while the tables close
            from .output import plotworker
            sent = plotworker.submit(self.cm, data, info, self.out, self.plots, self.animate,
                                     self.x)
        body_stats, point_stats, derived, busy = self._close_tables()
        wall = None if started is None else time.perf_counter() - started
        info.timings["write"] = busy
        summary = build_summary(self.cm, info, self.steps, body_stats, point_stats, wall)
        for d, (stats, extra) in zip(self.derived, derived):
            summary["columns"][d.filename] = stats.as_dict()
            if d.section is not None and extra is not None:
                summary[d.section] = extra
        if data is not None:
            t0 = time.perf_counter()
            files = plotworker.collect() if sent else None
            if files is None:
                from .output import plots as plotting   # matplotlib only when plotting
                files = []
                if self.plots:
                    files += plotting.write_plots(self.cm, data, info, self.out,
                                                  fmt=self.plots, x=self.x)
                if self.animate:
                    opts = self.animate if isinstance(self.animate, dict) else {}
                    files.append(plotting.write_animation(self.cm, data, self.out, **opts))
            if self.plots:      # rooms' plot functions (closures) draw in this process
                for d in self.derived:
                    if d.plot is not None:
                        files += d.plot(self.cm, d.compute(data), info, self.out, self.plots)
            summary["plots"] = [f.name for f in files]
            summary["wall_time"]["plots"] = round(time.perf_counter() - t0, 6)
        write_json(self.out / "summary.json", summary)
        return summary


def build_summary(cm: CompiledModel, info: RunInfo, steps: StepStats, body_stats: ColumnStats,
                  point_stats: ColumnStats | None, wall: float | None) -> dict:
    from . import __version__
    o = info.options
    spec = cm.spec
    grid_rows = o.steps + 1
    out = {
        "planarkin": __version__,
        "model": spec.name,
        "file": spec.file,
        "status": "ok" if info.status == 0 else "failed",
        "exit_code": info.status,
        "message": info.message,
        "units": {"length": spec.length_unit, "angle": spec.angle_unit, "time": "s"},
        "time": {"start": o.start, "end": o.end, "steps": o.steps, "rows_planned": grid_rows,
                 "rows_written": steps.rows,
                 "stopped_at": info.event.t if info.event is not None else None},
        "dof": cm.n - cm.m_joint if not info.assembly["redundant"] else None,
        "bodies": list(cm.body_names),
        "points": list(cm.point_names),
        "equations": {"joints": cm.m_joint, "drivers": len(cm.driver_rows),
                      "coordinates": cm.n},
        "characteristic_length": cm.L,
        "settings": {"tol": o.tol, "newton": o.newton, "iterations": o.iterations,
                     "path_tol": o.path_tol, "max_step": o.max_step,
                     "interpolate": o.interpolate, "bifurcation": o.bifurcation,
                     "order": ("position", "velocity", "acceleration")[o.order]},
        "assembly": info.assembly,
        "solver": {
            "internal_steps": info.internal_steps,
            "rejected_steps": info.rejected_steps,
            "grid_fallbacks": info.fallbacks,
            "newton_iterations": {
                "min": steps.iter_min, "max": steps.iter_max,
                "mean": steps.iter_sum / steps.rows if steps.rows else None},
        },
        "residual": {"max": steps.res_max, "t": steps.res_tmax,
                     "note": "max |Phi| over all equations, relative to the characteristic length"},
        "condition": {"min": steps.cond_min if steps.rows else None,
                      "max": steps.cond_max if steps.rows else None, "t_max": steps.cond_tmax},
        "error_estimate": error_estimates(steps),
        "warnings": [{"kind": "redundant", "line": d.line, "message": d.message}
                     for d in info.diagnostics] + [w.as_dict() for w in info.warnings],
        "event": info.event.as_dict() if info.event is not None else None,
        "columns": {"bodies.csv": body_stats.as_dict()},
        "wall_time": {k: round(v, 6) for k, v in info.timings.items()},
    }
    if point_stats is not None:
        out["columns"]["points.csv"] = point_stats.as_dict()
    if wall is not None:
        out["wall_time"]["total"] = round(wall, 6)
    return out


def _take(ch: Chunk, sel) -> Chunk:
    g = lambda a: None if a is None else a[sel]
    return Chunk(ch.t[sel], ch.q[sel], g(ch.qd), g(ch.qdd), ch.p[sel], g(ch.pd), g(ch.pdd),
                 ch.iterations[sel], ch.cond[sel], ch.residual[sel])


def _concat(parts: list[Chunk]) -> Chunk:
    def cat(name):
        arrays = [getattr(p, name) for p in parts]
        return None if arrays[0] is None else np.concatenate(arrays)
    return Chunk(*(cat(f) for f in ("t", "q", "qd", "qdd", "p", "pd", "pdd", "iterations", "cond",
                                    "residual")))


class Result:
    """What `planarkin.solve` returns: arrays on the grid (user units) and the run's diagnostics.

    t: (N,) s. q, qd, qdd: (N, 3 nb) per body x, y, phi and derivatives (None above the
    computed order). p, pd, pdd: (N, P, 2) points. iterations, cond, residual: (N,) per step.
    status: 0 ok, 1 analysis failure (arrays hold the results up to the failure); message;
    event (why it stopped), warnings (near-singular passages, redundancies), info (RunInfo).
    """

    def __init__(self, model: CompiledModel, chunk: Chunk | None, info: RunInfo):
        self.model = model
        self.info = info
        self.status = info.status
        self.message = info.message
        self.event = info.event
        self.warnings = info.warnings
        if chunk is None:
            n, P = model.n, len(model.point_names)
            z = lambda *s: np.zeros((0,) + s)
            chunk = Chunk(z(), z(n), z(n), z(n), z(P, 2), z(P, 2), z(P, 2),
                          np.zeros(0, int), z(), z())
        self._chunk = chunk
        for name in ("t", "q", "qd", "qdd", "p", "pd", "pdd", "iterations", "cond", "residual"):
            setattr(self, name, getattr(chunk, name))

    @property
    def success(self) -> bool:
        return self.status == 0

    def body(self, name: str) -> dict:
        """Columns of one body: x, y, phi, vx, vy, omega, ax, ay, alpha (user units)."""
        b = self.model.body_names.index(name)
        out = {}
        for arr, keys in ((self.q, ("x", "y", "phi")), (self.qd, ("vx", "vy", "omega")),
                          (self.qdd, ("ax", "ay", "alpha"))):
            if arr is not None:
                for k, key in enumerate(keys):
                    out[key] = arr[:, 3 * b + k]
        return out

    def point(self, name: str) -> dict:
        """Columns of one point: x, y, vx, vy, ax, ay (user units)."""
        k = self.model.point_names.index(name)
        out = {}
        for arr, keys in ((self.p, ("x", "y")), (self.pd, ("vx", "vy")), (self.pdd, ("ax", "ay"))):
            if arr is not None:
                out[keys[0]], out[keys[1]] = arr[:, k, 0], arr[:, k, 1]
        return out

    def table(self, filename: str) -> dict:
        """Columns of a derived table (e.g. ``forces.csv``) by header name without the unit
        (``{"t": ..., "crank-driver.torque": ...}``), computed from this result's arrays."""
        for d in derived_tables(self.model, self.info.options):
            if d.filename == filename:
                X = d.compute(self._chunk)
                return {h.split(" [", 1)[0]: X[:, k] for k, h in enumerate(d.header)}
        from .diagnostics import did_you_mean
        names = [d.filename for d in derived_tables(self.model, self.info.options)]
        raise KeyError(f"this result has no table '{filename}'"
                       f"{did_you_mean(filename, names) or ' (derived tables: ' + (', '.join(names) or 'none') + ')'}")

    def write(self, out: str | Path, plots: str | None = "png", animate: bool = False,
              x: str | None = None) -> dict:
        """Write bodies.csv, points.csv, summary.json (and plots) into directory out; returns the
        summary. x: abscissa of the time-history plots, "time" or "driver" (default: the
        model's output: x)."""
        if x is not None:
            from .model.spec import X_AXES, x_axis_problem
            problem = (f"x must be one of {', '.join(X_AXES)}, not {x!r}" if x not in X_AXES
                       else x_axis_problem(x, self.model.spec, "x"))
            if problem:
                from .diagnostics import Diagnostic, InputError
                raise InputError([Diagnostic(self.model.spec.file, None, problem)])
        w = DirectoryWriter(self.model, Path(out), self.info.options, plots=plots,
                            animate=animate, x=x)
        w.add(self._chunk)
        return w.finish(self.info)

    def __repr__(self) -> str:
        return (f"<Result {self.model.spec.name}: {'ok' if self.success else 'failed'}, "
                f"{len(self.t)} rows, {self.message}>")


def analyse(cm: CompiledModel, opts: Options, sink=None, progress=None):
    """Run an analysis: assembly (raises InputError), path, dense chunks into sink (an object
    with add(chunk)) or into a Result. Returns (info, result or None)."""
    from .assembly import assemble
    t0 = time.perf_counter()
    A = assemble(cm)
    t1 = time.perf_counter()
    an = Analysis(cm, A, opts)
    an.timings["assembly"] = t1 - t0
    an.follow()
    parts = []
    t2 = time.perf_counter()
    for ch in an.chunks():
        if sink is not None:
            sink.add(ch)
        else:
            parts.append(ch)
        if progress is not None:
            progress(len(ch.t))
    an.timings["grid"] = time.perf_counter() - t2
    if sink is not None and not getattr(sink, "background", False):
        an.timings["grid"] -= getattr(sink, "t_write", 0.0)     # written in this process
    info = run_info(an)
    result = None if sink is not None else Result(cm, _concat(parts) if parts else None, info)
    return info, result
