"""`planarkin tolerance`: Monte-Carlo tolerance analysis with exact first-order sensitivities.

Each sample draws every toleranced parameter as nominal + sigma * z, z standard normal
(``--dist normal``) or uniform on [-sqrt(3), sqrt(3)] (``--dist uniform``: the same standard
deviation sigma, half-width sigma sqrt(3)), from numpy's PCG64 generator seeded with the seed,
all draws made before any sample is solved (so the samples, and every result, are the same bit
for bit however the samples are distributed over processes). The outputs are the metrics of
`planarkin.studies.variants`, including ``dev:POINT``, the largest distance of a point's path
from its nominal path.

First order: for an output on a position column (max, min, stroke, absmax of x, y, phi of a
body or x, y of a point) d(output)/dp is the exact sensitivity (planarkin.studies.sensitivity) at
the time of the nominal's refined extreme, and the first-order standard deviation is
sqrt(sum_p (d(output)/dp sigma_p)^2), to set against the Monte-Carlo spread.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .execute import kept, solve
from .sweep import PLOT_FORMATS, staged, write_csv
from .variants import Outcome, Study

PERCENTILES = (1, 5, 50, 95, 99)
DISTRIBUTIONS = ("normal", "uniform")


def draw(names: list[str], nominal: dict, sigma: dict, n: int, seed: int, dist: str):
    """n variants (dicts) of the toleranced parameters; all draws at once, in order."""
    rng = np.random.Generator(np.random.PCG64(seed))
    k = len(names)
    if dist == "normal":
        Z = rng.standard_normal((n, k))
    else:
        Z = rng.uniform(-math.sqrt(3.0), math.sqrt(3.0), (n, k))
    V = np.array([nominal[p] for p in names]) + Z * np.array([sigma[p] for p in names])
    return [{p: float(V[i, j]) for j, p in enumerate(names)} for i in range(n)]


@dataclass
class ToleranceResult:
    names: list[str]
    variants: list[dict]
    outcomes: list[Outcome]
    nominal: tuple              # nominal value of each output
    gradient: np.ndarray        # (outputs, parameters) exact d(output)/dp (nan: not available)
    first_order_sd: np.ndarray  # (outputs,)
    stats: list[dict]           # per output: mean, std, percentiles, samples ok
    files: list[Path]


def output_gradients(study: Study, res, names: list[str]) -> np.ndarray:
    """(outputs, parameters) exact d(output)/dp at the nominal result res (nan where the
    output is not a max/min/stroke/absmax of a position column): the column's sensitivity at
    its refined extreme's time (planarkin.studies.sensitivity.metric_gradients)."""
    from .sensitivity import metric_gradients
    return metric_gradients(study, res, names)


def run_tolerance(study: Study, sigma: dict, outdir: Path, samples: int, seed: int = 0,
                  dist: str = "normal", plots: str | None = "png", execute=None
                  ) -> ToleranceResult:
    """Monte-Carlo samples of the toleranced parameters, their outputs and the first-order
    prediction; writes tolerance.csv, samples.csv, sensitivities.csv (+ tolerance.png)."""
    from .budget import check_study
    from .sweep import api_error, check_count, check_names
    if not isinstance(sigma, dict) or not sigma:
        raise api_error(study, f"run_tolerance(): sigma must be a non-empty dict of parameter "
                               f"names to standard deviations, not {sigma!r:.60}")
    check_names(study, list(sigma), "run_tolerance(): sigma")
    for k, v in sigma.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < math.inf:
            raise api_error(study, f"run_tolerance(): sigma of '{k}' must be a number >= 0, "
                                   f"not {v!r}")
    check_count(study, samples, "run_tolerance(): samples", 2)
    if dist not in DISTRIBUTIONS:
        raise api_error(study, f"run_tolerance(): dist must be one of "
                               f"{', '.join(DISTRIBUTIONS)}, not {dist!r}")
    names = list(sigma)
    check_study(study, samples, len(names) + len(study.metrics), "--samples")
    nominal_res = getattr(study, "nominal_result", None) or study.nominal_run()
    from .variants import metric_values
    nominal = metric_values(study.metrics, study.nominal, study.opts, nominal_res._chunk,
                            nominal_res.p)
    G = output_gradients(study, nominal_res, names)
    s = np.array([sigma[p] for p in names])
    fo = np.sqrt(((G * s) ** 2).sum(axis=1)) if len(names) else np.zeros(len(study.metrics))
    variants = draw(names, study.parameters, sigma, samples, seed, dist)
    outcomes, lost = solve(execute, study, variants)
    Y = np.array([o.metrics for o in outcomes], dtype=float).reshape(len(outcomes), -1)
    stats = []
    for i in range(Y.shape[1]):
        y = Y[:, i][np.isfinite(Y[:, i])]
        st = {"ok": len(y), "mean": float(np.mean(y)) if len(y) else math.nan,
              "std": float(np.std(y, ddof=1)) if len(y) > 1 else math.nan}
        for q in PERCENTILES:
            st[q] = float(np.percentile(y, q)) if len(y) else math.nan
        stats.append(st)
    base = ["tolerance.csv", "samples.csv", "sensitivities.csv"]
    files = [outdir / f for f in base]
    labels = [m.label for m in study.metrics]
    head = (["output", "nominal", "mean", "std", "first_order_std", "samples_ok"]
            + [f"p{q}" for q in PERCENTILES] + [f"d/d{p}" for p in names])
    family = tuple(base) + tuple(f"tolerance.{f}" for f in PLOT_FORMATS)
    with staged(outdir, family) as stage:
        write_csv(stage(base[0]), head,
                  [[lab, nominal[i], stats[i]["mean"], stats[i]["std"], fo[i], stats[i]["ok"]]
                   + [stats[i][q] for q in PERCENTILES] + list(G[i])
                   for i, lab in enumerate(labels)])
        write_csv(stage(base[1]), ["sample"] + names + ["status", "kind", "t [s]", "message"]
                  + labels, [[k + 1] + list(v.values()) + [o.status, o.kind, o.t, o.message]
                             + list(o.metrics) for k, (v, o) in enumerate(zip(variants, outcomes))])
        _write_sensitivities(stage(base[2]), study, nominal_res, names)
        if plots:
            from .plots import tolerance_plot
            title = (f"{study.nominal.spec.name}: {samples} samples ({dist}, seed {seed}), "
                     + ", ".join(f"sigma {p} = {sigma[p]:g}" for p in names))
            tolerance_plot(stage(f"tolerance.{plots}"), labels, Y, list(nominal), list(fo),
                           {q: [st[q] for st in stats] for q in (5, 95)}, title)
            files.append(outdir / f"tolerance.{plots}")
    if lost is not None:
        raise kept(lost, files[1])
    return ToleranceResult(names, variants, outcomes, nominal, G, fo, stats, files)


def _write_sensitivities(path: Path, study: Study, res, names: list[str]) -> None:
    """sensitivities.csv: t, then d(column)/d(parameter) of every position column."""
    from .sensitivity import sensitivities
    cm = study.nominal
    dq, dP = sensitivities(cm, study.root, study.texts(), names, res.t, res.q)
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    head, cols = ["t [s]"], [res.t]
    for b, bn in enumerate(cm.body_names):
        for c, (q, u) in enumerate((("x", lu), ("y", lu), ("phi", au))):
            for j, p in enumerate(names):
                head.append(f"d({bn}.{q})/d({p}) [{u} per unit of {p}]")
                cols.append(dq[:, 3 * b + c, j])
    for k, pn in enumerate(cm.point_names):
        for c, q in enumerate(("x", "y")):
            for j, p in enumerate(names):
                head.append(f"d({pn}.{q})/d({p}) [{lu} per unit of {p}]")
                cols.append(dP[:, k, c, j])
    from ..output.tables import CsvWriter
    w = CsvWriter(path, head)
    w.write(np.column_stack(cols))
    w.close()


def summary_lines(r: ToleranceResult, study: Study) -> list[str]:
    """The table printed on stdout."""
    labels = [m.label for m in study.metrics]
    width = max([len(x) for x in labels] + [6])
    lines = [f"{'output':<{width}}  {'nominal':>12} {'mean':>12} {'std':>10} {'1st order':>10} "
             f"{'p5':>12} {'p95':>12}"]
    for i, lab in enumerate(labels):
        st = r.stats[i]
        lines.append(f"{lab:<{width}}  {r.nominal[i]:12.6g} {st['mean']:12.6g} {st['std']:10.3g} "
                     f"{r.first_order_sd[i]:10.3g} {st[5]:12.6g} {st[95]:12.6g}")
    return lines
