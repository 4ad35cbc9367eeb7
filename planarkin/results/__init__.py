"""Results of an analysis: the run's account (`RunInfo`) and the arrays (`Result`, SciPy-style).

This module holds results only: the passes that produce them (prepare, the grid pass into a
sink or a Result, the refusal of rows) are `planarkin.analysis`'s, and nothing here writes a
file except through `Result.write` (the output contract's door, imported when called).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pathlib import Path

import numpy as np

from planarkin.derived import derived_tables
from .runinfo import RunInfo
from planarkin.solver.chunks import Chunk

if TYPE_CHECKING:          # annotations only: the model is compiled before the solver runs
    from planarkin.model.compile import CompiledModel

__all__ = ["Result", "RunInfo"]


class Result:
    """What `planarkin.solve` returns: arrays on the grid (user units) and the run's diagnostics.

    t: (N,) s. q, qd, qdd: (N, 3 nb) per body x, y, phi and derivatives (None above the
    computed order); qddd: their jerks (up_to: jerk; else None). p, pd, pdd (pddd): (N, P, 2)
    points. iterations, cond, residual: (N,) per step.
    status: 0 ok, 1 analysis failure (arrays hold the results up to the failure); message;
    event (why it stopped), warnings (near-singular passages, redundancies), info (RunInfo).
    """

    def __init__(self, model: CompiledModel, chunk: Chunk | None, info: RunInfo):
        self.model = model
        self.info = info
        self.status = info.status
        self.message = info.message
        self.event = info.event
        self.warnings = info.warnings
        if chunk is None:
            n, P = model.n, len(model.point_names)
            z = lambda *s: np.zeros((0,) + s)
            chunk = Chunk(z(), z(n), z(n), z(n), z(P, 2), z(P, 2), z(P, 2),
                          np.zeros(0, int), z(), z())
        self._chunk = chunk
        for name in ("t", "q", "qd", "qdd", "p", "pd", "pdd", "iterations", "cond", "residual",
                     "qddd", "pddd"):
            setattr(self, name, getattr(chunk, name))
        if info.options.order >= 3 and self.qddd is None:      # no row: empty jerk arrays
            self.qddd, self.pddd = np.zeros_like(self.q), np.zeros_like(self.p)

    @property
    def success(self) -> bool:
        return self.status == 0

    def body(self, name: str) -> dict:
        """Columns of one body: x, y, phi, vx, vy, omega, ax, ay, alpha (and with up_to: jerk
        jx, jy, jphi) (user units)."""
        b = _index(self.model.body_names, name, "body")
        out = {}
        for arr, keys in ((self.q, ("x", "y", "phi")), (self.qd, ("vx", "vy", "omega")),
                          (self.qdd, ("ax", "ay", "alpha")), (self.qddd, ("jx", "jy", "jphi"))):
            if arr is not None:
                for k, key in enumerate(keys):
                    out[key] = arr[:, 3 * b + k]
        return out

    def point(self, name: str) -> dict:
        """Columns of one point: x, y, vx, vy, ax, ay (and jx, jy) (user units)."""
        k = _index(self.model.point_names, name, "point")
        out = {}
        for arr, keys in ((self.p, ("x", "y")), (self.pd, ("vx", "vy")), (self.pdd, ("ax", "ay")),
                          (self.pddd, ("jx", "jy"))):
            if arr is not None:
                out[keys[0]], out[keys[1]] = arr[:, k, 0], arr[:, k, 1]
        return out

    def table(self, filename: str) -> dict:
        """Columns of a derived table (e.g. ``forces.csv``) by header name without the unit
        (``{"t": ..., "crank-driver.torque": ...}``), computed from this result's arrays."""
        for d in derived_tables(self.model, self.info.options):
            if d.filename == filename:
                X = d.compute(self._chunk)
                return {h.split(" [", 1)[0]: X[:, k] for k, h in enumerate(d.header)}
        from planarkin.diagnostics import did_you_mean
        names = [d.filename for d in derived_tables(self.model, self.info.options)]
        raise KeyError(f"this result has no table '{filename}'"
                       f"{did_you_mean(filename, names) or ' (derived tables: ' + (', '.join(names) or 'none') + ')'}")

    def forces(self, name: str) -> dict:
        """Forces of one driver, joint or of ``total`` / ``shaking`` (models with masses or
        loads): its forces.csv columns without the name and unit, e.g. ``{"fx": ..., "fy": ...}``
        for a revolute joint, ``{"torque": ..., "power": ...}`` for an angle driver (units as in
        forces.csv: N, N*m, W when lengths are m)."""
        from planarkin.diagnostics import did_you_mean
        if not any(d.filename == "forces.csv" for d in derived_tables(self.model,
                                                                         self.info.options)):
            raise KeyError("this result has no forces: the model gives no mass, inertia or load "
                           "(or the run stopped at velocities)")
        cols = self.table("forces.csv")
        out = {k.rsplit(".", 1)[1]: v for k, v in cols.items() if k.rsplit(".", 1)[0] == name}
        if not out:
            names = list(dict.fromkeys(k.rsplit(".", 1)[0] for k in cols if k != "t"))
            raise KeyError(f"no forces named '{name}'"
                           f"{did_you_mean(name, names) or ' (names: ' + ', '.join(names) + ')'}")
        return out

    def write(self, out: str | Path, plots: str | None = "png", animate: bool = False,
              x: str | None = None, table_format: str | None = None) -> dict:
        """Write bodies.csv, points.csv, summary.json (and plots) into directory out, under the
        same output contract as `planarkin run` (raises planarkin.InputError when out is
        being written by another run, is not a planarkin result directory, or cannot be
        written); returns the summary. x: abscissa of the time-history plots, "time" or
        "driver" (default: the model's output: x). table_format: "csv" or "parquet" (bodies.parquet
        ...; needs pyarrow; default: the model's output: table_format)."""
        from planarkin.diagnostics import Diagnostic, InputError
        from planarkin.output.directory import OutputError
        from planarkin.output.writer import DirectoryWriter
        if x is not None:
            from planarkin.model.spec import X_AXES, x_axis_problem
            problem = (f"x must be one of {', '.join(X_AXES)}, not {x!r}" if x not in X_AXES
                       else x_axis_problem(x, self.model.spec, "x"))
            if problem:
                raise InputError([Diagnostic(self.model.spec.file, None, problem)])
        if table_format is not None:
            from planarkin.model.spec import table_format_problem
            problem = table_format_problem(table_format, "table_format")
            if problem:
                raise InputError([Diagnostic(self.model.spec.file, None, problem)])
        try:
            w = DirectoryWriter(self.model, Path(out), self.info.options, plots=plots,
                                animate=animate, x=x, table_format=table_format)
        except OutputError as e:
            raise InputError([Diagnostic(self.model.spec.file, None, f"write(): {e}")]) from None
        w.add(self._chunk)
        return w.finish(self.info)

    def __repr__(self) -> str:
        return (f"<Result {self.model.spec.name}: {'ok' if self.success else 'failed'}, "
                f"{len(self.t)} rows, {self.message}>")


def _index(names, name: str, what: str) -> int:
    """Position of name in names; an unknown name raises KeyError with a suggestion."""
    try:
        return list(names).index(name)
    except ValueError:
        from planarkin.diagnostics import did_you_mean
        hint = did_you_mean(name, names) or f" ({what} names: {', '.join(names) or 'none'})"
        raise KeyError(f"no {what} '{name}' in this model{hint}") from None
