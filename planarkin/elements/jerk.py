"""Third time derivatives shared by the kinds' `jerk` methods (issue 8, item 5).

A kind's jerk_g is minus every term of d^3 g/dt^3 that does not contain q''' (the rule of
reference §0 for gamma, one order up). The chains below carry a time-varying 2-vector as
(v, v', v'', v3): value, first and second derivative in full, and v3 the part of v''' without
q''' (the part with q''' is g_q q''', the left-hand side). For a body-fixed vector s = A s' of a
body turning at omega, alpha (reference §0, B = A R):

    s' = omega R s,   s'' = alpha R s - omega^2 s,
    s''' = phi''' R s - 3 omega alpha s - omega^3 R s      -> v3 = -3 omega alpha s - omega^3 R s.

Arrays are (N, K), internal units, written from the equations by hand (never by differences).
"""

from __future__ import annotations

from .base import Frame


def alpha(F: Frame, b):
    """(N, K) angular accelerations of bodies b (F.qdd)."""
    return F.qdd[:, 3 * b + 2]


def turning(s, w, a):
    """Chain of a vector s = (sx, sy) turning with the rate w and acceleration a (N, K): a
    body-fixed vector (w, a of its body) or a unit vector at a moving angle (theta', theta'')."""
    sx, sy = s
    rx, ry = -sy, sx                                   # R s
    w2 = w * w
    k, m = -3.0 * w * a, -w2 * w
    return ((sx, sy), (w * rx, w * ry), (a * rx - w2 * sx, a * ry - w2 * sy),
            (k * sx + m * rx, k * sy + m * ry))


def third(F: Frame, b, s):
    """v3 alone of the body-fixed vector s of bodies b: -3 omega alpha s - omega^3 R s."""
    w = F.qd[:, 3 * b + 2]
    k, m = -3.0 * w * alpha(F, b), -w * w * w
    return k * s[0] - m * s[1], k * s[1] + m * s[0]


def fixed(F: Frame, b, s):
    """Chain of the body-fixed (global image) vector s of bodies b."""
    return turning(s, F.qd[:, 3 * b + 2], alpha(F, b))


def origin(F: Frame, b):
    """Chain of the origins r_b of bodies b (r''' is all q''': v3 = 0)."""
    q, qd, qdd = F.q, F.qd, F.qdd
    return ((q[:, 3 * b], q[:, 3 * b + 1]), (qd[:, 3 * b], qd[:, 3 * b + 1]),
            (qdd[:, 3 * b], qdd[:, 3 * b + 1]), (0.0, 0.0))


def point(F: Frame, b, s):
    """Chain of the point r_b + s of bodies b, s the global image of its body-fixed vector."""
    return add(origin(F, b), fixed(F, b, s))


def add(u, v, sign: float = 1.0):
    """Chain of u + sign v."""
    return tuple((a[0] + sign * b[0], a[1] + sign * b[1]) for a, b in zip(u, v))


def dot(u, v):
    """The non-q''' part of (u^T v)''' = u'''^T v + 3 u''^T v' + 3 u'^T v'' + u^T v'''."""
    d = lambda a, b: a[0] * b[0] + a[1] * b[1]           # noqa: E731
    return d(u[3], v[0]) + 3.0 * d(u[2], v[1]) + 3.0 * d(u[1], v[2]) + d(u[0], v[3])


def pair(F: Frame, bi, si, bj, sj):
    """Chain of h = r_j + s_j - r_i - s_i (reference §0) for the global images si, sj."""
    return add(point(F, bj, sj), point(F, bi, si), -1.0)


def chain_rule3(d2, d3, x1, x2):
    """The non-q''' part of f(x)''' = f''' x'^3 + 3 f'' x' x'' + f' x''' for f of a linear
    combination x of coordinates (x''' is all q''': left out); d2, d3 = f'', f''' at x."""
    return d3 * x1 ** 3 + 3.0 * d2 * x1 * x2
