"""Force rows that are not finite stop the run there; a cam follower that would lift off is
reported (issue 21, items 3 and 5)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import planarkin
from planarkin.cli import main

from test_contact_forces import VALVE

CRANK = """
name: crank-load
bodies:
  crank: {{q: [0, 0, 0], mass: 1, inertia: 0.01}}
joints:
  - {{type: revolute, i: ground, j: crank, at: [0, 0]}}
drivers:
  - {{type: angle, body: crank, f: "2*pi*t"}}
loads:
  - {{type: torque, body: crank, f: "{f}"}}
analysis: {{start: 0, end: 1, steps: 360}}
"""


def run(tmp_path, text, name="model"):
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    r = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "out"), "--no-plots"])
    out = tmp_path / "out" / name
    summary = json.loads((out / "summary.json").read_text())
    rows = (out / "forces.csv").read_text().splitlines()[1:]
    return r, summary, rows


@pytest.mark.parametrize("f, rows, t", [("sqrt(0.5 - t)", 181, 0.5 + 1 / 360),
                                         ("1/(t - 0.5)", 180, 0.5)])
def test_a_non_finite_force_stops_the_run_at_its_row(tmp_path, f, rows, t):
    r, summary, lines = run(tmp_path, CRANK.format(f=f))
    assert r.exit_code == 1, r.output
    assert f"non-finite forces at t = {t:.10g} s" in r.output
    assert summary["status"] == "failed"
    assert summary["event"]["kind"] == "non-finite" and abs(summary["event"]["t"] - t) < 1e-12
    assert len(lines) == rows
    assert all(math.isfinite(float(x)) for line in lines for x in line.split(","))
    for rec in summary["forces"]["peak"].values():
        assert rec["value"] is not None and math.isfinite(rec["value"])


def test_peaks_never_skip_a_non_finite_value():
    from planarkin.forces.output import Accumulator
    acc = Accumulator(["t [s]", "a [N]", "b [N]"], [1], [], [], {"force": "N"})
    acc.add(np.array([[0.0, 1.0, 2.0], [0.1, np.nan, 3.0], [0.2, 5.0, -4.0]]))
    d = acc.as_dict()
    assert d["peak"]["a"] == {"value": None, "abs": None, "t": None, "non_finite_at": 0.1}
    assert d["peak"]["b"] == {"value": -4.0, "abs": 4.0, "t": 0.2}
    assert d["rms"]["a"] is None


# The valve train of test_contact_forces with a weak preload P: the contact force is
# f = P + m omega^2 h cos(theta) / 2, negative where cos(theta) < -2 P / (m omega^2 h), smallest
# at theta = 180 deg: P - m omega^2 h / 2.
@pytest.mark.parametrize("P", [0.05, 200.0])
def test_cam_lift_off_is_warned_with_time_and_margin(tmp_path, P):
    from planarkin.forces.output import cycle_contact
    from planarkin.measures.cycle import format_contact
    text = VALVE.replace('f: ["0", "-200"]', f'f: ["0", "-{P}"]')
    r, summary, lines = run(tmp_path, text, "valve")
    assert r.exit_code == 0, r.output
    m, w, h = 0.5, 2 * math.pi, 0.01
    low = P - m * w * w * h / 2
    rec = summary["forces"]["contact"]["valve"]
    assert rec["lift_off"] is (low < 0) and rec["unit"] == "N"
    assert abs(rec["min"] - low) <= 1e-9 * P and abs(rec["t"] - 0.5) < 1e-12
    warned = [w_ for w_ in summary["warnings"] if w_.get("kind") == "lift-off"]
    if low < 0:
        first = math.degrees(math.acos(-2 * P / (m * w * w * h)))
        t0 = math.ceil(first / 5) * 5 / 360                     # the first row past it
        assert len(warned) == 1 and abs(warned[0]["t"] - t0) < 1e-12
        msg = warned[0]["message"]
        assert f"turns negative at t = {t0:.6g} s" in msg and f"reaches {low:.4g} N" in msg
        assert "lift off" in r.output
        assert "lift off" in format_contact(cycle_contact(summary["forces"]))[0]
    else:
        assert not warned and "lift off" not in r.output
    assert cycle_contact(summary["forces"])["valve"] == rec
    col = lines[0].split(",")
    assert len(col) > 1


def test_contact_force_column_is_signed_and_in_forces_csv():
    cm = planarkin.load("valve.yaml", text=VALVE.replace('f: ["0", "-200"]', 'f: ["0", "-0.05"]'))
    res = planarkin.solve(cm)
    c = res.table("forces.csv")["valve.contact"]
    th = 2 * np.pi * res.t
    want = 0.05 + 0.5 * (2 * np.pi) ** 2 * 0.01 * np.cos(th) / 2
    assert np.abs(c - want).max() <= 1e-12


ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("model", ["flat-rocker-cam", "roller-rocker"])
def test_rocker_contact_sign_follows_the_pressing_torque(model):
    """A counter-clockwise torque on these rockers turns them towards the cam: the contact force
    is positive (pressing); the opposite torque pulls the rocker off: negative, warned."""
    import test_machine_elements as tm
    base = tm.ROCKER if model == "roller-rocker" else (ROOT / "mechanisms" /
                                                        f"{model}.yaml").read_text()
    body = "arm" if model == "roller-rocker" else "rocker"
    for T in (1000.0, -1000.0):
        text = base + f'loads:\n  - {{type: torque, body: {body}, f: "{T}"}}\n'
        res = planarkin.solve(planarkin.load("m.yaml", text=text))
        assert res.success, res.message
        name = "swing" if model == "roller-rocker" else "rocker"
        c = res.table("forces.csv")[f"{name}.contact"]
        assert (np.sign(c) == np.sign(T)).all()
        lift = [w for w in res.warnings if w.kind == "lift-off"]
        assert len(lift) == (T < 0)
