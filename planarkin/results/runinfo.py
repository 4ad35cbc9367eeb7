"""A run's account except the arrays (`RunInfo`): what results produces and output writes (a
leaf of both, so that the writer's annotations import no module that imports the writer)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from planarkin.options import Options
from planarkin.solver.path import Event


@dataclass
class RunInfo:
    """Everything about a run except the arrays: status, events, counters, timings."""

    status: int                      # 0 ok, 1 analysis failure
    message: str
    options: Options
    event: Event | None
    warnings: list
    assembly: dict
    internal_steps: int
    rejected_steps: int
    fallbacks: int
    timings: dict = field(default_factory=dict)
    diagnostics: list = field(default_factory=list)   # assembly warnings (FILE:LINE: warning)
    breakpoints: dict = field(default_factory=dict)   # drivers' breakpoints (Analysis.breakpoint_info)
    interrupted: str | None = None   # 'SIGINT' / 'SIGTERM': the rows up to then are complete
    loops: Any = None                # planarkin.measures.loops.LoopFigures (summary's loops)

    @property
    def success(self) -> bool:
        return self.status == 0
