"""Grashof classification of every four-bar loop of a model (printed by `planarkin check`).

A four-bar loop is ground, two bodies p and r pinned to ground, and a coupler c pinned to both
(four revolute joints). Its link lengths are the distances between each link's two pins (ground:
between its two pivots). With s the shortest, l the longest and p, q the others:
    s + l < p + q   Grashof: s = ground -> double-crank; s next to ground -> crank-rocker (s is
                    the crank); s = coupler -> double-rocker;
    s + l = p + q   change point (the loop can fold flat);
    s + l > p + q   non-Grashof: triple-rocker (no link turns fully relative to another).
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


def four_bar_loops(cm) -> list[Loop]:
    """Every four-bar loop of the compiled model, classified."""
    pins: dict[tuple[int, int], list] = {}       # (body a, body b) -> [(s_a, s_b)] internal
    for g in cm.groups:
        if g.kind.name != "revolute":
            continue
        for k in range(len(g)):
            a, b = int(g.bodies[k, 0]), int(g.bodies[k, 1])
            sa, sb = tuple(g.params["si"][k]), tuple(g.params["sj"][k])
            pins.setdefault((a, b), []).append((sa, sb))
            pins.setdefault((b, a), []).append((sb, sa))
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
            out.append(_classify((name(G), name(p), name(c), name(r)), lengths))
    return out


def _classify(links, lengths) -> Loop:
    s, l = min(lengths), max(lengths)
    pq = sum(lengths) - s - l
    k = lengths.index(s)
    tol = 1e-12 * l
    if abs((s + l) - pq) <= tol:
        return Loop(links, lengths, "change point", None)
    if s + l > pq:
        return Loop(links, lengths, "triple-rocker", None)
    if k == 0:
        return Loop(links, lengths, "double-crank", None)
    if k == 2:
        return Loop(links, lengths, "double-rocker", None)
    return Loop(links, lengths, "crank-rocker", links[k])
