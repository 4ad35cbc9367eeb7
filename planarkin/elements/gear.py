"""Gear pair on fixed centres or on a common carrier (reference §3.1).

Signed pitch radii: ri, rj > 0 for external gears; the ring of an internal pair has a negative
radius. The centre distance |ri + rj| itself comes from other joints (revolutes to the carrier).
The phase constant is fixed by the body angles given in the model (the gears mesh as drawn).
"""

from __future__ import annotations

import math

import numpy as np

from .base import Kind, Param, body_xy, force_at, gradient_force, rotate

DEFAULT_PRESSURE_ANGLE = math.radians(20.0)      # the standard involute tooth
PRESSURE_ANGLE = Param("pressure_angle", "angle", "pressure angle of the teeth, 0 to 45 deg "
                       "(the tooth force's angle to the pitch circles' tangent; default 20 deg)",
                       required=False, default=None)


def pressure_tan(G) -> np.ndarray:
    """(K,) tan of every instance's pressure angle (the default where none is given)."""
    a = G.params["pressure_angle"]
    return np.tan(np.where(np.isfinite(a), a, DEFAULT_PRESSURE_ANGLE))


def check_pressure_angle(arrays, af, au) -> list:
    """The pressure angle's range, as messages (user units)."""
    a = float(arrays["pressure_angle"])
    if math.isfinite(a) and not 0.0 <= a <= math.radians(45.0) + 1e-12:
        return [f"pressure_angle must be between 0 and {math.radians(45.0) / af:g} {au}, not "
                f"{a / af:g} {au} (involute teeth: 14.5, 20 or 25 deg)"]
    return []


COAXIAL_TOL = 1e-9     # two revolute points of one body this close (internal units) are one axis


def centre_on(pivots, b: int, k: int):
    """The centre of gear (pulley) b on its carrier k: (2,) in b's frame, internal units, or None.
    It is where b turns on k (their revolute joint), or where b turns on a body about the same
    point as k does: a sun on the frame, coaxial with the carrier that turns on the frame too,
    has no joint to the carrier, yet its centre is fixed on it all the same."""
    if b == k:
        return None
    c = pivots.get((b, k))
    if c is not None:
        return c
    for (x, y), on_b in pivots.items():
        if x != b:
            continue
        k_on_y = pivots.get((y, k))
        if k_on_y is not None and np.abs(pivots[(y, b)] - k_on_y).max() <= COAXIAL_TOL:
            return on_b
    return None


def carrier_centres(G, pivots):
    """{'ci', 'cj'}: (K, 2) the centres of i and j in their own frames on the carrier k
    (`centre_on`; NaN where there is none), and 'ok' (K,) where both are known."""
    K = len(G)
    ci, cj = np.full((K, 2), np.nan), np.full((K, 2), np.nan)
    for k, (bi, bj, bk) in enumerate(G.bodies):
        for c, b in ((ci, bi), (cj, bj)):
            found = centre_on(pivots, int(b), int(bk))
            if found is not None:
                c[k] = found
    return {"ci": ci, "cj": cj, "ok": np.isfinite(ci).all(axis=1) & np.isfinite(cj).all(axis=1)}


MESH_WARN = 1e-6      # relative centre-distance error of a gear pair that is worth a warning
MESH_ERROR = 0.1      # ... and that no tooth form can take up: an error


def mesh_check(k, d, ri, rj, L, lu) -> list:
    """check_pose of a gear pair whose centres are d apart (internal units): its centre distance
    must be |ri + rj| (a warning above MESH_WARN relative, an error above MESH_ERROR: the teeth
    cannot mesh)."""
    want = abs(ri + rj)
    dev = abs(d - want) / want
    if not dev > MESH_WARN:
        return []
    grossly = dev > MESH_ERROR
    return [(k, "error" if grossly else "warning",
             f"the centre distance is {d * L:.6g} {lu} but the pitch radii give |ri + rj| = "
             f"{want * L:.6g} {lu}" + (" (more than 10% off: the teeth cannot mesh); correct the "
                                       "radii or the centres" if grossly else "; the gears turn "
                                       "at the ratio of the radii all the same"))]


def centre_gap(F, G, k, ci, cj) -> float:
    """Distance (internal units) of instance k's centres ci on i and cj on j (body frames)."""
    bi, bj = G.bodies[k:k + 1, 0], G.bodies[k:k + 1, 1]
    xi, yi = global_point(F, bi, np.asarray(ci, float)[None, :])
    xj, yj = global_point(F, bj, np.asarray(cj, float)[None, :])
    return float(np.hypot(xj - xi, yj - yi)[0, 0])


def carrier_pairs(G, pivots):
    """(k, centre of i, centre of j) of the instances whose bodies' centres on their carrier k
    are known (`centre_on`; the others are not checked)."""
    for k, (bi, bj, bk) in enumerate(G.bodies):
        ci, cj = centre_on(pivots, int(bi), int(bk)), centre_on(pivots, int(bj), int(bk))
        if ci is not None and cj is not None:
            yield k, ci, cj


def global_point(F, b, s):
    """Global (x, y), (N, K), of body-frame points s (K, 2) of bodies b (K,)."""
    x, y = body_xy(F, b)
    sx, sy = rotate(F, b, s[:, 0], s[:, 1])
    return x + sx, y + sy


class Gear(Kind):
    name = "gear"
    reaction_columns = ("fx", "fy", "torque")    # the tooth force, its moment about j
    nbody = 3
    params = (
        Param("ri", "length", "signed pitch radius of gear i (negative for an internal ring gear)"),
        Param("rj", "length", "signed pitch radius of gear j (negative for an internal ring gear)"),
    )
    summary = ("gear pair on fixed centres or a common carrier k (default ground): "
               "ri (phi_i - phi_k) + rj (phi_j - phi_k) = c (1 equation)")
    equations = "ri (phi_i - phi_k) + rj (phi_j - phi_k) - c0 = 0 (c0 from the given body angles)"
    params = params + (PRESSURE_ANGLE,)
    reaction_sign = (
        "fx, fy: the tooth force on gear j (global), along the line of action through the pitch "
        "point (the relative pole of i and j on the line of their centres: their revolute joints "
        "to the carrier k, or about k's axis): its tangential part F_t = T_j / rj, its radial "
        "part |F_t| tan"
        "(pressure_angle) pushing the gears apart; torque: its moment about j's centre (the "
        "torque the teeth put on j, counter-clockwise positive). Gear i gets minus the force at "
        "the same point; the carrier nothing (its bearings take the rest)")

    def check_pose(self, G, F, pivots, L, lu):
        out = []
        for k, ci, cj in carrier_pairs(G, pivots):
            out += mesh_check(k, centre_gap(F, G, k, ci, cj), float(G.params["ri"][k]),
                              float(G.params["rj"][k]), L, lu)
        return out

    def prepare(self, arrays, poses):
        # the phase constant: the gears mesh as drawn
        pi_, pj, pk = (p[2] for p in poses)
        return {}, [arrays["ri"] * (pi_ - pk) + arrays["rj"] * (pj - pk)]

    def diagnose(self, arrays, L, af, lu, au):
        return check_pressure_angle(arrays, af, au)

    def reaction_setup(self, G, pivots, L):
        return carrier_centres(G, pivots)

    def reaction_point(self, G, F, setup):
        x, y = body_xy(F, G.bodies[:, 1])
        cx, cy = global_point(F, G.bodies[:, 1], np.nan_to_num(setup["cj"]))
        ok = setup["ok"]
        return np.where(ok, cx, x), np.where(ok, cy, y)

    def reaction(self, G, F, lam, setup):
        out = gradient_force(G, F, lam)
        ok = setup["ok"]
        if not ok.any():
            return out
        bi, bj = G.bodies[:, 0], G.bodies[:, 1]
        xi, yi = global_point(F, bi, np.nan_to_num(setup["ci"]))
        xj, yj = global_point(F, bj, np.nan_to_num(setup["cj"]))
        ri, rj = self._radii(G)
        S = ri + rj
        dx, dy = xj - xi, yj - yi
        dist = np.hypot(dx, dy)
        with np.errstate(invalid="ignore", divide="ignore"):
            ex, ey = dx / dist, dy / dist
        px, py = xi + ri * dx / S, yi + ri * dy / S          # the pitch point, relative pole
        ft = lam[..., 0] * S / dist                           # along R e on j
        fr = np.abs(ft) * pressure_tan(G) * np.sign(S)        # along e on j: apart
        fx, fy = -ft * ey + fr * ex, ft * ex + fr * ey
        phys = np.zeros_like(out)
        force_at(F, bj, px, py, fx, fy, phys, 1)
        force_at(F, bi, px, py, fx, fy, phys, 0, -1.0)
        return np.where(ok[None, :, None, None], phys, out)

    @staticmethod
    def _radii(G):
        """The coefficients of phi_i and phi_j (a belt changes the sign of rj)."""
        return G.params["ri"], G.params["rj"]

    def g(self, G, F):
        bi, bj, bk = G.bodies[:, 0], G.bodies[:, 1], G.bodies[:, 2]
        ri, rj = self._radii(G)
        pk = F.q[:, 3 * bk + 2]
        return (ri * (F.q[:, 3 * bi + 2] - pk) + rj * (F.q[:, 3 * bj + 2] - pk))[..., None]

    def grad(self, G, F):
        ri, rj = self._radii(G)
        out = np.zeros((F.q.shape[0], len(G), 1, 9))
        out[..., 0, 2] = ri
        out[..., 0, 5] = rj
        out[..., 0, 8] = -(ri + rj)
        return out

    def gamma(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 1))

    def jerk(self, G, F):
        return np.zeros((F.q.shape[0], len(G), 1))

    def draw(self, G, k, parts):
        """Both pitch circles, about each gear's pivot on the carrier k."""
        bi, _, bj, _ = parts.joint_points(G, k)
        bk = parts.body(G, k, 2)
        parts.disc(bi, parts.point(G, k, "ri"), bk)
        parts.disc(bj, parts.point(G, k, "rj"), bk)
