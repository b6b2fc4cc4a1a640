"""Reader and writer for ``*.RUN`` simulation data files (thesis A8.4, L8971–8985; L5560–5566).

One record per line, whitespace-separated (THEORY §13.3, D40)::

    YYMMDD HHMMSS LAT LON R G P HDG SPD RUD [INCL [PFREQ [ECHO]]]
    920917 083538 52 50 33.020 N 004 31 51.134 E .862 .325 .109 232.4 12.7 -.2

* date/time: UTC; two-digit years 70–99 → 19xx, 00–69 → 20xx.
* LAT ``D M S.sss N|S`` and LON ``D M S.sss E|W`` (4 tokens each): the GPS receiver's WGS84
  position string (thesis L5564).
* R G P: Decca lane fractions of the Red, Green, Purple patterns, in [0, 1) (``.862``).
* HDG gyro heading [deg true, 0–360); SPD EM-log speed through the water [kn, 0–60];
  RUD rudder angle [deg, −90…90, sign only displayed].
* Optional trailing columns (A10): INCL inclinometer [deg, −90…90], PFREQ pressure-sensor
  crystal frequency [Hz, > 0], ECHO echo-sounder depth [m, ≥ 0].
* Optional trailing ``key=value`` tokens (UVNAV 2026, for NMEA 0183 input, docs/NMEA.md) after
  all three optional columns (``-`` when absent), each key at most once: ``hdop=`` GNSS HDOP
  (> 0, ≤ 99.99), ``q=`` GGA fix quality (1–5), ``sats=`` satellites (whole number),
  ``cog=`` course over ground [deg true, 0–360), ``sog=`` speed over ground [kn, 0–200]::

      261202 120000 - - - - - 10.0 5.2 - - - 12.34 hdop=1.20 q=1 sats=7 cog=45.0 sog=6.00

  A 1993 line has none, and the fields stay None.
* Any field whose sensor gave nothing is the single token ``-`` (also for LAT/LON: one ``-``).
* Lines starting with ``*``, blank lines and the A8.4 caption line (``Date Time GPS lat …``)
  are skipped.

Every number is a plain decimal in ASCII digits (:data:`engine.io.operator_input.DECIMAL`), with an
optional ``-`` in the numeric columns (the range checks then reject a negative heading, speed
…); ``+5``, ``5_2``, ``1e3``, ``inf``, ``nan`` and non-ASCII digits are not numbers, although
``float()`` takes them. Fields are separated by spaces or tabs only.

Parsing is per line (``str.split``, one character check of the numeric columns, ``float``; no
regular expression for a good line); :func:`iter_run_file` streams and turns bad lines into
:class:`BadRecord`. A run may hand it a quicker parser of the usual line
(:data:`QuickParser`: the compiled one of ``engine.fast.runfile``), checked against this one.
"""

from __future__ import annotations

import math
import os
import re
import stat
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from datetime import UTC, datetime

from engine.errors import InputError, read_error
from engine.io.deccafile import format_dms, parse_dms

__all__ = [
    "BadRecord",
    "RunRecord",
    "check_input_file",
    "format_run_record",
    "iter_run_file",
    "iter_run_lines",
    "parse_run_line",
]

MAX_SPEED_KN = 60.0
"""Log speeds above this are rejected as implausible [kn]."""


@dataclass(frozen=True, slots=True)
class RunRecord:
    """One parsed ``.RUN`` line (units: degrees, knots, hertz, metres; time tz-aware UTC).

    ``gps_lat_deg``/``gps_lon_deg`` are geodetic WGS84 degrees (south/west negative);
    ``decca`` holds the Red, Green, Purple lane fractions. ``None`` means the sensor gave
    nothing (``-``) or, for ``incl_deg``/``press_freq_hz``/``echo_m``, that the optional
    column is absent: the caller treats an absent column as "sensor not connected"
    (status 2, THEORY D40). ``raw`` is the line without its line ending. The GNSS fields after
    ``raw`` (HDOP, fix quality, satellites, course and speed over ground) come from NMEA 0183
    input (docs/NMEA.md); a 1993 ``.RUN`` line leaves them None.
    """

    line_no: int
    time: datetime
    gps_lat_deg: float | None
    gps_lon_deg: float | None
    decca: tuple[float | None, float | None, float | None]
    heading_deg: float | None
    speed_kn: float | None
    rudder_deg: float | None
    incl_deg: float | None = None
    press_freq_hz: float | None = None
    echo_m: float | None = None
    raw: str = ""
    gps_hdop: float | None = None
    """Horizontal dilution of precision of the GNSS fix (NMEA GGA; None: not given, as in the
    1993 grammar)."""
    gps_quality: int | None = None
    """GGA fix quality of the GNSS position (1 GPS/SPS, 2 DGPS, 3 PPS, 4 RTK fixed, 5 RTK float;
    0/6/7/8 are not fixes and never reach a record); None: not given."""
    gps_sats: int | None = None
    """Satellites used in the GNSS fix (None: not given)."""
    cog_deg: float | None = None
    """Course over ground [deg true, 0–360) from NMEA RMC/VTG (None: not given)."""
    sog_kn: float | None = None
    """Speed over ground [kn] from NMEA RMC/VTG (None: not given)."""


@dataclass(frozen=True, slots=True)
class BadRecord:
    """A line that could not be parsed: its 1-based number, text and the located error."""

    line_no: int
    raw: str
    error: InputError


_NUMERIC_FIELDS = (
    "Decca red", "Decca green", "Decca purple", "heading", "speed", "rudder",
    "inclinometer", "pressure frequency", "echo sounder",
)
_NOT_NUMBER_CHARS = str.maketrans("", "", "0123456789.- ")
"""``text.translate(_NOT_NUMBER_CHARS)`` is what is left after removing the characters of the
numeric columns (ASCII digits, ``.``, ``-``, the joining blank): "" for well-formed columns."""
_NOT_RECORD_CHAR_RE = re.compile(r"[^\t -~]")
"""A character that cannot occur in a record (its line ending removed): not printable ASCII or
tab."""


def _parse_tokens(toks: list[str], n: int, line: str, line_no: int) -> RunRecord:
    """One record's tokens (``n`` of them) to a :class:`RunRecord`, checked field by field."""
    if "=" in line:
        return _parse_with_keys(toks, line, line_no)
    if not 10 <= n <= 19:
        raise InputError(f"Wrong number of fields ({n}) !", field="record", text=line.strip())
    time = _parse_time(toks[0], toks[1])
    lat, lon, i = _parse_gps(toks)
    if not 6 <= n - i <= 9:
        raise InputError(f"Wrong number of fields ({n}) !", field="record", text=line.strip())
    fr_r, fr_g, fr_p, hdg, spd, rud, incl, pfreq, echo = _parse_numbers(toks, i)
    _check_separators(line)
    return RunRecord(
        line_no, time, lat, lon, (fr_r, fr_g, fr_p), hdg, spd, rud, incl, pfreq, echo,
        line.rstrip("\r\n"),
    )


GNSS_KEYS = ("hdop", "q", "sats", "cog", "sog")
"""The optional trailing ``key=value`` tokens, in the order they are written."""
MAX_SOG_KN = 200.0
"""Speeds over ground above this are rejected as implausible [kn]."""
_KEY_FIELDS = {"hdop": "gps_hdop", "q": "gps_quality", "sats": "gps_sats", "cog": "cog_deg",
               "sog": "sog_kn"}


def _parse_with_keys(toks: list[str], line: str, line_no: int) -> RunRecord:
    """A record with trailing ``key=value`` tokens: the columns before them (with all three
    optional columns) and the GNSS values, each key at most once."""
    first = next(i for i, tok in enumerate(toks) if "=" in tok)
    rec = _parse_tokens(toks[:first], first, " ".join(toks[:first]), line_no)
    i = 3 if toks[2] == "-" else 6  # the head parsed, so these tokens exist
    i += 1 if toks[i] == "-" else 4
    if first - i != 9:
        raise InputError("key=value tokens need all nine numeric columns (- when absent) !",
                         field="record", text=toks[first])
    values: dict[str, float | int] = {}
    for tok in toks[first:]:
        key, sep, text = tok.partition("=")
        if key not in _KEY_FIELDS or not sep:
            raise InputError("Unknown key (hdop, q, sats, cog, sog) !", field="record", text=tok)
        if key in values:
            raise InputError("Key given twice !", field=key, text=tok)
        values[key] = _key_value(key, text)
    _check_separators(line)
    return replace(rec, raw=line.rstrip("\r\n"),
                   **{_KEY_FIELDS[k]: v for k, v in values.items()})  # type: ignore[arg-type]


def _key_value(key: str, text: str) -> float | int:
    """One ``key=value`` value, range-checked (the field named by the key)."""
    if key in ("q", "sats"):
        if not (text.isascii() and text.isdigit()) or len(text) > 3:
            raise InputError("Not a whole number !", field=key, text=text)
        number = int(text)
        if key == "q" and not 1 <= number <= 5:
            raise InputError("Fix quality must be 1 to 5 !", field=key, text=text)
        return number
    if not text or text.translate(_NOT_NUMBER_CHARS) or text.count("-") > (text[0] == "-"):
        raise InputError("Not a number !", field=key, text=text)
    try:
        value = float(text)
    except ValueError:
        raise InputError("Not a number !", field=key, text=text) from None
    if key == "hdop" and not (0.0 < value <= 99.99):
        raise InputError("HDOP must be > 0 and <= 99.99 !", field=key, text=text)
    if key == "cog" and not 0.0 <= value < 360.0:
        raise InputError("Course must be in [0, 360) degrees !", field=key, text=text)
    if key == "sog" and not 0.0 <= value <= MAX_SOG_KN:
        raise InputError(f"Speed over ground must be in [0, {MAX_SOG_KN:.0f}] knots !",
                         field=key, text=text)
    return value


def _parse_time(d: str, t: str) -> datetime:
    """Date ``YYMMDD`` and time ``HHMMSS`` (UTC; years 70–99 → 19xx, 00–69 → 20xx)."""
    if len(d) != 6 or not (d.isascii() and d.isdigit()):
        raise InputError("Wrong date (YYMMDD) !", field="date", text=d)
    if len(t) != 6 or not (t.isascii() and t.isdigit()):
        raise InputError("Wrong time (HHMMSS) !", field="time", text=t)
    yy, mmdd = divmod(int(d), 10000)
    month, day = divmod(mmdd, 100)
    hh, mmss = divmod(int(t), 10000)
    minute, second = divmod(mmss, 100)
    if hh > 23 or minute > 59 or second > 59:
        raise InputError("Wrong time (HHMMSS) !", field="time", text=t)
    try:
        return datetime(
            yy + (1900 if yy >= 70 else 2000), month, day, hh, minute, second, tzinfo=UTC
        )
    except ValueError:
        raise InputError("Wrong date (YYMMDD) !", field="date", text=d) from None


def _parse_gps(toks: list[str]) -> tuple[float | None, float | None, int]:
    """GPS latitude and longitude [deg] (one ``-`` or four tokens each) from ``toks[2]`` on,
    and the index of the first numeric column."""
    if toks[2] == "-":
        lat = None
        i = 3
    else:
        lat = parse_dms(toks[2], toks[3], toks[4], toks[5], True, "GPS latitude")
        i = 6
    if toks[i] == "-":
        lon = None
        i += 1
    else:
        lon = parse_dms(toks[i], toks[i + 1], toks[i + 2], toks[i + 3], False, "GPS longitude")
        i += 4
    return lat, lon, i


def _parse_numbers(toks: list[str], i: int) -> list[float | None]:
    """The 6 to 9 numeric columns from ``toks[i]`` on, range-checked, padded with None to 9.

    Over the characters 0-9 . - float() accepts exactly the grammar's numbers (-?DECIMAL), so
    one character check of all columns plus float() is the strict grammar (float alone would
    take '+5', '5_2', '1e3', 'inf', non-ASCII digits); lean hot path.
    """
    cols = toks[i:]
    if " ".join(cols).translate(_NOT_NUMBER_CHARS):
        for k, tok in enumerate(cols):
            if tok.translate(_NOT_NUMBER_CHARS):
                raise InputError("Not a number !", field=_NUMERIC_FIELDS[k], text=tok)
    values: list[float | None] = []
    for k, tok in enumerate(cols):
        try:
            values.append(None if tok == "-" else float(tok))
        except ValueError:
            raise InputError("Not a number !", field=_NUMERIC_FIELDS[k], text=tok) from None
    values += [None] * (9 - len(values))
    _check_ranges(values, cols)
    return values


def _check_ranges(v: list[float | None], cols: list[str]) -> None:
    """Range checks of the numeric columns (NaN fails every comparison, so it is rejected)."""
    fr_r, fr_g, fr_p, hdg, spd, rud, incl, pfreq, echo = v
    if fr_r is not None and not 0.0 <= fr_r < 1.0:
        raise InputError("Decca fraction must be in [0, 1) !", field="Decca red", text=cols[0])
    if fr_g is not None and not 0.0 <= fr_g < 1.0:
        raise InputError("Decca fraction must be in [0, 1) !", field="Decca green", text=cols[1])
    if fr_p is not None and not 0.0 <= fr_p < 1.0:
        raise InputError("Decca fraction must be in [0, 1) !", field="Decca purple", text=cols[2])
    if hdg is not None and not 0.0 <= hdg < 360.0:
        raise InputError("Heading must be in [0, 360) degrees !", field="heading", text=cols[3])
    if spd is not None and not 0.0 <= spd <= MAX_SPEED_KN:
        raise InputError("Speed must be in [0, 60] knots !", field="speed", text=cols[4])
    if rud is not None and not -90.0 <= rud <= 90.0:
        raise InputError(
            "Rudder angle must be in [-90, 90] degrees !", field="rudder", text=cols[5]
        )
    if incl is not None and not -90.0 <= incl <= 90.0:
        raise InputError(
            "Inclination must be in [-90, 90] degrees !", field="inclinometer", text=cols[6]
        )
    if pfreq is not None and not (pfreq > 0.0 and math.isfinite(pfreq)):
        raise InputError(
            "Pressure frequency must be > 0 Hz !", field="pressure frequency", text=cols[7]
        )
    if echo is not None and not (echo >= 0.0 and math.isfinite(echo)):
        raise InputError("Echo depth must be >= 0 m !", field="echo sounder", text=cols[8])


def _check_separators(line: str) -> None:
    """Every token is valid ASCII by now, so anything else is a separator ``str.split()`` took
    (a Unicode blank, form feed, U+001C …): the grammar allows spaces and tabs only."""
    body = line.rstrip("\r\n")
    if not (body.isascii() and (body.isprintable() or body.replace("\t", " ").isprintable())):
        odd = _NOT_RECORD_CHAR_RE.search(body)
        raise InputError(
            "Fields must be separated by spaces or tabs !",
            field="record", text=odd.group() if odd is not None else body,
        )


def parse_run_line(line: str, line_no: int = 0, filename: str = "<string>") -> RunRecord | None:
    """Parse one ``.RUN`` line (grammar in the module docstring).

    Returns ``None`` for a blank, comment (``*``) or caption (``Date Time …``) line. Raises
    ``InputError`` naming ``filename``, ``line_no`` and the field (``record``, ``date``,
    ``time``, ``GPS latitude``, ``GPS longitude``, ``Decca red|green|purple``, ``heading``,
    ``speed``, ``rudder``, ``inclinometer``, ``pressure frequency``, ``echo sounder``).
    """
    toks = line.split()
    n = len(toks)
    if n == 0:
        return None
    first = toks[0]
    if first[0] == "*" or (first[0] in "Dd" and first.lower() == "date"):
        return None
    try:
        return _parse_tokens(toks, n, line, line_no)
    except InputError as exc:
        raise exc.located(file=filename, line=line_no) from None


MAX_LINE_CHARS = 4096
"""Longest ``.RUN`` line read (a record is under 200 characters); a longer one is a bad record
whose text is not kept, so one huge line cannot fill the memory."""
LINE_TOO_LONG_MESSAGE = f"Line too long (more than {MAX_LINE_CHARS} characters) !"
RAW_KEPT_CHARS = 80
"""Characters of an over-long line kept as its ``raw`` text."""


def _parse_one(line: str, line_no: int, filename: str) -> RunRecord | BadRecord | None:
    try:
        return parse_run_line(line, line_no, filename)
    except InputError as exc:
        return BadRecord(line_no, line.rstrip("\r\n"), exc)


def iter_run_lines(
    lines: Iterable[str], filename: str = "<string>"
) -> Iterator[RunRecord | BadRecord]:
    """Parse lines lazily (line numbers from 1); a bad line gives a :class:`BadRecord`.

    Never raises ``InputError``, so a replay does not stop on a bad line.
    """
    for line_no, line in enumerate(lines, 1):
        item = _parse_one(line, line_no, filename)
        if item is not None:
            yield item


QuickParser = Callable[[str, int], "RunRecord | None"]
"""A parser of the usual record tried before the checked one: ``quick(line, line_no)`` gives
the record :func:`parse_run_line` gives for that line, or None for any line it leaves to it
(a comment, a ``key=value`` record, a bad line: every message stays the checked parser's).
The run loop passes the compiled one (``engine.fast.runfile``) where it is in use."""


def iter_run_file(path: str | os.PathLike[str],
                  quick: QuickParser | None = None) -> Iterator[RunRecord | BadRecord]:
    """Stream the records of a ``.RUN`` file, reading one line at a time (constant memory).

    The file is checked when this is called (opened and closed), so a missing, unreadable or
    non-regular file is an ``InputError`` before anything runs
    (:func:`~engine.errors.read_error`); it is opened on the first ``next()`` and closed when
    the iterator is exhausted or closed. Undecodable bytes become U+FFFD (so the line is
    reported as bad, never crashes the replay); a line over :data:`MAX_LINE_CHARS` characters
    is a bad record. ``quick``: a :data:`QuickParser` tried first on each line (None: every
    line through :func:`parse_run_line`).
    """
    name = check_input_file(path)
    return _stream(name, quick)


def check_input_file(path: str | os.PathLike[str]) -> str:
    """The name of a readable regular input file (``.RUN`` or NMEA log), checked now: a
    missing, unreadable or non-regular file (a device, a pipe) is an ``InputError``
    (:func:`~engine.errors.read_error`)."""
    name = os.fspath(path)
    if "\0" in name:
        raise InputError("A path cannot contain a NUL character !", file=name)
    try:
        if not stat.S_ISDIR(mode := os.stat(name).st_mode) and not stat.S_ISREG(mode):
            raise InputError("Not a regular file (a device or pipe) !", file=name)
        with open(name, "rb"):  # readable now (reopened, and closed again, by the stream)
            pass
    except OSError as exc:
        raise read_error(exc, name) from None
    return name


def _stream(name: str, quick: QuickParser | None) -> Iterator[RunRecord | BadRecord]:
    with open(name, encoding="utf-8-sig", errors="replace") as fh:
        line_no = 0
        readline = fh.readline
        limit = MAX_LINE_CHARS + 1
        while line := readline(limit):
            line_no += 1
            if len(line) < limit:  # a whole line (or the last one)
                if quick is not None and (rec := quick(line, line_no)) is not None:
                    yield rec
                    continue
            elif not line.endswith("\n"):
                raw = line[:RAW_KEPT_CHARS] + "…"
                while line and not line.endswith("\n"):  # skip the rest, a chunk at a time
                    line = fh.readline(1 << 16)
                yield BadRecord(line_no, raw, InputError(
                    LINE_TOO_LONG_MESSAGE, file=name, line=line_no, field="record"))
                continue
            item = _parse_one(line, line_no, name)
            if item is not None:
                yield item


# --------------------------------------------------------------------------- writer


def _strip0(text: str) -> str:
    """Drop the leading zero of a magnitude below 1, as the thesis prints: 0.2 → .2, -0.2 → -.2."""
    if text.startswith("0."):
        return text[1:]
    if text.startswith("-0."):
        return "-" + text[2:]
    return text


def _opt(value: float | None, spec: str) -> str:
    return "-" if value is None else _strip0(format(value, spec))


def _fraction(value: float | None) -> str:
    if value is None:
        return "-"
    text = f"{value:.3f}"
    if text == "1.000":  # 0.9995 ≤ v < 1 would round out of [0, 1): clamp to the last step
        text = "0.999"
    return _strip0(text)


def _heading(value: float | None) -> str:
    if value is None:
        return "-"
    text = f"{value:.1f}"
    if text == "360.0":  # 359.95 ≤ v < 360 wraps to north
        text = "0.0"
    return _strip0(text)


def format_run_record(rec: RunRecord) -> str:
    """One ``.RUN`` line in the thesis layout, single-space separated (no line ending).

    Precision: seconds of arc 0.001″, fractions 0.001 lane (≥ .9995 clamped to .999), heading,
    speed and rudder 0.1 (heading 359.95+ wraps to 0.0), inclination 0.01°, pressure frequency
    0.001 Hz, echo depth 0.01 m. Optional columns are written up to the last present one,
    with ``-`` for a ``None`` before it.
    """
    t = rec.time.astimezone(UTC) if rec.time.tzinfo is not None else rec.time
    parts = [
        f"{t.year % 100:02d}{t.month:02d}{t.day:02d}",
        f"{t.hour:02d}{t.minute:02d}{t.second:02d}",
        "-" if rec.gps_lat_deg is None else format_dms(rec.gps_lat_deg, True),
        "-" if rec.gps_lon_deg is None else format_dms(rec.gps_lon_deg, False),
        _fraction(rec.decca[0]),
        _fraction(rec.decca[1]),
        _fraction(rec.decca[2]),
        _heading(rec.heading_deg),
        _opt(rec.speed_kn, ".1f"),
        _opt(rec.rudder_deg, ".1f"),
    ]
    optional = [
        _opt(rec.incl_deg, ".2f"),
        _opt(rec.press_freq_hz, ".3f"),
        _opt(rec.echo_m, ".2f"),
    ]
    keys = _key_tokens(rec)
    if not keys:
        while optional and optional[-1] == "-":
            optional.pop()
    return " ".join(parts + optional + keys)


def _key_tokens(rec: RunRecord) -> list[str]:
    """The ``key=value`` tokens of the GNSS values that are present (order of GNSS_KEYS)."""
    out = []
    if rec.gps_hdop is not None:
        out.append(f"hdop={rec.gps_hdop:.2f}")
    if rec.gps_quality is not None:
        out.append(f"q={rec.gps_quality:d}")
    if rec.gps_sats is not None:
        out.append(f"sats={rec.gps_sats:d}")
    if rec.cog_deg is not None:
        text = f"{rec.cog_deg:.1f}"
        out.append(f"cog={'0.0' if text == '360.0' else text}")
    if rec.sog_kn is not None:
        out.append(f"sog={rec.sog_kn:.2f}")
    return out
