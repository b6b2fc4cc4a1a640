"""UVNAV navigation filter: the 11-state extended Kalman filter of thesis ch. 6 (Neele 1993).

State (kalman.md §6.3), SI units, TM grid frame:
0 x, 1 y (grid East/North, m), 2 z (depth, m, positive down), 3 v (speed through water, m/s),
4 ψ (GRID heading, rad, kept in [0, 2π)), 5 ε (inclination, rad, bow-down positive),
6 v_cx, 7 v_cy (current East/North, m/s), 8 Δv (log bias, m/s), 9 Δψ (gyro bias, rad),
10 Δε (inclinometer bias, rad); then optional first-order Gauss–Markov fix-error states
(thesis §6.3.2 / A6, kalman.md §3) appended at index 11 onwards.

Everything here is a pure function of immutable values: a :class:`FilterState` goes in, a new
one comes out. The model builders (:func:`transition`, :func:`noise_gain`, :func:`process_noise`,
:func:`propagate_mean`) are shared by prediction, smoothing and the tests.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np
from scipy.linalg import blas, lapack

from engine.geodesy.angles import TWO_PI, wrap_2pi, wrap_pi
from engine.lsq.statistics import chi2_bounds

__all__ = [
    "N_NAV",
    "STATE_LABELS",
    "FilterDivergence",
    "FilterParams",
    "FilterState",
    "LomTest",
    "LsTest",
    "Measurement",
    "UpdateResult",
    "accel_variance",
    "add_fix_states",
    "current_rate_variance",
    "derived_fix_model",
    "discrete_noise",
    "innovation_distance",
    "init_state",
    "jacobian",
    "lom_test",
    "lop_measurement",
    "ls_test",
    "lse_measurement",
    "nav_measurement",
    "noise_gain",
    "predict",
    "predict_horizon",
    "predict_step",
    "process_noise",
    "propagate_mean",
    "restart_fix_states",
    "sensor_measurement",
    "stack_measurements",
    "state_transition",
    "transition",
    "update",
    "van_loan",
]

N_NAV = 11
IX, IY, IZ, IV, IPSI, IEPS, IVCX, IVCY, IDV, IDPSI, IDEPS = range(N_NAV)
STATE_LABELS: tuple[str, ...] = (
    "x", "y", "z", "v", "psi", "eps", "v_cx", "v_cy", "dv", "dpsi", "deps",
)
DEG = math.pi / 180.0


def _read_only(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


_EYE11 = _read_only(np.eye(N_NAV))
_EYES = tuple(_read_only(np.eye(k)) for k in range(21))  # identities up to 20×20


def _eye(k: int) -> np.ndarray:
    """The k×k identity (read-only, shared for k ≤ 20: rows of an update, states)."""
    return _EYES[k] if k < len(_EYES) else np.eye(k)
_G8 = _read_only(np.vstack([np.zeros((3, 8)), np.eye(8)]))  # G of 6.1: w drives states 3–10

LS_MONITOR = 1.960  # |t| above this: accept but monitor (thesis L1871–L1879)
LS_REJECT = 2.576  # |t| above this: reject


def accel_variance(a_max: float, p_max: float, p_zero: float) -> float:
    """σ_a² (m²/s⁴) of Gelb's mixed acceleration pdf, eq. 6.35: (a_max²/3)(1 + 4 p_max − p_0)."""
    return a_max * a_max / 3.0 * (1.0 + 4.0 * p_max - p_zero)


def current_rate_variance(v_cm_ms: float, period_s: float) -> float:
    """σ_vc² (m²/s⁴) per current component, §6.6: σ = ½ V_cm (ω_v + ω_ψ), ω = 2π/period."""
    omega = TWO_PI / period_s
    return (0.5 * v_cm_ms * 2.0 * omega) ** 2


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
FIX_WHITE_FLOOR = 0.01
"""Least white share of a fix variance the coloured model keeps in R, so that R stays non-singular
(thesis L2287–2291: the augmented R is singular otherwise; option (a): 1–10 % white)."""


def derived_fix_model(gps_on: bool, gps_var_m2: float, decca_on: bool,
                      p_code: bool = False) -> tuple[float, float]:
    """(τ in s, coloured fraction) of the LSE error for the systems switched on.

    τ: the longest correlation time among the systems on (:data:`FIX_TAU_GPS_CA_S`,
    :data:`FIX_TAU_GPS_P_S`, :data:`FIX_TAU_DECCA_S`): a filter that assumed a shorter one would
    average a slow error down too soon. Fraction: 1 − (white variance / fix variance) per
    system, at most 1 − :data:`FIX_WHITE_FLOOR`; for GPS the white part is the receiver noise
    (:data:`GPS_WHITE_SIGMA_M`, a tenth of it for P code) squared against the program's a priori
    variance ``gps_var_m2`` (C/A at GPS.SE_SF 0.5: 1 − 25/1250 = 0.98; P: 1 − 0.25/39.6 → the
    floor, 0.99); the Decca
    reading's only white error is the 0.001-lane quantisation of the ``.RUN``
    format (σ 0.0003 lane against ≥ 0.01 lane of sky-wave), so the floor decides (0.99). With
    both on, the smaller fraction (the larger white share) is kept. Neither on: (C/A τ, floor).
    """
    taus: list[float] = []
    fracs: list[float] = []
    top = 1.0 - FIX_WHITE_FLOOR
    if gps_on:
        taus.append(FIX_TAU_GPS_P_S if p_code else FIX_TAU_GPS_CA_S)
        white = GPS_WHITE_SIGMA_M / 10.0 if p_code else GPS_WHITE_SIGMA_M
        fracs.append(min(top, max(0.0, 1.0 - white**2 / gps_var_m2)))
    if decca_on:
        taus.append(FIX_TAU_DECCA_S)
        fracs.append(top)
    if not taus:
        return FIX_TAU_GPS_CA_S, top
    return max(taus), min(fracs)


class FilterDivergence(ArithmeticError):
    """The filter produced a non-positive variance or a non-PD innovation covariance.

    ``state`` is kept for logging: the updated state with the bad variance, or the input
    state when S = HPHᵀ + R was not positive definite.
    """

    def __init__(self, message: str, state: FilterState) -> None:
        super().__init__(message)
        self.state = state


@dataclass(frozen=True)
class FilterParams:
    """Run parameters of the navigation filter (kalman.md §6.6–§6.8, A4–A7, A11, A12).

    Rates of turn in deg/s (σ = ½ maximum, A4); σ_a² in m²/s⁴ (eq. 6.35); σ_vc² in m²/s⁴
    (thesis 2·10⁻⁸, §6.6); sensor σ in deg / m; log σ = max(frac·v, floor) m/s (eq. 4.19).
    ``q_mode`` (kalman.md A5): "vanloan" (default) takes the thesis Q values as power spectral
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
    sigma_current2: float = 2e-8  # m²/s⁴ per component, §6.6
    sigma_gyro_deg: float = 0.65  # gyro random error (L1429)
    sigma_incl_deg: float = 0.5  # inclinometer (not in the thesis, L1447)
    sigma_press_m: float = 1.45  # pressure depth (L1532–L1539)
    log_sigma_frac: float = 0.02  # EM log σ = 0.02 v (4.19) …
    log_sigma_floor_ms: float = 0.05  # … but at least this (m/s)
    p0: Literal["thesis", "physical"] = "thesis"  # P₀ = I₁₁ (§6.8) or A7
    q_mode: Literal["thesis", "psd", "vanloan"] = "vanloan"  # A5
    hold_course: bool = False  # A6: w_v = w_ψ = w_ε = 0
    coloured: bool = False  # Gauss–Markov fix-error states (§3, A6)
    fix_tau_s: float = 240.0  # their correlation time (s)
    fix_sigma_frac: float = 0.9  # coloured share of the fix variance; the rest stays in R
    bias_noise: bool = False  # A11: random-walk biases instead of random constants
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
        g8sq = _G8 * sq
        q.flags.writeable = sq.flags.writeable = g8sq.flags.writeable = False
        object.__setattr__(self, "_q", q)
        object.__setattr__(self, "_sq", sq)
        object.__setattr__(self, "_g8sq", g8sq)


def _empty_cov() -> np.ndarray:
    return np.zeros((0, 0))


@dataclass(frozen=True, eq=False)
class FilterState:
    """Filter estimate at time ``t`` (s): state ``x`` (n,) and error VCV ``P`` (n×n).

    ``fix_states`` names the augmented Gauss–Markov fix-error states (indices 11, 12, …);
    ``fix_tau_s`` their correlation times (s) and ``fix_cov`` their stationary covariance
    (m², m×m). The arrays are copied to float64 and made read-only: a state is an immutable
    value and every filter step returns a new one.
    """

    t: float
    x: np.ndarray
    P: np.ndarray
    fix_states: tuple[str, ...] = ()
    fix_tau_s: tuple[float, ...] = ()
    fix_cov: np.ndarray = field(default_factory=_empty_cov)

    def __post_init__(self) -> None:
        for name in ("x", "P", "fix_cov"):
            object.__setattr__(self, name, _read_only(np.array(getattr(self, name), dtype=float)))

    @property
    def n(self) -> int:
        """Number of states (11 plus augmented fix-error states)."""
        return self.x.shape[0]

    def index(self, key: str) -> int:
        """State index of a nav label (``STATE_LABELS``) or an augmented fix-error key."""
        if key in self.fix_states:
            return N_NAV + self.fix_states.index(key)
        return STATE_LABELS.index(key)

    def with_fix_cov(self, keys: Sequence[str], cov: np.ndarray) -> FilterState:
        """The same estimate with the stationary VCV of fix-error states ``keys`` set to ``cov``
        (m², over ``keys``); their covariances with the other fix-error states become 0."""
        C = np.asarray(cov, dtype=float)
        C = 0.5 * (C + C.T)
        if tuple(keys) == self.fix_states:  # the usual case: the LSE pair is all there is
            fc = C
        else:
            idx = [self.fix_states.index(k) for k in keys]
            fc = np.array(self.fix_cov)
            fc[idx, :] = 0.0
            fc[:, idx] = 0.0
            fc[np.ix_(idx, idx)] = C
        new = self._with(self.t, self.x, self.P)
        fc.flags.writeable = False
        new.__dict__["fix_cov"] = fc
        return new

    def _with(self, t: float, x: np.ndarray, P: np.ndarray) -> FilterState:
        """Same metadata, new t, x, P (fresh arrays owned by the caller; made read-only).

        Hot path: fills the instance dict directly instead of the dataclass __init__.
        """
        x.setflags(write=False)
        P.setflags(write=False)
        new = object.__new__(FilterState)
        d = new.__dict__
        d.update(self.__dict__)
        d["t"], d["x"], d["P"] = t, x, P
        return new


@dataclass(frozen=True, eq=False)
class Measurement:
    """Linear(ised) measurement rows: z = H x + b + v, v ~ N(0, R).

    ``z`` (p,), ``H`` (p×n_H, n_H ≤ n_state; narrower H is zero-padded), ``R`` (p×p),
    ``labels`` per row; innovations of ``angle_rows`` are wrapped to (−π, π].
    ``bias_keys`` (empty, or one entry per row): the Gauss–Markov fix-error state b added to
    that row (None for none); :func:`update` puts the 1 in the right column and, if the state
    lacks a key, adds it first with stationary VCV ``bias_cov`` (m², over the distinct keys in
    order of first appearance) and correlation times ``bias_tau_s`` (s, same order).
    """

    z: np.ndarray
    H: np.ndarray
    R: np.ndarray
    labels: tuple[str, ...]
    angle_rows: tuple[int, ...] = ()
    bias_keys: tuple[str | None, ...] = ()
    bias_cov: np.ndarray | None = None
    bias_tau_s: tuple[float, ...] = ()


@dataclass(frozen=True)
class LomTest:
    """Local Overall Model test (6.38–6.40, A12): T = v̂ᵀS⁻¹v̂/p in [χ²_p(α/2)/p, χ²_p(1−α/2)/p]."""

    t: float
    lower: float
    upper: float
    dof: int
    verdict: str  # "accept" | "reject" | "too small" | "none"


@dataclass(frozen=True, eq=False)
class LsTest:
    """Local Slippage w-statistics per row (eq. 6.41) from the factor L⁻¹ of S and w = L⁻¹v̂.

    ``t`` = (S⁻¹v̂)_i / √(S⁻¹)_ii; ``flags``: accept (|t| ≤ 1.960) / monitor (≤ 2.576) /
    reject; ``identified``: the row with the largest |t| > 2.576, only when the LOM test
    rejects (kalman.md §8). Computed on access, so the per-cycle update stays cheap.
    """

    l_inv: np.ndarray
    w: np.ndarray
    lom_reject: bool

    @cached_property
    def t(self) -> np.ndarray:
        """LS statistic per row (dimensionless, N(0, 1) under H0; read-only, computed once)."""
        lt = self.l_inv.T
        t = lt.dot(self.w) / np.sqrt(np.add.reduce(lt * lt, axis=1))
        t.setflags(write=False)
        return t

    @property
    def flags(self) -> tuple[str, ...]:
        """Per-row verdict "accept" / "monitor" / "reject"."""
        return tuple("reject" if a > LS_REJECT else "monitor" if a > LS_MONITOR else "accept"
                     for a in np.abs(self.t).tolist())

    @property
    def identified(self) -> int | None:
        """Index of the suspected outlier row, or None."""
        a = np.abs(self.t)
        if self.lom_reject and a.size and a.max() > LS_REJECT:
            return int(np.argmax(a))
        return None


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """Result of one measurement update: new state, innovation v̂ (6.37), S, K and tests."""

    state: FilterState
    innovation: np.ndarray
    S: np.ndarray
    K: np.ndarray
    labels: tuple[str, ...]
    lom: LomTest
    ls: LsTest


# --------------------------------------------------------------------------------------------
# Model builders (thesis §6.5.4)
# --------------------------------------------------------------------------------------------


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
    Gam = _G8 * (scale * dt)
    Gam[:3] = Phi[:3, 3:] * (scale * (0.5 * dt))
    return Gam


def _rate_variances(params: FilterParams) -> np.ndarray:
    """Diagonal of Q (eq. 6.34) as variances of rates held over 1 s, times q_scale."""
    q = np.zeros(8)
    if not params.hold_course:
        q[0] = params.sigma_a2
        q[1] = (0.5 * params.turn_rate_max_deg_s * DEG) ** 2
        q[2] = (0.5 * params.pitch_rate_max_deg_s * DEG) ** 2
    q[3] = q[4] = params.sigma_current2
    if params.bias_noise:  # A11: random walks, given per √h, converted to per √s
        q[5] = params.bias_rw_log_ms_sqrth**2 / 3600.0
        q[6] = (params.bias_rw_gyro_deg_sqrth * DEG) ** 2 / 3600.0
        q[7] = (params.bias_rw_incl_deg_sqrth * DEG) ** 2 / 3600.0
    return q * params.q_scale


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
    exponential); "thesis" Γ Q Γᵀ of 6.20b/6.32; "psd" Γ Q Γᵀ/Δt (kalman.md A5).
    """
    if dt == 0.0:
        return np.zeros((N_NAV, N_NAV))
    return _noise_from_phi(_phi(x, dt), dt, params)


def _noise_from_phi(Phi: np.ndarray, dt: float, params: FilterParams) -> np.ndarray:
    """:func:`discrete_noise` from the step's Φ (Δt > 0).

    With A = G√q and B = F G √q (rows 0–2 only), "thesis" is U Uᵀ with U = Γ√q = AΔt + BΔt²/2;
    "psd" the same with q/Δt, U = A√Δt + BΔt^{3/2}/2; "vanloan" is the exact integral
    AAᵀΔt + (ABᵀ + BAᵀ)Δt²/2 + BBᵀΔt³/3 = (psd U Uᵀ) + V Vᵀ with V = BΔt^{3/2}/√12.
    """
    c = dt if params.q_mode == "thesis" else math.sqrt(dt)  # psd/vanloan: Q·(1 s/Δt) on Γ
    Gs = params._g8sq * c  # Γ Q^{1/2}: rows 3–10 Δt·√q, rows 0–2 F[:3, 3:] Δt²/2·√q
    Gs[:3] = Phi[:3, 3:] * (params._sq * (0.5 * c))
    Q = Gs.dot(Gs.T)
    if params.q_mode == "vanloan":
        V = Phi[:3, 3:] * (params._sq * math.sqrt(dt / 12.0))  # F[:3, 3:]√q Δt^{3/2}/√12
        Q[:3, :3] += V.dot(V.T)
    return Q


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


# --------------------------------------------------------------------------------------------
# Initialisation and augmented fix-error states
# --------------------------------------------------------------------------------------------


def init_state(
    t: float,
    x_m: float,
    y_m: float,
    z_m: float,
    speed_ms: float,
    heading_grid_rad: float,
    incl_rad: float,
    current_e_ms: float,
    current_n_ms: float,
    params: FilterParams,
    pos_cov: np.ndarray | None = None,
    from_sensors: tuple[bool, bool, bool] = (False, False, False),
) -> FilterState:
    """Initial state x̂₀|₀ (§6.8, biases 0) and P₀: I₁₁ ("thesis") or the A7 "physical" P₀.

    ``pos_cov`` (2×2, m²), e.g. the first LSE's VCV (A3), replaces the position block in either
    mode; "physical" otherwise uses ``dr_pos_sigma_m``. Heading in grid rad, wrapped to [0, 2π).
    ``from_sensors`` says which of speed, heading and inclination are a sensor reading (log,
    gyro, inclinometer): such a value estimates state + bias (6.27–6.29) with the sensor's σ,
    so in "physical" mode its error is the reading's error minus the unknown bias: P_ss = σ_m² +
    σ_b², P_sb = −σ_b², P_bb = σ_b² (σ_b the A7 bias σ) instead of independent σ_m², σ_b².
    """
    x = np.array(
        [x_m, y_m, z_m, speed_ms, wrap_2pi(heading_grid_rad), incl_rad,
         current_e_ms, current_n_ms, 0.0, 0.0, 0.0],
        dtype=float,
    )
    if params.p0 == "thesis":
        P = np.eye(N_NAV)
    else:
        sv = max(params.log_sigma_frac * abs(speed_ms), params.log_sigma_floor_ms)
        P = np.diag([
            params.dr_pos_sigma_m**2, params.dr_pos_sigma_m**2, params.sigma_press_m**2, sv**2,
            (params.sigma_gyro_deg * DEG) ** 2, (params.sigma_incl_deg * DEG) ** 2,
            params.p0_current_sigma_ms**2, params.p0_current_sigma_ms**2,
            params.p0_log_bias_ms**2, (params.p0_gyro_bias_deg * DEG) ** 2,
            (params.p0_incl_bias_deg * DEG) ** 2,
        ])
        for on, i, b in zip(from_sensors, (IV, IPSI, IEPS), (IDV, IDPSI, IDEPS), strict=True):
            if on:
                P[i, i] += P[b, b]
                P[i, b] = P[b, i] = -P[b, b]
    if pos_cov is not None:
        C = np.asarray(pos_cov, dtype=float)
        P[:2, :2] = 0.5 * (C + C.T)
    return FilterState(float(t), x, P)


def add_fix_states(
    state: FilterState,
    keys: Sequence[str],
    sigma2: float | Sequence[float] | np.ndarray,
    params: FilterParams,
    tau_s: float | Sequence[float] | None = None,
) -> FilterState:
    """Append first-order Gauss–Markov fix-error states (A6; kalman.md §3.2), zero mean.

    ``sigma2`` is their stationary variance (m²; scalar, per key, or a full matrix over
    ``keys``, e.g. frac·C_LSE) and becomes their prior P block; τ = ``tau_s`` (s; one value or
    one per key) or params.fix_tau_s. Keys already present are left alone (idempotent).
    """
    keys = tuple(keys)
    new = [i for i, k in enumerate(keys) if k not in state.fix_states]
    if not new:
        return state
    s2 = np.asarray(sigma2, dtype=float)
    if s2.ndim == 0:
        C = np.eye(len(keys)) * float(s2)
    elif s2.ndim == 1:
        C = np.diag(s2)
    else:
        C = 0.5 * (s2 + s2.T)
    C = C[np.ix_(new, new)]
    tau_all = np.broadcast_to(
        np.asarray(params.fix_tau_s if tau_s is None else tau_s, dtype=float), (len(keys),))
    taus = tuple(float(tau_all[i]) for i in new)
    n, m = state.n, len(new)
    x = np.concatenate([state.x, np.zeros(m)])
    P = np.zeros((n + m, n + m))
    P[:n, :n] = state.P
    P[n:, n:] = C
    k0 = state.fix_cov.shape[0]
    fc = np.zeros((k0 + m, k0 + m))
    fc[:k0, :k0] = state.fix_cov
    fc[k0:, k0:] = C
    return FilterState(
        state.t, x, P, state.fix_states + tuple(keys[i] for i in new),
        state.fix_tau_s + taus, fc,
    )


def restart_fix_states(
    state: FilterState,
    keys: Sequence[str],
    cov: np.ndarray,
    phi: np.ndarray | None = None,
) -> tuple[FilterState, np.ndarray | None]:
    """Start the Gauss–Markov fix-error states ``keys`` afresh as a new, independent error
    process (the fix source changed, e.g. C/A → P code): b = 0, P_bb = ``cov`` (its stationary
    VCV, m²), no covariance with any other state, and ``fix_cov`` = ``cov``.

    This is the prediction of a transition whose rows for b are 0 and whose process noise for b
    is ``cov``; ``phi`` (the step's full Φ, if given) is returned with those rows zeroed, so the
    RTS smoother sees a consistent (state, prediction, Φ) triple. Keys not in the state are
    ignored (they are added with this prior on first use anyway).
    """
    present = [i for i, k in enumerate(keys) if k in state.fix_states]
    if not present:
        return state, phi
    keys = [keys[i] for i in present]
    C = np.atleast_2d(np.asarray(cov, dtype=float))[np.ix_(present, present)]
    idx = [N_NAV + state.fix_states.index(k) for k in keys]
    x = np.array(state.x)
    P = np.array(state.P)
    x[idx] = 0.0
    P[idx, :] = 0.0
    P[:, idx] = 0.0
    P[np.ix_(idx, idx)] = 0.5 * (C + C.T)
    new = state._with(state.t, x, P).with_fix_cov(keys, C)
    if phi is not None:
        phi = np.array(phi)
        phi[idx, :] = 0.0
    return new, phi


# --------------------------------------------------------------------------------------------
# Prediction (6.20, 6.13–6.14)
# --------------------------------------------------------------------------------------------


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


def predict_step(
    state: FilterState, dt: float, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """Propagate x̂ and P over Δt s (6.20a/b, re-linearised at x̂ₖ|ₖ); returns (state, Φ used).

    Fix-error states decay as e^{−Δt/τ} with exact noise C_ij (1 − e^{−Δt(1/τ_i + 1/τ_j)}).
    """
    return _predict(state, dt, params, True)


def predict(state: FilterState, dt: float, params: FilterParams) -> FilterState:
    """x̂ₖ₊₁|ₖ, Pₖ₊₁|ₖ after Δt s (6.20; 6.13–6.14 when no update follows)."""
    return _predict(state, dt, params, False)[0]


def _predict(
    state: FilterState, dt: float, params: FilterParams, want_phi: bool
) -> tuple[FilterState, np.ndarray]:
    """Shared propagation; the full n×n Φ is assembled only if ``want_phi`` (else Φ_nav)."""
    if dt < 0.0:
        raise ValueError(f"negative time step {dt} s")
    if dt == 0.0:
        return state, np.eye(state.n)
    x, P = state.x, state.P
    Phi = _phi(x, dt)
    Qd = _noise_from_phi(Phi, dt, params)
    xn = propagate_mean(x, dt)
    if not state.fix_states:
        Pn = Phi.dot(P).dot(Phi.T)
        Pn += Qd
        Pn = Pn + Pn.T
        Pn *= 0.5
        return state._with(state.t + dt, xn, Pn), Phi
    # Augmented: Φ = blockdiag(Φ_nav, D), D = diag(e^{−Δt/τ}); done block by block.
    n = state.n
    d = np.exp(-dt / np.asarray(state.fix_tau_s))
    dd = d[:, None] * d[None, :]
    xn[N_NAV:] = x[N_NAV:] * d
    Pn = np.empty((n, n))
    Pnn = Phi.dot(P[:N_NAV, :N_NAV]).dot(Phi.T)
    Pnn += Qd
    Pn[:N_NAV, :N_NAV] = Pnn
    Pnb = Phi.dot(P[:N_NAV, N_NAV:]) * d
    Pn[:N_NAV, N_NAV:] = Pnb
    Pn[N_NAV:, :N_NAV] = Pnb.T
    Pn[N_NAV:, N_NAV:] = P[N_NAV:, N_NAV:] * dd + state.fix_cov * (1.0 - dd)
    Pn = Pn + Pn.T
    Pn *= 0.5
    if want_phi:
        full = np.zeros((n, n))
        full[:N_NAV, :N_NAV] = Phi
        for i, di in enumerate(d.tolist(), start=N_NAV):
            full[i, i] = di
        Phi = full
    return state._with(state.t + dt, xn, Pn), Phi


def predict_horizon(
    state: FilterState, horizon_s: float, step_s: float, params: FilterParams
) -> list[FilterState]:
    """Kalman ▸ Predict (kalman.md §4): N = ceil(T/h) steps of h s, the last one shortened so
    the steps sum to T s exactly. Returns the N predicted states; the input is untouched."""
    if step_s <= 0.0 or horizon_s <= 0.0:
        raise ValueError("horizon and step must be positive (s)")
    step = min(step_s, horizon_s)
    n_steps = max(1, math.ceil(horizon_s / step - 1e-9))
    out: list[FilterState] = []
    s = state
    for i in range(n_steps):
        dt = step if i < n_steps - 1 else horizon_s - step * (n_steps - 1)
        s = predict(s, dt, params)
        out.append(s)
    return out


# --------------------------------------------------------------------------------------------
# Measurements (6.26–6.29, 6.33, 6.36; §10.3)
# --------------------------------------------------------------------------------------------


def lse_measurement(
    x_m: float,
    y_m: float,
    C2: np.ndarray,
    params: FilterParams | None = None,
    keys: tuple[str, str] = ("fix_e", "fix_n"),
) -> Measurement:
    """Rows 0–1 of eq. 6.26a/6.36: the LSE grid position (m) with its full 2×2 VCV C2 (m²).

    With ``params.coloured`` the rows become x + b_e, y + b_n on the Gauss–Markov states
    ``keys`` (added by :func:`update` on first use, stationary VCV frac·C2, τ = fix_tau_s) and
    R = (1 − frac)·C2, the white part (kalman.md §3.1 option (a)).
    """
    C = np.asarray(C2, dtype=float)
    H = np.zeros((2, N_NAV))
    H[0, IX] = H[1, IY] = 1.0
    z = np.array([x_m, y_m], dtype=float)
    if params is not None and params.coloured:
        f = params.fix_sigma_frac
        return Measurement(z, H, C * (1.0 - f), ("x_LSE", "y_LSE"), (), keys, C * f,
                           (params.fix_tau_s, params.fix_tau_s))
    return Measurement(z, H, C, ("x_LSE", "y_LSE"))


def sensor_measurement(
    state: FilterState,
    *,
    depth_m: float | None = None,
    log_ms: float | None = None,
    gyro_grid_rad: float | None = None,
    incl_rad: float | None = None,
    params: FilterParams,
) -> Measurement:
    """Rows 2–5 (eqs. 6.26b–6.29) for the sensors that gave a value this cycle.

    Pressure depth (m, σ_p), log speed (m/s, σ = max(frac·v, floor), 4.19), gyro GRID heading
    (rad, σ 0.65°, innovation wrapped) and inclination (rad, bow-down +).
    """
    return nav_measurement(state, params, depth_m=depth_m, log_ms=log_ms,
                           gyro_grid_rad=gyro_grid_rad, incl_rad=incl_rad)


def nav_measurement(
    state: FilterState,
    params: FilterParams,
    *,
    fix_xy: tuple[float, float] | None = None,
    fix_cov: np.ndarray | None = None,
    depth_m: float | None = None,
    log_ms: float | None = None,
    gyro_grid_rad: float | None = None,
    incl_rad: float | None = None,
    fix_keys: tuple[str, str] = ("fix_e", "fix_n"),
) -> Measurement:
    """The thesis measurement vector (6.26–6.29, H of 6.33, R of 6.36) in one go: the LSE rows
    (grid m, full 2×2 VCV ``fix_cov`` m²; coloured mode as in :func:`lse_measurement`) and the
    sensor rows that are available, in the fixed order x, y, z_p, v_m, ψ_m, ε_m. ``state`` is
    not read (kept for symmetry with :func:`sensor_measurement`); H has the 11 nav columns."""
    cols: list[int] = []  # H entries (row, col) set to 1
    rows: list[int] = []
    z: list[float] = []
    var: list[float] = []
    labels: list[str] = []
    angle: tuple[int, ...] = ()
    p = 0
    if fix_xy is not None:
        if fix_cov is None:
            raise ValueError("an LSE needs its 2×2 VCV fix_cov")
        rows += [0, 1]
        cols += [IX, IY]
        z += [float(fix_xy[0]), float(fix_xy[1])]
        var += [0.0, 0.0]
        labels += ["x_LSE", "y_LSE"]
        p = 2
    if depth_m is not None:
        rows.append(p)
        cols.append(IZ)
        z.append(depth_m)
        var.append(params.sigma_press_m**2)
        labels.append("z_p")
        p += 1
    if log_ms is not None:
        rows += [p, p]
        cols += [IV, IDV]
        z.append(log_ms)
        var.append(max(params.log_sigma_frac * abs(log_ms), params.log_sigma_floor_ms) ** 2)
        labels.append("v_m")
        p += 1
    if gyro_grid_rad is not None:
        rows += [p, p]
        cols += [IPSI, IDPSI]
        z.append(gyro_grid_rad)
        var.append((params.sigma_gyro_deg * DEG) ** 2)
        labels.append("psi_m")
        angle = (p,)
        p += 1
    if incl_rad is not None:
        rows += [p, p]
        cols += [IEPS, IDEPS]
        z.append(incl_rad)
        var.append((params.sigma_incl_deg * DEG) ** 2)
        labels.append("eps_m")
        p += 1
    H = np.zeros((p, N_NAV))
    for r, c in zip(rows, cols, strict=True):
        H[r, c] = 1.0
    R = np.zeros((p, p))
    for i, vi in enumerate(var):
        R[i, i] = vi
    zz = np.array(z, dtype=float)
    if fix_xy is not None:
        C = np.asarray(fix_cov, dtype=float)
        if params.coloured:
            f = params.fix_sigma_frac
            R[:2, :2] = C * (1.0 - f)
            keys = (fix_keys[0], fix_keys[1]) + (None,) * (p - 2)
            return Measurement(zz, H, R, tuple(labels), angle, keys, C * f,
                               (params.fix_tau_s, params.fix_tau_s))
        R[:2, :2] = C
    return Measurement(zz, H, R, tuple(labels), angle)


def lop_measurement(
    a_rows: np.ndarray,
    omc_m: np.ndarray,
    x_ref: np.ndarray,
    R: np.ndarray,
    fix_keys: Sequence[str | None] | None = None,
    labels: Sequence[str] | None = None,
    bias_cov: np.ndarray | None = None,
    bias_tau_s: Sequence[float] = (),
) -> Measurement:
    """Raw metric LOPs fed directly to the filter (kalman.md §10.3, A10).

    Rows A (k×2, dimensionless, ∂LOP/∂(x, y)) linearised at grid ``x_ref`` (m) where O−C is
    ``omc_m`` (m); R (k×k, m², the white part if rows carry fix-error states). Innovation =
    omc − A(x̂_xy − x_ref) − b, b the Gauss–Markov state ``fix_keys[i]`` of row i (or None);
    ``bias_cov``/``bias_tau_s`` let :func:`update` add missing ones. H is the LSQ A-row padded
    with zeros.
    """
    A = np.atleast_2d(np.asarray(a_rows, dtype=float))
    k = A.shape[0]
    H = np.zeros((k, N_NAV))
    H[:, :2] = A
    z = np.asarray(omc_m, dtype=float).reshape(k) + A @ np.asarray(x_ref, dtype=float)
    lab = tuple(labels) if labels is not None else tuple(f"lop{i}" for i in range(k))
    keys = tuple(fix_keys) if fix_keys is not None and any(fix_keys) else ()
    return Measurement(z, H, np.atleast_2d(np.asarray(R, dtype=float)), lab, (), keys,
                       None if bias_cov is None else np.atleast_2d(bias_cov),
                       tuple(float(t) for t in bias_tau_s))


def _distinct(keys: Sequence[str | None]) -> list[str]:
    out: list[str] = []
    for k in keys:
        if k is not None and k not in out:
            out.append(k)
    return out


def stack_measurements(*parts: Measurement) -> Measurement:
    """Concatenate measurement blocks (R block-diagonal), e.g. LSE rows then sensor rows.

    Fix-error keys are concatenated per row; their prior VCVs block-diagonally (a key already
    given by an earlier block keeps that block's prior).
    """
    parts = tuple(p for p in parts if p.z.shape[0])
    if not parts:
        return Measurement(np.zeros(0), np.zeros((0, N_NAV)), np.zeros((0, 0)), ())
    n = max(p.H.shape[1] for p in parts)
    p_tot = sum(p.z.shape[0] for p in parts)
    H = np.zeros((p_tot, n))
    R = np.zeros((p_tot, p_tot))
    angle: list[int] = []
    keys: list[str | None] = []
    prior: dict[str, tuple[int, int, float, np.ndarray]] = {}  # key -> (part, index, τ, cov)
    i = 0
    for j, p in enumerate(parts):
        k = p.z.shape[0]
        H[i:i + k, :p.H.shape[1]] = p.H
        R[i:i + k, i:i + k] = p.R
        angle.extend(i + a for a in p.angle_rows)
        keys.extend(p.bias_keys if p.bias_keys else (None,) * k)
        if p.bias_cov is not None:
            for m, key in enumerate(_distinct(p.bias_keys)):
                tau = p.bias_tau_s[m] if m < len(p.bias_tau_s) else float("nan")
                prior.setdefault(key, (j, m, tau, p.bias_cov))
        i += k
    z = np.concatenate([p.z for p in parts])
    labels = tuple(lab for p in parts for lab in p.labels)
    if not any(k is not None for k in keys):
        return Measurement(z, H, R, labels, tuple(angle))
    dk = _distinct(keys)
    cov = None
    if all(k in prior for k in dk):
        cov = np.zeros((len(dk), len(dk)))
        for a_, ka in enumerate(dk):
            for b_, kb in enumerate(dk):
                (ja, ma, _, bc), (jb, mb, _, _) = prior[ka], prior[kb]
                if ja == jb:
                    cov[a_, b_] = bc[ma, mb]
    taus = tuple(prior[k][2] for k in dk) if cov is not None else ()
    return Measurement(z, H, R, labels, tuple(angle), tuple(keys), cov, taus)


# --------------------------------------------------------------------------------------------
# Statistical tests (6.37–6.41, A12)
# --------------------------------------------------------------------------------------------


LOM_TABLE_DOF = 20
"""At the default α = 0.05 and up to this many rows the LOM bounds are the χ² quantiles to 6
significant digits: the printed table the filter used before (kept, so the .OUT logs stay
byte-identical); other α or more rows use the full-precision quantiles."""


def lom_bounds(p: int, alpha: float) -> tuple[float, float]:
    """χ²_p bounds (α/2, 1 − α/2) of the LOM test on p rows (before the division by p)."""
    digits = 6 if alpha == 0.05 and p <= LOM_TABLE_DOF else None
    return chi2_bounds(alpha, p, digits)


def _lom_from_nis(nis: float, p: int, alpha: float) -> LomTest:
    lo, hi = lom_bounds(p, alpha)
    t = nis / p
    lower, upper = lo / p, hi / p
    verdict = "reject" if t > upper else ("too small" if t < lower else "accept")
    return LomTest(t, lower, upper, p, verdict)




def _factor_solve(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """L⁻¹B with L the Cholesky factor of S (raises LinAlgError if S is not PD)."""
    L, info = lapack.dpotrf(np.asarray(S, dtype=float), lower=1, clean=1)
    if info != 0:
        raise np.linalg.LinAlgError("matrix is not positive definite")
    B2 = np.asfortranarray(np.asarray(B, dtype=float).reshape(L.shape[0], -1))
    return blas.dtrsm(1.0, L, B2, lower=1).reshape(np.shape(B))


def lom_test(v: np.ndarray, S: np.ndarray, alpha: float = 0.05) -> LomTest:
    """LOM test of any innovation v (p,) with covariance S (p×p), A12 bounds χ²_p/p."""
    w = _factor_solve(S, np.asarray(v, dtype=float))
    return _lom_from_nis(float(w @ w), len(w), alpha)


def innovation_distance(result: UpdateResult, rows: slice = slice(None)) -> float:
    """Mahalanobis length √(v̂ᵀ S⁻¹ v̂) of the innovation ``rows`` of an update (in σ).

    Under H0 its square is χ²_p; a length of tens of σ is no statistical question any more but
    a gross error (a fix thousands of km away), which the cycle keeps out of the filter.
    """
    v = np.asarray(result.innovation[rows], dtype=float)
    if v.shape[0] == 0:
        return 0.0
    S = np.asarray(result.S[rows, rows], dtype=float)
    try:
        w = _factor_solve(S, v)
    except np.linalg.LinAlgError:
        return math.inf
    d2 = float(w @ w)
    return math.sqrt(d2) if d2 >= 0.0 else math.inf


def ls_test(v: np.ndarray, S: np.ndarray, lom_reject: bool) -> LsTest:
    """LS statistics t_i = (S⁻¹v)_i / √(S⁻¹)_ii (eq. 6.41) of any innovation v with covariance S."""
    p = len(v)
    Y = _factor_solve(S, np.column_stack([np.asarray(v, dtype=float), np.eye(p)]))
    return LsTest(Y[:, 1:], Y[:, 0], lom_reject)


# --------------------------------------------------------------------------------------------
# Update (6.21, Joseph form)
# --------------------------------------------------------------------------------------------


def _with_bias_columns(
    state: FilterState, rows: Measurement, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """Add missing fix-error states named by ``rows.bias_keys`` and the 1s of b in H."""
    keys = rows.bias_keys
    if len(keys) != rows.z.shape[0]:
        raise ValueError("bias_keys needs one entry per measurement row")
    dk = _distinct(keys)
    missing = [i for i, k in enumerate(dk) if k not in state.fix_states]
    if missing:
        if rows.bias_cov is None:
            raise ValueError(f"fix-error states {[dk[i] for i in missing]} are not in the state "
                             "and the measurement gives no prior (bias_cov)")
        C = np.asarray(rows.bias_cov, dtype=float)[np.ix_(missing, missing)]
        taus = [rows.bias_tau_s[i] if i < len(rows.bias_tau_s) else params.fix_tau_s
                for i in missing]
        state = add_fix_states(state, [dk[i] for i in missing], C, params, taus)
    if rows.bias_cov is not None and len(missing) < len(dk):
        # The fix's own VCV changes with geometry and receiver: its coloured part frac·C is the
        # stationary VCV that drives the next prediction (no longer frozen at the first fix).
        state = state.with_fix_cov(dk, rows.bias_cov)
    n = state.n
    H = np.zeros((rows.z.shape[0], n))
    H[:, :rows.H.shape[1]] = rows.H
    for i, k in enumerate(keys):
        if k is not None:
            H[i, N_NAV + state.fix_states.index(k)] = 1.0
    return state, H


def update(state: FilterState, rows: Measurement, params: FilterParams) -> UpdateResult:
    """Measurement update (6.21a–c) with the innovation tests (6.37–6.41).

    S = H P Hᵀ + R is Cholesky-factorised (S = L Lᵀ) and one triangular solve L Y = [HP | v̂ | I]
    gives L⁻¹HP, L⁻¹v̂ and L⁻¹, so K = (L⁻¹HP)ᵀ L⁻¹ and T_LOM·p = |L⁻¹v̂|²; neither S nor P is
    inverted. P by the Joseph form (or the thesis (I − KH)P with ``params.joseph=False``),
    symmetrised; heading wrapped to [0, 2π). Rows with fix-error keys first add any missing
    Gauss–Markov states (so the returned state may be larger than the input). Raises
    :class:`FilterDivergence` if S is not PD or a variance becomes ≤ 0 (or non-finite).
    """
    n = state.n
    z = rows.z
    p = z.shape[0]
    if p == 0:
        lom = LomTest(float("nan"), float("nan"), float("nan"), 0, "none")
        empty = np.zeros(0)
        return UpdateResult(state, empty, np.zeros((0, 0)), np.zeros((n, 0)), (), lom,
                            LsTest(np.zeros((0, 0)), empty, False))
    H = rows.H
    if rows.bias_keys:
        state, H = _with_bias_columns(state, rows, params)
        n = state.n
    elif H.shape[1] < n:
        Hp = np.zeros((p, n))
        Hp[:, :H.shape[1]] = H
        H = Hp
    x, P, R = state.x, state.P, rows.R
    v = z - H.dot(x)
    for i in rows.angle_rows:
        v[i] = wrap_pi(v[i])
    HP = H.dot(P)
    S = HP.dot(H.T)
    S += R
    # Cholesky S = L Lᵀ (LAPACK potrf) and one forward substitution L Y = [HP | v | I] (BLAS
    # trsm): numpy has neither a Cholesky solve nor a triangular solve for small matrices.
    L, info = lapack.dpotrf(S, lower=1, clean=1)
    if info != 0:
        raise FilterDivergence("innovation covariance S is not positive definite", state)
    B = np.zeros((p, n + 1 + p), order="F")
    B[:, :n] = HP
    B[:, n] = v
    B[:, n + 1:] = _eye(p)
    Y = blas.dtrsm(1.0, L, B, lower=1)
    LiHP, w, Li = Y[:, :n], Y[:, n], Y[:, n + 1:]
    LiHPt = LiHP.T
    K = LiHPt.dot(Li)  # P Hᵀ S⁻¹ = (L⁻¹HP)ᵀ L⁻¹
    xn = x + LiHPt.dot(w)
    xn[IPSI] = wrap_2pi(xn[IPSI])
    if params.joseph:
        A = _eye(n) - K.dot(H)
        Pn = A.dot(P).dot(A.T)
        Pn += K.dot(R).dot(K.T)
    else:
        Pn = P - K.dot(HP)
    Pn = Pn + Pn.T
    Pn *= 0.5
    new = state._with(state.t, xn, Pn)
    nis = float(w.dot(w))
    if not (np.minimum.reduce(Pn.diagonal()) > 0.0 and math.isfinite(nis)):
        raise FilterDivergence("non-positive or non-finite variance after update", new)
    lom = _lom_from_nis(nis, p, params.alpha)
    ls = LsTest(Li, w, lom.verdict == "reject")
    return UpdateResult(new, v, S, K, rows.labels, lom, ls)
