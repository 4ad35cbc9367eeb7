"""loads.csv and the ``loads`` section of summary.json: every joint's reaction as a part designer
takes it (an FEA load case, a bearing calculation).

Columns (units as forces.csv's, angles in the model's angle unit): ``t [s]``; per joint with a
reaction (forces.csv's, the redundant ones left out), in the ground frame, the reaction on body j
exactly as forces.csv gives it: ``<joint>.fx``, ``<joint>.fy``, ``<joint>.magnitude`` |(fx, fy)|,
``<joint>.direction`` (the angle of (fx, fy) from the x axis, counter-clockwise, in (-180, 180]
deg or (-pi, pi] rad; 0 for a zero force), ``<joint>.torque`` where the kind transmits a moment;
then for each body the joint connects (i, then j; not the ground, nor the carrier k of a gear,
belt or cam, which gets nothing), the reaction on that body in that body's frame (the frame its
points ``s`` are given in): ``<joint>.<body>.fx``, ``<joint>.<body>.fy``,
``<joint>.<body>.direction`` and ``<joint>.<body>.torque``. The force on i is the solver's
reaction on i (minus the force on j, see each kind's reaction_sign), turned into i's frame; a
torque is the moment about the joint's point as in forces.csv (a scalar: the same in every
frame). A joint that transmits a moment only (``angle``) has its torques only.

Body and element names have no dots (planarkin.model.validate.NAME_RE), so ``<joint>.<body>.fx``
is read back without ambiguity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .layout import element_names
from .units import unit_names
from .solve import JOINT_OUTPUT

PEAK_NOTE = ("peak: the grid row with the largest reaction magnitude |(fx, fy)| (|torque| for a "
             "joint that transmits a moment only) and the reaction there in every frame; it is "
             "the largest grid-row value, not refined between rows (the forces room computes no "
             "force rates): a finer --steps narrows the gap")
MEAN_NOTE = ("mean: the time average over the run (trapezoidal rule over the rows: over a run "
             "of one whole cycle, the cycle's mean); amplitude: half of (max - min) over the rows")
SIGN_NOTE = ("ground frame: the reaction on body j, as forces.csv; <joint>.<body>.*: the "
             "reaction on that body (the force on i is minus the force on j) in that body's "
             "frame; direction: the angle of the force from the frame's x axis, "
             "counter-clockwise; torque: the moment about the joint's point, as forces.csv")


@dataclass(frozen=True)
class JointLoad:
    """One joint's columns in loads.csv (indices into the table, t at 0).

    e: element index; name: its column name; force / torque: what the kind transmits; bodies:
    [(slot, body name, body index)] of the connected bodies that are not the ground, i first;
    ground: {part: column} (fx, fy, magnitude, direction, torque); frames: {body name: {part:
    column}} (fx, fy, direction, torque)."""

    e: int
    name: str
    i: str
    j: str
    force: bool
    torque: bool
    bodies: tuple
    ground: dict
    frames: dict

    @property
    def peak_column(self) -> int:
        """The column whose largest |value| marks the peak row (magnitude, else the torque)."""
        return self.ground["magnitude" if self.force else "torque"]


class LoadsLayout:
    """The columns of loads.csv for a compiled model (left_out: element indices whose reaction
    is not unique: no columns) and the rows from a solve (`rows`)."""

    def __init__(self, cm, left_out=frozenset()):
        spec = cm.spec
        u = unit_names(spec)
        self.deg = spec.angle_unit == "deg"
        angle = spec.angle_unit
        names = element_names(cm)
        index = {name: k for k, name in enumerate(cm.body_names)}
        self.header = ["t [s]"]
        self.joints: list[JointLoad] = []

        def col(title: str, unit: str) -> int:
            self.header.append(f"{title} [{unit}]")
            return len(self.header) - 1

        for e, el in enumerate(spec.joints):
            if e in left_out:
                continue
            out = JOINT_OUTPUT[el.kind]
            force, torque = "fx" in out, "torque" in out
            name = names[e]
            ground = {}
            if force:
                for part in ("fx", "fy", "magnitude"):
                    ground[part] = col(f"{name}.{part}", u["force"])
                ground["direction"] = col(f"{name}.direction", angle)
            if torque:
                ground["torque"] = col(f"{name}.torque", u["torque"])
            bodies, frames = [], {}
            for slot, body in enumerate(el.bodies[:2]):
                if body == "ground":
                    continue
                bodies.append((slot, body, index[body]))
                parts = {}
                if force:
                    parts["fx"] = col(f"{name}.{body}.fx", u["force"])
                    parts["fy"] = col(f"{name}.{body}.fy", u["force"])
                    parts["direction"] = col(f"{name}.{body}.direction", angle)
                if torque:
                    parts["torque"] = col(f"{name}.{body}.torque", u["torque"])
                frames[body] = parts
            self.joints.append(JointLoad(e, name, el.bodies[0], el.bodies[1], force, torque,
                                         tuple(bodies), ground, frames))

    def direction(self, fx, fy) -> np.ndarray:
        """The angle of (fx, fy) from the x axis in the model's angle unit, in (-180, 180] deg
        ((-pi, pi] rad): -0.0 components count as +0.0, so a force along -x is +180, never
        -180, and a zero force has direction 0."""
        a = np.arctan2(fy + 0.0, fx + 0.0)
        return np.degrees(a) if self.deg else a

    def rows(self, F, out: np.ndarray) -> None:
        """Fill out (N, len(header)) with the rows of the Forces F (planarkin.forces.solve)."""
        out[:, 0] = F.t
        turn: dict = {}                                        # body -> (cos, sin) of its angle
        for J in self.joints:
            fx, fy, mo = F.reaction(J.e, 1)
            g = J.ground
            if J.force:
                out[:, g["fx"]] = fx
                out[:, g["fy"]] = fy
                out[:, g["magnitude"]] = np.hypot(fx, fy)
                out[:, g["direction"]] = self.direction(fx, fy)
            if J.torque:
                out[:, g["torque"]] = mo
            for slot, body, b in J.bodies:
                gx, gy, gm = F.reaction(J.e, slot)
                cols = J.frames[body]
                if J.force:
                    if b not in turn:
                        phi = F.p[:, 3 * b + 2]                 # radians
                        turn[b] = (np.cos(phi), np.sin(phi))
                    c, s = turn[b]
                    bx = c * gx + s * gy                        # A(phi)^T (gx, gy)
                    by = c * gy - s * gx
                    out[:, cols["fx"]] = bx
                    out[:, cols["fy"]] = by
                    out[:, cols["direction"]] = self.direction(bx, by)
                if J.torque:
                    out[:, cols["torque"]] = gm


class LoadsAccumulator:
    """Per joint: the row of the largest reaction magnitude (the reaction there in every
    frame), and each column's time average (trapezoidal, across blocks) and half range. A
    non-finite value makes its joint's peak, and its column's mean and amplitude, null with the
    first time it occurred (never skipped)."""

    def __init__(self, layout: LoadsLayout, units: dict, notes: list, left_out: list):
        self.layout = layout
        self.units = units
        self.notes = notes
        self.left_out = left_out
        k = len(layout.header)
        self.hi = np.full(k, -np.inf)
        self.lo = np.full(k, np.inf)
        self.area = np.zeros(k)
        self.bad = np.full(k, np.nan)            # first time of a non-finite value
        self.first = self.last = None            # the first and the last row seen
        self.peak = {J.name: (-1.0, None) for J in layout.joints}   # (value, row)
        self.rows = 0

    def add(self, X: np.ndarray) -> None:
        if not len(X):
            return
        fin = np.isfinite(X)
        if not fin.all():
            where = np.argmax(~fin, axis=0)
            new = ~fin.all(axis=0) & np.isnan(self.bad)
            self.bad[new] = X[where[new], 0]
        with np.errstate(invalid="ignore"):
            self.hi = np.maximum(self.hi, np.where(fin, X, -np.inf).max(axis=0))
            self.lo = np.minimum(self.lo, np.where(fin, X, np.inf).min(axis=0))
            Y = X if self.last is None else np.vstack([self.last, X])
            if len(Y) > 1:
                dt = np.diff(Y[:, 0])
                self.area += (0.5 * (Y[1:] + Y[:-1]) * dt[:, None]).sum(axis=0)
        if self.first is None:
            self.first = X[0].copy()
        self.last = X[-1].copy()
        for J in self.layout.joints:
            v = np.abs(X[:, J.peak_column])
            if not np.isfinite(v).any():
                continue
            i = int(np.argmax(np.where(np.isfinite(v), v, -1.0)))
            if v[i] > self.peak[J.name][0]:
                self.peak[J.name] = (float(v[i]), X[i].copy())
        self.rows += len(X)

    def _mean(self, k: int):
        if not self.rows or not np.isnan(self.bad[k]):
            return None
        span = self.last[0] - self.first[0]
        return float(self.area[k] / span) if span > 0 else float(self.last[k])

    def _amplitude(self, k: int):
        if not self.rows or not np.isnan(self.bad[k]):
            return None
        return float(0.5 * (self.hi[k] - self.lo[k]))

    def _joint(self, J: JointLoad) -> dict:
        cols = [c for c in J.ground.values()] + [c for p in J.frames.values()
                                                 for c in p.values()]
        bad = [float(self.bad[c]) for c in cols if not np.isnan(self.bad[c])]
        unit = self.units["force" if J.force else "torque"]
        components = ("fx", "fy", "torque")
        out: dict = {"i": J.i, "j": J.j}
        _, row = self.peak[J.name]
        if bad or row is None:
            out["peak"] = {"t": None, "magnitude": None, "unit": unit}
            if bad:
                out["peak"]["non_finite_at"] = min(bad)
        else:
            peak = {"t": float(row[0]), "magnitude": float(abs(row[J.peak_column])),
                    "unit": unit}
            keep = ("fx", "fy", "direction", "torque")
            peak["ground"] = {p: float(row[c]) for p, c in J.ground.items() if p in keep}
            for body, parts in J.frames.items():
                peak[body] = {p: float(row[c]) for p, c in parts.items()}
            out["peak"] = peak
        for key, f in (("mean", self._mean), ("amplitude", self._amplitude)):
            d: dict = {}
            if J.force:
                d["magnitude"] = f(J.ground["magnitude"])
            d["ground"] = {p: f(c) for p, c in J.ground.items() if p in components}
            for body, parts in J.frames.items():
                d[body] = {p: f(c) for p, c in parts.items() if p in components}
            out[key] = d
        return out

    def as_dict(self) -> dict:
        return {"units": self.units, "notes": self.notes, "left_out": self.left_out,
                "joints": {J.name: self._joint(J) for J in self.layout.joints}}


def loads_units(cm) -> dict:
    u = unit_names(cm.spec)
    return {"force": u["force"], "torque": u["torque"], "angle": cm.spec.angle_unit,
            "length": cm.spec.length_unit}
