"""One variant's outcome in a study: what the serial path (variants) and the batch both return."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Outcome:
    """One variant's result: status 'ok' | 'failed' | 'invalid'; kind: the stopping event's kind
    (lock-up, bifurcation, ...) or '' ; t: its time, s (nan when none); message: the reason;
    metrics: one value per metric (nan unless ok)."""

    status: str
    kind: str
    t: float
    message: str
    metrics: tuple
