"""Where the variants of a study run: this process, local processes, or a Dask cluster.

The unit of work is a chain of variants (studies.warm.chains): each chain is solved the same
way wherever it runs, so the results of `--jobs N` and `--scheduler` equal the serial run's bit
for bit. The Study (the parsed file, the nominal model, the metrics) is sent once per worker
process (Pool initializer) or scattered once to the cluster; each task gets a chain's variants
and returns its outcomes, collected in variant order.
"""

from __future__ import annotations

import os

from .warm import chains

_STUDY = None       # the worker process's Study (set once by the Pool initializer)


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def _init(study) -> None:
    global _STUDY
    _STUDY = study


def _chain(variants):
    return _STUDY.run_chain(variants)


def _dask_chain(study, variants):
    return study.run_chain(variants)


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
    parts = [[variants[i] for i in ch] for ch in chains(len(variants), study.chain)]
    if len(parts) <= 1:
        return study.run(variants)
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    out = []
    with ctx.Pool(min(jobs, len(parts)), initializer=_init, initargs=(study,)) as pool:
        for res in pool.imap(_chain, parts):        # in order, as they arrive
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
        [remote] = client.scatter([study], broadcast=True)
        futures = [client.submit(_dask_chain, remote, [variants[i] for i in ch], pure=False)
                   for ch in chains(len(variants), study.chain)]
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
    path, outdir, quiet, overrides, analysis, plots, animate = args
    out, err = io.StringIO(), io.StringIO()
    rep = Report(quiet)
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        model = _load(path, rep, overrides)
        if model is not None:
            _run_one(path, model, outdir, rep, dict(analysis), plots, animate)
    return out.getvalue(), err.getvalue(), rep.counts


def run_models(models, dirs, report, overrides, analysis, plots, animate, jobs: int) -> None:
    """`planarkin run --jobs N`: the models in N local processes (each still writes its tables
    in its own writer process); the terminal lines in model order, the counts into report."""
    import multiprocessing as mp
    import sys
    from concurrent.futures import ProcessPoolExecutor
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    tasks = [(m, dirs[m], report.quiet, overrides, analysis, plots, animate) for m in models]
    with ProcessPoolExecutor(min(jobs, len(models)), mp_context=ctx) as pool:
        for out, err, counts in pool.map(_run_model, tasks):
            sys.stderr.write(err)
            sys.stdout.write(out)
            for k, v in counts.items():
                report.counts[k] += v
