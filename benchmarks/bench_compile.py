"""What a new mechanism structure costs on the compiled route, for two source trees alternating.

    python benchmarks/bench_compile.py OLD_TREE NEW_TREE [--rounds 5]
        [--models four-bar,slider-crank,six-bar,jansen-leg] [--steps 200000]

OLD_TREE and NEW_TREE are checkouts of planarkin (`git worktree add /tmp/old <commit>`). Each
round, for each model and each tree in turn (the tree that goes first alternates), fresh
processes with that tree first on the path and the compiled route's threshold at 0:

* first: an empty cache directory; CPU seconds of the call that compiles the structure's grid
  kernel (and the fixed functions of the route), `planarkin.solve(model, steps=240)`;
* run: the same directory again in a new process (the kernel loaded), the median CPU seconds
  of 5 calls of `planarkin.solve(model, steps=STEPS)` after one untimed call: what the
  compiled code costs to run;
* a hash of q, qd, qdd and the iteration counts of the last call: the trees agree bit for bit
  when their hashes are equal.

Printed per model and tree: medians of the rounds with the spread (min-max), the ratio
NEW / OLD of the medians, and the load average before and after.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

FIRST = """
import sys, time
import planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
m = planarkin.load(sys.argv[1])
t = time.process_time()
r = planarkin.solve(m, steps=240)
print(time.process_time() - t)
"""

RUN = """
import hashlib, statistics, sys, time
import planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
m = planarkin.load(sys.argv[1])
planarkin.solve(m, steps=1000)
ts = []
for _ in range(5):
    t = time.process_time()
    r = planarkin.solve(m, steps=int(sys.argv[2]))
    ts.append(time.process_time() - t)
h = hashlib.sha256(r.q.tobytes() + r.qd.tobytes() + r.qdd.tobytes() + r.iterations.tobytes())
print(statistics.median(ts), h.hexdigest()[:12])
"""


def _python(tree: Path, code: str, cache: str, *args) -> list[str]:
    env = dict(os.environ, PYTHONPATH=str(tree), PLANARKIN_CACHE=cache,
               OPENBLAS_NUM_THREADS="1", PYTHONWARNINGS="ignore")
    r = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True,
                       text=True, env=env, cwd=str(tree), check=True)
    return r.stdout.split()


def _spread(xs: list[float]) -> str:
    return f"{statistics.median(xs):.3f} ({min(xs):.3f}-{max(xs):.3f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--models", default="four-bar,slider-crank,six-bar,jansen-leg")
    ap.add_argument("--steps", type=int, default=200_000)
    a = ap.parse_args()
    trees = {"old": a.old.resolve(), "new": a.new.resolve()}
    first = {(m, s): [] for m in a.models.split(",") for s in trees}
    run = {k: [] for k in first}
    hashes = {k: set() for k in first}
    print("load average at start:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    for r in range(a.rounds):
        for i, model in enumerate(a.models.split(",")):
            order = ("old", "new") if (r + i) % 2 == 0 else ("new", "old")
            for side in order:
                tree = trees[side]
                path = tree / "mechanisms" / f"{model}.yaml"
                with tempfile.TemporaryDirectory() as cache:
                    os.chmod(cache, 0o700)
                    first[model, side].append(float(_python(tree, FIRST, cache, path)[0]))
                    t, h = _python(tree, RUN, cache, path, a.steps)
                run[model, side].append(float(t))
                hashes[model, side].add(h)
        print(f"round {r + 1} done, load {os.getloadavg()[0]:.2f}", flush=True)
    print("load average at end:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"| model | first solve, old (CPU s) | new | new / old | {a.steps} steps, old | new "
          f"| new / old | same bits |")
    print("|---|---|---|---|---|---|---|---|")
    for model in a.models.split(","):
        fo, fn = first[model, "old"], first[model, "new"]
        ro, rn = run[model, "old"], run[model, "new"]
        same = hashes[model, "old"] == hashes[model, "new"] and len(hashes[model, "old"]) == 1
        print(f"| {model} | {_spread(fo)} | {_spread(fn)} | "
              f"{statistics.median(fn) / statistics.median(fo):.2f}x | {_spread(ro)} | "
              f"{_spread(rn)} | {statistics.median(rn) / statistics.median(ro):.2f}x | "
              f"{'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
