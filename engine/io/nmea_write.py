"""Writing NMEA 0183 sentences: the checksum, the number formats and one helper per sentence.

Every helper returns one sentence ``$TTKKK,f1,f2,…*HH`` without a line ending (the caller adds
``\\r\\n``, as NMEA 0183 §5.3 prescribes on the wire, or ``\\n`` in a log file). ``HH`` is the
XOR of every byte between ``$`` and ``*``, in two upper-case hexadecimal digits.

Formats (docs/NMEA_OUT.md "Formats"):

* latitude ``ddmm.mmmm`` and longitude ``dddmm.mmmm`` with ``N``/``S``, ``E``/``W``: four
  decimals of a minute by default, a step of 1e-4′ = 0.185 m in latitude (≤ 0.185 m in
  longitude), so the rounding error is at most 0.093 m, far below any position UVNAV sends
  (GNSS noise of metres, filter σ of metres to kilometres) yet inside the 82 characters of a
  sentence with every GGA field filled. The value is rounded once, in whole steps of the last
  decimal, so 59.99995′ carries into the next degree (``5300.0000``, never ``5259.10000``
  or ``5260.0000``);
* time ``hhmmss.ss`` (UTC, 0.01 s) and date ``ddmmyy``: the time is rounded to the 0.01 s
  first and both fields come from the rounded instant, so 23:59:59.996 on 31 Dec writes
  ``000000.00`` and the next day's date;
* headings and courses in degrees true with one decimal, in [0, 360) (359.96° → ``0.0``);
  speeds in knots with one decimal (km/h in VHW/VTG derived from the knots: 1 kn = 1.852 km/h);
  depths in metres with one decimal, feet (0.3048 m) and fathoms (1.8288 m) derived from them.

``None`` for a value writes an empty field (``$IIHDT,,T*0C`` is "no heading", not zero).
A value out of range (a latitude beyond ±90°, a negative speed, a NaN, a quality code beyond
0–8) is a programming error, not input: :class:`ValueError`.
"""

from __future__ import annotations

import math
import re
from datetime import UTC, datetime, timedelta

__all__ = [
    "MAX_SENTENCE_CHARS",
    "checksum",
    "dbt",
    "format_date",
    "format_lat",
    "format_lon",
    "format_time",
    "gga",
    "gll",
    "gst",
    "hdt",
    "rmc",
    "round_time",
    "sentence",
    "vhw",
    "vtg",
    "zda",
]

MAX_SENTENCE_CHARS = 80
"""Longest sentence without its ``\\r\\n`` (NMEA 0183: 82 characters including them)."""

KMH_PER_KN = 1.852
"""Kilometres per hour in one knot (1 international nautical mile = 1852 m)."""
FEET_PER_M = 1.0 / 0.3048
"""Feet in one metre (international foot 0.3048 m)."""
FATHOMS_PER_M = 1.0 / 1.8288
"""Fathoms in one metre (1 fathom = 6 ft = 1.8288 m)."""

_BAD_FIELD = re.compile(r"[^\x20-\x7e]|[$!*,\\^~]")
"""A character that may not appear in a field: not printable ASCII, or a delimiter or reserved
character (NMEA 0183 §5.1.3)."""
_TALKER = re.compile(r"[A-Z0-9]{2}")
_KIND = re.compile(r"[A-Z]{3}")


def checksum(body: str) -> str:
    """The NMEA checksum of ``body`` (the text between ``$`` and ``*``): XOR of its bytes as two
    upper-case hexadecimal digits."""
    value = 0
    for byte in body.encode("ascii"):
        value ^= byte
    return f"{value:02X}"


def sentence(talker: str, kind: str, fields: list[str]) -> str:
    """``$`` + talker + kind + ``,``-joined fields + ``*HH``, no line ending.

    ``talker`` is two upper-case letters or digits (``GP``, ``IN``, ``HE``), ``kind`` three
    upper-case letters (``GGA``). Raises ValueError for a bad talker or kind, a field holding a
    delimiter or non-printable character, or a sentence longer than :data:`MAX_SENTENCE_CHARS`.
    """
    if _TALKER.fullmatch(talker) is None:
        raise ValueError(f"talker must be two upper-case letters or digits (got {talker!r})")
    if _KIND.fullmatch(kind) is None:
        raise ValueError(f"sentence kind must be three upper-case letters (got {kind!r})")
    for text in fields:
        if _BAD_FIELD.search(text) is not None:
            raise ValueError(f"NMEA field holds a reserved or non-printable character: {text!r}")
    body = ",".join([talker + kind, *fields])
    out = f"${body}*{checksum(body)}"
    if len(out) > MAX_SENTENCE_CHARS:
        raise ValueError(f"sentence longer than {MAX_SENTENCE_CHARS} characters: {out!r}")
    return out


# --------------------------------------------------------------------------------------------
# Number formats


def _finite(value: float, name: str) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number (got {value!r})")
    return value


def _steps(value: float, decimals: int) -> int:
    """``value`` in whole steps of 10^-decimals, rounded half away from zero (value ≥ 0)."""
    return math.floor(value * 10**decimals + 0.5)


def _fixed(steps: int, decimals: int) -> str:
    """Whole steps of 10^-decimals as fixed-point text (steps ≥ 0)."""
    if decimals == 0:
        return str(steps)
    whole, frac = divmod(steps, 10**decimals)
    return f"{whole}.{frac:0{decimals}d}"


def _angle_minutes(value_deg: float, deg_digits: int, decimals: int) -> str:
    """|value| as ``d…dmm.m…m`` with ``deg_digits`` degree digits, rounded once in whole steps
    of 10^-decimals minutes so that 59.99995′ carries into the degree."""
    if not 1 <= decimals <= 7:
        raise ValueError(f"minute decimals must be 1–7 (got {decimals})")
    per_deg = 60 * 10**decimals
    steps = _steps(abs(value_deg) * 60.0, decimals)
    deg, minute_steps = divmod(steps, per_deg)
    return f"{deg:0{deg_digits}d}{_fixed(minute_steps, decimals).zfill(3 + decimals)}"


def format_lat(lat_deg: float, decimals: int = 4) -> tuple[str, str]:
    """Geodetic latitude (degrees, north positive) → (``ddmm.mmmm``, ``N``|``S``).

    A value that rounds to zero is ``N``; ±90° is the pole. Raises ValueError beyond ±90°.
    """
    lat = _finite(lat_deg, "latitude")
    if abs(lat) > 90.0:
        raise ValueError(f"latitude beyond ±90° (got {lat!r})")
    text = _angle_minutes(lat, 2, decimals)
    south = lat < 0.0 and _steps(abs(lat) * 60.0, decimals) > 0
    return text, "S" if south else "N"


def format_lon(lon_deg: float, decimals: int = 4) -> tuple[str, str]:
    """Geodetic longitude (degrees, east positive, any turn) → (``dddmm.mmmm``, ``E``|``W``).

    Normalised to (−180°, 180°] first; 180° is written ``18000.0000,E`` (and a value rounding to
    180° W too, so the two meridians never differ by a sign). A value rounding to zero is ``E``.
    """
    lon = _finite(lon_deg, "longitude")
    lon = math.remainder(lon, 360.0)  # [-180, 180]
    steps = _steps(abs(lon) * 60.0, decimals)
    if steps >= 180 * 60 * 10**decimals:
        lon = 180.0
    text = _angle_minutes(lon, 3, decimals)
    west = lon < 0.0 and steps > 0
    return text, "W" if west else "E"


def round_time(t: datetime, decimals: int = 2) -> datetime:
    """``t`` in UTC (a naive datetime is taken as UTC) rounded to 10^-decimals s, with carry into
    the minute, hour and date."""
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    t = t.astimezone(UTC)
    unit_us = 10 ** (6 - decimals)
    us = t.microsecond
    rounded = (us + unit_us // 2) // unit_us * unit_us
    return t.replace(microsecond=0) + timedelta(microseconds=rounded)


def format_time(t: datetime, decimals: int = 2) -> str:
    """UTC time of day ``hhmmss.ss`` of an already rounded ``t`` (:func:`round_time`)."""
    t = round_time(t, decimals)
    sec_steps = t.second * 10**decimals + t.microsecond // 10 ** (6 - decimals)
    return f"{t.hour:02d}{t.minute:02d}{_fixed(sec_steps, decimals).zfill(3 + decimals)}"


def format_date(t: datetime, decimals: int = 2) -> str:
    """UTC date ``ddmmyy`` of ``t`` after rounding the time to 10^-decimals s."""
    t = round_time(t, decimals)
    return f"{t.day:02d}{t.month:02d}{t.year % 100:02d}"


def _opt(value: float | None, decimals: int, name: str, *, minimum: float | None = 0.0,
         maximum: float | None = None) -> str:
    """A number with ``decimals`` decimals or an empty field for None (range-checked)."""
    if value is None:
        return ""
    v = _finite(value, name)
    if (minimum is not None and v < minimum) or (maximum is not None and v > maximum):
        raise ValueError(f"{name} out of range [{minimum}, {maximum}] (got {v!r})")
    text = f"{v:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def _bearing(value_deg: float | None, name: str) -> str:
    """Degrees true in [0, 360) with one decimal (359.96 → ``0.0``), or empty for None."""
    if value_deg is None:
        return ""
    steps = _steps(_finite(value_deg, name) % 360.0, 1) % 3600
    return _fixed(steps, 1)


def _latlon_fields(lat_deg: float | None, lon_deg: float | None, decimals: int) -> list[str]:
    if lat_deg is None or lon_deg is None:
        return ["", "", "", ""]
    return [*format_lat(lat_deg, decimals), *format_lon(lon_deg, decimals)]


# --------------------------------------------------------------------------------------------
# Sentences

GGA_QUALITY = {
    0: "invalid", 1: "GPS fix (SPS)", 2: "DGPS fix", 3: "PPS fix", 4: "RTK fixed",
    5: "RTK float", 6: "estimated (dead reckoning)", 7: "manual input", 8: "simulation",
}
"""GGA fix-quality codes (NMEA 0183 v2.3+)."""

MODES = {"A": "autonomous", "D": "differential", "E": "estimated (dead reckoning)",
         "M": "manual input", "S": "simulator", "N": "data not valid"}
"""Mode indicators of RMC, GLL and VTG (NMEA 0183 v2.3+)."""


def _mode(mode: str) -> str:
    if mode not in MODES:
        raise ValueError(f"mode indicator must be one of {''.join(MODES)} (got {mode!r})")
    return mode


def gga(
    time: datetime,
    lat_deg: float | None,
    lon_deg: float | None,
    *,
    quality: int,
    sats: int | None,
    hdop: float | None,
    altitude_m: float | None = None,
    geoid_sep_m: float | None = None,
    talker: str = "GP",
    decimals: int = 4,
) -> str:
    """GGA, fix data: UTC time, position (WGS84 degrees), ``quality`` (0–8, :data:`GGA_QUALITY`),
    satellites used (0–99, two digits), HDOP (one decimal), antenna altitude above mean sea level
    and geoid separation (m, one decimal; empty when None); the DGPS age and station are empty."""
    if not 0 <= quality <= 8:
        raise ValueError(f"GGA quality must be 0–8 (got {quality!r})")
    if sats is not None and not 0 <= sats <= 99:
        raise ValueError(f"satellites must be 0–99 (got {sats!r})")
    return sentence(talker, "GGA", [
        format_time(time),
        *_latlon_fields(lat_deg, lon_deg, decimals),
        str(quality),
        "" if sats is None else f"{sats:02d}",
        _opt(hdop, 1, "HDOP", maximum=99.9),
        _opt(altitude_m, 1, "altitude", minimum=None),
        "" if altitude_m is None else "M",
        _opt(geoid_sep_m, 1, "geoid separation", minimum=None),
        "" if geoid_sep_m is None else "M",
        "",
        "",
    ])


def rmc(
    time: datetime,
    lat_deg: float | None,
    lon_deg: float | None,
    *,
    sog_kn: float | None,
    cog_deg: float | None,
    valid: bool = True,
    mode: str = "A",
    variation_deg: float | None = None,
    talker: str = "GP",
    decimals: int = 4,
) -> str:
    """RMC, recommended minimum: UTC time, status ``A`` (``valid``) or ``V``, position (WGS84),
    speed over ground (kn) and course over ground (degrees true), date ``ddmmyy``, magnetic
    variation (degrees, east positive; empty when None) and the mode indicator (:data:`MODES`)."""
    var_text = var_dir = ""
    if variation_deg is not None:
        v = _finite(variation_deg, "variation")
        var_text = _opt(abs(v), 1, "variation", maximum=180.0)
        var_dir = "W" if v < 0.0 and float(var_text) > 0.0 else "E"
    return sentence(talker, "RMC", [
        format_time(time),
        "A" if valid else "V",
        *_latlon_fields(lat_deg, lon_deg, decimals),
        _opt(sog_kn, 1, "speed over ground"),
        _bearing(cog_deg, "course over ground"),
        format_date(time),
        var_text,
        var_dir,
        _mode(mode),
    ])


def gll(
    time: datetime,
    lat_deg: float | None,
    lon_deg: float | None,
    *,
    valid: bool = True,
    mode: str = "A",
    talker: str = "GP",
    decimals: int = 4,
) -> str:
    """GLL, geographic position: position (WGS84), UTC time, status ``A``/``V``, mode."""
    return sentence(talker, "GLL", [
        *_latlon_fields(lat_deg, lon_deg, decimals),
        format_time(time),
        "A" if valid else "V",
        _mode(mode),
    ])


def gst(
    time: datetime,
    *,
    rms_m: float | None,
    major_sigma_m: float | None,
    minor_sigma_m: float | None,
    major_az_deg: float | None,
    lat_sigma_m: float | None,
    lon_sigma_m: float | None,
    alt_sigma_m: float | None = None,
    talker: str = "GP",
) -> str:
    """GST, position error statistics (1 σ, metres): RMS of the range residuals, semi-major and
    semi-minor axis of the error ellipse, orientation of the major axis (degrees from true
    north), σ of latitude, longitude and altitude (empty when None). Two decimals, so a
    centimetre ellipse is not written as zero."""
    az = None if major_az_deg is None else _finite(major_az_deg, "orientation") % 180.0
    return sentence(talker, "GST", [
        format_time(time),
        _opt(rms_m, 2, "RMS"),
        _opt(major_sigma_m, 2, "semi-major σ"),
        _opt(minor_sigma_m, 2, "semi-minor σ"),
        _opt(az, 1, "orientation", maximum=180.0),
        _opt(lat_sigma_m, 2, "latitude σ"),
        _opt(lon_sigma_m, 2, "longitude σ"),
        _opt(alt_sigma_m, 2, "altitude σ"),
    ])


def hdt(heading_deg: float | None, *, talker: str = "HE") -> str:
    """HDT, heading true (degrees, one decimal, [0, 360)); ``None`` = no heading (``,,T``)."""
    return sentence(talker, "HDT", [_bearing(heading_deg, "heading"), "T"])


def vhw(
    heading_true_deg: float | None,
    speed_kn: float | None,
    *,
    heading_mag_deg: float | None = None,
    talker: str = "VW",
) -> str:
    """VHW, water speed and heading: heading true and magnetic (degrees), speed through the
    water in knots and km/h (one decimal; the km/h from the knots, × 1.852)."""
    kmh = None if speed_kn is None else _finite(speed_kn, "speed") * KMH_PER_KN
    return sentence(talker, "VHW", [
        _bearing(heading_true_deg, "heading"), "T",
        _bearing(heading_mag_deg, "magnetic heading"), "M",
        _opt(speed_kn, 1, "speed through water"), "N",
        _opt(kmh, 1, "speed through water"), "K",
    ])


def vtg(
    cog_deg: float | None,
    sog_kn: float | None,
    *,
    cog_mag_deg: float | None = None,
    mode: str = "A",
    talker: str = "GP",
) -> str:
    """VTG, course and speed over ground: course true and magnetic (degrees), speed in knots and
    km/h (one decimal), mode indicator."""
    kmh = None if sog_kn is None else _finite(sog_kn, "speed") * KMH_PER_KN
    return sentence(talker, "VTG", [
        _bearing(cog_deg, "course over ground"), "T",
        _bearing(cog_mag_deg, "magnetic course"), "M",
        _opt(sog_kn, 1, "speed over ground"), "N",
        _opt(kmh, 1, "speed over ground"), "K",
        _mode(mode),
    ])


def dbt(depth_m: float | None, *, talker: str = "SD") -> str:
    """DBT, depth below transducer: feet, metres and fathoms (one decimal each, all from the
    metres given); empty fields for None."""
    if depth_m is None:
        return sentence(talker, "DBT", ["", "f", "", "M", "", "F"])
    d = _finite(depth_m, "depth")
    return sentence(talker, "DBT", [
        _opt(d * FEET_PER_M, 1, "depth"), "f",
        _opt(d, 1, "depth"), "M",
        _opt(d * FATHOMS_PER_M, 1, "depth"), "F",
    ])


def zda(time: datetime, *, talker: str = "GP") -> str:
    """ZDA, time and date: UTC ``hhmmss.ss``, day, month, four-digit year (all from the time
    rounded to 0.01 s) and the local zone ``00,00`` (UVNAV works in UTC)."""
    t = round_time(time)
    return sentence(talker, "ZDA", [
        format_time(t), f"{t.day:02d}", f"{t.month:02d}", f"{t.year:04d}", "00", "00",
    ])
