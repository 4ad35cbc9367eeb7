"""Messages to mend (issue 21 item 16): each hostile input is one FILE:LINE error naming the
element and the fix, never an internal error, an analysis failure or a silent acceptance."""

import math

import pytest
from click.testing import CliRunner

import planarkin
from planarkin.cli import main
from planarkin.diagnostics import InputError

ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent
MECH = ROOT / "mechanisms"
ARC = "curve: {segments: [{arc: {centre: [Cx, 0], radius: R, from: 150, to: 90}}]}"


def _errors(path, text=None):
    with pytest.raises(InputError) as e:
        planarkin.load(str(path), text=text)
    return [d.format() for d in e.value.diagnostics]


def _slot(curve: str) -> str:
    text = (MECH / "curved-slot.yaml").read_text()
    assert ARC in text
    return text.replace(ARC, curve)


# -- curve points far from the others: the spline's arc length loses a step or overflows -------
@pytest.mark.parametrize("curve, want", [
    ("curve: [[1e100, 0.29], [0.15, 0.3], [0.2, 0.3], [0.25, 0.29], [0.3, 0.27], [0.35, 0.24]]",
     "curve: point 3 is 0.05 from point 2, a step lost to rounding in the curve's arc length so "
     "far (1e+100): point 1 at [1e+100, 0.29] is far from the others; give the points of one "
     "curve at a common scale"),
    ("curve: [[0.1, 0.29], [0.15, 0.3], [0.2, 0.3], [0.25, 0.29], [0.3, 0.27], [1e100, 0.24]]",
     "curve: the curve's arc length reaches 1e+100 at point 6, too long for its quintic spline "
     "(at most 1e+50): point 6 at [1e+100, 0.24] is far from the others; give the points of "
     "one curve at a common scale"),
])
def test_curve_points_at_1e100_are_an_input_error_at_the_curve(curve, want):
    assert _errors("slot.yaml", _slot(curve)) == [
        f"slot.yaml:32: error: joint 'slot' (curve-slot ground-link): {want}"]


def test_a_curve_table_with_a_far_point_is_an_error_at_its_line(tmp_path):
    (tmp_path / "big.csv").write_text("x,y\n0.1,0.29\n0.15,0.3\n1e100,0.3\n0.25,0.29\n0.3,0.27\n"
                                      "0.35,0.24\n")
    p = tmp_path / "slot.yaml"
    p.write_text(_slot("curve: {table: big.csv}"))
    [msg] = _errors(p)
    assert msg.startswith(f"{tmp_path / 'big.csv'}:6: error: point 5 is 0.0539 from point 4, a "
                          f"step lost to rounding") and "point 3 at [1e+100, 0.3]" in msg
    assert msg.endswith("(the curve of joint 'slot' (curve-slot ground-link))")


# -- pressure_limit outside (0, 90) deg --------------------------------------------------------
@pytest.mark.parametrize("limit", ["-5", "0", "90", "360"])
def test_a_pressure_limit_outside_its_range_is_refused(limit):
    text = (MECH / "cam-roller.yaml").read_text().replace(
        "    roller: rr\n", f"    roller: rr\n    pressure_limit: {limit}\n", 1)
    [msg] = _errors("cam.yaml", text)
    assert msg == (f"cam.yaml:25: error: joint 'lift' (cam cam-follower-ground): pressure_limit "
                   f"must be more than 0 and less than 90 deg (a pressure angle of 90 deg locks "
                   f"the follower), not {float(limit):g} deg")


def test_a_pressure_limit_within_its_range_is_kept():
    text = (MECH / "cam-roller.yaml").read_text().replace(
        "    roller: rr\n", "    roller: rr\n    pressure_limit: 89.9\n", 1)
    planarkin.load("cam.yaml", text=text)


def test_a_rocker_cam_pressure_limit_past_90_deg_is_refused():
    text = (MECH / "flat-rocker-cam.yaml").read_text().replace(
        "    psi:", "    pressure_limit: 100\n    psi:", 1)
    [msg] = _errors("rocker.yaml", text)
    assert msg.endswith("pressure_limit must be more than 0 and less than 90 deg (a pressure "
                        "angle of 90 deg locks the follower), not 100 deg")


# -- a motion segment too short to follow ------------------------------------------------------
def test_a_90_deg_rise_in_1e_12_s_is_an_input_error_at_its_segment():
    text = (MECH / "servo-press.yaml").read_text()
    old = "        - {rise: stroke, in: 0.4, law: cycloidal}"
    assert old in text
    text = text.replace(old, "        - {rise: 90, in: 1e-12, law: cycloidal}")
    line = next(k for k, x in enumerate(text.splitlines(), 1) if "in: 1e-12" in x)
    assert _errors("press.yaml", text) == [
        f"press.yaml:{line}: error: driver 1 (angle ground-crank): motion: segment 1: rise 90 in "
        f"1e-12 cycloidal is too short to follow: a segment lasts at least 1e-07 of its motion's "
        f"cycle (0.8 s), here 8e-08 s"]


def test_a_cam_segment_of_a_billionth_of_a_degree_is_an_input_error_at_its_segment():
    text = (MECH / "valve-cam.yaml").read_text()
    old = "          - {rise: h, in: 120, law: cycloidal}"
    assert old in text
    text = text.replace(old, "          - {rise: h, in: 1e-9, law: cycloidal}").replace(
        "          - {dwell: 60}\n          - {return", "          - {dwell: 179.999999999}\n"
                                                      "          - {return", 1)
    [msg] = _errors("cam.yaml", text)
    assert msg.endswith("s: motion: segment 1: rise 8 in 1e-09 cycloidal is too short to follow: "
                        "a segment lasts at least 1e-07 of its motion's cycle (360 deg), here "
                        "3.6e-05 deg")


def test_segments_long_enough_still_run():
    text = (MECH / "servo-press.yaml").read_text().replace(
        "        - {rise: stroke, in: 0.4, law: cycloidal}",
        "        - {rise: stroke, in: 1e-6, law: cycloidal}")
    res = planarkin.solve(planarkin.load("press.yaml", text=text))
    assert res.success


# -- a parameter reported invalid: its uses in expressions are not reported again ----------------
NAN_USES = """\
name: slider-crank
units: {length: m, angle: rad}
parameters:
  a: .nan
  b: 3*a
bodies:
  crank:  {q: [0.05, 0.0, 0.3]}
  rod:    {q: [0.2, 0.02, -0.1]}
  slider: {q: [0.4, 0.0, 0.0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: rod, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: rod, j: slider, si: [b, 0], sj: [0, 0]}
  - {type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "2*pi*t + a"}
points:
  P: {body: rod, s: [b, a]}
analysis: {start: 0, end: 1, steps: 36}
"""


def test_one_nan_parameter_is_one_error_even_in_a_driver_expression():
    assert _errors("nan.yaml", NAN_USES) == [
        "nan.yaml:4: error: parameter 'a': expression 'nan' is not finite (nan)"]


def test_one_nan_parameter_is_one_error_in_a_cam_law():
    text = (MECH / "cam-roller.yaml").read_text()
    assert "  h: 0.02 " in text
    [msg] = _errors("cam.yaml", text.replace("  h: 0.02 ", "  h: .nan "))
    assert msg.endswith("parameter 'h': expression 'nan' is not finite (nan)")


# -- the study API: InputError in API words ----------------------------------------------------
@pytest.fixture(scope="module")
def study():
    from planarkin.studies.variants import Study
    return Study(str(MECH / "four-bar.yaml"))


def _api(call):
    with pytest.raises(InputError) as e:
        call()
    [d] = e.value.diagnostics
    assert d.file == str(MECH / "four-bar.yaml")
    return d.message


def test_run_sweep_refuses_bad_arguments_with_input_errors(study, tmp_path):
    from planarkin.studies.sweep import parse_range, run_sweep
    a = parse_range("a=0.03:0.05:3", True)
    assert _api(lambda: run_sweep(study, [parse_range("zz=1:2:3", True)], tmp_path)) == (
        "run_sweep(): unknown parameter 'zz' (parameters: a, b, c, d)")
    assert _api(lambda: run_sweep(study, None, tmp_path)) == (
        "run_sweep(): ranges must be a non-empty list of Range (from parse_range('a=0.1:0.2:11', "
        "True)), not None")
    assert _api(lambda: run_sweep(study, [a, a], tmp_path)) == (
        "run_sweep(): each parameter may be varied once")
    for n in (0, -3, 2.5, True):
        assert _api(lambda: run_sweep(study, [parse_range("a=0.03:0.05", False)], tmp_path,
                                      samples=n)) == (
            f"run_sweep(): samples must be a whole number >= 1, not {n!r}")
    assert _api(lambda: run_sweep(study, [parse_range("a=0.03:0.05", False)], tmp_path)) == (
        "run_sweep(): the range of 'a' has no number of values: give NAME=LO:HI:N, or samples")
    assert not list(tmp_path.iterdir())          # nothing written


def test_run_tolerance_refuses_bad_arguments_with_input_errors(study, tmp_path):
    from planarkin.studies.tolerance import run_tolerance
    assert _api(lambda: run_tolerance(study, {"zz": 0.1}, tmp_path, 10)) == (
        "run_tolerance(): sigma: unknown parameter 'zz' (parameters: a, b, c, d)")
    assert _api(lambda: run_tolerance(study, {"aa": 0.1}, tmp_path, 10)) == (
        "run_tolerance(): sigma: unknown parameter 'aa'; did you mean 'a'?")
    for v in (-0.1, "x", math.inf, math.nan):
        assert _api(lambda: run_tolerance(study, {"a": v}, tmp_path, 10)) == (
            f"run_tolerance(): sigma of 'a' must be a number >= 0, not {v!r}")
    assert _api(lambda: run_tolerance(study, [("a", 0.1)], tmp_path, 10)) == (
        "run_tolerance(): sigma must be a non-empty dict of parameter names to standard "
        "deviations, not [('a', 0.1)]")
    for n in (0, 1):
        assert _api(lambda: run_tolerance(study, {"a": 0.001}, tmp_path, n)) == (
            f"run_tolerance(): samples must be a whole number >= 2, not {n}")
    assert _api(lambda: run_tolerance(study, {"a": 0.001}, tmp_path, 10, dist="cauchy")) == (
        "run_tolerance(): dist must be one of normal, uniform, not 'cauchy'")
    assert not list(tmp_path.iterdir())


def test_study_metrics_in_api_words():
    from planarkin.studies.variants import Study
    path = str(MECH / "four-bar.yaml")
    assert _api(lambda: Study(path, metrics="max:P.x")) == (
        "metrics must be a list of 'KIND:COLUMN' texts, not 'max:P.x'")
    assert _api(lambda: Study(path, metrics=[5])) == (
        "metrics must be a list of 'KIND:COLUMN' texts, not [5]")
    assert _api(lambda: Study(path, metrics=["max:P.x", "max:P.x"])) == (
        "metric max:P.x is given twice; give each metric once")
    assert _api(lambda: Study(path, metrics=["max:nothing"])).startswith(
        "metric max:nothing: no column 'nothing' in this model's tables")


def test_the_command_line_keeps_its_option_words(tmp_path):
    r = CliRunner().invoke(main, ["sweep", str(MECH / "four-bar.yaml"), "--vary",
                                  "a=0.03:0.05:3", "--metric", "max:P.x", "--metric", "max:P.x",
                                  "--out", str(tmp_path), "--no-plots"])
    assert r.exit_code == 2
    assert "error: --metric max:P.x is given twice; give each metric once" in r.output


def test_run_jobs_workers_keep_the_command_line_words(tmp_path):
    # the workers of `run --jobs` have no click context: they were told by the command line
    from clitools import run_cli
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    for p in (a, b):
        p.write_text((MECH / "four-bar.yaml").read_text())
    r = run_cli("run", a, b, "-j", "2", "--no-plots", "--out", tmp_path / "out", "--set", "zz=1")
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.count("error: --set zz: unknown parameter 'zz'") == 2, r.stderr
    assert "parameter override" not in r.stderr
