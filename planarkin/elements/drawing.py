"""What each kind's `draw` hook gives the mechanism figures: body-frame geometry, no matplotlib.

A kind knows how it looks (a revolute is a pin, a gear a pitch circle, a cam its profile); the
figures (planarkin.output.plots.scene) know how to draw pins, bars, dashed outlines and slide
axes. Between them is `Parts`: the scene makes one per figure, calls ``kind.draw(G, k, parts)``
for every instance k of every group G, and draws what the hooks put in it. Everything is in
user units (internal lengths times the model's length L), in the frame of the body named.
"""

from __future__ import annotations

import numpy as np


class Parts:
    """The drawing of a mechanism, collected from its elements (lists filled in element order).

    nb: moving bodies (ground is body nb); L: the model's length (internal -> user units);
    pivots: (body, other) -> the first revolute's point on body (internal units, body frame),
    `planarkin.elements.base.pivots`; phi: (N, nb) body angles over the run (rad).

    attach: per moving body, the points its outline spans (its frame origin first);
    joints: (body, s) joint points whose paths are drawn; pins: (body, s) pins on moving bodies;
    pivots_drawn: pins on ground (global points); links: (bi, si, bj, sj) distance links;
    slides: (bi, si, vi, bj, sj) sliding pairs (an axis on ground, a slot on a moving body);
    slide_dir: body -> the direction of its slide (a lone slider block is drawn along it);
    discs: (body, centre, r) pitch circles about a pivot;
    shaped: bodies drawn by their outlines (a gear, a disc, a cam), never as a slider block;
    outlines: (body, polyline) dashed lines (profiles, slots; ground's are drawn as axes);
    faces: (body, polyline) solid lines (a flat follower's face).
    """

    def __init__(self, nb: int, L: float, pivots: dict, phi: np.ndarray):
        self.ground = nb
        self.L = L
        self.pivot_points = pivots
        self.phi = phi
        self.attach = [[np.zeros(2)] for _ in range(nb)]
        self.joints: list = []
        self.pins: list = []
        self.pivots_drawn: list = []
        self.links: list = []
        self.slides: list = []
        self.slide_dir: dict = {}
        self.discs: list = []
        self.shaped: set = set()
        self.outlines: list = []
        self.surfaces: list = []      # the outlines that are a part's working surface (a cam)
        self.faces: list = []

    # -- what the hooks read ------------------------------------------------------------------
    def body(self, G, k: int, col: int) -> int:
        """The body in column col (0: i, 1: j, 2: k) of instance k."""
        return int(G.bodies[k, col])

    def point(self, G, k: int, name: str) -> np.ndarray | None:
        """Parameter name (a body-frame point or a length) of instance k in user units, or None
        when the kind has no such parameter."""
        return G.params[name][k] * self.L if name in G.params else None

    def pivot(self, body: int, other: int, origin: bool = True):
        """The point on body (its frame, user units) of the first revolute joining it to other:
        where a gear or a cam turns; when none does, the body's origin (None with
        origin=False)."""
        p = self.pivot_points.get((body, other))
        if p is None:
            return np.zeros(2) if origin else None
        return p * self.L

    # -- what the hooks add -------------------------------------------------------------------
    def joint_points(self, G, k: int) -> tuple:
        """The instance's si (on i) and sj (on j), where the kind has them: outline vertices of
        their bodies and traced paths. Returns (bi, si, bj, sj) (None for a missing point)."""
        bi, bj = self.body(G, k, 0), self.body(G, k, 1)
        si, sj = self.point(G, k, "si"), self.point(G, k, "sj")
        for b, s in ((bi, si), (bj, sj)):
            if s is not None and b != self.ground:
                self.attach[b].append(s)
                self.joints.append((b, s))
        return bi, si, bj, sj

    def axis_points(self, G, k, vi="vi", vj="vj") -> tuple:
        """As `joint_points`, for a kind whose si and sj are any points of a sliding axis (a
        translational joint: the sketch form puts them at the guide's reference pin, which may
        be far from both bodies): each is drawn at the foot of its body's frame origin on the
        axis (the axis through s along v, body frame), so that a one-pin slider is a block on
        its pin and the reference pin neither stretches the body nor the view. The points
        handed to `slide` must be the ones returned."""
        bi, bj = self.body(G, k, 0), self.body(G, k, 1)
        ends = []
        for b, name, v in ((bi, "si", vi), (bj, "sj", vj)):
            s = self.point(G, k, name)
            u = np.asarray(G.params[v][k], float)
            u = u / np.hypot(*u)
            s = s - (s @ u) * u                     # the foot of the origin (0, 0) on the axis
            if b != self.ground:
                self.attach[b].append(s)
                self.joints.append((b, s))
            ends.append(s)
        return bi, ends[0], bj, ends[1]

    def pin(self, body: int, s) -> None:
        """A pin at s: a pivot (triangle and pin) on ground, a pin marker on a moving body."""
        (self.pivots_drawn.append(s) if body == self.ground else self.pins.append((body, s)))

    def link(self, bi, si, bj, sj) -> None:
        """A thin straight link between si on bi and sj on bj (a distance constraint)."""
        self.links.append((bi, si, bj, sj))

    def slide(self, bi, si, vi, bj, sj) -> None:
        """Point sj of bj slides along the line through si with direction vi on bi."""
        self.slides.append((bi, si, vi, bj, sj))

    def slide_direction(self, body: int, v) -> None:
        """The direction (body frame) a lone block on body is drawn along (the first given)."""
        self.slide_dir.setdefault(body, v)

    def disc(self, body: int, r: float, carrier: int) -> None:
        """A pitch circle of radius r about body's pivot on carrier."""
        self.discs.append((body, self.pivot(body, carrier), r))
        self.shaped.add(body)

    def shape(self, body: int) -> None:
        """Body is drawn by its outlines (a disc, a cam profile): no slider block for it."""
        self.shaped.add(body)

    def outline(self, body: int, polyline, surface: bool = False) -> None:
        """A dashed outline of body (a slot, a pitch circle), or with surface its working
        surface (a cam's profile, a roller), drawn solid at the named instant only."""
        self.outlines.append((body, np.asarray(polyline, float)))
        if surface:
            self.surfaces.append(self.outlines[-1][1])

    def face(self, body: int, polyline) -> None:
        self.faces.append((body, np.asarray(polyline, float)))


def circle(centre, r, n=61) -> np.ndarray:
    """(n, 2) closed polyline of the circle of radius |r| about centre."""
    a = np.linspace(0.0, 2 * np.pi, n)
    return np.asarray(centre, float) + abs(r) * np.c_[np.cos(a), np.sin(a)]


def circle_with_mark(body, centre, r, parts: Parts) -> None:
    """A pitch circle and a radius mark along the body's x axis (which shows its rotation)."""
    parts.shape(body)
    parts.outline(body, circle(centre, r))
    parts.outline(body, np.array([centre, centre + (abs(r), 0.0)]))
