"""planarkin.clearance.geometry: exact distances between rounded point sets (closest features,
not sampling), overlap and its depth, and the distance's exact rate and acceleration."""

import numpy as np
import pytest

from planarkin.clearance.geometry import (Motion, convex_hull, core, inside, is_convex,
                                          self_crossing, separation)


def still(N, x=0.0, y=0.0, phi=0.0):
    z = np.zeros(N)
    return Motion(np.tile([x, y], (N, 1)), z + phi, np.zeros((N, 2)), z.copy(),
                  np.zeros((N, 2)), z.copy())


def turning(t, w, phi0=0.0, x=0.0, y=0.0, al=0.0):
    """A body turning about its origin at (x, y): phi = phi0 + w t + al t^2 / 2."""
    N = len(t)
    return Motion(np.tile([x, y], (N, 1)), phi0 + w * t + 0.5 * al * t * t, np.zeros((N, 2)),
                  w + al * t, np.zeros((N, 2)), np.full(N, al))


def test_two_circles():
    t = np.linspace(0, 1, 7)
    A = core([[0.0, 0.0]], 1.0, True)
    B = core([[2.0, 0.0]], 0.5, True)          # a disc off the centre of a turning body
    S = separation(A, still(7), B, turning(t, 3.0, x=5.0))
    th = 3.0 * t
    c = np.stack([5 + 2 * np.cos(th), 2 * np.sin(th)], axis=1)
    r = np.hypot(c[:, 0], c[:, 1])
    assert np.allclose(S.d, r - 1.5, rtol=0, atol=1e-14)
    # r^2 = 29 + 20 cos th: r r' = -30 sin th, r'' = (-90 cos th - r'^2) / r
    r1 = -30 * np.sin(th) / r
    assert np.allclose(S.d1, r1, rtol=0, atol=1e-13)
    assert np.allclose(S.d2, (-90 * np.cos(th) - r1 ** 2) / r, rtol=0, atol=1e-12)
    assert np.allclose(S.pa, c / r[:, None], atol=1e-14)
    assert np.allclose(S.pb, c - 0.5 * c / r[:, None], atol=1e-14)


def test_a_vertex_against_a_turning_edge():
    # a point at (px, py) against the line through the origin at angle al(t) = 0.2 + w t + a t^2/2
    t = np.linspace(0, 0.2, 9)
    w, acc = 1.3, 0.7
    A = core([[-10.0, 0.0], [10.0, 0.0]], 0.0, False)
    B = core([[0.0, 0.0]], 0.0, True)
    px, py = 0.3, 2.0
    S = separation(A, turning(t, w, 0.2, al=acc), B, still(9, px, py))
    al, w_t = 0.2 + w * t + 0.5 * acc * t * t, w + acc * t
    d = -np.sin(al) * px + np.cos(al) * py
    d1 = w_t * (-np.cos(al) * px - np.sin(al) * py)
    d2 = acc * (-np.cos(al) * px - np.sin(al) * py) + w_t ** 2 * (np.sin(al) * px -
                                                                    np.cos(al) * py)
    assert np.allclose(S.d, d, atol=1e-14)
    assert np.allclose(S.d1, d1, atol=1e-13)
    assert np.allclose(S.d2, d2, atol=1e-12)


def test_overlapping_convex_cores_have_the_depth_of_the_separating_axis():
    sq = [[0, 0], [2, 0], [2, 2], [0, 2]]
    A, B = core(sq, 0.1, True), core(sq, 0.2, True)
    S = separation(A, still(1), B, still(1, 1.5, 0.3))
    assert S.d[0] == pytest.approx(-0.5 - 0.3, abs=1e-14)      # 0.5 deep along x
    assert np.isnan(S.d1[0]) and np.isnan(S.d2[0])
    assert S.pb[0][0] - S.pa[0][0] == pytest.approx(-0.8, abs=1e-14)


def test_a_core_inside_another_is_an_overlap_and_a_notch_is_not():
    L = [[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]]        # an L, not convex
    A = core(L, 0.0, True)
    assert not A.convex
    S = separation(A, still(2), core([[0.5, 0.5]], 0.1, True), Motion(
        np.array([[0.0, 0.0], [2.0, 2.0]]), np.zeros(2)))
    assert S.d[0] < 0                       # inside the L's foot
    # in the notch at (2.5, 2.5): 1.5 from both inner edges, less the radius
    assert S.d[1] == pytest.approx(1.5 - 0.1, abs=1e-14)


def test_crossing_edges_overlap():
    A = core([[-1, 0], [1, 0]], 0.0, False)
    B = core([[0, -1], [0, 1]], 0.0, False)
    S = separation(A, still(1), B, still(1, 0.3, 0.2))
    assert S.d[0] == -0.0 or S.d[0] < 0


def test_against_sampled_outlines():
    rng = np.random.default_rng(29)
    for _ in range(25):
        P = rng.normal(size=(rng.integers(1, 6), 2))
        Q = rng.normal(size=(rng.integers(1, 6), 2))
        A = core(convex_hull(P), rng.uniform(0, 0.2), True)
        B = core(Q, rng.uniform(0, 0.2), False)
        MB = still(1, *rng.normal(size=2) * 3, rng.uniform(0, 6))
        S = separation(A, still(1), B, MB)
        # dense samples of both cores' edges
        VB = MB.place(B.points)[0]

        def samples(V, E):
            s = np.linspace(0, 1, 301)[:, None]
            return np.concatenate([V[a] + s * (V[b] - V[a]) for a, b in E])
        sa, sb = samples(A.points, A.edges), samples(VB, B.edges)
        if S.d[0] > 0:
            brute = np.min(np.hypot(*(sa[:, None] - sb[None]).transpose(2, 0, 1)))
            assert S.d[0] == pytest.approx(brute - A.radius - B.radius, abs=2e-3)
            assert S.d[0] <= brute - A.radius - B.radius + 1e-15


def test_convexity_hull_and_self_crossing():
    assert is_convex(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))
    assert not is_convex(np.array([[0, 0], [2, 0], [1, 0.5], [2, 2], [0, 2]], float))
    assert self_crossing([[0, 0], [1, 1], [1, 0], [0, 1]]) == (0, 2)
    assert self_crossing([[0, 0], [2, 0], [2, 2], [0, 2]]) is None
    assert self_crossing([[0, 0], [2, 0], [1, 0], [1, 1]]) is not None     # folds back
    h = convex_hull([[0, 0], [2, 0], [1, 0], [1, 1], [0.5, 0.2]])
    assert len(h) == 3
    assert convex_hull([[0, 0], [1, 0], [3, 0]]).tolist() == [[0, 0], [3, 0]]


def test_inside_by_the_crossing_number():
    V = np.array([[[0, 0], [4, 0], [4, 1], [1, 1], [1, 4], [0, 4]]], float)
    E = core(V[0], 0, True).edges
    assert inside(np.array([[0.5, 3.0]]), V, E)[0]
    assert not inside(np.array([[3.0, 3.0]]), V, E)[0]
