"""The simulated mission as an NMEA 0183 log: the same readings as the ``.RUN``, as sentences.

One epoch of the simulator (:func:`engine.sim.simulate.simulate`: a truth row and a record with
the *unquantised* readings) becomes, in this order within the second (docs/NMEA_OUT.md):

1. ``$GPGGA`` and ``$GPRMC`` — only when the record has a GPS position. Position on WGS84
   (the reading, on ``run_gps_datum``, converted to WGS84 with h = 0 on that datum as the run
   does, THEORY §2.1–2.2; the identity for the usual ``run_gps_datum = "WGS84"``), rounded to
   1e-4 minute (≤ 0.093 m). GGA: the record's fix quality and HDOP when the scenario models
   them (``RunRecord.gps_quality``/``gps_hdop``), else quality 1 (GPS SPS) and HDOP
   :data:`SIM_GGA_HDOP`; :data:`SIM_GGA_SATS` satellites; no altitude. RMC: status ``A``,
   mode ``A`` (``D`` for DGPS), speed and course over ground from the *true* velocity over
   ground (water speed along the true heading, times cos pitch, plus the current; the
   scenario has no error model for them), no variation.
2. ``$GPZDA`` — every epoch: the receiver's clock keeps giving time and date while the antenna
   is under water, so a reader always has the date and the second of the sensors that follow.
3. ``$HEHDT`` — when the gyro has a reading (true heading, 0.1°).
4. ``$VWVHW`` — when the log has a reading: speed through the water (0.1 kn) with the gyro's
   true heading when there is one (a log does not measure heading; VHW carries it by custom).
5. ``$SDDBT`` — when the echo sounder has a reading (depth below the transducer, 0.1 m).

Not written, because NMEA 0183 has no sentence for it: Decca (lane fractions), the pressure
depth sensor and the inclinometer (a proprietary ``XDR`` could carry them; no reader would
know what it means); the rudder angle (``RSA``) is display only and left out.

Differences from the ``.RUN`` (both written from the same unquantised readings): positions
1e-4′ (0.19 m step) against 0.001″ (0.03 m); echo depth 0.1 m against 0.01 m; heading and
speed 0.1 as in the ``.RUN`` (a value exactly on a half step may round the other way: the
``.RUN`` uses Python's float formatting, NMEA whole-step rounding half up); time 0.01 s.
"""

from __future__ import annotations

import math

from engine.geodesy.ellipsoid import WGS84, Datum
from engine.geodesy.ellipsoidal import DatumShift, datum_shift
from engine.io.nmea_write import dbt, gga, hdt, rmc, vhw, zda
from engine.io.runfile import RunRecord
from engine.systems.sensors import KNOT_MS

__all__ = ["SIM_GGA_HDOP", "SIM_GGA_QUALITY", "SIM_GGA_SATS", "SimNmea"]

SIM_GGA_QUALITY = 1
"""GGA fix quality of a simulated fix: 1 = GPS SPS (the scenarios model C/A-code GPS)."""
SIM_GGA_SATS = 8
"""Satellites in use written in GGA: a typical open-sky count (not modelled)."""
SIM_GGA_HDOP = 1.0
"""HDOP written in GGA when the scenario does not model one. The scenario's GPS error is then a
stationary Gauss–Markov process (one σ for the whole run), i.e. constant geometry: a constant
HDOP says exactly that. A reader that weights a fix by HDOP × UERE / √2 per axis needs a UERE of
√2 × the scenario's σ to weight it honestly (49.7 m for the SA-era demo's 35 m + 3 m)."""


def _same(a: Datum, b: Datum) -> bool:
    return a.name.strip().upper() == b.name.strip().upper()


class SimNmea:
    """Turns simulator epochs into NMEA sentences (one instance per run: holds the GPS datum →
    WGS84 transformation, built once)."""

    def __init__(self, gps_datum: Datum) -> None:
        self._to_wgs84: DatumShift | None = (
            None if _same(gps_datum, WGS84) else datum_shift(gps_datum, WGS84))

    def gps_wgs84(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """A GPS reading (degrees on ``run_gps_datum``) on WGS84 (h = 0 on the GPS datum)."""
        if self._to_wgs84 is None:
            return lat_deg, lon_deg
        lat, lon, _h = self._to_wgs84.transform(lat_deg, lon_deg, 0.0)
        return lat, lon

    def epoch(self, rec: RunRecord, *, heading_true_deg: float, speed_kn: float,
              pitch_deg: float, current_e_ms: float, current_n_ms: float) -> list[str]:
        """The sentences of one epoch, in the order of the module docstring (no line endings).

        ``rec`` holds the readings; the keyword arguments are the truth at the epoch (true
        heading deg, speed through the water kn, pitch deg, current east/north m/s) from which
        RMC's speed and course over ground are computed.
        """
        t = rec.time
        out: list[str] = []
        if rec.gps_lat_deg is not None and rec.gps_lon_deg is not None:
            lat, lon = self.gps_wgs84(rec.gps_lat_deg, rec.gps_lon_deg)
            sog_kn, cog_deg = ground_velocity(heading_true_deg, speed_kn, pitch_deg,
                                              current_e_ms, current_n_ms)
            quality = rec.gps_quality if rec.gps_quality is not None else SIM_GGA_QUALITY
            hdop = rec.gps_hdop if rec.gps_hdop is not None else SIM_GGA_HDOP
            out.append(gga(t, lat, lon, quality=quality, sats=SIM_GGA_SATS, hdop=hdop))
            out.append(rmc(t, lat, lon, sog_kn=sog_kn, cog_deg=cog_deg, valid=True,
                           mode="D" if quality == 2 else "A"))
        out.append(zda(t))
        if rec.heading_deg is not None:
            out.append(hdt(rec.heading_deg))
        if rec.speed_kn is not None:
            out.append(vhw(rec.heading_deg, rec.speed_kn))
        if rec.echo_m is not None:
            out.append(dbt(rec.echo_m))
        return out


def ground_velocity(heading_true_deg: float, speed_kn: float, pitch_deg: float,
                    current_e_ms: float, current_n_ms: float) -> tuple[float, float | None]:
    """(speed over ground kn, course over ground deg true) of a vessel with true heading,
    speed through the water (kn) and pitch (deg), in a current (east, north m/s); the course
    is None when the speed over ground is below 1 mm/s (no direction)."""
    v_h = speed_kn * KNOT_MS * math.cos(math.radians(pitch_deg))
    h = math.radians(heading_true_deg)
    ve = v_h * math.sin(h) + current_e_ms
    vn = v_h * math.cos(h) + current_n_ms
    sog_ms = math.hypot(ve, vn)
    cog = None if sog_ms < 1e-3 else math.degrees(math.atan2(ve, vn)) % 360.0
    return sog_ms / KNOT_MS, cog
