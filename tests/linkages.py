"""Famous linkages from their published link lengths: pin coordinates at one crank angle computed
independently here (circle intersections, no planarkin code), and the same linkage written in
both forms (sketch: pins and links; body/joint: bodies, body-frame vectors from the lengths).

Sources: Jansen's "holy numbers" (Theo Jansen, The Great Pretender, 2007): a..m as in the brief.
Klann: the optimised geometry of boim.com/Walkin8r/Klann.html (crank A-C = 17.5, fixed pivots
B = (-38.8, -12.5), D = (-14.6, 41.9), BH, CF, CH, DE, EF, EG, FG, FH). Peaucellier-Lipkin
inversor: long links 5, rhombus sides 2, driving link 2 (O C . O P = 5^2 - 2^2 = 21, so P runs
on the line x = 21 / 4 = 5.25; C stays at least 5 - 2 = 3 from O for a driving angle within 82 deg).
"""

from __future__ import annotations

import math

JANSEN = dict(a=38.0, b=41.5, c=39.3, d=40.1, e=55.8, f=39.4, g=36.7, h=65.7, i=49.0, j=50.0,
              k=61.9, l=7.8, m=15.0)
KLANN = dict(AC=17.5, Bx=-38.8, By=-12.5, Dx=-14.6, Dy=41.9, BH=23.7, CF=73.4, CH=38.8,
             DE=34.1, EF=57.7, EG=111.7, FG=59.0, FH=35.2)
PEAUCELLIER = dict(L=5.0, s=2.0, r=2.0)


def circles(p, rp, q, rq, side):
    """The intersection of circle (p, rp) and circle (q, rq) to the left (side=+1) or right
    (side=-1) of the direction p -> q."""
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = math.hypot(dx, dy)
    a = (rp * rp - rq * rq + d * d) / (2 * d)
    h = math.sqrt(rp * rp - a * a)
    ux, uy = dx / d, dy / d
    return (p[0] + a * ux - side * h * uy, p[1] + a * uy + side * h * ux)


def jansen(theta):
    """Pins of Jansen's leg at crank angle theta (rad): crank axle O at the origin, fixed pivot
    B = (-a, -l); X the top joint, E the upper triangle's outer corner, F the lower joint, G the
    knee, H the foot."""
    J = JANSEN
    O, B = (0.0, 0.0), (-J["a"], -J["l"])
    A = (J["m"] * math.cos(theta), J["m"] * math.sin(theta))
    # sides as in Jansen's drawings: X above the line A-B, F below it, E (d = 40.1 from B,
    # e = 55.8 from X) away from the crank, the knee G behind, the foot H at the bottom
    X = circles(A, J["j"], B, J["b"], -1)
    F = circles(A, J["k"], B, J["c"], +1)
    E = circles(X, J["e"], B, J["d"], -1)
    G = circles(E, J["f"], F, J["g"], -1)
    H = circles(G, J["h"], F, J["i"], -1)
    return dict(O=O, B=B, A=A, X=X, E=E, F=F, G=G, H=H)


def klann(theta):
    """Pins of the Klann leg at crank angle theta (rad): crank axle A at the origin, crank pin C,
    rockers B-H and D-E, connecting rod C-H-F, leg E-F-G with the foot G."""
    K = KLANN
    A, B, D = (0.0, 0.0), (K["Bx"], K["By"]), (K["Dx"], K["Dy"])
    C = (K["AC"] * math.cos(theta), K["AC"] * math.sin(theta))
    H = circles(C, K["CH"], B, K["BH"], -1)
    F = circles(C, K["CF"], H, K["FH"], +1)
    E = circles(D, K["DE"], F, K["EF"], -1)
    G = circles(E, K["EG"], F, K["FG"], +1)
    return dict(A=A, B=B, D=D, C=C, H=H, F=F, E=E, G=G)


def peaucellier(theta):
    """Pins of the Peaucellier-Lipkin inversor with the driving link Q-C at angle theta (rad):
    fixed pivots O (origin) and Q = (r, 0); long links O-A, O-B; rhombus C-A-P-B."""
    P_ = PEAUCELLIER
    O, Q = (0.0, 0.0), (P_["r"], 0.0)
    C = (Q[0] + P_["r"] * math.cos(theta), P_["r"] * math.sin(theta))
    A = circles(O, P_["L"], C, P_["s"], +1)
    B = circles(O, P_["L"], C, P_["s"], -1)
    P = circles(A, P_["s"], B, P_["s"], +1)
    return dict(O=O, Q=Q, C=C, A=A, B=B, P=P)


# topology: link -> pins (first two fix the frame), ground pins, driven link
JANSEN_LINKS = dict(crank=["O", "A"], upper=["A", "X"], triangle=["B", "X", "E"],
                    lower=["A", "F"], rocker=["B", "F"], thigh=["E", "G"], foot=["F", "G", "H"])
KLANN_LINKS = dict(crank=["A", "C"], rod=["C", "H", "F"], lower=["B", "H"], upper=["D", "E"],
                   leg=["E", "F", "G"])
PEAUCELLIER_LINKS = dict(driver=["Q", "C"], long1=["O", "A"], long2=["O", "B"],
                         side1=["C", "A"], side2=["C", "B"], side3=["A", "P"], side4=["B", "P"])
GROUND = dict(jansen=["O", "B"], klann=["A", "B", "D"], peaucellier=["O", "Q"])


def num(x: float) -> str:
    return repr(float(x))


def sketch_yaml(name, pins, links, ground, driven, f, steps=72) -> str:
    """The sketch form: every pin at its coordinates, links listing pins."""
    lines = [f"name: {name}", "units: {length: mm, angle: deg}", "points:"]
    for p, (x, y) in pins.items():
        g = ", ground: true" if p in ground else ""
        lines.append(f"  {p}: {{at: [{num(x)}, {num(y)}]{g}}}")
    lines.append("links:")
    for k, pts in links.items():
        lines.append(f"  {k}: [{', '.join(pts)}]")
    lines += ["drivers:", f"  - {{type: angle, link: {driven}, f: \"{f}\"}}",
              f"analysis: {{start: 0, end: 1, steps: {steps}}}"]
    return "\n".join(lines) + "\n"


def body_joint_yaml(name, pins, links, ground, driven, f, lengths, steps=72) -> str:
    """The body/joint form of the same linkage: each body's frame at its first pin with the x
    axis towards the second; body-frame vectors of the pins from the link LENGTHS (law of
    cosines, the corner's side taken from the sketch); the body poses as rough estimates (the
    solver assembles them); one revolute per carrier after the first."""
    lines = [f"name: {name}-bodies", "units: {length: mm, angle: deg}", "bodies:"]
    local = {}
    for k, pts in links.items():
        p0, p1 = pins[pts[0]], pins[pts[1]]
        phi = math.atan2(p1[1] - p0[1], p1[0] - p0[0])
        # rough estimate: 1% off in position, 1 degree off in angle
        lines.append(f"  {k}: {{q: [{num(p0[0] + 0.2)}, {num(p0[1] - 0.1)}, "
                     f"{num(math.degrees(phi) + 1.0)}]}}")
        l01 = lengths(pts[0], pts[1])
        local[(k, pts[0])] = (0.0, 0.0)
        local[(k, pts[1])] = (l01, 0.0)
        for p in pts[2:]:
            l0p, l1p = lengths(pts[0], p), lengths(pts[1], p)
            x = (l01 * l01 + l0p * l0p - l1p * l1p) / (2 * l01)
            y = math.sqrt(l0p * l0p - x * x)
            q = pins[p]
            cross = (p1[0] - p0[0]) * (q[1] - p0[1]) - (p1[1] - p0[1]) * (q[0] - p0[0])
            local[(k, p)] = (x, y if cross > 0 else -y)
    lines.append("joints:")
    for p in pins:
        carriers = (["ground"] if p in ground else []) + [k for k, pts in links.items()
                                                          if p in pts]
        for other in carriers[1:]:
            si = pins[p] if carriers[0] == "ground" else local[(carriers[0], p)]
            sj = local[(other, p)]
            lines.append(f"  - {{type: revolute, i: {carriers[0]}, j: {other}, "
                         f"si: [{num(si[0])}, {num(si[1])}], sj: [{num(sj[0])}, {num(sj[1])}]}}")
    lines += ["drivers:", f"  - {{type: angle, body: {driven}, f: \"{f}\"}}", "points:"]
    for p in pins:
        carriers = [k for k, pts in links.items() if p in pts]
        if carriers:
            s = local[(carriers[0], p)]
            lines.append(f"  {p}: {{body: {carriers[0]}, s: [{num(s[0])}, {num(s[1])}]}}")
    lines.append(f"analysis: {{start: 0, end: 1, steps: {steps}}}")
    return "\n".join(lines) + "\n"


def jansen_length(p, q):
    J = JANSEN
    table = {("O", "A"): J["m"], ("A", "X"): J["j"], ("B", "X"): J["b"], ("B", "E"): J["d"],
             ("X", "E"): J["e"], ("A", "F"): J["k"], ("B", "F"): J["c"], ("E", "G"): J["f"],
             ("F", "G"): J["g"], ("F", "H"): J["i"], ("G", "H"): J["h"]}
    return table.get((p, q)) or table[(q, p)]


def klann_length(p, q):
    K = KLANN
    table = {("A", "C"): K["AC"], ("C", "H"): K["CH"], ("C", "F"): K["CF"], ("H", "F"): K["FH"],
             ("B", "H"): K["BH"], ("D", "E"): K["DE"], ("E", "F"): K["EF"], ("E", "G"): K["EG"],
             ("F", "G"): K["FG"]}
    return table.get((p, q)) or table[(q, p)]


def peaucellier_length(p, q):
    P_ = PEAUCELLIER
    table = {("Q", "C"): P_["r"], ("O", "A"): P_["L"], ("O", "B"): P_["L"],
             ("C", "A"): P_["s"], ("C", "B"): P_["s"], ("A", "P"): P_["s"], ("B", "P"): P_["s"]}
    return table.get((p, q)) or table[(q, p)]
