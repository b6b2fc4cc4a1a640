"""Observation models of the fix beyond the worked example: bearings, distances, the filter's
pseudo-LOPs, rejection policies and the robust estimator, on noise-free synthetic geometry."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from engine.datumfile import read_datum_file
from engine.decca import decca_geometry, place_chain
from engine.deccafile import read_chain_file
from engine.fix import (
    DeccaReading,
    GpsFix,
    LsqSettings,
    ManualObservation,
    PositionPrior,
    compute_fix,
)
from engine.geodesy import GeodesicSolver, line_scale_factor, mean_radius_sq
from engine.tmgrid import TMGrid

DATA = Path(__file__).resolve().parents[1] / "data"
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
        # The model compares with the spheroidal distance grid chord / L (A5.10, lsq.md §4.6).
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
    """Table 5.1 category I: one Decca LOP plus the filter's two position LOPs (lsq.md §4.8)."""
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
    # The hybrid LS is the Kalman position update in information form (kalman.md §10.3):
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
    # The raw LOP (not the hybrid LSE) is kept for the filter update (kalman.md A10).
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
