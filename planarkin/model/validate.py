"""Validate a YAML node tree into a `ModelSpec` (user units), collecting every problem of the file.

Each message names the element (``joint 3 (revolute crank-rod)``), says what is wrong and, where
possible, the fix; it is reported at the line of the offending node. The kind registry
(`planarkin.elements.KINDS`) tells which keys each joint and driver kind takes.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from ..diagnostics import Collector, did_you_mean, one_of
from ..elements import DRIVER_KINDS, JOINT_KINDS, KINDS
from ..expr import ExprError, TimeFunction, evaluate_constant, function_names
from ..options import ANALYSIS_KEYS, OPTIONS, ORDERS, cross_check, override_word
from .spec import (X_AXES, AnalysisSpec, BodySpec, ElementSpec, ModelSpec, OutputSpec, PointSpec,
                   x_axis_problem)
from .spec import TABLE_FORMATS, table_format_problem
from .yamlread import Node, raw_text, type_name
from ..forces.keys import BODY_KEYS as FORCE_BODY_KEYS, validate_forces

TOP_KEYS = ("name", "units", "parameters", "bodies", "joints", "drivers", "points", "analysis",
            "assembly", "output", "gravity", "loads", "links", "ground", "sliders", "slots",
            "measures",
            "lengths", "design")
# \Z, not $: '$' also matches before a final newline, which would let "a\n" into CSV headers
NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*\Z")
UNIT_RE = re.compile(r"[A-Za-z\u00b5\u03bc]{1,12}\Z")    # m, mm, in, ft, um, µm ...
TURN = 2 * math.pi
RESERVED = {"t", "pi", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh",
            "tanh", "exp", "log", "sqrt", "abs"} | set(function_names())
MAX_SEGMENTS = 100       # segments of one motion: profile (longer motions: a table)
MAX_MAGNITUDE = 1e100    # squares and products of lengths must stay far from overflow


class _Validator:
    def __init__(self, root: Node, file: str, overrides: dict | None = None):
        self.root = root
        self.file = file
        self.C = Collector(file)
        self.params: dict[str, float] = {}
        self.broken: set[str] = set()   # parameters reported invalid (uses: not again)
        self.overrides = dict(overrides or {})
        self.body_names: list[str] = []
        self.body_set: set[str] = set()
        self.bodies_ok = True        # False when the bodies section itself is broken
        self.sketch = None           # planarkin.model.sketch.Sketch (pins and links)
        self.sketch_tolerance = None  # assembly: sketch_tolerance (user length unit)

    # -- small typed readers -------------------------------------------------------------------
    def err(self, node_or_line, msg: str) -> None:
        line = node_or_line if isinstance(node_or_line, int) or node_or_line is None \
            else node_or_line.line
        self.C.error(line, msg)

    def keys(self, node: Node, allowed, what: str) -> bool:
        """Report unknown keys of a mapping; False if node is not a mapping."""
        if node.kind != "map":
            self.err(node, f"{what} must be a mapping (key: value), not {type_name(node)}")
            return False
        for key in node.value:
            if key not in allowed:
                hint = did_you_mean(key, allowed) or " (valid keys: " + ", ".join(allowed) + ")"
                self.err(node.key_lines[key], f"{what}: unknown key '{key}'{hint}")
        return True

    def number(self, node: Node, what: str) -> float | None:
        if node.kind != "scalar" or node.value is None or isinstance(node.value, bool):
            self.err(node, f"{what} must be a number or an expression, not {type_name(node)}")
            return None
        v = node.value
        try:
            x = evaluate_constant(v if isinstance(v, str) else float(v), self.params)
        except ExprError as e:
            if not (isinstance(v, str) and self.broken & set(re.findall(r"[A-Za-z_]\w*", v))):
                self.err(node, f"{what}: {e}")   # (else a consequence of a reported parameter)
            return None
        except OverflowError:
            self.err(node, f"{what}: the number {node.text} is too large")
            return None
        if not math.isfinite(x):
            self.err(node, f"{what} must be finite, not {node.text}")
            return None
        if abs(x) > MAX_MAGNITUDE:
            self.err(node, f"{what}: {x:.3g} is too large (numbers up to {MAX_MAGNITUDE:g} in "
                           f"magnitude are accepted)")
            return None
        return x

    def vector(self, node: Node, what: str, size: int = 2) -> tuple | None:
        if node.kind != "seq":
            self.err(node, f"{what} must be a list of {size} numbers, not {type_name(node)}")
            return None
        if len(node.value) != size:
            self.err(node, f"{what} must have {size} numbers, got {len(node.value)}")
            return None
        vals = [self.number(item, what) for item in node.value]
        return None if any(v is None for v in vals) else tuple(vals)

    def table_ref(self, node: Node, what: str, columns: tuple, extra: tuple = (),
                  contents: str = ""):
        """A `table:` reference (drivers, cam laws, curves): a file name, or a map of `file`,
        the `columns` keys (a column name or 0-based number each) and the `extra` keys.
        Returns (file name, {column key: name or number}, the map's entries) or None, the
        problem reported. contents: what the file holds, for the missing-file message."""
        if node.kind == "map":
            if not self.keys(node, ("file", *columns, *extra), what):
                return None
            v = node.value
            if "file" not in v:
                self.err(node, f"{what}: missing file (the CSV file{contents}, relative to the "
                               f"model file)")
                return None
            fname = self.text(v["file"], f"{what}: file")
        else:
            v = {}
            fname = self.text(node, what)
        if fname is None:
            return None
        cols = {}
        for key in columns:
            if key in v:
                n = v[key]
                if n.kind != "scalar" or n.value is None or isinstance(n.value, bool):
                    self.err(n, f"{what}: {key} must be a column name or number, not "
                                f"{type_name(n)}")
                    return None
                cols[key] = n.value if isinstance(n.value, int) else str(n.text)
        return fname, cols, v

    def table_errors(self, exc, node: Node, what: str, shown: str, whose: str) -> None:
        """A TableError's problems: at the table file's own line (naming `whose` table it is),
        or, for a problem of the whole file, at the model's `table:` node."""
        from ..diagnostics import Diagnostic
        for line, msg in exc.args[0]:
            if line is None:
                self.err(node, f"{what}: {shown}: {msg}")
            else:
                self.C.items.append(Diagnostic(shown, line, f"{msg} ({whose})"))

    def text(self, node: Node, what: str) -> str | None:
        if node.kind != "scalar" or node.value is None:
            self.err(node, f"{what} must be a text, not {type_name(node)}")
            return None
        return str(node.text if node.text is not None else node.value)

    def body_ref(self, node: Node, what: str, allow_ground: bool = True) -> str | None:
        name = self.text(node, what)
        if name is None:
            return None
        if not self.bodies_ok:
            return name if name in self.body_set or name == "ground" else None
        if name == "ground":
            if allow_ground:
                return name
            self.err(node, f"{what}: 'ground' is not a moving body here")
            return None
        if name not in self.body_set:
            choices = self.body_names + (["ground"] if allow_ground else [])
            hint = did_you_mean(name, choices)
            if not hint:
                shown = ", ".join(self.body_names[:10]) + (", ..." if len(self.body_names) > 10
                                                            else "")
                hint = f" (bodies: {shown or 'none defined'})"
            self.err(node, f"{what}: unknown body '{name}'{hint}")
            return None
        return name

    def choice(self, node: Node, what: str, choices) -> str | None:
        s = self.text(node, what)
        if s is None:
            return None
        if s not in choices:
            self.err(node, f"{what} must be {one_of(choices)}, not '{s}'{did_you_mean(s, choices)}")
            return None
        return s

    def identifier(self, key: str, line: int, what: str) -> bool:
        if not NAME_RE.match(key):
            self.err(line, f"{what} name '{key}' is not valid: use letters, digits, '_' and '-', "
                           f"starting with a letter")
            return False
        return True

    # -- sections -------------------------------------------------------------------------------
    def run(self) -> ModelSpec | None:
        root = self.root
        if root.kind != "map":
            self.err(root, f"a model file must be a mapping with keys {', '.join(TOP_KEYS)}; "
                           f"found {type_name(root)}")
            self.C.raise_if_any()
        self.keys(root, TOP_KEYS, "model")
        sketched = "links" in root.value
        for req in ("bodies", "joints"):
            if req not in root.value and not sketched:
                self.err(None if not root.value else 1,
                         f"model: missing '{req}'" + (" (the moving bodies: name: {q: [x, y, phi]})"
                                                      if req == "bodies" else
                                                      " (the joints: a list of {type: ..., i: ..., j: ...})"))
        name = Path(self.file).stem
        if "name" in root.value:
            name = self.text(root.value["name"], "name") or name
        length_unit, angle_unit = self.units(root.value.get("units"))
        self.angle_unit = angle_unit
        self.parameters(root.value.get("parameters"))
        from .sketch import Sketch
        sk = self.sketch = Sketch(self, root.value)
        bodies = self.bodies(root.value.get("bodies"))
        sk.register_links()
        bodies += sk.bodies(angle_unit)
        if sketched and not self.body_names and "bodies" not in root.value:
            self.err(root.value["links"], "links is empty: a mechanism needs at least one "
                                          "moving link, e.g. crank: [O, A]")
        joints = self.elements(root.value.get("joints"), "joint")
        file_joints = list(joints)
        joints += sk.joints(len(joints) + 1)
        drivers = self.elements(root.value.get("drivers"), "driver")
        self.unique_names(joints + drivers)
        points = self.points(root.value.get("points"))
        file_points = list(points)
        names = {p.name for p in points}
        points += [p for p in sk.points() if p.name not in names]
        from ..measures import read_measures
        measures = read_measures(self, root.value.get("measures"), [p.name for p in points],
                                 {el.name: el for el in joints if el.name})
        from ..synthesis.spec import read_design
        read_design(self, root.value.get("design"), [p.name for p in points], len(drivers))
        analysis = self.analysis(root.value.get("analysis"))
        self.check_drivers(drivers, analysis)
        output = self.output(root.value.get("output"), points, drivers)
        if output.order >= 3 and analysis.interpolate:
            self.err(root.value["output"].value["up_to"], "output: up_to: jerk needs the exact "
                     "solve at every grid row, and analysis: interpolate: true interpolates the "
                     "rows: set interpolate: false or stop at acceleration")
        branch, branch_lines = self.assembly(root.value.get("assembly"))
        self.angle_units(bodies, angle_unit, root)
        forces = validate_forces(self, root)
        sk.check_placements(file_joints, file_points, forces)
        self.C.raise_if_any()
        return ModelSpec(name=name, file=self.file, length_unit=length_unit, angle_unit=angle_unit,
                         parameters=dict(self.params), bodies=tuple(bodies), joints=tuple(joints),
                         drivers=tuple(drivers), points=tuple(points), analysis=analysis,
                         output=output, branch=branch, branch_lines=branch_lines,
                         sketch_tolerance=self.sketch_tolerance,
                         section_lines=dict(root.key_lines or {}), forces=forces, measures=measures,
                         overrides={k: self.params[k] for k in self.overrides
                                    if k in self.params},
                         warnings=tuple(d for d in self.C.items if d.severity == "warning"))

    def angle_units(self, bodies: list[BodySpec], angle_unit: str, root: Node) -> None:
        """A likely degree/radian mix-up: body angles of more than a turn in a model in rad."""
        if angle_unit != "rad":
            return
        big = [b for b in bodies if abs(b.q[2]) > TURN]
        if big:
            shown = ", ".join(f"{b.name} {b.q[2]:g}" for b in big[:4])
            self.C.warning(big[0].line, f"body angles of more than a turn in radians ({shown}): "
                                        f"if they are degrees, write units: {{angle: deg}} (the "
                                        f"model's angle unit is rad)")

    def units(self, node: Node | None):
        length, angle = "m", "rad"
        if node is None or not self.keys(node, ("length", "angle"), "units"):
            return length, angle
        if "length" in node.value:
            n = node.value["length"]
            text = self.text(n, "units: length")
            if text is not None and not UNIT_RE.match(text):
                self.err(n, f"units: length {text!r} is not a unit name: write letters only "
                            f"(m, mm, cm, in, ft, um, ...); it labels every column")
            elif text is not None:
                length = text
        if "angle" in node.value:
            angle = self.choice(node.value["angle"], "units: angle", ("rad", "deg")) or angle
        return length, angle

    def parameters(self, node: Node | None) -> None:
        if node is not None and node.kind != "map":
            self.err(node, f"parameters must be a mapping of names to values, not {type_name(node)}")
            return
        items = node.value.items() if node is not None else ()
        known = [k for k, _ in items]
        for key in self.overrides:
            if key not in known:
                hint = did_you_mean(key, known) or (
                    f" (parameters: {', '.join(known)})" if known else
                    " (the model has no parameters: section)")
                self.err(node.line if node is not None else None,
                         f"{override_word(key)}: unknown parameter '{key}'{hint}")
        for key, val in items:
            line = node.key_lines[key]
            if not self.identifier(key, line, "parameter"):
                continue
            if key in RESERVED or key == "ground":
                self.err(line, f"parameter name '{key}' is reserved (t, pi and the function "
                               f"names cannot be parameters)")
                continue
            later = None if key in self.overrides else self._defined_later(node, key, val)
            if later:
                name, at = later
                self.err(val, f"parameter '{key}' uses '{name}', which is defined later (line "
                              f"{at}): parameters are read top to bottom; move '{name}' above "
                              f"'{key}'")
                continue
            if key in self.overrides:
                # the override takes the place of the file's value, so every parameter and number
                # after it is evaluated with it
                x = self.override(key, self.overrides[key], val)
            else:
                x = self.number(val, f"parameter '{key}'")
            if x is not None:
                self.params[key] = x
            else:
                self.broken.add(key)


    def override(self, key: str, value, node: Node) -> float | None:
        """The value of parameter key given by --set / load(key=...): a number or an expression
        of the parameters before it (reported at the parameter's line)."""
        what = f"{override_word(key, value)}: parameter '{key}'"
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            self.err(node, f"{what} must be a number or an expression, not {value!r}")
            return None
        return self.number(Node("scalar", value, node.line, text=str(value)), what)

    def _defined_later(self, node: Node, key: str, val: Node):
        """(name, line) of a parameter after `key` that val's expression uses, or None."""
        if val.kind != "scalar" or not isinstance(val.value, str):
            return None
        keys = list(node.value)
        used = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", val.value))
        for k in keys[keys.index(key) + 1:]:
            if k in used and k not in self.params:
                return k, node.key_lines[k]
        return None

    def bodies(self, node: Node | None) -> list[BodySpec]:
        out: list[BodySpec] = []
        if node is None:
            return out
        if node.kind != "map":
            self.err(node, "bodies must be a mapping of body names to {q: [x, y, phi]}, "
                           f"not {type_name(node)}")
            self.bodies_ok = False
            return out
        # names first, so that joints can refer to any body regardless of order
        for key in node.value:
            line = node.key_lines[key]
            if key == "ground":
                self.err(line, "body 'ground' is implicit (origin, angle 0): do not list it under "
                               "bodies")
            elif self.identifier(key, line, "body"):
                self.body_names.append(key)
                self.body_set.add(key)
        if not node.value and "links" not in self.root.value:
            self.err(node, "bodies is empty: a mechanism needs at least one moving body")
        for key, val in node.value.items():
            if key not in self.body_set:
                continue
            what = f"body '{key}'"
            if val.kind == "seq":
                self.err(val, f"{what}: write {{q: [x, y, phi]}} (the estimated pose at t = start)")
                continue
            if not self.keys(val, ("q",) + FORCE_BODY_KEYS, what):
                continue
            if "q" not in val.value:
                self.err(val, f"{what}: missing q: [x, y, phi] (its estimated pose at t = start)")
                continue
            q = self.vector(val.value["q"], f"{what}: q", 3)
            if q is not None:
                out.append(BodySpec(key, q, val.line))
        return out

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

    def element(self, node: Node, role: str, idx: int) -> ElementSpec | None:
        kinds = JOINT_KINDS if role == "joint" else DRIVER_KINDS
        what = f"{role} {idx}"
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
            if kind.name == "distance":
                allowed.append("between")
        between = None
        if role == "driver" and "between" in v and kind.name == "distance":
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
        # parameters
        pnames = [p.name for p in kind.params]
        allowed += pnames
        has_at = kind.at_form is not None and role == "joint"
        if has_at:
            allowed.append("at")
            if kind.name in ("translational", "pin-slot"):
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
        at = axis = None
        if has_at and "at" in v:
            at = self.placement(v["at"], kind, what)
            clash = [p for p in pnames if p in v and kind.params[pnames.index(p)].unit in
                     ("point", "vector")]
            if clash:
                self.err(v["at"], f"{what}: give either at or {', '.join(clash)}, not both")
            if "axis" in allowed:
                if "axis" not in v:
                    self.err(v["at"], f"{what}: with at, give axis: [dx, dy] (the slide direction)")
                else:
                    axis = self.direction(v["axis"], f"{what}: axis")
        elif "axis" in v and "at" not in v:
            self.err(v["axis"], f"{what}: axis is used with at; give at: [x, y] too")
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
            elif kind.name == "pin-slot":
                target = 0.0
            elif not (kind.name == "distance" and at is not None):
                self.err(node, f"{what}: missing {kind.target} (the constant value"
                               f"{', in ' + kind.target_unit + ' units' if kind.target_unit else ''})")
            if kind.name == "distance" and target is not None and target <= 0:
                self.err(v[kind.target], f"{what}: the distance c must be positive, not {target:g} "
                                         f"(for a zero distance use a revolute joint)")
        if role == "driver":
            f = self.driver_function(node, v, what, lines)
        if "vi" in params and "vj" in params and kind.name == "translational":
            pass
        kind.validate(self, params, v, what)
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
        return tuple(pts)

    def direction(self, node: Node, what: str):
        vec = self.vector(node, what)
        if vec is not None and vec[0] == 0 and vec[1] == 0:
            self.err(node, f"{what} is a zero vector; give a direction such as [1, 0]")
            return None
        return vec

    def placement(self, node: Node, kind, what: str):
        if kind.name == "distance":
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
            return TimeFunction(v if isinstance(v, str) else float(v), self.params)
        except ExprError as e:
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
        from ..laws import ALIASES, LAWS, law
        from ..motion import Segment, profile
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
        if over is not None:
            return out, initial, t0, repeat
        try:
            return profile(out, initial, t0, repeat)
        except ExprError as e:
            self.err(node, f"{what}: {e}")
            return None

    def table(self, node: Node, what: str):
        from ..diagnostics import Diagnostic
        from ..inputtable import TableError, read_table, table_function
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

    def points(self, node: Node | None) -> list[PointSpec]:
        out: list[PointSpec] = []
        if node is None:
            return out
        if node.kind != "map":
            self.err(node, "points must be a mapping of point names to {body: NAME, s: [x, y]}, "
                           f"not {type_name(node)}")
            return out
        for key, val in node.value.items():
            line = node.key_lines[key]
            if not self.identifier(key, line, "point"):
                continue
            what = f"point '{key}'"
            if not self.keys(val, ("body", "s", "at", "ground"), what):
                continue
            if "body" not in val.value and "at" in val.value and "s" not in val.value:
                continue        # a sketch pin: planarkin.model.sketch reads it
            if "ground" in val.value and "body" in val.value:
                self.err(val.value["ground"], f"{what}: ground: true marks a sketch pin (at: "
                                              f"[x, y] without body); drop body or ground")
                continue
            if "body" not in val.value:
                self.err(val, f"{what}: missing body (the body that carries the point)")
                continue
            body = self.body_ref(val.value["body"], f"{what}: body", allow_ground=False)
            s = at = None
            if "s" in val.value and "at" in val.value:
                self.err(val.value["at"], f"{what}: give either s or at, not both")
            elif "s" in val.value:
                s = self.vector(val.value["s"], f"{what}: s")
            elif "at" in val.value:
                at = self.vector(val.value["at"], f"{what}: at")
            else:
                self.err(val, f"{what}: missing s: [x, y] (body frame) or at: [x, y] (global, at "
                              f"the assembly pose)")
                continue
            if body is not None and (s is not None or at is not None):
                out.append(PointSpec(key, body, s, at, val.line))
        return out

    def analysis(self, node: Node | None) -> AnalysisSpec:
        """The analysis: block, every key checked by the rules of planarkin.options (the same
        rules and words as the command line and the API)."""
        if node is None or not self.keys(node, ANALYSIS_KEYS, "analysis"):
            spec = AnalysisSpec()
            self.check_analysis(spec, {})
            return spec
        v = node.value
        vals: dict[str, Any] = {}
        lines = {k: v[k].line for k in v}
        for key, n in v.items():
            if key not in OPTIONS:
                continue
            val = self.option(n, key, f"analysis: {key}")
            if val is not None:
                vals[key] = val
        spec = AnalysisSpec(**vals, line=node.line, lines=lines)
        self.check_analysis(spec, vals)
        return spec

    def option(self, n: Node, key: str, what: str):
        """One option's value from its node (numbers may be expressions), or None (reported)."""
        opt = OPTIONS[key]
        if opt.kind in ("float", "int"):
            x = self.number(n, what)
            if x is None:
                return None
        elif opt.kind == "bool":
            if not (n.kind == "scalar" and isinstance(n.value, bool)):
                self.err(n, f"{what} must be true or false, not {type_name(n)}")
                return None
            x = n.value
        else:
            x = self.text(n, what)
            if x is None:
                return None
        val, msg = opt.check(x)
        if msg is not None:
            self.err(n, f"{what} {msg}")
            return None
        return val

    def check_analysis(self, a: AnalysisSpec, given: dict) -> None:
        vals = {k: getattr(a, k) for k in ANALYSIS_KEYS}
        vals["up_to"] = "acceleration"
        for d in cross_check(self.file, a, vals, {k: "yaml" for k in given}):
            self.C.items.append(d)

    def output(self, node: Node | None, points: list[PointSpec], drivers=()) -> OutputSpec:
        if node is None or not self.keys(node, ("bodies", "points", "up_to", "centres", "x",
                                                 "table_format"),
                                         "output"):
            return OutputSpec()
        v = node.value
        vals: dict[str, Any] = {}
        for key, names in (("bodies", self.body_names), ("points", [p.name for p in points])):
            if key not in v:
                continue
            n = v[key]
            if n.kind != "seq":
                self.err(n, f"output: {key} must be a list of names, not {type_name(n)}")
                continue
            chosen = []
            for item in n.value:
                s = self.text(item, f"output: {key}")
                if s is None:
                    continue
                if s not in names:
                    self.err(item, f"output: {key}: unknown {key[:-1]} '{s}'{did_you_mean(s, names)}")
                else:
                    chosen.append(s)
            vals[key] = tuple(chosen)
        if "centres" in v:
            n = v["centres"]
            if n.kind == "scalar" and isinstance(n.value, bool):
                vals["centres"] = n.value
            elif n.kind == "scalar" and n.value in ("fixed", "moving"):
                vals["centres"] = True
                vals["moving_centrodes"] = n.value == "moving"
            else:
                self.err(n, f"output: centres must be true, false, fixed or moving (moving: "
                            f"mechanism.png also draws the moving centrodes), not "
                            f"{type_name(n)}")
        if "up_to" in v:
            c = self.option(v["up_to"], "up_to", "output: up_to")
            if c is not None:
                vals["order"] = ORDERS.index(c)
        if "x" in v:
            c = self.choice(v["x"], "output: x", X_AXES)
            problem = c and x_axis_problem(c, drivers, "output: x")
            if problem:
                self.err(v["x"], problem)
            elif c is not None:
                vals["x"] = c
        if "table_format" in v:
            c = self.choice(v["table_format"], "output: table_format", TABLE_FORMATS)
            problem = c and table_format_problem(c, "output: table_format")
            if problem:
                self.err(v["table_format"], problem)
            elif c is not None:
                vals["table_format"] = c
        return OutputSpec(**vals)

    def assembly(self, node: Node | None):
        if node is None or not self.keys(node, ("branch", "sketch_tolerance"), "assembly"):
            return {}, {}
        if "sketch_tolerance" in node.value:
            tn = node.value["sketch_tolerance"]
            x = self.number(tn, "assembly: sketch_tolerance")
            if x is not None and not x >= 0:
                self.err(tn, f"assembly: sketch_tolerance must be a length >= 0 (pins moved by "
                             f"more are warned about), not {x:g}")
            elif x is not None:
                self.sketch_tolerance = x
        b = node.value.get("branch")
        if b is None:
            return {}, {}
        if b.kind != "map":
            self.err(b, "assembly: branch must map a body name to + or - (see `planarkin check`), "
                        f"not {type_name(b)}")
            return {}, {}
        out, lines = {}, {}
        for key, val in b.value.items():
            line = b.key_lines[key]
            if key not in self.body_set:
                self.err(line, f"assembly: branch: unknown body '{key}'"
                               f"{did_you_mean(key, self.body_names)}")
                continue
            s = val.text if val.kind == "scalar" else None
            if s in ("+", "+1", "1"):
                out[key] = 1
            elif s in ("-", "-1"):
                out[key] = -1
            else:
                self.err(val, f"assembly: branch: {key} must be + or -, not {type_name(val)}")
                continue
            lines[key] = line
        return out, lines


def _target_param(kind):
    from ..elements import Param
    return Param(kind.target, kind.target_unit or "real", "constant")


def validate(root: Node, file: str, overrides: dict | None = None) -> ModelSpec:
    """Validate the node tree of one model file; raises InputError with every problem found.

    overrides: parameter name -> number or expression text, replacing the file's values (the
    parameters and numbers that depend on them are evaluated with the new values). Tables are
    read from the model's folder only (planarkin.inputtable.confined)."""
    from ..inputtable import confined
    with confined(file):
        return _Validator(root, file, overrides).run()
