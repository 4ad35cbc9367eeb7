"""The shapes of a model compiled (`Shape`, internal units, on CompiledModel.shapes) and the
pairs of shapes that can touch.

Called by planarkin.model.compile when the file has a `shapes:` section. A plate's pins are the
body's revolute joints (where `pins:` names none), so a link written as sketched gets its plate
from its pins; a global outline (frame: global) is turned into the body's frame at the start
pose, as a point's `at:`.

Which pairs are checked (`pairs(cm)`): two shapes on different bodies whose layers overlap,
except a pair `clearance: ignore` lists and a pair joined where they meet: bodies joined by a
pin (a revolute between them, or a pin three links or more share) that lies in both shapes (two
plates on one pin, a crank's plate and the housing it turns in), or by any other joint with the shapes touching at the start pose (a
slider's block on its guide, a cam and its follower, gears in mesh: in contact by design; a
slider and a stop on the frame it slides on are checked). A pair `clearance: pairs` names is always checked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Collector
from .geometry import convex_hull, core
from .shape import Shape


@dataclass(frozen=True)
class Pair:
    """Two shapes to check: indices into cm.shapes, the column name 'a|b', the smallest
    clearance allowed (user length unit) and the line of the key that set it."""

    a: int
    b: int
    name: str
    limit: float
    line: int


def _pins(cm) -> dict:
    """body index -> [(joint name or None, (x, y) internal units, other body)] of every revolute
    joint on it."""
    out: dict = {}
    for G in cm.groups:
        if G.kind.name != "revolute":
            continue
        for k in range(len(G)):
            el = cm.element_of_row(int(G.rows[k, 0]))
            bi, bj = (int(x) for x in G.bodies[k, :2])
            out.setdefault(bi, []).append((el.name, tuple(G.params["si"][k]), bj))
            out.setdefault(bj, []).append((el.name, tuple(G.params["sj"][k]), bi))
    return out


def build_shapes(cm) -> tuple:
    """The Shapes of cm.spec.clearance (internal units); InputError (FILE:LINE) for a plate
    without pins."""
    spec = cm.spec.clearance
    if spec is None or not spec.shapes:
        return ()
    L, af = cm.L, cm.angle_factor
    index = {n: k for k, n in enumerate(cm.body_names)}
    index["ground"] = cm.nb
    poses = {b.name: (b.q[0] / L, b.q[1] / L, b.q[2] * af) for b in cm.spec.bodies}
    pins = _pins(cm)
    problems = Collector(cm.spec.file)
    out = []
    for s in spec.shapes:
        b = index[s.body]
        holes: tuple = ()
        if s.outline == "plate":
            where = _plate_pins(cm, s, b, pins)
            if not where:
                problems.error(s.line, f"shape '{s.name}': body '{s.body}' has no revolute joint "
                                       f"to draw a plate around; name its pins (pins: [P, Q]) or "
                                       f"give a polygon or circle")
                continue
            P = np.array(where, dtype=float)
            pts = convex_hull(P)
            radius, closed = 0.5 * s.size / L, True
            if s.hole > 0:
                holes = tuple((float(x), float(y), s.hole / L) for x, y in _unique(P))
        elif s.outline == "profile":
            got = _profile(cm, s, b)
            if isinstance(got, str):
                problems.error(s.line, f"shape '{s.name}': profile: {got}")
                continue
            pts, radius, closed = got
        elif s.outline == "circle":
            pts = np.array(s.points, dtype=float) / L
            radius, closed = 0.5 * s.size / L, True
        else:
            pts = np.array(s.points, dtype=float) / L
            radius, closed = s.radius / L, s.outline == "polygon"
        if s.frame == "global" and s.outline != "plate" and s.body != "ground":
            from ..elements.revolute import to_body
            pts = np.array([to_body(p, poses[s.body]) for p in pts])
        pts = np.asarray(pts, dtype=float).reshape(-1, 2)
        pts.setflags(write=False)
        out.append(Shape(body=b, name=s.name, points=pts, radius=float(radius), closed=closed,
                         holes=holes, layer=tuple(s.layer), source=(cm.spec.file, s.line)))
    problems.raise_if_any()
    return tuple(out)


PROFILE_POINTS = 360      # a cam's working surface: a polygon through this many of its points


def _profile(cm, s, b):
    """(points, radius, closed) internal units of the part of joint s.points[0] on body b: a
    gear's or disc's pitch circle, a pinion's, a cam's working surface (a polygon through
    PROFILE_POINTS points of the exact profile, over the law's range: closed for a full turn),
    a follower's roller (a point for a knife edge); or the reason there is none (text)."""
    from ..elements.base import pivots
    name = s.points[0]
    idx = next(k for k, el in enumerate(cm.spec.elements)
               if el.role == "joint" and el.name == name)
    row = int(np.nonzero(cm.row_element == idx)[0][0])
    for G in cm.groups:
        hit = np.nonzero(G.rows[:, 0] == row)[0]
        if len(hit) and cm.spec.elements[idx].kind == G.kind.name:
            k = int(hit[0])
            break
    kind, par = G.kind.name, {n: v[k] for n, v in G.params.items()}
    bi = int(G.bodies[k, 0])
    mine = "i" if b == bi else "j"
    if kind in ("roll-disc", "gear-mesh", "gear"):
        r = float(par["r" + mine])
        if r < 0:
            return (f"'{s.body}' is the internal (ring) gear of joint '{name}': its pitch "
                    f"circle is a ring, not a disc; give its outline as a polyline")
        if kind == "gear":
            c = pivots(cm.groups).get((b, int(G.bodies[k, 2])))
            if c is None:
                return (f"gear '{s.body}' of joint '{name}' turns on no revolute joint to its "
                        f"carrier, so its centre is not known; give a circle")
        else:
            c = par["s" + mine]
        return np.array([c], dtype=float), abs(r), True
    if kind == "rack-pinion":
        if mine == "i":
            return (f"'{s.body}' is the rack of joint '{name}': its profile is a line; give a "
                    f"polyline along its pitch line")
        return np.array([par["sj"]], dtype=float), float(par["r"]), True
    if mine == "j":                              # a cam's follower: its roller, or its tip
        return np.array([par["sj"]], dtype=float), float(par["roller"]), True
    from ..elements.cam import profile
    lo, hi = (float(x) for x in par["range"])
    full = not (np.isfinite(lo) and np.isfinite(hi)) or hi - lo >= 2 * np.pi * (1 - 1e-12)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        lo, hi = 0.0, 2 * np.pi
    th = np.linspace(lo, hi, PROFILE_POINTS + (0 if full else 1), endpoint=not full)
    P = profile(kind, par, th)
    c = pivots(cm.groups).get((bi, int(G.bodies[k, 2])), np.zeros(2))
    pts = np.stack([P["surface_x"], P["surface_y"]], axis=1) + c
    return pts, 0.0, full


def _plate_pins(cm, s, b, pins) -> list:
    if not s.pins:
        return [p for _, p, _ in pins.get(b, [])]
    out = []
    for name in s.pins:
        if name in cm.point_names:
            k = cm.point_names.index(name)
            if int(cm.point_body[k]) == b:
                out.append(tuple(cm.point_s[k]))
                continue
        # a sketch pin carried by this link but reported on its first carrier: its joint
        out += [p for n, p, _ in pins.get(b, []) if n == name or (n or "").startswith(name + "-")]
    return out


def _unique(P) -> list:
    seen: list = []
    for p in P:
        if not any(np.allclose(p, q, rtol=0, atol=1e-12) for q in seen):
            seen.append(p)
    return seen


def _contains(shape: Shape, s) -> bool:
    """Whether body-frame point s (internal units) lies in the shape (on its outline counts)."""
    from .geometry import Motion, separation
    one = core([s], 0.0, True)
    z = np.zeros((1, 2))
    M = Motion(z, np.zeros(1))
    return bool(separation(core(shape.points, shape.radius, shape.closed), M, one, M).d[0]
                <= 1e-9)


def pairs(cm) -> list[Pair]:
    """The pairs of cm.shapes that can touch (see the module's text), in shape order."""
    spec = cm.spec.clearance
    shapes = cm.shapes
    if spec is None or len(shapes) < 2:
        return []
    at = {s.name: k for k, s in enumerate(shapes)}
    named = {frozenset(p.shapes): p for p in spec.pairs}
    ignored = {frozenset(p) for p in spec.ignore}
    joints = _joints(cm)
    out = []
    for i in range(len(shapes)):
        for j in range(i + 1, len(shapes)):
            A, B = shapes[i], shapes[j]
            key = frozenset((A.name, B.name))
            p = named.get(key)
            if p is None:
                if A.body == B.body or key in ignored:
                    continue
                if A.layer[0] > B.layer[1] or B.layer[0] > A.layer[1]:
                    continue
                if _joined(cm, A, B, joints.get(frozenset((A.body, B.body)), [])):
                    continue
            limit = spec.min if p is None or p.min is None else p.min
            out.append(Pair(at[A.name], at[B.name], f"{A.name}|{B.name}", float(limit),
                            p.line if p is not None else spec.line))
    return out


def _joints(cm) -> dict:
    """frozenset of two body indices -> [(kind, {body: pin location} or None)]: every pin two
    bodies share (a revolute between them, or a pin carried by three links or more, which
    joins each to the first: two revolutes at one point of a body make one pin), and every
    other joint between them."""
    out: dict = {}
    parent: dict = {}

    def node(b, s):
        return (b, round(float(s[0]), 9), round(float(s[1]), 9))

    def find(x):
        while parent.setdefault(x, x) != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x
    for G in cm.groups:
        if G.kind.name == "revolute":
            for k in range(len(G)):
                bi, bj = (int(x) for x in G.bodies[k, :2])
                a, b = node(bi, G.params["si"][k]), node(bj, G.params["sj"][k])
                parent[find(a)] = find(b)
            continue
        for k in range(len(G)):
            if cm.element_of_row(int(G.rows[k, 0])).role == "driver":
                continue        # a driver moves a body, it does not join two
            bs = sorted({int(x) for x in G.bodies[k]})
            for u in range(len(bs)):
                for w in range(u + 1, len(bs)):
                    out.setdefault(frozenset((bs[u], bs[w])), []).append((G.kind.name, None))
    pins: dict = {}
    for x in list(parent):
        pins.setdefault(find(x), []).append(x)
    for members in pins.values():
        for u in range(len(members)):
            for w in range(u + 1, len(members)):
                (b1, *s1), (b2, *s2) = members[u], members[w]
                if b1 != b2:
                    out.setdefault(frozenset((b1, b2)), []).append(
                        ("revolute", {b1: tuple(s1), b2: tuple(s2)}))
    return out


def _joined(cm, A: Shape, B: Shape, joints: list) -> bool:
    for kind, where in joints:
        if where is None:
            if _touching(cm, A, B):
                return True
        elif _contains(A, where[A.body]) and _contains(B, where[B.body]):
            return True
    return False


def _touching(cm, A: Shape, B: Shape) -> bool:
    """Whether A and B touch or overlap at the start pose (the file's estimate, internal
    units): a slider's block on its guide, a cam and its follower, gears in mesh."""
    from .geometry import Motion, separation

    def motion(b):
        if b == cm.nb:
            return Motion(np.zeros((1, 2)), np.zeros(1))
        return Motion(np.asarray(cm.q0[3 * b:3 * b + 2], dtype=float)[None, :],
                      np.array([float(cm.q0[3 * b + 2])]))
    d = separation(core(A.points, A.radius, A.closed), motion(A.body),
                   core(B.points, B.radius, B.closed), motion(B.body)).d[0]
    return bool(d <= 1e-6)
