"""Where the variants of a study run: this process, local processes, or a Dask cluster.

Both go through the standard executor interface (`concurrent.futures`): local processes are a
`ProcessPoolExecutor` (planarkin.processes: forkserver on Linux, spawn elsewhere, never a bare
fork); Dask is the same interface through `distributed.Client.get_executor()`.

The unit of work of a study is a group of chains of variants (Study.units): each is solved the
same way wherever it runs, so the results of `--jobs N` and `--scheduler` equal the serial
run's bit for bit. The Study is sent once per worker process (the executor's initializer) or
scattered once to the cluster; each task gets a unit and returns its outcomes, collected in
variant order.

Units can be lost: a local worker that dies (the OOM killer, SIGKILL, a crash) breaks the pool,
and every unit not yet solved fails within the moment the pool notices (it watches its
processes); a Dask cluster that loses its last worker, or its scheduler, cancels the tasks it
had. The units solved are kept: the study's error (WorkerDied, SchedulerError) carries every
variant's outcome, those of the lost units marked (status failed, kind lost), and the study
writes its files from them before raising it (exit 1, as for an analysis failure). A scheduler
that cannot be used (nothing listens, a server that does not speak Dask's protocol or never
answers, no workers) is refused within DASK_TIMEOUT seconds, before anything is solved.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from concurrent.futures.process import BrokenProcessPool

from .outcome import Outcome

_STUDY = None       # the worker process's Study (set once by the initializer)

DASK_TIMEOUT = 5.0  # seconds to reach a Dask scheduler (and find a worker) before giving up
_ADDRESS = re.compile(r"^(tcp|tls|ws|wss)://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]+):(\d{1,5})$")
LOST = "lost"       # the kind of a variant whose unit was lost with its worker


class StudyIncomplete(Exception):
    """Units of a study were lost. outcomes: every variant's outcome in order, the lost ones
    marked (status failed, kind LOST), when some were solved; None when none was."""

    def __init__(self, message: str, outcomes: list | None = None):
        super().__init__(message)
        self.outcomes = outcomes


class WorkerDied(StudyIncomplete):
    """A worker process ended without returning its unit's results."""


class SchedulerError(StudyIncomplete):
    """The Dask scheduler cannot be used (not installed, unreachable, no workers), or the
    cluster lost units."""


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


def dask_problem(address) -> str | None:
    """Why this installation cannot use the (well-formed) scheduler address: Dask missing, or
    a TLS address without Dask's TLS settings; None when it can."""
    try:
        from distributed.security import Security
    except ImportError:
        return "needs Dask: pip install 'planarkin[dask]'"
    scheme = address.strip().split("://")[0] if isinstance(address, str) else "tcp"
    if scheme in ("tls", "wss") and Security().get_connection_args("client").get(
            "ssl_context") is None:
        return (f"'{address}': {scheme}:// needs Dask's TLS settings (distributed.comm.tls: "
                f"ca-file, client: cert and key, in the Dask configuration); a cluster without "
                f"TLS is tcp://HOST:PORT")
    return None


# -- studies ---------------------------------------------------------------------------------

def solve(execute, study, variants):
    """(outcomes, None) of execute(study, variants) (None: serially, here); (outcomes, the
    StudyIncomplete) when units were lost after others were solved, for the study to write
    what was solved before it raises kept(...). Raises it when none was solved."""
    from .variants import Study
    try:
        return (execute or Study.run)(study, variants), None
    except StudyIncomplete as e:
        if e.outcomes is None:
            raise
        return e.outcomes, e


def kept(e: StudyIncomplete, table) -> StudyIncomplete:
    """e, once the variants solved are written: its message says where."""
    return type(e)(f"{e}; the variants solved are in {table} (the others: status failed, kind "
                   f"{LOST})")


def _init_study(study) -> None:
    global _STUDY
    _STUDY = study
    _quiet_on_signals()


def _quiet_on_signals() -> None:
    # a Ctrl-C reaches every process of the group, and the parent ends its workers when it
    # stops: a worker then ends quietly (the parent reports the interruption)
    import signal

    from ..processes import accept_signals
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet)
    accept_signals()


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


def _lost(study, unit, why: str) -> list:
    """The outcomes of a lost unit's variants."""
    none = (math.nan,) * len(study.metrics)
    return [Outcome("failed", LOST, math.nan, f"not solved: {why}", none)
            for ch in unit for _ in ch]


def _incomplete(kind, study, units, results, first: int, why: str, lost_what: str):
    """kind (WorkerDied, SchedulerError) for results (each unit's outcomes, None where it was
    lost), naming the first unit lost and carrying every variant's outcome when some unit was
    solved."""
    out = []
    for unit, r in zip(units, results):
        out += r if r is not None else _lost(study, unit, why)
    at = sum(len(ch) for u in units[:first] for ch in u)
    lost = sum(len(ch) for u, r in zip(units, results) if r is None for ch in u)
    solved = any(r is not None for r in results)
    which = _describe(units[first], at)
    return kind(f"{lost_what} while {which} {'were' if '-' in which else 'was'} being solved; "
                f"{lost} of {len(out)} variants were not solved", out if solved else None)


def _collect(futures, units, study) -> list:
    """The outcomes of every unit, in order; WorkerDied (with the outcomes of the units solved)
    when a worker died."""
    results, first = [], None
    for k, f in enumerate(futures):
        try:
            results.append(f.result())
        except BrokenProcessPool:
            results.append(None)
            first = k if first is None else first
    if first is not None:
        raise _incomplete(WorkerDied, study, units, results, first, "its worker process died",
                          "a worker process died (killed by a signal, out of memory or a "
                          "crash)")
    return [o for r in results for o in r]


def run_processes(study, variants, jobs: int):
    from concurrent.futures import ProcessPoolExecutor

    from ..processes import context, stop_workers
    # the workers' server started first: it loads the compiled route while this process
    # prepares the study (study.units compiles or loads the structure's kernel here)
    ctx = context(engine=study.on_engine(variants))
    units = study.units(variants)          # prepares the batched solver before the workers
    if len(units) <= 1:
        return study.run(variants)
    from ..output.directory import critical
    pool = ProcessPoolExecutor(min(jobs, len(units)), mp_context=ctx,
                               initializer=_init_study, initargs=(study,))
    try:
        with critical():        # a worker is started (sent the study) whole, or not at all
            futures = [pool.submit(_unit, u) for u in units]
        out = _collect(futures, units, study)
    except BaseException:
        stop_workers(pool)
        raise
    pool.shutdown()
    return out


# -- Dask ------------------------------------------------------------------------------------

def run_dask(study, variants, scheduler):
    """Units as tasks on a Dask distributed cluster through its executor interface; the study
    scattered once. Raises ValueError for a malformed address; SchedulerError when Dask is
    missing, when the scheduler cannot be reached, does not answer as one, or has no worker
    within DASK_TIMEOUT seconds, and when the cluster loses units (with the outcomes of those
    solved)."""
    problem = scheduler_problem(scheduler)
    if problem:
        raise ValueError(problem)
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerError("--scheduler needs Dask: pip install 'planarkin[dask]'") from None
    with _quiet_logs():
        return _run_dask(study, variants, scheduler, not isinstance(scheduler, Client))


def _run_dask(study, variants, scheduler, own: bool):
    from distributed import Client
    client = None
    try:
        if own:
            _probe(scheduler)
            try:
                client = Client(scheduler, timeout=DASK_TIMEOUT)
            except Exception as e:  # noqa: BLE001 - any failure to connect: one line
                raise SchedulerError(f"cannot reach the Dask scheduler at {scheduler} within "
                                     f"{DASK_TIMEOUT:g} s ({_first_line(e)})") from None
        else:
            client = scheduler
        return _run_on(client, study, variants)
    finally:
        if own and client is not None:
            try:
                client.close(timeout=DASK_TIMEOUT)
            except Exception:  # noqa: BLE001 - a scheduler gone: nothing left to close
                pass


@contextlib.contextmanager
def _quiet_logs():
    """distributed's loggers (each has its own level in Dask's configuration) silenced: its
    retries, reconnections and lost workers print pages of warnings and logged tracebacks,
    where the error raised says what matters in one line."""
    import logging
    names = ["distributed"] + [n for n in list(logging.root.manager.loggerDict)
                               if n.startswith("distributed.")]
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)


def _run_on(client, study, variants):
    where = client.scheduler.address
    units = study.units(variants)
    try:
        client.wait_for_workers(1, timeout=DASK_TIMEOUT)
    except Exception:  # noqa: BLE001 - a timeout, or the scheduler gone meanwhile
        raise SchedulerError(f"the Dask scheduler at {where} has no worker (none within "
                             f"{DASK_TIMEOUT:g} s): start one, e.g. dask worker "
                             f"{where}") from None
    try:
        [remote] = client.scatter([study], broadcast=True, timeout=DASK_TIMEOUT)
        ex = client.get_executor(pure=False)
        futures = [ex.submit(_dask_unit, remote, u) for u in units]
    except Exception as e:  # noqa: BLE001 - the workers or the scheduler gone meanwhile
        raise SchedulerError(f"the Dask cluster at {where} failed before any variant was "
                             f"solved ({_first_line(e)})") from None
    return _collect_dask(client, futures, units, study, where)


def _collect_dask(client, futures, units, study, where: str) -> list:
    """The outcomes of every unit, in order. A task that fails (its data or the scheduler lost:
    cancelled; its worker killed under it, KilledWorker) loses its unit; so does every task
    still waiting while the cluster has had no worker for DASK_TIMEOUT seconds. SchedulerError
    (with the outcomes of the units solved) when units were lost."""
    import time
    from concurrent.futures import FIRST_COMPLETED, CancelledError, wait
    results: list = [None] * len(futures)
    why: list = [None] * len(futures)          # why each unit lost was
    index = {f: k for k, f in enumerate(futures)}
    pending = set(futures)
    quiet_since = time.monotonic()
    while pending:
        done, pending = wait(pending, timeout=min(1.0, DASK_TIMEOUT),
                             return_when=FIRST_COMPLETED)
        for f in done:
            k = index[f]
            try:
                results[k] = f.result()
            except CancelledError:
                why[k] = "cancelled: the scheduler, or every worker holding the study, is gone"
            except Exception as e:  # noqa: BLE001 - the cluster's reasons, said in one line
                why[k] = _first_line(e)
        if done:
            quiet_since = time.monotonic()
        elif time.monotonic() - quiet_since > DASK_TIMEOUT:
            quiet_since = time.monotonic()
            if not _workers(client):
                for f in pending:
                    why[index[f]] = "no worker left"
                    f.cancel()
                break
    if any(r is None for r in results):
        first = next(k for k, r in enumerate(results) if r is None)
        raise _incomplete(SchedulerError, study, units, results, first,
                          "the Dask cluster lost it", f"the Dask cluster at {where} lost "
                          f"units ({why[first]})")
    return [o for r in results for o in r]


def _workers(client) -> int:
    """The workers the scheduler knows now (0 when it cannot be asked)."""
    try:
        return len(client.scheduler_info(n_workers=-1).get("workers", {}))
    except Exception:  # noqa: BLE001 - the scheduler gone
        return 0


def _probe(address: str) -> None:
    """A Dask handshake with address, bounded by DASK_TIMEOUT: distributed's own connect waits
    for the handshake's answer without a limit (a port that accepts and never answers held the
    command for ever) and reads any answer as a frame length (a server answering anything else
    made it allocate exabytes). Raises SchedulerError, in one line."""
    import asyncio
    import socket
    import threading

    from distributed.comm import connect

    # a plain TCP connect first: connect's retries end in a timeout whose cause, refused or
    # not, depends on how busy the machine is, while the reason is what the user needs
    m = re.fullmatch(r"tcp://(\[[^\]]+\]|[^:/]+):(\d+)", address)
    if m is not None:
        try:
            socket.create_connection((m.group(1).strip("[]"), int(m.group(2))),
                                     timeout=DASK_TIMEOUT).close()
        except OSError as e:
            why = e.strerror or type(e).__name__
            raise SchedulerError(f"cannot reach the Dask scheduler at {address} within "
                                 f"{DASK_TIMEOUT:g} s ({why})") from None

    async def handshake():
        # connect's own retries end first: nothing listening is then told from no answer
        comm = await asyncio.wait_for(connect(address, timeout=0.9 * DASK_TIMEOUT),
                                      DASK_TIMEOUT)
        await comm.close()

    box: dict = {}

    def attempt():
        try:
            asyncio.run(handshake())
        except BaseException as e:  # noqa: BLE001 - said by the caller
            box["error"] = e

    # a thread of its own: the caller's thread may run an event loop already (a notebook)
    t = threading.Thread(target=attempt, name="planarkin-dask-probe", daemon=True)
    t.start()
    t.join(DASK_TIMEOUT + 1.0)
    e = box.get("error")
    if t.is_alive() or isinstance(e, (asyncio.TimeoutError, TimeoutError)):
        raise SchedulerError(f"cannot reach the Dask scheduler at {address} within "
                             f"{DASK_TIMEOUT:g} s (it accepts connections but does not answer: "
                             f"is it a Dask scheduler?)")
    if isinstance(e, OSError):          # its cause says why (refused, no route) when not
        cause = e.__cause__             # an attempt's own timeout
        why = (re.sub(r"^in <[^>]*>: ", "", _first_line(cause))
               if isinstance(cause, OSError) and not isinstance(cause, TimeoutError)
               else "no connection")
        raise SchedulerError(f"cannot reach the Dask scheduler at {address} within "
                             f"{DASK_TIMEOUT:g} s ({why})")
    if e is not None:
        raise SchedulerError(f"cannot use {address} as a Dask scheduler: what answers there "
                             f"does not speak Dask's protocol ({type(e).__name__})")


def _first_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__
