"""What `synth --jobs 2` gains on two cores: the straight line (mechanisms/synthesis/
straight-line.yaml) searched with jobs=1 and jobs=2 for each seed, the two sides alternating
(which goes first alternates too), wall time of each search in this process (the workers' CPU
is not this process's), and a check that both give the same result (designs, evaluations,
runs). Prints per seed the walls and their ratio, then the median ratio with its range and the
load average before and after.

    python benchmarks/bench_synth_jobs.py [--seeds 1,2,3,4,5] [--model FILE]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from common import ROOT  # noqa: F401 (puts the checkout first on sys.path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="1,2,3,4,5")
    ap.add_argument("--model", default=str(ROOT / "mechanisms" / "synthesis" /
                                          "straight-line.yaml"))
    a = ap.parse_args()
    from planarkin.synthesis.synth import synthesize
    seeds = [int(s) for s in a.seeds.split(",")]
    print(f"load average {os.getloadavg()[0]:.2f} at the start")
    print("| seed | jobs 1 wall [s] | jobs 2 wall [s] | jobs 2 / jobs 1 | same result |")
    print("|---|---|---|---|---|")
    ratios = []
    for k, seed in enumerate(seeds):
        wall, res = {}, {}
        for jobs in ((1, 2) if k % 2 == 0 else (2, 1)):
            t0 = time.perf_counter()
            res[jobs] = synthesize(a.model, seed=seed, jobs=jobs)
            wall[jobs] = time.perf_counter() - t0
        r1, r2 = res[1], res[2]
        same = (r1.evaluations, r1.analyses, r1.jacobians, r1.runs, r1.message) == \
            (r2.evaluations, r2.analyses, r2.jacobians, r2.runs, r2.message) and all(
                np.array_equal(d.x, e.x) and d.cost == e.cost
                for d, e in zip(r1.designs, r2.designs))
        ratios.append(wall[2] / wall[1])
        print(f"| {seed} | {wall[1]:.2f} | {wall[2]:.2f} | {ratios[-1]:.3f} | "
              f"{'yes' if same else 'NO'} |", flush=True)
    print(f"jobs 2 / jobs 1 wall: median {statistics.median(ratios):.3f} (range "
          f"{min(ratios):.3f}-{max(ratios):.3f}) over {len(seeds)} seeds")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
