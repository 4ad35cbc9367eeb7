"""The rows-outer engine (rows_outer.py) against the kernels generated per structure.

1. Kernel alone: every example whose structure it covers (blocks of at most 2 unknowns), N
   points predicted by the path's Hermite interpolant, both Newton policies: every output of
   the two kernels compared bit for bit (Q, Qd, Qdd, iterations, convergence, ratio, signs,
   sigma_min, residuals, largest residual, condition); CPU per point of the kernel's call
   alone (its arrays allocated once, the inputs copied in before the clock starts), the sides
   alternating, median of ROUNDS.
2. Whole solves: planarkin.solve(model, steps=200_000) on the compiled route with the
   generated kernel and with this engine in its place (kernels.function patched), the sides
   alternating, median of ROUNDS, CPU per step; q, qd, qdd compared bit for bit.
3. The sweep of benchmarks/bench_sweep.py (the four-bar, a and b over 100 values each, 360
   steps, metric max:rocker.phi): `Study.run` with the generated studies' solve and with the
   engine's (`each`, kernels.function_each patched), the sides alternating, median of ROUNDS,
   variants per CPU second; every outcome compared (status, metrics, bit for bit).

    python benchmarks/experiments/bench_rows_outer.py [--points 100000] [--rounds 7]
        [--solve mechanisms/four-bar.yaml mechanisms/slider-crank.yaml] [--variants 10000]
        [--skip kernels solves sweep]

The first call compiles the engine (once; numba's cache beside this file afterwards): its CPU
seconds are printed.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE))

import planarkin  # noqa: E402
from planarkin.analysis import prepare  # noqa: E402
from planarkin.diagnostics import InputError  # noqa: E402
from planarkin.options import resolve  # noqa: E402
from planarkin.solver.compiled import kernel, kernels  # noqa: E402
from planarkin.solver.path import hermite5  # noqa: E402

import rows_outer as ro  # noqa: E402

NAMES = ["Q", "Qd", "Qdd", "iters", "conv", "ratio", "sign", "smin", "R", "rmax", "cond"]


def setup(path, N):
    """The grid System of a model, its packed form and N predicted points with their drivers;
    None where the engine does not cover it."""
    cm = planarkin.load(path)
    opts = resolve(cm, {}, source="api")
    an = prepare(cm, opts)
    if an.event is not None or len(an.Tn) < 2 or len(an.follower.systems) != 1:
        return None
    S = an.follower.systems[0][0]
    P = kernel.pack(S)
    if P is None or int(P.arrays[6].max()) > 2 or ((P.arrays[6] == 2) & (P.fine[1] > 2)).any():
        return None
    Tn, Qn, Qdn, Qddn = an.Tn, an.Qn, an.Qdn, an.Qddn
    t = np.linspace(opts.start, an.Tn[-1], N)
    idx = np.clip(np.searchsorted(Tn, t, side="right") - 1, 0, len(Tn) - 2)
    h = (Tn[idx + 1] - Tn[idx])[:, None]
    s = (t[:, None] - Tn[idx][:, None]) / h
    Q = hermite5(s, h, Qn[idx], Qdn[idx], Qddn[idx], Qn[idx + 1], Qdn[idx + 1], Qddn[idx + 1])
    T, NU, FDD = (np.ascontiguousarray(np.broadcast_to(X, (N, cm.m)))
                  for X in S.driver_values(t))
    return cm, opts, S, P, np.ascontiguousarray(Q), T, NU, FDD


class Side:
    """One kernel's call on preallocated arrays (so that the times are the kernels', not
    numpy's allocations and page faults): the generated kernel as kernels.solve calls it, or
    the engine's grid."""

    def __init__(self, side, S, P, Q0, T, NU, FDD, fn, st):
        N, W = Q0.shape
        m, nb = S.cm.m, S.nb
        self.side, self.fn, self.st, self.Q0 = side, fn, st, Q0
        self.drv = (T, NU, FDD)
        self.prm = np.ascontiguousarray(P.arrays[3], dtype=float)
        self.Q, self.Qd, self.Qdd = np.empty((N, W)), np.zeros((N, W)), np.zeros((N, W))
        self.out = (np.empty(N, dtype=np.int64), np.empty(N, dtype=np.uint8), np.empty(N),
                    np.zeros((N, P.nfine)), np.empty((N, P.nblk)), np.empty((N, m)),
                    np.empty(N), np.empty(N))
        self.work = (np.empty((N, nb + 1)), np.empty((N, nb + 1)), np.empty((N, 4)),
                     np.empty(N))
        self.N, self.n, self.nb = N, W - 3, nb

    def prepare(self):
        np.copyto(self.Q, self.Q0)
        self.Qd[:] = 0.0
        self.Qdd[:] = 0.0

    def call(self, policy, opts):
        """The kernel alone; returns its outputs (Q, Qd, Qdd and the diagnostics)."""
        full = int(policy == "full")
        if self.side == "gen":
            self.fn(self.N, self.Q, self.Qd, self.Qdd, *self.drv, self.prm,
                    int(opts.iterations), float(opts.tol), full, 2, *self.out, *ro.NO_PRED)
        else:
            C, Sn, MI, SZ = self.work
            ro.grid(self.N, self.n, self.nb, self.Q, self.Qd, self.Qdd, C, Sn, *self.drv,
                    self.prm, int(opts.iterations), float(opts.tol), full, *self.out, MI, SZ,
                    *self.st, ro.NO_PRED)
        return (self.Q, self.Qd, self.Qdd) + self.out


def run(side, policy, opts):
    side.prepare()
    return tuple(np.array(x) for x in side.call(policy, opts))


def differences(a, b):
    out = []
    for name, x, y in zip(NAMES, a, b):
        x, y = np.asarray(x), np.asarray(y)
        if not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
            out.append(f"{name} {np.nanmax(np.abs(x.astype(float) - y.astype(float))):.2g}")
    return out


def alternating(rounds, call):
    """{side: [call(side) per round]} for sides 'gen' and 'ro', their order alternating from
    round to round (call returns the round's figure)."""
    times = {"gen": [], "ro": []}
    for r in range(rounds):
        for side in ("gen", "ro") if r % 2 == 0 else ("ro", "gen"):
            times[side].append(call(side))
    return times


def cell(xs, fmt):
    """median (min-max) of xs."""
    return f"{np.median(xs):{fmt}} ({min(xs):{fmt}}-{max(xs):{fmt}})"


def engine_for(make):
    """A stand-in for kernels.function or kernels.function_each: the engine's drop-in (make)
    for each packed system, made once (the packed system kept alive with it)."""
    made: dict = {}

    def engine(P, W, m, nb):
        if id(P) not in made:
            made[id(P)] = (P, make(P, W, m, nb))
        return made[id(P)][1]
    return engine


def kernels_alone(N, rounds):
    first = True
    for path in sorted(glob.glob(str(HERE.parent.parent / "mechanisms" / "*.yaml"))):
        try:
            got = setup(path, N)
        except InputError:
            continue
        if got is None:
            continue
        cm, opts, S, P, Q0, T, NU, FDD = got
        W = Q0.shape[1]
        fn = kernels.function(P, W, cm.m, S.nb)
        st = ro.arrays(P, W - 3, cm.m, S.nb)
        gen = Side("gen", S, P, Q0, T, NU, FDD, fn, st)
        eng = Side("ro", S, P, Q0, T, NU, FDD, fn, st)
        if first:
            t0 = time.process_time()
            run(eng, "reuse", opts)
            print(f"engine's first call (compile or cache load): {time.process_time() - t0:.1f}"
                  f" s CPU")
            first = False
        diff = []
        for policy in ("reuse", "full"):
            d = differences(run(gen, policy, opts), run(eng, policy, opts))
            diff += [f"{policy}: {x}" for x in d]
        sides = {"gen": gen, "ro": eng}

        def timed(name):
            side = sides[name]
            side.prepare()
            t0 = time.process_time()
            side.call(opts.newton, opts)
            return (time.process_time() - t0) / N * 1e6
        times = alternating(rounds, timed)
        g, o = np.median(times["gen"]), np.median(times["ro"])
        print(f"| {Path(path).name} | {len(P.arrays[6])} | "
              f"{'same bits' if not diff else '; '.join(diff)} "
              f"| {cell(times['gen'], '.3f')} | {cell(times['ro'], '.3f')} | {o / g:.2f}x |")


def solves(paths, rounds, steps=200_000):
    original = kernels.function
    engine = engine_for(ro.drop_in)
    kernel.COMPILED_FROM_POINTS = 0
    for path in paths:
        model = planarkin.load(path)
        res = {}
        for side in ("gen", "ro"):
            kernels.function = original if side == "gen" else engine
            res[side] = planarkin.solve(model, steps=steps)
        same = all(np.array_equal(getattr(res["gen"], a), getattr(res["ro"], a))
                   for a in ("q", "qd", "qdd"))
        def timed(side):
            kernels.function = original if side == "gen" else engine
            t0 = time.process_time()
            planarkin.solve(model, steps=steps)
            return (time.process_time() - t0) / steps * 1e6
        times = alternating(rounds, timed)
        kernels.function = original
        g, o = np.median(times["gen"]), np.median(times["ro"])
        print(f"| {Path(path).name} | {'same bits' if same else 'DIFFERENT'} "
              f"| {cell(times['gen'], '.3f')} | {cell(times['ro'], '.3f')} | {o / g:.2f}x |")


def sweep(nvar, rounds):
    sys.path.insert(0, str(HERE.parent))
    import tempfile

    import models
    from planarkin.studies.variants import Study
    side = int(round(nvar ** 0.5))
    variants = [{"a": float(a), "b": float(b)} for a in np.linspace(0.03, 0.05, side)
                for b in np.linspace(0.11, 0.13, side)]
    original = kernels.function_each
    engine = engine_for(ro.drop_in_each)

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "four-bar.yaml"
        path.write_text(models.four_bar_yaml())
        study = Study(str(path), metrics=["max:rocker.phi"])
        study.units(variants)
        if study.batch(variants).kernel() is None:
            print("the sweep takes the numpy passes here: nothing to compare")
            return
        out = {}
        for side_ in ("gen", "ro"):
            kernels.function_each = original if side_ == "gen" else engine
            t0 = time.process_time()
            study.run(variants)          # the compiled route's size: compiled or loaded here
            if side_ == "ro":
                print(f"engine's studies solve, first run (its compile or cache load): "
                      f"{time.process_time() - t0:.1f} s CPU")
        def rate(side):
            kernels.function_each = original if side == "gen" else engine
            t0 = time.process_time()
            out[side] = study.run(variants)
            return len(variants) / (time.process_time() - t0)
        times = alternating(rounds, rate)
        kernels.function_each = original
        same = all(a.status == b.status and a.kind == b.kind and
                   np.array_equal(np.array(a.metrics, dtype=float),
                                  np.array(b.metrics, dtype=float), equal_nan=True)
                   for a, b in zip(out["gen"], out["ro"]))
        ok = sum(o.status == "ok" for o in out["gen"])
        g, o = np.median(times["gen"]), np.median(times["ro"])
        print(f"| sweep, {len(variants)} variants x 360 steps, Study.run | "
              f"{'same outcomes' if same else 'DIFFERENT outcomes'} ({ok} ok) "
              f"| {cell(times['gen'], '.0f')} | {cell(times['ro'], '.0f')} | {g / o:.2f}x |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=100_000)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--solve", nargs="*", default=["mechanisms/four-bar.yaml",
                                                   "mechanisms/slider-crank.yaml"])
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--skip", nargs="*", default=[], choices=["kernels", "solves", "sweep"])
    a = ap.parse_args()
    print(f"load {os.getloadavg()}")
    if "kernels" not in a.skip:
        print("| example | blocks | generated against rows-outer | generated, us/point "
              "| rows-outer, us/point | ratio |\n|---|---|---|---|---|---|")
        kernels_alone(a.points, a.rounds)
    if "solves" not in a.skip:
        print("\n| example, planarkin.solve at 200,000 steps | results | generated, us/step "
              "| rows-outer, us/step | ratio |\n|---|---|---|---|---|")
        solves(a.solve, a.rounds)
    if "sweep" not in a.skip:
        print("\n| job | results | generated, variants per CPU s | rows-outer, variants per "
              "CPU s | ratio (time) |\n|---|---|---|---|---|")
        sweep(a.variants, a.rounds)
    print(f"load {os.getloadavg()}")


if __name__ == "__main__":
    main()
