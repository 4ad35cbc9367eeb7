"""Driver functions of time (`TimeFunction`: f with exact f', f'', f''') and their breakpoints
(times where f, f' or f'' jumps, found with bounded cost)."""

from __future__ import annotations

import ast
import math
from typing import Mapping

import numpy as np

from .core import (CMPS, SWITCH_OPS, ZERO, BuildError, Expr, ExprError, bin_node, derivs_of,
                   diff_expr, evaluate_all, quote)
from .parser import parse_text


_SHARED_MAX = 1024
_NAMES: dict = {}       # (text, the model's parameter names) -> the names the text uses
_SHARED: dict = {}      # (text, the values of those names) -> TimeFunction (TimeFunction.shared)


class TimeFunction:
    """A driver function f(t) with exact first, second (and third) derivatives.

    Parameters in text are replaced by their values and folded; `expr`, `first` and `second`
    are the `Expr` trees of f, f' and f''. `text` is what messages show; `domain` is None or the
    (lo, hi) range of t outside which f is not defined (a non-periodic table).
    """

    def __init__(self, text: str | int | float, values: Mapping[str, float]):
        self._setup(parse_text(text, values.keys(), True, values),
                    text if isinstance(text, str) else str(text))

    @classmethod
    def shared(cls, text: str | int | float, values: Mapping[str, float]) -> "TimeFunction":
        """TimeFunction(text, values), the same object again for the same text and the same
        values of the parameters it uses: a model is validated again for every design of a
        study or a synthesis, and a driver the design does not reach is then not parsed and
        differentiated again. What it keeps later (the third derivative, breakpoints) depends
        on its expression alone."""
        nk = (text, tuple(values))
        names = _NAMES.get(nk)
        if names is None:
            tf = cls(text, values)                   # raises as before
            # every name written in the text, also those its simplification drops (a/a,
            # 0*sqrt(a)): another value of one may make the text invalid
            written = {n.id for n in ast.walk(ast.parse(str(text).strip(), mode="eval"))
                       if isinstance(n, ast.Name)}
            names = tuple(sorted(written & set(values)))
            if len(_NAMES) >= _SHARED_MAX:
                _NAMES.clear()
            _NAMES[nk] = names
        else:
            tf = None
        key = (text, tuple(float(values[n]) for n in names))
        got = _SHARED.get(key)
        if got is None:
            got = tf if tf is not None else cls(text, values)
            if len(_SHARED) >= _SHARED_MAX:
                _SHARED.clear()
            _SHARED[key] = got
        return got

    @classmethod
    def checked(cls, text, values: Mapping[str, float], ranges):
        """shared(text, values), or None where it cannot be made or where it has problems
        (jumps, derivatives that are not finite, see `problems`) over one of the (start, end)
        ranges: what the validator's check of a driver refuses, for a design or a study's
        variant made without validating the file (planarkin.studies.design, .batch)."""
        try:
            f = cls.shared(text, values)
        except Exception:  # noqa: BLE001 - refused: the validator words it
            return None
        bad = any(list(f.problems(lo, hi)) for lo, hi in ranges
                  if math.isfinite(lo) and math.isfinite(hi) and hi > lo)
        return None if bad else f

    @classmethod
    def from_expr(cls, expr: Expr, text: str, domain: tuple | None = None) -> "TimeFunction":
        """A TimeFunction of an expression tree built in code (motion profiles, tables)."""
        self = cls.__new__(cls)
        self._setup(expr, text, domain)
        return self

    def _setup(self, expr: Expr, text: str, domain: tuple | None = None) -> None:
        self.expr, self.text, self.domain = expr, text, domain
        # a table's interpolant f(t) = pw(t), or pw(t0 + mod(t - t0, period)) when periodic:
        # (pw, period or None, rows), set by inputtable.table_function (the budget reads it)
        self.table = None
        if _switch_depth(expr, {}) > MAX_SWITCH_NESTING:
            raise ExprError(f"expression {quote(str(text).strip())} nests piecewise forms (where, "
                            f"min, max, clip, mod, abs, sign, floor, laws) more than "
                            f"{MAX_SWITCH_NESTING} deep")
        try:
            self.first = diff_expr(self.expr, "t", {})
            self.second = diff_expr(self.first, "t", {})
        except BuildError as exc:
            raise ExprError(exc.args[0].replace("{}", quote(self.text.strip()))) from None
        self.is_constant = "t" not in self.expr.names
        self._third = None
        self._bp: dict = {}

    def __getstate__(self):
        return {"expr": self.expr, "text": self.text, "domain": getattr(self, "domain", None),
                "table": getattr(self, "table", None)}

    def __setstate__(self, state):
        self._setup(state["expr"], state["text"], state.get("domain"))
        if state.get("table") is not None:
            self.table = state["table"]

    def __repr__(self) -> str:
        return f"TimeFunction({self.text!r})"

    def __call__(self, t, side: int = 0):
        """f(t) for a scalar (-> float) or an array (-> new array of t's shape)."""
        return evaluate_all((self.expr,), {"t": t}, side)[0]

    def derivatives(self, t, side: int = 0) -> tuple:
        """(f, f', f'') at t, vectorised like __call__.

        side: +1 / -1 the limits from the right / left, which differ from each other only at a
        breakpoint (see `breakpoints`): every switch (abs, sign, where, min, max, clip, mod, a
        law's or table's knot) whose switching value lies at t, or within rounding of t (8 ulp),
        takes the branch of that side. side 0 (the default): SIDE_RULE, the right-hand limit at
        a switch within 8 ulp of t (smooth compositions such as abs(t-a)**2 are exact at a, both
        sides agreeing there); elsewhere
        the plain value."""
        return tuple(evaluate_all((self.expr, self.first, self.second), {"t": t}, side))

    def third(self, t, side: int = 0):
        """f''' at t (the exact symbolic third derivative), vectorised, side as in derivatives."""
        if self._third is None:
            try:
                self._third = diff_expr(self.second, "t", {})
            except BuildError as exc:
                raise ExprError(exc.args[0].replace("{}", quote(self.text.strip()))) from None
        return evaluate_all((self._third,), {"t": t}, side)[0]

    def breakpoints(self, start: float, end: float) -> list:
        """Times in [start, end] where f, f' or f'' jumps (a step, a kink, a jump of the
        acceleration), sorted: the path is followed piece by piece between them.

        Returns a list of `Breakpoint` (t, the jumps of f, f' and f'' there). An expression made
        only of smooth operations has none. A jump of f itself is a model error, reported by the
        validator (see `problems`), so jump[0] is 0 for every breakpoint that reaches the solver.
        Found by `find_breakpoints` (bounded cost: see there); raises ExprError when [start,
        end] holds more than MAX_BREAKPOINTS candidate times."""
        key = (float(start), float(end))
        if key not in self._bp:
            self._bp[key] = find_breakpoints(self, *key)
        return self._bp[key]

    def problems(self, start: float, end: float) -> list:
        """Messages for what makes f unusable as a driver over [start, end]: a time outside its
        domain, a jump of f, derivatives that are not finite beside a breakpoint."""
        out = []
        if self.domain is not None:
            lo, hi = self.domain
            if start < lo or end > hi:
                return [f"{self.text} covers t from {lo:g} to {hi:g} s, but the analysis runs from "
                        f"{start:g} to {end:g} (extend the table, or set periodic: true for a "
                        f"cyclic one)"]
        try:
            bps = self.breakpoints(start, end)
        except ExprError as exc:
            return [str(exc)]
        for bp in bps:
            j = bp.jump
            inside = start < bp.t < end
            if not all(math.isfinite(x) for x in j) and (inside or not bp.finite_inside):
                out.append(f"f = {_short(self.text)} or its derivatives are not finite beside "
                           f"t = {bp.t:.12g}: a driver needs a finite velocity and acceleration")
            elif inside and j[0] != 0:
                out.append(f"f jumps by {j[0]:.6g} at t = {bp.t:.12g}: a driver position must be "
                           f"continuous")
        return out


MAX_SWITCH_NESTING = 6   # switches inside switches' arguments: the cost of one-sided values grows
_SWITCHY = SWITCH_OPS | {"abs", "sqrt"}


def _switch_depth(e: Expr, memo: dict) -> int:
    """How many switches are nested in each other along the deepest path of e."""
    r = memo.get(id(e))
    if r is None:
        inner = max((_switch_depth(a, memo) for a in e.args), default=0)
        r = memo[id(e)] = inner + (e.op in _SWITCHY and e.op != "where")
    return r


def _short(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= 60 else text[:57] + "..."


class Breakpoint:
    """A time where a driver function's derivative jumps: t (s) and jump = (f(t+) - f(t-),
    f'(t+) - f'(t-), f''(t+) - f''(t-)); nan where a one-sided value is not finite."""

    __slots__ = ("t", "jump", "finite_inside")

    def __init__(self, t: float, jump: tuple, finite_inside: bool = True):
        self.t = float(t)
        self.jump = tuple(float(x) for x in jump)
        self.finite_inside = finite_inside  # at start/end: the side inside [start, end] is finite

    def __repr__(self) -> str:
        return f"Breakpoint(t={self.t!r}, jump={self.jump!r})"


# ---- finding breakpoints ----------------------------------------------------------------------

MAX_BREAKPOINTS = 10_000   # candidate times in one [start, end]; more is refused (ExprError)
_BASE_INTERVALS = 1024      # samples per switching argument over [start, end] ...
_SUB = 4                    # ... and each interval between known breaks cut into 4
_JUMP_REL = 1e-11           # a jump below this times the largest |f^(k)| is rounding, not a jump


def _switch_args(exprs) -> list:
    """(g, levels) for every switch in the trees: levels 'zero', 'int' or an array of knots,
    innermost first (so that a switch inside another's argument is found before it)."""
    seen, out, stack = set(), [], list(exprs)
    while stack:
        e = stack.pop()
        if e._str in seen or "t" not in e._names:
            continue
        seen.add(e._str)
        stack.extend(e.args)
        if not e._sw and e.op not in ("abs", "sqrt"):
            continue
        op, a = e.op, e.args
        if op in CMPS:
            out.append((bin_node("-", a[0], a[1]), "zero"))
        elif op in ("sign", "abs", "sqrt"):
            out.append((a[0], "zero"))
        elif op == "floor":
            out.append((a[0], "int"))
        elif op == "pw":
            out.append((a[0], np.asarray(getattr(e.value[0], "switch_knots", e.value[0].knots))))
    uniq = {}
    for g, lv in out:
        if "t" in g._names:
            uniq.setdefault((g._str, lv if isinstance(lv, str) else lv.tobytes()), (g, lv))
    return sorted(uniq.values(), key=lambda x: x[0]._depth)


def _ulp(t):
    return np.spacing(np.maximum(np.abs(t), 1e-300))


def _refine(g: Expr, dg: Expr, ta, tb, level):
    """Roots of g - level bracketed by [ta, tb] (sign change): safeguarded Newton with the
    exact derivative dg, to within 2 ulp (vectorised over brackets)."""
    ta, tb = ta.copy(), tb.copy()
    sa = np.sign(evaluate_all((g,), {"t": ta})[0] - level)
    x = 0.5 * (ta + tb)
    for _ in range(80):
        h, d = evaluate_all((g, dg), {"t": x})
        h = h - level
        left = np.sign(h) == sa
        ta = np.where(left, x, ta)
        tb = np.where(left, tb, x)
        with np.errstate(all="ignore"):
            xn = x - h / d
        ok = np.isfinite(xn) & (xn > ta) & (xn < tb)
        xn = np.where(h == 0, x, np.where(ok, xn, 0.5 * (ta + tb)))
        done = (np.abs(xn - x) <= 2 * _ulp(x)) | (tb - ta <= 2 * _ulp(x))
        x = xn
        if done.all():
            break
    return x


_MAX_SAMPLES = 200_000      # samples of one switching argument, refinement included


def _sample(g: Expr, dg: Expr, a: np.ndarray, b: np.ndarray, sub: int):
    """g and g' on every [a_i, b_i] cut into sub intervals, as flat arrays of the intervals'
    (t0, t1, g0, g1, g'0, g'1); a_i from the right, everything else from the left (so that a
    jump of g at a known break a_i or b_i is not taken for a crossing)."""
    frac = np.linspace(0.0, 1.0, sub + 1)
    S = a[:, None] + (b - a)[:, None] * frac[None, :]
    S[:, -1] = b
    G, G1 = np.empty_like(S), np.empty_like(S)
    G[:, 0], G1[:, 0] = evaluate_all((g, dg), {"t": S[:, 0]}, +1)
    rest = evaluate_all((g, dg), {"t": S[:, 1:].reshape(-1)}, -1)
    G[:, 1:], G1[:, 1:] = (r.reshape(len(a), sub) for r in rest)
    return (S[:, :-1].reshape(-1), S[:, 1:].reshape(-1), G[:, :-1].reshape(-1),
            G[:, 1:].reshape(-1), G1[:, :-1].reshape(-1), G1[:, 1:].reshape(-1))


def find_breakpoints(f: TimeFunction, start: float, end: float) -> list:
    """The breakpoints of f in [start, end] (see TimeFunction.breakpoints).

    For each switching argument g (of abs, sign, sqrt, a comparison, floor/mod, a law's or
    table's knot), innermost first: g and g' are sampled on 1024 intervals of [start, end], each
    interval between breaks already found cut into 4 more (so sawtooth arguments of periodic
    profiles are sampled on every period); a sign change of g - level is refined by safeguarded
    Newton with the exact g'; a sign change of g' whose refined root puts g within 1e-9 of a
    level is a touching root (abs((t-a)**2)). Then the one-sided values of f, f', f'' are
    compared at every candidate and only real jumps kept (larger than 1e-11 times the largest
    |f^(k)| seen, or not finite). Cost: about (1024 + 4 * breaks) * 5 evaluations of g and g'
    per switch, and at most MAX_BREAKPOINTS candidates."""
    if f.is_constant or not (end >= start):
        return []
    trees = (f.expr, f.first, f.second)
    args = _switch_args(trees)
    if not args:
        return []
    found: list = []
    for g, levels in args:
        ders = derivs_of(g)
        if not ders:
            continue
        dg = ders[0]
        d2g = ders[1] if len(ders) > 1 else ZERO
        B = np.unique(np.concatenate([np.linspace(start, end, _BASE_INTERVALS + 1),
                                      np.asarray([x for x in found if start <= x <= end])]))
        if len(B) > MAX_BREAKPOINTS + _BASE_INTERVALS + 1:
            raise ExprError(f"f = {_short(f.text)} switches more than {MAX_BREAKPOINTS} times "
                            f"between t = {start:g} and {end:g}")
        t0, t1, g0, g1, d0, d1 = _sample(g, dg, B[:-1], B[1:], _SUB)
        # where g' disagrees with the secant by a fair part of g's range (or of the level
        # spacing 1 for floor), g may cross a level and back between two samples: those
        # intervals are sampled again, finer, within a bounded number of samples
        total = len(t0)
        while True:
            with np.errstate(all="ignore"):
                fin = np.isfinite(g0) & np.isfinite(g1)
                R = float(np.max(np.maximum(g0, g1)[fin]) - np.min(np.minimum(g0, g1)[fin])) \
                    if fin.any() else 0.0
                if levels == "int" if isinstance(levels, str) else False:
                    R = min(R, 1.0)
                dt = t1 - t0
                sec = (g1 - g0) / np.where(dt > 0, dt, 1.0)
                bad = fin & ((np.abs(d0 - sec) + np.abs(d1 - sec)) * dt > 0.1 * R) & (dt > 0)
            if not bad.any():
                break
            total += 15 * int(bad.sum())
            if total > _MAX_SAMPLES:
                where = float(t0[np.flatnonzero(bad)[0]])
                raise ExprError(f"f = {_short(f.text)} switches too fast to be followed near "
                                f"t = {where:.6g} (more than {_MAX_SAMPLES} samples would be "
                                f"needed to find its switches)")
            r = _sample(g, dg, t0[bad], t1[bad], 16)
            keep = ~bad
            order = np.argsort(np.concatenate([t0[keep], r[0]]), kind="stable")
            t0, t1, g0, g1, d0, d1 = (np.concatenate([x[keep], y])[order]
                                      for x, y in zip((t0, t1, g0, g1, d0, d1), r))
        cands = []
        # level crossings
        if isinstance(levels, str) and levels == "int":
            with np.errstate(invalid="ignore"):
                lo = np.floor(np.minimum(g0, g1))
                hi = np.floor(np.maximum(g0, g1))
            ok = np.isfinite(lo) & np.isfinite(hi)
            cntf = np.where(ok, hi - lo, 0.0)
            if cntf.sum() > MAX_BREAKPOINTS:
                raise ExprError(f"f = {_short(f.text)} switches more than {MAX_BREAKPOINTS} "
                                f"times between t = {start:g} and {end:g}")
            cnt = cntf.astype(np.int64)
            rep = np.repeat(np.arange(len(cnt)), cnt)
            k = lo[rep] + 1 + (np.arange(len(rep)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
            strict = (g0[rep] != k) & (g1[rep] != k)  # an end exactly at k is a candidate itself
            brackets = [(rep[strict], k[strict])]
            cands.append(t1[ok & (g1 == np.round(g1)) & (g0 != g1)])
            exact = ok & (g0 == np.round(g0)) & ((g1 != g0) | (np.roll(g0, 1) != g0))
            cands.append(t0[exact])
        else:
            brackets = []
            lv = np.zeros(1) if isinstance(levels, str) else levels
            for L in lv:
                h0, h1 = g0 - L, g1 - L
                sel = np.flatnonzero(np.sign(h0) * np.sign(h1) < 0)
                brackets.append((sel, np.full(len(sel), L)))
                # an exact zero is a candidate unless g stays at the level (a plateau, or
                # underflow): only where it arrives or leaves
                cands.append(t0[(h0 == 0) & (h1 != 0)])
                cands.append(t1[(h1 == 0) & (h0 != 0)])
        for sel, L in brackets:
            if len(sel):
                # a bracket split by a jump of g (at a known break) is no root: only the pieces
                cands.append(_refine(g, dg, t0[sel], t1[sel], L))
        cands.append(_touching_roots(g, dg, d2g, levels, t0, t1, g0, d0, d1))
        new = np.concatenate(cands) if cands else np.empty(0)
        new = new[(new >= start) & (new <= end)]
        found.extend(new.tolist())
        if len(found) > MAX_BREAKPOINTS:
            raise ExprError(f"f = {_short(f.text)} switches more than {MAX_BREAKPOINTS} times "
                            f"between t = {start:g} and {end:g}")
    if not found:
        return []
    return _real_jumps(trees, np.sort(np.asarray(found)), start, end)


def _touching_roots(g, dg, d2g, levels, t0, t1, g0, d0, d1) -> np.ndarray:
    """Touching roots: where g' changes sign between two samples and g reaches a level there
    (abs((t-a)**2)), refined by Newton on g' with the exact g''."""
    sel = np.flatnonzero(np.sign(d0) * np.sign(d1) < 0)
    if not len(sel) or d2g is None:
        return np.empty(0)
    x = _refine(dg, d2g, t0[sel], t1[sel], 0.0)
    gx = evaluate_all((g,), {"t": x})[0]
    if isinstance(levels, str):
        near = np.round(gx) if levels == "int" else np.zeros_like(gx)
    else:
        j = np.clip(np.searchsorted(levels, gx), 1, max(len(levels) - 1, 1))
        lvl = np.asarray(levels)
        near = np.where(np.abs(gx - lvl[j - 1]) < np.abs(gx - lvl[np.minimum(j, len(lvl) - 1)]),
                        lvl[j - 1], lvl[np.minimum(j, len(lvl) - 1)])
    with np.errstate(invalid="ignore"):
        fin = np.isfinite(g0)
        scale = float(np.max(np.abs(g0[fin]))) if fin.any() else 1.0
    return x[np.abs(gx - near) <= 1e-9 * max(1.0, scale)]


def _real_jumps(trees, T: np.ndarray, start: float, end: float) -> list:
    """The candidates T (sorted) where f, f' or f'' really jumps: one-sided values compared,
    a jump larger than _JUMP_REL times the largest |f^(k)| seen, or not finite."""
    keep = np.concatenate([[True], np.diff(T) > 16 * _ulp(T[1:])])
    T = T[keep]
    nice = np.array([float(f"{x:.12g}") for x in T])  # 0.25, not 0.24999999999999994
    T = np.where(np.abs(nice - T) <= 8 * _ulp(T), nice, T)
    plus = evaluate_all(trees, {"t": T}, +1)
    minus = evaluate_all(trees, {"t": T}, -1)
    grid = np.linspace(start, end, _BASE_INTERVALS + 1)
    base = evaluate_all(trees, {"t": grid})
    out = []
    jumps = []
    for k in range(3):
        vals = np.concatenate([base[k], plus[k], minus[k]])
        fin = vals[np.isfinite(vals)]
        scale = float(np.max(np.abs(fin))) if len(fin) else 0.0
        with np.errstate(invalid="ignore"):
            jk = plus[k] - minus[k]
        real = ~np.isfinite(jk) | (np.abs(jk) > _JUMP_REL * scale)
        jumps.append((np.where(np.isfinite(jk), jk, np.nan), real))
    for i, t in enumerate(T):
        if any(real[i] for _, real in jumps):
            j = tuple(float(jk[i]) if real[i] else 0.0 for jk, real in jumps)
            side = plus if t <= start else minus
            inside_ok = all(math.isfinite(side[k][i]) for k in range(3))
            out.append(Breakpoint(t, j, inside_ok))
    return out
