"""The forces room's check of every chunk before it is written (analysis.refuse calls it).

A non-finite force (a load sqrt(t - 0.5) before 0.5 s, a pole, a spring of zero length) stops
the run at its row: the rows before it are written, the run fails with the time and the
columns. A cam whose contact force turns negative (the follower pulled onto the cam: it would
lift off, the joint being bilateral) gets one warning with the first time, the smallest
contact force and when. A gear pair or belt whose centres on its carrier are not known (no pitch
point for its tooth force: solve.unplaced) gets one 'tooth-force' warning at the first row.
"""

from __future__ import annotations

import numpy as np

from ..elements import KINDS
from planarkin.solver.grid import Event
from .layout import CONTACT_KINDS
from .output import APPLIED_MEMO, ROWS_MEMO, ForceRows
from .solve import Kinetostatics


def _applied_only(cm):
    """A Kinetostatics used only for its applied and inertia forces (any n rows will do)."""
    return Kinetostatics(cm, rows=np.arange(cm.n), dense=True)


class RowCheck:
    """check(an, chunk) -> (row index, message) of the first row to refuse, or None; adds the
    lift-off warnings to the analysis' warnings.

    A model with cams has its whole forces table computed here (the contact forces decide
    lift-off); the rows, with loads.csv's, are handed to the writer's forces table
    (output.ROWS_MEMO), so that they are computed once. Other models have only their applied
    forces computed (loads, springs, gravity and inertia: what can make a force row non-finite
    when the motion is finite; the multipliers solve a regular system with it), at a fraction of
    the table's cost."""

    def __init__(self, cm, opts):
        self.cm = cm
        self.lift: dict = {}                      # column -> [Event, min, t_min]
        self.K = None
        self.contacts = []
        from .solve import physical_kind, unplaced
        self.unplaced = unplaced(cm)
        if any(el.kind in CONTACT_KINDS or physical_kind(KINDS[el.kind])
               for el in cm.spec.joints):
            self.table = ForceRows(cm)
            self.header = self.table.header
            self.contacts = [k for k, h in enumerate(self.header) if ".contact [" in h]
            from .layout import column_name
            self.labels = {column_name(el): el.label for el in cm.spec.joints}

    def __call__(self, an, ch):
        if self.unplaced and len(ch.t):
            for e, missing in self.unplaced:
                an.follower.warnings.append(Event("tooth-force", float(ch.t[0]),
                                                  self._unplaced(self.cm.spec.elements[e],
                                                                 missing)))
            self.unplaced = []
        if not self.contacts:
            return self._applied(ch)
        X, XL = self.table.compute(ch)
        ROWS_MEMO.clear()                             # one chunk's rows at most are held
        ROWS_MEMO[id(self.cm)] = (ch.t, X, XL)
        stop = None
        fin = np.isfinite(X).all(axis=1)
        if not fin.all():
            i = int(np.argmax(~fin))
            cols = [h.split(" [", 1)[0] for h, v in zip(self.header, X[i]) if not np.isfinite(v)]
            stop = (i, self._message(float(ch.t[i]), cols))
            if self._applied(_row(ch, i)) is None:
                stop = (i, self._undetermined(float(ch.t[i]), cols))
            X = X[:i]
            ROWS_MEMO.pop(id(self.cm), None)          # the writer gets a cut chunk: new arrays
        for k in self.contacts:
            self._lift_off(an, X[:, 0], X[:, k], self.header[k])
        return stop

    def _applied(self, ch):
        """The first row whose applied or inertia forces are not finite."""
        cm = self.cm
        if self.K is None:
            self.K = _applied_only(cm)
        K = self.K
        unit = np.tile([1.0, 1.0, cm.angle_factor], cm.nb)
        with np.errstate(all="ignore"):
            QA, Qin = K.generalised_forces(np.asarray(ch.t, float), ch.q * unit, ch.qd * unit,
                                           ch.qdd * unit)
            bad = ~(np.isfinite(QA).all(axis=1) & np.isfinite(Qin).all(axis=1))
        if not bad.any():
            APPLIED_MEMO.clear()                      # the table takes them (output.compute)
            APPLIED_MEMO[id(cm)] = (ch.t, QA, Qin)
            return None
        i = int(np.argmax(bad))
        t = float(ch.t[i])
        names = []
        for ld in cm.spec.forces.loads:
            if ld.kind in ("force", "torque"):
                with np.errstate(all="ignore"):
                    v = [np.asarray(f(np.array([t])), float) for f in ld.f]
                if not all(np.isfinite(x).all() for x in v):
                    names.append(ld.name or f"load {ld.index} ({ld.kind} {'-'.join(ld.bodies)})")
        return i, self._message(t, names or ["an applied force (a spring of zero length?)"])

    @staticmethod
    def _unplaced(el, missing):
        gear = el.kind == "gear"
        what, part = ("tooth force", "gear") if gear else ("belt pull", "pulley")
        carrier = el.bodies[2] if len(el.bodies) > 2 else "ground"
        one = len(missing) == 1
        return (f"{el.label}: the {what} is not known: {part}{'' if one else 's'} "
                f"{' and '.join(missing)} turn{'s' if one else ''} on no revolute joint to the "
                f"carrier {carrier}, nor on one about the carrier's axis, so "
                f"{'its centre is' if one else 'their centres are'} not known; forces.csv "
                f"gives the {'teeth' if gear else 'belt'}'s torque on {el.bodies[1]} alone, and "
                f"the bearing loads leave the {what} out")

    @staticmethod
    def _undetermined(t, cols):
        names = list(dict.fromkeys(c.rsplit(".", 1)[0] for c in cols))
        return (f"the reaction of {', '.join(names[:3])} at t = {t:.10g} s is not determined: "
                f"the joints its parts turn or slide on cannot take its contact force (a gear or "
                f"pulley whose revolute joint to its carrier is not its centre, a cam whose "
                f"revolute joint is not at sk, a follower not guided along vk?); rows are "
                f"written up to the one before")

    @staticmethod
    def _message(t, cols):
        shown = ", ".join(cols[:4]) + (f" and {len(cols) - 4} more" if len(cols) > 4 else "")
        return (f"non-finite forces at t = {t:.10g} s ({shown}): a load, spring or mass that is "
                f"not finite there (a square root of a negative number, a pole, a spring of zero "
                f"length?); rows are written up to the one before")

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
        ev.message = (f"{self.labels.get(name, name)}: the cam's contact force turns negative "
                      f"at t = {ev.t:.6g} s and reaches {low:.4g} {unit} at t = {tl:.6g} s: the "
                      f"follower would lift off the cam there (the cam joint holds it as if "
                      f"glued); a spring must press it on with at least {-low:.4g} {unit} more "
                      f"there")


def _row(ch, i):
    """Chunk ch's row i alone (t, q, qd, qdd: what _applied reads)."""
    class _One:
        pass
    one = _One()
    one.t = ch.t[i:i + 1]
    one.q, one.qd, one.qdd = ch.q[i:i + 1], ch.qd[i:i + 1], ch.qdd[i:i + 1]
    return one
