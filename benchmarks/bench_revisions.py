"""This tree against an earlier commit of it, on what a user runs, sides alternating in one run.

    python benchmarks/bench_revisions.py --base COMMIT [--rounds 5]
                                         [--parts numpy,compiled,kernel,cold]

A change that should not cost speed (a refactor: the element equations written once for both
routes) is measured here against the commit before it, checked out with `git worktree` into a
temporary directory. Every measurement is a fresh process per side (PYTHONPATH the side's tree),
the sides alternating within each round (which goes first alternates too); printed per part the
median over --rounds rounds with the spread (min-max), the ratio this tree / base of the medians,
and the load average before and after.

* numpy: CPU seconds of `planarkin.solve` on five examples at their own grids plus the four-bar
  at 20,000 steps, the default route (numpy), after one warm-up pass (the fixed cost users pay
  on small runs).
* compiled: CPU us per step of `planarkin.solve` at 200,000 steps, P + V + A, the compiled route
  forced, four-bar and slider-crank, each side on a warm cache of its own (median of 3 calls
  in the process).
* kernel: the same solves, CPU us per step of the generated grid kernel's calls alone
  (planarkin.solver.compiled.kernel.solve, timed around each call).
* cold: CPU seconds of the first compiled solve of the four-bar (2,000 steps) on an empty cache
  (numba's compile of the layout and of the structure's generated kernel), then of the six-bar
  and the Jansen leg in the same process (their generated kernels alone: a new structure), with
  a hash of each solve's q, qd, qdd and iteration counts (equal hashes: the same bits).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from common import machine_info, print_header

ROOT = Path(__file__).resolve().parent.parent

PROBES = {
    "numpy": """
import json, time, planarkin
ms = ["mechanisms/four-bar.yaml", "mechanisms/jansen-leg.yaml", "mechanisms/six-bar.yaml",
      "mechanisms/slider-crank.yaml", "mechanisms/quick-return.yaml"]
def run():
    for m in ms:
        planarkin.solve(m)
    planarkin.solve("mechanisms/four-bar.yaml", steps=20000)
run()
t = time.process_time(); run()
print(json.dumps({"numpy s": time.process_time() - t}))
""",
    "compiled": """
import json, statistics, time, planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
out = {}
for m in ("four-bar", "slider-crank"):
    planarkin.solve(f"mechanisms/{m}.yaml", steps=2000)
    ts = []
    for _ in range(3):
        t = time.process_time(); planarkin.solve(f"mechanisms/{m}.yaml", steps=200000)
        ts.append(time.process_time() - t)
    out[f"{m} us/step"] = statistics.median(ts) / 200000 * 1e6
print(json.dumps(out))
""",
    "kernel": """
import json, statistics, time, planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
orig, spent = kernel.solve, [0.0]
def timed(*a, **k):
    t = time.process_time()
    r = orig(*a, **k)
    spent[0] += time.process_time() - t
    return r
kernel.solve = timed
out = {}
for m in ("four-bar", "slider-crank"):
    planarkin.solve(f"mechanisms/{m}.yaml", steps=2000)
    ts = []
    for _ in range(3):
        spent[0] = 0.0
        planarkin.solve(f"mechanisms/{m}.yaml", steps=200000)
        ts.append(spent[0])
    out[f"{m} kernel us/step"] = statistics.median(ts) / 200000 * 1e6
print(json.dumps(out))
""",
    "cold": """
import hashlib, json, time, planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
out = {}
for i, m in enumerate(("four-bar", "six-bar", "jansen-leg")):
    t = time.process_time(); r = planarkin.solve(f"mechanisms/{m}.yaml", steps=2000)
    key = f"{m} first compile s" if i == 0 else f"{m} new structure s"
    out[key] = time.process_time() - t
    h = hashlib.sha256(r.q.tobytes() + r.qd.tobytes() + r.qdd.tobytes() + r.iterations.tobytes())
    out[f"{m} result hash"] = int(h.hexdigest()[:12], 16)
print(json.dumps(out))
""",
}


def median_spread(xs: list) -> tuple:
    xs = sorted(xs)
    n = len(xs)
    med = xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])
    return med, f"{xs[0]:.4g}-{xs[-1]:.4g}"


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def probe(tree: Path, part: str, cache: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), PLANARKIN_CACHE=str(cache),
               PYTHONDONTWRITEBYTECODE="1")
    r = subprocess.run([sys.executable, "-c", PROBES[part]], cwd=tree, env=env,
                       capture_output=True, text=True, timeout=1800)
    if r.returncode != 0:
        raise SystemExit(f"{tree} {part}: {r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", required=True, help="the earlier commit")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--parts", default="numpy,compiled,kernel,cold")
    a = ap.parse_args()
    parts = a.parts.split(",")
    work = Path(tempfile.mkdtemp(prefix="pk-revisions-"))
    base = work / "base"
    subprocess.run(["git", "worktree", "add", "--detach", "-q", str(base), a.base], cwd=ROOT,
                   check=True)
    sides = {"base": base, "this": ROOT}
    caches = {s: work / f"cache-{s}" for s in sides}
    try:
        print_header(machine_info(), "bench_revisions: this tree against an earlier commit")
        print(f"base {a.base}; load before {load()}")
        results: dict = {}
        for r in range(a.rounds):
            order = list(sides) if r % 2 == 0 else list(sides)[::-1]
            for part in parts:
                for side in order:
                    cache = caches[side]
                    if part == "cold":
                        cache = work / f"cold-{side}-{r}"
                    for k, v in probe(sides[side], part, cache).items():
                        results.setdefault((k, side), []).append(v)
                    if part == "cold":
                        shutil.rmtree(cache, ignore_errors=True)
        print(f"load after {load()}; medians of {a.rounds} rounds (min-max)")
        for k in dict.fromkeys(k for k, _ in results):
            b, t = results[(k, "base")], results[(k, "this")]
            (mb, sb), (mt, st) = median_spread(b), median_spread(t)
            if k.endswith("hash"):
                same = set(b) == set(t) and len(set(b)) == 1
                print(f"{k:28s} {'the same bits' if same else 'DIFFERENT'}")
                continue
            print(f"{k:28s} base {mb:.4g} ({sb})  this {mt:.4g} ({st})  this/base {mt / mb:.3f}")
    finally:
        subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT)
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
