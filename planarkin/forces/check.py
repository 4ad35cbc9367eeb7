"""The forces room's check of every chunk before it is written (results.refuse calls it).

A non-finite force (a load sqrt(t - 0.5) before 0.5 s, a pole, a spring of zero length) stops
the run at its row: the rows before it are written, the run fails with the time and the
columns. A cam whose contact force turns negative (the follower pulled onto the cam: it would
lift off, the joint being bilateral) gets one warning with the first time, the smallest
contact force and when.
"""

from __future__ import annotations

import numpy as np

from ..solver import Event
from .output import _MEMO, forces_table


class RowCheck:
    """check(an, chunk) -> (row index, message) of the first row to refuse, or None; adds the
    lift-off warnings to the analysis' warnings. The computed rows are handed to the writer's
    forces table (output._MEMO), so that they are computed once."""

    def __init__(self, cm, opts):
        self.cm = cm
        self.table = forces_table(cm, opts)
        self.header = self.table.header
        self.contacts = [k for k, h in enumerate(self.header) if ".contact [" in h]
        self.lift: dict = {}                      # column -> [Event, min, t_min]

    def __call__(self, an, ch):
        X = self.table.compute(ch)
        _MEMO[id(self.cm)] = (ch.t, X)
        stop = None
        fin = np.isfinite(X).all(axis=1)
        if not fin.all():
            i = int(np.argmax(~fin))
            cols = [h.split(" [", 1)[0] for h, v in zip(self.header, X[i]) if not np.isfinite(v)]
            shown = ", ".join(cols[:4]) + (f" and {len(cols) - 4} more" if len(cols) > 4 else "")
            stop = (i, f"non-finite forces at t = {float(ch.t[i]):.10g} s ({shown}): a load, "
                       f"spring or mass that is not finite there (a square root of a negative "
                       f"number, a pole, a spring of zero length?); rows are written up to the "
                       f"one before")
            X = X[:i]
            _MEMO.pop(id(self.cm), None)          # the writer gets a cut chunk: new arrays
        for k in self.contacts:
            self._lift_off(an, X[:, 0], X[:, k], self.header[k])
        return stop

    def _lift_off(self, an, t, f, header):
        if not len(f) or not (f < 0).any():
            return
        j = int(np.argmin(f))
        name, unit = header.split(".contact [", 1)
        unit = unit.rstrip("]")
        rec = self.lift.get(header)
        if rec is None:
            t0 = float(t[int(np.argmax(f < 0))])
            ev = Event("lift-off", t0, "")
            an.follower.warnings.append(ev)
            rec = self.lift[header] = [ev, np.inf, 0.0]
        if f[j] < rec[1]:
            rec[1], rec[2] = float(f[j]), float(t[j])
        ev, low, tl = rec
        ev.message = (f"{name}: the cam's contact force turns negative at t = {ev.t:.6g} s and "
                      f"reaches {low:.4g} {unit} at t = {tl:.6g} s: the follower would lift off "
                      f"the cam there (the cam joint holds it as if glued); a spring must press "
                      f"it on with at least {-low:.4g} {unit} more there")
