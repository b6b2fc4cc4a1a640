"""TO_WGS84.DAT: the bundled transcription, the parser's checks and the writer's round trip.

Expected values are read off the thesis text, appendix A8.4 (seed L8800–8871, copy 1
L4077–4088 + L4188–4248) and the A8.2 parameter defaults (seed L8741–8754).
"""

from __future__ import annotations

import math
import pathlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.datumfile import DatumFile, format_datum_file, parse_datum_text, read_datum_file
from engine.ellipsoid import WGS84, Datum, Ellipsoid
from engine.errors import InputError

DATA = pathlib.Path(__file__).resolve().parents[1] / "data"
DAT = DATA / "TO_WGS84.DAT"
DAT_TEXT = DAT.read_text(encoding="utf-8")
DAT_LINES = DAT_TEXT.splitlines()


@pytest.fixture(scope="module")
def df() -> DatumFile:
    return read_datum_file(DAT)


# --------------------------------------------------------------------------- bundled file


def test_counts_and_order(df: DatumFile) -> None:
    # A8.4 lists 19 spheroids and 15 datums, in this order.
    assert len(df.spheroids) == 19
    assert list(df.datums) == [
        "AUSTRALIAN GEODETIC 1966", "AUSTRALIAN GEODETIC 1984", "ED50", "ED50 [DMA]",
        "ED50 [UKOOA]", "ED79", "GRS67", "NAD 1927", "NAD 1983", "OSGB 1936", "TOKYO",
        "WGS72", "WGS72 [DMA]", "WGS84", "ZANDERIJ",
    ]
    assert list(df.spheroids)[0] == "AIRY 1830"
    assert list(df.spheroids)[-1] == "MADRID 1924"


def test_spheroid_values(df: DatumFile) -> None:
    # Exact decimal values as printed in A8.4 section 1.
    assert df.spheroids["AIRY 1830"] == Ellipsoid("AIRY 1830", 6377563.396, 299.3249646)
    assert df.spheroids["CLARKE 1880 MODIFIED"] == Ellipsoid(
        "CLARKE 1880 MODIFIED", 6378249.145, 293.4663
    )
    assert df.spheroids["KRASOVSKY"].a_m == 6378245.0
    assert df.spheroids["INTERNATIONAL"].inv_f == 297.0


def test_ed50_row(df: DatumFile) -> None:
    ed50 = df.datum("ED50")
    assert (ed50.ellipsoid.a_m, ed50.ellipsoid.inv_f) == (6378388.0, 297.0)
    assert (ed50.dx_m, ed50.dy_m, ed50.dz_m) == (-87.0, -98.0, -121.0)
    assert ed50.is_three_parameter
    # Named after the first section-1 spheroid with the same a and 1/f (HAYFORD 1909).
    assert ed50.ellipsoid.name == "HAYFORD 1909"


def test_ed50_matches_a82_defaults(df: DatumFile) -> None:
    # A8.2 default datum block: ED50 axis 6378388, e2 0.00672267002, dX/dY/dZ -87/-98/-121.
    # e2 is printed with 11 decimals, so agree to 5e-12.
    ed50 = df.datum("ED50")
    assert ed50.ellipsoid.e2 == pytest.approx(0.00672267002, abs=5e-12)
    wgs = df.datum("WGS84")
    assert wgs.ellipsoid.a_m == 6378137.0
    assert wgs.ellipsoid.e2 == pytest.approx(0.00669437999, abs=5e-12)


def test_wgs72_dma_seven_parameters(df: DatumFile) -> None:
    d = df.datum("WGS72 [DMA]")
    assert (d.dx_m, d.dy_m, d.dz_m) == (0.0, 0.0, 4.5)
    assert (d.rx_arcsec, d.ry_arcsec, d.rz_arcsec, d.scale_ppm) == (0.0, 0.0, 0.55, 0.22)
    assert not d.is_three_parameter
    # Every other datum has the four extra columns at zero (program.md §5.1).
    others = [x for n, x in df.datums.items() if n != "WGS72 [DMA]"]
    assert all(x.is_three_parameter for x in others)


def test_other_rows(df: DatumFile) -> None:
    assert df.datum("ED50 [UKOOA]").dx_m == -86.0
    assert df.datum("ED50 [UKOOA]").dy_m == -96.0
    tokyo = df.datum("TOKYO")
    assert (tokyo.dx_m, tokyo.dy_m, tokyo.dz_m) == (-128.0, 481.0, 664.0)
    assert tokyo.ellipsoid.name == "BESSEL 1841"
    grs = df.datum("GRS67")
    assert (grs.dx_m, grs.dy_m, grs.dz_m, grs.ellipsoid.inv_f) == (
        59.944, -3.843, 22.932, 298.247167427
    )
    # OSGB 1936 prints 1/f = 299.3249647, AIRY 1830 299.3249646: no match, own name.
    assert df.datum("OSGB 1936").ellipsoid == Ellipsoid("OSGB 1936", 6377563.396, 299.3249647)


def test_wgs84_row_equals_shared_constant(df: DatumFile) -> None:
    assert df.datum("WGS84") == WGS84


def test_lookup_is_case_and_space_insensitive(df: DatumFile) -> None:
    assert df.datum("ed50   [ukooa]") is df.datums["ED50 [UKOOA]"]


def test_unknown_datum(df: DatumFile) -> None:
    # The manual names ED87 (L5296), which the file does not contain (program.md A3).
    with pytest.raises(InputError) as info:
        df.datum("ED87")
    err = info.value
    assert (err.message, err.field, err.text) == ("Unknown datum !", "datum", "ED87")


def test_tolerates_crlf_blank_lines_and_missing_end_marker() -> None:
    text = "\r\n\r\n".join(line for line in DAT_LINES if "End of Data" not in line)
    assert parse_datum_text(text) == read_datum_file(DAT)


def test_file_not_found(tmp_path: pathlib.Path) -> None:
    missing = tmp_path / "NONE.DAT"
    with pytest.raises(InputError) as info:
        read_datum_file(missing)
    assert info.value.message == "File not found !"
    assert info.value.file == str(missing)


# --------------------------------------------------------------------------- writer


def test_round_trip_bundled(df: DatumFile) -> None:
    assert parse_datum_text(format_datum_file(df)) == df


_NAME = st.lists(
    st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789[]-", min_size=1, max_size=8),
    min_size=1, max_size=3,
).map(" ".join).filter(lambda s: not s.startswith("-"))
_FINITE = st.floats(-1e4, 1e4, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    names=st.lists(_NAME, min_size=1, max_size=4, unique_by=str.upper),
    a=st.floats(6_350_000, 6_390_000),
    inv_f=st.floats(250, 320),
    params=st.lists(_FINITE, min_size=7, max_size=7),
)
def test_round_trip_arbitrary_floats(
    names: list[str], a: float, inv_f: float, params: list[float]
) -> None:
    # Values that need more than the printed decimals are written with repr(): still exact.
    datums = {
        n: Datum(n, Ellipsoid(n, a, inv_f), *params) for n in names
    }
    df = DatumFile(spheroids={}, datums=datums)
    assert parse_datum_text(format_datum_file(df)) == df


# --------------------------------------------------------------------------- malformed input


def _replace(line_no: int, new: str) -> str:
    lines = list(DAT_LINES)
    lines[line_no - 1] = new
    return "\n".join(lines)


def _insert(line_no: int, new: str) -> str:
    lines = list(DAT_LINES)
    lines.insert(line_no - 1, new)
    return "\n".join(lines)


ED50 = 37  # line of the ED50 row in data/TO_WGS84.DAT
AIRY = 6  # line of AIRY 1830

BAD_CASES = [
    ("a not a number", _replace(ED50, "ED50 6378388.0x 297 -87 -98 -121 0 0 0 0"),
     ED50, "a", "Not a number !", "6378388.0x"),
    ("1/f not a number", _replace(AIRY, "AIRY 1830 6377563.396 abc"),
     AIRY, "1/f", "Not a number !", "abc"),
    ("dX nan", _replace(ED50, "ED50 6378388 297 nan -98 -121 0 0 0 0"),
     ED50, "dX", "Not a number !", "nan"),
    ("scale not a number", _replace(ED50, "ED50 6378388 297 -87 -98 -121 0 0 0 0.2.2"),
     ED50, "scale", "Not a number !", "0.2.2"),
    ("a negative", _replace(ED50, "ED50 -6378388 297 -87 -98 -121 0 0 0 0"),
     ED50, "a", "Semi-major axis must be between 6300000 and 6400000 m !", "-6378388"),
    ("spheroid 1/f missing", _replace(AIRY, "AIRY 1830 6377563.396"),
     AIRY, "a", "Semi-major axis must be between 6300000 and 6400000 m !", "1830"),
    ("1/f below 1", _replace(AIRY, "AIRY 1830 6377563.396 0.5"),
     AIRY, "1/f", "Inverse flattening must be 0 (sphere) or > 1 !", "0.5"),
    ("datum row too short", _replace(ED50, "ED50 6378388 297 -87 -98 -121 0 0 0"),
     ED50, "record", "Too few fields, expected NAME a 1/f dX dY dZ Rx Ry Rz scale !",
     "ED50 6378388 297 -87 -98 -121 0 0 0"),
    ("datum row with a column missing", _replace(38, "ED50 [DMA] 6378388 297 -87 -98 -121 0 0 0"),
     38, "a", "Not a number !", "[DMA]"),
    ("duplicate datum", _replace(38, "ed50  6378388 297 -87 -98 -121 0 0 0 0"),
     38, "name", "Duplicate datum name !", "ed50"),
    ("duplicate spheroid", _replace(AIRY + 1, "AIRY 1830 6377563.396 299.3249646"),
     AIRY + 1, "name", "Duplicate spheroid name !", "AIRY 1830"),
    ("data before a section", "HOUGH 6378270 297\n" + DAT_TEXT,
     1, "section", "Data line before any section header !", "HOUGH 6378270 297"),
    ("data after End of Data", DAT_TEXT + "ED87 6378388 297 -82.981 -99.719 -110.709 0 0 0 0\n",
     52, "section", "Data after 'End of Data' (line 51) !",
     "ED87 6378388 297 -82.981 -99.719 -110.709 0 0 0 0"),
    ("datum row in spheroid section", _insert(AIRY, "ED50 6378388 297 -87 -98 -121 0 0 0 0"),
     AIRY, "section", "Datum row in the spheroid section (missing section header?) !",
     "ED50 6378388 297 -87 -98 -121 0 0 0 0"),
    ("no datums", "* reference spheroids\nHOUGH 6378270 297\n* End of Data\n",
     3, "section", "No datums in file !", None),
]


@pytest.mark.parametrize(
    ("text", "line", "field", "message", "got"),
    [case[1:] for case in BAD_CASES],
    ids=[case[0] for case in BAD_CASES],
)
def test_malformed(text: str, line: int, field: str, message: str, got: str | None) -> None:
    with pytest.raises(InputError) as info:
        parse_datum_text(text, filename="TO_WGS84.DAT")
    err = info.value
    assert (err.file, err.line, err.field, err.message, err.text) == (
        "TO_WGS84.DAT", line, field, message, got
    )
    assert str(err).startswith(f"TO_WGS84.DAT:{line}: {field}: {message}")


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_fuzz_only_input_errors(data: st.DataObject) -> None:
    lines = list(DAT_LINES)
    for _ in range(data.draw(st.integers(1, 4))):
        k = data.draw(st.integers(0, len(lines) - 1))
        op = data.draw(st.sampled_from(["delete", "duplicate", "garble", "truncate"]))
        if op == "delete":
            del lines[k]
        elif op == "duplicate":
            lines.insert(k, lines[k])
        elif op == "garble":
            lines[k] = data.draw(st.text(max_size=40))
        else:
            lines[k] = lines[k][: data.draw(st.integers(0, len(lines[k])))]
        if not lines:
            lines = [""]
    try:
        result = parse_datum_text("\n".join(lines))
    except InputError as err:
        assert err.file == "<string>" and err.message
        return
    assert all(math.isfinite(d.ellipsoid.a_m) for d in result.datums.values())
