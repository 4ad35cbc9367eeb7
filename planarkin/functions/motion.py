"""Chained motion profiles (a driver's ``motion:``): rise, dwell, return, move, as data.

A profile is a list of segments, each over its own time interval, one after the other from t0:
``{rise: h, in: T, law: cycloidal}`` (up by h in T), ``{return: h, in: T, law: ...}`` (down by
h), ``{move: h, in: T, law: ...}`` (by a signed h) and ``{dwell: T}`` (hold). With laws that
hold 0 before and 1 after their interval (planarkin.functions.laws), the profile is one expression:

    f(t) = initial + sum_k h_k * law_k((tau - a_k)/T_k),   tau = t - t0

(a_k the start of segment k within the cycle). Before t0 f = initial; after the last segment it
holds the final value. With repeat, tau = mod(t - t0, P) over the cycle P = sum T_k and, when the
cycle does not return to its start (an indexing motion), net*floor((t - t0)/P) is added, so the
position stays continuous across every cycle. Position is continuous at every joint by
construction; a velocity or acceleration jump between laws (e.g. constant_velocity, or harmonic
into a dwell) is a breakpoint of the TimeFunction (see TimeFunction.breakpoints).
"""

from __future__ import annotations

from dataclasses import dataclass

from .expr import Expr, ExprError, TimeFunction
from .expr.core import BuildError, bin_node, call_node, num_node, pw_node, sugar_node
from .laws import law

__all__ = ["Segment", "profile", "short_segment"]

# the shortest segment, as a part of its motion's cycle: the path follower resolves times to
# 1e-11 of a run, and a 150 deg rise in 1e-9 of a 2.4 s run already stops it at t = 0
MIN_PART = 1e-7


@dataclass(frozen=True)
class Segment:
    """kind: 'rise', 'return', 'move' or 'dwell'; amount: the displacement in the driver's user
    units (signed: a return's is -h); duration: s (> 0); law: a law name (None for a dwell)."""

    kind: str
    amount: float
    duration: float
    law: str | None = None

    def describe(self) -> str:
        if self.kind == "dwell":
            return f"dwell {self.duration:g}"
        h = -self.amount if self.kind == "return" else self.amount
        return f"{self.kind} {h:g} in {self.duration:g} {self.law}"


def profile(segments, initial: float = 0.0, t0: float = 0.0, repeat: bool = False) -> TimeFunction:
    """The TimeFunction of a chain of `Segment` (validated: durations > 0, laws known)."""
    t = Expr("name", (), "t")
    tau = bin_node("-", t, num_node(t0))
    period = sum(s.duration for s in segments)
    local = sugar_node("mod", (tau, num_node(period))) if repeat else tau
    terms = [num_node(initial)]
    start = 0.0
    for s in segments:
        if s.kind != "dwell" and s.amount != 0:
            u = bin_node("/", bin_node("-", local, num_node(start)), num_node(s.duration))
            terms.append(bin_node("*", num_node(s.amount), pw_node(law(s.law), u)))
        start += s.duration
    net = sum(s.amount for s in segments)
    if repeat and net != 0:  # an indexing motion: each cycle starts where the last one ended
        cycles = call_node("floor", (bin_node("/", tau, num_node(period)),))
        terms.append(bin_node("*", num_node(net), cycles))
    text = "motion: " + ", ".join(s.describe() for s in segments) + (", repeat" if repeat else "")
    try:
        return TimeFunction.from_expr(_sum(terms), text)
    except BuildError as exc:
        raise ExprError(exc.args[0].replace("{}", "'" + text[:77] + "'")) from None


def short_segment(segments, unit: str = "s") -> tuple[int, str] | None:
    """(index, why) of the first segment too short to follow (shorter than MIN_PART of the
    whole cycle: a 90 deg rise in 1e-12 s), else None."""
    cycle = sum(s.duration for s in segments)
    for k, s in enumerate(segments):
        if s.duration < MIN_PART * cycle:
            return k, (f"{s.describe()} is too short to follow: a segment lasts at least "
                       f"{MIN_PART:g} of its motion's cycle ({cycle:g} {unit}), here "
                       f"{MIN_PART * cycle:.3g} {unit}")
    return None


def _sum(terms: list) -> Expr:
    """terms added as a balanced tree (its depth grows as log2 of the segments)."""
    if len(terms) == 1:
        return terms[0]
    h = len(terms) // 2
    return bin_node("+", _sum(terms[:h]), _sum(terms[h:]))
