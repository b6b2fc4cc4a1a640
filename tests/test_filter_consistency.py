"""Monte-Carlo consistency of the navigation filter against a known truth (kalman.md §12.5).

Truth and measurements come from tests/navsim_small.py (thesis kinematics integrated with
sub-steps, thesis sensor σ, position fixes at 1 Hz with σ = 40 m per axis). Seeds are fixed, so
every figure below is reproducible; the tolerances are the statistical bands named in each
test; sample sizes keep this file at about 25 s on one core.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import navsim_small as ns
import numpy as np
from scipy.stats import chi2

from engine import kalman as kf
from engine.smoother import rts_smooth

SIGMA_FIX = 40.0  # m per axis: an SA-era GPS fix
C_FIX = np.eye(2) * SIGMA_FIX**2
K2_95 = chi2.ppf(0.95, 2)  # 95 % ellipse: d² < 5.991


@dataclass(frozen=True)
class McResult:
    """Filtered (and optionally smoothed) estimates of every run and epoch."""

    x: np.ndarray  # (runs, epochs+1, 11) filtered nav states
    P: np.ndarray  # (runs, epochs+1, 11, 11)
    xs: np.ndarray | None  # (runs, epochs+1, 2) smoothed positions


def _start(params: kf.FilterParams) -> kf.FilterState:
    """Initial estimate: 12.6 kn on grid heading 57°, 50 m deep, current (0.2, −0.1) m/s."""
    return kf.init_state(0.0, 0.0, 0.0, 50.0, 6.5, 1.0, 0.0, 0.2, -0.1, params, pos_cov=C_FIX)


def run_filter(params: kf.FilterParams, sim: ns.SimRun, smooth: bool = False) -> McResult:
    """Run the filter over every simulated run: predict 1 s, update with fix + 4 sensors."""
    runs, n_ep = sim.fix.shape[:2]
    X = np.empty((runs, n_ep, 11))
    PP = np.empty((runs, n_ep, 11, 11))
    XS = np.empty((runs, n_ep, 2)) if smooth else None
    s0 = _start(params)
    for r in range(runs):
        fix, dep = sim.fix[r].tolist(), sim.depth[r].tolist()
        log, gyr, inc = sim.log[r].tolist(), sim.gyro[r].tolist(), sim.incl[r].tolist()
        s = s0
        recs: list[tuple] = []
        for k in range(n_ep):
            if k:
                sp, phi = kf.predict_step(s, 1.0, params)
                if smooth:
                    recs.append((s, sp, phi))
                s = sp
            m = kf.nav_measurement(s, params, fix_xy=fix[k], fix_cov=C_FIX, depth_m=dep[k],
                                   log_ms=log[k], gyro_grid_rad=gyr[k], incl_rad=inc[k])
            s = kf.update(s, m, params).state
            X[r, k] = s.x[:11]
            PP[r, k] = s.P[:11, :11]
        if smooth:
            recs.append((s, None, None))
            XS[r] = [q.x[:2] for q in rts_smooth(recs)]
    return McResult(X, PP, XS)


def _errors(sim: ns.SimRun, res: McResult) -> np.ndarray:
    e = sim.truth - res.x
    e[..., 4] = (e[..., 4] + math.pi) % (2 * math.pi) - math.pi
    return e


def _nees(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", e, np.linalg.solve(P, e[..., None])[..., 0])


def _coverage(e: np.ndarray, P: np.ndarray) -> float:
    """Fraction of (run, epoch) with the true position inside the filter's 95 % ellipse."""
    return float((_nees(e[..., :2], P[..., :2, :2]) < K2_95).mean())


def _rms(e2: np.ndarray) -> float:
    """Radial RMS (m) of position errors (..., 2)."""
    return float(np.sqrt((e2**2).sum(-1).mean()))


def test_thesis_filter_consistent_with_white_fixes() -> None:
    """Thesis model (q_mode "thesis", white R), 200 runs × 300 s, 100 straight + 100 turning.

    Straight = random-walk heading around a fixed course (the model's own ψ̇ noise); turning =
    the same plus a nominal 0.2 °/s turn (a full circle in 30 min), which the thesis model only
    absorbs as process noise. P₀ is the A7 "physical" one, and the truth starts from N(x̂₀, P₀).
    """
    params = kf.FilterParams(p0="physical")
    s0 = _start(params)
    rng = np.random.default_rng(20240611)
    runs, epochs = 100, 300
    sims = [ns.simulate(rng, runs, epochs, s0.x, s0.P, params, turn_rate_deg_s=turn,
                        fix_sigma_m=SIGMA_FIX) for turn in (0.0, 0.2)]
    res = [run_filter(params, sim, smooth=True) for sim in sims]
    e = np.concatenate([_errors(sim, r) for sim, r in zip(sims, res, strict=True)])
    P = np.concatenate([r.P for r in res])
    n_runs = e.shape[0]

    # NEES of the full 11-state vector. Under consistency the run-average at each epoch is
    # χ²(11·N)/N; the two-sided 95 % band for N = 200 is [10.36, 11.66].
    nees = _nees(e, P)
    lo, hi = chi2.ppf([0.025, 0.975], 11 * n_runs) / n_runs
    per_epoch = nees.mean(axis=0)
    inside = float(((per_epoch > lo) & (per_epoch < hi)).mean())
    assert lo < nees.mean() < hi, (nees.mean(), lo, hi)
    # 95 % of epochs would fall in the band if they were independent; they are correlated in
    # time, so allow 90 % (this seed: 97.7 %; 95–99 % on others).
    assert inside >= 0.90, inside

    cov = _coverage(e, P)
    assert 0.93 <= cov <= 0.97, cov

    e_sm = np.concatenate([sim.truth[..., :2] - r.xs for sim, r in zip(sims, res, strict=True)])
    rms_filter, rms_smooth = _rms(e[..., :2]), _rms(e_sm)
    rms_fix = _rms(np.concatenate([sim.fix_err for sim in sims]))
    assert rms_smooth < rms_filter < rms_fix, (rms_smooth, rms_filter, rms_fix)


def test_correlated_fixes_thesis_overconfident_coloured_consistent() -> None:
    """Fix errors Gauss–Markov, τ = 240 s, 90 % of σ² = 40² m² coloured plus 10 % white.

    The thesis model (all fixes white, R = C) must be grossly over-confident; the augmented
    model (coloured=True, GM states with the same τ and split) must cover 93–97 % while still
    beating the raw fix on RMS.
    """
    tau = 240.0
    thesis = kf.FilterParams(p0="physical")
    coloured = kf.FilterParams(p0="physical", coloured=True, fix_tau_s=tau, fix_sigma_frac=0.9)
    s0 = _start(thesis)
    rng = np.random.default_rng(7)

    sim_t = ns.simulate(rng, 20, 600, s0.x, s0.P, thesis, fix_sigma_m=SIGMA_FIX,
                        fix_tau_s=tau, fix_white_frac=0.1)
    res_t = run_filter(thesis, sim_t)
    cov_t = _coverage(_errors(sim_t, res_t), res_t.P)
    assert cov_t < 0.5, cov_t  # "far below 93 %" (this seed: 7.9 %; 5–8 % on others)

    # 120 runs × 600 s (2.5 τ each): with this sample the coverage estimate itself scatters
    # by ≈ 0.8 % (1σ) between seeds (8 other seeds: 93.9–96.7 %, mean 95.2 %), so the
    # 93–97 % band is about ±2.5σ wide.
    sim_c = ns.simulate(rng, 120, 600, s0.x, s0.P, coloured, fix_sigma_m=SIGMA_FIX,
                        fix_tau_s=tau, fix_white_frac=0.1)
    res_c = run_filter(coloured, sim_c)
    e_c = _errors(sim_c, res_c)
    cov_c = _coverage(e_c, res_c.P)
    assert 0.93 <= cov_c <= 0.97, cov_c
    assert _rms(e_c[..., :2]) < _rms(sim_c.fix_err), (_rms(e_c[..., :2]), _rms(sim_c.fix_err))
