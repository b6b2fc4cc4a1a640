"""Decca Navigator hyperbolic lane model, lane expansion factor and a priori VCV.

Frame: the TM grid of the working datum (k0 = 1, no false origin, ``engine.geodesy.tmgrid``);
distances are
spheroidal (grid chord divided by the line scale factor, A5.10/A5.13); azimuths are geodetic on the
working-datum ellipsoid.  References: thesis eq. 4.9/4.10 (lane count), 4.12 (LEF), A4.1–A4.4 (VCV),
A5.9–A5.12 (observation equation); docs/THEORY.md §3.2–3.5.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import datetime
from statistics import NormalDist
from typing import Any, NamedTuple

import numpy as np

from engine.geodesy.ellipsoidal import (
    DatumShift,
    GeodesicSolver,
    andoyer_lambert_m,
)
from engine.geodesy.tmgrid import TMGrid
from engine.io.deccafile import DeccaChain
from engine.io.operator_input import (
    ZONE_LETTERS,
    decca_pattern,
    lanes_from_zone_lane,
    zone_lane_of,
)
from engine.systems.base import (
    EVAL_ERRORS,
    CycleInputs,
    LopReading,
    ObservationError,
    Point,
    SystemReading,
)
from engine.systems.decca_season import DeccaCondition, decca_condition

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
    """Sky-wave phase σ (lanes, summer night) of the Purple slave signal (A4.3b, THEORY D11)."""
    return (2.843 * d_100km * d_100km - 2.597 * d_100km + 5.000) * 1e-3


@dataclass(frozen=True, slots=True)
class ChainOnGrid:
    """A Decca chain placed on the working grid: everything that does not depend on the ship.

    ``station_latlon_deg`` rows are master, red, green, purple (geodetic, working datum);
    ``station_xy_m`` the same on the TM grid; ``baseline_m`` the Andoyer–Lambert master–slave
    lengths (THEORY §2.5); ``wavelength_m`` the comparison wavelengths λc = v / f_c (THEORY §3.2);
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
        xy = tuple(tuple(r) for r in np.asarray(self.station_xy_m, dtype=float).tolist())
        latlon = tuple(tuple(r) for r in np.asarray(self.station_latlon_deg,
                                                    dtype=float).tolist())
        base = tuple(np.asarray(self.baseline_m, dtype=float).tolist())
        ell = self.grid.ellipsoid
        e2 = ell.e2
        a = ell.a_m
        object.__setattr__(self, "_scalars", _ChainScalars(
            xy,
            latlon,
            tuple(np.asarray(self.wavelength_m, dtype=float).tolist()),
            base,
            tuple(np.asarray(self.min_lanes, dtype=float).tolist()),
            tuple((xs, ys, xs * xs, lat) for (xs, ys), (lat, _lon) in zip(xy, latlon,
                                                                          strict=True)),
            e2,
            a * a * (1.0 - e2),
            _baseline_sky(base),
        ))


class _ChainScalars(NamedTuple):
    """ChainOnGrid's per-station numbers as floats: grid (x, y) m and (lat, lon) degrees of
    master, red, green, purple; λc (m), baselines (m) and k per pattern; and what the
    per-epoch arithmetic of :func:`_lane_model` and :func:`_vcv_core` would otherwise
    recompute from these every evaluation (the same operations, done once per placement):
    per station (x, y, x², lat), e² and a²(1 − e²) of the working ellipsoid (R_m² numerator,
    :func:`engine.geodesy.ellipsoidal.mean_radius_sq`), the baselines' sky-wave variances
    σ_path_a(B)² (A4.3a, lanes²)."""

    xy: tuple[tuple[float, float], ...]
    latlon: tuple[tuple[float, float], ...]
    wavelength: tuple[float, ...]
    baseline: tuple[float, ...]
    min_lanes: tuple[float, ...]
    stations: tuple[tuple[float, float, float, float], ...]
    e2: float
    rm2_numerator: float
    baseline_sky: tuple[float, ...]


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


def place_chain_on_datum(chain: DeccaChain, grid: TMGrid,
                         shift: DatumShift | None = None) -> ChainOnGrid:
    """Place ``chain`` on ``grid`` of the working datum; ``shift`` transforms the chain file's
    datum to the working datum (None: the same datum; h = 0 on the chain datum)."""
    latlon = np.array([[s.lat_deg, s.lon_deg] for s in
                       (chain.master, chain.red, chain.green, chain.purple)])
    if shift is not None:
        latlon = np.array([shift.transform(float(a), float(b), 0.0)[:2] for a, b in latlon])
    return place_chain(chain, grid, latlon)


@dataclass(frozen=True, slots=True)
class DeccaGeometry:
    """Ship-dependent Decca quantities at one grid point (the content of Pg 810).

    Distances in metres (spheroidal), azimuths in radians (geodetic, ship → station), ``row``
    the lane-count gradient ∂N/∂(x, y) in lanes per metre (A5.11–A5.12), ``metres_per_lane``
    k = λc·LEF/2 (A4.4), ``lop_azimuth_rad`` the azimuth of the LOP (gradient + 90°, THEORY §3.4).
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


def _lane_model(
    sc: _ChainScalars, x_m: float, y_m: float, lat0: float
) -> tuple[list[float], list[float], list[float], list[float]]:
    """(D per station (m), N_calc per pattern (lanes), ∂N/∂x and ∂N/∂y per pattern (lanes/m))
    at grid point (x, y) of geodetic latitude ``lat0`` (degrees); stations master, red, green,
    purple, patterns red, green, purple.

    D = grid chord / L (A5.10, L at the mean latitude of the two end points, THEORY §2.4),
    N_calc = (D_m − D_s + B)/λc + k (eq. 4.9), the partials A5.11–A5.12. The operations of
    :func:`engine.geodesy.ellipsoidal.mean_radius_sq` and ``line_scale_factor`` written out
    in the same order (the ``.OUT`` is reproducible to the last bit), with the per-station
    constants of the placement.
    """
    e2 = sc.e2
    num = sc.rm2_numerator
    sin = math.sin
    radians = math.radians
    hypot = math.hypot
    xx = x_m * x_m
    two_x = 2.0 * x_m
    dist = []
    dxp = []
    dyp = []
    for xs, ys, xs2, slat in sc.stations:
        s = sin(radians(0.5 * (lat0 + slat)))
        w2 = 1.0 - e2 * s * s
        rm2 = num / (w2 * w2)  # R_m² = ρν at the mean latitude
        dx = x_m - xs
        dy = y_m - ys
        chord = hypot(dx, dy)
        lsf = 1.0 + (xx + x_m * xs + xs2) / (6.0 * rm2)  # L (A5.10)
        lc = lsf * chord
        dist.append(chord / lsf)
        # ∂D/∂x including the line-scale term (A5.11), ∂D/∂y (A5.12).
        dxp.append(dx / lc - chord * (two_x + xs) / (lsf * lsf * 6.0 * rm2))
        dyp.append(dy / lc)
    l0, l1, l2 = sc.wavelength
    b0, b1, b2 = sc.baseline
    k0, k1, k2 = sc.min_lanes
    d0, d1, d2, d3 = dist
    x0, x1, x2, x3 = dxp
    y0, y1, y2, y3 = dyp
    return (dist,
            [(d0 - d1 + b0) / l0 + k0, (d0 - d2 + b1) / l1 + k1, (d0 - d3 + b2) / l2 + k2],
            [(x0 - x1) / l0, (x0 - x2) / l1, (x0 - x3) / l2],
            [(y0 - y1) / l0, (y0 - y2) / l1, (y0 - y3) / l2])


_TWO_PI = 2.0 * math.pi
_HALF_PI = math.pi / 2.0


def _azimuths_rad(
    sc: _ChainScalars, geodesic: GeodesicSolver, lat0: float, lon0: float
) -> list[float]:
    """Geodetic azimuths ship → master, red, green, purple (radians, from [0°, 360°))."""
    return geodesic.forward_azimuths_rad(lat0, lon0, sc.latlon)


def _lef(az: list[float]) -> list[float]:
    """Lane expansion factor 1/sin(γ/2) per pattern, γ the angle master–ship–slave
    (eq. 4.12)."""
    out = []
    az0 = az[0]
    for s in (1, 2, 3):
        gamma = abs(az[s] - az0) % _TWO_PI
        if gamma > math.pi:
            gamma = _TWO_PI - gamma
        out.append(1.0 / math.sin(gamma / 2.0))
    return out


def decca_geometry(
    placed: ChainOnGrid,
    x_m: float,
    y_m: float,
    geodesic: GeodesicSolver,
    latlon_deg: tuple[float, float] | None = None,
) -> DeccaGeometry:
    """Compute lane counts, partials, LEF and LOP azimuths at grid point (x, y) (eq. 4.9, A5.9–12).

    N_calc = (D_m − D_s + B)/λc + k with D = grid chord / L (A5.10, L at the mean latitude of the
    two end points, THEORY §2.4).  ``latlon_deg`` is the point's geodetic (lat, lon) in degrees
    when the caller already has it (else the grid is inverted here).  Scalar arithmetic
    throughout (:func:`_lane_model`).
    """
    lat0, lon0 = placed.grid.inverse(x_m, y_m) if latlon_deg is None else latlon_deg
    sc = placed._scalars
    dist, n_calc, row_x, row_y = _lane_model(sc, x_m, y_m, lat0)
    az = _azimuths_rad(sc, geodesic, lat0, lon0)
    lef = _lef(az)
    lam = sc.wavelength
    sin, cos, atan2 = math.sin, math.cos, math.atan2
    two_pi = _TWO_PI
    k = [lam[j] * lef[j] / 2.0 for j in range(3)]  # metres per lane, λc·LEF/2 (A4.4)
    # Direction in which N increases: −ê(Az_m) + ê(Az_s); the LOP runs 90° from it (§5.7).
    s0, c0 = sin(az[0]), cos(az[0])
    lop_az = [(atan2(-s0 + sin(a), -c0 + cos(a)) + _HALF_PI) % two_pi for a in az[1:]]
    # One conversion for all per-pattern numbers (rows of `block` are views, in this order).
    block = np.array(dist[1:] + [a % two_pi for a in az[1:]] + lef + k + lop_az + n_calc
                     + [row_x[0], row_y[0], row_x[1], row_y[1], row_x[2], row_y[2]])
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


_H_100KM = 1e-5
"""Metres → units of 100 km (the argument of the path σ polynomials A4.3)."""
_MM0_2, _MM1_2, _MM2_2 = (m ** 2 for m in MASTER_MULTIPLIER)
_MS0_2, _MS1_2, _MS2_2 = (m ** 2 for m in COMPARISON_MULTIPLIER_SLAVE)
_MM01, _MM02, _MM12 = (MASTER_MULTIPLIER[0] * MASTER_MULTIPLIER[1],
                       MASTER_MULTIPLIER[0] * MASTER_MULTIPLIER[2],
                       MASTER_MULTIPLIER[1] * MASTER_MULTIPLIER[2])
_SYNC0_2, _SYNC1_2, _SYNC2_2 = (s ** 2 for s in SYNC_SIGMA_LANES)


def _baseline_sky(baseline_m: Sequence[float]) -> tuple[float, ...]:
    """σ_path_a(B)² per pattern (lanes², A4.3a): the baseline term of A4.1's diagonal."""
    return tuple(sigma_path_a(b * _H_100KM) ** 2 for b in baseline_m)


def _vcv_core(d_master: float, d_slave: Sequence[float], baseline_sky: Sequence[float],
              cf: float) -> list[list[float]]:
    """:func:`decca_vcv_lanes` as nested lists (lanes²) from the distances (m) and
    :func:`_baseline_sky`: A4.1–A4.3 with :func:`sigma_path_a`/``_b`` written out (the same
    operations; integer multiplier products as Python ints, as ``m_i * m_j`` gives them)."""
    h = _H_100KM
    d = d_master * h
    s_n2 = ((2.407 * d * d - 2.273 * d + 4.240) * 1e-3) ** 2  # σ_path_a(D_m)²
    d = d_slave[0] * h
    s_r = (2.407 * d * d - 2.273 * d + 4.240) * 1e-3
    d = d_slave[1] * h
    s_g = (2.407 * d * d - 2.273 * d + 4.240) * 1e-3
    d = d_slave[2] * h
    s_p = (2.843 * d * d - 2.597 * d + 5.000) * 1e-3  # σ_path_b (A4.3b)
    sb0, sb1, sb2 = baseline_sky
    o01 = _MM01 * s_n2 / cf
    o02 = _MM02 * s_n2 / cf
    o12 = _MM12 * s_n2 / cf
    return [[(_MM0_2 * (s_n2 + sb0) + _MS0_2 * s_r ** 2) / cf + _SYNC0_2, o01, o02],
            [o01, (_MM1_2 * (s_n2 + sb1) + _MS1_2 * s_g ** 2) / cf + _SYNC1_2, o12],
            [o02, o12, (_MM2_2 * (s_n2 + sb2) + _MS2_2 * s_p ** 2) / cf + _SYNC2_2]]


def _vcv_lanes(geom: DeccaGeometry, cf: float) -> list[list[float]]:
    """:func:`decca_vcv_lanes` as nested lists (lanes²)."""
    return _vcv_core(geom.d_master_m, geom.d_slave_m.tolist(),
                     _baseline_sky(geom.baseline_m.tolist()), cf)


def decca_vcv_lanes(geom: DeccaGeometry, cf: float) -> np.ndarray:
    """A priori 3×3 VCV of the Red, Green, Purple lane counts (lanes², A4.1–A4.3).

    Sky-wave terms are divided by ``cf`` (``Decca.CF``: 64 summer day, 4 winter day, 1 summer
    night, 1/2.25 winter night); the synchronisation terms are not (THEORY §3.5, verified).
    """
    return np.array(_vcv_lanes(geom, cf))


def _vcv_m2(c: list[list[float]], k: Sequence[float]) -> list[list[float]]:
    """C_ij·(k_i·k_j) (m², A4.4) of a symmetric lane VCV ``c`` (lanes²) and metres per lane
    ``k`` (k_i·k_j = k_j·k_i exactly, so the result is symmetric to the bit)."""
    (c00, c01, c02), (_c10, c11, c12), (_c20, _c21, c22) = c
    k0, k1, k2 = k
    m01 = c01 * (k0 * k1)
    m02 = c02 * (k0 * k2)
    m12 = c12 * (k1 * k2)
    return [[c00 * (k0 * k0), m01, m02], [m01, c11 * (k1 * k1), m12],
            [m02, m12, c22 * (k2 * k2)]]


def decca_vcv_m2(geom: DeccaGeometry, cf: float) -> np.ndarray:
    """A priori 3×3 Decca VCV in m² across the LOPs: C_ij·k_i·k_j with k = λc·LEF/2 (A4.4).

    The fix's Decca block (:meth:`DeccaObservations.linearise`) is this VCV, computed there
    from the same numbers without the geometry's arrays; a function put in this name's place
    (the thesis' printed VCV of Pg 615/821, in the tests) is called with the geometry instead.
    """
    return np.array(_vcv_m2(_vcv_lanes(geom, cf), geom.metres_per_lane.tolist()))


_DECCA_VCV_M2 = decca_vcv_m2
"""The model's own :func:`decca_vcv_m2` (linearise takes its shortcut only while it is the one
under that name)."""


@dataclass(frozen=True, slots=True)
class LaneResolution:
    """Outcome of :func:`resolve_total_lanes`.

    ``total`` the total lane count (lanes, uncorrected); ``cycle`` the chosen 10-zone cycle c;
    ``offset_lanes`` = total − N_calc; ``warning`` an operator text when |offset| exceeds half a
    zone (lpz/2 lanes, THEORY D7), else None.
    """

    total: float
    cycle: int
    offset_lanes: float
    warning: str | None


def resolve_total_lanes(
    zone: int, lane: int, fraction: float, pattern: str, n_calc: float
) -> LaneResolution:
    """Total lane count from zone, whole lane and fraction, choosing the 10-zone cycle c that puts
    it nearest to ``n_calc`` (the count computed at the provisional position; THEORY §3.3, D7).

    The nearest cycle is always within 5 zones of ``n_calc``; a count more than half a zone
    (lpz/2 = 12, 9 or 15 lanes for Red, Green, Purple) from it means the entered zone/lane and
    the provisional position disagree by more than about half a zone width (Red: 12 lanes
    ≈ 5 km on the baseline), so the result carries a warning (THEORY D7). ValueError for a zone,
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
    d = fraction - (previous_total - math.floor(previous_total))
    return previous_total + (d - math.floor(d + 0.5))  # _wrap_half(d), written out


def identify_lane(n_calc: float, fraction: float) -> float:
    """Lane identification from a position: the total count with this ``fraction`` nearest to
    the count ``n_calc`` computed at the provisional position (after a gap in Decca reception)."""
    return track_lane(n_calc, fraction)


# --------------------------------------------------------------------------------------------
# Zone/lane resolution and decometer lane tracking (thesis §4.2.3; issue 11)

DECCA_TRACK_GAP_S = 30.0
"""Longest gap in a pattern's readings over which its lane count is still tracked (s); after a
longer gap (a dive) the lane is identified again from the provisional position."""

LANE_STEP_MAX = 0.25
"""Largest change of a pattern's reading between consecutive records (lanes) a tracked count
follows under ``[decca] lane_check = "dia"``: half the half lane :func:`track_lane` relies on,
the other half left to the ship's motion and the reading's noise over the interval. A larger
step may have put the count on the wrong lane: the lane is identified again, as after a gap."""

LANE_SIGMA_MAX = 0.5 / 3.0
"""Largest 1σ (lanes) along a pattern's lane gradient of a position an integer lane may be taken
from: 3σ < 0.5 lane, so the nearest whole lane is the right one with probability ≥ 99.7 %
(Gaussian). Applies to lane identification after a gap (a dive) and to the GPS lane check."""


class ZoneLaneResolver:
    """Resolves the operator's zone/lane entries against the lane counts N_calc at one
    provisional grid point (m), computed once on first use: the one place the cycle and the fix
    turn a zone/lane and a fraction into a total lane count (THEORY §3.3, D7)."""

    def __init__(self, placed: ChainOnGrid, x_m: float, y_m: float,
                 geodesic: GeodesicSolver) -> None:
        self.placed = placed
        self.x_m = x_m
        self.y_m = y_m
        self.geodesic = geodesic
        self._geom: DeccaGeometry | None = None
        self.problem: str | None = None
        """Why the lane counts cannot be evaluated (set by :meth:`resolve_checked`)."""

    def geometry(self) -> DeccaGeometry:
        """The lane geometry at the provisional point (ValueError/ArithmeticError where the lane
        model cannot be evaluated)."""
        if self._geom is None:
            self._geom = decca_geometry(self.placed, self.x_m, self.y_m, self.geodesic)
        return self._geom

    def resolve(self, i: int, zone_lane: tuple[int, int], fraction: float) -> LaneResolution:
        """Total lane count of pattern ``i`` (:func:`resolve_total_lanes`); raises as
        :meth:`geometry` and for a non-finite N_calc."""
        n_calc = float(self.geometry().n_calc[i])
        return resolve_total_lanes(zone_lane[0], zone_lane[1], fraction, PATTERNS[i], n_calc)

    def resolve_checked(self, i: int, zone_lane: tuple[int, int], fraction: float,
                        notes: list[str]) -> LaneResolution | None:
        """:meth:`resolve`, or None while the lane counts at the provisional point cannot be
        evaluated or are not finite (one note says so, the first time)."""
        if self.problem is not None:
            return None
        if self._geom is None:
            try:
                geom = self.geometry()
                problem = None if np.isfinite(geom.n_calc).all() else "not finite"
            except (ValueError, ArithmeticError) as exc:
                problem = str(exc)
            if problem is not None:
                self.problem = problem
                notes.append(f"Decca: lane count not resolved at the provisional position "
                             f"({problem})")
                return None
        return self.resolve(i, zone_lane, fraction)


def lane_sigma(row: np.ndarray, cov: np.ndarray) -> float:
    """1σ (lanes) along a lane gradient ``row`` (lanes/m, ∂N/∂(x, y)) of a position whose 2×2
    VCV is ``cov`` (m², grid x/y): √(row·C·rowᵀ)."""
    r = np.asarray(row, dtype=float)
    return math.sqrt(max(float(r @ np.asarray(cov, dtype=float) @ r), 0.0))


@dataclass(frozen=True, slots=True)
class LaneSource:
    """A position that may settle Decca integer lanes: grid (x, y) m, its 2×2 VCV (m²) and the
    name the messages use ("GPS", "the DR position")."""

    name: str
    x_m: float
    y_m: float
    cov: np.ndarray


class _LaneAt:
    """(N_calc, σ along the gradient) of a pattern at a :class:`LaneSource` (lanes), or None
    where the lane model cannot be evaluated; the lane counts and gradients are cached per
    source name."""

    def __init__(self, placed: ChainOnGrid, geodesic: GeodesicSolver) -> None:
        self.placed = placed
        self.geodesic = geodesic
        self.cache: dict[str, tuple[list[float], np.ndarray, list[float]] | None] = {}

    def _lanes(self, src: LaneSource) -> tuple[list[float], np.ndarray, list[float]] | None:
        """(N_calc per pattern, 3×2 gradients, distances master/Red/Green/Purple in m) at
        ``src``: :func:`decca_geometry`'s numbers without its page data (None where it raises or
        N_calc is not finite)."""
        placed = self.placed
        sc = placed._scalars
        try:
            lat0, lon0 = placed.grid.inverse(src.x_m, src.y_m)
            dist, n_calc, row_x, row_y = _lane_model(sc, src.x_m, src.y_m, lat0)
            # Not used here, but where decca_geometry cannot form the LEF (γ = 0) it raises.
            _lef(_azimuths_rad(sc, self.geodesic, lat0, lon0))
        except (ValueError, ArithmeticError):
            return None
        isfinite = math.isfinite
        if not (isfinite(n_calc[0]) and isfinite(n_calc[1]) and isfinite(n_calc[2])):
            return None
        return n_calc, np.array([[row_x[0], row_y[0]], [row_x[1], row_y[1]],
                                 [row_x[2], row_y[2]]]), list(dist)

    def lanes_at(self, src: LaneSource) -> tuple[list[float], np.ndarray, list[float]] | None:
        """:meth:`_lanes` at ``src``, cached per source name."""
        cache = self.cache
        name = src.name
        if name in cache:
            return cache[name]
        g = cache[name] = self._lanes(src)
        return g

    def __call__(self, src: LaneSource, i: int) -> tuple[float, float] | None:
        cache = self.cache
        name = src.name
        if name in cache:
            g = cache[name]
        else:
            g = cache[name] = self._lanes(src)
        if g is None:
            return None
        return g[0][i], lane_sigma(g[1][i], src.cov)


@dataclass(frozen=True, slots=True)
class LaneTotals:
    """Outcome of :func:`decca_totals`: total lane counts per pattern (None: not available),
    the new lane track, the operator notes and the number of lane slips corrected from GPS."""

    totals: tuple[float | None, float | None, float | None]
    track: tuple[tuple[float, datetime] | None, ...]
    notes: tuple[str, ...]
    slips: int


@dataclass(frozen=True, slots=True)
class LaneRule:
    """When a position may settle Decca whole lanes (THEORY §3.3, "Lane identification with
    its uncertainty"; config ``[decca] lane_success``, ``lane_ratio``, ``lane_cf``).

    The float lane ambiguities a_i = N_calc_i(reference) − fraction_i have the VCV
    Q = G·P·Gᵀ + C_lanes (G the lane gradients, P the reference position's 2×2 VCV, C_lanes the
    Decca a priori VCV of A4.1–A4.3 at Decca.CF = min(configured, ``cf``)). Lanes are taken
    only as far as the integer-bootstrapping success rate (Teunissen 1998) stays at or above
    ``success`` (partial fixing, most precise pattern first), and only when the integer
    least-squares solution of those patterns passes the ratio test q₂/q₁ ≥ ``ratio``
    (Euler & Schaffrin 1991; Verhagen & Teunissen 2013).

    ``check`` (config ``[decca] lane_check = "dia"``): the lanes a record starts from are
    tested too (:func:`check_lanes`) — the start-up zone/lane entries against the reference
    position, a tracked lane before GPS may change it — and a pattern the test puts in doubt
    stays out of the fix until a position confirms its lane (:func:`decca_totals`)."""

    success: float = 0.999
    ratio: float = 3.0
    cf: float = 1.0
    check: bool = True


LANE_RULE = LaneRule()
"""The default :class:`LaneRule` (its sources in docs/CONFIG.md)."""


@dataclass(frozen=True, slots=True)
class LaneFixing:
    """Outcome of :func:`fix_lanes`: the whole lanes z_i taken per pattern index, the
    bootstrapped success rate of those (1.0 when none), the ratio q₂/q₁ of their integer
    least-squares solution (inf: no second candidate), and why the others were not taken
    (None when every pattern asked for was)."""

    lanes: dict[int, int]
    success: float
    ratio: float
    why: str | None


_SQRT1_2 = math.sqrt(0.5)


def _success_factor(sigma: float) -> float:
    """P(|e| < ½) of a Gaussian e with σ = ``sigma`` lanes: 2Φ(1/(2σ)) − 1 (Teunissen 1998)."""
    if sigma <= 0.0:
        return 1.0
    return math.erf(0.5 / sigma * _SQRT1_2)


def why_unsure(sigma: float, rule: LaneRule) -> str:
    """Why :func:`fix_lanes` took no pattern: the most precise one's conditional 1σ
    ``sigma`` (lanes) as 3σ and its success rate."""
    return (f"±{3 * sigma:.2f} lane (3σ) at best, success rate "
            f"{_success_factor(sigma):.3f} < {rule.success:g}")


def why_ratio(ratio: float, rule: LaneRule) -> str:
    """Why :func:`fix_lanes` took no pattern: the ratio test q₂/q₁ = ``ratio`` failed."""
    return f"ratio test q2/q1 = {ratio:.2f} < {rule.ratio:g}"


def fix_lanes(a: np.ndarray, q: np.ndarray, want: Sequence[int], known: dict[int, int],
              rule: LaneRule) -> LaneFixing:
    """Whole lanes of the patterns ``want`` from float ambiguities ``a`` (lanes, per pattern
    index 0–2) with VCV ``q`` (lanes², 3×3), given the whole lanes ``known`` of other patterns.

    The floats of ``want`` are first conditioned on ``known`` (a_S|T = a_S − Q_ST·Q_TT⁻¹·(a_T −
    z_T)); then patterns are taken in the bootstrapping order (least conditional variance
    first) while the product of 2Φ(1/(2σ_i|I)) − 1 stays ≥ ``rule.success`` (Teunissen 1998's
    success rate, a lower bound of integer least squares', Teunissen 1999); the taken set is
    solved by integer least squares (a box search, q(z) = (a − z)ᵀQ⁻¹(a − z)) and accepted only
    when the second-best candidate's q is at least ``rule.ratio`` times the best's."""
    want = list(want)
    t_idx = [i for i in known if i not in want]
    a_s = np.array([a[i] for i in want], dtype=float)
    q_ss = np.array([[q[i][j] for j in want] for i in want], dtype=float)
    if t_idx:
        q_tt = np.array([[q[i][j] for j in t_idx] for i in t_idx], dtype=float)
        q_st = np.array([[q[i][j] for j in t_idx] for i in want], dtype=float)
        r_t = np.array([a[i] - known[i] for i in t_idx], dtype=float)
        try:
            k = np.linalg.solve(q_tt, q_st.T).T  # Q_ST·Q_TT⁻¹
        except np.linalg.LinAlgError:
            k = None
        if k is not None:
            a_s = a_s - k @ r_t
            q_ss = q_ss - k @ q_st.T
    if not (np.isfinite(a_s).all() and np.isfinite(q_ss).all()):
        return LaneFixing({}, 1.0, math.inf, "no finite lane variance")
    # Bootstrapping order and conditional σ (sequential conditioning on those chosen).
    order: list[int] = []
    sigmas: list[float] = []
    rest = list(range(len(want)))
    while rest:
        best = None
        for j in rest:
            v = float(q_ss[j, j])
            if order:
                c = q_ss[np.ix_([j], order)]
                try:
                    v -= float((c @ np.linalg.solve(q_ss[np.ix_(order, order)], c.T))[0, 0])
                except np.linalg.LinAlgError:
                    pass
            if best is None or v < best[1]:
                best = (j, v)
        assert best is not None
        order.append(best[0])
        sigmas.append(math.sqrt(max(best[1], 0.0)))
        rest.remove(best[0])
    p = 1.0
    taken: list[int] = []
    for j, sg in zip(order, sigmas, strict=True):
        f = p * _success_factor(sg)
        if f < rule.success:
            break
        p = f
        taken.append(j)
    if not taken:
        return LaneFixing({}, p * _success_factor(sigmas[0]), math.nan,
                          why_unsure(sigmas[0], rule))
    # Integer least squares of the taken patterns: a box of ±(⌈3σ⌉ + 1) lanes around the float.
    a_u = a_s[taken]
    q_u = q_ss[np.ix_(taken, taken)]
    try:
        w = np.linalg.inv(q_u)
    except np.linalg.LinAlgError:
        return LaneFixing({}, p, math.nan, "singular lane variance")
    spans = []
    for m in range(len(taken)):
        half = min(int(math.ceil(3.0 * math.sqrt(max(float(q_u[m, m]), 0.0)))) + 1, 4)
        c0 = int(math.floor(a_u[m] + 0.5))
        spans.append(range(c0 - half, c0 + half + 1))
    grids = np.array(np.meshgrid(*spans, indexing="ij"), dtype=float).reshape(len(taken), -1).T
    d = a_u[None, :] - grids
    qv = np.einsum("ni,ij,nj->n", d, w, d)
    two = np.argsort(qv)[:2]
    q1 = float(qv[two[0]])
    q2 = float(qv[two[1]]) if two.size > 1 else math.inf
    ratio = math.inf if q1 <= 0.0 else q2 / q1
    if not ratio >= rule.ratio:
        return LaneFixing({}, p, ratio, why_ratio(ratio, rule))
    z = grids[two[0]]
    lanes = {want[j]: int(z[m]) for m, j in enumerate(taken)}
    why = None
    if len(taken) < len(want):
        why = (f"success rate with the next pattern "
               f"{p * _success_factor(sigmas[len(taken)]):.3f} < {rule.success:g}")
    return LaneFixing(lanes, p, ratio, why)


def lr_critical(success: float) -> float:
    """χ²₁(1 − α), α = 1 − ``success``: the critical value of the likelihood-ratio test of the
    lanes under test against one alternative (10.83 at 0.999; the w-test's 3.29²)."""
    z = NormalDist().inv_cdf(0.5 + 0.5 * success)
    return z * z


@dataclass(frozen=True, slots=True)
class LaneCheck:
    """Outcome of :func:`check_lanes`. ``verdict``: "kept" (no alternative is better than the
    lanes under test at α), "changed" (the one alternative the test and the ratio allow:
    pattern index ``pattern`` moved by ``shift`` whole lanes) or "doubt" (rejected, and the
    patterns ``doubt`` carry the alternatives the ratio test cannot separate); ``lr`` the
    statistic q(z₀) − q(best alternative)."""

    verdict: str
    pattern: int = -1
    shift: int = 0
    doubt: tuple[int, ...] = ()
    lr: float = 0.0


_KEPT = LaneCheck("kept")
_SHIFTS = (-2, -1, 1, 2)
"""Whole-lane alternatives of one pattern :func:`check_lanes` weighs (a lane or two off: an
entry or a count one or two lanes wrong; a larger error the zone/lane warning of D7 names)."""


def check_lanes(a: np.ndarray, q: np.ndarray, z0: dict[int, int], under_test: Sequence[int],
                rule: LaneRule) -> LaneCheck:
    """Detection, identification and adaptation (Teunissen's DIA; Baarda's data snooping with
    whole-lane alternatives) of the whole lanes ``z0`` (per pattern index) against the float
    ambiguities ``a`` with VCV ``q`` (lanes², :func:`_floats_at`; the patterns of ``z0``).

    The alternatives are one pattern of ``under_test`` off by ±1 or ±2 lanes. The lanes are
    rejected when the best alternative's q(z) = (a − z)ᵀQ⁻¹(a − z) is below q(z₀) by at least
    χ²₁(1 − α), α = 1 − ``rule.success`` (:func:`lr_critical`: the likelihood-ratio test of
    one alternative at the lane rule's own α); the alternative is taken when every other
    candidate, ``z0`` included, has q at least ``rule.ratio`` times its q (the ratio test),
    else the patterns of the candidates within that ratio are in doubt."""
    idx = sorted(z0)
    if not under_test or not idx:
        return _KEPT
    a_u = np.array([a[i] for i in idx], dtype=float)
    q_u = np.array([[q[i][j] for j in idx] for i in idx], dtype=float)
    if not (np.isfinite(a_u).all() and np.isfinite(q_u).all()):
        return _KEPT
    try:
        w = np.linalg.inv(q_u)
    except np.linalg.LinAlgError:
        return _KEPT
    zv = np.array([z0[i] for i in idx], dtype=float)
    d0 = a_u - zv
    q0 = float(d0 @ w @ d0)
    cands: list[tuple[float, int, int]] = []
    for i in under_test:
        m = idx.index(i)
        wm = w[m]
        for k in _SHIFTS:
            # q(z0 + k·e_m) = q0 − 2k·(W d0)_m + k²·W_mm
            cands.append((q0 - 2.0 * k * float(wm @ d0) + k * k * float(wm[m]), i, k))
    cands.sort()
    qb, ib, kb = cands[0]
    lr = q0 - qb
    if not lr >= lr_critical(rule.success):
        return _KEPT
    lim = rule.ratio * max(qb, 0.0)
    rivals = [c for c in cands[1:] if c[0] < lim]
    if not rivals and q0 >= lim:
        return LaneCheck("changed", ib, kb, (), lr)
    return LaneCheck("doubt", -1, 0, tuple(sorted({ib, *(c[1] for c in rivals)})), lr)


def _floats_at(at: _LaneAt, src: LaneSource, fractions: Sequence[float | None],
               cf: float) -> tuple[np.ndarray, np.ndarray, list[float]] | None:
    """(float ambiguities a_i = N_calc_i − fraction_i, their VCV G·P·Gᵀ + C_lanes (lanes²),
    N_calc per pattern) at ``src``; a pattern without a fraction has a = nan. None where the
    lane model cannot be evaluated."""
    g = at.lanes_at(src)
    if g is None:
        return None
    n_calc, rows, dist = g
    sc = at.placed._scalars
    c = np.array(_vcv_core(dist[0], dist[1:], sc.baseline_sky, cf), dtype=float)
    q = rows @ np.asarray(src.cov, dtype=float) @ rows.T + c
    a = np.array([math.nan if f is None else n_calc[i] - f for i, f in enumerate(fractions)])
    return a, q, list(n_calc)


def _total_for(n_calc: float, frac: float, z: int) -> float:
    """The total count with fraction ``frac`` and whole lane ambiguity ``z`` (= z + frac),
    written as :func:`identify_lane` from ``n_calc`` when z is the nearest lane (the same
    operations, so the same bits as before the lane rule)."""
    base = identify_lane(n_calc, frac)
    return base + (z - round(base - frac))


def _identify_after_gap(at: _LaneAt, i: int, frac: float, sources: Sequence[LaneSource | None],
                        gps: LaneSource | None, notes: list[str]) -> tuple[float | None, bool]:
    """The total of pattern ``i`` identified again after a gap from the first source precise
    enough along the lane gradient (None and a note while none is); True if that was GPS.
    The rule of ``[decca] lane_rule = "sigma"``: 1σ ≤ :data:`LANE_SIGMA_MAX`, the source's
    position error only."""
    pattern = PATTERNS[i]
    worst = math.inf
    for src in sources:
        if src is None:
            continue
        lane = at(src, i)
        if lane is None:
            continue
        if lane[1] <= LANE_SIGMA_MAX:
            notes.append(f"Decca {pattern}: lane identified again from {src.name} "
                         f"(±{3 * lane[1]:.2f} lane, 3σ)")
            return identify_lane(lane[0], frac), src is gps
        worst = min(worst, lane[1])
    why = ("no position" if not math.isfinite(worst) else
           f"position ±{3 * worst:.1f} lanes (3σ) along the lane gradient")
    notes.append(f"Decca {pattern}: lane not identified after the gap ({why}): "
                 "kept out of the fix until GPS, a better position or a zone/lane "
                 "entered in Setup > Decca settles it")
    return None, False


def _slip_note(i: int, slip: int, total: float, expected: float) -> str:
    """The operator note of a lane slip of pattern ``i`` corrected from GPS."""
    return (f"Decca {PATTERNS[i]}: lane slip of {slip:+d} lane"
            f"{'s' if abs(slip) > 1 else ''} corrected from GPS "
            f"({total:.2f} → {expected:.2f})")


def _gps_lane_check(at: _LaneAt, i: int, frac: float, total: float, gps: LaneSource,
                       notes: list[str]) -> tuple[float, int]:
    """``total`` checked against GPS's lane when GPS settles it: (total, 1) corrected to GPS's
    lane with a note for a slip of a whole lane or more, else (total, 0)."""
    lane = at(gps, i)
    if lane is None or not lane[1] <= LANE_SIGMA_MAX:
        return total, 0
    expected = identify_lane(lane[0], frac)
    slip = round(total - expected)
    if slip == 0:
        return total, 0
    notes.append(_slip_note(i, slip, total, expected))
    return expected, 1


LANE_DOUBT_NOTE = "lane in doubt"
"""Words every note of a pattern kept out of the fix by the lane rule carries (counted by the
campaign's ``lane_doubt`` column)."""


DOUBT = "in doubt"
"""Third item of a pattern's lane track while the pattern is in doubt (``lane_check``): the
count is tracked on but kept out of the fix until a position confirms its lane
(:func:`decca_totals`). A track of two items is a lane in use."""


def _lane_of(total: float, frac: float) -> int:
    """The whole lane z of a total count (total = z + fraction)."""
    return round(total - frac)


def _gps_slip_confirmed(at: _LaneAt, fractions: Sequence[float | None],
                        totals: list[float | None], suspects: list[int], gps: LaneSource,
                        rule: LaneRule, notes: list[str]) -> int:
    """The lane slips the old rule suspects (``suspects``: the count and GPS's nearest lane
    differ) judged by :class:`LaneRule`: the patterns with counts are identified from GPS
    together (:func:`fix_lanes`); a suspect GPS settles is corrected to GPS's lane (or kept
    when GPS's lane is its own), one GPS cannot settle is kept out of this record's fix with a
    note (the track goes on). ``totals`` is changed in place; returns the slips corrected."""
    fl = _floats_at(at, gps, fractions, rule.cf)
    want = [i for i in range(3) if totals[i] is not None and fractions[i] is not None]
    fixing = None if fl is None else fix_lanes(fl[0], fl[1], want, {}, rule)
    slips = 0
    for i in suspects:
        total = totals[i]
        frac = fractions[i]
        assert total is not None and frac is not None
        if fixing is None or i not in fixing.lanes:
            why = "no GPS lane" if fixing is None else (fixing.why or "")
            notes.append(f"Decca {PATTERNS[i]}: {LANE_DOUBT_NOTE}: the count {total:.2f} and "
                         f"GPS differ by half a lane or more and GPS cannot settle the lane "
                         f"({why}): kept out of this fix")
            totals[i] = None
            continue
        expected = _total_for(fl[2][i], frac, fixing.lanes[i])  # type: ignore[index]
        slip = round(total - expected)
        if slip != 0:
            notes.append(_slip_note(i, slip, total, expected))
            totals[i] = expected
            slips += 1
    return slips


def _zone_lane_text(i: int, total: float) -> str:
    """The zone letter and whole lane of ``total`` in pattern ``i`` ("E33")."""
    letter, lane = zone_lane_of(total, PATTERNS[i])
    return f"{letter}{math.floor(lane)}"


def _check_entry(at: _LaneAt, entered: list[int], fractions: Sequence[float | None],
                 totals: list[float | None], new_track: list[tuple[Any, ...] | None],
                 time: datetime, sources: Sequence[LaneSource | None], rule: LaneRule,
                 notes: list[str]) -> None:
    """The start-up zone/lane entries of ``entered`` (their first reading, ``totals`` from the
    entry) tested with :func:`check_lanes` against the first of ``sources`` (GPS, the filter's
    position with its P) that gives lane counts, together with the other patterns' counts of
    this record: an entry the test rejects is corrected when one alternative is clear,
    else the patterns the test cannot tell apart are put in doubt (tracked on from the entry,
    kept out of the fix until a position confirms their lanes). ``totals`` and ``new_track``
    are changed in place; a note names the pattern, the entered and the resolved lane."""
    under = [i for i in entered if totals[i] is not None]
    if not under:
        return
    for src in sources:
        if src is None:
            continue
        fl = _floats_at(at, src, fractions, rule.cf)
        if fl is None:
            continue
        z0 = {i: _lane_of(t, fractions[i])  # type: ignore[arg-type]
              for i, t in enumerate(totals) if t is not None and fractions[i] is not None}
        check = check_lanes(fl[0], fl[1], z0, under, rule)
        if check.verdict == "changed":
            i, k = check.pattern, check.shift
            old = totals[i]
            assert old is not None
            total = old + k
            notes.append(f"Decca {PATTERNS[i]}: the zone/lane entered, "
                         f"{_zone_lane_text(i, old)} ({old:.2f}), is {abs(k)} lane"
                         f"{'s' if abs(k) > 1 else ''} {'low' if k > 0 else 'high'} against "
                         f"{src.name} (likelihood ratio {check.lr:.1f}): "
                         f"{_zone_lane_text(i, total)} ({total:.2f}) used")
            totals[i] = total
            new_track[i] = (total, time)
        elif check.verdict == "doubt":
            for i in check.doubt:
                old = totals[i]
                assert old is not None
                notes.append(f"Decca {PATTERNS[i]}: {LANE_DOUBT_NOTE}: the zone/lane entered, "
                             f"{_zone_lane_text(i, old)} ({old:.2f}), fails its test against "
                             f"{src.name} (likelihood ratio {check.lr:.1f}) and no one lane "
                             "explains it: kept out of the fix until a position confirms it")
                totals[i] = None
                new_track[i] = (old, time, DOUBT)
        return


def _confirm_doubt(at: _LaneAt, doubted: dict[int, float], fractions: Sequence[float | None],
                   totals: list[float | None], new_track: list[tuple[Any, ...] | None],
                   time: datetime, gps: LaneSource | None, rule: LaneRule,
                   notes: list[str]) -> None:
    """The patterns in doubt (``doubted``: index → this record's tracked total) back in the fix
    once GPS, precise enough to have put them in doubt (1σ ≤ :data:`LANE_SIGMA_MAX` along the
    gradient), puts its float a = N_calc(GPS) − fraction within the ratio test's reach of the
    tracked lane z: (1 − |a − z|)² / (a − z)² ≥ ``rule.ratio`` (|a − z| ≤ 0.366 lane at 3),
    the next lane's q at least ``rule.ratio`` times the tracked one's. The track is the
    candidate, so the success rate of an identification from scratch is not asked; GPS never
    moves a count in doubt to another lane (the track is continuous: its steps are small, else
    it is identified again as after a gap). The rest stay in doubt (tracked on, out of the fix)
    with a note."""
    for i in sorted(doubted):
        total = doubted[i]
        frac = fractions[i]
        assert frac is not None
        lane = None if gps is None else at(gps, i)
        if lane is not None and lane[1] <= LANE_SIGMA_MAX:
            d = abs(lane[0] - frac - _lane_of(total, frac))
            if (1.0 - d) ** 2 >= rule.ratio * d * d:
                notes.append(f"Decca {PATTERNS[i]}: lane in doubt confirmed from GPS "
                             f"({total:.2f}, {d:.2f} lane from GPS)")
                totals[i] = total
                new_track[i] = (total, time)
                continue
        notes.append(f"Decca {PATTERNS[i]}: {LANE_DOUBT_NOTE}: {total:.2f} not yet confirmed "
                     "by GPS: kept out of the fix")


def decca_totals(
    placed: ChainOnGrid,
    geodesic: GeodesicSolver,
    zone_lane: Sequence[tuple[int, int] | None],
    track: Sequence[tuple[float, datetime] | None],
    fractions: Sequence[float | None],
    time: datetime,
    x_start: tuple[float, float],
    position: LaneSource | None = None,
    gps: LaneSource | None = None,
    rule: LaneRule | None = LANE_RULE,
) -> LaneTotals:
    """Total lane counts of one record's ``fractions``, tracked like a decometer, with lane
    integrity (thesis §4.2.3 on lane identification; THEORY §3.3).

    The first reading of a pattern takes the operator's ``zone_lane`` (resolving the 10-zone
    cycle from the provisional position ``x_start``, :class:`ZoneLaneResolver`); later readings
    follow lane crossings (:func:`track_lane`). After a gap longer than
    :data:`DECCA_TRACK_GAP_S` (a dive) the integer lanes are identified again from ``gps``,
    else the filter's ``position``, only as :class:`LaneRule` ``rule`` allows (conditioned on
    the patterns still tracked; None: the older rule, 1σ ≤ :data:`LANE_SIGMA_MAX` along the
    gradient of the position alone); a pattern no source settles stays out of the fix and a
    note says why. Whenever ``gps`` settles a lane, every count is checked against it: a count
    a whole lane or more off is a lane slip, corrected to GPS's lane with a note (under
    ``rule``, a suspected slip GPS cannot settle keeps that pattern out of this record's fix).
    A zone/lane more than half a zone from the provisional count gives a warning (THEORY D7).
    """
    slips = 0
    totals: list[float | None] = [None, None, None]
    new_track = list(track)
    notes: list[str] = []
    resolver: ZoneLaneResolver | None = None  # built on first use (a pattern's first reading)
    at = _LaneAt(placed, geodesic)
    floor = math.floor
    # The patterns' tracks usually share one time: its interval is taken once (a pure function
    # of the two datetimes).
    last_time: datetime | None = None
    last_s = 0.0
    gap: list[int] = []  # patterns to identify again after a gap (under ``rule``)
    suspects: list[int] = []  # lane slips the old GPS check finds (judged under ``rule``)
    entered: list[int] = []  # first readings, from the zone/lane entries
    doubted: dict[int, float] = {}  # patterns in doubt (``rule.check``): their tracked totals
    check = rule is not None and rule.check
    for i in range(3):
        frac = fractions[i]
        if frac is None:
            continue
        prev = new_track[i]
        checked = False
        if prev is not None:
            t_prev = prev[1]
            if t_prev is not last_time:
                last_s = (time - t_prev).total_seconds()
                last_time = t_prev
        if prev is not None and last_s <= DECCA_TRACK_GAP_S:
            # track_lane(prev[0], frac), written out (the same operations)
            p0 = prev[0]
            d = frac - (p0 - floor(p0))
            step = d - floor(d + 0.5)
            total: float | None = p0 + step
            if check:
                if not abs(step) <= LANE_STEP_MAX:  # the track may have slipped here
                    gap.append(i)
                    continue
                if len(prev) > 2:  # in doubt: tracked on, out of the fix
                    doubted[i] = total  # type: ignore[assignment]
                    new_track[i] = (total, time, DOUBT)  # type: ignore[assignment]
                    continue
        elif prev is not None:
            if rule is not None:
                gap.append(i)
                continue
            total, checked = _identify_after_gap(at, i, frac, (gps, position), gps, notes)
            if total is None:
                continue  # the stale track stays: the next record tries again
        else:
            if resolver is None:
                resolver = ZoneLaneResolver(placed, x_start[0], x_start[1], geodesic)
            zl = zone_lane[i]
            lanes = None if zl is None else resolver.resolve_checked(i, zl, frac, notes)
            if lanes is None:
                continue  # never entered by the operator, or no N_calc: not available
            total = lanes.total
            entered.append(i)
            if lanes.warning is not None:  # more than half a zone from N_calc (THEORY D7)
                notes.append(lanes.warning)
        if gps is not None and not checked:
            if rule is not None:
                lane = at(gps, i)
                if (lane is not None and lane[1] <= LANE_SIGMA_MAX
                        and round(total - identify_lane(lane[0], frac)) != 0):
                    if check and prev is not None:
                        # a continuous track does not slip: the reading's error (or GPS's)
                        notes.append(f"Decca {PATTERNS[i]}: {LANE_DOUBT_NOTE}: the count "
                                     f"{total:.2f} and GPS differ by half a lane or more on a "
                                     "track without a step that could slip it: kept out of "
                                     "the fix until GPS confirms its lane")
                        new_track[i] = (total, time, DOUBT)
                        continue
                    suspects.append(i)
            else:
                total, slipped = _gps_lane_check(at, i, frac, total, gps, notes)
                slips += slipped
        totals[i] = total
        new_track[i] = (total, time)
    if rule is not None and suspects and gps is not None:
        slips += _gps_slip_confirmed(at, fractions, totals, suspects, gps, rule, notes)
        for i in suspects:
            if totals[i] is not None:
                new_track[i] = (totals[i], time)  # type: ignore[assignment]
    if check and entered:
        _check_entry(at, entered, fractions, totals, new_track,  # type: ignore[arg-type]
                     time, (gps, position), rule, notes)
    if rule is not None and gap:
        _identify_gap(at, gap, fractions, totals, new_track, time, (gps, position), rule,
                      notes)
    if check and doubted:
        _confirm_doubt(at, doubted, fractions, totals, new_track,  # type: ignore[arg-type]
                       time, gps, rule, notes)
    return LaneTotals((totals[0], totals[1], totals[2]), tuple(new_track), tuple(notes),
                       slips)


def _identify_gap(at: _LaneAt, gap: list[int], fractions: Sequence[float | None],
                  totals: list[float | None], new_track: list[tuple[float, datetime] | None],
                  time: datetime, sources: Sequence[LaneSource | None], rule: LaneRule,
                  notes: list[str], floats: Any = _floats_at, fix: Any = fix_lanes) -> None:
    """The patterns ``gap`` identified again after a gap under ``rule``: from each source in
    turn (GPS, then the filter's position), jointly and conditioned on the whole lanes of the
    patterns with counts in this record (:func:`fix_lanes`); ``totals`` and ``new_track`` are
    set in place for those taken, a note says why for the others (kept out of the fix).
    ``floats`` and ``fix`` are :func:`_floats_at` and :func:`fix_lanes` unless the compiled
    path (engine.fast.decca) passes its own."""
    known: dict[int, int] = {}
    for i in range(3):
        t, f = totals[i], fractions[i]
        if t is not None and f is not None:
            known[i] = round(t - f)
    left = list(gap)
    whys: list[str] = []
    for src in sources:
        if src is None or not left:
            continue
        fl = floats(at, src, fractions, rule.cf)
        if fl is None:
            whys.append(f"{src.name}: no lane count")
            continue
        fixing = fix(fl[0], fl[1], left, known, rule)
        for i, z in sorted(fixing.lanes.items()):
            frac = fractions[i]
            assert frac is not None
            total = _total_for(fl[2][i], frac, z)
            totals[i] = total
            new_track[i] = (total, time)
            known[i] = z
            notes.append(f"Decca {PATTERNS[i]}: lane identified again from {src.name} "
                         f"(success rate {fixing.success:.4f}, ratio {fixing.ratio:.1f})")
        left = [i for i in left if i not in fixing.lanes]
        if fixing.why is not None and left:
            whys.append(f"{src.name}: {fixing.why}")
    for i in left:
        why = "; ".join(whys) if whys else "no position"
        notes.append(f"Decca {PATTERNS[i]}: lane not identified after the gap ({why}), "
                     f"{LANE_DOUBT_NOTE}: kept out of the fix until GPS, a better position or "
                     "a zone/lane entered in Setup > Decca settles it")


# --------------------------------------------------------------------------------------------
# Decca behind the systems seam (engine.systems.base)

DECCA_PATTERN_NAMES = ("Red", "Grn", "Prp")
_EYE2 = np.eye(2)
_EYE2.setflags(write=False)
"""Short Decca pattern names of the LOP tables (Pg 631) and the operator messages."""


@dataclass(frozen=True, slots=True)
class DeccaReading:
    """One cycle's Decca input: lane fractions (None = no reading), the operator's zone/lane per
    pattern (None = not entered), selected patterns, corrections "C-O" (lanes) and ``Decca.CF``.

    ``totals`` (uncorrected total lane counts per pattern) overrides the zone/lane resolution when
    the caller tracks lanes from cycle to cycle like a decometer (:func:`decca_totals`).
    """

    placed: ChainOnGrid
    fractions: tuple[float | None, float | None, float | None]
    zone_lane: tuple[tuple[int, int] | None, tuple[int, int] | None, tuple[int, int] | None]
    selected: tuple[bool, bool, bool]
    corrections_lanes: tuple[float, float, float] = (0.0, 0.0, 0.0)
    cf: float = 64.0
    totals: tuple[float | None, float | None, float | None] | None = None
    condition: DeccaCondition | None = None
    """The sky-wave condition ``cf`` was chosen by (``lsq.decca_cf = "auto"``; None: a fixed
    ``Decca.CF``)."""


class DeccaObservations:
    """The three pattern rows of a fix: corrected total lane counts as metric LOPs (A5.9–A5.12,
    k = λc·LEF/2 metres per lane) with the a priori VCV of A4.1–A4.4 in m²."""

    __slots__ = ("_at", "_available", "messages", "observed", "raw", "reading")

    def __init__(self, reading: DeccaReading, observed: list[float],
                 raw: list[float | None], available: list[bool], messages: list[str]) -> None:
        self.reading = reading
        self.observed = observed
        """Corrected total lane counts (NaN: no reading)."""
        self.raw = (raw[0], raw[1], raw[2])
        """Uncorrected total lane counts (None: no reading), the "read" of Pg 631."""
        self._available = available
        self.messages = tuple(messages)
        self._at: tuple[Point, DeccaGeometry] | None = None

    def available(self) -> list[bool]:
        return list(self._available)

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        """:func:`decca_geometry`'s rows at ``p`` without its page data: lane model, LEF and
        the VCV as Python floats (the same operations; ``p.latlon`` where ``p`` is on the
        chain's grid, as :meth:`geometry_at`)."""
        placed = self.reading.placed
        sc = placed._scalars
        grid = placed.grid
        lat0, lon0 = p.latlon if p.grid is grid else grid.inverse(p.x, p.y)
        dist, n_calc, row_x, row_y = _lane_model(sc, p.x, p.y, lat0)
        lef = _lef(_azimuths_rad(sc, p.geodesic, lat0, lon0))
        lam = sc.wavelength
        k = [lam[0] * lef[0] / 2.0, lam[1] * lef[1] / 2.0, lam[2] * lef[2] / 2.0]  # A4.4
        for j, obs in enumerate(self.observed):
            if obs == obs:  # a reading (NaN: none); A5.9–A5.12 in metres across the LOP
                kj = k[j]
                i = slot0 + j
                A[2 * i] = row_x[j] * kj
                A[2 * i + 1] = row_y[j] * kj
                b[i] = (obs - n_calc[j]) * kj
        s = slice(slot0, slot0 + len(PATTERNS))
        vcv_m2 = decca_vcv_m2
        if vcv_m2 is _DECCA_VCV_M2:
            Cl[s, s] = _vcv_m2(_vcv_core(dist[0], dist[1:], sc.baseline_sky, self.reading.cf),
                               k)
        else:  # another a priori VCV put in its place (the printed one of Pg 615/821)
            geom = decca_geometry(placed, p.x, p.y, p.geodesic, (lat0, lon0))
            Cl[s, s] = vcv_m2(geom, self.reading.cf)

    def geometry_at(self, p: Point) -> DeccaGeometry:
        """The lane geometry at the estimate ``p`` (computed once per point; Pg 810)."""
        if self._at is None or self._at[0] is not p:
            self._at = (p, decca_geometry(self.reading.placed, p.x, p.y, p.geodesic, p.latlon))
        return self._at[1]

    def readings(self, p: Point) -> list[LopReading]:
        """The page rows of the patterns read: read and computed lane counts, the LOP's
        azimuth in degrees."""
        geom = self.geometry_at(p)
        n_calc = geom.n_calc.tolist()
        lop_az = geom.lop_azimuth_rad.tolist()
        corrections = self.reading.corrections_lanes
        return [LopReading(i, "Decca", DECCA_PATTERN_NAMES[i], raw, corrections[i], n_calc[i],
                           math.degrees(lop_az[i]))
                for i, raw in enumerate(self.raw) if raw is not None]

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        """The nearest station of a used pattern (its hyperbola has the master and its slave
        as foci), metres."""
        geom = self.geometry_at(p)
        d_slave = geom.d_slave_m.tolist()
        near = math.inf
        for i in range(len(PATTERNS)):
            if used[i]:
                near = min(near, geom.d_master_m, d_slave[i])
        return near


class DeccaSystem:
    """Decca behind :class:`engine.systems.base.NavSystem` (config table ``[decca]``, the lane
    corrections in ``[corrections]``, ``Decca.CF`` in ``[lsq]``)."""

    name = "decca"
    letter = "D"
    column: int | None = 4
    slot_labels = DECCA_PATTERN_NAMES
    observations_class: type[DeccaObservations] = DeccaObservations
    """What :meth:`observations` makes of a reading."""

    def is_on(self, config: Any) -> bool:
        return bool(config.decca.on)

    def fix_source(self, config: Any) -> tuple[object, ...]:
        """The chain and the selected patterns while Decca is on."""
        d = config.decca
        return ("Decca", d.chain, *d.select) if d.on else ()

    def read(self, inputs: CycleInputs) -> SystemReading:
        """The record's fractions as tracked total lane counts (``detail``: the
        :class:`LaneTotals` with the new lane track), checked against this cycle's GPS."""
        cfg, ctx, rec = inputs.config, inputs.context, inputs.record
        if not cfg.decca.on:
            return SystemReading()
        cm = inputs.cm_deg
        pl = ctx._placed  # ctx.placed_chain(cm), its usual case looked up here
        placed = pl[cm] if cm in pl else ctx.placed_chain(cm)
        if placed is None:
            return SystemReading(messages=(f"Decca chain {cfg.decca.chain} not in the chain file",))
        gps_reading = inputs.earlier.get("gps")
        g = None if gps_reading is None else gps_reading.value
        lanes = self.lane_totals(inputs, placed, g)
        per = self._per_config
        if per is None or per[0] is not cfg:
            select = cfg.decca.select
            c = cfg.corrections
            per = self._per_config = (
                cfg, (PATTERNS[0] in select, PATTERNS[1] in select, PATTERNS[2] in select),
                (c.decca_red_lanes, c.decca_green_lanes, c.decca_purple_lanes))
        totals = lanes.totals
        cf, condition = self._epoch_cf(inputs)
        reading = DeccaReading(placed, rec.decca, ctx.zone_lane, per[1], per[2], cf, totals,
                               condition)
        return SystemReading(reading, lanes.notes, lanes, totals != (None, None, None))

    _epoch: tuple[CycleInputs, float, Any] | None = None
    """(inputs, Decca.CF, condition) of the last epoch whose CF was resolved."""

    def _epoch_cf(self, inputs: CycleInputs) -> tuple[float, Any]:
        """This epoch's Decca.CF and, under ``lsq.decca_cf = "auto"``, its sky-wave condition
        from the sun at the last MPP (docs/THEORY.md §3.5; None for a fixed CF)."""
        got = self._epoch
        if got is not None and got[0] is inputs:
            return got[1], got[2]
        cf = inputs.config.lsq.decca_cf
        condition = None
        if isinstance(cf, str):
            nav = inputs.nav
            condition = decca_condition(inputs.record.time, nav.mpp_lat_deg, nav.mpp_lon_deg)
            cf = condition.cf
        self._epoch = (inputs, cf, condition)
        return cf, condition

    def lane_totals(self, inputs: CycleInputs, placed: ChainOnGrid, gps: Any) -> LaneTotals:
        """The record's lane counts tracked from the last cycle's (:func:`decca_totals`),
        checked against ``gps`` (the cycle's :class:`engine.systems.gps.GpsFix`, None: no GPS)
        and, after a gap, against the filter's prediction."""
        ctx, rec = inputs.context, inputs.record
        x_start, prior = inputs.x_start, inputs.prior
        return decca_totals(
            placed, ctx.geodesic, ctx.zone_lane, inputs.nav.decca_track, rec.decca, rec.time,
            x_start,
            None if prior is None else LaneSource("the DR position", *x_start, prior.cov),
            None if gps is None else LaneSource("GPS", gps.x_m + gps.corr_east_m,
                                                gps.y_m + gps.corr_north_m,
                                                self._gps_cov(gps.var_m2)),
            self._rule(inputs.config, self._epoch_cf(inputs)[0]))

    _rule_of: tuple[Any, float, LaneRule | None] | None = None

    def _rule(self, cfg: Any, cf: float) -> LaneRule | None:
        """The :class:`LaneRule` of ``cfg.decca`` (None: ``lane_rule = "sigma"``), the
        assumed Decca.CF the smaller of ``lane_cf`` and this epoch's ``cf``."""
        got = self._rule_of
        if got is not None and got[0] is cfg and got[1] == cf:
            return got[2]
        d = cfg.decca
        rule = (None if d.lane_rule == "sigma" else
                LaneRule(d.lane_success, d.lane_ratio, min(d.lane_cf, cf),
                         d.lane_check == "dia"))
        self._rule_of = (cfg, cf, rule)
        return rule

    _per_config: tuple[Any, tuple[bool, bool, bool], tuple[float, float, float]] | None = None
    """(configuration, selected patterns, corrections "C-O" in lanes) of the last configuration
    read (frozen, so computed once per configuration object)."""
    _cov: tuple[float, np.ndarray] | None = None

    def _gps_cov(self, var_m2: float) -> np.ndarray:
        """``_EYE2 * var_m2``, the GPS fix's 2×2 VCV (m²): one read-only array while the
        variance stays the same (a nonzero float equal to the last has its bits)."""
        cov = self._cov
        if cov is not None and cov[0] == var_m2 and var_m2 != 0.0:
            return cov[1]
        arr = _EYE2 * var_m2
        arr.setflags(write=False)
        self._cov = (var_m2, arr)
        return arr

    def observations(self, value: DeccaReading | None, p0: Point) -> DeccaObservations | None:
        """Corrected total lane counts of ``value``: its ``totals``, else resolved from the
        zone/lane entries at ``p0`` (:class:`ZoneLaneResolver`; ObservationError where that
        cannot be evaluated)."""
        if value is None:
            return None
        totals = value.totals
        if totals is not None:
            # the loop below for tracked totals, without its resolver and messages
            fr = value.fractions
            corr = value.corrections_lanes
            sel = value.selected
            t_obs = [math.nan] * 3
            t_raw: list[float | None] = [None, None, None]
            t_av = [False] * 3
            for i in (0, 1, 2):
                t = totals[i]
                if t is not None and fr[i] is not None:
                    r = t_raw[i] = float(t)
                    t_obs[i] = r + corr[i]
                    t_av[i] = sel[i]
            return self.observations_class(value, t_obs, t_raw, t_av, [])
        observed = [math.nan] * 3
        raw: list[float | None] = [None, None, None]
        available = [False] * 3
        messages: list[str] = []
        resolver = (None if value.totals is not None
                    else ZoneLaneResolver(value.placed, p0.x, p0.y, p0.geodesic))
        for i in range(len(PATTERNS)):
            frac, zl = value.fractions[i], value.zone_lane[i]
            if value.totals is not None:
                if value.totals[i] is None or frac is None:
                    continue
                total = float(value.totals[i])  # type: ignore[arg-type]
            else:
                if frac is None or zl is None:
                    continue
                try:
                    res = resolver.resolve(i, zl, frac)  # type: ignore[union-attr]
                except EVAL_ERRORS as exc:
                    raise ObservationError("Decca lane count not resolved at the provisional "
                                           f"position: {exc}", messages) from exc
                total = res.total
                if res.warning is not None:
                    messages.append(res.warning)
            raw[i] = total
            observed[i] = total + value.corrections_lanes[i]
            available[i] = value.selected[i]
        return self.observations_class(value, observed, raw, available, messages)

    def row_name(self, index: int, value: Any) -> str | None:
        """``Decca Red``/``Grn``/``Prp``."""
        return f"Decca {DECCA_PATTERN_NAMES[index]}"


DECCA = DeccaSystem()
