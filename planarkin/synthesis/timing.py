"""Targets whose inputs are relative to an unknown offset: `inputs: {offset: free, step: 60}`.

The classic statement of precision points at input angles theta0 + k delta, theta0 found (and
delta given or found): input e of such a target is u_e = offset + rel_e, rel_e = e step
(`step:`) or the value given (`values:`), in the driver's unit (spec.Timing). The offset and a
free step are unknowns of the search, after the free parameters and the free times of the
layout (Synthesis.timing: (target, 'offset' | 'step') per unknown, Synthesis.nu of them).

Each input's time t_e solves f(t_e; p) = u_e, so (the chain rule of problem.py's prescribed
inputs, with u_e now moving too):

    dt_e/dp = -f_p / f_t,   dt_e/d offset = 1 / f_t,   dt_e/d step = e / f_t (values: 0),

and a residual row r(t_e) has d r/d offset = r_t / f_t: the offset's column gathers, row by
row, the chain rule through each point's input (exact, `dtdx`). In a model that returns to its
start at the end of its range (Synthesis.wrap), u_e is taken modulo the driver's travel over
the range (one turn), a shift of whole turns that leaves the derivatives as they are; the
offset is then unbounded in a local run (as a free time around the cycle) and reported
within the driver's range. The start of a search's offset (and step) is the best of a scan
over the driver's values on the start's grid (`start`), as the free times of a start are the
grid's nearest points.
"""

from __future__ import annotations

import numpy as np

STEPS = 24          # steps tried per start when the step is an unknown (see start)


def layout(targets) -> list:
    """[(target index, 'offset' | 'step')] of the unknowns, in order."""
    return [(i, name) for i, tg in enumerate(targets) if tg.timing is not None
            for name in tg.timing.unknowns]


def probe_wrap(syn) -> None:
    """Decide syn.wrap before a search: whether the free times of a closed target, and the
    offsets of inputs relative to one, go around the cycle (the model returns to its start).
    Decided on the bounds' midpoint, else the file's own values (each when inside the
    bounds; an evaluation each), else left to the first start accepted (None until then,
    taken as no: Synthesis.candidates calls settle_wrap). On the midpoint alone, a file whose
    midpoint is no linkage (every length halfway: a change point) was searched without
    wrapping (ellipse.yaml: runs from the first 100 starts of seed 0 reached the published
    best in 3 of 18 with wrapping, in none without).

    An open path's points, and free times without a closed target, are taken in order
    within the analysis range, not around it: its start (a free start angle, or the range
    chosen) fixes where the sweep begins. Around the cycle, straight-line.yaml's searches
    took many times the evaluations and one seed missed the goal within its budget
    (benchmarks/README.md, "Figures moved from the code's comments")."""
    from .problem import Rejected
    if not (syn.closed or syn.nu):
        syn.wrap = False
        return
    syn.wrap = None
    nominal = np.array([float(syn.model.spec.parameters[k]) for k in syn.model.free])
    for x in ((syn.lo + syn.hi) / 2, nominal):
        if np.all((syn.lo <= x) & (x <= syn.hi)):
            syn.tick()
            got = syn.model.analyse(syn.model.values(x))
            if not isinstance(got, Rejected):
                settle_wrap(syn, got[2])
                return


def settle_wrap(syn, res) -> None:
    """syn.wrap from the analysis res of a design: whether the model returns to its start at
    the end of its range (Model.periodic), for a closed target or offsets (an open path never
    wraps: probe_wrap); InputError for a closed target when it does not."""
    syn.wrap = bool(syn.closed or syn.nu) and syn.model.periodic(res)
    closed = [tg for tg in syn.design.targets if tg.closed]
    if closed and not syn.wrap:
        from ..diagnostics import Diagnostic, InputError
        raise InputError([Diagnostic(syn.model.path, closed[0].line, (
            "design: a closed target (closed: true, or its last point the first) is traced "
            "once per turn: the model must return to its start at the end of the analysis "
            "range (the driver turning once), and the first design analysed does not"))])


def travel(syn, cm) -> tuple:
    """(u(start), u(end)) of the driver over the analysis range, its unit."""
    u = syn.model.input_values(cm, np.array([syn.start, syn.end]))
    return float(u[0]), float(u[1])


def bounds(syn) -> tuple:
    """(lo, hi) of the unknowns (syn.timing) from each target's bounds or, without them, the
    nominal model's driver travel: an offset keeps every input within the travel, a step
    within it from the first input to the last (the sign of the travel)."""
    u0, u1 = travel(syn, syn.model.nominal)
    lo, hi = [], []
    for i, name in syn.timing:
        tm = syn.design.targets[i].timing
        given = tm.offset_bounds if name == "offset" else tm.step_bounds
        if given is not None:
            b = given
        elif name == "step":
            b = sorted((0.0, (u1 - u0) / max(1, tm.n - 1)))
        else:
            rel = [e * (hi_step(syn, tm) if tm.step is None else tm.step)
                   for e in (0, tm.n - 1)] if tm.values is None else tm.values
            b = (min(u0, u1) - min(rel), max(u0, u1) - max(rel))
            if b[0] >= b[1]:
                b = (min(u0, u1), max(u0, u1))
        lo.append(float(b[0]))
        hi.append(float(b[1]))
    return np.array(lo), np.array(hi)


def hi_step(syn, tm) -> float:
    """The step's end farthest from zero (its bounds, or the travel over n - 1 steps)."""
    if tm.step_bounds is not None:
        return max(tm.step_bounds, key=abs)
    u0, u1 = travel(syn, syn.model.nominal)
    return (u1 - u0) / max(1, tm.n - 1)


def values(syn, i, xu) -> tuple:
    """(offset, step) of target i from the unknowns' values xu (syn.timing's order)."""
    tm = syn.design.targets[i].timing
    got = {name: float(xu[c]) for c, (j, name) in enumerate(syn.timing) if j == i}
    return got.get("offset", tm.offset), got.get("step", tm.step)


def inputs(syn, cm, i, xu) -> np.ndarray:
    """(N,) the driver values of target i's inputs, wrapped into the driver's travel when the
    model returns to its start (syn.wrap)."""
    tm = syn.design.targets[i].timing
    offset, step = values(syn, i, xu)
    u = offset + np.array(tm.relative(step))
    return wrap_inputs(syn, cm, u)


def wrap_inputs(syn, cm, u) -> np.ndarray:
    if not syn.wrap:
        return u
    u0, u1 = travel(syn, cm)
    if u1 == u0:
        return u
    return u0 + np.mod(u - u0, u1 - u0)


def times(syn, cm, grid, i, xu):
    """(N,) the times of target i's inputs (Model.times_of on grid), or Rejected."""
    return syn.model.times_of(cm, grid, inputs(syn, cm, i, xu))


def dtdx(syn, cm, i, t, ncol: int, col0: int) -> np.ndarray:
    """(N, ncol) the exact dt/dx of target i's inputs at their times t: -f_p / f_t in the
    parameters' columns, 1 / f_t in the offset's, e / f_t in the step's (columns col0 + c of
    the unknowns syn.timing), zero in the free times'."""
    out = np.zeros((len(t), ncol))
    out[:, :syn.k] = syn.model.input_dtdp(cm, t)
    el = syn.model.driver(cm)
    _, ft, _ = el.f.derivatives(np.asarray(t, dtype=float))
    ft = np.broadcast_to(ft, np.shape(t))
    for c, (j, name) in enumerate(syn.timing):
        if j != i:
            continue
        du = np.ones(len(t)) if name == "offset" else np.arange(len(t), dtype=float)
        out[:, col0 + c] = du / ft
    return out


def prescribed_dtdx(syn, cm, t, ncol: int) -> np.ndarray:
    """(N, ncol) dt/dx of prescribed inputs: -f_p / f_t in the parameters' columns."""
    out = np.zeros((len(t), ncol))
    out[:, :syn.k] = syn.model.input_dtdp(cm, t)
    return out


def start(syn, cm, res) -> np.ndarray:
    """(nu,) the unknowns' start for an analysed design: per target, the offset (and step) of
    a scan whose inputs, placed on the grid by the driver's values (linear between grid
    points), leave the least weighted sum of squares of the grid's interpolated values;
    the offsets tried are the driver's grid values (within the bounds), the steps STEPS
    between low and high."""
    lo, hi = bounds(syn)
    out = np.zeros(syn.nu)
    fg = syn.model.input_values(cm, res.t)
    order = np.argsort(fg, kind="stable")
    for i, tg in enumerate(syn.design.targets):
        tm = tg.timing
        if tm is None:
            continue
        cols = [c for c, (j, _) in enumerate(syn.timing) if j == i]
        names = [syn.timing[c][1] for c in cols]
        oc = cols[names.index("offset")] if "offset" in names else None
        sc = cols[names.index("step")] if "step" in names else None
        # inside the bounds, where a local run's change of variables (x = mid + half sin z)
        # has a slope to move it
        inner = 1e-3 * (hi - lo)
        offsets = np.array([tm.offset]) if oc is None else \
            np.unique(np.clip(fg, lo[oc] + inner[oc], hi[oc] - inner[oc]))
        steps = np.array([tm.step if tm.step is not None else 0.0]) if sc is None else \
            np.linspace(lo[sc], hi[sc], STEPS + 2)[1:-1]
        vals, goal, angle = _grid_quantities(syn, tg, res)
        best = (np.inf, offsets[0], steps[0])
        for s in steps:
            rel = np.array(tm.relative(s))
            U = wrap_inputs(syn, cm, offsets[:, None] + rel[None, :])       # (O, N)
            tt = np.interp(U, fg[order], res.t[order])
            V = np.stack([np.interp(tt, res.t, vals[:, c]) for c in range(vals.shape[1])],
                         axis=-1)                                           # (O, N, c)
            D = V - goal[None]
            if angle is not None:
                D[..., angle] = _wrap_angle(D[..., angle], syn.unit)
            cost = (D ** 2).sum(axis=(1, 2))
            o = int(np.argmin(cost))
            if cost[o] < best[0]:
                best = (float(cost[o]), offsets[o], s)
        if oc is not None:
            out[oc] = best[1]
        if sc is not None:
            out[sc] = best[2]
    return out


def _grid_quantities(syn, tg, res):
    """(G, c) the target's quantities on the grid, (N, c) their targets, the column that is an
    angle (or None)."""
    if tg.kind == "function":
        body, _, qty = tg.name.rpartition(".")
        col = 3 * syn.bodies.index(body) + ("x", "y", "phi").index(qty)
        return res.q[:, [col]], np.array(tg.values, dtype=float)[:, None], \
            (0 if qty == "phi" else None)
    j = syn.points.index(tg.point if tg.kind == "motion" else tg.name)
    P = res.p[:, j]
    goal = np.array(tg.values, dtype=float)
    if tg.kind == "path":
        return P, goal, None
    phi = res.q[:, 3 * syn.bodies.index(tg.name) + 2]
    return np.column_stack([P, phi]), goal, 2


def _wrap_angle(d, unit):
    half = 180.0 if unit == "deg" else np.pi
    return (d + half) % (2 * half) - half


def report(syn, x) -> list:
    """Per target with an unknown offset: {target, offset, step, unit} of the unknowns' values
    in the design x (full layout), the offset within the driver's travel when the model
    returns to its start."""
    xu = np.asarray(x)[syn.k + syn.nt:]
    cm = syn.model.nominal
    el = syn.model.driver(cm)
    from ..elements import KINDS
    unit = syn.unit if KINDS[el.kind].target_unit == "angle" else syn.lunit
    out = []
    for i, tg in enumerate(syn.design.targets):
        if tg.timing is None:
            continue
        offset, step = values(syn, i, xu)
        offset = float(wrap_inputs(syn, cm, np.array([offset]))[0])
        out.append({"target": i + 1, "offset": offset,
                    "step": step if tg.timing.values is None else None, "unit": unit,
                    "found": list(tg.timing.unknowns)})
    return out

