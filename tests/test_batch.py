"""Variants solved together (variant x time as one batch): the closed form, the per-variant
path's results, failures that fall back, and parallel runs bit for bit."""

import numpy as np
import pytest

from planarkin.studies import batch as batchmod
from planarkin.studies.execute import executor
from planarkin.studies.fused import Fused
from planarkin.studies.sweep import Range, factorial
from planarkin.studies.variants import Study
from planarkin.studies.warm import predictor_error
from test_sweep import four_bar_closed_form

FB = "mechanisms/four-bar.yaml"
STEPS = 180        # fine enough for the follower's step test on the grid (the batch applies)


@pytest.fixture(scope="module")
def study():
    s = Study(FB, analysis={"steps": STEPS},
              metrics=["max:rocker.phi", "stroke:rocker.phi", "max:P.x", "min:P.y", "dev:P"])
    s.chain, s.group = 4, 2
    return s


def test_batched_sweep_matches_the_closed_form_without_falling_back(study, monkeypatch):
    variants = factorial([Range("a", 0.03, 0.05, 4), Range("b", 0.11, 0.13, 3)])
    assert study.batch(variants) is not None
    fallbacks = []
    orig = study.solve
    monkeypatch.setattr(study, "solve", lambda v, *a, **k: fallbacks.append(v) or orig(v, *a, **k))
    out = study.run(variants)
    monkeypatch.undo()
    assert fallbacks == [] and [o.status for o in out] == ["ok"] * 12
    theta2 = np.radians(360 * np.linspace(0, 1, STEPS + 1))
    _, Px0, Py0 = four_bar_closed_form(0.04, 0.12, 0.10, 0.10, theta2)
    for v, o in zip(variants, out):
        rocker, Px, Py = four_bar_closed_form(v["a"], v["b"], 0.10, 0.10, theta2)
        dev = np.hypot(Px - Px0, Py - Py0).max()
        expect = [rocker.max(), rocker.max() - rocker.min(), Px.max(), Py.min(), dev]
        assert np.allclose(o.metrics, expect, rtol=1e-12, atol=1e-15), (v, o.metrics, expect)
        cold = study.solve(v)[0]            # the ordinary per-variant path
        assert np.allclose(o.metrics, cold.metrics, rtol=1e-12, atol=1e-15)


def test_variants_the_batch_cannot_take_fall_back_to_the_ordinary_path(study):
    variants = [{"a": 0.04, "b": 0.12}, {"a": 0.08, "b": 0.12}, {"a": 0.17, "b": 0.12},
                {"a": 0.041, "b": 0.12}]
    out = study.run(variants)
    assert [(o.status, o.kind) for o in out] == [("ok", ""), ("invalid", ""),
                                                 ("failed", "lock-up"), ("ok", "")]


def test_batched_units_in_processes_equal_the_serial_run_bit_for_bit(study):
    variants = factorial([Range("a", 0.035, 0.045, 4), Range("b", 0.115, 0.125, 4)])
    assert len(study.units(variants)) == 2
    serial = study.run(variants)
    assert repr(executor(2)(study, variants)) == repr(serial)


def test_what_the_batch_does_not_take(study):
    with pytest.raises(batchmod.Unsupported, match="coarser than the path follower"):
        batchmod.Batch(Study(FB, analysis={"steps": 12}), ["a"])


def test_a_parameter_reaching_the_analysis_settings_is_not_batched(tmp_path):
    text = open(FB).read().replace("d: 0.10 ", "d: 0.10\n  T: 1 ").replace(
        "analysis: {start: 0, end: 1, steps: 360}", "analysis: {start: 0, end: T, steps: 360}")
    path = tmp_path / "fb.yaml"
    path.write_text(text)
    with pytest.raises(batchmod.Unsupported, match="analysis settings"):
        batchmod.Batch(Study(str(path)), ["T"])
    assert Study(str(path)).batch([{"T": 1.0}]) is None


def test_a_chain_steps_to_every_variant_at_once_rows_and_heads_included(study, monkeypatch):
    # heads (from the nominal) and a factorial's next row (a step that repeats no earlier one)
    # are predicted to first order with the nominal's exact sensitivities: no step is retried
    # in substeps, so each unit takes one solve per chain position
    variants = factorial([Range("a", 0.03, 0.05, 4), Range("b", 0.11, 0.13, 3)])
    B = study.batch(variants)
    assert B.tangent is not None
    calls = []
    orig = B.solve
    monkeypatch.setattr(B, "solve", lambda vals, Q, *a, **k: calls.append(len(Q))
                        or orig(vals, Q, *a, **k))
    out = study.run(variants)
    assert [o.status for o in out] == ["ok"] * 12
    assert calls == [2, 2, 2, 2, 1, 1, 1, 1]       # 3 chains of 4, in units of 2 chains


def test_path_errors_of_many_variants_are_the_followers_per_variant():
    rng = np.random.default_rng(7)
    grid = np.sort(rng.uniform(0, 1, 9))
    Q, Qd, Qdd = (rng.normal(size=(3, 9, 12)) for _ in range(3))
    many = batchmod._path_errors(grid, Q, Qd, Qdd, 9)
    for v in range(3):
        assert np.array_equal(many[v], predictor_error(grid, Q[v], Qd[v], Qdd[v], 9))


@pytest.mark.parametrize("path", [FB, "mechanisms/slider-crank.yaml",
                                  "mechanisms/klann-leg.yaml"])     # klann: a 4 x 4 block
@pytest.mark.parametrize("spread", ["even", "few far"])
def test_the_fused_pass_equals_the_block_by_block_solve(path, spread):
    from planarkin.assembly import assemble
    from planarkin.linalg import noise
    from planarkin.results import analyse
    s = Study(path, analysis={"steps": 90})
    cm = s.nominal
    _, res = analyse(cm, s.opts)
    S = assemble(cm).system
    assert Fused.applies(S)
    unit = np.tile([cm.L, cm.L, 1.0 / cm.angle_factor], cm.nb)
    exact = np.concatenate([res.q / unit, np.zeros((len(res.t), 3))], axis=1)
    pred = exact.copy()
    dev = noise(pred[:, :cm.n].size, 3).reshape(len(pred), cm.n)
    if spread == "even":
        pred[:, :cm.n] += 1e-4 * dev
    else:   # most rows one correction from the solution, every 8th farther: those iterate alone
        far = np.arange(len(pred)) % 8 == 0
        pred[:, :cm.n] += np.where(far[:, None], 3e-3, 1e-9) * dev
    ref = [pred.copy(), np.zeros_like(pred), np.zeros_like(pred)]
    info = S.solve_batch(res.t, *ref, policy="full", tol=1e-10, maxit=8, order=2)
    got = [pred.copy(), np.zeros_like(pred), np.zeros_like(pred)]
    drivers = S.driver_values(res.t)
    fi = Fused(S).solve(cm.groups, *got, *drivers, tol=1e-10, maxit=8)
    assert info.converged.all() and fi.converged.all()
    for a, b in zip(got, ref):
        scale = np.abs(b).max(axis=0) + 1e-300
        assert (np.abs(a - b) <= 1e-12 * scale).all()
    assert np.allclose(got[0], exact, rtol=0, atol=1e-12)
    assert np.array_equal(fi.sign, info.sign)
    assert np.allclose(fi.smin, info.smin, rtol=1e-10, atol=0)


# -- the compiled route (planarkin.kernel, compiled_each.solve_each) against the numpy reference -

def _kernel():
    """planarkin.kernel with its Library ready for studies (numba is a dependency: no skip)."""
    from planarkin import kernel
    lib = kernel.library()
    assert lib is not None, "numba is a dependency of planarkin"
    lib.need("study")
    lib.need("grid")
    return kernel, lib


def test_the_kernel_route_equals_the_numpy_route_failures_included(monkeypatch):
    # the same sweep both ways in one process (PLANARKIN_KERNEL is read per call): every
    # status and failure kind exactly, metrics to 1e-12; a = 0.08 cannot be assembled, 0.17
    # locks up (its time: the per-variant follower's, whose own passes follow the same switch
    # and place the event to ~1e-11)
    kernel, _ = _kernel()
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 1)     # a small study takes it too
    from planarkin.studies.fused import Fused
    s = Study(FB, analysis={"steps": STEPS},
              metrics=["max:rocker.phi", "stroke:rocker.phi", "max:P.x", "min:P.y", "dev:P",
                       "absmax:rocker.alpha", "max:P.vy", "min:coupler.omega"])
    s.chain, s.group = 4, 2
    variants = (factorial([Range("a", 0.03, 0.05, 4), Range("b", 0.11, 0.13, 3)])
                + [{"a": 0.08, "b": 0.12}, {"a": 0.17, "b": 0.12}, {"a": 0.041, "b": 0.12},
                   {"a": 0.06, "b": 0.12}, {"a": 0.065, "b": 0.125}])
    calls = {"kernel": 0, "fused": 0}
    rows, fsolve = kernel.solve_rows, Fused.solve

    def count(name, f):
        def g(*a, **k):
            calls[name] += 1
            return f(*a, **k)
        return g
    monkeypatch.setattr(kernel, "solve_rows", count("kernel", rows))
    monkeypatch.setattr(Fused, "solve", count("fused", fsolve))
    fast = s.run(variants)
    assert calls == {"kernel": calls["kernel"], "fused": 0} and calls["kernel"] > 0
    monkeypatch.setenv("PLANARKIN_KERNEL", "0")
    ref = s.run(variants)
    assert calls["fused"] > 0
    assert [(o.status, o.kind) for o in fast] == [(o.status, o.kind) for o in ref]
    assert [(o.status, o.kind) for o in fast][12:14] == [("invalid", ""), ("failed", "lock-up")]
    for f, r in zip(fast, ref):
        if f.status == "ok":
            assert np.allclose(f.metrics, r.metrics, rtol=1e-12, atol=1e-15), (f, r)
        else:
            assert np.isnan(f.metrics).all() and np.isnan(r.metrics).all()
        assert (np.isnan(f.t) and np.isnan(r.t)) or abs(f.t - r.t) <= 1e-9


@pytest.fixture(scope="module")
def solved(study):
    """Three variants solved by the kernel from the nominal's solution, with the predecessor
    signs of the nominal (variant 1's flipped at one grid time), and what accept needs."""
    kernel, _ = _kernel()
    from planarkin.studies.batch import COND_WARN, KAPPA
    B = study.batch([{"a": 0.04, "b": 0.12}])
    Q0, _, _, sg0 = B.nominal
    vals = [{"a": 0.0401, "b": 0.12}, {"a": 0.04, "b": 0.1202}, {"a": 0.0399, "b": 0.1199}]
    groups, targets, s, env, ok = B.numbers(vals)
    V = len(vals)
    Q = np.repeat(Q0[None], V, axis=0)
    sign = np.repeat(sg0[None], V, axis=0)
    sign[1, 7, 0] *= -1
    B.job_points = kernel.COMPILED_FROM_POINTS         # a study large enough for the route
    k = B.kernel()
    assert k is not None
    return B, groups, targets, env, Q, sign, s, (kernel, k, KAPPA, COND_WARN)


def test_the_kernels_acceptance_equals_the_numpy_tests(solved):
    B, groups, targets, env, Q, sign, s, (kernel, k, _, _) = solved
    V, T = Q.shape[:2]
    Qr, Qdr, Qddr, info, good, perr = B.solve_kernel(k, groups, targets, env, Q, sign)
    tol = B.study.opts.path_tol
    ok_kernel = good.reshape(V, T).all(axis=1) & (perr.reshape(V, T) <= tol).all(axis=1)
    ok_numpy = B.accept(Qr, Qdr, Qddr, info, sign, np.ones(V, dtype=bool), s)[4]
    assert ok_kernel.tolist() == ok_numpy.tolist() == [True, False, True]
    assert good.reshape(V, T)[1].tolist() == [t != 7 for t in range(T)]
    # the path errors: warm.predictor_error's (h * h * h here, numpy's h ** 3 there)
    ref = batchmod._path_errors(B.grid, *(a.reshape(V, T, -1) for a in (Qr, Qdr, Qddr)), B.cm.n)
    got = perr.reshape(V, T)
    assert (got[:, 0] == 0).all() and np.allclose(got[:, 1:], ref, rtol=1e-9, atol=1e-18)
    # a point that cannot converge (nan): refused, and the path test of its intervals too
    Qbad = Q.copy()
    Qbad[2, 50, :] = np.nan
    _, Qdb, Qddb, infob, goodb, perrb = B.solve_kernel(k, groups, targets, env, Qbad, sign)
    assert not goodb.reshape(V, T)[2, 50] and goodb.reshape(V, T)[0].all()
    assert np.isnan(perrb.reshape(V, T)[2, 51])


def test_per_point_parameters_equal_a_solve_per_parameter_set(solved):
    # solve_each with a (V, E, 8) table and a variant index per point against solve_points
    # with each variant's parameters as the system's own
    B, groups, targets, env, Q, sign, s, (kernel, k, _, _) = solved
    lib, P = k[:2]
    V, T, W = Q.shape
    table = kernel.table(B.cm, groups)
    rows = np.repeat(np.arange(V, dtype=np.int32), T)
    drv = [a.reshape(V * T, -1) for a in B.drivers(targets, env)]
    o = B.study.opts
    ref = []
    for v in range(V):
        Pv = kernel.Packed(*P.arrays[:3], table[v], *P.arrays[4:], *P.tail, P.nfine, *P.fine,
                           P.fixed)
        X = [Q[v].copy(), np.zeros((T, W)), np.zeros((T, W))]
        info = kernel.solve(lib, B.S, Pv, *X, *(a[v * T:(v + 1) * T] for a in drv), "full",
                            o.tol, 8, 2)
        ref.append((X, info))
    out = kernel.solve_rows(lib, B.S, P, Q.reshape(V * T, W).copy(), *drv, o.tol, 8,
                            rows=rows, table=table)
    for v in range(V):
        sl = slice(v * T, (v + 1) * T)
        for a, b in zip(out[:3], ref[v][0]):
            scale = np.abs(b).max(axis=0) + 1e-300
            assert (np.abs(a[sl] - b) <= 1e-12 * scale).all()
        inf = out[3:]
        assert inf[1][sl].all() and np.array_equal(inf[3][sl], ref[v][1][3])
        assert np.allclose(inf[4][sl], ref[v][1][4], rtol=1e-10, atol=0)
    with pytest.raises(ValueError, match="out of the table"):
        kernel.solve_rows(lib, B.S, P, Q.reshape(V * T, W).copy(), *drv, o.tol, 8,
                          rows=rows + 1, table=table)


def test_a_units_numbers_taken_by_row_equal_the_numbers_of_those_variants(tmp_path):
    # run_group evaluates the file's expressions once for all variants of a unit and takes
    # each step's rows: the same bits as evaluating them for the step's variants alone
    text = open(FB).read().replace("d: 0.10 ", "d: 0.10\n  e: sin(a / b) * c + b**2 ").replace(
        "sj: [c, 0]}    # C", "sj: [c + e - sin(a / b) * c - b**2, 0]}    # C")
    path = tmp_path / "fb.yaml"
    path.write_text(text)
    B = Study(str(path), analysis={"steps": STEPS}).batch([{"a": 0.04, "b": 0.12}])
    assert B is not None and "e" in B.dep
    vals = [{"a": 0.03 + 0.001 * i, "b": 0.11 + 0.0007 * i} for i in range(23)]
    pre = B.numbers(vals)
    idx = np.array([3, 17, 4, 22, 0])
    got, want = B.take(pre, idx), B.numbers([vals[i] for i in idx])
    for g, w in zip(got[0], want[0]):
        assert g.keys() == w.keys() and all(np.array_equal(g[k], w[k]) for k in g)
    for a, b in zip(got[1:3] + (got[4],), want[1:3] + (want[4],)):
        assert np.array_equal(a, b)
    assert all(np.array_equal(got[3][k], want[3][k]) for k in want[3])


def test_the_first_order_prediction_is_numpys_sum_in_its_bits(study):
    # the heads, a factorial's rows and every sampled variant start from it: the same bits as
    # (tangent * dp).sum(axis=-1) for any number of varied parameters (numpy adds left to
    # right below 8 numbers, pairwise from 8)
    B = study.batch([{"a": 0.04, "b": 0.12}])
    rng = np.random.default_rng(11)
    T, W = B.tangent.shape[:2]
    saved = B.tangent
    try:
        for k in range(1, 13):
            B.tangent = rng.standard_normal((T, W, k))
            B.__dict__.pop("_tcols", None)
            dp = rng.standard_normal((5, k)) * 1e-3
            want = (B.tangent[None] * dp[:, None, None, :]).sum(axis=-1)
            assert np.array_equal(B.first_order(dp), want), k
    finally:
        B.tangent = saved
        B.__dict__.pop("_tcols", None)
