"""The progress line of a long synth or fit on stderr: evaluations so far, their rate and the
best sum of squares so far. On a terminal one line is rewritten in place (a few times a
second); otherwise (a log, a CI job) a line is written every LINE_EVERY seconds. A search
shorter than the first interval prints nothing, so short runs and tests stay quiet.
"""

from __future__ import annotations

import math
import sys
import time

TTY_EVERY = 0.5       # s between rewrites of the line on a terminal
LINE_EVERY = 5.0      # s between lines in a log


class SearchProgress:
    """Called as progress(evaluations, best) by the search (planarkin.synthesis.synth.
    Synthesis.tick, fit's evaluations); close() before the command prints its own lines.
    quiet: print nothing. stream: default sys.stderr, looked up when the object is made."""

    def __init__(self, what: str, quiet: bool = False, stream=None, clock=time.monotonic):
        self.what = what
        self.quiet = quiet
        self.stream = stream if stream is not None else sys.stderr
        try:
            self.tty = bool(self.stream.isatty())
        except (AttributeError, ValueError):
            self.tty = False
        self.clock = clock
        self.every = TTY_EVERY if self.tty else LINE_EVERY
        self.t0 = clock()
        self.next = self.t0 + self.every
        self.shown = False

    def __call__(self, evaluations: int, best: float) -> None:
        if self.quiet:
            return
        now = self.clock()
        if now < self.next:
            return
        self.next = now + self.every
        elapsed = now - self.t0
        rate = evaluations / elapsed if elapsed > 0 else 0.0
        text = (f"{self.what}: {evaluations} evaluations ({rate:.3g}/s), best sum of squares "
                + (f"{best:.3g}" if math.isfinite(best) else "none yet") + f", {elapsed:.0f} s")
        try:
            if self.tty:
                self.stream.write("\r" + text + "\x1b[K")
            else:
                self.stream.write(text + "\n")
            self.stream.flush()
        except (OSError, ValueError):   # a closed or broken stderr must not stop the search
            self.quiet = True
            return
        self.shown = True

    def close(self) -> None:
        """Clear the line on a terminal (the command's report follows)."""
        if self.tty and self.shown and not self.quiet:
            try:
                self.stream.write("\r\x1b[K")
                self.stream.flush()
            except (OSError, ValueError):
                pass
        self.shown = False
