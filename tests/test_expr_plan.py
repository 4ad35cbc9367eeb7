"""Constant expressions evaluated from their plans (planarkin.functions.expr.plan) give the
folded tree's value bit for bit, and every problem still gets the parser's message."""

import math

import numpy as np
import pytest

from planarkin.functions.expr import ExprError
from planarkin.functions.expr import parser
from planarkin.functions.expr.parser import evaluate_constant, parse_text
from planarkin.functions.expr.plan import plan

TEXTS = [
    "a + b", "a - b*c", "2*a/3", "(2*a)/3", "a**2 + b**2", "-a", "+a", "-(a - b)", "a/b/c",
    "sqrt((a - b)**2 + (c - 1)**2)", "atan2(b - a, c + a) + acos((a**2 + 1 - b**2)/(2*a*c))",
    "x0 + a*cos(th0)", "y0 + a*sin(th0)", "exp(-a) * log(c) - tanh(b)", "2**10 * a",
    "pi * a / 180", "e * a", "abs(a - b) + floor(c)", "1e-3 * a", "0x10 + a", "a * 1 + 0",
    "sinh(a) + cosh(b) + tan(c) + asin(a/4) + atan(b)",
]


def folded(text, values):
    return parse_text(text, values.keys(), False, values).value


@pytest.mark.parametrize("text", TEXTS)
def test_plan_gives_the_folded_value_bit_for_bit(text):
    f = plan(text)
    assert f is not None
    rng = np.random.default_rng(len(text))
    for _ in range(200):
        a, b, c = rng.uniform(0.2, 3.5, 3)
        values = {"a": a, "b": b, "c": c, "x0": rng.normal(), "y0": rng.normal(),
                  "th0": rng.uniform(-7, 13)}
        try:
            want = folded(text, values)
        except ExprError:
            continue
        with np.errstate(all="ignore"):
            assert f(values) == want or (f(values) - want) == 0, (text, values)
        assert evaluate_constant(text, values) == want


def test_a_parameter_called_e_wins_over_the_constant():
    assert plan("e * 2")({"e": 3.0}) == 6.0
    assert plan("e * 2")({}) == 2 * math.e


@pytest.mark.parametrize("text", ["a if b else c", "min(a, b)", "a % b", "a < b",
                                  "where(a > 1, a, b)", "cycloidal(a)", "sign(a)", "atan2(a)"])
def test_forms_without_a_plan_go_to_the_parser(text):
    assert plan(text) is None


@pytest.mark.parametrize("text, values, message", [
    ("acos(a)", {"a": 2.0}, "not finite"),
    ("a / b", {"a": 1.0, "b": 0.0}, "division by zero"),
    ("sqrt(a - 3)", {"a": 1.0}, "not finite"),
    ("exp(a)", {"a": 1000.0}, "overflows"),
    ("a + zz", {"a": 1.0}, "unknown name 'zz'"),
])
def test_a_planned_text_that_fails_gets_the_parsers_message(text, values, message):
    fine = {k: 4.0 if text.startswith("sqrt") else 0.5 for k in values}
    if "zz" in text:
        fine["zz"] = 1.0
    evaluate_constant(text, fine)           # planned with values that work
    assert text.strip() in parser._PLANS
    with pytest.raises(ExprError, match=message):
        evaluate_constant(text, values)
    with pytest.raises(ExprError) as direct:
        folded(text, values)
    with pytest.raises(ExprError) as planned:
        evaluate_constant(text, values)
    assert str(planned.value) == str(direct.value)


def test_a_driver_the_design_does_not_reach_is_shared_between_designs():
    """TimeFunction.shared: the same object for the same text and values of the parameters it
    uses (whatever the others), a new one when one of those changes, the constructor's
    errors as they were."""
    from planarkin.functions.expr import TimeFunction
    a = TimeFunction.shared("w*t + c", {"w": 2.0, "c": 0.5, "x": 1.0})
    assert TimeFunction.shared("w*t + c", {"w": 2.0, "c": 0.5, "x": 7.0}) is a
    b = TimeFunction.shared("w*t + c", {"w": 3.0, "c": 0.5, "x": 1.0})
    assert b is not a
    t = np.linspace(0, 1, 5)
    assert np.array_equal(b.derivatives(t)[0], TimeFunction("w*t + c", {"w": 3.0, "c": 0.5})
                          .derivatives(t)[0])
    TimeFunction.shared("a/a*t", {"a": 1.0})     # simplified to t, but a is still read
    with pytest.raises(ExprError, match="division by zero"):
        TimeFunction.shared("a/a*t", {"a": 0.0})
    with pytest.raises(ExprError) as shared:
        TimeFunction.shared("sqrt(c - 1)*t", {"c": 0.5})
    with pytest.raises(ExprError) as direct:
        TimeFunction("sqrt(c - 1)*t", {"c": 0.5})
    assert str(shared.value) == str(direct.value)
