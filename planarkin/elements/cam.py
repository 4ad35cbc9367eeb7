"""Cam and follower, the follower's motion given as a law over cam angle (issue 8, item 4).

Machine designers specify a cam by the follower's motion over cam angle, s(theta) (a rise of h
over beta with a named law, dwells, a return), and derive the profile from it. planarkin does the
same: the constraint couples the cam's rotation theta = phi_i - phi_k (cam i turning on frame k)
to the follower's coordinate, exactly, and the profile follows from s, s', s'' by kinematic
inversion (`profile`), exactly too.

`cam`, translating follower j guided on frame k along the unit direction u = A_k vk:
    u^T (r_j + A_j sj - r_k - A_k sk) - s(theta) = s0
with sk the cam's centre on k, sj the follower's reference point (roller centre, knife tip, or
the flat face's point on its axis) and s0 = sqrt((base + roller)^2 - offset^2) (knife edge,
roller) or base (flat face): s = 0 puts the follower on the base circle. The follower's own
translational joint to k keeps it on its axis at `offset` (along R u) from the cam centre.

`cam-rocker`, oscillating follower j pivoted on k at pk (its pivot on j: pj): the arm angle
    phi_j - phi_k - psi(theta) = psi0
psi0 from the drawn rocker angle (the law's zero is psi0 + psi(theta0) = the estimate).

The law is an expression of `theta` in the file's angle unit (s in its length unit, psi in its
angle unit); its derivatives are the exact symbolic ones of `planarkin.functions.expr`.
"""

from __future__ import annotations

import math
import re
from typing import NamedTuple

import numpy as np

from planarkin.functions.expr import parse
from . import jerk as J
from .base import Kind, Param, body_xy, check_positive, force_at, omega, relative_velocity, rotate

VAR = "theta"
DEFAULT_LIMIT = {"cam": math.radians(30.0), "cam-rocker": math.radians(45.0)}
SAMPLES_PER_TURN = 2880          # profile checks: every 0.125 degrees of cam angle


class Law:
    """s(theta) (or psi(theta)) with exact first and second derivatives.

    text: an expression of theta and the model's parameters (values: name -> float, user units).
    Called with theta in radians (N,) it returns (value, d/dtheta, d2/dtheta2) in internal units
    once `scaled` (a = user angle per radian, b = internal per user output unit); unscaled
    (a = b = 1) it is the plain expression, as the element tests use it."""

    def __init__(self, text, values, a: float = 1.0, b: float = 1.0):
        self.text = text if isinstance(text, str) else repr(text)
        self.values = {k: float(v) for k, v in values.items() if k != VAR}
        e = parse(text, list(self.values) + [VAR])          # messages speak of theta
        # evaluated as a function of t, the name the switch rules of planarkin.functions.expr resolve
        # at rounding level (SIDE_RULE: a knot within 8 ulp of theta is at theta, right-hand)
        self.var = VAR
        if "t" not in self.values and isinstance(text, str):
            e = parse(re.sub(rf"\b{VAR}\b", "t", text), list(self.values) + ["t"])
            self.var = "t"
        d1 = e.diff(self.var)
        self.exprs = (e, d1, d1.diff(self.var))
        self.a, self.b = a, b

    def scaled(self, out_per_user: float, angle_factor: float) -> "Law":
        law = Law.__new__(Law)
        law.text, law.values, law.exprs, law.var = self.text, self.values, self.exprs, self.var
        law.a, law.b = 1.0 / angle_factor, out_per_user
        return law

    def __call__(self, theta, orders=(0, 1, 2)):
        """(value, d/dtheta, d2/dtheta2) at theta; only the given orders are computed (the
        others are None). orders may include 3 (the jerk's d3/dtheta3, then a 4-tuple)."""
        theta = np.asarray(theta, dtype=float)
        env = dict(self.values)
        env[self.var] = self.a * theta
        if 3 in orders and len(self.exprs) == 3:          # only runs asking for jerk need it
            self.exprs = self.exprs + (self.exprs[2].diff(self.var),)
        out = [None] * (4 if 3 in orders else 3)
        for o in orders:
            f = np.broadcast_to(np.asarray(self.exprs[o].evaluate(env), float), theta.shape)
            out[o] = (self.b * self.a ** o) * f
        return tuple(out)

    def __repr__(self) -> str:
        return f"Law({self.text!r})"


class FunctionLaw(Law):
    """A law given as data: a ``motion:`` profile of segments over cam angle or a table of
    (cam angle, value), held as the planarkin.functions.expr TimeFunction of the driver forms with theta
    (user angle units) in the place of t. Derivatives are the exact ones of that function (the
    laws' closed forms, the spline's polynomials), up to the third. Outside `domain` (a table
    that does not wrap: its angle range, user units) the law is NaN, so that a cam turned past
    its table stops the run instead of extrapolating.

    fn: the TimeFunction; text: what messages show; span: the cam angle the data covers (user
    units); periodic: whether the law repeats every turn; a, b as for Law."""

    def __init__(self, fn, text: str, span: float, periodic: bool, a: float = 1.0,
                 b: float = 1.0):
        self.fn, self.text, self.span, self.periodic = fn, text, float(span), bool(periodic)
        self.values = {}
        self.a, self.b = a, b

    def scaled(self, out_per_user: float, angle_factor: float) -> "FunctionLaw":
        return FunctionLaw(self.fn, self.text, self.span, self.periodic, 1.0 / angle_factor,
                           out_per_user)

    def __call__(self, theta, orders=(0, 1, 2)):
        """As Law.__call__, with order 3 (the third derivative) available too; the tuple has
        max(3, largest order + 1) entries."""
        theta = np.asarray(theta, dtype=float)
        x = self.a * theta
        out = [None] * max(3, max(orders) + 1)
        if any(o < 3 for o in orders):
            d = self.fn.derivatives(x)
            for o in orders:
                if o < 3:
                    out[o] = (self.b * self.a ** o) * np.broadcast_to(np.asarray(d[o], float),
                                                                    theta.shape)
        if 3 in orders:
            out[3] = (self.b * self.a ** 3) * np.broadcast_to(np.asarray(self.fn.third(x), float),
                                                            theta.shape)
        dom = getattr(self.fn, "domain", None)
        if dom is not None:
            outside = (x < dom[0]) | (x > dom[1])
            if outside.any():
                for o in orders:
                    out[o] = np.where(outside, np.nan, out[o])
        return tuple(out)

    def __repr__(self) -> str:
        return f"FunctionLaw({self.text!r})"


def _laws(G, name, theta, order):
    """d^order s / dtheta^order (N, K) of every instance's law at its own theta (N, K)."""
    out = np.empty(theta.shape)
    laws = G.params[name]
    for law in {id(x): x for x in laws}.values():        # one evaluation per distinct law
        cols = [k for k, x in enumerate(laws) if x is law]
        out[:, cols] = law(theta[:, cols], (order,))[order]
    return out


def _cam_angle(G, F):
    bi, bk = G.bodies[:, 0], G.bodies[:, 2]
    th = F.q[:, 3 * bi + 2] - F.q[:, 3 * bk + 2]
    thd = None if F.qd is None else omega(F, bi) - omega(F, bk)
    return th, thd


def _cam_rates(G, F):
    """Cam angle, its rate and its acceleration (N, K)."""
    th, thd = _cam_angle(G, F)
    return th, thd, J.alpha(F, G.bodies[:, 0]) - J.alpha(F, G.bodies[:, 2])


_COMMON = (
    Param("roller", "length", "roller radius (0: a knife edge)", required=False, default=0.0),
    Param("pressure_limit", "angle", "largest pressure angle allowed, above 0 and below 90 deg "
          "(default 30 deg translating, 45 deg oscillating)", required=False, default=None),
    Param("range", "range", "[from, to]: the cam angles the law describes (default a full "
          "turn, then the law must be periodic)", required=False, default=None),
)
_REST = (Param("rest", "real", "s0 (cam) or psi0 (cam-rocker), from the geometry"),)

CAM_SIGN = (
    "fx, fy: the contact force on the follower j (global), along the common normal at the "
    "point of contact (through the roller's centre; normal to a flat face); torque: its moment "
    "about the follower's point sj (for a flat face the contact force times the contact's "
    "offset along the face). The cam i gets minus the force at the same point, the frame k "
    "nothing (the cam's bearing and the follower's guide or pivot take the rest). "
    "<name>.contact: its normal component, positive while the cam presses on the follower; "
    "negative where the joint holds the follower on the cam (it would lift off: warned)")


class _CamReaction:
    """The contact force of the cams: on the follower f N at the contact C, minus that on the
    cam, N the unit normal from the cam to the follower. The law's constraint has a force
    along the follower's travel (translating: -lambda u at sj; rocker: the torque -lambda about
    the pivot), and the follower's guide (pivot) takes every other part of f N; so f is the
    one whose part along the travel (moment about the pivot) is the constraint's."""

    def _contact(self, G, F, lam):
        """(f, Cx, Cy, Nx, Ny), (N, K) each, global, internal units."""
        bk = G.bodies[:, 2]
        th, _ = _cam_angle(G, F)
        N, K = th.shape
        cx, cy, nx, ny = (np.empty((N, K)) for _ in range(4))
        for k in range(K):
            P = profile(self.name, instance(G, k), th[:, k])
            cx[:, k], cy[:, k] = P["contact_x"], P["contact_y"]
            nx[:, k], ny[:, k] = P["normal_x"], P["normal_y"]
        sk = G.params["sk"]
        ox, oy = rotate(F, bk, sk[:, 0], sk[:, 1])
        xk, yk = body_xy(F, bk)
        Cx, Cy = rotate(F, bk, cx, cy)
        Cx, Cy = Cx + xk + ox, Cy + yk + oy
        Nx, Ny = rotate(F, bk, nx, ny)
        with np.errstate(invalid="ignore", divide="ignore"):
            f = -lam[..., 0] / self._lever(G, F, Cx, Cy, Nx, Ny)
        return f, Cx, Cy, Nx, Ny

    def reaction(self, G, F, lam, setup):
        f, Cx, Cy, Nx, Ny = self._contact(G, F, lam)
        out = np.zeros((F.q.shape[0], len(G), 3, 3))
        force_at(F, G.bodies[:, 1], Cx, Cy, f * Nx, f * Ny, out, 1)
        force_at(F, G.bodies[:, 0], Cx, Cy, f * Nx, f * Ny, out, 0, -1.0)
        return out

    def contact_force(self, G, F, lam, setup):
        return self._contact(G, F, lam)[0]


class Cam(_CamReaction, Kind):
    name = "cam"
    reaction_columns = ("fx", "fy", "torque")
    reaction_sign = CAM_SIGN
    sampled_zeros = False     # straight pieces, dwells: zeros on whole regions
    nbody = 3
    params = (
        Param("sk", "point", "the cam's centre of rotation on frame k, in its frame"),
        Param("vk", "vector", "the follower's direction of travel on frame k (away from the cam)"),
        Param("sj", "point", "the follower's point on j: roller centre, knife tip or the flat "
              "face's point on its axis"),
        Param("s", "law", "follower displacement above the base circle: an expression of the cam "
              "angle theta = phi_i - phi_k, or {motion: {segments: [...]}} or {table: FILE}"),
        Param("base", "length", "base circle radius (the working surface's smallest radius)"),
        Param("offset", "length", "offset of the follower axis from the cam centre along R vk",
              required=False, default=0.0),
        Param("flat", "flag", "true: a flat-faced follower (face perpendicular to vk)",
              required=False, default=False),
    ) + _COMMON
    derived = _REST
    summary = ("cam i turning on frame k (default ground) drives a translating follower j (knife "
               "edge, roller or flat face) by the law s(theta); writes cam-<name>.csv (1 equation)")
    equations = "u_k^T (P_j - C_k) - s(phi_i - phi_k) - s0 = 0 (s0: follower on the base circle)"

    def validate(self, V, params, given, what):
        check_positive(V, params, given, what, ("roller", "base"), zero_ok=("roller",))

    def _h(self, G, F):
        bj, bk = G.bodies[:, 1], G.bodies[:, 2]
        sk, sj, v = G.params["sk"], G.params["sj"], G.params["vk"]
        skx, sky = rotate(F, bk, sk[:, 0], sk[:, 1])
        sjx, sjy = rotate(F, bj, sj[:, 0], sj[:, 1])
        ux, uy = rotate(F, bk, v[:, 0], v[:, 1])
        hx = F.q[:, 3 * bj] + sjx - F.q[:, 3 * bk] - skx
        hy = F.q[:, 3 * bj + 1] + sjy - F.q[:, 3 * bk + 1] - sky
        return ux, uy, skx, sky, sjx, sjy, hx, hy

    def g(self, G, F):
        ux, uy, *_, hx, hy = self._h(G, F)
        th, _ = _cam_angle(G, F)
        return (ux * hx + uy * hy - _laws(G, "s", th, 0))[..., None]

    def grad(self, G, F):
        ux, uy, skx, sky, sjx, sjy, hx, hy = self._h(G, F)
        nx, ny = -uy, ux
        th, _ = _cam_angle(G, F)
        s1 = _laws(G, "s", th, 1)
        out = np.zeros((F.q.shape[0], len(G), 1, 9))
        out[..., 0, 2] = -s1
        out[..., 0, 3] = ux
        out[..., 0, 4] = uy
        out[..., 0, 5] = -(nx * sjx + ny * sjy)
        out[..., 0, 6] = -ux
        out[..., 0, 7] = -uy
        out[..., 0, 8] = nx * (hx + skx) + ny * (hy + sky) + s1
        return out

    def gamma(self, G, F):
        ux, uy, skx, sky, sjx, sjy, hx, hy = self._h(G, F)
        nx, ny = -uy, ux
        bj, bk = G.bodies[:, 1], G.bodies[:, 2]
        wk, wj, hdx, hdy = relative_velocity(F, bk, bj, skx, sky, sjx, sjy)
        kx = wj * wj * sjx - wk * wk * skx
        ky = wj * wj * sjy - wk * wk * sky
        th, thd = _cam_angle(G, F)
        s2 = _laws(G, "s", th, 2)
        out = (wk * wk * (ux * hx + uy * hy) - 2.0 * wk * (nx * hdx + ny * hdy)
               + ux * kx + uy * ky + s2 * thd * thd)
        return out[..., None]

    def jerk(self, G, F):
        ux, uy, skx, sky, sjx, sjy, hx, hy = self._h(G, F)
        bj, bk = G.bodies[:, 1], G.bodies[:, 2]
        u = J.fixed(F, bk, (ux, uy))
        h = J.pair(F, bk, (skx, sky), bj, (sjx, sjy))
        th, thd, thdd = _cam_rates(G, F)
        s3 = J.chain_rule3(_laws(G, "s", th, 2), _laws(G, "s", th, 3), thd, thdd)
        return (s3 - J.dot(u, h))[..., None]

    def diagnose(self, arrays, L, af, lu, au):
        return check(self.name, arrays, L, af, lu, au)

    def _lever(self, G, F, Cx, Cy, Nx, Ny):
        """N^T u: the part of a unit contact force along the follower's travel."""
        ux, uy = rotate(F, G.bodies[:, 2], G.params["vk"][:, 0], G.params["vk"][:, 1])
        return Nx * ux + Ny * uy

    def prepare(self, arrays, poses):
        if arrays["flat"] > 0.5:
            s0 = float(arrays["base"])
        else:
            rp, e = float(arrays["base"] + arrays["roller"]), float(arrays["offset"])
            s0 = math.sqrt(max(rp * rp - e * e, 0.0))
        # theta0 (the drawn cam angle) is not a Group parameter: only `diagnose` reads it
        return {"rest": np.float64(s0), "theta0": poses[0][2] - poses[2][2]}, [s0]

    def draw(self, G, k, parts):
        """The working surface on the cam, the roller, a flat follower's face."""
        draw_cam(G, k, parts)


class CamRocker(_CamReaction, Kind):
    name = "cam-rocker"
    reaction_columns = ("fx", "fy", "torque")
    reaction_sign = CAM_SIGN
    sampled_zeros = False     # straight pieces, dwells: zeros on whole regions
    nbody = 3
    params = (
        Param("sk", "point", "the cam's centre of rotation on frame k, in its frame"),
        Param("pk", "point", "the rocker's pivot on frame k, in its frame"),
        Param("pj", "point", "the rocker's pivot on j, in its frame", required=False,
              default=(0.0, 0.0)),
        Param("sj", "point", "the follower's roller centre (or knife tip, or a point of the "
              "flat face) on j, in its frame"),
        Param("psi", "angle-law", "rocker angle from its drawn rest: an expression of the cam "
              "angle theta = phi_i - phi_k, or {motion: {segments: [...]}} or {table: FILE}"),
    ) + _COMMON + (
        Param("flat", "flag", "true: a flat-faced rocker, its face the line through sj along "
              "face", required=False, default=False),
        Param("face", "vector", "direction of the flat face on j, in its frame (default: along "
              "sj - pj, a face through the pivot)", required=False, default=None),
    )
    derived = _REST
    summary = ("cam i turning on frame k (default ground) swings a rocker j (knife edge, roller "
               "or flat face) by the law psi(theta); writes cam-<name>.csv (1 equation)")
    equations = "phi_j - phi_k - psi(phi_i - phi_k) - psi0 = 0 (psi0 as drawn)"

    def validate(self, V, params, given, what):
        check_positive(V, params, given, what, ("roller", "base"), zero_ok=("roller",))

    def g(self, G, F):
        bj, bk = G.bodies[:, 1], G.bodies[:, 2]
        th, _ = _cam_angle(G, F)
        return (F.q[:, 3 * bj + 2] - F.q[:, 3 * bk + 2] - _laws(G, "psi", th, 0))[..., None]

    def grad(self, G, F):
        th, _ = _cam_angle(G, F)
        p1 = _laws(G, "psi", th, 1)
        out = np.zeros((F.q.shape[0], len(G), 1, 9))
        out[..., 0, 2] = -p1
        out[..., 0, 5] = 1.0
        out[..., 0, 8] = -1.0 + p1
        return out

    def gamma(self, G, F):
        th, thd = _cam_angle(G, F)
        return (_laws(G, "psi", th, 2) * thd * thd)[..., None]

    def jerk(self, G, F):
        th, thd, thdd = _cam_rates(G, F)
        return J.chain_rule3(_laws(G, "psi", th, 2), _laws(G, "psi", th, 3), thd,
                             thdd)[..., None]

    def diagnose(self, arrays, L, af, lu, au):
        return check(self.name, arrays, L, af, lu, au)

    def _lever(self, G, F, Cx, Cy, Nx, Ny):
        """(C - pivot) x N: the moment of a unit contact force about the rocker's pivot."""
        bj = G.bodies[:, 1]
        x, y = body_xy(F, bj)
        px, py = rotate(F, bj, G.params["pj"][:, 0], G.params["pj"][:, 1])
        return (Cx - x - px) * Ny - (Cy - y - py) * Nx

    def prepare(self, arrays, poses):
        th0 = poses[0][2] - poses[2][2]
        psi0 = (poses[1][2] - poses[2][2]) - float(arrays["psi"](np.array([th0]))[0][0])
        return {"rest": np.float64(psi0), "theta0": th0}, [psi0]

    def draw(self, G, k, parts):
        """The working surface on the cam, the roller, a flat rocker's face."""
        draw_cam(G, k, parts)


# -- the profile, by kinematic inversion ---------------------------------------------------------

def _rot(c, s, x, y):
    return c * x - s * y, s * x + c * y


def profile(kind: str, par: dict, theta) -> dict:
    """The cam's profile where the cam angle is theta (N,) rad, exactly from the law's s, s', s''.

    par: one instance's parameters (internal units, as in a Group, plus 'rest'). In frame k,
    relative to the cam centre, the follower point is w(theta) with w', w'' (translating:
    w = e n + (s0 + s) u; rocker: w = D + A(psi0 + psi) a', D the pivot, a' the arm); in the
    cam's frame it is p = A(-theta) w, so p' = A(-theta)(w' - R w), p'' = A(-theta)(w'' - 2 R w'
    - w). Returns (N,) arrays: value (s or psi), pitch x, y (the roller centre / tip / face point
    on the axis, cam frame), surface x, y (the working surface: the pitch curve offset inwards by
    the roller radius along its normal; for a flat face the envelope of the face), rho_pitch
    (signed radius of curvature of the pitch curve, > 0 where convex), rho_surface, pressure
    (the angle between the contact normal and the follower point's direction of motion, rad)."""
    theta = np.asarray(theta, dtype=float)
    if kind == "cam":
        s, s1, s2 = par["s"](theta)
        ux, uy = par["vk"]
        nx, ny = -uy, ux
        e = float(par["offset"])
        d = par["rest"] + s
        wx, wy = e * nx + d * ux, e * ny + d * uy
        w1x, w1y = s1 * ux, s1 * uy
        w2x, w2y = s2 * ux, s2 * uy
        mx, my = ux + 0 * s, uy + 0 * s                   # the follower's direction of motion
        value = s
    else:
        p0, p1, p2 = par["psi"](theta)
        ang = par["rest"] + p0
        a = np.asarray(par["sj"]) - np.asarray(par["pj"])
        ax_, ay_ = _rot(np.cos(ang), np.sin(ang), a[0], a[1])
        D = np.asarray(par["pk"]) - np.asarray(par["sk"])
        wx, wy = D[0] + ax_, D[1] + ay_
        w1x, w1y = -p1 * ay_, p1 * ax_                    # psi' R A a'
        w2x, w2y = -p2 * ay_ - p1 * p1 * ax_, p2 * ax_ - p1 * p1 * ay_
        mx, my = -ay_, ax_
        value = p0
    # frame-k components of the cam-frame derivatives (a rotation keeps lengths and crossings)
    vx, vy = w1x + wy, w1y - wx                           # w' - R w
    qx, qy = w2x + 2.0 * w1y - wx, w2y - 2.0 * w1x - wy   # w'' - 2 R w' - w
    speed = np.hypot(vx, vy)
    cross = vx * qy - vy * qx
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = -speed**3 / cross
        Nx, Ny = -vy / speed, vx / speed                  # outward normal R v / |v|
    c, sn = np.cos(-theta), np.sin(-theta)
    px, py = _rot(c, sn, wx, wy)
    roller = float(par.get("roller", 0.0))
    if kind == "cam" and par["flat"] > 0.5:
        # envelope of the face u^T x = base + s turning by -theta: contact at d u - s' n
        fx, fy = d * ux - s1 * nx, d * uy - s1 * ny
        sx, sy = _rot(c, sn, fx, fy)
        rho_s = d + s2
        pressure = np.zeros_like(theta)
        contact = (fx, fy, mx, my)
    elif kind == "cam-rocker" and par.get("flat", 0.0) > 0.5:
        sx, sy, rho_s, pressure, contact = _flat_rocker(par, theta, ang, p1, p2, D)
    else:
        nxc, nyc = _rot(c, sn, Nx, Ny)
        sx, sy = px - roller * nxc, py - roller * nyc
        rho_s = rho - roller
        dot = np.abs(mx * Nx + my * Ny)
        pressure = np.arctan2(np.abs(mx * Ny - my * Nx), dot)
        contact = (wx - roller * Nx, wy - roller * Ny, Nx, Ny)
    return {"value": value, "pitch_x": px, "pitch_y": py, "surface_x": sx, "surface_y": sy,
            "rho_pitch": rho, "rho_surface": rho_s, "pressure": pressure,
            "contact_x": contact[0], "contact_y": contact[1], "normal_x": contact[2],
            "normal_y": contact[3]}


def _flat_rocker(par, theta, ang, p1, p2, D):
    """Surface point (cam frame), its radius of curvature and the pressure angle of a flat-faced
    rocker. In frame k, about the cam centre, the face is the line m^T x = h with m = R e the
    normal of the face's direction e = A(beta) f' (beta = the rocker's angle ang, f' the face
    on j) and h = m^T D + f0 (f0 = (R f')^T (sj - pj), the face's offset from the pivot). Seen
    from the cam the normal has the angle g = beta + beta0 + pi/2 - theta, so g' = psi' - 1,
    g'' = psi''. The working surface is the envelope of these lines: y = h n + (dh/dg) R n,
    radius of curvature sigma (h + d2h/dg2), sigma = sign(h) (the cam centre on the face's inner
    side: a convex cam has h > 0 along its normal). Pressure angle: between the contact normal and
    the direction the rocker moves its contact point, R (Y - D) for the contact Y in frame k."""
    a = np.asarray(par["sj"], float) - np.asarray(par["pj"], float)
    f = np.asarray(par["face"], float)
    f = a / np.hypot(*a) if not np.isfinite(f).all() else f / np.hypot(*f)
    f0 = -f[1] * a[0] + f[0] * a[1]                       # (R f')^T (sj - pj)
    beta = ang + math.atan2(f[1], f[0])
    mx, my = -np.sin(beta), np.cos(beta)                  # R e, frame k
    h = mx * D[0] + my * D[1] + f0
    hb = -(np.cos(beta) * D[0] + np.sin(beta) * D[1])     # dh/dbeta
    hbb = -(h - f0)                                       # d2h/dbeta2
    h1 = p1 * hb                                          # dh/dtheta
    h2 = p2 * hb + p1 * p1 * hbb
    g1 = p1 - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        hg = h1 / g1
        hgg = (h2 * g1 - h1 * p2) / g1**3
    sigma = np.sign(h)
    Yx, Yy = h * mx - hg * my, h * my + hg * mx           # contact point, frame k
    c, sn = np.cos(-theta), np.sin(-theta)
    sx, sy = _rot(c, sn, Yx, Yy)
    rho_s = sigma * (h + hgg)
    vx, vy = -(Yy - D[1]), Yx - D[0]                      # R (Y - D)
    pressure = np.arctan2(np.abs(vx * my - vy * mx), np.abs(vx * mx + vy * my))
    return sx, sy, rho_s, pressure, (Yx, Yy, sigma * mx, sigma * my)


def instance(G, k: int) -> dict:
    """One instance's parameters of a Group of a cam kind (internal units)."""
    return {name: v[k] for name, v in G.params.items()}


def check(kind: str, par: dict, L: float, af: float, lu: str, au: str) -> list[str]:
    """What makes the cam unusable, as messages (user units): an undercut profile, a pressure
    angle past the limit, a full-turn law that does not close. Sampled every 0.125 degrees of
    the law's range and at its ends (a check, not a result: the profile itself is exact)."""
    msgs = []
    lim = par["pressure_limit"]
    if not np.isnan(lim) and not 0 < lim < math.pi / 2:
        return [f"pressure_limit must be more than 0 and less than {math.pi / 2 / af:g} {au} (a "
                f"pressure angle of {math.pi / 2 / af:g} {au} locks the follower), not "
                f"{lim / af:g} {au}"]
    if kind == "cam" and not par["flat"] > 0.5 and not abs(par["offset"]) < par["base"] + \
            par["roller"]:
        return [f"the follower axis' offset {abs(par['offset']) * L:.4g} {lu} must be smaller "
                f"than base + roller = {(par['base'] + par['roller']) * L:.4g} {lu} (the follower "
                f"would miss the cam)"]
    law = par["s" if kind == "cam" else "psi"]
    dom = getattr(getattr(law, "fn", None), "domain", None)
    if dom is not None and "theta0" in par and not dom[0] <= law.a * par["theta0"] <= dom[1]:
        return [f"the cam is drawn at theta = {law.a * par['theta0']:.6g} {au}, outside the "
                f"angles of its law's table ({dom[0]:g} to {dom[1]:g} {au}); draw the cam (its "
                f"q angle) within them"]
    lo, hi = par["range"]
    full = not np.isfinite(lo)
    if full:
        lo, hi = 0.0, 2.0 * math.pi
    n = max(int(math.ceil((hi - lo) / (2.0 * math.pi) * SAMPLES_PER_TURN)), 16) + 1
    th = np.linspace(lo, hi, n)
    law = par["s" if kind == "cam" else "psi"]
    ends = [law(np.array([x])) for x in (lo, hi)]
    unit = lambda x: f"{x * L:.4g} {lu}"
    deg = lambda x: f"{x / af:.4g} {au}"
    if full:
        names = ("value", "first derivative", "second derivative")
        for o in range(3):
            jump = float(ends[1][o][0] - ends[0][o][0])
            scale = max(float(np.max(np.abs(law(th)[o]))), 1e-300)
            if abs(jump) > 1e-9 * scale:
                msgs.append(f"the law {law.text!r} does not close over a full turn: its {names[o]} "
                            f"differs by {abs(jump) / scale:.3g} (relative) between theta = 0 "
                            f"and 360 deg; give range: [from, to] for the part of the turn it "
                            f"describes")
                break
    P = profile(kind, par, th)
    flat = kind == "cam" and par["flat"] > 0.5
    roller = float(par.get("roller", 0.0))
    if kind == "cam-rocker" and par.get("flat", 0.0) > 0.5:
        msgs += _check_flat_rocker(par, P, th, deg, unit)
    elif flat:
        bad = ~(P["rho_surface"] > 0)
        if bad.any():
            k = int(np.argmin(np.where(np.isfinite(P["rho_surface"]), P["rho_surface"], -np.inf)))
            need = float(par["base"] - np.min(P["rho_surface"]))
            msgs.append(f"the profile undercuts at theta = {deg(th[k])}: base + s + s'' = "
                        f"{unit(P['rho_surface'][k])} is not positive (the flat face "
                        f"cannot touch the cam there); use a base circle larger than "
                        f"{unit(need)}")
    else:
        rho = P["rho_pitch"]
        convex = ~(rho < 0)
        bad = convex & ~(rho > roller)
        if bad.any():
            k = int(np.flatnonzero(bad)[np.argmin(np.where(np.isfinite(rho[bad]), rho[bad], 0))])
            msgs.append(f"the profile undercuts at theta = {deg(th[k])}: the pitch curve's radius "
                        f"of curvature {unit(rho[k])} is not larger than the roller "
                        f"radius {unit(roller)}; use a larger base circle or a smaller "
                        f"roller")
        lim = par["pressure_limit"]
        lim = DEFAULT_LIMIT[kind] if not np.isfinite(lim) else float(lim)
        k = int(np.argmax(P["pressure"]))
        if P["pressure"][k] > lim:
            msgs.append(f"the pressure angle reaches {deg(P['pressure'][k])} at theta = "
                        f"{deg(th[k])}, more than pressure_limit = {deg(lim)}; use a larger base "
                        f"circle, spread the rise over a larger cam angle or raise pressure_limit")
    return msgs


def _check_flat_rocker(par, P, th, deg, unit) -> list[str]:
    """A flat-faced rocker's undercut (the envelope's radius of curvature not positive: the face
    cannot touch the cam there) and pressure angle."""
    msgs = []
    rho = P["rho_surface"]
    bad = ~(rho > 0)
    if bad.any():
        k = int(np.flatnonzero(bad)[np.argmin(np.where(np.isfinite(rho[bad]), rho[bad], -np.inf))])
        msgs.append(f"the profile undercuts at theta = {deg(th[k])}: the working surface's radius "
                    f"of curvature {unit(rho[k])} is not positive (the flat face cannot touch "
                    f"the cam there); use a gentler law (a smaller psi'' or a larger swing "
                    f"angle), or move the pivot or the face further from the cam centre")
    lim = par["pressure_limit"]
    lim = DEFAULT_LIMIT["cam-rocker"] if not np.isfinite(lim) else float(lim)
    k = int(np.argmax(P["pressure"]))
    if P["pressure"][k] > lim:
        msgs.append(f"the pressure angle reaches {deg(P['pressure'][k])} at theta = "
                    f"{deg(th[k])}, more than pressure_limit = {deg(lim)}; move the pivot, spread "
                    f"the swing over a larger cam angle or raise pressure_limit")
    return msgs


# -- the angles a law describes: refused past its range --------------------------------------------

RANGE_TOL = 1e-9        # rad: a cam angle this far past its law's range is still in it (rounding)


def row_checks(cm, opts) -> list:
    """[check(an, chunk)] for the cams whose law has a `range:`: the law and its profile were
    checked over that range only (a full-turn law over the whole turn), so a row whose cam angle
    lies outside it is refused, the run stopping there, as a full-turn law that does not close
    is refused before the run (issue 21, item 4)."""
    out = []
    nb, af, au = cm.nb, cm.angle_factor, cm.spec.angle_unit
    for G in cm.groups:
        if G.kind.name not in ("cam", "cam-rocker"):
            continue
        for k in range(len(G)):
            lo, hi = (float(x) for x in G.params["range"][k])
            if not (np.isfinite(lo) and np.isfinite(hi)):
                continue
            el = cm.element_of_row(int(G.rows[k, 0]))
            bi, bk = int(G.bodies[k, 0]), int(G.bodies[k, 2])
            out.append(_range_check(el.label, bi, bk, nb, lo, hi, af, au))
    return out


def _range_check(label, bi, bk, nb, lo, hi, af, au):
    def check(an, ch):
        th = ch.q[:, 3 * bi + 2] - (ch.q[:, 3 * bk + 2] if bk != nb else 0.0)
        x = th * af
        bad = ~((x >= lo - RANGE_TOL) & (x <= hi + RANGE_TOL))
        if not bad.any():
            return None
        i = int(np.argmax(bad))
        return (i, f"{label}: the cam angle theta = {th[i]:.6g} {au} at t = "
                   f"{float(ch.t[i]):.10g} s is outside the law's range [{lo / af:g}, "
                   f"{hi / af:g}] {au}: the law and its profile are checked over that range "
                   f"only; give the law over every angle the cam turns through (its range, "
                   f"or a full turn), or end the analysis sooner; rows are written up to the "
                   f"one before", "range")
    return check


# -- cam-<name>.csv: the room of planarkin.derived ------------------------------------------------

def derived_tables(cm, opts) -> list:
    """One table cam-<name>.csv per cam (name: the element's name, else joint<index>): per grid
    row the cam angle, the law's value and the profile point in contact then (cam frame), its
    radii of curvature and the pressure angle. A run over one turn at constant speed is the
    manufacturing table of the whole profile."""
    from ..derived import DerivedTable

    out = []
    lu, au = cm.spec.length_unit, cm.spec.angle_unit
    for c in cam_joints(cm):
        value = f"s [{lu}]" if c.kind == "cam" else f"psi [{au}]"
        header = ["t [s]", f"theta [{au}]", value, f"pitch.x [{lu}]", f"pitch.y [{lu}]",
                  f"surface.x [{lu}]", f"surface.y [{lu}]", f"rho_pitch [{lu}]",
                  f"rho_surface [{lu}]", f"pressure_angle [{au}]"]
        out.append(DerivedTable(f"cam-{c.name}.csv", header,
                                _table(cm, c.kind, c.par, c.bodies)))
    return out


class CamJoint(NamedTuple):
    """One cam joint of a model: name (the element's name, else <role><index>: its table is
    cam-<name>.csv), kind ("cam" or "cam-rocker"), par (its parameters, internal units, as
    `instance` gives them), bodies (i, j, k) and label (the element's message label)."""
    name: str
    kind: str
    par: dict
    bodies: tuple
    label: str


def cam_joints(cm) -> list[CamJoint]:
    """Every cam joint of the compiled model cm, in the order of their tables (`derived_tables`):
    what cam-<name>.csv and the cam figures (planarkin.output.plots.cam) are made from."""
    out = []
    for G in cm.groups:
        if G.kind.name not in ("cam", "cam-rocker"):
            continue
        for k in range(len(G)):
            el = cm.element_of_row(int(G.rows[k, 0]))
            out.append(CamJoint(el.name or f"{el.role}{el.index}", G.kind.name, instance(G, k),
                                tuple(int(b) for b in G.bodies[k]), el.label))
    return out


def _table(cm, kind, par, bodies):
    L, af, nb = cm.L, cm.angle_factor, cm.nb
    bi, bk = int(bodies[0]), int(bodies[2])
    value_scale = L if kind == "cam" else 1.0 / af

    def compute(ch):
        th = ch.q[:, 3 * bi + 2] - (ch.q[:, 3 * bk + 2] if bk != nb else 0.0)
        P = profile(kind, par, th * af)
        cols = [ch.t, th, P["value"] * value_scale]
        cols += [P[c] * L for c in ("pitch_x", "pitch_y", "surface_x", "surface_y", "rho_pitch",
                                    "rho_surface")]
        cols.append(P["pressure"] / af)
        return np.column_stack(cols)

    return compute


def draw_cam(G, k: int, parts) -> None:
    """cam, cam-rocker: the working surface over the law's range on the cam (about its pivot on
    the frame k), the roller, and a flat follower's face."""
    from .drawing import circle             # (a leaf module: numpy only)
    parts.joint_points(G, k)
    par = instance(G, k)
    bi, bj, bk = (int(b) for b in G.bodies[k])
    lo, hi = par["range"]
    if not np.isfinite(lo):
        lo, hi = 0.0, 2 * np.pi
    P = profile(G.kind.name, par, np.linspace(lo, hi, 181))
    centre = parts.pivot(bi, bk)
    parts.shape(bi)
    parts.outline(bi, centre + np.c_[P["surface_x"], P["surface_y"]] * parts.L, surface=True)
    roller = float(par["roller"]) * parts.L
    if roller > 0:
        parts.outline(bj, circle(parts.point(G, k, "sj"), roller, 31), surface=True)
    face = _flat_face(G, k, par, parts.phi)
    if face is not None:
        parts.face(bj, face * parts.L)


def _flat_face(G, k: int, par: dict, phi):
    """A flat follower's face (cam, cam-rocker with flat: true), in j's frame (internal units):
    a segment over every point of contact of the law's range, with a margin, from the face's
    own point sj on (a corner of the body's outline); None for other followers. The contact
    point c and the face's point w (the pitch point of the profile) both lie on the face: its
    position along the face, seen from the cam, is (c - w)^T e for the face's direction e there.
    phi: (N, nb) the bodies' angles (rad) over the run (a translating follower's face direction
    on its body: the angle between it and the frame its axis is given in, constant)."""
    if not par.get("flat", 0.0) > 0.5:
        return None
    bj, bk = int(G.bodies[k, 1]), int(G.bodies[k, 2])
    lo, hi = par["range"]
    if not np.isfinite(lo):
        lo, hi = 0.0, 2 * np.pi
    th = np.linspace(lo, hi, 361)
    P = profile(G.kind.name, par, th)
    dx, dy = P["surface_x"] - P["pitch_x"], P["surface_y"] - P["pitch_y"]   # cam frame
    ang = lambda b: phi[0, b] if b < phi.shape[1] else 0.0              # noqa: E731 - ground
    if G.kind.name == "cam-rocker":
        a = np.asarray(par["sj"], float) - np.asarray(par["pj"], float)
        f = np.asarray(par["face"], float)
        f = a / np.hypot(*a) if not np.isfinite(f).all() else f / np.hypot(*f)
        e = par["rest"] + par["psi"](th)[0] + np.arctan2(f[1], f[0]) - th     # e's angle
    else:       # the face perpendicular to the travel u: along R u, on j at a fixed angle
        u = np.asarray(par["vk"], float)
        rel = ang(bk) - ang(bj)
        n = np.array([-u[1], u[0]]) / np.hypot(*u)
        f = np.array([np.cos(rel) * n[0] - np.sin(rel) * n[1],
                      np.sin(rel) * n[0] + np.cos(rel) * n[1]])
        e = np.arctan2(n[1], n[0]) - th
    xi = dx * np.cos(e) + dy * np.sin(e)
    if not np.isfinite(xi).all():
        return None
    a0, a1 = xi.min(), xi.max()
    pad = 0.15 * (a1 - a0) + 0.05 * np.hypot(*np.c_[P["surface_x"], P["surface_y"]].T).max()
    a0, a1 = min(a0 - pad, 0.0), max(a1 + pad, 0.0)     # from the face's point on: the body
    sj = np.asarray(par["sj"], float)
    return np.array([sj + a0 * f, sj + a1 * f])
