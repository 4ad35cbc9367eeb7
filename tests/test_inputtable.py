"""Tabulated input motion (planarkin.functions.inputtable and a driver's table:)."""

import math

import numpy as np
import pytest

import planarkin
from planarkin.functions.inputtable import TableError, read_table, table_function

PI = math.pi


def test_quintic_polynomial_is_reproduced_to_rounding():
    rng = np.random.default_rng(7)
    t = np.sort(np.concatenate([[0.0, 2.0], rng.uniform(0, 2, 18)]))  # uneven spacing
    p = np.poly1d([0.3, -1.0, 0.5, 2.0, -1.0, 0.7])
    f = table_function(t, p(t), False, "poly.csv")
    x = np.linspace(0, 2, 2001)
    got = f.derivatives(x)
    for k, g in enumerate(got):
        want = p.deriv(k)(x) if k else p(x)
        np.testing.assert_allclose(g, want, rtol=0, atol=1e-12 * np.abs(want).max())
    np.testing.assert_allclose(f.third(x), p.deriv(3)(x), rtol=0,
                               atol=1e-10 * np.abs(p.deriv(3)(x)).max())
    assert f.breakpoints(0.0, 2.0) == []          # C4 inside: nothing to split at
    assert f.problems(0.0, 2.0) == []
    assert f.problems(-0.5, 2.0) == ["table poly.csv covers t from 0 to 2 s, but the analysis "
                                     "runs from -0.5 to 2 (extend the table, or set periodic: "
                                     "true for a cyclic one)"]


def test_short_tables_use_the_cubic_and_reproduce_a_cubic():
    t = np.array([0.0, 0.3, 1.0, 1.4, 2.0])
    p = np.poly1d([1.0, -2.0, 0.5, 3.0])
    f = table_function(t, p(t), False, "c.csv")
    x = np.linspace(0, 2, 101)
    for k, g in enumerate(f.derivatives(x)):
        np.testing.assert_allclose(g, p.deriv(k)(x) if k else p(x), atol=1e-12 * 10)


def test_periodic_table_is_smooth_across_the_wrap_and_converges():
    errs = []
    for n in (16, 32, 64):
        t = np.linspace(0.0, 1.0, n + 1)
        f = table_function(t, np.sin(2 * PI * t), True, "sin.csv")
        x = np.linspace(-1.0, 3.0, 4001)
        errs.append(np.abs(f(x) - np.sin(2 * PI * x)).max())
        for tw in (0.0, 1.0, 2.0):  # the wrap: value and three derivatives continuous
            left = (*f.derivatives(tw, -1), f.third(tw, -1))
            right = (*f.derivatives(tw, +1), f.third(tw, +1))
            assert left == pytest.approx(right, rel=1e-9, abs=1e-9)
        assert f.breakpoints(0.0, 3.0) == [] and f.problems(-1.0, 3.0) == []
    # a quintic spline: error ~ h**6, so each halving of the spacing gains about 2**6 = 64
    assert errs[0] / errs[1] > 40 and errs[1] / errs[2] > 40
    assert errs[2] < 1e-9


def test_reading_columns_headers_and_comments(tmp_path):
    p = tmp_path / "m.csv"
    p.write_text("# measured\ntime, x, angle\n0, 9, 0\n\n0.5, 9, 1\n1.0, 9, 4\n1.5, 9, 9\n")
    t, y, lines = read_table(p, "time", "angle")
    assert t.tolist() == [0, 0.5, 1.0, 1.5] and y.tolist() == [0, 1, 4, 9]
    assert lines == [3, 5, 6, 7]
    t, y, _ = read_table(p, 1, 2)
    assert y.tolist() == [9, 9, 9, 9]
    q = tmp_path / "w.txt"
    q.write_text("0 1\n1 2\n2 3\n3 5\n")
    assert read_table(q)[1].tolist() == [1, 2, 3, 5]
    with pytest.raises(TableError) as info:
        read_table(q, "time")
    assert info.value.args[0] == [(1, "the table has no header line, so time column 'time' "
                                      "cannot be found; give a column number (1, 2, ...)")]
    r = tmp_path / "bad.csv"
    r.write_text("t,v\n0,1\n1,nan\n2\n3,1e400\n")
    with pytest.raises(TableError) as info:
        read_table(r)
    assert info.value.args[0] == [(3, "values must be finite numbers"),
                                  (4, "expected at least 2 columns, found 1"),
                                  (5, "values must be finite numbers")]


def test_table_driver_in_a_model(tmp_path):
    t = np.linspace(0.0, 1.0, 21)
    rows = "\n".join(f"{float(a)!r},{float(b)!r}" for a, b in zip(t, 30 * np.sin(2 * PI * t)))
    (tmp_path / "motion.csv").write_text("t,angle\n" + rows + "\n")
    (tmp_path / "m.yaml").write_text("""
units: {angle: deg}
bodies:
  crank: {q: [0, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: crank, table: {file: motion.csv, time: t, value: angle, periodic: true}}
analysis: {end: 1.5, steps: 30}
""")
    model = planarkin.load(tmp_path / "m.yaml")
    res = planarkin.solve(model)
    assert res.status == 0
    f = table_function(t, 30 * np.sin(2 * PI * t), True, "motion.csv")
    v, d1, d2 = f.derivatives(res.t)
    np.testing.assert_allclose(res.q[:, 2], v, atol=1e-12 * 30)
    np.testing.assert_allclose(res.qd[:, 2], d1, atol=1e-12 * 200)
    np.testing.assert_allclose(res.qdd[:, 2], d2, atol=1e-12 * 1200)
    np.testing.assert_allclose(res.q[:, 2], 30 * np.sin(2 * PI * res.t), atol=1e-4)


def test_table_sampled_from_a_quintic_drives_a_model_exactly(tmp_path):
    """The issue's acceptance case: a tabulated motion reproduces the polynomial it was
    sampled from, in the solved positions, velocities and accelerations (1e-12 relative)."""
    p = np.poly1d([2.0, -5.0, 3.0, 1.0, 0.5, 0.1])    # x(t) of a slider, m
    t = np.array([0.0, 0.1, 0.25, 0.3, 0.45, 0.6, 0.7, 0.85, 1.0])
    (tmp_path / "x.csv").write_text("\n".join(f"{float(a)!r} {float(p(a))!r}" for a in t) + "\n")
    (tmp_path / "m.yaml").write_text("""
bodies:
  slider: {q: [0.1, 0, 0]}
joints:
  - {type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: x, body: slider, table: x.csv}
analysis: {end: 1, steps: 20}
""")
    res = planarkin.solve(planarkin.load(tmp_path / "m.yaml"))
    assert res.status == 0
    for got, want in ((res.q[:, 0], p(res.t)), (res.qd[:, 0], p.deriv()(res.t)),
                      (res.qdd[:, 0], p.deriv(2)(res.t))):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.abs(want).max())
