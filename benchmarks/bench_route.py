"""Where the compiled route pays: the threshold kernel.COMPILED_FROM_POINTS, and its cost per
point against the numpy passes.

    python benchmarks/bench_route.py [--rounds 5] [--steps 20000,100000,200000,500000]
    python benchmarks/bench_route.py --micro        # one grid solve call, us per point

Default: `planarkin run`'s analysis in a fresh process per round (`planarkin.solve`, the
four-bar, --steps each), the numpy passes (PLANARKIN_KERNEL=0) against the compiled route
(the threshold lowered to 0, so that it is taken at every size; numba's import and cache load
included, as a real run pays them), sides alternating, median of --rounds with min-max and the
load. The compiled route pays from the step count where its median falls below numpy's.

--micro: kernel.solve (planarkin/compiled.py) on 8192 points of the four-bar and the
slider-crank, 1e-7 off the solution, in process (compiled beforehand), median of 7 calls.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

RUN = """
import sys, time
t0 = time.perf_counter()
import planarkin
from planarkin.solver.compiled import kernel
if sys.argv[2] == "compiled":
    kernel.COMPILED_FROM_POINTS = 0
m = planarkin.load("mechanisms/four-bar.yaml")
r = planarkin.solve(m, steps=int(sys.argv[1]))
assert r.status == 0
print(time.perf_counter() - t0)
"""


def one(steps, route):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if route == "numpy":
        env["PLANARKIN_KERNEL"] = "0"
    out = subprocess.run([sys.executable, "-c", RUN, str(steps), route], capture_output=True,
                         text=True, env=env, cwd=str(ROOT), check=True)
    return float(out.stdout.split()[-1])


def median(xs):
    xs = sorted(xs)
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def micro():
    sys.path.insert(0, str(ROOT))
    import numpy as np

    import planarkin
    from planarkin.solver.compiled import kernel
    from planarkin.options import resolve
    from planarkin.analysis import prepare
    lib = kernel.library().need("points")
    for name in ("four-bar", "slider-crank"):
        m = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
        an = prepare(m, resolve(m, {"steps": 100}, source="api"))
        S = an.follower.systems[0][0]
        N = 8192
        t = np.linspace(0.0, 1.0, N)
        Q0 = S.ext(an._dense(t).q / np.tile([m.L, m.L, 1.0 / m.angle_factor], m.nb))
        Q0 += 1e-7 * np.sin(np.arange(Q0.size).reshape(Q0.shape))
        Q0[:, S.n:] = 0
        drv = S.driver_values(t)
        P = kernel.pack(S)
        ts = []
        for _ in range(7):
            X = [Q0.copy(), np.zeros_like(Q0), np.zeros_like(Q0)]
            t0 = time.perf_counter()
            kernel.solve(lib, S, P, *X, *drv, "reuse", 1e-10, 8, 2)
            ts.append((time.perf_counter() - t0) / N * 1e6)
        print(f"{name}: kernel.solve {median(ts):.3f} us/point ({min(ts):.3f}-{max(ts):.3f})")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--steps", default="20000,100000,200000,500000")
    ap.add_argument("--micro", action="store_true")
    a = ap.parse_args(argv)
    print("load avg", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    if a.micro:
        micro()
    else:
        one(1000, "compiled")             # the cache warm (compiled once per machine)
        for steps in (int(s) for s in a.steps.split(",")):
            got = {"numpy": [], "compiled": []}
            for _ in range(a.rounds):
                for route in got:
                    got[route].append(one(steps, route))
            print(f"{steps:>8} steps: " + "   ".join(
                f"{r} {median(v):.3f} s ({min(v):.3f}-{max(v):.3f})" for r, v in got.items()),
                flush=True)
    print("load avg", " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
