"""Gear pair on fixed centres or on a common carrier (reference §3.1).

Signed pitch radii: ri, rj > 0 for external gears; the ring of an internal pair has a negative
radius. The centre distance |ri + rj| itself comes from other joints (revolutes to the carrier).
The phase constant is fixed by the body angles given in the model (the gears mesh as drawn).
"""

from __future__ import annotations

import numpy as np

from .base import Kind, Param


class Gear(Kind):
    name = "gear"
    nbody = 3
    params = (
        Param("ri", "length", "signed pitch radius of gear i (negative for an internal ring gear)"),
        Param("rj", "length", "signed pitch radius of gear j (negative for an internal ring gear)"),
    )
    summary = ("gear pair on fixed centres or a common carrier k (default ground): "
               "ri (phi_i - phi_k) + rj (phi_j - phi_k) = c (1 equation)")
    equations = "ri (phi_i - phi_k) + rj (phi_j - phi_k) - c0 = 0 (c0 from the given body angles)"

    @staticmethod
    def _radii(G):
        """The coefficients of phi_i and phi_j (a belt changes the sign of rj)."""
        return G.params["ri"], G.params["rj"]

    def g(self, G, F):
        bi, bj, bk = G.bodies[:, 0], G.bodies[:, 1], G.bodies[:, 2]
        ri, rj = self._radii(G)
        pk = F.q[:, 3 * bk + 2]
        return (ri * (F.q[:, 3 * bi + 2] - pk) + rj * (F.q[:, 3 * bj + 2] - pk))[..., None]

    def grad(self, G, F):
        ri, rj = self._radii(G)
        out = np.zeros((F.q.shape[0], len(G), 1, 9))
        out[..., 0, 2] = ri
        out[..., 0, 5] = rj
        out[..., 0, 8] = -(ri + rj)
        return out

    def gamma(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 1))

    def jerk(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 1))
