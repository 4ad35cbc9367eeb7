"""Speed and accuracy of planarkin against a plain per-step numpy Newton solver and the closed
form, in one run.

    python benchmarks/bench_speed.py [--quick] [--json PATH] [--repeat N] [--chain N ...]

For the slider-crank, the four-bar and the IFToMM A02 N-four-bar chain it prints:

* closed form: the vectorised numpy closed form over the whole grid (best of `repeat`), us/step;
* textbook: benchmarks/textbook.py (per-step Newton on the dense Jacobian, numpy.linalg.solve)
  timed on the first K points of the same grid (same time step, so the same Newton work per
  step); its correctness is asserted against the closed form, for the slider-crank and the
  four-bar also over a whole turn at 360 steps;
* planarkin: planarkin.solve(model, steps=S), one warm-up call excluded, best of `repeat`,
  us/step = seconds / grid rows; with the split into assembly, path following and grid
  (dense output) from the result's timings;
* ratio textbook / planarkin per step and the max relative errors (P, V, A) of both against the
  closed form (see models.rel_error);
* for the chain: N = 10, 100, 1000 and the per-step ratio N=1000 / N=100;
* whole CLI: `planarkin run slider-crank.yaml --no-plots --steps S --out TMP`, wall time of
  subprocess.run (best of `repeat`), us/step, the CLI's fixed cost (the same with --steps 1),
  the ratio textbook / CLI per step, and the written bodies.csv checked against the closed form.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402  (puts the checkout on sys.path)
import models  # noqa: E402
import textbook  # noqa: E402

import planarkin  # noqa: E402

TEXTBOOK_TOL = 1e-8     # asserted max relative error of the textbook solver
WARN_TOL = 1e-8         # planarkin errors above this are flagged

FULL = dict(steps=200_000, tb_points=2000, tb_check=360, chain=(10, 100, 1000),
            chain_steps=1000, chain_tb_points={10: 1001, 100: 50, 1000: 3}, cli_steps=200_000)
QUICK = dict(steps=20_000, tb_points=300, tb_check=360, chain=(10, 100), chain_steps=200,
             chain_tb_points={10: 201, 100: 10, 1000: 2}, cli_steps=20_000)


def us(seconds: float, rows: int) -> float:
    return seconds / rows * 1e6


def fmt_err(e: dict) -> str:
    return f"P {e['P']:.1e}  V {e['V']:.1e}  A {e['A']:.1e}"


def flag(e: dict, tol=WARN_TOL) -> str:
    return "" if max(e.values()) <= tol else f"   ** above {tol:g} **"


def time_closed_form(cf, t, repeat):
    sec, c = common.best_of(lambda: cf(t), repeat)
    return sec, c


def time_textbook(mech, cf_full, t, K, predictor="taylor"):
    """Textbook solver on the first K points of grid t, from the exact pose at t[0]."""
    S = textbook.System.from_mechanism(mech)
    tk = t[:K]
    ref = {k: v[:K] for k, v in cf_full.items()}
    t0 = time.perf_counter()
    Q, Qd, Qdd, its = textbook.solve(S, ref["q"][0], tk, tol=1e-10 * mech.length,
                                     predictor=predictor)
    sec = time.perf_counter() - t0
    err = models.errors(Q, Qd, Qdd, ref)
    return {"points": int(K), "seconds": sec, "us_per_step": us(sec, K),
            "newton_mean": float(its.mean()), "predictor": predictor, "errors": err}


def textbook_check(mech, cf, steps):
    """Whole turn at `steps` steps: the textbook solver must agree with the closed form."""
    t = np.linspace(0.0, 1.0, steps + 1)
    r = time_textbook(mech, cf(t), t, len(t))
    assert max(r["errors"].values()) < TEXTBOOK_TOL, (mech.name, r["errors"])
    return r


def time_planarkin(text, name, steps, repeat):
    model = planarkin.load(f"{name}.yaml", text=text)
    planarkin.solve(model, steps=steps)                  # warm-up, excluded
    sec, res = common.best_of(lambda: planarkin.solve(model, steps=steps), repeat)
    if not res.success:
        raise RuntimeError(f"planarkin failed on {name}: {res.message}")
    return sec, res


def bench_mechanism(label, text, cf, mech, steps, tb_points, tb_check, repeat, out):
    print(f"== {label}: {steps} steps (t = 0..1 s, dt = {1 / steps:.3g} s) ==")
    t = np.linspace(0.0, 1.0, steps + 1)
    rows = len(t)
    sec_cf, c = time_closed_form(cf, t, repeat)
    print(f"  closed form (vectorised numpy)  {us(sec_cf, rows):10.3f} us/step")
    tb = time_textbook(mech, c, t, tb_points)
    assert max(tb["errors"].values()) < TEXTBOOK_TOL, (label, tb["errors"])
    tbp = time_textbook(mech, c, t, tb_points, predictor="previous")
    assert max(tbp["errors"].values()) < TEXTBOOK_TOL, (label, tbp["errors"])
    chk = textbook_check(mech, cf, tb_check)
    print(f"  textbook, Taylor predictor      {tb['us_per_step']:10.1f} us/step   "
          f"(first {tb['points']} steps; {tb['newton_mean']:.2f} Newton solves/step)   "
          f"{fmt_err(tb['errors'])}")
    print(f"  textbook, previous-step guess   {tbp['us_per_step']:10.1f} us/step   "
          f"(first {tbp['points']} steps; {tbp['newton_mean']:.2f} Newton solves/step)   "
          f"{fmt_err(tbp['errors'])}")
    print(f"  textbook, whole turn at {tb_check} steps {chk['us_per_step']:7.1f} us/step   "
          f"({chk['newton_mean']:.2f} Newton solves/step)   {fmt_err(chk['errors'])}   "
          f"(asserted < {TEXTBOOK_TOL:g})")
    sec_pk, res = time_planarkin(text, label, steps, repeat)
    err = models.errors(res.q, res.qd, res.qdd, models_cf_at(cf, res.t))
    tm = res.info.timings
    pk = us(sec_pk, rows)
    print(f"  planarkin.solve (best of {repeat})     {pk:10.3f} us/step   "
          f"({sec_pk:.3f} s: assembly {tm.get('assembly', 0):.3f}, path {tm.get('path', 0):.3f}"
          f" [{res.info.internal_steps} nodes], grid {tm.get('grid', 0):.3f})   "
          f"{fmt_err(err)}{flag(err)}")
    print(f"  ratio textbook / planarkin      {tb['us_per_step'] / pk:10.1f} x   "
          f"(previous-step textbook: {tbp['us_per_step'] / pk:.1f} x)")
    print()
    out[label] = {"steps": steps, "closed_form_us": us(sec_cf, rows), "textbook": tb,
                  "textbook_previous": tbp, "textbook_check": chk,
                  "planarkin_us": pk, "planarkin_seconds": sec_pk,
                  "planarkin_timings": dict(tm), "planarkin_errors": err,
                  "ratio_textbook_planarkin": tb["us_per_step"] / pk}
    return out[label]


def models_cf_at(cf, t):
    return cf(np.asarray(t))


def bench_chain(Ns, steps, tb_points, repeat, out):
    print(f"== IFToMM A02 N-four-bar chain (2N+1 bodies): {steps} steps "
          f"(theta = pi/2 + 0.5 sin 2 pi t) ==")
    t = np.linspace(0.0, 1.0, steps + 1)
    rows = len(t)
    res_all = {}
    for N in Ns:
        cf = lambda tt, N=N: models.chain_closed_form(tt, N)   # noqa: E731
        mech = models.chain_mechanism(N)
        sec_cf, c = time_closed_form(cf, t, repeat)
        K = min(tb_points.get(N, 3), rows)
        tb = time_textbook(mech, c, t, K)
        assert max(tb["errors"].values()) < TEXTBOOK_TOL, (N, tb["errors"])
        sec_pk, res = time_planarkin(models.chain_yaml(N), f"chain-{N}", steps, repeat)
        err = models.errors(res.q, res.qd, res.qdd, cf(res.t))
        tm = res.info.timings
        pk = us(sec_pk, rows)
        print(f"  N = {N:4d} ({2 * N + 1} bodies, {3 * (2 * N + 1)} coordinates)")
        print(f"    closed form                   {us(sec_cf, rows):12.3f} us/step")
        print(f"    textbook (Taylor)             {tb['us_per_step']:12.1f} us/step   "
              f"(first {K} steps; {tb['newton_mean']:.2f} Newton solves/step)   "
              f"{fmt_err(tb['errors'])}")
        print(f"    planarkin.solve (best of {repeat})   {pk:12.1f} us/step   "
              f"({sec_pk:.3f} s: assembly {tm.get('assembly', 0):.3f}, path "
              f"{tm.get('path', 0):.3f} [{res.info.internal_steps} nodes], grid "
              f"{tm.get('grid', 0):.3f})   {fmt_err(err)}{flag(err)}")
        print(f"    ratio textbook / planarkin    {tb['us_per_step'] / pk:12.1f} x")
        res_all[N] = {"closed_form_us": us(sec_cf, rows), "textbook": tb, "planarkin_us": pk,
                      "planarkin_seconds": sec_pk, "planarkin_timings": dict(tm),
                      "planarkin_errors": err, "ratio_textbook_planarkin":
                          tb["us_per_step"] / pk}
    if 100 in res_all and 1000 in res_all:
        a, b = res_all[100], res_all[1000]
        r = b["planarkin_us"] / a["planarkin_us"]
        sa = a["planarkin_timings"].get("assembly", 0)
        sb = b["planarkin_timings"].get("assembly", 0)
        r_na = (b["planarkin_seconds"] - sb) / max(a["planarkin_seconds"] - sa, 1e-300)
        print(f"  per-step ratio planarkin N=1000 / N=100: {r:.1f} x (target <= 20; 10x the "
              f"bodies); without assembly: {r_na:.1f} x")
        res_all["ratio_1000_100"] = r
        res_all["ratio_1000_100_without_assembly"] = r_na
    print()
    out["chain"] = {"steps": steps, "by_N": res_all}


def bench_cli(steps, repeat, tb_us, out):
    print(f"== whole CLI: planarkin run slider-crank.yaml --no-plots --steps {steps} ==")
    with tempfile.TemporaryDirectory(prefix="planarkin-bench-") as tmp:
        tmp = Path(tmp)
        model = tmp / "slider-crank.yaml"
        model.write_text(models.slider_crank_yaml())
        outdir = tmp / "out"
        args = ["run", str(model), "--no-plots", "--steps", str(steps), "--out", str(outdir)]
        common.run_cli(args)                               # warm the file cache, excluded
        runs = [common.run_cli(args)[:2] for _ in range(repeat)]
        walls = [w for w, _ in runs]
        wall, cpu = min(runs)
        cpu_best = min(c for _, c in runs)
        summary = json.loads((outdir / "slider-crank" / "summary.json").read_text())
        one = ["run", str(model), "--no-plots", "--steps", "1", "--out", str(tmp / "out1")]
        fixed_runs = [common.run_cli(one)[:2] for _ in range(repeat)]
        fixed = min(w for w, _ in fixed_runs)
        fixed_cpu = min(c for _, c in fixed_runs)
        ver = min(common.run_cli(["--version"])[0] for _ in range(repeat))
        # the file written must be exact too
        csv = outdir / "slider-crank" / "bodies.csv"
        size = csv.stat().st_size + (outdir / "slider-crank" / "points.csv").stat().st_size
        X = np.loadtxt(csv, delimiter=",", skiprows=1)
    rows = steps + 1
    cf = models.slider_crank_closed_form(X[:, 0])
    body = X[:, 1:].reshape(len(X), 3, 9)          # per body: x y phi vx vy w ax ay alpha
    q = body[:, :, 0:3].reshape(len(X), 9)
    qd = body[:, :, 3:6].reshape(len(X), 9)
    qdd = body[:, :, 6:9].reshape(len(X), 9)
    err = models.errors(q, qd, qdd, cf)
    per = us(wall, rows)
    marginal = (wall - fixed) / steps * 1e6
    marginal_cpu = (cpu_best - fixed_cpu) / steps * 1e6
    wt = summary.get("wall_time", {})
    print(f"  wall time (best of {repeat})           {wall:8.3f} s   ({', '.join(f'{w:.3f}' for w in walls)})")
    print(f"  per step                          {per:8.3f} us/step   (target <= 5)")
    print(f"  CPU time of the child (best)      {cpu_best:8.3f} s    {us(cpu_best, rows):.3f} us/step"
          f"   (user + sys; less sensitive to a busy machine)")
    print(f"  fixed cost (--steps 1)            {fixed:8.3f} s   (CPU {fixed_cpu:.3f} s; "
          f"planarkin --version: {ver:.3f} s)")
    print(f"  marginal cost per step            {marginal:8.3f} us/step   (CPU {marginal_cpu:.3f}"
          f" us/step): (run - fixed) / steps")
    print("  planarkin's own split (summary.json of the last run): "
          + ", ".join(f"{k} {v:.3f} s" for k, v in wt.items()))
    print(f"  written: {rows} rows, {size / 1e6:.1f} MB of CSV; bodies.csv vs closed form: "
          f"{fmt_err(err)}{flag(err, 1e-9)}")
    print(f"  ratio textbook (Taylor) / CLI     {tb_us / per:8.1f} x per step   (target >= 100)")
    print()
    out["cli"] = {"steps": steps, "wall_best": wall, "walls": walls, "us_per_step": per,
                  "cpu_best": cpu_best, "cpu_us_per_step": us(cpu_best, rows),
                  "fixed_cpu_seconds": fixed_cpu, "marginal_cpu_us_per_step": marginal_cpu,
                  "fixed_seconds": fixed, "version_seconds": ver, "marginal_us_per_step":
                      marginal, "summary_wall_time": wt, "csv_bytes": size, "csv_errors": err,
                  "ratio_textbook_cli": tb_us / per}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes, for a smoke run")
    ap.add_argument("--json", metavar="PATH", help="save the results as JSON")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions (best of)")
    ap.add_argument("--chain", type=int, nargs="+", metavar="N", help="chain sizes")
    a = ap.parse_args(argv)
    cfg = dict(QUICK if a.quick else FULL)
    if a.chain:
        cfg["chain"] = tuple(a.chain)
    info = common.machine_info()
    common.print_header(info, "planarkin speed benchmark" + (" (--quick)" if a.quick else ""))
    print("us/step = wall seconds / grid rows (steps + 1). Errors: max relative error against "
          "the closed form\n(per column, see benchmarks/models.py rel_error) of positions P, "
          "velocities V, accelerations A.\n")
    t_start = time.perf_counter()
    out = {"machine": info, "config": {k: (v if not isinstance(v, dict) else
                                           {str(kk): vv for kk, vv in v.items()})
                                       for k, v in cfg.items()}, "repeat": a.repeat}
    sc = bench_mechanism("slider-crank", models.slider_crank_yaml(),
                         models.slider_crank_closed_form, models.slider_crank_mechanism(),
                         cfg["steps"], cfg["tb_points"], cfg["tb_check"], a.repeat, out)
    bench_mechanism("four-bar", models.four_bar_yaml(), models.four_bar_closed_form,
                    models.four_bar_mechanism(), cfg["steps"], cfg["tb_points"],
                    cfg["tb_check"], a.repeat, out)
    bench_chain(cfg["chain"], cfg["chain_steps"], cfg["chain_tb_points"], a.repeat, out)
    # CLI per step against the textbook per step at the CLI's own time step
    tb_us = sc["textbook"]["us_per_step"]
    if cfg["cli_steps"] != cfg["steps"]:
        t = np.linspace(0, 1, cfg["cli_steps"] + 1)
        tb_us = time_textbook(models.slider_crank_mechanism(),
                              models.slider_crank_closed_form(t), t,
                              cfg["tb_points"])["us_per_step"]
    try:
        bench_cli(cfg["cli_steps"], a.repeat, tb_us, out)
    except (RuntimeError, OSError) as e:      # report, do not hide the other results
        msg = str(e).strip().splitlines()
        print("  ** the CLI run failed: " + "\n  ".join(msg[:2] + ["..."] + msg[-3:]))
        print()
        out["cli"] = {"error": str(e)}

    la = os.getloadavg()
    out["machine"]["loadavg_end"] = la
    out["total_seconds"] = time.perf_counter() - t_start
    print("== targets (issue) ==")
    cli = out["cli"]
    failed = "error" in cli
    rows = [
        ("whole CLI, slider-crank, us/step",
         "FAILED" if failed else f"{cli['us_per_step']:.2f}", "<= 5"),
        ("textbook / CLI per step",
         "FAILED" if failed else f"{cli['ratio_textbook_cli']:.0f} x", ">= 100"),
        ("planarkin.solve slider-crank, us/step", f"{sc['planarkin_us']:.2f}",
         "~0.7-0.9 (pylinkage+numba)"),
    ]
    ch = out["chain"]["by_N"]
    if "ratio_1000_100" in ch:
        rows.append(("chain per step N=1000 / N=100", f"{ch['ratio_1000_100']:.1f} x", "<= 20"))
    worst = max(max(v["planarkin_errors"].values()) for k, v in ch.items()
                if isinstance(v, dict))
    rows.append(("chain max relative error (P/V/A)", f"{worst:.1e}", "exact"))
    for name, val, target in rows:
        print(f"  {name:40s} {val:>12s}   target {target}")
    print(f"\nload avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}; total "
          f"{out['total_seconds']:.0f} s")
    if a.json:
        Path(a.json).write_text(json.dumps(out, indent=2, default=float))
        print(f"results saved to {a.json}")


if __name__ == "__main__":
    main()
