"""`planarkin export`: the options checked, the model read, its parts drawn and laid out, and the
result directory DIR/<model>.drawings/ written whole (planarkin.output.directory: a temporary
directory renamed into place, the previous one left as it was when anything fails).

The directory holds per part <part>.dxf and/or <part>.svg (its body frame), layout.dxf and/or
layout.svg (every part side by side) and summary.json (the sizes, per part its files, holes and
place on the sheet, per cam curve its arcs and the largest deviation measured).

Exit status: 0 written; 1 the pose could not be solved, or a file could not be written (disk
full); 2 invalid input or usage (`error: ...` naming the fix, or the model's FILE:LINE
diagnostics).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from ..version import __version__
from . import geometry as geo
from .drawings import MM, DrawingError, Sizes, mm_per_unit, parts, size_problems

GAP = 10.0               # mm between the parts of the layout sheet
RESERVED = {"layout", "summary"}


class UsageError(Exception):
    """A command-line value that cannot be used: the message names the option and the fix."""


def _sizes(width, pin, clearance, thickness, tolerance, module) -> Sizes:
    given = {k: v for k, v in (("width", width), ("pin", pin), ("clearance", clearance),
                               ("thickness", thickness), ("tolerance", tolerance),
                               ("module", module)) if v is not None}
    s = Sizes(**given)
    problems = size_problems(s)
    if problems:
        raise UsageError(problems[0])
    return s


def _bodies(cm, names, path) -> set | None:
    if not names:
        return None
    from ..diagnostics import did_you_mean
    for n in names:
        if n == "ground":
            raise UsageError("--body ground: ground is not a part (it is the frame the "
                             "mechanism stands on); name a moving body")
        if n not in cm.body_names:
            raise UsageError(f"--body {n!r}: no such body in {path}"
                             f"{did_you_mean(n, cm.body_names)} (its bodies: "
                             f"{', '.join(cm.body_names)})")
    return set(names)


def _angles(cm, time: float | None) -> dict:
    """Body name -> its angle (rad) at `time` (the layout's pose), {} without one."""
    if time is None:
        return {}
    a = cm.spec.analysis
    if not math.isfinite(time) or time < a.start:
        raise UsageError(f"--pose {time:g}: must be a time from the analysis' start on "
                         f"({a.start:g} s)")
    from .. import solve
    res = solve(cm, steps=1, up_to="position") if time == a.start else \
        solve(cm, end=time, steps=1, up_to="position")
    if res.status != 0:
        raise PoseError(f"the pose at t = {time:g} s could not be solved: {res.message}")
    row = 0 if time == a.start else -1
    return {b: float(res.body(b)["phi"][row]) * cm.angle_factor for b in cm.body_names}


class PoseError(Exception):
    """The model could not be solved up to the pose asked for (exit 1)."""


def file_names(drawn) -> list[str]:
    """A distinct portable file stem per part (never layout or summary)."""
    from ..output.directory import safe_name
    taken, out = set(), []
    for p in drawn:
        stem = safe_name(p.name)
        while stem.lower() in taken or stem.lower() in RESERVED:
            stem += "-part"
        taken.add(stem.lower())
        out.append(stem)
    return out


def _json(x):
    if isinstance(x, dict):
        return {k: _json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json(v) for v in x]
    if hasattr(x, "tolist"):
        return _json(x.tolist())
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    return x


def write_drawings(outdir: Path, drawn, placements, formats, sizes: Sizes, meta: dict) -> list:
    """Write the drawings' directory whole (or raise, leaving the previous one as it was):
    returns the files written, summary.json last."""
    from ..output.directory import ResultDirectory, WriteError, critical
    from . import dxf, svg
    from .drawings import labels
    from .layout import hole_centres, sheet
    writers = {"dxf": lambda p, s, t, title: dxf.write(p, s, t), "svg": svg.write}
    with critical():
        rd = ResultDirectory(Path(outdir))
    files, entries = [], []
    try:
        for stem, p, pl in zip(file_names(drawn), drawn, placements):
            mine = []
            for fmt in formats:
                name = f"{stem}.{fmt}"
                try:
                    writers[fmt](rd.path(name), p.shapes, labels(p.shapes, p.notes, sizes.text),
                                 p.name)
                except OSError as e:
                    raise WriteError(f"writing {name} failed: {e.strerror or e}") from None
                mine.append(name)
            files += mine
            entries.append({"part": p.name, "body": p.body, "kind": p.kind, "files": mine,
                            "holes_mm": p.holes, "hole_diameter_mm": p.hole, "notes": p.notes,
                            "layout": {"angle_deg": math.degrees(pl.angle), "offset_mm":
                                       pl.offset, "box_mm": pl.box,
                                       "holes_mm": hole_centres(p, pl)},
                            "curves": p.fits})
        shapes, texts = sheet(drawn, placements, sizes.text)
        for fmt in formats:
            name = f"layout.{fmt}"
            try:
                writers[fmt](rd.path(name), shapes, texts, f"{meta['model']}: layout")
            except OSError as e:
                raise WriteError(f"writing {name} failed: {e.strerror or e}") from None
            files.append(name)
        summary = {"planarkin": __version__, "command": "export", "status": "ok", **meta,
                   "unit": "mm", "formats": list(formats),
                   "sizes_mm": {"width": sizes.width, "pin": sizes.pin, "clearance":
                                sizes.clearance, "hole": sizes.hole, "thickness":
                                sizes.thickness, "tolerance": sizes.tolerance, "module":
                                sizes.module, "text": sizes.text},
                   "layers": {k: v[1] for k, v in geo.LAYERS.items()},
                   "files": files + ["summary.json"], "parts": entries}
        try:
            rd.path("summary.json").write_text(json.dumps(_json(summary), indent=2) + "\n",
                                               encoding="utf-8")
        except OSError as e:
            raise WriteError(f"writing summary.json failed: {e.strerror or e}") from None
    except BaseException:
        rd.abandon()
        raise
    with critical():
        try:
            rd.commit()
        except OSError as e:
            rd.abandon()
            raise WriteError(f"putting {rd.final.name}/ in place failed: {e.strerror or e}") \
                from None
    return files + ["summary.json"]


def drawings_dir(model_path, out) -> Path:
    """DIR/<model>.drawings: run's name for the model with .drawings after it (beside run's
    directory, never in it)."""
    from ..output.directory import out_dirs
    d = out_dirs([model_path], Path(out))[0]
    return d.with_name(f"{d.name}.drawings")


def export(model_path, out, dxf: bool, svg: bool, overrides: dict | None = None, width=None,
           pin=None, clearance=None, thickness=None, tolerance=None, module=None, pose=None,
           body=()) -> int:
    """The command: returns its exit status (module docstring); prints its lines."""
    from ..diagnostics import Diagnostic, InputError
    from ..output.directory import OutputError, WriteError
    from ..report import Report
    from . import dxf as dxf_writer
    report = Report()
    try:
        formats = [f for f, on in (("dxf", dxf), ("svg", svg)) if on]
        if not formats:
            raise UsageError("give --dxf, --svg or both: the formats to write")
        sizes = _sizes(width, pin, clearance, thickness, tolerance, module)
        why = dxf_writer.missing() if dxf else None
        if why:
            raise UsageError(why)
        from .. import load
        try:
            cm = load(model_path, **(overrides or {}))
        except InputError as e:
            report.invalid(model_path, e.diagnostics)
            return report.exit_code
        report.diagnostics(cm.spec.warnings)
        unit = cm.spec.length_unit
        if mm_per_unit(unit) is None:
            report.invalid(model_path, [Diagnostic(
                model_path, cm.spec.section_lines.get("units"),
                f"units: length {unit!r} has no known size, so the drawings cannot be made in "
                f"millimetres; write one of {', '.join(sorted(MM))}")])
            return report.exit_code
        only = _bodies(cm, body, model_path)
        angles = _angles(cm, pose)
        try:
            drawn, skipped = parts(cm, sizes, only)
        except DrawingError as e:
            report.invalid(model_path, [Diagnostic(model_path, None, str(e))])
            return report.exit_code
        if not drawn:
            raise UsageError(f"{model_path} has no part to draw: " + "; ".join(skipped))
        from .layout import arrange
        placements = arrange(drawn, {p.name: angles.get(p.body, 0.0) for p in drawn}, GAP,
                             sizes.text)
        outdir = drawings_dir(model_path, out)
        meta = {"model": str(model_path), "model_unit": unit,
                "pose_s": pose, "skipped": skipped}
        write_drawings(outdir, drawn, placements, formats, sizes, meta)
    except UsageError as e:
        click.echo(f"error: {e}", err=True)
        return 2
    except InputError as e:                       # the pose's solve: an option out of range
        report.invalid(model_path, e.diagnostics)
        return report.exit_code
    except OutputError as e:
        report.invalid(model_path, [Diagnostic(model_path, None, str(e))])
        return report.exit_code
    except (WriteError, PoseError) as e:
        report.failed(model_path, str(e))
        return report.exit_code
    for line in skipped:
        click.echo(f"  not drawn: {line}")
    for p in drawn:
        for c in p.fits:
            click.echo(f"  {p.name}: cam {c['cam']} {c['curve']}: {c['arcs']} arcs, "
                       f"{c['max_deviation_mm']:.3g} mm at most from the exact curve "
                       f"(tolerance {c['tolerance_mm']:g} mm)")
    report.ok(model_path, f"{len(drawn)} part{'s' if len(drawn) != 1 else ''} "
                          f"({', '.join(formats)}) -> {outdir}/")
    return report.exit_code
