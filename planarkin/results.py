"""Results of an analysis: the arrays (SciPy-style result object) and the streaming writers.

`solve()` collects every chunk into a `Result`; `planarkin run` streams the chunks straight to the
CSV files and folds them into the summary, so memory stays bounded for millions of steps. Both
consume the same `Analysis.chunks()` and write through the same `DirectoryWriter`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .model.compile import CompiledModel
from .output.directory import (SINKS, Interrupted, ProcessSink, ResultDirectory,
                               fork_context, held_signals)
from .output.summary import ColumnStats, StepStats, error_estimates, write_json
from .output.tables import Layout
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
    breakpoints: dict = field(default_factory=dict)   # drivers' breakpoints (Analysis.breakpoint_info)
    interrupted: str | None = None   # 'SIGINT' / 'SIGTERM': the rows up to then are complete

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
                   an.fallbacks, dict(an.timings), list(cm.spec.warnings) + list(A.warnings),
                   an.breakpoint_info())


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


class DirectoryWriter:
    """Streams chunks into the tables of one result directory (bodies.csv, points.csv and the
    derived tables), then writes summary.json and the plots and puts the directory in place
    (the output contract: planarkin.output.directory).

    With background=True (where fork exists), each table is formatted and written by its own
    forked process while this one solves the next chunk: CSV formatting costs about as much per
    step as solving, so on two cores the writing hides behind the solve. Threads would not help:
    both sides spend much of their time in the interpreter, under the GIL. Every table gets the
    same blocks in the same order, so the files are identical either way, and stop at the same
    row whenever the run stops. Raises OutputError (busy, not ours, not writable); add() and
    finish() raise WriteError (disk full ...) after abandoning the new directory.
    """

    def __init__(self, cm: CompiledModel, out: Path, opts: Options, plots: str | None = "png",
                 animate: bool = False, background: bool = False, x: str | None = None,
                 table_format: str | None = None):
        self.cm = cm
        self.final = Path(out)
        self.dir = ResultDirectory(self.final)
        self.out = self.dir.tmp            # files are written here until commit()
        self.sinks: dict = {}
        self.rows = 0
        self.committed = False             # the directory is in place
        try:
            spec = cm.spec.output
            self.layout = Layout(cm, opts.order, spec.bodies, spec.points)
            self.steps = StepStats()
            self.plots = plots
            self.animate = animate
            self.x = x or cm.spec.output.x          # abscissa of the time histories
            self.buffer = PlotBuffer(opts.steps + 1) if (plots or animate) else None
            self.t_write = 0.0
            ctx = fork_context() if background else None
            self.background = ctx is not None

            # table_format: "csv" or "parquet" (default: the model's output: table_format);
            # the sinks, and summary.json's files and columns, go by the names of the files
            # written (bodies.parquet ...)
            fmt = table_format or cm.spec.output.table_format
            kind = SINKS[fmt]
            self.names = {}             # a table's CSV name -> the name of its file

            def sink(name, header, accumulator=None):
                fname = self.names[name] = name[:-len(".csv")] + "." + fmt
                path = self.out / fname
                self.sinks[fname] = ProcessSink(ctx, path, header, accumulator, kind) if ctx \
                    else kind(path, header, accumulator)
                return fname
            from .measures.cycle import CoordinateFigures

            def figures(header):
                return lambda: CoordinateFigures(cm, header, opts)
            sink("bodies.csv", self.layout.body_header, figures(self.layout.body_header))
            if self.layout.points:
                sink("points.csv", self.layout.point_header, figures(self.layout.point_header))
            # the rooms' tables under the names of the files written (forces.parquet ...)
            self.derived = [dataclasses.replace(d, filename=sink(d.filename, d.header,
                                                                 d.accumulator))
                            for d in derived_tables(cm, opts)]
        except BaseException:
            self.abort()
            raise

    def _tables(self, ch: Chunk) -> list:
        out = [self.layout.body_table(ch)]
        if self.layout.points:
            out.append(self.layout.point_table(ch))
        out += [d.compute(ch) for d in self.derived]
        for X in out:
            X += 0.0          # -0.0 + 0.0 is +0.0: no "-0.0" cells in the tables
        return out

    def add(self, ch: Chunk) -> None:
        t0 = time.perf_counter()
        tables = self._tables(ch)          # all computed before any is sent: equal rows
        with held_signals():               # an interruption waits until every table has them
            try:
                for s, X in zip(self.sinks.values(), tables):
                    s.add(X)
            except Exception:
                self.abort()
                raise
            self.rows += len(ch.t)
            self.steps.add(ch)
            if self.buffer is not None:
                self.buffer.add(ch)
        self.t_write += time.perf_counter() - t0

    def _close_tables(self):
        closed, busy = {}, 0.0
        for name, s in self.sinks.items():
            stats, extra, b = s.close()
            stats.table = name         # build_summary keys the columns by the file's name
            closed[name] = (stats, extra)
            busy = max(busy, b) if self.background else busy + b
        for csv, name in self.names.items():     # bodies.csv, points.csv: found by those names
            closed.setdefault(csv, closed[name])
        return closed, busy

    def finish(self, info: RunInfo, started: float | None = None) -> dict:
        """Close the tables, write summary.json (wall time since `started`, a perf_counter
        value) and the plots, and put the directory in place; returns the summary.

        An interruption while the tables close or the plots are drawn keeps the complete
        tables (status interrupted, some plots missing) and is raised again once the directory
        is in place; one that arrives while the summary is written and the directory moved
        waits until it is in place."""
        pending = None
        drawn: list = []
        data = self.buffer.chunk() if self.buffer is not None and info.interrupted is None \
            else None
        try:
            try:
                with held_signals():
                    sent = False
                    if data is not None and self.background:
                        # the CLI's plot server (if it started one) draws while the tables close
                        from .output import plotworker
                        sent = plotworker.submit(self.cm, data, info, self.out, self.plots,
                                                 self.animate, self.x)
                    closed, busy = self._close_tables()
                    summary = self._summary(info, closed, busy, started)
            except (KeyboardInterrupt, Interrupted) as e:      # raised once they were closed
                pending = e
            if data is not None and pending is None:
                t0 = time.perf_counter()
                try:
                    drawn = [p.name for p in self._plots(info, data, sent)]
                except Exception as e:  # noqa: BLE001 - a figure must not cost the tables
                    summary["warnings"].append({"kind": "plots", "message": f"drawing the "
                                                f"plots failed: {type(e).__name__}: {e}"})
                except (KeyboardInterrupt, Interrupted) as e:
                    pending = e
                summary["wall_time"]["plots"] = round(time.perf_counter() - t0, 6)
            if pending is not None:
                info.interrupted = _signal_name(pending)
                summary.update(_interrupted_status(info, "while the results were closed: the "
                                                         "tables are complete, plots may be "
                                                         "missing"))
                if data is not None and sent:     # nothing may still draw into the directory
                    from .output import plotworker
                    with held_signals():
                        plotworker.stop()
            # what is there, whoever drew it, in figure order (the plot server, this process,
            # a room; an interrupted drawing may have left some)
            there = {p.name for p in self.out.iterdir()} - set(summary["files"]) - \
                {"summary.json"}
            summary["plots"] = [n for n in drawn if n in there] + sorted(there - set(drawn))
            with held_signals():
                write_json(self.out / "summary.json", summary)
                self.dir.commit()
                self.committed = True
        except BaseException:
            if not self.committed:
                self.abort()
            raise
        if pending is not None:
            raise pending
        return summary

    def _summary(self, info: RunInfo, closed: dict, busy: float, started) -> dict:
        wall = None if started is None else time.perf_counter() - started
        info.timings["write"] = busy
        summary = build_summary(self.cm, info, self.steps, closed["bodies.csv"][0],
                                closed.get("points.csv", (None,))[0], wall)
        for d in self.derived:
            stats, extra = closed[d.filename]
            summary["columns"][d.filename] = stats.as_dict()
            if d.section is not None and extra is not None:
                summary[d.section] = extra
        from .measures.cycle import cycle_section
        summary["cycle"] = cycle_section(closed["bodies.csv"][1],
                                         closed.get("points.csv", (None, None))[1],
                                         summary.get("cycle"))
        summary["files"] = {name: {"rows": self.rows, "columns": len(closed[name][0].header)}
                            for name in self.sinks}
        return summary

    def _plots(self, info: RunInfo, data, sent: bool) -> list:
        """Collect the plot server's files (the model's and the rooms' figures), or draw them all
        here (no server, or it died). Returns the files in figure order."""
        from .output import plotworker
        files = plotworker.collect() if sent else None
        if files is not None:
            return files                # the server drew the rooms' figures too
        from .output import plots as plotting       # matplotlib only when plotting
        files = []
        if self.plots:
            files += plotting.write_plots(self.cm, data, info, self.out, fmt=self.plots,
                                          x=self.x)
        if self.animate:
            opts = self.animate if isinstance(self.animate, dict) else {}
            files.append(plotting.write_animation(self.cm, data, self.out, **opts))
        if self.plots:
            for d in self.derived:
                if d.plot is not None:
                    files += d.plot(self.cm, d.compute(data), info, self.out, self.plots)
        return files

    def abort(self) -> None:
        """Stop every writer and remove the new files; the previous directory stays."""
        with held_signals():
            for s in self.sinks.values():
                s.kill()
            self.dir.abandon()


def _signal_name(e: BaseException) -> str:
    return "SIGTERM" if isinstance(e, Interrupted) else "SIGINT"


def _interrupted_status(info: RunInfo, how: str) -> dict:
    code = 143 if info.interrupted == "SIGTERM" else 130
    return {"status": "interrupted", "exit_code": code,
            "message": f"interrupted by {info.interrupted} {how}"}


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
        **(_interrupted_status(info, f"at t = {steps.t_last:.10g} s (the rows up to then are "
                                     f"complete)" if steps.rows else "before any row was "
                                     "written") if info.interrupted else {}),
        "units": {"length": spec.length_unit, "angle": spec.angle_unit, "time": "s"},
        "time": {"start": o.start, "end": o.end, "steps": o.steps, "rows_planned": grid_rows,
                 "rows_written": steps.rows,
                 "last_t": steps.t_last if steps.rows else None,
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
        "warnings": [{"kind": "model" if d in spec.warnings and "is not consistent with" not in
                      d.message else "moved" if "is not consistent with" in d.message else
                      "redundant", "line": d.line, "message": d.message}
                     for d in info.diagnostics] + [w.as_dict() for w in info.warnings],
        "event": info.event.as_dict() if info.event is not None else None,
        "breakpoints": info.breakpoints,
        "columns": {getattr(body_stats, "table", "bodies.csv"): body_stats.as_dict()},
        "wall_time": {k: round(v, 6) for k, v in info.timings.items()},
    }
    if spec.overrides:
        out["overrides"] = dict(spec.overrides)
    if point_stats is not None:
        out["columns"][getattr(point_stats, "table", "points.csv")] = point_stats.as_dict()
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
        b = _index(self.model.body_names, name, "body")
        out = {}
        for arr, keys in ((self.q, ("x", "y", "phi")), (self.qd, ("vx", "vy", "omega")),
                          (self.qdd, ("ax", "ay", "alpha"))):
            if arr is not None:
                for k, key in enumerate(keys):
                    out[key] = arr[:, 3 * b + k]
        return out

    def point(self, name: str) -> dict:
        """Columns of one point: x, y, vx, vy, ax, ay (user units)."""
        k = _index(self.model.point_names, name, "point")
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

    def forces(self, name: str) -> dict:
        """Forces of one driver, joint or of ``total`` / ``shaking`` (models with masses or
        loads): its forces.csv columns without the name and unit, e.g. ``{"fx": ..., "fy": ...}``
        for a revolute joint, ``{"torque": ..., "power": ...}`` for an angle driver (units as in
        forces.csv: N, N*m, W when lengths are m)."""
        from .diagnostics import did_you_mean
        if not any(d.filename == "forces.csv" for d in derived_tables(self.model,
                                                                         self.info.options)):
            raise KeyError("this result has no forces: the model gives no mass, inertia or load "
                           "(or the run stopped at velocities)")
        cols = self.table("forces.csv")
        out = {k.rsplit(".", 1)[1]: v for k, v in cols.items() if k.rsplit(".", 1)[0] == name}
        if not out:
            names = list(dict.fromkeys(k.rsplit(".", 1)[0] for k in cols if k != "t"))
            raise KeyError(f"no forces named '{name}'"
                           f"{did_you_mean(name, names) or ' (names: ' + ', '.join(names) + ')'}")
        return out

    def write(self, out: str | Path, plots: str | None = "png", animate: bool = False,
              x: str | None = None, table_format: str | None = None) -> dict:
        """Write bodies.csv, points.csv, summary.json (and plots) into directory out, under the
        same output contract as `planarkin run` (raises planarkin.InputError when out is
        being written by another run, is not a planarkin result directory, or cannot be
        written); returns the summary. x: abscissa of the time-history plots, "time" or
        "driver" (default: the model's output: x). table_format: "csv" or "parquet" (bodies.parquet
        ...; needs pyarrow; default: the model's output: table_format)."""
        from .diagnostics import Diagnostic, InputError
        from .output.directory import OutputError
        if x is not None:
            from .model.spec import X_AXES, x_axis_problem
            problem = (f"x must be one of {', '.join(X_AXES)}, not {x!r}" if x not in X_AXES
                       else x_axis_problem(x, self.model.spec, "x"))
            if problem:
                raise InputError([Diagnostic(self.model.spec.file, None, problem)])
        if table_format is not None:
            from .model.spec import table_format_problem
            problem = table_format_problem(table_format, "table_format")
            if problem:
                raise InputError([Diagnostic(self.model.spec.file, None, problem)])
        try:
            w = DirectoryWriter(self.model, Path(out), self.info.options, plots=plots,
                                animate=animate, x=x, table_format=table_format)
        except OutputError as e:
            raise InputError([Diagnostic(self.model.spec.file, None, f"write(): {e}")]) from None
        w.add(self._chunk)
        return w.finish(self.info)

    def __repr__(self) -> str:
        return (f"<Result {self.model.spec.name}: {'ok' if self.success else 'failed'}, "
                f"{len(self.t)} rows, {self.message}>")


def _index(names, name: str, what: str) -> int:
    """Position of name in names; an unknown name raises KeyError with a suggestion."""
    try:
        return list(names).index(name)
    except ValueError:
        from .diagnostics import did_you_mean
        hint = did_you_mean(name, names) or f" ({what} names: {', '.join(names) or 'none'})"
        raise KeyError(f"no {what} '{name}' in this model{hint}") from None


def prepare(cm: CompiledModel, opts: Options) -> Analysis:
    """Everything before the first row: the budget check, assembly and path following.
    Invalid input (the budget, a model that cannot be assembled) raises InputError, so nothing
    has been written yet when it does."""
    from .assembly import assemble
    from .budget import preflight
    from .diagnostics import Diagnostic, InputError
    a = cm.spec.analysis
    if (opts.start, opts.end) != (a.start, a.end):
        # the validator checked the drivers over the model's range; this run has another one
        problems = [Diagnostic(cm.spec.file, el.param_lines.get("f", el.line), f"{el.label}: {msg}")
                    for el in cm.spec.drivers if el.f is not None and hasattr(el.f, "problems")
                    for msg in el.f.problems(opts.start, opts.end)]
        if problems:
            raise InputError(problems)
    reason = preflight(cm, opts)
    if reason is not None:
        row = next((r for r in cm.driver_rows if reason.startswith(cm.row_label[r])), None)
        line = cm.element_of_row(int(row)).line if row is not None else None
        raise InputError([Diagnostic(cm.spec.file, line, reason)])
    t0 = time.perf_counter()
    A = assemble(cm, opts.start)
    an = Analysis(cm, A, opts)
    an.timings["assembly"] = time.perf_counter() - t0
    an.follow()
    return an


def stream(an: Analysis, sink=None, progress=None):
    """The grid pass: checked chunks into sink (an object with add(chunk)) or into a Result.
    Returns (info, result or None)."""
    parts = []
    t2 = time.perf_counter()
    for ch in an.chunks():
        ch = refuse(an, ch)
        if len(ch.t):
            if sink is not None:
                sink.add(ch)
            else:
                parts.append(ch)
            if progress is not None:
                progress(len(ch.t))
        if an.event is not None and an.event.kind in REFUSALS:
            break
    an.timings["grid"] = time.perf_counter() - t2
    if sink is not None and not getattr(sink, "background", False):
        an.timings["grid"] -= getattr(sink, "t_write", 0.0)     # written in this process
    info = run_info(an)
    result = None if sink is not None else Result(an.cm, _concat(parts) if parts else None, info)
    return info, result


def analyse(cm: CompiledModel, opts: Options, sink=None, progress=None):
    """Run an analysis: prepare (raises InputError), then the grid pass into sink or a Result.
    Returns (info, result or None)."""
    return stream(prepare(cm, opts), sink, progress)


REFUSALS = ("non-finite", "residual")


def residual_limit(opts: Options) -> float:
    """Largest constraint residual a written row may have (relative to the model's length):
    ten times the Newton tolerance, or the path tolerance when the rows are interpolated."""
    return 10 * max(opts.tol, opts.path_tol if opts.interpolate else 0.0)


def refuse(an: Analysis, ch: Chunk) -> Chunk:
    """Results are refused rather than written when they are not what they claim: the chunk is
    cut before the first row with a non-finite time or value, or a residual above
    residual_limit, and the run stops there (an event of kind 'non-finite' or 'residual')."""
    arrays = [a for a in (ch.q, ch.qd, ch.qdd) if a is not None]
    bad = ~np.isfinite(ch.t) | ~np.isfinite(ch.residual)
    for a in arrays:
        bad |= ~np.isfinite(a).all(axis=1)
    for a in (ch.p, ch.pd, ch.pdd):
        if a is not None and a.size:
            bad |= ~np.isfinite(a).all(axis=(1, 2))
    limit = residual_limit(an.opts)
    high = np.isfinite(ch.residual) & (ch.residual > limit)
    stop = bad | high
    if not stop.any():
        return ch
    i = int(np.argmax(stop))
    t = float(ch.t[i])
    cm = an.cm
    if bad[i]:
        cols = []
        layout = Layout(cm, an.opts.order)
        row = layout.body_table(_take(ch, np.array([i])))[0]
        cols = [h for h, v in zip(layout.body_header, row) if not np.isfinite(v)]
        if not cols:
            cols = ["a point's coordinates" if np.isfinite(ch.residual[i]) else "the residual"]
        shown = ", ".join(cols[:4]) + (f" and {len(cols) - 4} more" if len(cols) > 4 else "")
        msg = (f"non-finite results at t = {t:.10g} s ({shown}): a driver's velocity or "
               f"acceleration does not exist there (a kink, a step, a square root at 0?) or the "
               f"numbers overflowed; rows are written up to the one before")
        kind = "non-finite"
    else:
        msg = (f"the constraint residual {ch.residual[i]:.3g} at t = {t:.10g} s is above the "
               f"limit {limit:.3g} (10 x tol, relative to the model's size): that row would not "
               f"be a solution; rows are written up to the one before")
        kind = "residual"
    an.event = Event(kind, t, msg)
    an.t_stop = t
    return _take(ch, np.arange(i))
