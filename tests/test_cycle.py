"""Cycle figures of every output coordinate (summary.json cycle.coordinates) against closed forms
derived here: slider-cranks (in-line and offset, extremes where crank and rod are collinear) and a
crank-rocker four-bar (the rocker's limit angles by the law of cosines)."""

import math


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
    assert abs(_ref(phi["min"])["value"] - lims[0]) < 1e-6
    assert abs(_ref(phi["max"])["value"] - lims[1]) < 1e-6
    assert abs(phi["stroke"] - (lims[1] - lims[0])) < 1e-6
    # the refinement is what reaches that: the grid extreme alone is O(h^2) off
    assert abs(phi["max"]["value"] - lims[1]) > abs(_ref(phi["max"])["value"] - lims[1])
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
