"""The process model against another checkout (issue 18's targets), sides alternating.

    python benchmarks/bench_process.py --baseline DIR [--rounds 5] [--batch 100]
                                       [--steps 200000] [--memory-steps 10000000] [--json PATH]

DIR: another checkout (e.g. a copy of main). Each figure is `python -m planarkin run ...` of
the checkout (PYTHONPATH = its root), wall time around the subprocess, sides alternating round
by round; printed: median, min-max spread, and the load average before and after.

1. four-bar default run with plots (target: no slower than the baseline);
2. slider-crank --no-plots at --steps N: microseconds per step end to end (target <= 2 us);
3. a batch of --batch models (the examples in turn) with plots: seconds per model (target: no
   slower than the baseline), and --no-plots once each for the plotting share;
4. peak memory of a --memory-steps run --no-plots, summed over the process and every
   descendant (VmRSS sampled from /proc every 10 ms), one round per side (target < 150 MB).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ["four-bar", "slider-crank", "six-bar", "quick-return", "boom", "trammel"]


# bytecode cached outside both checkouts (an installed planarkin has its .pyc files; a session
# that sets PYTHONDONTWRITEBYTECODE would compile every module of every run: 0.14 s a run)
PYCACHE = Path(tempfile.gettempdir()) / "planarkin-bench-pycache"


def _env(root: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(root), MPLBACKEND="Agg",
               PYTHONPYCACHEPREFIX=str(PYCACHE))
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


CPU: list = []     # user + system CPU seconds of each timed() run, in order


def timed(root: Path, args: list, cwd: Path) -> float:
    """Wall seconds of one run (its CPU seconds appended to CPU: on a shared machine the CPU
    time says what the wall time cannot, how much work the run did)."""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "planarkin", "run", *args], cwd=cwd, env=_env(root),
                   check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return wall


def _tree_rss(pid: int) -> int:
    """Resident set size (kB) of pid and all its descendants, from /proc."""
    kids: dict[int, list[int]] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                ppid = int(open(f"/proc/{d}/stat").read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            kids.setdefault(ppid, []).append(int(d))
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        todo += kids.get(p, [])
        try:
            for line in open(f"/proc/{p}/status"):
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        except OSError:
            pass
    return total


def memory(root: Path, steps: int, out: Path) -> dict:
    p = subprocess.Popen([sys.executable, "-m", "planarkin", "run",
                          str(root / "mechanisms" / "slider-crank.yaml"), "--no-plots",
                          "--steps", str(steps), "--max-rows", str(steps + 1), "-q",
                          "--out", str(out)], env=_env(root),
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    peak, t0 = 0, time.perf_counter()
    while p.poll() is None:
        peak = max(peak, _tree_rss(p.pid))
        time.sleep(0.01)
    wall = time.perf_counter() - t0
    shutil.rmtree(out, ignore_errors=True)
    return {"sum_peak_mb": peak * 1024 / 1e6, "wall": wall}


def _stats(v: list) -> dict:
    return {"median": statistics.median(v), "min": min(v), "max": max(v), "all": v}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, required=True)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--batch", type=int, default=100)
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--memory-steps", type=int, default=10_000_000)
    ap.add_argument("--skip", nargs="*", default=[], choices=["plots", "steps", "batch",
                                                               "memory"])
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    sides = {"this": ROOT, "baseline": a.baseline.resolve()}
    tmp = Path(tempfile.mkdtemp(prefix="bench-process-"))
    res: dict = {"load_before": os.getloadavg(), "cores": os.cpu_count()}
    print(f"load average {res['load_before'][0]:.2f} on {res['cores']} cores; this = {ROOT}, "
          f"baseline = {sides['baseline']}")

    def rounds(name, args_of, cwd_of=lambda root: root):
        got = {s: [] for s in sides}
        cpu = {s: [] for s in sides}
        for _ in range(a.rounds):
            for s, root in sides.items():
                got[s].append(timed(root, args_of(s, root), cwd_of(root)))
                cpu[s].append(CPU[-1])
        out = {s: _stats(v) for s, v in got.items()}
        for s in sides:
            out[s]["cpu"] = _stats(cpu[s])
        return out

    def show(title, r, scale=1.0, unit="s"):
        print(title)
        for s in sides:
            st = r[s]
            c = st["cpu"]
            print(f"  {s:<9} median {st['median'] * scale:8.3f} {unit}   spread "
                  f"{st['min'] * scale:.3f}-{st['max'] * scale:.3f}   CPU median "
                  f"{c['median'] * scale:.3f} {unit} ({c['min'] * scale:.3f}-"
                  f"{c['max'] * scale:.3f})")
        print(f"  ratio this/baseline {r['this']['median'] / r['baseline']['median']:.2f} (CPU "
              f"{r['this']['cpu']['median'] / r['baseline']['cpu']['median']:.2f})")

    if "plots" not in a.skip:
        r = rounds("plots", lambda s, root: [str(root / "mechanisms" / "four-bar.yaml"), "-q",
                                             "--out", str(tmp / f"fb-{s}")])
        res["four_bar_plots"] = r
        show(f"four-bar default run with plots, {a.rounds} rounds:", r)
    if "steps" not in a.skip:
        r = rounds("steps", lambda s, root: [str(root / "mechanisms" / "slider-crank.yaml"),
                                             "--no-plots", "--steps", str(a.steps), "-q",
                                             "--out", str(tmp / f"sc-{s}")])
        res["slider_crank_steps"] = r
        show(f"slider-crank --no-plots --steps {a.steps}, end to end, per step:", r,
             1e6 / a.steps, "us")
    if "batch" not in a.skip:
        src = tmp / "models"
        src.mkdir()
        files = []
        for k in range(a.batch):
            f = src / f"{k:03d}-{EXAMPLES[k % len(EXAMPLES)]}.yaml"
            shutil.copy(ROOT / "mechanisms" / f"{EXAMPLES[k % len(EXAMPLES)]}.yaml", f)
            files.append(str(f))
        r = rounds("batch", lambda s, root: [*files, "-q", "--out", str(tmp / f"b-{s}")])
        res["batch_plots"] = r
        show(f"batch of {a.batch} models with plots, per model:", r, 1e3 / a.batch, "ms")
        nop = {s: timed(root, [*files, "-q", "--no-plots", "--out", str(tmp / f"bn-{s}")], root)
               for s, root in sides.items()}
        res["batch_no_plots"] = nop
        print("  --no-plots once: " + ", ".join(f"{s} {v * 1e3 / a.batch:.0f} ms per model"
                                               for s, v in nop.items()))
    if "memory" not in a.skip:
        m = {s: memory(root, a.memory_steps, tmp / f"m-{s}") for s, root in sides.items()}
        res["memory"] = m
        print(f"slider-crank --no-plots --steps {a.memory_steps}, peak memory:")
        for s, v in m.items():
            print(f"  {s:<9} summed over processes {v['sum_peak_mb']:.0f} MB (sampled), "
                  f"{v['wall']:.1f} s "
                  f"({v['wall'] * 1e6 / a.memory_steps:.2f} us per step)")
    res["load_after"] = os.getloadavg()
    print(f"load average after {res['load_after'][0]:.2f}")
    shutil.rmtree(tmp, ignore_errors=True)
    if a.json:
        a.json.write_text(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
