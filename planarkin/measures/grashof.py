"""Grashof classification of every four-bar loop of a model (printed by `planarkin check`).

A four-bar loop is ground, two bodies p and r pinned to ground, and a coupler c pinned to both
(four revolute joints). Its link lengths are the distances between each link's two pins (ground:
between its two pivots). With s the shortest, l the longest and p, q the others:
    s + l < p + q   Grashof: s = ground -> double-crank; s next to ground -> crank-rocker (s is
                    the crank); s = coupler -> double-rocker;
    s + l = p + q   change point (the loop can fold flat);
    s + l > p + q   non-Grashof: triple-rocker (no link turns fully relative to another).

A slider-crank loop is ground, a crank p pinned to ground, a rod c pinned to p and to a slider s
that slides on a translational joint to ground (s not pinned to ground). With the crank a (its
pins' distance), the rod b and the offset e (the signed distance of the crank's pivot A from
the line the rod-slider pin C runs on), the crank's angle theta from the guide direction u
puts the crank pin at n.(C - B) = e - a sin(theta) off the rod's span (n = u turned by +90
deg), and the rod reaches only while |e - a sin(theta)| <= b:
    (e - b) / a <= sin(theta) <= (e + b) / a,
so the crank turns fully exactly when b >= a + |e|; past a limit the rod stands perpendicular
to the guide and the loop locks when the crank is driven (`lock_ups`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Loop:
    links: tuple        # (ground, p, c, r) body names
    lengths: tuple      # their lengths, user length unit
    kind: str           # 'crank-rocker', 'double-crank', 'double-rocker', 'change point',
                        # 'triple-rocker'
    crank: str | None   # the link that turns fully, for a crank-rocker
    bodies: tuple = ()  # (ground, p, c, r) body indices (ground = cm.nb)
    pins: tuple = ()    # internal body-frame points: ground's pivots of p and r, p's ends at
                        # ground and at c, r's ends at ground and at c

    def describe(self, unit: str) -> str:
        s, l = min(self.lengths), max(self.lengths)
        pq = sum(self.lengths) - s - l
        rel = "<" if self.kind in ("crank-rocker", "double-crank", "double-rocker") else \
            "=" if self.kind == "change point" else ">"
        what = {"crank-rocker": f"crank-rocker ({self.crank} turns fully)",
                "double-crank": "double-crank (both pinned links turn fully)",
                "double-rocker": "double-rocker (Grashof: the coupler turns fully)",
                "change point": "change point (s + l = p + q: the loop can fold flat)",
                "triple-rocker": "triple-rocker (non-Grashof: no link turns fully)"}[self.kind]
        names = "-".join(self.links)
        lens = ", ".join(f"{n} {x:.6g}" for n, x in zip(self.links, self.lengths))
        return (f"four-bar loop {names}: {what}; s + l = {s + l:.6g} {rel} p + q = {pq:.6g} "
                f"{unit} ({lens})")


def pin_pairs(cm) -> dict:
    """{(body a, body b): [(s_a, s_b)]}: every pair of bodies sharing a pin (internal units,
    body frames). A pin carried by three links is two revolute joints (the sketch form pins its
    first carrier to each other one): the carriers' points are joined through the body points
    they share, so the other two carriers share the pin too."""
    parent: dict = {}

    def root(x):
        while parent.setdefault(x, x) != x:
            parent[x] = x = parent[parent[x]]
        return x
    for g in cm.groups:
        if g.kind.name != "revolute":
            continue
        for k in range(len(g)):
            a, b = (int(x) for x in g.bodies[k, :2])
            ends = (a, tuple(g.params["si"][k])), (b, tuple(g.params["sj"][k]))
            parent[root(ends[0])] = root(ends[1])
    members: dict = {}
    for x in list(parent):
        members.setdefault(root(x), []).append(x)
    pins: dict[tuple[int, int], list] = {}
    for group in members.values():
        for a, sa in group:
            for b, sb in group:
                if a != b:
                    pins.setdefault((a, b), []).append((sa, sb))
    return pins


def four_bar_loops(cm) -> list[Loop]:
    """Every four-bar loop of the compiled model, classified."""
    pins = pin_pairs(cm)
    G = cm.nb
    name = lambda b: "ground" if b == G else cm.body_names[b]
    grounded = sorted({b for (a, b) in pins if a == G})
    # couplers from the pin graph's neighbours: looping over every pair of grounded bodies and
    # every body (as written first) never finished for the 18,003-coordinate N-four-bar chain
    # (6,000 grounded bodies); the loops come out in the same order
    rank = {b: i for i, b in enumerate(grounded)}
    nbrs: dict[int, list] = {}
    for a, b in pins:
        nbrs.setdefault(a, []).append(b)
    out = []
    for ip, p in enumerate(grounded):
        found = sorted((rank[r], c, r) for c in nbrs.get(p, ()) if c not in (G, p)
                       for r in nbrs.get(c, ()) if rank.get(r, -1) > ip and r != c)
        for _, c, r in found:
            gp, pg = pins[(G, p)][0]         # ground's pivot of p, p's end there
            gr, rg = pins[(G, r)][0]
            pc, cp = pins[(p, c)][0]
            cr, rc = pins[(c, r)][0]
            L = cm.L
            lengths = (math.dist(gp, gr) * L, math.dist(pg, pc) * L,
                       math.dist(cp, cr) * L, math.dist(rc, rg) * L)
            out.append(_classify((name(G), name(p), name(c), name(r)), lengths,
                                 (G, p, c, r), (gp, gr, pg, pc, rg, rc)))
    return out


def _classify(links, lengths, bodies=(), pins=()) -> Loop:
    s, l = min(lengths), max(lengths)
    pq = sum(lengths) - s - l
    k = lengths.index(s)
    tol = 1e-12 * l
    kind, crank = ("change point" if abs((s + l) - pq) <= tol else
                   "triple-rocker" if s + l > pq else
                   "double-crank" if k == 0 else "double-rocker" if k == 2 else
                   "crank-rocker"), None
    if kind == "crank-rocker":
        crank = links[k]
    return Loop(links, lengths, kind, crank, tuple(bodies), tuple(pins))


@dataclass(frozen=True)
class SliderCrank:
    links: tuple        # (ground, crank, rod, slider) body names
    bodies: tuple       # their body indices (ground = cm.nb)
    pins: tuple         # internal body-frame points: ground's pivot of the crank, the crank's
                        # ends at ground and at the rod, the slider's pin (slider frame)
    guide: tuple        # (body index carrying the axis, its axis vi (unit, that body's frame),
                        # spec element index of the translational joint)
    a: float            # crank length (its pins' distance), internal units
    b: float            # rod length, internal units

    def offset(self, q) -> float:
        """e = n.(C - A) at the pose q (internal units, (n,) or extended): the signed distance
        of the crank's pivot A from the line of the rod-slider pin C (constant: the slider
        does not turn), n the guide direction u turned by +90 deg."""
        u, n = self.axes(q)
        gp, pg, pc, sc = self.pins
        C = _global(q, self.bodies[3], sc)
        return float(n[0] * (C[0] - gp[0]) + n[1] * (C[1] - gp[1]))

    def describe(self, q, L: float, unit: str) -> str:
        """In words for `check`: whether the crank turns fully at the pose q (internal units;
        L: user length per internal unit), with the lengths that decide it."""
        a, b, e = self.a * L, self.b * L, self.offset(q) * L
        if abs(e) <= 1e-12 * max(a, b):
            e = 0.0                             # on the guide's line, to rounding
        names = "-".join(self.links)
        crank, rod = self.links[1], self.links[2]
        lens = f"crank {a:.6g}, rod {b:.6g}, offset {e:.6g} {unit}"
        if b > a + abs(e):
            return (f"slider-crank loop {names}: {crank} turns fully; rod > crank + |offset|: "
                    f"{b:.6g} > {a + abs(e):.6g} {unit} ({lens})")
        if b == a + abs(e):
            return (f"slider-crank loop {names}: change point (rod = crank + |offset|: the "
                    f"loop can fold flat) ({lens})")
        return (f"slider-crank loop {names}: {crank} cannot turn fully (rod < crank + |offset|: "
                f"{b:.6g} < {a + abs(e):.6g} {unit}): {rod} reaches only while (e - b)/a <= "
                f"sin(theta) <= (e + b)/a, theta the crank's angle from the guide ({lens})")

    def axes(self, q):
        """The guide direction u and its normal n = k x u (global) at the pose q."""
        gb, vi, _ = self.guide
        phi = float(q[3 * gb + 2]) if 3 * gb + 2 < len(q) else 0.0
        c, s = math.cos(phi), math.sin(phi)
        u = (c * vi[0] - s * vi[1], s * vi[0] + c * vi[1])
        return u, (-u[1], u[0])


def _global(q, b, s):
    """Global position of body b's point s (internal units) at the pose q (ground: s)."""
    if 3 * b + 2 >= len(q):
        return tuple(s)
    phi = float(q[3 * b + 2])
    c, sn = math.cos(phi), math.sin(phi)
    return (float(q[3 * b]) + c * s[0] - sn * s[1], float(q[3 * b + 1]) + sn * s[0] + c * s[1])


def slider_crank_loops(cm) -> list[SliderCrank]:
    """Every slider-crank loop of the compiled model: a slider on a translational joint to
    ground (and not pinned to ground), a rod pinned to it, a crank pinned to the rod and to
    ground; in the order of the translational joints, then of the bodies."""
    pins = pin_pairs(cm)
    G = cm.nb
    name = lambda b: "ground" if b == G else cm.body_names[b]
    nbrs: dict[int, list] = {}
    for a, b in pins:
        nbrs.setdefault(a, []).append(b)
    out, seen = [], set()
    for g in cm.groups:
        if g.kind.name != "translational":
            continue
        for k in range(len(g)):
            bi, bj = (int(x) for x in g.bodies[k, :2])
            if (bi == G) == (bj == G):
                continue
            s = bj if bi == G else bi
            if (G, s) in pins:
                continue                      # pinned to ground as well: it does not slide
            vi = tuple(float(x) for x in g.params["vi"][k])
            norm = math.hypot(*vi)
            if not norm > 0:
                continue
            el = int(cm.row_element[int(g.rows[k, 0])])
            for c in sorted(set(nbrs.get(s, ()))):
                if c in (G, s):
                    continue
                for p in sorted(set(nbrs.get(c, ()))):
                    if p in (G, s, c) or (G, p) not in pins or (p, s, c) in seen:
                        continue
                    seen.add((p, s, c))
                    gp, pg = pins[(G, p)][0]
                    pc, cp = pins[(p, c)][0]
                    cs, sc = pins[(c, s)][0]
                    out.append(SliderCrank(
                        (name(G), name(p), name(c), name(s)), (G, p, c, s), (gp, pg, pc, sc),
                        (bi, (vi[0] / norm, vi[1] / norm), el), math.dist(pg, pc),
                        math.dist(cp, cs)))
    return out


def _first_crossing(theta, ends, start, end, steps):
    """The first time the driven angle theta(t) (internal radians) leaves [ends[0][0],
    ends[1][0]] on the run's grid (at most 200,000 samples), by bisection of the driver
    function: (the end crossed, its reason, t) or None when it stays within."""
    import numpy as np
    n = int(min(steps, 200_000))
    t = np.linspace(start, end, n + 1)
    th = np.broadcast_to(theta(t), t.shape)
    past = (th < ends[0][0]) | (th > ends[1][0])
    if not past.any() or past[0]:
        return None
    k = int(np.argmax(past))
    limit, why = ends[0] if th[k] < ends[0][0] else ends[1]
    ta, tb = float(t[k - 1]), float(t[k])
    for _ in range(200):
        tm = 0.5 * (ta + tb)
        if tm in (ta, tb):
            break
        inside = ends[0][0] <= float(theta(tm)) <= ends[1][0]
        ta, tb = (tm, tb) if inside else (ta, tm)
    return limit, why, tb


def _ground_angle_drivers(cm):
    """(driver, sign, body index) of each angle driver between ground and one body: the body's
    angle is sign * f(t) plus a constant (phi_j - phi_i = f(t))."""
    for el in cm.spec.drivers:
        if el.kind != "angle" or el.f is None or "ground" not in el.bodies[:2] or \
                el.bodies[0] == el.bodies[1]:
            continue
        i, j = el.bodies[:2]
        yield el, (1.0 if i == "ground" else -1.0), cm.body_names.index(j if i == "ground"
                                                                         else i)


def _driven_past(el, theta0, sgn, af, ends, start, end, steps):
    """Where the driver el takes the driven angle (theta0 at start, internal radians; sgn and af
    from the driver's coordinate to it) past ends: ((limit, why, t), lim, span) with lim the
    driver's coordinate at an angle and span the driver's range between the ends, or None."""
    import numpy as np
    f0 = float(el.f(start))
    theta = lambda tt: theta0 + sgn * (np.asarray(el.f(tt), float) - f0) * af
    hit = _first_crossing(theta, ends, start, end, steps)
    if hit is None:
        return None
    lim = lambda v: f0 + sgn * (v - theta0) / af
    return hit, lim, sorted(lim(v) for v, _ in ends)


def _slider_crank_window(sc, q0):
    """The crank angles (from the guide direction u, internal radians, unwrapped around the
    assembled one) between which the slider-crank sc closes, reached from the pose q0:
    (theta0, [(lower limit, reason), (upper limit, reason)]), or None when the crank turns
    fully (b > a + |e|), at b = a + |e| (a change point: the rod touches the perpendicular at one
    pose, where the branches cross, as a four-bar's change point, which lock_ups leaves to the
    run's bifurcation) or q0 lies on no branch."""
    gp, pg, pc, sc_ = sc.pins
    a, b = sc.a, sc.b
    e = sc.offset(q0)
    if a == 0 or b >= a + abs(e) - 1e-12 * (a + b):
        return None
    u, _ = sc.axes(q0)
    p = sc.bodies[1]
    theta0 = (float(q0[3 * p + 2]) + math.atan2(pc[1] - pg[1], pc[0] - pg[0])
              - math.atan2(u[1], u[0]))
    hi, lo = (e + b) / a, (e - b) / a           # sin(theta) must stay within [lo, hi]
    if lo >= 1 or hi <= -1:
        return None                              # never closes (assembly refuses it)
    arcs = []                                    # forbidden open arcs (start, end), radians
    if hi < 1:      # rod perpendicular, the slider pin on the -n side of the crank pin
        al = math.asin(hi)
        arcs.append((al, math.pi - al, "-n"))
    if lo > -1:     # the slider pin on the +n side
        be = math.asin(lo)
        arcs.append((math.pi - be, 2 * math.pi + be, "+n"))
    up = down = None
    for s0, s1, why in arcs:
        k = math.floor((theta0 - s0) / (2 * math.pi))
        for kk in (k - 1, k, k + 1, k + 2):
            a0, a1 = s0 + 2 * math.pi * kk, s1 + 2 * math.pi * kk
            if a0 + 1e-9 < theta0 < a1 - 1e-9:
                return None                      # assembled inside a forbidden arc
            if a0 >= theta0 - 1e-9 and (up is None or a0 < up[0]):
                up = (a0, why)
            if a1 <= theta0 + 1e-9 and (down is None or a1 > down[0]):
                down = (a1, why)
    return theta0, [down, up]


def _slider_crank_lock_ups(cm, q0, start, end, steps) -> list:
    """lock_ups' warnings for slider-crank loops whose crank an angle driver turns past the
    angle where its rod stands perpendicular to the guide (b < a + |e|)."""
    from ..diagnostics import Diagnostic
    spec = cm.spec
    af = math.pi / 180 if spec.angle_unit == "deg" else 1.0
    loops = slider_crank_loops(cm)
    out = []
    if not loops:
        return out
    for el, sgn, x in _ground_angle_drivers(cm):
        for sc in loops:
            if x != sc.bodies[1]:
                continue
            win = _slider_crank_window(sc, q0)
            if win is None:
                continue
            theta0, ends = win
            crossed = _driven_past(el, theta0, sgn, af, ends, start, end, steps)
            if crossed is None:
                continue
            (limit, _, tb), lim, span = crossed
            u, lu = spec.angle_unit, spec.length_unit
            L = cm.L
            e = sc.offset(q0)
            e = 0.0 if abs(e) <= 1e-12 * (sc.a + sc.b) else e      # rounding of a centred one
            crank, rod, slider = sc.links[1:]
            out.append(Diagnostic(spec.file, el.param_lines.get("f", el.line), (
                f"{el.label}: the slider-crank loop {'-'.join(sc.links)} (rod {sc.b * L:.6g} "
                f"{lu} < crank {sc.a * L:.6g} + |offset| {abs(e) * L:.6g} {lu}: the crank "
                f"cannot turn fully) locks where {crank} reaches {lim(limit):.6g} {u} of this "
                f"driver ({rod} perpendicular to the guide of {slider}), which the driver "
                f"reaches at t = {tb:.6g} s: the run will stop there (lock-up). "
                f"{crank} moves only between {span[0]:.6g} and {span[1]:.6g} {u} of this "
                f"driver; end the run before t = {tb:.6g} s, keep the driver within that "
                f"range, lengthen the rod to at least {(sc.a + abs(e)) * L:.6g} {lu}, or drive "
                f"another link"), "warning"))
            break
    return out


def lock_ups(cm, q0, start: float, end: float, steps: int) -> list:
    """Warnings (Diagnostic, at the driver's line) for every angle driver that turns a grounded
    link of a four-bar loop, or the crank of a slider-crank loop (see the module docstring),
    past the angle where the loop locks, within start..end.

    With the driven link of length a at the pivot A, the ground line g from A to the other
    pivot D, the coupler b and the other link c, the distance BD from the driven link's far pin
    to D obeys BD^2 = a^2 + g^2 - 2 a g cos(theta) (theta: the driven link's angle from the
    line A-D), and the loop closes only while |b - c| <= BD <= b + c:
        cos(theta) >= (a^2 + g^2 - (b + c)^2) / (2 a g)   (b and c stretched in line), and
        cos(theta) <= (a^2 + g^2 - (b - c)^2) / (2 a g)   (b and c folded onto each other).
    The range of theta reached from the assembled pose without crossing either limit is
    compared with the driver's values on the run's grid (at most 200,000 samples); the first
    crossing is found by bisection of the driver function."""
    from ..diagnostics import Diagnostic
    spec = cm.spec
    af = math.pi / 180 if spec.angle_unit == "deg" else 1.0
    loops = [lp for lp in four_bar_loops(cm) if lp.bodies and lp.kind != "change point"]
    out = []
    for el, sgn, x in _ground_angle_drivers(cm):
        for lp in loops:
            if x not in (lp.bodies[1], lp.bodies[3]):
                continue
            gp, gr, pg, pc, rg, rc = lp.pins
            g = math.dist(gp, gr)
            if x == lp.bodies[1]:
                base, tip, ax, ad = pg, pc, gp, gr
                b, c, other = lp.lengths[2] / cm.L, lp.lengths[3] / cm.L, lp.links[3]
            else:
                base, tip, ax, ad = rg, rc, gr, gp
                b, c, other = lp.lengths[2] / cm.L, lp.lengths[1] / cm.L, lp.links[1]
            a = math.dist(base, tip)
            if a == 0 or g == 0:
                continue
            c1 = (a * a + g * g - (b + c) ** 2) / (2 * a * g)
            c2 = (a * a + g * g - (b - c) ** 2) / (2 * a * g)
            if c1 <= -1 and c2 >= 1:
                continue                                 # the driven link turns fully
            theta0 = (float(q0[3 * x + 2]) + math.atan2(tip[1] - base[1], tip[0] - base[0])
                      - math.atan2(ad[1] - ax[1], ad[0] - ax[0]))
            w = math.remainder(theta0, 2 * math.pi)
            sigma = 1.0 if w >= 0 else -1.0
            lo = math.acos(min(c2, 1.0))                 # folded
            hi = math.acos(max(c1, -1.0))                # stretched
            ends = [(-hi, "stretched"), (hi, "stretched")] if c2 >= 1 else \
                [(lo, "folded"), (2 * math.pi - lo, "folded")] if c1 <= -1 else \
                [(lo, "folded"), (hi, "stretched")]
            if not ends[0][0] - 1e-9 <= abs(w) <= ends[1][0] + 1e-9:
                continue                                 # assembled on no branch of this law
            ends = sorted((theta0 - w + sigma * u, why) for u, why in ends)
            crossed = _driven_past(el, theta0, sgn, af, ends, start, end, steps)
            if crossed is None:
                continue
            (limit, why, tb), lim, span = crossed
            u, lu = spec.angle_unit, spec.length_unit
            link = cm.body_names[x]
            dist = (b + c if why == "stretched" else abs(b - c)) * cm.L
            words = {"triple-rocker": "non-Grashof", "crank-rocker": "Grashof, "
                     f"{lp.crank} the crank", "double-rocker": "Grashof double-rocker"}
            out.append(Diagnostic(spec.file, el.param_lines.get("f", el.line), (
                f"{el.label}: the four-bar loop {'-'.join(lp.links)} "
                f"({words.get(lp.kind, lp.kind)}) locks where {link} reaches "
                f"{lim(limit):.6g} {u} of this driver ({lp.links[2]} and {other} {why} in "
                f"line, {dist:.6g} {lu} from the {link}-{lp.links[2]} pin to the {other}'s "
                f"ground pivot), which the driver reaches at t = {tb:.6g} s: the run will stop "
                f"there (lock-up). {link} moves only between {span[0]:.6g} and {span[1]:.6g} {u} "
                f"of this driver; end the run before t = {tb:.6g} "
                f"s, keep the driver within that range, or drive another link"), "warning"))
            break
    return out + _slider_crank_lock_ups(cm, q0, start, end, steps)
