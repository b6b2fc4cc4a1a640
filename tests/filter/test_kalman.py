"""Unit tests of engine/filter/kalman.py against thesis numbers (THEORY §8.7, §14.4–14.5), the
Theseus closed forms (seed 000, THEORY §11.3) and independent numpy computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import chi2

from engine.filter import kalman as kf

KN = 1852.0 / 3600.0  # m/s per knot (THEORY §8.4)
D = math.pi / 180.0


def _example_state(params: kf.FilterParams | None = None) -> kf.FilterState:
    """The §6.10 state: v = 12.7 kn, ψ = 232.4°, ε = 0, P₀ = I (thesis)."""
    p = params or kf.FilterParams()
    return kf.init_state(0.0, 0.0, 0.0, 0.0, 12.7 * KN, 232.4 * D, 0.0, 0.0, 0.0, p)


def _sym_psd_min_eig(P: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(0.5 * (P + P.T)).min())


# ------------------------------------------------------------------------------------------
# Thesis numbers (§6.10, §6.6)
# ------------------------------------------------------------------------------------------


def test_phi_gamma_rows_match_section_6_10() -> None:
    s = _example_state()
    Phi = kf.transition(s.x, 1.0)
    Gam = kf.noise_gain(s.x, 1.0)
    # THEORY §8.7 prints 5 decimals: tolerance half a unit in the last place.
    phi_xyz = [
        [1, 0, 0, -0.79229, -3.98635, 0, 1, 0],
        [0, 1, 0, -0.61015, 5.17638, 0, 0, 1],
        [0, 0, 1, 0, 0, 6.53344, 0, 0],
    ]
    gam_xyz = [
        [-0.39614, -1.99317, 0, 0.5, 0],
        [-0.30507, 2.58819, 0, 0, 0.5],
        [0, 0, 3.26672, 0, 0],
    ]
    np.testing.assert_allclose(Phi[:3, :8], phi_xyz, atol=5e-6)
    np.testing.assert_allclose(Gam[:3, :5], gam_xyz, atol=5e-6)
    # Every other entry: Φ rows 3–10 are the identity, Γ rows 3–10 are Δt·I₈ (6.31, 6.32).
    np.testing.assert_array_equal(Phi[3:], np.eye(11)[3:])
    np.testing.assert_array_equal(Gam[3:], np.eye(8))
    # F² = 0, so Φ(Δt) = I + FΔt is exact: Φ(2) = Φ(1)².
    np.testing.assert_allclose(kf.transition(s.x, 2.0), Phi @ Phi, atol=1e-12)


def test_p_1_0_position_block_from_identity() -> None:
    """§6.10's P₁|₀ is computed with the thesis Γ Q Γᵀ (6.32, q per 1-s step)."""
    p = kf.FilterParams(q_mode="thesis")
    s = _example_state(p)
    s1 = kf.predict(s, 1.0, p)
    # THEORY §8.7 prints 3 decimals: tolerance half a unit in the last place.
    np.testing.assert_allclose(
        s1.P[:3, :3], [[18.520, -20.151, 0], [-20.151, 29.168, 0], [0, 0, 43.686]], atol=5e-4
    )
    Phi = kf.transition(s.x, 1.0)
    gqg = s1.P[:3, :3] - (Phi @ Phi.T)[:3, :3]
    # "The Γ Q Γᵀ contribution to that block is only about 10⁻³ m²".
    assert 1e-4 < np.abs(gqg).max() < 2e-3
    # The default "vanloan" mode (A5) differs at Δt = 1 s only in the position block, by the
    # exact integral's F M Fᵀ Δt³/3 instead of Γ's Δt³/4: + F[:3, 3:] diag(q) F[:3, 3:]ᵀ / 12.
    d = kf.FilterParams()
    assert d.q_mode == "vanloan"
    F = kf.jacobian(s.x)[:3, 3:]
    q = np.diag(kf.process_noise(d, 1.0))
    extra = (F * q) @ F.T / 12.0
    np.testing.assert_allclose(kf.predict(s, 1.0, d).P[:3, :3] - s1.P[:3, :3], extra,
                               rtol=1e-9, atol=1e-12)
    assert np.abs(extra).max() < 5e-4  # below the printed 3 decimals' half unit


def test_noise_variances_recomputed_from_thesis_inputs() -> None:
    # eq. 6.35: a_max 0.25 m/s², p_max 0.01, p₀ 0.75 -> 0.0625/3 × 0.29 = 0.0060417 ≈ 0.00604.
    sa2 = kf.accel_variance(0.25, 0.01, 0.75)
    assert sa2 == pytest.approx(0.0625 / 3 * 0.29, rel=1e-15)
    assert round(sa2, 5) == 0.00604
    assert kf.FilterParams().sigma_a2 == sa2
    # §6.6: V_cm = 1 m/s, semi-diurnal 12 h 30 min: σ = ½ V_cm (ω_v + ω_ψ) -> 1.95·10⁻⁸ (3 s.f.).
    sc2 = kf.current_rate_variance(1.0, 12.5 * 3600.0)
    assert sc2 == pytest.approx(1.95e-8, abs=5e-11)
    assert kf.FilterParams().sigma_current2 == 2e-8  # the thesis's rounded value (L2635)


# ------------------------------------------------------------------------------------------
# Pg 641 dead-reckoning reproduction (§10.5)
# ------------------------------------------------------------------------------------------

START_GRID = (-33699.25, 5856313.41)  # 52°50'00"N 004°30'00"E, ED50, CM 5°E
KF_ROW = (-33709.65, 5856305.50)  # Pg 641 "KF" row


def _convergence() -> float:
    """γ = arctan(tan(λ − λ₀) sin φ) at the start position (THEORY §8.4), rad."""
    phi = (52.0 + 50.0 / 60.0) * D
    return math.atan(math.tan((4.5 - 5.0) * D) * math.sin(phi))


def test_pg641_dead_reckoning_with_grid_heading() -> None:
    gam = _convergence()
    assert gam / D == pytest.approx(-0.3985, abs=1e-4)
    v = 12.7 * KN
    # Pure DR (the "KF" row with Filter N/A, A2/A3): each record's gyro is the heading of the
    # 1-s step it triggers (records 083538: 232.4°, 083539: 232.3° true).
    x = np.array([*START_GRID, 0.0, v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    for gyro in (232.4, 232.3):
        x[4] = gyro * D - gam
        x = kf.propagate_mean(x, 1.0)
    # ±0.01 m: the thesis prints centimetres.
    assert x[0] == pytest.approx(KF_ROW[0], abs=0.01)
    assert x[1] == pytest.approx(KF_ROW[1], abs=0.01)
    # Without the grid conversion the result is (−33709.60, 5856305.43): the γ step matters.
    y = np.array([*START_GRID, 0.0, v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    for gyro in (232.4, 232.3):
        y[4] = gyro * D
        y = kf.propagate_mean(y, 1.0)
    assert math.hypot(y[0] - KF_ROW[0], y[1] - KF_ROW[1]) > 0.05


def test_pg641_through_the_filter_sensor_update_then_propagate() -> None:
    """The EKF cycle: start at record 1 (ψ = its gyro in grid), propagate 1 s; record 2: sensor
    update (gyro, log) then propagate 1 s. With the thesis P₀ = I the gyro innovation −0.1° is
    split equally between ψ and Δψ (P_ψψ = P_ΔψΔψ), and the ψ–x correlation built in step 1
    moves the position as if step 1 had been steered at 232.35°; the two steps then sum to the
    same displacement as 232.4° + 232.3° (to first order), so the Pg 641 row reproduces."""
    p = kf.FilterParams()
    gam = _convergence()
    v = 12.7 * KN
    s = kf.init_state(0.0, *START_GRID, 0.0, v, 232.4 * D - gam, 0.0, 0.0, 0.0, p)
    s = kf.predict(s, 1.0, p)
    m = kf.sensor_measurement(s, log_ms=v, gyro_grid_rad=232.3 * D - gam, params=p)
    s = kf.update(s, m, p).state
    assert (s.x[4] + gam) / D == pytest.approx(232.35, abs=1e-4)
    s = kf.predict(s, 1.0, p)
    assert s.t == 2.0
    assert s.x[0] == pytest.approx(KF_ROW[0], abs=0.01)
    assert s.x[1] == pytest.approx(KF_ROW[1], abs=0.01)


# ------------------------------------------------------------------------------------------
# Prediction (§4, A5, A6)
# ------------------------------------------------------------------------------------------


def _moving_state(p: kf.FilterParams) -> kf.FilterState:
    return kf.init_state(0.0, 1e3, 2e3, 30.0, 6.5, 232.4 * D, 2.0 * D, 0.1, 0.2, p)


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_vanloan_prediction_is_step_size_invariant() -> None:
    """One 600-s step = 600 one-second steps (1e-6 relative) in "vanloan" mode: its Φ is exact
    (F² = 0) and its Q_d is the exact integral, so the semigroup property holds while F stays
    constant (the mean changes only x, y, z, not v, ψ, ε, so the re-linearisation point of
    every step is the same)."""
    p = kf.FilterParams(q_mode="vanloan")
    s = _moving_state(p)
    one = kf.predict(s, 600.0, p)
    many = kf.predict_horizon(s, 600.0, 1.0, p)[-1]
    assert _rel(one.P, many.P) < 1e-6
    np.testing.assert_allclose(one.x, many.x, rtol=0, atol=1e-6)


def test_psd_and_thesis_modes_step_size_dependence() -> None:
    """"psd" (Q·1 s/Δt, A5) makes the accumulated rate noise step-invariant, but its Γ holds each
    rate over the step, so a single step gives ∫ position noise Δt³/4 instead of the exact Δt³/3:
    1 s vs 10 s steps agree within 1e-5 (A5 asks 1 %), one 600-s step is off by ≈ 0.6 %.
    "thesis" (Q per step) gives velocity variance σ_a² h² per step, i.e. σ_a² T h in total: a
    600-s single step has 600× the noise of 600 one-second steps."""
    p = kf.FilterParams(q_mode="psd")
    s = _moving_state(p)
    h1 = kf.predict_horizon(s, 600.0, 1.0, p)[-1]
    h10 = kf.predict_horizon(s, 600.0, 10.0, p)[-1]
    assert _rel(h10.P, h1.P) < 1e-5
    assert 1e-3 < _rel(kf.predict(s, 600.0, p).P, h1.P) < 2e-2

    t = kf.FilterParams(q_mode="thesis")
    st = _moving_state(t)
    dv_one = kf.predict(st, 600.0, t).P[3, 3] - st.P[3, 3]
    dv_many = kf.predict_horizon(st, 600.0, 1.0, t)[-1].P[3, 3] - st.P[3, 3]
    assert dv_one / dv_many == pytest.approx(600.0, rel=1e-9)
    assert dv_many == pytest.approx(600.0 * t.sigma_a2, rel=1e-9)


def test_vanloan_closed_form_equals_matrix_exponential() -> None:
    p = kf.FilterParams(q_mode="vanloan", bias_noise=True)
    x = _moving_state(p).x
    F = kf.jacobian(x)
    M = np.zeros((11, 11))
    M[3:, 3:] = kf.process_noise(p, 600.0)  # PSD in this mode
    Phi, Qd = kf.van_loan(F, M, 600.0)  # scipy expm of the 22×22 Van Loan matrix
    assert _rel(kf.discrete_noise(x, 600.0, p), Qd) < 1e-10
    np.testing.assert_allclose(kf.transition(x, 600.0), Phi, atol=1e-9)


def test_predict_horizon_leaves_input_and_shortens_last_step() -> None:
    p = kf.FilterParams(q_mode="psd")
    s = _moving_state(p)
    x0, P0 = s.x.copy(), s.P.copy()
    out = kf.predict_horizon(s, 605.0, 10.0, p)
    assert len(out) == 61  # ceil(605/10)
    assert [o.t for o in out[-3:]] == [590.0, 600.0, 605.0]
    np.testing.assert_array_equal(s.x, x0)
    np.testing.assert_array_equal(s.P, P0)
    with pytest.raises(ValueError):
        s.P[0, 0] = 0.0  # read-only: a state is an immutable value
    # the output equals repeated propagation (THEORY §14.5 item 8)
    r = s
    for _ in range(60):
        r = kf.predict(r, 10.0, p)
    r = kf.predict(r, 5.0, p)
    np.testing.assert_array_equal(r.x, out[-1].x)
    np.testing.assert_array_equal(r.P, out[-1].P)


def test_hold_course_mode_has_no_v_psi_eps_noise() -> None:
    p = kf.FilterParams(hold_course=True)
    s = _moving_state(p)
    Q = kf.discrete_noise(s.x, 1.0, p)
    assert np.all(Q[3:6] == 0) and np.all(Q[:, 3:6] == 0)
    assert Q[6, 6] == pytest.approx(2e-8) and Q[0, 0] > 0  # current noise remains
    assert kf.predict(s, 100.0, p).P[4, 4] == s.P[4, 4]


def test_q_scale_scales_the_process_noise() -> None:
    x = _moving_state(kf.FilterParams()).x
    Q1 = kf.discrete_noise(x, 1.0, kf.FilterParams())
    Q5 = kf.discrete_noise(x, 1.0, kf.FilterParams(q_scale=5.0))
    np.testing.assert_allclose(Q5, 5.0 * Q1, rtol=1e-14)


# ------------------------------------------------------------------------------------------
# Theseus error growth (seed 000, THEORY §11.3)
# ------------------------------------------------------------------------------------------

V0 = 4.0 * KN  # inferred mission speed (THEORY §11.3)
ROCKWELL = dict(R0=10.0, Rd=100.0, dV=0.01 * V0, phi0=0.2 * D, eps0=0.04 * D / 3600.0,
                mua=0.05 * D / 60.0, mud=0.005 * D / 3600.0**1.5)
REFINED = dict(R0=10.0, Rd=130.0, dV=0.001 * V0, phi0=0.2 * D, eps0=0.0,
               mua=0.003 * D / 60.0, mud=0.001 * D / 3600.0**1.5)


def _out_eq7(c: dict, T: float) -> float:
    return math.sqrt(c["R0"] ** 2 + (T * c["dV"]) ** 2 + (V0 * T * c["phi0"]) ** 2
                     + V0**2 * T**4 * c["eps0"] ** 2 / 4 + V0**2 * c["mua"] ** 2 * T**3 / 3
                     + V0**2 * c["mud"] ** 2 * T**5 / 20)


def _in_eq13(c: dict, T: float, Tp: float) -> float:
    d = Tp - T
    return math.sqrt(c["Rd"] ** 2 + (d / T) ** 2 * c["R0"] ** 2
                     + Tp**2 / 4 * d**2 * V0**2 * c["eps0"] ** 2
                     + Tp / 3 * d**2 * V0**2 * c["mua"] ** 2
                     + Tp / 60 * d**2 * (3 * Tp**2 + 6 * T * Tp - T**2) * V0**2 * c["mud"] ** 2)


@pytest.mark.parametrize(
    ("c", "outbound", "inbound"),
    [(ROCKWELL, (547, 1178, 2935), (100, 682, 1632, 2870, 4400)),
     (REFINED, (182, 364, 735), (130, 143, 199, 302, 450))],
)
def test_theseus_closed_form_and_covariance_propagation(
    c: dict, outbound: tuple, inbound: tuple
) -> None:
    T = 200e3 / V0
    # (1) the paper's formulas (eq 7 at 50/100/200 km, eq 13 at 0…200 km back) reproduce its
    # numbers to the metre they are quoted to (THEORY §11.3 table).
    out = [_out_eq7(c, km * 1e3 / V0) for km in (50, 100, 200)]
    back = [_in_eq13(c, T, T + km * 1e3 / V0) for km in (0, 50, 100, 150, 200)]
    np.testing.assert_allclose(out, outbound, atol=1.0)
    np.testing.assert_allclose(back, inbound, atol=1.0)

    # (2) the same growth by covariance propagation of the heading-error state model
    # s = (δY, b, φ, r): δẎ = b + V0 φ, ḃ = 0, φ̇ = r + w_a, ṙ = w_d (PSDs μ_a², μ_d²),
    # discretised with kalman.van_loan in 1600 steps per leg. Spec tolerance: < 0.1 %.
    F = np.zeros((4, 4))
    F[0, 1], F[0, 2], F[2, 3] = 1.0, V0, 1.0
    Qc = np.diag([0.0, 0.0, c["mua"] ** 2, c["mud"] ** 2])
    n = 1600
    Phi, Qd = kf.van_loan(F, Qc, T / n)
    P = np.diag([c["R0"] ** 2, c["dV"] ** 2, c["phi0"] ** 2, c["eps0"] ** 2])
    sig = {}
    for k in range(1, n + 1):
        P = Phi @ P @ Phi.T + Qd
        sig[k] = math.sqrt(P[0, 0])
    np.testing.assert_allclose([sig[n // 4], sig[n // 2], sig[n]], out, rtol=1e-3)

    # Far end: position reset to δR_d (new, independent) and the heading correction
    # c = δY_out/T applied as a constant rate on the way back: δẎ = b + V0 φ − c.
    J = np.zeros((5, 4))
    J[1, 1] = J[2, 2] = J[3, 3] = 1.0
    J[4, 0] = 1.0 / T
    P5 = J @ P @ J.T
    P5[0, 0] += c["Rd"] ** 2
    F5 = np.zeros((5, 5))
    F5[:4, :4] = F
    F5[0, 4] = -1.0
    Phi5, Qd5 = kf.van_loan(F5, np.diag([0.0, 0.0, c["mua"] ** 2, c["mud"] ** 2, 0.0]), T / n)
    ret = [math.sqrt(P5[0, 0])]
    for k in range(1, n + 1):
        P5 = Phi5 @ P5 @ Phi5.T + Qd5
        if k % (n // 4) == 0:
            ret.append(math.sqrt(P5[0, 0]))
    np.testing.assert_allclose(ret, back, rtol=1e-3)


# ------------------------------------------------------------------------------------------
# Update, tests, invariants
# ------------------------------------------------------------------------------------------


def _filtered_state(p: kf.FilterParams) -> kf.FilterState:
    """A few cycles of a realistic run, so that P has cross-correlations."""
    s = kf.init_state(0.0, 0.0, 0.0, 20.0, 6.5, 1.0, 0.0, 0.1, 0.0, p, pos_cov=np.eye(2) * 900)
    for k in range(20):
        s = kf.predict(s, 1.0, p)
        m = kf.nav_measurement(s, p, fix_xy=(6.5 * (k + 1), 3.0), fix_cov=np.eye(2) * 900.0,
                               depth_m=20.0, log_ms=6.5, gyro_grid_rad=1.0, incl_rad=0.0)
        s = kf.update(s, m, p).state
    return kf.predict(s, 1.0, p)


def test_update_matches_textbook_kalman_equations() -> None:
    """v̂, S, K, x̂⁺ and P⁺ against an independent numpy evaluation of 6.21 / 6.37."""
    p = kf.FilterParams()
    s = _filtered_state(p)
    C = np.array([[814.936, -298.408], [-298.408, 196.756]])  # Pg 641 LSE VCV
    m = kf.nav_measurement(s, p, fix_xy=(s.x[0] + 20.0, s.x[1] - 5.0), fix_cov=C,
                           depth_m=21.0, log_ms=6.6, gyro_grid_rad=1.01)
    r = kf.update(s, m, p)
    H, R = m.H, m.R
    v = m.z - H @ s.x
    S = H @ s.P @ H.T + R
    K = s.P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(r.innovation, v, atol=1e-12)
    np.testing.assert_allclose(r.S, S, rtol=1e-12)
    np.testing.assert_allclose(r.K, K, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(r.state.x, s.x + K @ v, rtol=1e-12)
    P_std = (np.eye(11) - K @ H) @ s.P
    np.testing.assert_allclose(r.state.P, 0.5 * (P_std + P_std.T), rtol=1e-7, atol=1e-9)
    # the thesis form (joseph=False) gives the same P for the optimal gain
    r2 = kf.update(s, m, kf.FilterParams(joseph=False))
    np.testing.assert_allclose(r2.state.P, r.state.P, rtol=1e-7, atol=1e-9)
    # R block: the full 2×2 LSE VCV (6.36)
    np.testing.assert_array_equal(m.R[:2, :2], C)
    assert m.labels == ("x_LSE", "y_LSE", "z_p", "v_m", "psi_m")


def test_nav_measurement_equals_stacked_building_blocks() -> None:
    p = kf.FilterParams()
    s = _filtered_state(p)
    C = np.array([[100.0, 20.0], [20.0, 50.0]])
    a = kf.nav_measurement(s, p, fix_xy=(1.0, 2.0), fix_cov=C, log_ms=6.0, gyro_grid_rad=0.5,
                           incl_rad=0.01, depth_m=3.0)
    b = kf.stack_measurements(
        kf.lse_measurement(1.0, 2.0, C),
        kf.sensor_measurement(s, depth_m=3.0, log_ms=6.0, gyro_grid_rad=0.5, incl_rad=0.01,
                              params=p))
    for f in ("z", "H", "R"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert a.labels == b.labels and a.angle_rows == b.angle_rows == (4,)
    # log σ = max(0.02 v, floor) (4.19)
    assert a.R[3, 3] == pytest.approx((0.02 * 6.0) ** 2)
    low = kf.sensor_measurement(s, log_ms=0.5, params=p)
    assert low.R[0, 0] == pytest.approx(0.05**2)


def test_infinite_r_leaves_state_unchanged() -> None:
    p = kf.FilterParams()
    s = _filtered_state(p)
    m = kf.nav_measurement(s, p, fix_xy=(s.x[0] + 500.0, s.x[1] - 300.0),
                           fix_cov=np.eye(2) * 1e12, log_ms=9.0)
    m = kf.Measurement(m.z, m.H, np.eye(3) * 1e12, m.labels, m.angle_rows)
    r = kf.update(s, m, p)
    np.testing.assert_allclose(r.state.x, s.x, rtol=0, atol=1e-6)
    np.testing.assert_allclose(r.state.P, s.P, rtol=1e-6, atol=1e-9)


def test_heading_innovation_wraps_and_heading_stays_in_range() -> None:
    p = kf.FilterParams()
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 5.0, 359.9 * D, 0.0, 0.0, 0.0, p)
    r = kf.update(s, kf.sensor_measurement(s, gyro_grid_rad=0.1 * D, params=p), p)
    assert r.innovation[0] == pytest.approx(0.2 * D, abs=1e-12)
    assert 0.0 <= r.state.x[4] < 2 * math.pi
    # P0 = I: the gain on ψ is P_ψψ/(P_ψψ + P_ΔψΔψ + σ²) ≈ ½ -> ψ moves from 359.9° to ≈ 0.0°
    assert r.state.x[4] < 0.01 * D or r.state.x[4] > 2 * math.pi - 0.01 * D


def test_lom_ls_against_chi2_and_w_thresholds() -> None:
    # table vs scipy, and the spec's bounds on n·T for n = 1…6 (THEORY §8.14, 3–4 s.f.)
    for p in range(1, 23):  # p ≤ 20 from the built-in table, above from scipy
        t = kf.lom_test(np.ones(p), np.eye(p))
        assert t.t == pytest.approx(1.0) and t.verdict == "accept" and t.dof == p
        assert t.lower * p == pytest.approx(chi2.ppf(0.025, p), rel=1e-5)
        assert t.upper * p == pytest.approx(chi2.ppf(0.975, p), rel=1e-5)
    t99 = kf.lom_test(np.ones(3), np.eye(3), alpha=0.01)
    assert t99.upper * 3 == pytest.approx(chi2.ppf(0.995, 3), rel=1e-9)
    spec = [(0.00098, 5.024), (0.0506, 7.378), (0.216, 9.348), (0.484, 11.143), (0.831, 12.833),
            (1.237, 14.449)]
    for p, (lo, hi) in enumerate(spec, start=1):
        t = kf.lom_test(np.zeros(p), np.eye(p))
        assert t.lower * p == pytest.approx(lo, abs=6e-4)
        assert t.upper * p == pytest.approx(hi, abs=6e-4)
        assert t.verdict == "too small"
    # Choose v = L u, L = chol(S): then vᵀS⁻¹v = |u|² exactly.
    S = np.array([[4.0, 1.0, 0.5], [1.0, 2.0, 0.3], [0.5, 0.3, 1.0]])
    L = np.linalg.cholesky(S)
    assert kf.lom_test(L @ np.array([1.0, 1.0, 1.0]), S).verdict == "accept"  # 3·T = 3
    big = kf.lom_test(L @ np.array([0.0, 0.0, 4.0]), S)  # 3·T = 16 > 9.348
    assert big.verdict == "reject" and big.t == pytest.approx(16.0 / 3.0)
    # LS statistic against an independent inverse; flags at 1.960 / 2.576
    v = L @ np.array([0.2, -0.5, 4.0])
    Si = np.linalg.inv(S)
    t_ref = (Si @ v) / np.sqrt(np.diag(Si))
    ls = kf.ls_test(v, S, lom_reject=True)
    np.testing.assert_allclose(ls.t, t_ref, rtol=1e-12)
    assert ls.identified == int(np.argmax(np.abs(t_ref)))
    assert kf.ls_test(v, S, lom_reject=False).identified is None  # only after LOM rejects
    flags = kf.ls_test(np.array([1.5, 2.2, 3.0, -2.6]), np.eye(4), lom_reject=True).flags
    assert flags == ("accept", "monitor", "reject", "reject")


def test_update_flags_an_outlier_row() -> None:
    p = kf.FilterParams()
    s = _filtered_state(p)
    good = kf.nav_measurement(s, p, depth_m=float(s.x[2]), log_ms=float(s.x[3] + s.x[8]),
                              gyro_grid_rad=float(s.x[4] + s.x[9]))
    r = kf.update(s, good, p)
    assert r.lom.verdict == "too small" and r.ls.identified is None  # zero innovation
    bad = kf.nav_measurement(s, p, depth_m=float(s.x[2]), log_ms=float(s.x[3] + s.x[8]) + 3.0,
                             gyro_grid_rad=float(s.x[4] + s.x[9]))
    r = kf.update(s, bad, p)
    assert r.lom.verdict == "reject"
    assert r.ls.identified == 1 and r.labels[1] == "v_m"
    assert r.ls.flags[1] == "reject"


def test_divergence_guard() -> None:
    p = kf.FilterParams()
    s = _filtered_state(p)
    m = kf.sensor_measurement(s, log_ms=6.5, params=p)
    neg = kf.Measurement(m.z, m.H, -np.eye(1) * 1e6, m.labels)
    with pytest.raises(kf.FilterDivergence) as err:
        kf.update(s, neg, p)
    assert err.value.state is s
    P = s.P.copy()
    P[10, 10] = -1.0  # a broken variance outside the measured rows
    bad = kf.FilterState(s.t, s.x.copy(), P)
    with pytest.raises(kf.FilterDivergence):
        kf.update(bad, m, p)


def test_empty_measurement_is_a_no_op() -> None:
    p = kf.FilterParams()
    s = _filtered_state(p)
    r = kf.update(s, kf.stack_measurements(), p)
    assert r.state is s and r.lom.verdict == "none"


def test_lop_rows_innovation_and_equivalence_to_lse() -> None:
    """Raw metric LOPs (THEORY §9.3): innovation = omc − A(x̂ − x_ref) − b; two orthogonal
    unit LOPs carry the same information as an LSE with the same VCV."""
    p = kf.FilterParams()
    s = _filtered_state(p)
    x_ref = s.x[:2] + np.array([3.0, -4.0])
    A = np.array([[0.6, 0.8], [-0.8, 0.6]])
    omc = np.array([12.0, -7.0])
    Rl = np.diag([400.0, 900.0])
    r = kf.update(s, kf.lop_measurement(A, omc, x_ref, Rl), p)
    np.testing.assert_allclose(r.innovation, omc - A @ (s.x[:2] - x_ref), atol=1e-9)
    # same information as an LSE: x_fix = x_ref + A⁻¹ omc with C = A⁻¹ R A⁻ᵀ
    Ai = np.linalg.inv(A)
    fix = x_ref + Ai @ omc
    r2 = kf.update(s, kf.lse_measurement(fix[0], fix[1], Ai @ Rl @ Ai.T), p)
    np.testing.assert_allclose(r.state.x, r2.state.x, atol=1e-7)
    np.testing.assert_allclose(r.state.P, r2.state.P, rtol=1e-8, atol=1e-9)
    # with a fix-error state b on row 0 (one GM state per Decca pattern): innovation − b
    sb = kf.add_fix_states(s, ("decca_red",), 100.0, p)
    sb = kf.FilterState(sb.t, np.r_[sb.x[:11], 5.0], sb.P, sb.fix_states, sb.fix_tau_s,
                        sb.fix_cov)
    rb = kf.update(sb, kf.lop_measurement(A, omc, x_ref, Rl, ("decca_red", None)), p)
    np.testing.assert_allclose(rb.innovation, omc - A @ (s.x[:2] - x_ref) - [5.0, 0.0],
                               atol=1e-9)
    # a missing key is added on first use when the rows carry its prior, else refused
    m2 = kf.lop_measurement(A, omc, x_ref, Rl, (None, "decca_green"), bias_cov=[[64.0]],
                            bias_tau_s=(600.0,))
    r3 = kf.update(s, m2, p)
    assert r3.state.fix_states == ("decca_green",) and r3.state.fix_tau_s == (600.0,)
    assert r3.K.shape == (12, 2)
    with pytest.raises(ValueError):
        kf.update(s, kf.lop_measurement(A, omc, x_ref, Rl, (None, "decca_green")), p)


# ------------------------------------------------------------------------------------------
# Coloured fix noise (thesis 6.3.2 / A6, THEORY §8.2)
# ------------------------------------------------------------------------------------------


def test_fix_states_gauss_markov_exact_discretisation() -> None:
    p = kf.FilterParams(coloured=True, fix_tau_s=240.0)
    s = _moving_state(p)
    C = np.array([[1440.0, 200.0], [200.0, 900.0]])
    s2 = kf.add_fix_states(s, ("fix_e", "fix_n"), C, p)
    assert s2.fix_states == ("fix_e", "fix_n") and s2.n == 13 and s2.fix_tau_s == (240.0, 240.0)
    np.testing.assert_array_equal(s2.P[11:, 11:], C)
    assert np.all(s2.P[:11, 11:] == 0) and np.all(s2.x[11:] == 0)
    assert kf.add_fix_states(s2, ("fix_e", "fix_n"), 1.0, p) is s2  # idempotent
    x = s2.x.copy()
    x[11:] = (10.0, -4.0)
    s3 = kf.FilterState(0.0, x, s2.P.copy(), s2.fix_states, s2.fix_tau_s, s2.fix_cov.copy())
    a = kf.predict(s3, 240.0, p)
    # mean decays by e^{−Δt/τ}; a stationary VCV stays stationary; no coupling to the nav states
    np.testing.assert_allclose(a.x[11:], np.array([10.0, -4.0]) / math.e, rtol=1e-14)
    np.testing.assert_allclose(a.P[11:, 11:], C, rtol=1e-12)
    assert np.all(a.P[:11, 11:] == 0)
    # exact discretisation: two steps of 120 s = one step of 240 s (GM block)
    b = kf.predict(kf.predict(s3, 120.0, p), 120.0, p)
    np.testing.assert_allclose(b.x[11:], a.x[11:], rtol=1e-13)
    # from a zero prior, Var after Δt is σ²(1 − e^{−2Δt/τ})
    s0 = kf.FilterState(0.0, x, np.diag(np.r_[np.diag(s2.P)[:11], 0.0, 0.0]), s2.fix_states,
                        s2.fix_tau_s, s2.fix_cov.copy())
    g = kf.predict(s0, 60.0, p)
    np.testing.assert_allclose(g.P[11:, 11:], C * (1 - math.exp(-120.0 / 240.0)), rtol=1e-12)
    np.testing.assert_allclose(kf.state_transition(s3, 60.0)[11:, 11:],
                               np.eye(2) * math.exp(-0.25), rtol=1e-14)


def test_coloured_lse_rows_and_white_part() -> None:
    p = kf.FilterParams(coloured=True, fix_sigma_frac=0.9, fix_tau_s=240.0)
    s = _moving_state(p)
    C = np.array([[1600.0, 300.0], [300.0, 900.0]])
    m = kf.lse_measurement(1.0, 2.0, C, p)
    np.testing.assert_allclose(m.R, 0.1 * C)  # the white part stays in R (§3.1 option (a))
    np.testing.assert_allclose(m.bias_cov, 0.9 * C)
    assert m.bias_keys == ("fix_e", "fix_n") and m.bias_tau_s == (240.0, 240.0)
    # first use: update adds the GM states with prior 0.9·C, then applies z = x + b + v
    r = kf.update(s, m, p)
    assert r.state.fix_states == ("fix_e", "fix_n") and r.state.n == 13
    prior = kf.add_fix_states(s, ("fix_e", "fix_n"), 0.9 * C, p)
    Hf = np.zeros((2, 13))
    Hf[0, 0] = Hf[1, 1] = Hf[0, 11] = Hf[1, 12] = 1.0
    S = Hf @ prior.P @ Hf.T + 0.1 * C
    np.testing.assert_allclose(r.S, S, rtol=1e-12)
    K = prior.P @ Hf.T @ np.linalg.inv(S)
    np.testing.assert_allclose(r.state.x, prior.x + K @ (m.z - Hf @ prior.x), rtol=1e-12)
    # with b already non-zero the innovation is z − (x + b)
    x = r.state.x.copy()
    x[11:] = (7.0, -3.0)
    s3 = kf.FilterState(0.0, x, r.state.P, r.state.fix_states, r.state.fix_tau_s,
                        r.state.fix_cov)
    r3 = kf.update(s3, m, p)
    np.testing.assert_allclose(r3.innovation, m.z - x[:2] - x[11:], atol=1e-12)
    # nav_measurement builds the same coloured rows (and the thesis model none)
    n = kf.nav_measurement(s, p, fix_xy=(1.0, 2.0), fix_cov=C, log_ms=6.0)
    st = kf.stack_measurements(m, kf.sensor_measurement(s, log_ms=6.0, params=p))
    for f in ("z", "H", "R", "bias_cov"):
        np.testing.assert_array_equal(getattr(n, f), getattr(st, f))
    assert n.bias_keys == st.bias_keys == ("fix_e", "fix_n", None)
    assert kf.lse_measurement(1.0, 2.0, C, kf.FilterParams()).bias_keys == ()
    # an 11-column measurement is zero-padded onto the augmented state
    r4 = kf.update(r.state, kf.sensor_measurement(s, log_ms=6.0, params=p), p)
    assert r4.state.n == 13


def test_fix_error_stationary_vcv_follows_each_fix() -> None:
    """The Gauss–Markov pair's stationary VCV is frac·C of the latest LSE, not of the first:
    after a C/A fix (C₁) and a P-code fix (C₂), the next prediction drives b towards frac·C₂,
    P_bb(Δt) = P_bb·ρ² + frac·C₂·(1 − ρ²), ρ = e^{−Δt/τ} (THEORY §8.2)."""
    p = kf.FilterParams(coloured=True, fix_tau_s=240.0, fix_sigma_frac=0.9)
    s = _moving_state(p)
    c1 = np.array([[734.0, -200.0], [-200.0, 177.0]]) / 0.9
    c2 = np.array([[63.0, -8.0], [-8.0, 40.0]]) / 0.9
    s1 = kf.update(s, kf.lse_measurement(1.0, 2.0, c1, p), p).state
    np.testing.assert_allclose(s1.fix_cov, 0.9 * c1, rtol=1e-12)
    s2 = kf.update(kf.predict(s1, 1.0, p), kf.lse_measurement(8.0, 4.0, c2, p), p).state
    np.testing.assert_allclose(s2.fix_cov, 0.9 * c2, rtol=1e-12)
    rho2 = math.exp(-2 * 60.0 / 240.0)
    s3 = kf.predict(s2, 60.0, p)
    np.testing.assert_allclose(s3.P[11:, 11:], s2.P[11:, 11:] * rho2 + 0.9 * c2 * (1 - rho2),
                               rtol=1e-12)


def test_restart_fix_states_is_a_zero_row_transition() -> None:
    """A new fix source: b = 0, P_bb = its stationary VCV, no correlation with the other states;
    the returned Φ has zero rows for b, so P' = Φ' P Φ'ᵀ + Q' with Q'_bb = C (smoother link)."""
    p = kf.FilterParams(coloured=True, fix_tau_s=240.0)
    s = _moving_state(p)
    s = kf.update(s, kf.lse_measurement(1.0, 2.0, np.eye(2) * 900.0, p), p).state
    start = kf.update(kf.predict(s, 1.0, p), kf.lse_measurement(9.0, 1.0, np.eye(2) * 900.0, p),
                      p).state
    pred, phi = kf.predict_step(start, 1.0, p)
    c = np.array([[60.0, -9.0], [-9.0, 40.0]])
    new, phi2 = kf.restart_fix_states(pred, ("fix_e", "fix_n"), c, phi)
    assert np.all(new.x[11:] == 0.0) and np.all(new.P[11:, :11] == 0.0)
    np.testing.assert_array_equal(new.P[11:, 11:], c)
    np.testing.assert_array_equal(new.fix_cov, c)
    np.testing.assert_array_equal(new.P[:11, :11], pred.P[:11, :11])
    assert np.all(phi2[11:] == 0.0)
    np.testing.assert_allclose(np.diag(phi)[11:], math.exp(-1.0 / 240.0))  # input untouched
    q = new.P - phi2 @ start.P @ phi2.T
    np.testing.assert_allclose(q[11:, 11:], c, rtol=1e-12)
    assert np.abs(q[:11, 11:]).max() < 1e-12
    # keys the state does not carry are ignored (they are added on first use)
    same, _ = kf.restart_fix_states(_moving_state(p), ("fix_e", "fix_n"), c)
    assert same.n == 11


def test_physical_p0_from_sensor_readings_correlates_state_and_bias() -> None:
    """ψ̂₀ = the gyro reading = ψ + Δψ + v: its error is Δψ + v, so P_ψψ = σ_g² + σ_b²,
    P_ψΔψ = −σ_b², while the sum ψ + Δψ keeps the reading's σ_g² (A7 values, eq. 6.28)."""
    p = kf.FilterParams(p0="physical")
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 1.0, 0.0, 0.0, 0.0, p,
                      from_sensors=(True, True, False))
    sg, sb = (0.65 * D) ** 2, D**2
    assert s.P[4, 4] == pytest.approx(sg + sb) and s.P[4, 9] == pytest.approx(-sb)
    h = np.zeros(11)
    h[4] = h[9] = 1.0
    assert h @ s.P @ h == pytest.approx(sg, rel=1e-12)
    assert s.P[3, 8] == pytest.approx(-0.01) and s.P[5, 10] == 0.0  # ε not from a sensor
    assert np.linalg.eigvalsh(s.P).min() > 0.0


# ------------------------------------------------------------------------------------------
# Set-up and a long run
# ------------------------------------------------------------------------------------------


def test_initial_covariances() -> None:
    assert np.array_equal(_example_state().P, np.eye(11))  # P₀ = I₁₁ (§6.8)
    p = kf.FilterParams(p0="physical")
    s = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 0.0, 0.0, 0.0, 0.0, p)
    expect = [1e6, 1e6, 1.45**2, 0.12**2, (0.65 * D) ** 2, (0.5 * D) ** 2, 0.25, 0.25, 0.01,
              D**2, (0.5 * D) ** 2]  # A7
    np.testing.assert_allclose(np.diag(s.P), expect, rtol=1e-12)
    C = np.array([[814.936, -298.408], [-298.408, 196.756]])
    s2 = kf.init_state(0.0, 0.0, 0.0, 0.0, 6.0, 7.0, 0.0, 0.0, 0.0, p, pos_cov=C)
    np.testing.assert_array_equal(s2.P[:2, :2], C)  # A3: P_xy = C_LSE
    assert s2.x[4] == pytest.approx(7.0 - 2 * math.pi)  # heading kept in [0, 2π)


def test_params_validation() -> None:
    for bad in (dict(q_mode="exact"), dict(p0="unit"), dict(fix_sigma_frac=1.0),
                dict(fix_tau_s=0.0), dict(alpha=0.0)):
        with pytest.raises(ValueError):
            kf.FilterParams(**bad)


def test_p_stays_symmetric_positive_definite_over_24_hours() -> None:
    """86,400 predict + update cycles at 1 Hz (thesis mode, P₀ = I): gyro, log, pressure and
    inclinometer every second, a 30-m LSE every 10 min. Synthetic sensor values follow a
    slowly weaving 6.5 m/s track (no truth comparison here, only the invariants)."""
    p = kf.FilterParams()
    rng = np.random.default_rng(86400)
    n = 86_400
    t = np.arange(n + 1, dtype=float)
    psi = (1.0 + 0.3 * np.sin(2 * math.pi * t / 3600.0)) % (2 * math.pi)
    xe = np.r_[0.0, np.cumsum(6.5 * np.sin(psi[:-1]))]  # x_{k+1} = x_k + v sin ψ_k (6.30)
    yn = np.r_[0.0, np.cumsum(6.5 * np.cos(psi[:-1]))]
    gyro = ((psi + 0.0113 * rng.standard_normal(n + 1)) % (2 * math.pi)).tolist()
    log = (6.5 + 0.13 * rng.standard_normal(n + 1)).tolist()
    depth = (10.0 + 1.45 * rng.standard_normal(n + 1)).tolist()
    incl = (0.0087 * rng.standard_normal(n + 1)).tolist()
    fx = (xe + 30.0 * rng.standard_normal(n + 1)).tolist()
    fy = (yn + 30.0 * rng.standard_normal(n + 1)).tolist()
    C = np.eye(2) * 900.0
    s = kf.init_state(0.0, fx[0], fy[0], 10.0, 6.5, gyro[0], 0.0, 0.0, 0.0, p, pos_cov=C)
    worst = math.inf
    for k in range(1, n + 1):
        s = kf.predict(s, 1.0, p)
        fix = (fx[k], fy[k]) if k % 600 == 0 else None
        m = kf.nav_measurement(s, p, fix_xy=fix, fix_cov=C, depth_m=depth[k], log_ms=log[k],
                               gyro_grid_rad=gyro[k], incl_rad=incl[k])
        s = kf.update(s, m, p).state
        if k % 3600 == 0:
            worst = min(worst, _sym_psd_min_eig(s.P))
    assert s.t == 86_400.0
    assert worst > 0.0 and _sym_psd_min_eig(s.P) > 0.0
    assert np.abs(s.P - s.P.T).max() < 1e-9
    # and the estimate still tracks the track (within 5 σ of the last fix-aligned truth)
    d = math.hypot(s.x[0] - xe[-1], s.x[1] - yn[-1])
    assert d < 5 * math.sqrt(s.P[0, 0] + s.P[1, 1])
