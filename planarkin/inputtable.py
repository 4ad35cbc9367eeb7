"""Tabulated input motion (a driver's ``table:``): read a CSV of time and value, interpolate with
a quintic spline whose derivatives are the exact derivatives of the interpolant.

The interpolant is the degree-5 interpolating B-spline with not-a-knot ends (scipy's
make_interp_spline, k = 5; with ``periodic: true`` its periodic form), so it is C4: position,
velocity, acceleration and jerk are continuous, and a table sampled from any polynomial of degree
<= 5 is reproduced to rounding. Tables of 4 or 5 rows get the cubic (C2) spline of the same kind.
It is converted to piecewise polynomials (planarkin.piecewise) that the expression layer
evaluates and differentiates exactly. scipy is imported only when a table is read.
"""

from __future__ import annotations

import math
import secrets
from pathlib import Path

import numpy as np

from .expr import Expr, TimeFunction, _bin, _Num, _pw, _sugar
from .piecewise import Piece, Piecewise

__all__ = ["TableError", "read_columns", "read_table", "spline", "table_function"]

MAX_ROWS = 1_000_000
MAX_BYTES = 64 * 2**20
MAX_MAGNITUDE = 1e100    # as for numbers in the model file: their squares must not overflow


class TableError(Exception):
    """Problems of a table file: args[0] is a list of (line or None, message)."""


def _column(header: list | None, want, default: int, what: str, line: int) -> int:
    if want is None:
        return default
    if isinstance(want, int) and not isinstance(want, bool):
        if want < 1:
            raise TableError([(line, f"{what} column {want} does not exist (columns count from 1)")])
        return want - 1
    if header is None:
        raise TableError([(line, f"the table has no header line, so {what} column '{want}' "
                                 f"cannot be found; give a column number (1, 2, ...)")])
    if want not in header:
        raise TableError([(line, f"no {what} column '{want}' in the header (columns: "
                                 f"{', '.join(header)})")])
    return header.index(want)


def read_table(path: Path, time=None, value=None):
    """(t, y, t_lines) from a CSV file: comma separated (or whitespace when a line has no comma),
    an optional header line naming the columns, '#' comments and blank lines skipped. time and
    value: a header name or a 1-based column number (default: columns 1 and 2)."""
    (t, y), lines = read_columns(path, [(time, 0, "time"), (value, 1, "value")])
    return t, y, lines


def read_columns(path: Path, columns, increasing: bool = True, min_rows: int = 4):
    """The columns of a CSV table, read as `read_table` reads a motion table: ([arrays (n,)],
    data line numbers). columns: (wanted: a header name, a 1-based number or None, default
    0-based index, what: its name in messages) per column; increasing: the first column must
    increase strictly (times, cam angles); min_rows: the fewest data rows accepted."""
    try:
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise TableError([(None, f"the table is too large ({size} bytes; at most {MAX_BYTES})")])
        text = path.read_text(encoding="utf-8-sig")
    except TableError:
        raise
    except UnicodeDecodeError:
        raise TableError([(None, "the table is not a UTF-8 text file")]) from None
    except OSError as exc:
        raise TableError([(None, f"cannot read the table: {exc.strerror or exc}")]) from None
    rows, header, problems = [], None, []
    idx = None
    first = columns[0][2]
    for n, raw in enumerate(text.splitlines(), start=1):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        fields = [x.strip() for x in (s.split(",") if "," in s else s.split())]
        if header is None and not rows and idx is None:
            try:
                [float(x) for x in fields]
            except ValueError:
                header = fields
                idx = [_column(header, want, d, what, n) for want, d, what in columns]
                continue
        if idx is None:
            idx = [_column(None, want, d, what, n) for want, d, what in columns]
        if max(idx) >= len(fields):
            problems.append((n, f"expected at least {max(idx) + 1} columns, found "
                                f"{len(fields)}"))
            continue
        try:
            vals = [float(fields[i]) for i in idx]
        except ValueError:
            bad = next(fields[i] for i in idx if not _is_number(fields[i]))
            problems.append((n, f"'{bad[:40]}' is not a number"))
            continue
        if not all(math.isfinite(v) for v in vals):
            problems.append((n, "values must be finite numbers"))
            continue
        big = max(abs(v) for v in vals)
        if big > MAX_MAGNITUDE:
            problems.append((n, f"{big:.3g} is too large (numbers up to "
                                f"{MAX_MAGNITUDE:g} in magnitude are accepted)"))
            continue
        if increasing and rows and not vals[0] > rows[-1][0][0]:
            problems.append((n, f"{first}s must increase strictly: {vals[0]:g} follows "
                                f"{rows[-1][0][0]:g} (line {rows[-1][1]})"))
            continue
        rows.append((vals, n))
        if len(rows) > MAX_ROWS:
            raise TableError([(n, f"the table has more than {MAX_ROWS} rows")])
        if len(problems) > 20:
            break
    if problems:
        raise TableError(problems)
    if len(rows) < min_rows:
        raise TableError([(None, f"the table needs at least {min_rows} rows of numbers, found "
                                 f"{len(rows)}")])
    arr = np.array([r[0] for r in rows])
    return [arr[:, k] for k in range(len(columns))], [r[1] for r in rows]


def _is_number(x: str) -> bool:
    try:
        float(x)
        return True
    except ValueError:
        return False


def spline(t: np.ndarray, y: np.ndarray, periodic: bool = False, name: str = "table") -> Piecewise:
    """The interpolating spline (quintic; cubic for 4-5 points) as a Piecewise in t."""
    from scipy.interpolate import PPoly, make_interp_spline  # lazily: only tables need it

    k = 5 if len(t) >= 6 else 3
    bspl = make_interp_spline(t, y, k=k, bc_type="periodic" if periodic else None)
    pp = PPoly.from_spline(bspl)
    x, c = pp.x, pp.c
    keep = [i for i in range(len(x) - 1) if x[i] >= t[0] and x[i + 1] <= t[-1] and x[i + 1] > x[i]]
    knots = [x[keep[0]]] + [x[i + 1] for i in keep]
    pieces = [Piece(c[:, i], (), x[i]) for i in keep]
    pw = Piecewise(name, knots, [pieces[0]] + pieces + [pieces[-1]])
    pw.switch_knots = np.array([t[0], t[-1]])  # inside, the spline is C4 (C2 when cubic)
    return pw


def table_function(t: np.ndarray, y: np.ndarray, periodic: bool, shown: str) -> TimeFunction:
    """The driver function of a table: f(t) interpolated; periodic wraps t into the table's
    range [t0, tN) (period tN - t0; y[-1] is taken equal to y[0]), otherwise f is defined on
    [t0, tN] only (domain)."""
    name = f"table_{secrets.token_hex(6)}"  # unique across processes (printed trees are keys)
    if periodic:  # the caller has checked that they agree (to 1e-9); make them equal
        y = np.array(y, dtype=float)
        y[-1] = y[0]
    pw = spline(t, y, periodic, name)
    tt = Expr("name", (), "t")
    if periodic:
        t0, period = float(t[0]), float(t[-1] - t[0])
        arg = _bin("+", _Num(t0), _sugar("mod", (_bin("-", tt, _Num(t0)), _Num(period))))
        return TimeFunction.from_expr(_pw(pw, arg), f"table {shown} (periodic)")
    return TimeFunction.from_expr(_pw(pw, tt), f"table {shown}", domain=(float(t[0]), float(t[-1])))
