"""The generated grid kernels (planarkin.solver.compiled.gen): written, checked, loaded and called.

A structure's source goes into the checked cache entry of planarkin.solver.compiled.jitcache (a directory only
the user can write), as gen/<name>.py, its name the hash of the structure
(compiled_gen.name_of). Before it is run, the file's bytes are compared with the source
generated now: a file that differs (truncated, doctored, foreign) is replaced, atomically,
never executed. numba caches the compiled function beside it (cache=True: its index and data
files, which jitcache's manifest vouches for), so that a second run loads instead of compiling.
Where there is no usable cache directory the source is compiled in memory.
"""

from __future__ import annotations

import functools
import os
import sys
import types

import numpy as np

from planarkin.solver.compiled import gen as compiled_gen, jitcache

_fns: dict = {}           # module name -> the compiled grid function


def function(P, W: int, m: int, nb: int):
    """The grid function generated for packed system P's structure, compiled (or loaded from
    numba's cache). Every structure kernel.pack accepts is covered (compiled_gen.covers)."""
    assert compiled_gen.covers(P), "kernel.pack accepted a structure compiled_gen cannot write"
    key = getattr(P, "gen_name", None)
    if key is None:
        key = P.gen_name = compiled_gen.name_of(compiled_gen.structure(P, W, m, nb))
    if key not in _fns:
        _fns[key] = _build(key, compiled_gen.source(P, W, m, nb))
    return _fns[key]


def function_each(P, W: int, m: int, nb: int):
    """The studies' point-by-point solve generated for packed system P's structure
    (planarkin.solver.compiled.gen_each), compiled or loaded (as function)."""
    assert compiled_gen.covers(P), "kernel.pack accepted a structure compiled_gen cannot write"
    key = getattr(P, "each_name", None)
    if key is None:
        key = P.each_name = compiled_gen.name_of(compiled_gen.structure(P, W, m, nb), "each")
    if key not in _fns:
        from planarkin.solver.compiled import gen_each as compiled_gen_each
        _fns[key] = _build(key, compiled_gen_each.source(P, W, m, nb), "each",
                           signature_each())
    return _fns[key]


def _build(name: str, text: str, entry_point: str = "grid", sig=None):
    """The function entry_point of the generated module name (source text): loaded from the
    cache entry where numba's files for it are there, else compiled (jitcache.compiling: under
    the kernel's own lock, into a staging directory, then published into the entry), or
    compiled in memory where there is no usable cache."""
    fn, path = _cached(name, text, entry_point, sig)
    if fn is not None:
        return fn
    if path is None:                    # no usable cache directory: in memory
        return _load(name, text, None, None, entry_point, sig)
    with jitcache.compiling(name) as staging:
        fn, path = _cached(name, text, entry_point, sig)        # compiled meanwhile elsewhere
        if fn is not None:
            return fn
        stage = None if staging is None or path is None else staging()
        if stage is None:
            return _load(name, text, None, None, entry_point, sig)
        try:
            fn = _load(name, text, stage, path, entry_point, sig)
        except OSError as e:            # numba could not save its files: compiled without
            jitcache.unwritable(path.parent.parent, e)          # (the entry: entry/gen/name)
            return _load(name, text, None, None, entry_point, sig)
        finally:                        # numba's later caches: the entry's again
            import numba
            numba.config.CACHE_DIR = os.environ.get("NUMBA_CACHE_DIR", "")
        jitcache.publish(stage)
    return fn


def _cached(name: str, text: str, entry_point: str, sig):
    """(the function loaded from the cache entry, its source's path) where numba's files for
    it are there and load; (None, path) where they are not, or where numba would compile
    (an index whose data is gone, or written by another numba or for another CPU: the compile
    is then _build's, outside the entry's lock, which every other process waits for only
    LOCK_WAIT seconds); (None, None) without a usable cache. Under the entry's lock, the source
    written first where it is not there as generated."""
    from numba.core import event
    entry = jitcache.prepare()
    try:
        path = None if entry is None else written(entry, name, text)
        if path is None or not jitcache.has(entry, path, entry_point):
            return None, path
        try:
            with event.install_listener("numba:compile", _no_compile()):
                return _load(name, text, entry, path, entry_point, sig), path
        except _WouldCompile:
            return None, path
        except OSError as e:            # numba could not save to the cache: compiled without
            jitcache.unwritable(entry, e)
            return _load(name, text, None, None, entry_point, sig), path
    finally:
        jitcache.record()


class _WouldCompile(Exception):
    """numba was about to compile where _cached only loads."""


@functools.cache
def _no_compile():
    """A numba event listener that stops a compile as it starts (numba's compile events come
    only where its cache did not load); made once (this module does not import numba at its
    top)."""
    from numba.core import event

    class NoCompile(event.Listener):
        def on_start(self, _event):
            raise _WouldCompile

        def on_end(self, _event):
            pass
    return NoCompile()


def _load(name: str, text: str, entry, path, entry_point: str, sig):
    import numba
    if entry is not None:           # numba imported before: its configuration read then
        numba.config.CACHE_DIR = str(entry)
    # a module of its own in sys.modules: numba's cache finds the function's globals
    # there when it loads it in a later process
    mod = types.ModuleType(name)
    mod.__file__ = str(path) if path else f"<planarkin {name}>"
    mod.CACHE = path is not None
    sys.modules[name] = mod
    exec(compile(text, mod.__file__, "exec"), mod.__dict__)
    fn = getattr(mod, entry_point)
    if hasattr(fn, "compile"):          # (not with NUMBA_DISABLE_JIT=1)
        fn.compile(signature() if sig is None else sig)
    return fn


def written(entry, name: str, text: str):
    """entry/gen/<name>.py holding exactly text (written atomically where it does not), or None
    when it cannot be written."""
    data = text.encode()
    d = entry / "gen"
    path = d / f"{name}.py"
    try:
        d.mkdir(mode=0o700, exist_ok=True)
        if not jitcache.private(d):
            return None
        if path.is_file() and not path.is_symlink() and path.read_bytes() == data:
            return path
        tmp = d / f".{name}.{os.getpid()}.tmp"
        tmp.write_bytes(data)
        os.replace(tmp, path)
    except OSError:
        return None
    return path


def signature():
    import numba
    INT, DBL = numba.int64, numba.float64
    F1, F2 = numba.float64[::1], numba.float64[:, ::1]
    return (INT, F2, F2, F2, F2, F2, F2, F2, INT, DBL, INT, INT, numba.int64[::1],
            numba.uint8[::1], F1, F2, F2, F2, F1, F1, INT, F1, numba.int64[::1], F1, F1, F1, F1,
            F1)


def signature_each():
    import numba
    INT, DBL = numba.int64, numba.float64
    F1, I1, U1 = numba.float64[::1], numba.int64[::1], numba.uint8[::1]
    return (INT, F1, F1, F1, F1, F1, F1, INT, DBL, INT, I1, U1, F1, F1, F1, INT, I1, F1, INT,
            INT, I1, F1, F1, INT, U1, F1)


def _c(a):
    """a as a C-contiguous, writable float64 array (a view where it already is one)."""
    a = np.ascontiguousarray(a, dtype=float)
    return a if a.flags.writeable else a.copy()


_NONE_F = np.zeros(0)
_NONE_I = np.zeros(0, dtype=np.int64)


def solve(fn, S, P, Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order, predict=None, R=None):
    """kernel.solve by the generated kernel fn: the same arguments and results. predict:
    (t, idx, Tn, Qn, Qdn, Qddn), Q's rows are then written by the kernel as the quintic
    Hermite predictions at times t (N,) between path nodes idx (N,) and idx + 1 (Tn (K,), Qn,
    Qdn, Qddn (K, W)) before they are solved (Q, C-contiguous float, need not hold anything);
    R: an (N, m) array for the residuals (else a new one)."""
    N, W = Q.shape
    m = S.cm.m
    iters = np.empty(N, dtype=np.int64)
    conv = np.empty(N, dtype=np.uint8)
    ratio = np.empty(N)
    sign = np.zeros((N, P.nfine))
    smin = np.empty((N, P.nblk))
    if R is None or R.shape != (N, m) or R.dtype != float or not R.flags.c_contiguous:
        R = np.empty((N, m))
    rmax = np.empty(N)
    cond = np.empty(N)
    work = [_c(X) for X in (Q, Qd, Qdd)]
    drv = [_c(X if X.shape == (N, m) else np.broadcast_to(X, (N, m))) for X in (T, NU, FDD)]
    prm = np.ascontiguousarray(P.arrays[3], dtype=float)
    if predict is None:
        pred = (0, _NONE_F, _NONE_I, _NONE_F, _NONE_F, _NONE_F, _NONE_F, _NONE_F)
    else:
        t, idx, Tn, Qn, Qdn, Qddn = predict
        K = len(Tn)
        idx = np.ascontiguousarray(idx, dtype=np.int64)
        if len(t) != N or len(idx) != N or Qn.shape[1:] != (W,) or (
                N and not 0 <= idx.min() <= idx.max() < K - 1):
            raise ValueError("planarkin kernel: predictions between nodes that do not exist")
        pred = (1, _c(t), idx, *(_c(X).reshape(-1) for X in (Tn, Qn, Qdn, Qddn)),
                work[0].reshape(-1))
    fn(N, *work, *drv, prm, int(maxit), float(tol), int(policy == "full"), int(order), iters,
       conv, ratio, sign, smin, R, rmax, cond, *pred)
    for X, Wk in zip((Q, Qd, Qdd), work):
        if Wk is not X:
            X[...] = Wk
    return iters, conv.view(bool), ratio, sign, smin, R, rmax, cond
