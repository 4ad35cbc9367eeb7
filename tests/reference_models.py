"""Reference mechanisms for tests/test_reference.py: YAML model texts and closed-form kinematics.

Every closed form below is derived by hand (derivations in the comments) and differentiated
analytically: velocities and accelerations are exact derivatives of the position formulas, never
finite differences. Each `*_closed_form` function returns

    {"bodies": {name: {x, y, phi, vx, vy, omega, ax, ay, alpha}},
     "points": {name: {x, y, vx, vy, ax, ay}}}

with arrays over the time grid, in the same units as the model's results (angles in degrees,
deg/s, deg/s^2 when the model says units: {angle: deg}).

Notation: e(u) = [cos u, sin u], e_perp(u) = [-sin u, cos u] = de/du. For a rigid body with
origin r, angle phi and a body-fixed point s' (s = A(phi) s'):
    P = r + s,   V = r' + phi' R s,   A = r'' + phi'' R s - phi'^2 s      (R: +90 deg rotation)
which is the exact time derivative of P (R s = dA/dphi s').
"""

from __future__ import annotations

import math

import numpy as np

from closedforms import four_bar, slider_crank

TWO_PI = 2.0 * math.pi


# -- helpers ---------------------------------------------------------------------------------------

def body(x, y, phi, vx, vy, omega, ax, ay, alpha):
    """A closed-form body record; scalars are broadcast to the grid by `broadcast`."""
    return dict(x=x, y=y, phi=phi, vx=vx, vy=vy, omega=omega, ax=ax, ay=ay, alpha=alpha)


def fixed_pivot_body(x0, y0, phi, w, al):
    """A body whose frame origin is a ground pivot (x0, y0): only the angle moves."""
    return body(x0, y0, phi, 0.0, 0.0, w, 0.0, 0.0, al)


def rigid_point(b: dict, s) -> dict:
    """P, V, A of the body-fixed point s' = s of body b (angles in radians), see module docstring:
    P = r + A s', V = r' + w R A s', A = r'' + alpha R A s' - w^2 A s'."""
    c, sn = np.cos(b["phi"]), np.sin(b["phi"])
    sx = c * s[0] - sn * s[1]
    sy = sn * s[0] + c * s[1]
    w, al = b["omega"], b["alpha"]
    return dict(x=b["x"] + sx, y=b["y"] + sy,
                vx=b["vx"] - w * sy, vy=b["vy"] + w * sx,
                ax=b["ax"] - al * sy - w * w * sx, ay=b["ay"] + al * sx - w * w * sy)


def broadcast(cf: dict, t: np.ndarray) -> dict:
    out = {"bodies": {}, "points": {}}
    for sec in ("bodies", "points"):
        for name, rec in cf.get(sec, {}).items():
            out[sec][name] = {k: np.broadcast_to(np.asarray(v, float), t.shape).copy()
                              for k, v in rec.items()}
    return out


def to_degrees(cf: dict) -> dict:
    """Angles, angular velocities and accelerations in degrees (units: {angle: deg})."""
    for rec in cf["bodies"].values():
        for k in ("phi", "omega", "alpha"):
            rec[k] = np.degrees(rec[k])
    return cf


def uniform(w=TWO_PI, phase=0.0):
    """theta = phase + w t: (theta, theta', theta'') as functions of t."""
    return lambda t: (phase + w * t, w + 0.0 * t, 0.0 * t)


def wobbly(t):
    """theta = 2 pi t + 0.3 sin(2 pi t): theta' = 2 pi (1 + 0.3 cos 2 pi t) > 0,
    theta'' = -0.3 (2 pi)^2 sin 2 pi t."""
    return (TWO_PI * t + 0.3 * np.sin(TWO_PI * t),
            TWO_PI * (1.0 + 0.3 * np.cos(TWO_PI * t)),
            -0.3 * TWO_PI ** 2 * np.sin(TWO_PI * t))


# == 1. Offset slider-crank ========================================================================

SLIDER_CRANK = dict(a=0.08, b=0.25, e=0.03, P=(0.10, 0.02))

SLIDER_CRANK_YAML = """\
# Offset slider-crank. The crank O-A turns about the ground pivot O = (0, 0); the connecting rod
# A-B drives a slider (piston) whose axis is the horizontal line y = e (parameter h), above O.
# Body frames: crank at O along O->A; rod at the crank pin A along A->B; slider at the pin B.
name: offset-slider-crank
units: {length: m, angle: rad}
parameters:
  a: 0.08          # crank radius O-A
  b: 0.25          # connecting rod A-B (b > a + h: the crank turns fully)
  h: 0.03          # offset e of the slider axis above O ('e' itself is the constant 2.718...)
bodies:            # rough estimates at t = 0; true pose: crank 0 rad, rod at (0.08, 0) at
                   # asin(h/b) = 0.1203 rad, slider at (0.3282, 0.03)
  crank:  {q: [0.002, -0.003, 0.05]}
  rod:    {q: [0.078, 0.004, 0.16]}
  slider: {q: [0.318, 0.031, 0.02]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}    # main bearing O
  - {type: revolute, i: crank, j: rod, si: [a, 0], sj: [0, 0]}       # crank pin A
  - {type: revolute, i: rod, j: slider, si: [b, 0], sj: [0, 0]}      # gudgeon pin B
  - {type: translational, i: ground, j: slider, si: [0, h], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "@F@"}
points:
  P: {body: rod, s: [0.10, 0.02]}     # a point of the rod web, off its centre line
analysis: {start: 0, end: 1, steps: 200}
"""


def slider_crank_yaml(f="2*pi*t"):
    return SLIDER_CRANK_YAML.replace("@F@", f)


def slider_crank_bodies(th, thd, thdd, a, b, e=0.0) -> dict:
    """Crank (frame at O), rod (frame at the crank pin A = a e(th)) and slider (at B = (xB, e))
    of a slider-crank driven by th, th', th'' (closedforms.slider_crank, B right of A), before
    `broadcast`. A' = a th' e_perp(th), A'' = a th'' e_perp(th) - a th'^2 e(th)."""
    be, bed, bedd, xB, xBd, xBdd = slider_crank(th, thd, thdd, a, b, e)
    crank = fixed_pivot_body(0.0, 0.0, th, thd, thdd)
    A = rigid_point(crank, (a, 0.0))
    rod = body(A["x"], A["y"], be, A["vx"], A["vy"], bed, A["ax"], A["ay"], bedd)
    slider = body(xB, e, 0.0, xBd, 0.0, 0.0, xBdd, 0.0, 0.0)
    return {"crank": crank, "rod": rod, "slider": slider}


def slider_crank_closed_form(t, theta_fn=uniform(TWO_PI)):
    """Bodies and rod point P of SLIDER_CRANK_YAML."""
    a, b, e = SLIDER_CRANK["a"], SLIDER_CRANK["b"], SLIDER_CRANK["e"]
    bodies = slider_crank_bodies(*theta_fn(t), a, b, e)
    return broadcast({"bodies": bodies, "points": {"P": rigid_point(bodies["rod"],
                                                                    SLIDER_CRANK["P"])}}, t)


# == 2. / 6. Four-bar crank-rocker =================================================================

FOURBAR = dict(a=0.04, b=0.12, c=0.10, d=0.13, P=(0.07, 0.035))
# Grashof: s + l = 0.04 + 0.13 = 0.17 < p + q = 0.12 + 0.10 = 0.22, the shortest link is the
# crank: a crank-rocker.

FOURBAR_DEG_YAML = """\
# Crank-rocker four-bar, angles in degrees (q, f and every angular result: deg, deg/s, deg/s^2).
# Ground pivots O2 = (0, 0) (crank) and O4 = (d, 0) (rocker). Body frames: crank at O2 along
# O2->A; coupler at A along A->B; rocker at O4 along O4->B. Open configuration (B above A-O4).
name: crank-rocker-deg
units: {length: m, angle: deg}
parameters:
  a: 0.04          # crank O2-A (shortest link)
  b: 0.12          # coupler A-B
  c: 0.10          # rocker O4-B
  d: 0.13          # ground O2-O4 (longest link; 0.04 + 0.13 < 0.12 + 0.10: Grashof)
bodies:            # rough estimates at t = 0; true pose: crank 0 deg, coupler at (0.04, 0) at
                   # 54.64 deg, rocker at (0.13, 0) at 101.87 deg
  crank:   {q: [0.001, 0.002, 3]}
  coupler: {q: [0.041, -0.002, 51]}
  rocker:  {q: [0.128, 0.001, 105]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}      # O2
  - {type: revolute, i: crank, j: coupler, si: [a, 0], sj: [0, 0]}     # A
  - {type: revolute, i: coupler, j: rocker, si: [b, 0], sj: [c, 0]}    # B
  - {type: revolute, i: ground, j: rocker, si: [d, 0], sj: [0, 0]}     # O4
drivers:
  - {type: angle, body: crank, f: "360*t"}      # one turn per second, in degrees
points:
  P: {body: coupler, s: [0.07, 0.035]}          # coupler point, off the line A-B
analysis: {start: 0, end: 1, steps: 360}
"""


def fourbar_bodies(th, thd, thdd, a, b, c, d, sigma=1) -> dict:
    """Crank (frame at O2), coupler (frame at A along A->B) and rocker (frame at O4 along
    O4->B) of a four-bar driven by th, th', th'' (closedforms.four_bar, branch sigma), before
    `broadcast`."""
    th3, w3, al3, th4, w4, al4 = four_bar(th, thd, thdd, a, b, c, d, sigma)
    crank = fixed_pivot_body(0.0, 0.0, th, thd, thdd)
    A = rigid_point(crank, (a, 0.0))
    coupler = body(A["x"], A["y"], th3, A["vx"], A["vy"], w3, A["ax"], A["ay"], al3)
    return {"crank": crank, "coupler": coupler, "rocker": fixed_pivot_body(d, 0.0, th4, w4, al4)}


def fourbar_closed_form(t, theta_fn=uniform(TWO_PI), frames="pins", degrees=False):
    """Bodies and coupler point P of the crank-rocker. frames='pins': frames as in
    FOURBAR_DEG_YAML; frames='mid': every frame at its link's midpoint (fourbar_at_yaml)."""
    a, b, c, d = (FOURBAR[k] for k in "abcd")
    bd = fourbar_bodies(*theta_fn(t), a, b, c, d)
    crank, coupler, rocker = bd["crank"], bd["coupler"], bd["rocker"]
    sP = FOURBAR["P"]
    if frames == "mid":
        # the frame of a link at its midpoint is the body-fixed point (length/2, 0) of the
        # pin-framed body: same angle, r, r', r'' from rigid_point
        def mid(bd, half):
            p = rigid_point(bd, (half, 0.0))
            return body(p["x"], p["y"], bd["phi"], p["vx"], p["vy"], bd["omega"], p["ax"],
                        p["ay"], bd["alpha"])
        crank, coupler, rocker = mid(crank, a / 2), mid(coupler, b / 2), mid(rocker, c / 2)
        sP = (sP[0] - b / 2, sP[1])
    cf = {"bodies": {"crank": crank, "coupler": coupler, "rocker": rocker},
          "points": {"P": rigid_point(coupler, sP)}}
    cf = broadcast(cf, t)
    return to_degrees(cf) if degrees else cf


def fourbar_at_yaml(th0=0.7):
    """The crank-rocker (radians) placed by global points: every body at its EXACT pose at t = 0
    (frames at the link midpoints), joints with at: [x, y], the coupler point with at."""
    cf = fourbar_closed_form(np.array([0.0]), uniform(TWO_PI, th0), frames="mid")
    pins = fourbar_closed_form(np.array([0.0]), uniform(TWO_PI, th0), frames="pins")
    B = rigid_point({k: v[0] for k, v in pins["bodies"]["rocker"].items()},
                    (FOURBAR["c"], 0.0))
    A = rigid_point({k: v[0] for k, v in pins["bodies"]["crank"].items()}, (FOURBAR["a"], 0.0))
    P = cf["points"]["P"]
    q = {k: "[%r, %r, %r]" % (float(v["x"][0]), float(v["y"][0]), float(v["phi"][0]))
         for k, v in cf["bodies"].items()}
    return f"""\
# The crank-rocker of FOURBAR (radians), placed by global points: the bodies at their exact
# poses at t = 0 (crank angle {th0}), body frames at the link midpoints, joints by position.
name: crank-rocker-at
units: {{length: m, angle: rad}}
bodies:
  crank:   {{q: {q['crank']}}}
  coupler: {{q: {q['coupler']}}}
  rocker:  {{q: {q['rocker']}}}
joints:
  - {{type: revolute, i: ground, j: crank, at: [0, 0]}}                 # O2
  - {{type: revolute, i: crank, j: coupler, at: [{float(A['x'])!r}, {float(A['y'])!r}]}}   # A
  - {{type: revolute, i: coupler, j: rocker, at: [{float(B['x'])!r}, {float(B['y'])!r}]}}  # B
  - {{type: revolute, i: rocker, j: ground, at: [{FOURBAR['d']!r}, 0]}}      # O4
drivers:
  - {{type: angle, body: crank, f: "{th0} + 2*pi*t"}}
points:
  P: {{body: coupler, at: [{float(P['x'][0])!r}, {float(P['y'][0])!r}]}}
analysis: {{start: 0, end: 1, steps: 240}}
"""


FOURBAR_SISJ_YAML = """\
# The same crank-rocker as fourbar_at_yaml, written with body-frame joint points (frames at the
# link midpoints) and rough pose estimates.
name: crank-rocker-sisj
units: {length: m, angle: rad}
parameters: {a: 0.04, b: 0.12, c: 0.10, d: 0.13}
bodies:            # true pose at t = 0: crank (0.0153, 0.0129, 0.7), coupler (0.0778, 0.0628,
                   # 0.6656), rocker (0.1275, 0.0499, 1.6210)
  crank:   {q: [0.015, 0.013, 0.68]}
  coupler: {q: [0.076, 0.064, 0.63]}
  rocker:  {q: [0.129, 0.048, 1.67]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [-a/2, 0]}
  - {type: revolute, i: crank, j: coupler, si: [a/2, 0], sj: [-b/2, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [b/2, 0], sj: [c/2, 0]}
  - {type: revolute, i: rocker, j: ground, si: [-c/2, 0], sj: [d, 0]}
drivers:
  - {type: angle, body: crank, f: "0.7 + 2*pi*t"}
points:
  P: {body: coupler, s: [0.07 - b/2, 0.035]}
analysis: {start: 0, end: 1, steps: 240}
"""


# == 3. Whitworth quick-return (inverted slider-crank) ============================================

WHITWORTH = dict(r=0.10, d=0.04, l=0.20, T=(0.20, 0.01))

WHITWORTH_BLOCK_YAML = """\
# Whitworth quick-return: the crank O2-A (O2 = (0, 0)) carries at A a block that slides in the
# slot of a lever pivoted at O4 = (0, -d). d < r, so the slotted lever turns fully, slowly while
# A is above O4's horizontal and fast below (the quick return).
# Body frames: crank at O2 along O2->A; lever at O4 along its slot; block at A, along the slot.
name: whitworth-block
units: {length: m, angle: rad}
parameters:
  r: 0.10          # crank O2-A
  d: 0.04          # O2-O4, the lever pivot below the crank pivot
  l: 0.20          # lever length to its tip
bodies:            # rough estimates at t = 0; true: lever and block at atan2(d, r) = 0.3805 rad,
                   # block at A = (0.1, 0)
  crank: {q: [0.002, 0.001, 0.04]}
  lever: {q: [0.001, -0.042, 0.35]}
  block: {q: [0.097, 0.003, 0.36]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}      # O2
  - {type: revolute, i: ground, j: lever, si: [0, -d], sj: [0, 0]}     # O4
  - {type: revolute, i: crank, j: block, si: [r, 0], sj: [0, 0]}       # crank pin A in the block
  - {type: translational, i: lever, j: block, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
points:
  T: {body: lever, s: [l, 0.01]}      # lever tip (the connecting-rod pin to the ram)
analysis: {start: 0, end: 1, steps: 240}
"""

WHITWORTH_PINSLOT_YAML = """\
# The same Whitworth quick-return with the crank pin A running directly in the lever's slot
# (pin-slot composite joint, no block body).
name: whitworth-pin-slot
units: {length: m, angle: rad}
parameters: {r: 0.10, d: 0.04, l: 0.20}
bodies:
  crank: {q: [0.002, 0.001, 0.04]}
  lever: {q: [0.001, -0.042, 0.35]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: ground, j: lever, si: [0, -d], sj: [0, 0]}
  - {type: pin-slot, i: lever, j: crank, si: [0, 0], vi: [1, 0], sj: [r, 0]}
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
points:
  T: {body: lever, s: [l, 0.01]}
analysis: {start: 0, end: 1, steps: 240}
"""


def whitworth_closed_form(t, theta_fn=uniform(TWO_PI)):
    """A - O4 = (u, v) = (r cos th, r sin th + d) = rho e(ph):
        ph = atan2(v, u) (unwrapped),  rho^2 = r^2 + d^2 + 2 r d sin th.
    With u' = -r sin th th', v' = r cos th th':
        ph' = (u v' - v u') / rho^2 = r (r + d sin th) th' / rho^2 = N / rho^2
        rho rho' = u u' + v v' = r d cos th th'  =>  rho' = r d cos th th' / rho
        ph'' = (N' rho^2 - N (rho^2)') / rho^4,  N' = r d cos th th'^2 + r (r + d sin th) th'',
               (rho^2)' = 2 r d cos th th'
        rho rho'' + rho'^2 = r d (cos th th'' - sin th th'^2)
    The block is at A (x, y of the crank pin), at the lever's angle ph; its slide along the slot
    (from O4) is rho.
    """
    r, d = WHITWORTH["r"], WHITWORTH["d"]
    th, thd, thdd = theta_fn(t)
    ct, st = np.cos(th), np.sin(th)
    u, v = r * ct, r * st + d
    ph = np.unwrap(np.atleast_1d(np.arctan2(v, u)))
    rho2 = r * r + d * d + 2 * r * d * st
    rho = np.sqrt(rho2)
    N = r * (r + d * st) * thd
    phd = N / rho2
    Nd = r * d * ct * thd ** 2 + r * (r + d * st) * thdd
    phdd = (Nd * rho2 - N * 2 * r * d * ct * thd) / rho2 ** 2
    rhod = r * d * ct * thd / rho
    rhodd = (r * d * (ct * thdd - st * thd ** 2) - rhod ** 2) / rho
    crank = fixed_pivot_body(0.0, 0.0, th, thd, thdd)
    lever = fixed_pivot_body(0.0, -d, ph, phd, phdd)
    A = rigid_point(crank, (r, 0.0))
    block = body(A["x"], A["y"], ph, A["vx"], A["vy"], phd, A["ax"], A["ay"], phdd)
    cf = broadcast({"bodies": {"crank": crank, "lever": lever, "block": block},
                    "points": {"T": rigid_point(lever, WHITWORTH["T"])}}, t)
    cf["slide"] = {"s": rho, "v": rhod, "a": rhodd}
    return cf


# == 4. Elliptical trammel =========================================================================

TRAMMEL = dict(L=0.5, p=0.2)

TRAMMEL_YAML = """\
# Elliptical trammel (trammel of Archimedes): slider 1 runs on the x axis, slider 2 on the y axis,
# a bar of length L is pinned to both (A on slider 1, B on slider 2). Slider 1 is driven in x
# between -0.8 L and 0.8 L (clear of the dead positions |x| = L). A bar point at p from A traces
# the ellipse (x / (L - p))^2 + (y / p)^2 = 1.
# Body frames: sliders at their pins; bar at A along A->B.
name: elliptical-trammel
units: {length: m, angle: rad}
parameters:
  L: 0.5           # bar length A-B
  p: 0.2           # tracing point, from A along the bar
bodies:            # rough estimates at t = 0; true: slider 1 at (0.4, 0), slider 2 at (0, 0.3),
                   # bar at A, acos(-0.8) = 2.4981 rad
  slider1: {q: [0.39, 0.004, 0.01]}
  slider2: {q: [0.006, 0.29, -0.02]}
  bar:     {q: [0.395, -0.003, 2.45]}
joints:
  - {type: translational, i: ground, j: slider1, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
  - {type: translational, i: ground, j: slider2, si: [0, 0], sj: [0, 0], vi: [0, 1], vj: [0, 1]}
  - {type: revolute, i: slider1, j: bar, si: [0, 0], sj: [0, 0]}       # A
  - {type: revolute, i: bar, j: slider2, si: [L, 0], sj: [0, 0]}       # B
drivers:
  - {type: x, body: slider1, f: "0.8*L*cos(2*pi*t)"}
points:
  P: {body: bar, s: [p, 0]}
analysis: {start: 0, end: 1, steps: 300}
"""


def trammel_closed_form(t):
    """x1 = 0.8 L cos(w t) (w = 2 pi): x1' = -0.8 L w sin, x1'' = -0.8 L w^2 cos.
    B = A + L e(be) lies on the y axis: x1 + L cos be = 0 => be = acos(-x1/L) in (0, pi)
    (slider 2 above the x axis), y2 = L sin be.
        -sin be be' = -x1'/L                    =>  be' = x1' / (L sin be)
        -cos be be'^2 - sin be be'' = -x1''/L   =>  be'' = (x1''/L - cos be be'^2) / sin be
        y2' = L cos be be',  y2'' = L (cos be be'' - sin be be'^2)
    """
    L, p = TRAMMEL["L"], TRAMMEL["p"]
    w = TWO_PI
    x1 = 0.8 * L * np.cos(w * t)
    x1d = -0.8 * L * w * np.sin(w * t)
    x1dd = -0.8 * L * w * w * np.cos(w * t)
    be = np.arccos(-x1 / L)
    cb, sb = np.cos(be), np.sin(be)
    bed = x1d / (L * sb)
    bedd = (x1dd / L - cb * bed ** 2) / sb
    y2, y2d, y2dd = L * sb, L * cb * bed, L * (cb * bedd - sb * bed ** 2)
    slider1 = body(x1, 0.0, 0.0, x1d, 0.0, 0.0, x1dd, 0.0, 0.0)
    slider2 = body(0.0, y2, 0.0, 0.0, y2d, 0.0, 0.0, y2dd, 0.0)
    bar = body(x1, 0.0, be, x1d, 0.0, bed, x1dd, 0.0, bedd)
    return broadcast({"bodies": {"slider1": slider1, "slider2": slider2, "bar": bar},
                      "points": {"P": rigid_point(bar, (p, 0.0))}}, t)


# == 5. Boom raised by a hydraulic cylinder ========================================================

BOOM = dict(C=(0.4, -0.3), sP=(0.9, -0.1), tip=(2.0, 0.0))

BOOM_YAML = """\
# A boom pinned to the ground at O = (0, 0), raised by a hydraulic cylinder between the ground
# bracket C = (0.4, -0.3) and the boom bracket P (0.9 m along the boom, 0.1 m below its axis).
# The cylinder is a distance driver: |P - C| = f(t). Body frame: boom at O along the boom axis.
name: boom
units: {length: m, angle: rad}
parameters:
  L0: @L0@         # cylinder length (pin to pin) at t = 0
  v: 0.3           # extension speed, m/s
  s: 0.18          # stroke amplitude of the oscillating run, m
bodies:            # rough estimate at t = 0; true: @TRUE@ rad
  boom: {q: [0.01, -0.01, @EST@]}
joints:
  - {type: revolute, i: ground, j: boom, si: [0, 0], sj: [0, 0]}       # boom foot O
drivers:
  - {type: distance, name: cylinder, i: ground, j: boom, si: [0.4, -0.3], sj: [0.9, -0.1],
     f: "@F@"}
points:
  tip: {body: boom, s: [2.0, 0]}       # boom tip
  P:   {body: boom, s: [0.9, -0.1]}    # cylinder rod eye
analysis: {start: 0, end: @END@, steps: 300}
"""

BOOM_RUNS = {
    # f(t), f'(t), f''(t), L0, estimate of the boom angle at t = 0 (true value), end
    "linear": (lambda t: (0.65 + 0.3 * t, 0.3 + 0.0 * t, 0.0 * t), "L0 + v*t", 0.65,
               0.25, 0.2413, "1"),
    "sine": (lambda t: (0.75 + 0.18 * np.sin(t), 0.18 * np.cos(t), -0.18 * np.sin(t)),
             "L0 + s*sin(t)", 0.75, 0.42, 0.4430, "2*pi"),
}


def boom_yaml(run):
    _, f, L0, est, true, end = BOOM_RUNS[run]
    return (BOOM_YAML.replace("@L0@", repr(L0)).replace("@F@", f).replace("@EST@", repr(est))
            .replace("@TRUE@", repr(true)).replace("@END@", end))


def boom_closed_form(t, run):
    """With S = |s'_P|, al_P = atan2(s'_P), Cn = |C|, al_C = atan2(C) and the boom angle th:
        |A(th) s'_P - C|^2 = S^2 + Cn^2 - 2 S Cn cos(psi) = f^2,  psi = th + al_P - al_C
    so  cos psi = K = (S^2 + Cn^2 - f^2) / (2 S Cn), psi = acos K in (0, pi) (the cylinder is
    below and ahead of the boom: P is counter-clockwise of C seen from O).
        K' = -f f' / (S Cn),  K'' = -(f'^2 + f f'') / (S Cn)
        -sin psi psi' = K'                        => psi' = -K' / sin psi
        -cos psi psi'^2 - sin psi psi'' = K''     => psi'' = -(K'' + cos psi psi'^2) / sin psi
    th = psi - al_P + al_C, th' = psi', th'' = psi''.
    """
    fn = BOOM_RUNS[run][0]
    f, fd, fdd = fn(t)
    Cx, Cy = BOOM["C"]
    S = math.hypot(*BOOM["sP"])
    Cn = math.hypot(Cx, Cy)
    alP = math.atan2(BOOM["sP"][1], BOOM["sP"][0])
    alC = math.atan2(Cy, Cx)
    K = (S * S + Cn * Cn - f * f) / (2 * S * Cn)
    Kd = -f * fd / (S * Cn)
    Kdd = -(fd * fd + f * fdd) / (S * Cn)
    psi = np.arccos(K)
    psid = -Kd / np.sin(psi)
    psidd = -(Kdd + np.cos(psi) * psid ** 2) / np.sin(psi)
    boom = fixed_pivot_body(0.0, 0.0, psi - alP + alC, psid, psidd)
    return broadcast({"bodies": {"boom": boom},
                      "points": {"tip": rigid_point(boom, BOOM["tip"]),
                                 "P": rigid_point(boom, BOOM["sP"])}}, t)
