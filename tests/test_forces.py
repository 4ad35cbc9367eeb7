"""Kinetostatics (planarkin.forces) against closed forms derived by hand, invariants and hand
statics.

The references here do not use the solver's Jacobians or multipliers: the slider-crank and the
four-bar are solved in closed form (positions by trigonometry, velocities and accelerations by
differentiating the loop equations by hand) and their forces by free-body Newton-Euler equations
written out link by link; the power balance uses only the result's exact q, q', q''. Errors are
relative to the largest magnitude of the compared column over the run, at every grid point.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import planarkin
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
    psi = np.arcsin(-a * np.sin(th) / b)
    psd = -a * np.cos(th) * thd / (b * np.cos(psi))
    psdd = (-a * (np.cos(th) * thdd - np.sin(th) * thd ** 2) + b * np.sin(psi) * psd ** 2) / (
        b * np.cos(psi))
    e = np.array([np.cos(psi), np.sin(psi)])
    a2 = aA + c2 * (psdd * np.array([-e[1], e[0]]) - psd ** 2 * e)
    xB = a * np.cos(th) + b * np.cos(psi)
    xBdd = -a * (np.cos(th) * thd ** 2 + np.sin(th) * thdd) - b * (np.cos(psi) * psd ** 2
                                                                   + np.sin(psi) * psdd)
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
    D = O4 - rA
    dl = np.hypot(D[0], D[1])
    u = D / dl
    along = (b * b - c * c + dl * dl) / (2 * dl)
    h = np.sqrt(b * b - along ** 2)
    B = rA + along * u + h * R(u)                       # the open branch: B left of A -> O4
    e3 = (B - rA) / b
    e4 = (B - O4) / c
    th3 = np.arctan2(e3[1], e3[0])
    th4 = np.arctan2(e4[1], e4[0])
    # loop rA + b e3 = O4 + c e4, differentiated by hand: 2 x 2 systems by Cramer's rule
    M11, M21 = b * R(e3)
    M12, M22 = -c * R(e4)
    det = M11 * M22 - M12 * M21
    solve = lambda r: ((r[0] * M22 - M12 * r[1]) / det, (M11 * r[1] - r[0] * M21) / det)
    w3, w4 = solve(-a * thd * R(e2))
    al3, al4 = solve(-a * thdd * R(e2) + a * thd ** 2 * e2 + b * w3 ** 2 * e3 - c * w4 ** 2 * e4)
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
