"""summary.json's ``clearance`` section, accumulated from clearance.csv's rows chunk by chunk:
per pair its refined minimum (t, distance), its limit and the first instant it comes closer (or
null); per limited joint its refined smallest and largest travel and the first instant outside
its range; the model's limit and what a contact is.

The minima are refined as every extreme of run (planarkin.measures.extremes, from the columns'
exact rates and accelerations); the last row of a chunk is kept, so that the interval across
two chunks is refined like any other and the figures do not depend on the chunk size.
"""

from __future__ import annotations

import numpy as np

from ..measures.extremes import better, extreme
from .cycle import first_below


class ClearanceFigures:
    """add(X) the rows of clearance.csv; as_dict() the section. header: the table's."""

    def __init__(self, C, header: list[str]):
        self.C = C
        names = [h.split(" [", 1)[0] for h in header]
        self.at = {n: k for k, n in enumerate(names)}
        self.items = []                   # (key, value column, rate, accel, limits)
        for p in C.pairs:
            self.items.append((p.name,) + self._cols(p.name) + ((p.limit, None),))
        for lim in C.limits:
            self.items.append((lim.joint,) + self._cols(lim.joint) + ((lim.lo, lim.hi),))
        self.low = {it[0]: (np.nan, np.nan) for it in self.items}      # (t, value)
        self.high = {it[0]: (np.nan, np.nan) for it in self.items}
        self.first: dict = {}             # key -> first instant outside
        self.last = None                  # the previous chunk's last row

    def _cols(self, name):
        return (self.at[name], self.at.get(name + ".rate"), self.at.get(name + ".accel"))

    def add(self, X) -> None:
        X = np.asarray(X, dtype=float)
        if not len(X):
            return
        Y = X if self.last is None else np.vstack([self.last, X])
        t = Y[:, 0]
        for key, c, r, a, (lo, hi) in self.items:
            y = Y[:, c]
            v = None if r is None else Y[:, r]
            acc = None if a is None else Y[:, a]
            for sense, store in ((-1.0, self.low), (1.0, self.high)):
                if sense > 0 and hi is None:
                    continue
                tt, val = extreme(t, y, v, acc, sense)
                old = store[key]
                if better(sense * val, sense * old[1]):
                    store[key] = (float(tt), float(val))
            if key not in self.first:
                hits = [first_below(t, y, v, acc, lo)]
                if hi is not None:
                    hits.append(first_below(t, -y, None if v is None else -v,
                                            None if acc is None else -acc, -hi))
                hits = [h for h in hits if h is not None]
                if hits:
                    self.first[key] = min(hits)
        self.last = X[-1:].copy()

    def as_dict(self) -> dict:
        C = self.C
        spec = C.cm.spec.clearance
        out: dict = {"min": spec.min, "on_contact": spec.on_contact, "pairs": {}, "limits": {}}
        for p in C.pairs:
            t, d = self.low[p.name]
            sa, sb = C.cm.shapes[p.a], C.cm.shapes[p.b]
            out["pairs"][p.name] = {"a": sa.name, "b": sb.name, "min": _num(d), "t": _num(t),
                                    "limit": p.limit, "contact": _num(self.first.get(p.name))}
        for lim in C.limits:
            lo, hi = self.low[lim.joint], self.high[lim.joint]
            out["limits"][lim.joint] = {"range": [lim.lo, lim.hi], "min": _num(lo[1]),
                                        "t_min": _num(lo[0]), "max": _num(hi[1]),
                                        "t_max": _num(hi[0]),
                                        "outside": _num(self.first.get(lim.joint))}
        out["contacts"] = sum(1 for p in C.pairs if p.name in self.first)
        out["outside"] = sum(1 for lim in C.limits if lim.joint in self.first)
        return out


def _num(x):
    return None if x is None or not np.isfinite(x) else float(x)
