"""assembly: the start pose, its degrees of freedom and the message when it cannot be analysed."""

import pytest

import planarkin
from planarkin.solver import assembly
from planarkin.diagnostics import InputError

from clitools import ROOT

FOLDED = ROOT / "tests" / "cases" / "four-bar-folded.yaml"

# a parallelogram four-bar with a third parallel link: one joint equation repeats the others at
# every pose (a structural redundancy, not a singular pose); without a driver it is free to move
DOUBLE_PARALLELOGRAM = """\
name: double-parallelogram
parameters: {a: 0.1, d: 0.3, e: 0.15}
bodies:
  crank:   {q: [0, 0, 1.0]}
  coupler: {q: [0.054, 0.084, 0]}
  rocker:  {q: [0.3, 0, 1.0]}
  link:    {q: [0.15, 0, 1.0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: coupler, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [d, 0], sj: [a, 0]}
  - {type: revolute, i: ground, j: rocker, si: [d, 0], sj: [0, 0]}
  - {type: revolute, i: ground, j: link, si: [e, 0], sj: [0, 0]}
  - {type: revolute, i: link, j: coupler, si: [a, 0], sj: [e, 0]}
drivers: []
analysis: {start: 0, end: 1, steps: 10}
"""


def _message(path=None, text=None) -> str:
    model = planarkin.load(path or "double-parallelogram.yaml", text=text)
    with pytest.raises(InputError) as e:
        assembly.assemble(model)
    return str(e.value)


@pytest.mark.parametrize("rank_tol", [assembly.RANK_TOL, 1e-7, 1e-6])
def test_a_start_folded_flat_is_a_change_point_whatever_side_of_the_rank_tolerance(
        monkeypatch, rank_tol):
    # At the folded start the joints' smallest singular value is ~4e-8 here: which side of
    # RANK_TOL (1e-8) it falls on depends on the BLAS, the processor and the assembly's last
    # steps. The tolerances above it put it on the other side, as another machine did ("2
    # degrees of freedom but 1 driver ... add 1 driver", the wrong fix).
    monkeypatch.setattr(assembly, "RANK_TOL", rank_tol)
    msg = _message(FOLDED)
    assert "dead point or a change point" in msg
    assert "joints leave 1 degree of freedom and 1 driver is given" in msg
    assert "add 1 driver" not in msg


@pytest.mark.parametrize("rank_tol", [assembly.RANK_TOL, 1e-7])
def test_a_joint_that_repeats_the_others_everywhere_still_asks_for_a_driver(
        monkeypatch, rank_tol):
    monkeypatch.setattr(assembly, "RANK_TOL", rank_tol)
    msg = _message(text=DOUBLE_PARALLELOGRAM)
    assert "the mechanism has 1 degree of freedom but 0 drivers" in msg
    assert "add 1 driver" in msg
    assert "dead point" not in msg
