"""The flat-faced oscillating follower (cam-rocker with flat: true), against a closed form: an
eccentric circle cam.

A disc of radius Rc whose centre sits e from the shaft (at E = e (cos theta, sin theta) in the
frame when the cam has turned by theta) touches a flat face on a rocker pivoted at D. The face is
the line through sj = (0, f) of the rocker (rocker frame at the pivot, face along its x axis), so
with the rocker at angle beta its normal is m = (-sin beta, cos beta) and it lies f from the
pivot along m. Tangency with the disc on the cam side, m^T (E - D) = Rc + f, reads
-sin(beta) X + cos(beta) Y = C with X = e cos(theta) - Dx, Y = e sin(theta) - Dy, C = Rc + f:
    beta(theta) = acos(C / rho) - atan2(X, Y),   rho = sqrt(X^2 + Y^2).
Its derivatives come here by implicit differentiation of F(beta, theta) = 0, not from the law's
expression: beta' = -F_t / F_b, beta'' = -(F_bb beta'^2 + 2 F_bt beta' + F_tt) / F_b. The
working surface seen from the cam must be the disc itself (radius Rc about (e, 0)), and the
pressure angle the angle between m and the direction R (Y - D) in which the rocker moves its
contact point Y = E - Rc m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import planarkin

TOL = 1e-12
E_, RC, DX, DY, F_ = 0.01, 0.03, 0.1, 0.06, 0.02
C_ = RC + F_


def beta_closed(th):
    X, Y = E_ * np.cos(th) - DX, E_ * np.sin(th) - DY
    return np.arccos(C_ / np.hypot(X, Y)) - np.arctan2(X, Y)


def beta_derivatives(th):
    b = beta_closed(th)
    X, Y = E_ * np.cos(th) - DX, E_ * np.sin(th) - DY
    X1, Y1 = -E_ * np.sin(th), E_ * np.cos(th)
    X2, Y2 = -E_ * np.cos(th), -E_ * np.sin(th)
    sb, cb = np.sin(b), np.cos(b)
    Fb = -cb * X - sb * Y
    Ft = -sb * X1 + cb * Y1
    Fbb = sb * X - cb * Y
    Fbt = -cb * X1 - sb * Y1
    Ftt = -sb * X2 + cb * Y2
    b1 = -Ft / Fb
    b2 = -(Fbb * b1 * b1 + 2 * Fbt * b1 + Ftt) / Fb
    return b, b1, b2


MODEL = """
units: {{length: m, angle: rad}}
parameters: {{e: {e}, Dx: {dx}, Dy: {dy}, C: {c}}}
bodies:
  cam:    {{q: [0, 0, 0]}}
  rocker: {{q: [Dx, Dy, {b0!r}]}}
joints:
  - {{type: revolute, i: ground, j: cam, at: [0, 0]}}
  - {{type: revolute, i: ground, j: rocker, at: [Dx, Dy]}}
  - name: swing
    type: cam-rocker
    i: cam
    j: rocker
    sk: [0, 0]
    pk: [Dx, Dy]
    sj: [0, {f}]
    flat: true
    face: [1, 0]
    psi: "acos(C/sqrt((e*cos(theta) - Dx)**2 + (e*sin(theta) - Dy)**2)) - atan2(e*cos(theta) - Dx, e*sin(theta) - Dy)"
drivers:
  - {{type: angle, body: cam, f: "2*pi*t + 0.5*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 90}}
"""


def model_text():
    return MODEL.format(e=E_, dx=DX, dy=DY, c=C_, f=F_, b0=float(beta_closed(0.0)))


def test_eccentric_circle_cam_flat_rocker_motion():
    """The rocker's angle, angular velocity and acceleration over a turn at varying cam speed."""
    res = planarkin.solve(planarkin.load("flat.yaml", text=model_text()))
    assert res.status == 0, res.message
    w = 2 * math.pi
    t = res.t
    th = w * t + 0.5 * np.sin(w * t)
    thd = w + 0.5 * w * np.cos(w * t)
    thdd = -0.5 * w * w * np.sin(w * t)
    b, b1, b2 = beta_derivatives(th)
    r = res.body("rocker")
    for key, want in (("phi", b), ("omega", b1 * thd), ("alpha", b2 * thd**2 + b1 * thdd)):
        err = np.max(np.abs(r[key] - want)) / np.max(np.abs(want))
        assert err < TOL, (key, err)


def test_eccentric_circle_cam_flat_rocker_profile_is_the_disc():
    """cam-swing.csv: the working surface is the disc (radius Rc about (e, 0) in the cam's
    frame), its radius of curvature Rc; the pressure angle is the closed form's."""
    res = planarkin.solve(planarkin.load("flat.yaml", text=model_text()))
    cam = res.table("cam-swing.csv")
    gap = np.hypot(cam["surface.x"] - E_, cam["surface.y"]) - RC
    assert np.max(np.abs(gap)) < TOL * RC
    assert np.max(np.abs(cam["rho_surface"] - RC)) < 1e-10 * RC
    th = cam["theta"]
    b = beta_closed(th)
    m = np.stack([-np.sin(b), np.cos(b)])
    Y = E_ * np.stack([np.cos(th), np.sin(th)]) - RC * m
    v = np.stack([-(Y[1] - DY), Y[0] - DX])
    want = np.arctan2(np.abs(v[0] * m[1] - v[1] * m[0]), np.abs((v * m).sum(axis=0)))
    assert np.max(np.abs(cam["pressure_angle"] - want)) < 1e-12
    assert np.max(cam["pressure_angle"]) > 0.1        # a rocker's flat face is not at 0 deg


def test_flat_rocker_undercut_is_an_error():
    """A swing too abrupt for a flat face (1 rad of psi'' over a small base): the envelope
    turns back on itself, so the validator refuses the cam naming the angle."""
    text = """
units: {length: m, angle: rad}
bodies:
  cam:    {q: [0, 0, 0]}
  rocker: {q: [0.1, 0.03, 3.14159]}
joints:
  - {type: revolute, i: ground, j: cam, at: [0, 0]}
  - {type: revolute, i: ground, j: rocker, at: [0.1, 0.03]}
  - {name: swing, type: cam-rocker, i: cam, j: rocker, sk: [0, 0], pk: [0.1, 0.03],
     sj: [0, 0.01], flat: true, face: [1, 0], psi: "0.3*sin(3*theta)", pressure_limit: 1.5}
drivers:
  - {type: angle, body: cam, f: "2*pi*t"}
"""
    with pytest.raises(planarkin.InputError) as exc:
        planarkin.load("undercut.yaml", text=text)
    msg = str(exc.value)
    assert "undercut.yaml:9: error: joint 'swing' (cam-rocker cam-rocker-ground): the profile " \
           "undercuts at theta = " in msg, msg
    assert "the working surface's radius of curvature" in msg and "is not positive" in msg
