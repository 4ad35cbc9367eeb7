"""Piecewise and periodic expressions: comparisons, where, min/max/clip/mod, one-sided
derivatives, breakpoints (planarkin.functions.expr), against closed forms written out here."""

import math
import pickle
import time

import numpy as np
import pytest

from planarkin.functions.expr import ExprError, TimeFunction, parse

PI = math.pi


def tf(text, **params):
    return TimeFunction(text, params)


def test_comparisons_logic_and_where_values():
    t = np.linspace(-1, 2, 301)
    cases = {
        "t < 0.5": (t < 0.5), "t <= 0.5": (t <= 0.5), "t > 0.5": (t > 0.5),
        "t >= 0.5": (t >= 0.5), "0 < t < 1": (0 < t) & (t < 1),
        "t < 0 or t > 1": (t < 0) | (t > 1), "not (t < 0)": ~(t < 0),
        "where(t < 0.5, t**2, 1 - t)": np.where(t < 0.5, t**2, 1 - t),
        "t**2 if t < 0.5 else 1 - t": np.where(t < 0.5, t**2, 1 - t),
        "min(t, 0.5, t**2)": np.minimum(np.minimum(t, 0.5), t**2),
        "max(t, 0.5)": np.maximum(t, 0.5), "clip(t, 0.2, 0.7)": np.clip(t, 0.2, 0.7),
        "mod(t, 0.3)": np.mod(t, 0.3), "t % 0.3": np.mod(t, 0.3), "sign(t - 1)": np.sign(t - 1),
        "floor(2*t)": np.floor(2 * t),
    }
    off = np.abs(((t * 10) % 3)) > 1e-9  # away from mod's wrap (there: the mean, see below)
    for text, want in cases.items():
        f = tf(text)
        got = f(t)
        ok = off if "mod" in text or "%" in text else np.ones_like(off)
        if "floor" in text:
            ok = (2 * t) % 1 != 0
        sw = np.isin(t, [0.0, 0.2, 0.5, 0.7, 1.0])  # switch points: side 0 is the mean there
        np.testing.assert_allclose(got[ok & ~sw], np.asarray(want, float)[ok & ~sw], atol=1e-15,
                                   err_msg=text)
        # scalar path == vector path, also through the chunked evaluation (> 2048 points)
        assert f(0.37) == pytest.approx(float(f(np.array([0.37]))[0]), abs=0)
        big = np.tile(t, 8)
        np.testing.assert_array_equal(f(big), np.tile(got, 8))


def test_constant_conditions_fold():
    assert str(parse("where(1 < 2, 3, 4)")) == "3" and str(parse("min(2, 1)")) == "1"
    assert str(parse("7 % 3")) == "1" and str(parse("clip(5, 0, 1)")) == "1"
    assert str(parse("where(t < 1, t, t)", allow_t=True)) == "t"


def test_piecewise_derivatives_are_exact_on_each_piece():
    f = tf("where(t < 0.4, 3*t**2, 0.48 + 2.4*(t - 0.4) - (t - 0.4)**3)")
    t = np.array([0.1, 0.3, 0.5, 0.9])
    v, d1, d2 = f.derivatives(t)
    left = t < 0.4
    np.testing.assert_allclose(d1, np.where(left, 6 * t, 2.4 - 3 * (t - 0.4)**2), rtol=1e-15)
    np.testing.assert_allclose(d2, np.where(left, 6.0, -6 * (t - 0.4)), rtol=1e-14)
    np.testing.assert_allclose(f.third(t), np.where(left, 0.0, -6.0), rtol=1e-15)


# ---- the derivative rules at 0 (issue 7) ---------------------------------------------------------

def test_abs_squared_is_exact_at_its_zero():
    for text in ("abs(t - 0.5)**2", "abs((t - 0.5)**2)", "sqrt((t - 0.5)**4)",
                 "abs(t - 0.5)*abs(t - 0.5)"):
        f = tf(text)
        for side in (0, -1, 1):
            assert f.derivatives(0.5, side) == (0.0, 0.0, 2.0), (text, side)
        assert f.breakpoints(0, 1) == [], text


def test_sqrt_of_a_square_is_a_kink_with_finite_one_sided_velocities():
    f = tf("sqrt((t - 0.5)**2)")
    assert f.derivatives(0.5, -1) == (0.0, -1.0, 0.0)
    assert f.derivatives(0.5, +1) == (0.0, 1.0, 0.0)
    assert f.derivatives(0.5) == (0.0, 1.0, 0.0)  # side 0 at the kink: the right-hand limit
    assert np.isfinite(f.derivatives(np.linspace(0, 1, 101))).all()
    [bp] = f.breakpoints(0.0, 1.0)
    assert bp.t == 0.5 and bp.jump == (0.0, 2.0, 0.0)


def test_kinks_and_smooth_compositions():
    f = tf("abs(t - 0.5)*(t - 0.5)")  # C1: the acceleration jumps from -2 to 2
    assert f.derivatives(0.5, -1) == (0.0, 0.0, -2.0) and f.derivatives(0.5, 1) == (0.0, 0.0, 2.0)
    assert [(b.t, b.jump) for b in f.breakpoints(0, 1)] == [(0.5, (0.0, 0.0, 4.0))]
    assert tf("abs((t - 0.5)**3)").breakpoints(0, 1) == []       # C2 at 0.5
    g = tf("abs((t - 0.5)**3)")
    assert g.third(0.5, -1) == -6.0 and g.third(0.5, 1) == 6.0
    k = tf("2*pi*abs(t - 0.5)")
    [bp] = k.breakpoints(0, 1)
    assert bp.t == 0.5 and bp.jump == pytest.approx((0.0, 4 * PI, 0.0), abs=1e-15)
    assert k.derivatives(0.5, -1)[1] == -2 * PI and k.derivatives(0.5, 1)[1] == 2 * PI


def test_sign_and_floor_are_one_sided_at_their_switch():
    f = tf("sign(t - 0.25)")
    # side 0: the rule at breakpoints (expr.SIDE_RULE), the right-hand limit
    assert f(0.25, -1) == -1.0 and f(0.25, 1) == 1.0 and f(0.25) == 1.0
    g = tf("floor(4*t)")
    assert g(0.5, -1) == 1.0 and g(0.5, 1) == 2.0
    # a switch whose value is within rounding of t: 0.3/0.1 = 2.9999999999999996
    h = tf("floor(t/0.1)")
    assert h(0.3, -1) == 2.0 and h(0.3, 1) == 3.0 and h(0.3) == 3.0


# ---- breakpoints ------------------------------------------------------------------------------

def test_breakpoints_of_clip_and_min_with_sides():
    f = tf("clip(2*t, 0.3, 1.1)")
    bps = f.breakpoints(0.0, 1.0)
    assert [b.t for b in bps] == [0.15, 0.55]
    assert [b.jump for b in bps] == [(0.0, 2.0, 0.0), (0.0, -2.0, 0.0)]
    for b in bps:
        assert f.derivatives(b.t, -1)[1] == (0.0 if b.t < 0.3 else 2.0)
        assert f.derivatives(b.t, +1)[1] == (2.0 if b.t < 0.3 else 0.0)


def test_breakpoint_at_an_irrational_time_is_refined_to_rounding():
    f = tf("max(sin(t), 0.5)")  # kink where sin t = 1/2, t = pi/6 and 5*pi/6
    bps = f.breakpoints(0.0, 3.0)
    assert [b.t for b in bps] == pytest.approx([PI / 6, 5 * PI / 6], abs=2e-15)
    a, b = bps
    assert a.jump == pytest.approx((0.0, math.cos(PI / 6), -0.5), rel=1e-12)
    assert f.derivatives(a.t, -1)[1] == 0.0 and f.derivatives(a.t, +1)[1] == pytest.approx(
        math.cos(PI / 6), rel=1e-12)
    assert f.derivatives(b.t, -1)[1] == pytest.approx(math.cos(5 * PI / 6), rel=1e-12)
    assert f.derivatives(b.t, +1)[1] == 0.0


def test_touching_zero_of_a_switching_argument_is_found():
    # sqrt(abs(u)) with u = (t - 1/3)**2 touching 0 at t = 1/3, off every sample point: the
    # derivative rule of sqrt gives 0/0 there, which must be refused with the time
    f = tf("sqrt(abs((t - 1/3)**2))")
    msgs = f.problems(0.0, 1.0)
    assert msgs == ["f = sqrt(abs((t - 1/3)**2)) or its derivatives are not finite beside "
                    "t = 0.333333333333: a driver needs a finite velocity and acceleration"]
    assert tf("abs((t - 1/3)**2)").breakpoints(0, 1) == []  # found, measured, no jump


def test_position_jumps_are_problems_with_their_time_and_size():
    f = tf("where(t < 0.3, 0, 0.5)")
    assert f.problems(0.0, 1.0) == ["f jumps by 0.5 at t = 0.3: a driver position must be "
                                    "continuous"]
    assert f.problems(0.3, 1.0) == []          # at the start only the inside matters
    assert tf("2*pi*t").problems(0, 1) == [] and tf("1").breakpoints(0, 1) == []


def test_periodic_repetition_breakpoints():
    # harmonic rise over 0.2 s, repeated every 0.25 s with a jump back: position jumps
    saw = tf("harmonic(mod(t, 0.25)/0.2)")
    msgs = saw.problems(0.0, 1.0)
    assert msgs == [f"f jumps by -1 at t = {x}: a driver position must be continuous"
                    for x in (0.25, 0.5, 0.75)]
    # rise and return, C2 everywhere (cycloidal): no breakpoints, exact across the wrap
    f = tf("cycloidal(2*mod(t, 0.5)/0.5) - cycloidal(2*mod(t, 0.5)/0.5 - 1)")
    assert f.breakpoints(0.0, 2.0) == []
    v = f.derivatives(np.array([0.1, 0.6, 1.1]))
    u = 0.4
    np.testing.assert_allclose(v[1], 4 * (1 - math.cos(2 * PI * u)), rtol=1e-13)
    # harmonic rise 0.2 s, dwell, return 0.2 s, dwell: the acceleration jumps at every end
    # (by h*pi**2/2/T**2 = 123.37 into or out of each dwell)
    h = tf("harmonic(mod(t, 0.5)/0.2) - harmonic((mod(t, 0.5) - 0.25)/0.2)")
    bps = h.breakpoints(0.0, 1.0)
    assert [b.t for b in bps] == [0.0, 0.2, 0.25, 0.45, 0.5, 0.7, 0.75, 0.95, 1.0]
    a = PI**2 / 2 / 0.04
    assert all(b.jump[:2] == pytest.approx((0, 0), abs=1e-12) for b in bps)
    assert [b.jump[2] for b in bps] == pytest.approx([a, a, -a, -a] * 2 + [a], rel=1e-12)


def test_breakpoint_cost_is_bounded():
    t0 = time.process_time()
    f = tf("harmonic(mod(t, 0.01)/0.008)")     # 1000 periods, two knots each
    bps = f.breakpoints(0.0, 10.0)
    assert len(bps) == 2001
    assert time.process_time() - t0 < 5.0
    with pytest.raises(ExprError, match="switches more than 10000 times between t = 0 and 10"):
        tf("mod(t, 1e-4)").breakpoints(0.0, 10.0)
    assert "switches more than" in tf("mod(t, 1e-4)").problems(0.0, 10.0)[0]


def test_pickle_and_third_derivative():
    f = pickle.loads(pickle.dumps(tf("cycloidal(t/0.5)*where(t < 2, 1, 1)")))
    assert f.derivatives(0.25)[1] == pytest.approx(2 / 0.5, rel=1e-15)
    g = tf("sin(3*t)")
    np.testing.assert_allclose(g.third(np.array([0.1, 0.2])), -27 * np.cos(3 * np.array([0.1, 0.2])),
                               rtol=1e-15)


def test_hostile_piecewise_expressions_are_refused_quickly():
    t0 = time.process_time()
    assert tf("abs(sin(1e6*t))").problems(0.0, 1.0) == [
        "f = abs(sin(1e6*t)) switches too fast to be followed near t = 0 (more than 200000 "
        "samples would be needed to find its switches)"]
    with pytest.raises(ExprError, match="nests piecewise forms .* more than 6 deep"):
        tf("cycloidal(" * 7 + "t" + ")" * 7)
    with pytest.raises(ExprError, match="too complex|more than 6 deep"):
        tf("min(" * 40 + "t" + ", 1)" * 40)   # each level repeats its argument
    f = tf("min(" + ", ".join(f"t*{k}" for k in range(1, 60)) + ")")  # balanced: 6 deep
    assert f(2.0) == 2.0 and f(-1.0) == -59.0
    assert time.process_time() - t0 < 5.0
    assert tf("mod(t, -0.3)").problems(0.0, 1.0) == [
        f"f jumps by -0.3 at t = {x}: a driver position must be continuous" for x in (0.3, 0.6, 0.9)]
