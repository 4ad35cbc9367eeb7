"""Every registered kind keeps the contract of planarkin.elements.base.Kind (the numbered list in
its docstring): a kind is one module that holds its equations, validation, estimates and
reaction components, registered once in planarkin.elements.KINDS.

`missing_parts` names what a kind lacks; the last tests show that it notices a kind without a
part (a test of the check itself), and that the docstring's list and this check agree.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from planarkin.elements import DRIVER_KINDS, JOINT_KINDS, KINDS
from planarkin.elements.base import UNITS, Kind, Param
from planarkin.forces.solve import JOINT_OUTPUT

# the parts of the contract this check covers, by their number in Kind's docstring
PARTS = {
    1: ("name", "neq", "nbody", "joint", "driver", "params", "target", "target_unit", "summary",
        "equations", "driver_equations"),
    2: ("g", "grad", "gamma", "jerk", "row_unit"),
    3: ("validate", "diagnose", "at_form", "place", "at_points", "at_axis", "target_from_at",
        "target_default", "between", "positive_target"),
    4: ("prepare", "derived", "check_pose", "sampled_zeros"),
    5: ("reaction_columns", "reaction_sign", "reaction_setup", "reaction", "reaction_point",
        "contact_force"),
    6: ("draw",),
}
COLUMNS = ("fx", "fy", "torque")


def own(kind: Kind, method: str) -> bool:
    """Whether the kind (or a class it derives from other than Kind) defines method."""
    return getattr(type(kind), method) is not getattr(Kind, method)


def missing_parts(kind: Kind) -> list[str]:
    """The parts of the contract that kind lacks, as 'part N: what' (empty: it keeps it)."""
    out = []
    # 1. identity and the reference tables
    if not (isinstance(kind.name, str) and re.fullmatch(r"[a-z][a-z-]*", kind.name)):
        out.append("part 1: name")
    if not (isinstance(kind.neq, int) and kind.neq >= 1):
        out.append("part 1: neq")
    if kind.nbody not in (2, 3):
        out.append("part 1: nbody")
    if not (kind.joint or kind.driver):
        out.append("part 1: joint or driver")
    if not all(isinstance(p, Param) and p.unit in UNITS and p.doc for p in kind.params):
        out.append("part 1: params")
    if not kind.summary:
        out.append("part 1: summary")
    if kind.joint and not kind.equations:
        out.append("part 1: equations")
    if kind.driver and not (kind.driver_equations and kind.target_unit in ("length", "angle")):
        out.append("part 1: driver_equations and target_unit")
    # 2. the equations
    out += [f"part 2: {m}" for m in PARTS[2][:4] if not own(kind, m)]
    if any(kind.row_unit(k) not in ("angle", "length") for k in range(kind.neq)):
        out.append("part 2: row_unit")
    # 3. validation: the hooks are callables; a kind placed by 'at' says how
    out += [f"part 3: {m}" for m in ("validate", "diagnose") if not callable(getattr(kind, m))]
    if kind.at_form is not None and not own(kind, "place"):
        out.append("part 3: place (the kind has an at_form)")
    if kind.at_points not in (1, 2) or ((kind.at_axis or kind.target_from_at or
                                         kind.at_points != 1) and kind.at_form is None):
        out.append("part 3: at_points, at_axis, target_from_at (without an at_form)")
    if kind.target_default is not None and not (kind.joint and kind.target):
        out.append("part 3: target_default (the kind has no joint target)")
    if kind.between and not (kind.driver and {"si", "sj"} <= {p.name for p in kind.params}):
        out.append("part 3: between (not a driver with points si and sj)")
    # 4. estimates: derived parameters need prepare to fill them
    if kind.derived and not own(kind, "prepare"):
        out.append("part 4: prepare (the kind has derived parameters)")
    if not callable(kind.check_pose):
        out.append("part 4: check_pose")
    if not isinstance(kind.sampled_zeros, bool):
        out.append("part 4: sampled_zeros")
    # 5. reactions: what a joint's columns are and what their signs mean
    if kind.joint:
        cols = kind.reaction_columns
        if not (cols and set(cols) <= set(COLUMNS) and list(cols) == sorted(
                cols, key=COLUMNS.index)):
            out.append("part 5: reaction_columns")
        if not kind.reaction_sign:
            out.append("part 5: reaction_sign")
    out += [f"part 5: {m}" for m in PARTS[5][2:] if not callable(getattr(kind, m))]
    # 6. drawing: its own hook (the figures hold no kind's drawing)
    if not own(kind, "draw"):
        out.append("part 6: draw")
    return out


@pytest.mark.parametrize("name", sorted(KINDS))
def test_every_registered_kind_keeps_the_contract(name):
    kind = KINDS[name]
    assert kind.name == name
    assert missing_parts(kind) == []


def test_kinds_are_registered_once():
    classes = [type(k) for k in KINDS.values()]
    assert len(set(classes)) == len(classes)
    assert JOINT_KINDS == {n: k for n, k in KINDS.items() if k.joint}
    assert DRIVER_KINDS == {n: k for n, k in KINDS.items() if k.driver}
    # the forces room reads each joint's columns from its kind, not a list of its own
    assert JOINT_OUTPUT == {n: k.reaction_columns for n, k in JOINT_KINDS.items()}


def test_the_docstring_lists_every_part_checked_here():
    doc = Kind.__doc__
    items = dict(re.findall(r"^\s*(\d)\. (.*?)(?=^\s*\d\. |\n\s*\n)", doc, re.M | re.S))
    assert sorted(int(k) for k in items) == [1, 2, 3, 4, 5, 6]
    for number, names in PARTS.items():
        for n in names:
            assert f"``{n}" in items[str(number)], (number, n)


# -- the check itself: it notices a kind that lacks a part ------------------------------------

class _Complete(Kind):
    name = "test-pin"
    neq = 2
    params = (Param("si", "point", "a point of i"), Param("sj", "point", "a point of j"))
    summary = "a kind for this test"
    equations = "r_i + s_i - r_j - s_j = 0"
    reaction_columns = ("fx", "fy")
    reaction_sign = "fx, fy: on j"

    def g(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 2))

    grad = gamma = jerk = g

    def draw(self, G, k, parts):
        return None


def _without(**changes):
    return type("Partial", (_Complete,), changes)()


def test_a_complete_kind_passes():
    assert missing_parts(_Complete()) == []


@pytest.mark.parametrize("changes, missing", [
    ({"jerk": Kind.jerk}, ["part 2: jerk"]),
    ({"g": Kind.g, "grad": Kind.grad}, ["part 2: g", "part 2: grad"]),
    ({"reaction_columns": ()}, ["part 5: reaction_columns"]),
    ({"reaction_columns": ("torque", "fx")}, ["part 5: reaction_columns"]),
    ({"reaction_sign": ""}, ["part 5: reaction_sign"]),
    ({"summary": ""}, ["part 1: summary"]),
    ({"equations": ""}, ["part 1: equations"]),
    ({"driver": True}, ["part 1: driver_equations and target_unit"]),
    ({"at_form": "[x, y]"}, ["part 3: place (the kind has an at_form)"]),
    ({"derived": (Param("side", "real", "a side"),)},
     ["part 4: prepare (the kind has derived parameters)"]),
    ({"params": (Param("si", "pointy", "a point"),)}, ["part 1: params"]),
    ({"validate": None}, ["part 3: validate"]),
    ({"at_axis": True}, ["part 3: at_points, at_axis, target_from_at (without an at_form)"]),
    ({"at_points": 3, "at_form": "[x, y]", "place": lambda self, at, poses, given: {}},
     ["part 3: at_points, at_axis, target_from_at (without an at_form)"]),
    ({"target_default": 0.0}, ["part 3: target_default (the kind has no joint target)"]),
    ({"between": True}, ["part 3: between (not a driver with points si and sj)"]),
    ({"row_unit": lambda self, k: "radian"}, ["part 2: row_unit"]),
    ({"draw": Kind.draw}, ["part 6: draw"]),
])
def test_a_kind_without_a_part_is_named(changes, missing):
    assert missing_parts(_without(**changes)) == missing
