"""Speed-up of a study on local processes and on a Dask cluster against the serial run, in one
run, and a check that all three give the same outcomes bit for bit.

    python benchmarks/bench_parallel.py [--variants 128] [--jobs 2] [--steps 360]

The study: a four-bar sweep over the crank length a in [0.03, 0.05] with a max metric (what
`planarkin sweep mechanisms/four-bar.yaml --vary a=0.03:0.05:N --metric max:rocker.phi` runs).
Local processes: a ProcessPoolExecutor (forkserver on Linux), the pool's start-up (the
forkserver, the study sent to each worker) inside the clock. Dask (optional, `pip install
'planarkin[dask]'`): a LocalCluster of --jobs single-threaded worker processes on 127.0.0.1,
started before the clock starts, used through Client.get_executor().
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=128)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--steps", type=int, default=360)
    args = ap.parse_args()
    from planarkin.studies.execute import executor, run_dask
    from planarkin.studies.sweep import Range, factorial
    from planarkin.studies.variants import Study
    study = Study("mechanisms/four-bar.yaml", analysis={"steps": args.steps},
                  metrics=["max:rocker.phi"])
    variants = factorial([Range("a", 0.03, 0.05, args.variants)])
    print(f"{len(variants)} variants x {args.steps} steps, chains of {study.chain}; load "
          f"average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    t0 = time.perf_counter()
    serial = executor(1)(study, variants)
    ts = time.perf_counter() - t0
    t0 = time.perf_counter()
    par = executor(args.jobs)(study, variants)
    tp = time.perf_counter() - t0
    print(f"serial            {ts:7.2f} s")
    print(f"--jobs {args.jobs}          {tp:7.2f} s  speed-up {ts / tp:.2f}x, equal bit for bit: "
          f"{repr(par) == repr(serial)}")
    try:
        import distributed
    except ImportError:
        print("dask: not installed (pip install 'planarkin[dask]')")
        return
    with distributed.LocalCluster(n_workers=args.jobs, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        t0 = time.perf_counter()
        got = run_dask(study, variants, client)
        td = time.perf_counter() - t0
    print(f"dask, {args.jobs} workers   {td:7.2f} s  speed-up {ts / td:.2f}x, equal bit for bit: "
          f"{repr(got) == repr(serial)}")


if __name__ == "__main__":
    main()
