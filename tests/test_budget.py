"""Budgets, not hangs (planarkin/solver/budget.py): a driver whose rate would make the path follower's
step count explode, or that has a pole, is refused in seconds before the analysis, naming the
driver; and the node budget holds during the path too."""

import numpy as np
import pytest

import planarkin
from planarkin import InputError

from clitools import PLAIN_SLIDER_CRANK, run_cli

SLIDER = PLAIN_SLIDER_CRANK


def _model(tmp_path, f: str, name="m"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(SLIDER.replace('f: "2*pi*t"', f'f: "{f}"'))
    return p


@pytest.mark.parametrize("f, words", [
    ("1e6*t", "driver 1 (angle ground-crank): f moves by 1e+06 internal units over the time "
              "range (radians, or lengths divided by the model's size"),
    ("0.01/(t-0.4999)", "it is unbounded near t = 0.4999"),
    ("0.01/(t-0.5)", "f is not finite at t = 0.5 s"),
    ("1e3*sin(1e3*t)", "more than 500000 internal steps"),
])
def test_fast_or_unbounded_drivers_are_refused_quickly(tmp_path, f, words, monkeypatch):
    """Refused by the preflight's bounded sampling (counted: the driver values it computes),
    before a single path step."""
    from planarkin.solver import budget
    from planarkin.functions.expr import TimeFunction
    from planarkin.solver.grid import PathFollower
    sampled, followed = [0], []
    call = TimeFunction.__call__

    def counting(self, t, side=0):
        sampled[0] += np.size(t)
        return call(self, t, side)

    monkeypatch.setattr(TimeFunction, "__call__", counting)
    monkeypatch.setattr(PathFollower, "run", lambda self: followed.append(1))
    p = _model(tmp_path, f)
    r = run_cli("run", p, "--out", tmp_path, "--no-plots")
    assert followed == [] and sampled[0] <= 3 * budget._MAX_SAMPLES, sampled[0]
    assert r.returncode == 2 and "Traceback" not in r.stderr
    line = next(i for i, t in enumerate(p.read_text().splitlines(), 1) if "type: angle" in t)
    assert r.stderr.startswith(f"{p}:{line}: error: driver 1 (angle ground-crank): "), r.stderr
    assert words in r.stderr, r.stderr
    assert not (tmp_path / "m").exists()


def test_budget_can_be_raised_and_is_honoured_on_the_path(tmp_path):
    m = planarkin.load(_model(tmp_path, "200*t"))
    with pytest.raises(InputError, match="more than 100 internal steps"):
        planarkin.solve(m, max_nodes=100)
    res = planarkin.solve(m, max_nodes=100_000, steps=50)
    assert res.status == 0


def test_ordinary_drivers_pass_the_preflight(tmp_path):
    for f in ("2*pi*t", "0.3 + 0.2*sin(2*pi*t)", "2*pi*t**3", "100*t"):
        assert planarkin.solve(planarkin.load(_model(tmp_path, f)), steps=20).status == 0


@pytest.mark.parametrize("start, refused", [(0.0, False), (1e4, False), (3e4, True),
                                            (1e5, True), (1e8, True)])
def test_driver_values_beyond_double_precision_are_refused(tmp_path, start, refused):
    """2*pi*t at t = 1e5 s is 6.3e5 rad, resolved only to 1.2e-10 rad: Newton cannot meet its
    1e-12 tolerance there, and the run used to fail as 'singular Jacobian at the assembly pose'
    (1e6) or as a violated joint (1e8). Refused up front, naming the driver and the fix, by the
    API, `run` and `check` alike; up to 1e4 s the run is exact."""
    m = planarkin.load(_model(tmp_path, "2*pi*t"))
    if not refused:
        res = planarkin.solve(m, start=start, end=start + 1, steps=36)
        assert res.info.status == 0
        # the crank angle itself: its error is the driver value's own rounding (ulp 7e-12 rad)
        assert abs(res.body("crank")["phi"][-1] - 2 * np.pi * (start + 1)) < 1e-11
        return
    with pytest.raises(InputError) as e:
        planarkin.solve(m, start=start, end=start + 1, steps=36)
    msg = str(e.value)
    assert "driver 1 (angle ground-crank): f reaches" in msg and "which double precision " \
        "resolves only to" in msg and "shift the time origin towards 0" in msg, msg
    p = _model(tmp_path, "2*pi*t", name="late")
    p.write_text(p.read_text().replace("start: 0, end: 1,", f"start: {start}, end: {start + 1},"))
    for cmd in ("run", "check"):
        r = run_cli(cmd, p, "--out", tmp_path, "--no-plots") if cmd == "run" \
            else run_cli(cmd, p)
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        assert "double precision resolves only to" in r.stderr


# -- study sizes (issue 21, item 14): refused before the first variant, with the figures -------
@pytest.mark.parametrize("args, words", [
    (["sweep", "--vary", "a=0.05:0.06:10000", "--vary", "b=0.3:0.4:10000"],
     "a study of 100000000 variants of 101 grid rows each would take about 112 GB of memory and "
     "350 h (the budget: 1 GB and 24 h): use fewer variants (the N of each --vary), or split it "
     "into smaller studies"),
    (["sweep", "--vary", "a=0.05:0.06", "--samples", "10000000"],
     "a study of 10000000 variants of 101 grid rows each would take about 10.2 GB of memory and "
     "35 h (the budget: 1 GB and 24 h): use fewer variants (--samples), or split it into "
     "smaller studies"),
    (["sweep", "--vary", "a=0.05:0.06:3", "--steps", "9000000"],
     "a study of 3 variants of 9000001 grid rows each would take about 27.7 GB of memory and "
     "162 s (the budget: 1 GB and 24 h): use fewer --steps (the variants solved together, up "
     "to 16, hold every grid row)"),
    (["tolerance", "--sigma", "a=0.001", "--samples", "10000000"],
     "a study of 10000000 variants of 101 grid rows each would take about 11.2 GB of memory "
     "and 35 h (the budget: 1 GB and 24 h): use fewer variants (--samples), or split it into "
     "smaller studies"),
])
def test_a_study_too_large_is_refused_before_it_starts(tmp_path, args, words, monkeypatch):
    """Refused before the first variant (counted: the groups of variants solved)."""
    from click.testing import CliRunner

    from planarkin.cli import main
    from planarkin.studies.batch import Batch
    solved = []
    monkeypatch.setattr(Batch, "run_group", lambda self, *a, **k: solved.append(1))
    p = tmp_path / "m.yaml"
    p.write_text(SLIDER.replace("steps: 360", "steps: 100"))
    r = CliRunner().invoke(main, [args[0], str(p), *args[1:], "--no-plots", "--out",
                                  str(tmp_path / "out")])
    assert solved == []
    assert r.exit_code == 2, r.output
    assert f"{p}: error: {words}\n" in r.output
    assert not (tmp_path / "out").exists()
