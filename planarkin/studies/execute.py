"""Where the variants of a study run: this process, local processes, or a Dask cluster.

The unit of work is a group of chains of variants (Study.units): each is solved the same way
wherever it runs, so the results of `--jobs N` and `--scheduler` equal the serial run's bit
for bit. The Study (the parsed file, the nominal model, the metrics) is sent once per worker
process (Pool initializer) or scattered once to the cluster; each task gets a chain's variants
and returns its outcomes, collected in variant order.
"""

from __future__ import annotations

import os
import sys

_STUDY = None       # the worker process's Study (set once by the Pool initializer)


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def _init(study, parent: int | None = None) -> None:
    global _STUDY
    _STUDY = study
    # a worker forked from the command inherits its start-up handlers, which print
    # "interrupted while starting" (planarkin/__main__.py): the pool's terminate() at the end
    # of every study sends SIGTERM, and a Ctrl-C reaches the whole process group, so a worker
    # ends quietly on either (the parent reports the interruption once)
    import signal
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet)
    # and it dies with the parent: a SIGTERM to the parent alone ends it at once, and a worker
    # left running would finish its unit and print a BrokenPipeError traceback for each
    # result it could no longer send (Linux: PR_SET_PDEATHSIG; elsewhere it ends at the pipe)
    if parent is not None and sys.platform.startswith("linux"):
        try:
            import ctypes
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            pass
        if os.getppid() != parent:          # the parent died before prctl took effect
            os._exit(0)


def _quiet(signum, frame):
    os._exit(128 + signum)


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
    with ctx.Pool(min(jobs, len(parts)), initializer=_init,
                  initargs=(study, os.getpid())) as pool:
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
    """One model of `planarkin run --jobs`: its terminal output captured, returned in order with
    the signal that interrupted it (None when it ran to its end)."""
    import contextlib
    import io

    from ..cli import _load, _run_one, _signame
    from ..output.directory import Interrupted, interruptible
    from ..report import Report
    path, outdir, quiet, overrides, analysis, plots, animate, table_format = args
    out, err = io.StringIO(), io.StringIO()
    rep = Report(quiet)
    stopped = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), interruptible():
        _first_signal_only()
        # after the handlers: a model the parent stops later is interrupted, not run to its end
        if _STOP is not None and _STOP.is_set():
            return "", "", {}, None             # the batch was stopped before this model
        try:
            model = _load(path, rep, overrides)
            if model is not None:
                _run_one(path, model, outdir, rep, dict(analysis), plots, animate,
                         table_format=table_format)
        except (KeyboardInterrupt, Interrupted) as e:   # the directory says so already
            stopped = _signame(e)
    return out.getvalue(), err.getvalue(), rep.counts, stopped


_STOP = None        # a `run --jobs` worker's stop event (set by the parent when interrupted)


def _run_worker_init(stop) -> None:
    """A `run --jobs` worker between models: a signal must not kill it in the pool's own loop
    (a traceback, and a pool the parent then waits on); each model installs its handlers."""
    import signal
    global _STOP
    _STOP = stop
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)


def _first_signal_only() -> None:
    """A worker stops at the first SIGINT or SIGTERM and ignores the rest: a Ctrl-C reaches
    the whole process group and the parent forwards it too, and a second signal must not cut
    the worker's orderly stop (the interrupted summary, the writers joined) short."""
    import signal

    from ..output import directory
    handler = signal.getsignal(signal.SIGINT)

    def once(signum, frame):
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)
        handler(signum, frame)
    if handler is directory._on_signal:
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, once)


def run_models(models, dirs, report, overrides, analysis, plots, animate, jobs: int,
               table_format: str | None = None) -> None:
    """`planarkin run --jobs N` (dirs: one output directory per model, in order): the models in
    N local processes (each still writes its tables in its own writer process); the terminal
    lines in model order, the counts into report. Interrupted (SIGINT, SIGTERM to this process
    alone or to the whole group): the models not started are dropped, the running ones are
    told and stop in order, every finished model's lines are printed and counted, and the
    signal is raised again."""
    import multiprocessing as mp
    import signal
    import sys
    from concurrent.futures import ProcessPoolExecutor

    from ..output.directory import Interrupted, held_signals
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    tasks = [(m, d, report.quiet, overrides, analysis, plots, animate, table_format)
             for m, d in zip(models, dirs)]

    def take(result) -> None:
        out, err, counts, stopped = result
        sys.stderr.write(err)
        sys.stdout.write(out)
        for k, v in counts.items():
            report.counts[k] += v
        if stopped is not None:
            report.signal = stopped

    stop = ctx.Event()
    with ProcessPoolExecutor(min(jobs, len(models)), mp_context=ctx,
                             initializer=_run_worker_init, initargs=(stop,)) as pool:
        futures = [pool.submit(_run_model, t) for t in tasks]
        k = 0
        try:
            for k, f in enumerate(futures):
                take(f.result())
        except (KeyboardInterrupt, Interrupted) as e:
            signum = signal.SIGINT if isinstance(e, KeyboardInterrupt) else signal.SIGTERM
            with held_signals():            # a second signal must not cut this short
                stop.set()                  # before the signals: see _run_model
                for f in futures[k:]:
                    f.cancel()
                for p in mp.active_children():
                    if p.name != "planarkin-plots":
                        try:
                            os.kill(p.pid, signum)
                        except OSError:
                            pass
                for f in futures[k:]:
                    if f.cancelled():
                        continue
                    try:
                        take(f.result(timeout=120))
                    except Exception:  # noqa: BLE001 - a worker that died: its line is lost
                        pass
            if report.signal is None:
                report.signal = "SIGINT" if signum == signal.SIGINT else "SIGTERM"
            raise
