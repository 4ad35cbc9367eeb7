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

from . import __version__
from .model.spec import X_AXES, x_axis_problem
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

NEWTON = ("reuse", "full", "fixed")
BIFURCATION = ("stop", "continue")
ORDERS = {"position": 0, "velocity": 1, "acceleration": 2}


def _load(path: str, report: Report):
    """Read, validate, compile; report diagnostics. Returns the model or None."""
    from .diagnostics import Diagnostic, InputError
    from . import load
    try:
        return load(path)
    except InputError as e:
        report.invalid(path, e.diagnostics)
    except (RecursionError, MemoryError) as e:
        report.invalid(path, [Diagnostic(path, 1, f"the file is too deeply nested or too large "
                                                   f"to read ({type(e).__name__})")])
    except Exception as e:  # noqa: BLE001 - a bug must not become a traceback for the user
        report.invalid(path, [Diagnostic(path, 1, f"internal error while reading the model: "
                                                   f"{type(e).__name__}: {e} (please report)")])
    return None


def _out_dirs(models: tuple[str, ...], out: Path) -> dict[str, Path]:
    """DIR/<file stem>/ per model; a repeated stem gets -2, -3 ..."""
    seen: dict[str, int] = {}
    dirs = {}
    for m in models:
        stem = Path(m).stem
        seen[stem] = seen.get(stem, 0) + 1
        dirs[m] = out / (stem if seen[stem] == 1 else f"{stem}-{seen[stem]}")
    return dirs


def _options(model, **cli):
    from .solver import Options
    order = cli.pop("up_to", None)
    if order is not None:
        cli["order"] = ORDERS[order]
    return Options.from_model(model, **cli)


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


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="planarkin")
def main():
    """Kinematic analysis of planar mechanisms described in YAML files.

    Exit status: 0 ok, 1 analysis failure (results up to the failure are written), 2 invalid
    input or usage.
    """


def _analysis_options(f):
    opts = [
        click.option("--steps", type=click.IntRange(1, 10**9), help="Grid intervals (rows - 1)."),
        click.option("--end", type=float, help="End time, s."),
        click.option("--tol", type=click.FloatRange(1e-15, 0.1),
                     help="Newton tolerance: size of the last correction relative to the model's "
                          "length (default 1e-10)."),
        click.option("--newton", type=click.Choice(NEWTON),
                     help="Iteration policy: reuse (one Jacobian per point), full (new Jacobian "
                          "every iteration), fixed (exactly --iterations iterations)."),
        click.option("--iterations", type=click.IntRange(1, 100),
                     help="Maximum (or, with --newton fixed, exact) Newton iterations."),
        click.option("--path-tol", type=click.FloatRange(1e-12, 0.1),
                     help="Predictor error allowed between internal path nodes (default 1e-4)."),
        click.option("--max-step", type=click.FloatRange(min=0, min_open=True),
                     help="Largest internal step, s."),
        click.option("--interpolate/--no-interpolate", default=None,
                     help="P/V/A on the grid by quintic Hermite interpolation of the exact "
                          "internal nodes instead of a Newton solve at every grid point."),
        click.option("--bifurcation", type=click.Choice(BIFURCATION),
                     help="At a bifurcation: stop (default) or continue on the smooth branch."),
        click.option("--up-to", type=click.Choice(tuple(ORDERS)),
                     help="Compute and write up to this derivative (default acceleration)."),
    ]
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
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
def run(models, out, no_plots, fmt, animate, animate_fps, animate_width, x_axis, quiet,
        **analysis):
    """Analyse MODELS: positions, velocities and accelerations over the time grid."""
    if animate_fps or animate_width:
        animate = {k: v for k, v in (("fps", animate_fps), ("width", animate_width)) if v}
    if sys.platform.startswith("linux"):
        _tune_malloc()
    if not no_plots or animate:
        from .output import plotworker      # imports matplotlib while the models solve
        plotworker.start()                  # (stopped below, or at exit)
    report = Report(quiet)
    dirs = _out_dirs(models, Path(out))
    for path in models:
        model = _load(path, report)
        if model is None:
            continue
        _run_one(path, model, dirs[path], report, dict(analysis),
                 None if no_plots else fmt, animate, x_axis)
    if not no_plots or animate:
        plotworker.stop()
    report.summary()
    sys.exit(report.exit_code)


def _run_one(path, model, outdir: Path, report: Report, analysis: dict, plots, animate,
             x_axis=None):
    from .diagnostics import InputError
    from .results import DirectoryWriter, analyse
    t0 = time.perf_counter()
    try:
        opts = _options(model, **analysis)
        if opts.end <= opts.start:
            from .diagnostics import Diagnostic
            report.invalid(path, [Diagnostic(path, model.spec.analysis.lines.get(
                "end", model.spec.analysis.line) or None,
                f"analysis: end ({opts.end:g}) must be greater than start ({opts.start:g})")])
            return
        problem = x_axis and x_axis_problem(x_axis, model.spec, "--x")
        if problem:
            from .diagnostics import Diagnostic
            report.invalid(path, [Diagnostic(path, None, problem)])
            return
        writer = DirectoryWriter(model, outdir, opts, plots=plots, animate=animate,
                                 background=True, x=x_axis)
        progress = _Progress(opts.steps + 1, Path(path).name)
        try:
            info, _ = analyse(model, opts, sink=writer, progress=progress)
        finally:
            progress.close()
    except InputError as e:
        report.invalid(path, e.diagnostics)
        return
    except Exception as e:  # noqa: BLE001 - a bug must not become a traceback for the user
        report.failed(path, f"internal error during the analysis: {type(e).__name__}: {e} "
                            f"(please report)")
        return
    report.diagnostics(info.diagnostics)
    for w in info.warnings:
        report.warning(path, w.message)
    summary = writer.finish(info, started=t0)
    rows = summary["time"]["rows_written"]
    detail = (f"{rows} rows, {summary['solver']['internal_steps']} internal steps, max residual "
              f"{summary['residual']['max']:.1e}, {time.perf_counter() - t0:.2f} s -> {outdir}/")
    if info.status == 0:
        report.ok(path, detail)
    else:
        report.failed(path, info.message, detail)


@main.command()
@click.argument("models", nargs=-1, required=True, type=click.Path())
@click.option("--quiet", "-q", is_flag=True, help="Only errors and the summary line.")
def check(models, quiet):
    """Validate MODELS, assemble them and report degrees of freedom, redundancy and assembly
    modes, without running the analysis."""
    from .assembly import assemble
    from .diagnostics import InputError
    report = Report(quiet)
    for path in models:
        model = _load(path, report)
        if model is None:
            continue
        try:
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
        ndrv = len(model.driver_rows)
        modes = "; ".join(f"{'+'.join(md.bodies)}: {'+' if md.sign > 0 else '-'}"
                          for md in A.modes)
        detail = (f"{model.nb} bodies, {model.n} coordinates, {model.m_joint} joint equations, "
                  f"{ndrv} driver{'s' if ndrv != 1 else ''}; {A.dof} DOF"
                  f"{' (redundant: ' + ', '.join(model.row_label[r] for r in A.redundant_rows) + ')' if A.redundant_rows else ''}"
                  f"; assembled in {A.iterations} iterations, residual {A.residual * model.L:.1e} "
                  f"{model.spec.length_unit}"
                  + (f"; assembly branches {modes} (set assembly: {{branch: {{BODY: +|-}}}} to "
                     f"choose)" if modes else ""))
        report.ok(path, detail)
    report.summary("checked")
    sys.exit(report.exit_code)


@main.command()
@click.argument("model_path", metavar="MODEL", type=click.Path())
@click.option("--out", "out", type=click.Path(file_okay=False), default="out", show_default=True,
              help="Output directory; writes DIR/<file stem>/tradeoff.csv and tradeoff.png.")
@click.option("--steps", type=click.IntRange(1, 10**8), help="Grid intervals for every setting.")
@click.option("--repeats", type=click.IntRange(1, 100), default=3, show_default=True,
              help="Runs per setting; the best time counts.")
@click.option("--no-plots", is_flag=True, help="Skip tradeoff.png.")
@click.option("--quiet", "-q", is_flag=True, help="Only the table.")
def tradeoff(model_path, out, steps, repeats, no_plots, quiet):
    """Run MODEL at a range of solver settings and measure wall time against the achieved
    errors in positions, velocities and accelerations (against a tight reference run)."""
    from .diagnostics import InputError
    from .tradeoff import run_tradeoff
    if sys.platform.startswith("linux"):
        _tune_malloc()
    report = Report(quiet)
    model = _load(model_path, report)
    if model is None:
        sys.exit(report.exit_code)
    outdir = Path(out) / Path(model_path).stem
    try:
        table = run_tradeoff(model, outdir, steps=steps, plot=not no_plots, repeats=repeats)
    except InputError as e:
        report.invalid(model_path, e.diagnostics)
        sys.exit(report.exit_code)
    click.echo(table)
    report.ok(model_path, f"-> {outdir}/tradeoff.csv")
    sys.exit(report.exit_code)
