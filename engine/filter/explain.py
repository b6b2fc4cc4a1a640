"""The parts of an update and a prediction that a cycle does not keep, recovered for display
(Pg 853) from what it keeps: H and R from the gain K, the innovation VCV S and the prior P;
ΓQΓᵀ from the prediction's two covariances and Φ. Pure functions of plain arrays.

Kalman update (THEORY §8.9, eqs. 6.21a–c): K = P Hᵀ S⁻¹ with S = H P Hᵀ + R, so
Hᵀ = P⁻¹ K S and R = S − H P Hᵀ. Prediction (eq. 6.31): P(k+1|k) = Φ P(k|k) Φᵀ + ΓQΓᵀ.
"""

from __future__ import annotations

import numpy as np

CHECK_RTOL = 1e-6
"""The recovered H and R must give back the updated P to this relative tolerance (Joseph form,
against the largest entry of P⁺), else the prior given is not the one the update used."""


def update_matrices(prior_P: np.ndarray, K: np.ndarray, S: np.ndarray,
                    posterior_P: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(H, R) of the update that took ``prior_P`` to ``posterior_P`` with gain ``K`` (n×p) and
    innovation VCV ``S`` (p×p); None when the shapes do not fit or the result does not give back
    ``posterior_P`` (:data:`CHECK_RTOL`): another prior, or rows that added states."""
    P = np.asarray(prior_P, dtype=float)
    K = np.asarray(K, dtype=float)
    S = np.asarray(S, dtype=float)
    Pn = np.asarray(posterior_P, dtype=float)
    n = P.shape[0]
    if K.ndim != 2 or K.shape[0] != n or S.shape != (K.shape[1], K.shape[1]) \
            or Pn.shape != P.shape or K.shape[1] == 0:
        return None
    try:
        H = np.linalg.solve(P, K @ S).T
    except np.linalg.LinAlgError:
        return None
    R = S - H @ P @ H.T
    R = 0.5 * (R + R.T)
    A = np.eye(n) - K @ H
    back = A @ P @ A.T + K @ R @ K.T
    scale = max(float(np.max(np.abs(Pn))), 1e-300)
    if not np.all(np.isfinite(back)) or float(np.max(np.abs(back - Pn))) > CHECK_RTOL * scale:
        return None
    return H, R


def added_process_noise(before_P: np.ndarray, predicted_P: np.ndarray,
                        phi: np.ndarray) -> np.ndarray | None:
    """ΓQΓᵀ = P(k+1|k) − Φ P(k|k) Φᵀ of one prediction step; None when the shapes differ."""
    P0 = np.asarray(before_P, dtype=float)
    P1 = np.asarray(predicted_P, dtype=float)
    F = np.asarray(phi, dtype=float)
    if P0.shape != P1.shape or F.shape != P0.shape:
        return None
    Q = P1 - F @ P0 @ F.T
    return 0.5 * (Q + Q.T)


__all__ = ["CHECK_RTOL", "added_process_noise", "update_matrices"]
