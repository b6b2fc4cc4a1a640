"""The fast paths of the compiled ``.OUT`` writer (``engine.native.outfmt``, issue 14) write the
same characters as ``repr`` / ``format(x, ".3f")``.

``cycle_text`` writes each float through a table of the texts it wrote last, keyed by the
float's bits (``outfmt.short_float_cached``), in front of the kernel's own shortest digits
(``outfmt.short_float``: exact-integer Ryu, its 128-bit products shifted by one SHRD on
x86-64). Checked here: the cached text is ``short_float``'s and ``repr``'s on a miss, on a hit
and after a colliding float took the slot; hypothesis floats of every binary exponent the
kernel writes (1e-4 <= |x| < 1e16) and just outside it, ties of the last digits, powers of ten
and two with their neighbours, decimals with many trailing zeros; and every float of a real
demo replay, in the order the writer meets them, twice (all hits the second time).
"""

from __future__ import annotations

import math
import random
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import native
from tests.native.replay import replay

K = native._load("outfmt")[0]
"""The built kernel (whatever ``UVNAV_PURE`` says), or None: the kernel tests are skipped."""
needs_kernel = pytest.mark.skipif(K is None or not hasattr(K, "short_float_cached"),
                                  reason="engine.native.outfmt not built")

_GOLDEN = 0x9E3779B97F4A7C15
_SLOT_BITS = 9


def _bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


def _float(bits: int) -> float:
    return struct.unpack("<d", struct.pack("<Q", bits))[0]


def _slot(x: float) -> int:
    """The table slot of x in outfmt.c (FTEXT: (bits * golden) >> (64 - 9))."""
    return ((_bits(x) * _GOLDEN) & (2**64 - 1)) >> (64 - _SLOT_BITS)


def _check(x: float) -> None:
    """short_float and short_float_cached (a miss, then a hit) write repr(x), or both leave
    x to repr's routine (exponent forms, subnormals)."""
    assert K is not None
    want = repr(x)
    got = K.short_float(x)
    if got is None:
        assert "e" in want, want
    else:
        assert got == want, (x, got)
    assert K.short_float_cached(x) == got
    assert K.short_float_cached(x) == got


@needs_kernel
def test_cached_text_after_collisions() -> None:
    """Floats of one slot written in turn: each writes its own text (the slot keeps the bits),
    whatever the slot held before; the zeros, nan (any payload) and inf too."""
    assert K is not None
    assert K.short_checked() is True
    rng = random.Random(1414)
    by_slot: dict[int, list[float]] = {}
    while not any(len(v) >= 6 for v in by_slot.values()):
        x = rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-4.0, 15.9)
        by_slot.setdefault(_slot(x), []).append(x)
    same = max(by_slot.values(), key=len)
    assert len({_slot(x) for x in same}) == 1
    specials = [0.0, -0.0, math.nan, -math.nan, _float(0x7FF8000000000001), math.inf,
                -math.inf, 5e-324, 1e16, 1e-5, 123.0]
    for _ in range(5):
        for x in same + specials + same[::-1]:
            _check(x)


@needs_kernel
def test_cached_text_on_random_streams() -> None:
    """Random floats with many repeats (a few hundred distinct values in a stream of 60,000:
    the table's 512 slots keep most, a colliding value evicts): every text is repr's."""
    assert K is not None
    rng = random.Random(14_2026)
    pool = [rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-4.5, 16.5) for _ in range(900)]
    pool += [_float(rng.getrandbits(64)) for _ in range(100)]
    for _ in range(60_000):
        x = rng.choice(pool)
        assert K.short_float_cached(x) == K.short_float(x)
    for x in pool:
        _check(x)


def _from_parts(sign: int, exponent: int, mantissa: int) -> float:
    return _float((sign << 63) | (exponent << 52) | mantissa)


# biased exponents: 1010 (~1e-4 .. 2e-4) to 1076 (2^53 .. 2^54, ~1e16), and a few outside
_EXPONENTS = st.one_of(st.integers(1005, 1080), st.integers(1, 2046))
_MANTISSAS = st.one_of(
    st.integers(0, 2**52 - 1),
    st.sampled_from([0, 1, 2, 2**52 - 1, 2**52 - 2, 2**51, 2**51 + 1]),
    st.integers(0, 2**20).map(lambda m: m << 32),  # many trailing zero bits
    st.integers(0, 2**52 - 1).map(lambda m: m | 1),  # odd: bounds outside the interval
)


@needs_kernel
@settings(max_examples=3000, deadline=None)
@given(st.integers(0, 1), _EXPONENTS, _MANTISSAS)
def test_every_exponent_is_repr(sign: int, exponent: int, mantissa: int) -> None:
    _check(_from_parts(sign, exponent, mantissa))


@needs_kernel
@settings(max_examples=2000, deadline=None)
@given(st.integers(1, 10**17), st.integers(-22, 17), st.integers(0, 16), st.booleans())
def test_decimals_with_trailing_zeros_are_repr(digits: int, exp10: int, zeros: int,
                                               negative: bool) -> None:
    """Short decimals, with trailing zeros (digits * 10^zeros * 10^exp10), and their two
    neighbours: the cases where the cut digits are all zero (vr / vm exactly on a multiple)."""
    x = float(f"{'-' if negative else ''}{digits * 10 ** zeros}e{exp10}")
    for y in (x, math.nextafter(x, math.inf), math.nextafter(x, -math.inf)):
        _check(y)


@needs_kernel
@settings(max_examples=1500, deadline=None)
@given(st.integers(0, 2**53 - 1), st.sampled_from([1, 2, 3, 4, 5, 6, 7]), st.integers(1, 3))
def test_ties_of_the_last_digits_are_repr(n: int, eighth: int, scale: int) -> None:
    """n + k/8 (exact binary fractions: ties of the shortest digits, to the even one) and the
    same scaled by powers of ten and two."""
    x = n + eighth / 8
    for y in (x, -x, x / 10**scale, x * 2.0**-scale, x / 2**40):
        _check(y)


@needs_kernel
def test_powers_of_ten_and_two_with_neighbours() -> None:
    values: list[float] = []
    for e in range(-8, 20):
        x = 10.0**e
        for _ in range(30):
            values += [x, -x]
            x = math.nextafter(x, math.inf)
        x = 10.0**e
        for _ in range(30):
            x = math.nextafter(x, -math.inf)
            values.append(x)
    for e in range(-40, 60):
        x = 2.0**e
        values += [x, math.nextafter(x, 0.0), math.nextafter(x, math.inf), 3 * x, 5 * x]
    for x in values:
        _check(x)


@needs_kernel
def test_every_float_of_a_demo_replay() -> None:
    """The floats of 120 demo epochs in the order the writer meets them (the table as the run
    fills it), twice."""
    from engine.run.records import cycle_block

    assert K is not None
    session = replay(120, history=1000)
    values: list[float] = []
    for r in session.history:
        head, lines = cycle_block(r)
        rows = [("CYCLE", tuple(head), tuple(head.values())), *lines.rows]
        values += [v for _p, _k, vs in rows for v in vs if type(v) is float]
    assert len(values) > 10_000
    for _ in range(2):
        for x in values:
            got = K.short_float_cached(x)
            assert got == repr(x) or (got is None and "e" in repr(x)), x


_WORDS = st.one_of(
    st.sampled_from(["accept", "reject", "GPS", "Decca", "Lat", "ON", "KF", "ED50", "", "-",
                     "1e5", "nan", "123", "12.5", "a b", 'q"', "x=y", "lse", "IV", "1_0"]),
    st.text(alphabet="abcdef0123456789.-_e =\"\\", max_size=12),
    st.text(max_size=40),
)


@needs_kernel
@settings(max_examples=300, deadline=None)
@given(st.lists(_WORDS, min_size=1, max_size=40))
def test_remembered_word_forms_are_the_python_rule(words: list[str]) -> None:
    """The quoting form of a str value is remembered per str object (64 slots): words
    written again (the same objects, equal copies, after other words took their slot) are
    written as outlog._format_text writes them."""
    from engine.io import outlog

    assert K is not None
    copies = ["".join(list(w)) for w in words]  # equal words, other objects (most of them)
    values = tuple(words + copies + words[::-1])
    rows = [("W", tuple(f"k{i}" for i in range(len(values))), values)]
    for _ in range(2):
        got = K.render_rows(rows, None, outlog._format_text, outlog.format_value)
        assert got == outlog.render_rows(rows, False)
