"""Constant expressions evaluated again with other parameter values, without building a tree.

A model is validated once per design of a sweep, a tolerance study, a synthesis or a fit: the
same texts with new values. Building the folded `Expr` of a text (what `parse_text` does with
values) allocates a node per operation; a plan is the text's arithmetic as nested closures over
the same operations, in the same order (the folding constructors' rule for two numbers is
``float(op(x, y))``), so it gives the same float bit for bit. A plan is made only from a text
that has already been parsed without error, and only of numbers, names, + - * / **, unary signs
and the functions of `FUNCS`; anything else, or any value that is not finite, is `Unplanned`,
and the caller parses the text as before (with the same message for the same problem).
"""

from __future__ import annotations

import ast
import math

import numpy as np

from .core import CONSTANTS, FUNCS

# the folding constructors' functions (core's table of operators, index 2): the same ufuncs
_BIN = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.divide,
        ast.Pow: np.power}


class Unplanned(Exception):
    """The text (or these values) needs the full parser."""


def plan(src: str):
    """A function values -> float for the constant expression src, or None when the text has
    forms a plan does not take (comparisons, where, min/max, mod, laws, ...)."""
    try:
        return _node(ast.parse(src, mode="eval").body)
    except (Unplanned, SyntaxError, ValueError, RecursionError, MemoryError):
        return None


def _node(node):
    kind = type(node)
    if kind is ast.Constant and type(node.value) in (int, float):
        try:
            v = float(node.value)
        except OverflowError:
            raise Unplanned from None
        if not math.isfinite(v):
            raise Unplanned
        return lambda values: v
    if kind is ast.Name:
        return _name(node.id)
    if kind is ast.UnaryOp and type(node.op) in (ast.USub, ast.UAdd):
        a = _node(node.operand)
        if type(node.op) is ast.UAdd:
            return a
        return lambda values: -a(values)
    if kind is ast.BinOp and type(node.op) in _BIN:
        f = _BIN[type(node.op)]
        a, b = _node(node.left), _node(node.right)
        return lambda values: _finite(float(f(a(values), b(values))))
    if kind is ast.Call and type(node.func) is ast.Name and node.func.id in FUNCS \
            and node.func.id != "sign" and not node.keywords \
            and len(node.args) == FUNCS[node.func.id][0]:
        f = FUNCS[node.func.id][2]
        args = tuple(_node(a) for a in node.args)
        if len(args) == 1:
            a, = args
            return lambda values: _finite(float(f(a(values))))
        a, b = args
        return lambda values: _finite(float(f(a(values), b(values))))
    raise Unplanned


def _name(n: str):
    const = CONSTANTS.get(n)

    def value(values):
        if n in values:                 # a parameter of the same name wins over a constant
            v = float(values[n])
            return _finite(v)
        if const is None:
            raise Unplanned
        return const
    return value


def _finite(v: float) -> float:
    if v - v != 0.0:                    # inf or nan: the parser says which
        raise Unplanned
    return v
