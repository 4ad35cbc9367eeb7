"""Issue 31 item 3: every run reports the transmission angle and the velocity ratio (mechanical
advantage) of every four-bar and slider-crank loop in summary.json's `loops`, and warns of a
passage near a toggle (planarkin.measures.loops), without a `measures:` block.

Closed forms (independent of planarkin's code):
* a four-bar with the driven link a pivoted at A, the coupler b, the output c pivoted at D: the
  angle at the coupler-output pin follows from the triangle of b, c and the distance from the
  driven link's pin to D (law of cosines), and the output's angular speed per the input's from
  the rigid coupler, (v_C - v_B).(C - B) = 0, with the positions solved in closed form;
* a rocker-driven treadle (the rocker c, pivot D at distance g from the crank's pivot A) sees
  its crank a and coupler b fold in line when |A C| = b - a; with the rocker at psi, |A C|^2 =
  g^2 + c^2 + 2 g c cos(psi), so the angle at the crank-coupler pin is mu = 2 asin(sqrt((|A C|^2 -
  (b - a)^2) / (4 a b))), evaluated in 40-digit arithmetic (mpmath) from the model's numbers;
* a centred slider-crank (crank a, rod b, crank angle theta): the rod leans by asin(a sin(theta)
  / b) from the guide, the slider sits at x = a cos(theta) + sqrt(b^2 - a^2 sin^2(theta)) and
  moves at dx/dtheta = -a sin(theta) x / (x - a cos(theta)) per unit crank speed.
"""

import json
import math

import mpmath
import pytest
from clitools import ROOT, run_cli
from scipy.optimize import minimize_scalar

from planarkin.measures.loops import RATIO_LIMIT, TOGGLE_MARGIN_DEG

DEG = 180 / math.pi


def _run(tmp_path, text=None, path=None, name="model"):
    if path is None:
        path = tmp_path / f"{name}.yaml"
        path.write_text(text)
    r = run_cli("run", path, "--out", tmp_path / "out", "--no-plots")
    s = json.loads((tmp_path / "out" / path.stem / "summary.json").read_text())
    return r, s


def _circles(p, r1, q, r2, upper=True):
    """The intersection of circle (p, r1) and circle (q, r2), left of p -> q when upper."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = math.hypot(dx, dy)
    x = (d * d + r1 * r1 - r2 * r2) / (2 * d)
    h = math.sqrt(r1 * r1 - x * x)
    s = 1 if upper else -1
    return (p[0] + (x * dx - s * h * dy) / d, p[1] + (x * dy + s * h * dx) / d)


# -- the treadle: a crank-rocker driven by its rocker to 0.0026 deg of its toggle ----------------

A_, B_, C_, G_ = 0.3, 0.5, 0.4, 0.45     # crank, coupler, rocker, ground (Grashof: crank-rocker)
DELTA = 0.0026                            # deg: the crank and coupler's closest approach to line
SWING = 0.2                               # rad: the rocker's swing back from its turning point


def _treadle():
    """The rocker driven as psi(t) = psi_t - SWING (1 + cos(2 pi t)): it turns back at psi_t
    (t = 0.5), where |A C| = sqrt((b - a)^2 + 4 a b sin^2(DELTA / 2)), the crank-coupler angle
    DELTA; radians, so that the driver's value is the model's own number."""
    a, b, c, g = A_, B_, C_, G_
    ac2 = (b - a) ** 2 + 4 * a * b * math.sin(math.radians(DELTA) / 2) ** 2
    psi_t = math.acos((ac2 - g * g - c * c) / (2 * g * c))
    psi0 = psi_t - 2 * SWING
    C = (g + c * math.cos(psi0), c * math.sin(psi0))
    B = _circles((0.0, 0.0), a, C, b, upper=True)
    text = f"""\
name: treadle
units: {{length: m, angle: rad}}
points:
  A: {{at: [0, 0], ground: true}}
  D: {{at: [{g!r}, 0], ground: true}}
  B: {{at: [{B[0]!r}, {B[1]!r}]}}
  C: {{at: [{C[0]!r}, {C[1]!r}]}}
links:
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {{type: angle, link: rocker, f: "{psi_t!r} - {SWING!r}*(1 + cos(2*pi*t))"}}
analysis: {{start: 0, end: 1, steps: 360}}
"""
    return text, psi_t


def _treadle_closed_form(psi_t):
    """mu at the turning point (deg) and |crank' / rocker'| there, in 40 digits."""
    mpmath.mp.dps = 40
    a, b, c, g = (mpmath.mpf(x) for x in (A_, B_, C_, G_))
    psi = mpmath.mpf(psi_t)
    C = (g + c * mpmath.cos(psi), c * mpmath.sin(psi))
    ac2 = C[0] ** 2 + C[1] ** 2
    mu = 2 * mpmath.asin(mpmath.sqrt((ac2 - (b - a) ** 2) / (4 * a * b)))
    # the crank pin B: on the crank's circle at angle mu from the line A -> C's far side
    d = mpmath.sqrt(ac2)
    x = (ac2 + a * a - b * b) / (2 * d)
    h = mpmath.sqrt(a * a - x * x)
    B = ((x * C[0] - h * C[1]) / d, (x * C[1] + h * C[0]) / d)
    cross = lambda u, w: u[0] * w[1] - u[1] * w[0]
    CB = (C[0] - B[0], C[1] - B[1])
    # omega_crank (B x CB) = omega_rocker ((C - D) x CB): the coupler is rigid
    ratio = abs(cross((C[0] - g, C[1]), CB) / cross(B, CB))
    return float(mu * 180 / mpmath.pi), float(ratio)


def test_a_treadle_passing_near_its_toggle_warns_with_the_closed_form_angle(tmp_path):
    text, psi_t = _treadle()
    r, s = _run(tmp_path, text, name="treadle")
    assert r.returncode == 0, r.stderr
    mu_cf, ratio_cf = _treadle_closed_form(psi_t)
    assert abs(mu_cf - DELTA) < 1e-9            # the construction's own rounding
    (lp,) = s["loops"]
    assert (lp["kind"], lp["loop"], lp["class"]) == ("four-bar", "ground-crank-coupler-rocker",
                                                    "crank-rocker")
    assert (lp["input"], lp["output"], lp["input_from"]) == ("rocker", "crank", "driver")
    ta = lp["transmission_angle"]
    assert ta["unit"] == "rad" and "crank-coupler pin" in ta["where"]
    assert abs(ta["min"]["value"] * DEG - mu_cf) < 1e-9
    assert abs(ta["min"]["value"] * DEG - DELTA) < 1e-9
    assert abs(ta["min"]["t"] - 0.5) < 1e-9 and ta["min"]["found"] == "turning point"
    vr = lp["velocity_ratio"]["max"]
    assert abs(vr["value"] - ratio_cf) < 1e-7 * ratio_cf       # ~1/mu: rounding / mu
    assert abs(vr["t"] - 0.5) < 1e-9
    assert lp["mechanical_advantage"]["min"]["value"] == pytest.approx(1 / vr["value"],
                                                                       rel=1e-15)
    assert lp["near_toggle"] is True and ta["poor"] is True
    # the warning: on the terminal and in summary.json, once
    toggles = [w for w in s["warnings"] if w["kind"] == "toggle"]
    assert len(toggles) == 1
    msg = toggles[0]["message"]
    assert msg.startswith("four-bar loop ground-crank-coupler-rocker (rocker driving crank): "
                          "passes near a toggle: the transmission angle at the crank-coupler "
                          "pin, between coupler and crank comes down to 4.538e-05 rad "
                          "(0.0026 deg) at t = 0.5 s")
    assert f"reaches {ratio_cf:.4g} (mechanical advantage" in msg
    assert f"within {TOGGLE_MARGIN_DEG:g} deg of 0 or 180 deg" in msg
    assert f"above {RATIO_LIMIT:g}" in msg
    assert abs(toggles[0]["t"] - 0.5) < 1e-9
    assert r.stderr.count(f"treadle.yaml: warning: {msg}") == 1


TREADLE_DEG = """\
name: treadle
units: {length: m, angle: deg}
bodies:
  crank:   {q: [0, 0, 162]}
  coupler: {q: [-0.29, 0.09, 23]}
  rocker:  {q: [0.45, 0, 134]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: coupler, si: [0.3, 0], sj: [0, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [0.5, 0], sj: [0.4, 0]}
  - {type: revolute, i: ground, j: rocker, si: [0.45, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: rocker, f: "153.61 - 10*(1 + cos(2*pi*t))"}
analysis: {start: 0, end: 1, steps: 360}
"""


def test_a_toggle_passage_the_condition_estimate_misses_is_warned(tmp_path):
    """The report's case: 0.59 deg from the toggle the condition estimate stays below the
    near-singular limit (1e3), so the run used to say ok with no warning."""
    r, s = _run(tmp_path, TREADLE_DEG, name="treadle")
    assert r.returncode == 0, r.stderr
    assert s["condition"]["max"] < 1e3
    assert [w["kind"] for w in s["warnings"]] == ["toggle"]
    mpmath.mp.dps = 40
    a, b, c, g = (mpmath.mpf(x) for x in ("0.3", "0.5", "0.4", "0.45"))
    ac2 = g * g + c * c + 2 * g * c * mpmath.cos(mpmath.mpf("153.61") * mpmath.pi / 180)
    mu = 2 * mpmath.asin(mpmath.sqrt((ac2 - (b - a) ** 2) / (4 * a * b))) * 180 / mpmath.pi
    ta = s["loops"][0]["transmission_angle"]
    assert abs(ta["min"]["value"] - float(mu)) < 1e-9 and abs(ta["min"]["t"] - 0.5) < 1e-9
    assert f"comes down to {float(mu):.4g} deg at t = 0.5 s" in s["warnings"][0]["message"]
    assert f"treadle.yaml: warning: {s['warnings'][0]['message']}" in r.stderr


# -- the ordinary examples: figures in closed form, no warning -----------------------------------

def test_four_bar_example_figures_in_closed_form_and_no_warning(tmp_path):
    r, s = _run(tmp_path, path=ROOT / "mechanisms" / "four-bar.yaml")
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    assert not [w for w in s["warnings"] if w["kind"] == "toggle"]
    a, b, c, d = 0.04, 0.12, 0.10, 0.10
    (lp,) = s["loops"]
    assert (lp["input"], lp["output"], lp["near_toggle"]) == ("crank", "rocker", False)
    ta = lp["transmission_angle"]
    # the angle at C: |B D| runs from d - a (crank towards D, t = 0) to d + a (t = 0.5)
    lo = math.degrees(math.acos((b * b + c * c - (d - a) ** 2) / (2 * b * c)))
    hi = math.degrees(math.acos((b * b + c * c - (d + a) ** 2) / (2 * b * c)))
    assert abs(ta["min"]["value"] - lo) < 1e-9 and ta["min"]["t"] == 0.0
    assert abs(ta["max"]["value"] - hi) < 1e-9 and abs(ta["max"]["t"] - 0.5) < 1e-9
    assert ta["poor"] is True and ta["unit"] == "deg"         # 29.9 deg: below 40, no warning

    def ratio(theta):
        """omega_rocker / omega_crank at crank angle theta (rad), the open branch."""
        B = (a * math.cos(theta), a * math.sin(theta))
        C = _circles(B, b, (d, 0.0), c, upper=True)     # four-bar.yaml's branch: C above
        CB = (C[0] - B[0], C[1] - B[1])
        return ((B[0] * CB[1] - B[1] * CB[0])
                / ((C[0] - d) * CB[1] - C[1] * CB[0]))
    th0 = max((2 * math.pi * k / 3600 for k in range(3600)), key=lambda th: abs(ratio(th)))
    best = minimize_scalar(lambda th: -abs(ratio(th)), bounds=(th0 - 0.01, th0 + 0.01),
                           method="bounded", options={"xatol": 1e-12})
    vr = lp["velocity_ratio"]["max"]
    assert abs(vr["value"] - abs(ratio(best.x))) < 1e-9
    assert abs(vr["t"] - best.x / (2 * math.pi)) < 1e-6


def test_slider_crank_example_figures_in_closed_form_and_no_warning(tmp_path):
    r, s = _run(tmp_path, path=ROOT / "mechanisms" / "slider-crank.yaml")
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    assert not [w for w in s["warnings"] if w["kind"] == "toggle"]
    a, b = 0.1, 0.3
    (lp,) = s["loops"]
    assert (lp["kind"], lp["loop"], lp["class"]) == ("slider-crank", "ground-crank-rod-slider",
                                                    "crank turns fully")
    assert (lp["input"], lp["output"], lp["near_toggle"]) == ("crank", "slider", False)
    assert lp["lengths"] == {"crank": pytest.approx(a, rel=1e-15),
                             "rod": pytest.approx(b, rel=1e-15), "offset": 0.0, "unit": "m"}
    ta = lp["transmission_angle"]
    # between the rod and the guide's normal: 90 deg - the rod's lean asin(a sin(theta) / b)
    assert abs(ta["min"]["value"] - (math.pi / 2 - math.asin(a / b))) < 1e-12
    assert abs(ta["min"]["t"] - 0.25) < 1e-9          # theta = 90 deg (or 270: t = 0.75)
    assert ta["max"]["value"] == pytest.approx(math.pi / 2, abs=1e-15)
    assert ta["poor"] is False

    def speed(theta):
        x = a * math.cos(theta) + math.sqrt(b * b - (a * math.sin(theta)) ** 2)
        return abs(-math.sin(theta) * x / (x - a * math.cos(theta)))   # per a omega
    best = minimize_scalar(lambda th: -speed(th), bounds=(0.5, 2.0), method="bounded",
                           options={"xatol": 1e-12})
    vr = lp["velocity_ratio"]["max"]
    assert abs(vr["value"] - speed(best.x)) < 1e-12
    # the same peak at theta and 360 deg - theta
    assert min(abs(vr["t"] - best.x / (2 * math.pi)),
               abs(vr["t"] - (1 - best.x / (2 * math.pi)))) < 1e-6


# -- a slider-crank driven by its slider to 0.5 deg of its dead centre ---------------------------

def test_a_slider_driven_to_near_its_dead_centre_warns(tmp_path):
    a, b, gap = 0.1, 0.3, 0.5            # crank, rod; the crank-rod angle's distance to 180 deg
    x_t = math.sqrt(a * a + b * b + 2 * a * b * math.cos(math.radians(gap)))
    x0 = x_t - 0.06
    th0 = math.acos((a * a + x0 * x0 - b * b) / (2 * a * x0))
    text = f"""\
name: pushed
units: {{length: m, angle: deg}}
bodies:
  crank:  {{q: [0, 0, {math.degrees(th0)!r}]}}
  rod:    {{q: [{a * math.cos(th0)!r}, {a * math.sin(th0)!r}, -20]}}
  slider: {{q: [{x0!r}, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, i: crank, j: rod, si: [{a!r}, 0], sj: [0, 0]}}
  - {{type: revolute, i: rod, j: slider, si: [{b!r}, 0], sj: [0, 0]}}
  - {{type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{type: x, body: slider, f: "{x_t!r} - 0.03*(1 + cos(2*pi*t))"}}
analysis: {{start: 0, end: 1, steps: 200}}
"""
    r, s = _run(tmp_path, text, name="pushed")
    assert r.returncode == 0, r.stderr
    (lp,) = s["loops"]
    assert (lp["input"], lp["output"], lp["input_from"]) == ("slider", "crank", "driver")
    ta = lp["transmission_angle"]
    assert "crank-rod pin" in ta["where"]
    # the angle at B between B -> C and B -> A: law of cosines in A B C, |A C| = x
    assert abs(ta["max"]["value"] - (180 - gap)) < 1e-9 and abs(ta["max"]["t"] - 0.5) < 1e-9
    lo = math.degrees(math.acos((a * a + b * b - x0 * x0) / (2 * a * b)))
    assert abs(ta["min"]["value"] - lo) < 1e-9 and ta["min"]["t"] == 0.0
    # crank pin speed per slider speed: 1 / |dx/dtheta| at the crank angle of x_t
    th = math.acos((a * a + x_t * x_t - b * b) / (2 * a * x_t))
    want = 1 / abs(math.sin(th) * x_t / (x_t - a * math.cos(th)))
    vr = lp["velocity_ratio"]["max"]
    assert want > RATIO_LIMIT and abs(vr["value"] - want) < 1e-7 * want
    (w,) = [w for w in s["warnings"] if w["kind"] == "toggle"]
    assert w["message"].startswith("slider-crank loop ground-crank-rod-slider (slider driving "
                                   "crank): passes near a toggle: the transmission angle at the "
                                   "crank-rod pin, between rod and crank reaches 179.5 deg, "
                                   "0.5 deg short of 180 deg, at t = 0.5 s")
    assert w["message"] in r.stderr


# -- the two rooms agree: the measures' transmission angle, and the solved rates' ratio ----------

LINKAGE = """\
name: linkage
units: {length: m, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.1, 0], ground: true}
  B: {at: [0.04, 0]}
  C: {at: [0.10666666666666667, 0.09977753031397177]}
links:
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "360*t"}
measures:
  mu: {transmission: [B, C, D]}
  crank: {angle: crank}
  rocker: {angle: rocker}
  vr: {ratio: [crank, rocker]}
analysis: {start: 0, end: 1, steps: 72}
"""


def test_loop_figures_agree_with_the_measures(tmp_path):
    r, s = _run(tmp_path, LINKAGE, name="linkage")
    assert r.returncode == 0, r.stderr
    (lp,) = s["loops"]
    m = s["cycle"]["measures"]
    # the measure's grid extremes (refined between rows by measures.extremes): the same angle
    ref = lambda x: x.get("refined", x)["value"]
    assert abs(ref(m["mu"]["min"]) - lp["transmission_angle"]["min"]["value"]) < 1e-9
    assert abs(ref(m["mu"]["max"]) - lp["transmission_angle"]["max"]["value"]) < 1e-6
    # the velocity ratio from the solved rates (rocker' / crank' on the grid) never exceeds the
    # located maximum of the position form, and comes within the grid's resolution of it
    grid = max(abs(m["vr"]["min"]["value"]), abs(m["vr"]["max"]["value"]))
    located = lp["velocity_ratio"]["max"]["value"]
    assert located * (1 - 1e-3) < grid <= located * (1 + 1e-12)


def test_a_model_without_loops_has_none(tmp_path):
    r, s = _run(tmp_path, path=ROOT / "mechanisms" / "boom.yaml")
    assert r.returncode == 0
    assert "loops" not in s


# ---- check: every loop and every driver's motion in words (issue 31, items 2 and 3) ---------

def _check(tmp_path, text):
    path = tmp_path / "model.yaml"
    path.write_text(text)
    return run_cli("check", path)


def test_check_names_a_slider_cranks_class_with_the_lengths_that_decide_it(tmp_path):
    from clitools import PLAIN_SLIDER_CRANK
    r = _check(tmp_path, PLAIN_SLIDER_CRANK)
    assert r.returncode == 0
    assert ("slider-crank loop ground-crank-rod-slider: crank turns fully; rod > crank + "
            "|offset|: 0.3 > 0.1 m (crank 0.1, rod 0.3, offset 0 m)") in r.stdout


@pytest.mark.parametrize("f, low, high, reversals", [
    ("20*sind(360*t)", -20, 20, 2),            # a pedal swinging once a second, as meant
    ("20*sin(360*t)", -20, 20, 115),           # radians: 360/(2 pi) = 57.3 swings a second
    ("90*t", 0, 90, 0),
])
def test_check_prints_each_drivers_range_and_its_reversals(tmp_path, f, low, high, reversals):
    # the reversals are the sign changes of the exact f' = 7200 pi/180 cos(2 pi t) (2, at
    # t = 1/4 and 3/4), of 7200 cos(360 t) (zeros at (k + 1/2) pi / 360 < 1: k = 0 .. 114)
    text = f"""\
name: pedal
units: {{length: m, angle: deg}}
bodies:
  pedal: {{q: [0, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: pedal, si: [0, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, body: pedal, f: "{f}"}}
analysis: {{start: 0, end: 1, steps: 36}}
"""
    r = _check(tmp_path, text)
    assert r.returncode == 0
    line = next(x.strip() for x in r.stdout.splitlines() if x.strip().startswith("driver 1"))
    s = "" if reversals == 1 else "s"
    assert line == (f"driver 1 (angle ground-pedal): f from {low:g} to {high:g} deg over t = 0 "
                    f"to 1 s, {reversals} reversal{s} of its motion")
