"""Budgets that bound (issue 33): each finding's reproducer scaled down, kept with a bounded
count (path steps estimated, rows and bytes held, artists drawn, names compared) or the refusal
itself, never a wall-clock figure; a deadline only as a hang guard.

1. a noisy input table (a measured motion used as a driver) took the path follower several
   steps per row: refused before the analysis, with the figures and the fix;
2. a curve slot of 10,000 points at 100,000 steps: the closest-point search held a table of
   every point against every sample: a k-d tree;
3. 24,000 named points at 3,000 steps grew past 6 GB: grid chunks and the plots' rows sized
   with the points, at most MAX_POINTS points, at most MAX_POINT_ROWS point rows;
4. plots of 20,000 points: the first NAMED_POINTS drawn one by one, the rest one collection;
5. the files planarkin reads: a model that is a FIFO or a device, a model of thousands of
   parameters or of broken references.
"""

from __future__ import annotations

import os
import threading
import tracemalloc

import numpy as np
import pytest

import planarkin
from clitools import PLAIN_SLIDER_CRANK, ROOT, run_cli
from planarkin.diagnostics import InputError

FOUR_BAR = """\
name: fb
units: {length: m, angle: deg}
parameters: {a: 0.04, b: 0.12, c: 0.10, d: 0.10}
bodies:
  crank:   {q: [0, 0, 0]}
  coupler: {q: [0.04, 0, 55]}
  rocker:  {q: [0.1, 0, 85]}
joints:
  - {type: revolute, i: ground, j: crank,   si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank,  j: coupler, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: coupler, j: rocker, si: [b, 0], sj: [c, 0]}
  - {type: revolute, i: ground, j: rocker,  si: [d, 0], sj: [0, 0]}
drivers:
  - {type: angle, body: crank, DRIVER}
POINTS
analysis: {start: 0, end: END, steps: STEPS}
"""


def four_bar(tmp_path, driver='f: "360*t"', points="points: {P: {body: coupler, s: [0.06, "
             "0.045]}}", end=1, steps=100, name="fb"):
    p = tmp_path / f"{name}.yaml"
    p.write_text(FOUR_BAR.replace("DRIVER", driver).replace("POINTS", points)
                 .replace("END", str(end)).replace("STEPS", str(steps)))
    return p


def noisy_table(path, rows, noise=0.5, seed=1):
    """A crank angle measured with noise (deg), one turn a second."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, rows)
    y = 360.0 * t + noise * rng.standard_normal(rows)
    path.write_text("t,angle\n" + "".join(f"{a:.9f},{b:.9f}\n" for a, b in zip(t, y)))


def driver_line(p):
    return next(i for i, s in enumerate(p.read_text().splitlines(), 1) if "type: angle" in s)


# -- 1. a noisy table ---------------------------------------------------------------------------
def test_a_noisy_table_is_refused_before_the_path_with_the_figures_and_the_fix(tmp_path):
    """2,500 noisy rows: the path would take about 11,000 steps, 4.5 a row (the finding's
    100,000 rows about 450,000); refused before the analysis, nothing written."""
    noisy_table(tmp_path / "noisy.csv", 2500)
    p = four_bar(tmp_path, "table: {file: noisy.csv, time: t, value: angle}")
    r = run_cli("run", p, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith(
        f"{p}:{driver_line(p)}: error: driver 1 (angle ground-crank): table noisy.csv: its "
        f"interpolant's fourth derivative changes sign at 8"), r.stderr
    for words in ("% of the rows (noise in measured data, or a motion sampled too sparsely?)",
                  "internal steps (4.", "per row), more than 10000 (the budget for a table whose "
                  "rows alternate so)", "smooth the data (a moving average, a smoothing spline) "
                  "or thin it out to fewer rows, or raise path_tol"):
        assert words in r.stderr, r.stderr
    assert not (tmp_path / "out" / "fb").exists()
    assert run_cli("check", p).returncode == 2


def test_the_estimate_is_a_lower_bound_of_the_steps_the_path_takes(tmp_path):
    """On a small noisy table the path's accepted steps are 1-3 times the estimate: the
    refusal above is made on a count the path would at least take."""
    from planarkin.solver.budget import table_steps
    noisy_table(tmp_path / "small.csv", 150)
    m = planarkin.load(four_bar(tmp_path, "table: {file: small.csv, time: t, value: angle}"))
    steps, signs, rows = table_steps(m.driver_funcs[0], m.driver_scale[0], 0.0, 1.0, 1e-4)
    assert signs > 0.7 and rows == pytest.approx(149.0)
    res = planarkin.solve(m, steps=20)
    assert res.status == 0
    assert steps <= res.info.internal_steps <= 3 * steps, (steps, res.info.internal_steps)


def test_smooth_tables_are_not_refused_however_long_the_run(tmp_path):
    """A measured cycle without noise (the example's 25 rows), periodic, over 400 s: more
    estimated steps than NOISY_STEPS, but its rows do not alternate: it passes the preflight
    (it is not run here)."""
    from planarkin.solver.budget import NOISY_STEPS, preflight, table_steps
    from planarkin.options import resolve
    (tmp_path / "in.csv").write_text((ROOT / "mechanisms" / "table-input.csv").read_text())
    p = four_bar(tmp_path, "table: {file: in.csv, time: t, value: angle, periodic: true}",
                 end=400)
    m = planarkin.load(p)
    opts = resolve(m, {}, source="api")
    steps, signs, _ = table_steps(m.driver_funcs[0], m.driver_scale[0], 0.0, 400.0, 1e-4)
    assert steps > NOISY_STEPS and signs < 0.3
    assert preflight(m, opts) is None


def test_a_table_past_the_node_budget_is_refused_whatever_its_signs(tmp_path):
    noisy_table(tmp_path / "noisy.csv", 400)
    p = four_bar(tmp_path, "table: {file: noisy.csv, time: t, value: angle}")
    with pytest.raises(InputError) as e:
        planarkin.solve(planarkin.load(p), max_nodes=1000)
    msg = str(e.value)
    assert "following its interpolant would take at least" in msg and "more than 1000 (the " \
        "budget: analysis: max_nodes = 1000" in msg, msg


def test_vectorised_derivative_tables_equal_the_pieces_derivatives():
    """Piecewise._table of order k > 0 from order k - 1 at once: the same coefficients as each
    piece's np.polyder (which a 1e5-row table called for every piece and order)."""
    from planarkin.functions.inputtable import spline
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 2, 40))
    pw = spline(t, rng.standard_normal(40))
    for k in range(1, 7):
        C, O = pw._table(k)
        P = pw.pieces(k)
        want = np.zeros_like(C)
        for i, piece in enumerate(P):
            want[i, C.shape[1] - len(piece.poly):] = piece.poly
        assert np.array_equal(C, want) and np.array_equal(O, [q.origin for q in P])
    assert pw.interior_ends(2).shape == (len(pw.knots) - 1, 2)


# -- 2. a curve slot of many points -------------------------------------------------------------
def test_the_closest_point_search_holds_no_table_of_points_against_samples():
    """A curve of 10,000 points has 20,000 samples; 250 pins searched against every one held
    two (250, 20000, 2) arrays (160 MB; at a grid chunk of 8192 rows, gigabytes): through the
    k-d tree the search holds a few numbers per pin."""
    from planarkin.elements.curve import Curve
    a = np.linspace(0.0, 1.0, 10_000)
    cv = Curve(np.c_[np.cos(a), np.sin(a)], closed=False)
    rng = np.random.default_rng(0)
    p = np.c_[np.cos(a[::40]), np.sin(a[::40])] * (1 + 1e-3 * rng.standard_normal((250, 1)))
    cv.project(p[:2])                   # the tree is built once, outside the measurement
    tracemalloc.start()
    try:
        cv.project(p)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 << 20, peak


def test_the_nearest_sample_is_the_argmin_over_every_sample():
    from planarkin.elements.curve import Curve
    rng = np.random.default_rng(5)
    for closed in (False, True):
        a = np.linspace(0.0, 2 * np.pi, 400, endpoint=not closed)
        cv = Curve(np.c_[np.cos(a), 0.5 * np.sin(a)], closed=closed)
        p = rng.uniform(-1.5, 1.5, (2000, 2))
        p = np.vstack([p, cv.samples[:50], [[0.0, 0.0], [np.nan, 0.0], [np.inf, 1.0]]])
        with np.errstate(invalid="ignore"):
            want = np.argmin(((p[:, None, :] - cv.samples[None]) ** 2).sum(axis=2), axis=1)
        assert np.array_equal(cv.nearest_sample(p), want)


# -- 3. many named points -----------------------------------------------------------------------
def _points(n, body="coupler"):
    return "points:\n" + "".join(f"  P{k}: {{body: {body}, s: [{0.001 * (k % 50)}, "
                                 f"{0.001 * (k // 50)}]}}\n" for k in range(n))


def test_more_named_points_than_the_budget_are_refused_at_the_points(tmp_path):
    from planarkin.model.validate import MAX_POINTS
    p = four_bar(tmp_path, points=_points(MAX_POINTS + 1))
    r = run_cli("run", p, "--out", tmp_path / "out")
    line = next(i for i, s in enumerate(p.read_text().splitlines(), 1) if s == "points:")
    assert r.returncode == 2 and r.stderr.startswith(
        f"{p}:{line}: error: points: {MAX_POINTS + 1} points, more than {MAX_POINTS} (the "
        f"budget: "), r.stderr
    assert "keep the points you need" in r.stderr and not (tmp_path / "out" / "fb").exists()


def test_points_times_rows_past_the_budget_are_refused_before_the_analysis(tmp_path,
                                                                           monkeypatch):
    from planarkin.solver.budget import MAX_POINT_ROWS, point_rows
    from planarkin.options import resolve
    from planarkin.solver.grid import PathFollower
    followed = []
    monkeypatch.setattr(PathFollower, "run", lambda self: followed.append(1))
    p = four_bar(tmp_path, points=_points(1000))
    steps = MAX_POINT_ROWS // 1000          # one row more than the budget: steps + 1 rows
    r = run_cli("run", p, "--out", tmp_path / "out", "--steps", steps, "--no-plots")
    line = next(i for i, s in enumerate(p.read_text().splitlines(), 1) if s == "points:")
    assert r.returncode == 2 and r.stderr.startswith(
        f"{p}:{line}: error: 1000 points at {steps + 1} grid rows are 2e+07 point rows, more "
        f"than the budget of 2e+07"), r.stderr
    assert "use fewer steps (analysis: steps, --steps) or fewer points" in r.stderr
    assert followed == [] and not (tmp_path / "out" / "fb").exists()
    m = planarkin.load(p)
    assert point_rows(m, resolve(m, {"steps": steps - 1}, source="api")) is None   # at it


def test_grid_chunks_are_sized_with_the_points(tmp_path):
    """A model of 2,000 points at 3,000 steps was one chunk of 3,001 rows (a gigabyte of
    point kinematics); its chunks now hold CHUNK_BYTES of points at most."""
    from planarkin.analysis import prepare
    from planarkin.solver.budget import POINT_ROW_BYTES
    from planarkin.options import resolve
    from planarkin.solver.grid import CHUNK_BYTES
    m = planarkin.load(four_bar(tmp_path, points=_points(2000), steps=3000))
    an = prepare(m, resolve(m, {}, source="api"))
    sizes = [len(g) for g in an._grid_chunks()]
    assert sum(sizes) == 3001
    assert max(sizes) * 2000 * POINT_ROW_BYTES <= CHUNK_BYTES, max(sizes)


def test_the_plot_buffer_keeps_a_bounded_number_of_bytes():
    """The plots' rows (up to PLOT_ROWS) of every point: 4,000 rows of 2,000 points were 400 MB
    and as much again when joined; the stride now keeps PLOT_BYTES at most."""
    from planarkin.output.writer import PLOT_BYTES, PlotBuffer
    from planarkin.solver.chunks import Chunk
    buf = PlotBuffer(3001)
    N, P = 1000, 2000
    for a in range(0, 3001, N):
        n = min(N, 3001 - a)
        z = np.zeros((n, 9))
        w = np.zeros((n, P, 2))
        buf.add(Chunk(np.arange(a, a + n, dtype=float), z, z, z, w, w, w, np.zeros(n),
                      np.zeros(n), np.zeros(n)))
    ch = buf.chunk()
    row = sum(x.nbytes for x in vars(ch).values() if isinstance(x, np.ndarray)) / len(ch.t)
    assert len(ch.t) * row <= PLOT_BYTES + row and ch.t[-1] == 3000.0


# -- 4. plots of many points --------------------------------------------------------------------
def test_plots_of_many_points_draw_a_bounded_number_of_artists(tmp_path):
    """300 points: each was two lines, a marker, a legend entry and a placed label in the
    paths, and four curves in the time histories compared pairwise with every other. Now
    the first NAMED_POINTS are drawn so, the rest are one collection and a legend entry, and
    the time histories say what they leave out."""
    from matplotlib.collections import LineCollection

    from planarkin.output import plots
    from planarkin.output.plots.style import NAMED_POINTS
    m = planarkin.load(four_bar(tmp_path, points=_points(300), steps=40))
    res = planarkin.solve(m)
    data = res._chunk                   # user units, as the writer hands the plots a buffer
    scene = plots.Scene(m, data)
    fig = plots.trajectories_figure(m, scene)
    ax = fig.axes[0]
    assert len(ax.lines) <= 3 * NAMED_POINTS + 12, len(ax.lines)     # path, start, marker
    crowd = [c for c in ax.collections if isinstance(c, LineCollection)]
    assert len(crowd) == 1 and len(crowd[0].get_segments()) == 300 - NAMED_POINTS
    assert len(ax.get_legend().get_texts()) <= NAMED_POINTS + 4
    assert f"{300 - NAMED_POINTS} more points" in [t.get_text() for t in
                                                   ax.get_legend().get_texts()]
    fig = plots.mechanism_figure(m, scene)
    ax = fig.axes[0]
    assert len(ax.lines) <= 8 * NAMED_POINTS, len(ax.lines)
    assert len(ax.texts) <= NAMED_POINTS + m.nb + 2, len(ax.texts)
    fig = plots.points_figure(m, data, res.info)
    for ax in fig.axes:
        assert len(ax.lines) <= 2 * NAMED_POINTS + 2, len(ax.lines)
    note = " ".join(t.get_text() for t in fig.texts)
    assert f"the points after the first {NAMED_POINTS} ({300 - NAMED_POINTS} more) are not " \
           f"drawn: points.csv has every point" in " ".join(note.split())


# -- 5. the files planarkin reads ---------------------------------------------------------------
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_model_that_is_a_fifo_is_refused_at_once_not_read_for_ever(tmp_path):
    from planarkin.model.yamlread import read_file
    fifo = tmp_path / "m.yaml"
    os.mkfifo(fifo)
    out = []

    def read():
        try:
            read_file(fifo)
        except InputError as e:
            out.append([d.format() for d in e.diagnostics])

    th = threading.Thread(target=read, daemon=True)   # the old reader blocked in open()
    th.start()
    th.join(30)                                       # a hang guard, not a timing
    assert out == [[f"{fifo}: error: cannot read file: it is a FIFO, not a regular file (a "
                    f"FIFO, device or socket is not read): give a YAML file"]]


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero here")
def test_a_model_that_is_a_device_is_refused_before_it_is_read(tmp_path):
    r = run_cli("check", "/dev/zero")
    assert r.returncode == 2 and r.stderr.startswith(
        "/dev/zero: error: cannot read file: it is a device, not a regular file"), r.stderr


def test_thousands_of_parameters_are_read_in_one_pass(tmp_path, monkeypatch):
    """A chain of parameters (p1: p0 + 1, ...) within the YAML node budget was quadratic to
    read: every parameter copied the names known for its expression, and listed every
    parameter to find one defined later. Counted: the names copied, the passes over them."""
    from planarkin.functions.expr import parser
    from planarkin.model import validate as V
    from planarkin.model.yamlread import read_yaml
    n = 3000
    text = ("parameters:\n  p0: 1\n" + "".join(f"  p{k}: p{k - 1} + 1\n" for k in range(1, n))
            + "  q: z + 1\n  z: 2\n" + PLAIN_SLIDER_CRANK.split("parameters:\n", 1)[1])
    root = read_yaml(text, "m.yaml")
    passes = [0]

    class Counting(dict):
        def __iter__(self):
            passes[0] += 1
            return super().__iter__()

    params = root.value["parameters"]
    params.value = Counting(params.value)
    copied = [0]
    real = frozenset

    def counting(names=()):
        names = list(names)
        copied[0] += len(names)
        return real(names)

    monkeypatch.setattr(parser, "frozenset", counting, raising=False)
    with pytest.raises(InputError) as e:
        V.validate(root, "m.yaml")
    assert [d.message for d in e.value.diagnostics][0].startswith(
        "parameter 'q' uses 'z', which is defined later")
    assert copied[0] <= 10 * n and passes[0] <= 10, (copied[0], passes[0])


def test_a_file_of_broken_references_stops_at_the_error_budget(tmp_path, monkeypatch):
    """300 joints naming bodies that do not exist among 300 that do: each error looked for the
    name meant among every body (an alignment each: errors times bodies). At most
    MAX_ERRORS are reported, and names too different to be a slip are not aligned."""
    from planarkin import diagnostics
    from planarkin.model.validate import MAX_ERRORS
    n = 300
    text = ("bodies: {" + ", ".join(f"body{k}: {{q: [0, 0, 0]}}" for k in range(n)) + "}\n"
            "joints:\n" + "".join(f"  - {{type: revolute, i: ground, j: link{k}, si: [0, 0], "
                                  f"sj: [0, 0]}}\n" for k in range(n)))
    p = tmp_path / "m.yaml"
    p.write_text(text)
    aligned = [0]
    real = diagnostics._edits

    def counting(a, b):
        aligned[0] += 1
        return real(a, b)

    monkeypatch.setattr(diagnostics, "_edits", counting)
    with pytest.raises(InputError) as e:
        planarkin.load(p)
    d = e.value.diagnostics
    assert len(d) == MAX_ERRORS + 1
    assert d[0].message == f"{MAX_ERRORS} errors, and the file was not read further: mend " \
                           f"these first"
    assert aligned[0] <= MAX_ERRORS * n // 10, aligned[0]
