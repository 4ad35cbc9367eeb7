"""Clearance room (issue 29): what clearance.csv, its summary and its findings cost, measured
against the same analysis without shapes, in one run.

    python benchmarks/bench_clearance.py [--steps 3600] [--rounds 7] [--pairs 45]

The model is the IFToMM A02 chain of benchmarks/models.py with N = 5 (11 bodies); ten of them
carry a plate around their pins, one layer, every one of the 45 pairs asked for by name
(`clearance: pairs:`, so that joined pairs are measured too: a pin's two plates overlap at
every row, the overlap's depth path is timed with the rest). Both sides load, solve and write
the run's tables and summary (no plots), interleaved and alternating in order, so that a drift
of the machine's load favours neither; the ratio is taken per round, its median and spread
(min - max) reported with the load average before and after. The target: the room adds at most
1x the analysis without it (a ratio <= 2).

Also: the cost of the room for a model without shapes (derived_tables -> [] and no row check),
and the time of the table alone (45 pairs, vectorised over the rows) against the solve.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from itertools import combinations

from common import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))

import planarkin  # noqa: E402


def models(n_shapes: int) -> tuple[str, str]:
    import models as M
    plain = M.chain_yaml(5)
    bodies = [f"c{k}" for k in range(6)] + [f"k{k}" for k in range(5)]
    shaped = bodies[:n_shapes]
    shapes = "".join(f"  {b}: {{plate: 0.1, hole: 0.04}}\n" for b in shaped)
    pairs = "".join(f"    - {{between: [{a}, {b}]}}\n" for a, b in combinations(shaped, 2))
    text = plain.replace("analysis:", "shapes:\n" + shapes + "clearance:\n  min: 0.01\n"
                         "  pairs:\n" + pairs + "analysis:")
    return plain, text


def run_once(text: str, steps: int, out: str) -> float:
    t0 = time.perf_counter()
    res = planarkin.solve(planarkin.load("chain.yaml", text=text), steps=steps)
    res.write(out, plots=None)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=3600)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--shapes", type=int, default=10)
    a = ap.parse_args()
    plain, shaped = models(a.shapes)
    cm = planarkin.load("chain.yaml", text=shaped)
    from planarkin.clearance.build import pairs
    n_pairs = len(pairs(cm))
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as out:
        run_once(plain, a.steps, out)                   # warm imports and caches
        run_once(shaped, a.steps, out)
        base, room = [], []
        for k in range(a.rounds):
            for which in ((0, 1) if k % 2 == 0 else (1, 0)):
                (base, room)[which].append(run_once((plain, shaped)[which], a.steps, out))
    load1 = os.getloadavg()
    ratios = [r / b for b, r in zip(base, room)]
    print(f"chain N = 5, {cm.nb} bodies, {a.shapes} shapes, {n_pairs} pairs, {a.steps} steps, "
          f"{a.rounds} rounds alternating (load average {load0[0]:.2f} before, {load1[0]:.2f} "
          f"after)")
    print(f"  without shapes: median {statistics.median(base) * 1e3:.0f} ms "
          f"({min(base) * 1e3:.0f} - {max(base) * 1e3:.0f})")
    print(f"  with shapes:    median {statistics.median(room) * 1e3:.0f} ms "
          f"({min(room) * 1e3:.0f} - {max(room) * 1e3:.0f})")
    print(f"  ratio with / without: median {statistics.median(ratios):.3f} (spread "
          f"{min(ratios):.3f} - {max(ratios):.3f}); the room adds "
          f"{statistics.median(ratios) - 1:.2f}x the analysis (target <= 1x)")
    # the table alone, on the solved rows
    res = planarkin.solve(cm, steps=a.steps)
    from planarkin.clearance.cycle import Clearance
    C = Clearance(cm)
    t0 = time.perf_counter()
    for _ in range(3):
        C._memo = None
        C.table(res, 2)
    t_table = (time.perf_counter() - t0) / 3
    print(f"  clearance.csv's rows alone ({n_pairs} pairs x {len(res.t)} rows): "
          f"{t_table * 1e3:.0f} ms")
    # a model without shapes: the room's whole cost is asking (and nothing of it imported but
    # its package's door, planarkin.clearance: checked in a fresh process)
    from planarkin.clearance import derived_tables, row_checks
    cm0 = planarkin.load("chain.yaml", text=plain)
    opts = res.info.options
    t0 = time.perf_counter()
    for _ in range(1000):
        assert derived_tables(cm0, opts) == [] and row_checks(cm0, opts) == []
    asking = (time.perf_counter() - t0) * 1e3          # ms for 1000: us each
    import subprocess
    code = ("import sys, planarkin; planarkin.solve(planarkin.load('mechanisms/four-bar.yaml'));"
            "print(sorted(m for m in sys.modules if m.startswith('planarkin.clearance')))")
    mods = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=str(ROOT)).stdout.strip()
    print(f"  a model without shapes: the room's derived_tables and row_checks take "
          f"{asking:.1f} us per run; modules of the room imported: "
          f"{mods}")

if __name__ == "__main__":
    main()
