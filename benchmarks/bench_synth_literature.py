"""Classic path-synthesis problems of the optimisation literature, as planarkin states them.

five-point-curve (mechanisms/synthesis/five-point-curve.yaml)
    targets: the coupler point through (3, 3), (2.759, 3.363), (2.372, 3.663), (1.890, 3.862),
             (1.355, 3.943) (length unit: mm here; the problem is scale-free)
    timing:  prescribed, crank angles 30, 45, 60, 75, 90 deg measured from the ground line
    unknowns: x0, y0 (ground pivot A), th0 (ground line), a, b, c, d (crank, coupler, rocker,
             ground), px, py (coupler point in the coupler frame): 9; 10 equations
    bounds:  this file's: |x0|, |y0|, |px|, |py| <= 10, lengths 0.2 .. 10, th0 free (periodic)
    constraint set: the crank turns fully (Grashof with crank or ground shortest); branch: the
             open assembly at t = 0 (the coupler-rocker pin left of the line B-D), kept over the
             cycle
    error norm: sum of squared distances between targets and achieved points (mm^2)
    source: Kunjur and Krishnamurty (1997), restated by Cabrera, Simon and Prado (2002), Mech.
             Mach. Theory 37, and later papers, which report small best errors for it. Those
             published figures could not be checked from this checkout (the papers are not at
             hand), and the published bounds may differ from this file's: no published figure
             is quoted or compared here.

Reports per seed the best SSE, evaluations (analyses over the whole cycle and local trials at
the target inputs), Jacobians, local runs, wall and CPU seconds (time.process_time: the time
this process ran, less sensitive to other work on the machine than the wall time) and the load
average (os.getloadavg, 1 min) before and after the seed; then the seeds at or below the target
(--target, default 2.72e-7 mm^2) and medians with ranges.

    python benchmarks/bench_synth_literature.py [--seeds 10] [--first 0] [--target 2.72e-7]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from common import ROOT

PROBLEMS = ("five-point-curve",)


def main() -> None:
    from planarkin.synthesis.synth import synthesize
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first", type=int, default=0, help="first seed")
    ap.add_argument("--target", type=float, default=2.72e-7, help="SSE counted as met")
    a = ap.parse_args()
    print("load:", os.getloadavg())
    for name in PROBLEMS:
        rows = []
        print("| seed | best SSE [mm^2] | evaluations (analyses) | local runs | ended | wall [s] "
              "| CPU [s] | load before / after |")
        print("|---|---|---|---|---|---|---|---|")
        for seed in range(a.first, a.first + a.seeds):
            l0, c0 = os.getloadavg()[0], time.process_time()
            r = synthesize(ROOT / "mechanisms" / "synthesis" / f"{name}.yaml", seed=seed)
            cpu, l1 = time.process_time() - c0, os.getloadavg()[0]
            best = r.designs[0].cost if r.designs else float("nan")
            rows.append((best, r.evaluations, r.jacobians, r.seconds, cpu))
            print(f"| {seed} | {best:.3e} | {r.evaluations:,} ({r.analyses:,}) | {r.runs} | "
                  f"{r.ended} | {r.seconds:.1f} | {cpu:.1f} | {l0:.1f} / {l1:.1f} |", flush=True)
        R = np.array(rows)
        ok = int((R[:, 0] <= a.target).sum())
        print(f"{name}: SSE <= {a.target:g} in {ok} of {len(R)} seeds; SSE median "
              f"{np.median(R[:, 0]):.3e} (range {R[:, 0].min():.3e} .. {R[:, 0].max():.3e}); "
              f"evaluations median {np.median(R[:, 1]):.0f} (range {R[:, 1].min():.0f} .. "
              f"{R[:, 1].max():.0f}); wall median {np.median(R[:, 3]):.1f} s (range "
              f"{R[:, 3].min():.1f} .. {R[:, 3].max():.1f}); CPU median {np.median(R[:, 4]):.1f} s")
    print("load:", os.getloadavg())

if __name__ == "__main__":
    main()
