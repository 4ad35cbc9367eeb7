"""The directory writer: streams a run's chunks into the tables of one result directory, then
writes summary.json and the plots and puts the directory in place, under the output contract of
`planarkin.output.directory` (the only code that touches the directory itself). It only reads
results (chunks, `planarkin.results.RunInfo`); it computes nothing of the analysis.
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from planarkin.solver.chunks import concat, take
from ..derived import derived_tables
from ..options import ORDERS
from planarkin.solver.chunks import Chunk
from planarkin.solver.grid import Options
from .directory import (DISK_ERRORS, SINKS, OutputError, ResultDirectory, WriteError,
                        checkpoint, critical, signame)
from .summary import ColumnStats, StepStats, error_estimates, write_json
from planarkin.solver.layout import Layout
from planarkin.results.runinfo import RunInfo

if TYPE_CHECKING:                     # annotations only
    from ..model.compile import CompiledModel

PLOT_ROWS = 4000    # rows kept for plots (the tables keep every row)
PLOT_BYTES = 64 << 20   # and at most this much of them (a model of thousands of points)


class PlotBuffer:
    """Every k-th row of the run (and the last), enough for plots of any run length."""

    def __init__(self, total_rows: int):
        self.total = total_rows
        self.stride = max(1, math.ceil(total_rows / PLOT_ROWS))
        self.seen = 0
        self.parts: list[Chunk] = []
        self.last: Chunk | None = None

    def add(self, ch: Chunk) -> None:
        n = len(ch.t)
        if not self.seen and n:         # the width of a row is known from the first chunk
            row = sum(a.nbytes for a in vars(ch).values() if isinstance(a, np.ndarray)) / n
            self.stride = max(self.stride, math.ceil(self.total * row / PLOT_BYTES))
        first = (-self.seen) % self.stride
        sel = np.arange(first, n, self.stride)
        self.parts.append(take(ch, sel))
        self.last = take(ch, np.array([n - 1])) if n else self.last
        self.seen += n

    def chunk(self) -> Chunk | None:
        parts = self.parts
        if self.last is not None and (not parts or not len(parts[-1].t)
                                      or parts[-1].t[-1] != self.last.t[0]):
            parts = parts + [self.last]
        parts = [p for p in parts if len(p.t)]
        return concat(parts) if parts else None


class DirectoryWriter:
    """Streams chunks into the tables of one result directory (bodies.csv, points.csv and the
    derived tables), then writes summary.json and the plots and puts the directory in place
    (the output contract: planarkin.output.directory). Everything runs in this process: the
    tables are formatted as each chunk arrives, the plots are drawn after the tables are
    closed. Every table gets the same blocks (a critical block each), so the tables stop at the
    same row whenever the run stops. Raises OutputError (busy, not ours, not writable); add()
    and finish() raise WriteError (disk full ...) after abandoning the new directory.

    stop: a `run --jobs` worker's shared stop value (planarkin.output.directory.checkpoint).
    """

    def __init__(self, cm: CompiledModel, out: Path, opts: Options, plots: str | None = "png",
                 animate: bool = False, x: str | None = None, table_format: str | None = None,
                 stop=None, report: bool = False):
        self.cm = cm
        self.final = Path(out)
        self.stop = stop
        self.dir = ResultDirectory(self.final)
        self.out = self.dir.tmp            # files are written here until commit()
        self.sinks: dict = {}
        self.rows = 0
        self.committed = False             # the directory is in place
        # called with the summary as the directory is put in place, in the same critical block
        # (the CLI's report line: a signal then cannot leave a directory without its line)
        self.on_commit = None
        self.reported = False              # on_commit was called
        try:
            spec = cm.spec.output
            self.layout = Layout(cm, opts.order, spec.bodies, spec.points)
            self.steps = StepStats()
            self.plots = plots
            self.animate = animate
            self.report = report                    # report.html (planarkin.output.report_html)
            self.notes: list[str] = []              # summary.json's notes (an MP4 not written)
            self.x = x or cm.spec.output.x          # abscissa of the time histories
            self.buffer = PlotBuffer(opts.steps + 1) if (plots or animate or report) else None
            self.t_write = 0.0
            # table_format: "csv" or "parquet" (default: the model's output: table_format);
            # the sinks, and summary.json's files and columns, go by the names of the files
            # written (bodies.parquet ...)
            fmt = table_format or cm.spec.output.table_format
            kind = SINKS[fmt]
            self.names = {}             # a table's CSV name -> the name of its file

            def sink(name, header, accumulator=None):
                fname = self.names[name] = name[:-len(".csv")] + "." + fmt
                self.sinks[fname] = kind(self.out / fname, header, accumulator)
                return fname
            from ..measures.cycle import CoordinateFigures

            def figures(header):
                return lambda: CoordinateFigures(cm, header, opts)
            sink("bodies.csv", self.layout.body_header, figures(self.layout.body_header))
            if self.layout.points:
                sink("points.csv", self.layout.point_header, figures(self.layout.point_header))
            # the rooms' tables under the names of the files written (forces.parquet ...)
            self.derived = [dataclasses.replace(d, filename=sink(d.filename, d.header,
                                                                 d.accumulator))
                            for d in derived_tables(cm, opts)]
        except WriteError as e:
            self.abort()
            if e.errno in DISK_ERRORS:      # a full disk: an analysis failure (exit 1)
                raise
            raise OutputError(str(e)) from None
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
        checkpoint(self.stop)              # a signal lost in a finalizer, a parent's stop
        t0 = time.perf_counter()
        tables = self._tables(ch)          # all computed before any is written: equal rows
        with critical():                   # an interruption waits until every table has them
            try:
                for s, X in zip(self.sinks.values(), tables):
                    s.add(X)
            except BaseException:
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
            busy += b
        for csv, name in self.names.items():     # bodies.csv, points.csv: found by those names
            closed.setdefault(csv, closed[name])
        return closed, busy

    def finish(self, info: RunInfo, started: float | None = None) -> dict:
        """Close the tables, write the plots and summary.json (wall time since `started`, a
        perf_counter value) and put the directory in place; returns the summary.

        An interruption while the tables close, or while the summary is written and the
        directory moved, waits until that is done; one while the plots are drawn leaves them
        out (the tables are complete; status interrupted). Either is raised again once the
        directory is in place."""
        pending = None
        data = self.buffer.chunk() if self.buffer is not None and info.interrupted is None \
            else None
        try:
            try:
                with critical():
                    closed, busy = self._close_tables()
                    summary = self._summary(info, closed, busy, started)
            except KeyboardInterrupt as e:          # raised once they were closed
                pending = e
        except BaseException:
            self.abort()
            raise
        try:
            drawn: list = []
            material = None                # what report.html shows besides the summary
            if data is not None and pending is None:
                t0 = time.perf_counter()
                try:
                    drawn = [p.name for p in self._plots(info, data)]
                except OSError as e:
                    if e.errno in DISK_ERRORS:  # the summary and the rename would fail next
                        raise WriteError(f"writing the plots failed: {e.strerror or e}",
                                         e.errno) from None
                    summary["warnings"].append({"kind": "plots", "message": f"drawing the plots "
                                                f"failed: {type(e).__name__}: {e}"})
                except Exception as e:  # noqa: BLE001 - a figure must not cost the tables
                    summary["warnings"].append({"kind": "plots", "message": f"drawing the plots "
                                                f"failed: {type(e).__name__}: {e}"})
                except KeyboardInterrupt as e:
                    pending = e
                summary["wall_time"]["plots"] = round(time.perf_counter() - t0, 6)
                if self.notes:
                    summary["notes"] = list(self.notes)
                if self.report and pending is None:
                    t0 = time.perf_counter()
                    try:
                        material = self._report_material(info, data)
                    except OSError as e:
                        if e.errno in DISK_ERRORS:
                            raise WriteError(f"writing report.html failed: {e.strerror or e}",
                                             e.errno) from None
                        summary["warnings"].append(_no_report(e))
                    except Exception as e:  # noqa: BLE001 - the page must not cost the tables
                        summary["warnings"].append(_no_report(e))
                    except KeyboardInterrupt as e:
                        pending = e
                    summary["wall_time"]["report"] = round(time.perf_counter() - t0, 6)
            if pending is None:
                try:
                    checkpoint()           # a signal lost in a finalizer meanwhile
                except KeyboardInterrupt as e:
                    pending = e
            with critical():
                if pending is not None:
                    info.interrupted = signame(pending)
                    summary.update(_interrupted_status(info, "while the results were closed: "
                                                             "the tables are complete, the "
                                                             "plots are left out"))
                    drawn = []
                    summary.pop("notes", None)      # (about a video not drawn either)
                # a figure drawn half (an interruption, an error) is not left in the directory
                for p in self.out.iterdir():
                    if p.name not in summary["files"] and p.name not in drawn:
                        p.unlink()
                summary["plots"] = drawn
                if material is not None and pending is None:
                    summary["report"] = "report.html"
                self._write_summary(summary)
                if material is not None and pending is None:
                    self._write_report(summary, material)
                try:
                    self.dir.commit()
                except OSError as e:
                    raise WriteError(f"putting {self.final}/ in place failed: "
                                     f"{e.strerror or e}", e.errno) from None
                self.committed = True
                if self.on_commit is not None and pending is None:
                    self.reported = True
                    self.on_commit(summary)
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
        from ..forces.output import cycle_contact
        from ..measures.cycle import cycle_section
        summary["cycle"] = cycle_section(closed["bodies.csv"][1],
                                         closed.get("points.csv", (None, None))[1],
                                         summary.get("cycle"), cycle_contact(summary.get("forces")))
        summary["files"] = {name: {"rows": self.rows, "columns": len(closed[name][0].header)}
                            for name in self.sinks}
        return summary

    def _plots(self, info: RunInfo, data) -> list:
        """Draw the model's and the rooms' figures and the animation; returns their files in
        figure order."""
        return self._figures(info, data, self.out, self.plots, self.animate)

    def _figures(self, info: RunInfo, data, out: Path, fmt: str | None, animate=None) -> list:
        """Draw the model's and the rooms' figures (format fmt; None: none) into out, and with
        animate the animation between them (animation.gif, and animation.mp4 where ffmpeg is,
        else a note for the summary); returns their files in figure order."""
        from . import plots as plotting       # matplotlib only when plotting
        files = []
        minima = ()          # the closest approaches, marked where the model gives shapes
        if getattr(self.cm, "shapes", ()) and (fmt or animate) and len(data.t) > 1:
            from planarkin.clearance.cycle import minima as closest
            minima = closest(self.cm, data)
        if fmt:
            files += plotting.write_plots(self.cm, data, info, out, fmt=fmt, x=self.x,
                                          minima=minima)
        if animate:
            from .plots.animation import write_animations
            opts = animate if isinstance(animate, dict) else {}
            written, notes = write_animations(self.cm, data, out, minima=minima, **opts)
            files += written
            self.notes += notes
        if fmt:
            for d in self.derived:
                if d.plot is not None:
                    files += d.plot(self.cm, d.compute(data), info, out, fmt)
            # cam.<fmt>: drawn here, not as cam-<name>.csv's plot (the elements may not import
            # the plots)
            from .plots.cam import cam_figures
            files += cam_figures(self.cm, data, info, out, fmt)
        return files

    def _report_material(self, info: RunInfo, data):
        """What report.html shows besides the summary (planarkin.output.report_html.Material):
        the figures as SVG (drawn into a folder of the staged directory, removed at once; none
        when the run draws no plots), the mechanism moving, key rows of bodies.csv."""
        from . import report_html as rh
        from planarkin.solver.chunks import take
        m = rh.Material()
        n = len(data.t)
        if not n:
            return m
        index = np.arange(n) * self.buffer.stride        # the plot rows' rows in the tables
        index[-1] = self.rows - 1
        if self.plots:
            few, _ = rh.thin(data, rh.FIGURE_ROWS)
            tmp = self.out / ".report-figures"
            try:
                tmp.mkdir()
                files = self._figures(info, few, tmp, "svg")
                m.figures = [(f"{p.stem}.{self.plots}",
                              rh.inline_svg(p.read_text(encoding="utf-8"), f"f{k}-"))
                             for k, p in enumerate(files)]
            except Exception as e:  # noqa: BLE001 - the page without its figures, saying why
                if isinstance(e, OSError) and e.errno in DISK_ERRORS:
                    raise
                m.notes.append(f"The figures could not be drawn for this page: "
                               f"{type(e).__name__}: {e}.")
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            if m.figures and len(few.t) < self.rows:
                m.notes.append(f"The figures are drawn from {len(few.t)} of the run's "
                               f"{self.rows} rows, evenly spread.")
        m.motion, frames = rh.motion(self.cm, data, index, self.rows)
        m.notes.append(f"The animation has {frames} frames: "
                       + ("every row of the run." if frames == self.rows else
                          f"rows evenly spread over the run's {self.rows} rows."))
        key = np.unique(np.linspace(0, n - 1, min(rh.KEY_ROWS, n)).round().astype(int))
        m.table, m.header = self.names["bodies.csv"], list(self.layout.body_header)
        m.rows = self.layout.body_table(take(data, key)) + 0.0      # no -0.0, as in the file
        m.row_index = index[key]
        return m

    def _write_summary(self, summary: dict) -> None:
        try:
            write_json(self.out / "summary.json", summary)
        except OSError as e:
            raise WriteError(f"writing summary.json failed: {e.strerror or e}", e.errno) from None

    def _write_report(self, summary: dict, material) -> None:
        """report.html, made from summary.json as written (its values as they are there); a
        bug making it leaves it out and says so in the summary (written again)."""
        from .report_html import REPORT, page
        try:
            text = page(json.loads((self.out / "summary.json").read_text(encoding="utf-8")),
                        material)
        except OSError as e:
            raise WriteError(f"reading summary.json back failed: {e.strerror or e}",
                             e.errno) from None
        except Exception as e:  # noqa: BLE001 - the page must not cost the tables
            del summary["report"]
            summary["warnings"].append(_no_report(e))
            self._write_summary(summary)
            return
        try:
            (self.out / REPORT).write_text(text, encoding="utf-8")
        except OSError as e:
            raise WriteError(f"writing {REPORT} failed: {e.strerror or e}", e.errno) from None

    def abort(self) -> None:
        """Close every table and remove the new files; the previous directory stays."""
        for s in self.sinks.values():
            s.kill()
        self.dir.abandon()


def _no_report(e: BaseException) -> dict:
    """The summary's warning for a report.html left out by an error."""
    return {"kind": "report", "message": f"report.html was not written: {type(e).__name__}: "
                                         f"{e} (please report)"}


def _interrupted_status(info: RunInfo, how: str) -> dict:
    code = 143 if info.interrupted == "SIGTERM" else 130
    return {"status": "interrupted", "exit_code": code,
            "message": f"interrupted by {info.interrupted} {how}"}


def build_summary(cm: CompiledModel, info: RunInfo, steps: StepStats, body_stats: ColumnStats,
                  point_stats: ColumnStats | None, wall: float | None) -> dict:
    from ..version import __version__
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
                     "order": ORDERS[o.order]},
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
    if getattr(info, "loops", None) is not None:       # four-bar and slider-crank figures
        out["loops"] = info.loops.as_dict()
    if spec.overrides:
        out["overrides"] = dict(spec.overrides)
    if point_stats is not None:
        out["columns"][getattr(point_stats, "table", "points.csv")] = point_stats.as_dict()
    if wall is not None:
        out["wall_time"]["total"] = round(wall, 6)
    return out
