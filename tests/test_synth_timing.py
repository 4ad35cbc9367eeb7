"""Targets with inputs relative to an unknown offset (planarkin.synthesis.timing): the offset
(and step) recovered exactly, their Jacobian columns against the exact chain rule, the forms of
`inputs: {...}` read from the file, and the offset reported in the driver's unit."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from planarkin.synthesis.local import Local
from planarkin.synthesis.output import write_synth
from planarkin.synthesis.synth import Synthesis, synthesize

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "mechanisms" / "synthesis"
# mechanisms/four-bar.yaml's coupler point P (a, b, c, d = 0.04, 0.12, 0.10, 0.10 m) at crank
# angles 37 + 60 k deg, k = 0 .. 5 (solved by planarkin at those times, Newton to 1e-13)
P37 = [[0.05299980162385923, 0.09605671744743727], [0.024392767990155023, 0.10875552809127496],
       [-0.017874631497868904, 0.08819690774658324], [-0.0360527812271176, 0.050814845198428146],
       [-0.023373152610787807, 0.0297751620528234], [0.014641525630268316, 0.05601645719643675]]
TRUE = {"a": 0.04, "b": 0.12, "c": 0.10, "d": 0.10}


def _model(tmp_path, inputs, points=P37, search="{starts: 6, local: 2, keep: 1, seed: 0, "
           "goal: 1e-20}", name="relative.yaml", base="four-bar-path.yaml"):
    """four-bar-path.yaml with one path target of P through `points` at `inputs` (YAML text)."""
    text = (EX / base).read_text()
    target = (f"  targets:\n    - path: P\n      inputs: {inputs}\n"
              f"      points: {json.dumps(points)}\n")
    text = re.sub(r"  targets:\n(?:      .*\n|    .*\n|               .*\n)+", target, text)
    text = re.sub(r"search: \{.*\}", f"search: {search}", text)
    path = tmp_path / name
    path.write_text(text)
    return path


def _target_timing(path):
    return Synthesis(path).design.targets[0]


@pytest.mark.parametrize("inputs, offset, step, values, unknowns", [
    ("{offset: free, step: 60}", None, 60.0, None, ("offset",)),
    ("{step: 60}", None, 60.0, None, ("offset",)),              # offset: free by default
    ("{offset: free, step: free}", None, None, None, ("offset", "step")),
    ("{offset: 37, step: free}", 37.0, None, None, ("step",)),
    ("{offset: [20, 50], values: [0, 60, 120, 180, 240, 300]}", None, None,
     (0.0, 60.0, 120.0, 180.0, 240.0, 300.0), ("offset",)),
])
def test_forms_of_relative_inputs(tmp_path, inputs, offset, step, values, unknowns):
    tg = _target_timing(_model(tmp_path, inputs))
    assert tg.inputs is None and not tg.free_timing
    tm = tg.timing
    assert (tm.offset, tm.step, tm.values, tm.unknowns) == (offset, step, values, unknowns)
    assert tm.n == 6


def test_nothing_unknown_is_a_list_of_inputs(tmp_path):
    """{offset: 37, step: 60}: the inputs are given (37, 97, ...): no unknown, no Timing."""
    tg = _target_timing(_model(tmp_path, "{offset: 37, step: 60}"))
    assert tg.timing is None and tg.inputs == (37.0, 97.0, 157.0, 217.0, 277.0, 337.0)


def test_offset_recovered_exactly_from_a_start_near_it(tmp_path):
    """The coupler points at crank angles 37 + 60 k deg: from the file's values a little off
    (a = 0.041, b = 0.119, with search nominal: 1), the search finds a, b, c, d and the offset
    37 deg to 1e-9 (SSE < 1e-20 m^2)."""
    path = _model(tmp_path, "{offset: free, step: 60}",
                  search="{starts: 2, local: 1, keep: 1, seed: 0, goal: 1e-24, nominal: 1}")
    res = synthesize(path, overrides={"a": 0.041, "b": 0.119})
    best = res.designs[0]
    assert res.status == 0 and best.cost < 1e-20
    syn = res.model
    assert syn.nu == 1 and syn.timing == [(0, "offset")]
    offset = float(best.x[syn.k + syn.nt])
    assert abs(offset - 37.0) < 1e-9
    for name, v in TRUE.items():
        assert abs(best.values[name] - v) < 1e-9
    # the times of the targets are the inputs' times: f(t) = 360 t = 37 + 60 k
    assert np.allclose(best.times[0], (37 + 60 * np.arange(6)) / 360, atol=1e-12, rtol=0)


def test_offset_and_step_recovered_from_the_starts(tmp_path):
    """Offset and step both unknown, from the Latin-hypercube starts (each start's offset and
    step the best of a scan on its grid): 37 and 60 deg found."""
    res = synthesize(_model(tmp_path, "{offset: free, step: free}"))
    best, syn = res.designs[0], res.model
    assert res.status == 0 and best.cost < 1e-20
    offset, step = best.x[syn.k + syn.nt:]
    assert abs(offset - 37) < 1e-7 and abs(step - 60) < 1e-7


def _columns(syn, d):
    """(offset column, step column) of the exact chain rule: row (e, c) of a path target is
    dP_c/dt (t_e) de/d(offset or step) / f_t, with f = 360 t deg: f_t = 360 deg/s."""
    st = d.state
    V = st.pd[d.where[0], syn.points.index("P")]          # (N, 2) m/s
    e = np.arange(len(V), dtype=float)[:, None]
    return (V / 360.0).ravel(), (e * V / 360.0).ravel()


def test_offset_and_step_columns_are_the_exact_chain_rule(tmp_path):
    """Full evaluation: the offset's column is dP/dt / f_t row by row, the step's e dP/dt /
    f_t (to rounding); a central difference of the residuals in the offset agrees to the
    order of its step squared."""
    syn = Synthesis(_model(tmp_path, "{offset: free, step: free}"))
    syn.wrap = True
    x = np.array([0.041, 0.119, 0.101, 0.099, 30.0, 61.0])
    r, J, d = syn.evaluate(x)
    assert r is not None, d
    off, stp = _columns(syn, d)
    assert J.shape == (12 + 1, 6)                    # 6 points x (x, y) and the turns barrier
    assert np.abs(J[:12, 4] - off).max() <= 1e-12 * np.abs(off).max()
    assert np.abs(J[:12, 5] - stp).max() <= 1e-12 * np.abs(stp).max()
    assert J[12, 4] == 0 and J[12, 5] == 0           # the barrier does not see the inputs
    h = 1e-3                                          # deg
    for col, most in ((4, 1), (5, 5)):               # the inputs move by h, by up to 5 h
        xp, xm = x.copy(), x.copy()
        xp[col] += h
        xm[col] -= h
        fd = (syn.evaluate(xp, jac=False)[0] - syn.evaluate(xm, jac=False)[0]) / (2 * h)
        # a central difference's error: h^2 / 6 |d3r/dx3| + the solves' rounding / h; here
        # |d3P/du3| <= 10 |P| (pi / 180)^3 (|P| <= 0.2 m, a coupler curve's harmonics), times
        # most^3 for the step, and Newton's 1e-13 (internal units, L <= 1 m) over h
        bound = h ** 2 / 6 * most ** 3 * 10 * 0.2 * (np.pi / 180) ** 3 + 1e-13 / h
        assert np.abs(fd[:12] - J[:12, col]).max() <= bound


def test_trial_jacobian_with_a_parameter_in_the_driver(tmp_path):
    """A local trial of straight-line.yaml (its driver th0 + 2 pi t depends on a parameter),
    the six points at inputs offset + k step (rad), both unknown: every column of the exact
    Jacobian, -f_p / f_t for th0 among them, against central differences of the trial."""
    pts = [[20, 20], [20, 25], [20, 30], [20, 35], [20, 40], [20, 45]]
    path = _model(tmp_path, "{offset: free, step: free}", points=pts, base="straight-line.yaml",
                  search="{starts: 4, local: 1, keep: 1, seed: 0}")
    syn = Synthesis(path)
    syn.wrap = True
    x = np.array([0, 0, 0.3, 10, 40, 30, 40, 20, 20, 1.0, 0.3])
    r, _, d = syn.evaluate(x, jac=False, final=True)
    assert r is not None, d
    loc = Local(syn)
    loc.anchor(d)
    assert loc.nt == 0 and len(loc.ref[0]) == 11
    xt = loc.ref[0] + 1e-4 * np.arange(11) / 11
    r, st, bar = loc.evaluate(xt)
    assert r is not None, st
    J = loc.jacobian(st, bar)
    Jn = np.zeros_like(J)
    for i in range(len(xt)):
        h = 1e-6 * max(1.0, abs(xt[i]))
        xp, xm = xt.copy(), xt.copy()
        xp[i] += h
        xm[i] -= h
        Jn[:, i] = (loc.evaluate(xp)[0] - loc.evaluate(xm)[0]) / (2 * h)
    scale = np.abs(J).max()
    assert np.abs(J - Jn).max() <= 1e-6 * scale, np.abs(J - Jn).max(axis=0) / scale
    # th0's column holds the driver's share: at a fixed input the crank angle from the ground
    # line does not move with th0 (u = th0 + 2 pi t), so the time does (dt/dth0 = -1 / 2 pi)
    dtdx = syn.input_dtdx(st.cm, syn.design.targets[0], 0, st.t, loc.free_t)
    assert np.allclose(dtdx[:, 2], -1 / (2 * np.pi), rtol=1e-12, atol=0)
    assert np.allclose(dtdx[:, 9], 1 / (2 * np.pi), rtol=1e-12, atol=0)
    assert np.allclose(dtdx[:, 10], np.arange(6) / (2 * np.pi), rtol=1e-12, atol=0)


def test_offset_reported_in_the_driver_unit(tmp_path):
    """summary.json gives each design's offset and step (deg, the driver's unit), designs.csv a
    column for the offset found, design-1.yaml a header line."""
    path = _model(tmp_path, "{offset: free, step: 60}",
                  search="{starts: 2, local: 1, keep: 1, seed: 0, goal: 1e-20, nominal: 1}")
    res = synthesize(path, overrides={"a": 0.041})
    out = write_synth(res, tmp_path / "out", plots=None)
    summary = json.loads((out / "summary.json").read_text())
    (found,) = summary["designs"][0]["inputs"]
    assert found["target"] == 1 and found["unit"] == "deg" and found["step"] == 60
    assert abs(found["offset"] - 37) < 1e-9
    head, row = (out / "designs.csv").read_text().splitlines()[:2]
    col = head.split(",").index("target 1 offset [deg]")
    assert abs(float(row.split(",")[col]) - 37) < 1e-9
    assert "# target 1: inputs from offset 37" in (out / "design-1.yaml").read_text()


def test_offset_reported_within_the_driver_travel(tmp_path):
    """In a model that returns to its start, an offset found a turn away is reported within
    the driver's travel (0 .. 360 deg here)."""
    path = _model(tmp_path, "{offset: free, step: 60}")
    syn = Synthesis(path)
    syn.wrap = True
    x = np.array([0.04, 0.12, 0.10, 0.10, 37.0 + 360.0])
    from planarkin.synthesis import timing
    assert abs(timing.report(syn, x)[0]["offset"] - 37.0) < 1e-9
    r, _, d = syn.evaluate(x, jac=False)
    assert d.cost < 1e-20
