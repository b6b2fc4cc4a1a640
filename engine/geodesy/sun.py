"""The sun's position as seen from a place on the Earth: declination and elevation.

The low-accuracy solar coordinates of Meeus (*Astronomical Algorithms*, 2nd ed. 1998, ch. 25
"Solar coordinates", eqs. 25.2–25.8, and the equation of time of ch. 28, eq. 28.3), in the form
of the NOAA Global Monitoring Laboratory's solar calculator: accurate to about 0.01° in
declination and a few seconds in the equation of time for 1800–2100, far below what telling
day from night needs. The elevation is geometric (no atmospheric refraction, which lifts the
sun by about 0.6° at the horizon and less than 0.2° above 5°).

Plain numbers in, plain numbers out: times are UTC ``datetime`` (a naive one is taken as UTC),
latitudes and longitudes in degrees (north and east positive, any datum: a datum shift of a few
hundred metres moves the sun by less than 0.01°), angles out in degrees.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime

__all__ = ["equation_of_time_min", "solar_declination_deg", "solar_position_deg",
           "sun_elevation_deg"]

_J2000 = datetime(2000, 1, 1, 12, tzinfo=UTC)
"""Epoch J2000.0 (JD 2451545.0); UTC is used for TT (their difference, about a minute, moves
the sun by 0.0007°)."""


def _centuries(t: datetime) -> float:
    """Julian centuries of 36525 days from J2000.0 to ``t``."""
    if t.tzinfo is None:
        t = t.replace(tzinfo=UTC)
    return (t - _J2000).total_seconds() / (86400.0 * 36525.0)


def _solar(t: datetime) -> tuple[float, float]:
    """(apparent declination in degrees, equation of time in minutes) at ``t`` (Meeus ch. 25,
    28)."""
    tc = _centuries(t)
    l0 = (280.46646 + tc * (36000.76983 + 0.0003032 * tc)) % 360.0  # mean longitude (25.2)
    m = math.radians(357.52911 + tc * (35999.05029 - 0.0001537 * tc))  # mean anomaly (25.3)
    e = 0.016708634 - tc * (0.000042037 + 0.0000001267 * tc)  # eccentricity (25.4)
    c = (math.sin(m) * (1.914602 - tc * (0.004817 + 0.000014 * tc))
         + math.sin(2.0 * m) * (0.019993 - 0.000101 * tc)
         + math.sin(3.0 * m) * 0.000289)  # equation of the centre
    omega = math.radians(125.04 - 1934.136 * tc)
    lam = math.radians(l0 + c - 0.00569 - 0.00478 * math.sin(omega))  # apparent longitude
    eps0 = 23.0 + (26.0 + (21.448 - tc * (46.815 + tc * (0.00059 - tc * 0.001813))) / 60.0) / 60.0
    eps = math.radians(eps0 + 0.00256 * math.cos(omega))  # obliquity, corrected (25.8)
    decl = math.degrees(math.asin(math.sin(eps) * math.sin(lam)))  # (25.7)
    y = math.tan(eps / 2.0) ** 2
    l0r = math.radians(l0)
    eot = (y * math.sin(2.0 * l0r) - 2.0 * e * math.sin(m)
           + 4.0 * e * y * math.sin(m) * math.cos(2.0 * l0r)
           - 0.5 * y * y * math.sin(4.0 * l0r) - 1.25 * e * e * math.sin(2.0 * m))  # (28.3)
    return decl, 4.0 * math.degrees(eot)


def solar_declination_deg(t: datetime) -> float:
    """The sun's apparent declination at ``t`` (degrees, north positive)."""
    return _solar(t)[0]


def equation_of_time_min(t: datetime) -> float:
    """Apparent minus mean solar time at ``t`` (minutes; positive: the sun transits early)."""
    return _solar(t)[1]


def sun_elevation_deg(t: datetime, lat_deg: float, lon_deg: float) -> float:
    """Geometric elevation of the sun's centre above the horizon at ``t`` seen from
    ``lat_deg``, ``lon_deg`` (degrees; negative: below the horizon)."""
    return solar_position_deg(t, lat_deg, lon_deg)[1]


def solar_position_deg(t: datetime, lat_deg: float, lon_deg: float) -> tuple[float, float]:
    """(the sun's declination, its geometric elevation at ``lat_deg``, ``lon_deg``) at ``t``,
    degrees: :func:`solar_declination_deg` and :func:`sun_elevation_deg` in one evaluation."""
    if t.tzinfo is not None:
        t = t.astimezone(UTC)
    decl, eot = _solar(t)
    minutes = t.hour * 60.0 + t.minute + (t.second + t.microsecond * 1e-6) / 60.0
    hour_angle = math.radians((minutes + eot + 4.0 * lon_deg) / 4.0 - 180.0)
    lat, d = math.radians(lat_deg), math.radians(decl)
    s = math.sin(lat) * math.sin(d) + math.cos(lat) * math.cos(d) * math.cos(hour_angle)
    return decl, math.degrees(math.asin(max(-1.0, min(1.0, s))))
