"""min_clearance as a study metric (sweep, tolerance) and the clearance constraint of a
synthesis (issue 29)."""

import math

import pytest

import planarkin
from planarkin.clearance.cycle import least_margin, minima
from planarkin.studies.variants import metric_values, parse_metrics

from test_clearance_cycle import MIRROR


def test_min_clearance_is_a_metric_refined_between_the_rows():
    cm = planarkin.load("mirror.yaml", text=MIRROR)
    res = planarkin.solve(cm, steps=100)
    metrics = parse_metrics(["min_clearance", "min_clearance:left|right", "max:left|right"],
                            cm, res.info.options, "mirror.yaml")
    assert [m.label for m in metrics] == ["min:clearance [m]", "min:left|right [m]",
                                          "max:left|right [m]"]
    lo, pair, hi = metric_values(metrics, cm, res.info.options, res)
    assert lo == pair == pytest.approx(0.3 - 0.2 - 0.02, rel=1e-9)
    assert lo == minima(cm, res)[0].d
    assert hi > lo


def test_the_synthesis_constraint_is_the_pair_nearest_its_limit():
    cm = planarkin.load("mirror.yaml", text=MIRROR.replace("analysis:",
                                                           "clearance: {min: 0.1}\nanalysis:"))
    res = planarkin.solve(cm, steps=100)
    value, pair = least_margin(cm, res)
    assert pair == "left|right"
    assert value == pytest.approx(0.08 - 0.1, rel=1e-9)
    assert math.isfinite(value)
