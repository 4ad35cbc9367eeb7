"""Variants started from a neighbour's solution: chains of variants, each analysed with the
warm start of its predecessor's path (planarkin.solver.warmstart: `Analysis(..., warm=Start)`, whose
nodes are taken only when they pass every test the path follower applies to a step).

A variant's results are those of `planarkin run` with its parameters to rounding (a warm start
that fails falls back to the ordinary path follower). Which neighbour starts which variant
depends only on the variant's position in its chain (see `chains`), never on how the chains are
distributed over processes: parallel runs equal the serial run bit for bit.
"""

from __future__ import annotations

from planarkin.solver.warmstart import Start

CHAIN = 32      # variants per chain: the first starts cold, each next from its predecessor


def analyse(cm, opts, start: Start | None = None):
    """planarkin.analysis's pipeline (in memory), started from a neighbour when one is given:
    the preflight and budgets, the grid pass and the refusal of rows of `planarkin run`.
    Returns (info, result, Start for the next variant or None, warm: whether it was used);
    raises InputError where `run` refuses the model before it starts."""
    from ..analysis import prepare, stream
    an = prepare(cm, opts, warm=start)
    info, res = stream(an)
    return info, res, Start.of(an), an.warmed


def chains(n: int, size: int = CHAIN) -> list[range]:
    """The variant indices 0..n-1 cut into chains of `size`: the unit of work of a process."""
    return [range(a, min(a + size, n)) for a in range(0, n, size)]
