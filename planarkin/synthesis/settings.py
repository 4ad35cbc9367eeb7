"""The search settings of a synthesis: the caller's options checked as the design block's are
(spec.SEARCH), and the search's cost checked against the study budget before the first analysis
(planarkin.studies.budget)."""

from __future__ import annotations

import math

from .problem import memory_problem


def search_options(path, search: dict) -> dict:
    """The search settings given by the caller (None: the design block's), checked as the
    design block's are (spec.SEARCH); InputError naming the option otherwise."""
    from ..diagnostics import Diagnostic, InputError, did_you_mean
    from .spec import SEARCH
    out, errs = {}, []
    for key, val in search.items():
        if val is None:
            continue
        if key not in SEARCH:
            errs.append(f"synthesize: unknown option '{key}'"
                        f"{did_you_mean(key, SEARCH) or ' (valid: ' + ', '.join(SEARCH) + ')'}")
            continue
        typ, lo, hi, _ = SEARCH[key]
        ok = isinstance(val, (int, float)) and not isinstance(val, bool) and math.isfinite(val)
        if not ok or (typ is int and val != int(val)) or not lo <= val <= hi:
            what = "a whole number" if typ is int else "a number"
            errs.append(f"synthesize: {key} must be {what} from {lo:g} to {hi:g}, not {val!r}")
            continue
        out[key] = typ(val)
    if errs:
        raise InputError([Diagnostic(str(path), None, e) for e in errs])
    return out


LOCAL = 10     # local runs a draw unless given, or with probe: every accepted start of the draw


def settled(cfg: dict) -> dict:
    """The search settings with the defaults that follow from others: local, when not given,
    is LOCAL, or with probe (short runs, abandoned when they fall too slowly) every start of
    a draw, so that the many cheap runs that find a narrow basin are all made."""
    if cfg["local"] is None:
        cfg = {**cfg, "local": cfg["starts"] if cfg["probe"] else LOCAL}
    return cfg


def check_cost(syn, cfg, total: int, size: int) -> None:
    """InputError, before the first analysis, when the search would pass the study budget
    (planarkin.studies.budget, whose figures per grid row and per analysis it uses): the grids
    held at once (the starts of a batch kept for the local runs, the designs kept, the one
    being analysed) against STUDY_BYTES, the analyses of the starts against STUDY_SECONDS."""
    from ..diagnostics import Diagnostic, InputError
    from ..studies.budget import STUDY_SECONDS, study_cost
    m = syn.model
    starts = min(size, cfg["local"])
    errors = [memory_problem(m, starts + cfg["keep"] + 1, (
        f"{starts} start(s) for the local runs, {cfg['keep']} design(s) kept, the one being "
        f"analysed"), " (or fewer --local runs, or a smaller design: search: batch)"
        if starts > 1 else "", k=syn.k)]
    seconds = study_cost(m.nominal, m.study.opts, 1, syn.k)[1]
    if total * seconds > STUDY_SECONDS:
        errors.append(
            f"the search would analyse {total} starts of {m.study.opts.rows} grid rows: about "
            f"{total * seconds / 3600:.3g} h, more than the budget of "
            f"{STUDY_SECONDS / 3600:.3g} h: use fewer --starts (or fewer --steps)")
    errors = [e for e in errors if e]
    if errors:
        raise InputError([Diagnostic(m.path, None, "synth: " + e) for e in errors])
