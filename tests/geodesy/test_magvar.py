"""Magnetic variation from IGRF-14 (engine/geodesy/magvar.py) against published values.

Reference values: the NOAA NCEI magnetic field calculator
(https://www.ngdc.noaa.gov/geomag/calculators/magcalc.shtml), model IGRF, sea level, as
recorded in the online tests of the open-source Python package ``demag`` (declination in
degrees, east positive, to 0.01°). For 2015-10-15 NOAA used IGRF-12, whose 2015–2020 secular
variation was a forecast; IGRF-13/14 replaced it with the definitive DGRF 2015 and 2020, which
moves the declination by a few hundredths of a degree: tolerance 0.1°. For 1990 and 2007 both
generations use the same definitive models: tolerance 0.02° (the calculator's rounding and
interpolation).
"""

from __future__ import annotations

from datetime import UTC, date, datetime

import pytest

from engine.geodesy.magvar import MODEL, declination_deg, model_covers

NOAA_2015 = [  # (lat, lon, D) on 2015-10-15
    (0.0, 0.0, -5.338),
    (0.0, -45.0, -20.34),
    (0.0, -180.0, 9.58),
    (0.0, 90.0, -2.03),
    (45.0, 0.0, -0.15),
    (45.0, 90.0, 2.36),
    (45.0, -90.0, -2.36),
    (-45.0, 0.0, -22.21),
    (-45.0, 90.0, -41.67),
    (-45.0, -90.0, 21.46),
]


@pytest.mark.parametrize(("lat", "lon", "d_deg"), NOAA_2015)
def test_igrf_declination_matches_noaa_2015(lat: float, lon: float, d_deg: float) -> None:
    assert declination_deg(lat, lon, date(2015, 10, 15)) == pytest.approx(d_deg, abs=0.1)


@pytest.mark.parametrize(("year", "d_deg"), [(1990, 22.36), (2007, 21.80)])
def test_igrf_declination_matches_noaa_definitive_years(year: int, d_deg: float) -> None:
    assert declination_deg(-45.0, -90.0, date(year, 10, 15)) == pytest.approx(d_deg, abs=0.02)


def test_markermeer_receivers_own_variation() -> None:
    """The Markermeer log (data/nmea, 2016-08-15, 52°29.6'N 5°17.8'E) carries its
    instrument's variation, 0.9°E, in every HDG; that instrument's model is unknown and it
    rounds to 0.1°, so this is a sanity check (0.5°), not a reference."""
    d = declination_deg(52.49, 5.30, datetime(2016, 8, 15, 12, 0, tzinfo=UTC))
    assert d == pytest.approx(0.9, abs=0.5)


def test_outside_the_model_is_none_and_silent(capsys: pytest.CaptureFixture[str]) -> None:
    """ppigrf prints a warning for dates outside its coefficients: never reached."""
    assert MODEL == "IGRF-14"
    assert model_covers(date(1900, 1, 1)) and model_covers(date(2029, 12, 31))
    assert not model_covers(date(1899, 12, 31)) and not model_covers(date(2030, 1, 1))
    assert declination_deg(52.0, 5.0, date(1899, 12, 31)) is None
    assert declination_deg(52.0, 5.0, date(2030, 1, 1)) is None
    assert declination_deg(float("nan"), 5.0, date(2020, 1, 1)) is None
    assert capsys.readouterr() == ("", "")
