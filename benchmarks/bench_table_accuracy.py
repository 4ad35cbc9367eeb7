"""Accuracy of the table interpolant (planarkin.functions.inputtable) on a smooth signal.

sin(2*pi*t) is sampled at n points per period (uniform), once as a periodic table and once as
an open one (not-a-knot ends) over one period, and the interpolant's value, velocity,
acceleration and jerk are compared with the exact ones on 20,001 points. Errors are relative to
each quantity's amplitude (1, 2 pi, 4 pi**2, 8 pi**3). Deterministic; a few seconds.

    python benchmarks/bench_table_accuracy.py
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from planarkin.functions.inputtable import table_function  # noqa: E402

W = 2 * math.pi


def errors(n: int, periodic: bool) -> list[float]:
    t = np.linspace(0.0, 1.0, n + 1)
    f = table_function(t, np.sin(W * t), periodic, "sin.csv")
    x = np.linspace(0.0, 1.0, 20001)
    v, d1, d2 = f.derivatives(x)
    d3 = f.third(x)
    exact = (np.sin(W * x), W * np.cos(W * x), -W**2 * np.sin(W * x), -W**3 * np.cos(W * x))
    return [float(np.abs(g - e).max() / W**k) for k, (g, e) in enumerate(zip((v, d1, d2, d3),
                                                                                exact))]


def main() -> None:
    print("| samples per period | ends | position | velocity | acceleration | jerk |")
    print("|---|---|---|---|---|---|")
    for periodic in (True, False):
        for n in (8, 16, 32, 64, 128):
            e = errors(n, periodic)
            print(f"| {n} | {'periodic' if periodic else 'not-a-knot'} | "
                  + " | ".join(f"{x:.1e}" for x in e) + " |")


if __name__ == "__main__":
    main()
