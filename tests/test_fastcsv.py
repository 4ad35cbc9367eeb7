"""Tests of planarkin.output.fastcsv: every value must be formatted exactly as
repr(float(v)) (and therefore round-trip bit for bit)."""

import io
import math
import random
from fractions import Fraction

import numpy as np
import pytest

from planarkin.output import fastcsv
from planarkin.output.fastcsv import format_table, format_value, write_table


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------

def check_values(values) -> int:
    """Format `values` as one column; compare every line with repr() and check
    that it parses back to the same bits.  Returns the number checked."""
    x = np.ascontiguousarray(np.asarray(values, dtype=np.float64).ravel())
    out = format_table(x[:, None])
    assert out.endswith(b"\n") or x.size == 0
    got = out.decode("ascii").split("\n")[:-1]
    assert len(got) == x.size
    vals = x.tolist()
    bad = [(v, g) for v, g in zip(vals, got) if g != repr(v)]
    assert not bad, f"{len(bad)} mismatches, e.g. {bad[:10]}"
    back = np.array([float(g) for g in got])
    fin = ~np.isnan(x)
    assert np.array_equal(back[fin].view(np.uint64), x[fin].view(np.uint64))
    assert np.isnan(back[~fin]).all()
    return x.size


def _neighbours(vals):
    out = []
    for v in vals:
        out += [v, math.nextafter(v, math.inf), math.nextafter(v, -math.inf)]
    return [v for v in out if math.isfinite(v)]


# ---------------------------------------------------------------------------
# hand-picked edge values
# ---------------------------------------------------------------------------

EDGE = [
    0.0, -0.0, 0.1, 0.2, 0.3, 0.7, 1 / 3, 2 / 3, -1 / 3, 0.5, 1.0, -1.0, 2.0, 10.0,
    1e-4, 9.999999999999999e-05, 1.0000000000000001e-04, 1e-5, 1.5e-5, 0.00011,
    1e15, 1e16, 1e17, 1e22, 1e23, 1e-7, 123.456, -123.456, 1234567890.0987654,
    9007199254740992.0, 9007199254740993.0, 9007199254740994.0, 9007199254740996.0,
    4503599627370496.5, 2251799813685248.25, 1125899906842624.125,
    999999999999999.9, 9999999999999998.0, 999999999999999.0, 99999999999999.99,
    1974014629615873.75, 1743829569681555.25,          # exact 17-digit ties
    5e-324, 1e-323, 2.225073858507201e-308, 2.2250738585072014e-308,
    2.2250738585072009e-308, 4.9406564584124654e-324, 1.7976931348623157e308,
    -1.7976931348623157e308, 8.98846567431158e307, 1.5e300, 2.5e-300,
    0.30000000000000004, 0.1 + 0.2, 1.1, 2.675, 1.005, 4.35, 0.015625,
    3.141592653589793, 2.718281828459045, 6.283185307179586, 1e300 * 1e8,
    float("nan"), float("inf"), -float("inf"), -float("nan"),
    123456789012345.67, 12345678901234567.0, 1.2345678901234567e-5,
    1.7976931348623157e-300, 6.02214076e23, 1.602176634e-19, 299792458.0,
]


def test_edge_values():
    check_values(_neighbours([v for v in EDGE if math.isfinite(v)]) + EDGE)


def test_format_value_matches_repr():
    for v in EDGE:
        assert format_value(v) == repr(v)
    assert format_value(-0.0) == "-0.0"
    assert format_value(1e16) == "1e+16"
    assert format_value(1e-5) == "1e-05"
    assert format_value(1e15) == "1000000000000000.0"
    assert format_value(5e-324) == "5e-324"
    assert format_value(np.float64(0.25)) == "0.25"
    assert format_value(3) == "3.0"


def test_powers_of_two():
    check_values(_neighbours([math.ldexp(1.0, k) for k in range(-1074, 1024)]))
    check_values([-math.ldexp(1.0, k) for k in range(-1074, 1024)])


def test_powers_of_ten():
    p10 = [float(f"1e{k}") for k in range(-323, 309)] + [5e-324]
    check_values(_neighbours(p10))
    # 9.99..e(k-1) and 1.00..e(k) at every scale
    check_values([float(f"9.999999999999999e{k}") for k in range(-300, 300)])
    check_values([float(f"9.9999999999999999e{k}") for k in range(-300, 300)])
    check_values([float(f"1.0000000000000002e{k}") for k in range(-300, 300)])


def test_significant_digit_counts():
    rng = random.Random(1234)
    vals = []
    for nd in range(1, 18):
        for _ in range(2000):
            digits = str(rng.randrange(10 ** (nd - 1), 10**nd))
            e = rng.randrange(-310, 309)
            vals.append(float(f"{digits[0]}.{digits[1:]}e{e}"))
            vals.append(float(f"0.{digits}") if rng.random() < 0.5 else float(digits))
    check_values([v for v in vals if math.isfinite(v)])


def test_integers():
    rng = np.random.default_rng(7)
    ints = np.concatenate([
        np.arange(-1000, 1001),
        rng.integers(0, 2**53, 20000),
        rng.integers(0, 10**15, 20000),
        2**53 + np.arange(-1000, 1000),
        10**15 + np.arange(-1000, 1000),
        10**16 + 2 * np.arange(-1000, 1000),
    ]).astype(np.float64)
    check_values(ints)


# ---------------------------------------------------------------------------
# >= 1,000,000 random doubles, several distributions
# ---------------------------------------------------------------------------

def test_random_uniform():
    rng = np.random.default_rng(1)
    n = check_values(rng.random(300_000))
    n += check_values(-rng.random(50_000) * 1e3)
    assert n >= 350_000


def test_random_bit_patterns():
    # uniform over the whole exponent range, subnormals, nan, inf included
    rng = np.random.default_rng(2)
    bits = rng.integers(0, 2**64, 400_000, dtype=np.uint64)
    bits[:2000] &= np.uint64((1 << 52) - 1)  # subnormals (and zeros)
    check_values(bits.view(np.float64))


def test_random_mechanism_values():
    # position / velocity / acceleration of a slider-crank over one turn
    t = np.linspace(0.0, 2 * np.pi, 50_001)
    r, l, w = 0.1, 0.35, 2 * np.pi * 25
    s = r * np.sin(t)
    c = np.sqrt(l * l - s * s)
    x = r * np.cos(t) + c
    v = -r * w * np.sin(t) - r * r * w * np.sin(t) * np.cos(t) / c
    a = np.gradient(v, t) * w
    check_values(np.concatenate([0.1 * np.cos(t), x, v, a, t, t * 1e-3]))


def test_random_near_powers_of_ten():
    rng = np.random.default_rng(3)
    k = rng.integers(-300, 300, 100_000)
    rel = rng.normal(0.0, 1.0, k.size) * 10.0 ** rng.integers(-17, -1, k.size)
    vals = 10.0 ** k.astype(np.float64) * (1.0 + rel)
    # and the exact neighbours of 10**k in units of the last place
    p = 10.0 ** np.arange(-300, 300, dtype=np.float64)
    steps = np.arange(-20, 21)
    near = (p.view(np.int64)[:, None] + steps[None, :]).ravel().view(np.float64)
    check_values(np.concatenate([vals, near]))


def test_zeros_and_short_values_mixed():
    # zero columns and "nice" values dominate some blocks (whole-block zero
    # stripping); also nan/inf with arbitrary payloads
    rng = np.random.default_rng(11)
    X = np.zeros((3000, 12))
    X[:, 1] = np.arange(3000) * 0.001
    X[:, 2] = rng.integers(-50, 50, 3000) / 4.0
    X[:, 3] = -0.0
    X[:, 4] = rng.random(3000)
    X[::7, 5] = 1e-300
    assert format_table(X) == _reference(X)
    check_values(X.ravel())
    fr = rng.integers(0, 2**52, 20000, dtype=np.uint64)
    b = fr | np.uint64(0x7FF << 52)
    b[::2] |= np.uint64(1 << 63)
    check_values(b.view(np.float64))


def test_random_short_decimals():
    # values whose repr has few digits (the p = 15 path + zero stripping)
    rng = np.random.default_rng(4)
    n = 100_000
    m = rng.integers(1, 10**6, n).astype(np.float64)
    e = rng.integers(-12, 12, n).astype(np.float64)
    check_values(m * 10.0**e)
    check_values(m / 1000.0)
    check_values(rng.integers(-10**6, 10**6, n) / 64.0)


def test_total_random_count():
    # (documentation of the requirement: the random tests above check
    # 350k + 400k + 300k + 124k + 300k > 1e6 values against repr)
    assert 350_000 + 400_000 + 6 * 50_001 + 124_000 + 300_000 >= 1_000_000


# ---------------------------------------------------------------------------
# claims the method relies on
# ---------------------------------------------------------------------------

def test_short_reprs_come_from_15_digit_rounding():
    """For normal doubles whose shortest repr has < 15 digits, rounding to 15
    significant digits and stripping trailing zeros gives the same digits."""
    rng = np.random.default_rng(5)
    vals = []
    for nd in range(1, 15):
        m = rng.integers(10 ** (nd - 1), 10**nd, 3000)
        e = rng.integers(-300, 300, 3000)
        vals += [float(f"{a}e{b}") for a, b in zip(m.tolist(), e.tolist())]
    vals += [math.ldexp(1.0, k) for k in range(-1022, 1024)]
    checked = 0
    for v in vals:
        if not math.isfinite(v) or v == 0 or abs(v) < 2.2250738585072014e-308:
            continue
        r = repr(v)
        mant = r.split("e")[0].replace("-", "").replace(".", "").strip("0")
        if len(mant) >= 15:
            continue
        m15 = ("%.14e" % v).split("e")[0].replace(".", "").rstrip("0")
        assert m15 == mant, (v, r, m15)
        checked += 1
    assert checked > 30_000


def test_scaling_precision():
    """_scale's N + F is within 2e-6 of |x| * 10**(16 - e10) (the ambiguity
    tolerance is 1e-5), checked against exact rational arithmetic."""
    rng = np.random.default_rng(6)
    bits = rng.integers(1 << 52, 0x7FF << 52, 3000, dtype=np.int64)
    x = bits.view(np.float64)
    N, F, c16, e, bexp, frac = fastcsv._scale(x, fastcsv._Work(x.size))
    worst = 0.0
    for xi, Ni, Fi, ei in zip(x.tolist(), N.tolist(), F.tolist(), e.tolist()):
        y = Fraction(xi) * Fraction(10) ** (16 - ei)
        assert 10**16 <= y < 10**17
        worst = max(worst, abs(float(y - Ni - Fraction(Fi))))
    assert worst < 2e-6
    assert fastcsv._TOL >= 5 * worst


def test_17_digits_always_round_trip():
    """Argument used in the module doc: the 17-digit spacing is at most
    2**53 * 10**-16 ulp, so half an ulp is >= 0.555 units of the 17th digit."""
    assert 2.0**53 * 1e-16 < 0.9008
    assert 0.5 / (2.0**53 * 1e-16) > 0.555


# ---------------------------------------------------------------------------
# format_table
# ---------------------------------------------------------------------------

def _reference(X) -> bytes:
    return "".join(",".join(map(repr, row)) + "\n" for row in np.asarray(X).tolist()).encode()


def test_table_layout_and_parse_back():
    rng = np.random.default_rng(8)
    X = rng.normal(size=(500, 7)) * 10.0 ** rng.integers(-8, 8, (500, 7))
    X[0, 0] = -0.0
    X[1, 2] = np.nan
    X[2, 3] = np.inf
    X[3, 4] = -np.inf
    out = format_table(X)
    assert out == _reference(X)
    lines = out.split(b"\n")
    assert lines[-1] == b""
    assert len(lines) == 501
    assert all(line.count(b",") == 6 for line in lines[:-1])
    back = np.loadtxt(io.BytesIO(out), delimiter=",")
    fin = np.isfinite(X) | np.isinf(X)
    assert np.array_equal(back[fin].view(np.uint64), X[fin].view(np.uint64))
    assert np.isnan(back[~fin]).all()


def test_large_table_multiple_blocks():
    t = np.linspace(0, 2 * np.pi, 4001)[:, None]
    ph = np.linspace(0, 1, 35)[None, :]
    X = 0.1 * np.cos(t + ph) * (1 + ph) + 0.02 * np.sin(3 * t) * ph * 1e3
    assert X.size > 2 * fastcsv._CHUNK_VALUES
    out = format_table(X)
    assert out == _reference(X)
    assert out == format_table(X)  # byte-identical on repeated calls
    assert out == format_table(X.copy(order="F"))


def test_empty_and_degenerate_tables():
    assert format_table(np.zeros((0, 5))) == b""
    assert format_table(np.zeros((0, 0))) == b""
    assert format_table(np.zeros((3, 0))) == b"\n\n\n"
    assert format_table(np.array([[1.5]])) == b"1.5\n"
    assert format_table(np.array([1.5, -2.0])) == b"1.5\n-2.0\n"  # 1-D = column
    with pytest.raises(ValueError):
        format_table(np.zeros((2, 2, 2)))


def test_single_column_and_single_row():
    x = np.array([0.1, -2.5, 1e-7, 3e20])
    assert format_table(x[:, None]) == b"0.1\n-2.5\n1e-07\n3e+20\n"
    assert format_table(x[None, :]) == b"0.1,-2.5,1e-07,3e+20\n"


def test_input_conversion():
    X32 = np.array([[0.1, 0.25]], dtype=np.float32)
    assert format_table(X32) == _reference(X32.astype(np.float64))
    Xi = np.array([[1, 2], [3, -4]])
    assert format_table(Xi) == b"1.0,2.0\n3.0,-4.0\n"
    assert format_table([[0.5, 2]]) == b"0.5,2.0\n"
    X = np.arange(40.0).reshape(8, 5) / 7
    assert format_table(X[::2, 1::2]) == _reference(X[::2, 1::2])


def test_write_table_matches_format_table():
    rng = np.random.default_rng(9)
    X = rng.random((3000, 20))
    buf = io.BytesIO()
    n = write_table(buf, X)
    assert buf.getvalue() == format_table(X)
    assert n == len(buf.getvalue())
    buf = io.BytesIO()
    assert write_table(buf, np.zeros((0, 3))) == 0


def test_fallback_paths_agree(monkeypatch):
    rng = np.random.default_rng(10)
    X = rng.integers(0, 2**64, (300, 9), dtype=np.uint64).view(np.float64)
    fast = format_table(X)
    assert fast == _reference(X)
    monkeypatch.setattr(fastcsv, "_compact", fastcsv._compact_mask)
    assert format_table(X) == fast
    monkeypatch.setattr(fastcsv, "_FAST", False)
    assert format_table(X) == fast


def test_overlap_compaction_probe():
    # numpy assigns overlapping items in index order on this platform
    assert fastcsv._probe_overlap()
    assert fastcsv._FAST
