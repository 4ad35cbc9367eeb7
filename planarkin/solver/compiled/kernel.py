"""The compiled route of the grid pass and the studies' solves, on numba (issue 17).

System.solve_batch's reference pass is numpy; the compiled route is the same algorithm written
out per mechanism structure as Python (planarkin.solver.compiled.gen and gen_each: compiled by
numba, or interpreted with NUMBA_DISABLE_JIT=1), with the small entry points of
planarkin.solver.compiled.points. Here: which route a job takes (route), what the compiled functions
are given (pack: a System's elements and blocks as int64 / float64 arrays; table: a study's
per-variant parameters), and the calls themselves (solve, solve_rows, layout), which check and
flatten their arguments.

The route depends on the job, the installed packages and, for a solve of the Python API
(planarkin.solve), the session's earlier solves: a job of at least COMPILED_FROM_POINTS points
(grid rows, or variants x grid times) takes the compiled route when numba can be imported, and
so does a solve of at least ADDS_UP_FROM points once the session's solves of its structure add
up to COMPILED_FROM_POINTS (route); every other job the numpy passes, so a small run never pays
numba's start-up (its import, and the load of the compiled functions from its cache). Both
routes give the same results to 1e-15 of a column's largest value (the equations are one text,
and the kernels do the reference pass's operations in its order; whole runs of the examples at
their own grids are the same bits, but a dense block's inverse, Gauss-Jordan here and LAPACK's
there, can move a last digit): a session's later solves of a mechanism can differ from its
first ones by that much; a command's run, a study and a synthesis never depend on what ran
before them.
Never what earlier runs left on disk: the cache (planarkin.solver.compiled.jitcache) only saves compiling, and
a corrupt entry is compiled again. Where numba cannot be imported, the numpy passes run and
one line on stderr says so, once per process; PLANARKIN_KERNEL=0: the numpy passes only.

A system's solve is the kernel generated for its structure (planarkin.solver.compiled.kernels: the
grid pass written out as straight-line Python by planarkin.solver.compiled.gen, compiled once
and kept in the cache; a study's point-by-point solve by planarkin.solver.compiled.gen_each):
one compiled route, every structure pack accepts written out, no generic kernel beside it.

It covers the kinds whose equations are the point-and-line formulas of reference sections 1-2
(revolute, translational, pin-slot, slide, angle, x, y, distance), fine blocks of up to KFINE
unknowns and solve blocks of up to KMAX; any other kind or a larger block keeps the numpy
passes (pack returns None).
"""

from __future__ import annotations

import os
import sys

import numpy as np

KMAX = 16             # largest solve block: gen.KDENSE, the largest it writes out
KFINE = 6             # largest fine block (of the grid pass: larger ones are J5's dense/sparse LU)

# A job of at least this many points (grid rows; variants x grid times for a study) takes the
# compiled route: a smaller one, in a fresh process, would not repay numba's start-up (its
# import and the cache loads) by the compiled solve's lower cost per point. The crossover is
# measured by benchmarks/bench_route.py and bench_coldstart.py (the four-bar's planarkin.solve
# in a fresh process, warm cache; benchmarks/README.md, "Figures moved from the code's
# comments").
COMPILED_FROM_POINTS = 300_000
# A solve of the Python API of at least this many points counts towards COMPILED_FROM_POINTS with
# the session's earlier ones of its structure (route): smaller solves never add up.
ADDS_UP_FROM = 20_000

# where pack puts a kind's parameters (its compiled_params): p[0:2] si, p[2:4] sj, p[4:6] vi,
# p[6:8] vj, whatever order the kind lists them in
_SLOT = {"si": 0, "sj": 2, "vi": 4, "vj": 6}


def compiled_kind(kind):
    """(code, parameter names) of a kind the compiled route compiles (its class's own
    compiled_code and compiled_params, planarkin.elements.base.Kind: a subclass that does not
    state them is not compiled on its parent's word), or None."""
    own = vars(type(kind))
    code = own.get("compiled_code")
    return None if code is None else (code, tuple(own.get("compiled_params", ())))


_state: dict = {}        # "lib": the loaded Library, or None: numba could not be imported


class Library:
    """The compiled entry points apart from the generated solves, each compiled for its one
    signature (or loaded from numba's cache) when a job first needs it (need):
    planarkin.solver.compiled.points' layout ('points', every job on the route: the generated kernels
    write their own predictions) and the studies' cubic ('study')."""

    PARTS = {"points": ("points", ("layout",)),
             "study": ("points", ("cubic",))}

    def __init__(self):
        self.cache = None          # numba's disk cache directory once prepared, or None
        self._ready: set = set()

    def need(self, part: str) -> "Library":
        """The entry points of part ('points', 'study') compiled or loaded, under the
        cache's lock (planarkin.solver.compiled.jitcache), before anything is solved (and before a study forks
        its workers)."""
        if part not in self._ready:
            import importlib

            from planarkin.solver.compiled import jitcache
            spec = self.PARTS[part]
            self.cache = jitcache.prepare()
            try:
                for k in range(0, len(spec), 2):
                    mod = importlib.import_module(f"{__package__}.{spec[k]}")
                    for name in spec[k + 1]:
                        fn = getattr(mod, name)
                        if hasattr(fn, "compile"):          # (not with NUMBA_DISABLE_JIT=1)
                            jitcache.compile_cached(fn, mod.SIGNATURES[name])
                        setattr(self, name, fn)
            finally:
                jitcache.record()
            self._ready.add(part)
        return self


def disabled() -> bool:
    """PLANARKIN_KERNEL=0: the numpy passes only."""
    return os.environ.get("PLANARKIN_KERNEL", "1") == "0"


def route(points: int, part: str = "grid", structure=None):
    """The compiled Library for a job of `points` points, its entry points for part ready
    (Library.need; a grid job: the layout, its solves generated and compiled per structure
    when first solved, see solve), or None: the numpy passes (a job below COMPILED_FROM_POINTS,
    PLANARKIN_KERNEL=0, or numba not importable).

    structure (the mechanism structure of a solve of the Python API, planarkin.solve: any
    hashable key, `structure_key`; None for every other job): a job of at least ADDS_UP_FROM
    points also counts the process's earlier such solves of the same structure, so that a
    session solving one mechanism again and again (a notebook, a script's loop) pays numba's
    start-up once its solves together would repay it. A command's run, a study's variants and
    a design's analyses take their route by their own size (the same bytes whatever ran
    before them)."""
    if disabled():
        return None
    total = points
    if structure is not None and points >= ADDS_UP_FROM:
        done = _state.setdefault("points", {})
        total = done[structure] = done.get(structure, 0) + points
    if total < COMPILED_FROM_POINTS:
        return None
    lib = library()
    return None if lib is None else lib.need("points" if part == "grid" else part)


def would_route(points: int) -> bool:
    """Whether route(points) (a job that is not a session's solve) would take the compiled
    route, told without importing numba (numba found, not imported)."""
    import importlib.util
    return not disabled() and points >= COMPILED_FROM_POINTS and \
        importlib.util.find_spec("numba") is not None


def structure_key(cm) -> tuple:
    """What a compiled model's grid kernel depends on, cheaply (route's structure): each
    group's kind and bodies, the coordinates and equations (a key may stand for more than one
    kernel: it only counts jobs)."""
    return (cm.n, cm.m) + tuple((G.kind.name, G.bodies.tobytes()) for G in cm.groups)


def library():
    """The compiled Library (numba imported and the entry points compiled or loaded from the
    cache: once per process), or None where numba cannot be imported (said once on stderr)."""
    if "lib" not in _state:
        _state["lib"] = _load()
    return _state["lib"]


def _load():
    try:
        import numba  # noqa: F401
    except Exception as e:          # (any failure of the import: not installed, broken)
        print(f"planarkin: numba cannot be imported ({type(e).__name__}: {e}); the numpy "
              f"route runs (slower for large jobs)", file=sys.stderr)
        return None
    return Library()


class Packed:
    """A System's elements and blocks as the compiled route's int64 / float64 arrays (one type
    for every index, so that each compiled helper is specialised once)."""

    def __init__(self, ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows, inblk,
                 rcol, rpos, nfine, bfirst, bnf, bfo, bfs, fixed):
        self.arrays = (ekind, ebi, ebj, eprm, rowel, roweq, bk, boff, baff, bcols, brows)
        self.nblk = len(bk)
        self.tail = (inblk, rcol, rpos)
        self.nfine = nfine
        self.fine = (bfirst, bnf, bfo, bfs)
        self.fixed = fixed


def pack(S) -> Packed | None:
    """The kernel's description of System S, or None when it does not apply: a kind the kernel
    does not know, a solve block of more than KMAX unknowns or a fine block of more than KFINE,
    an element on one body twice."""
    if not S.blocks or any(len(B.cols) > KMAX or max(B.sizes) > KFINE or S.is_large(B)
                           for B in S.blocks):
        return None
    cm = S.cm
    ekind, ebi, ebj, eprm = [], [], [], []
    rowel = np.full(cm.m, -1, dtype=np.int32)
    roweq = np.zeros(cm.m, dtype=np.int32)
    for G in cm.groups:
        ck = compiled_kind(G.kind)
        if ck is None or G.kind.nbody != 2 or set(G.params) - set(ck[1]):
            return None
        code, names = ck
        for k in range(len(G)):
            bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
            if bi == bj:
                return None
            p = np.zeros(8)
            for name in names:
                at = _SLOT[name]
                p[at:at + 2] = G.params[name][k]
            e = len(ekind)
            ekind.append(code)
            ebi.append(bi)
            ebj.append(bj)
            eprm.append(p)
            for q, r in enumerate(G.rows[k]):
                rowel[r] = e
                roweq[r] = q
    bk, boff, baff, bcols, brows = [], [], [], [], []
    if (rowel < 0).any():
        return None
    for B in S.blocks:
        boff.append(len(bcols))
        bk.append(len(B.cols))
        baff.append(int(B.affine))
        bcols.extend(int(c) for c in B.cols)
        brows.extend(int(r) for r in B.rows)
    rcol = np.zeros((cm.m, 6), dtype=np.int32)
    rpos = np.full((cm.m, 6), -1, dtype=np.int32)
    for r in range(cm.m):
        e = rowel[r]
        rcol[r] = [3 * ebi[e], 3 * ebi[e] + 1, 3 * ebi[e] + 2, 3 * ebj[e], 3 * ebj[e] + 1,
                   3 * ebj[e] + 2]
    for B in S.blocks:
        pos = {int(c): j for j, c in enumerate(B.cols)}
        for r in B.rows:
            rpos[r] = [pos.get(int(c), -1) for c in rcol[r]]
    i32 = lambda v: np.ascontiguousarray(v, dtype=np.int64)       # noqa: E731
    return Packed(i32(ekind), i32(ebi), i32(ebj),
                  np.ascontiguousarray(np.array(eprm).reshape(-1, 8), dtype=float),
                  i32(rowel), i32(roweq), i32(bk), i32(boff), i32(baff), i32(bcols), i32(brows),
                  np.isin(np.arange(cm.m), brows).astype(np.uint8), i32(rcol), i32(rpos),
                  S.nfine, i32([B.first for B in S.blocks]), i32([len(B.sizes) for B in S.blocks]),
                  i32(np.cumsum([0] + [len(B.sizes) for B in S.blocks])[:-1]),
                  i32([z for B in S.blocks for z in B.sizes]),
                  i32([B.fixed_grad for B in S.blocks]))




def chunk_buffers(keep: dict, N: int, W: int, m: int):
    """Q, Qd, Qdd (N, W) and the residuals (N, m) of a grid chunk on the compiled route: views
    of arrays kept in keep (the analysis's) from chunk to chunk, so that no fresh pages are
    faulted in: nothing of them outlives a chunk (the kernel lays the results out into new
    arrays, layout). Zeros at first: the ground's columns, which the kernel does not write."""
    got = keep.get("_chunk_buffers")
    if got is None or got[0].shape[0] < N or got[0].shape[1] != W or got[3].shape[1] != m:
        got = keep["_chunk_buffers"] = (np.zeros((N, W)), np.zeros((N, W)), np.zeros((N, W)),
                                        np.empty((N, m)))
    return tuple(a[:N] for a in got)


def _flat(a, dtype=float):
    """a as a flat, writable, C-contiguous array of dtype (a view where it already is one):
    numba types a read-only array apart, and would compile the entry point again for it."""
    a = np.ascontiguousarray(a, dtype=dtype).reshape(-1)
    return a if a.flags.writeable else a.copy()


def solve(lib, S, P: Packed, Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order, predict=None,
          R=None):
    """System.solve_batch by the compiled route (the kernel generated for S's structure,
    kernels.solve): Q, Qd, Qdd (N, n + 3) updated in place. Returns (iterations,
    converged, ratio, sign, smin) as BatchInfo wants them (converged False where a coordinate
    is not finite), the residual |Phi| (N, m) of every equation at the results (redundant ones
    included), its largest value per point (N,) and the condition estimate (N,) of
    acceptance.condition. predict: (t, idx, Tn, Qn, Qdn, Qddn), Q is then first written with
    the Hermite predictions between the path's nodes; R: an (N, m) array to hold the
    residuals."""
    from planarkin.solver.compiled import kernels as compiled_grid
    fn = compiled_grid.function(P, Q.shape[1], S.cm.m, S.nb)
    return compiled_grid.solve(fn, S, P, Q, Qd, Qdd, T, NU, FDD, policy, tol, maxit, order,
                               predict, R)


def table(cm, params) -> np.ndarray:
    """(V, E, 8) element parameters of V parameter sets in pack's layout: params holds, per
    group of cm.groups (in order), the arrays name -> (V, K, 2) of its K instances' 2-vectors
    (si, sj, vi, vj), the model's own where a name is missing."""
    V = next((a.shape[0] for p in params for a in p.values()), 1)
    parts = []
    for G, p in zip(cm.groups, params):
        out = np.zeros((V, len(G), 8))
        for name in compiled_kind(G.kind)[1]:
            at = _SLOT[name]
            out[:, :, at:at + 2] = p.get(name, G.params[name])
        parts.append(out)
    return np.concatenate(parts, axis=1)


def _rows(rows, table, N, P):
    if rows is None:
        return None, None
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    table = np.ascontiguousarray(table, dtype=float)
    if rows.shape != (N,) or table.shape[1:] != P.arrays[3].shape or (
            N and not 0 <= rows.min() <= rows.max() < len(table)):
        raise ValueError("planarkin kernel: per-point parameter rows out of the table")
    return rows, table


def _buffer(work, name, shape, dtype=float):
    """An array for a result: from work (a dict kept by the caller between calls) when it has
    one of this shape and type, else a new one (kept there)."""
    if work is None:
        return np.empty(shape, dtype=dtype)
    a = work.get(name)
    if a is None or a.shape != shape or a.dtype != dtype:
        a = work[name] = np.empty(shape, dtype=dtype)
    return a


_NONE_I64 = np.zeros(1, dtype=np.int64)
_NONE_F64 = np.zeros(1)
_NONE_U8 = np.zeros(1, dtype=np.uint8)


def solve_rows(lib, S, P: Packed, Q, T, NU, FDD, tol, maxit, rows=None, table=None,
               trow=None, accept=None, hist=None, work=None, out=None):
    """The studies' point-by-point solve (gen_each, generated for S's structure):
    full Newton for the positions of N points from the
    predictions Q (N, n + 3), each point to its own convergence, then velocities and
    accelerations. T, NU, FDD: the drivers' targets, nu and f'' (N, m), or with trow (N,)
    int32 tables (K, m) of which point i reads row trow[i]; rows, table: per-point element
    parameters, an index per point into a (V, E, 8) table of parameter sets (see `table`).
    Returns (Q, Qd, Qdd, iterations, converged, ratio, sign, smin, good, perr), Q the array
    given when it is contiguous float64 (updated in place), else a copy. accept: (tg, sign0),
    the acceptance tests of studies.batch (planarkin.solver.compiled.helpers.accept_point, its bounds compiled in):
    good (N,) bool and perr (N,), the path error of the interval from the point before (grid
    times tg, indexed as T); None: not tested (good, perr None). hist: (H0, H1, H2, H3, cub),
    four arrays shaped as Q (the last four solutions, newest first) and cub (N,) bool: the
    prediction of point i is then the cubic through the rows of H0-H3 where cub[i], else Q's
    row, and Q is not written (the positions are a new array). work: a dict the caller keeps
    between calls, whose arrays then hold the diagnostics (iterations to perr: valid until the
    next call with it); out: arrays (N, W) for the positions (with hist), velocities and
    accelerations."""
    N, W = Q.shape
    if maxit < 1:
        raise ValueError("planarkin kernel: at least one Newton iteration")
    rows, table = _rows(rows, table, N, P)
    Q = np.ascontiguousarray(Q, dtype=float)
    if hist is not None:
        cub = np.ascontiguousarray(hist[4], dtype=bool)
        hist = [np.ascontiguousarray(h, dtype=float) for h in hist[:4]]
        if any(h.shape != Q.shape for h in hist) or cub.shape != (N,):
            raise ValueError("planarkin kernel: four history arrays shaped as Q and a flag "
                             "per point wanted")
    if out is not None and all(a.shape == (N, W) and a.dtype == float and a.flags.c_contiguous
                               and not any(np.may_share_memory(a, x) for x in [Q, *(hist or [])])
                               for a in out) and len({a.ctypes.data for a in out}) == 3:
        Qo, Qd, Qdd = out
    else:
        Qo = np.empty((N, W)) if hist is not None else None
        Qd, Qdd = np.empty((N, W)), np.empty((N, W))
    # (the study solve writes every column)
    drv = [np.ascontiguousarray(X, dtype=float) for X in (T, NU, FDD)]
    if trow is not None:
        trow = np.ascontiguousarray(trow, dtype=np.int64)
        if trow.shape != (N,) or (N and not 0 <= trow.min() <= trow.max() < len(drv[0])):
            raise ValueError("planarkin kernel: driver rows out of the tables")
    elif len(drv[0]) != N:
        raise ValueError("planarkin kernel: one driver row per point wanted")
    iters = _buffer(work, "iters", (N,), np.int64)
    conv = _buffer(work, "conv", (N,), np.uint8)
    ratio = _buffer(work, "ratio", (N,))
    sign = _buffer(work, "sign", (N, P.nfine))
    smin = _buffer(work, "smin", (N, P.nblk))
    good = perr = None
    sign0, tg = _NONE_F64, _NONE_F64
    if accept is not None:
        tg, sign0 = accept
        tg = np.ascontiguousarray(tg, dtype=float)
        sign0 = np.ascontiguousarray(sign0, dtype=float)
        if sign0.shape != (N, P.nfine) or len(tg) != len(drv[0]):
            raise ValueError("planarkin kernel: acceptance arrays do not match")
        good = _buffer(work, "good", (N,), np.uint8)
        perr = _buffer(work, "perr", (N,))
    if hist is not None:
        out = Qo
        lib.cubic(*(h.reshape(-1) for h in hist), out.reshape(-1))
        keep = ~cub
        out[keep] = Q[keep]
        Q = out
    eprm = P.arrays[3]
    prm = eprm if table is None else table
    from planarkin.solver.compiled import kernels as compiled_grid
    fn = compiled_grid.function_each(P, W, S.cm.m, S.nb)
    fn(N, Q.reshape(-1), Qd.reshape(-1), Qdd.reshape(-1), *(X.reshape(-1) for X in drv),
       int(maxit), float(tol), 1, iters, conv, ratio, sign.reshape(-1), smin.reshape(-1),
       int(rows is not None), _NONE_I64 if rows is None else rows, prm.reshape(-1),
       eprm.shape[0], int(trow is not None), _NONE_I64 if trow is None else trow,
       tg.reshape(-1), sign0.reshape(-1), int(accept is not None),
       _NONE_U8 if good is None else good, _NONE_F64 if perr is None else perr)
    return (Q, Qd, Qdd, iters, conv.view(bool), ratio, sign, smin,
            None if good is None else good.view(bool), perr)


def layout(lib, cm, Q, Qd, Qdd, order: int, unit, out=None):
    """A chunk's user-unit arrays from its internal (N, n + 3) rows, in one pass: q, qd, qdd
    (N, n) (None above order) and the points' p, pd, pdd (N, P, 2), as solver._chunk computes
    them with point_kinematics. out: those six arrays (C-contiguous, float) to write into."""
    N, W = Q.shape
    n = cm.n
    P = len(cm.point_body)
    arrs = [_flat(a) for a in (Q, Qd, Qdd)]
    if out is None:
        out = tuple(np.empty((N, n)) if k <= order else None for k in range(3)) \
            + tuple(np.empty((N, P, 2)) if k <= order else None for k in range(3))
    q, qd, qdd, p, pd, pdd = out
    pbody = _flat(cm.point_body, np.int64)
    ps = _flat(cm.point_s)
    unit = _flat(unit)
    flat = [a.reshape(-1) for a in (q, p)]
    lib.layout(N, W, n, P, int(order), unit, float(cm.L), pbody, ps, *arrs,
               *[flat[0] if a is None else a.reshape(-1) for a in (q, qd, qdd)],
               *[flat[1] if a is None else a.reshape(-1) for a in (p, pd, pdd)])
    return q, qd, qdd, p, pd, pdd
