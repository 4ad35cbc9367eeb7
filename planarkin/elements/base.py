"""What every constraint kind shares: parameter declarations, batched body frames, element groups.

Conventions (``../shared/reference/constraints.md`` §0): body k has q_k = (x_k, y_k, phi_k); a
body-fixed vector s' has the global image s = A(phi) s'; R rotates by +90 degrees. Each kind
writes its equations as ``g(q) - target = 0``: the target is a constant (joints) or a driver
function f(t) (drivers). A kind therefore supplies g, its gradient with respect to the
coordinates of the bodies it connects, and gamma_g, the part of the acceleration right-hand side
that comes from g (reference §5: gamma = gamma_g + f'' and nu = f').

Everything here is batched: N time points (or candidate states) times K instances of a kind, so
that one numpy call serves a whole time chunk. Arrays are in internal units: lengths divided by the
model's characteristic length, angles in radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import pointline

# What a parameter is, as the validator reads it (planarkin.model.validate, Validator.param)
UNITS = ("point", "vector", "length", "angle", "real", "flag", "range", "curve", "law",
         "angle-law")


@dataclass(frozen=True)
class Param:
    """One YAML key of a kind.

    unit (one of UNITS): 'point' (2-vector of lengths, body frame), 'vector' (2-vector
    direction, normalised), 'length' (scalar length), 'angle' (scalar angle in the file's angle
    unit), 'real' (number), 'flag' (true/false), 'range' ([from, to] of a cam angle), 'curve' (a
    curve-slot's path), 'law' / 'angle-law' (a cam's motion law of the cam angle: a lift, an
    angle).
    """

    name: str
    unit: str
    doc: str
    required: bool = True
    default: object = None


@dataclass(frozen=True)
class Frame:
    """Positions (and velocities) of all bodies for a batch of N states.

    q: (N, 3*nb + 3) coordinates, ground last (always zero); internal units.
    c, s: (N, nb + 1) cos and sin of every body angle (ground last: 1, 0).
    qd: (N, 3*nb + 3) velocities (ground zero) or None when only positions are needed.
    qdd: (N, 3*nb + 3) accelerations (ground zero, same shape as qd) or None; only the jerk
        right-hand side reads them.
    """

    q: np.ndarray
    c: np.ndarray
    s: np.ndarray
    qd: np.ndarray | None = None
    qdd: np.ndarray | None = None


@dataclass(frozen=True)
class Group:
    """K instances of one kind, with their bodies and parameters (internal units).

    bodies: (K, kind.nbody) body indices (ground = nb).
    cols: (K, 3*kind.nbody) coordinate columns in the extended q of those bodies.
    params: name -> (K,) or (K, 2) arrays.
    rows: (K, kind.neq) global equation rows.
    """

    kind: "Kind"
    bodies: np.ndarray
    cols: np.ndarray
    params: dict
    rows: np.ndarray

    def take(self, idx) -> "Group":
        idx = np.asarray(idx, dtype=np.intp)
        return Group(self.kind, self.bodies[idx], self.cols[idx],
                     {k: v[idx] for k, v in self.params.items()}, self.rows[idx])

    def __len__(self) -> int:
        return len(self.bodies)

    # -- evaluation ---------------------------------------------------------------------------
    def g(self, F: Frame) -> np.ndarray:
        """(N, K, neq) values of g."""
        return self.kind.g(self, F)

    def grad(self, F: Frame) -> np.ndarray:
        """(N, K, neq, 3*nbody) gradient of g with respect to the coordinates of its bodies."""
        return self.kind.grad(self, F)

    def g_grad(self, F: Frame) -> tuple:
        """(g, grad) at one state, as g and grad give them (a Newton step needs both)."""
        return self.kind.g_grad(self, F)

    def gamma(self, F: Frame) -> np.ndarray:
        """(N, K, neq) gamma_g, using F.qd."""
        return self.kind.gamma(self, F)

    def jerk(self, F: Frame) -> np.ndarray:
        """(N, K, neq) jerk_g, using F.qd and F.qdd."""
        return self.kind.jerk(self, F)


class Kind:
    """A constraint kind: everything planarkin knows about one YAML ``type``, in the kind's own
    module of this package, registered once in `planarkin.elements.KINDS`. The contract (what
    `tests/test_kinds.py` checks for every registered kind):

    1. Identity and reference: ``name`` (the YAML type), ``neq`` equations and ``nbody``
       bodies (i, j[, k]) per instance, ``joint`` / ``driver`` (where it may appear),
       ``params`` (`Param`: its YAML keys), ``target`` and ``target_unit`` (the constant of a
       joint, the unit of a driver's f), ``summary``, ``equations`` and, for drivers,
       ``driver_equations`` (the reference tables of the docs are made from them).
    2. Equations, batched over N states and K instances (reference §0, §5): ``g``, ``grad``,
       ``gamma`` and ``jerk`` (the third-derivative right-hand side, up_to: jerk);
       ``row_unit`` (what each equation's residual measures).
    3. Validation, at the element's line in the file: ``validate(V, params, given, what)``,
       checks of the parameters' values once read (radii, a closed curve), and
       ``diagnose(arrays, L, af, lu, au)``, what only the compiled parameters show (a cam
       that undercuts). ``at_form`` and ``place``: a global ``at:`` placement turned into
       body-frame parameters (``at_points``, ``at_axis``, ``target_from_at``);
       ``target_default``, ``between``: what the file may leave out or name otherwise;
       ``positive_target`` (a distance's c and f).
    4. Assembly: ``prepare(arrays, poses)`` and the ``derived`` parameters it fills from the
       estimated poses (a rolling phase, a side, a phase constant); ``check_pose``, what the
       assembled pose must satisfy beyond the equations (a gear pair's centre distance);
       ``sampled_zeros`` (whether a zero of the gradient at random states is structural).
    5. Reactions (the forces room): ``reaction_columns`` (what a joint's forces.csv columns
       are: fx, fy, torque), ``reaction_sign`` (their meaning and signs), ``reaction_setup``,
       ``reaction`` (the physical force where -g_q^T lambda is not), ``reaction_point`` (where
       the moment is taken) and ``contact_force`` (contacts that only press); see the notes at
       `reaction_sign` below.
    6. Drawing: ``draw(G, k, parts)`` (the kind's part of the mechanism figure: body-frame
       geometry into a `planarkin.elements.drawing.Parts`, no matplotlib; the figures,
       planarkin.output.plots.scene, turn the parts into artists).

    A method left as here means "nothing to add" (parts 3-5: no checks, no estimates, the
    constraint force is the physical one); parts 1, 2 and, for joints, 5's reaction_columns and
    reaction_sign every kind states itself. The compiled route compiles a kind that states its
    ``compiled_code`` (its function in planarkin.elements.pointline.CODES) and
    ``compiled_params`` (the parameters that function reads, each a body-frame 2-vector);
    the others (None) take the numpy route.
    """

    name: str = ""
    neq: int = 1
    nbody: int = 2
    joint: bool = True
    driver: bool = False
    params: tuple = ()
    target: str | None = None
    target_unit: str | None = None
    summary: str = ""
    equations: str = ""
    driver_equations: str = ""
    # the forces.csv columns of a joint of this kind (part 5): ("fx", "fy"), ("torque",) ...
    reaction_columns: tuple = ()

    # Whether a zero of the gradient at a few random states is structural (it comes from
    # constant parameters: the phi column of a pin at a body's origin). False for kinds whose
    # gradient vanishes on whole regions of states (a straight piece of a slot, a cam's dwell):
    # every column of their bodies is then a dependency of their rows, or the block structure
    # and the fused pass would drop a coupling that exists elsewhere (System.pattern), and
    # their blocks are never taken as affine (_ClassifyState).
    sampled_zeros: bool = True
    compiled_code: int | None = None       # planarkin.elements.pointline.CODES; None: numpy only
    compiled_params: tuple = ()            # of si, sj, vi, vj: what its compiled function reads

    # Parameters the compiler derives from the body estimates (not YAML keys), e.g. the side of
    # a rack's pitch line on which the pinion sits: Param entries, filled by `prepare`.
    derived: tuple = ()

    # The validator converts 'at' (global placement) into body-frame parameters through this.
    # at_form: None (no global placement) or a description of the 'at' value for messages;
    # at_points: how many global points 'at' gives; at_axis: with 'at', the slide direction is
    # given as 'axis'; target_from_at: the joint's constant follows from 'at' when not given.
    at_form: str | None = None
    at_points: int = 1
    at_axis: bool = False
    target_from_at: bool = False
    # the constant of a joint whose target may be left out (None: it must be given)
    target_default: float | None = None
    # the target (a joint's c, a driver's f) must be positive (a distance)
    positive_target: bool = False
    # a driver of this kind may name two sketch pins, between: [C, D], for its bodies and points
    between: bool = False

    def g(self, G: Group, F: Frame) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def grad(self, G: Group, F: Frame) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def gamma(self, G: Group, F: Frame) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def g_grad(self, G: Group, F: Frame) -> tuple:
        """g and grad at one state: (g(G, F), grad(G, F)), or one pass where a kind shares
        their work (PointLineKind)."""
        return self.g(G, F), self.grad(G, F)

    def row_unit(self, k: int) -> str:
        """'angle' or 'length': what the residual of equation k measures (messages give it in
        the file's angle or length unit)."""
        return "angle" if self.target_unit == "angle" else "length"

    def jerk(self, G: Group, F: Frame) -> np.ndarray:  # pragma: no cover - abstract
        """(N, K, neq) jerk_g at (F.q, F.qd, F.qdd). With g this kind's function,
        g_q q''' = jerk_g + f''' (f''' = 0 for joints): jerk_g = -(d^3 g/dt^3 - g_q q'''),
        minus every term of the third time derivative of g that does not contain q'''."""
        raise NotImplementedError

    def place(self, at, poses, given):  # pragma: no cover - overridden where at_form is set
        """Body-frame parameters from global placement.

        at: the validated 'at' value (global coordinates, internal units); poses: list of
        (x, y, phi) of the kind's bodies (ground = (0, 0, 0)); given: parameters already given.
        Returns a dict of parameters to add.
        """
        raise NotImplementedError

    def check_pose(self, G: Group, F: Frame, pivots: dict, L: float, lu: str) -> list:
        """What the assembled pose F (one state) must satisfy beyond the equations (a gear
        pair's centre distance, pulleys that do not overlap): (instance k, 'error' or
        'warning', message in user units: lengths times L, in lu). pivots: see `pivots`."""
        return []

    def prepare(self, arrays, poses):
        """Derived parameters and constant targets from the estimated poses, for kinds whose
        constant (a rolling phase, a side sign) depends on how the model is drawn.

        arrays: parameter name -> value (internal units); poses: (x, y, phi) of the kind's bodies
        (internal units; ground (0, 0, 0)). Returns (dict of the `derived` parameters, list of
        neq constant targets) or None when the kind needs nothing (targets from c or 0)."""
        return None

    # -- reactions (the forces room, planarkin.forces) ---------------------------------------
    # 1. `reaction_sign`: what the kind's reaction columns in forces.csv mean and their signs
    #    (the docs' table of sign conventions is made from it, `reaction_table`).
    # 2. A kind whose constraint force -g_q^T lambda is not the force its parts exchange on the
    #    machine (a cam written as a motion law, a gear pair as a ratio of angles) gives the
    #    physical one by `reaction`: a contact force where the contact is, on i and j only.
    #    It must differ from -g_q^T lambda by a generalised force that does no work on any
    #    motion the other joints allow (the bearings take the difference), so that lambda of
    #    the kind's own rows is the same either way (planarkin.forces.solve checks it).
    # 3. `reaction_point`: the point of body j about which the moment column is written.
    # 4. `contact_force`: for contacts that hold only by pressing (cams), the signed normal
    #    force, positive while the parts press on each other (lift-off where it turns negative).
    reaction_sign: str = ""

    def reaction_setup(self, G: Group, pivots: dict, L: float):
        """What `reaction` needs beyond the group's parameters, from the rest of the model:
        pivots maps (body, other body) -> the revolute's point on body (body frame, internal
        units), see `pivots`; L the model's length (a force parameter in user units times L is
        one in internal units). None when the kind needs nothing."""
        return None

    def reaction(self, G: Group, F: Frame, lam: np.ndarray, setup):
        """(N, K, nbody, 3) generalised force of each instance on each of its bodies (force
        x, y, moment about the body frame's origin; internal units, as -g_q^T lambda) from its
        multipliers lam (N, K, neq), or None when -g_q^T lambda is the physical force."""
        return None

    def reaction_point(self, G: Group, F: Frame, setup):
        """Global (x, y), two (N, K) arrays (internal units), of the point of body j about which
        the reaction's moment is written: sj where the kind has it, else None (the moment is
        about body j's frame origin)."""
        if "sj" not in G.params:
            return None
        bj = G.bodies[:, 1]
        sx, sy = rotate(F, bj, G.params["sj"][:, 0], G.params["sj"][:, 1])
        x, y = body_xy(F, bj)
        return x + sx, y + sy

    def contact_force(self, G: Group, F: Frame, lam: np.ndarray, setup):
        """(N, K) signed normal contact force (internal units), positive while the parts press
        on each other, for unilateral contacts modelled as bilateral; None for other kinds."""
        return None

    def validate(self, V, params: dict, given: dict, what: str) -> None:
        """Checks of one instance's parameter values once read (user units), reported through
        the validator V (``V.err(node, message)``) at the offending key's node in given (the
        element's YAML mapping); what: the element's label for messages."""
        return None

    def diagnose(self, arrays, L, af, length_unit, angle_unit) -> list:
        """Problems of one instance that only its compiled parameters show (a cam profile that
        undercuts): messages in user units, reported as errors at the element's line."""
        return []

    def draw(self, G: Group, k: int, parts) -> None:  # pragma: no cover - abstract
        """How instance k of group G looks in the mechanism figures: ``draw(G, k, parts)`` adds
        body-frame geometry in user units to parts, a `planarkin.elements.drawing.Parts` (its
        joint points, pins, slides, pitch circles, profiles), and returns None. No matplotlib
        here: the figures (planarkin.output.plots.scene) turn the parts into artists."""
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"<kind {self.name}>"


class PointLineKind(Kind):
    """A kind whose equations are a function of planarkin.elements.pointline (``equation``, its
    name there): its g, grad and gamma broadcast that function over the group, the text the
    compiled route compiles (so both routes do the same element arithmetic)."""

    equation: str = ""

    def rows(self, G: Group, F: Frame, want: int) -> tuple:
        """The function's rows for the group: (N, K) arrays, or floats where a term is a
        constant."""
        return getattr(pointline, self.equation)(want, *point_line_arguments(G, F, want))

    def g(self, G, F):
        rows = self.rows(G, F, 1)
        out = empty(F, len(G), len(rows))
        for r, row in enumerate(rows):
            out[..., r] = row[0]
        return out

    def grad(self, G, F):
        rows = self.rows(G, F, 2)
        out = np.empty((F.q.shape[0], len(G), len(rows), 6))
        for r, row in enumerate(rows):
            gradient_row(out, r, row)
        return out

    def g_grad(self, G, F):
        rows = self.rows(G, F, 3)
        g = empty(F, len(G), len(rows))
        grad = np.empty((F.q.shape[0], len(G), len(rows), 6))
        for r, row in enumerate(rows):
            g[..., r] = row[0]
            gradient_row(grad, r, row)
        return g, grad

    def gamma(self, G, F):
        rows = self.rows(G, F, 4)
        out = empty(F, len(G), len(rows))
        for r, row in enumerate(rows):
            out[..., r] = row[7]
        return out


def gradient_row(out: np.ndarray, r: int, row: tuple) -> None:
    """A planarkin.elements.pointline row's gradient (row[1:7]) into out[..., r, :]."""
    for c in range(6):
        out[..., r, c] = row[1 + c]


def point_line_arguments(G: Group, F: Frame, want: int) -> tuple:
    """The arguments after want of a planarkin.elements.pointline function for the group, as
    (N, K) arrays (its parameter slots as (K,) arrays or 0.0, its velocities 0.0 unless want
    asks for gamma)."""
    q = F.q[:, G.cols]
    c = F.c[:, G.bodies]
    s = F.s[:, G.bodies]
    slots = []
    for name in ("si", "sj", "vi"):
        v = G.params.get(name)
        slots += [0.0, 0.0] if v is None else [v[:, 0], v[:, 1]]
    rates = [0.0] * 6
    if want & 4:
        v = F.qd[:, G.cols]
        rates = [v[..., k] for k in range(6)]
    return (q[..., 0], q[..., 1], q[..., 2], c[..., 0], s[..., 0],
            q[..., 3], q[..., 4], q[..., 5], c[..., 1], s[..., 1], *slots, *rates)


# -- shared kinematics (reference §0) -------------------------------------------------------------

def body_xy(F: Frame, b: np.ndarray):
    """(N, K) x and y of bodies b."""
    return F.q[:, 3 * b], F.q[:, 3 * b + 1]


def rotate(F: Frame, b: np.ndarray, vx, vy):
    """Global image A(phi_b) v' of body-fixed vectors v' = (vx, vy): two (N, K) arrays."""
    c = F.c[:, b]
    s = F.s[:, b]
    return c * vx - s * vy, s * vx + c * vy


def omega(F: Frame, b: np.ndarray):
    """(N, K) angular velocities of bodies b."""
    return F.qd[:, 3 * b + 2]


def body_velocity(F: Frame, b: np.ndarray):
    return F.qd[:, 3 * b], F.qd[:, 3 * b + 1]


def relative_point(G: Group, F: Frame, si="si", sj="sj"):
    """The pair vectors of reference §0 for points si on body i and sj on body j.

    Returns (sx_i, sy_i, sx_j, sy_j, hx, hy) with s = A s' and h = r_j + s_j - r_i - s_i.
    """
    bi = G.bodies[:, 0]
    bj = G.bodies[:, 1]
    pi_ = G.params[si]
    pj = G.params[sj]
    six, siy = rotate(F, bi, pi_[:, 0], pi_[:, 1])
    sjx, sjy = rotate(F, bj, pj[:, 0], pj[:, 1])
    xi, yi = body_xy(F, bi)
    xj, yj = body_xy(F, bj)
    return six, siy, sjx, sjy, xj + sjx - xi - six, yj + sjy - yi - siy


def relative_velocity(F: Frame, bi, bj, six, siy, sjx, sjy):
    """h-dot = rdot_j + w_j R s_j - rdot_i - w_i R s_i and the angular velocities (reference §0)."""
    wi = omega(F, bi)
    wj = omega(F, bj)
    vxi, vyi = body_velocity(F, bi)
    vxj, vyj = body_velocity(F, bj)
    hdx = vxj - wj * sjy - vxi + wi * siy
    hdy = vyj + wj * sjx - vyi - wi * six
    return wi, wj, hdx, hdy


def empty(F: Frame, K: int, *shape) -> np.ndarray:
    return np.empty((F.q.shape[0], K) + shape)


def make_frame(q: np.ndarray, qd: np.ndarray | None = None,
               qdd: np.ndarray | None = None) -> Frame:
    """Frame from extended coordinates q (N, 3*nb + 3) (ground last, zero)."""
    phi = q[:, 2::3]
    return Frame(q, np.cos(phi), np.sin(phi), qd, qdd)


def group(kind: Kind, bodies, params, rows=None) -> Group:
    """A Group from body indices (K, nbody) and parameter arrays; cols are derived."""
    bodies = np.asarray(bodies, dtype=np.intp).reshape(-1, kind.nbody)
    cols = (3 * bodies[:, :, None] + np.arange(3)).reshape(len(bodies), -1)
    if rows is None:
        rows = np.arange(len(bodies) * kind.neq).reshape(len(bodies), kind.neq)
    return Group(kind, bodies, cols, {k: _param_array(v) for k, v in params.items()},
                 np.asarray(rows, dtype=np.intp))


def _param_array(v) -> np.ndarray:
    """Numbers become a float array; objects (a cam's motion law) stay an object array."""
    a = np.asarray(v)
    return a if a.dtype == object else a.astype(float)


def pivots(groups) -> dict:
    """(body, other) -> the point (2,) on body (its frame, internal units) of the first revolute
    joint between the two bodies: where a gear or a pulley turns on its carrier."""
    out: dict = {}
    for G in groups:
        if G.kind.name != "revolute":
            continue
        for (bi, bj), si, sj in zip(G.bodies, G.params["si"], G.params["sj"]):
            out.setdefault((int(bi), int(bj)), np.asarray(si, float))
            out.setdefault((int(bj), int(bi)), np.asarray(sj, float))
    return out


def check_positive(V, params: dict, given: dict, what: str, keys, zero_ok=()) -> None:
    """Kind.validate's common check: each of keys given must be positive (zero allowed for the
    keys in zero_ok, a roller of radius 0 being a knife edge)."""
    for key in keys:
        x = params.get(key)
        if x is not None and (x < 0 or (x == 0 and key not in zero_ok)):
            V.err(given[key], f"{what}: {key} must be positive, not {x:g}")


def force_at(F: Frame, bodies, px, py, fx, fy, out, slot, sign=1.0):
    """Add the force sign * (fx, fy) acting at the global point (px, py) (all (N, K)) to slot of
    out (N, K, nbody, 3): force and its moment about each body's frame origin."""
    x, y = body_xy(F, bodies)
    out[:, :, slot, 0] += sign * fx
    out[:, :, slot, 1] += sign * fy
    out[:, :, slot, 2] += sign * ((px - x) * fy - (py - y) * fx)


def gradient_force(G: Group, F: Frame, lam: np.ndarray) -> np.ndarray:
    """-g_q^T lambda per body: (N, K, nbody, 3) from lam (N, K, neq)."""
    g = G.grad(F)
    N, K = lam.shape[:2]
    return -np.einsum("nke,nkec->nkc", lam, g).reshape(N, K, G.kind.nbody, 3)
