"""The per-model run pipeline of `planarkin run`: read, validate, compile (load_model); prepare,
solve and write one model's result directory (run_model); a batch of models, here or in local
worker processes with `--jobs` (run_models). Invalid input is reported before anything is
written, an analysis failure keeps the rows up to it, an interruption (SIGINT, SIGTERM) leaves
every directory consistent and stops the batch (planarkin.output.directory). The reporting is
planarkin.report's; the command line is planarkin.cli's.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from .report import Report

_RUN_STOP = None    # a `run --jobs` worker's stop value (the parent's signal number, or 0)
_RUN_SIGNALLED = False  # this worker's model was stopped by a signal: the batch is ending


def run_models(models, dirs, report: Report, overrides: dict | None, analysis: dict, plots,
               animate, x_axis=None, cycle: bool = False, table_format=None,
               jobs: int = 1, html: bool = False) -> int:
    """Analyse models into dirs (one directory each, planarkin.output.directory.out_dirs), in
    order, reporting into report (its exit_code says how it went); with jobs > 1 in that many
    local processes. An interruption is reported (report.signal) and ends the batch.

    html: each model's directory gets report.html, and their parent index.html, a row per
    model linking its report (written at the end, after an interruption too). Returns 0, or 1
    when index.html could not be written (one line said why)."""
    from .output.directory import checkpoint, interruptible, signame
    since = time.time()
    with interruptible():
        try:
            if jobs > 1 and len(models) > 1:
                _run_parallel(models, dirs, report, overrides, analysis, plots, animate, jobs,
                              table_format, x_axis, html)
            else:
                for path, outdir in zip(models, dirs):
                    checkpoint()            # a signal lost in a finalizer: no further model
                    model = load_model(path, report, overrides)
                    if model is not None:
                        run_model(path, model, outdir, report, dict(analysis), plots, animate,
                                  x_axis, cycle=cycle, table_format=table_format, html=html)
        except KeyboardInterrupt as e:
            if report.signal is None:        # stopped before a model had its directory
                report.interrupted(None, signame(e), "nothing more was written")
        return write_index(models, dirs, report, since) if html and dirs else 0


def write_index(models, dirs, report: Report, since: float) -> int:
    """The batch's index.html in the parent of dirs: a row per model (its outcome, and a link
    to its report.html when this batch wrote one: ok, or failed with its directory put in
    place after `since`, a time.time()). Written whole or not at all; returns 0, or 1 after a
    line saying why it could not be (the earlier page is left as it was)."""
    from .output.directory import critical, signame
    from .output.report_html import REPORT, write_index as write_page
    root = Path(dirs[0]).parent
    items = []
    for entry, outdir in zip(report.model_entries(models), dirs):
        page = Path(outdir) / REPORT
        try:
            fresh = entry.outcome in ("ok", "failed") and page.stat().st_mtime >= since
        except OSError:
            fresh = False
        lines = entry.text.splitlines()
        message = entry.message or (lines[-1].split(": ", 1)[-1] if lines else "")
        items.append((entry.name, entry.outcome, message,
                      f"{Path(outdir).name}/{REPORT}" if fresh else None))
    try:
        with critical():
            write_page(root, f"planarkin run: {len(models)} model{'s' * (len(models) != 1)}",
                       items)
    except OSError as e:
        click.echo(f"error: writing {root / 'index.html'} failed: {e.strerror or e}; it is left "
                   f"as it was", err=True)
        return 1
    except KeyboardInterrupt as e:      # the page is written: a signal during it stops here
        if report.signal is None:
            report.interrupted(None, signame(e), "after the last model")
    return 0


def load_model(path: str, report: Report, overrides: dict | None = None):
    """Read, validate, compile; report diagnostics. Returns the model or None."""
    from .diagnostics import Diagnostic, InputError
    from . import load
    try:
        model = load(path, **(overrides or {}))
        report.diagnostics(model.spec.warnings)
        return model
    except InputError as e:
        report.invalid(path, e.diagnostics)
    except (RecursionError, MemoryError) as e:
        report.invalid(path, [Diagnostic(path, 1, f"the file is too deeply nested or too large "
                                                   f"to read ({type(e).__name__})")])
    except Exception as e:  # noqa: BLE001 - a bug must not become a traceback for the user
        report.invalid(path, [Diagnostic(path, 1, f"internal error while reading the model: "
                                                   f"{type(e).__name__}: {e} (please report)")])
    return None



class Progress:
    """A progress bar on stderr for long runs, only when stderr is a terminal."""

    def __init__(self, total: int, label: str):
        self.bar = None
        if total >= 200_000 and sys.stderr.isatty():
            self.bar = click.progressbar(length=total, label=label, file=sys.stderr)
            self.bar.__enter__()

    def __call__(self, n: int) -> None:
        if self.bar is not None:
            self.bar.update(n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None


def run_model(path, model, outdir: Path, report: Report, analysis: dict, plots, animate,
             x_axis=None, cycle=False, table_format=None, stop=None, html=False):
    """One model: options, preparation, then the directory. Invalid input (options, budget,
    assembly, a busy or foreign directory) is reported before anything is written; an
    interruption keeps the complete rows (status interrupted) and is raised again to stop the
    batch. stop: a `run --jobs` worker's stop value (see DirectoryWriter); html: write
    report.html too."""
    from .diagnostics import Diagnostic, InputError
    from .model.spec import x_axis_problem
    from .options import resolve
    from .output.directory import OutputError, WriteError, critical
    from .output.writer import DirectoryWriter
    from .analysis import prepare, stream
    t0 = time.perf_counter()
    try:
        opts = resolve(model, analysis, source="cli")
        problem = x_axis and x_axis_problem(x_axis, model.spec, "--x")
        if problem:
            raise InputError([Diagnostic(path, None, problem)])
        an = prepare(model, opts)
    except InputError as e:
        report.invalid(path, e.diagnostics)
        return
    except KeyboardInterrupt:
        raise
    except Exception as e:  # noqa: BLE001 - a bug must not become a traceback for the user
        report.failed(path, f"internal error during the analysis: {type(e).__name__}: {e} "
                            f"(please report)")
        return
    writer = None
    try:
        with critical():    # a signal waits until the writer exists, so that it can abandon it
            writer = DirectoryWriter(model, outdir, opts, plots=plots, animate=animate, x=x_axis,
                                     table_format=table_format, stop=stop, report=html)
    except OutputError as e:
        report.invalid(path, [Diagnostic(path, None, str(e))])
        return
    except WriteError as e:             # a full disk as the directory was staged
        report.failed(path, f"{e}; {outdir}/ is left as it was")
        return
    except KeyboardInterrupt:
        if writer is not None:  # staged, nothing written: the earlier results stay as they were
            writer.abort()
        raise
    # the assembly's warnings before the grid pass (a lock-up ahead: planarkin.measures.grashof)
    report.diagnostics(an.A.warnings)
    progress = Progress(opts.steps + 1, Path(path).name)
    try:
        info, _ = stream(an, sink=writer, progress=progress)
        progress.close()
        report.diagnostics([d for d in info.diagnostics
                            if d not in model.spec.warnings and d not in an.A.warnings])
        for w in info.warnings:
            report.warning(path, w.message)
        # the line is printed as the directory is put in place (in the same critical block)
        writer.on_commit = lambda s: report_line(path, outdir, report, info, s, cycle,
                                               time.perf_counter() - t0)
        writer.finish(info, started=t0)
    except BaseException as e:  # noqa: BLE001 - each kind is handled below
        progress.close()
        _end_failed(e, path, outdir, writer, report, an, t0)


def _end_failed(e, path, outdir, writer, report, an, t0):
    """After an exception in a model's run: its directory left as it was (a write error, a
    bug) or in place with the complete rows (an interruption: raised again)."""
    from .output.directory import WriteError, signame
    from .analysis import run_info
    if isinstance(e, WriteError):
        report.failed(path, f"{e}; {outdir}/ is left as it was")
        return
    if isinstance(e, KeyboardInterrupt):
        if writer.reported:
            raise e                     # in place and its line printed: the batch stops
        if not writer.committed:        # else: interrupted while plotting, already in place
            info = run_info(an)
            info.interrupted = signame(e)
            writer.on_commit = None     # its line is the interrupted one below
            try:
                writer.finish(info, started=t0)
            except WriteError as w:
                report.interrupted(path, signame(e), f"{w}; {outdir}/ is left as it was")
                raise e from None
        rows = writer.rows
        report.interrupted(path, signame(e),
                           f"{rows} complete rows (up to t = {writer.steps.t_last:.6g} s) -> "
                           f"{outdir}/" if rows else f"no rows -> {outdir}/")
        raise e
    if isinstance(e, Exception) and writer.committed:     # a bug while printing its line
        report.failed(path, f"internal error while reporting: {type(e).__name__}: {e} "
                            f"(please report); {outdir}/ is in place")
        return
    if isinstance(e, Exception):  # a bug must not become a traceback for the user
        writer.abort()
        report.failed(path, f"internal error during the analysis: {type(e).__name__}: {e} "
                            f"(please report); {outdir}/ is left as it was")
        return
    raise e


def report_line(path, outdir, report, info, summary, cycle, seconds):
    """A model's report line (and its cycle figures), once its directory is in place (seconds:
    its own wall time, the next model's solve not counted)."""
    rows = summary["time"]["rows_written"]
    detail = (f"{rows} rows, {summary['solver']['internal_steps']} internal steps, max residual "
              f"{summary['residual']['max']:.1e}, {seconds:.2f} s -> {outdir}/")
    if info.status == 0:
        report.ok(path, detail)
    else:
        report.failed(path, info.message, detail)
    for w in summary.get("warnings", ()):     # a figure or the page left out: the tables are in
        if isinstance(w, dict) and w.get("kind") in ("plots", "report"):
            report.warning(path, w["message"])
    if cycle:
        from .measures.cycle import format_cycle
        try:
            lines = format_cycle(summary.get("cycle"))
        except Exception as e:  # noqa: BLE001 - the results are written; only the report failed
            report.warning(path, f"the cycle figures could not be printed: {type(e).__name__}: "
                                 f"{e} (please report); they are in {outdir}/summary.json")
            lines = []
        for line in lines:
            click.echo(line)


# -- run --jobs ------------------------------------------------------------------------------

HUNG = 120.0    # seconds an interrupted `run --jobs` waits for a worker to stop in order


def _init_run(stop, command_line: bool = False) -> None:
    """A `run --jobs` worker: between models a signal must not end it in the executor's own
    loop (a traceback); each model takes the signals over (interruptible) and stops in order,
    on its own signal (a Ctrl-C to the group) or when the parent sets `stop`. command_line:
    the parent is planarkin's command line (its messages name --set, not the API's words)."""
    import signal

    from . import options
    from .processes import accept_signals
    global _RUN_STOP
    _RUN_STOP = stop
    options.COMMAND_LINE = command_line
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)
    accept_signals()


def _run_model(args):
    """One model of `planarkin run --jobs`: its terminal output captured, returned in order with
    the signal that interrupted it (None when it ran to its end)."""
    import contextlib
    import io

    from .output.directory import interruptible, signame
    path, outdir, quiet, overrides, analysis, plots, animate, table_format, x_axis, html = args
    out, err = io.StringIO(), io.StringIO()
    rep = Report(quiet)
    stopped = None
    global _RUN_SIGNALLED
    # the batch was stopped before this model: by the parent, or by the signal that reached
    # this worker first (the group's, which the parent may not have acted on yet)
    if _RUN_SIGNALLED or (_RUN_STOP is not None and _RUN_STOP.value):
        return "", "", rep.counts, None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), interruptible():
        try:
            model = load_model(path, rep, overrides)
            if model is not None:
                run_model(path, model, outdir, rep, dict(analysis), plots, animate, x_axis,
                          table_format=table_format, stop=_RUN_STOP, html=html)
        except KeyboardInterrupt as e:          # the directory says so already
            stopped = signame(e)
            _RUN_SIGNALLED = True
            if rep.signal is None:              # before its directory was staged
                rep.interrupted(path, stopped, f"nothing was written, {outdir}/ is left as it "
                                               f"was")
    return out.getvalue(), err.getvalue(), rep.counts, stopped


def on_disk(outdir: Path, since: float) -> str:
    """What a model's directory holds when its worker could not say (it died, or hung): the
    results its summary.json describes when they were put in place after `since` (a
    time.time()), else the earlier ones, untouched."""
    import json
    try:
        mtime = (outdir / "summary.json").stat().st_mtime
        with open(outdir / "summary.json", encoding="utf-8") as f:
            s = json.load(f)
        status, rows = s["status"], s["time"]["rows_written"]
    except (OSError, ValueError, KeyError, TypeError):
        return f"{outdir}/ is left as it was"
    if mtime < since:
        return f"{outdir}/ is left as it was"
    return f"{outdir}/ holds its {status} results ({rows} rows, as its summary.json says)"


def _run_parallel(models, dirs, report, overrides, analysis, plots, animate, jobs: int,
                  table_format: str | None = None, x_axis: str | None = None,
                  html: bool = False) -> None:
    """`planarkin run --jobs N` (dirs: one output directory per model, in order): the models in
    N local processes, each writing its own directory; the terminal lines in model order, the
    counts into report. Interrupted (SIGINT, SIGTERM to this process alone or to the whole
    group): the running models are told (a shared value their writers check between blocks of
    rows, and the models not started read first) and stop in order, every model's lines are
    printed and counted, and the interruption is raised again once every worker has ended. A
    worker that dies fails its model (exit 1), its line saying what its directory holds."""
    import signal
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures import TimeoutError as NoAnswer
    from concurrent.futures.process import BrokenProcessPool   # here: an import a plain run skips

    from .options import from_command_line
    from .output.directory import critical, signame
    from .processes import context, stop_workers
    ctx = context()
    since = time.time()
    tasks = [(m, d, report.quiet, overrides, analysis, plots, animate, table_format, x_axis,
              html) for m, d in zip(models, dirs)]

    def take(result) -> None:
        out, err, counts, stopped = result
        sys.stderr.write(err)
        sys.stdout.write(out)
        for k, v in counts.items():
            report.counts[k] += v
        if stopped is not None:
            report.signal = stopped

    def died(path, outdir) -> None:
        report.failed(path, f"its worker process died (killed by a signal, out of memory or a "
                            f"crash); {on_disk(outdir, since)}")

    stop = ctx.Value("i", 0, lock=False)
    pool = ProcessPoolExecutor(min(jobs, len(models)), mp_context=ctx,
                               initializer=_init_run,
                               initargs=(stop, from_command_line()))
    k, futures = 0, []
    try:
        with critical():        # a worker is started whole, or not at all
            futures = [pool.submit(_run_model, t) for t in tasks]
        for k, f in enumerate(futures):
            try:
                take(f.result())
            except BrokenProcessPool:
                died(models[k], dirs[k])
    except KeyboardInterrupt as e:
        with critical():                # a second signal is ignored anyway; this must finish
            stop.value = int(signal.SIGTERM if signame(e) == "SIGTERM" else signal.SIGINT)
            # nothing is cancelled here: a model not started returns at once (its worker reads
            # `stop` first), and a future cancelled here as the executor's thread failed it (a
            # broken pool) raised InvalidStateError in that thread: a traceback
            deadline = time.monotonic() + HUNG
            hung = []
            for f, path, outdir in zip(futures[k:], models[k:], dirs[k:]):
                try:
                    take(f.result(timeout=max(0.0, deadline - time.monotonic())))
                except BrokenProcessPool:
                    died(path, outdir)
                except NoAnswer:
                    if f.running():         # else never started: it has nothing to say
                        hung.append((path, outdir))
            if hung:
                stop_workers(pool)
                for path, outdir in hung:
                    report.failed(path, f"its worker did not stop within {HUNG:g} s of the "
                                        f"{signame(e)} and was killed; {on_disk(outdir, since)}")
        if report.signal is None:
            report.signal = signame(e)
        pool.shutdown()         # every worker ends before the command does
        raise
    pool.shutdown()
