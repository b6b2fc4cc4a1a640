"""The .RUN grammar's optional key=value tokens (hdop= q= sats= cog= sog=, engine/io/runfile.py)
that make an NMEA log's conversion lossless."""

from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.runfile import RunRecord, format_run_record, parse_run_line

BASE = "261202 120000 - - - - - 10.0 5.2 - - - 12.34"


def test_keys_parse() -> None:
    r = parse_run_line(BASE + " hdop=1.20 q=2 sats=11 cog=359.9 sog=0.05")
    assert r is not None
    assert (r.gps_hdop, r.gps_quality, r.gps_sats, r.cog_deg, r.sog_kn) == (
        1.2, 2, 11, 359.9, 0.05)
    assert (r.heading_deg, r.echo_m) == (10.0, 12.34)
    only = parse_run_line(BASE + " sog=3")
    assert only is not None and only.sog_kn == 3.0 and only.gps_hdop is None


@pytest.mark.parametrize(("tail", "field"), [
    (" hdop=0", "hdop"), (" hdop=1e3", "hdop"), (" hdop=", "hdop"), (" q=0", "q"),
    (" q=6", "q"), (" q=1.0", "q"), (" sats=-1", "sats"), (" cog=360", "cog"),
    (" cog=-0.1", "cog"), (" sog=201", "sog"), (" sog=nan", "sog"), (" sog=5-", "sog"),
    (" foo=1", "record"), (" hdop", "record"), (" q=1 q=1", "q"), (" q=1 5", "record"),
])
def test_bad_keys_are_located(tail: str, field: str) -> None:
    with pytest.raises(InputError) as err:
        parse_run_line(BASE + tail, 7, "X.RUN")
    assert err.value.field == field and err.value.line == 7 and err.value.file == "X.RUN"


def test_keys_need_all_optional_columns() -> None:
    with pytest.raises(InputError, match="nine numeric columns"):
        parse_run_line("261202 120000 - - - - - 10.0 5.2 - 12.34 q=1")


def test_1993_lines_unchanged() -> None:
    rec = RunRecord(1, datetime(1992, 9, 17, 8, 35, 38, tzinfo=UTC), None, None,
                    (0.862, 0.325, 0.109), 232.4, 12.7, -0.2)
    assert format_run_record(rec) == "920917 083538 - - .862 .325 .109 232.4 12.7 -.2"


@settings(max_examples=200, deadline=None)
@given(st.none() | st.floats(0.01, 99.99), st.none() | st.integers(1, 5),
       st.none() | st.integers(0, 99), st.none() | st.floats(0.0, 359.94),
       st.none() | st.floats(0.0, 200.0))
def test_format_then_parse_round_trips(hdop: float | None, q: int | None, sats: int | None,
                                       cog: float | None, sog: float | None) -> None:
    base = parse_run_line(BASE)
    assert base is not None
    rec = replace(base, gps_hdop=hdop, gps_quality=q, gps_sats=sats, cog_deg=cog, sog_kn=sog)
    line = format_run_record(rec)
    back = parse_run_line(line)
    assert back is not None
    # written with 2 decimals (HDOP, SOG) and 1 (COG): equal to that rounding (half a unit)
    for got, want, tol in ((back.gps_hdop, hdop, 0.005), (back.cog_deg, cog, 0.05),
                           (back.sog_kn, sog, 0.005)):
        assert (got is None) == (want is None)
        if got is not None and want is not None:
            assert abs(got - want) <= tol + 1e-9
    assert (back.gps_quality, back.gps_sats) == (q, sats)
    assert format_run_record(back) == line  # the written line is a fixed point
