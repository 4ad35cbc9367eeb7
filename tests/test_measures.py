"""Measures against closed forms derived here, independently of planarkin/measures: a crank-rocker
four-bar and an offset slider-crank (tests/reference_models.py), driven by a non-uniform crank
(theta = 2 pi t + 0.3 sin 2 pi t) so that every acceleration term counts."""

import math

import numpy as np
import pytest

import planarkin
from planarkin.diagnostics import InputError

import reference_models as R
from closedforms import four_bar, slider_crank

WOBBLY_DEG = "360*t + 0.3*180/pi*sin(2*pi*t)"
TOL = 1e-12


def _close(got, want, scale=None):
    scale = scale if scale is not None else max(np.max(np.abs(want)), 1.0)
    err = np.max(np.abs(np.asarray(got) - np.asarray(want))) / scale
    assert err < TOL, err
    return err


def _angle_close(got, want_deg):
    d = (np.asarray(got) - want_deg + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(d)) / 180.0 < TOL


FOURBAR_MEASURES = """
  O2: {body: crank, s: [0, 0]}
  A: {body: crank, s: [a, 0]}
  B: {body: rocker, s: [c, 0]}
  O4: {body: rocker, s: [0, 0]}
measures:
  reach: {distance: [O2, B]}
  crank: {angle: crank}
  rocker: {angle: rocker}
  coupler: {angle: [A, B]}
  knee: {between: [coupler, rocker]}
  pinB: {joint: B}
  mu: {transmission: [A, B, O4]}
  vr: {ratio: [crank, rocker]}
  ma: {advantage: [crank, rocker]}
"""


@pytest.fixture(scope="module")
def fourbar():
    text = R.FOURBAR_DEG_YAML.replace('f: "360*t"', f'f: "{WOBBLY_DEG}"')
    text = text.replace("- {type: revolute, i: coupler, j: rocker",
                        "- {type: revolute, name: B, i: coupler, j: rocker")
    text = text.replace("points:\n", "points:" + FOURBAR_MEASURES.split("measures:")[0], 1)
    text = text.replace("analysis:", "measures:" + FOURBAR_MEASURES.split("measures:")[1]
                        + "analysis:")
    res = planarkin.solve(planarkin.load("fourbar.yaml", text=text), steps=180)
    assert res.success
    return res, res.table("measures.csv")


def _fourbar_cf(t):
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    th, thd, thdd = R.wobbly(t)
    th3, w3, al3, th4, w4, al4 = four_bar(th, thd, thdd, a, b, c, d)
    return a, b, c, d, th, thd, thdd, th3, w3, al3, th4, w4, al4


def test_fourbar_distance_to_rocker_pin(fourbar):
    res, M = fourbar
    a, b, c, d, th, thd, thdd, th3, w3, al3, th4, w4, al4 = _fourbar_cf(res.t)
    # |O2 B|^2 = d^2 + c^2 + 2 d c cos th4 (B = O4 + c e(th4))
    D = np.sqrt(d * d + c * c + 2 * d * c * np.cos(th4))
    D1 = -d * c * np.sin(th4) * w4 / D
    D2 = (-d * c * np.cos(th4) * w4 ** 2 - d * c * np.sin(th4) * al4 - D1 ** 2) / D
    _close(M["reach"], D)
    _close(M["reach.rate"], D1)
    _close(M["reach.accel"], D2)


def test_fourbar_link_and_line_angles(fourbar):
    res, M = fourbar
    a, b, c, d, th, thd, thdd, th3, w3, al3, th4, w4, al4 = _fourbar_cf(res.t)
    deg = np.degrees
    _angle_close(M["rocker"], deg(th4))
    _close(M["rocker.rate"], deg(w4))
    _close(M["rocker.accel"], deg(al4))
    _angle_close(M["coupler"], deg(th3))        # the line A -> B is the coupler's direction
    assert np.all(M["coupler"] > -180) and np.all(M["coupler"] <= 180)
    _close(M["coupler.rate"], deg(w3))
    _close(M["coupler.accel"], deg(al3))
    for name in ("knee", "pinB"):               # rocker relative to coupler, both ways
        _angle_close(M[name], deg(th4 - th3))
        _close(M[name + ".rate"], deg(w4 - w3))
        _close(M[name + ".accel"], deg(al4 - al3))


def test_fourbar_transmission_angle(fourbar):
    res, M = fourbar
    a, b, c, d, th, thd, thdd, *_ = _fourbar_cf(res.t)
    # law of cosines in triangle A-B-O4 with z = |A O4|^2 = a^2 + d^2 - 2 a d cos th:
    # cos mu = (b^2 + c^2 - z) / (2 b c); differentiated: mu' = z' / (2 b c sin mu),
    # cos mu mu'^2 + sin mu mu'' = z'' / (2 b c)
    z = a * a + d * d - 2 * a * d * np.cos(th)
    z1 = 2 * a * d * np.sin(th) * thd
    z2 = 2 * a * d * (np.cos(th) * thd ** 2 + np.sin(th) * thdd)
    mu = np.arccos((b * b + c * c - z) / (2 * b * c))
    mu1 = z1 / (2 * b * c * np.sin(mu))
    mu2 = (z2 / (2 * b * c) - np.cos(mu) * mu1 ** 2) / np.sin(mu)
    _close(M["mu"], np.degrees(mu))
    _close(M["mu.rate"], np.degrees(mu1))
    _close(M["mu.accel"], np.degrees(mu2))


def test_fourbar_velocity_ratio_and_advantage(fourbar):
    res, M = fourbar
    *_, th, thd, thdd, th3, w3, al3, th4, w4, al4 = _fourbar_cf(res.t)
    _close(M["vr"], w4 / thd)
    _close(M["vr.rate"], (al4 * thd - w4 * thdd) / thd ** 2)
    _close(M["ma"], thd / w4, scale=np.max(np.abs(thd / w4)))
    assert "vr.accel" not in M and "ma.accel" not in M


def test_fourbar_cycle_figures(tmp_path):
    # uniform crank: the rocker's limit positions are where crank and coupler are collinear,
    # |O4 A| = b -/+ a... i.e. |O2 B| = b - a and b + a; time ratio from those crank angles
    text = R.FOURBAR_DEG_YAML.replace("points:\n", "points:" +
                                      FOURBAR_MEASURES.split("measures:")[0], 1)
    text = text.replace("analysis:", "measures:\n  rocker: {angle: rocker}\n"
                                     "  reach: {distance: [O2, B]}\n"
                                     "  mu: {transmission: [A, B, O4]}\nanalysis:")
    res = planarkin.solve(planarkin.load("fb.yaml", text=text), steps=720)
    s = res.write(tmp_path / "out", plots=None)
    cyc = s["cycle"]["measures"]
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    assert abs(cyc["reach"]["min"]["refined"]["value"] - (b - a)) < 1e-7
    assert abs(cyc["reach"]["max"]["refined"]["value"] - (b + a)) < 1e-7
    # crank angles at the limit positions (law of cosines in triangle O2-O4-B, |O2 B| = b -/+ a)
    def crank_at(r, outer):
        th4 = math.acos((r * r - d * d - c * c) / (2 * d * c))
        Bx, By = d + c * math.cos(th4), c * math.sin(th4)
        return math.degrees(math.atan2(By, Bx)) + (180.0 if not outer else 0.0)
    th_out, th_in = crank_at(b + a, True), crank_at(b - a, False)
    adv = ((th_in - th_out) % 360) / 360.0
    want = max(adv, 1 - adv) / min(adv, 1 - adv)
    assert abs(cyc["rocker"]["time_ratio"] - want) < 1e-5
    assert abs(cyc["reach"]["max"]["refined"]["driver"] - th_out) < 1e-3
    mu_min = math.degrees(math.acos((b * b + c * c - (d - a) ** 2) / (2 * b * c)))
    assert abs(cyc["mu"]["transmission_min"]["value"] - mu_min) < 1e-6


SLIDER_MEASURES_POINTS = """
  A: {body: rod, s: [0, 0]}
  B: {body: rod, s: [b, 0]}
  O: {body: crank, s: [0, 0]}
"""


@pytest.fixture(scope="module")
def slider():
    text = R.slider_crank_yaml("2*pi*t + 0.3*sin(2*pi*t)")
    text = text.replace("- {type: translational, i: ground", "- {type: translational, name: "
                                                               "piston, i: ground")
    text = text.replace("points:\n", "points:" + SLIDER_MEASURES_POINTS, 1)
    text = text.replace("analysis:", "measures:\n  stroke: {joint: piston}\n"
                                     "  psi: {transmission: [A, B], guide: piston}\n"
                                     "  OB: {distance: [O, B]}\n  crank: {angle: crank}\n"
                                     "  vr: {ratio: [crank, stroke]}\nanalysis:")
    res = planarkin.solve(planarkin.load("sc.yaml", text=text), steps=200)
    assert res.success
    return res, res.table("measures.csv")


def _slider_cf(t):
    a, b, e = (R.SLIDER_CRANK[k] for k in "abe")
    th, thd, thdd = R.wobbly(t)
    return (a, b, e, th, thd, thdd) + slider_crank(th, thd, thdd, a, b, e)


def test_slider_displacement_and_distance(slider):
    res, M = slider
    a, b, e, th, thd, thdd, be, bed, bedd, xB, xBd, xBdd = _slider_cf(res.t)
    # the slide measured from the axis point (0, e) on ground to the slider's origin B
    _close(M["stroke"], xB)
    _close(M["stroke.rate"], xBd)
    _close(M["stroke.accel"], xBdd)
    D = np.hypot(xB, e)
    _close(M["OB"], D)
    _close(M["OB.rate"], xB * xBd / D)
    _close(M["OB.accel"], (xBd ** 2 + xB * xBdd) / D - (xB * xBd) ** 2 / D ** 3)
    _close(M["vr"], xBd / thd)
    _close(M["vr.rate"], (xBdd * thd - xBd * thdd) / thd ** 2)


def test_slider_rod_guide_angle(slider):
    res, M = slider
    *_, be, bed, bedd, xB, xBd, xBdd = _slider_cf(res.t)
    # the rod A -> B makes the angle be with the horizontal guide; the acute angle is |be|
    # (this model is in radians)
    s = np.sign(be)
    _close(M["psi"], np.abs(be))
    _close(M["psi.rate"], s * bed)
    _close(M["psi.accel"], s * bedd)


def test_measure_errors_are_file_line_diagnostics():
    text = R.FOURBAR_DEG_YAML.replace("analysis:", """measures:
  m1: {distance: [P, Q]}
  m2: {angle: rockr}
  m3: {transmission: [P, P, P]}
  m4: {ratio: [m2, nothing]}
  m5: {joint: B}
  m6: {distanc: [P, P]}
  m7: {ratio: [m2, m1]}
analysis:""")
    with pytest.raises(InputError) as e:
        planarkin.load("m.yaml", text=text)
    got = [d.format() for d in e.value.diagnostics]
    assert got == [
        "m.yaml:26: error: measure 'm1': unknown point 'Q' (points: P)",
        "m.yaml:27: error: measure 'm2': unknown link 'rockr'; did you mean 'rocker'?",
        "m.yaml:28: error: measure 'm3': the points must differ",
        "m.yaml:29: error: measure 'm4': unknown measure 'nothing' (measures: m1, m2, m3)",
        "m.yaml:30: error: measure 'm5': unknown joint 'B' (joints: none defined)",
        "m.yaml:31: error: measure 'm6': unknown key 'distanc'; did you mean 'distance'?",
    ]


@pytest.mark.parametrize("lengths,kind,crank", [
    ((0.10, 0.04, 0.12, 0.10), "crank-rocker", "crank"),    # shortest next to ground
    ((0.04, 0.10, 0.12, 0.10), "double-crank", None),       # shortest is the ground
    ((0.10, 0.12, 0.04, 0.10), "double-rocker", None),      # shortest is the coupler
    ((0.10, 0.04, 0.14, 0.08), "change point", None),       # 0.04 + 0.14 = 0.10 + 0.08
    ((0.10, 0.07, 0.12, 0.03 + 0.2), "triple-rocker", None),
])
def test_grashof_classification(lengths, kind, crank):
    from planarkin.measures.grashof import _classify
    loop = _classify(("ground", "crank", "coupler", "rocker"), lengths)
    assert loop.kind == kind and loop.crank == crank


def test_check_prints_grashof_and_run_reports_cycle(tmp_path):
    from clitools import run_cli
    r = run_cli("check", "mechanisms/four-bar.yaml")
    assert ("four-bar loop ground-crank-coupler-rocker: crank-rocker (crank turns fully); "
            "s + l = 0.16 < p + q = 0.2 m (ground 0.1, crank 0.04, coupler 0.12, rocker 0.1)"
            in r.stdout)
    model = tmp_path / "fb.yaml"
    model.write_text((ROOT_FB := R.FOURBAR_DEG_YAML).replace(
        "points:\n", "points:" + FOURBAR_MEASURES.split("measures:")[0], 1).replace(
        "analysis:", "measures:\n  reach: {distance: [O2, B]}\nanalysis:"))
    r = run_cli("run", str(model), "--out", str(tmp_path / "out"), "--no-plots",
                "--report", "cycle")
    assert r.returncode == 0, r.stderr
    a, b = R.FOURBAR["a"], R.FOURBAR["b"]
    line = next(x for x in r.stdout.split("\n") if x.strip().startswith("reach:"))
    assert line.strip().startswith(f"reach: min {b - a:.6g} m at t = ")
    assert f"max {b + a:.6g} m at t = " in line and "time ratio" in line
    del ROOT_FB


def test_lower_orders_write_what_they_can(fourbar):
    res, M = fourbar
    text = R.FOURBAR_DEG_YAML.replace('f: "360*t"', f'f: "{WOBBLY_DEG}"')
    text = text.replace("- {type: revolute, i: coupler, j: rocker",
                        "- {type: revolute, name: B, i: coupler, j: rocker")
    text = text.replace("points:\n", "points:" + FOURBAR_MEASURES.split("measures:")[0], 1)
    text = text.replace("analysis:", "measures:" + FOURBAR_MEASURES.split("measures:")[1]
                        + "analysis:")
    m = planarkin.load("fourbar.yaml", text=text)
    for order, want in ((1, {"reach", "reach.rate", "vr", "ma"}), (0, {"reach", "mu"})):
        lo = planarkin.solve(m, steps=180, up_to=("position", "velocity")[order]).table("measures.csv")
        assert want <= set(lo) and "reach.accel" not in lo
        assert (order == 1) == ("vr" in lo) and "vr.rate" not in lo
        for k in lo:
            if k != "t":
                assert np.array_equal(lo[k], M[k], equal_nan=True), k


# -- jerk (up_to: jerk): every measure's third derivative, a ratio's second -----------------------

def _d6(a, h):
    """Sixth-order central difference of a column over a uniform grid (rows 3 .. N-4)."""
    return (a[6:] - 9 * a[5:-1] + 45 * a[4:-2] - 45 * a[2:-4] + 9 * a[1:-5] - a[:-6]) / (60 * h)


def _jerk_run(text, name):
    res = planarkin.solve(planarkin.load(name, text=text), steps=1500, up_to="jerk")
    assert res.success
    return res, res.table("measures.csv")


def _fourbar_text():
    text = R.FOURBAR_DEG_YAML.replace('f: "360*t"', f'f: "{WOBBLY_DEG}"')
    text = text.replace("- {type: revolute, i: coupler, j: rocker",
                        "- {type: revolute, name: B, i: coupler, j: rocker")
    text = text.replace("points:\n", "points:" + FOURBAR_MEASURES.split("measures:")[0], 1)
    return text.replace("analysis:", "measures:" + FOURBAR_MEASURES.split("measures:")[1]
                        + "analysis:")


@pytest.mark.parametrize("which", ["four-bar", "slider-crank"])
def test_measure_jerks_are_the_derivatives_of_their_exact_accelerations(which):
    # each .jerk column (and a ratio's .accel) against a sixth-order difference of the exact
    # column below it over a fine grid: independent of the chain-rule formulas. (The advantage
    # ma = 1 / vr, the same formula with the measures swapped, is infinite at the rocker's
    # dead points, where a difference quotient means nothing: vr stands for both.)
    if which == "four-bar":
        res, M = _jerk_run(_fourbar_text(), "fb.yaml")
        names = ["reach", "crank", "rocker", "coupler", "knee", "pinB", "mu"]
        ratios = ["vr"]
    else:
        text = R.slider_crank_yaml("2*pi*t + 0.3*sin(2*pi*t)").replace(
            "- {type: translational, i: ground", "- {type: translational, name: piston, "
                                                 "i: ground").replace(
            "points:\n", "points:" + SLIDER_MEASURES_POINTS, 1).replace(
            "analysis:", "measures:\n  stroke: {joint: piston}\n"
                         "  psi: {transmission: [A, B], guide: piston}\n"
                         "  OB: {distance: [O, B]}\n  crank: {angle: crank}\n"
                         "  vr: {ratio: [crank, stroke]}\nanalysis:")
        res, M = _jerk_run(text, "sc.yaml")
        names = ["stroke", "psi", "OB", "crank"]
        ratios = ["vr"]
    h = res.t[1] - res.t[0]
    for n in names:
        scale = np.abs(M[n + ".jerk"]).max()
        assert scale > 0, n
        # unsigned angles (psi, mu) have a kink where they touch 0: rows whose difference
        # stencil spans one are left out
        v = np.abs(M[n])
        away = np.min([v[k:len(v) - 6 + k] for k in range(7)], axis=0) > 1e-3 * v.max()
        err = np.abs(M[n + ".jerk"][3:-3] - _d6(M[n + ".accel"], h))[away].max() / scale
        assert err < 1e-8 and away.mean() > 0.9, (n, err, away.mean())
    for n in ratios:
        assert n + ".jerk" not in M
        a = M[n + ".accel"]
        err = np.abs(a[3:-3] - _d6(M[n + ".rate"], h)).max() / np.abs(a).max()
        assert err < 1e-8, (n, err)


def test_measure_jerks_against_closed_forms():
    # the crank: theta''' of theta = 2 pi t + 0.3 sin 2 pi t; the rocker and the knee: the
    # body jerks (checked against closed forms in test_jerk.py); a ratio's acceleration from the
    # closed-form rocker derivatives
    res, M = _jerk_run(_fourbar_text(), "fb.yaml")
    w = 2 * np.pi
    _close(M["crank.jerk"], np.degrees(-0.3 * w ** 3 * np.cos(w * res.t)))
    rocker, coupler = res.body("rocker"), res.body("coupler")
    _close(M["rocker.jerk"], rocker["jphi"])
    _close(M["knee.jerk"], rocker["jphi"] - coupler["jphi"])
    th, thd, thdd = R.wobbly(res.t)
    th3 = -0.3 * w ** 3 * np.cos(w * res.t)
    w4, al4, j4 = (np.radians(rocker[k]) for k in ("omega", "alpha", "jphi"))
    n1 = al4 * thd - w4 * thdd
    _close(M["vr.accel"], (j4 * thd - w4 * th3) / thd ** 2 - 2 * n1 * thdd / thd ** 3)
    assert "ma.accel" in M and "ma.jerk" not in M


def test_measures_csv_names_the_jerk_columns(tmp_path):
    res = planarkin.solve(planarkin.load("fb.yaml", text=_fourbar_text()), steps=60,
                          up_to="jerk")
    res.write(tmp_path / "out", plots=None)
    csv = next((tmp_path / "out").rglob("measures.csv"))
    header = csv.read_text().splitlines()[0].split(",")
    assert "reach.jerk [m/s^3]" in header and "mu.jerk [deg/s^3]" in header
    assert "vr.accel [1/s^2]" in header and not any(h.startswith("vr.jerk") for h in header)
    assert header.index("reach.jerk [m/s^3]") == header.index("reach.accel [m/s^2]") + 1
