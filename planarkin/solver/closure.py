"""Loops of pin joints that cannot close, whatever the drivers do: the reason a model cannot be
assembled when its links are simply too short (or one too long) for their loop.

A loop of revolute joints is a polygon: body by body, the distance between the pin it enters by
and the pin it leaves by is a side, and the distance between the loop's two ground pins is the
last side. It closes in some pose exactly when no side is longer than the others together.
Only the failed assembly asks (planarkin.solver.assembly), so the loop search may take its time.
"""

from __future__ import annotations

import math

from planarkin.diagnostics import Diagnostic

MAX_LOOP = 8          # bodies in a loop searched
MAX_LOOPS = 200       # loops looked at
SLACK = 1e-9          # relative to the loop's length: closing exactly (a folded loop) is allowed


def short_loops(cm) -> list[Diagnostic]:
    """One error per loop of revolute joints through ground whose longest side is longer than
    the others together (at most three), at the line of the loop's first joint."""
    ground = cm.nb
    adj: dict[int, list] = {b: [] for b in range(cm.nb + 1)}
    for G in cm.groups:
        if G.kind.name != "revolute":
            continue
        for k in range(len(G)):
            bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
            si, sj = tuple(map(float, G.params["si"][k])), tuple(map(float, G.params["sj"][k]))
            row = int(G.rows[k, 0])
            adj[bi].append((bj, si, sj, row))
            adj[bj].append((bi, sj, si, row))
    loops, seen = [], set()

    def walk(body, entry, path, rows, g_start):
        if len(loops) >= MAX_LOOPS:
            return
        for nxt, here, there, row in adj[body]:
            if row == rows[-1]:
                continue
            side = (body, math.dist(entry, here))
            if nxt == ground:
                key = frozenset(rows + [row])
                if key not in seen:
                    seen.add(key)
                    loops.append((path + [side], math.dist(g_start, there), rows + [row]))
            elif len(path) < MAX_LOOP and nxt not in {b for b, _ in path} and nxt != body:
                walk(nxt, there, path + [side], rows + [row], g_start)

    for nxt, g_pin, there, row in adj[ground]:
        if nxt != ground:
            walk(nxt, there, [], [row], g_pin)
    out = []
    for sides, ground_side, rows in loops:
        lengths = [d for _, d in sides] + [ground_side]
        total = sum(lengths)
        longest = max(lengths)
        if not longest > total - longest + SLACK * total or len(out) >= 3:
            continue
        out.append(_message(cm, sides, ground_side, rows))
    return out


def _message(cm, sides, ground_side, rows) -> Diagnostic:
    L, u = cm.L, cm.spec.length_unit
    names = [cm.body_names[b] for b, _ in sides]
    loop = "-".join(["ground"] + names)
    links = ", ".join(f"{n} {d * L:.4g}" for n, (_, d) in zip(names, sides))
    moving = sum(d for _, d in sides)
    line = cm.element_of_row(rows[0]).line
    if ground_side >= moving:
        msg = (f"the loop {loop} cannot close: its moving links add up to {moving * L:.4g} {u} "
               f"({links}), less than the {ground_side * L:.4g} {u} between its ground pins; "
               f"lengthen a link or bring the ground pins closer")
    else:
        k = max(range(len(sides)), key=lambda i: sides[i][1])
        d = sides[k][1]
        others = ", ".join([f"{n} {s * L:.4g}" for i, (n, (_, s)) in enumerate(zip(names, sides))
                            if i != k] + [f"ground {ground_side * L:.4g}"])
        msg = (f"the loop {loop} cannot close: its link {names[k]} ({d * L:.4g} {u} between "
               f"its pins) is longer than the other sides together "
               f"({(moving - d + ground_side) * L:.4g} {u}: {others}); shorten it or lengthen "
               f"the others")
    return Diagnostic(cm.spec.file, line, msg)
