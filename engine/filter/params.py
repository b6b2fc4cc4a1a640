"""Run parameters of the navigation filter (thesis ch. 6, THEORY §8.9–8.11, D23–D26, D29–D30).

:class:`FilterParams` is the one value every filter function reads: process noise (rates of turn,
acceleration, current), sensor σ, P₀ choice, Q discretisation mode, Gauss–Markov fix-error model,
bias random walks, update form and test size. It imports nothing else of the filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from engine.filter.variances import accel_variance, current_rate_variance

DEG = math.pi / 180.0
"""Radians per degree."""

__all__ = ["DEG", "G8", "FilterParams", "accel_variance", "current_rate_variance",
           "read_only", "symmetrised"]


def read_only(a: np.ndarray) -> np.ndarray:
    """``a`` itself, made read-only (shared constants and the arrays of immutable values)."""
    a.flags.writeable = False
    return a


_HALF = read_only(np.array(0.5))


def symmetrised(P: np.ndarray) -> np.ndarray:
    """(P + Pᵀ)/2 as (P + Pᵀ)·0.5, a new array (the transpose copied first: a contiguous add is
    cheaper than one with a transposed operand, and gives the same sums)."""
    S = P + P.T.copy()
    S *= _HALF
    return S


G8 = read_only(np.vstack([np.zeros((3, 8)), np.eye(8)]))
"""G of eq. 6.1 (11×8): the eight process-noise inputs w drive states 3–10."""


@dataclass(frozen=True)
class FilterParams:
    """Run parameters of the navigation filter (THEORY §8.9–8.11, D23–D26, D29–D30).

    Rates of turn in deg/s (σ = ½ maximum, THEORY D23); σ_a² in m²/s⁴ (eq. 6.35); σ_vc² in m²/s⁴
    (thesis 2·10⁻⁸, §6.6); sensor σ in deg / m; log σ = max(frac·v, floor) m/s (eq. 4.19).
    ``q_mode`` (THEORY D24): "vanloan" (default) takes the thesis Q values as power spectral
    densities per 1 s and discretises (F, G Q Gᵀ) exactly, so any Δt and any Kalman ▸ Predict
    step give the same VCV; at Δt = 1 s it equals the thesis Γ Q Γᵀ except the position term
    F M Fᵀ Δt³/3 instead of /4 (≈ 10⁻⁴ m² per step at 6.5 m/s). "thesis" = Γ of 6.32 with Q as
    per-step rate variances (right only at Δt = 1 s: the accumulated noise grows with the step);
    "psd" = the thesis Γ with Q·(1 s/Δt) (rate noise step-invariant, position noise not quite).
    ``coloured`` enables Gauss–Markov fix-error states (τ ``fix_tau_s`` s; the fraction
    ``fix_sigma_frac`` of each fix variance is coloured, the rest stays white in R).
    """

    q_scale: float = 1.0  # Q_k := q_scale·Q_k (L2779)
    turn_rate_max_deg_s: float = 1.0  # ψ̇_max, σ_ψ̇ = ½ of it (A4)
    pitch_rate_max_deg_s: float = 0.5  # ε̇_max, σ_ε̇ = ½ of it (A4)
    sigma_a2: float = accel_variance(0.25, 0.01, 0.75)  # m²/s⁴, eq. 6.35
    sigma_current2: float = 2e-8  # m²/s⁴ per component, THEORY §8.9
    sigma_gyro_deg: float = 0.65  # gyro random error (L1429)
    sigma_incl_deg: float = 0.5  # inclinometer (not in the thesis, L1447)
    sigma_press_m: float = 1.45  # pressure depth (L1532–L1539)
    log_sigma_frac: float = 0.02  # EM log σ = 0.02 v (4.19) …
    log_sigma_floor_ms: float = 0.05  # … but at least this (m/s)
    p0: Literal["thesis", "physical"] = "thesis"  # P₀ = I₁₁ (THEORY §8.11) or D26
    q_mode: Literal["thesis", "psd", "vanloan"] = "vanloan"  # A5
    hold_course: bool = False  # THEORY D25: w_v = w_ψ = w_ε = 0
    coloured: bool = False  # Gauss–Markov fix-error states (THEORY §8.2, D25)
    fix_tau_s: float = 240.0  # their correlation time (s)
    fix_sigma_frac: float = 0.9  # coloured share of the fix variance; the rest stays in R
    bias_noise: bool = False  # THEORY D29: random-walk biases instead of random constants
    bias_rw_log_ms_sqrth: float = 0.01  # m/s per √h
    bias_rw_gyro_deg_sqrth: float = 0.5  # deg per √h
    bias_rw_incl_deg_sqrth: float = 0.1  # deg per √h
    joseph: bool = True  # Joseph-form P update; False = thesis (I − KH)P (6.21b)
    alpha: float = 0.05  # two-sided LOM test size (A12)
    dr_pos_sigma_m: float = 1000.0  # "physical" P₀: DR position σ without an LSE (A7)
    p0_current_sigma_ms: float = 0.5
    p0_log_bias_ms: float = 0.1
    p0_gyro_bias_deg: float = 1.0
    p0_incl_bias_deg: float = 0.5
    _q: np.ndarray = field(init=False, repr=False, compare=False)
    _sq: np.ndarray = field(init=False, repr=False, compare=False)
    _g8sq: np.ndarray = field(init=False, repr=False, compare=False)
    _memo: dict[float, Any] = field(init=False, repr=False, compare=False)
    """Per-Δt constants of the time update (``engine.filter.model.step_constants``)."""

    def __post_init__(self) -> None:
        if self.p0 not in ("thesis", "physical"):
            raise ValueError(f"p0 must be 'thesis' or 'physical', got {self.p0!r}")
        if self.q_mode not in ("thesis", "psd", "vanloan"):
            raise ValueError(f"q_mode must be 'thesis', 'psd' or 'vanloan', got {self.q_mode!r}")
        if not 0.0 <= self.fix_sigma_frac < 1.0:
            raise ValueError("fix_sigma_frac must be in [0, 1) so that R stays non-singular")
        if self.fix_tau_s <= 0.0 or self.q_scale < 0.0 or not 0.0 < self.alpha < 1.0:
            raise ValueError("fix_tau_s must be > 0, q_scale >= 0 and alpha in (0, 1)")
        q = _rate_variances(self)
        sq = np.sqrt(q)
        g8sq = G8 * sq
        q.flags.writeable = sq.flags.writeable = g8sq.flags.writeable = False
        object.__setattr__(self, "_q", q)
        object.__setattr__(self, "_sq", sq)
        object.__setattr__(self, "_g8sq", g8sq)
        object.__setattr__(self, "_memo", {})


def _rate_variances(params: FilterParams) -> np.ndarray:
    """Diagonal of Q (eq. 6.34) as variances of rates held over 1 s, times q_scale."""
    q = np.zeros(8)
    if not params.hold_course:
        q[0] = params.sigma_a2
        q[1] = (0.5 * params.turn_rate_max_deg_s * DEG) ** 2
        q[2] = (0.5 * params.pitch_rate_max_deg_s * DEG) ** 2
    q[3] = q[4] = params.sigma_current2
    if params.bias_noise:  # THEORY D29: random walks, given per √h, converted to per √s
        q[5] = params.bias_rw_log_ms_sqrth**2 / 3600.0
        q[6] = (params.bias_rw_gyro_deg_sqrth * DEG) ** 2 / 3600.0
        q[7] = (params.bias_rw_incl_deg_sqrth * DEG) ** 2 / 3600.0
    return q * params.q_scale
