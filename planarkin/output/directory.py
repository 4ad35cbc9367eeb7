"""The output contract: the only code that touches a model's result directory.

After `planarkin run`, a model's directory holds the files of one run and a summary.json that
describes them (``files``, ``plots``): complete results (status ok), results up to a failure
(failed, with the time) or up to an interruption (interrupted); for invalid input the previous
directory is left untouched. Everything happens in the process that solves:

- the run writes into a temporary sibling ``.NAME.tmp-PID`` and puts it in place with
  `os.replace` at the end (at an interruption too). When NAME exists it is first moved aside to
  ``.NAME.old-PID``, the new directory replaces it, and the old one is removed. The window: for
  the microseconds between the two renames NAME does not exist; a process killed exactly then
  (SIGKILL, power loss) leaves the previous results in ``.NAME.old-PID``, and the next run into
  NAME puts them back before it starts;
- ``.NAME.lock`` (flock: the kernel releases it even when the process is killed) refuses a
  concurrent run into the same directory. It exists only while a run writes: it is unlinked
  before it is released, and a run that took the lock checks that the file it locked is still
  the one at that path (else it lost a race with a run ending and tries again). A killed run's
  lock file and temporaries are removed by the next run;
- a directory that exists but is not a planarkin result (no summary.json of ours, and not only
  the files of the study commands) is never replaced;
- the study commands (sweep, tolerance, tradeoff) own their files in the same directory
  (`STUDY_FILES`): a run keeps them (hard links into the new directory), a study replaces only
  its own, under the same lock (`locked`), so neither deletes the other's files;
- SIGINT and SIGTERM raise `Interrupted` (a KeyboardInterrupt) in the main thread while a run is
  `interruptible` (one lost in a finalizer is raised again at the next `checkpoint`, between
  blocks of rows, models and files); inside a `critical` block (a block of rows going to every table, summary.json
  and the rename) a signal waits until the block ends. Only the first signal counts: a second
  one (a Ctrl-C reaches every process of the group) is ignored while the run stops in order.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shutil
import signal
import sys
import time
from pathlib import Path

import numpy as np

from .summary import ColumnStats
from .tables import CsvWriter

_PORTABLE = re.compile(r"[^A-Za-z0-9._-]")
PLOT_FORMATS = ("png", "svg", "pdf")
# the files of the study commands in a model's directory (planarkin.studies.sweep, tolerance,
# planarkin.tradeoff): `run` keeps them, and they are never a run's
STUDY_FILES = frozenset(
    ["sweep.csv", "sweep.parquet", "tolerance.csv", "samples.csv", "sensitivities.csv",
     "tradeoff.csv", "tradeoff.png"]
    + [f"{stem}.{f}" for stem in ("sweep", "tolerance") for f in PLOT_FORMATS])


# failures of the disk rather than of the path asked for (a full disk, a quota, a file size
# limit, an I/O error): exit 1 as an analysis failure, where a path that cannot hold results
# (not a directory, a link to nowhere, no permission) is a usage error (exit 2)
DISK_ERRORS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO})


class OutputError(Exception):
    """The results cannot be written where asked (busy, not ours, not writable)."""


class WriteError(Exception):
    """A file could not be written (disk full, file size limit, I/O error). errno: the
    OSError's, when there was one."""

    def __init__(self, message: str, code: int | None = None):
        super().__init__(message)
        self.errno = code


def path_error(e: OSError, where: Path) -> Exception:
    """The error to raise for e, met while making or writing in the directory `where`:
    WriteError for the disk's own failures (DISK_ERRORS), else OutputError."""
    if e.errno in DISK_ERRORS:
        return WriteError(f"cannot write into {where}/: {e.strerror}", e.errno)
    return OutputError(f"cannot write results into {where}/: {e.strerror or e}")


def link_problem(path: Path) -> str | None:
    """Why a result directory cannot be path when path is a symbolic link (one to nowhere
    made mkdir fail with a bare "File exists", and the final rename with "Not a directory"),
    or a file; None otherwise."""
    if path.is_symlink():
        target = os.readlink(path)
        if not path.exists():
            return (f"{path} is a symbolic link to {target}, which does not exist: create "
                    f"{target} or remove the link, or choose another --out")
        if not path.is_dir():
            return (f"{path} is a symbolic link to {target}, which is not a directory: remove "
                    f"the link or choose another --out")
    elif path.exists() and not path.is_dir():
        return f"{path} is a file, not a directory: remove it or choose another --out"
    return None


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: stop, keep what is complete. `signame` says which."""

    def __init__(self, signame: str = "SIGINT"):
        super().__init__(signame)
        self.signame = signame


def signame(e: BaseException) -> str:
    """"SIGINT" or "SIGTERM": the signal behind an interruption (a bare KeyboardInterrupt is a
    Ctrl-C)."""
    return getattr(e, "signame", "SIGINT")


# -- interruption ------------------------------------------------------------------------------
# A Python signal handler always runs in the main thread, between bytecodes: it raises there,
# unless a critical block runs (then the block raises as it ends). Raised inside a finalizer or
# a weakref callback (the garbage collector runs them anywhere) the exception cannot propagate:
# Python hands it to sys.unraisablehook, which prints "Exception ignored". While interruptible,
# that hook drops it quietly and the next checkpoint() raises it again.

class _Stop:
    requested: str | None = None    # the first signal's name, once one came
    raised = False                  # Interrupted was raised for it (and not swallowed)
    critical = 0                    # depth of critical() blocks


def _raise() -> None:
    _Stop.raised = True
    raise Interrupted(_Stop.requested)


def _on_signal(signum, frame):
    if _Stop.requested is not None:
        return                      # stopping already: further signals are ignored
    _Stop.requested = signal.Signals(signum).name
    if _Stop.critical:
        return                      # raised as the block ends
    _raise()


def _unraisable(hook):
    def swallow(u):
        if isinstance(u.exc_value, Interrupted) and _Stop.requested is not None:
            _Stop.raised = False    # lost in a finalizer: the next checkpoint raises it
            return
        hook(u)
    return swallow


def checkpoint(stop=None) -> None:
    """Raise Interrupted if a signal came and was not raised yet (or, with stop, a shared
    multiprocessing value, when the parent asked this worker to stop: it holds the signal's
    number); called between blocks of rows."""
    if _Stop.requested is None and stop is not None and stop.value:
        _Stop.requested = signal.Signals(stop.value).name
    if _Stop.requested is not None and not _Stop.raised and not _Stop.critical:
        _raise()


def stop_requested() -> str | None:
    """The name of the signal that stops this run, or None."""
    return _Stop.requested


@contextlib.contextmanager
def interruptible():
    """While inside, SIGINT and SIGTERM raise Interrupted in the main thread (see critical());
    the previous handlers are restored after."""
    try:
        old = {s: signal.signal(s, _on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    except ValueError:                      # not the main thread: leave signals alone
        yield
        return
    _Stop.requested, _Stop.raised, _Stop.critical = None, False, 0
    hook = sys.unraisablehook
    sys.unraisablehook = _unraisable(hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        for s, h in old.items():
            signal.signal(s, h)


@contextlib.contextmanager
def critical():
    """A block a signal must not cut (rows half sent to the tables, a directory half renamed):
    a signal arriving inside is raised as the block ends."""
    _Stop.critical += 1
    try:
        yield
    finally:
        _Stop.critical -= 1
        if not _Stop.critical and _Stop.requested is not None and not _Stop.raised:
            _raise()


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
    """True when path is absent, an empty directory, a planarkin result directory, or holds
    only the files of the study commands."""
    if not os.path.lexists(path):
        return True
    if not path.is_dir() or path.is_symlink():
        return False
    entries = {p.name for p in path.iterdir()}
    if entries <= STUDY_FILES:
        return True
    try:
        with open(path / "summary.json", encoding="utf-8") as f:
            return "planarkin" in json.load(f)
    except (OSError, ValueError):
        return False


class _Lock:
    """``.NAME.lock`` beside NAME, held with flock while a run or a study writes NAME, unlinked
    as it is released (no litter). Raises OutputError when another process holds it."""

    def __init__(self, final: Path):
        self.path = final.parent / f".{final.name}.lock"
        self.fd = None
        try:
            import fcntl
        except ImportError:          # no flock on this platform: no protection against a race
            return
        while True:
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            except OSError as e:
                raise path_error(e, final.parent) from None
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                raise OutputError(f"{final}/ is being written by another planarkin run; wait "
                                  f"for it or choose another --out") from None
            try:
                st = os.stat(self.path)
                mine = os.fstat(fd)
                same = (st.st_ino, st.st_dev) == (mine.st_ino, mine.st_dev)
            except FileNotFoundError:
                same = False
            if same:
                self.fd = fd
                return
            os.close(fd)             # the file was unlinked by a run that ended: again

    def release(self) -> None:
        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.unlink(self.path)     # before the release: nobody locks a dead file
            os.close(self.fd)
            self.fd = None


@contextlib.contextmanager
def locked(final: Path):
    """Hold NAME's lock (a study writing its files into a model's directory). Raises
    OutputError when a run or another study writes NAME."""
    final = Path(final)
    _make_parent(final)
    lock = _Lock(final)
    try:
        _restore(final)
        problem = link_problem(final)
        if problem is not None:
            raise OutputError(problem)
        yield
    finally:
        lock.release()


def _make_parent(final: Path) -> None:
    """final's parent directory, made when missing (OutputError or WriteError when it cannot
    be)."""
    problem = next((p for p in map(link_problem, reversed(final.parents)) if p), None)
    if problem is not None:
        raise OutputError(problem)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise path_error(e, final.parent) from None


def _restore(final: Path) -> None:
    """Put back the previous results a run killed between its two renames left aside."""
    if not os.path.lexists(final):
        for old in sorted(final.parent.glob(f".{final.name}.old-*")):
            os.replace(old, final)
            break
    for stale in final.parent.glob(f".{final.name}.old-*"):
        shutil.rmtree(stale, ignore_errors=True)


class ResultDirectory:
    """A model's result directory being written: files go to `tmp`; `commit()` puts them in
    place of `final`, `abandon()` leaves `final` as it was. Raises OutputError when `final` is
    being written by another run, is not a planarkin result, or cannot be written."""

    def __init__(self, final: Path):
        self.final = Path(final)
        parent = self.final.parent
        name = self.final.name
        _make_parent(self.final)
        self.lock = _Lock(self.final)
        try:
            _restore(self.final)
            if self.final.is_symlink():      # (replaced, not followed, by the final rename)
                raise OutputError(link_problem(self.final) or
                                  f"{self.final} is a symbolic link to "
                                  f"{os.readlink(self.final)}: a result directory is never "
                                  f"written through a link; remove it or choose another --out")
            if not _is_ours(self.final):
                raise OutputError(f"{self.final} exists and is not a planarkin result directory "
                                  f"(no summary.json of ours): it is left alone; choose another "
                                  f"--out or remove it")
            for stale in parent.glob(f".{name}.tmp-*"):    # left by a killed run (we hold the lock)
                shutil.rmtree(stale, ignore_errors=True)
            self.tmp = parent / f".{name}.tmp-{os.getpid()}"
            try:
                self.tmp.mkdir()
            except OSError as e:
                raise path_error(e, parent) from None
        except BaseException:
            self.lock.release()
            raise

    def path(self, filename: str) -> Path:
        return self.tmp / filename

    def commit(self) -> None:
        """Put the new files in place of the old directory (which is then removed), keeping the
        study commands' files."""
        try:
            if self.final.exists():
                for name in STUDY_FILES:
                    src = self.final / name
                    if src.is_file() and not (self.tmp / name).exists():
                        try:
                            os.link(src, self.tmp / name)
                        except OSError:          # no hard links here
                            shutil.copy2(src, self.tmp / name)
                old = self.final.parent / f".{self.final.name}.old-{os.getpid()}"
                os.replace(self.final, old)
                os.replace(self.tmp, self.final)
                shutil.rmtree(old, ignore_errors=True)
            else:
                os.replace(self.tmp, self.final)
        finally:
            self.lock.release()

    def abandon(self) -> None:
        """Remove what was written; the previous directory stays as it was."""
        shutil.rmtree(self.tmp, ignore_errors=True)
        self.lock.release()


def check_writable(out: Path) -> str | None:
    """None if result directories can be made under `out`, else why not, naming the fix (a
    usage error). Raises WriteError when the disk itself fails (DISK_ERRORS)."""
    out = Path(out)
    problem = next((p for p in map(link_problem, [*reversed(out.parents), out]) if p), None)
    if problem is not None:
        return problem
    # the folders made for the probe are removed again: a command refused later (invalid
    # input, a study too large) leaves nothing on disk, not even an empty --out
    made = [d for d in [*reversed(out.parents), out] if not d.exists()]
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".planarkin-probe-{os.getpid()}"
        probe.mkdir()
        probe.rmdir()
    except OSError as e:
        if e.errno in DISK_ERRORS:
            raise WriteError(f"cannot write into {out}/: {e.strerror}", e.errno) from None
        return f"cannot write into {out}/: {e.strerror}: choose another --out"
    finally:
        for d in reversed(made):
            try:
                d.rmdir()
            except OSError:
                break               # not made here after all (another run), or not empty
    return None


# -- table writers ----------------------------------------------------------------------------

class _Sink:
    """A table fed block by block, with its column statistics (and a room's accumulator):
    subclasses say how a block is written (_write) and the file closed (_close). An OSError
    (disk full, a file size limit) becomes WriteError naming the file."""

    def __init__(self, path: Path, header: list[str], accumulator=None):
        self.name = Path(path).name
        self.stats = ColumnStats(header)
        self.extra = accumulator() if accumulator is not None else None
        self.rows = 0
        self.busy = 0.0

    def add(self, X: np.ndarray) -> None:
        t0 = time.perf_counter()
        try:
            self._write(X)
        except OSError as e:
            raise WriteError(f"writing {self.name} failed: {e.strerror or e}", e.errno) from None
        self.stats.add(X)
        if self.extra is not None:
            self.extra.add(X)
        self.rows += len(X)
        self.busy += time.perf_counter() - t0

    def close(self):
        """(column statistics, the accumulator's dict or None, seconds busy)"""
        t0 = time.perf_counter()
        try:
            self._close()
        except OSError as e:
            raise WriteError(f"writing {self.name} failed: {e.strerror or e}", e.errno) from None
        self.busy += time.perf_counter() - t0
        return self.stats, (self.extra.as_dict() if self.extra is not None else None), self.busy

    def kill(self) -> None:
        with contextlib.suppress(Exception):
            self._close()


class TableSink(_Sink):
    """One CSV table."""

    def __init__(self, path: Path, header: list[str], accumulator=None):
        super().__init__(path, header, accumulator)
        try:
            self.csv = CsvWriter(path, header)
        except OSError as e:
            raise WriteError(f"writing {self.name} failed: {e.strerror or e}", e.errno) from None

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
        super().__init__(path, header, accumulator)
        import pyarrow as pa
        import pyarrow.parquet as pq
        self.pa = pa
        self.schema = pa.schema([(h, pa.float64()) for h in header])
        # dictionary encoding would not pay for doubles that rarely repeat
        try:
            self.writer = pq.ParquetWriter(path, self.schema, use_dictionary=False)
        except OSError as e:
            raise WriteError(f"writing {self.name} failed: {e.strerror or e}", e.errno) from None

    def _write(self, X: np.ndarray) -> None:
        if len(X):
            cols = [self.pa.array(np.ascontiguousarray(X[:, k])) for k in range(X.shape[1])]
            self.writer.write_table(self.pa.Table.from_arrays(cols, schema=self.schema))

    def _close(self) -> None:
        self.writer.close()


SINKS = {"csv": TableSink, "parquet": ParquetSink}     # by table format (spec.TABLE_FORMATS)
