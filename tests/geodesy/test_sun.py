"""The sun's declination, equation of time and elevation (engine.geodesy.sun) against published
values and a hand calculation."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest

from engine.geodesy.sun import equation_of_time_min, solar_declination_deg, sun_elevation_deg


def test_meeus_worked_examples() -> None:
    """Meeus, Astronomical Algorithms (2nd ed.), ex. 25.a: 1992 Oct 13.0 TD, apparent
    δ = −7.78507° (low-accuracy method); ex. 28.b: equation of time E = +13 min 42.6 s. UTC is
    taken for TD (ΔT ≈ 59 s in 1992: 0.0003° of declination, 0.01 s of E)."""
    t = datetime(1992, 10, 13, tzinfo=UTC)
    assert solar_declination_deg(t) == pytest.approx(-7.78507, abs=0.001)
    assert equation_of_time_min(t) == pytest.approx(13.0 + 42.6 / 60.0, abs=2.0 / 60.0)


def _crossings(day: datetime, lat: float, lon: float, level: float) -> list[datetime]:
    """The times (10-s steps) at which the elevation crosses ``level`` on ``day``."""
    out, prev = [], None
    for k in range(8640):
        t = day + timedelta(seconds=10 * k)
        above = sun_elevation_deg(t, lat, lon) >= level
        if prev is not None and above != prev:
            out.append(t)
        prev = above
    return out


def test_amsterdam_sunrise_and_sunset_at_the_solstice() -> None:
    """Amsterdam (52.3676° N, 4.9041° E) on 21 June 2020: sunrise 05:18 and sunset 22:06 CEST
    as published (timeanddate.com, KNMI), i.e. 03:18 and 20:06 UTC; the published times put the
    sun's centre at −0.833° (refraction 34′ and semi-diameter 16′). Tolerance 1.5 min (the
    tables round to the minute)."""
    rise, sset = _crossings(datetime(2020, 6, 21, tzinfo=UTC), 52.3676, 4.9041, -0.833)
    assert abs((rise - datetime(2020, 6, 21, 3, 18, tzinfo=UTC)).total_seconds()) < 90.0
    assert abs((sset - datetime(2020, 6, 21, 20, 6, tzinfo=UTC)).total_seconds()) < 90.0


def test_noon_elevation_by_hand() -> None:
    """At the June solstice the declination is the obliquity (23.437° in 2020, Meeus 22.2), so
    the noon elevation at 52° N is 90 − 52 + 23.437 = 61.437° (hand calculation; ±0.01°); in
    the south at 34° S it is 90 − 34 − 23.437 = 32.563°. A naive time is UTC."""
    day = datetime(2020, 6, 21)
    north = max(sun_elevation_deg(day + timedelta(minutes=k), 52.0, 0.0) for k in range(1440))
    south = max(sun_elevation_deg(day + timedelta(minutes=k), -34.0, 18.4)
                for k in range(1440))
    assert north == pytest.approx(61.437, abs=0.01)
    assert south == pytest.approx(32.563, abs=0.01)
    assert sun_elevation_deg(day.replace(hour=23, minute=59), 52.0, 0.0) < 0.0  # midnight
