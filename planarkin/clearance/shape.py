"""A body's outline for interference and clearance (issue 29): what the figures draw and the
distances are measured between.

Every shape is a rounded point set: the set of points within `radius` of the filled simple
polygon through `points` in order (closed=True; the plate around a link's pins is the convex hull
of its pins, computed when the model is compiled) or of the polyline through them (closed=False: a
wall, a housing outline, a guide). One point is a circle, two a capsule (a two-pin link's plate),
three or more a rounded plate, or with radius 0 a polygon. Holes are drawn, not measured:
a pin in its hole never counts as contact.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Shape:
    """One outline, fixed to one body.

    body: index of the body (0..nb-1; nb is ground: frame obstacles). name: the body's (or the
    obstacle's) name, as messages and columns name it. points: (k, 2) body-frame coordinates,
    internal length units (as CompiledModel.point_s). radius: >= 0, internal length units.
    closed: True for a filled region (the polygon through points, in order, rounded), False for a polyline (rounded).
    holes: ((x, y, diameter), ...) body frame, internal units, drawn only. layer: (lo, hi) z range;
    two shapes can touch only where their ranges overlap (a single level is lo == hi).
    source: (file, line) of the key that declared it, for messages.
    """

    body: int
    name: str
    points: np.ndarray
    radius: float = 0.0
    closed: bool = True
    holes: tuple = ()
    layer: tuple = (0.0, 0.0)
    source: tuple = field(default=("", 0))
