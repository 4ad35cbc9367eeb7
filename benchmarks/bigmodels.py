"""Big coupled mechanisms for the large-block benchmarks and tests (YAML generators).

(a) arch: one closed loop of N unit links between two ground pins A = (0, 0) and B = (2R, 0),
    driven by N - 2 relative angle drivers between consecutive links. At t = 0 the pins lie on
    a half circle of radius R (chord 1 between neighbours, so 2 R sin(pi / 2N) = 1); the drivers
    bend every joint k = 0..N-3 by a (1 + k / N) sin(2 pi t) with a = 2 / N^2 (rad: small
    enough that the chord from A to the last inner pin stays well inside the triangle
    inequality, so the motion is regular at every N). The constraint graph does not split: one irreducible block of 3 N unknowns.
(b) scissor lift: S stages of two bars of length 2 crossed at their midpoints; stage k's lower
    ends are pinned to stage k-1's upper ends; at the base one bar is pinned to ground, the other
    slides on the x axis and its distance to the pin is driven, x(t) = 2 cos(theta0) (1 +
    0.1 sin 2 pi t). Every stage is determined by the one below it (small blocks, many of
    them).
(c) arched ladder: the arch with a rung at every inner pin and an outer rail joining the rung
    tops, driven by the rung angles: a ladder of coupled loops, one block of 9 (N - 1) unknowns
    (see ladder_yaml).
Body order and frames: each link's frame at its first end, x axis along the link.
"""

from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi


def arch_radius(N: int) -> float:
    return 0.5 / math.sin(math.pi / (2 * N))


def arch_yaml(N: int, steps: int = 1000) -> str:
    R = arch_radius(N)
    th = math.pi / N
    a = 2.0 / N ** 2
    out = [f"# arch (benchmarks/bigmodels.py): {N} unit links, one loop, {N - 2} relative "
           f"angle drivers",
           f"name: arch-{N}", "units: {length: m, angle: rad}", "bodies:"]
    for k in range(N):
        ang = math.pi - k * th                       # polar angle of pin k on the circle
        x, y = R + R * math.cos(ang), R * math.sin(ang)
        phi = math.pi / 2 - (k + 0.5) * th           # direction of the chord k -> k + 1
        out.append(f"  l{k}: {{q: [{x!r}, {y!r}, {phi!r}]}}")
    out.append("joints:")
    out.append("  - {type: revolute, i: ground, j: l0, si: [0, 0], sj: [0, 0]}")
    for k in range(N - 1):
        out.append(f"  - {{type: revolute, i: l{k}, j: l{k + 1}, si: [1, 0], sj: [0, 0]}}")
    out.append(f"  - {{type: revolute, i: ground, j: l{N - 1}, si: [{2 * R!r}, 0], "
               f"sj: [1, 0]}}")
    out.append("drivers:")
    for k in range(N - 2):
        amp = a * (1 + k / N)
        out.append(f"  - {{type: angle, i: l{k}, j: l{k + 1}, "
                   f"f: \"{-th!r} + {amp!r}*sin(2*pi*t)\"}}")
    out.append("points:")
    out.append(f"  top: {{body: l{N // 2}, s: [0, 0]}}")
    out.append(f"analysis: {{start: 0, end: 1, steps: {steps}}}")
    return "\n".join(out) + "\n"


def scissor_yaml(S: int, steps: int = 1000, theta0: float = 0.6) -> str:
    """S stages; bar a_k rises to the right, b_k to the left (both of length 2)."""
    c, s = math.cos(theta0), math.sin(theta0)
    w = 2 * c
    out = [f"# scissor lift (benchmarks/bigmodels.py): {S} stages, {2 * S} bars", f"name: scissor-{S}", "units: {length: m, angle: rad}", "bodies:"]
    for k in range(S):
        y0 = 2 * s * k
        out.append(f"  a{k}: {{q: [0.0, {y0!r}, {theta0!r}]}}")
        out.append(f"  b{k}: {{q: [{w!r}, {y0!r}, {math.pi - theta0!r}]}}")
    out.append("joints:")
    out.append("  - {type: revolute, i: ground, j: a0, si: [0, 0], sj: [0, 0]}")
    out.append("  - {type: y, i: ground, j: b0, si: [0, 0], sj: [0, 0], c: 0}")
    for k in range(S):
        out.append(f"  - {{type: revolute, i: a{k}, j: b{k}, si: [1, 0], sj: [1, 0]}}")
        if k:
            out.append(f"  - {{type: revolute, i: b{k - 1}, j: a{k}, si: [2, 0], sj: [0, 0]}}")
            out.append(f"  - {{type: revolute, i: a{k - 1}, j: b{k}, si: [2, 0], sj: [0, 0]}}")
    out.append("drivers:")
    out.append(f"  - {{type: x, i: ground, j: b0, si: [0, 0], sj: [0, 0], "
               f"f: \"{w!r}*(1 + 0.1*sin(2*pi*t))\"}}")
    out.append("points:")
    out.append(f"  top: {{body: a{S - 1}, s: [2, 0]}}")
    out.append(f"analysis: {{start: 0, end: 1, steps: {steps}}}")
    return "\n".join(out) + "\n"


def ladder_yaml(N: int, steps: int = 1000, h: float = 0.5) -> str:
    """An arched ladder: the arch's N links, a rung of length h at each inner pin k = 1..N-1
    (pinned there, pointing radially outwards) and an outer rail of N - 2 links joining
    neighbouring rung tops. The drivers are the rung angles relative to the arch link they stand
    on (N - 1 drivers); every cell (two rungs, their two arch links, one outer link) is a rigid
    triangle, so the cells fix the arch joints 2..N-1 and the arch's closure couples them all:
    one irreducible block of 9 (N - 1) unknowns."""
    R = arch_radius(N)
    th = math.pi / N
    a = 2.0 / N ** 2
    lo = 2 * (R + h) * math.sin(th / 2)
    out = [f"# arched ladder (benchmarks/bigmodels.py): {N} arch links, {N - 1} rungs, "
           f"{N - 2} outer links", f"name: ladder-{N}", "units: {length: m, angle: rad}",
           "bodies:"]
    for k in range(N):
        ang = math.pi - k * th
        out.append(f"  l{k}: {{q: [{R + R * math.cos(ang)!r}, {R * math.sin(ang)!r}, "
                   f"{math.pi / 2 - (k + 0.5) * th!r}]}}")
    for k in range(1, N):
        ang = math.pi - k * th
        out.append(f"  r{k}: {{q: [{R + R * math.cos(ang)!r}, {R * math.sin(ang)!r}, "
                   f"{ang!r}]}}")
    for k in range(1, N - 1):
        ang = math.pi - k * th
        out.append(f"  o{k}: {{q: [{R + (R + h) * math.cos(ang)!r}, "
                   f"{(R + h) * math.sin(ang)!r}, {math.pi / 2 - (k + 0.5) * th!r}]}}")
    out.append("joints:")
    out.append("  - {type: revolute, i: ground, j: l0, si: [0, 0], sj: [0, 0]}")
    for k in range(N - 1):
        out.append(f"  - {{type: revolute, i: l{k}, j: l{k + 1}, si: [1, 0], sj: [0, 0]}}")
    out.append(f"  - {{type: revolute, i: ground, j: l{N - 1}, si: [{2 * R!r}, 0], "
               f"sj: [1, 0]}}")
    for k in range(1, N):
        out.append(f"  - {{type: revolute, i: l{k}, j: r{k}, si: [0, 0], sj: [0, 0]}}")
    for k in range(1, N - 1):
        out.append(f"  - {{type: revolute, i: r{k}, j: o{k}, si: [{h!r}, 0], sj: [0, 0]}}")
        out.append(f"  - {{type: revolute, i: r{k + 1}, j: o{k}, si: [{h!r}, 0], "
                   f"sj: [{lo!r}, 0]}}")
    out.append("drivers:")
    for k in range(1, N):
        amp = a * (1 + k / N)
        out.append(f"  - {{type: angle, i: l{k}, j: r{k}, "
                   f"f: \"{math.pi / 2 + th / 2!r} + {amp!r}*sin(2*pi*t)\"}}")
    out.append("points:")
    out.append(f"  top: {{body: o{(N - 1) // 2}, s: [0, 0]}}")
    out.append(f"analysis: {{start: 0, end: 1, steps: {steps}}}")
    return "\n".join(out) + "\n"
