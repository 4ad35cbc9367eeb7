"""The clearance room's findings: a pair of shapes closer than its limit (or overlapping), a
joint past its travel range, at the first instant, with the bodies and the points.

`RowCheck` sees every chunk before it is written (planarkin.derived.row_checks): a finding is a
warning (planarkin.solver.path.Event of kind 'contact' or 'limit', one per pair or joint) or,
with `clearance: {on_contact: error}`, a refusal: the run stops at the row of the first
finding with exit status 1, the rows before it written (as a cam past its law's range).
`overlaps(cm, q)` is what `planarkin check` says of the assembled pose.
"""

from __future__ import annotations

import numpy as np

from .cycle import Clearance, Rows, first_below


def _fmt(p) -> str:
    """(x, y) to 6 digits, a component below rounding of the other written 0."""
    big = max(abs(float(p[0])), abs(float(p[1])))
    x, y = (0.0 if abs(float(c)) <= 1e-12 * big else float(c) + 0.0 for c in p)
    return f"({x:.6g}, {y:.6g})"


def _body_name(cm, b: int) -> str:
    return "ground" if b == cm.nb else cm.body_names[b]


def _who(cm, shape) -> str:
    body = _body_name(cm, shape.body)
    return f"'{shape.name}'" if shape.name == body else f"'{shape.name}' (on {body})"


class RowCheck:
    """check(an, chunk) -> (row, message, kind) of the first finding when findings are errors,
    else None with the findings added to the run's warnings."""

    def __init__(self, cm, opts, C=None):
        self.cm = cm
        self.C = C if C is not None else Clearance(cm)
        self.order = opts.order
        self.error = self.C.on_contact == "error"
        self.carry = None                 # the previous chunk's last row (Rows) and values
        self.done: set = set()            # pairs and joints already reported

    def __call__(self, an, ch):
        C, cm = self.C, self.cm
        T = np.asarray(ch.t, dtype=float)
        found = []                        # (t, kind, message, bodies)
        seps = C.separations(ch) if C.pairs else []
        travel = C.travel(ch)
        prev = self.carry
        joined: list = []       # the chunk's rows after the carried one, joined when first asked

        def distance_at(tt, p):
            if not joined:
                joined.append(self._rows(ch, prev, -np.inf))
            return C.closest(joined[0], p, tt)[0]

        for k, (p, s) in enumerate(zip(C.pairs, seps)):
            if ("pair", k) in self.done:
                continue
            t, y, y1, y2 = self._with_carry(prev, ("pair", k), T, s.d, s.d1, s.d2)
            tf = first_below(t, y, y1, y2, p.limit, lambda tt, p=p: distance_at(tt, p))
            if tf is not None:
                self.done.add(("pair", k))
                found.append((tf, "contact", self._contact(ch, prev, p, tf),
                              [_body_name(cm, cm.shapes[i].body) for i in (p.a, p.b)]))
        for k, (lim, val) in enumerate(zip(C.limits, travel)):
            if ("limit", k) in self.done:
                continue
            t, y, y1, y2 = self._with_carry(prev, ("limit", k), T, *val)
            neg = (lambda x: None if x is None else -x)
            lo = first_below(t, y, y1, y2, lim.lo)
            hi = first_below(t, -y, neg(y1), neg(y2), -lim.hi)
            hits = [x for x in (lo, hi) if x is not None]
            if hits:
                self.done.add(("limit", k))
                tf = min(hits)
                bodies = next(list(el.bodies) for el in cm.spec.joints if el.name == lim.joint)
                found.append((tf, "limit", self._limit(lim, tf, tf == lo), bodies))
        self._keep(ch, seps, travel)
        if not found:
            return None
        found.sort(key=lambda f: f[0])
        if self.error:
            tf, kind, msg, _ = found[0]
            i = int(np.searchsorted(T, tf, side="left"))
            return (min(i, len(T) - 1), msg + "; rows are written up to the one before "
                    "(clearance: on_contact: error)", kind)
        from ..solver.path import Event
        for tf, kind, msg, bodies in found:
            an.follower.warnings.append(Event(kind, tf, msg, bodies=bodies))
        return None

    def _with_carry(self, prev, key, T, y, y1, y2):
        """The columns with the previous chunk's last row in front (an interval across the
        chunks' seam is an interval like any other)."""
        if prev is None or key not in prev[1]:
            return T, y, y1, y2
        p = prev[1][key]
        join = (lambda a, b: None if a is None or b is None else np.r_[a, b])
        return np.r_[prev[0].t, T], np.r_[p[0], y], join(p[1], y1), join(p[2], y2)

    def _keep(self, ch, seps, travel):
        if not len(ch.t):
            return
        last = slice(len(ch.t) - 1, len(ch.t))
        vals = {}
        for k, s in enumerate(seps):
            vals[("pair", k)] = tuple(None if x is None else x[last] for x in (s.d, s.d1, s.d2))
        for k, v in enumerate(travel):
            vals[("limit", k)] = tuple(None if x is None else x[last] for x in v)
        rows = Rows(np.asarray(ch.t)[last], ch.q[last],
                     None if ch.qd is None else ch.qd[last],
                     None if ch.qdd is None else ch.qdd[last])
        self.carry = (rows, vals)

    @staticmethod
    def _rows(ch, prev, tf):
        """The chunk's rows, with the previous chunk's last row in front when tf lies before
        the chunk's first row (across the seam)."""
        if prev is None or tf >= ch.t[0]:
            return ch
        cat = (lambda a, b: None if a is None or b is None else np.concatenate([a, b]))
        return Rows(np.r_[prev[0].t, ch.t], cat(prev[0].q, ch.q), cat(prev[0].qd, ch.qd),
                    cat(prev[0].qdd, ch.qdd))

    def _contact(self, ch, prev, p, tf) -> str:
        cm, lu = self.cm, self.cm.spec.length_unit
        rows = self._rows(ch, prev, tf)
        d, pa, pb = self.C.closest(rows, p, tf)
        A, B = cm.shapes[p.a], cm.shapes[p.b]
        # at the instant found d is the limit, to the interpolation of the pose between rows
        crossing = abs(d - p.limit) <= 1e-7 * cm.L
        if crossing and p.limit == 0:
            what = "touch"
        elif crossing:
            what = f"come within {p.limit:g} {lu}, the least clearance allowed,"
        elif d < 0:
            what = f"overlap by {-d:.4g} {lu}"
        else:
            what = f"are {d:.4g} {lu} apart, closer than the {p.limit:g} {lu} allowed,"
        return (f"clearance: shapes {_who(cm, A)} and {_who(cm, B)} {what} at t = {tf:.10g} s"
                f"{', the start' if tf == float(rows.t[0]) and not crossing else ''}, at "
                f"{_fmt(pa)} on '{A.name}' and {_fmt(pb)} on '{B.name}'")

    def _limit(self, lim, tf, low: bool) -> str:
        spec = self.cm.spec
        u = spec.angle_unit if lim.kind == "revolute" else spec.length_unit
        what = "relative angle" if lim.kind == "revolute" else "slide"
        end = lim.lo if low else lim.hi
        return (f"limits: joint '{lim.joint}' reaches the {'lower' if low else 'upper'} end "
                f"{end:g} {u} of its travel range [{lim.lo:g}, {lim.hi:g}] {u} at t = "
                f"{tf:.10g} s (its {what}) and passes it: the stop would be hit")


def overlaps(cm, q) -> list:
    """Warnings (planarkin.diagnostics.Diagnostic, at the first shape's line) of the pairs of
    shapes that overlap or come closer than their limit at the pose q (internal units: the
    assembly's), for planarkin check; [] without pairs."""
    if not getattr(cm, "shapes", ()):
        return []
    from ..diagnostics import Diagnostic
    C = Clearance(cm)
    if not C.pairs:
        return []
    unit = np.tile([cm.L, cm.L, 1.0 / cm.angle_factor], cm.nb)
    one = Rows(np.zeros(1), (np.asarray(q, dtype=float) * unit)[None, :], None, None)
    lu = cm.spec.length_unit
    out = []
    for p, s in zip(C.pairs, C.separations(one)):
        d = float(s.d[0])
        if d >= p.limit:
            continue
        A, B = cm.shapes[p.a], cm.shapes[p.b]
        what = f"overlap by {-d:.4g} {lu}" if d < 0 else \
            f"are {d:.4g} {lu} apart, closer than the {p.limit:g} {lu} allowed"
        out.append(Diagnostic(cm.spec.file, A.source[1],
                              f"shapes {_who(cm, A)} and {_who(cm, B)} {what} at the assembled "
                              f"pose, at {_fmt(s.pa[0])} on '{A.name}' and {_fmt(s.pb[0])} on "
                              f"'{B.name}'", "warning"))
    return out
