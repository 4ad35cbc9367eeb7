"""Belt or chain drive between two pulleys on fixed centres or a common carrier k.

An open belt turns both pulleys the same way: ri (phi_i - phi_k) - rj (phi_j - phi_k) = c; a
crossed belt (``crossed: true``) turns them opposite ways, ri (phi_i - phi_k) + rj (phi_j -
phi_k) = c, the gear relation of §3.1 with positive radii. ri, rj are the pitch radii of the
pulleys (sprockets); c is fixed by the given body angles. The belt's run and the centre distance
do not enter the kinematics (a belt that does not slip is a ratio); assembly checks that the
pulleys do not overlap.
"""

from __future__ import annotations

import numpy as np

from .base import Param
from .gear import Gear


class Belt(Gear):
    """The gear relation (g, grad, gamma of `Gear`) with the sign of rj set by `crossed`."""

    name = "belt"
    nbody = 3
    params = (
        Param("ri", "length", "pitch radius of pulley i, > 0"),
        Param("rj", "length", "pitch radius of pulley j, > 0"),
        Param("crossed", "flag", "true: a crossed belt (the pulleys turn opposite ways)",
              required=False, default=False),
    )
    summary = ("belt or chain drive on fixed centres or a common carrier k (default ground); "
               "`crossed: true` for a crossed belt (1 equation)")
    equations = ("ri (phi_i - phi_k) -+ rj (phi_j - phi_k) - c0 = 0 (- open, + crossed; c0 from "
                 "the given body angles)")

    @staticmethod
    def _radii(G):
        """The gear relation's coefficients: -rj for an open belt, +rj for a crossed one."""
        return G.params["ri"], np.where(G.params["crossed"] > 0.5, 1.0, -1.0) * G.params["rj"]

    def prepare(self, arrays, poses):
        pi_, pj, pk = (p[2] for p in poses)
        rj = (1.0 if arrays["crossed"] > 0.5 else -1.0) * arrays["rj"]
        return {}, [arrays["ri"] * (pi_ - pk) + rj * (pj - pk)]
