"""The `design:` block of a model file: free parameters, targets, constraints, search settings.

    design:
      free: {a: [5, 60], b: [5, 60]}        # parameters of `parameters:` with [low, high] bounds
      targets:
        - {path: P, points: [[20, 20], [20, 25]], inputs: [0, 30]}     # inputs optional
        - {function: rocker.phi, inputs: [0, 30, 60], outputs: [80, 92, 101]}
        - {motion: coupler, point: P, poses: [[x, y, phi], ...], inputs: [...]}
        - {path: P, points: [[20, 20], ..., [20, 20]]}   # closed: the first point again last
          # (or closed: true): free timing in order around one turn (Target.closed)
        - {path: P, points: [...], inputs: {offset: free, step: 60}}   # inputs offset + 60 k,
          # the offset found (Timing; values: [...] relative to it instead of step; offset and
          # step each a number, free or [low, high]; offset free when left out)
      constraints:
        turns: crank                          # the driven link turns fully over the range
                                              # ({body: crank, shortest: true}: a four-bar
                                              # loop with the crank its shortest link)
        transmission: {points: [B, C, D], min: 30}
        order: true                           # free-timing targets in order along the path
                                              # (either direction: the input may turn back)
      search: {starts: 200, local: 10, keep: 1, seed: 0, goal: 1e-12, evaluations: 2000,
               per_local: 300}       # per_local: evaluations of one local run
      # local: runs a draw, from its best starts (default 10; with probe, every accepted start
      # of the draw: probed runs are short); keep: distinct designs written
      # evaluations, time (s, 0: none): the budgets; the search draws `starts` starts at a
      # time from one seeded sequence (at most `local` runs a draw) until the goal is met or a
      # budget runs out, and ends with the best designs so far
      # batch: starts analysed at a time (0: all), the search stopping once the goal is met;
      # probe, probe_cost: abandon a local run above probe_cost after probe trials (and
      # above 1e-2, 1e-4 of it after a third more, twice as many: local.probe_limits)
      # band: how near the Grashof wall of a turns: constraint the local runs may go, a
      # fraction of the loop's length sum (margins.barrier)

Targets are in the model's units (length unit for points, angle unit for angles); `inputs` are
values of the model's one driver (its f, in its unit); without them the timing is free (the
input values are extra unknowns). Validated with the rest of the file (planarkin.model.validate
calls `read_design`), so every problem is a FILE:LINE error; `design_of` gives the DesignSpec of
a validated model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..diagnostics import Collector, Diagnostic, InputError, did_you_mean

KEYS = ("free", "targets", "constraints", "search")
TARGET_KINDS = ("path", "function", "motion")
TARGET_KEYS = {"path": ("path", "points", "inputs", "weight", "closed"),
               "function": ("function", "inputs", "outputs", "weight"),
               "motion": ("motion", "point", "poses", "inputs", "weight", "closed")}
CONSTRAINT_KEYS = ("turns", "transmission", "order")
INPUT_KEYS = ("offset", "step", "values")      # inputs: {...}, relative to an unknown offset
TURNS_KEYS = ("body", "shortest")
SEARCH = {"starts": (int, 1, 100_000, 200), "local": (int, 1, 10_000, None),
          "keep": (int, 1, 1000, 1), "seed": (int, 0, 2**32 - 1, 0),
          "goal": (float, 0.0, math.inf, 0.0), "evaluations": (int, 1, 10**7, 2000),
          "per_local": (int, 1, 10**6, 300), "nominal": (int, 0, 1, 0),
          "batch": (int, 0, 100_000, 0), "probe": (int, 0, 10**6, 0),
          "probe_cost": (float, 0.0, math.inf, 1e-2), "time": (float, 0.0, 1e7, 0.0),
          "band": (float, 0.0, 1.0, 0.01)}
QUANTITIES = ("x", "y", "phi")


@dataclass(frozen=True)
class Target:
    """One target. kind 'path' | 'function' | 'motion'; name: the point (path), BODY.QUANTITY
    (function) or body (motion); point: the motion's point; values: (N, 2) points, (N,) outputs
    or (N, 3) poses in user units; inputs: (N,) driver values or None (free timing, or timing
    relative to an unknown offset: Timing)."""

    kind: str
    name: str
    point: str | None
    values: tuple
    inputs: tuple | None
    weight: float
    line: int
    closed: bool = False    # free timing around one turn (the order is cyclic)
    repeat: bool = False    # closed, the last point repeating the first (one turn after it)
    timing: Timing | None = None    # inputs relative to an unknown offset (inputs: {...})

    @property
    def free_timing(self) -> bool:
        """No inputs given: each input value is an unknown (or a projection)."""
        return self.inputs is None and self.timing is None

    @property
    def label(self) -> str:
        return f"{self.kind} {self.name}" + (f" ({self.point})" if self.point else "")

    def __len__(self) -> int:
        return len(self.values)


@dataclass(frozen=True)
class Timing:
    """A target's inputs relative to one offset: input e is offset + values[e] (values:) or
    offset + e step (step:), in the driver's unit. offset, step: the value given, or None for
    an unknown of the search, found within its bounds (offset_bounds, step_bounds: (low,
    high) given, or None: planarkin.synthesis.timing's default)."""

    n: int
    values: tuple | None = None
    offset: float | None = None
    step: float | None = None
    offset_bounds: tuple | None = None
    step_bounds: tuple | None = None
    line: int = 0

    @property
    def unknowns(self) -> tuple:
        """The names of the unknowns, in the order of the search's layout."""
        return tuple(n for n, given in (("offset", self.offset), ("step", self.step))
                     if given is None and (n == "offset" or self.values is None))

    def relative(self, step=None) -> list:
        """(n,) each input less the offset (step: the step's value when it is an unknown)."""
        if self.values is not None:
            return [float(u) for u in self.values]
        return [e * (self.step if self.step is not None else step) for e in range(self.n)]


@dataclass(frozen=True)
class DesignSpec:
    free: dict                          # name -> (low, high), user units
    targets: tuple
    turns: str | None = None
    transmission: tuple | None = None   # ((B, C, D), min angle in the model's angle unit)
    order: bool = True
    search: dict = field(default_factory=dict)
    line: int = 0
    lines: dict = field(default_factory=dict)     # free parameter -> line
    shortest: bool = False      # turns: {body: B, shortest: true}: B the shortest link


def _valid(keys) -> str:
    return " (valid keys: " + ", ".join(keys) + ")"


def _seq(v, node, what, size=None):
    if node.kind != "seq" or (size is not None and len(node.value) != size):
        v.err(node, f"{what} must be a list" + (f" of {size} numbers" if size else ""))
        return None
    return node.value


def _numbers(v, node, what, size):
    items = _seq(v, node, what, size)
    if items is None:
        return None
    out = [v.number(n, what) for n in items]
    return None if any(x is None for x in out) else tuple(out)


def read_design(v, node, point_names, n_drivers: int):
    """Validate a design node (None: no design block). v: the validator (err, number, params,
    body_names); returns a DesignSpec or None, every problem reported through v.err."""
    if node is None:
        return None
    if node.kind != "map":
        v.err(node, "design must be a mapping with keys " + ", ".join(KEYS))
        return None
    for key in node.value:
        if key not in KEYS:
            v.err(node.key_lines[key], f"design: unknown key '{key}'"
                  f"{did_you_mean(key, KEYS) or _valid(KEYS)}")
    free, lines = {}, {}
    fn = node.value.get("free")
    if fn is None or fn.kind != "map" or not fn.value:
        v.err(fn if fn is not None else node, "design: free must name at least one parameter "
              "with its bounds, e.g. free: {a: [0.02, 0.08]}")
    else:
        for name, b in fn.value.items():
            line = fn.key_lines[name]
            if name not in v.params:
                hint = did_you_mean(name, v.params) or \
                    f" (parameters: {', '.join(v.params) or 'none'})"
                v.err(line, f"design: free: '{name}' is not a parameter{hint}")
                continue
            lohi = _numbers(v, b, f"design: free: {name}", 2)
            if lohi is None:
                continue
            if not lohi[0] < lohi[1]:
                v.err(b, f"design: free: {name}: the bounds [{lohi[0]:g}, {lohi[1]:g}] must be "
                         f"[low, high] with low < high")
                continue
            free[name] = lohi
            lines[name] = line
    targets = []
    tn = node.value.get("targets")
    if tn is not None:
        for k, t in enumerate(_seq(v, tn, "design: targets") or (), start=1):
            tg = _target(v, t, k, point_names, n_drivers)
            if tg is not None:
                targets.append(tg)
    turns, trans, order, shortest = None, None, True, False
    cn = node.value.get("constraints")
    if cn is not None:
        if cn.kind != "map":
            v.err(cn, "design: constraints must be a mapping with keys "
                  + ", ".join(CONSTRAINT_KEYS))
        else:
            for key in cn.value:
                if key not in CONSTRAINT_KEYS:
                    v.err(cn.key_lines[key], f"design: constraints: unknown key '{key}'"
                          f"{did_you_mean(key, CONSTRAINT_KEYS) or _valid(CONSTRAINT_KEYS)}")
            if "turns" in cn.value:
                turns, shortest = _turns(v, cn.value["turns"])
            if "transmission" in cn.value:
                trans = _transmission(v, cn.value["transmission"], point_names)
            if "order" in cn.value:
                o = cn.value["order"]
                if o.kind != "scalar" or not isinstance(o.value, bool):
                    v.err(o, "design: constraints: order must be true or false")
                else:
                    order = o.value
    search = {k: d for k, (_, _, _, d) in SEARCH.items()}
    sn = node.value.get("search")
    if sn is not None:
        if sn.kind != "map":
            v.err(sn, "design: search must be a mapping with keys " + ", ".join(SEARCH))
        else:
            for key, val in sn.value.items():
                if key not in SEARCH:
                    v.err(sn.key_lines[key], f"design: search: unknown key '{key}'"
                          f"{did_you_mean(key, SEARCH) or _valid(SEARCH)}")
                    continue
                typ, lo, hi, _ = SEARCH[key]
                x = v.number(val, f"design: search: {key}")
                if x is None:
                    continue
                if (typ is int and x != int(x)) or not lo <= x <= hi:
                    v.err(val, f"design: search: {key} must be "
                               f"{'a whole number' if typ is int else 'a number'} from {lo:g} "
                               f"to {hi:g}, not {x:g}")
                    continue
                search[key] = typ(x)
    return DesignSpec(free=free, targets=tuple(targets), turns=turns, transmission=trans,
                      order=order, search=search, line=node.line, lines=lines,
                      shortest=shortest)


def _turns(v, b):
    """(body, shortest) of `turns: BODY` or `turns: {body: BODY, shortest: true|false}`;
    (None, False) after an error."""
    what = "design: constraints: turns"
    shortest = False
    if b.kind == "map":
        for key in b.value:
            if key not in TURNS_KEYS:
                v.err(b.key_lines[key], f"{what}: unknown key '{key}'"
                      f"{did_you_mean(key, TURNS_KEYS) or _valid(TURNS_KEYS)}")
                return None, False
        if "shortest" in b.value:
            sn = b.value["shortest"]
            if sn.kind != "scalar" or not isinstance(sn.value, bool):
                v.err(sn, f"{what}: shortest must be true or false")
                return None, False
            shortest = sn.value
        if "body" not in b.value:
            v.err(b, f"{what} must be BODY or {{body: BODY, shortest: true}}: missing body")
            return None, False
        b = b.value["body"]
    if b.kind != "scalar" or b.value not in v.body_names:
        v.err(b, f"{what} must name a moving body{did_you_mean(str(b.value), v.body_names)}")
        return None, False
    return b.value, shortest


def _transmission(v, node, point_names):
    what = "design: constraints: transmission"
    if node.kind != "map" or set(node.value) != {"points", "min"}:
        v.err(node, f"{what} must be {{points: [B, C, D], min: ANGLE}} (the angle at C between "
                    f"C -> B and C -> D, kept between min and 180 - min)")
        return None
    pts = _seq(v, node.value["points"], f"{what}: points", 3)
    mn = v.number(node.value["min"], f"{what}: min")
    if pts is None or mn is None:
        return None
    names = []
    for p in pts:
        if p.kind != "scalar" or p.value not in point_names:
            v.err(p, f"{what}: '{p.value}' is not a point of the model"
                     f"{did_you_mean(str(p.value), point_names)}")
            return None
        names.append(p.value)
    return tuple(names), mn


def _target(v, t, k, point_names, n_drivers):
    what = f"design: target {k}"
    if t.kind != "map":
        v.err(t, f"{what} must be a mapping with one of the keys {', '.join(TARGET_KINDS)}")
        return None
    kinds = [kk for kk in TARGET_KINDS if kk in t.value]
    if len(kinds) != 1:
        v.err(t, f"{what} needs exactly one of the keys {', '.join(TARGET_KINDS)} "
                 f"(path: POINT, function: BODY.QUANTITY, motion: BODY)")
        return None
    kind = kinds[0]
    ok = True
    for key in t.value:
        if key not in TARGET_KEYS[kind]:
            v.err(t.key_lines[key], f"{what} ({kind}): unknown key '{key}'"
                  f"{did_you_mean(key, TARGET_KEYS[kind]) or _valid(TARGET_KEYS[kind])}")
            ok = False
    nm = t.value[kind]
    name = nm.value if nm.kind == "scalar" else None
    point = None
    if kind == "path":
        if name not in point_names:
            v.err(nm, f"{what}: path: '{name}' is not a point of the model"
                      f"{did_you_mean(str(name), point_names)}")
            ok = False
        vals_key, width = "points", 2
    elif kind == "function":
        body, _, qty = str(name).rpartition(".")
        if body not in v.body_names or qty not in QUANTITIES:
            v.err(nm, f"{what}: function: '{name}' must be BODY.x, BODY.y or BODY.phi of a "
                      f"moving body{did_you_mean(body, v.body_names)}")
            ok = False
        vals_key, width = "outputs", None
    else:
        if name not in v.body_names:
            v.err(nm, f"{what}: motion: '{name}' is not a moving body"
                      f"{did_you_mean(str(name), v.body_names)}")
            ok = False
        pn = t.value.get("point")
        point = pn.value if pn is not None and pn.kind == "scalar" else None
        if point not in point_names:
            v.err(pn if pn is not None else t, f"{what}: motion needs point: a point of the "
                  f"model on body '{name}'{did_you_mean(str(point), point_names)}")
            ok = False
        vals_key, width = "poses", 3
    vn = t.value.get(vals_key)
    if vn is None:
        v.err(t, f"{what}: missing '{vals_key}'")
        return None
    rows = _seq(v, vn, f"{what}: {vals_key}")
    if rows is None:
        return None
    if not rows:
        v.err(vn, f"{what}: {vals_key} is empty")
        return None
    values = []
    for r in rows:
        x = _numbers(v, r, f"{what}: {vals_key}", width) if width else \
            v.number(r, f"{what}: {vals_key}")
        ok = ok and x is not None
        values.append(x)
    inode = t.value.get("inputs")
    if kind == "function" and inode is None:
        v.err(t, f"{what}: function generation needs inputs: the driver values, one per output")
        ok = False
    inputs, timing, good = _inputs(v, inode, what, len(rows), vals_key, n_drivers)
    ok = ok and good
    weight = 1.0
    if "weight" in t.value:
        w = v.number(t.value["weight"], f"{what}: weight")
        if w is None or not w > 0:
            if w is not None:
                v.err(t.value["weight"], f"{what}: weight must be > 0")
            ok = False
        else:
            weight = w
    closed = None
    if "closed" in t.value:
        cn = t.value["closed"]
        if cn.kind != "scalar" or not isinstance(cn.value, bool):
            v.err(cn, f"{what}: closed must be true or false")
            ok = False
        elif cn.value and inode is not None:
            v.err(cn, f"{what}: closed: true is for free timing (the points in order around "
                      f"one turn, their input values unknowns): remove inputs or closed")
            ok = False
        elif cn.value and len({tuple(x) for x in values if x is not None}) < 3:
            v.err(cn, f"{what}: closed: true needs at least 3 distinct {vals_key}")
            ok = False
        else:
            closed = cn.value
    if not ok:
        return None
    # the last point equal to the first, with free timing: a closed curve traced once per turn
    repeat = (closed is not False and inputs is None and timing is None and len(values) >= 4 and
              values[-1] == values[0])
    return Target(kind=kind, name=name, point=point, values=tuple(values), inputs=inputs,
                  weight=weight, line=t.line, closed=bool(closed) or repeat, repeat=repeat,
                  timing=timing)


def _inputs(v, inode, what, n, vals_key, n_drivers):
    """(inputs, timing, ok) of a target's inputs: node (None: free timing): a list of driver
    values, or a mapping relative to an unknown offset (_relative)."""
    if inode is None:
        return None, None, True
    inputs, timing = None, None
    if inode.kind == "map":
        inputs, timing = _relative(v, inode, f"{what}: inputs", n, vals_key)
        ok = inputs is not None or timing is not None
    else:
        inputs = _numbers(v, inode, f"{what}: inputs", None) if inode.kind == "seq" else None
        if inode.kind != "seq":
            v.err(inode, f"{what}: inputs must be a list of driver values, or "
                         f"{{offset: free, step: STEP}} (offset + k STEP, the offset found) "
                         f"or {{offset: free, values: [...]}}")
        ok = inputs is not None
        if inputs is not None and len(inputs) != n:
            v.err(inode, f"{what}: {len(inputs)} inputs for {n} {vals_key}: give one input "
                         f"value per target")
            ok = False
    if n_drivers != 1:
        v.err(inode, f"{what}: inputs are values of the model's driver, and it has "
                     f"{n_drivers} drivers (exactly one is needed)")
        ok = False
    return inputs, timing, ok


def _relative(v, node, what, n, vals_key):
    """(inputs, None) of an inputs mapping with nothing unknown (offset and step given), (None,
    Timing) of one with an unknown offset or step, (None, None) after an error."""
    for key in node.value:
        if key not in INPUT_KEYS:
            v.err(node.key_lines[key], f"{what}: unknown key '{key}'"
                  f"{did_you_mean(key, INPUT_KEYS) or _valid(INPUT_KEYS)}")
            return None, None
    if ("step" in node.value) == ("values" in node.value):
        both = "step" in node.value
        v.err(node, f"{what}: " + ("give step: or values:, not both" if both else
                                   "needs step: or values:") +
              " (step: STEP for the inputs offset, offset + STEP, offset + 2 STEP, ...; "
              "values: [...] for offset + each value)")
        return None, None
    offset, obounds = _free_or_number(v, node.value.get("offset"), f"{what}: offset")
    if offset is False:
        return None, None
    step, sbounds, values = None, None, None
    if "step" in node.value:
        step, sbounds = _free_or_number(v, node.value["step"], f"{what}: step")
        if step is False:
            return None, None
        if step == 0:
            v.err(node.value["step"], f"{what}: step must not be 0 (every input would be the "
                                      f"offset): give the step between consecutive {vals_key}, "
                                      f"or free")
            return None, None
    else:
        vn = node.value["values"]
        values = _numbers(v, vn, f"{what}: values", None) if vn.kind == "seq" else None
        if vn.kind != "seq":
            v.err(vn, f"{what}: values must be a list of driver values relative to the offset")
        if values is None:
            return None, None
        if len(values) != n:
            v.err(vn, f"{what}: values has {len(values)} entries for {n} {vals_key}: give one "
                      f"value per {vals_key[:-1]}")
            return None, None
    tm = Timing(n=n, values=values, offset=offset, step=step, offset_bounds=obounds,
                step_bounds=sbounds, line=node.line)
    if not tm.unknowns:         # nothing to find: the inputs are given
        return tuple(float(tm.offset + u) for u in tm.relative()), None
    return None, tm


def _free_or_number(v, node, what):
    """(value, None) of a number, (None, bounds) of `free` (bounds None) or [low, high], (False,
    None) after an error. No node: free."""
    if node is None or (node.kind == "scalar" and node.value == "free"):
        return None, None
    hint = f"{what} must be free, a number or [low, high] (the driver's unit)"
    if node.kind == "seq" and len(node.value) != 2:
        v.err(node, f"{hint}, not a list of {len(node.value)}")
        return False, None
    if node.kind == "seq":
        lohi = _numbers(v, node, what, 2)
        if lohi is None:
            return False, None
        if not lohi[0] < lohi[1]:
            v.err(node, f"{what}: the bounds [{lohi[0]:g}, {lohi[1]:g}] must be [low, high] "
                        f"with low < high")
            return False, None
        return None, lohi
    if node.kind == "scalar" and isinstance(node.value, str) and node.value not in v.params:
        near = did_you_mean(node.value, ["free"])
        if near:
            v.err(node, hint + near)
            return False, None
    if node.kind != "scalar":
        v.err(node, hint)
        return False, None
    x = v.number(node, what)
    return (False, None) if x is None else (x, None)


class _Reader:
    """The validator's small interface over a validated model (for design_of)."""

    def __init__(self, spec):
        from planarkin.functions.expr import evaluate_constant
        self.C = Collector(spec.file)
        self.params = dict(spec.parameters)
        self.body_names = [b.name for b in spec.bodies]
        self._eval = evaluate_constant

    def err(self, node_or_line, msg):
        line = node_or_line if isinstance(node_or_line, int) or node_or_line is None \
            else node_or_line.line
        self.C.error(line, msg)

    def number(self, node, what):
        val = node.value
        if node.kind != "scalar" or val is None or isinstance(val, bool):
            self.err(node, f"{what} must be a number")
            return None
        try:
            x = self._eval(val if isinstance(val, str) else float(val), self.params)
        except Exception:  # noqa: BLE001 - reported by the validator already
            self.err(node, f"{what} must be a number")
            return None
        return x if math.isfinite(x) else None


def design_of(root, spec, required: str = "synth") -> DesignSpec:
    """The DesignSpec of a validated model (root: its node tree). InputError when it has no
    design block, or (required='synth') no targets."""
    node = root.value.get("design")
    if node is None:
        raise _error(spec.file, 1, "the model has no design: block; add design: {free: "
                             "{NAME: [LOW, HIGH]}, targets: [...]} (see planarkin synth --help)")
    r = _Reader(spec)
    d = read_design(r, node, [p.name for p in spec.points], len(spec.drivers))
    r.C.raise_if_any()
    if required == "synth" and not d.targets:
        raise _error(spec.file, node.line, "design: no targets: give targets: [{path: "
                             "POINT, points: [[x, y], ...]}, ...]")
    return d


def _error(file, line, message) -> InputError:
    return InputError([Diagnostic(file, line, message)])
