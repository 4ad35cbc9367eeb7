"""Reference tests: planarkin against hand-derived closed-form kinematics of classic mechanisms.

The models (YAML texts) and the closed forms (positions, and their ANALYTIC first and second time
derivatives; derivations in the docstrings) live in tests/reference_models.py. Every grid row is
checked. Errors are relative to the scale of the quantity over the run: for a 2-vector (a body
origin, a point, their velocities, accelerations) the largest norm over the grid, for an angle,
angular velocity or acceleration the largest magnitude; a quantity that is identically zero in
the closed form (a fixed pivot's position, a slider's angle) is measured against the largest
quantity of its kind in the mechanism. Tolerances: positions 1e-9, velocities 1e-8,
accelerations 1e-7.

Cases:
  1. offset slider-crank, constant and non-uniform crank speed
  2. crank-rocker four-bar in degrees (Freudenstein, open branch), coupler point off the coupler line
  3. Whitworth quick-return with a sliding block, and the same with a pin-slot joint
  4. elliptical trammel driven by a slider's x
  5. boom raised by a hydraulic cylinder (distance driver), linear and oscillating stroke
  6. a four-bar placed by global points (at:) against the same with si/sj
  7. invariants: loop closure, constant link lengths, velocities and accelerations against
     high-order central differences of the computed positions; grid independence (7/36/360 steps)
"""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

import planarkin  # noqa: E402
import reference_models as R  # noqa: E402

TOL = {"P": 1e-9, "V": 1e-8, "A": 1e-7}
TOL_SAME = 1e-12          # two models / two grids of the same motion
TOL_CLOSURE = 1e-12       # joint points coincide, link lengths constant
TOL_FD = 1e-6             # against central differences of the computed positions

BODY_GROUPS = (("P", ("x", "y")), ("V", ("vx", "vy")), ("A", ("ax", "ay")),
               ("P", ("phi",)), ("V", ("omega",)), ("A", ("alpha",)))
POINT_GROUPS = (("P", ("x", "y")), ("V", ("vx", "vy")), ("A", ("ax", "ay")))

SLIDER_DRIVERS = {
    "uniform": ("2*pi*t", R.uniform(R.TWO_PI)),
    "wobbly": ("2*pi*t + 0.3*sin(2*pi*t)", R.wobbly),
}


# -- helpers ---------------------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def solve(text: str, name: str = "model", **options):
    """Load a model text and solve it; the run must succeed. Cached: several tests share runs."""
    model = planarkin.load(f"{name}.yaml", text=text)
    res = planarkin.solve(model, **options)
    assert res.status == 0, f"{name}: {res.message}"
    assert len(res.t) == options.get("steps", model.spec.analysis.steps) + 1
    return res


def _norm(cols):
    return np.sqrt(sum(np.asarray(c, float) ** 2 for c in cols))


def _records(res, cf):
    """(label, kind, keys, numeric record, closed-form record, is_angle) for every checked group."""
    for sec, get, groups in (("bodies", res.body, BODY_GROUPS), ("points", res.point, POINT_GROUPS)):
        for name, rec in cf[sec].items():
            num = get(name)
            for kind, keys in groups:
                yield f"{sec[:-1]} {name} {'/'.join(keys)}", kind, keys, num, rec, len(keys) == 1


def compare(res, cf, tol=TOL):
    """Relative errors of a result against a closed form, per group; asserts the tolerances.
    Returns the worst relative error per kind (P, V, A)."""
    recs = list(_records(res, cf))
    # largest quantity of each kind (lengths and angles apart): the scale of identically-zero ones
    ref = {}
    for _, kind, keys, _, rec, ang in recs:
        ref[kind, ang] = max(ref.get((kind, ang), 0.0), _norm([rec[k] for k in keys]).max())
    worst = {"P": 0.0, "V": 0.0, "A": 0.0}
    failures = []
    for label, kind, keys, num, rec, ang in recs:
        scale = _norm([rec[k] for k in keys]).max()
        if scale <= 1e-12 * ref[kind, ang]:
            scale = ref[kind, ang]
        err = _norm([num[k] - rec[k] for k in keys])
        rel = err.max() / scale
        worst[kind] = max(worst[kind], rel)
        if not rel <= tol[kind]:
            i = int(np.argmax(err))
            failures.append(f"{label}: relative error {rel:.3g} > {tol[kind]:g} (worst at "
                            f"t = {res.t[i]:.6g}: got {[float(num[k][i]) for k in keys]}, closed "
                            f"form {[float(rec[k][i]) for k in keys]})")
    assert not failures, "\n".join(failures)
    return worst


def assert_same(r1, r2, tol=TOL_SAME, rows1=slice(None), rows2=slice(None), bodies=None,
                points=None):
    """Two results of the same motion agree on the given bodies and points (default: all of r2's),
    group by group as in `compare`, relative to each quantity's largest size over r2's run (to the
    largest of its kind when it is identically zero, like a fixed pivot's position)."""
    np.testing.assert_allclose(r1.t[rows1], r2.t[rows2], rtol=0, atol=1e-13)
    bodies = r2.model.body_names if bodies is None else bodies
    points = r2.model.point_names if points is None else points
    recs = [(f"body {b}", g, r1.body(b), r2.body(b)) for b in bodies for g in BODY_GROUPS] + \
           [(f"point {p}", g, r1.point(p), r2.point(p)) for p in points for g in POINT_GROUPS]
    ref = {}
    for _, (kind, keys), _, rec in recs:
        key = kind, len(keys) == 1
        ref[key] = max(ref.get(key, 0.0), _norm([rec[k] for k in keys]).max())
    failures = []
    for label, (kind, keys), num, rec in recs:
        scale = _norm([rec[k] for k in keys]).max()
        if scale <= 1e-12 * ref[kind, len(keys) == 1]:
            scale = ref[kind, len(keys) == 1]
        rel = _norm([num[k][rows1] - rec[k][rows2] for k in keys]).max() / scale
        if not rel <= tol:
            failures.append(f"{label} {'/'.join(keys)}: relative difference {rel:.3g} > {tol:g}")
    assert not failures, "\n".join(failures)


def rigid(res, body, s, degrees=False):
    """Global position, velocity, acceleration of the body-fixed point s of a body, from the
    solver's body coordinates (each an (N, 2) array)."""
    b = res.body(body)
    k = math.pi / 180.0 if degrees else 1.0
    phi, w, al = b["phi"] * k, b["omega"] * k, b["alpha"] * k
    c, sn = np.cos(phi), np.sin(phi)
    sx, sy = c * s[0] - sn * s[1], sn * s[0] + c * s[1]
    P = np.stack([b["x"] + sx, b["y"] + sy], axis=1)
    V = np.stack([b["vx"] - w * sy, b["vy"] + w * sx], axis=1)
    A = np.stack([b["ax"] - al * sy - w * w * sx, b["ay"] + al * sx - w * w * sy], axis=1)
    return P, V, A


def xy(d, a="x", b="y"):
    return np.stack([d[a], d[b]], axis=1)


def max_rel(x, scale):
    return float(np.abs(x).max() / scale)


# 8th-order central differences (first and second derivative), interior rows only
D1 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
D2 = np.array([-1 / 560, 8 / 315, -1 / 5, 8 / 5, -205 / 72, 8 / 5, -1 / 5, 8 / 315, -1 / 560])


def central(y, h, coef):
    """Central difference of the columns of y (N, ...) on a uniform grid of spacing h."""
    k = len(coef) // 2
    n = y.shape[0]
    out = sum(c * y[k + j: n - k + j] for j, c in zip(range(-k, k + 1), coef) if c != 0)
    return out / (h if coef is D1 else h * h)


# == 1. offset slider-crank ========================================================================

@pytest.mark.parametrize("driver", sorted(SLIDER_DRIVERS))
def test_offset_slider_crank(driver):
    f, theta = SLIDER_DRIVERS[driver]
    res = solve(R.slider_crank_yaml(f), "offset-slider-crank", steps=200)
    np.testing.assert_allclose(res.t, np.linspace(0, 1, 201), rtol=0, atol=1e-15)
    compare(res, R.slider_crank_closed_form(res.t, theta))


# == 2. crank-rocker four-bar in degrees ===========================================================

def test_crank_rocker_in_degrees():
    res = solve(R.FOURBAR_DEG_YAML, "crank-rocker-deg", steps=360)
    cf = R.fourbar_closed_form(res.t, degrees=True)
    compare(res, cf)
    # the angles really are degrees: the crank turns 360 deg at 360 deg/s, the rocker swings
    # between about 92.9 and 142.0 deg
    crank, rocker = res.body("crank"), res.body("rocker")
    np.testing.assert_allclose(crank["phi"], 360.0 * res.t, rtol=0, atol=1e-10)
    np.testing.assert_allclose(crank["omega"], 360.0, rtol=1e-13)
    assert 92.0 < rocker["phi"].min() < 93.0 and 141.5 < rocker["phi"].max() < 142.5
    # Freudenstein: K1 cos th4 - K2 cos th2 + K3 = cos(th2 - th4) on every row (radians)
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    th2, th4 = np.radians(crank["phi"]), np.radians(rocker["phi"])
    K1, K2, K3 = d / a, d / c, (a * a - b * b + c * c + d * d) / (2 * a * c)
    lhs = K1 * np.cos(th4) - K2 * np.cos(th2) + K3
    assert max_rel(lhs - np.cos(th2 - th4), K1 + K2 + K3) <= 1e-12
    # open configuration: B on the left of A -> O4 at every row
    A = rigid(res, "crank", (a, 0.0), degrees=True)[0]
    B = rigid(res, "rocker", (c, 0.0), degrees=True)[0]
    cross = (d - A[:, 0]) * (B[:, 1] - A[:, 1]) - (-A[:, 1]) * (B[:, 0] - A[:, 0])
    assert (cross > 0).all()


# == 3. Whitworth quick-return ===================================================================

def _whitworth_slide(res):
    """The block's slide rho along the slot, from O4, and its derivatives, from the results:
    rho = (r_b - O4).e, rho' = v_b.e, rho'' = a_b.e + 2 w v_b.e_perp - w^2 rho (e = lever axis;
    (r_b - O4).e_perp = 0 on the solution)."""
    blk, lev = res.body("block"), res.body("lever")
    e = np.stack([np.cos(lev["phi"]), np.sin(lev["phi"])], axis=1)
    ep = np.stack([-e[:, 1], e[:, 0]], axis=1)
    w = lev["omega"]
    rel = xy(blk) - xy(lev)
    rho = (rel * e).sum(1)
    rhod = (xy(blk, "vx", "vy") * e).sum(1)
    rhodd = (xy(blk, "ax", "ay") * e).sum(1) + 2 * w * (xy(blk, "vx", "vy") * ep).sum(1) \
        - w * w * rho
    return rho, rhod, rhodd, (rel * ep).sum(1)


def test_whitworth_quick_return_block():
    res = solve(R.WHITWORTH_BLOCK_YAML, "whitworth-block", steps=240)
    cf = R.whitworth_closed_form(res.t)
    compare(res, cf)
    rho, rhod, rhodd, off = _whitworth_slide(res)
    s = cf["slide"]
    assert max_rel(off, np.abs(s["s"]).max()) <= TOL["P"]          # the block is on the slot line
    assert max_rel(rho - s["s"], np.abs(s["s"]).max()) <= TOL["P"]
    assert max_rel(rhod - s["v"], np.abs(s["v"]).max()) <= TOL["V"]
    assert max_rel(rhodd - s["a"], np.abs(s["a"]).max()) <= TOL["A"]
    # quick return: the lever turns once per crank turn, slowly on the working stroke
    lev = res.body("lever")
    assert abs(lev["phi"][-1] - lev["phi"][0] - 2 * math.pi) < 1e-9
    assert lev["omega"].max() / lev["omega"].min() > 1.5


def test_whitworth_pin_slot_equals_block():
    block = solve(R.WHITWORTH_BLOCK_YAML, "whitworth-block", steps=240)
    pin = solve(R.WHITWORTH_PINSLOT_YAML, "whitworth-pin-slot", steps=240)
    assert_same(pin, block, bodies=("crank", "lever"), points=("T",))
    cf = R.whitworth_closed_form(pin.t)
    del cf["bodies"]["block"]
    compare(pin, cf)


# == 4. elliptical trammel =========================================================================

def test_elliptical_trammel():
    res = solve(R.TRAMMEL_YAML, "elliptical-trammel", steps=300)
    compare(res, R.trammel_closed_form(res.t))
    # the bar point traces (x/(L-p))^2 + (y/p)^2 = 1; the velocity is tangent to the ellipse and
    # the acceleration satisfies its second time derivative
    L, p = R.TRAMMEL["L"], R.TRAMMEL["p"]
    P = res.point("P")
    ax2, by2 = (L - p) ** 2, p ** 2
    g0 = P["x"] ** 2 / ax2 + P["y"] ** 2 / by2 - 1
    g1 = P["x"] * P["vx"] / ax2 + P["y"] * P["vy"] / by2
    g2 = (P["vx"] ** 2 + P["x"] * P["ax"]) / ax2 + (P["vy"] ** 2 + P["y"] * P["ay"]) / by2
    vmax = _norm([P["vx"], P["vy"]]).max()
    amax = _norm([P["ax"], P["ay"]]).max()
    assert max_rel(g0, 1.0) <= TOL["P"]
    assert max_rel(g1, vmax / p) <= TOL["V"]
    assert max_rel(g2, (vmax ** 2 + L * amax) / p ** 2) <= TOL["A"]
    # the sliders stay on their axes, and A-B stays L apart
    s1, s2 = res.body("slider1"), res.body("slider2")
    assert max_rel(s1["y"], L) <= TOL_CLOSURE and max_rel(s2["x"], L) <= TOL_CLOSURE
    assert max_rel(np.hypot(s1["x"], s2["y"]) - L, L) <= TOL_CLOSURE


# == 5. boom and hydraulic cylinder ================================================================

@pytest.mark.parametrize("run", sorted(R.BOOM_RUNS))
def test_boom_cylinder(run):
    res = solve(R.boom_yaml(run), f"boom-{run}", steps=300)
    compare(res, R.boom_closed_form(res.t, run))
    # the cylinder length and its first two derivatives are the driver's f, f', f''
    f, fd, fdd = R.BOOM_RUNS[run][0](res.t)
    P = res.point("P")
    h = xy(P) - np.array(R.BOOM["C"])
    V, A = xy(P, "vx", "vy"), xy(P, "ax", "ay")
    ln = np.hypot(h[:, 0], h[:, 1])
    lnd = (h * V).sum(1) / ln
    lndd = ((V * V).sum(1) + (h * A).sum(1)) / ln - (h * V).sum(1) ** 2 / ln ** 3
    assert max_rel(ln - f, f.max()) <= TOL["P"]
    assert max_rel(lnd - fd, np.abs(fd).max()) <= TOL["V"]
    # (f'' = 0 for the linear run: measure against the size of the terms of lndd)
    terms = ((V * V).sum(1) + np.hypot(*h.T) * np.hypot(*A.T)) / ln
    assert max_rel(lndd - fdd, max(np.abs(fdd).max(), terms.max())) <= TOL["A"]


# == 6. a four-bar placed by global points =========================================================

def test_fourbar_placed_by_points():
    at = solve(R.fourbar_at_yaml(0.7), "crank-rocker-at", steps=240)
    sisj = solve(R.FOURBAR_SISJ_YAML, "crank-rocker-sisj", steps=240)
    assert_same(at, sisj)
    cf = R.fourbar_closed_form(at.t, R.uniform(R.TWO_PI, 0.7), frames="mid")
    compare(at, cf)
    compare(sisj, cf)


# == 7. invariants =================================================================================

def _slider_crank_joints(res):
    a, b, e = (R.SLIDER_CRANK[k] for k in "abe")
    A_crank = rigid(res, "crank", (a, 0.0))
    A_rod = rigid(res, "rod", (0.0, 0.0))
    B_rod = rigid(res, "rod", (b, 0.0))
    B_slider = rigid(res, "slider", (0.0, 0.0))
    return a, b, e, A_crank, A_rod, B_rod, B_slider


@pytest.mark.parametrize("driver", sorted(SLIDER_DRIVERS))
def test_slider_crank_loop_closure(driver):
    res = solve(R.slider_crank_yaml(SLIDER_DRIVERS[driver][0]), "offset-slider-crank", steps=200)
    a, b, e, A_crank, A_rod, B_rod, B_slider = _slider_crank_joints(res)
    for k, name in enumerate("PVA"):      # the pins coincide in position, velocity, acceleration
        scale = np.abs(B_slider[k]).max()
        assert max_rel(A_crank[k] - A_rod[k], scale) <= TOL_CLOSURE, name
        assert max_rel(B_rod[k] - B_slider[k], scale) <= TOL_CLOSURE, name
    crank, slider = res.body("crank"), res.body("slider")
    assert max_rel(np.hypot(crank["x"], crank["y"]), a) <= TOL_CLOSURE          # main bearing O
    assert max_rel(slider["y"] - e, b) <= TOL_CLOSURE                            # slider axis
    assert max_rel(slider["phi"], 1.0) <= TOL_CLOSURE
    # link lengths: |B - A| = b with A from the crank and B from the slider; the rod point P
    # keeps its distances to both pins
    AB = B_slider[0] - A_crank[0]
    assert max_rel(np.hypot(*AB.T) - b, b) <= TOL_CLOSURE
    P = xy(res.point("P"))
    sP = np.array(R.SLIDER_CRANK["P"])
    assert max_rel(np.hypot(*(P - A_crank[0]).T) - np.hypot(*sP), b) <= TOL_CLOSURE
    assert max_rel(np.hypot(*(P - B_slider[0]).T) - np.hypot(*(sP - [b, 0])), b) <= TOL_CLOSURE


def test_crank_rocker_loop_closure():
    res = solve(R.FOURBAR_DEG_YAML, "crank-rocker-deg", steps=360)
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    A_crank = rigid(res, "crank", (a, 0.0), degrees=True)
    A_coupler = rigid(res, "coupler", (0.0, 0.0), degrees=True)
    B_coupler = rigid(res, "coupler", (b, 0.0), degrees=True)
    B_rocker = rigid(res, "rocker", (c, 0.0), degrees=True)
    O4 = rigid(res, "rocker", (0.0, 0.0), degrees=True)
    for k, name in enumerate("PVA"):
        scale = np.abs(B_rocker[k]).max()
        assert max_rel(A_crank[k] - A_coupler[k], scale) <= TOL_CLOSURE, name
        assert max_rel(B_coupler[k] - B_rocker[k], scale) <= TOL_CLOSURE, name
        assert max_rel(O4[k] - ([d, 0.0] if k == 0 else 0.0), scale) <= TOL_CLOSURE, name
    AB = B_rocker[0] - A_crank[0]
    assert max_rel(np.hypot(*AB.T) - b, d) <= TOL_CLOSURE
    assert max_rel(np.hypot(*(B_rocker[0] - [d, 0.0]).T) - c, d) <= TOL_CLOSURE
    crank = res.body("crank")
    assert max_rel(np.hypot(crank["x"], crank["y"]), d) <= TOL_CLOSURE
    P = xy(res.point("P"))
    sP = np.array(R.FOURBAR["P"])
    assert max_rel(np.hypot(*(P - A_crank[0]).T) - np.hypot(*sP), d) <= TOL_CLOSURE
    assert max_rel(np.hypot(*(P - B_rocker[0]).T) - np.hypot(*(sP - [b, 0])), d) <= TOL_CLOSURE


FD_CASES = {
    "slider-crank-uniform": lambda: R.slider_crank_yaml(SLIDER_DRIVERS["uniform"][0]),
    "slider-crank-wobbly": lambda: R.slider_crank_yaml(SLIDER_DRIVERS["wobbly"][0]),
    "crank-rocker-deg": lambda: R.FOURBAR_DEG_YAML,
}


@pytest.mark.parametrize("case", sorted(FD_CASES))
def test_derivatives_against_central_differences(case):
    steps = 1200
    res = solve(FD_CASES[case](), case, steps=steps)
    h = (res.t[-1] - res.t[0]) / steps
    k = len(D1) // 2
    for pos, vel, acc in ((res.q, res.qd, res.qdd), (res.p, res.pd, res.pdd)):
        dv = central(pos, h, D1)
        da = central(pos, h, D2)
        dav = central(vel, h, D1)
        for name, got, ref in (("velocity", vel[k:-k], dv), ("acceleration", acc[k:-k], da),
                               ("acceleration (from velocities)", acc[k:-k], dav)):
            scale = np.abs(got).reshape(len(got), -1).max(axis=0)
            err = np.abs(got - ref).reshape(len(got), -1).max(axis=0)
            used = scale > 0
            rel = (err[used] / scale[used]).max()
            assert rel <= TOL_FD, f"{case} {name}: {rel:.3g}"


@pytest.mark.parametrize("driver", sorted(SLIDER_DRIVERS))
def test_slider_crank_grid_independence(driver):
    f, theta = SLIDER_DRIVERS[driver]
    text = R.slider_crank_yaml(f)
    runs = {n: solve(text, "offset-slider-crank", steps=n) for n in (7, 36, 360)}
    for n1, n2 in ((7, 36), (7, 360), (36, 360)):
        r1, r2 = runs[n1], runs[n2]
        i1, i2 = np.nonzero(np.abs(r1.t[:, None] - r2.t[None, :]) <= 1e-13)
        assert len(i1) == math.gcd(n1, n2) + 1
        assert_same(r1, r2, rows1=i1, rows2=i2)
    # the coarsest grid is as exact as the fine one
    compare(runs[7], R.slider_crank_closed_form(runs[7].t, theta))
