"""Least-squares core (engine.lsq.adjustment): thesis worked example, independent solvers, geometry.

Independent sources: the thesis screens Pg 821/830/633/641 as transcribed in THEORY §14.2 (inputs
AND outputs are printed there), ``numpy.linalg.lstsq`` on the Cholesky-whitened system, and hand
geometry (distances to known points).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from engine.lsq.adjustment import (
    COND_MAX,
    MAX_AXIS_RATIO,
    NOT_ENOUGH,
    Adjustment,
    Linearisation,
    category,
    gauss_newton,
)

# ------------------------------------------------------------------------------------------
# The worked example A8.5 at matrix level (THEORY §14.2, Pg 821 inputs). Slots: GPS Lat, GPS Lon,
# Decca Red, Green, Purple (Purple deselected). Purple's row is given as NaN/garbage on purpose:
# an unused slot must not influence anything.

A_PG821 = np.array(
    [[0.0, 1.0], [1.0, 0.0], [-0.47409, 0.88046], [-0.42885, -0.90336], [np.nan, np.nan]]
)
B_PG821 = np.array([12.45880, 1.84520, -1.60637, 0.28186, np.nan])
CL_PG821 = np.zeros((5, 5))
CL_PG821[0, 0] = CL_PG821[1, 1] = 2500.0
CL_PG821[2:4, 2:4] = [[916.877, 18.050], [18.050, 83.585]]
CL_PG821[4, 4] = 77.0  # arbitrary: Purple's variance is irrelevant once deselected
CL_PG821[2, 4] = CL_PG821[4, 2] = 5.0
USED_PG = np.array([True, True, True, True, False])


def pg821(x: np.ndarray) -> Linearisation:
    """The printed last-iteration linearisation, whatever x (constant A, b, C_l)."""
    return Linearisation(A_PG821, B_PG821, CL_PG821)


@pytest.fixture(scope="module")
def sample() -> Adjustment:
    # epsilon 50 m: the printed b belong to the last iteration (whose δx̂ was 2 mm, THEORY §5.1),
    # so exactly one Gauss–Newton step from the printed linearisation reproduces the screens.
    return gauss_newton(pg821, np.zeros(2), USED_PG, epsilon=50.0)


def test_sample_converges_in_one_step_with_a_2mm_correction(sample: Adjustment) -> None:
    assert sample.ok and sample.converged and sample.iterations == 1
    # THEORY §5.1: "their b were evaluated 2 mm from the final x̂"; 1 mm tolerance for rounding
    assert sample.steps[0] == pytest.approx(0.002, abs=0.001)


def test_sample_cov_matches_pg641(sample: Adjustment) -> None:
    # Pg 641 prints C_x̂ to 3 dp; the printed C_l inputs are themselves rounded to 3 dp, which
    # moves σy² by 1.4e-3 (THEORY §14.3: recomputed 196.756), hence ±0.002 m².
    expect = np.array([[814.936, -298.408], [-298.408, 196.755]])
    np.testing.assert_allclose(sample.cov_x, expect, atol=0.002)
    np.testing.assert_allclose(sample.cov_x_apriori, sample.cov_x)  # scaling is off


def test_sample_weights_match_pg830(sample: Adjustment) -> None:
    W = sample.W
    # Pg 830 prints 5 decimals: ±0.5e-5. Our W_GG = 0.0120149 sits 5e-8 below the rounding
    # point of the printed 0.01202; the C_l we invert is itself printed to 3 dp, and ±0.0005 m²
    # on it moves W_GG by up to W²·0.0005 ≈ 1e-7, so the tolerance is 0.5e-5 + 0.2e-6.
    tol = 5e-6 + 2e-7
    assert W[0, 0] == pytest.approx(0.00040, abs=tol)
    assert W[1, 1] == pytest.approx(0.00040, abs=tol)
    np.testing.assert_allclose(
        W[2:4, 2:4], [[0.00110, -0.00024], [-0.00024, 0.01202]], atol=tol
    )
    assert np.all(W[4, :] == 0.0) and np.all(W[:, 4] == 0.0)  # Purple: W_ii = 0
    assert W[0, 2] == 0.0 and W[1, 3] == 0.0  # no GPS–Decca correlation


def test_sample_matrices_are_laid_out_like_pg821(sample: Adjustment) -> None:
    # Pg 821: Purple's A row and b are 0; Pg 615: its variance 1.000 and covariances 0.
    np.testing.assert_array_equal(sample.A[4], [0.0, 0.0])
    assert sample.b[4] == 0.0
    assert sample.Cl[4, 4] == 1.0 and sample.Cl[2, 4] == 0.0
    np.testing.assert_array_equal(sample.A[:4], A_PG821[:4])
    np.testing.assert_array_equal(sample.b[:4], B_PG821[:4])


def test_sample_residuals_rms_and_unit_variance(sample: Adjustment) -> None:
    v = sample.v
    # Hand-rounded to 2 dp (±0.01 m) and the screen's 1 dp (Pg 631/633: −12.5, −1.8, 1.6, −0.3)
    np.testing.assert_allclose(v[:4], [-12.46, -1.85, 1.61, -0.28], atol=0.01)
    np.testing.assert_allclose(v[:4], [-12.5, -1.8, 1.6, -0.3], atol=0.05)
    assert math.isnan(v[4])  # blank on Pg 631
    assert sample.n_used == 4 and sample.redundancy == 2 and sample.category == "IV"
    assert sample.s2 == pytest.approx(0.034, abs=0.0005)  # Pg 633 "S² : 0.034"
    assert sample.rms_m == pytest.approx(6.35, abs=0.005)  # Pg 100 "RMS 6.35m"
    # d_rms = sqrt(trace C_x̂) = 31.81 m (THEORY §7.3), 2 dp
    assert sample.drms_m == pytest.approx(31.81, abs=0.005)
    vt = sample.variance_test
    assert vt is not None and vt.accepted and vt.dof == 2


def test_sample_linear_model_converges_to_the_same_statistics() -> None:
    """A linear model b(x) = b0 − A(x − x0) with the default ε: the second iteration's δx̂ is 0
    and every statistic equals the one-step values (they are invariant along a linear model)."""
    x0 = np.array([-31615.0, 5857300.0])
    A, b0, C = A_PG821[:4], B_PG821[:4], CL_PG821[:4, :4]

    def lin(x: np.ndarray) -> Linearisation:
        return Linearisation(A, b0 - A @ (x - x0), C)

    one = gauss_newton(pg821, np.zeros(2), USED_PG, epsilon=50.0)
    adj = gauss_newton(lin, x0, np.ones(4, bool))
    assert adj.ok
    np.testing.assert_allclose(adj.x - x0, one.x, atol=1e-9)
    np.testing.assert_allclose(adj.v, one.v[:4], atol=1e-9)
    np.testing.assert_allclose(adj.w, one.w[:4], atol=1e-9)


def test_category_table_5_1() -> None:
    # Table 5.1 (THEORY §5.4): 2-D n = 1..5 → I II III IV IV; 3-D n = 2..5 → I II III IV
    assert [category(n, 2) for n in (1, 2, 3, 4, 5)] == ["I", "II", "III", "IV", "IV"]
    assert [category(n, 3) for n in (1, 2, 3, 4, 5)] == ["I", "I", "II", "III", "IV"]


def test_category_ii_has_no_statistics() -> None:
    adj = gauss_newton(pg821, np.zeros(2), np.array([True, False, True, False, False]),
                       epsilon=50.0)
    assert adj.ok and adj.category == "II" and adj.s2 is None and adj.variance_test is None
    assert np.all(np.isnan(adj.w)) and np.all(np.isnan(adj.sigma_d))
    np.testing.assert_allclose(adj.v[[0, 2]], 0.0, atol=1e-9)  # r = 0: v̂ = 0


# ------------------------------------------------------------------------------------------
# Random geometries against numpy.linalg.lstsq on the whitened system


def _random_spd_blocks(rng: np.random.Generator, n: int) -> np.ndarray:
    """Block-diagonal SPD matrix with random block sizes 1..3 (correlated blocks) [m²]."""
    C = np.zeros((n, n))
    i = 0
    while i < n:
        k = int(min(rng.integers(1, 4), n - i))
        M = rng.normal(size=(k, k)) * rng.uniform(0.5, 20.0)
        C[i:i + k, i:i + k] = M @ M.T + np.eye(k) * rng.uniform(0.1, 5.0)
        i += k
    return C


def _cases(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        u = int(rng.choice([2, 3]))
        n = int(rng.integers(max(3, u + 1), 13))
        A = rng.normal(size=(n, u))
        C = _random_spd_blocks(rng, n)
        l = rng.normal(size=n) * 10.0
        used = np.ones(n, bool)
        n_drop = int(rng.integers(0, n - u))  # keep at least u + 1 rows used
        used[rng.choice(n, n_drop, replace=False)] = False
        yield A, C, l, used


def test_random_geometries_match_whitened_lstsq() -> None:
    """400 seeded cases, n 3..12, u 2/3, correlated blocks, random exclusions: one GN step on a
    linear model equals lstsq on L⁻¹A x = L⁻¹l (C_l = LLᵀ over the used block) to 1e-9 relative
    (double precision with cond(N) ≲ 1e4 leaves ~1e-12), and Σ r_i = n_used − u to 1e-9."""
    checked = 0
    for A, C, l, used in _cases(7, 400):
        x0 = np.zeros(A.shape[1])
        adj = gauss_newton(lambda x, A=A, C=C, l=l: Linearisation(A, l - A @ x, C), x0, used,
                           epsilon=1e-12, max_iter=3)
        Au, lu = A[used], l[used]
        L = np.linalg.cholesky(C[np.ix_(used, used)])
        x_ref, *_ = np.linalg.lstsq(np.linalg.solve(L, Au), np.linalg.solve(L, lu), rcond=None)
        assert adj.ok, adj.reason
        scale = max(1.0, float(np.max(np.abs(x_ref))))
        np.testing.assert_allclose(adj.x, x_ref, rtol=0, atol=1e-9 * scale)
        Aw = np.linalg.solve(L, Au)
        np.testing.assert_allclose(adj.cov_x, np.linalg.inv(Aw.T @ Aw), rtol=1e-9, atol=1e-12)
        assert float(np.nansum(adj.redundancy_numbers)) == pytest.approx(
            used.sum() - A.shape[1], abs=1e-9)
        assert np.all(np.isnan(adj.w[~used])) and np.all(np.isnan(adj.v[~used]))
        checked += 1
    assert checked == 400


def test_w_equals_closed_form_for_diagonal_cl() -> None:
    """Uncorrelated C_l: w_i = −v_i/(σ_i·sqrt(r_i)), σ_d = σ_i/sqrt(r_i), τ = 1/sqrt(r_i) and
    VF = 1 − r_i (THEORY §6.1–6.2), from the full-matrix formulas; 300 random cases, 1e-9."""
    rng = np.random.default_rng(11)
    for _ in range(300):
        u = int(rng.choice([2, 3]))
        n = int(rng.integers(u + 2, 13))
        A = rng.normal(size=(n, u))
        sig = rng.uniform(0.5, 30.0, n)
        C = np.diag(sig**2)
        l = rng.normal(size=n) * sig
        adj = gauss_newton(lambda x, A=A, C=C, l=l: Linearisation(A, l - A @ x, C),
                           np.zeros(u), np.ones(n, bool), epsilon=1e-12, max_iter=3)
        r = adj.redundancy_numbers
        np.testing.assert_allclose(adj.w, -adj.v / (sig * np.sqrt(r)), rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(adj.sigma_d, sig / np.sqrt(r), rtol=1e-9)
        np.testing.assert_allclose(adj.tau, 1.0 / np.sqrt(r), rtol=1e-9)
        np.testing.assert_allclose(adj.vf, 1.0 - r, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------------------------------
# Non-linear model: distances to known points


def _distances(stations: np.ndarray, truth: np.ndarray, sigma: float = 2.0):
    obs = np.linalg.norm(stations - truth, axis=1)
    C = np.eye(len(stations)) * sigma**2

    def lin(x: np.ndarray) -> Linearisation:
        d = x[None, :] - stations
        r = np.linalg.norm(d, axis=1)
        return Linearisation(d / r[:, None], obs - r, C)

    return lin


def test_nonlinear_distances_converge_from_2km() -> None:
    stations = np.array([[0.0, 0.0], [5000.0, 300.0], [4200.0, 6100.0], [-800.0, 4500.0]])
    truth = np.array([2200.0, 2600.0])
    lin = _distances(stations, truth)
    x0 = truth + np.array([1500.0, -1322.9])  # ≈ 2000 m away
    assert np.hypot(*(x0 - truth)) == pytest.approx(2000.0, abs=0.1)
    adj = gauss_newton(lin, x0, np.ones(4, bool))
    assert adj.ok and adj.iterations <= 10
    # default ε = 1 m: the last step is < 1 m, and Gauss–Newton's quadratic convergence leaves
    # an error ~ step²/range ≪ 1 cm with error-free data
    assert np.hypot(*(adj.x - truth)) < 0.01
    tight = gauss_newton(lin, x0, np.ones(4, bool), epsilon=1e-9)
    assert tight.ok and np.hypot(*(tight.x - truth)) < 1e-6
    assert list(tight.steps) == sorted(tight.steps, reverse=True)  # monotone shrinking steps


def test_three_parameter_fix() -> None:
    """u = 3: slant ranges to 6 points in 3-D converge to the true (x, y, z)."""
    st = np.array([[0, 0, 0], [4000, 0, 10], [0, 4000, -20], [4000, 4000, 30],
                   [2000, -1000, 800], [-1500, 2500, 400.0]])
    truth = np.array([1800.0, 2100.0, -150.0])
    obs = np.linalg.norm(st - truth, axis=1)

    def lin(x: np.ndarray) -> Linearisation:
        d = x[None, :] - st
        r = np.linalg.norm(d, axis=1)
        return Linearisation(d / r[:, None], obs - r, np.eye(6))

    adj = gauss_newton(lin, truth + [300.0, -200.0, 100.0], np.ones(6, bool), epsilon=1e-8)
    assert adj.ok and adj.u == 3 and adj.category == "IV"
    np.testing.assert_allclose(adj.x, truth, atol=1e-6)
    assert adj.ext.shape == (6, 3) and adj.cov_x.shape == (3, 3)


# ------------------------------------------------------------------------------------------
# Failures: never raise for bad geometry


def _const(A: np.ndarray, b: np.ndarray, C: np.ndarray):
    return lambda x: Linearisation(A, b, C)


def test_not_enough_lops() -> None:
    adj = gauss_newton(pg821, np.zeros(2), np.array([True, False, False, False, False]))
    assert not adj.ok and adj.reason == NOT_ENOUGH and adj.category == "I"
    assert adj.iterations == 0 and np.all(np.isnan(adj.cov_x))


def test_collinear_stations_with_point_on_the_line_is_singular() -> None:
    stations = np.array([[0.0, 0.0], [1000.0, 0.0], [2500.0, 0.0], [4000.0, 0.0]])
    lin = _distances(stations, np.array([1500.0, 0.0]))
    adj = gauss_newton(lin, np.array([1490.0, 0.0]), np.ones(4, bool))
    assert not adj.ok
    assert adj.reason is not None
    assert "singular" in adj.reason or "ill-conditioned" in adj.reason


def test_parallel_rows_and_near_parallel_rows() -> None:
    A = np.array([[1.0, 0.0], [2.0, 0.0], [-1.0, 0.0]])
    adj = gauss_newton(_const(A, np.ones(3), np.eye(3)), np.zeros(2), np.ones(3, bool))
    assert not adj.ok and adj.reason == "singular normal matrix"
    A2 = np.array([[1.0, 0.0], [1.0, 1e-7], [1.0, -1e-7]])
    adj2 = gauss_newton(_const(A2, np.ones(3), np.eye(3)), np.zeros(2), np.ones(3, bool))
    assert not adj2.ok and adj2.reason is not None and "ill-conditioned" in adj2.reason


def test_non_finite_and_model_errors_do_not_raise() -> None:
    A = np.array([[1.0, 0.0], [0.0, 1.0], [np.nan, 1.0]])
    adj = gauss_newton(_const(A, np.ones(3), np.eye(3)), np.zeros(2), np.ones(3, bool))
    assert not adj.ok and adj.reason == "non-finite linearisation"
    b = np.array([1.0, np.inf, 0.0])
    adj = gauss_newton(_const(np.eye(3)[:, :2], b, np.eye(3)), np.zeros(2), np.ones(3, bool))
    assert not adj.ok and adj.reason == "non-finite linearisation"

    def boom(x: np.ndarray) -> Linearisation:
        raise ValueError("math domain error")

    adj = gauss_newton(boom, np.zeros(2), np.ones(3, bool))
    assert not adj.ok and adj.reason == "model evaluation failed: math domain error"
    singular_c = np.ones((3, 3))
    adj = gauss_newton(_const(np.eye(3)[:, :2], np.ones(3), singular_c), np.zeros(2),
                       np.ones(3, bool))
    assert not adj.ok and adj.reason == "a priori VCV not invertible"


def test_no_convergence_keeps_last_x() -> None:
    """A constant b never lets δx̂ shrink: after max_iter steps of 5 m, ok=False."""
    A = np.eye(3)[:, :2]
    adj = gauss_newton(_const(A, np.array([5.0, 0.0, 0.0]), np.eye(3)), np.zeros(2),
                       np.ones(3, bool), max_iter=4)
    assert not adj.ok and adj.reason == "no convergence" and adj.iterations == 4
    np.testing.assert_allclose(adj.x, [20.0, 0.0])


def test_shape_mismatch_is_a_programming_error() -> None:
    with pytest.raises(ValueError, match="shapes"):
        gauss_newton(_const(np.eye(3), np.ones(3), np.eye(3)), np.zeros(2), np.ones(3, bool))


def test_scale_vcv_multiplies_by_s2(sample: Adjustment) -> None:
    scaled = gauss_newton(pg821, np.zeros(2), USED_PG, epsilon=50.0, scale_vcv=True)
    assert scaled.scaled and sample.s2 is not None
    np.testing.assert_allclose(scaled.cov_x, sample.cov_x * sample.s2, rtol=1e-12)
    np.testing.assert_allclose(scaled.x, sample.x)  # x̂ unchanged (THEORY §6.4)
    np.testing.assert_allclose(scaled.w, sample.w)  # tests use the a priori model


def test_uncontrolled_observation_is_not_testable() -> None:
    """Three LOPs fix East only, one fixes North alone: that one has r_i = 0 (nothing checks
    it), so σ_d = MDB = inf and w = NaN, while Σ r_i = r = 2 sits on the other three."""
    A = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    l = np.array([1.0, 2.0, 4.0, 7.0])
    adj = gauss_newton(lambda x: Linearisation(A, l - A @ x, np.eye(4)), np.zeros(2),
                       np.ones(4, bool), epsilon=1e-9)
    assert adj.ok and adj.category == "IV"
    np.testing.assert_allclose(adj.x, [7.0 / 3.0, 7.0])
    assert math.isinf(adj.sigma_d[3]) and math.isinf(adj.mdb[3]) and math.isnan(adj.w[3])
    np.testing.assert_allclose(adj.redundancy_numbers, [2 / 3, 2 / 3, 2 / 3, 0.0], atol=1e-12)
    # the other three: w_i = −v_i/sqrt(r_i) with v = x̂ − l
    v = 7.0 / 3.0 - l[:3]
    np.testing.assert_allclose(adj.w[:3], -v / math.sqrt(2 / 3), rtol=1e-12)


def test_invalid_settings_are_programming_errors() -> None:
    """Settings no adjustment can run with raise ValueError (documented); data never does."""
    lin = _const(np.eye(3)[:, :2], np.ones(3), np.eye(3))
    used = np.ones(3, bool)
    for kw in ({"max_iter": 0}, {"max_iter": -1}, {"max_iter": 2.5}, {"epsilon": 0.0},
               {"epsilon": math.nan}, {"s02": -1.0}, {"cond_max": 1.0},
               {"max_axis_ratio": 0.5}, {"alpha": 0.0}, {"power": 1.0}):
        with pytest.raises(ValueError):
            gauss_newton(lin, np.zeros(2), used, **kw)  # type: ignore[arg-type]
    one = gauss_newton(lin, np.zeros(2), used, max_iter=1, epsilon=2.0)
    assert one.ok and one.iterations == 1  # max_iter = 1 is the smallest valid cap


@pytest.mark.parametrize("start", [(math.nan, 0.0), (math.inf, 1.0), (1e30, 1e30)])
def test_degenerate_start_points_do_not_raise(start: tuple[float, float]) -> None:
    """A non-finite start is refused up front; a start 1e30 m away makes the distance model's
    rows finite but the squared misclosures overflow to inf/NaN: ok=False, no exception."""
    stations = np.array([[0.0, 0.0], [5000.0, 300.0], [4200.0, 6100.0], [-800.0, 4500.0]])
    adj = gauss_newton(_distances(stations, np.array([2200.0, 2600.0])), np.array(start),
                       np.ones(4, bool))
    assert not adj.ok and adj.reason is not None
    if not math.isfinite(start[0]):
        assert adj.reason == "provisional point not finite" and adj.iterations == 0


# ------------------------------------------------------------------------------------------
# Conditioning: the parameter-scaled condition number and the horizontal axis ratio


def _two_lops(theta_deg: float) -> Callable[[np.ndarray], Linearisation]:
    """Two LOPs crossing at θ (unit normals at ±θ/2 from East), σ = 1 m, r = 0."""
    h = math.radians(theta_deg) / 2.0
    A = np.array([[math.cos(h), math.sin(h)], [math.cos(h), -math.sin(h)]])
    return _const(A, np.zeros(2), np.eye(2))


def test_axis_ratio_of_two_crossing_lops_is_cot_half_angle() -> None:
    """Hand calculation: N = Σ n nᵀ for unit normals at ±θ/2 is diag(2cos²(θ/2), 2sin²(θ/2)),
    so a/b = cot(θ/2). MAX_AXIS_RATIO = 1e4 ⇔ θ = 2·atan(1e-4) = 0.011459°: 0.0114° is refused
    (a/b = 10 051), 0.0116° accepted (a/b = 9 878). This N is diagonal, so its parameter-scaled
    condition number is 1: only the rotation-invariant axis ratio sees the degeneracy."""
    assert 2.0 * math.degrees(math.atan(1.0 / MAX_AXIS_RATIO)) == pytest.approx(0.011459, abs=1e-6)
    ok = gauss_newton(_two_lops(0.0116), np.zeros(2), np.ones(2, bool))
    assert ok.ok
    a, b = np.sqrt(np.linalg.eigvalsh(ok.cov_x)[::-1])
    assert a / b == pytest.approx(1.0 / math.tan(math.radians(0.0116) / 2.0), rel=1e-9)
    bad = gauss_newton(_two_lops(0.0114), np.zeros(2), np.ones(2, bool))
    assert not bad.ok and bad.reason is not None
    assert "nearly parallel" in bad.reason and "1.01e+04" in bad.reason
    off = gauss_newton(_two_lops(0.0114), np.zeros(2), np.ones(2, bool), max_axis_ratio=None)
    assert off.ok  # the numerical guard alone accepts it: the solve itself is exact


def test_scaled_condition_number_ignores_parameter_units() -> None:
    """u = 3, the third parameter an orientation-like unknown in units 1e8 times too small
    (every row's third column × 1e-8): the raw normal matrix's condition number grows by 1e16,
    the Jacobi-scaled one (COND_MAX) not at all, so the fix is accepted and the third
    parameter is simply 1e8 times larger, the first two unchanged."""
    rng = np.random.default_rng(5)
    A = rng.normal(size=(8, 3))
    l = rng.normal(size=8)
    base = gauss_newton(lambda x: Linearisation(A, l - A @ x, np.eye(8)), np.zeros(3),
                        np.ones(8, bool), epsilon=1e-9)
    As = A * np.array([1.0, 1.0, 1e-8])
    scaled = gauss_newton(lambda x: Linearisation(As, l - As @ x, np.eye(8)), np.zeros(3),
                          np.ones(8, bool), epsilon=1e-9)
    assert np.linalg.cond(As.T @ As) > 1e6 * COND_MAX  # an unscaled test would refuse it
    assert base.ok and scaled.ok
    np.testing.assert_allclose(scaled.x[:2], base.x[:2], rtol=1e-9)
    assert scaled.x[2] == pytest.approx(base.x[2] * 1e8, rel=1e-9)


def test_scaled_condition_number_refuses_a_nearly_dependent_column() -> None:
    """Column 2 = column 1 + 1e-6 noise: the scaled condition number is ≈ 1e12 > COND_MAX."""
    rng = np.random.default_rng(6)
    c1 = rng.normal(size=6)
    A = np.c_[c1, rng.normal(size=6), c1 + 1e-6 * rng.normal(size=6)]
    adj = gauss_newton(_const(A, np.ones(6), np.eye(6)), np.zeros(3), np.ones(6, bool))
    assert not adj.ok and adj.reason is not None
    assert adj.reason.startswith("ill-conditioned normal matrix (scaled condition number")


# ------------------------------------------------------------------------------------------
# A posteriori VCVs of the residuals and of the adjusted observations (5.5b–c, corrected)


def test_cov_v_and_cov_lhat_against_numpy() -> None:
    """300 random cases (correlated blocks, exclusions, u 2/3): C_l̂ = A (AᵀWA)⁻¹ Aᵀ recomputed
    with numpy from the used rows (1e-9 relative); C_l̂ + C_v = C_l; C_v W is idempotent (the
    residual projector); diag(C_v W) are the redundancy numbers and sum to n_used − u;
    diag(C_l̂)/diag(C_l) = VF (5.12). Unused rows and columns are NaN."""
    for A, C, l, used in _cases(17, 300):
        adj = gauss_newton(lambda x, A=A, C=C, l=l: Linearisation(A, l - A @ x, C),
                           np.zeros(A.shape[1]), used, epsilon=1e-12, max_iter=3)
        assert adj.ok
        Au, Cu = A[used], C[np.ix_(used, used)]
        Wu = np.linalg.inv(Cu)
        lhat = Au @ np.linalg.solve(Au.T @ Wu @ Au, Au.T)
        scale = float(np.max(np.abs(Cu)))
        np.testing.assert_allclose(adj.cov_lhat_used, lhat, rtol=1e-9, atol=1e-12 * scale)
        np.testing.assert_allclose(adj.cov_v_used, Cu - lhat, rtol=1e-9, atol=1e-9 * scale)
        np.testing.assert_allclose(adj.cov_v_used + adj.cov_lhat_used, Cu, rtol=1e-12,
                                   atol=1e-12 * scale)
        P = adj.cov_v_used @ Wu
        np.testing.assert_allclose(P @ P, P, atol=1e-9)
        assert float(np.trace(P)) == pytest.approx(used.sum() - A.shape[1], abs=1e-9)
        np.testing.assert_allclose(np.diag(P), adj.redundancy_numbers[used], atol=1e-9)
        np.testing.assert_allclose(np.diag(adj.cov_lhat_used) / np.diag(Cu), adj.vf[used],
                                   rtol=1e-9, atol=1e-12)
        assert np.isnan(adj.cov_v[~used]).all() and np.isnan(adj.cov_lhat[:, ~used]).all()
        np.testing.assert_array_equal(adj.cov_v[np.ix_(used, used)], adj.cov_v_used)


def test_cov_lhat_of_the_worked_example(sample: Adjustment) -> None:
    """Pg 633 inputs: VF = (C_l̂)_ii/(C_l)_ii = 0.079, 0.326, 0.638, 0.948 (THEORY §6.2, 3 dp).
    The GPS block of C_l̂ is C_x̂ itself, reordered (rows (0, 1) and (1, 0)): Pg 641's VCV."""
    lhat = sample.cov_lhat_used
    np.testing.assert_allclose(np.diag(lhat) / np.diag(sample.Cl_used),
                               [0.079, 0.326, 0.638, 0.948], atol=0.0005)
    np.testing.assert_allclose(lhat[:2, :2], [[196.755, -298.408], [-298.408, 814.936]],
                               atol=0.002)
    assert float(np.trace(sample.cov_v_used @ sample.W_used)) == pytest.approx(2.0, abs=1e-12)
    assert np.isnan(sample.cov_v[4]).all()  # Purple deselected
