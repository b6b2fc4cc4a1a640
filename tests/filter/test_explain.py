"""engine.filter.explain: H, R and ΓQΓᵀ recovered from what a cycle keeps (Pg 853), checked
against an update and a prediction whose H, R and Q are known (built by hand here)."""

from __future__ import annotations

import numpy as np
import pytest

from engine.filter.explain import added_process_noise, update_matrices


def _update(P: np.ndarray, H: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """K, S and the Joseph-form P⁺ of a textbook update (Gelb 1974, table 4.2-1)."""
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    A = np.eye(P.shape[0]) - K @ H
    return K, S, A @ P @ A.T + K @ R @ K.T


def test_h_and_r_come_back_from_k_s_and_the_prior() -> None:
    rng = np.random.default_rng(7)
    M = rng.normal(size=(6, 6))
    P = M @ M.T + 6 * np.eye(6)
    H = np.zeros((3, 6))
    H[0, 0] = H[1, 1] = 1.0  # a position fix: east, north
    H[2, 3] = 1.0  # a log row on the speed state
    R = np.array([[25.0, 4.0, 0.0], [4.0, 16.0, 0.0], [0.0, 0.0, 0.01]])
    K, S, Pn = _update(P, H, R)
    got = update_matrices(P, K, S, Pn)
    assert got is not None
    assert got[0] == pytest.approx(H, abs=1e-9)
    assert got[1] == pytest.approx(R, abs=1e-9)
    # another prior than the update's: refused, not shown wrong
    assert update_matrices(P * 1.1, K, S, Pn) is None
    assert update_matrices(P, K[:5], S, Pn) is None


def test_process_noise_is_what_the_prediction_added() -> None:
    phi = np.array([[1.0, 10.0], [0.0, 1.0]])  # position, velocity over 10 s
    P0 = np.diag([4.0, 0.25])
    q = 0.01  # white acceleration, (m/s²)² s: ΓQΓᵀ of a constant-velocity model
    Q = q * np.array([[10.0**3 / 3, 10.0**2 / 2], [10.0**2 / 2, 10.0]])
    P1 = phi @ P0 @ phi.T + Q
    assert added_process_noise(P0, P1, phi) == pytest.approx(Q, abs=1e-12)
    assert added_process_noise(P0, np.eye(3), phi) is None
