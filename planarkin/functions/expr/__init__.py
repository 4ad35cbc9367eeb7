"""Arithmetic expressions in model files: parsed, folded and differentiated, never eval'd.

Accepted (anything else is an `ExprError`):

* numbers: Python int and float literals (``2``, ``.5``, ``1e-6``, ``0x10``); digit separators
  follow Python, so ``1_000`` is 1000 and ``1__0`` an error. All arithmetic is in floats;
* names: the caller's parameters, ``t`` (time, drivers only), the constants ``pi`` and ``e``
  (a parameter of the same name wins, so an offset called ``e`` works);
* ``+ - * / ** %`` (``^`` is rejected with a hint), unary ``-`` and ``+``, parentheses;
* comparisons ``< <= > >= == !=`` (chained: ``a < t < b``), ``and or not``, ``a if c else b``:
  conditions are 1 or 0;
* calls, positional arguments only: sin cos tan asin acos atan atan2(y, x) sinh cosh tanh exp
  log sqrt abs sign floor, where(c, a, b), min/max(a, b, ...), clip(x, lo, hi), mod(x, p), and
  the motion laws of planarkin.functions.laws (cycloidal(u), ...); the trigonometric functions take
  radians whatever the file's angle unit, and sind cosd tand asind acosd atand atan2d(y, x) are
  the same in degrees.

`ast.parse` serves only as the parser; its tree is walked against that whitelist and rebuilt as
an immutable `Expr`. min, max, clip and mod are rewritten into where() and floor(), the
functions in degrees into those in radians. Limits: 1000 characters, 64 levels of nesting, 2000 nodes, derivative trees at most 150 levels deep and
2,000,000 characters printed, piecewise forms nested at most 6 deep (TimeFunction). Constants
are folded (one that overflows, divides by zero or is not finite is an error) and trees
simplified as they are built (x+0, x*1, x*0, x-x, x/x, c1*(c2*u), sqrt(u**2) = abs(u),
abs(u)**2 = u**2, ...), so results may differ from the literal text in the last bit.
`Expr.diff` is exact, piece by piece for the piecewise forms. Evaluation never raises for domain
problems (nan/inf come back silently): scalars use `math` and redo the evaluation with numpy on
a domain error; arrays go through numpy ufuncs in chunks of 2048 points (temporaries stay in
cache), shared sub-expressions computed once. Expressions with switches (sign, floor,
comparisons, where, laws, tables) always take the numpy path, where a switch exactly at t (or,
for one-sided evaluation, within rounding of t) is resolved from the requested side; see
`TimeFunction.derivatives` and `TimeFunction.breakpoints`.

The cost of evaluating an expression, on arrays and on Python floats, as measured when this
package was written: benchmarks/README.md, "Figures moved from the code's comments".
"""

from __future__ import annotations

from .core import Expr, ExprError
from .parser import evaluate_constant, function_names, parse
from .timefunction import Breakpoint, TimeFunction, find_breakpoints

__all__ = ["ExprError", "Expr", "parse", "evaluate_constant", "TimeFunction", "Breakpoint",
           "find_breakpoints", "function_names"]
