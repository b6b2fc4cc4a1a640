"""Geodesy (engine/geodesy/ellipsoidal.py) against the thesis screens (A8.5), pyproj and hand
calculations."""

from __future__ import annotations

import math
import os
import pickle
import random
import subprocess
import sys

import pytest
from pyproj import Geod, Transformer

from engine.geodesy.ellipsoid import WGS84, WGS84_ELLIPSOID, Datum, Ellipsoid
from engine.geodesy.ellipsoidal import (
    DatumShift,
    GeodesicSolver,
    andoyer_lambert_m,
    bursa_wolf_from_wgs84,
    bursa_wolf_to_wgs84,
    datum_shift,
    ecef_to_geodetic,
    geocentric_datum_shift,
    geodesic_inverse,
    geodetic_to_ecef,
    helmert_pipeline,
    line_scale_factor,
    mean_radius_sq,
    spheroidal_distance,
    wgs84_fix_ecef,
    wgs84_fix_to_datum,
)
from engine.geodesy.tmgrid import TMGrid
from tests.paths import ROOT
from tests.tolerance import Near

INTL = Ellipsoid("INTERNATIONAL", 6378388.0, 297.0)
ED50 = Datum("ED50", INTL, -87.0, -98.0, -121.0)
WGS72_DMA = Datum(
    "WGS72 [DMA]", Ellipsoid("WGS72", 6378135.0, 298.26), 0.0, 0.0, 4.5, 0.0, 0.0, 0.55, 0.22
)
GRID_5E = TMGrid(INTL, 5.0)


def dms(d: float, m: float, s: float) -> float:
    """Degrees from degrees, minutes, seconds (positive: N/E)."""
    return d + m / 60.0 + s / 3600.0


def arcsec(a: float, b: float) -> float:
    """a − b in arc-seconds (a, b in degrees)."""
    return (a - b) * 3600.0


# The sample GPS fix (Pg 611, THEORY §14.2): WGS84 52°50'30.000"N 004°31'46.200"E.
GPS_LAT = dms(52, 50, 30.000)
GPS_LON = dms(4, 31, 46.200)


# --------------------------------------------------------------------------- ECEF
POINTS = [
    (0.0, 0.0, 0.0),
    (52.84, 4.53, -39.5),
    (-33.9, 151.2, 120.0),
    (89.999, -45.0, 5e3),
    (-90.0, 0.0, 0.0),
    (90.0, 123.0, -100.0),
    (12.0, -179.9, -1.1e4),
    (45.0, 90.0, 8e5),
]


@pytest.mark.parametrize(("lat", "lon", "h"), POINTS)
def test_ecef_against_pyproj_cart(lat: float, lon: float, h: float) -> None:
    cart = Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        "+step +proj=cart +a=6378388 +rf=297"
    )
    xp, yp, zp = cart.transform(lon, lat, h)
    x, y, z = geodetic_to_ecef(lat, lon, h, INTL)
    assert (x, y, z) == pytest.approx((xp, yp, zp), abs=1e-6)  # µm: both are closed forms
    lat2, lon2, h2 = ecef_to_geodetic(x, y, z, INTL)
    # Requirement < 0.1 mm; 1e-9° ≈ 0.1 mm on the ground.
    assert lat2 == pytest.approx(lat, abs=1e-9)
    if abs(lat) < 90.0:
        assert (lon2 - lon + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
    assert h2 == pytest.approx(h, abs=1e-4)


# --------------------------------------------------------------------------- GPS chain, Pg 611/100
def test_gps_fix_to_ed50_pg611() -> None:
    lat, lon, h = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50)
    # Pg 611 "ED50 52°50'32.777"N 004°31'51.052"E": half a printed digit = 0.0005".
    # We get 32.77695" and 51.05223".
    assert arcsec(lat, dms(52, 50, 32.777)) == pytest.approx(0.0, abs=5e-4)
    assert arcsec(lon, dms(4, 31, 51.052)) == pytest.approx(0.0, abs=5e-4)
    # THEORY §2.1–2.2: h_datum = −39.543 m, displayed WGS84 height Hg = −h_datum = "39.5".
    assert h == pytest.approx(-39.543, abs=5e-4)
    assert f"{-h:.1f}" == "39.5"


def test_gps_fix_ecef_pg100() -> None:
    _, _, h = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50)
    x, y, z = wgs84_fix_ecef(GPS_LAT, GPS_LON, h)
    # Pg 100 "GPS X 3848703.06 Y 304893.45 Z 5059951.55" (we get .0649, .4451, .5530):
    # the display rounds to 1 cm, so compare the printed strings exactly, and ±0.02 m.
    assert (f"{x:.2f}", f"{y:.2f}", f"{z:.2f}") == ("3848703.06", "304893.45", "5059951.55")
    assert (x, y, z) == pytest.approx((3848703.06, 304893.45, 5059951.55), abs=0.02)
    # THEORY §14.1 item 1 recomputed with the rounded h = 39.5: .04 / .44 / .52 (±0.005).
    x5, y5, z5 = geodetic_to_ecef(GPS_LAT, GPS_LON, 39.5, WGS84_ELLIPSOID)
    assert (x5, y5, z5) == pytest.approx((3848703.04, 304893.44, 5059951.52), abs=0.005)


def test_gps_fix_grid_pg611() -> None:
    lat, lon, _ = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50)
    x, y = GRID_5E.forward(lat, lon)
    # Pg 611 obs "x : −31613.554", "y : 5857312.625" (THEORY §14.2): 1 mm (we get .5538, .6247).
    assert x == pytest.approx(-31613.554, abs=1e-3)
    assert y == pytest.approx(5857312.625, abs=1e-3)


def test_gps_h_zero_rule_matters() -> None:
    # THEORY §2.1–2.2: with h_WGS84 = 39.54 instead of 0 the northing moves by ~1 mm (the reason
    # for the rule): check the two differ, and that the h = 0 one is the screen's.
    lat0, lon0, _ = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50)
    lat1, lon1, _ = geocentric_datum_shift(GPS_LAT, GPS_LON, 39.543, WGS84, ED50)
    y0 = GRID_5E.forward(lat0, lon0)[1]
    y1 = GRID_5E.forward(lat1, lon1)[1]
    assert abs(y1 - y0) > 4e-4
    assert abs(y0 - 5857312.625) < abs(y1 - 5857312.625) + 1e-4


# --------------------------------------------------------------------------- pipelines
def test_pipeline_is_pinned_and_explicit() -> None:
    p = helmert_pipeline(ED50, WGS84)
    assert p.startswith("+proj=pipeline +step +proj=axisswap +order=2,1")
    assert "+proj=cart +a=6378388.0 +rf=297.0" in p
    assert "+proj=helmert +x=-87.0 +y=-98.0 +z=-121.0" in p
    assert "+convention=position_vector" in p
    assert "+inv +proj=cart +a=6378137.0 +rf=298.257223563" in p
    assert "epsg" not in p.lower() and "+towgs84" not in p and "+datum" not in p
    q = helmert_pipeline(WGS84, WGS72_DMA)
    assert "+step +inv +proj=helmert +x=0.0 +y=0.0 +z=4.5" in q and "+rz=0.55 +s=0.22" in q


PAIRS = [(WGS84, ED50), (ED50, WGS84), (ED50, WGS72_DMA), (WGS72_DMA, WGS84), (WGS84, WGS72_DMA)]


@pytest.mark.parametrize(("src", "dst"), PAIRS)
def test_shift_agrees_with_pyproj_pipeline(src: Datum, dst: Datum) -> None:
    """The engine's geocentric shift (pure Python) against PROJ running the same steps
    (:func:`helmert_pipeline` through pyproj's public ``Transformer.from_pipeline``), over the
    globe at heights of ±10 km: within 1e-9° and 1e-5 m (measured: ≤ 1e-11° and ≤ 2e-6 m,
    the height's worst near the poles)."""
    shift = datum_shift(src, dst)
    assert isinstance(shift, DatumShift)
    proj = Transformer.from_pipeline(helmert_pipeline(src, dst))
    rng = random.Random(14)
    for _ in range(3000):
        lat, lon = rng.uniform(-90.0, 90.0), rng.uniform(-180.0, 180.0)
        h = rng.choice((0.0, rng.uniform(-10000.0, 10000.0)))
        got = shift.transform(lat, lon, h)
        want = tuple(float(v) for v in proj.transform(lat, lon, h))
        assert Near(got, (1e-9, 1e-9, 1e-5)) == Near(want, (1e-9, 1e-9, 1e-5)), (lat, lon, h)
    twin = pickle.loads(pickle.dumps(shift))
    assert twin.transform(52.0, 4.0, 0.0) == shift.transform(52.0, 4.0, 0.0)


def _towgs84_crs(d: Datum) -> object:
    from pyproj import CRS

    e = d.ellipsoid
    return CRS.from_proj4(
        f"+proj=longlat +a={e.a_m} +rf={e.inv_f} +towgs84={d.dx_m},{d.dy_m},{d.dz_m},"
        f"{d.rx_arcsec},{d.ry_arcsec},{d.rz_arcsec},{d.scale_ppm} +no_defs +type=crs")


@pytest.mark.parametrize("datum", [ED50, WGS72_DMA])
def test_shift_agrees_with_pyproj_towgs84_crs(datum: Datum) -> None:
    """The same shift as PROJ builds it itself from a ``+towgs84`` CRS (not from the engine's
    pipeline text): datum → WGS84 at h = 0 within 1e-9° (measured ~3e-14°)."""
    wgs = Transformer.from_crs(_towgs84_crs(datum), "+proj=longlat +datum=WGS84 +type=crs",
                               always_xy=True)
    shift = datum_shift(datum, WGS84)
    rng = random.Random(34)
    for _ in range(2000):
        lat, lon = rng.uniform(-89.9, 89.9), rng.uniform(-179.9, 179.9)
        want_lon, want_lat = wgs.transform(lon, lat)
        got = shift.transform(lat, lon, 0.0)
        assert got[0] == pytest.approx(want_lat, abs=1e-9)
        assert got[1] == pytest.approx(want_lon, abs=1e-9)


@pytest.mark.parametrize(("src", "dst"), PAIRS)
def test_shift_round_trip(src: Datum, dst: Datum) -> None:
    shift = datum_shift(src, dst)
    for lat, lon, h in ((52.84, 4.53, 0.0), (-45.0, 170.0, 100.0), (71.0, -8.0, -50.0),
                        (0.0, -179.9, 0.0), (GPS_LAT, GPS_LON, 0.0)):
        back = shift.inverse(*shift.transform(lat, lon, h))
        # Exact for 3-parameter datums; the small-angle rotation of WGS72 [DMA] inverted by its
        # transpose (as PROJ's +inv helmert does) leaves ~3e-5 m, far below 1 mm.
        assert back[0] == pytest.approx(lat, abs=1e-9)
        assert back[1] == pytest.approx(lon, abs=1e-9)
        assert back[2] == pytest.approx(h, abs=1e-3)


def test_pipeline_gps_path_uses_shift() -> None:
    shift = datum_shift(WGS84, ED50)
    a = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50, shift)
    b = wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50)
    assert a == pytest.approx(b, abs=1e-9)
    with pytest.raises(ValueError):
        wgs84_fix_to_datum(GPS_LAT, GPS_LON, ED50, datum_shift(ED50, WGS84))


_NO_OTHER_LIBRARY = """
import sys
from engine.fast.geodesy import FastDatumShift
from engine.geodesy.ellipsoid import WGS84, Datum, Ellipsoid
from engine.geodesy.ellipsoidal import DatumShift
ed50 = Datum("ED50", Ellipsoid("INTERNATIONAL", 6378388.0, 297.0), -87.0, -98.0, -121.0)
for kind in (DatumShift, FastDatumShift):
    kind(WGS84, ed50).transform(52.0, 4.0, 0.0)
    kind(ed50, WGS84).transform(52.0, 4.0, 0.0)
with open("/proc/self/maps", encoding="utf-8") as maps:
    libproj = any("libproj" in line for line in maps)
print("pyproj" in sys.modules, libproj)
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/maps"), reason="needs Linux's /proc")
def test_datum_shifts_load_no_other_library() -> None:
    """A run's datum shifts, reference and compiled, are the engine's own formulas: they
    neither import pyproj (start-up time) nor load PROJ's shared library."""
    out = subprocess.run([sys.executable, "-c", _NO_OTHER_LIBRARY], cwd=ROOT,
                         capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"], out.stdout + out.stderr


@pytest.mark.parametrize(("lat", "lon"), [(0.0, 0.0), (0.0, 100.0), (52.0, 4.5), (-60.0, -170.0)])
def test_wgs72_dma_rotation_sign(lat: float, lon: float) -> None:
    # THEORY D1: WGS72 [DMA] → WGS84 must increase longitude by ≈ +0.554" (DMA practice).
    # The file's rz = 0.55" gives exactly +0.550" (a pure z rotation changes only λ; dz and the
    # scale leave λ alone), so: 0.55" to 1e-6", and within 0.005" of DMA's 0.554".
    _, lon84, _ = datum_shift(WGS72_DMA, WGS84).transform(lat, lon, 0.0)
    d = arcsec(lon84, lon)
    assert d == pytest.approx(0.55, abs=1e-6)
    assert d == pytest.approx(0.554, abs=0.005)


def test_bursa_wolf_python_inverse_and_three_parameter() -> None:
    x, y, z = geodetic_to_ecef(52.0, 4.0, 0.0, INTL)
    assert bursa_wolf_to_wgs84(x, y, z, ED50) == pytest.approx((x - 87, y - 98, z - 121), abs=1e-9)
    u = bursa_wolf_to_wgs84(x, y, z, WGS72_DMA)
    # Transpose inverse of the small-angle rotation: residual ~(2.7e-6 rad)²·6.4e6 m ≈ 5e-5 m.
    assert bursa_wolf_from_wgs84(*u, WGS72_DMA) == pytest.approx((x, y, z), abs=1e-4)


# --------------------------------------------------------------------------- Pg 810
# Decca chain 9B stations on ED50 (DECCA.CHN, Pg 810 header): master, Red, Green, Purple.
MASTER = (dms(53, 12, 12.388), dms(7, 6, 0.590))
SLAVES = [
    (dms(55, 1, 7.110), dms(8, 41, 38.420)),
    (dms(52, 35, 30.089), dms(4, 43, 47.118)),
    (dms(53, 17, 7.219), dms(9, 15, 48.858)),
]
RECEIVER_GRID = (-31615.400, 5857300.165)


def test_pg810_spheroidal_distances_and_azimuths() -> None:
    rlat, rlon = GRID_5E.inverse(*RECEIVER_GRID)
    solver = GeodesicSolver(INTL)
    expected = [
        (177026.82, 1.32392),
        (365220.90, 0.81675),
        (30962.69, 2.69107),
        (321036.13, 1.38371),
    ]
    for (lat, lon), (d_screen, az_screen) in zip([MASTER, *SLAVES], expected, strict=True):
        x, y = GRID_5E.forward(lat, lon)
        d = spheroidal_distance(*RECEIVER_GRID, x, y, mean_radius_sq(INTL, rlat, lat))
        # ±0.01 m: half the printed cm plus the 4-7 mm model agreement (THEORY §2.4)
        # (we get 177026.825, 365220.907, 30962.690, 321036.130).
        assert d == pytest.approx(d_screen, abs=0.01)
        az = math.radians(solver.inverse(rlat, rlon, lat, lon)[0]) % (2 * math.pi)
        assert az == pytest.approx(az_screen, abs=1e-5)  # printed to 1e-5 rad


def test_pg810_andoyer_baselines() -> None:
    # Printed to 1 cm; we get 227344.0749, 173435.7081, 144712.4718.
    for (lat, lon), b_screen in zip(SLAVES, (227344.07, 173435.71, 144712.47), strict=True):
        assert andoyer_lambert_m(INTL, *MASTER, lat, lon) == pytest.approx(b_screen, abs=0.01)
    # THEORY §2.5: the exact geodesic Red baseline is 227344.331, 0.26 m longer.
    _, _, exact = geodesic_inverse(INTL, *MASTER, *SLAVES[0])
    assert exact == pytest.approx(227344.33, abs=0.005)


def test_andoyer_on_sphere_and_degenerate() -> None:
    sphere = Ellipsoid("SPHERE", 6371000.0, 0.0)
    # f = 0: Andoyer–Lambert reduces to the great-circle distance a·σ (pyproj Geod on a sphere).
    _, _, d = Geod(a=6371000.0, f=0.0).inv(10.0, 20.0, 40.0, -5.0)
    assert andoyer_lambert_m(sphere, 20.0, 10.0, -5.0, 40.0) == pytest.approx(d, abs=1e-6)
    assert andoyer_lambert_m(INTL, 52.0, 4.0, 52.0, 4.0) == 0.0
    # On the ellipsoid over 100-300 km its first-order error is a few dm at most (Red: 0.26 m).
    solver = GeodesicSolver(INTL)
    for lat2, lon2 in ((54.0, 7.0), (50.0, 1.0), (53.0, 8.5)):
        exact = solver.inverse(52.0, 4.0, lat2, lon2)[2]
        assert andoyer_lambert_m(INTL, 52.0, 4.0, lat2, lon2) == pytest.approx(exact, abs=0.5)


def test_geodesic_inverse_conventions() -> None:
    az12, az21, d = geodesic_inverse(WGS84_ELLIPSOID, 0.0, 0.0, 0.0, 1.0)
    # Along the equator: forward azimuth east (90°), back azimuth (at 2 towards 1) west (−90°),
    # length a·Δλ exactly.
    assert az12 == pytest.approx(90.0, abs=1e-12)
    assert az21 == pytest.approx(-90.0, abs=1e-12)
    assert d == pytest.approx(6378137.0 * math.radians(1.0), abs=1e-6)
    assert GeodesicSolver(INTL).inverse(52.0, 4.0, 53.0, 7.0) == geodesic_inverse(
        INTL, 52.0, 4.0, 53.0, 7.0
    )


# --------------------------------------------------------------------------- A5.10 / A5.13
def test_mean_radius_sq_hand_values() -> None:
    a, e2 = INTL.a_m, INTL.e2
    assert mean_radius_sq(INTL, 0.0, 0.0) == pytest.approx(a * a * (1 - e2), rel=1e-15)
    assert mean_radius_sq(INTL, 80.0, 100.0) == pytest.approx(a * a / (1 - e2), rel=1e-15)
    # Mean latitude, not mean of the radii: (52.6 + 53.2)/2 = 52.9°.
    s = math.sin(math.radians(52.9))
    assert mean_radius_sq(INTL, 52.6, 53.2) == pytest.approx(
        a * a * (1 - e2) / (1 - e2 * s * s) ** 2, rel=1e-15
    )


def test_line_scale_factor_and_distance_hand_values() -> None:
    rm2 = 6.4e6**2
    # (1e5² + 1e10 + 1e10)/(6·4.096e13) = 3e10/2.4576e14
    assert line_scale_factor(1e5, 1e5, rm2) == pytest.approx(1 + 3e10 / 2.4576e14, rel=1e-15)
    assert line_scale_factor(0.0, 0.0, rm2) == 1.0
    assert line_scale_factor(-2e5, 1e5, rm2) == pytest.approx(1 + 3e10 / 2.4576e14, rel=1e-15)
    # 3-4-5 chord of 5 km at the CM: D = d exactly; 100 km east: D = d / L.
    assert spheroidal_distance(0.0, 0.0, 0.0, 5000.0, rm2) == 5000.0
    d = spheroidal_distance(1e5, 0.0, 1e5 + 3000.0, 4000.0, rm2)
    assert d == pytest.approx(5000.0 / line_scale_factor(1e5, 1e5 + 3000.0, rm2), rel=1e-15)
