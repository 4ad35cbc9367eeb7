"""Clearance: link shapes, interference, clearance and travel limits over the cycle (issue 29).

The room of `planarkin.derived` that writes ``clearance.csv`` (the distance of every pair of
shapes that can touch, and the travel of every limited joint, at every grid row, with exact
rates and accelerations), the ``clearance`` section of summary.json (each pair's minimum refined
between the rows, with its time; the first instant of each contact) and the findings (a pair
closer than its limit, a joint past its range: warnings, or with ``on_contact: error`` the run
stops there with exit 1), when the model has a ``shapes:`` or ``limits:`` section; models
without them pay nothing (this module imports nothing until asked).

Modules: `shape` (the Shape every stage shares: CompiledModel.shapes), `keys` (validating the
YAML keys), `build` (compiling them to Shapes, the pairs that can touch), `geometry` (exact
distances between rounded point sets and their derivatives), `cycle` (the table, the refined
minima: `planarkin.clearance.cycle.minima(cm, result)`, and `least_margin`, the synthesis'
constraint), `check` (the findings; overlaps at the assembled pose for `planarkin check`),
`summary` (summary.json's section), `plot` (clearance.<fmt>, drawn by the figures' module).
Studies: the metric `min_clearance` (or `min_clearance:A|B`) is `min:clearance`
(planarkin.studies.variants).
"""

from __future__ import annotations


_LAST: list = []        # [(cm, Clearance)] of the last models asked: the table and the row
#                         check share one, and with it the distances of the chunk they both see


def _room(cm):
    if not getattr(cm, "shapes", ()) and getattr(cm.spec, "clearance", None) is None:
        return None
    for m, C in _LAST:
        if m is cm:
            return C if C else None
    from .cycle import Clearance
    C = Clearance(cm)
    _LAST[:] = ([(cm, C)] + _LAST)[:4]
    return C if C else None


def derived_tables(cm, opts) -> list:
    """[clearance.csv's DerivedTable] when the model has pairs of shapes that can touch or
    limited joints, else [] (no cost)."""
    C = _room(cm)
    if C is None:
        return []
    from ..derived import DerivedTable
    from .summary import ClearanceFigures
    order = opts.order
    header = C.columns(order)

    def plot(cm_, X, info, out, fmt):
        # clearance.<fmt>: planarkin.output.plots.clearance.draw(t, {(a, b): distance}, minima,
        # limit, out, fmt, unit, name), the figures' function (planarkin.clearance.plot)
        from .plot import plot_clearance
        return plot_clearance(C, X, out, fmt)
    return [DerivedTable(filename="clearance.csv", header=header,
                         compute=lambda ch: C.table(ch, order), section="clearance",
                         accumulator=lambda: ClearanceFigures(C, header), plot=plot)]


def row_checks(cm, opts) -> list:
    """[the findings' check of every chunk] (planarkin.clearance.check) when the model has
    pairs or limited joints, else []."""
    if _room(cm) is None:
        return []
    from .check import RowCheck
    return [RowCheck(cm, opts, _room(cm))]
