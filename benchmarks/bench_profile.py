"""Where planarkin spends its time: cProfile of one in-process solve.

    python benchmarks/bench_profile.py [--steps 200000] [--chain 1000] [--chain-steps 1000]
                                       [--top 15] [--sort tottime]

Profiles planarkin.solve(model, steps=...) (after one warm-up call, not profiled) for the
slider-crank and for the N-four-bar chain, and prints the top lines of each profile.
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200_000, help="slider-crank steps")
    ap.add_argument("--chain", type=int, default=1000, help="chain size N (0: skip)")
    ap.add_argument("--chain-steps", type=int, default=1000)
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--sort", default="tottime", help="pstats sort key (tottime, cumulative)")
    ap.add_argument("--no-warm", action="store_true",
                    help="skip the warm-up call (the chain's solve takes long)")
    a = ap.parse_args(argv)
    common.print_header(common.machine_info(), "planarkin profile")
    profile("slider-crank", models.slider_crank_yaml(), a.steps, a.top, a.sort, not a.no_warm)
    if a.chain:
        profile(f"chain-{a.chain}", models.chain_yaml(a.chain), a.chain_steps, a.top, a.sort,
                not a.no_warm)


if __name__ == "__main__":
    main()
