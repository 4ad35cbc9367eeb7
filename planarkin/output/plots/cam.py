"""cam.<fmt>: the figure a cam designer reads, one per cam joint (cam-<name>.<fmt> when the model
has several), written with the cam's table cam-<name>.csv whenever the plots are.

Left, four axes sharing the cam angle theta (the file's angle unit, over the run): the follower's
S, V, A, J per unit cam angle, s, ds/dtheta, d2s/dtheta2, d3s/dtheta3 (psi and its derivatives
for a rocker), in the file's units (mm/deg, mm/deg^2 ...): the valve-train convention, a property
of the law alone, whatever the speed the cam is run at. They are the law's exact derivatives,
those the constraint uses (`planarkin.elements.cam.Law`, `FunctionLaw`); where a derivative jumps
(a knot of the law) both one-sided limits are drawn, joined by a vertical line, and the law's
knots (where s', s'', s''' or s'''' jumps: the segment boundaries) are light vertical lines. A law
whose third derivative cannot be formed exactly has no J axes: the figure says why (never a
finite difference).

Right: the cam in its own frame (the frame of cam-<name>.csv, centred on its axis) as its working
surface (solid) and pitch curve (dashed) over the law's range, the base circle and the follower
at one pose (where the pressure angle is largest), and under it the radius of curvature and the
pressure angle against the same cam angle, with their limits: the roller radius (the pitch
curve's radius of curvature must exceed it where convex) or 0 (the working surface's, for a flat
face), and the pressure angle the run is checked against (the model's pressure_limit, else the
default, 30 deg translating or 45 deg oscillating: the common guidelines).

`cam_data` prepares every drawn array (tests compare them with the tables); `cam_figure` draws;
`cam_figures` writes the files (called by planarkin.output.writer's plot step).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...elements.cam import DEFAULT_LIMIT, CamJoint, cam_joints, derived_tables, profile
from .axes import add_axes
from .render import save_figure, text_inches
from .style import FONT, body_palette, plot_title, styled, tick_label_width

PER_TURN = 1440             # law samples per turn of cam angle (every 0.25 deg)
MAX_SAMPLES = 20_000        # at most this many over the run (a run of many turns)
MAX_KNOTS = 60              # more knots than this (a table's points) are not marked
RHO_VIEW = 2.5              # radii of curvature shown within +- this many times the cam's size
LIMIT_COLOR = "tab:red"
KNOT_COLOR = "0.8"


@dataclass
class CamData:
    """Every array cam.<fmt> draws for one cam, user units (the file's length and angle units).

    theta: cam angles of the S, V, A, J curves over the run, sorted; at a knot the angle is
    there twice, the left-hand limits first. s, v, a, j: the law and its derivatives per unit
    cam angle there (j None when the law's third derivative cannot be formed: jerk_note says
    why). knots: the law's knots inside the run. at: cam angles of the radius of curvature and
    the pressure angle over the run (each once), rho (of the pitch curve; of the working surface
    for a flat face) and pressure there. profile_theta: cam angles of the drawn profile over the
    law's range, with surface_x, surface_y, pitch_x, pitch_y (cam frame). Both sample sets
    hold the table's own cam angles (the profile's folded into the law's turn)."""
    cam: CamJoint
    kind: str
    flat: bool
    roller: float
    length_unit: str
    angle_unit: str
    theta: np.ndarray
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray | None
    jerk_note: str
    knots: list
    at: np.ndarray
    rho: np.ndarray
    pressure: np.ndarray
    limit: float
    limit_given: bool
    profile_theta: np.ndarray
    surface_x: np.ndarray
    surface_y: np.ndarray
    pitch_x: np.ndarray
    pitch_y: np.ndarray
    base: float
    pose: float
    pose_why: str = "pressure"
    follower: dict = field(default_factory=dict)


def cam_figures(cm, data, info, out: Path, fmt: str = "png") -> list[Path]:
    """Write cam.<fmt> (cam-<name>.<fmt> per cam when there are several) from the plot rows
    data (a Chunk, user units); returns the files ([] for a model without a cam or no rows)."""
    cams = cam_joints(cm)
    if not cams or data is None or not len(data.t):
        return []
    files = []
    for cam, table in zip(cams, derived_tables(cm, None)):
        X = table.compute(data)
        stem = "cam" if len(cams) == 1 else f"cam-{cam.name}"
        files.append(save_figure(cam_figure(cm, cam_data(cm, cam, X), info),
                                 Path(out) / f"{stem}.{fmt}"))
    return files


# -- the data ---------------------------------------------------------------------------------

def cam_data(cm, cam: CamJoint, X: np.ndarray) -> CamData:
    """What cam.<fmt> draws for cam, from X, the rows of its table cam-<name>.csv."""
    L, af = cm.L, cm.angle_factor
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    par, kind = cam.par, cam.kind
    law = par["s" if kind == "cam" else "psi"]
    turn = 2 * math.pi / af
    rows = X[:, 1][np.isfinite(X[:, 1])]
    rng = np.asarray(par["range"], float) / af
    whole = not np.isfinite(rng[0])
    lo_r, hi_r = (0.0, turn) if whole else (float(rng[0]), float(rng[1]))
    lo, hi = (float(rows.min()), float(rows.max())) if len(rows) else (lo_r, hi_r)
    if not hi > lo:             # a cam that does not turn: its law over the law's range
        lo, hi, rows = lo_r, hi_r, rows[:0]
    n = int(min(max(math.ceil((hi - lo) / turn * PER_TURN), 240), MAX_SAMPLES)) + 1
    knots = law_knots(law, lo, hi)
    at = np.unique(np.concatenate([np.linspace(lo, hi, n), rows, knots]))
    # the S, V, A, J curves: the right-hand limits everywhere (the tables' rule at a knot), and
    # at each knot the left-hand ones before them
    left = np.asarray(knots, float)
    theta = np.concatenate([left, at])
    order = np.argsort(theta, kind="stable")         # a knot's left-hand sample first
    sides = np.concatenate([-np.ones(len(left)), np.ones(len(at))])[order]
    theta = theta[order]
    sides[-1] = -1.0            # the curves end where they were going (a knot at the end)
    derivs, jerk_note = law_derivatives(law, theta, sides)
    P = profile(kind, par, at * af)
    flat = bool(par.get("flat", 0.0) > 0.5)
    rho = (P["rho_surface"] if flat else P["rho_pitch"]) * L
    limit = float(par["pressure_limit"])
    given = bool(np.isfinite(limit))
    limit = (limit if given else DEFAULT_LIMIT[kind]) / af
    # the drawn profile: the law's range, with the table's cam angles (folded into its turn)
    m = int(max(math.ceil((hi_r - lo_r) / turn * PER_TURN), 240)) + 1
    folded = lo_r + np.mod(rows - lo_r, turn) if whole else rows[(rows >= lo_r) & (rows <= hi_r)]
    pth = np.unique(np.concatenate([np.linspace(lo_r, hi_r, m), folded]))
    Q = dict(profile(kind, par, pth * af), theta=pth * af)
    base = float(par["base"]) * L if kind == "cam" else \
        float(np.nanmin(np.hypot(Q["surface_x"], Q["surface_y"]))) * L
    pressure = P["pressure"] / af
    # the follower drawn where the pressure angle is largest (a flat translating face: 0
    # everywhere, then where the lift is largest)
    why = "pressure" if np.nanmax(pressure) > 1e-9 * limit else "lift"
    pose = float(at[int(np.nanargmax(pressure if why == "pressure" else
                                      np.abs(P["value"])))])
    return CamData(
        cam=cam, kind=kind, flat=flat, roller=float(par.get("roller", 0.0)) * L,
        length_unit=lu, angle_unit=au, theta=theta, s=derivs[0], v=derivs[1], a=derivs[2],
        j=derivs[3], jerk_note=jerk_note, knots=list(knots), at=at, rho=rho, pressure=pressure,
        limit=limit, limit_given=given, profile_theta=pth, surface_x=Q["surface_x"] * L,
        surface_y=Q["surface_y"] * L, pitch_x=Q["pitch_x"] * L, pitch_y=Q["pitch_y"] * L,
        base=base, pose=pose, pose_why=why, follower=follower_at(cm, cam, pose, Q))


def law_derivatives(law, x, sides) -> tuple:
    """((s, s', s'', s''' or None), why not s''') of the law at the cam angles x (user units),
    per unit cam angle in the file's units: the law's own exact derivatives (as its constraint
    evaluates them: `Law`, `FunctionLaw`), each point's one-sided limit as sides says (+1: the
    right-hand one, the rule of the tables; -1: the left-hand one)."""
    from planarkin.functions.expr import ExprError
    from planarkin.functions.expr.core import evaluate_all

    x = np.asarray(x, float)
    out: list = [np.empty(len(x)) for _ in range(3)] + [np.empty(len(x))]
    note = ""
    for side in (-1, 1):
        sel = sides == side
        if not sel.any():
            continue
        xs = x[sel]
        if hasattr(law, "fn"):                  # FunctionLaw: a motion or a table
            vals = list(law.fn.derivatives(xs, side))
            try:
                vals.append(law.fn.third(xs, side))
            except (ExprError, ArithmeticError, ValueError) as e:
                vals.append(None)
                note = str(e)
        else:                                   # an expression of theta
            env = dict(law.values)
            env[law.var] = xs
            vals = list(evaluate_all(law.exprs[:3], env, side))
            try:
                vals += evaluate_all((law.exprs[2].diff(law.var),), env, side)
            except (ExprError, ArithmeticError, ValueError) as e:
                vals.append(None)
                note = str(e)
        for o, v in enumerate(vals):
            if v is None:
                out[o] = None
            elif out[o] is not None:
                out[o][sel] = np.broadcast_to(np.asarray(v, float), xs.shape)
    if out[3] is None:
        note = "J is not drawn: the law's third derivative cannot be formed exactly" + \
            (f" ({note})" if note else "")
    return tuple(out), note


def law_knots(law, lo: float, hi: float) -> list:
    """The law's knots strictly inside (lo, hi), cam angles in the file's unit: where its value
    or one of its first four derivatives jumps (planarkin.functions.expr's breakpoints of the law and of
    its second derivative, found from the exact one-sided values), the boundaries of a motion's
    segments; [] for a smooth expression, and when there are more than MAX_KNOTS (a table's
    points) or they cannot be found."""
    from planarkin.functions.expr import ExprError, TimeFunction

    try:
        if hasattr(law, "fn"):
            fn = law.fn
        elif law.var == "t":
            fn = TimeFunction(re.sub(r"\btheta\b", "t", law.text), law.values)
        else:
            return []
        found = {bp.t for bp in fn.breakpoints(lo, hi)}
        if not fn.is_constant:
            found |= {bp.t for bp in TimeFunction.from_expr(fn.second, fn.text)
                      .breakpoints(lo, hi)}
    except (ExprError, ArithmeticError, ValueError, KeyError):
        return []
    eps = 1e-9 * max(hi - lo, abs(hi), abs(lo))
    knots = sorted(t for t in found if lo + eps < t < hi - eps and math.isfinite(t))
    return knots if len(knots) <= MAX_KNOTS else []


def follower_at(cm, cam: CamJoint, theta: float, Q: dict) -> dict:
    """The follower drawn at cam angle theta (user units), in the cam's frame (user lengths):
    'pitch' (its roller centre, knife tip or face point), 'roller' radius, 'face' (a flat face:
    its segment over every contact point of the law's range, Q its profile), 'stem' (a
    segment along a translating follower's axis) or 'pivot' and 'arm' (a rocker)."""
    L, af = cm.L, cm.angle_factor
    par = cam.par
    P = profile(cam.kind, par, np.array([theta * af]))
    c, sn = math.cos(-theta * af), math.sin(-theta * af)
    rot = lambda x, y: (c * x - sn * y, sn * x + c * y)           # noqa: E731 - frame k -> cam
    p = np.array([P["pitch_x"][0], P["pitch_y"][0]]) * L
    size = float(np.nanmax(np.hypot(Q["pitch_x"], Q["pitch_y"]))) * L
    out = {"pitch": p, "roller": float(par.get("roller", 0.0)) * L}
    if cam.kind == "cam":
        u = np.asarray(par["vk"], float)
        u = np.array(rot(*(u / np.hypot(*u))))
        out["stem"] = np.array([p + out["roller"] * u, p + (out["roller"] + 0.45 * size) * u])
    else:
        D = np.asarray(par["pk"], float) - np.asarray(par["sk"], float)
        out["pivot"] = np.array(rot(*D)) * L
        out["arm"] = np.array([out["pivot"], p])
    if par.get("flat", 0.0) > 0.5:
        # the face: along the tangent at the contact (perpendicular to the contact normal),
        # from its own point (the pitch point) over every contact point of the law's range:
        # xi, the contact's place along the face, as seen at each cam angle of Q
        n = np.array(rot(P["normal_x"][0], P["normal_y"][0]))
        t = np.array([-n[1], n[0]])
        th = Q["theta"]
        wx = np.cos(th) * Q["pitch_x"] - np.sin(th) * Q["pitch_y"]      # frame k
        wy = np.sin(th) * Q["pitch_x"] + np.cos(th) * Q["pitch_y"]
        xi = ((Q["contact_x"] - wx) * -Q["normal_y"] + (Q["contact_y"] - wy) * Q["normal_x"]) * L
        xi = xi[np.isfinite(xi)]
        a0 = min(0.0, float(xi.min()) if len(xi) else 0.0) - 0.08 * size
        a1 = max(0.0, float(xi.max()) if len(xi) else 0.0) + 0.08 * size
        out["face"] = np.array([p + a0 * t, p + a1 * t])
    return out


# -- the figure -------------------------------------------------------------------------------

RH, GAP = 1.4, 0.16         # the rows' height and the gap between them, inches
LW = 5.4                    # the law's column
RW = 4.3                    # the radius of curvature's and the pressure angle's column
DRAW_BELOW = 0.5            # under the drawing: its x tick labels and label
LEGEND_W = 2.0              # beside the drawing: its legend
SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076"
                                            "\u2077\u2078\u2079")


@styled
def cam_figure(cm, D: CamData, info=None):
    """The figure of one cam (see the module) from its CamData."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator, MultipleLocator, ScalarFormatter

    lu, au = D.length_unit, D.angle_unit
    bi, bj = D.cam.bodies[0], D.cam.bodies[1]
    palette = body_palette(cm.nb)
    cam_c = palette[bi] if bi < cm.nb else "0.3"
    fol_c = palette[bj] if bj < cm.nb else "0.3"
    rows = [("S", D.s), ("V", D.v), ("A", D.a)] + ([("J", D.j)] if D.j is not None else [])
    fig = Figure()
    law_axes: list = []
    for k, (key, y) in enumerate(rows):
        ax = add_axes(fig, (0, 0, 1, 1), xlabels=k == len(rows) - 1,
                      sharex=law_axes[0] if law_axes else None)
        e = _exponent(y)
        ax.plot(D.theta, y / 10.0 ** e, color=fol_c, lw=1.4, zorder=3)
        if key != "S":
            ax.axhline(0, color="0.6", lw=0.6, zorder=1)
        ax.set_ylabel(_label(D, key, e))
        law_axes.append(ax)
    rho_ax = add_axes(fig, (0, 0, 1, 1), xlabels=False, sharex=law_axes[0])
    pa_ax = add_axes(fig, (0, 0, 1, 1), xlabels=True, sharex=law_axes[0])
    _rho_axes(rho_ax, D, cam_c, lu)
    _pressure_axes(pa_ax, D, fol_c, au)
    for ax in law_axes + [rho_ax, pa_ax]:
        ax.yaxis.set_major_locator(MaxNLocator(nbins=5 if ax in law_axes else 4,
                                               steps=[1, 2, 2.5, 5, 10]))
        ax.yaxis.set_major_formatter(ScalarFormatter(useOffset=False))
        for x in D.knots:
            ax.axvline(x, color=KNOT_COLOR, lw=0.8, zorder=1.2)
    for ax in (law_axes[-1], pa_ax):
        ax.set_xlabel(f"cam angle \u03b8 [{au}]")
    lo, hi = float(D.theta[0]), float(D.theta[-1])
    if hi > lo:
        law_axes[0].set_xlim(lo, hi)
        if au == "deg":         # ticks at 15, 30, 45, 90 ... degrees
            step = next((s for s in (15, 30, 45, 90, 180, 360, 720) if (hi - lo) / s <= 8), None)
            if step is not None and (hi - lo) / step >= 2:
                law_axes[0].xaxis.set_major_locator(MultipleLocator(step))
    draw = add_axes(fig, (0, 0, 1, 1))
    handles = _drawing(draw, D, cam_c, fol_c, lu, au)
    # the layout, in inches: the law's rows on the left; on the right the drawing over rows 1
    # and 2, the radius of curvature in row 3, the pressure angle in row 4
    left = 0.75 + max(tick_label_width(ax.yaxis, *ax.get_ylim()) for ax in law_axes)
    room = 0.75 + max(tick_label_width(ax.yaxis, *ax.get_ylim()) for ax in (rho_ax, pa_ax, draw))
    x_r = left + LW + 0.3 + room
    dh = 2 * RH + GAP - DRAW_BELOW
    dw = min(dh, RW - LEGEND_W)
    # the legend beside the drawing: handle and pad (3 em), its widest line
    legend_w = 3.0 * FONT / 72 + text_inches([line for h in handles
                                              for line in h.get_label().split("\n")], FONT)
    W = x_r + max(RW, dw + 0.2 + legend_w) + 0.25
    notes = [line for note in _notes(D) for line in _wrap(note, int((W - 0.5) / 0.066))
             .split("\n")]
    title = plot_title(cm, f"cam '{D.cam.name}': the follower's law over cam angle and the "
                           f"profile", info)
    top = 0.2 + 0.24 * (title.count("\n") + 1) + 0.32
    bottom = 0.62 + 0.17 * len(notes)
    H = top + 4 * RH + 3 * GAP + bottom
    fig.set_size_inches(W, H)

    def box(x, y, w, h):
        return (x / W, y / H, w / W, h / H)
    y_of = [bottom + (3 - k) * (RH + GAP) for k in range(4)]
    for k, ax in enumerate(law_axes):
        ax.set_position(box(left, y_of[k], LW, RH))
    rho_ax.set_position(box(x_r, y_of[2], RW, RH))
    pa_ax.set_position(box(x_r, y_of[3], RW, RH))
    draw.set_position(box(x_r, y_of[1] + DRAW_BELOW, dw, dh))
    for ax in law_axes:
        ax.yaxis.set_label_coords(-(left - 0.45) / LW, 0.5)
        ax.xaxis.set_label_coords(0.5, -0.29 / RH)
    for ax in (rho_ax, pa_ax):
        ax.yaxis.set_label_coords(-(room - 0.45) / RW, 0.5)
        ax.xaxis.set_label_coords(0.5, -0.29 / RH)
    draw.yaxis.set_label_coords(-(room - 0.45) / dw, 0.5)
    draw.xaxis.set_label_coords(0.5, -0.29 / dh)
    if D.j is None:                          # where J would be: why it is not
        fig.text((left + 0.5 * LW) / W, (y_of[3] + 0.4 * RH) / H, _wrap(D.jerk_note, 75),
                 ha="center", va="center", fontsize=FONT, color="0.25")
    law_axes[0].set_title("the follower's law per unit cam angle (its exact derivatives)",
                          fontsize=10, y=1.0, loc="left")
    draw.set_title("the cam in its own frame, as in its table", fontsize=10, y=1.0, loc="left")
    fig.legend(handles=handles, loc="upper left", frameon=False, fontsize=FONT,
               bbox_to_anchor=((x_r + dw + 0.2) / W, (y_of[1] + DRAW_BELOW + dh) / H),
               borderaxespad=0, handlelength=2.2, labelspacing=0.7)
    if notes:
        fig.text(0.25 / W, 0.12 / H, "\n".join(notes), ha="left", va="bottom",
                 fontsize=FONT - 0.5, color="0.3", linespacing=1.35)
    fig.suptitle(title, fontsize=12, y=1 - 0.12 / H, va="top")
    return fig


def _exponent(y) -> int:
    """A power of 1000 that brings the largest |y| within 0.01 to 10000 (0: none needed)."""
    if y is None:
        return 0
    m = float(np.nanmax(np.abs(y))) if np.isfinite(y).any() else 0.0
    if not m > 0 or 0.01 <= m < 10_000:
        return 0
    return 3 * math.floor(math.log10(m) / 3)


def _label(D: CamData, key: str, e: int) -> str:
    """The axis label of S, V, A or J: the quantity per unit cam angle, its unit (times 10^e)
    on a second line."""
    lu, au = D.length_unit, D.angle_unit
    q, unit = ("s", lu) if D.kind == "cam" else ("\u03c8", au)
    o = "SVAJ".index(key)
    sup = ("", "", "\u00b2", "\u00b3")[o]
    what = q if o == 0 else f"d{sup}{q}/d\u03b8{sup}"
    unit = unit if o == 0 else f"{unit}/{au}{sup}"
    scale = f"10{str(e).translate(SUPERSCRIPT)} " if e else ""
    return f"{key} = {what}\n[{scale}{unit}]"


def _limit_label(ax, y, text):
    """A limit line's name, right-aligned just above it."""
    from matplotlib.transforms import blended_transform_factory
    ax.text(0.99, y, text, transform=blended_transform_factory(ax.transAxes, ax.transData),
            ha="right", va="bottom", fontsize=FONT - 0.5, color=LIMIT_COLOR, zorder=4,
            bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.5))


def _rho_axes(ax, D: CamData, color, lu):
    """The radius of curvature against cam angle with the undercut limit (the pitch curve's
    for a roller or a knife edge, dashed as the pitch curve; the working surface's for a flat
    face, solid)."""
    rho = np.array(D.rho, float)
    size = float(np.nanmax(np.hypot(D.pitch_x, D.pitch_y)))
    view = RHO_VIEW * size
    shown = np.where(np.abs(rho) <= 2 * view, rho, np.nan)     # no line through infinity
    ax.plot(D.at, shown, color=color, lw=1.4, ls="-" if D.flat else (0, (5, 2)), zorder=3)
    limit = D.roller if not D.flat else 0.0
    fin = rho[np.isfinite(rho)]
    lo = min(0.0, float(fin.min()) if len(fin) else 0.0)
    hi = max(limit, float(fin.max()) if len(fin) else 1.0)
    lo, hi = max(lo, -view), min(hi, view)
    pad = 0.1 * (hi - lo) if hi > lo else 1.0
    ax.set_ylim(lo - pad, hi + 1.5 * pad)
    ax.axhline(limit, color=LIMIT_COLOR, lw=1.0, ls=(0, (4, 2)), zorder=2)
    if limit > 0:
        ax.axhline(0, color="0.6", lw=0.6, zorder=1)
        _limit_label(ax, limit, f"roller radius {limit:.4g} {lu}: undercut below (convex)")
    elif D.flat:
        _limit_label(ax, 0.0, "undercut at 0 and below")
    else:
        _limit_label(ax, 0.0, "knife edge: undercut at 0 (convex)")
    ax.set_ylabel(f"radius of curvature\n{'surface' if D.flat else 'pitch curve'} [{lu}]")


def _pressure_axes(ax, D: CamData, color, au):
    """The pressure angle against cam angle with the limit the run is checked against."""
    ax.plot(D.at, D.pressure, color=color, lw=1.4, zorder=3)
    ax.axhline(D.limit, color=LIMIT_COLOR, lw=1.0, ls=(0, (4, 2)), zorder=2)
    top = max(float(np.nanmax(D.pressure)) if len(D.pressure) else 0.0, D.limit)
    ax.set_ylim(0, 1.25 * top if top > 0 else 1.0)
    how = "pressure_limit" if D.limit_given else \
        f"limit {D.limit:.4g} {au} (the default: a common guideline)"
    _limit_label(ax, D.limit, f"pressure_limit {D.limit:.4g} {au}" if D.limit_given else how)
    ax.set_ylabel(f"pressure angle\n[{au}]")


def _drawing(ax, D: CamData, cam_c, fol_c, lu, au) -> list:
    """The cam in its frame, the base circle and the follower at D.pose; the legend's
    handles."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle

    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(f"x [{lu}]")
    ax.set_ylabel(f"y [{lu}]")
    ax.plot(D.surface_x, D.surface_y, color=cam_c, lw=1.8, zorder=4)
    ax.plot(D.pitch_x, D.pitch_y, color=cam_c, lw=1.0, ls=(0, (5, 3)), zorder=3)
    ax.add_patch(Circle((0, 0), D.base, fill=False, ec="0.5", lw=0.9, ls=(0, (1.5, 2)),
                        zorder=2))
    ax.plot([0], [0], marker="+", color="0.2", ms=8, mew=1.2, zorder=5)
    F = D.follower
    if F["roller"] > 0:
        ax.add_patch(Circle(tuple(F["pitch"]), F["roller"], fill=False, ec=fol_c, lw=1.5,
                            zorder=6))
    ax.plot([F["pitch"][0]], [F["pitch"][1]], marker="o", ms=3.5, color=fol_c, zorder=7)
    for key in ("stem", "arm", "face"):
        if key in F:
            ax.plot(F[key][:, 0], F[key][:, 1], color=fol_c, lw=2.4, zorder=6,
                    solid_capstyle="butt")
    if "pivot" in F:
        ax.plot([F["pivot"][0]], [F["pivot"][1]], marker="o", ms=6, mfc="white", mec="0.15",
                mew=1.2, zorder=7)
    pts = [np.c_[D.surface_x, D.surface_y], np.c_[D.pitch_x, D.pitch_y],
           D.base * np.array([[1, 1], [-1, -1]])]
    pts += [F[key] for key in ("stem", "arm", "face") if key in F]
    if F["roller"] > 0:
        pts.append(F["pitch"] + F["roller"] * np.array([[1, 1], [-1, -1]]))
    P = np.concatenate(pts)
    ax.update_datalim(P[np.isfinite(P).all(axis=1)])
    ax.margins(0.05)
    ax.autoscale_view()
    base = "base circle" if D.kind == "cam" else "smallest radius"
    who = "roller" if F["roller"] > 0 else "flat face" if "face" in F else "knife edge"
    why = "largest pressure angle" if D.pose_why == "pressure" else "largest lift"
    return [Line2D([], [], color=cam_c, lw=1.8, label="working surface"),
            Line2D([], [], color=cam_c, lw=1.0, ls=(0, (5, 3)), label="pitch curve"),
            Line2D([], [], color="0.5", lw=0.9, ls=(0, (1.5, 2)),
                   label=f"{base}\nr = {D.base:.4g} {lu}"),
            Line2D([], [], color=fol_c, lw=2.4,
                   label=f"follower ({who})\nat \u03b8 = {D.pose:.4g} {au}\n({why})")]


def _notes(D: CamData) -> list:
    """Lines under the figure: the extremes against their limits, what the lines mean."""
    lu, au = D.length_unit, D.angle_unit
    out = []
    rho = D.rho
    if D.flat:
        fin = np.isfinite(rho)
        if fin.any():
            k = int(np.argmin(np.where(fin, rho, np.inf)))
            out.append(f"radius of curvature of the working surface: smallest {rho[k]:.4g} "
                       f"{lu} at \u03b8 = {D.at[k]:.4g} {au} (the flat face undercuts where it "
                       f"is not positive)")
    else:
        convex = np.isfinite(rho) & (rho > 0)
        if convex.any():
            k = int(np.argmin(np.where(convex, rho, np.inf)))
            lim = f"the roller radius {D.roller:.4g} {lu}" if D.roller > 0 else "0"
            out.append(f"radius of curvature of the pitch curve: smallest where convex "
                       f"{rho[k]:.4g} {lu} at \u03b8 = {D.at[k]:.4g} {au} (undercut where it is "
                       f"not larger than {lim})")
    view = RHO_VIEW * float(np.nanmax(np.hypot(D.pitch_x, D.pitch_y)))
    if np.abs(rho[np.isfinite(rho)]).max(initial=0.0) > view:
        clipped = (f"beyond \u00b1{view:.3g} {lu} off the axes (nearly straight: the radius "
                   f"grows without bound), below 0 concave")
        out[-1:] = [f"{out[-1]}; {clipped}" if out else f"radius of curvature: {clipped}"]
    if np.isfinite(D.pressure).any():
        k = int(np.nanargmax(D.pressure))
        out.append(f"pressure angle: largest {D.pressure[k]:.4g} {au} at \u03b8 = "
                   f"{D.at[k]:.4g} {au}; " + (f"pressure_limit {D.limit:.4g} {au}"
                                              if D.limit_given else
                                              f"the default limit {D.limit:.4g} {au}, a common "
                                              f"guideline"))
    q = "s" if D.kind == "cam" else "\u03c8"
    out.append(f"S, V, A, J: {q} and its derivatives per unit cam angle; at a constant cam "
               f"speed \u03c9 the follower's velocity is V\u00b7\u03c9, its acceleration "
               f"A\u00b7\u03c9\u00b2, its jerk J\u00b7\u03c9\u00b3"
               + ("; light vertical lines: the law's knots (segment boundaries)" if D.knots
                  else ""))
    return out


def _wrap(text: str, width: int) -> str:
    import textwrap
    return "\n".join(textwrap.wrap(text, width))
