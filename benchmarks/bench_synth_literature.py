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
the target inputs), Jacobians, seconds;
then the fraction of seeds below 1e-12 and medians with ranges.

    /tmp/venv/bin/python benchmarks/bench_synth_literature.py [--seeds 10]
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from common import ROOT

PROBLEMS = ("five-point-curve",)


def main() -> None:
    from planarkin.synthesis.synth import synthesize
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=10)
    a = ap.parse_args()
    print("load:", os.getloadavg())
    for name in PROBLEMS:
        rows = []
        for seed in range(a.seeds):
            r = synthesize(ROOT / "mechanisms" / "synthesis" / f"{name}.yaml", seed=seed)
            best = r.designs[0].cost if r.designs else float("nan")
            rows.append((best, r.evaluations, r.jacobians, r.seconds))
            print(f"{name} seed {seed}: SSE {best:.3e}, {r.evaluations} evaluations ("
                  f"{r.analyses} over the whole cycle), {r.jacobians} Jacobians, "
                  f"{r.seconds:.1f} s", flush=True)
        R = np.array(rows)
        ok = int((R[:, 0] < 1e-12).sum())
        print(f"{name}: SSE < 1e-12 in {ok} of {len(R)} seeds; SSE median {np.median(R[:, 0]):.3e}"
              f" (range {R[:, 0].min():.3e} .. {R[:, 0].max():.3e}); evaluations median "
              f"{np.median(R[:, 1]):.0f} (range {R[:, 1].min():.0f} .. {R[:, 1].max():.0f}); "
              f"seconds median {np.median(R[:, 3]):.1f} (range {R[:, 3].min():.1f} .. "
              f"{R[:, 3].max():.1f})")
    print("load:", os.getloadavg())


if __name__ == "__main__":
    main()
