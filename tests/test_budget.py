"""Budgets, not hangs (planarkin/budget.py): a driver whose rate would make the path follower's
step count explode, or that has a pole, is refused in seconds before the analysis, naming the
driver; and the node budget holds during the path too."""

import time

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
def test_fast_or_unbounded_drivers_are_refused_quickly(tmp_path, f, words):
    p = _model(tmp_path, f)
    t0 = time.perf_counter()
    r = run_cli("run", p, "--out", tmp_path, "--no-plots")
    assert time.perf_counter() - t0 < 30
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
