"""Learning the dead-reckoning process noise from multi-minute predictions (THEORY §8.19).

The one-step fix innovations (engine.filter.adapt) cannot tell whether the filter's random
walks of the current and of the log and gyro biases are right: their effect is second order
over one second and shows only over minutes of dead reckoning. So, while fixes arrive, the
filter keeps **shadow predictions**: at a fix epoch t₀ a copy of the filter's state and
covariance, propagated with the same dynamics, the same gyro/log rows and the process noise in
force, but no fix update. At the first taken fix at or after t₀ + h the shadow is compared with
it (a multi-step innovation, Bar-Shalom, Li & Kirubarajan 2001, §5.4; the predictive NEES):

    NEES_h = dᵀ S_h⁻¹ d,   d = z_fix − H x̂_shadow,   S_h = H P_shadow Hᵀ + R_fix

(H the fix rows: position plus the Gauss–Markov fix-error states where the model has them;
R_fix the white part of the fix VCV in force, λ included). With the right model NEES_h is
χ²₂. One factor μ on the spectral densities of the dead-reckoning states' random walks — the
current (both components) and the log and gyro biases (not the inclinometer's: it does not
move the horizontal position; not the acceleration and rates of turn: those are the vessel's
manoeuvres, seen by the one-step innovations) — is learnt by covariance matching (Mehra 1970,
*IEEE TAC* 15, 175–184; Mohamed & Schwarz 1999, *J. Geodesy* 73, 193–203) on this statistic,
a stochastic approximation in ℓ = ln μ:

    r_k    = min(NEES_h / 2, c)                    (no division by μ: the shadow ran with it)
    Δ_k    = g_k (r_k − (1 − e^{−c})),             g_k = 1 / clamp(k, K₀, W)
    ℓ_k+1  = clamp(ℓ_k + max(Δ_k, −δ), ln μ_min, ln μ_max)

The mean is not robust on purpose (large errors must inflate); the clip c only bounds what one
check can do. Up fast (a run of large NEES raises μ within a few checks: one check raises it
by at most e^{g(c−1)}), down slowly (by at most e^{−δ} per check), and never below μ_min.

The factor applied is ℓ rounded to steps of 1/16 (6 %), so the filter's per-step constants
(engine.filter.model.step_constants) are kept per step of μ, not rebuilt every epoch.

The shadow takes the gyro/log rows of ``every`` records at once (their mean, the variance of
the mean, the heading unwrapped) and one time step of their summed Δt: the same position
variance from white sensor errors as the 1-s steps (v²σ²h), a fifth of the cost.

Pure functions of immutable values; times in s (filter time), μ dimensionless.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from engine.filter.params import FilterParams
from engine.filter.state import IX, IY, FilterState

__all__ = [
    "MU_STEP",
    "START_CHECKS",
    "DrAdaptSettings",
    "DrAdaptState",
    "Shadow",
    "advance",
    "check",
    "learn",
    "scaled_params",
    "shadow_nees",
    "start_shadow",
]

START_CHECKS = 8.0
"""K₀: the gain of the first checks is 1/K₀ at most, so one early check moves ℓ by at most
(c − 1)/K₀ (μ × 2.4 with c = 8)."""

MU_STEP = 1.0 / 16.0
"""Step of ln μ in the factor applied (6 %)."""


@dataclass(frozen=True, slots=True)
class DrAdaptSettings:
    """How the dead-reckoning noise factor μ is learnt (docs/CONFIG.md ``[filter] adapt_dr*``).

    ``horizon_s``: h, the shadow's prediction span (s); ``stagger_s``: a new shadow at most
    this often (s); ``every``: records per shadow step; ``clip``: c (NEES/2); ``window``: W
    (checks); ``down``: δ, the largest fall of ln μ per check; ``mu_min``/``mu_max``: bounds
    of μ; ``max_age_s``: a shadow not checked by then is dropped (s)."""

    horizon_s: float = 300.0
    stagger_s: float = 150.0
    every: int = 5
    clip: float = 8.0
    window: float = 24.0
    down: float = 0.05
    mu_min: float = 1.0
    mu_max: float = 100.0
    max_age_s: float = 7200.0

    def __post_init__(self) -> None:
        if not (self.horizon_s > 0.0 and self.stagger_s > 0.0 and self.every >= 1
                and self.clip > 1.0 and self.window >= 1.0 and self.down > 0.0
                and 0.0 < self.mu_min <= 1.0 <= self.mu_max and math.isfinite(self.mu_max)
                and self.max_age_s >= self.horizon_s):
            raise ValueError("adapt_dr: horizon, stagger, down > 0; every >= 1; clip > 1; "
                             "window >= 1; 0 < mu_min <= 1 <= mu_max; max_age >= horizon")


@dataclass(frozen=True, slots=True)
class Shadow:
    """One shadow prediction: started at filter time ``t0`` (s), its state at ``state.t``."""

    t0: float
    state: FilterState


@dataclass(frozen=True, slots=True)
class Pending:
    """The sensor rows and steps the shadows have not taken yet: the sums of the rows'
    values (angle rows unwrapped) and variances, their layout, how many records, summed Δt."""

    zsum: tuple[float, ...]
    varsum: tuple[float, ...]
    layout: Any
    n: int
    dt: float


@dataclass(frozen=True, slots=True)
class DrAdaptState:
    """The learnt dead-reckoning noise factor and the shadows in flight.

    ``log_mu``: ℓ (continuous); ``mu``: the factor applied (ℓ in steps of :data:`MU_STEP`);
    ``n``: checks learnt from; ``clipped``: checks that hit the clip; ``nees``: the last
    NEES_h (NaN: none yet); ``nees_sum``: the sum of all, for their mean; ``shadows``: oldest
    first; ``pending``: rows every shadow has still to take (None: none); ``last_start``:
    filter time of the newest shadow; ``at_bound``: μ is held at its upper bound."""

    log_mu: float = 0.0
    mu: float = 1.0
    n: int = 0
    clipped: int = 0
    nees: float = math.nan
    nees_sum: float = 0.0
    shadows: tuple[Shadow, ...] = ()
    pending: Pending | None = None
    last_start: float = -math.inf
    at_bound: bool = False

    @property
    def nees_mean(self) -> float:
        """Mean NEES_h of the checks so far (2 when the model is right; NaN before any)."""
        return self.nees_sum / self.n if self.n else math.nan

    def _with(self, shadows: tuple[Shadow, ...], pending: Pending | None,
              last_start: float) -> DrAdaptState:
        """This state with other shadows, pending rows and newest start (positionally)."""
        return DrAdaptState(self.log_mu, self.mu, self.n, self.clipped, self.nees,
                            self.nees_sum, shadows, pending, last_start, self.at_bound)


_SCALED: dict[tuple[int, int], tuple[FilterParams, FilterParams]] = {}


def scaled_params(params: FilterParams, mu: float) -> FilterParams:
    """``params`` with the current's and the log and gyro biases' random walks × ``mu`` (their
    spectral densities; the random-walk rates × √μ); ``params`` itself for μ = 1. Kept per
    (params, step of μ) so the per-Δt constants are built once per step."""
    if mu == 1.0:
        return params
    key = (id(params), round(math.log(mu) / MU_STEP))
    hit = _SCALED.get(key)
    if hit is not None and hit[0] is params:
        return hit[1]
    s = math.sqrt(mu)
    new = replace(params, sigma_current2=params.sigma_current2 * mu,
                  bias_rw_log_ms_sqrth=params.bias_rw_log_ms_sqrth * s,
                  bias_rw_gyro_deg_sqrth=params.bias_rw_gyro_deg_sqrth * s)
    if len(_SCALED) >= 64:
        _SCALED.clear()
    _SCALED[key] = (params, new)
    return new


def _applied(log_mu: float) -> float:
    """The factor applied for ℓ: e^ℓ in steps of :data:`MU_STEP`."""
    return math.exp(round(log_mu / MU_STEP) * MU_STEP)


def start_shadow(st: DrAdaptState, state: FilterState,
                 settings: DrAdaptSettings) -> DrAdaptState:
    """Start a shadow from the filter's state after a fix update, when the newest is at least
    ``stagger_s`` old (so at most ⌈h/stagger⌉ + 1 are in flight) and no rows are pending (the
    shadows share them: a start waits at most ``every`` − 1 records)."""
    t = state.t
    if t - st.last_start < settings.stagger_s or st.pending is not None:
        return st
    return st._with((*st.shadows, Shadow(t, state)), None, t)


Update = Callable[..., Any]
Predict = Callable[..., tuple[FilterState, np.ndarray]]


def _flush(shadows: tuple[Shadow, ...], pend: Pending | None, params: FilterParams,
           update_rows: Update, predict: Predict) -> tuple[Shadow, ...]:
    """Every shadow with the pending rows (their mean, variance/n²) and the summed step."""
    if pend is None:
        return shadows
    zs = var = None
    if pend.n > 0:
        n = float(pend.n)
        zs = [z / n for z in pend.zsum]
        var = [v / (n * n) for v in pend.varsum]
    out = []
    for sh in shadows:
        state = sh.state
        if zs is not None:
            state = update_rows(state, zs, var, pend.layout, params).state
        if pend.dt > 0.0:
            state = predict(state, pend.dt, params)[0]
        out.append(Shadow(sh.t0, state))
    return tuple(out)


def _add(pend: Pending | None, zs: Sequence[float], var: Sequence[float], layout: Any,
         dt: float) -> Pending:
    """``pend`` with this record's rows and step added (angle rows unwrapped against the
    pending mean)."""
    if pend is None:
        return Pending(tuple(zs), tuple(var), layout if zs else None, 1 if zs else 0, dt)
    if not zs:
        return Pending(pend.zsum, pend.varsum, pend.layout, pend.n, pend.dt + dt)
    n = pend.n
    if n == 0:
        return Pending(tuple(zs), tuple(var), layout, 1, pend.dt + dt)
    zsum = list(pend.zsum)
    angles = layout[3]
    for i, z in enumerate(zs):
        if i in angles:  # the reading nearest the pending mean
            mean = zsum[i] / n
            zsum[i] += mean + math.remainder(z - mean, math.tau)
        else:
            zsum[i] += z
    vs = pend.varsum
    return Pending(tuple(zsum), tuple([vs[i] + v for i, v in enumerate(var)]), layout, n + 1,
                  pend.dt + dt)


def advance(st: DrAdaptState, zs: Sequence[float], var: Sequence[float], layout: Any,
            dt: float, params: FilterParams, update_rows: Update, predict: Predict,
            settings: DrAdaptSettings) -> DrAdaptState:
    """The shadows take this record's sensor rows (``engine.filter.measurements.sensor_rows``
    values, variances, layout; none: ``zs`` empty) and its step of ``dt`` s: they are kept
    pending and applied every ``settings.every`` records (earlier when the layout changes)."""
    if not st.shadows:
        return st
    pend = st.pending
    shadows = st.shadows
    if pend is not None and pend.n > 0 and zs and layout is not pend.layout:
        shadows, pend = _flush(shadows, pend, params, update_rows, predict), None
    pend = _add(pend, zs, var, layout, dt)
    if pend.n >= settings.every or (pend.n == 0 and pend.dt >= settings.every):
        shadows, pend = _flush(shadows, pend, params, update_rows, predict), None
    return st._with(shadows, pend, st.last_start)


def shadow_nees(state: FilterState, z: tuple[float, float], fix_cov: np.ndarray,
                white_frac: float) -> float:
    """NEES_h of a fix at grid (x, y) ``z`` (m) against the shadow ``state``: the fix rows are
    the position plus the fix-error states where the shadow has them (then R is
    ``white_frac`` × ``fix_cov``, the white part), else the position with R = ``fix_cov``.
    NaN when S is not positive definite."""
    cols = [(IX,), (IY,)]
    frac = 1.0
    if "fix_e" in state.fix_states and "fix_n" in state.fix_states:
        cols = [(IX, state.index("fix_e")), (IY, state.index("fix_n"))]
        frac = white_frac
    x, P = state.x, state.P
    d = [z[r] - sum(float(x[c]) for c in cols[r]) for r in range(2)]
    S = [[sum(float(P[a, b]) for a in cols[r] for b in cols[s]) + frac * float(fix_cov[r, s])
          for s in range(2)] for r in range(2)]
    a, b, dd = S[0][0], 0.5 * (S[0][1] + S[1][0]), S[1][1]
    det = a * dd - b * b
    if not (a > 0.0 and det > 0.0):
        return math.nan
    p, q = d
    v = (dd * p * p - 2.0 * b * p * q + a * q * q) / det
    return v if math.isfinite(v) else math.nan


def learn(st: DrAdaptState, nees: float, settings: DrAdaptSettings) -> tuple[DrAdaptState,
                                                                          str | None]:
    """One check's step of ℓ from NEES_h (module docstring); a non-finite NEES is not learnt
    and said; reaching μ_max is said once."""
    if not (math.isfinite(nees) and nees >= 0.0):
        return st, f"Dead-reckoning noise factor: NEES {nees!r} not finite, not learnt"
    c = settings.clip
    r = 0.5 * nees
    clipped = r >= c
    if clipped:
        r = c
    k = float(st.n + 1)
    g = 1.0 / min(max(k, min(START_CHECKS, settings.window)), settings.window)
    step = max(g * (r - (1.0 - math.exp(-c))), -settings.down)
    lo, hi = math.log(settings.mu_min), math.log(settings.mu_max)
    ell = min(max(st.log_mu + step, lo), hi)
    at_bound = ell >= hi
    msg = None
    if at_bound and not st.at_bound:
        msg = (f"Dead-reckoning noise factor at its bound {settings.mu_max:g}: the dead "
               "reckoning drifts far more than its model; check the gyro and log")
    mu = min(max(_applied(ell), settings.mu_min), settings.mu_max)
    return replace(st, log_mu=ell, mu=mu, n=st.n + 1, clipped=st.clipped + clipped,
                   nees=nees, nees_sum=st.nees_sum + nees, at_bound=at_bound), msg


def check(st: DrAdaptState, t: float, z: tuple[float, float] | None, fix_cov: np.ndarray | None,
          white_frac: float, params: FilterParams, update_rows: Update, predict: Predict,
          settings: DrAdaptSettings) -> tuple[DrAdaptState, str | None]:
    """At filter time ``t`` (s) with a taken fix at grid ``z`` (None: no fix this epoch): the
    oldest shadow, when at least h old, is compared with it and learnt from; the others as old
    are dropped (one check per fix: they would see the same fix error). Shadows older than
    ``max_age_s`` are dropped unchecked."""
    shadows = st.shadows
    if not shadows or t - shadows[0].t0 < settings.horizon_s - 1e-6:
        return st, None
    if z is None or fix_cov is None:
        if t - shadows[0].t0 <= settings.max_age_s:
            return st, None
        keep = tuple(sh for sh in shadows if t - sh.t0 <= settings.max_age_s)
        return st._with(keep, st.pending if keep else None, st.last_start), None
    flushed = _flush(shadows, st.pending, params, update_rows, predict)
    keep = tuple(sh for sh in flushed if t - sh.t0 < settings.horizon_s - 1e-6)
    nees = shadow_nees(flushed[0].state, z, fix_cov, white_frac)
    return learn(st._with(keep, None, st.last_start), nees, settings)
