"""Batch reporting (after black's report.py): one line per model, a summary line, and the exit
status decided here and nowhere else: 0 all ok, 1 an analysis failed, 2 invalid input or usage.
"""

from __future__ import annotations


import click

OK, FAILED, INVALID = 0, 1, 2
SIGNAL_EXIT = {"SIGINT": 130, "SIGTERM": 143}     # 128 + the signal number, as shells report


class Report:
    def __init__(self, quiet: bool = False):
        self.quiet = quiet
        self.counts = {OK: 0, FAILED: 0, INVALID: 0}
        self.signal: str | None = None      # set when the run was interrupted

    @staticmethod
    def _err(text: str) -> None:
        click.echo(text, err=True)

    def diagnostics(self, diags) -> None:
        for d in diags:
            if d.severity == "error" or not self.quiet:
                self._err(d.format())

    def ok(self, path: str, detail: str) -> None:
        self.counts[OK] += 1
        if not self.quiet:
            click.echo(f"ok       {path}: {detail}")

    def failed(self, path: str, message: str, detail: str = "") -> None:
        self.counts[FAILED] += 1
        self._err(f"{path}: error: {message}")
        click.echo(f"failed   {path}: {detail}" if detail else f"failed   {path}")

    def invalid(self, path: str, diags) -> None:
        self.counts[INVALID] += 1
        self.diagnostics(diags)
        n = sum(1 for d in diags if d.severity == "error")
        click.echo(f"invalid  {path}: {n} error{'s' if n != 1 else ''}")

    def interrupted(self, path: str | None, signame: str, detail: str) -> None:
        """The batch stops here: one line for the model being analysed."""
        self.signal = signame
        click.echo(f"interrupted {path}: {detail}" if path else f"interrupted: {detail}")

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
        total = sum(self.counts.values())
        parts = [f"{self.counts[OK]} ok"]
        if self.counts[FAILED]:
            parts.append(f"{self.counts[FAILED]} failed")
        if self.counts[INVALID]:
            parts.append(f"{self.counts[INVALID]} invalid")
        if self.signal is not None:
            parts.append(f"interrupted by {self.signal}")
        click.echo(f"{total} model{'s' if total != 1 else ''} {verb}: {', '.join(parts)}")
