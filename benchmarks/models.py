"""Benchmark mechanisms: YAML text for planarkin, the same mechanisms for the textbook solver,
and vectorised closed forms (positions, velocities, accelerations) of all three (the slider-crank
and the four-bar from tests/closedforms.py).

Every closed form returns a dict with t (K,), q, qd, qdd (K, 3 nb), with the columns in
planarkin's order (per body, in the YAML's body order: x, y, phi) and in the units of the YAML
(m, rad, s). `python benchmarks/models.py` checks the closed forms against central differences.

(a) slider-crank: crank r = 0.1 (frame at the ground pivot O), rod l = 0.3 (frame at the crank
    pin A), slider (frame at the rod's end B, sliding on the x axis); crank angle 2 pi t, one turn.
(b) four-bar: the crank-rocker of mechanisms/four-bar.yaml (a = 0.04, b = 0.12, c = 0.10,
    d = 0.10), written in radians; crank 2 pi t, one turn; open (upper) branch.
(c) IFToMM A02 N-four-bar chain: N + 1 vertical cranks (length 1 m) pinned to ground at
    x = 0, 1, ..., N and N horizontal couplers (length 1 m), coupler k pinned to the tops of
    cranks k and k + 1: 2 N + 1 bodies. The first crank is driven,
    theta(t) = pi/2 + 0.5 sin(2 pi t); every crank is at theta and coupler k (frame at its left
    end) is at (k + cos theta, sin theta, 0). Body order: cranks c0..cN, then couplers k0..k(N-1).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from closedforms import four_bar, slider_crank  # noqa: E402  (the closed forms, written once)

TWO_PI = 2.0 * math.pi

# -- slider-crank --------------------------------------------------------------------------------

SC_R, SC_L = 0.1, 0.3


def slider_crank_yaml(r: float = SC_R, l: float = SC_L) -> str:
    return f"""\
# Slider-crank (benchmarks/models.py): crank r, rod l, crank angle 2*pi*t, one turn.
name: slider-crank
units: {{length: m, angle: rad}}
parameters:
  a: {r!r}          # crank length
  b: {l!r}          # connecting-rod length
bodies:
  crank:  {{q: [0.05, 0.0, 0.3]}}
  rod:    {{q: [0.2, 0.02, -0.1]}}
  slider: {{q: [0.4, 0.0, 0.0]}}
joints:
  - {{type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}}
  - {{type: revolute, i: crank, j: rod, si: [a, 0], sj: [0, 0]}}
  - {{type: revolute, i: rod, j: slider, si: [b, 0], sj: [0, 0]}}
  - {{type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}}
drivers:
  - {{type: angle, body: crank, f: "2*pi*t"}}
points:
  B: {{body: rod, s: [b, 0]}}
analysis: {{start: 0, end: 1, steps: 360}}
"""


def slider_crank_closed_form(t, r: float = SC_R, l: float = SC_L) -> dict:
    """tests/closedforms.py's slider_crank, crank angle 2 pi t, in planarkin's columns."""
    t = np.asarray(t, dtype=float)
    th, w, al = TWO_PI * t, TWO_PI + 0 * t, 0 * t
    c, s = np.cos(th), np.sin(th)
    be, bd, bdd, xb, xbd, xbdd = slider_crank(th, w, al, r, l)
    # crank pin A (rod frame)
    ax, ay = r * c, r * s
    axd, ayd = -r * s * w, r * c * w
    axdd = -r * c * w * w - r * s * al
    aydd = -r * s * w * w + r * c * al
    z = 0 * t
    q = np.stack([z, z, th, ax, ay, be, xb, z, z], axis=1)
    qd = np.stack([z, z, w, axd, ayd, bd, xbd, z, z], axis=1)
    qdd = np.stack([z, z, al, axdd, aydd, bdd, xbdd, z, z], axis=1)
    return {"t": t, "q": q, "qd": qd, "qdd": qdd}


# -- four-bar ------------------------------------------------------------------------------------

FB_A, FB_B, FB_C, FB_D = 0.04, 0.12, 0.10, 0.10


def four_bar_yaml() -> str:
    return """\
# Four-bar crank-rocker of mechanisms/four-bar.yaml, in radians (benchmarks/models.py).
name: four-bar
units: {length: m, angle: rad}
parameters:
  a: 0.04         # crank A-B
  b: 0.12         # coupler B-C
  c: 0.10         # rocker D-C
  d: 0.10         # ground A-D
bodies:           # body frames: crank at A, coupler at B, rocker at D, each x axis along its link
  crank:   {q: [0, 0, 0]}
  coupler: {q: [0.04, 0, 0.96]}
  rocker:  {q: [0.1, 0, 1.48]}
joints:
  - {type: revolute, i: ground, j: crank,   si: [0, 0], sj: [0, 0]}    # A
  - {type: revolute, i: crank,  j: coupler, si: [a, 0], sj: [0, 0]}    # B
  - {type: revolute, i: coupler, j: rocker, si: [b, 0], sj: [c, 0]}    # C
  - {type: revolute, i: ground, j: rocker,  si: [d, 0], sj: [0, 0]}    # D
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
points:
  P: {body: coupler, s: [0.06, 0.045]}
  C: {body: rocker, s: [c, 0]}
analysis: {start: 0, end: 1, steps: 360}
"""


def four_bar_closed_form(t, a=FB_A, b=FB_B, c=FB_C, d=FB_D) -> dict:
    """tests/closedforms.py's four_bar (open branch), crank angle 2 pi t, in planarkin's
    columns."""
    t = np.asarray(t, dtype=float)
    th, w, al = TWO_PI * t, TWO_PI + 0 * t, 0 * t
    ct, st = np.cos(th), np.sin(th)
    p3, w3, a3, p4, w4, a4 = four_bar(th, w, al, a, b, c, d)
    bx, by = a * ct, a * st                      # pin B
    bxd, byd = -a * st * w, a * ct * w
    bxdd, bydd = -a * ct * w * w - a * st * al, -a * st * w * w + a * ct * al
    z = 0 * t
    dd = d + z
    q = np.stack([z, z, th, bx, by, p3, dd, z, p4], axis=1)
    qd = np.stack([z, z, w, bxd, byd, w3, z, z, w4], axis=1)
    qdd = np.stack([z, z, al, bxdd, bydd, a3, z, z, a4], axis=1)
    return {"t": t, "q": q, "qd": qd, "qdd": qdd}


# -- IFToMM A02 N-four-bar chain -----------------------------------------------------------------

def chain_theta(t):
    t = np.asarray(t, dtype=float)
    th = 0.5 * math.pi + 0.5 * np.sin(TWO_PI * t)
    thd = 0.5 * TWO_PI * np.cos(TWO_PI * t)
    thdd = -0.5 * TWO_PI * TWO_PI * np.sin(TWO_PI * t)
    return th, thd, thdd


def chain_yaml(N: int) -> str:
    lines = [
        f"# IFToMM A02 N-four-bar chain, N = {N}: {N + 1} cranks, {N} couplers, {2 * N + 1} "
        f"bodies (benchmarks/models.py).",
        f"name: chain-{N}",
        "units: {length: m, angle: rad}",
        "bodies:",
    ]
    # rough estimates near the pose at t = 0 (theta = pi/2): the solver assembles from them
    for k in range(N + 1):
        lines.append(f"  c{k}: {{q: [{k}, 0, 1.57]}}")
    for k in range(N):
        lines.append(f"  k{k}: {{q: [{k}, 1, 0]}}")
    lines.append("joints:")
    for k in range(N + 1):
        lines.append(f"  - {{type: revolute, i: ground, j: c{k}, si: [{k}, 0], sj: [0, 0]}}")
    for k in range(N):
        lines.append(f"  - {{type: revolute, i: c{k}, j: k{k}, si: [1, 0], sj: [0, 0]}}")
        lines.append(f"  - {{type: revolute, i: c{k + 1}, j: k{k}, si: [1, 0], sj: [1, 0]}}")
    lines += [
        "drivers:",
        '  - {type: angle, body: c0, f: "pi/2 + 0.5*sin(2*pi*t)"}',
        "analysis: {start: 0, end: 1, steps: 1000}",
        "",
    ]
    return "\n".join(lines)


def chain_closed_form(t, N: int) -> dict:
    t = np.asarray(t, dtype=float)
    th, thd, thdd = chain_theta(t)
    K, nb = len(t), 2 * N + 1
    q = np.zeros((K, 3 * nb))
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    cr = 3 * np.arange(N + 1)                       # crank columns
    cp = 3 * (N + 1 + np.arange(N))                 # coupler columns
    q[:, cr] = np.arange(N + 1)
    q[:, cr + 2] = th[:, None]
    qd[:, cr + 2] = thd[:, None]
    qdd[:, cr + 2] = thdd[:, None]
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    w, a = thd[:, None], thdd[:, None]
    q[:, cp] = np.arange(N) + c
    q[:, cp + 1] = s
    qd[:, cp] = -s * w
    qd[:, cp + 1] = c * w
    qdd[:, cp] = -c * w * w - s * a
    qdd[:, cp + 1] = -s * w * w + c * a
    return {"t": t, "q": q, "qd": qd, "qdd": qdd}


# -- the same mechanisms for the textbook solver -------------------------------------------------

@dataclass
class Mechanism:
    """Input of benchmarks/textbook.py: bodies, joints (revolute / translational) and angle
    drivers with f, f', f'' as Python callables. Bodies are indices 0..nb-1, ground is None."""

    name: str
    nb: int
    revolutes: list = field(default_factory=list)       # (i, j, si, sj)
    translationals: list = field(default_factory=list)  # (i, j, si, sj, vi, c0)
    angle_drivers: list = field(default_factory=list)   # (i, j, f, fd, fdd)
    length: float = 1.0                                   # characteristic length (tolerance)


def _linear(w):
    return (lambda t: w * t, lambda t: w + 0 * t, lambda t: 0 * t)


def slider_crank_mechanism(r=SC_R, l=SC_L) -> Mechanism:
    m = Mechanism("slider-crank", 3, length=l)
    m.revolutes = [(None, 0, (0, 0), (0, 0)), (0, 1, (r, 0), (0, 0)), (1, 2, (l, 0), (0, 0))]
    m.translationals = [(None, 2, (0, 0), (0, 0), (1, 0), 0.0)]
    m.angle_drivers = [(None, 0, *_linear(TWO_PI))]
    return m


def four_bar_mechanism(a=FB_A, b=FB_B, c=FB_C, d=FB_D) -> Mechanism:
    m = Mechanism("four-bar", 3, length=b)
    m.revolutes = [(None, 0, (0, 0), (0, 0)), (0, 1, (a, 0), (0, 0)),
                   (1, 2, (b, 0), (c, 0)), (None, 2, (d, 0), (0, 0))]
    m.angle_drivers = [(None, 0, *_linear(TWO_PI))]
    return m


def chain_mechanism(N: int) -> Mechanism:
    m = Mechanism(f"chain-{N}", 2 * N + 1, length=1.0)
    crank = lambda k: k                    # noqa: E731
    coupler = lambda k: N + 1 + k          # noqa: E731
    m.revolutes = [(None, crank(k), (k, 0), (0, 0)) for k in range(N + 1)]
    for k in range(N):
        m.revolutes.append((crank(k), coupler(k), (1, 0), (0, 0)))
        m.revolutes.append((crank(k + 1), coupler(k), (1, 0), (1, 0)))

    def f(t):
        return chain_theta(t)[0]

    def fd(t):
        return chain_theta(t)[1]

    def fdd(t):
        return chain_theta(t)[2]

    m.angle_drivers = [(None, crank(0), f, fd, fdd)]
    return m


# -- error measure -------------------------------------------------------------------------------

def rel_error(x, ref, floor=1e-3) -> float:
    """max over steps and columns of |x - ref| / scale_col, scale_col = the column's largest
    |ref| over the run, floored at `floor` times the largest column maximum of the array (so an
    identically zero column, e.g. the slider's y, is measured against the array's size)."""
    x = np.asarray(x, dtype=float)
    ref = np.asarray(ref, dtype=float)
    if x.shape != ref.shape:
        raise ValueError(f"shape {x.shape} != reference shape {ref.shape}")
    colmax = np.abs(ref).max(axis=0)
    scale = np.maximum(colmax, floor * max(colmax.max(), 1e-300))
    return float((np.abs(x - ref) / scale).max())


def errors(res_q, res_qd, res_qdd, cf: dict, rows=None) -> dict:
    sl = slice(None) if rows is None else rows
    return {"P": rel_error(res_q, cf["q"][sl]), "V": rel_error(res_qd, cf["qd"][sl]),
            "A": rel_error(res_qdd, cf["qdd"][sl])}


# -- self-check ----------------------------------------------------------------------------------

def _check_derivatives(cf_fn, name, tol=1e-6):
    t = np.linspace(0.013, 0.987, 97)
    h = 1e-5
    c0, cp, cm = cf_fn(t), cf_fn(t + h), cf_fn(t - h)
    fd_v = (cp["q"] - cm["q"]) / (2 * h)
    fd_a = (cp["qd"] - cm["qd"]) / (2 * h)
    ev, ea = rel_error(fd_v, c0["qd"]), rel_error(fd_a, c0["qdd"])
    print(f"  {name:14s} closed form vs central differences: V {ev:.1e}, A {ea:.1e}")
    assert ev < tol and ea < tol, name


if __name__ == "__main__":
    _check_derivatives(slider_crank_closed_form, "slider-crank")
    _check_derivatives(four_bar_closed_form, "four-bar")
    _check_derivatives(lambda t: chain_closed_form(t, 5), "chain-5")
    # the four-bar's closure and lengths
    cf = four_bar_closed_form(np.linspace(0, 1, 50))
    q = cf["q"]
    cx = q[:, 3] + FB_B * np.cos(q[:, 5])
    cy = q[:, 4] + FB_B * np.sin(q[:, 5])
    assert np.allclose(cx, FB_D + FB_C * np.cos(q[:, 8])) and np.allclose(
        cy, FB_C * np.sin(q[:, 8]))
    print("  closed forms ok")
