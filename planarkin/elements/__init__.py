"""The registry of constraint and driver kinds: one table feeds the validator, the solver, the
README's reference table and the "did you mean" hints. Adding a kind means adding a class in one
module of this package, listing it here, and giving it the finite-difference tests of
``tests/test_elements.py`` (reference §10)."""

from __future__ import annotations

from .base import Frame, Group, Kind, Param
from .belt import Belt
from .cam import Cam, CamRocker
from .curve import CurveSlot
from .gear import Gear
from .mesh import GearMesh, RollDisc
from .rack import RackPinion, RollLine
from .revolute import Revolute
from .scalar import Angle, Distance, XDistance, YDistance
from .translational import PinSlot, Slide, Translational

KINDS: dict[str, Kind] = {k.name: k for k in (
    Revolute(), Translational(), Angle(), Distance(), XDistance(), YDistance(),
    PinSlot(), Gear(), Slide(), RackPinion(), RollLine(), GearMesh(), RollDisc(), Belt(),
    Cam(), CamRocker(), CurveSlot(),
)}

JOINT_KINDS = {name: k for name, k in KINDS.items() if k.joint}
DRIVER_KINDS = {name: k for name, k in KINDS.items() if k.driver}



def reaction_table() -> str:
    """The sign conventions of the reactions in forces.csv, one row per kind (markdown), from
    each kind's reaction_sign: what the docs print beside the kinds table."""
    lines = ["| type | forces.csv columns and signs |", "|---|---|"]
    for name, k in KINDS.items():
        lines.append(f"| `{name}` | {k.reaction_sign.replace('|', chr(92) + '|')} |")
    return "\n".join(lines)


__all__ = ["KINDS", "JOINT_KINDS", "DRIVER_KINDS", "Frame", "Group", "Kind", "Param",
           "reaction_table"]
