"""The columns of forces.csv: what the table (planarkin.forces.output) and its plot
(planarkin.forces.plot) share, read here by both."""

from __future__ import annotations

import re

import numpy as np

from ..elements import KINDS
from ..elements.base import Kind
from .units import unit_names
from .solve import JOINT_OUTPUT

UNIQUE_TOL = 1e-9       # a left null vector of Phi_q with an entry above this makes a row's
                        # multiplier non-unique (normalised rows, unit null vectors)


# kinds with a signed normal contact force (their own Kind.contact_force): bilateral joints
# standing for contacts that only press; forces.csv gets <name>.contact, positive while pressing
CONTACT_KINDS = tuple(name for name, k in KINDS.items()
                      if type(k).contact_force is not Kind.contact_force)


def column_name(el) -> str:
    """The element's name, or its message label made CSV-safe."""
    if el.name:
        return el.name
    return re.sub(r"[^A-Za-z0-9_\-]+", "_", el.label).strip("_")


def redundancy(cm):
    """(active rows, indices of elements whose reaction is not unique, their labels)."""
    if cm.m <= cm.n:
        return np.arange(cm.m), set(), []
    from planarkin.solver.assembly import assemble
    from planarkin.solver.system import System
    A = assemble(cm)
    Sys = System(cm)
    J = Sys.jacobian(Sys.ext(A.q))[0]
    Jn = J / np.maximum(np.linalg.norm(J, axis=1, keepdims=True), 1e-300)
    U, sv, _ = np.linalg.svd(Jn)
    rank = int((sv > 1e-9 * sv[0]).sum())
    null = U[:, rank:]                               # left null space: non-unique multipliers
    rows = np.nonzero(np.abs(null).max(axis=1) > UNIQUE_TOL)[0] if null.size else []
    elements = {int(cm.row_element[r]) for r in rows}
    labels = [cm.spec.elements[e].label for e in sorted(elements)]
    return np.asarray(A.active_rows), elements, labels


def element_names(cm) -> dict:
    """{element index: its column name}: `column_name`, made unique (``_2``, ``_3`` ...) and
    never ``total`` or ``shaking`` (forces.csv's own columns)."""
    used: set = {"total", "shaking"}
    names = {}
    for e, el in enumerate(cm.spec.elements):
        base = column_name(el)
        name, k = base, 2
        while name in used:
            name, k = f"{base}_{k}", k + 1
        used.add(name)
        names[e] = name
    return names


def columns(cm, left_out=frozenset()):
    """[(header, getter(Forces) -> (N,) array, role)] in table order (t excluded); role is
    'effort', 'reaction', 'contact', 'power' or 'shaking'."""
    u = unit_names(cm.spec)
    spec = cm.spec
    nj = len(spec.joints)
    names = element_names(cm)
    out = []
    for d, el in enumerate(spec.drivers):
        e = nj + d
        if e in left_out:
            continue
        q = "torque" if KINDS[el.kind].target_unit == "angle" else "force"
        out.append((f"{names[e]}.{q} [{u[q]}]", lambda F, d=d: F.effort(d), "effort"))
    comp = {"fx": 0, "fy": 1, "torque": 2}
    for e, el in enumerate(spec.joints):
        if e in left_out:
            continue
        for c in JOINT_OUTPUT[el.kind]:
            unit = u["torque" if c == "torque" else "force"]
            out.append((f"{names[e]}.{c} [{unit}]",
                        lambda F, e=e, k=comp[c]: F.reaction(e, 1)[k], "reaction"))
    for e, el in enumerate(spec.joints):
        if e not in left_out and el.kind in CONTACT_KINDS:
            out.append((f"{names[e]}.contact [{u['force']}]", lambda F, e=e: F.contact(e),
                        "contact"))
    for d, el in enumerate(spec.drivers):
        if nj + d in left_out:
            continue
        out.append((f"{names[nj + d]}.power [{u['power']}]", lambda F, d=d: F.power(d), "power"))
    drivers = [d for d in range(len(spec.drivers)) if nj + d not in left_out]
    out.append((f"total.power [{u['power']}]",
                lambda F: sum((F.power(d) for d in drivers), np.zeros(len(F.t))), "power"))
    for k, c in enumerate(("fx", "fy", "torque")):
        unit = u["torque" if c == "torque" else "force"]
        out.append((f"shaking.{c} [{unit}]", lambda F, k=k: F.ground()[k], "shaking"))
    return out
