"""The integrated position as NMEA 0183: one cycle's MPP → ZDA, GGA, RMC, (GLL), GST, HDT on WGS84.

A chart plotter (OpenCPN, …) shows the UVNAV position next to the raw GNSS when it receives
these sentences (docs/NMEA_OUT.md). Pure: a :class:`~engine.run.cycle.CycleResult` in, a list
of sentences out (no line endings); sending them is :mod:`engine.io.nmea_send`'s job.

* **Datum.** NMEA positions are WGS84. The MPP is geodetic on the cycle's working datum (often
  ED50); it is transformed with the project's datum machinery
  (:class:`~engine.geodesy.ellipsoidal.DatumShift`, the Bursa–Wolf parameters of
  ``TO_WGS84.DAT``, THEORY §2.1–2.2) with h = 0 on the working datum. The run converts GPS the
  other way with h = 0 on WGS84; the two differ by the tens of metres of height between the
  ellipsoids, which moves the horizontal position by well under a millimetre.
* **Fix quality (GGA) / status and mode (RMC, GLL).** 1 (status ``A``, mode ``A``) when this
  cycle's least-squares fix was used (GPS, Decca or bearings: GGA has no code for a non-GNSS
  radio fix; the quality says "a measured position this second"); 6 "estimated (dead
  reckoning)" (status ``V``, mode ``E`` as NMEA 0183 v4.1 requires for any mode but A/D)
  when the MPP is the filter's prediction or a fix kept out by the gross-error gate; 0 with
  empty position fields when the MPP has no precision (no filter and no fix: the last MPP
  repeated). OpenCPN and most plotters plot GGA quality 6; a UVNAV NMEA reader never takes
  a 6 or a ``V`` as a fix (issue 13).
* **HDOP (GGA).** A pseudo value: the MPP's horizontal error drms = √(σ_E² + σ_N²) divided
  by :data:`NMEA_OUT_UERE_M`, so that HDOP × UERE = drms as for a receiver; clipped to
  0.1–99.9. The ellipse itself goes in GST.
* **GST.** 1 σ semi-axes of the MPP's error ellipse, the major axis' orientation from true
  north (grid azimuth + convergence γ), σ of latitude and longitude (m, the VCV rotated from
  grid to true north); the range-residual RMS and the altitude σ are empty.
* **Speed and course over ground (RMC), heading (HDT).** From the filter state: velocity
  through the water along the grid heading times cos ε plus the current, rotated to true by
  γ (grid scale ignored: k − 1 < 1e-3 on the run's grid); HDT = grid heading + γ. Empty / not
  sent without a filter.
* **Satellites (GGA).** Empty: the integrated position has none of its own.
* **ZDA** first in every cycle: the cycle's time and date from the integrated system's clock,
  so a reader has the time of a cycle whose GGA/RMC it rejects as "not a fix" (a dead-reckoned
  cycle), and of the HDT after it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.filter.state import IEPS, IPSI, IV, IVCX, IVCY
from engine.geodesy.ellipsoid import WGS84, Datum
from engine.geodesy.ellipsoidal import DatumShift, datum_shift
from engine.geodesy.tmgrid import TMGrid
from engine.io.datumfile import DatumFile
from engine.io.nmea_write import gga, gll, gst, hdt, rmc, zda
from engine.run.cycle import CycleResult
from engine.systems.sensors import KNOT_MS

__all__ = [
    "NMEA_OUT_UERE_M",
    "QUALITY_DR",
    "QUALITY_FIX",
    "QUALITY_NONE",
    "NmeaOutOptions",
    "NmeaPositionOut",
    "cycle_quality",
]

NMEA_OUT_UERE_M = 5.0
"""User equivalent range error (m, 1 σ) that turns the MPP's drms into a pseudo HDOP: about
what a single-frequency GPS receiver of today has (broadcast orbits and clocks ~1 m, ionosphere
after the broadcast model a few metres), so a plotter's "HDOP 1" still means "metres"."""
QUALITY_FIX = 1
"""GGA quality of a cycle whose fix was used."""
QUALITY_DR = 6
"""GGA quality "estimated (dead reckoning)": the MPP is the filter's prediction."""
QUALITY_NONE = 0
"""GGA quality "invalid": the MPP has no precision (the last MPP repeated)."""
HDOP_RANGE = (0.1, 99.9)
"""Pseudo HDOP bounds (the GGA field has one decimal; 0.0 would read as 'unknown')."""


@dataclass(frozen=True, slots=True)
class NmeaOutOptions:
    """What to send per cycle: the talker (``IN`` = integrated navigation, so a plotter does not
    mistake it for the raw ``GP``), ZDA (time and date) before, GLL besides GGA and RMC, GST (the
    ellipse), HDT (the filter's true heading) and the UERE of the pseudo HDOP (m)."""

    talker: str = "IN"
    zda: bool = True
    gll: bool = False
    gst: bool = True
    hdt: bool = True
    uere_m: float = NMEA_OUT_UERE_M


def cycle_quality(r: CycleResult) -> int:
    """GGA quality of the cycle's MPP (module docstring): 1 fix used, 6 dead reckoning,
    0 no precision."""
    cov = np.asarray(r.mpp.cov, dtype=float)
    if cov.shape[:2] != (2, 2) or not np.isfinite(cov[:2, :2]).all():
        return QUALITY_NONE
    if r.fix is not None and r.fix.lse_ok and r.fix_gate != "gross":
        return QUALITY_FIX
    return QUALITY_DR


class NmeaPositionOut:
    """Cycle results → NMEA sentences on WGS84. Holds the datum shifts and grids it needs,
    built on first use per working datum (the operator may change it during a run)."""

    def __init__(self, datums: DatumFile, options: NmeaOutOptions | None = None) -> None:
        self.datums = datums
        self.options = options if options is not None else NmeaOutOptions()
        self._datums: dict[str, tuple[Datum, DatumShift | None]] = {}
        self._grids: dict[tuple[str, float], TMGrid] = {}

    def _datum(self, name: str) -> tuple[Datum, DatumShift | None]:
        key = name.strip().upper()
        found = self._datums.get(key)
        if found is None:
            datum = WGS84 if key == "WGS84" else self.datums.datum(name)
            found = (datum, None if key == "WGS84" else datum_shift(datum, WGS84))
            self._datums[key] = found
        return found

    def to_wgs84(self, datum_name: str, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """Geodetic degrees on ``datum_name`` (h = 0 there) → WGS84 degrees."""
        _datum, shift = self._datum(datum_name)
        if shift is None:
            return lat_deg, lon_deg
        lat, lon, _h = shift.transform(lat_deg, lon_deg, 0.0)
        return lat, lon

    def convergence_deg(self, r: CycleResult) -> float:
        """Grid convergence γ (deg) at the MPP on the cycle's grid: true = grid + γ."""
        key = (r.datum.strip().upper(), r.cm_deg)
        grid = self._grids.get(key)
        if grid is None:
            grid = TMGrid(self._datum(r.datum)[0].ellipsoid, r.cm_deg)
            self._grids[key] = grid
        return grid.forward_full(r.mpp.lat_deg, r.mpp.lon_deg)[2]

    def sentences(self, r: CycleResult) -> list[str]:
        """(ZDA), GGA, RMC, (GLL), (GST), (HDT) of the cycle's MPP, no line endings."""
        o = self.options
        quality = cycle_quality(r)
        valid = quality == QUALITY_FIX
        mode = "A" if valid else ("E" if quality == QUALITY_DR else "N")
        lat: float | None
        lon: float | None
        hdop = sog = cog = heading = None
        cov_true = None
        if quality == QUALITY_NONE:
            lat = lon = None
        else:
            lat, lon = self.to_wgs84(r.datum, r.mpp.lat_deg, r.mpp.lon_deg)
            gamma = self.convergence_deg(r)
            cov_true = _rotate_cov(np.asarray(r.mpp.cov, dtype=float)[:2, :2], gamma)
            drms = math.sqrt(max(float(np.trace(cov_true)), 0.0))
            hdop = min(max(drms / o.uere_m, HDOP_RANGE[0]), HDOP_RANGE[1])
            fs = r.filter_state
            if fs is not None:
                x = fs.x
                v_h = float(x[IV]) * math.cos(float(x[IEPS]))
                psi = float(x[IPSI])
                ve = v_h * math.sin(psi) + float(x[IVCX])
                vn = v_h * math.cos(psi) + float(x[IVCY])
                sog_ms = math.hypot(ve, vn)
                sog = sog_ms / KNOT_MS
                cog = None if sog_ms < 1e-3 else (math.degrees(math.atan2(ve, vn)) + gamma)
                heading = math.degrees(psi) + gamma
        out = [zda(r.time, talker=o.talker)] if o.zda else []
        out += [
            gga(r.time, lat, lon, quality=quality, sats=None, hdop=hdop, talker=o.talker),
            rmc(r.time, lat, lon, sog_kn=sog, cog_deg=cog, valid=valid, mode=mode,
                talker=o.talker),
        ]
        if o.gll:
            out.append(gll(r.time, lat, lon, valid=valid, mode=mode, talker=o.talker))
        if o.gst and cov_true is not None:
            out.append(_gst(r, cov_true, o.talker))
        if o.hdt and heading is not None:
            out.append(hdt(heading, talker=o.talker))
        return out


def _rotate_cov(cov_grid: np.ndarray, gamma_deg: float) -> np.ndarray:
    """A 2×2 (east, north) VCV on the grid → on true east/north: a grid azimuth α is the true
    azimuth α + γ, so (e_t, n_t) = R (e_g, n_g) with R = [[cos γ, sin γ], [−sin γ, cos γ]]."""
    g = math.radians(gamma_deg)
    c, s = math.cos(g), math.sin(g)
    rot = np.array([[c, s], [-s, c]])
    return rot @ cov_grid @ rot.T


def _gst(r: CycleResult, cov_true: np.ndarray, talker: str) -> str:
    """GST from the VCV on true axes: 1 σ ellipse and σ of latitude (north) and longitude
    (east), metres; orientation of the major axis from true north in [0, 180)."""
    sxx, sxy, syy = float(cov_true[0, 0]), float(cov_true[0, 1]), float(cov_true[1, 1])
    half = 0.5 * (sxx + syy)
    root = math.hypot(0.5 * (sxx - syy), sxy)
    lam1, lam2 = half + root, max(half - root, 0.0)
    # major axis direction (east, north) = eigenvector of λ1; azimuth from north
    az = 0.5 * math.degrees(math.atan2(2.0 * sxy, syy - sxx)) % 180.0
    return gst(r.time, rms_m=None, major_sigma_m=math.sqrt(lam1), minor_sigma_m=math.sqrt(lam2),
               major_az_deg=az, lat_sigma_m=math.sqrt(max(syy, 0.0)),
               lon_sigma_m=math.sqrt(max(sxx, 0.0)), talker=talker)
