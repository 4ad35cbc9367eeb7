"""Andrews' squeezer mechanism (7 bodies; Schiehlen 1990, Hairer & Wanner 1996 test set): it
assembles from rough estimates to the published consistent initial angles.

Geometry after Hairer & Wanner, "Solving ODEs II", §VII.7: with the angle beta of the driven
link OF fixed, the six loop equations determine Theta, gamma, Phi, delta, Omega, epsilon. In
Cartesian coordinates: b1 = OF (angle beta), b2 = FE (beta + Theta), b3 = BE (gamma),
b4 = GE (Phi + delta), b5 = AG (delta), b6 = HE (Omega + epsilon), b7 = AH (epsilon); the
point E is shared by b2, b3, b4 and b6.
"""

import numpy as np
import pytest

import planarkin

PUBLISHED = {   # beta, Theta, gamma, Phi, delta, Omega, epsilon at t = 0 (30 digits published)
    "beta": -0.0617138900142764496358948458001,
    "Theta": 0.0,
    "gamma": 0.455279819163070380255912382449,
    "Phi": 0.222668390165885884674473185609,
    "delta": 0.487364979543842550225598953530,
    "Omega": -0.222668390165885884674473185609,
    "epsilon": 1.23054744454982119249735015568,
}

MODEL = """
name: andrews-squeezer
parameters:
  xa: -0.06934
  ya: -0.00227
  xb: -0.03635
  yb: 0.03273
  d: 0.028
  e: 0.02
  zf: 0.02
  zt: 0.04
  u: 0.04
  rr: 0.007
  ss: 0.035
  beta0: -0.0617138900142764496358948458001
bodies:                                   # rough estimates: angles off by up to 0.05 rad
  b1: {q: [0, 0, -0.03]}
  b2: {q: [0.0065, -0.0005, -0.1]}
  b3: {q: [-0.036, 0.033, 0.5]}
  b4: {q: [-0.035, 0.036, 0.66]}
  b5: {q: [-0.069, -0.002, 0.45]}
  b6: {q: [-0.033, 0.0, 1.05]}
  b7: {q: [-0.069, -0.002, 1.2]}
joints:
  - {type: revolute, i: ground, j: b1, si: [0, 0], sj: [0, 0]}          # O
  - {type: revolute, i: b1, j: b2, si: [rr, 0], sj: [0, 0]}            # F
  - {type: revolute, i: b2, j: b3, si: [-d, 0], sj: [0, -ss]}          # E
  - {type: revolute, i: ground, j: b3, si: [xb, yb], sj: [0, 0]}       # B
  - {type: revolute, i: b2, j: b4, si: [-d, 0], sj: [0, -e]}           # E
  - {type: revolute, i: b4, j: b5, si: [0, 0], sj: [zt, 0]}            # G
  - {type: revolute, i: ground, j: b5, si: [xa, ya], sj: [0, 0]}       # A
  - {type: revolute, i: b2, j: b6, si: [-d, 0], sj: [zf, 0]}           # E
  - {type: revolute, i: b6, j: b7, si: [0, 0], sj: [0, -u]}            # H
  - {type: revolute, i: ground, j: b7, si: [xa, ya], sj: [0, 0]}       # A
drivers:
  - {type: angle, body: b1, f: "beta0 + 0*t"}
analysis: {start: 0, end: 0.001, steps: 1}
"""


def test_assembles_to_the_published_angles():
    from planarkin.solver.assembly import assemble
    model = planarkin.load("andrews.yaml", text=MODEL)
    A = assemble(model)
    phi = dict(zip(model.body_names, A.q[2::3]))
    got = {
        "beta": phi["b1"], "Theta": phi["b2"] - phi["b1"], "gamma": phi["b3"],
        "Phi": phi["b4"] - phi["b5"], "delta": phi["b5"], "Omega": phi["b6"] - phi["b7"],
        "epsilon": phi["b7"],
    }
    for name, value in PUBLISHED.items():
        assert got[name] == pytest.approx(value, abs=1e-12), name
    assert A.residual < 1e-15


def test_runs_and_reports_seven_bodies():
    res = planarkin.solve(planarkin.load("andrews.yaml", text=MODEL))
    assert res.status == 0, res.message
    np.testing.assert_allclose(res.body("b7")["phi"], PUBLISHED["epsilon"], atol=1e-12)
