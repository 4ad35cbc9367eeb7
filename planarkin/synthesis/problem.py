"""A synthesis or fitting problem: design parameters in, residuals and their exact Jacobian out.

A design is evaluated through the ordinary pipeline: its compiled model (`Model.compiled`: made
from the nominal's arrays where the file allows, bit for bit what the model file validated with
the design's values as overrides and compiled gives, else that), analysed over its whole range
(`analyse`: the assembly branch tracked over the cycle, refusal at lock-up and bifurcation),
then solved exactly at the times the targets need by Newton from the grid's cubic Hermite
interpolant, and the velocities there from Phi_q qdot = nu. Derivatives are exact:

* with respect to the parameters, dq/dp from Phi_q dq/dp = -Phi_p (studies.sensitivity) at the
  target times;
* with respect to a free input time, dq/dt = qdot (the velocity solution);
* at a prescribed input value u of a driver f(t; p) the time moves with p: f(t*, p) = u gives
  dt*/dp = -f_p / f_t, so dq/dp|u = dq/dp|t + qdot dt*/dp.

A design that cannot be assembled, stops (lock-up, bifurcation) before the end of the range or
violates a constraint is a `Rejected` design with its reason, never an exception.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..diagnostics import Diagnostic, InputError

NEWTON_TOL = 1e-13     # internal units
# Model.compiled(worded=False)'s refusal: a number of the design fails the file's checks
UNWORDED = "a number of the design fails the model file's checks"
BRANCH_JUMP = 1e-3     # Newton correction from the interpolant always allowed (internal units)


@dataclass
class Rejected:
    reason: str


@dataclass
class State:
    """A design solved at the target times. t: (N,) s; q, qd: (N, n) user units; p, pd:
    (N, P, 2) points, user units; dq: (N, n, k), dp: (N, P, 2, k) per unit of each free
    parameter (at constant time); result: the grid Result; cm: the compiled model."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    p: np.ndarray
    pd: np.ndarray
    dq: np.ndarray
    dp: np.ndarray
    result: object
    cm: object
    pdd: np.ndarray | None = None      # (N, P, 2) point accelerations (solve_at(accel=True))
    Q: np.ndarray | None = None        # (N, n) q in internal units (Model.solve_from)


class Model:
    """A model file prepared for repeated evaluation at other parameter values.

    path: the model file; free: names of the varied parameters; overrides: fixed --set values;
    analysis: Options keywords (steps, end, ...)."""

    def __init__(self, path, free, overrides=None, analysis=None):
        from ..studies.variants import Study
        self.study = Study(path, overrides, analysis)
        from ..studies.sensitivity import body_form_only
        body_form_only(self.study.root, path, "synth and fit")
        self.path = str(path)
        self.free = list(free)
        self.analysis = {k: v for k, v in (analysis or {}).items() if v is not None}
        self.analysis.setdefault("up_to", "velocity")
        self.nominal = self.study.nominal
        self.spec = self.nominal.spec
        self.evaluations = 0
        self.jacobians = 0
        self._batch = False           # batch()'s, built when first asked for

    def values(self, x) -> dict:
        return {name: float(v) for name, v in zip(self.free, x)}

    def batch(self):
        """The study's batched form for the free parameters (studies.batch.Batch), or None
        where the model does not take it."""
        if self._batch is False:
            from ..studies.batch import Batch
            try:
                self._batch = Batch(self.study, self.free, nominal=False)
            except Exception:  # noqa: BLE001 - a model the batch cannot take: Study.model
                self._batch = None
        return self._batch

    def compiled(self, values: dict, worded: bool = True):
        """The compiled model of a design: made from the nominal's arrays (Batch.design, the
        same numbers, without validating and compiling the file again) where the file allows
        it, else the file validated and compiled with the design's values (Study.model:
        raises InputError with the validator's message for an invalid design). worded=False:
        a design the arrays show the validator would refuse raises InputError without
        validating the file for the words (a search that only counts its refusals)."""
        from ..studies.design import REFUSED
        B = self.batch()
        cm = None if B is None else B.design(values)
        if cm is REFUSED:
            if not worded:
                raise InputError([Diagnostic(self.path, None, UNWORDED)])
            cm = None
        return cm if cm is not None else self.study.model(values)

    def analyse(self, values: dict):
        """(cm, opts, result) of the design over its whole range, or Rejected."""
        from ..options import Options
        from ..analysis import analyse
        self.evaluations += 1
        try:
            cm = self.compiled(values)
            opts = Options.from_model(cm, **self.analysis)
            info, res = analyse(cm, opts)
        except InputError as e:
            return Rejected("invalid: " + "; ".join(d.message for d in e.diagnostics
                                                     if d.severity == "error"))
        if info.status != 0:
            ev = info.event
            where = f" at t = {ev.t:.6g} s" if ev is not None else ""
            return Rejected(f"{ev.kind if ev else 'failure'}{where}: {info.message}")
        return cm, opts, res

    def periodic(self, res) -> bool:
        """Whether the points and bodies return to their start at the end of the range (a full
        cycle), so that a free input time may wrap around."""
        if res.p.shape[1]:
            scale = max(1e-300, float(np.abs(res.p).max()))
            return bool(np.abs(res.p[-1] - res.p[0]).max() <= 1e-7 * scale)
        return False

    def solve_at(self, cm, res, t, sens: bool = True, accel: bool = False):
        """State at times t (N,) from the analysed grid result, or Rejected; accel: with the
        points' accelerations (Phi_q qdd = gamma)."""
        t = np.asarray(t, dtype=float)
        L, af = cm.L, cm.angle_factor
        to_int = np.tile([1 / L, 1 / L, af], cm.nb)
        Tg = res.t
        Qg = res.q * to_int
        Qdg = res.qd * to_int
        k = np.clip(np.searchsorted(Tg, t, side="right") - 1, 0, len(Tg) - 2)
        h = Tg[k + 1] - Tg[k]
        s = ((t - Tg[k]) / h)[:, None]
        h = h[:, None]
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        Q0 = h00 * Qg[k] + h10 * h * Qdg[k] + h01 * Qg[k + 1] + h11 * h * Qdg[k + 1]
        # off the branch: a correction larger than the interpolant can be off by, at most
        # half the grid step's own motion (another branch is a finite distance away)
        jump = np.maximum(BRANCH_JUMP, 0.5 * np.abs(Qg[k + 1] - Qg[k]).max(axis=1))
        st = self.solve_from(cm, t, Q0, jump, sens=sens, accel=accel)
        if not isinstance(st, Rejected):
            st.result = res
        elif st.reason.startswith("a target pose moved"):
            return Rejected("a target pose is off the tracked branch (raise analysis: steps)")
        return st

    def solve_from(self, cm, t, Q0, jump: float, sens: bool = True, accel: bool = False):
        """State at times t (N,) by Newton from the guess Q0 (N, n) in internal units (lengths
        over cm.L, angles in rad), or Rejected when Newton does not converge or moves a pose by
        more than `jump` (internal units; a number or one per time) from the guess: the guess
        is a pose on the branch wanted (the grid's interpolant, or a first-order predictor
        from a nearby design), so a larger correction means another branch. The state's `Q`
        is the solution in internal units (the next guess of a continuation)."""
        from planarkin.solver.kinematics import point_kinematics
        from planarkin.solver.system import System
        t = np.asarray(t, dtype=float)
        L, af = cm.L, cm.angle_factor
        to_int = np.tile([1 / L, 1 / L, af], cm.nb)
        S = System(cm)
        Q = np.array(Q0, dtype=float)
        T, NU, _ = S.driver_values(t)        # the drivers at t, once for every iteration
        for _ in range(20):
            R, J = S.residual_jacobian(S.ext(Q), T)
            dQ = _solve(J, -R)
            Q += dQ
            if not np.isfinite(Q).all():
                break
            if np.abs(dQ).max() <= NEWTON_TOL:
                break
        else:
            return Rejected("Newton did not converge at a target time")
        if not np.isfinite(Q).all():
            return Rejected("Newton did not converge at a target time")
        if np.any(np.abs(Q - Q0).max(axis=1) > jump):
            return Rejected("a target pose moved off its branch")
        J = S.jacobian(S.ext(Q))
        Qd = _solve(J, NU)
        Qdd = _solve(J, S.gamma(S.ext(Q), S.ext(Qd), t)) if accel else None
        # the extended coordinates (ground last): points on the ground (a sketch's pivots) too
        P, Pd, Pdd = point_kinematics(cm, S.ext(Q), S.ext(Qd),
                                      S.ext(Qdd) if accel else None)
        q, qd = Q / to_int, Qd / to_int
        st = State(t=t, q=q, qd=qd, p=P * L, pd=Pd * L, dq=None, dp=None, result=None, cm=cm,
                   pdd=Pdd * L if accel else None)
        st.Q = Q
        if sens:
            self.add_sensitivities(st)
        return st

    def add_sensitivities(self, st: State) -> None:
        """Fill st.dq, st.dp: the exact sensitivities at the state's times (one Jacobian
        evaluation)."""
        from ..studies.sensitivity import sensitivities
        self.jacobians += 1
        cm = st.cm
        texts = self.study.texts()
        texts.update({k: float(v) for k, v in cm.spec.parameters.items() if k in self.free})
        st.dq, st.dp = sensitivities(cm, self.study.root, texts, self.free, st.t, st.q)

    # -- the driver ------------------------------------------------------------------------
    def driver(self, cm):
        if len(cm.spec.drivers) != 1:
            return None
        return cm.spec.drivers[0]

    def input_values(self, cm, t) -> np.ndarray:
        """The driver's values f(t) (user unit)."""
        el = self.driver(cm)
        v, _, _ = el.f.derivatives(np.asarray(t, dtype=float))
        return np.broadcast_to(v, np.shape(t)).astype(float)

    def times_of(self, cm, res, u):
        """Times t with f(t) = u over the range (the first crossing), or Rejected."""
        el = self.driver(cm)
        tg = res.t
        fg = self.input_values(cm, tg)
        out = []
        for uk in np.atleast_1d(u):
            d = fg - uk
            hit = np.nonzero((d[:-1] <= 0) & (d[1:] >= 0) | (d[:-1] >= 0) & (d[1:] <= 0))[0]
            if not len(hit):
                return Rejected(f"the input value {uk:g} is not reached by the driver "
                                f"{el.label} over t = {tg[0]:g} .. {tg[-1]:g} s")
            i = hit[0]
            a, b = tg[i], tg[i + 1]
            tk = a if d[i] == 0 else b if d[i + 1] == 0 else a + (b - a) * d[i] / (d[i] - d[i + 1])
            for _ in range(30):         # Newton on f, kept inside the bracket
                v, d1, _ = el.f.derivatives(np.array([tk]))
                v, d1 = float(np.ravel(v)[0]), float(np.ravel(d1)[0])
                if d1 == 0:
                    break
                tn = min(max(tk - (v - uk) / d1, a), b)
                if abs(tn - tk) <= 1e-15 * max(1.0, abs(tk)):
                    tk = tn
                    break
                tk = tn
            out.append(tk)
        return np.array(out)

    def input_dtdp(self, cm, t) -> np.ndarray:
        """(N, k) dt*/dp = -f_p / f_t at prescribed input values (f: the driver's function)."""
        from ..studies.sensitivity import derivatives
        el = self.driver(cm)
        texts = self.study.texts()
        texts.update({k: float(v) for k, v in cm.spec.parameters.items() if k in self.free})
        D = derivatives(self.study.root, cm.spec.parameters, texts, self.free)
        node = self.study.root.value["drivers"].value[el.index - 1].value["f"]
        fp = D.function(node, np.asarray(t, dtype=float))
        _, ft, _ = el.f.derivatives(np.asarray(t, dtype=float))
        ft = np.broadcast_to(ft, np.shape(t))
        if np.any(ft == 0):
            raise InputError([Diagnostic(self.path, el.line, f"{el.label}: its rate is zero at "
                                         f"a prescribed input value; the time of that input is "
                                         f"not defined")])
        return -fp / ft[:, None]


def memory_problem(model, grids: int, held: str, more: str = "", k: int = 0) -> str | None:
    """Why `grids` analyses over the whole range, held at once, would pass the memory budget of
    a study (planarkin.studies.budget: its bytes per grid row and column), naming the largest
    --steps that fits; None when they fit. held: what the grids are; more: other fixes."""
    from ..studies.budget import ROW_BYTES, STUDY_BYTES, study_cost
    cm, opts = model.nominal, model.study.opts
    grid = study_cost(cm, opts, 1, k)[0]
    if grids * grid <= STUDY_BYTES:
        return None
    per_row = ROW_BYTES * (cm.n + 2 * len(cm.point_names))     # as study_cost counts a row
    most = max(1, int((STUDY_BYTES / grids - (grid - opts.rows * per_row)) // per_row) - 1)
    return (f"{grids} grids of {opts.rows} rows would be held at once ({held}): about "
            f"{grids * grid / 2**30:.3g} GB of memory, more than the budget of "
            f"{STUDY_BYTES / 2**30:.3g} GB: use --steps {most} or fewer{more}")


def _solve(J, R):
    """Solve J x = R row by row: J (N, m, n), R (N, m); least squares when m > n (consistent
    redundant constraints: the least-squares solution is the exact one)."""
    if J.shape[1] == J.shape[2]:
        return np.linalg.solve(J, R[..., None])[..., 0]
    return np.stack([np.linalg.lstsq(J[i], R[i], rcond=None)[0] for i in range(len(J))])


def wrap(d, unit: str):
    """An angle difference wrapped into (-half turn, half turn], in the model's unit."""
    half = 180.0 if unit == "deg" else math.pi
    return (np.asarray(d) + half) % (2 * half) - half
