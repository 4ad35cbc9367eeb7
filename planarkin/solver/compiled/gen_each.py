"""The design studies' point-by-point solve written out for one mechanism structure (issue 17
target 2: studies solve their variants through a generated kernel with a per-point parameter
table).

A generic solve reading the structure from arrays at every point was slower on the four-bar (it
was removed on 2026-12-06; benchmarks/README.md, "Figures moved from the code's comments"); here
the solve is written into Python source as planarkin.solver.compiled.gen writes the grid pass:
every row a call of its kind's function (planarkin.elements.pointline) with the coordinates
named as local variables, every block's Newton step, inverse and substitution written out for
its size. The algorithm, operation for operation: each point alone, block by block, each block
by Newton to that point's own convergence (an affine block: one step), the inverse 1 x 1 and
2 x 2 in closed form, larger ones by Gauss-Jordan, an angle's cosine and sine recomputed when it
moved or is a zero, then the velocities and accelerations by forward substitution through the
inverse's entries (an affine block whose gradient its own unknowns do not move keeps its Newton
inverse), and the studies' acceptance tests (planarkin.solver.compiled.helpers.accept_point).
The element parameters of point i are row vrow[i] of a table of parameter sets, its drivers' row
trow[i]: one compiled function per structure serves every variant.

Arrays are flat (row-major).
"""

from __future__ import annotations

from planarkin.solver.compiled.gen import KGEN, Writer, discards, helper_lines, pairs
from planarkin.elements.pointline import CODES

VERSION = 1       # of the generated text's shape (gen.name_of hashes this file too)

_SLOTS = 6


class EachWriter(Writer):
    """The source of one structure's point-by-point solve (see the module docstring)."""

    def keep(self, b) -> bool:
        """keep[b]: the Newton inverse of affine block b is exact at the converged
        positions (its rows: angle, or revolute, x, y without an angle among its unknowns)."""
        kb, cols, rows, aff = self.blocks[b]
        if not aff:
            return False
        for row in rows:
            e = int(self.rowel[row])
            kd = int(self.kind[e])
            if kd not in (1, 3, 4, 5):
                return False
            if kd != 3 and any(c in (3 * int(self.bi[e]) + 2, 3 * int(self.bj[e]) + 2)
                               for c in cols):
                return False
        return True

    def matrix(self, d, b, x, dense):
        """Block b's matrix from the gradients d<x>_...: locals J<x>_<k> (closed forms) or
        JW (dense)."""
        kb = self.blocks[b][0]
        src = self.entries(b, x)
        if dense:
            self.out(d, f"for uk in range({kb * kb}):")
            self.out(d + 1, "JW[uk] = 0.0")
            for pos, name in src.items():
                self.out(d, f"JW[{pos}] = {name}")
        else:
            for k in range(kb * kb):
                self.out(d, f"J{x}_{k} = {src.get(k, '0.0')}")

    def inverse(self, d, b, x, newton):
        """The inverse M<x>_<k> (dense: MB[mo<b>:]): with newton, sigma_min's
        bound s0<x> and the sign sg<x> (invert_small), else the entries only."""
        kb = self.blocks[b][0]
        o = self.out
        if kb == 1:
            o(d, f"M{x}_0 = 1.0 / J{x}_0")
            if newton:
                o(d, f"s0{x} = abs(J{x}_0)")
                o(d, f"sg{x} = sign_of(J{x}_0)")
        elif kb == 2:
            if newton:
                o(d, f"det{x} = J{x}_0 * J{x}_3 - J{x}_1 * J{x}_2")
                o(d, f"rd{x} = 1.0 / det{x}")
            else:
                o(d, f"rd{x} = 1.0 / (J{x}_0 * J{x}_3 - J{x}_1 * J{x}_2)")
            o(d, f"M{x}_0 = J{x}_3 * rd{x}")
            o(d, f"M{x}_1 = -J{x}_1 * rd{x}")
            o(d, f"M{x}_2 = -J{x}_2 * rd{x}")
            o(d, f"M{x}_3 = J{x}_0 * rd{x}")
            if newton:
                o(d, f"nf{x} = np.sqrt(J{x}_0 * J{x}_0 + J{x}_1 * J{x}_1 + J{x}_2 * J{x}_2 + "
                     f"J{x}_3 * J{x}_3) * abs(rd{x})")
                o(d, f"s0{x} = 1.0 / nf{x} if (math.isfinite(nf{x}) and det{x} != 0) else 0.0")
                o(d, f"sg{x} = sign_of(det{x})")
        else:
            o(d, f"ok{x}, sg{x} = gj({kb}, JW, 0, MB, {self.mof[b]}, WK)")
            if newton:
                o(d, "fs = 0.0")
                o(d, f"for uk in range({kb * kb}):")
                o(d + 1, f"fs += MB[{self.mof[b]} + uk] * MB[{self.mof[b]} + uk]")
                o(d, f"s0{x} = 1.0 / np.sqrt(fs) if ok{x} else 0.0")

    def minv(self, b, x, k):
        return f"MB[{self.mof[b] + k}]" if self.blocks[b][0] > KGEN else f"M{x}_{k}"

    # the first iteration's determinant signs: Writer.fine_signs with these two
    def sign_at(self, f: int) -> str:
        return f"sign[i * {self.P.nfine} + {f}]"      # sign flat (N * nfine)

    def entry(self, b: int, k: int) -> str:
        return f"JW[{k}]" if self.blocks[b][0] > KGEN else f"J{b}_{k}"   # small: scalars

    def position(self, b):
        """Block b for point i: Newton to its own convergence."""
        kb, cols, rows, aff = self.blocks[b]
        o = self.out
        x = str(b)
        nblk = len(self.blocks)
        dense = kb > KGEN
        o(2, f"# block {b}: columns {cols}, rows {rows}{' (affine)' if aff else ''}")
        o(2, "sz = np.inf")
        if not dense:
            for k in range(kb * kb):
                o(2, f"M{x}_{k} = 0.0")
        o(2, f"for it in range({'1' if aff else 'maxit'}):")
        # the gradient at every iteration (g is the same with or without it): one call a row
        self.evaluate(3, b, 3, x, matrix=False)
        for rp, row in enumerate(rows):
            o(3, f"r{x}_{rp} = g{x}_{rp} - T[ti + {row}]")
        d = 3
        if not aff:
            o(3, "if it == 0 or full != 0:")
            d = 4
        self.matrix(d, b, x, dense)
        self.inverse(d, b, x, True)
        o(d, "if it == 0:")
        o(d + 1, f"smin[i * {nblk} + {b}] = s0{x}")
        self.fine_signs(d + 1, b)
        o(3, "sz = 0.0")
        for a, c in enumerate(cols):
            terms = " + ".join(f"{self.minv(b, x, a * kb + k)} * r{x}_{k}" for k in range(kb))
            o(3, f"dx = 0.0 + {terms}")
            o(3, f"q{c} -= dx")
            o(3, "sz = nanmax(sz, abs(dx))")
            if c % 3 == 2:
                o(3, f"if dx != 0.0 or q{c} == 0.0:")
                o(4, f"c{c // 3} = np.cos(q{c})")
                o(4, f"s{c // 3} = np.sin(q{c})")
        o(3, "sz = inf_unless_finite(sz)")
        o(3, "if it == 0:")
        o(4, f"rat = nanmax(rat, ratio_of(sz, smin[i * {nblk} + {b}]))")
        o(3, "its = max(its, it + 1)")
        if aff:
            o(3, "sz = 0.0 if sz < np.inf else np.inf")
            o(3, "break")
        else:
            o(3, "if sz <= tol:")
            o(4, "break")
        o(2, "ok = ok and sz <= tol")

    def rate(self, b, X):
        """Block b's rows of the velocity (X 'v') or acceleration ('a') system, through the
        inverse's entries."""
        kb, cols, rows, aff = self.blocks[b]
        o = self.out
        x = str(b)
        last = len(self.blocks) - 1
        keep = self.keep(b)
        y = x if keep else x + "c"
        if X == "v" and not keep:
            self.evaluate(2, b, 2, y, matrix=False)
            self.matrix(2, b, y, kb > KGEN)
            self.inverse(2, b, y, False)
        for rp, row in enumerate(rows):
            if X == "v":
                rhs = f"NU[ti + {row}]"
            else:
                o(2, f"_, _, _, _, _, _, _, gm{x}_{rp} = {self.call(row, 4, upto=last)}")
                rhs = f"gm{x}_{rp} + FDD[ti + {row}]"
            terms = []
            for k in range(6):
                c = int(self.rcol[row, k])
                known = c < self.n and self.colblock.get(c, b) < b
                terms.append(f"d{y}_{rp}_{k} * {X}{c}" if known else None)
            expr = pairs(terms)
            o(2, f"{X}r{x}_{rp} = ({rhs}) - {expr}" if expr else f"{X}r{x}_{rp} = {rhs}")
        for a, c in enumerate(cols):
            terms = " + ".join(f"{self.minv(b, y, a * kb + k)} * {X}r{x}_{k}" for k in range(kb))
            o(2, f"{X}{c} = 0.0 + {terms}")

    def source(self) -> str:
        o, n, nb, m = self.out, self.n, self.nb, self.m
        W = n + 3
        self.mof, mo = [], 0
        for blk in self.blocks:
            self.mof.append(mo)
            mo += blk[0] * blk[0] if blk[0] > KGEN else 0
        o(0, '"""planarkin.solver.compiled.gen_each: the studies\' point-by-point solve of one '
             'mechanism structure (generated; the file is used only while its bytes are the '
             'generated text)."""')
        for line in ("import math", "", "import numba", "import numpy as np", "",
                     "from planarkin.elements import pointline as E",
                     "from planarkin.solver.compiled import helpers as K", ""):
            o(0, line)
        o(0, "# CACHE: numba's disk cache or not, given by planarkin.solver.compiled.kernels")
        o(0, "ROW = (numba.int64,) + (numba.float64,) * 22")
        for kd in sorted({CODES[int(k)] for k in self.kind}):
            o(0, f"k_{kd} = numba.njit([ROW], error_model='numpy', _nrt=False, cache=CACHE)"
                 f"(E.{kd})")
        o(0, "F1, I1 = numba.float64[::1], numba.int64[::1]")
        o(0, "INT, DBL = numba.int64, numba.float64")
        o(0, "gj = numba.njit([(INT, F1, INT, F1, INT, F1)], error_model='numpy', _nrt=False, "
             "cache=CACHE)(getattr(K.gauss_jordan, 'py_func', K.gauss_jordan))")
        o(0, "accept = numba.njit([(INT, INT, INT, INT, INT, F1, F1, F1, F1, F1, numba.uint8, "
             "DBL, INT, I1, INT, I1, F1, F1, F1, numba.boolean, numba.uint8[::1], F1)], "
             "error_model='numpy', _nrt=False, cache=CACHE)(getattr(K.accept_point, 'py_func', "
             "K.accept_point))")
        for line in helper_lines():
            o(0, line)
        o(0, "")
        o(0, "")
        o(0, "@numba.njit(cache=CACHE, error_model='numpy', nogil=True)")
        o(0, "def each(N, Q, Qd, Qdd, T, NU, FDD, maxit, tol, full, iters, conv, ratio, sign, "
             "smin, has_v, vrow, prm, ne, has_t, trow, tg, sign0, test, good, perr):")
        o(1, "ZERO = 0.0")
        o(1, "ONE = 1.0")
        o(1, "W1, W2, W3, W4, W5 = 1, 2, 3, 4, 5")
        kd = max([blk[0] for blk in self.blocks], default=1)
        fmax = max(max(z) for z in self.sizes)
        o(1, f"JW = np.empty({kd * kd})")
        o(1, f"MB = np.empty({max(mo, 1)})")
        o(1, f"WK = np.empty({2 * max(kd, fmax) ** 2})")
        o(1, f"SB = np.empty({fmax * fmax})")
        o(1, f"SI = np.empty({fmax * fmax})")
        o(1, f"jerk = np.empty({max(n, 1)})")
        o(1, "jerk_ok = False")
        o(1, "for i in range(N):")
        o(2, f"qo = i * {W}")
        o(2, f"ti = (trow[i] if has_t != 0 else i) * {m}")
        o(2, "pb = vrow[i] * 8 * ne if has_v != 0 else 0")
        for e in range(len(self.kind)):
            for k in range(_SLOTS):
                o(2, f"p{e}_{k} = prm[pb + {8 * e + k}]")
        o(2, "rat = 0.0")
        o(2, "its = 0")
        o(2, "ok = True")
        for c in range(n):
            o(2, f"q{c} = Q[qo + {c}]")
        for b in range(nb):
            o(2, f"if q{3 * b + 2} == 0.0:")
            o(3, f"c{b} = 1.0")
            o(3, f"s{b} = 0.0")
            o(2, "else:")
            o(3, f"c{b} = np.cos(q{3 * b + 2})")
            o(3, f"s{b} = np.sin(q{3 * b + 2})")
        for b in range(len(self.blocks)):
            self.position(b)
        o(2, "iters[i] = its")
        o(2, "conv[i] = 1 if ok else 0")
        o(2, "ratio[i] = rat")
        for c in range(n):
            o(2, f"Q[qo + {c}] = q{c}")
        for b in range(len(self.blocks)):
            self.rate(b, "v")
        for b in range(len(self.blocks)):
            self.rate(b, "a")
        for c in range(W):
            o(2, f"Qd[qo + {c}] = {'v' + str(c) if c < n else '0.0'}")
            o(2, f"Qdd[qo + {c}] = {'a' + str(c) if c < n else '0.0'}")
        o(2, "if test != 0:")
        o(3, f"jerk_ok = accept(i, {W}, {n}, {len(self.blocks)}, {self.P.nfine}, Q, Qd, Qdd, "
             "smin, sign, conv[i], ratio[i], has_t, trow, has_v, vrow, tg, sign0, jerk, "
             "jerk_ok, good, perr)")
        return "\n".join(discards(o.lines)) + "\n"


def source(P, W: int, m: int, nb: int) -> str:
    """The module text of the studies' point-by-point solve for packed system P
    (gen.covers(P))."""
    return EachWriter(P, W, m, nb).source()
