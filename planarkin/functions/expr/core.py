"""The expression tree: `Expr` nodes, the smart constructors that fold constants and simplify
as trees are built, evaluation (scalar and numpy, with one-sided rules at switches) and exact
symbolic derivatives. The package's docstring (planarkin.functions.expr) describes what is accepted."""

from __future__ import annotations

import functools
import math
import operator
from typing import Mapping

import numpy as np

MAX_CHARS, MAX_DEPTH, MAX_NODES, MAX_TREE_DEPTH, CHUNK = 1000, 64, 2000, 150, 2048
# printed size of one tree: min/max/clip repeat their arguments, so nesting them doubles the
# text (and the work) per level; past this an expression is too complex
MAX_TEXT = 2_000_000


class ExprError(ValueError):
    """Invalid expression; the message is a user-facing sentence fragment naming the text."""


class BuildError(Exception):
    """Raised while building; args[0] is the message with ``{}`` standing for the quoted text."""


def _sign(x: float) -> float:
    return 1.0 if x > 0 else (-1.0 if x < 0 else x * 0.0)  # nan stays nan, like numpy.sign


# name -> (arity, scalar function, vectorised function); 'sign' is private (made by diff(abs))
FUNCS = {
    "sin": (1, math.sin, np.sin), "cos": (1, math.cos, np.cos), "tan": (1, math.tan, np.tan),
    "asin": (1, math.asin, np.arcsin), "acos": (1, math.acos, np.arccos),
    "atan": (1, math.atan, np.arctan), "atan2": (2, math.atan2, np.arctan2),
    "sinh": (1, math.sinh, np.sinh), "cosh": (1, math.cosh, np.cosh),
    "tanh": (1, math.tanh, np.tanh), "exp": (1, math.exp, np.exp), "log": (1, math.log, np.log),
    "sqrt": (1, math.sqrt, np.sqrt), "abs": (1, abs, np.abs),
    "sign": (1, _sign, np.sign), "floor": (1, math.floor, np.floor),
}
# piecewise and periodic forms, rewritten at parse time into where() and floor() (see sugar_node);
# arity None: two or more arguments
SUGAR = {"where": 3, "min": None, "max": None, "clip": 3, "mod": 2,
         # trigonometry in degrees, whatever the file's angle unit: sind(x) is sin(x*pi/180),
         # asind(x) is asin(x)*180/pi (sin and the others always take radians)
         "sind": 1, "cosd": 1, "tand": 1, "asind": 1, "acosd": 1, "atand": 1, "atan2d": 2}
DEGREE_FUNCS = ("sind", "cosd", "tand", "asind", "acosd", "atand", "atan2d")
CMPS = {"<": np.less, "<=": np.less_equal, ">": np.greater, ">=": np.greater_equal,
         "==": np.equal, "!=": np.not_equal}
_LOGIC = {"and": lambda a, b: np.logical_and(a != 0, b != 0),
          "or": lambda a, b: np.logical_or(a != 0, b != 0), "not": lambda a: np.equal(a, 0)}
# ops whose value or derivative switches where an argument crosses a level: evaluated on the
# numpy path with one-sided rules (see _side_sign); "pw" is a piecewise function (laws, tables)
SWITCH_OPS = frozenset(("sign", "floor", "where", "pw") + tuple(CMPS))
# operator -> (precedence, scalar function, vectorised function); math.pow never gives a complex
_BINOPS = {"+": (1, operator.add, np.add), "-": (1, operator.sub, np.subtract),
           "*": (2, operator.mul, np.multiply), "/": (2, operator.truediv, np.divide),
           "**": (4, math.pow, np.power)}
_OPS = {**FUNCS, **_BINOPS, **{k: (2, None, f) for k, f in CMPS.items()},
        **{k: (2 - (k == "not"), None, f) for k, f in _LOGIC.items()},
        "where": (3, None, lambda c, a, b: np.where(c != 0, a, b))}
CONSTANTS = {"pi": math.pi, "e": math.e}


_NO_NAMES: frozenset = frozenset()


class Expr:
    """Immutable expression node. op is 'num' or 'name' (with value), 'neg', a binary operator
    or a function name (with args). Build them with `parse`, not directly."""

    __slots__ = ("op", "args", "value", "_names", "_depth", "prec", "_str", "_cs", "_cv", "_sw")

    def __init__(self, op: str, args: tuple = (), value=None):
        # a node is made for every operation of every text, derivative and design (a synthesis
        # builds its driver's tree again per design): the fields set one by one, a leaf
        # without looking at children
        args = tuple(args)
        if args:
            names = frozenset().union(*[a._names for a in args])
            depth = 1 + max([a._depth for a in args])
            if depth > MAX_TREE_DEPTH:  # keeps every recursive walk far from the recursion limit
                raise BuildError("expression {} is too complex (its derivatives nest more than "
                                 f"{MAX_TREE_DEPTH} levels)")
            sw = op in SWITCH_OPS or any([a._sw for a in args])
        else:
            names, depth, sw = frozenset((value,)) if op == "name" else _NO_NAMES, 1, \
                op in SWITCH_OPS
        # printing precedence: 1 + -, 2 * /, 3 unary minus, 4 **, 5 atoms
        prec = 3 if op == "neg" or (op == "num" and value < 0) else _BINOPS.get(op, (5,))[0]
        put = object.__setattr__
        put(self, "op", op)
        put(self, "args", args)
        put(self, "value", value)
        put(self, "_names", names)
        put(self, "_depth", depth)
        put(self, "prec", prec)
        put(self, "_cs", None)
        put(self, "_cv", None)
        put(self, "_sw", sw)
        text = _format(self)  # eager, so str() never recurses
        if len(text) > MAX_TEXT:
            raise BuildError("expression {} is too complex (its pieces or derivatives would print "
                        f"as more than {MAX_TEXT} characters)")
        put(self, "_str", text)

    def __setattr__(self, key, value):
        raise AttributeError("Expr is immutable")

    def __reduce__(self):
        return (Expr, (self.op, self.args, self.value))

    @property
    def names(self) -> frozenset[str]:
        """Free names used, 't' included (pi and e are folded into numbers)."""
        return self._names

    def __str__(self) -> str:  # unambiguous, so also the key for shared sub-expressions
        return self._str

    def __repr__(self) -> str:
        return f"Expr({self._str!r})"

    def _fn(self, vec: bool):
        """Compiled closure vals -> value (scalar: math module; vec: numpy ufuncs), cached."""
        slot = "_cv" if vec else "_cs"
        if getattr(self, slot) is not None:
            return getattr(self, slot)
        stack = [self]
        while stack:  # compile children first, without recursion
            e = stack[-1]
            todo = [a for a in e.args if getattr(a, slot) is None]
            if todo:
                stack.extend(todo)
                continue
            stack.pop()
            if getattr(e, slot) is None:
                f = _compile(e, vec)
                if vec and e.args:  # a repeated sub-expression is computed once per evaluation
                    f = functools.partial(_memoised, f, e._str)
                object.__setattr__(e, slot, f)
        return getattr(self, slot)

    def evaluate(self, env: Mapping[str, float | np.ndarray]) -> float | np.ndarray:
        """Value for env (name -> float or array). Array inputs give a new array of their
        broadcast shape (also for a constant when env['t'] is an array); scalars a float."""
        return evaluate_all((self,), env)[0]

    def diff(self, var: str = "t") -> Expr:
        """Exact symbolic derivative with respect to var, simplified."""
        try:
            return diff_expr(self, var, {})
        except BuildError as exc:
            raise ExprError(exc.args[0].replace("{}", quote(self._str))) from None


def _format(e: Expr) -> str:
    op, args = e.op, e.args
    _paren = lambda x, yes: f"({x})" if yes else str(x)  # noqa: E731
    if op == "num":
        return str(int(e.value)) if e.value.is_integer() and abs(e.value) < 1e15 else repr(e.value)
    if op == "name":
        return e.value
    if op == "neg":
        return "-" + _paren(args[0], args[0].prec < 4)
    if op in _BINOPS:  # fully determined by the tree: a*(b*c) keeps its parentheses
        p, (a, b) = e.prec, args
        left = _paren(a, a.prec < p or (p == 4 and a.prec == 4))
        right = _paren(b, b.prec < p or b.prec == 3 or (b.prec == p and p != 4))
        return f"{left}{op}{right}" if p > 1 else f"{left} {op} {right}"
    if op in CMPS or op in ("and", "or"):
        return f"({args[0]} {op} {args[1]})"
    if op == "not":
        return f"(not {args[0]})"
    if op == "pw":
        return f"{e.value[0].name}{chr(39) * e.value[1]}({args[0]})"  # primes: derivative order
    return f"{op}({', '.join(map(str, args))})"


def _compile(e: Expr, vec: bool):
    if e.op in SWITCH_OPS:
        return _compile_switch(e)
    if e.op == "num":
        c = e.value
        return lambda vals: c
    if e.op == "name":
        return operator.itemgetter(e.value)
    fs = [a._cv if vec else a._cs for a in e.args]
    if e.op == "neg":
        f = fs[0]
        return lambda vals: -f(vals)
    fn = _OPS[e.op][2 if vec else 1]
    if len(fs) == 1:
        f = fs[0]
        return lambda vals: fn(f(vals))
    (a, b), (fa, fb) = e.args, fs
    if a.op == "num":
        c = a.value
        return lambda vals: fn(c, fb(vals))
    if b.op == "num":
        c = b.value
        return lambda vals: fn(fa(vals), c)
    return lambda vals: fn(fa(vals), fb(vals))


def _memoised(f, key: str, vals: dict):
    r = vals.get(key)
    if r is None:
        r = vals[key] = f(vals)
    return r


SIDE_RULE = (
    "A grid time within 8 units in the last place of a driver's breakpoint, and a cam angle "
    "within 8 units in the last place of a knot of its law (a segment's end, a table's "
    "point), is taken to be at it. There velocity, acceleration and jerk are the right-hand "
    "limits (the values just after), for drivers and cam laws alike and for every kind of "
    "law (motion:, table: or an expression); only a row at the run's end time takes the "
    "left-hand limit of a driver's breakpoint there. Position is continuous at every knot, so "
    "only the derivatives that jump (a follower's acceleration where harmonic meets a dwell, "
    "the jerk wherever the acceleration has a corner) depend on this rule.")
_EPS = float(np.finfo(float).eps)
_PREFILTER = 1e-7   # |d| below this (relative) is looked at closely for a switch at rounding level
# a switch resolved from the derivatives of its argument may meet switches there in turn (a law
# of a law): resolved to this depth, beyond it plain sign(), so that the cost stays bounded
_MAX_RESOLVE_DEPTH = 2


def derivs_of(u: Expr) -> tuple:
    """The first four derivatives of u in t (fewer when one is 0 or too complex), cached."""
    cache = _DERIVS.get(u._str)
    if cache is None:
        out, d = [], u
        for _ in range(4):
            try:
                d = diff_expr(d, "t", {})
            except BuildError:
                break
            if d.op == "num" and d.value == 0:
                break
            out.append(d)
        if len(_DERIVS) > 4096:  # a bound on memory, not a policy
            _DERIVS.clear()
        cache = _DERIVS[u._str] = tuple(out)
    return cache


_DERIVS: dict = {}


def _side_sign(d, u: Expr, vals: dict, scale=None) -> np.ndarray:
    """The sign of d = u - level (an array of the chunk's shape) just beside t, on the side
    vals['@side'] (+1 right, -1 left).

    Where d is 0 (or, unless vals['@exact'], within rounding of 0: u's root lies within 8 ulp
    of t) the sign is that of the first non-zero derivative of u times side**order, so that a
    switch exactly at t takes the branch of the side asked for, and a switch at a touching zero
    (u = (t-a)**2) the branch both sides agree on. Everywhere else it is sign(d)."""
    n = vals["@n"]
    d = _full(d, n)
    s = np.sign(d)
    if "t" not in u._names or vals["@depth"] >= _MAX_RESOLVE_DEPTH:
        return s
    exact = vals["@exact"]
    if exact:
        cand = d == 0
    else:
        ref = float(np.max(np.abs(d))) if scale is None else float(scale)
        cand = np.abs(d) <= _PREFILTER * (ref if ref > 1.0 else 1.0)
    if not cand.any():
        return s
    ders = derivs_of(u)
    if not ders:
        return s
    idx = np.flatnonzero(cand)
    t = np.broadcast_to(vals["t"], (n,))[idx]
    env = {k: (np.broadcast_to(vals[k], (n,))[idx] if isinstance(vals[k], np.ndarray)
               else vals[k]) for k in u._names}
    env["t"] = t
    side = vals["@side"]
    D = _core(ders, env, side, exact, None, depth=vals["@depth"] + 1)
    dd = d[idx]
    snap = dd == 0 if exact else np.abs(dd) <= 8 * _EPS * np.maximum(1.0, np.abs(t)) * np.abs(D[0])
    if not snap.any():
        return s
    res = np.zeros(len(idx))
    done = np.zeros(len(idx), dtype=bool)
    for k, Dk in enumerate(D, 1):
        nz = ~done & (Dk != 0) & ~np.isnan(Dk)
        res[nz] = np.sign(Dk[nz]) * side ** k
        done |= nz
    s = s.copy()
    s[idx[snap]] = res[snap]
    if vals["@hits"] is not None:
        vals["@hits"].append(idx[snap])
    return s


def _full(x, n: int) -> np.ndarray:
    """x as a float array of shape (n,) (a view when it already is one)."""
    if type(x) is np.ndarray and x.shape == (n,) and x.dtype == float:
        return x
    return np.broadcast_to(np.asarray(x, dtype=float), (n,))


def _compile_switch(e: Expr):
    """Vectorised closure for an op in SWITCH_OPS (values are arrays of the chunk's shape)."""
    op, args = e.op, e.args
    fs = [a._fn(True) for a in args]
    if op in CMPS:
        (fa, fb), diff = fs, bin_node("-", *args)
        test = CMPS[op]

        def cmp(vals):
            s = _side_sign(fa(vals) - fb(vals), diff, vals)
            return test(s, 0.0).astype(float)
        return cmp
    if op == "sign":
        (fu,), u = fs, args[0]
        return lambda vals: _side_sign(fu(vals), u, vals)
    if op == "floor":
        (fu,), u = fs, args[0]

        def floor(vals):
            x = _full(fu(vals), vals["@n"])
            r = np.round(x)
            scale = np.max(np.abs(x))
            return r - (_side_sign(x - r, u, vals, scale) < 0)
        return floor
    if op == "where":
        fc, fa, fb = fs
        return lambda vals: np.where(np.asarray(fc(vals)) != 0, fa(vals), fb(vals))
    # "pw": a piecewise function of its argument (value = (Piecewise, derivative order))
    (fu,), u = fs, args[0]
    pw, order = e.value

    key = ("@piece", pw.name, u._str)  # shared by the law's derivatives of every order

    def piecewise(vals):
        x = _full(fu(vals), vals["@n"])
        piece = vals.get(key)
        if piece is None:
            j, d = pw.nearest_knot(x)
            scale = np.max(np.abs(x))
            piece = vals[key] = j - (_side_sign(d, u, vals, scale) < 0)
        return pw.evaluate(x, order, piece)
    return piecewise


def evaluate_all(exprs: tuple, env: Mapping, side: int = 0) -> list:
    """Values of exprs over env (see Expr.evaluate); side as in TimeFunction.derivatives."""
    names = exprs[0]._names if len(exprs) == 1 else frozenset().union(*(e._names for e in exprs))
    vals, arrays = {}, {}
    for n in names:
        x = env[n]
        if type(x) is float:
            vals[n] = x
        elif isinstance(x, (np.ndarray, list, tuple)):
            arrays[n] = np.asarray(x, dtype=float)
        else:
            vals[n] = float(x)
    if "t" not in names and isinstance(env.get("t"), (np.ndarray, list, tuple)):
        arrays[""] = np.asarray(env["t"], dtype=float)  # an unused t still sets the shape
    switch = any(e._sw for e in exprs)
    if not arrays and not switch:
        out = []
        for e in exprs:
            try:
                out.append(e._fn(False)(vals))
            except (ArithmeticError, ValueError):  # math domain error: numpy gives nan/inf
                with np.errstate(all="ignore"):
                    out.append(float(e._fn(True)(vals)))
        return out
    # side 0 is the rule at breakpoints (SIDE_RULE): a switch within 8 ulp of the argument is
    # at it, and there the right-hand limit holds, as at a driver's breakpoint row
    side = side or 1
    if not arrays:  # a scalar through a switch: the one-sided rules live on the numpy path
        out = _core(exprs, {n: np.array([v]) for n, v in vals.items()}, side, False, None)
        return [float(o[0]) for o in out]
    shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    flat = {n: np.broadcast_to(a, shape).reshape(-1) for n, a in arrays.items()}
    out = _core(exprs, {**vals, **flat}, side, False, None)
    return [o.reshape(shape) for o in out]


def _core(exprs: tuple, env: dict, side: int, exact: bool, hits, average: bool = False,
          depth: int = 0) -> list:
    """Chunked numpy evaluation; env values are floats or flat arrays of one length.

    average (side 0): evaluated as seen from the right with switches resolved only at exact
    zeros; the points where a switch sat exactly at t are evaluated again from the left and the
    two averaged, so that a smooth composition (abs(t-a)**2 at a) gets its exact value and a
    kink the mean of its two one-sided limits."""
    if average:
        side, exact = 1, True
    size = next((len(v) for v in env.values() if isinstance(v, np.ndarray)), 1)
    out = [np.empty(size) for _ in exprs]
    with np.errstate(all="ignore"):
        for i in range(0, size, CHUNK):
            m = min(CHUNK, size - i)
            chunk = {n: (v[i:i + m] if isinstance(v, np.ndarray) else v) for n, v in env.items()}
            got = [] if average else hits
            chunk.update({"@n": m, "@side": side, "@exact": exact, "@hits": got, "@depth": depth})
            for o, e in zip(out, exprs):
                o[i:i + m] = e._fn(True)(chunk)
            if average and got:
                idx = np.unique(np.concatenate(got))
                sub = {n: (v[i:i + m][idx] if isinstance(v, np.ndarray) else v)
                       for n, v in env.items()}
                left = _core(exprs, sub, -1, True, None, depth=depth)
                for o, lv in zip(out, left):
                    o[i + idx] = 0.5 * (o[i + idx] + lv)
    return out


def diff_expr(e: Expr, var: str, memo: dict) -> Expr:
    if var not in e._names:
        return ZERO
    r = memo.get(id(e))
    if r is None:
        r = memo[id(e)] = _derive(e, var, memo)
    return r


def _derive(e: Expr, var: str, memo: dict) -> Expr:
    op, args = e.op, e.args
    if op == "name":
        return _ONE
    if op in CMPS or op in _LOGIC or op in ("sign", "floor"):
        return ZERO  # piecewise constant; a jump of the value is found by breakpoints()
    if op == "where":  # exact piece by piece
        return where_node(args[0], diff_expr(args[1], var, memo), diff_expr(args[2], var, memo))
    u = args[0]
    du = diff_expr(u, var, memo)
    if op == "neg":
        return neg_node(du)
    if op in _BINOPS:
        w = args[1]
        dw = diff_expr(w, var, memo)
        if op in ("+", "-"):
            return bin_node(op, du, dw)
        if op == "*":
            return bin_node("+", bin_node("*", du, w), bin_node("*", u, dw))
        if op == "/":
            if var not in w._names:
                return bin_node("/", du, w)
            return bin_node("/", bin_node("-", bin_node("*", du, w), bin_node("*", u, dw)),
                            bin_node("**", w, _TWO))
        if var not in w._names:  # u**c -> c*u**(c-1)*u'
            return bin_node("*", bin_node("*", w, bin_node("**", u, bin_node("-", w, _ONE))), du)
        if var not in u._names:  # c**v -> c**v*log(c)*v'
            return bin_node("*", bin_node("*", e, call_node("log", (u,))), dw)
        inner = bin_node("+", bin_node("*", dw, call_node("log", (u,))),
                         bin_node("/", bin_node("*", w, du), u))
        return bin_node("*", e, inner)  # u**v -> u**v*(v'*log(u) + v*u'/u)
    if op == "atan2":  # (x*y' - y*x')/(x**2 + y**2)
        x, dx = args[1], diff_expr(args[1], var, memo)
        num = bin_node("-", bin_node("*", x, du), bin_node("*", u, dx))
        return bin_node("/", num, bin_node("+", bin_node("**", x, _TWO), bin_node("**", u, _TWO)))
    if op == "pw":
        pw, order = e.value
        return bin_node("*", Expr("pw", (u,), (pw, order + 1)), du)
    one_minus_u2 = lambda: bin_node("-", _ONE, bin_node("**", u, _TWO))  # noqa: E731
    g = {"sin": lambda: call_node("cos", (u,)), "cos": lambda: neg_node(call_node("sin", (u,))),
         "tan": lambda: bin_node("/", _ONE, bin_node("**", call_node("cos", (u,)), _TWO)),
         "asin": lambda: bin_node("/", _ONE, call_node("sqrt", (one_minus_u2(),))),
         "acos": lambda: bin_node("/", num_node(-1.0), call_node("sqrt", (one_minus_u2(),))),
         "atan": lambda: bin_node("/", _ONE, bin_node("+", _ONE, bin_node("**", u, _TWO))),
         "sinh": lambda: call_node("cosh", (u,)), "cosh": lambda: call_node("sinh", (u,)),
         "tanh": lambda: bin_node("/", _ONE, bin_node("**", call_node("cosh", (u,)), _TWO)),
         "exp": lambda: e, "log": lambda: bin_node("/", _ONE, u),
         "sqrt": lambda: bin_node("/", _ONE, bin_node("*", _TWO, e)),
         "abs": lambda: call_node("sign", (u,))}[op]()  # outer derivative g(u), times u'
    if g.op == "/" and g.args[0].op == "num":  # (c/v)*u' -> (c*u')/v
        return bin_node("/", bin_node("*", g.args[0], du), g.args[1])
    return bin_node("*", g, du)


# ---- smart constructors: fold constants and simplify ----------------------------------------

def num_node(v: float) -> Expr:
    return Expr("num", (), float(v))


ZERO, _ONE, _TWO = num_node(0.0), num_node(1.0), num_node(2.0)


def _fold(op: str, vals: tuple, strict: bool) -> Expr | None:
    """Folded constant; if not finite: None (keep the node), or BuildError when strict."""
    fast = _FAST_FOLD.get(op)
    if fast is not None and (op != "/" or vals[1] != 0):
        r = float(fast(*vals))      # IEEE arithmetic: numpy's float64 result, bit for bit
    else:
        with np.errstate(all="ignore"):
            r = float(_OPS[op][2](*vals))
    if math.isfinite(r):
        return num_node(r)
    if not strict:
        return None
    if (op == "/" and vals[1] == 0) or (op == "**" and vals[0] == 0 and vals[1] < 0):
        raise BuildError("division by zero in expression {}")
    if math.isnan(r) or op == "log":
        raise BuildError("expression {} is not finite (%r)" % r)
    raise BuildError("expression overflows: {}")


# + - * / of two floats in Python: the same IEEE double operation as numpy's ufunc (an overflow
# gives inf there too) without an errstate block per fold; a division by zero, powers and
# functions stay on numpy (tests/test_expr.py compares both on random and edge-case operands)
_FAST_FOLD = {"+": operator.add, "-": operator.sub, "*": operator.mul, "/": operator.truediv}


def _num(e: Expr) -> float | None:
    return e.value if e.op == "num" else None


def _split(e: Expr) -> tuple:  # c*u -> (c, u); u -> (1, u)
    return (e.args[0].value, e.args[1]) if e.op == "*" and e.args[0].op == "num" else (1.0, e)


def neg_node(a: Expr) -> Expr:
    if a.op in ("num", "neg"):
        return num_node(-a.value) if a.op == "num" else a.args[0]
    c, u = _split(a)
    return Expr("neg", (a,)) if u is a else (u if c == -1 else Expr("*", (num_node(-c), u)))


def _negative(e: Expr) -> bool:
    return e.op == "neg" or _split(e)[0] < 0 or (e.op == "num" and e.value < 0)


def _same(a: Expr, b: Expr) -> bool:
    return a is b or (a._names == b._names and str(a) == str(b))


def bin_node(op: str, a: Expr, b: Expr, strict: bool = False) -> Expr:
    x, y = _num(a), _num(b)
    if x is not None and y is not None:
        return _fold(op, (x, y), strict) or Expr(op, (a, b))
    if op in ("+", "-"):
        if y == 0 or x == 0:
            return a if y == 0 else b if op == "+" else neg_node(b)
        if _negative(b):
            return bin_node("-" if op == "+" else "+", a, neg_node(b))
        if op == "+" and _negative(a):
            return bin_node("-", b, neg_node(a))
        if _same(a, b):
            return bin_node("*", _TWO, a) if op == "+" else ZERO
    elif op in ("*", "/") and (a.op == "neg" or b.op == "neg"):
        r = bin_node(op, a.args[0] if a.op == "neg" else a, b.args[0] if b.op == "neg" else b)
        return r if a.op == b.op else neg_node(r)
    elif op == "*":
        if x == 0 or y == 0:
            return ZERO
        ca, ra = (x, None) if x is not None else _split(a)
        cb, rb = (y, None) if y is not None else _split(b)
        c = ca * cb  # canonical form: the constant first, c*u
        if math.isfinite(c):
            core = rb if ra is None else ra if rb is None else Expr("*", (ra, rb))
            return core if c == 1 else neg_node(core) if c == -1 else Expr("*", (num_node(c), core))
    elif op == "/":
        if y in (1, -1) or x == 0:
            return ZERO if x == 0 else a if y == 1 else neg_node(a)
        if _same(a, b):
            return _ONE
        c, u = _split(a)
        if c != 1 and y is None:  # (c*u)/v -> c*(u/v)
            return bin_node("*", num_node(c), bin_node("/", u, b))
        if c != 1 and math.isfinite(c / y):  # (c*u)/k -> (c/k)*u
            return bin_node("*", num_node(c / y), u)
    elif y == 0 or x == 1 or y == 1:  # **
        return a if y == 1 else _ONE
    elif op == "**" and _even(b) and a.op in ("abs", "sqrt"):
        # abs(u)**2k = u**2k, sqrt(u)**2k = u**k: exact where the rule for abs or sqrt at 0 is not
        return bin_node("**", a.args[0], b if a.op == "abs" else num_node(b.value / 2))
    return Expr(op, (a, b))


def call_node(fn: str, args: tuple, strict: bool = False) -> Expr:
    vals = tuple(_num(a) for a in args)
    if None not in vals:
        return _fold(fn, vals, strict) or Expr(fn, args)
    a = args[0]
    if fn == "sqrt" and a.op == "**" and _even(a.args[1]):  # sqrt(u**2k) = abs(u)**k, exact
        k = a.args[1].value / 2  # derivatives at u = 0 (the rule 1/(2*sqrt) would give 0/0)
        absu = call_node("abs", (a.args[0],))
        return absu if k == 1 else bin_node("**", absu, num_node(k))
    if fn in ("abs", "sign") and a.op == "neg":
        return call_node(fn, (a.args[0],)) if fn == "abs" else neg_node(call_node(fn, (a.args[0],)))
    return Expr(fn, args)


def _even(e: Expr) -> bool:
    return e.op == "num" and e.value > 0 and e.value % 2 == 0


def cmp_node(op: str, a: Expr, b: Expr) -> Expr:
    x, y = _num(a), _num(b)
    return num_node(float(CMPS[op](x, y))) if x is not None and y is not None else Expr(op, (a, b))


def logic_node(op: str, *args: Expr) -> Expr:
    vals = tuple(_num(a) for a in args)
    if None not in vals:
        return num_node(float(_LOGIC[op](*vals)))
    return Expr(op, tuple(_truth(a) for a in args))


def _truth(c: Expr) -> Expr:
    """c as a condition (1 or 0): comparisons and logic as they are, anything else c != 0."""
    return c if c.op in CMPS or c.op in _LOGIC or c.op == "num" else Expr("!=", (c, ZERO))


def where_node(c: Expr, a: Expr, b: Expr) -> Expr:
    if c.op == "num":
        return a if c.value != 0 else b
    if _same(a, b):
        return a
    return Expr("where", (_truth(c), a, b))


def pw_node(pw, u: Expr, order: int = 0) -> Expr:
    """A piecewise function (planarkin.functions.laws, planarkin.functions.inputtable) of u."""
    if u.op == "num":
        x = np.array([u.value])
        j, d = pw.nearest_knot(x)
        return num_node(float(pw.evaluate(x, order, j - (d < 0))[0]))
    return Expr("pw", (u,), (pw, order))


def sugar_node(fn: str, args: tuple) -> Expr:
    """min, max, clip, mod and where, written with where() and floor(); the trigonometric
    functions in degrees, written with those in radians."""
    if fn in ("sind", "cosd", "tand"):
        return call_node(fn[:-1], (bin_node("*", args[0], num_node(math.pi / 180)),))
    if fn in DEGREE_FUNCS:
        return bin_node("*", call_node(fn[:-1], args), num_node(180 / math.pi))
    if fn == "where":
        return where_node(*args)
    if fn in ("min", "max"):  # a balanced tree: nesting grows as log2 of the arguments
        if len(args) > 2:
            h = len(args) // 2
            return sugar_node(fn, (sugar_node(fn, args[:h]) if h > 1 else args[0],
                               sugar_node(fn, args[h:]) if len(args) - h > 1 else args[h]))
        a, b = args
        return where_node(cmp_node("<=" if fn == "min" else ">=", a, b), a, b)
    if fn == "clip":
        x, lo, hi = args
        return where_node(cmp_node("<", x, lo), lo, where_node(cmp_node(">", x, hi), hi, x))
    x, p = args  # mod: x - p*floor(x/p), in [0, p) for p > 0 (Python's %)
    if _num(p) == 0:
        raise BuildError("mod by zero in expression {}")
    return bin_node("-", x, bin_node("*", p, call_node("floor", (bin_node("/", x, p),))))


def quote(text: str) -> str:
    return "'" + (text if len(text) <= 80 else text[:77] + "...") + "'"

