"""Where numba caches the compiled route (planarkin.solver.compiled), checked before numba
reads it.

numba's disk cache holds pickles that it loads and runs; planarkin gives it a directory only the
user can write and vouches for every file in it:

- the directory: PLANARKIN_CACHE, else $XDG_CACHE_HOME/planarkin/numba, else
  ~/.cache/planarkin/numba, created with mode 0700; it and its entry must be directories (not
  links) owned by the current user and not writable by group or others, else the route
  compiles in memory only (no disk cache: slower to start, the same results), said in one
  line;
- an entry per source version: a subdirectory named by the hash of the compiled route's
  sources and the Python version (numba
  keys its files on each source file's own contents only, a hash of that one file, and a change
  in one module would leave the functions of another inlined stale);
- in it, gen/: the kernels generated per mechanism structure (planarkin.solver.compiled.gen), Python
  sources that planarkin.solver.compiled.kernels runs only while their bytes are the text it generates
  (otherwise it writes them again, atomically), numba's files for them beside the others;
- a manifest (manifest.json: file -> sha256) written, atomically, after every load or
  compile; before numba is imported, every file in the entry that the manifest does not name
  with its exact hash (truncated, garbled, foreign, or left by a process that died) is
  deleted, so that numba compiles it again and never reads it.

A lock (flock, where the platform has it) serialises processes from prepare() to record(), so
that one process's manifest never names another's half-written files. A process waits for it
LOCK_WAIT seconds at most (another run may hold it for as long as it is suspended, with Ctrl-Z
during its first compile), then says so in one line and compiles without the cache. A cache
that cannot be written (a full disk, a file size limit) costs only the caching: the compile
goes on in memory, said in one line (compile_cached()). Either line once per process.

A generated kernel (seconds to compile) is compiled without that lock: under a lock of its own
(compiling(): a process that needs the same kernel waits for it, up to KERNEL_WAIT seconds or
until that process is seen stopped, then loads it), into a staging directory of its own beside
the entries, whose files are then moved into the entry under the entry's lock (publish()).
Processes that compile different structures (a parallel batch, the workers of a test run)
compile side by side, and every kernel lands in the cache. A kernel whose numba files are in
the entry but do not load (planarkin.solver.compiled.kernels._cached) compiles that way too.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import stat
import sys
import tempfile
import time
from pathlib import Path

# the modules numba compiles and caches (the generated kernels' names hash their generator)
SOURCES = ("solver/compiled/points.py", "solver/compiled/helpers.py", "elements/pointline.py")
MANIFEST = "manifest.json"
LOCK_WAIT = 5.0           # seconds to wait for another process's hold on the entry
KERNEL_WAIT = 300.0       # for another process compiling the same kernel (the largest: minutes)
STALE = 3600.0            # a staging directory left this long ago (its process killed) goes
_held: dict = {}          # "dir": the entry prepared; "lock": its lock file, while held
_said: set = set()        # the lines said (once per process)
_seeded: dict = {}        # staging directory -> {file: stamp} of the entry's files copied in


def _say(key: str, line: str) -> None:
    if key not in _said:
        _said.add(key)
        print(f"planarkin: {line}", file=sys.stderr, flush=True)


def unwritable(entry, e: OSError) -> None:
    """The cache cannot be written (e): said once, and not used again by this process."""
    _say("unwritable", f"the compiled code's cache {entry} cannot be written "
                       f"({e.strerror or e}): compiling without it (the results are the same)")
    _held["dir"] = None


def base_dir() -> Path:
    env = os.environ.get("PLANARKIN_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "planarkin" / "numba"


def tag() -> str:
    """The entry's name: the hash of the compiled route's sources and the Python version."""
    h = hashlib.sha256(sys.version.encode())
    package = Path(__file__).parent.parent.parent
    for name in SOURCES:
        h.update((package / name).read_bytes())
    return h.hexdigest()[:16]


def private(path: Path) -> bool:
    """path is a directory (not a link) owned by this user, not writable by group or others
    (where the platform has owners: elsewhere a directory will do)."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    if not stat.S_ISDIR(st.st_mode):
        return False
    if hasattr(os, "getuid"):
        return st.st_uid == os.getuid() and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)
    return True


def _make(path: Path) -> bool:
    try:
        os.makedirs(path, mode=0o700, exist_ok=True)
    except OSError as e:
        unwritable(path, e)
        return False
    if private(path):
        return True
    # (every run then compiles every kernel again: said, or a user sees only slow runs)
    _say("shared", f"the compiled code's cache {path} is not a private folder (a link, another "
                   f"user's, or writable by group or others): compiling without it (the "
                   f"results are the same; chmod 700 it, or set PLANARKIN_CACHE to another "
                   f"folder)")
    return False


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _stamp(path: Path) -> tuple:
    st = os.stat(path)
    return st.st_ino, st.st_size, st.st_mtime_ns


def _known_digest(path: Path, rel: str) -> str:
    """path's sha256, read again unless this process hashed it already (in prepare or a record)
    and its inode, size and modification time are unchanged since: the entry holds hundreds of
    files (numba's index and data for every kernel), and hashing them all at every record()
    cost a sweep time it need not spend, twice (benchmarks/README.md, "Figures moved from the
    code's comments")."""
    seen = _held.setdefault("seen", {})
    stamp = _stamp(path)
    old = seen.get(rel)
    if old is not None and old[0] == stamp:
        return old[1]
    d = _digest(path)
    seen[rel] = (stamp, d)
    return d


def _files(entry: Path):
    for p in sorted(entry.rglob("*")):
        if p.is_file() and p.name not in (MANIFEST, ".lock"):
            yield p


def _manifest(entry: Path) -> dict:
    try:
        m = json.loads((entry / MANIFEST).read_text())
    except (OSError, ValueError):
        return {}
    return m if isinstance(m, dict) else {}


def prepare() -> Path | None:
    """The checked cache entry for numba (NUMBA_CACHE_DIR set to it), or None: no usable
    directory (numba then compiles without a disk cache). Deletes every file of the entry the
    manifest does not vouch for; holds the entry's lock until record()."""
    if "dir" in _held:            # checked already: the lock again, for another compile
        if _held["dir"] is not None and "lock" not in _held and not _lock(_held["dir"]):
            _held["dir"] = None
        return _held["dir"]
    base = base_dir()
    entry = base / tag()
    if not (_make(base) and _make(entry) and _lock(entry)):
        _held["dir"] = None
        return None
    try:
        known = _manifest(entry)
        for p in _files(entry):
            rel = p.relative_to(entry).as_posix()
            if known.get(rel) != _known_digest(p, rel):
                p.unlink()
    except OSError as e:
        release()
        unwritable(entry, e)
        return None
    os.environ["NUMBA_CACHE_DIR"] = str(entry)
    _held["dir"] = entry
    return entry


def has(entry: Path, path: Path, entry_point: str) -> bool:
    """numba's index of the function entry_point of the generated module at path is in the
    entry (vouched for: prepare() left only such files)."""
    return any(entry.glob(f"*/{path.stem}.{entry_point}-*.nbi"))


@contextlib.contextmanager
def compiling(name: str):
    """The lock of the kernel name (another process compiling it holds it: waited for up to
    KERNEL_WAIT seconds, or until that process is seen stopped, then compiled here too) and a
    function that gives a fresh staging directory for numba's files, made and seeded on its
    first call (a process that waited finds the kernel published and needs none: seeding
    copies the entry's files of the kinds' functions), or None where it cannot be made; it is
    removed at the end (what publish() did not move is dropped). Yields None where there is
    no usable cache directory."""
    base = base_dir()
    if not private(base):
        yield None
        return
    for old in base.glob(".staging-*"):         # left by a process that was killed
        try:
            if time.time() - old.stat().st_mtime > STALE:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            pass
    lock, got = None, False
    try:
        lock = open(base / f".{tag()}.{name}.lock", "a+")
        # (not taken in time, or its holder stopped, with Ctrl-Z: compiled here too)
        got = _flock(lock, KERNEL_WAIT, stop=lambda: _stopped(_holder_pid(lock)))
        if got:
            _claim(lock)
    except (OSError, ImportError):              # (no flock: compiled here, as if not waited)
        pass
    made: list = []                             # [the staging directory or None], once made

    def stage():
        if not made:
            made.append(None)
            try:
                made[0] = Path(tempfile.mkdtemp(prefix=".staging-", dir=base))
                _seed(made[0])
            except OSError:                     # (no staging: compiled in memory)
                if made[0] is not None:
                    shutil.rmtree(made[0], ignore_errors=True)
                made[0] = None
        return made[0]
    try:                                        # (an interrupt while seeding: removed too)
        yield stage
    finally:
        if made and made[0] is not None:
            _seeded.pop(made[0], None)
            shutil.rmtree(made[0], ignore_errors=True)
        if lock is not None:
            if got:
                _unclaim(lock)
            lock.close()


def _seed(stage: Path) -> None:
    """The entry's numba files of planarkin's own modules (the kinds' functions a kernel calls,
    compiled once for all structures) copied into stage, under the entry's lock, so that the
    kernel's compile there loads them instead of compiling them again."""
    entry = prepare()
    try:
        if entry is not None:
            for d in entry.iterdir():
                if d.is_dir() and not d.name.startswith("gen"):
                    shutil.copytree(d, stage / d.name)
            # what publish() leaves alone: the copies the compile did not touch (the entry's
            # own may be newer by then)
            _seeded[stage] = {p: _stamp(p) for p in stage.rglob("*") if p.is_file()}
    finally:
        record()


def publish(stage: Path) -> bool:
    """numba's files compiled into stage moved into the checked entry (numba's data before its
    indexes, each atomically) and vouched for, under the entry's lock. False: not published
    (no usable entry; the compiled function still runs)."""
    entry = prepare()
    try:
        if entry is None or "lock" not in _held:
            return False
        seeded = _seeded.pop(stage, {})
        files = sorted((p for p in stage.rglob("*") if p.is_file()
                        and seeded.get(p) != _stamp(p)),
                       key=lambda p: (p.suffix == ".nbi", str(p)))
        for p in files:
            dest = entry / p.relative_to(stage)
            dest.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            os.replace(p, dest)
        return True
    except OSError as e:
        unwritable(entry, e)
        return False
    finally:
        record()


def _lock(entry: Path) -> bool:
    """Hold the entry's lock (False: not within LOCK_WAIT seconds, said once; or no lock file)."""
    try:
        lock = open(entry / ".lock", "a+")
    except OSError as e:
        unwritable(entry, e)
        return False
    try:
        got = _flock(lock, LOCK_WAIT)
    except ImportError:           # (no flock: Windows)
        _held["lock"] = lock
        return True
    except OSError:
        lock.close()
        return False
    if not got:
        holder = _holder(lock)
        lock.close()
        _say("locked", f"the compiled code's cache {entry} is held by another planarkin "
                       f"process{holder} for more than {LOCK_WAIT:g} s (suspended?): "
                       f"compiling without the cache")
        return False
    _claim(lock)                  # who holds it, for the line of a process that waits
    _held["lock"] = lock
    return True


def _claim(lock) -> None:
    """This process's pid into a lock file it holds (a waiting process reads it)."""
    try:
        lock.seek(0)
        lock.truncate()
        lock.write(str(os.getpid()))
        lock.flush()
    except OSError:
        pass


def _unclaim(lock) -> None:
    """No holder named once the lock is free."""
    try:
        lock.truncate(0)
    except OSError:
        pass


def _flock(lock, seconds: float, stop=None) -> bool:
    """lock's exclusive flock taken, waiting up to seconds for another process that holds it:
    False when it still does then, or as soon as stop() is true. ImportError where there is no
    flock, OSError where it fails."""
    import fcntl
    deadline = time.monotonic() + seconds
    while True:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if time.monotonic() >= deadline or (stop is not None and stop()):
                return False
            time.sleep(0.05)


def _holder_pid(lock) -> int | None:
    try:
        lock.seek(0)
        return int(lock.read(20).strip())
    except (OSError, ValueError):
        return None


def _holder(lock) -> str:
    pid = _holder_pid(lock)
    return "" if pid is None else f" (pid {pid})"


def _stopped(pid: int | None) -> bool:
    """The process pid is stopped (Ctrl-Z, SIGSTOP), where the platform says (Linux's /proc):
    a kernel's compile it holds the lock of will not end while it is."""
    if pid is None:
        return False
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            state = f.read().rsplit(b")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state in (b"T", b"t")


def compile_cached(fn, sig):
    """fn.compile(sig) for a numba dispatcher made with cache=True: its disk cache only under
    the entry's lock (without it, fn compiles in memory), and a cache that cannot be written
    (numba raises OSError as it saves, the overload already compiled) costs only the caching,
    said once."""
    cache = getattr(fn, "_cache", None)       # numba's FunctionCache (NullCache: cache=False)
    if "lock" not in _held and cache is not None:
        cache.disable()
    try:
        return fn.compile(sig)
    except OSError as e:
        if cache is None:
            raise
        cache.disable()
        unwritable(_held.get("dir") or base_dir(), e)
        return fn.compile(sig)


def record() -> None:
    """After numba loaded or compiled the route: the manifest of the entry's files as they are
    now (written atomically), then the lock released."""
    entry = _held.get("dir")
    try:
        if entry is not None and "lock" in _held:
            m = {}
            for p in _files(entry):
                rel = p.relative_to(entry).as_posix()
                m[rel] = _known_digest(p, rel)
            if m != _manifest(entry):
                tmp = entry / f".{MANIFEST}.{os.getpid()}"
                tmp.write_text(json.dumps(m, indent=0, sort_keys=True))
                os.replace(tmp, entry / MANIFEST)
    except OSError:
        pass
    finally:
        release()


def release() -> None:
    lock = _held.pop("lock", None)
    if lock is not None:
        _unclaim(lock)
        lock.close()


def forget() -> None:
    """Release the lock and forget the checked entry: the next prepare() checks again, as a new
    process does."""
    release()
    _held.clear()
