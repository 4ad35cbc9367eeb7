"""The clearance keys of a model file: `shapes:`, `clearance:` and `limits:` (issue 29).

Called by planarkin.model.validate with its validator (typed readers, FILE:LINE messages naming
the shape), only when the file has one of these sections; returns a `ClearanceSpec` in the
file's units (lengths in its length unit, angles in its angle unit):

    shapes:                                  # a name per shape: a body's (or link's) name puts
      crank:   {plate: 12, layer: 0}         # it on that body; any other name takes body: NAME
      coupler: {plate: 10, hole: 4, layer: 1}
      rocker:  {polygon: [[0, -5], [60, -5], [60, 5], [0, 5]], radius: 1}
      slider:  {circle: 20, centre: [0, 0]}
      wall:    {body: ground, polyline: [[-50, 80], [150, 80]], layer: [0, 1]}
      cover:   {body: coupler, polygon: [...], frame: global}     # at the start pose
      cam:     {profile: lift}               # a cam's working surface, a gear's pitch circle
    clearance: {min: 2, on_contact: error, pairs: [{between: [crank, wall], min: 5}],
                ignore: [[coupler, rocker]]}
    limits: {A: [-30, 60], piston: [0, 120]}     # a joint's travel: angle or stroke range

plate: W is a plate of width W around the body's pins (its revolute joints, or `pins:
[P, Q]`): a capsule for two pins, the convex hull of the rounded pins for more, a disc for one.
profile: JOINT takes the part's outline from a named cam, gear, rack-pinion or rolling-disc
joint on the body (planarkin.clearance.build._profile). Lengths are numbers in the file's
length unit, as every other length of the file.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..diagnostics import did_you_mean

OUTLINES = ("plate", "circle", "polygon", "polyline", "profile")
# the joints whose parts planarkin draws from their own data (profile: JOINT)
PROFILED = ("cam", "cam-rocker", "gear", "gear-mesh", "roll-disc", "rack-pinion")
SHAPE_KEYS = ("body",) + OUTLINES + ("pins", "hole", "radius", "centre", "layer", "frame")
CLEARANCE_KEYS = ("min", "on_contact", "pairs", "ignore")
PAIR_KEYS = ("between", "min")
ON_CONTACT = ("warning", "error")
FRAMES = ("body", "global")
SECTIONS = ("shapes", "clearance", "limits")


@dataclass(frozen=True)
class ShapeSpec:
    """One shape, user units. outline: one of OUTLINES; points: the polygon's or polyline's
    points (or the circle's centre, one point; for a profile the joint's name) in the body frame
    (frame 'body') or global at the start pose ('global'); size: the plate's width or the circle's diameter (0 else);
    radius: the rounding of a polygon or polyline; pins: point names (plate; () the body's
    revolute joints); hole: the plate's pin hole diameter (0: none); layer: (lo, hi)."""

    name: str
    body: str
    outline: str
    line: int
    points: tuple = ()
    size: float = 0.0
    radius: float = 0.0
    pins: tuple = ()
    hole: float = 0.0
    layer: tuple = (0.0, 0.0)
    frame: str = "body"


@dataclass(frozen=True)
class PairSpec:
    """A pair named in clearance: pairs: (shape names), its own limit (None: the model's)."""

    shapes: tuple
    min: float | None
    line: int


@dataclass(frozen=True)
class LimitSpec:
    """A joint's travel range (user angle or length unit) from limits:."""

    joint: str
    kind: str            # the joint's kind: revolute (an angle) or translational (a stroke)
    lo: float
    hi: float
    line: int


@dataclass(frozen=True)
class ClearanceSpec:
    """shapes, the smallest clearance allowed (min, length unit), what a contact is
    (on_contact: warning or error), named pairs, ignored pairs, joint limits."""

    shapes: tuple = ()
    min: float = 0.0
    on_contact: str = "warning"
    pairs: tuple = ()
    ignore: tuple = ()
    limits: tuple = ()
    line: int = 0


def wanted(root) -> bool:
    """Whether a file's root mapping has a section of this room (else it is not imported)."""
    return root.kind == "map" and any(k in root.value for k in SECTIONS)


def read_clearance(V, root, points, joints: dict) -> ClearanceSpec | None:
    """ClearanceSpec from the model's root mapping (V: the model validator; points: the
    PointSpecs; joints: joint name -> ElementSpec), or None without these sections."""
    v = root.value
    if not any(k in v for k in SECTIONS):
        return None
    V.named_joints = tuple(joints.values())
    shapes = _shapes(V, v.get("shapes"), points)
    names = {s.name: s for s in shapes}
    out = dict(shapes=tuple(shapes), limits=tuple(_limits(V, v.get("limits"), joints)),
               line=(root.key_lines or {}).get("clearance", 0))
    node = v.get("clearance")
    if node is not None and V.keys(node, CLEARANCE_KEYS, "clearance"):
        c = node.value
        if "min" in c:
            x = _length(V, c["min"], "clearance: min", zero=True)
            if x is not None:
                out["min"] = x
        if "on_contact" in c:
            out["on_contact"] = V.choice(c["on_contact"], "clearance: on_contact",
                                         ON_CONTACT) or "warning"
        sn = v.get("shapes")
        declared = list(sn.value) if sn is not None and sn.kind == "map" else []
        if "pairs" in c:
            out["pairs"] = tuple(_pairs(V, c["pairs"], names, declared))
        if "ignore" in c:
            out["ignore"] = tuple(_ignore(V, c["ignore"], names, declared))
    return ClearanceSpec(**out)


def _length(V, node, what: str, zero: bool = False):
    """A length > 0 (>= 0 with zero), or None (reported)."""
    x = V.number(node, what)
    if x is None:
        return None
    if x < 0 or (x == 0 and not zero):
        V.err(node, f"{what} must be a length {'>= 0' if zero else '> 0'}, not {x:g}")
        return None
    return x


def _shapes(V, node, points) -> list[ShapeSpec]:
    out: list[ShapeSpec] = []
    if node is None:
        return out
    if node.kind != "map":
        V.err(node, "shapes must be a mapping of shape names to e.g. {plate: 12} (on the body "
                    "of that name) or {body: ground, polyline: [[x, y], ...]}")
        return out
    for key, val in node.value.items():
        line = node.key_lines[key]
        if not V.identifier(key, line, "shape"):
            continue
        spec = _shape(V, key, val, line, points)
        if spec is not None:
            out.append(spec)
    return out


def _shape(V, key: str, val, line: int, points) -> ShapeSpec | None:
    what = f"shape '{key}'"
    if val.kind != "map":
        V.err(val, f"{what} must be a mapping like {{plate: 12}} or {{circle: 20}} "
                   f"({', '.join(OUTLINES)})")
        return None
    if not V.keys(val, SHAPE_KEYS, what):
        return None
    v = val.value
    if "body" in v:
        body = V.body_ref(v["body"], f"{what}: body")
        if body is None:
            return None
    elif key in V.body_set:
        body = key
    else:
        hint = did_you_mean(key, V.body_names)
        V.err(line, f"{what}: unknown body '{key}'{hint or ''}; a shape is named after the "
                    f"body (or link) it is on, or says which with body: NAME (ground for a "
                    f"frame obstacle)")
        return None
    kinds = [k for k in OUTLINES if k in v]
    if len(kinds) != 1:
        V.err(val, f"{what}: give exactly one of {', '.join(OUTLINES)}"
                   + (f" (found {' and '.join(kinds)})" if kinds else ""))
        return None
    outline = kinds[0]
    fields: dict = dict(name=key, body=body, outline=outline, line=line)
    if outline == "profile":
        fields["points"] = (_profile_ref(V, v["profile"], what, body),)
        ok = fields["points"][0] is not None
    ok = fields.get("points", (True,))[0] is not None
    for k, only in (("pins", ("plate",)), ("hole", ("plate",)), ("radius", ("polygon", "polyline")),
                    ("centre", ("circle",)), ("frame", ("circle", "polygon", "polyline"))):
        if k in v and outline not in only:
            V.err(v[k], f"{what}: {k} is used with {' or '.join(only)}, not with {outline}")
            ok = False
    if outline == "plate":
        if body == "ground":
            V.err(v["plate"], f"{what}: ground carries no plate; give its outline as a polygon "
                              f"or polyline")
            return None
        w = _length(V, v["plate"], f"{what}: plate (the plate's width)")
        ok &= w is not None
        fields["size"] = w or 0.0
        if "hole" in v:
            h = _length(V, v["hole"], f"{what}: hole (the pin holes' diameter)")
            if h is not None and w is not None and h >= w:
                V.err(v["hole"], f"{what}: hole {h:g} must be smaller than the plate's width "
                                 f"{w:g}")
                h = None
            ok &= h is not None
            fields["hole"] = h or 0.0
        if "pins" in v:
            pins = _pins(V, v["pins"], what, body, points)
            ok &= pins is not None
            fields["pins"] = pins or ()
    elif outline == "profile":
        pass
    elif outline == "circle":
        dia = _length(V, v["circle"], f"{what}: circle (its diameter)")
        ok &= dia is not None
        fields["size"] = dia or 0.0
        c = V.vector(v["centre"], f"{what}: centre") if "centre" in v else (0.0, 0.0)
        ok &= c is not None
        fields["points"] = (c,)
    else:
        pts = _outline_points(V, v[outline], what, outline)
        ok &= pts is not None
        fields["points"] = pts or ()
        if "radius" in v:
            r = _length(V, v["radius"], f"{what}: radius", zero=True)
            ok &= r is not None
            fields["radius"] = r or 0.0
    if "frame" in v:
        f = V.choice(v["frame"], f"{what}: frame", FRAMES)
        sketch = getattr(V, "sketch", None)
        if f == "global" and sketch is not None and body in sketch.shaped:
            # as a point's at: on such a link (planarkin.model.sketch.check_placements)
            V.err(v["frame"], f"{what}: frame: global is read against the sketched pose of link "
                              f"'{body}', which has given lengths and is only rough; give the "
                              f"outline in the link's frame (origin at its first point, x axis "
                              f"towards the second)")
            f = None
        ok &= f is not None
        fields["frame"] = f or "body"
    if "layer" in v:
        layer = _layer(V, v["layer"], what)
        ok &= layer is not None
        fields["layer"] = layer
    return ShapeSpec(**fields) if ok else None


def _profile_ref(V, node, what: str, body: str):
    """The joint named by profile: (a cam, gear, rack-pinion or rolling disc joint on body), or
    None (reported)."""
    name = V.text(node, f"{what}: profile")
    if name is None:
        return None
    joints = {el.name: el for el in getattr(V, "named_joints", ()) if el.name}
    el = joints.get(name)
    usable = [n for n, e in joints.items() if e.kind in PROFILED]
    if el is None or el.kind not in PROFILED:
        hint = did_you_mean(name, usable) or \
            f" (cam, gear, rack-pinion and rolling-disc joints: {', '.join(usable) or 'none named'})"
        V.err(node, f"{what}: profile: '{name}' is not a named cam, gear, rack-pinion or "
                    f"rolling-disc joint{hint if el is None else ''}"
                    + (f" (it is a {el.kind} joint)" if el is not None else ""))
        return None
    if body not in el.bodies[:2]:
        V.err(node, f"{what}: profile: joint '{name}' joins {el.bodies[0]} and {el.bodies[1]}, "
                    f"not '{body}'")
        return None
    return name


def _pins(V, node, what: str, body: str, points):
    if node.kind != "seq" or len(node.value) < 1:
        V.err(node, f"{what}: pins must be a list of point names on '{body}', e.g. [A, B]")
        return None
    sketch = getattr(V, "sketch", None)
    carried = {name for name, c in (sketch.carriers.items() if sketch is not None else ())
               if body in c}
    on = list(dict.fromkeys([p.name for p in points if p.body == body] + sorted(carried)))
    out = []
    for item in node.value:
        s = V.text(item, f"{what}: pins")
        if s is None:
            return None
        if s not in on:
            hint = did_you_mean(s, on) or f" (points on '{body}': {', '.join(on) or 'none'})"
            V.err(item, f"{what}: pins: '{s}' is not a point on '{body}'{hint}")
            return None
        out.append(s)
    return tuple(out)


def _outline_points(V, node, what: str, outline: str):
    need = 3 if outline == "polygon" else 2
    if node.kind != "seq" or len(node.value) < need:
        V.err(node, f"{what}: {outline} must be a list of at least {need} points [[x, y], ...]")
        return None
    pts = [V.vector(item, f"{what}: {outline}") for item in node.value]
    if any(p is None for p in pts):
        return None
    closed = outline == "polygon"
    for k in range(len(pts) if closed else len(pts) - 1):
        if pts[k] == pts[(k + 1) % len(pts)]:
            V.err(node.value[(k + 1) % len(pts)], f"{what}: {outline} point {k + 2 if k + 1 < len(pts) else 1} "
                  f"repeats the one before it")
            return None
    if closed:
        from .geometry import self_crossing
        crossing = self_crossing(pts)
        if crossing is not None:
            i, j = crossing
            V.err(node, f"{what}: the polygon crosses itself (its edges {i + 1} and {j + 1} "
                        f"meet): list its points in order around the outline")
            return None
    return tuple(pts)


def _layer(V, node, what: str):
    if node.kind == "seq":
        if len(node.value) != 2:
            V.err(node, f"{what}: layer must be a level z or a range [lo, hi]")
            return None
        lo, hi = (V.number(n, f"{what}: layer") for n in node.value)
        if lo is None or hi is None:
            return None
        if lo > hi:
            V.err(node, f"{what}: the layer range [{lo:g}, {hi:g}] is reversed; write "
                        f"[{hi:g}, {lo:g}]")
            return None
        return (lo, hi)
    z = V.number(node, f"{what}: layer")
    return None if z is None else (z, z)


def _shape_ref(V, node, names: dict, declared, what: str):
    s = V.text(node, what)
    if s is None:
        return None
    if s not in names:
        if s not in declared:
            hint = did_you_mean(s, declared) or f" (shapes: {', '.join(declared) or 'none'})"
            V.err(node, f"{what}: unknown shape '{s}'{hint}")
        return None
    return s


def _two(V, node, names, declared, what: str):
    if node.kind != "seq" or len(node.value) != 2:
        V.err(node, f"{what} must be two shape names [A, B]")
        return None
    ab = [_shape_ref(V, n, names, declared, what) for n in node.value]
    if None in ab:
        return None
    if ab[0] == ab[1]:
        V.err(node, f"{what}: a shape is never checked against itself ('{ab[0]}' twice)")
        return None
    if names[ab[0]].body == names[ab[1]].body:
        V.err(node, f"{what}: '{ab[0]}' and '{ab[1]}' are on the same body "
                    f"'{names[ab[0]].body}': their distance cannot change")
        return None
    return tuple(ab)


def _pairs(V, node, names, declared):
    out = []
    if node.kind != "seq":
        V.err(node, "clearance: pairs must be a list of {between: [A, B], min: D}")
        return out
    for item in node.value:
        what = "clearance: pairs"
        if item.kind != "map" or not V.keys(item, PAIR_KEYS, what):
            if item.kind != "map":
                V.err(item, f"{what}: each entry is {{between: [A, B], min: D}}")
            continue
        if "between" not in item.value:
            V.err(item, f"{what}: missing between: [A, B] (two shape names)")
            continue
        ab = _two(V, item.value["between"], names, declared, f"{what}: between")
        m = _length(V, item.value["min"], f"{what}: min", zero=True) \
            if "min" in item.value else None
        if ab is None or ("min" in item.value and m is None):
            continue
        la, lb = names[ab[0]].layer, names[ab[1]].layer
        if la[0] > lb[1] or lb[0] > la[1]:
            V.err(item, f"{what}: '{ab[0]}' (layer {_shown(la)}) and '{ab[1]}' (layer "
                        f"{_shown(lb)}) are in different layers and cannot touch; put them in "
                        f"one layer or drop the pair")
            continue
        out.append(PairSpec(ab, m, item.line))
    return out


def _shown(layer) -> str:
    return f"{layer[0]:g}" if layer[0] == layer[1] else f"[{layer[0]:g}, {layer[1]:g}]"


def _ignore(V, node, names, declared):
    out = []
    if node.kind != "seq":
        V.err(node, "clearance: ignore must be a list of shape pairs [[A, B], ...]")
        return out
    for item in node.value:
        ab = _two(V, item, names, declared, "clearance: ignore")
        if ab is not None:
            out.append(ab)
    return out


def _limits(V, node, joints: dict) -> list[LimitSpec]:
    out: list[LimitSpec] = []
    if node is None:
        return out
    if node.kind != "map":
        V.err(node, "limits must map joint names to their travel ranges, e.g. A: [-30, 60]")
        return out
    usable = [n for n, el in joints.items() if el.kind in ("revolute", "translational")]
    for key, val in node.value.items():
        line = node.key_lines[key]
        what = f"limits: {key}"
        el = joints.get(key)
        if el is None:
            hint = did_you_mean(key, usable) or \
                f" (revolute and translational joints: {', '.join(usable) or 'none named'})"
            V.err(line, f"{what}: unknown joint '{key}'{hint}")
            continue
        if el.kind not in ("revolute", "translational"):
            V.err(line, f"{what}: '{key}' is a {el.kind} joint; travel limits are for revolute "
                        f"(an angle range) and translational joints (a stroke range)")
            continue
        rng = val.value.get("range") if val.kind == "map" and set(val.value) == {"range"} \
            else val
        if rng is None or rng.kind != "seq" or len(rng.value) != 2:
            V.err(val, f"{what} must be a range [lo, hi] ({_unit(V, el)})")
            continue
        lo, hi = (V.number(n, what) for n in rng.value)
        if lo is None or hi is None:
            continue
        if lo >= hi:
            V.err(rng, f"{what}: the range [{lo:g}, {hi:g}] is {'empty' if lo == hi else 'reversed'}"
                       f"; write [lo, hi] with lo < hi")
            continue
        out.append(LimitSpec(key, el.kind, lo, hi, line))
    return out


def _unit(V, el) -> str:
    return (f"the relative angle phi_j - phi_i, {getattr(V, 'angle_unit', 'rad')}"
            if el.kind == "revolute" else "the slide's displacement, length unit")

