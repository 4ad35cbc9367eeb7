"""Sketch form against the body/joint form and the exact linkage (Jansen, Klann, Peaucellier).

For each linkage the same solve as tests/test_sketch_exact.py (72 steps): the sketch from
rounded pin coordinates, the sketch with the published lengths (`lengths:`), the body/joint
form, and the exact kinematics (50-digit circle intersections). Prints the largest error of the
named points: positions relative to the model's size, velocities and accelerations relative to
the point's own largest |v| or |a|; and, to show where the floor comes from, the exact
kinematics of the rounded pins against the published ones. Deterministic; a few seconds.

    python benchmarks/bench_sketch_accuracy.py
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import exact_linkages as X  # noqa: E402
import linkages as L  # noqa: E402
import test_sketch_exact as T  # noqa: E402


class _Table:
    def __init__(self, d):
        self.d = d

    def point(self, p):
        return self.d[p]


def main() -> None:
    print(f"{'linkage':12s} {'compared':34s} {'P':>9s} {'V':>9s} {'A':>9s}")
    for key in sorted(T.CASES):
        res, exact, size = T._forms(key)
        bj = {p: res["bodies"].point(p) for p in res["bodies"].model.point_names}
        name, fn, th, *_ = T.CASES[key]
        import math
        pins = fn(math.radians(th))
        own = X.kinematics(key, {p: pins[p] for p in L.GROUND[key]}, X.own_length(pins),
                           T._angle(key), res["bodies"].t)
        rows = [("sketch (coordinates) vs exact", X.errors(res["sketch"], exact, size)),
                ("sketch + lengths vs exact", X.errors(res["lengths"], exact, size)),
                ("body/joint vs exact", X.errors(res["bodies"], exact, size)),
                ("sketch (coordinates) vs body/joint", X.errors(res["sketch"], bj, size)),
                ("sketch + lengths vs body/joint", X.errors(res["lengths"], bj, size)),
                ("exact: rounded pins vs published", X.errors(_Table(own), exact, size))]
        for what, err in rows:
            print(f"{key:12s} {what:34s} " + " ".join(f"{err[g][0]:9.2e}" for g in "PVA"))


if __name__ == "__main__":
    main()
