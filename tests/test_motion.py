"""Chained motion profiles (planarkin.functions.motion and a driver's motion:), against closed forms."""

import math

import numpy as np
import pytest

import planarkin
from planarkin.functions.laws import LAWS
from planarkin.functions.motion import Segment, profile

PI = math.pi


def cyc(u):
    u = np.clip(u, 0, 1)
    return u - np.sin(2 * PI * u) / (2 * PI), 1 - np.cos(2 * PI * u), 2 * PI * np.sin(2 * PI * u)


def p345(u):
    inside = (u > 0) & (u < 1)
    u = np.clip(u, 0, 1)
    return (10 * u**3 - 15 * u**4 + 6 * u**5, np.where(inside, 30 * u**2 - 60 * u**3 + 30 * u**4, 0),
            np.where(inside, 60 * u - 180 * u**2 + 120 * u**3, 0))


def servo_closed_form(t):
    """rise 90 in 0.3 (cycloidal), dwell 0.2, return 90 in 0.3 (3-4-5), dwell 0.2, repeated."""
    tau = np.mod(t, 1.0)
    r, rv, ra = cyc(tau / 0.3)
    d, dv, da = p345((tau - 0.5) / 0.3)
    return 90 * (r - d), 90 * (rv - dv) / 0.3, 90 * (ra - da) / 0.09


SERVO = [Segment("rise", 90, 0.3, "cycloidal"), Segment("dwell", 0, 0.2),
         Segment("return", -90, 0.3, "3-4-5"), Segment("dwell", 0, 0.2)]


def test_chained_profile_matches_its_closed_form():
    f = profile(SERVO, repeat=True)
    t = np.linspace(0, 3, 3001) + 1e-7  # off the joints (there one-sided, tested below)
    got = f.derivatives(t)
    for g, w, scale in zip(got, servo_closed_form(t), (90, 600, 90 * 2 * PI / 0.09)):
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-12 * scale)


def test_continuity_at_every_segment_boundary_and_cycle():
    f = profile(SERVO, repeat=True)
    joints = [0.3, 0.5, 0.8, 1.0, 1.3, 2.0]
    for tj in joints:
        left, right = f.derivatives(tj, -1), f.derivatives(tj, +1)
        # position, velocity (both laws start and end at rest) and acceleration (cycloidal
        # ends at 0, 3-4-5 ends at 0) continuous
        assert left == pytest.approx(right, abs=1e-10)
    assert f.breakpoints(0.0, 3.0) == []  # C2 everywhere: nothing for the path follower
    assert f.problems(0.0, 3.0) == []
    assert f.text == ("motion: rise 90 in 0.3 cycloidal, dwell 0.2, return 90 in 0.3 3-4-5, "
                      "dwell 0.2, repeat")


@pytest.mark.parametrize("name", sorted(LAWS))
def test_every_law_chains_continuously(name):
    f = profile([Segment("rise", 2.0, 0.4, name), Segment("dwell", 0, 0.1),
                 Segment("return", -2.0, 0.5, name)], initial=1.0, t0=0.2)
    for tj in (0.2, 0.6, 0.7, 1.2):
        assert f(tj, -1) == pytest.approx(f(tj, +1), abs=1e-14)
    assert f(0.0) == 1.0 and f(0.6) == pytest.approx(3.0, abs=1e-14) and f(5.0) == 1.0
    bps = f.breakpoints(0.0, 2.0)
    assert all(b.jump[0] == 0 for b in bps)
    kinds = {"constant_velocity": 1, "harmonic": 2}
    if name in kinds:  # a velocity (or acceleration) jump at each of the four ends
        assert [b.t for b in bps] == [0.2, 0.6, 0.7, 1.2]
        k = kinds[name]
        assert all(b.jump[k] != 0 for b in bps)
        if name == "constant_velocity":
            assert [b.jump[1] for b in bps] == pytest.approx([5.0, -5.0, -4.0, 4.0], rel=1e-14)
    else:
        assert bps == []


def test_indexing_motion_keeps_rising_from_cycle_to_cycle():
    f = profile([Segment("rise", 90, 0.25, "modified_sine"), Segment("dwell", 0, 0.25)],
                repeat=True)
    assert [f(float(t)) for t in (0.5, 1.0, 1.5, 2.0)] == pytest.approx([90, 180, 270, 360],
                                                                         abs=1e-12)
    for tj in (0.5, 1.0, 1.25):
        assert f(tj, -1) == pytest.approx(f(tj, +1), abs=1e-12)
    assert f.problems(0.0, 3.0) == [] and f.breakpoints(0.0, 3.0) == []


def test_motion_key_in_a_model_drives_the_crank_exactly(tmp_path):
    path = tmp_path / "servo.yaml"
    path.write_text("""
units: {angle: deg}
bodies:
  crank: {q: [0, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
drivers:
  - type: angle
    body: crank
    motion:
      segments:
        - {rise: 90, in: 0.3, law: cycloidal}
        - {dwell: 0.2}
        - {return: 90, in: 0.3, law: poly345}
        - {dwell: 0.2}
      repeat: true
analysis: {end: 1.2, steps: 24}
""")
    res = planarkin.solve(planarkin.load(path))
    assert res.status == 0
    phi, w, a = servo_closed_form(res.t)
    # one body rotating about the origin: phi, omega, alpha are the profile (results in deg)
    np.testing.assert_allclose(res.q[:, 2], phi, rtol=0, atol=1e-12 * 90)
    np.testing.assert_allclose(res.qd[:, 2], w, rtol=0, atol=1e-12 * 600)
    np.testing.assert_allclose(res.qdd[:, 2], a, rtol=0, atol=1e-12 * 6300)


def test_long_chains_build_and_too_long_ones_are_refused(tmp_path):
    f = profile([Segment("rise", 1.0, 0.01, "cycloidal"), Segment("dwell", 0, 0.01)] * 50,
                repeat=True)
    assert f(np.array([0.01, 0.995, 1.01, 2.0])).tolist() == pytest.approx([1, 50, 51, 100],
                                                                           abs=1e-12)
    segs = ", ".join(["{rise: 1, in: 0.01, law: cycloidal}"] * 101)
    path = tmp_path / "long.yaml"
    path.write_text(f"""
bodies:
  a: {{q: [0, 0, 0]}}
joints:
  - {{type: revolute, i: ground, j: a, si: [0, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, body: a, motion: {{segments: [{segs}]}}}}
""")
    with pytest.raises(planarkin.InputError, match="motion: at most 100 segments"):
        planarkin.load(path)
