"""Reference §10 for every kind in the registry: Phi_q, gamma against finite differences at
random states (fixed seed). The deliberately broken variants at the end show the tests can fail."""

import numpy as np
import pytest

from planarkin.elements import KINDS
from planarkin.elements.base import make_frame, group

NB = 3          # moving bodies in the test system; index NB is ground
K = 12          # instances per kind, random bodies (ground included)


def random_instances(kind, rng):
    bodies = []
    while len(bodies) < K:
        b = rng.integers(0, NB + 1, size=kind.nbody)
        if len(set(b.tolist())) == kind.nbody and not (b == NB).all():
            bodies.append(b)
    params = {}
    for p in kind.params + kind.derived:
        if p.unit in ("range",) or (p.unit == "angle" and p.default is None):
            params[p.name] = np.full(K, np.nan)     # optional keys unused by g, grad, gamma
        elif p.unit == "flag":
            params[p.name] = rng.integers(0, 2, size=K).astype(float)
        elif p.name == "side":
            params[p.name] = rng.choice([-1.0, 1.0], size=K)
        elif p.unit == "curve":
            params[p.name] = random_curves(rng)
        elif p.unit in ("law", "angle-law"):
            params[p.name] = random_laws(p, rng)
        elif p.unit == "point":
            params[p.name] = rng.normal(size=(K, 2))
        elif p.unit == "vector":
            v = rng.normal(size=(K, 2))
            params[p.name] = v / np.linalg.norm(v, axis=1, keepdims=True)
        else:
            params[p.name] = rng.uniform(0.5, 2.0, size=K) * rng.choice([-1, 1], size=K)
    if "phase" in params:
        # moving-centre gears: ri + rj = 0 is no gear pair (the validator refuses it); keep the
        # random pairs away from it, as a real internal pair is (ring at least 1.5x the pinion)
        small = np.abs(params["ri"] + params["rj"]) < 0.5 * np.abs(params["rj"])
        params["ri"][small] = -2.5 * params["rj"][small]
    return group(kind, np.array(bodies), params)


def random_laws(p, rng):
    """K smooth motion laws of the cam kinds, random coefficients (internal units)."""
    from planarkin.elements.cam import Law
    laws = []
    for _ in range(3):          # three distinct laws shared by the K instances
        a, b, c = rng.uniform(0.2, 1.0, size=3)
        laws.append(Law(f"{a:.6f}*sin(theta) + {b:.6f}*cos(2*theta) + {c:.6f}*theta**2", {}))
    out = np.empty(K, dtype=object)
    for k in range(K):
        out[k] = laws[rng.integers(0, 3)]
    return out


def random_curves(rng):
    """K curves of the curve-slot kind: a closed wavy oval around the random states and an open
    arc long enough that every random pin projects inside it."""
    from planarkin.elements.curve import Curve
    a = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    r = 6.0 + 0.4 * np.sin(3 * a)
    oval = Curve(np.c_[r * np.cos(a), 0.8 * r * np.sin(a)], closed=True)
    x = np.linspace(-12, 12, 30)
    arc = Curve(np.c_[x, 0.05 * x * x - 1.0], closed=False)
    out = np.empty(K, dtype=object)
    for k in range(K):
        out[k] = (oval, arc)[rng.integers(0, 2)]
    return out


def ext(x):
    """Append ground coordinates (zeros) to (N, 3*NB) arrays."""
    return np.concatenate([x, np.zeros((x.shape[0], 3))], axis=1)


def state(rng, n=1):
    q = rng.normal(size=(n, 3 * NB)) * 0.8
    return ext(q), ext(rng.normal(size=(n, 3 * NB))), ext(rng.normal(size=(n, 3 * NB)))


def g_at(G, q):
    return G.g(make_frame(q))


def directional(G, q, qd):
    """Phi_q qd per instance row: (1, K, neq)."""
    J = G.grad(make_frame(q))
    return np.einsum("nkec,nkc->nke", J, qd[:, G.cols])


@pytest.mark.parametrize("name", sorted(KINDS))
def test_jacobian_against_central_differences(name):
    rng = np.random.default_rng(1)
    kind = KINDS[name]
    for _ in range(25):
        G = random_instances(kind, rng)
        q, _, _ = state(rng)
        J = G.grad(make_frame(q))
        eps = 1e-6
        for c in range(3 * NB):
            dq = np.zeros_like(q)
            dq[0, c] = eps
            fd = (g_at(G, q + dq) - g_at(G, q - dq)) / (2 * eps)
            # column c of the element's 6 (or 9) columns, where present
            an = np.zeros_like(fd)
            for loc in range(G.cols.shape[1]):
                hit = G.cols[:, loc] == c
                an[:, hit, :] += J[..., loc][:, hit, :]
            np.testing.assert_allclose(an, fd, rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("name", sorted(KINDS))
def test_g_grad_is_g_and_grad_bit_for_bit(name):
    """A Newton step takes the residual and the Jacobian from one g_grad per group
    (System.residual_jacobian); its numbers are g's and grad's, to the last bit."""
    rng = np.random.default_rng(5)
    kind = KINDS[name]
    for _ in range(10):
        G = random_instances(kind, rng)
        q, _, _ = state(rng, n=4)
        F = make_frame(q)
        g, grad = G.g_grad(F)
        for a, b in ((g, G.g(F)), (grad, G.grad(F))):
            assert a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("name", sorted(KINDS))
def test_gamma_three_ways(name):
    """(b1) gamma = -d/ds[Phi_q qd]; (b2) gamma = -d2Phi/ds2 along q + s qd;
    (b3) Phi_q qdd - gamma = d2Phi/ds2 along q + s qd + s^2/2 qdd."""
    rng = np.random.default_rng(2)
    kind = KINDS[name]
    for _ in range(25):
        G = random_instances(kind, rng)
        q, qd, qdd = state(rng)
        gam = G.gamma(make_frame(q, qd))
        e = 1e-5
        b1 = -(directional(G, q + e * qd, qd) - directional(G, q - e * qd, qd)) / (2 * e)
        np.testing.assert_allclose(gam, b1, rtol=1e-6, atol=1e-6)
        e2 = 1e-4
        d2 = (g_at(G, q + e2 * qd) - 2 * g_at(G, q) + g_at(G, q - e2 * qd)) / e2**2
        np.testing.assert_allclose(gam, -d2, rtol=2e-5, atol=2e-5)
        path = lambda s: q + s * qd + 0.5 * s * s * qdd
        d2p = (g_at(G, path(e2)) - 2 * g_at(G, path(0.0)) + g_at(G, path(-e2))) / e2**2
        lhs = directional(G, q, qdd) - gam
        np.testing.assert_allclose(lhs, d2p, rtol=2e-5, atol=2e-5)


def test_broken_gamma_is_detected():
    """A revolute gamma with its sign flipped must fail check (b2): the recipe can fail."""
    rng = np.random.default_rng(3)
    kind = KINDS["revolute"]
    G = random_instances(kind, rng)
    q, qd, _ = state(rng)
    gam = -G.gamma(make_frame(q, qd))
    e2 = 1e-4
    d2 = (g_at(G, q + e2 * qd) - 2 * g_at(G, q) + g_at(G, q - e2 * qd)) / e2**2
    assert np.max(np.abs(gam + d2)) > 0.1
