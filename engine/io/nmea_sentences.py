"""One NMEA 0183 line → typed sentence values or a classified skip (docs/NMEA.md "Input").

:func:`parse_nmea_line` never raises for any text: framing, the ``*hh`` checksum (verified,
``pynmea2.parse(line, check=True)``), the talker and the sentence type come from ``pynmea2``;
the fields are then read by name from the parsed sentence and checked strictly here (pynmea2
turns an empty latitude into 0.0 and takes ``float('nan')``, so its numeric properties are not
used). Any talker is accepted (``GP``, ``GN``, ``GL``, ``II``, ``HE``, ``SD``, ``VW`` …).

Sentences used and what they give (units: degrees, knots, metres, seconds of the UTC day):

* GGA: time, position (fix quality, HDOP, satellites); quality 0/6/7/8 (or anything but
  1–5) is *not a fix*.
* RMC: time, date, position, course and speed over ground (true course); status ``V`` or an
  FAA mode ``N``/``E``/``M``/``S`` is *not a fix*.
* GLL: time and position; status ``V`` or mode ``N``/``E``/``M``/``S`` is *not a fix*.
* ZDA: time and date (time only when the date fields are all empty).
* HDT: true heading. HDG: magnetic sensor heading + deviation + variation = true heading
  (without a variation, ``variation_deg`` is used, else the magnetic heading is returned for
  the epoch builder to make true). RMC's magnetic variation is returned too.
* VHW: heading (true, else magnetic + variation, else magnetic for the epoch builder) and
  speed through the water (knots, else km/h converted). VBW: longitudinal speed through the
  water when its status is ``A``.
* VTG: true course and speed over ground (knots, else km/h); FAA mode ``N`` is not valid.
* DBT: depth below the transducer (metres, else feet, else fathoms); DPT: depth below the
  transducer (its offset is not applied).

A sentence whose fix is invalid gives no position; it is a skip of kind *not a fix* that carries
its time (and RMC's date), which the epoch builder uses only once the log has had a valid fix
(docs/NMEA.md).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from datetime import date
from functools import reduce
from operator import xor
from typing import Any

__all__ = [
    "NmeaValues",
    "SkipKind",
    "SentenceSkip",
    "USED_TYPES",
    "parse_nmea_line",
]

KMH_TO_KN = 1.0 / 1.852
"""km/h → knots (1 international nautical mile = 1852 m)."""
FEET_TO_M = 0.3048
FATHOMS_TO_M = 1.8288
MAX_SENTENCE_CHARS = 200
"""Longest line taken as a sentence (NMEA 0183 allows 82 characters; some devices exceed it);
longer lines are malformed."""

USED_TYPES = ("GGA", "RMC", "GLL", "ZDA", "HDT", "HDG", "VHW", "VBW", "VTG", "DBT", "DPT")
"""Sentence types whose values are used."""


class SkipKind:
    """Why a line gave nothing (the summary counts each kind; docs/NMEA.md)."""

    BAD_CHECKSUM = "bad checksum"
    NO_CHECKSUM = "no checksum"
    MALFORMED = "truncated/malformed"
    UNKNOWN = "unknown/unused sentence type"
    NOISE = "binary noise/non-ASCII"
    AIS = "AIS/encapsulated (!)"
    EMPTY = "empty fields"
    NOT_FIX = "not a fix"
    NOT_TEXT = "not a sentence"

    REPORTED = (BAD_CHECKSUM, NO_CHECKSUM, MALFORMED, NOISE, NOT_TEXT)
    """Kinds that are damage (``BAD`` lines of the .OUT log); the others are normal in a log
    and only counted."""


@dataclass(frozen=True, slots=True)
class SentenceSkip:
    """A line that gave no value: its kind (:class:`SkipKind`), the sentence type if known
    (``"GSV"``) and a message for the report."""

    kind: str
    message: str
    sentence_type: str | None = None
    time_s: float | None = None
    """Time of day [s] of a *not a fix* GGA/RMC/GLL (None otherwise)."""
    date: date | None = None
    """Date of a *not a fix* RMC (None otherwise)."""


@dataclass(frozen=True, slots=True)
class NmeaValues:
    """What one sentence gave (None: not in this sentence). Angles in degrees (true),
    speeds in knots, depth in metres, time as seconds of the UTC day."""

    sentence_type: str
    talker: str
    time_s: float | None = None
    date: date | None = None
    lat_deg: float | None = None
    lon_deg: float | None = None
    quality: int | None = None
    hdop: float | None = None
    sats: int | None = None
    heading_deg: float | None = None
    stw_kn: float | None = None
    cog_deg: float | None = None
    sog_kn: float | None = None
    depth_m: float | None = None
    magnetic_deg: float | None = None
    """A magnetic heading (sensor + deviation) the sentence gave without a variation and none
    was configured: the epoch builder makes it true with the log's or the model's variation
    (docs/NMEA.md "Magnetic headings")."""
    variation_deg: float | None = None
    """The magnetic variation [deg, east positive] the sentence carries (HDG, RMC)."""
    notes: tuple[str, ...] = field(default=())
    """Parts of the sentence that were not used and why (e.g. ``HDG without variation: not
    used``)."""


_NUMBER_RE = re.compile(r"-?(?:\d+\.?\d*|\.\d+)\Z")
_TIME_RE = re.compile(r"(\d\d)(\d\d)(\d\d)(\.\d*)?\Z")
_LAT_RE = re.compile(r"(\d\d)(\d\d(?:\.\d*)?)\Z")
_LON_RE = re.compile(r"(\d\d\d)(\d\d(?:\.\d*)?)\Z")
_FRAME_RE = re.compile(r"\$[A-Z0-9]{5},[\x20-\x7e]*\*[0-9A-Fa-f]{2}\Z")
_PROPRIETARY_RE = re.compile(r"\$(P[A-Z0-9]{3,9})[,*]")
"""A proprietary sentence: its address field is ``P``, the maker's three-character mnemonic
and the maker's own sentence type (``PGRMZ``, ``PNCTR``, ``PMTK001``); kept whole (up to 10
characters) to name it in the counts."""
NOT_FIX_MODES = frozenset("NEMS")
"""FAA mode indicators that are not a fix: not valid, estimated (DR), manual, simulator."""
FIX_QUALITIES = frozenset({1, 2, 3, 4, 5})


class _Bad(Exception):
    """A field could not be read (inside :func:`parse_nmea_line` only)."""

    def __init__(self, kind: str, message: str, time_s: float | None = None,
                 day: date | None = None) -> None:
        super().__init__(message)
        self.kind = kind
        self.message = message
        self.time_s = time_s
        self.day = day


def _not_fix(message: str, time_text: str, date_text: str = "") -> _Bad:
    """A *not a fix* skip carrying the sentence's time (and date) when they read well: the
    log clock may still use them (docs/NMEA.md)."""
    try:
        return _Bad(SkipKind.NOT_FIX, message, _time(time_text), _ddmmyy(date_text))
    except _Bad:
        return _Bad(SkipKind.NOT_FIX, message)


def _num(text: str | None, what: str) -> float | None:
    """A plain decimal (``-``, digits, one ``.``) or None for an empty field."""
    if text is None or text == "":
        return None
    if not _NUMBER_RE.match(text):
        raise _Bad(SkipKind.MALFORMED, f"{what}: not a number (got {text!r})")
    return float(text)


def _time(text: str | None) -> float | None:
    """``hhmmss[.ss]`` → seconds of the day, or None when empty."""
    if not text:
        return None
    m = _TIME_RE.match(text)
    if m is None:
        raise _Bad(SkipKind.MALFORMED, f"time: not hhmmss.ss (got {text!r})")
    hh, mm, ss = int(m.group(1)), int(m.group(2)), int(m.group(3))
    frac = float(m.group(4)) if m.group(4) and len(m.group(4)) > 1 else 0.0
    if hh > 23 or mm > 59 or ss > 60:  # 60: a leap second, taken as the next second's start
        raise _Bad(SkipKind.MALFORMED, f"time: out of range (got {text!r})")
    return min(hh * 3600 + mm * 60 + ss + frac, 86399.999)


def _ddmmyy(text: str | None) -> date | None:
    if not text:
        return None
    if len(text) != 6 or not (text.isascii() and text.isdigit()):
        raise _Bad(SkipKind.MALFORMED, f"date: not ddmmyy (got {text!r})")
    dd, mm, yy = int(text[:2]), int(text[2:4]), int(text[4:])
    try:  # two-digit years as in the .RUN grammar: 70–99 → 19xx, 00–69 → 20xx
        return date(yy + (1900 if yy >= 70 else 2000), mm, dd)
    except ValueError:
        raise _Bad(SkipKind.MALFORMED, f"date: no such date (got {text!r})") from None


def _coord(value: str, hemi: str, lat: bool) -> float | None:
    """``ddmm.mmm``/``dddmm.mmm`` + hemisphere → signed degrees; None when both are empty."""
    if value == "" and hemi == "":
        return None
    what = "latitude" if lat else "longitude"
    m = (_LAT_RE if lat else _LON_RE).match(value)
    if m is None or hemi not in (("N", "S") if lat else ("E", "W")):
        raise _Bad(SkipKind.MALFORMED, f"{what}: not {'dd' if lat else 'ddd'}mm.mmm,"
                   f"{'N|S' if lat else 'E|W'} (got {value + ',' + hemi!r})")
    deg = int(m.group(1)) + float(m.group(2)) / 60.0
    if float(m.group(2)) >= 60.0 or deg > (90.0 if lat else 180.0):
        raise _Bad(SkipKind.MALFORMED, f"{what}: out of range (got {value!r})")
    return -deg if hemi in ("S", "W") else deg


def _angle(value: float | None, what: str) -> float | None:
    """An angle in [0, 360] → [0, 360) degrees (360 is north); else malformed."""
    if value is None:
        return None
    if not 0.0 <= value <= 360.0:
        raise _Bad(SkipKind.MALFORMED, f"{what}: not in [0, 360] degrees (got {value!r})")
    return value % 360.0


def _speed(value: float | None, what: str) -> float | None:
    if value is None:
        return None
    if value < 0.0:
        raise _Bad(SkipKind.MALFORMED, f"{what}: negative (got {value!r})")
    return value


def _east(value: float | None, direction: str, what: str) -> float | None:
    """A deviation/variation with its E/W letter → degrees, east positive."""
    if value is None:
        return None
    if direction not in ("E", "W"):
        raise _Bad(SkipKind.MALFORMED, f"{what}: direction not E|W (got {direction!r})")
    if not 0.0 <= value <= 180.0:
        raise _Bad(SkipKind.MALFORMED, f"{what}: not in [0, 180] degrees (got {value!r})")
    return -value if direction == "W" else value


def _f(msg: Any, name: str) -> str:
    """Field ``name`` of a pynmea2 sentence as text ('' when absent: a short sentence)."""
    idx = msg.name_to_idx.get(name)
    data = msg.data
    if idx is None or idx >= len(data):
        return ""
    return str(data[idx]).strip()


def _fix_mode(mode: str) -> bool:
    return not (mode and mode[0] in NOT_FIX_MODES)


def _position(msg: Any, kind: str, lat: str, lat_dir: str, lon: str, lon_dir: str
              ) -> tuple[float, float]:
    la = _coord(_f(msg, lat), _f(msg, lat_dir), True)
    lo = _coord(_f(msg, lon), _f(msg, lon_dir), False)
    if la is None or lo is None:
        raise _Bad(SkipKind.EMPTY, f"{kind}: valid fix without a position")
    return la, lo


def _gga(msg: Any, talker: str) -> NmeaValues:
    q_text = _f(msg, "gps_qual")
    if not (q_text.isascii() and q_text.isdigit()):
        if q_text == "":
            raise _not_fix("GGA: no fix quality", _f(msg, "timestamp"))
        raise _Bad(SkipKind.MALFORMED, f"GGA: fix quality not a digit (got {q_text!r})")
    quality = int(q_text)
    if quality not in FIX_QUALITIES:
        raise _not_fix(f"GGA: fix quality {quality} is not a fix", _f(msg, "timestamp"))
    time_s = _time(_f(msg, "timestamp"))
    lat, lon = _position(msg, "GGA", "lat", "lat_dir", "lon", "lon_dir")
    sats_text = _f(msg, "num_sats")
    sats: int | None = None
    if sats_text:
        if not (sats_text.isascii() and sats_text.isdigit()):
            raise _Bad(SkipKind.MALFORMED, f"GGA: satellites not a number (got {sats_text!r})")
        sats = int(sats_text)
    hdop = _num(_f(msg, "horizontal_dil"), "GGA HDOP")
    if hdop is not None and not hdop > 0.0:
        raise _Bad(SkipKind.MALFORMED, f"GGA: HDOP must be > 0 (got {hdop!r})")
    return NmeaValues("GGA", talker, time_s=time_s, lat_deg=lat, lon_deg=lon, quality=quality,
                      hdop=hdop, sats=sats)


def _rmc(msg: Any, talker: str) -> NmeaValues:
    status = _f(msg, "status")
    if status != "A" or not _fix_mode(_f(msg, "mode_indicator")):
        raise _not_fix(f"RMC: status {status!r}/mode {_f(msg, 'mode_indicator')!r} is not a fix",
                       _f(msg, "timestamp"), _f(msg, "datestamp"))
    time_s = _time(_f(msg, "timestamp"))
    day = _ddmmyy(_f(msg, "datestamp"))
    lat, lon = _position(msg, "RMC", "lat", "lat_dir", "lon", "lon_dir")
    sog = _speed(_num(_f(msg, "spd_over_grnd"), "RMC speed over ground"), "RMC SOG")
    cog = _angle(_num(_f(msg, "true_course"), "RMC course"), "RMC course")
    notes: tuple[str, ...] = ()
    try:  # the receiver's variation: a bad one costs the variation, not the fix
        var = _east(_num(_f(msg, "mag_variation"), "RMC variation"), _f(msg, "mag_var_dir"),
                    "RMC variation")
    except _Bad:
        var, notes = None, ("RMC variation malformed: not used",)
    return NmeaValues("RMC", talker, time_s=time_s, date=day, lat_deg=lat, lon_deg=lon,
                      sog_kn=sog, cog_deg=cog, variation_deg=var, notes=notes)


def _gll(msg: Any, talker: str) -> NmeaValues:
    status = _f(msg, "status")
    if status != "A" or not _fix_mode(_f(msg, "faa_mode")):
        raise _not_fix(f"GLL: status {status!r}/mode {_f(msg, 'faa_mode')!r} is not a fix",
                       _f(msg, "timestamp"))
    time_s = _time(_f(msg, "timestamp"))
    lat, lon = _position(msg, "GLL", "lat", "lat_dir", "lon", "lon_dir")
    return NmeaValues("GLL", talker, time_s=time_s, lat_deg=lat, lon_deg=lon)


def _zda(msg: Any, talker: str) -> NmeaValues:
    time_s = _time(_f(msg, "timestamp"))
    parts = [_f(msg, "day"), _f(msg, "month"), _f(msg, "year")]
    if time_s is None:
        raise _Bad(SkipKind.EMPTY, "ZDA: no time")
    if not any(parts):  # time only (some instruments leave the date empty): as a GLL's time
        return NmeaValues("ZDA", talker, time_s=time_s, notes=("ZDA without date",))
    if not all(parts):
        raise _Bad(SkipKind.MALFORMED, f"ZDA: date incomplete (got {','.join(parts)!r})")
    if not all(p.isascii() and p.isdigit() for p in parts):
        raise _Bad(SkipKind.MALFORMED, f"ZDA: date not digits (got {','.join(parts)!r})")
    try:
        day = date(int(parts[2]), int(parts[1]), int(parts[0]))
    except ValueError:
        raise _Bad(SkipKind.MALFORMED, f"ZDA: no such date (got {','.join(parts)!r})") from None
    return NmeaValues("ZDA", talker, time_s=time_s, date=day)


def _hdt(msg: Any, talker: str) -> NmeaValues:
    hdg = _angle(_num(_f(msg, "heading"), "HDT heading"), "HDT heading")
    if hdg is None:
        raise _Bad(SkipKind.EMPTY, "HDT: no heading")
    return NmeaValues("HDT", talker, heading_deg=hdg)


def _hdg(msg: Any, talker: str, variation_deg: float | None) -> NmeaValues:
    sensor = _angle(_num(_f(msg, "heading"), "HDG heading"), "HDG heading")
    if sensor is None:
        raise _Bad(SkipKind.EMPTY, "HDG: no heading")
    dev = _east(_num(_f(msg, "deviation"), "HDG deviation"), _f(msg, "dev_dir"), "HDG deviation")
    own = _east(_num(_f(msg, "variation"), "HDG variation"), _f(msg, "var_dir"), "HDG variation")
    var = own if own is not None else variation_deg
    if var is None:  # made true by the epoch builder (the log's or the model's variation)
        return NmeaValues("HDG", talker, magnetic_deg=(sensor + (dev or 0.0)) % 360.0)
    notes = () if own is not None else ("HDG made true with [nmea] variation_deg",)
    return NmeaValues("HDG", talker, heading_deg=(sensor + (dev or 0.0) + var) % 360.0,
                      variation_deg=own, notes=notes)


def _vhw(msg: Any, talker: str, variation_deg: float | None) -> NmeaValues:
    magnetic: float | None = None
    notes: tuple[str, ...] = ()
    hdg = _angle(_num(_f(msg, "heading_true"), "VHW true heading"), "VHW true heading")
    if hdg is None:
        mag = _angle(_num(_f(msg, "heading_magnetic"), "VHW magnetic heading"),
                     "VHW magnetic heading")
        if mag is not None:
            if variation_deg is None:  # made true by the epoch builder
                magnetic = mag
            else:
                hdg = (mag + variation_deg) % 360.0
                notes = ("VHW magnetic heading made true with [nmea] variation_deg",)
    stw = _speed(_num(_f(msg, "water_speed_knots"), "VHW speed"), "VHW speed")
    if stw is None:
        kmh = _speed(_num(_f(msg, "water_speed_km"), "VHW speed km/h"), "VHW speed")
        stw = None if kmh is None else kmh * KMH_TO_KN
    if hdg is None and stw is None and magnetic is None:
        raise _Bad(SkipKind.EMPTY, "VHW: no heading and no speed")
    return NmeaValues("VHW", talker, heading_deg=hdg, stw_kn=stw, magnetic_deg=magnetic,
                      notes=notes)


def _vbw(msg: Any, talker: str) -> NmeaValues:
    if _f(msg, "data_validity_water_spd") != "A":
        raise _Bad(SkipKind.EMPTY, "VBW: water speed not valid (status not A)")
    stw = _num(_f(msg, "lon_water_spd"), "VBW water speed")
    if stw is None:
        raise _Bad(SkipKind.EMPTY, "VBW: no water speed")
    if stw < 0.0:
        return NmeaValues("VBW", talker, notes=("VBW speed astern (negative): not used",))
    return NmeaValues("VBW", talker, stw_kn=stw)


def _vtg(msg: Any, talker: str) -> NmeaValues:
    if not _fix_mode(_f(msg, "faa_mode")):
        raise _Bad(SkipKind.NOT_FIX, f"VTG: mode {_f(msg, 'faa_mode')!r} is not valid")
    cog = _angle(_num(_f(msg, "true_track"), "VTG course"), "VTG course")
    sog = _speed(_num(_f(msg, "spd_over_grnd_kts"), "VTG speed"), "VTG speed")
    if sog is None:
        kmh = _speed(_num(_f(msg, "spd_over_grnd_kmph"), "VTG speed km/h"), "VTG speed")
        sog = None if kmh is None else kmh * KMH_TO_KN
    if cog is None and sog is None:
        raise _Bad(SkipKind.EMPTY, "VTG: no course and no speed")
    return NmeaValues("VTG", talker, cog_deg=cog, sog_kn=sog)


def _depth(value: float | None, what: str) -> float | None:
    if value is not None and value < 0.0:
        raise _Bad(SkipKind.MALFORMED, f"{what}: negative depth (got {value!r})")
    return value


def _dbt(msg: Any, talker: str) -> NmeaValues:
    depth = _depth(_num(_f(msg, "depth_meters"), "DBT metres"), "DBT")
    if depth is None:
        feet = _depth(_num(_f(msg, "depth_feet"), "DBT feet"), "DBT")
        fathoms = _depth(_num(_f(msg, "depth_fathoms"), "DBT fathoms"), "DBT")
        depth = (feet * FEET_TO_M if feet is not None
                 else None if fathoms is None else fathoms * FATHOMS_TO_M)
    if depth is None:
        raise _Bad(SkipKind.EMPTY, "DBT: no depth")
    return NmeaValues("DBT", talker, depth_m=depth)


def _dpt(msg: Any, talker: str) -> NmeaValues:
    depth = _depth(_num(_f(msg, "depth"), "DPT depth"), "DPT")
    if depth is None:
        raise _Bad(SkipKind.EMPTY, "DPT: no depth")
    return NmeaValues("DPT", talker, depth_m=depth)


def _values(msg: Any, kind: str, talker: str, variation_deg: float | None) -> NmeaValues | None:
    if kind == "GGA":
        return _gga(msg, talker)
    if kind == "RMC":
        return _rmc(msg, talker)
    if kind == "GLL":
        return _gll(msg, talker)
    if kind == "ZDA":
        return _zda(msg, talker)
    if kind == "HDT":
        return _hdt(msg, talker)
    if kind == "HDG":
        return _hdg(msg, talker, variation_deg)
    if kind == "VHW":
        return _vhw(msg, talker, variation_deg)
    if kind == "VBW":
        return _vbw(msg, talker)
    if kind == "VTG":
        return _vtg(msg, talker)
    if kind == "DBT":
        return _dbt(msg, talker)
    if kind == "DPT":
        return _dpt(msg, talker)
    return None


def _checksum(body: str) -> int:
    """XOR of the characters between ``$`` and ``*`` (ASCII by now)."""
    return reduce(xor, body.encode("ascii"), 0)


def parse_nmea_line(
    line: str, variation_deg: float | None = None, accept_no_checksum: bool = False
) -> NmeaValues | SentenceSkip | None:
    """One log line → its values, a :class:`SentenceSkip`, or None for a blank line.

    ``variation_deg`` (east positive) turns a magnetic heading without its own variation
    (HDG, VHW) into a true one. A sentence without ``*hh`` is skipped as ``no checksum``
    unless ``accept_no_checksum`` (docs/NMEA.md). Never raises.
    """
    text = line.strip()
    if not text:
        return None
    if not text.isascii() or not text.isprintable():
        return SentenceSkip(SkipKind.NOISE, "binary noise or non-ASCII characters")
    if text[0] == "!":
        return SentenceSkip(SkipKind.AIS, "AIS/encapsulated sentence (!): not used",
                            text[3:6] if len(text) >= 6 else None)
    if text[0] != "$":
        return SentenceSkip(SkipKind.NOT_TEXT, "does not start with $")
    if len(text) > MAX_SENTENCE_CHARS:
        return SentenceSkip(SkipKind.MALFORMED, f"longer than {MAX_SENTENCE_CHARS} characters")
    star = text.rfind("*")
    if star < 0 or not re.fullmatch(r"\*[0-9A-Fa-f]{2}", text[star:]):
        if "*" in text:
            return SentenceSkip(SkipKind.MALFORMED, "checksum field is not *hh")
        if not accept_no_checksum:
            return SentenceSkip(SkipKind.NO_CHECKSUM, "no *hh checksum",
                                text[3:6] if len(text) >= 6 else None)
        text += f"*{_checksum(text[1:]):02X}"
    elif int(text[star + 1:], 16) != _checksum(text[1:star]):
        return SentenceSkip(SkipKind.BAD_CHECKSUM,
                            f"checksum {text[star + 1:].upper()} != {_checksum(text[1:star]):02X}",
                            text[3:6] if len(text) >= 6 else None)
    if text[1] == "P" and (m := _PROPRIETARY_RE.match(text)):
        # proprietary: $PGRMC is Garmin's, not an RMC; its whole address names it (PMTK001)
        return SentenceSkip(SkipKind.UNKNOWN, f"{m.group(1)}: proprietary sentence not used",
                            m.group(1))
    if not _FRAME_RE.match(text):
        return SentenceSkip(SkipKind.MALFORMED, "not $TTSSS,…*hh")
    talker, kind = text[1:3], text[3:6]
    if kind not in USED_TYPES:
        return SentenceSkip(SkipKind.UNKNOWN, f"{kind}: sentence type not used", kind)
    import pynmea2  # on first use: a replay of a .RUN file never parses NMEA (start-up)

    try:
        msg = pynmea2.parse(text, check=True)
    except pynmea2.ChecksumError as exc:
        return SentenceSkip(SkipKind.BAD_CHECKSUM, str(exc.args[0][0]), kind)
    except (pynmea2.ParseError, ValueError, TypeError, IndexError) as exc:
        return SentenceSkip(SkipKind.MALFORMED, f"{kind}: {exc}", kind)
    if getattr(msg, "sentence_type", None) != kind:  # pragma: no cover - defensive
        return SentenceSkip(SkipKind.MALFORMED, f"{kind}: not parsed as {kind}", kind)
    try:
        values = _values(msg, kind, talker, variation_deg)
    except _Bad as bad:
        return SentenceSkip(bad.kind, bad.message, kind, bad.time_s, bad.day)
    if values is None:  # pragma: no cover - USED_TYPES and _values agree
        return SentenceSkip(SkipKind.UNKNOWN, f"{kind}: sentence type not used", kind)
    for v in (values.hdop, values.heading_deg, values.stw_kn, values.cog_deg, values.sog_kn,
              values.depth_m, values.magnetic_deg, values.variation_deg):
        if v is not None and not math.isfinite(v):
            return SentenceSkip(SkipKind.MALFORMED, f"{kind}: not a finite number", kind)
    return values
