"""cam.png (planarkin.output.plots.cam): the figure a cam designer reads, written with the cam's
table whenever the plots are. The drawn arrays come from `cam_data`, tested here against the
run's own tables: S is the table's s (psi), V and A times the cam's speed are the follower's
velocity and acceleration in bodies.csv, J times its cube the follower's jerk of a run with
up_to: jerk (the law's exact derivatives, never finite differences), and the drawn working
surface, pitch curve, radius of curvature and pressure angle are the table's columns."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import planarkin
from planarkin.elements.cam import cam_joints, derived_tables
from planarkin.functions.expr import ExprError
from planarkin.output import plots
from planarkin.output.plots.cam import cam_data, cam_figure, cam_figures, law_derivatives

ROOT = Path(__file__).resolve().parents[1]
MECHANISMS = ROOT / "mechanisms"
PNG = b"\x89PNG\r\n\x1a\n"
STEPS = 72                        # a row every 5 deg of the turn: the knots are rows
# model -> (follower, its coordinate along the travel, the cam's knots in deg)
FOLLOWERS = {"valve-cam": ("stem", "y", [120.0, 180.0, 300.0]),
             "flat-rocker-cam": ("rocker", "phi", [150.0, 180.0, 330.0])}

TWO_CAMS = """\
name: two-cams
units: {length: mm, angle: deg}
parameters: {h: 8, rb: 30, rr: 6}
bodies:
  cam:  {q: [0, 0, 0]}
  up:   {q: [0, 36, 0]}
  side: {q: [36, 0, 0]}
joints:
  - {type: revolute, i: ground, j: cam, at: [0, 0]}
  - {type: translational, i: ground, j: up, at: [0, 36], axis: [0, 1]}
  - {type: translational, i: ground, j: side, at: [36, 0], axis: [1, 0]}
  - {name: a, type: cam, i: cam, j: up, sk: [0, 0], vk: [0, 1], sj: [0, 0], base: rb, roller: rr,
     s: "h*(1 - cos(pi*theta/180))/2"}
  - {name: b, type: cam, i: cam, j: side, sk: [0, 0], vk: [1, 0], sj: [0, 0], base: rb,
     roller: rr, s: "h*(1 - cos(pi*theta/180))/2"}
drivers:
  - {type: angle, body: cam, f: "360*t"}
analysis: {start: 0, end: 1, steps: 36}
"""


@pytest.fixture(scope="module")
def runs():
    """model name -> (compiled model, its result with jerks, the cam's CamData, its table)."""
    out = {}
    for name in FOLLOWERS:
        m = planarkin.load(MECHANISMS / f"{name}.yaml")
        r = planarkin.solve(m, steps=STEPS, up_to="jerk")
        cam = cam_joints(m)[0]
        X = derived_tables(m, None)[0].compute(r._chunk)
        out[name] = (m, r, cam_data(m, cam, X), r.table(f"cam-{cam.name}.csv"))
    return out


def _right(D, theta):
    """Indices in D.theta of the cam angles theta: their right-hand limits (the last of a knot's
    two samples), as the tables hold them."""
    idx = np.searchsorted(D.theta, theta, side="right") - 1
    assert np.array_equal(D.theta[idx], theta)
    return idx


@pytest.mark.parametrize("name", FOLLOWERS)
def test_the_plotted_law_is_the_tables(runs, name):
    """S is the table's s (psi); V, A and J times the cam's speed (constant: 360 deg/s) are the
    follower's velocity, acceleration and jerk of the run."""
    m, r, D, T = runs[name]
    body, coord, _ = FOLLOWERS[name]
    theta = T["theta"]
    k = _right(D, theta)
    np.testing.assert_allclose(D.s[k], T["s" if D.kind == "cam" else "psi"], rtol=0,
                               atol=1e-12 * np.abs(D.s).max())
    w = r.body("cam")["omega"]
    np.testing.assert_allclose(w, 360.0, rtol=1e-12)
    b = r.body(body)
    names = {"y": ("vy", "ay", "jy"), "phi": ("omega", "alpha", "jphi")}[coord]
    for (col, y), o in zip(zip(names, (D.v, D.a, D.j)), (1, 2, 3)):
        rows = slice(None) if o < 3 else slice(0, -1)   # the last angle: its left-hand limit
        np.testing.assert_allclose(y[k][rows] * w[rows] ** o, b[col][rows], rtol=0,
                                   atol=1e-9 * np.abs(b[col]).max(), err_msg=col)


@pytest.mark.parametrize("name", FOLLOWERS)
def test_the_knots_are_marked_and_both_limits_drawn(runs, name):
    """The law's segment boundaries are its knots; at each the curves have both one-sided
    limits (the jerk jumps there), the left-hand one first."""
    _, _, D, _ = runs[name]
    assert D.knots == pytest.approx(FOLLOWERS[name][2], abs=1e-9)
    law = D.cam.par["s" if D.kind == "cam" else "psi"]
    for x in D.knots:
        k = np.flatnonzero(D.theta == x)
        assert len(k) == 2
        left, right = law.fn.third(np.array([x]), -1)[0], law.fn.third(np.array([x]), 1)[0]
        assert left != pytest.approx(right)
        assert D.j[k] == pytest.approx([left, right], rel=1e-12)


@pytest.mark.parametrize("name", FOLLOWERS)
def test_the_drawn_profile_is_the_tables(runs, name):
    """The working surface and the pitch curve drawn (over the law's turn, the table's cam
    angles among their samples), and the radius of curvature and pressure angle against cam
    angle, are the table's columns."""
    _, _, D, T = runs[name]
    theta = T["theta"]
    folded = np.mod(theta, 360.0)
    k = np.searchsorted(D.profile_theta, folded)
    assert np.allclose(D.profile_theta[k], folded, rtol=0, atol=1e-12)
    size = np.abs(D.surface_x).max()
    for drawn, col in ((D.surface_x, "surface.x"), (D.surface_y, "surface.y"),
                       (D.pitch_x, "pitch.x"), (D.pitch_y, "pitch.y")):
        np.testing.assert_allclose(drawn[k], T[col], rtol=0, atol=1e-9 * size, err_msg=col)
    i = np.searchsorted(D.at, theta)
    assert np.array_equal(D.at[i], theta)
    rho = T["rho_surface" if D.flat else "rho_pitch"]
    np.testing.assert_allclose(D.rho[i], rho, rtol=1e-9)
    np.testing.assert_allclose(D.pressure[i], T["pressure_angle"], rtol=0, atol=1e-9)
    # the base circle touches the working surface: its smallest radius
    assert np.hypot(D.surface_x, D.surface_y).min() == pytest.approx(D.base, rel=1e-6)


def test_the_figure_is_written_for_a_cam_model_and_not_for_one_without(tmp_path, monkeypatch):
    """Through the writer's plot step (the other figures left out here): cam.png for the cam
    model, listed in summary.json; none for a model without a cam."""
    monkeypatch.setattr(plots, "write_plots", lambda *a, **k: [])
    for name, expect in (("valve-cam", ["cam.png"]), ("four-bar", [])):
        r = planarkin.solve(MECHANISMS / f"{name}.yaml", steps=36)
        s = r.write(tmp_path / name, plots="png")
        assert s["plots"] == expect
        assert sorted(p.name for p in (tmp_path / name).glob("*.png")) == expect
    from PIL import Image
    path = tmp_path / "valve-cam" / "cam.png"
    assert path.read_bytes().startswith(PNG)
    with Image.open(path) as im:
        assert round(im.info["dpi"][0]) == 150
        assert 1500 <= im.width <= 2200 and 900 <= im.height <= 1400


def test_several_cams_get_a_figure_each(tmp_path):
    p = tmp_path / "two-cams.yaml"
    p.write_text(TWO_CAMS)
    m = planarkin.load(p)
    r = planarkin.solve(m)
    files = cam_figures(m, r._chunk, r.info, tmp_path)
    assert [f.name for f in files] == ["cam-a.png", "cam-b.png"]
    assert all(f.read_bytes().startswith(PNG) for f in files)


def test_no_plots_writes_no_figure(tmp_path):
    from planarkin.cli import main
    r = CliRunner().invoke(main, ["run", str(MECHANISMS / "valve-cam.yaml"), "--out",
                                  str(tmp_path), "--steps", "36", "--no-plots", "-q"])
    assert r.exit_code == 0, r.output
    d = tmp_path / "valve-cam"
    assert (d / "cam-valve.csv").is_file()
    assert not [p.name for p in d.iterdir() if p.suffix != ".csv" and p.name != "summary.json"]
    assert json.loads((d / "summary.json").read_text())["plots"] == []


class _NoThird:
    """A law given as data whose third derivative cannot be formed."""

    class fn:
        @staticmethod
        def derivatives(x, side=0):
            return x ** 2, 2 * x, 2 + 0 * x

        @staticmethod
        def third(x, side=0):
            raise ExprError("expression 'x' is too complex")


def test_a_law_without_an_exact_third_derivative_has_no_jerk_axes(runs):
    """No J curve (never a finite difference): the figure says why where it would be."""
    x = np.linspace(0, 1, 5)
    (s, v, a, j), note = law_derivatives(_NoThird(), x, np.ones(5))
    assert j is None and np.array_equal(a, np.full(5, 2.0))
    assert "third derivative" in note and "too complex" in note
    m, r, D, _ = runs["valve-cam"]
    fig = cam_figure(m, dataclasses.replace(D, j=None, jerk_note=note), r.info)
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert not any(lab.startswith("J =") for lab in labels)
    assert [lab.split(" =")[0] for lab in labels if " = " in lab.split("\n")[0]][:3] == \
        ["S", "V", "A"]
    assert any(note[:40] in t.get_text().replace("\n", " ") for t in fig.texts)
