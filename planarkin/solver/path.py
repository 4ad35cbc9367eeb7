"""The path follower's data: its internal nodes, the events that stop or mark it, the drivers'
breakpoints it lands on, and the quintic Hermite interpolant between nodes (the grid pass's
prediction and dense output). Internal units throughout (lengths / L, radians, seconds).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import math
from dataclasses import dataclass, field

import numpy as np


from .tolerances import NODE_TOL  # noqa: F401  (the path's Newton tolerance, shared)

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel
PATH_POLICY = "reuse"   # Newton at path nodes: one factorisation per block and candidate


def path_block(n: int) -> int:
    """Largest solve block of the path follower: the whole system up to 64 unknowns (fewest
    Python-level calls); beyond, 12 (dense inverses of merged blocks cost k^3: 64-blocks made
    the N = 1000 four-bar chain spend long in LAPACK, 12-blocks keep both costs small;
    benchmarks/README.md, "Figures moved from the code's comments")."""
    return n if n <= 64 else 12


@dataclass
class Nodes:
    """Internal nodes of the path (exact solutions): t (K,), q, qd, qdd (K, n + 3) internal units,
    sign: per node the determinant signs of the fine blocks, cond (K,) condition estimate,
    seg (K,) which set of equations (segment) the node was solved with: a model with redundant
    constraints may switch the set along the path, the switch node then appears twice."""

    t: list = field(default_factory=list)
    q: list = field(default_factory=list)
    qd: list = field(default_factory=list)
    qdd: list = field(default_factory=list)
    sign: list = field(default_factory=list)
    cond: list = field(default_factory=list)
    seg: list = field(default_factory=list)

    def add(self, t, q, qd, qdd, sign, cond, seg=0):
        self.t.append(float(t))
        self.q.append(q)
        self.qd.append(qd)
        self.qdd.append(qdd)
        self.sign.append(sign)
        self.cond.append(float(cond))
        self.seg.append(seg)

    def truncate(self, k: int) -> None:
        """Keep nodes 0..k."""
        for lst in (self.t, self.q, self.qd, self.qdd, self.sign, self.cond, self.seg):
            del lst[k + 1:]

    def copy_from(self, other: "Nodes", k: int) -> None:
        for name in ("t", "q", "qd", "qdd", "sign", "cond", "seg"):
            getattr(self, name).append(getattr(other, name)[k])

    def __len__(self):
        return len(self.t)


@dataclass
class Event:
    """Why the path stopped (or what it passed, for warnings).

    kind: 'lock-up', 'bifurcation', 'near-singular', 'driver', 'redundant', 'failure',
    'breakpoint' (a warning: a driver's kink, followed piece by piece)."""

    kind: str
    t: float
    message: str
    cond: float = float("nan")
    constraints: list = field(default_factory=list)
    bodies: list = field(default_factory=list)

    def as_dict(self):
        d = {"kind": self.kind, "t": self.t, "message": self.message}
        if math.isfinite(self.cond):
            d["condition"] = self.cond
        if self.constraints:
            d["constraints"] = self.constraints
        if self.bodies:
            d["bodies"] = self.bodies
        return d


@dataclass
class Kink:
    """A time where one or more drivers' derivatives jump (their TimeFunction.breakpoints):
    t (s) and jumps: list of (driver row, Breakpoint), jumps in the driver's user units."""

    t: float
    jumps: list = field(default_factory=list)


# rows exactly at a breakpoint take this one-sided limit (documented in the README, stated in
# summary.json): the right-hand one, which continues into the run; the end row the left-hand one
ROWS_AT_BREAKPOINTS = ("right-hand limit (t+) of velocities and accelerations; a row at the end "
                       "time: left-hand limit (t-)")
# An undeclared kink inside an accepted step shows as a mismatch of the trapezoid rule for the
# driver's f' = integral of f''. A smooth driver on an accepted step (h omega <= ~0.2) misses it
# by h^2 omega^2 / 12 <= ~0.004 of the scale below; a kink by about half of it or more.
KINK_TOL = 0.1


def driver_breakpoints(cm: CompiledModel, start: float, end: float) -> list[Kink]:
    """The breakpoints of every driver function in [start, end], sorted, those of different
    drivers at the same time (within rounding) merged into one Kink."""
    found = []
    for r, f in zip(cm.driver_rows, cm.driver_funcs):
        for bp in f.breakpoints(start, end):
            if math.isfinite(bp.t) and start <= bp.t <= end:
                found.append((bp.t, int(r), bp))
    found.sort(key=lambda x: (x[0], x[1]))
    out: list[Kink] = []
    span = max(abs(start), abs(end), end - start, 1e-300)
    for t, r, bp in found:
        if out and t - out[-1].t <= 4 * np.finfo(float).eps * span:
            out[-1].jumps.append((r, bp))
        else:
            out.append(Kink(t, [(r, bp)]))
    return out


def hermite5(s, h, y0, d0, a0, y1, d1, a1, deriv=0):
    """Quintic Hermite interpolant on [0, 1] (s: (N, 1)) matching value, first and second
    derivative at both ends; deriv = 0, 1, 2 returns the value or a time derivative."""
    s2 = s * s
    s3 = s2 * s
    if deriv == 0:
        s4, s5 = s3 * s, s3 * s2
        H0 = 1 - 10 * s3 + 15 * s4 - 6 * s5
        H1 = s - 6 * s3 + 8 * s4 - 3 * s5
        H2 = 0.5 * s2 - 1.5 * s3 + 1.5 * s4 - 0.5 * s5
        H3 = 10 * s3 - 15 * s4 + 6 * s5
        H4 = -4 * s3 + 7 * s4 - 3 * s5
        H5 = 0.5 * s3 - s4 + 0.5 * s5
        return H0 * y0 + H1 * h * d0 + H2 * h * h * a0 + H3 * y1 + H4 * h * d1 + H5 * h * h * a1
    s4 = s3 * s
    if deriv == 1:
        H0 = -30 * s2 + 60 * s3 - 30 * s4
        H1 = 1 - 18 * s2 + 32 * s3 - 15 * s4
        H2 = s - 4.5 * s2 + 6 * s3 - 2.5 * s4
        H4 = -12 * s2 + 28 * s3 - 15 * s4
        H5 = 1.5 * s2 - 4 * s3 + 2.5 * s4
        return (H0 * (y0 - y1)) / h + H1 * d0 + H2 * h * a0 + H4 * d1 + H5 * h * a1
    if deriv == 3:          # only rows the solver cannot solve (inside a bifurcation crossing)
        H0 = -60 + 360 * s - 360 * s2
        H1 = -36 + 192 * s - 180 * s2
        H2 = -9 + 36 * s - 30 * s2
        H4 = -24 + 168 * s - 180 * s2
        H5 = 3 - 24 * s + 30 * s2
        return (H0 * (y0 - y1)) / h ** 3 + (H1 * d0 + H4 * d1) / (h * h) + (H2 * a0 + H5 * a1) / h
    H0 = -60 * s + 180 * s2 - 120 * s3
    H1 = -36 * s + 96 * s2 - 60 * s3
    H2 = 1 - 9 * s + 18 * s2 - 10 * s3
    H4 = -24 * s + 84 * s2 - 60 * s3
    H5 = 3 * s - 12 * s2 + 10 * s3
    return (H0 * (y0 - y1)) / (h * h) + (H1 * d0 + H4 * d1) / h + H2 * a0 + H5 * a1
