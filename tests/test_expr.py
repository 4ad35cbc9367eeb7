"""Tests for planarkin.functions.expr: parsing, evaluation, exact derivatives, and hostile input."""

import math
import pickle
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from planarkin.functions import expr as E
from planarkin.functions.expr.core import CHUNK
from planarkin.functions.expr import Expr, ExprError, TimeFunction, evaluate_constant, parse


def value(text, **env):
    """Evaluate text with env giving the parameters (and 't' if present)."""
    e = parse(text, names=[n for n in env if n != "t"], allow_t="t" in env)
    return e.evaluate(env)


# ---- parsing and evaluation ---------------------------------------------------------------------

@pytest.mark.parametrize("text, expected", [
    ("1+2", 3.0), ("7-10", -3.0), ("3*4", 12.0), ("1/4", 0.25), ("2**10", 1024.0),
    ("-2**2", -4.0), ("2**3**2", 512.0), ("(2**3)**2", 64.0), ("2**-1", 0.5), ("-(-3)", 3.0),
    ("+5", 5.0), ("1+2*3", 7.0), ("(1+2)*3", 9.0), ("10-4-3", 3.0), ("100/10/5", 2.0),
    ("2*-3", -6.0), (".5", 0.5), ("1e-10", 1e-10), ("0.1*(1+1e-6)", 0.1 * (1 + 1e-6)),
    ("pi", math.pi), ("e", math.e), ("2*pi", 2 * math.pi), ("-e**2", -math.e ** 2),
    ("  3  ", 3.0), ("(\n1 +\n2)", 3.0),
])
def test_constant_expressions(text, expected):
    assert evaluate_constant(text, {}) == pytest.approx(expected, rel=1e-15)
    assert parse(text).evaluate({}) == pytest.approx(expected, rel=1e-15)


@pytest.mark.parametrize("text, expected", [
    ("x + y", 2.5), ("x - y", -1.5), ("x*y", 1.0), ("x/y", 0.25), ("y**x", 2.0 ** 0.5),
    ("-x**2", -0.25), ("x**y**2", 0.5 ** 4), ("(x + y)*(x - y)", 0.25 - 4.0), ("-(x)*-y", 1.0),
])
def test_operators_on_parameters(text, expected):
    assert value(text, x=0.5, y=2.0) == pytest.approx(expected, rel=1e-15)


FUNCTIONS = [
    ("sin", math.sin, 0.7), ("cos", math.cos, 0.7), ("tan", math.tan, 0.7),
    ("asin", math.asin, 0.3), ("acos", math.acos, -0.3), ("atan", math.atan, 2.5),
    ("sinh", math.sinh, 1.2), ("cosh", math.cosh, -1.2), ("tanh", math.tanh, 0.4),
    ("exp", math.exp, -1.5), ("log", math.log, 2.5), ("sqrt", math.sqrt, 2.0), ("abs", abs, -3.25),
]


@pytest.mark.parametrize("name, ref, x", FUNCTIONS)
def test_functions(name, ref, x):
    assert value(f"{name}(x)", x=x) == pytest.approx(ref(x), rel=1e-15)  # scalar path
    assert evaluate_constant(f"{name}({x!r})", {}) == pytest.approx(ref(x), rel=1e-15)  # folded
    xs = np.array([x, x / 2])
    np.testing.assert_allclose(value(f"{name}(x)", x=xs), [ref(x), ref(x / 2)], rtol=1e-14)


@pytest.mark.parametrize("y, x", [(1, 2), (1, -2), (-1, -2), (-1, 2), (0.0, 1.0), (3, 0)])
def test_atan2(y, x):
    assert value("atan2(y, x)", y=y, x=x) == pytest.approx(math.atan2(y, x), rel=1e-15)
    assert evaluate_constant(f"atan2({y}, {x})", {}) == pytest.approx(math.atan2(y, x), rel=1e-15)


DEGREES = [("sind", lambda x: math.sin(math.radians(x)), 30.0),
           ("cosd", lambda x: math.cos(math.radians(x)), 60.0),
           ("tand", lambda x: math.tan(math.radians(x)), 45.0),
           ("asind", lambda x: math.degrees(math.asin(x)), 0.5),
           ("acosd", lambda x: math.degrees(math.acos(x)), 0.5),
           ("atand", lambda x: math.degrees(math.atan(x)), 1.0)]


@pytest.mark.parametrize("name, ref, x", DEGREES)
def test_functions_in_degrees(name, ref, x):
    assert value(f"{name}(x)", x=x) == pytest.approx(ref(x), rel=1e-15)
    assert evaluate_constant(f"{name}({x!r})", {}) == pytest.approx(ref(x), rel=1e-15)
    assert value("atan2d(y, x)", y=-1.0, x=-1.0) == pytest.approx(-135.0, rel=1e-15)


def test_a_pedal_written_in_degrees_turns_once_a_second_with_exact_derivatives():
    # a file with units: {angle: deg} wrote cos(360*t), which takes radians (57 turns a second)
    t = np.linspace(0.0, 1.0, 1001)
    got = TimeFunction("30*cosd(360*t)", {}).derivatives(t)
    w = 2 * math.pi
    want = (30 * np.cos(w * t), -30 * w * np.sin(w * t), -30 * w * w * np.cos(w * t))
    for g, r in zip(got, want):
        np.testing.assert_allclose(g, r, rtol=0, atol=1e-15 * np.abs(r).max())
    # asind's derivative is asin's times 180/pi, exactly
    d = TimeFunction("asind(t/2)", {}).derivatives(np.array([0.5]))[1][0]
    assert d == pytest.approx(180 / math.pi / 2 / math.sqrt(1 - 0.0625), rel=1e-15)


def test_parameters_and_names():
    assert evaluate_constant("b/2 + 3*a", {"a": 2, "b": 5}) == 8.5
    assert evaluate_constant("a/2", {"a": np.float64(3.0)}) == 1.5
    e = parse("2*pi*omega*t + phi", names=["omega", "phi", "unused"], allow_t=True)
    assert e.names == frozenset({"omega", "phi", "t"})
    assert parse("2*pi*e").names == frozenset()
    # a parameter called e (an offset, say) takes precedence over the constant
    assert evaluate_constant("2*e", {"e": 0.25}) == 0.5
    assert parse("2*e", names=["e"]).names == frozenset({"e"})


def test_numbers_as_input():
    assert evaluate_constant(3, {}) == 3.0 and type(evaluate_constant(3, {})) is float
    assert evaluate_constant(0.25, {}) == 0.25
    assert evaluate_constant(np.float64(1.5), {}) == 1.5
    assert TimeFunction(2, {})(0.0) == 2.0 and TimeFunction(2, {}).text == "2"


def test_digit_separators_follow_python():
    assert evaluate_constant("1_000", {}) == 1000.0
    assert evaluate_constant("1_000.5e1_0", {}) == 1000.5e10
    with pytest.raises(ExprError, match="cannot parse expression '1__000'"):
        parse("1__000")
    with pytest.raises(ExprError, match="cannot parse expression '1000_'"):
        parse("1000_")


def test_scalar_results_are_python_floats():
    assert type(value("sin(t)", t=0.5)) is float
    assert type(value("t", t=1)) is float
    assert type(parse("3").evaluate({})) is float


def test_vectorised_equals_pointwise():
    rng = np.random.default_rng(1)
    t = rng.uniform(0.05, 2.0, size=257)
    for text in ["0.3 + 0.05*sin(2*pi*t)**2", "exp(-t/2)*cos(3*t + 0.2) - sqrt(1 + t**2)",
                 "atan2(sin(t), t - 1)", "abs(t - 1)**1.5 + log(t)*tanh(t)", "t**t / (1 + t)",
                 "a*t + b", "asin(t/3) + acos(t/3) + atan(t) + sinh(t) - cosh(t) + tan(t)"]:
        e = parse(text, names=["a", "b"], allow_t=True)
        env = {"a": 0.5, "b": -1.0}
        vec = e.evaluate({**env, "t": t})
        pointwise = [e.evaluate({**env, "t": float(ti)}) for ti in t]
        np.testing.assert_allclose(vec, pointwise, rtol=1e-13, atol=1e-15)
        assert vec.shape == t.shape
        grid = t[:256].reshape(16, 16)  # n-d arrays keep their shape; lists are accepted
        on_grid = e.evaluate({**env, "t": grid})
        np.testing.assert_allclose(on_grid, vec[:256].reshape(16, 16), rtol=1e-13)
        np.testing.assert_allclose(e.evaluate({**env, "t": list(t[:5])}), vec[:5], rtol=1e-13)


def test_long_arrays_are_evaluated_in_chunks_correctly():
    t = np.linspace(-3, 3, 3 * CHUNK + 17)
    f = TimeFunction("sin(t)*t + t**2", {})
    v, d1, d2 = f.derivatives(t)
    np.testing.assert_allclose(v, np.sin(t) * t + t ** 2, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(d1, np.cos(t) * t + np.sin(t) + 2 * t, rtol=1e-13, atol=1e-14)
    np.testing.assert_allclose(d2, -np.sin(t) * t + 2 * np.cos(t) + 2, rtol=1e-13, atol=1e-14)


def test_constant_broadcasts_to_shape_of_t():
    t = np.zeros((3, 4))
    r = parse("2*a", names=["a"]).evaluate({"a": 1.5, "t": t})
    assert isinstance(r, np.ndarray) and r.shape == (3, 4) and np.all(r == 3.0)
    f = TimeFunction("0.5 + a", {"a": 1})
    assert f.is_constant and f(0.3) == 1.5
    v, d1, d2 = f.derivatives(np.linspace(0, 1, 7))
    assert v.shape == d1.shape == d2.shape == (7,)
    assert np.all(v == 1.5) and np.all(d1 == 0) and np.all(d2 == 0)
    zero_d = TimeFunction("t", {})(np.array(2.0))
    assert isinstance(zero_d, np.ndarray) and zero_d.shape == () and zero_d == 2.0


def test_results_are_new_arrays():
    t = np.linspace(0, 1, 5)
    f = TimeFunction("t", {})
    r = f(t)
    assert r is not t and np.array_equal(r, t)
    v, d1, d2 = TimeFunction("exp(t)", {}).derivatives(t)  # f = f' = f'' share one tree
    assert v is not d1 and d1 is not d2
    v[:] = 0
    assert np.all(d1 > 0)


def test_domain_errors_are_silent_nan_and_inf():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert math.isnan(value("sqrt(t - 2)", t=1.0))
        assert value("log(t)", t=0.0) == -math.inf
        assert value("1/t", t=0.0) == math.inf
        assert math.isnan(value("t**0.5", t=-1.0))
        assert math.isnan(value("asin(t)", t=2.0))
        assert value("exp(t)", t=1000.0) == math.inf
        assert math.isnan(value("sin(t)", t=math.inf))
        r = value("sqrt(t) + 1/t", t=np.array([-1.0, 0.0, 4.0]))
        assert math.isnan(r[0]) and r[1] == math.inf and r[2] == 2.25


# ---- derivatives --------------------------------------------------------------------------------

C1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
C2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])
TS = np.array([0.15, 0.4, 0.55, 0.9, 1.3])


def fd(fn, coefficients, order, h):
    """Eighth-order central finite difference of fn at the points TS."""
    ts = TS[:, None] + h * np.arange(-4, 5)[None, :]
    return (fn(ts) @ coefficients) / h ** order


def check_close(exact, approx, rtol):
    scale = max(1.0, float(np.max(np.abs(exact))))
    np.testing.assert_allclose(approx, exact, rtol=rtol, atol=rtol * scale)


DERIVATIVE_CASES = [
    # each function, composed with an inner function (chain rule)
    "sin(3*t)", "cos(t**2)", "tan(0.5*t)", "asin(0.4*t)", "acos(0.3*t + 0.1)", "atan(2*t)",
    "atan2(sin(t), 2 + cos(t))", "atan2(-1 - t, t - 2)", "atan2(t - 1, -0.5)", "sinh(t)",
    "cosh(2*t)", "tanh(t - 0.5)", "exp(-t)", "log(1 + t**2)", "sqrt(1 + t)", "abs(t - 0.7)",
    "abs(sin(3*t))", "t**3", "2**t", "t**t", "1/t",
    # composites
    "0.3 + 0.05*sin(2*pi*t)**2", "exp(-0.5*t)*cos(3*t + 0.2)", "(1 + t**2)/(2 + sin(t))",
    "sqrt(1 + t**2)*log(2 + t)", "2**(t/3) - t**3 + 4*t - 1", "asin(0.5*sin(t)) + acos(0.3*t)",
    "tanh(2*t - 1)**2 + sinh(t)*cosh(t)", "abs(t - 0.3)*t", "tan(0.5*t)/(1 + t)",
    "-(-(t))**3/7 + 1/t", "exp(sin(t))**(1 + t)", "log(t)**2 + sqrt(t)",
    "(1 + t)**(1/3) - 1/(1 + t)**2", "atan2(sin(2*t), 1 + 0.5*cos(t))*exp(-t/4)", "cos(t)/sin(t)",
]


@pytest.mark.parametrize("text", DERIVATIVE_CASES)
def test_derivatives_match_finite_differences(text):
    f = TimeFunction(text, {})
    v, d1, d2 = f.derivatives(TS)
    np.testing.assert_allclose(v, [f(float(t)) for t in TS], rtol=1e-14)
    check_close(d1, fd(f, C1, 1, 1e-3), 1e-7)
    check_close(d2, fd(f, C2, 2, 2e-3), 1e-7)
    check_close(d2, fd(lambda t: f.first.evaluate({"t": t}), C1, 1, 1e-3), 1e-7)
    e = parse(text, allow_t=True)  # Expr.diff gives the same as TimeFunction
    np.testing.assert_allclose(e.diff().diff().evaluate({"t": TS}), d2, rtol=1e-13)


def test_closed_form_derivatives():
    t = np.linspace(0, 1, 11)
    w = 2 * math.pi
    f, d1, d2 = TimeFunction("0.3 + 0.05*sin(2*pi*t)**2", {}).derivatives(t)
    np.testing.assert_allclose(f, 0.3 + 0.05 * np.sin(w * t) ** 2, rtol=1e-14)
    np.testing.assert_allclose(d1, 0.05 * w * np.sin(2 * w * t), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(d2, 0.1 * w ** 2 * np.cos(2 * w * t), rtol=1e-12, atol=1e-13)

    p = {"amp": 0.2, "omega": 3.0, "phi": 0.4}
    f, d1, d2 = TimeFunction("amp*sin(omega*t + phi)", p).derivatives(t)
    np.testing.assert_allclose(d1, 0.6 * np.cos(3 * t + 0.4), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(d2, -1.8 * np.sin(3 * t + 0.4), rtol=1e-14, atol=1e-15)

    f, d1, d2 = TimeFunction("log(1 + t**2)", {}).derivatives(t)
    np.testing.assert_allclose(d1, 2 * t / (1 + t ** 2), rtol=1e-14)
    np.testing.assert_allclose(d2, 2 * (1 - t ** 2) / (1 + t ** 2) ** 2, rtol=1e-13, atol=1e-15)


def test_linear_driver_derivatives_are_exact_and_small():
    f = TimeFunction("2*pi*t", {})
    assert not f.is_constant and f.text == "2*pi*t"
    assert str(f.expr) == "6.283185307179586*t"
    assert str(f.first) == "6.283185307179586" and str(f.second) == "0"
    assert f.derivatives(0.25) == (math.pi / 2, 2 * math.pi, 0.0)
    f = TimeFunction("w*t + 0.5*alpha*t**2", {"w": 2.0, "alpha": 3.0})
    assert str(f.first) == "2 + 3*t" and str(f.second) == "3"


def test_simplification_rules():
    def s(text):
        return str(parse(text, names=["x", "y"]))
    assert s("x + 0") == s("0 + x") == s("x*1") == s("1*x") == s("x - 0") == s("x/1") == "x"
    assert s("x**1") == "x" and s("x**0") == "1" and s("x*0") == "0" and s("0*x") == "0"
    assert s("-(-x)") == "x" and s("x - x") == "0" and s("x/x") == "1" and s("x + x") == "2*x"
    assert s("2*(3*x)") == "6*x" and s("x*3") == "3*x" and s("x + -y") == "x - y"
    assert str(parse("x*y", ["x", "y"]).diff("t")) == "0"
    assert str(parse("x*t", ["x"], allow_t=True).diff("x")) == "t"
    assert str(parse("sin(t)", allow_t=True).diff()) == "cos(t)"
    assert str(parse("abs(t)", allow_t=True).diff()) == "sign(t)"
    assert str(parse("abs(t)", allow_t=True).diff().diff()) == "0"


def test_derivative_with_symbolic_parameters():
    e = parse("a*t**2 + b*sin(t)", names=["a", "b"], allow_t=True)
    d = e.diff()
    assert d.names == frozenset({"a", "b", "t"})
    expected = 2 * 1.5 * 0.3 + 2 * math.cos(0.3)
    assert d.evaluate({"a": 1.5, "b": 2.0, "t": 0.3}) == pytest.approx(expected, rel=1e-15)


def test_str_reparses_to_equal_value():
    t = np.linspace(0.1, 2.0, 9)
    env = {"a": 0.7, "b": 1.3, "t": t}
    for text in ["a - (b - t)", "a/(b/t)", "(a**b)**t", "a**b**t", "-t**2", "(-t)**3",
                 "2**-t", "t*(a*b)", "-(a + t)", "1e-300*t + 1e300", "a - -t", "t/-3",
                 "atan2(-t, -(a*b))", "0.1*(1+1e-6)*t", "-2**2*t", "exp(-t/2)*cos(3*t + 0.2)",
                 "a*b/t/t", "(t - a)*(t + b)/(t - b)", "sqrt(abs(t - 1))"]:
        e = parse(text, names=["a", "b"], allow_t=True)
        again = parse(str(e), names=["a", "b"], allow_t=True)
        np.testing.assert_allclose(again.evaluate(env), e.evaluate(env), rtol=1e-15)
        assert str(again) == str(e)
        d = e.diff()  # derivatives print re-parseably too (when they contain no sign())
        if "sign" not in str(d):
            d_again = parse(str(d), ["a", "b"], allow_t=True)
            np.testing.assert_allclose(d_again.evaluate(env), d.evaluate(env), rtol=1e-14)


def test_expr_is_immutable_and_picklable():
    e = parse("a*sin(t)", names=["a"], allow_t=True)
    with pytest.raises(AttributeError):
        e.op = "cos"
    e.evaluate({"a": 1.0, "t": 0.5})  # caches compiled closures; pickling must still work
    again = pickle.loads(pickle.dumps(e))
    assert str(again) == str(e) and again.evaluate({"a": 2.0, "t": 0.5}) == 2 * math.sin(0.5)
    f = pickle.loads(pickle.dumps(TimeFunction("sin(t)", {})))
    assert f.derivatives(0.0) == (0.0, 1.0, -0.0)
    assert isinstance(e, Expr) and repr(e) == "Expr('a*sin(t)')"


# ---- errors -------------------------------------------------------------------------------------

@pytest.mark.parametrize("text, values, message", [
    ("1/(a-a)", {"a": 2.0}, "division by zero in expression '1/(a-a)'"),
    ("a^2", {"a": 2.0}, "use ** for powers, not ^, in expression 'a^2'"),
    ("2*t", {}, "'t' (time) is only allowed in driver functions f, not in expression '2*t'"),
    ("9**9**9**9", {}, "expression overflows: '9**9**9**9'"),
    ("1e308*10", {}, "expression overflows: '1e308*10'"),
    ("sqrt(-1)", {}, "expression 'sqrt(-1)' is not finite (nan)"),
    ("log(a - 1)", {"a": 1}, "expression 'log(a - 1)' is not finite (-inf)"),
    ("atan2(1)", {}, "function 'atan2' takes 2 arguments (y, x), got 1, in expression 'atan2(1)'"),
    ("sin(1, 2)", {}, "function 'sin' takes 1 argument (x), got 2, in expression 'sin(1, 2)'"),
    ("sin(x=1)", {}, "function 'sin' takes positional arguments only, in expression 'sin(x=1)'"),
    ("sin*2", {}, "function 'sin' must be called, e.g. sin(x), in expression 'sin*2'"),
    ("sine(1)", {}, "unknown function 'sine' in expression 'sine(1)'; did you mean 'sin'?"),
    ("maxi(1, 2)", {}, "unknown function 'maxi' in expression 'maxi(1, 2)'; did you mean 'max'?"),
    ("pow(2, 3)", {}, "unknown function 'pow' in expression 'pow(2, 3)'; use a**b for powers"),
    ("where(1, 2)", {}, "function 'where' takes 3 arguments (condition, a, b), got 2, in "
                        "expression 'where(1, 2)'"),
    ("min(1)", {}, "function 'min' takes 2 or more arguments, got 1, in expression 'min(1)'"),
    ("mod(1, 0)", {}, "mod by zero in expression 'mod(1, 0)'"),
    ("80mm", {}, "cannot parse expression '80mm': the number 80 is followed by 'mm'; numbers "
                 "carry no units: write 80 and give the unit once for the model (units: "
                 "{length: mm} or {angle: deg})"),
    ("2pi", {}, "cannot parse expression '2pi': the number 2 is followed by 'pi'; products "
                "need *: write 2*pi"),
    ("0**-1", {}, "division by zero in expression '0**-1'"),
    ("7 // 2", {}, "operator '//' is not allowed in expression '7 // 2'; use + - * / ** % (and "
                  "comparisons)"),
    ("  ", {}, "empty expression"),
    (True, {}, "expected a number or an expression, got a boolean (True)"),
    (None, {}, "expected a number or an expression, got NoneType"),
    (math.inf, {}, "expression 'inf' is not finite (inf)"),
    ("a*2", {"a": math.nan}, "parameter 'a' is not finite (nan) in expression 'a*2'"),
    ("a*2", {"a": "x"}, "parameter 'a' has no numeric value, in expression 'a*2'"),
])
def test_error_messages_of_evaluate_constant(text, values, message):
    with pytest.raises(ExprError) as info:
        evaluate_constant(text, values)
    assert str(info.value) == message


@pytest.mark.parametrize("call, message", [
    (lambda: TimeFunction("2*pi*omgea*t", {"omega": 3.0}),
     "unknown name 'omgea' in expression '2*pi*omgea*t'; did you mean 'omega'?"),
    (lambda: TimeFunction("T*2", {}), "unknown name 'T' in expression 'T*2'; did you mean 't'?"),
    (lambda: TimeFunction(False, {}), "expected a number or an expression, got a boolean (False)"),
    (lambda: parse("omega*t", ["omega"]),
     "'t' (time) is only allowed in driver functions f, not in expression 'omega*t'"),
    (lambda: parse("a*omega", ["a", "Omega"]),
     "unknown name 'omega' in expression 'a*omega'; did you mean 'Omega'?"),
    (lambda: parse("a*b", ["a"]), "unknown name 'b' in expression 'a*b'"),
    (lambda: parse("zzz"), "unknown name 'zzz' in expression 'zzz'"),
])
def test_error_messages(call, message):
    with pytest.raises(ExprError) as info:
        call()
    assert str(info.value) == message


@pytest.mark.parametrize("text, fragment", [
    ("'abc'", "strings are not allowed"), ("True", "booleans are not allowed"),
    ("1j", "complex numbers are not allowed"), ("None", "'NoneType' is not allowed"),
    ("...", "'ellipsis' is not allowed"), ("b'x'", "'bytes' is not allowed"),
    ("lambda: 1", "lambda is not allowed"), ("[1, 2]", "lists are not allowed"),
    ("().__class__", "attribute access ('.') is not allowed"),
    ("sin.__globals__", "attribute access ('.') is not allowed"),
    ("(1, 2)[0]", "subscripts ('[...]') are not allowed"), ("1 is 2", "only < <= > >= == != compare"),
    ("~1", "operator '~' is not allowed"), ("f'{1}'", "f-strings are not allowed"),
    ("__import__('os')", "unknown function '__import__'"), ("(lambda: 0)()", "only functions named directly"),
    ("import os", "cannot parse expression"),
    ("(x := 1)", "':=' is not allowed"), ("sin(*[1])", "'*' is not allowed"),
    ("[x for x in ()]", "comprehensions are not allowed"), ("{1: 2}", "dicts are not allowed"),
    ("2 @ 3", "operator '@' is not allowed"),
    ("1 << 2", "operator '<<' is not allowed"), ("1 | 2", "operator '|' is not allowed"),
    ("2^", "use ** for powers, not ^"), ("(1", "'(' was never closed"), ("a.b", "attribute access"),
    ("sin", "function 'sin' must be called"),
])
def test_rejected_syntax(text, fragment):
    with pytest.raises(ExprError) as info:
        parse(text, names=["x"], allow_t=True)
    assert fragment in str(info.value)


def test_hostile_input_fails_fast():
    cases = [
        "(" * 10_000 + "1" + ")" * 10_000, "x" * 100_000, "1+" * 50_000 + "1", "1\x00",
        "\x00", "sin(t)\x00", "-" * 999 + "1", "+-~" * 333, "(" * 65 + "1" + ")" * 65,
        "sin(" * 70 + "1" + ")" * 70, "[" * 500, "1" + "+1" * 499, "9**9**9**9", "9.0**9**9**9",
        "10**400", "1" + "0" * 400, "1e999", "-1e999", "1e308*10", "exp(1000)", "cosh(1e4)",
        "2**1024", "(1e200*1e200)-(1e200*1e200)", "__import__('os').system('true')",
        "().__class__.__bases__[0].__subclasses__()", "eval('1')", "exec('1')",
        "compile('1', '', 'eval')", "open('/etc/passwd')", "globals()", "t.__class__",
        "(lambda: 1)()", "[x for x in range(10**9)]", "'a'*10**9", "f'{1}'" * 10,
        "sin(" + "t, " * 300 + "t)", "atan2(" + ", ".join(["1"] * 300) + ")",
    ]
    start = time.process_time()
    for text in cases:
        with pytest.raises(ExprError):
            TimeFunction(text, {"x": 1.0})
        with pytest.raises(ExprError):
            evaluate_constant(text, {"x": 1.0})
    elapsed = time.process_time() - start
    assert elapsed < 5.0, elapsed       # ~0.1 s of CPU quiet: only a blow-up reaches 5


def test_limit_messages(monkeypatch):
    with pytest.raises(ExprError) as info:
        parse("x" * 100_000)
    assert str(info.value) == "expression is too long (100000 characters; at most 1000)"
    with pytest.raises(ExprError, match=r"nested too deeply \(more than 64 levels\)$"):
        parse("(" * 65 + "1" + ")" * 65)
    with pytest.raises(ExprError, match=r"nested too deeply \(more than 64 levels\)$"):
        parse("-" * 65 + "1")
    parse("(" * 63 + "1" + ")" * 63)  # just inside the limits
    parse("-" * 63 + "1")
    with pytest.raises(ExprError, match="^expression contains a null byte$"):
        parse("1\x00")
    from planarkin.functions.expr import parser
    monkeypatch.setattr(parser, "MAX_NODES", 10)
    with pytest.raises(ExprError) as info:
        parse("1+2+3+4+5+6")
    assert str(info.value) == "expression '1+2+3+4+5+6' is too large (more than 10 nodes)"
    parse("1+2+3+4+5")


def test_long_expression_text_is_shortened_in_messages():
    text = "1 + " * 30 + "nope"
    with pytest.raises(ExprError) as info:
        parse(text)
    assert str(info.value) == f"unknown name 'nope' in expression '{text[:77]}...'"


def test_evaluation_never_uses_eval_or_exec(monkeypatch):
    import builtins

    def forbidden(*args, **kwargs):
        raise AssertionError("eval/exec called")
    monkeypatch.setattr(builtins, "eval", forbidden)
    monkeypatch.setattr(builtins, "exec", forbidden)
    f = TimeFunction("0.3 + 0.05*sin(2*pi*t)**2", {})
    f.derivatives(np.linspace(0, 1, 5))
    assert evaluate_constant("a/2", {"a": 1}) == 0.5
    files = sorted(Path(E.__file__).parent.glob("*.py"))      # the package's every module
    assert len(files) >= 4
    for f in files:
        assert not re.search(r"(?<![\w.])(eval|exec|compile)\s*\(", f.read_text()), f.name


def test_derivative_complexity_limit():
    text = "*".join(["t"] * 63)  # legal text, but f'' would nest about 250 levels deep
    with pytest.raises(ExprError) as info:
        TimeFunction(text, {})
    assert str(info.value) == (f"expression '{text[:77]}...' is too complex "
                               "(its derivatives nest more than 150 levels)")
    with pytest.raises(ExprError, match="is too complex"):
        parse(text, allow_t=True).diff().diff()
    assert TimeFunction("*".join(["t"] * 20), {}).derivatives(1.0) == (1.0, 20.0, 380.0)


def stack_depth():
    frame, n = sys._getframe(), 0
    while frame is not None:
        frame, n = frame.f_back, n + 1
    return n


def with_headroom(frames, fn):
    """Call fn with only `frames` stack frames left below the recursion limit."""
    if stack_depth() < sys.getrecursionlimit() - frames:
        return with_headroom(frames, fn)
    return fn()


def test_deep_trees_stay_far_from_the_recursion_limit():
    text = "sin(" * 62 + "t" + ")" * 62  # the deepest nesting parse allows

    def work():
        f = TimeFunction(text, {})
        values = f.derivatives(np.linspace(0, 1, 5))
        return f, values, f.derivatives(0.5), str(f.second), f.first.diff()
    f, values, at_half, printed, second = with_headroom(350, work)
    assert f.second.evaluate({"t": 0.5}) == at_half[2] == second.evaluate({"t": 0.5})
    assert printed.startswith("cos(sin(sin(") and len(printed) > 100_000
    check_close(f.derivatives(TS)[1], fd(f, C1, 1, 1e-3), 1e-7)


@pytest.mark.parametrize("text", [0, -0.0, 3, 2.5, 1e308, 1.7976931348623157e308, -1.5e308,
                                  10**308, 10**400, float("inf"), float("nan"), "a", " a ",
                                  "b_2", "big", "huge", "nan_p", "inf_p", "word", "pi", "t",
                                  "None", "a ", "text_p", "a + 0", "-a"])
def test_evaluate_constants_shortcuts_equal_the_parse(text):
    """evaluate_constant takes numbers and parameter names without building an expression;
    its value, or its error message, is parse_text's for every such text (large, signed zero,
    not finite, a name with spaces, a keyword, a name not among the parameters, a parameter
    that is not a finite number)."""
    from planarkin.functions.expr.parser import parse_text
    values = {"a": 0.1, "b_2": -0.0, "big": 1e308, "huge": 10**400, "nan_p": float("nan"),
              "inf_p": float("inf"), "pi": 3.0, "text_p": "x"}

    def outcome(f):
        try:
            v = f()
        except (ExprError, OverflowError) as e:
            return type(e).__name__, str(e)
        return "value", repr(v), math.copysign(1.0, v)

    assert outcome(lambda: evaluate_constant(text, values)) == \
        outcome(lambda: parse_text(text, values.keys(), False, values).value)


def test_a_folded_constant_is_numpys_value_bit_for_bit():
    """Folding + - * / of two numbers in Python (core._fold's fast path) gives numpy's float64
    result exactly, on random operands of every magnitude and on the edge cases (signed zeros,
    subnormals, the largest finite numbers, overflow to inf), so a design's driver built with
    the fast path is the tree it was before."""
    from planarkin.functions.expr import core
    rng = np.random.default_rng(7)
    bits = rng.integers(0, 2**64, size=4000, dtype=np.uint64).view(np.float64)
    special = np.array([0.0, -0.0, 5e-324, -5e-324, 2.2250738585072014e-308, 1.0, -1.0, 3.0,
                        1.7976931348623157e308, -1.7976931348623157e308, 1e-300, 1e300])
    xs = np.concatenate([bits[np.isfinite(bits)], special, rng.normal(size=500),
                         rng.normal(size=500) * 1e10])
    ys = np.roll(xs, 7)
    xs = np.concatenate([xs, np.repeat(special, len(special))])
    ys = np.concatenate([ys, np.tile(special, len(special))])
    ufunc = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide}
    for op, fast in core._FAST_FOLD.items():
        for x, y in zip(xs.tolist(), ys.tolist()):
            if op == "/" and y == 0:
                continue            # stays on numpy
            with np.errstate(all="ignore"):
                want = float(ufunc[op](x, y))
            got = float(fast(x, y))
            assert np.float64(got).tobytes() == np.float64(want).tobytes() or (
                math.isnan(got) and math.isnan(want)), (op, x, y, got, want)
    with pytest.raises(ExprError, match="overflows"):       # as before: refused, not inf
        parse("1e308*10 + t", allow_t=True)
    with pytest.raises(ExprError, match="division by zero"):
        parse("1/0 + t", allow_t=True)
