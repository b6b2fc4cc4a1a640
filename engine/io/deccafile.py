"""Reader and writer for the Decca chain file ``DECCA.CHN`` (thesis A8.4, L8873–8969).

Role of the file: thesis L5556–5558; layout: THEORY §13.2, §3.2. Per chain, in this
fixed order, one item per line (``*`` comment lines and blank lines may come in between)::

    9B                                         chain id (one word)
    53 12 12.388 N 007 06 00.590 E 85.7200     master: lat, lon (D M S.sss H), f [kHz] (6 f0)
    ...                                        red (8 f0), green (9 f0), purple (5 f0) slaves
    ED50                                       datum of the station coordinates
    0                                          minimum lane count Red    (k of eq. 4.9/4.10)
    0                                          minimum lane count Green
    0                                          minimum lane count Purple
    299550.000                                 assumed signal propagation speed [km/s]

Names live in comments:

* The first non-empty comment after a station line names the station:
  ``* Master : Finsterwolde`` → ``Finsterwolde`` (text after the first ``:``, or the whole
  comment if there is none); no such comment before the next data line → ``""``.
* The chain name is taken from the last comment between two chain blocks that ends in
  ``chain <id>``, optionally parenthesised, with one trailing word ``Chain`` removed:
  ``* Frisian Islands Chain (chain 9B)`` → ``Frisian Islands``. No such comment → ``""``.
* Other comments (``* Geodetic Datum``, ``* Min. lanecount - Red`` …) are ignored.

The datum line must not start with a number (catches a missing datum or station line); read
with the datum file's names (``known_datums``), it must be one of them. Minimum lane counts and
the speed are one number per line. Every number is a plain decimal in ASCII digits with an
optional ``-`` (no ``+``, exponent, ``_``, ``inf``/``nan``); degrees and minutes are whole
numbers.

Physical ranges (docs/DATAFILES.md), each reported at its own line and field:

* propagation speed :data:`SPEED_RANGE_KM_S`: 299 000 ≤ v ≤ c = 299 792.458 km/s (the ground
  wave at 70–130 kHz travels a few hundred km/s below c over sea and land);
* frequencies: the master's f/6 is the chain's fundamental f0, in :data:`F0_RANGE_KHZ` (the
  Decca allocations, 14.0–14.33 kHz, with a margin); each slave is its harmonic of f0 (Red 8,
  Green 9, Purple 5; thesis §4) to :data:`F0_TOLERANCE_KHZ` (the file's 4 decimals in kHz);
* baselines: the master–slave distance in :data:`BASELINE_RANGE_KM` (a slave on its master or
  a continent away is a mistyped coordinate);
* minimum lane counts: |k| below the number of lanes on that pattern's baseline, 2B/λc
  (eq. 4.9/4.10: k shifts the count by whole lanes along the baseline).

``* End of Data`` ends the file and is required (a file without it was cut short: a cut inside
the last speed would otherwise read as another speed); data after it is an error. At most
:data:`engine.io.datafile_io.MAX_DATA_FILE_BYTES` are read, from a regular file only.
Station coordinates are geodetic degrees on the chain's datum, south and west negative.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from engine.errors import InputError
from engine.io.datafile_io import DataLines, is_plain_number, plain_number, read_data_text
from engine.io.operator_input import SIGNED_DECIMAL_RE, format_decimal, parse_datum_name

__all__ = [
    "DeccaChain",
    "DeccaStation",
    "format_chain_file",
    "format_dms",
    "parse_chain_text",
    "parse_dms",
    "read_chain_file",
]

#: Upper bound for the propagation speed: the speed of light in vacuum [km/s].
C_VACUUM_KM_S = 299_792.458
SPEED_RANGE_KM_S = (299_000.0, C_VACUUM_KM_S)
"""Accepted assumed propagation speeds [km/s] (the thesis' chains use 299 550)."""
F0_RANGE_KHZ = (13.9, 14.5)
"""Accepted fundamental frequencies f0 = f_master / 6 [kHz]."""
F0_TOLERANCE_KHZ = 1e-4
"""Largest difference between f_slave / harmonic and f0 [kHz]."""
BASELINE_RANGE_KM = (40.0, 300.0)
"""Accepted master–slave distances [km] (great circle on a 6371 km sphere, a range check)."""
HARMONICS = (6, 8, 9, 5)
"""Harmonic numbers of master, red, green, purple (f = n·f0)."""
COMPARISON_HARMONICS = (24, 18, 30)
"""Comparison frequencies of red, green, purple as multiples of f0 (λc = v / (n·f0))."""
_EARTH_RADIUS_KM = 6371.0

_ROLES = ("master", "red", "green", "purple")
_ROLE_ALIASES = {"m": "master", "r": "red", "g": "green", "p": "purple"}
_STATION_LAYOUT = "DD MM SS.sss N DDD MM SS.sss E f[kHz]"
_WHOLE_RE = re.compile("[0-9]+")


# --------------------------------------------------------------------------- D M S helpers


_AXES = {True: ("Latitude", 90, "N", "S"), False: ("Longitude", 180, "E", "W")}
"""Per axis (is_lat): name, largest value [deg], positive and negative hemisphere letters."""


def parse_dms(d: str, m: str, s: str, h: str, is_lat: bool, field: str) -> float:
    """Degrees from the four tokens ``D M S.sss H`` (thesis .RUN / .CHN layout, §7.3.2).

    D and M must be whole numbers in ASCII digits (``52``, ``004``), S a plain decimal
    (``33.020``, :data:`engine.io.operator_input.DECIMAL`: no sign, exponent, ``_`` or non-ASCII
    digit), 0 ≤ M < 60, 0 ≤ S < 60, H ∈ {N, S} for a latitude (≤ 90°) or {E, W} for a longitude
    (≤ 180°), any case; S and W give negative degrees. Raises ``InputError`` with ``field`` and
    the four tokens as ``text`` (no file/line).
    """
    value = dms_fast(d, m, s, h, is_lat)
    if value is not None:
        return value
    return _dms_checked(d, m, s, h, is_lat, field)


def dms_fast(d: str, m: str, s: str, h: str, is_lat: bool) -> float | None:
    """:func:`parse_dms`'s usual case: the degrees of well-formed tokens with an upper-case
    hemisphere, else None (then the checked path decides, and raises where the tokens are
    wrong).

    D and M: ASCII digits; S: ASCII digits with at most one "." and at least one digit, which
    is exactly DECIMAL (str methods are faster than a regular expression here)."""
    if not (d.isascii() and d.isdigit() and m.isascii() and m.isdigit()
            and s.isascii() and s.replace(".", "", 1).isdigit()):
        return None
    mv = float(m)
    sv = float(s)
    if not (mv < 60.0 and sv < 60.0):
        return None
    value = float(d) + mv / 60.0 + sv / 3600.0
    _, limit, plus, minus = _AXES[is_lat]
    if not value <= limit:
        return None
    if h == minus:
        return -value
    return value if h == plus else None


def _dms_checked(d: str, m: str, s: str, h: str, is_lat: bool, field: str) -> float:
    """Slow path of :func:`parse_dms`: every check in turn, raising the first that fails."""
    text = f"{d} {m} {s} {h}"
    kind = "latitude" if is_lat else "longitude"
    if not all(SIGNED_DECIMAL_RE.fullmatch(tok) for tok in (d, m, s)):
        raise InputError(
            f"Wrong {kind} format (D M S.sss {'N|S' if is_lat else 'E|W'}) !",
            field=field, text=text,
        )
    dv = float(d)
    mv = float(m)
    sv = float(s)
    if not (_WHOLE_RE.fullmatch(d) and _WHOLE_RE.fullmatch(m)):
        raise InputError(
            "Degrees and minutes must be whole non-negative numbers !", field=field, text=text
        )
    if mv >= 60.0:
        raise InputError("Minutes must be < 60 !", field=field, text=text)
    if not 0.0 <= sv < 60.0:
        raise InputError("Seconds must be in [0, 60) !", field=field, text=text)
    value = dv + mv / 60.0 + sv / 3600.0
    hem = h.upper() if h.isascii() else h  # "ſ".upper() is "S": only ASCII letters count
    name, limit, plus, minus = _AXES[is_lat]
    if value > limit:
        raise InputError(f"{name} must be <= {limit} degrees !", field=field, text=text)
    if hem == minus:
        return -value
    if hem != plus:
        raise InputError(f"Hemisphere must be {plus} or {minus} !", field=field, text=text)
    return value


def format_dms(value_deg: float, is_lat: bool) -> str:
    """``52 50 33.020 N`` / ``004 31 51.134 E`` (seconds rounded to 0.001″ ≈ 3 cm, carried)."""
    total_ms = round(abs(value_deg) * 3_600_000.0)
    deg, rest = divmod(total_ms, 3_600_000)
    minutes, ms = divmod(rest, 60_000)
    sec, frac = divmod(ms, 1000)
    south_west = value_deg < 0 and total_ms > 0  # a value that rounds to 0 is written N/E
    if is_lat:
        hem = "S" if south_west else "N"
        return f"{deg:02d} {minutes:02d} {sec:02d}.{frac:03d} {hem}"
    hem = "W" if south_west else "E"
    return f"{deg:03d} {minutes:02d} {sec:02d}.{frac:03d} {hem}"


# --------------------------------------------------------------------------- data model


@dataclass(frozen=True, slots=True)
class DeccaStation:
    """One transmitter: ``role`` ∈ master/red/green/purple, position in geodetic degrees on the
    chain's datum (south/west negative), transmitted frequency ``freq_khz`` [kHz]."""

    role: str
    name: str
    lat_deg: float
    lon_deg: float
    freq_khz: float


@dataclass(frozen=True, slots=True)
class DeccaChain:
    """One Decca chain as read from ``DECCA.CHN`` (thesis A8.4; THEORY §3.2).

    ``min_lanes`` are the minimum lane counts k for Red, Green, Purple (eq. 4.9/4.10);
    ``speed_km_s`` is the assumed propagation speed [km/s], so v/f[kHz] gives metres.
    """

    chain_id: str
    name: str
    master: DeccaStation
    red: DeccaStation
    green: DeccaStation
    purple: DeccaStation
    datum_name: str
    min_lanes: tuple[float, float, float]
    speed_km_s: float

    @property
    def slaves(self) -> tuple[DeccaStation, DeccaStation, DeccaStation]:
        """The slaves in pattern order (red, green, purple)."""
        return (self.red, self.green, self.purple)

    def station(self, pattern: str) -> DeccaStation:
        """Station by role name or initial (``"red"``, ``"R"``, ``"master"`` …, any case).

        Raises ``InputError("Unknown Decca pattern !", field="pattern")``.
        """
        key = pattern.strip().lower()
        role = _ROLE_ALIASES.get(key, key)
        if role not in _ROLES:
            raise InputError("Unknown Decca pattern !", field="pattern", text=pattern)
        station: DeccaStation = getattr(self, role)
        return station


# --------------------------------------------------------------------------- parser

# Items of a chain block after the id: (field used in "truncated" errors, role or None).
_BLOCK_ITEMS = (
    "master station", "red station", "green station", "purple station",
    "datum", "min lane count", "min lane count", "min lane count", "propagation speed",
)


def _station(role: str, stripped: str) -> tuple[float, float, float]:
    tokens = stripped.split()
    if len(tokens) != 9:
        raise InputError(
            f"{role.capitalize()} station line needs 9 fields: {_STATION_LAYOUT} !",
            field=f"{role} station", text=stripped,
        )
    lat = parse_dms(*tokens[0:4], True, "latitude")
    lon = parse_dms(*tokens[4:8], False, "longitude")
    freq = plain_number(tokens[8], "frequency")
    if freq <= 0.0:
        raise InputError("Frequency must be > 0 kHz !", field="frequency", text=tokens[8])
    return lat, lon, freq


def _single(stripped: str, field: str) -> str:
    tokens = stripped.split()
    if len(tokens) != 1:
        raise InputError("Expected one number on this line !", field=field, text=stripped)
    return tokens[0]


def _chain_name(comments: list[str], chain_id: str) -> str:
    pattern = re.compile(r"\(?\s*chain\s+" + re.escape(chain_id) + r"\s*\)?\s*$", re.IGNORECASE)
    for comment in reversed(comments):
        match = pattern.search(comment)
        if match is None:
            continue
        name = comment[: match.start()].rstrip()
        if name.lower() == "chain":
            return ""
        if name.lower().endswith(" chain"):
            name = name[:-6].rstrip()
        return name
    return ""


class _Block:
    """Mutable accumulator for one chain block while parsing (local to one parse call)."""

    def __init__(self, chain_id: str, name: str, line_no: int) -> None:
        self.chain_id = chain_id
        self.name = name
        self.line_no = line_no
        self.stations: list[tuple[float, float, float]] = []
        self.station_names: list[str] = []
        self.datum = ""
        self.min_lanes: list[float] = []
        self.speed = 0.0
        self.items = 0  # data lines read after the id
        self.lines: list[int] = []  # line of each item
        self.last_tokens: list[str] = []  # last token of each item's line, as written

    def add(self, stripped: str, line_no: int, known: list[str] | None) -> int | None:
        """Read the block's next item from a data line; the station's index for a station line
        (its name may follow in a comment), else None."""
        item = self.items
        station = None
        if item < 4:
            self.stations.append(_station(_ROLES[item], stripped))
            self.station_names.append("")
            station = item
        elif item == 4:
            self.datum = _datum(stripped, known)
        elif item < 8:
            self.min_lanes.append(plain_number(_single(stripped, "min lane count"),
                                               "min lane count"))
        else:
            self.speed = _speed(stripped)
        self.items += 1
        self.lines.append(line_no)
        self.last_tokens.append(stripped.split()[-1])
        return station

    def name_station(self, index: int, comment: str) -> None:
        """Name station ``index`` from the comment after its line (``* Master : Finsterwolde``
        → text after the first ``:``, else the whole comment)."""
        head, colon, tail = comment.partition(":")
        self.station_names[index] = tail.strip() if colon else head

    def check(self, file: str) -> None:
        """Frequencies, baselines and minimum lane counts against each other (module doc)."""
        f0 = self.stations[0][2] / HARMONICS[0]
        if not F0_RANGE_KHZ[0] <= f0 <= F0_RANGE_KHZ[1]:
            raise InputError(
                f"Master frequency must be 6 f0 with f0 in [{F0_RANGE_KHZ[0]}, "
                f"{F0_RANGE_KHZ[1]}] kHz ({6 * F0_RANGE_KHZ[0]:.1f}-"
                f"{6 * F0_RANGE_KHZ[1]:.1f} kHz) !",
                file=file, line=self.lines[0], field="frequency",
                text=self.last_tokens[0],
            )
        lat0, lon0 = self.stations[0][0], self.stations[0][1]
        baselines = []
        for i in (1, 2, 3):
            lat, lon, freq = self.stations[i]
            n = HARMONICS[i]
            if abs(freq / n - f0) > F0_TOLERANCE_KHZ:
                raise InputError(
                    f"{_ROLES[i].capitalize()} frequency must be {n} f0 = {n * f0:.4f} kHz "
                    f"(f0 = master / 6) !",
                    file=file, line=self.lines[i], field="frequency", text=self.last_tokens[i],
                )
            b_km = _sphere_distance_km(lat0, lon0, lat, lon)
            if not BASELINE_RANGE_KM[0] <= b_km <= BASELINE_RANGE_KM[1]:
                raise InputError(
                    f"{_ROLES[i].capitalize()} slave {b_km:.1f} km from the master: a baseline "
                    f"must be {BASELINE_RANGE_KM[0]:.0f}-{BASELINE_RANGE_KM[1]:.0f} km !",
                    file=file, line=self.lines[i], field=f"{_ROLES[i]} station",
                )
            baselines.append(b_km)
        for j, (k, b_km) in enumerate(zip(self.min_lanes, baselines, strict=True)):
            lam_km = self.speed / (COMPARISON_HARMONICS[j] * f0 * 1000.0)
            lanes = 2.0 * b_km / lam_km
            if abs(k) >= lanes:
                raise InputError(
                    f"Min. lane count must be smaller than the {lanes:.0f} lanes on the "
                    f"{_ROLES[j + 1]} baseline !",
                    file=file, line=self.lines[5 + j], field="min lane count",
                    text=self.last_tokens[5 + j],
                )

    def build(self) -> DeccaChain:
        made = [
            DeccaStation(role, self.station_names[i], *self.stations[i])
            for i, role in enumerate(_ROLES)
        ]
        k = self.min_lanes
        return DeccaChain(
            self.chain_id, self.name, made[0], made[1], made[2], made[3],
            self.datum, (k[0], k[1], k[2]), self.speed,
        )


def _sphere_distance_km(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance on a 6371 km sphere (km; within 0.5 % of the geodesic: a range
    check, not a baseline for the lane model)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    h = (math.sin((p2 - p1) / 2.0) ** 2
         + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2.0) ** 2)
    return 2.0 * _EARTH_RADIUS_KM * math.asin(min(1.0, math.sqrt(h)))


def parse_chain_text(
    text: str, filename: str = "<string>", known_datums: Iterable[str] | None = None
) -> dict[str, DeccaChain]:
    """Parse chain-file text into ``{chain_id: DeccaChain}`` in file order (module doc).

    With ``known_datums`` (the datum names of ``TO_WGS84.DAT``) each chain's datum must be one
    of them (``Unknown datum !`` at the datum line) and is returned in that file's spelling.
    Raises ``InputError`` with file, line, field (``chain id``, ``<role> station``,
    ``latitude``, ``longitude``, ``frequency``, ``datum``, ``min lane count``,
    ``propagation speed``, ``section``) and the offending text.
    """
    return _parse_lines(text.splitlines(), filename, known_datums)


def read_chain_file(
    path: str | os.PathLike[str], known_datums: Iterable[str] | None = None
) -> dict[str, DeccaChain]:
    """Read and parse a chain file from disk (``known_datums``: see :func:`parse_chain_text`);
    a missing file gives ``File not found !``; a device, FIFO or directory, or a file over
    1 MiB, is refused (:func:`engine.io.datafile_io.read_data_text`)."""
    name = os.fspath(path)
    return _parse_lines(read_data_text(name).text.splitlines(), name, known_datums)


def _parse_lines(
    lines: Iterable[str], file: str, known_datums: Iterable[str] | None = None
) -> dict[str, DeccaChain]:
    known = None if known_datums is None else list(known_datums)
    chains: dict[str, DeccaChain] = {}
    block: _Block | None = None
    free_comments: list[str] = []
    name_station: int | None = None  # index of the station waiting for its name comment
    scan = DataLines(lines, file)
    for line in scan:
        if line.comment is not None:
            if scan.is_end(line):
                if block is not None:
                    _truncated(block, file, line.line_no)
            elif line.comment:
                if block is None:
                    free_comments.append(line.comment)
                elif name_station is not None:
                    block.name_station(name_station, line.comment)
                name_station = None
            continue
        name_station = None
        try:
            if block is None:
                block = _start_block(line.text, chains, free_comments, line.line_no)
                free_comments = []
                continue
            name_station = block.add(line.text, line.line_no, known)
        except InputError as exc:
            raise exc.located(file=file, line=line.line_no) from None
        if block.items == len(_BLOCK_ITEMS):
            block.check(file)  # located at the line of the item at fault
            chains[block.chain_id] = block.build()
            block = None

    if block is not None:
        _truncated(block, file, scan.last_line)
    if not chains:
        raise InputError(
            "No chains in file !", file=file, line=scan.last_line or None, field="section"
        )
    scan.require_end()
    return chains


def _datum(stripped: str, known: list[str] | None) -> str:
    """The datum line: a name (not a number), in the datum file's spelling when ``known``."""
    if is_plain_number(stripped.split()[0]):
        raise InputError("Datum name expected !", field="datum", text=stripped)
    datum = " ".join(stripped.split())
    if known is not None:
        datum = parse_datum_name(datum, known, field="datum")
    return datum


def _speed(stripped: str) -> float:
    """The propagation speed line [km/s], within :data:`SPEED_RANGE_KM_S`."""
    token = _single(stripped, "propagation speed")
    speed = plain_number(token, "propagation speed")
    lo, hi = SPEED_RANGE_KM_S
    if not lo <= speed <= hi:
        raise InputError(
            f"Propagation speed must be in [{lo:.0f}, {hi}] km/s !",
            field="propagation speed", text=token,
        )
    return speed


def _start_block(
    stripped: str, chains: Mapping[str, DeccaChain], comments: list[str], line_no: int
) -> _Block:
    tokens = stripped.split()
    if len(tokens) != 1 or is_plain_number(tokens[0]):
        raise InputError("Chain id expected (one word, e.g. 9B) !", field="chain id",
                         text=stripped)
    chain_id = tokens[0]
    if chain_id in chains:
        raise InputError("Duplicate chain id !", field="chain id", text=chain_id)
    return _Block(chain_id, _chain_name(comments, chain_id), line_no)


def _truncated(block: _Block, file: str, line_no: int) -> None:
    missing = _BLOCK_ITEMS[block.items]
    raise InputError(
        f"Truncated chain block (started line {block.line_no}), {missing} missing !",
        file=file, line=line_no, field=missing, text=block.chain_id,
    )


# --------------------------------------------------------------------------- writer


_LANE_LABELS = ("Red", "Green", "Purple")


def format_chain_file(chains: Mapping[str, DeccaChain]) -> str:
    """Write chains in the thesis layout (A8.4); ``parse_chain_text`` reads it back equal.

    Positions are written to 0.001″ (exact for values read from a chain file).
    """
    out = ["* Decca chain data"]
    for chain in chains.values():
        out += ["*", f"* {chain.name} Chain (chain {chain.chain_id})".replace("*  ", "* ", 1), "*"]
        out.append(chain.chain_id)
        for st in (chain.master, chain.red, chain.green, chain.purple):
            out.append(
                f"{format_dms(st.lat_deg, True)} {format_dms(st.lon_deg, False)} "
                f"{format_decimal(st.freq_khz, 4)}"
            )
            out.append(f"* {st.role.capitalize()} : {st.name}".rstrip())
        out += [chain.datum_name, "* Geodetic Datum"]
        for k, label in zip(chain.min_lanes, _LANE_LABELS, strict=True):
            out += ["0" if k == 0 else format_decimal(k, 3), f"* Min. lanecount - {label}"]
        out += [format_decimal(chain.speed_km_s, 3), "* Assumed signal prop. speed"]
    out += ["*", "*", "* End of Data"]
    return "\n".join(out) + "\n"
