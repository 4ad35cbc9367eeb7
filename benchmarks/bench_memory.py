"""Peak memory of a whole `planarkin run` of the slider-crank.

    python benchmarks/bench_memory.py [--quick] [--steps N ...] [--chain N ...] [--json PATH]
                                      [--time-v]

Each measurement runs in a fresh, bare helper interpreter that starts
`planarkin run slider-crank.yaml --no-plots --steps N --out TMP` with subprocess.run and then
reads resource.getrusage(RUSAGE_CHILDREN).ru_maxrss: the peak resident set size of the
planarkin process (kB on Linux). A fresh helper per run keeps the maxima apart (RUSAGE_CHILDREN
is the largest over every child ever waited for). Printed: peak RSS in MB (10^6 bytes) and MiB,
wall time, and the CSV bytes written. The baseline rows (`planarkin --version`, `--steps 1`)
show the interpreter and import footprint; --chain N adds the N-four-bar chain at 1000 steps.
A run is one process (the tables are written and the plots drawn in it: issue 18), so its peak
RSS is the sum over its processes; benchmarks/bench_process.py samples the sum over a process
tree, to compare with a checkout that still forks writers. Targets: 2,000,000 steps under
400 MB (issue 5); 10,000,000 steps under 150 MB (issue 18: `--steps 10000000`, which writes
about 7 GB of CSV).
--time-v cross-checks the peak with /usr/bin/time -v.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
import models  # noqa: E402

TARGET_MB = 400.0


# The helper is a bare interpreter (no numpy imported): on Linux a child's ru_maxrss also
# counts the memory it had before exec (the fork of its parent), so the helper must be small.
HELPER = r"""
import json, resource, subprocess, sys, time
cmd, cwd = json.loads(sys.argv[1]), sys.argv[2]
t0 = time.perf_counter()
p = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
wall = time.perf_counter() - t0
ru = resource.getrusage(resource.RUSAGE_CHILDREN)
out = {"maxrss_kb": ru.ru_maxrss, "wall": wall, "returncode": p.returncode,
       "user": ru.ru_utime, "sys": ru.ru_stime}
for line in p.stderr.splitlines():
    if "Maximum resident set size" in line:
        out["time_v_maxrss_kb"] = int(line.split(":")[1])
if p.returncode != 0:
    out["stderr"], out["stdout"] = p.stderr[-2000:], p.stdout[-2000:]
print(json.dumps(out))
"""


def measure(args: list[str], use_time: bool = False) -> dict:
    """Run planarkin ARGS once in a fresh helper; returns its peak RSS (kB) and wall time."""
    cmd, env = common.planarkin_command()
    full = (["/usr/bin/time", "-v"] if use_time else []) + cmd + args
    p = subprocess.run([sys.executable, "-S", "-c", HELPER, json.dumps(full), str(common.ROOT)],
                       capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"helper failed: {p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def dir_bytes(d: Path) -> int:
    return sum(f.stat().st_size for f in d.rglob("*") if f.is_file())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="20,000 and 200,000 steps only")
    ap.add_argument("--steps", type=int, nargs="+", metavar="N", help="step counts to measure")
    ap.add_argument("--json", metavar="PATH", help="save the results as JSON")
    ap.add_argument("--chain", type=int, nargs="+", metavar="N", default=[],
                    help="also the N-four-bar chain (1000 steps) for these N")
    ap.add_argument("--time-v", action="store_true",
                    help="cross-check with /usr/bin/time -v (Maximum resident set size)")
    a = ap.parse_args(argv)
    if a.time_v and not shutil.which("/usr/bin/time"):
        ap.error("/usr/bin/time is not installed")
    steps = a.steps or ([20_000, 200_000] if a.quick else [200_000, 2_000_000])
    info = common.machine_info()
    common.print_header(info, "planarkin memory benchmark" + (" (--quick)" if a.quick else ""))
    results = {"machine": info, "runs": []}
    print(f"{'run':44s} {'peak RSS':>18s} {'wall':>9s} {'us/step':>9s} {'CSV written':>12s}")
    with tempfile.TemporaryDirectory(prefix="planarkin-mem-") as tmp:
        tmp = Path(tmp)
        model = tmp / "slider-crank.yaml"
        model.write_text(models.slider_crank_yaml())
        runs = [("planarkin --version", ["--version"], None)]
        runs += [(f"run --no-plots --steps {n}",
                  ["run", str(model), "--no-plots", "--steps", str(n),
                   "--max-rows", str(n + 1), "--out",
                   str(tmp / f"out{n}")], n) for n in [1] + steps]
        for N in a.chain:
            cm = tmp / f"chain-{N}.yaml"
            cm.write_text(models.chain_yaml(N))
            runs.append((f"chain N={N}: run --no-plots --steps 1000",
                         ["run", str(cm), "--no-plots", "--steps", "1000", "--out",
                          str(tmp / f"outc{N}")], f"c{N}"))
        for label, args, n in runs:
            r = measure(args, a.time_v)
            if r["returncode"] != 0:
                print(f"{label:44s} FAILED (exit {r['returncode']}):\n{r.get('stderr', '')}")
                results["runs"].append({"label": label, "steps": n, **r})
                continue
            written = dir_bytes(tmp / f"out{n}") if n else 0
            if n:
                shutil.rmtree(tmp / f"out{n}", ignore_errors=True)   # 2M steps: ~0.9 GB
            if isinstance(n, str):                                   # a chain run
                n = 1000
            kb = r["maxrss_kb"]
            mb, mib = kb * 1024 / 1e6, kb / 1024
            per = f"{r['wall'] / (n + 1) * 1e6:9.2f}" if n and n > 1 else f"{'':9s}"
            extra = ""
            if "time_v_maxrss_kb" in r:
                extra = f"  (/usr/bin/time -v: {r['time_v_maxrss_kb'] * 1024 / 1e6:.1f} MB)"
            print(f"{label:44s} {mb:7.1f} MB {mib:6.1f} MiB {r['wall']:8.2f}s {per} "
                  f"{written / 1e6:9.1f} MB{extra}")
            results["runs"].append({"label": label, "steps": n, "peak_rss_mb": mb,
                                    "peak_rss_mib": mib, "csv_bytes": written, **r})
    big = [r for r in results["runs"] if r.get("steps") == 2_000_000 and "peak_rss_mb" in r]
    if big:
        mb = big[0]["peak_rss_mb"]
        print(f"\n2,000,000 steps: peak {mb:.1f} MB, target < {TARGET_MB:.0f} MB: "
              f"{'met' if mb < TARGET_MB else 'NOT met'}")
    la = os.getloadavg()
    results["machine"]["loadavg_end"] = la
    print(f"load avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}")
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2))
        print(f"results saved to {a.json}")


if __name__ == "__main__":
    main()
