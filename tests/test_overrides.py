"""Parameter overrides: --set NAME=VALUE on the command line, keyword arguments to load()."""

import json
import math

import numpy as np
import pytest

import planarkin
from clitools import run_cli
from closedforms import slider_crank

SC = "mechanisms/slider-crank.yaml"
FB = "mechanisms/four-bar.yaml"


def _slider_x(a, b, phi):
    """Closed form: slider position of a centred slider-crank, crank a, rod b."""
    return slider_crank(phi, 0.0, 0.0, a, b)[3]


def test_override_re_evaluates_every_dependent_parameter_and_number():
    m = planarkin.load(SC, a=0.08)
    assert m.spec.parameters == {"a": 0.08, "b": 3 * 0.08}
    assert m.spec.overrides == {"a": 0.08}
    r = planarkin.solve(m, steps=24)
    phi = 2 * np.pi * r.t
    assert np.allclose(r.body("slider")["x"], _slider_x(0.08, 0.24, phi), rtol=0, atol=1e-15)
    assert np.allclose(r.point("B")["x"], _slider_x(0.08, 0.24, phi), rtol=0, atol=1e-15)


def test_override_value_may_be_an_expression_of_earlier_parameters():
    m = planarkin.load(SC, b="2.5*a + 0.01")
    assert m.spec.parameters == {"a": 0.1, "b": 2.5 * 0.1 + 0.01}
    m = planarkin.load(SC, a="sqrt(0.0064)", b=0.3)
    assert m.spec.parameters == {"a": math.sqrt(0.0064), "b": 0.3}


def test_unknown_parameter_is_an_input_error_with_a_suggestion():
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load(FB, aa=0.05)
    # API callers get the API's words, not the command line's --set (issue 21, item 19)
    assert str(e.value) == ("mechanisms/four-bar.yaml:7: error: parameter override aa: unknown "
                            "parameter 'aa'; did you mean 'a'?")
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load("mechanisms/trammel.yaml", zz=1)
    assert "parameter override zz: unknown parameter 'zz'" in str(e.value)


def test_invalid_override_value_is_reported_at_the_parameter():
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load(SC, b="3*c")
    assert str(e.value).startswith("mechanisms/slider-crank.yaml:8: error: parameter override "
                                   "b=3*c: parameter 'b': unknown name 'c'")
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load(SC, a=[1])
    assert "parameter override a=[1]: parameter 'a' must be a number or an expression" in \
        str(e.value)


def test_the_command_line_in_process_still_says_set():
    from click.testing import CliRunner
    from planarkin.cli import main
    r = CliRunner().invoke(main, ["check", FB, "--set", "aa=1"])
    assert r.exit_code == 2
    assert r.stderr.startswith("mechanisms/four-bar.yaml:7: error: --set aa: unknown parameter "
                               "'aa'; did you mean 'a'?\n")


@pytest.mark.parametrize("command", [["check"], ["run", "--no-plots"], ["synth"]])
def test_a_parameter_set_twice_is_a_usage_error(command):
    # the last --set silently won: a sweep script that appends a value ran the old one
    from clitools import run_cli
    r = run_cli(*command, FB, "--set", "a=0.04", "--set", "a = 0.05")
    assert r.returncode == 2
    assert "'a' is set twice (a=0.04 and a=0.05): give each parameter once" in r.stderr


def test_a_broken_parameter_is_one_error_not_one_per_use():
    # 'zz' is unknown: each number using a was reported too (8 errors, 7 of them consequences)
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load(FB, a="zz")
    assert [d.format() for d in e.value.diagnostics] == [
        "mechanisms/four-bar.yaml:7: error: parameter override a=zz: parameter 'a': unknown name "
        "'zz' in expression 'zz'"]
    text = open(FB).read().replace("  a: 0.04 ", "  a: .nan ")
    with pytest.raises(planarkin.InputError) as e:
        planarkin.load(FB, text=text)
    assert [d.format() for d in e.value.diagnostics] == [
        "mechanisms/four-bar.yaml:7: error: parameter 'a': expression 'nan' is not finite (nan)"]


def test_cli_set_on_run_check_and_the_summary_records_it(tmp_path):
    r = run_cli("run", SC, "--out", tmp_path, "--no-plots", "--steps", "12", "--set", "a=0.08",
                "--set", "b = 0.2")
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "slider-crank" / "summary.json").read_text())
    assert s["overrides"] == {"a": 0.08, "b": 0.2}
    r = run_cli("check", FB, "--set", "aa=1")
    assert r.returncode == 2
    assert r.stderr == ("mechanisms/four-bar.yaml:7: error: --set aa: unknown parameter 'aa'; "
                        "did you mean 'a'?\n")
    r = run_cli("check", FB, "--set", "a")
    assert r.returncode == 2 and "'a': write NAME=VALUE" in r.stderr
    r = run_cli("run", SC, "--out", tmp_path, "--no-plots", "--steps", "12")
    assert "overrides" not in json.loads((tmp_path / "slider-crank" / "summary.json").read_text())
