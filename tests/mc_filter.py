"""The engine's navigation filter vectorised over Monte-Carlo runs (a test helper, not engine).

:mod:`engine.filter.kalman` steps one :class:`~engine.filter.kalman.FilterState` at a time, which
is right for
the program but makes a 200-run Monte-Carlo cost tens of seconds. This module applies the same
equations to a batch of runs at once with numpy broadcasting: Φ = I + FΔt (eq. 6.31), the
process noise of ``params.q_mode`` (thesis Γ Q Γᵀ of 6.32, or the exact Van Loan integral of
the PSD), the exact Gauss–Markov discretisation of the augmented fix-error states (THEORY
§8.2) and the Joseph-form update (6.21, THEORY §8.13). ``tests/filter/test_filter_consistency.py``
checks that a batch of one run reproduces :func:`engine.filter.kalman.predict` /
:func:`engine.filter.kalman.update` to rounding, so the Monte-Carlo statistics are those of the
engine.

Shapes: x (R, n), P (R, n, n) with n = 11 nav states (THEORY §8.6) plus m fix-error states;
units as in the engine (m, m/s, rad, s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.filter import kalman as kf

TWO_PI = 2.0 * math.pi


@dataclass
class Batch:
    """R filter estimates: x (R, n), P (R, n, n); ``tau_s`` and ``fix_cov`` (m×m, m²) of the
    m Gauss–Markov fix-error states at indices 11…"""

    x: np.ndarray
    P: np.ndarray
    tau_s: np.ndarray
    fix_cov: np.ndarray

    @classmethod
    def from_state(cls, s: kf.FilterState, runs: int) -> Batch:
        """``runs`` copies of one engine state."""
        return cls(np.repeat(s.x[None], runs, 0).copy(), np.repeat(s.P[None], runs, 0).copy(),
                   np.asarray(s.fix_tau_s, dtype=float), np.array(s.fix_cov))


def transition(x: np.ndarray, dt: float) -> np.ndarray:
    """Φ = I + F Δt (R, 11, 11), eq. 6.31, at each run's v, ψ, ε."""
    runs = x.shape[0]
    v, psi, eps = x[:, 3], x[:, 4], x[:, 5]
    ce, se, cp, sp = np.cos(eps), np.sin(eps), np.cos(psi), np.sin(psi)
    vdt = v * dt
    Phi = np.repeat(np.eye(11)[None], runs, 0)
    Phi[:, 0, 3], Phi[:, 0, 4], Phi[:, 0, 5] = ce * sp * dt, vdt * ce * cp, -vdt * se * sp
    Phi[:, 1, 3], Phi[:, 1, 4], Phi[:, 1, 5] = ce * cp * dt, -vdt * ce * sp, -vdt * se * cp
    Phi[:, 2, 3], Phi[:, 2, 5] = se * dt, vdt * ce
    Phi[:, 0, 6] = Phi[:, 1, 7] = dt
    return Phi


def process_noise(Phi: np.ndarray, dt: float, params: kf.FilterParams) -> np.ndarray:
    """Q_d (R, 11, 11) for ``params.q_mode``: with A = G√q (rows 3–10) and B = F G √q
    (rows 0–2), "thesis" is (AΔt + BΔt²/2)(…)ᵀ (Γ of 6.32, q per 1-s step), "psd" the same with
    q/Δt, "vanloan" AAᵀΔt + (ABᵀ + BAᵀ)Δt²/2 + BBᵀΔt³/3 (exact, F² = 0)."""
    q = np.diag(kf.process_noise(params, 1.0))  # rates' variances (thesis) = PSD (vanloan)
    sq = np.sqrt(q)
    runs = Phi.shape[0]
    A = np.zeros((11, 8))
    A[3:] = np.diag(sq)
    B = np.zeros((runs, 11, 8))
    B[:, :3] = (Phi[:, :3, 3:] - np.eye(11)[:3, 3:]) / dt * sq  # F[:3, 3:] √q
    if params.q_mode == "vanloan":
        AB = np.einsum("ik,rjk->rij", A, B)
        return (A @ A.T) * dt + (AB + AB.transpose(0, 2, 1)) * (dt * dt / 2.0) + (
            B @ B.transpose(0, 2, 1)) * (dt**3 / 3.0)
    c = dt if params.q_mode == "thesis" else math.sqrt(dt)
    Gs = A[None] * c + B * (c * dt / 2.0)
    return Gs @ Gs.transpose(0, 2, 1)


def predict(b: Batch, dt: float, params: kf.FilterParams) -> tuple[Batch, np.ndarray]:
    """x̂ₖ₊₁|ₖ, Pₖ₊₁|ₖ after Δt s (6.20; Euler mean 6.30) and the full Φ (R, n, n) used."""
    x = b.x
    runs, n = x.shape
    Phi11 = transition(x, dt)
    xn = x.copy()
    v, psi, eps = x[:, 3], x[:, 4], x[:, 5]
    vc = v * np.cos(eps)
    xn[:, 0] += (vc * np.sin(psi) + x[:, 6]) * dt
    xn[:, 1] += (vc * np.cos(psi) + x[:, 7]) * dt
    xn[:, 2] += v * np.sin(eps) * dt
    Phi = np.zeros((runs, n, n))
    Phi[:, :11, :11] = Phi11
    Q = np.zeros((runs, n, n))
    Q[:, :11, :11] = process_noise(Phi11, dt, params)
    if n > 11:
        d = np.exp(-dt / b.tau_s)
        Phi[:, 11:, 11:] = np.diag(d)
        xn[:, 11:] *= d
        Q[:, 11:, 11:] = b.fix_cov * (1.0 - np.outer(d, d))
    Pn = Phi @ b.P @ Phi.transpose(0, 2, 1) + Q
    Pn = 0.5 * (Pn + Pn.transpose(0, 2, 1))
    return Batch(xn, Pn, b.tau_s, b.fix_cov), Phi


def update(b: Batch, z: np.ndarray, H: np.ndarray, R: np.ndarray,
           angle_rows: tuple[int, ...] = ()) -> tuple[Batch, np.ndarray, np.ndarray]:
    """Joseph-form update (6.21) of every run with z (R, p), H (p, n), R (R, p, p) or (p, p);
    innovations of ``angle_rows`` wrapped to (−π, π], heading kept in [0, 2π).
    Returns the batch, the innovations (R, p) and their covariances S (R, p, p)."""
    x, P = b.x, b.P
    n = x.shape[1]
    v = z - x @ H.T
    for i in angle_rows:
        v[:, i] = math.pi - np.mod(math.pi - v[:, i], TWO_PI)
    PHt = P @ H.T
    S = H @ PHt + R
    K = np.linalg.solve(S, PHt.transpose(0, 2, 1)).transpose(0, 2, 1)  # P Hᵀ S⁻¹ (S sym.)
    xn = x + np.einsum("rij,rj->ri", K, v)
    xn[:, 4] = np.mod(xn[:, 4], TWO_PI)
    A = np.eye(n) - K @ H
    Pn = A @ P @ A.transpose(0, 2, 1) + K @ R @ K.transpose(0, 2, 1)
    Pn = 0.5 * (Pn + Pn.transpose(0, 2, 1))
    return Batch(xn, Pn, b.tau_s, b.fix_cov), v, S


def smooth(filt_x: np.ndarray, filt_P: np.ndarray, pred_x: np.ndarray, pred_P: np.ndarray,
           phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RTS smoother (THEORY §11.1–11.2) over K epochs of every run: filt (R, K, n[, n]),
    pred/phi (R, K−1, n[, n]) with pred[:, k] the prediction from epoch k to k+1.
    Returns the smoothed x (R, K, n) and P (R, K, n, n); heading differences wrapped."""
    xs = filt_x.copy()
    Ps = filt_P.copy()
    for k in range(filt_x.shape[1] - 2, -1, -1):
        Pf = filt_P[:, k]
        Ct = np.linalg.solve(pred_P[:, k], phi[:, k] @ Pf)  # C_kᵀ = P_k+1|k⁻¹ Φ P_k|k
        C = Ct.transpose(0, 2, 1)
        dx = xs[:, k + 1] - pred_x[:, k]
        dx[:, 4] = math.pi - np.mod(math.pi - dx[:, 4], TWO_PI)
        xs[:, k] = filt_x[:, k] + np.einsum("rij,rj->ri", C, dx)
        xs[:, k, 4] = np.mod(xs[:, k, 4], TWO_PI)
        Ps[:, k] = Pf + C @ (Ps[:, k + 1] - pred_P[:, k]) @ Ct
    return xs, Ps


def nav_rows(params: kf.FilterParams, n: int, *, fix: bool, sensors: bool,
             fix_cov: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """H (p, n) and the constant part of R (p, p) of :func:`engine.filter.kalman.nav_measurement`
    rows: x, y (+ b_e, b_n when n > 11; R the white part (1 − frac)·C) if ``fix``, then z_p,
    v_m, ψ_m, ε_m if ``sensors`` (the log row's R is filled per run by :func:`log_variance`).
    Returns H, R and the angle rows."""
    rows: list[tuple[int, ...]] = []
    var: list[float] = []
    if fix:
        rows += [(0, 11), (1, 12)] if n > 11 else [(0,), (1,)]
        var += [0.0, 0.0]
    angle: tuple[int, ...] = ()
    if sensors:
        rows += [(2,), (3, 8), (4, 9), (5, 10)]
        var += [params.sigma_press_m**2, 0.0, (params.sigma_gyro_deg * kf.DEG) ** 2,
                (params.sigma_incl_deg * kf.DEG) ** 2]
        angle = (len(rows) - 2,)
    H = np.zeros((len(rows), n))
    for i, cols in enumerate(rows):
        H[i, list(cols)] = 1.0
    R = np.diag(var)
    if fix:
        assert fix_cov is not None
        frac = params.fix_sigma_frac if n > 11 else 0.0
        R[:2, :2] = fix_cov * (1.0 - frac)
    return H, R, angle


def log_variance(params: kf.FilterParams, log_ms: np.ndarray) -> np.ndarray:
    """EM-log variance max(frac·|v_m|, floor)² (eq. 4.19) per run (m²/s²)."""
    return np.maximum(params.log_sigma_frac * np.abs(log_ms), params.log_sigma_floor_ms) ** 2
