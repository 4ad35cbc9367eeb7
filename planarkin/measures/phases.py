"""Dwells and phases of a column over one period: the rise, dwell and return intervals of the
cycle figures (planarkin.measures.cycle).

A row is still when its exact rate and acceleration are both within DWELL_TOL of the column's
scales: its largest |rate| and |acceleration| over the rows seen, at least FLOOR of the
model's (its length L per period for a length, a turn per period for an angle, and those per
period again for the acceleration), so that a dwell's rounding (|rate| ~ 1e-16 of the motion's)
is still and a coordinate passing through a turning point is not (its acceleration is not zero
there). A dwell is a run of at least two consecutive still rows whose values stay within
DWELL_SPREAD of the column's stroke, with the row on either side whose rate is within the
tolerance too (where the motion stops or starts with a jump of the acceleration, as a harmonic
law's does: that row takes the moving side's acceleration). Its ends are those rows: the motion
stops after the row before the first and starts again before the row after the last, each
within one grid step (`resolution`), and exactly at those rows where the grid has a row at the
stop (a cam law's segment boundaries on a grid that divides them).

`Stills` follows the runs of still rows chunk by chunk, over the rows of a window (one period,
or the whole run without one), keeping per column only its runs (at most MAX_RUNS: more, and
the column has no dwells listed); `phases` orders a period's dwells and turning points into
named intervals.
"""

from __future__ import annotations

import math

import numpy as np

DWELL_TOL = 1e-9      # still: |rate| and |acceleration| within this of the column's scales
FLOOR = 1e-4          # the scales are at least this of the model's (L or a turn, per period)
DWELL_SPREAD = 1e-6   # a dwell's values stay within this of the stroke
MAX_RUNS = 1024       # runs of still rows kept per column


class Stills:
    """Runs of still rows of value columns, fed table chunks (rows of t and columns).

    cols: [(value column, rate column, acceleration column or None)], scale (len(cols),): each
    column's model scale per second (L / T or a turn / T), span: the window's duration T (s),
    stop: the last time of the window."""

    def __init__(self, cols, scale, span: float, stop: float):
        self.cols = list(cols)
        n = len(self.cols)
        self.value = np.array([v for v, _, _ in self.cols], dtype=np.intp)
        self.rate = np.array([r for _, r, _ in self.cols], dtype=np.intp)
        self.acc = np.array([-1 if a is None else a for _, _, a in self.cols], dtype=np.intp)
        self.vfloor = FLOOR * np.asarray(scale, dtype=float)
        self.afloor = self.vfloor / span
        self.stop = stop
        self.vmax = np.zeros(n)
        self.amax = np.zeros(n)
        self.runs: list[list] = [[] for _ in range(n)]
        self.over = np.zeros(n, dtype=bool)
        # the run still open at the last row seen, per column: its first time, the time of the
        # row before it (nan: none seen), its lowest and highest value
        self.open = np.zeros(n, dtype=bool)
        self.first = np.full(n, np.nan)
        self.before = np.full(n, np.nan)
        self.lo = np.full(n, np.nan)
        self.hi = np.full(n, np.nan)
        self.t_last = math.nan
        self.t_first = None
        self.slow_last = np.zeros(n, dtype=bool)    # the last row seen: its rate within tol

    def add(self, X: np.ndarray) -> None:
        if not len(self.cols) or not len(X) or self.t_last > self.stop:
            return
        X = X[:int(np.searchsorted(X[:, 0], self.stop, side="right"))]
        if not len(X):
            return
        if self.t_first is None:
            self.t_first = float(X[0, 0])
        t = X[:, 0]
        Y, V = X[:, self.value], np.abs(X[:, self.rate])
        A = np.where(self.acc >= 0, np.abs(X[:, np.maximum(self.acc, 0)]), 0.0)
        with np.errstate(invalid="ignore"):
            self.vmax = np.fmax(self.vmax, np.nanmax(np.where(np.isfinite(V), V, np.nan),
                                                     axis=0, initial=0.0))
            self.amax = np.fmax(self.amax, np.nanmax(np.where(np.isfinite(A), A, np.nan),
                                                     axis=0, initial=0.0))
            slow = V <= DWELL_TOL * np.maximum(self.vmax, self.vfloor)
            still = slow & (A <= DWELL_TOL * np.maximum(self.amax, self.afloor))
        still[:, self.over] = False
        every, none = still.all(axis=0), ~still.any(axis=0)
        # the common chunks, column by column at once: still throughout (a run goes on or
        # starts at the first row) or not at all (an open run ends at the row before)
        new = every & ~self.open
        self.first[new] = np.where(self.slow_last[new], self.t_last, t[0])
        self.before[new] = np.where(self.slow_last[new], np.nan, self.t_last)
        self.lo[new], self.hi[new] = np.inf, -np.inf
        self.open |= new
        self.lo[every] = np.minimum(self.lo[every], Y[:, every].min(axis=0))
        self.hi[every] = np.maximum(self.hi[every], Y[:, every].max(axis=0))
        for c in np.flatnonzero(none & self.open):
            self._close(c, self.t_last, float(t[0]), slow[0, c])
        for c in np.flatnonzero(~every & ~none):
            self._mixed(c, t, Y[:, c], still[:, c], slow[:, c])
        self.t_last = float(t[-1])
        self.slow_last = slow[-1].copy()

    def _close(self, c: int, last: float, after: float, slow: bool) -> None:
        """End column c's open run at its last row (time last), the row after it at after
        (slow: with a rate within tolerance, where the motion starts with a jump of the
        acceleration: the run's last row)."""
        if slow:
            last, after = after, math.nan
        self.runs[c].append((self.first[c], last, self.before[c], after, self.lo[c],
                             self.hi[c]))
        self.open[c] = False
        if len(self.runs[c]) > MAX_RUNS:
            self.over[c] = True
            self.runs[c] = []

    def _mixed(self, c: int, t, y, m, slow) -> None:
        """Column c over a chunk where some rows are still (m) and some are not (slow: the
        rows whose rate is within tolerance)."""
        d = np.diff(m.astype(np.int8))
        starts = list(np.flatnonzero(d == 1) + 1)
        ends = list(np.flatnonzero(d == -1))
        if m[0]:
            starts.insert(0, 0)
        elif self.open[c]:
            self._close(c, self.t_last, float(t[0]), slow[0])
        if m[-1]:
            ends.append(len(m) - 1)
        for s, e in zip(starts, ends):
            lo, hi = float(np.min(y[s:e + 1])), float(np.max(y[s:e + 1]))
            if not (s == 0 and self.open[c]):
                self.open[c] = True
                self.first[c] = t[s]
                self.before[c] = t[s - 1] if s > 0 else self.t_last
                if slow[s - 1] if s > 0 else self.slow_last[c]:
                    # the motion stopped there with a jump of the acceleration
                    self.first[c], self.before[c] = self.before[c], math.nan
                self.lo[c], self.hi[c] = lo, hi
            else:
                self.lo[c], self.hi[c] = min(self.lo[c], lo), max(self.hi[c], hi)
            if e < len(m) - 1:
                self._close(c, float(t[e]), float(t[e + 1]), slow[e + 1])
            if self.over[c]:
                return

    def dwells(self, c: int, stroke: float, period: float | None = None) -> list | None:
        """Column c's dwells over the window, in time order: dicts start, end (s: the first and
        last still rows), before, after (the moving rows around them, nan: none in the window),
        value; None when the column had more than MAX_RUNS runs. period: the window is one
        period from the first row, which a dwell may span (its end then past the window's)."""
        if self.over[c]:
            return None
        runs = list(self.runs[c])
        if self.open[c]:
            runs.append((self.first[c], self.t_last, self.before[c], math.nan, self.lo[c],
                         self.hi[c]))
        if period is not None and len(runs) > 1 and self.t_first is not None:
            t0 = self.t_first
            head, tail = runs[0], runs[-1]
            if head[0] <= t0 and tail[0] <= t0 + period <= tail[1] + 1e-9 * period:
                # one dwell across the period's end: its rows at the start are its continuation
                runs = runs[1:-1] + [(tail[0], max(tail[1], head[1] + period), tail[2],
                                      head[3] + period, min(tail[4], head[4]),
                                      max(tail[5], head[5]))]
            runs = [r for r in runs if r[0] < t0 + period * (1 - 1e-12)]
        out = []
        for first, last, before, after, lo, hi in runs:
            if last > first and hi - lo <= DWELL_SPREAD * stroke:
                out.append({"start": first, "end": last, "before": before, "after": after,
                            "value": 0.5 * (lo + hi)})
        return out


def phases(marks: list, period: float, t0: float) -> list:
    """The named intervals of one period from its marks in time order: dicts start, end,
    value, kind ('max', 'min' for a turning point or a dwell at an extreme, 'dwell' for a
    pause) and dwell (the dwell's dict, or None for a turning point). Returns [(kind 'rise',
    'dwell' or 'return', start, end, mark or None)] in time order from the first interval
    starting at or after t0 (times past a period are those of the next one)."""
    if len(marks) < 2:
        return []
    out = []
    n = len(marks)
    for k, m in enumerate(marks):
        nxt = marks[(k + 1) % n]
        wrap = 1 if k == n - 1 else 0      # the last interval ends at the first mark's start
        if m["dwell"] is not None:          # a period on
            out.append(("dwell", m["start"], m["end"], 0, m))
        if nxt["start"] + wrap * period > m["end"]:
            out.append(("rise" if nxt["value"] > m["value"] else "return", m["end"],
                        nxt["start"], wrap, None))
    slack = 1e-9 * period
    shifted = []
    for kind, s, e, w, m in out:
        k = math.floor((s - t0 + slack) / period)
        # a time shifted by whole periods only where it must be (exact where it need not)
        shift = lambda x, j: x if j == 0 else x + j * period     # noqa: E731
        shifted.append((kind, shift(s, -k), shift(e, w - k), m))
    shifted.sort(key=lambda p: p[1])
    return shifted


def classify(marks: list) -> None:
    """Set the kind of each dwell mark of a period (in time order, cyclic): 'max' above both
    neighbours, 'min' below both, else 'dwell' (a pause within a rise or a return)."""
    n = len(marks)
    for k, m in enumerate(marks):
        if m["dwell"] is None or n < 2:
            continue
        a, b = marks[k - 1]["value"], marks[(k + 1) % n]["value"]
        v = m["value"]
        m["kind"] = "max" if v > a and v > b else "min" if v < a and v < b else "dwell"
