"""Compare two result directories column by column: the regression gate for CI.

Every table the directories hold (bodies.csv, points.csv, derived tables such as forces.csv,
sweep.csv, ...; CSV or Parquet, a table in one format against the same table in the other) is
compared value by value with numpy's rule |new - golden| <= atol + rtol *
|golden| (NaN equals NaN, infinities must match exactly), and summary.json's status must agree.
The outcome is an exit status: 0 equal within the tolerances, 1 differs, 2 unusable input
(a missing directory or table, a malformed CSV, different columns or row counts).

Two roots of result directories (`planarkin run MODEL... --out ROOT`) are compared model by
model (root_models, compare_roots): each directory on either side is same, differs, missing on
one side or unusable, and a run that did not end ok is said so from its summary.json.
"""

from __future__ import annotations

import csv
import json
import math
import stat
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

SAME, DIFFERS, UNUSABLE = 0, 1, 2


class Unusable(Exception):
    """The inputs cannot be compared (the message says which file and why)."""


@dataclass
class Difference:
    """One column's worst difference. excess: |d| / allowed (inf when nothing is allowed)."""

    table: str
    column: str
    row: int                   # 1-based data row
    t: float | None            # the row's time when the table's first column is t [s]
    new: float | str
    golden: float | str
    excess: float
    count: int                 # values of the column outside the tolerance

    def format(self) -> str:
        where = f"t = {self.t!r} s (row {self.row})" if self.t is not None else f"row {self.row}"
        if isinstance(self.new, str) or isinstance(self.golden, str):
            return (f"{self.table}: {self.column} at {where}: {self.new!r} (new) vs "
                    f"{self.golden!r} (golden); {self.count} value{'s' if self.count != 1 else ''}"
                    f" of the column differ")
        d = abs(self.new - self.golden) if math.isfinite(self.new - self.golden) else math.inf
        rel = d / abs(self.golden) if self.golden else math.inf
        return (f"{self.table}: {self.column} at {where}: {self.new!r} (new) vs {self.golden!r} "
                f"(golden), difference {d:.3g}, relative {rel:.3g}; {self.count} value"
                f"{'s' if self.count != 1 else ''} of the column outside the tolerance")


@dataclass
class Comparison:
    status: int = SAME
    tables: list[str] = field(default_factory=list)
    columns: int = 0
    values: int = 0
    differences: list[Difference] = field(default_factory=list)   # worst first
    notes: list[str] = field(default_factory=list)                # e.g. summary status differs
    error: str | None = None                                      # why the input is unusable
    summaries: bool = True          # both hold summary.json (False: statuses not compared)


def read_table(path: Path) -> tuple[list[str], np.ndarray, dict]:
    """Header, (rows, columns) float array and text columns of a CSV table.

    An empty cell reads as NaN. A column with a cell that is not a number is a text column
    (sweep.csv's status and message): texts maps its index to (its cells, the file line of its
    first non-number). Unusable when the file cannot be read or a row has the wrong length.
    A .parquet table (planarkin run --table-format parquet) is read through pyarrow."""
    if path.suffix == ".parquet":
        return _read_parquet(path)
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as e:
        raise Unusable(f"{path}: cannot read: {e}") from None
    if not rows:
        raise Unusable(f"{path}:1: empty file (no header)")
    header = rows[0]
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise Unusable(f"{path}:1: repeated column name {', '.join(repr(d) for d in dup)}")
    data = np.empty((len(rows) - 1, len(header)))
    texts: dict[int, tuple[list[str], int]] = {}
    for k, row in enumerate(rows[1:]):
        if len(row) != len(header):
            raise Unusable(f"{path}:{k + 2}: {len(row)} values, the header has {len(header)}")
        try:
            data[k] = [float(v) if v else math.nan for v in row]
        except ValueError:
            for c, v in enumerate(row):
                if v and not _is_float(v) and c not in texts:
                    texts[c] = (None, k + 2)
            data[k] = [float(v) if v and _is_float(v) else math.nan for v in row]
    for c in texts:
        texts[c] = ([r[c] for r in rows[1:]], texts[c][1])
    return header, data, texts


def _read_parquet(path: Path) -> tuple[list[str], np.ndarray, dict]:
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise Unusable(f"{path}: reading Parquet needs pyarrow: pip install "
                       f"'planarkin[parquet]'") from None
    import pyarrow as pa
    texts: dict[int, tuple[list[str], int]] = {}
    try:
        t = pq.read_table(path)
        header = list(t.column_names)
        cols = []
        for k in range(t.num_columns):
            col = t.column(k)
            if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
                # a text column (sweep.parquet's status, kind, message): compared exactly,
                # a missing cell as the CSV's empty one; its number column is NaN
                texts[k] = (["" if v is None else v for v in col.to_pylist()], 1)
                cols.append(np.full(t.num_rows, np.nan))
            else:
                cols.append(col.to_numpy(zero_copy_only=False).astype(np.float64))
        data = np.column_stack(cols) if cols else np.empty((0, 0))
    except Exception as e:  # noqa: BLE001 - any damage makes the table unusable
        raise Unusable(f"{path}: cannot read: {e}") from None
    if len(set(header)) != len(header):
        dup = sorted({h for h in header if header.count(h) > 1})
        raise Unusable(f"{path}: repeated column name {', '.join(repr(d) for d in dup)}")
    return header, data.reshape(t.num_rows, len(header)), texts


def _is_float(v: str) -> bool:
    try:
        float(v)
        return True
    except ValueError:
        return False


def _text(x: float) -> str:
    return "" if math.isnan(x) else repr(x)


def _regular(p: Path) -> bool:
    """Whether p is a regular file (after symbolic links): a FIFO would block the read for
    ever and a device (/dev/zero) never end, so anything else is refused before it is opened."""
    try:
        return stat.S_ISREG(p.stat().st_mode)
    except OSError:
        return False


def _tables(d: Path) -> set[str]:
    names = set()
    for p in d.iterdir():
        if p.suffix in (".csv", ".parquet"):
            if not _regular(p):
                raise Unusable(f"{p}: not a regular file (a FIFO, device or folder is not read)")
            names.add(p.name)
    return names


def _pairs(new: Path, golden: Path) -> list[tuple[str, str]]:
    """The tables to compare, (name in new, name in golden) sorted: the same name, or the same
    table in the other format (bodies.parquet against bodies.csv: values are compared, whatever
    the table format). Unusable when a table has no counterpart."""
    tn, tg = _tables(new), _tables(golden)
    pairs = [(n, n) for n in tn & tg]
    stem = lambda names: {Path(n).stem: n for n in names}
    sn, sg = stem(tn - tg), stem(tg - tn)
    pairs += [(sn[k], sg[k]) for k in sn.keys() & sg.keys()]
    lone_n = sorted(sn[k] for k in sn.keys() - sg.keys())
    lone_g = sorted(sg[k] for k in sg.keys() - sn.keys())
    if lone_n or lone_g:
        parts = []
        if lone_g:
            parts.append(f"missing in {new}: {', '.join(lone_g)}")
        if lone_n:
            parts.append(f"missing in {golden}: {', '.join(lone_n)}")
        raise Unusable("different tables (" + "; ".join(parts) + ")")
    return sorted(pairs)


def _status(d: Path):
    p = d / "summary.json"
    if not p.exists():
        return None
    if not _regular(p):
        raise Unusable(f"{p}: not a regular file (a FIFO, device or folder is not read)")
    try:
        s = json.loads(p.read_text())
        return s["status"]
    except (OSError, ValueError, KeyError, TypeError):
        raise Unusable(f"{p}: not a planarkin summary (no readable 'status')") from None


def compare_tables(name: str, new: tuple, golden: tuple, rtol: float, atol: float,
                   out: Comparison) -> None:
    (hn, a, tn), (hg, b, tg) = new, golden
    if hn != hg:
        missing = [h for h in hg if h not in hn]
        extra = [h for h in hn if h not in hg]
        why = "; ".join(filter(None, [
            f"columns missing in the new table: {', '.join(missing)}" if missing else "",
            f"columns only in the new table: {', '.join(extra)}" if extra else "",
            "the same columns in another order" if not missing and not extra else ""]))
        raise Unusable(f"{name}: different columns ({why})")
    if a.shape[0] != b.shape[0]:
        raise Unusable(f"{name}: different number of rows: {a.shape[0]} new, {b.shape[0]} "
                       f"golden")
    for c, (_, line) in tn.items():
        bad = next((v for v in tn[c][0] if v and not _is_float(v)), None)
        if c not in tg and bad is not None:      # (a Parquet text column may be all empty)
            raise Unusable(f"{name}:{line}: column '{hn[c]}': '{bad[:40]}' is not a number")
    out.columns += len(hn)
    out.values += a.size
    with np.errstate(invalid="ignore", over="ignore"):
        diff = np.abs(a - b)
        allowed = atol + rtol * np.abs(b)
        both_nan = np.isnan(a) & np.isnan(b)
        inf_differs = (np.isinf(a) | np.isinf(b)) & (a != b)
        bad = (~(diff <= allowed) & ~both_nan & (a != b)) | inf_differs
        excess = np.where(bad, np.where(allowed > 0, diff / np.where(allowed > 0, allowed, 1),
                                        np.inf), 0.0)
        excess[bad & np.isnan(excess)] = np.inf
    timed = bool(hn) and hn[0].startswith("t [")
    for c, (cells, _) in tg.items():
        # a text column (a status, a message) must match exactly
        new_cells = tn[c][0] if c in tn else [_text(x) for x in a[:, c]]
        wrong = [r for r, (x, y) in enumerate(zip(new_cells, cells)) if x != y]
        bad[:, c] = False
        if wrong:
            r = wrong[0]
            out.differences.append(Difference(
                name, hn[c], r + 1, float(b[r, 0]) if timed else None, new_cells[r], cells[r],
                math.inf, len(wrong)))
    for c in np.flatnonzero(bad.any(axis=0)):
        col = excess[:, c]
        key = np.where(bad[:, c], col, -1.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            # among equal excesses (nothing allowed: all infinite) the largest relative one
            rel = np.where(key == key.max(), diff[:, c] / np.abs(b[:, c]), -1.0)
        rel = np.nan_to_num(rel, nan=np.inf, posinf=np.inf)
        r = int(np.argmax(rel))
        out.differences.append(Difference(
            name, hn[c], r + 1, float(b[r, 0]) if timed else None, float(a[r, c]),
            float(b[r, c]), float(col[r]), int(bad[:, c].sum())))


def compare_dirs(new: str | Path, golden: str | Path, rtol: float = 1e-9,
                 atol: float = 1e-12) -> Comparison:
    """Compare result directory `new` against `golden`. Never raises for bad input: the
    Comparison's status is UNUSABLE and its error says why."""
    out = Comparison()
    new, golden = Path(new), Path(golden)
    try:
        for d, what in ((new, "new"), (golden, "golden")):
            if not d.is_dir():
                raise Unusable(f"{d}: no such directory (the {what} results)")
        pairs = _pairs(new, golden)
        if not pairs:
            raise Unusable(f"{golden}: no CSV or Parquet tables to compare")
        sn, sg = _status(new), _status(golden)
        if (sn is None) != (sg is None):
            raise Unusable(f"{new if sn is None else golden}/summary.json is missing")
        if sn != sg:
            out.notes.append(f"summary.json: status '{sn}' (new) vs '{sg}' (golden)")
        out.summaries = sn is not None
        for a, b in pairs:
            name = a if a == b else f"{a} vs {b}"
            out.tables.append(name)
            compare_tables(name, read_table(new / a), read_table(golden / b), rtol, atol, out)
    except Unusable as e:
        out.status, out.error = UNUSABLE, str(e)
        return out
    out.differences.sort(key=lambda d: -d.excess)
    out.status = DIFFERS if out.differences or out.notes else SAME
    return out


def report(c: Comparison, rtol: float, atol: float, show: int = 10) -> list[str]:
    """Lines for the terminal: the verdict first, then the worst differences."""
    if c.status == UNUSABLE:
        return [f"error: cannot compare: {c.error}"]
    tol = f"rtol {rtol:g}, atol {atol:g}"
    if c.status == SAME:
        return [f"same: {len(c.tables)} tables, {c.columns} columns, {c.values} values within "
                f"{tol}" + ("" if c.summaries else "; neither directory holds summary.json, so "
                                                   "no run status was compared")]
    lines = [f"differs: {len(c.differences)} of {c.columns} columns outside {tol}"
             + (f"; {'; '.join(c.notes)}" if c.notes else "")]
    lines += ["  " + d.format() for d in c.differences[:show]]
    if len(c.differences) > show:
        lines.append(f"  ... and {len(c.differences) - show} more columns")
    return lines


# -- two result roots (`planarkin run MODEL... --out ROOT`): one comparison per model ----------

@dataclass
class ModelComparison:
    """One model of two roots: outcome same, differs, missing (on one side) or unusable; line:
    the terminal's words after the model's name; text: the whole verdict (report())."""

    name: str
    outcome: str
    line: str
    text: str
    seconds: float


def _summary(d: Path) -> dict | None:
    """d's summary.json when it is a readable planarkin summary, else None."""
    p = d / "summary.json"
    if not _regular(p):
        return None
    try:
        s = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return s if isinstance(s, dict) and "planarkin" in s else None


def _holds_results(d: Path) -> bool:
    """Whether folder d holds a result: a summary.json or a CSV or Parquet table."""
    try:
        return any(p.name == "summary.json" or p.suffix in (".csv", ".parquet")
                   for p in d.iterdir())
    except OSError:
        return False


def _model_dirs(root: Path) -> list[str]:
    """The result directories in root: its folders (not hidden: a run's temporaries and locks
    start with a dot) that hold a summary.json or a table."""
    try:
        subs = [p for p in root.iterdir() if not p.name.startswith(".") and p.is_dir()]
    except OSError as e:
        raise Unusable(f"{root}: cannot read: {e.strerror or e}") from None
    return sorted(p.name for p in subs if _holds_results(p))


def _is_root(d: Path) -> bool:
    """A root of result directories: no table or summary.json of its own, and at least one
    folder whose summary.json is a planarkin summary."""
    return not _holds_results(d) and any(_summary(d / n) is not None for n in _model_dirs(d))


def root_models(new: str | Path, golden: str | Path) -> list[str] | None:
    """The models to compare when new and golden are roots of result directories (a root and
    an empty folder too: every model is then missing on one side): the union of their result
    directories' names, sorted. None when they are not roots (compare_dirs compares them as
    two result directories). Unusable when one is a root and the other a model's directory."""
    new, golden = Path(new), Path(golden)
    if not (new.is_dir() and golden.is_dir()):
        return None
    rn, rg = _is_root(new), _is_root(golden)
    if not (rn or rg):
        return None
    for root, other, is_root in ((new, golden, rg), (golden, new, rn)):
        if not is_root and _holds_results(other):
            raise _mismatch(root, other)
    return sorted(set(_model_dirs(new)) | set(_model_dirs(golden)))


def _mismatch(root: Path, single: Path) -> Unusable:
    n = len(_model_dirs(root))
    return Unusable(f"{root} holds {n} result director{'ies' if n != 1 else 'y'} but {single} "
                   f"is one model's result directory: give two roots (planarkin run ... --out "
                   f"ROOT) or two model directories (e.g. {root / single.name} {single})")


_RUN_WORDS = {"failed": ("failed", "the failure"),
              "interrupted": ("was interrupted", "the interruption"),
              "invalid": ("found the model invalid", "then")}


def _how(s: dict) -> tuple[str, str]:
    """A run's status and the lead clause of its summary.json message (`singular
    configuration at t = 0.25 s`)."""
    msg = s.get("message")
    lead = msg.split(": ", 1)[0][:120] if isinstance(msg, str) else ""
    return str(s.get("status")), lead


def _runs_said(sn: dict | None, sg: dict | None) -> str:
    """What the summaries say of the runs that did not end ok, and so what their directories
    hold ('' when both ended ok)."""
    bad = [(side, s) for side, s in (("new", sn), ("golden", sg))
           if s is not None and s.get("status") != "ok"]
    if not bad:
        return ""

    def said(status, lead):
        verb, upto = _RUN_WORDS.get(status, (f"ended with status '{status}'", "then"))
        return verb + (f" ({lead})" if lead else ""), upto
    if len(bad) == 2 and _how(sn) == _how(sg):
        verb, upto = said(*_how(sn))
        return f"both runs {verb}, as summary.json says: the tables hold the rows up to {upto}"
    parts = []
    for side, s in bad:
        verb, upto = said(*_how(s))
        parts.append(f"the {side} run {verb}, as its summary.json says: its directory holds "
                     f"the rows up to {upto}")
    return "; ".join(parts)


def _rows(s: dict):
    t = s.get("time")
    return t.get("rows_written") if isinstance(t, dict) else None


def compare_model(name: str, new: Path, golden: Path, rtol: float, atol: float,
                  show: int = 10) -> ModelComparison:
    """Compare new/name against golden/name: missing on a side, unusable, or the verdict of
    compare_dirs, with what summary.json says when a run did not end ok."""
    t0 = time.perf_counter()
    n, g = new / name, golden / name

    def done(outcome, line, text=None):
        return ModelComparison(name, outcome, line, line if text is None else text,
                               time.perf_counter() - t0)
    if not _holds_results(n) or not _holds_results(g):
        if not _holds_results(g):
            return done("missing", f"missing in {golden}/: a new model? make its golden "
                                   f"results (planarkin run MODEL --out {golden}) and review "
                                   f"them")
        return done("missing", f"missing in {new}/: the model was not run, or its run found it "
                               f"invalid (`planarkin run` writes no directory for invalid "
                               f"input)")
    c = compare_dirs(n, g, rtol=rtol, atol=atol)
    text = "\n".join(report(c, rtol, atol, show))
    sn, sg = _summary(n), _summary(g)
    said = _runs_said(sn, sg)
    if said and sn is not None and sg is not None and (
            sn.get("status") != sg.get("status") or _rows(sn) != _rows(sg)):
        # the runs ended otherwise: a difference, whatever the tables (they have other rows)
        line = f"{said}; {_rows(sn)} rows (new) vs {_rows(sg)} (golden)"
        if c.status == DIFFERS and c.differences:
            line += f"; worst column: {c.differences[0].format()}"
        return done("differs", line, line + ("\n" + text if c.status != UNUSABLE else ""))
    if c.status == UNUSABLE:
        return done("unusable", c.error + (f"; {said}" if said else ""),
                    text + (f"\n{said}" if said else ""))
    if c.status == SAME:
        line = text.splitlines()[0].removeprefix("same: ")
        return done("same", line + (f"; {said}" if said else ""))
    line = (f"{len(c.differences)} of {c.columns} columns outside rtol {rtol:g}, atol {atol:g}"
            + (f"; {'; '.join(c.notes)}" if c.notes else ""))
    if c.differences:
        line += f"; worst: {c.differences[0].format()}"
    return done("differs", line + (f"; {said}" if said else ""),
                text + (f"\n{said}" if said else ""))


def compare_roots(new: str | Path, golden: str | Path, names: list[str], rtol: float = 1e-9,
                  atol: float = 1e-12, show: int = 10):
    """Compare each model of names (root_models) in root new against root golden: yields a
    ModelComparison per model, in order, as it is compared."""
    new, golden = Path(new), Path(golden)
    for name in names:
        yield compare_model(name, new, golden, rtol, atol, show)
