"""Cycle figures of the measures: limit positions, stroke, time ratio (summary.json, ``cycle``).

For every measure value column: its limit positions (smallest and largest value on the grid,
with the time and the driver's coordinate there), each refined by one second-order Taylor step
from the exact rate and acceleration at that grid row (t* = t - v'/v'', value* = v - v'^2 /
(2 v''), used only when t* stays within one grid interval: the refined extreme of a smooth
measure is then accurate to O(h^3) of the grid step h, while the grid value is only O(h^2));
the stroke (max - min); for a periodic driver (an angle driven at constant speed, the run
covering at least one period T) the time of advance (min -> max) and of return and their ratio
(the slower over the faster, >= 1). A transmission measure also gets its minimum as
``transmission_min``.
"""

from __future__ import annotations

import math

import numpy as np


class CycleFigures:
    """Accumulator of the measures table (rows of t and the measure columns)."""

    def __init__(self, cm, header: list[str], opts):
        self.names = [h.split(" [", 1)[0] for h in header]
        self.units = [h.split(" [", 1)[1][:-1] if " [" in h else "" for h in header]
        self.value_cols = [k for k, n in enumerate(self.names) if k > 0 and "." not in n]
        self.kinds = {m.name: m.kind for m in cm.spec.measures}
        self.h = (opts.end - opts.start) / opts.steps
        self.span = (opts.start, opts.end)
        self.best: dict = {}                 # (col, 'min'|'max') -> row snapshot
        f = cm.driver_funcs[0] if len(cm.driver_funcs) else None
        self.driver = f
        el = next((e for e in cm.spec.drivers), None)
        self.driver_label = el.label if el is not None else None
        self.period = None
        if f is not None and el.kind == "angle":
            t = np.array([opts.start, 0.5 * (opts.start + opts.end), opts.end])
            _, f1, f2 = (np.broadcast_to(np.asarray(x, float), t.shape)
                         for x in f.derivatives(t))
            if np.all(f2 == 0) and f1[0] != 0 and np.all(f1 == f1[0]):
                full = 360.0 if cm.spec.angle_unit == "deg" else 2 * math.pi
                self.period = full / abs(float(f1[0]))

    def add(self, X: np.ndarray) -> None:
        if not len(X):
            return
        for k in self.value_cols:
            col = X[:, k]
            if np.all(np.isnan(col)):
                continue
            for which, idx in (("min", np.nanargmin(col)), ("max", np.nanargmax(col))):
                v = col[idx]
                old = self.best.get((k, which))
                if old is None or (v < old[1] if which == "min" else v > old[1]):
                    nm = self.names
                    rate = X[idx, k + 1] if nm[k + 1:k + 2] == [f"{nm[k]}.rate"] else np.nan
                    acc = X[idx, k + 2] if nm[k + 2:k + 3] == [f"{nm[k]}.accel"] else np.nan
                    self.best[(k, which)] = (float(X[idx, 0]), float(v), float(rate), float(acc))

    def _limit(self, rec) -> dict:
        t, v, rate, acc = rec
        out = {"value": v, "t": t}
        if self.driver is not None:
            out["driver"] = float(self.driver(t))
        if math.isfinite(acc) and acc != 0 and abs(rate / acc) <= self.h and \
                self.span[0] <= t - rate / acc <= self.span[1]:
            ts = t - rate / acc
            out["refined"] = {"value": v - rate * rate / (2 * acc), "t": ts}
            if self.driver is not None:
                out["refined"]["driver"] = float(self.driver(ts))
        return out

    def as_dict(self) -> dict:
        figures = {}
        for k in self.value_cols:
            name = self.names[k]
            if (k, "min") not in self.best:
                figures[name] = None
                continue
            lo, hi = self._limit(self.best[(k, "min")]), self._limit(self.best[(k, "max")])
            rec = {"unit": self.units[k], "min": lo, "max": hi,
                   "stroke": hi.get("refined", hi)["value"] - lo.get("refined", lo)["value"]}
            T = self.period
            if self.kinds.get(name) in ("ratio", "advantage"):
                rec["note"] = "grid extremes only; a ratio is infinite at a dead point"
                T = None
            if T is not None and self.span[1] - self.span[0] >= T * (1 - 1e-12):
                t_lo = lo.get("refined", lo)["t"]
                t_hi = hi.get("refined", hi)["t"]
                adv = (t_hi - t_lo) % T
                ret = T - adv
                if min(adv, ret) > self.h:        # else a monotonic measure (a crank angle)
                    rec["advance_time"] = adv
                    rec["return_time"] = ret
                    rec["time_ratio"] = max(adv, ret) / min(adv, ret)
            if self.kinds.get(name) == "transmission":
                rec["transmission_min"] = lo.get("refined", lo)
            figures[name] = rec
        return {"driver": self.driver_label, "period": self.period, "measures": figures,
                "note": "limit positions from the grid, refined by one Taylor step from the exact "
                        "rate and acceleration; time ratio for a constant-speed angle driver"}


def format_cycle(section: dict | None) -> list[str]:
    """The cycle figures of summary.json as report lines (`planarkin run --report cycle`)."""
    if not section:
        return ["         cycle: no measures (add a measures: block)"]
    out = []
    drv = section.get("driver")
    for name, rec in section["measures"].items():
        if rec is None:
            out.append(f"         {name}: no finite values")
            continue
        u = rec["unit"]

        def lim(x):
            r = x.get("refined", x)
            at = f" at t = {r['t']:.6g} s"
            if "driver" in r:
                at += f" (driver {r['driver']:.6g})"
            return f"{r['value']:.6g} {u}{at}"
        line = (f"         {name}: min {lim(rec['min'])}, max {lim(rec['max'])}, stroke "
                f"{rec['stroke']:.6g} {u}")
        if "time_ratio" in rec:
            line += (f", advance {rec['advance_time']:.6g} s / return {rec['return_time']:.6g} s,"
                     f" time ratio {rec['time_ratio']:.6g}")
        out.append(line)
    if drv:
        out.append(f"         (driver: {drv})")
    return out
