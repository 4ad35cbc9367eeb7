"""Local worker processes for `planarkin run --jobs` and the studies: the multiprocessing
context of their `concurrent.futures.ProcessPoolExecutor`, the cores to use, and how an
interrupted command ends them.

Linux: forkserver (its server imports the modules the workers need once, and each worker is
forked from that clean, single-threaded process); elsewhere: spawn. Never a bare fork of the
command: macOS calls fork without exec unsafe, and a fork copies the parent's threads' locks.

The forkserver and multiprocessing's resource tracker are started deaf to SIGINT and SIGTERM
(as CPython starts the tracker): a Ctrl-C or a `docker stop` reaches every process of the
group, and a server killed by it broke the pool under workers that were still stopping in
order (their models reported as dead, their processes left running). Both end by themselves
when the command ends: they read EOF on the pipes it holds. The workers, forked from the
server, inherit its blocked signals and take them back in their initializer (accept_signals).
"""

from __future__ import annotations

import os
import signal
import sys

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def context(engine: bool = False):
    """The multiprocessing context of the workers (its forkserver started, deaf to signals).
    engine: the workers solve on the compiled route, whose numba and entry points the server
    then loads once (planarkin.solver.compiled.preload) for every worker it forks (decided by
    the first call of a process: the server is started once)."""
    import multiprocessing as mp
    if sys.platform.startswith("linux") and "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["planarkin.studies.variants", "planarkin.run"] + (
            ["planarkin.solver.compiled.preload"] if engine else []))
        _start_servers()
        return ctx
    return mp.get_context("spawn")


def _start_servers() -> None:
    """Start the resource tracker and the forkserver (once per process) with SIGINT and SIGTERM
    blocked: an exec keeps the mask, and neither server ever unblocks them, so a signal to the
    group stays pending there for ever. A signal to this process meanwhile is pending only for
    the moment of the spawn, then delivered as usual."""
    from multiprocessing import forkserver, resource_tracker
    # the tracker first: its own start unblocks SIGINT and SIGTERM here when it is done
    resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        forkserver.ensure_running()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def accept_signals() -> None:
    """In a worker, after its handlers are installed: SIGINT and SIGTERM delivered again (a
    worker forked from the forkserver starts with them blocked)."""
    if hasattr(signal, "pthread_sigmask"):          # (not on Windows: spawn, nothing blocked)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)


def stop_workers(pool) -> None:
    """End an executor's workers now (an interruption, a broken pool, a worker that hung) with
    SIGKILL, then wait for the executor's own thread to reap them and release its queues: the
    work they run is not waited for, and nothing of the pool outlives the command (neither a
    worker nor the resource tracker's "leaked semaphore" warning at exit). SIGKILL: a `run
    --jobs` worker ignores SIGTERM between models, and a study worker inside a compiled kernel
    would answer it only when the kernel returns; a worker holds nothing to clean up (a
    staged directory is removed by the next run into it)."""
    import multiprocessing as mp
    for p in mp.active_children():
        if p.name.startswith(("ForkServerProcess", "SpawnProcess")):
            p.kill()
    # the executor's thread sees the workers end, marks the pool broken, joins them and closes
    # its queues; futures are cancelled there only (one cancelled here as that thread fails
    # the pending ones raises InvalidStateError inside it: a traceback)
    pool.shutdown(wait=True, cancel_futures=True)
