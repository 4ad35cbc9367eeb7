"""SVG files of the drawings: plain text, sized in millimetres (width and height in mm, the
viewBox in mm, so one user unit is one millimetre at true size).

SVG's y axis points down: a point (x, y) of the drawing is at (x - xmin, ymax - y) in the file;
coordinates are written with Python's repr (they read back to the same doubles). Arcs are path
arcs (A) of the polylines' bulges; one group per layer, its id the layer's name
(planarkin.export.geometry.LAYERS).
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import escape

from . import geometry as geo

STYLE = {   # layer -> stroke attributes
    geo.OUTLINE: 'stroke="black" stroke-width="0.25"',
    geo.HOLES: 'stroke="red" stroke-width="0.25"',
    geo.CENTRES: 'stroke="grey" stroke-width="0.13"',
    geo.PITCH: 'stroke="green" stroke-width="0.18" stroke-dasharray="3 1 0.5 1"',
}
MARGIN = 5.0            # mm around the drawing


def _n(x: float) -> str:
    return repr(float(x))


def _path(s: geo.Shape, X, Y) -> str:
    P = s.points
    d = [f"M {_n(X(P[0][0]))} {_n(Y(P[0][1]))}"]
    for p0, p1, b in geo.segments(s):
        end = f"{_n(X(p1[0]))} {_n(Y(p1[1]))}"
        if b == 0.0:
            d.append(f"L {end}")
            continue
        _, r, sweep = geo.arc_of(p0, p1, b)
        # counter-clockwise on the drawing is clockwise with y down: sweep-flag 0
        d.append(f"A {_n(r)} {_n(r)} 0 {int(abs(sweep) > math.pi)} {int(sweep < 0)} {end}")
    if s.closed:
        d.append("Z")
    return " ".join(d)


def text(shapes, texts, title: str = "") -> str:
    """The SVG document of shapes and texts (mm)."""
    boxes = [geo.extent(shapes)] if shapes else []
    boxes += [(t.at[0], t.at[1] - 0.3 * t.height, t.at[0] + 0.75 * t.height * len(t.text),
               t.at[1] + t.height) for t in texts]
    x0 = min(b[0] for b in boxes) - MARGIN
    y0 = min(b[1] for b in boxes) - MARGIN
    x1 = max(b[2] for b in boxes) + MARGIN
    y1 = max(b[3] for b in boxes) + MARGIN
    W, H = x1 - x0, y1 - y0

    def X(x):
        return x - x0

    def Y(y):
        return y1 - y

    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" width="{_n(W)}mm" height="{_n(H)}mm" '
           f'viewBox="0 0 {_n(W)} {_n(H)}">']
    if title:
        out.append(f"<title>{escape(title)}</title>")
    for layer, style in STYLE.items():
        out.append(f'<g id="{layer}" fill="none" {style}>')
        for s in shapes:
            if s.layer != layer:
                continue
            if s.kind == "circle":
                (cx, cy), r = s.points[0], s.r
                out.append(f'<circle cx="{_n(X(cx))}" cy="{_n(Y(cy))}" r="{_n(r)}"/>')
            elif s.kind == "line":
                (ax, ay), (bx, by) = s.points
                out.append(f'<line x1="{_n(X(ax))}" y1="{_n(Y(ay))}" x2="{_n(X(bx))}" '
                           f'y2="{_n(Y(by))}"/>')
            else:
                out.append(f'<path d="{_path(s, X, Y)}"/>')
        out.append("</g>")
    out.append(f'<g id="{geo.TEXT}" fill="blue" font-family="sans-serif">')
    for t in texts:
        out.append(f'<text x="{_n(X(t.at[0]))}" y="{_n(Y(t.at[1]))}" '
                   f'font-size="{_n(t.height)}">{escape(t.text)}</text>')
    out.append("</g>")
    out.append(f"<desc>millimetres; the drawing's point (x, y) is at (x - X0, Y1 - y): "
               f"X0 = {_n(x0)}, Y1 = {_n(y1)}</desc>")
    out.append("</svg>")
    return "\n".join(out) + "\n"


def write(path: Path, shapes, texts, title: str = "") -> None:
    Path(path).write_text(text(shapes, texts, title), encoding="utf-8")

