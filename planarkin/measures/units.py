"""The measures' spec and the columns of measures.csv with their units: what the table and its
plot share (the plot module reads them here, so that it does not import the package that
imports it)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class MeasureSpec:
    """One validated measure: kind (one of KINDS), refs (names it refers to), guide (a
    translational joint's name, for the rod-guide angle), line in the file."""

    name: str
    kind: str
    refs: tuple
    line: int
    guide: str | None = None


def unit_of(cm, m: MeasureSpec, units: dict) -> str:
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    if m.kind == "distance":
        return lu
    if m.kind == "joint":
        el = next(el for el in cm.spec.joints if el.name == m.refs[0])
        return au if el.kind == "revolute" else lu
    if m.kind in ("ratio", "advantage"):
        a, b = units[m.refs[0]], units[m.refs[1]]
        if m.kind == "advantage":
            a, b = b, a
        return "-" if a == b else f"{b}/{a}"
    return au


def orders(m: MeasureSpec, order: int) -> tuple[int, ...]:
    """The derivative orders of m that can be written with q up to `order` (3: the jerk; a
    ratio of rates needs q' for its value, q'' for its rate and the jerk for its acceleration,
    and has no jerk column)."""
    order = min(order, 3)
    if m.kind in ("ratio", "advantage"):
        return tuple(k for k in (0, 1, 2) if k + 1 <= order)
    return tuple(range(order + 1))


def columns(cm, measures, order: int = 2) -> list[tuple[str, str, int, int]]:
    """(header name, unit, derivative order, measure index) of every column after t."""
    units: dict[str, str] = {}
    out = []
    for k, m in enumerate(measures):
        u = units[m.name] = unit_of(cm, m, units)
        suffix = ("", ".rate", ".accel", ".jerk")
        per = ("", "/s", "/s^2", "/s^3")
        for d in orders(m, order):
            unit = (u + per[d]) if u != "-" or d == 0 else ("1" + per[d])
            out.append((m.name + suffix[d], unit, d, k))
    return out
