"""Pg 100, the main page (THEORY §12.8; thesis A8.5 L8991–8997).

Two boxes MPP and LSE (``Datum :``, ``Lat :``, ``Lon :``, ``Hg :``, ``RMS :``, ``a / b :``,
``Az :``), the sensor strip (``GYRO 232.3°  LOG 12.7kts  RUDR OFF  INCL N/A  PRESS OFF``) and the
five system boxes GPS, SINS, OMEGA, LORAN-C and DECCA. Every number is an engine value in the
engine's thesis format; each box is repainted only when its text changes (no flicker).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from textual.app import ComposeResult
from textual.containers import Horizontal
from textual.widget import Widget
from textual.widgets import Static

from engine import api
from engine.api import (
    PLACEHOLDER,
    RunConfig,
    format_angle_deg,
    format_lat_dm,
    format_lat_dms,
    format_lon_dm,
    format_lon_dms,
    format_metres,
    format_speed_kn,
    format_zone_lane,
)
from uvnav_tui.pages.input_kind import RUN_FILE, InputKind
from uvnav_tui.widgets.status_column import fix_age_text

if TYPE_CHECKING:
    from engine.api import CycleResult, PositionEstimate

SENSOR_LABELS = (("GYRO", 0), ("LOG", 1), ("RUDR", 2), ("INCL", 3), ("PRESS", 4), ("ECHO", 5))
"""Sensor strip labels and their index in ``SensorValues.status``."""
PATTERN_LABELS = (("Red", "red"), ("Green", "green"), ("Purple", "purple"))


def _ellipse_text(p: PositionEstimate | None, level: float) -> tuple[str, str]:
    """(``a / b`` text, ``Az`` text) of an estimate's ellipse at ``level``, or placeholders."""
    if p is None or p.ellipse is None:
        return f"{PLACEHOLDER}m {PLACEHOLDER}m", PLACEHOLDER
    a, b = p.ellipse.scaled(level)
    if not (math.isfinite(a) and math.isfinite(b)):
        return f"{PLACEHOLDER}m {PLACEHOLDER}m", PLACEHOLDER
    return (f"{format_metres(a, space=False)} {format_metres(b, space=False)}",
            format_angle_deg(p.ellipse.az_deg))


SECOND_M = 1852.0 / 60.0
"""One second of latitude on the ground [m] (a nautical mile is one minute)."""


def seconds_decimals(p: PositionEstimate | None) -> int:
    """Decimals of the seconds of arc a position deserves: the coarsest last digit no larger
    than its 95 % semi-major axis a (0.1″ ≈ 3 m for a GNSS fix of a = 4–30 m, whole seconds
    for a Decca fix of ±100 m), at most 3 (0.001″ ≈ 3 cm, the thesis' format; also without an
    ellipse)."""
    if p is None or p.ellipse is None:
        return 3
    a = p.ellipse.scaled(0.95)[0]
    if not (math.isfinite(a) and a > 0.0):
        return 3
    return max(0, min(3, math.ceil(math.log10(SECOND_M / a))))


def position_box_lines(p: PositionEstimate | None, datum: str, rms_m: float | None,
                       level: float, decimals: int = 3) -> list[str]:
    """The five lines of the MPP or LSE box (blank values when there is no estimate);
    ``decimals`` of the seconds of arc (the thesis: 3)."""
    if p is None:
        lat = lon = hg = ""
    else:
        lat = format_lat_dms(p.lat_deg, decimals=decimals)
        lon = format_lon_dms(p.lon_deg, decimals=decimals)
        hg = format_metres(-p.depth_m, decimals=1)
    rms = (format_metres(rms_m, space=False)
           if rms_m is not None and math.isfinite(rms_m) else PLACEHOLDER)
    ab, az = _ellipse_text(p, level)
    return [
        f"Datum : {datum}".ljust(22) + f"Hg : {hg}",
        f"Lat : {lat}",
        f"Lon : {lon}",
        f"RMS : {rms}".ljust(22) + f"Az : {az}",
        f"a / b : {ab}",
    ]


def _sensor_value(r: CycleResult, index: int) -> str:
    """The strip's value of sensor ``index`` (``OFF``, ``N/A``, a value, ``COG …`` for a
    stand-in)."""
    s = r.sensors
    status = s.status[index]
    if s.standin and index in (0, 1):  # COG/SOG stand in (docs/GNSS_WEIGHTS.md)
        v = s.heading_true_deg if index == 0 else s.speed_kn
        if v is None:
            return "COG ---"  # below sensors.cog_min_sog_kn
        return "COG " + format_angle_deg(v) if index == 0 else "SOG " + format_speed_kn(v)
    if status == 0:
        return "OFF"
    if status == 2:
        return "N/A"
    value = (s.heading_true_deg, s.speed_kn, s.rudder_deg, s.incl_deg, s.depth_m, s.echo_m)[index]
    if value is None:
        return "N/A"
    if index == 1:
        return format_speed_kn(value)
    if index >= 4:
        return format_metres(value, decimals=1, space=False)
    return format_angle_deg(value)


NMEA_SENSORS = (0, 1, 5)
"""The sensors NMEA 0183 input can have: heading, water speed, echo sounder (docs/NMEA.md)."""


def sensor_strip(r: CycleResult | None, cfg: RunConfig, kind: InputKind = RUN_FILE) -> str:
    """``GYRO 232.3°  LOG 12.7kts  RUDR OFF  INCL N/A  PRESS OFF  ECHO N/A`` for a ``.RUN``;
    for NMEA input the heading named by its source (``GYRO``, ``COMPASS``), no rudder,
    inclinometer or pressure, and the record's COG/SOG when it has them:
    ``COMPASS 72.5°  LOG 4.7kts  ECHO 3.9m  COG 81.7° SOG 4.3kts``."""
    parts = []
    for label, i in SENSOR_LABELS:
        if kind.nmea and i not in NMEA_SENSORS:
            continue
        if kind.nmea and i == 0:
            label = kind.heading_short
        if r is None:
            name = ("gyro", "log", "rudder", "inclinometer", "pressure", "echosounder")[i]
            state = cfg.sensors.status(name)
            value = {0: "OFF", 1: "---", 2: "N/A"}[state]
        else:
            value = _sensor_value(r, i)
        if kind.nmea and i == 5 and value == "N/A":
            continue  # no echo sounder in this stream
        parts.append(f"{label} {value}")
    if kind.nmea and r is not None and not r.sensors.standin:
        rec = api.run_record(r)
        if rec is not None and rec.cog_deg is not None:
            parts.append(f"COG {format_angle_deg(rec.cog_deg)}")
        if rec is not None and rec.sog_kn is not None:
            parts.append(f"SOG {format_speed_kn(rec.sog_kn)}")
    return "  ".join(parts)


def gps_box_lines(r: CycleResult | None, cfg: RunConfig,
                  kind: InputKind = RUN_FILE) -> list[str]:
    """WGS84 ECEF and the raw WGS84 fix (``X 3848703.06 … Lat 52°50.50' N``); for NMEA input
    the receiver's fix as it gives it: latitude, longitude (minutes to 4 decimals, 0.2 m, as
    GGA carries them), fix quality, HDOP and satellites."""
    if not cfg.gps.on:
        return ["off", "", ""]
    if r is None or r.gps is None:
        return ["no fix", "", ""]
    g = r.gps
    x, y, z = g.ecef_m
    w = g.weight
    extra = ""
    if w is not None and w.hdop is not None:  # NMEA GGA only: a 1993 box is unchanged
        extra = f"{api.quality_name(w.quality)} HDOP {w.hdop:.1f}"
    if kind.nmea:
        rec = api.run_record(r)
        sats = f"  {rec.gps_sats} sats" if rec is not None and rec.gps_sats is not None else ""
        return [f"Lat {format_lat_dm(g.wgs84_lat_deg, space=True, decimals=4)}",
                f"Lon {format_lon_dm(g.wgs84_lon_deg, space=True, decimals=4)}",
                (extra + sats).strip() or "WGS84"]
    return [
        f"X {x:.2f}".ljust(15) + f"Lat {format_lat_dm(g.wgs84_lat_deg, space=True)}",
        f"Y {y:.2f}".ljust(15) + f"Lon {format_lon_dm(g.wgs84_lon_deg, space=True)}",
        (f"Z {z:.2f}".ljust(15) + extra).rstrip(),
    ]


def decca_box_lines(r: CycleResult | None, cfg: RunConfig,
                    cycle_cfg: RunConfig | None = None) -> list[str]:
    """``Chain 9B``, then zone+lane per pattern (``Red B20.9 *``; * = selected). The chain and
    the selection are those the cycle ``r`` was computed with (``cycle_cfg``), so that a chain
    chosen since does not label the old chain's lanes: ``Chain 9B (2E next)`` until the next
    cycle."""
    d = cfg.decca
    shown = cycle_cfg.decca if r is not None and cycle_cfg is not None else d
    head = f"Chain {shown.chain}" + (f" ({d.chain} next)" if d.chain != shown.chain else "")
    lines = [head + ("" if d.on else "  off")]
    d = shown
    observed: tuple[float | None, ...] = (None, None, None)
    if r is not None and r.decca_on and r.fix is not None:
        observed = r.fix.decca_observed
    for (label, pattern), total in zip(PATTERN_LABELS, observed, strict=True):
        value = format_zone_lane(total, pattern) if total is not None else "---"
        star = " *" if pattern in d.select else ""
        lines.append(f"{label:<7}{value}{star}")
    return lines


def mpp_rms(r: CycleResult) -> float | None:
    """RMS of the LOP residuals of this cycle's fix (None without a fix)."""
    if r.fix is None or not r.fix.ok:
        return None
    return r.fix.rms_m


class MainPage(Widget):
    """Pg 100; call :meth:`show` with the latest cycle."""

    def __init__(self, *, id: str | None = None) -> None:
        super().__init__(id=id)
        self._texts: dict[str, str] = {}

    def compose(self) -> ComposeResult:
        """Boxes laid out as on the thesis page."""
        with Horizontal(id="pos-boxes"):
            yield Static(id="box-mpp", classes="pg-box pos-box", markup=False)
            yield Static(id="box-lse", classes="pg-box pos-box", markup=False)
        yield Static(id="sensor-strip", markup=False)
        with Horizontal(id="sys-row-1"):
            yield Static(id="box-gps", classes="pg-box", markup=False)
            yield Static(id="box-decca", classes="pg-box", markup=False)
        with Horizontal(id="sys-row-2"):
            yield Static("not connected", id="box-sins", classes="pg-box", markup=False)
            yield Static("not connected", id="box-omega", classes="pg-box", markup=False)
            yield Static("not connected", id="box-loran", classes="pg-box", markup=False)

    def on_mount(self) -> None:
        """Box titles."""
        for box, title in (("mpp", "MPP"), ("lse", "LSE"), ("gps", "GPS"), ("decca", "DECCA"),
                           ("sins", "SINS"), ("omega", "OMEGA"), ("loran", "LORAN-C")):
            self.query_one(f"#box-{box}", Static).border_title = title

    def _set(self, box: str, text: str) -> None:
        if self._texts.get(box) != text:
            self._texts[box] = text
            self.query_one(f"#{box}", Static).update(text, layout=False)

    def show(self, r: CycleResult | None, cfg: RunConfig,
             cycle_cfg: RunConfig | None = None, *, fix_age_s: float | None = None,
             kind: InputKind = RUN_FILE) -> None:
        """Render the cycle ``r`` (None before the first cycle) with the run's settings
        (``cycle_cfg``: those ``r`` was computed with, where they label its values); the MPP
        box's lower edge names its source and the age of the last fix (``fix_age_s``);
        ``kind``: the input (NMEA: readings labelled by their source, positions to the
        precision of the fix)."""
        level = cfg.lsq.conf_region_pct / 100.0
        datum = r.datum if r is not None else cfg.datum
        mpp = r.mpp if r is not None else None
        lse = api.lse_estimate(r) if r is not None else None
        rms = mpp_rms(r) if r is not None else None
        nd = seconds_decimals(mpp) if kind.nmea else 3
        self._set("box-mpp", "\n".join(position_box_lines(mpp, datum, rms, level, nd)))
        nd = seconds_decimals(lse) if kind.nmea else 3
        self._set("box-lse", "\n".join(position_box_lines(
            lse, datum, rms if lse is not None else None, level, nd)))
        mpp_box = self.query_one("#box-mpp", Static)
        mpp_box.border_subtitle = (f"{mpp.source}  {fix_age_text(fix_age_s)}"
                                   if mpp is not None else "")
        self._set("sensor-strip", sensor_strip(r, cfg, kind))
        self._set("box-gps", "\n".join(gps_box_lines(r, cfg, kind)))
        self._set("box-decca", "\n".join(decca_box_lines(r, cfg, cycle_cfg)))
