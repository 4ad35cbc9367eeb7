"""Unit systems of the forces room (issue 31, item 1): `units: {length, force, mass}` and the
named systems (`system: SI | mm-N-s | mm-kg-s | in-lbf-s`).

One slider-crank with masses, inertias, centres of mass, gravity, a force, a torque, a spring
and a damper is written in each system, its inputs converted by the hand-written factors below;
the forces.csv and loads.csv that `planarkin run` writes must be the SI run's, converted by the
same factors, to 1e-12 of the largest value of each quantity. Every header names its unit, the
summary says the units, the note on forces in kg*length/s^2 appears exactly when the file chose
no force unit, and bad units are refused with their exact messages.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from clitools import run_cli

LBF = 4.4482216152605        # N (exact, by definition)
INCH = 0.0254                # m (exact, by definition)

# the model in SI (m, kg, N, s; angles deg); {units} and every number scaled by `scaled`
MODEL = """\
name: sc-units
units: {units}
gravity: [0, {g}]
bodies:
  crank:  {{q: [0, 0, 20], mass: {m1}, inertia: {J1}, cm: [{c1x}, {c1y}]}}
  rod:    {{q: [{x2}, 0, -5], mass: {m2}, inertia: {J2}, cm: [{c2x}, {c2y}]}}
  slider: {{q: [{x3}, 0, 0], mass: {m3}, inertia: {J3}, cm: [{c3x}, {c3y}]}}
joints:
  - {{name: main, type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{name: pin, type: revolute, i: crank, j: rod, si: [{a}, 0], sj: [0, 0]}}
  - {{name: wrist, type: revolute, i: rod, j: slider, si: [{b}, 0], sj: [0, 0]}}
  - {{name: guide, type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0],
     vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{name: motor, type: angle, body: crank, f: "30 + 360*t + 20*sin(2*pi*t)"}}
loads:
  - {{name: gas, type: force, body: slider, s: [{sx}, {sy}], f: ["{F0}*(1 + sin(2*pi*t))", "{F1}"]}}
  - {{name: brake, type: torque, body: crank, f: "{T0}*cos(2*pi*t)"}}
  - {{name: return, type: spring, i: ground, j: slider, si: [{p}, 0], sj: [0, 0], k: {k},
     length: {l0}}}
  - {{name: shock, type: damper, i: ground, j: rod, si: [{q}, {q}], sj: [{r}, 0], c: {c}}}
analysis: {{start: 0, end: 1, steps: 48}}
"""

# SI values: lengths (m), masses (kg), inertias (kg*m^2), forces (N), torques (N*m), spring rate
# (N/m), damping (N*s/m), gravity (m/s^2)
LENGTH = {"c1x": 0.035, "c1y": 0.012, "x2": 0.2, "c2x": 0.13, "c2y": -0.008, "x3": 0.4,
          "c3x": 0.005, "c3y": 0.003, "a": 0.1, "b": 0.32, "sx": 0.01, "sy": 0.005, "p": 0.6,
          "l0": 0.15, "q": 0.2, "r": 0.16}
MASS = {"m1": 1.3, "m2": 2.1, "m3": 0.7}
INERTIA = {"J1": 0.0021, "J2": 0.018, "J3": 5e-5}


def model(units: str, length: float, force: float, mass: float) -> str:
    """The model with its inputs in file units: length, force and mass are the sizes of the
    file's units per metre, newton and kilogram."""
    v = {k: x * length for k, x in LENGTH.items()}
    v.update({k: x * mass for k, x in MASS.items()})
    v.update({k: x * mass * length ** 2 for k, x in INERTIA.items()})
    v.update(g=-9.81 * length, F0=-200 * force, F1=15 * force, T0=-3 * force * length,
             k=1500 * force / length, c=40 * force / length)
    return MODEL.format(units=units, **{k: repr(float(x)) for k, x in v.items()})


# name: (units:, file units per m, per N, per kg; header units of force, torque, power; summary
# mass unit)
SYSTEMS = {
    "m-kg-N": ("{length: m, angle: deg}", 1.0, 1.0, 1.0, "N", "N*m", "W", "kg"),
    "SI": ("{system: SI, angle: deg}", 1.0, 1.0, 1.0, "N", "N*m", "W", "kg"),
    "mm-kg-N": ("{length: mm, angle: deg, force: N, mass: kg}", 1e3, 1.0, 1.0, "N", "N*mm",
                "mW", "kg"),
    "mm-t-N": ("{system: mm-N-s, angle: deg}", 1e3, 1.0, 1e-3, "N", "N*mm", "mW", "t"),
    "mm-t-N keys": ("{length: mm, angle: deg, force: N, mass: t}", 1e3, 1.0, 1e-3, "N", "N*mm",
                    "mW", "t"),
    "mm-kg (default)": ("{length: mm, angle: deg}", 1e3, 1e3, 1.0, "kg*mm/s^2",
                        "kg*mm^2/s^2", "kg*mm^2/s^3", "kg"),
    "mm-kg-s": ("{system: mm-kg-s, angle: deg}", 1e3, 1e3, 1.0, "mN", "mN*mm", "mN*mm/s",
                "kg"),
    "m-kg-kN": ("{length: m, angle: deg, force: kN, mass: kg}", 1.0, 1e-3, 1.0, "kN", "kN*m",
                "kW", "kg"),
    "in-lbf-s": ("{system: in-lbf-s, angle: deg}", 1 / INCH, 1 / LBF, INCH / LBF, "lbf",
                 "lbf*in", "lbf*in/s", "lbf*s^2/in"),
}
TOL = 1e-12


def quantity(header: str) -> str:
    """force, torque, power, angle or time: what a column of forces.csv or loads.csv holds."""
    name = header.split(" [", 1)[0]
    if name == "t":
        return "time"
    part = name.rsplit(".", 1)[1]
    return {"fx": "force", "fy": "force", "force": "force", "magnitude": "force",
            "torque": "torque", "power": "power", "direction": "angle"}[part]


def read(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """{system: (forces.csv (header, X), loads.csv (header, X), summary, stderr)}."""
    out = {}
    for name, (units, length, force, mass, *_) in SYSTEMS.items():
        d = tmp_path_factory.mktemp("units")
        (d / "m.yaml").write_text(model(units, length, force, mass))
        r = run_cli("run", "m.yaml", "--out", "out", "--no-plots", "-q", cwd=d)
        assert r.returncode == 0, (name, r.stderr)
        o = d / "out" / "m"
        out[name] = (read(o / "forces.csv"), read(o / "loads.csv"),
                     json.loads((o / "summary.json").read_text()), r.stderr)
    return out


def factors(name):
    _, length, force, *_ = SYSTEMS[name]
    return {"force": force, "torque": force * length, "power": force * length}


@pytest.mark.parametrize("name", list(SYSTEMS))
@pytest.mark.parametrize("table", [0, 1], ids=["forces.csv", "loads.csv"])
def test_every_system_gives_the_si_forces_converted(runs, name, table):
    (H, A) = runs["m-kg-N"][table]
    (h, B) = runs[name][table]
    assert len(h) == len(H) and B.shape == A.shape
    assert np.array_equal(B[:, 0], A[:, 0])
    f = factors(name)
    kinds = [quantity(x) for x in H]
    scale = {q: np.abs(A[:, [k for k, x in enumerate(kinds) if x == q]]).max(initial=0.0)
             * f[q] for q in f}
    worst = 0.0
    for k, q in enumerate(kinds):
        if q in f:
            err = np.abs(B[:, k] - f[q] * A[:, k]).max() / scale[q]
            worst = max(worst, err)
            assert err <= TOL, (H[k], err)
        elif q == "angle":                  # directions (deg) of forces not near zero
            stem = H[k].split(" [", 1)[0].rsplit(".", 1)[0]
            fx, fy = (A[:, H.index(f"{stem}.{c} [N]")] for c in ("fx", "fy"))
            big = np.hypot(fx, fy) > 1e-6 * scale["force"] / f["force"]
            d = (B[big, k] - A[big, k] + 180) % 360 - 180
            assert np.abs(d).max(initial=0.0) <= 1e-9, H[k]
    if name in ("m-kg-N", "SI"):
        assert worst == 0.0                 # the same numbers: the same bytes


def test_si_by_name_writes_the_bytes_of_the_default(runs):
    assert runs["SI"][0][0] == runs["m-kg-N"][0][0]
    assert np.array_equal(runs["SI"][0][1], runs["m-kg-N"][0][1])
    assert np.array_equal(runs["SI"][1][1], runs["m-kg-N"][1][1])
    assert runs["SI"][2]["forces"] == runs["m-kg-N"][2]["forces"]


@pytest.mark.parametrize("name", list(SYSTEMS))
def test_every_header_and_summary_names_its_unit(runs, name):
    _, length, _, _, F, T, P, M = SYSTEMS[name]
    lu = "m" if length == 1.0 else "mm" if length == 1e3 else "in"
    want = {"time": "s", "force": F, "torque": T, "power": P, "angle": "deg"}
    for table in (0, 1):
        for h in runs[name][table][0]:
            assert h.endswith(f" [{want[quantity(h)]}]"), (name, h)
    s = runs[name][2]
    assert s["forces"]["units"] == {"force": F, "torque": T, "power": P, "mass": M,
                                    "length": lu}
    assert s["loads"]["units"] == {"force": F, "torque": T, "angle": "deg", "length": lu}
    assert s["units"] == {"length": lu, "angle": "deg", "time": "s"}
    assert "motor.torque" in s["forces"]["peak"]


@pytest.mark.parametrize("name,force,effort", [("mm-kg-N", "N", "N·mm"),
                                               ("in-lbf-s", "lbf", "lbf·in")])
def test_the_plot_labels_say_the_units(name, force, effort, tmp_path):
    import planarkin
    from planarkin.derived import derived_tables
    from planarkin.forces.plot import forces_figure
    units, length, f, mass, *_ = SYSTEMS[name]
    res = planarkin.solve(planarkin.load("m.yaml", text=model(units, length, f, mass)))
    X = derived_tables(res.model, res.info.options)[0].compute(res._chunk)
    labels = [ax.get_ylabel() for ax in forces_figure(res.model, X, res.info).axes]
    assert f"driver effort [{effort}]" in labels
    assert f"joint reaction |F| [{force}]" in labels


# -- the note on forces in kg*length/s^2 -------------------------------------------------------
NOTE_MM = ("m.yaml:1: warning: units: forces are in kg*mm/s^2 (= mN) and torques in "
           "kg*mm^2/s^2, from lengths in mm and masses in kg: for forces in N and torques in "
           "N*mm, write units: {length: mm, force: N, mass: kg} (loads, spring rates k and "
           "dampings c are then read in N)")
NOTE_T = ("m.yaml:1: warning: units: masses are in t and inertias in t*mm^2 (the mass unit "
          "consistent with N and mm: 1 N = 1 t*mm/s^2); if they are kg and kg*mm^2, add "
          "mass: kg to units")

SMALL = """\
units: {units}
bodies:
  arm: {{q: [0, 0, 0]{mass}}}
joints:
  - {{type: revolute, i: ground, j: arm, si: [0, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, body: arm, f: "t"}}
{extra}analysis: {{end: 1, steps: 4}}
"""
LOAD = "loads:\n  - {type: force, body: arm, s: [1, 0], f: ['0', '-2']}\n"


def warnings_of(tmp_path, units, mass=", mass: 2, inertia: 3", extra=""):
    (tmp_path / "m.yaml").write_text(SMALL.format(units=units, mass=mass, extra=extra))
    r = run_cli("check", "m.yaml", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    return [line for line in r.stderr.splitlines() if ": warning: " in line]


@pytest.mark.parametrize("units,mass,extra,want", [
    ("{length: mm}", ", mass: 2, inertia: 3", "", [NOTE_MM]),
    ("{length: mm}", "", LOAD, [NOTE_MM]),                        # a load alone has forces
    ("{length: mm}", "", "gravity: [0, -9810]\n", []),           # gravity without mass: none
    ("{length: mm}", "", "", []),                                 # no forces at all
    ("{length: m}", ", mass: 2, inertia: 3", LOAD, []),
    ("{angle: deg}", ", mass: 2", "", []),
    ("{length: mm, force: N, mass: kg}", ", mass: 2", LOAD, []),
    ("{length: mm, force: N}", ", mass: 2", "", [NOTE_T]),
    ("{length: mm, force: N}", ", inertia: 3", "", [NOTE_T]),
    ("{length: mm, force: N}", "", LOAD, []),                     # no masses to misread
    ("{length: m, force: N}", ", mass: 2", "", []),               # masses in kg already
    ("{length: mm, mass: t}", ", mass: 2", LOAD, []),             # forces in N
    ("{system: mm-N-s}", ", mass: 2", LOAD, []),
    ("{system: mm-kg-s}", ", mass: 2", LOAD, []),
    ("{system: in-lbf-s}", ", mass: 2", LOAD, []),
])
def test_the_note_appears_exactly_when_the_file_chose_no_force_unit(tmp_path, units, mass,
                                                                     extra, want):
    assert warnings_of(tmp_path, units, mass, extra) == want


def test_the_note_names_the_force_unit_of_other_lengths_and_masses(tmp_path):
    cm = warnings_of(tmp_path, "{length: cm}")
    assert cm == ["m.yaml:1: warning: units: forces are in kg*cm/s^2 (= 0.01 N) and torques in "
                  "kg*cm^2/s^2, from lengths in cm and masses in kg: for forces in N and "
                  "torques in N*cm, write units: {length: cm, force: N, mass: kg} (loads, "
                  "spring rates k and dampings c are then read in N)"]
    g = warnings_of(tmp_path, "{length: m, mass: g}")
    assert g == ["m.yaml:1: warning: units: forces are in mN and torques in mN*m, from "
                 "lengths in m and masses in g: for forces in N and torques in N*m, write units: "
                 "{length: m, force: N, mass: g} (loads, spring rates k and dampings c are then "
                 "read in N)"]
    odd = warnings_of(tmp_path, "{length: furlong}")
    assert odd == ["m.yaml:1: warning: units: forces are in kg*furlong/s^2 and torques in "
                   "kg*furlong^2/s^2, from lengths in furlong and masses in kg: a force unit "
                   "(units: force: 'N', 'kN', 'mN' or 'lbf') needs a length unit of known size "
                   "(m, dm, cm, mm, um, km, in, ft)"]


# -- bad units -------------------------------------------------------------------------------
BAD = [
    ("{length: mm, force: newton}", "m.yaml:1: error: units: force must be 'N', 'kN', 'mN' or "
                                    "'lbf', not 'newton'"),
    ("{length: mm, mass: kilo}", "m.yaml:1: error: units: mass must be 'kg', 'g', 't' or 'lb', "
                                 "not 'kilo'"),
    ("{system: cgs}", "m.yaml:1: error: units: system must be 'SI', 'mm-N-s', 'mm-kg-s' or "
                      "'in-lbf-s', not 'cgs'"),
    ("{system: mm-N-s, length: m}", "m.yaml:1: error: units: length m contradicts system mm-N-s "
                                    "(length mm, mass t, force N): give the system alone, or "
                                    "length, force and mass without it"),
    ("{system: mm-N-s, mass: kg}", "m.yaml:1: error: units: mass kg contradicts system mm-N-s "
                                   "(length mm, mass t, force N): give the system alone, or "
                                   "length, force and mass without it"),
    ("{system: SI, force: kN}", "m.yaml:1: error: units: force kN contradicts system SI (length "
                                "m, mass kg, force N): give the system alone, or length, force "
                                "and mass without it"),
    ("{length: furlong, force: N}", "m.yaml:1: error: units: force N needs a length unit of "
                                    "known size (m, dm, cm, mm, um, km, in, ft), not 'furlong'; "
                                    "or leave force out: forces are then in kg*furlong/s^2"),
    ("{length: mm, time: s}", "m.yaml:1: error: units: unknown key 'time' (valid keys: length, "
                              "angle, force, mass, system)"),
]


@pytest.mark.parametrize("units,message", BAD, ids=[b[0] for b in BAD])
def test_bad_units_are_refused_naming_the_choices(tmp_path, units, message):
    (tmp_path / "m.yaml").write_text(SMALL.format(units=units, mass=", mass: 2", extra=""))
    r = run_cli("check", "m.yaml", cwd=tmp_path)
    assert r.returncode == 2
    assert [line for line in r.stderr.splitlines() if ": error: " in line] == [message]


def test_a_system_and_the_units_it_has_are_accepted(tmp_path):
    units = "{system: mm-N-s, length: mm, force: N, mass: t}"
    assert warnings_of(tmp_path, units, ", mass: 2", LOAD) == []


def test_default_units_convert_nothing():
    """The default (no force, mass or system): masses in kg, used as written (factor exactly 1),
    and the unit names of before."""
    from planarkin.forces.units import force_units
    for length, names in (("m", ("N", "N*m", "W")),
                          ("mm", ("kg*mm/s^2", "kg*mm^2/s^2", "kg*mm^2/s^3")),
                          ("furlong", ("kg*furlong/s^2", "kg*furlong^2/s^2",
                                       "kg*furlong^2/s^3"))):
        u = force_units(length)
        assert (u.force, u.torque, u.power, u.mass, u.mass_factor) == (*names, "kg", 1.0)


def test_the_forces_how_to_shows_the_systems_table():
    from clitools import ROOT

    from planarkin.forces.units import systems_table
    text = (ROOT / "docs" / "how-to" / "forces.md").read_text()
    assert "## Units of forces" in text and systems_table() in text
