"""Machine elements transmit physical forces where their parts touch (issue 21, item 1).

A cam presses on its follower along the common normal at the contact, gear teeth along the line
of action at the pitch point, a belt pulls along its tight run. Their bearings then carry these
forces: every body satisfies Newton-Euler with the reactions as forces.csv reports them (each
machine element's force on i is minus that on j, at the same point; the frame k gets nothing).
Closed forms derived by hand: a flat tappet on a cam, a gear pair and a belt drive on fixed
bearings.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.forces.solve import Kinetostatics

ROOT = Path(__file__).resolve().parent.parent
MACHINE = ("gear", "rack-pinion", "roll-line", "gear-mesh", "roll-disc", "belt", "cam",
           "cam-rocker", "curve-slot")


def load(text, name="model.yaml"):
    return planarkin.load(name, text=text)


def forces_of(text, steps=None):
    cm = load(text)
    res = planarkin.solve(cm, steps=steps) if steps else planarkin.solve(cm)
    assert res.success, res.message
    return cm, res, Kinetostatics(cm).solve(res.t, res.q, res.qd, res.qdd)


def rot(phi, v):
    c, s = np.cos(phi), np.sin(phi)
    return c * v[0] - s * v[1], s * v[0] + c * v[1]


def with_masses(text: str) -> str:
    """Gravity and a mass, an inertia and an off-frame centre of mass on every body."""
    text = re.sub(r"\{q: (\[[^\]]*\])\}", r"{q: \1, mass: 1.3, inertia: 0.02, cm: [0.011, 0.017]}",
                  text)
    return "gravity: [0.5, -9.81]\n" + text


def newton_euler(cm, res, F):
    """Largest residual of Newton-Euler over all bodies and rows, relative to the largest force
    (or moment over the model's size): sum of the reported reactions (forces.csv's, each
    element's force on i minus that on j), gravity and loads minus m a_c; moments about c
    minus J alpha."""
    spec = cm.spec
    af = cm.angle_factor
    fs = spec.forces
    masses = {m.body: m for m in fs.masses}
    g = np.zeros(2) if fs.gravity is None else np.array(fs.gravity)
    worst, scale = 0.0, 0.0
    size = max(np.abs(res.q[:, 0::3]).max(), np.abs(res.q[:, 1::3]).max(), 1e-3)
    for body in cm.body_names:
        b = res.body(body)
        phi, w, al = b["phi"] * af, b["omega"] * af, b["alpha"] * af
        m = masses.get(body)
        mass, J, c = (m.mass, m.inertia, m.cm) if m else (0.0, 0.0, (0.0, 0.0))
        scx, scy = rot(phi, c)
        cx, cy = b["x"] + scx, b["y"] + scy
        acx = b["ax"] - al * scy - w * w * scx
        acy = b["ay"] + al * scx - w * w * scy
        Fx, Fy = mass * g[0] - mass * acx, mass * g[1] - mass * acy
        M = -J * al
        for e, el in enumerate(spec.elements):
            for slot, name in enumerate(el.bodies):
                if name != body:
                    continue
                fx, fy, mo = (np.asarray(v) for v in F.reaction(e, slot))
                P = F.point(e)
                if P is None:
                    P = (b["x"], b["y"])
                Fx, Fy = Fx + fx, Fy + fy
                M = M + mo + (P[0] - cx) * fy - (P[1] - cy) * fx
                scale = max(scale, np.abs(fx).max(), np.abs(fy).max(), np.abs(mo).max() / size)
        for ld in fs.loads:
            if ld.bodies[0] != body:
                continue
            if ld.kind == "torque":
                M = M + np.broadcast_to(ld.f[0](res.t), res.t.shape)
            elif ld.kind == "force":
                assert ld.at is None
                fx, fy = (np.broadcast_to(f(res.t), res.t.shape) for f in ld.f)
                sx, sy = rot(phi, ld.s)
                Fx, Fy = Fx + fx, Fy + fy
                M = M + (b["x"] + sx - cx) * fy - (b["y"] + sy - cy) * fx
            else:
                raise AssertionError(ld.kind)
        worst = max(worst, np.abs(Fx).max(), np.abs(Fy).max(), np.abs(M).max() / size)
    return worst / scale


def third_law(cm, F):
    """Each machine element: its force on i is minus that on j with the moment about the same
    point, and the frame k gets nothing, so forces.csv's columns (on j) say everything."""
    for e, el in enumerate(cm.spec.elements):
        if el.kind not in MACHINE:
            continue
        Ri, Rj = np.array(F.reaction(e, 0)), np.array(F.reaction(e, 1))
        s = np.abs(Rj).max()
        assert s > 0, el.label
        assert np.abs(Ri + Rj).max() <= 1e-12 * s, el.label
        if len(el.bodies) == 3:
            assert np.abs(np.array(F.reaction(e, 2))).max() <= 1e-12 * s, el.label


EXAMPLES = ("valve-cam", "cam-roller", "flat-rocker-cam", "planetary", "belt-drive",
            "rack-pinion-steering", "curved-slot")


@pytest.mark.parametrize("name", EXAMPLES)
def test_every_body_of_the_machine_element_examples_obeys_newton_euler(name):
    text = with_masses((ROOT / "mechanisms" / f"{name}.yaml").read_text())
    cm, res, F = forces_of(text, steps=48)
    assert any(el.kind in MACHINE for el in cm.spec.elements)
    assert newton_euler(cm, res, F) <= 1e-9
    third_law(cm, F)
    assert not F.moved


# -- a valve train: flat tappet on a cam, the cam on a revolute bearing, constant speed ----------
# Law s = h (1 - cos theta) / 2 over the whole turn, omega = 2 pi rad/s. The tappet (mass m on its
# axis x = 0) is pressed down by a spring preload P. Vertically m s'' omega^2 = f - P, so the
# contact force is f = P + m omega^2 h cos(theta) / 2. A flat face touches the cam where the face
# point's velocity seen from the cam is along the face: at x = ds/dtheta = h sin(theta) / 2 off
# the axis. The camshaft bearing carries f upwards (the cam is massless), the guide the moment
# -f ds/dtheta about the tappet's axis point, and the motor torque is f ds/dtheta.
VALVE = """
name: valve-train
units: {length: m, angle: rad}
parameters: {h: 0.01, rb: 0.03}
bodies:
  cam:    {q: [0, 0, 0]}
  tappet: {q: [0, 0.03, 0], mass: 0.5}
joints:
  - {type: revolute, name: bearing, i: ground, j: cam, at: [0, 0]}
  - {type: translational, name: guide, i: ground, j: tappet, at: [0, 0.03], axis: [0, 1]}
  - {name: valve, type: cam, i: cam, j: tappet, sk: [0, 0], vk: [0, 1], sj: [0, 0], base: rb,
     flat: true, s: "h*(1 - cos(theta))/2"}
drivers:
  - {type: angle, name: motor, body: cam, f: "2*pi*t"}
loads:
  - {type: force, body: tappet, f: ["0", "-200"]}
analysis: {start: 0, end: 1, steps: 72}
"""


def test_valve_train_bearing_guide_and_contact_in_closed_form():
    cm, res, F = forces_of(VALVE)
    th = 2 * np.pi * res.t
    h, m, P, w = 0.01, 0.5, 200.0, 2 * np.pi
    f = P + m * w * w * h * np.cos(th) / 2
    ds = h * np.sin(th) / 2
    names = {el.name: e for e, el in enumerate(cm.spec.elements)}
    cx, cy, cm_ = F.reaction(names["valve"], 1)
    assert np.abs(cx).max() <= 1e-12 * P and np.abs(cy - f).max() <= 1e-11 * P
    assert np.abs(cm_ - f * ds).max() <= 1e-11 * P * h         # about the tappet's axis point
    bx, by, _ = F.reaction(names["bearing"], 1)                   # on the cam
    assert np.abs(bx).max() <= 1e-12 * P and np.abs(by - f).max() <= 1e-11 * P
    gx, gy, gm = F.reaction(names["guide"], 1)
    assert np.abs(gx).max() <= 1e-12 * P and np.abs(gy).max() <= 1e-11 * P
    assert np.abs(gm + f * ds).max() <= 1e-11 * P * h
    assert np.abs(F.effort(0) - f * ds).max() <= 1e-11 * P * h
    assert np.abs(F.contact(names["valve"]) - f).max() <= 1e-11 * P
    assert newton_euler(cm, res, F) <= 1e-9


# -- a gear pair on fixed bearings ---------------------------------------------------------------
# Gear i (ri) at the origin turned by a motor, gear j (rj) at (ri + rj, 0) held back by a torque
# T (counter-clockwise: j turns clockwise). The teeth put -T on j: a tangential force
# F_t = T / rj along +y at the pitch point (ri, 0) and F_t tan(alpha) along +x (apart), so
# |F| = T / (rj cos alpha); the bearing of j carries minus that, the bearing of i plus it.
GEARS = """
name: gear-pair
units: {{length: m, angle: deg}}
bodies:
  a: {{q: [0, 0, 0]}}
  b: {{q: [0.15, 0, 0]}}
joints:
  - {{type: revolute, name: Oa, i: ground, j: a, at: [0, 0]}}
  - {{type: revolute, name: Ob, i: ground, j: b, at: [0.15, 0]}}
  - {{type: {kind}, name: teeth, i: a, j: b, {keys}{extra}}}
drivers:
  - {{type: angle, name: motor, body: a, f: "90*t"}}
loads:
  - {{type: torque, body: b, f: "12 + 3*sin(t)"}}
analysis: {{start: 0, end: 2, steps: 20}}
"""
GEAR_KEYS = {"gear": "ri: 0.05, rj: 0.1", "gear-mesh": "si: [0, 0], sj: [0, 0], ri: 0.05, rj: 0.1"}


@pytest.mark.parametrize("kind", ["gear", "gear-mesh"])
@pytest.mark.parametrize("alpha", [None, 25.0, 0.0])
def test_gear_pair_bearings_carry_the_tooth_force(kind, alpha):
    extra = "" if alpha is None else f", pressure_angle: {alpha}"
    cm, res, F = forces_of(GEARS.format(kind=kind, keys=GEAR_KEYS[kind], extra=extra))
    T = 12 + 3 * np.sin(res.t)
    a = math.radians(20.0 if alpha is None else alpha)
    ft = T / 0.1
    tx, ty, tm = F.reaction(2, 1)                                 # on b
    assert np.abs(ty - ft).max() <= 1e-12 * ft.max()
    assert np.abs(tx - ft * math.tan(a)).max() <= 1e-12 * ft.max()
    assert np.abs(np.hypot(tx, ty) - T / (0.1 * math.cos(a))).max() <= 1e-12 * ft.max()
    assert np.abs(tm + T).max() <= 1e-12 * T.max()               # about b's centre
    px, py = F.point(2)
    assert np.abs(px - 0.15).max() <= 1e-15 and np.abs(py).max() <= 1e-15
    bx, by, _ = F.reaction(1, 1)
    assert np.abs(bx + tx).max() <= 1e-12 * ft.max() and np.abs(by + ty).max() <= 1e-12 * ft.max()
    ax, ay, _ = F.reaction(0, 1)
    assert np.abs(ax - tx).max() <= 1e-12 * ft.max() and np.abs(ay - ty).max() <= 1e-12 * ft.max()
    assert newton_euler(cm, res, F) <= 1e-9
    third_law(cm, F)


def test_pressure_angle_is_validated():
    text = GEARS.format(kind="gear", keys=GEAR_KEYS["gear"], extra=", pressure_angle: 60")
    with pytest.raises(planarkin.InputError) as e:
        load(text)
    assert "pressure_angle must be between 0 and 45 deg, not 60 deg" in str(e.value)


# -- a belt drive on fixed bearings --------------------------------------------------------------
# Pulleys r1 at the origin (motor, counter-clockwise) and r2 at (c, 0), open belt: both turn
# counter-clockwise; a torque -T on pulley 2 holds it back. The belt must put +T on pulley 2: the
# upper run, pulling towards pulley 1, is tight with tension T / r2, the lower one slack. With
# sb = (r1 - r2) / c the upper run touches the pulleys at r1 m and (c, 0) + r2 m, m = (sb,
# sqrt(1 - sb^2)).
BELT = """
name: belt-pull
units: {length: m, angle: deg}
bodies:
  p1: {q: [0, 0, 0]}
  p2: {q: [0.4, 0, 0]}
joints:
  - {type: revolute, name: O1, i: ground, j: p1, at: [0, 0]}
  - {type: revolute, name: O2, i: ground, j: p2, at: [0.4, 0]}
  - {type: belt, name: belt, i: p1, j: p2, ri: 0.05, rj: 0.125}
drivers:
  - {type: angle, body: p1, f: "360*t"}
loads:
  - {type: torque, body: p2, f: "-15.625"}
analysis: {start: 0, end: 1, steps: 12}
"""


def test_belt_drive_shafts_carry_the_belt_pull():
    cm, res, F = forces_of(BELT)
    c, r1, r2, T = 0.4, 0.05, 0.125, 15.625
    sb = (r1 - r2) / c
    m = np.array([sb, math.sqrt(1 - sb * sb)])
    Ti, Tj = r1 * m, np.array([c, 0.0]) + r2 * m
    pull = T / r2 * (Ti - Tj) / np.hypot(*(Ti - Tj))             # 125 N towards pulley 1
    fx, fy, mo = F.reaction(2, 1)
    assert np.abs(fx - pull[0]).max() <= 1e-12 * 125 and np.abs(fy - pull[1]).max() <= 1e-12 * 125
    assert np.abs(mo - T).max() <= 1e-12 * T
    bx, by, _ = F.reaction(1, 1)                                  # the driven shaft's bearing
    assert np.abs(bx + pull[0]).max() <= 1e-12 * 125 and np.abs(by + pull[1]).max() <= 1e-12 * 125
    ax, ay, _ = F.reaction(0, 1)                                  # the motor shaft's bearing
    assert np.abs(ax - pull[0]).max() <= 1e-12 * 125 and np.abs(ay - pull[1]).max() <= 1e-12 * 125
    assert newton_euler(cm, res, F) <= 1e-9
    # reversed torque: the lower run is the tight one
    cm, res, F = forces_of(BELT.replace('f: "-15.625"', 'f: "15.625"'))
    m = np.array([sb, -math.sqrt(1 - sb * sb)])
    Ti, Tj = r1 * m, np.array([c, 0.0]) + r2 * m
    pull = T / r2 * (Ti - Tj) / np.hypot(*(Ti - Tj))
    fx, fy, mo = F.reaction(2, 1)
    assert np.abs(fx - pull[0]).max() <= 1e-12 * 125 and np.abs(fy - pull[1]).max() <= 1e-12 * 125
    assert newton_euler(cm, res, F) <= 1e-9


def test_every_kind_states_its_reaction_sign():
    from planarkin.elements import KINDS, reaction_table
    assert all(k.reaction_sign for k in KINDS.values()), [n for n, k in KINDS.items()
                                                          if not k.reaction_sign]
    table = reaction_table()
    assert all(f"`{n}`" in table for n in KINDS)


def test_belt_pretension_loads_both_runs():
    # pretension 100 N, tension difference 125 N: slack 100 - 62.5 = 37.5 N, tight 162.5 N
    text = BELT.replace("ri: 0.05, rj: 0.125}", "ri: 0.05, rj: 0.125, pretension: 100}")
    cm, res, F = forces_of(text)
    c, r1, r2 = 0.4, 0.05, 0.125
    sb = (r1 - r2) / c
    want = np.zeros(2)
    for side, T in ((1.0, 162.5), (-1.0, 37.5)):
        m = np.array([sb, side * math.sqrt(1 - sb * sb)])
        Ti, Tj = r1 * m, np.array([c, 0.0]) + r2 * m
        want += T * (Ti - Tj) / np.hypot(*(Ti - Tj))
    fx, fy, mo = F.reaction(2, 1)
    assert np.abs(fx - want[0]).max() <= 1e-12 * 200 and np.abs(fy - want[1]).max() <= 1e-12 * 200
    assert np.abs(mo - 15.625).max() <= 1e-12 * 15.625
    assert newton_euler(cm, res, F) <= 1e-9
    with pytest.raises(planarkin.InputError) as e:
        load(BELT.replace("ri: 0.05, rj: 0.125}", "ri: 0.05, rj: 0.125, pretension: -1}"))
    assert "pretension must not be negative, not -1" in str(e.value)
