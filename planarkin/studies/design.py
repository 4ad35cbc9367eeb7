"""A design's compiled model made from the nominal's arrays (designs as data): what
compile_model gives for the model file validated with the design's parameter values, bit for bit,
without reading, validating or compiling the file again.

`design(B, values)` takes the map a studies.batch.Batch keeps from the varied parameters to every
number they reach (element parameters, joint constants, driver functions, point offsets, pose
estimates, each with its text). Each reached number is evaluated from its text by the validator's
own evaluate_constant (the same bits) and checked as the validator checks every number (finite,
at most MAX_MAGNITUDE; a distance's constant positive; a driver function's problems over the
analysis range); the length scale comes from compile's own sizes (model.compile.length_sizes),
and where it moves, the nominal's internal numbers are rescaled by a power of two (exact for
normal numbers) in a model whose kinds prepare nothing at compile time. A number that fails one
of those checks gives REFUSED (the file with these values is refused; Study.model words why);
anything else the arrays do not hold -- a varied parameter reaching a key the batch does not
map, masses, loads or shapes, a length scale a power of two cannot bridge -- gives None, and the
caller validates and compiles the file (Study.model). tests/test_design_model.py compares both
on random designs of the synthesis examples and on the cases a review found.
"""

from __future__ import annotations

import math
import weakref
from dataclasses import replace

import numpy as np

from ..elements.base import Group, Kind
from ..model.compile import length_scale, length_sizes
from planarkin.functions.expr import ExprError, TimeFunction, evaluate_constant
from ..model.validate import MAX_MAGNITUDE

_NOMINAL: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()   # Batch -> _Nominal


class _Refused:
    """design()'s answer where one of the validator's own checks fails (the file validated
    with these values is refused): a caller that needs no words for it skips validating."""

    def __repr__(self) -> str:
        return "REFUSED"


REFUSED = _Refused()


class _Invalid(Exception):
    """A number of the design fails the validator's check of it."""


def design(B, values: dict):
    """The compiled model of one design (values: the varied parameters of the Batch B) from
    the nominal's arrays; its spec is the nominal's with the design's parameters, overrides
    and driver functions (its elements, bodies, points and warnings keep the nominal's: read
    the arrays). REFUSED where a number of the design fails the check the validator makes of
    it (a value that is not finite or too large, an expression it cannot evaluate, a distance
    that is not positive, a driver function with problems over the range): the file with
    these values is refused, which Study.model words. None where it cannot be made so for
    another reason (see the module docstring)."""
    cm, spec = B.cm, B.cm.spec
    if B.elsewhere or spec.forces is not None or spec.clearance is not None:
        return None     # (masses, loads and shapes are built from the bodies' poses)
    try:
        return _design(B, values, cm, spec)
    except (_Invalid, ExprError):
        return REFUSED
    except Exception:  # noqa: BLE001 - any other case is the validator's to judge (Study.model)
        return None


def _design(B, values, cm, spec):
    ps = {}
    for k in B.order:
        v = float(values[k]) if k in B.varied else evaluate_constant(
            B.texts[k], ps) if k in B.dep else spec.parameters[k]
        ps[k] = _number(v)
    num = lambda text: _number(evaluate_constant(text, ps))    # noqa: E731
    N = _NOMINAL.get(B)
    if N is None:
        N = _NOMINAL[B] = _Nominal(B)
    q = N.q_user.copy()
    for b, c, _, text in B.qvar:
        q[b, c] = num(text)
    sizes = [N.fixed, float(np.abs(q[:, :2]).max(initial=0.0))]
    reached = {}
    for gi, entries in enumerate(B.gvar):
        for name, k, c, _, _, text in entries:
            # a point's other coordinate: the nominal's, in user units (exact: L is a
            # power of two)
            v = reached.setdefault((gi, name, k), list(
                np.atleast_1d(cm.groups[gi].params[name][k]) * cm.L))
            v[c or 0] = num(text)
    for (gi, name, k), v in reached.items():
        unit = N.units[gi][name]
        if unit == "point":
            sizes.append(math.hypot(*v))
        elif unit == "length":
            sizes.append(abs(v[0]))
    consts = []
    for r, text, unit, positive in B.ttext:
        c = num(text)
        if positive and not c > 0:
            raise _Invalid
        consts.append(c)
        if unit == "length":
            sizes.append(abs(c))
    pts = [(j, num(tx), num(ty)) for j, tx, ty in B.stext]
    sizes += [math.hypot(x, y) for _, x, y in pts]
    L = length_scale(max(sizes))
    ratio = cm.L / L                    # a power of two: exact (from normal numbers)
    if ratio != 1.0 and not (N.rescalable and 0.0 < ratio < math.inf):
        return None
    af = cm.angle_factor
    groups = []
    for gi, G in enumerate(cm.groups):
        params = dict(G.params)
        for name, unit in N.units[gi].items():
            if ratio != 1.0 and unit in ("point", "length"):
                params[name] = params[name] * ratio
        mine = [(name, k, v) for (g, name, k), v in reached.items() if g == gi]
        for name, k, v in mine:
            if params[name] is G.params[name]:
                params[name] = params[name].copy()
            unit = N.units[gi][name]
            # as compile_model: a point's [x, y] / L, a length / L, an angle * af
            params[name][k] = np.asarray(v, dtype=float) / L if unit == "point" else \
                v[0] * {"length": 1.0 / L, "angle": af, "real": 1.0}[unit]
        groups.append(Group(G.kind, G.bodies, G.cols, params, G.rows)
                      if mine or ratio != 1.0 else G)
    targets = cm.targets * np.where(N.length_rows, ratio, 1.0)
    for (r, _, unit, _), c in zip(B.ttext, consts):
        targets[r] = c * {"length": 1.0 / L, "angle": af, None: 1.0}[unit]
    point_s = cm.point_s * ratio
    for j, x, y in pts:
        point_s[j] = np.array([x, y]) / L
    q0 = np.array([v for b in q for v in (b[0] / L, b[1] / L, b[2] * af)])
    driver_scale = np.where(N.length_rows[cm.driver_rows], 1.0 / L, cm.driver_scale)
    for a in (targets, point_s, q0, driver_scale):
        a.setflags(write=False)
    funcs, drivers = list(cm.driver_funcs), list(spec.drivers)
    a = spec.analysis
    for r, e_idx, text in B.ftext:       # as the validator: the shared TimeFunction
        f = TimeFunction.checked(text, ps, ((a.start, a.end),))
        if f is None:
            raise _Invalid
        funcs[list(cm.driver_rows).index(r)] = f
        drivers[e_idx - len(spec.joints)] = replace(drivers[e_idx - len(spec.joints)], f=f)
    overrides = {k: ps[k] for k in {**spec.overrides, **dict.fromkeys(B.varied)}}
    spec = replace(spec, parameters=ps, drivers=tuple(drivers), overrides=overrides)
    return replace(cm, spec=spec, L=L,
                   q0=q0, groups=tuple(groups), targets=targets, driver_scale=driver_scale,
                   point_s=point_s, driver_funcs=tuple(funcs))


def _number(v: float) -> float:
    """v where the validator accepts it as a number of the file, else _Invalid."""
    if not abs(v) <= MAX_MAGNITUDE:
        raise _Invalid(f"{v!r} is not a number the file accepts")
    return v


class _Nominal:
    """What design() reads of the nominal once: the largest of the sizes the varied parameters
    do not reach, the bodies' pose estimates (user units), each group's parameter units, the
    rows whose constant is a length, and whether the arrays may be rescaled to another length
    scale (kinds that prepare nothing, no shapes, no subnormal length)."""

    def __init__(self, B):
        cm, spec = B.cm, B.cm.spec
        self.fixed = max((size for src, size in length_sizes(spec)
                          if src[0] != "body" and src not in B.sized), default=0.0)
        self.q_user = np.array([b.q for b in spec.bodies], dtype=float).reshape(-1, 3)
        self.units = [{p.name: p.unit for p in G.kind.params} for G in cm.groups]
        rows = np.zeros(cm.m, dtype=bool)
        for G in cm.groups:
            if G.kind.target_unit == "length":
                rows[G.rows[:, 0]] = True
        self.length_rows = rows
        plain = {"point", "length", "angle", "vector", "real", "flag"}
        lengths = [cm.q0.reshape(-1, 3)[:, :2], cm.point_s, cm.targets[rows]] + [
            G.params[p.name] for G in cm.groups for p in G.kind.params
            if p.unit in ("point", "length")]
        tiny = min((np.abs(a[a != 0]).min(initial=np.inf) for a in lengths), default=np.inf)
        # rescaled by a power of two, a length is exact unless it is subnormal
        self.rescalable = not cm.shapes and tiny >= np.finfo(float).tiny and all(
            type(G.kind).prepare is Kind.prepare and not G.kind.derived
            and all(p.unit in plain for p in G.kind.params) for G in cm.groups)

