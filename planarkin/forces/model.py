"""The mass and load data of a model as arrays, in physical units: the model's length unit,
radians, seconds, its force unit and the mass unit consistent with them (planarkin.forces.units:
kg by default, forces then following as kg * length / s^2; masses and inertias written in
another mass unit are converted here, the only conversion of the forces room).

Built from `ModelSpec.forces` when the forces room runs; never mutated.
"""

from __future__ import annotations


from dataclasses import dataclass

import numpy as np

from ..elements.revolute import to_body
from .units import units_of


@dataclass(frozen=True)
class ForceModel:
    """nb bodies (ground = index nb).

    mass (nb,), inertia (nb,) about the centre of mass, cm (nb, 2) centre of mass in the body
    frame (length); gravity (2,) length/s^2 (zero when none).
    force_body (F,), force_s (F, 2) body-frame point, force_f: F pairs of TimeFunction (global
    components); torque_body (T,), torque_f: T TimeFunction.
    spring_i, spring_j (S,) bodies (ground allowed), spring_si, spring_sj (S, 2) points in their
    frames, spring_k (S,) stiffness, spring_l0 (S,) free length, spring_c (S,) damping: one entry
    per spring (c = 0) and per damper (k = 0).
    """

    nb: int
    mass: np.ndarray
    inertia: np.ndarray
    cm: np.ndarray
    gravity: np.ndarray
    force_body: np.ndarray
    force_s: np.ndarray
    force_f: tuple
    torque_body: np.ndarray
    torque_f: tuple
    spring_i: np.ndarray
    spring_j: np.ndarray
    spring_si: np.ndarray
    spring_sj: np.ndarray
    spring_k: np.ndarray
    spring_l0: np.ndarray
    spring_c: np.ndarray


def force_model(cm) -> ForceModel:
    spec = cm.spec
    fs = spec.forces
    nb = cm.nb
    index = {name: k for k, name in enumerate(cm.body_names)}
    index["ground"] = nb
    af = cm.angle_factor
    poses = {b.name: (b.q[0], b.q[1], b.q[2] * af) for b in spec.bodies}
    mass = np.zeros(nb)
    inertia = np.zeros(nb)
    com = np.zeros((nb, 2))
    mf = units_of(spec).mass_factor              # the file's mass unit -> the consistent one
    for m in fs.masses:
        b = index[m.body]
        mass[b], inertia[b], com[b] = m.mass * mf, m.inertia * mf, m.cm
    grav = np.zeros(2) if fs.gravity is None else np.array(fs.gravity, dtype=float)
    fb, fsp, ff, tb, tf = [], [], [], [], []
    si, sj, ps, pj, k, l0, c = [], [], [], [], [], [], []
    for ld in fs.loads:
        if ld.kind == "force":
            b = ld.bodies[0]
            fb.append(index[b])
            fsp.append(ld.s if ld.at is None else to_body(np.array(ld.at, float), poses[b]))
            ff.append(ld.f)
        elif ld.kind == "torque":
            tb.append(index[ld.bodies[0]])
            tf.append(ld.f[0])
        else:
            si.append(index[ld.bodies[0]])
            sj.append(index[ld.bodies[1]])
            ps.append(ld.si)
            pj.append(ld.sj)
            k.append(ld.k if ld.kind == "spring" else 0.0)
            l0.append(ld.length if ld.kind == "spring" else 0.0)
            c.append(ld.c if ld.kind == "damper" else 0.0)
    a = lambda x, dt=float: np.asarray(x, dtype=dt)
    return ForceModel(nb, mass, inertia, com, grav, a(fb, np.intp), a(fsp).reshape(-1, 2),
                      tuple(ff), a(tb, np.intp), tuple(tf), a(si, np.intp), a(sj, np.intp),
                      a(ps).reshape(-1, 2), a(pj).reshape(-1, 2), a(k), a(l0), a(c))


def has_forces(cm) -> bool:
    """Whether the model gives anything that makes forces: a mass or inertia, or a load."""
    fs = cm.spec.forces
    return fs is not None and (any(m.mass > 0 or m.inertia > 0 for m in fs.masses)
                               or bool(fs.loads))
