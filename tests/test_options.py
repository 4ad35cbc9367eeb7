"""One door for options: the YAML `analysis:` block, the command line and the Python API accept
the same values and refuse the others with the same words (planarkin.options)."""

import math
import tracemalloc

import pytest

import planarkin
from planarkin import InputError
from planarkin.options import OPTIONS, resolve

from clitools import ROOT, run_cli

SLIDER = ROOT / "mechanisms" / "slider-crank.yaml"
BASE = SLIDER.read_text()


def _with_analysis(block: str) -> str:
    """The slider-crank with its analysis: line replaced."""
    lines = [t for t in BASE.splitlines() if not t.startswith("analysis:")]
    return "\n".join(lines) + f"\nanalysis: {block}\n"


@pytest.fixture(scope="module")
def model():
    return planarkin.load(SLIDER)


# (option, bad value as the API gets it, as the command line gets it, the complaint)
BAD = [
    ("end", -1.0, "-1", "end (-1) must be greater than start (0)"),
    ("end", math.nan, "nan", "must be a finite number, not nan"),
    ("end", math.inf, "inf", "must be a finite number, not inf"),
    ("steps", -1, "-1", "must be a whole number between 1 and 1000000000, not -1"),
    ("steps", 2.5, "2.5", "must be a whole number between 1 and 1000000000, not 2.5"),
    ("tol", -1.0, "-1", "must be a finite number between 1e-15 and 0.1, not -1"),
    ("iterations", 0, "0", "must be a whole number between 1 and 100, not 0"),
    ("path_tol", 1.0, "1", "must be a finite number between 1e-12 and 0.1, not 1"),
    ("max_step", 0.0, "0", "must be a finite number greater than 0, not 0"),
    ("max_rows", 0, "0", "must be a whole number of at least 1, not 0"),
]


@pytest.mark.parametrize("name, api, cli, words", BAD, ids=[f"{b[0]}={b[2]}" for b in BAD])
def test_api_cli_and_yaml_refuse_alike(model, tmp_path, name, api, cli, words):
    with pytest.raises(InputError) as e:
        planarkin.solve(model, **{name: api})
    assert words in str(e.value)
    assert str(e.value).startswith(f"{SLIDER}: error: solve()")
    r = run_cli("run", SLIDER, "--out", tmp_path, "--no-plots", OPTIONS[name].flag, cli)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    assert words in r.stderr and OPTIONS[name].flag in r.stderr
    assert not (tmp_path / "slider-crank").exists()
    yaml_value = {"nan": ".nan", "inf": ".inf"}.get(cli, cli)
    f = tmp_path / "m.yaml"
    f.write_text(_with_analysis(f"{{{name}: {yaml_value}}}"))
    r = run_cli("check", f)
    assert r.returncode == 2
    line = next(i for i, t in enumerate(f.read_text().splitlines(), 1) if "analysis:" in t)
    # a non-finite number is refused where the YAML number is read, in that reader's words
    words = "is not finite" if cli in ("nan", "inf") else words
    assert f"{f}:{line}: error: analysis: {name}" in r.stderr or \
        f"{f}:{line}: error: analysis: end (" in r.stderr, r.stderr
    assert words in r.stderr, r.stderr


@pytest.mark.parametrize("name, value, words", [
    ("newton", "bogus", "newton must be 'reuse', 'full' or 'fixed', not 'bogus'"),
    ("bifurcation", "go", "bifurcation must be 'stop' or 'continue', not 'go'"),
    ("up_to", 7, "up_to must be 'position', 'velocity', 'acceleration' or 'jerk', not 7"),
    ("up_to", "velocty", "did you mean 'velocity'?"),
    ("interpolate", "no", "interpolate must be true or false, not 'no'"),
    ("interpolate", 1, "interpolate must be true or false, not 1"),
])
def test_api_refuses_wrong_kinds(model, name, value, words):
    with pytest.raises(InputError) as e:
        planarkin.solve(model, **{name: value})
    assert words in str(e.value)


def test_api_unknown_option_suggests(model):
    with pytest.raises(InputError, match=r"unknown option 'stpes'; did you mean 'steps'\?"):
        planarkin.solve(model, stpes=10)
    with pytest.raises(InputError, match=r"unknown option 'order'; did you mean 'up_to'\?"):
        planarkin.solve(model, order=1)


def test_api_good_options_resolve(model):
    o = resolve(model, {"steps": 50, "up_to": "velocity", "interpolate": True, "end": 2},
                source="api")
    assert (o.steps, o.order, o.interpolate, o.end) == (50, 1, True, 2.0)
    res = planarkin.solve(model, steps=8, up_to="position")
    assert res.status == 0 and res.qd is None and len(res.t) == 9


def test_cli_end_is_blamed_on_the_option_not_the_yaml(tmp_path):
    r = run_cli("run", SLIDER, "--out", tmp_path, "--no-plots", "--end", "-1")
    assert r.returncode == 2
    assert f"{SLIDER}: error: option --end: end (-1) must be greater than start (0)" in r.stderr


def test_yaml_end_before_start_at_its_line(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text(_with_analysis("\n  start: 2\n  end: 1"))
    r = run_cli("check", f)
    n = len(f.read_text().splitlines())
    assert f"{f}:{n}: error: analysis: end (1) must be greater than start (2)" in r.stderr


def test_unresolvable_time_grid_is_refused(model):
    with pytest.raises(InputError, match="below what double precision resolves near t = 1e"):
        planarkin.solve(model, start=1e14, end=1e14 + 1, steps=10**4)
    # a start away from 0 assembles there (an API start used to assemble at the YAML start)
    res = planarkin.solve(model, start=100, end=101, steps=10)
    assert res.status == 0 and len(set(res.t)) == 11


def test_huge_grid_is_refused_before_allocating(model, tmp_path):
    # a bound on bytes, not seconds: 1e9 rows would be gigabytes; refused, a few megabytes
    tracemalloc.start()
    with pytest.raises(InputError, match=r"1000000001 grid rows is more than max_rows "
                                         r"\(10000000\); raise max_rows"):
        planarkin.solve(model, steps=10**9)
    r = run_cli("run", SLIDER, "--out", tmp_path, "--no-plots", "--steps", "1000000000")
    assert r.returncode == 2 and "option --steps: 1000000001 grid rows" in r.stderr
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6


def test_grid_is_made_chunk_by_chunk(model):
    o = resolve(model, {"steps": 7, "start": 0.1, "end": 0.8})
    whole = o.times()
    assert whole[0] == 0.1 and whole[-1] == 0.8 and len(whole) == 8
    parts = [o.times(a, a + 3) for a in range(0, 8, 3)]
    assert [list(p) for p in parts] == [list(whole[a:a + 3]) for a in range(0, 8, 3)]


def test_unknown_body_and_point_names_raise_keyerror(model):
    res = planarkin.solve(model, steps=4)
    with pytest.raises(KeyError, match="no body 'sldier' in this model; did you mean 'slider'"):
        res.body("sldier")
    with pytest.raises(KeyError, match=r"no point 'Q' in this model \(point names: B\)"):
        res.point("Q")
    with pytest.raises(KeyError, match="no table 'forcez.csv'"):
        res.table("forcez.csv")
