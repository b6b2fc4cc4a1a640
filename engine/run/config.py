"""The run configuration: start-up dialog answers and program parameters, stored as TOML.

It replaces the thesis' "Parameter Initialization" dialog (L5488–5496) and the A8.2 program
parameter defaults (L8708–8788; THEORY §12.3, §12.11–12.12). Every key is declared once in a
:class:`Key` table next to its dataclass; those tables drive validation, TOML loading and
:func:`dump_config`, and ``docs/CONFIG.md`` documents them. The dataclasses validate and
normalise themselves in ``__post_init__``, so ``dataclasses.replace`` cannot build an invalid
configuration either. Every problem is an :class:`engine.errors.InputError` whose ``field`` is
``"table.key"`` (``"key"`` at top level); the loaders add the file name and line.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from datetime import date
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from engine.errors import InputError
from engine.filter.variances import accel_variance
from engine.io.operator_input import (
    DATUM_MESSAGE,
    DEPTH_MESSAGE,
    DIRECTION_MESSAGE,
    FILE_NAME_MESSAGE,
    MAX_DEPTH_M,
    MAX_SPEED_KN,
    PATTERNS,
    SIGNED_DECIMAL_RE,
    SPEED_MESSAGE,
    ZONE_LETTERS,
    parse_datum_name,
    parse_position,
    parse_zone_lane,
)
from engine.io.tomlsource import (
    NUL_IN_PATH_MESSAGE,
    UNKNOWN_KEY_MESSAGE,
    UNKNOWN_TABLE_MESSAGE,
    parse_located,
    read_text,
)
from engine.systems.decca_season import DECCA_CF_CONDITIONS
from engine.systems.sensors import SENSOR_STATUS

if TYPE_CHECKING:
    from engine.io.nmea_epochs import NmeaOptions

UNKNOWN_PATTERN_MESSAGE = "Unknown Decca pattern !"
PATTERN_NOT_ENTERED_MESSAGE = "No zone/lane entered for this pattern !"
PATTERN_TWICE_MESSAGE = "Pattern selected twice !"
UNKNOWN_CHAIN_MESSAGE = "Unknown chain !"


# --------------------------------------------------------------------------------------------
# Key declarations and checks


@dataclass(frozen=True)
class Key:
    """One configuration key: TOML name, dataclass attribute, value kind, unit, meaning, source.

    ``kind`` is ``"float"`` (an integer is accepted), ``"int"``, ``"bool"``, ``"str"`` or
    ``"str_list"``. ``check`` validates/normalises the typed value or raises an InputError
    carrying only its message (the caller adds field and text).
    """

    key: str
    attr: str
    kind: str
    unit: str
    doc: str
    source: str
    check: Callable[[Any], Any] | None = None


def _bad(message: str) -> InputError:
    return InputError(message)


def _between(
    lo: float | None,
    hi: float | None,
    *,
    lo_open: bool = False,
    hi_open: bool = False,
    message: str | None = None,
) -> Callable[[float], float]:
    """A check accepting lo ≤ x ≤ hi (strict where ``*_open``), ``None`` meaning unbounded."""
    lo_txt = "" if lo is None else f"{lo:g} {'<' if lo_open else '<='} "
    hi_txt = "" if hi is None else f" {'<' if hi_open else '<='} {hi:g}"
    text = message or f"Out of range: must be {lo_txt}value{hi_txt} !"

    def check(value: float) -> float:
        if lo is not None and (value < lo or (lo_open and value == lo)):
            raise _bad(text)
        if hi is not None and (value > hi or (hi_open and value == hi)):
            raise _bad(text)
        return value

    return check


_POSITIVE = _between(0.0, None, lo_open=True)
_NON_NEGATIVE = _between(0.0, None)


def _choice(*options: str, upper: bool = False) -> Callable[[str], str]:
    """A check accepting one of ``options`` in any case; returns the canonical spelling."""
    canon = {o.lower(): o for o in options}
    text = "Must be one of " + ", ".join(f'"{o}"' for o in options) + " !"

    def check(value: str) -> str:
        found = canon.get(value.strip().lower())
        if found is None:
            raise _bad(text)
        return found.upper() if upper else found

    return check


def _non_empty(message: str) -> Callable[[str], str]:
    def check(value: str) -> str:
        if not value.strip():
            raise _bad(message)
        return value.strip()

    return check


def _path(check: Callable[[str], str] | None = None) -> Callable[[str], str]:
    """A file or directory name: no NUL character (no file system accepts one), then
    ``check``."""

    def path_check(value: str) -> str:
        if "\0" in value:
            raise _bad(NUL_IN_PATH_MESSAGE)
        return value if check is None else check(value)

    return path_check


def _angle(value: float) -> float:
    """Degrees in [0, 360]; 360 becomes 0."""
    if not 0.0 <= value <= 360.0:
        raise _bad(DIRECTION_MESSAGE)
    return 0.0 if value == 360.0 else value


def _dr_position(value: str) -> str:
    parse_position(value)
    return value.strip()


def _zone_lane(pattern: str) -> Callable[[str], str]:
    """Check a ``B20``-style entry for ``pattern``; "" means "not entered"; returns ``B20``."""

    def check(value: str) -> str:
        if not value.strip():
            return ""
        zone, lane = parse_zone_lane(value, pattern)
        return f"{ZONE_LETTERS[zone]}{lane}"

    return check


_PACE_RE = re.compile(r"x([0-9]+(?:\.[0-9]*)?|\.[0-9]+)")


def pace_factor(pace: str) -> float:
    """Playback speed relative to real time for a pace word: 1 for "real", inf for "fast",
    N for "xN" (the one definition; the console's run control uses it too)."""
    if pace == "real":
        return 1.0
    if pace == "fast":
        return math.inf
    return float(pace[1:])


def _pace(value: str) -> str:
    word = value.strip().lower()
    if word in ("real", "fast"):
        return word
    match = _PACE_RE.fullmatch(word)
    if match is None or not 0.0 < float(match.group(1)) < math.inf:
        raise _bad('Must be "real", "fast" or a multiplier like "x10" !')
    return word


def _type_error(kind: str) -> InputError:
    expected = {
        "float": "a number",
        "int": "a whole number",
        "bool": "true or false",
        "str": "a text in quotes",
        "str_list": "a list of texts",
        "table": "a table",
    }[kind]
    return _bad(f"Wrong type: {expected} expected !")


def _typed(value: Any, kind: str) -> Any:
    """``value`` checked against ``kind`` (ints promoted to float for "float")."""
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise _type_error(kind)
        try:
            number = float(value)
        except OverflowError:
            raise _bad("Not a finite number !") from None
        if not math.isfinite(number):
            raise _bad("Not a finite number !")
        return number
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise _type_error(kind)
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise _type_error(kind)
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise _type_error(kind)
        return value
    if kind == "float_auto":
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise _bad('Wrong type: "auto" or a number expected !')
        return value
    if kind == "float_none":
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise _bad('Wrong type: "none" or a number expected !')
        return value
    if kind == "str_list":
        if not isinstance(value, list | tuple) or not all(isinstance(v, str) for v in value):
            raise _type_error(kind)
        return tuple(value)
    raise ValueError(f"unknown key kind {kind!r}")


def _field_name(table: str, key: str) -> str:
    return f"{table}.{key}" if table else key


def _validate(obj: object, table: str, keys: tuple[Key, ...]) -> None:
    """Type-check, range-check and normalise every declared attribute of a frozen dataclass."""
    for key in keys:
        raw = getattr(obj, key.attr)
        try:
            value = _typed(raw, key.kind)
            if key.check is not None:
                value = key.check(value)
        except InputError as err:
            raise InputError(
                err.message, field=_field_name(table, key.key), text=_toml_value(raw)
            ) from None
        object.__setattr__(obj, key.attr, value)


SUBMARINE_SIGMA_A2 = accel_variance(0.25, 0.01, 0.75)
"""σ_a² (m²/s³ as a spectral density, eq. 6.35) of the thesis' submarine: the default of
``filter.sigma_a2``."""

THESIS_SIGMA_CURRENT2 = 2e-8
"""σ_vc² of the thesis (§6.6; m²/s³ read per 1 s): its 1 m/s semi-diurnal tide's rate of change,
``current_rate_variance(1.0, 45000.0)`` = 1.95·10⁻⁸ rounded; ``preset = "thesis"``."""

HONEST_SIGMA_CURRENT2 = 3.5e-5
"""Default ``filter.sigma_current2`` (m²/s³, THEORY §8.9): the thesis' tide (V_cm 1 m/s, period
45 000 s) matched as a random walk over an hour without fixes,
``tidal_current_psd(1.0, 45000.0, 3600.0)`` = 3.44·10⁻⁵, rounded up."""

SURFACE_SIGMA_CURRENT2 = HONEST_SIGMA_CURRENT2
"""``filter.sigma_current2`` of ``vessel = "surface"`` (m²/s³, docs/CONFIG.md "The vessel
decision"): the tide of the submarine's default, which a yacht at sea has too; its leeway (the
angle between heading and course through the water, changing with every tack and gust) is a
heading error, carried by the surface preset's gyro-bias random walk (5°/√h)."""

_UERE = _between(0.001, 1000.0)
"""Range of a UERE key (m, 1σ): from a millimetre to a kilometre."""


# --------------------------------------------------------------------------------------------
# The configuration tree


@dataclass(frozen=True)
class GpsConfig:
    """GPS system switch and receiver type (Setup ▸ Systems ▸ GPS; A8.2 ``Systems[1]``, PCode)."""

    TABLE: ClassVar[str] = "gps"
    KEYS: ClassVar[tuple[Key, ...]]

    on: bool = False
    receiver: str = "C/A"
    weights: str = "receiver"
    uere_sps_m: float = 5.0
    uere_dgps_m: float = 1.5
    uere_pps_m: float = 3.0
    uere_rtk_fixed_m: float = 0.05
    uere_rtk_float_m: float = 0.5
    sigma_floor_m: float = 0.5

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)

    def uere_m(self, quality: int | None) -> float:
        """UERE (m, 1σ) of a GGA fix quality code (1 SPS, 2 DGPS, 3 PPS, 4 RTK fixed, 5 RTK
        float); None or any other code: the SPS figure, the least accurate one
        (docs/GNSS_WEIGHTS.md)."""
        return {2: self.uere_dgps_m, 3: self.uere_pps_m, 4: self.uere_rtk_fixed_m,
                5: self.uere_rtk_float_m}.get(quality or 1, self.uere_sps_m)

    @property
    def p_code(self) -> bool:
        """True for a P-code (PPS) receiver, the thesis' ``PCode`` (L8758)."""
        return self.receiver == "P"

    @property
    def status(self) -> int:
        """A8.2 ``Systems[1]`` status code: 1 on, 0 connected but off."""
        return 1 if self.on else 0


# fmt: off
GpsConfig.KEYS = (
    Key("on", "on", "bool", "—", "GPS switched on for fixing (no system is on at start-up)",
        "L5426; A8.2 Systems[1] = 0 (L8712, L8729–8731)"),
    Key("receiver", "receiver", "str", "—",
        '"C/A" (SPS, σ 50 m per grid axis) or "P" (PPS, P-code; σ 8.9 m, THEORY D5)',
        "A8.2 PCode = false (L8758); L5526–5527", _choice("C/A", "P", upper=True)),
    Key("weights", "weights", "str", "—",
        '"receiver": a record with an HDOP (NMEA GGA) weighs each horizontal coordinate with '
        'σ = HDOP × UERE(quality)/√2, at least sigma_floor_m; "fixed": always the receiver '
        "type's σ × lsq.gps_se_sf. A C/A record without a usable HDOP gets under 'receiver' the "
        "SPS PS 2008 worst-site σ 6.95 m when dated after SA was switched off (2 May 2000), "
        "else the fixed σ (every 1993 .RUN)",
        "docs/GNSS_WEIGHTS.md [not in the thesis]", _choice("receiver", "fixed")),
    Key("uere_sps_m", "uere_sps_m", "float", "m",
        "UERE (1σ) of a GGA quality 1 (SPS, single frequency) fix, and of an HDOP without a "
        "quality", "docs/GNSS_WEIGHTS.md: L1 C/A budget without SA ~5 m", _UERE),
    Key("uere_dgps_m", "uere_dgps_m", "float", "m",
        "UERE (1σ) of a GGA quality 2 fix (DGPS beacon or SBAS)",
        "docs/GNSS_WEIGHTS.md: SBAS/beacon 95 % horizontal ~3 m", _UERE),
    Key("uere_pps_m", "uere_pps_m", "float", "m", "UERE (1σ) of a GGA quality 3 (PPS) fix",
        "docs/GNSS_WEIGHTS.md [assumption]", _UERE),
    Key("uere_rtk_fixed_m", "uere_rtk_fixed_m", "float", "m",
        "UERE (1σ) of a GGA quality 4 (RTK, integer ambiguities fixed) fix",
        "docs/GNSS_WEIGHTS.md: receiver specifications ~1 cm + 1 ppm", _UERE),
    Key("uere_rtk_float_m", "uere_rtk_float_m", "float", "m",
        "UERE (1σ) of a GGA quality 5 (RTK float) fix",
        "docs/GNSS_WEIGHTS.md: decimetres to a metre", _UERE),
    Key("sigma_floor_m", "sigma_floor_m", "float", "m",
        "least σ per horizontal coordinate of a receiver-weighted fix (antenna lever arm and "
        "ship motion are not modelled)", "docs/GNSS_WEIGHTS.md [assumption]",
        _between(0.001, 100.0)),
)
# fmt: on


@dataclass(frozen=True)
class DeccaConfig:
    """Decca system: switch, chain, operator zone/lane entries and selected patterns.

    ``red``/``green``/``purple`` are the zone letter + whole lane typed by the navigator (e.g.
    ``B20``), normalised to upper case, "" if not entered (THEORY §12.6 Setup, §3.2, D7).
    ``select`` lists the patterns used for fixing in the order red, green, purple.
    """

    TABLE: ClassVar[str] = "decca"
    KEYS: ClassVar[tuple[Key, ...]]

    on: bool = False
    chain: str = "9B"
    red: str = ""
    green: str = ""
    purple: str = ""
    select: tuple[str, ...] = ()
    lane_rule: str = "bootstrap"
    lane_success: float = 0.999
    lane_ratio: float = 3.0
    lane_cf: float = 1.0
    lane_check: str = "dia"

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)
        chosen: list[str] = []
        for name in self.select:
            pattern = name.strip().lower()
            error = None
            if pattern not in PATTERNS:
                error = UNKNOWN_PATTERN_MESSAGE
            elif pattern in chosen:
                error = PATTERN_TWICE_MESSAGE
            elif not getattr(self, pattern):
                error = PATTERN_NOT_ENTERED_MESSAGE
            if error is not None:
                raise InputError(error, field="decca.select", text=_toml_value(self.select))
            chosen.append(pattern)
        ordered = tuple(p for p in PATTERNS if p in chosen)
        object.__setattr__(self, "select", ordered)

    def entered(self) -> tuple[str, ...]:
        """Patterns with a zone/lane entered, in the order red, green, purple."""
        return tuple(p for p in PATTERNS if getattr(self, p))

    def zone_lane(self, pattern: str) -> tuple[int, int] | None:
        """(zone index A=0, whole lane) entered for ``pattern``, or None if not entered."""
        text = getattr(self, pattern.lower())
        return parse_zone_lane(text, pattern) if text else None

    @property
    def status(self) -> int:
        """A8.2 ``Systems[5]`` status code: 1 on, 0 connected but off."""
        return 1 if self.on else 0


# fmt: off
DeccaConfig.KEYS = (
    Key("on", "on", "bool", "—", "Decca switched on for fixing",
        "L5426; A8.2 Systems[5] = 0 (L8716)"),
    Key("chain", "chain", "str", "—", "chain id as in DECCA.CHN (9B Frisian Islands, 2E Holland)",
        "L5528; DECCA.CHN L8873–8969", _non_empty("Unknown chain !")),
    Key("red", "red", "str", "zone+lane",
        'Red zone letter + whole lane, e.g. "B20" (lanes 0–23); "" = not entered',
        "L5526–5531; THEORY D7", _zone_lane("red")),
    Key("green", "green", "str", "zone+lane",
        'Green zone letter + whole lane, e.g. "F34" (lanes 30–47); "" = not entered',
        "L5526–5531; THEORY D7", _zone_lane("green")),
    Key("purple", "purple", "str", "zone+lane",
        'Purple zone letter + whole lane, e.g. "A51" (lanes 50–79); "" = not entered',
        "L5526–5531; THEORY D7", _zone_lane("purple")),
    Key("select", "select", "str_list", "—",
        "patterns used for fixing; omitted = every entered pattern",
        "L5424 (observables selectable); L5531"),
    Key("lane_rule", "lane_rule", "str", "—",
        '"bootstrap" (whole lanes after a gap, and GPS lane slips, only as the success rate and '
        'ratio test below allow) or "sigma" (1σ of the position alone ≤ 1/6 lane)',
        "THEORY §3.3 [not in the thesis]", _choice("bootstrap", "sigma")),
    Key("lane_success", "lane_success", "float", "—",
        "least integer-bootstrapping success rate 1 − α of a lane identification",
        "Teunissen 1998 (J. Geod. 72:606); THEORY §3.3 [not in the thesis]",
        _between(0.5, 1.0, hi_open=True)),
    Key("lane_ratio", "lane_ratio", "float", "—",
        "least ratio q2/q1 of the second-best to the best lane candidate (ratio test)",
        "Euler & Schaffrin 1991; Verhagen & Teunissen 2013 (GPS Solut. 17:535); THEORY §3.3",
        _between(1.0, None)),
    Key("lane_cf", "lane_cf", "float", "—",
        "largest Decca.CF of the Decca VCV a lane decision assumes (1 = summer night)",
        "thesis table 4.3 (summer night σ), A4.1–A4.3; THEORY §3.3", _POSITIVE),
    Key("lane_check", "lane_check", "str", "—",
        '"dia" (the start-up zone/lane entries tested against the reference position, a tracked '
        'lane changed only when the test rejects it at α = 1 − lane_success, a pattern in doubt '
        'kept out until a position confirms its lane) or "off" (preset thesis)',
        "Teunissen 2000 (DIA, Delft); Baarda 1968; THEORY §3.3 [not in the thesis]",
        _choice("dia", "off")),
)
# fmt: on


@dataclass(frozen=True)
class SensorsConfig:
    """Sensor states "on" | "off" | "n/a" = A8.2 ``Sensors[]`` status 1 / 0 / 2 (L8729–8731)."""

    TABLE: ClassVar[str] = "sensors"
    KEYS: ClassVar[tuple[Key, ...]]

    gyro: str = "on"
    log: str = "on"
    rudder: str = "off"
    inclinometer: str = "n/a"
    pressure: str = "off"
    echosounder: str = "n/a"
    cog_sog: str = "off"
    cog_min_sog_kn: float = 1.0

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)

    def status(self, sensor: str) -> int:
        """A8.2 status code of ``sensor`` (e.g. "gyro"): 1 on, 0 off, 2 not connected."""
        return SENSOR_STATUS[getattr(self, sensor)]

    @property
    def standin(self) -> bool:
        """Course and speed over ground stand in for a missing gyro heading / log speed."""
        return self.cog_sog == "standin"


_SENSOR_WORD = _choice("on", "off", "n/a")
# fmt: off
SensorsConfig.KEYS = tuple(
    Key(name, name, "str", "—", f"{label} state: on / off / n/a (not connected)", source,
        _SENSOR_WORD)
    for name, label, source in (
        ("gyro", "gyro compass", "A8.2 Sensors[1] = 1 (L8718); L5430–5432 (assumed always on)"),
        ("log", "EM log", "A8.2 Sensors[2] = 1 (L8719); L5430–5432 (assumed always on)"),
        ("rudder", "rudder angle (displayed only)", "A8.2 Sensors[3] = 0 (L8720)"),
        ("inclinometer", "inclinometer", "A8.2 Sensors[4] = 2 (L8721)"),
        ("pressure", "pressure sensor", "A8.2 Sensors[5] = 0 (L8722)"),
        ("echosounder", "echo sounder", "A8.2 Sensors[6] = 2 (L8723)"),
    )
) + (
    Key("cog_sog", "cog_sog", "str", "—",
        '"standin": course/speed over ground (NMEA RMC/VTG) stand in for a missing gyro '
        'heading / log speed, with a larger σ, the filter then dead-reckons over ground; '
        '"off": a record without them has no dead reckoning',
        "docs/GNSS_WEIGHTS.md [not in the thesis]", _choice("off", "standin")),
    Key("cog_min_sog_kn", "cog_min_sog_kn", "float", "kn",
        "COG is not used below this speed over ground (its direction is noise there)",
        "docs/GNSS_WEIGHTS.md [assumption]", _between(0.0, 10.0)),
)
# fmt: on


@dataclass(frozen=True)
class CorrectionsConfig:
    """User observation corrections "C-O", added to the readings (Demo ▸ Corrections, A7)."""

    TABLE: ClassVar[str] = "corrections"
    KEYS: ClassVar[tuple[Key, ...]]

    gps_north_m: float = 0.0
    gps_east_m: float = 0.0
    decca_red_lanes: float = 0.0
    decca_green_lanes: float = 0.0
    decca_purple_lanes: float = 0.0

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)


# fmt: off
CorrectionsConfig.KEYS = (
    Key("gps_north_m", "gps_north_m", "float", "m", "correction added to the GPS fix, north",
        "L7680 (Demo: corrections); THEORY §3.4 [choice]"),
    Key("gps_east_m", "gps_east_m", "float", "m", "correction added to the GPS fix, east",
        "L7680; THEORY §3.4 [choice]"),
    Key("decca_red_lanes", "decca_red_lanes", "float", "lanes",
        "fixed-error correction added to the Red reading (samples: −0.05)",
        "L6520, L5384; Pg 615 C-O; THEORY D12"),
    Key("decca_green_lanes", "decca_green_lanes", "float", "lanes",
        "fixed-error correction added to the Green reading", "L6520; Pg 615; A7"),
    Key("decca_purple_lanes", "decca_purple_lanes", "float", "lanes",
        "fixed-error correction added to the Purple reading", "L6520; Pg 615; A7"),
)
# fmt: on


def decca_cf_condition(cf: float | str) -> str | None:
    """The condition code (``SD`` …) whose CF is ``cf``, or None for another value (and for
    ``"auto"``, whose condition changes from epoch to epoch)."""
    if isinstance(cf, str):
        return None
    for code, (_name, value) in DECCA_CF_CONDITIONS.items():
        if math.isclose(cf, value, rel_tol=1e-9):
            return code
    return None


def parse_decca_cf(text: str) -> float | str:
    """``Decca.CF`` as typed: ``auto`` (by the sun, :func:`decca_condition`), a positive number,
    a condition code (``SD``, ``WD``, ``SN``, ``WN``) or its name (``winter night``), any case;
    InputError otherwise."""
    t = " ".join(text.split()).lower()
    if t == "auto":
        return "auto"
    for code, (name, value) in DECCA_CF_CONDITIONS.items():
        if t in (code.lower(), name):
            return value
    value = float(t) if SIGNED_DECIMAL_RE.fullmatch(t) else math.nan
    if not value > 0.0:
        raise InputError(DECCA_CF_MESSAGE, field="decca_cf",
                         text=text)
    return value


DECCA_CF_MESSAGE = 'Decca.CF: "auto", a number > 0 or SD, WD, SN, WN !'
"""The message of a ``Decca.CF`` neither ``auto``, a positive number nor a condition."""


def _decca_cf_check(value: Any) -> float | str:
    """``lsq.decca_cf`` from TOML: ``"auto"`` (any case), a condition code or name, or a
    number > 0 (the A8.2 fixed divisor)."""
    if isinstance(value, str):
        return parse_decca_cf(value)
    return _POSITIVE(_typed(value, "float"))


THESIS_DECCA_CF = 64.0
"""``lsq.decca_cf`` under ``filter.preset = "thesis"`` when the file does not set it: the thesis
program's "Summer's day conditions" (A8.2, L8763–8764)."""


@dataclass(frozen=True)
class LsqConfig:
    """Least-squares fixing and testing parameters (A8.2; THEORY §5.1–5.5, §6)."""

    TABLE: ClassVar[str] = "lsq"
    KEYS: ClassVar[tuple[Key, ...]]

    lop_reject: str = "A"
    reliab_interval_pct: float = 5.0
    conf_region_pct: float = 95.0
    scale_vcv: bool = False
    epsilon_m: float = 1.0
    s02: float = 1.0
    decca_cf: float | str = "auto"
    gps_se_sf: float = 0.67
    estimator: str = "lsq"
    sigma_compass_deg: float = 0.8
    sigma_periscope_deg: float = 0.7
    sigma_radar_bearing_deg: float = 0.85
    sigma_radar_range_m: float = 105.0

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)


# fmt: off
LsqConfig.KEYS = (
    Key("lop_reject", "lop_reject", "str", "—",
        '"A" ask before discarding a rejected LOP, "Y" reject automatically, "N" flag only',
        "A8.2 LOPReject = 'A' (L8776); THEORY D16", _choice("A", "Y", "N", upper=True)),
    Key("reliab_interval", "reliab_interval_pct", "float", "%",
        "significance level α: a w-test beyond k_α (5 % → 1.960) is monitored, and α sets the "
        "MDB (δ0) and the unit-variance test; an LOP is rejected only beyond the fixed 2.576",
        "A8.2 ReliabInterval = 5.0 (L8781); L6665–6669",
        _between(0.0, 50.0, lo_open=True, hi_open=True)),
    Key("conf_region", "conf_region_pct", "float", "%",
        "confidence level of the displayed ellipse/ellipsoid", "A8.2 ConfRegion = 95.0 (L8782)",
        _between(0.0, 100.0, lo_open=True, hi_open=True)),
    Key("scale_vcv", "scale_vcv", "bool", "—", "scale the a-priori VCV by S² automatically",
        "A8.2 ScaleVCV = false (L8784); L6736"),
    Key("epsilon_m", "epsilon_m", "float", "m",
        "LS iteration stops when every parameter correction is below this",
        "A8.2 epsilon = 1.0 (L8772); L6526", _POSITIVE),
    Key("s02", "s02", "float", "—", "a-priori unit variance σ0²", "A8.2 s02 = 1.0 (L8773)",
        _POSITIVE),
    Key("decca_cf", "decca_cf", "float_auto", "—",
        'Decca sky-wave VCV divisor: 64 summer day, 4 winter day, 1 summer night, 1/2.25 '
        'winter night; "auto" chooses it per epoch from the sun\'s elevation at the receiver '
        "(night below +6°) and the hemisphere's half-year (preset thesis: 64)",
        "L8352 (summer night ×1, summer day ÷8, winter day ÷2, winter night ×1.5 on σ); "
        "L758, L1023–1025, L3295; A8.2 Decca.CF = 64 (L8763–8764)", _decca_cf_check),
    Key("gps_se_sf", "gps_se_sf", "float", "—",
        "scale factor on the GPS error VCV (C/A 2500 m², P 79.2 m² per axis): 0.67 reads the "
        "SPS specification's 100 m (C/A, SA on) horizontal at 95 % as the 95 % radius of a "
        "circular normal error, σ = 100/2.448 = 40.9 m per axis (P: 17.8 m → 7.3 m); the "
        "thesis program's 1 (σ = d_rms per axis) is in data/920917_1.toml",
        "GPS SPS Signal Specification (1993; 2nd ed. 1995) §3; A8.2 GPS.SE_SF = 1 (L8759); "
        "THEORY D5; docs/CONFIG.md", _POSITIVE),
    Key("estimator", "estimator", "str", "—",
        '"lsq" (thesis) or the robust "huber" / "danish" alternatives', "not in the thesis",
        _choice("lsq", "huber", "danish")),
    Key("sigma_compass_deg", "sigma_compass_deg", "float", "deg",
        "σ of a compass-repeater bearing", "L1431–1443 (0.7–0.8°)", _POSITIVE),
    Key("sigma_periscope_deg", "sigma_periscope_deg", "float", "deg",
        "σ of a periscope bearing", "L1541–1565", _POSITIVE),
    Key("sigma_radar_bearing_deg", "sigma_radar_bearing_deg", "float", "deg",
        "σ of a radar bearing", "L1210–1217", _POSITIVE),
    Key("sigma_radar_range_m", "sigma_radar_range_m", "float", "m",
        "σ of a radar distance", "L1257–1264 (60–105 m)", _POSITIVE),
)
# fmt: on


@dataclass(frozen=True)
class FilterConfig:
    """Kalman filter switches and noise parameters (chapter 6; THEORY §8, D26, D32).

    The defaults are the "honest" preset; ``preset = "thesis"`` in a TOML ``[filter]`` table
    (or :meth:`from_preset`) gives the thesis-literal filter (:data:`FILTER_PRESETS`).
    ``fix_tau_s`` and ``fix_sigma_frac`` are a number or ``"auto"`` (derived from the systems
    on by ``engine.filter.kalman.derived_fix_model``)."""

    TABLE: ClassVar[str] = "filter"
    KEYS: ClassVar[tuple[Key, ...]]

    on: bool = True
    preset: str = "honest"
    vessel: str = "auto"
    model: str = "coloured"
    p0: str = "physical"
    q_scale: float = 1.0
    q_mode: str = "vanloan"
    turn_rate_max_deg_s: float = 1.0
    pitch_rate_max_deg_s: float = 0.5
    sigma_incl_deg: float = 0.5
    sigma_gyro_deg: float = 0.65
    sigma_press_m: float = 1.45
    log_sigma_frac: float = 0.02
    log_sigma_floor_ms: float = 0.05
    fix_tau_s: float | str = "auto"
    fix_sigma_frac: float | str = "auto"
    dr_sigma_m: float = 1000.0
    bias_noise: bool = True
    log_bias_rw_ms_sqrth: float = 0.01
    gyro_bias_rw_deg_sqrth: float = 1.2
    incl_bias_rw_deg_sqrth: float = 0.1
    sigma_current2: float = HONEST_SIGMA_CURRENT2
    sigma_a2: float = SUBMARINE_SIGMA_A2
    adapt: bool = True
    adapt_window: float = 300.0
    adapt_clip: float = 4.0
    adapt_fix_max: float = 100.0
    recover: str = "reset"
    recover_epochs: int = 5
    recover_gap_s: float = 240.0
    adapt_dr: bool = False
    adapt_dr_horizon_s: float = 300.0
    adapt_dr_min: float = 1.0
    adapt_dr_max: float = 100.0
    set_keys: tuple[str, ...] = field(default=(), compare=False, repr=False)
    """The keys a TOML ``[filter]`` table set (not a key itself): they win over ``vessel``
    "auto" when it resolves to "surface" (:func:`resolve_vessel`)."""

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)

    @classmethod
    def from_vessel(cls, vessel: str, **changes: Any) -> FilterConfig:
        """The ``[filter]`` table of ``vessel = …`` ("submarine", "surface" or "auto") with
        ``changes`` on top: what a TOML ``[filter]`` table with that key and those keys gives."""
        name = _VESSEL_CHECK(vessel)
        return cls(**{**VESSEL_PRESETS.get(name, {}), "vessel": name, **changes})

    @classmethod
    def from_preset(cls, preset: str, **changes: Any) -> FilterConfig:
        """The ``[filter]`` table of ``preset`` ("honest" or "thesis") with ``changes`` on top:
        what a TOML ``[filter]`` table with ``preset = …`` and those keys gives."""
        name = _PRESET_CHECK(preset)
        return cls(**{**FILTER_PRESETS[name], "preset": name, **changes})


RECOVER_MODES = ("reset", "fade", "off")
"""``filter.recover``: the remedies of engine.filter.divergence (THEORY §8.18), defined here so
that reading a configuration does not load numpy (the console's first frame)."""

FILTER_PRESETS: dict[str, dict[str, Any]] = {
    "honest": {},
    "thesis": {"model": "thesis", "p0": "thesis", "bias_noise": False, "adapt": False,
               "adapt_dr": False, "sigma_current2": THESIS_SIGMA_CURRENT2, "recover": "off"},
}
"""Values a ``filter.preset`` gives to the keys the file does not set (docs/CONFIG.md, "The
filter decision"). "honest" is the class defaults: time-correlated fix errors with parameters
derived from the configured receiver and chain, P0 from sensor accuracies, drifting biases.
"thesis" is the thesis-literal filter of ch. 6: white fix noise (L2291), P0 = I (L2670), the
biases random constants (L2639–2641) and the current's random walk of §6.6 (2·10⁻⁸)."""

_PRESET_CHECK = _choice("honest", "thesis")

VESSEL_PRESETS: dict[str, dict[str, Any]] = {
    "submarine": {},
    "surface": {
        "sigma_gyro_deg": 3.0,
        "log_sigma_frac": 0.05,
        "gyro_bias_rw_deg_sqrth": 5.0,
        "log_bias_rw_ms_sqrth": 0.2,
        "sigma_current2": SURFACE_SIGMA_CURRENT2,
        "turn_rate_max_deg_s": 3.0,
    },
}
"""Values ``filter.vessel`` gives to the keys the file does not set (docs/CONFIG.md, "The
vessel decision"). "submarine" is the class defaults (the thesis' gyro compass, EM log and slow
drifts). "surface" is a small surface vessel with consumer instruments (a fluxgate or
magnetic compass, a paddle-wheel log, leeway and tidal stream that change with every course),
values from consumer instruments and a yacht's motion, checked on the first half of the
Markermeer GNSS-denied windows (validation: the second half) and on the Baltic and Plaka
stand-in runs (docs/REALDATA.md, "Tuning the surface vessel"). "auto" (the default) is
"surface" when the run file is an NMEA 0183 log and "submarine" for a 1993 ``.RUN``
(:func:`resolve_vessel`)."""

_VESSEL_CHECK = _choice("auto", "submarine", "surface")


def _auto_or(check: Callable[[float], float]) -> Callable[[Any], Any]:
    """A check for a key that takes ``"auto"`` (any case) or a number passing ``check``."""

    def run(value: Any) -> Any:
        if isinstance(value, str):
            if value.strip().lower() != "auto":
                raise _bad('Must be "auto" or a number !')
            return "auto"
        return check(_typed(value, "float"))

    return run


# fmt: off
FilterConfig.KEYS = (
    Key("on", "on", "bool", "—", "Kalman filtering on (Kalman ▸ Filtering)", "L7641"),
    Key("preset", "preset", "str", "—",
        '"honest" (default: the keys below as listed) or "thesis" (model, p0 "thesis", '
        'bias_noise and adapt false, sigma_current2 2e-8, recover off: the thesis-literal '
        'filter); keys set in the file override it',
        "docs/CONFIG.md \"The filter decision\" [not in the thesis]", _PRESET_CHECK),
    Key("vessel", "vessel", "str", "—",
        '"submarine" (the thesis\' gyro 0.65°, EM log 2 %, slow drifts: the keys below as '
        'listed), "surface" (a yacht\'s compass 3°, paddle log 5 %, fast bias drifts, a '
        'current/leeway random walk 500× the thesis\', turn rate 3°/s) or "auto" (default: '
        '"surface" for an NMEA 0183 run file, "submarine" for a .RUN); keys set in the file '
        "override it",
        "docs/CONFIG.md \"The vessel decision\", docs/REALDATA.md [not in the thesis]",
        _VESSEL_CHECK),
    Key("model", "model", "str", "—",
        '"coloured" (time-correlated fix error, state augmented) or "thesis" (white noise)',
        "L2291 (no coloured noise implemented); THEORY §8.2", _choice("thesis", "coloured")),
    Key("p0", "p0", "str", "—", '"physical" P0 in consistent units or "thesis" P0 = I',
        "L2670; THEORY D26", _choice("thesis", "physical")),
    Key("q_scale", "q_scale", "float", "—", "factor applied to the system noise Q_k",
        "L2779, L7579", _POSITIVE),
    Key("q_mode", "q_mode", "str", "—",
        'discretisation of Q: "vanloan" (thesis Q as spectral densities per 1 s, exact for any '
        'Δt and Predict step), "thesis" (Q per step, eq. 6.32: right at Δt = 1 s only) or '
        '"psd" (thesis Γ with Q·1 s/Δt)',
        "L2581, L2593–2641 (Q for Δt = 1 s); THEORY §8.15, D24 [recommendation]",
        _choice("vanloan", "thesis", "psd")),
    Key("turn_rate_max_deg_s", "turn_rate_max_deg_s", "float", "deg/s",
        "maximum rate of turn; σ of the heading-rate noise is half of it",
        "L2623 (no value given); THEORY D23 [assumption]", _POSITIVE),
    Key("pitch_rate_max_deg_s", "pitch_rate_max_deg_s", "float", "deg/s",
        "maximum pitch rate; σ of the inclination-rate noise is half of it",
        "L2623; THEORY D23 [assumption]", _POSITIVE),
    Key("sigma_incl_deg", "sigma_incl_deg", "float", "deg", "inclinometer σ",
        "L1447 (no value found); THEORY D23 [assumption]", _POSITIVE),
    Key("sigma_gyro_deg", "sigma_gyro_deg", "float", "deg",
        "gyro heading σ (steady course and speed)", "L1429", _POSITIVE),
    Key("sigma_press_m", "sigma_press_m", "float", "m", "pressure-sensor depth σ",
        "L1532–1539", _POSITIVE),
    Key("log_sigma_frac", "log_sigma_frac", "float", "—", "EM-log σ as a fraction of the speed",
        "eq. 4.19, L1356", _NON_NEGATIVE),
    Key("log_sigma_floor_ms", "log_sigma_floor_ms", "float", "m/s",
        "lower bound of the log σ (keeps R positive definite when stopped)",
        "THEORY §8.10 [recommendation]", _POSITIVE),
    Key("fix_tau_s", "fix_tau_s", "float_auto", "s",
        'correlation time of the coloured fix error ("coloured" model); "auto" = from the '
        "systems on: GPS C/A 240, P 600, Decca 180, the longest of those on",
        "thesis A6 (L8574–8650); docs/CONFIG.md \"The filter decision\" [not in the thesis]",
        _auto_or(_POSITIVE)),
    Key("fix_sigma_frac", "fix_sigma_frac", "float_auto", "—",
        'fraction of the fix variance that is time-correlated ("coloured" model); "auto" = '
        "1 − receiver white variance / fix variance, at most 0.99 (C/A 0.98, P and Decca 0.99)",
        "thesis L2287–2291 (keep a white part); docs/CONFIG.md \"The filter decision\"",
        _auto_or(_between(0.0, 1.0, hi_open=True))),
    Key("dr_sigma_m", "dr_sigma_m", "float", "m",
        "accuracy (1σ) of an operator DR position (physical P0, DR Pos while submerged)",
        "THEORY §8.11, D26 [recommendation]", _POSITIVE),
    Key("bias_noise", "bias_noise", "bool", "—",
        "log, gyro and inclinometer biases drift as random walks (rates below) instead of "
        "being random constants",
        "L2639–2641 (thesis: no bias noise); THEORY D29 [recommendation]"),
    Key("log_bias_rw_ms_sqrth", "log_bias_rw_ms_sqrth", "float", "m/s/√h",
        "random-walk rate of the log bias (with bias_noise)", "THEORY D29 [assumption]",
        _NON_NEGATIVE),
    Key("gyro_bias_rw_deg_sqrth", "gyro_bias_rw_deg_sqrth", "float", "deg/√h",
        "random-walk rate of the gyro bias (with bias_noise): the thesis' slowly varying gyro "
        "error, 0.5° over a quarter of its 84-min period, √(2·0.5²/0.35 h) = 1.2",
        "L1425–1429 (84-min oscillation, 0.65° in all); docs/CONFIG.md", _NON_NEGATIVE),
    Key("incl_bias_rw_deg_sqrth", "incl_bias_rw_deg_sqrth", "float", "deg/√h",
        "random-walk rate of the inclinometer bias (with bias_noise)",
        "THEORY D29 [assumption]", _NON_NEGATIVE),
    Key("sigma_current2", "sigma_current2", "float", "m²/s³",
        "spectral density of the current random walk per grid component (the rate noise of "
        "the current states): the thesis' 1 m/s semi-diurnal tide matched over an hour without "
        "fixes, A²(1 − cos ωh)/h = 3.44·10⁻⁵, rounded up (preset thesis: 2·10⁻⁸, the same tide "
        "matched over its 1-s step; surface: leeway and stream change with course and wind)",
        "thesis §6.6 (tide V_cm 1 m/s, period 45 000 s); THEORY §8.9; docs/CONFIG.md",
        _NON_NEGATIVE),
    Key("sigma_a2", "sigma_a2", "float", "m²/s³",
        "spectral density of the along-track acceleration noise (Gelb's mixed pdf, a_max "
        "0.25 m/s², P_max 0.01, P_0 0.75)", "eq. 6.35; THEORY §8.9", _NON_NEGATIVE),
    Key("adapt", "adapt", "bool", "—",
        "learn a factor on the fix VCV from the filter's fix innovations (covariance matching; "
        "never below the a-priori VCV) and, with the COG/SOG stand-in, its rate-of-turn and "
        "acceleration noise from the COG/SOG history (at most the configured ones); preset "
        "thesis: false",
        "Mehra 1970; Mohamed & Schwarz 1999; THEORY §8.17 [not in the thesis]"),
    Key("adapt_window", "adapt_window", "float", "fix epochs",
        "W: the learnt log-factor moves by (clipped NIS per row − its mean)/W per fix epoch",
        "THEORY §8.17: at least the fix-error correlation time (C/A 240 s) at 1 Hz",
        _between(1.0, 1e6)),
    Key("adapt_clip", "adapt_clip", "float", "—",
        "c: the largest NIS per row one fix epoch counts with (a blunder moves the factor by "
        "at most e^((c−1)/W))", "THEORY §8.17 (Huber-type clip)", _between(1.0, 1e3, lo_open=True)),
    Key("adapt_fix_max", "adapt_fix_max", "float", "—",
        "upper bound of the learnt fix-VCV factor (σ × √ of it); reaching it is said",
        "THEORY §8.17", _between(1.0, 1e6)),
    Key("recover", "recover", "str", "—",
        'what the filter does when consistent good fixes fail its innovation test epoch after '
        'epoch (divergence): "reset" (re-initialise the position from the LSE, widen the '
        'current), "fade" (inflate P by T/T_upper until accepted) or "off"; preset thesis: off',
        "Teunissen & Salzmann 1989; Brown & Hwang 2012; Fagin 1964; THEORY §8.18 "
        "[not in the thesis]", _choice(*RECOVER_MODES)),
    Key("recover_epochs", "recover_epochs", "int", "fix epochs",
        "K: consistent innovation-test rejections in a row before the remedy (a consistent "
        "filter rejects K in a row with probability 0.025^K ≈ 10⁻⁸ for K = 5)",
        "THEORY §8.18", _between(2, 1000)),
    Key("recover_gap_s", "recover_gap_s", "float", "s",
        "G: the remedy acts only on a run of rejections that began after at least this long "
        "without a fix update (a dive, an outage): the longest 'auto' fix-error correlation "
        "time of the 1993 systems but P code (C/A 240 s), beyond which the first fix is an "
        "independent check of the dead reckoning", "THEORY §8.18", _NON_NEGATIVE),
    Key("adapt_dr", "adapt_dr", "bool", "—",
        "learn a factor μ ≥ 1 on the random walks of the current and of the log and gyro "
        "biases from multi-minute shadow predictions checked against later fixes (predictive "
        "NEES; with adapt on); off by default: measured, it moved no target of the randomized "
        "missions and costs a tenth of a replay",
        "Mehra 1970; Bar-Shalom, Li & Kirubarajan 2001 §5.4; THEORY §8.19 [not in the thesis]"),
    Key("adapt_dr_horizon_s", "adapt_dr_horizon_s", "float", "s",
        "h: the span of each shadow prediction (a new one every h/2 while fixes arrive)",
        "THEORY §8.19: the 5-minute dead reckoning of docs/REALDATA.md", _between(10.0, 7200.0)),
    Key("adapt_dr_min", "adapt_dr_min", "float", "—",
        "lower bound of μ: 1 keeps the cited random walks as the floor (a surfaced check "
        "cannot see the hour of a dive)", "THEORY §8.19, §8.9", _between(0.01, 1.0)),
    Key("adapt_dr_max", "adapt_dr_max", "float", "—",
        "upper bound of μ (σ of the random walks × √ of it); reaching it is said",
        "THEORY §8.19", _between(1.0, 1e6)),
)
# fmt: on


MAX_DELTA_T_S = 3600
"""Largest ``[demo] delta_t_s`` (s): one KF step of an hour at 40 kn is 74 km; a step of 10⁹ s
carried the prediction off the TM grid (an engine failure, not an input error)."""


@dataclass(frozen=True)
class DemoConfig:
    """Demo-menu performance and layout parameters (L7678–7680, A8.2, THEORY D43)."""

    TABLE: ClassVar[str] = "demo"
    KEYS: ClassVar[tuple[Key, ...]]

    delta_t_s: int = 1
    s_weight: float = 1.026
    press_ref_freq_hz: float = 0.0
    plot_scale_m: float = 2000.0
    plot_size: float = 1.0
    pace: str = "real"
    poe_expansion_m_h: float = 1800.0

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)

    @property
    def pace_factor(self) -> float:
        """Playback speed relative to real time: 1 for "real", inf for "fast", N for "xN"."""
        return pace_factor(self.pace)


# fmt: off
DemoConfig.KEYS = (
    Key("delta_t_s", "delta_t_s", "int", "s",
        "sample interval: every DeltaT-th record is processed, KF Δt = DeltaT; 1 to 3600",
        "A8.2 DeltaT = 1 (L8788); L7610; THEORY D43", _between(1, MAX_DELTA_T_S)),
    Key("s_weight", "s_weight", "float", "—", "specific weight of seawater γ (eq. 3.3)",
        "A8.2 s_weight = 1.026 (L8768)", _POSITIVE),
    Key("press_ref_freq_hz", "press_ref_freq_hz", "float", "Hz",
        "pressure-crystal surface reference frequency; 0 = one standard atmosphere",
        "L597; THEORY D40–D41", _NON_NEGATIVE),
    Key("plot_scale_m", "plot_scale_m", "float", "m", "extent of the position plot",
        "L7678 (no value given)", _POSITIVE),
    Key("plot_size", "plot_size", "float", "—", "relative size of the position plot",
        "L7678 (no value given)", _POSITIVE),
    Key("pace", "pace", "str", "—",
        'playback pace: "real" (1 record/s), "fast" (no waiting) or "xN" (N times real time)',
        "THEORY D43 [not in the thesis]", _pace),
    Key("poe_expansion_m_h", "poe_expansion_m_h", "float", "m/h",
        "Pool of Errors expansion rate ε (eq. 2.1, typically 900–1800 m/h)",
        "L289–300; THEORY §10", _NON_NEGATIVE),
)
# fmt: on


_ISO_DATE_RE = re.compile(r"\d{4}-\d{2}-\d{2}\Z")


def _iso_date(value: str) -> str:
    """"" or a UTC date ``YYYY-MM-DD``."""
    text = value.strip()
    if text and (not _ISO_DATE_RE.match(text) or _date_or_none(text) is None):
        raise _bad('Must be "" or a date YYYY-MM-DD !')
    return text


def _date_or_none(text: str) -> date | None:
    try:
        return date.fromisoformat(text)
    except ValueError:
        return None


def _none_or(check: Callable[[float], float]) -> Callable[[Any], Any]:
    """A check for a key that takes ``"none"`` (any case) or a number passing ``check``."""

    def run(value: Any) -> Any:
        if isinstance(value, str):
            if value.strip().lower() != "none":
                raise _bad('Must be "none" or a number !')
            return "none"
        return check(_typed(value, "float"))

    return run


@dataclass(frozen=True)
class NmeaConfig:
    """How an NMEA 0183 log run file becomes epochs (docs/NMEA.md; not in the thesis).

    Written to a log's header only when a key differs from its default, so the header of a
    ``.RUN`` replay is as before.
    """

    TABLE: ClassVar[str] = "nmea"
    KEYS: ClassVar[tuple[Key, ...]]

    interval_s: int = 1
    position_stale_s: float = 3.0
    heading_stale_s: float = 3.0
    water_speed_stale_s: float = 5.0
    cog_sog_stale_s: float = 3.0
    depth_stale_s: float = 10.0
    date: str = ""
    variation_deg: float | str = "none"
    """Magnetic variation [deg, east positive], or "none"."""
    accept_no_checksum: bool = False

    def __post_init__(self) -> None:
        _validate(self, self.TABLE, self.KEYS)

    @property
    def options(self) -> NmeaOptions:
        """These settings as the reader's :class:`~engine.io.nmea_epochs.NmeaOptions`."""
        from engine.io.nmea_epochs import NmeaOptions  # not at start-up: it loads pynmea2

        return NmeaOptions(
            interval_s=self.interval_s,
            position_stale_s=self.position_stale_s,
            heading_stale_s=self.heading_stale_s,
            water_speed_stale_s=self.water_speed_stale_s,
            cog_sog_stale_s=self.cog_sog_stale_s,
            depth_stale_s=self.depth_stale_s,
            date=date.fromisoformat(self.date) if self.date else None,
            variation_deg=None if self.variation_deg == "none" else float(self.variation_deg),
            accept_no_checksum=self.accept_no_checksum,
        )


_STALE = _between(0.0, 86400.0)
# fmt: off
NmeaConfig.KEYS = (
    Key("interval_s", "interval_s", "int", "s",
        "epoch interval of an NMEA log: one record per interval from the latest values; whole "
        "seconds 1 to 3600 (the .RUN time resolution)",
        "docs/NMEA.md [not in the thesis]", _between(1, 3600)),
    Key("position_stale_s", "position_stale_s", "float", "s",
        "a GNSS position older than this at an epoch is absent (1 Hz receiver: two missed)",
        "docs/NMEA.md [not in the thesis]", _STALE),
    Key("heading_stale_s", "heading_stale_s", "float", "s",
        "a heading (HDT/HDG/VHW) older than this is absent", "docs/NMEA.md", _STALE),
    Key("water_speed_stale_s", "water_speed_stale_s", "float", "s",
        "a speed through the water (VHW/VBW) older than this is absent (logs send slowly)",
        "docs/NMEA.md", _STALE),
    Key("cog_sog_stale_s", "cog_sog_stale_s", "float", "s",
        "a course/speed over ground (RMC/VTG) older than this is absent", "docs/NMEA.md",
        _STALE),
    Key("depth_stale_s", "depth_stale_s", "float", "s",
        "a depth (DBT/DPT) older than this is absent (sounders send at 0.2–1 Hz)",
        "docs/NMEA.md", _STALE),
    Key("date", "date", "str", "—",
        'UTC date "YYYY-MM-DD" of a log that starts without RMC/ZDA; "" = from the log',
        "docs/NMEA.md", _iso_date),
    Key("variation_deg", "variation_deg", "float_none", "deg",
        'magnetic variation (east positive) for HDG/VHW magnetic headings without one; "none" '
        "= the log's own (RMC), else the IGRF-14 model's at the fix", "docs/NMEA.md",
        _none_or(_between(-180.0, 180.0))),
    Key("accept_no_checksum", "accept_no_checksum", "bool", "—",
        "use sentences without a *hh checksum (default: skipped, counted as \"no checksum\")",
        "docs/NMEA.md"),
)
# fmt: on


_TABLES: tuple[tuple[str, type], ...] = (
    ("gps", GpsConfig),
    ("decca", DeccaConfig),
    ("sensors", SensorsConfig),
    ("corrections", CorrectionsConfig),
    ("lsq", LsqConfig),
    ("filter", FilterConfig),
    ("demo", DemoConfig),
    ("nmea", NmeaConfig),
)


@dataclass(frozen=True)
class RunConfig:
    """A complete run configuration (start-up dialog + parameters; THEORY §12.3, §12.11).

    ``dr_lat_deg``/``dr_lon_deg`` (degrees on the working datum, north/east positive) are parsed
    from ``dr_position``. ``config_dir`` is the (absolute) directory of the TOML file, the
    current directory by default; ``run_path`` and ``data_dir`` resolve ``run_file`` and
    ``data_dir_text`` against it.
    """

    KEYS: ClassVar[tuple[Key, ...]]

    datum: str = "ED50"
    dr_position: str = "52 50 00 N 004 30 00 E"
    depth_m: float = 0.0
    current_set_deg: float = 0.0
    current_speed_kn: float = 0.0
    run_file: str = "920917_1.RUN"
    run_gps_datum: str = "WGS84"
    data_dir_text: str = "."
    gps: GpsConfig = GpsConfig()
    decca: DeccaConfig = DeccaConfig()
    sensors: SensorsConfig = SensorsConfig()
    corrections: CorrectionsConfig = CorrectionsConfig()
    lsq: LsqConfig = LsqConfig()
    filter: FilterConfig = FilterConfig()
    demo: DemoConfig = DemoConfig()
    nmea: NmeaConfig = NmeaConfig()
    config_dir: Path = Path(".")
    dr_lat_deg: float = field(init=False)
    dr_lon_deg: float = field(init=False)

    def __post_init__(self) -> None:
        _validate(self, "", self.KEYS)
        for name, cls in _TABLES:
            if not isinstance(getattr(self, name), cls):
                raise InputError(_type_error("table").message, field=name)
        lat, lon = parse_position(self.dr_position, field="dr_position")
        object.__setattr__(self, "dr_lat_deg", lat)
        object.__setattr__(self, "dr_lon_deg", lon)
        object.__setattr__(self, "config_dir", Path(os.path.abspath(self.config_dir)))

    @property
    def run_path(self) -> Path:
        """Absolute path of the run file (``.RUN`` is added to a name without suffix, unless
        only the name without it exists: an NMEA log such as ``capture``)."""
        path = Path(os.path.abspath(self.config_dir / self.run_file))
        if not path.suffix:
            with_run = path.with_name(path.name + ".RUN")
            if with_run.exists() or not path.is_file():
                return with_run
        return path

    @property
    def data_dir(self) -> Path:
        """Absolute directory holding ``TO_WGS84.DAT`` and ``DECCA.CHN`` (THEORY D35)."""
        return Path(os.path.abspath(self.config_dir / self.data_dir_text))

    def replace(self, **changes: Any) -> RunConfig:
        """A copy with ``changes`` applied (validated like a loaded configuration)."""
        return dataclasses.replace(self, **changes)


# fmt: off
RunConfig.KEYS = (
    Key("datum", "datum", "str", "—",
        "working datum for all calculations and displays (a name from TO_WGS84.DAT)",
        "L5490; A8.2 calculation datum ED50 (L8748)", _non_empty(DATUM_MESSAGE)),
    Key("dr_position", "dr_position", "str", "deg",
        'initial DR position in an operator-input form, e.g. "52 50 00 N 004 30 00 E"',
        "L5491, L7723–7754; default = start-up of L5526", _dr_position),
    Key("depth_m", "depth_m", "float", "m", "depth below the sea surface",
        "L5492", _between(0.0, MAX_DEPTH_M, message=DEPTH_MESSAGE)),
    Key("current_set_deg", "current_set_deg", "float", "deg",
        "current direction: the set, towards which the water flows", "L5493, L7461", _angle),
    Key("current_speed_kn", "current_speed_kn", "float", "kn", "current speed",
        "L5493", _between(0.0, MAX_SPEED_KN, message=SPEED_MESSAGE)),
    Key("run_file", "run_file", "str", "path",
        ".RUN simulation data, relative to the configuration file's directory",
        "L5494; A8.2 RunDataFile (L8737)", _path(_non_empty(FILE_NAME_MESSAGE))),
    Key("run_gps_datum", "run_gps_datum", "str", "—",
        "datum of the GPS positions in the .RUN file", "L5547; THEORY D6",
        _non_empty(DATUM_MESSAGE)),
    Key("data_dir", "data_dir_text", "str", "path",
        "directory of TO_WGS84.DAT and DECCA.CHN, relative to the configuration file",
        "A8.2 (L8735–8737); THEORY D35", _path()),
)
# fmt: on


def default_config() -> RunConfig:
    """The configuration with every key at its default (A8.2 and the recommendations)."""
    return RunConfig()


# --------------------------------------------------------------------------------------------
# Loading


def _build(data: Mapping[str, Any], config_dir: Path) -> RunConfig:
    """A RunConfig from a parsed TOML document; unknown keys and tables are errors."""
    top = {key.key: key for key in RunConfig.KEYS}
    tables = dict(_TABLES)
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        if name in top:
            kwargs[top[name].attr] = value
        elif name in tables:
            if not isinstance(value, dict):
                raise InputError(_type_error("table").message, field=name, text=_toml_value(value))
            kwargs[name] = _build_table(name, tables[name], value)
        else:
            message = UNKNOWN_TABLE_MESSAGE if isinstance(value, dict) else UNKNOWN_KEY_MESSAGE
            raise InputError(message, field=name, text=name)
    lsq = data.get("lsq")
    if (_file_preset(data) == "thesis"
            and not (isinstance(lsq, dict) and "decca_cf" in lsq)):
        # the thesis preset's Decca.CF: summer's day (A8.2), not the sun's condition
        kwargs["lsq"] = dataclasses.replace(kwargs.get("lsq", LsqConfig()),
                                            decca_cf=THESIS_DECCA_CF)
    decca = data.get("decca")
    if (_file_preset(data) == "thesis"
            and not (isinstance(decca, dict) and "lane_check" in decca)):
        # the thesis preset takes the zone/lane entries literally (thesis §7.3.1)
        kwargs["decca"] = dataclasses.replace(kwargs.get("decca", DeccaConfig()),
                                              lane_check="off")
    return RunConfig(**kwargs, config_dir=config_dir)


def _file_preset(data: Mapping[str, Any]) -> str | None:
    """The ``filter.preset`` a parsed document sets (checked by the filter table), else None."""
    f = data.get("filter")
    preset = f.get("preset") if isinstance(f, dict) else None
    return preset.strip().lower() if isinstance(preset, str) else None


def _build_table(table: str, cls: type, data: Mapping[str, Any]) -> Any:
    keys = {key.key: key for key in cls.KEYS}  # type: ignore[attr-defined]
    kwargs: dict[str, Any] = {}
    if cls is FilterConfig and "preset" in data:
        # The preset fills the keys the file leaves out; a key in the file wins.
        try:
            preset = _PRESET_CHECK(_typed(data["preset"], "str"))
        except InputError as err:
            raise InputError(err.message, field="filter.preset",
                             text=_toml_value(data["preset"])) from None
        kwargs.update(FILTER_PRESETS[preset])
    if cls is FilterConfig and "vessel" in data:
        try:
            vessel = _VESSEL_CHECK(_typed(data["vessel"], "str"))
        except InputError as err:
            raise InputError(err.message, field="filter.vessel",
                             text=_toml_value(data["vessel"])) from None
        kwargs.update(VESSEL_PRESETS.get(vessel, {}))
    for name, value in data.items():
        if name not in keys:
            raise InputError(UNKNOWN_KEY_MESSAGE, field=f"{table}.{name}", text=name)
        kwargs[keys[name].attr] = value
    if cls is FilterConfig:
        kwargs["set_keys"] = tuple(keys[name].attr for name in data)
    obj = cls(**kwargs)
    if cls is DeccaConfig and "select" not in data:
        obj = dataclasses.replace(obj, select=obj.entered())
    return obj


def resolve_vessel(cfg: RunConfig, nmea: bool | None = None) -> RunConfig:
    """``cfg`` with ``filter.vessel = "auto"`` resolved for its run file: an NMEA 0183 log
    (``nmea``; None = look at the file's content; a ``.RUN`` that ``uvnav convert`` wrote from
    one counts as one) makes it "surface", whose values replace the
    keys the TOML file did not set and that are still at the submarine default; a 1993 ``.RUN``
    leaves ``cfg`` as it is ("auto" then means "submarine": every .RUN run is unchanged)."""
    f = cfg.filter
    if f.vessel != "auto":
        return cfg
    if nmea is None:
        from engine.io.nmea_log import is_converted_nmea_run, is_nmea_file  # loads pynmea2

        nmea = is_nmea_file(cfg.run_path) or is_converted_nmea_run(cfg.run_path)
    if not nmea:
        return cfg
    sub = FilterConfig()
    changes = {k: v for k, v in VESSEL_PRESETS["surface"].items()
               if k not in f.set_keys and getattr(f, k) == getattr(sub, k)}
    return cfg.replace(filter=dataclasses.replace(f, vessel="surface", **changes))


def _with_names(cfg: RunConfig, known_datums: Iterable[str] | None,
                known_chains: Iterable[str] | None) -> RunConfig:
    if known_chains is not None and cfg.decca.chain not in set(known_chains):
        raise InputError(UNKNOWN_CHAIN_MESSAGE, field="decca.chain", text=cfg.decca.chain)
    if known_datums is None:
        return cfg
    names = list(known_datums)
    return cfg.replace(
        datum=parse_datum_name(cfg.datum, names, field="datum"),
        run_gps_datum=parse_datum_name(cfg.run_gps_datum, names, field="run_gps_datum"),
    )


def parse_config_text(
    text: str,
    filename: str = "<string>",
    base_dir: Path = Path("."),
    known_datums: Iterable[str] | None = None,
    known_chains: Iterable[str] | None = None,
) -> RunConfig:
    """Parse TOML ``text`` into a RunConfig; omitted keys take their defaults.

    Relative paths resolve against ``base_dir``. If ``known_datums`` (the names of
    TO_WGS84.DAT section 2) is given, ``datum`` and ``run_gps_datum`` must be among them and
    are returned in the file's spelling; if ``known_chains`` (DECCA.CHN ids) is given,
    ``decca.chain`` must be one. Errors are InputErrors with ``file=filename``, the 1-based line
    of the offending key (or of the TOML syntax error), ``field`` and ``text``.
    """
    return parse_located(
        text, filename,
        lambda data: config_from_data(data, Path(base_dir), known_datums, known_chains))


def config_from_data(
    data: Mapping[str, Any],
    base_dir: Path = Path("."),
    known_datums: Iterable[str] | None = None,
    known_chains: Iterable[str] | None = None,
) -> RunConfig:
    """A RunConfig from an already parsed TOML document (e.g. a configuration with a
    campaign's overrides merged in), checked as :func:`parse_config_text` checks a file;
    InputErrors carry the ``field`` but no file or line."""
    return _with_names(_build(data, Path(base_dir)), known_datums, known_chains)


def load_config(
    path: str | os.PathLike[str],
    known_datums: Iterable[str] | None = None,
    known_chains: Iterable[str] | None = None,
) -> RunConfig:
    """Load a TOML run configuration file (see :func:`parse_config_text`)."""
    file = Path(path)
    return parse_config_text(read_text(file), str(file), file.parent, known_datums,
                             known_chains)


# --------------------------------------------------------------------------------------------
# Writing


def _toml_string(text: str) -> str:
    out = ['"']
    for ch in text:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch < " " or ch == "\x7f":
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _toml_value(value: Any) -> str:
    """``value`` as TOML source (bool, int, float, str, list/tuple of those; else ``repr``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return repr(value)


def _dump_keys(obj: object, keys: tuple[Key, ...]) -> list[str]:
    return [f"{key.key} = {_toml_value(getattr(obj, key.attr))}" for key in keys]


def dump_config(cfg: RunConfig) -> str:
    """TOML text of ``cfg`` with every key written; parsing it (with the same base directory)
    gives back an equal RunConfig."""
    lines = ["# UVNAV run configuration (keys: docs/CONFIG.md)"]
    lines += _dump_keys(cfg, RunConfig.KEYS)
    for name, cls in _TABLES:
        if cls is NmeaConfig and cfg.nmea == NmeaConfig():
            continue  # only when set: a .RUN replay's log header is as before the table came
        lines += ["", f"[{name}]"]
        lines += _dump_keys(getattr(cfg, name), cls.KEYS)  # type: ignore[attr-defined]
    return "\n".join(lines) + "\n"


def all_keys() -> tuple[tuple[str, Key, Any], ...]:
    """Every key as (``table.key`` name, declaration, default value), in file order."""
    rows = [(key.key, key, getattr(RunConfig(), key.attr)) for key in RunConfig.KEYS]
    for name, cls in _TABLES:
        default = cls()
        rows += [(f"{name}.{key.key}", key, getattr(default, key.attr)) for key in cls.KEYS]
    return tuple(rows)
