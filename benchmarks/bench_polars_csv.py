#!/usr/bin/env python3
"""Could polars' DataFrame.write_csv replace planarkin/output/fastcsv.py? (a script, not a test)

    python benchmarks/bench_polars_csv.py [--rows 200001] [--cols 28] [--repeat 5]

polars is NOT a planarkin dependency: run this with a Python that has it, e.g. a separate
virtual environment (python -m venv --system-site-packages V && V/bin/pip install polars, then
V/bin/python benchmarks/bench_polars_csv.py). On the same tables (bench_fastcsv.py's
slider-crank over one turn and uniform random [0, 1)), in one run:

- time per value writing the table body to a file, best of --repeat, interleaved: ours
  (fastcsv.write_table) against polars (DataFrame from the numpy array + write_csv);
- exact round trip: every cell parsed with float() must give the same double, bit for bit;
- byte-identical to ``','.join(map(repr, row))`` (planarkin's contract), or how many cells
  differ and how (notation such as 1e-05 against 0.00001);
- import time, numpy already imported (both need it), median of 7 fresh interpreters.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))
from bench_fastcsv import slider_crank_table, uniform_table  # noqa: E402
from planarkin.output import fastcsv  # noqa: E402


def write_ours(X, path):
    with open(path, "wb") as f:
        fastcsv.write_table(f, X)


def write_polars(X, path):
    import polars as pl
    pl.DataFrame(X, schema=[f"c{k}" for k in range(X.shape[1])], orient="row").write_csv(
        path, include_header=False)


def cells(path) -> list[bytes]:
    return Path(path).read_bytes().replace(b"\n", b",").split(b",")[:-1]


def import_seconds(module: str, python=sys.executable, n=7) -> float:
    code = ("import numpy, time; t = time.perf_counter(); import " + module +
            "; print(time.perf_counter() - t)")
    env = dict(os.environ, PYTHONPATH=str(HERE.parent))
    return statistics.median(float(subprocess.run([python, "-c", code], capture_output=True,
                                                  text=True, env=env, check=True).stdout)
                             for _ in range(n))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=200_001)
    ap.add_argument("--cols", type=int, default=28)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    import polars as pl
    print(f"polars {pl.__version__}, numpy {np.__version__}; fastcsv fast path "
          f"{'on' if fastcsv._FAST else 'OFF'}")
    tables = {"slider-crank, one turn": slider_crank_table(args.rows, args.cols),
              "uniform random [0,1)": uniform_table(args.rows, args.cols)}
    with tempfile.TemporaryDirectory(prefix="bench-polars-") as tmp:
        for name, X in tables.items():
            X = np.ascontiguousarray(X)
            n = X.size
            print(f"\n{name}: {X.shape[0]} x {X.shape[1]} = {n} values")
            paths = {"ours": Path(tmp) / "ours.csv", "polars": Path(tmp) / "polars.csv"}
            fns = {"ours": write_ours, "polars": write_polars}
            best = {k: float("inf") for k in fns}
            cpu = {k: float("inf") for k in fns}
            for _ in range(args.repeat):          # interleaved: the same load for both
                for k, fn in fns.items():
                    r0 = resource.getrusage(resource.RUSAGE_SELF)
                    t0 = time.perf_counter()
                    fn(X, paths[k])
                    best[k] = min(best[k], time.perf_counter() - t0)
                    r1 = resource.getrusage(resource.RUSAGE_SELF)
                    cpu[k] = min(cpu[k], r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
            for k in fns:
                print(f"  {k:7s} {best[k] / n * 1e9:6.1f} ns/value wall, {cpu[k] / n * 1e9:6.1f} "
                      f"ns/value CPU (all threads), {paths[k].stat().st_size / n:.2f} bytes/value")
            print(f"  polars / ours: wall time {best['polars'] / best['ours']:.3f}, CPU time "
                  f"{cpu['polars'] / cpu['ours']:.3f}")
            ref = [repr(v).encode() for v in X.ravel().tolist()]
            bits = X.ravel().view(np.uint64)
            for k in fns:
                got = cells(paths[k])
                back = np.array([float(c) for c in got]).view(np.uint64) \
                    if len(got) == n else None
                exact = back is not None and bool(np.array_equal(back, bits))
                wrong = [(r, g) for r, g in zip(ref, got) if r != g]
                examples = ", ".join(f"{g.decode()} for {r.decode()}" for r, g in wrong[:3])
                print(f"  {k:7s} round trip bit for bit: {exact}; cells differing from repr: "
                      f"{len(wrong)} of {n}" + (f" (e.g. {examples})" if wrong else ""))
    t_ours = import_seconds("planarkin.output.fastcsv")
    t_pl = import_seconds("polars")
    print(f"\nimport, numpy already imported (median of 7): planarkin.output.fastcsv "
          f"{t_ours * 1e3:.1f} ms, polars {t_pl * 1e3:.1f} ms; polars / ours {t_pl / t_ours:.1f}")


if __name__ == "__main__":
    main()
