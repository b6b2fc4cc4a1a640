"""NMEA 0183 writer (engine/io/nmea_write.py): every sentence parsed back by pynmea2.

Independent sources: pynmea2 (parser and checksum check, ``check=True``), the classic GGA example
of the NMEA literature with its published checksum, and hand-written expected strings.
Tolerances are the quantisation of the format: a position is rounded to 1e-4 minute, so the
parsed value is within half a step, 0.5e-4/60 degree (≈ 0.093 m), plus 1e-12 degree for the
floating-point arithmetic of the parser; times to 0.01 s (within 0.005 s); headings, speeds and
depths to one decimal (within 0.05).
"""

from __future__ import annotations

import math
from datetime import UTC, date, datetime, timedelta

import pynmea2
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.io import nmea_write as w

HALF_STEP_DEG = 0.5e-4 / 60.0 + 1e-12
T0 = datetime(2026, 12, 2, 12, 34, 56, 789000, tzinfo=UTC)


def parsed(text: str) -> pynmea2.NMEASentence:
    """Parse with the checksum verified (pynmea2 raises ChecksumError otherwise)."""
    assert "\r" not in text and "\n" not in text
    return pynmea2.parse(text, check=True)


def test_checksum_of_the_classic_gga_example() -> None:
    # The GGA example of the NMEA literature (e.g. gpsinformation.org), checksum 47.
    body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"
    assert w.checksum(body) == "47"


def test_empty_heading_matches_the_issue_text() -> None:
    # issue 13: "$IIHDT,,T*0C" is "no heading"
    assert w.hdt(None, talker="II") == "$IIHDT,,T*0C"
    assert parsed(w.hdt(None)).heading is None


@pytest.mark.parametrize("bad", [("G", "GGA"), ("gp", "GGA"), ("GP", "GG"), ("GP", "Gga")])
def test_sentence_refuses_bad_talker_or_kind(bad: tuple[str, str]) -> None:
    with pytest.raises(ValueError):
        w.sentence(bad[0], bad[1], [])


@pytest.mark.parametrize("field", ["a,b", "a*b", "$", "é", "a\r", "!"])
def test_sentence_refuses_reserved_characters(field: str) -> None:
    with pytest.raises(ValueError):
        w.sentence("GP", "TXT", [field])


def test_sentence_refuses_more_than_82_characters_with_crlf() -> None:
    assert len(w.sentence("GP", "TXT", ["x" * 70])) == 80
    with pytest.raises(ValueError):
        w.sentence("GP", "TXT", ["x" * 71])


@pytest.mark.parametrize(
    ("lat", "text", "hemi"),
    [
        (52.5, "5230.0000", "N"),
        (-33.8568, "3351.4080", "S"),
        (52 + 59.99995 / 60, "5300.0000", "N"),  # carries into the degree
        (52 + 59.99994 / 60, "5259.9999", "N"),
        (-0.4e-4 / 60, "0000.0000", "N"),  # rounds to zero: no "S"
        (90.0, "9000.0000", "N"),
        (-90.0, "9000.0000", "S"),
    ],
)
def test_latitude_format(lat: float, text: str, hemi: str) -> None:
    assert w.format_lat(lat) == (text, hemi)


@pytest.mark.parametrize(
    ("lon", "text", "hemi"),
    [
        (4.52, "00431.2000", "E"),
        (-4.52, "00431.2000", "W"),
        (-(179 + 59.99996 / 60), "18000.0000", "E"),  # 180° W is 180° E
        (181.0, "17900.0000", "W"),
        (-0.0, "00000.0000", "E"),
        (9 + 59.99995 / 60, "01000.0000", "E"),
    ],
)
def test_longitude_format(lon: float, text: str, hemi: str) -> None:
    assert w.format_lon(lon) == (text, hemi)


@pytest.mark.parametrize("lat", [90.0001, -91.0, math.nan, math.inf])
def test_latitude_out_of_range(lat: float) -> None:
    with pytest.raises(ValueError):
        w.format_lat(lat)


def test_time_carries_into_the_next_day_and_year() -> None:
    t = datetime(2026, 12, 31, 23, 59, 59, 996000, tzinfo=UTC)
    s = parsed(w.rmc(t, 52.0, 4.0, sog_kn=1.0, cog_deg=10.0))
    assert s.timestamp.isoformat() == "00:00:00+00:00"
    assert s.datestamp == date(2027, 1, 1)
    z = parsed(w.zda(t))
    assert (z.day, z.month, z.year) == (1, 1, 2027)


def test_naive_time_is_utc_and_aware_time_is_converted() -> None:
    from datetime import timezone

    cet = timezone(timedelta(hours=1))
    assert w.format_time(datetime(2026, 1, 1, 13, 0, 0, tzinfo=cet)) == "120000.00"
    assert w.format_time(datetime(2026, 1, 1, 13, 0, 0)) == "130000.00"


def test_gga_fields() -> None:
    s = parsed(w.gga(T0, 52.84219, -4.53, quality=2, sats=9, hdop=0.84, altitude_m=3.25,
                     geoid_sep_m=46.9, talker="IN"))
    assert s.talker == "IN" and s.sentence_type == "GGA"
    assert s.gps_qual == 2 and int(s.num_sats) == 9
    assert float(s.horizontal_dil) == pytest.approx(0.8, abs=1e-9)  # 0.84 → 0.8
    assert s.altitude == pytest.approx(3.2, abs=0.051) and s.altitude_units == "M"
    assert float(s.geo_sep) == pytest.approx(46.9)
    assert abs(s.latitude - 52.84219) <= HALF_STEP_DEG
    assert abs(s.longitude - (-4.53)) <= HALF_STEP_DEG
    assert s.timestamp.isoformat() == "12:34:56.790000+00:00"


def test_gga_without_a_fix_has_empty_position() -> None:
    text = w.gga(T0, None, None, quality=0, sats=0, hdop=None)
    assert text.startswith("$GPGGA,123456.79,,,,,0,00,,")
    s = parsed(text)
    assert s.gps_qual == 0 and s.lat == ""


@pytest.mark.parametrize("q", [-1, 9])
def test_gga_quality_out_of_range(q: int) -> None:
    with pytest.raises(ValueError):
        w.gga(T0, 0.0, 0.0, quality=q, sats=5, hdop=1.0)


def test_rmc_fields() -> None:
    s = parsed(w.rmc(T0, -12.5, 130.25, sog_kn=12.345, cog_deg=359.96, valid=False, mode="E",
                     variation_deg=-2.04))
    assert s.status == "V" and s.mode_indicator == "E"
    assert s.spd_over_grnd == pytest.approx(12.3) and s.true_course == pytest.approx(0.0)
    assert s.datestamp == date(2026, 12, 2)
    assert s.mag_variation == "2.0" and s.mag_var_dir == "W"
    assert abs(s.latitude + 12.5) <= HALF_STEP_DEG and abs(s.longitude - 130.25) <= HALF_STEP_DEG


def test_rmc_refuses_negative_speed() -> None:
    with pytest.raises(ValueError):
        w.rmc(T0, 0.0, 0.0, sog_kn=-0.1, cog_deg=0.0)


def test_gll_fields() -> None:
    s = parsed(w.gll(T0, 1.0, 2.0, valid=True, mode="A"))
    assert s.status == "A" and s.faa_mode == "A"
    assert abs(s.latitude - 1.0) <= HALF_STEP_DEG and abs(s.longitude - 2.0) <= HALF_STEP_DEG


def test_gst_fields() -> None:
    s = parsed(w.gst(T0, rms_m=None, major_sigma_m=12.345, minor_sigma_m=3.0, major_az_deg=200.0,
                     lat_sigma_m=10.0, lon_sigma_m=7.5))
    assert s.std_dev_major == pytest.approx(12.35, abs=0.0051)
    assert s.orientation == pytest.approx(20.0)  # an ellipse axis: 200° is 20°
    assert s.std_dev_altitude is None


def test_hdt_vhw_vtg_dbt_values() -> None:
    assert float(parsed(w.hdt(123.456)).heading) == pytest.approx(123.5)
    v = parsed(w.vhw(359.99, 7.25))
    assert float(v.heading_true) == 0.0
    assert float(v.water_speed_knots) == pytest.approx(7.2, abs=0.051)
    assert float(v.water_speed_km) == pytest.approx(7.25 * 1.852, abs=0.05)
    g = parsed(w.vtg(45.0, 3.0, mode="D"))
    assert g.true_track == 45.0 and float(g.spd_over_grnd_kts) == 3.0 and g.faa_mode == "D"
    d = parsed(w.dbt(25.0))
    # 25 m = 82.02 ft = 13.67 fathoms (hand calculation: /0.3048, /1.8288)
    assert float(d.depth_meters) == 25.0
    assert float(d.depth_feet) == pytest.approx(82.0)
    assert float(d.depth_fathoms) == pytest.approx(13.7)


def test_empty_values_write_empty_fields() -> None:
    assert parsed(w.vhw(None, None)).water_speed_knots is None
    assert parsed(w.dbt(None)).depth_meters is None
    assert parsed(w.vtg(None, None)).true_track is None


# RMC's ddmmyy has a two-digit year: pynmea2 reads it with strptime's %y (69–99 → 19xx), so
# the round trip holds for 1980 (GPS time zero) to 2068; ZDA carries the four-digit year.
times = st.datetimes(min_value=datetime(1980, 1, 6), max_value=datetime(2068, 12, 31),
                     timezones=st.just(UTC))


@settings(max_examples=300, deadline=None)
@given(lat=st.floats(-90.0, 90.0), lon=st.floats(-180.0, 180.0), t=times)
def test_property_position_and_time_round_trip(lat: float, lon: float, t: datetime) -> None:
    """Any position and instant survives GGA, RMC and GLL within the format's quantisation."""
    for text in (w.gga(t, lat, lon, quality=1, sats=8, hdop=1.0),
                 w.rmc(t, lat, lon, sog_kn=0.0, cog_deg=0.0),
                 w.gll(t, lat, lon)):
        s = parsed(text)
        assert abs(s.latitude - lat) <= HALF_STEP_DEG
        dlon = math.remainder(s.longitude - lon, 360.0)  # 180° W is written 180° E
        assert abs(dlon) <= HALF_STEP_DEG
    r = parsed(w.rmc(t, lat, lon, sog_kn=0.0, cog_deg=0.0))
    back = datetime.combine(r.datestamp, r.timestamp)
    assert abs((back - t).total_seconds()) <= 0.005 + 1e-9
    z = parsed(w.zda(t))
    back_z = datetime(z.year, z.month, z.day, tzinfo=UTC) + (
        datetime.combine(date.min, z.timestamp.replace(tzinfo=None)) - datetime.min)
    assert abs((back_z - t).total_seconds()) <= 0.005 + 1e-9
