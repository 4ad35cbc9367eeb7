"""What the figures show (issue 21 item 20): a sketch slider drawn as a block on its pin, forces.png
legends off the curves and equal curves named once, labels of a small crank apart; and every
kind says how it is drawn (its `draw` hook)."""

from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.output import plots

ROOT = Path(__file__).resolve().parents[1]

# A sketch slider-crank whose guide line is given by two reference pins far from the slider
# (P 0.6 m behind the crank pivot, Q 0.4 m past the slider's stroke).
SKETCH_SLIDER = """\
name: sketch-slider
points:
  O: {at: [0, 0], ground: true}
  A: {at: [0.1, 0]}
  B: {at: [0.4, 0]}
  P: {at: [-0.6, 0]}
  Q: {at: [0.8, 0]}
links:
  crank: [O, A]
  rod: [A, B]
  slider: [B]
sliders:
  piston: {link: slider, along: [P, Q]}
drivers:
  - {type: angle, link: crank, f: "2*pi*t"}
analysis: {steps: 72}
"""


def test_every_kind_has_its_own_draw_hook():
    from planarkin.elements import KINDS
    from planarkin.elements.base import Kind
    assert [n for n, k in KINDS.items() if type(k).draw is Kind.draw] == []


def test_a_one_pin_sketch_slider_is_a_block_on_its_pin_and_the_reference_pin_stays_out():
    """The translational joint's points are at the reference pin P (-0.6, 0): the slider was a
    bar 1 m long from B to P and P's path stretched the view to x = -0.9. Now the slider is
    the block about B and the view spans the crank circle and the stroke (x in -0.1..0.4)."""
    m = planarkin.load("sketch-slider.yaml", text=SKETCH_SLIDER)
    r = planarkin.solve(m)
    sc = plots.Scene(m, r._chunk)
    b = m.body_names.index("slider")
    assert sc.bars[b] is None and sc.fills[b] is not None and len(sc.fills[b]) == 4
    assert np.ptp(sc.fills[b], axis=0).max() <= 1.2 * sc.size + 1e-12
    assert np.abs(sc.fills[b].mean(axis=0)).max() < 1e-12          # about the pin B
    x0, x1, y0, y1 = sc.bounds
    assert -0.2 < x0 < -0.1 and 0.4 < x1 < 0.55, sc.bounds
    # no trace of the slider's axis point apart from B's own path
    B = r.point("B")
    far = [xy for xy in sc.traces if np.nanmax(np.abs(xy[:, 0] - B["x"])) > 1e-9]
    assert all(np.nanmin(xy[:, 0]) > -0.11 for xy in far)


@pytest.fixture(scope="module")
def slider_crank_forces():
    from planarkin.derived import derived_tables
    res = planarkin.solve(planarkin.load(ROOT / "mechanisms" / "slider-crank.yaml"), steps=120)
    d = derived_tables(res.model, res.info.options)[0]      # forces.csv (then loads.csv)
    return res, d.compute(res._chunk)


def _drawn(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    FigureCanvasAgg(fig).draw()
    return fig.canvas.get_renderer()


def test_forces_legends_stand_off_the_curves_and_equal_curves_are_named_once(
        slider_crank_forces):
    """slider-crank: the crank is balanced and massless in effect, so its main bearing and its
    crank pin carry the same force; that curve is drawn once, named "main-bearing =
    crank-pin" (the dashed crank-pin hid the main bearing's). No legend box meets an axes'
    box (they sat on the curves inside the axes)."""
    from planarkin.forces.plot import forces_figure
    res, X = slider_crank_forces
    fig = forces_figure(res.model, X, res.info)
    renderer = _drawn(fig)
    legends = fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    assert len(legends) == 2
    boxes = [ax.get_window_extent(renderer) for ax in fig.axes]
    for lg in legends:
        lb = lg.get_window_extent(renderer)
        assert not any(lb.overlaps(b) for b in boxes), (lb, boxes)
        assert lb.x1 <= fig.bbox.x1                          # inside the figure
    labels = [t.get_text() for t in legends[1].get_texts()]
    assert labels == ["main-bearing = crank-pin", "wrist-pin", "guide"]
    reaction_axes = [ax for ax in fig.axes if "reaction" in ax.get_ylabel()]
    assert all(len(ax.get_lines()) == 3 for ax in reaction_axes)


def test_same_curves_groups_only_equal_curves():
    from planarkin.forces.plot import same_curves
    t = np.linspace(0, 1, 50)
    a, b = np.sin(t), np.sin(t) + 1e-12
    groups = same_curves([("a", a), ("b", b), ("c", a + 1e-3), ("d", np.full(50, np.nan)),
                          ("e", np.full(50, np.nan))])
    assert [labels for labels, _ in groups] == [["a", "b"], ["c"], ["d", "e"]]


# A four-bar whose crank (6 mm) is small beside its 0.3 m frame: the crank's name and the names
# of its two pins meet in a few points of the page.
SMALL_CRANK = """\
name: small-crank
units: {length: m, angle: deg}
points:
  A: {at: [0, 0], ground: true}
  D: {at: [0.3, 0], ground: true}
  B: {at: [0.006, 0]}
  C: {at: [0.3, 0.2]}
  P: {at: [0.15, 0.25]}
links:
  crank: [A, B]
  coupler: [B, C, P]
  rocker: [D, C]
lengths: {A-B: 0.006, B-C: 0.36, D-C: 0.2, B-P: 0.29, C-P: 0.16}
drivers:
  - {type: angle, link: crank, f: "360*t"}
analysis: {start: 0, end: 1, steps: 72}
"""


def test_labels_of_a_small_crank_do_not_pile_up():
    """mechanism.png of the small crank: no two name labels (bodies and points) overlap, and no
    label covers a pin (the crank's name sat on its pins A and B, A's and B's on each other)."""
    m = planarkin.load("small-crank.yaml", text=SMALL_CRANK)
    r = planarkin.solve(m)
    sc = plots.Scene(m, r._chunk)
    fig = plots.mechanism_figure(m, sc)
    renderer = _drawn(fig)
    ax = fig.axes[0]
    names = set(m.body_names) | set(m.point_names)
    texts = [t for t in ax.texts if t.get_text() in names]
    assert sorted(t.get_text() for t in texts) == sorted(names)
    # the label's box (its white pad), not its leader line
    boxes = [t.get_bbox_patch().get_window_extent(renderer) for t in texts]
    for k, a in enumerate(boxes):
        for b in boxes[k + 1:]:
            assert not a.overlaps(b), (a, b)
    row = int(np.flatnonzero(np.isin(np.arange(len(sc.t)), sc.instants(4)))[0])
    pins = np.array([sc.at(b, s, row)[0] for b, s in sc.pins] + list(sc.pivots))
    px = ax.transData.transform(pins)
    r_px = 3.0 * fig.dpi / 72                 # the pin marker's radius (5.5 pt across)
    for t, box in zip(texts, boxes):
        for x, y in px:
            assert not (box.x0 < x + r_px and x - r_px < box.x1 and box.y0 < y + r_px
                        and y - r_px < box.y1), (t.get_text(), box, (x, y))


@pytest.mark.parametrize("example, body", [("cam-roller", "cam"), ("valve-cam", "cam"),
                                           ("planetary", "sun"),
                                           ("rack-pinion-steering", "pinion")])
def test_a_cam_or_a_disc_is_drawn_by_its_outline_not_as_a_slider_block(example, body):
    """A cam or a gear pinned at its frame origin has one attachment point; it was drawn as the
    small block of a lone slider, turning on its pivot, under its profile or pitch circle."""
    m = planarkin.load(ROOT / "mechanisms" / f"{example}.yaml")
    r = planarkin.solve(m, steps=12)
    sc = plots.Scene(m, r._chunk)
    b = m.body_names.index(body)
    assert sc.fills[b] is None and sc.bars[b] is None and sc.dashed[b]


def test_measures_png_leaves_the_callers_matplotlib_backend_alone(tmp_path):
    """measures.png switched the process to Agg (matplotlib.use) and drew through pyplot: an
    API caller with an interactive backend lost it. Now the object-oriented API only."""
    import matplotlib
    from planarkin.derived import derived_tables
    res = planarkin.solve(planarkin.load(ROOT / "mechanisms" / "four-bar-sketch.yaml"), steps=60)
    table = next(d for d in derived_tables(res.model, res.info.options)
                 if d.filename == "measures.csv")
    before = matplotlib.get_backend()
    matplotlib.use("svg")
    try:
        files = table.plot(res.model, table.compute(res._chunk), res.info, tmp_path, "png")
        assert matplotlib.get_backend() == "svg"
    finally:
        matplotlib.use(before)
    assert [f.name for f in files] == ["measures.png"] and files[0].stat().st_size > 10_000


def test_study_plots_leave_the_backend_alone_and_name_the_status(tmp_path):
    """sweep.png and tolerance.png switched the process to Agg through pyplot; a sweep without
    a metric plotted the status as the number 1.0 on a 0.96..1.04 axis."""
    import matplotlib
    from PIL import Image
    from planarkin.studies.plots import sweep_plot, tolerance_plot
    before = matplotlib.get_backend()
    matplotlib.use("svg")
    try:
        P = np.linspace(0.03, 0.05, 5)[:, None]
        sweep_plot(tmp_path / "sweep.png", ["a"], P, ["ok"] * 4 + ["failed"], [],
                   np.zeros((5, 0)), [P[:, 0]], "t")
        Y = np.random.default_rng(0).normal(size=(50, 1))
        tolerance_plot(tmp_path / "tolerance.png", ["y"], Y, [0.0], [1.0],
                       {5: [-1.6], 95: [1.6]}, "t")
        assert matplotlib.get_backend() == "svg"
    finally:
        matplotlib.use(before)
    for name in ("sweep.png", "tolerance.png"):
        with Image.open(tmp_path / name) as im:
            assert im.width > 400
