"""planarkin against pylinkage + numba and the closed form, in one script and one run.

    python benchmarks/bench_peers.py [--steps 200000] [--rounds 5] [--peer-python PATH]

Per mechanism (the slider-crank and the four-bar of models.py, one crank turn in t = 0..1 s on
a grid of --steps intervals), positions + velocities + accelerations:

* closed form: the vectorised numpy closed forms of models.py over the whole grid (the floor);
* planarkin: `planarkin.solve(model, steps=S)` in process (model loaded once, one warm-up call),
  by each grid-pass route of --routes: compiled (the numba route through planarkin/solver/compiled/kernel.py,
  taken whatever the job's size: the kernel generated for the structure, planarkin/solver/compiled/gen.py;
  compiled or loaded from numba's cache by the warm-up call), numpy (PLANARKIN_KERNEL=0: the numpy
  reference, System._solve_batch, the only numpy solve since issue 17 folded the fused passes
  into it), default (nothing forced: what a Python session gets, the route chosen by the
  solve's size and, from the second call on, by the session's solves of the structure added up:
  see planarkin/solver/compiled/kernel.py, route; the forced routes' solves are not counted);
* pylinkage + numba: `Linkage.step_fast_with_kinematics(S)` (pylinkage's numba-compiled
  simulation with velocities and accelerations) on the same mechanism and step, built and
  compiled once; the JIT start-up (first call) is reported separately and not counted.

pylinkage and numba are not planarkin dependencies: they live in their own environment, whose
interpreter is --peer-python (default /tmp/benchvenv/bin/python, made with
`python -m venv /tmp/benchvenv && /tmp/benchvenv/bin/pip install pylinkage numba pyyaml
scipy`);
this script runs a worker there. The measurements alternate between planarkin and pylinkage,
--rounds times; printed are each one's median wall time per step (with the spread of the
rounds, min-max) and median CPU time per step, and the ratio planarkin / pylinkage per step
from the medians. Errors: max relative error against
the closed form (models.rel_error) of the points both compute (the crank pin and the slider /
rocker pin), at each row's own crank angle.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

# The worker runs in the peer environment: numpy, pylinkage, numba, models.py only.
WORKER = r"""
import json, math, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
import models
import pylinkage as pl
from pylinkage.simulation import Linkage
name, steps, rounds = sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
w = 2 * math.pi

def build():
    if name == "four-bar":
        A = pl.Ground(0.0, 0.0, name="A"); D = pl.Ground(models.FB_D, 0.0, name="D")
        crank = pl.Crank(anchor=A, radius=models.FB_A, angular_velocity=w / steps, name="B")
        C = pl.RRRDyad(anchor1=crank.output, anchor2=D, distance1=models.FB_B,
                       distance2=models.FB_C, x=0.06, y=0.1, name="C")
        L = Linkage([A, D, crank, C], name="four-bar")
    else:
        O = pl.Ground(0.0, 0.0, name="O"); g1 = pl.Ground(0.0, 0.0, name="g1")
        g2 = pl.Ground(1.0, 0.0, name="g2")
        crank = pl.Crank(anchor=O, radius=models.SC_R, angular_velocity=w / steps, name="A")
        B = pl.RRPDyad(revolute_anchor=crank.output, line_anchor1=g1, line_anchor2=g2,
                       distance=models.SC_L, x=0.4, y=0.0, name="B")
        L = Linkage([O, g1, g2, crank, B], name="slider-crank")
    L.set_input_velocity(crank, omega=w, alpha=0.0)
    L.compile()
    return L

t0 = time.perf_counter()
build().step_fast_with_kinematics(iterations=10, dt=1)
jit = time.perf_counter() - t0
# one round per line on stdin: the parent alternates with planarkin
out = {"jit": jit, "wall": [], "cpu": []}
for _ in range(rounds):
    sys.stdin.readline()
    L = build()
    c0, t0 = time.process_time(), time.perf_counter()
    p, v, a = L.step_fast_with_kinematics(iterations=steps + 1, dt=1)
    out["wall"].append(time.perf_counter() - t0)
    out["cpu"].append(time.process_time() - c0)
    print("done", flush=True)
# accuracy: each row at its own crank angle
ip = 2 if name == "four-bar" else 3          # the crank's output component
iq = 3 if name == "four-bar" else 4          # the rocker pin C / the slider pin B
th = np.unwrap(np.arctan2(p[:, ip, 1], p[:, ip, 0]))
t = th / w
cf = (models.four_bar_closed_form if name == "four-bar" else models.slider_crank_closed_form)(t)
q, qd, qdd = cf["q"], cf["qd"], cf["qdd"]
if name == "four-bar":
    c = models.FB_C
    ref = lambda Q: np.stack([Q[:, 6] + c * np.cos(Q[:, 8]), Q[:, 7] + c * np.sin(Q[:, 8])], 1)
    pin = ref(q)
    phi, wr, ar = q[:, 8], qd[:, 8], qdd[:, 8]
    vel = np.stack([-c * wr * np.sin(phi), c * wr * np.cos(phi)], 1)
    acc = np.stack([-c * ar * np.sin(phi) - c * wr ** 2 * np.cos(phi),
                    c * ar * np.cos(phi) - c * wr ** 2 * np.sin(phi)], 1)
else:
    pin, vel, acc = q[:, 6:8], qd[:, 6:8], qdd[:, 6:8]
out["err"] = [models.rel_error(p[:, iq], pin), models.rel_error(v[:, iq], vel),
              models.rel_error(a[:, iq], acc)]
out["rows"] = int(p.shape[0])
print(json.dumps(out), flush=True)
"""


def planarkin_errors(res, name) -> list:
    import models
    cf = (models.four_bar_closed_form if name == "four-bar"
          else models.slider_crank_closed_form)(res.t)
    e = models.errors(res.q, res.qd, res.qdd, cf)
    return [e["P"], e["V"], e["A"]]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--peer-python", default="/tmp/benchvenv/bin/python")
    ap.add_argument("--json", metavar="PATH")
    ap.add_argument("--routes", default="compiled,numpy,default",
                    help="planarkin grid-pass routes to time, comma-separated")
    a = ap.parse_args(argv)
    routes = [r for r in a.routes.split(",") if r]
    import common
    import models
    import numpy as np

    import planarkin
    info = common.machine_info()
    common.print_header(info, "planarkin against pylinkage + numba and the closed form")
    peer = subprocess.run([a.peer_python, "-c", "import pylinkage, numba; "
                           "print(pylinkage.__version__, numba.__version__)"],
                          capture_output=True, text=True)
    if peer.returncode != 0:
        sys.exit(f"no pylinkage + numba at {a.peer_python}: {peer.stderr.strip()[-300:]}")
    print(f"peer       pylinkage {peer.stdout.split()[0]}, numba {peer.stdout.split()[1]} "
          f"({a.peer_python})\n")
    S = a.steps
    rows = S + 1
    results = {"machine": info, "steps": S, "mechanisms": {}}
    for name, text, cf_fn in (("slider-crank", models.slider_crank_yaml(),
                               models.slider_crank_closed_form),
                              ("four-bar", models.four_bar_yaml(), models.four_bar_closed_form)):
        t = np.linspace(0.0, 1.0, rows)
        best_cf = median([_timed(lambda: cf_fn(t))[0] for _ in range(3)])
        model = planarkin.load(f"{name}.yaml", text=text)
        for route in routes:
            with _route(route):
                planarkin.solve(model, steps=S)               # warm-up (compiles the kernel)
        w = subprocess.Popen([a.peer_python, "-c", WORKER, str(HERE), name, str(S),
                              str(a.rounds)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                             text=True)
        walls = {r: [] for r in routes}
        cpus = {r: [] for r in routes}
        res = {}
        for _ in range(a.rounds):
            for route in routes:
                with _route(route):
                    c0, t0 = time.process_time(), time.perf_counter()
                    res[route] = planarkin.solve(model, steps=S)
                    walls[route].append(time.perf_counter() - t0)
                    cpus[route].append(time.process_time() - c0)
            w.stdin.write("go\n")
            w.stdin.flush()
            assert w.stdout.readline().strip() == "done"
        w.stdin.close()
        peer_out = json.loads(w.stdout.readline())
        w.wait()
        us = lambda s: s / rows * 1e6                         # noqa: E731
        pl, plc = median(peer_out["wall"]), median(peer_out["cpu"])
        print(f"== {name}: {S} steps, P + V + A ==")
        print(f"  closed form (vectorised numpy)    {us(best_cf):7.3f} us/step")
        print(f"  pylinkage + numba                 {us(pl):7.3f} us/step "
              f"({us(min(peer_out['wall'])):.3f}-{us(max(peer_out['wall'])):.3f})   "
              f"CPU {us(plc):7.3f}"
              f"   (JIT start-up {peer_out['jit']:.2f} s, not counted)   errors P/V/A "
              + " ".join(f"{e:.1e}" for e in peer_out["err"]))
        out = {"closed_form_us": us(best_cf), "pylinkage_us": us(pl), "pylinkage_cpu_us": us(plc),
               "pylinkage_err": peer_out["err"], "jit_s": peer_out["jit"],
               "rounds": {"pylinkage": peer_out["wall"]}, "routes": {}}
        for route in routes:
            pk, pkc = median(walls[route]), median(cpus[route])
            pk_err = planarkin_errors(res[route], name)
            print(f"  planarkin.solve, {route:9s}       {us(pk):7.3f} us/step "
                  f"({us(min(walls[route])):.3f}-{us(max(walls[route])):.3f})   CPU {us(pkc):7.3f}"
                  f"   errors P/V/A " + " ".join(f"{e:.1e}" for e in pk_err))
            print(f"    ratio planarkin / pylinkage+numba {pk / pl:6.2f} x (wall)   "
                  f"{pkc / plc:.2f} x (CPU)   target <= 0.5;  planarkin / closed form "
                  f"{pk / best_cf:.1f} x")
            out["routes"][route] = {"planarkin_us": us(pk), "planarkin_cpu_us": us(pkc),
                                    "ratio_wall": pk / pl, "ratio_cpu": pkc / plc,
                                    "planarkin_err": pk_err}
            out["rounds"][route] = walls[route]
        print("  all rounds (s): " + "; ".join(
            f"{r} {', '.join(f'{x:.3f}' for x in walls[r])}" for r in routes)
            + f"; pylinkage {', '.join(f'{x:.3f}' for x in peer_out['wall'])}\n", flush=True)
        results["mechanisms"][name] = out
    import os
    la = os.getloadavg()
    print(f"load avg at end {la[0]:.2f} {la[1]:.2f} {la[2]:.2f}")
    if a.json:
        Path(a.json).write_text(json.dumps(results, indent=2))


class _route:
    """Context: planarkin's grid pass takes one route (see the module docstring)."""

    def __init__(self, route):
        if route not in ("compiled", "numpy", "default"):
            sys.exit(f"unknown route {route!r} (compiled, numpy, default)")
        self.route = route

    def __enter__(self):
        import os

        from planarkin.solver.compiled import kernel
        self.saved = (os.environ.get("PLANARKIN_KERNEL"), kernel.COMPILED_FROM_POINTS,
                      dict(kernel._state.get("points", {})))
        if self.route != "default":
            os.environ["PLANARKIN_KERNEL"] = "1" if self.route == "compiled" else "0"
            kernel.COMPILED_FROM_POINTS = 0
        return self

    def __exit__(self, *exc):
        import os

        from planarkin.solver.compiled import kernel
        if self.route == "default":
            return False
        # a forced route's jobs do not count towards the default route's choice
        env, kernel.COMPILED_FROM_POINTS, kernel._state["points"] = self.saved
        if env is None:
            os.environ.pop("PLANARKIN_KERNEL", None)
        else:
            os.environ["PLANARKIN_KERNEL"] = env
        return False


def median(xs):
    xs = sorted(xs)
    k = len(xs) // 2
    return xs[k] if len(xs) % 2 else 0.5 * (xs[k - 1] + xs[k])


def _timed(fn):
    t0 = time.perf_counter()
    r = fn()
    return time.perf_counter() - t0, r


if __name__ == "__main__":
    main()
