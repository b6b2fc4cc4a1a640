"""The filter state with named indices: the only code that edits the state vector.

State (THEORY §8.6), SI units, TM grid frame:
0 x, 1 y (grid East/North, m), 2 z (depth, m, positive down), 3 v (speed through water, m/s),
4 ψ (GRID heading, rad, kept in [0, 2π)), 5 ε (inclination, rad, bow-down positive),
6 v_cx, 7 v_cy (current East/North, m/s), 8 Δv (log bias, m/s), 9 Δψ (gyro bias, rad),
10 Δε (inclinometer bias, rad); then optional first-order Gauss–Markov fix-error states
(thesis §6.3.2 / A6, THEORY §8.2) appended at index 11 onwards.

A :class:`FilterState` is an immutable value; the constructors (:func:`init_state`,
:func:`add_fix_states`, :func:`restart_fix_states`) and the edits the operator and the run
make (:func:`replace_position`, :func:`replace_current`, :func:`move_to_grid`) return new
states; code outside this module reads the state through the named indices or the properties
of :class:`FilterState`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from engine.filter.params import DEG, FilterParams, read_only
from engine.geodesy.angles import wrap_2pi

N_NAV = 11

IX, IY, IZ, IV, IPSI, IEPS, IVCX, IVCY, IDV, IDPSI, IDEPS = range(N_NAV)

STATE_LABELS: tuple[str, ...] = (
    "x", "y", "z", "v", "psi", "eps", "v_cx", "v_cy", "dv", "dpsi", "deps",
)


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
            object.__setattr__(self, name, read_only(np.array(getattr(self, name), dtype=float)))

    @property
    def n(self) -> int:
        """Number of states (11 plus augmented fix-error states)."""
        return self.x.shape[0]

    @property
    def east_north_m(self) -> tuple[float, float]:
        """Horizontal position (grid East x, North y) [m]."""
        return float(self.x[IX]), float(self.x[IY])

    @property
    def depth_m(self) -> float:
        """Depth z [m, positive down]."""
        return float(self.x[IZ])

    @property
    def position_cov_m2(self) -> np.ndarray:
        """A copy of the 2×2 VCV of the horizontal position (x, y) [m²]."""
        return np.array(self.P[IX:IY + 1, IX:IY + 1])

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
        fc.setflags(write=False)
        new = object.__new__(FilterState)  # x and P are shared, and read-only already
        d = new.__dict__
        d.update(self.__dict__)
        d["fix_cov"] = fc
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


def estimate_parts(fs: FilterState) -> tuple[float, float, float, np.ndarray, bool]:
    """The horizontal position x, y (grid m) and depth z (m) of a state as floats, a read-only
    copy of its 2×2 position VCV (m²) and whether that VCV is finite: what the estimate of a
    state is made of (:func:`engine.filter.estimate.filter_estimate`)."""
    x, y, z = fs.x[IX:IZ + 1].tolist()
    cov = fs.P[IX:IY + 1, IX:IY + 1].copy()
    finite = all(map(math.isfinite, cov.ravel().tolist()))
    cov.setflags(write=False)
    return x, y, z, cov, finite


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
    """Initial state x̂₀|₀ (THEORY §8.11, biases 0) and P₀: I₁₁ ("thesis") or the D26
    "physical" P₀.

    ``pos_cov`` (2×2, m²), e.g. the first LSE's VCV (A3), replaces the position block in either
    mode; "physical" otherwise uses ``dr_pos_sigma_m``. Heading in grid rad, wrapped to [0, 2π).
    ``from_sensors`` says which of speed, heading and inclination are a sensor reading (log,
    gyro, inclinometer): such a value estimates state + bias (6.27–6.29) with the sensor's σ,
    so in "physical" mode its error is the reading's error minus the unknown bias: P_ss = σ_m² +
    σ_b², P_sb = −σ_b², P_bb = σ_b² (σ_b the D26 bias σ) instead of independent σ_m², σ_b².
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
    """Append first-order Gauss–Markov fix-error states (A6; THEORY §8.2), zero mean.

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
    tau_s: Sequence[float] | None = None,
) -> tuple[FilterState, np.ndarray | None]:
    """Start the Gauss–Markov fix-error states ``keys`` afresh as a new, independent error
    process (the fix source changed, e.g. C/A → P code, SPS → DGPS): b = 0, P_bb = ``cov`` (its
    stationary VCV, m²), no covariance with any other state, and ``fix_cov`` = ``cov``; with
    ``tau_s`` (s, one per key) the new process's correlation times too.

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
    if tau_s is not None:
        taus = list(new.fix_tau_s)
        for i, k in zip(present, keys, strict=True):
            taus[new.fix_states.index(k)] = float(tau_s[i])
        new.__dict__["fix_tau_s"] = tuple(taus)
    if phi is not None:
        phi = np.array(phi)
        phi[idx, :] = 0.0
    return new, phi


# --------------------------------------------------------------------------------------------
# Edits by the run and the operator (the only code that writes into x and P)


def replace_position(fs: FilterState, x_m: float, y_m: float, cov: np.ndarray) -> FilterState:
    """The state with its horizontal position at grid (``x_m``, ``y_m``) [m] with the 2×2 VCV
    ``cov`` [m²] and no covariance with any other state."""
    x = fs.x.copy()
    P = fs.P.copy()
    x[IX], x[IY] = x_m, y_m
    P[IX:IY + 1, :] = 0.0
    P[:, IX:IY + 1] = 0.0
    P[IX:IY + 1, IX:IY + 1] = cov
    return replace(fs, x=x, P=P)


def replace_current(
    fs: FilterState, east_ms: float, north_ms: float, variance: float
) -> FilterState:
    """The state with the grid current (``east_ms``, ``north_ms``) [m/s], each component with
    ``variance`` [m²/s²] and no covariance with any other state (the operator's estimate)."""
    x = np.array(fs.x)
    P = np.array(fs.P)
    x[IVCX], x[IVCY] = east_ms, north_ms
    P[IVCX:IVCY + 1, :] = 0.0
    P[:, IVCX:IVCY + 1] = 0.0
    P[IVCX, IVCX] = P[IVCY, IVCY] = variance
    return replace(fs, x=x, P=P)


def move_to_grid(fs: FilterState, x_m: float, y_m: float, rotation_rad: float) -> FilterState:
    """The state carried to another grid: position at (``x_m``, ``y_m``) [m]; grid heading,
    current and their covariances turned by the change of grid convergence Δγ =
    ``rotation_rad`` (a grid azimuth α becomes α − Δγ; THEORY D3)."""
    c, s_ = math.cos(rotation_rad), math.sin(rotation_rad)
    # (e, n) → (e cosΔ − n sinΔ, n cosΔ + e sinΔ).
    rot = np.array([[c, -s_], [s_, c]])
    J = np.eye(fs.n)
    J[IX:IY + 1, IX:IY + 1] = rot
    J[IVCX:IVCY + 1, IVCX:IVCY + 1] = rot
    x = np.array(fs.x, dtype=float)
    x[IX], x[IY] = x_m, y_m
    x[IPSI] = wrap_2pi(x[IPSI] - rotation_rad)
    x[IVCX:IVCY + 1] = rot @ x[IVCX:IVCY + 1]
    P = J @ fs.P @ J.T
    return replace(fs, x=x, P=0.5 * (P + P.T))


def restart_dr_states(fs: FilterState, params: FilterParams) -> FilterState:
    """The state with the current (grid east/north, m/s), the log bias (m/s) and the gyro bias
    (rad) restarted at 0 with their physical P0 variances (``params.p0_current_sigma_ms``,
    ``p0_log_bias_ms``, ``p0_gyro_bias_deg``) and no covariance with any other state: the dead
    reckoning changed its reference (gyro/log through the water ↔ COG/SOG over ground), so what
    those states had learnt belongs to the other sensors (docs/GNSS_WEIGHTS.md)."""
    x = np.array(fs.x)
    P = np.array(fs.P)
    sig = ((IVCX, params.p0_current_sigma_ms), (IVCY, params.p0_current_sigma_ms),
           (IDV, params.p0_log_bias_ms), (IDPSI, params.p0_gyro_bias_deg * DEG))
    for i, s in sig:
        x[i] = 0.0
        P[i, :] = 0.0
        P[:, i] = 0.0
        P[i, i] = s * s
    return fs._with(fs.t, x, P)


def fix_states_from_fix(
    state: FilterState,
    keys: Sequence[str],
    cov: np.ndarray,
    params: FilterParams,
    tau_s: float,
) -> FilterState:
    """The fix-error states ``keys`` (grid east, north) of a position just set from a fix
    (:func:`replace_position`) whose coloured error they model: b = 0, P_bb = ``cov`` (m², its
    stationary VCV frac·C_LSE) and cov(x̂ − x, b̂ − b) = −``cov``, because x̂ − x = b + w for a
    position taken from that fix. Without that correlation the filter would count the next fix
    of the same slowly varying error as independent of the first and halve the variance for as
    long as τ lasts (issue 13: τ = 30 min for a receiver-weighted GNSS fix). Keys not yet in the
    state are added (correlation time ``tau_s`` s)."""
    state = add_fix_states(state, keys, cov, params, tau_s)
    C = 0.5 * (np.asarray(cov, dtype=float) + np.asarray(cov, dtype=float).T)
    idx = [N_NAV + state.fix_states.index(k) for k in keys]
    x = np.array(state.x)
    P = np.array(state.P)
    x[idx] = 0.0
    P[idx, :] = 0.0
    P[:, idx] = 0.0
    P[np.ix_(idx, idx)] = C
    P[np.ix_([IX, IY], idx)] = -C
    P[np.ix_(idx, [IX, IY])] = -C.T
    return state._with(state.t, x, P).with_fix_cov(keys, C)



def inflate_fix_states(state: FilterState, keys: Sequence[str], add_cov: np.ndarray) -> FilterState:
    """The fix-error states ``keys`` with ``add_cov`` (m², positive semi-definite, over
    ``keys``) added to their P block: extra process noise when the stationary VCV of the error
    they model has grown (a larger HDOP; docs/GNSS_WEIGHTS.md). Their estimate is unchanged;
    the smoother's (state, prediction, Φ) link stays consistent (the noise of a prediction is
    what Φ does not explain)."""
    idx = [N_NAV + state.fix_states.index(k) for k in keys]
    P = np.array(state.P)
    P[np.ix_(idx, idx)] += 0.5 * (add_cov + add_cov.T)
    return state._with(state.t, np.array(state.x), P)
