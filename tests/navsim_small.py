"""Small truth and measurement generator for the filter tests (not part of the engine).

Truth follows the kinematics of thesis eq. 6.25 in the TM grid (x East, y North, z depth down,
m; v m/s; ψ grid heading rad; ε rad bow-down; current m/s), integrated with sub-steps, not with
the filter's own Φ: each 1-s step holds random rates (acceleration, turn rate, pitch rate,
current change) drawn with the thesis per-step variances (eq. 6.34) times ``q_scale``, plus an
optional nominal turn rate for turning tracks. Biases are random constants. All runs are
generated at once (arrays of shape (runs, ...)), so the generator costs little next to the
filter. Sensor and fix errors:

* gyro ψ + Δψ + N(0, σ_g²), log v + Δv + N(0, max(0.02 v, 0.05)²), pressure z + N(0, σ_p²),
  inclinometer ε + Δε + N(0, σ_i²);
* position fixes x + e_x, y + e_y where e is white, or a first-order Gauss–Markov process
  (e_{k+1} = e^{−Δt/τ} e_k + N(0, σ²(1 − e^{−2Δt/τ})), started stationary) plus a white part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from engine.filter.kalman import FilterParams

DEG = math.pi / 180.0


@dataclass(frozen=True)
class SimRun:
    """Truth and measurements for ``runs`` Monte-Carlo runs at epochs t = 0, Δt, …, K·Δt (s).

    truth (runs, K+1, 11) in the filter's state order; gyro/log/depth/incl (runs, K+1);
    fix (runs, K+1, 2) grid E/N (m) and fix_err the fix error that was added (m), of which
    fix_gm is the Gauss–Markov part (zero for white fix errors).
    """

    t: np.ndarray
    truth: np.ndarray
    gyro: np.ndarray
    log: np.ndarray
    depth: np.ndarray
    incl: np.ndarray
    fix: np.ndarray
    fix_err: np.ndarray
    fix_gm: np.ndarray


def rate_sigmas(params: FilterParams) -> np.ndarray:
    """√ of the thesis Q diagonal (rates held over a 1-s step): v̇, ψ̇, ε̇, v̇_cx, v̇_cy."""
    q = np.array([
        params.sigma_a2,
        (0.5 * params.turn_rate_max_deg_s * DEG) ** 2,
        (0.5 * params.pitch_rate_max_deg_s * DEG) ** 2,
        params.sigma_current2,
        params.sigma_current2,
    ])
    return np.sqrt(q * params.q_scale)


def simulate(
    rng: np.random.Generator,
    runs: int,
    epochs: int,
    x0_mean: np.ndarray,
    P0: np.ndarray,
    params: FilterParams,
    *,
    dt: float = 1.0,
    turn_rate_deg_s: float = 0.0,
    fix_sigma_m: float = 40.0,
    fix_tau_s: float | None = None,
    fix_white_frac: float = 1.0,
    substeps: int = 4,
    balanced_start: bool = False,
) -> SimRun:
    """Generate ``runs`` independent truths drawn from N(x0_mean, P0) and their measurements.

    ``fix_tau_s`` None gives white fix errors of σ ``fix_sigma_m`` per axis; otherwise the
    fix error is Gauss–Markov with variance (1 − fix_white_frac)·σ² and correlation time τ, plus
    white noise of variance fix_white_frac·σ² (σ² total per axis). ``balanced_start`` draws the
    initial deviations with sample mean 0 and sample covariance exactly P0 (moment matching), so
    the batch's initial errors carry no common offset into the states that stay unobservable.
    """
    n_ep = epochs + 1
    Lc = np.linalg.cholesky(P0)
    z0 = rng.standard_normal((runs, 11))
    if balanced_start:
        z0 -= z0.mean(axis=0)
        z0 = z0 @ np.linalg.inv(np.linalg.cholesky(z0.T @ z0 / runs)).T
    s = x0_mean[None, :] + z0 @ Lc.T
    truth = np.empty((runs, n_ep, 11))
    truth[:, 0] = s
    sig = rate_sigmas(params)
    r0 = turn_rate_deg_s * DEG
    h = dt / substeps
    for k in range(1, n_ep):
        w = rng.standard_normal((runs, 5)) * sig
        a, r, pr = w[:, 0], w[:, 1] + r0, w[:, 2]
        dvc = w[:, 3:5]
        s = s.copy()
        # integrate position with the held rates (midpoint rule on each sub-step)
        for j in range(substeps):
            tm = (j + 0.5) * h
            v = s[:, 3] + a * tm
            psi = s[:, 4] + r * tm
            eps = s[:, 5] + pr * tm
            vc = s[:, 6:8] + dvc * tm
            ce = np.cos(eps)
            s[:, 0] += (v * ce * np.sin(psi) + vc[:, 0]) * h
            s[:, 1] += (v * ce * np.cos(psi) + vc[:, 1]) * h
            s[:, 2] += v * np.sin(eps) * h
        s[:, 3] += a * dt
        s[:, 4] = np.mod(s[:, 4] + r * dt, 2 * math.pi)
        s[:, 5] += pr * dt
        s[:, 6:8] += dvc * dt
        truth[:, k] = s

    sg = params.sigma_gyro_deg * DEG
    gyro = np.mod(truth[:, :, 4] + truth[:, :, 9] + sg * rng.standard_normal((runs, n_ep)),
                  2 * math.pi)
    sv = np.maximum(params.log_sigma_frac * np.abs(truth[:, :, 3]), params.log_sigma_floor_ms)
    log = truth[:, :, 3] + truth[:, :, 8] + sv * rng.standard_normal((runs, n_ep))
    depth = truth[:, :, 2] + params.sigma_press_m * rng.standard_normal((runs, n_ep))
    incl = (truth[:, :, 5] + truth[:, :, 10]
            + params.sigma_incl_deg * DEG * rng.standard_normal((runs, n_ep)))

    if fix_tau_s is None:
        err = fix_sigma_m * rng.standard_normal((runs, n_ep, 2))
        gm = np.zeros_like(err)
    else:
        s_gm = fix_sigma_m * math.sqrt(1.0 - fix_white_frac)
        s_w = fix_sigma_m * math.sqrt(fix_white_frac)
        phi = math.exp(-dt / fix_tau_s)
        q = s_gm * math.sqrt(1.0 - phi * phi)
        gm = np.empty((runs, n_ep, 2))
        gm[:, 0] = s_gm * rng.standard_normal((runs, 2))
        drive = q * rng.standard_normal((runs, n_ep, 2))
        for k in range(1, n_ep):
            gm[:, k] = phi * gm[:, k - 1] + drive[:, k]
        err = gm + s_w * rng.standard_normal((runs, n_ep, 2))
    fix = truth[:, :, :2] + err
    t = np.arange(n_ep) * dt
    return SimRun(t, truth, gyro, log, depth, incl, fix, err, gm)
