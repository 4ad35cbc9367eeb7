"""Instant centres against Kennedy's theorem on a four-bar and a slider-crank, computed here from
the closed-form pin positions (tests/reference_models.py) by intersecting lines."""

import numpy as np
import pytest

import planarkin

import reference_models as R
from closedforms import four_bar, slider_crank

TOL = 1e-12


def _intersect(P1, P2, Q1, Q2):
    """Intersection of line P1-P2 with line Q1-Q2 (arrays (N, 2))."""
    d1, d2 = P2 - P1, Q2 - Q1
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    s = ((Q1 - P1)[:, 0] * d2[:, 1] - (Q1 - P1)[:, 1] * d2[:, 0]) / den
    return P1 + s[:, None] * d1


def _centre(C, pair):
    return np.stack([C[f"{pair}.x"], C[f"{pair}.y"]], axis=1), C[f"{pair}.flag"]


def _close(got, want, scale):
    err = np.max(np.abs(got - want)) / scale
    assert err < TOL, err
    return err


@pytest.fixture(scope="module")
def fourbar():
    text = R.FOURBAR_DEG_YAML.replace('f: "360*t"', 'f: "360*t + 0.3*180/pi*sin(2*pi*t)"')
    text = text.replace("analysis:", "output: {centres: true}\nanalysis:")
    res = planarkin.solve(planarkin.load("fb.yaml", text=text), steps=90)
    assert res.success
    return res, res.table("centres.csv")


def test_fourbar_centres_kennedy(fourbar):
    res, C = fourbar
    a, b, c, d = (R.FOURBAR[k] for k in "abcd")
    th, thd, thdd = R.wobbly(res.t)
    th3, w3, al3, th4, w4, al4 = four_bar(th, thd, thdd, a, b, c, d)
    N = len(res.t)
    O2 = np.zeros((N, 2))
    O4 = np.tile([d, 0.0], (N, 1))
    A = np.stack([a * np.cos(th), a * np.sin(th)], axis=1)
    B = np.stack([d + c * np.cos(th4), c * np.sin(th4)], axis=1)
    # 1 ground, 2 crank, 3 coupler, 4 rocker: I12 = O2, I23 = A, I34 = B, I14 = O4
    scale = 0.13
    # at theta = 0 and 180 deg (A on the ground line) coupler and rocker turn alike: relative
    # rest, the centre is undefined and flagged 2
    rest = np.abs(w3 - w4) < 1e-9 * np.abs(w4)
    assert np.array_equal(np.nonzero(rest)[0], [0, 45, 90])
    for pair, want in (("ground/crank", O2), ("crank/coupler", A), ("coupler/rocker", B),
                       ("ground/rocker", O4)):
        got, flag = _centre(C, pair)
        if pair == "coupler/rocker":
            assert np.array_equal(flag == 2, rest) and not (flag == 1).any()
            assert np.isnan(got[rest]).all()
            got, want = got[~rest], want[~rest]
        else:
            assert not flag.any()
        _close(got, want, scale)
    # Kennedy: I13 on I12-I23 and on I14-I34; I24 on I12-I14 and on I23-I34
    I13 = _intersect(O2, A, O4, B)
    I24 = _intersect(O2, O4, A, B)
    far = np.maximum(np.max(np.abs(I13), axis=1), np.max(np.abs(I24), axis=1))
    ok = far < 1e3 * scale       # the centres run off to infinity near parallel lines
    for pair, want in (("ground/coupler", I13), ("crank/rocker", I24)):
        got, flag = _centre(C, pair)
        sz = np.maximum(np.max(np.abs(want), axis=1), scale)
        err = np.max(np.abs(got - want)[ok] / sz[ok, None])
        assert err < TOL, (pair, err)


SLIDER_TEXT = R.slider_crank_yaml("2*pi*t + 0.3*sin(2*pi*t)").replace(
    "analysis:", "output: {centres: true}\nanalysis:")


def test_slider_crank_centres_kennedy():
    res = planarkin.solve(planarkin.load("sc.yaml", text=SLIDER_TEXT), steps=100)
    C = res.table("centres.csv")
    a, b, e = (R.SLIDER_CRANK[k] for k in "abe")
    th, thd, thdd = R.wobbly(res.t)
    be = slider_crank(th, thd, thdd, a, b, e)[0]
    N = len(res.t)
    O = np.zeros((N, 2))
    A = np.stack([a * np.cos(th), a * np.sin(th)], axis=1)
    B = np.stack([a * np.cos(th) + b * np.cos(be), np.full(N, e)], axis=1)
    up = np.tile([0.0, 1.0], (N, 1))
    # 1 ground, 2 crank, 3 rod, 4 slider: I12 = O, I23 = A, I34 = B, I14 at infinity across
    # the guide. I13 = line O-A with the normal to the guide through B; I24 = the normal to
    # the guide through O with line A-B.
    I13 = _intersect(O, A, B, B + up)
    I24 = _intersect(O, O + up, A, B)
    for pair, want in (("ground/crank", O), ("crank/rod", A), ("rod/slider", B),
                       ("ground/rod", I13), ("crank/slider", I24)):
        got, flag = _centre(C, pair)
        ok = np.max(np.abs(want), axis=1) < 100.0      # I13 runs off where O-A is vertical
        assert not flag[ok].any(), pair
        sz = np.maximum(np.max(np.abs(want), axis=1), 0.25)
        err = np.max(np.abs(got - want)[ok] / sz[ok, None])
        assert err < TOL, (pair, err)
    got, flag = _centre(C, "ground/slider")     # pure translation: at infinity, said so
    assert np.all(flag == 1) and np.all(np.isnan(got))


def test_centres_only_when_asked():
    res = planarkin.solve(R.slider_crank_yaml() and planarkin.load(
        "sc.yaml", text=R.slider_crank_yaml()), steps=4)
    with pytest.raises(KeyError):
        res.table("centres.csv")


def test_centres_written_and_flag_documented(tmp_path):
    res = planarkin.solve(planarkin.load("sc.yaml", text=SLIDER_TEXT), steps=20)
    res.write(tmp_path / "out", plots=None)
    head = (tmp_path / "out" / "centres.csv").read_text().split("\n")[0].split(",")
    assert head[:4] == ["t [s]", "ground/crank.x [m]", "ground/crank.y [m]",
                        "ground/crank.flag [-]"]
    row = (tmp_path / "out" / "centres.csv").read_text().split("\n")[1].split(",")
    k = head.index("ground/slider.x [m]")
    assert row[k] == "nan" and row[k + 2] == "1.0"


def test_centrodes_figure(tmp_path, fourbar):
    from planarkin.measures import centres
    res, _ = fourbar
    X = centres.compute(res.model, res._chunk)
    files = centres._plot(res.model, X, res._chunk, tmp_path, "png")
    assert [f.name for f in files] == ["centres.png"]       # the coupler's centrodes only
