"""DECCA.CHN: the bundled transcription, the parser's checks and the writer's round trip.

Expected values are read off the thesis text, appendix A8.4 (seed L8873–8969, copy 1
L4090–4186), plus the Decca frequency ratios of §4 (master 6f0, red 8f0, green 9f0, purple 5f0).
"""

from __future__ import annotations

import math
import pathlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.errors import InputError
from engine.io.deccafile import (
    DeccaChain,
    DeccaStation,
    format_chain_file,
    format_dms,
    parse_chain_text,
    parse_dms,
    read_chain_file,
)
from tests.paths import DATA

CHN = DATA / "DECCA.CHN"
CHN_TEXT = CHN.read_text(encoding="utf-8")
CHN_LINES = CHN_TEXT.splitlines()

# The "Decca chain data file" block of thesis A8.4 (seed L8875–8969), copied verbatim from the
# thesis text (the blank lines of the extraction included), independently of data/DECCA.CHN.
THESIS_CHN = """\
* Decca chain data

*

* Frisian Islands Chain (chain 9B)

*

9B

53 12 12.388 N 007 06 00.590 E 85.7200

* Master : Finsterwolde

55 01 07.110 N 008 41 38.420 E 114.2930

* Red : Hoyer

52 35 30.089 N 004 43 47.118 E 128.5800

* Green : Heiloo

53 17 07.219 N 009 15 48.858 E 71.4333

* Purple : Zeven

ED50

* Geodetic Datum

0

* Min. lanecount - Red

0

* Min. lanecount - Green

0

* Min. Lanecount - Purple

299550.000

* Assumed signal prop. speed

*

* Holland Chain (chain 2E)

*

2E

51 36 36.629 N 004 55 36.521 E 84.5500

* Master : Gilze-Rijen

52 35 24.325 N 004 44 37.086 E 112.7333

* Red : Heiloo

51 13 27.506 N 003 51 41.203 E 126.8250

* Green : Sas v. Gent

52 11 11.350 N 001 35 46.272 E 70.4583

* Purple : Thorpeness

ED50

* Geodetic Datum

-3.920

* Min. lanecount - Red

3.205

* Min. lanecount - Green

0

* Min. lanecount - Purple

299550.000

* Assumed signal prop. speed

*

*

* End of Data
"""
THESIS_CHN_LINES = [ln for ln in THESIS_CHN.splitlines() if ln.strip()]


def dms(d: int, m: int, s: float) -> float:
    return d + m / 60 + s / 3600


@pytest.fixture(scope="module")
def chains() -> dict[str, DeccaChain]:
    return read_chain_file(CHN)


# --------------------------------------------------------------------------- bundled file


def test_two_chains_in_file_order(chains: dict[str, DeccaChain]) -> None:
    assert list(chains) == ["9B", "2E"]
    assert chains["9B"].name == "Frisian Islands"
    assert chains["2E"].name == "Holland"


def test_9b_master_finsterwolde(chains: dict[str, DeccaChain]) -> None:
    m = chains["9B"].master
    assert m == DeccaStation("master", "Finsterwolde", dms(53, 12, 12.388), dms(7, 6, 0.590),
                             85.72)


def test_9b_all_stations(chains: dict[str, DeccaChain]) -> None:
    c = chains["9B"]
    assert [s.name for s in (c.master, *c.slaves)] == ["Finsterwolde", "Hoyer", "Heiloo", "Zeven"]
    assert [s.role for s in (c.master, *c.slaves)] == ["master", "red", "green", "purple"]
    assert c.red.lat_deg == dms(55, 1, 7.110) and c.red.lon_deg == dms(8, 41, 38.420)
    assert c.green.lat_deg == dms(52, 35, 30.089) and c.green.lon_deg == dms(4, 43, 47.118)
    assert c.purple.lat_deg == dms(53, 17, 7.219) and c.purple.lon_deg == dms(9, 15, 48.858)
    assert [s.freq_khz for s in c.slaves] == [114.293, 128.58, 71.4333]
    assert c.datum_name == "ED50"
    assert c.min_lanes == (0.0, 0.0, 0.0)
    assert c.speed_km_s == 299550.0


def test_2e_chain(chains: dict[str, DeccaChain]) -> None:
    c = chains["2E"]
    assert [s.name for s in (c.master, *c.slaves)] == [
        "Gilze-Rijen", "Heiloo", "Sas v. Gent", "Thorpeness"
    ]
    assert c.master.lat_deg == dms(51, 36, 36.629) and c.master.freq_khz == 84.55
    # Heiloo is 2E's Red slave at slightly different coordinates than 9B's Green.
    assert (c.red.lat_deg, c.red.lon_deg) == (dms(52, 35, 24.325), dms(4, 44, 37.086))
    assert c.purple.lon_deg == dms(1, 35, 46.272) and c.purple.freq_khz == 70.4583
    assert c.min_lanes == (-3.920, 3.205, 0.0)
    assert c.datum_name == "ED50" and c.speed_km_s == 299550.0


@pytest.mark.parametrize("chain_id", ["9B", "2E"])
def test_frequencies_are_harmonics_of_f0(chains: dict[str, DeccaChain], chain_id: str) -> None:
    # Master 6 f0, Red 8 f0, Green 9 f0, Purple 5 f0 (thesis §4, THEORY §3.2). The file prints
    # 4 decimals in kHz, so each f/n agrees with master/6 to 1e-4 kHz; a mistyped digit fails.
    c = chains[chain_id]
    f0 = c.master.freq_khz / 6
    for station, n in zip(c.slaves, (8, 9, 5), strict=True):
        assert station.freq_khz / n == pytest.approx(f0, abs=1e-4)


def test_9b_comparison_wavelengths(chains: dict[str, DeccaChain]) -> None:
    # THEORY §3.2: lambda_c = v / f_c with f_c = 3 f_R, 2 f_G, 6 f_P: 873.632, 1164.839, 698.904 m
    # (printed to 1 mm, so 1e-3 m tolerance).
    c = chains["9B"]
    lam = [c.speed_km_s / (k * s.freq_khz) for k, s in zip((3, 2, 6), c.slaves, strict=True)]
    assert lam == pytest.approx([873.632, 1164.839, 698.904], abs=1e-3)


def test_station_lookup(chains: dict[str, DeccaChain]) -> None:
    c = chains["9B"]
    assert c.station("red") is c.red
    assert c.station("G") is c.green
    assert c.station(" Purple ") is c.purple
    assert c.station("master") is c.master
    with pytest.raises(InputError) as info:
        c.station("blue")
    assert (info.value.message, info.value.field) == ("Unknown Decca pattern !", "pattern")


def test_dms_helpers() -> None:
    assert parse_dms("52", "50", "33.020", "S", True, "x") == -dms(52, 50, 33.020)
    assert parse_dms("004", "31", "51.134", "w", False, "x") == -dms(4, 31, 51.134)
    assert format_dms(dms(4, 31, 51.134), False) == "004 31 51.134 E"
    assert format_dms(-dms(52, 50, 33.020), True) == "52 50 33.020 S"
    # 59.9996" rounds to the next minute, carried (not "60.000").
    assert format_dms(dms(52, 59, 59.9996), True) == "53 00 00.000 N"


def test_tolerates_crlf() -> None:
    assert parse_chain_text("\r\n".join(CHN_LINES)) == read_chain_file(CHN)


def test_missing_end_marker_is_an_error() -> None:
    # Issue 15: a file cut short must not load (a cut inside the last speed read "29955").
    text = "\n".join(line for line in CHN_LINES if "End of Data" not in line)
    with pytest.raises(InputError) as info:
        parse_chain_text(text, "DECCA.CHN")
    err = info.value
    assert (err.line, err.field, err.message) == (
        47, "section", "No '* End of Data' line: the file is cut short !")


def test_file_not_found(tmp_path: pathlib.Path) -> None:
    with pytest.raises(InputError) as info:
        read_chain_file(tmp_path / "NONE.CHN")
    assert info.value.message == "File not found !"


# --------------------------------------------------------------------------- transcription


def test_data_file_is_the_thesis_block_token_by_token() -> None:
    ours = [ln for ln in CHN_LINES if ln.strip()]
    assert len(ours) == len(THESIS_CHN_LINES) == 48
    for mine, theirs in zip(ours, THESIS_CHN_LINES, strict=True):
        assert mine.split() == theirs.split()


def _thesis_blocks() -> list[tuple[list[str], list[str]]]:
    """Per chain of the thesis copy: its 10 data lines (id, 4 stations, datum, 3 minimum lane
    counts, speed) and the comment texts after the station lines (the station names)."""
    blocks: list[tuple[list[str], list[str]]] = []
    data: list[str] = []
    names: list[str] = []
    after_station = False
    for line in THESIS_CHN_LINES:
        if line.startswith("*"):
            if after_station:
                names.append(line.split(":", 1)[1].strip())
            after_station = False
            continue
        data.append(line)
        after_station = len(line.split()) == 9
        if len(data) == 10:
            blocks.append((data, names))
            data, names = [], []
    return blocks


def test_every_value_equals_the_thesis_block(chains: dict[str, DeccaChain]) -> None:
    blocks = _thesis_blocks()
    assert [data[0] for data, _ in blocks] == list(chains)
    for data, names in blocks:
        c = chains[data[0]]
        stations = (c.master, c.red, c.green, c.purple)
        assert [s.name for s in stations] == names
        for stn, line in zip(stations, data[1:5], strict=True):
            t = line.split()
            assert (t[3], t[7]) == ("N", "E")  # both chains lie north and east
            # d + m/60 + s/3600 as the parser computes it: equal to 1e-12 deg (float rounding).
            assert stn.lat_deg == pytest.approx(dms(int(t[0]), int(t[1]), float(t[2])), abs=1e-12)
            assert stn.lon_deg == pytest.approx(dms(int(t[4]), int(t[5]), float(t[6])), abs=1e-12)
            assert stn.freq_khz == float(t[8])
        assert c.datum_name == data[5]
        assert c.min_lanes == tuple(float(x) for x in data[6:9])
        assert c.speed_km_s == float(data[9])


# --------------------------------------------------------------------------- datums


def test_chain_datums_are_checked_against_the_datum_file() -> None:
    # A chain datum must be a TO_WGS84.DAT name: reported at the chain file's datum line.
    with pytest.raises(InputError) as info:
        parse_chain_text(_replace(14, "XX50"), "DECCA.CHN", known_datums=["ED50", "WGS84"])
    err = info.value
    assert (err.file, err.line, err.field, err.message, err.text) == (
        "DECCA.CHN", 14, "datum", "Unknown datum !", "XX50")
    # Known names are matched like the datum file's own lookup and returned in its spelling.
    chains = parse_chain_text(_replace(36, "ed50"), known_datums=["ED50 [DMA]", "ED50"])
    assert chains["2E"].datum_name == "ED50"


# --------------------------------------------------------------------------- writer


def test_round_trip_bundled(chains: dict[str, DeccaChain]) -> None:
    text = format_chain_file(chains)
    assert parse_chain_text(text) == chains
    # The written station lines are the thesis lines verbatim.
    for line in CHN_LINES[5:13:2] + CHN_LINES[27:35:2]:
        assert line in text.splitlines()


_WORDS = st.text(alphabet="abcdefghijklmnopqrstuvwxyzABC.-' ", min_size=0, max_size=20).map(
    lambda s: " ".join(s.split())
)


def _dms_float(value: float, is_lat: bool) -> float:
    """The float a chain file yields for ``value`` (written to 0.001″ and read back)."""
    return parse_dms(*format_dms(value, is_lat).split(), is_lat, "latitude" if is_lat else "x")


@st.composite
def _chain(draw: st.DrawFn, chain_id: str) -> DeccaChain:
    # Only physically valid chains (docs/DATAFILES.md): f0 in 13.9-14.5 kHz with the slaves its
    # harmonics, baselines 40-300 km, |k| below the lanes on the baseline (>= 66 for 40 km).
    mas = 3_600_000
    lat0 = draw(st.integers(-70 * mas, 70 * mas)) / mas
    lon0 = draw(st.integers(-170 * mas, 170 * mas)) / mas
    f0 = draw(st.integers(139_000, 145_000)) / 10_000
    freqs = [round(n * f0, 4) for n in (6, 8, 9, 5)]
    positions = [(_dms_float(lat0, True), _dms_float(lon0, False))]
    for _ in range(3):
        # A slave 45-290 km away on a random bearing (spherical direct problem, 6371 km).
        d = draw(st.floats(45.0, 290.0)) / 6371.0
        az = math.radians(draw(st.floats(0.0, 360.0)))
        p1 = math.radians(positions[0][0])
        p2 = math.asin(math.sin(p1) * math.cos(d) + math.cos(p1) * math.sin(d) * math.cos(az))
        dl = math.atan2(math.sin(az) * math.sin(d) * math.cos(p1),
                        math.cos(d) - math.sin(p1) * math.sin(p2))
        lat, lon = _dms_float(math.degrees(p2), True), _dms_float(lon0 + math.degrees(dl), False)
        positions.append((lat, lon))
    roles = [DeccaStation(r, draw(_WORDS), lat, lon, f)
             for r, (lat, lon), f in zip(("master", "red", "green", "purple"), positions, freqs,
                                         strict=True)]
    k = st.floats(-30, 30)
    return DeccaChain(
        chain_id, draw(_WORDS), *roles, draw(st.sampled_from(["ED50", "WGS84", "ED50 [DMA]"])),
        (draw(k), draw(k), draw(k)), draw(st.floats(299_000, 299_792.458)),
    )


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_round_trip_generated(data: st.DataObject) -> None:
    ids = data.draw(st.lists(st.sampled_from(["9B", "2E", "5B", "0A", "X1"]), min_size=1,
                             max_size=3, unique=True))
    chains = {i: data.draw(_chain(i)) for i in ids}
    assert parse_chain_text(format_chain_file(chains)) == chains


# --------------------------------------------------------------------------- malformed input


def _replace(line_no: int, new: str) -> str:
    lines = list(CHN_LINES)
    lines[line_no - 1] = new
    return "\n".join(lines)


def _delete(line_no: int) -> str:
    lines = list(CHN_LINES)
    del lines[line_no - 1]
    return "\n".join(lines)


MASTER = 6  # line of the 9B master station
SPEED = 22  # line of the 9B propagation speed
END = 48  # * End of Data

BAD_CASES = [
    ("minutes 61", _replace(MASTER, "53 61 12.388 N 007 06 00.590 E 85.7200"),
     MASTER, "latitude", "Minutes must be < 60 !", "53 61 12.388 N"),
    ("seconds 60", _replace(MASTER, "53 12 60.000 N 007 06 00.590 E 85.7200"),
     MASTER, "latitude", "Seconds must be in [0, 60) !", "53 12 60.000 N"),
    ("latitude 91", _replace(MASTER, "91 00 00.000 N 007 06 00.590 E 85.7200"),
     MASTER, "latitude", "Latitude must be <= 90 degrees !", "91 00 00.000 N"),
    ("longitude 181", _replace(MASTER, "53 12 12.388 N 181 06 00.590 E 85.7200"),
     MASTER, "longitude", "Longitude must be <= 180 degrees !", "181 06 00.590 E"),
    ("longitude hemisphere", _replace(MASTER, "53 12 12.388 N 007 06 00.590 X 85.7200"),
     MASTER, "longitude", "Hemisphere must be E or W !", "007 06 00.590 X"),
    ("latitude hemisphere swapped", _replace(MASTER, "53 12 12.388 E 007 06 00.590 N 85.7200"),
     MASTER, "latitude", "Hemisphere must be N or S !", "53 12 12.388 E"),
    ("frequency zero", _replace(MASTER, "53 12 12.388 N 007 06 00.590 E 0"),
     MASTER, "frequency", "Frequency must be > 0 kHz !", "0"),
    ("frequency text", _replace(MASTER, "53 12 12.388 N 007 06 00.590 E 85,72"),
     MASTER, "frequency", "Not a number !", "85,72"),
    ("station too short", _replace(8, "55 01 07.110 N 008 41 38.420 E"),
     8, "red station",
     "Red station line needs 9 fields: DD MM SS.sss N DDD MM SS.sss E f[kHz] !",
     "55 01 07.110 N 008 41 38.420 E"),
    ("station line missing", _delete(12),
     13, "purple station",
     "Purple station line needs 9 fields: DD MM SS.sss N DDD MM SS.sss E f[kHz] !", "ED50"),
    ("datum missing", _replace(14, "0"), 14, "datum", "Datum name expected !", "0"),
    ("lane count text", _replace(18, "zero"), 18, "min lane count", "Not a number !", "zero"),
    ("lane counts on one line", _replace(16, "0 0 0"),
     16, "min lane count", "Expected one number on this line !", "0 0 0"),
    ("speed negative", _replace(SPEED, "-299550"), SPEED, "propagation speed",
     "Propagation speed must be in [299000, 299792.458] km/s !", "-299550"),
    ("speed above c", _replace(SPEED, "300000"), SPEED, "propagation speed",
     "Propagation speed must be in [299000, 299792.458] km/s !", "300000"),
    # Issue 15: DECCA.CHN cut at byte 398 read the 9B speed as 29955 (a 24 km error).
    ("speed cut short", _replace(SPEED, "29955"), SPEED, "propagation speed",
     "Propagation speed must be in [299000, 299792.458] km/s !", "29955"),
    ("master frequency off the Decca band",
     _replace(MASTER, "53 12 12.388 N 007 06 00.590 E 8.572"), MASTER, "frequency",
     "Master frequency must be 6 f0 with f0 in [13.9, 14.5] kHz (83.4-87.0 kHz) !", "8.572"),
    ("red frequency not 8 f0", _replace(8, "55 01 07.110 N 008 41 38.420 E 114.2830"),
     8, "frequency", "Red frequency must be 8 f0 = 114.2933 kHz (f0 = master / 6) !",
     "114.2830"),
    ("purple slave on the master", _replace(12, "53 12 12.388 N 007 06 00.590 E 71.4333"),
     12, "purple station",
     "Purple slave 0.0 km from the master: a baseline must be 40-300 km !", None),
    ("green slave a continent away", _replace(10, "12 35 30.089 N 004 43 47.118 E 128.5800"),
     10, "green station",
     "Green slave 4520.7 km from the master: a baseline must be 40-300 km !", None),
    ("min lane count beyond the baseline", _replace(16, "600"), 16, "min lane count",
     "Min. lane count must be smaller than the 520 lanes on the red baseline !", "600"),
    ("chain id two words", _replace(5, "9 B"),
     5, "chain id", "Chain id expected (one word, e.g. 9B) !", "9 B"),
    ("chain id numeric", _replace(5, "9"),
     5, "chain id", "Chain id expected (one word, e.g. 9B) !", "9"),
    ("duplicate chain id", _replace(27, "9B"), 27, "chain id", "Duplicate chain id !", "9B"),
    ("truncated at End of Data", _delete(44),
     END - 1, "propagation speed",
     "Truncated chain block (started line 27), propagation speed missing !", "2E"),
    ("truncated at end of file", "\n".join(CHN_LINES[:30]),
     30, "green station",
     "Truncated chain block (started line 27), green station missing !", "2E"),
    ("data after End of Data", CHN_TEXT + "5B\n",
     END + 1, "section", "Data after 'End of Data' (line 48) !", "5B"),
    ("no chains", "* Decca chain data\n* End of Data\n",
     2, "section", "No chains in file !", None),
    # Numbers float() takes but the grammar does not (plain ASCII decimals, '-' only):
    ("frequency exponent", _replace(MASTER, "53 12 12.388 N 007 06 00.590 E 8.572e1"),
     MASTER, "frequency", "Not a number !", "8.572e1"),
    ("frequency plus sign", _replace(MASTER, "53 12 12.388 N 007 06 00.590 E +85.72"),
     MASTER, "frequency", "Not a number !", "+85.72"),
    ("latitude degrees underscore", _replace(MASTER, "5_3 12 12.388 N 007 06 00.590 E 85.72"),
     MASTER, "latitude", "Wrong latitude format (D M S.sss N|S) !", "5_3 12 12.388 N"),
    ("longitude minutes Arabic-Indic",
     _replace(MASTER, "53 12 12.388 N 007 ٠٦ 00.590 E 85.72"),
     MASTER, "longitude", "Wrong longitude format (D M S.sss E|W) !", "007 ٠٦ 00.590 E"),
    ("lane count underscore", _replace(16, "1_0"), 16, "min lane count", "Not a number !", "1_0"),
    ("speed exponent", _replace(SPEED, "2.9955e5"), SPEED, "propagation speed",
     "Not a number !", "2.9955e5"),
    ("speed infinity", _replace(SPEED, "inf"), SPEED, "propagation speed",
     "Not a number !", "inf"),
]


@pytest.mark.parametrize(
    ("text", "line", "field", "message", "got"),
    [case[1:] for case in BAD_CASES],
    ids=[case[0] for case in BAD_CASES],
)
def test_malformed(text: str, line: int, field: str, message: str, got: str | None) -> None:
    with pytest.raises(InputError) as info:
        parse_chain_text(text, filename="DECCA.CHN")
    err = info.value
    assert (err.file, err.line, err.field, err.message, err.text) == (
        "DECCA.CHN", line, field, message, got
    )
    assert str(err).startswith(f"DECCA.CHN:{line}: {field}: {message}")


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_fuzz_only_input_errors(data: st.DataObject) -> None:
    lines = list(CHN_LINES)
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
        result = parse_chain_text("\n".join(lines))
    except InputError as err:
        assert err.file == "<string>" and err.message
        return
    for chain in result.values():
        for s in (chain.master, *chain.slaves):
            assert -90 <= s.lat_deg <= 90 and -180 <= s.lon_deg <= 180 and s.freq_khz > 0


def test_names_without_label_comments() -> None:
    # A user-written block: no "Assumed speed" label before the next chain's name comment,
    # and a station without a name comment.
    text = CHN_TEXT.replace("* Assumed signal prop. speed\n*\n* Holland", "* Holland")
    text = text.replace("* Red : Hoyer\n", "")
    chains = parse_chain_text(text)
    assert chains["2E"].name == "Holland"
    assert chains["9B"].red.name == ""
    assert chains["9B"].green.name == "Heiloo"
