"""loads.csv and the ``loads`` section of summary.json: every joint's reaction in the ground frame
and in the frame of each body it connects, for sizing parts (issue 30, item 3).

The references do not use the solver's Jacobians or multipliers: a slider-crank with a massless
crank and rod is solved by hand (a massless rod is a two-force member: in its own frame the pin
forces have no y component); the power balances use only the result's exact q, q', q'' and the
model's masses and loads; the summary is checked against the table it summarises.
"""

from __future__ import annotations

import csv
import json
import math
import re

import numpy as np
import pytest
from clitools import run_cli

import planarkin
from test_contact_forces import VALVE
from test_forces import SC, SLIDER_CRANK

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent

G = -9.81


def load(text: str, name="model.yaml"):
    return planarkin.load(name, text=text)


def solved(text: str, **kw):
    res = planarkin.solve(load(text), **kw)
    assert res.success, res.message
    return res


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], np.array(rows[1:], dtype=float)


def wrap(a):
    """An angle difference in (-pi, pi]."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# -- a slider-crank solved by hand ----------------------------------------------------------------
# Crank O-A (a, massless, frame at O along OA) driven at constant speed against a constant drag
# torque; rod A-B (b, massless, frame at A along AB); slider at B on the x axis (mass m, gravity,
# a gas force P(t) along x). The rod carries a force C along its axis only (C > 0: compression):
# on the slider C u (u = (B - A) / b), so along x C u_x + P = m x_B'' and across the guide
# N = -C u_y - m g. In the rod's frame the pin forces are (C, 0) at A and (-C, 0) at B; in the
# crank's frame (angle theta) the bearing force is C (cos(beta - theta), sin(beta - theta)) (beta
# the rod's angle) and the crank pin's minus it; the motor torque balances the crank:
# T = -drag + C a sin(beta - theta).
HAND = dict(a=0.1, b=0.3, m=0.8, drag=-5.0, th0=0.3)
HAND_SC = f"""
name: sc-by-hand
units: {{length: m, angle: rad}}
parameters: {{a: {HAND['a']}, b: {HAND['b']}}}
gravity: [0, {G}]
bodies:
  crank:  {{q: [0, 0, 0.3]}}
  rod:    {{q: [0.1, 0, -0.1]}}
  slider: {{q: [0.4, 0, 0], mass: {HAND['m']}}}
joints:
  - {{type: revolute, name: main-bearing, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, name: crank-pin, i: crank, j: rod, si: [a, 0], sj: [0, 0]}}
  - {{type: revolute, name: wrist-pin, i: rod, j: slider, si: [b, 0], sj: [0, 0]}}
  - {{type: translational, name: guide, i: ground, j: slider, si: [0, 0], sj: [0, 0],
     vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{type: angle, name: motor, body: crank, f: "{HAND['th0']} + 2*pi*t"}}
loads:
  - {{type: force, name: gas, body: slider, f: ["-200*(1 + cos(2*pi*t))", "0"]}}
  - {{type: torque, name: drag, body: crank, f: "{HAND['drag']}"}}
analysis: {{start: 0, end: 1, steps: 72}}
"""


def hand_reference(t):
    a, b, m, drag = HAND["a"], HAND["b"], HAND["m"], HAND["drag"]
    w = 2 * np.pi
    th = HAND["th0"] + w * t
    s, c = np.sin(th), np.cos(th)
    r = np.sqrt(b * b - a * a * s * s)
    # x_B = a cos(theta) + r; r r' = -a^2 s c w
    rdd = -a * a * w * w * np.cos(2 * th) / r - a ** 4 * w * w * s * s * c * c / r ** 3
    xdd = -a * w * w * c + rdd
    ux, uy = r / b, -a * s / b
    beta = np.arctan2(uy, ux)
    P = -200 * (1 + np.cos(w * t))
    C = (m * xdd - P) / ux
    N = -C * uy - m * G
    return dict(C=C, N=N, theta=th, beta=beta, ux=ux, uy=uy,
                motor=-drag + C * a * np.sin(beta - th))


@pytest.fixture(scope="module")
def hand():
    res = solved(HAND_SC)
    return res, res.table("loads.csv"), hand_reference(res.t)


def test_massless_rod_carries_its_pin_forces_along_its_axis(hand):
    res, L, ref = hand
    C = ref["C"]
    scale = np.abs(C).max()
    assert (C > 0).any() and scale > 100
    # in the rod's frame: (C, 0) at A (crank-pin, on j = rod), (-C, 0) at B (wrist-pin, on i)
    assert np.abs(L["crank-pin.rod.fx"] - C).max() <= 1e-12 * scale
    assert np.abs(L["crank-pin.rod.fy"]).max() <= 1e-12 * scale
    assert np.abs(L["wrist-pin.rod.fx"] + C).max() <= 1e-12 * scale
    assert np.abs(L["wrist-pin.rod.fy"]).max() <= 1e-12 * scale
    # its direction: along the rod's axis, 0 in compression, pi in tension at A
    assert np.abs(wrap(L["crank-pin.rod.direction"] - np.where(C > 0, 0, np.pi)) * C).max() \
        <= 1e-12 * scale


def test_crank_slider_and_ground_frames_in_closed_form(hand):
    res, L, ref = hand
    C, N, th, beta = ref["C"], ref["N"], ref["theta"], ref["beta"]
    scale = np.abs(C).max()

    def close(got, want, what):
        err = np.abs(np.asarray(got) - want).max() / scale
        assert err <= 1e-12, (what, err)

    # the pins in the ground frame: C u on body j of each
    for joint in ("main-bearing", "crank-pin", "wrist-pin"):
        close(L[f"{joint}.fx"], C * ref["ux"], joint)
        close(L[f"{joint}.fy"], C * ref["uy"], joint)
        close(L[f"{joint}.magnitude"], np.abs(C), joint)
    # the crank's frame: the bearing pushes C (cos, sin)(beta - theta), the crank pin minus it
    close(L["main-bearing.crank.fx"], C * np.cos(beta - th), "bearing on crank")
    close(L["main-bearing.crank.fy"], C * np.sin(beta - th), "bearing on crank")
    close(L["crank-pin.crank.fx"], -C * np.cos(beta - th), "pin on crank")
    close(L["crank-pin.crank.fy"], -C * np.sin(beta - th), "pin on crank")
    # the slider (frame parallel to the ground's): the wrist pin C u, the guide (0, N), no moment
    close(L["wrist-pin.slider.fx"], C * ref["ux"], "pin on slider")
    close(L["wrist-pin.slider.fy"], C * ref["uy"], "pin on slider")
    close(L["guide.slider.fx"], 0.0, "guide")
    close(L["guide.slider.fy"], N, "guide")
    close(L["guide.fy"], N, "guide")
    close(L["guide.magnitude"], np.abs(N), "guide")
    close(L["guide.torque"] / HAND["a"], 0.0, "guide moment")
    close(L["guide.slider.torque"] / HAND["a"], 0.0, "guide moment")
    # the guide pushes up or down: direction +-pi/2 in the ground and the slider's frame
    assert (N > 0).any() and (N < 0).any()
    up = np.where(N > 0, np.pi / 2, -np.pi / 2)
    assert np.abs(L["guide.direction"] - up).max() <= 1e-12
    assert np.abs(L["guide.slider.direction"] - up).max() <= 1e-12
    # the motor torque that drives the massless crank against the drag
    torque = res.table("forces.csv")["motor.torque"]
    close(torque / HAND["a"], ref["motor"] / HAND["a"], "motor torque")


def test_summary_peak_is_the_largest_grid_row(hand, tmp_path):
    res, L, ref = hand
    s = res.write(tmp_path, plots=None)
    peak = s["loads"]["joints"]["main-bearing"]["peak"]
    k = int(np.argmax(np.abs(ref["C"])))
    assert peak["t"] == res.t[k]
    assert abs(peak["magnitude"] - abs(ref["C"][k])) <= 1e-12 * abs(ref["C"][k])
    assert abs(peak["crank"]["fy"] - ref["C"][k] * np.sin(ref["beta"][k] - ref["theta"][k])) \
        <= 1e-12 * abs(ref["C"][k])
    assert peak["unit"] == "N" and set(peak) == {"t", "magnitude", "unit", "ground", "crank"}


# -- loads.csv is forces.csv's reactions, turned into each body's frame ---------------------------
def _frames_of(res):
    """{(joint, body): (fx, fy, torque) of the reaction on body, ground frame}, from the solver's
    reactions (forces.csv's on j) and the body's angle."""
    from planarkin.forces.solve import Kinetostatics
    cm = res.model
    F = Kinetostatics(cm).solve(res.t, res.q, res.qd, res.qdd)
    out = {}
    for e, el in enumerate(cm.spec.joints):
        for slot, body in enumerate(el.bodies[:2]):
            if body != "ground":
                out[el.name, body] = F.reaction(e, slot)
    return out


@pytest.mark.parametrize("text", [SLIDER_CRANK, VALVE], ids=["slider-crank", "valve-cam"])
def test_loads_are_the_reactions_of_forces_csv_turned_exactly(text):
    res = solved(text)
    f, L = res.table("forces.csv"), res.table("loads.csv")
    af = res.model.angle_factor
    joints = [el.name for el in res.model.spec.joints]
    for j in joints:                     # the ground frame: forces.csv's own numbers
        for part in ("fx", "fy", "torque"):
            if f"{j}.{part}" in f:
                assert np.array_equal(L[f"{j}.{part}"], f[f"{j}.{part}"]), (j, part)
        assert np.array_equal(L[f"{j}.magnitude"], np.hypot(f[f"{j}.fx"], f[f"{j}.fy"]))
        assert np.array_equal(L[f"{j}.direction"],
                              np.arctan2(f[f"{j}.fy"] + 0.0, f[f"{j}.fx"] + 0.0) / af)
    for (j, body), (gx, gy, gm) in _frames_of(res).items():
        phi = res.body(body)["phi"] * af
        scale = max(np.abs(gx).max(), np.abs(gy).max())
        bx, by = L[f"{j}.{body}.fx"], L[f"{j}.{body}.fy"]
        # turned back into the ground frame, they are the reaction on that body
        c, s = np.cos(phi), np.sin(phi)
        assert np.abs(c * bx - s * by - gx).max() <= 1e-14 * scale, (j, body)
        assert np.abs(s * bx + c * by - gy).max() <= 1e-14 * scale, (j, body)
        assert np.abs(np.hypot(bx, by) - L[f"{j}.magnitude"]).max() <= 1e-14 * scale
        assert np.array_equal(L[f"{j}.{body}.direction"], np.arctan2(by + 0.0, bx + 0.0) / af)
        if f"{j}.{body}.torque" in L:
            assert np.array_equal(L[f"{j}.{body}.torque"], gm)
    # on body j the force is forces.csv's; on i of a joint minus it (third law)
    for el in res.model.spec.joints:
        if el.bodies[0] != "ground":
            i, j = el.bodies[:2]
            c, s = np.cos(res.body(i)["phi"] * af), np.sin(res.body(i)["phi"] * af)
            bx, by = L[f"{el.name}.{i}.fx"], L[f"{el.name}.{i}.fy"]
            scale = np.abs(L[f"{el.name}.magnitude"]).max()
            assert np.abs(c * bx - s * by + f[f"{el.name}.fx"]).max() <= 1e-12 * scale
            assert np.abs(s * bx + c * by + f[f"{el.name}.fy"]).max() <= 1e-12 * scale


# -- virtual power: the reactions do no work; per body, power in = rate of kinetic energy ---------
def _kinematics(res, body):
    af = res.model.angle_factor
    if body == "ground":
        z = np.zeros_like(res.t)
        return dict(x=z, y=z, phi=z, vx=z, vy=z, w=z, ax=z, ay=z, al=z)
    b = res.body(body)
    return dict(x=b["x"], y=b["y"], phi=b["phi"] * af, vx=b["vx"], vy=b["vy"], w=b["omega"] * af,
                ax=b["ax"], ay=b["ay"], al=b["alpha"] * af)


def _point(k, s):
    c, sn = np.cos(k["phi"]), np.sin(k["phi"])
    sx, sy = c * s[0] - sn * s[1], sn * s[0] + c * s[1]
    return (k["x"] + sx, k["y"] + sy, k["vx"] - k["w"] * sy, k["vy"] + k["w"] * sx,
            k["ax"] - k["al"] * sy - k["w"] ** 2 * sx, k["ay"] + k["al"] * sx - k["w"] ** 2 * sy)


def _reaction_power(res, L, joint, body, P):
    """(power, size): power of the joint's reaction on body (loads.csv's, in the body's frame)
    acting at the global point P (x, y): F' . v'(P) + M omega, v'(P) the velocity of the body's
    material point at P in the body's frame; size: the largest of its terms' magnitudes."""
    k = _kinematics(res, body)
    c, s = np.cos(k["phi"]), np.sin(k["phi"])
    px, py = c * (P[0] - k["x"]) + s * (P[1] - k["y"]), c * (P[1] - k["y"]) - s * (P[0] - k["x"])
    vx = c * k["vx"] + s * k["vy"] - k["w"] * py
    vy = c * k["vy"] - s * k["vx"] + k["w"] * px
    fx, fy = L[f"{joint}.{body}.fx"], L[f"{joint}.{body}.fy"]
    M = L.get(f"{joint}.{body}.torque", 0.0)
    terms = (fx * vx, fy * vy, M * k["w"])
    return sum(terms), max(float(np.abs(x).max()) for x in terms)


# the joints' points (where forces.csv's moment is taken): body j's point sj, here its origin
SC_POINTS = {"O": ("crank", (0, 0)), "A": ("rod", (-SC["c2"], 0)), "B": ("slider", (0, 0)),
             "guide": ("slider", (0, 0))}
VALVE_POINTS = {"bearing": ("cam", (0, 0)), "guide": ("tappet", (0, 0)),
                "valve": ("tappet", (0, 0))}


@pytest.mark.parametrize("text, points", [(SLIDER_CRANK, SC_POINTS), (VALVE, VALVE_POINTS)],
                         ids=["slider-crank", "valve-cam"])
def test_the_reactions_in_the_body_frames_do_no_work(text, points):
    res = solved(text)
    L = res.table("loads.csv")
    for el in res.model.spec.joints:
        owner, s = points[el.name]
        P = _point(_kinematics(res, owner), s)[:2]
        got = [_reaction_power(res, L, el.name, b, P) for b in el.bodies[:2] if b != "ground"]
        power = sum(p for p, _ in got)
        # to the ground: its body's point at a pin is still, at a guide it slides along it
        scale = max(max(size for _, size in got), 1e-12 * np.abs(L[f"{el.name}.magnitude"]).max())
        assert np.abs(power).max() <= 1e-12 * scale, el.name
        if len(got) == 2:
            assert scale > 1.0, el.name


def test_every_body_balances_its_power_with_the_loads_in_its_frame():
    """Per body of the slider-crank of test_forces (masses, off-frame centres of mass, a varying
    crank speed, a press load): the power of its joint reactions (loads.csv, its frame) + the
    motor's + gravity's + the loads' = d/dt of its kinetic energy, at every row to 1e-9; summed
    over the bodies the reactions cancel: the drivers' and loads' power is dT/dt."""
    res = solved(SLIDER_CRANK)
    L = res.table("loads.csv")
    f = res.table("forces.csv")
    fs = res.model.spec.forces
    masses = {m.body: m for m in fs.masses}
    total = np.zeros_like(res.t)
    rates = np.zeros_like(res.t)
    for body in res.model.body_names:
        k = _kinematics(res, body)
        m = masses[body]
        _, _, vx, vy, ax, ay = _point(k, m.cm)
        dT = m.mass * (vx * ax + vy * ay) + m.inertia * k["w"] * k["al"]
        power = m.mass * G * vy
        for el in res.model.spec.joints:
            if body in el.bodies[:2]:
                owner, s = SC_POINTS[el.name]
                P = _point(_kinematics(res, owner), s)[:2]
                power = power + _reaction_power(res, L, el.name, body, P)[0]
        if body == "crank":
            power = power + f["motor.torque"] * k["w"]
        for ld in fs.loads:
            if ld.bodies[0] == body:
                _, _, pvx, pvy, _, _ = _point(k, ld.s)
                power = power + ld.f[0](res.t) * pvx + ld.f[1](res.t) * pvy
        scale = max(np.abs(dT).max(), 1e-300)
        assert np.abs(power - dT).max() <= 1e-9 * scale, body
        total += power
        rates += dT
    assert np.abs(total - rates).max() <= 1e-9 * np.abs(rates).max()


# -- the run writes it: header, units, summary, bytes ---------------------------------------------
@pytest.fixture(scope="module")
def example_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("loads")
    r = run_cli("run", "mechanisms/slider-crank.yaml", "--out", out, "--no-plots", "-q")
    assert r.returncode == 0, r.stderr
    d = out / "slider-crank"
    return d, json.loads((d / "summary.json").read_text())


EXAMPLE_HEADER = [
    "t [s]",
    "main-bearing.fx [N]", "main-bearing.fy [N]", "main-bearing.magnitude [N]",
    "main-bearing.direction [rad]",
    "main-bearing.crank.fx [N]", "main-bearing.crank.fy [N]", "main-bearing.crank.direction [rad]",
    "crank-pin.fx [N]", "crank-pin.fy [N]", "crank-pin.magnitude [N]", "crank-pin.direction [rad]",
    "crank-pin.crank.fx [N]", "crank-pin.crank.fy [N]", "crank-pin.crank.direction [rad]",
    "crank-pin.rod.fx [N]", "crank-pin.rod.fy [N]", "crank-pin.rod.direction [rad]",
    "wrist-pin.fx [N]", "wrist-pin.fy [N]", "wrist-pin.magnitude [N]", "wrist-pin.direction [rad]",
    "wrist-pin.rod.fx [N]", "wrist-pin.rod.fy [N]", "wrist-pin.rod.direction [rad]",
    "wrist-pin.slider.fx [N]", "wrist-pin.slider.fy [N]", "wrist-pin.slider.direction [rad]",
    "guide.fx [N]", "guide.fy [N]", "guide.magnitude [N]", "guide.direction [rad]",
    "guide.torque [N*m]",
    "guide.slider.fx [N]", "guide.slider.fy [N]", "guide.slider.direction [rad]",
    "guide.slider.torque [N*m]"]


def test_the_header_names_every_column_with_its_unit(example_run):
    d, s = example_run
    header, X = read_csv(d / "loads.csv")
    assert header == EXAMPLE_HEADER
    assert all(re.fullmatch(r"[\w.-]+ \[[^\]]+\]", h) for h in header)
    assert s["files"]["loads.csv"] == {"rows": 361, "columns": len(header)}
    assert len(X) == 361 and np.isfinite(X).all()
    assert s["loads"]["units"] == {"force": "N", "torque": "N*m", "angle": "rad", "length": "m"}
    # a model in mm and degrees: its units in every header
    text = SLIDER_CRANK.replace("name: sc-forces", "name: sc\nunits: {length: mm, angle: deg}")
    text = text.replace("a: 0.1, b: 0.32, c2: 0.13", "a: 100, b: 320, c2: 130")
    cm = load(text)
    from planarkin.derived import derived_tables
    from planarkin.solver.grid import Options
    _, loads = derived_tables(cm, Options.from_model(cm))
    assert "A.rod.direction [deg]" in loads.header and "guide.torque [kg*mm^2/s^2]" in loads.header
    assert "O.magnitude [kg*mm/s^2]" in loads.header


def test_directions_in_degrees_stay_in_the_half_open_range():
    text = SLIDER_CRANK.replace("name: sc-forces", "name: sc\nunits: {length: m, angle: deg}")
    text = text.replace('"0.4 + 2*pi*t + 0.3*sin(2*pi*t)"', '"22.9 + 360*t + 17*sin(2*pi*t)"')
    text = text.replace("q: [0, 0, 0.4]", "q: [0, 0, 23]").replace("q: [0.2, 0.0, -0.1]",
                                                                   "q: [0.2, 0.0, -6]")
    res = solved(text)
    L = res.table("loads.csv")
    for k, v in L.items():
        if k.endswith(".direction"):
            assert (v > -180).all() and (v <= 180).all(), k
    fx, fy = L["A.rod.fx"], L["A.rod.fy"]
    assert np.array_equal(L["A.rod.direction"], np.degrees(np.arctan2(fy + 0.0, fx + 0.0)))


def test_summary_extremes_means_and_amplitudes_are_the_tables(example_run):
    d, s = example_run
    header, X = read_csv(d / "loads.csv")
    col = {h.split(" [")[0]: X[:, k] for k, h in enumerate(header)}
    t = col["t"]
    joints = s["loads"]["joints"]
    assert list(joints) == ["main-bearing", "crank-pin", "wrist-pin", "guide"]
    assert joints["guide"]["i"] == "ground" and joints["guide"]["j"] == "slider"
    for name, rec in joints.items():
        k = int(np.argmax(col[f"{name}.magnitude"]))
        peak = rec["peak"]
        assert peak["t"] == t[k] and peak["magnitude"] == col[f"{name}.magnitude"][k], name
        assert peak["magnitude"] == s["columns"]["loads.csv"][f"{name}.magnitude [N]"]["max"]
        for frame in ["ground"] + [b for b in (rec["i"], rec["j"]) if b != "ground"]:
            prefix = name if frame == "ground" else f"{name}.{frame}"
            for part, v in peak[frame].items():
                assert v == col[f"{prefix}.{part}"][k], (name, frame, part)
            for part in ("fx", "fy", "torque"):
                if f"{prefix}.{part}" not in col:
                    continue
                v = col[f"{prefix}.{part}"]
                mean = np.sum((v[1:] + v[:-1]) * np.diff(t)) / 2 / (t[-1] - t[0])
                scale = max(np.abs(v).max(), 1e-300)
                assert abs(rec["mean"][frame][part] - mean) <= 1e-12 * scale, (name, part)
                assert rec["amplitude"][frame][part] == (v.max() - v.min()) / 2
        m = col[f"{name}.magnitude"]
        assert rec["amplitude"]["magnitude"] == (m.max() - m.min()) / 2
    # the gas force alone, averaged over a cycle, reaches the main bearing: mean fx = 200 N
    assert abs(joints["main-bearing"]["mean"]["ground"]["fx"] - 200.0) <= 1e-9
    assert any("not refined between rows" in n for n in s["loads"]["notes"])


def test_the_written_bytes_are_the_table_computed_afresh(example_run):
    """loads.csv goes through the same writer as forces.csv (exact shortest digits): its bytes
    are those of the table computed from the same rows by a fresh solve."""
    from planarkin.derived import derived_tables
    from planarkin.output.fastcsv import format_table
    d, _ = example_run
    res = planarkin.solve(ROOT / "mechanisms" / "slider-crank.yaml")
    loads = [t for t in derived_tables(res.model, res.info.options) if t.filename == "loads.csv"]
    X = loads[0].compute(res._chunk) + 0.0
    want = (",".join(loads[0].header) + "\n").encode() + format_table(X)
    assert (d / "loads.csv").read_bytes() == want


def test_parquet_holds_the_same_loads(tmp_path, example_run):
    pq = pytest.importorskip("pyarrow.parquet")
    d, _ = example_run
    r = run_cli("run", "mechanisms/slider-crank.yaml", "--out", tmp_path, "--no-plots", "-q",
                "--table-format", "parquet")
    assert r.returncode == 0, r.stderr
    table = pq.read_table(tmp_path / "slider-crank" / "loads.parquet")
    header, X = read_csv(d / "loads.csv")
    assert table.column_names == header
    assert np.array_equal(np.column_stack([table.column(h).to_numpy() for h in header]), X)


# -- what has loads, and what has none ------------------------------------------------------------
def test_a_model_without_forces_writes_no_loads_csv(tmp_path):
    text = HAND_SC.split("loads:")[0].replace(f", mass: {HAND['m']}", "")
    text = text.replace(f"gravity: [0, {G}]\n", "") + "analysis: {start: 0, end: 1, steps: 12}\n"
    res = solved(text)
    s = res.write(tmp_path, plots=None)
    assert not (tmp_path / "loads.csv").exists() and "loads.csv" not in s["files"]
    assert "loads" not in s
    with pytest.raises(KeyError, match="no table 'loads.csv'"):
        res.table("loads.csv")


def test_a_joint_that_transmits_a_moment_only_has_its_torques(tmp_path):
    """An arm welded to the crank (a revolute and an angle joint at the crank's pivot), turning
    at constant speed: the angle joint carries the moment of the arm's weight about the pin alone
    (its inertia force passes through the pin), and its peak is the largest |torque|."""
    text = """
name: weld
bodies:
  crank: {q: [0, 0, 0]}
  arm:   {q: [0, 0, 0], mass: 2, inertia: 0.05, cm: [0.3, 0]}
gravity: [0, -9.81]
joints:
  - {type: revolute, name: pivot, i: ground, j: crank, at: [0, 0]}
  - {type: revolute, name: pin, i: crank, j: arm, at: [0, 0]}
  - {type: angle, name: weld, i: crank, j: arm, c: 0}
drivers:
  - {type: angle, name: motor, body: crank, f: "2*pi*t"}
analysis: {start: 0, end: 1, steps: 36}
"""
    res = solved(text)
    L = res.table("loads.csv")
    assert [k for k in L if k.startswith("weld")] == ["weld.torque", "weld.crank.torque",
                                                      "weld.arm.torque"]
    th = 2 * np.pi * res.t
    # the arm turns at constant speed: moments about the pin: weld torque + weight's = 0
    want = 2 * 9.81 * 0.3 * np.cos(th)
    assert np.abs(L["weld.arm.torque"] - want).max() <= 1e-12 * want.max()
    assert np.array_equal(L["weld.crank.torque"], -L["weld.arm.torque"])     # i gets minus it
    s = res.write(tmp_path, plots=None)
    rec = s["loads"]["joints"]["weld"]
    k = int(np.argmax(np.abs(L["weld.torque"])))
    assert rec["peak"]["magnitude"] == abs(L["weld.torque"][k]) and rec["peak"]["unit"] == "N*m"
    assert rec["peak"]["arm"] == {"torque": L["weld.arm.torque"][k]}
    assert "magnitude" not in rec["mean"] and set(rec["mean"]["ground"]) == {"torque"}


def test_a_run_stopped_by_a_non_finite_force_has_equal_rows_of_loads(tmp_path):
    from test_force_rows import CRANK
    path = tmp_path / "crank.yaml"
    path.write_text(CRANK.format(f="1/(t - 0.5)"))
    r = run_cli("run", path, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 1
    d = tmp_path / "out" / "crank"
    _, X = read_csv(d / "loads.csv")
    _, Y = read_csv(d / "forces.csv")
    assert len(X) == len(Y) == 180 and np.isfinite(X).all()
    s = json.loads((d / "summary.json").read_text())
    peak = s["loads"]["joints"]["joint_1_revolute_ground-crank"]["peak"]
    assert math.isfinite(peak["magnitude"]) and peak["t"] < 0.5


def test_the_cam_models_rows_come_from_the_refusal_check(tmp_path):
    """A model with a cam has its force rows computed by the refusal check (for lift-off) and
    handed to the writer: loads.csv from them is the table computed afresh."""
    path = tmp_path / "valve.yaml"
    path.write_text(VALVE)
    r = run_cli("run", path, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 0, r.stderr
    header, X = read_csv(tmp_path / "out" / "valve" / "loads.csv")
    res = solved(VALVE)
    L = res.table("loads.csv")
    assert np.array_equal(X, np.column_stack([L[h.split(" [")[0]] for h in header]))
    assert "valve.cam.torque [N*m]" in header and "valve.tappet.fx [N]" in header


@pytest.mark.parametrize("model", ["slider-crank", "valve"])
def test_each_row_is_solved_once_for_both_tables(tmp_path, monkeypatch, model):
    """The writer computes forces.csv and then loads.csv from the same solve (a cam model's rows
    from the refusal check's): rows solved = rows written."""
    from planarkin.forces.output import ForceRows
    if model == "valve":
        path = tmp_path / "valve.yaml"
        path.write_text(VALVE)
    else:
        path = ROOT / "mechanisms" / "slider-crank.yaml"
    solved_rows = []
    compute = ForceRows.compute

    def counted(self, ch, *a, **kw):
        solved_rows.append(len(ch.t))
        return compute(self, ch, *a, **kw)
    monkeypatch.setattr(ForceRows, "compute", counted)
    r = run_cli("run", path, "--out", tmp_path / "out", "--no-plots", "-q")
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "out" / path.stem / "summary.json").read_text())
    assert s["files"]["loads.csv"]["rows"] == s["files"]["forces.csv"]["rows"] == sum(solved_rows)
