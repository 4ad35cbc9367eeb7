"""Budgets, not hangs: what a run may cost, checked before it starts.

A driver whose rate makes the path follower's step count explode (``1e6*t`` on a crank, a pole
``0.01/(t-0.5)``) would otherwise run for minutes and gigabytes before failing. Before the
analysis, every driver's motion over the time range is measured in internal units (radians;
lengths divided by the model's length L) by adaptive sampling, and the run is refused when the
path would need more internal steps than the budget: the follower's accepted steps measured on
the examples move 0.2-1.1 internal units each, so a motion of M units needs at least about M
steps. The node count is also limited by memory (`NODE_BYTES`): a node keeps q, q', q'' of every
coordinate.
"""

from __future__ import annotations

import numpy as np

from .tolerances import NODE_TOL

NODE_BYTES = 512 * 2**20     # memory the internal path nodes may take
UNIT_PER_STEP = 1.0          # internal units of driver motion per path step (an upper bound)
_SAMPLES = 4097              # first sampling of each driver over the time range
_MAX_SAMPLES = 2_000_000     # adaptive refinement stops here (then the estimate is a lower bound)
# a driver value whose unit in the last place passes this many times the Newton tolerance is
# refused (at 1 the slider-crank's crank 2*pi*t already fails to converge near t = 3e4 s)
PRECISION_FACTOR = 10.0


def node_limit(cm, opts) -> int:
    """Largest number of internal path nodes: max_nodes, or fewer when their memory would pass
    NODE_BYTES (q, q', q'' of n + 3 coordinates per node plus Python's overhead)."""
    per_node = 3 * 8 * (cm.n + 3) + 600
    return int(max(16, min(opts.max_nodes, NODE_BYTES // per_node)))


def check_preflight(cm, opts) -> None:
    """preflight as an input error at the driver's line (InputError), for run and check alike."""
    reason = preflight(cm, opts)
    if reason is None:
        return
    from .diagnostics import Diagnostic, InputError
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
