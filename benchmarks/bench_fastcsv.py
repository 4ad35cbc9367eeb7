#!/usr/bin/env python3
"""Benchmark of planarkin.output.fastcsv.format_table (a script, not a test).

    python benchmarks/bench_fastcsv.py [--rows 200000] [--cols 35] [--repeat 5]
                                       [--repr-rows 20000]

Data sets: (a) uniform random in [0, 1); (b) mechanism-like: time, crank
angle, and positions / velocities / accelerations of a slider-crank (crank,
connecting rod, slider) over one turn, plus reaction-force-like columns.
Prints ns per value for format_table, for write_table to /dev/null, for the
``','.join(map(repr, row))`` reference (timed on --repr-rows rows), and a
profile of the formatting stages on one internal block.  Timings are the best
of --repeat runs (wall clock); the machine may be shared, so also the user /
system CPU time and page faults of the best run are shown.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from planarkin.output import fastcsv  # noqa: E402


def uniform_table(rows: int, cols: int) -> np.ndarray:
    return np.random.default_rng(0).random((rows, cols))


def slider_crank_table(rows: int, cols: int) -> np.ndarray:
    """Columns of a slider-crank run over one crank turn at 1500 rpm."""
    r, l, w = 0.1, 0.35, 2 * np.pi * 25.0
    t = np.linspace(0.0, 2 * np.pi / w, rows)
    th = w * t
    s, c = np.sin(th), np.cos(th)
    phi = -np.arcsin(r * s / l)                       # rod angle
    cp = np.cos(phi)
    dphi = -r * w * c / (l * cp)
    ddphi = (r * w * w * s + l * dphi**2 * np.sin(phi)) / (l * cp)
    xs = r * c + l * cp                               # slider position
    vs = -r * w * s - l * np.sin(phi) * dphi
    acs = -r * w * w * c - l * (np.cos(phi) * dphi**2 + np.sin(phi) * ddphi)
    crank = [0.5 * r * c, 0.5 * r * s, th, -0.5 * r * w * s, 0.5 * r * w * c,
             np.full_like(t, w), -0.5 * r * w * w * c, -0.5 * r * w * w * s, np.zeros_like(t)]
    rod_x = r * c + 0.5 * l * cp
    rod_y = 0.5 * r * s
    rod = [rod_x, rod_y, phi, -r * w * s - 0.5 * l * np.sin(phi) * dphi, 0.5 * r * w * c, dphi,
           -r * w * w * c - 0.5 * l * (cp * dphi**2 + np.sin(phi) * ddphi),
           -0.5 * r * w * w * s, ddphi]
    slider = [xs, np.zeros_like(t), np.zeros_like(t), vs, np.zeros_like(t), np.zeros_like(t),
              acs, np.zeros_like(t), np.zeros_like(t)]
    m1, m2, m3 = 1.2, 0.8, 0.5
    lam = [m3 * acs, m2 * rod[6] + m3 * acs, m2 * rod[7], m1 * crank[6] + m2 * rod[6],
           m1 * crank[7] + m2 * rod[7], 0.5 * m2 * l * l * ddphi / 12, m3 * 9.81 + m2 * rod[7]]
    columns = [t, th] + crank + rod + slider + lam
    while len(columns) < cols:
        columns.append(columns[len(columns) % 27 + 2] * 1.5)
    return np.ascontiguousarray(np.stack(columns[:cols], axis=1))


def _timed(fn, repeat):
    best = None
    for _ in range(repeat):
        r0 = resource.getrusage(resource.RUSAGE_SELF)
        t0 = time.perf_counter()
        out = fn()
        t1 = time.perf_counter()
        r1 = resource.getrusage(resource.RUSAGE_SELF)
        res = (t1 - t0, r1.ru_utime - r0.ru_utime, r1.ru_stime - r0.ru_stime,
               r1.ru_minflt - r0.ru_minflt)
        if best is None or res[0] < best[0]:
            best = res
        del out
    return best


def _fmt(res, n):
    wall, user, sys_, flt = res
    return (f"{wall / n * 1e9:7.1f} ns/value  (user {user / n * 1e9:5.1f}, "
            f"sys {sys_ / n * 1e9:5.1f} ns/value, {flt} page faults)")


def profile_stages(X: np.ndarray, reps: int = 40) -> dict:
    """ns/value of each stage on the first internal block of X (hot cache)."""
    ncols = X.shape[1]
    step = max(1, fastcsv._CHUNK_VALUES // ncols)
    x = np.ascontiguousarray(X[:step]).ravel()
    nlc = np.full((step, ncols), fastcsv._CLS_OFF, dtype=np.int64)
    nlc[:, -1] += 1
    nlc = nlc.ravel()[:x.size]
    w = fastcsv._Work(x.size)
    N, F, c16, e, bexp, frac = (a.copy() for a in fastcsv._scale(x, w))
    D, nd, e2, bexp, frac = (a.copy() for a in fastcsv._digits(x, w))
    rows, L = (a.copy() for a in fastcsv._rows(x, D, nd, e2, bexp, frac, nlc, w))
    ends = np.cumsum(L)
    out = np.empty(int(ends[-1]) + fastcsv._ITEM, dtype=np.uint8)

    def tm(f):
        f()
        best = 1e9
        for _ in range(7):
            t0 = time.perf_counter()
            for _ in range(reps):
                f()
            best = min(best, (time.perf_counter() - t0) / reps / x.size * 1e9)
        return best

    res = {
        "scale  (exponent, table look-ups, |x|*10**(16-e) as N + F)": tm(lambda: fastcsv._scale(x, w)),
        "choose (15/16/17 digits, rounding, ambiguity flags)": tm(lambda: fastcsv._choose(N, F, c16, w)),
        "digits (scale + choose + strip zeros, specials, fallback)": tm(lambda: fastcsv._digits(x, w)),
        "layout (digit field, 4-digit tables, class patterns)": tm(
            lambda: fastcsv._rows(x, D.copy(), nd, e2, bexp, frac, nlc, w)),
        "lengths + compaction (overlapping fancy assignment)": tm(
            lambda: fastcsv._compact(rows, np.cumsum(L), out)),
        "whole block (digits + layout + compaction)": tm(lambda: fastcsv._render(x, nlc, w)),
    }
    res["(fix-ups inside digits)"] = (res["digits (scale + choose + strip zeros, specials, fallback)"]
                                      - res["scale  (exponent, table look-ups, |x|*10**(16-e) as N + F)"]
                                      - res["choose (15/16/17 digits, rounding, ambiguity flags)"])
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", type=int, default=200_000)
    ap.add_argument("--cols", type=int, default=35)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--repr-rows", type=int, default=20_000)
    args = ap.parse_args(argv)

    print(f"fastcsv: fast path {'on' if fastcsv._FAST else 'OFF (repr fallback)'}, "
          f"compaction {fastcsv._compact.__name__}, block {fastcsv._CHUNK_VALUES} values")
    datasets = {
        "(a) uniform random [0,1)": uniform_table(args.rows, args.cols),
        "(b) slider-crank, one turn": slider_crank_table(args.rows, args.cols),
    }
    for name, X in datasets.items():
        n = X.size
        print(f"\n{name}: {X.shape[0]} x {X.shape[1]} = {n} values")
        sub = X[: args.repr_rows]
        ref = "".join(",".join(map(repr, row)) + "\n" for row in sub.tolist()).encode()
        assert fastcsv.format_table(sub) == ref, "output differs from repr"
        out = fastcsv.format_table(X)
        print(f"  output {len(out) / 1e6:.1f} MB, {len(out) / n:.2f} bytes/value; "
              f"identical to repr on the first {sub.shape[0]} rows")
        del out

        print("  format_table          ", _fmt(_timed(lambda: fastcsv.format_table(X), args.repeat), n))

        def blocks_only():
            for _ in fastcsv._blocks(X):
                pass
        print("  blocks only (no bytes)", _fmt(_timed(blocks_only, args.repeat), n))
        with open(os.devnull, "wb") as f:
            print("  write_table(/dev/null)", _fmt(_timed(lambda: fastcsv.write_table(f, X), args.repeat), n))

        def repr_join():
            return "".join(",".join(map(repr, row)) + "\n" for row in sub.tolist()).encode()
        print("  repr join (reference) ", _fmt(_timed(repr_join, max(1, args.repeat // 2)), sub.size))

        print("  stage profile (one block, hot cache, best of 7x40):")
        for stage, v in profile_stages(X).items():
            print(f"    {v:6.1f} ns/value  {stage}")


if __name__ == "__main__":
    main()
