"""Exact first-order sensitivities of the positions to the model's parameters.

At every grid time the constraints Phi(q(t, p), t, p) = 0 hold, so differentiating with respect
to a parameter p gives Phi_q dq/dp = -Phi_p: a linear solve with the same Jacobian as the
velocity solve. Phi_p is exact, by the chain rule, never by finite differences:

* every number of the file is an expression of the parameters; its derivative with respect to p
  is the symbolic derivative (planarkin.functions.expr ``diff``) of the text as written, through the
  parameters it uses, which are themselves differentiated in file order (``b: 3*a`` gives
  db/da = 3);
* a body-frame point s'_i of body i enters every kind only through r_i + A_i s'_i (reference
  §0), so dg/ds'_i = (dg/dr_i) A_i, from the kind's own gradient;
* a joint's constant c enters as g - c (dPhi/dc = -1) and a driver's f(t) as g - f(t)
  (dPhi/dp = -df/dp, the symbolic derivative of f at every grid time).

A parameter that reaches a direction (vi, vj), a gear radius, or a global placement ``at`` is
refused with a message naming the element (those enter nonlinearly through the compile step).
Results are in user units per unit of the parameter. A metric of a study (the max, min, stroke
or absmax of a position column, refined between the grid rows) has for derivative its column's
sensitivity at the refined extreme's time (`metric_gradients`), solved there.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..diagnostics import Diagnostic, InputError
from ..elements import KINDS
from ..elements.base import make_frame
from planarkin.functions.expr import ExprError, parse
from ..measures.extremes import extreme, hermite


def _text(node):
    v = node.value
    return v if isinstance(v, str) else float(v)


# A file's texts and their symbolic derivatives do not change between the designs of a study or
# a synthesis (only the parameter values do), so each text is parsed and differentiated once per
# process rather than at every Jacobian. Bounded: a free parameter's text is its float value,
# new for every design. Expressions are immutable, so sharing one between callers is safe.
@lru_cache(maxsize=4096)
def _parsed(text, names: tuple, allow_t: bool = False):
    return parse(text, names, allow_t)


@lru_cache(maxsize=4096)
def _derivative(text, names: tuple, allow_t: bool, var: str):
    return _parsed(text, names, allow_t).diff(var)


class ParameterDerivatives:
    """d(number)/d(parameter) for every number of a model file, exact (symbolic chain rule).

    root: the file's node tree; values: the parameters' values as evaluated (with overrides);
    texts: parameter -> text used (an override's text replaces the file's)."""

    def __init__(self, root, values: dict, texts: dict, wrt: list[str]):
        self.values = dict(values)
        self.wrt = list(wrt)
        self._numbers: dict = {}        # id(node) -> number(node) (the nodes live in root)
        self.order = tuple(values)
        # dparam[k][p]: derivative of parameter k with respect to p, in file order
        self.dparam: dict[str, np.ndarray] = {}
        for k, name in enumerate(self.order):
            g = np.array([1.0 if name == p else 0.0 for p in self.wrt])
            if name not in self.wrt:
                g = self._chain(texts[name], self.order[:k])
            else:
                _parsed(texts[name], self.order[:k])      # refuses a bad text all the same
            self.dparam[name] = g

    def _chain(self, text, names: tuple) -> np.ndarray:
        """Gradient of an expression with respect to wrt, through the parameters it uses (in
        the file's order: a set's order changes with each process's string hashes, and the
        sum of the terms with their order)."""
        g = np.zeros(len(self.wrt))
        used = _parsed(text, names).names
        for name in [n for n in names if n in used]:
            if name in self.dparam and self.dparam[name].any():
                d = _derivative(text, names, False, name)
                g = g + np.asarray(d.evaluate(self.values)) * self.dparam[name]
        return g

    def number(self, node) -> np.ndarray:
        """(len(wrt),) derivative of one scalar node of the file (kept: asked again by
        `depends` and by each user of the same design's derivatives)."""
        got = self._numbers.get(id(node))
        if got is None:
            got = self._numbers[id(node)] = self._chain(_text(node), self.order)
            got.setflags(write=False)
        return got

    def function(self, node, t: np.ndarray) -> np.ndarray:
        """(N, len(wrt)) derivative of a driver function f(t) with respect to wrt."""
        text = _text(node)
        e = _parsed(text, self.order, True)
        out = np.zeros((len(t), len(self.wrt)))
        env = {**self.values, "t": t}
        for name in [n for n in self.order if n in e.names]:     # (the file's order)
            if name in self.dparam and self.dparam[name].any():
                d = _derivative(text, self.order, True, name)
                out += np.broadcast_to(d.evaluate(env), t.shape)[:, None] * self.dparam[name]
        return out

    def depends(self, node) -> bool:
        if node is None:
            return False
        if node.kind == "seq":
            return any(self.depends(n) for n in node.value)
        if node.kind == "map":
            return any(self.depends(n) for n in node.value.values())
        if node.value is None or isinstance(node.value, bool):
            return False
        return bool(self.number(node).any())


_LAST: list = [None, None, None]       # root, key, ParameterDerivatives (see derivatives)


def derivatives(root, values: dict, texts: dict, wrt: list[str]) -> ParameterDerivatives:
    """ParameterDerivatives(root, values, texts, wrt), the last one again for the same file
    tree and arguments: a synthesis Jacobian asks for the same design's up to three times (the
    sensitivities, the times of prescribed inputs, the turns barrier). It is not changed
    after it is built."""
    key = (tuple(values.items()), tuple(texts.items()), tuple(wrt))
    if _LAST[0] is not root or _LAST[1] != key:
        _LAST[:] = [root, key, ParameterDerivatives(root, values, texts, wrt)]
    return _LAST[2]


def body_form_only(root, file: str, who: str, instead: str = "") -> None:
    """Refuse a model in the sketch form (links:) at its links: line: every point there is a
    global placement at:, which enters the compiled body frames nonlinearly and which the
    sensitivities do not differentiate. who: what needs the body form; instead: the message's
    end (another command that serves)."""
    links = root.value.get("links")
    if links is not None:
        raise InputError([Diagnostic(str(file), root.key_lines.get("links", links.line), (
            f"{who} need the body form (bodies:, joints:): in the sketch form (links:) every "
            f"point is a global placement at:, which the sensitivities do not differentiate; "
            f"write the model with bodies and joints (as mechanisms/four-bar.yaml){instead}"))])


def sensitivities(cm, root, texts: dict, wrt: list[str], t: np.ndarray, q: np.ndarray):
    """Exact dq/dp of the body coordinates and dP/dp of the points at the grid times.

    cm: the compiled model (nominal); root: its file's node tree; texts: the parameter texts
    used; wrt: parameter names; t: (N,) s; q: (N, n) body coordinates in user units (a Result's
    q). Returns (dq (N, n, k), dp (N, P, 2, k)), user units per unit of each parameter.
    Raises InputError naming the element where a parameter enters in a way not differentiated.
    """
    spec = cm.spec
    body_form_only(root, spec.file, "first-order sensitivities", ", or use planarkin sweep")
    D = derivatives(root, spec.parameters, texts, wrt)
    k = len(wrt)
    N = len(t)
    L, af = cm.L, cm.angle_factor
    Q = np.array(q, dtype=float)
    Q[:, 0::3] /= L
    Q[:, 1::3] /= L
    Q[:, 2::3] *= af
    Qe = np.concatenate([Q, np.zeros((N, 3))], axis=1)
    F = make_frame(Qe)
    n, m = cm.n, cm.m
    J = np.zeros((N, m, n + 3))
    Phi_p = np.zeros((N, m, k))
    problems = []
    sections = {"joint": root.value.get("joints"), "driver": root.value.get("drivers")}
    grads = {}                                        # id(group) -> (N, K, neq, 3 nbody)
    for g in cm.groups:
        grad = grads[id(g)] = g.grad(F)
        J[:, g.rows[:, :, None], g.cols[:, None, :]] += grad
    # Phi_p element by element (an element's rows are consecutive; its bodies from the group)
    where = {}
    for g in cm.groups:
        for kk in range(len(g)):
            where[int(g.rows[kk][0])] = (g, kk)
    for r0, (g, kk) in where.items():
        el = cm.element_of_row(r0)
        kind = KINDS[el.kind]
        node = sections[el.role].value[el.index - 1]
        keys = node.value
        rows = g.rows[kk]
        if D.depends(keys.get("at")) or D.depends(keys.get("axis")):
            problems.append((el, "at", "its global placement"))
            continue
        grad = None
        for p in kind.params:
            pn = keys.get(p.name)
            try:
                if pn is None or not D.depends(pn):
                    continue
            except ExprError:       # a law of the kind's own variable (a cam's theta): refused
                problems.append((el, p.name, f"its {p.name}"))      # below, by name
                continue
            if p.unit == "point" and p.name in ("si", "sj"):
                if grad is None:
                    grad = grads[id(g)][:, kk]        # (N, neq, 3 nbody)
                side = 0 if p.name == "si" else 1
                b = g.bodies[kk, side]
                ds = np.stack([D.number(pn.value[0]), D.number(pn.value[1])]) / L   # (2, k)
                c, s = F.c[:, b], F.s[:, b]
                Ads = np.stack([c[:, None] * ds[0] - s[:, None] * ds[1],
                                s[:, None] * ds[0] + c[:, None] * ds[1]], axis=1)  # (N, 2, k)
                Phi_p[:, rows, :] += np.einsum("nex,nxk->nek", grad[:, :, 3 * side:3 * side + 2],
                                               Ads)
            else:
                problems.append((el, p.name, f"its {p.name}"))
        # a joint's constant (c of angle, distance, x, y, pin-slot, slide) is the kind's target,
        # not one of its params: its equation's first row is g - c
        cn = keys.get(kind.target) if kind.target else None
        if el.role == "joint" and cn is not None and D.depends(cn):
            scale = {"length": 1.0 / L, "angle": af, None: 1.0}[kind.target_unit]
            Phi_p[:, rows[0], :] -= scale * D.number(cn)
        if el.role == "driver" and "f" in keys:
            scale = {"length": 1.0 / L, "angle": af, None: 1.0}[kind.target_unit]
            Phi_p[:, rows[0], :] -= scale * D.function(keys["f"], t)
    if problems:
        raise InputError([Diagnostic(spec.file, el.param_lines.get(key, el.line),
                                     f"{el.label}: parameters {', '.join(wrt)} reach {what}; "
                                     f"sensitivities are computed for parameters that enter "
                                     f"points si/sj, constants c and driver functions f")
                          for el, key, what in problems])
    Jq = J[:, :, :n]
    if m == n:
        dq = -np.linalg.solve(Jq, Phi_p)
    else:       # consistent redundant rows: the least-squares solution is the exact one
        dq = np.stack([-np.linalg.lstsq(Jq[i], Phi_p[i], rcond=None)[0] for i in range(N)])
    # points: P = r_b + A_b s'
    pts = spec.points
    dP = np.zeros((N, len(pts), 2, k))
    for j, ps in enumerate(pts):
        b = int(cm.point_body[j])
        s0 = cm.point_s[j]
        c, s = F.c[:, b], F.s[:, b]
        dphi = dq[:, 3 * b + 2, :]
        # d(A s')/dphi = R A s'
        ax, ay = c * s0[0] - s * s0[1], s * s0[0] + c * s0[1]
        dP[:, j, 0] = dq[:, 3 * b] - ay[:, None] * dphi
        dP[:, j, 1] = dq[:, 3 * b + 1] + ax[:, None] * dphi
        pnode = root.value["points"].value[ps.name]
        sn = pnode.value.get("s")
        if D.depends(pnode.value.get("at")):
            raise InputError([Diagnostic(spec.file, ps.line, f"point '{ps.name}': parameters "
                                         f"reach its global placement at; give s instead")])
        if sn is not None and D.depends(sn):
            ds = np.stack([D.number(sn.value[0]), D.number(sn.value[1])]) / L
            dP[:, j, 0] += c[:, None] * ds[0] - s[:, None] * ds[1]
            dP[:, j, 1] += s[:, None] * ds[0] + c[:, None] * ds[1]
    dq_user = dq.copy()
    dq_user[:, 0::3] *= L
    dq_user[:, 1::3] *= L
    dq_user[:, 2::3] /= af
    return dq_user, dP * L


def pose_at(res, times) -> np.ndarray:
    """(K, n) body coordinates of a Result at times (K,) within its grid (user units): the rows
    themselves at grid times, between rows the quintic Hermite of the two rows' exact q, q' and
    q'' (planarkin.measures.extremes.hermite, O(h^6) of the grid step; cubic without q'')."""
    t = res.t
    times = np.asarray(times, dtype=float)
    j = np.clip(np.searchsorted(t, times, side="right") - 1, 0, max(len(t) - 2, 0))
    if len(t) < 2 or res.qd is None:
        return res.q[np.clip(np.searchsorted(t, times), 0, len(t) - 1)]
    h = (t[j + 1] - t[j])[:, None]
    s = (times[:, None] - t[j][:, None]) / h
    acc = (lambda k: res.qdd[k]) if res.qdd is not None else \
        (lambda k: np.full_like(res.q[k], np.nan))
    out = hermite(s, h, res.q[j], res.qd[j], acc(j), res.q[j + 1], res.qd[j + 1], acc(j + 1))
    at = times == t[j]
    out[at] = res.q[j[at]]
    at = times == t[j + 1]
    out[at] = res.q[j[at] + 1]
    return out


def metric_gradients(study, res, names: list[str]) -> np.ndarray:
    """(metrics, parameters) exact d(metric)/dp at the nominal Result res, for the max, min,
    stroke and absmax of a position column (x, y, phi of a body, x, y of a point); nan for the
    others. A metric is its column's refined extreme (planarkin.measures.extremes.extreme, as
    the metric itself): there the column's rate is zero, so its derivative is the column's
    sensitivity at the extreme's time, from the sensitivity equations Phi_q dq/dp = -Phi_p
    (`sensitivities`) solved at that time and the pose interpolated there (`pose_at`)."""
    cm = study.nominal
    G = np.full((len(study.metrics), len(names)), np.nan)
    need = []          # (metric, time, sign, column kind, index, component)
    for i, m in enumerate(study.metrics):
        if not m.position:
            continue
        name, q = m.column.rsplit(".", 1)
        if m.source == "bodies.csv":
            k = 3 * cm.body_names.index(name) + ("x", "y", "phi").index(q)
            cols = [a[:, k] if a is not None else None for a in (res.q, res.qd, res.qdd)]
            where = ("q", k, 0)
        else:
            j, c = cm.point_names.index(name), ("x", "y").index(q)
            cols = [a[:, j, c] if a is not None else None for a in (res.p, res.pd, res.pdd)]
            where = ("p", j, c)
        if len(res.t) == 0:
            continue
        (th, yh), (tl, yl) = (extreme(res.t, *cols, sense) for sense in (1.0, -1.0))
        picks = {"max": [(th, 1.0)], "min": [(tl, 1.0)], "stroke": [(th, 1.0), (tl, -1.0)],
                 "absmax": [(th, 1.0)] if yh >= -yl else [(tl, -1.0)]}[m.kind]
        need += [(i, float(tt), sg) + where for tt, sg in picks]
    if not need:
        return G
    times = np.array(sorted({n[1] for n in need}))
    dq, dP = sensitivities(cm, study.root, study.texts(), names, times, pose_at(res, times))
    G[[n[0] for n in need]] = 0.0
    for i, tt, sg, kind, k, c in need:
        r = int(np.searchsorted(times, tt))
        G[i] += sg * (dq[r, k] if kind == "q" else dP[r, k, c])
    return G
