"""planarkin synth: the design block's validation, the exact Jacobian of the residuals (against
central differences, per element kind and target kind), the search and the result directory."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from planarkin.cli import main
from planarkin.synthesis.problem import Rejected
from planarkin.synthesis.synth import Synthesis, synthesize

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "mechanisms" / "synthesis"
LINE = EX / "straight-line.yaml"


def _central(syn, x, rel=1e-6):
    J = np.zeros((len(syn.evaluate(x, jac=False)[0]), len(x)))
    for i in range(len(x)):
        h = rel * max(1.0, abs(x[i]))
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        J[:, i] = (syn.evaluate(xp, jac=False)[0] - syn.evaluate(xm, jac=False)[0]) / (2 * h)
    return J


def _check(syn, x, tol=1e-6):
    r, J, d = syn.evaluate(np.asarray(x, dtype=float))
    assert r is not None, d
    Jn = _central(syn, np.asarray(x, dtype=float))
    scale = np.abs(J).max()
    assert np.abs(J - Jn).max() <= tol * scale, np.abs(J - Jn).max(axis=0) / scale


def test_jacobian_revolute_path_free_timing():
    """Four revolutes, the ground pivots and the ground angle free (they reach si of ground
    joints and the driver's f); the six crank times projected (the nearest points of the
    path, in order): the residuals are the signed normal distances and n . dP/dp their exact
    gradient, which central differences of the re-projected distances confirm."""
    syn = Synthesis(LINE)
    syn.wrap = True
    assert syn.nt == 0 and syn.projected == [0]
    r, _, d = syn.evaluate(np.array([0, 0, 0.3, 10, 40, 30, 40, 20, 20.0]))
    # the projection: (P - T) normal to the path, its length the residual
    st, T = d.state, np.array(syn.design.targets[0].values)
    j = syn.points.index("P")
    V = st.pd[:, j]
    assert np.abs(((st.p[:, j] - T) * V).sum(axis=1)).max() <= 1e-9 * np.abs(V).max()
    assert np.allclose(np.abs(r[:6]), np.hypot(*(st.p[:, j] - T).T), rtol=1e-12)
    assert d.cost == pytest.approx(float(r[:6] @ r[:6]), rel=1e-12)
    _check(syn, [0, 0, 0.3, 10, 40, 30, 40, 20, 20])


def test_turns_barrier_row_and_its_gradient():
    """Near a change point (crank 10, coupler 50, rocker 40.6, ground 20: margin
    50 + 40.6 + 20 - 2 * 50 - 10 = 0.6 mm, below 1 % of the length sum, the default band) the
    barrier row (m0 - m)^2 / m is on, and its exact gradient (through the lengths' expressions)
    matches central differences with the rest of the Jacobian; with search: band 1e-4 the row
    acts only within 0.012 mm of the wall, so here it is off."""
    x = [0, 0, 0.3, 10, 50, 40.6, 20, 20, 20]
    syn = Synthesis(LINE)
    syn.wrap = True
    syn.band = 1e-4
    r, _, d = syn.evaluate(np.array(x, dtype=float))
    assert r[-1] == 0
    syn = Synthesis(LINE)
    syn.wrap = True
    assert syn.band == 0.01
    r, _, d = syn.evaluate(np.array(x, dtype=float))
    assert d.margins["turns"]["value"] == pytest.approx(0.6, abs=1e-9)
    m0 = 0.01 * (10 + 50 + 40.6 + 20)
    assert r[-1] == pytest.approx((m0 - 0.6) ** 2 / 0.6, rel=1e-9)
    _check(syn, x)
    # above the band the row is zero, its gradient too
    r, J, d = syn.evaluate(np.array([0, 0, 0.3, 10, 40, 30, 40, 20, 20.0]))
    assert r[-1] == 0 and not J[-1].any()


def _variant(tmp_path, src, old, new, name="m.yaml"):
    text = Path(src).read_text()
    assert old in text
    p = tmp_path / name
    p.write_text(text.replace(old, new))
    return p


def test_jacobian_prescribed_inputs_through_a_driver_that_depends_on_p(tmp_path):
    """Inputs given as driver values of f = th0 + 2 pi t: the time of each input moves with th0
    (dt*/dp = -f_p / f_t)."""
    p = _variant(tmp_path, LINE, "[20, 40], [20, 45]]}",
                 "[20, 40], [20, 45]], inputs: [0.5, 1.5, 2.5, 3.5, 4.5, 5.5]}")
    syn = Synthesis(p)
    assert syn.nt == 0
    _check(syn, [1, -2, 0.4, 10, 40, 30, 40, 20, 20])


def test_jacobian_translational_function_generation():
    """Slider-crank (revolutes and a translational joint), the slider's x at crank angles; b is
    an expression (3*a) in the file and becomes free."""
    syn = Synthesis(EX / "slider-crank-stroke.yaml")
    _check(syn, [0.09, 0.31])


def test_jacobian_motion_generation(tmp_path):
    """Poses of the coupler: point P and the coupler's angle (degrees, wrapped)."""
    p = _variant(tmp_path, EX / "four-bar-function.yaml", """    - function: rocker.phi
      inputs: [0, 60, 120, 180, 240, 300]
      outputs: [86.1774462707, 77.1623665969, 100.5363231374, 122.8783495644, 132.7405506414,
                123.9888154896]""", """    - motion: coupler
      point: P
      poses: [[0.03, 0.07, 50], [0.04, 0.1, 20], [0.0, 0.1, 10]]""")
    syn = Synthesis(p)
    assert syn.nt == 3
    _check(syn, [0.121, 0.099, 0.101, 0.05, 0.3, 0.6])


def test_path_with_timing_finds_the_model_again():
    """The targets are four-bar.yaml's coupler points at six crank angles: the search returns
    a = 0.04, b = 0.12, c = d = 0.1 (rounding of the targets: 1e-12 m)."""
    res = synthesize(EX / "four-bar-path.yaml", starts=8, local=1)
    assert res.status == 0
    d = res.designs[0]
    assert d.cost < 1e-20
    for k, v in {"a": 0.04, "b": 0.12, "c": 0.1, "d": 0.1}.items():
        assert abs(d.values[k] - v) < 1e-9
    assert d.margins["turns"]["ok"] and d.margins["transmission"]["ok"]
    assert res.evaluations > 0 and res.jacobians > 0


def test_a_design_that_cannot_assemble_is_rejected_with_its_reason():
    syn = Synthesis(LINE)
    r, J, d = syn.evaluate(np.array([0, 0, 0, 5, 5, 5, 60, 20, 20] + [0.1] * 6))
    assert r is None and isinstance(d, Rejected) and d.reason.startswith("invalid")
    # a triple-rocker (non-Grashof) assembles at t = 0 and locks up part-way: rejected with the
    # kind and time
    out = syn.model.analyse({"x0": 0, "y0": 0, "th0": 0, "a": 10, "b": 20, "c": 15, "d": 40,
                             "px": 20, "py": 20})
    assert isinstance(out, Rejected) and out.reason.startswith("lock-up at t =")


def test_cli_synth_writes_ready_to_run_designs(tmp_path):
    runner = CliRunner()
    r = runner.invoke(main, ["synth", str(EX / "four-bar-function.yaml"), "--out",
                             str(tmp_path), "--starts", "6", "--local", "1"])
    assert r.exit_code == 0, r.output
    out = tmp_path / "four-bar-function.synth"
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "ok" and s["designs"][0]["cost"] < 1e-12
    assert s["evaluations"] > 0 and s["jacobians"] > 0
    assert 0 < s["analyses"] <= s["evaluations"]
    assert (out / "synth.png").exists() and (out / "residuals.csv").exists()
    r = runner.invoke(main, ["run", str(out / "design-1.yaml"), "--out", str(tmp_path / "run"),
                             "--no-plots"])
    assert r.exit_code == 0, r.output


def test_cli_synth_none_acceptable_exits_1(tmp_path):
    # a small evaluation budget: the search spends the whole budget when the goal is out of
    # reach (the default's 2,000 evaluations took 20 s here)
    p = _variant(tmp_path, EX / "four-bar-function.yaml", "goal: 1e-12",
                 "goal: 1e-30, evaluations: 60")
    p = _variant(tmp_path, p, "outputs: [86.1774462707", "outputs: [96.1774462707",
                 "far.yaml")
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path), "--starts", "4",
                                  "--local", "1", "--no-plots"])
    assert r.exit_code == 1, r.output
    assert "no design reaches the goal" in r.output


BAD = [
    ("free: {b: [0.10, 0.14], c: [0.08, 0.12], d: [0.08, 0.12]}", "free: {}",
     "design: free must name at least one parameter"),
    ("b: [0.10, 0.14]", "b: [0.14, 0.10]",
     "design: free: b: the bounds [0.14, 0.1] must be [low, high] with low < high"),
    ("b: [0.10, 0.14]", "bb: [0.10, 0.14]",
     "design: free: 'bb' is not a parameter; did you mean 'b'?"),
    ("function: rocker.phi", "function: rockr.phi", "design: target 1: function: 'rockr.phi' "
                                                     "must be BODY.x, BODY.y or BODY.phi"),
    ("inputs: [0, 60, 120, 180, 240, 300]", "inputs: [0, 60, 120]",
     "design: target 1: 3 inputs for 6 outputs"),
    ("constraints: {turns: crank}", "constraints: {turns: crank, trans: 3}",
     "design: constraints: unknown key 'trans'"),
]


@pytest.mark.parametrize("old,new,message", BAD)
def test_bad_design_is_a_file_line_error(tmp_path, old, new, message):
    p = _variant(tmp_path, EX / "four-bar-function.yaml", old, new)
    lines = p.read_text().splitlines()
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    err = [ln for ln in r.output.splitlines() if ": error: " in ln]
    assert err and message in err[0], r.output
    line = int(err[0].split(":")[1])
    assert 1 <= line <= len(lines)
    # the same door as run and check
    assert CliRunner().invoke(main, ["check", str(p)]).exit_code == 2


def test_no_design_block_is_refused(tmp_path):
    r = CliRunner().invoke(main, ["synth", str(ROOT / "mechanisms" / "four-bar.yaml"), "--out",
                                  str(tmp_path)])
    assert r.exit_code == 2 and "the model has no design: block" in r.output


def test_order_along_the_path_either_direction():
    """Free times in cyclic order (forwards or backwards, over the end of the cycle) pass; a
    sequence that goes back and forth does not."""
    syn = Synthesis(LINE)
    syn.wrap = True
    t = np.array
    assert syn._in_order(t([0.1, 0.2, 0.3])) > 0
    assert syn._in_order(t([0.8, 0.9, 0.05])) > 0            # over the end of the cycle
    assert max(syn._in_order(t([0.3, 0.2, 0.1])), syn._in_order(t([0.1, 0.2, 0.3]))) > 0
    bad = t([0.1, 0.3, 0.2, 0.4])
    assert max(syn._in_order(bad), syn._in_order(bad[::-1])) < 0


def test_jacobian_six_bar_function_generation():
    """Stephenson III six-bar: the output link's angle through the dyad's lengths."""
    syn = Synthesis(EX / "six-bar-output.yaml")
    _check(syn, [0.155, 0.105])


def test_synth_and_run_in_the_same_out_keep_each_others_files(tmp_path):
    """run writes DIR/<name>/, synth DIR/<name>.synth/ (run's name, output.directory.out_dirs):
    a synth after a run, and a run after a synth, leave the other's files as they were; a
    second synth replaces its own directory whole (the output contract of run)."""
    runner = CliRunner()
    model = EX / "four-bar-function.yaml"
    r = runner.invoke(main, ["run", str(model), "--out", str(tmp_path), "--no-plots"])
    assert r.exit_code == 0, r.output
    run_dir = tmp_path / "four-bar-function"
    before = {p.name: p.read_bytes() for p in run_dir.iterdir()}
    args = ["synth", str(model), "--out", str(tmp_path), "--starts", "6", "--local", "1",
            "--no-plots"]
    r = runner.invoke(main, args)
    assert r.exit_code == 0, r.output
    assert {p.name: p.read_bytes() for p in run_dir.iterdir()} == before
    syn_dir = tmp_path / "four-bar-function.synth"
    assert json.loads((syn_dir / "summary.json").read_text())["command"] == "synth"
    (syn_dir / "design-9.yaml").write_text("stale")        # not a file of the next synth
    r = runner.invoke(main, args)
    assert r.exit_code == 0, r.output
    assert not (syn_dir / "design-9.yaml").exists()
    synth_files = {p.name: p.read_bytes() for p in syn_dir.iterdir()}
    r = runner.invoke(main, ["run", str(model), "--out", str(tmp_path), "--no-plots"])
    assert r.exit_code == 0, r.output
    assert {p.name: p.read_bytes() for p in syn_dir.iterdir()} == synth_files
    assert json.loads((run_dir / "summary.json").read_text()).get("command") != "synth"
    # a directory of someone else's at that name is left alone: exit 2, nothing replaced
    other = tmp_path / "x"
    (other / "four-bar-function.synth").mkdir(parents=True)
    (other / "four-bar-function.synth" / "notes.txt").write_text("mine")
    r = runner.invoke(main, args[:3] + [str(other)] + args[4:])
    assert r.exit_code == 2 and "is not a planarkin result directory" in r.output, r.output
    assert (other / "four-bar-function.synth" / "notes.txt").read_text() == "mine"


MORE_BAD = [
    ("design:\n  free: {b: [0.10, 0.14]", "design: [1, 2]\nxdesign:\n  free: {b: [0.10, 0.14]",
     "design must be a mapping"),
    ("b: [0.10, 0.14]", "b: [0.10]", "design: free: b must be a list of 2 numbers"),
    ("b: [0.10, 0.14]", "b: [0.10, oops]", "design: free: b: unknown name 'oops'"),
    ("search: {starts: 16", "search: {starts: 0", "design: search: starts must be a whole "
                                                  "number from 1 to 100000, not 0"),
    ("search: {starts: 16", "search: {starts: 2.5", "design: search: starts must be a whole "
                                                    "number"),
    ("goal: 1e-12", "goal: 1e-12, start: 5", "design: search: unknown key 'start'"),
    ("function: rocker.phi", "function: rocker.phi\n      weight: 0", "weight must be > 0"),
    ("function: rocker.phi", "function: rocker.speed", "must be BODY.x, BODY.y or BODY.phi"),
    ("    - function: rocker.phi\n      inputs: [0, 60, 120, 180, 240, 300]\n",
     "    - path: Q\n      inputs: [0, 60, 120, 180, 240, 300]\n",
     "design: target 1: path: 'Q' is not a point of the model"),
    ("targets:", "targets: 3\n  old_targets:", "design: targets must be a list"),
]


@pytest.mark.parametrize("old,new,message", MORE_BAD)
def test_more_bad_designs_are_file_line_errors(tmp_path, old, new, message):
    test_bad_design_is_a_file_line_error(tmp_path, old, new, message)


def test_no_targets_is_refused_for_synth(tmp_path):
    p = tmp_path / "m.yaml"
    text = (EX / "four-bar-function.yaml").read_text()
    p.write_text(text[:text.index("  targets:")] + "  search: {starts: 4}\n")
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert f"{p}:" in r.output and "design: no targets" in r.output


def test_inputs_out_of_the_drivers_range_are_a_clear_refusal(tmp_path):
    """Targets out of reach: inputs the driver never takes (the crank turns 0..360 deg) make
    every start a rejected candidate, counted with its reason; exit 1, no traceback."""
    p = _variant(tmp_path, EX / "four-bar-function.yaml",
                 "inputs: [0, 60, 120, 180, 240, 300]", "inputs: [0, 60, 120, 180, 240, 900]")
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path), "--starts", "4",
                                  "--local", "1", "--no-plots"])
    assert r.exit_code == 1, r.output
    assert "no acceptable design: 4 the input value 900 is not reached" in r.output, r.output


def test_points_out_of_reach_end_with_the_best_design_and_exit_1(tmp_path):
    """Path points a kilometre away: the search ends, the best design is written with its
    residuals and the summary says the goal was not reached."""
    p = _variant(tmp_path, EX / "four-bar-path.yaml", "[[0.035916759466, 0.074888765157]",
                 "[[1000.035916759466, 0.074888765157]")
    p = _variant(tmp_path, p, "goal: 1e-20}", "goal: 1e-20, evaluations: 200}")   # (as above)
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path), "--starts", "4",
                                  "--local", "1", "--no-plots"])
    assert r.exit_code == 1, r.output
    assert "no design reaches the goal 1e-20" in r.output
    s = json.loads((tmp_path / "m.synth" / "summary.json").read_text())
    assert s["status"] == "failed" and s["designs"][0]["cost"] > 1e5


@pytest.mark.parametrize("options,message", [
    ({"starts": 0}, "synthesize: starts must be a whole number from 1 to 100000, not 0"),
    ({"local": 2.5}, "synthesize: local must be a whole number"),
    ({"goal": float("nan")}, "synthesize: goal must be a number"),
    ({"start": 3}, "synthesize: unknown option 'start'; did you mean 'starts'?"),
    ({"batch": -1}, "synthesize: batch must be a whole number from 0 to 100000, not -1"),
    ({"probe_cost": -1.0}, "synthesize: probe_cost must be a number from 0 to inf"),
])
def test_api_options_are_checked(options, message):
    import planarkin
    with pytest.raises(planarkin.InputError) as e:
        planarkin.synthesize(EX / "four-bar-function.yaml", **options)
    assert message in str(e.value)


def test_local_follows_probe_unless_given():
    """local's default: 10 runs a draw, or with probe every start of the draw (the probed runs
    are short); a value given stays. keep's default is 1."""
    from planarkin.synthesis.settings import settled
    from planarkin.synthesis.spec import SEARCH
    cfg = {k: d for k, (_, _, _, d) in SEARCH.items()}
    assert cfg["keep"] == 1 and cfg["local"] is None
    assert settled(cfg)["local"] == 10
    assert settled({**cfg, "probe": 30, "starts": 150})["local"] == 150
    assert settled({**cfg, "probe": 30, "local": 7})["local"] == 7


def test_the_straight_line_needs_three_search_settings():
    """The six collinear points (free timing): the file's search block says what the problem
    needs (goal, budget, probe) and nothing the defaults give."""
    import yaml
    doc = yaml.safe_load((EX / "straight-line.yaml").read_text())
    assert sorted(doc["design"]["search"]) == ["evaluations", "goal", "probe"]
    syn = Synthesis(EX / "straight-line.yaml")
    from planarkin.synthesis.settings import settled
    cfg = settled(dict(syn.design.search))
    assert (cfg["local"], cfg["keep"], cfg["starts"]) == (200, 1, 200)


def test_jacobian_angle_joint_constant_and_relative_driver():
    """The five-point problem: th0 reaches an angle joint's constant c (dPhi/dc = -1) and the
    crank is driven relative to that frame; prescribed inputs, the barrier row off."""
    syn = Synthesis(EX / "five-point-curve.yaml")
    _check(syn, [0.5, -0.3, 0.4, 1.1, 4.2, 3.1, 3.9, 2.1, 1.8])


@pytest.mark.parametrize("name,truth", [
    ("slider-crank-stroke.yaml", {"a": 0.1, "b": 0.3}),
    ("six-bar-output.yaml", {"e5": 0.16, "e6": 0.10}),
])
def test_synth_finds_the_slider_crank_and_the_six_bar_again(name, truth):
    """Function generation on the slider-crank (the slider's x) and the Stephenson six-bar
    (the output link's angle): the targets are the example models' own values, so the search
    returns their parameters (to the targets' rounding)."""
    import planarkin
    res = planarkin.synthesize(EX / name, starts=6, local=2)
    assert res.status == 0, res.message
    d = res.designs[0]
    for k, v in truth.items():
        assert abs(d.values[k] - v) < 1e-8, (k, d.values)


def test_sketch_form_models_are_refused_with_the_line_of_links(tmp_path):
    """The sketch form's points are global placements (at:), which the sensitivities do not
    differentiate: synth and fit refuse it at the line of links: (it was an AttributeError)."""
    text = (ROOT / "mechanisms" / "four-bar-sketch.yaml").read_text()
    text = text.replace("points:\n  A:", "parameters:\n  dx: 0.1\npoints:\n  A:", 1)
    text = text.replace("D: {at: [0.1, 0], ground: true}", "D: {at: [dx, 0], ground: true}")
    text += ("design:\n  free: {dx: [0.09, 0.11]}\n  targets:\n    - function: rocker.phi\n"
             "      inputs: [0, 60]\n      outputs: [86.2, 77.2]\n")
    p = tmp_path / "sk.yaml"
    p.write_text(text)
    line = text.splitlines().index("links:") + 1
    r = CliRunner().invoke(main, ["synth", str(p), "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert f"{p}:{line}: error: synth and fit need the body form" in r.output
    d = tmp_path / "d.csv"
    d.write_text("t [s],P.x [m],P.y [m]\n0,0.05,0.08\n0.1,0.04,0.09\n")
    r = CliRunner().invoke(main, ["fit", str(p), "--data", str(d), "--free", "dx", "--out",
                                  str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert f"{p}:{line}: error: synth and fit need the body form" in r.output
