"""Decca Navigator hyperbolic lane model, lane expansion factor and a priori VCV.

Frame: the TM grid of the working datum (k0 = 1, no false origin, ``engine.geodesy.tmgrid``);
distances are
spheroidal (grid chord divided by the line scale factor, A5.10/A5.13); azimuths are geodetic on the
working-datum ellipsoid.  References: thesis eq. 4.9/4.10 (lane count), 4.12 (LEF), A4.1–A4.4 (VCV),
A5.9–A5.12 (observation equation); digest ``lsq.md`` §5 and §6.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from engine.geodesy.ellipsoidal import (
    GeodesicSolver,
    andoyer_lambert_m,
    line_scale_factor,
    mean_radius_sq,
)
from engine.geodesy.tmgrid import TMGrid
from engine.io.deccafile import DeccaChain
from engine.io.operator_input import ZONE_LETTERS, decca_pattern, lanes_from_zone_lane

PATTERNS: tuple[str, str, str] = ("red", "green", "purple")
"""Pattern order used everywhere (slots 3–5 of the LS observation vector)."""

COMPARISON_MULTIPLIER_SLAVE: tuple[int, int, int] = (3, 2, 6)
"""f_c / f_slave for Red, Green, Purple: comparison frequencies 24, 18, 30 f0 (thesis L774)."""

MASTER_MULTIPLIER: tuple[int, int, int] = (4, 3, 5)
"""f_c / f_master for Red, Green, Purple (A4.1a–c)."""

SYNC_SIGMA_LANES: tuple[float, float, float] = (0.012, 0.009, 0.015)
"""Synchronisation error of each pattern in lanes (3σ_syncR, 2σ_syncG, 6σ_syncP; thesis L8338)."""


def sigma_path_a(d_100km: float) -> float:
    """Sky-wave phase σ (lanes, summer night) for a path of ``d_100km`` × 100 km (A4.3a)."""
    return (2.407 * d_100km * d_100km - 2.273 * d_100km + 4.240) * 1e-3


def sigma_path_b(d_100km: float) -> float:
    """Sky-wave phase σ (lanes, summer night) of the Purple slave signal (A4.3b, lsq.md Q15)."""
    return (2.843 * d_100km * d_100km - 2.597 * d_100km + 5.000) * 1e-3


@dataclass(frozen=True, slots=True)
class ChainOnGrid:
    """A Decca chain placed on the working grid: everything that does not depend on the ship.

    ``station_latlon_deg`` rows are master, red, green, purple (geodetic, working datum);
    ``station_xy_m`` the same on the TM grid; ``baseline_m`` the Andoyer–Lambert master–slave
    lengths (lsq.md §2.4); ``wavelength_m`` the comparison wavelengths λc = v / f_c (lsq.md §5.2);
    ``min_lanes`` the chain file's k per pattern (eq. 4.9). The same numbers are also kept as
    Python floats (``_scalars``) for the per-iteration scalar arithmetic of
    :func:`decca_geometry`.
    """

    chain_id: str
    grid: TMGrid
    station_latlon_deg: np.ndarray
    station_xy_m: np.ndarray
    baseline_m: np.ndarray
    wavelength_m: np.ndarray
    min_lanes: np.ndarray
    _scalars: _ChainScalars = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_scalars", _ChainScalars(
            tuple(tuple(r) for r in np.asarray(self.station_xy_m, dtype=float).tolist()),
            tuple(tuple(r) for r in np.asarray(self.station_latlon_deg, dtype=float).tolist()),
            tuple(np.asarray(self.wavelength_m, dtype=float).tolist()),
            tuple(np.asarray(self.baseline_m, dtype=float).tolist()),
            tuple(np.asarray(self.min_lanes, dtype=float).tolist()),
        ))


class _ChainScalars(NamedTuple):
    """ChainOnGrid's per-station numbers as floats: grid (x, y) m and (lat, lon) degrees of
    master, red, green, purple; λc (m), baselines (m) and k per pattern."""

    xy: tuple[tuple[float, float], ...]
    latlon: tuple[tuple[float, float], ...]
    wavelength: tuple[float, ...]
    baseline: tuple[float, ...]
    min_lanes: tuple[float, ...]


def place_chain(
    chain: DeccaChain,
    grid: TMGrid,
    station_latlon_deg: np.ndarray | None = None,
) -> ChainOnGrid:
    """Place ``chain`` on ``grid``.

    ``station_latlon_deg`` (4×2, degrees on the working datum) overrides the chain file's
    coordinates; the caller passes them when the chain datum differs from the working datum.
    """
    stations = (chain.master, chain.red, chain.green, chain.purple)
    if station_latlon_deg is None:
        station_latlon_deg = np.array([[s.lat_deg, s.lon_deg] for s in stations], dtype=float)
    xy = np.array([grid.forward(float(la), float(lo)) for la, lo in station_latlon_deg])
    ell = grid.ellipsoid
    m_lat, m_lon = station_latlon_deg[0]
    baselines = np.array(
        [
            andoyer_lambert_m(ell, float(m_lat), float(m_lon), float(la), float(lo))
            for la, lo in station_latlon_deg[1:]
        ]
    )
    slaves = (chain.red, chain.green, chain.purple)
    wavelength = np.array(
        [
            chain.speed_km_s / (mult * s.freq_khz)
            for mult, s in zip(COMPARISON_MULTIPLIER_SLAVE, slaves, strict=True)
        ]
    )
    return ChainOnGrid(
        chain_id=chain.chain_id,
        grid=grid,
        station_latlon_deg=np.asarray(station_latlon_deg, dtype=float),
        station_xy_m=xy,
        baseline_m=baselines,
        wavelength_m=wavelength,
        min_lanes=np.array(chain.min_lanes, dtype=float),
    )


@dataclass(frozen=True, slots=True)
class DeccaGeometry:
    """Ship-dependent Decca quantities at one grid point (the content of Pg 810).

    Distances in metres (spheroidal), azimuths in radians (geodetic, ship → station), ``row``
    the lane-count gradient ∂N/∂(x, y) in lanes per metre (A5.11–A5.12), ``metres_per_lane``
    k = λc·LEF/2 (A4.4), ``lop_azimuth_rad`` the azimuth of the LOP (gradient + 90°, lsq.md §5.7).
    """

    d_master_m: float
    az_master_rad: float
    d_slave_m: np.ndarray
    az_slave_rad: np.ndarray
    baseline_m: np.ndarray
    lef: np.ndarray
    metres_per_lane: np.ndarray
    lop_azimuth_rad: np.ndarray
    n_calc: np.ndarray
    row: np.ndarray


def decca_geometry(
    placed: ChainOnGrid,
    x_m: float,
    y_m: float,
    geodesic: GeodesicSolver,
    latlon_deg: tuple[float, float] | None = None,
) -> DeccaGeometry:
    """Compute lane counts, partials, LEF and LOP azimuths at grid point (x, y) (eq. 4.9, A5.9–12).

    N_calc = (D_m − D_s + B)/λc + k with D = grid chord / L (A5.10, L at the mean latitude of the
    two end points, lsq.md §2.3).  ``latlon_deg`` is the point's geodetic (lat, lon) in degrees
    when the caller already has it (else the grid is inverted here).  Scalar arithmetic
    throughout: this runs in every LS iteration.
    """
    lat0, lon0 = placed.grid.inverse(x_m, y_m) if latlon_deg is None else latlon_deg
    ell = placed.grid.ellipsoid
    sc = placed._scalars
    azimuth = geodesic.azimuth_distance
    dist = [0.0] * 4
    dxp = [0.0] * 4
    dyp = [0.0] * 4
    az = [0.0] * 4
    for i in range(4):
        xs, ys = sc.xy[i]
        slat, slon = sc.latlon[i]
        rm2 = mean_radius_sq(ell, lat0, slat)
        chord = math.hypot(x_m - xs, y_m - ys)
        lsf = line_scale_factor(x_m, xs, rm2)
        dist[i] = chord / lsf
        # ∂D/∂x including the line-scale term (A5.11), ∂D/∂y (A5.12).
        dxp[i] = (x_m - xs) / (lsf * chord) - chord * (2.0 * x_m + xs) / (lsf * lsf * 6.0 * rm2)
        dyp[i] = (y_m - ys) / (lsf * chord)
        az[i] = math.radians(azimuth(lat0, lon0, slat, slon)[0])
    lam = sc.wavelength
    base = sc.baseline
    kmin = sc.min_lanes
    two_pi = 2.0 * math.pi
    n_calc, row, lef, lop_az, k = [], [], [], [], []
    for j in range(3):
        s = j + 1
        n_calc.append((dist[0] - dist[s] + base[j]) / lam[j] + kmin[j])
        row.append(((dxp[0] - dxp[s]) / lam[j], (dyp[0] - dyp[s]) / lam[j]))
        gamma = abs(az[s] - az[0]) % two_pi
        if gamma > math.pi:
            gamma = two_pi - gamma
        lef_j = 1.0 / math.sin(gamma / 2.0)
        lef.append(lef_j)
        k.append(lam[j] * lef_j / 2.0)  # metres per lane, λc·LEF/2 (A4.4)
        # Direction in which N increases: −ê(Az_m) + ê(Az_s); the LOP runs 90° from it (§5.7).
        gx = -math.sin(az[0]) + math.sin(az[s])
        gy = -math.cos(az[0]) + math.cos(az[s])
        lop_az.append((math.atan2(gx, gy) + math.pi / 2.0) % two_pi)
    # One conversion for all per-pattern numbers (rows of `block` are views, in this order).
    block = np.array(dist[1:] + [a % two_pi for a in az[1:]] + lef + k + lop_az + n_calc
                     + [r for pair in row for r in pair])
    return DeccaGeometry(
        d_master_m=dist[0],
        az_master_rad=az[0] % two_pi,
        d_slave_m=block[0:3],
        az_slave_rad=block[3:6],
        baseline_m=placed.baseline_m,
        lef=block[6:9],
        metres_per_lane=block[9:12],
        lop_azimuth_rad=block[12:15],
        n_calc=block[15:18],
        row=block[18:24].reshape(3, 2),
    )


def _vcv_lanes(geom: DeccaGeometry, cf: float) -> list[list[float]]:
    """:func:`decca_vcv_lanes` as nested lists (lanes²)."""
    h = 1e-5  # metres → units of 100 km
    s_n2 = sigma_path_a(geom.d_master_m * h) ** 2
    d_s = geom.d_slave_m.tolist()
    base = geom.baseline_m.tolist()
    s_x = (sigma_path_a(d_s[0] * h), sigma_path_a(d_s[1] * h), sigma_path_b(d_s[2] * h))
    mm, ms = MASTER_MULTIPLIER, COMPARISON_MULTIPLIER_SLAVE
    c = [[mm[i] * mm[j] * s_n2 / cf for j in range(3)] for i in range(3)]
    for i in range(3):
        sky = mm[i] ** 2 * (s_n2 + sigma_path_a(base[i] * h) ** 2) + ms[i] ** 2 * s_x[i] ** 2
        c[i][i] = sky / cf + SYNC_SIGMA_LANES[i] ** 2
    return c


def decca_vcv_lanes(geom: DeccaGeometry, cf: float) -> np.ndarray:
    """A priori 3×3 VCV of the Red, Green, Purple lane counts (lanes², A4.1–A4.3).

    Sky-wave terms are divided by ``cf`` (``Decca.CF``: 64 summer day, 4 winter day, 1 summer
    night, 1/2.25 winter night); the synchronisation terms are not (lsq.md §6.3, verified).
    """
    return np.array(_vcv_lanes(geom, cf))


def decca_vcv_m2(geom: DeccaGeometry, cf: float) -> np.ndarray:
    """A priori 3×3 Decca VCV in m² across the LOPs: C_ij·k_i·k_j with k = λc·LEF/2 (A4.4)."""
    k = geom.metres_per_lane.tolist()
    c = _vcv_lanes(geom, cf)
    return np.array([[c[i][j] * (k[i] * k[j]) for j in range(3)] for i in range(3)])


@dataclass(frozen=True, slots=True)
class LaneResolution:
    """Outcome of :func:`resolve_total_lanes`.

    ``total`` the total lane count (lanes, uncorrected); ``cycle`` the chosen 10-zone cycle c;
    ``offset_lanes`` = total − N_calc; ``warning`` an operator text when |offset| exceeds half a
    zone (lpz/2 lanes, lsq.md Q7), else None.
    """

    total: float
    cycle: int
    offset_lanes: float
    warning: str | None


def resolve_total_lanes(
    zone: int, lane: int, fraction: float, pattern: str, n_calc: float
) -> LaneResolution:
    """Total lane count from zone, whole lane and fraction, choosing the 10-zone cycle c that puts
    it nearest to ``n_calc`` (the count computed at the provisional position; lsq.md §5.3, Q7).

    The nearest cycle is always within 5 zones of ``n_calc``; a count more than half a zone
    (lpz/2 = 12, 9 or 15 lanes for Red, Green, Purple) from it means the entered zone/lane and
    the provisional position disagree by more than about half a zone width (Red: 12 lanes
    ≈ 5 km on the baseline), so the result carries a warning (lsq.md Q7). ValueError for a zone,
    lane, fraction or pattern outside its range or a non-finite ``n_calc`` (programming errors:
    the operator's input is checked by ``parse_zone_lane``).
    """
    if not math.isfinite(n_calc):
        raise ValueError(f"computed lane count {n_calc!r} is not finite")
    base = lanes_from_zone_lane(zone, lane, fraction, pattern, 0)
    period = lanes_from_zone_lane(zone, lane, fraction, pattern, 1) - base
    cycle = math.floor((n_calc - base) / period + 0.5)
    total = base + cycle * period
    offset = total - n_calc
    spec = decca_pattern(pattern)
    half = spec.lanes_per_zone / 2.0
    warning = None
    if abs(offset) > half:
        warning = (
            f"Decca {spec.name}: zone/lane {ZONE_LETTERS[zone]}{lane} gives {total:.3f} lanes, "
            f"{offset:+.2f} from the {n_calc:.2f} computed at the provisional position (more "
            f"than half a zone, {half:g} lanes): check the zone/lane or the DR position"
        )
    return LaneResolution(total, cycle, offset, warning)


def _wrap_half(d: float) -> float:
    """Wrap a lane difference into [−0.5, 0.5)."""
    return d - math.floor(d + 0.5)


def track_lane(previous_total: float, fraction: float) -> float:
    """Decometer lane tracking: the total count nearest to ``previous_total`` whose fraction is
    ``fraction`` (valid while the ship moves less than half a lane between readings)."""
    return previous_total + _wrap_half(fraction - (previous_total - math.floor(previous_total)))


def identify_lane(n_calc: float, fraction: float) -> float:
    """Lane identification from a position: the total count with this ``fraction`` nearest to
    the count ``n_calc`` computed at the provisional position (after a gap in Decca reception)."""
    return track_lane(n_calc, fraction)
