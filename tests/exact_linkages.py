"""Exact (50-digit) kinematics of the linkages in tests/linkages.py, for any set of link lengths.

The pins are built by the same circle intersections as linkages.py, in mpmath at 50 digits, from
lengths given per pair of pins (the published ones, or those of a model's own rounded geometry);
velocities and accelerations are central differences in the driver's time at h = 1e-15, whose
truncation (h^2 ~ 1e-30) and rounding (1e-50 / h^2 = 1e-20) errors are far below double
precision. Used by tests only (finite differences belong in tests)."""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np

# each linkage: ground pins, the crank (axle, pin), then pin = circles(p, |p pin|, q, |q pin|,
# side), in the order and on the sides of linkages.py
BUILD = {
    "jansen": (("O", "B"), ("O", "A"),
               (("X", "A", "B", -1), ("F", "A", "B", +1), ("E", "X", "B", -1),
                ("G", "E", "F", -1), ("H", "G", "F", -1))),
    "klann": (("A", "B", "D"), ("A", "C"),
              (("H", "C", "B", -1), ("F", "C", "H", +1), ("E", "D", "F", -1),
               ("G", "E", "F", +1))),
    "peaucellier": (("O", "Q"), ("Q", "C"),
                    (("A", "O", "C", +1), ("B", "O", "C", -1), ("P", "A", "B", +1))),
}


def _circles(p, rp, q, rq, side):
    dx, dy = q[0] - p[0], q[1] - p[1]
    d = mp.hypot(dx, dy)
    a = (rp * rp - rq * rq + d * d) / (2 * d)
    h = mp.sqrt(rp * rp - a * a)
    ux, uy = dx / d, dy / d
    return (p[0] + a * ux - side * h * uy, p[1] + a * uy + side * h * ux)


def pins_at(key, ground_xy: dict, length, phi):
    """All pins at crank angle phi (mp, rad): ground_xy the ground pins, length(p, q) -> mp."""
    ground, (axle, pin), steps = BUILD[key]
    P = {g: (mp.mpf(ground_xy[g][0]), mp.mpf(ground_xy[g][1])) for g in ground}
    r = length(axle, pin)
    P[pin] = (P[axle][0] + r * mp.cos(phi), P[axle][1] + r * mp.sin(phi))
    for name, p, q, side in steps:
        P[name] = _circles(P[p], length(p, name), P[q], length(q, name), side)
    return P


def kinematics(key, ground_xy, length, angle, t) -> dict:
    """{pin: {x, y, vx, vy, ax, ay}} as float arrays over the times t (s); angle(t) -> the
    crank's angle in degrees (an mp function of mp time)."""
    mp.mp.dps = 50
    h = mp.mpf("1e-15")
    out: dict = {}
    for ti in t:
        ti = mp.mpf(float(ti))
        ev = [pins_at(key, ground_xy, length, mp.radians(angle(ti + s * h))) for s in (-1, 0, 1)]
        for p in ev[1]:
            d = out.setdefault(p, {k: [] for k in ("x", "y", "vx", "vy", "ax", "ay")})
            for c, n in ((0, "x"), (1, "y")):
                fm, f0, fp = ev[0][p][c], ev[1][p][c], ev[2][p][c]
                d[n].append(float(f0))
                d["v" + n].append(float((fp - fm) / (2 * h)))
                d["a" + n].append(float((fp - 2 * f0 + fm) / (h * h)))
    return {p: {k: np.array(v) for k, v in d.items()} for p, d in out.items()}


def own_length(pins: dict):
    """The lengths of a sketch's own geometry: exact distances between its (rounded) pins."""
    def length(p, q):
        a, b = pins[p], pins[q]
        return mp.hypot(mp.mpf(a[0]) - mp.mpf(b[0]), mp.mpf(a[1]) - mp.mpf(b[1]))
    return length


def published_length(fn):
    def length(p, q):
        return mp.mpf(fn(p, q))
    return length


def errors(result, ref, size) -> dict:
    """Largest error of every named point of `result` against `ref`: positions relative to the
    model's size, velocities and accelerations relative to the point's own largest |v| or |a|
    over the run. {'P'|'V'|'A': (error, 'pin.column')}."""
    worst = {}
    for p, d in ref.items():
        r = result.point(p)
        for g, ks in (("P", ("x", "y")), ("V", ("vx", "vy")), ("A", ("ax", "ay"))):
            scale = size if g == "P" else max(float(np.max(np.abs(d[k]))) for k in ks)
            if scale == 0:
                continue
            for k in ks:
                e = float(np.max(np.abs(r[k] - d[k]))) / scale
                worst[g] = max(worst.get(g, (0.0, "")), (e, f"{p}.{k}"))
    return worst


def model_size(pins) -> float:
    return max(math.hypot(*p) for p in pins.values())
