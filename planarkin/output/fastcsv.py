"""Fast, exact CSV formatting of float64 tables.

``format_table(X)`` renders every value exactly as ``repr(float(v))`` does
(shortest round-trip digits, Python's layout: positional for
-4 <= exponent < 16, otherwise scientific with >= 2 exponent digits; ``nan``,
``inf``, ``-inf``), separated by ``,`` with ``\n`` after each row.  It uses
vectorised numpy (float64/int64) arithmetic on blocks of values, many times
faster per value than ``','.join(map(repr, row))`` (benchmarks/bench_fastcsv.py;
benchmarks/README.md, "Figures moved from the code's comments").
``write_table(f, X)`` streams the same bytes to a file block by block.

Method (per value, vectorised over a block of ~16k values)
---------------------------------------------------------
1. *Scaling.*  ``|x| = m * 2**E`` with ``m`` in [1, 2).  The decimal exponent
   ``e10 = floor(log10|x|)`` is ``t`` or ``t + 1`` with
   ``t = floor(E*log10(2))``, decided exactly by comparing ``m`` with a table
   of thresholds (the smallest double >= 10**(t+1) / 2**E).  Then
   ``y = |x| * 10**(16 - e10)``, in [1e16, 1e17), is ``m * G`` with the
   exact rational ``G = 2**E * 10**(16-e10)`` tabulated (per binary exponent
   and flag) as ``G1`` (27 significant bits) + ``G2`` (the next 53 bits) and
   ``Gf = double(G)``.  With ``m = mh + ml`` (``mh`` = m rounded to 26
   significant bits, ``|ml| <= 2**-26``), ``P = mh*G1`` is exact (53 bits) and
   an integer (>= 2**53), and ``R = ml*Gf + mh*G2`` (|R| < 2**32) carries an
   absolute error below 2e-6 units of the 17th digit (4e-7 observed; checked
   against exact rationals in the tests).  ``N = P + floor(R)`` (int64) and
   ``F = R - floor(R)`` give ``y = N + F``.
   (``numpy.longdouble`` was measured first: many times slower per operation
   than float64, ``floor`` most of all, and only ~2**-65 relative
   precision; Dekker's exact two-product in float64 also works but costs 10
   more passes than this precision needs.)

2. *Shortest digits.*  For p = 15, 16, 17 the candidates are the nearest
   p-digit decimals ``round(y / 10**(17-p))``.  A candidate round-trips iff
   its distance from ``y`` is below half the gap to the neighbouring doubles,
   ``h = Gf * 2**-53`` in the same units.  The smallest p whose nearest
   candidate round-trips wins, as in repr (dtoa mode 0: shortest, then
   nearest).
   * 17 digits always round-trip: the 17-digit spacing is at most
     ``2**53 * 10**-16 = 0.9007`` ulp, so ``h >= 0.555`` digit units while the
     nearest 17-digit decimal is at most 0.5 units away -- even if a near tie
     were rounded the wrong way because of the 2e-6 error, the result would
     be at most 0.500002 < 0.555 units away and still round-trip.  Near ties
     are nevertheless sent to the exact fallback, so that the nearer decimal
     (the one repr prints) is chosen.
   * Shortest representations with fewer than 15 digits come out of the
     p = 15 step after stripping trailing zeros: the 15-digit spacing is more
     than 4.5 ulp, so at most one 15-digit decimal lies in the rounding
     interval, and a shorter round-tripping decimal padded with zeros is such
     a decimal.  (Checked in the tests.  Not true for subnormals, whose
     precision is lower: those use the exact fallback.)
   * A p = 16 or 17 result never ends in 0 (it would be a shorter candidate
     that was already accepted), so only p = 15 results are stripped.
   * Exact powers of two have a gap below half as wide as above; their
     digits (2046 values) come from a table made with repr at import.

   Whenever a decision is within ``_TOL = 1e-5`` digit units of its threshold
   (a candidate at or next to the midpoint between two doubles, or a tie
   between two candidates), the value is *ambiguous*: its digits are taken
   from ``repr`` (exact).  With a computation error < 2e-6 this never hides a
   wrong decision.  The rate is ~2e-5 of random values, plus exact ties that
   occur for doubles with few fraction bits (large integers; ~1e-3 of random
   bit patterns), so the fallback adds next to nothing per value.

3. *Layout without per-value Python code.*  Each value becomes a right-aligned
   32-byte row: its text (without the optional minus sign) is a string of at
   most 23 "decimal digit positions", built as integers: the digit string D,
   with a 0 digit inserted where the '.' goes (V = D + 9 * I * 10**k, where I
   is the integer part and k the number of fraction digits; I = trunc(|x|)
   exactly, because a shortest repr never rounds across an integer), and, in
   scientific notation, followed by two 0 digits (for 'e' and the sign) and
   the exponent.  8-digit words are converted to bytes with two look-ups in a
   table of 4-digit byte strings, and then a per-layout pattern row is added
   (1638 layouts: sign x digit count x exponent/notation x separator): '0' on
   digit positions, the literal ('.', 'e', '+', '-', 'nan', 'inf') on the zero
   positions, and the separator in byte 24.

4. *Compaction.*  The rows (25 bytes each, text right-aligned, garbage on the
   left) are copied into the output with one fancy assignment through an
   overlapping (stride 1) view, in *descending* row order: each row's left
   garbage lands on the previous row, which is written afterwards.  numpy
   performs such assignments in index order; this is verified at import, with
   a boolean-mask compaction as fallback.

All buffers of a block are preallocated (``_Work``): on Linux, large
temporaries are mmap-ed and page-faulted again on many allocations, which on
the VMs measured costs more than the arithmetic.  For the same reason the
final ``bytes`` object (one page-faulting pass over ~20 bytes per value, plus
one for the per-block pieces) is a noticeable part of ``format_table``'s time
on big tables; ``write_table`` avoids both.

The result is deterministic (IEEE float64/int64 arithmetic only, no FMA can
be contracted across numpy calls) and independent of the block size.  The
exactness preconditions are self-checked at import; if they fail (unusual
platform), ``format_table`` falls back to ``repr``.
"""

from __future__ import annotations

import math
import numpy as np

__all__ = ["format_table", "format_value", "write_table"]

_CHUNK_VALUES = 1 << 14  # values per internal block (workspace ~4 MB)
_ITEM = 25  # bytes per rendered row: 24 text positions + separator
_TOL = 1e-5  # ambiguity margin, in units of the 17th significant digit

_POW10 = np.array([10**i for i in range(19)], dtype=np.int64)


# ---------------------------------------------------------------------------
# Tables for the exact scaling (index 2*biased_exponent + flag)
# ---------------------------------------------------------------------------

# powers of ten up to the doubles' range (|K| <= 326 below), made once: raising 10 to each
# power afresh was half of building the tables at import (every run's start-up)
_P10 = [10**k for k in range(400)]


def _ratio(E: int, K: int) -> tuple[int, int]:
    """2**E * 10**K as an integer fraction (num, den)."""
    num = (1 << max(E, 0)) * _P10[max(K, 0)]
    den = (1 << max(-E, 0)) * _P10[max(-K, 0)]
    return num, den


def _build_scale_tables():
    """Per index 2*b + f (b = biased binary exponent, f = 1 when |x| >=
    10**(t+1)): G = 2**E * 10**(16 - e10) as G1 (27 bits) + G2 (next 53
    bits), Gf = double(G), and 5 - h with h = Gf * 2**-53 (half an ulp of x
    in units of the 17th digit); e10; and the thresholds per b (the smallest
    double >= 10**(t+1) / 2**E).  Exact integer arithmetic."""
    n = 2 * 2048
    gtab = np.zeros((n, 4))  # rows 0, 1 (zero, subnormals): N = 0, "0.0"
    gtab[4094:, 0] = gtab[4094:, 2] = 1e16
    e10 = np.zeros(n, dtype=np.int64)
    thr = np.full(2048, np.inf)
    for b in range(1, 2047):
        E = b - 1023
        t = (E * 78913) >> 18  # floor(E * log10(2)), then checked exactly
        while True:
            n0, d0 = _ratio(-E, t)          # 10**t / 2**E
            n1, d1 = _ratio(-E, t + 1)
            if n0 > d0:
                t -= 1
            elif n1 <= d1:
                t += 1
            else:
                break
        # threshold: ceil(r) on the double grid, r = 10**(t+1) / 2**E in (1, 10]
        e2 = n1.bit_length() - d1.bit_length()
        if (n1 >> e2 if e2 >= 0 else n1 << -e2) < d1:
            e2 -= 1
        sc = 52 - e2
        c = -((-n1 << sc) // d1)
        thr[b] = math.ldexp(float(c), -sc)
        for f in (0, 1):
            num, den = _ratio(E, 16 - t - f)
            sh = 128 - (num.bit_length() - den.bit_length())
            q = (num << sh) // den if sh >= 0 else num // (den << -sh)
            drop = q.bit_length() - 27
            g1 = (q + (1 << (drop - 1))) >> drop
            i = 2 * b + f
            gf = math.ldexp(float(q), -sh)
            gtab[i] = (math.ldexp(float(g1), drop - sh),
                       math.ldexp(float(q - (g1 << drop)), -sh),
                       gf, 5.0 - gf * 2.0**-53)
            e10[i] = t + f
    e10[:2] = -1  # zero: "0.d" with D = 0
    return gtab, e10, thr


_GTAB, _E10, _THR = _build_scale_tables()


# ---------------------------------------------------------------------------
# Layout classes
# ---------------------------------------------------------------------------
# class = 2 * (sign + 2*(nd-1) + 34*t) + newline, where t = e + 4 for the
# positional layout (-4 <= e <= 15) and t = 20 + 2*(3 exponent digits) +
# (exponent < 0) for the scientific one; 816, 817, 818 (before doubling) are
# 'nan', 'inf', '-inf'.
_NCLS = 819
_CLS_NAN, _CLS_INF, _CLS_NINF = 816, 817, 818


def _template(sign: int, nd: int, t: int) -> str:
    """Text template: 'd' = digit position (from the digit field), other
    characters are literals (the digit field holds a 0 there)."""
    if t < 20:
        e = t - 4
        if e >= 0:
            s = "d" * (e + 1) + "." + "d" * max(nd - e - 1, 1)
        else:
            s = "d." + "d" * (-e - 1 + nd)
    else:
        ed = 3 if (t - 20) & 2 else 2
        es = "-" if (t - 20) & 1 else "+"
        s = "d" + ("." + "d" * (nd - 1) if nd > 1 else "") + "e" + es + "d" * ed
    return ("-" if sign else "") + s


def _build_layout_tables():
    """(2*819, 4) int64 rows of 32 bytes: byte 23-j holds the j-th character
    from the end of the text ('0' for digit positions, to be added to the
    digit value), byte 24 the separator.  Plus the total length (text + sep)."""
    pat = np.zeros((2 * _NCLS, 32), dtype=np.uint8)
    length = np.zeros(2 * _NCLS, dtype=np.int64)
    texts = {}
    for t in range(24):
        for nd in range(1, 18):
            for sign in (0, 1):
                texts[sign + 2 * (nd - 1) + 34 * t] = _template(sign, nd, t)
    texts[_CLS_NAN] = "nan"
    texts[_CLS_INF] = "inf"
    texts[_CLS_NINF] = "-inf"
    for c, s in texts.items():
        assert len(s) <= 24
        for nl in (0, 1):
            row = pat[2 * c + nl]
            for j, ch in enumerate(reversed(s)):
                row[23 - j] = 0x30 if ch == "d" else ord(ch)
            row[24] = 0x0A if nl else 0x2C
            length[2 * c + nl] = len(s) + 1
    return np.ascontiguousarray(pat).view("<i8"), length


_PAT, _LEN = _build_layout_tables()


# ---------------------------------------------------------------------------
# Exact slow path
# ---------------------------------------------------------------------------

def _digits_of(v: float) -> tuple[int, int, int]:
    """(D, nd, e) of repr(abs(v)) for finite nonzero v: digits D (no trailing
    zeros), number of digits, decimal exponent of the first digit."""
    s = repr(abs(v))
    if "e" in s:
        mant, ex = s.split("e")
        ex = int(ex)
    else:
        mant, ex = s, 0
    ip, _, fp = mant.partition(".")
    if ip.strip("0"):
        e = ex + len(ip.lstrip("0")) - 1
    else:
        e = ex - (len(fp) - len(fp.lstrip("0"))) - 1
    digits = (ip + fp).strip("0")
    return int(digits), len(digits), e


def _slow_table(X: np.ndarray) -> bytes:
    return "".join(",".join(map(repr, row.tolist())) + "\n" for row in X).encode()


# ---------------------------------------------------------------------------
# Vectorised kernel
# ---------------------------------------------------------------------------
# numpy scalars (Python scalars cost an extra conversion per ufunc call)
_i = np.int64
_f = np.float64
_C52, _C7FF, _CFRAC = _i(52), _i(0x7FF), _i((1 << 52) - 1)
_CONE = _i(0x3FF0000000000000)
_C5, _C45, _C50, _CHALF, _CTOL = _f(5.0), _f(45.0), _f(50.0), _f(0.5), _f(_TOL)
_I0, _I1, _I5, _I10, _I17, _I100 = _i(0), _i(1), _i(5), _i(10), _i(17), _i(100)
_E4, _E8, _E16 = _i(10**4), _i(10**8), _i(10**16)
# class index (see _build_layout_tables) of a positional value, as
# 68*e + 4*nd + 2*neg + newline + _CLS_OFF
_I68, _I4 = _i(68), _i(4)
_CLS_OFF = 68 * 4 - 4

# digit tables: 4 decimal digits -> 4 bytes (digit values 0..9, most
# significant first in memory); _T4H is the same shifted to bytes 4..7
_T4 = np.zeros(10**4, dtype=np.int64)
for _d in range(4):
    _T4 |= ((np.arange(10**4) // 10 ** (3 - _d)) % 10) << (8 * _d)
_T4H = _T4 << 32

# positional layout, indexed by k + 20 where k = nd - 1 - e is the number of
# fraction digits (<= 0 when the value is an integer, printed as "I.0"):
# V = D * _KM + I * _KP9 is D with a 0 digit inserted before the fraction
_KP9 = np.zeros(41, dtype=np.int64)  # 9 * 10**k  (0 if k <= 0 or k > 18)
_KM = np.ones(41, dtype=np.int64)    # 10**(2-k) for k <= 0, else 1
for _k in range(-20, 21):
    if 1 <= _k <= 18:
        _KP9[_k + 20] = 9 * 10**_k
    elif _k <= 0 and 2 - _k <= 18:
        _KM[_k + 20] = 10 ** (2 - _k)


def _pow2_table():
    d = np.zeros(2048, dtype=np.int64)
    nd = np.ones(2048, dtype=np.int64)
    e = np.zeros(2048, dtype=np.int64)
    for b in range(1, 2047):
        d[b], nd[b], e[b] = _digits_of(math.ldexp(1.0, b - 1023))
    return d, nd, e


_P2D, _P2N, _P2E = _pow2_table()


class _Work:
    """Preallocated buffers for one block of n values.  Every vectorised step
    writes into these (out=...), so formatting a block allocates nothing
    large: on Linux, large temporaries are mmap-ed and page-faulted afresh on
    many calls, which costs more than the arithmetic."""

    def __init__(self, n: int):
        self.n = n
        f = lambda: np.empty(n, dtype=np.float64)  # noqa: E731
        i = lambda: np.empty(n, dtype=np.int64)    # noqa: E731
        b = lambda: np.empty(n, dtype=np.bool_)    # noqa: E731
        self.f1, self.f2, self.f3, self.f4, self.f5 = f(), f(), f(), f(), f()
        (self.bexp, self.frac, self.mi, self.j, self.N, self.e, self.q100, self.D,
         self.nd, self.cls, self.V, self.I, self.HI, self.LO, self.a, self.b, self.g,
         self.w, self.w0, self.L, self.ends, self.i1, self.i2, self.k15, self.k16) = (
            i() for _ in range(25))
        self.b1, self.b2, self.flag, self.ok15, self.ok16, self.amb = (b() for _ in range(6))
        self.gt = np.empty((n, 4), dtype=np.float64)
        self.rows = np.empty((n, 4), dtype=np.int64)
        self.out = np.empty(n * _ITEM + _ITEM, dtype=np.uint8)

    def view(self, n: int) -> "_Work":
        """The same buffers cut to the first n values."""
        if n == self.n:
            return self
        v = object.__new__(_Work)
        for k, a in self.__dict__.items():
            v.__dict__[k] = a[:n] if isinstance(a, np.ndarray) and k != "out" else a
        v.n = n
        return v


def _scale(x, w):
    """Scaling: |x| * 10**(16-e10) = N + F with N int64 in [1e16, 1e17) and
    F in [0, 1), absolute error < 2e-6 (see module doc).
    Returns N, F, c16 (= 5 - h), e10, bexp, frac."""
    bits = x.view(np.int64)
    bexp = np.right_shift(bits, _C52, out=w.bexp)
    np.bitwise_and(bexp, _C7FF, out=bexp)
    frac = np.bitwise_and(bits, _CFRAC, out=w.frac)
    m = np.bitwise_or(frac, _CONE, out=w.mi).view(np.float64)  # mantissa in [1, 2)
    thr = np.take(_THR, bexp, out=w.f1, mode="clip")
    flag = np.greater_equal(m, thr, out=w.flag)                # |x| >= 10**(t+1)
    j = np.add(bexp, bexp, out=w.j)
    np.add(j, flag, out=j)
    g = np.take(_GTAB, j, axis=0, out=w.gt, mode="clip")
    mh = np.add(m, _CRND, out=w.f1)        # m rounded to 25 fraction bits
    np.subtract(mh, _CRND, out=mh)
    ml = np.subtract(m, mh, out=w.f2)      # |ml| <= 2**-26
    P = np.multiply(mh, g[:, 0], out=w.f3)  # exact (27 x 26 bits), an integer
    R = np.multiply(ml, g[:, 2], out=w.f4)
    np.add(R, np.multiply(mh, g[:, 1], out=ml), out=R)  # |R| < 2**32, error < 2e-6
    fl = np.floor(R, out=w.f2)
    N = w.N
    np.copyto(N, P, casting="unsafe")
    t = w.i1
    np.copyto(t, fl, casting="unsafe")
    np.add(N, t, out=N)
    F = np.subtract(R, fl, out=R)
    e = np.take(_E10, j, out=w.e, mode="clip")
    return N, F, g[:, 3], e, bexp, frac


def _choose(N, F, c16, w):
    """Shortest round-trip digits from the scaled value (see module doc).
    Returns D, nd, ok15, ambiguous-mask."""
    q100 = np.floor_divide(N, _I100, out=w.q100)
    r = np.multiply(q100, _I100, out=w.i1)
    np.subtract(N, r, out=r)
    rem15 = w.f1
    np.copyto(rem15, r)
    np.add(rem15, F, out=rem15)                # y mod 100
    t = np.multiply(rem15, _f(0.1), out=w.f2)
    np.floor(t, out=t)
    np.multiply(t, _C10F, out=t)
    rem16 = np.subtract(rem15, t, out=t)       # y mod 10 (a wrap-around is harmless)
    d15 = np.subtract(rem15, _C50, out=w.f3)
    np.abs(d15, out=d15)
    np.subtract(d15, c16, out=d15)
    np.subtract(d15, _C45, out=d15)            # > 0: nearest 15-digit decimal round-trips
    u16 = np.subtract(rem16, _C5, out=w.f5)
    np.abs(u16, out=u16)
    d16 = np.subtract(u16, c16, out=rem16)     # > 0: nearest 16-digit decimal round-trips
    ok15 = np.greater(d15, _C0, out=w.ok15)
    ok16 = np.greater(d16, _C0, out=w.ok16)
    # ambiguous: a decision within _TOL of its threshold, or a near tie
    a = np.abs(d15, out=d15)
    np.minimum(a, np.abs(d16, out=d16), out=a)
    np.minimum(a, u16, out=a)
    h = np.subtract(F, _CHALF, out=u16)
    np.minimum(a, np.abs(h, out=h), out=a)
    amb = np.less(a, _CTOL, out=w.amb)
    # candidates: 17 digits N + (F >= .5), 16 (N + 5) // 10, 15 q100 + (rem15 > 50)
    np.add(q100, np.greater(rem15, _C50, out=w.b1), out=q100)
    D16 = np.add(N, _I5, out=w.i1)
    np.floor_divide(D16, _I10, out=D16)
    D = np.add(N, np.greater_equal(F, _CHALF, out=w.b1), out=w.D)
    k15 = w.k15
    k16 = w.k16
    np.copyto(k15, ok15)
    np.copyto(k16, ok16)
    np.subtract(q100, D16, out=q100)           # D16 += ok15 * (D15 - D16)
    np.multiply(q100, k15, out=q100)
    np.add(D16, q100, out=D16)
    np.subtract(D16, D, out=D16)               # D += ok16 * (D16 - D)
    np.multiply(D16, k16, out=D16)
    np.add(D, D16, out=D)
    nd = np.subtract(_I17, k16, out=w.nd)
    np.subtract(nd, k15, out=nd)
    return D, nd, ok15, amb


_C10F = _f(10.0)
_C0 = _f(0.0)
_U2E53, _U2E54 = np.uint64(1 << 53), np.uint64(1 << 54)
_CRND = _f(1.5 * 2.0**27)


def _really_ambiguous(N, F, c16):
    """Exact version of _choose's ambiguity filter for a (small) subset:
    only the decisions that matter for the chosen digit count count."""
    rem15 = (N % 100).astype(np.float64) + F
    rem16 = (N % 10).astype(np.float64) + F
    d15 = np.abs(rem15 - 50.0) - c16 - 45.0
    u16 = np.abs(rem16 - 5.0)
    d16 = u16 - c16
    ok15 = d15 > 0
    ok16 = d16 > 0
    tol = _TOL
    return ((np.abs(d15) < tol) | (np.abs(d16) < tol)
            | (ok16 & ~ok15 & (u16 < tol))
            | (~ok16 & (np.abs(F - 0.5) < tol)))


def _strip_zeros(D, nd, idx):
    """Remove the trailing zeros of D[idx] (at most 15), adjusting nd."""
    Ds = D[idx]
    nds = nd[idx]
    for k in (8, 4, 2, 1):
        pk = _i(10**k)
        q = Ds // pk
        z = Ds == q * pk
        Ds = np.where(z, q, Ds)
        nds -= z * _i(k)
    D[idx] = Ds
    nd[idx] = nds


def _strip_zeros_all(D, nd, w):
    """_strip_zeros on the whole block (D of 16/17-digit results has no
    trailing zeros, see module doc), without allocating."""
    q, t, z = w.i2, w.I, w.b2
    for k in (8, 4, 2, 1):
        pk = _i(10**k)
        np.floor_divide(D, pk, out=q)
        np.multiply(q, pk, out=t)
        np.equal(D, t, out=z)
        np.subtract(q, D, out=q)                # D += z * (q - D)
        np.multiply(q, z, out=q)
        np.add(D, q, out=D)
        np.multiply(z, _i(k), out=t)
        np.subtract(nd, t, out=nd)
    np.maximum(nd, _I1, out=nd)             # zeros (D = 0) keep one digit


def _digits(x, w):
    """Shortest repr digits of flat float64 x: (D, nd, e, bexp, frac) with
    |x| == D * 10**(e - nd + 1) after rounding (repr's digits); zero: D = 0,
    nd = 1, e = -1 (laid out as "0.0"); nan/inf: D = 0, nd = 1."""
    N, F, c16, e, bexp, frac = _scale(x, w)
    D, nd, ok15, amb = _choose(N, F, c16, w)
    bits = x.view(np.int64)
    # carry (rounded up to 10**nd): "1" with exponent + 1
    if N.max() >= 10**17 - 50:
        carry = (N >= _i(10**17 - 50)) & (D == np.take(_POW10, nd))
        D[carry] = 1
        nd[carry] = 1
        e += carry
        ok15 &= ~carry
    # zeros took the main path with N = 0 (table rows 0, 1): D = 0, e = -1;
    # the layout of "0.d" with nd = 1 is "0.0"
    s1 = np.left_shift(bits, _I1, out=w.i1).view(np.uint64)   # |x| bits << 1
    irr = np.less(s1, _U2E53, out=w.b1)                        # zero or subnormal
    if irr.any():
        zero = s1 == np.uint64(0)
        ok15 &= ~zero
        nd -= zero * _i(14)
        irr &= ~zero                                           # subnormals
    n15 = np.count_nonzero(ok15)
    if 4 * n15 > D.size:
        _strip_zeros_all(D, nd, w)
    elif n15:
        _strip_zeros(D, nd, np.flatnonzero(ok15))
    # irregular values: powers of two with an asymmetric gap below (table),
    # nan/inf, subnormals and ambiguous ones (repr)
    pow2 = np.equal(frac, _I0, out=w.flag)
    pow2 &= s1 >= _U2E54                                       # bexp >= 2
    irr |= pow2
    if amb.any():
        ai = np.flatnonzero(amb)
        irr[ai[_really_ambiguous(N[ai], F[ai], c16[ai])]] = True
    if bexp.max() == 0x7FF:
        irr |= bexp == _C7FF
    if irr.any():
        idx = np.flatnonzero(irr)
        bi = bexp[idx]
        p2 = pow2[idx] | ((frac[idx] == 0) & (bi == 0x7FF))
        if p2.any():
            i2 = idx[p2]
            b2 = bi[p2]
            D[i2] = _P2D[b2]
            nd[i2] = _P2N[b2]
            e[i2] = _P2E[b2]
        nan = (bi == 0x7FF) & ~p2
        if nan.any():
            i3 = idx[nan]
            D[i3] = 0
            nd[i3] = 1
            e[i3] = 0
        slow = idx[~p2 & ~nan]
        if slow.size:
            res = [_digits_of(v) for v in x[slow].tolist()]
            D[slow] = [r[0] for r in res]
            nd[slow] = [r[1] for r in res]
            e[slow] = [r[2] for r in res]
    return D, nd, e, bexp, frac


def _rows(x, D, nd, e, bexp, frac, nlc, w):
    """Render into (n, 4) int64 rows: bytes 0..23 hold the text right-aligned
    (garbage before it), byte 24 the separator.  nlc = newline flag + class
    offset per value.  Returns (rows, lengths)."""
    bits = x.view(np.int64)
    neg2 = np.right_shift(bits, _i(62), out=w.i1)   # 2 if negative else 0
    np.bitwise_and(neg2, _i(2), out=neg2)
    # class (positional layout; scientific and specials patched below)
    cls = np.multiply(e, _I68, out=w.cls)
    np.add(cls, neg2, out=cls)
    np.add(cls, np.multiply(nd, _I4, out=neg2), out=cls)
    np.add(cls, nlc, out=cls)
    emax = e.max()
    emin = e.min()
    if emax < 0:
        V = D                              # 0.000ddd: digits only (scientific
                                           # values are redone below)
    else:
        # V = D with a 0 digit inserted before the fraction digits
        k = np.subtract(nd, e, out=w.i1)
        np.add(k, _i(19), out=k)           # k + 20, k = nd - 1 - e
        with np.errstate(invalid="ignore"):
            I = w.I                        # integer part (exact, see notes)
            np.copyto(I, np.abs(x, out=w.f1), casting="unsafe")
        np.multiply(I, np.take(_KP9, k, out=w.i2, mode="clip"), out=I)
        V = w.V
        if k.min() <= 20:                  # some integer values "I.0"
            np.multiply(D, np.take(_KM, k, out=w.i2, mode="clip"), out=V)
            np.add(V, I, out=V)
        else:
            np.add(D, I, out=V)
    HI = np.floor_divide(V, _E16, out=w.HI)
    LO = np.multiply(HI, _E16, out=w.LO)
    np.subtract(V, LO, out=LO)
    w0 = np.take(_T4H, HI, out=w.w0, mode="clip")   # HI < 100 if positional
    if emin < -4 or emax > 15:
        sci = (e + _I4).view(np.uint64) >= np.uint64(20)
        si = np.flatnonzero(sci)
        Ds = D[si]
        nds = nd[si]
        es = e[si]
        Pk = _POW10[nds - 1]
        Vs = Ds + (Ds // Pk) * Pk * (nds > 1) * 9   # d.ddd
        ae = np.abs(es)
        ed3 = ae >= 100
        div = np.where(ed3, 10**11, 10**12)
        HIs = Vs // div
        LO[si] = (Vs - HIs * div) * np.where(ed3, 10**5, 10**4) + ae
        w0[si] = _T4H[HIs % 10**4] | _T4[HIs // 10**4]
        tcls = 20 + 2 * ed3 + (es < 0)
        cls[si] = 2 * (34 * tcls + 2 * (nds - 1) + (bits[si] < 0)) + (nlc[si] & 1)
    if bexp.max() == 0x7FF:
        si = np.flatnonzero(bexp == _C7FF)
        c = np.where(frac[si] != 0, _CLS_NAN, np.where(bits[si] < 0, _CLS_NINF, _CLS_INF))
        cls[si] = 2 * c + (nlc[si] & 1)
    rows = np.take(_PAT, cls, axis=0, out=w.rows, mode="clip")
    np.add(rows[:, 0], w0, out=rows[:, 0])
    a = np.floor_divide(LO, _E8, out=w.a)        # digit positions 15..8
    b = np.multiply(a, _E8, out=w.b)             # digit positions 7..0
    np.subtract(LO, b, out=b)
    _add_word(rows[:, 1], a, w)
    _add_word(rows[:, 2], b, w)
    L = np.take(_LEN, cls, out=w.L, mode="clip")
    return rows, L


def _add_word(col, v, w):
    """col += the 8 digit bytes of v (< 1e8), most significant first."""
    g = np.floor_divide(v, _E4, out=w.g)
    lo4 = np.multiply(g, _E4, out=w.i1)
    np.subtract(v, lo4, out=lo4)
    wd = np.take(_T4H, lo4, out=w.w, mode="clip")
    np.bitwise_or(wd, np.take(_T4, g, out=w.i2, mode="clip"), out=wd)
    np.add(col, wd, out=col)


def _render(x: np.ndarray, nlc: np.ndarray, w: "_Work") -> np.ndarray:
    """Render flat float64 x (nlc: see _rows) using workspace w.  Returns a
    uint8 view of w.out with the concatenated text."""
    D, nd, e, bexp, frac = _digits(x, w)
    rows, L = _rows(x, D, nd, e, bexp, frac, nlc, w)
    ends = np.cumsum(L, out=w.ends)
    total = int(ends[-1])
    _compact(rows, ends, w.out[:total + _ITEM])
    return w.out[_ITEM:total + _ITEM]


def _compact_overlap(rows, ends, out):
    n = rows.shape[0]
    src = np.ndarray(shape=(n,), dtype=f"V{_ITEM}", buffer=rows, strides=(32,))
    dst = np.ndarray(shape=(out.size - _ITEM + 1,), dtype=f"V{_ITEM}", buffer=out, strides=(1,))
    dst[ends[::-1]] = src[::-1]


def _compact_mask(rows, ends, out):
    b = rows.view(np.uint8)[:, :_ITEM]
    L = np.diff(ends, prepend=0)
    keep = np.arange(_ITEM)[None, :] >= (_ITEM - L)[:, None]
    out[_ITEM:] = b[keep]


_compact = _compact_overlap


def _probe_overlap() -> bool:
    """Check that overlapping fancy assignment happens in index order."""
    n = 300
    i = np.arange(n * 4, dtype=np.int64)
    rows = ((i * 2654435761) % 1000003).reshape(n, 4)  # arbitrary bytes
    L = (i[:n] * 7919) % _ITEM + 1
    ends = np.cumsum(L)
    total = int(ends[-1])
    out = np.zeros(total + _ITEM, dtype=np.uint8)
    _compact_overlap(rows, ends, out)
    b = rows.view(np.uint8)
    ref = b"".join(bytes(b[k, _ITEM - L[k]:_ITEM]) for k in range(n))
    return out[_ITEM:].tobytes() == ref


# ---------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------

def _blocks(X: np.ndarray):
    """Yield the rendered text of X block by block (uint8 views into a scratch
    buffer that is reused: consume each block before asking for the next)."""
    nrows, ncols = X.shape
    step = max(1, _CHUNK_VALUES // ncols)
    nlc = np.full((min(step, nrows), ncols), _CLS_OFF, dtype=np.int64)
    nlc[:, -1] += 1
    nlc = nlc.ravel()
    work = _Work(nlc.size)
    for r0 in range(0, nrows, step):
        blk = np.ascontiguousarray(X[r0:r0 + step]).ravel()
        yield _render(blk, nlc[:blk.size], work.view(blk.size))


def _as_table(X) -> np.ndarray:
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X[:, None]
    if X.ndim != 2:
        raise ValueError("expected a 2-D array (rows, cols)")
    return X


def format_table(X: np.ndarray) -> bytes:
    """X: float64 array (rows, cols).  Returns b'v,v,...,v\n' for each row,
    values formatted exactly as Python's repr(float(v)) would format them.
    (A 1-D array is taken as a single column.)"""
    X = _as_table(X)
    nrows, ncols = X.shape
    if nrows == 0:
        return b""
    if ncols == 0:
        return b"\n" * nrows
    if not _FAST:
        return _slow_table(X)
    return b"".join([blk.tobytes() for blk in _blocks(X)])


def write_table(f, X: np.ndarray) -> int:
    """Write format_table(X) to the binary file object f block by block
    (no full-size intermediate), returning the number of bytes written."""
    X = _as_table(X)
    nrows, ncols = X.shape
    if nrows == 0 or ncols == 0 or not _FAST:
        data = format_table(X)
        f.write(data)
        return len(data)
    n = 0
    for blk in _blocks(X):
        f.write(memoryview(blk))
        n += blk.size
    return n


def format_value(x: float) -> str:
    """repr(float(x)), computed by the vectorised formatter (for tests and
    occasional scalar use: repr itself is faster for single values)."""
    out = format_table(np.array([[float(x)]]))
    return out[:-1].decode("ascii")


def _self_test() -> bool:
    vals = [0.0, -0.0, 0.1, 1 / 3, 1e23, 5e-324, 2.2250738585072014e-308,
            1.7976931348623157e308, 9007199254740993.0, 1e16, 1e-5, 123.456,
            float("nan"), float("inf"), -float("inf"), -1.5e-7, 0.3]
    X = np.array(vals)[:, None]
    try:
        ref = "".join(repr(v) + "\n" for v in vals).encode()
        return format_table(X) == ref
    except Exception:  # pragma: no cover
        return False


_FAST = True
if not _probe_overlap():  # pragma: no cover
    _compact = _compact_mask
_FAST = _self_test()
