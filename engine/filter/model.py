"""Motion model of the filter (thesis §6.5.4): mean propagation, transition Φ = I + F Δt, noise
gain Γ, process noise Q (white and Van Loan discretisations) and the Gauss–Markov fix-error
presets (correlation times, coloured share of the fix variance).
"""

from __future__ import annotations

import math

import numpy as np

from engine.filter.params import G8, FilterParams, read_only
from engine.filter.state import IEPS, IPSI, IV, IVCX, IVCY, IX, IY, IZ, N_NAV, FilterState

_EYE11 = read_only(np.eye(N_NAV))

FIX_TAU_GPS_CA_S = 240.0
"""Correlation time (s) of a C/A (SPS) GPS fix error in the SA era: Selective Availability, a
Gauss–Markov process of a few minutes (docs/SIMULATOR.md ``gps.tau_s``; thesis A6 for the model)."""

FIX_TAU_GPS_P_S = 600.0
"""Correlation time (s) of a P-code (PPS, no SA) fix error: ionosphere, troposphere and ephemeris
errors, slower than SA (an assumption, not in the thesis: a longer τ is the cautious side, the
filter then averages less)."""

FIX_TAU_DECCA_S = 180.0
"""Correlation time (s) of the Decca sky-wave error (docs/SIMULATOR.md ``decca.tau_s``, "a few
minutes"; the A4 VCV gives its size, thesis A4.1–A4.3)."""

GPS_WHITE_SIGMA_M = 5.0
"""White receiver noise per grid axis (m) of a C/A receiver (docs/SIMULATOR.md
``gps.white_sigma_m``): the only part of a GPS fix error that averages out within seconds. A
P-code receiver's is a tenth of it (code noise scales with the chip length: 10.23 against
1.023 Mchip/s)."""

FIX_TAU_GNSS_S = 1800.0
"""Correlation time (s) of a receiver-weighted (HDOP × UERE) GNSS fix error without SA: the
residual ionosphere, troposphere and broadcast orbit/clock errors that dominate the UERE change
over tens of minutes (docs/GNSS_WEIGHTS.md); an assumption on the cautious side: a filter that
assumes a longer τ than the truth averages less, never more."""

FIX_WHITE_FLOOR = 0.01
"""Least white share of a fix variance the coloured model keeps in R, so that R stays non-singular
(thesis L2287–2291: the augmented R is singular otherwise; option (a): 1–10 % white)."""


def derived_fix_model(gps_on: bool, gps_var_m2: float, decca_on: bool,
                      p_code: bool = False, gnss_receiver: bool = False) -> tuple[float, float]:
    """(τ in s, coloured fraction) of the LSE error for the systems switched on.

    τ: the longest correlation time among the systems on (:data:`FIX_TAU_GPS_CA_S`,
    :data:`FIX_TAU_GPS_P_S`, :data:`FIX_TAU_DECCA_S`): a filter that assumed a shorter one would
    average a slow error down too soon. Fraction: 1 − (white variance / fix variance) per
    system, at most 1 − :data:`FIX_WHITE_FLOOR`; for GPS the white part is the receiver noise
    (:data:`GPS_WHITE_SIGMA_M`, a tenth of it for P code) squared against the program's a priori
    variance ``gps_var_m2`` (C/A at GPS.SE_SF 0.67: 1 − 25/1675 = 0.985; P: 1 − 0.25/53.1 → the
    floor, 0.99); the Decca
    reading's only white error is the 0.001-lane quantisation of the ``.RUN``
    format (σ 0.0003 lane against ≥ 0.01 lane of sky-wave), so the floor decides (0.99). With
    both on, the smaller fraction (the larger white share) is kept. Neither on: (C/A τ, floor).
    ``gnss_receiver``: the GPS fix is weighted by the receiver's HDOP × UERE (a modern receiver,
    no SA): τ :data:`FIX_TAU_GNSS_S` and the floor's white share (its code noise, ~0.3 m,
    is ≤ 1 % of a UERE of metres; docs/GNSS_WEIGHTS.md).
    """
    taus: list[float] = []
    fracs: list[float] = []
    top = 1.0 - FIX_WHITE_FLOOR
    if gps_on and gnss_receiver:
        taus.append(FIX_TAU_GNSS_S)
        fracs.append(top)
    elif gps_on:
        taus.append(FIX_TAU_GPS_P_S if p_code else FIX_TAU_GPS_CA_S)
        white = GPS_WHITE_SIGMA_M / 10.0 if p_code else GPS_WHITE_SIGMA_M
        fracs.append(min(top, max(0.0, 1.0 - white**2 / gps_var_m2)))
    if decca_on:
        taus.append(FIX_TAU_DECCA_S)
        fracs.append(top)
    if not taus:
        return FIX_TAU_GPS_CA_S, top
    return max(taus), min(fracs)


def propagate_mean(x: np.ndarray, dt: float) -> np.ndarray:
    """One Euler step of the motion model, eq. 6.30 (exact for constant v, ψ, ε, current).

    x, y advance by v cos ε (sin ψ, cos ψ) Δt + current Δt (m); z by v sin ε Δt (m). The other
    states (and any augmented ones) are copied unchanged. Δt in s.
    """
    xs = np.asarray(x, dtype=float).tolist()
    v, psi, eps = xs[IV], xs[IPSI], xs[IEPS]
    vc = v * math.cos(eps)
    xs[IX] += (vc * math.sin(psi) + xs[IVCX]) * dt
    xs[IY] += (vc * math.cos(psi) + xs[IVCY]) * dt
    xs[IZ] += v * math.sin(eps) * dt
    return np.array(xs)


def jacobian(x: np.ndarray) -> np.ndarray:
    """F = ∂f/∂x (11×11, per s) of the continuous model 6.25 at x (nilpotent: F² = 0)."""
    return _phi(x, 1.0) - _EYE11


def _phi(x: np.ndarray, dt: float) -> np.ndarray:
    """I + F Δt written entry by entry (6.31; F1…F4 of L2585)."""
    v, psi, eps = float(x[IV]), float(x[IPSI]), float(x[IEPS])
    ce, se, cp, sp = math.cos(eps), math.sin(eps), math.cos(psi), math.sin(psi)
    vdt = v * dt
    Phi = _EYE11.copy()
    Phi[IX, IV], Phi[IX, IPSI], Phi[IX, IEPS] = ce * sp * dt, vdt * ce * cp, -vdt * se * sp
    Phi[IY, IV], Phi[IY, IPSI], Phi[IY, IEPS] = ce * cp * dt, -vdt * ce * sp, -vdt * se * cp
    Phi[IZ, IV], Phi[IZ, IEPS] = se * dt, vdt * ce
    Phi[IX, IVCX] = Phi[IY, IVCY] = dt
    return Phi


def transition(x: np.ndarray, dt: float) -> np.ndarray:
    """Φ = I + F Δt (eq. 6.31), 11×11; exact because F² = 0 (A7.5). Δt in s."""
    return _phi(x, dt)


def noise_gain(x: np.ndarray, dt: float) -> np.ndarray:
    """Γ = G Δt + F G Δt²/2 (eq. 6.32), 11×8, for w = (w_v, w_ψ, w_ε, w_vcx, w_vcy, w_Δv, w_Δψ,
    w_Δε) held constant over the step. Δt in s."""
    return _gamma(_phi(x, dt), dt, np.ones(8))


def _gamma(Phi: np.ndarray, dt: float, scale: np.ndarray) -> np.ndarray:
    """Γ·diag(scale) from Φ: rows 0–2 (Φ − I)[:3, 3:] Δt/2 = F[:3, 3:] Δt²/2, rows 3–10 Δt·I₈."""
    Gam = G8 * (scale * dt)
    Gam[:3] = Phi[:3, 3:] * (scale * (0.5 * dt))
    return Gam


def process_noise(params: FilterParams, dt: float) -> np.ndarray:
    """Q_k (8×8, eq. 6.34) to pair with :func:`noise_gain`.

    "thesis": diag(σ_a², σ_ψ̇², σ_ε̇², σ_vc², σ_vc², biases) as printed (right at Δt = 1 s);
    "psd": the same times 1 s/Δt (A5); "vanloan": the power spectral density itself (per s).
    """
    q = params._q
    if params.q_mode == "psd":
        q = q / dt
    return np.diag(q)


def discrete_noise(x: np.ndarray, dt: float, params: FilterParams) -> np.ndarray:
    """Discrete process-noise VCV Γ Q Γᵀ (11×11) added per step (6.20b).

    In "vanloan" mode (the default) the exact ∫₀^Δt e^{Fs} M e^{Fᵀs} ds with M = G Q_psd Gᵀ,
    which because F² = 0 is M Δt + (F M + M Fᵀ) Δt²/2 + F M Fᵀ Δt³/3 (equal to Van Loan's matrix
    exponential); "thesis" Γ Q Γᵀ of 6.20b/6.32; "psd" Γ Q Γᵀ/Δt (THEORY D24).
    """
    if dt == 0.0:
        return np.zeros((N_NAV, N_NAV))
    return noise_from_transition(_phi(x, dt), dt, params)


def noise_from_transition(Phi: np.ndarray, dt: float, params: FilterParams) -> np.ndarray:
    """:func:`discrete_noise` from the step's Φ (Δt > 0).

    With A = G√q and B = F G √q (rows 0–2 only), "thesis" is U Uᵀ with U = Γ√q = AΔt + BΔt²/2;
    "psd" the same with q/Δt, U = A√Δt + BΔt^{3/2}/2; "vanloan" the exact integral
    AAᵀΔt + (ABᵀ + BAᵀ)Δt²/2 + BBᵀΔt³/3 = (psd U Uᵀ) + V Vᵀ with V = BΔt^{3/2}/√12.
    """
    return step_noise(Phi, step_constants(params, dt))


def step_noise(Phi: np.ndarray, c: StepConstants) -> np.ndarray:
    """:func:`noise_from_transition` with the step's constants ``c`` (:func:`step_constants`)."""
    F3 = Phi[:3, 3:]  # F[:3, 3:] Δt
    Gs = c.gs.copy()  # Γ Q^{1/2}: rows 3–10 Δt·√q (or √Δt·√q), rows 0–2 F[:3, 3:] Δt²/2·√q
    np.multiply(F3, c.gs_scale, out=Gs[:3])
    Q = Gs.dot(Gs.T)
    if c.v_scale is not None:  # "vanloan": + V Vᵀ, V = F[:3, 3:]√q Δt^{3/2}/√12
        V = F3 * c.v_scale
        Q[:3, :3] += V.dot(V.T)
    return Q


_PHI_AT = np.ravel_multi_index(
    ([IX, IX, IX, IY, IY, IY, IZ, IZ], [IV, IPSI, IEPS, IV, IPSI, IEPS, IV, IEPS]),
    (N_NAV, N_NAV))
"""Flat indices of the Φ entries that depend on the state (6.31; F1…F4 of L2585), in the order
:func:`transition_and_mean` writes them."""

_MEMO_SIZE = 16
"""Δt values whose :class:`StepConstants` a :class:`FilterParams` keeps (a run with a steady
record interval needs one; a log with jittering time stamps must not grow the memo)."""


class FixDecay:
    """The parts of one step of the Gauss–Markov fix-error states (A6, THEORY §8.2) that depend
    on Δt and their correlation times τ only: d = e^{−Δt/τ} (array and floats), d_i d_j,
    1 − d_i d_j and the full n×n Φ with zeros where the nav block goes (read-only)."""

    __slots__ = ("d", "d_list", "dd", "one_minus_dd", "phi")

    def __init__(self, dt: float, fix_tau_s: tuple[float, ...]) -> None:
        d = np.exp(-dt / np.asarray(fix_tau_s))
        dd = d[:, None] * d[None, :]
        m = d.shape[0]
        n = N_NAV + m
        phi = np.zeros((n, n))
        for i, di in enumerate(d.tolist(), start=N_NAV):
            phi[i, i] = di
        self.d = read_only(d)
        self.d_list: list[float] = d.tolist()
        self.dd = read_only(dd)
        self.one_minus_dd = read_only(1.0 - dd)
        self.phi = read_only(phi)


class StepConstants:
    """What one time update of Δt s needs that depends on Δt and the parameters only, built
    once per Δt (:func:`step_constants`): Φ's constant part (I with Δt at (x, v_cx) and (y,
    v_cy), 6.31), Γ√q's constant rows 3–10 and the factors of its rows 0–2 and of V in
    :func:`noise_from_transition`, and the fix-error decay per set of τ (:class:`FixDecay`).
    The arrays are read-only and computed by the same operations as the per-step code did."""

    __slots__ = ("dt", "phi", "gs", "gs_scale", "v_scale", "fix")

    def __init__(self, params: FilterParams, dt: float) -> None:
        c = dt if params.q_mode == "thesis" else math.sqrt(dt)  # psd/vanloan: Q·(1 s/Δt) on Γ
        phi = _EYE11.copy()
        phi[IX, IVCX] = phi[IY, IVCY] = dt
        self.dt = dt
        self.phi = read_only(phi)
        self.gs = read_only(params._g8sq * c)
        self.gs_scale = read_only(params._sq * (0.5 * c))
        self.v_scale = (read_only(params._sq * math.sqrt(dt / 12.0))
                        if params.q_mode == "vanloan" else None)
        self.fix: dict[tuple[float, ...], FixDecay] = {}

    def fix_decay(self, fix_tau_s: tuple[float, ...]) -> FixDecay:
        """The :class:`FixDecay` of fix-error states with correlation times ``fix_tau_s`` (s)."""
        f = self.fix.get(fix_tau_s)
        if f is None:
            if len(self.fix) >= _MEMO_SIZE:
                self.fix.clear()
            f = self.fix[fix_tau_s] = FixDecay(self.dt, fix_tau_s)
        return f


def step_constants(params: FilterParams, dt: float) -> StepConstants:
    """The :class:`StepConstants` of a step of ``dt`` s (Δt > 0), kept by ``params``."""
    memo = params._memo
    c = memo.get(dt)
    if c is None:
        if len(memo) >= _MEMO_SIZE:
            memo.clear()
        c = memo[dt] = StepConstants(params, dt)
    return c


def transition_and_mean(xs: list[float], c: StepConstants) -> np.ndarray:
    """Φ of the nav states (:func:`transition`) for a step of ``c.dt`` s at the state ``xs``
    (a list), and ``xs`` advanced in place by :func:`propagate_mean` (eq. 6.30): both from the
    same sines and cosines, with the same operations as those two functions."""
    dt = c.dt
    v, psi, eps = xs[IV], xs[IPSI], xs[IEPS]
    ce, se, cp, sp = math.cos(eps), math.sin(eps), math.cos(psi), math.sin(psi)
    vdt = v * dt
    Phi = c.phi.copy()
    Phi.put(_PHI_AT, (ce * sp * dt, vdt * ce * cp, -vdt * se * sp,
                      ce * cp * dt, -vdt * ce * sp, -vdt * se * cp,
                      se * dt, vdt * ce))
    vc = v * ce
    xs[IX] += (vc * sp + xs[IVCX]) * dt
    xs[IY] += (vc * cp + xs[IVCY]) * dt
    xs[IZ] += v * se * dt
    return Phi


def van_loan(F: np.ndarray, Qc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact discretisation of ẋ = F x + w, E[w wᵀ] = Qc δ (Van Loan 1978): returns (Φ, Q_d).

    Generic helper for Predict studies and validation (uses scipy's expm; not the hot path).
    """
    from scipy.linalg import expm

    n = F.shape[0]
    A = np.zeros((2 * n, 2 * n))
    A[:n, :n] = -F
    A[:n, n:] = Qc
    A[n:, n:] = F.T
    B = expm(A * dt)
    Phi = B[n:, n:].T
    Qd = Phi @ B[:n, n:]
    return Phi, 0.5 * (Qd + Qd.T)


def state_transition(state: FilterState, dt: float) -> np.ndarray:
    """Full Φ (n×n) for one step of Δt s: eq. 6.31 plus e^{−Δt/τ} for each fix-error state."""
    Phi = _phi(state.x, dt)
    m = len(state.fix_states)
    if m == 0:
        return Phi
    n = N_NAV + m
    full = np.zeros((n, n))
    full[:N_NAV, :N_NAV] = Phi
    full[N_NAV:, N_NAV:].flat[::m + 1] = np.exp(-dt / np.asarray(state.fix_tau_s))
    return full
