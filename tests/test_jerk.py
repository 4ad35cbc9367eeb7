"""Jerk (issue 8, item 5): jerk_g of every kind against differences in time, and runs with
`up_to: jerk` against closed forms and invariants.

The element identity: along a trajectory q(t), g'' = g_q q'' - gamma_g (the definition of
gamma_g) and g''' = g_q q''' - jerk_g (that of jerk_g). So d/dt [g_q q'' - gamma_g] taken by a
central difference in t must equal g_q q''' - jerk_g: it checks jerk_g against the (separately
tested) gradient and gamma. A second check needs neither: the third difference of g itself."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from test_elements import NB, ext, random_instances  # noqa: E402

from planarkin.elements import KINDS  # noqa: E402
from planarkin.elements.base import make_frame  # noqa: E402


def trajectory(rng):
    """q(t) = q0 + q1 t + q2 t^2/2 + q3 t^3/6 and its derivatives, (1, 3 NB + 3) each at t."""
    c = [rng.normal(size=(1, 3 * NB)) * s for s in (0.8, 1.0, 1.0, 1.0)]

    def at(t):
        q = c[0] + c[1] * t + c[2] * t * t / 2 + c[3] * t ** 3 / 6
        qd = c[1] + c[2] * t + c[3] * t * t / 2
        qdd = c[2] + c[3] * t
        return ext(q), ext(qd), ext(qdd), ext(c[3])
    return at


def product(G, q, v):
    J = G.grad(make_frame(q))
    return np.einsum("nkec,nkc->nke", J, v[:, G.cols])


@pytest.mark.parametrize("name", sorted(KINDS))
def test_jerk_is_the_time_derivative_of_the_gamma_identity(name):
    rng = np.random.default_rng(11)
    kind = KINDS[name]
    for _ in range(8):
        G = random_instances(kind, rng)
        at = trajectory(rng)

        def accel(t):                            # g'' = g_q q'' - gamma_g along q(t)
            q, qd, qdd, _ = at(t)
            return product(G, q, qdd) - G.gamma(make_frame(q, qd))

        h = 1e-3
        fd = (accel(3 * h) - 9 * accel(2 * h) + 45 * accel(h) - 45 * accel(-h)
              + 9 * accel(-2 * h) - accel(-3 * h)) / (60 * h)     # sixth order
        q, qd, qdd, q3 = at(0.0)
        jerk = G.jerk(make_frame(q, qd, qdd))
        assert jerk.shape == (1, len(G), kind.neq)
        got = product(G, q, q3) - jerk
        np.testing.assert_allclose(got, fd, rtol=1e-7, atol=1e-7 * (1 + np.abs(fd).max()))

        # independent of gamma and the gradient: the third difference of g itself
        g = lambda t: G.g(make_frame(at(t)[0]))          # noqa: E731
        e = 1e-3                                          # fourth-order stencil
        d3 = (-g(3 * e) + 8 * g(2 * e) - 13 * g(e) + 13 * g(-e) - 8 * g(-2 * e)
              + g(-3 * e)) / (8 * e ** 3)
        np.testing.assert_allclose(got, d3, rtol=1e-5, atol=1e-5 * (1 + np.abs(d3).max()))


def test_a_wrong_jerk_is_detected():
    """The revolute jerk without its -3 omega alpha s term fails the identity by far: the check
    can fail."""
    rng = np.random.default_rng(12)
    G = random_instances(KINDS["revolute"], rng)
    at = trajectory(rng)

    def accel(t):
        q, qd, qdd, _ = at(t)
        return product(G, q, qdd) - G.gamma(make_frame(q, qd))

    h = 1e-3
    fd = (accel(3 * h) - 9 * accel(2 * h) + 45 * accel(h) - 45 * accel(-h)
          + 9 * accel(-2 * h) - accel(-3 * h)) / (60 * h)
    q, qd, qdd, q3 = at(0.0)
    F = make_frame(q, qd, qdd)
    bi, bj, si, sj = KINDS["revolute"]._s(G, F)
    # the broken rule: s''' without its -3 omega alpha s term
    wrong = lambda b, s: -F.qd[:, 3 * b + 2] ** 3 * np.array([-s[1], s[0]])   # noqa: E731
    broken = np.moveaxis(-(wrong(bi, si) - wrong(bj, sj)), 0, -1)
    err = lambda jerk: np.abs(product(G, q, q3) - jerk - fd).max() / np.abs(fd).max()  # noqa
    assert err(KINDS["revolute"].jerk(G, F)) < 1e-9
    assert err(broken) > 1e-2


# -- runs with up_to: jerk against closed forms ------------------------------------------------

import planarkin  # noqa: E402
from closedforms import rel, slider_crank_jerk  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
TWO_PI = 2 * math.pi


def run(model, **opts):
    res = planarkin.solve(model, up_to="jerk", **opts)
    assert res.status == 0, res.message
    return res


def load(text):
    return planarkin.load("model.yaml", text=text)


def test_slider_crank_slider_jerk_closed_form():
    """The slider's jerk (closedforms.slider_crank_jerk, theta' = 2 pi)."""
    res = run(ROOT / "mechanisms" / "slider-crank.yaml", steps=360)
    a, b, w = 0.1, 0.3, TWO_PI
    th = w * res.t
    S = np.sin(th)
    x3 = slider_crank_jerk(th, w, a, b)
    assert rel(res.body("slider")["jx"], x3) < 1e-12
    assert rel(res.point("B")["jx"], x3) < 1e-12           # the wrist pin moves with the slider
    assert np.abs(res.body("slider")["jy"]).max() < 1e-12
    assert np.abs(res.body("crank")["jphi"]).max() < 1e-9   # constant speed: zero jerk
    # the rod's frame is the crank pin A = a (cos wt, sin wt): its jerk a w^3 (sin wt, -cos wt)
    A = res.body("rod")
    assert rel(A["jx"], a * w ** 3 * S) < 1e-12 and rel(A["jy"], -a * w ** 3 * np.cos(th)) < 1e-12


def test_cam_cycloidal_rise_follower_jerk_is_the_law_scaled():
    """s = h (u - sin(2 pi u)/(2 pi)), u = theta/beta: s''' = (h / beta^3) 4 pi^2 cos(2 pi u)
    (C_j = 4 pi^2), and at constant cam speed w the follower's jerk is s''' w^3."""
    res = run(ROOT / "mechanisms" / "cam-roller.yaml")
    h, beta, w = 0.02, 120.0, 360.0                     # m, deg, deg/s
    u = w * res.t / beta
    want = h / beta ** 3 * 4 * math.pi ** 2 * np.cos(TWO_PI * u) * w ** 3
    assert rel(res.body("follower")["jy"], want) < 1e-12
    assert abs(np.max(np.abs(res.body("follower")["jy"])) / (h / beta ** 3 * w ** 3)
               - 4 * math.pi ** 2) < 1e-9


RACK = """
units: {length: m, angle: rad}
parameters: {R: 0.02}
bodies:
  pinion: {q: [0, 0, 0]}
  rack: {q: [0, 0.02, 0]}
joints:
  - {type: revolute, i: ground, j: pinion, at: [0, 0]}
  - {type: translational, i: ground, j: rack, at: [0, R], axis: [1, 0]}
  - {type: rack-pinion, i: rack, j: pinion, si: [0, 0], vi: [1, 0], sj: [0, 0], r: R}
drivers:
  - {type: angle, body: pinion, f: "0.5*sin(3*t) + 0.2*t**3"}
points:
  tooth: {body: pinion, s: [0.02, 0]}
analysis: {end: 2, steps: 200}
"""


def test_rack_and_pinion_rack_jerk_is_minus_r_phi_triple_dot():
    """The rack above the pinion moves by -R phi (reference §3.3 sign check), so its jerk is
    -R phi''' = -R (-13.5 cos 3t + 1.2); a point on the pitch circle has the jerk of §0."""
    res = run(load(RACK))
    t = res.t
    phi3 = -0.5 * 27 * np.cos(3 * t) + 1.2
    assert rel(res.body("rack")["jx"], -0.02 * phi3) < 1e-12
    assert rel(res.body("pinion")["jphi"], phi3) < 1e-12
    phi = 0.5 * np.sin(3 * t) + 0.2 * t ** 3
    w = 1.5 * np.cos(3 * t) + 0.6 * t ** 2
    al = -4.5 * np.sin(3 * t) + 1.2 * t
    # s''' = phi''' R s - 3 w alpha s - w^3 R s for s = R (cos phi, sin phi)
    sx, sy = 0.02 * np.cos(phi), 0.02 * np.sin(phi)
    jx = (phi3 - w ** 3) * -sy - 3 * w * al * sx
    jy = (phi3 - w ** 3) * sx - 3 * w * al * sy
    assert rel(res.point("tooth")["jx"], jx) < 1e-12
    assert rel(res.point("tooth")["jy"], jy) < 1e-12


SERVO = """
units: {length: mm, angle: deg}
bodies:
  carriage: {q: [0, 0, 0]}
joints:
  - {type: translational, i: ground, j: carriage, at: [0, 0], axis: [1, 0]}
drivers:
  - type: slide
    i: ground
    j: carriage
    si: [0, 0]
    vi: [1, 0]
    sj: [0, 0]
    motion:
      segments:
        - {rise: 80, in: 0.5, law: cycloidal}
        - {dwell: 0.25}
        - {return: 80, in: 0.5, law: 3-4-5}
analysis: {end: 1.25, steps: 250}
"""


def test_servo_axis_jerk_is_the_profile_third_derivative():
    """Cycloidal rise of h = 80 mm in T = 0.5 s: x''' = h 4 pi^2 cos(2 pi t/T) / T^3; dwell: 0;
    3-4-5 return, s = h (1 - (10 u^3 - 15 u^4 + 6 u^5)): x''' = -h (60 - 360 u + 360 u^2)/T^3.
    Rows at the segment joints take the right-hand limit (the 3-4-5 jerk jumps there)."""
    res = run(load(SERVO))
    t = res.t
    h, T = 80.0, 0.5
    want = np.where(t < 0.5, h * 4 * math.pi ** 2 * np.cos(TWO_PI * t / T) / T ** 3, 0.0)
    u = (t - 0.75) / T
    ret = -h * (60 - 360 * u + 360 * u * u) / T ** 3
    want = np.where((t >= 0.75) & (t < 1.25), ret, want)
    want[-1] = ret[-1]                                  # the end row: the left-hand limit
    got = res.body("carriage")["jx"]
    assert np.max(np.abs(got - want)) / np.max(np.abs(want)) < 1e-12


FOUR_BAR = ROOT / "mechanisms" / "four-bar.yaml"


def test_four_bar_rocker_jerk_is_the_derivative_of_its_exact_acceleration():
    """The rocker's alpha column is exact; its derivative by a sixth-order difference over the
    grid must match the jerk column (interior rows, h = 1e-3 of the period)."""
    res = run(FOUR_BAR, steps=1000)
    t = res.t
    h = t[1] - t[0]
    for body in res.model.body_names:
        cols = res.body(body)
        for acc, jk in (("alpha", "jphi"), ("ax", "jx"), ("ay", "jy")):
            a = cols[acc]
            fd = (a[6:] - 9 * a[5:-1] + 45 * a[4:-2] - 45 * a[2:-4] + 9 * a[1:-5]
                  - a[:-6]) / (60 * h)
            got = cols[jk][3:-3]
            scale = np.abs(cols[jk]).max()
            if scale > 0:
                assert np.abs(got - fd).max() / scale < 1e-8, (body, jk)


def test_integrated_jerk_is_the_acceleration_difference():
    """Velocity / acceleration / jerk consistency: Simpson's rule of the jerk over each pair of
    grid intervals equals the change of the (exact) acceleration (error ~ h^4 jerk'''')."""
    res = run(ROOT / "mechanisms" / "slider-crank.yaml", steps=2000)
    h = res.t[1] - res.t[0]
    for b in res.model.body_names:
        cols = res.body(b)
        for acc, jk in (("ax", "jx"), ("ay", "jy"), ("alpha", "jphi")):
            j, a = cols[jk], cols[acc]
            simpson = h / 3 * (j[:-2:2] + 4 * j[1:-1:2] + j[2::2])
            da = a[2::2] - a[:-2:2]
            scale = max(np.abs(a).max(), 1e-300)
            assert np.abs(simpson - da).max() / scale < 1e-9, (b, jk)


def test_jerk_columns_in_the_tables(tmp_path):
    """bodies.csv and points.csv gain .jx .jy .jphi [unit/s^3] after the acceleration columns,
    equal to the API's arrays; runs that do not ask for jerk keep their columns."""
    from clitools import run_cli
    r = run_cli("run", str(ROOT / "mechanisms" / "slider-crank.yaml"), "--out", str(tmp_path),
                "--up-to", "jerk", "--no-plots", "--steps", "20")
    assert r.returncode == 0, r.stderr
    header = (tmp_path / "slider-crank" / "bodies.csv").read_text().splitlines()[0].split(",")
    assert header[10:13] == ["crank.jx [m/s^3]", "crank.jy [m/s^3]", "crank.jphi [rad/s^3]"]
    pts = (tmp_path / "slider-crank" / "points.csv").read_text().splitlines()[0].split(",")
    assert pts[1:] == ["B.x [m]", "B.y [m]", "B.vx [m/s]", "B.vy [m/s]", "B.ax [m/s^2]",
                       "B.ay [m/s^2]", "B.jx [m/s^3]", "B.jy [m/s^3]"]
    X = np.loadtxt(tmp_path / "slider-crank" / "bodies.csv", delimiter=",", skiprows=1)
    res = run(ROOT / "mechanisms" / "slider-crank.yaml", steps=20)
    np.testing.assert_array_equal(X[:, header.index("slider.jx [m/s^3]")],
                                  res.body("slider")["jx"])
    plain = planarkin.solve(ROOT / "mechanisms" / "slider-crank.yaml", steps=20)
    assert plain.qddd is None and "jx" not in plain.body("slider")


def test_jerk_refused_with_interpolated_rows():
    with pytest.raises(planarkin.InputError) as e:
        planarkin.solve(ROOT / "mechanisms" / "slider-crank.yaml", up_to="jerk",
                        interpolate=True)
    assert ("solve(): up_to: jerk needs the exact solve at every grid row, and interpolate: "
            "true interpolates the rows") in str(e.value)


def test_jerk_of_a_row_solved_by_path_following():
    """A grid row that falls back to path following gets its jerk from the same exact solve
    (Analysis._jerk_at), here at internal path nodes of the slider-crank, against x'''."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    cm = planarkin.load(ROOT / "mechanisms" / "slider-crank.yaml")
    an = prepare(cm, resolve(cm, {"up_to": "jerk"}))
    slider = list(cm.body_names).index("slider")
    a, b, w = 0.1, 0.3, TWO_PI
    for k in range(1, len(an.Tn), 5):
        t = float(an.Tn[k])
        third = an.S_all.driver_third(np.array([t]))[0]
        j = an._jerk_at(int(an.seg[k]), t, an.Qn[k], an.Qdn[k], an.Qddn[k], third)
        x3 = slider_crank_jerk(w * t, w, a, b)
        assert abs(j[3 * slider] * cm.L - x3) < 1e-12 * (a * w ** 3) * 10


def test_block_solve_satisfies_the_whole_jerk_system():
    """The block-by-block jerks satisfy the dense system Phi_q q''' = jerk_g + f''' of every
    row (System.jacobian, System.jerk), here on the six-bar (two loops, several blocks)."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    from planarkin.solver.system import System
    cm = planarkin.load(ROOT / "mechanisms" / "six-bar.yaml")
    an = prepare(cm, resolve(cm, {"up_to": "jerk", "steps": 40}))
    ch = next(an.chunks())
    unit = np.tile([cm.L, cm.L, 1.0 / cm.angle_factor], cm.nb)
    S = System(cm)
    Q, Qd, Qdd, Q3 = (S.ext(a / unit) for a in (ch.q, ch.qd, ch.qdd, ch.qddd))
    lhs = np.einsum("nmc,nc->nm", S.jacobian(Q), Q3[:, :cm.n])
    rhs = S.jerk(Q, Qd, Qdd, ch.t)
    assert np.abs(lhs - rhs).max() < 1e-9 * max(1.0, np.abs(rhs).max())


@pytest.mark.slow
@pytest.mark.parametrize("path", sorted((ROOT / "mechanisms").glob("*.yaml")),
                         ids=lambda p: p.stem)
def test_every_example_runs_with_jerk(path):
    """Every example (every kind they use: gears, belts, racks, cams, tables, motion
    profiles...) runs with up_to: jerk, and its jerk integrates to its acceleration changes: the
    trapezoid rule over each interval of the example's own grid, within 1e-3 of the
    acceleration's range plus h |change of the jerk| (where the jerk steps, at the joints of a
    motion profile, a row holds one one-sided value, and the rule is off by about h/2 times the
    step). A gross check, which catches a missing or mis-signed term of any kind."""
    res = run(path)
    h = np.diff(res.t)[:, None]
    acc = np.hstack([res.qdd, res.pdd.reshape(len(res.t), -1)])
    jerk = np.hstack([res.qddd, res.pddd.reshape(len(res.t), -1)])
    assert np.isfinite(jerk).all()
    trap = 0.5 * h * (jerk[1:] + jerk[:-1])
    scale = np.maximum(np.ptp(acc, axis=0), 1e-9 * (1 + np.abs(acc).max()))
    allowed = 1e-3 * scale + h * np.abs(np.diff(jerk, axis=0))
    assert (np.abs(trap - np.diff(acc, axis=0)) <= allowed).all()


@pytest.mark.parametrize("source", ["expression", "piecewise", "law", "motion", "table"])
def test_every_driver_form_has_an_exact_third_derivative(source):
    """f''' of every driver form (TimeFunction.third) against a central difference of its exact
    f'' at points away from the knots (the difference is the test's only approximation)."""
    from planarkin.functions.expr import TimeFunction
    if source == "motion":
        f = planarkin.load(ROOT / "mechanisms" / "servo-press.yaml").driver_funcs[0]
    elif source == "table":
        f = planarkin.load(ROOT / "mechanisms" / "table-input.yaml").driver_funcs[0]
    else:
        text = {"expression": "0.3*sin(2*t) + exp(-t)*t**4 + sqrt(1 + t*t)",
                "piecewise": "where(t < 0.37, t**4, 0.37**4 + 4*0.37**3*(t - 0.37)) + "
                             "max(t**2, 0.5*t) + mod(t**3, 0.7) + clip(t**5, 0.1, 0.9)",
                "law": "cycloidal(t/0.8) + poly345(t) + modified_sine(t/1.3)"}[source]
        f = TimeFunction(text, {})
    rng = np.random.default_rng(21)
    t = np.sort(rng.uniform(0.05, 0.95, 40))
    e = 1e-5
    fd = (f.derivatives(t + e)[2] - f.derivatives(t - e)[2]) / (2 * e)
    got = np.asarray(f.third(t), float)
    scale = max(np.abs(fd).max(), 1.0)
    # a knot inside (t - e, t + e) would spoil the difference: none of these random t is one
    assert np.abs(got - fd).max() / scale < 1e-6
