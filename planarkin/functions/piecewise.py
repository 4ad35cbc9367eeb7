"""Piecewise functions of one argument with exact derivatives of every order: the motion laws
(planarkin.functions.laws) and tabulated motions (planarkin.functions.inputtable) are built from them.

A piece on [k_i, k_i+1) is poly(w) + sum(a*sin(omega*w) + b*cos(omega*w)) in the local variable
w = x - k_i; the piece below the first knot and the one from the last knot on are given too (a
law holds 0 before and 1 after; a table extends its end polynomials). Derivatives act on the
coefficients (polynomial: exact; sinusoid: (a, b) -> (-b*omega, a*omega)), so an order-k
derivative is evaluated with the same rounding as the value. Used in expressions as
``Expr('pw', (u,), (piecewise, order))``: the expression layer chooses the piece (one-sided at a
knot), this module evaluates it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Piece", "Piecewise"]


class Piece:
    """poly (coefficients, highest power first, as numpy.polyval) and sinusoids
    ((a, b, omega), ...) in the local variable w = x - origin."""

    __slots__ = ("poly", "sines", "origin")

    def __init__(self, poly, sines=(), origin: float = 0.0):
        self.poly = np.atleast_1d(np.asarray(poly, dtype=float))
        self.sines = tuple((float(a), float(b), float(w)) for a, b, w in sines)
        self.origin = float(origin)

    def derivative(self) -> "Piece":
        poly = np.polyder(self.poly) if len(self.poly) > 1 else np.zeros(1)
        return Piece(poly, [(-b * w, a * w, w) for a, b, w in self.sines], self.origin)

    def integral(self, value_at_origin: float) -> "Piece":
        """The antiderivative that equals value_at_origin at w = 0."""
        poly = np.polyint(self.poly)
        sines = [(b / w, -a / w, w) for a, b, w in self.sines]
        poly[-1] = value_at_origin - sum(b for _, b, _ in sines)
        return Piece(poly, sines, self.origin)

    def __call__(self, x):
        w = np.asarray(x, dtype=float) - self.origin
        c = self.poly
        if len(c) == 1:
            r = np.full(w.shape, c[0])
        else:
            r = c[0] * w + c[1]
            for k in range(2, len(c)):  # Horner
                r = r * w + c[k]
        for a, b, om in self.sines:
            r = r + (a * np.sin(om * w) if a else 0.0) + (b * np.cos(om * w) if b else 0.0)
        return r


class Piecewise:
    """pieces[0] below knots[0], pieces[i + 1] on [knots[i], knots[i + 1]), pieces[-1] from
    knots[-1] on. name is how the function prints in expressions: it must be unique, since
    printed trees are the keys of shared sub-expressions. switch_knots (optional attribute):
    the knots where a derivative up to the second may jump (default: all knots)."""

    def __init__(self, name: str, knots, pieces):
        self.name = name
        self.knots = np.asarray(knots, dtype=float)
        if len(pieces) != len(self.knots) + 1:
            raise ValueError("need one piece more than knots")
        self._orders = [list(pieces)]
        self._poly = None

    def __reduce__(self):
        state = {"switch_knots": self.switch_knots} if hasattr(self, "switch_knots") else None
        return (Piecewise, (self.name, self.knots, self._orders[0]), state)

    def __setstate__(self, state):
        self.__dict__.update(state or {})

    def pieces(self, order: int) -> list:
        while len(self._orders) <= order:
            self._orders.append([p.derivative() for p in self._orders[-1]])
        return self._orders[order]

    def nearest_knot(self, x: np.ndarray):
        """(j, x - knots[j]) for the knot nearest to each x (arrays of x's shape)."""
        K = self.knots
        j = np.clip(np.searchsorted(K, x), 0, len(K) - 1)
        lower = np.maximum(j - 1, 0)
        with np.errstate(invalid="ignore"):
            closer = np.abs(x - K[lower]) < np.abs(x - K[j])
        j = np.where(closer, lower, j)
        return j, x - K[j]

    def evaluate(self, x: np.ndarray, order: int, piece: np.ndarray) -> np.ndarray:
        """The order-th derivative at x, piece[i] + 1 being the index into pieces (so
        piece = j for x just right of knot j and j - 1 just left of it)."""
        x = np.asarray(x, dtype=float)
        sel = np.asarray(piece, dtype=np.int64) + 1
        count = len(self.knots) + 1
        if count <= 8 and (len(sel) == 1 or (sel == sel[0]).all()):  # one piece (the usual)
            P = self.pieces(order)
            k = int(sel[0])
            return P[k](x) if 0 <= k < len(P) else np.full(x.shape, np.nan)
        out = np.full(x.shape, np.nan)
        if count > 8 and self._table(order) is not None:
            C, O = self._table(order)
            ok = (sel >= 0) & (sel < count)
            s = sel[ok]
            w = x[ok] - O[s]
            r = C[s, 0].copy()
            for c in range(1, C.shape[1]):
                r = r * w + C[s, c]
            out[ok] = r
            return out
        P = self.pieces(order)
        for k in range(len(P)):
            m = sel == k
            if m.any():
                out[m] = P[k](x[m])
        return out

    def interior_ends(self, order: int) -> np.ndarray:
        """(len(knots) - 1, 2): the order-th derivative at the start and at the end of every
        piece between the first and the last knot (each piece from its own side)."""
        K = self.knots
        if len(K) < 2:
            return np.zeros((0, 2))
        j = np.arange(len(K) - 1)
        x0, x1 = K[:-1], K[1:]
        return np.stack([self.evaluate(x0, order, j), self.evaluate(x1, order, j)], axis=1)

    def _table(self, order: int):
        """(coefficients (pieces, degree + 1), origins) when no piece has sinusoids."""
        if self._poly is None:
            self._poly = {}
        if order not in self._poly:
            below = self._table(order - 1) if order > 0 else None
            if below is not None:
                # the derivative of every piece at once, with np.polyder's products: a table's
                # pieces one by one as Piece objects are a Python call per piece and order
                C, O = below
                deg = C.shape[1] - 1
                D = C[:, :-1] * np.arange(deg, 0, -1, dtype=float) if deg else np.zeros_like(C)
                self._poly[order] = (D, O)
                return self._poly[order]
            P = self.pieces(order)
            if any(p.sines for p in P):
                self._poly[order] = None
            else:
                deg = max(len(p.poly) for p in P)
                C = np.zeros((len(P), deg))
                for i, p in enumerate(P):
                    C[i, deg - len(p.poly):] = p.poly
                self._poly[order] = (C, np.array([p.origin for p in P]))
        return self._poly[order]
