"""planarkin.clearance.keys and .build: the shapes:, clearance: and limits: keys, compiled to
Shapes (CompiledModel.shapes) and the pairs that can touch; misuse is a FILE:LINE error (the
whole catalogue is tests/cases/clearance-bad-keys.yaml)."""

import re
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.clearance.build import pairs
from planarkin.clearance.keys import CLEARANCE_KEYS, SHAPE_KEYS
from planarkin.diagnostics import InputError
from planarkin.docs import KEYS

SKETCH = """
name: fb
units: {length: mm, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [100, 0], ground: true}
  B: {at: [40, 0]}
  C: {at: [106.66666666666667, 99.77753031397177]}
  P: {at: [56.61785, 84.81585]}
links:
  crank: [A, B]
  coupler: [B, C, P]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "360*t"}
analysis: {start: 0, end: 1, steps: 36}
"""


def load(extra):
    return planarkin.load("fb.yaml", text=SKETCH + extra)


def errors(extra):
    with pytest.raises(InputError) as e:
        load(extra)
    return [f"{d.line}: {d.message}" for d in e.value.diagnostics]


def test_a_plate_is_the_hull_of_the_links_pins_rounded_by_half_its_width():
    cm = load("shapes:\n  coupler: {plate: 10, hole: 4, layer: 1}\n")
    (s,) = cm.shapes
    assert s.name == "coupler" and s.body == cm.body_names.index("coupler")
    # the sketch's coupler frame: origin at B, x towards C; its pins B and C (P is no joint)
    pts = np.asarray(s.points) * cm.L
    assert len(pts) == 2 and s.radius * cm.L == pytest.approx(5.0)
    assert sorted(np.hypot(pts[:, 0], pts[:, 1]).round(9)) == \
        [0.0, round(float(np.hypot(66.66666666666667, 99.77753031397177)), 9)]
    assert [h[2] * cm.L for h in s.holes] == pytest.approx([4.0, 4.0])
    assert s.layer == (1.0, 1.0) and s.closed and s.source == ("fb.yaml", 18)


def test_pins_name_the_points_a_plate_is_drawn_around():
    cm = load("shapes:\n  coupler: {plate: 10, pins: [B, C, P]}\n")
    assert len(cm.shapes[0].points) == 3


def test_a_global_outline_is_turned_into_the_bodys_frame():
    cm = load("shapes:\n  rocker: {polygon: [[95, 0], [105, 0], [110, 100], [100, 100]], "
              "frame: global}\n  wall: {body: ground, polyline: [[0, 120], [150, 120]], "
              "layer: [0, 1]}\n")
    r = cm.shapes[0]
    phi = np.arctan2(99.77753031397177, 6.66666666666667)
    c, s = np.cos(phi), np.sin(phi)
    P = np.asarray(r.points) * cm.L
    world = np.stack([100 + c * P[:, 0] - s * P[:, 1], s * P[:, 0] + c * P[:, 1]], axis=1)
    assert np.allclose(world, [[95, 0], [105, 0], [110, 100], [100, 100]], atol=1e-9)
    assert np.allclose(np.asarray(cm.shapes[1].points) * cm.L, [[0, 120], [150, 120]])


def test_pairs_leave_out_joined_shapes_other_layers_and_ignored_pairs():
    base = ("shapes:\n  crank: {plate: 12}\n  coupler: {plate: 12}\n  rocker: {plate: 12}\n"
            "  wall: {body: ground, polyline: [[-50, 120], [150, 120]]}\n")
    cm = load(base)
    # crank-coupler and coupler-rocker share a pin: joined where they meet
    assert [p.name for p in pairs(cm)] == ["crank|rocker", "crank|wall", "coupler|wall",
                                           "rocker|wall"]
    cm = load(base.replace("[150, 120]]}", "[150, 120]], layer: 5}") +
              "clearance:\n  min: 2\n  ignore: [[rocker, crank]]\n"
              "  pairs: [{between: [coupler, rocker], min: 0.5}, {between: [crank, coupler]}]\n")
    got = {p.name: p.limit for p in pairs(cm)}
    assert got == {"crank|coupler": 2.0, "coupler|rocker": 0.5}


def test_a_pair_in_different_layers_cannot_be_asked_for():
    msgs = errors("shapes:\n  crank: {plate: 12}\n  rocker: {plate: 12, layer: [2, 3]}\n"
                  "clearance: {pairs: [{between: [crank, rocker]}]}\n")
    assert msgs == ["20: clearance: pairs: 'crank' (layer 0) and 'rocker' (layer [2, 3]) are "
                    "in different layers and cannot touch; put them in one layer or drop the "
                    "pair"]


def test_two_shapes_on_one_body_are_never_a_pair():
    msgs = errors("shapes:\n  crank: {plate: 12}\n  cam: {body: crank, circle: 30}\n"
                  "clearance: {ignore: [[crank, cam]]}\n")
    assert msgs == ["20: clearance: ignore: 'crank' and 'cam' are on the same body 'crank': "
                    "their distance cannot change"]


def test_limits_take_a_named_revolute_or_translational_joint():
    cm = load("limits: {D: {range: [60, 140]}, C: [-90, 90]}\n")
    lim = cm.spec.clearance.limits
    assert [(x.joint, x.kind, x.lo, x.hi) for x in lim] == [("D", "revolute", 60, 140),
                                                            ("C", "revolute", -90, 90)]
    assert cm.shapes == ()


def test_every_key_is_in_the_reference():
    documented = {k.split(".")[-1] for k in KEYS if k.startswith("shapes.<s>.")}
    assert documented == set(SHAPE_KEYS)
    documented = {k.split(".", 1)[1] for k in KEYS if k.startswith("clearance.")}
    assert documented == set(CLEARANCE_KEYS)
    msgs = errors("clearance: {zzz: 1}\n")
    assert re.search(r"valid keys: ([^)]*)\)", msgs[0]).group(1).split(", ") == \
        list(CLEARANCE_KEYS)


ROOT = Path(__file__).resolve().parent.parent


def test_a_cams_profile_and_its_roller_touch_at_every_row():
    from planarkin.clearance.cycle import minima
    text = (ROOT / "mechanisms" / "cam-roller.yaml").read_text() + (
        "shapes:\n  cam: {profile: lift}\n  follower: {profile: lift}\n"
        "clearance: {pairs: [{between: [cam, follower]}]}\n")
    cm = planarkin.load("cam.yaml", text=text)
    cam, roller = cm.shapes
    assert len(cam.points) == 361 and not cam.closed       # the rise only: a polyline
    assert roller.radius * cm.L == pytest.approx(0.01) and len(roller.points) == 1
    (m,) = minima(cm, planarkin.solve(cm))
    # the roller rides on the exact profile; the polygon through 361 of its points is within
    # the chord's sagitta of it
    assert np.abs(m.distance).max() < 1e-6


def test_pitch_circles_of_gears_in_mesh_touch_and_a_ring_has_no_disc():
    from planarkin.clearance.cycle import minima
    text = (ROOT / "mechanisms" / "planetary.yaml").read_text().replace(
        "ri: Rs, rj: Rp}", "ri: Rs, rj: Rp, name: mesh}").replace(
        "ri: -Rr, rj: Rp}", "ri: -Rr, rj: Rp, name: ring}")
    cm = planarkin.load("planetary.yaml", text=text + "shapes:\n  sun: {profile: mesh}\n"
                        "  planet: {profile: mesh}\nclearance: {pairs: [{between: [sun, planet]}]}\n")
    (m,) = minima(cm, planarkin.solve(cm, steps=36))
    assert np.abs(m.distance).max() < 1e-12
    with pytest.raises(InputError) as e:
        planarkin.load("planetary.yaml", text=text + "shapes:\n  ring: {body: ground, profile: "
                       "ring}\n  gear: {body: planet, profile: lift}\n")
    assert [d.message for d in e.value.diagnostics] == [
        "shape 'gear': profile: 'lift' is not a named cam, gear, rack-pinion or rolling-disc "
        "joint (cam, gear, rack-pinion and rolling-disc joints: mesh, ring)"]
    with pytest.raises(InputError) as e:
        planarkin.load("planetary.yaml", text=text + "shapes:\n  ring: {body: ground, profile: "
                       "ring}\n")
    assert "the internal (ring) gear of joint 'ring': its pitch circle is a ring" in str(e.value)


def test_a_global_outline_on_a_link_with_given_lengths_is_refused():
    text = (ROOT / "mechanisms" / "six-bar-sketch.yaml").read_text()
    with pytest.raises(InputError) as e:
        planarkin.load("s.yaml", text=text + "\nshapes:\n  crank: {circle: 0.01, frame: global}\n")
    (d,) = e.value.diagnostics
    assert d.message.startswith("shape 'crank': frame: global is read against the sketched "
                                "pose of link 'crank', which has given lengths")
