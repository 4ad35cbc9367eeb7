"""Cycle figures that understand dwells, and one function for every extreme (issue 31, item 4).

A rise-dwell-return-dwell cam (rise 150, dwell 30, return 150, dwell 30 deg of cam angle at one
turn per second) is reported as its four intervals, its extremes as its dwells and without a
time ratio; the studies' metrics (sweep, tolerance) and the synthesis margins are the extremes
run's cycle figures give (planarkin.measures.extremes.extreme), and the tolerance study's exact
sensitivities are the derivatives of those refined metrics (checked against central differences
here, in the test only).
"""

import csv
import json
import math

import numpy as np
import pytest

import planarkin
from clitools import run_cli
from planarkin.measures.extremes import extreme

FB = "mechanisms/four-bar.yaml"

# rise h in 150 deg, dwell 30 deg at the top, return in 150 deg, dwell 30 deg at the bottom
# (cycloidal and 3-4-5 by default): the follower's lift y = 48 + s(theta), theta = 360 t deg
CAM = """
name: rdrd
units: {{length: mm, angle: deg}}
parameters: {{h: 12, rb: 40, rr: 8}}
bodies:
  cam:      {{q: [0, 0, 0]}}
  follower: {{q: [0, 48, 0]}}
joints:
  - {{type: revolute, i: ground, j: cam, at: [0, 0]}}
  - {{type: translational, i: ground, j: follower, at: [0, 48], axis: [0, 1]}}
  - name: lift
    type: cam
    i: cam
    j: follower
    sk: [0, 0]
    vk: [0, 1]
    sj: [0, 0]
    base: rb
    roller: rr
    s:
      motion:
        segments:
          - {{rise: h, in: 150, law: {rise}}}
          - {{dwell: 30}}
          - {{return: h, in: 150, law: {ret}}}
          - {{dwell: 30}}
drivers:
  - {{type: angle, body: cam, f: "360*t"}}
points:
  roller: {{body: follower, s: [0, 0]}}
analysis: {{start: {start}, end: {end}, steps: {steps}}}
"""


def cam(start=0, end=1, steps=360, rise="cycloidal", ret="3-4-5"):
    return CAM.format(start=start, end=end, steps=steps, rise=rise, ret=ret)


def _run(tmp_path, text, name="m.yaml"):
    model = tmp_path / name
    model.write_text(text)
    r = run_cli("run", model, "--out", tmp_path / "o", "--no-plots", "--report", "cycle")
    assert r.returncode == 0, r.stderr
    stem = name.rsplit(".", 1)[0]
    summary = json.loads((tmp_path / "o" / stem / "summary.json").read_text())
    return r.stdout, summary


def _angles(rec):
    return rec["start"]["driver"], rec["end"]["driver"]


@pytest.mark.parametrize("rise, ret", [("cycloidal", "3-4-5"), ("harmonic", "harmonic")])
def test_a_rise_dwell_return_dwell_cam_is_reported_exactly(tmp_path, rise, ret):
    # a harmonic law starts and stops with a jump of the acceleration: the row at the
    # boundary takes the moving side's, its rate is zero, and it ends the dwell all the same
    out, s = _run(tmp_path, cam(rise=rise, ret=ret))
    y = s["cycle"]["coordinates"]["bodies"]["follower"]["y"]
    phases = y["phases"]
    assert [p["kind"] for p in phases] == ["rise", "dwell", "return", "dwell"]
    want = [(0, 150), (150, 180), (180, 330), (330, 360)]
    for p, (a, b) in zip(phases, want):
        assert abs(p["start"]["driver"] - a) < 1e-9 and abs(p["end"]["driver"] - b) < 1e-9
        assert abs(p["duration"] - (b - a) / 360) < 1e-12
    assert [p["value"] for p in phases if p["kind"] == "dwell"] == [60.0, 48.0]
    # no time ratio: the rise, return and dwell times instead, and what the ratio is
    for k in ("time_ratio", "advance_time", "extremes"):
        assert k not in y
    assert abs(y["rise_time"] - 150 / 360) < 1e-12 and abs(y["return_time"] - 150 / 360) < 1e-12
    assert abs(y["dwell_time"] - 60 / 360) < 1e-12
    assert abs(y["rise_return_ratio"] - 1) < 1e-12 and "dwells excluded" in y["note"]
    # the extremes are the dwells, not times placed by rounding inside them
    assert "t" not in y["max"] and "refined" not in y["max"]
    assert _angles(y["max"]["dwell"]) == pytest.approx((150, 180), abs=1e-9)
    assert _angles(y["min"]["dwell"]) == pytest.approx((330, 360), abs=1e-9)
    assert y["max"]["value"] == pytest.approx(60, abs=1e-12)
    assert y["min"]["value"] == pytest.approx(48, abs=1e-12) and y["stroke"] == pytest.approx(12)
    # the cam turns at constant speed: no dwell, no phases
    assert "phases" not in s["cycle"]["coordinates"]["bodies"]["cam"]["phi"]
    line = next(x.strip() for x in out.splitlines() if x.strip().startswith("follower.y:"))
    assert line == (
        "follower.y: min 48 mm over the dwell t = 0.916667..1 s (driver 330..360), max 60 mm over "
        "the dwell t = 0.416667..0.5 s (driver 150..180), stroke 12 mm; rise 0.416667 s (driver "
        "0..150), dwell 0.0833333 s (driver 150..180), return 0.416667 s (driver 180..330), "
        "dwell 0.0833333 s (driver 330..360): no time ratio (dwells); rise / return time 1, "
        "dwells excluded")


def test_a_dwell_across_the_start_of_the_run_is_one_dwell(tmp_path):
    # from 342 deg, inside the bottom dwell, for one turn: the dwell's rows at the start and at
    # the end are one dwell; the phases are listed from the first starting in the run
    _, s = _run(tmp_path, cam(start=0.95, end=1.95))
    y = s["cycle"]["coordinates"]["bodies"]["follower"]["y"]
    got = [(p["kind"],) + _angles(p) for p in y["phases"]]
    want = [("rise", 360, 510), ("dwell", 510, 540), ("return", 540, 690), ("dwell", 690, 720)]
    assert [g[0] for g in got] == [w[0] for w in want]
    assert np.allclose([g[1:] for g in got], [w[1:] for w in want], atol=1e-9, rtol=0)
    assert _angles(y["min"]["dwell"]) == pytest.approx((690, 720), abs=1e-9)
    assert "time_ratio" not in y


def test_dwell_ends_off_the_grid_are_within_one_step(tmp_path):
    # 97 steps per turn: no row at the segment boundaries; each dwell is given by its still rows,
    # and the moving rows around it bracket the true ends (the resolution: one grid step)
    _, s = _run(tmp_path, cam(steps=97))
    y = s["cycle"]["coordinates"]["bodies"]["follower"]["y"]
    h = 1 / 97
    assert [p["kind"] for p in y["phases"]] == ["rise", "dwell", "return", "dwell"]
    for d, (a, b) in ((y["max"]["dwell"], (150, 180)), (y["min"]["dwell"], (330, 360))):
        assert d["resolution"] == pytest.approx(h)
        assert a / 360 <= d["start"]["t"] < a / 360 + h
        assert b / 360 - h < d["end"]["t"] <= b / 360 + 1e-12
    assert "time_ratio" not in y     # was 1.36585: the dwells lumped into the return


def test_a_turning_point_without_a_dwell_keeps_its_time_ratio(tmp_path):
    # the slider-crank's dead centres: the rate vanishes at one instant, the acceleration does
    # not: no dwell, a rise and a return, and the time ratio of those
    _, s = _run(tmp_path, open("mechanisms/slider-crank.yaml").read())
    x = s["cycle"]["coordinates"]["bodies"]["slider"]["x"]
    assert [p["kind"] for p in x["phases"]] == ["rise", "return"] or \
        [p["kind"] for p in x["phases"]] == ["return", "rise"]
    assert abs(x["time_ratio"] - 1) < 1e-9 and "rise_time" not in x
    assert "dwell" not in x["min"] and "dwell" not in x["max"]


def _sweep(tmp_path, *args):
    r = run_cli("sweep", FB, "--out", tmp_path / "sw", "--no-plots", "-j", "1", *args)
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "sw" / "four-bar" / "sweep.csv") as f:
        return list(csv.DictReader(f))


METRICS = [("stroke", "P.x"), ("max", "P.y"), ("min", "rocker.phi"), ("stroke", "rocker.phi"),
           ("max", "C.x"), ("stroke", "coupler.phi")]


def _figure(summary, column):
    owner, q = column.rsplit(".", 1)
    for group in ("bodies", "points"):
        recs = summary["cycle"]["coordinates"][group]
        if owner in recs:
            return recs[owner][q]


def _value(fig, kind):
    ref = lambda x: x.get("refined", x)["value"]       # noqa: E731
    return {"stroke": fig["stroke"], "max": ref(fig["max"]), "min": ref(fig["min"])}[kind]


def test_sweep_metrics_equal_runs_cycle_figures(tmp_path):
    """A sweep's metrics are run's figures of the same model (the user's report: a stroke of
    0.1005358 on the raw grid against run's 0.1005380)."""
    rows = _sweep(tmp_path, "--vary", "a=0.04:0.05:3",
                  *[x for k, c in METRICS for x in ("--metric", f"{k}:{c}")])
    assert [r["status"] for r in rows] == ["ok"] * 3
    for row in rows:
        a = row["a"]
        _, s = _run(tmp_path, open(FB).read().replace("a: 0.04 ", f"a: {a} "), name="fb.yaml")
        for k, c in METRICS:
            got = float(row[f"{k}:{c} [{_figure(s, c)['unit']}]"])
            want = _value(_figure(s, c), k)
            assert abs(got - want) <= 1e-12 * abs(want), (a, k, c, got, want)


def test_tolerance_nominal_equals_run_and_its_sensitivities_are_the_metrics_derivatives(
        tmp_path):
    from planarkin.studies.tolerance import run_tolerance
    from planarkin.studies.variants import Study
    metrics = [f"{k}:{c}" for k, c in METRICS]
    study = Study(FB, metrics=metrics)
    names = ["a", "b", "d"]
    r = run_tolerance(study, {p: 1e-4 for p in names}, tmp_path / "tol", 2, seed=1, plots=None)
    _, s = _run(tmp_path, open(FB).read(), name="fb.yaml")
    for i, (k, c) in enumerate(METRICS):
        want = _value(_figure(s, c), k)
        assert abs(r.nominal[i] - want) <= 1e-12 * abs(want), (k, c, r.nominal[i], want)
    # d(metric)/dp against central differences of the refined metric itself: their error falls
    # as the step squared (the differences' truncation) to a floor of ~1e-10 of the derivative
    G = r.gradient
    assert np.isfinite(G).all()
    for j, p in enumerate(names):
        p0 = study.parameters[p]
        err = []
        for rel in (2e-4, 1e-4):
            up, dn = (np.array(study.solve({p: p0 + sg * rel * p0})[0].metrics)
                      for sg in (1, -1))
            fd = (up - dn) / (2 * rel * p0)
            err.append(np.abs(fd - G[:, j]) / np.abs(G[:, j]))
        assert (err[1] < 1e-7).all(), (p, err)
        big = err[0] > 1e-9
        assert big.any() and (np.abs(err[0][big] / err[1][big] - 4) < 0.5).all(), (p, err)


def test_synthesis_margins_take_runs_extremes(tmp_path):
    from planarkin.synthesis.margins import angle_span, worst_transmission
    text = """
name: linkage
units: {length: m, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.1, 0], ground: true}
  B: {at: [0.04, 0]}
  C: {at: [0.10666666666666667, 0.09977753031397177]}
links:
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "360*t"}
measures:
  mu: {transmission: [B, C, D]}
analysis: {start: 0, end: 1, steps: 72}
"""
    _, s = _run(tmp_path, text)
    res = planarkin.solve(planarkin.load("m.yaml", text=text))
    pn = list(res.model.point_names)
    mu = s["cycle"]["measures"]["mu"]
    worst = worst_transmission(res, pn.index("B"), pn.index("C"), pn.index("D"), True)
    want = min(mu["min"]["refined"]["value"], 180 - mu["max"]["refined"]["value"])
    assert abs(worst - want) <= 1e-12 * want
    b = res.model.body_names.index("rocker")
    stroke = s["cycle"]["coordinates"]["bodies"]["rocker"]["phi"]["stroke"]
    assert abs(angle_span(res, 3 * b + 2) - stroke) <= 1e-12 * stroke


def test_the_refinement_is_the_same_whole_or_chunk_by_chunk():
    from planarkin.solver.layout import Layout
    from planarkin.measures.cycle import CoordinateFigures
    res = planarkin.solve(planarkin.load(FB), steps=90)
    L = Layout(res.model, res.info.options.order)
    X = L.point_table(res._chunk)

    def figures(size):
        acc = CoordinateFigures(res.model, L.point_header, res.info.options)
        for a in range(0, len(X), size):
            acc.add(X[a:a + size])
        return acc.as_dict()["coordinates"]
    whole, chunked = figures(len(X)), figures(7)
    assert chunked == whole
    k = L.point_header.index("P.x [m]")
    t, v = extreme(X[:, 0], X[:, k], X[:, k + 2], X[:, k + 4], 1.0)
    assert whole["P"]["x"]["max"]["refined"] == {"value": v, "t": t, "driver": 360 * t}


def test_the_refined_extreme_converges_as_the_sixth_power_of_the_step():
    # y = sin(w t + p) + 0.3 sin(2 w t + p) with its exact derivatives, the largest error over
    # eight phases p: the quintic Hermite's extreme is O(h^6) off, the cubic's (no
    # acceleration) O(h^4), the grid's O(h^2)
    w = 2 * math.pi

    def cols(n, p):
        t = np.linspace(0, 1, n + 1)
        return (t, np.sin(w * t + p) + 0.3 * np.sin(2 * w * t + p),
                w * np.cos(w * t + p) + 0.6 * w * np.cos(2 * w * t + p),
                -w * w * (np.sin(w * t + p) + 1.2 * np.sin(2 * w * t + p)))
    err = {40: np.zeros(3), 160: np.zeros(3)}
    for p in np.linspace(0, 1, 9)[:-1]:
        t, y, v, a = cols(200000, p)
        best = extreme(t, y, v, a)[1]
        for n in err:
            t, y, v, a = cols(n, p)
            got = (extreme(t, y, v, a)[1], extreme(t, y, v)[1], y.max())
            err[n] = np.maximum(err[n], np.abs(np.array(got) - best))
    order = np.log2(err[40] / err[160]) / 2
    assert abs(order[0] - 6) < 0.3 and abs(order[1] - 4) < 0.3 and abs(order[2] - 2) < 0.3
    assert err[160][0] < 1e-11
