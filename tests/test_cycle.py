"""Cycle figures of every output coordinate (summary.json cycle.coordinates) against closed forms
derived here: slider-cranks (in-line and offset, extremes where crank and rod are collinear) and a
crank-rocker four-bar (the rocker's limit angles by the law of cosines)."""

import math

import pytest

import planarkin

import reference_models as R

TWO_PI = 2 * math.pi


def _cycle(tmp_path, text, steps=360, **kw):
    res = planarkin.solve(planarkin.load("m.yaml", text=text), steps=steps, **kw)
    assert res.success
    return res.write(tmp_path / "out", plots=None)["cycle"]


def _ref(lim):
    return lim.get("refined", lim)


def _slider_limits(e):
    """Crank angles (rad, in [0, 2 pi)) and slider x at the outer and inner dead centres:
    outer B = (a + b) e(th1), inner B = (b - a) e(th2 + pi), both with B.y = e."""
    a, b = R.SLIDER_CRANK["a"], R.SLIDER_CRANK["b"]
    x_out, x_in = math.sqrt((a + b) ** 2 - e * e), math.sqrt((b - a) ** 2 - e * e)
    th1 = math.atan2(e, x_out) % TWO_PI
    th2 = (math.atan2(e, x_in) + math.pi) % TWO_PI
    return x_out, th1, x_in, th2


def test_inline_slider_crank_stroke_times_and_ratio(tmp_path):
    text = R.slider_crank_yaml().replace("h: 0.03", "h: 0.0")
    cyc = _cycle(tmp_path, text)
    a, b = R.SLIDER_CRANK["a"], R.SLIDER_CRANK["b"]
    x = cyc["coordinates"]["bodies"]["slider"]["x"]
    assert abs(x["stroke"] - 2 * a) < 1e-7
    assert abs(_ref(x["max"])["value"] - (a + b)) < 1e-7 and abs(_ref(x["max"])["t"]) < 1e-9
    assert abs(_ref(x["min"])["value"] - (b - a)) < 1e-7
    assert abs(_ref(x["min"])["t"] - 0.5) < 1e-6
    assert abs(_ref(x["min"])["driver"] - math.pi) < 1e-5
    assert abs(x["time_ratio"] - 1.0) < 1e-5 and x["moves"]
    # a guided slider does not move across its guide nor turn; the crank's pivot stays put
    sl = cyc["coordinates"]["bodies"]["slider"]
    assert not sl["y"]["moves"] and not sl["phi"]["moves"]
    cr = cyc["coordinates"]["bodies"]["crank"]
    assert not cr["x"]["moves"] and cr["phi"]["moves"] and "time_ratio" not in cr["phi"]
    assert cyc["period"] == 1.0


def test_offset_slider_crank_quick_return_ratio(tmp_path):
    e = R.SLIDER_CRANK["e"]
    cyc = _cycle(tmp_path, R.slider_crank_yaml())
    x_out, th1, x_in, th2 = _slider_limits(e)
    x = cyc["coordinates"]["bodies"]["slider"]["x"]
    assert abs(_ref(x["max"])["value"] - x_out) < 1e-7
    assert abs(_ref(x["min"])["value"] - x_in) < 1e-7
    assert abs(x["stroke"] - (x_out - x_in)) < 1e-7
    assert abs(_ref(x["max"])["t"] - th1 / TWO_PI) < 1e-4
    assert abs(_ref(x["min"])["t"] - th2 / TWO_PI) < 1e-4
    assert abs(_ref(x["min"])["driver"] - th2) < 1e-3
    adv = ((th1 - th2) / TWO_PI) % 1.0            # min -> max at one turn per second
    assert abs(x["advance_time"] - adv) < 1e-4
    want = max(adv, 1 - adv) / min(adv, 1 - adv)
    assert want > 1.02                            # the offset makes it a quick return
    assert abs(x["time_ratio"] - want) < 1e-5
    # the same figures for the slider pin as a point would be: the rod point P also moves
    assert cyc["coordinates"]["points"]["P"]["x"]["moves"]


def test_fourbar_rocker_limit_angles(tmp_path):
    cyc = _cycle(tmp_path, R.FOURBAR_DEG_YAML, steps=720)
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    # |O2 B| = b + a and b - a; with O4 = (d, 0): |O2 B|^2 = d^2 + c^2 + 2 d c cos th4
    lims = sorted(math.degrees(math.acos((r * r - d * d - c * c) / (2 * d * c)))
                  for r in (b + a, b - a))
    phi = cyc["coordinates"]["bodies"]["rocker"]["phi"]
    assert phi["unit"] == "deg"
    # refined between the rows (the quintic Hermite of the exact value, rate and acceleration:
    # O(h^6)), where the grid extreme alone is O(h^2) off
    assert abs(_ref(phi["min"])["value"] - lims[0]) < 1e-10
    assert abs(_ref(phi["max"])["value"] - lims[1]) < 1e-10
    assert abs(phi["stroke"] - (lims[1] - lims[0])) < 1e-10
    assert abs(phi["max"]["value"] - lims[1]) > 1e-5
    assert "time_ratio" in phi and phi["time_ratio"] > 1


def test_position_only_runs_keep_grid_extremes(tmp_path):
    cyc = _cycle(tmp_path, R.slider_crank_yaml(), up_to="position")
    x = cyc["coordinates"]["bodies"]["slider"]["x"]
    assert "refined" not in x["min"] and "refined" not in x["max"]
    x_out, *_ = _slider_limits(R.SLIDER_CRANK["e"])
    assert 0 <= x_out - x["max"]["value"] < 1e-4


def test_report_prints_moving_coordinates_grouped(tmp_path):
    from clitools import run_cli
    model = tmp_path / "sc.yaml"
    model.write_text(R.slider_crank_yaml().replace("h: 0.03", "h: 0.0"))
    r = run_cli("run", str(model), "--out", str(tmp_path / "o"), "--no-plots", "--report",
                "cycle")
    assert r.returncode == 0, r.stderr
    lines = [x.strip() for x in r.stdout.split("\n")]
    a, b = R.SLIDER_CRANK["a"], R.SLIDER_CRANK["b"]
    sl = next(x for x in lines if x.startswith("slider.x:"))
    assert sl.startswith(f"slider.x: min {b - a:.6g} m at t = 0.5 s (driver 3.14159), "
                         f"max {a + b:.6g} m at t = 0 s (driver 0), stroke {2 * a:.6g} m")
    assert "time ratio 1" in sl
    assert not any(x.startswith(("slider.y:", "crank.x:", "slider.phi:")) for x in lines)
    assert any(x.startswith("P.x:") for x in lines)


def test_a_failing_figure_does_not_cost_the_table(tmp_path, monkeypatch):
    from planarkin.measures import cycle

    def broken(self, X):
        raise RuntimeError("boom")
    monkeypatch.setattr(cycle.CycleFigures, "add", broken)
    res = planarkin.solve(planarkin.load("m.yaml", text=R.slider_crank_yaml()), steps=20)
    s = res.write(tmp_path / "out", plots=None)
    assert s["status"] == "ok" and s["files"]["bodies.csv"]["rows"] == 21
    assert s["cycle"]["error"].startswith("cycle figures not computed: RuntimeError: boom")
    assert (tmp_path / "out" / "bodies.csv").read_text().count("\n") == 22


# A wheel turning twice per turn of the crank (the first, constant-speed driver: period 1 s):
# its rim point P = (0.3 + r cos(720 t + p), r sin(720 t + p)) peaks twice per period, as a
# toggle ram does. Maxima of P.x where 720 t + p = 360 k, minima where it is 180 + 360 k.
WHEEL = """
name: wheel
units: {{length: m, angle: deg}}
bodies:
  crank: {{q: [0, 0, 0]}}
  wheel: {{q: [0.3, 0, {p}]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, i: ground, j: wheel, si: [0.3, 0], sj: [0, 0]}}
drivers:
  - {{type: angle, body: crank, f: "360*t"}}
  - {{type: angle, body: wheel, f: "720*t + {p}"}}
points:
  P: {{body: wheel, s: [0.05, 0]}}
analysis: {{start: 0, end: {end}, steps: {steps}}}
"""


@pytest.mark.parametrize("p, end, steps", [(0.0, 1, 360), (10.0, 1, 360), (37.0, 2.3, 997),
                                           (0.0, 1.5, 540)])
def test_two_maxima_per_period_give_the_extremes_and_no_time_ratio(tmp_path, p, end, steps):
    cyc = _cycle(tmp_path, WHEEL.format(p=p, end=end, steps=steps), steps=steps)
    h = end / steps
    r = 0.05
    x = cyc["coordinates"]["points"]["P"]["x"]
    assert "time_ratio" not in x and "advance_time" not in x
    assert x["note"] == "2 maxima and 2 minima per period: no single time ratio"
    # one period's turning points, each once, in the window (h/2, 1 + h/2]
    want = sorted(((360 * k + 180 * m - p) / 720, m) for k in range(-1, 4) for m in (0, 1)
                  if h / 2 < (360 * k + 180 * m - p) / 720 <= 1 + h / 2)
    got = x["extremes"]
    assert [g["kind"] for g in got] == ["max" if m == 0 else "min" for _, m in want]
    for g, (t, m) in zip(got, want):
        assert abs(_ref(g)["t"] - t) < 1e-6
        assert abs(_ref(g)["value"] - (0.3 + (r if m == 0 else -r))) < 1e-9
    assert abs(x["stroke"] - 2 * r) < 1e-9
    # the crank's own coordinates keep their figures; a one-peak column keeps its time ratio
    assert "extremes" not in cyc["coordinates"]["bodies"]["crank"]["phi"]


def test_a_one_peak_column_keeps_its_time_ratio_in_a_long_run(tmp_path):
    # the in-line slider-crank over three turns: one maximum per period, ratio 1
    text = R.slider_crank_yaml().replace("h: 0.03", "h: 0.0")
    res = planarkin.solve(planarkin.load("m.yaml", text=text), steps=1080, end=3.0)
    x = res.write(tmp_path / "out", plots=None)["cycle"]["coordinates"]["bodies"]["slider"]["x"]
    assert "extremes" not in x and abs(x["time_ratio"] - 1.0) < 1e-5


def test_report_prints_the_extremes_of_a_toggle(tmp_path):
    from click.testing import CliRunner

    from planarkin.cli import main
    model = tmp_path / "wheel.yaml"
    model.write_text(WHEEL.format(p=0.0, end=1, steps=360))
    r = CliRunner().invoke(main, ["run", str(model), "--out", str(tmp_path / "o"), "--no-plots",
                                  "--report", "cycle"])
    assert r.exit_code == 0, r.output
    line = next(x.strip() for x in r.output.splitlines() if x.strip().startswith("P.x:"))
    assert line.endswith("stroke 0.1 m; 2 maxima and 2 minima per period: no single time "
                         "ratio: min 0.25 m at t = 0.25 s (driver 90), max 0.35 m at t = 0.5 s "
                         "(driver 180), min 0.25 m at t = 0.75 s (driver 270), max 0.35 m at "
                         "t = 1 s (driver 360)")
    assert "time ratio " not in line


def test_cycle_figures_carry_the_cam_contact_minimum(tmp_path):
    # the valve train of test_force_rows: contact force P + m w^2 h cos(theta) / 2, smallest at
    # theta = 180 deg (t = 0.5 s): P - m w^2 h / 2
    from click.testing import CliRunner

    from planarkin.cli import main
    from test_contact_forces import VALVE
    model = tmp_path / "valve.yaml"
    model.write_text(VALVE)
    r = CliRunner().invoke(main, ["run", str(model), "--out", str(tmp_path / "o"), "--no-plots",
                                  "--report", "cycle"])
    assert r.exit_code == 0, r.output
    import json
    s = json.loads((tmp_path / "o" / "valve" / "summary.json").read_text())
    low = 200 - 0.5 * (2 * math.pi) ** 2 * 0.01 / 2
    rec = s["cycle"]["contact"]["valve"]
    assert rec == s["forces"]["contact"]["valve"]
    assert abs(rec["min"] - low) < 1e-9 * 200 and abs(rec["t"] - 0.5) < 1e-12
    assert not rec["lift_off"]
    assert f"valve: min contact force {low:.6g} N at t = 0.5 s" in r.output


def test_a_coordinate_that_does_not_move_has_no_turning_points(tmp_path):
    """The example slider-crank's slider pin B stays on y = 0 to rounding (|y| ~ 1e-17): its
    noise turned at thousands of rows, and each turn was listed as an extremum (a 15 MB
    summary.json at 200,000 steps). A coordinate within 1e-9 of the table's size does not
    move: no extremes, no note; a column with more turning points lists the first ones only."""
    from planarkin.measures.cycle import MAX_EXTREMES
    res = planarkin.solve(planarkin.load("mechanisms/slider-crank.yaml"), steps=20000)
    summary = res.write(tmp_path / "out", plots=None)
    y = summary["cycle"]["coordinates"]["points"]["B"]["y"]
    assert not y["moves"] and "extremes" not in y and "note" not in y
    assert (tmp_path / "out" / "summary.json").stat().st_size < 100_000
    assert MAX_EXTREMES >= 16


def test_the_turning_points_kept_stay_bounded(monkeypatch):
    """The noise of B.y turns at almost every row; kept, its turns grew with the run (1.1 GB of
    heap at 10,000,000 steps). Past MAX_TURNS a column keeps none: B.y still does not move, the
    moving B.x keeps its figures exactly."""
    from planarkin.solver.layout import Layout
    from planarkin.measures import cycle
    res = planarkin.solve(planarkin.load("mechanisms/slider-crank.yaml"), steps=20000)
    L = Layout(res.model, res.info.options.order)
    X = L.point_table(res._chunk)

    def figures():
        acc = cycle.CoordinateFigures(res.model, L.point_header, res.info.options)
        for a in range(0, len(X), 3000):
            acc.add(X[a:a + 3000])
        return acc
    monkeypatch.setattr(cycle, "MAX_TURNS", 10**9)
    full = figures()
    monkeypatch.setattr(cycle, "MAX_TURNS", 8)
    capped = figures()
    assert sum(len(c) for c, _ in full.turn_rows) > 1000           # the noise, uncapped
    assert sum(len(c) for c, _ in capped.turn_rows) <= 8 * len(capped.value_cols)
    got, want = capped.as_dict()["coordinates"]["B"], full.as_dict()["coordinates"]["B"]
    assert not got["y"]["moves"] and "note" not in got["y"] and "extremes" not in got["y"]
    assert got["x"] == want["x"]
