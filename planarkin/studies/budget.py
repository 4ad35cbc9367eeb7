"""The budget of a study (sweep, tolerance): checked before the first variant is drawn, so that
a study too large for memory or a day is refused at once with the option to change."""

from __future__ import annotations

from .batch import GROUP

# The per-variant and per-row figures below come from measurements on the slider-crank in one
# process (benchmarks/README.md, "Figures moved from the code's comments"), the memory ones
# rounded up: a variant's bookkeeping (its values, outcome, table row) is held to the end, and
# every row of the variants solved together is held while they are solved.
STUDY_BYTES = 2**30              # memory a study may take in one process
STUDY_SECONDS = 24 * 3600        # estimated time a study may take
VARIANT_BYTES = 1000             # per variant, plus VALUE_BYTES per parameter and metric
VALUE_BYTES = 100
ROW_BYTES = 100                  # per grid row, variant in flight and column (coordinates and
                                 # point coordinates)
VARIANT_SECONDS = 0.012
ROW_SECONDS = 6e-6


def study_cost(cm, opts, variants: int, values: int) -> tuple[float, float]:
    """(bytes, seconds) a study of `variants` variants of compiled model cm with options opts
    is estimated to take; values: parameters plus metrics per variant. Variants solved
    together (studies.batch.GROUP) hold their grids at once."""
    columns = cm.n + 2 * len(cm.point_names)
    flight = min(variants, GROUP)
    memory = variants * (VARIANT_BYTES + VALUE_BYTES * values) + \
        flight * opts.rows * ROW_BYTES * columns
    seconds = variants * (VARIANT_SECONDS + opts.rows * ROW_SECONDS)
    return float(memory), float(seconds)


def check_study(study, variants: int, values: int, count: str) -> None:
    """InputError when the study would pass STUDY_BYTES or STUDY_SECONDS, with both figures and
    the options to change: count (how the number of variants is set, e.g. '--samples') and
    --steps when the grid rows are what take the memory."""
    memory, seconds = study_cost(study.nominal, study.opts, variants, values)
    if memory <= STUDY_BYTES and seconds <= STUDY_SECONDS:
        return
    from ..diagnostics import Diagnostic, InputError
    rows = study.opts.rows
    grid_heavy = study.opts.rows * ROW_BYTES * (study.nominal.n + 2 * len(
        study.nominal.point_names)) * min(variants, GROUP) > memory / 2
    fix = (f"fewer --steps (the variants solved together, up to {GROUP}, hold every grid "
           f"row)" if grid_heavy else f"fewer variants ({count}), or split it into smaller "
           f"studies")
    raise InputError([Diagnostic(study.path, None, (
        f"a study of {variants} variants of {rows} grid rows each would take about "
        f"{_size(memory)} of memory and {_duration(seconds)} (the budget: {_size(STUDY_BYTES)} "
        f"and {_duration(STUDY_SECONDS)}): use {fix}"))])


def _size(b: float) -> str:
    return f"{b / 2**30:.3g} GB" if b >= 2**30 else f"{b / 2**20:.3g} MB"


def _duration(s: float) -> str:
    return f"{s / 3600:.3g} h" if s >= 3600 else f"{s:.3g} s"
