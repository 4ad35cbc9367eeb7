"""The compiled route (planarkin.compiled on numba, issue 17): one Python text, compiled or
interpreted; chosen by the job's size only; numba imported only then; its disk cache private,
checked and rebuilt when damaged; the numpy passes where numba cannot be imported.

(Route equality on every example: tests/test_perstep.py and, for the studies' batch path,
tests/test_batch.py.)"""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.solver.compiled import jitcache, kernel

from routes import HAVE_NUMBA, needs_numba

ROOT = Path(__file__).resolve().parent.parent
FOUR_BAR = ROOT / "mechanisms" / "four-bar.yaml"


def _python(code, env=None, timeout=300):
    """Run code in a fresh interpreter with this worktree first on the path; returns the
    CompletedProcess (stdout, stderr as text)."""
    e = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    e.update(env or {})
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=e,
                          timeout=timeout, cwd=str(ROOT))


# a tiny batch both ways: the four-bar's grid System at 7 points 1e-4 off the solution, solved
# by the reference pass and by the compiled route (solve, solve_rows, layout); prints
# the largest difference relative to each column's largest value, and the route's name
TINY = """
import json, numpy as np, planarkin
from planarkin.solver.compiled import kernel
from planarkin.options import resolve
from planarkin.analysis import prepare
m = planarkin.load("mechanisms/four-bar.yaml")
an = prepare(m, resolve(m, {"steps": 20}, source="api"))
an.follow()
S = an.follower.systems[0][0]
t = np.linspace(0.0, 1.0, 7)
ch = an._dense(t)
ext = S.ext(ch.q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
Q0 = ext + 1e-4 * np.sin(np.arange(ext.size).reshape(ext.shape))
Q0[:, S.n:] = 0.0
lib = kernel.library().need("points").need("study")
out = {}
for name, kw in (("ref", dict(fused=False)), ("lib", dict(compiled=lib))):
    X = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
    info = S.solve_batch(t, *X, tol=1e-12, maxit=8, policy="full", **kw)
    out[name] = X + [info.iterations]
X = kernel.solve_rows(lib, S, kernel.pack(S), Q0.copy(), *S.driver_values(t), 1e-12, 8)
L = kernel.layout(lib, m, *out["lib"][:3], 2, np.tile([m.L, m.L, 1.0], m.nb))
def rel(a, b):
    s = np.abs(b[:, :S.n]).max(axis=0)
    return float((np.abs(a[:, :S.n] - b[:, :S.n]) / np.where(s > 0, s, 1)).max())
print(json.dumps({"solve": max(rel(a, b) for a, b in zip(out["lib"][:3], out["ref"][:3])),
                  "iters": bool(np.array_equal(out["lib"][3], out["ref"][3])),
                  "rows": max(rel(a, b) for a, b in zip(X[:3], out["ref"][:3])),
                  "layout": bool(np.isfinite(L[5]).all()),
                  "jitted": hasattr(lib.layout, "py_func")}))
"""


@needs_numba
def test_the_same_source_runs_interpreted(tmp_path):
    """NUMBA_DISABLE_JIT=1: the compiled route's Python text runs as Python (for debugging),
    with the reference pass's results."""
    r = _python(TINY, {"NUMBA_DISABLE_JIT": "1", "PLANARKIN_CACHE": str(tmp_path / "c")})
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout.strip().splitlines()[-1])
    assert got["jitted"] is False
    assert got["solve"] <= 1e-15 and got["rows"] <= 1e-15 and got["iters"]
    assert got["layout"]


def test_small_jobs_do_not_import_numba():
    """A small run (the four-bar's 360 steps, CLI and API) stays on the numpy passes and never
    imports numba: its start-up would cost more than the whole run."""
    code = """
import sys
from click.testing import CliRunner
import planarkin
from planarkin.cli import main
import tempfile
with tempfile.TemporaryDirectory() as d:
    r = CliRunner().invoke(main, ["run", "mechanisms/four-bar.yaml", "--no-plots", "--out", d])
    assert r.exit_code == 0, r.output
res = planarkin.solve(planarkin.load("mechanisms/four-bar.yaml"), steps=2000)
assert res.status == 0
print("numba" in sys.modules, "planarkin.solver.compiled.kernels" in sys.modules)
"""
    r = _python(code)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split() == ["False", "False"]


@needs_numba
def test_each_entry_point_is_compiled_once(monkeypatch):
    """The wrappers give every entry point the types of its one signature (a read-only or
    int32 array would compile it again, silently, and its cache file would not be vouched
    for)."""
    from planarkin.solver.compiled import kernels as compiled_grid
    lib = kernel.library().need("points").need("study")
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 100)
    # (two structures: the signature is the entry point's, whatever the structure; each
    # structure's first compile costs seconds of a cold suite)
    for name in ("four-bar", "slider-crank"):
        assert planarkin.solve(planarkin.load(ROOT / "mechanisms" / f"{name}.yaml"),
                               steps=150).status == 0
    for name in ("layout", "cubic"):
        assert len(getattr(lib, name).signatures) == 1, name
    # and the kernels generated for the two structures
    assert len(compiled_grid._fns) >= 2
    for fn in compiled_grid._fns.values():
        assert len(getattr(fn, "signatures", [None])) == 1


def test_the_route_is_chosen_by_the_jobs_size(monkeypatch):
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    m = planarkin.load(FOUR_BAR)
    n = kernel.COMPILED_FROM_POINTS
    small = prepare(m, resolve(m, {"steps": n - 2}, source="api"))
    assert small.compiled is None
    large = prepare(m, resolve(m, {"steps": n - 1}, source="api"))
    # and the installed packages: where numba is missing, the numpy passes at any size
    assert large.compiled is kernel.library() and (large.compiled is not None) == HAVE_NUMBA
    monkeypatch.setenv("PLANARKIN_KERNEL", "0")
    assert prepare(m, resolve(m, {"steps": n}, source="api")).compiled is None


def test_large_solves_of_one_structure_add_up_to_the_compiled_route(monkeypatch):
    """A session that solves one mechanism again and again (planarkin.solve in a notebook, a
    script's loop) takes the compiled route once its solves of at least ADDS_UP_FROM points add
    up to COMPILED_FROM_POINTS; smaller solves never count, another structure counts apart,
    other jobs (a command's run, a study's variant, a design's analysis) take their route by
    their own size, and the results agree across the switch to 1e-15 of each column's largest
    value (the routes' rule)."""
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 3000)
    monkeypatch.setattr(kernel, "ADDS_UP_FROM", 1000)
    four, slider = planarkin.load(FOUR_BAR), planarkin.load("mechanisms/slider-crank.yaml")

    def route(m, steps, session=True):
        return prepare(m, resolve(m, {"steps": steps}, source="api"), session=session).compiled

    assert all(route(four, 998) is None for _ in range(10))       # 999 rows: never counted
    assert route(four, 1499) is None                               # 1,500
    assert route(slider, 1499) is None                             # another structure
    assert (route(four, 1499) is not None) == HAVE_NUMBA           # 3,000 together
    assert (route(four, 999) is not None) == HAVE_NUMBA            # from then on
    assert route(four, 998) is None
    assert route(four, 1499, session=False) is None               # not a session's solve
    kernel._state["points"].clear()
    first = planarkin.solve(four, steps=1999)                      # 2,000: numpy
    again = planarkin.solve(four, steps=1999)                      # 4,000: compiled
    assert (first.iterations == again.iterations).all()
    for a, b in ((first.q, again.q), (first.qd, again.qd), (first.qdd, again.qdd)):
        scale = np.abs(a).max(axis=0)
        assert (np.abs(a - b).max(axis=0) <= 1e-15 * np.where(scale > 0, scale, 1.0)).all()


def test_without_numba_the_numpy_passes_run_and_say_so_once(monkeypatch, capsys):
    """numba that cannot be imported: the numpy route runs (the same results to rounding) and
    one line on stderr says so, once per process."""
    monkeypatch.setattr(kernel, "_state", {})
    monkeypatch.setitem(sys.modules, "numba", None)        # import numba raises ImportError
    monkeypatch.setattr(kernel, "COMPILED_FROM_POINTS", 100)
    m = planarkin.load(FOUR_BAR)
    a = planarkin.solve(m, steps=200)
    b = planarkin.solve(m, steps=300)
    err = capsys.readouterr().err
    assert err.count("planarkin: numba cannot be imported") == 1, err
    assert "the numpy route runs" in err
    assert a.status == 0 and b.status == 0
    monkeypatch.setenv("PLANARKIN_KERNEL", "0")
    ref = planarkin.solve(m, steps=200)
    for x, y in ((a.q, ref.q), (a.qd, ref.qd), (a.qdd, ref.qdd)):
        assert np.array_equal(x, y)


# -- the cache ---------------------------------------------------------

@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """jitcache as in a new process, its directory under tmp_path."""
    saved = jitcache.prepare()
    jitcache.record()
    jitcache.forget()
    monkeypatch.setenv("PLANARKIN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", os.environ.get("NUMBA_CACHE_DIR", ""))
    yield tmp_path / "cache"
    jitcache.forget()
    monkeypatch.undo()
    again = jitcache.prepare()
    # this process's numba keeps its directory; where the setup found the cache's lock held
    # longer than jitcache.LOCK_WAIT (another worker compiling) it had none, and may now
    assert saved is None or again == saved
    jitcache.record()


def test_the_cache_directory_is_made_private(fresh):
    entry = jitcache.prepare()
    jitcache.record()
    assert entry == fresh / jitcache.tag() and os.environ["NUMBA_CACHE_DIR"] == str(entry)
    for d in (fresh, entry):
        assert d.stat().st_mode & 0o777 == 0o700


@pytest.mark.parametrize("damage", ["group-writable", "world-writable", "a link"])
def test_a_cache_directory_others_can_write_is_not_used(fresh, tmp_path, damage, monkeypatch,
                                                        capsys):
    """...and one line says so (every run would otherwise just be slow: each kernel compiled
    again), once per process."""
    monkeypatch.setattr(jitcache, "_said", set())
    if damage == "a link":
        real = tmp_path / "elsewhere"
        real.mkdir(mode=0o700)
        fresh.symlink_to(real)
    else:
        fresh.mkdir(mode=0o700)
        fresh.chmod(0o770 if damage == "group-writable" else 0o707)
    assert jitcache.prepare() is None
    jitcache.forget()
    assert jitcache.prepare() is None
    assert capsys.readouterr().err == (
        f"planarkin: the compiled code's cache {fresh} is not a private folder (a link, another "
        f"user's, or writable by group or others): compiling without it (the results are the "
        f"same; chmod 700 it, or set PLANARKIN_CACHE to another folder)\n")


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="needs root to chown")
def test_a_cache_directory_of_another_user_is_not_used(fresh):
    fresh.mkdir(mode=0o700)
    os.chown(fresh, 12345, 12345)
    assert jitcache.prepare() is None


def test_files_the_manifest_does_not_vouch_for_are_deleted(fresh):
    entry = jitcache.prepare()
    (entry / "sub").mkdir()
    good = entry / "sub" / "f.nbi"
    good.write_bytes(b"numba's")
    jitcache.record()
    assert json.loads((entry / jitcache.MANIFEST).read_text()) == {
        "sub/f.nbi": hashlib.sha256(b"numba's").hexdigest()}
    (entry / "sub" / "planted.nbc").write_bytes(b"x")
    bad = entry / "sub" / "g.nbc"
    bad.write_bytes(b"y")
    jitcache.forget()
    assert jitcache.prepare() == entry
    assert [p.name for p in (entry / "sub").iterdir()] == ["f.nbi"]
    good.write_bytes(b"numba'")                            # truncated
    jitcache.record()
    jitcache.forget()
    (entry / jitcache.MANIFEST).write_text("{garbled")
    jitcache.prepare()
    assert not good.exists()


RUN = """
import sys, numpy as np, planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 100
r = planarkin.solve(planarkin.load("mechanisms/four-bar.yaml"), steps=400)
assert r.status == 0
np.save(%r, np.concatenate([r.q, r.qd, r.qdd], axis=1))
"""


@needs_numba
def test_a_damaged_cache_entry_is_compiled_again_with_the_same_results(tmp_path):
    """A warm cache (a clean run in a process of its own: this process's functions may have
    been compiled under another test's cache directory), then a data file truncated, an index
    garbled and a foreign file planted: a new process detects them, compiles those functions
    again and gives the clean run's results; the manifest then vouches for the new files."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    warm_out = tmp_path / "clean.npy"
    r = _python("from planarkin.solver.compiled import kernel\n"
                "kernel.library().need('study')\n" + RUN % str(warm_out),
                {"PLANARKIN_CACHE": str(cache)})
    assert r.returncode == 0, r.stderr
    entry = cache / jitcache.tag()
    files = sorted(p for p in entry.rglob("*") if p.is_file() and p.suffix in (".nbi", ".nbc"))
    layout = [p for p in files if ".layout-" in p.name and p.suffix == ".nbc"]
    cubic = [p for p in files if ".cubic-" in p.name and p.suffix == ".nbi"]
    assert layout and cubic
    data = layout[0].read_bytes()
    layout[0].write_bytes(data[:len(data) // 2])           # truncated
    h = bytearray(cubic[0].read_bytes())
    h[len(h) // 2:] = b"\x00" * (len(h) - len(h) // 2)     # garbled
    cubic[0].write_bytes(bytes(h))
    planted = layout[0].parent / "compiled_points.foreign-1.py311.9.nbc"
    planted.write_bytes(b"not numba's")
    out = tmp_path / "damaged.npy"
    r = _python(RUN % str(out), {"PLANARKIN_CACHE": str(cache)})
    assert r.returncode == 0, r.stderr
    assert not planted.exists()
    manifest = json.loads((entry / jitcache.MANIFEST).read_text())
    assert all(hashlib.sha256((entry / f).read_bytes()).hexdigest() == d
               for f, d in manifest.items())
    # the truncated entry is gone (numba may write its rebuild under another index number)
    assert not any(p.read_bytes() == data[:len(data) // 2] for p in entry.rglob("*.nbc"))
    assert np.array_equal(np.load(out), np.load(warm_out))


@needs_numba
def test_each_compiled_kind_states_its_code_and_parameters():
    """The kinds the compiled route compiles say so themselves (Kind.compiled_code and
    compiled_params, issue 17): each code once, a function of planarkin.elements.pointline for it,
    parameters the kind has, in the 2-vector slots kernel.pack fills; a subclass that does not
    state its own is not compiled."""
    from planarkin.elements import pointline
    from planarkin.elements import KINDS
    coded = {name: kernel.compiled_kind(k) for name, k in KINDS.items()
             if kernel.compiled_kind(k) is not None}
    assert sorted(coded) == ["angle", "distance", "pin-slot", "revolute", "slide",
                             "translational", "x", "y"]
    codes = [c for c, _ in coded.values()]
    assert len(set(codes)) == len(codes) and set(codes) <= set(pointline.CODES)
    for name, (code, params) in coded.items():
        # the function the compiled route compiles is the one the numpy kind broadcasts
        assert pointline.CODES[code] == KINDS[name].equation, name
        assert set(params) <= {"si", "sj", "vi", "vj"}, name
        assert set(params) <= {p.name for p in KINDS[name].params}, name

    class Child(type(KINDS["revolute"])):
        pass
    assert kernel.compiled_kind(Child()) is None
