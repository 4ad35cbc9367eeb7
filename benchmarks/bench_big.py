"""Big coupled mechanisms: time and peak memory of whole CLI runs (benchmarks/bigmodels.py).

    python benchmarks/bench_big.py [--quick] [--busy] [--baseline DIR] [--json PATH]

Runs, each in a fresh bare helper interpreter (peak RSS from RUSAGE_CHILDREN, as
bench_memory.py), `python -m planarkin run MODEL --no-plots --steps S --out TMP` with
PYTHONPATH = this checkout (never a console script that may belong to another checkout):

* arch of 100 links (300 coordinates, one block of 298) at 1,000 and 3,000 steps (memory must
  not grow with the step count), arch of 500 links (1,500 coordinates) at 1,000 steps;
* the arched ladder of 34 links (297 coordinates, one block) and the scissor lift of 300
  stages (1,800 coordinates, many small blocks) at 1,000 steps;
* `planarkin check` of the IFToMM N-four-bar chain N = 3000 (18,003 coordinates).

--busy repeats the 300-coordinate arch while a busy-loop process holds a core (the situation of
a CI job beside others). --baseline DIR runs the 150-coordinate arch (with --baseline-300 also
the 300-coordinate one) with the planarkin of another checkout DIR as well (e.g.
`git archive main | tar -x -C DIR`), in the same run.
Printed per run: wall and CPU seconds (user + sys: less sensitive to a shared machine), peak
RSS in MB (10^6 bytes), and the targets of issue 12 (300 coordinates: <= 5 s and <= 300 MB for
1,000 steps; 1,500 coordinates: < 60 s; the 18,003-coordinate check: < 500 MB).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bigmodels  # noqa: E402
import common  # noqa: E402
import models  # noqa: E402
from bench_memory import HELPER  # noqa: E402


def measure(args: list[str], checkout: Path) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(checkout)
    full = [sys.executable, "-m", "planarkin"] + args
    p = subprocess.run([sys.executable, "-S", "-c", HELPER, json.dumps(full), str(checkout)],
                       capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(f"helper failed: {p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="the 300-coordinate arch only")
    ap.add_argument("--busy", action="store_true", help="also with a core held by a busy loop")
    ap.add_argument("--baseline", metavar="DIR", help="another checkout to compare with")
    ap.add_argument("--baseline-300", action="store_true",
                    help="the baseline also at 300 coordinates (issue 12: 4.4 GB, minutes)")
    ap.add_argument("--json", metavar="PATH")
    a = ap.parse_args(argv)
    info = common.machine_info()
    common.print_header(info, "planarkin big-mechanism benchmark")
    results = {"machine": info, "runs": []}
    print(f"{'run':58s} {'wall':>8s} {'CPU':>8s} {'peak RSS':>10s}  result")
    with tempfile.TemporaryDirectory(prefix="planarkin-big-") as tmp:
        tmp = Path(tmp)
        files = {}
        for name, text in (("arch-50", bigmodels.arch_yaml(50)),
                           ("arch-100", bigmodels.arch_yaml(100)),
                           ("arch-500", bigmodels.arch_yaml(500)),
                           ("ladder-34", bigmodels.ladder_yaml(34)),
                           ("scissor-300", bigmodels.scissor_yaml(300)),
                           ("chain-3000", models.chain_yaml(3000))):
            files[name] = tmp / f"{name}.yaml"
            files[name].write_text(text)

        def run(label, model, steps=1000, checkout=common.ROOT, command="run"):
            out = tmp / "out"
            args = ([command, str(files[model])] if command == "check" else
                    ["run", str(files[model]), "--no-plots", "--steps", str(steps), "--out",
                     str(out)])
            r = measure(args, Path(checkout))
            mb = r["maxrss_kb"] * 1024 / 1e6
            cpu = r["user"] + r["sys"]
            res = "ok" if r["returncode"] == 0 else f"exit {r['returncode']}"
            found = list(out.rglob("summary.json")) if command == "run" else []
            if found:
                summary = json.loads(found[0].read_text())
                wt = summary.get("wall_time") or {}
                res += f" {summary.get('status')}: " + ", ".join(
                    f"{k} {v:.2f}" for k, v in wt.items() if isinstance(v, (int, float)))
            subprocess.run(["rm", "-rf", str(out)])
            print(f"{label:58s} {r['wall']:7.2f}s {cpu:7.2f}s {mb:7.1f} MB  {res}", flush=True)
            results["runs"].append({"label": label, "peak_rss_mb": mb, "cpu": cpu, **r})
            return r

        run("arch 300 coordinates (one block of 298), 1000 steps", "arch-100")
        run("arch 300 coordinates, 3000 steps", "arch-100", 3000)
        if a.busy:
            busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            try:
                run("arch 300 coordinates, 1000 steps, a busy loop on a core", "arch-100")
            finally:
                busy.kill()
                busy.wait()
        if a.baseline:
            run("arch 150 coordinates, 1000 steps [baseline]", "arch-50", checkout=a.baseline)
            run("arch 150 coordinates, 1000 steps", "arch-50")
            if a.baseline_300:
                run("arch 300 coordinates, 1000 steps [baseline]", "arch-100",
                    checkout=a.baseline)
        if not a.quick:
            run("arch 1500 coordinates (one block of 1498), 1000 steps", "arch-500")
            run("arched ladder 297 coordinates (one block), 1000 steps", "ladder-34")
            run("scissor lift 1800 coordinates (small blocks), 1000 steps", "scissor-300")
            run("check: N-four-bar chain N = 3000 (18,003 coordinates)", "chain-3000",
                command="check")
    la = os.getloadavg()
    results["machine"]["loadavg_end"] = la
    print(f"load avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}")
    print("targets (issue 12): 300 coordinates <= 5 s and <= 300 MB at 1000 steps, busy core "
          "or free; 1500 coordinates < 60 s; 18,003-coordinate check < 500 MB")
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
