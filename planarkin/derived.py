"""Derived tables: the rooms fed by the Result (forces, measures, instant centres, ...).

Each room is a module with a function ``derived_tables(cm, opts) -> list[DerivedTable]``, listed
once in `ROOMS`. A model that needs none of a room's quantities gets ``[]`` from it and pays
nothing ("model only what a scene requires"). A derived table is computed from the same chunks
that fill bodies.csv (exact q, q', q'' on the grid, user units) and streamed chunk by chunk by the
same directory writer; its column statistics go into summary.json under ``columns`` and, when the
room gives an accumulator, its own section of summary.json. `Result.table(filename)` gives the
columns in memory.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

# modules with derived_tables(cm, opts); imported only when a model is run
ROOMS: tuple[str, ...] = ("planarkin.elements.cam", "planarkin.forces", "planarkin.measures",
                         "planarkin.measures.centres", "planarkin.clearance")


@dataclass
class DerivedTable:
    """One derived CSV table.

    filename: e.g. ``forces.csv``; header: ``t [s]`` first, every column with its unit in
    brackets; compute(chunk) -> (rows, len(header)) array, first column the chunk's t.
    section: key of the room's own summary.json section (None: none); accumulator(): a new object
    with add(X) (the computed rows) and as_dict() (JSON-ready), created in the process that writes
    the table. plot(cm, X, info, out, fmt) -> list of paths written, called once at the end with
    the table of the plot rows (every k-th row of the run, at most a few thousand).
    """

    filename: str
    header: list[str]
    compute: Callable[[Any], np.ndarray]
    section: str | None = None
    accumulator: Callable[[], Any] | None = None
    plot: Callable[..., list] | None = None


def row_checks(cm, opts) -> list:
    """The rooms' checks of every chunk before it is written (a room's optional
    ``row_checks(cm, opts)``): callables check(analysis, chunk) -> (row index, message[, event
    kind]) of the first row the room refuses (a non-finite force: 'non-finite', the default; a
    cam past its law's range: 'range'), or None; analysis.refuse stops the run there as at a
    non-finite coordinate."""
    out: list = []
    for name in ROOMS:
        f = getattr(importlib.import_module(name), "row_checks", None)
        if f is not None:
            out += f(cm, opts)
    return out


def path_figures(f) -> None:
    """The rooms' figures of a followed path (a room's optional ``path_figures(f)``, f the
    planarkin.solver.grid.PathFollower at the end of its run, called by planarkin.solver.singular): figures
    kept on f for the summary (the measures room's f.loops) and warnings added to f.warnings.
    Imported here by name, as the tables are, so that the solver reaches no room by import."""
    for name in ROOMS:
        hook = getattr(importlib.import_module(name), "path_figures", None)
        if hook is not None:
            hook(f)


def derived_tables(cm, opts) -> list[DerivedTable]:
    """Every derived table the model asks for, in room order."""
    out: list[DerivedTable] = []
    for name in ROOMS:
        out += importlib.import_module(name).derived_tables(cm, opts)
    names = [d.filename for d in out]
    assert len(set(names)) == len(names), f"two rooms write the same table: {names}"
    return out
