"""Jerk (issue 8, item 5): jerk_g of every kind against differences in time, and runs with
`up_to: jerk` against closed forms and invariants.

The element identity: along a trajectory q(t), g'' = g_q q'' - gamma_g (the definition of
gamma_g) and g''' = g_q q''' - jerk_g (that of jerk_g). So d/dt [g_q q'' - gamma_g] taken by a
central difference in t must equal g_q q''' - jerk_g: it checks jerk_g against the (separately
tested) gradient and gamma. A second check needs neither: the third difference of g itself."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from test_elements import NB, ext, random_instances  # noqa: E402

from planarkin.elements import KINDS  # noqa: E402
from planarkin.elements.base import make_frame  # noqa: E402


def trajectory(rng):
    """q(t) = q0 + q1 t + q2 t^2/2 + q3 t^3/6 and its derivatives, (1, 3 NB + 3) each at t."""
    c = [rng.normal(size=(1, 3 * NB)) * s for s in (0.8, 1.0, 1.0, 1.0)]

    def at(t):
        q = c[0] + c[1] * t + c[2] * t * t / 2 + c[3] * t ** 3 / 6
        qd = c[1] + c[2] * t + c[3] * t * t / 2
        qdd = c[2] + c[3] * t
        return ext(q), ext(qd), ext(qdd), ext(c[3])
    return at


def product(G, q, v):
    J = G.grad(make_frame(q))
    return np.einsum("nkec,nkc->nke", J, v[:, G.cols])


@pytest.mark.parametrize("name", sorted(KINDS))
def test_jerk_is_the_time_derivative_of_the_gamma_identity(name):
    rng = np.random.default_rng(11)
    kind = KINDS[name]
    for _ in range(8):
        G = random_instances(kind, rng)
        at = trajectory(rng)

        def accel(t):                            # g'' = g_q q'' - gamma_g along q(t)
            q, qd, qdd, _ = at(t)
            return product(G, q, qdd) - G.gamma(make_frame(q, qd))

        h = 1e-3
        fd = (accel(3 * h) - 9 * accel(2 * h) + 45 * accel(h) - 45 * accel(-h)
              + 9 * accel(-2 * h) - accel(-3 * h)) / (60 * h)     # sixth order
        q, qd, qdd, q3 = at(0.0)
        jerk = G.jerk(make_frame(q, qd, qdd))
        assert jerk.shape == (1, len(G), kind.neq)
        got = product(G, q, q3) - jerk
        np.testing.assert_allclose(got, fd, rtol=1e-7, atol=1e-7 * (1 + np.abs(fd).max()))

        # independent of gamma and the gradient: the third difference of g itself
        g = lambda t: G.g(make_frame(at(t)[0]))          # noqa: E731
        e = 1e-3                                          # fourth-order stencil
        d3 = (-g(3 * e) + 8 * g(2 * e) - 13 * g(e) + 13 * g(-e) - 8 * g(-2 * e)
              + g(-3 * e)) / (8 * e ** 3)
        np.testing.assert_allclose(got, d3, rtol=1e-5, atol=1e-5 * (1 + np.abs(d3).max()))


def test_a_wrong_jerk_is_detected():
    """The revolute jerk without its -3 omega alpha s term fails the check: it can fail."""
    from planarkin.elements import jerk as J
    rng = np.random.default_rng(12)
    G = random_instances(KINDS["revolute"], rng)
    at = trajectory(rng)
    q, qd, qdd, q3 = at(0.0)
    F = make_frame(q, qd, qdd)
    bi, bj, si, sj = KINDS["revolute"]._s(G, F)
    # the broken rule: only the omega^3 term of s'''
    wrong = lambda b, s: -F.qd[:, 3 * b + 2] ** 3 * np.array([-s[1], s[0]])   # noqa: E731
    broken = -(wrong(bi, si) - wrong(bj, sj))
    right = KINDS["revolute"].jerk(G, F)
    assert np.abs(np.moveaxis(broken, 0, -1) - right).max() > 1e-2
    assert J is not None
