"""The forces how-to's figure of a gear pair's tooth force (docs/how-to/forces.md), drawn from
what this room computes for a small spur pair (PAIR, solved by the caller: a room does not load
models), so that it cannot show another convention than forces.csv: ``python -m planarkin.docs
--figure`` writes it (tests/test_gear_forces.py checks that the checked-in file is what this
draws). matplotlib is imported when drawing only."""

from __future__ import annotations

import math

import numpy as np

FIGURE = "docs/images/gear-tooth-force.png"     # relative to the checkout
# pinion i driven at the origin, gear j held back by a torque T = 40 N*m: F_t = T / rj = 400 N
PAIR = """
name: tooth-force
units: {length: m, angle: deg}
bodies:
  pinion: {q: [0, 0, 0]}
  wheel: {q: [0.15, 0, 0]}
joints:
  - {type: revolute, name: Oi, i: ground, j: pinion, at: [0, 0]}
  - {type: revolute, name: Oj, i: ground, j: wheel, at: [0.15, 0]}
  - {type: gear, name: teeth, i: pinion, j: wheel, ri: 0.05, rj: 0.1, pressure_angle: 20}
drivers:
  - {type: angle, name: motor, body: pinion, f: "90*t"}
loads:
  - {type: torque, body: wheel, f: "40"}
analysis: {start: 0, end: 1, steps: 1}
"""


def tooth_force(res) -> dict:
    """The quantities of PAIR's Result res at t = 0 (user units): centres 'ci', 'cj', radii
    'ri', 'rj', pressure angle 'alpha' (rad), pitch point 'P', the tooth force 'F' on j
    (forces.csv's teeth.fx, teeth.fy), the bearing force 'B' on j and the torque 'T' that holds
    j back."""
    from .solve import Kinetostatics
    cm = res.model
    F = Kinetostatics(cm).solve(res.t, res.q, res.qd, res.qdd)
    e = {el.name: k for k, el in enumerate(cm.spec.elements)}
    el = cm.spec.elements[e["teeth"]]
    ri, rj = float(el.params["ri"]), float(el.params["rj"])
    ci, cj = np.zeros(2), np.array([res.body("wheel")["x"][0], res.body("wheel")["y"][0]])
    P = ci + ri / (ri + rj) * (cj - ci)
    fx, fy, _ = F.reaction(e["teeth"], 1)
    bx, by, _ = F.reaction(e["Oj"], 1)
    T = float(cm.spec.forces.loads[0].f[0](np.zeros(1))[0])
    return {"ci": ci, "cj": cj, "ri": ri, "rj": rj, "P": P, "T": T,
            "alpha": float(el.params["pressure_angle"]) * cm.angle_factor,
            "F": np.array([fx[0], fy[0]]), "B": np.array([bx[0], by[0]])}


def tooth_force_figure(dest, res) -> None:
    """Draw PAIR (res: its Result) with its pitch and base circles, the line of action through
    the pitch point at the pressure angle to the common tangent, and the tooth force on j with
    its tangential and radial parts (as computed) and the bearing force on j; write a png to
    dest."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Arc, Circle

    d = tooth_force(res)
    ci, cj, ri, rj, P, a = d["ci"], d["cj"], d["ri"], d["rj"], d["P"], d["alpha"]
    e = (cj - ci) / np.hypot(*(cj - ci))                  # line of centres, i to j
    t = np.array([-e[1], e[0]])                           # common tangent at P
    Fv = d["F"]
    ft, fr, f = Fv @ t, Fv @ e, np.hypot(*Fv)
    fig = Figure(figsize=(8.0, 3.6))
    FigureCanvasAgg(fig)
    ax = fig.add_axes([0.0, 0.0, 1.0, 1.0])
    ax.set_aspect("equal")
    ax.axis("off")
    grey, blue, red, green = "0.55", "#1f5fa8", "#c0392b", "#2e8b57"
    small = {"textcoords": "offset points", "fontsize": 9}
    for c, r, name, off in ((ci, ri, "gear i", (0, -16)), (cj, rj, "gear j", (22, 22))):
        ax.add_patch(Circle(c, r, fill=False, lw=1.4, color="0.2"))
        ax.add_patch(Circle(c, r * math.cos(a), fill=False, lw=0.8, ls=":", color=grey))
        ax.plot(*c, "o", color="0.2", ms=4)
        ax.annotate(name, c, xytext=off, ha="center", **small)
    ax.plot([ci[0] - 0.02, cj[0] + 0.02], [ci[1], cj[1]], "-.", lw=0.8, color=grey)
    # the common tangent of the pitch circles, and the line of action at alpha to it: tangent
    # to both base circles
    ax.plot(*np.array([P - 0.07 * t, P + 0.07 * t]).T, "--", lw=0.8, color=grey)
    act = math.cos(a) * t + math.sin(a) * e
    ax.plot(*np.array([P - 0.105 * act, P + 0.105 * act]).T, "-", lw=0.9, color=blue)
    ax.annotate("line of action", P - 0.105 * act, xytext=(-4, 0), ha="right", va="center",
                color=blue, **small)
    th = sorted(math.degrees(math.atan2(v[1], v[0])) for v in (t, act))
    ax.add_patch(Arc(P, 0.12, 0.12, theta1=th[0], theta2=th[1], color=blue, lw=0.9))
    mid = math.cos(a / 2) * t + math.sin(a / 2) * e
    ax.annotate("α", P + 0.06 * mid, xytext=(0, 2), ha="center", va="bottom", color=blue,
                **small)
    k = 0.09 / f                                          # arrow length per newton

    def arrow(start, vec, color, lw):
        ax.annotate("", start + k * vec, start, arrowprops={
            "arrowstyle": "-|>", "color": color, "lw": lw, "shrinkA": 0, "shrinkB": 0})
    arrow(P, Fv, red, 2.2)
    arrow(P, ft * t, green, 1.4)
    arrow(P, fr * e, green, 1.4)
    arrow(P, -Fv, red, 1.2)
    arrow(cj, d["B"], "0.3", 1.2)
    ax.annotate("F", P + k * Fv, xytext=(4, 0), color=red, va="center", **small)
    ax.annotate("F$_t$", P + k * ft * t, xytext=(-4, 0), color=green, ha="right",
                va="center", **small)
    ax.annotate("F$_r$", P + k * fr * e, xytext=(0, -5), color=green, ha="center", va="top",
                **small)
    ax.annotate("−F on i", P - k * Fv, xytext=(5, 0), color=red, va="center", **small)
    ax.annotate("bearing on j: −F", cj + 0.5 * k * d["B"], xytext=(6, 0), color="0.3",
                va="center", **small)
    ax.annotate("P", P, xytext=(-5, -4), ha="right", va="top", color="0.2", **small)
    text = (f"F: the tooth force on gear j at the pitch point P,\n"
            f"along the line of action (α = {math.degrees(a):g}° to the tangent)\n\n"
            f"T = {d['T']:g} N·m on j, rj = {rj:g} m\n"
            f"F$_t$ = T / rj = {ft:.1f} N  (tangential)\n"
            f"F$_r$ = F$_t$ tan α = {fr:.1f} N  (radial: apart)\n"
            f"|F| = T / (rj cos α) = {f:.1f} N\n\n"
            f"gear i gets −F at P; the bearings carry the\n"
            f"tooth force, the carrier k nothing\n"
            f"pitch circles solid, base circles r cos α dotted")
    ax.text(0.27, 0.0, text, fontsize=8.5, va="center", linespacing=1.45)
    ax.set_xlim(-0.095, 0.555)
    ax.set_ylim(-0.125, 0.125)
    fig.savefig(dest, dpi=100, metadata={"Software": None})
