"""Where the names go in mechanism.<fmt>: each label beside its anchor, clear of the pins, the
ground pivots and the labels placed before it.

Labels are placed in points on the page (the equal-aspect axes' data -> points map at its final
limits), their boxes measured by the renderer: a body's name first tries just above the body's
centre, a point's name just below right of the point (where both stood before), then the other
sides, further out each round. The first place that meets nothing wins; when every place meets
something, the one that covers least (a small crank in a crowd of pins). A label pushed away
from its anchor gets a thin leader line to it.
"""

from __future__ import annotations

import numpy as np

from .style import FONT

PAD = 0.15                     # the label boxes' pad (fraction of the font size), as drawn
GAP = 1.0                      # space kept around each label box, points
PIN = 4.5                      # half the side of the square a pin marker covers, points
LEADER = 22.0                  # a label whose centre is further than this (points) gets a line
ROUNDS = ((6, 9), (12, 17), (20, 26), (30, 36), (42, 48), (56, 62))   # (across, up), points
BODY_SIDES = ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (-1, 1), (1, -1), (-1, -1))
POINT_SIDES = ((1, -1), (1, 1), (-1, -1), (-1, 1), (1, 0), (-1, 0), (0, -1), (0, 1))


def text_box(s: str, bold: bool) -> tuple:
    """(width, height) in points of label s at FONT pt with its box and GAP around it."""
    from matplotlib.font_manager import FontProperties

    from .render import renderer_class
    renderer = renderer_class()(1, 1, 72)
    w, h, _ = renderer.get_text_width_height_descent(
        s, FontProperties(size=FONT, weight="bold" if bold else "normal"), False)
    return w + 2 * (PAD * FONT + GAP), h + 2 * (PAD * FONT + GAP)


def to_points(ax, xy) -> np.ndarray:
    """(k, 2) data points -> points on the page, at the axes' final (equal-aspect) limits."""
    ax.apply_aspect()
    return ax.transData.transform(np.asarray(xy, float).reshape(-1, 2)) * 72.0 / ax.figure.dpi


def _overlap(a, b) -> float:
    """Area shared by boxes a and b, (x0, y0, x1, y1) each."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return w * h if w > 0 and h > 0 else 0.0


def place(ax, labels, obstacles) -> list:
    """Offsets (dx, dy) in points of each label's centre from its anchor.

    labels: [(text, anchor (2,) data, is a body name)], placed in order; obstacles: boxes
    (x0, y0, x1, y1) in points that no label should cover (pins, pivots)."""
    x0, y0, x1, y1 = np.asarray(ax.bbox.extents) * 72.0 / ax.figure.dpi
    taken = list(obstacles)
    out = []
    for text, anchor, body in labels:
        w, h = text_box(text, body)
        a = to_points(ax, anchor)[0]
        best = None
        for across, up in ROUNDS:
            for sx, sy in (BODY_SIDES if body else POINT_SIDES):
                dx, dy = sx * (across + w / 2), sy * up
                c = a + (dx, dy)
                box = (c[0] - w / 2, c[1] - h / 2, c[0] + w / 2, c[1] + h / 2)
                inside = _overlap(box, (x0, y0, x1, y1))
                cost = sum(_overlap(box, o) for o in taken) + (w * h - inside)
                if best is None or cost < best[0] - 1e-9:
                    best = (cost, (dx, dy), box)
                if cost <= 0:
                    break
            if best[0] <= 0:
                break
        taken.append(best[2])
        out.append(best[1])
    return out


def pin_boxes(ax, points) -> list:
    """Boxes (points on the page) covered by pin markers at the data points (k, 2)."""
    P = to_points(ax, points) if len(points) else np.zeros((0, 2))
    return [(x - PIN, y - PIN, x + PIN, y + PIN) for x, y in P]


def pivot_boxes(ax, pivots, h) -> list:
    """Boxes covered by the ground pivots drawn at the data points (triangle and hatching,
    h the triangle's height in data units, `plane.mechanism_axes`)."""
    out = []
    for px, py in pivots:
        (a, b), (c, d) = to_points(ax, [(px - 0.9 * h, py - 1.35 * h), (px + 0.9 * h, py)])
        out.append((a, b, c, d))
    return out
