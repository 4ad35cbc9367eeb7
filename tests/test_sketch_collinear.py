"""A sketch pin on the line of its link's first two pins (issue 21 item 10): placed exactly on
that line (its body-frame y is 0.0, so it stays on the line to rounding all run), from the
length given; three lengths in line to rounding put it on the line too (the law of cosines put
it up to sqrt(rounding) off, nanometres); an impossible triangle says which length to write.

The four-bar (ground 0.1, crank 0.04, coupler 0.12, rocker 0.1) is drawn roughly, its lengths
given; its coupler carries E on the line B-C: beyond C, between B and C, or before B."""

import math

import numpy as np
import pytest

import planarkin
from planarkin.diagnostics import InputError

B = (0.04, 0.0)
C = (0.107, 0.100)          # rough: |B C| = 0.1204 drawn, 0.12 given


def _model(e_at, lengths):
    return f"""\
units: {{length: m, angle: deg}}
points:
  A: {{at: [0, 0], ground: true}}
  D: {{at: [0.1, 0], ground: true}}
  B: {{at: [{B[0]!r}, {B[1]!r}]}}
  C: {{at: [{C[0]!r}, {C[1]!r}]}}
  E: {{at: [{e_at[0]!r}, {e_at[1]!r}]}}
links:
  crank: [A, B]
  coupler: [B, C, E]
  rocker: [D, C]
lengths: {{A-B: 0.04, B-C: 0.12, D-C: 0.1, {lengths}}}
drivers:
  - {{type: angle, link: crank, f: "360*t"}}
assembly: {{sketch_tolerance: 0.01}}
analysis: {{steps: 72}}
"""


def _on_line(s):
    """E drawn at B + s (C - B): exactly on the drawn line, to rounding."""
    return (B[0] + s * (C[0] - B[0]), B[1] + s * (C[1] - B[1]))


@pytest.mark.parametrize("s, lengths, x", [
    (1.4, "C-E: 0.05", 0.17),          # beyond C, by its distance to C
    (1.4, "B-E: 0.17", 0.17),          # beyond C, by its distance to B
    (0.5, "C-E: 0.05", 0.07),          # between B and C
    (0.5, "B-E: 0.05", 0.05),
    (-0.3, "B-E: 0.03", -0.03),        # before B
    (-0.3, "C-E: 0.15", -0.03),
])
def test_a_pin_drawn_on_the_line_stays_on_it(s, lengths, x):
    m = planarkin.load("m.yaml", text=_model(_on_line(s), lengths))
    e = {p.name: p.s for p in m.spec.points}["E"]
    assert e[1] == 0.0 and abs(e[0] - x) <= 2e-16, e
    r = planarkin.solve(m, steps=72)
    assert r.success
    P = {n: np.column_stack([r.point(n)["x"], r.point(n)["y"]]) for n in "BCE"}
    u, w = P["C"] - P["B"], P["E"] - P["B"]
    # E on the line B-C at every row, at its distance from B and C
    assert np.max(np.abs(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])) / 0.12 < 1e-15
    assert np.max(np.abs(np.hypot(*w.T) - abs(x))) < 1e-15
    assert np.max(np.abs(np.hypot(*(P["E"] - P["C"]).T) - abs(x - 0.12))) < 1e-15


@pytest.mark.parametrize("b_e, c_e, x", [
    # the law of cosines put E 3.7e-9 m, 2e-10 m and 8e-11 m off the line
    (0.181, 0.061, 0.181),     # beyond C
    (0.003, 0.117, 0.003),     # between B and C
    (0.002, 0.122, -0.002),    # before B
    (0.17, 0.05, 0.17),
])
def test_three_lengths_in_line_put_the_pin_on_the_line(b_e, c_e, x):
    # E drawn off the line (the lengths decide); B-C 0.12 and the two given distances in line
    text = _model((0.13, 0.16), f"B-E: {b_e}, C-E: {c_e}")
    m = planarkin.load("m.yaml", text=text)
    e = {p.name: p.s for p in m.spec.points}["E"]
    assert e == (x, 0.0)


def test_an_impossible_triangle_says_which_length_to_write():
    # E drawn 2.3e-5 off the extension of B-C, only C-E given: B-E as sketched (0.17046) is
    # longer than B-C + C-E = 0.17
    e_at = (0.1349, 0.1416)
    with pytest.raises(InputError) as err:
        planarkin.load("m.yaml", text=_model(e_at, "C-E: 0.05"))
    off = abs((C[0] - B[0]) * (e_at[1] - B[1]) - (C[1] - B[1]) * (e_at[0] - B[0])) / math.dist(B, C)
    be = math.dist(B, e_at)
    assert [d.format() for d in err.value.diagnostics] == [
        f"m.yaml:12: error: link 'coupler': the lengths B-C 0.12, B-E {be:.6g} (as sketched), "
        f"C-E 0.05 cannot form a triangle (each side must be at most the sum of the other two); "
        f"give B-E in lengths: (from 0.07 to 0.17: 0.17 puts E on the line B-C, beyond C, where "
        f"it is drawn {off:.3g} off the line)"]
    # written as told, it loads, E on the line
    m = planarkin.load("m.yaml", text=_model(e_at, "C-E: 0.05, B-E: 0.17"))
    assert {p.name: p.s for p in m.spec.points}["E"] == (0.17, 0.0)
