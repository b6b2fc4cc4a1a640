"""*.RUN: the bundled sample (thesis A8.4, seed L8971–8985), parser checks, writer, streaming."""

from __future__ import annotations

import math
import pathlib
import re
import sys
import tracemalloc
from datetime import UTC, datetime, timedelta

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.runfile import (
    BadRecord,
    RunRecord,
    format_run_record,
    iter_run_file,
    iter_run_lines,
    parse_run_line,
)
from tests.paths import DATA

RUN = DATA / "920917_1.RUN"
RUN_LINES = RUN.read_text(encoding="utf-8").splitlines()
SAMPLE = "920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2"

# The "Simulation data file" block of thesis A8.4 (seed L8973–8983), copied verbatim from the
# thesis text (its tabs included), independently of data/920917_1.RUN.
THESIS_RUN = """\
Date	Time	GPS lat	GPS lon	Decca	Heading	Speed	Rudder
920917	083538	52 50 33.020 N	004 31 51.134 E	.862 .325 .109	232.4	12.7	-.2
920917	083539	52 50 32.781 N	004 31 50.672 E	.862 .337 .111	232.3	12.7	-.2
920917	083540	52 50 32.706 N	004 31 50.497 E	.866 .343 .115	232.2	12.7	-.2
920917	083541	52 50 32.584 N	004 31 50.125 E	.873 .347 .118	232.1	12.7	-.4
920917	083542	52 50 32.509 N	004 31 49.950 E	.877 .353 .118	231.8	12.6	-.5
920917	083543	52 50 32.359 N	004 31 49.663 E	.879 .357 .116	231.7	12.6	.2
920917	083544	52 50 32.269 N	004 31 49.489 E	.872 .361 .112	231.8	12.8	1.2
920917	083545	52 50 32.223 N	004 31 49.289 E	.872 .368 .107	232.3	12.9	1.5
920917	083546	52 50 32.073 N	004 31 48.973 E	.870 .372 .103	232.9	13.0	-.1
920917	083547	52 50 31.997 N	004 31 48.798 E	.869 .376 .104	233.0	13.0	-2.4
"""
THESIS_RUN_LINES = THESIS_RUN.splitlines()


def dms(d: int, m: int, s: float) -> float:
    return d + m / 60 + s / 3600


def records() -> list[RunRecord]:
    out = list(iter_run_file(RUN))
    assert all(isinstance(r, RunRecord) for r in out)
    return out  # type: ignore[return-value]


# --------------------------------------------------------------------------- bundled sample


def test_sample_has_ten_records_one_second_apart() -> None:
    recs = records()
    assert len(recs) == 10
    t0 = datetime(1992, 9, 17, 8, 35, 38, tzinfo=UTC)
    assert [r.time for r in recs] == [t0 + timedelta(seconds=k) for k in range(10)]
    assert recs[-1].time == datetime(1992, 9, 17, 8, 35, 47, tzinfo=UTC)
    # Line 1 of the file is the A8.4 caption, skipped; records are lines 2..11.
    assert [r.line_no for r in recs] == list(range(2, 12))


def test_first_record_values() -> None:
    r = records()[0]
    assert r.gps_lat_deg == dms(52, 50, 33.020)
    assert r.gps_lon_deg == dms(4, 31, 51.134)
    assert r.decca == (0.862, 0.325, 0.109)
    assert (r.heading_deg, r.speed_kn, r.rudder_deg) == (232.4, 12.7, -0.2)
    # No optional columns in the thesis sample: sensors "not connected".
    assert (r.incl_deg, r.press_freq_hz, r.echo_m) == (None, None, None)


def test_second_record_matches_pg611_inputs() -> None:
    # THEORY D6: Pg 611 shows 08:35:39Z with gyro 232.3 and log 12.7 = line 2 of the sample.
    r = records()[1]
    assert r.time.strftime("%H:%M:%SZ") == "08:35:39Z"
    assert (r.heading_deg, r.speed_kn) == (232.3, 12.7)
    assert r.decca == (0.862, 0.337, 0.111)


def test_last_record_values() -> None:
    r = records()[-1]
    assert r.gps_lat_deg == dms(52, 50, 31.997)
    assert r.gps_lon_deg == dms(4, 31, 48.798)
    assert r.decca == (0.869, 0.376, 0.104)
    assert (r.heading_deg, r.speed_kn, r.rudder_deg) == (233.0, 13.0, -2.4)


def test_sample_rudder_column() -> None:
    assert [r.rudder_deg for r in records()] == [
        -0.2, -0.2, -0.2, -0.4, -0.5, 0.2, 1.2, 1.5, -0.1, -2.4
    ]


def test_writer_reproduces_the_thesis_lines() -> None:
    # Same tokens as printed in A8.4 (the thesis separates some columns by tabs); compared with
    # the copy of the thesis block above, not with the data file the records came from.
    for rec, line in zip(records(), THESIS_RUN_LINES[1:], strict=True):
        assert format_run_record(rec) == " ".join(line.split())


# --------------------------------------------------------------------------- transcription


def test_data_file_is_the_thesis_block_token_by_token() -> None:
    # Every line, every token: the caption and the 10 records (blanks between tokens are tabs in
    # the thesis and may differ; nothing else may).
    assert len(RUN_LINES) == len(THESIS_RUN_LINES) == 11
    for ours, thesis in zip(RUN_LINES, THESIS_RUN_LINES, strict=True):
        assert ours.split() == thesis.split()


def _thesis_values(line: str) -> tuple[object, ...]:
    """A thesis record's values computed by hand from its tokens (not by the parser)."""
    t = line.split()
    when = datetime(1900 + int(t[0][:2]), int(t[0][2:4]), int(t[0][4:]),
                    int(t[1][:2]), int(t[1][2:4]), int(t[1][4:]), tzinfo=UTC)
    assert t[5] == "N" and t[9] == "E"  # the sample is in the NE quadrant
    lat = int(t[2]) + int(t[3]) / 60 + float(t[4]) / 3600
    lon = int(t[6]) + int(t[7]) / 60 + float(t[8]) / 3600
    return (when, lat, lon, tuple(float(x) for x in t[10:13]), float(t[13]), float(t[14]),
            float(t[15]))


def test_parsed_values_equal_the_thesis_block() -> None:
    for rec, line in zip(records(), THESIS_RUN_LINES[1:], strict=True):
        when, lat, lon, decca, hdg, spd, rud = _thesis_values(line)
        assert rec.time == when
        # D + M/60 + S/3600 in the same floating-point order as the parser: equal to the last
        # bit, 1e-12 deg (4e-9 ") allows for a different but equivalent rounding.
        assert rec.gps_lat_deg == pytest.approx(lat, abs=1e-12)
        assert rec.gps_lon_deg == pytest.approx(lon, abs=1e-12)
        assert rec.decca == decca
        assert (rec.heading_deg, rec.speed_kn, rec.rudder_deg) == (hdg, spd, rud)


# --------------------------------------------------------------------------- grammar details


def test_skipped_lines() -> None:
    for line in ("", "   \n", "* comment", "  *indented comment",
                 "Date\tTime\tGPS lat\tGPS lon\tDecca\tHeading\tSpeed\tRudder"):
        assert parse_run_line(line) is None


@pytest.mark.parametrize(
    ("date", "year"), [("700101", 1970), ("991231", 1999), ("000229", 2000), ("691231", 2069)]
)
def test_two_digit_year_pivot(date: str, year: int) -> None:
    rec = parse_run_line(SAMPLE.replace("920917", date))
    assert rec is not None and rec.time.year == year and rec.time.tzinfo is UTC


def test_dashes_and_optional_columns() -> None:
    line = "920917 083538 - 004 31 51.134 W - .325 - - - - 1.5 - 12.25"
    rec = parse_run_line(line)
    assert rec is not None
    assert rec.gps_lat_deg is None
    assert rec.gps_lon_deg == -dms(4, 31, 51.134)
    assert rec.decca == (None, 0.325, None)
    assert (rec.heading_deg, rec.speed_kn, rec.rudder_deg) == (None, None, None)
    assert (rec.incl_deg, rec.press_freq_hz, rec.echo_m) == (1.5, None, 12.25)
    assert format_run_record(rec) == line.replace("1.5 ", "1.50 ")


def test_all_optional_columns_and_southern_hemisphere() -> None:
    rec = parse_run_line("011231 235959 33 51 35.9 s 151 12 40 e .0 .5 .999 0 0 90 -90 10000. 0")
    assert rec is not None
    assert rec.time == datetime(2001, 12, 31, 23, 59, 59, tzinfo=UTC)
    assert rec.gps_lat_deg == -dms(33, 51, 35.9) and rec.gps_lon_deg == dms(151, 12, 40)
    assert (rec.rudder_deg, rec.incl_deg, rec.press_freq_hz, rec.echo_m) == (
        90.0, -90.0, 10000.0, 0.0
    )


def test_iter_run_lines_yields_bad_records_and_continues() -> None:
    lines = [SAMPLE, SAMPLE.replace("232.4", "400.0"), "* note", SAMPLE.replace("083538", "083540")]
    out = list(iter_run_lines(lines, "x.RUN"))
    assert [type(o) for o in out] == [RunRecord, BadRecord, RunRecord]
    bad = out[1]
    assert isinstance(bad, BadRecord)
    assert (bad.line_no, bad.error.line, bad.error.field) == (2, 2, "heading")
    assert bad.raw == lines[1]
    assert out[2].line_no == 4


def test_iter_run_file_bad_bytes_do_not_stop_replay(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "bytes.RUN"
    path.write_bytes(SAMPLE.encode() + b"\n\xff\xfe garbage \x00\n" + SAMPLE.encode() + b"\n")
    out = list(iter_run_file(path))
    assert [type(o) for o in out] == [RunRecord, BadRecord, RunRecord]


def test_iter_run_file_missing(tmp_path: pathlib.Path) -> None:
    with pytest.raises(InputError) as info:
        iter_run_file(tmp_path / "NONE.RUN")
    assert info.value.message == "File not found !"


# --------------------------------------------------------------------------- malformed input


def _sub(old: str, new: str) -> str:
    assert old in SAMPLE
    return SAMPLE.replace(old, new, 1)


RANGE = "Wrong number of fields"
BAD_CASES = [
    # (id, line, field, message, offending text)
    ("heading 400", _sub("232.4", "400.0"), "heading",
     "Heading must be in [0, 360) degrees !", "400.0"),
    ("heading 360", _sub("232.4", "360"), "heading", "Heading must be in [0, 360) degrees !",
     "360"),
    ("heading text", _sub("232.4", "N232"), "heading", "Not a number !", "N232"),
    ("speed 61", _sub("12.7", "61"), "speed", "Speed must be in [0, 60] knots !", "61"),
    ("speed negative", _sub("12.7", "-0.1"), "speed", "Speed must be in [0, 60] knots !", "-0.1"),
    ("rudder 91", _sub("-.2", "91"), "rudder", "Rudder angle must be in [-90, 90] degrees !",
     "91"),
    ("fraction 1.000", _sub(".862", "1.000"), "Decca red", "Decca fraction must be in [0, 1) !",
     "1.000"),
    ("fraction text", _sub(".325", "o.325"), "Decca green", "Not a number !", "o.325"),
    ("fraction nan", _sub(".109", "nan"), "Decca purple", "Not a number !", "nan"),
    ("month 13", _sub("920917", "921317"), "date", "Wrong date (YYMMDD) !", "921317"),
    ("29 Feb 2001", _sub("920917", "010229"), "date", "Wrong date (YYMMDD) !", "010229"),
    ("date letter O", _sub("920917", "92O917"), "date", "Wrong date (YYMMDD) !", "92O917"),
    ("seconds 60", _sub("083538", "083560"), "time", "Wrong time (HHMMSS) !", "083560"),
    ("time 5 digits", _sub("083538", "83538"), "time", "Wrong time (HHMMSS) !", "83538"),
    ("lat minutes 60", _sub("52 50 33.020", "52 60 33.020"), "GPS latitude",
     "Minutes must be < 60 !", "52 60 33.020 N"),
    ("lat seconds 60.5", _sub("52 50 33.020", "52 50 60.5"), "GPS latitude",
     "Seconds must be in [0, 60) !", "52 50 60.5 N"),
    ("lat 91", _sub("52 50 33.020", "91 00 00"), "GPS latitude",
     "Latitude must be <= 90 degrees !", "91 00 00 N"),
    ("lat hemisphere X", _sub("33.020 N", "33.020 X"), "GPS latitude",
     "Hemisphere must be N or S !", "52 50 33.020 X"),
    ("lat decimal degrees", _sub("52 50 33.020", "52.5 50 33.020"), "GPS latitude",
     "Degrees and minutes must be whole non-negative numbers !", "52.5 50 33.020 N"),
    ("lon 181", _sub("004 31", "181 31"), "GPS longitude",
     "Longitude must be <= 180 degrees !", "181 31 51.134 E"),
    ("lon hemisphere N", _sub("51.134 E", "51.134 N"), "GPS longitude",
     "Hemisphere must be E or W !", "004 31 51.134 N"),
    ("lat dash inside 4 tokens", _sub("52 50", "- 50"), "GPS longitude",
     "Wrong longitude format (D M S.sss E|W) !", "50 33.020 N 004"),
    ("rudder missing", SAMPLE[: -len(" -.2")], "record", "Wrong number of fields (15) !",
     SAMPLE[: -len(" -.2")]),
    ("too many fields", SAMPLE + " 1 2 3 4", "record", "Wrong number of fields (20) !",
     SAMPLE + " 1 2 3 4"),
    ("one fraction missing", _sub(" .325", ""), "record", "Wrong number of fields (15) !",
     _sub(" .325", "")),
    ("inclinometer 95", SAMPLE + " 95", "inclinometer",
     "Inclination must be in [-90, 90] degrees !", "95"),
    ("pressure frequency 0", SAMPLE + " 1.5 0", "pressure frequency",
     "Pressure frequency must be > 0 Hz !", "0"),
    ("pressure frequency inf", SAMPLE + " - inf", "pressure frequency", "Not a number !", "inf"),
    ("echo negative", SAMPLE + " - 32768 -1", "echo sounder", "Echo depth must be >= 0 m !",
     "-1"),
    ("echo text", SAMPLE + " - - 12m", "echo sounder", "Not a number !", "12m"),
    # Numbers float() takes but the grammar does not (plain ASCII decimals, '-' only):
    ("heading underscore", _sub("232.4", "2_32.4"), "heading", "Not a number !", "2_32.4"),
    ("heading Arabic-Indic", _sub("232.4", "٢٣٢.٤"), "heading", "Not a number !", "٢٣٢.٤"),
    ("heading full-width", _sub("232.4", "２３２.4"), "heading", "Not a number !", "２３２.4"),
    ("speed plus sign", _sub("12.7", "+12.7"), "speed", "Not a number !", "+12.7"),
    ("rudder exponent", _sub("-.2", "-2e-1"), "rudder", "Not a number !", "-2e-1"),
    ("fraction infinity", _sub(".862", "-infinity"), "Decca red", "Not a number !", "-infinity"),
    ("echo exponent", SAMPLE + " - - 1E2", "echo sounder", "Not a number !", "1E2"),
    ("fraction lone dot", _sub(".325", "."), "Decca green", "Not a number !", "."),
    ("lat D underscore", _sub("52 50 33.020", "5_2 50 33.020"), "GPS latitude",
     "Wrong latitude format (D M S.sss N|S) !", "5_2 50 33.020 N"),
    ("lat D plus sign", _sub("52 50 33.020", "+52 50 33.020"), "GPS latitude",
     "Wrong latitude format (D M S.sss N|S) !", "+52 50 33.020 N"),
    ("lat D Arabic-Indic", _sub("52 50 33.020", "٥٢ 50 33.020"), "GPS latitude",
     "Wrong latitude format (D M S.sss N|S) !", "٥٢ 50 33.020 N"),
    ("lat D superscript", _sub("52 50 33.020", "5² 50 33.020"), "GPS latitude",
     "Wrong latitude format (D M S.sss N|S) !", "5² 50 33.020 N"),
    ("lat D exponent", _sub("52 50 33.020", "5.2e1 50 33.020"), "GPS latitude",
     "Wrong latitude format (D M S.sss N|S) !", "5.2e1 50 33.020 N"),
    ("lon S exponent", _sub("51.134 E", "5.1134e1 E"), "GPS longitude",
     "Wrong longitude format (D M S.sss E|W) !", "004 31 5.1134e1 E"),
    ("lon M plus sign", _sub("004 31", "004 +31"), "GPS longitude",
     "Wrong longitude format (D M S.sss E|W) !", "004 +31 51.134 E"),
    ("lat M negative", _sub("52 50 33.020", "52 -0 33.020"), "GPS latitude",
     "Degrees and minutes must be whole non-negative numbers !", "52 -0 33.020 N"),
    ("lat hemisphere long s", _sub("33.020 N", "33.020 ſ"), "GPS latitude",
     "Hemisphere must be N or S !", "52 50 33.020 ſ"),
    ("em-space separator", _sub(" 232.4", "\u2003232.4"), "record",
     "Fields must be separated by spaces or tabs !", "\u2003"),
    ("U+001C separator", _sub(" 12.7", "\x1c12.7"), "record",
     "Fields must be separated by spaces or tabs !", "\x1c"),
]


@pytest.mark.parametrize(
    ("line", "field", "message", "got"),
    [case[1:] for case in BAD_CASES],
    ids=[case[0] for case in BAD_CASES],
)
def test_malformed(line: str, field: str, message: str, got: str) -> None:
    with pytest.raises(InputError) as info:
        parse_run_line(line, 3, "file.RUN")
    err = info.value
    assert (err.file, err.line, err.field, err.message, err.text) == (
        "file.RUN", 3, field, message, got
    )
    assert str(err) == f"file.RUN:3: {field}: {message} (got {got!r})"


def test_heading_error_text_format() -> None:
    # The exact rendering promised to the UI.
    with pytest.raises(InputError) as info:
        parse_run_line(_sub("232.4", "400.0"), 3, "file.RUN")
    assert str(info.value) == "file.RUN:3: heading: Heading must be in [0, 360) degrees ! " \
        "(got '400.0')"


# --------------------------------------------------------------------------- round trip (property)

@st.composite
def run_records(draw: st.DrawFn) -> RunRecord:
    time = draw(st.datetimes(datetime(1970, 1, 1), datetime(2069, 12, 31, 23, 59, 59),
                             timezones=st.just(UTC))).replace(microsecond=0)
    frac = st.none() | st.floats(0.0, 1.0, exclude_max=True)
    return RunRecord(
        line_no=0,
        time=time,
        gps_lat_deg=draw(st.none() | st.floats(-90.0, 90.0)),
        gps_lon_deg=draw(st.none() | st.floats(-180.0, 180.0)),
        decca=(draw(frac), draw(frac), draw(frac)),
        heading_deg=draw(st.none() | st.floats(0.0, 360.0, exclude_max=True)),
        speed_kn=draw(st.none() | st.floats(0.0, 60.0)),
        rudder_deg=draw(st.none() | st.floats(-90.0, 90.0)),
        incl_deg=draw(st.none() | st.floats(-90.0, 90.0)),
        press_freq_hz=draw(st.none() | st.floats(1.0, 1e6)),
        echo_m=draw(st.none() | st.floats(0.0, 11_000.0)),
    )


def _close(a: float | None, b: float | None, tol: float, period: float | None = None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    diff = abs(a - b)
    if period is not None:
        diff = min(diff, period - diff)
    return diff <= tol


@settings(max_examples=200, deadline=None)
@given(run_records())
def test_round_trip_property(rec: RunRecord) -> None:
    line = format_run_record(rec)
    back = parse_run_line(line, 7, "rt.RUN")
    assert back is not None and back.line_no == 7 and back.raw == line
    assert back.time == rec.time
    # Tolerances = half the last written digit (+ float slack): 0.0005" of arc, 0.05 for
    # 1-decimal columns, 0.005 for 2-decimal ones, 0.0005 Hz. Fractions: 0.001 because
    # values in [0.9995, 1) are clamped to .999; heading is compared modulo 360.
    assert _close(back.gps_lat_deg, rec.gps_lat_deg, 0.0005 / 3600 + 1e-12)
    assert _close(back.gps_lon_deg, rec.gps_lon_deg, 0.0005 / 3600 + 1e-12)
    for x, y in zip(back.decca, rec.decca, strict=True):
        assert _close(x, y, 0.001 + 1e-12)
    assert _close(back.heading_deg, rec.heading_deg, 0.05 + 1e-9, period=360.0)
    assert _close(back.speed_kn, rec.speed_kn, 0.05 + 1e-9)
    assert _close(back.rudder_deg, rec.rudder_deg, 0.05 + 1e-9)
    assert _close(back.incl_deg, rec.incl_deg, 0.005 + 1e-9)
    assert _close(back.press_freq_hz, rec.press_freq_hz, 0.0005 + 1e-9)
    assert _close(back.echo_m, rec.echo_m, 0.005 + 1e-9)
    # Writing the parsed record again gives the same line (the text is a fixed point).
    assert format_run_record(back) == line


# --------------------------------------------------------------------------- fuzz


def _check_valid(rec: RunRecord) -> None:
    """Every value of a record the parser accepts lies in its documented range."""
    assert rec.time.tzinfo is UTC and 1970 <= rec.time.year <= 2069
    assert rec.gps_lat_deg is None or -90 <= rec.gps_lat_deg <= 90
    assert rec.gps_lon_deg is None or -180 <= rec.gps_lon_deg <= 180
    assert all(f is None or 0 <= f < 1 for f in rec.decca)
    assert rec.heading_deg is None or 0 <= rec.heading_deg < 360
    assert rec.speed_kn is None or 0 <= rec.speed_kn <= 60
    assert rec.rudder_deg is None or -90 <= rec.rudder_deg <= 90
    assert rec.incl_deg is None or -90 <= rec.incl_deg <= 90
    assert rec.press_freq_hz is None or (0 < rec.press_freq_hz and math.isfinite(
        rec.press_freq_hz))
    assert rec.echo_m is None or (0 <= rec.echo_m and math.isfinite(rec.echo_m))


# The record grammar written out independently of the parser: ASCII digits only, numbers are
# plain decimals (a '-' only in the numeric columns), fields separated by spaces or tabs.
_DEC = r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)"
_SEP = r"[ \t]+"
_LAT = rf"(?:[0-9]+{_SEP}[0-9]+{_SEP}{_DEC}{_SEP}[NSns]|-)"
_LON = rf"(?:[0-9]+{_SEP}[0-9]+{_SEP}{_DEC}{_SEP}[EWew]|-)"
_COL = rf"(?:-?{_DEC}|-)"
_RECORD_RE = re.compile(
    rf"[ \t]*[0-9]{{6}}{_SEP}[0-9]{{6}}{_SEP}{_LAT}{_SEP}{_LON}(?:{_SEP}{_COL}){{6,9}}[ \t]*"
)


def _parse_or_input_error(line: str) -> None:
    try:
        rec = parse_run_line(line, 1, "fuzz.RUN")
    except InputError as err:
        assert (err.file, err.line) == ("fuzz.RUN", 1) and err.field
        assert str(err).startswith(f"fuzz.RUN:1: {err.field}: ")
        return
    if rec is not None:
        _check_valid(rec)
        # Anything accepted is in the grammar (catches float()'s '+5', '5_2', '1e3', '٣' …).
        assert _RECORD_RE.fullmatch(line.rstrip("\r\n")), line


@pytest.mark.parametrize(
    "line", [SAMPLE, _sub("-.2", "-"), _sub("52 50 33.020 N", "-") + " 1.5 - 25.",
             "\t".join(THESIS_RUN_LINES[1].split("\t"))],
)
def test_grammar_of_the_fuzz_accepts_good_records(line: str) -> None:
    # The independent grammar above must accept what it should, or the fuzz proves nothing.
    assert parse_run_line(line) is not None and _RECORD_RE.fullmatch(line)


_FULL = SAMPLE + " 1.5 32768.125 25.40"
_ARABIC_INDIC = str.maketrans("0123456789", "٠١٢٣٤٥٦٧٨٩")
_TOKEN_CHARS = st.sampled_from(
    list("0123456789.-+eE NSEW*_nainf\t") + ["\x00", "٣", "½", "²", "ſ", "\u2003", "\x1c"]
)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=120))
def test_fuzz_arbitrary_text(line: str) -> None:
    _parse_or_input_error(line)


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_fuzz_mutated_lines(data: st.DataObject) -> None:
    toks = data.draw(st.sampled_from([SAMPLE, _FULL])).split()
    for _ in range(data.draw(st.integers(1, 3))):
        k = data.draw(st.integers(0, len(toks) - 1))
        op = data.draw(st.sampled_from(
            ["delete", "duplicate", "replace", "insert_chars", "dash", "float_variant"]))
        if op == "delete" and len(toks) > 1:
            del toks[k]
        elif op == "duplicate":
            toks.insert(k, toks[k])
        elif op == "replace":
            toks[k] = data.draw(st.text(_TOKEN_CHARS, min_size=1, max_size=8))
        elif op == "insert_chars":
            pos = data.draw(st.integers(0, len(toks[k])))
            toks[k] = toks[k][:pos] + data.draw(st.text(_TOKEN_CHARS, max_size=3)) + toks[k][pos:]
        elif op == "float_variant":  # the same number in a spelling float() also reads
            toks[k] = data.draw(st.sampled_from([
                "+" + toks[k], toks[k] + "e0", toks[k].translate(_ARABIC_INDIC),
                toks[k][:1] + "_" + toks[k][1:], toks[k] + "\u2003",
            ]))
        else:
            toks[k] = "-"
    _parse_or_input_error(" ".join(toks))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.text(max_size=60) | st.just(SAMPLE), max_size=20))
def test_fuzz_iter_run_lines_never_raises(lines: list[str]) -> None:
    out = list(iter_run_lines(lines, "fuzz.RUN"))
    numbers = [o.line_no for o in out]
    assert numbers == sorted(numbers) and len(set(numbers)) == len(numbers)
    for o in out:
        if isinstance(o, BadRecord):
            assert o.error.line == o.line_no and o.error.file == "fuzz.RUN"
        else:
            _check_valid(o)


# --------------------------------------------------------------------------- streaming

N_DAY = 86_400


def test_streaming_a_day_in_constant_memory(tmp_path: pathlib.Path) -> None:
    path = tmp_path / "DAY.RUN"
    with open(path, "w", encoding="ascii") as fh:
        fh.write("Date Time GPS lat GPS lon Decca Heading Speed Rudder\n")
        for k in range(N_DAY):
            hh, rest = divmod(k, 3600)
            mm, ss = divmod(rest, 60)
            fh.write(f"920917 {hh:02d}{mm:02d}{ss:02d} 52 50 {k % 60:02d}.020 N "
                     f"004 31 51.134 E .{k % 1000:03d} .325 .109 232.4 12.7 -.2\n")
        fh.write("920917 250000 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2\n")

    tracemalloc.start()
    try:
        good = bad = 0
        last: RunRecord | None = None
        for item in iter_run_file(path):
            if isinstance(item, RunRecord):
                good += 1
                last = item
            else:
                bad += 1
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()

    assert (good, bad) == (N_DAY, 1)
    assert last is not None and last.time == datetime(1992, 9, 17, 23, 59, 59, tzinfo=UTC)
    # A list of all records would hold at least N_DAY × (record object + its raw line)
    # ≈ 86 400 × ~250 B ≈ 20 MB (more with the datetime, tuple and floats). Streaming keeps
    # the peak to the file buffer plus a few records: require < 1 MiB and < 1/20 of the list.
    lower_bound_list = N_DAY * (sys.getsizeof(last) + sys.getsizeof(last.raw))
    assert peak < 1024 * 1024
    assert peak < lower_bound_list / 20
