"""Variants solved together: variant x time as the batch dimension of the grid pass.

The variants of a study share their structure: the same block-triangular form, the same
kinds with other numbers. Here the element groups of the nominal model are given per-row
parameters (one row per variant and grid time), so `System.solve_batch` -- the grid pass's
block-by-block Newton, velocity and acceleration solve -- solves many variants at every grid time
in one call, and nothing is validated, compiled or assembled per variant: the numbers that
depend on the varied parameters are evaluated from the file's expressions for all variants at
once, in the nominal model's internal units.

Each variant is predicted from its predecessor in its chain (studies.warm.chains): along a
repeated parameter step by the cubic (quadratic, secant) through the previous solutions, otherwise
(a chain's head, from the nominal; a factorial's next row) to first order with the nominal's
exact sensitivities dq/dp (studies.sensitivity); a parameter step that fails is retried in
equal substeps. For a study large enough (`job_points`: variants x grid times, at least
kernel.COMPILED_FROM_POINTS) the solve is the compiled route's where it covers the
system (planarkin.solver.compiled.kernel, planarkin.solver.compiled.gen_each: each row a point with its variant's
element parameters, Newton to its own convergence block by block, the acceptance tests below and the
cubic prediction in the same pass), else, and as the reference (PLANARKIN_KERNEL=0), the grid
pass's own solve (System.solve_batch) over all variants x grid times at once, its element groups
reading per-row parameters (Batch.system). A variant is accepted only if every grid point
passes the tests the path follower applies to a step: Newton converged, its first correction
at most KAPPA of the smallest singular value, finite velocities and accelerations, condition
below COND_WARN, the determinant sign of every fine block equal to the predecessor's at the same
time (the same assembly branch), and between consecutive grid times the Taylor
predictor error, forwards and backwards, within path_tol (the grid is a path the follower would
have accepted). A variant that fails, and every variant of a study this does not apply to, is
solved by the ordinary per-variant path (`Study.solve`). Chains are solved in lockstep in fixed
groups of GROUP chains, so the result of a variant does not depend on how the groups are spread
over processes: parallel runs equal the serial run bit for bit.

Applies when the varied parameters reach only body-frame points (si, sj), joint constants, other
scalar keys of the kinds except gear radii, driver functions and the points' s; not through
directions, gear radii or global placements (at), nor through the parameters or the bodies'
poses of an element whose kind prepares constants from them at compile time (a slide's
parallel constant, a mesh's phase, a belt's, a cam's rest) or checks them at validation or
assembly (radii, pulleys that overlap); not with redundant constraints, derived
tables among the metrics, or rows a room checks (forces, a cam's range: those variants take
`run`'s refusal of rows, analysis.refuse, one by one). Variants follow the nominal's assembly
branch. Every variant's drivers pass `run`'s check before a run (budget.preflight) or the
variant is solved by the per-variant path, which refuses it as `run` does.
"""

from __future__ import annotations


from dataclasses import replace

import numpy as np

from ..elements import KINDS
from ..elements.base import Group, Kind
from ..model.validate import MAX_MAGNITUDE
from planarkin.functions.expr import TimeFunction, parse
from planarkin.solver.acceptance import COND_WARN, accepted, path_errors
from .lockstep import Lockstep
from .outcome import Outcome

GROUP = 16          # chains solved in lockstep (fixed: results do not depend on --jobs)


class RowParam(np.ndarray):
    """(R, K, 2) per-row 2-vectors that the element code reads as it reads (K, 2) arrays:
    p[:, i] gives the (R, K) array of component i."""

    def __getitem__(self, key):
        if isinstance(key, tuple) and len(key) == 2 and key[0] == slice(None) \
                and isinstance(key[1], (int, np.integer)):
            return np.asarray(self)[..., key[1]]
        raise TypeError("per-row parameters are read as p[:, i] only")


class VariantDriver:
    """A driver function f(t) of one variant (its parameter values), user units, as
    budget.preflight reads a model's driver functions."""

    is_constant = False

    def __init__(self, expr, values: dict):
        self.expr, self.values = expr, values

    def __call__(self, t):
        return self.expr.evaluate({**self.values, "t": np.asarray(t, dtype=float)})


class Unsupported(Exception):
    """The study cannot be batched (the message says why); it runs variant by variant."""


def _text(node):
    v = node.value
    return v if isinstance(v, str) else float(v)


def _written(text) -> set:
    """Every name written in an expression's text (also those its simplification drops); none
    in a text that does not parse as Python (a label)."""
    import ast
    if not isinstance(text, str):
        return set()
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except Exception:  # noqa: BLE001 - not an expression
        return set()
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}


def _valid(v) -> np.ndarray:
    """Where numbers v pass the validator's test of every number of a file: finite and at most
    MAX_MAGNITUDE in magnitude."""
    with np.errstate(invalid="ignore"):
        return np.abs(v) <= MAX_MAGNITUDE


def _checked(kind, reached: list, posed: bool) -> bool:
    """Whether varied parameters that reach the kind's params `reached` (and its bodies' poses
    when posed) reach numbers it prepares constants from at compile time (Kind.prepare) or
    checks at assembly (Kind.check_pose), or numbers other than its points that it checks at
    validation or compile time (Kind.validate, Kind.diagnose; a distance's positive constant is
    checked by numbers())."""
    own = type(kind)
    if own.prepare is not Kind.prepare or own.check_pose is not Kind.check_pose:
        return bool(reached) or posed
    return (own.validate is not Kind.validate or own.diagnose is not Kind.diagnose) and \
        not kind.positive_target and \
        any(p.unit != "point" for p in reached)


class Batch:
    """The batched form of a Study for a set of varied parameter names."""

    def __init__(self, study, varied, nominal: bool = True):
        """nominal: solve the nominal model on the grid (the chains' first predictions,
        Lockstep); False for a caller that starts every variant from its own pose
        (planarkin.synthesis.starts)."""
        from planarkin.solver.assembly import assemble
        cm = self.cm = study.nominal
        self.study = study
        spec = cm.spec
        root = study.root
        self.varied = list(varied)
        if any(m.source not in ("bodies.csv", "points.csv") for m in study.metrics):
            raise Unsupported("a metric reads a derived table")
        if study.opts.interpolate:
            raise Unsupported("interpolate: true")
        from ..derived import row_checks
        if row_checks(cm, study.opts):
            # a room refuses rows by the variant's own model (a non-finite force, a cam past
            # its law): each variant takes `run`'s refusal of rows (analysis.refuse)
            raise Unsupported("a room checks the rows (forces, a cam's range)")
        texts = study.texts()
        self.order = list(spec.parameters)
        self.pexpr = {k: parse(texts[k], self.order[:i]) for i, k in enumerate(self.order)}
        dep = self.dep = set(self.varied)
        for k in self.order:
            if k not in dep and self._uses(texts[k], self.pexpr[k]):
                dep.add(k)
        self.L, self.af = cm.L, cm.angle_factor
        uses = lambda node: node is not None and self._depends(node)
        A = assemble(cm)
        if A.redundant_rows:
            raise Unsupported("redundant constraints")
        self.S = A.system
        if uses(root.value.get("analysis")):
            raise Unsupported("a varied parameter reaches the analysis settings")
        sections = {"joint": root.value.get("joints"), "driver": root.value.get("drivers")}
        # per group, per parameter: the (instance, component, Expr, scale) that vary
        self.gvar = []
        self.tvar = []          # (row, Expr, scale, must be positive): joint constants
        self.fvar = []          # (row, Expr f, scale): driver functions
        # for design(): the texts of what the varied parameters reach, and what else they reach
        self.texts = texts
        self.ttext = []         # (row, text, unit, must be positive): joint constants
        self.ftext = []         # (row, element index, text): driver functions
        self.sized = set()      # length_sizes' sources the varied parameters reach
        self.elsewhere = [k for k, node in root.value.items()
                          if k not in ("name", "units", "output", "parameters", "bodies",
                                       "joints", "drivers", "points")
                          and self._reaches(node)]
        bodies = root.value.get("bodies")
        body_q = {name: node.value.get("q") for name, node in bodies.value.items()} \
            if bodies is not None and bodies.kind == "map" else {}
        for gi, G in enumerate(cm.groups):
            entries = []
            for k in range(len(G)):
                el = cm.element_of_row(int(G.rows[k, 0]))
                e_idx = int(cm.row_element[int(G.rows[k, 0])])
                kind = KINDS[el.kind]
                keys = sections[el.role].value[el.index - 1].value
                known = {p.name for p in kind.params} | {kind.target, "f", "type", "i", "j"}
                self.elsewhere += [f"{el.label}: {key}" for key, node in keys.items()
                                   if key not in known and self._reaches(node)]
                if uses(keys.get("at")) or uses(keys.get("axis")):
                    raise Unsupported(f"{el.label}: a varied parameter reaches 'at'")
                if el.at is not None and any(uses(body_q.get(b)) for b in el.bodies):
                    # a global placement is turned into body-frame points (and a distance's
                    # constant) at the bodies' drawn poses
                    raise Unsupported(f"{el.label}: a varied parameter reaches the pose of a "
                                      f"body it is placed on with 'at'")
                if _checked(kind, [p for p in kind.params if uses(keys.get(p.name))],
                            any(uses(body_q.get(b)) for b in el.bodies)):
                    # the kind prepares constants at compile time from its parameters and its
                    # bodies' poses (a mesh's phase, a belt's, a cam's rest), or checks them
                    # at validation or assembly (radii, pulleys that overlap): the batch would
                    # keep the nominal's constants and skip the checks
                    raise Unsupported(f"{el.label}: a varied parameter reaches numbers its "
                                      f"kind prepares or checks at compile time")
                # a joint's constant (c of angle, distance, x, y, pin-slot, slide) is the
                # kind's target, not one of its params: its equation's first row is g - c
                if el.role == "joint" and kind.target and uses(keys.get(kind.target)):
                    scale = {"length": 1 / self.L, "angle": self.af, None: 1.0}[kind.target_unit]
                    self.tvar.append((int(G.rows[k, 0]), self._expr(keys[kind.target]), scale,
                                      kind.positive_target))
                    self.ttext.append((int(G.rows[k, 0]), _text(keys[kind.target]),
                                       kind.target_unit, kind.positive_target))
                    self.sized.add(("target", e_idx))
                for p in kind.params:
                    node = keys.get(p.name)
                    if not uses(node):
                        continue
                    if p.unit in ("point", "length"):
                        self.sized.add(("param", e_idx, p.name))
                    if p.unit == "point":
                        for c in range(2):
                            entries.append((p.name, k, c, self._expr(node.value[c]),
                                            1 / self.L, _text(node.value[c])))
                    elif p.unit in ("length", "angle", "real") and el.kind != "gear":
                        scale = {"length": 1 / self.L, "angle": self.af, "real": 1.0}[p.unit]
                        entries.append((p.name, k, None, self._expr(node), scale, _text(node)))
                    else:
                        raise Unsupported(f"{el.label}: a varied parameter reaches {p.name}")
                if el.role == "driver" and self._depends_t(keys.get("f")):
                    scale = {"length": 1 / self.L, "angle": self.af, None: 1.0}[kind.target_unit]
                    f = parse(_text(keys["f"]), self.order, allow_t=True)
                    self.fvar.append((int(G.rows[k, 0]), (f, f.diff("t"), f.diff("t").diff("t")),
                                      scale))
                    self.ftext.append((int(G.rows[k, 0]), e_idx, _text(keys["f"])))
            self.gvar.append(entries)
        self._points_and_bodies(root, spec, uses, bodies, body_q)
        # where each part of each solve block comes from: (group, instance indices)
        first = {}
        for gi, G in enumerate(cm.groups):
            for k in range(len(G)):
                first[int(G.rows[k, 0])] = (gi, k)
        self.part_src = [[(first[int(p.group.rows[0, 0])][0],
                           np.array([first[int(r)][1] for r in p.group.rows[:, 0]]))
                          for p in B.parts] for B in self.S.blocks]
        self.grid = study.opts.grid
        if nominal:
            self.nominal_solution()

    def _points_and_bodies(self, root, spec, uses, bodies, body_q) -> None:
        """The points' offsets (svar, stext) and the bodies' pose estimates (qvar) the varied
        parameters reach, and what else of theirs they reach (elsewhere)."""
        cm = self.cm
        self.svar = []
        self.stext = []         # (point, text of x, text of y)
        pts = root.value.get("points")
        for j, ps in enumerate(spec.points):
            pn = pts.value[ps.name].value
            if uses(pn.get("at")) or (ps.at is not None and uses(body_q.get(ps.body))):
                raise Unsupported(f"point '{ps.name}': a varied parameter reaches 'at' or the "
                                  f"pose of the body it is placed on")
            if uses(pn.get("s")):
                self.svar.append((j, self._expr(pn["s"].value[0]), self._expr(pn["s"].value[1])))
                self.stext.append((j, _text(pn["s"].value[0]), _text(pn["s"].value[1])))
                self.sized.add(("point", j))
            self.elsewhere += [f"point '{ps.name}': {key}" for key, node in pn.items()
                               if key not in ("s", "body") and self._reaches(node)]
        # the bodies' pose estimates the varied parameters reach: (body, coordinate, Expr, text)
        self.qvar = []
        for b, name in enumerate(cm.body_names):
            bn = bodies.value[name].value if name in body_q else {}
            self.elsewhere += [f"body '{name}': {key}" for key, node in bn.items()
                               if key != "q" and self._reaches(node)]
            qn = body_q.get(name)
            if qn is not None and qn.kind == "seq" and uses(qn):
                self.qvar += [(b, c, self._expr(qn.value[c]), _text(qn.value[c]))
                              for c in range(3) if uses(qn.value[c])]

    def _uses(self, text, expr) -> bool:
        """Whether a varied parameter is written in text (parsed as expr). Unsupported when its
        simplification drops one (0*sqrt(a), a/a): the validator evaluates the text as
        written, and a varied value can make it invalid that the simplified expression would
        not show."""
        written = _written(text) & self.dep
        if written - expr.names:
            raise Unsupported(f"{text!r}: a varied parameter that its simplification drops")
        return bool(written)

    def _depends_t(self, node) -> bool:
        """_depends for a driver's f, a function of t: whether a varied parameter reaches it."""
        if node is not None and node.kind not in ("seq", "map") and isinstance(node.value, str):
            try:
                expr = parse(node.value, self.order, allow_t=True)
            except Exception:  # noqa: BLE001 - the validator has reported it for the nominal
                return True
            return self._uses(node.value, expr)
        return node is not None and self._depends(node)

    def _reaches(self, node) -> bool:
        """Whether a varied parameter reaches a number under node (a text that is not an
        expression of the parameters, a name or a label, reaches none)."""
        if node.kind == "seq":
            return any(self._reaches(n) for n in node.value)
        if node.kind == "map":
            return any(self._reaches(n) for n in node.value.values())
        return isinstance(node.value, str) and bool(_written(node.value) & self.dep)

    def _expr(self, node):
        return parse(_text(node), self.order)

    def _depends(self, node) -> bool:
        if node.kind == "seq":
            return any(self._depends(n) for n in node.value)
        if node.kind == "map":
            return any(self._depends(n) for n in node.value.values())
        if node.value is None or isinstance(node.value, bool) or not isinstance(
                node.value, (str, int, float)):
            return False
        try:
            expr = parse(_text(node), self.order)
        except Exception:  # noqa: BLE001 - the validator has reported it for the nominal
            return True
        return self._uses(_text(node), expr)

    # -- numbers of many variants at once ------------------------------------------------------
    def numbers(self, values: list[dict]):
        """Per-variant arrays (internal units) of everything the varied parameters reach, and
        ok (Vn,): the variants whose numbers pass the validator's checks (every number finite
        and at most MAX_MAGNITUDE, a distance's constant positive) and whose drivers pass
        preflight; a variant that fails is left to the per-variant path, which refuses it with
        the validator's message."""
        Vn = len(values)
        env = {}
        for k in self.order:
            if k in self.varied:
                env[k] = np.array([v[k] for v in values], dtype=float)
            else:
                env[k] = np.broadcast_to(np.asarray(self.pexpr[k].evaluate(env), float),
                                         (Vn,)).copy()
        ok = self.preflight(env, Vn)
        for k in self.dep:
            ok &= _valid(env[k])
        groups = []
        for G, entries in zip(self.cm.groups, self.gvar):
            params = {name: np.repeat(arr[None], Vn, axis=0) for name, arr in G.params.items()}
            for name, k, c, e, scale, _ in entries:
                v = np.broadcast_to(e.evaluate(env), (Vn,))
                ok &= _valid(v)
                if c is None:
                    params[name][:, k] = v * scale
                else:
                    params[name][:, k, c] = v * scale
            groups.append(params)
        targets = np.repeat(self.cm.targets[None], Vn, axis=0)
        for r, e, scale, must_be_positive in self.tvar:
            v = np.broadcast_to(e.evaluate(env), (Vn,))
            ok &= _valid(v) & ((v > 0) if must_be_positive else True)
            targets[:, r] = v * scale
        s = np.repeat(self.cm.point_s[None], Vn, axis=0)
        for j, ex, ey in self.svar:
            for c, e in enumerate((ex, ey)):
                v = np.broadcast_to(e.evaluate(env), (Vn,))
                ok &= _valid(v)
                s[:, j, c] = v / self.L
        for _, _, e, _ in self.qvar:            # pose estimates: checked, not used here
            ok &= _valid(np.broadcast_to(e.evaluate(env), (Vn,)))
        return groups, targets, s, env, ok

    def preflight(self, env, Vn: int) -> np.ndarray:
        """(Vn,) the variants (parameters env) whose drivers pass `run`'s check before a run
        (budget.preflight: finite over the time range, within the node budget, resolvable to
        the solver's tolerance), each with its own driver functions where a varied parameter
        reaches them; every variant where none does (the nominal's check holds for all).
        A variant that fails is left to the per-variant path, which refuses it as `run` does."""
        ok = np.ones(Vn, dtype=bool)
        if not self.fvar:
            return ok
        from planarkin.solver.budget import preflight
        cm = self.cm
        where = {int(r): i for i, r in enumerate(cm.driver_rows)}
        o, a = self.study.opts, cm.spec.analysis
        for v in range(Vn):
            funcs = list(cm.driver_funcs)
            values = {k: float(x[v]) for k, x in env.items()}
            for r, (f, _, _), _ in self.fvar:
                funcs[where[r]] = VariantDriver(f, values)
            ok[v] = preflight(replace(cm, driver_funcs=tuple(funcs)), o) is None and \
                all(TimeFunction.checked(text, values, ((a.start, a.end), (o.start, o.end)))
                    is not None for _, _, text in self.ftext)
        return ok



    # -- one design from the arrays ------------------------------------------------------------
    def design(self, values: dict):
        """The compiled model of one design from the nominal's arrays, or None
        (planarkin.studies.design.design)."""
        from .design import design
        return design(self, values)

    def drivers(self, targets, env, t=None):
        """(Vn, T, m) targets, nu and f'' on the grid (or at times t, (T,))."""
        Vn = targets.shape[0]
        if t is not None:
            base = self.S.driver_values(t)
        else:
            t = self.grid
            if not hasattr(self, "_base"):
                self._base = self.S.driver_values(t)
            base = self._base
        T = targets[:, None, :] + (base[0] - self.cm.targets)[None]
        NU = np.repeat(base[1][None], Vn, axis=0)
        FDD = np.repeat(base[2][None], Vn, axis=0)
        penv = {k: v[:, None] for k, v in env.items()}
        penv["t"] = t[None, :]
        with np.errstate(all="ignore"):
            for r, (f, f1, f2), scale in self.fvar:
                T[:, :, r] = targets[:, None, r] + scale * np.broadcast_to(f.evaluate(penv),
                                                                           (Vn, len(t)))
                NU[:, :, r] = scale * np.broadcast_to(f1.evaluate(penv), (Vn, len(t)))
                FDD[:, :, r] = scale * np.broadcast_to(f2.evaluate(penv), (Vn, len(t)))
        return T, NU, FDD

    # -- solving -------------------------------------------------------------------------------
    def system(self, groups):
        """A copy of the nominal System whose element groups read per-row parameters."""
        import copy
        S = copy.copy(self.S)
        blocks = []
        for B, src in zip(self.S.blocks, self.part_src):
            parts = []
            for p, (gi, idx) in zip(B.parts, src):
                g0 = p.group
                params = {}
                for name, arr in groups[gi].items():
                    sub = arr[:, idx]
                    params[name] = sub.view(RowParam) if sub.ndim == 3 else sub
                parts.append(replace(p, group=Group(g0.kind, g0.bodies, g0.cols, params,
                                                    g0.rows)))
            blocks.append(replace(B, parts=tuple(parts)))
        S.blocks = tuple(blocks)
        return S

    def take(self, num, idx):
        """Variants idx (an index array) of numbers()' arrays: the same numbers (numbers()
        works element by element), without evaluating the file's expressions again."""
        groups, targets, s, env, ok = num
        return ([{k: a[idx] for k, a in g.items()} for g in groups], targets[idx], s[idx],
                {k: v[idx] for k, v in env.items()}, ok[idx])

    def solve(self, values, Q, Qd, Qdd, sign, num=None, hist=None, k=False, work=None,
              out=None):
        """Solve variants (dicts) from predictions Q, Qd, Qdd (Vn, T, n + 3) whose fine-block
        signs are sign (Vn, T, nfine); Qd, Qdd are not read (every route solves the velocities
        and accelerations afresh: None will do). num: their numbers()
        when known (values is then not read). hist (the kernel's route only): the last four
        solutions (Vn, T, n + 3) each and a flag per row: the predictions of the rows flagged
        are the cubic through the four, the others Q's rows (Q is not written).
        k: self.kernel() when the caller has it. work, out: kernel.solve_rows' (buffers of
        the kernel's results: the sign returned is then valid until the next call with work).
        Returns (Q, Qd, Qdd, sign, ok (Vn,), s (Vn, P, 2))."""
        Vn, T = Q.shape[0], Q.shape[1]
        groups, targets, s, env, ok = self.numbers(values) if num is None else num
        n3 = Q.shape[2]
        o = self.study.opts
        if k is False:
            k = self.kernel()
        if k is not None:
            Qr, Qdr, Qddr, info, good, perr = self.solve_kernel(k, groups, targets, env, Q, sign,
                                                                hist, work, out)
            with np.errstate(invalid="ignore"):
                ok &= good.reshape(Vn, T).all(axis=1) & (perr.reshape(Vn, T)
                                                         <= o.path_tol).all(axis=1)
            return (*(a.reshape(Vn, T, n3) for a in (Qr, Qdr, Qddr)),
                    info.sign.reshape(Vn, T, -1), ok, s)
        TT, NU, FDD = self.drivers(targets, env)
        Qr = Q.reshape(Vn * T, n3).copy()
        Qdr, Qddr = np.zeros_like(Qr), np.zeros_like(Qr)      # solved afresh
        drivers = tuple(a.reshape(Vn * T, -1) for a in (TT, NU, FDD))
        # full Newton: from a neighbour's solution the chord iteration converges only
        # linearly, and its last correction below tol would leave ~1e-13 in the results
        S = self.system([{k: np.repeat(v, T, axis=0) for k, v in g.items()} for g in groups])
        info = S.solve_batch(np.tile(self.grid, Vn), Qr, Qdr, Qddr, policy="full", tol=o.tol,
                             maxit=max(o.iterations, 8), order=2, drivers=drivers)
        return self.accept(Qr, Qdr, Qddr, info, sign, ok, s)

    def kernel(self):
        """(library, packed system) of the compiled route (planarkin.solver.compiled.kernel) when the study is
        large enough (job_points, set by Study.units: variants x grid times; kernel.route) and the
        route covers the system, else None: the numpy reference, System.solve_batch
        (PLANARKIN_KERNEL read per call)."""
        from planarkin.solver.compiled import kernel
        lib = kernel.route(getattr(self, "job_points", 0), "study")
        if lib is None:
            return None
        if not hasattr(self, "_kpack"):
            self._kpack = kernel.pack(self.S)
            if self._kpack is not None:
                # the solve this structure takes, compiled or loaded now (before any worker
                # forks)
                from planarkin.solver.compiled import kernels as compiled_grid
                compiled_grid.function_each(self._kpack, self.S.cm.n + 3, self.S.cm.m,
                                            self.S.nb)
        return None if self._kpack is None else (lib, self._kpack)

    def solve_kernel(self, k, groups, targets, env, Q, sign, hist=None, work=None, out=None):
        """The batch solve by the kernel (kernel.solve_rows): every (variant, time) row a
        point, its variant's element parameters one row of a (Vn, E, 8) table, its drivers'
        the grid time's row where no varied parameter reaches them; with the acceptance tests
        of every row (those of `accept`, against the predecessors' signs sign) and the path
        errors. Returns (Q, Qd, Qdd) (Vn T, n + 3), the diagnostics, good (Vn T,) and the path
        errors (Vn T,) (each row's interval from the row before, 0 for a variant's first).
        hist, work, out: as for solve."""
        from planarkin.solver.compiled import kernel
        from planarkin.solver.system import BatchInfo
        Vn, T, n3 = Q.shape
        o = self.study.opts
        Qr = Q.reshape(Vn * T, n3)
        if hist is None:
            Qr = Qr.copy()
        else:
            hist = [h.reshape(Vn * T, n3) for h in hist[:4]] + [hist[4]]
        table = kernel.table(self.cm, groups)
        # per batch size: each row's variant, grid time (row of the driver tables) and time
        cache = self.__dict__.setdefault("_rowcache", {})
        if Vn not in cache:
            cache[Vn] = (np.repeat(np.arange(Vn, dtype=np.int32), T),
                         np.tile(np.arange(T, dtype=np.int32), Vn), np.tile(self.grid, Vn))
        rows, trow, tg = cache[Vn]
        if self.tvar or self.fvar:
            drv, trow = [a.reshape(Vn * T, -1) for a in self.drivers(targets, env)], None
        else:       # drivers() of one variant: the same for all (computed once)
            if "_drv1" not in self.__dict__:
                self._drv1 = [a[0] for a in self.drivers(targets[:1], env)]
            drv, tg = self._drv1, self.grid
        Qr, Qdr, Qddr, iters, conv, ratio, sg, smin, good, perr = kernel.solve_rows(
            k[0], self.S, k[1], Qr, *drv, o.tol, max(o.iterations, 8), rows=rows, table=table,
            trow=trow, accept=(tg, sign.reshape(Vn * T, -1)),
            hist=hist, work=work, out=None if out is None else [a.reshape(Vn * T, n3)
                                                                for a in out])
        # good: finite positions too, with the velocities and accelerations
        return Qr, Qdr, Qddr, BatchInfo(iters, conv, ratio, sg, smin), good, perr

    def accept(self, Qr, Qdr, Qddr, info, sign, ok, s):
        """Every acceptance test of a step on every row (see the module), then the Taylor path
        test per variant. Returns (Q, Qd, Qdd, sign, ok, s) as solve."""
        Vn, T = sign.shape[0], sign.shape[1]
        n3 = Qr.shape[1]
        o = self.study.opts
        good = accepted(info, sign.reshape(Vn * T, -1), (Qdr, Qddr), cond_max=COND_WARN)
        ok &= good.reshape(Vn, T).all(axis=1)
        Qs, Qds, Qdds = (a.reshape(Vn, T, n3) for a in (Qr, Qdr, Qddr))
        if ok.all():
            ok = (path_errors(self.grid, Qs, Qds, Qdds, self.cm.n) <= o.path_tol).all(axis=1)
        elif ok.any():
            ok[ok] = (path_errors(self.grid, Qs[ok], Qds[ok], Qdds[ok], self.cm.n)
                      <= o.path_tol).all(axis=1)
        return Qs, Qds, Qdds, info.sign.reshape(Vn, T, -1), ok, s

    def nominal_solution(self):
        """The nominal run on the grid (internal units) and its fine-block signs."""
        res = getattr(self.study, "nominal_result", None) or self.study.nominal_run()
        self.study.nominal_result = res
        cm = self.cm
        unit = np.tile([cm.L, cm.L, 1.0 / cm.angle_factor], cm.nb)
        ext = lambda a: np.concatenate([a / unit, np.zeros((len(a), 3))], axis=1)
        if res.qdd is None or len(res.t) != len(self.grid):
            raise Unsupported("the nominal run does not give accelerations on the whole grid")
        Q, Qd, Qdd = ext(res.q), ext(res.qd), ext(res.qdd)
        info = self.S.solve_batch(self.grid, Q.copy(), Qd.copy(), Qdd.copy(),
                                  policy=self.study.opts.newton, tol=self.study.opts.tol,
                                  maxit=self.study.opts.iterations, order=2)
        self.nominal = (Q, Qd, Qdd, info.sign)
        self.tangent = self._tangent(res)
        if not (path_errors(self.grid, Q, Qd, Qdd, cm.n) <= self.study.opts.path_tol).all():
            raise Unsupported("the grid is coarser than the path follower's steps")

    # numpy sums a last axis of fewer than this many numbers left to right (pairwise above)
    _SEQUENTIAL = 8

    def first_order(self, dp) -> np.ndarray:
        """(len(dp), T, n + 3): the first-order change of the nominal's positions for parameter
        steps dp (len(dp), k), (tangent * dp).sum(axis=-1), in its bits: elementwise (a BLAS
        product would wake its threads for a few numbers), and below 8 parameters one array
        pass per parameter over contiguous columns (numpy's sum over a last axis of 2-3
        numbers is its slowest reduction; it adds them left to right there, as here)."""
        d = dp[:, None, None, :]
        if dp.shape[1] >= self._SEQUENTIAL:
            return (self.tangent[None] * d).sum(axis=-1)
        if "_tcols" not in self.__dict__:
            self._tcols = [np.ascontiguousarray(self.tangent[..., j])
                           for j in range(self.tangent.shape[-1])]
        acc = self._tcols[0][None] * d[..., 0]
        for j in range(1, dp.shape[1]):
            acc += self._tcols[j][None] * d[..., j]
        return acc

    def _tangent(self, res):
        """(T, n + 3, k) exact dq/dp of the nominal positions on the grid, internal units per
        unit of each varied parameter (studies.sensitivity), or None where it does not apply."""
        from ..diagnostics import InputError
        from .sensitivity import sensitivities
        cm = self.cm
        try:
            dq, _ = sensitivities(cm, self.study.root, self.study.texts(), self.varied,
                                  res.t, res.q)
        except (InputError, np.linalg.LinAlgError):
            return None
        except Exception:  # noqa: BLE001 - only a prediction: without it the batch still runs
            return None
        dq = dq.copy()
        dq[:, 0::3] /= cm.L
        dq[:, 1::3] /= cm.L
        dq[:, 2::3] *= cm.angle_factor
        if not np.isfinite(dq).all():
            return None
        return np.concatenate([dq, np.zeros((len(dq), 3, dq.shape[2]))], axis=1)

    # -- metrics -------------------------------------------------------------------------------
    def metrics(self, Q, Qd, Qdd, s) -> np.ndarray:
        """(Vn, metrics) from solutions (Vn, T, n + 3), point offsets s (Vn, P, 2): each refined
        between the grid rows from the column's exact rate and acceleration, as the per-variant
        path and run's cycle figures (Metric.value)."""
        cm = self.cm
        study = self.study
        L, af = cm.L, cm.angle_factor
        out = np.empty((Q.shape[0], len(study.metrics)))
        pts = None
        levels = {"x": 0, "y": 0, "phi": 0, "vx": 1, "vy": 1, "omega": 1, "ax": 2, "ay": 2,
                  "alpha": 2}
        for i, m in enumerate(study.metrics):
            name, q = m.column.rsplit(".", 1) if m.kind != "dev" else (m.column, None)
            if m.kind == "dev":
                if pts is None:
                    pts = self.points(Q, Qd, Qdd, s)
                j = cm.point_names.index(name)
                d = pts[0][:, :, j] - study.reference[None, :, j]
                out[:, i] = m.value(self.grid, np.hypot(d[..., 0], d[..., 1]))
                continue
            lev = levels[q]
            if m.source == "bodies.csv":
                b = cm.body_names.index(name)
                k = {"x": 0, "y": 1, "phi": 2, "vx": 0, "vy": 1, "omega": 2, "ax": 0, "ay": 1,
                     "alpha": 2}[q]
                scale = L if k < 2 else 1.0 / af
                cols = [src[:, :, 3 * b + k] * scale for src in (Q, Qd, Qdd)[lev:]]
            else:
                if pts is None:
                    pts = self.points(Q, Qd, Qdd, s)
                j = cm.point_names.index(name)
                c = 0 if q in ("x", "vx", "ax") else 1
                cols = [arr[:, :, j, c] for arr in pts[lev:]]
            cols += [None] * (3 - len(cols))
            out[:, i] = m.value(self.grid, *cols)
        return out

    def points(self, Q, Qd, Qdd, s):
        """(Vn, T, P, 2) positions, velocities, accelerations of the points, user units."""
        cm = self.cm
        b = cm.point_body
        L = cm.L
        phi = Q[:, :, 3 * b + 2]
        c, sn = np.cos(phi), np.sin(phi)
        sx = c * s[:, None, :, 0] - sn * s[:, None, :, 1]
        sy = sn * s[:, None, :, 0] + c * s[:, None, :, 1]
        p = np.stack([Q[:, :, 3 * b] + sx, Q[:, :, 3 * b + 1] + sy], axis=-1)
        w = Qd[:, :, 3 * b + 2]
        pd = np.stack([Qd[:, :, 3 * b] - w * sy, Qd[:, :, 3 * b + 1] + w * sx], axis=-1)
        a = Qdd[:, :, 3 * b + 2]
        pdd = np.stack([Qdd[:, :, 3 * b] - a * sy - w * w * sx,
                        Qdd[:, :, 3 * b + 1] + a * sx - w * w * sy], axis=-1)
        return p * L, pd * L, pdd * L

    # -- a group of chains in lockstep ---------------------------------------------------------
    def run_group(self, chains_values: list[list[dict]]) -> list[list[Outcome]]:
        """Outcomes of a group of chains (lists of variants), solved in lockstep
        (planarkin.studies.lockstep: predictions along each chain, substeps where a step
        fails, the per-variant path for what still fails)."""
        return Lockstep(self, chains_values).run()
