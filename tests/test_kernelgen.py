"""pk_rows specialised to a system's structure (planarkin.kernelgen) gives pk_rows' results bit
for bit: positions, velocities, accelerations, iteration counts, convergence, ratios, signs,
sigma_min bounds, the acceptance tests and the path errors, on every kind and block size the
kernel covers, with shared and per-point parameters, at predictions off the solution and at
points that cannot converge."""

import os

import numpy as np
import pytest

import planarkin
from planarkin import kernel, kernelgen
from reference_models import WHITWORTH_PINSLOT_YAML
from test_forces import SLIDE_DRIVEN          # slide driver, translational joint

ROOT = os.path.join(os.path.dirname(__file__), "..", "mechanisms")

COMPONENTS = """
name: components
bodies:
  a: {q: [0.3, 0.1, 0.2]}
  b: {q: [0.8, 0.4, -0.3]}
joints:
  - {type: x, i: ground, j: a, si: [0.3, 0], sj: [0.02, 0.01], c: 0.01}
  - {type: distance, i: a, j: b, si: [0.1, 0.05], sj: [-0.1, 0.0], c: 0.45}
  - {type: y, i: a, j: b, si: [0, 0], sj: [0.05, 0], c: 0.3}
drivers:
  - {type: y, body: a, f: "0.1 + 0.05*sin(2*pi*t)"}
  - {type: angle, body: a, f: "0.2 + 0.1*t"}
  - {type: angle, i: a, j: b, f: "-0.5 + 0.3*t"}
analysis: {start: 0, end: 1, steps: 24}
"""


def _system(source, merged=False, N=200):
    """A model's grid System (merged: the path follower's) and predictions off its solution
    at N times; the ground's columns zero, as the studies give them."""
    m = planarkin.load(os.path.join(ROOT, source))     # a name in mechanisms/ or a path
    from planarkin.options import resolve
    from planarkin.results import prepare
    an = prepare(m, resolve(m, {"steps": 100}, source="api"))
    an.follow()
    S = an.follower.systems[0][1 if merged else 0]
    t = np.linspace(0.0, 1.0, N)
    ch = an._dense(t)
    Q0 = S.ext(ch.q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
    Q0 = Q0 + 1e-6 * np.sin(np.arange(Q0.size).reshape(Q0.shape))
    Q0[:, S.n:] = 0.0
    return S, t, Q0


def _both(S, t, Q, rows=None, table=None, accept=True):
    lib = kernel.library()
    P = kernel.pack(S)
    assert P is not None and kernelgen.applies(P)
    gen = kernelgen.function(P, S.cm.n + 3, S.cm.m, S.nb)
    assert gen is not None
    T, NU, FDD = S.driver_values(t)
    sign0 = kernel.solve_rows(lib, S, P, Q.copy(), T, NU, FDD, 1e-12, 8, rows=rows,
                              table=table)[6].copy()
    sign0[::7] *= -1                            # some rows refused by the sign test
    out = []
    for g in (None, gen):
        acc = (t, sign0, 1e-2, 1e8) if accept else None
        out.append(kernel.solve_rows(lib, S, P, Q.copy(), T, NU, FDD, 1e-12, 8, rows=rows,
                                     table=table, accept=acc, gen=g))
    for a, b in zip(*out):
        if a is None:
            assert b is None
        else:
            assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
    return out[1]


CASES = [("four-bar.yaml", False), ("slider-crank.yaml", False), ("klann-leg.yaml", False),
         ("trammel.yaml", False), ("boom.yaml", False), ("quick-return.yaml", False),
         ("jansen-leg.yaml", False), ("boom.yaml", True), ("trammel.yaml", True),
         ("four-bar.yaml", True)]


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    saved = os.environ.get("PLANARKIN_CACHE")
    os.environ["PLANARKIN_CACHE"] = str(tmp_path_factory.mktemp("kernelgen"))
    kernel._state.clear()
    kernelgen._libs.clear()
    if kernel.library(build=True) is None:
        pytest.skip("no C compiler: the numpy passes run")
    yield
    if saved is None:
        del os.environ["PLANARKIN_CACHE"]
    else:
        os.environ["PLANARKIN_CACHE"] = saved
    kernel._state.clear()
    kernelgen._libs.clear()


def _load_text(text, tmp_path):
    p = tmp_path / "m.yaml"
    p.write_text(text)
    return str(p)


@pytest.mark.parametrize("name,merged", CASES, ids=[f"{n[:-5]}{'-merged' if m else ''}"
                                                    for n, m in CASES])
def test_specialised_kernel_equals_pk_rows_bit_for_bit(name, merged, compiled):
    S, t, Q = _system(name, merged)
    if merged:
        P = kernel.pack(S)
        assert max(P.fine[1]) > 1, "a merged block of several fine ones"
    out = _both(S, t, Q)
    assert out[4].all() and out[8].any() and not out[8].all()


@pytest.mark.parametrize("text", [COMPONENTS, SLIDE_DRIVEN, WHITWORTH_PINSLOT_YAML],
                         ids=["x-y-distance-angle", "slide-translational", "pin-slot"])
@pytest.mark.parametrize("merged", [False, True], ids=["grid", "merged"])
def test_every_kind_bit_for_bit(text, merged, compiled, tmp_path):
    S, t, Q = _system(_load_text(text, tmp_path), merged)
    kinds = set(kernel.pack(S).arrays[0].tolist())
    out = _both(S, t, Q)
    assert out[4].all()
    assert kinds & {4, 5, 6, 7, 8}


def test_per_point_parameters_and_failing_points_bit_for_bit(compiled):
    S, t, Q = _system("four-bar.yaml")
    P = kernel.pack(S)
    N = len(t)
    table = np.repeat(P.arrays[3][None], 3, axis=0)
    table[1, :, 0] *= 1.001
    table[2, :, 2] *= 0.999
    rows = (np.arange(N) % 3).astype(np.int32)
    rows[N // 2:] = 2                       # runs of one variant: the path errors
    Q = Q.copy()
    Q[5, :S.n] = np.nan                     # cannot converge
    Q[9, 3] = 1e6                           # far off: Newton's limit
    out = _both(S, t, Q, rows=rows, table=table)
    assert not out[4][5] and not out[8][5]
    _both(S, t, Q, rows=rows, table=table, accept=False)


def test_a_block_larger_than_kgen_keeps_pk_rows(compiled):
    S, _, _ = _system("jansen-leg.yaml", merged=True)
    P = kernel.pack(S)
    assert P is not None and int(P.arrays[6].max()) > kernelgen.KGEN
    assert not kernelgen.applies(P) and kernelgen.function(P, S.cm.n + 3, S.cm.m, S.nb) is None


def test_the_source_names_its_structure_and_is_cached_by_it(compiled):
    S1, _, _ = _system("four-bar.yaml")
    S2, _, _ = _system("slider-crank.yaml")
    P1, P2 = kernel.pack(S1), kernel.pack(S2)
    f1 = kernelgen.function(P1, S1.cm.n + 3, S1.cm.m, S1.nb)
    assert kernelgen.function(P1, S1.cm.n + 3, S1.cm.m, S1.nb) is f1
    assert P1.gen_key[2] != kernelgen.function(P2, S2.cm.n + 3, S2.cm.m, S2.nb) and \
        P1.gen_key[2] != P2.gen_key[2]
    assert P1.gen_key[2].exists() and P1.gen_key[2].name.startswith("kernel-gen-")


def test_the_kernels_cubic_prediction_equals_the_numpy_lines(compiled):
    # studies.batch predicts chains in lockstep by pk_cubic where the kernel is, else by numpy
    rng = np.random.default_rng(7)
    q0, q1, q2, q3 = (rng.standard_normal((16, 37, 12)) * 10.0 ** rng.integers(-3, 4)
                      for _ in range(4))
    r = np.subtract(q0, q1)
    r *= 3
    r += q0
    t = np.subtract(q1, q2)
    t *= 3
    r -= t
    np.subtract(q2, q3, out=t)
    r += t
    out = np.empty_like(q0)
    kernel.library().pk_cubic(out.size, *(a.ctypes.data for a in (q0, q1, q2, q3, out)))
    assert np.array_equal(out, r)


def test_predicting_from_the_history_equals_predicting_first(compiled):
    # solve_rows(hist=...) (the cubic computed as the kernel reads each row) against pk_cubic
    # then solve_rows, on both kernels; Q itself is not written
    S, t, Q = _system("four-bar.yaml")
    P = kernel.pack(S)
    lib = kernel.library()
    gen = kernelgen.function(P, S.cm.n + 3, S.cm.m, S.nb)
    T, NU, FDD = S.driver_values(t)
    rng = np.random.default_rng(3)
    hist = []
    for k in (1, 2, 3):
        h = Q + 1e-5 * k * rng.standard_normal(Q.shape)
        h[:, S.n:] = 0.0
        hist.append(h)
    pred = np.empty_like(Q)
    lib.pk_cubic(Q.size, *(a.ctypes.data for a in (Q, *hist, pred)))
    cub = np.arange(len(Q)) % 5 != 3            # the others: Qin's rows
    direct = Q + 1e-7
    direct[:, S.n:] = 0.0
    pred[~cub] = direct[~cub]
    ref = kernel.solve_rows(lib, S, P, pred.copy(), T, NU, FDD, 1e-12, 8)
    keep = [a.copy() for a in (Q, direct, *hist)]
    for g in (None, gen):
        out = kernel.solve_rows(lib, S, P, direct, T, NU, FDD, 1e-12, 8, gen=g,
                                hist=(Q, *hist, cub))
        assert all(np.array_equal(a, b) for a, b in zip(keep, (Q, direct, *hist)))
        for a, b in zip(out, ref):
            assert (a is None and b is None) or np.array_equal(a, b, equal_nan=True)
    # a ground coordinate that is not +0 (never in a study): that point is refused, the
    # others are pk_rows' bits
    for at, value in (((4, S.n + 1), -0.0), ((9, S.n), 1e-3)):
        sign0 = ref[6].copy()
        acc = (t, sign0, 1e-2, 1e8)
        Qg = Q.copy()
        Qg[at] = value
        a = kernel.solve_rows(lib, S, P, Qg.copy(), T, NU, FDD, 1e-12, 8, gen=gen, accept=acc)
        b = kernel.solve_rows(lib, S, P, Qg.copy(), T, NU, FDD, 1e-12, 8, accept=acc)
        assert not a[4][at[0]] and not a[8][at[0]] and b[4][at[0]]
        rest = np.arange(len(Q)) != at[0]
        nxt = rest.copy()
        nxt[at[0] + 1] = False              # its successor's path error reads it
        for x, y in zip(a[:8], b[:8]):
            assert np.array_equal(x[rest], y[rest], equal_nan=True)
        assert np.array_equal(a[8][nxt], b[8][nxt]) and np.array_equal(a[9][nxt], b[9][nxt])


def test_a_large_study_compiles_it_and_its_outcomes_are_pk_rows_bits(compiled, tmp_path,
                                                                       monkeypatch):
    # Study.units compiles the specialised kernel for a study of SPECIALISE_ROWS rows or more
    # (before any worker starts); a smaller one on a machine without it runs pk_rows: the
    # outcomes are the same bits either way
    from planarkin.studies import variants as variantsmod
    from planarkin.studies.sweep import Range, factorial
    path = os.path.join(ROOT, "four-bar.yaml")
    vs = factorial([Range("a", 0.035, 0.045, 5), Range("b", 0.115, 0.125, 4)])
    metrics = ["max:rocker.phi", "min:P.y", "absmax:coupler.alpha"]

    def outcomes(rows, cache):
        monkeypatch.setattr(variantsmod, "SPECIALISE_ROWS", rows)
        monkeypatch.setenv("PLANARKIN_CACHE", str(cache))
        kernel._state.clear()
        kernelgen._libs.clear()
        s = variantsmod.Study(path, analysis={"steps": 180}, metrics=metrics)
        s.units(vs)
        B = s.batch(vs)
        gen = B.kernel()[2]
        return s.run(vs), gen, sorted(p.name for p in cache.glob("kernel-gen-*.so"))

    big, gen, files = outcomes(len(vs) * 181, tmp_path / "a")
    assert gen is not None and len(files) == 1
    small, gen, files = outcomes(len(vs) * 181 + 1, tmp_path / "b")
    assert gen is None and files == []
    assert [o.status for o in big] == ["ok"] * len(vs) and repr(big) == repr(small)


def test_the_kernels_compile_without_warnings(compiled, tmp_path):
    # -Wall -Wextra at -O2 (where gcc's maybe-uninitialized analysis runs), the generated
    # source of a system with 1 x 1, 2 x 2 and 4 x 4 blocks included
    import shutil
    import subprocess
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        pytest.skip("no C compiler")
    sources = [("kernel.c", kernel.SOURCE)]
    for model in ("four-bar.yaml", "klann-leg.yaml"):
        S, _, _ = _system(model)
        sources.append((model + ".c", kernel.HELPERS + kernelgen.source(
            kernel.pack(S), S.cm.n + 3, S.cm.m, S.nb)))
    for name, src in sources:
        path = tmp_path / name
        path.write_text(src)
        r = subprocess.run([cc, *kernel.CFLAGS, "-Wall", "-Wextra", "-Wno-unused-function",
                            "-fPIC", "-c", "-o", str(path.with_suffix(".o")), str(path)],
                           capture_output=True, text=True)
        assert r.returncode == 0 and "warning" not in r.stderr, (name, r.stderr[-2000:])
