"""Accuracy of a curve-slot's table interpolant on a circle, against the exact circle.

A circle of radius 0.5 (a closed table, M points uniformly spaced in angle) and a quarter of it
(an open table, not-a-knot ends) are interpolated in the chord-length parameter by splines of
degree 5 (planarkin's curve.Curve) and, for comparison, 7 and 3 (scipy's make_interp_spline,
the same parameter). Measured on 20,001 points along each spline: the largest radius error
(relative to the radius: what positions see) and curvature error (relative to 1/R: what
accelerations see; the pin's acceleration error is about this). The exact `circle:` curve
(elements/path.py) has neither error beyond rounding. Deterministic; a few seconds.
--speed also times one solve (2,000 steps, best of 3, alternating in one run) of the pin in a
circular slot with the exact circle and with a 720-point table, and prints the ratio.

    python benchmarks/bench_curve_accuracy.py [--speed]
"""

from __future__ import annotations

import math
import sys
import time
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


SLOT = """
units: {{length: m, angle: rad}}
bodies: {{block: {{q: [0.3, 0.7, 0]}}}}
joints:
  - {{type: angle, i: ground, j: block, c: 0}}
  - {{type: curve-slot, i: ground, j: block, sj: [0, 0], {curve}}}
drivers:
  - {{type: x, i: ground, j: block, f: "0.3 + 0.4*sin(2*pi*t)"}}
analysis: {{end: 1, steps: 2000}}
"""


def speed() -> None:
    import planarkin
    a = np.linspace(0.0, 2 * math.pi, 720, endpoint=False)
    pts = ", ".join(f"[{0.3 + R * math.cos(x)!r}, {0.2 + R * math.sin(x)!r}]" for x in a)
    models = {"exact circle": SLOT.format(curve="curve: {circle: {centre: [0.3, 0.2], radius: 0.5}}"),
              "720-point table": SLOT.format(curve=f"closed: true, curve: [{pts}]")}
    best = dict.fromkeys(models, math.inf)
    for _ in range(3):
        for name, text in models.items():
            m = planarkin.load("slot.yaml", text=text)
            t0 = time.perf_counter()
            planarkin.solve(m)
            best[name] = min(best[name], time.perf_counter() - t0)
    for name, t in best.items():
        print(f"{name}: {t:.3f} s")
    print(f"table / exact: {best['720-point table'] / best['exact circle']:.1f}x")


if __name__ == "__main__":
    main()
    if "--speed" in sys.argv:
        speed()
