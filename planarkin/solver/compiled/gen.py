"""The grid pass written out for one mechanism structure, as Python for numba (issue 17).

The compiled route's one solve: a system's structure (each row's kind, bodies and columns,
each block's size and matrix positions) is written into Python source, one function per
structure (the design of the C kernel generator it replaced, in Python): every row a call of its
kind's function of planarkin.elements.pointline (the one text of the element equations) with the
equation, the bodies' coordinates and the parameters named as local variables, every block's
Newton step, inverse and substitution written out for its size. The kind functions are
compiled apart (LLVM inlines them); a structure's kernel compiles in seconds and runs a grid
point faster than the generic kernel that read the structure from arrays at every point and
took far longer to compile (docs/explanation/performance.md; the figures: benchmarks/README.md,
"Figures moved from the code's comments"). That generic kernel was removed on 2026-12-06:
every structure kernel.pack accepts is written out here.

The algorithm is System._solve_batch's, step for step: the blocks in order;
an affine block takes one Newton step (exact), point by point; any other block iterates, all
points of the batch together, until every point's correction is at most tol (so the iteration
counts agree with the reference); sigma_min and the determinant's sign at the first iteration;
then per point the residual of every row, the velocities and accelerations by forward
substitution with each block's matrix at the converged positions (1 x 1: r times the inverse,
2 x 2: Cramer's rule, larger: Gauss-Jordan), the largest residual, the condition estimate,
and no convergence where a coordinate is not finite.

Covered: every structure kernel.pack packs (solve blocks of at most kernel.KMAX = KDENSE
unknowns, covers). Only the structure is
written into the source (kinds, bodies, rows, blocks, sizes): the parameters are an argument,
so every model of one structure shares one compiled function (and one cache entry).
"""

from __future__ import annotations

import ast
import hashlib
import re
from pathlib import Path

import numpy as np

from planarkin.elements.pointline import CODES

# largest dense block (Gauss-Jordan, its rows written out): kernel.KMAX, the largest block
# kernel.pack accepts, is this number (a test holds them equal; kernel does not import this
# module at its top, which imports numba)
KDENSE = 16

KGEN = 2          # largest block written out in closed form (1 x 1 and 2 x 2)
VERSION = 3       # of the generated text's shape: part of its hash

_SLOTS = 6        # parameter slots the kind functions read (si, sj, vi: p[0:6] of pack's 8)


def covers(P) -> bool:
    """The structure can be written out: packed, every solve block of at most KDENSE unknowns
    (a block of 2, in closed form, holds one fine block or two of one unknown)."""
    if P is None:
        return False
    bk, bnf = P.arrays[6], P.fine[1]
    return bool(len(bk)) and int(bk.max()) <= KDENSE and not bool(
        ((bk == 2) & (bnf > 2)).any())


def structure(P, W: int, m: int, nb: int) -> tuple:
    """What the generated source depends on (no parameter values)."""
    ekind, ebi, ebj, _, rowel, roweq, bk, boff, baff, bcols, brows = P.arrays
    inblk, _, rpos = P.tail
    parts = (ekind, ebi, ebj, rowel, roweq, bk, boff, baff, bcols, brows, inblk, rpos,
             *P.fine, P.fixed)
    return (W, m, nb, P.nfine) + tuple(tuple(int(x) for x in np.ravel(a)) for a in parts)


def name_of(struct: tuple, what: str = "grid") -> str:
    """The generated module's name: what it holds ('grid', or 'each': gen_each's), a
    hash of the structure and of the generators (their sources and the kind functions')."""
    h = hashlib.sha256(repr((VERSION, what, struct)).encode())
    package = Path(__file__).parent.parent.parent
    for name in ("solver/compiled/gen.py", "solver/compiled/gen_each.py",
                 "solver/compiled/helpers.py", "elements/pointline.py"):
        h.update((package / name).read_bytes())
    return f"pk_{what}_{h.hexdigest()[:20]}"


# the helpers a kernel calls at every block, each compiled apart for its one signature, as the
# kinds are: inlined in numba's IR, their branches were most of the variables numba's SSA pass
# rewrites (LLVM inlines them all the same; benchmarks/README.md, 2026-12-08)
_HELPERS = (("sign_of", 1), ("nanmax", 2), ("ratio_of", 2), ("inf_unless_finite", 1))


def helper_lines() -> list[str]:
    """The generated module's lines that compile the helpers (gen_each's too)."""
    return [f"{h} = numba.njit([(numba.float64,) * {k}], error_model='numpy', _nrt=False, "
            f"cache=CACHE)(getattr(K.{h}, 'py_func', K.{h}))" for h, k in _HELPERS]


class _Text:
    def __init__(self):
        self.lines: list[str] = []

    def __call__(self, depth: int, line: str) -> None:
        self.lines.append("    " * depth + line)


class Writer:
    """The source of one structure, piece by piece (see source)."""

    def __init__(self, P, W, m, nb):
        ekind, ebi, ebj, _, rowel, roweq, bk, boff, baff, bcols, brows = P.arrays
        self.P, self.W, self.m, self.nb, self.n = P, W, m, nb, W - 3
        self.kind, self.bi, self.bj, self.rowel, self.roweq = ekind, ebi, ebj, rowel, roweq
        self.rcol, self.rpos = P.tail[1], P.tail[2]
        self.bfirst = P.fine[0]
        self.fixed = P.fixed
        bnf, bfo, bfs = P.fine[1], P.fine[2], P.fine[3]
        self.sizes = [[int(bfs[bfo[b] + f]) for f in range(bnf[b])] for b in range(P.nblk)]
        self.blocks = [(int(bk[b]), [int(c) for c in bcols[boff[b]:boff[b] + bk[b]]],
                        [int(r) for r in brows[boff[b]:boff[b] + bk[b]]], bool(baff[b]))
                       for b in range(P.nblk)]
        self.colblock = {c: b for b, blk in enumerate(self.blocks) for c in blk[1]}
        self.out = _Text()

    # -- names: coordinates q<c>, rates v<c>, a<c>; a moving body's cos, sin c<b>, s<b> ---------
    def coord(self, b, k, pre="q"):
        return "ZERO" if b == self.nb else f"{pre}{3 * b + k}"

    def call(self, row, want, upto=-1):
        """The kind function's call for a row; with upto >= 0 the rates of the columns that
        blocks up to upto solve (the others are zero at that time, as in the reference)."""
        e = int(self.rowel[row])
        args = [f"W{want}"]
        for b in (int(self.bi[e]), int(self.bj[e])):
            cs = ("ONE", "ZERO") if b == self.nb else (f"c{b}", f"s{b}")
            args += [self.coord(b, 0), self.coord(b, 1), self.coord(b, 2), *cs]
        args += [f"p{e}_{k}" for k in range(_SLOTS)]
        for b in (int(self.bi[e]), int(self.bj[e])):
            args += [self.coord(b, k, "v") if self.colblock.get(3 * b + k, upto + 1) <= upto
                     else "ZERO" for k in range(3)]
        return f"k_{CODES[int(self.kind[e])]}({', '.join(args)})[{int(self.roweq[row])}]"

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

    # -- one block: every temporary named by its block (x), so that each is assigned once and
    # numba's SSA reconstruction, the slowest part of its first compile, has little to do ----
    def evaluate(self, d, b, want, x, matrix=True):
        """Block b's rows: g<x>_<rp>, with want & 2 the gradients d<x>_<rp>_<k> and the block
        matrix J<x>_<k> (of a repeated position the last entry, as System.block_matrix)."""
        kb, cols, rows, _ = self.blocks[b]
        src = {}
        for rp, row in enumerate(rows):
            dn = [f"d{x}_{rp}_{k}" for k in range(6)] if want & 2 else ["_"] * 6
            self.out(d, f"g{x}_{rp}, {', '.join(dn)}, _ = {self.call(row, want)}")
            for k in range(6):
                pos = int(self.rpos[row, k])
                if pos >= 0:
                    src[rp * kb + pos] = f"d{x}_{rp}_{k}"
        if want & 2 and matrix:
            for k in range(kb * kb):
                self.out(d, f"J{x}_{k} = {src.get(k, '0.0')}")

    def invert(self, d, kb, x):
        """M<x>_<k> the inverse of J<x>, sm<x> its sigma_min bound, sg<x> the determinant's
        sign (closed forms)."""
        o = self.out
        J = [f"J{x}_{k}" for k in range(kb * kb)]
        if kb == 1:
            o(d, f"M{x}_0 = 1.0 / {J[0]}")
            o(d, f"sm{x} = abs({J[0]})")
            o(d, f"sg{x} = sign_of({J[0]})")
            return
        o(d, f"det{x} = {J[0]} * {J[3]} - {J[1]} * {J[2]}")
        o(d, f"ok{x} = math.isfinite(det{x}) and det{x} != 0")
        o(d, f"inv{x} = 1.0 / (det{x} if ok{x} else np.nan)")
        for k, e in enumerate((J[3], "-" + J[1], "-" + J[2], J[0])):
            o(d, f"M{x}_{k} = {e} * inv{x}")
        o(d, f"sm{x} = abs(det{x}) / np.sqrt({J[0]} * {J[0]} + {J[1]} * {J[1]} + {J[2]} * "
             f"{J[2]} + {J[3]} * {J[3]}) if ok{x} else 0.0")
        o(d, f"sg{x} = sign_of(det{x}) if ok{x} else 0.0")

    def step(self, d, b, x):
        """dx = M r applied: the columns moved, the cosines and sines of the angles among them
        (as the reference, at every step), sz<x> the largest |dx| (not finite: inf)."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        for rp, row in enumerate(rows):
            o(d, f"r{x}_{rp} = g{x}_{rp} - T[i, {row}]")
        for a, c in enumerate(cols):
            terms = " + ".join(f"M{x}_{a * kb + k} * r{x}_{k}" for k in range(kb))
            o(d, f"dx{x}_{a} = {terms}")
            o(d, f"q{c} -= dx{x}_{a}")
            if c % 3 == 2:
                o(d, f"c{c // 3} = np.cos(q{c})")
                o(d, f"s{c // 3} = np.sin(q{c})")
        size = f"abs(dx{x}_0)" if kb == 1 else f"nanmax(abs(dx{x}_0), abs(dx{x}_1))"
        o(d, f"sz{x} = inf_unless_finite({size})")

    def rates(self, d, b, have, x):
        """Block b at the converged positions: its rows' residuals into R, the velocities and
        the accelerations by substitution (computed whatever the order, stored up to it).
        have: the gradients and J of the Newton step serve (a fixed gradient: the residual and
        gamma then come from one call, after the velocities), else evaluated here (y)."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        y = x if have else x + "c"
        if not have:
            self.evaluate(d, b, 3, y)
            for rp, row in enumerate(rows):
                o(d, f"R[i, {row}] = abs(g{y}_{rp} - T[i, {row}])")
        self.substitute(d, b, "v", "NU[i, {row}]", y)
        for rp, row in enumerate(rows):
            if have:
                o(d, f"h{x}_{rp}, _, _, _, _, _, _, gm{x}_{rp} = {self.call(row, 5, upto=b)}")
                o(d, f"R[i, {row}] = abs(h{x}_{rp} - T[i, {row}])")
            else:
                o(d, f"_, _, _, _, _, _, _, gm{x}_{rp} = {self.call(row, 4, upto=b)}")
        self.substitute(d, b, "a", "(gm{x}_{rp} + FDD[i, {row}])", y, x)

    def substitute(self, d, b, X, rhs, y, x=None):
        """Block b's rows of Phi_q x = rhs solved for its columns (X: 'v' the velocities, 'a'
        the accelerations; y: the names of the gradients and J): r = rhs - gradient . x summed
        in pairs (the columns of this block, of later blocks and of the
        ground are zero at this time: their terms, exact zeros, are left out), then 1 x 1: r
        times the inverse, 2 x 2: Cramer's rule."""
        kb, cols, rows, _ = self.blocks[b]
        for rp, row in enumerate(rows):
            self.out(d, f"{X}r{y}_{rp} = {self.rhs(b, rp, row, X, rhs, y, x)}")
        J = [f"J{y}_{k}" for k in range(kb * kb)]
        r = [f"{X}r{y}_{k}" for k in range(kb)]
        if kb == 1:
            self.out(d, f"{X}{cols[0]} = {r[0]} * (1.0 / {J[0]})")
        else:
            self.out(d, f"{X}det{y} = {J[0]} * {J[3]} - {J[1]} * {J[2]}")
            self.out(d, f"{X}{cols[0]} = ({J[3]} * {r[0]} - {J[1]} * {r[1]}) / {X}det{y}")
            self.out(d, f"{X}{cols[1]} = ({J[0]} * {r[1]} - {J[2]} * {r[0]}) / {X}det{y}")

    def rhs(self, b, rp, row, X, rhs, y, x):
        """The right-hand side of row rp of block b, rhs minus the gradient's terms of the
        columns earlier blocks solved (X: their rates' prefix), summed in pairs."""
        terms = []
        for k in range(6):
            c = int(self.rcol[row, k])
            known = c < self.n and self.colblock.get(c, b) < b
            terms.append(f"d{y}_{rp}_{k} * {X}{c}" if known else None)
        expr = pairs(terms)
        r = rhs.format(rp=rp, row=row, x=x)
        return f"{r} - {expr}" if expr else r

    def first(self, d, b, x):
        o = self.out
        o(d, f"smin[i, {b}] = sm{x}")
        f0 = int(self.bfirst[b])
        if len(self.sizes[b]) == 1:
            o(d, f"sign[i, {f0}] = sg{x}")
        else:       # a path block of two 1 x 1 fine blocks: their signs (System.fine_signs)
            o(d, f"sign[i, {f0}] = sign_of(J{x}_0)")
            o(d, f"sign[i, {f0 + 1}] = sign_of(J{x}_3)")

    def dense(self, b):
        """A block of more than KGEN unknowns (a dense inverse by Gauss-Jordan): Newton for
        all points together until every point's correction is at most tol (affine: one step,
        exact), sigma_min 1 / ||J^-1||_F and the signs of the fine blocks inside at the first
        iteration; then per point its convergence, residuals and rates with the inverse at the
        converged positions."""
        kb, cols, rows, aff = self.blocks[b]
        o = self.out
        x = str(b)
        kk = kb * kb
        o(1, f"# block {b}: columns {cols}, rows {rows} (dense, fine blocks "
             f"{self.sizes[b]}{'; affine: one step' if aff else ''})")
        o(1, f"MI{x} = np.empty(N * {kk})")
        o(1, f"for it in range({'1' if aff else 'maxit'}):")
        o(2, "small = True")
        o(2, "for i in range(N):")
        self.load(3, [b], rates=False)
        o(3, f"mo = i * {kk}")
        # the gradients at every iteration, used or not (g is the same bits either way): one
        # call site a row, not two (the path's kernel, whose few points make its first
        # compile, not its run, the cost)
        self.evaluate(3, b, 2 | 1, x, matrix=False)
        d = 3
        if not aff:
            o(3, "if it == 0 or full != 0:")
            d = 4
        self.factor(d, b, x, f"MI{x}", "mo")
        o(d, "if it == 0:")
        o(d + 1, f"smin[i, {b}] = sm{x}")
        self.fine_signs(d + 1, b)
        for rp, row in enumerate(rows):
            o(3, f"RV[{rp}] = g{x}_{rp} - T[i, {row}]")
        o(3, "sz = 0.0")
        o(3, f"for ua in range({kb}):")
        o(4, "dx = 0.0")
        o(4, f"for uk in range({kb}):")
        o(5, f"dx += MI{x}[mo + ua * {kb} + uk] * RV[uk]")
        o(4, "DX[ua] = dx")
        o(4, "sz = nanmax(sz, abs(dx))")
        for a, c in enumerate(cols):
            o(3, f"q{c} -= DX[{a}]")
            if c % 3 == 2:
                o(3, f"c{c // 3} = np.cos(q{c})")
                o(3, f"s{c // 3} = np.sin(q{c})")
        o(3, "sz = inf_unless_finite(sz)")
        self.store(3, [b], rates=False)
        o(3, "if it == 0:")
        o(4, f"ratio[i] = nanmax(ratio[i], ratio_of(sz, smin[i, {b}]))")
        o(3, "iters[i] = max(iters[i], it + 1)")
        o(3, "SZ[i] = sz")
        o(3, "small = small & (sz <= tol)")
        if not aff:
            o(2, "if small:")
            o(3, "break")
        o(1, "for i in range(N):")
        if aff:     # one step is exact: converged unless not finite
            o(2, "conv[i] = 1 if (conv[i] != 0 and SZ[i] < np.inf) else 0")
        else:
            o(2, "conv[i] = 1 if (conv[i] != 0 and SZ[i] <= tol) else 0")
        self.load(2, [b])
        y = x + "c"
        self.evaluate(2, b, 3, y, matrix=False)
        for rp, row in enumerate(rows):
            o(2, f"R[i, {row}] = abs(g{y}_{rp} - T[i, {row}])")
        self.factor(2, b, y, "MR", "0", norm=False)
        for rp, row in enumerate(rows):
            o(2, f"RV[{rp}] = {self.rhs(b, rp, row, 'v', 'NU[i, {row}]', y, x)}")
        self.apply(2, b, "v")
        for rp, row in enumerate(rows):
            o(2, f"_, _, _, _, _, _, _, gm{x}_{rp} = {self.call(row, 4, upto=b)}")
            o(2, f"RV[{rp}] = {self.rhs(b, rp, row, 'a', '(gm{x}_{rp} + FDD[i, {row}])', y, x)}")
        self.apply(2, b, "a")
        self.store(2, [b])

    def factor(self, d, b, x, M, mo, norm=True):
        """Block b's matrix JW (from the gradients d<x>_...) inverted into M[mo:] by
        Gauss-Jordan; with norm sm<x>, the bound 1 / ||J^-1||_F, and sg<x>
        the determinant's sign."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        o(d, f"for uk in range({kb * kb}):")
        o(d + 1, "JW[uk] = 0.0")
        for pos, name in self.entries(b, x).items():
            o(d, f"JW[{pos}] = {name}")
        o(d, f"ok{x}, sg{x} = gj({kb}, JW, 0, {M}, {mo}, WK)")
        if norm:
            o(d, "fs = 0.0")
            o(d, f"for uk in range({kb * kb}):")
            o(d + 1, f"fs += {M}[{mo} + uk] * {M}[{mo} + uk]")
            o(d, f"sm{x} = 1.0 / np.sqrt(fs) if ok{x} else 0.0")

    def sign_at(self, f: int) -> str:
        """Where the determinant sign of fine block f goes (the grid kernel's sign (N, nfine))."""
        return f"sign[i, {f}]"

    def entry(self, b: int, k: int) -> str:
        """Entry k of block b's matrix (row-major), as the text reads it."""
        return f"JW[{k}]"

    def fine_signs(self, d, b):
        """The determinant signs of the fine blocks inside block b from its matrix JW
        : 1 x 1 their entry, larger by Gauss-Jordan; a single fine
        block: the block's own sign."""
        o = self.out
        f0 = int(self.bfirst[b])
        kb = self.blocks[b][0]
        if len(self.sizes[b]) == 1:
            o(d, f"{self.sign_at(f0)} = sg{b}")
            return
        off = 0
        for f, sz in enumerate(self.sizes[b]):
            if sz == 1:
                o(d, f"{self.sign_at(f0 + f)} = sign_of({self.entry(b, off * kb + off)})")
            else:
                for u in range(sz):
                    for v in range(sz):
                        o(d, f"SB[{u * sz + v}] = JW[{(off + u) * kb + off + v}]")
                o(d, f"_, sf = gj({sz}, SB, 0, SI, 0, WK)")
                o(d, f"{self.sign_at(f0 + f)} = sf")
            off += sz

    def apply(self, d, b, X):
        """The block's columns of X (v, a) = MR RV."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        o(d, f"for ua in range({kb}):")
        o(d + 1, "xa = 0.0")
        o(d + 1, f"for uk in range({kb}):")
        o(d + 2, f"xa += MR[ua * {kb} + uk] * RV[uk]")
        o(d + 1, "DX[ua] = xa")
        for a, c in enumerate(cols):
            o(d, f"{X}{c} = DX[{a}]")

    def entries(self, b, x):
        """Block b's matrix entries: position -> the gradient's name (of a repeated position
        the last, as System.block_matrix)."""
        kb, cols, rows, _ = self.blocks[b]
        src = {}
        for rp, row in enumerate(rows):
            for k in range(6):
                pos = int(self.rpos[row, k])
                if pos >= 0:
                    src[rp * kb + pos] = f"d{x}_{rp}_{k}"
        return src

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
            x = str(b)
            o(2, f"# block {b}: columns {cols}, rows {rows} (affine: one step)")
            self.evaluate(2, b, 3, x)
            self.invert(2, kb, x)
            self.step(2, b, x)
            self.first(2, b, x)
            o(2, f"rat = nanmax(rat, ratio_of(sz{x}, sm{x}))")
            o(2, f"ok = ok & math.isfinite(sz{x})")
            self.rates(2, b, bool(self.fixed[b]), x)
        self.store(2, seg)
        o(2, "ratio[i] = rat")
        o(2, "conv[i] = 1 if ok else 0")
        o(2, "iters[i] = max(iters[i], 1)")

    def newton(self, b):
        """A block that is not affine: Newton for all points together until every point's
        correction is at most tol (the reference's iteration counts), then per point its
        convergence, residuals and rates."""
        kb, cols, rows, _ = self.blocks[b]
        o = self.out
        x = str(b)
        o(1, f"# block {b}: columns {cols}, rows {rows} (Newton, all points together)")
        o(1, f"MI = np.empty((N, {kb * kb}))")
        o(1, "for it in range(maxit):")
        o(2, "small = True")
        o(2, "for i in range(N):")
        self.load(3, [b], rates=False)
        o(3, "if it == 0 or full != 0:")
        self.evaluate(4, b, 3, x)
        self.invert(4, kb, x)
        for k in range(kb * kb):
            o(4, f"MI[i, {k}] = M{x}_{k}")
        o(4, "if it == 0:")
        self.first(5, b, x)
        o(3, "else:")
        self.evaluate(4, b, 1, x)
        for k in range(kb * kb):
            o(4, f"M{x}_{k} = MI[i, {k}]")
        self.step(3, b, x)
        self.store(3, [b], rates=False)
        o(3, "if it == 0:")
        o(4, f"ratio[i] = nanmax(ratio[i], ratio_of(sz{x}, smin[i, {b}]))")
        o(3, "iters[i] = max(iters[i], it + 1)")
        o(3, f"SZ[i] = sz{x}")
        o(3, f"small = small & (sz{x} <= tol)")
        o(2, "if small:")
        o(3, "break")
        o(1, "for i in range(N):")
        o(2, "conv[i] = 1 if (conv[i] != 0 and SZ[i] <= tol) else 0")
        self.load(2, [b])
        self.rates(2, b, False, x)
        self.store(2, [b])

    def source(self) -> str:
        o, n, nb, m = self.out, self.n, self.nb, self.m
        o(0, '"""planarkin.solver.compiled.gen: the grid pass of one mechanism structure (generated; '
             'the file is used only while its bytes are the generated text)."""')
        for line in ("import math", "", "import numba", "import numpy as np", "",
                     "from planarkin.elements import pointline as E",
                     "from planarkin.solver.compiled import helpers as K", ""):
            o(0, line)
        o(0, "# CACHE: numba's disk cache or not, given by planarkin.solver.compiled.kernels")
        o(0, "# the kinds' equations (planarkin.elements.pointline), each compiled once, for one")
        o(0, "# signature, as a function of its own: inlined in numba's IR they made the first")
        o(0, "# compile ten times longer, and literal arguments would compile one per value;")
        o(0, "# cached (a later process loads them, as it loads grid)")
        o(0, "ROW = (numba.int64,) + (numba.float64,) * 22")
        for kd in sorted({CODES[int(k)] for k in self.kind}):
            o(0, f"k_{kd} = numba.njit([ROW], error_model='numpy', _nrt=False, cache=CACHE)"
                 f"(E.{kd})")
        if any(blk[0] > KGEN for blk in self.blocks):
            o(0, "F1 = numba.float64[::1]")
            o(0, "gj = numba.njit([(numba.int64, F1, numba.int64, F1, numba.int64, F1)], "
                 "error_model='numpy', _nrt=False, cache=CACHE)(getattr(K.gauss_jordan, "
                 "'py_func', K.gauss_jordan))")
        for line in helper_lines():
            o(0, line)
        o(0, "")
        o(0, "")
        o(0, "@numba.njit(cache=CACHE, error_model='numpy', nogil=True)")
        o(0, "def grid(N, Q, Qd, Qdd, T, NU, FDD, prm, maxit, tol, full, order, iters, conv, "
             "ratio, sign, smin, R, rmax, cond, pred, t, idx, Tn, Qn, Qdn, Qddn, Qf):")
        # the calls' constant arguments as variables (a literal is a statement of numba's IR
        # at every use: the first compile's time is that of the IR's statements)
        o(1, "ZERO = 0.0")
        o(1, "ONE = 1.0")
        o(1, "W1, W2, W3, W4, W5 = 1, 2, 3, 4, 5")
        for e in range(len(self.kind)):
            for k in range(_SLOTS):
                o(1, f"p{e}_{k} = prm[{e}, {k}]")
        o(1, f"C = np.empty((N, {max(nb, 1)}))")
        o(1, f"S = np.empty((N, {max(nb, 1)}))")
        o(1, "SZ = np.empty(N)")
        kd = max([blk[0] for blk in self.blocks if blk[0] > KGEN], default=0)
        if kd:       # the dense blocks' work arrays
            fmax = max(max(z) for z in self.sizes)
            o(1, f"JW = np.empty({kd * kd})")
            o(1, f"MR = np.empty({kd * kd})")
            o(1, f"WK = np.empty({2 * kd * kd})")
            o(1, f"RV = np.empty({kd})")
            o(1, f"DX = np.empty({kd})")
            o(1, f"SB = np.empty({fmax * fmax})")
            o(1, f"SI = np.empty({fmax * fmax})")
        o(1, "for i in range(N):")
        # pred: the predictions written here from the path's nodes (Qf: Q's flat view), in
        # the pass that reads them first (helpers.hermite_row: path.hermite5's formula)
        o(2, "if pred != 0:")
        o(3, f"K.hermite_row(t[i], idx[i], {n + 3}, Tn, Qn, Qdn, Qddn, Qf, i * {n + 3})")
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
            if blk[3] and blk[0] <= KGEN and segs and self.blocks[segs[-1][0]][3] \
                    and self.blocks[segs[-1][0]][0] <= KGEN:
                segs[-1].append(b)
            else:
                segs.append([b])
        for seg in segs:
            if self.blocks[seg[0]][0] > KGEN:
                self.dense(seg[0])
            elif self.blocks[seg[0]][3]:
                self.affine(seg)
            else:
                self.newton(seg[0])
        # per point: the rows left out as redundant, the largest residual, the condition
        # estimate (acceptance.condition), and no convergence where a coordinate is not finite
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
        return "\n".join(per_loop_names(discards(o.lines))) + "\n"


def source(P, W: int, m: int, nb: int) -> str:
    """The module text of the grid pass for the structure of packed system P (covers(P))."""
    return Writer(P, W, m, nb).source()


def pairs(terms):
    """((t0 + t1) + (t2 + t3)) + (t4 + t5), the missing terms (None) left out."""
    def add(a, b):
        if a is None:
            return b
        if b is None:
            return a
        return f"({a} + {b})"
    return add(add(add(terms[0], terms[1]), add(terms[2], terms[3])), add(terms[4], terms[5]))


def discards(lines):
    """Each discarded value (the `_` of an unpacking) a name of its own: a name assigned many
    times costs numba's SSA reconstruction time in proportion to its assignments."""
    count = [0]

    def name(_):
        count[0] += 1
        return f"_u{count[0]}"

    out = []
    for line in lines:
        head, sep, tail = line.partition(" = ")
        if sep and "," in head:
            head = re.sub(r"(?<![\w])_(?![\w])", name, head)
        out.append(head + sep + tail)
    return out


def per_loop_names(lines: list[str]) -> list[str]:
    """Each top-level loop of the kernel its own names for what it computes per point, where
    other statements use the same names (q3 in statement 73 becomes q3__73). numba makes one
    variable of a name however many loops assign it, and its SSA reconstruction costs time in
    proportion to such variables times the function's statements.

    A name is renamed in a top-level loop where its first occurrence (reads before stores on a
    line) is a plain assignment in the body of that loop or of a loop within it, reached
    through loop bodies only, and no occurrence lies after the end of that body: no value flows
    in. It is renamed only where every later top-level statement that uses it renames it too:
    no value flows out. A loop's own variable is not an assignment here. Loops with an else,
    statements over several lines and text that is not ASCII are left as they are (the rule
    reads lines and columns). Every other byte of the text stays as it is."""
    text = "\n".join(lines)
    if not text.isascii():
        return list(lines)
    fn = next(n for n in ast.parse(text).body if isinstance(n, ast.FunctionDef))
    loops = {id(f.target) for f in ast.walk(fn) if isinstance(f, ast.For)}
    fresh = [_fresh_names(s, loops) if isinstance(s, (ast.For, ast.While)) else set()
             for s in fn.body]
    seen = [{n.id for n in ast.walk(s) if isinstance(n, ast.Name)} for s in fn.body]
    edits: dict[int, list] = {}
    for k, stmt in enumerate(fn.body):
        keep = {x for x in fresh[k] if sum(x in names for names in seen) > 1
                and all(x not in seen[j] or x in fresh[j] for j in range(k + 1, len(fn.body)))}
        for n in ast.walk(stmt):
            if isinstance(n, ast.Name) and n.id in keep:
                edits.setdefault(n.lineno - 1, []).append((n.col_offset, n.end_col_offset,
                                                           f"{n.id}__{k}"))
    out = list(lines)
    for i, spans in edits.items():
        for a, b, name in sorted(spans, reverse=True):
            out[i] = out[i][:a] + name + out[i][b:]
    return out


def _fresh_names(loop, loops: set) -> set:
    """The names per_loop_names may rename in one top-level loop."""
    compound = (ast.For, ast.While, ast.If)
    if any(isinstance(n, (ast.For, ast.While)) and n.orelse
           or isinstance(n, (ast.stmt, ast.expr)) and not isinstance(n, compound)
           and n.lineno != n.end_lineno for n in ast.walk(loop)):
        return set()
    first, places, parent = {}, {}, {}
    for node in ast.walk(loop):
        for child in ast.iter_child_nodes(node):
            parent[id(child)] = node
    for n in ast.walk(loop):
        if isinstance(n, ast.Name) and id(n) not in loops:
            key = (n.lineno, isinstance(n.ctx, ast.Store), n.col_offset)
            places.setdefault(n.id, []).append(n.lineno)
            if n.id not in first or key < first[n.id][0]:
                first[n.id] = (key, n)
    out = set()
    for name, ((_, store, _), n) in first.items():
        stmt = parent[id(n)]
        while isinstance(stmt, ast.Tuple):
            stmt = parent[id(stmt)]
        body = parent.get(id(stmt))
        if not (store and isinstance(stmt, ast.Assign) and isinstance(body, (ast.For, ast.While))
                and stmt in body.body):
            continue
        up = body
        while up is not loop:
            above = parent.get(id(up))
            if not isinstance(above, (ast.For, ast.While)) or up not in above.body:
                break
            up = above
        if up is loop and max(places[name]) <= body.end_lineno:
            out.add(name)
    return out
