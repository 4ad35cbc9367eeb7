"""A design's compiled model made from the nominal's arrays (studies.batch.Batch.design): the
numbers the file validated and compiled with the design's values gives, bit for bit, or None
where the validator would refuse the design (Study.model then words the refusal)."""

import numpy as np
import pytest

from planarkin.diagnostics import InputError
from planarkin.studies import batch as batchmod
from planarkin.studies.batch import Batch
from planarkin.studies.design import REFUSED
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
    made = refused = rescaled = said = 0
    for _ in range(60):
        values = m.values(syn.lo + (syn.hi - syn.lo) * rng.random(len(syn.lo)))
        d = B.design(values)
        try:
            ref = m.study.model(values)
        except InputError:
            assert d is None or d is REFUSED    # never accepted where the validator refuses
            refused += 1
            said += d is REFUSED
            continue
        assert d is not None and d is not REFUSED   # REFUSED only where the validator refuses
        assert_same_model(d, ref)
        made += 1
        rescaled += d.L != B.cm.L
    assert made >= 20
    if name in ("five-point-curve", "straight-line"):
        # other length scales than the nominal's (the arrays rescaled), and designs whose
        # drawn pose is impossible (acos out of its domain)
        assert rescaled >= 5 and refused >= 5
        # the arrays say so themselves (a local trial then skips validating the file)
        assert said == refused


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
        assert B.design(values) is REFUSED
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


# the review's cases (2026-12-07): each once accepted from the arrays, or given other numbers
FB = """name: fb
units: {length: m, angle: deg}
parameters:
  a: 0.04
  b: 0.12
  ph: 55
  tj: 2
  s: 1
  k: 0.1
bodies:
  crank:   {q: [0, 0, 0]}
  coupler: {q: [a, 0, ph]}
  rocker:  {q: [0.1, 0, 85]}
joints:
  - {type: revolute, i: ground, j: crank,   si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank,  j: coupler, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [b, 0], sj: [k, 0]}
  - {type: revolute, i: ground, j: rocker,  si: [0.1*s, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: crank, f: "360*t"}
points:
  P: {body: coupler, s: [0.06, 0.045]}
analysis: {start: 0, end: 1, steps: 36}
"""


def _refused(B, s, values, said=True):
    """Refused by the validator; from the arrays REFUSED (said: one of the validator's checks
    failed there) or None (the arrays do not hold what the validator checks)."""
    assert B.design(values) is (REFUSED if said else None)
    with pytest.raises(InputError):
        s.model(values)


def test_a_point_placed_at_on_a_body_whose_pose_varies_is_not_taken(tmp_path):
    # its body-frame offset comes from the body's drawn pose: Batch does not take the study
    path = tmp_path / "fb.yaml"
    path.write_text(FB.replace("P: {body: coupler, s: [0.06, 0.045]}",
                               "P: {body: coupler, at: [0.0566, 0.0848]}"))
    with pytest.raises(batchmod.Unsupported, match="pose of the body it is placed on"):
        Batch(Study(str(path)), ["a"], nominal=False)


def test_a_driver_function_the_validator_refuses_is_refused(tmp_path):
    path = tmp_path / "fb.yaml"
    path.write_text(FB.replace('f: "360*t"', 'f: "360*t + 1e-7*floor(t/tj)"'))
    s = Study(str(path), analysis={"steps": 360}, metrics=["max:rocker.phi"])
    _refused(Batch(s, ["tj"], nominal=False), s, {"tj": 0.5})       # a jump at t = 0.5
    assert_same_model(Batch(s, ["tj"], nominal=False).design({"tj": 3.0}), s.model({"tj": 3.0}))
    # a study's variant too: left to the per-variant path, which says why
    B = Batch(s, ["tj"])
    assert list(B.numbers([{"tj": 2.0}, {"tj": 0.5}])[4]) == [True, False]
    out = s.run([{"tj": 2.0}, {"tj": 0.5}])
    assert [o.status for o in out] == ["ok", "invalid"] and "jumps" in out[1].message


def test_design_bounds_written_with_a_free_parameter_are_the_validators(tmp_path):
    path = tmp_path / "fb.yaml"
    path.write_text(FB + "design:\n  free:\n    a: [0.02, 0.06]\n    b: [a + 0.05, 0.1]\n"
                         "  targets:\n    - path: P\n      points: [[0.1, 0.1], [0.05, 0.1]]\n")
    s = Study(str(path))
    # the bounds are not in the arrays: the validator judges (Batch.elsewhere)
    _refused(Batch(s, ["a", "b"], nominal=False), s, {"a": 0.055, "b": 0.1}, said=False)


def test_an_override_written_with_a_free_parameter_is_the_designs(tmp_path):
    path = tmp_path / "fb.yaml"
    path.write_text(FB)
    s = Study(str(path), {"b": "3*a"})
    d = Batch(s, ["a"], nominal=False).design({"a": 0.041})
    assert d.spec.overrides["b"] == 3 * 0.041
    assert_same_model(d, s.model({"a": 0.041}))


def test_a_free_parameter_that_a_simplification_drops_is_not_batched(tmp_path):
    # k = 0*sqrt(a) + 0.1 simplifies to 0.1, yet a < 0 makes the file invalid
    path = tmp_path / "fb.yaml"
    path.write_text(FB.replace("k: 0.1", "k: 0*sqrt(a) + 0.1"))
    with pytest.raises(batchmod.Unsupported, match="simplification drops"):
        Batch(Study(str(path)), ["a"], nominal=False)


def test_length_scales_a_power_of_two_cannot_bridge_take_the_file(tmp_path):
    scaled = FB.replace("q: [a, 0, ph]", "q: [a*s, 0, ph]").replace("q: [0.1, 0, 85]",
                                                                   "q: [0.1*s, 0, 85]")
    for old in ("si: [a, 0]", "si: [b, 0], sj: [k, 0]", "[0.06, 0.045]"):
        scaled = scaled.replace(old, old.replace("a,", "a*s,").replace("b,", "b*s,")
                                .replace("k,", "k*s,").replace("0.06,", "0.06*s,")
                                .replace("0.045]", "0.045*s]"))
    path = tmp_path / "fb.yaml"
    path.write_text(scaled.replace("s: 1\n", "s: 1e90\n"))
    s = Study(str(path))
    B = Batch(s, ["s"], nominal=False)
    assert B.design({"s": 1e-250}) is None          # L / L' overflows
    assert_same_model(B.design({"s": 2e90}), s.model({"s": 2e90}))
    # a length subnormal in internal units (1.2345e-305 / 2**14) is not rescaled exactly
    path.write_text(FB.replace("sj: [k, 0]", "sj: [k, 1.2345e-305]").replace(
        "P: {body: coupler, s: [0.06, 0.045]}", "P: {body: coupler, s: [0.06, 0.045]}\n"
                                                "  F: {body: coupler, s: [s, 0]}").replace(
        "s: 1\n", "s: 1e4\n").replace("[0.1*s, 0]", "[0.1, 0]"))
    s = Study(str(path))
    B = Batch(s, ["s"], nominal=False)
    assert B.design({"s": 1.01e4}) is not None and B.design({"s": 1.01}) is None
