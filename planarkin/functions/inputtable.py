"""Tabulated input motion (a driver's ``table:``): read a CSV of time and value, interpolate with
a quintic spline whose derivatives are the exact derivatives of the interpolant.

The interpolant is the degree-5 interpolating B-spline with not-a-knot ends (scipy's
make_interp_spline, k = 5; with ``periodic: true`` its periodic form), so it is C4: position,
velocity, acceleration and jerk are continuous, and a table sampled from any polynomial of degree
<= 5 is reproduced to rounding. Tables of 4 or 5 rows get the cubic (C2) spline of the same kind.
It is converted to piecewise polynomials (planarkin.functions.piecewise) that the expression layer
evaluates and differentiates exactly. scipy is imported only when a table is read.
"""

from __future__ import annotations

import itertools
import math
import os
import re
import secrets
import stat
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from .expr import Expr, TimeFunction
from .expr.core import bin_node, num_node, pw_node, sugar_node
from .piecewise import Piece, Piecewise

__all__ = ["TableError", "confined", "open_lines", "read_columns", "read_table", "spline",
           "table_function"]

# Budgets that keep a table's check within seconds and well under 1 GB (the piecewise
# polynomial keeps a Python object per interval; a curve's points cost more in the run): the
# figures behind each are in benchmarks/README.md, "Figures behind the code's limits".
MAX_ROWS = 100_000
MAX_CURVE_POINTS = 10_000
MAX_BYTES = 16 * 2**20   # 16 MB: 1e5 rows of a few numbers fit many times over
MAX_MAGNITUDE = 1e100    # as for numbers in the model file: their squares must not overflow
MAX_LINE = 10_000        # characters of one line (a huge header is refused, not parsed)
MAX_LINES = 4 * MAX_ROWS  # lines with comments and blanks
EXCERPT = 40             # characters of a file quoted in a message, at most
TABLE_DIRS_VAR = "PLANARKIN_TABLE_DIRS"
# (the model's folder as given, then the real paths of the folders tables may come from)
_ROOTS: ContextVar[tuple | None] = ContextVar("planarkin_table_roots", default=None)


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
        shown = ", ".join(h if len(h) <= 20 else h[:20] + "..." for h in header[:8])
        more = f", ... ({len(header)} columns)" if len(header) > 8 else ""
        raise TableError([(line, f"no {what} column '{want}' in the header (columns: "
                                 f"{shown}{more})")])
    return header.index(want)


def read_table(path: Path, time=None, value=None):
    """(t, y, t_lines) from a CSV file: comma separated (or whitespace when a line has no comma),
    an optional header line naming the columns, '#' comments and blank lines skipped. time and
    value: a header name or a 1-based column number (default: columns 1 and 2)."""
    (t, y), lines = read_columns(path, [(time, 0, "time"), (value, 1, "value")])
    return t, y, lines


def read_columns(path: Path, columns, increasing: bool = True, min_rows: int = 4,
                 max_rows: int | None = None):
    """The columns of a CSV table, read as `read_table` reads a motion table: ([arrays (n,)],
    data line numbers). columns: (wanted: a header name, a 1-based number or None, default
    0-based index, what: its name in messages) per column; increasing: the first column must
    increase strictly (times, cam angles); min_rows, max_rows: the fewest and most data rows
    accepted (max_rows: MAX_ROWS unless given).

    Only a regular file inside the allowed folders (`confined`) is read, at most MAX_BYTES and
    lines of at most MAX_LINE characters; messages quote at most EXCERPT characters of it."""
    rows, header, problems = [], None, []
    max_rows = MAX_ROWS if max_rows is None else max_rows
    idx = None
    first = columns[0][2]
    with _open(path) as lines:
        for n, raw in lines:
            if len(problems) > 20:      # a file of bad lines gives a screenful, not a line each
                break
            s = raw.strip()
            if not s or s.startswith("#"):
                continue
            fields = [x.strip() for x in (s.split(",") if "," in s else s.split())]
            if header is None and not rows and idx is None and _is_header(fields):
                header = fields
                idx = [_column(header, want, d, what, n) for want, d, what in columns]
                continue
            if idx is None:
                idx = [_column(None, want, d, what, n) for want, d, what in columns]
            if max(idx) >= len(fields):
                problems.append((n, f"expected at least {max(idx) + 1} columns, found "
                                    f"{len(fields)}"))
                continue
            bad = next((fields[i] for i in idx if not _NUMBER.match(fields[i])), None)
            if bad is not None:
                hint = (" (write numbers with the digits 0-9, no '_': e.g. 10, -0.5, 1.5e-3)"
                        if _NUMERIC_START.match(bad) else "")
                problems.append((n, f"{_excerpt(bad)} is not a number{hint}"))
                continue
            vals = [float(fields[i]) for i in idx]
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
            if len(rows) > max_rows:
                raise TableError([(n, f"the table has more than {max_rows} rows, the most "
                                      f"read here (the analysis would take minutes and "
                                      f"gigabytes): thin it out")])
    if problems:
        raise TableError(problems)
    if len(rows) < min_rows:
        raise TableError([(None, f"the table needs at least {min_rows} rows of numbers, found "
                                 f"{len(rows)}")])
    arr = np.array([r[0] for r in rows])
    return [arr[:, k] for k in range(len(columns))], [r[1] for r in rows]


# a number as a table writes it: ASCII digits, '.', an exponent (float() also takes '1_0' as 10
# and Arabic-Indic or full-width digits, which no table means as numbers), or inf/nan (refused
# later as not finite)
_NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan)\Z",
                     re.ASCII | re.IGNORECASE)
_NUMERIC_START = re.compile(r"[+-]?\.?\d")     # any script's digits: a number, not a name


def _is_header(fields: list[str]) -> bool:
    """A first line is a header when it names columns: a field that is not a number, and none
    that starts as a number does (so '1_0, 2' is a data line with a bad number, not a header)."""
    return (not all(_NUMBER.match(x) for x in fields)
            and not any(_NUMERIC_START.match(x) for x in fields))


def _excerpt(text: str) -> str:
    """text quoted, cut to EXCERPT characters: a message never repeats a file at length."""
    return repr(text) if len(text) <= EXCERPT else repr(text[:EXCERPT]) + "..."


@contextmanager
def confined(model_file: str | Path):
    """Within this block, tables are read only from the model file's folder (and below) and
    from the folders named in the environment variable PLANARKIN_TABLE_DIRS (separated by
    os.pathsep); symbolic links are followed before the check."""
    folder = Path(model_file).parent
    roots = [Path(os.path.realpath(folder))]
    roots += [Path(os.path.realpath(d)) for d in os.environ.get(TABLE_DIRS_VAR, "").split(
        os.pathsep) if d]
    token = _ROOTS.set((str(folder), *roots))
    try:
        yield
    finally:
        _ROOTS.reset(token)


def _check_place(path: Path) -> None:
    roots = _ROOTS.get()
    if roots is None:
        return
    real = Path(os.path.realpath(path))
    if any(real == r or r in real.parents for r in roots[1:]):
        return
    raise TableError([(None, f"the table is outside the model's folder {roots[0]}: put it in that "
                             f"folder (or below it), or name its folder in the environment "
                             f"variable {TABLE_DIRS_VAR}")])


@contextmanager
def _open(path: Path):
    """(line number, line) of a regular file, each line at most MAX_LINE characters and all of
    them at most MAX_BYTES; a FIFO, device or folder is refused before it is read (opened without
    blocking: a FIFO without a writer would wait for ever, /dev/zero never ends)."""
    _check_place(path)
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise TableError([(None, "the table is not a regular file (a FIFO, device or "
                                     "folder is not read): give a CSV file")])
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as exc:
        raise TableError([(None, f"cannot read the table: {exc.strerror or exc}")]) from None
    f = os.fdopen(fd, encoding="utf-8-sig", newline=None)
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):    # replaced between the two looks
            raise TableError([(None, "the table is not a regular file: give a CSV file")])
        if info.st_size > MAX_BYTES:
            raise TableError([(None, f"the table is too large ({info.st_size} bytes; at most "
                                     f"{MAX_BYTES})")])
        yield _lines(f)
    except UnicodeDecodeError:
        raise TableError([(None, "the table is not a UTF-8 text file")]) from None
    except OSError as exc:
        raise TableError([(None, f"cannot read the table: {exc.strerror or exc}")]) from None
    finally:
        f.close()


def open_lines(path: Path):
    """The lines of a tabular file under the budgets of a model's tables (see `_open`), for the
    other readers of such files (planarkin.synthesis.fit's tracked data): a context manager
    of (line number, line); TableError for a file refused."""
    return _open(path)


def _lines(f):
    total = 0
    for n in itertools.count(1):
        raw = f.readline(MAX_LINE + 1)
        if not raw:
            return
        if n > MAX_LINES:
            raise TableError([(n, f"the table has more than {MAX_LINES} lines, comments and "
                                  f"blank lines included")])
        if len(raw) > MAX_LINE:
            raise TableError([(n, f"the line is longer than {MAX_LINE} characters (a table "
                                  f"line holds a few numbers)")])
        total += len(raw)
        if total > MAX_BYTES:   # a file that grows while it is read
            raise TableError([(n, f"the table is too large (more than {MAX_BYTES} bytes)")])
        yield n, raw


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
        arg = bin_node("+", num_node(t0),
                       sugar_node("mod", (bin_node("-", tt, num_node(t0)), num_node(period))))
        fn = TimeFunction.from_expr(pw_node(pw, arg), f"table {shown} (periodic)")
    else:
        period = None
        fn = TimeFunction.from_expr(pw_node(pw, tt), f"table {shown}",
                                    domain=(float(t[0]), float(t[-1])))
    fn.table = (pw, period, len(t))
    return fn
