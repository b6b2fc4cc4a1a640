"""The engine's hot-path shortcuts (issue 7) give exactly what the general code they replace gives.

Each test compares a shortcut with an independent reference: numpy/LAPACK for the linear algebra,
the general routine it specialises (Clenshaw with derivative, the grid inversion inside the Decca
geometry), or the rule it implements written out plainly (the ``.OUT`` quoting rule, argmax).
Equality is exact (``==``, ``array_equal``) where the shortcut performs the same floating-point
operations; a tolerance is stated where it does not.
"""

from __future__ import annotations

import cmath
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pyproj import Geod

import engine.filter.kalman as kf
from engine.geodesy.angles import wrap_180_deg
from engine.geodesy.ellipsoidal import GeodesicSolver, line_scale_factor, mean_radius_sq
from engine.geodesy.tmgrid import TMGrid, _clenshaw, _clenshaw_sum
from engine.io.datumfile import read_datum_file
from engine.io.deccafile import read_chain_file
from engine.io.outlog import _NEEDS_QUOTES, format_value
from engine.lsq.confidence import eigenvalues_2x2, error_ellipse
from engine.lsq.snooping import _worst
from engine.systems.base import Point
from engine.systems.decca import (
    ChainOnGrid,
    DeccaObservations,
    DeccaReading,
    LaneSource,
    _LaneAt,
    _wrap_half,
    decca_geometry,
    decca_vcv_lanes,
    decca_vcv_m2,
    lane_sigma,
    place_chain,
    sigma_path_a,
    sigma_path_b,
    track_lane,
)
from tests.native.test_decca import directions
from tests.paths import DATA
from tests.tolerance import Near

ED50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
GRID = TMGrid(ED50.ellipsoid, 5.0)
GEOD = GeodesicSolver(ED50.ellipsoid)


# --------------------------------------------------------------------------- .OUT values


@pytest.mark.parametrize(("value", "text"), [
    (0.1, "0.1"),
    (np.float64(0.1), "0.1"),  # a numpy float writes like a Python float, not "np.float64(…)"
    (-0.0, "-0.0"),
    (math.nan, "nan"),
    (np.float64(math.nan), "nan"),
    (-math.inf, "-inf"),
    (7, "7"),
    (np.int64(-7), "-7"),
    (True, "1"),
    (False, "0"),
    (None, "-"),
    ("ED50", "ED50"),
    ("", '""'),
    ("-", '"-"'),
    ("a b", '"a b"'),
    ("1e5", '"1e5"'),  # a bare word that reads back as a number is quoted
    ("\u0661\u0662", '"\u0661\u0662"'),  # Arabic-Indic digits: float() reads them
    ("x\u2003y", '"x\u2003y"'),  # an em space is a blank (str.isspace)
    ('say "hi"', '"say \\"hi\\""'),
])
def test_format_value_by_type(value: object, text: str) -> None:
    assert format_value(value) == text  # type: ignore[arg-type]


@given(st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=20))
def test_quoting_pattern_is_the_isspace_rule(text: str) -> None:
    """The compiled pattern flags exactly the words the plain rule flags: a character with
    ``str.isspace()``, a quote, ``=`` or a backslash."""
    plain = any(c.isspace() or c in '"=\\' for c in text)
    assert (_NEEDS_QUOTES(text) is not None) is plain


# --------------------------------------------------------------------------- linear algebra


@settings(deadline=None)
@given(st.floats(0.0, 1e8), st.floats(-1e8, 1e8), st.floats(0.0, 1e8))
def test_eigenvalues_2x2_match_eigvalsh(sxx: float, sxy: float, syy: float) -> None:
    """Closed form against LAPACK's symmetric eigensolver; 1e-9 of the largest magnitude
    (the closed form loses relative accuracy in λ2 when λ2 ≪ λ1, both are backward stable)."""
    l1, l2 = eigenvalues_2x2(sxx, sxy, syy)
    lam = np.linalg.eigvalsh(np.array([[sxx, sxy], [sxy, syy]]))
    scale = max(abs(sxx), abs(sxy), abs(syy), 1e-300)
    assert l1 == pytest.approx(lam[1], abs=1e-9 * scale)
    assert l2 == pytest.approx(lam[0], abs=1e-9 * scale)
    assert l1 >= l2


def test_isotropic_ellipse_points_east() -> None:
    e = error_ellipse(np.eye(2) * 4.0)
    assert (e.a_m, e.b_m, e.az_deg, e.phi_deg) == (2.0, 2.0, 90.0, 0.0)


# --------------------------------------------------------------------------- w-test helpers


def _fake(w: list[float]) -> SimpleNamespace:
    return SimpleNamespace(w=np.array(w))


@pytest.mark.parametrize("w", [
    [math.nan, 1.0, -3.0, 3.0, math.nan],
    [0.5, -0.5, 0.5],
    [math.nan, math.nan],
    [2.0, math.nan, -2.5, 2.5, 0.1],
])
def test_worst_is_the_first_largest_abs_w_ignoring_nan(w: list[float]) -> None:
    """Reference: the former numpy form, NaN replaced by −1 and the first argmax taken."""
    aw = np.abs(np.array(w))
    aw[np.isnan(aw)] = -1.0
    k = int(aw.argmax())
    slot, value = _worst(_fake(w))  # type: ignore[arg-type]
    assert slot == k
    assert value == w[k] or (math.isnan(value) and math.isnan(w[k]))


# --------------------------------------------------------------------------- TM grid


@given(st.floats(-1.0, 1.0), st.floats(-0.05, 0.05))
def test_clenshaw_sum_equals_the_general_sum(xi: float, eta: float) -> None:
    """The sum without its derivative is the same recurrence: equal to the last bit."""
    z = complex(xi, eta)
    s2, c2 = cmath.sin(2.0 * z), cmath.cos(2.0 * z)
    assert _clenshaw_sum(GRID._alpha, s2, c2) == _clenshaw(GRID._alpha, s2, c2)[0]
    assert _clenshaw_sum(GRID._beta, s2, c2) == _clenshaw(GRID._beta, s2, c2)[0]


@given(st.floats(50.0, 56.0), st.floats(2.0, 8.0))
def test_forward_equals_forward_full(lat: float, lon: float) -> None:
    """The position-only forward and the one with convergence and scale agree exactly, and the
    inverse (with the inlined conformal-latitude Newton) returns the point to 1e-9°
    (≈ 0.1 mm; the series and the Newton stop are accurate to nanometres near the CM)."""
    x, y = GRID.forward(lat, lon)
    assert (x, y) == GRID.forward_full(lat, lon)[:2]
    la, lo = GRID.inverse(x, y)
    assert la == pytest.approx(lat, abs=1e-9) and lo == pytest.approx(lon, abs=1e-9)


# --------------------------------------------------------------------------- Decca geometry


def _placed() -> object:
    return place_chain(read_chain_file(DATA / "DECCA.CHN")["9B"], GRID)


def test_decca_geometry_with_a_known_position_is_the_same() -> None:
    """Passing the point's (lat, lon) skips one grid inversion and changes nothing."""
    placed = _placed()
    for x, y in ((-31615.4, 5857300.2), (-40000.0, 5870000.0), (10000.0, 5830000.0)):
        a = decca_geometry(placed, x, y, GEOD)  # type: ignore[arg-type]
        b = decca_geometry(placed, x, y, GEOD, GRID.inverse(x, y))  # type: ignore[arg-type]
        for name in a.__slots__:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


def test_decca_vcv_in_metres_is_lanes_times_k_k() -> None:
    """C_ij(m²) = C_ij(lanes²)·k_i·k_j (A4.4), the numpy outer product as reference."""
    geom = decca_geometry(_placed(), -31615.4, 5857300.2, GEOD)  # type: ignore[arg-type]
    k = geom.metres_per_lane
    np.testing.assert_array_equal(decca_vcv_m2(geom, 64.0),
                                  decca_vcv_lanes(geom, 64.0) * np.outer(k, k))


# --------------------------------------------------------------------------- filter


def test_ls_statistics_are_computed_once_and_read_only() -> None:
    p = kf.FilterParams()
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 0.5, 0.0, 0.0, 0.0, p)
    r = kf.update(s, kf.sensor_measurement(s, log_ms=6.5, gyro_grid_rad=0.52, params=p), p)
    t = r.ls.t
    assert t is r.ls.t and not t.flags.writeable
    S_inv = np.linalg.inv(r.S)
    np.testing.assert_allclose(t, S_inv @ r.innovation / np.sqrt(np.diag(S_inv)), rtol=1e-12)


def test_stacked_priors_of_two_parts_are_block_diagonal() -> None:
    """Fix-error keys from two blocks: each keeps its own prior, no covariance between them."""
    a = kf.lop_measurement(np.array([[1.0, 0.0]]), np.array([0.0]), np.zeros(2),
                           np.array([[4.0]]), fix_keys=("b1",), bias_cov=np.array([[9.0]]),
                           bias_tau_s=(100.0,))
    b = kf.lse_measurement(1.0, 2.0, np.array([[100.0, 20.0], [20.0, 50.0]]),
                           kf.FilterParams(coloured=True))
    m = kf.stack_measurements(a, b)
    assert m.bias_keys == ("b1", "fix_e", "fix_n")
    expected = np.zeros((3, 3))
    expected[0, 0] = 9.0
    expected[1:, 1:] = b.bias_cov
    np.testing.assert_array_equal(m.bias_cov, expected)
    assert m.bias_tau_s == (100.0, 240.0, 240.0)


# --------------------------------------------------------------------------- issue 14: Decca


_PYPROJ_GEOD = Geod(a=ED50.ellipsoid.a_m, f=ED50.ellipsoid.f)


def _reference_geometry(placed: ChainOnGrid, x_m: float, y_m: float) -> dict[str, object]:
    """decca_geometry as the engine computed it before issue 14 (9578da6), written plainly: the
    grid inverted here, ``mean_radius_sq``/``line_scale_factor`` per station, one
    ``Geod.inv`` per station, LEF and k per pattern, the VCV of A4.1–A4.4 by its loops."""
    lat0, lon0 = placed.grid.inverse(x_m, y_m)
    ell = placed.grid.ellipsoid
    xy = placed.station_xy_m.tolist()
    ll = placed.station_latlon_deg.tolist()
    dist, dxp, dyp, az = [], [], [], []
    for (xs, ys), (slat, slon) in zip(xy, ll, strict=True):
        rm2 = mean_radius_sq(ell, lat0, slat)
        chord = math.hypot(x_m - xs, y_m - ys)
        lsf = line_scale_factor(x_m, xs, rm2)
        dist.append(chord / lsf)
        dxp.append((x_m - xs) / (lsf * chord) - chord * (2.0 * x_m + xs) / (lsf * lsf * 6.0 * rm2))
        dyp.append((y_m - ys) / (lsf * chord))
        az.append(math.radians(float(_PYPROJ_GEOD.inv(lon0, lat0, slon, slat)[0]) % 360.0))
    lam = placed.wavelength_m.tolist()
    base = placed.baseline_m.tolist()
    kmin = placed.min_lanes.tolist()
    two_pi = 2.0 * math.pi
    n_calc, row, lef, lop, k = [], [], [], [], []
    for j in range(3):
        s = j + 1
        n_calc.append((dist[0] - dist[s] + base[j]) / lam[j] + kmin[j])
        row.append([(dxp[0] - dxp[s]) / lam[j], (dyp[0] - dyp[s]) / lam[j]])
        gamma = abs(az[s] - az[0]) % two_pi
        if gamma > math.pi:
            gamma = two_pi - gamma
        lef.append(1.0 / math.sin(gamma / 2.0))
        k.append(lam[j] * lef[j] / 2.0)
        gx = -math.sin(az[0]) + math.sin(az[s])
        gy = -math.cos(az[0]) + math.cos(az[s])
        lop.append((math.atan2(gx, gy) + math.pi / 2.0) % two_pi)
    return {"d_master_m": dist[0], "az_master_rad": az[0] % two_pi, "d_slave_m": dist[1:],
            "az_slave_rad": [a % two_pi for a in az[1:]], "baseline_m": base, "lef": lef,
            "metres_per_lane": k, "lop_azimuth_rad": lop, "n_calc": n_calc, "row": row}


def _reference_vcv_m2(g: dict[str, object], cf: float) -> list[list[float]]:
    """A4.1–A4.4 (m²) as before issue 14, from a reference geometry."""
    h = 1e-5
    s_n2 = sigma_path_a(g["d_master_m"] * h) ** 2  # type: ignore[operator]
    d_s, base, k = g["d_slave_m"], g["baseline_m"], g["metres_per_lane"]
    s_x = (sigma_path_a(d_s[0] * h), sigma_path_a(d_s[1] * h),  # type: ignore[index]
           sigma_path_b(d_s[2] * h))  # type: ignore[index]
    mm, ms = (4, 3, 5), (3, 2, 6)
    c = [[mm[i] * mm[j] * s_n2 / cf for j in range(3)] for i in range(3)]
    for i in range(3):
        sky = (mm[i] ** 2 * (s_n2 + sigma_path_a(base[i] * h) ** 2)  # type: ignore[index]
               + ms[i] ** 2 * s_x[i] ** 2)
        c[i][i] = sky / cf + (0.012, 0.009, 0.015)[i] ** 2
    return [[c[i][j] * (k[i] * k[j]) for j in range(3)] for i in range(3)]  # type: ignore[index]


_PLACED = place_chain(read_chain_file(DATA / "DECCA.CHN")["9B"], GRID)
_SHIP = st.tuples(st.floats(-150_000.0, 300_000.0), st.floats(5_700_000.0, 6_200_000.0))


@settings(deadline=None, max_examples=300)
@given(_SHIP, st.sampled_from([64.0, 4.0, 1.0, 1 / 2.25]))
def test_decca_geometry_and_linearise_are_the_pre_issue_14_numbers(
        ship: tuple[float, float], cf: float) -> None:
    """The lane model with per-placement constants, pyproj's scalar inverse and the rows
    formed without the Pg 810 arrays give the former routine's numbers to the last bit: the
    geometry, decca_vcv_m2, and the rows, misclosures and VCV block of linearise."""
    x, y = ship
    ref = _reference_geometry(_PLACED, x, y)
    geom = decca_geometry(_PLACED, x, y, GEOD)
    # The compiled path: to the tolerance contract, widened near a baseline extension, where
    # the LEF ~ 1/Δaz magnifies an azimuth's last bit (relative error ~ LEF · 1e-15).
    rtol = max(1e-9, 1e-14 * float(np.max(np.abs(ref["lef"]))))
    for name, want in ref.items():
        assert Near(np.asarray(getattr(geom, name)), rtol=rtol) == Near(
            np.asarray(want, float)), name
    vcv = _reference_vcv_m2(ref, cf)
    assert Near(decca_vcv_m2(geom, cf), rtol=rtol) == Near(np.array(vcv))
    reading = DeccaReading(_PLACED, (0.1, 0.2, 0.3), (None, None, None), (True, True, True),
                           cf=cf, totals=(44.1, 274.2, 1.3))
    observed = [44.1, math.nan, 1.3]
    obs = DeccaObservations(reading, observed, [44.1, None, 1.3], [True, False, True], [])
    A, b, Cl = [9.0] * 10, [9.0] * 5, np.eye(5)
    obs.linearise(Point(GRID, GEOD, x, y), 2, A, b, Cl)
    k, row, n_calc = ref["metres_per_lane"], ref["row"], ref["n_calc"]
    for j in (0, 2):  # Green has no reading: its row stays as it was
        i = 2 + j
        assert Near((A[2 * i], A[2 * i + 1]), rtol=rtol) == Near(
            (row[j][0] * k[j], row[j][1] * k[j]))  # type: ignore[index]
        assert Near(b[i], rtol=rtol) == Near((observed[j] - n_calc[j]) * k[j])  # type: ignore[index]
    assert A[6:8] == [9.0, 9.0] and b[3] == 9.0
    assert Near(Cl[2:, 2:], rtol=rtol) == Near(np.array(vcv))


def test_a_vcv_put_in_decca_vcv_m2_s_place_is_the_fix_s(monkeypatch: pytest.MonkeyPatch) -> None:
    """linearise computes the model VCV itself, but a function put in ``decca_vcv_m2``'s place
    (the printed VCV of Pg 615/821) is what the fix then takes, called with the geometry."""
    import engine.systems.decca as decca_mod

    seen = []

    def printed(geom: object, cf: float) -> np.ndarray:
        seen.append(geom)
        return np.full((3, 3), 7.0)

    monkeypatch.setattr(decca_mod, "decca_vcv_m2", printed)
    reading = DeccaReading(_PLACED, (0.1, 0.2, 0.3), (None, None, None), (True, True, True),
                           totals=(44.1, 274.2, 1.3))
    obs = DeccaObservations(reading, [44.1, 274.2, 1.3], [44.1, 274.2, 1.3], [True] * 3, [])
    Cl = np.eye(5)
    obs.linearise(Point(GRID, GEOD, -31615.4, 5857300.2), 2, [0.0] * 10, [0.0] * 5, Cl)
    assert np.array_equal(Cl[2:, 2:], np.full((3, 3), 7.0))
    want = decca_geometry(_PLACED, -31615.4, 5857300.2, GEOD)
    assert np.array_equal(seen[0].n_calc, want.n_calc)  # type: ignore[attr-defined]


@settings(deadline=None, max_examples=200)
@given(_SHIP, st.floats(1.0, 1e7), st.floats(-0.9, 0.9))
def test_lane_check_numbers_are_the_geometry_s(ship: tuple[float, float], var: float,
                                                rho: float) -> None:
    """The GPS lane check's (N_calc, σ along the gradient) without the full geometry: equal to
    those of the pre-issue-14 geometry (``lane_sigma`` of its gradient row)."""
    x, y = ship
    ref = _reference_geometry(_PLACED, x, y)
    cov = np.array([[var, rho * var], [rho * var, 2.0 * var]])
    at = _LaneAt(_PLACED, GEOD)
    src = LaneSource("GPS", x, y, cov)
    for i in range(3):
        n, sigma = at(src, i)  # type: ignore[misc]
        assert n == ref["n_calc"][i]  # type: ignore[index]
        assert sigma == lane_sigma(np.array(ref["row"][i]), cov)  # type: ignore[index]


@given(st.floats(-1e4, 1e4), st.floats(0.0, 1.0, exclude_max=True))
def test_track_lane_is_the_wrapped_difference(previous: float, fraction: float) -> None:
    """track_lane with _wrap_half written out: the same number as through _wrap_half."""
    want = previous + _wrap_half(fraction - (previous - math.floor(previous)))
    assert track_lane(previous, fraction) == want


def test_lane_check_refuses_where_the_geometry_raised() -> None:
    """At a station the gradient divides by a zero chord: no lane, as before."""
    xs, ys = _PLACED.station_xy_m[1].tolist()
    with pytest.raises(ZeroDivisionError):
        _reference_geometry(_PLACED, xs, ys)
    assert _LaneAt(_PLACED, GEOD)(LaneSource("GPS", xs, ys, np.eye(2)), 0) is None


# --------------------------------------------------------------------------- issue 14: geodesy


@settings(deadline=None)
@given(st.floats(-89.0, 89.0), st.floats(-180.0, 180.0), st.floats(-89.0, 89.0),
       st.floats(-180.0, 180.0))
def test_scalar_geodesic_path_is_geod_inv(lat1: float, lon1: float, lat2: float,
                                          lon2: float) -> None:
    """azimuth_distance and forward_azimuths_deg equal Geod.inv's azimuth (in [0, 360)) and
    distance exactly."""
    az12, _az21, dist = _PYPROJ_GEOD.inv(lon1, lat1, lon2, lat2)
    want = (float(az12) % 360.0, float(dist))
    assert GEOD.azimuth_distance(lat1, lon1, lat2, lon2) == want
    assert GEOD.azimuth_distance(np.float64(lat1), lon1, lat2, lon2) == want
    # the compiled geodesic where built: the same directions to the tolerance contract
    assert directions(GEOD.forward_azimuths_deg(lat1, lon1, [(lat2, lon2), (lat2, lon2)])) == \
        directions([want[0]] * 2)
    assert directions(GEOD.forward_azimuths_rad(lat1, lon1, [(lat2, lon2)]), 180 / math.pi) == \
        directions([math.radians(want[0])], 180 / math.pi)


@settings(deadline=None)
@given(st.lists(st.tuples(st.floats(-400_000.0, 400_000.0), st.floats(-9e6, 9e6)),
                min_size=1, max_size=30))
def test_grid_inverse_memo_returns_the_computed_inverse(points: list[tuple[float, float]]) -> None:
    """The remembered inverses are the computed ones, through evictions and repeats."""
    grid = TMGrid(ED50.ellipsoid, 5.0)
    for x, y in points + points[::-1] + points:
        assert grid.inverse(x, y) == grid._inverse(x, y)
    assert len(grid._inverted) <= 8


def _inverse_plain(grid: TMGrid, x_m: float, y_m: float) -> tuple[float, float]:
    """The grid inverse as before issue 14: through _clenshaw_sum, _tau_from_taup and
    wrap_180_deg."""
    z = complex(y_m / grid._A, x_m / grid._A)
    zp = z - _clenshaw_sum(grid._beta, cmath.sin(2.0 * z), cmath.cos(2.0 * z))
    sxi, cxi, she = math.sin(zp.real), math.cos(zp.real), math.sinh(zp.imag)
    r = math.hypot(she, cxi)
    lon = wrap_180_deg(grid.cm_deg + math.degrees(math.atan2(she, cxi)))
    if r == 0.0:
        return math.copysign(90.0, sxi), lon
    return math.degrees(math.atan(grid._tau_from_taup(sxi / r))), lon


@settings(deadline=None, max_examples=300)
@given(st.floats(-600_000.0, 600_000.0), st.floats(-9.9e6, 9.9e6),
       st.sampled_from([-179.0, -3.0, 0.0, 5.0, 180.0]))
def test_inlined_grid_inverse_is_the_composed_one(x: float, y: float, cm: float) -> None:
    """The inverse with its Clenshaw sum, Newton and wrap written out equals the composition
    of those routines exactly (zeros and signs included; both hemispheres, the antimeridian)."""
    grid = TMGrid(ED50.ellipsoid, cm)
    got, want = grid._inverse(x, y), _inverse_plain(grid, x, y)
    assert got == want
    assert [math.copysign(1.0, v) for v in got] == [math.copysign(1.0, v) for v in want]


@settings(deadline=None, max_examples=300)
@given(st.floats(-89.0, 89.0), st.floats(-180.0, 180.0),
       st.sampled_from([-179.0, -3.0, 0.0, 5.0, 180.0]))
def test_inlined_grid_forward_is_forward_full(lat: float, dlon: float, cm: float) -> None:
    """The forward with its wrap, τ' and Clenshaw sum written out equals forward_full's
    position (which goes through wrap_180_deg, _taup and _clenshaw) exactly, to 30° off the
    CM (the series' range) and across the antimeridian."""
    grid = TMGrid(ED50.ellipsoid, cm)
    lon = wrap_180_deg(cm + dlon / 6.0)
    assert grid.forward(lat, lon) == grid.forward_full(lat, lon)[:2]


def test_grid_inverse_memo_keeps_the_sign_of_zero() -> None:
    """0.0 and −0.0 are one dict key, but a zero northing's sign reaches the latitude."""
    grid = TMGrid(ED50.ellipsoid, 5.0)
    for first, second in ((0.0, -0.0), (-0.0, 0.0)):
        grid.inverse(-1000.0, first)
        lat, _lon = grid.inverse(-1000.0, second)
        assert math.copysign(1.0, lat) == math.copysign(1.0, second)  # west of the CM: the sign
    assert grid == TMGrid(ED50.ellipsoid, 5.0)  # the memo is not part of the value
