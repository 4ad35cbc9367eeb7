"""The `planarkin` command and `python -m planarkin`.

SIGINT and SIGTERM end the program at once, quietly (exit 130 / 143), while it starts: importing
click and numpy takes a noticeable moment, and an interruption then must not print a
traceback. `planarkin run` and the studies take the signals over once they can stop in order
(planarkin.output.directory.interruptible); once the command is over they are ignored and the
process leaves with the command's exit status, so that a signal then cannot turn a finished run
into a killed one.

OpenBLAS runs on one thread unless OPENBLAS_NUM_THREADS says otherwise: planarkin's linear
algebra is many small factorisations, and OpenBLAS's idle threads spin: they cost the four-bar
example's whole solve a large share of its CPU time (benchmarks/README.md, "Figures moved from
the code's comments"). This can only be set before numpy loads, so here, in the command, not in
the library."""

import os
import signal
import sys


def _quiet_exit(signum, frame):
    os.write(1, b"interrupted while starting: nothing was written\n")
    os._exit(128 + signum)


def entry():
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet_exit)
    from .cli import main
    try:
        main()
        code = 0
    except SystemExit as e:
        code = e.code
    finally:
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)
    if not isinstance(code, int):           # sys.exit("text"), as Python prints it
        if code is not None:
            print(code, file=sys.stderr)
        code = 0 if code is None else 1
    # the command is over: its files are closed and in place, its worker processes joined.
    # The interpreter's teardown (a large part of a small run with matplotlib loaded,
    # benchmarks/bench_plot_timeline.py) would only free memory the kernel frees anyway
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    entry()
