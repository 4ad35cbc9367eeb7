"""Plates on the links of the six-bar and the Jansen leg (mechanisms/): in one layer, every
overlap a drawing of the plates shows is found, at the rows where it shows, and no other; in
separate layers nothing is checked (issue 29). The drawing is computed here independently: each
plate the convex hull of its pins' paths (points.csv) rounded by half its width, two plates
apart by the least distance of their edges (segment against segment, the textbook formula)."""

import re
from pathlib import Path

import numpy as np
import pytest

import planarkin
from planarkin.clearance.cycle import minima

ROOT = Path(__file__).resolve().parent.parent
WIDTH = {"jansen-leg": 6.0, "six-bar-sketch": 0.012}      # mm, m


def segment_distance(p1, q1, p2, q2):
    """Least distance (N,) between segments p1-q1 and p2-q2 (N, 2) (Ericson, Real-Time
    Collision Detection, 5.1.9), 0 where they cross."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e = (d1 * d1).sum(1), (d2 * d2).sum(1)
    f, c, b = (d2 * r).sum(1), (d1 * r).sum(1), (d1 * d2).sum(1)
    den = a * e - b * b
    s = np.where(den > 1e-30, np.clip((b * f - c * e) / np.where(den > 1e-30, den, 1), 0, 1), 0)
    t = (b * s + f) / e
    s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    gap = p1 + d1 * s[:, None] - (p2 + d2 * t[:, None])
    return np.hypot(gap[:, 0], gap[:, 1])


def inside_triangle(X, T):
    def side(a, b):
        return np.sign((b[:, 0] - a[:, 0]) * (X[:, 1] - a[:, 1]) -
                       (b[:, 1] - a[:, 1]) * (X[:, 0] - a[:, 0]))
    s = [side(T[0], T[1]), side(T[1], T[2]), side(T[2], T[0])]
    return (s[0] == s[1]) & (s[1] == s[2])


def drawn_distance(res, pins_a, pins_b, width):
    """(N,) distance of two plates (cores: segments or triangles of pins), 0 where they
    overlap, less the width."""
    P = [np.stack([res.point(n)["x"], res.point(n)["y"]], 1) for n in pins_a]
    Q = [np.stack([res.point(n)["x"], res.point(n)["y"]], 1) for n in pins_b]

    def edges(V):
        return [(V[0], V[1])] if len(V) == 2 else [(V[k], V[(k + 1) % 3]) for k in range(3)]
    d = np.min([segment_distance(a, b, c, e) for a, b in edges(P) for c, e in edges(Q)], axis=0)
    for V, W in ((P, Q), (Q, P)):
        if len(V) == 3:
            d = np.where(inside_triangle(W[0], V), 0.0, d)
    return d - width


def links_of(text):
    block = text.split("links:", 1)[1].split("\n\n", 1)[0]
    return {m.group(1): [p.strip() for p in m.group(2).split(",")]
            for m in re.finditer(r"^\s+([\w-]+):\s*\[([^\]]*)\]", block, re.M)}


def with_plates(name, layers=False):
    text = (ROOT / "mechanisms" / f"{name}.yaml").read_text()
    links = links_of(text)
    shapes = "".join(f"  {k}: {{plate: {WIDTH[name]}, pins: [{', '.join(pins)}], "
                     f"layer: {i if layers else 0}}}\n" for i, (k, pins) in enumerate(links.items()))
    return text + "\nshapes:\n" + shapes, links


@pytest.mark.parametrize("name", ["jansen-leg", "six-bar-sketch"])
def test_the_overlaps_a_drawing_shows_are_found(name):
    text, links = with_plates(name)
    cm = planarkin.load(f"{name}.yaml", text=text)
    res = planarkin.solve(cm, steps=180)
    found = {(m.a, m.b): m for m in minima(cm, res)}
    assert found, "no pair to check"
    shown = 0
    for (a, b), m in found.items():
        drawn = drawn_distance(res, links[a], links[b], WIDTH[name])
        over = drawn < -1e-9
        # where the drawing is clear of overlap, the distances agree exactly
        clear = drawn > 1e-9
        assert np.allclose(m.distance[clear], drawn[clear], rtol=0, atol=1e-9), (a, b)
        assert ((m.distance < 0) == over)[np.abs(drawn) > 1e-9].all(), (a, b)
        assert (m.contact is not None) == bool(over.any() or m.d <= 0), (a, b)
        shown += bool(over.any())
    assert shown, "the plates in one layer overlap somewhere in a drawing"
    assert any(w.kind == "contact" for w in res.warnings)


@pytest.mark.parametrize("name", ["jansen-leg", "six-bar-sketch"])
def test_none_where_the_layers_differ(name):
    text, _ = with_plates(name, layers=True)
    cm = planarkin.load(f"{name}.yaml", text=text)
    res = planarkin.solve(cm, steps=36)
    assert minima(cm, res) == [] and not [w for w in res.warnings if w.kind == "contact"]
