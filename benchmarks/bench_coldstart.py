"""The first run on a fresh machine against a warm one: the compiled route's start-up.

    python benchmarks/bench_coldstart.py [--rounds 5] [--steps 200000] [--model four-bar]

Each round, in fresh processes (`planarkin.solve` of mechanisms/<model>.yaml, --steps, the
compiled route's threshold lowered to 0 so that the route is taken at any size):

* cold: an empty cache directory (PLANARKIN_CACHE pointed at a new temporary directory): numba
  compiles the generated kernel of the structure and the predictions and layout;
* warm: the same directory again (numba loads what the cold run compiled);
* numpy: PLANARKIN_KERNEL=0 (no numba at all).

Sides alternate within a round; printed are the medians with the spread (min-max) of the
rounds, wall and CPU time of each process (the CPU time is what a busy machine inflates
least), the cold - warm difference (the target: at most 1.5 s) and the load average.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

RUN = """
import sys, time
t0 = time.perf_counter()
import planarkin
from planarkin.solver.compiled import kernel
kernel.COMPILED_FROM_POINTS = 0
r = planarkin.solve(planarkin.load(sys.argv[1]), steps=int(sys.argv[2]))
assert r.status == 0, r.message
print(time.perf_counter() - t0, time.process_time())
"""


def one(model, steps, env):
    e = dict(os.environ, PYTHONPATH=str(ROOT), **env)
    out = subprocess.run([sys.executable, "-c", RUN, str(model), str(steps)],
                         capture_output=True, text=True, env=e, cwd=str(ROOT), check=True)
    wall, cpu = out.stdout.split()[-2:]
    return float(wall), float(cpu)


def median(xs):
    xs = sorted(xs)
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--model", default="four-bar")
    a = ap.parse_args(argv)
    model = ROOT / "mechanisms" / f"{a.model}.yaml"
    print("load avg at start", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    got = {"cold": [], "warm": [], "numpy": []}
    cpu = {"cold": [], "warm": [], "numpy": []}
    for r in range(a.rounds):
        with tempfile.TemporaryDirectory() as d:
            env = {"PLANARKIN_CACHE": str(Path(d) / "cache")}
            sides = [("cold", env), ("warm", env), ("numpy", {"PLANARKIN_KERNEL": "0"})]
            if r % 2:                      # alternate the numpy side with the compiled pair
                sides = sides[2:] + sides[:2]
            for name, e in sides:
                w, c = one(model, a.steps, e)
                got[name].append(w)
                cpu[name].append(c)
        print(f"round {r + 1}: " + "  ".join(f"{k} {v[-1]:.2f} s (CPU {cpu[k][-1]:.2f})"
                                            for k, v in got.items()), flush=True)
    print(f"== {a.model}, {a.steps} steps, planarkin.solve in a fresh process ==")
    for k, v in got.items():
        print(f"  {k:6s} wall {median(v):6.2f} s ({min(v):.2f}-{max(v):.2f})   CPU "
              f"{median(cpu[k]):6.2f} s ({min(cpu[k]):.2f}-{max(cpu[k]):.2f})")
    for what, d in (("wall", got), ("CPU", cpu)):
        diff = [c - w for c, w in zip(d["cold"], d["warm"])]
        print(f"  cold - warm, {what:4s} {median(diff):6.2f} s ({min(diff):.2f}-{max(diff):.2f})"
              f"   target <= 1.5")
    print("load avg at end", " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
