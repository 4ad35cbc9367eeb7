"""mechanism.png draws the fixed centrode of each floating body when output: {centres: true}
asks for instant centres, and only then (four-bar-sketch.yaml: the coupler's)."""

from pathlib import Path

import numpy as np

import planarkin
from planarkin.output import plots

EXAMPLE = Path(__file__).resolve().parents[1] / "mechanisms" / "four-bar-sketch.yaml"
LABEL = "fixed centrode\nof coupler"


def _figure(text):
    m = planarkin.load(EXAMPLE, text=text)
    r = planarkin.solve(m, steps=120)
    assert r.success
    return r, plots._Scene(m, r._chunk), plots._mechanism_figure(m, plots._Scene(m, r._chunk))


def _labels(fig):
    return [t.get_text() for lg in fig.legends for t in lg.get_texts()]


def test_centrode_drawn_when_centres_are_asked_and_lies_on_both_pivoted_links():
    r, scene, fig = _figure(EXAMPLE.read_text())
    assert [scene.names[j] for j, _ in scene.centrodes] == ["coupler"]   # crank, rocker: pinned
    assert _labels(fig).count(LABEL) == 1
    line = next(ln for ln in fig.axes[0].get_lines() if ln.get_label() == LABEL)
    x, y = (np.asarray(v, float) for v in line.get_data())
    fin = np.isfinite(x)
    assert 20 < fin.sum() < len(x)            # mostly drawn, cut where it runs off
    # Kennedy: the coupler's centre relative to ground is on line A-B (crank) and line D-C
    # (rocker), A and D the ground pivots
    A, D = np.array([0.0, 0.0]), np.array([0.1, 0.0])
    for pivot, pin in ((A, "B"), (D, "C")):
        p = r.point(pin)
        ux, uy = p["x"] - pivot[0], p["y"] - pivot[1]
        cross = ux * (y - pivot[1]) - uy * (x - pivot[0])
        assert np.nanmax(np.abs(cross[fin])) / 0.1 ** 2 < 1e-9
    # drawn within the mechanism's drawing: the centrode never widens it
    x0, x1, y0, y1 = scene.bounds
    m = 1e-12
    assert x[fin].min() >= x0 - m and x[fin].max() <= x1 + m
    assert y[fin].min() >= y0 - m and y[fin].max() <= y1 + m


def test_no_centrode_unless_asked():
    text = EXAMPLE.read_text().replace("output: {centres: true}", "output: {centres: false}")
    _, scene, fig = _figure(text)
    assert scene.centrodes == []
    assert not any("centrode" in s for s in _labels(fig))
    assert not any("centrode" in ln.get_label() for ln in fig.axes[0].get_lines())
