"""Kinetostatics (planarkin.forces) against closed forms derived by hand, invariants and hand
statics.

The references here do not use the solver's Jacobians or multipliers: the slider-crank and the
four-bar are solved in closed form (tests/closedforms.py: positions by trigonometry, velocities
and accelerations by differentiating the loop equations by hand) and their forces by free-body Newton-Euler equations
written out link by link; the power balance uses only the result's exact q, q', q''. Errors are
relative to the largest magnitude of the compared column over the run, at every grid point.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import planarkin
import closedforms as CF
from planarkin.elements import JOINT_KINDS
from planarkin.forces.solve import JOINT_OUTPUT, Kinetostatics

G = -9.81


def load(text: str, name="model.yaml"):
    return planarkin.load(name, text=text)


def rel_err(got, ref):
    got, ref = np.asarray(got), np.asarray(ref)
    return float(np.abs(got - ref).max() / max(np.abs(ref).max(), 1e-300))


def cross(ax, ay, bx, by):
    return ax * by - ay * bx


def rot(phi, v):
    c, s = np.cos(phi), np.sin(phi)
    return c * v[0] - s * v[1], s * v[0] + c * v[1]


# -- slider-crank ---------------------------------------------------------------------------------
# crank O-A (a) with its frame at O and centre of mass off the crank line; rod A-B (b) with its
# frame at its centre of mass, c2 from A on the line A-B; slider at B on the x axis through O.
SC = dict(a=0.1, b=0.32, c1=(0.035, 0.012), m1=1.3, J1=0.0021, c2=0.13, m2=2.1, J2=0.018, m3=0.7,
          P=-40.0)
SLIDER_CRANK = f"""
name: sc-forces
parameters: {{a: {SC['a']}, b: {SC['b']}, c2: {SC['c2']}}}
gravity: [0, {G}]
bodies:
  crank:  {{q: [0, 0, 0.4], mass: {SC['m1']}, inertia: {SC['J1']}, cm: [{SC['c1'][0]}, {SC['c1'][1]}]}}
  rod:    {{q: [0.2, 0.0, -0.1], mass: {SC['m2']}, inertia: {SC['J2']}}}
  slider: {{q: [0.4, 0.0, 0.0], mass: {SC['m3']}}}
joints:
  - {{type: revolute, name: O, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, name: A, i: crank, j: rod, si: [a, 0], sj: [-c2, 0]}}
  - {{type: revolute, name: B, i: rod, j: slider, si: [b - c2, 0], sj: [0, 0]}}
  - {{type: translational, name: guide, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{type: angle, name: motor, body: crank, f: "0.4 + 2*pi*t + 0.3*sin(2*pi*t)"}}
loads:
  - {{type: force, name: press, body: slider, f: ["{SC['P']}*(1 + 0.5*cos(2*pi*t))", "0"]}}
analysis: {{start: 0, end: 1, steps: 72}}
"""


def slider_crank_reference(t, a, b, c1, m1, J1, c2, m2, J2, m3, P):
    w = 2 * np.pi
    th = 0.4 + w * t + 0.3 * np.sin(w * t)
    thd = w + 0.3 * w * np.cos(w * t)
    thdd = -0.3 * w * w * np.sin(w * t)
    g = np.array([0.0, G])
    Pt = P * (1 + 0.5 * np.cos(w * t))
    # kinematics by hand
    p1 = np.array(rot(th, c1))
    a1 = thdd * np.array([-p1[1], p1[0]]) - thd ** 2 * p1
    rA = a * np.array([np.cos(th), np.sin(th)])
    aA = thdd * np.array([-rA[1], rA[0]]) - thd ** 2 * rA
    psi, psd, psdd, xB, _, xBdd = CF.slider_crank(th, thd, thdd, a, b)
    e = np.array([np.cos(psi), np.sin(psi)])
    a2 = aA + c2 * (psdd * np.array([-e[1], e[0]]) - psd ** 2 * e)
    # slider: F23 from the rod, N from the guide, the press load P and gravity
    Fx = m3 * xBdd - Pt
    q2 = m2 * (a2 - g[:, None])
    Fy = ((-c2 * cross(e[0], e[1], q2[0], q2[1]) - J2 * psdd) / b + e[1] * Fx) / e[0]
    N = -Fy - m3 * G
    F23 = np.array([Fx, Fy])
    F12 = m2 * a2 + F23 - m2 * g[:, None]          # crank on rod at A
    F01 = m1 * a1 + F12 - m1 * g[:, None]          # ground on crank at O
    q1 = m1 * (a1 - g[:, None])
    tau = J1 * thdd + cross(p1[0], p1[1], q1[0], q1[1]) + cross(rA[0], rA[1], F12[0], F12[1])
    return {"motor.torque": tau, "O.fx": F01[0], "O.fy": F01[1], "A.fx": F12[0],
            "A.fy": F12[1], "B.fx": Fx, "B.fy": Fy, "guide.fx": 0 * t, "guide.fy": N,
            "guide.torque": 0 * t, "motor.power": tau * thd,
            "shaking.fx": -F01[0], "shaking.fy": -F01[1] - N, "shaking.torque": -tau - xB * N}


@pytest.fixture(scope="module")
def slider_crank():
    return planarkin.solve(load(SLIDER_CRANK))


def test_slider_crank_against_newton_euler_by_hand(slider_crank):
    res = slider_crank
    got = res.table("forces.csv")
    ref = slider_crank_reference(res.t, **SC)
    for key, r in ref.items():
        if key in ("guide.fx", "guide.torque"):
            scale = np.abs(ref["guide.fy"]).max()
            assert np.abs(got[key]).max() <= 1e-10 * scale, key
            continue
        assert rel_err(got[key], r) <= 1e-9, (key, rel_err(got[key], r))


# -- four-bar -------------------------------------------------------------------------------------
FB = dict(a=0.05, b=0.14, c=0.11, d=0.12, c2=(0.02, 0.006), m2=0.8, J2=4e-4, u3=(0.06, 0.02),
          m3=1.6, J3=3.1e-3, c4=(0.05, -0.01), m4=1.1, J4=1.4e-3, pl=(0.09, 0.05))
FOUR_BAR = f"""
name: fb-forces
units: {{length: m, angle: deg}}
gravity: [0, {G}]
bodies:
  crank:   {{q: [0, 0, 57.3], mass: {FB['m2']}, inertia: {FB['J2']}, cm: [{FB['c2'][0]}, {FB['c2'][1]}]}}
  coupler: {{q: [0.06, 0.08, 10], mass: {FB['m3']}, inertia: {FB['J3']}}}
  rocker:  {{q: [{FB['d']}, 0, 75], mass: {FB['m4']}, inertia: {FB['J4']}, cm: [{FB['c4'][0]}, {FB['c4'][1]}]}}
joints:
  - {{type: revolute, name: O2, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, name: A, i: crank, j: coupler, si: [{FB['a']}, 0], sj: [{-FB['u3'][0]}, {-FB['u3'][1]}]}}
  - {{type: revolute, name: B, i: coupler, j: rocker, si: [{FB['b'] - FB['u3'][0]}, {-FB['u3'][1]}], sj: [{FB['c']}, 0]}}
  - {{type: revolute, name: O4, i: ground, j: rocker, si: [{FB['d']}, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, name: motor, body: crank, f: "57.29577951308232 + 360*t + 20*sin(2*pi*t)"}}
loads:
  - {{type: force, name: tool, body: coupler, s: [{FB['pl'][0] - FB['u3'][0]}, {FB['pl'][1] - FB['u3'][1]}], f: ["3*cos(2*pi*t)", "-5 + 2*sin(4*pi*t)"]}}
  - {{type: torque, name: brake, body: rocker, f: "-0.4 + 0.1*t"}}
analysis: {{start: 0, end: 1, steps: 72}}
"""


def four_bar_reference(t, a, b, c, d, c2, m2, J2, u3, m3, J3, c4, m4, J4, pl):
    w = 2 * np.pi
    deg = np.pi / 180
    th = (57.29577951308232 + 360 * t + 20 * np.sin(w * t)) * deg
    thd = (360 + 20 * w * np.cos(w * t)) * deg
    thdd = (-20 * w * w * np.sin(w * t)) * deg
    g = np.array([0.0, G])[:, None]
    R = lambda v: np.array([-v[1], v[0]])
    e2 = np.array([np.cos(th), np.sin(th)])
    rA = a * e2
    O4 = np.array([d, 0.0])[:, None]
    th3, w3, al3, th4, w4, al4 = CF.four_bar(th, thd, thdd, a, b, c, d)    # open branch
    e3 = np.array([np.cos(th3), np.sin(th3)])
    B = rA + b * e3
    aA = a * thdd * R(e2) - a * thd ** 2 * e2
    s2 = np.array(rot(th, c2))
    a2c = thdd * R(s2) - thd ** 2 * s2
    s3 = np.array(rot(th3, u3))
    a3c = aA + al3 * R(s3) - w3 ** 2 * s3
    s4 = np.array(rot(th4, c4))
    a4c = al4 * R(s4) - w4 ** 2 * s4
    PL = rA + np.array(rot(th3, pl))
    FL = np.array([3 * np.cos(w * t), -5 + 2 * np.sin(2 * w * t)])
    tau4 = -0.4 + 0.1 * t
    # rocker moment about O4 and coupler moment about A: two equations in F34 (coupler on rocker)
    q4 = m4 * (a4c - g)
    q3 = m3 * (a3c - g)
    rR = J4 * al4 + cross(*s4, *q4) - tau4
    rC = -J3 * al3 - cross(*s3, *q3) + cross(*(PL - rA), *FL)
    vR, vC = B - O4, B - rA
    k11, k12, k21, k22 = -vR[1], vR[0], -vC[1], vC[0]
    dk = k11 * k22 - k12 * k21
    F34 = np.array([(rR * k22 - k12 * rC) / dk, (k11 * rC - rR * k21) / dk])
    F23 = m3 * a3c + F34 - FL - m3 * g                  # crank on coupler at A
    F14 = m4 * a4c - F34 - m4 * g                       # ground on rocker at O4
    F12 = m2 * a2c + F23 - m2 * g                       # ground on crank at O2
    tau = J2 * thdd + cross(*s2, *(m2 * (a2c - g))) + cross(*rA, *F23)
    return {"motor.torque": tau, "O2.fx": F12[0], "O2.fy": F12[1], "A.fx": F23[0],
            "A.fy": F23[1], "B.fx": F34[0], "B.fy": F34[1], "O4.fx": F14[0], "O4.fy": F14[1],
            "motor.power": tau * thd, "shaking.fx": -F12[0] - F14[0],
            "shaking.fy": -F12[1] - F14[1], "shaking.torque": -tau - d * F14[1]}


def test_four_bar_against_newton_euler_by_hand():
    res = planarkin.solve(load(FOUR_BAR))
    assert res.success, res.message
    got = res.table("forces.csv")
    ref = four_bar_reference(res.t, **FB)
    for key, r in ref.items():
        assert rel_err(got[key], r) <= 1e-9, (key, rel_err(got[key], r))


# -- power balance --------------------------------------------------------------------------------
LOADED = """
name: loaded
units: {length: mm, angle: deg}
gravity: [3000, -9810]
bodies:
  crank:  {q: [0, 0, 20], mass: 1.3, inertia: 2100, cm: [35, 12]}
  rod:    {q: [200, 0, -5], mass: 2.1, inertia: 18000, cm: [130, -8]}
  slider: {q: [400, 0, 0], mass: 0.7, inertia: 50, cm: [5, 3]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: rod, si: [100, 0], sj: [0, 0]}
  - {type: revolute, i: rod, j: slider, si: [320, 0], sj: [0, 0]}
  - {type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "30 + 360*t + 40*sin(2*pi*t)"}
loads:
  - {type: force, body: rod, s: [200, 30], f: ["100*t", "-2000 + 500*cos(2*pi*t)"]}
  - {type: torque, body: crank, f: "-3e5*sin(2*pi*t)"}
  - {type: spring, i: ground, j: rod, si: [0, 200], sj: [160, 0], k: 80, length: 150}
  - {type: damper, i: crank, j: slider, si: [100, 0], sj: [0, 0], c: 5}
  - {type: spring, i: crank, j: rod, si: [50, 10], sj: [60, 20], k: 300, length: 20}
analysis: {start: 0, end: 1, steps: 96}
"""

BOOM = """
name: loaded-boom
units: {length: m, angle: deg}
gravity: [0, -9.81]
bodies:
  boom: {q: [0, 0, 20], mass: 120, inertia: 160, cm: [2.0, 0.1]}
joints:
  - {type: revolute, i: ground, j: boom, si: [0, 0], sj: [0, 0]}
drivers:
  - {type: distance, name: cylinder, i: ground, j: boom, si: [0.8, -0.6], sj: [1.5, 0], f: "1.2 + 0.15*t + 0.05*sin(3*t)"}
loads:
  - {type: force, name: payload, body: boom, s: [4.0, 0], f: ["0", "-2000"]}
analysis: {start: 0, end: 4, steps: 80}
"""


def power_balance(res):
    """(sum of driver powers, dT/dt - P_applied) from the result's exact q, q', q'' and the
    model's mass and load data, each (N,)."""
    cm = res.model
    spec = cm.spec
    fs = spec.forces
    af = cm.angle_factor
    t = res.t
    names = list(cm.body_names)

    def body(b):
        if b == "ground":
            z = np.zeros_like(t)
            return (z,) * 9
        k = names.index(b)
        sl = slice(3 * k, 3 * k + 3)
        q, qd, qdd = res.q[:, sl], res.qd[:, sl], res.qdd[:, sl]
        return (q[:, 0], q[:, 1], q[:, 2] * af, qd[:, 0], qd[:, 1], qd[:, 2] * af,
                qdd[:, 0], qdd[:, 1], qdd[:, 2] * af)

    def point(b, s):
        x, y, ph, vx, vy, w, ax, ay, al = body(b)
        sx, sy = rot(ph, s)
        return x + sx, y + sy, vx - w * sy, vy + w * sx, ax - al * sy - w * w * sx, \
            ay + al * sx - w * w * sy

    g = np.zeros(2) if fs.gravity is None else np.array(fs.gravity)
    dT = np.zeros_like(t)
    P = np.zeros_like(t)
    for m in fs.masses:
        _, _, vx, vy, ax, ay = point(m.body, m.cm)
        w, al = body(m.body)[5], body(m.body)[8]
        dT += m.mass * (vx * ax + vy * ay) + m.inertia * w * al
        P += m.mass * (g[0] * vx + g[1] * vy)
    for ld in fs.loads:
        if ld.kind == "force":
            _, _, vx, vy, _, _ = point(ld.bodies[0], ld.s)
            P += ld.f[0](t) * vx + ld.f[1](t) * vy
        elif ld.kind == "torque":
            P += ld.f[0](t) * body(ld.bodies[0])[5]
        else:
            px, py, pvx, pvy, _, _ = point(ld.bodies[0], ld.si)
            qx, qy, qvx, qvy, _, _ = point(ld.bodies[1], ld.sj)
            ell = np.hypot(qx - px, qy - py)
            ldot = ((qx - px) * (qvx - pvx) + (qy - py) * (qvy - pvy)) / ell
            tension = ld.k * (ell - ld.length) + ld.c * ldot
            P += -tension * ldot
    return res.table("forces.csv")["total.power"], dT - P


# the slider-crank run backwards: a linear actuator drives the slider (slide driver), x varying
# between 0.36 and 0.40 (clear of the dead centres at 0.22 and 0.42)
SLIDE_DRIVEN = SLIDER_CRANK.replace(
    '  - {type: angle, name: motor, body: crank, f: "0.4 + 2*pi*t + 0.3*sin(2*pi*t)"}',
    '  - {type: slide, name: actuator, i: ground, j: slider, si: [0, 0], vi: [1, 0], '
    'f: "0.38 + 0.02*sin(2*pi*t)"}').replace("crank:  {q: [0, 0, 0.4]", "crank:  {q: [0, 0, 0.9]")


@pytest.mark.parametrize("text", [LOADED, BOOM, SLIDER_CRANK, FOUR_BAR, SLIDE_DRIVEN],
                         ids=["loaded-mm-deg", "boom", "slider-crank", "four-bar", "slide-driven"])
def test_power_balance_at_every_grid_point(text):
    res = planarkin.solve(load(text))
    assert res.success, res.message
    drivers, balance = power_balance(res)
    scale = np.abs(balance).max()
    assert scale > 0
    assert np.abs(drivers - balance).max() <= 1e-12 * scale, np.abs(drivers - balance).max() / scale


def test_driver_power_is_effort_times_rate():
    res = planarkin.solve(load(BOOM))
    f = res.table("forces.csv")
    rate = 0.15 + 0.15 * np.cos(3 * res.t)
    assert rel_err(f["cylinder.power"], f["cylinder.force"] * rate) <= 1e-13


# -- statics --------------------------------------------------------------------------------------

def test_boom_held_still_under_gravity_matches_hand_statics():
    text = BOOM.replace('f: "1.2 + 0.15*t + 0.05*sin(3*t)"', 'f: "1.5"').replace(
        "name: loaded-boom", "name: held-boom")
    res = planarkin.solve(load(text))
    assert res.success
    f = res.table("forces.csv")
    m, W = 120.0, -2000.0
    a0 = math.atan2(0.6, 0.8)
    phi = math.acos((3.25 - 1.5 ** 2) / 3) - a0
    assert np.allclose(res.body("boom")["phi"], math.degrees(phi), rtol=0, atol=1e-9)
    P = 1.5 * np.array([math.cos(phi), math.sin(phi)])
    C = np.array([0.8, -0.6])
    e = (P - C) / np.linalg.norm(P - C)
    rc = np.array(rot(phi, (2.0, 0.1)))
    tip = 4.0 * np.array([math.cos(phi), math.sin(phi)])
    F = -(cross(*rc, 0, m * G) + cross(*tip, 0, W)) / cross(*P, *e)
    pin = -(F * e + np.array([0, m * G]) + np.array([0, W]))
    assert F > 0                                        # the cylinder pushes
    assert rel_err(f["cylinder.force"], np.full_like(res.t, F)) <= 1e-12
    assert rel_err(f["joint_1_revolute_ground-boom.fx"], np.full_like(res.t, pin[0])) <= 1e-12
    assert rel_err(f["joint_1_revolute_ground-boom.fy"], np.full_like(res.t, pin[1])) <= 1e-12
    assert np.abs(f["cylinder.power"]).max() == 0.0     # nothing moves
    assert rel_err(f["shaking.fy"], np.full_like(res.t, m * G + W)) <= 1e-12
    assert np.abs(f["shaking.fx"]).max() <= 1e-12 * abs(m * G + W)
    assert rel_err(f["shaking.torque"], np.full_like(res.t, cross(*C, *(-F * e)))) <= 1e-12


# -- sign conventions, every joint kind -----------------------------------------------------------
KIND_MODELS = {
    "slider-crank": SLIDER_CRANK,
    "pin-slot": """
name: pin-slot-forces
gravity: [0, -9.81]
bodies:
  crank:  {q: [0, 0.2, 0], mass: 0.5, inertia: 0.001, cm: [0.03, 0.01]}
  rocker: {q: [0, 0, 1.1], mass: 2, inertia: 0.05, cm: [0.2, 0.02]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0.2], sj: [0, 0]}
  - {type: pin-slot, i: rocker, j: crank, si: [0, 0], vi: [1, 0], sj: [0.1, 0]}
  - {type: revolute, i: ground, j: rocker, si: [0, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
loads:
  - {type: force, body: rocker, s: [0.45, 0], f: ["-30", "0"]}
analysis: {start: 0, end: 1, steps: 24}
""",
    "distance-x-y-angle": """
name: components
gravity: [0, -9.81]
bodies:
  a: {q: [0.3, 0.1, 0.2], mass: 1.5, inertia: 0.02, cm: [0.05, -0.02]}
  b: {q: [0.8, 0.4, -0.3], mass: 0.9, inertia: 0.01, cm: [0.1, 0.03]}
joints:
  - {type: x, i: ground, j: a, si: [0.3, 0], sj: [0.02, 0.01], c: 0.01}
  - {type: angle, i: ground, j: a, c: 0.2}
  - {type: distance, i: a, j: b, si: [0.1, 0.05], sj: [-0.1, 0.0], c: 0.45}
  - {type: y, i: a, j: b, si: [0, 0], sj: [0.05, 0], c: 0.3}
drivers:
  - {type: y, body: a, f: "0.1 + 0.05*sin(2*pi*t)"}
  - {type: angle, i: a, j: b, f: "-0.5 + 0.3*t"}
loads:
  - {type: force, body: b, s: [0.2, 0.1], f: ["5", "-3*t"]}
analysis: {start: 0, end: 1, steps: 24}
""",
    "gear": """
name: gears
gravity: [0, -9.81]
bodies:
  pinion: {q: [0, 0, 0], mass: 0.4, inertia: 0.002}
  wheel:  {q: [0.15, 0, 0], mass: 1.2, inertia: 0.03, cm: [0.01, 0]}
joints:
  - {type: revolute, i: ground, j: pinion, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: ground, j: wheel, si: [0.15, 0], sj: [0, 0]}
  - {type: gear, i: pinion, j: wheel, ri: 0.05, rj: 0.1}
drivers:
  - {type: angle, body: pinion, f: "3*t + 2*t*t"}
loads:
  - {type: torque, body: wheel, f: "-2 + sin(t)"}
analysis: {start: 0, end: 1, steps: 24}
""",
}


def point_of(res, body, s):
    if body == "ground":
        return np.full_like(res.t, s[0]), np.full_like(res.t, s[1])
    b = res.body(body)
    sx, sy = rot(b["phi"] * res.model.angle_factor, s)
    return b["x"] + sx, b["y"] + sy


KIND_MODELS["x-driver"] = KIND_MODELS["distance-x-y-angle"].replace(
    "  - {type: x, i: ground, j: a, si: [0.3, 0], sj: [0.02, 0.01], c: 0.01}",
    "  - {type: y, i: ground, j: a, si: [0, 0.1], sj: [0.02, 0.01], c: 0.0}").replace(
    '  - {type: y, body: a, f: "0.1 + 0.05*sin(2*pi*t)"}',
    '  - {type: x, body: a, f: "0.3 + 0.05*sin(2*pi*t)"}')


def _with_masses(text: str) -> str:
    """A kinematic model given gravity and a mass and inertia on every body (centre of mass
    off the frame origin), so that every element carries a load."""
    import re
    text = re.sub(r"\{q: (\[[^\]]*\])\}", r"{q: \1, mass: 1.3, inertia: 0.02, cm: [0.01, 0.02]}",
                  text)
    return "gravity: [0.5, -9.81]\n" + text


def _machine_models() -> dict:
    import test_machine_elements as tm
    root = __import__("pathlib").Path(__file__).resolve().parent.parent
    models = {name: (root / "mechanisms" / f"{name}.yaml").read_text()
              for name in ("rack-pinion-steering", "cam-roller", "belt-drive", "planetary")}
    models["roll-line"] = tm.WHEEL
    models["cam-rocker"] = tm.ROCKER
    models["roll-disc"] = tm.DISC_ON_DISC.format(x0=0.3, ri=0.2, r=0.1, w=2.0, s=0.05)
    pts = tm._circle_points(0.3, 0.2, 0.5, 90)
    models["curve-slot"] = tm.CIRCLE_SLOT.format(
        joint="{type: curve-slot, i: ground, j: block, sj: [0, 0], closed: true, curve: "
              f"{tm._table(pts)}}}")
    return {k: _with_masses(v) for k, v in models.items()}


MACHINE_KINDS = ("rack-pinion", "roll-line", "gear-mesh", "roll-disc", "belt", "cam",
                 "cam-rocker", "curve-slot")


def test_every_kind_is_covered():
    from planarkin.elements import KINDS
    assert set(JOINT_OUTPUT) == set(JOINT_KINDS)
    used = set()
    for text in list(KIND_MODELS.values()) + [SLIDE_DRIVEN, BOOM]:
        used |= {el.kind for el in load(text).spec.elements}
    machine = set()
    for text in _machine_models().values():
        machine |= {el.kind for el in load(text).spec.elements}
    assert set(MACHINE_KINDS) <= machine
    assert used | machine == set(KINDS), set(KINDS) - used - machine


@pytest.mark.parametrize("name", ["rack-pinion-steering", "cam-roller", "belt-drive",
                                  "planetary", "roll-line", "cam-rocker", "roll-disc",
                                  "curve-slot"])
def test_machine_elements_balance_on_their_bodies(name):
    """A machine element is a relation between its bodies that a rigid motion of them all
    leaves alone: the forces it puts on its bodies add up to zero, and so do their moments
    about any one point (here the origin)."""
    cm = load(_machine_models()[name])
    res = planarkin.solve(cm, steps=24)
    assert res.success, res.message
    F = Kinetostatics(cm).solve(res.t, res.q, res.qd, res.qdd)
    for e, el in enumerate(cm.spec.elements):
        if el.kind not in MACHINE_KINDS:
            continue
        sx = sy = sm = 0.0
        scale = 0.0
        P = F.point(e)
        for slot, body in enumerate(el.bodies):
            fx, fy, mo = (np.asarray(v) for v in F.reaction(e, slot))
            if P is not None:              # every slot's moment is about the element's point
                rx, ry = P
            else:
                rx, ry = point_of(res, body, (0.0, 0.0))
            sx, sy = sx + fx, sy + fy
            sm = sm + mo + rx * fy - ry * fx
            scale = max(scale, np.abs(fx).max(), np.abs(fy).max(), np.abs(mo).max())
        assert scale > 0, el.label
        assert np.abs(sx).max() <= 1e-12 * scale and np.abs(sy).max() <= 1e-12 * scale, el.label
        assert np.abs(sm).max() <= 1e-11 * scale * (1 + np.abs(res.q).max()), el.label


@pytest.mark.parametrize("name", list(KIND_MODELS) + ["slide-driven", "boom"])
def test_reaction_on_i_is_minus_reaction_on_j(name):
    cm = load({"slide-driven": SLIDE_DRIVEN, "boom": BOOM}.get(name) or KIND_MODELS[name])
    res = planarkin.solve(cm)
    assert res.success, res.message
    F = Kinetostatics(cm).solve(res.t, res.q, res.qd, res.qdd)
    for e, el in enumerate(cm.spec.elements):
        Rj = np.array(F.reaction(e, 1))
        Ri = np.array(F.reaction(e, 0))
        scale = np.abs(Rj).max() + np.abs(Ri).max()
        assert scale > 0, el.label
        if el.kind == "gear":
            # the tooth force: on i minus that on j, about the same point (j's centre); the
            # carrier k gets nothing; the moments on the gears stand in the ratio of the radii
            Rk = np.array(F.reaction(e, 2))
            assert np.abs(Rk).max() <= 1e-13 * scale
            P = np.array(F.point(e))
            Pi = np.array(point_of(res, el.bodies[0], (0.0, 0.0)))
            Mi = Ri[2] + cross(*(P - Pi), Ri[0], Ri[1])          # about i's centre (its origin)
            assert rel_err(Mi / Rj[2], np.full_like(res.t, 0.05 / 0.1)) <= 1e-12
        assert np.abs(Ri[:2] + Rj[:2]).max() <= 1e-13 * scale, el.label
        if el.kind in ("x", "y"):
            # these fix a direction of the ground frame: the forces on i (at P_i) and on j (at
            # P_j) are parallel to it and form a couple, so about P_j the moment on i is
            # (P_i - P_j) x F_i and not minus that on j
            Pj = np.array(F.point(e))
            Pi = np.array(point_of(res, el.bodies[0], el.params["si"]))
            assert np.abs(Ri[2] - cross(*(Pi - Pj), Ri[0], Ri[1])).max() <= 1e-13 * scale
        else:
            assert np.abs(Ri[2] + Rj[2]).max() <= 1e-13 * scale, el.label
        if el.role == "joint" and "torque" not in JOINT_OUTPUT[el.kind]:
            # kinds without a torque column transmit no moment about their point
            assert np.abs(Rj[2]).max() <= 1e-12 * scale, el.label
        if el.role == "joint" and JOINT_OUTPUT[el.kind] == ("torque",):
            assert np.abs(Rj[:2]).max() == 0, el.label
    # driver efforts: the generalised force on body j along the driven coordinate
    for d, el in enumerate(cm.spec.drivers):
        e = len(cm.spec.joints) + d
        fx, fy, tq = F.reaction(e, 1)
        if el.kind == "angle":
            assert rel_err(tq, F.effort(d)) <= 1e-13 and not np.abs(fx).max()
        elif el.kind in ("distance", "slide"):
            # along the line P_i -> P_j (distance) or the slide axis of i, here ground's x axis
            if el.kind == "slide":
                e_ = np.array([1.0, 0.0])[:, None]
            else:
                Pi = np.array(point_of(res, el.bodies[0], el.params["si"]))
                Pj = np.array(F.point(e))
                e_ = (Pj - Pi) / np.hypot(*(Pj - Pi))
            assert rel_err(fx * e_[0] + fy * e_[1], F.effort(d)) <= 1e-13
            assert np.abs(fx * e_[1] - fy * e_[0]).max() <= 1e-12 * np.abs(F.effort(d)).max()
        elif el.kind == "y":
            assert rel_err(fy, F.effort(d)) <= 1e-13 and not np.abs(fx).max()
        elif el.kind == "x":
            assert rel_err(fx, F.effort(d)) <= 1e-13 and not np.abs(fy).max()
        else:
            raise AssertionError(el.kind)


# -- input, API and cost --------------------------------------------------------------------------

def test_bad_force_input_is_an_input_error_through_the_api():
    bad = SLIDER_CRANK.replace(f"mass: {SC['m3']}", "mass: -2")
    with pytest.raises(planarkin.InputError) as exc:
        load(bad, "bad.yaml")
    assert str(exc.value) == ("bad.yaml:8: error: body 'slider': mass must not be negative, not "
                              "-2 (a mass)")


def test_force_at_a_global_point_equals_the_same_force_in_the_body_frame():
    # the rod's estimate (0.2, 0, -0.1 rad) is where 'at' is read: s = A^T (at - r)
    s = [float(v) for v in rot(0.1, (0.3 - 0.2, 0.05))]
    a = SLIDER_CRANK.replace("  - {type: force, name: press",
                             '  - {type: force, body: rod, at: [0.3, 0.05], f: ["7", "-3*t"]}\n'
                             "  - {type: force, name: press")
    b = SLIDER_CRANK.replace("  - {type: force, name: press",
                             f'  - {{type: force, body: rod, s: [{s[0]!r}, {s[1]!r}], '
                             f'f: ["7", "-3*t"]}}\n  - {{type: force, name: press')
    fa = planarkin.solve(load(a)).table("forces.csv")
    fb = planarkin.solve(load(b)).table("forces.csv")
    assert rel_err(fa["motor.torque"], fb["motor.torque"]) <= 1e-13
    ref = planarkin.solve(load(SLIDER_CRANK)).table("forces.csv")
    assert rel_err(fa["motor.torque"], ref["motor.torque"]) > 1e-3      # the load matters


def test_forces_api_names_and_did_you_mean(slider_crank):
    res = slider_crank
    cols = res.table("forces.csv")
    assert set(res.forces("motor")) == {"torque", "power"}
    assert set(res.forces("guide")) == {"fx", "fy", "torque"}
    assert set(res.forces("A")) == {"fx", "fy"}
    assert set(res.forces("shaking")) == {"fx", "fy", "torque"}
    assert res.forces("A")["fx"] is not None
    assert np.array_equal(res.forces("A")["fx"], cols["A.fx"])
    with pytest.raises(KeyError, match="did you mean 'motor'"):
        res.forces("motr")


def test_model_without_masses_writes_no_forces_and_pays_nothing(tmp_path):
    text = SLIDER_CRANK
    for key in (f", mass: {SC['m1']}, inertia: {SC['J1']}, cm: [{SC['c1'][0]}, {SC['c1'][1]}]",
                f", mass: {SC['m2']}, inertia: {SC['J2']}", f", mass: {SC['m3']}"):
        text = text.replace(key, "")
    text = text.split("loads:")[0] + "analysis: {start: 0, end: 1, steps: 72}\n"
    cm = load(text)
    assert cm.spec.forces is not None and cm.spec.forces.gravity is not None   # gravity alone
    res = planarkin.solve(cm)
    res.write(tmp_path, plots=None)
    assert not (tmp_path / "forces.csv").exists()
    assert '"forces":' not in (tmp_path / "summary.json").read_text()
    with pytest.raises(KeyError, match="no forces"):
        res.forces("motor")


def test_forces_summary_section(tmp_path, slider_crank):
    import json
    slider_crank.write(tmp_path, plots=None)
    s = json.loads((tmp_path / "summary.json").read_text())
    f = s["forces"]
    cols = slider_crank.table("forces.csv")
    k = int(np.argmax(np.abs(cols["motor.torque"])))
    assert f["peak"]["motor.torque"] == {"value": cols["motor.torque"][k],
                                         "abs": abs(cols["motor.torque"][k]),
                                         "t": slider_crank.t[k]}
    assert f["rms"]["motor.torque"] == pytest.approx(
        np.sqrt(np.mean(cols["motor.torque"] ** 2)), rel=1e-12)
    assert set(f["rms"]) == {"motor.torque"}
    assert f["units"]["force"] == "N" and f["left_out"] == []
    header = (tmp_path / "forces.csv").read_text().splitlines()[0]
    assert header.startswith("t [s],motor.torque [N*m],O.fx [N],O.fy [N],A.fx [N]")
    assert header.endswith("shaking.fx [N],shaking.fy [N],shaking.torque [N*m]")


def test_redundant_constraints_have_no_columns_and_are_named(tmp_path):
    """A parallelogram with a third parallel crank: every joint's reaction is non-unique (the
    three cranks may share the load in any proportion), so none gets a column; the driver torque
    and the shaking force are unique and still right (power balance)."""
    from test_extremes import parallelogram_yaml
    text = parallelogram_yaml().replace(
        "coupler: {q: [0, 1, 0]}", "coupler: {q: [0, 1, 0], mass: 2, inertia: 0.1, cm: [0.5, 0.1]}"
    ).replace("name: parallelogram", "name: parallelogram\ngravity: [0, -9.81]")
    res = planarkin.solve(load(text), steps=30, end=1.2)
    assert res.success, res.message
    cols = res.table("forces.csv")
    assert [k for k in cols if ".f" in k or k.endswith("torque")] == [
        "driver_1_angle_ground-crank1.torque", "shaking.fx", "shaking.fy", "shaking.torque"]
    drivers, balance = power_balance(res)
    assert np.abs(drivers - balance).max() <= 1e-12 * np.abs(balance).max()
    # the coupler only translates on unit circles: its weight and inertia are carried as if hung
    # at the crank tip; shaking force = weight + inertia of the coupler (the cranks are massless)
    th = np.pi / 2 + res.t
    a = -np.array([np.cos(th), np.sin(th)])              # centripetal acceleration, w = 1
    assert rel_err(cols["shaking.fx"], -2 * a[0]) <= 1e-12
    assert rel_err(cols["shaking.fy"], 2 * G - 2 * a[1]) <= 1e-12
    s = res.write(tmp_path, plots=None)
    assert len(s["forces"]["left_out"]) == 6
    assert any("redundant constraints have no unique reaction" in n for n in s["forces"]["notes"])


def test_near_singular_warning_says_reactions_grow_without_bound():
    from test_extremes import R_CRANK, slider_crank_yaml
    text = slider_crank_yaml(R_CRANK, R_CRANK * (1 + 1e-6))
    plain = planarkin.solve(load(text), steps=36)
    heavy = text.replace("name: slider-crank", "name: toggle\ngravity: [0, -9.81]").replace(
        "slider: {q:", "slider: {mass: 1, q:")
    massive = planarkin.solve(load(heavy), steps=36)
    near = [w for w in massive.warnings if w.kind != "toggle"]      # (the loop's: test_loops)
    assert [w.kind for w in near] == ["near-singular"] * 2
    for w in near:
        assert w.message.endswith("; joint reactions and driver efforts grow without bound near "
                                  "such a configuration (forces.csv)")
    assert all("grow without bound" not in w.message for w in plain.warnings)
    torque = np.abs(massive.forces("driver_1_angle_ground-crank")["torque"])
    assert torque.max() > 1e2 * np.median(torque)


def test_forces_plot(tmp_path, slider_crank):
    """(DirectoryWriter lists it in summary.json: tests/test_plots.py, the slider-crank example.)"""
    from PIL import Image
    from planarkin.derived import derived_tables
    res = slider_crank
    d, loads = derived_tables(res.model, res.info.options)
    assert loads.filename == "loads.csv" and loads.plot is None
    files = d.plot(res.model, d.compute(res._chunk), res.info, tmp_path, "png")
    assert [f.name for f in files] == ["forces.png"]
    with Image.open(tmp_path / "forces.png") as im:
        assert im.width >= 1000 and im.height >= 500


def test_block_triangular_solve_equals_the_dense_one():
    """Large models solve Phi_q^T lambda = rhs block by block (the transposed block-triangular
    form); on a 4-loop chain with masses, loads and a spring both ways agree to rounding, and the
    power balance holds."""
    sys_path = str(__import__("pathlib").Path(__file__).resolve().parent.parent / "benchmarks")
    import sys
    sys.path.insert(0, sys_path)
    try:
        import models
    finally:
        sys.path.remove(sys_path)
    text = "\n".join(ln.replace("0]}", "0], mass: 1.5, inertia: 0.2, cm: [0.3, 0.1]}")
                     if ln.startswith(("  k", "  c1")) else ln
                     for ln in models.chain_yaml(4).splitlines())
    text = text.replace("analysis:", "gravity: [0, -9.81]\nloads:\n"
                        '  - {type: force, body: k3, s: [0.5, 0], f: ["10*t", "-20"]}\n'
                        "  - {type: spring, i: ground, j: k1, si: [1, 3], sj: [0.5, 0], k: 50, "
                        "length: 1}\nanalysis:")
    cm = load(text)
    res = planarkin.solve(cm, steps=40)
    assert res.success, res.message
    dense = Kinetostatics(cm, dense=True).solve(res.t, res.q, res.qd, res.qdd)
    blocks = Kinetostatics(cm, dense=False)
    assert len(blocks.blocked.blocks) > 1
    FB_ = blocks.solve(res.t, res.q, res.qd, res.qdd)
    assert np.abs(FB_.lam - dense.lam).max() <= 1e-12 * np.abs(dense.lam).max()
    _, balance = power_balance(res)
    assert np.abs(FB_.power(0) - balance).max() <= 1e-12 * np.abs(balance).max()


def test_cli_run_writes_forces_through_the_background_writer(tmp_path):
    """`planarkin run` formats tables in forked writer processes: forces.csv, its statistics and
    the room's summary section come through them (the boom example: its cylinder force)."""
    import csv
    import json
    from clitools import run_cli
    r = run_cli("run", "mechanisms/boom.yaml", "--out", tmp_path, "--no-plots", "--steps", "40")
    assert r.returncode == 0, r.stderr
    d = tmp_path / "boom"
    with open(d / "forces.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["t [s]", "cylinder.force [N]", "pivot.fx [N]", "pivot.fy [N]",
                       "cylinder.power [W]", "total.power [W]", "shaking.fx [N]",
                       "shaking.fy [N]", "shaking.torque [N*m]"]
    assert len(rows) == 42
    s = json.loads((d / "summary.json").read_text())
    force = np.array([float(row[1]) for row in rows[1:]])
    assert (force > 0).all()                              # the cylinder pushes the load up
    assert s["forces"]["peak"]["cylinder.force"]["abs"] == force.max()
    assert s["columns"]["forces.csv"]["cylinder.force [N]"]["max"] == force.max()


def test_units_follow_the_length_unit():
    """The loaded boom drawn in mm (masses in kg): forces come out in kg*mm/s^2 = 1e-3 N, torques
    in kg*mm^2/s^2 = 1e-6 N*m, power in kg*mm^2/s^3 = 1e-6 W, each header saying so."""
    mm = (BOOM.replace("units: {length: m, angle: deg}", "units: {length: mm, angle: deg}")
          .replace("gravity: [0, -9.81]", "gravity: [0, -9810]")
          .replace("inertia: 160, cm: [2.0, 0.1]", "inertia: 160e6, cm: [2000, 100]")
          .replace("si: [0.8, -0.6], sj: [1.5, 0], f: \"1.2 + 0.15*t + 0.05*sin(3*t)\"",
                   "si: [800, -600], sj: [1500, 0], f: \"1200 + 150*t + 50*sin(3*t)\"")
          .replace('s: [4.0, 0], f: ["0", "-2000"]', 's: [4000, 0], f: ["0", "-2000e3"]'))
    assert mm.count("mm") == 1 and "4000" in mm and "2000e3" in mm
    a = planarkin.solve(load(BOOM)).table("forces.csv")
    b = planarkin.solve(load(mm)).table("forces.csv")
    for key, factor in (("cylinder.force", 1e3), ("joint_1_revolute_ground-boom.fx", 1e3),
                        ("cylinder.power", 1e6), ("shaking.torque", 1e6)):
        assert rel_err(b[key], factor * a[key]) <= 1e-12, key
    from planarkin.derived import derived_tables
    from planarkin.solver.grid import Options
    cm = load(mm)
    d, loads = derived_tables(cm, Options.from_model(cm))
    assert "joint_1_revolute_ground-boom.boom.direction [deg]" in loads.header
    assert "joint_1_revolute_ground-boom.magnitude [kg*mm/s^2]" in loads.header
    assert d.header[1] == "cylinder.force [kg*mm/s^2]"
    assert d.header[-1] == "shaking.torque [kg*mm^2/s^2]"
    assert "cylinder.power [kg*mm^2/s^3]" in d.header


def test_the_runs_forces_table_reuses_the_checks_applied_forces_exactly(tmp_path):
    # `run` hands the refusal check's Q^A, Q^in to the forces table (forces.output.APPLIED_MEMO)
    # and each reaction is computed once for its fx, fy, torque columns: the bytes of forces.csv
    # are those of the table computed afresh from the same rows
    from click.testing import CliRunner

    from planarkin.cli import main
    from planarkin.derived import derived_tables
    from planarkin.forces import output as fo
    from planarkin.output.fastcsv import format_table
    r = CliRunner().invoke(main, ["run", "mechanisms/slider-crank.yaml", "--no-plots", "--steps",
                                  "20000", "-q", "--out", str(tmp_path)])
    assert r.exit_code == 0, r.output
    res = planarkin.solve("mechanisms/slider-crank.yaml", steps=20000)
    fo.APPLIED_MEMO.clear()
    calls = []
    gf = Kinetostatics.generalised_forces

    def counted(self, *a):
        calls.append(1)
        return gf(self, *a)
    Kinetostatics.generalised_forces = counted
    try:
        d = [d for d in derived_tables(res.model, res.info.options) if d.filename == "forces.csv"]
        X = d[0].compute(res._chunk) + 0.0
    finally:
        Kinetostatics.generalised_forces = gf
    assert calls                                    # computed afresh here
    want = (",".join(d[0].header) + "\n").encode() + format_table(X)
    assert (tmp_path / "slider-crank" / "forces.csv").read_bytes() == want
