"""The grid pass's fast routes against the reference pass (issue 12 item 3, issue 17).

System._solve_batch is the numpy reference (the only numpy solve); the compiled route
(planarkin.solver.compiled.kernel, planarkin.compiled: numba) must give the same positions, velocities and
accelerations to 1e-15 of each column's largest value, the same iteration counts, determinant
signs and convergence flags, on every example model it applies to. numba is a dependency: these tests
do not skip."""

import numpy as np
import pytest

import planarkin
from planarkin.solver.compiled import kernel
from planarkin.solver import system
from routes import skip_without_numba
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "mechanisms").glob("*.yaml"))


@pytest.fixture(scope="module")
def compiled():
    """The compiled route's Library, its grid entry points ready (numba's cache: the first
    session on a machine compiles them)."""
    skip_without_numba()
    lib = kernel.library()
    assert lib is not None, "numba is installed but cannot be imported"
    return lib.need("points")


def _solve(path, monkeypatch, route, steps=240, **opts):
    """Solve with the grid pass forced onto route ('reference' or 'kernel'); returns
    the Result and the routes the grid chunks took."""
    taken = []
    real = system.System.solve_batch

    lib = kernel.library() if route == "kernel" else None

    def spy(self, t, Q, Qd, Qdd, **kw):
        if Q.shape[0] > 8:                     # a grid chunk, not the path's candidates
            kw["fused"] = route != "reference"
            kw["compiled"] = lib
            if route == "kernel" and self.kernel(lib) is not None:
                taken.append("kernel")
            else:
                taken.append("reference")
        return real(self, t, Q, Qd, Qdd, **kw)

    with monkeypatch.context() as m:
        m.setattr(system.System, "solve_batch", spy)
        res = planarkin.solve(planarkin.load(path), steps=steps, **opts)
    return res, taken


# The compiled route agrees with the reference to 1e-15 of each column's largest value on every
# example it covers, the Jansen legs' chains of 2 x 2 blocks included (both invert them in closed
# form and solve their rate systems by Cramer's rule: system.Small2, compiled.factor and solve2)
DECLINED = {"belt-drive", "cam-roller", "curved-slot", "flat-rocker-cam", "planetary",
            "rack-pinion-steering", "valve-cam"}


def close_columns(a, b, what, rel=1e-15):
    """b equals a to rel of the largest magnitude of each column of a ((N, ...) arrays, the
    trailing axes flattened into columns); a column whose largest value is below 1e-6 of the
    array's is a zero to rounding (the Peaucellier point's x velocity on its line, 9e-15 m/s),
    compared to the array's largest value."""
    if not a.size:
        return
    a2, b2 = a.reshape(len(a), -1), b.reshape(len(b), -1)
    scale = np.abs(a2).max(axis=0)
    scale = np.where(scale < 1e-6 * scale.max(), scale.max(), scale)
    err = np.abs(a2 - b2).max(axis=0) / np.where(scale > 0, scale, 1.0)
    assert (err <= rel).all(), (what, err.max())



@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_fast_routes_match_reference(path, monkeypatch, compiled):
    ref, _ = _solve(path, monkeypatch, "reference")
    assert ref.status == 0
    res, taken = _solve(path, monkeypatch, "kernel")
    assert res.status == 0
    # the models whose kinds (motion laws, gears, belts: not point-and-line formulas) the
    # compiled route declines (kernel.pack)
    assert ("kernel" in taken) == (path.stem not in DECLINED)
    if "kernel" in taken:
        _same(ref, res, 1e-15)


def _same(ref, fus, rel=1e-15):
    for name in ("q", "qd", "qdd", "p", "pd", "pdd"):
        close_columns(getattr(ref, name), getattr(fus, name), name, rel)
    assert np.array_equal(ref.iterations, fus.iterations)
    np.testing.assert_allclose(ref.cond, fus.cond, rtol=1e-9)
    np.testing.assert_allclose(ref.residual, fus.residual, rtol=1e-3, atol=1e-15)


def _batch(name, merged=False, N=300):
    """The grid System of an example (merged: the path's) and predictions 1e-4 off its solution
    at N times."""
    m = planarkin.load(ROOT / "mechanisms" / name)
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    an = prepare(m, resolve(m, {"steps": 100}, source="api"))
    an.follow()
    S = an.follower.systems[0][1 if merged else 0]
    t = np.linspace(0.0, 1.0, N)
    ch = an._dense(t)                           # solved rows, user units: rebuild predictions
    ext = S.ext(ch.q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
    Q0 = ext + 1e-4 * np.sin(np.arange(ext.size).reshape(ext.shape))
    Q0[:, S.n:] = 0.0
    return S, t, Q0


def _info_match(S, t, Q0, routes, policy="reuse", order=2, lib=None, rel=1e-15):
    """routes: the first the reference; lib: the compiled route, taken by fused None or True;
    held to rel of each column's largest value."""
    out = []
    for fused in routes:
        Q, Qd, Qdd = Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)
        info = S.solve_batch(t, Q, Qd, Qdd, tol=1e-12, maxit=8, fused=fused, policy=policy,
                             order=order, compiled=lib)
        out.append((Q, Qd, Qdd, info))
    (Q1, Qd1, Qdd1, i1), (Q2, Qd2, Qdd2, i2) = out
    for a, b, what in ((Q1, Q2, "q"), (Qd1, Qd2, "qd"), (Qdd1, Qdd2, "qdd")):
        close_columns(a[:, :S.n], b[:, :S.n], what, rel)
    assert np.array_equal(i1.iterations, i2.iterations)
    assert np.array_equal(i1.converged, i2.converged) and i1.converged.all()
    assert np.array_equal(i1.sign, i2.sign)
    np.testing.assert_allclose(i1.smin, i2.smin, rtol=1e-12)
    np.testing.assert_allclose(i1.ratio, i2.ratio, rtol=1e-9)
    return i2


@pytest.mark.parametrize("name,policy,order", [
    ("four-bar.yaml", "reuse", 2), ("slider-crank.yaml", "reuse", 2),
    ("klann-leg.yaml", "reuse", 2),
    ("trammel.yaml", "reuse", 2), ("boom.yaml", "reuse", 2), ("quick-return.yaml", "full", 2),
    ("four-bar.yaml", "full", 1), ("slider-crank.yaml", "reuse", 0)])
def test_kernel_info_matches_reference(name, policy, order, monkeypatch, compiled):
    """Field by field, blocks of 1, 2 and 4 unknowns, revolute, translational, x and distance
    rows; and the residuals it returns are those of System.residual."""
    S, t, Q0 = _batch(name)
    assert S.kernel(compiled) is not None
    info = _info_match(S, t, Q0, (False, True), policy, order, compiled)
    Q = Q0.copy()
    S.solve_batch(t, Q, np.zeros_like(Q), np.zeros_like(Q), tol=1e-12, maxit=8, fused=False,
                  policy=policy, order=order)
    R = np.abs(S.residual(Q, t))
    assert np.abs(info.residual - R).max() <= 1e-15
    # what the kernel reduces for the grid pass: each point's largest residual and the
    # condition estimate of acceptance.condition, as numpy computes them from its arrays
    assert np.array_equal(info.residual_max, info.residual.max(axis=1))
    assert np.array_equal(info.cond, (1.0 / np.maximum(info.smin, 1e-300)).max(axis=1))


@pytest.mark.parametrize("name,N", [("four-bar.yaml", 4), ("klann-leg.yaml", 4),
                                    ("slider-crank.yaml", 300)])
def test_kernel_on_the_paths_merged_blocks(name, N, monkeypatch, compiled):
    """The path follower's blocks merge the fine ones (a 9 x 9 block for the four-bar): the
    determinant signs of every fine block inside, a handful of candidate points per call."""
    S, t, Q0 = _batch(name, merged=True, N=N)
    assert max(len(B.sizes) for B in S.blocks) > 1 and S.kernel(compiled) is not None
    for policy in ("reuse", "full"):
        # a 9 x 9 block: the kernel's Gauss-Jordan against LAPACK's LU (numpy's inverse of a
        # few matrices), 2.0e-15 on the four-bar. The path's candidates are always solved by
        # the reference (solver.PathFollower passes no compiled route), so no result differs
        _info_match(S, t, Q0, (False, None), policy, lib=compiled, rel=3e-15)


def test_kernel_declines_other_kinds():
    """A cam (a motion law) and gear meshes keep the numpy passes."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    for name in ("cam-roller.yaml", "planetary.yaml"):
        m = planarkin.load(ROOT / "mechanisms" / name)
        S = prepare(m, resolve(m, {"steps": 10}, source="api")).follower.systems[0][0]
        assert kernel.pack(S) is None


def _poisoned(path, monkeypatch, route, row_t, field, steps=240):
    """Solve on route with one value of a grid chunk's results made NaN after the solve (as an
    overflow would): field 'qd' or 'qdd', at the row of time row_t, coordinate 2."""
    real = system.System.solve_batch

    def poisoned(self, t, Q, Qd, Qdd, **kw):
        info = real(self, t, Q, Qd, Qdd, **kw)
        if Q.shape[0] > 8 and (t == row_t).any():
            {"qd": Qd, "qdd": Qdd}[field][int(np.nonzero(t == row_t)[0][0]), 2] = np.nan
        return info

    monkeypatch.setattr(system.System, "solve_batch", poisoned)
    try:
        return _solve(path, monkeypatch, route, steps=steps)
    finally:
        monkeypatch.setattr(system.System, "solve_batch", real)


@pytest.mark.parametrize("field", ["qd", "qdd"])
def test_a_refusal_is_the_same_on_every_route(field, monkeypatch, compiled):
    """A non-finite value in a kernel chunk (whose acceptance and refusal checks take the
    whole-array fast paths) is refused as the numpy reference refuses it: the same row, the
    same message, the same rows before it."""
    path = ROOT / "mechanisms" / "four-bar.yaml"
    out = {}
    for route in ("reference", "kernel"):
        res, taken = _poisoned(path, monkeypatch, route, 0.5, field)
        assert taken and set(taken) == {route}
        out[route] = res
    ref = out["reference"]
    assert ref.status == 1 and ref.event.kind == "non-finite" and len(ref.t) == 120
    assert "t = 0.5 s" in ref.message
    res = out["kernel"]
    assert (res.status, res.event.kind, res.message) == (ref.status, ref.event.kind,
                                                         ref.message)
    assert len(res.t) == len(ref.t)
    _same(ref, res, 1e-15)


def test_refuse_keeps_finite_rows_whose_sum_overflows(monkeypatch):
    """refuse() clears a chunk by one finite sum per array; a sum that overflows (huge but
    finite values) must fall through to the row-by-row checks and keep the rows, and a
    residual above the limit is still refused at its row."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare, refuse, residual_limit
    m = planarkin.load(ROOT / "mechanisms" / "four-bar.yaml")
    an = prepare(m, resolve(m, {"steps": 100}, source="api"))
    ch = next(an.chunks())
    N = len(ch.t)
    ch.q[:2, 0] = 1.7e308                       # finite, their sum is not
    with np.errstate(over="ignore"):
        assert not np.isfinite(ch.q.sum())
    kept = refuse(an, ch)
    assert an.event is None and len(kept.t) == N
    ch.residual[7] = 2 * residual_limit(an.opts)
    cut = refuse(an, ch)
    assert len(cut.t) == 7 and an.event.kind == "residual"
