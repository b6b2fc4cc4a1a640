"""Screen formats against the thesis sample screens (A8.5; THEORY §12.7–12.10, §14.2)."""

from __future__ import annotations

import datetime as dt
import math

import pytest

from engine.io.formatting import (
    PLACEHOLDER,
    format_angle_deg,
    format_dms_input,
    format_lat_dm,
    format_lat_dms,
    format_lon_dm,
    format_lon_dms,
    format_metres,
    format_speed_kn,
    format_stat,
    format_time_z,
    format_zone_lane,
)


def dms(d: int, m: int, s: float) -> float:
    return d + m / 60.0 + s / 3600.0


# The LSE/MPP of the sample (Pg 100/631/641): 52°50'32.373" N 004°31'50.958" E.
LSE_LAT = dms(52, 50, 32.373)
LSE_LON = dms(4, 31, 50.958)


def test_full_positions_pg100() -> None:
    assert format_lat_dms(LSE_LAT) == "52°50'32.373\" N"
    assert format_lon_dms(LSE_LON) == "004°31'50.958\" E"
    # Pg 611: the GPS fix converted to ED50, and the WGS84 fix.
    assert format_lat_dms(dms(52, 50, 32.777)) == "52°50'32.777\" N"
    assert format_lon_dms(dms(4, 31, 51.052)) == "004°31'51.052\" E"
    assert format_lat_dms(dms(52, 50, 30.0)) == "52°50'30.000\" N"
    assert format_lon_dms(dms(4, 31, 46.2)) == "004°31'46.200\" E"
    # Pg 631/641 footer: the central meridian.
    assert format_lon_dms(5.0) == "005°00'00.000\" E"
    assert format_lat_dms(LSE_LAT, space=False) == "52°50'32.373\"N"


def test_side_column_is_the_same_mpp_in_decimal_minutes() -> None:
    # Side column "MPP 52°50.54'N 004°31.85'E": 32.373" = 0.53955', 50.958" = 0.8493'.
    assert format_lat_dm(LSE_LAT) == "52°50.54'N"
    assert format_lon_dm(LSE_LON) == "004°31.85'E"
    assert format_lon_dm(5.0) == "005°00.00'E"  # "CM 005°00.00'E"
    # Pg 100 GPS box (with a space): the WGS84 fix 52°50'30.000" / 004°31'46.200" = 46.2/60'.
    assert format_lat_dm(dms(52, 50, 30.0), space=True) == "52°50.50' N"
    assert format_lon_dm(dms(4, 31, 46.2), space=True) == "004°31.77' E"


def test_zone_lane_pg100() -> None:
    # Pg 810 total lane counts 44.862 274.337 1.111 → Pg 100 "Red B20.9 Green F34.3 Purple A51.1".
    assert format_zone_lane(44.862, "red") == "B20.9"
    assert format_zone_lane(274.337, "green") == "F34.3"
    assert format_zone_lane(1.111, "purple") == "A51.1"
    assert format_zone_lane(44.862, "red", decimals=3) == "B20.862"


def test_small_fields() -> None:
    assert format_speed_kn(12.7) == "12.7kts"
    # Az of the major axis: eigenvector (0.92721, −0.37455) → atan2(0.92721, −0.37455) = 112.0°.
    assert format_angle_deg(math.degrees(math.atan2(0.92721, -0.37455))) == "112.0°"
    # RMS of the four LOP residuals (THEORY §12.7): √((12.46²+1.846²+1.6²+0.3²)/4) = 6.35.
    rms = math.sqrt((12.46**2 + 1.846**2 + 1.6**2 + 0.3**2) / 4)
    assert format_metres(rms) == "6.35 m"
    assert format_metres(rms, space=False) == "6.35m"
    # 95 % semi-axes from the Pg 641 VCV [[814.936, −298.408], [−298.408, 196.755]]:
    # λ = 505.8455 ± √(309.0905² + 298.408²), k = √(−2 ln 0.05) → "a / b : 74.87m 21.37m".
    mean, half = (814.936 + 196.755) / 2, (814.936 - 196.755) / 2
    root = math.sqrt(half**2 + 298.408**2)
    k95 = math.sqrt(-2.0 * math.log(0.05))
    assert format_metres(k95 * math.sqrt(mean + root), space=False) == "74.87m"
    assert format_metres(k95 * math.sqrt(mean - root), space=False) == "21.37m"
    assert format_time_z(dt.datetime(1992, 9, 17, 8, 35, 39)) == "08:35:39Z"
    assert format_time_z(dt.time(8, 35, 39)) == "08:35:39Z"


def test_rounding_carries() -> None:
    assert format_lat_dms(dms(52, 59, 59.9996)) == "53°00'00.000\" N"
    assert format_lat_dms(dms(52, 59, 59.9994)) == "52°59'59.999\" N"
    assert format_lon_dms(dms(4, 59, 59.9996)) == "005°00'00.000\" E"
    assert format_lat_dm(52 + 59.996 / 60) == "53°00.00'N"
    assert format_lon_dm(179 + 59.999 / 60) == "180°00.00'E"
    assert format_zone_lane(47.96, "red") == "C0.0"  # Red lane 23.96 → next zone
    assert format_zone_lane(287.99, "green") == "G30.0"  # 16·18 = 288


def test_hemispheres_and_zero() -> None:
    assert format_lat_dms(-dms(33, 52, 30.0)) == "33°52'30.000\" S"
    assert format_lon_dms(-dms(0, 7, 30.0)) == "000°07'30.000\" W"
    assert format_lat_dm(-33.5) == "33°30.00'S"
    assert format_lon_dm(-0.125) == "000°07.50'W"
    assert format_lat_dms(0.0) == "00°00'00.000\" N"
    assert format_lon_dm(0.0) == "000°00.00'E"
    # A tiny negative value that rounds to zero is printed as N/E, not S/W.
    assert format_lat_dms(-1e-9) == "00°00'00.000\" N"
    assert format_lon_dm(-1e-9) == "000°00.00'E"


def test_placeholder_statistics() -> None:
    assert PLACEHOLDER == "999.99"
    assert format_stat(None, 8, 2) == "  999.99"
    assert format_stat(math.nan, 6, 2) == "999.99"
    assert format_stat(52.0917, 7, 2) == "  52.09"  # σ_d of the GPS latitude row, Pg 633
    assert format_stat(-0.001, 6, 2) == "  0.00"


def test_dms_input_form() -> None:
    assert format_dms_input(dms(52, 50, 0.0), 4.5) == "52 50 00.000 N 004 30 00.000 E"
    assert format_dms_input(-dms(33, 52, 30.0), -151.21) == "33 52 30.000 S 151 12 36.000 W"


def test_non_finite_angle_is_rejected() -> None:
    with pytest.raises(ValueError):
        format_lat_dms(math.nan)
