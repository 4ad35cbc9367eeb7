"""Plots and animation (planarkin.output.plots): files, formats, failed and partial runs, and the
geometry of the mechanism drawing."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.output import plots
from planarkin.solver.grid import Event

ROOT = Path(__file__).resolve().parents[1]
SLIDER_CRANK = ROOT / "mechanisms" / "slider-crank.yaml"

# The slider-crank driven by its slider: the crank reaches dead centre (x = a + b) at t = 0.5 s.
SLIDER_DRIVEN = """\
name: slider-driven
units: {length: m, angle: rad}
parameters: {a: 0.1, b: 0.3}
bodies:
  crank:  {q: [0.05, 0.0, 0.8]}
  rod:    {q: [0.2, 0.02, -0.2]}
  slider: {q: [0.32, 0.0, 0.0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: rod, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: rod, j: slider, si: [b, 0], sj: [0, 0]}
  - {type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: x, body: slider, f: "0.32 + 0.16*t"}
analysis: {start: 0, end: 1, steps: 100}
"""

MAGIC = {"png": b"\x89PNG\r\n\x1a\n", "pdf": b"%PDF-", "gif": b"GIF89a"}


@pytest.fixture(scope="module")
def model():
    return planarkin.load(SLIDER_CRANK)


@pytest.fixture(scope="module")
def result(model):
    return planarkin.solve(model, steps=180)


@pytest.fixture(scope="module")
def written(result, tmp_path_factory):
    """The slider-crank written the way `planarkin run` writes it (DirectoryWriter.finish)."""
    out = tmp_path_factory.mktemp("slider-crank")
    return out, result.write(out, plots="png")


def check_file(path: Path, fmt: str, min_bytes=10_000):
    data = path.read_bytes()
    assert len(data) > min_bytes, path
    if fmt == "svg":
        assert data.startswith(b"<?xml") and b"<svg" in data[:2000]
    else:
        assert data.startswith(MAGIC[fmt]), path


def test_png_plots_from_result_write(written):
    from PIL import Image
    out, summary = written
    names = ["bodies.png", "points.png", "trajectories.png", "mechanism.png"]
    assert summary["plots"] == names + ["forces.png"]      # the example has masses
    for name in names:
        check_file(out / name, "png")
        with Image.open(out / name) as im:
            assert round(im.info["dpi"][0]) == 150
            assert 1000 <= im.width <= 1600 and 500 <= im.height <= 1500   # 7 to 10 in wide


@pytest.fixture(scope="module")
def positions(model):
    """A run that computed positions only (order 0): no velocities, no accelerations."""
    return planarkin.solve(model, steps=60, up_to="position")


@pytest.mark.parametrize("fmt", ["svg", "pdf"])
def test_vector_formats(model, positions, tmp_path, fmt):
    files = plots.write_plots(model, positions._chunk, positions.info, tmp_path, fmt=fmt)
    assert [f.name for f in files] == [f"{n}.{fmt}" for n in
                                       ("bodies", "points", "trajectories", "mechanism")]
    for f in files:
        check_file(f, fmt)


def test_failed_run_marks_the_stopping_time(tmp_path):
    model = planarkin.load("slider-driven.yaml", text=SLIDER_DRIVEN)
    res = planarkin.solve(model)
    assert res.status == 1 and res.event.kind == "lock-up"
    t_stop = res.event.t
    assert res.t[-1] < t_stop
    files = plots.write_plots(model, res._chunk, res.info, tmp_path)
    for f in files:
        check_file(f, "png")

    fig = plots.bodies_figure(model, res._chunk, res.info)
    axes = fig.axes
    assert len(axes) == 6
    for ax in axes:
        stops = [ln for ln in ax.get_lines() if ln.get_color() == "red"
                 and ln.get_linestyle() == "--" and np.allclose(ln.get_xdata(), t_stop)]
        assert len(stops) == 1
        assert ax.get_xlim() == (0.0, 1.0)          # the planned range: the stop is visible
    labels = [t.get_text() for ax in axes for t in ax.texts]
    assert labels.count("singular (lock-up)") == 2    # once per column, top row
    assert "run stopped at t = 0.5 s (lock-up)" in fig._suptitle.get_text()


def test_near_singular_warnings_are_thin_orange_lines(model, result):
    warn = [Event("near-singular", 0.25, "passed"), Event("near-singular", 0.75, "passed")]
    info = dataclasses.replace(result.info, warnings=warn)
    fig = plots.bodies_figure(model, result._chunk, info)
    for ax in fig.axes:
        orange = sorted(float(ln.get_xdata()[0]) for ln in ax.get_lines()
                        if ln.get_color() == "tab:orange")
        assert orange == [0.25, 0.75]
        assert not any(ln.get_color() == "red" for ln in ax.get_lines())


def test_positions_only(model, positions, tmp_path):
    res = positions
    assert res.qd is None and res.qdd is None and res.pd is None and res.pdd is None
    files = plots.write_plots(model, res._chunk, res.info, tmp_path)
    assert [f.name for f in files] == ["bodies.png", "points.png", "trajectories.png",
                                       "mechanism.png"]
    fig = plots.bodies_figure(model, res._chunk, res.info)
    assert [ax.get_ylabel() for ax in fig.axes] == ["x, y [m]", "phi [rad]"]


def test_model_without_points_skips_points_and_trajectories(tmp_path):
    text = SLIDER_CRANK.read_text()
    start = text.index("points:")
    text = text[:start] + text[text.index("analysis:", start):]
    model = planarkin.load("no-points.yaml", text=text)
    assert model.point_names == ()
    res = planarkin.solve(model, steps=60)
    files = plots.write_plots(model, res._chunk, res.info, tmp_path)
    assert [f.name for f in files] == ["bodies.png", "mechanism.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bodies.png", "mechanism.png"]


def test_drawing_closes_the_slider_crank_loop(model, result):
    """The drawing is built from the joints: crank and rod are bars between their pins, the
    slider a block on a ground axis along x, one ground pivot; drawn at any instant the crank
    tip meets the rod, the rod's end meets the slider and point B."""
    sc = plots.Scene(model, result._chunk)
    crank, rod, slider = range(3)
    a, b = 0.1, 0.3
    assert np.allclose(sc.bars[crank], [[0, 0], [a, 0]])
    assert np.allclose(sc.bars[rod], [[0, 0], [b, 0]])
    assert sc.bars[slider] is None and len(sc.fills[slider]) == 4
    assert np.allclose(sc.pivots, [[0, 0]])
    (axis,) = sc.axes
    assert np.allclose(axis[:, 1], 0) and axis[0, 0] < 0.2 and axis[1, 0] > 0.4
    for i in (0, 40, 97, len(result.t) - 1):
        tip = sc.at(crank, sc.bars[crank], i)[1]
        rod_ends = sc.at(rod, sc.bars[rod], i)
        assert np.allclose(tip, rod_ends[0])
        assert np.allclose(rod_ends[1], sc.at(slider, [0, 0], i)[0])
        assert np.allclose(rod_ends[1], result.p[i, 0])
        assert np.allclose(sc.fills[slider].mean(axis=0), 0)       # block centred on the pin
    assert sc.closed                                  # one full crank turn
    assert list(sc.instants(6)) == [0, 30, 60, 90, 120, 150]


def test_constant_quantity_is_drawn_on_the_model_scale():
    """A slider's y of rounding noise (1e-17 m) gets the model's scale, not a 1e-17 axis."""
    from matplotlib.figure import Figure
    ax = Figure().add_subplot()
    noise = np.array([1e-17, -2e-17, 0.0, 3e-17])
    ax.plot(np.arange(4), noise)
    plots.tidy_ylim(ax, noise, ref=0.5)
    assert ax.get_ylim() == pytest.approx((-0.05, 0.05))
    ax.plot(np.arange(4), [0.0, 0.2, 0.1, 0.0])        # a real motion keeps automatic limits
    lim = ax.get_ylim()
    plots.tidy_ylim(ax, [0.0, 0.2, 0.1, 0.0], ref=0.5)
    assert ax.get_ylim() == lim


@pytest.mark.slow
def test_animation_gif(model, result, tmp_path):
    from PIL import Image
    path = plots.write_animation(model, result._chunk, tmp_path)
    assert path == tmp_path / "animation.gif"
    check_file(path, "gif")
    assert path.stat().st_size < 3_000_000
    with Image.open(path) as im:
        assert im.n_frames > 10
        assert im.info["duration"] == 50           # 20 frames per second
        assert im.width == 640
        im.seek(im.n_frames - 1)                   # every frame decodes
    path = plots.write_animation(model, result._chunk, tmp_path, fps=10, width=480)
    with Image.open(path) as im:
        assert im.info["duration"] == 100 and im.width == 480


def _legend_labels(fig):
    return [t.get_text() for lg in fig.legends for t in lg.get_texts() if t.get_text().strip()]


def test_bodies_figure_skips_constant_curves_and_names_each_body_once(model, result):
    """Slider-crank: the crank's frame is pinned at the origin (x, y constant), the slider's
    y and phi are 0, the crank turns at 2 pi rad/s: those curves are not drawn but named with
    their values; every body appears once in the legend, with the line styles."""
    fig = plots.bodies_figure(model, result._chunk, result.info)
    labels = _legend_labels(fig)
    assert labels == ["x, phi", "y", "crank", "rod", "slider"]
    assert len(labels) == len(set(labels))
    (note,) = [t.get_text().replace("\n", " ") for t in fig.texts
               if t.get_text().startswith("constant")]
    for item in ("crank.x = 0 m", "crank.y = 0 m", "slider.y = 0 m", "slider.phi = 0 rad",
                 "crank.omega = 6.283 rad/s", "crank.alpha = 0 rad/s²"):
        assert item in note
    assert "crank.vx" not in note            # derivatives of a constant are not repeated
    x_pos, phi_pos, x_vel, phi_vel = (len(fig.axes[k].get_lines()) for k in (0, 1, 2, 3))
    assert x_pos == 3                        # rod.x, rod.y, slider.x (not crank, not slider.y)
    assert phi_pos == 2 and phi_vel == 1     # crank.phi, rod.phi; rod.omega
    assert fig.axes[0].get_ylabel() == "x, y [m]" and fig.axes[3].get_ylabel() == "omega [rad/s]"


def test_identical_curves_are_drawn_once():
    from matplotlib.figure import Figure
    ax = Figure().add_subplot()
    t = np.linspace(0, 1, 11)
    a, b = np.sin(t), np.sin(t) * (1 + 1e-13)
    sel = plots.Selection()
    sel.draw(ax, t, [(a, "C0", "-", "p.x", (0, 0)), (b, "C1", "-", "q.x", (1, 0)),
                     (np.full(11, 2.0), "C2", "-", "r.x", (2, 0))], 1.0, "m", 0)
    assert len(ax.get_lines()) == 1
    assert sel.note() == "constant, not drawn: r.x = 2 m; equal to a curve drawn: q.x = p.x"
    ax = Figure().add_subplot()                # all constant: drawn all the same
    sel = plots.Selection()
    sel.draw(ax, t, [(np.zeros(11), "C0", "-", "p.x", (0, 0)),
                     (np.ones(11), "C1", "-", "q.x", (1, 0))], 1.0, "m", 0)
    assert len(ax.get_lines()) == 2 and sel.note() == ""


def test_cli_draws_the_plots_in_process(tmp_path):
    """planarkin run with plots: the figures are drawn in the process, after the tables, no
    process is started, and summary.json says how long the drawing took."""
    import json
    import multiprocessing as mp
    from click.testing import CliRunner
    from planarkin.cli import main
    runner = CliRunner()
    r = runner.invoke(main, ["run", str(SLIDER_CRANK), str(ROOT / "mechanisms" / "four-bar.yaml"),
                             "--out", str(tmp_path), "--steps", "60", "-q"])
    assert r.exit_code == 0, r.output
    assert not mp.active_children()
    for stem in ("slider-crank", "four-bar"):
        s = json.loads((tmp_path / stem / "summary.json").read_text())
        forces = ["forces.png"] if stem == "slider-crank" else []      # it has masses
        assert s["plots"] == ["bodies.png", "points.png", "trajectories.png",
                              "mechanism.png"] + forces
        assert s["wall_time"]["plots"] > 0
        for name in s["plots"]:
            check_file(tmp_path / stem / name, "png")


def test_figure_names():
    assert plots.figure_names(planarkin.load(SLIDER_CRANK)) == [
        "bodies", "points", "trajectories", "mechanism"]


def _run(name, **kw):
    m = planarkin.load(ROOT / "mechanisms" / f"{name}.yaml")
    return m, planarkin.solve(m, **kw)


def test_mechanism_instants_few_distinct_and_the_final_pose_of_an_open_motion():
    """Six-bar: three instants of a full cycle (the end is the start); boom (cylinder extending,
    not periodic, the frame origin pinned to ground): its final pose is drawn; trammel (there and
    back): the pose at t = 0.75 s repeats t = 0.25 s and is drawn once."""
    m, r = _run("six-bar", steps=120)
    sc = plots.Scene(m, r._chunk)
    assert plots.instant_count(m) == 3 and sc.closed
    assert list(sc.instants(3)) == [0, 40, 80]
    m, r = _run("boom", steps=40)
    sc = plots.Scene(m, r._chunk)
    assert not sc.closed
    assert list(sc.instants(plots.instant_count(m))) == [0, 13, 27, 40]
    m, r = _run("trammel", steps=120)
    sc = plots.Scene(m, r._chunk)
    assert list(sc.instants(4)) == [0, 30, 60]


def test_mechanism_figure_legend_and_body_colours(model, result):
    """Every body drawn in its own colour (that of bodies.png) and named in it once; the legend
    names each instant and each kind of path once."""
    from matplotlib.colors import to_rgb
    fig = plots.mechanism_figure(model, plots.Scene(model, result._chunk))
    labels = _legend_labels(fig)
    assert labels == ["B", "joint paths", "t = 0 s (named)", "t = 0.25 s", "t = 0.5 s",
                      "t = 0.75 s"]
    ax = fig.axes[0]
    names = {t.get_text(): t for t in ax.texts}
    colors = plots.body_palette(model.nb)
    for b, name in enumerate(model.body_names):
        assert np.allclose(to_rgb(names[name].get_color()), plots.darker(colors[b]))
    bars = [ln for ln in ax.get_lines() if ln.get_linewidth() == 4.5]
    assert {to_rgb(ln.get_color()) for ln in bars} == {to_rgb(colors[0]), to_rgb(colors[1])}


def test_time_histories_against_the_driver_coordinate():
    """four-bar (degrees, crank driven by f = 360 t): with x = driver every curve is drawn
    against the crank angle, ticks every 45 degrees, the labels name it with its unit."""
    m, r = _run("four-bar", steps=72)
    for fig in (plots.bodies_figure(m, r._chunk, r.info, "driver"),
                plots.points_figure(m, r._chunk, r.info, "driver")):
        bottom = fig.axes[-1]
        assert bottom.get_xlabel() == "crank angle [deg]"
        assert "against the crank angle" in fig._suptitle.get_text()
        assert bottom.get_xlim() == (0.0, 360.0)
        ticks = [v for v in bottom.get_xticks() if 0 <= v <= 360]
        assert ticks == [0, 45, 90, 135, 180, 225, 270, 315, 360]
        for ax in fig.axes:
            for ln in ax.get_lines():
                assert np.allclose(ln.get_xdata(), 360 * r.t)
    fig = plots.bodies_figure(m, r._chunk, r.info)
    assert fig.axes[-1].get_xlabel() == "t [s]"


def test_x_option_is_checked_like_the_yaml_key(tmp_path):
    """--x driver on a model without drivers: the same message as output: x, exit 2; the API
    refuses an unknown abscissa with an InputError."""
    from click.testing import CliRunner
    from planarkin.cli import main
    case = ROOT / "tests" / "cases" / "output-x.yaml"
    text = case.read_text().replace("output: {x: driver}\n", "")
    f = tmp_path / "structure.yaml"
    f.write_text(text)
    r = CliRunner().invoke(main, ["run", str(f), "--x", "driver", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 2
    assert f"{f}: error: --x: driver needs a driver, and this model has none; use time" in r.output
    m, res = _run("slider-crank", steps=20)
    with pytest.raises(planarkin.InputError, match="x must be one of time, driver, not 'crank'"):
        res.write(tmp_path / "out", x="crank")


def test_legend_beside_the_drawing_is_never_cut():
    """A long point name (the text widths are estimated, never measured, when the figure is
    laid out): the figure widens until the legend fits."""
    from matplotlib.backends.backend_agg import RendererAgg
    text = SLIDER_CRANK.read_text().replace("  B: {body", "  WWWWWWWWWWWWWWWWWWWWWWWWWWWWWW: {body")
    m = planarkin.load("long.yaml", text=text)
    r = planarkin.solve(m, steps=40)
    fig = plots.mechanism_figure(m, plots.Scene(m, r._chunk))
    W, H = fig.get_size_inches()
    assert W > 9.0
    box = fig.legends[0].get_window_extent(RendererAgg(int(W * fig.dpi), int(H * fig.dpi),
                                                       fig.dpi))
    assert box.x1 <= W * fig.dpi


def test_tradeoff_labels_do_not_overlap():
    """Five settings on one spot and two close by: every name gets a place of its own inside
    the axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.text import Text
    from planarkin.tradeoff import _label_points
    fig = Figure(figsize=(8, 5.5))
    ax = fig.add_subplot()
    pts = [(40.0, 3e-16, f"setting {k}") for k in range(5)] + [(41.0, 3e-16, "close"),
                                                                (200.0, 1e-6, "far")]
    ax.scatter([p[0] for p in pts], [p[1] for p in pts])
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(1e-17, 1e-3)
    r = FigureCanvasAgg(fig).get_renderer()
    _label_points(ax, r, pts)
    boxes = []
    for t in ax.texts:
        t.update_positions(r)
        boxes.append(Text.get_window_extent(t, r))
    assert len(boxes) == 7
    frame = ax.get_window_extent(r)
    for k, b in enumerate(boxes):
        assert frame.contains(b.x0, b.y0) and frame.contains(b.x1, b.y1)
        assert not any(b.overlaps(o) for o in boxes[k + 1:])


def test_a_run_without_plots_never_imports_matplotlib(tmp_path):
    """matplotlib (0.3-0.5 s to import) is imported only when plotting."""
    import subprocess
    import sys
    code = ("import sys\nfrom planarkin.cli import main\n"
            "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n    code = e.code\n"
            "print('matplotlib' in sys.modules, code)")
    for extra, imported in ((["--no-plots"], "False"), ([], "True")):
        out = subprocess.run([sys.executable, "-c", code, "run", str(SLIDER_CRANK), "--steps",
                              "30", "--out", str(tmp_path), "-q", *extra], capture_output=True,
                             text=True, cwd=ROOT, timeout=300)
        assert out.stdout.split()[-2:] == [imported, "0"], out.stdout + out.stderr
    assert (tmp_path / "slider-crank" / "mechanism.png").exists()


def test_mechanism_legend_names_only_paths_that_are_drawn():
    """A sketch names its ground pins too: they do not move, so they have no path and no entry
    in the legend (an entry in a colour that appears nowhere in the drawing)."""
    m = planarkin.load(ROOT / "mechanisms" / "six-bar-sketch.yaml")
    r = planarkin.solve(m, steps=40)
    fig = plots.mechanism_figure(m, plots.Scene(m, r._chunk))
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert {"B", "C", "P", "F"} <= set(labels)
    assert not {"A", "D", "E"} & set(labels), labels


def test_a_slot_is_drawn_whole():
    """curved-slot.yaml: the arc slot on the frame is drawn along its whole length (the pin's
    path covers only the part it runs along), every point of it on the circle about C."""
    m = planarkin.load(ROOT / "mechanisms" / "curved-slot.yaml")
    r = planarkin.solve(m, steps=40)
    scene = plots.Scene(m, r._chunk)
    cx, R = 0.4, 0.3                                       # Cx and R of the file
    on_circle = [P for P in scene.axes if len(P) > 100 and np.allclose(
        np.hypot(P[:, 0] - cx, P[:, 1]), R, rtol=0, atol=1e-12)]
    assert on_circle, [len(P) for P in scene.axes]
    path = r.point("B")
    arc = on_circle[0]
    assert np.ptp(arc[:, 0]) > np.ptp(path["x"]) + 1e-3       # longer than the pin's run


def test_a_figure_does_not_depend_on_what_was_drawn_before(tmp_path):
    """The process keeps the texts it has rasterised (plots.TEXTS) and the plot server draws
    model after model: the six-bar's figures drawn after the four-bar's are byte-identical to
    the six-bar's drawn first, in a process that has drawn nothing."""
    six, four = _run("six-bar", steps=60), _run("four-bar", steps=60)
    for d in ("alone", "other", "after"):
        (tmp_path / d).mkdir()
    plots.TEXTS.clear()
    alone = plots.write_plots(six[0], six[1]._chunk, six[1].info, tmp_path / "alone")
    plots.TEXTS.clear()
    plots.write_plots(four[0], four[1]._chunk, four[1].info, tmp_path / "other")
    after = plots.write_plots(six[0], six[1]._chunk, six[1].info, tmp_path / "after")
    from matplotlib.backends.backend_agg import RendererAgg
    if hasattr(RendererAgg, "_draw_text_glyphs_and_boxes"):   # the cache's matplotlib (3.11)
        assert len(plots.TEXTS) > 0
    assert [f.name for f in alone] == [f.name for f in after]
    for a, b in zip(alone, after):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_png_writer_round_trips_and_states_the_resolution(tmp_path):
    """plots.write_png (unfiltered rows, zlib): Pillow reads back the same RGB pixels (the
    alpha channel dropped: figures are opaque) and 150 dpi."""
    from PIL import Image
    rng = np.random.default_rng(12)
    rgba = rng.integers(0, 256, size=(37, 53, 4), dtype=np.uint8)
    rgba[5:20, 10:40] = (255, 255, 255, 255)
    path = tmp_path / "x.png"
    plots.write_png(path, rgba, 150)
    with Image.open(path) as im:
        assert im.mode == "RGB" and im.size == (53, 37)
        assert round(im.info["dpi"][0]) == 150
        assert np.array_equal(np.asarray(im), rgba[:, :, :3])


@pytest.mark.parametrize("ydata", [(-0.04, 0.04), (0.0, 2.4e7), (1e6 + 0.1, 1e6 + 0.3)])
def test_tick_labels_are_drawn_where_matplotlib_draws_them(ydata):
    """_Ticks (the ticks, grid and tick labels of the figures' axes) draws the same tick labels
    and offset text as matplotlib's own axes, at the same places (within a pixel)."""
    import matplotlib as mpl
    from matplotlib.backends.backend_agg import RendererAgg
    from matplotlib.figure import Figure

    class Recorder(RendererAgg):
        def draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
            self.seen.append((s, x, y))

    def drawn(light):
        with mpl.rc_context(plots.STYLE):
            fig = Figure(figsize=(4, 3), dpi=150)
            rect = (0.25, 0.2, 0.7, 0.7)
            ax = plots.add_axes(fig, rect) if light else fig.add_axes(rect)
            ax.plot([0.0, 360.0], ydata)
            r = Recorder(600, 450, 150)
            r.seen = []
            fig.draw(r)
        return sorted(r.seen)

    ours, theirs = drawn(True), drawn(False)
    assert [s for s, _, _ in ours] == [s for s, _, _ in theirs]
    assert len(ours) >= 8
    for (s, x, y), (_, x2, y2) in zip(ours, theirs):
        assert abs(x - x2) <= 1.0 and abs(y - y2) <= 1.0, (s, x, y, x2, y2)


def test_a_drawing_failure_is_reported_and_the_tables_kept(tmp_path, monkeypatch):
    """A figure that cannot be drawn (a bug, a matplotlib that behaves otherwise) does not cost
    the tables: the model is ok, the failure is a warning on the terminal and in summary.json,
    not a silently missing figure."""
    import json

    from clitools import run_cli

    def boom(*a, **k):
        raise IndexError("list index out of range")
    monkeypatch.setattr(plots, "write_plots", boom)
    r = run_cli("run", ROOT / "mechanisms" / "four-bar.yaml", "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    assert "warning: drawing the plots failed: IndexError: list index out of range" in r.stderr
    assert r.stderr.count("drawing the plots failed") == 1
    summary = json.loads((tmp_path / "four-bar" / "summary.json").read_text())
    assert summary["status"] == "ok" and (tmp_path / "four-bar" / "bodies.csv").exists()
    assert [w["kind"] for w in summary["warnings"]] == ["plots"]


def _flat_face_touches_its_cam(m, r):
    """At every grid time the follower's drawn face is tangent to the cam's drawn working
    surface: no surface point beyond the face line, the nearest on it (to the polyline's
    sampling), and that point on the drawn segment."""
    sc = plots.Scene(m, r._chunk)
    faces = [(b, f) for b in range(sc.nb) for f in sc.faces[b]]
    assert len(faces) == 1
    bj, F = faces[0]
    G = next(G for G in m.groups if G.kind.name in ("cam", "cam-rocker"))
    bi = int(G.bodies[0, 0])
    surface = max(sc.dashed[bi], key=len)            # the working surface (181 points)
    span = sc.span
    for row in range(0, len(sc.t), 7):
        X, Y = sc.to_global(bj, F, [row])
        a, b = np.array([X[0, 0], Y[0, 0]]), np.array([X[0, 1], Y[0, 1]])
        u = (b - a) / np.hypot(*(b - a))
        Sx, Sy = sc.to_global(bi, surface, [row])
        S = np.c_[Sx[0], Sy[0]]
        d = (S - a) @ np.array([-u[1], u[0]])
        d *= np.sign(np.median(d))                      # the cam's side of the face: > 0
        assert d.min() >= -1e-9 * span and d.min() <= 2e-4 * span, (row, d.min() / span)
        along = (S[np.argmin(d)] - a) @ u
        assert 0 < along < np.hypot(*(b - a))


def test_a_flat_faced_rocker_is_drawn_with_its_face_on_the_cam():
    _flat_face_touches_its_cam(*_run("flat-rocker-cam"))


def _offset_cam(tmp_path, follower):
    from test_machine_elements import OFFSET_CAM
    p = tmp_path / "cam.yaml"
    p.write_text(OFFSET_CAM.format(e=0, off=0, follower=follower).replace("[e, 35, 0]",
                                                                          "[0, 30, 0]"))
    m = planarkin.load(p)
    return m, planarkin.solve(m)


def test_a_flat_faced_translating_follower_is_drawn_with_its_face_on_the_cam(tmp_path):
    _flat_face_touches_its_cam(*_offset_cam(tmp_path, "flat: true"))


def test_a_roller_follower_has_no_face(tmp_path):
    m, r = _offset_cam(tmp_path, "roller: rr")
    assert not any(plots.Scene(m, r._chunk).faces)
