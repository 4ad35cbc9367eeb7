"""The `planarkin` command and `python -m planarkin`.

SIGINT and SIGTERM end the program at once, quietly (exit 130 / 143), while it starts: importing
click and numpy takes a few hundred milliseconds, and an interruption then must not print a
traceback. `planarkin run` takes the signals over once it can stop in order (see
planarkin.output.directory.interruptible).

OpenBLAS runs on one thread unless OPENBLAS_NUM_THREADS says otherwise: planarkin's linear
algebra is many small factorisations (the large blocks are pinned to one thread anyway,
linalg.one_blas_thread), and OpenBLAS's idle threads spin. Measured on the four-bar example
(2-core VM, 2026-12-01): importing numpy 0.30 -> 0.18 s of CPU, a whole 360-step solve 0.58 ->
0.37 s of CPU and 0.46 -> 0.37 s of wall, and the spinning threads no longer take the core the
plot server imports matplotlib on. This can only be set before numpy loads, so here, in the
command, not in the library."""

import os
import signal


def _quiet_exit(signum, frame):
    os.write(1, b"interrupted while starting: nothing was written\n")
    os._exit(128 + signum)


def entry():
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet_exit)
    import sys
    from .output import plotworker
    if plotworker.wanted(sys.argv[1:]):
        plotworker.start(early=True)    # matplotlib's import overlaps click's, numpy's ...
    from .cli import main
    try:
        main()
    finally:
        # the command is over, its files in place and its processes joined (an interrupted
        # run leaves by os._exit before this): a signal from here on, while the interpreter
        # shuts down, would meet the default handler once Python has reset it and kill a
        # finished run (exit -15, seen as an intermittent test failure): it is ignored
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)


if __name__ == "__main__":
    entry()
