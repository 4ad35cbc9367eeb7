"""The closed forms the other tests trust, checked once: tests/closedforms.py against an independent
50-digit solution (mpmath: the loop equations solved by Newton's method, their time derivatives
by mpmath's numerical differentiation at 50 digits) and against central differences in double
precision; every closed form of tests/reference_models.py and the extremes' special ones against
central differences of their own positions. No planarkin code is run here."""

import math

import mpmath as mp
import numpy as np
import pytest

import reference_models as R
from closedforms import four_bar, four_bar_pose, slider_crank, slider_crank_jerk
from test_extremes import rod_equals_crank_smooth_cf, slider_driven_theta

TWO_PI = 2 * math.pi
T = np.linspace(0.02, 0.98, 9)          # sample times (s), clear of the grid's ends


def crank(th0, wobble=0.3):
    """th = th0 + 2 pi t + wobble sin 2 pi t and its derivatives: numpy (t -> th, th', th'')
    and mpmath (t -> th) forms."""
    def np_form(t):
        return (th0 + TWO_PI * t + wobble * np.sin(TWO_PI * t),
                TWO_PI * (1 + wobble * np.cos(TWO_PI * t)),
                -wobble * TWO_PI ** 2 * np.sin(TWO_PI * t))

    def mp_form(t):
        return th0 + 2 * mp.pi * t + wobble * mp.sin(2 * mp.pi * t)
    return np_form, mp_form


def mp_derivatives(f, t):
    """f(t), f'(t), f''(t) at 50 digits (f: mp function of mp time)."""
    with mp.workdps(50):
        t = mp.mpf(float(t))
        return [float(mp.diff(f, t, n)) for n in (0, 1, 2)]


def mp_four_bar(a, b, c, d, th_mp, guess):
    """(t -> th3, t -> th4) solving a e(th) + b e(th3) = (d, 0) + c e(th4) by Newton's method at 50
    digits from guess (th3, th4) (the branch is the guess's)."""
    def solve(t):
        th = th_mp(t)
        f = [lambda x3, x4: a * mp.cos(th) + b * mp.cos(x3) - d - c * mp.cos(x4),
             lambda x3, x4: a * mp.sin(th) + b * mp.sin(x3) - c * mp.sin(x4)]
        return mp.findroot(f, guess, tol=mp.mpf(10) ** -45)
    return (lambda t: solve(t)[0]), (lambda t: solve(t)[1])


def mp_slider_crank(r, l, e, th_mp, guess):
    """(t -> be, t -> x) solving r sin th + l sin be = e at 50 digits from guess, x = r cos th +
    l cos be."""
    def be(t):
        th = th_mp(t)
        return mp.findroot(lambda x: r * mp.sin(th) + l * mp.sin(x) - e, guess,
                           tol=mp.mpf(10) ** -45)
    return be, (lambda t: r * mp.cos(th_mp(t)) + l * mp.cos(be(t)))


def worst(got, want):
    """Largest |got - want| relative to the largest |want|."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    return float(np.max(np.abs(got - want)) / np.max(np.abs(want)))


FOUR_BARS = {
    # a, b, c, d, branch, th0: crank-rockers on both branches, a double crank, a wide one
    "crank-rocker open": (0.04, 0.12, 0.10, 0.13, 1, 0.3),
    "crank-rocker crossed": (0.04, 0.12, 0.10, 0.13, -1, 0.3),
    "double crank": (1.0, 0.9, 0.8, 0.35, 1, 0.0),
    "benchmark four-bar": (0.04, 0.12, 0.10, 0.10, 1, 0.0),
}


@pytest.mark.parametrize("name", sorted(FOUR_BARS))
def test_four_bar_against_a_50_digit_solution(name):
    a, b, c, d, sigma, th0 = FOUR_BARS[name]
    np_th, mp_th = crank(th0)
    th, thd, thdd = np_th(T)
    got = four_bar(th, thd, thdd, a, b, c, d, sigma)
    want = np.zeros((6, len(T)))
    for k, t in enumerate(T):
        th3_mp, th4_mp = mp_four_bar(a, b, c, d, mp_th, (got[0][k], got[3][k]))
        want[:3, k] = mp_derivatives(th3_mp, t)
        want[3:, k] = mp_derivatives(th4_mp, t)
    for i, label in enumerate(("th3", "w3", "al3", "th4", "w4", "al4")):
        assert worst(got[i], want[i]) < 1e-12, (label, worst(got[i], want[i]))
    # the branch: B left of A -> O4 (sigma +1) or right of it (-1)
    Ax, Ay = a * np.cos(th), a * np.sin(th)
    Bx, By = Ax + b * np.cos(got[0]), Ay + b * np.sin(got[0])
    assert np.all(sigma * ((d - Ax) * (By - Ay) - (-Ay) * (Bx - Ax)) > 0)


SLIDER_CRANKS = {
    # r, l, e, th0
    "in line": (0.1, 0.3, 0.0, 0.2),
    "offset": (0.08, 0.25, 0.03, 0.0),
    "offset below": (0.08, 0.25, -0.05, 1.0),
    "near toggle": (0.1, 0.1 * (1 + 1e-4), 0.0, 0.0),
}


@pytest.mark.parametrize("name", sorted(SLIDER_CRANKS))
def test_slider_crank_against_a_50_digit_solution(name):
    r, l, e, th0 = SLIDER_CRANKS[name]
    np_th, mp_th = crank(th0)
    th, thd, thdd = np_th(T)
    got = slider_crank(th, thd, thdd, r, l, e)
    want = np.zeros((6, len(T)))
    for k, t in enumerate(T):
        be_mp, x_mp = mp_slider_crank(r, l, e, mp_th, got[0][k])
        want[:3, k] = mp_derivatives(be_mp, t)
        want[3:, k] = mp_derivatives(x_mp, t)
    tol = 1e-9 if name == "near toggle" else 1e-12     # conditioning ~ 1 / cos(be)
    for i, label in enumerate(("be", "bed", "bedd", "x", "xd", "xdd")):
        assert worst(got[i], want[i]) < tol, (label, worst(got[i], want[i]))
    assert np.all(np.cos(got[0]) > 0)                    # the branch: B right of A


def test_slider_crank_jerk_against_a_50_digit_solution():
    r, l, w = 0.1, 0.3, TWO_PI
    got = slider_crank_jerk(w * T, w, r, l)
    want = []
    for t in T:
        x_mp = mp_slider_crank(r, l, 0, lambda s: 2 * mp.pi * s, 0.0)[1]
        with mp.workdps(50):
            want.append(float(mp.diff(x_mp, mp.mpf(float(t)), 3)))
    assert worst(got, want) < 1e-12, worst(got, want)
    # and the derivative of slider_crank's own x'', by central differences
    h = 1e-5
    xdd = lambda t: slider_crank(w * t, w, 0.0, r, l)[5]          # noqa: E731
    assert worst((xdd(T + h) - xdd(T - h)) / (2 * h), got) < 1e-7


def central(f, t, h=1e-5):
    """(f(t + h) - f(t - h)) / 2h for f returning a tuple of arrays."""
    return [(p - m) / (2 * h) for p, m in zip(f(t + h), f(t - h))]


@pytest.mark.parametrize("name", sorted(FOUR_BARS))
def test_four_bar_derivatives_are_central_differences(name):
    a, b, c, d, sigma, th0 = FOUR_BARS[name]
    np_th = crank(th0)[0]
    cf = lambda t: four_bar(*np_th(t), a, b, c, d, sigma)     # noqa: E731
    got, diff = cf(T), central(cf, T)
    for pos, der in ((0, 1), (1, 2), (3, 4), (4, 5)):
        assert worst(diff[pos], got[der]) < 1e-7, (name, pos, der)


@pytest.mark.parametrize("name", sorted(SLIDER_CRANKS))
def test_slider_crank_derivatives_are_central_differences(name):
    r, l, e, th0 = SLIDER_CRANKS[name]
    np_th = crank(th0)[0]
    cf = lambda t: slider_crank(*np_th(t), r, l, e)           # noqa: E731
    got, diff = cf(T), central(cf, T, h=1e-7 if name == "near toggle" else 1e-5)
    tol = 1e-5 if name == "near toggle" else 1e-7
    for pos, der in ((0, 1), (1, 2), (3, 4), (4, 5)):
        assert worst(diff[pos], got[der]) < tol, (name, pos, der, worst(diff[pos], got[der]))


def test_four_bar_pose_closes_the_loop():
    a, b, c, d = 0.04, 0.12, 0.10, 0.13
    th = np.linspace(0, TWO_PI, 37)
    for sigma in (1, -1):
        th3, th4 = four_bar_pose(th, a, b, c, d, sigma)
        x = a * np.cos(th) + b * np.cos(th3) - d - c * np.cos(th4)
        y = a * np.sin(th) + b * np.sin(th3) - c * np.sin(th4)
        assert np.hypot(x, y).max() < 1e-15


# -- the closed forms of tests/reference_models.py and test_extremes.py ---------------------------

def rates(rec):
    """(position, its rate) column pairs of a closed-form record."""
    pairs = [("x", "vx"), ("y", "vy"), ("vx", "ax"), ("vy", "ay")]
    if "phi" in rec:
        pairs += [("phi", "omega"), ("omega", "alpha")]
    return pairs


REFERENCE = {
    "slider-crank": lambda t: R.slider_crank_closed_form(t, R.wobbly),
    "four-bar pins": lambda t: R.fourbar_closed_form(t, R.wobbly),
    "four-bar mid, deg": lambda t: R.fourbar_closed_form(t, R.wobbly, frames="mid", degrees=True),
    "whitworth": lambda t: R.whitworth_closed_form(t, R.wobbly),
    "trammel": R.trammel_closed_form,
    "boom linear": lambda t: R.boom_closed_form(t, "linear"),
    "boom sine": lambda t: R.boom_closed_form(2 * math.pi * t, "sine"),
    "rod = crank": lambda t: rod_equals_crank_smooth_cf(t, 0.1),
    "slider-driven": lambda t: R.broadcast({"bodies": R.slider_crank_bodies(*slider_driven_theta(
        lambda s: (0.3 + 0.05 * np.sin(TWO_PI * s), 0.05 * TWO_PI * np.cos(TWO_PI * s),
                   -0.05 * TWO_PI ** 2 * np.sin(TWO_PI * s)), 0.1, 0.3)(t), 0.1, 0.3)}, t),
}


@pytest.mark.parametrize("name", sorted(REFERENCE))
def test_reference_closed_forms_are_their_own_derivatives(name):
    fn, h = REFERENCE[name], 1e-6
    if name == "boom sine":     # boom_closed_form(t, "sine") takes the time 2 pi t: rates / 2 pi
        scale = 2 * math.pi
    else:
        scale = 1.0
    now, up, down = fn(T), fn(T + h), fn(T - h)
    checked = 0
    for sec in ("bodies", "points"):
        for body, rec in now.get(sec, {}).items():
            for pos, rate in rates(rec):
                d = (up[sec][body][pos] - down[sec][body][pos]) / (2 * h) / scale
                size = max(np.abs(rec[rate]).max(), np.abs(d).max())
                if size < 1e-12:
                    continue
                assert np.abs(d - rec[rate]).max() < 1e-7 * size, (name, body, pos, rate)
                checked += 1
    assert checked >= 4


def test_a_wrong_derivative_is_caught():
    """The checks can fail: the four-bar's coupler acceleration without its b th3'^2 term, and
    the crossed branch taken for the open one, are far outside the tolerances above."""
    a, b, c, d, sigma, th0 = FOUR_BARS["crank-rocker open"]
    np_th, mp_th = crank(th0)
    th, thd, thdd = np_th(T)
    th3, w3, al3, th4, w4, al4 = four_bar(th, thd, thdd, a, b, c, d)
    wrong = al3 - b * w3 ** 2 * np.cos(th3 - th4) / (b * np.sin(th4 - th3))
    want = [mp_derivatives(mp_four_bar(a, b, c, d, mp_th, (th3[k], th4[k]))[0], t)[2]
            for k, t in enumerate(T[:3])]
    assert worst(al3[:3], want) < 1e-12 and worst(wrong[:3], want) > 1e-3
    crossed = four_bar(th, thd, thdd, a, b, c, d, -1)
    assert worst(crossed[3], th4) > 1e-2
