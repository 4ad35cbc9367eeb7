"""The grid kernels generated per mechanism structure (planarkin.solver.compiled.gen, loaded and called
by planarkin.solver.compiled.kernels; issue 17): the reference pass's results to 1e-15 of each column's
largest value on every example they cover, the closed forms to 1e-12 / 1e-11 / 1e-10, one
source run compiled or interpreted, a source file that is not the generated text never run,
and a first compile of a few seconds."""

import hashlib
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import planarkin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from routes import NO_NUMBA, REQUIRED  # noqa: E402

if not REQUIRED:        # the generated kernels are numba's (required: the import below fails)
    pytest.importorskip("numba", reason=NO_NUMBA)
from planarkin.solver.compiled import gen as compiled_gen, kernels as compiled_grid, jitcache, kernel  # noqa: E402

import reference_models as R  # noqa: E402
from test_reference import compare  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "mechanisms").glob("*.yaml"))
# the examples whose grid systems a generated kernel covers (the others: kinds kernel.pack
# declines); the Klann leg's 4 x 4 block by Gauss-Jordan (compiled_gen.KDENSE)
COVERED = {"boom", "crank-rocker-clearance", "four-bar", "four-bar-placed", "four-bar-sketch",
           "jansen-holy-numbers", "jansen-leg", "klann-leg", "peaucellier", "quick-return",
           "servo-press", "six-bar", "six-bar-sketch", "slider-crank", "slider-crank-clearance",
           "table-input", "trammel"}
# chains of 2 x 2 blocks carry rounding down six blocks (tests/test_perstep.py: ROUNDING)
ROUNDING = {"jansen-holy-numbers": 3e-15, "jansen-leg": 2e-15, "peaucellier": 2e-15}


def _python(code, env=None, timeout=600):
    e = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    e.update(env or {})
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=e,
                          timeout=timeout, cwd=str(ROOT))


def _followed(path):
    """(model, analysis, grid System) of a model followed over its range at 100 steps."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    m = planarkin.load(path)
    an = prepare(m, resolve(m, {"steps": 100}, source="api"))
    an.follow()
    return m, an, an.follower.systems[0][0]


def _batch(path, N=300, followed=None):
    """The grid System of a model and predictions 1e-4 off its solution at N times."""
    m, an, S = followed or _followed(path)
    t = np.linspace(0.0, 1.0, N)
    ch = an._dense(t)
    ext = S.ext(ch.q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
    Q0 = ext + 1e-4 * np.sin(np.arange(ext.size).reshape(ext.shape))
    Q0[:, S.n:] = 0.0
    return S, t, Q0


def _rel(a, b, n):
    s = np.abs(a[:, :n]).max(axis=0)
    return float((np.abs(a[:, :n] - b[:, :n]) / np.where(s > 0, s, 1.0)).max())


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
@pytest.mark.parametrize("policy,order", [("reuse", 2), ("full", 1)])
def test_generated_kernel_matches_the_reference(path, policy, order):
    """Every output of kernel.solve, field by field, against System._solve_batch at predictions
    off the solution (Newton iterates): positions, rates, iterations, signs, convergence,
    sigma_min, ratio, residuals and what the grid pass reduces from them."""
    followed = _followed(path)
    P = kernel.pack(followed[2])
    assert compiled_gen.covers(P) == (path.stem in COVERED)
    if path.stem not in COVERED:    # (the cam-roller's rows at 300 times took 5 s to solve)
        return
    S, t, Q0 = _batch(path, followed=followed)
    fn = compiled_grid.function(P, S.n + 3, S.cm.m, S.nb)
    ref = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
    info = S.solve_batch(t, *ref, tol=1e-12, maxit=8, fused=False, policy=policy, order=order)
    got = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
    iters, conv, ratio, sign, smin, Rs, rmax, cond = compiled_grid.solve(
        fn, S, P, *got, *S.driver_values(t), policy, 1e-12, 8, order)
    rel = ROUNDING.get(path.stem, 1e-15)
    for k in range(order + 1):
        assert _rel(ref[k], got[k], S.n) <= rel, (k, _rel(ref[k], got[k], S.n))
    assert np.array_equal(info.iterations, iters)
    assert np.array_equal(info.converged, conv) and conv.all()
    assert np.array_equal(info.sign, sign)
    np.testing.assert_allclose(info.smin, smin, rtol=1e-12)
    np.testing.assert_allclose(info.ratio, ratio, rtol=1e-9)
    assert np.abs(Rs - np.abs(S.residual(got[0], t))).max() <= 1e-15
    assert np.array_equal(rmax, Rs.max(axis=1))
    assert np.array_equal(cond, (1.0 / np.maximum(smin, 1e-300)).max(axis=1))


@pytest.mark.parametrize("which", ["slider-crank", "four-bar"])
def test_generated_route_meets_the_closed_forms(which, monkeypatch):
    """planarkin.solve on the compiled route (the threshold lowered) within the closed forms'
    tolerances (1e-12 / 1e-11 / 1e-10 relative), through the generated kernel."""
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 0)
    called = []
    real = compiled_grid.solve
    monkeypatch.setattr(compiled_grid, "solve", lambda *a: called.append(1) or real(*a))
    if which == "slider-crank":
        res = planarkin.solve(planarkin.load("offset-slider-crank.yaml",
                                             text=R.slider_crank_yaml()), steps=2000)
        cf = R.slider_crank_closed_form(res.t)
    else:
        res = planarkin.solve(planarkin.load("crank-rocker.yaml", text=R.FOURBAR_DEG_YAML),
                              steps=2000)
        cf = R.fourbar_closed_form(res.t, degrees=True)
    assert res.status == 0 and called
    compare(res, cf)


# a batch by the generated kernel of the smallest structure (tests/data/crank.yaml: the cache's
# behaviour is the same for every structure, its compile the shortest), printed as json: the largest difference to the reference
# pass relative to each column's largest value, whether it ran compiled, the CPU time of its
# compile or load (CPU, not wall: the tests share two cores with other work)
BATCH = """
import json, sys, time, numpy as np
sys.path.insert(0, "tests")
from test_compiled_gen import _batch, _rel
from planarkin.solver.compiled import kernels as compiled_grid, kernel
S, t, Q0 = _batch("tests/data/crank.yaml", 50)
P = kernel.pack(S)
t0 = time.process_time()
fn = compiled_grid.function(P, S.n + 3, S.cm.m, S.nb)
took = time.process_time() - t0
ref = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
S.solve_batch(t, *ref, tol=1e-12, maxit=8, fused=False)
got = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
compiled_grid.solve(fn, S, P, *got, *S.driver_values(t), "reuse", 1e-12, 8, 2)
py = getattr(fn, "py_func", fn)
print(json.dumps({"rel": max(_rel(a, b, S.n) for a, b in zip(ref, got)), "took": took,
                  "jitted": py is not fn, "file": str(py.__globals__.get("__file__")),
                  "loaded": py is not fn and len(fn.stats.cache_hits) > 0}))
"""


def _run_batch(env):
    r = _python(BATCH, env)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_the_generated_source_runs_interpreted(tmp_path):
    """NUMBA_DISABLE_JIT=1: the same generated text runs as Python, with the same results."""
    got = _run_batch({"NUMBA_DISABLE_JIT": "1", "PLANARKIN_CACHE": str(tmp_path / "c")})
    assert got["jitted"] is False and got["rel"] <= 1e-15


def test_every_structure_pack_accepts_is_written_out():
    """There is one compiled route: the largest block kernel.pack accepts is the largest the
    generator writes out, so no packed structure is left without a kernel."""
    assert kernel.KMAX == compiled_gen.KDENSE


def test_the_first_run_compiles_into_the_cache_and_the_second_loads_it(tmp_path):
    """An empty cache: the crank's kernel compiles and lands, with its source, in the
    checked private cache; a second process loads it (numba's cache hits) instead of compiling.
    How long a compile takes is measured in benchmarks/bench_coldstart.py, not here."""
    env = {"PLANARKIN_CACHE": str(tmp_path / "c")}
    cold = _run_batch(env)
    assert cold["rel"] <= 1e-15 and cold["jitted"] and not cold["loaded"]
    src = Path(cold["file"])
    assert src.parent.parent == tmp_path / "c" / jitcache.tag() and src.suffix == ".py"
    assert src.parent.stat().st_mode & 0o777 == 0o700
    warm = _run_batch(env)
    assert warm["loaded"] and warm["rel"] <= 1e-15


@pytest.mark.parametrize("damage", ["truncated", "doctored", "foreign", "a link"])
def test_a_source_file_that_is_not_the_generated_text_is_replaced(tmp_path, damage):
    """compiled_grid.written: the file on disk is used only when its bytes are exactly the text
    generated now; otherwise it is replaced atomically (never run)."""
    entry = tmp_path / "entry"
    entry.mkdir(mode=0o700)
    text = "x = 1\n"
    path = compiled_grid.written(entry, "pk_grid_test", text)
    assert path.read_text() == text
    if damage == "truncated":
        path.write_text(text[:3])
    elif damage == "doctored":
        path.write_text("x = 2\n")
    elif damage == "foreign":
        path.write_bytes(b"\x00garbage")
    else:
        other = tmp_path / "other.py"
        other.write_text(text)
        path.unlink()
        path.symlink_to(other)
    again = compiled_grid.written(entry, "pk_grid_test", text)
    assert again == path and not path.is_symlink() and path.read_text() == text
    assert [p.name for p in path.parent.iterdir()] == [path.name]


def test_a_doctored_cached_kernel_is_rebuilt_with_the_same_results(tmp_path):
    """A process after another one left its kernel in the cache. The source doctored (the
    crank's x shifted) is detected and written again, with the reference pass's results
    (numba's own files, keyed on the hash of the source's bytes, fit the restored text and
    load); numba's compiled data doctored is deleted (jitcache's manifest) and compiled again."""
    env = {"PLANARKIN_CACHE": str(tmp_path / "c")}
    first = _run_batch(env)
    src = Path(first["file"])
    text = src.read_text()
    step = re.search(r"q0(__\d+)? -= dx0_0(__\d+)?", text).group(0)
    src.write_text(text.replace(step, step + " - 0.001", 1))
    again = _run_batch(env)
    assert again["rel"] <= 1e-15 and src.read_text() == text
    entry = src.parent.parent
    data = [p for p in entry.rglob(f"{src.stem}.grid-*.nbc")]
    assert len(data) == 1
    blob = bytearray(data[0].read_bytes())
    blob[len(blob) // 2] ^= 0xFF
    data[0].write_bytes(bytes(blob))
    third = _run_batch(env)
    assert third["rel"] <= 1e-15 and not third["loaded"]
    assert not any(p.read_bytes() == bytes(blob) for p in entry.rglob("*.nbc"))
    # the manifest vouches for every file of the entry, the source among them
    manifest = json.loads((entry / jitcache.MANIFEST).read_text())
    assert f"gen/{src.name}" in manifest
    assert all(hashlib.sha256((entry / f).read_bytes()).hexdigest() == d
               for f, d in manifest.items())


def test_without_a_private_cache_the_kernel_compiles_in_memory(tmp_path):
    """A cache directory others can write: nothing is written there, the generated source is
    compiled in memory (numba's disk cache off), with the same results."""
    bad = tmp_path / "shared"
    bad.mkdir()
    bad.chmod(0o777)
    got = _run_batch({"PLANARKIN_CACHE": str(bad)})
    assert got["rel"] <= 1e-15 and got["jitted"] and not got["loaded"]
    assert got["file"].startswith("<planarkin pk_grid_") and not any(bad.iterdir())


# (six-bar for the 2 x 2 blocks: test_batch's study routes compile its study kernel too, where
# the Jansen leg's took 19 s of a cold suite for the same kind of block)
@pytest.mark.parametrize("name,merged", [("four-bar", False), ("klann-leg", False),
                                         ("six-bar", False), ("four-bar", True)])
def test_the_generated_study_solve_reads_each_points_parameters(name, merged, monkeypatch):
    """The studies' point-by-point solve written out per structure (compiled_gen_each), with
    two parameter sets alternating point by point (a per-point table) and the acceptance tests
    on, gives each point what a solve with its own set alone gives (bit for bit), and with the
    model's own set the numpy reference's positions, velocities and accelerations to 1e-15 of
    each column's largest value (System.solve_batch, every point iterated to convergence);
    2 x 2 blocks (the six-bar's), a 4 x 4 one (Klann) and the path's merged 9 x 9."""
    import test_perstep
    lib = kernel.library().need("study")
    S, t, Q0 = test_perstep._batch(f"{name}.yaml", merged=merged, N=120)
    P = kernel.pack(S)
    assert P is not None and compiled_gen.covers(P)
    T, NU, FDD = S.driver_values(t)
    table = np.stack([P.arrays[3], P.arrays[3] * (1 + 1e-3)])
    rows = (np.arange(len(t)) % 2).astype(np.int64)
    sign0 = np.ones((len(t), P.nfine))
    called = []
    real = compiled_grid.function_each
    monkeypatch.setattr(compiled_grid, "function_each",
                        lambda *a: called.append(1) or real(*a))
    mixed = [np.array(x) for x in kernel.solve_rows(lib, S, P, Q0.copy(), T, NU, FDD, 1e-12, 8,
                                                      rows=rows, table=table,
                                                      accept=(t, sign0))]
    assert called and mixed[4].any() and np.isfinite(mixed[9]).all()
    for k in (0, 1):
        alone = [np.array(x) for x in kernel.solve_rows(
            lib, S, P, Q0.copy(), T, NU, FDD, 1e-12, 8, rows=np.full(len(t), k),
            table=table, accept=(t, sign0))]
        sel = rows == k
        # positions, rates and each point's diagnostics (not the path errors and their test:
        # each is of the interval from the point before, of the other set in the mixed solve)
        for a, b in zip(mixed[:8], alone[:8]):
            assert np.array_equal(a[sel], b[sel], equal_nan=True)
    own = kernel.solve_rows(lib, S, P, Q0.copy(), T, NU, FDD, 1e-12, 8)
    X = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
    S.solve_batch(t, *X, tol=1e-12, maxit=8, policy="full", fused=False)
    for a, b, what in zip(own[:3], X, ("q", "qd", "qdd")):
        test_perstep.close_columns(b[:, :S.n], a[:, :S.n], what)


# (table-input and six-bar were here too: on an empty cache they cost 64 s and 26 s of the
# cold suite; every example's grid system is held to the numpy pass by
# test_generated_kernel_matches_the_reference above)
@pytest.mark.parametrize("name", ["four-bar", "slider-crank", "klann-leg", "jansen-leg"])
def test_a_whole_run_on_the_compiled_route_is_the_numpy_routes(name, monkeypatch):
    """planarkin.solve with the threshold lowered (the grid's chunks by the generated kernel,
    their predictions written inside it from the path's nodes, into buffers kept from chunk to
    chunk) against PLANARKIN_KERNEL=0: every column to 1e-15 of its largest value, the same
    iteration counts."""
    from test_perstep import close_columns

    from planarkin.solver import grid as solver
    monkeypatch.setattr(solver, "CHUNK_BYTES", 1)      # chunks of 16 points, the last of 1
    m = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
    monkeypatch.setenv("PLANARKIN_KERNEL", "0")
    ref = planarkin.solve(m, steps=240)
    monkeypatch.setenv("PLANARKIN_KERNEL", "1")
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 0)
    called = []
    real = compiled_grid.solve
    monkeypatch.setattr(compiled_grid, "solve",
                        lambda *a, **k: called.append(a[-2] is not None) or real(*a, **k))
    got = planarkin.solve(m, steps=240)
    assert ref.status == got.status == 0 and len(ref.t) == len(got.t) == 241
    assert len(called) == 16 and all(called)      # every chunk predicted in the kernel
    for what in ("q", "qd", "qdd", "p", "pd", "pdd"):
        close_columns(getattr(ref, what), getattr(got, what), what)
    assert np.array_equal(ref.iterations, got.iterations)
