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
    return r, plots.Scene(m, r._chunk), plots.mechanism_figure(m, plots.Scene(m, r._chunk))


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


MOVING = "moving centrode\nof coupler"


def _moving_scene(steps):
    m = planarkin.load(EXAMPLE, text=EXAMPLE.read_text().replace(
        "output: {centres: true}", "output: {centres: moving}"))
    assert m.spec.output.centres and m.spec.output.moving_centrodes
    r = planarkin.solve(m, steps=steps)
    return m, r, plots.Scene(m, r._chunk)


def test_moving_centrode_rolls_on_the_fixed_one_without_slipping():
    # the centrodes' theorem: the body-fixed curve rolls on the ground-fixed one, so at every
    # instant they touch at the centre and their arc lengths grow at the same rate
    m, r, scene = _moving_scene(1440)
    (j, local), = scene.moving
    assert scene.names[j] == "coupler"
    from planarkin.measures.centres import compute, pairs
    k = [jj for ii, jj in pairs(m)].index(j)          # ground/coupler: i is ground
    I = compute(m, r._chunk)[:, 1 + 3 * k:3 + 3 * k]
    cx, cy = r.body("coupler")["x"], r.body("coupler")["y"]
    phi = np.radians(r.body("coupler")["phi"])
    # the body-fixed curve at each instant's own pose is that instant's centre
    gx = cx + np.cos(phi) * local[:, 0] - np.sin(phi) * local[:, 1]
    gy = cy + np.sin(phi) * local[:, 0] + np.cos(phi) * local[:, 1]
    fin = np.isfinite(I).all(axis=1)
    assert np.max(np.hypot(gx - I[:, 0], gy - I[:, 1])[fin]) < 1e-14
    # arc lengths over a stretch where the centre stays near the linkage (|I| < 0.3 m)
    near = fin & (np.hypot(I[:, 0], I[:, 1]) < 0.3)
    start = int(np.argmax(near))
    stop = start + int(np.argmin(near[start:]))
    assert stop - start > 100
    sl = slice(start, stop)
    s_fixed = np.sum(np.hypot(*np.diff(I[sl], axis=0).T))
    s_moving = np.sum(np.hypot(*np.diff(local[sl], axis=0).T))
    assert abs(s_fixed - s_moving) < 1e-6 * s_fixed        # O(h^2) of the chords: 1e-7


def test_mechanism_plot_draws_the_moving_centrode_at_the_first_instant():
    m, r, scene = _moving_scene(120)
    fig = plots.mechanism_figure(m, scene)
    labels = _labels(fig)
    assert labels.count(MOVING) == 1 and labels.count("instant centre\nof coupler") == 1
    lines = fig.axes[0].get_lines()
    curve = next(ln for ln in lines if ln.get_label() == MOVING)
    dot = next(ln for ln in lines if ln.get_label() == "instant centre\nof coupler")
    x, y = (np.asarray(v, float) for v in curve.get_data())
    # at t = 0 the crank lies on the ground line A-D, so the coupler's centre (on line A-B and
    # line D-C) is the pivot D; the curve drawn at the first pose passes through it
    assert np.allclose(np.asarray(dot.get_data(), float).ravel(), [0.1, 0.0], atol=1e-12)
    assert abs(x[0] - 0.1) < 1e-12 and abs(y[0]) < 1e-12
    x0, x1, y0, y1 = scene.bounds
    fin = np.isfinite(x)
    assert fin.sum() > 20
    assert x[fin].min() >= x0 and x[fin].max() <= x1 and y[fin].min() >= y0 and y[fin].max() <= y1


def test_centres_fixed_is_true_and_draws_no_moving_centrode():
    m = planarkin.load(EXAMPLE, text=EXAMPLE.read_text().replace(
        "output: {centres: true}", "output: {centres: fixed}"))
    assert m.spec.output.centres and not m.spec.output.moving_centrodes
    r = planarkin.solve(m, steps=24)
    scene = plots.Scene(m, r._chunk)
    assert scene.moving == [] and scene.centrodes
