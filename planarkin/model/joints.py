"""The joints: and drivers: sections of a model file: each element's kind (the registry
`planarkin.elements.KINDS` tells which keys it takes), its bodies, its parameters by their unit,
its global placement, a driver's function of time (f, motion: or table:), and the checks across
the elements (unique names, drivers over the analysis range). The kind's own checks of its
values are the kind's (Kind.validate).

`ElementSections` holds these readers for the file's validator (planarkin.model.validate), whose
small typed readers (err, number, vector, text, body_ref ...) they use.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..diagnostics import did_you_mean, one_of
from ..elements import DRIVER_KINDS, JOINT_KINDS, KINDS
from planarkin.functions.expr import ExprError, TimeFunction
from .spec import AnalysisSpec, ElementSpec
from .yamlread import Node, raw_text, type_name

MAX_SEGMENTS = 100       # segments of one motion: profile (longer motions: a table)


class ElementSections:
    """The readers of the joints: and drivers: sections (a part of the file's validator)."""

    def elements(self, node: Node | None, role: str) -> list[ElementSpec]:
        out: list[ElementSpec] = []
        if node is None:
            return out
        section = role + "s"
        if node.kind != "seq":
            self.err(node, f"{section} must be a list of {{type: ..., ...}} entries, "
                           f"not {type_name(node)}")
            return out
        for idx, item in enumerate(node.value, start=1):
            spec = self.element(item, role, idx)
            if spec is not None:
                out.append(spec)
        return out

    def _kind_name(self, node: Node, role: str, what: str) -> str | None:
        """The entry's type, checked against the role's kinds (a message and None if not)."""
        kinds = JOINT_KINDS if role == "joint" else DRIVER_KINDS
        if node.kind != "map":
            self.err(node, f"{what} must be a mapping like {{type: revolute, i: ..., j: ...}}, "
                           f"not {type_name(node)}")
            return None
        v = node.value
        if "type" not in v:
            self.err(node, f"{what}: missing 'type' ({one_of(kinds)})")
            return None
        kname = self.text(v["type"], f"{what}: type")
        if kname is None:
            return None
        if kname not in kinds:
            other = "driver" if role == "joint" else "joint"
            if kname in KINDS:
                msg = (f"{what}: '{kname}' is a {other} kind, not a {role} kind "
                       f"({role} kinds: {', '.join(kinds)})")
            else:
                hint = did_you_mean(kname, kinds) or f" ({role} kinds: {one_of(kinds)})"
                msg = f"{what}: unknown type '{kname}'{hint}"
            self.err(v["type"], msg)
            return None
        return kname

    def _element_bodies(self, node: Node, v: dict, role: str, what: str, between, use_body: bool,
                        body_keys: list) -> list:
        """The bodies an entry connects (names, None where a reference is wrong)."""
        bodies: list[str | None] = []
        if between is not None:
            bodies = list(between[0])
        elif use_body:
            if "i" in v or "j" in v:
                self.err(v["body"], f"{what}: give either body or i and j, not both")
            bodies = ["ground", self.body_ref(v["body"], what, allow_ground=False)]
        elif role == "driver" and "i" not in v and "j" not in v:
            self.err(node, f"{what}: missing body: NAME (the driven body; or i and j for a "
                           f"relative driver)")
            bodies = [None, None]
        else:
            for key in body_keys:
                if key in v:
                    bodies.append(self.body_ref(v[key], what))
                elif key == "k":
                    bodies.append("ground")
                else:
                    self.err(node, f"{what}: missing '{key}' (a body name or ground)")
                    bodies.append(None)
        if None not in bodies and len(set(bodies)) < len(bodies):
            self.err(node, f"{what}: connects a body to itself; i and j must differ")
        return bodies

    def _at_axis(self, v: dict, kind, what: str, has_at: bool, wants_axis: bool) -> tuple:
        """A joint's placement at: (and the slide direction axis: where the kind takes one)."""
        at = axis = None
        pnames = [p.name for p in kind.params]
        if has_at and "at" in v:
            at = self.placement(v["at"], kind, what)
            clash = [p for p in pnames if p in v and kind.params[pnames.index(p)].unit in
                     ("point", "vector")]
            if clash:
                self.err(v["at"], f"{what}: give either at or {', '.join(clash)}, not both")
            if wants_axis:
                if "axis" not in v:
                    self.err(v["at"], f"{what}: with at, give axis: [dx, dy] (the slide direction)")
                else:
                    axis = self.direction(v["axis"], f"{what}: axis")
        elif "axis" in v and "at" not in v:
            self.err(v["axis"], f"{what}: axis is used with at; give at: [x, y] too")
        return at, axis

    def element(self, node: Node, role: str, idx: int) -> ElementSpec | None:
        what = f"{role} {idx}"
        kname = self._kind_name(node, role, what)
        if kname is None:
            return None
        v = node.value
        kind = KINDS[kname]
        ename = None
        if "name" in v:
            ename = self.text(v["name"], f"{what}: name")
            if ename is not None and not self.identifier(ename, v["name"].line, role):
                ename = None
        # bodies: the label uses the names as written, so that every message can show them
        body_keys = ["i", "j"] + (["k"] if kind.nbody == 3 else [])
        allowed = ["type", "name"] + body_keys
        if role == "driver":
            allowed.append("body")
            allowed.append("link")
            if "link" in v:
                if "body" in v:
                    self.err(v["link"], f"{what}: give either link or body, not both")
                v = dict(v)
                v["body"] = v.pop("link")
            if kind.between:
                allowed.append("between")
        between = None
        if role == "driver" and "between" in v and kind.between:
            if "i" in v or "j" in v or "body" in v:
                self.err(v["between"], f"{what} ({kname}): give either between: [C, D] or the "
                                       f"bodies i and j, not both")
                return None
            between = self.sketch.between(v["between"], f"{what} ({kname})")
            if between is None:
                return None
            v = dict(v)
            for key in ("si", "sj"):
                if key in v:
                    self.err(v[key], f"{what} ({kname}): {key} is fixed by between; drop it")
        use_body = role == "driver" and "body" in v
        raw = ["ground", raw_text(v["body"])] if use_body else list(between[0]) if between else \
            [raw_text(v[k]) if k in v else ("ground" if k == "k" else "?") for k in body_keys]
        shown = f" {'-'.join(raw)}" if any(r != "?" for r in raw) else ""
        what = (f"{role} '{ename}'" if ename else what) + f" ({kname}{shown})"
        bodies = self._element_bodies(node, v, role, what, between, use_body, body_keys)
        # parameters
        pnames = [p.name for p in kind.params]
        allowed += pnames
        has_at = kind.at_form is not None and role == "joint"
        if has_at:
            allowed.append("at")
            if kind.at_axis:
                allowed.append("axis")
        if role == "joint" and kind.target:
            allowed.append(kind.target)
        if role == "driver":
            allowed += ["f", "motion", "table"]
            if "sj" in pnames:
                allowed.append("s")
        self.keys(node, allowed, what)
        self.cam_keys = v                 # a cam's data law reads whether range is given
        params: dict[str, Any] = {}
        lines: dict[str, int] = {}
        at, axis = self._at_axis(v, kind, what, has_at, "axis" in allowed)
        if role == "driver" and "s" in v:
            if "sj" in v:
                self.err(v["s"], f"{what}: give either s or sj, not both")
            v = dict(v)
            v["sj"] = v.pop("s")
        if between is not None:
            params["si"], params["sj"] = between[1], between[2]
        for p in kind.params:
            if between is not None and p.name in ("si", "sj"):
                continue
            if p.name in v:
                lines[p.name] = v[p.name].line
                val = self.param(v[p.name], p, what)
                if val is not None:
                    params[p.name] = val
            elif at is not None and p.unit in ("point", "vector"):
                continue
            elif role == "driver" and p.unit == "point":
                params[p.name] = (0.0, 0.0)       # a driver's points default to body origins
            elif role == "driver" and p.unit == "vector":
                self.err(node, f"{what}: missing {p.name} ({p.doc})")
            elif not p.required:
                params[p.name] = p.default
            elif p.required:
                hint = f", or at: {kind.at_form}" if has_at else ""
                self.err(node, f"{what}: missing {p.name} ({p.doc}{hint})")
        target = None
        f = None
        if role == "joint" and kind.target:
            if kind.target in v:
                target = self.param(v[kind.target], _target_param(kind), what)
                lines[kind.target] = v[kind.target].line
            elif kind.target_default is not None:
                target = kind.target_default
            elif not (kind.target_from_at and at is not None):
                self.err(node, f"{what}: missing {kind.target} (the constant value"
                               f"{', in ' + kind.target_unit + ' units' if kind.target_unit else ''})")
        if role == "driver":
            f = self.driver_function(node, v, what, lines)
        kind.validate(self, {**params, kind.target: target} if target is not None else params,
                      v, what)
        if any(p.unit in ("law", "angle-law") for p in kind.params):
            from .camlaws import check_law
            check_law(self, params, v, what)
        if None in bodies:
            return None
        return ElementSpec(role=role, index=idx, kind=kname, bodies=tuple(bodies), params=params,
                           line=node.line, name=ename, target=target, f=f, at=at, axis=axis,
                           param_lines=lines)

    def param(self, node: Node, p, what: str):
        if p.unit in ("law", "angle-law"):
            from ..elements.cam import Law
            if node.kind == "map":
                from .camlaws import cam_law_form
                return cam_law_form(self, node, p, what)
            if node.kind != "scalar" or node.value is None or isinstance(node.value, bool):
                self.err(node, f"{what}: {p.name} must be an expression of the cam angle theta "
                               f"(or {{motion: ...}} or {{table: FILE}}), not {type_name(node)}")
                return None
            try:
                return Law(node.value if isinstance(node.value, str) else float(node.value),
                           self.params)
            except ExprError as e:
                if not self.of_broken(node.value):
                    self.err(node, f"{what}: {p.name}: {e}")
            except OverflowError:
                self.err(node, f"{what}: {p.name}: the number {node.text[:40]} is too large")
            return None
        if p.unit == "curve":
            return self.curve_points(node, f"{what}: {p.name}")
        if p.unit == "range":
            r = self.vector(node, f"{what}: {p.name}")
            if r is not None and not r[0] < r[1]:
                self.err(node, f"{what}: {p.name} must be [from, to] with from < to, not "
                               f"[{r[0]:g}, {r[1]:g}]")
                return None
            return r
        if p.unit == "flag":
            if node.kind == "scalar" and isinstance(node.value, bool):
                return float(node.value)
            self.err(node, f"{what}: {p.name} must be true or false, not {type_name(node)}")
            return None
        if p.unit == "point":
            return self.vector(node, f"{what}: {p.name}")
        if p.unit == "vector":
            return self.direction(node, f"{what}: {p.name}")
        x = self.number(node, f"{what}: {p.name}")
        if x is not None and p.name in ("ri", "rj") and x == 0:
            self.err(node, f"{what}: {p.name} must not be zero (a pitch radius)")
            return None
        return x

    def curve_points(self, node: Node, what: str):
        """A table of at least 6 distinct successive points [[x, y], ...] (a closed curve may
        repeat its first point at the end: it is dropped)."""
        if node.kind == "map":
            from .curves import curve_form
            return curve_form(self, node, what)
        if node.kind != "seq":
            self.err(node, f"{what} must be a list of points [[x, y], ...] or one of {{circle: "
                           f"...}}, {{segments: [...]}}, {{table: FILE.csv}}, not "
                           f"{type_name(node)}")
            return None
        pts = [self.vector(item, what) for item in node.value]
        if any(p is None for p in pts):
            return None
        if len(pts) > 6 and pts[0] == pts[-1]:
            pts = pts[:-1]
        if len(pts) < 6:
            self.err(node, f"{what} needs at least 6 points (a quintic spline), got {len(pts)}")
            return None
        for k in range(1, len(pts)):
            if pts[k] == pts[k - 1]:
                self.err(node.value[k], f"{what}: point {k + 1} repeats point {k}; the points "
                                        f"of a curve must be distinct in succession")
                return None
        from .curves import lost_step
        lost = lost_step(pts)
        if lost is not None:
            self.err(node.value[lost[0]], f"{what}: {lost[1]}")
            return None
        return tuple(pts)

    def direction(self, node: Node, what: str):
        vec = self.vector(node, what)
        if vec is not None and vec[0] == 0 and vec[1] == 0:
            self.err(node, f"{what} is a zero vector; give a direction such as [1, 0]")
            return None
        return vec

    def placement(self, node: Node, kind, what: str):
        if kind.at_points == 2:
            if node.kind != "seq" or len(node.value) != 2:
                self.err(node, f"{what}: at must be [[x1, y1], [x2, y2]] (the two points)")
                return None
            pts = [self.vector(n, f"{what}: at") for n in node.value]
            if None in pts:
                return None
            if pts[0] == pts[1]:
                self.err(node, f"{what}: the two points of at coincide; a distance joint needs "
                               f"two distinct points (for a pin use a revolute joint)")
                return None
            return tuple(pts)
        return self.vector(node, f"{what}: at")

    def function(self, node: Node, what: str):
        if node.kind != "scalar" or node.value is None or isinstance(node.value, bool):
            self.err(node, f"{what}: f must be an expression of t, not {type_name(node)}")
            return None
        v = node.value
        try:
            return TimeFunction.shared(v if isinstance(v, str) else float(v), self.params)
        except ExprError as e:
            if not self.of_broken(v):
                self.err(node, f"{what}: f: {e}")
        except OverflowError:
            self.err(node, f"{what}: f: the number {node.text[:40]} is too large")
        return None

    # -- driver functions: f, motion or table -------------------------------------------------
    def driver_function(self, node: Node, v: dict, what: str, lines: dict):
        forms = [k for k in ("f", "motion", "table") if k in v]
        if not forms:
            self.err(node, f"{what}: missing f (a function of time t, e.g. f: \"2*pi*t\"; or "
                           f"motion: or table:)")
            return None
        if len(forms) > 1:
            self.err(v[forms[1]], f"{what}: give one of f, motion and table, not "
                                  f"{' and '.join(forms)}")
            return None
        key = forms[0]
        lines["f"] = v[key].line
        if key == "motion":
            return self.motion(v[key], what)
        if key == "table":
            return self.table(v[key], what)
        return self.function(v[key], what)

    def motion(self, node: Node, what: str, over: str | None = None):
        """The TimeFunction of a motion: profile, or None. over: None for a driver (segments
        over time); for a cam's law the unit of its cam angles (then the result is
        (segments, initial, t0, repeat or None when not given), built by the cam's reader)."""
        from planarkin.functions.laws import ALIASES, LAWS, law
        from planarkin.functions.motion import Segment, profile, short_segment
        what = f"{what}: motion"
        noun, unit = ("duration", "s") if over is None else ("cam angle", over)
        span, T_ = f"{noun} ({unit})", "T" if over is None else "ANGLE"
        if not self.keys(node, ("segments", "initial", "t0", "repeat"), what):
            return None
        v = node.value
        initial = self.number(v["initial"], f"{what}: initial") if "initial" in v else 0.0
        t0 = self.number(v["t0"], f"{what}: t0") if "t0" in v else 0.0
        repeat = False if over is None else None
        if "repeat" in v:
            n = v["repeat"]
            if n.kind == "scalar" and isinstance(n.value, bool):
                repeat = n.value
            else:
                self.err(n, f"{what}: repeat must be true or false, not {type_name(n)}")
        segs = v.get("segments")
        if segs is None:
            self.err(node, f"{what}: missing segments (a list such as [{{rise: 90, in: 0.3, law: "
                           f"cycloidal}}, {{dwell: 0.2}}])")
            return None
        if segs.kind != "seq" or not segs.value:
            self.err(segs, f"{what}: segments must be a non-empty list of {{rise|return|move: "
                           f"h, in: T, law: NAME}} or {{dwell: T}}, not "
                           f"{'an empty list' if segs.kind == 'seq' else type_name(segs)}")
            return None
        if len(segs.value) > MAX_SEGMENTS:
            self.err(segs, f"{what}: at most {MAX_SEGMENTS} segments")
            return None
        laws = sorted(set(LAWS) | set(ALIASES))
        out, ok = [], initial is not None and t0 is not None
        for k, seg in enumerate(segs.value, start=1):
            sw = f"{what}: segment {k}"
            if not self.keys(seg, ("rise", "return", "move", "dwell", "in", "law"), sw):
                ok = False
                continue
            sv = seg.value
            kinds = [x for x in ("rise", "return", "move", "dwell") if x in sv]
            if len(kinds) != 1:
                self.err(seg, f"{sw}: give exactly one of rise, return, move and dwell"
                              + (f", not {' and '.join(kinds)}" if kinds else ""))
                ok = False
                continue
            kind = kinds[0]
            if kind == "dwell":
                for extra in ("in", "law"):
                    if extra in sv:
                        self.err(sv[extra], f"{sw}: a dwell takes its {noun} as "
                                            f"dwell: {T_}, without {extra}")
                        ok = False
                T = self.number(sv["dwell"], f"{sw}: dwell")
                if T is not None and not T > 0:
                    self.err(sv["dwell"], f"{sw}: dwell must be a positive {span}, not {T:g}")
                    T = None
                if T is None:
                    ok = False
                else:
                    out.append(Segment("dwell", 0.0, T))
                continue
            h = self.number(sv[kind], f"{sw}: {kind}")
            if h is not None and h < 0 and kind != "move":
                self.err(sv[kind], f"{sw}: {kind} is a size, not {h:g}; for the other direction "
                                   f"use {'return' if kind == 'rise' else 'rise'}, or move with a "
                                   f"signed amount")
                h = None
            T = None
            if "in" not in sv:
                self.err(seg, f"{sw}: missing in (the {noun} of the {kind}, {unit})")
            else:
                T = self.number(sv["in"], f"{sw}: in")
                if T is not None and not T > 0:
                    self.err(sv["in"], f"{sw}: in must be a positive {span}, not {T:g}")
                    T = None
            name = None
            if "law" not in sv:
                self.err(seg, f"{sw}: missing law ({', '.join(sorted(LAWS))})")
            else:
                name = self.text(sv["law"], f"{sw}: law")
                if name is not None and law(name) is None:
                    self.err(sv["law"], f"{sw}: unknown law '{name}'"
                                        f"{did_you_mean(name, laws) or ' (laws: ' + ', '.join(sorted(LAWS)) + ')'}")
                    name = None
            if h is None or T is None or name is None:
                ok = False
                continue
            out.append(Segment(kind, -h if kind == "return" else h, T, name))
        if not ok:
            return None
        short = short_segment(out, unit)
        if short is not None:
            self.err(segs.value[short[0]], f"{what}: segment {short[0] + 1}: {short[1]}")
            return None
        if over is not None:
            return out, initial, t0, repeat
        try:
            return profile(out, initial, t0, repeat)
        except ExprError as e:
            self.err(node, f"{what}: {e}")
            return None

    def table(self, node: Node, what: str):
        from ..diagnostics import Diagnostic
        from planarkin.functions.inputtable import TableError, read_table, table_function
        what = f"{what}: table"
        ref = self.table_ref(node, what, ("time", "value"), ("periodic",))
        if ref is None:
            return None
        fname, cols, v = ref
        periodic = False
        if "periodic" in v:
            n = v["periodic"]
            if n.kind == "scalar" and isinstance(n.value, bool):
                periodic = n.value
            else:
                self.err(n, f"{what}: periodic must be true or false, not {type_name(n)}")
                return None
        path = Path(self.file).parent / fname
        shown = str(path)
        try:
            t, y, tlines = read_table(path, cols.get("time"), cols.get("value"))
        except TableError as exc:
            self.table_errors(exc, node, what, shown, f"the table of {what[:-7]}")
            return None
        if periodic:
            scale = max(1.0, float(abs(y).max()))
            if abs(y[-1] - y[0]) > 1e-9 * scale:
                self.C.items.append(Diagnostic(
                    shown, tlines[-1], f"a periodic table must end with the value it starts with: "
                                       f"{y[-1]:g} here, {y[0]:g} at line {tlines[0]} (the table "
                                       f"of {what[:-7]})"))
                return None
            y = y.copy()
            y[-1] = y[0]
        try:
            return table_function(t, y, periodic, fname)
        except (ValueError, ExprError) as exc:
            self.err(node, f"{what}: cannot interpolate {fname}: {exc}")
            return None

    def check_drivers(self, drivers: list[ElementSpec], a: AnalysisSpec) -> None:
        """Problems of the driver functions over the analysis range (known only now): position
        jumps, derivatives that are not finite, times outside a table."""
        if not (math.isfinite(a.start) and math.isfinite(a.end) and a.end > a.start):
            return
        for d in drivers:
            if d.f is None:
                continue
            for msg in d.f.problems(a.start, a.end):
                self.err(d.param_lines.get("f", d.line), f"{d.label}: {msg}")

    def unique_names(self, elements: list[ElementSpec]) -> None:
        seen: dict[str, ElementSpec] = {}
        for el in elements:
            if el.name is None:
                continue
            if el.name in seen:
                self.err(el.line, f"{el.label}: the name '{el.name}' is already used at line "
                                  f"{seen[el.name].line}")
            else:
                seen[el.name] = el


def _target_param(kind):
    from ..elements import Param
    return Param(kind.target, kind.target_unit or "real", "constant")
