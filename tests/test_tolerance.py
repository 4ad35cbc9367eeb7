"""`planarkin tolerance`: exact sensitivities against finite differences of closed forms,
seeded reproducibility, and the first-order spread against the Monte-Carlo spread."""

import numpy as np
import pytest

import planarkin
from clitools import run_cli
from closedforms import slider_crank
from planarkin.model.yamlread import read_file, read_yaml
from planarkin.studies.sensitivity import sensitivities
from planarkin.studies.tolerance import draw, run_tolerance
from planarkin.studies.variants import Study
from test_sweep import four_bar_closed_form

FB = "mechanisms/four-bar.yaml"
SC = "mechanisms/slider-crank.yaml"


def _sens(path, wrt, steps, text=None, **overrides):
    root = read_yaml(text, path) if text is not None else read_file(path)
    cm = planarkin.load(path, text=text, **overrides)
    r = planarkin.solve(cm, steps=steps)
    texts = {k: (n.value if isinstance(n.value, str) else float(n.value))
             for k, n in root.value["parameters"].value.items()}
    texts.update(overrides)
    return r, sensitivities(cm, root, texts, wrt, r.t, r.q)


def test_four_bar_sensitivities_match_finite_differences_of_the_closed_form():
    r, (dq, dP) = _sens(FB, ["a", "b", "c", "d"], 36)
    theta2 = np.radians(360 * r.t)
    p0 = dict(a=0.04, b=0.12, c=0.10, d=0.10)
    rocker = r.model.body_names.index("rocker")
    P = r.model.point_names.index("P")
    for j, name in enumerate("abcd"):
        h = 1e-6 * p0[name]
        up = four_bar_closed_form(**{**p0, name: p0[name] + h}, theta2=theta2)
        dn = four_bar_closed_form(**{**p0, name: p0[name] - h}, theta2=theta2)
        fd = [(u - d) / (2 * h) for u, d in zip(up, dn)]
        got = [dq[:, 3 * rocker + 2, j], dP[:, P, 0, j], dP[:, P, 1, j]]
        for f, g in zip(fd, got):
            assert np.abs(g - f).max() <= 1e-7 * np.abs(f).max(), name


def test_chained_parameter_and_driver_function_sensitivities():
    # slider.x = a cos(phi) + sqrt(b^2 - a^2 sin^2 phi) with b = 3a and phi = w t
    text = (open(SC).read().replace("a: 0.1 ", "a: 0.1\n  w: 2*pi ")
            .replace('f: "2*pi*t"', 'f: "w*t"'))
    r, (dq, _) = _sens(SC, ["a", "w"], 24, text=text)
    t = r.t

    def x(a, w):
        return slider_crank(w * t, 0.0, 0.0, a, 3 * a)[3]

    s = r.model.body_names.index("slider")
    a, w = 0.1, 2 * np.pi
    for j, (fd) in enumerate(((x(a + 1e-7, w) - x(a - 1e-7, w)) / 2e-7,
                              (x(a, w + 1e-7) - x(a, w - 1e-7)) / 2e-7)):
        assert np.abs(dq[:, 3 * s, j] - fd).max() <= 1e-7 * np.abs(fd).max()


def test_parameters_reaching_a_direction_are_refused():
    text = open(SC).read().replace("a: 0.1 ", "a: 0.1\n  v: 1 ").replace(
        "vi: [1, 0], vj: [1, 0]", "vi: [v, 0], vj: [1, 0]")
    with pytest.raises(planarkin.InputError, match=r"joint 'guide' \(translational ground-slider\): "
                                                   r"parameters v reach its vi"):
        _sens(SC, ["v"], 4, text=text)


def test_seeded_tolerance_reproduces_itself_bit_for_bit(tmp_path):
    study = Study(SC, analysis={"steps": 12}, metrics=["max:slider.x", "dev:B"])
    r1 = run_tolerance(study, {"a": 1e-4, "b": 2e-4}, tmp_path / "1", 6, seed=5, plots=None)
    run_tolerance(study, {"a": 1e-4, "b": 2e-4}, tmp_path / "2", 6, seed=5, plots=None)
    for name in ("tolerance.csv", "samples.csv", "sensitivities.csv"):
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "2" / name).read_bytes()
    assert draw(["a"], {"a": 0.1}, {"a": 1e-4}, 6, 6, "normal") != r1.variants
    u = draw(["a"], {"a": 0.1}, {"a": 1.0}, 2000, 1, "uniform")
    assert max(abs(v["a"] - 0.1) for v in u) <= np.sqrt(3)
    assert np.std([v["a"] for v in u]) == pytest.approx(1.0, rel=0.05)


@pytest.mark.slow
def test_first_order_spread_matches_the_monte_carlo_spread(tmp_path):
    study = Study(FB, analysis={"steps": 24},
                  metrics=["max:rocker.phi", "stroke:rocker.phi", "max:P.y"])
    r = run_tolerance(study, {"a": 0.05e-3, "b": 0.05e-3, "d": 0.05e-3}, tmp_path, 60, seed=2,
                      plots=None)
    assert all(o.status == "ok" for o in r.outcomes)
    for st, fo in zip(r.stats, r.first_order_sd):
        # 60 samples: the sample standard deviation is within ~20 % of the true one (2 sigma)
        assert 0.75 < st["std"] / fo < 1.25


@pytest.mark.slow
def test_cli_tolerance(tmp_path):
    r = run_cli("tolerance", SC, "--sigma", "a=1e-4", "--samples", "4", "--steps", "12",
                "--metric", "max:slider.x", "--out", tmp_path, "--no-plots")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split() == ["output", "nominal", "mean", "std", "1st", "order", "p5", "p95"]
    assert lines[1].split()[:2] == ["max:slider.x", "[m]"] and lines[1].split()[5] == "0.0004"
    r = run_cli("tolerance", SC, "--sigma", "a=-1", "--out", tmp_path)
    assert r.returncode == 2 and "write NAME=SIGMA with SIGMA a number >= 0" in r.stderr


SKETCH = """\
name: sketch
units: {length: m, angle: deg}
parameters: {a: 0.04}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.1, 0], ground: true}
  B: {at: [a, 0]}
  C: {at: [0.10666666666666667, 0.09977753031397177]}
links:
  crank: [A, B]
  coupler: [B, C]
  rocker: [D, C]
drivers:
  - {type: angle, link: crank, f: "360*t"}
analysis: {start: 0, end: 1, steps: 12}
"""


def test_a_sketch_form_model_is_refused_at_its_links_line(tmp_path):
    """The sensitivities differentiate points s:, constants and driver functions; in the
    sketch form every point is a global placement (a traceback before)."""
    (tmp_path / "m.yaml").write_text(SKETCH)
    r = run_cli("tolerance", tmp_path / "m.yaml", "--sigma", "a=1e-3", "--samples", "4",
                "--out", tmp_path / "o")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.startswith(f"{tmp_path / 'm.yaml'}:9: error: first-order sensitivities "
                               f"need the body form"), r.stderr
