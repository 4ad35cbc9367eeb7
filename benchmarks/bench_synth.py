"""Synthesis and fitting targets of issue 20, measured.

1. Six collinear points (20, 20), (20, 25), ..., (20, 45) mm, no prescribed timing, a four-bar
   with free ground pivot, ground angle and lengths (mechanisms/synthesis/straight-line.yaml:
   9 parameters + 6 crank times = 15 unknowns of the classic statement: the starts project
   the times (the nearest points of the path, in order), the local runs take all 15 as
   unknowns; the search block of the file: probed runs in batches of starts); constraints: the crank turns fully (Grashof, crank or
   ground shortest), targets in order along the path; error: sum of squared distances, mm^2).
   An evaluation is either an analysis of a design over its whole cycle (the starts, and the
   check of every local run's result) or a local trial at the six target inputs only
   (planarkin.synthesis.local). Target: SSE < 1e-12 in >= 95 % of 20 seeds. Reports per
   seed the best SSE, the function and Jacobian evaluations, the local runs and the time.
2. fit: mechanisms/four-bar.yaml's coupler point P at 49 times (one cycle), 0.1 mm Gaussian
   noise on x and y, a, b, c, d free from 2-5 % off: the fraction of (trial, parameter) pairs
   with the true value within 2 standard errors (target >= 90 % of 100 trials); exact data:
   the largest parameter error (target 1e-9).

    python benchmarks/bench_synth.py [--seeds 20] [--first 0] [--trials 100] [--only line|fit]
        [--model FILE] [--jobs N]

--jobs N: the straight line with synthesize(jobs=N) (local runs in N - 1 worker processes and
this one, the same results as --jobs 1); its CPU column is then this process's only.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from common import ROOT  # noqa: F401 (puts the checkout first on sys.path)


def straight_line(seeds: int, first: int = 0, model=None, jobs: int = 1) -> None:
    """Per seed: best SSE, evaluations (of them analyses over the cycle), Jacobians, local
    runs, what ended the search, wall and CPU seconds (time.process_time) and the 1-min load
    average before and after (os.getloadavg: other work on the machine shows in the wall
    time, less in the CPU time)."""
    from planarkin.synthesis.synth import synthesize
    model = model or ROOT / "mechanisms" / "synthesis" / "straight-line.yaml"
    ok = 0
    print("| seed | best SSE [mm^2] | evaluations (analyses) | Jacobians | local runs | ended | "
          "wall [s] | CPU [s] | load before / after |")
    print("|---|---|---|---|---|---|---|---|---|")
    ev, an, jac, sec, cpu, best_all, runs = [], [], [], [], [], [], []
    for seed in range(first, first + seeds):
        l0, c0 = os.getloadavg()[0], time.process_time()
        r = synthesize(model, seed=seed, jobs=jobs)
        c, l1 = time.process_time() - c0, os.getloadavg()[0]
        best = r.designs[0].cost if r.designs else float("nan")
        ok += best < 1e-12
        ev.append(r.evaluations)
        an.append(r.analyses)
        jac.append(r.jacobians)
        sec.append(r.seconds)
        cpu.append(c)
        best_all.append(best)
        runs.append(r.runs)
        print(f"| {seed} | {best:.3e} | {r.evaluations:,} ({r.analyses:,}) | {r.jacobians:,} | "
              f"{r.runs:,} | {r.ended} | {r.seconds:.1f} | {c:.1f} | {l0:.1f} / {l1:.1f} |",
              flush=True)
    print(f"straight line: SSE < 1e-12 in {ok} of {seeds} seeds (target >= 95 %); best SSE "
          f"median {np.nanmedian(best_all):.2e} (range {np.nanmin(best_all):.2e} .. "
          f"{np.nanmax(best_all):.2e}); evaluations median {np.median(ev):.0f} (range "
          f"{min(ev)}-{max(ev)}), of them analyses over the cycle {np.median(an):.0f} "
          f"({min(an)}-{max(an)}); local runs {np.median(runs):.0f} ({min(runs)}-{max(runs)}); "
          f"Jacobians {np.median(jac):.0f} ({min(jac)}-{max(jac)}); "
          f"wall median {np.median(sec):.1f} s (range {min(sec):.1f}-{max(sec):.1f}); "
          f"CPU median {np.median(cpu):.1f} s (range {min(cpu):.1f}-{max(cpu):.1f})")


def fitting(trials: int) -> None:
    import planarkin
    four = ROOT / "mechanisms" / "four-bar.yaml"
    true = np.array([0.04, 0.12, 0.1, 0.1])
    start = {"a": 0.042, "b": 0.118, "c": 0.103, "d": 0.098}
    res = planarkin.solve(planarkin.load(four), steps=48)
    P = res.point("P")
    rng = np.random.default_rng(2026)
    tmp = Path(tempfile.mkdtemp())

    def write(x, y):
        p = tmp / "d.csv"
        p.write_text("t [s],P.x [m],P.y [m]\n" + "".join(
            f"{float(a)!r},{float(b)!r},{float(c)!r}\n" for a, b, c in zip(res.t, x, y)))
        return p

    r = planarkin.fit(four, write(P["x"], P["y"]), ["a", "b", "c", "d"], overrides=start)
    print(f"fit, exact data: largest parameter error {np.abs(r.estimate - true).max():.2e} m "
          f"(target 1e-9), {r.evaluations} evaluations, {r.seconds:.2f} s")
    hits, t0, evals = 0, time.perf_counter(), []
    for k in range(trials):
        r = planarkin.fit(four, write(P["x"] + 1e-4 * rng.standard_normal(len(res.t)),
                                      P["y"] + 1e-4 * rng.standard_normal(len(res.t))),
                          ["a", "b", "c", "d"], overrides=start)
        hits += int((np.abs(r.estimate - true) <= 2 * r.se).sum())
        evals.append(r.evaluations)
    print(f"fit, 0.1 mm noise: true within 2 se in {hits} of {4 * trials} (trial, parameter) "
          f"pairs = {100 * hits / (4 * trials):.1f} % (target >= 90 %); evaluations median "
          f"{int(np.median(evals))}, {(time.perf_counter() - t0) / trials:.2f} s per fit")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first", type=int, default=0, help="first seed")
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--only", choices=("line", "fit"))
    ap.add_argument("--model", help="another straight-line model file (default: "
                                    "mechanisms/synthesis/straight-line.yaml)")
    ap.add_argument("--jobs", type=int, default=1, help="processes for the local runs")
    a = ap.parse_args()
    print("load:", os.getloadavg())
    if a.only != "fit":
        straight_line(a.seeds, a.first, a.model, a.jobs)
    if a.only != "line":
        fitting(a.trials)
    print("load:", os.getloadavg())
