"""Batch reporting (after black's report.py): one line per model, a summary line, and the exit
status decided here and nowhere else: 0 all ok, 1 an analysis failed, 2 invalid input or usage;
for `compare` on two result roots (CompareReport): 0 all same, 1 a model differs or is missing
on one side, 2 unusable input.

Each model's outcome is also kept as an Entry (what it is, why, its terminal text, its seconds):
`--junit` writes them as a JUnit XML report (junit_cases: one test case per model, in order).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import click

OK, FAILED, INVALID = 0, 1, 2
ENTRIES = "entries"     # Report.counts' list of the models' entries (see Report)
SIGNAL_EXIT = {"SIGINT": 130, "SIGTERM": 143}     # 128 + the signal number, as shells report

# a model's outcome -> its JUnit element: None passed, else failure, error or skipped
VERDICT = {"ok": None, "same": None, "failed": "failure", "differs": "failure",
           "missing": "failure", "invalid": "error", "unusable": "error",
           "interrupted": "error", "skipped": "skipped"}


@dataclass
class Entry:
    """One model's outcome. name: the model as given (run: its file; compare: its directory's
    name); outcome: a key of VERDICT; message: one line saying why (empty when it passed);
    text: the lines the terminal had for it (its line, its diagnostics); seconds: its time."""

    name: str
    outcome: str
    message: str
    text: str
    seconds: float


class Report:
    """The lines and the exit status of `run`, `check` and the study commands.

    counts: per status the number of models, and under ENTRIES the list of their entries in
    order. A `run --jobs` parent adds its workers' counts into its own key by key (+=:
    numbers add, lists concatenate, in model order: planarkin.run._run_parallel), so each
    model's entry reaches the parent's report with its count."""

    def __init__(self, quiet: bool = False):
        self.quiet = quiet
        self.counts = {OK: 0, FAILED: 0, INVALID: 0, ENTRIES: []}
        self.signal: str | None = None      # set when the run was interrupted
        self.started = self._lap = time.perf_counter()

    @property
    def entries(self) -> list[Entry]:
        return self.counts[ENTRIES]

    def _entry(self, path, outcome: str, message: str, text: str) -> None:
        """Keep a model's entry; its seconds: since the previous entry (or the start)."""
        now = time.perf_counter()
        self.counts[ENTRIES].append(Entry(str(path), outcome, message, text, now - self._lap))
        self._lap = now

    @staticmethod
    def _err(text: str) -> None:
        click.echo(text, err=True)

    def diagnostics(self, diags) -> None:
        for d in diags:
            if d.severity == "error" or not self.quiet:
                self._err(d.format())

    def ok(self, path: str, detail: str) -> None:
        self.counts[OK] += 1
        self._entry(path, "ok", "", f"ok       {path}: {detail}")
        if not self.quiet:
            click.echo(f"ok       {path}: {detail}")

    def failed(self, path: str, message: str, detail: str = "") -> None:
        self.counts[FAILED] += 1
        line = f"failed   {path}: {detail}" if detail else f"failed   {path}"
        self._entry(path, "failed", message, f"{path}: error: {message}\n{line}")
        self._err(f"{path}: error: {message}")
        click.echo(line)

    def invalid(self, path: str, diags) -> None:
        self.counts[INVALID] += 1
        self.diagnostics(diags)
        n = sum(1 for d in diags if d.severity == "error")
        line = f"invalid  {path}: {n} error{'s' if n != 1 else ''}"
        first = [d for d in diags if d.severity == "error"][:1]
        self._entry(path, "invalid", f"invalid input: {n} error{'s' if n != 1 else ''}"
                                     + "".join(f"; {d.format()}" for d in first),
                    "\n".join([d.format() for d in diags] + [line]))
        click.echo(line)

    def interrupted(self, path: str | None, signame: str, detail: str) -> None:
        """The batch stops here: one line for the model being analysed."""
        self.signal = signame
        line = f"interrupted {path}: {detail}" if path else f"interrupted: {detail}"
        if path is not None:
            self._entry(path, "interrupted", f"interrupted by {signame}: {detail}", line)
        click.echo(line)

    def warning(self, path: str, message: str) -> None:
        if not self.quiet:
            self._err(f"{path}: warning: {message}")

    @property
    def exit_code(self) -> int:
        if self.signal is not None:
            return SIGNAL_EXIT[self.signal]
        if self.counts[INVALID]:
            return INVALID
        if self.counts[FAILED]:
            return FAILED
        return OK

    def summary(self, verb: str = "analysed") -> None:
        """The closing line, always printed (with --quiet too: it is what a CI log keeps)."""
        total = self.counts[OK] + self.counts[FAILED] + self.counts[INVALID]
        parts = [f"{self.counts[OK]} ok"]
        if self.counts[FAILED]:
            parts.append(f"{self.counts[FAILED]} failed")
        if self.counts[INVALID]:
            parts.append(f"{self.counts[INVALID]} invalid")
        if self.signal is not None:
            parts.append(f"interrupted by {self.signal}")
        click.echo(f"{total} model{'s' if total != 1 else ''} {verb}: {', '.join(parts)}")

    def model_entries(self, models) -> list[Entry]:
        """One entry per model argument, in order: its own, or `skipped` for a model the batch
        never reached (an interruption stopped it first). A model given twice has an entry
        per run; a model with two entries (its line, then a failure as it was reported) has
        the worse."""
        queue: dict[str, list[Entry]] = {}
        for e in self.entries:
            queue.setdefault(e.name, []).append(e)
        left = {}
        for m in map(str, models):
            left[m] = left.get(m, 0) + 1
        out = []
        for m in map(str, models):
            left[m] -= 1
            mine = queue.get(m, [])
            take = (mine[:1] if left[m] else mine[:])     # the last run of m takes the rest
            del mine[:len(take)]
            if not take:
                why = (f"not analysed: the run was interrupted by {self.signal} first"
                       if self.signal else "not analysed")
                out.append(Entry(m, "skipped", why, why, 0.0))
            else:
                out.append(max(take, key=lambda e: _RANK[e.outcome]))
        return out


_RANK = {"ok": 0, "same": 0, "skipped": 1, "failed": 2, "differs": 2, "missing": 2,
         "invalid": 3, "unusable": 3, "interrupted": 4}


class CompareReport:
    """The lines and the exit status of `compare` on two result roots: a line per model (same,
    differs, missing on one side, unusable), a summary line; the exit status the worst."""

    WORDS = ("same", "differs", "missing", "unusable")

    def __init__(self):
        self.entries: list[Entry] = []
        self.started = time.perf_counter()

    def add(self, name: str, outcome: str, line: str, text: str, seconds: float) -> None:
        """outcome: one of WORDS; line: what the terminal says after NAME (its message)."""
        self.entries.append(Entry(name, outcome, line, text, seconds))
        click.echo(f"{outcome:<8} {name}: {line}")

    def count(self, outcome: str) -> int:
        return sum(1 for e in self.entries if e.outcome == outcome)

    @property
    def exit_code(self) -> int:
        if self.count("unusable"):
            return INVALID
        if self.count("differs") or self.count("missing"):
            return FAILED
        return OK

    def summary(self) -> None:
        n = len(self.entries)
        parts = [f"{self.count(w)} {w}" for w in self.WORDS if w == "same" or self.count(w)]
        click.echo(f"{n} model{'s' if n != 1 else ''} compared: {', '.join(parts)}")


def junit_cases(entries, classname: str):
    """The JUnit test cases of entries (planarkin.output.junit.Case), in order."""
    from .output.junit import Case
    return [Case(e.name, classname, e.seconds, VERDICT[e.outcome], e.message, e.text)
            for e in entries]
