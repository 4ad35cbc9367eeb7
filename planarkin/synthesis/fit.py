"""Identification: the parameters that explain measured point trajectories.

The data file is a CSV whose first column is the time, ``t [s]``, and whose other columns are
point coordinates of the model, ``P.x [mm]``, ``P.y [mm]`` (the names of points.csv; lengths in
m, cm, mm, um, in or ft, converted to the model's unit). The residuals are model minus measured
at every data time, their Jacobian the exact sensitivities dP/dp at those times
(planarkin.synthesis.problem). Levenberg-Marquardt (MINPACK, scipy.optimize.least_squares
method='lm') when no bounds are given, the trust-region reflective method within the design
block's bounds otherwise. At the estimate: the residual variance s^2 = SSE / (m - k), the
covariance s^2 (J^T J)^-1, standard errors and correlations.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Diagnostic, InputError
from ..output.directory import checkpoint
from .problem import Model, Rejected, memory_problem

LENGTHS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "in": 0.0254,
           "ft": 0.3048}
WALL = 1e6


@dataclass
class Data:
    t: np.ndarray          # (N,) s
    columns: list          # (point index, 0 x | 1 y, header text)
    y: np.ndarray          # (N, c) in the model's length unit


@dataclass
class FitResult:
    status: int
    message: str
    names: list
    estimate: np.ndarray
    start: np.ndarray
    se: np.ndarray
    corr: np.ndarray
    residuals: np.ndarray        # (N, c) model - measured
    rms: float
    dof: int
    evaluations: int
    jacobians: int
    seconds: float
    data: Data
    state: object
    model: object


def _err(file, line, msg):
    return InputError([Diagnostic(file, line, msg)])


def read_data(path, cm) -> Data:
    """Read a tracked-data CSV against the compiled model; InputError (FILE:LINE) for a missing
    or wrong column, a unit that is not a length, a non-number or NaN, times out of order.

    The file is read under the budgets of the tables a model reads (planarkin.functions.inputtable): a
    regular file only (a FIFO or a device is refused before it is opened for reading), at
    most MAX_BYTES, lines of at most MAX_LINE characters, MAX_LINES lines and MAX_ROWS rows
    of data, so that a wrong --data costs a message, not the machine's memory."""
    from planarkin.functions import inputtable
    from planarkin.functions.inputtable import TableError, open_lines
    file = str(path)
    rows = []
    try:
        with open_lines(path) as lines:
            reader = csv.reader(raw for _, raw in lines)
            try:
                for r in reader:
                    if r and not r[0].startswith("#"):
                        rows.append((reader.line_num, r))
                    if len(rows) > inputtable.MAX_ROWS + 1:
                        raise _err(file, reader.line_num, (
                            f"the data file has more than {inputtable.MAX_ROWS} rows, the most "
                            f"read here (the fit would take minutes and gigabytes): thin it "
                            f"out"))
            except csv.Error as e:          # an unclosed quote that swallows the file
                raise _err(file, reader.line_num, f"not a CSV line ({e}): write "
                                                  f"'t [s],P.x [m],P.y [m]' and numbers") from None
    except TableError as e:
        raise InputError([Diagnostic(file, line, msg.replace("the table", "the data file"))
                          for line, msg in e.args[0]]) from None
    if not rows:
        raise _err(file, 1, "the data file is empty: it needs a header 't [s],P.x [m],P.y [m]' "
                            "and one row per time")
    hline, head = rows[0]
    names = [h.strip() for h in head]
    if names[0].replace(" ", "") not in ("t[s]", "t"):
        raise _err(file, hline, f"the first column must be the time 't [s]', not '{names[0]}'")
    unit = cm.spec.length_unit
    if unit not in LENGTHS:
        raise _err(file, hline, f"the model's length unit '{unit}' is not one of "
                                f"{', '.join(LENGTHS)}: the data cannot be converted")
    cols, scale = [], []
    points = list(cm.point_names)
    for h in names[1:]:
        name, _, u = h.partition(" [")
        u = u[:-1] if u.endswith("]") else u
        pt, _, comp = name.strip().rpartition(".")
        if pt not in points or comp not in ("x", "y"):
            from ..diagnostics import did_you_mean
            raise _err(file, hline, f"column '{h}': write POINT.x [UNIT] or POINT.y [UNIT] with "
                                    f"a point of the model{did_you_mean(pt, points)} (points: "
                                    f"{', '.join(points) or 'none'})")
        if u not in LENGTHS:
            raise _err(file, hline, f"column '{h}': give the length unit in brackets, one of "
                                    f"{', '.join(LENGTHS)}")
        cols.append((points.index(pt), "xy".index(comp), h))
        scale.append(LENGTHS[u] / LENGTHS[unit])
    if not cols:
        raise _err(file, hline, "no point columns: add POINT.x [UNIT], POINT.y [UNIT]")
    if len({(c[0], c[1]) for c in cols}) != len(cols):
        raise _err(file, hline, "a point coordinate is given in two columns")
    data = []
    for line, r in rows[1:]:
        if len(r) != len(names):
            raise _err(file, line, f"{len(r)} values for {len(names)} columns")
        try:
            vals = [float(x) for x in r]
        except ValueError:
            raise _err(file, line, f"not a number in '{','.join(r)}'") from None
        if not all(math.isfinite(v) for v in vals):
            raise _err(file, line, "a value is NaN or infinite: remove the row or fill it in")
        data.append(vals)
    if len(data) < 2:
        raise _err(file, hline, "the data needs at least two rows")
    D = np.array(data)
    bad = np.nonzero(np.diff(D[:, 0]) <= 0)[0]
    if len(bad):
        raise _err(file, rows[1 + bad[0] + 1][0], "the times must increase from row to row")
    return Data(t=D[:, 0], columns=cols, y=D[:, 1:] * np.array(scale))


def fit(path, data, free=None, overrides=None, analysis=None, progress=None) -> FitResult:
    """Fit the parameters `free` (names; default the model's design: free) of the model file
    to the tracked data (a CSV path). InputError for invalid input (a name given twice, a grid
    whose analyses would pass the study budget's memory too). progress: called as
    progress(evaluations, best sum of squares so far) before each analysis. An interruption
    (KeyboardInterrupt) is raised again with the analyses done as its `evaluations`."""
    t0 = time.perf_counter()
    from ..model.compile import compile_model
    from ..model.validate import validate
    from ..model.yamlread import read_file
    root = read_file(path)
    cm0 = compile_model(validate(root, str(path), overrides))
    bounds = None
    if not free:
        from .spec import design_of
        d = design_of(root, cm0.spec, required="fit")
        free = list(d.free)
        bounds = (np.array([d.free[n][0] for n in free]), np.array([d.free[n][1] for n in free]))
    twice = sorted({n for n in free if list(free).count(n) > 1})
    if twice:
        raise InputError([Diagnostic(str(path), None, f"--free {n} is given twice: name each "
                                                      f"parameter once") for n in twice])
    unknown = [n for n in free if n not in cm0.spec.parameters]
    if unknown:
        from ..diagnostics import did_you_mean
        raise InputError([Diagnostic(str(path), None, f"--free {n}: not a parameter of the model"
                                     f"{did_you_mean(n, cm0.spec.parameters)}") for n in unknown])
    D = read_data(data, cm0)
    a = dict(analysis or {})
    spec_a = cm0.spec.analysis
    if D.t[0] < spec_a.start:
        raise _err(str(data), None, f"the data starts at t = {D.t[0]:g} s, before the model's "
                                    f"analysis start {spec_a.start:g} s")
    if D.t[-1] > (a.get("end") or spec_a.end):
        a["end"] = float(D.t[-1])
    model = Model(path, free, overrides, a)
    problem = memory_problem(model, 2, "the design being analysed, the last one kept")
    if problem:
        raise InputError([Diagnostic(str(path), None, "fit: " + problem)])
    try:
        return _fit(path, free, bounds, cm0, D, model, progress, t0)
    except KeyboardInterrupt as e:
        e.evaluations = model.evaluations
        raise


def _fit(path, free, bounds, cm0, D, model, progress, t0) -> FitResult:
    from scipy.optimize import least_squares
    x0 = np.array([cm0.spec.parameters[n] for n in free], dtype=float)
    if bounds is not None:
        x0 = np.clip(x0, *bounds)
    rows = np.array([c[0] for c in D.columns])
    comps = np.array([c[1] for c in D.columns])
    cache = {}
    best = [math.inf]

    def evaluate(x, sens=True):
        """(r, J or None, State) or (None, None, Rejected); the last state is kept, so the
        Jacobian at the point just evaluated costs only its sensitivities."""
        key = x.tobytes()
        if key not in cache:
            checkpoint()            # a signal lost in a finalizer is raised again here
            if progress is not None:
                progress(model.evaluations, best[0])
            cache.clear()
            out = model.analyse(model.values(x))
            st = out if isinstance(out, Rejected) else model.solve_at(out[0], out[2], D.t,
                                                                       sens=False)
            cache[key] = st
        st = cache[key]
        if isinstance(st, Rejected):
            return None, None, st
        r = (st.p[:, rows, comps] - D.y).ravel()
        best[0] = min(best[0], float(r @ r))
        J = None
        if sens:
            if st.dp is None:
                model.add_sensitivities(st)
            J = st.dp[:, rows, comps, :].reshape(len(r), -1)
        return r, J, st

    r0, _, st0 = evaluate(x0)
    if r0 is None:
        raise InputError([Diagnostic(str(path), None, f"the starting model cannot be analysed "
                                     f"over the data's times: {st0.reason}")])
    m = len(r0)
    wall = np.full(m, WALL * (1 + float(np.linalg.norm(r0))))
    fun = lambda x: (lambda r: wall if r is None else r)(evaluate(x, False)[0])  # noqa: E731
    jac = lambda x: (lambda J: np.zeros((m, len(x))) if J is None else J)(evaluate(x)[1])  # noqa
    if bounds is None:
        sol = least_squares(fun, x0, jac=jac, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                            max_nfev=200 * (len(x0) + 1))
    else:
        span = bounds[1] - bounds[0]
        sol = least_squares(fun, x0, jac=jac, bounds=bounds, method="trf", x_scale=span,
                            xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200 * (len(x0) + 1))
    r, J, st = evaluate(sol.x)
    k = len(free)
    if r is None:
        return FitResult(1, f"the fit ended on a rejected design: {st.reason}", free, sol.x, x0,
                         np.full(k, np.nan), np.full((k, k), np.nan), np.zeros_like(D.y),
                         math.nan, m - k, model.evaluations, model.jacobians,
                         time.perf_counter() - t0, D, None, model)
    dof = max(m - k, 1)
    s2 = float(r @ r) / dof
    JTJ = J.T @ J
    try:
        cov = s2 * np.linalg.inv(JTJ)
        se = np.sqrt(np.maximum(np.diag(cov), 0.0))
        corr = cov / np.outer(se, se) if np.all(se > 0) else np.full((k, k), np.nan)
        status, msg = 0, f"fitted {k} parameters to {m} values: rms residual {math.sqrt(s2):.3g}"
        if np.linalg.cond(JTJ) > 1e14:
            status, msg = 1, ("the parameters are not identifiable from these data (J^T J is "
                              "singular): " + msg)
    except np.linalg.LinAlgError:
        se = np.full(k, np.nan)
        corr = np.full((k, k), np.nan)
        status, msg = 1, "the parameters are not identifiable from these data (J^T J singular)"
    return FitResult(status, msg, free, sol.x, x0, se, corr, r.reshape(D.y.shape),
                     math.sqrt(float(r @ r) / m), m - k, model.evaluations, model.jacobians,
                     time.perf_counter() - t0, D, st, model)
