"""What plots cost: a default `planarkin run` with plots against `--no-plots`, a batch of models
in one call with and without plots, and each figure drawn in process.

    python benchmarks/bench_plots.py [--repeat 5] [--batch 200] [--quick] [--json PATH]
                                     [--baseline DIR] [--figures-baseline DIR] [--only-figures]

Every ratio is measured in this one run, the runs with and without plots interleaved (a busy
machine slows both alike). Targets (issue 12): a default run of mechanisms/four-bar.yaml with
plots <= 2x its --no-plots time; a 200-model batch with plots <= 0.3 s of plotting per model.
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import ROOT, machine_info, print_header, run_cli  # noqa: E402


def _this_checkout():
    """`python -m planarkin` of this checkout: a `planarkin` console script on PATH may belong
    to another checkout (an editable install), and this benchmark measures this one."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"]
                                     if env.get("PYTHONPATH") else "")
    return [sys.executable, "-m", "planarkin"], env


common.planarkin_command = _this_checkout

EXAMPLES = ["four-bar", "slider-crank", "six-bar", "quick-return", "boom", "trammel"]
# --figures-baseline: the examples above, a cam and two with gears or belts
FIGURE_EXAMPLES = EXAMPLES + ["cam-roller", "planetary", "belt-drive"]


def single(model: str, repeat: int, tmp: Path) -> dict:
    """Median wall time of `planarkin run MODEL` with plots and with --no-plots, interleaved."""
    walls = {"plots": [], "no-plots": []}
    cpus = {"plots": [], "no-plots": []}
    args = ["run", str(ROOT / "mechanisms" / f"{model}.yaml"), "--quiet"]
    run_cli(args + ["--out", str(tmp / "warm")])                        # warm the file cache
    for _ in range(repeat):
        for kind, extra in (("plots", []), ("no-plots", ["--no-plots"])):
            w, cpu, _ = run_cli(args + extra + ["--out", str(tmp / kind)])
            walls[kind].append(w)
            cpus[kind].append(cpu)
    with open(tmp / "plots" / model / "summary.json") as f:
        inner = json.load(f)["wall_time"].get("plots")
    med = {k: statistics.median(v) for k, v in walls.items()}
    cpu = {k: statistics.median(v) for k, v in cpus.items()}
    return {"model": model, "walls": walls, "median": med, "cpus": cpus, "cpu_median": cpu,
            "ratio": med["plots"] / med["no-plots"], "cpu_ratio": cpu["plots"] / cpu["no-plots"],
            "plots_wait_last": inner}


def _batch_files(src: Path, n: int) -> list[str]:
    """n model files in src: copies of the examples in turn."""
    src.mkdir(exist_ok=True)
    files = []
    for k in range(n):
        name = EXAMPLES[k % len(EXAMPLES)]
        f = src / f"{k:03d}-{name}.yaml"
        shutil.copy(ROOT / "mechanisms" / f"{name}.yaml", f)
        files.append(str(f))
    return files


def _timed_run(root: Path, args: list) -> tuple:
    """(wall, CPU) seconds of `python -m planarkin run ARGS` of the checkout at root."""
    import resource
    env = dict(os.environ, PYTHONPATH=str(root))
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "planarkin", "run", *args], cwd=root, env=env,
                   check=True, capture_output=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime


def against(baseline: Path, repeat: int, tmp: Path) -> dict:
    """The default four-bar run with and without plots, this checkout and another one (e.g. a
    `git archive` of main), all four interleaved: wall and CPU medians."""
    trees = {"this": ROOT, "baseline": baseline}
    got: dict = {}
    for _ in range(repeat):
        for name, root in trees.items():
            for kind, extra in (("plots", []), ("no-plots", ["--no-plots"])):
                got.setdefault(name, {}).setdefault(kind, []).append(_timed_run(
                    root, [str(root / "mechanisms" / "four-bar.yaml"), "-q", "--out",
                           str(tmp / f"vs-{name}-{kind}")] + extra))
    out = {}
    for name, kinds in got.items():
        med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
               for k, v in kinds.items()}
        out[name] = {"median": med, "ratio_wall": med["plots"][0] / med["no-plots"][0],
                     "ratio_cpu": med["plots"][1] / med["no-plots"][1],
                     "plot_cpu": med["plots"][1] - med["no-plots"][1]}
    return out


def batch_against(baseline: Path, n: int, tmp: Path, rounds: int = 2) -> dict:
    """The n-model batch of `batch`, with plots and with --no-plots, this checkout and another
    one in turn (rounds times, interleaved): plotting per model, wall and CPU (medians)."""
    files = _batch_files(tmp / "models-against", n)
    got: dict = {}
    for _ in range(rounds):
        for who, root in (("this", ROOT), ("baseline", baseline)):
            for kind, extra in (("plots", []), ("no-plots", ["--no-plots"])):
                got.setdefault(who, {}).setdefault(kind, []).append(_timed_run(
                    root, [*files, "-q", "--out", str(tmp / f"ba-{who}-{kind}")] + extra))
    out = {}
    for who, kinds in got.items():
        med = {k: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v))
               for k, v in kinds.items()}
        out[who] = {"median": med,
                    "per_model_wall": (med["plots"][0] - med["no-plots"][0]) / n,
                    "per_model_cpu": (med["plots"][1] - med["no-plots"][1]) / n}
    out["models"] = n
    return out


def batch(n: int, tmp: Path) -> dict:
    """One call with n model files (the examples in turn), with plots and with --no-plots."""
    files = _batch_files(tmp / "models", n)
    out = {}
    for kind, extra in (("no-plots", ["--no-plots"]), ("plots", [])):
        w, cpu, _ = run_cli(["run"] + files + extra + ["--quiet", "--out", str(tmp / f"batch-{kind}")])
        out[kind] = {"wall": w, "cpu": cpu}
    waits = []
    for f in files:
        with open(tmp / "batch-plots" / Path(f).stem / "summary.json") as fh:
            waits.append(json.load(fh)["wall_time"]["plots"])
    out["models"] = n
    out["per_model_extra"] = (out["plots"]["wall"] - out["no-plots"]["wall"]) / n
    out["per_model_extra_cpu"] = (out["plots"]["cpu"] - out["no-plots"]["cpu"]) / n
    out["per_model_wait_mean"] = statistics.mean(waits)
    out["per_model_wait_max"] = max(waits)
    return out


def _cold(mod) -> None:
    """Forget the texts a plots module has rasterised in this process (`plots.TEXTS`), so that
    a repeated figure costs what its first drawing in a fresh process does."""
    for name in ("TEXTS", "_TEXTS"):            # (the name before the plots package)
        getattr(mod, name, {}).clear()


def in_process(models, repeat: int, tmp: Path) -> list[dict]:
    """Per figure: best-of-repeat seconds to build and write it in this process (wall and CPU:
    on a busy machine the CPU seconds are the steadier figure), each time without the texts
    rasterised before (`_cold`)."""
    import planarkin
    from planarkin.output import plots
    rows = []
    t0, c0 = time.perf_counter(), time.process_time()
    import matplotlib.figure  # noqa: F401
    import matplotlib.backends.backend_agg  # noqa: F401
    rows.append({"model": "-", "figure": "import matplotlib", "seconds": time.perf_counter() - t0,
                 "cpu": time.process_time() - c0})
    for name in models:
        cm = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
        t0, c0 = time.perf_counter(), time.process_time()
        res = planarkin.solve(cm)
        rows.append({"model": name, "figure": "solve (in process)",
                     "seconds": time.perf_counter() - t0, "cpu": time.process_time() - c0})
        d = tmp / f"fig-{name}"
        d.mkdir(exist_ok=True)
        for fig in plots.figure_names(cm) + ["animation.gif"]:
            best = cpu = float("inf")
            for _ in range(repeat):
                _cold(plots)
                t0, c0 = time.perf_counter(), time.process_time()
                if fig == "animation.gif":
                    plots.write_animation(cm, res._chunk, d)
                else:
                    plots.write_plots(cm, res._chunk, res.info, d, only=[fig])
                best = min(best, time.perf_counter() - t0)
                cpu = min(cpu, time.process_time() - c0)
            rows.append({"model": name, "figure": fig, "seconds": best, "cpu": cpu})
    return rows


def _baseline_plots(tree: Path):
    """The plots module of another checkout (e.g. `git archive main | tar -x -C /tmp/base`),
    loaded beside this checkout's as planarkin.output._baseline_plots: its relative imports
    resolve to this checkout's package, so only plots.py differs (the comparison is meant for
    changes to the figures themselves)."""
    import importlib.util

    import planarkin.output
    src = tree / "planarkin" / "output" / "plots.py"
    spec = importlib.util.spec_from_file_location("planarkin.output._baseline_plots", src)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    planarkin.output._baseline_plots = mod
    return mod


def figures_against(baseline: Path, models, repeat: int, tmp: Path) -> list[dict]:
    """Per model and figure: best-of-repeat CPU seconds of write_plots(only=[figure]) in this
    process, this checkout's plots.py and the baseline's, alternating call by call (so that a
    busy machine slows both alike), each without the texts rasterised before (`_cold`: as
    the first figure drawn in a fresh process); the png files' sizes."""
    import planarkin
    from planarkin.output import plots
    base = _baseline_plots(baseline)
    import matplotlib.figure  # noqa: F401
    rows = []
    for name in models:
        cm = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
        res = planarkin.solve(cm)
        dirs = {"this": tmp / f"ab-this-{name}", "baseline": tmp / f"ab-base-{name}"}
        for d in dirs.values():
            d.mkdir(exist_ok=True)
        for fig in plots.figure_names(cm):
            cpu = {"this": float("inf"), "baseline": float("inf")}
            for _ in range(repeat):
                for who, mod in (("baseline", base), ("this", plots)):
                    _cold(mod)
                    c0 = time.process_time()
                    mod.write_plots(cm, res._chunk, res.info, dirs[who], only=[fig])
                    cpu[who] = min(cpu[who], time.process_time() - c0)
            size = {k: (d / f"{fig}.png").stat().st_size for k, d in dirs.items()}
            rows.append({"model": name, "figure": fig, "cpu": cpu, "bytes": size})
    return rows


def forces_against(baseline: Path, repeat: int, tmp: Path) -> dict:
    """forces.png of the slider-crank (the example with masses): CPU seconds, best of repeat,
    with this checkout's forces/plot.py and output/plots.py and with the baseline's (its
    forces/plot.py loaded beside this one's, its `..output.plots` import pointed at the
    baseline's plots module for the duration of its call), alternating call by call."""
    import contextlib
    import importlib.util

    import planarkin
    from planarkin.derived import derived_tables
    from planarkin.forces import plot as this_plot
    from planarkin.output import plots
    base_plots = sys.modules.get("planarkin.output._baseline_plots") or _baseline_plots(baseline)
    spec = importlib.util.spec_from_file_location(
        "planarkin.forces._baseline_plot", baseline / "planarkin" / "forces" / "plot.py")
    base_plot = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = base_plot
    spec.loader.exec_module(base_plot)

    @contextlib.contextmanager
    def baseline_plots():
        sys.modules["planarkin.output.plots"] = base_plots
        try:
            yield
        finally:
            sys.modules["planarkin.output.plots"] = plots

    cm = planarkin.load(ROOT / "mechanisms" / "slider-crank.yaml")
    res = planarkin.solve(cm)
    (d,) = derived_tables(res.model, res.info.options)
    X = d.compute(res._chunk)
    cpu = {"this": float("inf"), "baseline": float("inf")}
    for _ in range(repeat):
        for who, mod, ctx in (("baseline", base_plot, baseline_plots),
                              ("this", this_plot, contextlib.nullcontext)):
            out = tmp / f"forces-{who}"
            out.mkdir(exist_ok=True)
            _cold(plots)
            with ctx():
                c0 = time.process_time()
                mod.forces_plot(res.model, X, res.info, out, "png")
                cpu[who] = min(cpu[who], time.process_time() - c0)
    return cpu


def png_encoders(repeat: int, tmp: Path) -> dict:
    """The four-bar's bodies.png drawn once, its Agg buffer encoded by Pillow at zlib level 1
    (RGB, what main's plots._save did) and by plots.write_png: CPU seconds (best of repeat)
    and file sizes."""
    import planarkin
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image

    from planarkin.output import plots
    cm = planarkin.load(ROOT / "mechanisms" / "four-bar.yaml")
    res = planarkin.solve(cm)
    fig = plots.bodies_figure(cm, res._chunk, res.info)
    fig.set_dpi(plots.DPI)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    buf = canvas.buffer_rgba()
    size = canvas.get_width_height()

    def pillow(path):
        Image.frombuffer("RGBA", size, buf, "raw", "RGBA", 0, 1).convert("RGB").save(
            path, format="png", compress_level=1, dpi=(plots.DPI, plots.DPI))

    def ours(path):
        plots.write_png(path, buf, plots.DPI)

    out = {}
    for _ in range(repeat):
        for name, fn in (("Pillow level 1", pillow), ("_write_png", ours)):
            path = tmp / f"enc-{name[:6]}.png"
            c0 = time.process_time()
            fn(path)
            c = time.process_time() - c0
            r = out.setdefault(name, {"cpu": float("inf"), "bytes": 0})
            r["cpu"] = min(r["cpu"], c)
            r["bytes"] = path.stat().st_size
    out["pixels"] = size
    return out


def print_extras(f, e, repeat) -> None:
    print(f"== forces.png of the slider-crank, this against the baseline, best of {repeat}: "
          f"{f['baseline']:.3f} s -> {f['this']:.3f} s CPU ({f['this'] / f['baseline']:.2f}x) ==")
    w, h = e["pixels"]
    print(f"== png encoding of bodies.png ({w} x {h}), best of {repeat}: " + ", ".join(
        f"{k} {v['cpu'] * 1000:.1f} ms CPU, {v['bytes'] / 1024:.0f} kB"
        for k, v in e.items() if k != "pixels") + " ==")
    print()


def print_figures_against(rows, baseline, repeat) -> None:
    print(f"== in process, this plots.py against {baseline}'s, alternating call by call, "
          f"best of {repeat}: CPU s (png kB) ==")
    print(f"  {'model':<14} {'figure':<13} {'baseline':>16} {'this':>16}  ratio")
    tot: dict = {}
    for r in rows:
        c, b = r["cpu"], r["bytes"]
        t = tot.setdefault(r["model"], {"this": 0.0, "baseline": 0.0})
        for k in t:
            t[k] += c[k]
        kb = {k: v / 1024 for k, v in b.items()}
        print(f"  {r['model']:<14} {r['figure']:<13} {c['baseline']:7.3f} ({kb['baseline']:5.0f})"
              f" {c['this']:7.3f} ({kb['this']:5.0f})  {c['this'] / c['baseline']:.2f}")
    for m, t in tot.items():
        print(f"  {m:<14} {'all four':<13} {t['baseline']:7.3f}         {t['this']:7.3f}"
              f"          {t['this'] / t['baseline']:.2f}")
    print()


def figures_report(baseline: Path, repeat: int, tmp: Path) -> dict:
    """Each figure, forces.png and the png encoders, this plots.py against baseline's: printed,
    and returned for --json."""
    ab = figures_against(baseline.resolve(), FIGURE_EXAMPLES, repeat, tmp)
    print_figures_against(ab, baseline, repeat)
    ab = {"figures": ab, "forces": forces_against(baseline.resolve(), repeat, tmp),
          "png": png_encoders(repeat, tmp)}
    print_extras(ab["forces"], ab["png"], repeat)
    return ab


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--batch", type=int, default=200)
    ap.add_argument("--quick", action="store_true", help="3 repeats, a batch of 24")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--baseline", type=Path, help="another checkout (e.g. `git archive main`) "
                    "to compare the default four-bar run and a batch (of at most 24 models) "
                    "with, interleaved")
    ap.add_argument("--figures-baseline", type=Path, help="another checkout whose plots.py "
                    "draws the same figures in this process, alternating with this one's")
    ap.add_argument("--only-figures", action="store_true", help="with --figures-baseline: "
                    "that comparison only")
    a = ap.parse_args()
    if a.quick:
        a.repeat, a.batch = 3, 24
    info = machine_info()
    print_header(info, "planarkin plot benchmark")
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-plots-") as tmp:
        tmp = Path(tmp)
        ab = None
        if a.figures_baseline and a.only_figures:
            ab = figures_report(a.figures_baseline, a.repeat, tmp)
            if a.json:
                a.json.write_text(json.dumps({"machine": info, "figures_against": ab}, indent=1))
            return
        s = single("four-bar", a.repeat, tmp)
        m = s["median"]
        print(f"== planarkin run mechanisms/four-bar.yaml (default 360 steps), median of "
              f"{a.repeat}, interleaved ==")
        print(f"  with plots      {m['plots']:.3f} s   ({', '.join(f'{w:.2f}' for w in s['walls']['plots'])})")
        print(f"  --no-plots      {m['no-plots']:.3f} s   ({', '.join(f'{w:.2f}' for w in s['walls']['no-plots'])})")
        print(f"  ratio           {s['ratio']:.2f} x   (target <= 2)")
        c = s["cpu_median"]
        print(f"  CPU (all processes of the run, median): with plots {c['plots']:.3f} s, "
              f"--no-plots {c['no-plots']:.3f} s, ratio {s['cpu_ratio']:.2f} x")
        print(f"  waited for the plots at the end (summary.json wall_time.plots, last run): "
              f"{s['plots_wait_last']:.3f} s")
        print()
        if a.baseline:
            v = against(a.baseline.resolve(), a.repeat, tmp)
            print(f"== this checkout against {a.baseline}: four-bar, median of {a.repeat}, "
                  f"interleaved ==")
            for name, r in v.items():
                (wp, cp), (wn, cn) = r["median"]["plots"], r["median"]["no-plots"]
                print(f"  {name:<9} plots {wp:.2f} s ({cp:.2f} s CPU), --no-plots {wn:.2f} s "
                      f"({cn:.2f} s CPU): ratio {r['ratio_wall']:.2f} x wall, "
                      f"{r['ratio_cpu']:.2f} x CPU; plots cost {r['plot_cpu']:.2f} s CPU")
            print()
        if a.baseline and a.batch:
            n = min(a.batch, 24)
            v = batch_against(a.baseline.resolve(), n, tmp)
            print(f"== batch of {n} models, this checkout against {a.baseline}, median of 2, "
                  f"interleaved ==")
            for who in ("this", "baseline"):
                r = v[who]
                (wp, cp), (wn, cn) = r["median"]["plots"], r["median"]["no-plots"]
                print(f"  {who:<9} plots {wp:.2f} s ({cp:.2f} s CPU), --no-plots {wn:.2f} s "
                      f"({cn:.2f} s CPU): plotting per model {r['per_model_wall']:.3f} s wall, "
                      f"{r['per_model_cpu']:.3f} s CPU")
            print()
        b = batch(a.batch, tmp) if a.batch else None
        if b is not None:
            print(f"== batch: {b['models']} models (the six examples in turn) in one call ==")
            print(f"  --no-plots      {b['no-plots']['wall']:.2f} s wall, "
                  f"{b['no-plots']['cpu']:.2f} s CPU")
            print(f"  with plots      {b['plots']['wall']:.2f} s wall, "
                  f"{b['plots']['cpu']:.2f} s CPU")
            print(f"  plotting per model: {b['per_model_extra']:.3f} s (wall difference / "
                  f"models; target <= 0.3), CPU {b['per_model_extra_cpu']:.3f} s")
            print(f"  waited for the plots per model (summary.json): mean "
                  f"{b['per_model_wait_mean']:.3f} s, max {b['per_model_wait_max']:.3f} s")
            print()
        rows = in_process(EXAMPLES, 1 if a.quick else 3, tmp)
        print("== in process, one figure at a time (best of "
              f"{1 if a.quick else 3}), seconds: wall  CPU ==")
        for r in rows:
            print(f"  {r['model']:<14} {r['figure']:<20} {r['seconds']:.3f}  {r['cpu']:.3f}")
        if a.figures_baseline:          # (after in_process, which times matplotlib's import)
            print()
            ab = figures_report(a.figures_baseline, a.repeat, tmp)
    la = os.getloadavg()
    print(f"\nload avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}; total "
          f"{time.perf_counter() - t_all:.0f} s")
    if a.json:
        a.json.write_text(json.dumps({"machine": info, "single": s, "batch": b,
                                      "in_process": rows, "figures_against": ab}, indent=1))


if __name__ == "__main__":
    main()
