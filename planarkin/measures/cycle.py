"""Cycle figures of the measures: limit positions, stroke, dwells, phases and time ratio
(summary.json, ``cycle``).

For every measure value column: its limit positions (smallest and largest value on the grid,
with the time and the driver's coordinate there), each refined between the grid rows from the
exact rate and acceleration (planarkin.measures.extremes: the one function every extreme of
planarkin goes through, the studies' metrics included) into ``refined``; the stroke (refined max -
refined min); its dwells (runs of rows whose exact rate and acceleration vanish, to a tolerance
of the motion's scale: planarkin.measures.phases), an extreme held over a dwell being given as
that dwell's interval, not as a time placed by rounding. For a periodic driver (an angle driven
at constant speed, the run covering at least one period T) its phases over one period (rise,
dwell and return intervals with their times and driver coordinates) and, for a column with one
maximum per period and no dwell, the time of advance (min -> max) and of return and their ratio
(the slower over the faster, >= 1); with dwells no time ratio but the rise, return and dwell
times; a column that peaks more than once per period (a toggle): its turning points over one
period (``extremes``) and no time ratio. A transmission measure also gets its minimum as
``transmission_min``; the section carries every cam's smallest contact force (``contact``,
from the forces section).
"""

from __future__ import annotations

import math

import numpy as np

from .extremes import GRID_ONLY, better, extreme
from .phases import DWELL_SPREAD, MAX_RUNS, Stills, classify, phases

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
    first row reaching one wins (as nanargmin does); scales: per triplet, the model's size of
    the column (its length L, or a turn for an angle; None: no dwells are looked for)."""

    def __init__(self, cm, header: list[str], opts, triplets=None, scales=None):
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
        # the refined extremes (planarkin.measures.extremes): (t, value) per column, of the
        # columns with a rate (a ratio's only at the grid: it is infinite at a dead point)
        self.refined = [c for c, (v, r, _) in enumerate(self.triplets)
                        if r is not None and self.kinds.get(self.names[v]) not in GRID_ONLY]
        self.rlo = np.full((n, 2), np.nan)
        self.rhi = np.full((n, 2), np.nan)
        self.last = None          # the last row of the table seen (the interval to the next)
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
        # per chunk (columns, their rows of the table with the rows around, +1 max / -1 min)
        self.turn_rows: list[tuple] = []
        self.rate_cols = tuple(np.array([-1 if x is None else x for x in col], dtype=np.intp)
                               for col in zip(*[(r, a) for _, r, a in self.triplets])) \
            if self.triplets else ()
        self.turns: list[list] | None = None        # per column, built once from turn_rows
        self.turn_count = np.zeros(n, dtype=np.int64)   # turning points kept per column
        self.turn_over = np.zeros(n, dtype=bool)        # more than MAX_TURNS: none kept
        self.tail = None          # the last table row seen in the turns' window
        self.before = None        # the row before it
        self.head: list = []      # the run's first two rows (the wrap of a one-period run)
        self.into = np.zeros(n)   # sign of the last non-zero change into that row
        self.out0 = None          # sign of the first non-zero change of the run (the wrap)
        self.t_last = None
        # dwells: runs of still rows over one period (the whole run without one)
        if scales is None:
            lu, au = cm.spec.length_unit, cm.spec.angle_unit
            full = 360.0 if au == "deg" else 2 * math.pi
            scales = [cm.L if self.units[v] == lu else full if self.units[v] == au else None
                      for v, _, _ in self.triplets]
        length = self.span[1] - self.span[0]
        window = self.period if self.period is not None and self.period <= length * (
            1 + 1e-12) else length
        self.dwell_cols = [c for c in self.refined if scales[c] is not None]
        self.stills = None
        if self.dwell_cols and window > 0:
            stop = self.span[0] + window + (1.5 * self.h if window < length else 0.0)
            self.stills = Stills([self.triplets[c] for c in self.dwell_cols],
                                 [scales[c] / window for c in self.dwell_cols], window, stop)
        self.dwell_window = window

    def add(self, X: np.ndarray) -> None:
        if not len(X) or not self.triplets:
            return
        V = X[:, self.value_cols]
        if self.period is not None:
            self._turns(X, V)
        if self.stills is not None:
            self.stills.add(X)
        if not len(self.head):
            self.head = [r.copy() for r in X[:2]]
        elif len(self.head) == 1:
            self.head.append(X[0].copy())
        nan = np.isnan(V)
        cols = np.arange(V.shape[1])
        for best, fill, pick, better_than in ((self.lo, np.inf, np.argmin, np.less),
                                              (self.hi, -np.inf, np.argmax, np.greater)):
            idx = pick(np.where(nan, fill, V), axis=0)
            v = V[idx, cols]
            new = ~nan[idx, cols] & (np.isnan(best[:, 1]) | better_than(v, best[:, 1]))
            for c in np.flatnonzero(new):
                _, r, a = self.triplets[c]
                i = idx[c]
                best[c] = (X[i, 0], v[c], X[i, r] if r is not None else np.nan,
                           X[i, a] if a is not None else np.nan)
        if self.refined:
            # the refined extremes of this chunk and of the interval from the last one
            Xe = X if self.last is None else np.vstack([self.last[None], X])
            c = self.refined
            Y, R, A = self._columns(Xe, c)
            for sense, best in ((1.0, self.rhi), (-1.0, self.rlo)):
                t, y = extreme(Xe[:, 0], Y, R, A, sense)
                new = better(sense * y, sense * best[c, 1])
                for k in np.flatnonzero(new):
                    best[c[k]] = (t[k], y[k])
        self.last = X[-1].copy()

    def _columns(self, X: np.ndarray, cols) -> tuple:
        """(values, rates, accelerations) (len(cols), rows) of triplets cols in rows X (nan
        where a column has none)."""
        v = [self.triplets[c][0] for c in cols]
        r, a = (np.array([-1 if self.triplets[c][k] is None else self.triplets[c][k]
                          for c in cols], dtype=np.intp) for k in (1, 2))
        return (X[:, v].T, np.where(r >= 0, X[:, np.maximum(r, 0)], np.nan).T,
                np.where(a >= 0, X[:, np.maximum(a, 0)], np.nan).T)

    def _turns(self, X: np.ndarray, V: np.ndarray) -> None:
        """Record every row where a column turns (its change from the row before and to the row
        after have opposite signs; a run of equal values, or of changes within 1e-13 of the
        values, continues the sign before it), for
        the rows up to 2.5 grid steps past one period: together with the run's first change
        (for a run of exactly one period) every turning point of one period is then seen once
        in the window (start + h/2, start + T + h/2]. Each is kept with the rows before and
        after it, where its extreme is refined (`_refine`)."""
        stop = self.span[0] + self.period + 2.5 * self.h
        if self.t_last is not None and self.t_last > stop:
            return
        n = int(np.searchsorted(X[:, 0], stop, side="right"))
        if not n:
            return
        X, W = X[:n], V[:n]
        before = np.full(X.shape[1], np.nan) if self.before is None else self.before
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
            Xp = np.vstack([before[None], X])       # row k of X is row k + 1 here
            recs = []
            for rows in (Xp[k], Xp[k + 1], Xp[k + 2]):
                recs += [rows[:, 0], rows[np.arange(len(k)), np.asarray(self.value_cols)[c]]]
                recs += [np.where(cols[c] >= 0, rows[np.arange(len(k)), np.maximum(cols[c], 0)],
                                  np.nan) for cols in self.rate_cols]
            self.turn_rows.append((c, np.column_stack(recs + [-S[k + 1, c]])))
            self.turn_count += np.bincount(c, minlength=len(self.turn_count))
            over = self.turn_count > MAX_TURNS
            if (over & ~self.turn_over).any():
                self.turn_over |= over
                self.turn_rows = [(cc[~over[cc]], rr[~over[cc]]) for cc, rr in self.turn_rows]
        self.before = X[-2].copy() if len(X) > 1 else before
        self.tail = X[-1].copy()
        self.into = S[-1].copy()
        self.t_last = float(t[-1])

    def _point(self, row: np.ndarray, c: int) -> list:
        """[t, value, rate, acceleration] of column c (of the triplets) in a table row."""
        v, r, a = self.triplets[c]
        return [row[0], row[v], row[r] if r is not None else np.nan,
                row[a] if a is not None else np.nan]

    def _extremes(self, c: int, stroke: float, size: float) -> list:
        """The turning points of column c over one period, smaller swings than 1e-6 of the
        stroke (rounding of a flat stretch) removed in pairs: [(t, value, rate, acc, +1 max /
        -1 min, refined t, refined value, whether refined: else those of the row)] in time
        order; None past MAX_TURNS."""
        if self.turn_over[c]:
            return None
        if self.turns is None:
            self.turns = [[] for _ in self.triplets]
            for cols, recs in self.turn_rows:
                for j, rec in zip(cols.tolist(), recs.tolist()):
                    self.turns[j].append(rec)
        pts = list(self.turns[c])
        T, t0 = self.period, self.span[0]
        if self.tail is not None and self.out0 is not None and \
                abs(self.t_last - (t0 + T)) <= 1e-9 * T and self.into[c] * self.out0[c] < 0:
            # a run of exactly one period: the wrap, the run's second row a period on after it
            after = self._point(self.head[1], c) if len(self.head) > 1 else [np.nan] * 4
            after[0] += T
            before = self._point(self.before, c) if self.before is not None else [np.nan] * 4
            pts.append(before + self._point(self.tail, c) + after + [-self.out0[c]])
        thr = 1e-6 * stroke + 1e-12 * size
        while len(pts) > 1:
            gaps = [abs(pts[i][5] - pts[i + 1][5]) for i in range(len(pts) - 1)]
            i = int(np.argmin(gaps))
            if gaps[i] >= thr:
                break
            del pts[i:i + 2]
        lo, hi = t0 + 0.5 * self.h, t0 + T + 0.5 * self.h
        pts = [p for p in pts if lo < p[4] <= hi]
        if not pts:
            return []
        P = np.array(pts)
        stencil = P[:, :12].reshape(len(P), 3, 4)
        refine = c in self.refined
        out = []
        for sense in (1.0, -1.0):
            sel = np.flatnonzero(P[:, 12] == sense)
            if not len(sel):
                continue
            st = stencil[sel]
            if refine:
                tr, yr = extreme(st[:, :, 0], st[:, :, 1], st[:, :, 2], st[:, :, 3], sense)
            else:
                tr, yr = st[:, 1, 0], st[:, 1, 1]
            out += [tuple(st[i, 1]) + (sense, float(tr[i]), float(yr[i]), refine)
                    for i in range(len(sel))]
        return sorted(out, key=lambda p: p[0])

    def _at(self, t: float) -> dict:
        out = {"t": float(t)}
        if self.driver is not None:
            out["driver"] = float(self.driver(t))
        return out

    def _limit(self, rec, refined=None) -> dict:
        """A limit position: the grid row rec (t, value, ...) and, given, its refined (t,
        value)."""
        out = {"value": float(rec[1]), **self._at(rec[0])}
        if refined is not None and not np.isnan(refined[1]):
            out["refined"] = {"value": float(refined[1]), **self._at(refined[0])}
        return out

    def _interval(self, d: dict) -> dict:
        """A dwell's interval as reported."""
        return {"start": self._at(d["start"]), "end": self._at(d["end"]),
                "duration": d["end"] - d["start"], "resolution": self.h}

    def _marks(self, dwells: list, turns: list, stroke: float) -> list:
        """A period's dwells and the turning points not at one, in time order (phases.phases'
        marks)."""
        T, h = self.period, self.h
        marks = [{"start": d["start"], "end": d["end"], "value": d["value"], "kind": "dwell",
                  "dwell": d} for d in dwells]
        tol = DWELL_SPREAD * stroke
        for p in turns:
            t, y = p[5], p[6]
            at = any(abs(y - d["value"]) <= tol and any(
                d["start"] - 1.5 * h <= t + k * T <= d["end"] + 1.5 * h for k in (-1, 0, 1))
                for d in dwells)
            if not at:
                marks.append({"start": t, "end": t, "value": y,
                              "kind": "max" if p[4] > 0 else "min", "dwell": None, "turn": p})
        marks.sort(key=lambda m: m["start"])
        classify(marks)
        return marks

    def _mark(self, m: dict) -> dict:
        """A turning point or an extreme dwell as listed in ``extremes``."""
        if m["dwell"] is not None:
            return {"value": m["value"], "dwell": self._interval(m["dwell"]), "kind": m["kind"]}
        p = m["turn"]
        return dict(self._limit(p[:4], p[5:7] if p[7] else None), kind=m["kind"])

    def figure(self, c: int, kind: str | None = None, scale: float = 0.0) -> dict | None:
        """The figures of value column number c (of the triplets): unit, min, max, stroke and,
        for a periodic driver, phases, advance, return and time ratio; None without a finite
        value. scale: the table's size in the column's unit (a coordinate whose stroke is within
        1e-9 of it does not move: its rounding noise has no turning points nor dwells)."""
        k = self.value_cols[c]
        if np.isnan(self.lo[c, 1]):
            return None
        refine = c in self.refined
        lo = self._limit(self.lo[c], self.rlo[c] if refine else None)
        hi = self._limit(self.hi[c], self.rhi[c] if refine else None)
        rec = {"unit": self.units[k], "min": lo, "max": hi,
               "stroke": hi.get("refined", hi)["value"] - lo.get("refined", lo)["value"]}
        stroke = rec["stroke"]
        T = self.period
        if kind in GRID_ONLY:
            rec["note"] = "grid extremes only; a ratio is infinite at a dead point"
            T = None
        size = max(abs(lo["value"]), abs(hi["value"]), scale)
        moves = stroke > 1e-9 * size
        dwells = []
        if moves and c in self.dwell_cols:
            dwells = self.stills.dwells(self.dwell_cols.index(c), stroke,
                                        T if self.dwell_window == T else None)
            if dwells is None:
                rec["note"] = f"more than {MAX_RUNS} dwells: none listed"
                dwells = []
        # an extreme held over a dwell is that dwell (the first, and all there are listed)
        for side, lim in (("min", lo), ("max", hi)):
            at = [d for d in dwells if abs(d["value"] - lim.get("refined", lim)["value"])
                  <= DWELL_SPREAD * stroke]
            if at:
                rec[side] = {"value": lim.get("refined", lim)["value"],
                             "dwell": self._interval(at[0])}
                if len(at) > 1:
                    rec[side]["dwells"] = [self._interval(d) for d in at[:MAX_EXTREMES]]
        turns = [] if T is None or not moves else self._extremes(c, stroke, size)
        if turns is None:
            rec["note"] = (f"more than {MAX_TURNS} turning points per period: none listed, no "
                           f"single time ratio")
            return self._finish(rec, kind)
        if T is None:
            return self._finish(rec, kind)
        marks = self._marks(dwells, turns, stroke)
        nmax = sum(1 for m in marks if m["kind"] == "max")
        nmin = sum(1 for m in marks if m["kind"] == "min")
        whole = self.span[1] - self.span[0] >= T * (1 - 1e-12)
        ph = phases(marks, T, self.span[0]) if whole else []
        if ph:
            rec["phases"] = [dict({"kind": p[0], "start": self._at(p[1]), "end": self._at(p[2]),
                                   "duration": p[2] - p[1]},
                                  **({"value": p[3]["value"]} if p[3] is not None else {}))
                             for p in ph[:MAX_EXTREMES]]
        if nmax > 1:
            # a toggle: the column peaks more than once per period; advance and return (and
            # their ratio) are not defined
            rec["extremes"] = [self._mark(m) for m in marks if m["kind"] != "dwell"][
                :MAX_EXTREMES]
            rec["note"] = (f"{nmax} maxima and {nmin} minima per period: no "
                           f"single time ratio" + (f" (the first {MAX_EXTREMES} listed)"
                                                   if nmax + nmin > MAX_EXTREMES else ""))
        elif ph and dwells:
            times = {kd: sum(p[2] - p[1] for p in ph if p[0] == kd)
                     for kd in ("rise", "return", "dwell")}
            rec["rise_time"], rec["return_time"] = times["rise"], times["return"]
            rec["dwell_time"] = times["dwell"]
            if times["rise"] > 0 and times["return"] > 0:
                rec["rise_return_ratio"] = times["rise"] / times["return"]
            rec["note"] = ("dwells: no time ratio; rise_return_ratio is rise_time / "
                           "return_time, the dwells excluded")
        elif whole and not dwells:
            t_lo = lo.get("refined", lo)["t"]
            t_hi = hi.get("refined", hi)["t"]
            adv = (t_hi - t_lo) % T
            ret = T - adv
            if min(adv, ret) > self.h:        # else a monotonic column (a crank angle)
                rec["advance_time"] = adv
                rec["return_time"] = ret
                rec["time_ratio"] = max(adv, ret) / min(adv, ret)
        return self._finish(rec, kind)

    def _finish(self, rec: dict, kind) -> dict:
        """rec with a transmission measure's `transmission_min`."""
        if kind == "transmission":
            rec["transmission_min"] = rec["min"].get("refined", rec["min"])
        return rec

    def as_dict(self) -> dict:
        figures = {}
        for c, k in enumerate(self.value_cols):
            name = self.names[k]
            figures[name] = self.figure(c, self.kinds.get(name))
        return {"driver": self.driver_label, "period": self.period, "measures": figures,
                "note": NOTE}


NOTE = ("limit positions from the grid, refined between the rows from the exact rate and "
        "acceleration (quintic Hermite); an extreme held over a dwell given as the dwell; "
        "phases (rise, dwell, return) for a constant-speed angle driver; time ratio for a "
        "column with one maximum per period and no dwell (else its extremes, or with dwells "
        "its rise, return and dwell times)")


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


def _span(a: dict, b: dict) -> str:
    """'t = a..b s (driver a..b)' of two instants."""
    out = f"t = {a['t']:.6g}..{b['t']:.6g} s"
    if "driver" in a:
        out += f" (driver {a['driver']:.6g}..{b['driver']:.6g})"
    return out


def _line(name: str, rec: dict | None) -> str:
    if rec is None:
        return f"         {name}: no finite values"
    u = rec["unit"]

    def lim(x):
        if "dwell" in x:
            d = x["dwell"]
            more = f" (and {len(x['dwells']) - 1} more)" if "dwells" in x else ""
            return f"{x['value']:.6g} {u} over the dwell {_span(d['start'], d['end'])}{more}"
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
    if "rise_time" in rec:
        line += "; " + ", ".join(
            f"{p['kind']} {p['duration']:.6g} s ("
            + (f"driver {p['start']['driver']:.6g}..{p['end']['driver']:.6g})"
               if "driver" in p["start"] else f"t = {p['start']['t']:.6g}..{p['end']['t']:.6g} s)")
            for p in rec["phases"])
        line += ": no time ratio (dwells)"
        if "rise_return_ratio" in rec:
            line += f"; rise / return time {rec['rise_return_ratio']:.6g}, dwells excluded"
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
