"""report.html: one self-contained page per run (`planarkin run --report html`), and the page of
a batch linking them (index.html).

The page opens offline in any browser and asks nothing of the network (a Content-Security-
Policy forbids it): no script, style, font or image from elsewhere. It shows the model's name,
status, warnings and notes, the mechanism moving (inline SVG of the bodies between their pins,
moved along a time scrubber by under a hundred lines of plain JavaScript), every figure of the
run as inline SVG, the cycle figures, loops, clearances, forces and every other section of the
summary, the columns' extremes, and key rows of bodies.csv.

Every value of the summary it shows is taken from the dict of the run's summary.json (the
writer reads the file back), written as Python's repr (the shortest text that reads back to the
same double) and tagged with its place in that dict: ``data-k``, a JSON list of keys and list
indices. The key rows are tagged with their row of bodies.csv (``data-r``, 0 the first row
after the header) and column (``data-c``); they are the table's own values, from the rows kept
for the plots. The animation has at most FRAMES frames (fewer for a large model: at most
MOTION_NUMBERS numbers) and the figures are drawn from at most FIGURE_ROWS rows, evenly spread
and said on the page, so that a page stays small whatever the run's length.
"""

from __future__ import annotations

import html
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPORT = "report.html"
INDEX = "index.html"
FRAMES = 400            # animation frames at most
MOTION_NUMBERS = 120_000    # and numbers in its data at most (fewer frames for a large model)
FIGURE_ROWS = 1000      # rows the report's figures are drawn from, at most
KEY_ROWS = 20           # rows of bodies.csv in the table of key rows
KEY_COLUMNS = 100       # its columns at most (t first)
# RUN_KEYS: the summary's keys shown together under "The run"; OWN_KEYS: every key the page shows
# in a place of its own. Any other key holding a dict or a list (loops, clearances, forces,
# loads ...) gets a section of its own after the cycle figures, whole.
RUN_KEYS = ("time", "units", "equations", "dof", "characteristic_length", "assembly", "solver",
            "residual", "condition", "error_estimate", "settings", "breakpoints", "event",
            "overrides", "files", "plots", "wall_time")
OWN_KEYS = {"planarkin", "model", "file", "status", "exit_code", "message", "bodies", "points",
            "warnings", "notes", "cycle", "columns", "report", *RUN_KEYS}


def thin(data, n: int):
    """data (a Chunk) with at most n rows, evenly spread, the first and the last among them;
    and the indices kept."""
    from planarkin.solver.chunks import take
    N = len(data.t)
    if N <= n:
        return data, np.arange(N)
    sel = np.unique(np.linspace(0, N - 1, n).round().astype(int))
    return take(data, sel), sel


@dataclass
class Material:
    """What the page shows besides the summary, made while the plots are drawn (the slow part):
    figures: (caption, svg text of the file) in figure order; motion: the animation's HTML;
    table, header, rows, row_index: key rows of bodies.csv (or bodies.parquet: table; rows: an
    array, row_index: each row's index in the table); notes: what was thinned, in a sentence
    each."""

    figures: list = field(default_factory=list)
    table: str = "bodies.csv"
    motion: str = ""
    header: list = field(default_factory=list)
    rows: np.ndarray | None = None
    row_index: np.ndarray | None = None
    notes: list = field(default_factory=list)


# -- the summary's values ------------------------------------------------------------------------

def esc(s) -> str:
    return html.escape(str(s), quote=True)


def value(v, path) -> str:
    """A value of the summary as shown, tagged with its place (data-k): numbers as repr, None as
    a dash, strings as they are."""
    if v is None:
        text = "&#8211;"
    elif isinstance(v, bool):
        text = "true" if v else "false"
    elif isinstance(v, (int, float)):
        text = repr(v)
    else:
        text = esc(v)
    num = " num" if isinstance(v, (int, float)) and not isinstance(v, bool) else ""
    return f'<span class="v{num}" data-k="{esc(json.dumps(path))}">{text}</span>'


def _scalar(v) -> bool:
    return v is None or isinstance(v, (str, int, float, bool))


def tree(v, path) -> str:
    """Any part of the summary, whole: a dict as a table of keys (a dict or list of flat dicts
    as one table with a row each), a list of scalars as a list, a scalar as `value`."""
    if _scalar(v):
        return value(v, path)
    if isinstance(v, list):
        if not v:
            return '<span class="none">none</span>'
        if all(_scalar(x) for x in v):
            return ", ".join(value(x, path + [k]) for k, x in enumerate(v))
        if all(isinstance(x, dict) and x and all(_scalar(y) for y in x.values()) for x in v):
            return _records(list(enumerate(v)), path, "#")
        return "<ol>" + "".join(f"<li>{tree(x, path + [k])}</li>" for k, x in enumerate(v)) + \
            "</ol>"
    if not v:
        return '<span class="none">none</span>'
    if len(v) <= 4 and all(_scalar(x) for x in v.values()):      # {value, t, found}: a line
        return "; ".join(f'<span class="key">{esc(k)}</span> {value(x, path + [k])}'
                         for k, x in v.items())
    if len(v) > 1 and all(isinstance(x, dict) and x and all(_scalar(y) for y in x.values())
                          for x in v.values()):
        return _records(list(v.items()), path, "")
    rows = "".join(f"<tr><th>{esc(k)}</th><td>{tree(x, path + [k])}</td></tr>"
                   for k, x in v.items())
    return f'<table class="kv">{rows}</table>'


def _records(items, path, corner) -> str:
    """A table with a row per (key, flat dict) and a column per key of the dicts."""
    cols: list = []
    for _, rec in items:
        cols += [c for c in rec if c not in cols]
    head = "".join(f"<th>{esc(c)}</th>" for c in cols)
    body = "".join(
        f"<tr><th>{esc(k)}</th>" + "".join(
            f"<td>{value(rec[c], path + [k, c]) if c in rec else ''}</td>" for c in cols)
        + "</tr>" for k, rec in items)
    return f'<table class="rec"><tr><th>{corner}</th>{head}</tr>{body}</table>'


def _section(key: str, title: str, body: str, open_: bool = True) -> str:
    return (f'<section id="{esc(key)}"><details{" open" if open_ else ""}><summary><h2>'
            f'{esc(title)}</h2></summary>{body}</details></section>')


def _header(s: dict) -> str:
    status = s.get("status", "")
    rows = [("file", value(s.get("file"), ["file"])),
            ("time", f'{value(s["time"]["start"], ["time", "start"])} to '
                     f'{value(s["time"]["end"], ["time", "end"])} s, '
                     f'{value(s["time"]["rows_written"], ["time", "rows_written"])} of '
                     f'{value(s["time"]["rows_planned"], ["time", "rows_planned"])} rows'
             if isinstance(s.get("time"), dict) else ""),
            ("bodies", tree(s.get("bodies", []), ["bodies"])),
            ("points", tree(s.get("points", []), ["points"])),
            ("degrees of freedom", value(s.get("dof"), ["dof"])),
            ("planarkin", value(s.get("planarkin"), ["planarkin"]))]
    facts = "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows)
    return (f'<header><h1>{value(s.get("model"), ["model"])}</h1>'
            f'<p class="status {esc(status)}">{value(status, ["status"])} '
            f'(exit {value(s.get("exit_code"), ["exit_code"])}): '
            f'{value(s.get("message"), ["message"])}</p><table class="kv">{facts}</table>'
            f'</header>')


def _warnings(s: dict) -> str:
    items = []
    for k, w in enumerate(s.get("warnings") or []):
        if isinstance(w, dict):
            line = (f' (line {value(w["line"], ["warnings", k, "line"])})'
                    if w.get("line") is not None else "")
            items.append(f'<li><b>{value(w.get("kind"), ["warnings", k, "kind"])}</b>{line}: '
                         f'{value(w.get("message"), ["warnings", k, "message"])}</li>')
        else:
            items.append(f"<li>{tree(w, ['warnings', k])}</li>")
    notes = [f'<li>{tree(n, ["notes", k])}</li>' for k, n in enumerate(s.get("notes") or [])]
    body = f'<ul class="warn">{"".join(items)}</ul>' if items else "<p>No warnings.</p>"
    if notes:
        body += f'<h3>Notes</h3><ul>{"".join(notes)}</ul>'
    if s.get("event"):
        body += f'<h3>Event</h3>{tree(s["event"], ["event"])}'
    return _section("warnings", f"Warnings ({len(items)})", body)


def _limit(x: dict, path) -> list[str]:
    """Cells of one limit of a cycle figure: value, t, driver (refined where it was)."""
    if "dwell" in x:
        d, p = x["dwell"], path + ["dwell"]
        span = [f'{value(d["start"].get(q), p + ["start", q])}..'
                f'{value(d["end"].get(q), p + ["end", q])}' if q in d["start"] else ""
                for q in ("t", "driver")]
        return [value(x["value"], path + ["value"]), "dwell " + span[0], span[1]]
    if "refined" in x:
        x, path = x["refined"], path + ["refined"]
    return [value(x[q], path + [q]) if q in x else "" for q in ("value", "t", "driver")]


def _cycle(c) -> str:
    if not isinstance(c, dict) or not c:
        return _section("cycle", "Cycle figures", tree(c, ["cycle"]))
    head = ("<tr><th>coordinate</th><th>unit</th><th>min</th><th>at t [s]</th><th>driver</th>"
            "<th>max</th><th>at t [s]</th><th>driver</th><th>stroke</th><th>time ratio</th>"
            "</tr>")
    rows = []
    groups = [(g, owner, q, rec, ["cycle", "coordinates", g, owner, q])
              for g, owners in (c.get("coordinates") or {}).items() for owner, recs in
              owners.items() for q, rec in recs.items()]
    groups += [("measures", name, "", rec, ["cycle", "measures", name])
               for name, rec in (c.get("measures") or {}).items()]
    for g, owner, q, rec, path in groups:
        if not isinstance(rec, dict) or (g != "measures" and not rec.get("moves")):
            continue
        ratio = next((value(rec[k], path + [k]) for k in ("time_ratio", "rise_return_ratio")
                      if k in rec), "")
        cells = ([value(rec.get("unit"), path + ["unit"])] + _limit(rec["min"], path + ["min"])
                 + _limit(rec["max"], path + ["max"]) + [value(rec["stroke"], path + ["stroke"]),
                                                          ratio])
        name = f"{owner}.{q}" if q else owner
        rows.append(f"<tr><th>{esc(name)}</th>" + "".join(f"<td>{x}</td>" for x in cells)
                    + "</tr>")
    body = (f'<p>{value(c.get("driver"), ["cycle", "driver"])}; period '
            f'{value(c.get("period"), ["cycle", "period"])} s. The coordinates that move'
            f'{" and the measures" if c.get("measures") else ""}:</p>'
            f'<table class="rec">{head}{"".join(rows)}</table>')
    rest = {k: v for k, v in c.items() if k not in ("driver", "period", "coordinates",
                                                   "measures")}
    for k, v in rest.items():
        body += f'<p><span class="key">{esc(k)}</span> {tree(v, ["cycle", k])}</p>'
    body += ("<p class=\"small\">Every coordinate's phases, extremes and dwells are in "
             "summary.json's cycle section.</p>")
    return _section("cycle", "Cycle figures", body)


def _columns(cols) -> str:
    if not isinstance(cols, dict):
        return _section("columns", "Column extremes", tree(cols, ["columns"]))
    parts = [f'<details{" open" if k < 2 else ""}><summary><h3>{esc(name)}</h3></summary>'
             f'{tree(stats, ["columns", name])}</details>'
             for k, (name, stats) in enumerate(cols.items())]
    return _section("columns", "Column extremes (min, max and when)", "".join(parts))


def _key_rows(m: Material) -> str:
    title = f"Key rows of {m.table}"
    if m.rows is None or not len(m.rows):
        return _section("rows", title, "<p>No rows were written.</p>")
    ncol = min(len(m.header), KEY_COLUMNS)
    head = "<tr><th>row</th>" + "".join(f"<th>{esc(h)}</th>" for h in m.header[:ncol]) + "</tr>"
    body = "".join(
        f'<tr><th>{int(i)}</th>' + "".join(
            f'<td data-r="{int(i)}" data-c="{c}">{repr(float(x))}</td>'
            for c, x in enumerate(row[:ncol])) + "</tr>"
        for i, row in zip(m.row_index, m.rows))
    note = (f"{len(m.rows)} rows of {m.table}, evenly spaced (row 0 is the first after the "
            f"header), as they are in the file")
    if ncol < len(m.header):
        note += f"; its first {ncol} of {len(m.header)} columns"
    return _section("rows", title, f'<p class="small">{note}.</p><div class="scroll">'
                                   f'<table class="rows">{head}{body}</table></div>')


def page(summary: dict, m: Material) -> str:
    """The whole page (text) of a run: summary, the dict of its summary.json."""
    s = summary
    parts = [("warnings", "warnings", _warnings(s))]
    if m.motion:
        parts.append(("motion", "motion", _section("motion", "The mechanism moving", m.motion)))
    if m.figures:
        figs = "".join(f'<figure>{svg}<figcaption>{esc(cap)}</figcaption></figure>'
                       for cap, svg in m.figures)
        parts.append(("figures", "figures", _section("figures", "Figures", figs)))
    parts.append(("cycle", "cycle", _cycle(s.get("cycle"))))
    for k, v in s.items():
        if k not in OWN_KEYS and isinstance(v, (dict, list)):
            title = k.replace("_", " ")
            parts.append((k, title, _section(k, title.capitalize(), tree(v, [k]),
                                             open_=len(json.dumps(v)) < 6000)))
    parts.append(("columns", "extremes", _columns(s.get("columns"))))
    parts.append(("rows", "key rows", _key_rows(m)))
    run = {k: s[k] for k in RUN_KEYS if k in s}
    parts.append(("run", "run", _section("run", "The run", tree(run, []), open_=False)))
    nav = "".join(f'<a href="#{esc(k)}">{esc(t)}</a>' for k, t, _ in parts)
    notes = "".join(f"<li>{esc(n)}</li>" for n in m.notes)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
            f'<title>{esc(s.get("model"))}: planarkin report</title><style>{CSS}</style></head>'
            f'<body>{_header(s)}<nav>{nav}</nav><main>{"".join(h for _, _, h in parts)}</main>'
            f'<footer><p>Written by planarkin {esc(s.get("planarkin"))} beside summary.json, '
            f'whose values it shows as they are there. This page needs no network.</p>'
            f'<ul>{notes}</ul></footer><script>{JS}</script></body></html>\n')


# -- figures -------------------------------------------------------------------------------------

def inline_svg(text: str, prefix: str) -> str:
    """A figure's SVG file as an element of the page: no XML declaration, doctype, metadata or
    namespace declarations (HTML needs none), its style rule left to the page's, its ids (and
    the references to them) prefixed so that figures on one page never share one."""
    import re
    text = text[text.index("<svg"):]
    text = re.sub(r"<metadata>.*?</metadata>\s*", "", text, flags=re.S)
    text = re.sub(r'<style type="text/css">.*?</style>', "", text, flags=re.S)
    text = re.sub(r'\s+xmlns(:\w+)?="[^"]*"', "", text, count=2)
    text = re.sub(r' id="([^"]+)"', rf' id="{prefix}\1"', text)
    text = re.sub(r'href="#([^"]+)"', rf'href="#{prefix}\1"', text)
    text = re.sub(r"url\(#([^)]+)\)", rf"url(#{prefix}\1)", text)
    text = re.sub(r">\s+<", "><", text)
    return text.replace("<svg ", '<svg class="fig" ', 1).strip()


# -- the mechanism moving ------------------------------------------------------------------------

def _hex(color) -> str:
    from matplotlib.colors import to_hex
    return to_hex(color)


def _rounded(a, digits: int) -> list:
    """Values rounded to digits decimals (enough for a drawing), None where not finite."""
    a = np.round(np.asarray(a, float), digits)
    return [x if math.isfinite(x) else None for x in a.ravel().tolist()]


def _pts(P, digits: int) -> str:
    P = np.asarray(P, float).reshape(-1, 2)
    if not np.isfinite(P).all():
        return ""
    return " ".join(f"{x:.{digits}f},{y:.{digits}f}" for x, y in P)


def motion(cm, data, row_index, total_rows: int) -> tuple[str, int]:
    """The animation: an inline SVG of the mechanism (each body's polygon, bar, slot and face
    lines in its colour, the links, the pins, the named points and their paths growing, the
    ground's pivots and slide axes) drawn at its first row, its geometry as JSON, and the
    controls; JS moves it. data: the rows to choose the frames from (a Chunk; at most FRAMES
    are kept, fewer when their data would hold more than MOTION_NUMBERS numbers), row_index:
    each row's index in the tables. Returns the HTML and the number of frames."""
    from .plots.scene import Scene
    data, sel = thin(data, FRAMES)
    sc = Scene(cm, data)
    npaths = sc.named + len(sc.traces) - len(cm.point_names)
    per_frame = max(1, 3 * sc.nb + 4 * npaths)      # poses, and each path twice (drawn, data)
    keep = thin(data, max(40, MOTION_NUMBERS // per_frame))[1]
    row_index = np.asarray(row_index)[sel][keep]
    N = len(keep)
    digits = max(0, 5 - math.floor(math.log10(sc.span)))     # 1e-5 of the drawing at least
    x0, x1, y0, y1 = sc.bounds
    r = 0.012 * sc.span
    shapes, els = [], []
    for b in range(sc.nb):
        c = _hex(sc.colors[b])
        parts = [(sc.fills[b], "fill")] if sc.fills[b] is not None else []
        parts += [(sc.bars[b], "bar")] if sc.bars[b] is not None else []
        parts += [(V, "dash") for V in sc.dashed[b]] + [(V, "face") for V in sc.faces[b]]
        for pl in sorted((p for p in sc.plates if p.body == b), key=lambda p: p.level):
            parts += [(pl.outline, "plate" if pl.filled else "wall")]   # issue 29's shapes
            parts += [(H, "hole") for H in pl.holes]
        for V, kind in parts:
            shapes.append([b, _rounded(V, digits + 2)])
            tag = "polygon" if kind in ("fill", "plate", "hole") else "polyline"
            els.append(f'<{tag} class="shape {kind}" style="--c:{c}" '
                       f'points="{_pts(sc.at(b, V, 0), digits)}"/>')
    ground = "".join(f'<polyline class="axis" points="{_pts(P, digits)}"/>' for P in sc.axes)
    ground += "".join(f'<{"polygon" if p.filled else "polyline"} class="obstacle" '
                      f'points="{_pts(p.outline, digits)}"/>'
                      for p in sc.plates if p.body == sc.nb)       # frame obstacles
    wedge = np.array([[0, 0], [-1, -1.6], [1, -1.6]]) * 0.5 * sc.size     # a ground pivot
    ground += "".join(f'<polygon class="pivot" points="{_pts(np.asarray(p) + wedge, digits)}"/>'
                      for p in sc.pivots if np.isfinite(p).all())
    paths = [np.asarray(P, float)[keep] for P in sc.traces[:sc.named]] + \
        [np.asarray(P, float)[keep] for P in sc.traces[len(cm.point_names):]]
    styles = sc.trace_styles[:sc.named] + sc.trace_styles[len(cm.point_names):]
    full = "".join(f'<polyline class="path" style="--c:{_hex(st[2])}" points="{_pts(P, digits)}"/>'
                   for P, st in zip(paths, styles))
    trails = "".join(f'<polyline class="trail" style="--c:{_hex(st[2])}" points=""/>'
                     for st in styles)
    def xy(names, P):       # a point's attributes, at the first frame (JS moves them)
        P = np.asarray(P, float).ravel()
        return "".join(f' {n}="{v:.{digits}f}"' for n, v in zip(names, P) if math.isfinite(v))
    links = "".join(f'<line class="link"{xy(("x1", "y1"), sc.at(bi, si, 0))}'
                    f'{xy(("x2", "y2"), sc.at(bj, sj, 0))}/>' for bi, si, bj, sj in sc.links)
    pins = "".join(f'<circle class="pin" r="{r:.{digits}f}"{xy(("cx", "cy"), sc.at(b, s_, 0))}/>'
                   for b, s_ in sc.pins)
    points = "".join(f'<circle class="point" style="--c:{_hex(sc.point_colors[k])}" '
                     f'r="{1.2 * r:.{digits}f}"{xy(("cx", "cy"), paths[k][0])}/>'
                     for k in range(sc.named))
    pose = np.stack([sc.x, sc.y, sc.phi], axis=2)[keep]
    pose[..., 2] = np.round(pose[..., 2], 7)           # radians: 1e-7, whatever the size
    D = {"t": data.t[keep].tolist(), "row": [int(i) for i in row_index],
         "rows": int(total_rows), "nb": sc.nb,
         "pose": _rounded(pose, max(digits + 2, 7)),
         "shapes": shapes,
         "pins": [[int(b)] + _rounded(s, digits + 2) for b, s in sc.pins],
         "links": [[int(bi)] + _rounded(si, digits + 2) + [int(bj)] + _rounded(sj, digits + 2)
                   for bi, si, bj, sj in sc.links],
         "paths": [_rounded(P, digits) for P in paths], "digits": digits}
    data_json = json.dumps(D, separators=(",", ":")).replace("</", "<\\/")
    w, h = x1 - x0, y1 - y0
    legend = "".join(f'<span><i style="background:{_hex(sc.colors[b])}"></i>{esc(n)}</span>'
                     for b, n in enumerate(sc.names))
    legend += "".join(f'<span><i class="pt" style="background:{_hex(sc.point_colors[k])}"></i>'
                      f'{esc(n)}</span>' for k, n in enumerate(cm.point_names[:sc.named]))
    return (f'<div class="motion"><svg id="pk-motion" viewBox="{x0:.{digits}f} {-y1:.{digits}f} '
            f'{w:.{digits}f} {h:.{digits}f}" role="img" aria-label="the mechanism at the time '
            f'chosen below"><g transform="scale(1,-1)"><g>{ground}</g><g>{full}</g><g>{trails}'
            f'</g><g>{"".join(els)}</g><g>{links}</g><g>{pins}</g><g>{points}</g></g></svg>'
            f'<div class="legend">{legend}</div>'
            f'<div class="controls"><button id="pk-play" type="button">play</button>'
            f'<input id="pk-t" type="range" min="0" max="{N - 1}" value="0" step="1" '
            f'aria-label="time: frame"><output id="pk-label"></output></div></div>'
            f'<script type="application/json" id="pk-data">{data_json}</script>', N)


# -- the batch's page ----------------------------------------------------------------------------

def index_page(title: str, items) -> str:
    """index.html: a row per model of the batch (name as given, outcome, message, its report's
    relative link or None), in order."""
    rows = "".join(
        f'<tr><td>{esc(name)}</td><td class="status {esc(outcome)}">{esc(outcome)}</td>'
        f'<td>{esc(message)}</td><td>'
        + (f'<a href="{esc(href)}">{esc(href)}</a>' if href else "&#8211;") + "</td></tr>"
        for name, outcome, message, href in items)
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
            f'<title>{esc(title)}</title><style>{CSS}</style></head><body><header><h1>'
            f'{esc(title)}</h1></header><main><table class="rec"><tr><th>model</th>'
            f'<th>status</th><th>message</th><th>report</th></tr>{rows}</table></main>'
            f'</body></html>\n')


def write_index(root: Path, title: str, items) -> Path:
    """Write root/index.html whole or not at all (a temporary file renamed into place); an
    OSError leaves the earlier page as it was and is raised."""
    root = Path(root)
    path = root / INDEX
    tmp = root / f".{INDEX}.tmp-{os.getpid()}"
    try:
        tmp.write_text(index_page(title, items), encoding="utf-8")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


CSP = ("default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; "
       "img-src data:")

CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,"Helvetica Neue",Arial,sans-serif;
margin:0 auto;max-width:1100px;padding:0 16px 40px;color:#1d1d1f;background:#fff}
h1{font-size:26px;margin:18px 0 4px}h2{display:inline;font-size:19px;margin:0}
h3{display:inline-block;font-size:15px;margin:10px 0 4px}
header .kv th{font-weight:600}nav{position:sticky;top:0;background:#f4f5f8;padding:6px 8px;
border-bottom:1px solid #dde;z-index:2}nav a{margin-right:14px;color:#2a4db3;
text-decoration:none}nav a:hover{text-decoration:underline}
section{margin:18px 0;border-top:1px solid #e4e4ea;padding-top:8px}summary{cursor:pointer}
.status{font-size:16px;margin:4px 0 10px}.status .v:first-child,td.status{font-weight:700}
.status.ok .v:first-child,td.ok{color:#17803d}.status.failed .v:first-child,td.failed,
td.invalid,td.interrupted{color:#b3261e}
table{border-collapse:collapse;margin:6px 0;font-size:13px}
th,td{border:1px solid #e1e1e8;padding:2px 6px;text-align:left;vertical-align:top}
.rec td,.rows td{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.rec tr:first-child th,.rows tr:first-child th{background:#f4f5f8}
.kv>tbody>tr>th,.kv>tr>th{background:#fafafc;font-weight:500;white-space:nowrap}
.num{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:12px}
.rows td{font-family:ui-monospace,SFMono-Regular,Menlo,Consolas,monospace;font-size:12px}
.scroll{overflow-x:auto}.key{color:#666;font-style:italic}.none{color:#888}
.small,footer{font-size:12px;color:#555}
ul.warn li{color:#8a4b00}ol{margin:2px 0;padding-left:22px}
figure{margin:10px 0}figcaption{font-size:12px;color:#555}
svg.fig{max-width:100%;height:auto}svg.fig *{stroke-linejoin:round;stroke-linecap:butt}
.motion svg{width:100%;max-height:520px;background:#fcfcfd;border:1px solid #e4e4ea}
.motion svg *{vector-effect:non-scaling-stroke}
.shape{stroke:var(--c);fill:none;stroke-linecap:round;stroke-linejoin:round}
.shape.fill{fill:var(--c);fill-opacity:.25;stroke-width:2}.shape.bar{stroke-width:7}
.shape.dash{stroke-width:1;stroke-dasharray:5 4}.shape.face{stroke-width:4}
.axis{stroke:#888;stroke-width:1;stroke-dasharray:6 4;fill:none}
.shape.plate{fill:var(--c);fill-opacity:.18;stroke-width:1.5}.shape.wall{stroke-width:2}
.shape.hole{fill:#fff;stroke-width:.9}.obstacle{fill:#bbb;fill-opacity:.45;stroke:#555;stroke-width:1.2}
polyline.obstacle{fill:none;stroke-width:2}
.pivot{fill:#ccc;stroke:#555;stroke-width:1}
.path{stroke:var(--c);stroke-opacity:.25;stroke-width:1;fill:none}
.trail{stroke:var(--c);stroke-width:1.6;fill:none}.link{stroke:#333;stroke-width:1.2}
.pin{fill:#fff;stroke:#222;stroke-width:1.3}.point{fill:var(--c);stroke:#222;stroke-width:.8}
.controls{display:flex;gap:10px;align-items:center;margin:6px 0}
.controls input{flex:1}.controls output{min-width:260px;font-variant-numeric:tabular-nums}
.legend span{margin-right:12px;font-size:12px;white-space:nowrap}
.legend i{display:inline-block;width:12px;height:12px;margin-right:4px;vertical-align:-2px;
opacity:.8}.legend i.pt{border-radius:50%}
@media print{nav,.controls button{display:none}details{display:block}}
"""

JS = """
(function () {
  "use strict";
  var box = document.getElementById("pk-data");
  if (!box) { return; }
  var D = JSON.parse(box.textContent);
  var svg = document.getElementById("pk-motion");
  var range = document.getElementById("pk-t");
  var label = document.getElementById("pk-label");
  var button = document.getElementById("pk-play");
  var shapes = svg.querySelectorAll(".shape"), links = svg.querySelectorAll(".link");
  var pins = svg.querySelectorAll(".pin"), points = svg.querySelectorAll(".point");
  var trails = svg.querySelectorAll(".trail");
  var N = D.t.length, timer = null, frame = 0;

  function at(f, b, sx, sy) {
    if (b === D.nb) { return [sx, sy]; }
    var o = 3 * (f * D.nb + b), x = D.pose[o], y = D.pose[o + 1], p = D.pose[o + 2];
    if (x === null || y === null || p === null) { return null; }
    var c = Math.cos(p), s = Math.sin(p);
    return [x + c * sx - s * sy, y + s * sx + c * sy];
  }

  function text(list) {
    var out = [];
    for (var k = 0; k < list.length; k++) {
      if (list[k] === null) { return ""; }
      out.push(list[k][0].toFixed(D.digits) + "," + list[k][1].toFixed(D.digits));
    }
    return out.join(" ");
  }

  function place(el, p, ax, ay) {
    if (p === null || p[0] === null || p[1] === null) {
      el.style.display = "none";
      return;
    }
    el.style.display = "";
    el.setAttribute(ax, p[0]);
    el.setAttribute(ay, p[1]);
  }

  function draw(f) {
    var k, j;
    frame = f;
    for (k = 0; k < shapes.length; k++) {
      var b = D.shapes[k][0], V = D.shapes[k][1], P = [];
      for (j = 0; j < V.length; j += 2) { P.push(at(f, b, V[j], V[j + 1])); }
      shapes[k].setAttribute("points", text(P));
    }
    for (k = 0; k < pins.length; k++) {
      var q = D.pins[k];
      place(pins[k], at(f, q[0], q[1], q[2]), "cx", "cy");
    }
    for (k = 0; k < links.length; k++) {
      var L = D.links[k];
      place(links[k], at(f, L[0], L[1], L[2]), "x1", "y1");
      place(links[k], at(f, L[3], L[4], L[5]), "x2", "y2");
    }
    for (k = 0; k < trails.length; k++) {
      var xy = D.paths[k], T = [];
      for (j = 0; j <= f; j++) {
        if (xy[2 * j] !== null && xy[2 * j + 1] !== null) { T.push([xy[2 * j], xy[2 * j + 1]]); }
      }
      trails[k].setAttribute("points", text(T));
      if (k < points.length) { place(points[k], [xy[2 * f], xy[2 * f + 1]], "cx", "cy"); }
    }
    range.value = String(f);
    label.textContent = "t = " + D.t[f] + " s (row " + D.row[f] + " of " + D.rows +
      "; frame " + (f + 1) + " of " + N + ")";
  }

  function stop() {
    if (timer !== null) { clearInterval(timer); timer = null; }
    button.textContent = "play";
  }

  button.addEventListener("click", function () {
    if (timer !== null) { stop(); return; }
    button.textContent = "pause";
    if (frame >= N - 1) { draw(0); }
    timer = setInterval(function () {
      if (frame >= N - 1) { stop(); return; }
      draw(frame + 1);
    }, Math.max(16, Math.round(6000 / N)));
  });
  range.addEventListener("input", function () { stop(); draw(parseInt(range.value, 10)); });
  draw(0);
}());
"""
