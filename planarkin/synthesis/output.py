"""Result directories of `planarkin synth` and `planarkin fit` (the output contract of `run`:
one directory per model, put in place whole by planarkin.output.directory.ResultDirectory, with
a summary.json).

synth: summary.json, designs.csv (one row per design: cost, parameters, free times),
residuals.csv (per target point and constraint), design-1.yaml ... (ready-to-run models),
synth.png (targets against the achieved path, law or poses).
fit: summary.json, estimates.csv (estimate, standard error, correlations), residuals.csv,
fitted.yaml, fit.png (measured against fitted trajectories).

Every write is checked: a file that cannot be written (disk full, a file size limit) abandons
the new directory, leaving the previous one as it was, and raises WriteError naming the file
(exit 1 in the CLI, as for `run`). The written models carry every --set value, so that running
one reproduces the residuals its header states. A search interrupted with designs found is
written as such (summary.json status "interrupted"); `interrupted` says what an interruption
left on disk.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
from pathlib import Path

import numpy as np

from ..version import __version__
from . import timing


def model_yaml(path, values: dict, q0=None, header: str = "") -> str:
    """The model file's data with `values` as its parameters, the bodies' estimates replaced by
    the assembled pose q0 (user units, file order) so that it assembles on the same branch, and
    no design block: a model `planarkin run` analyses as it stands."""
    import yaml
    with open(path, encoding="utf-8") as f:
        data = yaml.safe_load(f)
    data.pop("design", None)
    params = data.setdefault("parameters", {})
    for k, v in values.items():
        params[k] = float(v)
    if q0 is not None and isinstance(data.get("bodies"), dict):
        for k, name in enumerate(data["bodies"]):
            if isinstance(data["bodies"][name], dict):
                data["bodies"][name]["q"] = [float(v) for v in q0[3 * k:3 * k + 3]]
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    return "".join(f"# {line}\n" for line in header.splitlines()) + text


def fixed_values(cm, free) -> dict:
    """The --set values of a compiled model (their numbers, as the search used them) other than
    the free parameters: a written model must carry them, or it is not the design whose
    residuals it states."""
    return {k: float(v) for k, v in cm.spec.overrides.items() if k not in free}


def _set_line(fixed: dict) -> str:
    return ("\nset: " + ", ".join(f"{n} = {v!r}" for n, v in fixed.items())) if fixed else ""


@contextlib.contextmanager
def _writing(name: str):
    """An OSError (disk full, a file size limit, an I/O error) while writing `name` becomes
    WriteError naming it."""
    from ..output.directory import WriteError
    try:
        yield
    except OSError as e:
        raise WriteError(f"writing {name} failed: {e.strerror or e}") from None


def _write_text(rd, name: str, text: str) -> None:
    with _writing(name), open(rd.path(name), "w", encoding="utf-8") as f:
        f.write(text)


def _stage(outdir: Path):
    """The new result directory, staged in a critical block: a signal while it is made cannot
    leave a temporary directory that nothing removes."""
    from ..output.directory import ResultDirectory, critical
    rd = None
    try:
        with critical():
            rd = ResultDirectory(Path(outdir))
    except KeyboardInterrupt as e:
        if rd is not None:          # made, and the signal raised as the block ended
            rd.abandon()
        e.stage = "writing"
        raise
    return rd


def _put_in_place(rd) -> None:
    """Commit rd whole (a signal waits until it is in place: raised then, marked 'written');
    an OSError abandons the new directory (WriteError)."""
    from ..output.directory import WriteError, critical
    try:
        with critical():
            try:
                rd.commit()
            except OSError as e:
                rd.abandon()
                raise WriteError(f"putting {rd.final.name}/ in place failed: "
                                 f"{e.strerror or e}") from None
    except KeyboardInterrupt as e:
        e.stage = "written"
        raise


def _write_csv(rd, name, head, rows):
    with _writing(name), open(rd.path(name), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(head)
        for r in rows:
            w.writerow([f"{x:.17g}" if isinstance(x, float) else x for x in r])


def _json(x):
    if isinstance(x, dict):
        return {k: _json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.ndarray):
        return _json(x.tolist())
    return x


def write_synth(res, outdir: Path, plots: str | None = "png") -> Path:
    """The result directory of a synthesis (see the module docstring): put in place whole, or
    the previous one left as it was (WriteError, OutputError, an interruption)."""
    syn = res.model
    rd = _stage(outdir)
    try:
        names = list(syn.design.free)
        # the free times: of every target without inputs (unknowns or projected)
        free = [i for i, tg in enumerate(syn.design.targets) if tg.free_timing
                and tg.kind != "function"]
        nfree = sum(len(syn.design.targets[i]) for i in free)
        # the offsets (and steps) found of targets with inputs relative to one (timing.py)
        found = [timing.report(syn, d.x) for d in res.designs]
        ucols = [(e, key) for e, r in enumerate(found[0] if found else []) for key in
                 ("offset", "step") if key in r["found"]]
        _write_csv(rd, "designs.csv",
                   ["design", "cost"] + names + [f"t{j + 1} [s]" for j in range(nfree)]
                   + [f"target {found[0][e]['target']} {key} [{found[0][e]['unit']}]"
                      for e, key in ucols] + ["evaluations", "jacobians"],
                   [[k + 1, d.cost] + [d.values[n] for n in names]
                    + [t for i in free for t in d.times[i]]
                    + [found[k][e][key] for e, key in ucols]
                    + [d.nfev, d.njev] for k, d in enumerate(res.designs)])
        rows = []
        for k, d in enumerate(res.designs):
            for tg, R, times in zip(syn.design.targets, d.residuals, d.times):
                for e in range(len(R)):
                    rows.append([k + 1, tg.label, e + 1, times[e]] + list(R[e]) +
                                [""] * (3 - R.shape[1]) + [float(np.linalg.norm(R[e]))])
            for name, m in d.margins.items():
                rows.append([k + 1, f"constraint {name}", "", "", m["value"], "", "",
                             "ok" if m["ok"] else "violated"])
        _write_csv(rd, "residuals.csv",
                   ["design", "target", "index", "t [s]", "r1", "r2", "r3", "norm / margin"],
                   rows)
        files = []
        for k, d in enumerate(res.designs):
            st = d.state
            fixed = fixed_values(st.cm if st is not None else syn.model.nominal, names)
            fn = f"design-{k + 1}.yaml"
            files.append(fn)
            header = (f"design {k + 1} of planarkin synth {syn.model.path}: sum of squared "
                      f"residuals {d.cost:.6g}\nparameters: " +
                      ", ".join(f"{n} = {v:.10g}" for n, v in d.values.items()) +
                      "".join(f"\ntarget {r['target']}: inputs from offset {r['offset']:.10g}"
                              + (f" in steps of {r['step']:.10g}" if r["step"] is not None
                                 else "") + f" {r['unit']}" for r in found[k]) +
                      _set_line(fixed))
            with _writing(fn):      # the model file is read again (it may be gone by now)
                text = model_yaml(syn.model.path, {**fixed, **d.values},
                                  st.result.q[0] if st is not None else None, header)
            _write_text(rd, fn, text)
        if plots and res.designs:
            with _writing(f"synth.{plots}"):
                _plot_synth(res, rd.path(f"synth.{plots}"))
        status = ("interrupted" if getattr(res, "interrupted", None) else
                  "ok" if res.status == 0 else "failed")
        summary = {"planarkin": __version__, "command": "synth", "model": syn.model.path,
                   "status": status, "message": res.message,
                   "evaluations": res.evaluations, "analyses": res.analyses,
                   "jacobians": res.jacobians, "ended": getattr(res, "ended", None),
                   "seconds": res.seconds, "rejected_starts": res.rejected,
                   "set": fixed_values(syn.model.nominal, names),
                   "designs": [{"file": f, "cost": d.cost, "parameters": d.values,
                                "times": d.times, "margins": d.margins,
                                "inputs": [{key: r[key] for key in ("target", "offset",
                                                                    "step", "unit")}
                                           for r in found[k]],
                                "evaluations": d.nfev, "jacobians": d.njev}
                               for k, (f, d) in enumerate(zip(files, res.designs))]}
        _write_text(rd, "summary.json", json.dumps(_json(summary), indent=2))
    except BaseException as e:
        rd.abandon()
        if isinstance(e, KeyboardInterrupt):
            e.stage = "writing"
        raise
    _put_in_place(rd)
    return Path(outdir)


def _plot_synth(res, path):
    from matplotlib.figure import Figure     # not pyplot: an API caller's backend stays its own

    from ..output.plots.render import save_figure
    syn = res.model
    tgs = syn.design.targets
    fig = Figure(figsize=(5.5 * len(tgs), 5))
    axes = fig.subplots(1, len(tgs), squeeze=False)
    for ax, (i, tg) in zip(axes[0], enumerate(tgs)):
        for k, d in enumerate(res.designs):
            st = d.state
            grid = st.result
            sty = dict(lw=1.5 if k == 0 else 0.8, alpha=1.0 if k == 0 else 0.5)
            if tg.kind == "function":
                body, _, qty = tg.name.rpartition(".")
                col = 3 * syn.bodies.index(body) + ("x", "y", "phi").index(qty)
                u = syn.model.input_values(st.cm, grid.t)
                ax.plot(u, grid.q[:, col], label=f"design {k + 1}", **sty)
            else:
                j = syn.points.index(tg.point if tg.kind == "motion" else tg.name)
                ax.plot(grid.p[:, j, 0], grid.p[:, j, 1], label=f"design {k + 1}", **sty)
                if k == 0:
                    idx = slice(sum(len(x) for x in d.times[:i]),
                                sum(len(x) for x in d.times[:i + 1]))
                    ax.plot(st.p[idx, j, 0], st.p[idx, j, 1], "x", color="C0", ms=8,
                            label="achieved")
        v = np.array(tg.values, dtype=float)
        if tg.kind == "function":
            best = res.designs[0]
            u = tg.inputs if tg.timing is None else \
                timing.inputs(syn, best.state.cm, i, best.x[syn.k + syn.nt:])
            ax.plot(u, v, "o", mfc="none", color="k", label="targets")
            ax.set_xlabel(f"input [{syn.unit}]")
            ax.set_ylabel(f"{tg.name} [{syn.unit if tg.name.endswith('.phi') else syn.lunit}]")
        else:
            ax.plot(v[:, 0], v[:, 1], "o", mfc="none", color="k", ms=9, label="targets")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel(f"x [{syn.lunit}]")
            ax.set_ylabel(f"y [{syn.lunit}]")
        ax.set_title(tg.label)
        ax.legend(fontsize=8)
    fig.suptitle(f"{Path(syn.model.path).stem}: best sum of squares "
                 f"{res.designs[0].cost:.3g}")
    fig.tight_layout()
    save_figure(fig, Path(path))


def write_fit(res, outdir: Path, plots: str | None = "png") -> Path:
    """The result directory of a fit (see the module docstring), put in place whole or not at
    all."""
    rd = _stage(outdir)
    try:
        names = res.names
        _write_csv(rd, "estimates.csv",
                   ["parameter", "estimate", "standard error", "start"] +
                   [f"corr {n}" for n in names],
                   [[n, float(res.estimate[i]), float(res.se[i]), float(res.start[i])] +
                    [float(c) for c in res.corr[i]] for i, n in enumerate(names)])
        D = res.data
        _write_csv(rd, "residuals.csv", ["t [s]"] + [f"{c[2]} residual" for c in D.columns],
                   [[float(t)] + [float(x) for x in row] for t, row in zip(D.t, res.residuals)])
        m = res.model
        st = res.state
        fixed = fixed_values(st.cm if st is not None else m.nominal, names)
        with _writing("fitted.yaml"):
            text = model_yaml(m.path, {**fixed, **dict(zip(names, res.estimate))},
                              st.result.q[0] if st is not None else None,
                              f"planarkin fit {m.path}: rms residual {res.rms:.6g}"
                              + _set_line(fixed))
        _write_text(rd, "fitted.yaml", text)
        if plots and st is not None:
            with _writing(f"fit.{plots}"):
                _plot_fit(res, rd.path(f"fit.{plots}"))
        summary = {"planarkin": __version__, "command": "fit", "model": m.path,
                   "status": "ok" if res.status == 0 else "failed", "message": res.message,
                   "parameters": {n: {"estimate": res.estimate[i], "se": res.se[i],
                                      "start": res.start[i]} for i, n in enumerate(names)},
                   "set": fixed,
                   "correlation": res.corr, "rms_residual": res.rms, "dof": res.dof,
                   "evaluations": res.evaluations, "jacobians": res.jacobians,
                   "seconds": res.seconds}
        _write_text(rd, "summary.json", json.dumps(_json(summary), indent=2))
    except BaseException as e:
        rd.abandon()
        if isinstance(e, KeyboardInterrupt):
            e.stage = "writing"
        raise
    _put_in_place(rd)
    return Path(outdir)


def _plot_fit(res, path):
    from matplotlib.figure import Figure

    from ..output.plots.render import save_figure
    D, st = res.data, res.state
    pts = sorted({c[0] for c in D.columns})
    fig = Figure(figsize=(6, 5))
    ax = fig.subplots()
    cm = st.cm
    for p in pts:
        cx = [k for k, c in enumerate(D.columns) if c[0] == p and c[1] == 0]
        cy = [k for k, c in enumerate(D.columns) if c[0] == p and c[1] == 1]
        name = cm.point_names[p]
        if cx and cy:
            ax.plot(D.y[:, cx[0]], D.y[:, cy[0]], ".", ms=3, label=f"{name} measured")
            ax.plot(st.p[:, p, 0], st.p[:, p, 1], "-", lw=1, label=f"{name} fitted")
    ax.set_aspect("equal", adjustable="datalim")
    u = cm.spec.length_unit
    ax.set_xlabel(f"x [{u}]")
    ax.set_ylabel(f"y [{u}]")
    ax.set_title(f"fit: rms residual {res.rms:.3g} {u}")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, Path(path))


def interrupted(e: KeyboardInterrupt, outdir: Path, plots: str | None = "png") -> str:
    """What an interruption of synth or fit leaves on disk, said as the report's detail. The
    designs a search verified before it (the exception's `partial` SynthResult) are written,
    summary.json saying status interrupted; otherwise nothing was written and the previous
    directory stays as it was (the new one, if staged, was removed)."""
    from ..output.directory import OutputError, WriteError
    kept = f"nothing was written; {outdir}/ is left as it was"
    stage = getattr(e, "stage", None)
    if stage == "written":
        return f"after the results were put in place -> {outdir}/"
    if stage == "writing":
        return f"while the results were being written: {kept}"
    partial = getattr(e, "partial", None)
    if partial is not None:
        n = partial.evaluations
        what = f"during the search after {n} evaluation{'s' if n != 1 else ''}"
        if not partial.designs:
            return f"{what}, before a design was verified: {kept}"
        try:
            write_synth(partial, outdir, plots)
        except (OutputError, WriteError) as w:
            return f"{what}: the designs verified so far could not be written ({w}); {kept}"
        except KeyboardInterrupt:
            return f"{what}: {kept}"
        return (f"{what}: the {len(partial.designs)} design(s) verified so far (best sum of "
                f"squares {partial.designs[0].cost:.3g}) -> {outdir}/, status interrupted")
    if hasattr(e, "evaluations"):
        n = e.evaluations
        return f"during the fit after {n} evaluation{'s' if n != 1 else ''}: {kept}"
    return f"before the search began: {kept}"
