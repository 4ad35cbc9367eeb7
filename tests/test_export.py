"""planarkin export (planarkin.export): fabrication drawings read back and measured.

- DXF files read back with ezdxf: R2000 in millimetres, only LINE, CIRCLE, ARC, LWPOLYLINE and
  TEXT, ezdxf's audit finds no error; hole centres at the pins in the body frame to 1e-9 mm
  (computed here from the file's numbers, the sketch's pins through their links' frames), and
  on the layout sheet where summary.json places each part (turned by the body's angle at
  --pose, solved here independently); plate outlines closed, each pin width / 2 inside them;
  parts of the sheet apart.
- Cam profiles: the Hausdorff distance between the drawn arcs and the exact working surface
  (kinematic inversion of the law written here: the roller centre's path in the cam's frame,
  offset inwards by the roller radius) is within the stated tolerance, and the tolerance is
  written in the file.
- SVG: parses with xml.etree, sized in mm, its hole circles are the DXF's holes.
- Bad input: the exact messages, exit 2.
"""

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import ezdxf            # the test extra installs it: read back, not skipped
import numpy as np
import pytest
from clitools import ROOT, run_cli

import planarkin
from planarkin.export import biarcs, geometry

M = ROOT / "mechanisms"
ALLOWED = {"LINE", "ARC", "CIRCLE", "LWPOLYLINE", "TEXT"}
EXACT = 1e-9            # mm


def export(tmp, model, *args):
    r = run_cli("export", model, "--out", tmp, *args)
    assert r.returncode == 0, r.stdout + r.stderr
    d = Path(tmp) / f"{Path(model).stem}.drawings"
    return d, json.loads((d / "summary.json").read_text())


@pytest.fixture(scope="module")
def four_bar(tmp_path_factory):
    return export(tmp_path_factory.mktemp("fb"), M / "four-bar.yaml", "--dxf", "--svg")


@pytest.fixture(scope="module")
def sketch_posed(tmp_path_factory):
    return export(tmp_path_factory.mktemp("sk"), M / "four-bar-sketch.yaml", "--dxf",
                  "--pose", "0.3")


@pytest.fixture(scope="module")
def valve(tmp_path_factory):
    return export(tmp_path_factory.mktemp("vc"), M / "valve-cam.yaml", "--dxf", "--svg")


def holes(path, layer="HOLES"):
    doc = ezdxf.readfile(path)
    C = doc.modelspace().query(f'CIRCLE[layer=="{layer}"]')
    return np.array([[c.dxf.center.x, c.dxf.center.y] for c in C]), [c.dxf.radius for c in C]


def same_points(A, B, tol=EXACT):
    """Every point of A has one of B within tol and the other way round."""
    A, B = np.asarray(A, float).reshape(-1, 2), np.asarray(B, float).reshape(-1, 2)
    assert len(A) == len(B), (A, B)
    D = np.hypot(*(A[:, None, :] - B[None, :, :]).transpose(2, 0, 1))
    assert D.min(axis=1).max() <= tol and D.min(axis=0).max() <= tol, D.min(axis=1)
    return float(D.min(axis=1).max())


# -- the files ----------------------------------------------------------------------------------
def test_the_directory_has_a_file_per_part_and_format_and_the_layout(four_bar):
    d, summary = four_bar
    names = sorted(p.name for p in d.iterdir())
    assert names == sorted(f"{b}.{f}" for b in ("crank", "coupler", "rocker", "layout")
                           for f in ("dxf", "svg")) + ["summary.json"]
    assert summary["files"][-1] == "summary.json" and summary["unit"] == "mm"

def test_identical_input_gives_identical_bytes(four_bar, tmp_path):
    # ezdxf stamps creation times and random GUIDs unless told otherwise
    again, _ = export(tmp_path, M / "four-bar.yaml", "--dxf", "--svg")
    first, _ = four_bar
    names = sorted(p.name for p in first.iterdir())
    assert names == sorted(p.name for p in again.iterdir())
    for name in names:
        assert (first / name).read_bytes() == (again / name).read_bytes(), name


@pytest.mark.parametrize("model", ["four_bar", "valve"])
def test_dxf_is_r2000_in_mm_with_plain_entities_and_audits_clean(model, request):
    d, _ = request.getfixturevalue(model)
    for path in sorted(d.glob("*.dxf")):
        doc = ezdxf.readfile(path)
        assert doc.dxfversion == "AC1015", path.name
        assert doc.header["$INSUNITS"] == 4 and doc.header["$MEASUREMENT"] == 1
        assert {e.dxftype() for e in doc.modelspace()} <= ALLOWED, path.name
        auditor = doc.audit()
        assert not auditor.has_errors, (path.name, [str(e) for e in auditor.errors])


# -- holes where the pins are -------------------------------------------------------------------
def test_holes_are_the_pins_in_the_body_frame(four_bar):
    d, _ = four_bar
    spec = planarkin.load(M / "four-bar.yaml").spec
    pins = {b: [] for b in ("crank", "coupler", "rocker")}
    for el in spec.joints:
        for b, s in zip(el.bodies, (el.params["si"], el.params["sj"])):
            if b != "ground":
                pins[b].append(np.array(s) * 1000.0)            # m -> mm
    for body, expected in pins.items():
        P, radii = holes(d / f"{body}.dxf")
        same_points(P, expected)
        assert radii == [pytest.approx(3.05, abs=1e-12)] * len(P)     # (6 + 0.1) / 2


def test_sketch_pins_in_their_links_frames_and_posed_on_the_sheet(sketch_posed):
    """The sketch's links carry their frames at their first pin, x towards the second: the holes
    are the sketch's pins seen from there; on the sheet each part is turned by its body's angle
    at --pose 0.3 (solved here) and moved by the offset summary.json gives."""
    d, summary = sketch_posed
    pins = {"A": (0, 0), "D": (0.1, 0), "B": (0.04, 0),
            "C": (0.10666666666666667, 0.09977753031397177)}
    links = {"crank": ["A", "B"], "coupler": ["B", "C"], "rocker": ["D", "C"]}
    res = planarkin.solve(planarkin.load(M / "four-bar-sketch.yaml"), end=0.3, steps=3)
    sheet, _ = holes(d / "layout.dxf")
    expected_sheet = []
    for link, names in links.items():
        P = np.array([pins[n] for n in names], float) * 1000.0
        a = math.atan2(*(P[1] - P[0])[::-1])
        c, s = math.cos(a), math.sin(a)
        local = (P - P[0]) @ np.array([[c, -s], [s, c]])       # A(a)^T (P - P0)
        got, _ = holes(d / f"{link}.dxf")
        same_points(got, local)
        part = next(p for p in summary["parts"] if p["part"] == link)
        phi = math.radians(res.body(link)["phi"][-1])
        assert part["layout"]["angle_deg"] == pytest.approx(math.degrees(phi), abs=1e-9)
        cp, sp = math.cos(phi), math.sin(phi)
        expected_sheet.append(local @ np.array([[cp, -sp], [sp, cp]]).T
                              + part["layout"]["offset_mm"])
    same_points(sheet, np.vstack(expected_sheet))


def test_plates_are_closed_and_keep_width_half_around_every_pin(four_bar):
    d, _ = four_bar
    for body in ("crank", "coupler", "rocker"):
        doc = ezdxf.readfile(d / f"{body}.dxf")
        (outline,) = doc.modelspace().query('LWPOLYLINE[layer=="OUTLINE"]')
        assert outline.closed
        pts = outline.get_points("xyb")
        shape = geometry.Shape("poly", "OUTLINE", np.array([p[:2] for p in pts]),
                               np.array([p[2] for p in pts]), closed=True)
        P, _ = holes(d / f"{body}.dxf")
        for p in P:
            gap = min(biarcs.distance_to_segment(p[None, :], *seg)[0]
                      for seg in geometry.segments(shape))
            assert gap >= 6.0 - 1e-9                           # width 12 / 2
        # the coupler's plate takes in its point P (a triangle B, C, P: three arcs)
        if body == "coupler":
            assert sum(1 for p in pts if p[2] != 0) == 3


def test_layout_parts_do_not_overlap(sketch_posed, valve):
    for d, summary in (sketch_posed, valve):
        boxes = [p["layout"]["box_mm"] for p in summary["parts"]]
        for i in range(len(boxes)):
            for j in range(i):
                a, b = boxes[i], boxes[j]
                apart = a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1]
                assert apart, (summary["parts"][i]["part"], summary["parts"][j]["part"])
        # and every entity of the sheet lies in one part's box (ezdxf's extents: arcs
        # through Bezier curves, within 0.01 mm), so that no two parts overlap
        from ezdxf import bbox
        doc = ezdxf.readfile(d / "layout.dxf")
        for e in doc.modelspace().query("CIRCLE LWPOLYLINE LINE"):
            ext = bbox.extents([e])
            inside = [b for b in boxes if ext.extmin.x >= b[0] - 0.01 and ext.extmax.x <= b[2]
                      + 0.01 and ext.extmin.y >= b[1] - 0.01 and ext.extmax.y <= b[3] + 0.01]
            assert len(inside) == 1, (e.dxftype(), e.dxf.layer, ext)


# -- cams ---------------------------------------------------------------------------------------
def roller_surface(s, base, roller, th):
    """The working surface of a radial translating roller follower on a cam turning
    counter-clockwise (follower along +y): the roller centre at height base + roller + s(theta)
    seen from the cam is w = A(-theta) (0, base + roller + s), the surface w minus the roller
    radius along the pitch curve's outward normal (numerical tangent)."""
    def pitch(t):
        r = base + roller + s(t)
        return np.c_[r * np.sin(t), r * np.cos(t)]          # A(-t) (0, r)
    h = 1e-6
    T = pitch(th + h) - pitch(th - h)
    N = np.c_[T[:, 1], -T[:, 0]] / np.hypot(T[:, 0], T[:, 1])[:, None]
    P = pitch(th)
    N *= np.sign(np.einsum("ij,ij->i", N, P))[:, None]         # outward: away from the centre
    return P - roller * N, P


def arc_points(path, layer, step=1e-3):
    """Points every `step` mm along the layer's LWPOLYLINE, and its segments."""
    doc = ezdxf.readfile(path)
    (pl,) = doc.modelspace().query(f'LWPOLYLINE[layer=="{layer}"]')
    pts = pl.get_points("xyb")
    shape = geometry.Shape("poly", layer, np.array([p[:2] for p in pts]),
                           np.array([p[2] for p in pts]), closed=pl.closed)
    return geometry.sample(shape, step), list(geometry.segments(shape)), doc


def hausdorff(exact, drawn_points, segments):
    """Both directions: exact points to the drawn arcs (exact distances), the drawn arcs'
    points to the exact polyline (its samples 1e-3 mm apart: off the curve by far less)."""
    from scipy.spatial import cKDTree
    to_arcs = np.min([biarcs.distance_to_segment(exact, *s) for s in segments], axis=0).max()
    _, i = cKDTree(exact).query(drawn_points)
    best = np.full(len(drawn_points), np.inf)
    for lo in (np.maximum(i - 1, 0), np.minimum(i, len(exact) - 2)):
        a, b = exact[lo], exact[lo + 1]
        d = b - a
        t = np.clip(np.einsum("ij,ij->i", drawn_points - a, d) / np.einsum("ij,ij->i", d, d),
                    0, 1)
        best = np.minimum(best, np.hypot(*(drawn_points - a - t[:, None] * d).T))
    return max(to_arcs, best.max())


def test_valve_cam_profile_within_the_tolerance_and_says_it(valve):
    d, summary = valve
    cm = planarkin.load(M / "valve-cam.yaml")
    G = next(G for G in cm.groups if G.kind.name == "cam")
    law = G.params["s"][0]                                       # the exact law, internal units

    def s(t):
        return law(t, (0,))[0] * cm.L                            # mm
    th = np.linspace(0.0, 2 * math.pi, 300_001)
    surface, pitch = roller_surface(s, 30.0, 6.0, th)
    for layer, exact in (("OUTLINE", surface), ("PITCH", pitch)):
        points, segs, doc = arc_points(d / "cam.dxf", layer)
        H = hausdorff(exact, points, segs)
        assert H <= 0.01, (layer, H)
        assert H > 0.001          # arcs, not a dense polyline that hides the tolerance
    texts = [t.dxf.text for t in doc.modelspace().query("TEXT")]
    assert "cam valve: working surface and pitch curve as arcs, chordal tolerance 0.01 mm" in texts
    curves = next(p for p in summary["parts"] if p["part"] == "cam")["curves"]
    assert [c["max_deviation_mm"] <= 0.01 for c in curves] == [True, True]


def test_cam_roller_in_metres_open_profile_and_a_looser_tolerance(tmp_path):
    d, _ = export(tmp_path, M / "cam-roller.yaml", "--dxf", "--tolerance", "0.05")
    h, beta = 20.0, 2 * math.pi / 3                              # mm, rad

    def s(t):
        return h * (t / beta - np.sin(2 * np.pi * t / beta) / (2 * np.pi))
    th = np.linspace(0.0, beta, 200_001)
    surface, _ = roller_surface(s, 40.0, 10.0, th)
    points, segs, doc = arc_points(d / "cam.dxf", "OUTLINE")
    (pl,) = doc.modelspace().query('LWPOLYLINE[layer=="OUTLINE"]')
    assert not pl.closed                        # the law covers 0 to 120 deg only
    assert hausdorff(surface, points, segs) <= 0.05
    assert any("chordal tolerance 0.05 mm" in t.dxf.text for t in doc.modelspace().query("TEXT"))


def test_the_fit_holds_its_tolerance_on_an_ellipse():
    def ellipse(t):
        return np.c_[40 * np.cos(t), 25 * np.sin(t)]
    for tol in (0.1, 0.002):
        F = biarcs.fit(ellipse, 0.0, 2 * math.pi, True, tol)
        shape = geometry.Shape("poly", "OUTLINE", F.vertices, F.bulges, closed=True)
        segs = list(geometry.segments(shape))
        exact = ellipse(np.linspace(0, 2 * math.pi, 200_001))
        H = hausdorff(exact, geometry.sample(shape, 1e-3), segs)
        assert F.max_deviation <= tol and H <= tol, (tol, H)
        # tangent-continuous: each segment ends along the next one's start (an arc's tangents
        # are its chord's direction -/+ half its sweep)
        def ends(seg):
            p0, p1, b = seg
            chord, half = math.atan2(*(p1 - p0)[::-1]), 2 * math.atan(b)
            return chord - half, chord + half
        for a, b in zip(segs, segs[1:] + segs[:1]):
            assert abs(math.remainder(ends(a)[1] - ends(b)[0], 2 * math.pi)) < 1e-6


# -- gears --------------------------------------------------------------------------------------
def test_gear_blanks_pitch_and_outside_circles(tmp_path):
    d, _ = export(tmp_path, M / "planetary.yaml", "--dxf", "--module", "2")
    for part, r in (("sun", 40.0), ("planet", 20.0)):
        P, radii = holes(d / f"{part}.dxf", "PITCH")
        assert radii == [pytest.approx(r, abs=1e-12)] and same_points(P, [(0, 0)]) == 0
        _, radii = holes(d / f"{part}.dxf", "OUTLINE")
        assert radii == [pytest.approx(r + 2.0, abs=1e-12)]
    d, _ = export(tmp_path / "bare", M / "planetary.yaml", "--svg")
    assert "no module given: outside circle not drawn (--module)" in (d / "sun.svg").read_text()


# -- SVG ----------------------------------------------------------------------------------------
def test_svg_in_mm_and_its_circles_are_the_holes(four_bar):
    d, _ = four_bar
    for name in ("crank", "coupler", "layout"):
        root = ET.parse(d / f"{name}.svg").getroot()
        ns = {"s": "http://www.w3.org/2000/svg"}
        W, H = root.get("width"), root.get("height")
        assert W.endswith("mm") and H.endswith("mm")
        assert root.get("viewBox") == f"0 0 {W[:-2]} {H[:-2]}"
        X0, Y1 = map(float, re.search(r"X0 = (\S+), Y1 = (\S+)</desc>",
                                      (d / f"{name}.svg").read_text()).groups())
        (g,) = [g for g in root.findall("s:g", ns) if g.get("id") == "HOLES"]
        C = [(float(c.get("cx")) + X0, Y1 - float(c.get("cy"))) for c in g.findall("s:circle", ns)]
        same_points(C, holes(d / f"{name}.dxf")[0])


def svg_arcs(d: str, X0: float, Y1: float):
    """(centre in the drawing's coordinates, radius, large-arc flag) of every arc of an SVG path
    (the endpoint parameterisation's centre, SVG 1.1 F.6.5, for circles)."""
    tokens = re.findall(r"[MLAZ]|-?[\d.]+(?:e-?\d+)?", d)
    out, k, pos = [], 0, None
    while k < len(tokens):
        t = tokens[k]
        if t in "ML":
            pos, k = np.array(tokens[k + 1:k + 3], float), k + 3
        elif t == "A":
            r, large, sweep = float(tokens[k + 1]), int(tokens[k + 4]), int(tokens[k + 5])
            end = np.array(tokens[k + 6:k + 8], float)
            half = (pos - end) / 2
            root = math.sqrt(max(r * r / (half @ half) - 1.0, 0.0))
            c = (1 if large != sweep else -1) * root * np.array([half[1], -half[0]]) \
                + (pos + end) / 2
            out.append(((c[0] + X0, Y1 - c[1]), r, large))
            pos, k = end, k + 8
        else:
            k += 1
    return out


def test_svg_arcs_are_the_dxf_arcs(valve, four_bar):
    """Each arc of the SVG paths turns about the DXF arc's centre, and is the large or the small
    one as the DXF's: the sweep flags are right in SVG's downward y."""
    from ezdxf.math import bulge_to_arc
    for d, name in ((valve[0], "cam"), (four_bar[0], "coupler")):
        text = (d / f"{name}.svg").read_text()
        X0, Y1 = map(float, re.search(r"X0 = (\S+), Y1 = (\S+)</desc>", text).groups())
        root = ET.parse(d / f"{name}.svg").getroot()
        (g,) = [g for g in root if g.get("id") == "OUTLINE"]
        (path,) = list(g)
        got = svg_arcs(path.get("d"), X0, Y1)
        doc = ezdxf.readfile(d / f"{name}.dxf")
        (pl,) = doc.modelspace().query('LWPOLYLINE[layer=="OUTLINE"]')
        pts = pl.get_points("xyb")
        want = []
        for k, (x, y, *_, b) in enumerate(pts):
            if b:
                nxt = pts[(k + 1) % len(pts)]
                c, a0, a1, r = bulge_to_arc((x, y), nxt[:2], b)
                want.append(((c.x, c.y), r, int(4 * math.atan(abs(b)) > math.pi)))
        assert len(got) == len(want) > 0
        for (c, r, large), (cw, rw, lw) in zip(got, want):
            assert math.hypot(c[0] - cw[0], c[1] - cw[1]) < 1e-6 and r == pytest.approx(rw)
            assert large == lw


# -- bad input ----------------------------------------------------------------------------------
FOUR = str(M / "four-bar.yaml")


@pytest.mark.parametrize("args,message", [
    ([], "error: give --dxf, --svg or both: the formats to write"),
    (["--dxf", "--width", "5"], "error: --width 5 mm is not larger than the holes (pin 6 + "
     "clearance 0.1 = 6.1 mm): give a --width above 6.1 or a smaller --pin"),
    (["--dxf", "--tolerance", "0"], "error: --tolerance 0: must be a positive number of "
     "millimetres (the largest distance allowed between the drawn arcs and the exact cam "
     "profile)"),
    (["--svg", "--tolerance", "-0.01"], "error: --tolerance -0.01: must be a positive number of "
     "millimetres (the largest distance allowed between the drawn arcs and the exact cam "
     "profile)"),
    (["--dxf", "--body", "couplr"], f"error: --body 'couplr': no such body in {FOUR}; did you "
     f"mean 'coupler'? (its bodies: crank, coupler, rocker)"),
    (["--dxf", "--body", "ground"], "error: --body ground: ground is not a part (it is the "
     "frame the mechanism stands on); name a moving body"),
    (["--dxf", "--pose", "-1"], "error: --pose -1: must be a time from the analysis' start on "
     "(0 s)"),
    (["--svg", "--clearance", "-0.1"], "error: --clearance -0.1: must be 0 or more millimetres "
     "(added to the pin diameter for the holes)"),
])
def test_bad_options_are_refused_naming_the_fix(args, message, tmp_path):
    r = run_cli("export", FOUR, "--out", tmp_path, *args)
    assert (r.returncode, r.stderr.strip(), r.stdout) == (2, message, "")
    assert not list(tmp_path.iterdir())


def test_holes_that_would_overlap_or_leave_their_part_are_refused(tmp_path):
    r = run_cli("export", FOUR, "--out", tmp_path, "--svg", "--pin", "45", "--width", "50")
    assert (r.returncode, r.stderr.strip()) == (2, (
        f"{FOUR}: error: crank: the pins at (0, 0) and (40, 0) mm are 40 mm apart, not more "
        f"than the hole diameter 45.1 mm: their holes would overlap; give a smaller --pin"))
    cam = M / "valve-cam.yaml"               # base circle 30 mm: a 61.1 mm hole cuts it
    r = run_cli("export", cam, "--out", tmp_path, "--svg", "--pin", "61", "--width", "70")
    assert (r.returncode, r.stderr.strip()) == (2, (
        f"{cam}: error: cam: the hole at (0, 0) mm (61.1 mm) does not fit inside the cam's "
        f"outline; give a smaller --pin"))
    r = run_cli("export", cam, "--out", tmp_path, "--svg", "--pin", "12", "--width", "20")
    assert (r.returncode, r.stderr.strip()) == (2, (
        f"{cam}: error: cam 'valve': the roller (r 6 mm) is not larger than its bore (12.1 mm); "
        f"give a smaller --pin"))
    assert not list(tmp_path.iterdir())


def test_a_unit_without_a_size_is_refused_at_its_line(tmp_path):
    text = (M / "four-bar.yaml").read_text().replace("length: m,", "length: furlong,")
    (tmp_path / "m.yaml").write_text(text)
    r = run_cli("export", "m.yaml", "--svg", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.strip() == ("m.yaml:5: error: units: length 'furlong' has no known size, "
                                "so the drawings cannot be made in millimetres; write one of "
                                "cm, dm, ft, in, inch, km, m, micron, mm, um")


def test_a_directory_not_ours_is_left_alone_and_ours_is_replaced(tmp_path):
    foreign = tmp_path / "four-bar.drawings"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    r = run_cli("export", FOUR, "--out", tmp_path, "--svg")
    assert r.returncode == 2
    assert r.stderr.strip() == (f"{FOUR}: error: {foreign} exists and is not a planarkin result "
                                f"directory (no summary.json of ours): it is left alone; choose "
                                f"another --out or remove it")
    assert [p.name for p in foreign.iterdir()] == ["notes.txt"]
    d, _ = export(tmp_path / "again", FOUR, "--svg", "--body", "crank")
    d, summary = export(tmp_path / "again", FOUR, "--dxf", "--body", "rocker", "--body", "crank")
    assert sorted(p.name for p in d.iterdir()) == ["crank.dxf", "layout.dxf", "rocker.dxf",
                                                   "summary.json"]
    assert [p["part"] for p in summary["parts"]] == ["crank", "rocker"]
