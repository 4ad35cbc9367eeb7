"""What validating a model again costs (a study's variant, a synthesis trial): Study.model
(validate with overrides, then compile) per call, with planarkin.functions.expr.evaluate_constant's
shortcut for numbers and parameter names and without it (the full parse of every text, as
before 2026-12-06), alternating, medians of --rounds rounds of --calls calls (CPU time).

    python benchmarks/bench_validate.py [--rounds 7] [--calls 300]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from common import ROOT  # noqa: F401 (puts the checkout first on sys.path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--calls", type=int, default=300)
    a = ap.parse_args(argv)
    import planarkin.model.validate as V
    from planarkin.functions.expr import parser
    from planarkin.studies.variants import Study
    new = parser.evaluate_constant

    def old(text, values):
        return parser.parse_text(text, values.keys(), False, values).value

    print(f"load average {os.getloadavg()[0]:.2f} at the start")
    for path in ("mechanisms/synthesis/straight-line.yaml", "mechanisms/four-bar.yaml"):
        s = Study(ROOT / path)
        key = next(iter(s.parameters))
        base = float(s.parameters[key])
        res = {"without": [], "with": []}
        for _ in range(a.rounds):
            for name, fn in (("without", old), ("with", new)):
                V.evaluate_constant = fn          # the validator's calls (not synthesis.spec's)
                t0 = time.process_time()
                for i in range(a.calls):
                    s.model({key: base * (1 + 1e-6 * i)})
                res[name].append((time.process_time() - t0) / a.calls * 1e3)
        V.evaluate_constant = new
        o, n = statistics.median(res["without"]), statistics.median(res["with"])
        print(f"{path}: Study.model CPU per call without the shortcut {o:.3f} ms "
              f"({min(res['without']):.3f}-{max(res['without']):.3f}), with it {n:.3f} ms "
              f"({min(res['with']):.3f}-{max(res['with']):.3f}): {n / o:.2f}x")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
