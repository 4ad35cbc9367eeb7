"""Variants solved together (variant x time as one batch): the closed form, the per-variant
path's results, failures that fall back, and parallel runs bit for bit."""

import numpy as np
import pytest

from planarkin.studies import batch as batchmod
from planarkin.studies.execute import executor
from planarkin.studies.sweep import Range, factorial
from planarkin.studies.variants import Study
from routes import skip_without_numba
from test_sweep import closed_form_extreme, four_bar_closed_form

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
        # max, min, stroke: the closed form's extremes (the metrics are refined between the
        # grid rows: O(h^6), ~1e-11 at 180 steps); dev: at the grid times
        _, Px, Py = four_bar_closed_form(v["a"], v["b"], 0.10, 0.10, theta2)
        dev = np.hypot(Px - Px0, Py - Py0).max()
        f = [lambda th, k=k: four_bar_closed_form(v["a"], v["b"], 0.10, 0.10, th)[k]
             for k in range(3)]
        hi, lo = closed_form_extreme(f[0], 1), closed_form_extreme(f[0], -1)
        expect = [hi, hi - lo, closed_form_extreme(f[1], 1), closed_form_extreme(f[2], -1), dev]
        assert np.allclose(o.metrics, expect, rtol=1e-10, atol=1e-15), (v, o.metrics, expect)
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
    # acceptance.path_errors over many variants at once: per variant the follower's own step
    # error (acceptance.taylor_error of each interval, the jerk from the interval before)
    from planarkin.solver.acceptance import path_errors, taylor_error
    rng = np.random.default_rng(7)
    grid = np.sort(rng.uniform(0, 1, 9))
    Q, Qd, Qdd = (rng.normal(size=(3, 9, 12)) for _ in range(3))
    many = path_errors(grid, Q, Qd, Qdd, 9)
    assert many.shape == (3, 8)
    for v in range(3):
        assert np.array_equal(many[v], path_errors(grid, Q[v], Qd[v], Qdd[v], 9))
        for k in range(8):
            h = grid[k + 1] - grid[k]
            j3 = 0 * Qdd[v, k] if k == 0 else (Qdd[v, k] - Qdd[v, k - 1]) / (grid[k] - grid[k - 1])
            one = taylor_error(np.array([[h]]), Q[v, k, :9], Qd[v, k, :9], Qdd[v, k, :9], j3[:9],
                               Q[v, k + 1, None, :9], Qd[v, k + 1, None, :9],
                               Qdd[v, k + 1, None, :9])
            assert many[v, k] == one[0]
            # the definition: Taylor forwards from k, and backwards from k + 1 with its jerk
            fwd = Q[v, k] + h * Qd[v, k] + h * h / 2 * Qdd[v, k] + h ** 3 / 6 * j3
            jb = (Qdd[v, k + 1] - Qdd[v, k]) / h
            back = Q[v, k + 1] - h * Qd[v, k + 1] + h * h / 2 * Qdd[v, k + 1] - h ** 3 / 6 * jb
            want = max(np.abs(Q[v, k + 1] - fwd)[:9].max(), np.abs(back - Q[v, k])[:9].max())
            assert abs(many[v, k] - want) <= 1e-13 * want


# -- the compiled route (planarkin.solver.compiled.kernel, compiled_gen_each) against the numpy reference ------

def _kernel():
    """planarkin.solver.compiled.kernel with its Library ready for studies (skipped only where numba is not
    installed: routes.NO_NUMBA, which .ci/run does not allow in its run with numba)."""
    from planarkin.solver.compiled import kernel
    skip_without_numba()
    lib = kernel.library()
    assert lib is not None, "numba is installed but cannot be imported"
    lib.need("study")
    return kernel, lib


def test_the_kernel_route_equals_the_numpy_route_failures_included(monkeypatch):
    # the same sweep both ways in one process (PLANARKIN_KERNEL is read per call): every
    # status and failure kind exactly, metrics to 2e-15 (below); a = 0.08 cannot be assembled, 0.17
    # locks up (its time: the per-variant follower's, whose own passes follow the same switch
    # and place the event to ~1e-11)
    kernel, _ = _kernel()
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 1)     # a small study takes it too
    from planarkin.solver.system import System
    s = Study(FB, analysis={"steps": STEPS},
              metrics=["max:rocker.phi", "stroke:rocker.phi", "max:P.x", "min:P.y", "dev:P",
                       "absmax:rocker.alpha", "max:P.vy", "min:coupler.omega"])
    s.chain, s.group = 4, 2
    variants = (factorial([Range("a", 0.03, 0.05, 4), Range("b", 0.11, 0.13, 3)])
                + [{"a": 0.08, "b": 0.12}, {"a": 0.17, "b": 0.12}, {"a": 0.041, "b": 0.12},
                   {"a": 0.06, "b": 0.12}, {"a": 0.065, "b": 0.125}])
    calls = {"kernel": 0, "numpy": 0}
    rows, nsolve = kernel.solve_rows, System.solve_batch

    def count(name, f):
        def g(*a, **k):
            calls[name] += 1
            return f(*a, **k)
        return g
    monkeypatch.setattr(kernel, "solve_rows", count("kernel", rows))
    monkeypatch.setattr(System, "solve_batch", count("numpy", nsolve))
    fast = s.run(variants)
    assert calls["kernel"] > 0
    monkeypatch.setenv("PLANARKIN_KERNEL", "0")
    before = dict(calls)
    ref = s.run(variants)
    assert calls["kernel"] == before["kernel"] and calls["numpy"] > before["numpy"]
    assert [(o.status, o.kind) for o in fast] == [(o.status, o.kind) for o in ref]
    assert [(o.status, o.kind) for o in fast][12:14] == [("invalid", ""), ("failed", "lock-up")]
    for f, r in zip(fast, ref):
        if f.status == "ok":
            # each to 2e-15 of its column's largest value (the metric's own magnitude; a dev
            # metric's, a distance between positions, that of the positions: L). Not 1e-15:
            # the compiled study solve converges each point on its own and solves the rate
            # systems through the inverse's entries, the reference (and the grid's compiled
            # route) iterates a block until all points converged and uses Cramer's rule; far
            # from the nominal (a = 0.06) rocker.alpha differs by 1.2e-15 of its largest value
            assert all(abs(x - y) <= 2e-15 * max(abs(y), s.nominal.L if m.kind == "dev" else 0)
                       for x, y, m in zip(f.metrics, r.metrics, s.metrics)), (f, r)
        else:
            assert np.isnan(f.metrics).all() and np.isnan(r.metrics).all()
        assert (np.isnan(f.t) and np.isnan(r.t)) or abs(f.t - r.t) <= 1e-9


@pytest.fixture(scope="module")
def solved(study):
    """Three variants solved by the kernel from the nominal's solution, with the predecessor
    signs of the nominal (variant 1's flipped at one grid time), and what accept needs."""
    kernel, _ = _kernel()
    from planarkin.solver.acceptance import COND_WARN, KAPPA
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
    # the path errors: acceptance.path_errors' (h * h * h here, numpy's h ** 3 there)
    from planarkin.solver.acceptance import path_errors
    ref = path_errors(B.grid, *(a.reshape(V, T, -1) for a in (Qr, Qdr, Qddr)), B.cm.n)
    got = perr.reshape(V, T)
    assert (got[:, 0] == 0).all() and np.allclose(got[:, 1:], ref, rtol=1e-9, atol=1e-18)
    # a point that cannot converge (nan): refused, and the path test of its intervals too
    Qbad = Q.copy()
    Qbad[2, 50, :] = np.nan
    _, Qdb, Qddb, infob, goodb, perrb = B.solve_kernel(k, groups, targets, env, Qbad, sign)
    assert not goodb.reshape(V, T)[2, 50] and goodb.reshape(V, T)[0].all()
    assert np.isnan(perrb.reshape(V, T)[2, 51])


def test_per_point_parameters_equal_a_solve_per_parameter_set(solved):
    # the study solve with a (V, E, 8) table and a variant index per point against the grid
    # solve with each variant's parameters as the system's own
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
            assert (np.abs(a[sl] - b) <= 1e-15 * scale).all()
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


# -- the study routes on every example they cover: the numpy reference (System.solve_batch over
# per-row parameters, Batch.system) against the compiled route (compiled_gen_each) --------------

# the examples the batched study takes (steps: fine enough for the follower's step test on the
# grid), and why it declines the others that have parameters (no others may appear)
STUDY_STEPS = {"four-bar": 180, "quick-return": 180, "six-bar": 180, "trammel": 180,
               "servo-press": 720, "table-input": 360}
NOT_BATCHED = {"boom": "a room checks the rows", "cam-roller": "a room checks the rows",
               "slider-crank": "a room checks the rows", "flat-rocker-cam": "reaches 'at'",
               "planetary": "reaches 'at'", "rack-pinion-steering": "reaches 'at'",
               "valve-cam": "prepares or checks", "belt-drive": "prepares or checks"}
NOT_COMPILED = {"belt-drive", "curved-slot"}      # kinds the compiled route declines


def test_every_example_with_parameters_is_listed_for_the_study_routes():
    from pathlib import Path
    from planarkin.solver.compiled import kernel
    for path in sorted(Path("mechanisms").glob("*.yaml")):
        name = path.stem
        s = Study(str(path), analysis={"steps": STUDY_STEPS.get(name, 180)})
        if not s.parameters:
            assert name not in STUDY_STEPS and name not in NOT_BATCHED
            continue
        keys = list(s.parameters)[:2]
        if name in NOT_BATCHED:
            with pytest.raises(batchmod.Unsupported, match=NOT_BATCHED[name]):
                batchmod.Batch(s, keys)
            continue
        B = batchmod.Batch(s, keys)
        assert (kernel.pack(B.S) is None) == (name in NOT_COMPILED) and \
            (name in STUDY_STEPS) != (name in NOT_COMPILED), name


@pytest.mark.parametrize("name", sorted(STUDY_STEPS))
def test_the_study_routes_agree_to_1e15_of_each_columns_largest_value(name):
    from test_perstep import close_columns
    kernel, _ = _kernel()
    s = Study(f"mechanisms/{name}.yaml", analysis={"steps": STUDY_STEPS[name]})
    keys = list(s.parameters)[:2]
    B = batchmod.Batch(s, keys)
    B.job_points = kernel.COMPILED_FROM_POINTS         # a study large enough for the route
    k = B.kernel()
    assert k is not None
    Q0, _, _, sg0 = B.nominal
    p = s.parameters
    vals = [{key: p[key] + f * (abs(p[key]) or 1.0) for key in keys}
            for f in (1e-4, -2e-4, 3e-4)]
    V, T, W = len(vals), len(Q0), Q0.shape[1]
    Q = np.repeat(Q0[None], V, axis=0)
    sign = np.repeat(sg0[None], V, axis=0)
    fast = B.solve(vals, Q, None, None, sign, k=k)
    ref = B.solve(vals, Q, None, None, sign, k=None)
    assert fast[4].all() and ref[4].all()
    n = B.cm.n
    for a, b, what in zip(fast[:3], ref[:3], ("q", "qd", "qdd")):
        close_columns(b.reshape(V * T, W)[:, :n], a.reshape(V * T, W)[:, :n], what)
    assert np.array_equal(fast[3], ref[3])
    # the metrics the study reports from them: the points' kinematics, the same to 1e-15
    for a, b in zip(B.points(*fast[:3], fast[5]), B.points(*ref[:3], ref[5])):
        close_columns(b.reshape(V * T, -1), a.reshape(V * T, -1), "points")


def _all_batched(s, variants, monkeypatch, fallbacks):
    """The study's outcomes of variants, every one batched (fallbacks: the variants that took
    the ordinary path, kept in the list given)."""
    assert s.batch(variants) is not None
    orig = s.solve
    monkeypatch.setattr(s, "solve", lambda v, *a, **k: fallbacks.append(v) or orig(v, *a, **k))
    out = s.run(variants)
    assert fallbacks == []
    return out


ROD = """name: rod-as-distance
parameters:
  a: 0.1
  l: 0.3          # the rod, a distance joint between the crank pin and the slider's pin
  th: 0           # the guide's angle (a joint's constant)
bodies:
  crank:  {q: [0, 0, 0]}
  slider: {q: [0.4, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: distance, i: crank, j: slider, si: [a, 0], sj: [0, 0], c: l}
  - {type: y, i: ground, j: slider, si: [0, 0], sj: [0, 0], c: 0}
  - {type: angle, i: ground, j: slider, c: th}
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
analysis: {start: 0, end: 1, steps: 180}
"""


def test_parameters_that_reach_joint_constants_are_varied_in_the_batch(tmp_path, monkeypatch):
    """A joint's constant c (a distance's length, an angle) is the kind's target, not one of
    its params: the batch missed it and solved every variant with the nominal's constant (a
    guide's angle varied by 0.039 rad gave the nominal's angle, silently). Now each variant has
    its own: the closed forms max slider.x = a + l and slider.phi = th, every variant batched;
    a length that turns negative is left to the ordinary path, which refuses it."""
    path = tmp_path / "rod.yaml"
    path.write_text(ROD)
    s = Study(str(path), metrics=["max:slider.x", "max:slider.phi"])
    s.chain, s.group = 4, 2
    variants = [{"l": 0.3 + 0.002 * i, "th": 0.003 * i} for i in range(8)]
    fallbacks = []
    for v, o in zip(variants, _all_batched(s, variants, monkeypatch, fallbacks)):
        assert o.status == "ok"
        assert o.metrics[0] == pytest.approx(0.1 + v["l"], rel=1e-12)
        assert o.metrics[1] == pytest.approx(v["th"], abs=1e-15)
    bad = s.run([{"l": 0.3, "th": 0.0}, {"l": -0.3, "th": 0.0}])
    assert bad[1].status == "invalid" and fallbacks == [{"l": -0.3, "th": 0.0}]


def test_a_guides_angle_of_the_five_point_problem_is_the_closed_form():
    """max crank.phi over t in [0, 0.3] is th0 + 0.6 pi (the crank turns 2 pi t from the
    ground line at th0, an angle joint's constant)."""
    s = Study("mechanisms/synthesis/five-point-curve.yaml", metrics=["max:crank.phi"],
              analysis={"end": 0.3})
    variants = [{"th0": 1e-3 * i} for i in range(12)]
    out = s.run(variants)
    assert s.batch(variants) is not None
    for v, o in zip(variants, out):
        assert o.metrics[0] == pytest.approx(v["th0"] + 0.6 * np.pi, abs=1e-13)


@pytest.mark.parametrize("vary", ["r1", "m0"])
def test_a_constant_prepared_from_the_poses_is_each_variants_own(tmp_path, vary):
    """A belt's constant is prepared at compile time from its radii and its bodies' poses
    (ri (phi_i - phi_k) + rj (phi_j - phi_k) at the estimates), and its pulleys are checked at
    assembly. The batch kept the nominal's constant for every variant: with the motor drawn at
    30 deg, r1 varied, min pulley.phi stayed -12.0 deg where each variant's is -30 r1 / r2
    (silently, 0.84 deg off at r1 = 0.0535). Such variants take the ordinary path: the closed
    forms min = -m0 r1 / r2 and max = (270 - m0) r1 / r2 (the motor at 900 deg/s for 0.3 s,
    from 0), for r1 and for the motor's drawn angle m0 varied; pulleys that overlap are
    invalid."""
    text = open("mechanisms/belt-drive.yaml").read().replace(
        "motor:  {q: [0, 0, 0]}", "motor:  {q: [0, 0, m0]}").replace(
        "  r1: 0.05 ", "  m0: 30\n  r1: 0.05 ")
    path = tmp_path / "belt.yaml"
    path.write_text(text)
    s = Study(str(path), metrics=["max:pulley.phi", "min:pulley.phi"], analysis={"end": 0.3})
    variants = [{"r1": 0.05 + 0.0005 * i} if vary == "r1" else {"m0": 30.0 + 2 * i}
                for i in range(6)]
    # (the motor's drawn angle also places its pivot, written with at:)
    with pytest.raises(batchmod.Unsupported, match="prepares or checks|placed on with 'at'"):
        batchmod.Batch(s, [vary])
    for v, o in zip(variants, s.run(variants)):
        r1, m0 = v.get("r1", 0.05), v.get("m0", 30.0)
        ratio = r1 / 0.125
        assert o.metrics == pytest.approx(((270 - m0) * ratio, -m0 * ratio), rel=1e-12)
    if vary == "r1":        # the pulleys overlap from r1 = 0.275 (centre distance 0.4)
        assert [o.status for o in s.run([{"r1": 0.27}, {"r1": 0.28}])] == ["ok", "invalid"]
