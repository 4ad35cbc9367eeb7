"""Analysis options: one table, one door.

The YAML `analysis:` block (and `output: up_to`), the command line (`planarkin run --steps ...`)
and the Python API (`planarkin.solve(model, steps=...)`) all meet in `resolve()`, which checks
every value with the rules of `OPTIONS` and the cross-checks of `cross_check`, so the three
entry points accept exactly the same values and refuse the others with the same words (as SciPy's
`solve_ivp` validates every option at the top of the one function all callers go through).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, replace
from typing import Any

from .diagnostics import Diagnostic, InputError, did_you_mean, one_of

ORDERS = ("position", "velocity", "acceleration", "jerk")
NEWTON = ("reuse", "full", "fixed")
BIFURCATION = ("stop", "continue")
MAX_STEPS = 10**9            # hard limit of analysis: steps
DEFAULT_MAX_ROWS = 10**7     # grid rows a run may write unless max_rows is raised
DEFAULT_MAX_NODES = 500_000  # internal path steps a run may take unless max_nodes is raised
# A grid step must be this many ulps of the largest time, so that every row has its own time and
# the driver values between rows are resolved (start 1e14 with steps of 1e-14 is refused).
GRID_ULPS = 1000


@dataclass(frozen=True)
class Option:
    """One analysis option: its type and range, in every entry point.

    kind: 'float', 'int', 'bool' or 'choice'; lo/hi: inclusive bounds (None: none), positive:
    strictly above zero; optional: None is a legal value (no limit)."""

    name: str
    kind: str
    default: Any
    doc: str
    lo: float | None = None
    hi: float | None = None
    positive: bool = False
    choices: tuple = ()
    optional: bool = False
    hint: str = ""             # appended to a complaint, e.g. what steps counts

    @property
    def flag(self) -> str:
        return "--" + self.name.replace("_", "-")

    def rule(self) -> str:
        """What a valid value is, as the end of a sentence ('must be ...')."""
        if self.kind == "bool":
            return "true or false"
        if self.kind == "choice":
            return one_of(self.choices)
        what = "a whole number" if self.kind == "int" else "a finite number"
        num = (lambda x: str(int(x))) if self.kind == "int" else (lambda x: f"{x:g}")
        if self.positive:
            return f"{what} greater than 0"
        if self.lo is not None and self.hi is not None:
            return f"{what} between {num(self.lo)} and {num(self.hi)}"
        if self.lo is not None:
            return f"{what} of at least {num(self.lo)}"
        return what

    def check(self, value) -> tuple[Any, str | None]:
        """(the value in its type, None) or (None, the complaint: 'must be ..., not ...')."""
        bad = (None, f"must be {self.rule()}, not {_show(value)}{self.hint}")
        if value is None:
            return (None, None) if self.optional else bad
        if self.kind == "bool":
            return (bool(value), None) if _is_bool(value) else bad
        if self.kind == "choice":
            if isinstance(value, str) and value in self.choices:
                return value, None
            hint = did_you_mean(value, self.choices) if isinstance(value, str) else ""
            return None, bad[1] + hint
        if _is_bool(value) or not isinstance(value, numbers.Real):
            return bad
        x = float(value)
        if not math.isfinite(x):
            return bad
        if self.kind == "int":
            if x != int(x):
                return bad
            x = int(x)
        if self.positive and not x > 0:
            return bad
        if (self.lo is not None and x < self.lo) or (self.hi is not None and x > self.hi):
            return bad
        return x, None


OPTIONS: dict[str, Option] = {o.name: o for o in (
    Option("start", "float", 0.0, "start time, s"),
    Option("end", "float", 1.0, "end time, s (greater than start)"),
    Option("steps", "int", 100, "grid intervals: the tables have steps + 1 rows", lo=1,
           hi=MAX_STEPS, hint=" (steps counts intervals: the tables have steps + 1 rows)"),
    Option("tol", "float", 1e-10, "Newton tolerance: size of the last correction relative to "
           "the model's length", lo=1e-15, hi=0.1),
    Option("newton", "choice", "reuse", "iteration policy: reuse (one Jacobian per grid point), "
           "full (a new Jacobian every iteration), fixed (exactly `iterations` iterations)",
           choices=NEWTON),
    Option("iterations", "int", 8, "largest (with newton: fixed, exact) number of Newton "
           "iterations", lo=1, hi=100),
    Option("path_tol", "float", 1e-4, "predictor error allowed between internal path nodes",
           lo=1e-12, hi=0.1),
    Option("max_step", "float", None, "largest internal path step, s (default: none)",
           positive=True, optional=True),
    Option("interpolate", "bool", False, "P/V/A on the grid by quintic Hermite interpolation of "
           "the exact internal nodes instead of a Newton solve at every grid point"),
    Option("bifurcation", "choice", "stop", "at a bifurcation: stop, or continue on the smooth "
           "branch with a warning", choices=BIFURCATION),
    Option("up_to", "choice", "acceleration", "compute and write up to this derivative (jerk: "
           "the third, from its own exact linear system)", choices=ORDERS),
    Option("max_rows", "int", DEFAULT_MAX_ROWS, "largest number of grid rows (steps + 1) a run "
           "may write; raise it for longer tables", lo=1),
    Option("max_nodes", "int", DEFAULT_MAX_NODES, "largest number of internal path steps; a "
           "driver whose rate would need more is refused before the analysis", lo=1),
)}
ANALYSIS_KEYS = tuple(k for k in OPTIONS if k != "up_to")   # up_to is written under output:


@dataclass(frozen=True)
class Options:
    """Resolved analysis settings (the model's analysis: block, overridden by the command line or
    API keywords). order: 0 positions, 1 + velocities, 2 + accelerations, 3 + jerks (from
    up_to)."""

    start: float
    end: float
    steps: int
    tol: float = 1e-10
    newton: str = "reuse"
    iterations: int = 8
    path_tol: float = 1e-4
    max_step: float | None = None
    interpolate: bool = False
    bifurcation: str = "stop"
    order: int = 2
    max_rows: int = DEFAULT_MAX_ROWS
    max_nodes: int = DEFAULT_MAX_NODES
    chunk: int = 8192
    sources: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def up_to(self) -> str:
        return ORDERS[self.order]

    @property
    def rows(self) -> int:
        return self.steps + 1

    def times(self, a: int = 0, b: int | None = None):
        """Grid times of rows a..b-1 (s): start + k (end - start) / steps, computed per chunk so
        that a long grid is never held whole; the last row is exactly `end`."""
        import numpy as np
        b = self.rows if b is None else min(b, self.rows)
        k = np.arange(a, b, dtype=float)
        t = self.start + k * ((self.end - self.start) / self.steps)
        if b == self.rows and len(t):
            t[-1] = self.end
        return t

    @property
    def grid(self):
        return self.times()

    def with_(self, **changes) -> "Options":
        return replace(self, **changes)

    @classmethod
    def from_model(cls, cm, **overrides) -> "Options":
        """Kept for callers inside planarkin: `resolve` with API semantics."""
        return resolve(cm, overrides, source="api")


def _is_bool(v) -> bool:
    """Python's bool or numpy's (which is no numbers.Number), without importing numpy."""
    return isinstance(v, bool) or type(v).__name__ == "bool_"


def _show(v) -> str:
    if isinstance(v, str):
        return repr(v)
    if isinstance(v, float):
        return f"{v:g}"
    return repr(v)


def _where(a, name: str, source: str):
    """(line, how the option is named in a message) for an option from `source`; a: the
    model's AnalysisSpec (its lines)."""
    if source == "cli":
        return None, f"option {OPTIONS[name].flag}"
    if source == "api":
        return None, f"solve(): {name}"
    return (a.lines.get(name) or a.line or None), f"analysis: {name}"


def resolve(cm, overrides: dict | None = None, source: str = "api") -> Options:
    """The options of a run of compiled model cm: its analysis: block (already validated at its
    lines) overridden by `overrides` from `source` ('cli' or 'api'; None values are ignored).
    Raises InputError naming the option for any value the YAML would refuse too."""
    file = cm.spec.file
    a = cm.spec.analysis
    vals = {k: getattr(a, k) for k in ANALYSIS_KEYS if hasattr(a, k)}
    vals["up_to"] = ORDERS[cm.spec.output.order]
    sources = {k: "yaml" for k in vals}
    errors: list[Diagnostic] = []
    for key, value in (overrides or {}).items():
        if key == "order" and source == "api":
            errors.append(Diagnostic(file, None, "solve(): unknown option 'order'; did you mean "
                                     "'up_to'? (up_to='position', 'velocity', 'acceleration' or "
                                     "'jerk')"))
            continue
        if key not in OPTIONS:
            hint = did_you_mean(key, OPTIONS) or f" (options: {', '.join(OPTIONS)})"
            errors.append(Diagnostic(file, None, f"solve(): unknown option '{key}'{hint}"))
            continue
        if value is None:
            continue
        opt = OPTIONS[key]
        v, msg = opt.check(value)
        if msg is not None:
            line, who = _where(a, key, source)
            errors.append(Diagnostic(file, line, f"{who} {msg}"))
            continue
        vals[key] = v
        sources[key] = source
    if errors:
        raise InputError(errors)
    errors = cross_check(file, a, vals, sources)
    if vals["up_to"] == "jerk":
        errors += jerk_problems(cm)
    if errors:
        raise InputError(errors)
    order = ORDERS.index(vals.pop("up_to"))
    return Options(order=order, sources=sources, **vals)


def cross_check(file: str, a, v: dict, sources: dict) -> list[Diagnostic]:
    """Rules between options (v: name -> value, every option present); the message names the
    option given last (the command line or the API over the YAML). a: the AnalysisSpec."""
    out = []

    def blame(*names):
        """(name, line, who) of the option to blame; who is 'analysis', 'option --end' or
        'solve()', followed in the message by ': <the rule>'."""
        for src in ("api", "cli", "yaml"):
            for n in names:
                if sources.get(n) == src:
                    line, who = _where(a, n, src)
                    return n, line, ("analysis" if src == "yaml" else who.split(":")[0])
        return names[0], _where(a, names[0], "yaml")[0], "analysis"

    start, end, steps = v["start"], v["end"], v["steps"]
    if not end > start:
        _, line, who = blame("end", "start")
        fmt = "g" if f"{end:g}" != f"{start:g}" else ".17g"
        out.append(Diagnostic(file, line, f"{who}: end ({end:{fmt}}) must be greater than start "
                                          f"({start:{fmt}})"))
        return out
    if steps + 1 > v["max_rows"]:
        _, line, who = blame("steps", "max_rows")
        out.append(Diagnostic(file, line, f"{who}: {steps + 1} grid rows is more than max_rows "
                                          f"({v['max_rows']}); raise max_rows (analysis: "
                                          f"max_rows, --max-rows) if you need such a long table"))
    h = (end - start) / steps
    scale = max(abs(start), abs(end))
    ulp = math.ulp(scale) if scale > 0 else 0.0
    if not h > GRID_ULPS * ulp or end - start < GRID_ULPS * ulp:
        _, line, who = blame("steps", "start", "end")
        out.append(Diagnostic(file, line, f"{who}: the time step {h:.3g} s is below what double "
                                          f"precision resolves near t = {scale:.3g} s (one unit "
                                          f"in the last place is {ulp:.3g} s): shift the time "
                                          f"origin towards 0 or use fewer steps"))
    if v.get("up_to") == "jerk" and v["interpolate"]:
        _, line, who = blame("interpolate", "up_to")
        out.append(Diagnostic(file, line, f"{who}: up_to: jerk needs the exact solve at every "
                                          f"grid row, and interpolate: true interpolates the "
                                          f"rows: set interpolate: false or stop at "
                                          f"acceleration"))
    if v["max_step"] is not None and v["max_step"] < GRID_ULPS * ulp:
        _, line, who = blame("max_step")
        out.append(Diagnostic(file, line, f"{who}: max_step {v['max_step']:.3g} s is below what "
                                          f"double precision resolves near t = {scale:.3g} s"))
    return out


def jerk_problems(cm) -> list[Diagnostic]:
    """Drivers and cam laws whose exact third derivative cannot be formed (up_to: jerk needs
    it), one error at each element's line. Every form the expression language builds (laws,
    motion segments, tables, piecewise functions) differentiates exactly to any order, so this
    only refuses what the symbolic differentiation itself refuses."""
    import numpy as np

    from planarkin.functions.expr import ExprError
    out = []
    seen = set()
    for r, f in zip(cm.driver_rows, cm.driver_funcs):
        el = cm.element_of_row(int(r))
        try:
            f.third(0.0)
        except ExprError as exc:
            if id(el) not in seen:
                seen.add(id(el))
                out.append(Diagnostic(cm.spec.file, el.line, f"{el.label}: up_to: jerk needs "
                                      f"the third derivative of f, and {exc}"))
    for G in cm.groups:
        for name in ("s", "psi"):
            for k, law in enumerate(G.params.get(name, ()) if G.kind.name.startswith("cam")
                                    else ()):
                try:
                    law(np.zeros(1), (3,))
                except ExprError as exc:
                    el = cm.element_of_row(int(G.rows[k, 0]))
                    if id(el) not in seen:
                        seen.add(id(el))
                        out.append(Diagnostic(cm.spec.file, el.line, f"{el.label}: up_to: jerk "
                                              f"needs the third derivative of the law, and "
                                              f"{exc}"))
    return out


def describe() -> str:
    """The options table for the README (name, default, meaning)."""
    rows = ["| option | default | meaning |", "|---|---|---|"]
    for o in OPTIONS.values():
        d = "none" if o.default is None else str(o.default).lower() if o.kind == "bool" \
            else f"{o.default:g}" if isinstance(o.default, float) else str(o.default)
        rows.append(f"| `{o.name}` (`{o.flag}`) | {d} | {o.doc}; {o.rule()} |")
    return "\n".join(rows)


COMMAND_LINE = False     # set in the worker processes of the command line's `run --jobs`


def from_command_line() -> bool:
    """Whether planarkin's own command line is running (a click context of planarkin.cli, or a
    worker of its `run --jobs`): messages then name options as typed (--set a=0.1); API
    callers get the API's words."""
    import sys
    if COMMAND_LINE:
        return True
    click = sys.modules.get("click")        # not imported: certainly not the command line
    if click is None:
        return False
    ctx = click.get_current_context(silent=True)
    if ctx is None:
        return False
    callback = getattr(ctx.find_root().command, "callback", None)
    return getattr(callback, "__module__", "") == "planarkin.cli"


def override_word(key: str, value=None) -> str:
    """How a parameter override is named in a message: `--set a=0.1` on the command line,
    `parameter override a=0.1` from load(path, a=0.1) or a study's overrides."""
    shown = key if value is None else f"{key}={value}"
    return f"--set {shown}" if from_command_line() else f"parameter override {shown}"
