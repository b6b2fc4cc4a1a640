"""The ``.OUT`` fast path (issue 14) writes exactly what the general formatting writes.

:func:`engine.io.outlog.render_line` (cached ``%`` templates) and the writer's
:class:`~engine.io.outlog.KeyedLines` rows must give the same text as :func:`format_line` /
:func:`format_fields` (the general API) for every value: odd strings (text is data, quoted
exactly as before), nan/inf/-0.0, numpy scalars, ints, bools, None.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import random
import re
import struct
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.io import outlog
from engine.io.outlog import (
    _NEVER_IN_A_NUMBER,
    KeyedLines,
    OutLogWriter,
    _format_text,
    format_fields,
    format_line,
    format_value,
    render_line,
)
from engine.run.records import _utc_text

ODD_WORDS = ["", "-", "1", "1e5", "-0.0", "nan", "NaN", "inf", "-Infinity", "1_000", " 1 ",
             "a b", 'say "hi"', "k=v", "back\\slash", "tab\there", "new\nline", "\u00a0nbsp",
             "\u0661\u0662", "σ ≤ 3 m", "lse", "accept", "1992-09-17T08:35:38Z", "0.123,4.567",
             "%s", "%r %d", "%%", "null\x00byte", "\u2028"]

texts = st.one_of(st.sampled_from(ODD_WORDS),
                  st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=20),
                  st.text(alphabet="0123456789.eE+-_ infa:,", max_size=8))
floats = st.one_of(st.floats(), st.sampled_from([0.0, -0.0, math.nan, math.inf, -math.inf,
                                                 1e16, 1e-5, 5e-324, 1.7976931348623157e308]))
values = st.one_of(
    st.none(), st.booleans(), st.integers(), floats, texts,
    floats.map(np.float64), st.floats(width=32).map(np.float32),
    st.integers(-2**63, 2**63 - 1).map(np.int64),
    st.booleans().map(np.bool_),
)
keys = st.lists(st.one_of(st.from_regex(r"[a-z_][a-z0-9_]{0,8}", fullmatch=True),
                          st.sampled_from(["%", "%s", "a%d", "s_hdg", "n"])),
                unique=True, max_size=14)


@settings(max_examples=400)
@given(keys.flatmap(lambda ks: st.tuples(st.just(tuple(ks)),
                                         st.tuples(*[values] * len(ks)))),
       st.sampled_from(["CYCLE", "\n  LOP", "\n  %s", ""]))
def test_render_line_is_format_line(kv: tuple[tuple[str, ...], tuple], prefix: str) -> None:
    ks, vs = kv
    fields = dict(zip(ks, vs, strict=True))
    want = format_line(prefix, fields)
    assert render_line(prefix, ks, vs) == want
    assert render_line(prefix, ks, vs) == want  # again: from the cached template
    assert prefix + "".join(f" {k}={format_value(v)}" for k, v in fields.items()) == want


@given(st.lists(st.tuples(st.sampled_from(["IN", "LOP", "KF", "MSG"]),
                          keys.flatmap(lambda ks: st.tuples(st.just(tuple(ks)),
                                                            st.tuples(*[values] * len(ks))))),
                max_size=6),
       st.integers(0, 10**6))
@settings(max_examples=60, deadline=None)
def test_write_cycle_rows_equal_dict_lines(tmp_path_factory: pytest.TempPathFactory,
                                           lines: list, n: int) -> None:
    """The writer's text from KeyedLines rows = its text from (tag, dict) lines = the general
    format_line of each line."""
    d = tmp_path_factory.mktemp("fast")
    head = {"n": n, "t": "1992-09-17T08:35:38Z", "source": "KF"}
    rows = KeyedLines()
    rows.rows.extend(("\n  " + tag, ks, vs) for tag, (ks, vs) in lines)
    plain = [(tag, dict(zip(ks, vs, strict=True))) for tag, (ks, vs) in lines]
    assert list(rows) == plain and len(rows) == len(plain)
    texts_out = []
    for name, body in (("A.OUT", rows), ("B.OUT", plain)):
        with OutLogWriter.create(d / name, force=True) as w:
            w.write_cycle(head, body)
        texts_out.append((d / name).read_bytes())
    assert texts_out[0] == texts_out[1]
    block = "\n".join([format_line("CYCLE", head)]
                      + [format_line(t, f, "  ") for t, f in plain]
                      + [format_line("END", {"n": n})]) + "\n"
    assert texts_out[0].decode("utf-8").endswith(block)


def test_keyed_lines_read_as_a_sequence() -> None:
    rows = KeyedLines()
    rows.rows.append(("\n  IN", ("raw",), ("920917 083538",)))
    rows.rows.append(("\n  MPP", ("x", "y"), (1.5, None)))
    assert len(rows) == 2
    assert rows[0] == ("IN", {"raw": "920917 083538"})
    assert rows[-1] == ("MPP", {"x": 1.5, "y": None})
    assert rows[0:2] == list(rows)
    assert dict(rows)["MPP"]["x"] == 1.5
    with pytest.raises(IndexError):
        rows[2]


def _reference_text(text: str) -> str:
    """The quoting rule as written before issue 14 (json.dumps, float() probe)."""
    try:
        float(text)
        numeric = True
    except ValueError:
        numeric = False
    if text in ("", "-") or re.search(r'[\s"=\\]', text) or numeric:
        return json.dumps(text, ensure_ascii=False)
    return text


@given(texts)
def test_text_is_quoted_exactly_as_before(text: str) -> None:
    assert _format_text(text) == _reference_text(text)
    assert format_fields({"text": text}) == f" text={_reference_text(text)}"


@given(st.text(alphabet="0123456789.eE+-_ infatyINFATY", max_size=10),
       st.sampled_from(list(":,;/()<>|!?@#$%&*'^~`[]{}bcdghjkmopqrsuvwxzBCDGHJKMOPQRSUVWXZ")),
       st.integers(0, 10))
def test_a_word_with_a_never_numeric_character_is_no_number(word: str, c: str, at: int) -> None:
    """The shortcut of _looks_numeric: float() rejects these characters wherever they stand."""
    text = word[:at] + c + word[at:]
    assert _NEVER_IN_A_NUMBER(text)
    with pytest.raises(ValueError):
        float(text)


@given(st.datetimes(min_value=dt.datetime(1, 1, 1), max_value=dt.datetime(9999, 12, 31)))
def test_utc_text_is_strftime(t: dt.datetime) -> None:
    assert _utc_text(t) == t.strftime("%Y-%m-%dT%H:%M:%SZ")


def test_sample_cycles_render_as_the_general_path(tmp_path: Path) -> None:
    """Real cycles (thesis sample): cycle_block's rows through the fast writer = the same lines
    as dicts through format_line."""
    from engine.run.config import load_config
    from engine.run.records import cycle_block
    from engine.run.session import Session
    from tests.paths import DATA

    cfg = load_config(DATA / "920917_1.toml")
    s = Session(cfg, out_path=tmp_path / "S.OUT", force=True, history=1000)
    try:
        s.run(max_cycles=60)
    finally:
        s.close()
    assert len(s.history) > 3
    for r in s.history:
        head, lines = cycle_block(r)
        assert isinstance(lines, KeyedLines)
        with OutLogWriter.create(tmp_path / "F.OUT", force=True) as w:
            w.write_cycle(head, lines)
        got = (tmp_path / "F.OUT").read_text(encoding="utf-8").split("# config-end\n", 1)[1]
        want = "\n".join([format_line("CYCLE", head)]
                         + [format_line(t, f, "  ") for t, f in lines]
                         + [format_line("END", {"n": head["n"]})]) + "\n"
        assert got == want


# --- the batched float writer (orjson where installed) -------------------------------------

TIES = [n + f for n in (101065508335255, 123456789012345, 99999999999999, 10**14 + 7)
        for f in (0.125, 0.375, 0.625, 0.875)]
EDGES = [0.0, -0.0, 1.0, -1.0, 0.1, 1e-4, -1e-4, 9.999999999999999e-05, 0.00010000000000000002,
         1e16, 9999999999999998.0, -1e16, 1e-5, 5e-324, -5e-324, 2.2250738585072014e-308,
         1.7976931348623157e308, math.nan, math.inf, -math.inf, -math.nan, 1e22, 123.0]


@settings(max_examples=300)
@given(st.lists(floats, max_size=40))
def test_float_texts_are_repr(values: list[float]) -> None:
    assert outlog.float_texts(values) == [repr(v) for v in values]
    assert outlog.float_texts(values, compiled=False) == [repr(v) for v in values]


def test_float_texts_on_ties_edges_and_random_bits() -> None:
    rng = random.Random(14)
    bits = [struct.unpack("<d", struct.pack("<Q", rng.getrandbits(64)))[0]
            for _ in range(20000)]
    scaled = [rng.uniform(-1.0, 1.0) * 10.0 ** rng.uniform(-7.0, 18.0) for _ in range(20000)]
    rounded = [round(v, rng.randint(0, 12)) for v in scaled]
    for values in (TIES, EDGES, bits, scaled, rounded, EDGES * 3 + TIES):
        assert outlog.float_texts(list(values)) == [repr(v) for v in values]
        assert outlog.float_texts(list(values), compiled=False) == [repr(v) for v in values]


def test_the_compiled_writer_is_used_where_installed() -> None:
    """The speed of the .OUT rests on it (orjson, an optional dependency): where it is
    installed it must have passed its probes."""
    pytest.importorskip("orjson")
    assert outlog._float_writer() is not None


def test_a_writer_that_differs_from_repr_is_not_used() -> None:
    good = outlog._float_writer()
    if good is not None:
        assert outlog._checked_float_writer(good) is good

    def plain_big(values: list[float]) -> bytes:  # 1e16 without exponent
        return ("[" + ",".join(f"{v:.1f}" if abs(v) >= 1e16 and math.isfinite(v) else repr(v)
                               for v in values) + "]").encode()

    def short(values: list[float]) -> bytes:  # 15 digits: not the shortest round trip
        return ("[" + ",".join(f"{v:.15g}" for v in values) + "]").encode()

    def exp_small(values: list[float]) -> bytes:  # "0.00001" for 1e-05
        return ("[" + ",".join(f"{v:.20f}".rstrip("0") if 0 < abs(v) < 1e-4 else repr(v)
                               for v in values) + "]").encode()

    for bad in (plain_big, short, exp_small):
        assert outlog._checked_float_writer(bad) is None


@given(st.lists(st.tuples(st.sampled_from(["\n  LOP", "\n  KF", "CYCLE", "\n"]),
                          keys.flatmap(lambda ks: st.tuples(st.just(tuple(ks)),
                                                            st.tuples(*[values] * len(ks))))),
                max_size=6))
@settings(max_examples=200)
def test_render_rows_is_render_line_per_row(rows: list) -> None:
    flat_rows = [(p, ks, vs) for p, (ks, vs) in rows]
    want = "".join(format_line(p, dict(zip(ks, vs, strict=True))) for p, ks, vs in flat_rows)
    assert outlog.render_rows(flat_rows) == want
    assert outlog.render_rows(flat_rows) == want  # cached template
    assert outlog.render_rows(flat_rows, compiled=False) == want
