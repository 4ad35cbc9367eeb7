"""`planarkin sweep`: one row per variant of a model, over a grid or a Latin hypercube.

``--vary a=0.10:0.20:11`` gives 11 values of a from 0.10 to 0.20 (ends included); several
``--vary`` make the full factorial (the last varies fastest). With ``--samples N --seed S`` the
ranges are sampled by a Latin hypercube instead (``--vary a=0.10:0.20``): each range is cut into N
equal strata, each stratum gets exactly one sample at a uniformly random place in it, and the
strata of the parameters are paired by independent random permutations (numpy's PCG64 generator
seeded with S, so the same seed gives the same variants bit for bit).
"""

from __future__ import annotations

import contextlib
import decimal
import itertools
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..output.directory import WriteError
from .execute import kept, solve
from .variants import Outcome, Study

_DECIMAL = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?\Z", re.ASCII)
_RANGE = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_\-]*)\s*=\s*([^:]+):([^:]+?)(?::([^:]+))?\s*$")


@dataclass(frozen=True)
class Range:
    name: str
    lo: float
    hi: float
    n: int | None        # grid points (None: sampled)
    text: tuple = field(default=(), compare=False)   # (LO, HI) as written, when decimal

    def values(self) -> np.ndarray:
        """The grid: LO + k (HI - LO) / (N - 1), k = 0..N-1, computed in decimal from the
        numbers as written and rounded once, so that 0.1:0.2:11 gives 0.1, 0.11, ... 0.2 (each
        the double nearest the decimal, printed as written; linspace gave 0.10999999999999999)."""
        if self.n == 1:
            return np.array([self.lo])
        if not self.text:
            return np.linspace(self.lo, self.hi, self.n)
        with decimal.localcontext() as ctx:
            ctx.prec = 50
            lo, hi = (decimal.Decimal(x) for x in self.text)
            step = (hi - lo) / (self.n - 1)
            return np.array([float(lo + k * step) for k in range(self.n - 1)] + [float(hi)])


def parse_range(text: str, need_count: bool) -> Range:
    """``NAME=LO:HI:N`` (N >= 1 values, ends included) or, for sampling, ``NAME=LO:HI``.
    ValueError with the reason for anything else."""
    m = _RANGE.match(text)
    if not m:
        raise ValueError(f"'{text}': write NAME=LO:HI:N, e.g. a=0.10:0.20:11")
    name, lo, hi, n = m.groups()
    try:
        lo_v, hi_v = float(lo), float(hi)
    except ValueError:
        raise ValueError(f"'{text}': LO and HI must be numbers") from None
    if not (math.isfinite(lo_v) and math.isfinite(hi_v)):
        raise ValueError(f"'{text}': LO and HI must be finite")
    count = None
    if n is not None:
        try:
            count = int(n)
        except ValueError:
            raise ValueError(f"'{text}': N must be a whole number of values") from None
        if count < 1:
            raise ValueError(f"'{text}': N must be at least 1")
    elif need_count:
        raise ValueError(f"'{text}': give the number of values, NAME=LO:HI:N (or use --samples)")
    if count is not None and not need_count:     # sampled: a grid's N would be ignored
        raise ValueError(f"'{text}': with --samples the range is sampled, so N is not used: "
                         f"write {name}={lo.strip()}:{hi.strip()}")
    text = (lo.strip(), hi.strip())
    decimal_text = all(_DECIMAL.match(x) for x in text)
    return Range(name, lo_v, hi_v, count, text if decimal_text else ())


def api_error(study: Study, message: str):
    """The InputError of an API call's argument (what the command line checks by its options),
    at the study's model file."""
    from ..diagnostics import Diagnostic, InputError
    return InputError([Diagnostic(study.path, None, message)])


def check_names(study: Study, names, what: str) -> None:
    """InputError for a varied parameter the model does not have, or one given twice."""
    from ..diagnostics import did_you_mean
    for n in names:
        if n not in study.parameters:
            hint = did_you_mean(str(n), study.parameters) or \
                f" (parameters: {', '.join(study.parameters)})"
            raise api_error(study, f"{what}: unknown parameter '{n}'{hint}")
    if len(set(names)) != len(names):
        raise api_error(study, f"{what}: each parameter may be varied once")


def check_count(study: Study, n, what: str, least: int) -> None:
    if isinstance(n, bool) or not isinstance(n, int) or n < least:
        raise api_error(study, f"{what} must be a whole number >= {least}, not {n!r}")


def factorial(ranges: list[Range]) -> list[dict]:
    """Full factorial of the ranges' grids; the last range varies fastest."""
    grids = [r.values() for r in ranges]
    return [{r.name: float(v) for r, v in zip(ranges, combo)}
            for combo in itertools.product(*grids)]


def latin_hypercube(ranges: list[Range], n: int, seed: int) -> list[dict]:
    """n variants, one per stratum of every range, seeded (see the module docstring)."""
    rng = np.random.Generator(np.random.PCG64(seed))
    cols = []
    for r in ranges:
        u = (rng.permutation(n) + rng.random(n)) / n
        cols.append(r.lo + u * (r.hi - r.lo))
    return [{r.name: float(c[k]) for r, c in zip(ranges, cols)} for k in range(n)]


def header(study: Study, names: list[str]) -> list[str]:
    return (["variant"] + names + ["status", "kind", "t [s]", "message"]
            + [m.label for m in study.metrics])


def rows(study: Study, variants: list[dict], outcomes: list[Outcome]) -> list[list]:
    out = []
    for k, (v, o) in enumerate(zip(variants, outcomes), start=1):
        out.append([k] + list(v.values()) + [o.status, o.kind, o.t, o.message] + list(o.metrics))
    return out


def _cell(x) -> str:
    if isinstance(x, str):
        if any(c in x for c in ',"\n\r'):
            return '"' + x.replace('"', '""') + '"'
        return x
    if isinstance(x, (int, np.integer)):
        return str(x)
    # the shortest round-trip text, as the tables' vectorised formatter writes it (its
    # format_value, called per cell, made a large sweep.csv take several times as long to
    # write as the sweep took to solve; benchmarks/README.md, "Figures moved from the code's
    # comments")
    return "" if math.isnan(x) else repr(float(x))


def write_csv(path: Path, head: list[str], table: list[list]) -> None:
    """sweep.csv: numbers as the shortest round-trip text; empty where there is no value."""
    with open(path, "w", newline="") as f:
        f.write(",".join(head) + "\n")
        for row in table:
            f.write(",".join(_cell(x) for x in row) + "\n")


PLOT_FORMATS = ("png", "svg", "pdf")


class FilesNotWritten(WriteError, OSError):
    """A study's file that could not be written (a full disk, a file size limit): WriteError
    for the command line (exit 1, one line), and still the OSError it was for the API's
    callers."""


@contextlib.contextmanager
def staged(outdir: Path, family: tuple[str, ...]):
    """A study command's files in outdir (a model's directory it may share with `planarkin
    run`'s results, which keeps them: planarkin.output.directory.STUDY_FILES), all or none,
    under the directory's lock (a run or another study writing there meanwhile is refused):
    stage(name) gives the temporary path to write name to; at the end all are renamed into
    place together (a critical block) and the family's files this run did not write (the plot
    of an earlier run, now run with --no-plots; sweep.parquet without a Parquet library) are
    removed. An error or interruption before that leaves the earlier files as they were and
    no temporary behind; a killed run's temporaries are removed by the next. A file that
    cannot be written (a full disk, a file size limit) raises WriteError naming it."""
    from ..output.directory import checkpoint, critical, locked, path_error
    with locked(outdir):
        try:
            outdir.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise path_error(e, outdir) from None
        for old in outdir.glob(".tmp-*-*"):           # a killed run's (we hold the lock)
            m = re.match(r"\.tmp-(\d+)-(.+)$", old.name)
            if m and m.group(2) in family:
                old.unlink(missing_ok=True)
        tmp: dict[str, Path] = {}

        def stage(name: str) -> Path:
            tmp[name] = outdir / f".tmp-{os.getpid()}-{name}"   # (the suffix stays the format)
            return tmp[name]

        def failed(e: OSError, what: str):
            return FilesNotWritten(f"writing {what} failed: {e.strerror or e}; the earlier "
                                   f"files in {outdir}/ are left as they were", e.errno)

        try:
            try:
                yield stage
            except OSError as e:        # the file being written is the one staged last
                raise failed(e, next(reversed(tmp), "the study's files")) from None
            checkpoint()                # a signal lost in a finalizer: nothing goes in place
            with critical():
                written = set()
                try:
                    for name, path in tmp.items():
                        if path.exists():       # (staged but not written: sweep.parquet
                            os.replace(path, outdir / name)     # without a Parquet library)
                            written.add(name)
                    for name in family:
                        if name not in written:
                            (outdir / name).unlink(missing_ok=True)
                except OSError as e:
                    raise FilesNotWritten(f"putting the study's files into {outdir}/ failed: "
                                          f"{e.strerror or e}", e.errno) from None
        finally:
            for path in tmp.values():
                with contextlib.suppress(OSError):
                    path.unlink(missing_ok=True)


def write_parquet(path: Path, head: list[str], table: list[list]) -> str | None:
    """sweep.parquet through pyarrow or polars when one is importable; returns the library used
    or None."""
    cols = {h: [row[k] for row in table] for k, h in enumerate(head)}
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        pa = None
    if pa is not None:
        pq.write_table(pa.table(cols), path)
        return "pyarrow"
    try:
        import polars as pl
    except ImportError:
        return None
    pl.DataFrame(cols, strict=False).write_parquet(path)
    return "polars"


@dataclass
class SweepResult:
    variants: list[dict]
    outcomes: list[Outcome]
    files: list[Path]

    def counts(self) -> dict:
        return {s: sum(1 for o in self.outcomes if o.status == s)
                for s in ("ok", "failed", "invalid")}


def run_sweep(study: Study, ranges: list[Range], outdir: Path, samples: int | None = None,
              seed: int = 0, plots: str | None = "png", execute=None) -> SweepResult:
    """Run the variants (factorial of ranges, or samples of a Latin hypercube) and write
    sweep.csv (+ sweep.parquet, + sweep.png) into outdir. execute(study, variants) -> outcomes
    in order (default: serially in this process)."""
    from .budget import check_study
    if not isinstance(ranges, (list, tuple)) or not all(isinstance(r, Range) for r in ranges) \
            or not ranges:
        raise api_error(study, f"run_sweep(): ranges must be a non-empty list of Range (from "
                               f"parse_range('a=0.1:0.2:11', True)), not {ranges!r:.60}")
    if samples is not None:
        check_count(study, samples, "run_sweep(): samples", 1)
    elif any(r.n is None for r in ranges):
        raise api_error(study, f"run_sweep(): the range of "
                               f"'{next(r.name for r in ranges if r.n is None)}' has no number "
                               f"of values: give NAME=LO:HI:N, or samples")
    check_names(study, [r.name for r in ranges], "run_sweep()")
    count = math.prod(r.n for r in ranges) if samples is None else samples
    check_study(study, count, len(ranges) + len(study.metrics),
                "the N of each --vary" if samples is None else "--samples")
    variants = factorial(ranges) if samples is None else latin_hypercube(ranges, samples, seed)
    outcomes, lost = solve(execute, study, variants)
    names = [r.name for r in ranges]
    head = header(study, names)
    table = rows(study, variants, outcomes)
    files = [outdir / "sweep.csv"]
    family = ("sweep.csv", "sweep.parquet") + tuple(f"sweep.{f}" for f in PLOT_FORMATS)
    with staged(outdir, family) as stage:
        write_csv(stage("sweep.csv"), head, table)
        if write_parquet(stage("sweep.parquet"), head, table):
            files.append(outdir / "sweep.parquet")
        if plots:
            from .plots import sweep_plot
            P = np.array([[v[n] for n in names] for v in variants])
            M = np.array([o.metrics for o in outcomes], dtype=float).reshape(len(outcomes), -1)
            grid = [r.values() for r in ranges] if samples is None else None
            title = (f"{study.nominal.spec.name}: {len(variants)} variants "
                     + ("(full factorial)" if samples is None
                        else f"(Latin hypercube, seed {seed})"))
            sweep_plot(stage(f"sweep.{plots}"), names, P, [o.status for o in outcomes],
                       [m.label for m in study.metrics], M, grid, title)
            files.append(outdir / f"sweep.{plots}")
    if lost is not None:
        raise kept(lost, files[0])
    return SweepResult(variants, outcomes, files)
