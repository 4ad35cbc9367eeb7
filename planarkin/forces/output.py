"""forces.csv, the ``forces`` section of summary.json and forces.png; loads.csv and the ``loads``
section (planarkin.forces.loads), from the same solve.

Columns (units: the model's force unit, force * length for torques, see `units`): ``t [s]``;
per driver its effort (``<name>.torque`` for angle drivers, ``<name>.force`` otherwise: what the
actuator exerts on its body j along the driven coordinate); per joint its reaction on body j
(``<name>.fx``, ``<name>.fy`` global, ``<name>.torque`` about the joint's point where the kind
transmits a moment, see `solve.JOINT_OUTPUT`); per driver ``<name>.power``; ``total.power``; and
``shaking.fx``, ``shaking.fy``, ``shaking.torque``: what all joints and drivers together exert on
the ground, the moment about the origin. An element without a name is called by its message
label made CSV-safe (``joint_3_revolute_crank-rod``).
"""

from __future__ import annotations

import numpy as np

from ..derived import DerivedTable
from .layout import columns, redundancy
from .loads import (MEAN_NOTE, PEAK_NOTE, SIGN_NOTE, LoadsAccumulator, LoadsLayout,
                    loads_units)
from .units import unit_names
from .solve import Kinetostatics

SINGULAR_NOTE = ("near a singular configuration (see the near-singular warnings) joint "
                 "reactions and driver efforts grow without bound: values there are large and "
                 "sensitive to the geometry")


class ForceRows:
    """The rows of forces.csv and loads.csv (planarkin.forces.loads) of a model, both from one
    solve of each chunk (`compute`)."""

    def __init__(self, cm):
        self.cm = cm
        rows, self.left_out, self.labels = redundancy(cm)
        self.K = Kinetostatics(cm, rows)
        self.cols = columns(cm, self.left_out)
        self.header = ["t [s]"] + [h for h, _, _ in self.cols]
        self.loads = LoadsLayout(cm, self.left_out)

    def compute(self, ch, loads: bool = True):
        """(forces.csv rows, loads.csv rows or None) of the chunk ch (t, q, qd, qdd)."""
        cm, K, cols = self.cm, self.K, self.cols
        per = K.points_per_solve
        N = len(ch.t)
        applied = APPLIED_MEMO.pop(id(cm), None)    # its applied and inertia forces
        if applied is not None and (applied[0] is not ch.t or N > per):
            applied = None
        X = np.empty((N, len(self.header)))
        XL = np.empty((N, len(self.loads.header))) if loads else None
        X[:, 0] = ch.t
        for a in range(0, N, per):
            sl = slice(a, a + per)
            F = K.solve(ch.t[sl], ch.q[sl], ch.qd[sl], ch.qdd[sl],
                        applied=None if applied is None else applied[1:])
            ground = None
            for k, (_, get, role) in enumerate(cols, start=1):
                if role == "shaking":
                    ground = F.ground() if ground is None else ground
                    X[sl, k] = ground[k - len(cols) + 2]
                else:
                    X[sl, k] = get(F)
            if loads:
                self.loads.rows(F, XL[sl])
        return X, XL


def force_tables(cm, opts) -> list[DerivedTable]:
    """[forces.csv, loads.csv]: two DerivedTables fed by one solve per chunk. The writer
    computes a chunk's tables in order, so loads.csv takes the rows computed with forces.csv's
    (held for that chunk only, by the identity of its t); asked alone (Result.table), it solves
    the chunk itself."""
    R = ForceRows(cm)
    held: dict = {}

    def forces(ch) -> np.ndarray:
        memo = ROWS_MEMO.pop(id(cm), None)          # the rows the refusal check computed already
        if memo is not None and memo[0] is ch.t:
            X, XL = memo[1], memo[2]
        else:
            X, XL = R.compute(ch)
        held.clear()
        held["rows"] = (ch.t, XL)
        return X

    def loads(ch) -> np.ndarray:
        memo = held.pop("rows", None)
        if memo is not None and memo[0] is ch.t and memo[1] is not None:
            return memo[1]
        return R.compute(ch)[1]

    notes = [SINGULAR_NOTE]
    if R.labels:
        notes.append("redundant constraints have no unique reaction; left out of forces.csv: "
                     + "; ".join(R.labels))
    cols = R.cols
    efforts = [k for k, (_, _, role) in enumerate(cols, start=1) if role == "effort"]
    contacts = [k for k, (_, _, role) in enumerate(cols, start=1) if role == "contact"]
    if contacts:
        notes.append(LIFT_OFF_NOTE)
    units = unit_names(cm.spec)
    units["length"] = cm.spec.length_unit
    header = R.header
    labels = R.labels

    def accumulator():
        return Accumulator(header, efforts, notes, labels, units, contacts)

    load_notes = [SIGN_NOTE, PEAK_NOTE, MEAN_NOTE, SINGULAR_NOTE]
    if labels:
        load_notes.append("redundant constraints have no unique reaction; left out of "
                          "loads.csv: " + "; ".join(labels))

    def load_accumulator():
        return LoadsAccumulator(R.loads, loads_units(cm), load_notes, labels)

    from .plot import forces_plot
    return [DerivedTable("forces.csv", header, forces, section="forces", accumulator=accumulator,
                         plot=forces_plot),
            DerivedTable("loads.csv", R.loads.header, loads, section="loads",
                         accumulator=load_accumulator)]


def forces_table(cm, opts) -> DerivedTable:
    """forces.csv's DerivedTable alone (force_tables)."""
    return force_tables(cm, opts)[0]


LIFT_OFF_NOTE = ("a cam joint is bilateral: it holds the follower on the cam as if glued. "
                 "<name>.contact is the normal contact force, positive while the cam presses on "
                 "the follower; where it is negative the follower would lift off (see contact."
                 "<name>.min and the lift-off warning): a spring must add at least that much")

# id(cm) -> (t, forces.csv rows, loads.csv rows) of the chunk the refusal check computed (models
# with cams: planarkin.forces.check); a non-finite value in a written row: the run stops there;
# a column's peak and RMS then never hide it
ROWS_MEMO: dict = {}
# id(cm) -> (t, Q^A, Q^in) of the chunk the refusal check just passed: a model without cams has
# only its applied and inertia forces computed there, the same arrays the table needs (one chunk
# held at most; a chunk cut after the check has new arrays and is computed afresh)
APPLIED_MEMO: dict = {}


class Accumulator:
    """Peak (largest |value|, signed, and when) of every force column; RMS of driver efforts;
    the smallest contact force of every cam (and when). A non-finite value makes its column's
    peak and RMS null with the first time it occurred (never skipped)."""

    def __init__(self, header, efforts, notes, left_out, units, contacts=()):
        self.header = header
        self.efforts = efforts
        self.notes = notes
        self.left_out = left_out
        self.units = units
        self.contacts = list(contacts)
        k = len(header) - 1
        self.peak = np.full(k, -1.0)
        self.value = np.zeros(k)
        self.when = np.zeros(k)
        self.sq = np.zeros(k)
        self.bad = np.full(k, np.nan)           # first time of a non-finite value
        self.low = np.full(k, np.inf)
        self.low_t = np.zeros(k)
        self.rows = 0

    def add(self, X: np.ndarray) -> None:
        if not len(X):
            return
        V = X[:, 1:]
        A = np.abs(V)
        fin = np.isfinite(V)
        if not fin.all():
            first = np.argmax(~fin, axis=0)
            new = ~fin.all(axis=0) & np.isnan(self.bad)
            self.bad[new] = X[first[new], 0]
        i = np.argmax(np.where(fin, A, -1.0), axis=0)
        cols = np.arange(V.shape[1])
        better = A[i, cols] > self.peak
        self.peak[better] = A[i, cols][better]
        self.value[better] = V[i, cols][better]
        self.when[better] = X[i, 0][better]
        with np.errstate(over="ignore", invalid="ignore"):
            self.sq += (V * V).sum(axis=0)
        j = np.argmin(np.where(fin, V, np.inf), axis=0)
        lower = V[j, cols] < self.low
        self.low[lower] = V[j, cols][lower]
        self.low_t[lower] = X[j, 0][lower]
        self.rows += len(X)

    def as_dict(self) -> dict:
        name = lambda k: self.header[k].split(" [", 1)[0]

        def peak(k):
            if not np.isnan(self.bad[k]):
                return {"value": None, "abs": None, "t": None,
                        "non_finite_at": float(self.bad[k])}
            return {"value": float(self.value[k]), "abs": float(self.peak[k]),
                    "t": float(self.when[k])}

        def rms(k):
            if not self.rows or not np.isnan(self.bad[k - 1]):
                return None
            return float(np.sqrt(self.sq[k - 1] / self.rows))
        out = {
            "units": self.units,
            "peak": {name(k + 1): peak(k) for k in range(len(self.peak)) if self.rows},
            "rms": {name(k): rms(k) for k in self.efforts},
            "left_out": self.left_out,
            "notes": self.notes,
        }
        if self.contacts:
            out["contact"] = {
                name(k).rsplit(".", 1)[0]: {
                    "min": float(self.low[k - 1]) if self.rows and np.isfinite(self.low[k - 1])
                    else None, "t": float(self.low_t[k - 1]),
                    "lift_off": bool(self.low[k - 1] < 0), "unit": self.units["force"]}
                for k in self.contacts}
        return out


def cycle_contact(section: dict | None) -> dict:
    """The cycle figures' hook for planarkin.measures.cycle: {cam name: {"min", "t", "lift_off",
    "unit"}} from summary.json's forces section (empty without cams or forces)."""
    return dict((section or {}).get("contact", {}))
