"""Monte-Carlo consistency of the navigation filter against a known truth (THEORY §11.1–11.2).

Truth and measurements come from tests/navsim_small.py (thesis kinematics integrated with
sub-steps, thesis sensor σ, position fixes at 1 Hz with σ = 40 m per axis, white or first-order
Gauss–Markov with τ = 4 min). The 200 runs of each case are filtered at once by
tests/mc_filter.py, the engine's equations vectorised over the runs; the first test checks it
against engine.filter.kalman / engine.filter.smoother on whole runs, so the statistics are the
engine's.

NEES criterion (Bar-Shalom, Li & Kirubarajan 2001, §5.4.2): at each epoch k the average over N
runs of ε_k = x̃ᵀP⁻¹x̃ is χ²(N·d)/N under consistency (d states), so it lies in the two-sided
95 % band [χ²_{N·d}(0.025), χ²_{N·d}(0.975)]/N with probability 0.95 *at every epoch*. The
expected fraction of epochs inside is therefore 95 %; neighbouring epochs are correlated (the
same runs, a slowly varying error), so the realised fraction scatters more than a binomial one
would — each threshold below states the spread found over seeds. Seeds are fixed, so every
figure is reproducible.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path

import mc_filter as mf
import navsim_small as ns
import numpy as np
import pytest
from scipy.stats import chi2

from engine.filter import kalman as kf
from engine.filter.smoother import rts_smooth
from engine.io.runfile import RunRecord
from engine.run.config import parse_config_text
from engine.run.cycle import build_context, initial_state, step
from engine.run.session import load_data
from engine.systems.sensors import KNOT_MS, depth_to_frequency_hz, surface_reference_hz

SIGMA_FIX = 40.0  # m per axis: an SA-era GPS fix
C_FIX = np.eye(2) * SIGMA_FIX**2
K2_95 = chi2.ppf(0.95, 2)  # 95 % ellipse: d² < 5.991
RUNS = 200
TAU = 240.0  # s, the Gauss–Markov correlation time of the issue (4 min)
FRAC = 0.9  # coloured share of the fix variance (the rest white)
WHITE = kf.FilterParams(p0="physical")
COLOURED = kf.FilterParams(p0="physical", coloured=True, fix_tau_s=TAU, fix_sigma_frac=FRAC)
BALANCED = True  # moment-matched initial deviations (see navsim_small.simulate)


def _start(params: kf.FilterParams) -> kf.FilterState:
    """Initial estimate: 12.6 kn on grid heading 57°, 50 m deep, current (0.2, −0.1) m/s; with
    the coloured model the two fix-error states are there from the start (prior frac·C)."""
    s = kf.init_state(0.0, 0.0, 0.0, 50.0, 6.5, 1.0, 0.0, 0.2, -0.1, params, pos_cov=C_FIX)
    if params.coloured:
        s = kf.add_fix_states(s, ("fix_e", "fix_n"), params.fix_sigma_frac * C_FIX, params)
    return s


def _simulate(params: kf.FilterParams, seed: int, runs: int, epochs: int, turn: float,
              coloured_fixes: bool, balanced: bool = BALANCED) -> ns.SimRun:
    """Truth drawn from N(x̂₀, P₀) of the nav states; fixes white, or GM (τ, frac) + white."""
    s0 = _start(params)
    rng = np.random.default_rng(seed)
    return ns.simulate(rng, runs, epochs, s0.x[:11], s0.P[:11, :11], params,
                       turn_rate_deg_s=turn, fix_sigma_m=SIGMA_FIX,
                       fix_tau_s=TAU if coloured_fixes else None, fix_white_frac=1.0 - FRAC,
                       balanced_start=balanced)


@dataclass(frozen=True)
class McResult:
    """Filtered estimates x (runs, epochs+1, n), P (…, n, n) and, if asked, smoothed x."""

    x: np.ndarray
    P: np.ndarray
    xs: np.ndarray | None


def _sensor_rows(sim: ns.SimRun, k: int) -> np.ndarray:
    return np.stack([sim.depth[:, k], sim.log[:, k], sim.gyro[:, k], sim.incl[:, k]], 1)


def run_filter(params: kf.FilterParams, sim: ns.SimRun, smooth: bool = False) -> McResult:
    """Every run at once, in the textbook order: predict 1 s, then one update with the fix and
    the four sensors of that epoch (kf.nav_measurement's rows); RTS smoothing on request."""
    runs, n_ep = sim.fix.shape[:2]
    b = mf.Batch.from_state(_start(params), runs)
    n = b.x.shape[1]
    H, R0, angle = mf.nav_rows(params, n, fix=True, sensors=True, fix_cov=C_FIX)
    X = np.empty((runs, n_ep, n))
    PP = np.empty((runs, n_ep, n, n))
    pred_x = np.empty((runs, n_ep - 1, n))
    pred_P = np.empty((runs, n_ep - 1, n, n))
    phis = np.empty((runs, n_ep - 1, n, n))
    R = np.repeat(R0[None], runs, 0)
    for k in range(n_ep):
        if k:
            b, phi = mf.predict(b, 1.0, params)
            pred_x[:, k - 1], pred_P[:, k - 1], phis[:, k - 1] = b.x, b.P, phi
        R[:, 3, 3] = mf.log_variance(params, sim.log[:, k])
        z = np.concatenate([sim.fix[:, k], _sensor_rows(sim, k)], 1)
        b, _, _ = mf.update(b, z, H, R, angle)
        X[:, k], PP[:, k] = b.x, b.P
    xs = mf.smooth(X, PP, pred_x, pred_P, phis)[0] if smooth else None
    return McResult(X, PP, xs)


def _errors(sim: ns.SimRun, x: np.ndarray) -> np.ndarray:
    """Truth − estimate over the estimate's states (nav, then the GM fix errors), ψ wrapped."""
    truth = sim.truth if x.shape[-1] == 11 else np.concatenate([sim.truth, sim.fix_gm], -1)
    e = truth - x
    e[..., 4] = (e[..., 4] + math.pi) % (2 * math.pi) - math.pi
    return e


def _nees(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", e, np.linalg.solve(P, e[..., None])[..., 0])


def _epoch_band(e: np.ndarray, P: np.ndarray) -> tuple[float, float, float]:
    """Fraction of epochs whose run-average NEES is inside the 95 % χ²(N·d)/N band, and the
    fractions below and above it (e: (runs, epochs, d))."""
    n_runs, d = e.shape[0], e.shape[-1]
    lo, hi = chi2.ppf([0.025, 0.975], d * n_runs) / n_runs
    avg = _nees(e, P).mean(axis=0)
    return float(((avg > lo) & (avg < hi)).mean()), float((avg <= lo).mean()), float(
        (avg >= hi).mean())


def _coverage(e: np.ndarray, P: np.ndarray) -> float:
    """Fraction of (run, epoch) with the true position inside the filter's 95 % ellipse."""
    return float((_nees(e[..., :2], P[..., :2, :2]) < K2_95).mean())


def _rms(e2: np.ndarray) -> float:
    """Radial RMS (m) of position errors (..., 2)."""
    return float(np.sqrt((e2**2).sum(-1).mean()))


# ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("params", [WHITE, COLOURED], ids=["white", "coloured"])
def test_batch_filter_is_the_engine_filter(params: kf.FilterParams) -> None:
    """3 runs × 120 s through engine.filter.kalman (predict_step, nav_measurement, update) and
    engine.filter.smoother.rts_smooth one run at a time, and through mc_filter at once: the same
    numbers to rounding (1e-9 relative on P; the loops differ only in operation order)."""
    sim = _simulate(params, 11, 3, 120, 0.2, params.coloured, balanced=False)
    res = run_filter(params, sim, smooth=True)
    s0 = _start(params)
    for r in range(3):
        s = s0
        recs: list[tuple] = []
        for k in range(121):
            if k:
                sp, phi = kf.predict_step(s, 1.0, params)
                recs.append((s, sp, phi))
                s = sp
            m = kf.nav_measurement(s, params, fix_xy=tuple(sim.fix[r, k]), fix_cov=C_FIX,
                                   depth_m=sim.depth[r, k], log_ms=sim.log[r, k],
                                   gyro_grid_rad=sim.gyro[r, k], incl_rad=sim.incl[r, k])
            s = kf.update(s, m, params).state
            np.testing.assert_allclose(res.x[r, k], s.x, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(res.P[r, k], s.P, rtol=1e-9,
                                       atol=1e-12 * np.abs(s.P).max())
        recs.append((s, None, None))
        xs = np.array([q.x for q in rts_smooth(recs)])
        np.testing.assert_allclose(res.xs[r], xs, rtol=1e-9, atol=1e-7)


@pytest.mark.parametrize("turn", [0.0, 0.2], ids=["straight", "turning"])
@pytest.mark.parametrize(
    ("params", "epochs", "seed"),
    [(WHITE, 300, 20240611), (COLOURED, 600, 7)],
    ids=["white-fixes", "gauss-markov-fixes"],
)
def test_filter_consistent_over_200_runs(params: kf.FilterParams, epochs: int, seed: int,
                                         turn: float) -> None:
    """200 runs per case; white fixes with the thesis model (white R = C), Gauss–Markov fixes
    (τ = 240 s, 90 % of σ² = 40² m² coloured) with the coloured model (the same τ and split).
    Straight = random-walk heading around a fixed course (the model's own ψ̇ noise); turning =
    the same plus a nominal 0.2 °/s turn (a full circle in 30 min), which the model only
    absorbs as process noise. P₀ is the A7 "physical" one and the truth starts from N(x̂₀, P₀).
    Runs last 300 s (white) or 600 s = 2.5 τ (Gauss–Markov, so that the coverage estimate
    averages several independent fix-error excursions per run).

    The initial deviations of the 200 runs are drawn with sample covariance exactly P₀
    (``balanced_start``): the bias and current errors of a run persist over all its epochs (on
    a straight track they are barely observable), so with independent draws the luck of the
    first draw shifts the run-average NEES of *every* epoch alike and the fraction inside the
    band is nearly all-or-nothing per seed (8 seeds, white straight: 32–100 %). Balancing removes
    that common offset; it also narrows the spread a little, so the band is slightly lenient.

    * NEES of the full state (11 nav states, + the 2 fix-error states with the coloured model),
      the Bar-Shalom test: the run-average at each epoch inside the 95 % χ²(N·d)/N band in at
      least 75 % of the epochs (expected 95 %; 8 other seeds per case: 54–100 %, median 97 %),
      and the same for the 2-D position NEES (8 other seeds: 81–100 %, median 96 %).
    * 95 % ellipse coverage of the truth over all runs and epochs in [93 %, 97 %] (8 other seeds
      per case: means 95.0 % (white) and 95.3 % (Gauss–Markov), 1σ ≤ 1.0 %).
    * RMS position error: smoother < filter < raw fix (smoother/filter ≤ 0.45 white, ≤ 0.78
      Gauss–Markov over the seeds).
    """
    sim = _simulate(params, seed, RUNS, epochs, turn, params.coloured)
    res = run_filter(params, sim, smooth=True)
    e = _errors(sim, res.x)
    inside = _epoch_band(e, res.P)[0]
    assert inside >= 0.75, inside
    inside_pos = _epoch_band(e[..., :2], res.P[..., :2, :2])[0]
    assert inside_pos >= 0.75, inside_pos
    cov = _coverage(e, res.P)
    assert 0.93 <= cov <= 0.97, cov
    rms_smooth = _rms(sim.truth[..., :2] - res.xs[..., :2])
    rms_filter, rms_fix = _rms(e[..., :2]), _rms(sim.fix_err)
    assert rms_smooth < rms_filter < rms_fix, (rms_smooth, rms_filter, rms_fix)


def test_correlated_fixes_make_the_thesis_model_overconfident() -> None:
    """The thesis model (every fix white, R = C) on Gauss–Markov fixes (τ = 240 s) claims an
    ellipse far too small — the issue's "under 10 % of epochs" (this seed: 7 %; 5–9 % on
    others) — which is what the coloured model above repairs."""
    sim = _simulate(WHITE, 7, 50, 600, 0.0, True)
    res = run_filter(WHITE, sim)
    assert _coverage(_errors(sim, res.x), res.P) < 0.15


# ------------------------------------------------------------------------------------------
# The real processing cycle
# ------------------------------------------------------------------------------------------

CYCLE_CONFIG = """
datum = "WGS84"
dr_position = "52 50 00 N 004 30 00 E"
depth_m = 20.0
run_gps_datum = "WGS84"
[gps]
on = true
[sensors]
inclinometer = "on"
pressure = "on"
[lsq]
# The simulated fixes are white with σ 50 m per axis: the thesis program's C/A variance.
gps_se_sf = 1.0
[filter]
# The white-noise model these simulated fixes follow, with physical P0 (not the default
# honest preset, whose coloured fix model and drifting biases these runs do not simulate).
preset = "thesis"
p0 = "physical"
"""


def run_cycle(seed: int, runs: int, epochs: int) -> tuple[ns.SimRun, np.ndarray, np.ndarray,
                                                            np.ndarray]:
    """``runs`` simulated tracks through the real processing cycle (engine.run.cycle.step): .RUN
    records from the truth — GPS C/A (σ 50 m per axis, white, as the cycle's a priori), gyro
    (true = grid + γ), log (kn), inclinometer and pressure crystal — filtered in the cycle's own
    order. The truth is drawn from the cycle's own prior: speed, heading and inclination at
    nominal values with the biases drawn from their A7 σ (the cycle's first estimate is the
    first readings, whose error is then the bias plus the reading noise, exactly the correlated
    P₀ of kf.init_state(from_sensors=…)), depth and current spread by P₀ around the configured
    20 m and 0 kn; the first LSE sets the position (A3). A gentle 0.1 °/s turn. Returns the
    sim, the filtered x and P (runs, epochs+1, 11[, 11]) and the T_LOM of the gyro/log/
    inclinometer updates (runs, epochs)."""
    data = Path(__file__).resolve().parents[2] / "data"
    cfg = parse_config_text(CYCLE_CONFIG, base_dir=data)
    ctx = build_context(cfg, *load_data(cfg))
    params = ctx.filter_params
    grid = ctx.grid(5.0)
    x0, y0 = grid.forward(cfg.dr_lat_deg, cfg.dr_lon_deg)
    mean = np.array([x0, y0, cfg.depth_m, 6.5, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    tiny = 1e-14  # the estimate is the readings: their error comes from the biases and noise
    P0 = np.diag([1.0, 1.0, params.sigma_press_m**2, tiny, tiny, tiny,
                  params.p0_current_sigma_ms**2, params.p0_current_sigma_ms**2,
                  params.p0_log_bias_ms**2, (params.p0_gyro_bias_deg * kf.DEG) ** 2,
                  (params.p0_incl_bias_deg * kf.DEG) ** 2])
    sim = ns.simulate(np.random.default_rng(seed), runs, epochs, mean, P0, params,
                      turn_rate_deg_s=0.1, fix_sigma_m=50.0)
    ref = surface_reference_hz(cfg.demo.press_ref_freq_hz)
    t0 = datetime(1992, 9, 17, 10, 0, 0, tzinfo=UTC)
    X = np.empty((runs, epochs + 1, 11))
    PP = np.empty((runs, epochs + 1, 11, 11))
    nis = np.full((runs, epochs), np.nan)
    for r in range(runs):
        nav = initial_state(cfg)
        fixes = sim.fix[r].tolist()
        truth = sim.truth[r, :, :2].tolist()
        for k in range(epochs + 1):
            lat, lon = grid.inverse(*fixes[k])
            gamma = grid.convergence_deg(*grid.inverse(*truth[k]))
            rec = RunRecord(k + 1, t0 + timedelta(seconds=k), lat, lon, (None, None, None),
                            (math.degrees(sim.gyro[r, k]) + gamma) % 360.0,
                            sim.log[r, k] / KNOT_MS, 0.0, math.degrees(sim.incl[r, k]),
                            depth_to_frequency_hz(float(sim.depth[r, k]), ref,
                                                  cfg.demo.s_weight))
            nav, res = step(ctx, nav, rec)
            X[r, k], PP[r, k] = res.filter_state.x, res.filter_state.P
            if k and res.sensor_update is not None:
                nis[r, k - 1] = res.sensor_update.lom.t
    return sim, X, PP, nis


def test_real_cycle_order_positions_consistent_sensor_states_conservative() -> None:
    """40 runs × 240 s through engine.run.cycle.step, whose order is: this record's gyro, log and
    inclinometer update the state of the previous epoch, the step Δt follows, then the fix and
    pressure update at this epoch (README "Sensor timing", needed for the Pg 641 KF row).

    Why the audit's full-state NEES left the band in this order: the readings of t_k are
    applied to the state of t_{k−1}, and the step then adds one Δt of process noise to v, ψ
    and ε that those readings had already removed — the reported σ of speed, heading and
    inclination is too large (their NEES ≈ 0.6–0.8 instead of 1: conservative), the full
    11-state NEES falls below its band. Positions, whose uncertainty grows through Φ P Φᵀ from
    the updated P, are not affected, and neither are the innovations (the reading of t_k vs the
    prediction from t_{k−1} includes that step's noise in S): both are consistent.

    * position NEES, run-average per epoch inside the χ²(2N)/N band in ≥ 75 % of the epochs
      (expected 95 %; 12 seeds of 20 runs: 85–100 %);
    * 95 % ellipse coverage in [93 %, 97 %] (12 seeds of 20 runs: mean 95.6 %, 1σ 1.1 %; 40 runs
      halve the variance);
    * mean T_LOM of the gyro/log/inclinometer updates within 5 % of 1 (12 seeds: 1.00–1.03);
    * speed and inclination NEES below 0.85 (12 seeds: 0.60–0.78; heading scatters more,
      0.6–1.5 over 20 runs, its bias being only slowly observable, so it is not asserted).
    """
    sim, X, PP, tlom = run_cycle(12, 40, 240)
    e, P = _errors(sim, X)[:, 1:], PP[:, 1:]  # epoch 0: position = the first LSE (A3)
    inside = _epoch_band(e[..., :2], P[..., :2, :2])[0]
    assert inside >= 0.75, inside
    cov = _coverage(e, P)
    assert 0.93 <= cov <= 0.97, cov
    assert abs(float(np.nanmean(tlom)) - 1.0) < 0.05, np.nanmean(tlom)
    for j in (3, 5):  # v, ε
        nees_j = float((e[..., j] ** 2 / P[..., j, j]).mean())
        assert nees_j < 0.85, (j, nees_j)
