"""The grid pass's fast routes against the reference pass (issue 12 item 3).

System._solve_batch is the reference implementation; the fused small-block pass
(System._solve_small) must give the same positions, velocities and accelerations to rounding, the
same iteration counts, determinant signs and convergence flags, on every example model whose
blocks are small."""

from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin import system

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "mechanisms").glob("*.yaml"))


def _solve(path, monkeypatch, route, steps=240, **opts):
    """Solve with the grid pass forced onto route ('reference' or 'fused'); returns the Result
    and the routes the grid chunks took."""
    taken = []
    real = system.System.solve_batch

    def spy(self, t, Q, Qd, Qdd, **kw):
        if Q.shape[0] > 8:                     # a grid chunk, not the path's candidates
            kw["fused"] = route == "fused"
            taken.append(route if route != "fused" or self.small() else "reference")
        return real(self, t, Q, Qd, Qdd, **kw)

    with monkeypatch.context() as m:
        m.setattr(system.System, "solve_batch", spy)
        res = planarkin.solve(planarkin.load(path), steps=steps, **opts)
    return res, taken


def _close(a, b, what):
    if not a.size:
        return
    scale = max(1.0, float(np.abs(a).max()))
    assert np.abs(a - b).max() <= 1e-12 * scale, what


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_fused_pass_matches_reference(path, monkeypatch):
    ref, _ = _solve(path, monkeypatch, "reference")
    fus, taken = _solve(path, monkeypatch, "fused")
    assert ref.status == fus.status == 0
    if "fused" not in taken:
        pytest.skip("blocks larger than system.SMALL_BLOCK: the reference pass only")
    for name in ("q", "qd", "qdd", "p", "pd", "pdd"):
        _close(getattr(ref, name), getattr(fus, name), name)
    assert np.array_equal(ref.iterations, fus.iterations)
    np.testing.assert_allclose(ref.cond, fus.cond, rtol=1e-9)


def test_fused_pass_info_matches_reference():
    """BatchInfo field by field on the four-bar (a 2x2 block) at predictions off the solution."""
    m = planarkin.load(ROOT / "mechanisms" / "four-bar.yaml")
    from planarkin.options import resolve
    from planarkin.results import prepare
    an = prepare(m, resolve(m, {"steps": 100}, source="api"))
    an.follow()
    S = an.follower.systems[0][0]
    assert S.small()
    t = np.linspace(0.0, 1.0, 300)
    Q0 = an._dense(t)                           # solved rows, user units: rebuild predictions
    ext = S.ext(Q0.q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
    Q0 = ext + 1e-4 * np.sin(np.arange(ext.size).reshape(ext.shape))
    Q0[:, S.n:] = 0.0
    out = []
    for fused in (False, True):
        Q, Qd, Qdd = Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)
        info = S.solve_batch(t, Q, Qd, Qdd, tol=1e-12, maxit=8, fused=fused)
        out.append((Q, Qd, Qdd, info))
    (Q1, Qd1, Qdd1, i1), (Q2, Qd2, Qdd2, i2) = out
    for a, b, what in ((Q1, Q2, "q"), (Qd1, Qd2, "qd"), (Qdd1, Qdd2, "qdd")):
        _close(a, b, what)
    assert np.array_equal(i1.iterations, i2.iterations)
    assert np.array_equal(i1.converged, i2.converged) and i1.converged.all()
    assert np.array_equal(i1.sign, i2.sign)
    np.testing.assert_allclose(i1.smin, i2.smin, rtol=1e-12)
    np.testing.assert_allclose(i1.ratio, i2.ratio, rtol=1e-9)
