"""Where planarkin spends its time: cProfile of one in-process solve.

    python benchmarks/bench_profile.py [--steps 200000] [--chain 1000] [--chain-steps 1000]
                                       [--top 15] [--sort tottime] [--phases]

Profiles planarkin.solve(model, steps=...) (after one warm-up call, not profiled) for the
slider-crank and for the N-four-bar chain, and prints the top lines of each profile.
--phases instead prints, for the slider-crank and the four-bar and each grid-pass route
(compiled, numpy, reference; see bench_peers.py), the CPU time per step of the phases of a solve
(best of 3) and the Python function calls per grid chunk.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
import models  # noqa: E402

import planarkin  # noqa: E402


def profile(label, text, steps, top, sort, warm=True):
    model = planarkin.load(f"{label}.yaml", text=text)
    if warm:
        planarkin.solve(model, steps=steps)
    pr = cProfile.Profile()
    t0 = time.perf_counter()
    pr.enable()
    res = planarkin.solve(model, steps=steps)
    pr.disable()
    wall = time.perf_counter() - t0
    print(f"== {label}, {steps} steps: {wall:.2f} s under cProfile; timings "
          + ", ".join(f"{k} {v:.3f} s" for k, v in res.info.timings.items()) + " ==")
    s = io.StringIO()
    pstats.Stats(pr, stream=s).strip_dirs().sort_stats(sort).print_stats(top)
    lines = s.getvalue().splitlines()
    # drop pstats' preamble up to the call-count line
    start = next((i for i, ln in enumerate(lines) if "function calls" in ln), 0)
    print("\n".join(ln for ln in lines[start:] if ln.strip()))
    print()


PHASES = (  # (module, attribute, phase): the functions timed, CPU time
    ("planarkin.solver.grid.Analysis", "follow", "path following (fixed cost)"),
    ("planarkin.solver.grid", "hermite5", "prediction (numpy Hermite)"),
    ("planarkin.solver.grid.Analysis", "_driver_values", "driver values"),
    ("planarkin.solver.system.System", "_solve_batch", "P+V+A solve, reference pass"),
    ("planarkin.solver.compiled.kernel", "solve", "P+V+A solve, compiled route"),
    ("planarkin.solver.grid.Analysis", "_chunk", "layout of outputs (residual, units, points)"),
    ("planarkin.analysis", "refuse", "refusal checks"),
    ("planarkin.solver.grid.Analysis", "_dense", "grid pass in all (the rows above but path)"),
)


def phases(label, text, steps, route):
    import collections
    import importlib

    from bench_peers import _route
    model = planarkin.load(f"{label}.yaml", text=text)
    acc = collections.Counter()
    saved = []
    for modname, attr, phase in PHASES:
        path = modname.split(".")
        try:
            owner = importlib.import_module(modname)
        except ImportError:
            owner = getattr(importlib.import_module(".".join(path[:-1])), path[-1])
        f = getattr(owner, attr)

        def timed(*args, _f=f, _phase=phase, **kw):
            c0 = time.process_time()
            try:
                return _f(*args, **kw)
            finally:
                acc[_phase] += time.process_time() - c0
        saved.append((owner, attr, f))
        setattr(owner, attr, timed)
    try:
        with _route(route):
            planarkin.solve(model, steps=steps)                  # warm-up
            best = None
            for _ in range(3):
                acc.clear()
                c0 = time.process_time()
                res = planarkin.solve(model, steps=steps)
                total = time.process_time() - c0
                if best is None or total < best[0]:
                    best = (total, dict(acc))
            pr = cProfile.Profile()
            pr.enable()
            planarkin.solve(model, steps=steps)
            pr.disable()
    finally:
        for owner, attr, f in saved:
            setattr(owner, attr, f)
    calls = sum(v[1] for v in pstats.Stats(pr).stats.values())
    chunks = -(-len(res.t) // 8192)
    rows = len(res.t)
    total, parts = best
    print(f"== {label}, {steps} steps, route {route}: {total / rows * 1e6:.3f} us/step CPU, "
          f"{calls / chunks:.0f} Python calls per grid chunk of 8192 rows (path included) ==")
    for _, _, phase in PHASES:
        if phase in parts:
            print(f"  {phase:46s} {parts[phase] / rows * 1e6:7.3f} us/step")
    print()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200_000, help="slider-crank steps")
    ap.add_argument("--chain", type=int, default=1000, help="chain size N (0: skip)")
    ap.add_argument("--chain-steps", type=int, default=1000)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--sort", default="tottime", help="pstats sort key (tottime, cumulative)")
    ap.add_argument("--no-warm", action="store_true",
                    help="skip the warm-up call (the chain's solve takes long)")
    ap.add_argument("--phases", action="store_true", help="CPU time per step by phase")
    a = ap.parse_args(argv)
    common.print_header(common.machine_info(), "planarkin profile")
    if a.phases:
        for label, text in (("slider-crank", models.slider_crank_yaml()),
                            ("four-bar", models.four_bar_yaml())):
            for route in ("compiled", "numpy", "reference"):
                phases(label, text, a.steps, route)
        return
    profile("slider-crank", models.slider_crank_yaml(), a.steps, a.top, a.sort, not a.no_warm)
    if a.chain:
        profile(f"chain-{a.chain}", models.chain_yaml(a.chain), a.chain_steps, a.top, a.sort,
                not a.no_warm)


if __name__ == "__main__":
    main()
