"""The analysis pipeline shared by `planarkin run`, `planarkin check`, `planarkin.solve` and
the studies: the checks before the first row and the assembly (prepare), the grid pass into a
sink or into a `planarkin.results.Result` (stream, analyse), and the refusal of rows that are
not what they claim (refuse).

`solve()` collects every chunk into a `Result` (Collect); `planarkin run` streams the chunks
straight into `planarkin.output.writer.DirectoryWriter`, so memory stays bounded for millions
of steps. Both consume the same `Analysis.chunks()`; nothing here writes a file.
"""

from __future__ import annotations

import time

import numpy as np

from planarkin.solver.chunks import take
from planarkin.solver.layout import Layout
from .model.compile import CompiledModel
from .results import Result
from planarkin.results.runinfo import RunInfo
from planarkin.solver.grid import Analysis, Chunk, Event, Options


def assemble_checked(cm: CompiledModel, opts: Options):
    """The checks before a run and the assembly at opts.start (with the lock-ups ahead in its
    warnings): what `planarkin check` reports and `prepare` starts from. Invalid input (a
    driver outside this run's range, the budget, a model that cannot be assembled) raises
    InputError."""
    from planarkin.solver.assembly import assemble
    from planarkin.solver.budget import check_preflight
    from .diagnostics import Diagnostic, InputError
    from .measures.grashof import lock_ups
    a = cm.spec.analysis
    if (opts.start, opts.end) != (a.start, a.end):
        # the validator checked the drivers over the model's range; this run has another one
        problems = [Diagnostic(cm.spec.file, el.param_lines.get("f", el.line), f"{el.label}: {msg}")
                    for el in cm.spec.drivers if el.f is not None and hasattr(el.f, "problems")
                    for msg in el.f.problems(opts.start, opts.end)]
        if problems:
            raise InputError(problems)
    check_preflight(cm, opts)
    A = assemble(cm, opts.start)
    A.warnings += lock_ups(cm, A.q, opts.start, opts.end, opts.steps)
    return A


def prepare(cm: CompiledModel, opts: Options, warm=None, session=False) -> Analysis:
    """Everything before the first row: the budget check, assembly and path following (from
    the warm start warm, a warmstart.Start, when given: a design study's neighbour). Invalid
    input (the budget, a model that cannot be assembled) raises InputError, so nothing has been
    written yet when it does. session: a solve of the Python API (grid.Analysis)."""
    t0 = time.perf_counter()
    A = assemble_checked(cm, opts)
    an = Analysis(cm, A, opts, warm=warm, session=session)
    an.timings["assembly"] = time.perf_counter() - t0
    an.follow()
    return an


def run_info(an: Analysis) -> RunInfo:
    f = an.follower
    ev = an.event
    if ev is None:
        status, msg = 0, "analysis completed"
    else:
        status, msg = 1, ev.message
    A = an.A
    cm = an.cm
    asm = {
        "iterations": A.iterations,
        "residual": A.residual,
        "modes": [{"bodies": list(md.bodies), "branch": "+" if md.sign > 0 else "-",
                   "hint": f"assembly: {{branch: {{{md.key}: {'-' if md.sign > 0 else '+'}}}}} "
                           f"selects the other branch"} for md in A.modes],
        "redundant": [cm.row_label[r] for r in A.redundant_rows],
    }
    loops = getattr(f, "loops", None)       # the loops' figures (planarkin.measures.loops)
    if loops is not None:
        loops.t_stop = an.t_stop
    return RunInfo(status, msg, an.opts, ev, list(f.warnings), asm, len(f.nodes), f.rejected,
                   an.fallbacks, dict(an.timings), list(cm.spec.warnings) + list(A.warnings),
                   an.breakpoint_info(), loops=loops)


def stream(an: Analysis, sink=None, progress=None):
    """The grid pass: checked chunks into sink (an object with add(chunk)) or into a Result.
    Returns (info, result or None)."""
    collect = None
    if sink is None:
        collect = an.out = Collect(an.opts.rows)
    t2 = time.perf_counter()
    for ch in an.chunks():
        ch = refuse(an, ch)
        if len(ch.t):
            (sink if sink is not None else collect).add(ch)
            if progress is not None:
                progress(len(ch.t))
        if an.event is not None and an.event.kind in REFUSALS:
            break
    an.timings["grid"] = time.perf_counter() - t2
    if sink is not None:
        an.timings["grid"] -= getattr(sink, "t_write", 0.0)     # the tables' share
    info = run_info(an)
    result = None if sink is not None else Result(an.cm, collect.chunk(), info)
    an.out = None
    return info, result


class Collect:
    """The in-memory sink of solve(): the rows of every chunk in arrays for the whole grid (rows
    rows at most, allocated when first needed), so that a result is built without holding the
    chunks and concatenating them (one copy of each row less, and half the peak memory). The
    compiled kernel's chunks are laid out straight into these arrays (reserve)."""

    FIELDS = ("t", "q", "qd", "qdd", "p", "pd", "pdd", "iterations", "cond", "residual", "qddd",
              "pddd")

    def __init__(self, rows: int):
        self.rows = rows
        self.pos = 0
        self.arrays: dict = {}

    def _array(self, name: str, shape, dtype=float) -> np.ndarray:
        a = self.arrays.get(name)
        if a is None:
            a = self.arrays[name] = np.empty((self.rows,) + tuple(shape), dtype=dtype)
        return a

    def reserve(self, N: int, n: int, P: int, order: int):
        """Views of the next N rows of q, qd, qdd (N, n) and p, pd, pdd (N, P, 2), None above
        order; None when N rows do not fit (the caller allocates its own)."""
        if self.pos + N > self.rows:
            return None
        sl = slice(self.pos, self.pos + N)
        return (tuple(self._array(f, (n,))[sl] if k <= order else None
                      for k, f in enumerate(("q", "qd", "qdd")))
                + tuple(self._array(f, (P, 2))[sl] if k <= order else None
                        for k, f in enumerate(("p", "pd", "pdd"))))

    def add(self, ch: Chunk) -> None:
        N = len(ch.t)
        sl = slice(self.pos, self.pos + N)
        for f in self.FIELDS:
            a = getattr(ch, f)
            if a is None:
                continue
            dst = self._array(f, a.shape[1:], a.dtype)[sl]
            if not (a.shape == dst.shape and a.ctypes.data == dst.ctypes.data):
                dst[...] = a            # else laid out here already (reserve)
        self.pos += N

    def chunk(self) -> Chunk | None:
        if not self.pos:
            return None
        g = lambda f: self.arrays[f][: self.pos] if f in self.arrays else None   # noqa: E731
        return Chunk(*(g(f) for f in self.FIELDS))


def analyse(cm: CompiledModel, opts: Options, sink=None, progress=None, warm=None,
            session=False):
    """Run an analysis: prepare (raises InputError; warm: its warm start; session: a solve of
    the Python API), then the grid pass into sink or a Result. Returns (info, result or
    None)."""
    return stream(prepare(cm, opts, warm, session), sink, progress)


# range: a room's check (a cam past its law); contact, limit: a pair of shapes closer than its
# limit, a joint past its travel range, with clearance: {on_contact: error} (planarkin.clearance)
REFUSALS = ("non-finite", "residual", "range", "contact", "limit")


def residual_limit(opts: Options) -> float:
    """Largest constraint residual a written row may have (relative to the model's length):
    ten times the Newton tolerance, or the path tolerance when the rows are interpolated."""
    return 10 * max(opts.tol, opts.path_tol if opts.interpolate else 0.0)


def refuse(an: Analysis, ch: Chunk) -> Chunk:
    """Results are refused rather than written when they are not what they claim: the chunk is
    cut before the first row with a non-finite time or value, or a residual above
    residual_limit, or a row a room refuses (a non-finite force: derived.row_checks), and the
    run stops there (an event of kind 'non-finite' or 'residual')."""
    ch = _refuse_rows(an, ch)
    checks = getattr(an, "row_checks", None)
    if checks is None:
        from .derived import row_checks
        checks = an.row_checks = row_checks(an.cm, an.opts)
    for check in checks:
        cut = check(an, ch) if len(ch.t) else None
        if cut is not None:
            i, msg, kind = (tuple(cut) + ("non-finite",))[:3]
            an.event = Event(kind, float(ch.t[i]), msg)
            an.t_stop = float(ch.t[i])
            ch = take(ch, np.arange(i))
    return ch


def _refuse_rows(an: Analysis, ch: Chunk) -> Chunk:
    arrays = [a for a in (ch.q, ch.qd, ch.qdd, ch.qddd) if a is not None]
    limit = residual_limit(an.opts)
    points = [a for a in (ch.p, ch.pd, ch.pdd, ch.pddd) if a is not None]
    # the common case in one pass per array: a sum is finite only if every term is (a sum that
    # overflows takes the row-by-row checks below, which find nothing to refuse)
    with np.errstate(over="ignore", invalid="ignore"):
        if not len(ch.t) or (all(np.isfinite(a.sum()) for a in [ch.t, ch.residual] + arrays
                                 + points) and ch.residual.max() <= limit):
            return ch
    bad = ~np.isfinite(ch.t) | ~np.isfinite(ch.residual)
    for a in arrays:
        bad |= ~np.isfinite(a).all(axis=1)
    for a in (ch.p, ch.pd, ch.pdd, ch.pddd):
        if a is not None and a.size:
            bad |= ~np.isfinite(a).all(axis=(1, 2))
    high = np.isfinite(ch.residual) & (ch.residual > limit)
    stop = bad | high
    if not stop.any():
        return ch
    i = int(np.argmax(stop))
    t = float(ch.t[i])
    cm = an.cm
    if bad[i]:
        cols = []
        layout = Layout(cm, an.opts.order)
        row = layout.body_table(take(ch, np.array([i])))[0]
        cols = [h for h, v in zip(layout.body_header, row) if not np.isfinite(v)]
        if not cols:
            cols = ["a point's coordinates" if np.isfinite(ch.residual[i]) else "the residual"]
        shown = ", ".join(cols[:4]) + (f" and {len(cols) - 4} more" if len(cols) > 4 else "")
        msg = (f"non-finite results at t = {t:.10g} s ({shown}): a driver's velocity or "
               f"acceleration does not exist there (a kink, a step, a square root at 0?) or the "
               f"numbers overflowed; rows are written up to the one before")
        kind = "non-finite"
    else:
        msg = (f"the constraint residual {ch.residual[i]:.3g} at t = {t:.10g} s is above the "
               f"limit {limit:.3g} (10 x tol, relative to the model's size): that row would not "
               f"be a solution; rows are written up to the one before")
        kind = "residual"
    an.event = Event(kind, t, msg)
    an.t_stop = t
    return take(ch, np.arange(i))
