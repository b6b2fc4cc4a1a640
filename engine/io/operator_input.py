"""Parsers for what the navigator types into the dialogs (thesis §7.3.2–7.3.3, L7723–7758).

Every parser returns plain floats/ints/strings and raises :class:`engine.errors.InputError`
with a thesis-style message (``Wrong position input format !`` is the thesis' own, L7754; the
others follow its style, THEORY §13.7), ``field`` = the dialog field name and ``text`` = the
characters typed. Positions are geodetic degrees on the working datum, north and east positive.

The Decca zone/lane helpers implement the standard numbering (Red 0–23, Green 30–47,
Purple 50–79, zones A–J; THEORY D7, §3.3).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from decimal import Decimal
from typing import NamedTuple

from engine.errors import InputError

POSITION_MESSAGE = "Wrong position input format !"
BEARING_MESSAGE = "Wrong bearing input !"
DISTANCE_MESSAGE = "Wrong distance input !"
SPEED_MESSAGE = "Wrong speed input !"
DIRECTION_MESSAGE = "Wrong direction input !"
DEPTH_MESSAGE = "Wrong depth input !"
ZONE_LANE_MESSAGE = "Wrong zone/lane input !"
DATUM_MESSAGE = "Unknown datum !"
FILE_NAME_MESSAGE = "Wrong file name !"

MAX_SPEED_KN = 60.0
"""Upper limit of a typed speed (knots); a plausibility bound, not from the thesis."""
MAX_DISTANCE_NM = 10800.0
"""Upper limit of a typed distance (nm): half the Earth's circumference (21600 nm), so no
distance on it is longer."""
MAX_DEPTH_M = 1000.0
"""Upper limit of a typed depth (metres); a plausibility bound, not from the thesis."""

ZONE_LETTERS = "ABCDEFGHIJ"
"""Decca zone letters; zone index = position in this string (A = 0), repeating every 10 zones."""


class DeccaPattern(NamedTuple):
    """Lane numbering of one Decca pattern (THEORY §3.3): lanes per zone and first/last lane."""

    name: str
    lanes_per_zone: int
    first_lane: int
    last_lane: int


PATTERNS: dict[str, DeccaPattern] = {
    "red": DeccaPattern("red", 24, 0, 23),
    "green": DeccaPattern("green", 18, 30, 47),
    "purple": DeccaPattern("purple", 30, 50, 79),
}
"""The three Decca patterns by lower-case name (THEORY §3.2, D7)."""

_PATTERN_ALIASES = {
    "red": "red",
    "r": "red",
    "green": "green",
    "g": "green",
    "grn": "green",
    "purple": "purple",
    "p": "purple",
    "prp": "purple",
}

DECIMAL = r"(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)"
"""Regular-expression text of an unsigned plain decimal number in ASCII digits: ``12``,
``12.5``, ``12.``, ``.5``. Every number in UVNAV's input grammars (typed input, ``.RUN``,
``TO_WGS84.DAT``, ``DECCA.CHN``) is this, optionally preceded by ``-`` where a sign is allowed;
``float()`` alone would also take ``+5``, ``5_2``, ``1e3``, ``inf`` and non-ASCII digits."""
SIGNED_DECIMAL_RE = re.compile(rf"-?{DECIMAL}")
"""``DECIMAL`` with an optional leading ``-`` (use ``fullmatch``)."""
BLANKS = " \t"
"""The separators of the input grammars: ASCII space and tab (never other Unicode blanks)."""


def format_decimal(value: float, decimals: int) -> str:
    """``value`` written in the :data:`DECIMAL` grammar (with ``-`` if negative) so that it reads
    back exactly: with ``decimals`` decimals when that is exact, else all the digits of the
    shortest ``repr`` in positional notation (never an exponent). ``value`` must be finite."""
    text = f"{value:.{decimals}f}"
    if float(text) == value:
        return text
    return format(Decimal(repr(value)), "f")

_NUMBER_RE = re.compile(DECIMAL)
_POS_FIELD_RE = re.compile(rf"({DECIMAL})?([NSEWnsew])?")
_SEPARATOR_RE = re.compile(r"[ \t]*,[ \t]*|[ \t]+")
_ZONE_LANE_RE = re.compile(r"([A-Ja-j])[ \t]*([0-9]{1,2})")
_RUN_NAME_RE = re.compile(r"[A-Za-z0-9_-]+")


def decca_pattern(pattern: str) -> DeccaPattern:
    """The :class:`DeccaPattern` for ``pattern`` ("red"/"green"/"purple", also R/G/P, Grn/Prp).

    An unknown name is a programming error and raises ``ValueError`` (not ``InputError``).
    """
    key = _PATTERN_ALIASES.get(pattern.strip().lower())
    if key is None:
        raise ValueError(f"unknown Decca pattern {pattern!r}")
    return PATTERNS[key]


# --------------------------------------------------------------------------------------------
# Positions (§7.3.2, L7723–7754; THEORY §13.6)


def _position_groups(text: str, field: str) -> list[tuple[list[str], str]]:
    """Split a position text into groups of (number strings, hemisphere letter, upper case)."""
    bad = InputError(POSITION_MESSAGE, field=field, text=text)
    stripped = text.strip(BLANKS)
    if not stripped:
        raise bad
    groups: list[tuple[list[str], str]] = []
    numbers: list[str] = []
    for token in _SEPARATOR_RE.split(stripped):
        match = _POS_FIELD_RE.fullmatch(token)
        if not token or match is None:
            raise bad
        number, letter = match.group(1), match.group(2)
        if number is not None:
            numbers.append(number)
        if letter is not None:
            if not numbers:
                raise bad
            groups.append((numbers, letter.upper()))
            numbers = []
    if numbers:  # trailing numbers without a hemisphere letter
        raise bad
    return groups


def _group_degrees(numbers: list[str], limit: float, bad: InputError) -> float:
    """Degrees (unsigned) from 1–3 components D [M [S]]; only the last may carry decimals."""
    if not 1 <= len(numbers) <= 3:
        raise bad
    if any("." in n for n in numbers[:-1]):
        raise bad
    values = [float(n) for n in numbers]
    if any(not math.isfinite(v) for v in values):
        raise bad
    if any(v >= 60.0 for v in values[1:]):
        raise bad
    degrees = values[0] + sum(v / 60.0**i for i, v in enumerate(values[1:], start=1))
    if degrees > limit:
        raise bad
    return degrees


def _signed(value: float, letter: str) -> float:
    """Apply the hemisphere sign (S and W negative); a zero stays +0.0."""
    if value == 0.0:
        return 0.0
    return -value if letter in "SW" else value


def parse_latitude(text: str, *, field: str = "latitude") -> float:
    """Latitude in degrees (south negative) from one of the six thesis forms, e.g. ``52 30.0 N``.

    Forms D M S.sss / D M S / D M.m / D M / D.d / D followed by N or S (case-insensitive), with
    spaces or commas as separators and optional leading zeros (thesis L7728–7750).
    Raises ``InputError("Wrong position input format !")``.
    """
    return _parse_coordinate(text, field, "NS", 90.0)


def parse_longitude(text: str, *, field: str = "longitude") -> float:
    """Longitude in degrees (west negative), same forms as :func:`parse_latitude` with E or W."""
    return _parse_coordinate(text, field, "EW", 180.0)


def _parse_coordinate(text: str, field: str, letters: str, limit_deg: float) -> float:
    """One coordinate: a single group whose hemisphere letter is in ``letters``, signed,
    at most ``limit_deg`` degrees."""
    bad = InputError(POSITION_MESSAGE, field=field, text=text)
    groups = _position_groups(text, field)
    if len(groups) != 1 or groups[0][1] not in letters:
        raise bad
    numbers, letter = groups[0]
    return _signed(_group_degrees(numbers, limit_deg, bad), letter)


def parse_position(text: str, *, field: str = "position") -> tuple[float, float]:
    """(lat, lon) in degrees from a typed position, e.g. ``52 50 00 N 004 30 00 E``.

    Latitude first (N/S), then longitude (E/W); each part may use a different one of the six
    thesis forms (L7728–7750). Range checks: lat ≤ 90, lon ≤ 180, minutes and seconds < 60, no
    signs. Raises ``InputError("Wrong position input format !", field=field, text=text)``.
    """
    bad = InputError(POSITION_MESSAGE, field=field, text=text)
    groups = _position_groups(text, field)
    if len(groups) != 2:
        raise bad
    (lat_numbers, lat_letter), (lon_numbers, lon_letter) = groups
    if lat_letter not in "NS" or lon_letter not in "EW":
        raise bad
    lat = _signed(_group_degrees(lat_numbers, 90.0, bad), lat_letter)
    lon = _signed(_group_degrees(lon_numbers, 180.0, bad), lon_letter)
    return lat, lon


# --------------------------------------------------------------------------------------------
# Plain numbers: bearings, distances, speeds, current direction, depth (§7.3.2, L7752–7754)


def _plain_number(text: str, message: str, field: str) -> float:
    """An unsigned decimal number (``12``, ``12.5``, ``.5``; :data:`DECIMAL`, blanks around it
    allowed); anything else is an InputError."""
    stripped = text.strip(BLANKS)
    if _NUMBER_RE.fullmatch(stripped) is None:
        raise InputError(message, field=field, text=text)
    value = float(stripped)
    if not math.isfinite(value):
        raise InputError(message, field=field, text=text)
    return value


def parse_plain_number(text: str, message: str, *, field: str) -> float:
    """An unsigned decimal number as the dialogs take it (``12``, ``12.5``, ``.5``; no sign,
    exponent, ``inf`` or ``nan``); anything else is ``InputError(message)``."""
    return _plain_number(text, message, field)


def _parse_angle(text: str, message: str, field: str) -> float:
    """Degrees in [0, 360] clockwise from north; 360 is returned as 0."""
    value = _plain_number(text, message, field)
    if value > 360.0:
        raise InputError(message, field=field, text=text)
    return 0.0 if value == 360.0 else value


def parse_bearing_deg(text: str, *, field: str = "bearing") -> float:
    """Bearing in degrees true, 0 (north) clockwise to 360 (thesis L7752); 360 → 0."""
    return _parse_angle(text, BEARING_MESSAGE, field)


def parse_direction_deg(text: str, *, field: str = "direction") -> float:
    """Current direction (the set, towards which it flows; L7461) in degrees [0, 360]; 360 → 0."""
    return _parse_angle(text, DIRECTION_MESSAGE, field)


def parse_distance_nm(text: str, *, field: str = "distance") -> float:
    """Distance in nautical miles (1 nm = 1852 m exactly, L7754), 0 < d ≤
    :data:`MAX_DISTANCE_NM`."""
    value = _plain_number(text, DISTANCE_MESSAGE, field)
    if not 0.0 < value <= MAX_DISTANCE_NM:
        raise InputError(DISTANCE_MESSAGE, field=field, text=text)
    return value


def parse_speed_kn(text: str, *, field: str = "speed") -> float:
    """Speed in knots (1 kn = 1852/3600 m/s), 0 ≤ v ≤ 60."""
    value = _plain_number(text, SPEED_MESSAGE, field)
    if value > MAX_SPEED_KN:
        raise InputError(SPEED_MESSAGE, field=field, text=text)
    return value


def parse_depth_m(text: str, *, field: str = "depth") -> float:
    """Depth below the sea surface in metres (start-up dialog, L5492), 0 ≤ d ≤ 1000."""
    value = _plain_number(text, DEPTH_MESSAGE, field)
    if value > MAX_DEPTH_M:
        raise InputError(DEPTH_MESSAGE, field=field, text=text)
    return value


# --------------------------------------------------------------------------------------------
# Decca zone and lane (THEORY §3.2, D7; THEORY §3.3)


def parse_zone_lane(text: str, pattern: str, *, field: str | None = None) -> tuple[int, int]:
    """(zone index A=0..J=9, whole lane) from a typed zone letter + lane, e.g. ``B20`` → (1, 20).

    The lane must lie in the pattern's range (Red 0–23, Green 30–47, Purple 50–79, A14).
    ``field`` defaults to the pattern name. Raises ``InputError("Wrong zone/lane input !")``.
    """
    spec = decca_pattern(pattern)
    name = field if field is not None else spec.name
    match = _ZONE_LANE_RE.fullmatch(text.strip(BLANKS))
    if match is None:
        raise InputError(ZONE_LANE_MESSAGE, field=name, text=text)
    zone = ZONE_LETTERS.index(match.group(1).upper())
    lane = int(match.group(2))
    if not spec.first_lane <= lane <= spec.last_lane:
        raise InputError(ZONE_LANE_MESSAGE, field=name, text=text)
    return zone, lane


def lanes_from_zone_lane(zone: int, lane: int, fraction: float, pattern: str, cycle: int) -> float:
    """Total lane count N = (zone + 10·cycle)·lpz + (lane − firstLane) + fraction (THEORY §3.3).

    ``zone`` 0..9, ``lane`` a whole lane of the pattern, ``fraction`` in [0, 1) (the receiver
    reading), ``cycle`` the 10-zone cycle c. E.g. Green F34 + .337, c = 1 → 274.337.
    Bad arguments are programming errors (``ValueError``).
    """
    spec = decca_pattern(pattern)
    if not 0 <= zone <= 9:
        raise ValueError(f"zone index {zone} outside 0..9")
    if not spec.first_lane <= lane <= spec.last_lane:
        raise ValueError(f"lane {lane} outside {spec.first_lane}..{spec.last_lane}")
    if not 0.0 <= fraction < 1.0:
        raise ValueError(f"lane fraction {fraction} outside [0, 1)")
    return (zone + 10 * cycle) * spec.lanes_per_zone + (lane - spec.first_lane) + fraction


def zone_lane_of(n_total: float, pattern: str) -> tuple[str, float]:
    """(zone letter, lane with fraction) of a total lane count, e.g. Red 44.862 → ("B", 20.862).

    zone = 'ABCDEFGHIJ'[⌊N/lpz⌋ mod 10], lane = firstLane + N − lpz·⌊N/lpz⌋ (THEORY §3.3).
    """
    spec = decca_pattern(pattern)
    zone_count = math.floor(n_total / spec.lanes_per_zone)
    lane = spec.first_lane + (n_total - zone_count * spec.lanes_per_zone)
    return ZONE_LETTERS[zone_count % 10], lane


# --------------------------------------------------------------------------------------------
# Names: datum, run file


def parse_datum_name(text: str, known: Iterable[str], *, field: str = "datum") -> str:
    """The canonical datum name from ``known`` (TO_WGS84.DAT section 2) matching ``text``.

    Case-insensitive, runs of blanks count as one (``ed50  [dma]`` → ``ED50 [DMA]``).
    Raises ``InputError("Unknown datum !")``.
    """
    wanted = " ".join(text.split()).upper()
    if wanted:
        for name in known:
            if " ".join(name.split()).upper() == wanted:
                return name
    raise InputError(DATUM_MESSAGE, field=field, text=text)


def parse_run_name(text: str, *, field: str = "run file") -> str:
    """The run name typed at start-up, without ``.RUN`` (e.g. ``920917_1``; L5494).

    Letters, digits, ``_`` and ``-`` only; a typed ``.RUN`` suffix (any case) is dropped.
    Only the form is checked (``Wrong file name !``); whether the file exists is the caller's job.
    """
    name = text.strip()
    if name.upper().endswith(".RUN"):
        name = name[:-4]
    if _RUN_NAME_RE.fullmatch(name) is None:
        raise InputError(FILE_NAME_MESSAGE, field=field, text=text)
    return name
