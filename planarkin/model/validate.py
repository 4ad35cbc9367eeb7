"""Validate a YAML node tree into a `ModelSpec` (user units), collecting every problem of the file.

Each message names the element (``joint 3 (revolute crank-rod)``), says what is wrong and, where
possible, the fix; it is reported at the line of the offending node. One method per section of
the file; the joints: and drivers: sections are read by planarkin.model.joints (the kind
registry, `planarkin.elements.KINDS`, tells which keys each joint and driver kind takes).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from ..diagnostics import Collector, did_you_mean, one_of
from planarkin.functions.expr import ExprError, evaluate_constant, function_names
from ..options import ANALYSIS_KEYS, OPTIONS, ORDERS, cross_check, override_word
from .spec import (X_AXES, AnalysisSpec, BodySpec, ModelSpec, OutputSpec, PointSpec,
                   x_axis_problem)
from .spec import TABLE_FORMATS, table_format_problem
from .joints import ElementSections
from .yamlread import Node, type_name
from ..forces.keys import BODY_KEYS as FORCE_BODY_KEYS, validate_forces

TOP_KEYS = ("name", "units", "parameters", "bodies", "joints", "drivers", "points", "analysis",
            "assembly", "output", "gravity", "loads", "links", "ground", "sliders", "slots",
            "measures", "shapes", "clearance", "limits",
            "lengths", "design")
# \Z, not $: '$' also matches before a final newline, which would let "a\n" into CSV headers
NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_\-]*\Z")
UNIT_RE = re.compile(r"[A-Za-z\u00b5\u03bc]{1,12}\Z")    # m, mm, in, ft, um, µm ...
TURN = 2 * math.pi
RESERVED = {"t", "pi", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh",
            "tanh", "exp", "log", "sqrt", "abs"} | set(function_names())
MAX_MAGNITUDE = 1e100    # squares and products of lengths must stay far from overflow
MAX_ERRORS = 100         # errors reported before the validator stops reading
# named points (sketch pins included): 2048 points are 16,384 columns of points.csv with jerks,
# as wide as a spreadsheet opens
MAX_POINTS = 2048


class _Validator(ElementSections):
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
        self.error_count = 0         # err() calls: the reading stops at MAX_ERRORS
        self._places = None          # (parameters node, name -> place, names): _defined_later

    # -- small typed readers -------------------------------------------------------------------
    def err(self, node_or_line, msg: str) -> None:
        line = node_or_line if isinstance(node_or_line, int) or node_or_line is None \
            else node_or_line.line
        self.C.error(line, msg)
        self.error_count += 1
        if self.error_count >= MAX_ERRORS:
            # a file of thousands of broken elements: each error may search every name for
            # the one meant, so the reading stops here
            self.C.error(None, f"{MAX_ERRORS} errors, and the file was not read further: "
                               f"mend these first")
            self.C.raise_if_any()

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

    def of_broken(self, v) -> bool:
        """Whether expression v names a parameter already reported invalid (its error is then a
        consequence, not reported again)."""
        return isinstance(v, str) and bool(self.broken & set(re.findall(r"[A-Za-z_]\w*", v)))

    def number(self, node: Node, what: str) -> float | None:
        if node.kind != "scalar" or node.value is None or isinstance(node.value, bool):
            self.err(node, f"{what} must be a number or an expression, not {type_name(node)}")
            return None
        v = node.value
        try:
            x = evaluate_constant(v if isinstance(v, str) else float(v), self.params)
        except ExprError as e:
            if not self.of_broken(v):
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
        if len(points) > MAX_POINTS:
            self.err(root.key_lines.get("points") if root.key_lines else None,
                     f"points: {len(points)} points, more than {MAX_POINTS} (the budget: each "
                     f"is 6-8 columns of points.csv with statistics in summary.json, a path in "
                     f"the plots and a share of every grid row's memory): keep the points you "
                     f"need, or analyse a grid of them in parts")
        from ..measures import read_measures
        measures = read_measures(self, root.value.get("measures"), [p.name for p in points],
                                 {el.name: el for el in joints if el.name})
        clearance = None
        if any(k in root.value for k in ("shapes", "clearance", "limits")):
            from ..clearance.keys import read_clearance     # only a file with these keys
            clearance = read_clearance(self, root, points,
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
                         clearance=clearance,
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
        from ..forces.units import UNIT_KEYS, read_units    # force, mass, system: forces room
        length, angle = "m", "rad"
        self.unit_choice = None
        if node is None or not self.keys(node, UNIT_KEYS, "units"):
            return length, angle
        given = False
        if "length" in node.value:
            n = node.value["length"]
            text = self.text(n, "units: length")
            if text is not None and not UNIT_RE.match(text):
                self.err(n, f"units: length {text!r} is not a unit name: write letters only "
                            f"(m, mm, cm, in, ft, um, ...); it labels every column")
            elif text is not None:
                length, given = text, True
        if "angle" in node.value:
            angle = self.choice(node.value["angle"], "units: angle", ("rad", "deg")) or angle
        self.unit_choice = read_units(self, node, length, given)
        return self.unit_choice.length, angle

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
        # the parameters' places, once per mapping (looked up from every parameter's text)
        if self._places is None or self._places[0] is not node:
            self._places = (node, {k: i for i, k in enumerate(node.value)}, list(node.value))
        _, place, keys = self._places
        used = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", val.value))
        later = [place[k] for k in used if k in place and place[k] > place[key]
                 and k not in self.params]
        if not later:
            return None
        k = keys[min(later)]
        return k, node.key_lines[k]

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



def validate(root: Node, file: str, overrides: dict | None = None) -> ModelSpec:
    """Validate the node tree of one model file; raises InputError with every problem found.

    overrides: parameter name -> number or expression text, replacing the file's values (the
    parameters and numbers that depend on them are evaluated with the new values). Tables are
    read from the model's folder only (planarkin.functions.inputtable.confined)."""
    from planarkin.functions.inputtable import confined
    with confined(file):
        return _Validator(root, file, overrides).run()
