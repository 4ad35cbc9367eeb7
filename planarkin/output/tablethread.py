"""The tables' thread: blocks of rows formatted and written while the next chunk is solved.

Formatting a block (planarkin.output.fastcsv) is a few hundred numpy passes over arrays of 16k
values, and numpy lets go of the GIL inside each pass, as it does while a file is written; so
the rows of one chunk are turned into text in this thread while the main thread solves the
next chunk and computes its forces (benchmarks/bench_process.py measures what it pays). The
blocks go through a queue of DEPTH blocks at most (memory stays bounded: a block is the rows of
one chunk) and reach every table in the order they were put, so the tables stay equal row for
row.

Only the main thread sees signals: an interruption there leaves the blocks already put to be
written by `join` (the directory writer calls it in a critical block), so the tables stop at
the same row, the last one counted. An error in the thread (disk full: WriteError) is kept and
raised in the main thread at the next `put` or at `join`; the blocks after it are dropped.
"""

from __future__ import annotations

import queue
import threading

DEPTH = 2    # blocks waiting at most: one being written, one more solved ahead


class TableThread:
    """Feeds blocks (one array per sink, in the sinks' order) to sinks (objects with add(X))
    in one daemon thread."""

    def __init__(self, sinks: list):
        self.sinks = list(sinks)
        self.queue: queue.Queue = queue.Queue(DEPTH)
        self.error: BaseException | None = None
        self.drop = False               # abandoned: the blocks still waiting are not written
        self.thread = threading.Thread(target=self._run, name="planarkin-tables", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while True:
            blocks = self.queue.get()
            if blocks is None:
                return
            if self.error is not None or self.drop:
                continue
            try:
                for s, X in zip(self.sinks, blocks):
                    s.add(X)
            except BaseException as e:  # noqa: BLE001 - raised in the main thread instead
                self.error = e

    def _raise(self) -> None:
        if self.error is not None:
            e, self.error = self.error, None
            self.drop = True
            raise e

    def put(self, blocks: list) -> None:
        """Queue one block for every sink (waits while DEPTH blocks wait); raises the thread's
        error, if one came."""
        self._raise()
        self.queue.put(blocks)

    def join(self) -> None:
        """Write every block put, end the thread; raises its error, if one came."""
        if self.thread.is_alive():
            self.queue.put(None)
            self.thread.join()
        self._raise()

    def stop(self) -> None:
        """End the thread without writing the blocks still waiting (the block being written
        is finished first); its error, if any, is dropped."""
        self.drop = True
        if self.thread.is_alive():
            self.queue.put(None)
            self.thread.join()
        self.error = None
