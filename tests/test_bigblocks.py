"""Big coupled mechanisms (benchmarks/bigmodels.py) at a small size, and the large-block machinery:
sparse LU per time point, grid chunks sized from the block, one BLAS thread, no dense Jacobian
for large models.

Every run is checked against loop-closure invariants written here from the mechanisms' joint
lists, independently of planarkin's elements: each pin's two points coincide, and so do their
velocities and accelerations (the exact time derivatives r + A s, rdot + w B s,
rddot + alpha B s - w^2 A s); the drivers' angles follow their functions.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import bigmodels  # noqa: E402
import planarkin  # noqa: E402
from planarkin.solver import assembly, linalg, singular, grid as solver, system  # noqa: E402


# -- the mechanisms' pins, from their definitions in bigmodels --------------------------------

def arch_pins(N):
    R = bigmodels.arch_radius(N)
    pins = [(None, (0.0, 0.0), 0, (0.0, 0.0))]
    pins += [(k, (1.0, 0.0), k + 1, (0.0, 0.0)) for k in range(N - 1)]
    pins += [(None, (2 * R, 0.0), N - 1, (1.0, 0.0))]
    return pins


def ladder_pins(N, h=0.5):
    R = bigmodels.arch_radius(N)
    lo = 2 * (R + h) * math.sin(math.pi / N / 2)
    L = lambda k: k                       # noqa: E731  body indices: l0..l(N-1), r1..r(N-1), o1..
    Rg = lambda k: N + k - 1              # noqa: E731
    O = lambda k: 2 * N - 1 + k - 1       # noqa: E731
    pins = arch_pins(N)
    pins += [(L(k), (0.0, 0.0), Rg(k), (0.0, 0.0)) for k in range(1, N)]
    for k in range(1, N - 1):
        pins += [(Rg(k), (h, 0.0), O(k), (0.0, 0.0)), (Rg(k + 1), (h, 0.0), O(k), (lo, 0.0))]
    return pins


def scissor_pins(S):
    pins = [(None, (0.0, 0.0), 0, (0.0, 0.0))]
    for k in range(S):
        pins.append((2 * k, (1.0, 0.0), 2 * k + 1, (1.0, 0.0)))
        if k:
            pins.append((2 * k - 1, (2.0, 0.0), 2 * k, (0.0, 0.0)))
            pins.append((2 * k - 2, (2.0, 0.0), 2 * k + 1, (0.0, 0.0)))
    return pins


def _point(q, qd, qdd, b, s):
    """Position, velocity, acceleration (N, 2) of point s of body b (None: ground)."""
    if b is None:
        z = np.zeros((q.shape[0], 2))
        return z + np.asarray(s), z, z
    x, y, p = q[:, 3 * b], q[:, 3 * b + 1], q[:, 3 * b + 2]
    w, a = qd[:, 3 * b + 2], qdd[:, 3 * b + 2]
    c, sn = np.cos(p), np.sin(p)
    As = np.stack([c * s[0] - sn * s[1], sn * s[0] + c * s[1]], axis=1)
    Bs = np.stack([-As[:, 1], As[:, 0]], axis=1)
    r = np.stack([x, y], axis=1) + As
    v = np.stack([qd[:, 3 * b], qd[:, 3 * b + 1]], axis=1) + w[:, None] * Bs
    acc = (np.stack([qdd[:, 3 * b], qdd[:, 3 * b + 1]], axis=1) + a[:, None] * Bs
           - (w * w)[:, None] * As)
    return r, v, acc


def closure_errors(res, pins):
    """Largest pin mismatch of positions, velocities and accelerations over the run."""
    q, qd, qdd = res.q, res.qd, res.qdd
    out = np.zeros(3)
    for bi, si, bj, sj in pins:
        for k, (u, v) in enumerate(zip(_point(q, qd, qdd, bi, si), _point(q, qd, qdd, bj, sj))):
            out[k] = max(out[k], np.abs(u - v).max())
    return out


MODELS = {
    "arch": (lambda: bigmodels.arch_yaml(16, 24), lambda: arch_pins(16)),
    "ladder": (lambda: bigmodels.ladder_yaml(6, 24), lambda: ladder_pins(6)),
    "scissor": (lambda: bigmodels.scissor_yaml(8, 24), lambda: scissor_pins(8)),
}


def _solve(name, **kw):
    text, _ = MODELS[name]
    return planarkin.solve(planarkin.load(f"{name}.yaml", text=text()), **kw)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_big_models_close_their_loops(name, monkeypatch):
    # the small sizes' blocks (46 and 43 unknowns) take the sparse route, as the large ones do
    monkeypatch.setattr(system, "SPARSE_BLOCK", 32)
    res = _solve(name)
    assert res.status == 0, res.message
    assert len(res.t) == 25
    ep, ev, ea = closure_errors(res, MODELS[name][1]())
    scale_v = np.abs(res.qd).max()
    scale_a = np.abs(res.qdd).max()
    assert ep < 1e-11 and ev < 1e-11 * max(scale_v, 1) and ea < 1e-10 * max(scale_a, 1), \
        (ep, ev, ea)
    assert scale_v > 1e-3                     # it moves


def test_arch_drivers_follow_their_functions():
    N = 16
    res = _solve("arch")
    th, a = math.pi / N, 2.0 / N ** 2
    t = res.t
    for k in range(N - 2):
        rel = res.q[:, 3 * (k + 1) + 2] - res.q[:, 3 * k + 2]
        want = -th + a * (1 + k / N) * np.sin(2 * np.pi * t)
        assert np.abs(rel - want).max() < 1e-12


def test_arch_and_ladder_are_one_block():
    for name, size in (("arch", 3 * 16 - 2), ("ladder", 9 * 5 - 2)):
        cm = planarkin.load("m.yaml", text=MODELS[name][0]())
        A = assembly.assemble(cm)
        assert max(len(c) for c in A.system.fine.cols) == size


@pytest.mark.parametrize("name", ["arch", "ladder"])
def test_sparse_and_dense_blocks_agree(name, monkeypatch):
    """The pure dense route (batched inverses) is the reference for the sparse LU route."""
    monkeypatch.setattr(system, "SPARSE_BLOCK", 10 ** 9)
    dense = _solve(name)
    monkeypatch.setattr(system, "SPARSE_BLOCK", 32)
    sparse = _solve(name)
    assert dense.status == sparse.status == 0
    for k in ("q", "qd", "qdd"):
        ref = getattr(dense, k)
        assert np.abs(getattr(sparse, k) - ref).max() <= 1e-12 * max(np.abs(ref).max(), 1)
    assert (dense.iterations == sparse.iterations).all()
    # both condition estimates are of the same order (1/||J^-1||_F bound against 1/||J^-1||_1)
    ratio = sparse.cond / dense.cond
    assert 0.2 < ratio.min() and ratio.max() < 5


def _random_sparse(rng, k, density=0.08):
    A = np.where(rng.random((k, k)) < density, rng.normal(size=(k, k)), 0.0)
    A[np.arange(k), rng.permutation(k)] += 2.0 + rng.random(k)
    return A


@pytest.mark.parametrize("seed", range(4))
def test_sparse_lu_sign_solve_and_sigma_min(seed):
    rng = np.random.default_rng(seed)
    k = 40
    mats = [_random_sparse(rng, k) for _ in range(6)]
    order = rng.permutation(k)                   # a column order chosen for the pattern
    # one shared pattern: the union, explicit zeros where a matrix has none
    mask = np.zeros((k, k), bool)
    for A in mats:
        mask |= A != 0
    vals = []
    for A in mats:
        B = np.where(mask, A, 0.0)[:, order]
        cols, rows = np.nonzero(mask[:, order].T)
        vals.append(B[rows, cols])
    indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=k))]).astype(np.int32)
    lu = linalg.SparseLU(np.array(vals), rows.astype(np.int32), indptr, order,
                         linalg.permutation_sign(order))
    det_sign = np.sign([np.linalg.det(A) for A in mats])
    assert (lu.sign == det_sign).all() and lu.ok.all()
    rhs = rng.normal(size=(6, k))
    x = lu.solve(rhs)
    for A, xi, b in zip(mats, x, rhs):
        assert np.abs(A @ xi - b).max() < 1e-10
    true = np.array([np.linalg.svd(A, compute_uv=False)[-1] for A in mats])
    # 1/||A^-1||_1 lies within sqrt(k) of sigma_min = 1/||A^-1||_2 (Hager's estimate of the
    # 1-norm can only be low, which moves it up)
    assert ((lu.smin / true > 1 / math.sqrt(k)) & (lu.smin / true < math.sqrt(k))).all()


def test_sparse_lu_singular_and_nonfinite_points():
    k = 6
    A = np.eye(k)
    S = A.copy()
    S[3, 3] = 0.0                                # exactly singular
    cols, rows = np.nonzero(np.ones((k, k)).T)
    indptr = np.arange(0, k * k + 1, k, dtype=np.int32)
    vals = np.array([M[rows, cols] for M in (A, S, np.full((k, k), np.nan))])
    lu = linalg.SparseLU(vals, rows.astype(np.int32), indptr, np.arange(k))
    assert lu.ok.tolist() == [True, False, False]
    assert lu.sign.tolist() == [1.0, 0.0, 0.0] and lu.smin[1:].tolist() == [0.0, 0.0]
    x = lu.solve(np.ones((3, k)))
    assert np.allclose(x[0], 1.0) and np.isnan(x[1:]).all()


@pytest.mark.parametrize("k", [3, 9, 40])
def test_dense_inverse_without_sign_matches_and_flags_singular(k):
    """inv_batched(want_sign=False), the velocity systems' route: the same inverses as with the
    sign, an exactly singular or non-finite matrix flagged (nan) without spoiling the others."""
    rng = np.random.default_rng(k)
    J = rng.normal(size=(60, k, k)) + 3 * np.eye(k)
    J[7, :, 1] = J[7, :, 0]                     # two equal columns: exactly singular
    J[11, 2, 2] = np.nan
    with np.errstate(all="ignore"):
        ref, sign, ok = linalg.inv_batched(J)
        out, _, ok2 = linalg.inv_batched(J, want_sign=False)
    good = np.ones(60, bool)
    good[[7, 11]] = False
    assert ok2[good].all() and not ok2[11]
    assert np.abs(out[good] - ref[good]).max() < 1e-9 * np.abs(ref[good]).max()
    assert (ok2 == ok).all() and np.isnan(out[~ok2]).all()
    eye = np.einsum("nij,njk->nik", J[good], out[good])
    assert np.abs(eye - np.eye(k)).max() < 1e-9
    assert (sign[good] == np.sign(np.linalg.det(J[good]))).all()


@pytest.mark.parametrize("p", [[0, 1, 2, 3], [1, 0, 2, 3], [1, 2, 0, 3], [3, 2, 1, 0],
                               [1, 2, 3, 0]])
def test_permutation_sign(p):
    P = np.eye(4)[:, p]
    assert linalg.permutation_sign(np.array(p)) == np.sign(np.linalg.det(P))


def test_grid_chunks_are_bounded_by_the_working_set(monkeypatch):
    """The grid chunk is sized from the block (memory independent of the step count)."""
    cm = planarkin.load("arch.yaml", text=bigmodels.arch_yaml(16, 200))
    A = assembly.assemble(cm)
    per_point = A.system.point_bytes()
    monkeypatch.setattr(solver, "CHUNK_BYTES", 40 * per_point)
    an = solver.Analysis(cm, A, solver.Options.from_model(cm))
    an.follow()
    sizes = [len(ch.t) for ch in an.chunks()]
    assert sum(sizes) == 201 and max(sizes) <= 40


def test_many_small_blocks_get_larger_chunks_within_their_bound(monkeypatch):
    """A model of many solve blocks gets chunks of CHUNK_MIN_POINTS points (each block's
    per-call overhead is paid per chunk) as long as they stay under CHUNK_BYTES_MANY; the
    results are those of the small chunks."""
    cm = planarkin.load("scissor.yaml", text=bigmodels.scissor_yaml(8, 200))
    A = assembly.assemble(cm)
    nblocks = len(A.system.blocks)
    from planarkin.solver.budget import point_row_bytes
    per_point = A.system.point_bytes() + point_row_bytes(cm)    # as Analysis sizes its chunks
    monkeypatch.setattr(solver, "CHUNK_BYTES", 20 * per_point)
    runs = {}
    for many, bound in ((10 ** 9, 10 ** 12), (nblocks, 60 * per_point), (nblocks, 10 ** 12)):
        monkeypatch.setattr(solver, "CHUNK_MANY_BLOCKS", many)
        monkeypatch.setattr(solver, "CHUNK_MIN_POINTS", 100)
        monkeypatch.setattr(solver, "CHUNK_BYTES_MANY", bound)
        an = solver.Analysis(cm, A, solver.Options.from_model(cm))
        an.follow()
        chunks = list(an.chunks())
        runs[(many, bound)] = chunks
        assert sum(len(ch.t) for ch in chunks) == 201
    assert [len(ch.t) for ch in runs[(10 ** 9, 10 ** 12)]][:2] == [20, 20]
    assert [len(ch.t) for ch in runs[(nblocks, 60 * per_point)]][:2] == [60, 60]
    assert [len(ch.t) for ch in runs[(nblocks, 10 ** 12)]][:2] == [100, 100]
    ref = np.concatenate([ch.q for ch in runs[(10 ** 9, 10 ** 12)]])
    for chunks in runs.values():
        assert np.abs(np.concatenate([ch.q for ch in chunks]) - ref).max() < 1e-12


def test_one_blas_thread_pins_and_restores():
    from threadpoolctl import threadpool_info, threadpool_limits
    with threadpool_limits(limits=2, user_api="blas"):
        before = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
        if not before or before == [1] * len(before):
            pytest.skip("no BLAS in this process that runs more than one thread")
        with linalg.one_blas_thread():
            inside = [lib["num_threads"] for lib in threadpool_info()
                      if lib["user_api"] == "blas"]
            assert inside == [1] * len(before)
        after = [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]
        assert after == before


def test_large_model_never_builds_a_dense_jacobian(monkeypatch):
    """Above DENSE_LIMIT neither assembly nor the analysis calls the dense Jacobian."""
    monkeypatch.setattr(assembly, "DENSE_LIMIT", 30)
    monkeypatch.setattr(singular, "DENSE_LIMIT", 30)      # (the singular-point analysis)
    monkeypatch.setattr(system, "SPARSE_BLOCK", 32)

    def refuse(self, Q):
        raise AssertionError("dense Jacobian built for a large model")
    monkeypatch.setattr(system.System, "jacobian", refuse)
    res = _solve("arch")
    assert res.status == 0, res.message
    assert closure_errors(res, arch_pins(16))[0] < 1e-11


COINCIDENT = """\
name: coincident
bodies:
  a: {q: [0, 0, 0]}
  b: {q: [0, 0, 0]}
joints:
  - {type: revolute, i: ground, j: a, si: [0, 0], sj: [0, 0]}
  - {type: distance, i: a, j: b, si: [0, 0], sj: [0, 0], c: 1}
  - {type: revolute, i: ground, j: b, si: [1, 0], sj: [1, 0]}
drivers:
  - {type: angle, body: a, f: "t"}
"""


@pytest.mark.parametrize("limit", [3000, 2])
def test_coincident_distance_points_at_the_estimates_are_named(limit, monkeypatch):
    monkeypatch.setattr(assembly, "DENSE_LIMIT", limit)
    cm = planarkin.load("coincident.yaml", text=COINCIDENT)
    with pytest.raises(planarkin.InputError) as e:
        assembly.assemble(cm)
    assert "coincide at the body estimates q" in str(e.value)
    assert "coincident.yaml:7:" in str(e.value)



@pytest.mark.parametrize("name", sorted(MODELS))
def test_block_assembly_gives_what_the_dense_checks_give(name, monkeypatch):
    """From SPARSE_ASSEMBLY coordinates a square model is assembled block by block: the same
    pose (to rounding), degrees of freedom, rows, assembly modes and warnings as the dense
    checks, and no dense Jacobian is built."""
    text = MODELS[name][0]()
    dense = assembly.assemble(planarkin.load(f"{name}.yaml", text=text))
    monkeypatch.setattr(assembly, "SPARSE_ASSEMBLY", 10)

    def refuse(self, Q):
        raise AssertionError("dense Jacobian built")
    monkeypatch.setattr(system.System, "jacobian", refuse)
    blocks = assembly.assemble(planarkin.load(f"{name}.yaml", text=text))
    assert np.abs(blocks.q - dense.q).max() < 1e-12 and blocks.residual < 1e-12
    assert (blocks.dof, blocks.redundant_rows) == (dense.dof, dense.redundant_rows)
    assert (blocks.active_rows == dense.active_rows).all()
    assert [(m.bodies, m.sign) for m in blocks.modes] == [(m.bodies, m.sign) for m in dense.modes]
    assert [d.message for d in blocks.warnings] == [d.message for d in dense.warnings]


def test_block_assembly_leaves_unclear_models_to_the_dense_checks(monkeypatch):
    """A clear square model skips Levenberg-Marquardt; one whose blocks do not settle it (a
    driver repeated in place of the last one: square, but the arch's block singular) is
    refused by the dense checks with their named problem, as below SPARSE_ASSEMBLY."""
    monkeypatch.setattr(assembly, "SPARSE_ASSEMBLY", 2)
    calls = []
    real = assembly._levenberg_marquardt

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)
    monkeypatch.setattr(assembly, "_levenberg_marquardt", spy)
    text = MODELS["arch"][0]()
    A = assembly.assemble(planarkin.load("arch.yaml", text=text))
    assert not calls and A.residual < 1e-12
    lines = text.splitlines()
    last = max(i for i, ln in enumerate(lines) if "type: angle" in ln)
    lines[last] = lines[last - 1]
    with pytest.raises(planarkin.InputError) as e:
        assembly.assemble(planarkin.load("arch.yaml", text="\n".join(lines) + "\n"))
    assert calls and "driver" in str(e.value)


CRANKS = ["0.2*sin(2*pi*t)", "abs(t - 0.5)", "abs(t - 0.25)**2", "min(t, 0.4)",
          "clip(2*t - 0.5, 0, 1)", "where(t < 0.3, t, 0.6 - t)", "0.1 + 0.2*sin(2*pi*t)",
          "max(0.5*t, t - 0.5)"]


def _cranks_yaml():
    out = ["name: cranks", "units: {length: m, angle: rad}", "bodies:"]
    out += [f"  c{k}: {{q: [0, 0, 0]}}" for k in range(len(CRANKS))]
    out += ["joints:"] + [f"  - {{type: revolute, i: ground, j: c{k}, si: [{k}, 0], sj: [0, 0]}}"
                          for k in range(len(CRANKS))]
    out += ["drivers:"] + [f"  - {{type: angle, body: c{k}, f: \"{f}\"}}"
                           for k, f in enumerate(CRANKS)]
    return "\n".join(out + ["analysis: {start: 0, end: 1, steps: 20}"]) + "\n"


@pytest.mark.parametrize("name", ["cranks", "servo-press", "table-input"])
def test_joint_driver_evaluation_is_the_drivers_own(name, monkeypatch):
    """Many drivers are evaluated in one expression pass (system.JOINT_DRIVERS): bit for bit the
    values of each driver's own derivatives, at its breakpoints too (kinks of abs, min, clip,
    where; a motion law's knots; a table's), from either side and averaged."""
    cm = (planarkin.load("cranks.yaml", text=_cranks_yaml()) if name == "cranks" else
          planarkin.load(str(ROOT / "mechanisms" / f"{name}.yaml")))
    S = system.System(cm)
    a, b = cm.spec.analysis.start, cm.spec.analysis.end
    t = [np.linspace(a, b, 97)]
    for f in cm.driver_funcs:
        t.append(np.array([bp.t for bp in f.breakpoints(a, b)], dtype=float))
    t = np.concatenate(t)
    if name == "cranks":
        assert len(t) > 97 + 5                   # the kinks are among the times
    for side in (0, -1, 1):
        monkeypatch.setattr(system, "JOINT_DRIVERS", 10 ** 9)
        own = S.driver_values(t, side)
        monkeypatch.setattr(system, "JOINT_DRIVERS", 1)
        joint = S.driver_values(t, side)
        for x, y in zip(own, joint):
            assert np.array_equal(x, y, equal_nan=True)


def _four_bar_loops_brute(cm):
    """The definition, by brute force: every pair of grounded bodies p < r and every body c
    pinned to both (the enumeration planarkin.measures.grashof replaced)."""
    pins = {}
    for g in cm.groups:
        if g.kind.name == "revolute":
            for a, b in g.bodies[:, :2].tolist():
                pins[(a, b)] = pins[(b, a)] = True
    G = cm.nb
    grounded = sorted({b for (a, b) in pins if a == G})
    return [(p, c, r) for ip, p in enumerate(grounded) for r in grounded[ip + 1:]
            for c in range(cm.nb) if c not in (p, r) and (p, c) in pins and (c, r) in pins]


@pytest.mark.parametrize("name", ["four-bar", "six-bar", "jansen-leg", "klann-leg",
                                  "peaucellier", "chain"])
def test_four_bar_loops_found_from_the_pin_graph(name):
    """`planarkin check` lists the same four-bar loops, in the same order, as the brute-force
    enumeration (which never finished for the 18,003-coordinate chain)."""
    from planarkin.measures.grashof import four_bar_loops
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import models
    cm = (planarkin.load("chain.yaml", text=models.chain_yaml(7)) if name == "chain" else
          planarkin.load(str(ROOT / "mechanisms" / f"{name}.yaml")))
    index = {n: k for k, n in enumerate(cm.body_names)}
    got = [tuple(index[b] for b in loop.links[1:]) for loop in four_bar_loops(cm)]
    assert got == _four_bar_loops_brute(cm)
    if name == "chain":
        assert len(got) == 7
