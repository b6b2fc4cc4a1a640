"""Robust IRLS option (engine.lsq.robust): seeded Monte Carlo against plain least squares."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.lsq.adjustment import Linearisation, gauss_newton
from engine.lsq.robust import psi_weight, robust_adjust, standardised_residuals
from engine.lsq.snooping import adjust_with_testing

# 8 distance stations around the point, 45° apart, mixed ranges (well-spread geometry,
# every redundancy number ≈ 0.75), σ = 5 m.
ANG = np.arange(8) * np.pi / 4.0 + 0.3
RNG_M = np.array([800.0, 1500.0, 2500.0, 1200.0, 3000.0, 900.0, 2000.0, 1700.0])
STATIONS = np.c_[RNG_M * np.sin(ANG), RNG_M * np.cos(ANG)]
SIG = 5.0
TRUTH = np.zeros(2)
X0 = np.array([30.0, -20.0])
USED = np.ones(8, bool)


def _model(obs: np.ndarray, sig: float = SIG):
    C = np.eye(len(obs)) * sig**2

    def lin(x: np.ndarray) -> Linearisation:
        d = x[None, :] - STATIONS
        r = np.linalg.norm(d, axis=1)
        return Linearisation(d / r[:, None], obs - r, C)

    return lin


def test_psi_functions() -> None:
    w = np.array([0.0, 1.5, -3.0, 6.0, np.nan])
    np.testing.assert_allclose(psi_weight(w, "huber", 1.5), [1.0, 1.0, 0.5, 0.25, 1.0])
    np.testing.assert_allclose(
        psi_weight(w, "danish", 2.0), [1.0, 1.0, math.exp(1 - 9 / 4), math.exp(1 - 9), 1.0])
    with pytest.raises(ValueError):
        psi_weight(w, "tukey", 2.0)


def test_one_blunder_is_damped_and_the_position_error_shrinks() -> None:
    """400 seeded trials, one ±10σ blunder on a random one of 8 distances. Plain LSQ spreads
    it into the position; Huber (c 1.5) and Danish (c 2.0) give the blunder a weight < 0.2 and
    a median position error at least 3× smaller. Measured with this seed: median error LSQ
    12.4 m, Huber 3.9 m (ratio 3.2), Danish 3.4 m (ratio 3.6); the noise floor (no blunder)
    is ≈ 3 m, which is why Huber's margin over 3× is small."""
    rng = np.random.default_rng(2024)
    err = {"lsq": [], "huber": [], "danish": []}
    weight = {"huber": [], "danish": []}
    for _ in range(400):
        obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + rng.normal(0.0, SIG, 8)
        j = int(rng.integers(8))
        obs[j] += 10.0 * SIG * rng.choice([-1.0, 1.0])
        lin = _model(obs)
        plain = gauss_newton(lin, X0, USED, epsilon=1e-4)
        assert plain.ok
        err["lsq"].append(float(np.hypot(*(plain.x - TRUTH))))
        for psi in ("huber", "danish"):
            rob = robust_adjust(lin, X0, USED, psi=psi, epsilon=1e-4)
            assert rob.ok, rob.reason
            err[psi].append(float(np.hypot(*(rob.x - TRUTH))))
            weight[psi].append(float(rob.weights[j]))
            assert rob.weights[j] == pytest.approx(np.nanmin(rob.weights))  # the blunder
    med = {k: float(np.median(v)) for k, v in err.items()}
    assert med["huber"] * 3.0 <= med["lsq"]
    assert med["danish"] * 3.0 <= med["lsq"]
    assert max(weight["huber"]) < 0.2 and max(weight["danish"]) < 0.2


def test_no_blunder_small_residuals_equal_lsq() -> None:
    """When every standardised residual is within c the weights stay 1 and the robust
    estimate IS the LSQ one (to 1e-6 m; exactly, in fact)."""
    rng = np.random.default_rng(8)
    done = 0
    for _ in range(50):
        obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + rng.normal(0.0, 0.3 * SIG, 8)
        lin = _model(obs)
        plain = gauss_newton(lin, X0, USED, epsilon=1e-4)
        if np.nanmax(np.abs(plain.w)) > 1.5:
            continue
        for psi in ("huber", "danish"):
            rob = robust_adjust(lin, X0, USED, psi=psi, epsilon=1e-4)
            assert rob.ok and rob.iterations == 1
            np.testing.assert_allclose(rob.x, plain.x, atol=1e-6)
            np.testing.assert_allclose(rob.weights, 1.0)
        done += 1
    assert done >= 40


def test_no_blunder_normal_noise_stays_close_to_lsq() -> None:
    """Pure N(0, σ²) noise: Huber with c = 1.5 does down-weight the ≈ 13 % of observations
    beyond 1.5σ_d, so it is NOT identical to LSQ; the difference stays well inside the
    position's own standard deviation (median measured ≈ 0.2 m for σ_x̂ ≈ 3.5 m)."""
    rng = np.random.default_rng(9)
    diffs = []
    for _ in range(100):
        obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + rng.normal(0.0, SIG, 8)
        lin = _model(obs)
        plain = gauss_newton(lin, X0, USED, epsilon=1e-4)
        rob = robust_adjust(lin, X0, USED, psi="huber", epsilon=1e-4)
        diffs.append(float(np.hypot(*(rob.x - plain.x))))
        sx = math.sqrt(np.trace(plain.cov_x))
    assert float(np.median(diffs)) < 0.25 * sx


def test_standardised_residuals_are_the_w_statistics() -> None:
    obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + np.linspace(-4.0, 4.0, 8)
    plain = gauss_newton(_model(obs), X0, USED, epsilon=1e-6)
    np.testing.assert_allclose(standardised_residuals(plain), plain.w, rtol=1e-9)


def test_correlated_weights_are_damped_symmetrically() -> None:
    """W' = T^½ W T^½: with a correlated C_l the damped adjustment equals an LSQ adjustment
    with C_l' = T^-½ C_l T^-½ (checked against numpy on the linearisation)."""
    rng = np.random.default_rng(4)
    A = rng.normal(size=(6, 2))
    M = rng.normal(size=(6, 6))
    C = M @ M.T + np.eye(6)
    l = rng.normal(size=6)
    t = np.array([1.0, 0.3, 1.0, 0.05, 1.0, 0.7])
    lin = lambda x: Linearisation(A, l - A @ x, C)  # noqa: E731
    damped = gauss_newton(lin, np.zeros(2), np.ones(6, bool), damping=t, epsilon=1e-12)
    s = np.sqrt(t)
    C2 = C / np.outer(s, s)
    ref = gauss_newton(lambda x: Linearisation(A, l - A @ x, C2), np.zeros(2),
                       np.ones(6, bool), epsilon=1e-12)
    np.testing.assert_allclose(damped.x, ref.x, rtol=1e-10)
    np.testing.assert_allclose(damped.W_used, np.diag(s) @ np.linalg.inv(C) @ np.diag(s),
                               rtol=1e-10)


def test_zero_redundancy_is_the_lsq_fix_and_nothing_raises() -> None:
    """r = 0: v̂ = 0, so every weight stays 1 and the M-estimate IS the LSQ estimate (ok, no
    message to the operator); too few LOPs is the core's "no fix", not an exception."""
    obs = np.linalg.norm(STATIONS[:2] - TRUTH, axis=1) + np.array([3.0, -2.0])
    C = np.eye(2) * SIG**2

    def lin(x: np.ndarray) -> Linearisation:
        d = x[None, :] - STATIONS[:2]
        r = np.linalg.norm(d, axis=1)
        return Linearisation(d / r[:, None], obs - r, C)

    rob = robust_adjust(lin, X0, np.ones(2, bool))
    assert rob.ok and rob.reason is None and rob.iterations == 0
    np.testing.assert_array_equal(rob.weights, [1.0, 1.0])
    np.testing.assert_array_equal(rob.x, gauss_newton(lin, X0, np.ones(2, bool)).x)
    bad = robust_adjust(lin, X0, np.array([True, False]))
    assert not bad.ok and bad.reason == "Not enough LOPs for a fix !"


def test_robust_passes_the_settings_to_every_adjustment() -> None:
    """ScaleVCV, σ0², α and max_iter reach the damped adjustments (they were ignored by the
    fix's robust branch before): the damped C_x̂ is × S²; the unit-variance bounds follow α and
    σ0²; a 1-iteration cap from 30 m away cannot converge to ε = 1e-4 m."""
    rng = np.random.default_rng(12)
    obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + rng.normal(0.0, SIG, 8)
    obs[2] += 12.0 * SIG
    lin = _model(obs)
    rob = robust_adjust(lin, X0, USED, psi="huber", epsilon=1e-4, scale_vcv=True, s02=2.0,
                        alpha=0.01)
    adj = rob.adjustment
    assert rob.ok and adj.damping is not None and adj.scaled
    np.testing.assert_allclose(adj.cov_x, adj.cov_x_apriori * adj.s2, rtol=1e-12)
    vt = adj.variance_test
    assert vt is not None and vt.dof == 6
    # σ0²·χ²_6(α/2)/6 and σ0²·χ²_6(1 − α/2)/6 with α = 0.01 (tables: 0.6757, 18.548)
    assert (vt.lower, vt.upper) == pytest.approx((2.0 * 0.6757 / 6, 2.0 * 18.548 / 6), abs=2e-4)
    capped = robust_adjust(lin, X0, USED, psi="huber", epsilon=1e-4, max_iter=1)
    assert not capped.ok and capped.reason == "no convergence"


def test_adjust_with_testing_robust_estimator() -> None:
    rng = np.random.default_rng(77)
    obs = np.linalg.norm(STATIONS - TRUTH, axis=1) + rng.normal(0.0, SIG, 8)
    obs[5] += 15.0 * SIG
    t = adjust_with_testing(_model(obs), X0, USED, estimator="danish")
    assert t.rejected == () and t.estimator == "danish" and t.robust is not None
    assert t.robust.weights[5] < 0.01  # type: ignore[attr-defined]
    assert np.hypot(*t.adjustment.x) < 3.0 * math.sqrt(np.trace(t.adjustment.cov_x))
    assert any("down-weighted" in m for m in t.messages)
