"""Motion laws (planarkin.functions.laws): peak coefficients against published values, boundary values,
continuity, and the exact derivatives against closed forms written out independently here."""

import math

import numpy as np
import pytest

from planarkin.functions.expr import TimeFunction
from planarkin.functions.laws import ALIASES, LAWS, law

PI = math.pi

# published peak coefficients C_v = max|s'|, C_a = max|s''|, C_j = max|s'''| (VDI 2143; the
# reference forces-and-motion-laws.md §2, each re-derived by hand: e.g. for 4-5-6-7, s''' = 840u
# (1 - u)**3 ... vanishes at u = (5 -+ sqrt 5)/10, where s'' = +-84*sqrt(5)/25 = 7.51319 (not
# 7.5107 as a brief quoted)
PEAKS = {
    "harmonic": (PI / 2, PI ** 2 / 2, PI ** 3 / 2),
    "cycloidal": (2.0, 2 * PI, 4 * PI ** 2),
    "poly345": (15 / 8, 10 / math.sqrt(3), 60.0),
    "poly4567": (35 / 16, 84 * math.sqrt(5) / 25, 52.5),
    "modified_trapezoid": (2.0, 8 * PI / (2 + PI), 32 * PI ** 2 / (2 + PI)),
    "modified_sine": (4 * PI / (4 + PI), 4 * PI ** 2 / (4 + PI), 16 * PI ** 3 / (4 + PI)),
    "constant_velocity": (1.0, 0.0, 0.0),
}


def derivs(name, u, side=0):
    """s, s', s'', s''' of a law at u, through the expression language."""
    f = TimeFunction(f"{name}(t)", {})
    return (*f.derivatives(u, side), f.third(u, side))


def peak(name, order):
    """max |s^(order)| on [0, 1]: dense samples, then Newton on s^(order+1) (exact derivatives)
    from the best sample, or the best sample itself at a piece end."""
    u = np.linspace(0.0, 1.0, 20001)
    best = 0.0
    for side in (-1, 1):
        vals = derivs(name, u, side)
        k = int(np.argmax(np.abs(vals[order])))
        best = max(best, abs(vals[order][k]))
        x = u[k]
        if order < 3:
            f = TimeFunction(f"{name}(t)", {})
            for _ in range(30):  # Newton on the next derivative (a smooth interior maximum)
                d = f.derivatives(x)[order + 1] if order < 2 else f.third(x)
                dd = f.third(x) if order == 1 else None
                if order == 2:
                    h = 1e-6  # the fourth derivative only to steer Newton, not measured
                    dd = (f.third(x + h) - f.third(x - h)) / (2 * h)
                if not dd or not 0 < x - d / dd < 1:
                    break
                x = x - d / dd
            best = max(best, abs(derivs(name, x)[order]))
    return best


@pytest.mark.parametrize("name", sorted(PEAKS))
def test_peak_coefficients(name):
    cv, ca, cj = PEAKS[name]
    assert peak(name, 1) == pytest.approx(cv, rel=1e-12, abs=1e-12)
    assert peak(name, 2) == pytest.approx(ca, rel=1e-12, abs=1e-12)
    if name != "constant_velocity":
        assert peak(name, 3) == pytest.approx(cj, rel=1e-12)


@pytest.mark.parametrize("name", sorted(LAWS))
def test_boundary_values_clamp_and_symmetry(name):
    u = np.array([-1.0, -1e-9, 0.0, 1.0, 1 + 1e-9, 3.0])
    s, v, a, j = derivs(name, u)
    np.testing.assert_allclose(s, [0, 0, 0, 1, 1, 1], atol=1e-15)
    assert v[0] == v[-1] == a[0] == a[-1] == j[0] == j[-1] == 0
    x = np.linspace(0, 1, 101)
    s, v, _, _ = derivs(name, x)
    np.testing.assert_allclose(s + s[::-1], 1.0, atol=2e-15)   # every law here is symmetric
    assert (np.diff(s) >= 0).all()
    # the one-sided limits at the ends: position continuous; velocity zero except constant v
    for u0 in (0.0, 1.0):
        left, right = derivs(name, u0, -1), derivs(name, u0, +1)
        assert left[0] == pytest.approx(right[0], abs=1e-15)
        inner = right if u0 == 0 else left
        assert inner[1] == pytest.approx(1.0 if name == "constant_velocity" else 0.0, abs=1e-14)


@pytest.mark.parametrize("name", ["modified_trapezoid", "modified_sine"])
def test_piecewise_laws_continuous_at_their_knots(name):
    for k in LAWS[name].knots:
        left, right = derivs(name, k, -1), derivs(name, k, +1)
        np.testing.assert_allclose(left[:3], right[:3], atol=1e-13)  # C2 across every knot


def test_acceleration_definitions_of_the_trapezoid_and_sine():
    """s'' against the defining acceleration of the reference, piece by piece."""
    A, B = 8 * PI / (2 + PI), 4 * PI ** 2 / (4 + PI)
    u = np.linspace(0.0005, 0.9995, 1000)
    trap = A * np.select([u < 1 / 8, u < 3 / 8, u < 5 / 8, u < 7 / 8, u <= 1],
                         [np.sin(4 * PI * u), 1.0, np.cos(4 * PI * (u - 3 / 8)), -1.0,
                          -np.cos(4 * PI * (u - 7 / 8))])
    sine = B * np.select([u < 1 / 8, u < 7 / 8, u <= 1],
                         [np.sin(4 * PI * u), np.cos(4 * PI * (u - 1 / 8) / 3),
                          -np.cos(4 * PI * (u - 7 / 8))])
    np.testing.assert_allclose(derivs("modified_trapezoid", u)[2], trap, rtol=0, atol=1e-13)
    np.testing.assert_allclose(derivs("modified_sine", u)[2], sine, rtol=0, atol=1e-13)


def test_closed_forms_of_the_smooth_laws():
    u = np.linspace(0.001, 0.999, 999)
    forms = {
        "cycloidal": (u - np.sin(2 * PI * u) / (2 * PI), 1 - np.cos(2 * PI * u),
                      2 * PI * np.sin(2 * PI * u), 4 * PI ** 2 * np.cos(2 * PI * u)),
        "harmonic": ((1 - np.cos(PI * u)) / 2, PI / 2 * np.sin(PI * u),
                     PI ** 2 / 2 * np.cos(PI * u), -PI ** 3 / 2 * np.sin(PI * u)),
        "poly345": (10 * u**3 - 15 * u**4 + 6 * u**5, 30 * u**2 - 60 * u**3 + 30 * u**4,
                    60 * u - 180 * u**2 + 120 * u**3, 60 - 360 * u + 360 * u**2),
        "poly4567": (35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7,
                     140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6,
                     420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5,
                     840 * u - 5040 * u**2 + 8400 * u**3 - 4200 * u**4),
    }
    for name, want in forms.items():
        for got, exp in zip(derivs(name, u), want):
            np.testing.assert_allclose(got, exp, rtol=1e-13, atol=1e-11)  # expanded forms cancel


@pytest.mark.parametrize("name", sorted(LAWS))
def test_derivatives_match_finite_differences(name):
    u = np.linspace(0.01, 0.99, 50) + 1e-4  # off the knots
    h = 1e-6
    s, v, a, j = derivs(name, u)
    sp, vp, ap, _ = derivs(name, u + h)
    sm, vm, am, _ = derivs(name, u - h)
    np.testing.assert_allclose((sp - sm) / (2 * h), v, atol=1e-7)
    np.testing.assert_allclose((vp - vm) / (2 * h), a, atol=1e-6)
    np.testing.assert_allclose((ap - am) / (2 * h), j, atol=2e-5)


def test_aliases_and_scaling_in_an_expression():
    assert law("3-4-5") is LAWS["poly345"] and law("cycloidal") is LAWS["cycloidal"]
    assert law("bogus") is None and all(law(a) is not None for a in ALIASES)
    # a rise of h = 2 in T = 0.5 starting at t0 = 0.25: velocity peak h*C_v/T, accel h*C_a/T**2
    f = TimeFunction("2*cycloidal((t - 0.25)/0.5)", {})
    t_mid, t_quarter = 0.25 + 0.25, 0.25 + 0.125
    assert f.derivatives(t_mid)[1] == pytest.approx(2 * 2 / 0.5, rel=1e-14)
    assert f.derivatives(t_quarter)[2] == pytest.approx(2 * 2 * PI / 0.25, rel=1e-14)
    assert f.third(0.25, +1) == pytest.approx(2 * 4 * PI ** 2 / 0.125, rel=1e-14)
