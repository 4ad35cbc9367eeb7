"""Instant centres of velocity of every pair of bodies (ground included): centres.csv.

Asked for with ``output: {centres: true}``. For bodies i and j (i before j; ground first, then
the bodies in file order) the instant centre I is the point that has the same velocity on both:
    v_i + w_i k x (I - r_i) = v_j + w_j k x (I - r_j)
    =>  (w_j - w_i) k x I = b,   b = v_i - v_j - w_i k x r_i + w_j k x r_j
    =>  I = (b_y, -b_x) / (w_j - w_i)
from the exact q and q' of the solve (no differences). Columns per pair ``<i>/<j>.x [L]``,
``<i>/<j>.y [L]`` and ``<i>/<j>.flag [-]``: flag 0 where I is finite; 1 where the relative motion
is a pure translation (w_j = w_i, or I farther than 1e12 model sizes): I is at infinity, x and y
are nan -- never a huge finite number; 2 where there is no relative motion at all (|w_j - w_i| L
and |b| below 1e-13 of the largest body speed at that instant): I is undefined (every point is
one), x and y are nan. The centre does not need a one-DOF mechanism: it follows from
the velocities whatever drives them.

centres.png draws, for each body whose centre relative to ground moves, its fixed centrode (the
path of I in the ground frame) and its moving centrode (the same points in the body's frame,
drawn at the body's pose at t = start, where the two touch). With ``output: {centres: moving}``
mechanism.png draws the moving centrode of each floating body too, at the body's pose at every
instant drawn (`moving_centrodes`, `draw_moving`): the curve fixed to the body that rolls
without slipping on the fixed centrode, touching it at that instant's centre.
"""

from __future__ import annotations

import numpy as np

from planarkin.derived import DerivedTable

FAR = 1e12          # a centre farther than FAR model sizes counts as at infinity
REST = 1e-13        # relative w L and b below REST x the largest body speed: relative rest


def pairs(cm) -> list[tuple[int, int]]:
    """Body index pairs (ground = nb first), i before j."""
    order = [cm.nb] + list(range(cm.nb))
    return [(order[a], order[b]) for a in range(len(order)) for b in range(a + 1, len(order))]


def _name(cm, b) -> str:
    return "ground" if b == cm.nb else cm.body_names[b]


def _state(cm, ch, b):
    N = len(ch.t)
    if b == cm.nb:
        z = np.zeros(N)
        return z, z, z, z, z
    af = cm.angle_factor
    return (ch.q[:, 3 * b], ch.q[:, 3 * b + 1], ch.qd[:, 3 * b], ch.qd[:, 3 * b + 1],
            ch.qd[:, 3 * b + 2] * af)


def compute(cm, ch) -> np.ndarray:
    cols = [ch.t]
    # per row: the largest body speed (|r'| + |w| L), the scale of "no relative motion"
    af = cm.angle_factor
    vx, vy, w_all = ch.qd[:, 0::3], ch.qd[:, 1::3], ch.qd[:, 2::3] * af
    vscale = np.max(np.hypot(vx, vy) + np.abs(w_all) * cm.L, axis=1) if cm.nb else \
        np.zeros(len(ch.t))
    for i, j in pairs(cm):
        xi, yi, vxi, vyi, wi = _state(cm, ch, i)
        xj, yj, vxj, vyj, wj = _state(cm, ch, j)
        # k x r = (-r_y, r_x)
        bx = vxi - vxj + wi * yi - wj * yj
        by = vyi - vyj - wi * xi + wj * xj
        w = wj - wi
        bn = np.hypot(bx, by)
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y = by / w, -bx / w
        flag = np.zeros(len(ch.t))
        at_inf = np.abs(w) * FAR * cm.L <= bn
        flag[at_inf] = 1.0
        # relative rest: w and b both at rounding level of the mechanism's velocities
        rest = (np.abs(w) * cm.L <= REST * vscale) & (bn <= REST * vscale)
        flag[rest] = 2.0
        x = np.where(flag > 0, np.nan, x)
        y = np.where(flag > 0, np.nan, y)
        cols += [x, y, flag]
    return np.column_stack(cols)


def derived_tables(cm, opts) -> list[DerivedTable]:
    if not cm.spec.output.centres or opts.order < 1:
        return []
    lu = cm.spec.length_unit
    header = ["t [s]"]
    for i, j in pairs(cm):
        p = f"{_name(cm, i)}/{_name(cm, j)}"
        header += [f"{p}.x [{lu}]", f"{p}.y [{lu}]", f"{p}.flag [-]"]
    last = {}

    def table(ch):
        # the directory writer computes the plot rows right before calling plot: the moving
        # centrodes need those rows' body poses, which the table itself does not hold
        last["chunk"] = ch
        return compute(cm, ch)

    return [DerivedTable(filename="centres.csv", header=header, compute=table,
                         plot=lambda cm_, X, info, out, fmt: _plot(cm_, X, last.get("chunk"),
                                                                   out, fmt))]


def _plot(cm, X, ch, out, fmt):
    """centres.png: fixed and moving centrodes of each body relative to ground (matplotlib's
    object-oriented API: no pyplot, no backend switch; the legend under the axes, off the
    curves)."""
    from pathlib import Path

    from matplotlib.figure import Figure
    pl = pairs(cm)
    shown = []
    for k, (i, j) in enumerate(pl):
        if i != cm.nb:
            continue
        x, y = X[:, 1 + 3 * k], X[:, 2 + 3 * k]
        fin = np.isfinite(x)
        if fin.sum() > 1 and (np.ptp(x[fin]) > 1e-9 * cm.L or np.ptp(y[fin]) > 1e-9 * cm.L):
            shown.append((k, j))
    if not shown:
        return []
    # the view: the mechanism's extent (every point over the run), widened; a centrode runs to
    # infinity where the relative rotation stops, so points far outside are cut from the lines
    box = None
    if ch is not None and ch.p.size:
        P = ch.p.reshape(-1, 2)
        lo, hi = P.min(axis=0), P.max(axis=0)
        size = max(float(np.max(hi - lo)), 1e-12)
        box = (lo - 1.0 * size, hi + 1.0 * size, lo - 4.0 * size, hi + 4.0 * size)
    n = len(shown)
    fig = Figure(figsize=(5.2 * n, 5.6), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)
    for ax, (k, j) in zip(axes[0], shown):
        x, y = X[:, 1 + 3 * k], X[:, 2 + 3 * k]
        if box is not None:
            far = (x < box[2][0]) | (x > box[3][0]) | (y < box[2][1]) | (y > box[3][1])
            x, y = np.where(far, np.nan, x), np.where(far, np.nan, y)
        ax.plot(x, y, color="tab:blue", lw=1.5, label="fixed centrode (ground frame)")
        # moving centrode: each centre in body j's frame at its own instant, then drawn at the
        # body's pose at t = start; needs the body's pose at every plot row
        pose = None
        if ch is not None and len(ch.t) == len(X):
            pose = ch.q[:, 3 * j], ch.q[:, 3 * j + 1], ch.q[:, 3 * j + 2] * cm.angle_factor
        if pose is not None:
            px, py, phi = pose
            c, s = np.cos(phi), np.sin(phi)
            lx = c * (x - px) + s * (y - py)
            ly = -s * (x - px) + c * (y - py)
            x0, y0, p0 = px[0], py[0], phi[0]
            gx = x0 + np.cos(p0) * lx - np.sin(p0) * ly
            gy = y0 + np.sin(p0) * lx + np.cos(p0) * ly
            if box is not None:
                far = (gx < box[2][0]) | (gx > box[3][0]) | (gy < box[2][1]) | (gy > box[3][1])
                gx, gy = np.where(far, np.nan, gx), np.where(far, np.nan, gy)
            ax.plot(gx, gy, color="tab:orange", lw=1.2, ls="--",
                    label="moving centrode (body frame, at t = start)")
        if ch is not None:
            ax.plot(ch.p[0, :, 0], ch.p[0, :, 1], "s", color="0.4", ms=3,
                    label="the model's points at t = start")
        fin = np.isfinite(x)
        if fin.any():
            first = np.argmax(fin)
            ax.plot(x[first], y[first], "o", color="k", ms=4, label="centre at the first instant")
        ax.set_title(f"{_name(cm, j)} relative to ground (view cut at the mechanism's size)"
                     if box is not None else f"{_name(cm, j)} relative to ground", fontsize=9)
        ax.set_aspect("equal", adjustable="box")
        if box is not None:
            ax.set_xlim(box[0][0], box[1][0])
            ax.set_ylim(box[0][1], box[1][1])
        ax.grid(alpha=0.3)
        ax.set_xlabel(f"x [{cm.spec.length_unit}]")
        ax.set_ylabel(f"y [{cm.spec.length_unit}]")
    fig.legend(handles=axes[0][0].get_legend_handles_labels()[0], loc="outside lower center",
               ncol=2, fontsize=8, frameon=False)
    fig.suptitle(f"{cm.spec.name}: centrodes (instant centres relative to ground)")
    path = Path(out) / f"centres.{fmt}"
    fig.savefig(path, dpi=110)
    return [path]



# -- moving centrodes in the mechanism plot --------------------------------------------------------

def moving_centrodes(cm, data, bodies) -> list:
    """[(body, (N, 2) curve in the body's frame, user length unit)]: the instant centre of the
    body relative to ground (the ground's centre relative to the body: the same point) at every
    plot row, expressed in the body's frame at that row -- a curve fixed to the body. nan where
    the centre is at infinity or undefined. bodies: the body indices to give (those whose fixed
    centrode is drawn)."""
    if not bodies or getattr(data, "qd", None) is None:
        return []
    X = compute(cm, data)
    k_of = {j: k for k, (i, j) in enumerate(pairs(cm)) if i == cm.nb}
    out = []
    for j in bodies:
        k = k_of[j]
        x, y = X[:, 1 + 3 * k], X[:, 2 + 3 * k]
        px, py = data.q[:, 3 * j], data.q[:, 3 * j + 1]
        phi = data.q[:, 3 * j + 2] * cm.angle_factor
        c, s = np.cos(phi), np.sin(phi)
        out.append((j, np.c_[c * (x - px) + s * (y - py), -s * (x - px) + c * (y - py)]))
    return out


def draw_moving(ax, scene, row) -> list:
    """Draw each moving centrode of scene.moving at the body's pose at `row` (the mechanism
    plot's first, named instant: drawn at every instant the curves would hide the linkage), cut
    at the drawing's bounds (near a parallel position the centre runs to infinity), with a dot
    where it touches the fixed centrode: the instant centre at that row. Returns the legend
    handles."""
    x0, x1, y0, y1 = scene.bounds
    handles = []
    for j, local in scene.moving:
        c, s = scene.c[row, j], scene.s[row, j]
        gx = scene.x[row, j] + c * local[:, 0] - s * local[:, 1]
        gy = scene.y[row, j] + s * local[:, 0] + c * local[:, 1]
        far = ~((gx >= x0) & (gx <= x1) & (gy >= y0) & (gy <= y1))
        gx, gy = np.where(far, np.nan, gx), np.where(far, np.nan, gy)
        line, = ax.plot(gx, gy, color=scene.colors[j], lw=1.4, alpha=0.85, ls=(0, (6, 2)),
                        zorder=4, label=f"moving centrode\nof {scene.names[j]}")
        handles.append(line)
        if np.isfinite(gx[row]) and np.isfinite(gy[row]):
            dot, = ax.plot(gx[row], gy[row], "o", mfc=scene.colors[j], mec="k", mew=0.8, ms=6,
                           zorder=40, ls="none",
                           label=f"instant centre\nof {scene.names[j]}")
            handles.append(dot)
    return handles
