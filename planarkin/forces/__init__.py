"""Forces: driving efforts, joint reactions and power of a kinematically driven mechanism.

The room of `planarkin.derived` that writes ``forces.csv`` (and ``forces.png`` and the ``forces``
section of summary.json) and ``loads.csv`` (every joint's reaction in the ground frame and in
its bodies' frames, and the ``loads`` section) when the model gives any mass, load, spring or
damper. Modules: `keys` (validating the YAML keys), `units` (the force, mass and system units
of the units: section, and the unit of every output), `model` (the mass and load data as
arrays), `solve` (the Lagrange multipliers and the reactions), `check` (each chunk's refusals
and warnings), `output` (tables, summary, plot), `loads` (loads.csv's columns and summary),
`figures` (the how-to's figure of a gear pair's tooth force).
"""

from __future__ import annotations


def derived_tables(cm, opts):
    """[the forces.csv and loads.csv DerivedTables] when the model has masses or loads, else []
    (no cost)."""
    from .model import has_forces
    # forces need accelerations: a run up to velocities (output: up_to) computes none
    if not has_forces(cm) or opts.order < 2:
        return []
    from .output import force_tables
    return force_tables(cm, opts)


def row_checks(cm, opts):
    """[the check of every chunk before it is written] (planarkin.forces.check) when the model
    has forces, else []."""
    from .model import has_forces
    if not has_forces(cm) or opts.order < 2:
        return []
    from .check import RowCheck
    return [RowCheck(cm, opts)]
