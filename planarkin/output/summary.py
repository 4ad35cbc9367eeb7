"""summary.json: what happened, how well, and every column's range - built from streamed chunks."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

EPS = np.finfo(float).eps


class ColumnStats:
    """Running min/max (and when) of every column of a table."""

    def __init__(self, header: list[str]):
        self.header = header
        k = len(header) - 1
        self.min = np.full(k, np.inf)
        self.max = np.full(k, -np.inf)
        self.tmin = np.full(k, np.nan)
        self.tmax = np.full(k, np.nan)

    def add(self, X: np.ndarray) -> None:
        if not len(X):
            return
        t, V = X[:, 0], X[:, 1:]
        if V.shape[1] == 0:
            return
        W = V.T.copy()           # argmin along contiguous rows: much faster than nan-aware
        imin = W.argmin(axis=1)
        imax = W.argmax(axis=1)
        cols = np.arange(V.shape[1])
        if np.isnan(W[cols, imin]).any() or np.isnan(W[cols, imax]).any():
            imin = np.nanargmin(np.where(np.isnan(V), np.inf, V), axis=0)
            imax = np.nanargmax(np.where(np.isnan(V), -np.inf, V), axis=0)
        vmin, vmax = V[imin, cols], V[imax, cols]
        lo = vmin < self.min
        hi = vmax > self.max
        self.min[lo], self.tmin[lo] = vmin[lo], t[imin[lo]]
        self.max[hi], self.tmax[hi] = vmax[hi], t[imax[hi]]

    def as_dict(self) -> dict:
        out = {}
        for k, name in enumerate(self.header[1:]):
            if not math.isfinite(self.min[k]):
                continue
            out[name] = {"min": float(self.min[k]), "t_min": float(self.tmin[k]),
                         "max": float(self.max[k]), "t_max": float(self.tmax[k])}
        return out


class StepStats:
    """Per-step diagnostics folded over the run: Newton iterations, conditioning, residuals."""

    def __init__(self):
        self.rows = 0
        self.iter_sum = 0
        self.iter_min = None
        self.iter_max = 0
        self.cond_min = math.inf
        self.cond_max = 0.0
        self.cond_tmax = math.nan
        self.res_max = 0.0
        self.res_tmax = math.nan
        self.t_last = math.nan         # time of the last row written, s

    def add(self, ch) -> None:
        n = len(ch.t)
        if not n:
            return
        self.rows += n
        self.t_last = float(ch.t[-1])
        it = ch.iterations
        self.iter_sum += int(it.sum())
        self.iter_min = int(it.min()) if self.iter_min is None else min(self.iter_min,
                                                                        int(it.min()))
        self.iter_max = max(self.iter_max, int(it.max()))
        c = np.where(np.isfinite(ch.cond), ch.cond, np.inf)
        self.cond_min = min(self.cond_min, float(c.min()))
        i = int(np.argmax(c))
        if c[i] > self.cond_max:
            self.cond_max, self.cond_tmax = float(c[i]), float(ch.t[i])
        r = ch.residual
        i = int(np.argmax(r))
        if r[i] > self.res_max:
            self.res_max, self.res_tmax = float(r[i]), float(ch.t[i])


def error_estimates(steps: StepStats) -> dict:
    """Relative error estimates from the conditioning (reference §7.4): positions from the worst
    residual times the condition estimate; velocities from rounding in the linear solve
    (condition x eps) plus the effect of the position error on the Jacobian; accelerations,
    whose right-hand side carries the velocity error quadratically, an order more."""
    c = steps.cond_max if math.isfinite(steps.cond_max) else float("inf")
    pos = c * max(steps.res_max, EPS)
    vel = c * (10 * EPS + pos)
    return {"position": pos, "velocity": vel, "acceleration": 10 * vel}


def write_json(path: Path, data: dict) -> None:
    def clean(v):
        if isinstance(v, float) and not math.isfinite(v):
            return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, np.generic):
            return clean(v.item())
        return v
    Path(path).write_text(json.dumps(clean(data), indent=2) + "\n")
