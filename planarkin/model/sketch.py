"""The sketch form of a model: named pins at global coordinates, links listing the pins they carry.

A linkage is drawn on paper as pins and the links between them; this module turns that drawing
into the body/joint form the rest of planarkin reads (frozen specs, user units):

- ``points: {O: {at: [0, 0], ground: true}, A: {at: [x, y]}, ...}`` (or a top-level
  ``ground: [O, C]`` list) names the pins at the assembly pose;
- ``links: {crank: [O, A], coupler: [A, B, E]}``: each link becomes a body whose frame sits at its
  first pin with the x axis towards its second (angle 0 for a one-pin link), so the sketch is the
  exact pose at t = start; a pin listed by k carriers (ground counts) becomes k - 1 revolute joints
  between its first carrier and each other one, all named after the pin;
- ``sliders: {NAME: {link: L, on: G, along: [P, Q]}}``: a translational joint, L sliding on G
  (default ground) parallel to the line P-Q; ``slots: {NAME: {link: L, pin: C, along: [P, Q]}}``:
  pin C (carried by another link) runs in a slot of L along the line P-Q, which passes through C;
- drivers may name ``link:`` instead of ``body:``, and a distance driver ``between: [C, D]``;
- ``lengths: {A-B: 0.12, B-E: 0.05}``: link lengths given separately from a rough sketch. A link
  with a given length takes its shape from the lengths (its second pin at the given distance
  along its x axis, each further pin by its distances to the first two, given or as sketched,
  on the sketched side); the sketch then only seeds the assembly, which moves the pins to the
  consistent pose the sketch is nearest to (the branch it draws) and warns per moved pin.

Every sketch pin is reported in points.csv once, on its first carrier (ground pins on ground).
The validator (`planarkin.model.validate`) calls `Sketch` with its typed readers, so every
problem is a FILE:LINE diagnostic naming the point or the link.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..diagnostics import did_you_mean
from .spec import BodySpec, ElementSpec, PointSpec


@dataclass(frozen=True)
class Pin:
    """A named sketch point: global position at the assembly pose (user length unit)."""

    name: str
    at: tuple[float, float]
    ground: bool
    line: int


class Sketch:
    """Reads the sketch sections of one file through the validator `v` (its readers and its
    Collector). Steps, called by the validator in this order: `__init__` (pins, ground list),
    `register_links` (link names become body names, before joints are read), `bodies`,
    `joints`, `points`."""

    def __init__(self, v, top: dict):
        self.v = v
        self.pins: dict[str, Pin] = {}
        self.links: dict[str, tuple[str, ...]] = {}
        self.link_lines: dict[str, int] = {}
        self.carriers: dict[str, list[str]] = {}     # pin -> ['ground'?, link, ...] in order
        self.poses: dict[str, tuple[float, float, float]] = {}   # link -> x, y, phi (radians)
        self.line_refs: set[str] = set()              # pins used only to define a slide line
        self.mentioned: set[str] = set()              # pins listed by any link, broken or not
        self.shaped: dict[str, dict[str, tuple[float, float]]] = {}   # link -> pin -> local,
        #                                                 for links with a given length
        self.top = top
        ground_list = self._ground_list(top.get("ground"))
        node = top.get("points")
        if node is not None and node.kind == "map":
            for key, val in node.value.items():
                if val.kind != "map" or "body" in val.value or "at" not in val.value:
                    continue
                if not v.identifier(key, node.key_lines[key], "point"):
                    continue
                at = v.vector(val.value["at"], f"point '{key}': at")
                g = False
                if "ground" in val.value:
                    gn = val.value["ground"]
                    if gn.kind == "scalar" and isinstance(gn.value, bool):
                        g = gn.value
                    else:
                        v.err(gn, f"point '{key}': ground must be true or false, not "
                                  f"{_type(gn)}")
                if at is not None:
                    self.pins[key] = Pin(key, at, g or key in ground_list, val.line)
        for name, line in ground_list.items():
            if name not in self.pins:
                v.err(line, f"ground: unknown point '{name}'{did_you_mean(name, self.pins)}"
                            + ("" if self.pins else " (name it under points: with at: [x, y])"))

    @property
    def active(self) -> bool:
        return bool(self.pins) or "links" in self.top

    def _ground_list(self, node) -> dict[str, int]:
        if node is None:
            return {}
        if node.kind != "seq":
            self.v.err(node, f"ground must be a list of point names, e.g. ground: [O, C], not "
                             f"{_type(node)}")
            return {}
        out = {}
        for item in node.value:
            s = self.v.text(item, "ground")
            if s is not None:
                out[s] = item.line
        return out

    # -- links ---------------------------------------------------------------------------------
    def register_links(self) -> None:
        self._read_links()
        for name, pin in self.pins.items():
            c = (["ground"] if pin.ground else []) + [k for k, pts in self.links.items()
                                                      if name in pts]
            self.carriers[name] = c
        self._read_lengths()

    def _pair(self, key: str) -> tuple[str, str] | None:
        """`A-B` -> (A, B); names may contain '-', so every split into two known pins is
        tried."""
        splits = {(key[:k].strip(), key[k + 1:].strip()) for k, ch in enumerate(key) if ch == "-"}
        found = [ab for ab in splits if ab[0] in self.pins and ab[1] in self.pins]
        return found[0] if len(found) == 1 else None

    def _read_lengths(self) -> None:
        """The `lengths:` block: given distances between two pins of one link (user length
        unit), turned into the body-frame coordinates of every link they concern."""
        v = self.v
        node = self.top.get("lengths")
        if node is None:
            return
        if node.kind != "map":
            v.err(node, f"lengths must be a mapping of point pairs to lengths, e.g. "
                        f"lengths: {{A-B: 0.12}}, not {_type(node)}")
            return
        given: dict[str, dict[frozenset, tuple[float, int, str]]] = {}
        seen: dict[frozenset, tuple[str, int]] = {}
        for key, val in node.value.items():
            line = node.key_lines[key]
            what = f"lengths: {key}"
            ab = self._pair(str(key))
            if ab is None:
                v.err(line, f"{what}: name two points as A-B (points: "
                            f"{', '.join(list(self.pins)[:8])}{', ...' if len(self.pins) > 8 else ''})")
                continue
            a, b = ab
            if a == b:
                v.err(line, f"{what}: the two points are the same")
                continue
            if frozenset(ab) in seen:     # B-C and C-B: one distance, given twice
                k0, l0 = seen[frozenset(ab)]
                v.err(line, f"{what}: the distance of {a} and {b} is already given as {k0} "
                            f"(line {l0}); give each pair once")
                continue
            seen[frozenset(ab)] = (str(key), line)
            x = v.number(val, what)
            if x is None:
                continue
            if not x > 0:
                v.err(val, f"{what} must be a positive length, not {x:g}")
                continue
            links = [k for k, pts in self.links.items() if a in pts and b in pts]
            if not links:
                both_ground = self.pins[a].ground and self.pins[b].ground
                v.err(line, f"{what}: no link carries both {a} and {b}" +
                      (" (ground points stay where they are drawn)" if both_ground else
                       "; a length belongs to two points of one link"))
                continue
            for k in links:
                pts = self.links[k]
                i, j = sorted((pts.index(a), pts.index(b)))
                if i >= 2:
                    v.err(line, f"{what}: link '{k}' places {pts[i]} and {pts[j]} by their "
                                f"distances to its first two points {pts[0]} and {pts[1]}; give "
                                f"those ({pts[0]}-{pts[j]}, {pts[1]}-{pts[j]})")
                    continue
                given.setdefault(k, {})[frozenset((a, b))] = (x, line, key)
        for k, g in given.items():
            shape = self._shape(k, g)
            if shape is not None:
                self.shaped[k] = shape

    def _shape(self, link: str, given: dict) -> dict | None:
        """Body-frame coordinates of the pins of `link` from its given lengths (user length
        unit); the distances not given are taken from the sketch."""
        pts = self.links[link]
        at = {p: self.pins[p].at for p in pts}

        def length(a, b):
            g = given.get(frozenset((a, b)))
            return g[0] if g is not None else math.dist(at[a], at[b])

        p0 = pts[0]
        out = {p0: (0.0, 0.0)}
        if len(pts) == 1:
            return out
        p1 = pts[1]
        l01 = length(p0, p1)
        out[p1] = (l01, 0.0)
        ux, uy = at[p1][0] - at[p0][0], at[p1][1] - at[p0][1]
        ulen = math.hypot(ux, uy)
        for p in pts[2:]:
            g0, g1 = frozenset((p0, p)) in given, frozenset((p1, p)) in given
            # the sketched pin along the line p0 -> p1 (s: 0 at p0, 1 at p1) and off it
            dx, dy = at[p][0] - at[p0][0], at[p][1] - at[p0][1]
            s = (ux * dx + uy * dy) / (ulen * ulen) if ulen else 0.0
            off = (ux * dy - uy * dx) / ulen if ulen else 0.0
            drawn_on = abs(off) <= 1e-9 * max(ulen, math.hypot(dx, dy))
            if not g0 and not g1:
                x, y = self._sketched_local(p, link)
                out[p] = (x, 0.0 if drawn_on else y)
                continue
            if drawn_on and not (g0 and g1):
                # a pin drawn on the link's line stays on it: placed along the x axis by the
                # distance given, on the side where it is drawn (before p0, between, beyond p1)
                out[p] = ((length(p0, p) if s >= 0 else -length(p0, p)) if g0 else
                          l01 + length(p1, p) if s > 1 else l01 - length(p1, p), 0.0)
                continue
            l0p, l1p = length(p0, p), length(p1, p)
            along = self._collinear(l01, l0p, l1p)
            if along is not None:           # three lengths in line to rounding: exactly on it
                out[p] = (along, 0.0)
                continue
            # law of cosines in the link's frame: p0 at the origin, p1 at (l01, 0)
            x = (l01 * l01 + l0p * l0p - l1p * l1p) / (2 * l01)
            y2 = l0p * l0p - x * x
            if y2 < -1e-12 * l0p * l0p:
                names = [f"{a}-{b} {length(a, b):.6g}" +
                         ("" if frozenset((a, b)) in given else " (as sketched)")
                         for a, b in ((p0, p1), (p0, p), (p1, p))]
                line = min(g[1] for g in given.values())
                self.v.err(line, f"link '{link}': the lengths {', '.join(names)} cannot form "
                                 f"a triangle (each side must be at most the sum of the other "
                                 f"two)" + self._line_hint(link, p, s, off, g0, g1, l01, l0p,
                                                           l1p))
                return None
            cross = ux * (at[p][1] - at[p0][1]) - uy * (at[p][0] - at[p0][0])
            y = math.sqrt(max(y2, 0.0))
            out[p] = (x, y if cross >= 0 else -y)
        return out

    @staticmethod
    def _collinear(l01: float, l0p: float, l1p: float) -> float | None:
        """The x of a pin whose distances l0p, l1p to the link's first two pins (l01 apart) put
        it on their line to rounding (a degenerate triangle: one side the sum of the other two
        within 8 units in the last place), else None: the law of cosines would place it up to
        sqrt(rounding) off the line (13 nm on a 0.1 m link)."""
        tol = 8 * 2.0 ** -52 * (l01 + l0p + l1p)
        if abs(l01 + l1p - l0p) <= tol:
            return l0p                       # beyond p1
        if abs(l0p + l1p - l01) <= tol:
            return l0p                       # between p0 and p1
        if abs(l01 + l0p - l1p) <= tol:
            return -l0p                      # before p0
        return None

    def _line_hint(self, link, p, s, off, g0, g1, l01, l0p, l1p) -> str:
        """What to write when a pin's lengths cannot form a triangle: for the pin on the line
        of the link's first two pins (on the side where it is drawn), the missing distance that
        puts it there."""
        pts = self.links[link]
        a, b = pts[0], pts[1]
        side = "before " + a if s < 0 else "between " + a + " and " + b if s <= 1 else \
            "beyond " + b
        if g0 != g1:
            known = l0p if g0 else l1p
            key = f"{b}-{p}" if g0 else f"{a}-{p}"
            lo, hi = abs(l01 - known), l01 + known
            end = (hi if s < 0 else lo) if g0 else (hi if s > 1 else lo)
            return (f"; give {key} in lengths: (from {lo:.12g} to {hi:.12g}: {end:.12g} puts {p} "
                    f"on the line {a}-{b}, {side}, where it is drawn {abs(off):.3g} off the "
                    f"line)")
        return (f"; for {p} on the line {a}-{b} ({side}), one of {a}-{p}, {b}-{p} is the sum "
                f"or difference of the other and {a}-{b}")

    def _read_links(self) -> None:
        v = self.v
        node = self.top.get("links")
        if node is None:
            return
        if node.kind != "map":
            v.err(node, f"links must be a mapping of link names to lists of points, e.g. "
                        f"crank: [O, A], not {_type(node)}")
            return
        for key, val in node.value.items():
            line = node.key_lines[key]
            what = f"link '{key}'"
            if val.kind == "seq":       # whatever else is wrong, these pins are not orphans
                self.mentioned.update(str(n.value) for n in val.value if n.kind == "scalar")
            if key == "ground":
                v.err(line, "link 'ground' is implicit: mark its points with ground: true (or "
                            "list them in ground: [...])")
                continue
            if not v.identifier(key, line, "link"):
                continue
            if key in v.body_set:
                v.err(line, f"{what}: the name is already used by a body; rename the link or "
                            f"the body")
                continue
            if val.kind != "seq" or not val.value:
                v.err(val, f"{what} must be a list of the points it carries, e.g. [A, B], not "
                           f"{_type(val)}")
                continue
            # a broken link still names a body and carries its known points, so that its errors
            # do not cascade into "unknown body" or "no link carries it"
            v.body_names.append(key)
            v.body_set.add(key)
            names, ok = [], True
            for item in val.value:
                s = v.text(item, what)
                if s is None:
                    ok = False
                elif s not in self.pins:
                    body_point = _is_body_point(self.top.get("points"), s)
                    hint = (" (it is a body point; a link carries sketch points: {at: [x, y]} "
                            "without body)") if body_point else \
                        (did_you_mean(s, self.pins) or
                         " (name it under points: with at: [x, y])")
                    v.err(item, f"{what}: unknown point '{s}'{hint}")
                    ok = False
                elif s in names:
                    v.err(item, f"{what}: lists point '{s}' twice")
                    ok = False
                else:
                    names.append(s)
            self.mentioned.update(names)
            if not ok:
                continue
            pa = self.pins[names[0]].at
            if len(names) >= 2:
                pb = self.pins[names[1]].at
                if pa == pb:
                    v.err(val, f"{what}: its first two points {names[0]} and {names[1]} coincide; "
                               f"the link's frame runs from its first point to its second")
                    continue
                phi = math.atan2(pb[1] - pa[1], pb[0] - pa[0])
            else:
                phi = 0.0
            self.links[key] = tuple(names)
            self.link_lines[key] = val.line
            self.poses[key] = (pa[0], pa[1], phi)

    def bodies(self, angle_unit: str) -> list[BodySpec]:
        k = 180.0 / math.pi if angle_unit == "deg" else 1.0
        return [BodySpec(name, (x, y, phi * k), self.link_lines[name])
                for name, (x, y, phi) in self.poses.items()]

    # -- joints --------------------------------------------------------------------------------
    def joints(self, first_index: int) -> list[ElementSpec]:
        """Revolutes at shared pins, then sliders and slots; numbered on from first_index."""
        out: list[ElementSpec] = []
        idx = first_index
        for name, pin in self.pins.items():
            c = self.carriers.get(name, [])
            for n, other in enumerate(c[1:], start=1):
                jname = name if n == 1 else f"{name}-{n}"
                if c[0] in self.shaped or other in self.shaped:
                    # a link shaped by its lengths: the joint's vectors come from the shape,
                    # not from the (rough) sketched position
                    params = {"si": self.local(name, c[0]), "sj": self.local(name, other)}
                    out.append(ElementSpec(role="joint", index=idx, kind="revolute",
                                           bodies=(c[0], other), params=params, line=pin.line,
                                           name=jname))
                else:
                    out.append(ElementSpec(role="joint", index=idx, kind="revolute",
                                           bodies=(c[0], other), params={}, line=pin.line,
                                           name=jname, at=pin.at))
                idx += 1
        for section in ("sliders", "slots"):
            node = self.top.get(section)
            if node is None:
                continue
            if node.kind != "map":
                self.v.err(node, f"{section} must be a mapping of names to "
                                 f"{{link: L, along: [P, Q]{', pin: C' if section == 'slots' else ''}}}"
                                 f", not {_type(node)}")
                continue
            for key, val in node.value.items():
                el = self._prismatic(section, key, val, node.key_lines[key], idx)
                if el is not None:
                    out.append(el)
                    idx += 1
        for name, pin in self.pins.items():
            if not self.carriers.get(name) and name not in self.line_refs | self.mentioned:
                self.v.err(pin.line, f"point '{name}': no link carries it; list it in a link "
                                     f"under links:, mark it ground: true, or give body: NAME")
        return out

    def _link_ref(self, node, what: str) -> str | None:
        s = self.v.text(node, what)
        if s is None:
            return None
        if s == "ground" or s in self.v.body_set:
            return s
        self.v.err(node, f"{what}: unknown link '{s}'"
                         f"{did_you_mean(s, self.v.body_names + ['ground'])}")
        return None

    def _pin_ref(self, node, what: str) -> str | None:
        s = self.v.text(node, what)
        if s is None:
            return None
        if s not in self.pins:
            self.v.err(node, f"{what}: unknown point '{s}'{did_you_mean(s, self.pins)}")
            return None
        return s

    def _prismatic(self, section: str, key: str, node, line: int, idx: int):
        v = self.v
        slot = section == "slots"
        what = f"{section[:-1]} '{key}'"
        allowed = ("link", "pin", "along") if slot else ("link", "on", "along")
        if not v.keys(node, allowed, what):
            return None
        val = node.value
        need = ("link", "pin", "along") if slot else ("link", "along")
        missing = [k for k in need if k not in val]
        if missing:
            v.err(node, f"{what}: missing {', '.join(missing)} "
                        f"({'link: the slotted link, pin: the point running in the slot, ' if slot else 'link: the sliding link, '}"
                        f"along: [P, Q] two points on the line)")
            return None
        link = self._link_ref(val["link"], f"{what}: link")
        on = self._link_ref(val["on"], f"{what}: on") if "on" in val else "ground"
        for b in (link, on):
            if b in self.shaped:
                v.err(node, f"{what}: link '{b}' has given lengths; a {section[:-1]} is placed "
                            f"by the sketch, so its links must be drawn exactly (give the "
                            f"lengths of other links only)")
                return None
        a = val["along"]
        if a.kind != "seq" or len(a.value) != 2:
            v.err(a, f"{what}: along must be two point names [P, Q] (the line)")
            return None
        p, q = (self._pin_ref(n, f"{what}: along") for n in a.value)
        if None in (link, on, p, q):
            return None
        pa, pb = self.pins[p].at, self.pins[q].at
        if pa == pb:
            v.err(a, f"{what}: the points {p} and {q} of along coincide; they must give a line")
            return None
        self.line_refs.update((p, q))
        axis = (pb[0] - pa[0], pb[1] - pa[1])
        if not slot:
            if link == on:
                v.err(node, f"{what}: link and on are both '{link}'; a slider joins two links")
                return None
            return ElementSpec(role="joint", index=idx, kind="translational", bodies=(on, link),
                               params={}, line=line, name=key, at=pa, axis=axis)
        pin = self._pin_ref(val["pin"], f"{what}: pin")
        if pin is None:
            return None
        carriers = [c for c in self.carriers.get(pin, []) if c != link]
        if not carriers:
            v.err(val["pin"], f"{what}: pin '{pin}' must be carried by a link other than "
                              f"'{link}' (the link that runs in the slot)")
            return None
        pc = self.pins[pin].at
        off = abs((pc[0] - pa[0]) * axis[1] - (pc[1] - pa[1]) * axis[0]) / math.hypot(*axis)
        scale = max(math.hypot(*pa), math.hypot(*pb), math.hypot(*pc), 1e-300)
        if off > 1e-9 * scale:
            v.err(val["pin"], f"{what}: pin '{pin}' is {off:.6g} off the line {p}-{q}; a slot's "
                              f"line passes through its pin at the assembly pose")
            return None
        return ElementSpec(role="joint", index=idx, kind="pin-slot", bodies=(link, carriers[0]),
                           params={}, line=line, name=key, target=0.0, at=pc, axis=axis)

    def check_placements(self, joints, points, forces) -> None:
        """Refuse a global placement (`at:`) on a link with given lengths: it would be read
        against the link's sketched pose, which is only rough there. joints: the file's joints
        (the sketch's own are placed from the shape); points: the file's body points; forces:
        the ForcesSpec or None."""
        if not self.shaped:
            return
        fix = ("give it in the link's frame instead (s:, si:/sj:; the frame has its origin at "
               "the link's first point and its x axis towards the second) or make it a point of "
               "the link")
        for el in joints:
            for b in el.bodies:
                if el.at is not None and b in self.shaped:
                    self.v.err(el.line, f"{el.label}: at: is read against the sketched pose of "
                                        f"link '{b}', which has given lengths and is only rough; "
                                        f"{fix}")
                    break
        for p in points:
            if p.at is not None and p.body in self.shaped:
                self.v.err(p.line, f"point '{p.name}': at: is read against the sketched pose of "
                                   f"link '{p.body}', which has given lengths and is only rough; "
                                   f"{fix}")
        for ld in (forces.loads if forces is not None else ()):
            if ld.at is not None and ld.bodies and ld.bodies[0] in self.shaped:
                self.v.err(ld.line, f"{ld.label}: at: is read against the "
                                    f"sketched pose of link '{ld.bodies[0]}', which has given "
                                    f"lengths and is only rough; {fix}")

    # -- drivers ---------------------------------------------------------------------------------
    def between(self, node, what: str):
        """A distance driver's `between: [C, D]`: (bodies, si, sj) or None after an error."""
        v = self.v
        if node.kind != "seq" or len(node.value) != 2:
            v.err(node, f"{what}: between must be two point names [C, D]")
            return None
        names = [self._pin_ref(n, f"{what}: between") for n in node.value]
        if None in names:
            return None
        bodies, local = [], []
        for n in names:
            c = self.carriers.get(n) or []
            if not c:
                v.err(node, f"{what}: point '{n}' is not carried by any link")
                return None
            b = c[0]
            bodies.append(b)
            local.append(self.local(n, b))
        if bodies[0] == bodies[1]:
            v.err(node, f"{what}: points {names[0]} and {names[1]} are both on '{bodies[0]}'; "
                        f"their distance cannot change")
            return None
        return tuple(bodies), local[0], local[1]

    def local(self, pin: str, body: str) -> tuple[float, float]:
        """Body-frame coordinates of a pin on one of its carriers (user length unit): from the
        link's given lengths if it has any, else as sketched."""
        shape = self.shaped.get(body)
        if shape is not None:
            return shape[pin]
        return self._sketched_local(pin, body)

    def _sketched_local(self, pin: str, body: str) -> tuple[float, float]:
        x, y, phi = self.poses.get(body, (0.0, 0.0, 0.0))
        px, py = self.pins[pin].at
        c, s = math.cos(phi), math.sin(phi)
        dx, dy = px - x, py - y
        return (c * dx + s * dy, -s * dx + c * dy)

    # -- points ----------------------------------------------------------------------------------
    def points(self) -> list[PointSpec]:
        out = []
        for name, pin in self.pins.items():
            c = self.carriers.get(name)
            if c:
                # at: the sketched position, which the assembly warnings compare against
                s = self.shaped[c[0]][name] if c[0] in self.shaped else None
                out.append(PointSpec(name, c[0], s, pin.at, pin.line))
        return out


def _type(node) -> str:
    from .yamlread import type_name
    return type_name(node)


def _is_body_point(points_node, name: str) -> bool:
    if points_node is None or points_node.kind != "map" or name not in points_node.value:
        return False
    val = points_node.value[name]
    return val.kind == "map" and "body" in val.value


def derived_yaml(spec) -> str:
    """The body/joint form of a validated model as YAML a user can paste: bodies with their
    poses as given (for links: the exact sketched pose at t = start), joints and drivers with body-frame vectors (global placements `at`
    resolved), points in body frames. Numbers are written with repr (round-trip exact)."""
    from ..elements import KINDS
    from ..elements.revolute import to_body
    from .compile import placed_params
    af = math.pi / 180.0 if spec.angle_unit == "deg" else 1.0
    poses = {b.name: (b.q[0], b.q[1], b.q[2] * af) for b in spec.bodies}
    poses["ground"] = (0.0, 0.0, 0.0)
    num = lambda x: repr(float(x) + 0.0)        # + 0.0: no "-0.0"
    vec = lambda v: f"[{num(v[0])}, {num(v[1])}]"
    out = [f"# {spec.name}: the body/joint form derived by planarkin from {spec.file}",
           f"name: {spec.name}", f"units: {{length: {spec.length_unit}, angle: {spec.angle_unit}}}",
           ]
    if spec.parameters:
        out.append("parameters:")
        out += [f"  {k}: {num(x)}" for k, x in spec.parameters.items()]
    out.append("bodies:")
    out += [f"  {b.name}: {{q: [{num(b.q[0])}, {num(b.q[1])}, {num(b.q[2])}]}}"
            for b in spec.bodies]
    for section, els in (("joints", spec.joints), ("drivers", spec.drivers)):
        if not els:
            continue
        out.append(f"{section}:")
        for el in els:
            kind = KINDS[el.kind]
            params, c = placed_params(el, poses)
            if el.at is not None and el.target is None and c is not None:
                params[kind.target] = c
            items = [f"type: {el.kind}"] + ([f"name: {el.name}"] if el.name else [])
            names = ("i", "j", "k")
            items += [f"{names[n]}: {b}" for n, b in enumerate(el.bodies)]
            for p in kind.params:
                v = params.get(p.name)
                if v is None:
                    continue
                items.append(f"{p.name}: {vec(v) if p.unit in ('point', 'vector') else num(v)}")
            if el.role == "joint" and kind.target and el.target is not None and \
                    el.kind != "pin-slot" or (el.kind == "pin-slot" and el.target):
                items.append(f"{kind.target}: {num(el.target)}")
            elif el.role == "joint" and kind.target and kind.target in params:
                items.append(f"{kind.target}: {num(params[kind.target])}")
            if el.role == "driver":
                items.append(f"f: \"{el.f.text}\"")
            out.append("  - {" + ", ".join(items) + "}")
    if spec.points:
        out.append("points:")
        for p in spec.points:
            if p.body == "ground":      # a sketch pin on ground: the only form for a fixed point
                out.append(f"  {p.name}: {{at: {vec(p.at)}, ground: true}}")
                continue
            s = p.s if p.s is not None else to_body(p.at, poses[p.body])
            out.append(f"  {p.name}: {{body: {p.body}, s: {vec(s)}}}")
    a = spec.analysis
    out.append(f"analysis: {{start: {num(a.start)}, end: {num(a.end)}, steps: {a.steps}}}")
    return "\n".join(out) + "\n"
