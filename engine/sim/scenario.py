"""Simulation scenario: a planned mission and the error models of its sensors, read from TOML.

A scenario drives :mod:`engine.sim.simulate`, which turns it into a ``.RUN`` file (thesis A8.4,
THEORY §13.3) plus a truth file. The layout of every key, its unit, default and source is in
``docs/SIMULATOR.md``; in short::

    start_time = "1992-09-17T10:00:00Z"        # ISO 8601, UTC
    datum = "ED50"                             # working datum: the truth lives on it
    start_position = "52 50 00 N 004 30 00 E"  # an operator form of thesis §7.3.2
    [current]  set_deg, speed_kn               # scenario-wide current (set = towards)
    [sensors]  gyro, log, rudder, inclinometer, pressure, echosounder   (true/false)
    [gps] [decca] [gyro] [log] [inclinometer] [pressure] [echosounder]  error models
    [[leg]]    duration_s, course_deg, speed_kn, depth_m, surfaced, ...

Error-model sources: GPS SA-era σ ≈ 35 m per axis (2 d_rms 100 m, THEORY §3.1, D5) with a
first-order Gauss–Markov correlation time (THEORY §8.2, §11.1–11.2); Decca A4 VCV (THEORY §3.2);
gyro σ 0.65° (§8.6, L1429); EM log σ = 0.02·v (§8.7, eq. 4.19); inclinometer σ 0.5° (an
assumption, A16); pressure σ 1.45 m (§8.9, L1532–1539); echo sounder IHO σ = 0.25 + 0.0045·d
(§8.10, eq. 4.25).

Every problem raises :class:`engine.errors.InputError` with the file name, the 1-based line of
the offending key, the field as ``table.key`` (``key`` at top level, ``leg[2].speed_kn`` for the
second ``[[leg]]``) and the offending text. Unknown keys and tables are errors.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from engine.errors import InputError
from engine.io.operator_input import parse_datum_name, parse_position
from engine.io.tomlsource import (
    NUL_IN_PATH_MESSAGE,
    UNKNOWN_KEY_MESSAGE,
    UNKNOWN_TABLE_MESSAGE,
    parse_located,
    read_text,
)

__all__ = [
    "Current",
    "DeccaModel",
    "EchoModel",
    "GpsModel",
    "GyroModel",
    "InclinometerModel",
    "Leg",
    "LogModel",
    "PressureModel",
    "Scenario",
    "SensorSet",
    "load_scenario",
    "parse_scenario_text",
]

MISSING_KEY_MESSAGE = "Missing key !"
UNKNOWN_CHAIN_MESSAGE = "Unknown Decca chain !"


# --------------------------------------------------------------------------------------------
# The scenario as frozen dataclasses


@dataclass(frozen=True, slots=True)
class Current:
    """A current: ``set_deg`` the true direction it flows towards (deg), ``speed_kn`` (kn)."""

    set_deg: float = 0.0
    speed_kn: float = 0.0

    def east_north_ms(self) -> tuple[float, float]:
        """(east, north) components in m/s, true (geographic) axes."""
        v = self.speed_kn * 1852.0 / 3600.0
        a = math.radians(self.set_deg)
        return v * math.sin(a), v * math.cos(a)


@dataclass(frozen=True, slots=True)
class Leg:
    """One leg of the mission, sailed for ``duration_s`` (s, a multiple of the sample interval).

    The vessel turns at ``turn_rate_deg_s`` (deg/s, the shorter way; 180° turns to starboard)
    to ``course_deg`` (true heading at the end of the turn), accelerates at the scenario's
    ``acceleration_ms2`` to ``speed_kn`` (through the water) and dives at ``dive_rate_ms`` or
    climbs at ``climb_rate_ms`` (m/s, vertical) to ``depth_m``. ``surfaced`` legs receive GPS and
    Decca while the depth is at most the scenario's ``fix_depth_max_m``. ``current`` is the
    current on this leg (the scenario-wide one unless overridden). ``decca_sigma_factor``
    multiplies the Decca correlated error on this leg (a sky-wave episode; 1 = none).
    """

    duration_s: int
    course_deg: float
    speed_kn: float
    depth_m: float
    surfaced: bool
    turn_rate_deg_s: float
    dive_rate_ms: float
    climb_rate_ms: float
    current: Current
    decca_sigma_factor: float = 1.0


@dataclass(frozen=True, slots=True)
class SensorSet:
    """Which bounded sensors exist (write a column); absent ones are written as ``-``/omitted."""

    gyro: bool = True
    log: bool = True
    rudder: bool = True
    inclinometer: bool = False
    pressure: bool = False
    echosounder: bool = False


@dataclass(frozen=True, slots=True)
class GpsModel:
    """GPS position error per grid axis (m): first-order Gauss–Markov of σ ``sigma_m`` and
    correlation time ``tau_s`` (s; SA-era 35 m, 240 s) plus white noise ``white_sigma_m``.

    With ``hdop`` > 0 (a modern receiver, issue 13; docs/GNSS_WEIGHTS.md) each record carries
    an HDOP h(t) = ``hdop``·(1 + ``hdop_swing``·sin 2πt/``hdop_period_s``), rounded to 0.1 as
    NMEA GGA reports it, and the GGA ``quality``; the error per axis then has σ(t) = h(t)·
    ``uere_m``/√2 (the receiver weight's own formula), of which the share ``white_frac`` of
    the variance is white and the rest Gauss–Markov with ``tau_s``; ``sigma_m`` and
    ``white_sigma_m`` are not used. The random draws are the same, so ``hdop`` = 0 (the
    default) leaves every scenario's output as it was."""

    on: bool = True
    sigma_m: float = 35.0
    tau_s: float = 240.0
    white_sigma_m: float = 5.0
    hdop: float = 0.0
    hdop_swing: float = 0.0
    hdop_period_s: float = 900.0
    uere_m: float = 5.0
    quality: int = 1
    white_frac: float = 0.01

    def hdop_at(self, t_s: float) -> float:
        """The HDOP reported at ``t_s`` seconds into the mission (0.1 steps, at least 0.5)."""
        h = self.hdop * (1.0 + self.hdop_swing * math.sin(2.0 * math.pi * t_s / self.hdop_period_s))
        return max(0.5, round(h, 1))


@dataclass(frozen=True, slots=True)
class DeccaModel:
    """Decca lane error (lanes): Gauss–Markov with the A4 3×3 lane VCV at the true position for
    ``cf`` (Decca.CF: 64 summer day, 4 winter day, 1 summer night, 1/2.25 winter night) times
    ``sigma_scale``², correlation time ``tau_s`` (s), plus white noise ``white_sigma_lanes``.
    ``red_scale``, ``green_scale``, ``purple_scale`` scale each pattern's correlated error on top
    of ``sigma_scale`` (covariance D·Σ·D, D = diag of the three: the patterns keep their A4
    correlation); a leg's ``decca_sigma_factor`` multiplies all three (sky-wave episodes)."""

    on: bool = True
    chain: str = "9B"
    cf: float = 64.0
    sigma_scale: float = 1.0
    tau_s: float = 180.0
    white_sigma_lanes: float = 0.0
    red_scale: float = 1.0
    green_scale: float = 1.0
    purple_scale: float = 1.0


@dataclass(frozen=True, slots=True)
class GyroModel:
    """Gyro heading error (deg): constant ``bias_deg`` + Gauss–Markov ``gm_sigma_deg`` with
    correlation time ``gm_tau_s`` (s) + white ``sigma_deg`` (thesis 0.65°, L1429)."""

    bias_deg: float = 0.0
    sigma_deg: float = 0.65
    gm_sigma_deg: float = 0.0
    gm_tau_s: float = 600.0


@dataclass(frozen=True, slots=True)
class LogModel:
    """EM-log speed: v·(1 + ``scale_factor``) + ``bias_kn`` + white σ = ``sigma_frac``·v (kn)."""

    scale_factor: float = 0.0
    bias_kn: float = 0.0
    sigma_frac: float = 0.02


@dataclass(frozen=True, slots=True)
class InclinometerModel:
    """Inclinometer (pitch, bow-down positive) error: ``bias_deg`` + white ``sigma_deg`` (deg)."""

    bias_deg: float = 0.0
    sigma_deg: float = 0.5


@dataclass(frozen=True, slots=True)
class PressureModel:
    """Pressure-sensor depth error ``bias_m`` + white ``sigma_m`` (m), written as the crystal
    frequency for specific weight ``s_weight`` and surface reference ``ref_freq_hz`` (Hz, 0 = the
    frequency at one standard atmosphere, as the program assumes; eq. 3.2–3.3)."""

    bias_m: float = 0.0
    sigma_m: float = 1.45
    s_weight: float = 1.026
    ref_freq_hz: float = 0.0


@dataclass(frozen=True, slots=True)
class EchoModel:
    """Echo-sounder depth under the keel: white σ = ``sigma_a_m`` + ``sigma_b``·d (m, IHO)."""

    sigma_a_m: float = 0.25
    sigma_b: float = 0.0045


@dataclass(frozen=True, slots=True)
class Scenario:
    """A simulation scenario (see the module docstring and docs/SIMULATOR.md).

    Positions are geodetic degrees on ``datum`` (the working datum); ``start_time`` is tz-aware
    UTC; ``sample_interval_s`` (s) is the record spacing; ``water_depth_m`` (m, None = no bottom
    modelled) the constant depth of the sea; ``fix_depth_max_m`` the deepest depth at which a
    surfaced leg still receives GPS and Decca; ``max_pitch_deg`` bounds the pitch during depth
    changes; ``rudder_gain_s`` (s) turns the rate of turn (deg/s) into the rudder angle written.
    ``source`` is the file name the scenario was read from and ``config_dir`` its directory.
    """

    name: str
    source: str
    config_dir: Path
    start_time: datetime
    datum: str
    start_position: str
    start_lat_deg: float
    start_lon_deg: float
    sample_interval_s: int
    run_gps_datum: str
    data_dir_text: str
    water_depth_m: float | None
    fix_depth_max_m: float
    acceleration_ms2: float
    max_pitch_deg: float
    rudder_gain_s: float
    current: Current
    sensors: SensorSet
    gps: GpsModel
    decca: DeccaModel
    gyro: GyroModel
    log: LogModel
    inclinometer: InclinometerModel
    pressure: PressureModel
    echosounder: EchoModel
    legs: tuple[Leg, ...]

    @property
    def duration_s(self) -> int:
        """Total mission time (s), the sum of the leg durations."""
        return sum(leg.duration_s for leg in self.legs)

    @property
    def n_records(self) -> int:
        """Number of ``.RUN`` records: one every ``sample_interval_s`` from t = 0 to < duration."""
        return self.duration_s // self.sample_interval_s

    @property
    def end_time(self) -> datetime:
        """Time of the last record (UTC)."""
        return self.start_time + timedelta(seconds=(self.n_records - 1) * self.sample_interval_s)

    @property
    def data_dir(self) -> Path:
        """Directory of TO_WGS84.DAT and DECCA.CHN (``data_dir`` relative to the scenario file)."""
        return (self.config_dir / self.data_dir_text).resolve()

    def without_errors(self) -> Scenario:
        """The same mission with every sensor error (bias, scale, σ) set to zero: a truth run."""
        return dataclasses.replace(
            self,
            gps=dataclasses.replace(self.gps, sigma_m=0.0, white_sigma_m=0.0),
            decca=dataclasses.replace(self.decca, sigma_scale=0.0, white_sigma_lanes=0.0),
            gyro=dataclasses.replace(self.gyro, bias_deg=0.0, sigma_deg=0.0, gm_sigma_deg=0.0),
            log=dataclasses.replace(self.log, scale_factor=0.0, bias_kn=0.0, sigma_frac=0.0),
            inclinometer=InclinometerModel(0.0, 0.0),
            pressure=dataclasses.replace(self.pressure, bias_m=0.0, sigma_m=0.0),
            echosounder=EchoModel(0.0, 0.0),
        )


# --------------------------------------------------------------------------------------------
# Key specifications and value checks

_REQUIRED: Any = object()


@dataclass(frozen=True)
class _Spec:
    """One key: TOML name, kind ("float", "int", "bool", "str", "time"), default, check."""

    key: str
    kind: str
    default: Any
    check: Callable[[Any], Any] | None = None


def _range(
    lo: float | None, hi: float | None, *, lo_open: bool = False, hi_open: bool = False
) -> Callable[[float], float]:
    """A check accepting lo ≤ x ≤ hi (strict where ``*_open``), None meaning unbounded."""
    lo_txt = "" if lo is None else f"{lo:g} {'<' if lo_open else '<='} "
    hi_txt = "" if hi is None else f" {'<' if hi_open else '<='} {hi:g}"
    message = f"Out of range: must be {lo_txt}value{hi_txt} !"

    def check(value: float) -> float:
        if lo is not None and (value < lo or (lo_open and value == lo)):
            raise InputError(message)
        if hi is not None and (value > hi or (hi_open and value == hi)):
            raise InputError(message)
        return value

    return check


def _angle(value: float) -> float:
    """Degrees in [0, 360]; 360 is stored as 0."""
    if not 0.0 <= value <= 360.0:
        raise InputError("Out of range: must be 0 <= value <= 360 !")
    return 0.0 if value == 360.0 else value


def _non_empty(value: str) -> str:
    if not value.strip():
        raise InputError("Must not be empty !")
    return value.strip()


def _path(value: str) -> str:
    """A directory name: not empty, no NUL character."""
    if "\0" in value:
        raise InputError(NUL_IN_PATH_MESSAGE)
    return _non_empty(value)


def _position(value: str) -> str:
    parse_position(value)
    return value


_SIGMA = _range(0.0, None)
_POSITIVE = _range(0.0, None, lo_open=True)
_FINITE = _range(None, None)

_TOP: tuple[_Spec, ...] = (
    _Spec("name", "str", ""),
    _Spec("start_time", "time", _REQUIRED),
    _Spec("datum", "str", "ED50", _non_empty),
    _Spec("start_position", "str", _REQUIRED, _position),
    _Spec("sample_interval_s", "int", 1, _range(1, 3600)),
    _Spec("run_gps_datum", "str", "WGS84", _non_empty),
    _Spec("data_dir", "str", ".", _path),
    _Spec("water_depth_m", "float", None, _range(0.0, 11000.0, lo_open=True)),
    _Spec("fix_depth_max_m", "float", 0.5, _range(0.0, 30.0)),
    _Spec("acceleration_ms2", "float", 0.05, _range(0.0, 2.0, lo_open=True)),
    _Spec("max_pitch_deg", "float", 20.0, _range(0.0, 45.0, lo_open=True)),
    _Spec("rudder_gain_s", "float", 30.0, _range(0.0, 100.0)),
)
_CURRENT: tuple[_Spec, ...] = (
    _Spec("set_deg", "float", 0.0, _angle),
    _Spec("speed_kn", "float", 0.0, _range(0.0, 10.0)),
)
_SENSORS: tuple[_Spec, ...] = tuple(
    _Spec(f.name, "bool", f.default) for f in dataclasses.fields(SensorSet)
)
_GPS: tuple[_Spec, ...] = (
    _Spec("on", "bool", True),
    _Spec("sigma_m", "float", 35.0, _SIGMA),
    _Spec("tau_s", "float", 240.0, _POSITIVE),
    _Spec("white_sigma_m", "float", 5.0, _SIGMA),
    _Spec("hdop", "float", 0.0, _range(0.0, 50.0)),
    _Spec("hdop_swing", "float", 0.0, _range(0.0, 0.9)),
    _Spec("hdop_period_s", "float", 900.0, _POSITIVE),
    _Spec("uere_m", "float", 5.0, _POSITIVE),
    _Spec("quality", "int", 1, _range(1, 5)),
    _Spec("white_frac", "float", 0.01, _range(0.0, 1.0)),
)
_DECCA: tuple[_Spec, ...] = (
    _Spec("on", "bool", True),
    _Spec("chain", "str", "9B", _non_empty),
    _Spec("cf", "float", 64.0, _POSITIVE),
    _Spec("sigma_scale", "float", 1.0, _SIGMA),
    _Spec("tau_s", "float", 180.0, _POSITIVE),
    _Spec("white_sigma_lanes", "float", 0.0, _range(0.0, 0.5)),
    _Spec("red_scale", "float", 1.0, _range(0.0, 100.0)),
    _Spec("green_scale", "float", 1.0, _range(0.0, 100.0)),
    _Spec("purple_scale", "float", 1.0, _range(0.0, 100.0)),
)
_GYRO: tuple[_Spec, ...] = (
    _Spec("bias_deg", "float", 0.0, _range(-30.0, 30.0)),
    _Spec("sigma_deg", "float", 0.65, _range(0.0, 30.0)),
    _Spec("gm_sigma_deg", "float", 0.0, _range(0.0, 30.0)),
    _Spec("gm_tau_s", "float", 600.0, _POSITIVE),
)
_LOG: tuple[_Spec, ...] = (
    _Spec("scale_factor", "float", 0.0, _range(-0.5, 0.5)),
    _Spec("bias_kn", "float", 0.0, _range(-10.0, 10.0)),
    _Spec("sigma_frac", "float", 0.02, _range(0.0, 1.0)),
)
_INCL: tuple[_Spec, ...] = (
    _Spec("bias_deg", "float", 0.0, _range(-30.0, 30.0)),
    _Spec("sigma_deg", "float", 0.5, _range(0.0, 30.0)),
)
_PRESSURE: tuple[_Spec, ...] = (
    _Spec("bias_m", "float", 0.0, _range(-100.0, 100.0)),
    _Spec("sigma_m", "float", 1.45, _range(0.0, 100.0)),
    _Spec("s_weight", "float", 1.026, _POSITIVE),
    _Spec("ref_freq_hz", "float", 0.0, _range(0.0, None)),
)
_ECHO: tuple[_Spec, ...] = (
    _Spec("sigma_a_m", "float", 0.25, _SIGMA),
    _Spec("sigma_b", "float", 0.0045, _SIGMA),
)
_LEG: tuple[_Spec, ...] = (
    _Spec("duration_s", "int", _REQUIRED, _range(0, None, lo_open=True)),  # + MAX_MISSION_S
    _Spec("course_deg", "float", _REQUIRED, _angle),
    _Spec("speed_kn", "float", _REQUIRED, _range(0.0, 60.0)),
    _Spec("depth_m", "float", 0.0, _range(0.0, 1000.0)),
    _Spec("surfaced", "bool", None),
    _Spec("turn_rate_deg_s", "float", 0.5, _range(0.0, 10.0, lo_open=True)),
    _Spec("dive_rate_ms", "float", 0.2, _range(0.0, 5.0, lo_open=True)),
    _Spec("climb_rate_ms", "float", 0.2, _range(0.0, 5.0, lo_open=True)),
    _Spec("current_set_deg", "float", None, _angle),
    _Spec("current_speed_kn", "float", None, _range(0.0, 10.0)),
    _Spec("decca_sigma_factor", "float", 1.0, _range(0.0, 100.0)),
)
_TABLES: dict[str, tuple[_Spec, ...]] = {
    "current": _CURRENT,
    "sensors": _SENSORS,
    "gps": _GPS,
    "decca": _DECCA,
    "gyro": _GYRO,
    "log": _LOG,
    "inclinometer": _INCL,
    "pressure": _PRESSURE,
    "echosounder": _ECHO,
}

_TYPE_NAMES = {
    "float": "number",
    "int": "integer",
    "bool": "true/false",
    "str": "text",
    "time": "ISO 8601 UTC time",
}


def _typed(value: Any, kind: str) -> Any:
    """``value`` converted to ``kind`` or an InputError (bool is never a number here)."""
    bad = InputError(f"Wrong type: {_TYPE_NAMES[kind]} expected !")
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise bad
        value = float(value)
        if not math.isfinite(value):
            raise InputError("Not a finite number !")
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise bad
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise bad
        return value
    if kind == "str":
        if not isinstance(value, str):
            raise bad
        return value
    return _time(value)


def _time(value: Any) -> datetime:
    """A start time: TOML offset date-time or ISO 8601 text, UTC, whole seconds, 1970–2069."""
    if isinstance(value, str):
        try:
            value = datetime.fromisoformat(value.strip())
        except ValueError:
            raise InputError(
                "Wrong time: ISO 8601 UTC expected (e.g. 1992-09-17T08:35:38Z) !"
            ) from None
    if not isinstance(value, datetime):
        raise InputError("Wrong type: ISO 8601 UTC time expected !")
    offset = value.utcoffset()
    if offset is None or offset != timedelta(0):
        raise InputError("Time must be UTC (end with Z or +00:00) !")
    if value.microsecond:
        raise InputError("Whole seconds only (.RUN times are HHMMSS) !")
    if not 1970 <= value.year <= 2069:
        raise InputError("Year must be 1970-2069 (.RUN dates are YYMMDD) !")
    return value.astimezone(UTC)


def _read(data: Mapping[str, Any], specs: tuple[_Spec, ...], prefix: str) -> dict[str, Any]:
    """Typed and checked values of one table; unknown and missing keys are errors."""
    known = {s.key for s in specs}
    for key in data:
        if key not in known:
            raise InputError(UNKNOWN_KEY_MESSAGE, field=prefix + key, text=key)
    out: dict[str, Any] = {}
    for spec in specs:
        field = prefix + spec.key
        if spec.key not in data:
            if spec.default is _REQUIRED:
                raise InputError(MISSING_KEY_MESSAGE, field=field)
            out[spec.key] = spec.default
            continue
        raw = data[spec.key]
        try:
            value = _typed(raw, spec.kind)
            if spec.check is not None:
                value = spec.check(value)
        except InputError as err:
            raise InputError(err.message, field=field, text=str(raw)) from None
        out[spec.key] = value
    return out


def _table(data: Mapping[str, Any], name: str) -> Mapping[str, Any]:
    value = data.get(name, {})
    if not isinstance(value, dict):
        raise InputError("Wrong type: table expected !", field=name, text=str(value))
    return value


def _build(
    data: Mapping[str, Any],
    source: str,
    config_dir: Path,
    known_datums: Iterable[str] | None,
    known_chains: Iterable[str] | None,
) -> Scenario:
    tables = set(_TABLES) | {"leg"}
    top_data = {k: v for k, v in data.items() if k not in tables}
    for key, value in top_data.items():
        if isinstance(value, dict | list) and not any(s.key == key for s in _TOP):
            raise InputError(UNKNOWN_TABLE_MESSAGE, field=key, text=key)
    top = _read(top_data, _TOP, "")
    parts = {name: _read(_table(data, name), specs, f"{name}.") for name, specs in _TABLES.items()}
    current = Current(**parts["current"])
    sensors = SensorSet(**parts["sensors"])
    lat, lon = parse_position(top["start_position"])

    names = None if known_datums is None else list(known_datums)
    datum, gps_datum = top["datum"], top["run_gps_datum"]
    if names is not None:
        datum = parse_datum_name(datum, names, field="datum")
        gps_datum = parse_datum_name(gps_datum, names, field="run_gps_datum")
    decca = DeccaModel(**parts["decca"])
    if known_chains is not None and decca.chain not in set(known_chains):
        raise InputError(UNKNOWN_CHAIN_MESSAGE, field="decca.chain", text=decca.chain)

    water = top["water_depth_m"]
    if sensors.echosounder and water is None:
        raise InputError(
            "The echo sounder needs water_depth_m !", field="sensors.echosounder", text="true"
        )
    legs = _legs(data.get("leg"), top, current, water)
    return Scenario(
        name=top["name"],
        source=source,
        config_dir=config_dir,
        start_time=top["start_time"],
        datum=datum,
        start_position=top["start_position"],
        start_lat_deg=lat,
        start_lon_deg=lon,
        sample_interval_s=top["sample_interval_s"],
        run_gps_datum=gps_datum,
        data_dir_text=top["data_dir"],
        water_depth_m=water,
        fix_depth_max_m=top["fix_depth_max_m"],
        acceleration_ms2=top["acceleration_ms2"],
        max_pitch_deg=top["max_pitch_deg"],
        rudder_gain_s=top["rudder_gain_s"],
        current=current,
        sensors=sensors,
        gps=GpsModel(**parts["gps"]),
        decca=decca,
        gyro=GyroModel(**parts["gyro"]),
        log=LogModel(**parts["log"]),
        inclinometer=InclinometerModel(**parts["inclinometer"]),
        pressure=PressureModel(**parts["pressure"]),
        echosounder=EchoModel(**parts["echosounder"]),
        legs=legs,
    )


MAX_MISSION_S = 30 * 86400
"""Longest scenario (sum of the legs' ``duration_s``): 30 days, 2.6 million 1-s records, a
``.RUN`` file of about 250 MB; longer would only fill the disk (and the memory)."""


def _legs(
    raw: Any, top: Mapping[str, Any], current: Current, water: float | None
) -> tuple[Leg, ...]:
    if raw is None:
        raise InputError("No [[leg]] table: a scenario needs at least one leg !", field="leg")
    if not isinstance(raw, list) or not all(isinstance(t, dict) for t in raw):
        raise InputError("Wrong type: array of tables [[leg]] expected !", field="leg")
    legs = []
    total = 0
    for i, table in enumerate(raw, start=1):
        prefix = f"leg[{i}]."
        v = _read(table, _LEG, prefix)
        total += v["duration_s"]
        if total > MAX_MISSION_S:
            raise InputError(
                f"Mission too long: the legs may last {MAX_MISSION_S} s (30 days) in all !",
                field=prefix + "duration_s", text=str(v["duration_s"]),
            )
        legs.append(_leg(v, table, prefix, top, current, water))
    if not legs:
        raise InputError("No [[leg]] table: a scenario needs at least one leg !", field="leg")
    return tuple(legs)


def _leg(
    v: Mapping[str, Any], table: Mapping[str, Any], prefix: str, top: Mapping[str, Any],
    current: Current, water: float | None,
) -> Leg:
    """One leg from its read values ``v`` (raw ``table``), checked against the scenario's
    sample interval, water depth and fix depth; the scenario's current unless it sets its own."""
    if v["duration_s"] % top["sample_interval_s"]:
        raise InputError(
            "Must be a whole multiple of sample_interval_s !",
            field=prefix + "duration_s", text=str(v["duration_s"]),
        )
    if water is not None and v["depth_m"] >= water:
        raise InputError(
            "Must be shallower than water_depth_m !",
            field=prefix + "depth_m", text=str(table["depth_m"]),
        )
    surfaced = v["surfaced"]
    if surfaced is None:
        surfaced = v["depth_m"] <= top["fix_depth_max_m"]
    elif surfaced and v["depth_m"] > top["fix_depth_max_m"]:
        raise InputError(
            "A surfaced leg needs depth_m <= fix_depth_max_m !",
            field=prefix + "surfaced", text="true",
        )
    set_deg = current.set_deg if v["current_set_deg"] is None else v["current_set_deg"]
    speed = current.speed_kn if v["current_speed_kn"] is None else v["current_speed_kn"]
    return Leg(
        duration_s=v["duration_s"],
        course_deg=v["course_deg"],
        speed_kn=v["speed_kn"],
        depth_m=v["depth_m"],
        surfaced=surfaced,
        turn_rate_deg_s=v["turn_rate_deg_s"],
        dive_rate_ms=v["dive_rate_ms"],
        climb_rate_ms=v["climb_rate_ms"],
        current=Current(set_deg, speed),
        decca_sigma_factor=v["decca_sigma_factor"],
    )


# --------------------------------------------------------------------------------------------
# Loading, with errors located in the source


def parse_scenario_text(
    text: str,
    filename: str = "<string>",
    base_dir: Path = Path("."),
    *,
    known_datums: Iterable[str] | None = None,
    known_chains: Iterable[str] | None = None,
) -> Scenario:
    """Parse TOML ``text`` into a :class:`Scenario`.

    ``base_dir`` resolves ``data_dir``. With ``known_datums`` (TO_WGS84.DAT section 2 names)
    ``datum``/``run_gps_datum`` must be among them (stored in the file's spelling); with
    ``known_chains`` (DECCA.CHN ids) ``decca.chain`` must be one. Raises InputError located as
    ``filename:line: table.key: message (got 'text')``.
    """
    return parse_located(
        text, filename,
        lambda data: _build(data, filename, Path(base_dir), known_datums, known_chains),
        unquote=True)


def load_scenario(
    path: str | os.PathLike[str],
    *,
    known_datums: Iterable[str] | None = None,
    known_chains: Iterable[str] | None = None,
) -> Scenario:
    """Read and parse a scenario file (UTF-8 TOML); see :func:`parse_scenario_text`."""
    file = Path(path)
    text = read_text(file)
    return parse_scenario_text(
        text, str(file), file.parent, known_datums=known_datums, known_chains=known_chains
    )


