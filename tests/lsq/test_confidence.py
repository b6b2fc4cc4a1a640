"""Confidence regions (engine.lsq.confidence): thesis Tables 5.2/5.3, Pg 840/641,
numpy.linalg.eigh."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.lsq.confidence import drms, error_ellipse, error_ellipsoid, k_factor, two_drms

# Pg 641 a posteriori VCV of the MPP (x East, y North) [m²]
C_SAMPLE = np.array([[814.936, -298.408], [-298.408, 196.755]])


def test_k_factors_tables_5_2_and_5_3() -> None:
    # Table 5.2 (2-D): 50 % 1.177, 95 % 2.447, 99.9 % 3.717 (3 dp printed, ±0.0005);
    # THEORY §7.1: exact 2.4477 (4 dp, ±0.00005); P(k = 1) = 0.3935 (1 − e^−½)
    assert k_factor(0.5, 2) == pytest.approx(1.177, abs=0.0005)
    assert k_factor(0.95, 2) == pytest.approx(2.4477, abs=0.00005)
    assert k_factor(0.999, 2) == pytest.approx(3.717, abs=0.0005)
    assert k_factor(1.0 - math.exp(-0.5), 2) == pytest.approx(1.0, abs=1e-12)
    # Table 5.3 (3-D), 4 dp: 50 % 1.5382, 95 % 2.7955, 99.9 % 4.0332; standard P = 0.1987
    assert k_factor(0.5, 3) == pytest.approx(1.5382, abs=0.00005)
    assert k_factor(0.95, 3) == pytest.approx(2.7955, abs=0.00005)
    # Table 5.3 prints 4.0332, but χ²_3(0.999) = 16.266 (standard tables) gives
    # sqrt = 4.03314: the printed last digit is 0.6 units high. We keep the exact value.
    assert k_factor(0.999, 3) == pytest.approx(math.sqrt(16.266), abs=5e-5)
    assert k_factor(0.999, 3) == pytest.approx(4.0332, abs=1e-4)
    assert k_factor(0.198748, 3) == pytest.approx(1.0, abs=1e-5)
    # 2-D closed form equals the χ² route
    from scipy.stats import chi2

    assert k_factor(0.9, 2) == pytest.approx(math.sqrt(chi2.ppf(0.9, 2)), rel=1e-12)
    with pytest.raises(ValueError):
        k_factor(1.0, 2)


def test_sample_ellipse_pg840_pg641() -> None:
    e = error_ellipse(C_SAMPLE)
    # Pg 840 eigenvalues 935.48 / 76.21 (2 dp, ±0.005)
    assert e.eigenvalues[0] == pytest.approx(935.48, abs=0.005)
    assert e.eigenvalues[1] == pytest.approx(76.21, abs=0.005)
    # Pg 641 "Standard: 30.59 8.73", "95.0%: 74.87 21.37"; THEORY §7.1 99.9 % 113.68 × 32.45
    assert (e.a_m, e.b_m) == pytest.approx((30.59, 8.73), abs=0.005)
    assert e.scaled(0.95) == pytest.approx((74.87, 21.37), abs=0.005)
    assert e.scaled(0.999) == pytest.approx((113.68, 32.45), abs=0.005)
    # Pg 100/641 "Az 112.0" (1 dp), Pg 840 "0.00 0.00 −22.00" (φ, 2 dp)
    assert e.az_deg == pytest.approx(112.0, abs=0.05)
    assert e.phi_deg == pytest.approx(-22.00, abs=0.005)
    # Pg 840 rows of E: (0.92721, 0.37455) and (−0.37455, 0.92721), 5 dp
    np.testing.assert_allclose(e.eigenvectors, [[0.92721, 0.37455], [-0.37455, 0.92721]],
                               atol=5e-6)


def test_random_ellipses_against_eigh() -> None:
    rng = np.random.default_rng(5)
    for _ in range(300):
        M = rng.normal(size=(2, 2)) * rng.uniform(0.1, 100.0)
        C = M @ M.T + np.eye(2) * 1e-3
        e = error_ellipse(C)
        lam, _ = np.linalg.eigh(C)
        assert e.eigenvalues == pytest.approx((lam[1], lam[0]), rel=1e-9, abs=1e-12)
        E = e.eigenvectors
        np.testing.assert_allclose(E @ np.diag(e.eigenvalues) @ E.T, C, rtol=1e-9, atol=1e-9)
        assert np.linalg.det(E) == pytest.approx(1.0, abs=1e-12)
        assert 0.0 <= e.az_deg < 180.0
        # azimuth from North clockwise of the major axis (East, North) components
        assert e.az_deg == pytest.approx(math.degrees(math.atan2(E[0, 0], E[1, 0])), abs=1e-9)
        assert e.phi_deg == pytest.approx(90.0 - e.az_deg, abs=1e-9)


def test_degenerate_ellipses() -> None:
    iso = error_ellipse(np.eye(2) * 4.0)
    assert (iso.a_m, iso.b_m, iso.az_deg, iso.phi_deg) == (2.0, 2.0, 90.0, 0.0)
    north = error_ellipse(np.diag([1.0, 9.0]))
    assert north.az_deg == 0.0 and north.a_m == 3.0 and north.b_m == 1.0
    east = error_ellipse(np.diag([9.0, 1.0]))
    assert east.az_deg == 90.0
    flat = error_ellipse(np.array([[1.0, 1.0], [1.0, 1.0]]))  # singular: b = 0
    assert flat.b_m == pytest.approx(0.0, abs=1e-7) and flat.az_deg == pytest.approx(45.0)
    with pytest.raises(ValueError):
        error_ellipse(np.full((2, 2), np.nan))


def test_ellipsoid_2d_embedding_matches_pg840() -> None:
    """A horizontal ellipse in 3-D (σz = 0): ρ = θ = 0, φ = −22.00°, Az 112.0°, elev 0
    (Pg 840 rows 3–4, THEORY §7.2)."""
    C3 = np.zeros((3, 3))
    C3[:2, :2] = C_SAMPLE
    el = error_ellipsoid(C3)
    assert el.axes[:2] == pytest.approx((30.59, 8.73), abs=0.005)
    assert el.axes[2] == pytest.approx(0.0, abs=1e-6)
    assert el.rho_deg == pytest.approx(0.0, abs=1e-9)
    assert el.theta_deg == pytest.approx(0.0, abs=1e-9)
    assert el.phi_deg == pytest.approx(-22.00, abs=0.005)
    assert el.az_deg == pytest.approx(112.0, abs=0.05)
    assert el.elev_deg == pytest.approx(0.0, abs=1e-9)
    np.testing.assert_allclose(el.E[:2, :2], error_ellipse(C_SAMPLE).eigenvectors, atol=1e-9)


def _rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def _ry(a: float) -> np.ndarray:
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def _rx(a: float) -> np.ndarray:
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def test_random_ellipsoids_rotation_angles() -> None:
    """E = R_z(φ)R_y(θ)R_x(ρ) rebuilt from the reported angles equals E; E diag(λ) Eᵀ = C;
    det E = +1; axes descending; Az in [0, 180) (THEORY §7.2)."""
    rng = np.random.default_rng(9)
    for _ in range(300):
        M = rng.normal(size=(3, 3)) * rng.uniform(0.1, 50.0)
        C = M @ M.T + np.eye(3) * 1e-3
        el = error_ellipsoid(C)
        E = el.E
        assert np.linalg.det(E) == pytest.approx(1.0, abs=1e-9)
        np.testing.assert_allclose(E @ np.diag(el.eigenvalues) @ E.T, C, rtol=1e-9, atol=1e-8)
        assert el.axes[0] >= el.axes[1] >= el.axes[2]
        assert 0.0 <= el.az_deg < 180.0
        R = _rz(math.radians(el.phi_deg)) @ _ry(math.radians(el.theta_deg)) @ _rx(
            math.radians(el.rho_deg))
        np.testing.assert_allclose(R, E, atol=1e-9)
        assert el.elev_deg == pytest.approx(math.degrees(math.asin(E[2, 0])), abs=1e-9)
        k = k_factor(0.95, 3)
        assert el.scaled(0.95) == pytest.approx(tuple(k * a for a in el.axes))


def test_drms_sample() -> None:
    # THEORY §7.3: d_rms = 31.81 m, 2drms = 63.6 m
    assert drms(C_SAMPLE) == pytest.approx(31.81, abs=0.005)
    assert two_drms(C_SAMPLE) == pytest.approx(63.6, abs=0.05)
