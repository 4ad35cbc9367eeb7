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
rule -- no finite differences -- and with up_to: jerk with .jerk (d3/dt3) from the jerks too;
a ratio or an advantage has .rate, and .accel only with the jerks (its second derivative needs
the measures' third). Written to measures.csv (``t [s]``, then ``<name> [unit]``,
``<name>.rate [unit/s]``, ``<name>.accel [unit/s^2]``, ``<name>.jerk [unit/s^3]``), plotted in
measures.png, and summarised (limit positions, stroke, time ratio) in summary.json under
``cycle``. Unasked, every run also gets the transmission angle and the velocity ratio of every
four-bar and slider-crank loop (summary.json's ``loops``, planarkin.measures.loops).
"""

from __future__ import annotations


import numpy as np

from ..derived import DerivedTable
from .units import MeasureSpec, columns

KINDS = ("distance", "angle", "between", "joint", "transmission", "ratio", "advantage")


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
    """Position, velocity, acceleration and jerk (N, 2) of body-fixed point s (internal length
    units / L scaled back to user units) of body b (index; nb = ground), then phi, omega, alpha
    and the angle's jerk in radians; the two jerks None without ch.qddd (the point's:
    r''' + phi''' R s - 3 omega alpha s - omega^3 R s, with s turned to the global frame)."""
    N = len(ch.t)
    jerk = ch.qddd is not None
    if b == cm.nb:
        z = np.zeros((N, 2))
        p = z + np.asarray(s) * cm.L
        return (p, z, z.copy(), z.copy() if jerk else None, np.zeros(N), np.zeros(N),
                np.zeros(N), np.zeros(N) if jerk else None)
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
    if not jerk:
        return p, v, a, None, phi, w, al, None
    je = ch.qddd[:, 3 * b + 2] * af
    w3, wa = w * w * w, 3.0 * w * al
    j = np.stack([ch.qddd[:, 3 * b] - je * gy - wa * gx + w3 * gy,
                  ch.qddd[:, 3 * b + 1] + je * gx - wa * gy - w3 * gx], axis=1)
    return p, v, a, j, phi, w, al, je


def _point(ch, cm, name):
    k = cm.point_names.index(name)
    return _body(ch, cm, int(cm.point_body[k]), cm.point_s[k])[:4]


def _diff(P, Q):
    """Q - P of (position, velocity, acceleration, jerk) tuples (a jerk None: None)."""
    return tuple(None if p is None or q is None else q - p for p, q in zip(P, Q))


def _cross(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _dot(a, b):
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1]


def _atan2(c, c1, c2, d, d1, d2, c3=None, d3=None):
    """theta = atan2(c, d) and its exact first, second and (given c3, d3) third derivatives
    from those of c and d (the third None without them)."""
    r2 = c * c + d * d
    num = d * c1 - c * d1                       # d/dt of atan2: (d c' - c d') / r2
    th1 = num / r2
    num1 = d * c2 - c * d2                      # (d c' - c d')' = d c'' - c d''
    r21 = 2 * (c * c1 + d * d1)
    th2 = num1 / r2 - num * r21 / (r2 * r2)
    th3 = None
    if c3 is not None and d3 is not None:
        num2 = d1 * c2 + d * c3 - c1 * d2 - c * d3              # (d c'' - c d'')'
        r22 = 2 * (c1 * c1 + c * c2 + d1 * d1 + d * d2)         # (r^2)''
        th3 = (num2 / r2 - 2 * num1 * r21 / (r2 * r2) - num * r22 / (r2 * r2)
               + 2 * num * r21 * r21 / (r2 * r2 * r2))
    return np.arctan2(c, d), th1, th2, th3


def _vector_angle(u, u1, u2, u3=None):
    """Angle of the vector u(t) (N, 2) with derivatives (the third given u3)."""
    return _atan2(u[:, 1], u1[:, 1], u2[:, 1], u[:, 0], u1[:, 0], u2[:, 0],
                  None if u3 is None else u3[:, 1], None if u3 is None else u3[:, 0])


def _angle_between(u, u1, u2, u3, w, w1, w2, w3, acute=False):
    """Unsigned angle between vectors u and w in [0, pi] (acute: between lines, [0, pi/2]);
    u3, w3 the vectors' third derivatives or None."""
    c = _cross(u, w)
    c1 = _cross(u1, w) + _cross(u, w1)
    c2 = _cross(u2, w) + 2 * _cross(u1, w1) + _cross(u, w2)
    d = _dot(u, w)
    d1 = _dot(u1, w) + _dot(u, w1)
    d2 = _dot(u2, w) + 2 * _dot(u1, w1) + _dot(u, w2)
    c3 = d3 = None
    if u3 is not None and w3 is not None:
        c3 = _cross(u3, w) + 3 * _cross(u2, w1) + 3 * _cross(u1, w2) + _cross(u, w3)
        d3 = _dot(u3, w) + 3 * _dot(u2, w1) + 3 * _dot(u1, w2) + _dot(u, w3)
    sc = np.where(c < 0, -1.0, 1.0)
    sd = np.where(d < 0, -1.0, 1.0) if acute else 1.0
    return _atan2(sc * c, sc * c1, sc * c2, sd * d, sd * d1, sd * d2,
                  None if c3 is None else sc * c3, None if d3 is None else sd * d3)


def _distance(P, Q):
    r, r1, r2, r3 = _diff(P, Q)
    d = np.hypot(r[:, 0], r[:, 1])
    d1 = _dot(r, r1) / d
    d2 = (_dot(r1, r1) + _dot(r, r2) - d1 * d1) / d
    # d d'' = r'.r' + r.r'' - d'^2 differentiated: d' d'' + d d''' = 3 r'.r'' + r.r''' - 2 d' d''
    d3 = None if r3 is None else (3 * _dot(r1, r2) + _dot(r, r3) - 3 * d1 * d2) / d
    return d, d1, d2, d3


def _slide(ch, cm, el_index):
    """u_i . (P_j - P_i) of a translational joint, with derivatives (user length unit)."""
    g, k = _group_of(cm, el_index)
    bi, bj = (int(x) for x in g.bodies[k, :2])
    Pi = _body(ch, cm, bi, g.params["si"][k])
    Pj = _body(ch, cm, bj, g.params["sj"][k])
    u, u1, u2, u3 = _axis(g.params["vi"][k], *Pi[4:])
    h, h1, h2, h3 = _diff(Pi[:4], Pj[:4])
    third = None if u3 is None or h3 is None else \
        _dot(u3, h) + 3 * _dot(u2, h1) + 3 * _dot(u1, h2) + _dot(u, h3)
    return (_dot(u, h), _dot(u1, h) + _dot(u, h1), _dot(u2, h) + 2 * _dot(u1, h1) + _dot(u, h2),
            third)


def _axis(vi, phi, w, al, je):
    """The direction u = A(phi) vi (N, 2) on a body turning by phi, and its derivatives u' =
    w R u, u'' = al R u - w^2 u, u''' = (je - w^3) R u - 3 w al u (None without je)."""
    c, s = np.cos(phi), np.sin(phi)
    u = np.stack([c * vi[0] - s * vi[1], s * vi[0] + c * vi[1]], axis=1)
    Ru = np.stack([-u[:, 1], u[:, 0]], axis=1)
    u3 = None if je is None else (je - w * w * w)[:, None] * Ru - (3.0 * w * al)[:, None] * u
    return u, w[:, None] * Ru, al[:, None] * Ru - (w * w)[:, None] * u, u3


def _guide_axis(ch, cm, el_index):
    g, k = _group_of(cm, el_index)
    return _axis(g.params["vi"][k], *_body(ch, cm, int(g.bodies[k, 0]))[4:])


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
    """(value, rate, accel, jerk) arrays (N,) of measure m in user units; the jerk None without
    ch.qddd; a ratio's accel None without it too, its jerk always None."""
    af = cm.angle_factor
    deg = 1.0 / af                          # radians -> user angle unit
    levels = (ch.q, ch.qd, ch.qdd, ch.qddd)

    def angle(b):
        """Body b's angle and its derivatives (ground: 0)."""
        return tuple(None if X is None else np.zeros(len(ch.t)) if b == cm.nb
                     else X[:, 3 * b + 2] for X in levels)

    def relative(i, j):
        return _diff(angle(i), angle(j))

    def scaled(th):
        return tuple(None if x is None else x * deg for x in th)

    if m.kind == "distance":
        return _distance(_point(ch, cm, m.refs[0]), _point(ch, cm, m.refs[1]))
    if m.kind == "angle" and len(m.refs) == 1:
        return angle(_body_index(cm, m.refs[0]))
    if m.kind == "angle":
        return scaled(_vector_angle(*_diff(_point(ch, cm, m.refs[0]),
                                           _point(ch, cm, m.refs[1]))))
    if m.kind == "between":
        return relative(*(_body_index(cm, r) for r in m.refs))
    if m.kind == "joint":
        idx = next(k for k, el in enumerate(cm.spec.elements)
                   if el.role == "joint" and el.name == m.refs[0])
        el = cm.spec.elements[idx]
        if el.kind == "revolute":
            return relative(*(_body_index(cm, b) for b in el.bodies))
        return _slide(ch, cm, idx)
    if m.kind == "transmission":
        C = _point(ch, cm, m.refs[1])
        u = _diff(C, _point(ch, cm, m.refs[0]))
        if m.guide is not None:
            idx = next(k for k, el in enumerate(cm.spec.elements)
                       if el.role == "joint" and el.name == m.guide)
            return scaled(_angle_between(*u, *_guide_axis(ch, cm, idx), acute=True))
        return scaled(_angle_between(*u, *_diff(C, _point(ch, cm, m.refs[2]))))
    a, b = done[m.refs[0]], done[m.refs[1]]
    if m.kind == "advantage":
        a, b = b, a
    with np.errstate(divide="ignore", invalid="ignore"):
        r = b[1] / a[1]
        n1 = b[2] * a[1] - b[1] * a[2]      # (b'/a')' = (b'' a' - b' a'') / a'^2
        r1 = n1 / (a[1] * a[1])
        r2 = None
        if a[3] is not None and b[3] is not None:       # (n1 / a'^2)', n1' = b''' a' - b' a'''
            r2 = (b[3] * a[1] - b[1] * a[3]) / (a[1] * a[1]) \
                - 2 * n1 * a[2] / (a[1] * a[1] * a[1])
    return r, r1, r2, None


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


def path_figures(f) -> None:
    """The loops' figures of a followed path (planarkin.derived.path_figures): every four-bar and
    slider-crank loop's transmission angle and velocity ratio, asked or not, kept as f.loops for
    summary.json's ``loops``, and a warning for a passage near a toggle
    (planarkin.measures.loops)."""
    from .loops import follow
    follow(f)


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
