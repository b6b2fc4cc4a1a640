"""Observation models of the fix beyond the worked example: bearings, distances, the filter's
pseudo-LOPs, rejection policies and the robust estimator, on noise-free synthetic geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.geodesy.ellipsoidal import GeodesicSolver, line_scale_factor, mean_radius_sq
from engine.geodesy.tmgrid import TMGrid
from engine.io.datumfile import read_datum_file
from engine.io.deccafile import read_chain_file
from engine.lsq.fix import (
    DeccaReading,
    GpsFix,
    LsqSettings,
    ManualObservation,
    PositionPrior,
    compute_fix,
    lop_name,
)
from engine.systems.decca import decca_geometry, place_chain
from tests.paths import DATA

ED50 = read_datum_file(DATA / "TO_WGS84.DAT").datum("ED50")
GRID = TMGrid(ED50.ellipsoid, 5.0)
GEOD = GeodesicSolver(ED50.ellipsoid)
TRUTH = (52.80, 4.70)
STATIONS = {"Den Helder": (52.9600, 4.7450), "Texel": (53.1800, 4.8500),
            "Egmond": (52.6200, 4.6200), "IJmuiden": (52.4640, 4.5560)}


def _exact(kind: str, name: str, sigma: float, sensor: str = "") -> ManualObservation:
    lat, lon = STATIONS[name]
    if kind == "bearing":
        value, _ = GEOD.azimuth_distance(*TRUTH, lat, lon)
    else:
        # The model compares with the spheroidal distance grid chord / L (A5.10, THEORY §4.5).
        x0, y0 = GRID.forward(*TRUTH)
        xs, ys = GRID.forward(lat, lon)
        value = math.hypot(x0 - xs, y0 - ys) / line_scale_factor(
            x0, xs, mean_radius_sq(ED50.ellipsoid, TRUTH[0], lat))
    return ManualObservation(kind, name, lat, lon, value, sigma, sensor)


def test_bearings_and_distances_recover_the_truth() -> None:
    obs = [_exact("bearing", "Den Helder", 0.8, "compass repeater"),
           _exact("bearing", "Egmond", 0.7, "periscope"),
           _exact("distance", "Texel", 105.0, "radar"),
           _exact("bearing", "Texel", 0.85, "radar"),
           _exact("distance", "IJmuiden", 105.0, "radar")]
    start = GRID.forward(TRUTH[0] + 0.02, TRUTH[1] - 0.03)  # ~3 km off
    f = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="N"))
    tx, ty = GRID.forward(*TRUTH)
    assert f.ok and f.n_used == 5 and f.category == "IV"
    # Noise-free: the LSE is the truth to the iteration's break-off (ε = 1 m → a few mm left).
    assert math.hypot(f.x_m - tx, f.y_m - ty) < 0.01
    assert all(abs(r.v_m) < 0.01 for r in f.lops)
    # A bearing's LOP runs along the bearing line: its (grid) azimuth is the true bearing minus
    # the grid convergence γ at the ship, mod 180°.
    gamma = GRID.convergence_deg(*TRUTH)
    for r in (r for r in f.lops if r.pattern == "Brg"):
        diff = (r.az_deg - (r.read - gamma)) % 180.0
        assert min(diff, 180.0 - diff) < 0.01
    # σ⊥ of a bearing = σ·π/180·d (eq. 4.16): the a priori variance in C_l.
    adj = f.tested.adjustment
    d = math.hypot(tx - GRID.forward(*STATIONS["Den Helder"])[0],
                   ty - GRID.forward(*STATIONS["Den Helder"])[1])
    assert adj.Cl[5, 5] == pytest.approx((math.radians(0.8) * d) ** 2, rel=1e-3)
    assert adj.Cl[7, 7] == pytest.approx(105.0**2)


def test_blunder_policies_on_a_bearing() -> None:
    obs = [_exact("bearing", n, 0.8) for n in STATIONS] + [_exact("distance", "Texel", 105.0)]
    bad = obs[1]
    obs[1] = ManualObservation(bad.kind, bad.station, bad.lat_deg, bad.lon_deg, bad.value + 3.0,
                               bad.sigma)  # 3° ≈ 4σ blunder on Texel
    start = GRID.forward(*TRUTH)
    y = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="Y"))
    assert y.rejected_slots == (6,)
    tx, ty = GRID.forward(*TRUTH)
    assert math.hypot(y.x_m - tx, y.y_m - ty) < 0.05  # the rest is exact
    a = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="A"))
    assert a.candidate_slot == 6 and a.rejected_slots == ()
    again = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="A"),
                        excluded_slots=(6,))
    assert again.candidate_slot is None
    # Same LOPs, different iteration paths: equal to the break-off's leftovers (< 1 mm).
    assert (again.x_m, again.y_m) == pytest.approx((y.x_m, y.y_m), abs=1e-3)
    n = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="N"))
    assert n.rejected_slots == () and [r.verdict for r in n.lops if r.slot == 6] == ["reject"]


def test_robust_estimator_downweights_the_blunder() -> None:
    obs = [_exact("bearing", n, 0.8) for n in STATIONS] + [
        _exact("distance", n, 105.0) for n in STATIONS]
    bad = obs[1]
    obs[1] = ManualObservation(bad.kind, bad.station, bad.lat_deg, bad.lon_deg, bad.value + 3.0,
                               bad.sigma)
    start = GRID.forward(*TRUTH)
    tx, ty = GRID.forward(*TRUTH)
    plain = compute_fix(GRID, GEOD, start, manual=obs[:5] + obs[5:],
                        settings=LsqSettings(lop_reject="N"))
    huber = compute_fix(GRID, GEOD, start, manual=obs,
                        settings=LsqSettings(lop_reject="N", estimator="huber"))
    e_plain = math.hypot(plain.x_m - tx, plain.y_m - ty)
    e_huber = math.hypot(huber.x_m - tx, huber.y_m - ty)
    # MAX_BRR = 5 manual observations per cycle, so only the first five are used.
    assert plain.n_used == 5
    assert e_huber < 0.5 * e_plain


def test_too_few_lops_use_the_filter_prediction() -> None:
    """Table 5.1 category I: one Decca LOP plus the filter's two position LOPs (THEORY §4.6)."""
    chain = read_chain_file(DATA / "DECCA.CHN")["9B"]
    placed = place_chain(chain, GRID)
    tx, ty = GRID.forward(*TRUTH)
    n_true = decca_geometry(placed, tx, ty, GEOD).n_calc
    frac = tuple(float(n % 1.0) for n in n_true)
    reading = DeccaReading(placed, (frac[0], None, None), ((0, 0), None, None),
                           (True, False, False), totals=(float(n_true[0]), None, None))
    prior = PositionPrior(tx + 300.0, ty - 200.0, np.diag([200.0**2, 200.0**2]))
    f = compute_fix(GRID, GEOD, (prior.x_m, prior.y_m), decca=reading, prior=prior)
    assert f.ok and f.uses_prior and f.n_used == 3
    # The hybrid LS is the Kalman position update in information form (THEORY §9.3):
    # x = x_prior + P aᵀ (a P aᵀ + r)⁻¹ (O − C), with the LOP linearised at the prior.  The LS
    # re-linearises while iterating and stops when the step is below ε = 1 m (A8.2 epsilon), so
    # the two agree to that break-off (measured 0.51 m here).
    raw = f.raw_lops
    P = prior.cov
    a, omc, r = raw.A, raw.omc_m, raw.Cl
    gain = P @ a.T @ np.linalg.inv(a @ P @ a.T + r)
    expected = np.array([prior.x_m, prior.y_m]) + gain @ omc
    assert (f.x_m, f.y_m) == pytest.approx(tuple(expected), abs=1.0)
    red = next(r for r in f.lops if r.pattern == "Red")
    assert red.used and abs(red.v_m) > 1.0  # the prior keeps it from sitting on the LOP
    # The raw LOP (not the hybrid LSE) is kept for the filter update (THEORY D20).
    assert f.raw_lops is not None and f.raw_lops.slots == (2,)


def test_gps_only_and_no_lops() -> None:
    tx, ty = GRID.forward(*TRUTH)
    gps = GpsFix(TRUTH[0], TRUTH[1], tx, ty, 2500.0, corr_north_m=5.0, corr_east_m=-3.0)
    f = compute_fix(GRID, GEOD, (tx + 100, ty), gps=gps)
    # Two LOPs, redundancy 0 (category II): the fix is the corrected GPS position, no tests.
    assert f.category == "II" and (f.x_m, f.y_m) == pytest.approx((tx - 3.0, ty + 5.0), abs=1e-6)
    assert all(math.isnan(r.w) for r in f.lops)
    none = compute_fix(GRID, GEOD, (tx, ty))
    assert not none.ok and "Not enough LOPs" in none.reason


# ------------------------------------------------------------------------------------------
# Degenerate geometry at compute_fix level (no fix, with the reason) and legitimate geometry


def _bearing_to(lat: float, lon: float, sigma: float = 0.8) -> ManualObservation:
    value, _ = GEOD.azimuth_distance(*TRUTH, lat, lon)
    return ManualObservation("bearing", f"{lat:.3f}/{lon:.3f}", lat, lon, value, sigma)


def _radar(lat: float, lon: float) -> list[ManualObservation]:
    az, dist = GEOD.azimuth_distance(*TRUTH, lat, lon)
    # the model compares the range with the spheroidal distance grid chord / L (≈ geodesic to
    # well under the 105 m σ here)
    return [ManualObservation("bearing", "obj", lat, lon, az, 0.85, "radar"),
            ManualObservation("distance", "obj", lat, lon, dist, 105.0, "radar")]


START = GRID.forward(TRUTH[0] + 0.005, TRUTH[1] + 0.005)  # ~650 m off


def _around(az_deg: float, km: float) -> tuple[float, float]:
    """A point ≈ ``km`` from TRUTH at azimuth ``az_deg`` (spherical approximation: exactness
    does not matter, the observations are computed from the point actually used)."""
    a = math.radians(az_deg)
    return (TRUTH[0] + km / 111.2 * math.cos(a),
            TRUTH[1] + km / (111.2 * math.cos(math.radians(TRUTH[0]))) * math.sin(a))


@pytest.mark.parametrize("lats", [(53.0, 53.2, 53.4), (53.0, 53.2)])
def test_bearings_along_one_meridian_give_no_fix(lats: tuple[float, ...]) -> None:
    """Stations due north on the ship's own meridian: the bearing lines coincide. Before this
    check the 3-bearing case returned ok, category III, a = 77 000 km (cond(N) 8.5e10). Now
    the horizontal axis ratio a/b (2.9e5 and 4.6e5 measured) exceeds MAX_AXIS_RATIO."""
    f = compute_fix(GRID, GEOD, START, manual=[_bearing_to(la, TRUTH[1]) for la in lats],
                    settings=LsqSettings(lop_reject="N"))
    assert not f.ok and f.ellipse is None and math.isnan(f.rms_m)
    assert f.reason is not None and "nearly parallel" in f.reason


def test_nearly_parallel_bearings_beyond_the_linear_range_give_no_fix() -> None:
    """Two bearings 22 and 44 km away crossing at 0.09°: a/b = 1.7e3 passes the core's ratio
    test, but the standard semi-major axis (461 km measured) reaches far past the stations, where
    a bearing LOP ends: refused by compute_fix's linearisation check."""
    obs = [_bearing_to(53.0, TRUTH[1]), _bearing_to(53.2, TRUTH[1] + 0.001)]
    f = compute_fix(GRID, GEOD, START, manual=obs, settings=LsqSettings(lop_reject="N"))
    assert not f.ok and f.reason is not None
    assert "reaches the nearest station" in f.reason and "461 km" in f.reason


def test_legitimate_weak_geometry_still_gives_a_fix() -> None:
    """Poor but genuine geometry stays a fix (standard a, a/b measured with this geometry):
    radar bearing + range to an object 90 km away (a 1336 m, a/b 12.7); bearings to objects at
    1 km and 50 km at right angles (610 m, 50); two bearings at 20 km crossing at 5°
    (4.5 km, 23); Decca Green + Purple on a winter night (CF 1/2.25) west of the 9B chain
    (51.6 km, 126, nearest station 84 km)."""
    tx, ty = GRID.forward(*TRUTH)
    radar = compute_fix(GRID, GEOD, START, manual=_radar(TRUTH[0] + 90 / 111.2, TRUTH[1]))
    assert radar.ok and radar.ellipse.a_m == pytest.approx(1336, rel=0.01)
    near_far = compute_fix(GRID, GEOD, START,
                           manual=[_bearing_to(TRUTH[0] + 0.009, TRUTH[1], 0.7),
                                   _bearing_to(TRUTH[0], TRUTH[1] + 0.74, 0.7)])
    assert near_far.ok
    assert near_far.ellipse.a_m / near_far.ellipse.b_m == pytest.approx(50, rel=0.02)
    crossing = compute_fix(GRID, GEOD, START,
                           manual=[_bearing_to(*_around(a, 20.0)) for a in (0.0, 5.0)])
    assert crossing.ok and crossing.ellipse.a_m == pytest.approx(4538, rel=0.01)
    for f in (radar, near_far, crossing):  # noise-free: each is the truth
        assert math.hypot(f.x_m - tx, f.y_m - ty) < 0.01
    placed = place_chain(read_chain_file(DATA / "DECCA.CHN")["9B"], GRID)
    west = GRID.forward(52.5, 3.5)
    n = decca_geometry(placed, *west, GEOD).n_calc
    reading = DeccaReading(placed, tuple(float(v % 1.0) for v in n), (None, None, None),
                           (False, True, True), cf=1 / 2.25, totals=tuple(float(v) for v in n))
    decca = compute_fix(GRID, GEOD, west, decca=reading)
    assert decca.ok and decca.category == "II"
    assert decca.ellipse.a_m == pytest.approx(51640, rel=0.01)


@pytest.mark.parametrize("start", [(1e30, 1e30), (math.nan, 5.8e6), (-3e7, 9e7)])
def test_absurd_start_points_give_no_fix_not_an_exception(start: tuple[float, float]) -> None:
    """A start 1e30 m off (the TM inverse overflows), NaN, or 9e7 m off: before, compute_fix
    raised OverflowError from the zone resolution or from _no_fix; now ok=False with a reason,
    for GPS + Decca with zone/lane entry, for bearings, and for a single LOP."""
    chain = read_chain_file(DATA / "DECCA.CHN")["9B"]
    placed = place_chain(chain, GRID)
    tx, ty = GRID.forward(*TRUTH)
    gps = GpsFix(TRUTH[0], TRUTH[1], tx, ty, 2500.0)
    reading = DeccaReading(placed, (0.862, 0.337, None), ((1, 20), (5, 34), None),
                           (True, True, False))
    cases = [dict(gps=gps, decca=reading),
             dict(manual=[_bearing_to(*STATIONS[n]) for n in STATIONS]),
             dict(manual=[_bearing_to(*STATIONS["Texel"])])]
    for kw in cases:
        f = compute_fix(GRID, GEOD, start, **kw)  # type: ignore[arg-type]
        assert not f.ok and f.reason
        assert f.lops == () and f.ellipse is None


def test_invalid_settings_raise() -> None:
    """max_iter = 0 (not reachable from a run configuration) is a programming error: ValueError
    from the adjustment core instead of the former AssertionError."""
    tx, ty = GRID.forward(*TRUTH)
    gps = GpsFix(TRUTH[0], TRUTH[1], tx, ty, 2500.0)
    with pytest.raises(ValueError, match="max_iter"):
        compute_fix(GRID, GEOD, (tx, ty), gps=gps, settings=LsqSettings(max_iter=0))
    with pytest.raises(ValueError, match="estimator"):
        compute_fix(GRID, GEOD, (tx, ty), gps=gps, settings=LsqSettings(estimator="tukey"))


# ------------------------------------------------------------------------------------------
# The robust estimator honours the settings, replaces rejection, and says when it falls back


def _blundered_obs() -> list[ManualObservation]:
    obs = [_exact("bearing", n, 0.8) for n in ("Den Helder", "Texel", "Egmond")] + [
        _exact("distance", n, 105.0) for n in ("Texel", "IJmuiden")]
    bad = obs[1]
    obs[1] = ManualObservation(bad.kind, bad.station, bad.lat_deg, bad.lon_deg, bad.value + 3.0,
                               bad.sigma)  # ≈ 4σ on the Texel bearing (slot 6)
    return obs


def test_robust_fix_uses_scale_vcv_and_alpha() -> None:
    start = GRID.forward(*TRUTH)
    obs = _blundered_obs()
    f = compute_fix(GRID, GEOD, start, manual=obs,
                    settings=LsqSettings(estimator="huber", scale_vcv=True, reliab_interval=1.0))
    adj = f.tested.adjustment
    assert f.ok and adj.damping is not None and adj.scaled and adj.s2 is not None
    # the fix's VCV is the scaled one of the damped model: C = S²·(AᵀW'A)⁻¹ (THEORY §6.4)
    np.testing.assert_allclose(f.cov, adj.cov_x_apriori * adj.s2, rtol=1e-12)
    np.testing.assert_allclose(f.ellipse.eigenvalues, np.linalg.eigvalsh(f.cov)[::-1],
                               rtol=1e-9)
    # α = 1 %: the unit-variance bounds are χ²_r quantiles 0.005/0.995 over r = 3 (tables:
    # 0.0717/3 and 12.838/3)
    vt = f.tested.variance_test
    assert vt is not None and vt.dof == 3
    assert (vt.lower, vt.upper) == pytest.approx((0.0717 / 3, 12.838 / 3), abs=2e-4)
    off = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(estimator="huber"))
    assert not off.tested.adjustment.scaled
    np.testing.assert_allclose(off.cov, off.tested.adjustment.cov_x_apriori)


def test_robust_fix_honours_max_iter_and_s02() -> None:
    start = GRID.forward(TRUTH[0] + 0.03, TRUTH[1] - 0.04)  # ~5 km off: needs > 1 iteration
    obs = _blundered_obs()
    one = compute_fix(GRID, GEOD, start, manual=obs,
                      settings=LsqSettings(estimator="danish", max_iter=1))
    assert not one.ok and one.reason == "no convergence"
    s4 = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(estimator="danish",
                                                                        s02=4.0))
    s1 = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(estimator="danish"))
    v4, v1 = s4.tested.variance_test, s1.tested.variance_test
    assert v4 is not None and v1 is not None
    assert v4.upper == pytest.approx(4.0 * v1.upper, rel=1e-12)  # bounds are σ0²·χ²/r


def test_robust_fix_replaces_rejection_under_policy_a() -> None:
    """Policy A with Huber: the blunder is down-weighted, so no LSQ rejection candidate is
    offered (before, the plain-LSQ candidate was still reported next to the robust fix)."""
    start = GRID.forward(*TRUTH)
    obs = _blundered_obs()
    lsq = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(lop_reject="A"))
    assert lsq.candidate_slot == 6
    rob = compute_fix(GRID, GEOD, start, manual=obs,
                      settings=LsqSettings(lop_reject="A", estimator="huber"))
    assert rob.ok and rob.candidate_slot is None and rob.rejected_slots == ()
    assert rob.tested.robust is not None and rob.tested.robust.ok
    assert int(np.nanargmin(rob.tested.robust.weights)) == 6
    assert any(f"down-weighted LOP {lop_name(6, manual=obs)}" in m for m in rob.messages)
    assert not any("reject ?" in m for m in rob.messages)


def test_robust_failure_falls_back_to_tested_lsq_with_a_message() -> None:
    """Three LOPs (r = 1) with a blunder: every standardised residual is equally large, all
    weights drop and Σ T_ii < u + 1 — the M-estimation fails. The fix is then the plain LSQ
    one, tested as usual (category III: detected, not identifiable), and a message says so."""
    start = GRID.forward(*TRUTH)
    obs = [_bearing_to(*_around(az, 10.0)) for az in (10.0, 130.0, 250.0)]
    bad = obs[0]
    obs[0] = ManualObservation(bad.kind, bad.station, bad.lat_deg, bad.lon_deg, bad.value + 4.0,
                               bad.sigma)
    f = compute_fix(GRID, GEOD, start, manual=obs, settings=LsqSettings(estimator="huber"))
    t = f.tested
    assert f.ok and f.category == "III" and t.robust is not None and not t.robust.ok
    assert t.adjustment.damping is None  # the plain LSQ adjustment
    assert any(m.startswith("robust (huber) not used: too few effective observations")
               for m in f.messages)
    assert t.not_identifiable


def test_decca_half_zone_warning_reaches_the_fix_messages() -> None:
    """Zone/lane entered one zone (24 lanes, ≈ 10 km) off the provisional position's count: the
    10-zone cycle still resolves, but the count is > 12 lanes from N_calc (THEORY D7)."""
    chain = read_chain_file(DATA / "DECCA.CHN")["9B"]
    placed = place_chain(chain, GRID)
    tx, ty = GRID.forward(*TRUTH)
    n = decca_geometry(placed, tx, ty, GEOD).n_calc
    zone, lane = divmod(int(n[0]), 24)
    frac = float(n[0] % 1.0)
    gps = GpsFix(TRUTH[0], TRUTH[1], tx, ty, 2500.0)
    good = DeccaReading(placed, (frac, None, None), ((zone % 10, lane), None, None),
                        (True, False, False))
    f = compute_fix(GRID, GEOD, (tx, ty), gps=gps, decca=good)
    assert not any("half a zone" in m for m in f.messages)
    off = DeccaReading(placed, (frac, None, None), (((zone + 1) % 10, lane), None, None),
                       (True, False, False))
    g = compute_fix(GRID, GEOD, (tx, ty), gps=gps, decca=off)
    assert any(m.startswith("Decca red: zone/lane") and "more than half a zone" in m
               for m in g.messages)
