"""Decca lane model against Pg 810/615/821 of the thesis worked example (THEORY §3.2–3.5, §14.2).

The receiver is the LSE of the sample, grid (−31615.400, 5857300.165) on ED50, CM 5°E.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyproj import Geod

from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.io.datumfile import read_datum_file
from engine.io.deccafile import DeccaChain, read_chain_file
from engine.systems.decca import (
    ChainOnGrid,
    decca_geometry,
    decca_vcv_lanes,
    decca_vcv_m2,
    place_chain,
    resolve_total_lanes,
    sigma_path_a,
)
from tests.paths import DATA

RX = (-31615.400, 5857300.165)


@pytest.fixture(scope="module")
def geometry():
    ed50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
    chain = read_chain_file(DATA / "DECCA.CHN")["9B"]
    placed = place_chain(chain, TMGrid(ed50.ellipsoid, 5.0))
    return placed, decca_geometry(placed, *RX, GeodesicSolver(ed50.ellipsoid))


def test_pg810_distances_baselines_azimuths(geometry) -> None:
    placed, g = geometry
    # Pg 810 prints distances and baselines to 0.01 m and angles to 1e-5 rad.
    assert g.d_master_m == pytest.approx(177026.82, abs=0.01)
    assert g.d_slave_m == pytest.approx([365220.90, 30962.69, 321036.13], abs=0.01)
    assert g.baseline_m == pytest.approx([227344.07, 173435.71, 144712.47], abs=0.01)
    assert g.az_master_rad == pytest.approx(1.32392, abs=1e-5)
    assert g.az_slave_rad == pytest.approx([0.81675, 2.69107, 1.38371], abs=1e-5)
    assert g.lop_azimuth_rad == pytest.approx([1.07034, 5.14909, 4.49540], abs=1e-5)


def test_pg615_lef_calc_and_lop_azimuths(geometry) -> None:
    _, g = geometry
    # LEF printed with 5 decimals; Purple's 33.45517 is 2e-5 from ours because its γ is small
    # (LEF ∝ 1/sin(γ/2)): 1e-6 rad of azimuth moves it by 3e-5, below Pg 810's 1e-5 rad print.
    assert g.lef == pytest.approx([3.98609, 1.58335, 33.45517], abs=5e-5)
    # Calc on Pg 615 is printed to 0.01 lane: 44.81, 274.29, 1.01 (recomputed 44.8129 …).
    assert np.round(g.n_calc, 2) == pytest.approx([44.81, 274.29, 1.01], abs=1e-9)
    assert g.n_calc == pytest.approx([44.8129, 274.2867, 1.0061], abs=1e-4)
    assert np.round(np.degrees(g.lop_azimuth_rad), 1) == pytest.approx([61.3, 295.0, 257.6])


def test_pg821_metric_design_rows(geometry) -> None:
    _, g = geometry
    rows = g.row * g.metres_per_lane[:, None]
    # Pg 821 prints 5 decimals.
    assert rows[0] == pytest.approx([-0.47409, 0.88046], abs=5e-6)
    assert rows[1] == pytest.approx([-0.42885, -0.90336], abs=5e-6)


def test_partials_match_finite_differences(geometry) -> None:
    """∂N/∂(x, y) of A5.11–A5.12 against a central difference of the lane model itself."""
    placed, g = geometry
    solver = GeodesicSolver(placed.grid.ellipsoid)
    h = 0.5
    for axis in (0, 1):
        p = list(RX)
        p[axis] += h
        up = decca_geometry(placed, *p, solver).n_calc
        p[axis] -= 2 * h
        down = decca_geometry(placed, *p, solver).n_calc
        # Second-order difference error ~h²·N''' ≪ 1e-9 lane/m here.
        assert (up - down) / (2 * h) == pytest.approx(g.row[:, axis], abs=1e-9)


def test_decca_vcv_structure_and_tolerance(geometry) -> None:
    _, g = geometry
    c = decca_vcv_m2(g, 64.0)
    # Pg 615 prints [[916.877, 18.050], [18.050, 83.585]].  The documented A4 model gives
    # 917.98 / 18.126 / 83.633 (THEORY §3.5, D10: the 0.1–0.4 % misfit is unexplained).  We hold
    # the model to 0.5 %, the regression tolerance stated there.
    assert c[0, 0] == pytest.approx(916.877, rel=5e-3)
    assert c[0, 1] == pytest.approx(18.050, rel=5e-3)
    assert c[1, 1] == pytest.approx(83.585, rel=5e-3)
    # And exactly what the literal A4 formulas give (hand recomputation in THEORY §3.5).
    assert [c[0, 0], c[0, 1], c[1, 1]] == pytest.approx([917.98, 18.126, 83.633], abs=0.005)
    # Covariance structure: master terms only, 12σn²/CF between Red and Green (A4.2d).
    lanes = decca_vcv_lanes(g, 64.0)
    s_n = sigma_path_a(g.d_master_m / 1e5)
    assert lanes[0, 1] == pytest.approx(12 * s_n**2 / 64)
    assert lanes[0, 2] == pytest.approx(20 * s_n**2 / 64)
    assert lanes[1, 2] == pytest.approx(15 * s_n**2 / 64)
    # Sky-wave variance scales with 1/CF, sync does not: summer night (CF 1) is larger.
    assert np.all(np.diag(decca_vcv_lanes(g, 1.0)) > np.diag(lanes))


def test_path_sigma_polynomial() -> None:
    # A4.3a at d = 1 (100 km): (2.407 − 2.273 + 4.240)·10⁻³ = 4.374·10⁻³ lanes (hand).
    assert sigma_path_a(1.0) == pytest.approx(4.374e-3, abs=1e-12)


def test_zone_cycle_resolution() -> None:
    # THEORY §3.3: B20.862 → 44.862, F34.337 → 274.337 (second letter cycle), A51.111 → 1.111,
    # with N_calc at the DR start 44.88, 276.15, 1.05.
    red = resolve_total_lanes(1, 20, 0.862, "red", 44.88)
    assert red.total == pytest.approx(44.862) and red.cycle == 0 and red.warning is None
    assert red.offset_lanes == pytest.approx(-0.018)
    green = resolve_total_lanes(5, 34, 0.337, "green", 276.15)
    assert green.total == pytest.approx(274.337) and green.cycle == 1 and green.warning is None
    assert resolve_total_lanes(0, 51, 0.111, "purple", 1.05).total == pytest.approx(1.111)
    # A cycle further out is chosen when the computed count says so (10 zones × 24 lanes).
    assert resolve_total_lanes(1, 20, 0.862, "red", 44.88 + 240).total == pytest.approx(284.862)
    assert math.isclose(resolve_total_lanes(1, 20, 0.862, "red", 44.88 - 240).total, -195.138)


@pytest.mark.parametrize(
    ("pattern", "zone", "lane", "total", "half"),
    [("red", 1, 20, 44.862, 12.0), ("green", 5, 34, 94.337, 9.0), ("purple", 0, 51, 1.111, 15.0)],
)
def test_half_zone_warning(pattern: str, zone: int, lane: int, total: float, half: float) -> None:
    """THEORY D7: warn when the resolved count is more than half a zone (lpz/2 = 12, 9, 15 lanes)
    from N_calc. Hand calculation: the same reading with N_calc = total ± (half − 0.01) resolves
    to the same cycle without a warning; ± (half + 0.01) still resolves to it (the period is
    10 zones) but warns, naming the pattern, the zone/lane and the offset."""
    frac = total % 1.0
    for sign in (1.0, -1.0):
        inside = resolve_total_lanes(zone, lane, frac, pattern, total + sign * (half - 0.01))
        assert inside.total == pytest.approx(total) and inside.warning is None
        outside = resolve_total_lanes(zone, lane, frac, pattern, total + sign * (half + 0.01))
        assert outside.total == pytest.approx(total)
        assert outside.offset_lanes == pytest.approx(-sign * (half + 0.01))
        w = outside.warning
        assert w is not None and w.startswith(f"Decca {pattern}: zone/lane {'ABCDEFGHIJ'[zone]}")
        assert f"{-sign * (half + 0.01):+.2f} from" in w and f"{half:g} lanes" in w
    with pytest.raises(ValueError):
        resolve_total_lanes(zone, lane, frac, pattern, math.nan)


@pytest.fixture(scope="module")
def chain_2e() -> tuple[DeccaChain, ChainOnGrid, GeodesicSolver]:
    ed50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
    chain = read_chain_file(DATA / "DECCA.CHN")["2E"]
    placed = place_chain(chain, TMGrid(ed50.ellipsoid, 5.0))
    return chain, placed, GeodesicSolver(ed50.ellipsoid)


def test_min_lane_count_of_chain_2e(
    chain_2e: tuple[DeccaChain, ChainOnGrid, GeodesicSolver],
) -> None:
    """Chain 2E has k = −3.920 (Red), 3.205 (Green), 0 (Purple) (DECCA.CHN, THEORY §3.2, D8).

    Hand calculation from eq. 4.9, N = (D_m − D_s + B)/λc + k, at two points on each baseline
    extension, 5 km beyond a station along the geodesic through both (pyproj on the
    International ellipsoid, independent of the engine):
    * behind the master D_s = D_m + B, so N = k exactly: −3.920, 3.205, 0;
    * behind the slave D_m = D_s + B, so N = 2B/λc + k, with λc = v/(m·f_slave), v = 299550
      km/s, m = 3, 2, 6 (THEORY §3.2): Red λc = 299550/(3·112.7333) = 885.719 m, B = 109 758.61
      m → 247.841 − 3.920 = 243.921; Green 1180.958 m, 85 651.95 m → 145.055 + 3.205 =
      148.260; Purple 708.575 m, 238 043.89 m → 671.895.
    Tolerance 5e-4 lane: the engine's baseline is Andoyer–Lambert (THEORY §2.5), 0.15 m shorter
    than the geodesic for Red (1.7e-4 lane), and its distances are grid chord / L (mm). With
    k's sign reversed Red and Green would be off by 7.8 and 6.4 lanes."""
    chain, placed, solver = chain_2e
    geod = Geod(a=6378388.0, rf=297.0)  # International 1924 (ED50)
    grid = placed.grid
    master = chain.master
    assert chain.min_lanes == (-3.920, 3.205, 0.0)
    expected_slave_side = (243.921, 148.260, 671.895)
    for j, slave in enumerate((chain.red, chain.green, chain.purple)):
        fwd, back, base = geod.inv(master.lon_deg, master.lat_deg, slave.lon_deg, slave.lat_deg)
        lam = chain.speed_km_s / ((3, 2, 6)[j] * slave.freq_khz)  # km/s / kHz = m
        k = chain.min_lanes[j]
        lon, lat, _ = geod.fwd(master.lon_deg, master.lat_deg, fwd + 180.0, 5000.0)
        behind_master = decca_geometry(placed, *grid.forward(lat, lon), solver).n_calc[j]
        assert behind_master == pytest.approx(k, abs=5e-4)
        lon, lat, _ = geod.fwd(slave.lon_deg, slave.lat_deg, back + 180.0, 5000.0)
        behind_slave = decca_geometry(placed, *grid.forward(lat, lon), solver).n_calc[j]
        assert 2.0 * base / lam + k == pytest.approx(expected_slave_side[j], abs=5e-4)
        assert behind_slave == pytest.approx(2.0 * base / lam + k, abs=5e-4)
