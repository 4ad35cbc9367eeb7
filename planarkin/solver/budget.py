"""Budgets, not hangs: what a run may cost, checked before it starts.

A driver whose rate makes the path follower's step count explode (``1e6*t`` on a crank, a pole
``0.01/(t-0.5)``) would otherwise run for minutes and gigabytes before failing. Before the
analysis, every driver's motion over the time range is measured in internal units (radians;
lengths divided by the model's length L) by adaptive sampling, and the run is refused when the
path would need more internal steps than the budget: the follower's accepted steps measured on
the examples move 0.2-1.1 internal units each, so a motion of M units needs at least about M
steps. The node count is also limited by memory (`NODE_BYTES`): a node keeps q, q', q'' of every
coordinate.

A table's interpolant (a driver's ``table:``) is measured by its knots as well: the follower's
predictor misses a step h by about h^4 |f''''| / 8, so each piece of the spline needs at least
its length times (|f''''| / (8 path_tol))^(1/4) steps, however little the table moves. Noise in
measured rows makes f'''' large and alternate in sign from row to row: several steps per row.
Such a table is refused once it would take more than `NOISY_STEPS` (smooth it, or thin it out),
any table once it would pass the node budget.
"""

from __future__ import annotations

import numpy as np

from .tolerances import NODE_TOL

NODE_BYTES = 512 * 2**20     # memory the internal path nodes may take
UNIT_PER_STEP = 1.0          # internal units of driver motion per path step (an upper bound)
_SAMPLES = 4097              # first sampling of each driver over the time range
_MAX_SAMPLES = 2_000_000     # adaptive refinement stops here (then the estimate is a lower bound)
# a grid row of a model's points: p, p', p'' and their user-unit copies, the point kinematics'
# temporaries, the table row and its formatting (measured 160 bytes a point with 2,000 points)
POINT_ROW_BYTES = 8 * 24
# points times grid rows a run may take: a point's row is 2 (order + 1) numbers of a result
# (48 bytes, 64 with jerks) and about 100 characters of points.csv
MAX_POINT_ROWS = 20_000_000
POINT_RESULT_BYTES = 48
POINT_CSV_BYTES = 100
# the path's predictor (cubic, its jerk from the step before) misses a step h by about
# h^4 |f''''| / TAYLOR: measured nodes on noisy tables were 1.03-2.2 times the estimate
TAYLOR = 8.0
# a table whose interpolant's f'''' changes sign at more than this fraction of its rows is
# noise-like (measured noise: 0.86-0.91, smooth motions sampled 16 or more times a period:
# 0.16 or less) and is refused past NOISY_STEPS estimated steps: a path that long follows
# the noise, and its every step is a Python-level solve
NOISY_SIGNS = 0.5
NOISY_STEPS = 10_000
# a driver value whose unit in the last place passes this many times the Newton tolerance is
# refused (at 1 the slider-crank's crank 2*pi*t already fails to converge near t = 3e4 s)
PRECISION_FACTOR = 10.0


def node_limit(cm, opts) -> int:
    """Largest number of internal path nodes: max_nodes, or fewer when their memory would pass
    NODE_BYTES (q, q', q'' of n + 3 coordinates per node plus Python's overhead)."""
    per_node = 3 * 8 * (cm.n + 3) + 600
    return int(max(16, min(opts.max_nodes, NODE_BYTES // per_node)))


def point_row_bytes(cm) -> int:
    """Working set of one grid row's points in the grid pass and the tables (bytes): a grid
    chunk's rows are sized with it, since a model of many points holds them per row."""
    return POINT_ROW_BYTES * len(cm.point_names)


def point_rows(cm, opts) -> str | None:
    """The reason to refuse a run whose points times grid rows pass MAX_POINT_ROWS, or None."""
    n = len(cm.point_names)
    if n * opts.rows <= MAX_POINT_ROWS:
        return None
    return (f"{n} points at {opts.rows} grid rows are {n * opts.rows:.3g} point rows, more "
            f"than the budget of {MAX_POINT_ROWS:.3g} (about "
            f"{MAX_POINT_ROWS * POINT_RESULT_BYTES / 2**30:.2g} GB of results, "
            f"{MAX_POINT_ROWS * POINT_CSV_BYTES / 2**30:.2g} GB of points.csv): use fewer steps "
            f"(analysis: steps, --steps) or fewer points")


def check_preflight(cm, opts) -> None:
    """preflight as an input error at the driver's line (InputError), for run and check alike;
    and the points' share of the run (point_rows) at the model's points:."""
    from planarkin.diagnostics import Diagnostic, InputError
    reason = point_rows(cm, opts)
    if reason is not None:
        raise InputError([Diagnostic(cm.spec.file, cm.spec.section_lines.get("points"), reason)])
    reason = preflight(cm, opts)
    if reason is None:
        return
    row = next((r for r in cm.driver_rows if reason.startswith(cm.row_label[r])), None)
    line = cm.element_of_row(int(row)).line if row is not None else None
    raise InputError([Diagnostic(cm.spec.file, line, reason)])


def preflight(cm, opts) -> str | None:
    """None when every driver's motion fits the node budget; else the reason to refuse, naming
    the driver, how much it moves and where it is not finite or unbounded."""
    limit = node_limit(cm, opts)
    h_min = 1e-11 * (opts.end - opts.start)
    for row, f, sc in zip(cm.driver_rows, cm.driver_funcs, cm.driver_scale):
        if getattr(f, "is_constant", False):
            continue
        label = cm.row_label[row]
        t = np.linspace(opts.start, opts.end, _SAMPLES)
        with np.errstate(all="ignore"):
            v = sc * np.asarray(f(t), dtype=float)
            while True:
                bad = ~np.isfinite(v)
                if bad.any():
                    return (f"{label}: f is not finite at t = {t[np.argmax(bad)]:.10g} s (a pole "
                            f"or a domain error in the time range [{opts.start:g}, {opts.end:g}])")
                d = np.abs(np.diff(v))
                total = float(d.sum())
                if total / UNIT_PER_STEP > limit:
                    return _too_fast(cm, label, total, limit, opts, t, d, h_min)
                split = (d > UNIT_PER_STEP) & (np.diff(t) > h_min)
                if not split.any() or len(t) > _MAX_SAMPLES:
                    break
                mid = 0.5 * (t[:-1][split] + t[1:][split])
                vm = sc * np.asarray(f(mid), dtype=float)
                t = np.insert(t, np.nonzero(split)[0] + 1, mid)
                v = np.insert(v, np.nonzero(split)[0] + 1, vm)
            if (reason := _too_large(cm, label, v, t)) is not None:
                return reason
        if (reason := _rough_table(label, f, sc, opts, limit)) is not None:
            return reason
    return None


def table_steps(f, sc: float, start: float, end: float, path_tol: float):
    """(steps, signs, rows) of a table driver f (TimeFunction.table set) over [start, end]:
    the fewest internal path steps its interpolant's fourth derivative allows (see the module
    docstring; sc: internal units per user unit), the fraction of its rows where that
    derivative changes sign, and the rows the time range covers. None for other drivers."""
    table = getattr(f, "table", None)
    if table is None:
        return None
    # once per function and range: a study's preflight asks again for every variant
    cache = f.__dict__.setdefault("_steps", {})
    key = (float(sc), float(start), float(end), float(path_tol))
    if key not in cache:
        cache[key] = _table_steps(table, sc, start, end, path_tol)
    return cache[key]


def _table_steps(table, sc, start, end, path_tol):
    pw, period, n = table
    K = pw.knots
    if len(K) < 3 or not end > start:
        return None
    ends = pw.interior_ends(4)
    per = np.diff(K) * (np.abs(ends).max(axis=1) * abs(sc) / (TAYLOR * path_tol)) ** 0.25
    g = ends[:, 0]
    signs = float(np.mean(np.sign(g[:-1]) * np.sign(g[1:]) < 0))
    cum = np.concatenate([[0.0], np.cumsum(per)])
    rows = np.linspace(0.0, n - 1.0, len(K))        # the table's rows, spread over its knots

    def upto(x):
        """steps and rows from K[0] to x (inside the table), linear within a piece"""
        return np.interp(x, K, cum), np.interp(x, K, rows)

    if period is None:
        (s0, r0), (s1, r1) = upto(max(start, K[0])), upto(min(end, K[-1]))
        return max(0.0, float(s1 - s0)), signs, max(0.0, float(r1 - r0))
    # periodic: whole periods, then what is left of the range, wrapped into the table
    span = K[-1] - K[0]
    whole = np.floor((end - start) / span)
    a = K[0] + np.mod(start - K[0], span)
    b = a + (end - start - whole * span)
    steps, rws = whole * cum[-1], whole * rows[-1]
    for lo, hi in ((a, min(b, K[-1])), (K[0], K[0] + max(0.0, b - K[-1]))):
        (s0, r0), (s1, r1) = upto(lo), upto(hi)
        steps, rws = steps + max(0.0, s1 - s0), rws + max(0.0, r1 - r0)
    return float(steps), signs, float(rws)


def _rough_table(label, f, sc, opts, limit) -> str | None:
    """The reason to refuse a table driver whose interpolant would take the path follower too
    many steps: past the node budget, or noise-like and past NOISY_STEPS; else None."""
    got = table_steps(f, sc, opts.start, opts.end, opts.path_tol)
    if got is None:
        return None
    steps, signs, rows = got
    per_row = f"{steps / rows:.2g} per row" if rows >= 1 else "for its rows"
    if steps > limit:
        return (f"{label}: {f.text}: following its interpolant would take at least "
                f"{steps:.3g} internal steps ({per_row}), more than {limit} (the budget: "
                f"analysis: max_nodes = {opts.max_nodes}, and {NODE_BYTES // 2**20} MB of "
                f"nodes): smooth the data or thin it out to fewer rows, shorten the time range, "
                f"or raise max_nodes or path_tol")
    if signs > NOISY_SIGNS and steps > NOISY_STEPS:
        return (f"{label}: {f.text}: its interpolant's fourth derivative changes sign at "
                f"{100 * signs:.0f}% of the rows (noise in measured data, or a motion sampled "
                f"too sparsely?): following it would take at least {steps:.3g} internal steps "
                f"({per_row}), more than {NOISY_STEPS} (the budget for a table whose rows "
                f"alternate so), and its velocities and accelerations would be that noise, "
                f"amplified: smooth the data (a moving average, a smoothing spline) or thin it "
                f"out to fewer rows, or raise path_tol")
    return None


def _too_large(cm, label, v, t) -> str | None:
    """A driver value so large that double precision cannot resolve it to the solver's
    tolerance (a crank 2*pi*t at t = 1e5 s is 6.3e5 rad, resolved to 1.2e-10 rad): Newton could
    not converge, or an assembly would be reported as violated, for a reason that is neither."""
    i = int(np.argmax(np.abs(v)))
    ulp = float(np.spacing(abs(v[i])))
    if ulp <= PRECISION_FACTOR * NODE_TOL:
        return None
    return (f"{label}: f reaches {v[i]:.4g} internal units at t = {t[i]:.10g} s (radians, or "
            f"lengths divided by the model's size {cm.L:g} {cm.spec.length_unit}), which double "
            f"precision resolves only to {ulp:.2g}, coarser than the solver's tolerance "
            f"{NODE_TOL:g}: shift the time origin towards 0 (start the run near t = 0) or take "
            f"the large constant out of f")


def _too_fast(cm, label, total, limit, opts, t, d, h_min) -> str:
    i = int(np.argmax(d))
    where = ""
    if t[i + 1] - t[i] <= 2 * h_min or d[i] > 0.5 * total:
        where = f"; it is unbounded near t = {0.5 * (t[i] + t[i + 1]):.10g} s (a pole?)"
    return (f"{label}: f moves by {total:.3g} internal units over the time range (radians, or "
            f"lengths divided by the model's size {cm.L:g} {cm.spec.length_unit}){where}: the "
            f"path would need more than {limit} internal steps (the budget: analysis: "
            f"max_nodes = {opts.max_nodes}, and {NODE_BYTES // 2**20} MB of nodes). Shorten the "
            f"time range, lower the driver's rate, or raise max_nodes")
