"""The parser: `ast.parse` serves only as the parser; its tree is walked against the whitelist
and rebuilt with the smart constructors of planarkin.functions.expr.core."""

from __future__ import annotations

import ast
import difflib
import keyword
import math
import re
from collections.abc import Set as AbstractSet
from typing import Iterable, Mapping

import numpy as np

from ..laws import LAWS  # plain data: the laws do not import expr
from .core import (CONSTANTS, FUNCS, MAX_CHARS, MAX_DEPTH, MAX_NODES, SUGAR, BuildError, Expr,
                   ExprError, bin_node, call_node, cmp_node, logic_node, neg_node, num_node,
                   pw_node, quote, sugar_node, where_node)
from .plan import Unplanned, plan

PW_FUNCS: dict = dict(LAWS)   # name -> Piecewise callable in expressions (the motion laws)

_AST_OPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**",
            ast.USub: "neg", ast.UAdd: "+"}
_AST_CMPS = {ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=", ast.Eq: "==", ast.NotEq: "!="}
_BAD_OPS = {ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<",
            ast.RShift: ">>", ast.BitOr: "|", ast.BitAnd: "&", ast.Invert: "~"}
_BAD_NODES = {
    ast.Lambda: "lambda is",
    ast.Attribute: "attribute access ('.') is", ast.Subscript: "subscripts ('[...]') are",
    ast.JoinedStr: "f-strings are", ast.Tuple: "tuples are",
    ast.List: "lists are", ast.Dict: "dicts are", ast.Set: "sets are", ast.Starred: "'*' is",
    ast.NamedExpr: "':=' is", ast.ListComp: "comprehensions are", ast.SetComp: "comprehensions are",
    ast.DictComp: "comprehensions are", ast.GeneratorExp: "generators are",
    bool: "booleans are", str: "strings are", complex: "complex numbers are",
}



def _did_you_mean(word: str, candidates: Iterable[str]) -> str:
    cands = sorted(candidates)
    match = [c for c in cands if c.lower() == word.lower()]
    match = match or difflib.get_close_matches(word, cands, n=1)
    return f"; did you mean '{match[0]}'?" if match else ""


class _Builder:
    """Walks the ast against the whitelist, rebuilding it with the smart constructors."""

    def __init__(self, names, allow_t, values):
        self.names, self.allow_t, self.values, self.count = names, allow_t, values, 0

    def build(self, node, depth: int) -> Expr:
        self.count += 1
        if depth > MAX_DEPTH:
            raise BuildError(f"expression {{}} is nested too deeply (more than {MAX_DEPTH} levels)")
        if self.count > MAX_NODES:
            raise BuildError(f"expression {{}} is too large (more than {MAX_NODES} nodes)")
        kind = type(node)
        if kind is ast.Constant and type(node.value) in (int, float):
            try:
                v = float(node.value)
            except OverflowError:
                v = math.inf
            if not math.isfinite(v):
                raise BuildError("expression overflows: {}")
            return num_node(v)
        if kind is ast.Name:
            return self.name(node.id)
        if kind is ast.Compare:  # a < b < c means a < b and b < c
            if not all(type(o) in _AST_CMPS for o in node.ops):
                raise BuildError("only < <= > >= == != compare, in expression {}")
            terms = [self.build(node.left, depth + 1)]
            terms += [self.build(c, depth + 1) for c in node.comparators]
            r = None
            for o, a, b in zip(node.ops, terms, terms[1:]):
                c = cmp_node(_AST_CMPS[type(o)], a, b)
                r = c if r is None else logic_node("and", r, c)
            return r
        if kind is ast.BoolOp:
            vals = [self.build(v, depth + 1) for v in node.values]
            r = vals[0]
            for v in vals[1:]:
                r = logic_node("and" if type(node.op) is ast.And else "or", r, v)
            return r
        if kind is ast.IfExp:  # a if c else b is where(c, a, b)
            return where_node(self.build(node.test, depth + 1), self.build(node.body, depth + 1),
                          self.build(node.orelse, depth + 1))
        if kind is ast.UnaryOp and type(node.op) is ast.Not:
            return logic_node("not", self.build(node.operand, depth + 1))
        if kind is ast.BinOp and type(node.op) is ast.Mod:  # Python's %: mod(a, b)
            return sugar_node("mod", (self.build(node.left, depth + 1),
                                  self.build(node.right, depth + 1)))
        if kind is ast.BinOp or kind is ast.UnaryOp:
            op = _AST_OPS.get(type(node.op))
            if type(node.op) is ast.BitXor:
                raise BuildError("use ** for powers, not ^, in expression {}")
            if op is None:
                raise BuildError(f"operator '{_BAD_OPS.get(type(node.op), '?')}' is not allowed in "
                            "expression {}; use + - * / ** % (and comparisons)")
            if kind is ast.UnaryOp:
                a = self.build(node.operand, depth + 1)
                return neg_node(a) if op == "neg" else a
            a, b = self.build(node.left, depth + 1), self.build(node.right, depth + 1)
            return bin_node(op, a, b, strict=True)
        if kind is ast.Call:
            return self.call(node, depth)
        if kind is ast.Constant:
            kind = type(node.value)
        raise BuildError(_BAD_NODES.get(kind, f"'{kind.__name__}' is")
                         + " not allowed in expression {}")

    def name(self, n: str) -> Expr:
        if n == "t" and self.allow_t:
            return Expr("name", (), "t")
        if n in self.names:
            if self.values is None:
                return Expr("name", (), n)
            try:
                v = float(self.values[n])
            except (TypeError, ValueError):
                raise BuildError(f"parameter '{n}' has no numeric value, in expression "
                                 "{}") from None
            if not math.isfinite(v):
                raise BuildError(f"parameter '{n}' is not finite ({v!r}) in expression {{}}")
            return num_node(v)
        if n in CONSTANTS:
            return num_node(CONSTANTS[n])
        if n == "t":
            raise BuildError("'t' (time) is only allowed in driver functions f, not in "
                             "expression {}")
        if n in function_names():
            raise BuildError(f"function '{n}' must be called, e.g. {n}(x), in expression {{}}")
        # values before functions: 'aa' is far more likely a slip for the parameter 'a' than 'atan'
        cands = set(self.names) | set(CONSTANTS) | ({"t"} if self.allow_t else set())
        hint = _did_you_mean(n, cands) or _did_you_mean(n, function_names())
        raise BuildError(f"unknown name '{n}' in expression {{}}{hint}")

    def call(self, node: ast.Call, depth: int) -> Expr:
        names = function_names()
        if type(node.func) is not ast.Name:
            raise BuildError("only functions named directly, such as sin(x), min(a, b) or "
                        "cycloidal(u), may be called, in expression {}")
        fn = node.func.id
        if fn not in names:
            hint = _ALIASES.get(fn) or _did_you_mean(fn, names)
            raise BuildError(f"unknown function '{fn}' in expression {{}}{hint}")
        if node.keywords:
            raise BuildError(f"function '{fn}' takes positional arguments only, in expression {{}}")
        n = FUNCS[fn][0] if fn in FUNCS else SUGAR.get(fn, 1)
        if (len(node.args) != n) if n else len(node.args) < 2:
            form = _FORMS.get(fn, "1 argument (x)")
            raise BuildError(f"function '{fn}' takes {form}, got {len(node.args)}, in "
                             "expression {}")
        args = tuple(self.build(a, depth + 1) for a in node.args)
        if fn in SUGAR:
            return sugar_node(fn, args)
        if fn in PW_FUNCS:
            return pw_node(PW_FUNCS[fn], args[0])
        return call_node(fn, args, strict=True)


_FORMS = {"atan2": "2 arguments (y, x)", "atan2d": "2 arguments (y, x)", "where": "3 arguments (condition, a, b)",
          "clip": "3 arguments (x, lo, hi)", "mod": "2 arguments (x, p)",
          "min": "2 or more arguments", "max": "2 or more arguments"}
# names users bring from elsewhere, answered with the form that exists here
_ALIASES = {"pow": "; use a**b for powers", "ln": "; use log(x) (natural logarithm)",
            "arctan": "; use atan(x)", "arcsin": "; use asin(x)", "arccos": "; use acos(x)",
            "arctan2": "; use atan2(y, x)", "fmod": "; use mod(x, p)", "if": "; use where(c, a, b)",
            "heaviside": "; use where(t >= a, 1, 0)", "step": "; use where(t >= a, 1, 0)",
            "piecewise": "; use where(c, a, b)", "select": "; use where(c, a, b)",
            "fabs": "; use abs(x)", "clamp": "; use clip(x, lo, hi)",
            "minimum": "; use min(a, b)", "maximum": "; use max(a, b)"}


# a number glued to a word (80mm, 2pi, 1.5deg): Python's tokenizer calls it an invalid literal
_GLUED = re.compile(r"(?<![\w.])((?:\d[\d_]*\.?[\d_]*|\.\d[\d_]*)(?:[eE][-+]?\d+)?)"
                    r"([A-Za-z_]\w*)")


def function_names() -> tuple:
    """Every function name an expression may call (the motion laws included)."""
    return tuple(FUNCS) + tuple(SUGAR) + tuple(PW_FUNCS)


def parse_text(text, names: Iterable[str], allow_t: bool, values: Mapping | None) -> Expr:
    if isinstance(text, (bool, np.bool_)):
        raise ExprError(f"expected a number or an expression, got a boolean ({text})")
    if isinstance(text, (int, float, np.integer, np.floating)):
        try:
            v = float(text)
        except OverflowError:
            raise ExprError(f"expression overflows: {quote(str(text))}") from None
        if not math.isfinite(v):
            raise ExprError(f"expression {quote(str(text))} is not finite ({v!r})")
        return num_node(v)
    if not isinstance(text, str):
        raise ExprError(f"expected a number or an expression, got {type(text).__name__}")
    src = text.strip()
    q = quote(src)
    if not src:
        raise ExprError("empty expression")
    if len(src) > MAX_CHARS:
        raise ExprError(f"expression is too long ({len(src)} characters; at most {MAX_CHARS})")
    if "\x00" in src:
        raise ExprError("expression contains a null byte")
    level = 0
    for ch in src:  # bracket nesting, checked before the parser sees the text
        level += (ch in "([{") - (ch in ")]}")
        if level > MAX_DEPTH:
            raise ExprError(f"expression {q} is nested too deeply (more than {MAX_DEPTH} levels)")
    try:
        tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        glued = _GLUED.search(src)
        if glued and not re.fullmatch(r"0[xXoObB]\w*|\d[\d_]*[jJ]", glued.group(0)):
            num, word = glued.group(1), glued.group(2)
            if word in CONSTANTS or word in names or word == "t" or word in function_names():
                fix = f"products need *: write {num}*{word}"
            else:
                fix = (f"numbers carry no units: write {num} and give the unit once for the "
                       f"model (units: {{length: mm}} or {{angle: deg}})")
            raise ExprError(f"cannot parse expression {q}: the number {num} is followed by "
                            f"'{word}'; {fix}") from None
        hint = "; use ** for powers, not ^" if "^" in src else ""
        raise ExprError(f"cannot parse expression {q}: {exc.msg}{hint}") from None
    except Exception:  # ValueError, RecursionError, MemoryError, ... on hostile text
        raise ExprError(f"cannot parse expression {q}") from None
    try:
        # a set or a dict's keys as they are: a copy per expression made a model of
        # thousands of parameters quadratic to read
        known = names if isinstance(names, AbstractSet) else frozenset(names)
        return _Builder(known, allow_t, values).build(tree.body, 1)
    except BuildError as exc:
        raise ExprError(exc.args[0].replace("{}", q)) from None


def parse(text: str | int | float, names: Iterable[str] = (), allow_t: bool = False) -> Expr:
    """Parse text (or a number) into an `Expr`; names are the parameters that may appear."""
    return parse_text(text, names, allow_t, None)


def evaluate_constant(text: str | int | float, values: Mapping[str, float]) -> float:
    """Finite value of a constant expression over the parameters in values."""
    # the two commonest texts of a model file, a number and a parameter's name, without an
    # expression tree: the value parse_text gives them (num_node of the float; name()'s
    # float of the parameter), and anything else, or any error, through parse_text. A model is
    # validated again for every variant of a study and every trial of a synthesis, where this
    # is most of the validation (straight-line.yaml: 83 of 92 texts)
    kind = type(text)
    if kind is int or kind is float:
        v = float(text) if abs(text) < 1e308 else math.inf
        if math.isfinite(v):
            return v
    elif kind is str:
        src = text.strip()
        if src in values and src.isidentifier() and not keyword.iskeyword(src):
            try:
                v = float(values[src])
            except (TypeError, ValueError):
                v = math.nan
            if math.isfinite(v):
                return v
        planned = _PLANS.get(src)
        if planned is not None:
            try:
                with np.errstate(all="ignore"):
                    return planned(values)
            except Unplanned:       # not finite, or a name that is not a parameter here
                pass
        value = parse_text(text, values.keys(), False, values).value  # names substituted, folded
        if src not in _PLANS and len(_PLANS) < 4096:
            _PLANS[src] = plan(src)
        return value
    return parse_text(text, values.keys(), False, values).value


# text -> its plan (planarkin.functions.expr.plan), or None: a text is parsed in full once, then
# evaluated from its plan for every other design. Bounded: --set texts are few, a study's values
# are numbers (the fast path above)
_PLANS: dict = {}
