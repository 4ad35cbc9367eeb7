"""Diagnostics are data: where (file, line), what (message naming the element), and the fix (hint).

Every problem found while reading or validating a model becomes a `Diagnostic`. The readers
collect all of them for a file and raise one `InputError`; the CLI prints them compiler-style
(``FILE:LINE: error: message``) and exits with status 2. Numerical trouble during the analysis is
not a diagnostic: it is a status in the result (see `planarkin.results`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence


@dataclass(frozen=True)
class Diagnostic:
    """One problem in an input file.

    file: path as the user gave it; line: 1-based line of the offending YAML node (None when the
    problem is about the whole file, e.g. it cannot be read); message: what is wrong, naming the
    element (``joint 3 (revolute crank-rod)``) and, where one is known, the fix.
    """

    file: str
    line: int | None
    message: str
    severity: str = "error"

    def format(self) -> str:
        """One line, whatever the message quotes from the file (control characters such as a
        line break inside a quoted name are shown escaped, so every line starts FILE:LINE)."""
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        return _one_line(f"{where}: {self.severity}: {self.message}")

    def __str__(self) -> str:  # pragma: no cover - convenience
        return self.format()


_CONTROL = {c: f"\\x{c:02x}" for c in range(32)} | {10: "\\n", 13: "\\r", 9: "\\t", 127: "\\x7f"}


def _one_line(text: str) -> str:
    return text.translate(_CONTROL)


class InputError(Exception):
    """Invalid input: carries every diagnostic found in one file (exit status 2)."""

    def __init__(self, diagnostics: Sequence[Diagnostic]):
        self.diagnostics = list(diagnostics)
        super().__init__("\n".join(d.format() for d in self.diagnostics))


class Collector:
    """Accumulates diagnostics for one file; `raise_if_any` turns them into an InputError.

    Diagnostics are kept in line order (stable for equal lines), so that the output reads top to
    bottom like a compiler's.
    """

    def __init__(self, file: str):
        self.file = file
        self.items: list[Diagnostic] = []

    def error(self, line: int | None, message: str) -> None:
        self.items.append(Diagnostic(self.file, line, message))

    def warning(self, line: int | None, message: str) -> None:
        self.items.append(Diagnostic(self.file, line, message, severity="warning"))

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.items if d.severity == "error"]

    def raise_if_any(self) -> None:
        errs = self.errors
        if errs:
            errs.sort(key=lambda d: (d.line is not None, d.line or 0))
            raise InputError(errs)


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """Return ``"; did you mean 'rod'?"`` for the closest choice within a typo's reach (one edit
    below eight letters, two from eight on, case ignored; a swap of two neighbours counts as one
    edit; in names of up to three letters a replaced letter does not count; a name of four letters or
    more cut short of exactly one choice), or ``""``: a
    suggestion further away than a slip of the keyboard misleads."""
    choices = [c for c in choices if isinstance(c, str)]
    name = str(name)
    if len(name) >= 4:             # a name cut short ('cycloid' for 'cycloidal')
        longer = [c for c in choices if c.lower().startswith(name.lower()) and c != name]
        if len(longer) == 1:
            return f"; did you mean '{longer[0]}'?"
    best, best_d = None, None
    low = name.lower()
    letters = set(low)
    for c in choices:
        # a name whose letters differ from these in more than 4 (two edits' worth) is too far
        # before the alignment is computed: thousands of names cost no more than a glance each
        if len(letters.symmetric_difference(c.lower())) > 4:
            continue
        d = _edits(low, c.lower())
        if best_d is None or d < best_d:
            best, best_d = c, d
    if best is None or best_d > (1 if len(name) < 8 else 2):
        return ""
    if len(name) <= 3 and best_d == 1 and len(best) == len(name) and \
            sorted(best.lower()) != sorted(name.lower()):
        return ""          # one letter of two or three replaced: another name, not a slip
    return f"; did you mean '{best}'?"


def _edits(a: str, b: str) -> int:
    """Optimal string alignment distance: insertions, deletions, substitutions and swaps of
    neighbours (Damerau-Levenshtein without repeated edits of one substring)."""
    if abs(len(a) - len(b)) > 2:
        return 3
    prev2, prev = None, list(range(len(b) + 1))
    for i in range(1, len(a) + 1):
        cur = [i] + [0] * len(b)
        for j in range(1, len(b) + 1):
            cost = a[i - 1] != b[j - 1]
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + cost)
            if i > 1 and j > 1 and a[i - 1] == b[j - 2] and a[i - 2] == b[j - 1]:
                cur[j] = min(cur[j], prev2[j - 2] + 1)
        prev2, prev = prev, cur
    return prev[len(b)]


def one_of(choices: Iterable[str]) -> str:
    """Human list of choices: ``'a', 'b' or 'c'``."""
    items = [f"'{c}'" for c in choices]
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " or " + items[-1]
