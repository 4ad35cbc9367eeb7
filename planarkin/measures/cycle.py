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
    """Accumulator of one table (rows of t and value columns, each value column optionally
    followed elsewhere in the row by its exact rate and acceleration).

    triplets: [(value column, rate column or None, acceleration column or None)]; default: the
    measures table's ``<m>``, ``<m>.rate``, ``<m>.accel``. Extremes are kept per column, the
    first row reaching one wins (as nanargmin does)."""

    def __init__(self, cm, header: list[str], opts, triplets=None):
        self.names = [h.split(" [", 1)[0] for h in header]
        self.units = [h.split(" [", 1)[1][:-1] if " [" in h else "" for h in header]
        if triplets is None:
            nm = self.names
            triplets = [(k, k + 1 if nm[k + 1:k + 2] == [f"{nm[k]}.rate"] else None,
                         k + 2 if nm[k + 2:k + 3] == [f"{nm[k]}.accel"] else None)
                        for k, n in enumerate(nm) if k > 0 and "." not in n]
        self.triplets = list(triplets)
        self.value_cols = [v for v, _, _ in self.triplets]
        self.kinds = {m.name: m.kind for m in cm.spec.measures}
        self.h = (opts.end - opts.start) / opts.steps
        self.span = (opts.start, opts.end)
        n = len(self.triplets)
        # per value column: (t, value, rate, acc) of the smallest / largest value so far
        self.lo = np.full((n, 4), np.nan)
        self.hi = np.full((n, 4), np.nan)
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
        if not len(X) or not self.triplets:
            return
        V = X[:, self.value_cols]
        nan = np.isnan(V)
        cols = np.arange(V.shape[1])
        for best, fill, pick, better in ((self.lo, np.inf, np.argmin, np.less),
                                         (self.hi, -np.inf, np.argmax, np.greater)):
            idx = pick(np.where(nan, fill, V), axis=0)
            v = V[idx, cols]
            new = ~nan[idx, cols] & (np.isnan(best[:, 1]) | better(v, best[:, 1]))
            for c in np.flatnonzero(new):
                _, r, a = self.triplets[c]
                i = idx[c]
                best[c] = (X[i, 0], v[c], X[i, r] if r is not None else np.nan,
                           X[i, a] if a is not None else np.nan)

    def _limit(self, rec) -> dict:
        t, v, rate, acc = (float(x) for x in rec)
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

    def figure(self, c: int, kind: str | None = None) -> dict | None:
        """The figures of value column number c (of the triplets): unit, min, max, stroke and,
        for a periodic driver, advance, return and time ratio; None without a finite value."""
        k = self.value_cols[c]
        if np.isnan(self.lo[c, 1]):
            return None
        lo, hi = self._limit(self.lo[c]), self._limit(self.hi[c])
        rec = {"unit": self.units[k], "min": lo, "max": hi,
               "stroke": hi.get("refined", hi)["value"] - lo.get("refined", lo)["value"]}
        T = self.period
        if kind in ("ratio", "advantage"):
            rec["note"] = "grid extremes only; a ratio is infinite at a dead point"
            T = None
        if T is not None and self.span[1] - self.span[0] >= T * (1 - 1e-12):
            t_lo = lo.get("refined", lo)["t"]
            t_hi = hi.get("refined", hi)["t"]
            adv = (t_hi - t_lo) % T
            ret = T - adv
            if min(adv, ret) > self.h:        # else a monotonic column (a crank angle)
                rec["advance_time"] = adv
                rec["return_time"] = ret
                rec["time_ratio"] = max(adv, ret) / min(adv, ret)
        if kind == "transmission":
            rec["transmission_min"] = lo.get("refined", lo)
        return rec

    def as_dict(self) -> dict:
        figures = {}
        for c, k in enumerate(self.value_cols):
            name = self.names[k]
            figures[name] = self.figure(c, self.kinds.get(name))
        return {"driver": self.driver_label, "period": self.period, "measures": figures,
                "note": NOTE}


NOTE = ("limit positions from the grid, refined by one Taylor step from the exact rate and "
        "acceleration; time ratio for a constant-speed angle driver")


class CoordinateFigures(CycleFigures):
    """The cycle figures of every position column of bodies.csv (``<b>.x``, ``<b>.y``,
    ``<b>.phi``) or points.csv (``<p>.x``, ``<p>.y``), refined from their exact velocity and
    acceleration columns when the run writes them. as_dict(): {body or point: {coordinate:
    figures}}; each figure says whether the coordinate moves (a stroke above 1e-9 of the
    table's length scale, or of a turn for an angle)."""

    RATES = {"x": ("vx", "ax"), "y": ("vy", "ay"), "phi": ("omega", "alpha")}

    def __init__(self, cm, header: list[str], opts):
        names = [h.split(" [", 1)[0] for h in header]
        at = {n: k for k, n in enumerate(names)}
        trip = []
        for k, n in enumerate(names):
            owner, _, q = n.rpartition(".")
            if k > 0 and q in self.RATES:
                r, a = (at.get(f"{owner}.{d}") for d in self.RATES[q])
                trip.append((k, r, a))
        super().__init__(cm, header, opts, trip)
        self.full_turn = 360.0 if cm.spec.angle_unit == "deg" else 2 * math.pi
        self.error = None

    def add(self, X: np.ndarray) -> None:
        # runs in the process that writes bodies.csv: a failure here must not cost the table
        if self.error is None:
            try:
                super().add(X)
            except Exception as e:  # noqa: BLE001
                self.error = f"{type(e).__name__}: {e}"

    def as_dict(self) -> dict:
        if self.error is not None:
            return {"driver": self.driver_label, "period": self.period, "coordinates": {},
                    "error": f"cycle figures not computed: {self.error} (please report)"}
        recs = []
        for c, k in enumerate(self.value_cols):
            owner, _, q = self.names[k].rpartition(".")
            recs.append((owner, q, self.figure(c)))
        # the length scale: the largest coordinate magnitude or stroke of the table
        size = max([abs(r[m]["value"]) for _, q, r in recs if r and q != "phi"
                    for m in ("min", "max")] + [1e-300])
        out: dict = {}
        for owner, q, r in recs:
            if r is not None:
                r["moves"] = bool(r["stroke"] > 1e-9 * (self.full_turn if q == "phi" else size))
            out.setdefault(owner, {})[q] = r
        return {"driver": self.driver_label, "period": self.period, "coordinates": out}


def cycle_section(bodies: dict, points: dict | None, measures: dict | None) -> dict:
    """summary.json's ``cycle``: the driver and its period, the figures of every body and point
    coordinate (``coordinates.bodies``, ``coordinates.points``) and of every measure."""
    out = {"driver": bodies["driver"], "period": bodies["period"],
           "coordinates": {"bodies": bodies["coordinates"],
                           "points": points["coordinates"] if points else {}}}
    for part in (bodies, points):
        if part and "error" in part:
            out["error"] = part["error"]
    if measures:
        out["measures"] = measures["measures"]
    out["note"] = NOTE
    return out


def _line(name: str, rec: dict | None) -> str:
    if rec is None:
        return f"         {name}: no finite values"
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
    return line


def format_cycle(section: dict | None) -> list[str]:
    """The cycle figures of summary.json as report lines (`planarkin run --report cycle`): the
    coordinates that move, body by body and point by point, then the measures."""
    if not section:
        return ["         cycle: no figures (no rows were written)"]
    out = [f"         {section['error']}"] if section.get("error") else []
    coords = section.get("coordinates", {})
    for group in ("bodies", "points"):
        lines = [_line(f"{owner}.{q}", rec) for owner, recs in coords.get(group, {}).items()
                 for q, rec in recs.items() if rec is not None and rec.get("moves")]
        if lines:
            out += [f"         {group} (coordinates that move):"] + lines
    if section.get("measures"):
        out.append("         measures:")
        out += [_line(name, rec) for name, rec in section["measures"].items()]
    if section.get("driver"):
        out.append(f"         (driver: {section['driver']})")
    return out
