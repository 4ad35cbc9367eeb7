"""Closed-form reference mechanisms for the machine-element kinds: rack-and-pinion, rolling
discs, gears on moving centres (a planetary train, Willis' formula), belts and cams.

Every grid row is compared with a closed form derived by hand (derivations in the docstrings),
positions, velocities and accelerations, relative to the largest magnitude of the quantity over
the run (a quantity that is zero in the closed form is measured against the mechanism's scale).
Tolerance: 1e-12 relative (issue 8, "Done when").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import planarkin
from closedforms import rel, run

ROOT = Path(__file__).resolve().parent.parent
TOL = 1e-12
TWO_PI = 2 * math.pi


def check(measured: dict, exact: dict, scale: dict | None = None) -> float:
    """Assert every column matches; returns the worst relative error (for the report)."""
    worst = 0.0
    for key, want in exact.items():
        e = rel(measured[key], want, (scale or {}).get(key))
        assert e < TOL, f"{key}: relative error {e:.3g}"
        worst = max(worst, e)
    return worst


# -- rack-and-pinion steering (mechanisms/rack-pinion-steering.yaml) ---------------------------

def test_rack_pinion_steering_rack_moves_minus_r_phi():
    """The rack lies above the pinion (sigma = -1 seen from the rack's pitch line): a pinion
    turning counter-clockwise by phi moves its top, and so the rack, by x = -R phi; the rack's
    velocity and acceleration are -R omega and -R alpha, with omega, alpha of the driver
    f = lock sin(2 pi t) taken analytically, not from the solver."""
    res = planarkin.solve(ROOT / "mechanisms" / "rack-pinion-steering.yaml")
    assert res.status == 0
    R, lock = 0.02, 0.5
    t = res.t
    w = TWO_PI
    phi = lock * np.sin(w * t)
    om = lock * w * np.cos(w * t)
    al = -lock * w * w * np.sin(w * t)
    rack, pinion = res.body("rack"), res.body("pinion")
    check(pinion, {"phi": phi, "omega": om, "alpha": al})
    check(rack, {"x": -R * phi, "vx": -R * om, "ax": -R * al})
    check(rack, {"y": np.full_like(t, R), "vy": 0 * t, "ay": 0 * t, "phi": 0 * t},
          {"y": R, "vy": R * lock * w, "ay": R * lock * w * w, "phi": 1.0})


RACK_BELOW = """
units: {length: m, angle: rad}
bodies:
  pinion: {q: [0, 0, 0]}
  rack: {q: [0, -0.05, 0]}
joints:
  - {type: revolute, i: ground, j: pinion, at: [0, 0]}
  - {type: translational, i: ground, j: rack, at: [0, -0.05], axis: [1, 0]}
  - {type: rack-pinion, i: rack, j: pinion, si: [0, 0], vi: [1, 0], sj: [0, 0], r: 0.05}
drivers:
  - {type: angle, body: pinion, f: "t + 0.2*t**2"}
analysis: {end: 2, steps: 20}
"""


def test_rack_below_the_pinion_moves_plus_r_phi():
    """The bottom of a pinion turning counter-clockwise moves in +x: x_rack = +R phi."""
    res = run(RACK_BELOW)
    t = res.t
    check(res.body("rack"), {"x": 0.05 * (t + 0.2 * t * t), "vx": 0.05 * (1 + 0.4 * t),
                             "ax": 0.05 * 0.4 + 0 * t})


def test_pinion_rolling_on_a_fixed_rack_turns_clockwise():
    """Sign check of reference §3.3: a fixed rack along +x, the pinion above it, driven in +x
    by dx: it turns by -dx / r (clockwise). Uses roll-line (the pinion is held on the rack by
    nothing else: 2 equations)."""
    res = run("""
units: {length: m, angle: rad}
bodies: {pinion: {q: [0, 0.04, 0]}}
joints:
  - {type: roll-line, i: ground, j: pinion, si: [0, 0], vi: [1, 0], sj: [0, 0], r: 0.04}
drivers:
  - {type: x, i: ground, j: pinion, f: "0.1*t"}
analysis: {end: 1, steps: 4}
""")
    p = res.body("pinion")
    assert p["phi"][-1] == pytest.approx(-0.1 / 0.04, rel=1e-13)
    assert p["omega"][-1] < 0


# -- rolling -------------------------------------------------------------------------------------

WHEEL = """
units: {length: m, angle: rad}
parameters: {R: 0.3}
bodies: {wheel: {q: [0, R, 0]}}
joints:
  - {type: roll-line, i: ground, j: wheel, si: [0, 0], vi: [1, 0], sj: [0, 0], r: R}
drivers:
  - {type: x, i: ground, j: wheel, f: "0.5*t + 0.05*sin(2*pi*t)"}
points:
  rim: {body: wheel, s: [0, -R]}
analysis: {end: 2, steps: 80}
"""


def test_wheel_rolling_on_the_ground_is_a_cycloid():
    """Centre x(t) = 0.5 t + 0.05 sin(2 pi t) at height R; rolling: phi = -x / R; the rim
    point that touched the road at t = 0 traces the cycloid (x + R sin phi, R - R cos phi) =
    (x - R sin(x/R), R - R cos(x/R)). Derivatives by the chain rule with u = x/R:
    P' = x' (1 - cos u, sin u), P'' = x'' (1 - cos u, sin u) + x'^2/R (sin u, cos u)."""
    res = run(WHEEL)
    R, t = 0.3, res.t
    x = 0.5 * t + 0.05 * np.sin(TWO_PI * t)
    xd = 0.5 + 0.05 * TWO_PI * np.cos(TWO_PI * t)
    xdd = -0.05 * TWO_PI**2 * np.sin(TWO_PI * t)
    u = x / R
    w = res.body("wheel")
    check(w, {"x": x, "phi": -u, "omega": -xd / R, "alpha": -xdd / R})
    check(w, {"y": R + 0 * t, "vy": 0 * t, "ay": 0 * t}, {"y": R, "vy": R, "ay": R})
    P = res.point("rim")
    check(P, {"x": x - R * np.sin(u), "y": R - R * np.cos(u),
              "vx": xd * (1 - np.cos(u)), "vy": xd * np.sin(u),
              "ax": xdd * (1 - np.cos(u)) + xd**2 / R * np.sin(u),
              "ay": xdd * np.sin(u) + xd**2 / R * np.cos(u)})


DISC_ON_DISC = """
units: {{length: m, angle: rad}}
bodies: {{disc: {{q: [{x0}, 0, 0]}}}}
joints:
  - {{type: roll-disc, i: ground, j: disc, si: [0, 0], sj: [0, 0], ri: {ri}, rj: {r}}}
drivers:
  - {{type: angle, body: disc, f: "{w}*t"}}
points:
  P: {{body: disc, s: [{s}, 0]}}
analysis: {{end: 1, steps: 90}}
"""


@pytest.mark.parametrize("inside", [False, True], ids=["epicycloid", "hypocycloid"])
def test_disc_rolling_around_a_fixed_disc(inside):
    """A disc of radius r turning at phi = w t rolls on a fixed disc of radius F at the origin,
    outside (epicycloid) or inside it (F as an internal radius -F: hypocycloid). Rolling:
    S theta = r phi with S = ri + r (ri = F or -F); the centre is at S (cos theta, sin theta)
    (outside: distance F + r; inside: S < 0 and theta starts at pi, the centre at F - r).
    The rim point that touched the fixed disc at t = 0, at s' = (-sign(S) r, 0), traces
    P = S e(theta) - sign(S) r e(phi): outside the epicycloid (F + r) e(theta) - r e(((F + r)/r)
    theta); derivatives by hand: theta' = r w / S."""
    F, r, w = 0.1, 0.03, 5.0
    ri = -F if inside else F
    S = ri + r
    sg = math.copysign(1.0, S)
    res = run(DISC_ON_DISC.format(x0=abs(S), ri=ri, r=r, w=w, s=-sg * r))
    t = res.t
    phi = w * t
    th0 = math.pi if inside else 0.0
    th = th0 + r * phi / S
    thd = r * w / S
    # the centre is S e(theta) = |S| e(theta - th0) in both cases
    cx, cy = abs(S) * np.cos(th - th0), abs(S) * np.sin(th - th0)
    d = res.body("disc")
    check(d, {"x": cx, "y": cy, "vx": -cy * thd, "vy": cx * thd,
              "ax": -cx * thd**2, "ay": -cy * thd**2})
    P = res.point("P")
    px = cx - sg * r * np.cos(phi)
    py = cy - sg * r * np.sin(phi)
    check(P, {"x": px, "y": py,
              "vx": -cy * thd + sg * r * w * np.sin(phi), "vy": cx * thd - sg * r * w * np.cos(phi),
              "ax": -cx * thd**2 + sg * r * w * w * np.cos(phi),
              "ay": -cy * thd**2 + sg * r * w * w * np.sin(phi)})
    # the contact point is at rest at t = 0 (rolling without slipping)
    assert np.hypot(P["vx"][0], P["vy"][0]) < 1e-14 * r * w


# -- a planetary train on moving centres: Willis' formula --------------------------------------

PLANETARY = """
# sun on a fixed shaft (driven), planet on the carrier, fixed ring; gear-mesh on moving centres
units: {length: m, angle: rad}
parameters: {Rs: 0.04, Rp: 0.02, Rr: 0.08}
bodies:
  sun: {q: [0, 0, 0]}
  carrier: {q: [0, 0, 0]}
  planet: {q: [Rs + Rp, 0, 0]}
joints:
  - {type: revolute, i: ground, j: sun, at: [0, 0]}
  - {type: revolute, i: ground, j: carrier, at: [0, 0]}
  - {type: revolute, i: carrier, j: planet, at: [Rs + Rp, 0]}
  - {type: gear-mesh, i: sun, j: planet, si: [0, 0], sj: [0, 0], ri: Rs, rj: Rp}
  - {type: gear-mesh, i: ground, j: planet, si: [0, 0], sj: [0, 0], ri: -Rr, rj: Rp}
drivers:
  - {type: angle, body: sun, f: "2*pi*t + 0.3*sin(2*pi*t)"}
points:
  tooth: {body: planet, s: [Rp, 0]}
analysis: {end: 1, steps: 60}
"""


def test_planetary_train_on_moving_centres_obeys_willis():
    """Willis: (w_s - w_c) / (w_r - w_c) = -Rr / Rs and (w_p - w_c) / (w_s - w_c) = -Rs / Rp.
    With the ring fixed (w_r = 0): w_c = w_s Rs / (Rs + Rr), w_p = w_c - (w_s - w_c) Rs / Rp;
    all angles start at 0 and the relations are linear, so they hold for phi, omega and alpha
    alike. The planet centre is (Rs + Rp) e(phi_c)."""
    res = run(PLANETARY)
    Rs, Rp, Rr = 0.04, 0.02, 0.08
    t = res.t
    ps = TWO_PI * t + 0.3 * np.sin(TWO_PI * t)
    ws = TWO_PI + 0.3 * TWO_PI * np.cos(TWO_PI * t)
    as_ = -0.3 * TWO_PI**2 * np.sin(TWO_PI * t)
    k_c = Rs / (Rs + Rr)
    k_p = k_c - (1 - k_c) * Rs / Rp
    check(res.body("carrier"), {"phi": k_c * ps, "omega": k_c * ws, "alpha": k_c * as_})
    check(res.body("planet"), {"phi": k_p * ps, "omega": k_p * ws, "alpha": k_p * as_})
    a, pc, wc, ac = Rs + Rp, k_c * ps, k_c * ws, k_c * as_
    check(res.body("planet"), {
        "x": a * np.cos(pc), "y": a * np.sin(pc),
        "vx": -a * np.sin(pc) * wc, "vy": a * np.cos(pc) * wc,
        "ax": -a * np.cos(pc) * wc**2 - a * np.sin(pc) * ac,
        "ay": -a * np.sin(pc) * wc**2 + a * np.cos(pc) * ac})


def test_planetary_on_moving_centres_equals_the_carrier_gear_form():
    """The same train with the existing `gear` kind on carrier k gives the same motion."""
    carrier_form = PLANETARY.replace(
        "{type: gear-mesh, i: sun, j: planet, si: [0, 0], sj: [0, 0], ri: Rs, rj: Rp}",
        "{type: gear, i: sun, j: planet, k: carrier, ri: Rs, rj: Rp}").replace(
        "{type: gear-mesh, i: ground, j: planet, si: [0, 0], sj: [0, 0], ri: -Rr, rj: Rp}",
        "{type: gear, i: ground, j: planet, k: carrier, ri: -Rr, rj: Rp}")
    assert "type: gear-mesh" not in carrier_form
    a, b = run(PLANETARY), run(carrier_form)
    for arr in ("q", "qd", "qdd"):
        x, y = getattr(a, arr), getattr(b, arr)
        assert np.max(np.abs(x - y)) <= TOL * np.max(np.abs(y))


# -- belts -----------------------------------------------------------------------------------

BELT = """
units: {{length: m, angle: rad}}
bodies: {{small: {{q: [0, 0, 0]}}, big: {{q: [0.5, 0, 0]}}}}
joints:
  - {{type: revolute, i: ground, j: small, at: [0, 0]}}
  - {{type: revolute, i: ground, j: big, at: [0.5, 0]}}
  - {{type: belt, i: small, j: big, ri: 0.05, rj: 0.125{extra}}}
drivers:
  - {{type: angle, body: small, f: "3*t + sin(t)"}}
analysis: {{end: 2, steps: 20}}
"""


@pytest.mark.parametrize("crossed", [False, True])
def test_belt_ratio_and_direction(crossed):
    """No slip on both pulleys: ri phi_i = +-rj phi_j; open belt: same sense, crossed:
    opposite."""
    res = run(BELT.format(extra=", crossed: true" if crossed else ""))
    t = res.t
    k = (-1 if crossed else 1) * 0.05 / 0.125
    check(res.body("big"), {"phi": k * (3 * t + np.sin(t)), "omega": k * (3 + np.cos(t)),
                            "alpha": -k * np.sin(t)})


# -- cams ------------------------------------------------------------------------------------

def cam_frame(res, cam, point):
    """A point of the run seen in the cam's frame (cam centre at the origin): A(-phi) P."""
    phi = np.radians(res.body(cam)["phi"]) if res.model.spec.angle_unit == "deg" else \
        res.body(cam)["phi"]
    P = res.point(point)
    c, s = np.cos(phi), np.sin(phi)
    return c * P["x"] + s * P["y"], -s * P["x"] + c * P["y"]


def test_cam_cycloidal_rise_roller_follower():
    """mechanisms/cam-roller.yaml: cycloidal rise h over beta, cam turning at 360 deg/s, so
    u = theta / beta = 3 t. Follower: y = rb + rr + h (u - sin(2 pi u) / (2 pi)),
    y' = 3 h (1 - cos 2 pi u), y'' = 9 h 2 pi sin 2 pi u. Pitch curve (radial follower): the
    polar curve r(theta) = rb + rr + s, whose radius of curvature is (r^2 + r'^2)^(3/2) /
    (r^2 + 2 r'^2 - r r'') (derivatives in radians: s' = h / B (1 - cos 2 pi u), s'' = 2 pi h /
    B^2 sin 2 pi u, B = beta in rad); pressure angle atan(s' / r); the working surface lies rr
    inside the pitch curve with radius of curvature rho - rr."""
    res = planarkin.solve(ROOT / "mechanisms" / "cam-roller.yaml")
    assert res.status == 0
    h, beta, rb, rr = 0.02, 120.0, 0.04, 0.01
    t = res.t
    u = 3 * t
    y = rb + rr + h * (u - np.sin(TWO_PI * u) / TWO_PI)
    f = res.body("follower")
    worst = check(f, {"y": y, "vy": 3 * h * (1 - np.cos(TWO_PI * u)),
                      "ay": 9 * h * TWO_PI * np.sin(TWO_PI * u)})
    check(f, {"x": 0 * t, "vx": 0 * t, "ax": 0 * t}, {"x": rb, "vx": rb, "ax": rb})
    cam = res.table("cam-lift.csv")
    B = math.radians(beta)
    r = rb + rr + h * (u - np.sin(TWO_PI * u) / TWO_PI)
    r1 = h / B * (1 - np.cos(TWO_PI * u))
    r2 = TWO_PI * h / B**2 * np.sin(TWO_PI * u)
    rho = (r * r + r1 * r1) ** 1.5 / (r * r + 2 * r1 * r1 - r * r2)
    check(cam, {"theta": 360 * t, "s": r - rb - rr, "rho_pitch": rho, "rho_surface": rho - rr,
                "pressure_angle": np.degrees(np.arctan(r1 / r))})
    # the pitch curve is where the roller centre is, seen from the turning cam
    res_pts = planarkin.solve(planarkin.load(
        "cam.yaml", text=(ROOT / "mechanisms" / "cam-roller.yaml").read_text()
        + "points: {roller: {body: follower, s: [0, 0]}}\n"))
    px, py = cam_frame(res_pts, "cam", "roller")
    check(cam, {"pitch.x": px, "pitch.y": py}, {"pitch.x": r.max(), "pitch.y": r.max()})
    gap = np.hypot(cam["pitch.x"] - cam["surface.x"], cam["pitch.y"] - cam["surface.y"])
    assert np.max(np.abs(gap - rr)) < 1e-15
    assert worst < TOL


OFFSET_CAM = """
units: {{length: mm, angle: rad}}
parameters: {{e: {e}, rb: 30, rr: 8}}
bodies:
  cam: {{q: [0, 0, 0.4]}}
  stem: {{q: [e, 35, 0]}}
joints:
  - {{type: revolute, i: ground, j: cam, at: [0, 0]}}
  - {{type: translational, i: ground, j: stem, at: [e, 0], axis: [0, 1]}}
  - {{name: c, type: cam, i: cam, j: stem, sk: [0, 0], vk: [0, 1], sj: [0, 0], base: rb,
     {follower}, offset: {off}, s: "6*(1 - cos(theta))", pressure_limit: 0.6}}
drivers:
  - {{type: angle, body: cam, f: "0.4 + 2*pi*t + 0.3*sin(2*pi*t)"}}
points: {{tip: {{body: stem, s: [0, 0]}}}}
analysis: {{end: 1, steps: 72}}
"""


@pytest.mark.parametrize("e", [0.0, 7.0, -7.0])
def test_offset_roller_follower_profile(e):
    """A harmonic full-turn law s = 6 (1 - cos theta) on a cam turning non-uniformly, follower
    axis offset by e along R vk = -x (vk = +y): the follower's travel is the law exactly
    (y = sqrt((rb + rr)^2 - e^2) + s(theta(t)), by the chain rule), its pitch point in the cam
    frame is the roller centre seen from the cam, and the pressure angle is the angle between
    the follower's travel and the pitch curve's normal, the normal taken here from central
    differences of the computed pitch curve (a check independent of the profile's formulas)."""
    res = run(OFFSET_CAM.format(e=-e, off=e, follower="roller: rr"))
    t = res.t
    w = TWO_PI
    th = 0.4 + w * t + 0.3 * np.sin(w * t)
    thd = w + 0.3 * w * np.cos(w * t)
    thdd = -0.3 * w * w * np.sin(w * t)
    s0 = math.sqrt(38.0**2 - e * e)
    check(res.body("stem"), {"y": s0 + 6 * (1 - np.cos(th)), "vy": 6 * np.sin(th) * thd,
                             "ay": 6 * np.cos(th) * thd**2 + 6 * np.sin(th) * thdd})
    cam = res.table("cam-c.csv")
    px, py = cam_frame(res, "cam", "tip")
    check(cam, {"pitch.x": px, "pitch.y": py}, {"pitch.x": 44.0, "pitch.y": 44.0})
    # pressure angle against a finite-difference normal of the pitch curve at nearby angles
    from planarkin.elements.cam import profile
    G = next(G for G in res.model.groups if G.kind.name == "cam")
    from planarkin.elements.cam import instance
    par = instance(G, 0)
    thr = np.linspace(0.1, 6.2, 40)
    d = 1e-6
    a, b = profile("cam", par, thr - d), profile("cam", par, thr + d)
    tx, ty = b["pitch_x"] - a["pitch_x"], b["pitch_y"] - a["pitch_y"]
    # follower travel +y of the frame, seen in the cam frame: A(-theta) (0, 1)
    mx, my = np.sin(thr), np.cos(thr)
    # the normal is perpendicular to the tangent: angle(normal, m) = 90 deg - angle(tangent, m)
    cosang = np.abs(tx * mx + ty * my) / np.hypot(tx, ty)
    want = np.pi / 2 - np.arccos(cosang)
    got = profile("cam", par, thr)["pressure"]
    assert np.max(np.abs(got - want)) < 1e-8
    # and the hand formula of this convention: tan alpha = |s' - e_frame...|: with the axis at
    # x = -e (offset e along R vk = -x), tan alpha = |s' + e| / (s0 + s)
    s1 = 6 * np.sin(thr)
    np.testing.assert_allclose(got, np.arctan(np.abs(s1 + e) / (s0 + 6 * (1 - np.cos(thr)))),
                               rtol=1e-12, atol=1e-15)


def test_flat_faced_follower_profile_is_the_face_envelope():
    """Flat face perpendicular to the travel: the follower moves by the law (face at rb + s),
    the contact point lies on the face (in the cam frame u_c^T c = rb + s, u_c = A(-theta) u),
    the face is tangent to the surface there (central differences of the surface points are
    perpendicular to u_c), and the surface's radius of curvature is rb + s + s''."""
    res = run(OFFSET_CAM.format(e=0, off=0, follower="flat: true").replace(
        "[e, 35, 0]", "[0, 30, 0]"))
    from planarkin.elements.cam import instance, profile
    G = next(G for G in res.model.groups if G.kind.name == "cam")
    par = instance(G, 0)
    th = np.linspace(0.0, TWO_PI, 50)
    P = profile("cam", par, th)
    s, s2 = 6 * (1 - np.cos(th)), 6 * np.cos(th)
    ucx, ucy = np.sin(th), np.cos(th)
    L = res.model.L
    np.testing.assert_allclose((ucx * P["surface_x"] + ucy * P["surface_y"]) * L, 30 + s,
                               rtol=1e-14)
    np.testing.assert_allclose(P["rho_surface"] * L, 30 + s + s2, rtol=1e-13, atol=1e-12)
    d = 1e-6
    a, b = profile("cam", par, th - d), profile("cam", par, th + d)
    tx, ty = b["surface_x"] - a["surface_x"], b["surface_y"] - a["surface_y"]
    assert np.max(np.abs(tx * ucx + ty * ucy) / np.hypot(tx, ty)) < 1e-8
    assert np.max(np.abs(P["pressure"])) == 0.0
    t = res.t
    thr = 0.4 + TWO_PI * t + 0.3 * np.sin(TWO_PI * t)
    check(res.body("stem"), {"y": 30 + 6 * (1 - np.cos(thr))})


ROCKER = """
units: {length: m, angle: rad}
bodies:
  cam: {q: [0, 0, 0]}
  arm: {q: [0.1, 0, 2.0]}
joints:
  - {type: revolute, i: ground, j: cam, at: [0, 0]}
  - {type: revolute, i: ground, j: arm, at: [0.1, 0]}
  - {name: swing, type: cam-rocker, i: cam, j: arm, sk: [0, 0], pk: [0.1, 0], sj: [0.08, 0],
     psi: "0.2*(1 - cos(theta))", roller: 0.01}
drivers:
  - {type: angle, body: cam, f: "2*pi*t"}
points: {roller: {body: arm, s: [0.08, 0]}}
analysis: {end: 1, steps: 60}
"""


def test_oscillating_roller_follower():
    """Rocker pivoted at (0.1, 0) with the roller 0.08 along its arm, drawn at 2 rad; the law
    psi = 0.2 (1 - cos theta), theta = 2 pi t: phi = 2 + psi, omega = 0.2 sin(theta) 2 pi,
    alpha = 0.2 cos(theta) (2 pi)^2; the pitch curve is the roller centre seen from the cam."""
    res = run(ROCKER)
    t = res.t
    th = TWO_PI * t
    check(res.body("arm"), {"phi": 2 + 0.2 * (1 - np.cos(th)), "omega": 0.2 * np.sin(th) * TWO_PI,
                            "alpha": 0.2 * np.cos(th) * TWO_PI**2})
    cam = res.table("cam-swing.csv")
    px, py = cam_frame(res, "cam", "roller")
    check(cam, {"pitch.x": px, "pitch.y": py, "psi": 0.2 * (1 - np.cos(th))},
          {"pitch.x": 0.18, "pitch.y": 0.18, "psi": 0.4})
    assert np.all(cam["pressure_angle"] < math.radians(45))


# -- a pin following a curve given as a table of points ------------------------------------------

def _table(points) -> str:
    return "[" + ", ".join(f"[{float(x)!r}, {float(y)!r}]" for x, y in points) + "]"


CIRCLE_SLOT = """
units: {{length: m, angle: rad}}
parameters: {{Cx: 0.3, Cy: 0.2, R: 0.5}}
bodies: {{block: {{q: [0.3, 0.7, 0]}}}}
joints:
  - {{type: angle, i: ground, j: block, c: 0}}
  - {joint}
drivers:
  - {{type: x, i: ground, j: block, f: "Cx + 0.4*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 50}}
"""


def _circle_points(cx, cy, r, m):
    a = np.linspace(0.0, TWO_PI, m, endpoint=False)
    return np.c_[cx + r * np.cos(a), cy + r * np.sin(a)]


def test_pin_in_a_circular_slot_equals_a_link_to_the_centre():
    """A block (no rotation) whose origin runs in a circular slot of the ground (centre C,
    radius R, a closed table of 720 points), driven by x = Cx + 0.4 sin(2 pi t): the closed form
    is that of a link of length R pinned at C (y = Cy + w, w = sqrt(R^2 - u^2), u = x - Cx;
    y' = -u u'/w; y'' = -(u'^2 + u u'')/w - u^2 u'^2/w^3). The distance-joint model meets it to
    1e-12; the slot meets it to the interpolant's own error, measured here on the spline: its
    largest radius error (positions) and curvature error (accelerations)."""
    from planarkin.elements.curve import Curve
    pts = _circle_points(0.3, 0.2, 0.5, 720)
    slot = run(CIRCLE_SLOT.format(joint="{type: curve-slot, i: ground, j: block, sj: [0, 0], "
                                        f"closed: true, curve: {_table(pts)}}}"))
    link = run(CIRCLE_SLOT.format(joint="{type: distance, i: ground, j: block, si: [Cx, Cy], "
                                        "sj: [0, 0], c: R}"))
    t = res_t = slot.t
    w2 = TWO_PI
    u = 0.4 * np.sin(w2 * t)
    ud = 0.4 * w2 * np.cos(w2 * t)
    udd = -0.4 * w2 * w2 * np.sin(w2 * t)
    w = np.sqrt(0.25 - u * u)
    exact = {"y": 0.2 + w, "vy": -u * ud / w,
             "ay": -(ud * ud + u * udd) / w - u * u * ud * ud / w**3}
    check(link.body("block"), exact)
    # the interpolant's own errors against the circle, densely sampled
    cv = Curve(pts, closed=True)
    a = np.linspace(0.0, cv.a1, 20001)
    c, c1, c2 = cv.eval(a)
    radius_err = np.max(np.abs(np.hypot(c[:, 0] - 0.3, c[:, 1] - 0.2) - 0.5)) / 0.5
    sp = np.hypot(c1[:, 0], c1[:, 1])
    kappa_err = np.max(np.abs((c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]) / sp**3 * 0.5 - 1.0))
    assert radius_err < 1e-14 and kappa_err < 1e-8
    b = slot.body("block")
    assert rel(b["y"], exact["y"]) < 10 * radius_err + 1e-15
    assert rel(b["vy"], exact["vy"]) < 1e-10
    assert rel(b["ay"], exact["ay"]) < 10 * kappa_err
    assert len(res_t) == 51


def test_pin_in_a_straight_table_slot_equals_pin_slot():
    """An open slot given as 9 points along a line at 30 degrees through (0.1, 0) on a turning
    crank: the spline of a straight table is that line exactly, so the motion equals the
    pin-slot joint's to 1e-12 (positions, velocities, accelerations of every body)."""
    d = np.array([math.cos(math.pi / 6), math.sin(math.pi / 6)])
    pts = [tuple(np.array([0.1, 0.0]) + s * d) for s in np.linspace(-0.2, 0.6, 9)]
    base = """
units: {{length: m, angle: rad}}
bodies:
  crank: {{q: [0, 0, 0]}}
  slider: {{q: [0.35, 0.1443375672974065, 0]}}
joints:
  - {{type: revolute, i: ground, j: crank, at: [0, 0]}}
  - {{type: translational, i: ground, j: slider, si: [0, 0.1443375672974065], sj: [0, 0],
     vi: [1, 0], vj: [1, 0]}}
  - {joint}
drivers:
  - {{type: angle, body: crank, f: "0.2*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 40}}
"""
    table = run(base.format(joint="{type: curve-slot, i: crank, j: slider, sj: [0, 0], curve: "
                                  + _table(pts) + "}"))
    line = run(base.format(joint=f"{{type: pin-slot, i: crank, j: slider, si: [0.1, 0], "
                                 f"vi: [{float(d[0])!r}, {float(d[1])!r}], sj: [0, 0]}}"))
    for arr in ("q", "qd", "qdd"):
        x, y = getattr(table, arr), getattr(line, arr)
        assert np.max(np.abs(x - y)) <= TOL * np.max(np.abs(y)), arr


def test_pin_leaving_an_open_slot_stops_the_run():
    """An open slot ends: driving the pin past the end of the table is an analysis failure (exit
    status 1, results up to there kept), not an extrapolated curve."""
    pts = [(x, 0.0) for x in np.linspace(0.0, 0.5, 11)]
    res = planarkin.solve(planarkin.load("slot.yaml", text=f"""
units: {{length: m, angle: rad}}
bodies: {{pin: {{q: [0.1, 0, 0]}}}}
joints:
  - {{type: angle, i: ground, j: pin, c: 0}}
  - {{type: curve-slot, i: ground, j: pin, sj: [0, 0], curve: {_table(pts)}}}
drivers:
  - {{type: x, i: ground, j: pin, f: "0.1 + t"}}
analysis: {{end: 1, steps: 10}}
"""))
    assert res.status == 1
    assert 0.3 < res.t[-1] < 0.5 + 1e-12
    # the table ends at x = 0.5, reached at t = 0.4
    assert res.message == ("joint 2 (curve-slot ground-pin) is not defined just after t = 0.4: "
                           "the pin leaves the open curve at its end")
