"""Motion laws (the VDI 2143 family) as functions of a normalised argument u, exact to any order.

Each law s(u) rises from s(0) = 0 to s(1) = 1, holds 0 for u < 0 and 1 for u > 1 (so that laws
over consecutive intervals add up to a chained profile, see planarkin.functions.motion), and has exact
derivatives s', s'', s''' (and higher) as closed forms on each piece. In expressions they are
called by name: ``cycloidal((t - 0.2)/0.3)``. For a rise h in time T, x = h*s(u) with
u = (t - t0)/T, so velocity h*s'/T, acceleration h*s''/T**2, jerk h*s'''/T**3.

The modified trapezoid and modified sine are defined by their acceleration (reference:
../shared/reference/forces-and-motion-laws.md §2) and integrated here piece by piece, exactly in
the coefficients, with s(0) = s'(0) = 0.
"""

from __future__ import annotations

import math

from .piecewise import Piece, Piecewise

__all__ = ["LAWS", "ALIASES", "law"]

PI = math.pi


def _from_acceleration(name: str, knots, accels) -> Piecewise:
    """A law from its acceleration pieces (Piece objects, local w from each knot) on [0, 1]."""
    pieces, v, s = [], 0.0, 0.0
    for (a, b), acc in zip(zip(knots, knots[1:]), accels):
        vel = acc.integral(v)
        pos = vel.integral(s)
        pieces.append(pos)
        v, s = float(vel(b)), float(pos(b))
    return Piecewise(name, knots, [Piece([0.0])] + pieces + [Piece([1.0], origin=1.0)])


def _simple(name: str, piece: Piece) -> Piecewise:
    return Piecewise(name, [0.0, 1.0], [Piece([0.0]), piece, Piece([1.0], origin=1.0)])


def _build() -> dict:
    A = 8 * PI / (2 + PI)           # modified trapezoid: peak acceleration coefficient
    B = 4 * PI ** 2 / (4 + PI)      # modified sine
    w4 = 4 * PI
    return {
        "constant_velocity": _simple("constant_velocity", Piece([1.0, 0.0])),
        "harmonic": _simple("harmonic", Piece([0.5], [(0.0, -0.5, PI)])),
        "cycloidal": _simple("cycloidal", Piece([1.0, 0.0], [(-1 / (2 * PI), 0.0, 2 * PI)])),
        "poly345": _simple("poly345", Piece([6.0, -15.0, 10.0, 0.0, 0.0, 0.0])),
        "poly4567": _simple("poly4567", Piece([-20.0, 70.0, -84.0, 35.0, 0, 0, 0, 0])),
        "modified_trapezoid": _from_acceleration(
            "modified_trapezoid", [0, 1 / 8, 3 / 8, 5 / 8, 7 / 8, 1],
            [Piece([0.0], [(A, 0.0, w4)], 0.0), Piece([A], (), 1 / 8),
             Piece([0.0], [(0.0, A, w4)], 3 / 8), Piece([-A], (), 5 / 8),
             Piece([0.0], [(0.0, -A, w4)], 7 / 8)]),
        "modified_sine": _from_acceleration(
            "modified_sine", [0, 1 / 8, 7 / 8, 1],
            [Piece([0.0], [(B, 0.0, w4)], 0.0), Piece([0.0], [(0.0, B, w4 / 3)], 1 / 8),
             Piece([0.0], [(0.0, -B, w4)], 7 / 8)]),
    }


LAWS = _build()
# the spellings a motion: segment accepts (a law's own name works too)
ALIASES = {"3-4-5": "poly345", "4-5-6-7": "poly4567", "constant-velocity": "constant_velocity",
           "modified-trapezoid": "modified_trapezoid", "modified-sine": "modified_sine",
           "simple-harmonic": "harmonic", "linear": "constant_velocity"}


def law(name: str) -> Piecewise | None:
    """The law called name (its own name or an alias), None if there is none."""
    return LAWS.get(ALIASES.get(name, name))
