"""Command line: parses options, calls the API, reports. No numerics here.

    planarkin run MODEL... [--out DIR] [--steps N] [--end T] [--tol X] [--no-plots] ...
    planarkin check MODEL...
    planarkin tradeoff MODEL [--out DIR]
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import click

from . import __version__
from .model.spec import TABLE_FORMATS, X_AXES, table_format_problem, x_axis_problem
from .options import OPTIONS
from .report import Report


def _tune_malloc() -> None:
    """Keep numpy's large temporaries on the heap (glibc only).

    glibc serves blocks above 128 KB with fresh mmap pages and returns them on free, so every
    chunk's temporaries page-fault again; on the VMs we measured a page fault costs ~2 us, and
    the grid pass of the slider-crank ran 1.4-1.6x slower for it (2.8 -> 1.7 us per step in
    process). A high mmap threshold (and no trimming) lets freed blocks be reused. This tunes
    only this process (and the writer processes it forks), never a library user's."""
    import ctypes
    import ctypes.util
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3
    mallopt(M_MMAP_THRESHOLD, 1 << 30)
    mallopt(M_TRIM_THRESHOLD, 1 << 30)



def _load(path: str, report: Report, overrides: dict | None = None):
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


def _parse_set(ctx, param, values) -> dict:
    """--set NAME=VALUE (repeatable) -> {NAME: VALUE text}; the validator evaluates VALUE."""
    out = {}
    for v in values:
        name, eq, value = v.partition("=")
        name = name.strip()
        if not eq or not name or not value.strip():
            raise click.BadParameter(f"'{v}': write NAME=VALUE, e.g. --set a=0.12")
        out[name] = value.strip()
    return out


def _set_option(f):
    return click.option("--set", "overrides", multiple=True, metavar="NAME=VALUE",
                        callback=_parse_set,
                        help="Override a parameter (repeatable); VALUE may be an expression of "
                             "the parameters before NAME.")(f)


class _Progress:
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


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="planarkin")
def main():
    """Kinematic analysis of planar mechanisms described in YAML files.

    Exit status: 0 ok, 1 analysis failure (results up to the failure are written), 2 invalid
    input or usage.
    """


class _OptionType(click.ParamType):
    """A command-line value checked by the rules of planarkin.options (the same rules and words
    as the YAML and the API)."""

    def __init__(self, opt):
        self.opt = opt
        self.name = {"int": "integer", "float": "number"}.get(opt.kind, opt.kind)

    def convert(self, value, param, ctx):
        if not isinstance(value, str):
            return value
        try:
            x = int(value) if self.opt.kind == "int" and value.strip().lstrip("+-").isdigit() \
                else float(value)
        except ValueError:
            self.fail(f"must be {self.opt.rule()}, not {value!r}", param, ctx)
        v, msg = self.opt.check(x)
        if msg is not None:
            self.fail(msg, param, ctx)
        return v


def _analysis_options(f):
    """One click option per analysis option of planarkin.options, in its order."""
    opts = []
    for o in OPTIONS.values():
        if o.kind == "bool":
            opts.append(click.option(f"{o.flag}/--no-{o.flag[2:]}", o.name, default=None,
                                     help=o.doc[0].upper() + o.doc[1:] + "."))
        elif o.kind == "choice":
            opts.append(click.option(o.flag, o.name, type=click.Choice(o.choices),
                                     help=o.doc[0].upper() + o.doc[1:] + "."))
        else:
            opts.append(click.option(o.flag, o.name, type=_OptionType(o),
                                     help=f"{o.doc[0].upper() + o.doc[1:]} ({o.rule()})."))
    for o in reversed(opts):
        f = o(f)
    return f


@main.command()
@click.argument("models", nargs=-1, required=True, type=click.Path())
@click.option("--out", "out", type=click.Path(file_okay=False), default="out", show_default=True,
              help="Output directory; each model writes DIR/<file stem>/.")
@_analysis_options
@click.option("--no-plots", is_flag=True, help="Skip the plots (matplotlib is not imported).")
@click.option("--format", "fmt", type=click.Choice(("png", "svg", "pdf")), default="png",
              show_default=True, help="Plot file format.")
@click.option("--animate", is_flag=True, help="Also write animation.gif.")
@click.option("--animate-fps", type=click.IntRange(1, 100),
              help="Frames per second of animation.gif (default 20; 80 frames at most). "
                   "Implies --animate.")
@click.option("--animate-width", type=click.IntRange(320, 4000),
              help="Width of animation.gif in pixels (default 640; the legend may widen it). "
                   "Implies --animate.")
@click.option("--x", "x_axis", type=click.Choice(X_AXES),
              help="Abscissa of bodies and points plots: time, or driver (the first driver's "
                   "coordinate, e.g. the crank angle). Default: output: x of the model, or time.")
@click.option("--table-format", "table_format", type=click.Choice(TABLE_FORMATS),
              help="File format of the tables: csv, or parquet (bodies.parquet ...; needs "
                   "pip install 'planarkin[parquet]'). Default: output: table_format of the "
                   "model, or csv.")
@click.option("--report", "report_what", type=click.Choice(("cycle",)),
              help="Also print the cycle figures of the coordinates that move and of the measures "
                   "(limit positions, stroke, time ratio).")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
@click.option("--jobs", "-j", type=click.IntRange(1, 1024), default=1, show_default=True,
              help="Models analysed at once in local processes.")
def run(models, out, no_plots, fmt, animate, animate_fps, animate_width, x_axis, quiet,
        overrides, jobs, report_what=None, table_format=None, **analysis):
    """Analyse MODELS: positions, velocities and accelerations over the time grid."""
    if table_format is not None:
        problem = table_format_problem(table_format, "--table-format")
        if problem:
            raise click.BadParameter(problem.partition(": ")[2] or problem,
                                     param_hint="'--table-format'")
    if animate_fps or animate_width:
        animate = {k: v for k, v in (("fps", animate_fps), ("width", animate_width)) if v}
    from .output.directory import (Interrupted, check_writable, held_signals, interruptible,
                                   out_dirs)
    if sys.platform.startswith("linux"):
        _tune_malloc()
    plotting = (not no_plots or animate) and not (jobs > 1 and len(models) > 1)
    from .output import plotworker
    if not plotting:                        # (stopped below, or at exit)
        plotworker.stop()                   # one started by __main__ on a guess
    report = Report(quiet)
    later = _Later(report)          # the model whose plots the server draws meanwhile
    with interruptible():
        try:
            problem = check_writable(Path(out))
            if problem is not None:
                raise click.BadParameter(problem, param_hint="'--out'")
            dirs = out_dirs(models, Path(out))
            if jobs > 1 and len(models) > 1:
                from .studies.execute import run_models
                run_models(models, dirs, report, overrides, analysis, None if no_plots else fmt,
                           animate, jobs, table_format)
                models = ()
            for k, (path, outdir) in enumerate(zip(models, dirs)):
                later.more = k + 1 < len(models)
                model = _load(path, later, overrides)
                if model is not None and plotting and not plotworker.running():
                    # not started by __main__ (no core was free): forked now, it inherits
                    # numpy and the modules a job needs, and only imports matplotlib (while
                    # the models solve), instead of repeating the imports of this process
                    from . import results  # noqa: F401
                    plotworker.start()
                if model is not None:
                    _run_one(path, model, outdir, later, dict(analysis),
                             None if no_plots else fmt, animate, x_axis,
                             cycle=report_what == "cycle", table_format=table_format)
            later.settle()
        except (KeyboardInterrupt, Interrupted) as e:
            try:
                later.settle()
            except (KeyboardInterrupt, Interrupted):
                pass                            # that model reported itself interrupted
            if report.signal is None:        # stopped before a model had its directory
                report.interrupted(None, _signame(e), "nothing more was written")
        finally:
            if plotting:
                with held_signals():
                    plotworker.stop()
    report.summary()
    if report.signal is not None:
        # every writer is joined and every directory in place: leave now, with the status the
        # shell expects, before interpreter shutdown could meet another signal
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(report.exit_code)
    sys.exit(report.exit_code)


class _Later:
    """The report of a batch, through which a model's plots are drawn while the next models
    solve: `_run_one` leaves the model's end (collecting its plots, summary.json, the
    directory put in place, its report line) here, and the ends happen in the models' order
    before anything more is printed, so that the lines keep that order; `settle()` ends them
    explicitly. At most `plotworker.capacity()` ends wait at a time (the plot jobs in flight:
    one per drawing process)."""

    def __init__(self, report: Report):
        self.report = report
        self.waiting: list = []     # the ends of the last models, callables, oldest first
        self.more = False           # models follow the current one (else: wait for its plots)

    def settle(self, keep: int = 0) -> None:
        """End the oldest waiting models until `keep` wait. Every one is ended even when one
        of them is interrupted (its directory is in place, interrupted); the first
        interruption is raised again once all are."""
        first = None
        while len(self.waiting) > keep:
            conclude = self.waiting.pop(0)
            try:
                conclude()
            except BaseException as e:  # noqa: BLE001 - raised below, after the others
                first = first or e
                keep = 0            # interrupted: the rest are ended too, not left in flight
        if first is not None:
            raise first

    def diagnostics(self, diags) -> None:
        if diags:                   # (called for every model, mostly with none)
            self.settle()
            self.report.diagnostics(diags)

    def __getattr__(self, name):
        try:
            self.settle()
        except BaseException as e:
            # interrupted while ending the models before: their lines are printed; this
            # one's (a model already in place) too, then the interruption goes on
            attr, stopped = getattr(self.report, name), e
            if not callable(attr):
                raise

            def then_raise(*args, **kwargs):
                attr(*args, **kwargs)
                raise stopped
            return then_raise
        return getattr(self.report, name)


def _signame(e: BaseException) -> str:
    return "SIGINT" if isinstance(e, KeyboardInterrupt) else "SIGTERM"


def _run_one(path, model, outdir: Path, report: Report, analysis: dict, plots, animate,
             x_axis=None, cycle=False, table_format=None):
    """One model: options, preparation, then the directory. Invalid input (options, budget,
    assembly, a busy or foreign directory) is reported before anything is written; an
    interruption keeps the complete rows (status interrupted) and is raised again to stop the
    batch."""
    from .diagnostics import Diagnostic, InputError
    from .options import resolve
    from .output.directory import Interrupted, OutputError, WriteError
    from .output.writer import DirectoryWriter
    from .results import prepare, stream
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
    except (KeyboardInterrupt, Interrupted):
        raise
    except Exception as e:  # noqa: BLE001 - a bug must not become a traceback for the user
        report.failed(path, f"internal error during the analysis: {type(e).__name__}: {e} "
                            f"(please report)")
        return
    try:
        writer = DirectoryWriter(model, outdir, opts, plots=plots, animate=animate,
                                 background=True, x=x_axis, table_format=table_format)
    except OutputError as e:
        report.invalid(path, [Diagnostic(path, None, str(e))])
        return
    progress = _Progress(opts.steps + 1, Path(path).name)
    later = isinstance(report, _Later)      # else (a --jobs worker): the plots drawn here
    try:
        info, _ = stream(an, sink=writer, progress=progress)
        progress.close()
        if later:                       # the models before: their plots drawn meanwhile
            from .output import plotworker      # (one left drawing when two drawers can)
            report.settle(keep=plotworker.capacity() - 1)
        report.diagnostics([d for d in info.diagnostics if d not in model.spec.warnings])
        for w in info.warnings:
            report.warning(path, w.message)
        # the line is printed as the directory is put in place (signals held meanwhile)
        writer.on_commit = lambda s: _conclude(path, outdir, report, info, s, cycle,
                                               time.perf_counter() - t0)
        writer.finish(info, started=t0, defer=later and report.more)
    except (WriteError, KeyboardInterrupt, Interrupted, Exception) as e:
        progress.close()
        _conclude_failed(e, path, outdir, writer, report, an, t0)
        return
    finally:
        progress.close()
    if writer.committed:
        return
    spent = time.perf_counter() - t0

    def conclude():
        c0 = time.perf_counter()
        writer.on_commit = lambda s: _conclude(path, outdir, report.report, info, s, cycle,
                                               spent + time.perf_counter() - c0)
        try:
            writer.complete()
        except (WriteError, KeyboardInterrupt, Interrupted, Exception) as e:
            _conclude_failed(e, path, outdir, writer, report.report, an, t0)
    report.waiting.append(conclude)


def _conclude_failed(e, path, outdir, writer, report, an, t0):
    """After an exception in a model's end: its directory left as it was (a write error, a
    bug) or in place with the complete rows (an interruption: raised again)."""
    from .output.directory import Interrupted, WriteError
    from .results import run_info
    if isinstance(e, WriteError):
        report.failed(path, f"{e}; {outdir}/ is left as it was")
        return
    if isinstance(e, (KeyboardInterrupt, Interrupted)) and writer.reported:
        raise e                         # in place and its line printed: the signal goes on
    if isinstance(e, (KeyboardInterrupt, Interrupted)):
        if not writer.committed:        # else: interrupted while plotting, already in place
            info = run_info(an)
            info.interrupted = _signame(e)
            writer.on_commit = None     # its line is the interrupted one below
            try:
                writer.finish(info, started=t0)
            except WriteError as w:
                report.interrupted(path, _signame(e), f"{w}; {outdir}/ is left as it was")
                raise e from None
        rows = writer.rows
        report.interrupted(path, _signame(e),
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


def _conclude(path, outdir, report, info, summary, cycle, seconds):
    """A model's report line (and its cycle figures), once its directory is in place (seconds:
    its own wall time, the next model's solve not counted)."""
    rows = summary["time"]["rows_written"]
    detail = (f"{rows} rows, {summary['solver']['internal_steps']} internal steps, max residual "
              f"{summary['residual']['max']:.1e}, {seconds:.2f} s -> {outdir}/")
    if info.status == 0:
        report.ok(path, detail)
    else:
        report.failed(path, info.message, detail)
    for w in summary.get("warnings", ()):
        if isinstance(w, dict) and w.get("kind") == "plots":     # the tables are written
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


@main.command()
@click.argument("models", nargs=-1, required=True, type=click.Path())
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@click.option("--derived", is_flag=True,
              help="Also print each model's body/joint form (YAML), as derived from a sketch.")
@_set_option
def check(models, quiet, derived, overrides):
    """Validate MODELS, assemble them and report degrees of freedom, redundancy and assembly
    modes, without running the analysis."""
    from .assembly import assemble
    from .budget import check_preflight
    from .diagnostics import InputError
    from .options import resolve
    report = Report(quiet)
    for path in models:
        model = _load(path, report, overrides)
        if model is None:
            continue
        try:
            check_preflight(model, resolve(model))    # what `run` would refuse before assembly
            A = assemble(model)
        except InputError as e:
            report.invalid(path, e.diagnostics)
            continue
        except Exception as e:  # noqa: BLE001 - never a traceback
            from .diagnostics import Diagnostic
            report.invalid(path, [Diagnostic(path, None, f"internal error while assembling: "
                                                         f"{type(e).__name__}: {e} (please "
                                                         f"report)")])
            continue
        report.diagnostics(A.warnings)
        if derived:
            from .model.sketch import derived_yaml
            click.echo(derived_yaml(model.spec), nl=False)
        ndrv = len(model.driver_rows)
        from .assembly import describe_modes
        words = describe_modes(model, A) if A.modes else []
        modes = "; ".join(f"{'+'.join(md.bodies)}: {'+' if md.sign > 0 else '-'}"
                          + (f" ({w})" if w else "") for md, w in zip(A.modes, words))
        detail = (f"{model.nb} bodies, {model.n} coordinates, {model.m_joint} joint equations, "
                  f"{ndrv} driver{'s' if ndrv != 1 else ''}; {A.dof} DOF"
                  f"{' (redundant: ' + ', '.join(model.row_label[r] for r in A.redundant_rows) + ')' if A.redundant_rows else ''}"
                  f"; assembled in {A.iterations} iterations, residual {A.residual * model.L:.1e} "
                  f"{model.spec.length_unit}"
                  + (f"; assembly branches {modes} (set assembly: {{branch: {{BODY: +|-}}}} to "
                     f"choose)" if modes else ""))
        report.ok(path, detail)
        if not quiet:
            from .measures.grashof import four_bar_loops
            for loop in four_bar_loops(model):
                click.echo(f"         {loop.describe(model.spec.length_unit)}")
    report.summary("checked")
    sys.exit(report.exit_code)


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--out", "out", type=click.Path(file_okay=False), default="out", show_default=True,
              help="Output directory; writes DIR/<file stem>/tradeoff.csv and tradeoff.png.")
@click.option("--steps", type=_OptionType(OPTIONS["steps"]),
              help="Grid intervals for every setting (default: the model's, at least 20000).")
@click.option("--repeats", type=click.IntRange(1, 100), default=3, show_default=True,
              help="Runs per setting; the best time counts.")
@click.option("--no-plots", is_flag=True, help="Skip tradeoff.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only the table.")
@_set_option
def tradeoff(model_path, out, steps, repeats, no_plots, quiet, overrides):
    """Run MODEL at a range of solver settings and measure wall time against the achieved
    errors in positions, velocities and accelerations (against a tight reference run)."""
    from .diagnostics import InputError
    from .tradeoff import run_tradeoff
    if sys.platform.startswith("linux"):
        _tune_malloc()
    report = Report(quiet)
    model = _load(model_path, report, overrides)
    if model is None:
        sys.exit(report.exit_code)
    from .options import resolve
    from .output.directory import out_dirs
    from .tradeoff import ReferenceFailed
    outdir = out_dirs([model_path], Path(out))[0]
    try:
        base = resolve(model, {"steps": steps}, source="cli")
        table = run_tradeoff(model, outdir, base, plot=not no_plots, repeats=repeats)
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
        sys.exit(report.exit_code)
    except ReferenceFailed as e:
        report.failed(model_path, str(e))
        sys.exit(report.exit_code)
    click.echo(table)
    report.ok(model_path, f"-> {outdir}/tradeoff.csv")
    sys.exit(report.exit_code)


@main.command()
@click.argument("new", type=click.Path())
@click.argument("golden", type=click.Path())
@click.option("--rtol", type=click.FloatRange(min=0), default=1e-9, show_default=True,
              help="Relative tolerance: |new - golden| <= atol + rtol |golden|.")
@click.option("--atol", type=click.FloatRange(min=0), default=1e-12, show_default=True,
              help="Absolute tolerance, in each column's unit.")
@click.option("--show", type=click.IntRange(0), default=10, show_default=True,
              help="How many of the worst differing columns to print.")
def compare(new, golden, rtol, atol, show):
    """Compare result directory NEW against GOLDEN column by column (every CSV table and
    summary.json's status). Exit status: 0 same within the tolerances, 1 differs, 2 unusable
    input (missing directory or table, malformed CSV, different columns or rows)."""
    from .studies.compare import UNUSABLE, compare_dirs, report
    c = compare_dirs(new, golden, rtol=rtol, atol=atol)
    for line in report(c, rtol, atol, show):
        click.echo(line, err=c.status == UNUSABLE)
    sys.exit(c.status)


def _ranges(texts, need_count: bool):
    from .studies.sweep import parse_range
    out = []
    for t in texts:
        try:
            out.append(parse_range(t, need_count))
        except ValueError as e:
            raise click.BadParameter(str(e), param_hint="'--vary'") from None
    names = [r.name for r in out]
    if len(set(names)) != len(names):
        raise click.BadParameter("each parameter may be varied once", param_hint="'--vary'")
    return out


def _jobs_option(f):
    f = click.option("--scheduler", metavar="tcp://HOST:8786",
                     help="Run the variants on this Dask distributed scheduler "
                          "(pip install 'planarkin[dask]').")(f)
    return click.option("--jobs", "-j", type=click.IntRange(1, 1024),
                        help="Local processes (default: the number of cores).")(f)


def _study(model_path, report, overrides, analysis, metrics, varied):
    """The Study of a model for sweep and tolerance; None (reported) when invalid."""
    from .diagnostics import Diagnostic, InputError
    from .studies.variants import Study
    try:
        study = Study(model_path, overrides, analysis, metrics)
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
        return None
    unknown = [v for v in varied if v not in study.parameters]
    if unknown:
        from .diagnostics import did_you_mean
        report.invalid(model_path, [Diagnostic(model_path, None, f"unknown parameter '{u}'"
                                               f"{did_you_mean(u, study.parameters)}")
                                    for u in unknown])
        return None
    return study


def _study_options(unit: str, writes: str, plot: str):
    """The options sweep and tolerance share: output, grid (checked by planarkin.options), plots,
    quiet, --set and the executor."""
    def deco(f):
        opts = [
            click.option("--out", "out", type=click.Path(file_okay=False), default="out",
                         show_default=True, help=f"Writes DIR/<file stem>/{writes}."),
            click.option("--steps", type=_OptionType(OPTIONS["steps"]),
                         help=f"Grid intervals of every {unit}."),
            click.option("--end", type=_OptionType(OPTIONS["end"]), help="End time, s."),
            click.option("--no-plots", is_flag=True, help=f"Skip {plot}."),
            click.option("--format", "fmt", type=click.Choice(("png", "svg", "pdf")),
                         default="png", show_default=True, help="Plot file format."),
            click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line."),
            _set_option, _jobs_option]
        for o in reversed(opts):
            f = o(f)
        return f
    return deco


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--vary", "vary", multiple=True, required=True, metavar="NAME=LO:HI:N",
              help="A parameter's range: N values from LO to HI (repeatable: full factorial); "
                   "with --samples, NAME=LO:HI.")
@click.option("--samples", type=click.IntRange(1, 10**7),
              help="Sample the ranges by a Latin hypercube of this many variants.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True,
              help="Seed of the Latin hypercube.")
@click.option("--metric", "metrics", multiple=True, metavar="KIND:COLUMN",
              help="max, min, stroke or absmax of a column of bodies.csv, points.csv or a "
                   "derived table, e.g. max:slider.ax, or dev:POINT, the largest distance of a "
                   "point's path from nominal (repeatable).")
@_study_options("variant", "sweep.csv (+ .parquet, + plot)", "sweep.png")
def sweep(model_path, vary, samples, seed, metrics, out, steps, end, no_plots, fmt, quiet,
          overrides, jobs, scheduler):
    """Run variants of MODEL over parameter ranges; one row per variant in sweep.csv with the
    parameters, the status (ok, failed with the kind and time, invalid with the reason) and the
    metrics."""
    from .studies.sweep import run_sweep
    if sys.platform.startswith("linux"):
        _tune_malloc()
    report = Report(quiet)
    ranges = _ranges(vary, need_count=samples is None)
    study = _study(model_path, report, overrides, {"steps": steps, "end": end}, metrics,
                   [r.name for r in ranges])
    if study is None:
        sys.exit(report.exit_code)
    outdir = Path(out) / Path(model_path).stem
    t0 = time.perf_counter()
    from .studies.execute import executor
    res = run_sweep(study, ranges, outdir, samples=samples, seed=seed,
                    plots=None if no_plots else fmt, execute=executor(jobs, scheduler))
    c = res.counts()
    report.ok(model_path, f"{len(res.variants)} variants: {c['ok']} ok, {c['failed']} failed, "
                          f"{c['invalid']} invalid, {time.perf_counter() - t0:.2f} s -> "
                          f"{outdir}/sweep.csv")
    sys.exit(report.exit_code)


def _sigmas(texts) -> dict:
    out = {}
    for t in texts:
        name, eq, value = t.partition("=")
        name = name.strip()
        try:
            v = float(value)
        except ValueError:
            v = None
        if not eq or not name or v is None or not (v >= 0 and v < float("inf")):
            raise click.BadParameter(f"'{t}': write NAME=SIGMA with SIGMA a number >= 0, e.g. "
                                     f"a=0.05e-3", param_hint="'--sigma'")
        if name in out:
            raise click.BadParameter(f"'{name}' is given twice", param_hint="'--sigma'")
        out[name] = v
    return out


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--sigma", "sigma", multiple=True, required=True, metavar="NAME=SIGMA",
              help="Standard deviation of a parameter, in its unit (repeatable).")
@click.option("--samples", type=click.IntRange(2, 10**7), default=1000, show_default=True,
              help="Monte-Carlo samples.")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True,
              help="Seed of the random draws (the same seed gives the same results bit for bit).")
@click.option("--dist", type=click.Choice(("normal", "uniform")), default="normal",
              show_default=True,
              help="Deviations: normal, or uniform with the same standard deviation.")
@click.option("--metric", "metrics", multiple=True, metavar="KIND:COLUMN",
              help="Outputs: max, min, stroke, absmax of a column (as for sweep) or dev:POINT, the "
                   "largest distance of a point's path from nominal (default: dev of every point).")
@_study_options("sample", "tolerance.csv, samples.csv, sensitivities.csv", "tolerance.png")
def tolerance(model_path, sigma, samples, seed, dist, metrics, out, steps, end, no_plots, fmt,
              quiet, overrides, jobs, scheduler):
    """Monte-Carlo tolerance analysis of MODEL: the distribution of the outputs under random
    deviations of the parameters, and their exact first-order sensitivities."""
    from .diagnostics import InputError
    from .studies.tolerance import run_tolerance, summary_lines
    if sys.platform.startswith("linux"):
        _tune_malloc()
    report = Report(quiet)
    sig = _sigmas(sigma)
    if not metrics:
        from .model.yamlread import read_file
        try:
            pts = read_file(model_path).value.get("points")
            metrics = tuple(f"dev:{p}" for p in (pts.value if pts is not None and
                                                 pts.kind == "map" else ()))
        except Exception:  # noqa: BLE001 - the Study below reports the file's problems
            metrics = ()
    study = _study(model_path, report, overrides, {"steps": steps, "end": end}, metrics,
                   list(sig))
    if study is None:
        sys.exit(report.exit_code)
    outdir = Path(out) / Path(model_path).stem
    t0 = time.perf_counter()
    try:
        from .studies.execute import executor
        res = run_tolerance(study, sig, outdir, samples, seed=seed, dist=dist,
                            plots=None if no_plots else fmt, execute=executor(jobs, scheduler))
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
        sys.exit(report.exit_code)
    if not quiet:
        for line in summary_lines(res, study):
            click.echo(line)
    failed = sum(1 for o in res.outcomes if o.status != "ok")
    report.ok(model_path, f"{samples} samples, {failed} failed, {time.perf_counter() - t0:.2f} s "
                          f"-> {outdir}/tolerance.csv")
    sys.exit(report.exit_code)


# -- synthesis and identification (planarkin.synthesis) ----------------------------------------
def _synthesis_errors(model_path, report, call):
    """Run call(); InputError and OutputError are reported (exit 2), None returned."""
    from .diagnostics import Diagnostic, InputError
    from .output.directory import OutputError
    try:
        return call()
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
    except OutputError as e:
        report.invalid(model_path, [Diagnostic(model_path, None, str(e))])
    return None


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--out", "out", type=click.Path(file_okay=False), default="out",
              show_default=True, help="Writes DIR/<file stem>/ (designs, residuals, plot).")
@click.option("--starts", type=click.IntRange(1, 100_000),
              help="Latin-hypercube starts (default: design: search: starts).")
@click.option("--local", type=click.IntRange(1, 10_000), help="Local least-squares runs.")
@click.option("--keep", type=click.IntRange(1, 1000), help="Distinct designs kept.")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), help="Seed of the starts.")
@click.option("--goal", type=click.FloatRange(0), help="Sum of squares a design must reach.")
@click.option("--steps", type=_OptionType(OPTIONS["steps"]), help="Grid intervals per design.")
@click.option("--no-plots", is_flag=True, help="Skip synth.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
def synth(model_path, out, starts, local, keep, seed, goal, steps, no_plots, quiet, overrides):
    """Find the free parameters of MODEL's design: block that meet its targets (path, function
    or motion generation) under its constraints. Writes the best designs as ready-to-run models.
    Exit status: 0 designs found, 1 none acceptable, 2 invalid input."""
    from .synthesis.output import write_synth
    from .synthesis.synth import synthesize
    report = Report(quiet)
    res = _synthesis_errors(model_path, report, lambda: synthesize(
        model_path, overrides, {"steps": steps}, starts=starts, local=local, keep=keep,
        seed=seed, goal=goal))
    if res is None:
        sys.exit(report.exit_code)
    outdir = Path(out) / Path(model_path).stem
    if _synthesis_errors(model_path, report, lambda: write_synth(
            res, outdir, None if no_plots else "png")) is None:
        sys.exit(report.exit_code)
    detail = (f"{res.message}; {res.evaluations} evaluations, {res.jacobians} Jacobians, "
              f"{res.seconds:.2f} s -> {outdir}/")
    if res.status == 0:
        report.ok(model_path, detail)
    else:
        report.failed(model_path, res.message, detail)
    sys.exit(report.exit_code)


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--data", "data", required=True, type=click.Path(),
              help="CSV of tracked points: t [s], POINT.x [UNIT], POINT.y [UNIT], ...")
@click.option("--free", "free", multiple=True, metavar="NAME",
              help="A parameter to estimate (repeatable; default: design: free).")
@click.option("--out", "out", type=click.Path(file_okay=False), default="out",
              show_default=True, help="Writes DIR/<file stem>/ (estimates, residuals, plot).")
@click.option("--steps", type=_OptionType(OPTIONS["steps"]), help="Grid intervals.")
@click.option("--no-plots", is_flag=True, help="Skip fit.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
def fit(model_path, data, free, out, steps, no_plots, quiet, overrides):
    """Estimate parameters of MODEL from measured point trajectories (Levenberg-Marquardt with
    exact sensitivities): estimates, standard errors, correlations, residuals.
    Exit status: 0 fitted, 1 not identifiable or failed, 2 invalid input."""
    from .synthesis.fit import fit as run_fit
    from .synthesis.output import write_fit
    report = Report(quiet)
    res = _synthesis_errors(model_path, report, lambda: run_fit(
        model_path, data, list(free) or None, overrides, {"steps": steps}))
    if res is None:
        sys.exit(report.exit_code)
    outdir = Path(out) / Path(model_path).stem
    if _synthesis_errors(model_path, report, lambda: write_fit(
            res, outdir, None if no_plots else "png")) is None:
        sys.exit(report.exit_code)
    if not quiet:
        for i, n in enumerate(res.names):
            click.echo(f"  {n} = {res.estimate[i]:.10g} +- {res.se[i]:.3g}")
    detail = (f"{res.message}; {res.evaluations} evaluations, {res.jacobians} Jacobians, "
              f"{res.seconds:.2f} s -> {outdir}/")
    if res.status == 0:
        report.ok(model_path, detail)
    else:
        report.failed(model_path, res.message, detail)
    sys.exit(report.exit_code)
