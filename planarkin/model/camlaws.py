"""A cam's law given as data (``s:`` of a cam, ``psi:`` of a cam-rocker), besides an expression:

    s: {motion: {segments: [{rise: 10, in: 120, law: cycloidal}, {dwell: 60},
                            {return: 10, in: 120, law: 3-4-5}, {dwell: 60}]}}
    s: {table: lift.csv}   or   {table: {file: lift.csv, angle: COLUMN, value: COLUMN,
                                         periodic: true}}

The segment form is the driver's ``motion:`` (planarkin.functions.motion) with cam angle in the place of
time (``in`` and ``dwell`` in the file's angle unit, ``t0`` the cam angle where the first segment
starts); the table form is the driver's ``table:`` (planarkin.functions.inputtable: the same reader, the
same quintic spline) with a cam-angle column. Both become an `elements.cam.FunctionLaw`.

Without ``range`` a law describes every turn, so it must repeat each turn: a motion repeats
(``repeat`` defaults to true then) with a whole number of cycles per turn; a table covers one
turn exactly and is periodic (``periodic`` defaults to true when it does). With ``range`` the law
is used over that part of the turn only: a table must cover it (outside its angles the law is not
defined and the run stops there). A jump of the law's first derivative (a kink in the profile,
an infinite follower acceleration) is an error; a jump of the second derivative (harmonic into a
dwell) is allowed, as in practice: the follower's acceleration jumps there.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..diagnostics import Diagnostic
from ..elements.cam import FunctionLaw

TOL = 1e-9


def _turn(V) -> float:
    return 360.0 if getattr(V, "angle_unit", "rad") == "deg" else 2 * math.pi


def cam_law_form(V, node, p, what: str):
    """A FunctionLaw from the mapping node of a cam's s or psi, or None (diagnostics in V)."""
    what = f"{what}: {p.name}"
    if not V.keys(node, ("motion", "table"), what):
        return None
    given = [k for k in ("motion", "table") if k in node.value]
    if len(given) != 1:
        V.err(node, f"{what}: give one of motion and table"
                    + (f", not {' and '.join(given)}" if given else " (or an expression of "
                                                                    "theta)"))
        return None
    if given[0] == "motion":
        return _motion(V, node.value["motion"], what)
    return _table(V, node.value["table"], what)


def _motion(V, node, what: str):
    from planarkin.functions.expr import ExprError
    from planarkin.functions.motion import profile
    unit = getattr(V, "angle_unit", "rad")
    res = V.motion(node, what, over=unit)
    if res is None:
        return None
    segs, initial, t0, repeat = res
    total = sum(s.duration for s in segs)
    if repeat is None:
        repeat = "range" not in V.cam_keys
    try:
        fn = profile(segs, initial, t0, repeat)
    except ExprError as e:
        V.err(node, f"{what}: motion: {e}")
        return None
    turn = _turn(V)
    cycles = turn / total
    periodic = repeat and abs(cycles - round(cycles)) <= TOL * cycles and round(cycles) >= 1
    law = FunctionLaw(fn, fn.text, total, periodic)
    law.line, law.repeat = node.line, repeat
    return law


def _table(V, node, what: str):
    from planarkin.functions.inputtable import TableError, read_columns, table_function
    what = f"{what}: table"
    ref = V.table_ref(node, what, ("angle", "value"), ("periodic",),
                      " of cam angle and value")
    if ref is None:
        return None
    fname, cols, v = ref
    periodic = None
    if "periodic" in v:
        n = v["periodic"]
        if not (n.kind == "scalar" and isinstance(n.value, bool)):
            V.err(n, f"{what}: periodic must be true or false")
            return None
        periodic = n.value
    path = Path(V.file).parent / fname
    shown = str(path)
    owner = what.rsplit(": ", 2)[0]
    try:
        (th, y), lines = read_columns(path, [(cols.get("angle"), 0, "cam angle"),
                                             (cols.get("value"), 1, "value")])
    except TableError as exc:
        V.table_errors(exc, node, what, shown, f"the law of {owner}")
        return None
    turn = _turn(V)
    span = float(th[-1] - th[0])
    if periodic is None:
        periodic = abs(span - turn) <= TOL * turn and "range" not in V.cam_keys
    if periodic:
        scale = max(1.0, float(abs(y).max()))
        if abs(y[-1] - y[0]) > TOL * scale:
            V.C.items.append(Diagnostic(
                shown, lines[-1], f"a periodic table must end with the value it starts with: "
                                  f"{y[-1]:g} here, {y[0]:g} at line {lines[0]} (the law of "
                                  f"{owner})"))
            return None
    try:
        fn = table_function(th, y, periodic, fname)
    except (ValueError, ArithmeticError) as exc:
        V.err(node, f"{what}: cannot interpolate {fname}: {exc}")
        return None
    law = FunctionLaw(fn, f"table {fname}", span, periodic and abs(span - turn) <= TOL * turn)
    law.line = node.line
    law.angles = (float(th[0]), float(th[-1]))
    return law


def check_law(V, params: dict, v: dict, what: str) -> None:
    """With the element's range known: a data law without range must repeat every turn; a table
    must cover its range; the law's first derivative must not jump where the cam uses it (for a
    law of every turn: also at the joint of one turn with the next)."""
    import numpy as np

    from planarkin.functions.expr import ExprError
    for name in ("s", "psi"):
        law = params.get(name)
        if not isinstance(law, FunctionLaw):
            continue
        turn, unit = _turn(V), getattr(V, "angle_unit", "rad")
        rng = params.get("range")
        line = getattr(law, "line", None) or v[name].line
        table = hasattr(law, "angles")
        if rng is None and not law.periodic:
            if table:
                lo, hi = law.angles
                V.err(line, f"{what}: {name}: without range the table must cover one full turn "
                            f"({turn:g} {unit}) and be periodic; it covers {lo:g} to {hi:g} "
                            f"{unit}; give range: [from, to] for the part of the turn it "
                            f"describes")
            else:
                V.err(line, f"{what}: {name}: without range the motion must repeat a whole number "
                            f"of times per turn ({turn:g} {unit}); its segments cover "
                            f"{law.span:g} {unit}"
                            + ("" if getattr(law, "repeat", True) else " and repeat is false")
                            + "; give range: [from, to] for the part of the turn it describes")
            continue
        lo, hi = (0.0, turn) if rng is None else rng
        if table and not law.periodic and not (law.angles[0] <= lo and hi <= law.angles[1]):
            V.err(line, f"{what}: {name}: the table covers {law.angles[0]:g} to "
                        f"{law.angles[1]:g} {unit}, not all of range [{lo:g}, {hi:g}]")
            continue
        a, b = (lo - turn / 8, hi + turn / 8) if rng is None else (lo, hi)
        try:
            bps = law.fn.breakpoints(a, b)
            scale = float(np.max(np.abs(law.fn.derivatives(np.linspace(lo, hi, 2001))[1])))
        except ExprError as e:
            V.err(line, f"{what}: {name}: {e}")
            continue
        for bp in bps:
            jump = bp.jump[1]
            if a < bp.t < b and not abs(jump) <= 1e-9 * scale:
                V.err(line, f"{what}: {name}: the law's first derivative jumps by "
                            f"{abs(jump):.4g} at "
                            f"theta = {bp.t % turn if rng is None else bp.t:.6g} {unit} (a kink "
                            f"in the profile: the follower's acceleration would be infinite "
                            f"there); join the segments with laws that start and end at rest "
                            f"(cycloidal, 3-4-5, ...)")
                break
