"""A design's compiled model made from the nominal's arrays (studies.batch.Batch.design): the
numbers the file validated and compiled with the design's values gives, bit for bit, or None
where the validator would refuse the design (Study.model then words the refusal)."""

import numpy as np
import pytest

from planarkin.diagnostics import InputError
from planarkin.studies.batch import Batch
from planarkin.studies.variants import Study
from planarkin.synthesis.synth import Synthesis

ARRAYS = ("q0", "targets", "point_s", "driver_scale", "driver_rows", "row_element")


def assert_same_model(d, ref):
    """Every number a solve, a sensitivity or a check reads from a compiled model."""
    assert d.L == ref.L and d.angle_factor == ref.angle_factor
    for name in ARRAYS:
        a, b = getattr(d, name), getattr(ref, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert len(d.groups) == len(ref.groups)
    for g, h in zip(d.groups, ref.groups):
        assert g.kind is h.kind and np.array_equal(g.rows, h.rows)
        assert g.params.keys() == h.params.keys()
        for k in g.params:
            assert np.array_equal(g.params[k], h.params[k]), (g.kind.name, k)
    assert d.spec.parameters == ref.spec.parameters
    assert list(d.spec.parameters) == list(ref.spec.parameters)
    assert d.spec.overrides == ref.spec.overrides
    t = np.linspace(-0.3, 1.7, 23)
    for f, g in zip(d.driver_funcs, ref.driver_funcs):
        assert f.text == g.text
        for a, b in zip(f.derivatives(t), g.derivatives(t)):
            assert np.array_equal(np.broadcast_to(a, t.shape), np.broadcast_to(b, t.shape))
    assert [e.f for e in d.spec.drivers] == list(d.driver_funcs)


@pytest.mark.parametrize("name", ["five-point-curve", "straight-line", "four-bar-offset",
                                  "six-bar-output"])
def test_a_design_from_the_arrays_is_the_compiled_file_bit_for_bit(name):
    syn = Synthesis(f"mechanisms/synthesis/{name}.yaml")
    m = syn.model
    B = Batch(m.study, m.free, nominal=False)
    rng = np.random.default_rng(7)
    made = refused = rescaled = 0
    for _ in range(60):
        values = m.values(syn.lo + (syn.hi - syn.lo) * rng.random(len(syn.lo)))
        d = B.design(values)
        try:
            ref = m.study.model(values)
        except InputError:
            assert d is None            # never accepted where the validator refuses
            refused += 1
            continue
        assert d is not None
        assert_same_model(d, ref)
        made += 1
        rescaled += d.L != B.cm.L
    assert made >= 20
    if name in ("five-point-curve", "straight-line"):
        # other length scales than the nominal's (the arrays rescaled), and designs whose
        # drawn pose is impossible (acos out of its domain)
        assert rescaled >= 5 and refused >= 5


ROD = """name: rod
units: {length: mm, angle: deg}
parameters:
  a: 10
  l: 2*a + 5
  th: 30
bodies:
  crank: {q: [0, 0, th]}
  slider: {q: [a + l, 0, 0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: distance, i: crank, j: slider, si: [a, 0], sj: [0, 0], c: l - 10}
  - {type: y, i: ground, j: slider, si: [0, 0], sj: [0, 0], c: 0}
  - {type: angle, i: ground, j: slider, c: th - 30}
drivers:
  - {type: angle, body: crank, f: "th + 360*t"}
points:
  P: {body: slider, s: [a/2, sqrt(a)]}
analysis: {start: 0, end: 1, steps: 36}
"""


def test_refusals_and_every_place_a_parameter_reaches(tmp_path):
    path = tmp_path / "rod.yaml"
    path.write_text(ROD)
    s = Study(str(path))
    B = Batch(s, ["a", "th"], nominal=False)
    for values in ({"a": 20.0, "th": 10.0}, {"a": 40.0, "th": -75.5}, {"a": 8.0, "th": 1e3}):
        assert_same_model(B.design(values), s.model(values))
    # the distance's constant l - 10 = 2 a - 5 must be positive; sqrt(a) needs a >= 0; a
    # number over 1e100 is refused (a + l = 3 a + 5 for a = 4e99): the validator's messages, the arrays' None
    for values in ({"a": 2.0, "th": 0.0}, {"a": -1.0, "th": 0.0}, {"a": 1e101, "th": 0.0}, {"a": 4e99, "th": 0.0},
                   {"a": float("nan"), "th": 0.0}):
        assert B.design(values) is None
        with pytest.raises(InputError):
            s.model(values)


def test_a_kind_that_prepares_numbers_takes_the_file_when_the_length_scale_moves():
    # the quick-return's translational joint prepares its constants at compile time (in
    # internal units): at the nominal's length scale (0.5 m) the arrays serve, at another one
    # (r = 6.4 m: 8 m) the design is left to Study.model
    s = Study("mechanisms/quick-return.yaml")
    B = Batch(s, ["r"], nominal=False)
    for r in (0.101, 0.3):
        assert_same_model(B.design({"r": r}), s.model({"r": r}))
    assert B.design({"r": 6.4}) is None
    assert s.model({"r": 6.4}).L == 8.0
