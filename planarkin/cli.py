"""Command line: parses options, calls the API, reports. No numerics here.

    planarkin run MODEL... [--out DIR] [--steps N] [--end T] [--tol X] [--no-plots] ...
    planarkin check MODEL...
    planarkin tradeoff MODEL [--out DIR]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import click

from .version import __version__
from .model.spec import TABLE_FORMATS, X_AXES, table_format_problem
from .options import OPTIONS
from .report import Report
from .run import load_model as _load


def _parse_set(ctx, param, values) -> dict:
    """--set NAME=VALUE (repeatable) -> {NAME: VALUE text}; the validator evaluates VALUE."""
    out = {}
    for v in values:
        name, eq, value = v.partition("=")
        name = name.strip()
        if not eq or not name or not value.strip():
            raise click.BadParameter(f"'{v}': write NAME=VALUE, e.g. --set a=0.12")
        if name in out:         # the last one silently won
            raise click.BadParameter(f"'{name}' is set twice ({name}={out[name]} and "
                                     f"{name}={value.strip()}): give each parameter once")
        out[name] = value.strip()
    return out


def _set_option(f):
    return click.option("--set", "overrides", multiple=True, metavar="NAME=VALUE",
                        callback=_parse_set,
                        help="Override a parameter (repeatable); VALUE may be an expression of "
                             "the parameters before NAME.")(f)


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


def _junit_option(cases: str):
    return click.option("--junit", "junit", type=click.Path(), metavar="FILE",
                        help=f"Also write a JUnit XML report for CI: one test case per {cases}. "
                             f"Written whole or not at all.")


def _check_junit(junit) -> None:
    """A --junit FILE that cannot be written (a folder, under a file, no permission): one line
    naming the fix, exit 2, before anything runs."""
    if junit is None:
        return
    from .output.junit import problem
    why = problem(junit)
    if why is not None:
        click.echo(f"error: --junit {junit}: {why}", err=True)
        sys.exit(2)


def _write_junit(junit, suite: str, entries, seconds: float, code: int) -> int:
    """Write the JUnit report of entries at junit (if given); the exit status: code, or 1 when
    the report could not be written (one line; the file is left as it was)."""
    if junit is None:
        return code
    from .output.junit import write
    from .report import junit_cases
    try:
        write(junit, suite, junit_cases(entries, suite.replace(" ", ".")), seconds)
    except OSError as e:
        click.echo(f"error: --junit {junit}: cannot write: {e.strerror or e}; {junit} is left "
                   f"as it was", err=True)
        return max(code, 1)
    return code


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
@click.option("--report", "report_what", multiple=True, metavar="cycle|html",
              callback=lambda ctx, param, values: _parse_report(values),
              help="cycle: also print the cycle figures of the coordinates that move and of the "
                   "measures (limit positions, stroke, time ratio); html: also write "
                   "report.html per model (one self-contained page: summary, figures, the "
                   "mechanism moving) and DIR/index.html linking them. Repeatable, or a comma "
                   "list: --report cycle,html.")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
@click.option("--jobs", "-j", type=click.IntRange(1, 1024), default=1, show_default=True,
              help="Models analysed at once in local processes.")
@_junit_option("model: failure for a failed analysis, error for invalid input or an "
               "interruption, skipped for a model not reached")
def run(models, out, no_plots, fmt, animate, animate_fps, animate_width, x_axis, quiet,
        overrides, jobs, junit=None, report_what=None, table_format=None, **analysis):
    """Analyse MODELS: positions, velocities and accelerations over the time grid."""
    if table_format is not None:
        problem = table_format_problem(table_format, "--table-format")
        if problem:
            raise click.BadParameter(problem.partition(": ")[2] or problem,
                                     param_hint="'--table-format'")
    if animate_fps or animate_width:
        animate = {k: v for k, v in (("fps", animate_fps), ("width", animate_width)) if v}
    from .output.directory import out_dirs
    from .run import run_models
    _check_out(out)
    _check_junit(junit)
    report = Report(quiet)
    index = run_models(models, out_dirs(models, Path(out)), report, overrides, analysis,
                       None if no_plots else fmt, animate, x_axis, cycle="cycle" in report_what,
                       table_format=table_format, jobs=jobs, html="html" in report_what)
    report.summary()
    sys.exit(_write_junit(junit, "planarkin run", report.model_entries(models),
                          time.perf_counter() - report.started, max(report.exit_code, index)))


def _parse_report(values) -> tuple:
    """--report (repeatable, or a comma list) -> the reports asked for, each once."""
    out = []
    for v in values:
        for word in v.split(","):
            word = word.strip()
            if word not in ("cycle", "html"):
                raise click.BadParameter(f"{word!r} is not one of 'cycle', 'html' (repeat the "
                                         f"option or give a comma list: --report cycle,html)",
                                         param_hint="'--report'")
            if word not in out:
                out.append(word)
    return tuple(out)


@main.command()
@click.argument("models", nargs=-1, required=True, type=click.Path())
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@click.option("--derived", is_flag=True,
              help="Also print each model's body/joint form (YAML), as derived from a sketch.")
@_set_option
def check(models, quiet, derived, overrides):
    """Validate MODELS, assemble them and report degrees of freedom, redundancy and assembly
    modes, without running the analysis."""
    from .analysis import assemble_checked
    from .diagnostics import InputError
    from .options import resolve
    report = Report(quiet)
    for path in models:
        model = _load(path, report, overrides)
        if model is None:
            continue
        try:
            opts = resolve(model)
            A = assemble_checked(model, opts)         # what `run` would refuse, as `run` does
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
        if model.shapes:
            from .clearance.check import overlaps
            report.diagnostics(overlaps(model, A.q))
        if derived:
            from .model.sketch import derived_yaml
            click.echo(derived_yaml(model.spec), nl=False)
        ndrv = len(model.driver_rows)
        from planarkin.solver.branches import describe_modes
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
            from .measures.grashof import four_bar_loops, slider_crank_loops
            for loop in four_bar_loops(model):
                click.echo(f"         {loop.describe(model.spec.length_unit)}")
            for sc in slider_crank_loops(model):
                click.echo(f"         {sc.describe(A.q, model.L, model.spec.length_unit)}")
            for line in _driver_ranges(model):
                click.echo(f"         {line}")
    report.summary("checked")
    sys.exit(report.exit_code)


def _driver_ranges(model, samples: int = 8192) -> list[str]:
    """Each driver's range over the analysis and how often its motion reverses (its exact f'
    changes sign), so that a motion far from what was meant shows at check (a pedal written
    cos(360*t) in a file in degrees: radians, 57 swings a second)."""
    import numpy as np

    from .elements import KINDS
    spec = model.spec
    a = spec.analysis
    t = np.linspace(a.start, a.end, samples + 1)
    out = []
    for el in spec.drivers:
        if el.f is None:
            continue
        with np.errstate(all="ignore"):
            f, f1, _ = (np.asarray(x, dtype=float) for x in el.f.derivatives(t))
        if not (np.isfinite(f).all() and np.isfinite(f1).all()):
            continue            # the run says where (a driver not defined at a grid row)
        unit = {"length": spec.length_unit, "angle": spec.angle_unit}.get(
            KINDS[el.kind].target_unit, "")
        sign = np.sign(f1[np.abs(f1) > 1e-12 * max(np.abs(f1).max(), 1e-300)])
        turns = int((sign[1:] != sign[:-1]).sum())
        out.append(f"{el.label}: f from {f.min():.6g} to {f.max():.6g}{' ' + unit if unit else ''}"
                   f" over t = {a.start:g} to {a.end:g} s, {turns} reversal"
                   f"{'' if turns == 1 else 's'} of its motion")
    return out


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
              help="How many of the worst differing columns to print (two roots: in each "
                   "model's --junit failure; the terminal has a line per model).")
@_junit_option("model directory: failure for a difference or a model missing on one side, "
               "error for unusable input")
def compare(new, golden, rtol, atol, show, junit):
    """Compare result directory NEW against GOLDEN column by column (every CSV or Parquet
    table, either format against the other, and summary.json's status). Exit status: 0 same
    within the tolerances, 1 differs, 2 unusable input (missing directory or table, malformed
    CSV, different columns or rows).

    NEW and GOLDEN may also be two roots of result directories (`run MODEL... --out ROOT`):
    each model directory on either side is compared, one line each (same, differs with its
    worst column, missing on one side, unusable), then a summary line; the exit status is the
    worst: 0 all same, 1 a model differs or is missing on one side, 2 unusable input."""
    from .studies.compare import UNUSABLE, Unusable, compare_dirs, report, root_models
    _check_junit(junit)
    t0 = time.perf_counter()
    try:
        names = root_models(new, golden)
    except Unusable as e:
        click.echo(f"error: cannot compare: {e}", err=True)
        sys.exit(_write_junit(junit, "planarkin compare", [_compare_entry(
            new, "unusable", str(e), f"error: cannot compare: {e}", t0)],
                              time.perf_counter() - t0, 2))
    if names is not None:
        sys.exit(_compare_roots(new, golden, names, rtol, atol, show, junit))
    c = compare_dirs(new, golden, rtol=rtol, atol=atol)
    lines = report(c, rtol, atol, show)
    for line in lines:
        click.echo(line, err=c.status == UNUSABLE)
    outcome = ("same", "differs", "unusable")[c.status]
    message = ("" if c.status == 0 else c.error if c.status == UNUSABLE else
               lines[0].removeprefix("differs: ")
               + "".join(f"; worst: {d.format()}" for d in c.differences[:1]))
    entry = _compare_entry(new, outcome, message, "\n".join(lines), t0)
    sys.exit(_write_junit(junit, "planarkin compare", [entry], time.perf_counter() - t0,
                          c.status))


def _compare_entry(new, outcome: str, message: str, text: str, t0: float):
    """The JUnit entry of a comparison of two model directories (named by NEW's folder)."""
    from .report import Entry
    return Entry(Path(new).name or str(new), outcome, message, text, time.perf_counter() - t0)


def _compare_roots(new, golden, names, rtol, atol, show, junit) -> int:
    """`compare` on two roots of result directories: a line per model, the summary line; the
    exit status."""
    from .report import CompareReport
    from .studies.compare import compare_roots
    rep = CompareReport()
    for m in compare_roots(new, golden, names, rtol, atol, show):
        rep.add(m.name, m.outcome, m.line, m.text, m.seconds)
    rep.summary()
    return _write_junit(junit, "planarkin compare", rep.entries,
                        time.perf_counter() - rep.started, rep.exit_code)


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


def _check_scheduler(scheduler) -> None:
    """A --scheduler this command cannot use: malformed (no Dask needed), Dask missing, or TLS
    without Dask's TLS settings: one line, exit 2, before anything else."""
    if scheduler is None:
        return
    from .studies.execute import dask_problem, scheduler_problem
    problem = scheduler_problem(scheduler) or dask_problem(scheduler)
    if problem:
        click.echo(f"error: --scheduler: {problem}", err=True)
        sys.exit(2)


def _check_out(out) -> None:
    """An --out that cannot hold result directories (a file, a link to nowhere, no permission):
    one line naming the fix, exit 2, before anything is read; exit 1 when the disk itself
    fails (full)."""
    from .output.directory import WriteError, check_writable
    try:
        problem = check_writable(Path(out))
    except WriteError as e:
        click.echo(f"error: --out {out}: {e}", err=True)
        sys.exit(1)
    if problem is not None:
        click.echo(f"error: --out {out}: {problem}", err=True)
        sys.exit(2)


def _run_study(model_path, report: Report, outdir: Path, work):
    """work() (a study's runs and its files) under the interruption contract; returns its
    result, or reports and exits: interrupted 130/143 (the study's files are the earlier run's
    or this one's, never a mix, and no temporary is left), 1 for units lost with a worker or
    the cluster (the variants solved are written), an unusable scheduler or a full disk (the
    earlier files are left), 2 for a directory being written by another run or one that
    cannot be."""
    from .diagnostics import Diagnostic, InputError
    from .output.directory import OutputError, WriteError, interruptible, signame
    from .studies.execute import StudyIncomplete
    with interruptible():
        try:
            return work()
        except KeyboardInterrupt as e:
            report.interrupted(model_path, signame(e), f"the study's files in {outdir}/ are "
                                                       f"the earlier run's or this one's")
        except (StudyIncomplete, WriteError) as e:
            report.failed(model_path, str(e))
        except OutputError as e:
            report.invalid(model_path, [Diagnostic(model_path, None, str(e))])
        except InputError as e:         # the study's size (planarkin.studies.budget.check_study)
            report.invalid(model_path, e.diagnostics)
    sys.exit(report.exit_code)


def _study_dir(out, model_path) -> Path:
    """The model's directory, named as `planarkin run` names it (output.directory.out_dirs)."""
    from .output.directory import out_dirs
    return out_dirs([model_path], Path(out))[0]


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
    _check_scheduler(scheduler)
    report = Report(quiet)
    ranges = _ranges(vary, need_count=samples is None)
    _check_out(out)
    study = _study(model_path, report, overrides, {"steps": steps, "end": end}, metrics,
                   [r.name for r in ranges])
    if study is None:
        sys.exit(report.exit_code)
    outdir = _study_dir(out, model_path)
    t0 = time.perf_counter()
    from .studies.execute import executor
    res = _run_study(model_path, report, outdir, lambda: run_sweep(
        study, ranges, outdir, samples=samples, seed=seed, plots=None if no_plots else fmt,
        execute=executor(jobs, scheduler)))
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
    _check_scheduler(scheduler)
    report = Report(quiet)
    sig = _sigmas(sigma)
    _check_out(out)
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
    outdir = _study_dir(out, model_path)
    t0 = time.perf_counter()
    try:
        from .studies.execute import executor
        res = _run_study(model_path, report, outdir, lambda: run_tolerance(
            study, sig, outdir, samples, seed=seed, dist=dist, plots=None if no_plots else fmt,
            execute=executor(jobs, scheduler)))
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
def _synthesis_errors(model_path, report, call, outdir=None, plots=None, progress=None):
    """Run call() (a search, or the writing of its results) and return its result; or report
    what stopped it and return None: invalid input or a busy or foreign directory (exit 2), a
    file that could not be written, a full disk (exit 1, the directory left as it was), an
    interruption (130/143; a search's designs verified so far are written, marked
    interrupted, and the report line says what is on disk). progress: its line is cleared
    before anything is reported."""
    from .diagnostics import Diagnostic, InputError
    from .output.directory import OutputError, WriteError, signame
    from .synthesis.output import interrupted
    try:
        try:
            return call()
        finally:
            if progress is not None:
                progress.close()
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
    except OutputError as e:
        report.invalid(model_path, [Diagnostic(model_path, None, str(e))])
    except WriteError as e:
        report.failed(model_path, f"{e}; {outdir}/ is left as it was")
    except KeyboardInterrupt as e:
        report.interrupted(model_path, signame(e), interrupted(e, outdir, plots))
    return None


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--out", "out", type=click.Path(file_okay=False), default="out",
              show_default=True, help="Writes DIR/<file stem>.synth/ (designs, residuals, "
                                      "plot; beside run's DIR/<file stem>/, never in it).")
@click.option("--starts", type=click.IntRange(1, 100_000),
              help="Latin-hypercube starts (default: design: search: starts).")
@click.option("--local", type=click.IntRange(1, 10_000), help="Local least-squares runs.")
@click.option("--keep", type=click.IntRange(1, 1000), help="Distinct designs kept.")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), help="Seed of the starts.")
@click.option("--goal", type=click.FloatRange(0), help="Sum of squares a design must reach.")
@click.option("--time", "seconds", type=click.FloatRange(0, 1e7, min_open=True),
              help="Time budget (s): the best designs when it runs out.")
@click.option("--steps", type=_OptionType(OPTIONS["steps"]), help="Grid intervals per design.")
@click.option("--jobs", "-j", type=click.IntRange(1, 1024), default=1, show_default=True,
              help="Processes for the local runs (the same designs as with 1).")
@click.option("--no-plots", is_flag=True, help="Skip synth.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
def synth(model_path, out, starts, local, keep, seed, goal, seconds, steps, jobs, no_plots,
          quiet, overrides):
    """Find the free parameters of MODEL's design: block that meet its targets (path, function
    or motion generation) under its constraints. Writes the best designs as ready-to-run models.
    Exit status: 0 designs found, 1 none acceptable, 2 invalid input."""
    from .output.directory import interruptible
    from .synthesis.output import write_synth
    from .synthesis.progress import SearchProgress
    from .synthesis.synth import synthesize
    report = Report(quiet)
    outdir = _search_dir(model_path, out, "synth")
    plots = None if no_plots else "png"
    progress = SearchProgress("synth", quiet)
    with interruptible():       # a signal stops the search in order (what is kept: said)
        res = _synthesis_errors(model_path, report, lambda: synthesize(
            model_path, overrides, {"steps": steps}, progress=progress, jobs=jobs, starts=starts,
            local=local, keep=keep, seed=seed, goal=goal, time=seconds), outdir, plots, progress)
        if res is None:
            sys.exit(report.exit_code)
        if _synthesis_errors(model_path, report, lambda: write_synth(res, outdir, plots),
                             outdir, plots) is None:
            sys.exit(report.exit_code)
    _conclude_search(model_path, report, res, outdir)


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--data", "data", required=True, type=click.Path(),
              help="CSV of tracked points: t [s], POINT.x [UNIT], POINT.y [UNIT], ...")
@click.option("--free", "free", multiple=True, metavar="NAME",
              help="A parameter to estimate (repeatable; default: design: free).")
@click.option("--out", "out", type=click.Path(file_okay=False), default="out",
              show_default=True, help="Writes DIR/<file stem>.fit/ (estimates, residuals, "
                                      "plot; beside run's DIR/<file stem>/, never in it).")
@click.option("--steps", type=_OptionType(OPTIONS["steps"]), help="Grid intervals.")
@click.option("--no-plots", is_flag=True, help="Skip fit.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
@_set_option
def fit(model_path, data, free, out, steps, no_plots, quiet, overrides):
    """Estimate parameters of MODEL from measured point trajectories (Levenberg-Marquardt with
    exact sensitivities): estimates, standard errors, correlations, residuals.
    Exit status: 0 fitted, 1 not identifiable or failed, 2 invalid input."""
    twice = sorted({n for n in free if free.count(n) > 1})
    if twice:
        raise click.BadParameter(f"{', '.join(repr(n) for n in twice)} given twice: name "
                                 f"each parameter once", param_hint="'--free'")
    from .output.directory import interruptible
    from .synthesis.fit import fit as run_fit
    from .synthesis.output import write_fit
    from .synthesis.progress import SearchProgress
    report = Report(quiet)
    outdir = _search_dir(model_path, out, "fit")
    plots = None if no_plots else "png"
    progress = SearchProgress("fit", quiet)
    with interruptible():       # a signal stops the fit in order (nothing half written)
        res = _synthesis_errors(model_path, report, lambda: run_fit(
            model_path, data, list(free) or None, overrides, {"steps": steps},
            progress=progress), outdir, plots, progress)
        if res is None:
            sys.exit(report.exit_code)
        if _synthesis_errors(model_path, report, lambda: write_fit(res, outdir, plots),
                             outdir, plots) is None:
            sys.exit(report.exit_code)
    if not quiet:
        for i, n in enumerate(res.names):
            click.echo(f"  {n} = {res.estimate[i]:.10g} +- {res.se[i]:.3g}")
    _conclude_search(model_path, report, res, outdir)


def _search_dir(model_path, out, command: str) -> Path:
    """synth's and fit's result directory: run's name for the model (output.directory.out_dirs)
    with .synth or .fit after it, so that a run's directory in the same --out and theirs never
    replace each other's files."""
    from .output.directory import out_dirs
    d = out_dirs([model_path], Path(out))[0]
    return d.with_name(f"{d.name}.{command}")


def _conclude_search(model_path, report: Report, res, outdir: Path):
    """The summary line and exit status of synth and fit: 0 found, 1 none acceptable."""
    detail = (f"{res.message}; {res.evaluations} evaluations, {res.jacobians} Jacobians, "
              f"{res.seconds:.2f} s -> {outdir}/")
    if res.status == 0:
        report.ok(model_path, detail)
    else:
        report.failed(model_path, res.message, detail)
    sys.exit(report.exit_code)


@main.command("export")
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--dxf", is_flag=True, help="Write DXF (R2000, mm: LINE, CIRCLE, LWPOLYLINE, TEXT).")
@click.option("--svg", is_flag=True, help="Write SVG (sized in millimetres).")
@click.option("--out", type=click.Path(file_okay=False), default="out", show_default=True,
              help="Writes DIR/<file stem>.drawings/.")
@click.option("--width", type=float, help="Plate width around the pins, mm (default 12).")
@click.option("--pin", type=float, help="Pin diameter, mm (default 6).")
@click.option("--clearance", type=float, help="Added to the pin for the holes, mm (default 0.1).")
@click.option("--thickness", type=float, help="Plate thickness, noted on parts, mm (default 5).")
@click.option("--tolerance", type=float, help="Cam profiles' chordal tolerance, mm (default 0.01).")
@click.option("--module", type=float, help="Gear module, mm: outside circles (default: none).")
@click.option("--pose", type=float, metavar="TIME", help="Turn the layout's parts as at TIME (s).")
@click.option("--body", multiple=True, metavar="NAME", help="Draw this body (repeatable).")
@_set_option
def export_drawings(model_path, overrides, **options):
    """Fabrication drawings of MODEL's parts at true size: plates with pin holes, cam profiles
    (arcs within the tolerance), gear blanks, and a layout sheet. Exit status: 0 written,
    1 the pose or a file failed, 2 invalid input."""
    from .export.command import export
    sys.exit(export(model_path, overrides=overrides, **options))
