"""Accuracy of a curve-slot's table interpolant on a circle, against the exact circle.

A circle of radius 0.5 (a closed table, M points uniformly spaced in angle) and a quarter of it
(an open table, not-a-knot ends) are interpolated in the chord-length parameter by splines of
degree 5 (planarkin's curve.Curve) and, for comparison, 7 and 3 (scipy's make_interp_spline,
the same parameter). Measured on 20,001 points along each spline: the largest radius error
(relative to the radius: what positions see) and curvature error (relative to 1/R: what
accelerations see; the pin's acceleration error is about this). The exact `circle:` curve
(elements/path.py) has neither error beyond rounding. Deterministic; a few seconds.

    python benchmarks/bench_curve_accuracy.py
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from planarkin.elements.curve import Curve  # noqa: E402

R = 0.5


def spline_errors(P: np.ndarray, closed: bool, k: int) -> tuple[float, float]:
    from scipy.interpolate import make_interp_spline
    if k == 5:
        cv = Curve(P, closed)
        a = np.linspace(0.0, cv.a1, 20001)
        c, c1, c2 = cv.eval(a)
    else:
        Q = np.vstack([P, P[:1]]) if closed else P
        a = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(Q, axis=0).T))])
        sp = make_interp_spline(a, Q, k=k, bc_type="periodic" if closed else None)
        x = np.linspace(0.0, a[-1], 20001)
        c, c1, c2 = sp(x), sp(x, 1), sp(x, 2)
    radius = np.abs(np.hypot(c[:, 0], c[:, 1]) - R).max() / R
    sp_ = np.hypot(c1[:, 0], c1[:, 1])
    kappa = (c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]) / sp_**3
    return float(radius), float(np.abs(kappa * R - 1.0).max())


def main() -> None:
    print("| curve | points | degree | radius error | curvature error |")
    print("|---|---|---|---|---|")
    for closed, span in ((True, 2 * math.pi), (False, math.pi / 2)):
        for m in (90, 180, 360, 720, 1440, 2880):
            n = m if closed else m // 4 + 1
            ang = np.linspace(0.0, span, n, endpoint=not closed)
            P = np.c_[R * np.cos(ang), R * np.sin(ang)]
            for k in (3, 5, 7):
                e = spline_errors(P, closed, k)
                name = "circle (periodic)" if closed else "quarter arc (not-a-knot)"
                print(f"| {name} | {n} | {k} | {e[0]:.1e} | {e[1]:.1e} |")


if __name__ == "__main__":
    main()
