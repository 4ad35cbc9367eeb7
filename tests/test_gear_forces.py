"""Gear, rack and pinion reactions: the tooth force along the line of action (issue 33).

The teeth of a pair push on each other along the line of action through the pitch point, at the
pressure angle alpha to the pitch circles' tangent. A gear of pitch radius r that passes a torque
T gets a tooth force of magnitude T / r_b, r_b = r cos(alpha) its base radius: a tangential part
T / r (the only part that turns the gears) and a radial part (T / r) tan(alpha) that pushes the
gears apart and that only the bearings take. Closed forms derived by hand below; every body of
every model also obeys Newton-Euler with the reported reactions at every grid row
(test_contact_forces.newton_euler), each element's force on i is minus that on j at the same
point and the carrier k gets nothing (test_contact_forces.third_law).

Finding 2 of the issue: a `gear` on a driven carrier whose sun turns on the frame (about the
carrier's axis, not on a revolute joint to the carrier) had no known centre, and its reaction
was the constraint's couples alone: no tooth force, bearings off by the whole of it, no warning.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import planarkin
from planarkin.cli import main

from test_contact_forces import forces_of, newton_euler, third_law

ROOT = Path(__file__).resolve().parent.parent
TOL = 1e-9          # relative to the largest force of the model


def names(cm) -> dict:
    return {el.name: e for e, el in enumerate(cm.spec.elements) if el.name}


def close(got, want, scale, tol=TOL):
    got, want = np.broadcast_arrays(np.asarray(got, float), np.asarray(want, float))
    err = np.abs(got - want).max() / scale
    assert err <= tol, f"relative error {err:.3g}"


def balanced(cm, res, F):
    assert not F.moved
    assert newton_euler(cm, res, F) <= TOL
    third_law(cm, F)


# -- a loaded spur pair on fixed bearings --------------------------------------------------------
# Pinion a (ra) turns on the frame at the origin, driven at constant speed; gear b (rb) turns at
# C = (ra + rb) (cos beta, sin beta), held back by a torque T(t) (counter-clockwise). Both have
# their centre of mass on their axis, so at constant speed their bearings feel no inertia
# (alpha_b = 0 too: b turns at -ra/rb times a's speed). With e the unit vector from a's centre to
# b's and t = R e, b's tooth force at the pitch point ra e must have the moment -T about b's
# centre: (-rb e) x (F_t t) = -rb F_t, so F_t = T / rb; the radial part pushes b away from a:
# F = (T / rb) (t + tan(alpha) e), |F| = T / (rb cos alpha). Bearing of b: -F - m_b g; bearing
# of a: +F - m_a g. Gear a gets -F at ra e, of moment (ra e) x (-F_t t) = -ra F_t about its
# centre: the motor's torque on a is ra F_t = ra T / rb.
SPUR = """
name: spur
units: {{length: m, angle: deg}}
gravity: [0, -9.81]
parameters: {{ra: 0.05, rb: 0.1, beta: 35}}
bodies:
  a: {{q: [0, 0, 10], mass: 2, inertia: 0.004}}
  b: {{q: [(ra + rb)*cos(beta*pi/180), (ra + rb)*sin(beta*pi/180), -20], mass: 5,
       inertia: 0.03}}
joints:
  - {{type: revolute, name: Oa, i: ground, j: a, at: [0, 0]}}
  - {{type: revolute, name: Ob, i: ground, j: b,
     at: [(ra + rb)*cos(beta*pi/180), (ra + rb)*sin(beta*pi/180)]}}
  - {{type: {kind}, name: teeth, i: a, j: b, {keys}{extra}}}
drivers:
  - {{type: angle, name: motor, body: a, f: "90*t"}}
loads:
  - {{type: torque, body: b, f: "{torque}"}}
analysis: {{start: 0, end: 2, steps: 16}}
"""
SPUR_KEYS = {"gear": "ri: ra, rj: rb",
             "gear-mesh": "si: [0, 0], sj: [0, 0], ri: ra, rj: rb"}


@pytest.mark.parametrize("kind", ["gear", "gear-mesh"])
@pytest.mark.parametrize("alpha", [None, 14.5, 25.0])
@pytest.mark.parametrize("torque", ["40 + 3*sin(t)", "-25"])
def test_loaded_spur_pair_tooth_force_and_bearings_in_closed_form(kind, alpha, torque):
    extra = "" if alpha is None else f", pressure_angle: {alpha}"
    cm, res, F = forces_of(SPUR.format(kind=kind, keys=SPUR_KEYS[kind], extra=extra,
                                       torque=torque))
    e = names(cm)
    ra, rb, beta = 0.05, 0.1, math.radians(35)
    a = math.radians(20.0 if alpha is None else alpha)
    T = np.broadcast_to(eval(torque.replace("sin", "np.sin"), {"np": np, "t": res.t}),
                        res.t.shape)
    ex, ey = math.cos(beta), math.sin(beta)
    tx, ty = -ey, ex
    ft = T / rb
    fr = np.abs(ft) * math.tan(a)                         # apart, whatever the torque's sense
    Fx, Fy = ft * tx + fr * ex, ft * ty + fr * ey
    scale = np.abs(T).max() / (rb * math.cos(a))
    gx, gy, gm = F.reaction(e["teeth"], 1)
    close(gx, Fx, scale)
    close(gy, Fy, scale)
    close(np.hypot(gx, gy), np.abs(T) / (rb * math.cos(a)), scale)   # T / r_b
    close(gm, -T, np.abs(T).max())                        # about b's centre
    px, py = F.point(e["teeth"])
    close(px, (ra + rb) * ex, ra + rb, 1e-14)
    close(py, (ra + rb) * ey, ra + rb, 1e-14)
    g = 9.81
    bx, by, _ = F.reaction(e["Ob"], 1)
    close(bx, -Fx, scale)
    close(by, -Fy + 5 * g, scale)
    ax, ay, _ = F.reaction(e["Oa"], 1)
    close(ax, Fx, scale)
    close(ay, Fy + 2 * g, scale)
    close(F.effort(0), ra * T / rb, np.abs(T).max())
    balanced(cm, res, F)


def test_the_forces_table_carries_the_radial_part():
    """What forces.csv writes is what the closed form says (the table, not only the API)."""
    cm = planarkin.load("spur.yaml", text=SPUR.format(kind="gear", keys=SPUR_KEYS["gear"],
                                                      extra="", torque="40"))
    res = planarkin.solve(cm)
    assert res.success, res.message
    tab = res.table("forces.csv")
    ft, beta = 400.0, math.radians(35)
    fr = ft * math.tan(math.radians(20))
    close(tab["teeth.fx"], -ft * math.sin(beta) + fr * math.cos(beta), ft)
    close(tab["teeth.fy"], ft * math.cos(beta) + fr * math.sin(beta), ft)
    close(tab["Ob.fx"], -tab["teeth.fx"], ft)
    close(tab["Oa.fx"], tab["teeth.fx"], ft)


# -- an internal pair: pinion inside a ring, both on the frame -----------------------------------
# Ring a (pitch radius R, written -R) at the origin, driven; pinion b (r) at (R - r) e, held back
# by T. The pitch point R e lies beyond b's centre, at +r e from it: the tooth force F = F_t t +
# F_r e has the moment (r e) x (F_t t) = r F_t = -T about it, so F_t = -T / r; the radial part
# pushes the pinion towards its own centre from the pitch point, along -e: F_r = -|F_t| tan
# alpha. The ring gets -F at R e, of moment -R F_t: the motor's torque on the ring is -R T / r.
RING = """
name: ring
units: {length: m, angle: rad}
parameters: {R: 0.12, r: 0.04}
bodies:
  ring: {q: [0, 0, 0]}
  pinion: {q: [(R - r)*cos(0.6), (R - r)*sin(0.6), 0]}
joints:
  - {type: revolute, name: Oring, i: ground, j: ring, at: [0, 0]}
  - {type: revolute, name: Opin, i: ground, j: pinion, at: [(R - r)*cos(0.6), (R - r)*sin(0.6)]}
  - {type: KIND, name: teeth, i: ring, j: pinion, KEYS, pressure_angle: 0.4}
drivers:
  - {type: angle, name: motor, body: ring, f: "3*t + sin(t)"}
loads:
  - {type: torque, body: pinion, f: "6 + cos(2*t)"}
analysis: {end: 1, steps: 10}
"""


@pytest.mark.parametrize("kind, keys", [("gear", "ri: -R, rj: r"),
                                        ("gear-mesh", "si: [0, 0], sj: [0, 0], ri: -R, rj: r")])
def test_internal_pair_tooth_force_points_into_the_pinion(kind, keys):
    cm, res, F = forces_of(RING.replace("KIND", kind).replace("KEYS", keys))
    e = names(cm)
    R, r = 0.12, 0.04
    ex, ey = math.cos(0.6), math.sin(0.6)
    tx, ty = -ey, ex
    T = 6 + np.cos(2 * res.t)
    ft = -T / r
    fr = -np.abs(ft) * math.tan(0.4)
    scale = T.max() / (r * math.cos(0.4))
    gx, gy, gm = F.reaction(e["teeth"], 1)
    close(gx, ft * tx + fr * ex, scale)
    close(gy, ft * ty + fr * ey, scale)
    close(gm, -T, T.max())
    bx, by, _ = F.reaction(e["Opin"], 1)
    close(bx, -gx, scale)
    close(by, -gy, scale)
    close(F.effort(0), -R * T / r, R * T.max() / r)      # the ring turns the pinion the same way
    balanced(cm, res, F)


# -- rack and pinion -----------------------------------------------------------------------------
# The pinion (r) turns on the frame at the origin (the motor); the rack lies above it, its pitch
# line y = r, on a guide along x, and a force -P along x holds it back. The rack's tooth force
# along x is +P; the pinion gets minus it at the pitch point (0, r) and the radial part pushing
# it away from the rack, down: F = (-P, -P tan alpha). The motor's torque on the pinion is minus
# the moment of F about its centre: -(0 * Fy - r * Fx) = -r P. The guide takes the rack's radial
# part: (0, -P tan alpha) on the rack; the pinion's bearing -F.
RACK = """
name: rack
units: {length: m, angle: deg}
parameters: {r: 0.02}
bodies:
  pinion: {q: [0, 0, 0]}
  rack: {q: [0, r, 0]}
joints:
  - {type: revolute, name: bearing, i: ground, j: pinion, at: [0, 0]}
  - {type: translational, name: guide, i: ground, j: rack, at: [0, r], axis: [1, 0]}
  - {type: rack-pinion, name: teeth, i: rack, j: pinion, si: [0, 0], vi: [1, 0], sj: [0, 0],
     r: r EXTRA}
drivers:
  - {type: angle, name: motor, body: pinion, f: "30*sin(pi*t)"}
loads:
  - {type: force, body: rack, f: ["-P", "0"]}
analysis: {start: 0, end: 1, steps: 12}
"""


@pytest.mark.parametrize("alpha", [None, 0.0, 25.0])
@pytest.mark.parametrize("P", ["150", "-80 + 20*t"])
def test_rack_and_pinion_tooth_force_in_closed_form(alpha, P):
    extra = "" if alpha is None else f", pressure_angle: {alpha}"
    cm, res, F = forces_of(RACK.replace("EXTRA", extra).replace('"-P"', f'"-({P})"'))
    e = names(cm)
    Pv = np.broadcast_to(eval(P, {"t": res.t}), res.t.shape).astype(float)
    tan = math.tan(math.radians(20.0 if alpha is None else alpha))
    r = 0.02
    scale = np.abs(Pv).max() / math.cos(math.atan(tan))
    gx, gy, gm = F.reaction(e["teeth"], 1)                 # on the pinion
    close(gx, -Pv, scale)
    close(gy, -np.abs(Pv) * tan, scale)
    close(gm, r * Pv, scale * r)                           # about the pinion's centre
    bx, by, _ = F.reaction(e["bearing"], 1)
    close(bx, Pv, scale)
    close(by, np.abs(Pv) * tan, scale)
    _, gy_, _ = F.reaction(e["guide"], 1)                  # on the rack
    close(gy_, -np.abs(Pv) * tan, scale)
    close(F.effort(0), -r * Pv, scale * r)
    balanced(cm, res, F)


def test_rack_pinion_steering_balances_with_its_pressure_angle():
    from test_contact_forces import with_masses
    text = (ROOT / "mechanisms" / "rack-pinion-steering.yaml").read_text()
    text = with_masses(text.replace("sj: [0, 0], r: R}",
                                    "sj: [0, 0], r: R, pressure_angle: 25*pi/180}"))
    cm, res, F = forces_of(text, steps=24)
    balanced(cm, res, F)
    e = [k for k, el in enumerate(cm.spec.elements) if el.kind == "rack-pinion"][0]
    # the tooth force leans from the pitch line by the pressure angle on every row
    fx, fy, _ = F.reaction(e, 1)
    u = np.abs(fx) > 1e-9 * np.abs(fx).max()
    close(np.abs(fy[u] / fx[u]), math.tan(math.radians(25)), 1.0)


# -- finding 2: a gear on a driven carrier, the sun turning on the frame -------------------------
# Sun (Rs) on the frame at the origin, held by a brake (an angle driver f = 0); the carrier turns
# on the frame about the same axis, driven; the planet (Rp) turns on the carrier at (Rs + Rp) e,
# e = (cos phi_c, sin phi_c), and meshes with the sun (`gear`, carrier k). A torque T on the
# (massless) planet: the tooth force on the planet at the pitch point Rs e has the moment -T about
# the planet's centre, (-Rp e) x (F_t t) = -Rp F_t, so F_t = T / Rp, and its radial part pushes
# the planet away from the sun: F = (T / Rp) (t + tan(alpha) e). The planet's bearing on the
# carrier takes -F, the carrier's bearing -F (on the carrier), the sun's bearing +F (on the sun);
# the brake holds the sun against the moment of -F at Rs e: Rs T / Rp; the carrier's motor takes
# the moment of +F at (Rs + Rp) e: its torque is -(Rs + Rp) T / Rp.
CARRIER = """
name: carrier-gear
units: {length: m, angle: rad}
parameters: {Rs: 0.04, Rp: 0.02}
bodies:
  sun: {q: [0, 0, 0]}
  carrier: {q: [0, 0, 0]}
  planet: {q: [Rs + Rp, 0, 0]}
joints:
  - {type: revolute, name: Osun, i: ground, j: sun, at: [0, 0]}
  - {type: revolute, name: Ocar, i: ground, j: carrier, at: [0, 0]}
  - {type: revolute, name: Opl, i: carrier, j: planet, at: [Rs + Rp, 0]}
  - {type: gear, name: teeth, i: sun, j: planet, k: carrier, ri: Rs, rj: Rp}
drivers:
  - {type: angle, name: arm, body: carrier, f: "2*pi*t + 0.5*sin(2*pi*t)"}
  - {type: angle, name: brake, body: sun, f: "0"}
loads:
  - {type: torque, body: planet, f: "3 + t"}
analysis: {end: 1, steps: 12}
"""


def test_gear_on_a_driven_carrier_with_the_sun_on_the_frame_carries_its_tooth_force():
    cm, res, F = forces_of(CARRIER)
    e = names(cm)
    Rs, Rp = 0.04, 0.02
    phi = res.body("carrier")["phi"]
    ex, ey = np.cos(phi), np.sin(phi)
    T = 3 + res.t
    ft, fr = T / Rp, T / Rp * math.tan(math.radians(20))
    Fx, Fy = -ft * ey + fr * ex, ft * ex + fr * ey
    scale = T.max() / (Rp * math.cos(math.radians(20)))
    gx, gy, gm = F.reaction(e["teeth"], 1)
    close(gx, Fx, scale)
    close(gy, Fy, scale)
    close(gm, -T, T.max())
    close(np.array(F.reaction(e["teeth"], 2)), 0.0, scale)       # the carrier gets nothing
    for name, sign in (("Opl", -1), ("Ocar", -1), ("Osun", 1)):
        bx, by, _ = F.reaction(e[name], 1)
        close(bx, sign * Fx, scale)
        close(by, sign * Fy, scale)
    close(F.effort(1), Rs * T / Rp, scale * Rs)                   # the brake on the sun
    close(F.effort(0), -(Rs + Rp) * T / Rp, scale * Rs)           # the carrier's motor
    balanced(cm, res, F)


def test_planetary_gear_form_on_the_carrier_equals_the_moving_centre_form():
    """planetary.yaml (gear-mesh: sun-planet and ring-planet on moving centres) and the same
    train written with `gear` on the carrier k (the sun on the frame, coaxial with the carrier;
    the ring is the frame) are one machine: the same tooth forces, bearing loads and efforts,
    with masses and gravity on every body."""
    from test_contact_forces import with_masses
    mesh = with_masses((ROOT / "mechanisms" / "planetary.yaml").read_text())
    carrier = mesh.replace(
        "{type: gear-mesh, i: sun, j: planet, si: [0, 0], sj: [0, 0], ri: Rs, rj: Rp}",
        "{type: gear, i: sun, j: planet, k: carrier, ri: Rs, rj: Rp}").replace(
        "{type: gear-mesh, i: ground, j: planet, si: [0, 0], sj: [0, 0], ri: -Rr, rj: Rp}",
        "{type: gear, i: ground, j: planet, k: carrier, ri: -Rr, rj: Rp}")
    assert "gear-mesh" not in carrier.split("joints:")[1]
    (cm_a, _, Fa), (cm_b, res_b, Fb) = forces_of(mesh, 24), forces_of(carrier, 24)
    balanced(cm_b, res_b, Fb)
    A = np.array([Fa.reaction(e, 1) for e in range(len(cm_a.spec.elements))])
    B = np.array([Fb.reaction(e, 1) for e in range(len(cm_b.spec.elements))])
    close(B, A, np.abs(A).max())
    close(B[3:5], A[3:5], np.abs(A[3:5]).max())            # the tooth forces alone


def test_belt_on_a_driven_carrier_with_the_pulley_on_the_frame_carries_its_pull():
    """The same centres for a belt (pulleys ri = 10 mm on the frame's axis, rj = 15 mm on the
    carrier): the tight run pulls on j with the tension T / rj that the torque T on j needs, the
    carrier gets nothing (it had the couples before)."""
    cm, res, F = forces_of(CARRIER.replace(
        "{type: gear, name: teeth, i: sun, j: planet, k: carrier, ri: Rs, rj: Rp}",
        "{type: belt, name: teeth, i: sun, j: planet, k: carrier, ri: 0.01, rj: 0.015}"))
    T = 3 + res.t
    fx, fy, mo = F.reaction(names(cm)["teeth"], 1)
    close(np.hypot(fx, fy), T / 0.015, T.max() / 0.015)
    close(mo, -T, T.max())
    balanced(cm, res, F)


# -- a centre that cannot be found is said, not silently dropped ---------------------------------
UNPLACED = CARRIER.replace(
    "  - {type: revolute, name: Osun, i: ground, j: sun, at: [0, 0]}\n",
    "  - {type: x, name: Xsun, i: ground, j: sun, si: [0, 0], sj: [0, 0], c: 0}\n"
    "  - {type: y, name: Ysun, i: ground, j: sun, si: [0, 0], sj: [0, 0], c: 0}\n")


def test_a_gear_without_a_known_centre_is_warned(tmp_path):
    path = tmp_path / "unplaced.yaml"
    path.write_text(UNPLACED)
    r = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "out"),
                                  "--no-plots"])
    assert r.exit_code == 0, r.output
    summary = json.loads((tmp_path / "out" / "unplaced" / "summary.json").read_text())
    warned = [w for w in summary["warnings"] if w.get("kind") == "tooth-force"]
    assert len(warned) == 1, summary["warnings"]
    msg = warned[0]["message"]
    assert msg.startswith("joint 'teeth' (gear sun-planet-carrier): the tooth force is not "
                          "known: gear sun turns on no revolute joint to the carrier carrier"), msg
    assert msg in r.output
    # the same model with the sun on a revolute: no warning
    path.write_text(CARRIER)
    r = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "out"),
                                  "--no-plots"])
    summary = json.loads((tmp_path / "out" / "unplaced" / "summary.json").read_text())
    assert r.exit_code == 0 and not summary["warnings"], r.output


# -- input -------------------------------------------------------------------------------------

@pytest.mark.parametrize("alpha", ["50", "-1"])
def test_rack_pressure_angle_is_checked_at_its_line(tmp_path, alpha):
    text = RACK.replace("EXTRA", f", pressure_angle: {alpha}").replace('"-P"', '"-150"')
    path = tmp_path / "rack.yaml"
    path.write_text(text)
    line = [k for k, ln in enumerate(text.splitlines(), 1) if "type: rack-pinion" in ln][0]
    r = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "out")])
    assert r.exit_code == 2, r.output
    assert (f"{path}:{line}: error: joint 'teeth' (rack-pinion rack-pinion): pressure_angle "
            f"must be between 0 and 45 deg, not {alpha} deg") in r.output, r.output


def test_pressure_angle_is_in_the_generated_reference():
    from planarkin.docs import kinds_reference, kinds_table
    table = kinds_table()
    for kind in ("gear", "gear-mesh", "rack-pinion"):
        row = [ln for ln in table.splitlines() if ln.startswith(f"| [`{kind}`]")][0]
        assert "pressure_angle (optional)" in row, row
    assert "pressure angle of the teeth" in kinds_reference()


# -- the how-to's figure -------------------------------------------------------------------------

def test_the_how_to_figure_is_what_the_code_draws(tmp_path):
    """docs/images/gear-tooth-force.png is regenerable (`python -m planarkin.docs --figure`) and
    shows the forces room's own numbers; docs/how-to/forces.md shows it."""
    from matplotlib.image import imread

    from planarkin.forces.figures import FIGURE, PAIR, tooth_force, tooth_force_figure
    res = planarkin.solve(planarkin.load("tooth-force.yaml", text=PAIR))
    d = tooth_force(res)
    a = math.radians(20)
    close(d["F"], [400 * math.tan(a), 400], 400, 1e-12)          # T / rj = 40 / 0.1 up, apart
    close(d["B"], -d["F"], 400, 1e-12)
    tooth_force_figure(tmp_path / "new.png", res)
    old, new = imread(ROOT / FIGURE), imread(tmp_path / "new.png")
    assert old.shape == new.shape, "run: python -m planarkin.docs --figure"
    assert np.mean(np.abs(old - new) > 0.1) < 0.002, "run: python -m planarkin.docs --figure"
    assert "](../images/gear-tooth-force.png)" in (ROOT / "docs/how-to/forces.md").read_text()
