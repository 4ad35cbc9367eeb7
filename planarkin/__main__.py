"""The `planarkin` command and `python -m planarkin`.

SIGINT and SIGTERM end the program at once, quietly (exit 130 / 143), while it starts: importing
click and numpy takes a few hundred milliseconds, and an interruption then must not print a
traceback. `planarkin run` takes the signals over once it can stop in order (see
planarkin.output.directory.interruptible)."""

import os
import signal


def _quiet_exit(signum, frame):
    os.write(1, b"interrupted while starting: nothing was written\n")
    os._exit(128 + signum)


def entry():
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _quiet_exit)
    import sys
    from .output import plotworker
    if plotworker.wanted(sys.argv[1:]):
        plotworker.start(early=True)    # matplotlib's import overlaps click's, numpy's ...
    from .cli import main
    main()


if __name__ == "__main__":
    entry()
