"""The tables' thread (planarkin/output/tablethread.py): blocks reach every sink in the order they
were put, join writes them all, an error in the thread is raised in the caller and drops the
blocks after it, stop drops what waits; and the directory writer built on it gives the same
bytes as the formatter called directly, in the same process."""

import threading

import numpy as np
import pytest

from planarkin.output.directory import WriteError
from planarkin.output.fastcsv import format_table
from planarkin.output.tablethread import DEPTH, TableThread


class Sink:
    def __init__(self, fail_at=None, gate=None):
        self.got = []
        self.fail_at = fail_at
        self.gate = gate
        self.thread = None
        self.entered = threading.Event()

    def add(self, X):
        self.entered.set()
        if self.gate is not None:
            self.gate.wait(5)
        self.thread = threading.current_thread()
        if self.fail_at is not None and len(self.got) == self.fail_at:
            raise WriteError("writing t.csv failed: File too large")
        self.got.append(X)


def test_blocks_arrive_in_order_in_another_thread():
    a, b = Sink(), Sink()
    T = TableThread([a, b])
    for k in range(20):
        T.put([np.full(3, k), np.full(2, -k)])
    T.join()
    assert [int(x[0]) for x in a.got] == list(range(20))
    assert [int(x[0]) for x in b.got] == [-k for k in range(20)]
    assert a.thread is not threading.current_thread() and not T.thread.is_alive()


def test_an_error_in_the_thread_is_raised_by_the_next_put_or_join():
    s = Sink(fail_at=2)
    T = TableThread([s])
    with pytest.raises(WriteError, match="File too large"):
        for k in range(50):
            T.put([np.full(1, k)])
        T.join()
    T.stop()
    assert len(s.got) == 2                       # nothing after the failed block
    assert not T.thread.is_alive()


def test_stop_drops_the_blocks_waiting():
    gate = threading.Event()
    s = Sink(gate=gate)
    T = TableThread([s])
    for k in range(DEPTH + 1):                   # one being written (held), DEPTH waiting
        T.put([np.full(1, k)])
    assert s.entered.wait(5)                     # the first block is being written
    stopper = threading.Thread(target=T.stop)
    stopper.start()
    gate.set()
    stopper.join(5)
    assert not T.thread.is_alive() and len(s.got) == 1


def test_the_writer_gives_the_formatters_bytes(tmp_path):
    import planarkin
    from planarkin.chunks import take
    from planarkin.layout import Layout
    from planarkin.output.writer import DirectoryWriter
    m = planarkin.load("mechanisms/slider-crank.yaml")
    r = planarkin.solve(m, steps=20000)
    w = DirectoryWriter(m, tmp_path / "out", r.info.options, plots=None)
    N = len(r.t)
    for a in range(0, N, 3000):                  # seven blocks through the thread
        w.add(take(r._chunk, np.arange(a, min(N, a + 3000))))
    summary = w.finish(r.info)
    assert summary["files"]["bodies.csv"]["rows"] == N
    L = Layout(m, r.info.options.order)
    X = L.body_table(r._chunk) + 0.0
    got = (tmp_path / "out" / "bodies.csv").read_bytes()
    assert got == (",".join(L.body_header) + "\n").encode() + format_table(X)
