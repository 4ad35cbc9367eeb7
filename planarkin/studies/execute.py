"""Where the variants of a study run: this process, local processes, or a Dask cluster; and
where the models of `planarkin run --jobs` run.

Both go through the standard executor interface (`concurrent.futures`): local processes are a
`ProcessPoolExecutor` started by forkserver on Linux and by spawn elsewhere (never a bare fork:
macOS calls it unsafe, and a fork copies the parent's threads' locks); Dask is the same
interface through `distributed.Client.get_executor()`.

The unit of work of a study is a group of chains of variants (Study.units): each is solved the
same way wherever it runs, so the results of `--jobs N` and `--scheduler` equal the serial
run's bit for bit. The Study is sent once per worker process (the executor's initializer) or
scattered once to the cluster; each task gets a unit and returns its outcomes, collected in
variant order.

A worker that dies (the OOM killer, SIGKILL, a crash) breaks the pool: every unit not yet
collected fails with `WorkerDied`, naming the first of them, within the moment the pool
notices (it watches its processes), so the command ends (exit 1) and never waits.
"""

from __future__ import annotations

import os
import re
import sys
from concurrent.futures.process import BrokenProcessPool

_STUDY = None       # the worker process's Study (set once by the initializer)
_RUN_STOP = None    # a `run --jobs` worker's stop value (the parent's signal number, or 0)

DASK_TIMEOUT = 5.0  # seconds to reach a Dask scheduler before giving up
_ADDRESS = re.compile(r"^(tcp|tls|ws|wss)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")


class WorkerDied(Exception):
    """A worker process ended without returning its unit's results."""


class SchedulerError(Exception):
    """The Dask scheduler cannot be used (not installed, unreachable)."""


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def context():
    """The multiprocessing context of the local workers: forkserver on Linux (its server
    imports the study modules once, each worker is forked from it), spawn elsewhere."""
    import multiprocessing as mp
    if sys.platform.startswith("linux") and "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["planarkin.studies.variants", "planarkin.cli"])
        return ctx
    return mp.get_context("spawn")


def scheduler_problem(address) -> str | None:
    """Why a --scheduler address is malformed (None when it reads as SCHEME://HOST:PORT); needs
    no Dask."""
    if not isinstance(address, str):
        return None                 # a distributed.Client
    m = _ADDRESS.match(address.strip())
    if m is None:
        return (f"'{address}' is not a scheduler address: write tcp://HOST:PORT, e.g. "
                f"tcp://127.0.0.1:8786")
    if not 0 < int(m.group(3)) < 65536:
        return f"'{address}': the port must be 1 to 65535"
    return None


# -- studies ---------------------------------------------------------------------------------

def _init_study(study) -> None:
    global _STUDY
    _STUDY = study
    _quiet_on_signals()


def _quiet_on_signals() -> None:
    # a Ctrl-C reaches every process of the group, and the parent ends its workers with
    # SIGTERM when it stops: a worker then ends quietly (the parent reports the interruption)
    import signal
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet)


def _quiet(signum, frame):
    os._exit(128 + signum)


def _unit(unit):
    return _STUDY.run_unit(unit)


def _dask_unit(study, unit):
    return study.run_unit(unit)


def executor(jobs: int | None = None, scheduler=None):
    """A function (study, variants) -> outcomes in order. jobs: local processes (None: the
    cores); scheduler: a Dask scheduler address such as tcp://127.0.0.1:8786, or a
    distributed.Client."""
    if scheduler is not None:
        return lambda study, variants: run_dask(study, variants, scheduler)
    jobs = cores() if jobs is None else jobs
    if jobs <= 1:
        return lambda study, variants: study.run(variants)
    return lambda study, variants: run_processes(study, variants, jobs)


def _describe(unit, first: int) -> str:
    n = sum(len(ch) for ch in unit)
    return f"variant {first + 1}" if n == 1 else f"variants {first + 1}-{first + n}"


def _collect(futures, units) -> list:
    """The outcomes of every unit, in order; WorkerDied for the first unit whose worker died."""
    out = []
    for f, unit in zip(futures, units):
        try:
            out += f.result()
        except BrokenProcessPool:
            raise WorkerDied(f"a worker process died (killed by a signal, out of memory or a "
                             f"crash) while {_describe(unit, len(out))} were being solved; "
                             f"the study is abandoned and nothing was written") from None
    return out


def _stop_workers(pool, kill: bool = False) -> None:
    """End this pool's workers now (an interruption): the units running are not waited for.
    kill: SIGKILL (a `run --jobs` worker ignores SIGTERM between models), else SIGTERM."""
    import multiprocessing as mp
    pool.shutdown(wait=False, cancel_futures=True)
    for p in mp.active_children():
        if p.name.startswith(("ForkServerProcess", "SpawnProcess")):
            p.kill() if kill else p.terminate()


def run_processes(study, variants, jobs: int):
    from concurrent.futures import ProcessPoolExecutor
    units = study.units(variants)          # prepares the batched solver before the workers
    if len(units) <= 1:
        return study.run(variants)
    from ..output.directory import critical
    pool = ProcessPoolExecutor(min(jobs, len(units)), mp_context=context(),
                               initializer=_init_study, initargs=(study,))
    try:
        with critical():        # a worker is started (sent the study) whole, or not at all
            futures = [pool.submit(_unit, u) for u in units]
        out = _collect(futures, units)
    except BaseException:
        _stop_workers(pool)
        raise
    pool.shutdown()
    return out


def run_dask(study, variants, scheduler):
    """Units as tasks on a Dask distributed cluster through its executor interface; the study
    scattered once. Raises SchedulerError when Dask is missing or the scheduler cannot be
    reached within DASK_TIMEOUT seconds, ValueError for a malformed address."""
    problem = scheduler_problem(scheduler)
    if problem:
        raise ValueError(problem)
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerError("--scheduler needs Dask: pip install 'planarkin[dask]'") from None
    own = not isinstance(scheduler, Client)
    if own:
        import logging
        log = logging.getLogger("distributed")
        level = log.level
        log.setLevel(logging.CRITICAL)      # its retries would print a page of warnings
        try:
            client = Client(scheduler, timeout=DASK_TIMEOUT)
        except (OSError, TimeoutError) as e:
            raise SchedulerError(f"cannot reach the Dask scheduler at {scheduler} within "
                                 f"{DASK_TIMEOUT:g} s ({_first_line(e)})") from None
        finally:
            log.setLevel(level)
    else:
        client = scheduler
    try:
        units = study.units(variants)
        [remote] = client.scatter([study], broadcast=True)
        ex = client.get_executor(pure=False)
        return _collect([ex.submit(_dask_unit, remote, u) for u in units], units)
    finally:
        if own:
            client.close()


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


# -- run --jobs ------------------------------------------------------------------------------

def _init_run(stop) -> None:
    """A `run --jobs` worker: between models a signal must not end it in the executor's own
    loop (a traceback); each model takes the signals over (interruptible) and stops in order,
    on its own signal (a Ctrl-C to the group) or when the parent sets `stop`."""
    import signal
    global _RUN_STOP
    _RUN_STOP = stop
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, signal.SIG_IGN)


def _run_model(args):
    """One model of `planarkin run --jobs`: its terminal output captured, returned in order with
    the signal that interrupted it (None when it ran to its end)."""
    import contextlib
    import io

    from ..cli import _load, _run_one
    from ..output.directory import interruptible, signame
    from ..report import Report
    path, outdir, quiet, overrides, analysis, plots, animate, table_format, x_axis = args
    out, err = io.StringIO(), io.StringIO()
    rep = Report(quiet)
    stopped = None
    if _RUN_STOP is not None and _RUN_STOP.value:
        return "", "", rep.counts, None         # the batch was stopped before this model
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), interruptible():
        try:
            model = _load(path, rep, overrides)
            if model is not None:
                _run_one(path, model, outdir, rep, dict(analysis), plots, animate, x_axis,
                         table_format=table_format, stop=_RUN_STOP)
        except KeyboardInterrupt as e:          # the directory says so already
            stopped = signame(e)
    return out.getvalue(), err.getvalue(), rep.counts, stopped


def run_models(models, dirs, report, overrides, analysis, plots, animate, jobs: int,
               table_format: str | None = None, x_axis: str | None = None) -> None:
    """`planarkin run --jobs N` (dirs: one output directory per model, in order): the models in
    N local processes, each writing its own directory; the terminal lines in model order, the
    counts into report. Interrupted (SIGINT, SIGTERM to this process alone or to the whole
    group): the models not started are dropped, the running ones are told (a shared value
    their writers check between blocks of rows) and stop in order, every finished model's
    lines are printed and counted, and the interruption is raised again. A worker that dies
    fails its model (exit 1)."""
    import signal
    from concurrent.futures import ProcessPoolExecutor

    from ..output.directory import critical, signame
    ctx = context()
    tasks = [(m, d, report.quiet, overrides, analysis, plots, animate, table_format, x_axis)
             for m, d in zip(models, dirs)]

    def take(result) -> None:
        out, err, counts, stopped = result
        sys.stderr.write(err)
        sys.stdout.write(out)
        for k, v in counts.items():
            report.counts[k] += v
        if stopped is not None:
            report.signal = stopped

    def died(path) -> None:
        report.failed(path, "its worker process died (killed by a signal, out of memory or a "
                            "crash); its directory is left as it was")

    stop = ctx.Value("i", 0, lock=False)
    pool = ProcessPoolExecutor(min(jobs, len(models)), mp_context=ctx,
                               initializer=_init_run, initargs=(stop,))
    k, futures = 0, []
    try:
        with critical():        # a worker is started whole, or not at all
            futures = [pool.submit(_run_model, t) for t in tasks]
        for k, f in enumerate(futures):
            try:
                take(f.result())
            except BrokenProcessPool:
                died(models[k])
    except KeyboardInterrupt as e:
        with critical():                # a second signal is ignored anyway; this must finish
            stop.value = int(signal.SIGTERM if signame(e) == "SIGTERM" else signal.SIGINT)
            for f in futures[k:]:
                f.cancel()
            for f, path in zip(futures[k:], models[k:]):
                if f.cancelled():
                    continue
                try:
                    take(f.result(timeout=120))
                except BrokenProcessPool:
                    died(path)
                except Exception:  # noqa: BLE001 - a worker that hung: its line is lost
                    pass
            if not all(f.done() for f in futures):      # a worker that hung: ended now
                _stop_workers(pool, kill=True)
        if report.signal is None:
            report.signal = signame(e)
        pool.shutdown(cancel_futures=True)      # the idle workers end: nothing outlives us
        raise
    pool.shutdown()
