"""Every example model in mechanisms/ runs cleanly and exactly."""

from pathlib import Path

import numpy as np
import pytest

import planarkin

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "mechanisms").glob("*.yaml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(path):
    res = planarkin.solve(planarkin.load(path))
    assert res.status == 0, res.message
    assert len(res.t) == planarkin.load(path).spec.analysis.steps + 1
    assert res.residual.max() < 1e-12
    assert not [w for w in res.warnings if w.kind != "near-singular"]
    for arr in (res.q, res.qd, res.qdd):
        assert np.isfinite(arr).all()


def test_examples_exist():
    names = {p.name for p in EXAMPLES}
    for need in ("slider-crank.yaml", "four-bar.yaml", "quick-return.yaml", "six-bar.yaml",
                 "boom.yaml", "four-bar-placed.yaml"):
        assert need in names
