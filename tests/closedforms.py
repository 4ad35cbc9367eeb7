"""The closed forms the tests compare planarkin against, each written once, and what the
closed-form tests of machine elements share.

Loop closures, derived by hand; velocities and accelerations are exact derivatives of the
position formulas (never differences). Checked once, in tests/test_closedforms.py, against central
differences and against an independent 50-digit solution (mpmath). The closed forms are plain
numpy, no planarkin code; benchmarks/models.py uses them too.

- four_bar_pose, four_bar: the four-bar O2-A-B-O4 (crank a at O2 = origin, coupler b, rocker c
  at O4 = (d, 0)) on either branch;
- slider_crank: the offset slider-crank (crank r at O = origin, rod l, slider on y = e);
  slider_crank_jerk: the in-line one's slider jerk at a constant crank speed;
- run, rel: a model solved from its text, and the error measure of the machine-element tests.
"""

import math

import numpy as np

import planarkin


def four_bar_pose(th, a, b, c, d, sigma=1):
    """Coupler and rocker angles (th3, th4) at crank angle th (radians, not unwrapped); sigma = +1
    the open branch (B left of A -> O4), -1 the crossed one.

    A = a e(th); with D = O4 - A, delta = |D|, psi = atan2(D) and the law of cosines in triangle
    A-B-O4: cos gam = (b^2 + delta^2 - c^2) / (2 b delta), th3 = psi + sigma gam,
    B = A + b e(th3), th4 = atan2(B - O4)."""
    Ax, Ay = a * np.cos(th), a * np.sin(th)
    Dx, Dy = d - Ax, -Ay
    delta = np.hypot(Dx, Dy)
    psi = np.arctan2(Dy, Dx)
    gam = np.arccos(np.clip((b * b + delta * delta - c * c) / (2.0 * b * delta), -1.0, 1.0))
    th3 = psi + sigma * gam
    Bx, By = Ax + b * np.cos(th3), Ay + b * np.sin(th3)
    return th3, np.arctan2(By, Bx - d)


def four_bar(th, thd, thdd, a, b, c, d, sigma=1):
    """(th3, th3', th3'', th4, th4', th4'') of the four-bar driven by the crank's th, th', th''
    (arrays over time, radians); angles unwrapped in time (continuous, as the solver keeps them:
    call on a grid fine enough to unwrap).

    Velocity: d/dt of a e(th) + b e(th3) = (d, 0) + c e(th4):
        a th' e_p(th) + b th3' e_p(th3) = c th4' e_p(th4)            (e_p(u) = de/du)
    dotted with e(th4) and e(th3), using e_p(u) . e(v) = sin(v - u):
        th3' = -a th' sin(th4 - th) / (b sin(th4 - th3))
        th4' =  a th' sin(th3 - th) / (c sin(th3 - th4))
    Acceleration: a th'' e_p(th) - a th'^2 e(th) + b th3'' e_p(th3) - b th3'^2 e(th3)
                  = c th4'' e_p(th4) - c th4'^2 e(th4), dotted with e(th4) and e(th3)
    (e(u) . e(v) = cos(u - v)):
        th3'' = (-c th4'^2 - a th'' sin(th4 - th) + a th'^2 cos(th - th4)
                 + b th3'^2 cos(th3 - th4)) / (b sin(th4 - th3))
        th4'' = (a th'' sin(th3 - th) - a th'^2 cos(th - th3) - b th3'^2
                 + c th4'^2 cos(th4 - th3)) / (c sin(th3 - th4))
    valid on either branch."""
    th3, th4 = four_bar_pose(th, a, b, c, d, sigma)
    th3, th4 = np.unwrap(np.atleast_1d(th3)), np.unwrap(np.atleast_1d(th4))
    w3 = -a * thd * np.sin(th4 - th) / (b * np.sin(th4 - th3))
    w4 = a * thd * np.sin(th3 - th) / (c * np.sin(th3 - th4))
    al3 = (-c * w4 ** 2 - a * thdd * np.sin(th4 - th) + a * thd ** 2 * np.cos(th - th4)
           + b * w3 ** 2 * np.cos(th3 - th4)) / (b * np.sin(th4 - th3))
    al4 = (a * thdd * np.sin(th3 - th) - a * thd ** 2 * np.cos(th - th3) - b * w3 ** 2
           + c * w4 ** 2 * np.cos(th4 - th3)) / (c * np.sin(th3 - th4))
    return th3, w3, al3, th4, w4, al4


def slider_crank(th, thd, thdd, r, l, e=0.0):
    """(be, be', be'', x, x', x'') of the slider-crank driven by the crank's th, th', th'': be the
    rod's angle, x the slider pin B = (x, e), on the branch cos be > 0 (B right of the crank pin).

    Loop O -> A -> B:  r sin th + l sin be = e,  x = r cos th + l cos be.
    cos be = sqrt((l - e + r sin th)(l + e - r sin th)) / l, in product form (and for e = 0 with
    l -+ r sin th = (l - r) + 2 r sin^2(pi/4 -+ th/2)) so that it stays accurate near the toggle
    cos be -> 0. The y equation differentiated once and twice:
        be'  = -r cos th th' / (l cos be)
        be'' = (r sin th th'^2 - r cos th th'' + l sin be be'^2) / (l cos be)
    and the x equation:
        x'  = -r sin th th' - l sin be be'
        x'' = -r cos th th'^2 - r sin th th'' - l cos be be'^2 - l sin be be''."""
    st, ct = np.sin(th), np.cos(th)
    if e == 0.0:
        lo = (l - r) + 2.0 * r * np.sin(math.pi / 4 - th / 2) ** 2     # l - r sin th
        hi = (l - r) + 2.0 * r * np.sin(math.pi / 4 + th / 2) ** 2     # l + r sin th
    else:
        lo, hi = l - e + r * st, l + e - r * st
    cb = np.sqrt(np.maximum(lo * hi, 0.0)) / l
    sb = (e - r * st) / l
    be = np.arctan2(sb, cb)
    bed = -r * ct * thd / (l * cb)
    bedd = (r * st * thd ** 2 - r * ct * thdd + l * sb * bed ** 2) / (l * cb)
    x = r * ct + l * cb
    xd = -r * st * thd - l * sb * bed
    xdd = -r * ct * thd ** 2 - r * st * thdd - l * cb * bed ** 2 - l * sb * bedd
    return be, bed, bedd, x, xd, xdd


def slider_crank_jerk(th, w, r, l):
    """x''' of the in-line slider-crank's slider (e = 0) at crank angle th turning at the
    constant speed w: x(th) = r cos th + D, D = sqrt(l^2 - r^2 sin^2 th), differentiated by hand
    in th: with u = r^2 sin th cos th (u' = r^2 cos 2th, u'' = -2 r^2 sin 2th), D' = -u/D,
    D'' = -u'/D - u^2/D^3, D''' = -u''/D - 3 u u'/D^3 - 3 u^3/D^5, so
    x''' = w^3 (r sin th + D''')."""
    S = np.sin(th)
    D = np.sqrt(l * l - r * r * S * S)
    u = r * r * S * np.cos(th)
    u1, u2 = r * r * np.cos(2 * th), -2 * r * r * np.sin(2 * th)
    return w ** 3 * (r * S - u2 / D - 3 * u * u1 / D ** 3 - 3 * u ** 3 / D ** 5)


def run(text: str, name: str = "model.yaml"):
    """The Result of the model written in text (name: its file name in messages); it must run."""
    res = planarkin.solve(planarkin.load(name, text=text))
    assert res.status == 0, res.message
    return res


def rel(got, want, scale=None) -> float:
    """Largest |got - want| over the run, relative to the largest |want| (or scale)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    s = scale if scale is not None else np.max(np.abs(want))
    return float(np.max(np.abs(got - want)) / s)
