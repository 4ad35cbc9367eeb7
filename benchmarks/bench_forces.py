"""Forces room: accuracy against the hand-derived references and cost, measured in one run.

    python benchmarks/bench_forces.py [--steps 3600] [--repeats 7]

1. accuracy: the slider-crank and four-bar of tests/test_forces.py against their free-body
   Newton-Euler references (worst error over all columns and grid points, relative to each
   column's largest magnitude), and the power balance (sum of driver powers = dT/dt - P_applied)
   of the four power-balance models, at the given number of steps;
2. cost for a model WITHOUT masses: the room's whole work (derived_tables -> []), and load + solve + write (no plots) of the massless slider-crank
   with the forces room registered (planarkin.derived.ROOMS as shipped) against the same with
   ROOMS = () (the code before the room), interleaved, median ratio;
3. cost for a model WITH masses: the same run of the slider-crank with masses and a load against
   the massless one (what forces.csv costs);
4. a large model: the IFToMM A02 chain of benchmarks/models.py (N loops, masses on the couplers,
   gravity): time of the forces table (Kinetostatics, all columns) against the kinematic solve,
   with the block-triangular transposed solve (default above 60 coordinates) and the dense one.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time

import numpy as np

from common import ROOT

sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import planarkin  # noqa: E402
import planarkin.derived as derived  # noqa: E402
import test_forces as T  # noqa: E402


def accuracy(steps: int) -> None:
    for name, text, ref, par in (("slider-crank", T.SLIDER_CRANK, T.slider_crank_reference, T.SC),
                                 ("four-bar", T.FOUR_BAR, T.four_bar_reference, T.FB)):
        res = planarkin.solve(T.load(text), steps=steps)
        got = res.table("forces.csv")
        R = ref(res.t, **par)
        worst = max((T.rel_err(got[k], v), k) for k, v in R.items()
                    if k not in ("guide.fx", "guide.torque"))
        print(f"{name:14s} {len(res.t):6d} rows: worst relative error {worst[0]:.2e} ({worst[1]})")
    for name, text in (("loaded-mm-deg", T.LOADED), ("boom", T.BOOM),
                       ("slider-crank", T.SLIDER_CRANK), ("four-bar", T.FOUR_BAR)):
        res = planarkin.solve(T.load(text), steps=steps)
        d, b = T.power_balance(res)
        print(f"power balance {name:14s}: max |sum P_drivers - (dT/dt - P_applied)| / "
              f"max |dT/dt - P_applied| = {np.abs(d - b).max() / np.abs(b).max():.2e}")


def massless(text: str) -> str:
    for key in (f", mass: {T.SC['m1']}, inertia: {T.SC['J1']}, cm: [{T.SC['c1'][0]}, "
                f"{T.SC['c1'][1]}]", f", mass: {T.SC['m2']}, inertia: {T.SC['J2']}",
                f", mass: {T.SC['m3']}"):
        text = text.replace(key, "")
    return text.split("loads:")[0]


def run_once(text: str, steps: int, out: str) -> float:
    t0 = time.perf_counter()
    res = planarkin.solve(planarkin.load("bench.yaml", text=text), steps=steps)
    res.write(out, plots=None)
    return time.perf_counter() - t0


def cost(steps: int, repeats: int) -> None:
    plain = massless(T.SLIDER_CRANK)
    shipped = derived.ROOMS
    with tempfile.TemporaryDirectory() as out:
        run_once(plain, steps, out)                     # warm imports
        run_once(T.SLIDER_CRANK, steps, out)
        a, b, c = [], [], []
        for k in range(repeats):
            # the order alternates, so that a drift of the machine's load favours neither
            for which in ((0, 1, 2) if k % 2 == 0 else (2, 1, 0)):
                derived.ROOMS = () if which == 0 else shipped
                [a, b, c][which].append(run_once(T.SLIDER_CRANK if which == 2 else plain,
                                                 steps, out))
        derived.ROOMS = shipped
    ma, mb, mc = (min(x) for x in (a, b, c))
    pair = statistics.median(y / x for x, y in zip(a, b))
    from planarkin.solver.grid import Options
    cm = planarkin.load("bench.yaml", text=plain)
    opts = Options.from_model(cm)
    t0 = time.perf_counter()
    for _ in range(1000):
        assert derived.derived_tables(cm, opts) == []
    print(f"model without masses: derived_tables (what the room adds to a run, called once per "
          f"written result) takes {(time.perf_counter() - t0) * 1e3:.1f} us")
    print(f"model without masses, {steps} steps, {repeats} interleaved runs each: room registered "
          f"/ no room = {mb / ma:.3f} best against best ({mb * 1e3:.1f} ms / {ma * 1e3:.1f} ms), "
          f"{pair:.3f} median of the pairs")
    print(f"model with masses and a load: with forces.csv / without masses = {mc / mb:.3f} "
          f"({mc * 1e3:.1f} ms / {mb * 1e3:.1f} ms)")


def large(N: int, steps: int) -> None:
    import models
    from planarkin.derived import derived_tables
    from planarkin.forces import solve as fsolve
    text = "\n".join(ln.replace("0]}", "0], mass: 1, inertia: 0.1}") if ln.startswith("  k")
                     else ln for ln in models.chain_yaml(N).splitlines())
    text = text.replace("analysis:", "gravity: [0, -9.81]\nanalysis:")
    cm = planarkin.load("chain.yaml", text=text)
    t0 = time.perf_counter()
    res = planarkin.solve(cm, steps=steps)
    t1 = time.perf_counter()
    times = {}
    for dense in (False, True):
        fsolve.DENSE_MAX = 10**9 if dense else 60
        (d,) = derived_tables(cm, res.info.options)
        t2 = time.perf_counter()
        d.compute(res._chunk)
        times[dense] = time.perf_counter() - t2
    fsolve.DENSE_MAX = 60
    print(f"chain N = {N} ({cm.n} coordinates), {steps} steps: kinematic solve {t1 - t0:.2f} s; "
          f"forces table {times[False]:.2f} s block-triangular ({times[False] / (t1 - t0):.2f} of "
          f"the solve), {times[True]:.2f} s dense ({times[True] / times[False]:.0f}x slower)")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=3600)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--chain", type=int, default=20)
    a = ap.parse_args()
    accuracy(a.steps)
    cost(a.steps, a.repeats)
    large(a.chain, 1000)


if __name__ == "__main__":
    main()
