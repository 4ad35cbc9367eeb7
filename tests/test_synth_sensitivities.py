"""The sensitivities synth and fit use (planarkin.studies.sensitivity), per element kind and per
way a parameter enters, against central differences of the solved grid: dq/dp of every body
coordinate and dP/dp of every point at every grid time. Kinds whose parameters are not
differentiated are refused by name (never a silently zero derivative)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.model.yamlread import read_yaml
from planarkin.studies.sensitivity import sensitivities

ROOT = Path(__file__).resolve().parents[1]
M = ROOT / "mechanisms"


def _text(name, *subs):
    text = (M / name).read_text()
    for old, new in subs:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def _solve(path, text, values, steps):
    cm = planarkin.load(path, text=text, **values)
    res = planarkin.solve(cm, steps=steps)
    assert res.status == 0, res.message
    return cm, res


def _check(name, text, param, steps=12, rel=1e-6):
    root = read_yaml(text, name)
    cm, res = _solve(name, text, {}, steps)
    texts = {k: (n.value if isinstance(n.value, str) else float(n.value))
             for k, n in root.value["parameters"].value.items()}
    dq, dP = sensitivities(cm, root, texts, [param], res.t, res.q)
    p0 = cm.spec.parameters[param]
    h = rel * max(1.0, abs(p0))
    _, up = _solve(name, text, {param: p0 + h}, steps)
    _, dn = _solve(name, text, {param: p0 - h}, steps)
    fq = (up.q - dn.q) / (2 * h)
    fP = (up.p - dn.p) / (2 * h)
    assert np.abs(fq).max() > 1e-3, "the parameter moves nothing: the check would be empty"
    assert np.abs(dq[..., 0] - fq).max() <= 1e-6 * np.abs(fq).max()
    if fP.size:
        assert np.abs(dP[..., 0] - fP).max() <= 1e-6 * max(np.abs(fP).max(), 1e-12)


CASES = [
    # (id, model file, substitutions, parameter)
    ("revolute si (ground pivot)", "four-bar.yaml", (), "d"),
    ("revolute si (moving body)", "four-bar.yaml", (), "a"),
    ("revolute sj", "four-bar.yaml", (), "c"),
    ("translational si (offset guide)", "slider-crank.yaml",
     (("b: 3*a ", "b: 3*a\n  e: 0.02 "),
      ("guide, i: ground, j: slider, si: [0, 0]", "guide, i: ground, j: slider, si: [0, e]")),
     "e"),
    ("an expression of another parameter (b = 3a)", "slider-crank.yaml", (), "a"),
    ("angle joint constant c", "synthesis/five-point-curve.yaml", (), "th0"),
    ("angle driver relative to a body, ground pivot", "synthesis/five-point-curve.yaml", (),
     "x0"),
    ("distance driver f", "boom.yaml", (), "L0"),
    ("distance driver f, its rate", "boom.yaml", (), "v"),
    ("x driver f and revolute sj", "trammel.yaml", (), "L"),
    ("curve-slot sj", "curved-slot.yaml", (), "b"),
]


@pytest.mark.parametrize("name,subs,param", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_sensitivities_match_central_differences(name, subs, param):
    _check(name, _text(name, *subs), param)


@pytest.mark.parametrize("name,param,what", [
    ("planetary.yaml", "Rs", "its ri"),
    ("cam-roller.yaml", "rb", "its base"),
    ("cam-roller.yaml", "beta", "its range"),     # (the law, of the cam's theta, read too)
    ("curved-slot.yaml", "R", "its curve"),
])
def test_parameters_not_differentiated_are_refused_by_name(name, param, what):
    text = (M / name).read_text()
    root = read_yaml(text, name)
    cm, res = _solve(name, text, {}, 8)
    texts = {k: (n.value if isinstance(n.value, str) else float(n.value))
             for k, n in root.value["parameters"].value.items()}
    with pytest.raises(planarkin.InputError, match=f"parameters {param} reach {what}"):
        sensitivities(cm, root, texts, [param], res.t, res.q)


_SAME_BITS = """
import hashlib, sys
import numpy as np
from planarkin.functions.expr import ExprError, evaluate_constant
from planarkin.studies.sensitivity import ParameterDerivatives
from planarkin.synthesis.synth import Synthesis
syn = Synthesis(sys.argv[1])
m = syn.model
rng = np.random.default_rng(0)
h = hashlib.sha256()
for _ in range(100):
    texts = m.study.texts()
    texts.update(m.values(syn.lo + (syn.hi - syn.lo) * rng.random(len(syn.lo))))
    ps = {}
    try:
        for k, t in texts.items():
            ps[k] = evaluate_constant(t, ps)
    except ExprError:               # a design the file refuses (ph3's acos)
        continue
    D = ParameterDerivatives(m.study.root, ps, texts, m.free)
    for k in D.order:
        h.update(D.dparam[k].tobytes())
    h.update(D.function(m.study.root.value["drivers"].value[0].value["f"],
                        np.linspace(0.0, 1.0, 7)).tobytes())
print(h.hexdigest())
"""


def test_parameter_derivatives_are_the_same_bits_in_every_process():
    """The chain rule sums a parameter's terms in the file's order: in a set's order (which
    follows each process's string hashes, PYTHONHASHSEED) the straight line's e, ph3 and ph4
    differed by up to 3.6e-15 between processes, and with them any Jacobian they reach."""
    import os
    import subprocess
    import sys
    line = str(ROOT / "mechanisms" / "synthesis" / "straight-line.yaml")
    got = {subprocess.run([sys.executable, "-c", _SAME_BITS, line], capture_output=True,
                          text=True, check=True, cwd=ROOT,
                          env={**os.environ, "PYTHONHASHSEED": seed}).stdout
           for seed in ("1", "2", "3")}
    assert len(got) == 1, got
