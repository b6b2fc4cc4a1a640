"""The dead-reckoning noise factor μ learnt from shadow predictions (THEORY §8.19).

Known answers from a synthetic truth: a vessel on a straight course at constant speed in a
current that is a random walk of known spectral density q_true per component (m²/s³), gyro and
log with white errors of the σ the filter assumes, white GPS-like fixes of σ 5 m every step.
The filter is given q_true / 4: the factor that makes its model right is 4, and μ must find it
within a factor of 1.6 (the statistic's noise over the checks of the last two hours: ln μ has a
standard deviation of about (g/2)^½ ≈ 0.15 with g = 1/24, overlapping shadows count twice,
three of those ≈ ln 1.6). A quiet truth (a steady current) with the default's random walk
must pull μ down no faster than δ = 0.05 in ln μ per check and never below μ_min.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from engine.filter import horizon as H
from engine.filter.kalman import init_state
from engine.filter.measurements import lse_measurement, sensor_rows
from engine.filter.params import FilterParams
from engine.filter.predict import predict_step
from engine.filter.update import update, update_rows

DT = 2.0
V = 5.0
PSI = math.radians(40.0)
SIGMA_FIX = 5.0
SIGMA_GYRO_DEG = 0.65


def _run(q_true: float, q_model: float, hours: float, settings: H.DrAdaptSettings,
         seed: int) -> list[tuple[float, float, float]]:
    """The filter with μ learnt over ``hours`` of the synthetic truth; returns (time s, μ,
    ln μ) after every check."""
    rng = np.random.default_rng(seed)
    params = FilterParams(coloured=False, p0="physical", bias_noise=False,
                          sigma_current2=q_model)
    x = np.array([0.0, 0.0])
    vc = np.array([0.3, -0.2])
    fs = init_state(0.0, 0.0, 0.0, 0.0, V, PSI, 0.0, 0.0, 0.0, params,
                    pos_cov=np.eye(2) * SIGMA_FIX**2, from_sensors=(True, True, False))
    st = H.DrAdaptState()
    C = np.eye(2) * SIGMA_FIX**2
    out: list[tuple[float, float, float]] = []
    log_sigma = max(params.log_sigma_frac * V, params.log_sigma_floor_ms)
    for k in range(int(hours * 3600 / DT)):
        gyro = PSI + rng.normal(0.0, math.radians(SIGMA_GYRO_DEG))
        log = V + rng.normal(0.0, log_sigma)
        zs, var, layout = sensor_rows(None, log, gyro, None, params)
        qp = H.scaled_params(params, st.mu)
        fs = update_rows(fs, zs, var, layout, params).state
        fs = predict_step(fs, DT, qp)[0]
        if st.shadows:
            st = H.advance(st, zs, var, layout, DT, qp, update_rows, predict_step, settings)
        # the truth moves over the same step (the current: a random walk of q_true)
        x += (V * np.array([math.sin(PSI), math.cos(PSI)]) + vc) * DT
        vc += rng.normal(0.0, math.sqrt(q_true * DT), 2)
        z = x + rng.normal(0.0, SIGMA_FIX, 2)
        fs = update(fs, lse_measurement(float(z[0]), float(z[1]), C, params), params).state
        n0 = st.n
        if st.shadows:
            st, _msg = H.check(st, fs.t, (float(z[0]), float(z[1])), C, 1.0, qp, update_rows,
                               predict_step, settings)
        if st.n > n0:
            out.append((fs.t, st.mu, st.log_mu))
        st = H.start_shadow(st, fs, settings)
        assert k < 5 or fs.t > 0.0
    return out


@pytest.mark.slow
def test_mu_finds_the_true_ratio_of_the_current_random_walk() -> None:
    q_true = 4e-5
    checks = _run(q_true, q_true / 4.0, 8.0, H.DrAdaptSettings(), seed=3)
    assert len(checks) > 150  # one check per 150 s
    late = [ell for t, _mu, ell in checks if t > 6 * 3600]
    mean_mu = math.exp(sum(late) / len(late))
    assert 4.0 / 1.6 <= mean_mu <= 4.0 * 1.6, mean_mu


def test_mu_rises_fast_when_the_model_is_too_quiet() -> None:
    """Forty times too little current noise: μ above 4 within the first hour (24 checks)."""
    q_true = 4e-5
    checks = _run(q_true, q_true / 40.0, 1.0, H.DrAdaptSettings(), seed=5)
    assert checks and checks[-1][1] >= 4.0, checks[-3:]


def test_quiet_truth_shrinks_mu_slowly_and_not_below_the_floor() -> None:
    settings = H.DrAdaptSettings(mu_min=0.2)
    checks = _run(0.0, 3.5e-5, 3.0, settings, seed=7)
    ells = [0.0] + [ell for _t, _mu, ell in checks]
    steps = np.diff(ells)
    assert steps.min() >= -settings.down - 1e-12  # at most 5 % down per check
    assert min(mu for _t, mu, _e in checks) >= settings.mu_min
    assert checks[-1][1] < 0.8  # it does learn downwards on a quiet truth
    # the default floor: μ = 1, the cited random walks
    default = _run(0.0, 3.5e-5, 1.0, H.DrAdaptSettings(), seed=7)
    assert all(mu == 1.0 for _t, mu, _e in default)


@pytest.mark.parametrize("n", [0, 100])
def test_one_blunder_moves_mu_by_a_bounded_amount(n: int) -> None:
    """One check with an absurd NEES (a blunder fix) raises μ by at most e^{(c − 1)/K}: ×2.4
    in the first eight checks, ×1.34 once the gain is 1/W (c = 8, K₀ = 8, W = 24); the applied
    factor is ln μ rounded to 1/16 (half a step more)."""
    s = H.DrAdaptSettings()
    st = replace(H.DrAdaptState(), n=n)
    new, _msg = H.learn(st, 1e12, s)
    k = min(max(n + 1, H.START_CHECKS), s.window)
    bound = (s.clip - 1.0 + math.exp(-s.clip)) / k
    assert new.log_mu - st.log_mu == pytest.approx(bound)
    assert math.log(new.mu) <= bound + H.MU_STEP / 2 + 1e-12
    assert new.clipped == 1
    # and a NaN NEES is not learnt, said
    same, msg = H.learn(st, math.nan, s)
    assert same is st and msg is not None and "not finite" in msg


def test_scaled_params_scale_the_dr_random_walks_only() -> None:
    p = FilterParams(bias_noise=True)
    q = H.scaled_params(p, 4.0)
    assert q.sigma_current2 == pytest.approx(4.0 * p.sigma_current2)
    assert q._q[5] == pytest.approx(4.0 * p._q[5])  # log bias
    assert q._q[6] == pytest.approx(4.0 * p._q[6])  # gyro bias
    assert q._q[7] == p._q[7] and q._q[0] == p._q[0] and q._q[1] == p._q[1]
    assert H.scaled_params(p, 4.0) is q and H.scaled_params(p, 1.0) is p


def test_shadow_nees_by_hand() -> None:
    """NEES of a 2-D offset against a diagonal S: (3²/9 + 4²/16) = 2."""
    params = FilterParams(coloured=False, p0="physical")
    fs = init_state(0.0, 100.0, 200.0, 0.0, V, PSI, 0.0, 0.0, 0.0, params,
                    pos_cov=np.diag([5.0, 7.0]), from_sensors=(True, True, False))
    nees = H.shadow_nees(fs, (103.0, 196.0), np.diag([4.0, 9.0]), 1.0)
    assert nees == pytest.approx(2.0)
