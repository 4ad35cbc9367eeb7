#!/usr/bin/env python3
"""CSV against Parquet tables of one long run (a script, not a test).

    python benchmarks/bench_parquet.py [--steps 2000000] [--whole]

Solves the plain slider-crank (tests/clitools.py) over --steps intervals (2,000,001 rows) once,
and feeds every chunk, as `planarkin run` does, to both table writers in this process, one after
the other: TableSink (CSV through planarkin/output/fastcsv.py) and ParquetSink (pyarrow, one row
group per chunk). Prints, for bodies and points, each writer's busy time (formatting, encoding
and writing, with the column statistics both compute) and file size, as ratios Parquet / CSV
measured in this one run, and checks that the Parquet files read back bit for bit (a SHA-256 of
the row-major float64 bytes sent against the one read back). With --whole, also times the whole
`planarkin run --no-plots --table-format csv|parquet` of the same model (start-up, solve,
writer processes), one after the other, and prints the ratio.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "tests"))
from clitools import PLAIN_SLIDER_CRANK  # noqa: E402

import planarkin  # noqa: E402
from planarkin.options import resolve  # noqa: E402
from planarkin.output.directory import ParquetSink, TableSink  # noqa: E402
from planarkin.solver.layout import Layout  # noqa: E402
from planarkin.analysis import prepare, stream  # noqa: E402


class BothSinks:
    """stream()'s sink: every chunk's tables to a CSV and a Parquet writer, each timed."""

    def __init__(self, cm, opts, d: Path):
        self.layout = Layout(cm, opts.order, cm.spec.output.bodies, cm.spec.output.points)
        heads = {"bodies": self.layout.body_header, "points": self.layout.point_header}
        self.csv = {n: TableSink(d / f"{n}.csv", h) for n, h in heads.items()}
        self.pq = {n: ParquetSink(d / f"{n}.parquet", h) for n, h in heads.items()}
        self.sha = {n: hashlib.sha256() for n in heads}
        self.rows = 0

    def add(self, ch) -> None:
        for n, X in (("bodies", self.layout.body_table(ch)), ("points", self.layout.point_table(ch))):
            X += 0.0
            self.csv[n].add(X)
            self.pq[n].add(X)
            self.sha[n].update(np.ascontiguousarray(X).tobytes())
        self.rows += len(ch.t)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--steps", type=int, default=2_000_000)
    ap.add_argument("--whole", action="store_true", help="also time whole planarkin runs")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench-parquet-") as tmp:
        d = Path(tmp)
        (d / "sc.yaml").write_text(PLAIN_SLIDER_CRANK)
        cm = planarkin.load(d / "sc.yaml")
        opts = resolve(cm, {"steps": args.steps, "max_rows": args.steps + 1}, source="api")
        an = prepare(cm, opts)
        sinks = BothSinks(cm, opts, d)
        t0 = time.perf_counter()
        stream(an, sink=sinks)
        wall = time.perf_counter() - t0
        import pyarrow
        print(f"slider-crank, {sinks.rows} rows (solve and both writers: {wall:.1f} s); "
              f"pyarrow {pyarrow.__version__}, Parquet with pyarrow's default compression "
              f"(snappy), no dictionary")
        total = {"csv": [0.0, 0], "parquet": [0.0, 0]}
        for n in sinks.csv:
            tc = sinks.csv[n].close()[2]
            tp = sinks.pq[n].close()[2]
            sc, sp = os.path.getsize(d / f"{n}.csv"), os.path.getsize(d / f"{n}.parquet")
            import pyarrow.parquet as pq
            t = pq.read_table(d / f"{n}.parquet")
            back = np.column_stack([t.column(k).to_numpy() for k in range(t.num_columns)])
            same = hashlib.sha256(np.ascontiguousarray(back).tobytes()).digest() == \
                sinks.sha[n].digest()
            cols = t.num_columns
            print(f"  {n}.*: {t.num_rows} x {cols}: CSV {sc / 1e6:8.1f} MB {tc:7.2f} s | "
                  f"Parquet {sp / 1e6:8.1f} MB {tp:7.2f} s | Parquet/CSV size {sp / sc:.3f}, "
                  f"write time {tp / tc:.3f}; read back bit for bit: {same}")
            total["csv"][0] += tc
            total["csv"][1] += sc
            total["parquet"][0] += tp
            total["parquet"][1] += sp
            del t, back
        (tc, sc), (tp, sp) = total["csv"], total["parquet"]
        print(f"  both tables: Parquet/CSV size {sp / sc:.3f}, write time {tp / tc:.3f} "
              f"(CSV {sc / 1e6:.0f} MB in {tc:.1f} s, Parquet {sp / 1e6:.0f} MB in {tp:.1f} s)")
        for p in d.glob("*.*"):
            if p.suffix in (".csv", ".parquet"):
                p.unlink()
        if args.whole:
            env = dict(os.environ, PYTHONPATH=str(HERE.parent))
            wall = {}
            for fmt in ("csv", "parquet"):
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-m", "planarkin", "run", str(d / "sc.yaml"),
                                "--out", str(d / fmt), "--no-plots", "-q", "--steps",
                                str(args.steps), "--max-rows", str(args.steps + 1),
                                "--table-format", fmt], check=True, env=env,
                               stdout=subprocess.DEVNULL)
                wall[fmt] = time.perf_counter() - t0
            print(f"  whole planarkin run --no-plots: CSV {wall['csv']:.1f} s, Parquet "
                  f"{wall['parquet']:.1f} s; Parquet/CSV {wall['parquet'] / wall['csv']:.3f}")


if __name__ == "__main__":
    main()
