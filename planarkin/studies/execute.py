"""Where the variants of a study run: this process, local processes, or a Dask cluster.

The unit of work is a group of chains of variants (Study.units): each is solved the same way
wherever it runs, so the results of `--jobs N` and `--scheduler` equal the serial run's bit
for bit. The Study (the parsed file, the nominal model, the metrics) is sent once per worker
process (Pool initializer) or scattered once to the cluster; each task gets a chain's variants
and returns its outcomes, collected in variant order.
"""

from __future__ import annotations

import os

_STUDY = None       # the worker process's Study (set once by the Pool initializer)


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def _init(study) -> None:
    global _STUDY
    _STUDY = study


def _unit(unit):
    return _STUDY.run_unit(unit)


def _dask_unit(study, unit):
    return study.run_unit(unit)


def executor(jobs: int | None = None, scheduler: str | None = None):
    """A function (study, variants) -> outcomes in order. jobs: local processes (None: the
    cores); scheduler: a Dask scheduler address such as tcp://127.0.0.1:8786, or a
    distributed.Client."""
    if scheduler is not None:
        return lambda study, variants: run_dask(study, variants, scheduler)
    jobs = cores() if jobs is None else jobs
    if jobs <= 1:
        return lambda study, variants: study.run(variants)
    return lambda study, variants: run_processes(study, variants, jobs)


def run_processes(study, variants, jobs: int):
    import multiprocessing as mp
    parts = study.units(variants)          # prepares the batched solver before the fork
    if len(parts) <= 1:
        return study.run(variants)
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    out = []
    with ctx.Pool(min(jobs, len(parts)), initializer=_init, initargs=(study,)) as pool:
        for res in pool.imap(_unit, parts):        # in order, as they arrive
            out += res
    return out


def run_dask(study, variants, scheduler):
    """Chains of variants as tasks on a Dask distributed cluster; the study scattered once."""
    try:
        from distributed import Client
    except ImportError:
        raise RuntimeError("--scheduler needs Dask: pip install 'planarkin[dask]'") from None
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    try:
        units = study.units(variants)
        [remote] = client.scatter([study], broadcast=True)
        futures = [client.submit(_dask_unit, remote, u, pure=False) for u in units]
        out = []
        for f in futures:                           # in order
            out += f.result()
        return out
    finally:
        if own:
            client.close()


def _run_model(args):
    """One model of `planarkin run --jobs`: its terminal output captured, returned in order."""
    import contextlib
    import io
    from ..cli import _load, _run_one
    from ..report import Report
    path, outdir, quiet, overrides, analysis, plots, animate, table_format = args
    out, err = io.StringIO(), io.StringIO()
    rep = Report(quiet)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        model = _load(path, rep, overrides)
        if model is not None:
            _run_one(path, model, outdir, rep, dict(analysis), plots, animate,
                     table_format=table_format)
    return out.getvalue(), err.getvalue(), rep.counts


def run_models(models, dirs, report, overrides, analysis, plots, animate, jobs: int,
               table_format: str | None = None) -> None:
    """`planarkin run --jobs N` (dirs: one output directory per model, in order): the models in
    N local processes (each still writes its tables
    in its own writer process); the terminal lines in model order, the counts into report."""
    import multiprocessing as mp
    import sys
    from concurrent.futures import ProcessPoolExecutor
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    tasks = [(m, d, report.quiet, overrides, analysis, plots, animate, table_format)
             for m, d in zip(models, dirs)]
    with ProcessPoolExecutor(min(jobs, len(models)), mp_context=ctx) as pool:
        for out, err, counts in pool.map(_run_model, tasks):
            sys.stderr.write(err)
            sys.stdout.write(out)
            for k, v in counts.items():
                report.counts[k] += v
