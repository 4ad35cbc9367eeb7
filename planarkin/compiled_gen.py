"""The grid pass written out for one mechanism structure, as Python for numba (issue 17).

The generic compiled kernel (planarkin.compiled.solve_points) reads a system's structure from
arrays at every point: each row's kind, bodies and columns, each block's size and matrix
positions. Here that structure is written into Python source instead, one function per
structure (the old C generator kernelgen.py's design, in Python): every row a call of its
kind's function of planarkin.compiled_kinds (the one text of the element equations) with the
equation, the bodies' coordinates and the parameters named as local variables, every block's
Newton step, inverse and substitution written out for its size. numba inlines the kind
functions and compiles the whole in well under a second, where the generic kernel takes tens.

The algorithm is System._solve_batch's and solve_points', step for step: the blocks in order;
an affine block takes one Newton step (exact), point by point; any other block iterates, all
points of the batch together, until every point's correction is at most tol (so the iteration
counts agree with the reference); sigma_min and the determinant's sign at the first iteration;
then per point the residual of every row, the velocities and accelerations by forward
substitution with each block's matrix at the converged positions (1 x 1: r times the inverse,
2 x 2: Cramer's rule, as the generic kernel), the largest residual, the condition estimate,
and no convergence where a coordinate is not finite.

Covered: the structures kernel.pack packs whose solve blocks have at most KGEN unknowns and are
one fine block each (covers); the others keep the generic kernel. Only the structure is
written into the source (kinds, bodies, rows, blocks, sizes): the parameters are an argument,
so every model of one structure shares one compiled function (and one cache entry).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .compiled_kinds import KINDS

KGEN = 2          # largest block written out (1 x 1 and 2 x 2 in closed form)
VERSION = 1       # of the generated text's shape: part of its hash

_SLOTS = 6        # parameter slots the kind functions read (si, sj, vi: p[0:6] of pack's 8)


def covers(P) -> bool:
    """The structure can be written out: packed, every solve block of at most KGEN unknowns
    and a single fine block."""
    if P is None:
        return False
    bk = P.arrays[6]
    return bool(len(bk)) and int(bk.max()) <= KGEN and bool((P.fine[1] == 1).all())


def structure(P, W: int, m: int, nb: int) -> tuple:
    """What the generated source depends on (no parameter values)."""
    ekind, ebi, ebj, _, rowel, roweq, bk, boff, baff, bcols, brows = P.arrays
    inblk, _, rpos = P.tail
    parts = (ekind, ebi, ebj, rowel, roweq, bk, boff, baff, bcols, brows, inblk, rpos,
             P.fine[0])
    return (W, m, nb, P.nfine) + tuple(tuple(int(x) for x in np.ravel(a)) for a in parts)


def name_of(struct: tuple) -> str:
    """The generated module's name: a hash of the structure and of the generator (this module's
    source and the kind functions')."""
    h = hashlib.sha256(repr((VERSION, struct)).encode())
    here = Path(__file__).parent
    for name in ("compiled_gen.py", "compiled_kinds.py"):
        h.update((here / name).read_bytes())
    return f"pk_grid_{h.hexdigest()[:20]}"


class _Text:
    def __init__(self):
        self.lines: list[str] = []

    def __call__(self, depth: int, line: str) -> None:
        self.lines.append("    " * depth + line)


class _Writer:
    """The source of one structure, piece by piece (see source)."""

    def __init__(self, P, W, m, nb):
        ekind, ebi, ebj, _, rowel, roweq, bk, boff, baff, bcols, brows = P.arrays
        self.P, self.W, self.m, self.nb, self.n = P, W, m, nb, W - 3
        self.kind, self.bi, self.bj, self.rowel, self.roweq = ekind, ebi, ebj, rowel, roweq
        self.rcol, self.rpos = P.tail[1], P.tail[2]
        self.bfirst = P.fine[0]
        self.fixed = P.fixed
        self.blocks = [(int(bk[b]), [int(c) for c in bcols[boff[b]:boff[b] + bk[b]]],
                        [int(r) for r in brows[boff[b]:boff[b] + bk[b]]], bool(baff[b]))
                       for b in range(P.nblk)]
        self.colblock = {c: b for b, blk in enumerate(self.blocks) for c in blk[1]}
        self.out = _Text()

    # -- names: coordinates q<c>, rates v<c>, a<c>; a moving body's cos, sin c<b>, s<b> ---------
    def coord(self, b, k, pre="q"):
        return "0.0" if b == self.nb else f"{pre}{3 * b + k}"

    def call(self, row, want, upto=-1):
        """The kind function's call for a row; with upto >= 0 the rates of the columns that
        blocks up to upto solve (the others are zero at that time, as in the reference)."""
        e = int(self.rowel[row])
        args = [str(int(self.roweq[row])), str(want)]
        for b in (int(self.bi[e]), int(self.bj[e])):
            cs = ("1.0", "0.0") if b == self.nb else (f"c{b}", f"s{b}")
            args += [self.coord(b, 0), self.coord(b, 1), self.coord(b, 2), *cs]
        args += [f"p{e}_{k}" for k in range(_SLOTS)]
        for b in (int(self.bi[e]), int(self.bj[e])):
            args += [self.coord(b, k, "v") if self.colblock.get(3 * b + k, upto + 1) <= upto
                     else "0.0" for k in range(3)]
        return f"k_{KINDS[int(self.kind[e])]}({', '.join(args)})"

    def reads(self, bs):
        """Columns the rows of blocks bs read or solve, and the moving bodies whose angles."""
        cols = set()
        for b in bs:
            for row in self.blocks[b][2]:
                e = int(self.rowel[row])
                for body in (int(self.bi[e]), int(self.bj[e])):
                    if body != self.nb:
                        cols.update(3 * body + k for k in range(3))
            cols.update(self.blocks[b][1])
        return sorted(cols), sorted({c // 3 for c in cols})

    def solved(self, bs):
        cols = [c for b in bs for c in self.blocks[b][1]]
        return cols, [c // 3 for c in cols if c % 3 == 2]

    def load(self, d, bs, rates=True):
        """A point's numbers that blocks bs read: coordinates, cosines and sines, and the rates
        of columns earlier blocks solved."""
        cols, bodies = self.reads(bs)
        for c in cols:
            self.out(d, f"q{c} = Q[i, {c}]")
        for b in bodies:
            self.out(d, f"c{b} = C[i, {b}]")
            self.out(d, f"s{b} = S[i, {b}]")
        if rates:
            first = min(bs)
            for c in cols:
                if self.colblock.get(c, first) < first:
                    self.out(d, f"v{c} = Qd[i, {c}]")
                    self.out(d, f"a{c} = Qdd[i, {c}]")

    def store(self, d, bs, rates=True):
        cols, bodies = self.solved(bs)
        for c in cols:
            self.out(d, f"Q[i, {c}] = q{c}")
        for b in bodies:
            self.out(d, f"C[i, {b}] = c{b}")
            self.out(d, f"S[i, {b}] = s{b}")
        if rates:
            self.out(d, "if order >= 1:")
            for c in cols:
                self.out(d + 1, f"Qd[i, {c}] = v{c}")
            self.out(d, "if order >= 2:")
            for c in cols:
                self.out(d + 1, f"Qdd[i, {c}] = a{c}")

    # -- one block --------------------------------------------------------------------------
    def evaluate(self, d, b, want):
        """Block b's rows: g<rp>, and with want & 2 the gradients d<rp>_<k> and the block
        matrix J<k> (of a repeated position the last entry, as System.block_matrix)."""
        kb, cols, rows, _ = self.blocks[b]
        src = {}
        for rp, row in enumerate(rows):
            dn = [f"d{rp}_{k}" for k in range(6)] if want & 2 else ["_"] * 6
            self.out(d, f"g{rp}, {', '.join(dn)}, _ = {self.call(row, want)}")
            for k in range(6):
                pos = int(self.rpos[row, k])
                if pos >= 0:
                    src[rp * kb + pos] = f"d{rp}_{k}"
        if want & 2:
            for k in range(kb * kb):
                self.out(d, f"J{k} = {src.get(k, '0.0')}")

    def invert(self, d, kb):
        """M<k> the inverse of J, sm its sigma_min bound, sg the determinant's sign (as
        compiled.factor: closed forms)."""
        o = self.out
        if kb == 1:
            o(d, "M0 = 1.0 / J0")
            o(d, "sm = abs(J0)")
            o(d, "sg = sign_of(J0)")
            return
        o(d, "det = J0 * J3 - J1 * J2")
        o(d, "ok2 = math.isfinite(det) and det != 0")
        o(d, "inv = 1.0 / (det if ok2 else np.nan)")
        o(d, "M0 = J3 * inv")
        o(d, "M1 = -J1 * inv")
        o(d, "M2 = -J2 * inv")
        o(d, "M3 = J0 * inv")
        o(d, "sm = abs(det) / np.sqrt(J0 * J0 + J1 * J1 + J2 * J2 + J3 * J3) if ok2 else 0.0")
        o(d, "sg = sign_of(det) if ok2 else 0.0")

    def step(self, d, b):
        """dx = M r applied: the columns moved, the cosines and sines of the angles among them
        (as the reference, at every step), sz the largest |dx| (not finite: inf)."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        for rp, row in enumerate(rows):
            o(d, f"r{rp} = g{rp} - T[i, {row}]")
        for a, c in enumerate(cols):
            o(d, f"dx{a} = {' + '.join(f'M{a * kb + k} * r{k}' for k in range(kb))}")
            o(d, f"q{c} -= dx{a}")
            if c % 3 == 2:
                o(d, f"c{c // 3} = np.cos(q{c})")
                o(d, f"s{c // 3} = np.sin(q{c})")
        o(d, "sz = abs(dx0)" if kb == 1 else "sz = nanmax(abs(dx0), abs(dx1))")
        o(d, "if not math.isfinite(sz):")
        o(d + 1, "sz = np.inf")

    def rates(self, d, b, have):
        """Block b at the converged positions: its rows' residuals into R, then (order >= 1)
        the velocities and (order >= 2) the accelerations, by substitution. have: the
        gradients and J of the Newton step serve (a fixed gradient), else evaluated here."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        self.evaluate(d, b, 1 if have else 3)
        for rp, row in enumerate(rows):
            o(d, f"R[i, {row}] = abs(g{rp} - T[i, {row}])")
        o(d, "if order >= 1:")
        self.substitute(d + 1, b, "v", "NU[i, {row}]")
        o(d + 1, "if order >= 2:")
        for rp, row in enumerate(rows):
            o(d + 2, f"_, _, _, _, _, _, _, gm{rp} = {self.call(row, 4, upto=b)}")
        self.substitute(d + 2, b, "a", "(gm{rp} + FDD[i, {row}])")

    def substitute(self, d, b, X, rhs):
        """Block b's rows of Phi_q x = rhs solved for its columns (X: 'v' the velocities, 'a'
        the accelerations): r = rhs - gradient . x summed in pairs as compiled.dot6 (the
        columns of this block, of later blocks and of the ground are zero at this time: their
        terms, exact zeros, are left out), then 1 x 1: r times the inverse, 2 x 2: Cramer's rule
        (compiled.solve2)."""
        kb, cols, rows, _ = self.blocks[b]
        for rp, row in enumerate(rows):
            terms = []
            for k in range(6):
                c = int(self.rcol[row, k])
                known = c < self.n and self.colblock.get(c, b) < b
                terms.append(f"d{rp}_{k} * {X}{c}" if known else None)
            expr = _pairs(terms)
            r = rhs.format(rp=rp, row=row)
            self.out(d, f"r{rp} = {r} - {expr}" if expr else f"r{rp} = {r}")
        if kb == 1:
            self.out(d, f"{X}{cols[0]} = r0 * (1.0 / J0)")
        else:
            self.out(d, "det = J0 * J3 - J1 * J2")
            self.out(d, f"{X}{cols[0]} = (J3 * r0 - J1 * r1) / det")
            self.out(d, f"{X}{cols[1]} = (J0 * r1 - J2 * r0) / det")

    def first(self, d, b):
        o = self.out
        o(d, f"smin[i, {b}] = sm")
        o(d, f"sign[i, {int(self.bfirst[b])}] = sg")

    # -- the passes over points -------------------------------------------------------------
    def affine(self, seg):
        """A run of affine blocks, point by point: one Newton step each (exact), then the
        block's residuals and rates."""
        o = self.out
        o(1, "for i in range(N):")
        self.load(2, seg)
        o(2, "rat = ratio[i]")
        o(2, "ok = conv[i] != 0")
        for b in seg:
            kb, cols, rows, _ = self.blocks[b]
            o(2, f"# block {b}: columns {cols}, rows {rows} (affine: one step)")
            self.evaluate(2, b, 3)
            self.invert(2, kb)
            self.step(2, b)
            self.first(2, b)
            o(2, "v = sz / sm if sm > 0 else np.inf")
            o(2, "if v > rat or v != v:")
            o(3, "rat = v")
            o(2, "ok = ok and math.isfinite(sz)")
            self.rates(2, b, bool(self.fixed[b]))
        self.store(2, seg)
        o(2, "ratio[i] = rat")
        o(2, "conv[i] = 1 if ok else 0")
        o(2, "if iters[i] < 1:")
        o(3, "iters[i] = 1")

    def newton(self, b):
        """A block that is not affine: Newton for all points together until every point's
        correction is at most tol (the reference's iteration counts), then per point its
        convergence, residuals and rates."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        o(1, f"# block {b}: columns {cols}, rows {rows} (Newton, all points together)")
        o(1, f"MI = np.empty((N, {kb * kb}))")
        o(1, "for it in range(maxit):")
        o(2, "small = True")
        o(2, "for i in range(N):")
        self.load(3, [b], rates=False)
        o(3, "if it == 0 or full != 0:")
        self.evaluate(4, b, 3)
        self.invert(4, kb)
        for k in range(kb * kb):
            o(4, f"MI[i, {k}] = M{k}")
        o(4, "if it == 0:")
        self.first(5, b)
        o(3, "else:")
        self.evaluate(4, b, 1)
        for k in range(kb * kb):
            o(4, f"M{k} = MI[i, {k}]")
        self.step(3, b)
        self.store(3, [b], rates=False)
        o(3, "if it == 0:")
        o(4, f"sm = smin[i, {b}]")
        o(4, "v = sz / sm if sm > 0 else np.inf")
        o(4, "if v > ratio[i] or v != v:")
        o(5, "ratio[i] = v")
        o(3, "if iters[i] < it + 1:")
        o(4, "iters[i] = it + 1")
        o(3, "SZ[i] = sz")
        o(3, "if not (sz <= tol):")
        o(4, "small = False")
        o(2, "if small:")
        o(3, "break")
        o(1, "for i in range(N):")
        o(2, "conv[i] = 1 if (conv[i] != 0 and SZ[i] <= tol) else 0")
        self.load(2, [b])
        self.rates(2, b, False)
        self.store(2, [b])

    def source(self) -> str:
        o, n, nb, m = self.out, self.n, self.nb, self.m
        o(0, '"""planarkin.compiled_gen: the grid pass of one mechanism structure (generated; '
             'the file is used only while its bytes are the generated text)."""')
        for line in ("import math", "", "import numba", "import numpy as np", "",
                     "from planarkin import compiled_kinds as K", ""):
            o(0, line)
        o(0, "# the kinds' equations (planarkin.compiled_kinds), each compiled once, for one")
        o(0, "# signature, as a function of its own: inlined in numba's IR they made the first")
        o(0, "# compile ten times longer, and literal arguments would compile one per value")
        o(0, "ROW = (numba.int64, numba.int64) + (numba.float64,) * 22")
        for kd in sorted({KINDS[int(k)] for k in self.kind}):
            o(0, f"k_{kd} = numba.njit([ROW], error_model='numpy', _nrt=False)"
                 f"(getattr(K.{kd}, 'py_func', K.{kd}))")
        o(0, "sign_of = K.sign_of")
        o(0, "nanmax = K.nanmax")
        o(0, "")
        o(0, "")
        o(0, "# CACHE: numba's disk cache or not, given by planarkin.compiled_grid")
        o(0, "@numba.njit(cache=CACHE, error_model='numpy', nogil=True)")
        o(0, "def grid(N, Q, Qd, Qdd, T, NU, FDD, prm, maxit, tol, full, order, iters, conv, "
             "ratio, sign, smin, R, rmax, cond):")
        for e in range(len(self.kind)):
            for k in range(_SLOTS):
                o(1, f"p{e}_{k} = prm[{e}, {k}]")
        o(1, f"C = np.empty((N, {max(nb, 1)}))")
        o(1, f"S = np.empty((N, {max(nb, 1)}))")
        o(1, "SZ = np.empty(N)")
        o(1, "for i in range(N):")
        for b in range(nb):
            o(2, f"C[i, {b}] = np.cos(Q[i, {3 * b + 2}])")
            o(2, f"S[i, {b}] = np.sin(Q[i, {3 * b + 2}])")
        o(2, "iters[i] = 0")
        o(2, "conv[i] = 1")
        o(2, "ratio[i] = 0.0")
        o(2, f"for a in range({n}):")
        o(3, "Qd[i, a] = 0.0")
        o(3, "Qdd[i, a] = 0.0")
        segs: list[list[int]] = []
        for b, blk in enumerate(self.blocks):
            if blk[3] and segs and self.blocks[segs[-1][0]][3]:
                segs[-1].append(b)
            else:
                segs.append([b])
        for seg in segs:
            if self.blocks[seg[0]][3]:
                self.affine(seg)
            else:
                self.newton(seg[0])
        # per point: the rows left out as redundant, the largest residual, the condition
        # estimate (solver._cond), and no convergence where a coordinate is not finite
        o(1, "for i in range(N):")
        inrows = {r for blk in self.blocks for r in blk[2]}
        left = [r for r in range(m) if r not in inrows]
        self.load(2, range(len(self.blocks)), rates=False)
        for row in left:
            o(2, f"g0, _, _, _, _, _, _, _ = {self.call(row, 1)}")
            o(2, f"R[i, {row}] = abs(g0 - T[i, {row}])")
        o(2, "mx = R[i, 0]")
        o(2, f"for k in range(1, {m}):")
        o(3, "mx = nanmax(mx, R[i, k])")
        o(2, "rmax[i] = mx")
        o(2, "x = smin[i, 0]")
        o(2, "cd = 1.0 / (x if (x >= 1e-300 or x != x) else 1e-300)")
        o(2, f"for k in range(1, {len(self.blocks)}):")
        o(3, "x = smin[i, k]")
        o(3, "cd = nanmax(cd, 1.0 / (x if (x >= 1e-300 or x != x) else 1e-300))")
        o(2, "cond[i] = cd")
        o(2, f"for a in range({n}):")
        o(3, "if not math.isfinite(Q[i, a]):")
        o(4, "conv[i] = 0")
        return "\n".join(o.lines) + "\n"


def source(P, W: int, m: int, nb: int) -> str:
    """The module text of the grid pass for the structure of packed system P (covers(P))."""
    return _Writer(P, W, m, nb).source()


def _pairs(terms):
    """((t0 + t1) + (t2 + t3)) + (t4 + t5), the missing terms (None) left out."""
    def add(a, b):
        if a is None:
            return b
        if b is None:
            return a
        return f"({a} + {b})"
    return add(add(add(terms[0], terms[1]), add(terms[2], terms[3])), add(terms[4], terms[5]))
