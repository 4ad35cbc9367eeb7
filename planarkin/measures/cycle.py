"""Cycle figures of the measures: limit positions, stroke, time ratio (summary.json, ``cycle``).

For every measure value column: its limit positions (smallest and largest value on the grid,
with the time and the driver's coordinate there), each refined by one second-order Taylor step
from the exact rate and acceleration at that grid row (t* = t - v'/v'', value* = v - v'^2 /
(2 v''), used only when t* stays within one grid interval: the refined extreme of a smooth
measure is then accurate to O(h^3) of the grid step h, while the grid value is only O(h^2));
the stroke (max - min); for a periodic driver (an angle driven at constant speed, the run
covering at least one period T) the time of advance (min -> max) and of return and their ratio
(the slower over the faster, >= 1), unless the column peaks more than once per period (a
toggle): then its turning points over one period (``extremes``) and no time ratio. A
transmission measure also gets its minimum as ``transmission_min``; the section carries every
cam's smallest contact force (``contact``, from the forces section).
"""

from __future__ import annotations

import math

import numpy as np


MAX_EXTREMES = 64      # turning points listed per column (a vibrating column has more)
# turning points kept per column over one period. Rounding noise on a coordinate that does not
# move (|y| ~ 1e-17: the slider pin of the example) turns at almost every row; kept, its turns
# grew with the run (~50 bytes a row: at 10,000,000 steps, with the heap they fragmented,
# 1.1 GB). A column past this many is counted as such and drops what it kept: a coordinate that
# does not move lists none anyway, a moving one says it turns more often than this
MAX_TURNS = 1024

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
        # the turning points of each column over one period (see _turns), for a periodic driver:
        # per chunk (columns, their rows of the table, +1 max / -1 min)
        self.turn_rows: list[tuple] = []
        self.rate_cols = tuple(np.array([-1 if x is None else x for x in col], dtype=np.intp)
                               for col in zip(*[(r, a) for _, r, a in self.triplets])) \
            if self.triplets else ()
        self.turns: list[list] | None = None        # per column, built once from turn_rows
        self.turn_count = np.zeros(n, dtype=np.int64)   # turning points kept per column
        self.turn_over = np.zeros(n, dtype=bool)        # more than MAX_TURNS: none kept
        self.tail = None          # the last table row seen
        self.into = np.zeros(n)   # sign of the last non-zero change into that row
        self.out0 = None          # sign of the first non-zero change of the run (the wrap)
        self.t_last = None

    def add(self, X: np.ndarray) -> None:
        if not len(X) or not self.triplets:
            return
        V = X[:, self.value_cols]
        if self.period is not None:
            self._turns(X, V)
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

    def _turns(self, X: np.ndarray, V: np.ndarray) -> None:
        """Record every row where a column turns (its change from the row before and to the row
        after have opposite signs; a run of equal values, or of changes within 1e-13 of the
        values, continues the sign before it), for
        the rows up to 2.5 grid steps past one period: together with the run's first change
        (for a run of exactly one period) every turning point of one period is then seen once
        in the window (start + h/2, start + T + h/2]."""
        stop = self.span[0] + self.period + 2.5 * self.h
        if self.t_last is not None and self.t_last > stop:
            return
        n = int(np.searchsorted(X[:, 0], stop, side="right"))
        if not n:
            return
        X, W = X[:n], V[:n]
        if self.tail is not None:
            X = np.vstack([self.tail[None], X])
            W = np.vstack([self.tail[self.value_cols][None], W])
        t = X[:, 0]
        # a change within rounding of the values (a coordinate that does not move) is none
        D = np.diff(W, axis=0)
        aW = np.abs(W)
        with np.errstate(invalid="ignore"):
            D[~(np.abs(D) > 1e-13 * (aW[1:] + aW[:-1]))] = 0.0
        S = np.vstack([self.into[None], np.sign(D)])
        idx = np.where(S != 0, np.arange(len(S))[:, None], 0)
        S = np.take_along_axis(S, np.maximum.accumulate(idx, axis=0), axis=0)
        if self.out0 is None and len(S) > 1:
            self.out0 = S[1].copy()
        elif self.out0 is not None:           # a column still flat at the start
            flat = self.out0 == 0
            if flat.any():
                nz = np.argmax(S[1:] != 0, axis=0)
                self.out0[flat] = S[1:][nz, np.arange(S.shape[1])][flat]
        k, c = np.nonzero(S[:-1] * S[1:] < 0)
        if len(k) and self.turn_over.any():
            keep = ~self.turn_over[c]
            k, c = k[keep], c[keep]
        if len(k):                  # kept as arrays: a wide table may turn 10^4 times a chunk
            r, a = (np.where(cols[c] >= 0, X[k, np.maximum(cols[c], 0)], np.nan)
                    for cols in self.rate_cols)
            self.turn_rows.append((c, np.column_stack([t[k], W[k, c], r, a, -S[k + 1, c]])))
            self.turn_count += np.bincount(c, minlength=len(self.turn_count))
            over = self.turn_count > MAX_TURNS
            if (over & ~self.turn_over).any():
                self.turn_over |= over
                self.turn_rows = [(cc[~over[cc]], rr[~over[cc]]) for cc, rr in self.turn_rows]
        self.tail = X[-1].copy()
        self.into = S[-1].copy()
        self.t_last = float(t[-1])

    def _point(self, row: np.ndarray, c: int) -> tuple:
        """(t, value, rate, acceleration) of column c (of the triplets) in a table row."""
        v, r, a = self.triplets[c]
        return (row[0], row[v], row[r] if r is not None else np.nan,
                row[a] if a is not None else np.nan)

    def _extremes(self, c: int, stroke: float, size: float) -> list:
        """The turning points of column c over one period, smaller swings than 1e-6 of the
        stroke (rounding of a flat stretch) removed in pairs: [(t, value, rate, acc, +1 max /
        -1 min)] in time order; None past MAX_TURNS."""
        if self.turn_over[c]:
            return None
        if self.turns is None:
            self.turns = [[] for _ in self.triplets]
            for cols, recs in self.turn_rows:
                for j, rec in zip(cols.tolist(), recs.tolist()):
                    self.turns[j].append(tuple(rec))
        pts = list(self.turns[c])
        T, t0 = self.period, self.span[0]
        if self.tail is not None and self.out0 is not None and \
                abs(self.t_last - (t0 + T)) <= 1e-9 * T and self.into[c] * self.out0[c] < 0:
            # a run of exactly one period: the wrap
            pts.append(self._point(self.tail, c) + (-self.out0[c],))
        thr = 1e-6 * stroke + 1e-12 * size
        while len(pts) > 1:
            gaps = [abs(pts[i][1] - pts[i + 1][1]) for i in range(len(pts) - 1)]
            i = int(np.argmin(gaps))
            if gaps[i] >= thr:
                break
            del pts[i:i + 2]
        lo, hi = t0 + 0.5 * self.h, t0 + T + 0.5 * self.h
        return [p for p in pts if lo < p[0] <= hi]

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

    def figure(self, c: int, kind: str | None = None, scale: float = 0.0) -> dict | None:
        """The figures of value column number c (of the triplets): unit, min, max, stroke and,
        for a periodic driver, advance, return and time ratio; None without a finite value.
        scale: the table's size in the column's unit (a coordinate whose stroke is within 1e-9
        of it does not move: its rounding noise has no turning points)."""
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
        size = max(abs(lo["value"]), abs(hi["value"]), scale)
        turns = [] if T is None or not rec["stroke"] > 1e-9 * size else self._extremes(
            c, rec["stroke"], size)
        nmax = sum(1 for p in turns if p[4] > 0) if turns is not None else 0
        if turns is None:
            rec["note"] = (f"more than {MAX_TURNS} turning points per period: none listed, no "
                           f"single time ratio")
        elif T is not None and nmax > 1:
            # a toggle: the column peaks more than once per period; advance and return (and
            # their ratio) are not defined
            rec["extremes"] = [dict(self._limit(p[:4]), kind="max" if p[4] > 0 else "min")
                               for p in turns[:MAX_EXTREMES]]
            rec["note"] = (f"{nmax} maxima and {len(turns) - nmax} minima per period: no "
                           f"single time ratio" + (f" (the first {MAX_EXTREMES} listed)"
                                                   if len(turns) > MAX_EXTREMES else ""))
        elif T is not None and self.span[1] - self.span[0] >= T * (1 - 1e-12):
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
        "acceleration; time ratio for a constant-speed angle driver and a column with one "
        "maximum per period (else its extremes)")


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
        # the length scale: the largest coordinate magnitude of the table
        quantity = [self.names[k].rpartition(".")[2] for k in self.value_cols]
        with np.errstate(invalid="ignore"):
            ends = np.abs(np.concatenate([self.lo[:, 1], self.hi[:, 1]]))
        length = np.tile(np.array([q != "phi" for q in quantity]), 2)
        size = float(np.nanmax(np.append(ends[length], 1e-300)))
        recs = []
        for c, k in enumerate(self.value_cols):
            owner, _, q = self.names[k].rpartition(".")
            recs.append((owner, q, self.figure(c, scale=self.full_turn if q == "phi" else size)))
        out: dict = {}
        for owner, q, r in recs:
            if r is not None:
                r["moves"] = bool(r["stroke"] > 1e-9 * (self.full_turn if q == "phi" else size))
            out.setdefault(owner, {})[q] = r
        return {"driver": self.driver_label, "period": self.period, "coordinates": out}


def cycle_section(bodies: dict, points: dict | None, measures: dict | None,
                  contact: dict | None = None) -> dict:
    """summary.json's ``cycle``: the driver and its period, the figures of every body and point
    coordinate (``coordinates.bodies``, ``coordinates.points``), of every measure and, given
    contact (planarkin.forces.output.cycle_contact of the forces section, which the writer
    passes: the rooms do not import each other), every cam's smallest contact force."""
    out = {"driver": bodies["driver"], "period": bodies["period"],
           "coordinates": {"bodies": bodies["coordinates"],
                           "points": points["coordinates"] if points else {}}}
    for part in (bodies, points):
        if part and "error" in part:
            out["error"] = part["error"]
    if measures:
        out["measures"] = measures["measures"]
    if contact:
        out["contact"] = dict(contact)
    out["note"] = NOTE
    return out


def format_contact(contact: dict | None) -> list[str]:
    """Report lines of the smallest contact force of every cam (for --report cycle), from the
    cycle section's ``contact`` (planarkin.forces.output.cycle_contact)."""
    out = []
    for name, rec in (contact or {}).items():
        if rec["min"] is None:
            continue
        out.append(f"         {name}: min contact force {rec['min']:.6g} {rec['unit']} at t = "
                   f"{rec['t']:.6g} s" + (" (negative: the follower would lift off)"
                                          if rec["lift_off"] else ""))
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
    if "extremes" in rec:
        line += f"; {rec['note']}: " + ", ".join(
            f"{x['kind']} {lim(x)}" for x in rec["extremes"])
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
    if section.get("contact"):
        out += ["         cam contact:"] + format_contact(section["contact"])
    if section.get("driver"):
        out.append(f"         (driver: {section['driver']})")
    return out
