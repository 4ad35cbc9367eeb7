"""Path-synthesis problems of the optimisation literature, as planarkin states them, against the
published results.

Each problem is a model file of mechanisms/synthesis/ (its header states the problem and its
source); planarkin's search is the file's own (`search:`), whose evaluation budget is the one
the publication used. Per problem and seed: the best sum of squares (SSE), evaluations (analyses
over the whole cycle and local trials at the target inputs), local runs, what ended the search,
wall and CPU seconds (time.process_time of this process and, with --jobs, not the workers') and
the load average (os.getloadavg, 1 min) before and after; then the seeds at or below the
published best and medians with ranges.

Before the searches, the published designs (their parameter vectors, as printed with 6-8
digits) are scored by planarkin's own evaluation of the same file (`Synthesis.evaluate`,
checked over the whole cycle): the problem as stated here gives the published error again, so
the comparison is of the searches, not of two different problems.

Sources. The problems and the published designs are those of Nguyen-Van, Lieu, Xuan-Mung,
Nguyen, "A new study on optimization of four-bar mechanisms based on a hybrid-combined
differential evolution and Jaya algorithm", Symmetry 14 (2022) 381, doi:10.3390/sym14020381,
as restated in the authors' public code (github.com/sy-nguyen-van/
DE_Jaya_Synthesis_Four_Bar_Mechanisms: CaseN/ObjfN.m, Additional-functions/Mechanisms.m and
OPTIONS_CASE.m for the points, bounds and budgets; CaseN/Check*.m for the earlier papers'
designs). Their error is the plain sum of squared distances; their crank angles are measured
from the ground line; bounds: lengths 0 .. L, the rest -L .. L (here lengths from 0.1: a link
of zero length is no linkage). Their evaluation takes the real part of an unreachable pose
instead of refusing it; planarkin refuses such designs. The best published values are each
the best of 50 runs.

  five-point-curve  5 points, crank angles 30 .. 90 deg (Kunjur and Krishnamurty 1997);
                    this file frees the ground pivot and angle (9 unknowns; the publications
                    fix them: 6), bounds of its own: no published value is comparable
  ellipse           10 points of an ellipse, the first repeated last, free timing in order
                    around one turn (case 5 there); 100,000 evaluations; best published SSE
                    4.02e-4 (W.-Y. Lin and K.-M. Hsiao's design), then 4.20e-4 (Nguyen-Van
                    et al.), 4.77e-3
  eighteen-points   18 points at crank angles th1 + 20 k deg, th1 free (case 3 there, after
                    Cabrera et al. 2002); 5,000 evaluations; best published SSE 0.01608
                    (Nguyen-Van et al.), then 0.0194, 0.03375 (Cabrera et al.)
  five-point-fixed-pivot  held out (benchmarks/heldout/, not used to set the defaults): the
                    five-point problem as published, the ground pivot at the origin and the
                    ground line along x (case 2 there); 5,000 evaluations; the published designs
                    of Kunjur and Krishnamurty, Cabrera et al., MUMSA, IOA and Nguyen-Van et al.
                    scored by planarkin, the best of them the reference
  half-circle       6 points of a half circle, crank angles 30 .. 180 deg, the crank the
                    shortest link (case 4 there); 50,000 evaluations; best published SSE 1.2162
                    (Nguyen-Van et al.), a linkage on the change-point limit (crank = coupler,
                    ground = rocker to 7 digits) that planarkin refuses; then 2.23, 2.49

    python benchmarks/bench_synth_literature.py [--problems ellipse,eighteen-points]
        [--seeds 5] [--first 0] [--jobs 1]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from common import ROOT

# name: (best published SSE or None, label, {label: published design [d, a, b, c, px, py, x0,
# y0, th0] (+ [th1] for eighteen-points): the vectors of CaseN/Check*.m})
PROBLEMS = {
    "five-point-curve": (None, "", {}),
    "ellipse": (4.02e-4, "Lin and Hsiao", {
        "Lin and Hsiao": [80.0, 8.045662, 50.81902, 42.20801, -10.63697, -2.29109, 8.494813,
                          -0.7579678, 3.88921],
        "Nguyen-Van et al.": [79.999856, 8.1232008, 50.870344, 42.360533, -10.853763,
                              0.091433127, 7.5379031, -0.52254141, 4.0121195]}),
    "eighteen-points": (0.01608, "Nguyen-Van et al.", {
        "Nguyen-Van et al.": [49.800886, 0.28817159, 48.476138, 1.633642, -23.41281, 7.6644886,
                              -14.836153, 20.140223, 2.5286091, 5.0644224],
        "Cabrera et al.": [3.057878, 0.237803, 4.828954, 2.056456, 0.767038, 1.850828,
                           1.776808, -0.641991, 1.002168, 0.226186]}),
    # held out (benchmarks/heldout/: not used to set the search's defaults): case 2 there, the
    # designs of CheckCASE2.m and x_best_HCDJ_Case2.txt as [d, a, b, c, px, py] (the pivot and
    # the ground line fixed); the best published value is the best of these by planarkin
    "five-point-fixed-pivot": (None, "", {
        "Kunjur and Krishnamurty": [3.509643, 1.857606, 4.725835, 3.518721, 1.959538, 1.558898],
        "Cabrera et al.": [3.0630424, 1.9959624, 3.305823, 2.524706, 1.645158, 1.708959],
        "MUMSA": [3.77326856, 2.00000403, 4.11697104, 2.74615671, 1.67848787, 1.67098007],
        "IOA": [2.803607, 1.99226, 3.030461, 2.474117, 1.64413, 1.714536],
        "Nguyen-Van et al.": [4.2930812, 1.9978324, 4.7374099, 2.9417301, 1.7074051,
                              1.6441696]}),
    "half-circle": (1.2162, "Nguyen-Van et al.", {
        "Nguyen-Van et al.": [49.99998, 1.3484315, 1.3484507, 50, 11.384434, 4.4424357,
                              10.194752, -3.694134, 6.2158799],
        "earlier (2.49)": [49.968967, 4.785659, 6.491026, 48.393942, 16.444782, 11.988091,
                           12.046587, -14.774897, 0.038678]}),
}


HELD_OUT = ROOT / "benchmarks" / "heldout"


def path_of(name):
    held = HELD_OUT / f"{name}.yaml"
    return held if held.exists() else ROOT / "mechanisms" / "synthesis" / f"{name}.yaml"


def published_scores(name) -> None:
    """The published designs' SSE by planarkin's evaluation of the file (or why it refuses)."""
    from planarkin.synthesis.synth import Synthesis
    found = []
    for label, v in PROBLEMS[name][2].items():
        if len(v) == 6:                     # the pivot and the ground line fixed
            d, a, b, c, px, py = v
            values, rest = dict(a=a, b=b, c=c, d=d, px=px, py=py), []
        else:
            d, a, b, c, px, py, x0, y0, th0 = v[:9]
            values = dict(x0=x0, y0=y0, th0=th0, a=a, b=b, c=c, d=d, px=px, py=py)
            rest = v[9:]
        des = Synthesis(path_of(name)).score(values, rest)
        said = f"{des.cost:.6g}" if hasattr(des, "cost") else f"refused: {des.reason}"
        if hasattr(des, "cost"):
            found.append(des.cost)
        print(f"  published design of {label}: SSE by planarkin {said}")
    return min(found, default=None)


def main() -> None:
    from planarkin.synthesis.synth import synthesize
    ap = argparse.ArgumentParser()
    ap.add_argument("--problems", default=",".join(PROBLEMS))
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--first", type=int, default=0, help="first seed")
    ap.add_argument("--jobs", type=int, default=1)
    a = ap.parse_args()
    print("load:", os.getloadavg())
    for name in a.problems.split(","):
        best_pub, who, _ = PROBLEMS[name]
        print(f"\n{name}" + (f" (best published SSE {best_pub:g}, {who})" if best_pub else "")
              + (" [held out]" if path_of(name).parent == HELD_OUT else ""))
        scored = published_scores(name)
        if best_pub is None and path_of(name).parent == HELD_OUT:
            best_pub = scored       # the best published design as planarkin scores it
        rows = []
        print("| seed | best SSE | evaluations (analyses) | local runs | ended | wall [s] "
              "| CPU [s] | load before / after |")
        print("|---|---|---|---|---|---|---|---|")
        for seed in range(a.first, a.first + a.seeds):
            l0, c0 = os.getloadavg()[0], time.process_time()
            r = synthesize(path_of(name), seed=seed, jobs=a.jobs)
            cpu, l1 = time.process_time() - c0, os.getloadavg()[0]
            best = r.designs[0].cost if r.designs else float("nan")
            rows.append((best, r.evaluations, r.seconds, cpu))
            print(f"| {seed} | {best:.4e} | {r.evaluations:,} ({r.analyses:,}) | {r.runs} | "
                  f"{r.ended} | {r.seconds:.1f} | {cpu:.1f} | {l0:.1f} / {l1:.1f} |", flush=True)
        R = np.array(rows)
        met = f"; at or below the best published in {int((R[:, 0] <= best_pub).sum())} of " \
              f"{len(R)} seeds" if best_pub else ""
        print(f"{name}: SSE median {np.median(R[:, 0]):.4e} (range {R[:, 0].min():.4e} .. "
              f"{R[:, 0].max():.4e}){met}; evaluations median {np.median(R[:, 1]):.0f}; wall "
              f"median {np.median(R[:, 2]):.1f} s (range {R[:, 2].min():.1f} .. "
              f"{R[:, 2].max():.1f}); CPU median {np.median(R[:, 3]):.1f} s")
    print("load:", os.getloadavg())


if __name__ == "__main__":
    main()
