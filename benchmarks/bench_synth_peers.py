"""planarkin synth against pylinkage on the same path-synthesis problems, at equal budgets.

Problems (mechanisms/synthesis/):
  four-bar-path   six coupler points of mechanisms/four-bar.yaml at crank angles 0, 60, ...,
                  300 deg (prescribed timing); a, b, c, d free within the file's bounds; the
                  coupler point fixed; the crank turns fully; error: sum of squared distances
                  (m^2).
  straight-line   the six collinear points (20, 20) ... (20, 45) mm without prescribed timing;
                  x0, y0, th0, a, b, c, d, px, py free (the file's bounds); error: the sum of
                  squared distances from each target to the nearest point of the path, the
                  targets in order along it (mm^2).

planarkin: `synthesize` with the file's search settings and a seed; its budget is what it used,
evaluations (analyses over the whole cycle and local trials at the target inputs only) plus
Jacobians. pylinkage (1.3 with numba, in its own virtual environment, /tmp/benchvenv or
PEER_PYTHON): its kinematics (Ground, Crank, RRRDyad, FixedDyad) as the evaluation and
differential evolution as the search. pylinkage's own differential_evolution_optimization is a
thin wrapper of scipy.optimize.differential_evolution over the linkage's constraint vector
(crank radius and dyad distances), which leaves out the ground pivots and the ground angle, so
the peer side calls scipy's differential_evolution directly on the same parameters and bounds,
with as many function evaluations as planarkin used (population multiplier 15, pylinkage's
default, or less so that the budget covers 5 generations; polish off; maxiter cut to the
budget), and once more with 100 (--big) times that budget (DE's evaluations are much cheaper). A design
pylinkage cannot build over the cycle (UnbuildableError) scores 1e6. For the straight line the
pylinkage path is sampled at 360 crank positions and its best design is scored again by
planarkin's exact projection (the error column), so both sides' errors are the same measure.

Timing: the peer runs in one server process, warmed up (imports and numba compiles) before the
rounds; planarkin is warmed up by an untimed pass over the seeds, which also gives each seed's
budget (planarkin is deterministic per seed), so the timed rounds alternate which side runs
first (even seeds planarkin first). Each side's wall time is its own search's, imports
excluded; medians and ranges over the seeds, and the median of the per-round ratios.

    /tmp/venv/bin/python benchmarks/bench_synth_peers.py [--seeds 5] [--problem four-bar-path]
        [--big 100]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
# pylinkage 1.3 + numba in their own virtual environment (PEER_PYTHON overrides)
PEER = os.environ.get("PEER_PYTHON", "/tmp/benchvenv/bin/python")
PROBLEMS = ("four-bar-path", "straight-line")


def _bounds(name):
    import yaml
    data = yaml.safe_load((ROOT / "mechanisms" / "synthesis" / f"{name}.yaml").read_text())
    free = data["design"]["free"]
    return list(free), [float(v[0]) for v in free.values()], [float(v[1]) for v in free.values()], \
        data["design"]["targets"][0]["points"]


# -- the pylinkage side (runs in the peer's virtual environment) ------------------------------
def _peer(problem: str, budget: int, seed: int) -> dict:
    import pylinkage as pl
    from scipy.optimize import differential_evolution
    names, lo, hi, targets = _bounds(problem)
    T = np.array(targets, dtype=float)
    nfev = [0]

    def path(x0, y0, th0, a, b, c, d, px, py, n):
        A = pl.Ground(x0, y0)
        D = pl.Ground(x0 + d * math.cos(th0), y0 + d * math.sin(th0))
        B = pl.Crank(A, a, angular_velocity=2 * math.pi / n, initial_angle=th0)
        C = pl.RRRDyad(B, D, b, c)
        P = pl.FixedDyad(B, C, math.hypot(px, py), math.atan2(py, px))
        link = pl.Linkage([A, D, B, C, P])
        return np.array([pos[-1] for pos in link.step(iterations=n)], dtype=float)

    def score(x):
        nfev[0] += 1
        try:
            if problem == "four-bar-path":
                a, b, c, d = x
                # steps yield after each turn of 60 deg: the pose at 0 deg comes last
                p = path(0, 0, 0, a, b, c, d, 0.06, 0.045, 6)
                p = np.roll(p, 1, axis=0)
                return float(((p - T) ** 2).sum())
            p = path(*x, 360)
        except (pl.UnbuildableError, ValueError, ZeroDivisionError):
            return 1e6
        if not np.isfinite(p).all():
            return 1e6
        return _in_order_sse(p, T)

    t0 = time.perf_counter()
    dim = len(lo)
    # pylinkage's default multiplier 15, smaller when the budget would not cover 5 generations
    mult = max(1, min(15, budget // (5 * dim)))
    pop = mult * dim
    sol = differential_evolution(score, list(zip(lo, hi)), popsize=mult, seed=seed,
                                 maxiter=max(0, budget // pop - 1), polish=False, tol=0,
                                 init="latinhypercube")
    return {"cost": float(sol.fun), "x": [float(v) for v in sol.x], "nfev": nfev[0],
            "seconds": time.perf_counter() - t0, "names": names}


def _in_order_sse(p, T) -> float:
    """Targets in order along a closed sampled path (either direction): the smallest sum of
    squared distances to path samples with strictly increasing indices after a rotation that
    starts at the sample nearest the first target."""
    best = math.inf
    for q in (p, p[::-1]):
        D = ((q[None, :, :] - T[:, None, :]) ** 2).sum(axis=2)
        off = int(np.argmin(D[0]))
        D = np.roll(D, -off, axis=1)
        cost = D[0].copy()
        for e in range(1, len(T)):
            prev = np.concatenate([[math.inf], np.minimum.accumulate(cost)[:-1]])
            cost = prev + D[e]
        best = min(best, float(cost.min()))
    return best


# -- the planarkin side ------------------------------------------------------------------------
def _ours(problem: str, seed: int) -> dict:
    from planarkin.synthesis.synth import synthesize
    r = synthesize(ROOT / "mechanisms" / "synthesis" / f"{problem}.yaml", seed=seed)
    return {"cost": r.designs[0].cost if r.designs else math.nan,
            "budget": r.evaluations + r.jacobians, "seconds": r.seconds}


def _rescore(problem: str, x) -> float:
    """The straight line's pylinkage design scored by planarkin's exact projection."""
    from planarkin.synthesis.synth import Synthesis
    syn = Synthesis(ROOT / "mechanisms" / "synthesis" / f"{problem}.yaml")
    first = syn.model.analyse(syn.model.values(np.array(x)))
    if isinstance(first, tuple):
        syn.wrap = syn.model.periodic(first[2])
    r, _, d = syn.evaluate(np.array(x, dtype=float), jac=False)
    return d.cost if r is not None else math.nan


def _serve() -> None:
    """The peer side as a server: one line 'PROBLEM BUDGET SEED' in, one JSON line out, so
    pylinkage and numba are imported and compiled once, before the timed rounds."""
    _peer("four-bar-path", 40, 0)               # warm-up (numba compiles; not reported)
    _peer("straight-line", 40, 0)
    print("ready", flush=True)
    for line in sys.stdin:
        problem, budget, seed = line.split()
        print(json.dumps(_peer(problem, int(budget), int(seed))), flush=True)


class _Peer:
    def __init__(self):
        self.p = subprocess.Popen([PEER, __file__, "--serve"], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True)
        while self.p.stdout.readline().strip() != "ready":
            pass

    def __call__(self, problem, budget, seed) -> dict:
        self.p.stdin.write(f"{problem} {budget} {seed}\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())

    def close(self):
        self.p.stdin.close()
        self.p.wait()


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--problem", choices=PROBLEMS, action="append")
    ap.add_argument("--serve", action="store_true")
    ap.add_argument("--big", type=int, default=100,
                    help="the peer's second run gets this many times the budget")
    a = ap.parse_args()
    if a.serve:
        _serve()
        return
    sys.path.insert(0, str(ROOT))
    peer = _Peer()
    print("load before:", os.getloadavg(), flush=True)
    for problem in a.problem or PROBLEMS:
        # the budgets first (planarkin is deterministic per seed; this pass also warms it up),
        # so that the timed rounds can alternate which side runs first
        budget = {seed: _ours(problem, seed)["budget"] for seed in range(a.seeds)}
        rows = []
        for seed in range(a.seeds):
            out = {}
            for side in (("ours", "peer") if seed % 2 == 0 else ("peer", "ours")):
                if side == "ours":
                    out["ours"] = _ours(problem, seed)
                    assert out["ours"]["budget"] == budget[seed]
                else:
                    out["peer"] = peer(problem, budget[seed], seed)
            out["peer100"] = peer(problem, a.big * budget[seed], seed)
            if problem == "straight-line":
                for k in ("peer", "peer100"):
                    out[k]["exact"] = _rescore(problem, out[k]["x"])
            o, p, q = out["ours"], out["peer"], out["peer100"]
            rows.append((o["cost"], o["budget"], o["seconds"], p.get("exact", p["cost"]),
                         p["nfev"], p["seconds"], q.get("exact", q["cost"]), q["nfev"],
                         q["seconds"]))
            print(f"{problem} seed {seed}: planarkin SSE {o['cost']:.3e} ({o['budget']} "
                  f"evaluations + Jacobians, {o['seconds']:.3f} s); pylinkage + DE SSE "
                  f"{p.get('exact', p['cost']):.3e} ({p['nfev']} evaluations, "
                  f"{p['seconds']:.3f} s); at {a.big} x: {q.get('exact', q['cost']):.3e} "
                  f"({q['nfev']}, {q['seconds']:.3f} s)", flush=True)
        R = np.array(rows)
        for label, c, s in (("planarkin", 0, 2), ("pylinkage + DE", 3, 5),
                            (f"pylinkage + DE, {a.big} x the budget", 6, 8)):
            print(f"{problem}: {label}: SSE median {np.median(R[:, c]):.3e} (range "
                  f"{R[:, c].min():.3e} .. {R[:, c].max():.3e}); seconds median "
                  f"{np.median(R[:, s]):.3f} (range {R[:, s].min():.3f} .. {R[:, s].max():.3f})")
        ratio = R[:, 2] / R[:, 5]
        print(f"{problem}: wall time planarkin / pylinkage + DE at equal budgets: median "
              f"{np.median(ratio):.2f} (range {ratio.min():.2f} .. {ratio.max():.2f}) over "
              f"{len(R)} rounds")
        wins = int((R[:, 0] < R[:, 3]).sum())
        wins100 = int((R[:, 0] < R[:, 6]).sum())
        print(f"{problem}: planarkin's error lower in {wins} of {len(R)} seeds at equal budgets, "
              f"in {wins100} against {a.big} x the budget")
    peer.close()
    print("load after:", os.getloadavg())


if __name__ == "__main__":
    main()
