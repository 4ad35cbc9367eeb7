"""The units of the forces room: the `units:` keys force, mass and system (read with the model's
units section by planarkin.model.validate), the unit of every force quantity, and the one
conversion the forces room makes.

The forces room computes in consistent units: the file's length unit L, seconds, the force unit
F and the mass unit F*s^2/L, so that force = mass * length / s^2 holds with factor 1. A load
(F), a torque (F*L), a spring rate (F/L), a damping (F*s/L) and gravity (L/s^2) are used as
written, and forces.csv, loads.csv and summary.json come out in F, F*L (torques) and F*L/s
(powers; W, kW or mW when that is exactly what F*L/s is). Only masses and inertias (mass*L^2)
written in another mass unit than F*s^2/L are converted, once, when the arrays are built
(planarkin.forces.model); outputs need no conversion.

- No force, mass or system key (the default, as before this module): masses in kg, forces in
  kg*L/s^2 (N when L is m), torques kg*L^2/s^2, powers kg*L^2/s^3.
- `mass: M` alone: masses in M, forces in M*L/s^2 (named, e.g. N for t and mm, when the length is
  of known size and the product is one of FORCES exactly).
- `force: F` (needs a length of known size, LENGTHS): forces in F; masses in `mass: M` when given
  (converted), else in the consistent unit F*s^2/L (named when it is one of MASSES: t for N and
  mm, kg for N and m).
- `system: NAME`: the length, mass and force of SYSTEMS (a unit also given must agree).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..diagnostics import one_of

# sizes in metres of the length units a force unit may be used with
LENGTHS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001, "um": 1e-6, "\u00b5m": 1e-6,
           "\u03bcm": 1e-6, "km": 1000.0, "in": 0.0254, "ft": 0.3048}
FORCES = {"N": 1.0, "kN": 1000.0, "mN": 0.001, "lbf": 4.4482216152605}     # in N
MASSES = {"kg": 1.0, "g": 0.001, "t": 1000.0, "lb": 0.45359237}           # in kg
POWERS = {"W": 1.0, "kW": 1000.0, "mW": 0.001}                            # in W
# name: (length, mass, force); the mass is the one consistent with the length and the force
SYSTEMS = {"SI": ("m", "kg", "N"), "mm-N-s": ("mm", "t", "N"), "mm-kg-s": ("mm", "kg", "mN"),
           "in-lbf-s": ("in", "lbf*s^2/in", "lbf")}
UNIT_KEYS = ("length", "angle", "force", "mass", "system")
MATCH = 1e-12           # a product of unit sizes names a unit when within this (relative)


@dataclass(frozen=True)
class UnitChoice:
    """What a model's units: section says about forces: the length unit (resolved: a system's
    when not given), the system, force and mass named in the file (None: not named), and the
    lines of the length key (else of the units: mapping) and of the force key, for notes."""

    length: str = "m"
    system: str | None = None
    force: str | None = None
    mass: str | None = None
    length_line: int = 0
    force_line: int = 0


@dataclass(frozen=True)
class ForceUnits:
    """The unit of every force quantity of a model: force, torque (force * length), power and
    the unit its masses are written in (inertias: mass * length^2); mass_factor turns a mass
    (and an inertia) written in the file into the consistent mass unit force * s^2 / length."""

    length: str
    force: str
    torque: str
    power: str
    mass: str
    mass_factor: float = 1.0
    consistent_mass: str = "kg"

    def names(self) -> dict:
        """summary.json's forces.units (without the length): force, torque, power, mass."""
        return {"force": self.force, "torque": self.torque, "power": self.power,
                "mass": self.mass}


def _named(table: dict, value: float) -> str | None:
    for name, size in table.items():
        if abs(value - size) <= MATCH * size:
            return name
    return None


def force_units(length: str, force: str | None = None, mass: str | None = None) -> ForceUnits:
    """The units of a model with this length unit and the force and mass units its file names
    (None: not named; the force needs a length of LENGTHS, read_units checks it)."""
    L = length
    Lm = LENGTHS.get(L)
    if force is None and mass is None:
        if L == "m":
            return ForceUnits(L, "N", "N*m", "W", "kg")
        return ForceUnits(L, f"kg*{L}/s^2", f"kg*{L}^2/s^2", f"kg*{L}^2/s^3", "kg")
    if force is None:
        force = _named(FORCES, MASSES[mass] * Lm) if Lm is not None else None
        if force is None:
            return ForceUnits(L, f"{mass}*{L}/s^2", f"{mass}*{L}^2/s^2", f"{mass}*{L}^2/s^3",
                              mass, consistent_mass=mass)
        consistent, factor = mass, 1.0
    else:
        Mc = FORCES[force] / Lm                    # the consistent mass unit, in kg
        consistent = _named(MASSES, Mc) or f"{force}*s^2/{L}"
        if mass is None or mass == consistent:
            mass, factor = consistent, 1.0
        else:
            factor = MASSES[mass] / Mc
    power = _named(POWERS, FORCES[force] * Lm) if Lm is not None else None
    return ForceUnits(L, force, f"{force}*{L}", power or f"{force}*{L}/s", mass, factor,
                      consistent)


def units_of(spec) -> ForceUnits:
    """The ForceUnits of a ModelSpec (the default ones when its forces spec has none)."""
    fs = spec.forces
    if fs is not None and getattr(fs, "units", None) is not None:
        return fs.units
    return force_units(spec.length_unit)


def unit_names(spec) -> dict:
    """{force, torque, power, mass} unit names of a ModelSpec (forces.csv, loads.csv, plots)."""
    return units_of(spec).names()


def _system_text(name: str) -> str:
    length, mass, force = SYSTEMS[name]
    return f"length {length}, mass {mass}, force {force}"


def read_units(V, node, length: str, length_given: bool) -> UnitChoice:
    """The force, mass and system keys of the units mapping node (V: the model validator, which
    reports every problem at its line); length: the length unit read (or the default m),
    length_given: whether the file gave a valid one."""
    v = node.value
    system = force = mass = None
    if "system" in v:
        system = V.choice(v["system"], "units: system", tuple(SYSTEMS))
    if "force" in v:
        force = V.choice(v["force"], "units: force", tuple(FORCES))
    if "mass" in v:
        mass = V.choice(v["mass"], "units: mass", tuple(MASSES))
    length_line = v["length"].line if "length" in v else node.line
    force_line = v["force"].line if "force" in v else 0
    if system is not None:
        sl, sm, sf = SYSTEMS[system]
        for key, given, want in (("length", length if length_given else None, sl),
                                 ("mass", mass, sm), ("force", force, sf)):
            if given is not None and given != want:
                V.err(v[key], f"units: {key} {given} contradicts system {system} "
                              f"({_system_text(system)}): give the system alone, or length, "
                              f"force and mass without it")
        return UnitChoice(sl, system, sf, None, length_line, force_line)
    if force is not None and length not in LENGTHS:
        known = ", ".join(k for k in LENGTHS if k.isascii())
        V.err(v["force"], f"units: force {force} needs a length unit of known size ({known}), "
                          f"not '{length}'; or leave force out: forces are then in "
                          f"{mass or 'kg'}*{length}/s^2")
        force = None
    return UnitChoice(length, None, force, mass, length_line, force_line)


def unit_notes(choice: UnitChoice | None, units: ForceUnits, masses: bool) -> list:
    """[(line, message)]: the warnings of a model that has forces (masses: whether it has a mass
    or an inertia): forces in another unit than N that the file did not choose, and masses read
    in another unit than kg that the file did not name."""
    out = []
    if choice is None:
        choice = UnitChoice()
    L, M = units.length, units.mass
    if choice.force is None and units.force != "N":
        Lm = LENGTHS.get(L)
        size = ""
        if Lm is not None:
            value = MASSES[M] * Lm
            named = _named(FORCES, value)
            size = "" if named == units.force else f" (= {named})" if named else \
                f" (= {value:g} N)"
        if Lm is not None:
            how = (f"for forces in N and torques in N*{L}, write units: {{length: {L}, "
                   f"force: N, mass: {M}}} (loads, spring rates k and dampings c are then read "
                   f"in N)")
        else:
            how = (f"a force unit (units: force: {one_of(FORCES)}) needs a length unit of "
                   f"known size ({', '.join(k for k in LENGTHS if k.isascii())})")
        out.append((choice.length_line, f"units: forces are in {units.force}{size} and torques "
                                        f"in {units.torque}, from lengths in {L} and masses in "
                                        f"{M}: {how}"))
    if choice.force is not None and choice.system is None and choice.mass is None and \
            masses and units.mass != "kg":
        out.append((choice.force_line,
                    f"units: masses are in {M} and inertias in {M}*{L}^2 (the mass unit "
                    f"consistent with {units.force} and {L}: 1 {units.force} = 1 {M}*{L}/s^2); "
                    f"if they are kg and kg*{L}^2, add mass: kg to units"))
    return out


def systems_table() -> str:
    """The named systems (markdown rows: name, length, mass, force, torque, power)."""
    rows = ["| system | length | mass | force | torque | power |", "|---|---|---|---|---|---|"]
    for name, (length, _, force) in SYSTEMS.items():
        u = force_units(length, force)
        cells = [name, length, u.mass, u.force, u.torque, u.power]
        rows.append("| " + " | ".join(f"`{c}`" for c in cells) + " |")
    return "\n".join(rows)
