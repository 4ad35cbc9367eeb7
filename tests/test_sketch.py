"""The sketch form (pins and links) against the body/joint form of the same linkage.

Jansen's leg, Klann's leg and the Peaucellier-Lipkin inversor: pin coordinates computed in
tests/linkages.py from the published link lengths by circle intersections; the body/joint form
takes its body-frame vectors from the lengths (law of cosines) and rough body poses. Both must
give the same point trajectories to 1e-14 of the model's size."""

import math
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.diagnostics import InputError

import linkages as L
from closedforms import slider_crank

ROOT = Path(__file__).resolve().parent.parent

CASES = {
    "jansen": ("jansen-leg", L.jansen, 30.0, "30 + 360*t", L.JANSEN_LINKS, "crank",
               L.jansen_length),
    "klann": ("klann-leg", L.klann, 30.0, "30 + 360*t", L.KLANN_LINKS, "crank", L.klann_length),
    "peaucellier": ("peaucellier", L.peaucellier, 0.0, "50*sin(2*pi*t)", L.PEAUCELLIER_LINKS,
                    "driver", L.peaucellier_length),
}


def _both(key, steps=72):
    name, fn, th, f, links, driven, length = CASES[key]
    pins = fn(math.radians(th))
    sk = planarkin.load(f"{name}.yaml", text=L.sketch_yaml(name, pins, links, L.GROUND[key],
                                                           driven, f, steps))
    bj = planarkin.load(f"{name}-bodies.yaml", text=L.body_joint_yaml(
        name, pins, links, L.GROUND[key], driven, f, length, steps))
    return pins, sk, bj


@pytest.mark.parametrize("key", sorted(CASES))
def test_sketch_matches_body_joint_form(key):
    pins, sk, bj = _both(key)
    a, b = planarkin.solve(sk), planarkin.solve(bj)
    assert a.success and b.success
    size = max(math.hypot(*p) for p in pins.values())
    for p in bj.point_names:
        pa, pb = a.point(p), b.point(p)
        for k in ("x", "y"):
            assert np.max(np.abs(pa[k] - pb[k])) <= 1e-14 * size, (p, k)
        vscale = max(np.max(np.abs(pb["vx"])), np.max(np.abs(pb["vy"])), 1.0)
        ascale = max(np.max(np.abs(pb["ax"])), np.max(np.abs(pb["ay"])), 1.0)
        # two roundings of the geometry, each within 1e-14 of the exact linkage
        # (tests/test_sketch_exact.py)
        for k in ("vx", "vy"):
            assert np.max(np.abs(pa[k] - pb[k])) <= 2e-14 * vscale, (p, k)
        for k in ("ax", "ay"):
            assert np.max(np.abs(pa[k] - pb[k])) <= 2e-14 * ascale, (p, k)


@pytest.mark.parametrize("key", sorted(CASES))
def test_sketch_pins_reported_once_and_lengths_kept(key):
    pins, sk, _ = _both(key)
    assert sorted(sk.point_names) == sorted(pins)          # every pin once, ground pins too
    r = planarkin.solve(sk)
    links = CASES[key][4]
    for pts in links.values():                             # rigid links: every pair keeps length
        for i in range(len(pts)):
            for j in range(i + 1, len(pts)):
                P, Q = r.point(pts[i]), r.point(pts[j])
                d = np.hypot(P["x"] - Q["x"], P["y"] - Q["y"])
                assert np.max(np.abs(d - math.dist(pins[pts[i]], pins[pts[j]]))) < 1e-12


def test_sketch_starts_at_the_sketched_pose():
    pins, sk, _ = _both("jansen")
    r = planarkin.solve(sk, steps=4)
    for p, (x, y) in pins.items():
        assert abs(r.point(p)["x"][0] - x) < 1e-13 and abs(r.point(p)["y"][0] - y) < 1e-13


def test_peaucellier_point_runs_on_a_straight_line():
    _, sk, _ = _both("peaucellier", steps=90)
    P = planarkin.solve(sk).point("P")
    assert np.max(np.abs(P["x"] - 21.0 / 4.0)) < 1e-12
    assert np.max(np.abs(P["vx"])) < 1e-10 and np.max(np.abs(P["ax"])) < 1e-8


@pytest.mark.parametrize("key", sorted(CASES))
def test_shipped_example_has_the_published_coordinates(key):
    name, fn, th = CASES[key][:3]
    m = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
    pins = fn(math.radians(th))
    got = {p.name: p.at for p in m.spec.points}
    assert set(got) == set(pins)
    for p, xy in pins.items():
        assert math.dist(got[p], xy) < 1e-12, p


def _load(text):
    return planarkin.load("m.yaml", text=text)


FOUR_BAR = """\
units: {length: m, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.1, 0], ground: true}
  B: {at: [0.04, 0]}
  C: {at: [0.10666666666666667, 0.09977753031397177]}
  P: {at: [0.05661785, 0.08481585]}
links:
  crank: [A, B]
  coupler: [B, C, P]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "360*t"}
analysis: {steps: 36}
"""


def test_four_bar_sketch_matches_the_placed_example():
    a = planarkin.solve(_load(FOUR_BAR))
    b = planarkin.solve(ROOT / "mechanisms" / "four-bar-placed.yaml", steps=36)
    for k in ("x", "y", "vx", "vy", "ax", "ay"):
        assert np.max(np.abs(a.point("P")[k] - b.point("P")[k])) < 1e-13


def test_mixed_forms_and_ground_list():
    text = """\
units: {length: m, angle: deg}
ground: [A, D]
bodies:
  crank: {q: [0, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: coupler, si: [0.04, 0], sj: [0, 0]}
points:
  A: {at: [0, 0]}
  D: {at: [0.1, 0]}
  B: {at: [0.04, 0]}
  C: {at: [0.10666666666666667, 0.09977753031397177]}
  P: {body: coupler, at: [0.05661785, 0.08481585]}
links:
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {type: angle, body: crank, f: "360*t"}
analysis: {steps: 36}
"""
    m = _load(text)
    assert m.body_names == ("crank", "coupler", "rocker")
    a = planarkin.solve(m)
    b = planarkin.solve(ROOT / "mechanisms" / "four-bar-placed.yaml", steps=36)
    assert np.max(np.abs(a.point("P")["x"] - b.point("P")["x"])) < 1e-13


def test_distance_driver_between_points():
    # a crank-driven four-bar driven instead by the distance A-C (an actuator from A to C)
    text = FOUR_BAR.replace('  - {type: angle, link: crank, f: "360*t"}',
                            '  - {type: distance, between: [A, C], f: "0.1460 + 0.01*t"}')
    text = text.replace("[0.10666666666666667, 0.09977753031397177]",
                        "[0.10666666666666667, 0.09977753031397177]")
    m = _load(text)
    r = planarkin.solve(m, steps=10)
    C = r.point("C")
    d = np.hypot(C["x"], C["y"])
    assert r.success
    assert np.max(np.abs(d - (0.1460 + 0.01 * r.t))) < 1e-12


def test_slider_crank_sketch():
    text = """\
points:
  O: {at: [0, 0], ground: true}
  A: {at: [0.1, 0]}
  B: {at: [0.4, 0]}
links:
  crank: [O, A]
  rod: [A, B]
  slider: [B]
sliders:
  piston: {link: slider, along: [O, B]}
drivers:
  - {type: angle, link: crank, f: "2*pi*t"}
analysis: {steps: 36}
"""
    r = planarkin.solve(_load(text))
    th = 2 * np.pi * r.t
    x = slider_crank(th, 0.0, 0.0, 0.1, 0.3)[3]
    assert np.max(np.abs(r.point("B")["x"] - x)) < 1e-14
    assert np.max(np.abs(r.point("B")["y"])) < 1e-14


def _errors(text):
    with pytest.raises(InputError) as e:
        _load(text)
    return [d.format() for d in e.value.diagnostics]


def test_sketch_errors_name_the_point_and_link():
    text = """\
points:
  O: {at: [0, 0], ground: true}
  A: {at: [1, 0]}
  Z: {at: [5, 5]}
links:
  crank: [O, A, A]
  rod: [A, Q]
  bar: [O, O2]
drivers:
  - {type: angle, link: crank, f: "t"}
"""
    assert _errors(text) == [
        "m.yaml:4: error: point 'Z': no link carries it; list it in a link under links:, mark it "
        "ground: true, or give body: NAME",
        "m.yaml:6: error: link 'crank': lists point 'A' twice",
        "m.yaml:7: error: link 'rod': unknown point 'Q' (name it under points: with at: [x, y])",
        "m.yaml:8: error: link 'bar': unknown point 'O2'; did you mean 'O'?",
    ]


def test_check_derived_prints_a_pasteable_body_joint_model(tmp_path):
    from clitools import run_cli
    r = run_cli("check", "--derived", "mechanisms/jansen-leg.yaml")
    assert r.returncode == 0, r.stderr
    text = r.stdout.split("\nok ")[0]
    assert "links:" not in text and "  - {type: revolute, name: A, i: crank, j: upper," in text
    derived = planarkin.load("derived.yaml", text=text)
    assert derived.spec.bodies and all(p.body for p in derived.spec.points)
    a = planarkin.solve(ROOT / "mechanisms" / "jansen-leg.yaml", steps=24)
    b = planarkin.solve(derived, steps=24)
    for p in a.model.point_names:
        for k in ("x", "y", "vx", "vy"):
            scale = max(np.max(np.abs(a.point(p)[k])), 1.0)
            assert np.max(np.abs(a.point(p)[k] - b.point(p)[k])) < 1e-14 * scale, (p, k)


def test_rough_sketch_is_assembled_with_a_warning_per_moved_pin():
    # the driver asks for the crank at 10 deg, the sketch draws it at 0 deg: B moves on its
    # circle by the chord 2 a sin(5 deg)
    m = _load(FOUR_BAR.replace('f: "360*t"', 'f: "10 + 360*t"'))
    from planarkin.solver.assembly import assemble
    w = [d.format() for d in assemble(m).warnings]
    assert len(w) == 3 and [x.split(":")[1] for x in w] == ["5", "6", "7"]
    chord = 2 * 0.04 * math.sin(math.radians(5))
    assert w[0] == (f"m.yaml:5: warning: point 'B': the sketched position [0.04, 0] is not "
                    f"consistent with the joints and drivers at t = start; assembled "
                    f"{chord:.3g} m away, at [{0.04 * math.cos(math.radians(10)):.10g}, "
                    f"{0.04 * math.sin(math.radians(10)):.10g}]")
    assert not assemble(_load(FOUR_BAR)).warnings


def test_slot_sketch_quick_return():
    # Whitworth-type quick return: crank pin A runs in a slot of the rocker pivoted at C
    text = """\
points:
  O: {at: [0, 0.2], ground: true}
  C: {at: [0, 0], ground: true}
  A: {at: [0.1, 0.2]}
  E: {at: [0.3, 0.6]}
links:
  crank: [O, A]
  rocker: [C, E]
slots:
  s1: {link: rocker, pin: A, along: [C, E]}
drivers:
  - {type: angle, link: crank, f: "2*pi*t"}
analysis: {steps: 40}
"""
    r = planarkin.solve(_load(text))
    th = 2 * np.pi * r.t
    want = np.unwrap(np.arctan2(0.2 + 0.1 * np.sin(th), 0.1 * np.cos(th)))
    assert np.max(np.abs(r.body("rocker")["phi"] - want)) < 1e-14
    assert _errors(text.replace("E: {at: [0.3, 0.6]}", "E: {at: [0.3, 0.7]}")) == [
        f"m.yaml:10: error: slot 's1': pin 'A' is {0.01 / math.hypot(0.3, 0.7):.6g} off the "
        f"line C-E; a slot's line passes through its pin at the assembly pose"]


def test_no_moving_link_is_an_input_error():
    assert _errors("points:\n  A: {at: [0, 0], ground: true}\nlinks: {}\n") == [
        "m.yaml:3: error: links is empty: a mechanism needs at least one moving link, e.g. "
        "crank: [O, A]"]
