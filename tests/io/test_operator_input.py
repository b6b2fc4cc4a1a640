"""Operator-input parsers: the six thesis position forms (L7728–7750) and the error messages."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.formatting import format_dms_input
from engine.io.operator_input import (
    lanes_from_zone_lane,
    parse_bearing_deg,
    parse_datum_name,
    parse_depth_m,
    parse_direction_deg,
    parse_distance_nm,
    parse_latitude,
    parse_longitude,
    parse_position,
    parse_run_name,
    parse_speed_kn,
    parse_zone_lane,
    zone_lane_of,
)

# Hand-computed: 34'24.735" = 34/60 + 24.735/3600 = 0.566666… + 0.006870833… = 0.5735375 deg.
SIX_FORMS = [
    ("52 30 00.000 N 003 34 24.735 E", 52.5, 3.5735375),
    ("52 30 00 N 003 34 24 E", 52.5, 3.0 + 2064.0 / 3600.0),  # 34'24" = 2064"
    ("52 30.0 N 003 34.3 E", 52.5, 3.0 + 34.3 / 60.0),  # 3.571666…
    ("52 30 N 003 34 E", 52.5, 3.0 + 34.0 / 60.0),  # 3.566666…
    ("52.3 N 003.7 E", 52.3, 3.7),
    ("52 N 003 E", 52.0, 3.0),
]


@pytest.mark.parametrize(("text", "lat", "lon"), SIX_FORMS)
def test_six_thesis_forms(text: str, lat: float, lon: float) -> None:
    got = parse_position(text)
    assert got == pytest.approx((lat, lon), abs=1e-12)


def test_six_forms_decimal_values() -> None:
    # The same values written out as decimals, as a second, independent statement.
    assert parse_position("52 30 00 N 003 34 24 E")[1] == pytest.approx(3.5733333333333)
    assert parse_position("52 30.0 N 003 34.3 E")[1] == pytest.approx(3.5716666666667)
    assert parse_position("52 30 N 003 34 E")[1] == pytest.approx(3.5666666666667)


@pytest.mark.parametrize(
    ("text", "lat", "lon"),
    [
        ("52,30,00.000,N,003,34,24.735,E", 52.5, 3.5735375),  # commas as separators
        ("52, 30, N, 3, 34, E", 52.5, 3.0 + 34.0 / 60.0),  # comma + blank
        ("52 30 00 N 3.7 E", 52.5, 3.7),  # mixed forms: D M S with D.d
        ("52.5 N 003 34 24.735 E", 52.5, 3.5735375),  # mixed forms: D.d with D M S.sss
        ("52 30 n 003 34 e", 52.5, 3.0 + 34.0 / 60.0),  # lower case
        ("52 30 N 3 34 E", 52.5, 3.0 + 34.0 / 60.0),  # no leading zeros
        ("052 030 00 N 0003 034 E", 52.5, 3.0 + 34.0 / 60.0),  # extra leading zeros
        ("  52   30 N   003  34  E  ", 52.5, 3.0 + 34.0 / 60.0),  # runs of blanks
        ("33 52 30 S 151 12 36 E", -(33 + 52.5 / 60), 151.21),  # Sydney: S negative
        ("51 30 N 000 07.5 W", 51.5, -0.125),  # W negative
        ("0 N 0 E", 0.0, 0.0),
        ("90 N 180 W", 90.0, -180.0),
    ],
)
def test_separators_mixed_forms_case_and_signs(text: str, lat: float, lon: float) -> None:
    assert parse_position(text) == pytest.approx((lat, lon), abs=1e-12)


def test_single_latitude_and_longitude() -> None:
    assert parse_latitude("52 50 32.373 N") == pytest.approx(52 + 50 / 60 + 32.373 / 3600)
    assert parse_longitude("004 31 50.958 e") == pytest.approx(4 + 31 / 60 + 50.958 / 3600)
    assert parse_latitude("0 S") == 0.0 and math.copysign(1.0, parse_latitude("0 S")) == 1.0


POS = "Wrong position input format !"

MALFORMED = [
    # (parser, text, message, field)
    (parse_position, "52 30 00 003 34 24 E", POS, "position"),  # latitude letter missing
    (parse_position, "52 30 00 N", POS, "position"),  # longitude missing
    (parse_position, "91 00 N 003 E", POS, "position"),  # lat > 90
    (parse_position, "90 00 01 N 003 E", POS, "position"),  # lat > 90 by one second
    (parse_position, "52 60 N 003 E", POS, "position"),  # minutes = 60
    (parse_position, "52 30 60 N 003 E", POS, "position"),  # seconds = 60
    (parse_position, "52.5 30 N 003 E", POS, "position"),  # decimals before the last field
    (parse_position, "-52 30 N 003 E", POS, "position"),  # negative number
    (parse_position, "52 30 E 003 34 N", POS, "position"),  # hemispheres swapped
    (parse_position, "52 30 00 00 N 003 E", POS, "position"),  # four components
    (parse_position, "", POS, "position"),
    (parse_position, "52,,30 N 003 E", POS, "position"),  # empty field
    (parse_position, "52 30 X 003 E", POS, "position"),  # bad hemisphere letter
    (parse_position, "52 30 N 003 34 E 1", POS, "position"),  # trailing garbage
    (parse_longitude, "181 W", POS, "longitude"),
    (parse_latitude, "52 30 E", POS, "latitude"),
    (parse_bearing_deg, "361", "Wrong bearing input !", "bearing"),
    (parse_bearing_deg, "-5", "Wrong bearing input !", "bearing"),
    (parse_bearing_deg, "N45E", "Wrong bearing input !", "bearing"),
    (parse_distance_nm, "0", "Wrong distance input !", "distance"),
    (parse_distance_nm, "3 nm", "Wrong distance input !", "distance"),
    (parse_distance_nm, "10800.001", "Wrong distance input !", "distance"),
    (parse_distance_nm, "100000", "Wrong distance input !", "distance"),
    (parse_speed_kn, "61", "Wrong speed input !", "speed"),
    (parse_speed_kn, "", "Wrong speed input !", "speed"),
    (parse_direction_deg, "400", "Wrong direction input !", "direction"),
    (parse_depth_m, "1000.5", "Wrong depth input !", "depth"),
    (parse_run_name, "92/09 17", "Wrong file name !", "run file"),
    # Only ASCII digits, '.', spaces, tabs and commas belong to the numeric grammars:
    (parse_position, "52\u200330 N 003 E", POS, "position"),  # em space
    (parse_position, "52\xa030 N 003 E", POS, "position"),  # no-break space
    (parse_position, "52 30 N\x1c003 E", POS, "position"),  # U+001C (str.split() splits on it)
    (parse_position, "\u200352 30 N 003 E", POS, "position"),  # leading em space
    (parse_position, "+52 30 N 003 E", POS, "position"),
    (parse_position, "5_2 30 N 003 E", POS, "position"),
    (parse_position, "٥٢ 30 N 003 E", POS, "position"),  # Arabic-Indic digits
    (parse_position, "52 30 ſ 003 E", POS, "position"),  # 'ſ'.upper() == 'S'
    (parse_bearing_deg, "\u200345", "Wrong bearing input !", "bearing"),
    (parse_bearing_deg, "4_5", "Wrong bearing input !", "bearing"),
    (parse_bearing_deg, "+45", "Wrong bearing input !", "bearing"),
    (parse_distance_nm, "1e1", "Wrong distance input !", "distance"),
    (parse_speed_kn, "١٢", "Wrong speed input !", "speed"),
    (parse_depth_m, "inf", "Wrong depth input !", "depth"),
    (parse_direction_deg, "90\xa0", "Wrong direction input !", "direction"),
]


@pytest.mark.parametrize(("parser", "text", "message", "field"), MALFORMED)
def test_malformed_inputs(parser, text: str, message: str, field: str) -> None:
    with pytest.raises(InputError) as caught:
        parser(text)
    assert caught.value.message == message
    assert caught.value.field == field
    assert caught.value.text == text


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("K20", "red"),
        ("B24", "red"),
        ("F29", "green"),
        ("F48", "green"),
        ("A80", "purple"),
        ("B20.5", "red"),
        ("20B", "red"),
        ("", "green"),
        ("A49", "purple"),
        ("B\u200320", "red"),
        ("B٢٠", "red"),
        ("B+20", "red"),
    ],
)
def test_malformed_zone_lane(text: str, pattern: str) -> None:
    with pytest.raises(InputError) as caught:
        parse_zone_lane(text, pattern)
    assert caught.value.message == "Wrong zone/lane input !"
    assert caught.value.field == pattern
    assert caught.value.text == text


def test_unknown_datum() -> None:
    with pytest.raises(InputError) as caught:
        parse_datum_name("ED51", ["ED50", "WGS84"])
    assert (caught.value.message, caught.value.field, caught.value.text) == (
        "Unknown datum !",
        "datum",
        "ED51",
    )


def test_valid_numbers() -> None:
    assert parse_bearing_deg("360") == 0.0
    assert parse_bearing_deg(" 232.3 ") == 232.3
    assert parse_direction_deg("90") == 90.0
    assert parse_distance_nm(".5") == 0.5
    assert parse_distance_nm("10800") == 10800.0  # half the Earth's circumference: the bound
    assert parse_speed_kn("12.7") == 12.7
    assert parse_speed_kn("0") == 0.0
    assert parse_depth_m("1000") == 1000.0


def test_zone_lane_and_names() -> None:
    assert parse_zone_lane("B20", "red") == (1, 20)
    assert parse_zone_lane("f34", "green") == (5, 34)
    assert parse_zone_lane("A51", "purple") == (0, 51)
    assert parse_zone_lane("J79", "Purple") == (9, 79)
    assert parse_datum_name("ed50  [dma]", ["ED50", "ED50 [DMA]"]) == "ED50 [DMA]"
    assert parse_run_name("920917_1") == "920917_1"
    assert parse_run_name("920917_1.run") == "920917_1"


def test_total_lane_counts_of_the_sample() -> None:
    # THEORY §3.3: Red B20.862 → 1·24 + 20 + .862; Green F34.337, c = 1 → 15·18 + 4 + .337;
    # Purple A51.111 → 0·30 + 1 + .111 (Pg 810 prints 44.862 274.337 1.111).
    assert lanes_from_zone_lane(1, 20, 0.862, "red", 0) == pytest.approx(44.862)
    assert lanes_from_zone_lane(5, 34, 0.337, "green", 1) == pytest.approx(274.337)
    assert lanes_from_zone_lane(0, 51, 0.111, "purple", 0) == pytest.approx(1.111)
    assert lanes_from_zone_lane(5, 34, 0.337, "green", 0) == pytest.approx(94.337)


def test_zone_lane_of_inverts() -> None:
    letter, lane = zone_lane_of(44.862, "red")
    assert letter == "B" and lane == pytest.approx(20.862)
    letter, lane = zone_lane_of(274.337, "green")
    assert letter == "F" and lane == pytest.approx(34.337)
    letter, lane = zone_lane_of(1.111, "purple")
    assert letter == "A" and lane == pytest.approx(51.111)


_HALF_MILLI_ARCSEC_DEG = 0.0005 / 3600.0


@settings(max_examples=300, deadline=None)
@given(
    st.floats(min_value=-90.0, max_value=90.0, allow_nan=False),
    st.floats(min_value=-180.0, max_value=180.0, allow_nan=False),
)
def test_dms_input_round_trip(lat: float, lon: float) -> None:
    text = format_dms_input(lat, lon)
    got_lat, got_lon = parse_position(text)
    assert abs(got_lat - lat) <= _HALF_MILLI_ARCSEC_DEG + 1e-12
    assert abs(got_lon - lon) <= _HALF_MILLI_ARCSEC_DEG + 1e-12


_POSITION_ALPHABET = st.sampled_from(
    list("0123456789 ,.NSEWnsew-+x°'\"\t_e") + ["\u2003", "\xa0", "\x1c", "٣", "²", "ſ"]
)
# The characters of the position grammar (thesis L7728–7750): ASCII digits, '.', hemisphere
# letters, and spaces, tabs or commas between the fields. Written out here, not imported.
_POSITION_CHARS = set("0123456789.NSEWnsew ,\t")


@settings(max_examples=400, deadline=None)
@given(st.one_of(st.text(max_size=40), st.text(_POSITION_ALPHABET, max_size=40)))
def test_arbitrary_text_raises_only_input_error(text: str) -> None:
    try:
        lat, lon = parse_position(text)
    except InputError as err:
        assert err.message == POS and err.text == text
    else:
        assert -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0
        assert set(text) <= _POSITION_CHARS, text


@settings(max_examples=300, deadline=None)
@given(st.text(_POSITION_ALPHABET, max_size=8))
def test_accepted_plain_numbers_are_plain_decimals(text: str) -> None:
    # Bearings, distances, speeds, depths: an accepted text is blanks + an ASCII decimal.
    for parser in (parse_bearing_deg, parse_speed_kn, parse_depth_m, parse_distance_nm):
        try:
            value = parser(text)
        except InputError:
            continue
        assert re.fullmatch(r"[ \t]*(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)[ \t]*", text), text
        number = float(text.strip(" \t"))
        assert value == (number % 360.0 if parser is parse_bearing_deg else number)  # 360 → 0


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([t for t, _, _ in SIX_FORMS]), st.data())
def test_mutated_positions_stay_in_the_grammar(text: str, data: st.DataObject) -> None:
    # Valid forms with one or two characters replaced or inserted: accepted only if the result
    # still uses the grammar's characters (random text alone rarely comes close to a position).
    chars = list(text)
    for _ in range(data.draw(st.integers(1, 2))):
        k = data.draw(st.integers(0, len(chars)))
        new = data.draw(_POSITION_ALPHABET)
        if k < len(chars) and data.draw(st.booleans()):
            chars[k] = new
        else:
            chars.insert(k, new)
    mutated = "".join(chars)
    try:
        parse_position(mutated)
    except InputError as err:
        assert err.message == POS and err.text == mutated
    else:
        assert set(mutated) <= _POSITION_CHARS, mutated
