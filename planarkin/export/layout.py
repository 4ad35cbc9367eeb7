"""The layout sheet: every part side by side in rows, none overlapping, with gaps between them.

Each part is turned by its angle (0: as in its own file, its body frame; with --pose the body's
angle at that time) and boxed with its text. The boxes are shelved first fit by decreasing
height: the tallest opens the first row at the top, each next one goes left to right into the
first row with room for it within the sheet's width, else opens a row below; of the widths
tried (from the widest box to all in one row) the one that fits the smallest sheet 1.4 times
as wide as high is kept. A row is as high as its first box, so no two boxes overlap; the
sheet's lower left corner is the origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import geometry as geo
from .drawings import labels, text_width

ASPECT = 1.4             # width / height of the sheet the rows aim at
TRIES = 24               # sheet widths tried, from the widest part to all in one row


@dataclass(frozen=True)
class Placement:
    """Where a part goes on the sheet: turned by angle (rad) about its frame's origin, then
    moved by offset (mm); box: (xmin, ymin, xmax, ymax) of it and its text there."""

    angle: float
    offset: tuple
    box: tuple


def _box(shapes, notes, height) -> tuple:
    """The extent of shapes and of their text (drawings.labels)."""
    x0, y0, x1, y1 = geo.extent(shapes)
    T = labels(shapes, notes, height)
    if T:
        y0 = min(t.at[1] for t in T) - 0.4 * height
        x1 = max(x1, max(t.at[0] + text_width(t.text, height) for t in T))
    return x0, y0, x1, y1


def arrange(parts, angles: dict, gap: float, height: float) -> list[Placement]:
    """A placement per part (parts: drawings' Parts; angles: part name -> angle, rad; gap: the
    space between boxes, mm)."""
    boxes = []
    for p in parts:
        a = float(angles.get(p.name, 0.0))
        boxes.append((a, _box([geo.moved(s, a, (0.0, 0.0)) for s in p.shapes], p.notes, height)))
    widest = max(b[2] - b[0] for _, b in boxes)
    total = sum(b[2] - b[0] + gap for _, b in boxes)
    # the sheet's width: of the widths tried, the one whose rows fit the smallest sheet of
    # ASPECT (width / height)
    best = None
    for k in range(TRIES + 1):
        width = widest + (total - widest) * k / TRIES
        placed = _shelve(boxes, width, gap)
        W = max(p.box[2] for p in placed)
        H = -min(p.box[1] for p in placed)
        score = max(W, ASPECT * H)
        if best is None or score < best[0] - 1e-9:
            best = (score, placed)
    out = best[1]
    lift = -min(p.box[1] for p in out)                 # lower left corner at the origin
    return [Placement(p.angle, (p.offset[0], p.offset[1] + lift),
                      (p.box[0], p.box[1] + lift, p.box[2], p.box[3] + lift)) for p in out]


def _shelve(boxes, sheet: float, gap: float) -> list:
    """First fit by decreasing height into rows of the given width, the first row's top at
    y = 0: the tallest box opens the first row, each box goes into the first row with room for
    it, else opens a row below."""
    order = sorted(range(len(boxes)), key=lambda i: -(boxes[i][1][3] - boxes[i][1][1]))
    rows: list = []                                     # [top, height, x of the next box]
    out: list = [None] * len(boxes)
    for i in order:
        a, (x0, y0, x1, y1) = boxes[i]
        w, h = x1 - x0, y1 - y0
        row = next((r for r in rows if r[2] + w <= sheet + 1e-9), None)
        if row is None:
            top = rows[-1][0] - rows[-1][1] - gap if rows else 0.0
            row = [top, h, 0.0]
            rows.append(row)
        x, top = row[2], row[0]
        out[i] = Placement(a, (x - x0, top - y1), (x, top - h, x + w, top))
        row[2] = x + w + gap
    return out


def sheet(parts, placements, height: float) -> tuple[list, list]:
    """(shapes, texts) of the whole sheet (text height, mm)."""
    shapes, texts = [], []
    for p, pl in zip(parts, placements):
        moved = [geo.moved(s, pl.angle, pl.offset) for s in p.shapes]
        shapes += moved
        texts += labels(moved, p.notes, height)
    return shapes, texts


def hole_centres(part, pl: Placement) -> np.ndarray:
    """Where the part's holes are on the sheet."""
    return geo.placed_points(part.holes, pl.angle, pl.offset)
