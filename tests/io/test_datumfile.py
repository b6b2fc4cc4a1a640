"""TO_WGS84.DAT: the bundled transcription, the parser's checks and the writer's round trip.

Expected values are read off the thesis text, appendix A8.4 (seed L8800–8871, copy 1
L4077–4088 + L4188–4248) and the A8.2 parameter defaults (seed L8741–8754).
"""

from __future__ import annotations

import math
import pathlib
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.geodesy.ellipsoid import WGS84, Datum, Ellipsoid
from engine.io.datumfile import DatumFile, format_datum_file, parse_datum_text, read_datum_file
from tests.paths import DATA

DAT = DATA / "TO_WGS84.DAT"
DAT_TEXT = DAT.read_text(encoding="utf-8")
DAT_LINES = DAT_TEXT.splitlines()

# The "Geodetic datum data file" block of thesis A8.4 (seed L8802–8871), copied verbatim from
# the thesis text (tabs and the blank lines of the extraction included), independently of
# data/TO_WGS84.DAT. It prints "ED50 [UK00A]" with zeros; the data file reads it as UKOOA,
# the spelling of the manual's datum list (README).
THESIS_DAT = """\
*

* Parameters of reference spheroids

*

* Update : 29/01/92

*

AIRY 1830	6377563.396	299.3249646
AIRY MODIFIED	6377340.189	299.3249646
AUSTRALIAN NATIONAL	6378160	298.25
BESSEL 1841	6377397.155	299.1528128
BESSEL MODIFIED	6377492.018	299.1528
CLARKE 1858	6378235.6	294.2606768
CLARKE 1866	6378206.4	294.9786982
CLARKE 1880	6378249.145	293.465
CLARKE 1880 MODIFIED	6378249.145	293.4663
EVEREST	6377276.345	300.8017
EVEREST MODIFIED	6377304.063	300.8017
FISCHER 1960	6378166	298.3
FISCHER 1968	6378150	298.3
HAYFORD 1909	6378388	297
HELMERT 1906	6378200	298.3
HOUGH	6378270	297
INTERNATIONAL	6378388	297
KRASOVSKY	6378245	298.3
MADRID 1924	6378388	297

*

*

*

* Transformation parameters of Datums

*

* Datum ==> WGS84

*

* Update : 08/11/91

*

*

AUSTRALIAN GEODETIC 1966	6378160.000	298.25	-133.000	-48.000	148.000	0.00	0.00	0.00	0.00
AUSTRALIAN GEODETIC 1984	6378160.000	298.25	-134.000	-48.000	149.000	0.00	0.00	0.00	0.00
ED50	6378388.000	297	-87.000	-98.000	-121.000	0.00	0.00	0.00	0.00
ED50 [DMA]	6378388.000	297	-87.000	-98.000	-121.000	0.00	0.00	0.00	0.00
ED50 [UK00A]	6378388.000	297	-86.000	-96.000	-120.000	0.00	0.00	0.00	0.00
ED79	6378388.000	297	-86.000	-98.000	-119.000	0.00	0.00	0.00	0.00
GRS67	6378160.000	298.247167427	59.944	-3.843	22.932	0.00	0.00	0.00	0.00

NAD 1927	6378206.400	294.9786982	-8.000	160.000	176.000	0.00	0.00	0.00	0.00
NAD 1983	6378137.000	298.257222101	0.000	0.000	0.000	0.00	0.00	0.00	0.00
OSGB 1936	6377563.396	299.3249647	375.000	-111.000	431.000	0.00	0.00	0.00	0.00
TOKYO	6377397.155	299.1528128	-128.000	481.000	664.000	0.00	0.00	0.00	0.00
WGS72	6378135.000	298.26	0.000	0.000	0.000	0.00	0.00	0.00	0.00
WGS72 [DMA]	6378135.000	298.26	0.000	0.000	4.500	0.00	0.00	0.55	0.22
WGS84	6378137.000	298.257223563	0.000	0.000	0.000	0.00	0.00	0.00	0.00
ZANDERIJ	6378388.000	297	-265.000	120.000	-358.000	0.00	0.00	0.00	0.00

*

* End of Data
"""  # noqa: E501 (two thesis lines are wider than 100 columns with tabs of 8)
THESIS_DAT_LINES = [ln for ln in THESIS_DAT.splitlines() if ln.strip()]


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
    # Every other datum has the four extra columns at zero (THEORY §13.1).
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
    # The manual names ED87 (L5296), which the file does not contain (THEORY D2).
    with pytest.raises(InputError) as info:
        df.datum("ED87")
    err = info.value
    assert (err.message, err.field, err.text) == ("Unknown datum !", "datum", "ED87")


def test_tolerates_crlf_and_blank_lines() -> None:
    assert parse_datum_text("\r\n\r\n".join(DAT_LINES)) == read_datum_file(DAT)


def test_missing_end_marker_is_an_error() -> None:
    # Issue 15: a file cut short must not load (a cut inside a number reads another number).
    text = "\n".join(line for line in DAT_LINES if "End of Data" not in line)
    with pytest.raises(InputError) as info:
        parse_datum_text(text, "TO_WGS84.DAT")
    err = info.value
    assert (err.line, err.field, err.message) == (
        50, "section", "No '* End of Data' line: the file is cut short !")


def test_file_not_found(tmp_path: pathlib.Path) -> None:
    missing = tmp_path / "NONE.DAT"
    with pytest.raises(InputError) as info:
        read_datum_file(missing)
    assert info.value.message == "File not found !"
    assert info.value.file == str(missing)


# --------------------------------------------------------------------------- transcription


def test_data_file_is_the_thesis_block_token_by_token() -> None:
    # Every non-blank line, token by token; the only difference allowed is UK00A -> UKOOA.
    thesis = [ln.replace("[UK00A]", "[UKOOA]") for ln in THESIS_DAT_LINES]
    ours = [ln for ln in DAT_LINES if ln.strip()]
    assert len(ours) == len(thesis) == 51
    for mine, theirs in zip(ours, thesis, strict=True):
        assert mine.split() == theirs.split()
    assert sum("[UK00A]" in ln for ln in THESIS_DAT_LINES) == 1


def _thesis_rows() -> tuple[list[tuple[str, list[float]]], list[tuple[str, list[float]]]]:
    """(spheroid rows, datum rows) of the thesis copy as (name, numbers), by a minimal reading:
    section 2 starts at its "Transformation parameters" comment."""
    spheroids: list[tuple[str, list[float]]] = []
    datums: list[tuple[str, list[float]]] = []
    rows = spheroids
    for line in THESIS_DAT_LINES:
        if line.startswith("*"):
            if "Transformation parameters" in line:
                rows = datums
            continue
        tokens = line.split("\t")  # the thesis separates the name and each number by a tab
        rows.append((tokens[0].replace("[UK00A]", "[UKOOA]"), [float(t) for t in tokens[1:]]))
    return spheroids, datums


def test_every_value_equals_the_thesis_block(df: DatumFile) -> None:
    spheroids, datums = _thesis_rows()
    assert [name for name, _ in spheroids] == list(df.spheroids)
    assert [name for name, _ in datums] == list(df.datums)
    for name, (a, inv_f) in spheroids:
        assert (df.spheroids[name].a_m, df.spheroids[name].inv_f) == (a, inv_f)
    for name, values in datums:
        d = df.datums[name]
        assert [d.ellipsoid.a_m, d.ellipsoid.inv_f, d.dx_m, d.dy_m, d.dz_m,
                d.rx_arcsec, d.ry_arcsec, d.rz_arcsec, d.scale_ppm] == values


# --------------------------------------------------------------------------- writer


def test_round_trip_bundled(df: DatumFile) -> None:
    assert parse_datum_text(format_datum_file(df)) == df


_NAME = st.lists(
    st.text(alphabet="ABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789[]-", min_size=1, max_size=8),
    min_size=1, max_size=3,
).map(" ".join).filter(lambda s: not s.startswith("-"))
_FINITE = st.floats(-1000, 1000, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(
    names=st.lists(_NAME, min_size=1, max_size=4, unique_by=str.upper),
    a=st.floats(6_376_000, 6_379_000),
    inv_f=st.floats(290, 310),
    params=st.tuples(*[_FINITE] * 3, *[st.floats(-30, 30)] * 3, st.floats(-50, 50)),
)
def test_round_trip_arbitrary_floats(
    names: list[str], a: float, inv_f: float, params: list[float]
) -> None:
    # Values that need more than the printed decimals are written with every digit of repr(),
    # in positional notation (the grammar has no exponent): still exact.
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
     ED50, "a", "Semi-major axis must be between 6376000 and 6379000 m !", "-6378388"),
    ("spheroid 1/f missing", _replace(AIRY, "AIRY 1830 6377563.396"),
     AIRY, "a", "Semi-major axis must be between 6376000 and 6379000 m !", "1830"),
    ("1/f below 1", _replace(AIRY, "AIRY 1830 6377563.396 0.5"),
     AIRY, "1/f", "Inverse flattening must be between 290 and 310 !", "0.5"),
    # Issue 15: values the parser accepted before, each putting the MPP thousands of km off.
    ("a digit flipped", _replace(ED50, "ED50 6373388 297 -87 -98 -121 0 0 0 0"),
     ED50, "a", "Semi-major axis must be between 6376000 and 6379000 m !", "6373388"),
    ("1/f digit flipped", _replace(ED50, "ED50 6378388 397 -87 -98 -121 0 0 0 0"),
     ED50, "1/f", "Inverse flattening must be between 290 and 310 !", "397"),
    ("dX a million metres", _replace(ED50, "ED50 6378388 297 -1000000 -98 -121 0 0 0 0"),
     ED50, "dX", "dX must be between -1000 and 1000 m !", "-1000000"),
    ("dZ digit added", _replace(ED50, "ED50 6378388 297 -87 -98 -1121 0 0 0 0"),
     ED50, "dZ", "dZ must be between -1000 and 1000 m !", "-1121"),
    ("rotation 9999999", _replace(ED50, "ED50 6378388 297 -87 -98 -121 0 0 9999999 0"),
     ED50, "Rz", 'Rz must be between -30 and 30 " !', "9999999"),
    ("scale 99999999", _replace(ED50, "ED50 6378388 297 -87 -98 -121 0 0 0 99999999"),
     ED50, "scale", "scale must be between -50 and 50 ppm !", "99999999"),
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
    # Numbers float() takes but the grammar does not (plain ASCII decimals, '-' only):
    ("dX plus sign", _replace(ED50, "ED50 6378388 297 +87 -98 -121 0 0 0 0"),
     ED50, "dX", "Not a number !", "+87"),
    ("dY underscore", _replace(ED50, "ED50 6378388 297 -87 -9_8 -121 0 0 0 0"),
     ED50, "dY", "Not a number !", "-9_8"),
    ("a exponent", _replace(ED50, "ED50 6.378388e6 297 -87 -98 -121 0 0 0 0"),
     ED50, "a", "Not a number !", "6.378388e6"),
    ("dZ Arabic-Indic digits", _replace(ED50, "ED50 6378388 297 -87 -98 -١٢١ 0 0 0 0"),
     ED50, "dZ", "Not a number !", "-١٢١"),
    ("Rx infinity", _replace(ED50, "ED50 6378388 297 -87 -98 -121 inf 0 0 0"),
     ED50, "Rx", "Not a number !", "inf"),
    ("spheroid 1/f exponent", _replace(AIRY, "AIRY 1830 6377563.396 2.993249646E2"),
     AIRY, "1/f", "Not a number !", "2.993249646E2"),
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


_PLAIN = re.compile(r"-?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)")
_NUMBER_CHARS = st.sampled_from(list("0123456789.-+eE_ ") + ["٣", "²", "inf", "nan"])


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_fuzz_only_input_errors(data: st.DataObject) -> None:
    lines = list(DAT_LINES)
    for _ in range(data.draw(st.integers(1, 4))):
        k = data.draw(st.integers(0, len(lines) - 1))
        op = data.draw(st.sampled_from(["delete", "duplicate", "garble", "truncate", "insert"]))
        if op == "delete":
            del lines[k]
        elif op == "duplicate":
            lines.insert(k, lines[k])
        elif op == "garble":
            lines[k] = data.draw(st.text(max_size=40))
        elif op == "insert":  # a character float() might accept, inside a number
            pos = data.draw(st.integers(0, len(lines[k])))
            lines[k] = lines[k][:pos] + data.draw(_NUMBER_CHARS) + lines[k][pos:]
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
    # Every data line accepted ends in plain ASCII decimals (the grammar, written out here).
    for line in lines:
        tokens = line.split()
        if tokens and not line.strip().startswith("*"):
            assert all(_PLAIN.fullmatch(t) for t in tokens[-2:]), line
