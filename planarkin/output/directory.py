"""The output contract: the only code that touches a model's result directory.

After `planarkin run`, a model's directory holds exactly the files of one run and a summary.json
that describes them: complete results (status ok), results up to a failure (failed, with the
time) or up to an interruption (interrupted); for invalid input, the previous directory is left
untouched. How:

- everything is written into a temporary sibling ``.NAME.tmp-PID`` and renamed into place at the
  end (at an interruption too), atomically where the kernel can exchange two directories
  (renameat2 RENAME_EXCHANGE, Linux), else by two renames;
- ``.NAME.lock`` (flock, released by the kernel even when the process is killed) refuses a
  concurrent run into the same directory; temporaries left by a killed run are removed by the next;
- a directory that exists but is not a planarkin result (no summary.json of ours) is never
  replaced;
- tables are formatted by writer processes (`ProcessSink`) fed through pipes with SIGINT and
  SIGTERM held back while a block is sent, so every table holds the same complete rows whenever
  the run stops; the writers ignore those signals (the parent stops them in order), close every
  descriptor they inherit (`close_inherited`: no writer holds another's pipe or the parent's
  stdout) and so exit on end of file if the parent dies; they are always joined (`close`,
  `kill`).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import json
import os
import re
import shutil
import signal
import struct
import time
from pathlib import Path

import numpy as np

from .summary import ColumnStats
from .tables import CsvWriter

_SIGNALS = {signal.SIGINT, signal.SIGTERM}
_HEADER = struct.Struct("<qq")     # rows, columns of a float64 block
_JOIN_SECONDS = 30.0               # a writer that has not finished by then is killed
_PIPE_BYTES = 8 << 20              # room for a few chunks in flight (Linux F_SETPIPE_SZ)
_PORTABLE = re.compile(r"[^A-Za-z0-9._-]")


class OutputError(Exception):
    """The results cannot be written where asked (busy, not ours, not writable)."""


class Interrupted(BaseException):
    """SIGTERM arrived (SIGINT arrives as KeyboardInterrupt): stop, keep what is complete."""


# SIGINT and SIGTERM are Python-level handlers while a run is interruptible: a handler always
# runs in the main thread, whichever thread the kernel delivered the signal to (BLAS threads do
# not block it), so holding signals back is a flag the handler reads, not a signal mask alone.
_held = 0                  # depth of held_signals() blocks
_pending: int | None = None   # a signal that arrived while held


def _raise_for(signum: int):
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Interrupted(signum)


def _on_signal(signum, frame):
    global _pending, _deferred
    if _held:
        _pending = signum
        return
    if _in_finalizer(frame):
        # an exception raised inside a __del__ (the garbage collector ran one, e.g. of a
        # multiprocessing connection, when the signal came) is printed as "Exception ignored"
        # with its traceback and dropped, and the run would go on: the signal is sent again
        # once the finalizer has returned, if the run is still interruptible by then (else it
        # came as the run ended, and the run is over)
        import threading
        _deferred = signum
        timer = threading.Timer(0.005, _resend, (signum,))
        timer.daemon = True
        timer.start()
        return
    _raise_for(signum)


_deferred: int | None = None       # a signal that came during a finalizer, to be sent again


def _drop_deferred():
    global _deferred
    _deferred = None


def _resend(signum: int):
    global _deferred
    if _deferred == signum and signal.getsignal(signum) is _on_signal:
        _deferred = None
        os.kill(os.getpid(), signum)


def _in_finalizer(frame) -> bool:
    """Whether frame runs inside a __del__ method."""
    while frame is not None:
        if frame.f_code.co_name == "__del__":
            return True
        frame = frame.f_back
    return False


@contextlib.contextmanager
def interruptible():
    """While inside, SIGINT raises KeyboardInterrupt and SIGTERM raises Interrupted in the main
    thread, except inside held_signals() blocks, after which they are raised; the previous
    handlers are restored."""
    try:
        old = {s: signal.signal(s, _on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    except ValueError:                      # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        _drop_deferred()
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def held_signals():
    """SIGINT and SIGTERM wait until the block is done (they are raised right after), so that a
    block of rows is never half sent, a count never left behind, and a shutdown never cut
    short. The thread's signal mask is held too, so that a process forked inside starts with
    the signals blocked (it ignores them before it unblocks them)."""
    global _held, _pending
    try:
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    except (AttributeError, ValueError, OSError):     # no signal masks here
        mask = None
    _held += 1
    try:
        yield
    finally:
        _held -= 1
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if not _held and _pending is not None:
            signum, _pending = _pending, None
            _raise_for(signum)


# -- directories ------------------------------------------------------------------------------

def safe_name(stem: str) -> str:
    """A portable directory name for a model: letters, digits, '.', '_' and '-'; no leading dot
    (hidden, and our temporaries start with one); never '', '.' or '..'."""
    name = _PORTABLE.sub("_", stem).lstrip(".")
    return name[:100] or "model"


def out_dirs(models, out: Path) -> list[Path]:
    """One distinct directory under `out` for each model argument, in order: the file's stem
    made portable, then -2, -3 ... for repeats, never colliding with another model's own name,
    case-insensitively (the same file given twice is analysed twice, into two directories)."""
    out = Path(out)
    names = [safe_name(Path(str(m)).stem) for m in models]
    natural = {n.lower() for n in names}
    taken: set[str] = set()
    dirs = []
    for n in names:
        cand, k = n, 1
        while cand.lower() in taken or (cand != n and cand.lower() in natural):
            k += 1
            cand = f"{n}-{k}"
        taken.add(cand.lower())
        dirs.append(out / cand)
    return dirs


def _is_ours(path: Path) -> bool:
    """True when path is absent, an empty directory, or a planarkin result directory."""
    if not path.exists():
        return True
    if not path.is_dir() or path.is_symlink():
        return False
    entries = list(path.iterdir())
    if not entries:
        return True
    try:
        with open(path / "summary.json", encoding="utf-8") as f:
            return "planarkin" in json.load(f)
    except (OSError, ValueError):
        return False


def _exchange(a: Path, b: Path) -> bool:
    """Swap two directories atomically (Linux renameat2 RENAME_EXCHANGE); False if unsupported."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    AT_FDCWD, RENAME_EXCHANGE = -100, 2
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    r = fn(AT_FDCWD, os.fsencode(a), AT_FDCWD, os.fsencode(b), RENAME_EXCHANGE)
    if r == 0:
        return True
    e = ctypes.get_errno()
    if e in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP if hasattr(errno, "ENOTSUP") else -1):
        return False
    raise OSError(e, os.strerror(e), str(b))


class ResultDirectory:
    """A model's result directory being written: files go to `tmp`; `commit()` puts them in
    place of `final`, `abandon()` leaves `final` as it was. Raises OutputError when `final` is
    being written by another run, is not a planarkin result, or cannot be written."""

    def __init__(self, final: Path):
        self.final = Path(final)
        parent = self.final.parent
        name = self.final.name
        self.lockfd = None
        try:
            parent.mkdir(parents=True, exist_ok=True)
            self.lockfd = os.open(parent / f".{name}.lock", os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise OutputError(f"cannot write results into {parent}/: {e.strerror}") from None
        try:
            import fcntl
            fcntl.flock(self.lockfd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self._unlock()
            raise OutputError(f"{self.final}/ is being written by another planarkin run; wait "
                              f"for it or choose another --out") from None
        except ImportError:        # no flock on this platform: no protection against a race
            pass
        if not _is_ours(self.final):
            self._unlock()
            raise OutputError(f"{self.final} exists and is not a planarkin result directory "
                              f"(no summary.json of ours): it is left alone; choose another "
                              f"--out or remove it")
        for stale in parent.glob(f".{name}.tmp-*"):      # left by a killed run (we hold the lock)
            shutil.rmtree(stale, ignore_errors=True)
        self.tmp = parent / f".{name}.tmp-{os.getpid()}"
        try:
            self.tmp.mkdir()
        except OSError as e:
            self._unlock()
            raise OutputError(f"cannot write results into {parent}/: {e.strerror}") from None

    def path(self, filename: str) -> Path:
        return self.tmp / filename

    def commit(self) -> None:
        """Put the new files in place of the old directory (which is then removed)."""
        try:
            if self.final.exists():
                if _exchange(self.tmp, self.final):
                    shutil.rmtree(self.tmp, ignore_errors=True)
                else:
                    old = self.final.parent / f".{self.final.name}.old-{os.getpid()}"
                    os.rename(self.final, old)
                    os.rename(self.tmp, self.final)
                    shutil.rmtree(old, ignore_errors=True)
            else:
                os.rename(self.tmp, self.final)
        finally:
            self._unlock()

    def abandon(self) -> None:
        """Remove what was written; the previous directory stays as it was."""
        shutil.rmtree(self.tmp, ignore_errors=True)
        self._unlock()

    def _unlock(self) -> None:
        if self.lockfd is not None:
            os.close(self.lockfd)        # releases the flock
            self.lockfd = None


def check_writable(out: Path) -> str | None:
    """None if result directories can be made under `out`, else why not (for a usage error)."""
    out = Path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".planarkin-probe-{os.getpid()}"
        probe.mkdir()
        probe.rmdir()
    except OSError as e:
        return f"cannot write into {out}/: {e.strerror}"
    return None


# -- table writers ----------------------------------------------------------------------------

class _Sink:
    """A table fed block by block in this process, with its column statistics (and a room's
    accumulator): subclasses say how a block is written (_write) and the file closed
    (_close)."""

    def __init__(self, header: list[str], accumulator=None):
        self.stats = ColumnStats(header)
        self.extra = accumulator() if accumulator is not None else None
        self.rows = 0
        self.busy = 0.0

    def add(self, X: np.ndarray) -> None:
        t0 = time.perf_counter()
        self._write(X)
        self.stats.add(X)
        if self.extra is not None:
            self.extra.add(X)
        self.rows += len(X)
        self.busy += time.perf_counter() - t0

    def close(self):
        """(column statistics, the accumulator's dict or None, seconds busy)"""
        t0 = time.perf_counter()
        self._close()
        self.busy += time.perf_counter() - t0
        return self.stats, (self.extra.as_dict() if self.extra is not None else None), self.busy

    def kill(self) -> None:
        with contextlib.suppress(Exception):
            self._close()


class TableSink(_Sink):
    """One CSV table."""

    def __init__(self, path: Path, header: list[str], accumulator=None):
        super().__init__(header, accumulator)
        self.csv = CsvWriter(path, header)

    def _write(self, X: np.ndarray) -> None:
        self.csv.write(X)

    def _close(self) -> None:
        self.csv.close()


class ParquetSink(_Sink):
    """One Parquet table (pyarrow, imported here only). Every block is one row group, so a file
    closed after an interruption holds complete rows only. Columns are float64 named by the CSV
    header (units in the names); doubles are stored as they are, so they read back bit for
    bit."""

    def __init__(self, path: Path, header: list[str], accumulator=None):
        super().__init__(header, accumulator)
        import pyarrow as pa
        import pyarrow.parquet as pq
        self.pa = pa
        self.schema = pa.schema([(h, pa.float64()) for h in header])
        # dictionary encoding would not pay for doubles that rarely repeat
        self.writer = pq.ParquetWriter(path, self.schema, use_dictionary=False)

    def _write(self, X: np.ndarray) -> None:
        if len(X):
            cols = [self.pa.array(np.ascontiguousarray(X[:, k])) for k in range(X.shape[1])]
            self.writer.write_table(self.pa.Table.from_arrays(cols, schema=self.schema))

    def _close(self) -> None:
        self.writer.close()


SINKS = {"csv": TableSink, "parquet": ParquetSink}     # by table format (spec.TABLE_FORMATS)


def close_inherited(keep, keep_stderr: bool = False) -> None:
    """In a forked child: close every descriptor inherited from the parent except `keep`, and
    point stdin and stdout (and stderr unless keep_stderr) at /dev/null. A child holding the
    write end of its own pipe, or of a sibling's, never sees end of file when the parent dies,
    and one holding the parent's stdout keeps whoever reads it (a CI job, a shell pipe)
    waiting after the parent has exited."""
    keep = {int(fd) for fd in keep} | {0, 1, 2}
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1) if keep_stderr else (0, 1, 2):
        os.dup2(null, fd)
    try:
        fds = [int(n) for n in os.listdir("/proc/self/fd")]
    except OSError:
        fds = range(3, min(os.sysconf("SC_OPEN_MAX"), 65536))
    for fd in fds:
        if fd not in keep:
            with contextlib.suppress(OSError):
                os.close(fd)


def _writer_main(path, header, accumulator, inbox, outbox, kind=TableSink) -> None:
    """Body of a writer process: blocks of rows in (a header of rows and columns, then the
    float64 data; an empty message ends the table), statistics out."""
    for s in _SIGNALS:
        signal.signal(s, signal.SIG_IGN)       # the parent stops us in order
    with contextlib.suppress(AttributeError, ValueError, OSError):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)   # forked with them held
    close_inherited((inbox.fileno(), outbox.fileno()))   # end of file when the parent dies
    try:
        sink = kind(path, header, accumulator)
        while True:
            try:
                msg = inbox.recv_bytes()
            except EOFError:                   # the parent is gone: nothing to report to
                os._exit(1)
            if not msg:
                break
            rows, cols = _HEADER.unpack_from(msg)
            sink.add(np.frombuffer(msg, dtype=np.float64, offset=_HEADER.size).reshape(rows, cols))
        outbox.send(("ok", sink.close()))
    except BaseException as e:  # noqa: BLE001 - reported by the parent
        with contextlib.suppress(Exception):
            outbox.send(("error", f"{type(e).__name__}: {e}"))
    finally:
        os._exit(0)   # no atexit handlers or buffered output inherited from the parent


class WriteError(Exception):
    """A table could not be written (disk full, file size limit, I/O error)."""


class ProcessSink:
    """A TableSink (or another sink class `kind`, e.g. ParquetSink) in a forked process: add()
    sends the block through a pipe (large enough to hold a few chunks) and returns, so
    formatting runs in parallel with the solver."""

    def __init__(self, ctx, path: Path, header: list[str], accumulator=None, kind=TableSink):
        self.name = Path(path).name
        r, self.inbox = ctx.Pipe(duplex=False)
        self.outbox, w = ctx.Pipe(duplex=False)
        _grow_pipe(self.inbox)
        self.rows = 0
        with held_signals():      # the caller holds them too, until the sink is registered
            self.proc = ctx.Process(target=_writer_main, daemon=True,
                                    args=(path, header, accumulator, r, w, kind))
            self.proc.start()
            r.close()
            w.close()

    def add(self, X: np.ndarray) -> None:
        X = np.ascontiguousarray(X, dtype=np.float64)
        try:
            with held_signals():
                self.inbox.send_bytes(_HEADER.pack(*X.shape) + X.tobytes())
        except (BrokenPipeError, ConnectionError, OSError):
            raise WriteError(f"writing {self.name} failed: {self._reason()}") from None
        self.rows += len(X)

    def _reason(self) -> str:
        with contextlib.suppress(Exception):
            if self.outbox.poll(_JOIN_SECONDS):
                status, payload = self.outbox.recv()
                if status == "error":
                    return payload
        return "the writer process ended"

    def close(self):
        """End the table; returns what TableSink.close returns. Raises WriteError."""
        try:
            with held_signals():
                try:
                    self.inbox.send_bytes(b"")
                except (BrokenPipeError, ConnectionError, OSError):
                    raise WriteError(f"writing {self.name} failed: {self._reason()}") from None
                if not self.outbox.poll(_JOIN_SECONDS):
                    raise WriteError(f"writing {self.name} failed: the writer did not finish "
                                     f"within {_JOIN_SECONDS:g} s")
                try:
                    status, payload = self.outbox.recv()
                except (EOFError, OSError):
                    raise WriteError(f"writing {self.name} failed: the writer process "
                                     f"ended") from None
            if status != "ok":
                raise WriteError(f"writing {self.name} failed: {payload}")
            return payload
        finally:
            self.kill()

    def kill(self) -> None:
        """Release the process and its pipes, whatever state they are in."""
        for c in (self.inbox, self.outbox):
            with contextlib.suppress(OSError):
                c.close()
        with held_signals():
            self.proc.join(timeout=2.0)
            if self.proc.is_alive():
                self.proc.kill()
                self.proc.join()
            with contextlib.suppress(Exception):
                self.proc.close()


def _grow_pipe(conn) -> None:
    import fcntl
    F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
    with contextlib.suppress(OSError, ValueError):
        fcntl.fcntl(conn.fileno(), F_SETPIPE_SZ, _PIPE_BYTES)


def fork_context():
    """multiprocessing's fork context, or None where fork does not exist."""
    import multiprocessing as mp
    try:
        return mp.get_context("fork")
    except ValueError:
        return None
