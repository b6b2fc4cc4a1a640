"""The compiled ``.OUT`` block writer (``engine.native.outfmt``) writes exactly the characters of
the reference it stands in for (:func:`engine.io.outlog.render_rows`, through
``engine.fast.outlog``).

Compared with ``==`` on the whole text: the rows of a real replay (200 demo epochs and the
thesis sample), with orjson's float texts and with ``repr`` only (the kernel's
``PyOS_double_to_string`` path); hypothesis rows of every value type the log takes; every float
``repr`` writes differently (-0.0, nan, inf, subnormals, the 1e16 and 1e-4 switches to an
exponent, ties); the str quoting rule on every ASCII character; a float writer whose texts the
probe's rule must reject; and the pure path (kernel None / ``UVNAV_PURE=1``).
"""

from __future__ import annotations

import math
import random
import struct
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine import native
from engine.fast import outlog as fast_outlog
from engine.io import outlog
from engine.io.outlog import _N, KeyedLines
from engine.io.outlog import render_rows as _render_rows_py
from engine.run.records import BLOCK_SHAPES
from tests.native.replay import replay

K = native._load("outfmt")[0]
"""The built kernel (whatever ``UVNAV_PURE`` says), or None: the kernel tests are skipped."""
needs_kernel = pytest.mark.skipif(K is None, reason="engine.native.outfmt not built")

Row = tuple[str, tuple[str, ...], tuple[object, ...]]


def kernel_text(rows: list[Row], compiled: bool = True) -> str | None:
    """The kernel's text of ``rows`` with the writer :func:`outlog.render_rows` gives it."""
    assert K is not None
    return K.render_rows(rows, outlog._float_writer() if compiled else None,
                         outlog._format_text, outlog.format_value)


def block_rows(head: dict, lines: KeyedLines) -> list[Row]:
    """The rows :meth:`OutLogWriter.write_cycle` hands to :func:`outlog.render_rows`."""
    return [("CYCLE", tuple(head), tuple(head.values())), *lines.rows,
            ("\nEND", _N, (head.get("n"),)), ("\n", (), ())]


@pytest.fixture(scope="module")
def replay_blocks() -> list[list[Row]]:
    """The block rows of 200 demo epochs and of the thesis sample, as a replay writes them."""
    from engine.run.records import cycle_block
    from tests.paths import DATA

    out = []
    for cfg, n in ((DATA / "DEMO.toml", 200), (DATA / "920917_1.toml", 60)):
        s = replay(n, cfg, history=1000)
        out.extend(block_rows(*cycle_block(r)) for r in s.history)
    assert len(out) > 200
    return out


@needs_kernel
def test_replay_blocks_are_the_same_text(replay_blocks: list[list[Row]]) -> None:
    for rows in replay_blocks:
        for compiled in (True, False):
            assert kernel_text(rows, compiled) == _render_rows_py(rows, compiled)


@needs_kernel
def test_every_float_of_the_replay_is_repr(replay_blocks: list[list[Row]]) -> None:
    """``PyOS_double_to_string(x, 'r', 0, Py_DTSF_ADD_DOT_0)`` is ``repr`` on each float."""
    assert K is not None
    values = {v for rows in replay_blocks for _p, _k, vs in rows for v in vs
              if type(v) is float}
    assert len(values) > 10_000
    for v in values:
        assert K.float_repr(v) == repr(v)


TIES = [n + f for n in (101065508335255, 123456789012345, 99999999999999, 10**14 + 7)
        for f in (0.125, 0.375, 0.625, 0.875)]
EDGES = [0.0, -0.0, 1.0, -1.0, 0.1, 1e-4, -1e-4, 9.999999999999999e-05, 0.00010000000000000002,
         1e-5, 1.5e-5, 1e16, 9999999999999998.0, -1e16, 1e15, 1.5e16, 1e17, 1e22, 5e-324,
         -5e-324, 2.2250738585072014e-308, 2.225073858507201e-308, 1.7976931348623157e308,
         math.nan, -math.nan, math.inf, -math.inf, 123.0, 52.84232512345678]
floats = st.one_of(st.floats(), st.sampled_from(EDGES + TIES),
                   st.floats(min_value=1e-6, max_value=1e-3), st.floats(min_value=1e15,
                                                                        max_value=1e17),
                   st.floats(allow_subnormal=True, min_value=-1e-307, max_value=1e-307))


@needs_kernel
@settings(max_examples=300)
@given(st.lists(floats, max_size=30))
def test_floats_are_repr(values: list[float]) -> None:
    assert K is not None
    assert [K.float_repr(v) for v in values] == [repr(v) for v in values]
    rows: list[Row] = [("F", tuple(f"f{i}" for i in range(len(values))), tuple(values))]
    want = "F" + "".join(f" f{i}={v!r}" for i, v in enumerate(values))
    assert kernel_text(rows) == want
    assert kernel_text(rows, compiled=False) == want


@needs_kernel
def test_random_bits_ties_and_edges_are_repr() -> None:
    rng = random.Random(14)
    bits = [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0] for _ in range(4000)]
    scaled = [rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-7.0, 18.0) for _ in range(4000)]
    for values in (TIES, EDGES, bits, scaled, EDGES * 3 + TIES):
        rows: list[Row] = [("\n  X", tuple(f"k{i}" for i in range(len(values))), tuple(values))]
        for compiled in (True, False):
            assert kernel_text(rows, compiled) == _render_rows_py(rows, compiled)


def _short_is_repr(x: float) -> None:
    """The kernel's own shortest digits (``outfmt.short_float``) are ``repr``'s, and it writes
    every float ``repr`` writes without an exponent (normal, 1e-4 <= |x| < 1e16), the zeros,
    nan and inf; it leaves only the exponent forms and subnormals to ``repr``'s routine."""
    assert K is not None
    got = K.short_float(x)
    want = repr(x)
    if got is None:
        assert "e" in want, want
    else:
        assert got == want


def _around(x: float, n: int) -> list[float]:
    """x and its n neighbours on each side."""
    out, up, down = [x], x, x
    for _ in range(n):
        up, down = math.nextafter(up, math.inf), math.nextafter(down, -math.inf)
        out += [up, down]
    return out


@needs_kernel
def test_short_float_is_repr_on_random_bits_ties_and_boundaries() -> None:
    """cycle_text writes each float by ``short_float`` (exact-integer Ryu digit search) where
    it passed its probes: checked here on random bit patterns, random values of every decade
    of the positional range, short decimals (where the shortest digits are few), every power
    of two and its neighbours (the narrower lower gap), the powers of ten and 1e-4 / 1e16
    switches with 40 neighbours each, and ties of the last digit."""
    assert K is not None
    assert K.short_checked() is True
    rng = random.Random(1403)
    values: list[float] = list(EDGES + TIES)
    values += [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
               for _ in range(60_000)]
    values += [rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-4.5, 16.5) for _ in range(150_000)]
    values += [float(f"{rng.randint(1, 10 ** rng.randint(1, 17))}e{rng.randint(-21, 16)}")
               for _ in range(60_000)]
    for e in range(-1074, 1024):
        values += _around(2.0 ** e, 1)
    for e in range(-6, 18):
        values += _around(10.0 ** e, 40)
    for n in (101065508335255, 123456789012345, 99999999999999, 10**14 + 7, 2**52, 2**53 - 1,
              4503599627370495, 1, 0, 7):
        for f in (0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875):
            values += [n + f, -(n + f)]
    values += [math.ldexp(m, e) for m in (1, 3, 5, 2**53 - 1, 2**52 + 1) for e in range(-80, 60)]
    for x in values:
        _short_is_repr(x)
    some = [x for x in values if 1e-4 <= abs(x) < 1e16]
    assert len(some) > 100_000


@needs_kernel
@settings(max_examples=2000)
@given(st.one_of(floats, st.floats(min_value=1e-4, max_value=1e16),
                 st.floats(min_value=-1e16, max_value=-1e-4)))
def test_short_float_is_repr(x: float) -> None:
    _short_is_repr(x)


@needs_kernel
def test_fixed3_is_format_3f() -> None:
    """The TEST line's LS statistics (``"{:.3f}".format``) by the kernel's exact rounding
    (``outfmt.fixed3_float``): ties of the third decimal (exact binary halves) to even, the
    sign of a value that rounds to 0, subnormals, the 2**53 limit."""
    assert K is not None
    rng = random.Random(3)
    values: list[float] = list(EDGES + TIES)
    values += [rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-6.0, 16.0) for _ in range(100_000)]
    values += [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
               for _ in range(30_000)]
    values += [k / 2000 for k in range(-5000, 5000)]  # every x.xxx5 tie near 0
    values += [(2 * k + 1) / 2 ** 12 for k in range(-3000, 3000)]
    values += [n + k / 16 for n in (0, 1, 12345, 2**40) for k in range(-32, 32)]
    values += _around(2.0 ** 53, 3) + _around(-(2.0 ** 53), 3) + _around(0.0005, 5)
    values += [-1e-9, -0.0004, -0.0005, -0.0006, 5e-324, -5e-324]
    for x in values:
        got = K.fixed3_float(x)
        if got is None:
            assert not math.isfinite(x) or abs(x) >= 2.0 ** 53, x
        else:
            assert got == f"{x:.3f}", x


ODD_WORDS = ["", "-", "1", "0", "007", "1e5", "-0.0", "nan", "NaN", "inf", "-Infinity", "1_000",
             " 1 ", "a b", 'say "hi"', "k=v", "back\\slash", "tab\there", "new\nline",
             "\x00", "\x1c", "\x7f", "\u00a0nbsp", "\u0661\u0662", "σ ≤ 3 m", "lse", "accept",
             "1992-09-17T08:35:38Z", "0.123,4.567", "%s", "%r %d", "%%", "\u2028", "G...D",
             "111111", "ED50", "Lat", "e", "fail", "\ud800", "a\ud800b"]
texts = st.one_of(st.sampled_from(ODD_WORDS),
                  st.text(max_size=12),
                  st.text(alphabet=st.characters(max_codepoint=127), max_size=12),
                  st.text(alphabet="0123456789.eE+-_ infa:,\"=\\\t", max_size=8))
values = st.one_of(
    st.none(), st.booleans(), st.integers(), st.integers(-2**70, 2**70), floats, texts,
    floats.map(np.float64), st.floats(width=32).map(np.float32),
    st.integers(-2**63, 2**63 - 1).map(np.int64), st.booleans().map(np.bool_),
)
keys = st.lists(st.one_of(st.from_regex(r"[a-z_][a-z0-9_]{0,8}", fullmatch=True),
                          st.sampled_from(["%", "%s", "a%d", "s_hdg", "n", "σ"])),
                unique=True, max_size=10)
rows_st = st.lists(st.tuples(st.sampled_from(["CYCLE", "\n  LOP", "\n  %s", "", "\nEND", "\n"]),
                             keys.flatmap(lambda ks: st.tuples(st.just(tuple(ks)),
                                                               st.tuples(*[values] * len(ks))))),
                   max_size=6).map(lambda rs: [(p, ks, vs) for p, (ks, vs) in rs])


def _same_as_python(rows: list[Row], compiled: bool) -> None:
    """The kernel's text is the Python's, or the kernel leaves the rows to the Python (None)
    and the Python writes them (or fails) as without the kernel."""
    got = kernel_text(rows, compiled)
    try:
        want = _render_rows_py(rows, compiled)
    except (UnicodeEncodeError, ValueError):
        assert got is None
        return
    assert got is None or got == want
    assert fast_outlog.render_rows(rows, compiled) == want


@needs_kernel
@settings(max_examples=150, deadline=None)
@given(rows_st, st.booleans())
def test_rows_of_any_values_are_the_same_text(rows: list[Row], compiled: bool) -> None:
    _same_as_python(rows, compiled)


@needs_kernel
def test_surrogates_are_left_to_the_python() -> None:
    rows: list[Row] = [("\n  MSG", ("text",), ("a\ud800b",))]
    assert kernel_text(rows) is None
    rows = [("\n  MSG\ud800", ("text",), ("x",))]
    assert kernel_text(rows) is None


@needs_kernel
def test_malformed_rows_are_left_to_the_python() -> None:
    class Key(str):
        pass

    for rows in ([("X", ("a", "b"), (1.0,))], [("X", (Key("a"),), (1.0,))],
                 [("X", ["a"], (1.0,))], [("X", ("a",))], (("X", ("a",), (1.0,)),),
                 [["X", ("a",), (1.0,)]], [(Key("X"), ("a",), (1.0,))]):
        assert K is not None
        assert K.render_rows(rows, None, outlog._format_text, outlog.format_value) is None
    with pytest.raises(ValueError):
        outlog.render_rows([("X", ("a", "b"), (1.0,))])


@needs_kernel
def test_str_rule_on_every_ascii_character() -> None:
    """Where the kernel decides a word's form itself, it is outlog._format_text's."""
    assert K is not None
    decided = 0
    for c in map(chr, range(128)):
        for word in (c, c * 2, "ab" + c, c + "1", "1" + c + "2", "lse" + c, "1e" + c, c + "5"):
            form = K.text_form(word)
            if form is not None:
                decided += 1
                assert form == outlog._format_text(word), repr(word)
    assert decided > 700
    for word in ("lse", "accept", "KF", "ED50", "GPS", "G...D", "111111", "", "-", "a b",
                 "1992-09-17T08:35:38Z", "0.123,4.567", 'x"y', "a=b", "\\"):
        assert K.text_form(word) == outlog._format_text(word), word
    for word in ("1e5", "nan", "inf", "1_0", "\u00a0", "é"):
        assert K.text_form(word) is None


@needs_kernel
@given(st.one_of(st.text(alphabet=st.characters(max_codepoint=127), max_size=16), texts))
def test_str_rule_on_any_word(word: str) -> None:
    assert K is not None
    form = K.text_form(word)
    assert form is None or form == outlog._format_text(word)


def _writer(fmt: Callable[[float], str]) -> Callable[[list[float]], bytes]:
    return lambda vs: ("[" + ",".join(map(fmt, vs)) + "]").encode()


@needs_kernel
@pytest.mark.parametrize("fmt", [
    lambda v: f"{v:.17e}",           # an exponent everywhere: every float through repr
    lambda v: f"{v:.17g}",           # plain forms kept (as the Python keeps them), others repr
    lambda v: "null",
    lambda v: f"{v:.1f}",             # kept where plain and not "0.0000"
    lambda v: f"{v:.6f}",
    lambda v: str(int(v)) if math.isfinite(v) else "1",  # no point: repr
])
def test_a_float_writer_is_taken_by_the_python_rule(
        monkeypatch: pytest.MonkeyPatch, fmt: Callable[[float], str]) -> None:
    """Whatever texts the float writer gives, the kernel keeps the very ones the Python
    (:func:`outlog.float_texts`) keeps and writes the others by repr."""
    dumps = _writer(fmt)
    monkeypatch.setattr(outlog, "_float_writer", lambda: dumps)
    values = EDGES + TIES + [0.5, -2.25, 1234.5, 0.00012, 3e-5]
    rows: list[Row] = [("L", tuple(f"k{i}" for i in range(len(values))), tuple(values)),
                       ("M", ("a", "b"), ("x", 7))]
    assert K.render_rows(rows, dumps, outlog._format_text, outlog.format_value) == \
        _render_rows_py(rows)


@needs_kernel
def test_a_float_writer_with_a_wrong_count_is_not_used() -> None:
    assert K is not None
    rows: list[Row] = [("L", ("a", "b"), (1.5, 2.5))]
    for out in (b"[1.5]", b"[1.5,2.5,3.5]", b"", b"[]", "[1.5,2.5]"):
        assert K.render_rows(rows, lambda vs, o=out: o, outlog._format_text,
                             outlog.format_value) == "L a=1.5 b=2.5"


def test_pure_path_when_the_kernel_is_none(monkeypatch: pytest.MonkeyPatch,
                                           replay_blocks: list[list[Row]]) -> None:
    calls = []
    real = outlog.render_rows

    def spy(rows: list[Row], compiled: bool = True) -> str:
        calls.append(1)
        return real(rows, compiled)

    monkeypatch.setattr(fast_outlog, "kernel", lambda: None)
    monkeypatch.setattr(outlog, "render_rows", spy)
    rows = replay_blocks[5]
    assert fast_outlog.render_rows(rows) == real(rows)
    assert calls


def test_uvnav_pure_gives_no_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(native.PURE_ENV, "1")
    assert native.kernel("outfmt") is None


@needs_kernel
def test_the_writer_writes_the_kernel_text(tmp_path: Path,
                                           replay_blocks: list[list[Row]]) -> None:
    """The reference writer's block (write_cycle, flushed each block) is the kernel's text."""
    if fast_outlog.kernel() is None:
        pytest.skip("UVNAV_PURE=1: the writer uses the Python")
    rows = replay_blocks[3]
    head_row, *inner, _end, _nl = rows
    head = dict(zip(head_row[1], head_row[2], strict=True))
    lines = KeyedLines()
    lines.rows.extend(inner)
    with outlog.OutLogWriter.create(tmp_path / "W.OUT", force=True) as w:
        w.write_cycle(head, lines)
        text = (tmp_path / "W.OUT").read_text(encoding="utf-8")  # flushed before close
    assert text.endswith("# config-end\n" + kernel_text(rows))


# ---------------------------------------------------------------- the whole block of a cycle

def _python_rows(r: object) -> list[Row]:
    """The rows the Python path writes for ``r``: :func:`records.cycle_block` as
    :meth:`OutLogWriter.write_cycle` hands them to :func:`outlog.render_rows`."""
    from engine.run.records import cycle_block

    return block_rows(*cycle_block(r))  # type: ignore[arg-type]


def _typed(rows: list[Row]) -> list[tuple[str, tuple[str, ...], tuple[object, ...],
                                          tuple[type, ...]]]:
    """Rows with the types of their values (``==`` alone would take 1 for 1.0 or True)."""
    return [(p, ks, vs, tuple(map(type, vs))) for p, ks, vs in rows]


def _check_cycle(r: object) -> None:
    """The kernel's rows and text of ``r`` are the Python's, value by value and type by type."""

    assert K is not None
    if getattr(r, "adapt_logged", False):
        # A cycle with an ADAPT line ([filter] adapt) is the Python's to write (the session
        # and records.cycle_text route it there); the kernel writes every other line of it.
        from dataclasses import replace

        r = replace(r, adapt_logged=False)  # type: ignore[type-var]
    want = _python_rows(r)
    got = K.cycle_rows(r, BLOCK_SHAPES)
    assert got is not None
    assert _typed(got) == _typed(want)
    for compiled in (True, False):
        text = K.cycle_text(r, BLOCK_SHAPES,
                            outlog._float_writer() if compiled else None, outlog._format_text,
                            outlog.format_value)
        assert text == _render_rows_py(want, compiled)


@pytest.fixture(scope="module")
def replay_results() -> list[object]:
    """The cycle results of the demo, the thesis sample and the Markermeer NMEA log (receiver
    weights, COG/SOG stand-ins)."""
    from tests.paths import DATA

    out: list[object] = []
    for cfg, n in ((DATA / "DEMO.toml", 200), (DATA / "920917_1.toml", 60),
                   (DATA / "nmea" / "avnav-markermeer-20160815.toml", 150)):
        out.extend(replay(n, cfg, history=1000).history)
    return out


@needs_kernel
def test_cycle_rows_are_cycle_block(replay_results: list[object]) -> None:
    """``outfmt.cycle_rows`` / ``cycle_text`` give the Python's rows and text on every cycle of
    three real replays."""

    assert len(replay_results) > 250
    for r in replay_results:
        _check_cycle(r)
        if not r.adapt_logged:  # an ADAPT cycle is the reference's to write (_check_cycle)
            assert fast_outlog.cycle_text(r, BLOCK_SHAPES) == (
                None if fast_outlog.kernel() is None else _render_rows_py(_python_rows(r)))


@needs_kernel
def test_cycle_rows_of_every_line_shape(replay_results: list[object]) -> None:
    """Line shapes a replay may not show: DR references, COG/SOG stand-ins, receiver-weighted
    GPS, Obs-menu observations, rejected LOPs, a fix failing its tests, no fix, no filter, no
    updates, no ellipse, a VCV with NaN, messages, odd value types and time stamps."""
    from dataclasses import replace
    from datetime import UTC, datetime, timedelta

    from engine.systems.gps import GpsWeight
    from engine.systems.manual import ManualObservation

    base = next(r for r in replay_results if r.fix is not None and r.fix.ok  # type: ignore
                and r.gps is not None and r.kf_pred is not None)  # type: ignore[attr-defined]
    nofix = next((r for r in replay_results if r.fix is not None  # type: ignore[attr-defined]
                  and not r.fix.ok), None)  # type: ignore[attr-defined]
    s, f, g, p = base.sensors, base.fix, base.gps, base.kf_pred  # type: ignore[attr-defined]
    nan_cov = np.array([[1.0, math.nan], [math.nan, 2.0]])
    weight = GpsWeight("receiver", 3.5, 1.2, 2, 9, 5.0)
    obs = (ManualObservation("bearing", "Light A", 52.1, 4.2, 123.5, 1.0, "compass"),
           ManualObservation("distance", "St B", 52.0, 4.0, 1500.0, 30.0))
    variants = [
        replace(base, sensors=replace(s, reference="none")),
        replace(base, sensors=replace(s, reference="ground", heading_sigma_deg=2.5,
                                      speed_sigma_ms=None)),
        replace(base, gps=replace(g, weight=weight)),
        replace(base, gps=replace(g, weight=replace(weight, origin="fixed"))),
        replace(base, gps=None, manual=obs),
        replace(base, fix=replace(f, rejected_slots=(3, 5), uses_prior=True),
                fix_fails_tests=True, fix_cov_scale=2.25),
        replace(base, fix=replace(f, ellipse=None, cov=nan_cov), kf_pred=None),
        replace(base, fix=None, filter_state=None, filter_update=None, sensor_update=None),
        replace(base, kf_pred=replace(p, ellipse=None, cov=None)),
        replace(base, mpp=replace(base.mpp, cov=nan_cov, source="a b")),  # type: ignore
        replace(base, messages=("one", "two = 2", ""), raw="  spaced  "),
        replace(base, cm_deg=3, dt_s=np.float64(1.5), record=np.int64(7), datum=None),
        replace(base, time=datetime(999, 1, 2, 3, 4, 5)),
        replace(base, time=datetime(2001, 2, 3, 4, 5, 6, 789, tzinfo=UTC)),
        replace(base, time=datetime(9999, 12, 31, 23, 59, 59) - timedelta(seconds=1)),
    ]
    if nofix is not None:
        variants.append(nofix)
    for r in variants:
        _check_cycle(r)


@needs_kernel
def test_cycle_rows_leave_the_unexpected_to_the_python(replay_results: list[object]) -> None:
    """A VCV that is not 2×2, a missing attribute, a P diagonal of ints: None (the Python
    builds the block and raises or writes as it always did)."""
    from dataclasses import replace


    base = next(r for r in replay_results if r.kf_pred is not None)  # type: ignore
    int_p = replace(base.filter_state)  # type: ignore[attr-defined]
    object.__setattr__(int_p, "P", np.eye(len(int_p.x), dtype=int))  # past __post_init__
    bad = [
        replace(base, kf_pred=replace(base.kf_pred, cov=np.eye(3))),  # type: ignore
        replace(base, mpp=object()),
        replace(base, sensors=None),
        replace(base, filter_state=int_p),
    ]
    for r in bad:
        assert K.cycle_rows(r, BLOCK_SHAPES) is None  # type: ignore[union-attr]
        assert fast_outlog.cycle_text(r, BLOCK_SHAPES) is None
    assert K.cycle_rows(base, ()) is None  # type: ignore[union-attr]


def test_session_writes_the_python_block_without_the_kernel(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """With the kernel (or where it declines) and without it, a replay's ``.OUT`` is the same."""
    from tests.paths import DATA

    def run(name: str) -> str:
        from engine.run.config import load_config
        from engine.run.session import Session

        out = tmp_path / f"{name}.OUT"
        with Session(load_config(DATA / "DEMO.toml"), out_path=out, force=True,
                     history=1) as s:
            s.run(max_cycles=40)
        return out.read_text(encoding="utf-8").split("# config-end\n", 1)[1]

    fast = run("fast")
    monkeypatch.setattr(fast_outlog, "kernel", lambda: None)
    assert fast_outlog.cycle_text(object(), BLOCK_SHAPES) is None  # type: ignore[arg-type]
    assert run("pure") == fast
