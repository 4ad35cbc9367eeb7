"""The validated model, in the user's units: frozen dataclasses, one per YAML section.

Produced by `planarkin.model.validate` and consumed by `planarkin.model.compile`, which is the only
place where degrees become radians and lengths are scaled. Every element keeps the line it came
from, so that later stages (assembly, rank checks) can still point at the file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class BodySpec:
    name: str
    q: tuple[float, float, float]      # estimate (or exact pose) at t = start: length, length, angle
    line: int


@dataclass(frozen=True)
class ElementSpec:
    """A joint (constant target c) or a driver (target f(t)).

    bodies: body names (i, j[, k]); 'ground' allowed. params: kind parameters in user units
    (points and vectors as 2-tuples, scalars as floats). at/axis: global placement, when given.
    """

    role: str                          # 'joint' or 'driver'
    index: int                         # 1-based position within joints: or drivers:
    kind: str
    bodies: tuple[str, ...]
    params: dict[str, Any]
    line: int
    name: str | None = None
    target: float | None = None        # joints: c (None: derived at compile, e.g. from 'at')
    f: Any = None                      # drivers: planarkin.functions.expr.TimeFunction
    at: Any = None
    axis: tuple[float, float] | None = None
    param_lines: dict[str, int] = field(default_factory=dict)

    @property
    def label(self) -> str:
        """How messages name the element: ``joint 3 (revolute crank-rod)``."""
        who = f"'{self.name}'" if self.name else str(self.index)
        return f"{self.role} {who} ({self.kind} {'-'.join(self.bodies)})"


@dataclass(frozen=True)
class PointSpec:
    name: str
    body: str
    s: tuple[float, float] | None      # body frame, user length unit
    at: tuple[float, float] | None     # or global position at the assembly pose
    line: int


@dataclass(frozen=True)
class AnalysisSpec:
    """Time grid and solver settings (see README, 'analysis')."""

    start: float = 0.0
    end: float = 1.0
    steps: int = 100
    tol: float = 1e-10                 # Newton: size of the last correction, internal units
    newton: str = "reuse"              # 'reuse' | 'full' | 'fixed'
    iterations: int = 8                # maximum (or, for 'fixed', exact) Newton iterations
    path_tol: float = 1e-4             # predictor error allowed between internal nodes
    max_step: float | None = None      # largest internal step, seconds (None: no limit)
    interpolate: bool = False          # True: P/V/A on the grid from quintic Hermite of nodes
    bifurcation: str = "stop"          # 'stop' | 'continue' (on the smooth branch, with a warning)
    max_rows: int = 10**7              # grid rows a run may write (see planarkin.options)
    max_nodes: int = 500_000           # internal path steps a run may take
    line: int = 0
    lines: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class OutputSpec:
    """What to compute and write: 'model only what a scene requires'."""

    bodies: tuple[str, ...] | None = None    # None: all bodies
    points: tuple[str, ...] | None = None    # None: all points
    order: int = 2                           # 0 positions, 1 + velocities, 2 + accelerations
    centres: bool = False                    # centres.csv: instant centres of every body pair
    x: str = "time"                          # abscissa of the time-history plots (X_AXES)
    table_format: str = "csv"                # the run tables' file format (TABLE_FORMATS)
    moving_centrodes: bool = False           # centres: moving: mechanism.<fmt> also draws them


# The abscissa of bodies.<fmt> and points.<fmt>: `output: {x: ...}` and `planarkin run --x`.
# driver: the coordinate of the model's first driver, f(t) in the file's units (crank angle).
X_AXES = ("time", "driver")


def x_axis_problem(x: str, spec, what: str) -> str | None:
    """Why abscissa x does not fit the model (None: it does); what names the option in the
    message (``output: x`` or ``--x``). Shared by the YAML validator and the command line."""
    if x == "driver" and not spec_drivers(spec):
        return f"{what}: driver needs a driver, and this model has none; use time"
    return None


# The file format of the run tables: `output: {table_format: ...}`, `planarkin run --table-format`
# and Result.write(table_format=...). parquet needs pyarrow (the extra planarkin[parquet]).
TABLE_FORMATS = ("csv", "parquet")


def table_format_problem(fmt, what: str) -> str | None:
    """Why table format fmt cannot be written here (None: it can); what names the option in
    the message (``output: table_format``, ``--table-format``). Shared by the YAML validator,
    the command line and Result.write."""
    if fmt not in TABLE_FORMATS:
        return f"{what} must be one of {', '.join(TABLE_FORMATS)}, not {fmt!r}"
    if fmt == "parquet" and not pyarrow_available():
        return (f"{what}: parquet needs pyarrow, which is not installed: pip install "
                f"'planarkin[parquet]', or use csv")
    return None


def pyarrow_available() -> bool:
    """pyarrow can be imported (looked up without importing it: start-up time)."""
    import importlib.util
    try:
        return importlib.util.find_spec("pyarrow") is not None
    except (ImportError, ValueError):
        return False


def spec_drivers(spec) -> list:
    """The drivers of a ModelSpec (or of a list of element specs), in file order."""
    elements = getattr(spec, "drivers", spec)
    return [e for e in elements if e.role == "driver"]


@dataclass(frozen=True)
class ModelSpec:
    name: str
    file: str
    length_unit: str
    angle_unit: str                    # 'rad' or 'deg'
    parameters: dict[str, float]
    bodies: tuple[BodySpec, ...]
    joints: tuple[ElementSpec, ...]
    drivers: tuple[ElementSpec, ...]
    points: tuple[PointSpec, ...]
    analysis: AnalysisSpec
    output: OutputSpec
    branch: dict[str, int] = field(default_factory=dict)   # assembly-mode hints: body -> +1/-1
    branch_lines: dict[str, int] = field(default_factory=dict)
    section_lines: dict[str, int] = field(default_factory=dict)    # top-level key -> line
    warnings: tuple = ()               # Diagnostics of severity 'warning' found while validating
    forces: "ForcesSpec | None" = None     # masses, gravity, loads (None: none given)
    measures: tuple = ()               # planarkin.measures.MeasureSpec, file order
    clearance: Any = None              # planarkin.clearance.keys.ClearanceSpec: shapes:,
    #                                    clearance:, limits: (None: none of them)
    overrides: dict[str, float] = field(default_factory=dict)      # --set NAME=VALUE, evaluated
    sketch_tolerance: float | None = None  # assembly: warn of sketch pins moved by more

    @property
    def elements(self) -> tuple[ElementSpec, ...]:
        return self.joints + self.drivers


@dataclass(frozen=True)
class MassSpec:
    """Mass properties of one body (user units): mass (the file's mass unit, ForcesSpec.units),
    inertia about the centre of mass (mass * length^2), cm: centre of mass in the body frame
    (length)."""

    body: str
    mass: float
    inertia: float
    cm: tuple[float, float]
    line: int


@dataclass(frozen=True)
class LoadSpec:
    """One entry of loads: (user units; f are planarkin.functions.expr.TimeFunction of t).

    kind 'force': body, s (body frame) or at (global at the assembly pose), f = (fx, fy) global.
    kind 'torque': body, f = (tau,). kind 'spring': i, j, si, sj, k, length.
    kind 'damper': i, j, si, sj, c.
    """

    kind: str
    index: int                         # 1-based position within loads:
    line: int
    name: str | None = None
    bodies: tuple[str, ...] = ()       # (body,) for force/torque, (i, j) for spring/damper
    s: tuple | None = None             # force: point in the body frame
    at: tuple | None = None            # force: global point at the assembly pose
    f: tuple = ()
    si: tuple = (0.0, 0.0)
    sj: tuple = (0.0, 0.0)
    k: float = 0.0
    length: float = 0.0
    c: float = 0.0

    @property
    def label(self) -> str:
        who = f"'{self.name}'" if self.name else str(self.index)
        return f"load {who} ({self.kind} {'-'.join(self.bodies)})"


@dataclass(frozen=True)
class ForcesSpec:
    """What the forces room needs: per body mass data, gravity (length/s^2), the loads, and the
    units they are in (planarkin.forces.units.ForceUnits; None: the default ones, masses in kg
    and forces in kg*length/s^2)."""

    masses: tuple[MassSpec, ...] = ()
    gravity: tuple[float, float] | None = None
    loads: tuple[LoadSpec, ...] = ()
    gravity_line: int = 0
    units: Any = None
