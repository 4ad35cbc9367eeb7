"""Measures: named derived quantities with exact first and second time derivatives.

A model's ``measures:`` block maps names to one of (points are names under points:, links are
body or link names or ground, joints are joint names; a sketch's revolutes are named after pins):

    stroke:  {distance: [C, D]}            |C D|, length unit (an actuator's length and speed)
    rocker:  {angle: rocker}               the angle of a link (its body angle phi)
    line:    {angle: [C, D]}               the angle of the line C -> D, in (-180, 180] deg
    knee:    {between: [thigh, shin]}      phi_shin - phi_thigh, the angle between two links
    hinge:   {joint: C}                    a revolute's relative angle phi_j - phi_i, or a
                                           translational joint's displacement u_i . (P_j - P_i)
    mu:      {transmission: [B, C, D]}     the angle at C between C -> B and C -> D, in [0, 180]
                                           (a four-bar's transmission angle: coupler B-C, rocker D-C)
    psi:     {transmission: [B, C], guide: piston}
                                           the acute angle between the rod C -> B and the axis of
                                           translational joint 'piston' (a slider-crank), [0, 90]
    vr:      {ratio: [crank, rocker]}      velocity ratio rocker' / crank' of two other measures
    ma:      {advantage: [crank, rocker]}  ideal mechanical advantage crank' / rocker'

Every value comes with .rate and .accel (d/dt, d2/dt2) from the exact q, q', q'' by the chain
rule -- no finite differences; a ratio or an advantage has only .rate (its second derivative
would need the jerk). Written to measures.csv (``t [s]``, then ``<name> [unit]``,
``<name>.rate [unit/s]``, ``<name>.accel [unit/s^2]``), plotted in measures.png, and summarised
(limit positions, stroke, time ratio) in summary.json under ``cycle``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..derived import DerivedTable

KINDS = ("distance", "angle", "between", "joint", "transmission", "ratio", "advantage")


@dataclass(frozen=True)
class MeasureSpec:
    """One validated measure: kind (one of KINDS), refs (names it refers to), guide (a
    translational joint's name, for the rod-guide angle), line in the file."""

    name: str
    kind: str
    refs: tuple
    line: int
    guide: str | None = None


# -- validation (called by planarkin.model.validate with its readers) ----------------------------

def read_measures(v, node, points: list[str], joints: dict) -> tuple[MeasureSpec, ...]:
    """Validate the measures: block. points: point names; joints: joint name -> ElementSpec."""
    if node is None:
        return ()
    if node.kind != "map":
        v.err(node, f"measures must be a mapping of names to e.g. {{distance: [C, D]}}, not "
                    f"a {node.kind}")
        return ()
    from ..diagnostics import did_you_mean
    out: list[MeasureSpec] = []
    links = v.body_names + ["ground"]
    seen: list[str] = []
    for key, val in node.value.items():
        line = node.key_lines[key]
        if not v.identifier(key, line, "measure"):
            continue
        what = f"measure '{key}'"
        if val.kind != "map":
            v.err(val, f"{what} must be a mapping like {{distance: [C, D]}} ({', '.join(KINDS)})")
            continue
        kinds = [k for k in val.value if k in KINDS]
        extra = [k for k in val.value if k not in KINDS and k != "guide"]
        for k in extra:
            v.err(val.key_lines[k], f"{what}: unknown key '{k}'"
                                    f"{did_you_mean(k, KINDS) or ' (kinds: ' + ', '.join(KINDS) + ')'}")
        if len(kinds) != 1:
            if not extra:
                v.err(val, f"{what}: give exactly one of {', '.join(KINDS)}")
            continue
        kind = kinds[0]
        ref = val.value[kind]
        names = [ref.value] if ref.kind == "scalar" else \
            [n.value if n.kind == "scalar" else None for n in ref.value] if ref.kind == "seq" \
            else [None]
        names = [str(n) if n is not None else None for n in names]
        lines = [ref.line] if ref.kind == "scalar" else [n.line for n in ref.value] \
            if ref.kind == "seq" else [ref.line]

        def check(pool, label, ok=True):
            for n, ln in zip(names, lines):
                if n not in pool:
                    shown = ", ".join(list(pool)[:10]) or "none defined"
                    v.err(ln, f"{what}: unknown {label} '{n}'"
                              f"{did_you_mean(str(n), pool) or ' (' + label + 's: ' + shown + ')'}")
                    ok = False
            return ok

        want = {"distance": (2, "points"), "between": (2, "links"), "ratio": (2, "measures"),
                "advantage": (2, "measures")}
        guide = None
        if kind == "angle":
            if ref.kind == "scalar":
                ok = check(links, "link")
            elif len(names) == 2:
                ok = check(points, "point")
            else:
                v.err(ref, f"{what}: angle takes a link name or two points [C, D]")
                continue
        elif kind == "joint":
            if ref.kind != "scalar":
                v.err(ref, f"{what}: joint takes a joint's name")
                continue
            ok = check(joints, "joint")
            if ok and joints[names[0]].kind not in ("revolute", "translational"):
                v.err(ref, f"{what}: joint '{names[0]}' is a {joints[names[0]].kind} joint; the "
                           f"relative motion is measured for revolute and translational joints")
                ok = False
        elif kind == "transmission":
            if "guide" in val.value:
                if len(names) != 2:
                    v.err(ref, f"{what}: with guide, transmission takes the rod's two points "
                               f"[B, C]")
                    continue
                g = val.value["guide"]
                guide = g.value if g.kind == "scalar" else None
                if guide not in joints or joints[guide].kind != "translational":
                    tr = [n for n, el in joints.items() if el.kind == "translational"]
                    v.err(g, f"{what}: guide must name a translational joint"
                             f"{did_you_mean(str(guide), tr) or ' (translational joints: ' + (', '.join(tr) or 'none named') + ')'}")
                    continue
            elif len(names) != 3:
                v.err(ref, f"{what}: transmission takes three points [B, C, D] (the angle at C), "
                           f"or two points [B, C] with guide: JOINT")
                continue
            ok = check(points, "point")
        else:
            n, pool = want[kind]
            if len(names) != n:
                v.err(ref, f"{what}: {kind} takes two names [A, B]")
                continue
            ok = check({"points": points, "links": links, "measures": seen}[pool], pool[:-1])
            if ok and kind in ("ratio", "advantage"):
                for n_ in names:
                    ref_m = next((m for m in out if m.name == n_), None)
                    if ref_m is None:           # itself invalid, already reported
                        ok = False
                    elif ref_m.kind in ("ratio", "advantage"):
                        v.err(ref, f"{what}: '{n_}' is itself a {kind}; refer to plain measures")
                        ok = False
        if "guide" in val.value and kind != "transmission":
            v.err(val.value["guide"], f"{what}: guide is used with transmission only")
            ok = False
        if ok and kind in ("distance", "transmission") and len(set(names)) < len(names):
            v.err(ref, f"{what}: the points must differ")
            ok = False
        if ok:
            out.append(MeasureSpec(key, kind, tuple(names), line, guide))
        seen.append(key)
    return tuple(out)


# -- exact kinematics --------------------------------------------------------------------------

def _body(ch, cm, b, s=(0.0, 0.0)):
    """Position, velocity, acceleration (N, 2) of body-fixed point s (internal length units / L
    scaled back to user units) of body b (index; nb = ground); phi, omega, alpha in radians."""
    N = len(ch.t)
    if b == cm.nb:
        z = np.zeros((N, 2))
        p = z + np.asarray(s) * cm.L
        return p, z, z.copy(), np.zeros(N), np.zeros(N), np.zeros(N)
    af = cm.angle_factor
    phi = ch.q[:, 3 * b + 2] * af
    w = ch.qd[:, 3 * b + 2] * af
    al = ch.qdd[:, 3 * b + 2] * af
    sx, sy = s[0] * cm.L, s[1] * cm.L
    c, sn = np.cos(phi), np.sin(phi)
    gx, gy = c * sx - sn * sy, sn * sx + c * sy
    p = np.stack([ch.q[:, 3 * b] + gx, ch.q[:, 3 * b + 1] + gy], axis=1)
    v = np.stack([ch.qd[:, 3 * b] - w * gy, ch.qd[:, 3 * b + 1] + w * gx], axis=1)
    a = np.stack([ch.qdd[:, 3 * b] - al * gy - w * w * gx,
                  ch.qdd[:, 3 * b + 1] + al * gx - w * w * gy], axis=1)
    return p, v, a, phi, w, al


def _point(ch, cm, name):
    k = cm.point_names.index(name)
    return _body(ch, cm, int(cm.point_body[k]), cm.point_s[k])[:3]


def _cross(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]


def _atan2(c, c1, c2, d, d1, d2):
    """theta = atan2(c, d) and its exact first and second derivatives from those of c and d."""
    r2 = c * c + d * d
    num = d * c1 - c * d1                       # d/dt of atan2: (d c' - c d') / r2
    th1 = num / r2
    num1 = d * c2 - c * d2                      # (d c' - c d')' = d c'' - c d''
    r21 = 2 * (c * c1 + d * d1)
    th2 = num1 / r2 - num * r21 / (r2 * r2)
    return np.arctan2(c, d), th1, th2


def _vector_angle(u, u1, u2):
    """Angle of the vector u(t) (N, 2) with derivatives."""
    return _atan2(u[:, 1], u1[:, 1], u2[:, 1], u[:, 0], u1[:, 0], u2[:, 0])


def _angle_between(u, u1, u2, w, w1, w2, acute=False):
    """Unsigned angle between vectors u and w in [0, pi] (acute: between lines, [0, pi/2])."""
    c = _cross(u, w)
    c1 = _cross(u1, w) + _cross(u, w1)
    c2 = _cross(u2, w) + 2 * _cross(u1, w1) + _cross(u, w2)
    d = _dot(u, w)
    d1 = _dot(u1, w) + _dot(u, w1)
    d2 = _dot(u2, w) + 2 * _dot(u1, w1) + _dot(u, w2)
    sc = np.where(c < 0, -1.0, 1.0)
    sd = np.where(d < 0, -1.0, 1.0) if acute else 1.0
    return _atan2(sc * c, sc * c1, sc * c2, sd * d, sd * d1, sd * d2)


def _distance(P, Q):
    r, r1, r2 = (Q[k] - P[k] for k in range(3))
    d = np.hypot(r[:, 0], r[:, 1])
    d1 = _dot(r, r1) / d
    d2 = (_dot(r1, r1) + _dot(r, r2) - d1 * d1) / d
    return d, d1, d2


def _slide(ch, cm, el_index):
    """u_i . (P_j - P_i) of a translational joint, with derivatives (user length unit)."""
    g, k = _group_of(cm, el_index)
    bi, bj = (int(x) for x in g.bodies[k, :2])
    Pi = _body(ch, cm, bi, g.params["si"][k])
    Pj = _body(ch, cm, bj, g.params["sj"][k])
    vi = g.params["vi"][k]
    phi, w, al = Pi[3], Pi[4], Pi[5]
    c, s = np.cos(phi), np.sin(phi)
    u = np.stack([c * vi[0] - s * vi[1], s * vi[0] + c * vi[1]], axis=1)
    Ru = np.stack([-u[:, 1], u[:, 0]], axis=1)
    u1 = w[:, None] * Ru
    u2 = al[:, None] * Ru - (w * w)[:, None] * u
    h, h1, h2 = (Pj[m] - Pi[m] for m in range(3))
    return _dot(u, h), _dot(u1, h) + _dot(u, h1), _dot(u2, h) + 2 * _dot(u1, h1) + _dot(u, h2)


def _guide_axis(ch, cm, el_index):
    g, k = _group_of(cm, el_index)
    bi = int(g.bodies[k, 0])
    vi = g.params["vi"][k]
    _, _, _, phi, w, al = _body(ch, cm, bi)
    c, s = np.cos(phi), np.sin(phi)
    u = np.stack([c * vi[0] - s * vi[1], s * vi[0] + c * vi[1]], axis=1)
    Ru = np.stack([-u[:, 1], u[:, 0]], axis=1)
    return u, w[:, None] * Ru, al[:, None] * Ru - (w * w)[:, None] * u


def _group_of(cm, el_index):
    """(group, instance index) holding spec element el_index."""
    el = cm.spec.elements[el_index]
    row = int(np.nonzero(cm.row_element == el_index)[0][0])
    for g in cm.groups:
        if g.kind.name == el.kind:
            hit = np.nonzero(g.rows[:, 0] == row)[0]
            if hit.size:
                return g, int(hit[0])
    raise KeyError(el.label)


def _body_index(cm, name):
    return cm.nb if name == "ground" else cm.body_names.index(name)


def evaluate(cm, ch, m: MeasureSpec, done: dict):
    """(value, rate, accel) arrays (N,) of measure m in user units; accel None for ratios."""
    af = cm.angle_factor
    deg = 1.0 / af                          # radians -> user angle unit
    if m.kind == "distance":
        return _distance(_point(ch, cm, m.refs[0]), _point(ch, cm, m.refs[1]))
    if m.kind == "angle" and len(m.refs) == 1:
        b = _body_index(cm, m.refs[0])
        if b == cm.nb:
            z = np.zeros(len(ch.t))
            return z, z, z
        return ch.q[:, 3 * b + 2], ch.qd[:, 3 * b + 2], ch.qdd[:, 3 * b + 2]
    if m.kind == "angle":
        P, Q = _point(ch, cm, m.refs[0]), _point(ch, cm, m.refs[1])
        th = _vector_angle(*(Q[k] - P[k] for k in range(3)))
        return tuple(x * deg for x in th)
    if m.kind == "between":
        a, b = (_body_index(cm, r) for r in m.refs)
        col = lambda X, k: np.zeros(len(ch.t)) if k == cm.nb else X[:, 3 * k + 2]
        return tuple(col(X, b) - col(X, a) for X in (ch.q, ch.qd, ch.qdd))
    if m.kind == "joint":
        idx = next(k for k, el in enumerate(cm.spec.elements)
                   if el.role == "joint" and el.name == m.refs[0])
        el = cm.spec.elements[idx]
        if el.kind == "revolute":
            i, j = (_body_index(cm, b) for b in el.bodies)
            col = lambda X, k: np.zeros(len(ch.t)) if k == cm.nb else X[:, 3 * k + 2]
            return tuple(col(X, j) - col(X, i) for X in (ch.q, ch.qd, ch.qdd))
        return _slide(ch, cm, idx)
    if m.kind == "transmission":
        B, C = _point(ch, cm, m.refs[0]), _point(ch, cm, m.refs[1])
        u = tuple(B[k] - C[k] for k in range(3))
        if m.guide is not None:
            idx = next(k for k, el in enumerate(cm.spec.elements)
                       if el.role == "joint" and el.name == m.guide)
            g = _guide_axis(ch, cm, idx)
            return tuple(x * deg for x in _angle_between(*u, *g, acute=True))
        D = _point(ch, cm, m.refs[2])
        w = tuple(D[k] - C[k] for k in range(3))
        return tuple(x * deg for x in _angle_between(*u, *w))
    a, b = done[m.refs[0]], done[m.refs[1]]
    if m.kind == "advantage":
        a, b = b, a
    with np.errstate(divide="ignore", invalid="ignore"):
        r = b[1] / a[1]
        r1 = (b[2] * a[1] - b[1] * a[2]) / (a[1] * a[1])
    return r, r1, None


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


def _orders(m: MeasureSpec, order: int) -> tuple[int, ...]:
    """The derivative orders of m that can be written with q up to `order` (a ratio of rates
    needs q' for its value and q'' for its rate, and has no acceleration). Measures stop at the
    acceleration: up_to: jerk adds jerk columns to bodies and points only."""
    order = min(order, 2)
    if m.kind in ("ratio", "advantage"):
        return tuple(k for k in (0, 1) if k + 1 <= order)
    return tuple(range(order + 1))


def columns(cm, measures, order: int = 2) -> list[tuple[str, str, int, int]]:
    """(header name, unit, derivative order, measure index) of every column after t."""
    units: dict[str, str] = {}
    out = []
    for k, m in enumerate(measures):
        u = units[m.name] = unit_of(cm, m, units)
        suffix = ("", ".rate", ".accel")
        per = ("", "/s", "/s^2")
        for d in _orders(m, order):
            unit = (u + per[d]) if u != "-" or d == 0 else ("1" + per[d])
            out.append((m.name + suffix[d], unit, d, k))
    return out


def compute(cm, measures, ch, order: int = 2) -> np.ndarray:
    """(N, 1 + columns) table: t, then the columns of `columns(cm, measures, order)`."""
    if order < 2:
        # the formulas take q', q''; the columns that would need the missing ones are dropped
        from dataclasses import replace
        z = np.zeros_like(ch.q)
        ch = replace(ch, qd=ch.qd if ch.qd is not None else z, qdd=z)
    done: dict = {}
    vals = []
    for m in measures:
        val = done[m.name] = evaluate(cm, ch, m, done)
        vals.append(val)
    cols = [ch.t] + [vals[k][d] for _, _, d, k in columns(cm, measures, order)]
    return np.column_stack(cols)


def derived_tables(cm, opts) -> list[DerivedTable]:
    measures = getattr(cm.spec, "measures", ())
    if not measures:
        return []
    order = opts.order
    cols = columns(cm, measures, order)
    header = ["t [s]"] + [f"{n} [{u}]" for n, u, _, _ in cols]
    from .cycle import CycleFigures
    return [DerivedTable(
        filename="measures.csv", header=header,
        compute=lambda ch: compute(cm, measures, ch, order),
        section="cycle",
        accumulator=lambda: CycleFigures(cm, header, opts),
        plot=_plot)]


def _plot(cm, X, info, out, fmt):
    from .plot import plot_measures
    return plot_measures(cm, X, out, fmt)
