"""GPS behind the systems seam: a position on the working datum as two coordinate LOPs.

Frames: the record's GPS position is geodetic on ``run_gps_datum``; the run transforms it to the
working datum (h = 0 on the source datum, THEORY §2.1–2.2) and the TM grid of the cycle. The
two rows are northing ("Lat") and easting ("Lon"), each with the a priori variance of the receiver
type (thesis ch. 5, table 5.1; THEORY D5) or, for a record with an HDOP (NMEA GGA) under
``gps.weights = "receiver"``, σ = HDOP × UERE(quality) / √2 per axis (:func:`gps_weight`,
docs/GNSS_WEIGHTS.md). On the too-few-LOPs path the filter's prediction stands in for these two
rows (:class:`PriorObservations`, THEORY §4.6).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

import numpy as np

from engine.geodesy.ellipsoid import WGS84
from engine.io.runfile import RunRecord
from engine.systems.base import (
    CycleInputs,
    LopReading,
    Point,
    PositionPrior,
    SystemReading,
    set_row,
)

GPS_VAR_CA_M2 = 2500.0
"""A priori variance of a C/A-code GPS coordinate (σ = 50 m; thesis L5564, Pg 611/821)."""
GPS_VAR_P_M2 = 8.9**2
"""A priori variance of a P-code GPS coordinate: 2 d_rms 17.8 m → σ 8.9 m (THEORY D5)."""

SA_OFF_UTC = datetime(2000, 5, 2, 4, 0)
"""Selective Availability was set to zero at midnight EDT, 1–2 May 2000 (04:00 UTC, 2 May;
statement of the President of the United States, 1 May 2000): a C/A fix dated later is not
degraded by it (UTC; a record's naive time is read as UTC, :func:`after_sa`)."""
SPS_2008_H95_WORST_SITE_M = 17.0
"""GPS SPS Performance Standard, 4th ed. (Sept. 2008), the position domain accuracy
standard: ≤ 17 m 95 % horizontal error at the worst site (≤ 9 m global average), SA off."""
K95_2D = math.sqrt(-2.0 * math.log(0.05))
"""Radius of the 95 % circle of a circular 2-D normal in units of its σ per axis (2.4477):
the same reading of a 95 % horizontal figure as ``lsq.gps_se_sf`` (100 m → 41 m, THEORY D5)."""
GPS_SIGMA_CA_SPS_M = SPS_2008_H95_WORST_SITE_M / K95_2D
"""σ per axis (m) of a C/A fix without an HDOP dated after :data:`SA_OFF_UTC`: the SPS
Performance Standard's worst-site 17 m 95 % as a circular normal, 6.95 m (docs/GNSS_WEIGHTS.md)."""



def after_sa(time: datetime) -> bool:
    """True when ``time`` (UTC, naive or aware) is after :data:`SA_OFF_UTC`."""
    if time.year != 2000:
        return time.year > 2000
    return time.replace(tzinfo=None) >= SA_OFF_UTC if time.tzinfo is None else (
        time >= SA_OFF_UTC.replace(tzinfo=UTC))


ROW_LAT, ROW_LON = 0, 1
"""Rows of the system: northing ("Lat") and easting ("Lon")."""


QUALITY_NAMES = {1: "SPS", 2: "DGPS", 3: "PPS", 4: "RTK fixed", 5: "RTK float"}
"""NMEA GGA fix quality codes that reach a record, in words (0 invalid, 6 dead reckoning,
7 manual and 8 simulator are not fixes and never do)."""


def quality_name(quality: int | None) -> str:
    """The GGA quality code in words ("SPS", "DGPS", …; "?" for None, "q9" for another)."""
    if quality is None:
        return "?"
    return QUALITY_NAMES.get(quality, f"q{quality}")


@dataclass(frozen=True, slots=True)
class GpsWeight:
    """Where the a priori σ of a GPS coordinate comes from (docs/GNSS_WEIGHTS.md).

    ``origin`` "receiver": σ = HDOP × UERE(quality) / √2 per horizontal axis (the HDOP scales
    the horizontal d_rms, d_rms² = σ_E² + σ_N² = HDOP²·σ_UERE², split evenly over the two
    axes), at least ``floor_m``; "sps": a C/A fix without an HDOP dated after Selective
    Availability was switched off, σ :data:`GPS_SIGMA_CA_SPS_M` (the SPS Performance
    Standard 2008's worst site); "fixed": the receiver type's 1993 figure (C/A 50 m, P 8.9 m)
    times ``lsq.gps_se_sf``. ``sigma_m`` is the σ used per axis (m); ``hdop``, ``quality``,
    ``sats`` as in the record; ``uere_m`` the UERE of the quality code (m, 1σ)."""

    origin: str
    sigma_m: float
    hdop: float | None = None
    quality: int | None = None
    sats: int | None = None
    uere_m: float | None = None
    floored: bool = False
    se_sf: float = 1.0
    receiver: str = "C/A"

    @property
    def receiver_weighted(self) -> bool:
        """True when the σ follows the receiver's HDOP (not the fixed 1993 figure)."""
        return self.origin == "receiver"

    @property
    def sa_free(self) -> bool:
        """True when the fix is not degraded by Selective Availability (an HDOP-weighted or an
        "sps" fix): the filter models its error as a modern receiver's (docs/GNSS_WEIGHTS.md)."""
        return self.origin != "fixed"

    def describe(self) -> str:
        """The σ and its origin in one line, e.g. ``σ 4.24 m = HDOP 1.2 × UERE 5.0 m / √2``."""
        if self.receiver_weighted:
            text = (f"σ {self.sigma_m:.2f} m = HDOP {self.hdop:.1f} × UERE {self.uere_m:g} m "
                    f"({quality_name(self.quality)}) / √2")
            return text + (" → floor" if self.floored else "")
        if self.origin == "sps":
            return (f"σ {self.sigma_m:.2f} m = SPS PS 2008 worst site "
                    f"{SPS_2008_H95_WORST_SITE_M:g} m 95 % / {K95_2D:.3f} (no HDOP, SA off)")
        base = 8.9 if self.receiver == "P" else 50.0
        code = "P code" if self.receiver == "P" else "C/A code"
        return f"σ {self.sigma_m:.2f} m = {code} {base:g} m × √SE_SF {self.se_sf:g}"


@dataclass(frozen=True, slots=True)
class GpsFix:
    """A GPS position already on the working datum and grid (metres), with its a priori variance
    per coordinate (m², already × ``GPS.SE_SF`` or from the receiver's HDOP), the operator's
    corrections north/east (m) and where the variance came from (``weight``)."""

    lat_deg: float
    lon_deg: float
    x_m: float
    y_m: float
    var_m2: float
    corr_north_m: float = 0.0
    corr_east_m: float = 0.0
    weight: GpsWeight | None = None


@dataclass(frozen=True, slots=True)
class GpsInput:
    """The GPS record of a cycle: as received (on ``run_gps_datum``), its WGS84 ECEF for Pg 100,
    the displayed WGS84 height ``hg_m`` (THEORY §12.8), on the working datum, and on the grid."""

    lat_in_deg: float
    lon_in_deg: float
    wgs84_lat_deg: float
    wgs84_lon_deg: float
    hg_m: float
    ecef_m: tuple[float, float, float]
    lat_deg: float
    lon_deg: float
    x_m: float
    y_m: float
    weight: GpsWeight | None = None
    """The σ of its coordinates and where it came from (None only for a hand-built input)."""


GRID_MAX_DLON_DEG = 6.0
"""Farthest a GPS position may lie from the cycle's central meridian (degrees of longitude) to
be taken into the fix. The grid follows the MPP to the whole degree (THEORY §2.3), so a real
fix lies within 1–2° of it; 6° away the TM scale factor already reaches 1.0055 at the equator,
beyond what the fix's line-scale correction (thesis A5.10) is meant for, and much farther the
grid's series diverge. Such a fix means a wrong DR position or a wrong record."""


_WGS84_A = WGS84.ellipsoid.a_m
_WGS84_E2 = WGS84.ellipsoid.e2
"""WGS84's a (m) and e² as :func:`engine.geodesy.ellipsoidal.geodetic_to_ecef` reads them."""
radians, sin, cos, sqrt = math.radians, math.sin, math.cos, math.sqrt
remainder = math.remainder


def gps_input(inputs: CycleInputs) -> GpsInput | None:
    """The record's GPS position on WGS84, the working datum and the grid (None: GPS off or no
    position in the record)."""
    ctx, rec = inputs.context, inputs.record
    if not inputs.config.gps.on or rec.gps_lat_deg is None or rec.gps_lon_deg is None:
        return None
    lat_in, lon_in = rec.gps_lat_deg, rec.gps_lon_deg
    if ctx.gps_shift is None:
        lat, lon, h_datum = lat_in, lon_in, 0.0
    else:
        # h = 0 on the source datum for the horizontal transformation (THEORY §2.1–2.2).
        lat, lon, h_datum = ctx.gps_shift.transform(lat_in, lon_in, 0.0)
    if ctx.gps_to_wgs84 is None:
        w_lat, w_lon, hg = lat_in, lon_in, -h_datum
    else:
        w_lat, w_lon, hg = ctx.gps_to_wgs84.transform(lat_in, lon_in, 0.0)
    # geodetic_to_ecef(w_lat, w_lon, hg, WGS84.ellipsoid) written out with WGS84's a and e²
    # taken once (the same operations in the same order, the same floats).
    phi = radians(w_lat)
    lam = radians(w_lon)
    sphi = sin(phi)
    cphi = cos(phi)
    nu = _WGS84_A / sqrt(1.0 - _WGS84_E2 * sphi * sphi)
    r = (nu + hg) * cphi
    ecef = (r * cos(lam), r * sin(lam), (nu * (1.0 - _WGS84_E2) + hg) * sphi)
    x, y = inputs.grid.forward(lat, lon)
    return GpsInput(lat_in, lon_in, w_lat, w_lon, hg, ecef, lat, lon, x, y,
                    gps_weight(inputs.config, rec))


def gps_variance_m2(config: Any) -> float:
    """A priori variance of one GPS coordinate (m²) of a run configuration: the receiver's
    (C/A or P code) times ``lsq.gps_se_sf``."""
    return (GPS_VAR_P_M2 if config.gps.receiver == "P" else GPS_VAR_CA_M2) * config.lsq.gps_se_sf


class _PerConfig:
    """What :class:`GpsSystem` needs every cycle and that only the (frozen) run configuration
    decides, computed once per configuration object: the fixed variance (m²) and the fixed
    :class:`GpsWeight` of a record without HDOP, quality or satellites (a 1993 record)."""

    __slots__ = ("config", "variance_m2", "fixed_weight", "sps_weight")

    def __init__(self, config: Any) -> None:
        self.config = config
        self.variance_m2 = gps_variance_m2(config)
        self.fixed_weight = GpsWeight("fixed", math.sqrt(self.variance_m2), None, None, None,
                                      se_sf=config.lsq.gps_se_sf, receiver=config.gps.receiver)
        g = config.gps
        self.sps_weight = None
        if (g.weights == "receiver" and g.receiver == "C/A"
                and getattr(config.filter, "preset", "honest") != "thesis"):
            self.sps_weight = GpsWeight("sps", GPS_SIGMA_CA_SPS_M, None, None, None,
                                        receiver=g.receiver)


_per_config: _PerConfig | None = None


def _of_config(config: Any) -> _PerConfig:
    """The :class:`_PerConfig` of ``config`` (one entry: a run has one configuration)."""
    global _per_config
    pc = _per_config
    if pc is None or pc.config is not config:
        pc = _per_config = _PerConfig(config)
    return pc


def gps_weight(config: Any, record: RunRecord) -> GpsWeight:
    """The a priori σ per horizontal coordinate (m) of the record's GPS fix and its origin.

    With ``gps.weights = "receiver"`` and a usable HDOP in the record (finite, > 0):
    σ = max(HDOP × UERE(quality) / √2, ``gps.sigma_floor_m``) — HDOP² = G_EE + G_NN of the
    geometry's (GᵀG)⁻¹, so σ_E² + σ_N² = HDOP²·σ_UERE² (the horizontal d_rms²), split evenly
    because GGA gives no more (docs/GNSS_WEIGHTS.md). Without a usable HDOP, a C/A fix dated
    after :data:`SA_OFF_UTC` under ``gps.weights = "receiver"`` (not ``filter.preset =
    "thesis"``) gets :data:`GPS_SIGMA_CA_SPS_M` ("sps"). Otherwise the fixed 1993 figure:
    √(:func:`gps_variance_m2`), so every 1993 ``.RUN`` replays exactly as before.
    """
    g = config.gps
    hdop = record.gps_hdop
    sats, quality = record.gps_sats, record.gps_quality
    if hdop is None and sats is None and quality is None:  # a 1993 record: per configuration
        pc = _of_config(config)
        if pc.sps_weight is not None and after_sa(record.time):
            return pc.sps_weight
        return pc.fixed_weight
    if g.weights == "receiver" and hdop is not None and math.isfinite(hdop) and hdop > 0.0:
        uere = g.uere_m(quality)
        sigma = hdop * uere / math.sqrt(2.0)
        floored = sigma < g.sigma_floor_m
        return GpsWeight("receiver", max(sigma, g.sigma_floor_m), hdop, quality, sats, uere,
                         floored)
    pc = _of_config(config)
    if pc.sps_weight is not None and after_sa(record.time):
        return GpsWeight("sps", GPS_SIGMA_CA_SPS_M, hdop, quality, sats, receiver=g.receiver)
    return GpsWeight("fixed", math.sqrt(gps_variance_m2(config)), hdop, quality, sats,
                     se_sf=config.lsq.gps_se_sf, receiver=g.receiver)


class _GpsObservations:
    """The two coordinate rows of a GPS fix (thesis ch. 5, table 5.1 category I)."""

    messages: tuple[str, ...] = ()
    __slots__ = ("gps",)

    def __init__(self, gps: GpsFix) -> None:
        self.gps = gps

    def available(self) -> list[bool]:
        return [True, True]

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        g = self.gps
        lat, lon = slot0 + ROW_LAT, slot0 + ROW_LON
        # set_row(A, lat, 0.0, 1.0) and set_row(A, lon, 1.0, 0.0), written out
        A[2 * lat] = 0.0
        A[2 * lat + 1] = 1.0
        A[2 * lon] = 1.0
        A[2 * lon + 1] = 0.0
        b[lat] = g.y_m + g.corr_north_m - p.y
        b[lon] = g.x_m + g.corr_east_m - p.x
        Cl[lat, lat] = g.var_m2
        Cl[lon, lon] = g.var_m2

    def readings(self, p: Point) -> list[LopReading]:
        g = self.gps
        return _position_rows("GPS", g.lat_deg, g.lon_deg, g.corr_north_m, g.corr_east_m, p)

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        return float("inf")


class PriorObservations:
    """The filter's predicted position as the two rows of the GPS slots (the hybrid fix of the
    too-few-LOPs path; THEORY §4.6, §9.3)."""

    messages: tuple[str, ...] = ()
    __slots__ = ("prior",)

    def __init__(self, prior: PositionPrior) -> None:
        self.prior = prior

    def available(self) -> list[bool]:
        return [True, True]

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        pr = self.prior
        set_row(A, slot0 + ROW_LAT, 0.0, 1.0)
        set_row(A, slot0 + ROW_LON, 1.0, 0.0)
        b[slot0 + ROW_LAT] = pr.y_m - p.y
        b[slot0 + ROW_LON] = pr.x_m - p.x
        s = slice(slot0, slot0 + 2)
        Cl[s, s] = pr.cov[::-1, ::-1]  # slot order (y, x) against the prior's (x, y)

    def readings(self, p: Point) -> list[LopReading]:
        lat, lon = p.grid.inverse(self.prior.x_m, self.prior.y_m)
        return _position_rows("KF", lat, lon, 0.0, 0.0, p)

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        return float("inf")


def _position_rows(system: str, lat: float, lon: float, corr_n: float, corr_e: float,
                   p: Point) -> list[LopReading]:
    """The "Lat"/"Lon" page rows: read and computed in degrees, corrections in metres."""
    lat_hat, lon_hat = p.latlon
    return [LopReading(ROW_LAT, system, "Lat", lat, corr_n, lat_hat, 90.0),
            LopReading(ROW_LON, system, "Lon", lon, corr_e, lon_hat, 180.0)]


class GpsSystem:
    """GPS behind :class:`engine.systems.base.NavSystem` (config table ``[gps]``)."""

    name = "gps"
    letter = "G"
    column: int | None = 0
    slot_labels = ("Lat", "Lon")
    observations_class: type[_GpsObservations] = _GpsObservations
    """What :meth:`observations` makes of a fix."""

    def is_on(self, config: Any) -> bool:
        return bool(config.gps.on)

    def fix_source(self, config: Any) -> tuple[object, ...]:
        """The receiver type (C/A or P code) while GPS is on."""
        return ("GPS", config.gps.receiver) if config.gps.on else ()

    def read(self, inputs: CycleInputs) -> SystemReading:
        """The record's GPS position as a :class:`GpsFix` (``detail``: the :class:`GpsInput`)."""
        gps = self.gps_input(inputs)
        if gps is None:
            return SystemReading()
        wr = remainder(gps.lon_deg - inputs.cm_deg, 360.0)  # wrap_180_deg, written out
        off_deg = abs(180.0 if wr == -180.0 else wr + 0.0)
        if off_deg > GRID_MAX_DLON_DEG:
            return SystemReading(messages=(
                f"GPS position {off_deg:.1f}° of longitude from the grid's central meridian: "
                "not taken (check the DR position and the record)",))
        c = inputs.config.corrections
        w = gps.weight if gps.weight is not None else gps_weight(inputs.config, inputs.record)
        # The fixed figure keeps its variance exactly as before (σ² of √var is not bit-exact).
        # (w.origin == "fixed" is ``not w.sa_free``, without the property's call.)
        if w.origin == "fixed":
            pc = _per_config
            var = (pc if pc is not None and pc.config is inputs.config
                   else _of_config(inputs.config)).variance_m2
        else:
            var = w.sigma_m**2
        fix = GpsFix(gps.lat_deg, gps.lon_deg, gps.x_m, gps.y_m, var, c.gps_north_m,
                     c.gps_east_m, w)
        return SystemReading(fix, (), gps, True)

    def gps_input(self, inputs: CycleInputs) -> GpsInput | None:
        """The record's GPS position (:func:`gps_input`)."""
        return gps_input(inputs)

    def observations(self, value: GpsFix | None, p0: Point) -> _GpsObservations | None:
        return None if value is None else self.observations_class(value)

    def row_name(self, index: int, value: Any) -> str | None:
        """``GPS Lat``/``GPS Lon``; ``value`` is the label ("KF" when the prediction stands in)."""
        return f"{value} {self.slot_labels[index]}"


GPS = GpsSystem()
