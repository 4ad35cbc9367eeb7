"""Variants of one model: parameter values in, status and metrics out.

A `Study` reads the model file once and resolves the metrics against the nominal model; each
variant is then validated with its overrides (so every dependent parameter and number follows),
compiled and solved in process. A variant that cannot be assembled is 'invalid' with the
reason; one whose analysis stops (lock-up, bifurcation) is 'failed' with the kind and time of the
event: both are results of the study, kept in its table, never exceptions.

Metrics are ``KIND:COLUMN``: KIND one of `KINDS`, COLUMN a column of bodies.csv or points.csv
without its unit (``slider.ax``, ``P.y``) or of a derived table the model writes (forces.csv,
measures.csv, ...), e.g. ``max:slider.ax``, ``stroke:slider.x``. A column's largest and smallest
values are refined between the grid rows from its exact rate and acceleration by the function
`planarkin run`'s cycle figures use (planarkin.measures.extremes.extreme), so a study's metric of
the nominal model is run's figure; a column without a rate in its table (an acceleration, a
force, a ratio measure), and dev, are taken at the grid. ``min_clearance`` is short for
``min:clearance`` (the least distance of any two shapes that can touch, clearance.csv) and
``min_clearance:A|B`` for one pair's, ``min:A|B``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..diagnostics import Diagnostic, InputError, did_you_mean
from ..measures.extremes import GRID_ONLY, derivative_columns, extreme
from .outcome import Outcome

KINDS = {
    "max": "largest value (refined between the grid rows, as run's cycle figures)",
    "min": "smallest value (refined between the grid rows)",
    "stroke": "max - min",
    "absmax": "largest magnitude",
    "dev": "largest distance of a point's path from its nominal path, at the same (grid) times",
}
STATUSES = ("ok", "failed", "invalid")


@dataclass(frozen=True)
class Metric:
    kind: str
    column: str          # without unit: 'slider.ax'
    source: str          # 'bodies.csv', 'points.csv' or a derived table's file name
    index: int           # column in that table
    unit: str

    @property
    def label(self) -> str:
        return f"{self.kind}:{self.column} [{self.unit}]" if self.unit else \
            f"{self.kind}:{self.column}"

    def value(self, t, col, rate=None, acc=None):
        """The metric of columns col (..., N) sampled at times t (N,), refined between the rows
        from their exact rate and acceleration when given (planarkin.measures.extremes; for
        dev: the distances, at the grid). A float for one column, else an array."""
        col = np.asarray(col, dtype=float)
        if col.shape[-1] == 0:
            out = np.full(col.shape[:-1], np.nan)
        elif self.kind == "dev":
            out = np.max(col, axis=-1)
        elif self.kind in ("max", "min"):
            out = extreme(t, col, rate, acc, 1.0 if self.kind == "max" else -1.0)[1]
        else:
            hi, lo = (extreme(t, col, rate, acc, sense)[1] for sense in (1.0, -1.0))
            out = hi - lo if self.kind == "stroke" else np.fmax(hi, -lo)
        return float(out) if np.ndim(out) == 0 else out

    @property
    def position(self) -> bool:
        """Whether the column is a position (x, y, phi of a body or x, y of a point): the
        quantities with exact sensitivities."""
        return self.source in ("bodies.csv", "points.csv") and \
            self.column.rsplit(".", 1)[-1] in ("x", "y", "phi") and self.kind != "dev"


def tables(cm, opts):
    """Every table a run of cm writes: file name -> (header, function(chunk) -> array)."""
    from ..derived import derived_tables
    from planarkin.solver.layout import Layout
    lay = Layout(cm, opts.order)
    out = {"bodies.csv": (lay.body_header, lay.body_table),
           "points.csv": (lay.point_header, lay.point_table)}
    for d in derived_tables(cm, opts):
        out[d.filename] = (d.header, d.compute)
    return out


def split_unit(header: str) -> tuple[str, str]:
    name, _, unit = header.partition(" [")
    return name, unit[:-1] if unit.endswith("]") else unit


def parse_metrics(texts, cm, opts, file: str) -> list[Metric]:
    """Resolve ``KIND:COLUMN`` texts against the nominal model's tables; InputError naming the
    metric (with a suggestion) for an unknown kind or column."""
    if isinstance(texts, str) or not all(isinstance(t, str) for t in texts):
        raise InputError([Diagnostic(file, None, f"metrics must be a list of 'KIND:COLUMN' "
                                                 f"texts, not {texts!r:.60}")])
    from ..options import from_command_line
    flag = "--metric " if from_command_line() else "metric "       # API callers: API words
    cols = {}
    for fname, (header, _) in tables(cm, opts).items():
        for k, h in enumerate(header[1:], start=1):
            name, unit = split_unit(h)
            cols.setdefault(name, (fname, k, unit))
    out, problems = [], []
    if len(set(texts)) != len(texts):             # each would be a column of its own
        twice = sorted({t for t in texts if list(texts).count(t) > 1})
        problems.append(f"{flag}{twice[0]} is given twice; give each metric once")
        texts = list(dict.fromkeys(texts))
    for text in texts:
        if text == "min_clearance" or text.startswith("min_clearance:"):
            # the least clearance of every pair of shapes (clearance.csv's clearance column),
            # or of one pair (min_clearance:A|B), refined between the rows
            text = "min:" + (text.partition(":")[2] or "clearance")
        kind, sep, col = text.partition(":")
        if kind == "dev" and sep:
            if col not in cm.point_names:
                hint = did_you_mean(col, cm.point_names) or \
                    f" (points: {', '.join(cm.point_names) or 'none'})"
                problems.append(f"{flag}{text}: dev needs a point name, not '{col}'{hint}")
                continue
            out.append(Metric("dev", col, "points.csv", list(cm.point_names).index(col),
                              cm.spec.length_unit))
            continue
        if not sep or kind not in KINDS:
            problems.append(f"{flag}{text}: write KIND:COLUMN with KIND one of "
                            f"{', '.join(KINDS)}{did_you_mean(kind, KINDS) if sep else ''}")
            continue
        if col not in cols:
            hint = did_you_mean(col, cols) or (" (columns: " + ", ".join(list(cols)[:12])
                                               + (", ..." if len(cols) > 12 else "") + ")")
            problems.append(f"{flag}{text}: no column '{col}' in this model's tables{hint}")
            continue
        out.append(Metric(kind, col, *cols[col]))
    if problems:
        raise InputError([Diagnostic(file, None, p) for p in problems])
    return out


def rate_columns(cm, source: str, header: list[str], k: int) -> tuple:
    """(rate, acceleration) column indices (or None) of column k of table `source`: those its
    value is refined from (planarkin.measures.extremes.derivative_columns), none for a ratio or
    an advantage measure (infinite at a dead point: run's cycle figures keep its grid
    extremes)."""
    names = [split_unit(h)[0] for h in header]
    grid = {m.name for m in getattr(cm.spec, "measures", ()) if m.kind in GRID_ONLY}
    if source == "measures.csv" and names[k].partition(".")[0] in grid:
        return None, None
    return derivative_columns(names, k)


def metric_values(metrics, cm, opts, chunk, reference=None) -> tuple:
    """Metric values from a result chunk (only the tables the metrics need are computed), each
    refined between the grid rows as run's cycle figures (Metric.value). reference: (N, P, 2)
    nominal point positions, for dev metrics."""
    if not metrics:
        return ()
    tabs = tables(cm, opts)
    cache = {}
    vals = []
    for m in metrics:
        if m.kind == "dev":
            if chunk.p.shape != reference.shape:      # another grid (analysis: uses parameters)
                vals.append(float("nan"))
                continue
            d = chunk.p[:, m.index] - reference[:, m.index]
            vals.append(m.value(chunk.t, np.hypot(d[:, 0], d[:, 1])))
            continue
        if m.source not in cache:
            cache[m.source] = tabs[m.source][1](chunk)
        X = cache[m.source]
        r, a = rate_columns(cm, m.source, tabs[m.source][0], m.index)
        vals.append(m.value(X[:, 0], X[:, m.index], None if r is None else X[:, r],
                            None if a is None else X[:, a]))
    return tuple(vals)


class Study:
    """A model file read once, its nominal model, the solver options and the metrics.

    overrides: fixed --set values applied to every variant (a variant's own values win);
    analysis: Options keyword overrides (steps, end, ...); metrics: KIND:COLUMN texts.
    Picklable (the parsed file, the nominal model, the batched solver once built), so it is
    sent once to worker processes or a Dask cluster.
    """

    def __init__(self, path: str, overrides: dict | None = None, analysis: dict | None = None,
                 metrics=()):
        from ..model.compile import compile_model
        from ..model.validate import validate
        from ..model.yamlread import read_file
        from planarkin.solver.grid import Options
        self.path = str(path)
        self.overrides = dict(overrides or {})
        self.analysis = {k: v for k, v in (analysis or {}).items() if v is not None}
        self.root = read_file(path)
        self.nominal = compile_model(validate(self.root, self.path, self.overrides))
        self.opts = Options.from_model(self.nominal, **self.analysis)
        self.metrics = parse_metrics(metrics, self.nominal, self.opts, self.path)
        self.parameters = dict(self.nominal.spec.parameters)
        from .warm import CHAIN
        from .batch import GROUP
        self.chain = CHAIN              # variants per chain
        self.group = GROUP              # chains per unit of work when batched
        self.reference = None
        if any(m.kind == "dev" for m in self.metrics):
            self.nominal_result = self.nominal_run()
            self.reference = self.nominal_result.p

    def nominal_run(self):
        """The nominal model's Result (run's analysis); InputError when it fails."""
        from ..analysis import analyse
        info, res = analyse(self.nominal, self.opts)
        if info.status != 0:
            raise InputError([Diagnostic(self.path, None, f"the nominal model fails: "
                                                         f"{info.message}")])
        return res

    def texts(self) -> dict:
        """The text of every parameter as used: the override's where one is given."""
        node = self.root.value.get("parameters")
        out = {}
        for k, n in (node.value.items() if node is not None else ()):
            v = self.overrides.get(k, n.value)
            out[k] = v if isinstance(v, str) else float(v)
        return out

    def model(self, values: dict):
        """The compiled model of one variant (raises InputError)."""
        from ..model.compile import compile_model
        from ..model.validate import validate
        return compile_model(validate(self.root, self.path, {**self.overrides, **values}))

    def solve(self, values: dict, start=None, warm: bool = False):
        """(Outcome, Result or None) of one variant; with warm, (Outcome, Result, Start for the
        next variant) started from a neighbour's Start when one is given (studies.warm)."""
        from ..analysis import analyse
        from planarkin.solver.grid import Options
        from .warm import analyse as warm_analyse
        nan = float("nan")
        none = (nan,) * len(self.metrics)
        nxt = None
        try:
            cm = self.model(values)
            opts = Options.from_model(cm, **self.analysis)
            if warm:
                info, res, nxt, _ = warm_analyse(cm, opts, start)
            else:
                info, res = analyse(cm, opts)
        except InputError as e:
            msg = "; ".join(d.message for d in e.diagnostics if d.severity == "error")
            out = Outcome("invalid", "", nan, msg, none), None
            return out + (None,) if warm else out
        out = self._outcome(cm, opts, info, res)
        return out + (nxt,) if warm else out

    def _outcome(self, cm, opts, info, res):
        nan = float("nan")
        none = (nan,) * len(self.metrics)
        if info.status != 0:
            ev = info.event
            return Outcome("failed", ev.kind if ev else "failure", ev.t if ev else nan,
                           info.message, none), res
        return Outcome("ok", "", nan, "", metric_values(self.metrics, cm, opts, res._chunk,
                                                        self.reference)), res

    def units(self, variants) -> list[list[list[dict]]]:
        """The variants as units of work: groups of chains (studies.warm.chains), GROUP chains
        per unit when the study can be batched (studies.batch), else one chain per unit. A
        unit's outcomes do not depend on where it runs."""
        from .warm import chains
        chs = [[variants[i] for i in ch] for ch in chains(len(variants), self.chain)]
        B = self.batch(variants)
        per = self.group if B is not None else 1
        if B is not None:   # the job's size picks the route (kernel.route): loaded here,
            B.job_points = len(variants) * len(B.grid)     # before any worker starts
            B.kernel()
        return [chs[k:k + per] for k in range(0, len(chs), per)]

    def on_engine(self, variants) -> bool:
        """Whether these variants take the compiled route (kernel.route by the job's size, and
        numba importable), decided without importing numba: the workers' server loads it
        then while this process prepares the study (planarkin.processes.context)."""
        from planarkin.solver.compiled import kernel
        B = self.batch(variants)
        return B is not None and kernel.would_route(len(variants) * len(B.grid))

    def batch(self, variants):
        """The batched solver for these variants' parameter names, or None (cached)."""
        from .batch import Batch, Unsupported
        keys = tuple(sorted({k for v in variants for k in v}))
        if not keys or any(set(v) != set(keys) for v in variants):
            return None
        cache = self.__dict__.setdefault("_batches", {})
        if keys not in cache:
            try:
                cache[keys] = Batch(self, list(keys))
            except (Unsupported, InputError):
                cache[keys] = None
            except Exception:  # noqa: BLE001 - a model the batch cannot take runs per variant
                cache[keys] = None
        return cache[keys]

    def run_unit(self, unit) -> list[Outcome]:
        """Outcomes of one unit (a list of chains of variants), in order."""
        flat = [v for ch in unit for v in ch]
        B = self.batch(flat)
        if B is not None:
            return [o for ch in B.run_group(unit) for o in ch]
        return [o for ch in unit for o in self.run_chain(ch)]

    def run(self, variants) -> list[Outcome]:
        """Outcomes of variants (dicts name -> value) in order, serially in this process, unit
        by unit (see `units`)."""
        out = []
        for unit in self.units(variants):
            out += self.run_unit(unit)
        return out

    def run_chain(self, variants) -> list[Outcome]:
        """Outcomes of one chain of variants, each started from its predecessor's solution."""
        out, start = [], None
        for v in variants:
            o, _, start = self.solve(v, start, warm=True)
            out.append(o)
        return out
