"""The `planarkin` command and `python -m planarkin`.

SIGINT and SIGTERM end the program at once, quietly (exit 130 / 143), while it starts: importing
click and numpy takes a few hundred milliseconds, and an interruption then must not print a
traceback. `planarkin run` and the studies take the signals over once they can stop in order
(planarkin.output.directory.interruptible); once the command is over they are ignored, so that
a signal while the interpreter shuts down cannot turn a finished run into a killed one.

OpenBLAS runs on one thread unless OPENBLAS_NUM_THREADS says otherwise: planarkin's linear
algebra is many small factorisations, and OpenBLAS's idle threads spin (measured on the
four-bar example, 2-core VM, 2026-12-01: a whole 360-step solve 0.58 -> 0.37 s of CPU). This
can only be set before numpy loads, so here, in the command, not in the library."""

import os
import signal


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
    finally:
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)


if __name__ == "__main__":
    entry()
