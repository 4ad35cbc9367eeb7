"""Validation of the forces keys of a model file: body mass data, gravity and loads.

Called by `planarkin.model.validate` with its validator (whose typed readers report every
problem at its FILE:LINE, naming the element); returns a `ForcesSpec` in user units (the units
of the file's units: section, planarkin.forces.units), or None when the file gives no mass,
gravity or load at all. A model with forces whose units the file did not choose gets a note.
"""

from __future__ import annotations

from ..diagnostics import did_you_mean, one_of
from ..model.spec import ForcesSpec, LoadSpec, MassSpec
from .units import force_units, unit_notes

BODY_KEYS = ("mass", "inertia", "cm")
LOAD_KINDS = ("force", "torque", "spring", "damper")
LOAD_KEYS = {
    "force": ("type", "name", "body", "s", "at", "f"),
    "torque": ("type", "name", "body", "f"),
    "spring": ("type", "name", "i", "j", "si", "sj", "k", "length"),
    "damper": ("type", "name", "i", "j", "si", "sj", "c"),
}


def validate_forces(V, root) -> ForcesSpec | None:
    """ForcesSpec from the model's root mapping (V: the model validator)."""
    v = root.value
    masses = _masses(V, v.get("bodies"))
    gravity = None
    gline = 0
    if "gravity" in v:
        gravity = V.vector(v["gravity"], "gravity")
        gline = v["gravity"].line
    loads = _loads(V, v.get("loads"))
    if not masses and gravity is None and not loads:
        return None
    choice = getattr(V, "unit_choice", None)
    units = force_units(choice.length, choice.force, choice.mass) if choice is not None else \
        None
    weighty = any(m.mass > 0 or m.inertia > 0 for m in masses)
    if weighty or loads:                        # the model has forces (model.has_forces)
        shown = units or force_units("m")
        for line, msg in unit_notes(choice, shown, weighty):
            V.C.warning(line or None, msg)
    return ForcesSpec(tuple(masses), gravity, tuple(loads), gline, units)


def _nonnegative(V, node, what: str, meaning: str):
    x = V.number(node, what)
    if x is not None and x < 0:
        V.err(node, f"{what} must not be negative, not {x:g} ({meaning})")
        return None
    return x


def _masses(V, node) -> list[MassSpec]:
    out: list[MassSpec] = []
    if node is None or node.kind != "map":
        return out
    for key, val in node.value.items():
        if key not in V.body_set or val.kind != "map":
            continue
        b = val.value
        if not any(k in b for k in BODY_KEYS):
            continue
        what = f"body '{key}'"
        mass = inertia = 0.0
        cm = (0.0, 0.0)
        ok = True
        if "mass" in b:
            mass = _nonnegative(V, b["mass"], f"{what}: mass", "a mass")
            ok &= mass is not None
        if "inertia" in b:
            inertia = _nonnegative(V, b["inertia"], f"{what}: inertia",
                                   "the moment of inertia about the centre of mass")
            ok &= inertia is not None
        if "cm" in b:
            cm = V.vector(b["cm"], f"{what}: cm")
            ok &= cm is not None
            if cm is not None and "mass" not in b:
                V.err(b["cm"], f"{what}: cm is given but mass is not (the centre of mass of a "
                               f"massless body has no meaning); add mass: M")
                ok = False
        if ok:
            out.append(MassSpec(key, mass, inertia, cm, val.line))
    return out


def _loads(V, node) -> list[LoadSpec]:
    out: list[LoadSpec] = []
    if node is None:
        return out
    if node.kind != "seq":
        V.err(node, f"loads must be a list of {{type: force | torque | spring | damper, ...}} "
                    f"entries, not {_type(node)}")
        return out
    for idx, item in enumerate(node.value, start=1):
        spec = _load(V, item, idx)
        if spec is not None:
            out.append(spec)
    return out


def _type(node) -> str:
    from ..model.yamlread import type_name
    return type_name(node)


def _load(V, node, idx: int) -> LoadSpec | None:
    what = f"load {idx}"
    if node.kind != "map":
        V.err(node, f"{what} must be a mapping like {{type: force, body: ..., s: [x, y], "
                    f"f: [fx, fy]}}, not {_type(node)}")
        return None
    v = node.value
    if "type" not in v:
        V.err(node, f"{what}: missing 'type' ({one_of(LOAD_KINDS)})")
        return None
    kind = V.text(v["type"], f"{what}: type")
    if kind is None:
        return None
    if kind not in LOAD_KINDS:
        hint = did_you_mean(kind, LOAD_KINDS) or f" (load kinds: {one_of(LOAD_KINDS)})"
        V.err(v["type"], f"{what}: unknown type '{kind}'{hint}")
        return None
    name = V.text(v["name"], f"{what}: name") if "name" in v else None
    body_keys = ("body",) if kind in ("force", "torque") else ("i", "j")
    from ..model.yamlread import raw_text
    raw = [raw_text(v[k]) if k in v else "?" for k in body_keys]
    what = (f"load '{name}'" if name else what) + f" ({kind} {'-'.join(raw)})"
    V.keys(node, LOAD_KEYS[kind], what)
    bodies = []
    ok = True
    for k in body_keys:
        if k not in v:
            V.err(node, f"{what}: missing '{k}' (a body name" +
                  (" or ground)" if kind in ("spring", "damper") else ")"))
            ok = False
            continue
        b = V.body_ref(v[k], what, allow_ground=kind in ("spring", "damper"))
        ok &= b is not None
        bodies.append(b)
    if ok and len(bodies) == 2 and bodies[0] == bodies[1]:
        V.err(node, f"{what}: connects a body to itself; i and j must differ")
        ok = False
    vals: dict = {}
    if kind == "force":
        if "s" in v and "at" in v:
            V.err(v["at"], f"{what}: give either s or at, not both")
            ok = False
        elif "at" in v:
            vals["at"] = V.vector(v["at"], f"{what}: at")
            ok &= vals["at"] is not None
        elif "s" in v:
            vals["s"] = V.vector(v["s"], f"{what}: s")
            ok &= vals["s"] is not None
        else:
            vals["s"] = (0.0, 0.0)      # at the body frame's origin
        if "f" not in v:
            V.err(node, f"{what}: missing f: [fx, fy] (global components, expressions of t)")
            ok = False
        else:
            fn = v["f"]
            if fn.kind != "seq" or len(fn.value) != 2:
                V.err(fn, f"{what}: f must be a list of 2 expressions of t [fx, fy] (global "
                          f"components), not {_type(fn)}")
                ok = False
            else:
                fs = tuple(V.function(x, what) for x in fn.value)
                ok &= None not in fs
                vals["f"] = fs
    elif kind == "torque":
        if "f" not in v:
            V.err(node, f"{what}: missing f (the torque, an expression of t)")
            ok = False
        else:
            fs = V.function(v["f"], what)
            ok &= fs is not None
            vals["f"] = (fs,)
    else:
        for key in ("si", "sj"):
            if key in v:
                vals[key] = V.vector(v[key], f"{what}: {key}")
                ok &= vals[key] is not None
        if kind == "spring":
            for key, meaning, need in (("k", "a stiffness, force per length", True),
                                       ("length", "the free length", True)):
                if key not in v:
                    V.err(node, f"{what}: missing {key} ({meaning})")
                    ok = False
                    continue
                vals[key] = _nonnegative(V, v[key], f"{what}: {key}", meaning)
                ok &= vals[key] is not None
        else:
            if "c" not in v:
                V.err(node, f"{what}: missing c (the damping coefficient, force per velocity)")
                ok = False
            else:
                vals["c"] = _nonnegative(V, v["c"], f"{what}: c",
                                         "a damping coefficient, force per velocity")
                ok &= vals["c"] is not None
    if not ok:
        return None
    return LoadSpec(kind=kind, index=idx, line=node.line, name=name, bodies=tuple(bodies), **vals)
