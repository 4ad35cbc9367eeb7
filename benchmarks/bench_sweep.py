"""Throughput of a four-bar design sweep (variants per second, P + V + A over 360 steps),
planarkin against pylinkage with numba, the textbook solver and the closed form, in one run.

    python benchmarks/bench_sweep.py [--variants 10000] [--planarkin N] [--textbook 4]
                                     [--pylinkage-python /tmp/benchvenv/bin/python] [--numpy]
                                     [--rounds 5]

The sweep: the four-bar of benchmarks/models.py (crank a, coupler b, rocker c = 0.10, ground
d = 0.10), a full factorial of sqrt(V) crank lengths a in [0.03, 0.05] times sqrt(V) coupler
lengths b in [0.11, 0.13], each variant one crank turn at 360 steps with positions, velocities
and accelerations.

* pylinkage + numba (its own venv: `python -m venv /tmp/benchvenv && /tmp/benchvenv/bin/pip
  install pylinkage numba`; not a dependency of planarkin): `Linkage.step_fast_with_kinematics`
  (the numba-compiled solver with velocities and accelerations) in a Python loop over the
  variants, `set_constraints` per variant; the compile run excluded. All V variants.
* planarkin: `planarkin.studies.variants.Study.run` (what `planarkin sweep --jobs 1` runs: the
  variants batched, studies/batch.py, grid pass with P, V, A, a max metric) on all V variants,
  or with `--planarkin N` on N of them spread evenly over the factorial (a sparser sweep, whose
  neighbours are farther apart); variants/s extrapolates. The batch solves through the
  compiled route (planarkin/solver/compiled/gen_each.py on numba) when the sweep has at least
  kernel.COMPILED_FROM_POINTS rows (variants x grid times: 10,000 x 361 does), else through the
  numpy reference; `--numpy` also times the numpy reference (System.solve_batch, PLANARKIN_KERNEL=0:
  the reference route) in the same rounds and compares the outcomes.
  planarkin and pylinkage alternate, --rounds rounds; printed are the medians and every round.
* planarkin, the whole command (what issue 17 counts): `python -m planarkin sweep MODEL --vary
  a=0.03:0.05:S --vary b=0.11:0.13:S --metric max:rocker.phi -j 1 -q --no-plots` in a fresh
  process per round (interpreter start, imports, numba's import and cache loads, the model's
  checks, the solve, sweep.csv written), after one untimed run that fills the caches; in the
  same alternating rounds; `--jobs 2` also times it with -j 2. PYTHONDONTWRITEBYTECODE is
  dropped from its environment (an installed package has its bytecode; without it every run
  compiles planarkin's sources again, ~0.15 s). variants/s = V / the process's wall time.
* textbook: benchmarks/textbook.py per variant (per-step dense Newton) on `--textbook` variants.
* closed form: benchmarks/models.four_bar_closed_form per variant (vectorised over the grid).

Every rate is measured in this one run; the ratios are the figures to quote (the machine is
shared, absolute times vary). Rates are given per wall second and per CPU second of the process
(time.process_time; pylinkage's in its own process): on a machine shared with other jobs the
CPU-time ratio is the steadier one.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE))

import models  # noqa: E402

STEPS = 360

PYLINKAGE = r'''
import json, math, sys, time
import numpy as np
from pylinkage.components import Ground
from pylinkage.actuators import Crank
from pylinkage.dyads import RRRDyad
from pylinkage.simulation import Linkage
a_vals, b_vals, steps = json.loads(sys.argv[1])
c = d = 0.10
O1 = Ground(0.0, 0.0, name="A")
O2 = Ground(d, 0.0, name="D")
crank = Crank(anchor=O1, radius=a_vals[0], angular_velocity=2 * math.pi / steps)
rocker = RRRDyad(crank.output, O2, distance1=b_vals[0], distance2=c, x=0.05, y=0.1)
lk = Linkage([O1, O2, crank, rocker], name="four-bar")
lk.set_input_velocity(crank, omega=2 * math.pi)
base = lk.get_constraints()
init = lk.get_coords()
def one(a, b):
    cons = list(base)
    cons[0], cons[1] = a, b        # crank radius, coupler length (rocker length stays c)
    lk.set_constraints(cons)
    lk.set_coords(init)
    return lk.step_fast_with_kinematics(iterations=steps, dt=1.0)
pos, vel, acc = one(a_vals[0], b_vals[0])     # numba compile, excluded
t = time.perf_counter()
c = time.process_time()
n = 0
worst = 0
for a in a_vals:
    for b in b_vals:
        pos, vel, acc = one(a, b)
        n += 1
elapsed = time.perf_counter() - t
cpu = time.process_time() - c
print(json.dumps({"variants": n, "seconds": elapsed, "cpu": cpu, "constraints": list(base),
                  "nan": bool(np.isnan(pos).any()),
                  "last_C": [pos[-1, 3, 0], pos[-1, 3, 1]]}))
'''


def run_pylinkage(python: str, a_vals, b_vals):
    if not Path(python).exists():
        return None, f"{python} not found (install pylinkage + numba in their own venv)"
    r = subprocess.run([python, "-c", PYLINKAGE, json.dumps([list(a_vals), list(b_vals), STEPS])],
                       capture_output=True, text=True, timeout=3600)
    if r.returncode != 0:
        return None, r.stderr.strip().splitlines()[-1] if r.stderr else "failed"
    return json.loads(r.stdout), None


def median(xs):
    xs = sorted(xs)
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def closed_form_max(t_grid, a, b):
    """The rocker angle's largest value over the turn by the closed form: the grid's largest
    row, then Newton on the rocker's rate (its exact acceleration) to where the rate is zero,
    as planarkin's max: metric refines between rows (a grid's largest row is up to ~1e-5
    relative below it at 360 steps)."""
    cf = models.four_bar_closed_form(t_grid, a=a, b=b)
    t = float(t_grid[int(np.argmax(cf["q"][:, 8]))])
    for _ in range(20):
        c = models.four_bar_closed_form(np.array([t]), a=a, b=b)
        w4, a4 = float(c["qd"][0, 8]), float(c["qdd"][0, 8])
        if a4 >= 0:
            break
        step = w4 / a4
        t -= step
        if abs(step) <= 1e-15:
            break
    return float(models.four_bar_closed_form(np.array([t]), a=a, b=b)["q"][0, 8])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--planarkin", type=int, default=None,
                    help="variants planarkin solves (default: all)")
    ap.add_argument("--textbook", type=int, default=4)
    ap.add_argument("--pylinkage-python", default="/tmp/benchvenv/bin/python")
    ap.add_argument("--numpy", action="store_true",
                    help="also time planarkin's numpy passes (PLANARKIN_KERNEL=0)")
    ap.add_argument("--no-command", action="store_true",
                    help="leave out the whole `planarkin sweep --jobs 1` command")
    ap.add_argument("--jobs", type=int, default=1,
                    help="also time the whole command with -j JOBS (JOBS > 1)")
    ap.add_argument("--baseline", default=None,
                    help="a planarkin checkout whose whole command is also timed, alternating "
                         "(both then without bytecode files: nothing is written into it)")
    ap.add_argument("--rounds", type=int, default=5,
                    help="rounds of planarkin and pylinkage, alternating (medians printed)")
    args = ap.parse_args()
    side = int(round(args.variants ** 0.5))
    a_vals = np.linspace(0.03, 0.05, side)
    b_vals = np.linspace(0.11, 0.13, side)
    variants = [{"a": float(a), "b": float(b)} for a in a_vals for b in b_vals]
    t_grid = np.linspace(0, 1, STEPS + 1)
    print(f"four-bar sweep: {len(variants)} variants x {STEPS} steps (P, V, A); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; "
          f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    rates = {}
    cpu = {}        # variants per CPU second: less sensitive to the other jobs on the machine

    npk = len(variants) if args.planarkin is None else min(args.planarkin, len(variants))
    n = max(200, min(npk, 2000))

    # closed form
    t0, c0 = time.perf_counter(), time.process_time()
    for v in variants[:n]:
        models.four_bar_closed_form(t_grid, a=v["a"], b=v["b"])
    rates["closed form (numpy, per variant)"] = n / (time.perf_counter() - t0)
    cpu["closed form (numpy, per variant)"] = n / (time.process_time() - c0)

    # planarkin against pylinkage, alternating, --rounds rounds
    from planarkin.studies.variants import Study
    pl_rates, pl_cpu, why = [], [], None
    pk = {"planarkin Study.run (sweep --jobs 1)": ([], [])}
    if args.numpy:
        pk["planarkin, numpy passes (PLANARKIN_KERNEL=0)"] = ([], [])
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "four-bar.yaml"
        path.write_text(models.four_bar_yaml())
        study = Study(str(path), metrics=["max:rocker.phi"])
        sub = [variants[i] for i in np.linspace(0, len(variants) - 1, npk).astype(int)]
        study.units(sub)            # the route for this job's size: compiled or loaded here
        k = study.batch(sub).kernel()
        print("planarkin route: " + ("numpy passes" if k is None else "compiled (numba)"))
        study.run(sub[:2])

        cmd_keys = [] if args.no_command else [1] + ([args.jobs] if args.jobs > 1 else [])
        for j in cmd_keys:
            pk[f"planarkin sweep --jobs {j} (whole command)"] = ([], [])
        if args.baseline and cmd_keys:
            pk["baseline sweep --jobs 1 (whole command)"] = ([], [])
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        if args.baseline:
            env["PYTHONDONTWRITEBYTECODE"] = "1"
        env["PYTHONPATH"] = str(HERE.parent) + os.pathsep + env.get("PYTHONPATH", "")

        def command(j, root=None):
            """The whole `planarkin sweep -j j` in a fresh process: its rates (wall, and CPU
            of the process and its children) appended; the CSV's row count checked."""
            outdir = Path(d) / f"out{j}"
            argv = [sys.executable, "-m", "planarkin", "sweep", str(path),
                    "--vary", f"a=0.03:0.05:{side}", "--vary", f"b=0.11:0.13:{side}",
                    "--metric", "max:rocker.phi", "--out", str(outdir), "-j", str(j), "-q",
                    "--no-plots"]
            r0 = os.times()
            t0 = time.perf_counter()
            e = env if root is None else dict(env, PYTHONPATH=str(root))
            r = subprocess.run(argv, env=e, capture_output=True, text=True, timeout=3600)
            wall = time.perf_counter() - t0
            r1 = os.times()
            if r.returncode != 0:
                raise SystemExit(f"planarkin sweep failed: {r.stderr.strip()[-400:]}")
            rows = sum(1 for _ in open(outdir / path.stem / "sweep.csv")) - 1
            assert rows == side * side, rows
            c = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
            key = (f"planarkin sweep --jobs {j} (whole command)" if root is None
                   else "baseline sweep --jobs 1 (whole command)")
            pk[key][0].append(rows / wall)
            # (-j > 1: the workers are the forkserver's children, their CPU time not counted)
            pk[key][1].append(rows / c if j == 1 else float("nan"))

        runs = [(j, None) for j in cmd_keys] + (
            [(1, args.baseline)] if args.baseline and cmd_keys else [])
        for j, root in runs:        # caches filled (numba's, the bytecode), untimed
            command(j, root)
        for key in pk:
            if "whole command" in key:
                pk[key][0].clear()
                pk[key][1].clear()

        def timed(key):
            """study.run(sub), its rates appended under key (wall and CPU)."""
            t0, c0 = time.perf_counter(), time.process_time()
            res = study.run(sub)
            pk[key][0].append(len(sub) / (time.perf_counter() - t0))
            pk[key][1].append(len(sub) / (time.process_time() - c0))
            return res

        for _ in range(args.rounds):
            out = timed("planarkin Study.run (sweep --jobs 1)")
            for j, root in runs:
                command(j, root)
            if args.numpy:
                saved = os.environ.get("PLANARKIN_KERNEL")
                os.environ["PLANARKIN_KERNEL"] = "0"        # read per call
                try:
                    ref = timed("planarkin, numpy passes (PLANARKIN_KERNEL=0)")
                finally:
                    if saved is None:
                        del os.environ["PLANARKIN_KERNEL"]
                    else:
                        os.environ["PLANARKIN_KERNEL"] = saved
            res, why = run_pylinkage(args.pylinkage_python, a_vals, b_vals)
            if res is not None:
                pl_rates.append(res["variants"] / res["seconds"])
                pl_cpu.append(res["variants"] / res["cpu"])
        ok = sum(o.status == "ok" for o in out)
        err = 0.0
        for v, o in zip(sub, out):
            ref_v = closed_form_max(t_grid, v["a"], v["b"])
            err = max(err, abs(o.metrics[0] - ref_v) / abs(ref_v))
        print(f"planarkin: {ok}/{len(sub)} ok, max relative error of max:rocker.phi against the "
              f"closed form {err:.1e}")
        if args.numpy:
            same = all(a.status == b.status for a, b in zip(out, ref))
            dev = max((abs(x - y) / max(abs(y), 1e-300) for a, b in zip(out, ref)
                       for x, y in zip(a.metrics, b.metrics) if a.status == "ok"), default=0.0)
            print(f"planarkin compiled vs numpy passes: statuses equal {same}, largest relative "
                  f"metric difference {dev:.1e}")
    for key, (w, c) in pk.items():
        rates[key], cpu[key] = median(w), median(c)
        print(f"{key}: variants/s per round " + ", ".join(f"{x:.0f}" for x in w)
              + f" (median {median(w):.0f}, spread {min(w):.0f}-{max(w):.0f})")
    if pl_rates:
        key = "pylinkage + numba (step_fast_with_kinematics)"
        rates[key], cpu[key] = median(pl_rates), median(pl_cpu)
        print(f"{key}: variants/s per round " + ", ".join(f"{x:.0f}" for x in pl_rates)
              + f" (median {median(pl_rates):.0f}, spread {min(pl_rates):.0f}-"
                f"{max(pl_rates):.0f})")
        for k, (w, _) in pk.items():       # the ratio round by round (the sides alternate)
            print(f"{k} / pylinkage per round: "
                  + ", ".join(f"{x / y:.2f}" for x, y in zip(w, pl_rates)))
    else:
        print(f"pylinkage: not measured: {why}")

    # textbook (--textbook 0: left out)
    import textbook
    t0, c0 = time.perf_counter(), time.process_time()
    for v in variants[: args.textbook]:
        sysm = textbook.System.from_mechanism(models.four_bar_mechanism(a=v["a"], b=v["b"]))
        q0 = models.four_bar_closed_form(np.array([0.0]), a=v["a"], b=v["b"])["q"][0]
        textbook.solve(sysm, q0, t_grid)
    if args.textbook > 0:
        rates["textbook (per-step dense Newton)"] = args.textbook / (time.perf_counter() - t0)
        cpu["textbook (per-step dense Newton)"] = args.textbook / (time.process_time() - c0)

    print(f"load average after: {os.getloadavg()[0]:.1f}")
    key = "pylinkage + numba (step_fast_with_kinematics)"
    ref, cref = rates.get(key), cpu.get(key)
    print(f"\n{'solver':<48} {'variants/s':>12} {'us/step':>9} {'vs pylinkage':>13} "
          f"{'CPU variants/s':>15} {'vs pylinkage':>13}")
    for k, r in rates.items():
        rel = f"{r / ref:.3g}x" if ref else "-"
        crel = f"{cpu[k] / cref:.3g}x" if cref else "-"
        print(f"{k:<48} {r:12.1f} {1e6 / (r * (STEPS + 1)):9.2f} {rel:>13} {cpu[k]:15.1f} "
              f"{crel:>13}")


if __name__ == "__main__":
    main()
