"""What jerk costs: `planarkin.solve` of the slider-crank with up_to: acceleration against up_to:
jerk, in one run (rounds alternate, best of each), and optionally the same acceleration run of a
baseline checkout (--baseline DIR: e.g. `git archive main | tar -x -C DIR`), to show that runs not
asking for jerk did not get slower.

    python benchmarks/bench_jerk.py [--steps 200000] [--rounds 5] [--baseline DIR]

Each timing is one `planarkin.solve` in a fresh worker process importing the checkout named (a
warm-up solve first, so imports and first-call costs are left out; one BLAS thread); the worker
prints its wall and CPU seconds. On a shared machine the CPU time is the figure to compare: wall
time there is mostly time spent waiting for a core.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import common
import models

WORKER = r"""
import json, sys, time
import planarkin
steps, up_to, path = int(sys.argv[1]), sys.argv[2], sys.argv[3]
m = planarkin.load(path)
planarkin.solve(m, steps=200, up_to=up_to)
t0, c0 = time.perf_counter(), time.process_time()
r = planarkin.solve(m, steps=steps, up_to=up_to)
dt, dc = time.perf_counter() - t0, time.process_time() - c0
assert r.status == 0, r.message
print(json.dumps({"seconds": dt, "cpu": dc, "rows": len(r.t)}))
"""


def timed(checkout: Path, steps: int, up_to: str, model: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of one solve."""
    env = dict(os.environ, PYTHONPATH=str(checkout), OPENBLAS_NUM_THREADS="1")
    p = subprocess.run([sys.executable, "-c", WORKER, str(steps), up_to, str(model)],
                       capture_output=True, text=True, env=env, cwd=str(checkout), timeout=3600)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    out = json.loads(p.stdout.strip().splitlines()[-1])
    return out["seconds"], out["cpu"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--baseline", metavar="DIR", help="a checkout to time up_to: acceleration of")
    a = ap.parse_args(argv)
    info = common.machine_info()
    common.print_header(info, "planarkin jerk cost (slider-crank)")
    model = Path("/tmp") / f"bench-jerk-slider-crank-{os.getpid()}.yaml"
    model.write_text(models.slider_crank_yaml())
    cases = [("this checkout, up_to: acceleration", common.ROOT, "acceleration"),
             ("this checkout, up_to: jerk", common.ROOT, "jerk")]
    if a.baseline:
        cases.insert(0, ("baseline, up_to: acceleration", Path(a.baseline).resolve(),
                         "acceleration"))
    wall = {c[0]: float("inf") for c in cases}
    cpu = dict(wall)
    try:
        for _ in range(a.rounds):
            for name, checkout, up_to in cases:
                w, c = timed(checkout, a.steps, up_to, model)
                wall[name], cpu[name] = min(wall[name], w), min(cpu[name], c)
    finally:
        model.unlink(missing_ok=True)
    print(f"\n{a.steps} steps, best of {a.rounds} alternating rounds (ratios to this checkout's "
          f"acceleration run):")
    ref = "this checkout, up_to: acceleration"
    for name, _, _ in cases:
        print(f"  {name:38s} CPU {cpu[name]:7.3f} s  ratio {cpu[name] / cpu[ref]:.3f}   "
              f"wall {wall[name]:7.3f} s  ratio {wall[name] / wall[ref]:.3f}")
    la = os.getloadavg()
    print(f"load avg   {la[0]:.2f} {la[1]:.2f} {la[2]:.2f} at end")


if __name__ == "__main__":
    main()
