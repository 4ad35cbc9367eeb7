"""The parts of a compiled model, each in its body frame at its true size in millimetres.

A moving body is a part (ground is not): its pin holes at its pins, a small cross at every pin
centre and marked point, and

- a link: the plate around its pins and points (`geometry.plate`: a circle, a capsule, the hull
  of the circles of radius width / 2);
- a cam (the cam i of a `cam` or `cam-rocker` joint): its working surface as the cut outline and
  its pitch curve for reference, both computed densely from the law by kinematic inversion
  (`planarkin.elements.cam.profile`, as cam-<name>.csv is) and written as arcs within the
  chordal tolerance (`planarkin.export.biarcs`);
- a gear (gear, gear-mesh, rack-pinion): its pitch circle and, with a module, its outside circle
  (internal gears: the tip circle, |r| - module); a disc of roll-disc or roll-line: its circle;
  a belt's pulley: its pitch circle.

A roller follower's roller is a part of its own (a disc of the roller's radius with its bore),
and the roller's axle a pin of the follower. Pins are the points of revolute joints, the pin of
a pin-slot or curve-slot joint, and a roller's axle; pins within 1e-9 mm of each other are one.
Whatever cannot be drawn right is refused (DrawingError): a hole that overlaps another or does
not fit inside its cam or gear blank, a cam whose centre is not where it turns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import geometry as geo
from .biarcs import CurveError, fit

# millimetres per model length unit (units: length is a label; these are the ones with a size)
MM = {"m": 1000.0, "dm": 100.0, "cm": 10.0, "mm": 1.0, "um": 1e-3, "micron": 1e-3,
      "km": 1e6, "in": 25.4, "inch": 25.4, "ft": 304.8}
SAME = 1e-9                 # mm: pins this close are one pin
GEARS = {"gear": "gear", "gear-mesh": "gear", "rack-pinion": "gear", "roll-disc": "disc",
         "roll-line": "disc", "belt": "pulley"}
SLOTS = ("pin-slot", "curve-slot")


class DrawingError(ValueError):
    """The drawings cannot be made right: the message names the fix (exit 2)."""


@dataclass(frozen=True)
class Sizes:
    """What the drawings are made with, all in mm: plate width, pin diameter, the clearance
    added to it for the holes, the plate thickness (written on each part), the chordal
    tolerance of cam profiles, the gears' module (None: pitch circles only), text height."""

    width: float = 12.0
    pin: float = 6.0
    clearance: float = 0.1
    thickness: float = 5.0
    tolerance: float = 0.01
    module: float | None = None
    text: float = 2.5

    @property
    def hole(self) -> float:
        return self.pin + self.clearance


def size_problems(s: Sizes) -> list[str]:
    """What is wrong with the sizes, as messages naming the option and the fix."""
    out = []
    for name in ("width", "pin", "thickness", "tolerance", "module"):
        v = getattr(s, name)
        if v is not None and not (math.isfinite(v) and v > 0):
            out.append(f"--{name} {v:g}: must be a positive number of millimetres"
                       + (" (the largest distance allowed between the drawn arcs and the exact "
                          "cam profile)" if name == "tolerance" else ""))
    if not (math.isfinite(s.clearance) and s.clearance >= 0):
        out.append(f"--clearance {s.clearance:g}: must be 0 or more millimetres (added to the "
                   f"pin diameter for the holes)")
    if not out and not s.width > s.hole:
        out.append(f"--width {s.width:g} mm is not larger than the holes (pin {s.pin:g} + "
                   f"clearance {s.clearance:g} = {s.hole:g} mm): give a --width above "
                   f"{s.hole:g} or a smaller --pin")
    return out


def mm_per_unit(unit: str) -> float | None:
    return MM.get(unit)


class _Body:
    """What one moving body carries (internal units, its frame)."""

    def __init__(self):
        self.pins: list = []          # (point, what)
        self.marks: list = []         # points
        self.cams: list = []          # (G, k, name)
        self.gears: list = []         # (centre, signed radius, kind, what)
        self.notes: list = []


def _element_name(cm, G, k) -> str:
    el = cm.element_of_row(int(G.rows[k, 0]))
    return el.name or f"{el.role}{el.index}"


def _collect(cm) -> tuple[list[_Body], list]:
    """Per moving body what it carries, and the roller parts [(cam name, radius, follower)]."""
    from ..elements.base import pivots
    from ..elements.gear import centre_on
    nb, pv = cm.nb, pivots(cm.groups)
    bodies = [_Body() for _ in range(nb)]
    rollers = []

    def pin(b, s, what):
        if b < nb:
            bodies[b].pins.append((np.asarray(s, float), what))

    for G in cm.groups:
        kind = G.kind.name
        for k in range(len(G)):
            bi, bj = int(G.bodies[k, 0]), int(G.bodies[k, 1])
            name = _element_name(cm, G, k)
            if kind == "revolute":
                pin(bi, G.params["si"][k], name)
                pin(bj, G.params["sj"][k], name)
            elif kind == "translational":
                for b in (bi, bj):
                    if b < nb:
                        bodies[b].notes.append(f"slides in {name}: the guide not drawn")
            elif kind in SLOTS:
                pin(bj, G.params["sj"][k], name)
                if bi < nb:
                    bodies[bi].notes.append(f"slot of {name} not drawn")
            elif kind in ("cam", "cam-rocker"):
                if bi < nb:
                    bodies[bi].cams.append((G, k, name))
                r = float(G.params["roller"][k])
                if r > 0:
                    pin(bj, G.params["sj"][k], f"{name} roller")
                    rollers.append((name, r, bj))
            elif kind in GEARS:
                for col, (s, r) in enumerate((("si", "ri"), ("sj", "rj"))):
                    b = int(G.bodies[k, col])
                    if kind in ("rack-pinion", "roll-line"):
                        if col == 0:
                            if b < nb:
                                bodies[b].notes.append(f"rack (line) of {name} not drawn")
                            continue
                        s, r = "sj", "r"
                    if b >= nb:
                        continue
                    if kind in ("gear", "belt"):
                        c = centre_on(pv, b, int(G.bodies[k, 2]))
                        if c is None:
                            raise DrawingError(
                                f"{name}: no revolute joint places the centre of "
                                f"{cm.body_names[b]} on its carrier, so its pitch circle has "
                                f"no place on the part; pin it to the carrier")
                    else:
                        c = G.params[s][k]
                    bodies[b].gears.append((np.asarray(c, float), float(G.params[r][k]),
                                            GEARS[kind], name))
    for j in range(len(cm.point_names)):
        b = int(cm.point_body[j])
        if b < nb:
            bodies[b].marks.append(np.asarray(cm.point_s[j], float))
    return bodies, rollers


def _cam_shapes(cm, G, k, name, centre_i, f, tol, af, au) -> tuple[list, list, list]:
    """The working surface (OUTLINE) and pitch curve (PITCH) of cam instance k, its notes and
    its fits; centre_i: the cam's centre on its body (internal units); f: mm per internal."""
    from ..elements.cam import instance, profile
    par = instance(G, k)
    lo, hi = (float(x) for x in par["range"])
    closed = not (math.isfinite(lo) and math.isfinite(hi))
    if closed:
        lo, hi = 0.0, 2.0 * math.pi
    shapes, fits = [], []
    flat = par.get("flat", 0.0) > 0.5          # a flat face: no pitch curve to speak of
    for key, layer in (("surface", geo.OUTLINE),) + (() if flat else (("pitch", geo.PITCH),)):
        def curve(th, key=key):
            P = profile(G.kind.name, par, th)
            return (np.c_[P[f"{key}_x"], P[f"{key}_y"]] + centre_i) * f
        try:
            F = fit(curve, lo, hi, closed, tol)
        except CurveError as e:
            raise DrawingError(f"cam '{name}': its {key} curve cannot be drawn within "
                               f"{tol:g} mm: {e}") from None
        shapes.append(geo.Shape("poly", layer, F.vertices, F.bulges, closed=closed))
        fits.append({"cam": name, "curve": "working surface" if key == "surface" else
                     "pitch curve", "arcs": F.arcs, "tolerance_mm": tol,
                     "max_deviation_mm": F.max_deviation, "check_points": F.samples,
                     "theta_deg": [math.degrees(lo), math.degrees(hi)]})
    notes = [f"cam {name}: working surface{'' if flat else ' and pitch curve'} as arcs, chordal "
             f"tolerance {tol:g} mm"]
    if not closed:
        notes.append(f"cam {name}: its law covers theta {lo / af:g} to {hi / af:g} {au} only: "
                     f"the profile is open, complete the outline")
    return shapes, notes, fits


def _inside(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Whether each point lies inside the closed polygon poly (even-odd rule)."""
    x, y = points[:, 0:1], points[:, 1:2]
    a, b = poly, np.roll(poly, -1, axis=0)
    cond = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (np.count_nonzero(cond & (x < xs), axis=1) % 2) == 1


def _check_holes(part: geo.Part, body: str, sizes: Sizes) -> None:
    """Holes must not overlap, and must lie inside a cam's or gear's outline (DrawingError)."""
    H, r = part.holes, sizes.hole / 2.0
    for i in range(len(H)):
        for j in range(i):
            d = math.hypot(*(H[i] - H[j]))
            if d <= sizes.hole:
                raise DrawingError(
                    f"{body}: the pins at ({H[j][0]:.6g}, {H[j][1]:.6g}) and ({H[i][0]:.6g}, "
                    f"{H[i][1]:.6g}) mm are {d:.6g} mm apart, not more than the hole diameter "
                    f"{sizes.hole:g} mm: their holes would overlap; give a smaller --pin")
    cuts = [s for s in part.shapes if s.layer == geo.OUTLINE]
    if part.kind not in ("cam", "gear") or not cuts:
        return
    for h in H:
        fits = False
        for s in cuts:
            if s.kind == "circle":
                fits |= math.hypot(*(h - s.points[0])) + r < s.r
            elif s.closed:
                P = geo.sample(s, max(sizes.tolerance, 1e-3))
                fits |= bool(_inside(h[None, :], P)[0]) and \
                    geo.distance_to_polyline(h[None, :], P)[0] > r
            else:
                fits = True                  # an open profile: nothing to fit inside
        if not fits:
            raise DrawingError(
                f"{body}: the hole at ({h[0]:.6g}, {h[1]:.6g}) mm ({sizes.hole:g} mm) does not fit "
                f"inside the {part.kind}'s outline; give a smaller --pin"
                + (" or a --module" if part.kind == "gear" and sizes.module is None else ""))


def _gear_shapes(gears, f, m) -> tuple[list, list]:
    shapes, notes = [], []
    merged: list = []                  # a planet in two meshes has one pitch circle
    for c, r, kind, name in gears:
        same = next((g for g in merged if g[1] == r and g[2] == kind and
                     math.hypot(*(g[0] - c)) * f <= SAME), None)
        if same is None:
            merged.append([c, r, kind, name])
        else:
            same[3] += f", {name}"
    for c, r, kind, name in merged:
        c, R = c * f, abs(r) * f
        if kind == "disc":
            shapes.append(geo.circle(c, R, geo.OUTLINE))
            notes.append(f"disc of {name}: r {R:.6g} mm")
            continue
        shapes.append(geo.circle(c, R, geo.PITCH))
        if kind == "pulley":
            notes.append(f"pulley of {name}: pitch circle r {R:.6g} mm (the groove not drawn)")
        elif m is None:
            notes.append(f"gear of {name}: pitch circle r {R:.6g} mm; no module given: outside "
                         f"circle not drawn (--module)")
        elif r > 0:
            shapes.append(geo.circle(c, R + m, geo.OUTLINE))
            notes.append(f"gear of {name}: pitch circle r {R:.6g} mm, outside circle r "
                         f"{R + m:.6g} mm (module {m:g}, {2 * R / m:.6g} teeth)")
        elif R - m > 0:
            shapes.append(geo.circle(c, R - m, geo.OUTLINE))
            notes.append(f"internal gear of {name}: pitch circle r {R:.6g} mm, tip circle r "
                         f"{R - m:.6g} mm (module {m:g}); the outer rim not drawn")
        else:
            raise DrawingError(f"{name}: the internal gear's pitch radius {R:.6g} mm is not "
                               f"larger than the module {m:g} mm; give a smaller --module")
    return shapes, notes


def parts(cm, sizes: Sizes, only=None) -> tuple[list[geo.Part], list[str]]:
    """The parts of the compiled model cm (in body order, then the rollers) and the bodies left
    out with why. only: body names to draw (None: all). Raises DrawingError."""
    from ..elements.base import pivots
    from ..elements.gear import centre_on
    f = cm.L * MM[cm.spec.length_unit]          # mm per internal unit
    af, au = cm.angle_factor, cm.spec.angle_unit
    bodies, rollers = _collect(cm)
    pv = pivots(cm.groups)
    out, skipped = [], []
    cross = 0.3 * sizes.hole
    for b, name in enumerate(cm.body_names):
        if only is not None and name not in only:
            continue
        B = bodies[b]
        holes = geo.unique_points(np.array([p for p, _ in B.pins]).reshape(-1, 2) * f, SAME)
        marks = geo.unique_points(np.array(B.marks).reshape(-1, 2) * f, SAME)
        marks = marks[[not any(math.hypot(*(m - h)) <= SAME for h in holes) for m in marks]]
        kind = "cam" if B.cams else "gear" if B.gears else "link"
        if kind == "link" and not len(holes):
            skipped.append(f"{name}: no pin joint, cam or gear: nothing to cut")
            continue
        part = geo.Part(name, name, kind, holes=holes, hole=sizes.hole)
        notes = []
        if kind == "cam":
            for G, k, cam in B.cams:
                bk = int(G.bodies[k, 2])
                ci, ck = centre_on(pv, b, bk), centre_on(pv, bk, b)
                sk = np.asarray(G.params["sk"][k], float)
                if ci is None or ck is None or math.hypot(*(ck - sk)) * f > SAME:
                    raise DrawingError(
                        f"cam '{cam}': {name} does not turn on a revolute joint at the cam's "
                        f"centre sk, so the profile has no place on the part; pin the cam to its "
                        f"frame at sk")
                shapes, n, fits = _cam_shapes(cm, G, k, cam, ci, f, sizes.tolerance, af, au)
                part.shapes += shapes
                part.fits += fits
                notes += n
        if B.gears:
            shapes, n = _gear_shapes(B.gears, f, sizes.module)
            part.shapes += shapes
            notes += n
        if kind == "link":
            part.shapes.append(geo.plate(np.vstack([holes, marks]), sizes.width / 2.0))
        part.shapes += [geo.circle(h, sizes.hole / 2.0, geo.HOLES) for h in holes]
        for p in np.vstack([holes, marks]):
            part.shapes += geo.cross(p, cross)
        part.notes = _head(name, sizes, len(holes)) + notes + B.notes
        _check_holes(part, name, sizes)
        out.append(part)
    taken = {p.name for p in out} | set(cm.body_names)
    for cam, r, follower in rollers:
        if only is not None and cm.body_names[follower] not in only:
            continue
        R = r * f
        if not R > sizes.hole / 2.0:
            raise DrawingError(f"cam '{cam}': the roller (r {R:.6g} mm) is not larger than its "
                               f"bore ({sizes.hole:g} mm); give a smaller --pin")
        name = f"{cam}-roller"
        while name in taken:
            name += "-part"
        taken.add(name)
        part = geo.Part(name, None, "roller", holes=np.zeros((1, 2)), hole=sizes.hole)
        part.shapes = [geo.circle((0, 0), R, geo.OUTLINE),
                       geo.circle((0, 0), sizes.hole / 2.0, geo.HOLES), *geo.cross((0, 0), cross)]
        part.notes = _head(name, sizes, 1) + [f"roller of cam {cam}: r {R:.6g} mm"]
        out.append(part)
    return out, skipped


def _head(name: str, s: Sizes, holes: int) -> list[str]:
    return [name, f"thickness {s.thickness:g} mm",
            f"{holes} hole{'s' if holes != 1 else ''} {s.hole:g} mm (pin {s.pin:g} + clearance "
            f"{s.clearance:g})"]


def labels(shapes, notes: list[str], height: float) -> list[geo.Text]:
    """The notes as lines of text under the shapes, from their left edge down."""
    x0, y0, _, _ = geo.extent(shapes)
    return [geo.Text((x0, y0 - height * (1.0 + 1.6 * (i + 1))), height, line)
            for i, line in enumerate(notes)]


def text_width(line: str, height: float) -> float:
    """A generous estimate of a line's width (mm): the layout keeps this much room for it."""
    return 0.75 * height * len(line)
