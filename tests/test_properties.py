"""Property tests (hypothesis, derandomized): random Grashof crank-rockers and slider-cranks on
random grids.

For every drawn mechanism (random link lengths, offset, overall size, starting crank angle and
turning direction) and grid (3..400 steps over 1..3 turns):

* the results match the closed form (tests/test_extremes.py) on the drawn grid, on the assembled
  branch (positions 1e-8, velocities 1e-7, accelerations 1e-5 relative);
* loop closure: the joint points computed from either body coincide, in position, velocity and
  acceleration, to 1e-10 relative; link lengths stay constant;
* velocities and accelerations agree with 8th-order central differences of the positions (and
  accelerations with those of the velocities) on a fine grid, 1e-5 relative;
* grid independence: solved on n and on k n steps (k = 2 or 3), the common times agree to 1e-10.

Hypothesis prints the falsifying example (and a reproduction blob) on failure.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import planarkin
from hypothesis import HealthCheck, assume, given, note, settings
from hypothesis import strategies as st

try:    # hypothesis's caches (constants, no example database) outside the shared checkout
    from hypothesis.configuration import set_hypothesis_home_dir
    set_hypothesis_home_dir(Path(tempfile.gettempdir()) / "planarkin-hypothesis")
except ImportError:    # older hypothesis: nothing to move
    pass

sys.path.insert(0, str(Path(__file__).resolve().parent))

from closedforms import four_bar_pose as fourbar_pose  # noqa: E402
from test_extremes import (TWO_PI, compare, fourbar_cf, fourbar_yaml,  # noqa: E402
                           on_grid, slider_crank_cf, slider_crank_yaml, uniform)

TOL_CLOSURE = 1e-10
TOL_GRID = 1e-10
TOL_FD = 1e-5
FINE_PER_TURN = 400
WORST: dict = {}          # measured worst relative errors per check (for reports)


def record(key, value):
    WORST[key] = max(WORST.get(key, 0.0), float(value))
    return value

SETTINGS = dict(derandomize=True, deadline=None, database=None, print_blob=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])

# 8th-order central differences (first and second derivative)
D1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
D2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


def central(y, h, coef, power):
    k = len(coef) // 2
    n = y.shape[0]
    return sum(c * y[k + j: n - k + j] for j, c in zip(range(-k, k + 1), coef) if c) / h ** power


# == strategies ===================================================================================

sizes = st.sampled_from([1e-3, 1.0, 37.5])        # overall size of the mechanism (m)
grids = st.tuples(st.integers(3, 400), st.integers(1, 3), st.sampled_from([2, 3]))


@st.composite
def crank_rockers(draw):
    """Grashof crank-rockers, crank the shortest link: ground d = 1, coupler b and rocker c in
    [0.6, 1.6], crank a a fraction of the largest crank that keeps s + l < p + q."""
    b = draw(st.floats(0.6, 1.6))
    c = draw(st.floats(0.6, 1.6))
    d = 1.0
    links = sorted((b, c, d))
    a_max = min(links[0], links[0] + links[1] - links[2])   # a < min, a + l < p + q
    assume(a_max > 0.1)
    a = draw(st.floats(0.15, 0.8)) * a_max
    # keep the transmission angle away from 0 and pi (the rocker's dead positions are regular,
    # but a nearly flat coupler-rocker pair is a near-change point)
    th = np.linspace(0, TWO_PI, 721)
    th3, th4 = fourbar_pose(th, a, b, c, d, 1)
    assume(np.abs(np.sin(th4 - th3)).min() > 0.15)
    s = draw(sizes)
    return dict(a=a * s, b=b * s, c=c * s, d=d * s, th0=draw(st.floats(0.0, TWO_PI)),
                w=draw(st.sampled_from([TWO_PI, -TWO_PI])))


@st.composite
def slider_cranks(draw):
    """Slider-cranks with rod l > 1.05 r and an offset within 80 % of the limit l - r of a
    fully turning crank."""
    r = 1.0
    l = r * draw(st.floats(1.05, 4.0))
    e = draw(st.floats(-0.8, 0.8)) * (l - r)
    s = draw(sizes)
    return dict(r=r * s, l=l * s, e=e * s, th0=draw(st.floats(0.0, TWO_PI)),
                w=draw(st.sampled_from([TWO_PI, -TWO_PI])))


# == checks =======================================================================================

def rigid(res, body, s):
    """P, V, A ((N, 2) each) of the body-fixed point s, from the solver's body coordinates."""
    b = res.body(body)
    c, sn = np.cos(b["phi"]), np.sin(b["phi"])
    sx, sy = c * s[0] - sn * s[1], sn * s[0] + c * s[1]
    w, al = b["omega"], b["alpha"]
    return (np.stack([b["x"] + sx, b["y"] + sy], 1),
            np.stack([b["vx"] - w * sy, b["vy"] + w * sx], 1),
            np.stack([b["ax"] - al * sy - w * w * sx, b["ay"] + al * sx - w * w * sy], 1))


def check_pins(res, pins, size):
    """pins: [(body, s, body or None for ground, s or fixed point)] that must coincide."""
    worst = 0.0
    for k in range(3):
        # scale of kind k: the largest point quantity of that kind among the pins
        pts = [rigid(res, b, s)[k] for b, s, _, _ in pins]
        scale = max(np.hypot(*p.T).max() for p in pts) if k else size
        scale = scale or 1.0
        for (b1, s1, b2, s2), p1 in zip(pins, pts):
            p2 = rigid(res, b2, s2)[k] if b2 is not None else (np.asarray(s2) if k == 0 else 0.0)
            rel = float(np.hypot(*(p1 - p2).T).max() / scale)
            worst = max(worst, record(f"closure {'PVA'[k]}", rel))
            assert rel <= TOL_CLOSURE, f"{b1}{s1} vs {b2}{s2}, {'PVA'[k]}: {rel:.3g}"
    return worst


def check_lengths(res, pairs, size):
    for (b1, s1, b2, s2, length) in pairs:
        p1 = rigid(res, b1, s1)[0]
        p2 = rigid(res, b2, s2)[0] if b2 is not None else np.asarray(s2)
        rel = record("link length", np.abs(np.hypot(*(p1 - p2).T) - length).max() / size)
        assert rel <= TOL_CLOSURE, f"length {b1}-{b2}: {rel:.3g}"


def check_fd(res):
    """Velocities and accelerations against central differences of positions (and velocities),
    column by column, each relative to its largest value (floored at 1e-3 of its kind's)."""
    h = res.t[1] - res.t[0]
    k = len(D1) // 2
    worst = 0.0
    for name, got, ref in (("velocity", res.qd[k:-k], central(res.q, h, D1, 1)),
                           ("acceleration", res.qdd[k:-k], central(res.q, h, D2, 2)),
                           ("acceleration/v", res.qdd[k:-k], central(res.qd, h, D1, 1))):
        mag = np.abs(got).max(axis=0)
        angle = np.arange(got.shape[1]) % 3 == 2
        floor = np.where(angle, mag[angle].max(), mag[~angle].max()) * 1e-3
        scale = np.maximum(mag, np.maximum(floor, 1e-300))
        rel = (np.abs(got - ref).max(axis=0) / scale)
        worst = max(worst, record(f"finite differences {name}", rel.max()))
        assert rel.max() <= TOL_FD, f"{name}: {rel.max():.3g} (column {int(np.argmax(rel))})"
    return worst


def check_grid_independence(r1, r2, k):
    """r2 solved on k times r1's steps: its every k-th row is r1's row."""
    np.testing.assert_allclose(r2.t[::k], r1.t, rtol=0, atol=1e-12 * max(1.0, r1.t[-1]))
    worst = 0.0
    for a, b in ((r1.q, r2.q[::k]), (r1.qd, r2.qd[::k]), (r1.qdd, r2.qdd[::k])):
        scale = np.abs(b).max(axis=0)
        angle = np.arange(b.shape[1]) % 3 == 2
        floor = np.where(angle, scale[angle].max(), scale[~angle].max())
        scale = np.maximum(scale, floor * 1e-3) + 1e-300
        rel = float((np.abs(a - b).max(axis=0) / scale).max())
        worst = max(worst, record("grid independence", rel))
        assert rel <= TOL_GRID, f"grid {len(r1.t) - 1} vs {len(r2.t) - 1}: {rel:.3g}"
    return worst


def run(text, steps, turns):
    model = planarkin.load("prop.yaml", text=text)
    res = planarkin.solve(model, steps=steps, end=turns)
    assert res.status == 0, res.message
    assert len(res.t) == steps + 1
    return res


# == properties ===================================================================================

@settings(max_examples=22, **SETTINGS)
@given(m=crank_rockers(), grid=grids)
def test_random_crank_rocker(m, grid):
    n, turns, k = grid
    a, b, c, d, th0, w = (m[x] for x in ("a", "b", "c", "d", "th0", "w"))
    drv = f'{{type: angle, body: crank, f: "{th0!r} + {w!r}*t"}}'
    text = fourbar_yaml(a, b, c, d, th0=th0, driver=drv)
    note(text)
    res = run(text, n, turns)
    for kind, err in compare(res, on_grid(lambda t: fourbar_cf(t, a, b, c, d,
                                                                 theta=uniform(w, th0)),
                                          n, turns)).items():
        record(f"closed form {kind}", err)
    size = max(a, b, c, d)
    pins = [("crank", (0.0, 0.0), None, (0.0, 0.0)),
            ("crank", (a, 0.0), "coupler", (0.0, 0.0)),
            ("coupler", (b, 0.0), "rocker", (c, 0.0)),
            ("rocker", (0.0, 0.0), None, (d, 0.0))]
    check_pins(res, pins, size)
    check_lengths(res, [("crank", (a, 0.0), "rocker", (c, 0.0), b),
                        ("coupler", (b, 0.0), None, (d, 0.0), c)], size)
    fine = run(text, FINE_PER_TURN * turns, turns)
    check_pins(fine, pins, size)
    check_fd(fine)
    check_grid_independence(res, run(text, k * n, turns), k)


@settings(max_examples=22, **SETTINGS)
@given(m=slider_cranks(), grid=grids)
def test_random_slider_crank(m, grid):
    n, turns, k = grid
    r, l, e, th0, w = (m[x] for x in ("r", "l", "e", "th0", "w"))
    drv = f'{{type: angle, body: crank, f: "{th0!r} + {w!r}*t"}}'
    text = slider_crank_yaml(r, l, e, driver=drv, est=th0)
    note(text)
    res = run(text, n, turns)
    for kind, err in compare(res, on_grid(lambda t: slider_crank_cf(t, r, l, e,
                                                                    theta=uniform(w, th0)),
                                          n, turns)).items():
        record(f"closed form {kind}", err)
    size = max(r, l)
    pins = [("crank", (0.0, 0.0), None, (0.0, 0.0)),
            ("crank", (r, 0.0), "rod", (0.0, 0.0)),
            ("rod", (l, 0.0), "slider", (0.0, 0.0))]
    check_pins(res, pins, size)
    slider = res.body("slider")
    assert np.abs(slider["y"] - e).max() <= TOL_CLOSURE * size
    assert np.abs(slider["phi"]).max() <= TOL_CLOSURE
    check_lengths(res, [("crank", (r, 0.0), "slider", (0.0, 0.0), l)], size)
    assert (np.cos(res.body("rod")["phi"]) > 0).all()          # the assembled branch
    fine = run(text, FINE_PER_TURN * turns, turns)
    check_pins(fine, pins, size)
    check_fd(fine)
    check_grid_independence(res, run(text, k * n, turns), k)
