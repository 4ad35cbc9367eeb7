"""Short runs against a baseline checkout, in one run: `planarkin.solve(model)` of example models
at their own step count (360 for the four-bar), this checkout and --baseline DIR alternating.

    python benchmarks/bench_short.py --baseline DIR [--rounds 7] [--calls 20] [--models a.yaml ...]

DIR is another checkout (e.g. `git archive main | tar -x -C DIR`). Each checkout runs in a worker
process of its own (`PYTHONPATH` = the checkout), which loads the models once and makes one
warm-up call each (that compiles the kernel of its source version into the cache if missing);
then, round by round, the parent lets each worker in turn time --calls calls of every model.
Printed per model: the median round's CPU and wall time per call for both, with the spread of
the rounds (min-max), and the ratio of the medians this checkout / baseline (the issue's rule: a 360-step run must not get slower). The workers run
OpenBLAS on one thread, as `planarkin run` does, unless OPENBLAS_NUM_THREADS is set.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

WORKER = r"""
import json, sys, time
import planarkin
paths, calls = json.loads(sys.argv[1]), int(sys.argv[2])
models = [planarkin.load(p) for p in paths]
for m in models:
    assert planarkin.solve(m).success
print(json.dumps({"planarkin": planarkin.__file__}), flush=True)
for line in sys.stdin:
    out = []
    for m in models:
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(calls):
            planarkin.solve(m)
        out.append([(time.process_time() - c0) / calls, (time.perf_counter() - t0) / calls])
    print(json.dumps(out), flush=True)
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", metavar="DIR", required=True)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--models", nargs="*",
                    default=["mechanisms/four-bar.yaml", "mechanisms/slider-crank.yaml"])
    a = ap.parse_args(argv)
    import common
    info = common.machine_info()
    common.print_header(info, "short runs: this checkout against a baseline checkout")
    root = HERE.parent
    paths = [str((root / p).resolve()) for p in a.models]
    trees = {"this": root, "baseline": Path(a.baseline).resolve()}
    workers = {}
    for name, tree in trees.items():
        # OpenBLAS on one thread, as the command sets it (planarkin/__main__.py): its idle
        # threads' spinning counts as the process's CPU time and scattered the figures
        # by +-25% between runs
        env = dict(os.environ, PYTHONPATH=str(tree))
        env.setdefault("OPENBLAS_NUM_THREADS", "1")
        w = subprocess.Popen([sys.executable, "-c", WORKER, json.dumps(paths), str(a.calls)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
                             cwd=str(tree))
        first = json.loads(w.stdout.readline())
        print(f"{name:9s}  {first['planarkin']}")
        workers[name] = w
    rounds = {name: [[[], []] for _ in paths] for name in trees}
    for _ in range(a.rounds):
        for name, w in workers.items():
            w.stdin.write("go\n")
            w.stdin.flush()
            for k, (cpu, wall) in enumerate(json.loads(w.stdout.readline())):
                rounds[name][k][0].append(cpu)
                rounds[name][k][1].append(wall)
    for w in workers.values():
        w.stdin.close()
        w.wait()
    print(f"\nmedian [min-max] of {a.rounds} rounds of {a.calls} calls, per call, ms "
          f"(baseline -> this):")
    med = statistics.median
    for k, p in enumerate(a.models):
        parts = []
        for j, what in enumerate(("CPU", "wall")):
            b, t = rounds["baseline"][k][j], rounds["this"][k][j]
            parts.append(f"{what} {med(b) * 1e3:6.2f} [{min(b) * 1e3:.2f}-{max(b) * 1e3:.2f}] -> "
                         f"{med(t) * 1e3:6.2f} [{min(t) * 1e3:.2f}-{max(t) * 1e3:.2f}] "
                         f"({med(t) / med(b):4.2f} x)")
        print(f"  {p:30s} " + "   ".join(parts))
    la = os.getloadavg()
    print(f"load avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}")


if __name__ == "__main__":
    main()
