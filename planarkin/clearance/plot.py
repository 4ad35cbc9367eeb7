"""clearance.<fmt>: each pair's distance against time with the limit and each minimum, drawn by
the figures' planarkin.output.plots.clearance.draw (imported when drawn: matplotlib only when
plotting)."""

from __future__ import annotations

from types import SimpleNamespace


from .cycle import refined_minimum


def plot_clearance(C, X, out, fmt: str = "png") -> list:
    """Write clearance.<fmt> from the plot rows X of clearance.csv (C: the room's Clearance);
    returns [path], or [] without pairs."""
    if not C.pairs or not len(X):
        return []
    from ..output.plots.clearance import draw
    cm = C.cm
    header = C.columns(2)[:X.shape[1]]
    at = {h.split(" [", 1)[0]: k for k, h in enumerate(header)}
    t = X[:, 0]
    distances, lows = {}, []
    for p in C.pairs:
        a, b = cm.shapes[p.a].name, cm.shapes[p.b].name
        d = X[:, at[p.name]]
        distances[(a, b)] = d
        r, acc = at.get(p.name + ".rate"), at.get(p.name + ".accel")
        tm, dm = refined_minimum(t, d, None if r is None else X[:, r],
                                 None if acc is None else X[:, acc])
        lows.append(SimpleNamespace(a=a, b=b, t=tm, d=dm))
    spec = cm.spec.clearance
    limit = spec.min if spec is not None and spec.min > 0 else None
    path = draw(t, distances, lows, limit, out, fmt, cm.spec.length_unit, cm.spec.name)
    return [path]
