"""Cost of TimeFunction.derivatives (f, f', f'') for the kinds of driver function, in one run.

Compares a smooth 32-node expression (the reference: expr.py's docstring quotes it), a
chained motion profile (rise-dwell-return-dwell, repeated), a periodic quintic table of 25 rows
and a kink (abs), at 1 point and at 100,000 points; prints microseconds and the ratio to the
reference. Deterministic inputs; a few seconds. Ratios are what to quote (absolute times depend
on the machine's load).

    python benchmarks/bench_driver_functions.py
"""

from __future__ import annotations

import sys
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from planarkin.functions.expr import TimeFunction  # noqa: E402
from planarkin.functions.inputtable import table_function  # noqa: E402
from planarkin.functions.motion import Segment, profile  # noqa: E402


def main() -> None:
    ts = np.linspace(0, 1, 25)
    funcs = {
        "smooth expression (reference)": TimeFunction(
            "0.3 + 0.05*sin(2*pi*t)**2 + 0.1*exp(-t/2)*cos(3*t + 0.2) - sqrt(1 + t**2)", {}),
        "2*pi*abs(t - 0.5)": TimeFunction("2*pi*abs(t - 0.5)", {}),
        "motion: 4 segments, repeat": profile(
            [Segment("rise", 90, 0.3, "cycloidal"), Segment("dwell", 0, 0.2),
             Segment("return", -90, 0.3, "poly345"), Segment("dwell", 0, 0.2)], repeat=True),
        "table: 25 rows, periodic": table_function(ts, np.sin(2 * np.pi * ts), True, "b.csv"),
    }
    rows = []
    for n, reps in ((1, 2000), (100_000, 20)):
        t = 0.37 if n == 1 else np.linspace(0.0, 3.0, n)
        for name, f in funcs.items():
            f.derivatives(t)
            rows.append((n, name, min(timeit.repeat(lambda: f.derivatives(t), number=reps,
                                                    repeat=3)) / reps * 1e6))
    print("| points | driver function | us per call | ratio to the reference |")
    print("|---|---|---|---|")
    for n in (1, 100_000):
        ref = next(us for m, name, us in rows if m == n and "reference" in name)
        for m, name, us in rows:
            if m == n:
                print(f"| {n} | {name} | {us:.1f} | {us / ref:.2f} |")


if __name__ == "__main__":
    main()
