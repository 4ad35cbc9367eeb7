"""Local worker processes for `planarkin run --jobs` and the studies: the multiprocessing
context of their `concurrent.futures.ProcessPoolExecutor`, the cores to use, and how an
interrupted command ends them.

Linux: forkserver (its server imports the modules the workers need once, and each worker is
forked from that clean, single-threaded process); elsewhere: spawn. Never a bare fork of the
command: macOS calls fork without exec unsafe, and a fork copies the parent's threads' locks.
"""

from __future__ import annotations

import os
import sys


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:      # not Linux
        return os.cpu_count() or 1


def context():
    """The multiprocessing context of the workers."""
    import multiprocessing as mp
    if sys.platform.startswith("linux") and "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["planarkin.studies.variants", "planarkin.run"])
        return ctx
    return mp.get_context("spawn")


def stop_workers(pool, kill: bool = False) -> None:
    """End an executor's workers now (an interruption, a broken pool): the work they run is
    not waited for. kill: SIGKILL (a `run --jobs` worker ignores SIGTERM between models), else
    SIGTERM."""
    import multiprocessing as mp
    pool.shutdown(wait=False, cancel_futures=True)
    for p in mp.active_children():
        if p.name.startswith(("ForkServerProcess", "SpawnProcess")):
            p.kill() if kill else p.terminate()
