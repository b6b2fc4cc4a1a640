"""The thesis' screen number formats (A8.5 sample pages; THEORY §12.7–12.9).

Positions are rounded once, in integer units of the last printed digit, so that every carry
(59.9996" → next minute, 59.996' → next degree) comes out right. Negative latitudes and
longitudes print as S and W; a value that rounds to zero prints as N or E.
"""

from __future__ import annotations

import datetime as _dt
import math

from engine.io.operator_input import ZONE_LETTERS, decca_pattern

PLACEHOLDER = "999.99"
"""Printed for a statistic that was not computed (Pg 633 rows of unused LOPs, THEORY §12.7)."""


def _units(value_deg: float, per_degree: int) -> tuple[int, bool]:
    """(|value| in integer units of 1/per_degree degree, is negative); NaN/inf → ValueError."""
    if not math.isfinite(value_deg):
        raise ValueError(f"cannot format non-finite angle {value_deg!r}")
    units = round(abs(value_deg) * per_degree)
    return units, value_deg < 0.0 and units != 0


def _dms(value_deg: float, decimals: int, deg_width: int) -> tuple[str, str, str, bool]:
    """Texts (degrees, minutes, seconds) of abs(value) rounded to the last digit, and sign."""
    scale = 10**decimals
    units, negative = _units(value_deg, 3600 * scale)
    degrees, rest = divmod(units, 3600 * scale)
    minutes, rest = divmod(rest, 60 * scale)
    whole, frac = divmod(rest, scale)
    seconds = f"{whole:02d}.{frac:0{decimals}d}" if decimals > 0 else f"{whole:02d}"
    return f"{degrees:0{deg_width}d}", f"{minutes:02d}", seconds, negative


def _dm(value_deg: float, decimals: int) -> tuple[int, str, bool]:
    """(degrees, ``MM.mm`` minutes text, negativity) of a value rounded to the last minute digit."""
    scale = 10**decimals
    units, negative = _units(value_deg, 60 * scale)
    degrees, rest = divmod(units, 60 * scale)
    whole, frac = divmod(rest, scale)
    minutes = f"{whole:02d}.{frac:0{decimals}d}" if decimals > 0 else f"{whole:02d}"
    return degrees, minutes, negative


def _format_dms(value_deg: float, letters: str, deg_width: int, space: bool, decimals: int) -> str:
    degrees, minutes, seconds, negative = _dms(value_deg, decimals, deg_width)
    hemi = letters[1] if negative else letters[0]
    return f"{degrees}°{minutes}'{seconds}\"{' ' if space else ''}{hemi}"


def _format_dm(value_deg: float, letters: str, deg_width: int, space: bool, decimals: int) -> str:
    degrees, minutes, negative = _dm(value_deg, decimals)
    hemi = letters[1] if negative else letters[0]
    return f"{degrees:0{deg_width}d}°{minutes}'{' ' if space else ''}{hemi}"


def format_lat_dms(lat_deg: float, space: bool = True, decimals: int = 3) -> str:
    """Latitude as ``DD°MM'SS.sss" H`` (Pg 100/631/641, e.g. ``52°50'32.373" N``)."""
    return _format_dms(lat_deg, "NS", 2, space, decimals)


def format_lon_dms(lon_deg: float, space: bool = True, decimals: int = 3) -> str:
    """Longitude as ``DDD°MM'SS.sss" H`` (e.g. ``004°31'50.958" E``, CM ``005°00'00.000" E``)."""
    return _format_dms(lon_deg, "EW", 3, space, decimals)


def format_lat_dm(lat_deg: float, space: bool = False, decimals: int = 2) -> str:
    """Latitude as ``DD°MM.mm'H`` (side column, e.g. ``52°50.54'N``; Pg 100 GPS uses a space)."""
    return _format_dm(lat_deg, "NS", 2, space, decimals)


def format_lon_dm(lon_deg: float, space: bool = False, decimals: int = 2) -> str:
    """Longitude as ``DDD°MM.mm'H`` (e.g. ``004°31.85'E``, CM ``005°00.00'E``)."""
    return _format_dm(lon_deg, "EW", 3, space, decimals)


def format_dms_input(lat_deg: float, lon_deg: float) -> str:
    """A position in the operator-input form ``52 50 00.000 N 004 30 00.000 E`` (L7730).

    :func:`engine.io.operator_input.parse_position` reads it back to within 0.0005".
    """
    *lat, lat_neg = _dms(lat_deg, 3, 2)
    *lon, lon_neg = _dms(lon_deg, 3, 3)
    return f"{' '.join(lat)} {'S' if lat_neg else 'N'} {' '.join(lon)} {'W' if lon_neg else 'E'}"


def _fixed(value: float, decimals: int) -> str:
    """``value`` with ``decimals`` decimals; a result that rounds to zero has no minus sign."""
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]
    return text


def format_zone_lane(n_total: float, pattern: str, decimals: int = 1) -> str:
    """Zone letter + lane with ``decimals`` decimals from a total lane count (Pg 100).

    E.g. Red 44.862 → ``B20.9``, Green 274.337 → ``F34.3``, Purple 1.111 → ``A51.1``. The count
    is rounded first, so Red 47.96 → ``C0.0`` (the next zone), not ``B24.0``.
    """
    spec = decca_pattern(pattern)
    scale = 10**decimals
    units = round(n_total * scale)
    zone_count = units // (spec.lanes_per_zone * scale)
    lane_units = spec.first_lane * scale + units - zone_count * spec.lanes_per_zone * scale
    whole, frac = divmod(lane_units, scale)
    lane = f"{whole}.{frac:0{decimals}d}" if decimals > 0 else f"{whole}"
    return f"{ZONE_LETTERS[zone_count % 10]}{lane}"


def format_speed_kn(speed_kn: float, decimals: int = 1) -> str:
    """Speed in knots as on Pg 100, e.g. ``12.7kts``."""
    return f"{_fixed(speed_kn, decimals)}kts"


def format_angle_deg(angle_deg: float, decimals: int = 1) -> str:
    """An angle in degrees with 1 decimal and the degree sign, e.g. ``112.0°`` (Az, GYRO)."""
    return f"{_fixed(angle_deg, decimals)}°"


def format_metres(value_m: float, decimals: int = 2, space: bool = True) -> str:
    """A distance in metres, ``6.35 m`` (side column); ``space=False`` gives Pg 100's ``6.35m``."""
    return f"{_fixed(value_m, decimals)}{' ' if space else ''}m"


def format_time_z(when: _dt.datetime | _dt.time) -> str:
    """UTC time of day as ``HH:MM:SSZ`` (``Time`` field, e.g. ``08:35:39Z``)."""
    return f"{when.hour:02d}:{when.minute:02d}:{when.second:02d}Z"


def format_stat(x: float | None, width: int = 8, decimals: int = 2) -> str:
    """A statistic right-aligned in ``width``; ``999.99`` if it was not computed (None/NaN/inf)."""
    if x is None or not math.isfinite(x):
        return PLACEHOLDER.rjust(width)
    return _fixed(x, decimals).rjust(width)
