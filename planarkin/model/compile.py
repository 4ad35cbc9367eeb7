"""Compile a validated `ModelSpec` into numeric arrays: the immutable model the solver reads.

This is the only place where user units end: angles become radians and every length is divided
by the characteristic length L (a power of two near the model's largest length, so the scaling is
exact in binary and a mechanism drawn in micrometres or in kilometres gives the same internal
numbers). Global placements (``at``) become body-frame vectors here, using the bodies' poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Collector
from ..elements import KINDS
from ..elements.base import group as make_group
from .spec import ElementSpec, ModelSpec

EQUATION_NAMES = {"revolute": ("x", "y"), "translational": ("parallel", "on-axis")}


@dataclass(frozen=True)
class CompiledModel:
    """Numeric model, internal units (length / L, radians). Never mutated by the solver.

    nb: moving bodies; n = 3 nb coordinates (x, y, phi per body, file order); ground is index nb.
    q0: (n,) pose estimate at t = start. groups: one Group per kind present (all its instances).
    m: equations; rows 0..m_joint-1 are joints (file order), then drivers.
    targets: (m,) constant part of each row's target. driver_rows: (d,) rows driven by
    driver_funcs (TimeFunction, user units) times driver_scale (internal per user unit).
    row_element: (m,) index into spec.elements; row_label: (m,) text for messages.
    point_body: (P,) body index; point_s: (P, 2) body-frame offset.
    shapes: planarkin.clearance.shape.Shape per entry of the file's shapes: (outlines in the
    body frame, internal units; () without shapes).
    """

    spec: ModelSpec
    body_names: tuple
    L: float
    angle_factor: float
    q0: np.ndarray
    groups: tuple
    m: int
    m_joint: int
    targets: np.ndarray
    driver_rows: np.ndarray
    driver_funcs: tuple
    driver_scale: np.ndarray
    row_element: np.ndarray
    row_label: tuple
    point_names: tuple
    point_body: np.ndarray
    point_s: np.ndarray
    shapes: tuple = ()      # planarkin.clearance.shape.Shape per shape of the file's shapes:

    @property
    def nb(self) -> int:
        return len(self.body_names)

    @property
    def n(self) -> int:
        return 3 * len(self.body_names)

    def element_of_row(self, row: int) -> ElementSpec:
        return self.spec.elements[int(self.row_element[row])]

    def coord_label(self, col: int) -> str:
        return f"{self.body_names[col // 3]}.{('x', 'y', 'phi')[col % 3]}"


def placed_params(el: ElementSpec, poses: dict) -> tuple[dict, float | None]:
    """The element's parameters (user units) with an `at:` placement resolved into body-frame
    vectors at the given poses (body name -> (x, y, phi)), and the constant the placement gives
    (a distance's c), or None."""
    params = dict(el.params)
    if el.at is None:
        return params, None
    given = dict(params)
    if el.axis is not None:
        given["axis"] = el.axis
    if el.target is not None:
        given["c"] = el.target
    placed = KINDS[el.kind].place(el.at, [poses[b] for b in el.bodies], given)
    c = placed.pop("c", None)
    params.update(placed)
    return params, c


def length_sizes(spec: ModelSpec):
    """(source, size) of every length the model's scale is taken from, user units: ("body",
    index) its |x| and |y| (the larger), ("param", element index, name) a point's norm or a
    length, ("target", element index) a length constant, ("at", element index) a global
    placement's points (the largest norm), ("point", index) a point's s or at."""
    for k, b in enumerate(spec.bodies):
        yield ("body", k), max(abs(b.q[0]), abs(b.q[1]))
    for e, el in enumerate(spec.elements):
        kind = KINDS[el.kind]
        for p in kind.params:
            v = el.params.get(p.name)
            if v is None:
                continue
            if p.unit == "point":
                yield ("param", e, p.name), math.hypot(*v)
            elif p.unit == "length":
                yield ("param", e, p.name), abs(v)
        if el.target is not None and kind.target_unit == "length":
            yield ("target", e), abs(el.target)
        if el.at is not None:
            pts = el.at if kind.at_points == 2 else (el.at,)
            yield ("at", e), max(math.hypot(*p) for p in pts)
    for j, p in enumerate(spec.points):
        yield ("point", j), math.hypot(*(p.s if p.s is not None else p.at))


def length_scale(big: float) -> float:
    """The internal unit of length for a model whose largest length is big: a power of two
    (exact scaling), 1 for a model without lengths."""
    if not big > 0 or not math.isfinite(big):
        return 1.0
    mant, exp = math.frexp(big)            # big = mant * 2**exp, 0.5 <= mant < 1
    return math.ldexp(1.0, min(exp if mant > math.sqrt(0.5) else exp - 1, 1000))


def compile_model(spec: ModelSpec) -> CompiledModel:
    L = length_scale(max((size for _, size in length_sizes(spec)), default=0.0))
    af = math.pi / 180.0 if spec.angle_unit == "deg" else 1.0
    names = tuple(b.name for b in spec.bodies)
    index = {name: k for k, name in enumerate(names)}
    index["ground"] = len(names)
    poses = {b.name: (b.q[0], b.q[1], b.q[2] * af) for b in spec.bodies}   # user lengths, radians
    poses["ground"] = (0.0, 0.0, 0.0)
    q0 = np.array([v for b in spec.bodies for v in (b.q[0] / L, b.q[1] / L, b.q[2] * af)])

    per_kind: dict[str, list] = {}
    problems = Collector(spec.file)
    targets: list[float] = []
    row_element: list[int] = []
    row_label: list[str] = []
    driver_rows, driver_funcs, driver_scale = [], [], []
    row = 0
    for e_idx, el in enumerate(spec.elements):
        kind = KINDS[el.kind]
        params, target_from_at = placed_params(el, poses)
        # internal units
        arrays = {}
        for p in kind.params:
            if p.unit in ("law", "angle-law"):
                v = params[p.name]
            elif p.unit == "curve":
                from ..elements.curve import Curve
                raw = params[p.name]
                v = raw.scaled(1.0 / L) if hasattr(raw, "segments") else \
                    Curve(np.asarray(raw, dtype=float) / L, bool(params.get("closed")))
            elif params[p.name] is None:            # an optional key without a default value
                v = np.full(2 if p.unit in ("range", "vector") else (), np.nan)
            else:
                v = np.asarray(params[p.name], dtype=float)
            if p.unit in ("point", "length"):
                v = v / L
            elif p.unit == "vector":
                v = v / np.hypot(v[0], v[1])
            elif p.unit in ("angle", "range"):
                v = v * af
            elif p.unit == "law":
                v = v.scaled(1.0 / L, af)
            elif p.unit == "angle-law":
                v = v.scaled(af, af)
            arrays[p.name] = v
        tscale = {"length": 1.0 / L, "angle": af, None: 1.0}[kind.target_unit]
        rows = list(range(row, row + kind.neq))
        consts = [0.0] * kind.neq
        if el.role == "joint" and kind.target:
            c = el.target if el.target is not None else target_from_at
            consts[0] = c * tscale
        prepared = kind.prepare(arrays, [(poses[b][0] / L, poses[b][1] / L, poses[b][2])
                                         for b in el.bodies])
        if prepared is not None:
            derived, consts = prepared
            arrays.update(derived)
        for msg in kind.diagnose(arrays, L, af, spec.length_unit, spec.angle_unit):
            problems.error(el.line, f"{el.label}: {msg}")
        if el.role == "driver":
            driver_rows.append(row)
            driver_funcs.append(el.f)
            driver_scale.append(tscale)
        eqn = EQUATION_NAMES.get(el.kind)
        for e in range(kind.neq):
            targets.append(consts[e])
            row_element.append(e_idx)
            row_label.append(el.label + (f" [{eqn[e]}]" if eqn else ""))
        per_kind.setdefault(el.kind, []).append(([index[b] for b in el.bodies], arrays, rows))
        row += kind.neq

    problems.raise_if_any()
    groups = []
    for kname, items in per_kind.items():
        kind = KINDS[kname]
        bodies = np.array([it[0] for it in items], dtype=np.intp)
        params = {p.name: np.array([it[1][p.name] for it in items])
                  for p in kind.params + kind.derived}
        rows = np.array([it[2] for it in items], dtype=np.intp)
        groups.append(make_group(kind, bodies, params, rows))

    pnames, pbody, ps = [], [], []
    for p in spec.points:
        b = index[p.body]
        if p.s is not None:
            s = np.array(p.s) / L
        else:
            from ..elements.revolute import to_body
            s = to_body(np.array(p.at) / L, (poses[p.body][0] / L, poses[p.body][1] / L,
                                             poses[p.body][2]))
        pnames.append(p.name)
        pbody.append(b)
        ps.append(s)

    m_joint = sum(KINDS[el.kind].neq for el in spec.joints)
    ro = lambda a, dt=float: _frozen(np.asarray(a, dtype=dt))
    cm = CompiledModel(
        spec=spec, body_names=names, L=L, angle_factor=af, q0=ro(q0), groups=tuple(groups),
        m=row, m_joint=m_joint, targets=ro(targets), driver_rows=ro(driver_rows, np.intp),
        driver_funcs=tuple(driver_funcs), driver_scale=ro(driver_scale),
        row_element=ro(row_element, np.intp), row_label=tuple(row_label),
        point_names=tuple(pnames), point_body=ro(pbody, np.intp),
        point_s=ro(np.reshape(ps, (-1, 2))))
    if spec.clearance is not None and spec.clearance.shapes:
        from dataclasses import replace

        from ..clearance.build import build_shapes     # only a file with shapes:
        cm = replace(cm, shapes=build_shapes(cm))
    return cm


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a
