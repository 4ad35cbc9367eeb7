"""What validating a model again costs (a study's variant, a synthesis trial): Study.model
(validate with overrides, then compile) per call, alternating three ways of evaluating the
file's texts (planarkin.functions.expr.evaluate_constant): `parse`, the full parse of every text
(as before 2026-12-06); `names`, the shortcut for numbers and parameter names, every other text
parsed (2026-12-06); `plans`, the shortcut and every other text from its plan
(planarkin.functions.expr.plan, 2026-12-07: the default); and `arrays`, the design's compiled
model made from the nominal's arrays without validating the file (studies.batch.Batch.design,
what a synthesis trial takes since 2026-12-07, bit for bit the same model). Every free
parameter of the file's design: block is moved (the first parameter for a file without one).
Medians of --rounds rounds of --calls calls (CPU time), with the range.

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
    from planarkin.studies.batch import Batch
    from planarkin.studies.variants import Study
    new = parser.evaluate_constant
    plans = parser._PLANS

    class NoPlans(dict):                # never holds a plan: every other text is parsed
        def __len__(self):
            return 1 << 30

    def old(text, values):
        return parser.parse_text(text, values.keys(), False, values).value

    ways = (("parse", old, plans), ("names", new, NoPlans()), ("plans", new, plans))
    print(f"load average {os.getloadavg()[0]:.2f} at the start")
    for path in ("mechanisms/synthesis/five-point-curve.yaml",
                 "mechanisms/synthesis/straight-line.yaml", "mechanisms/four-bar.yaml"):
        s = Study(ROOT / path)
        design = s.root.value.get("design")
        keys = list(design.value["free"].value) if design is not None else \
            [next(iter(s.parameters))]
        base = {k: float(s.nominal.spec.parameters[k]) for k in keys}
        vary = [{k: v * (1 + 1e-6 * i) for k, v in base.items()} for i in range(a.calls)]
        B = Batch(s, keys, nominal=False)
        assert all(B.design(v) is not None for v in vary[:3])
        res = {name: [] for name, _, _ in ways + (("arrays", None, None),)}
        for _ in range(a.rounds):
            for name, fn, table in ways:
                V.evaluate_constant = fn          # the validator's calls (not synthesis.spec's)
                parser._PLANS = table
                t0 = time.process_time()
                for v in vary:
                    s.model(v)
                res[name].append((time.process_time() - t0) / a.calls * 1e3)
            V.evaluate_constant, parser._PLANS = new, plans
            t0 = time.process_time()
            for v in vary:
                B.design(v)
            res["arrays"].append((time.process_time() - t0) / a.calls * 1e3)
        V.evaluate_constant, parser._PLANS = new, plans
        med = {name: statistics.median(v) for name, v in res.items()}
        print(f"{path}: Study.model CPU per call, " + ", ".join(
            f"{name} {med[name]:.3f} ms ({min(v):.3f}-{max(v):.3f})" for name, v in res.items())
            + f"; plans / parse {med['plans'] / med['parse']:.2f}x, plans / names "
              f"{med['plans'] / med['names']:.2f}x, arrays / plans "
              f"{med['arrays'] / med['plans']:.2f}x")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
