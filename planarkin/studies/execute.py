"""Where the variants of a study run: this process, local processes, or a Dask cluster.

Both go through the standard executor interface (`concurrent.futures`): local processes are a
`ProcessPoolExecutor` (planarkin.processes: forkserver on Linux, spawn elsewhere, never a bare
fork); Dask is the same interface through `distributed.Client.get_executor()`.

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
from concurrent.futures.process import BrokenProcessPool

_STUDY = None       # the worker process's Study (set once by the initializer)

DASK_TIMEOUT = 5.0  # seconds to reach a Dask scheduler before giving up
_ADDRESS = re.compile(r"^(tcp|tls|ws|wss)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")


class WorkerDied(Exception):
    """A worker process ended without returning its unit's results."""


class SchedulerError(Exception):
    """The Dask scheduler cannot be used (not installed, unreachable)."""


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
    from ..processes import cores
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


def run_processes(study, variants, jobs: int):
    from concurrent.futures import ProcessPoolExecutor

    from ..processes import context, stop_workers
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
        stop_workers(pool)
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
