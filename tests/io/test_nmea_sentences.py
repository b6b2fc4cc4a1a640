"""One NMEA line → values or a classified skip (engine/io/nmea_sentences.py, docs/NMEA.md).

Checksums are computed by tests/nmea_lines.py (XOR, independently of the code); expected
numbers are worked by hand in the comments.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.io.nmea_sentences import NmeaValues, SentenceSkip, SkipKind, parse_nmea_line
from tests.nmea_lines import nmea


def _values(line: str, **kw: object) -> NmeaValues:
    v = parse_nmea_line(line, **kw)  # type: ignore[arg-type]
    assert isinstance(v, NmeaValues), v
    return v


def _skip(line: str, **kw: object) -> SentenceSkip:
    v = parse_nmea_line(line, **kw)  # type: ignore[arg-type]
    assert isinstance(v, SentenceSkip), v
    return v


def test_gga_position_quality_hdop_sats() -> None:
    v = _values(nmea("GNGGA,123519.50,5250.0000,N,00430.6000,W,2,08,0.9,545.4,M,46.9,M,,"))
    # 52° 50.0' = 52 + 50/60 = 52.8333333°; 4° 30.6' W = -(4 + 30.6/60) = -4.51°
    assert v.lat_deg == pytest.approx(52.8333333, abs=1e-7)
    assert v.lon_deg == pytest.approx(-4.51, abs=1e-12)
    # 12:35:19.5 = 12*3600 + 35*60 + 19.5 s of the day
    assert v.time_s == pytest.approx(45319.5, abs=1e-9)
    assert (v.quality, v.sats, v.hdop, v.talker) == (2, 8, 0.9, "GN")


@pytest.mark.parametrize("quality", ["0", "6", "7", "8", ""])
def test_gga_quality_not_a_fix(quality: str) -> None:
    s = _skip(nmea(f"GPGGA,123519,5250.0000,N,00430.0000,E,{quality},08,0.9,5.4,M,46.9,M,,"))
    assert s.kind == SkipKind.NOT_FIX and s.sentence_type == "GGA"


def test_rmc_date_cog_sog_and_invalid_status() -> None:
    v = _values(nmea("GPRMC,235959,A,5250.0000,S,00430.0000,E,022.4,084.4,311299,003.1,W"))
    assert v.date is not None and v.date.isoformat() == "1999-12-31"
    assert (v.time_s, v.sog_kn, v.cog_deg) == (86399.0, 22.4, 84.4)
    assert v.lat_deg == pytest.approx(-52.8333333, abs=1e-7)
    assert _skip(nmea("GPRMC,235959,V,5250.0000,S,00430.0000,E,0,0,311299,,")).kind == \
        SkipKind.NOT_FIX
    # FAA mode E (dead reckoning, estimated) is not a fix
    assert _skip(nmea("GPRMC,235959,A,5250.0000,S,00430.0000,E,0,0,311299,,,E")).kind == \
        SkipKind.NOT_FIX


def test_gll_and_zda() -> None:
    v = _values(nmea("GPGLL,5250.0000,N,00430.0000,E,000001.00,A,A"))
    assert (v.time_s, v.lon_deg) == (1.0, 4.5)
    assert _skip(nmea("GPGLL,5250.0000,N,00430.0000,E,000001.00,V,N")).kind == SkipKind.NOT_FIX
    z = _values(nmea("GPZDA,201530.00,04,07,2002,00,00"))
    assert z.date is not None and z.date.isoformat() == "2002-07-04" and z.time_s == 72930.0


def test_headings() -> None:
    assert _values(nmea("HEHDT,359.9,T")).heading_deg == 359.9
    assert _values(nmea("HEHDT,360.0,T")).heading_deg == 0.0
    # HDG: sensor 100.0 + deviation 2.0 E + variation 3.5 W = 98.5 true
    assert _values(nmea("HCHDG,100.0,2.0,E,3.5,W")).heading_deg == pytest.approx(98.5)
    # without variation: the option's variation (1.5 E): 100 - 2 + 1.5 = 99.5
    assert _values(nmea("HCHDG,100.0,2.0,W,,"), variation_deg=1.5).heading_deg == \
        pytest.approx(99.5)
    no_var = _values(nmea("HCHDG,100.0,2.0,W,,"))
    # none at all: the magnetic heading (100 - 2 = 98) for the epoch builder to make true
    assert (no_var.heading_deg, no_var.magnetic_deg, no_var.variation_deg) == (None, 98.0, None)
    # the sentence's own variation is handed on (a VHW without one may use it)
    assert _values(nmea("HCHDG,100.0,2.0,E,3.5,W")).variation_deg == -3.5
    vhw = _values(nmea("VWVHW,,T,10.0,M,5.1,N,,K"))
    assert (vhw.heading_deg, vhw.magnetic_deg, vhw.stw_kn) == (None, 10.0, 5.1)


def test_rmc_variation_is_read_and_a_bad_one_costs_only_itself() -> None:
    rmc = "GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,{},A"
    assert _values(nmea(rmc.format("003.1,W"))).variation_deg == -3.1
    assert _values(nmea(rmc.format("1.5,E"))).variation_deg == 1.5
    assert _values(nmea(rmc.format(","))).variation_deg is None
    bad = _values(nmea(rmc.format("3.1,X")))
    assert bad.lat_deg is not None and bad.variation_deg is None
    assert bad.notes == ("RMC variation malformed: not used",)


def test_empty_heading_is_no_heading_not_zero() -> None:
    assert nmea("IIHDT,,T") == "$IIHDT,,T*0C"  # the example, checksum by hand
    s = _skip("$IIHDT,,T*0C")
    assert s.kind == SkipKind.EMPTY and s.sentence_type == "HDT"


def test_vhw_vbw_vtg_depth() -> None:
    v = _values(nmea("VWVHW,,T,,M,,N,9.26,K"))
    assert v.heading_deg is None
    assert v.stw_kn == pytest.approx(5.0, abs=1e-12)  # 9.26 km/h / 1.852 = 5.0 kn
    m = _values(nmea("VWVHW,,T,10.0,M,5.1,N,,K"), variation_deg=-2.0)
    assert (m.heading_deg, m.stw_kn) == (8.0, 5.1)
    assert _values(nmea("VWVBW,4.2,0.1,A,4.0,0.2,A")).stw_kn == 4.2
    assert _skip(nmea("VWVBW,4.2,0.1,V,4.0,0.2,A")).kind == SkipKind.EMPTY
    t = _values(nmea("GPVTG,054.7,T,034.4,M,005.5,N,010.2,K,A"))
    assert (t.cog_deg, t.sog_kn) == (54.7, 5.5)
    # DBT without metres: 32.8 ft × 0.3048 = 9.99744 m
    assert _values(nmea("SDDBT,32.8,f,,M,,F")).depth_m == pytest.approx(9.99744, abs=1e-9)
    assert _values(nmea("SDDPT,10.5,0.3")).depth_m == 10.5


@pytest.mark.parametrize(("line", "kind"), [
    ("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*48", SkipKind.BAD_CHECKSUM),
    ("$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", SkipKind.NO_CHECKSUM),
    ("$GPGGA,123519,4807.0", SkipKind.NO_CHECKSUM),
    ("$GPGGA,123519,4807.0*4", SkipKind.MALFORMED),
    ("!AIVDM,1,1,,A,13aEOK?P00PD2wVMdLDRhgvL289?,0*26", SkipKind.AIS),
    ("\x00\x91garbage\xff", SkipKind.NOISE),
    ("hello world", SkipKind.NOT_TEXT),
])
def test_skip_kinds(line: str, kind: str) -> None:
    assert _skip(line).kind == kind


def test_truncated_sentence_with_valid_checksum_is_malformed() -> None:
    assert _skip(nmea("GPGGA,123519,4807.0")).kind == SkipKind.NOT_FIX  # no quality field
    assert _skip(nmea("GPGGA,123519,48x7.0,N,01131.000,E,1,08,0.9,5,M,4,M,,")).kind == \
        SkipKind.MALFORMED
    assert _skip(nmea("GPGGA,123519,4867.0,N,01131.000,E,1,08,0.9,5,M,4,M,,")).kind == \
        SkipKind.MALFORMED  # 67 minutes


def test_unknown_and_proprietary_types_are_counted_by_type() -> None:
    s = _skip(nmea("GPGSV,3,1,11,03,03,111,00"))
    assert (s.kind, s.sentence_type) == (SkipKind.UNKNOWN, "GSV")
    p = _skip(nmea("PGRMC,A,1"))  # Garmin's PGRMC is not an RMC
    assert (p.kind, p.sentence_type) == (SkipKind.UNKNOWN, "PGRMC")


@pytest.mark.parametrize("address", ["PNCTR", "PGRMZ", "PMTK001", "PSRFTXT"])
def test_proprietary_type_is_named_whole(address: str) -> None:
    """The whole address field names a proprietary sentence (PNCTR was counted as PNCT), also
    when it is longer than five characters (PMTK001 was malformed)."""
    p = _skip(nmea(f"{address},1,2"))
    assert (p.kind, p.sentence_type) == (SkipKind.UNKNOWN, address)
    assert p.message.startswith(f"{address}: ")


def test_missing_checksum_accepted_on_request() -> None:
    line = "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"
    assert _values(line, accept_no_checksum=True).quality == 1


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=120))
def test_random_bytes_never_crash(data: bytes) -> None:
    out = parse_nmea_line(data.decode("latin-1"))
    assert out is None or isinstance(out, NmeaValues | SentenceSkip)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(["GGA", "RMC", "GLL", "ZDA", "HDT", "HDG", "VHW", "VBW", "VTG", "DBT",
                        "DPT"]),
       st.lists(st.text(alphabet="0123456789.-NSEWATVMKf ", max_size=12), max_size=16))
def test_random_fields_with_valid_checksum_never_crash(kind: str, fields: list[str]) -> None:
    out = parse_nmea_line(nmea("GP" + kind + "," + ",".join(fields)), variation_deg=1.0)
    assert isinstance(out, NmeaValues | SentenceSkip)


def test_zda_without_date_gives_its_time() -> None:
    # the form some instruments send (e.g. the Signal K sample log of data/nmea)
    assert nmea("GPZDA,095559,,,,00,") == "$GPZDA,095559,,,,00,*4D"
    v = _values("$GPZDA,095559,,,,00,*4D")
    assert (v.time_s, v.date) == (9 * 3600 + 55 * 60 + 59, None)
    assert _skip(nmea("GPZDA,095559,18,,2014,00,00")).kind == SkipKind.MALFORMED
