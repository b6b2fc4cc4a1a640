"""Noise adaptation: the filter learns the variance of its fixes from the data.

Method (docs/THEORY.md §8.17): one variance factor λ on the fix VCV C_LSE (the family λ·C of
a variance-component / covariance-matching estimate: Mehra 1970, *IEEE TAC* 15; Mohamed &
Schwarz 1999, *J. Geodesy* 73, 193–203), learnt from two statistics whose expectation is 1 when
the VCV is right:

* **S²** of a redundant fix (r = n − 2 > 0 degrees of freedom): the least squares' a-posteriori
  variance factor, vᵀC_l⁻¹v / r, a χ²_r/r variable at each epoch. It sees the size of the LOP
  errors at the epoch itself, so it is blind to their correlation in time (a slowly varying
  Decca sky-wave error is as large in S² as a white one).
* **NIS** per row of the filter's fix update, v_fᵀS_f⁻¹v_f / 2, χ²_2/2: the only evidence for
  a fix without redundancy (GPS alone). With the Gauss–Markov fix-error states it sees the
  white part and the epoch-to-epoch change of the fix error, not its slow part.

Each is a robust M-estimate of scale by stochastic approximation in the logarithm (ℓ = ln λ):

    r_k   = min(t_k / λ_k, c)                       (t_k the statistic relative to the a-priori
    ℓ_k+1 = ℓ_k + g_k (r_k − E[min(χ²_d/d, c)])     VCV: S², or NIS × the factor the update's
                                                     VCV carried; λ_k the factor in force; d dof;
                                                     g_k = 1/clamp(k, 30, W): a running mean
                                                     at first, a window of W epochs later)

At the fixed point the clipped, normalised statistic has its χ² expectation: the covariance-
matching condition "observed = predicted" for the family λ·C. The clip c bounds what one epoch
can do: a blunder moves λ by at most e^{(c−1)·g}, 10 % in the first 30 fix epochs and 1 % once
g = 1/W (c = 4, W = 300), so one outlier never inflates everything; it also bounds the rate.
The factor applied is λ = clamp(e^{max(ℓ_S², ℓ_NIS)}, λ_min, λ_max), with λ_min = 1: the
a-priori VCV of the receiver class or chain is the floor (learning only widens; over-coverage
is the small fault). A non-finite statistic is ignored and said; a factor that reaches its upper
bound is clamped and said.

Pure functions of immutable values; λ is dimensionless (a variance factor), W in fix epochs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = [
    "START_WINDOW",
    "AdaptSettings",
    "AdaptState",
    "clipped_chi2_mean",
    "fix_nis_ratio",
    "gain",
    "learn_fix",
    "start",
]


@dataclass(frozen=True, slots=True)
class AdaptSettings:
    """How the fix-VCV factor is learnt (docs/CONFIG.md ``[filter] adapt*``).

    ``window``: W, fix epochs (the step of ℓ is 1/W); ``clip``: c, the largest NIS per row
    one epoch counts with; ``fix_min``/``fix_max``: bounds of λ (variance factors)."""

    window: float = 300.0
    clip: float = 4.0
    fix_min: float = 1.0
    fix_max: float = 100.0

    def __post_init__(self) -> None:
        if not (self.window >= 1.0 and self.clip > 1.0 and 0.0 < self.fix_min <= 1.0
                <= self.fix_max and math.isfinite(self.fix_max)):
            raise ValueError("adapt: window >= 1, clip > 1, 0 < fix_min <= 1 <= fix_max")


@dataclass(frozen=True, slots=True)
class AdaptState:
    """The learnt fix-VCV factor of one fix source.

    ``log_s2`` and ``log_nis``: ℓ of the two statistics (each held within the bounds'
    logarithms); ``fix_factor``: λ applied to the next fix's VCV; ``n``: fix epochs learnt
    from; ``clipped``: statistics that hit the clip; ``source``: the fix source it belongs to
    (``engine.run.cycle.fix_source``: a new source starts again at λ = 1); ``at_bound``: λ is
    held at its upper bound (said once when it gets there)."""

    log_s2: float = 0.0
    log_nis: float = 0.0
    fix_factor: float = 1.0
    n: int = 0
    clipped: int = 0
    source: tuple[object, ...] | None = None
    at_bound: bool = False


def start(source: tuple[object, ...] | None) -> AdaptState:
    """The state before any fix of ``source``: λ = 1 (the a-priori VCV)."""
    return AdaptState(source=source)


@lru_cache(maxsize=64)
def clipped_chi2_mean(n: int, c: float) -> float:
    """E[min(X/n, c)] for X ~ χ²_n (n = 1 or 2 in closed form, else by a 64-point rule):
    the value the clipped statistic has when the model is right, so clipping adds no bias."""
    if n == 2:  # X/2 ~ Exp(1): E[min(Y, c)] = 1 − e^{−c}
        return 1.0 - math.exp(-c)
    if n == 1:  # X = Z²: E[min(Z², c)] = P(Z² ≤ c) − 2c^{1/2}φ(c^{1/2}) + c·P(Z² > c)
        s = math.sqrt(c)
        p_in = math.erf(s / math.sqrt(2.0))
        phi = math.exp(-0.5 * c) / math.sqrt(2.0 * math.pi)
        return p_in - 2.0 * s * phi + c * (1.0 - p_in)
    # general n: E[min(X/n, c)] = ∫0^c P(X/n > t) dt, midpoint rule on a fine grid
    from math import lgamma

    k = n / 2.0
    ts = (np.arange(512) + 0.5) * (c / 512)

    def sf(t: float) -> float:  # P(χ²_n > n t) by the series of the regularised gamma
        x = n * t / 2.0
        term = math.exp(k * math.log(x) - x - lgamma(k + 1.0)) if x > 0 else 0.0
        total, j = term, 1
        while term > 1e-15 * max(total, 1e-300) and j < 500:
            term *= x / (k + j)
            total += term
            j += 1
        return max(0.0, 1.0 - total)

    return float(sum(sf(float(t)) for t in ts) * (c / 512))


def fix_nis_ratio(innovation: np.ndarray, S: np.ndarray, rows: slice) -> float:
    """v_fᵀ S_f⁻¹ v_f / n_f of the fix rows ``rows`` of an update (the marginal of the stacked
    innovation: the depth row stacked with them does not enter). NaN when S_f is not positive
    definite or the result is not finite. Two rows (the LSE) in closed form on floats."""
    v = innovation[rows].tolist()
    n = len(v)
    if n == 2:
        (a, b), (b2, d) = S[rows, rows].tolist()
        b = 0.5 * (b + b2)
        det = a * d - b * b
        if not (a > 0.0 and det > 0.0):
            return math.nan
        p, q = v
        r = (d * p * p - 2.0 * b * p * q + a * q * q) / det / 2.0
        return r if math.isfinite(r) else math.nan
    if n == 0:
        return math.nan
    Sf = np.asarray(S, dtype=float)[rows, rows]
    try:
        L = np.linalg.cholesky(Sf)
    except np.linalg.LinAlgError:
        return math.nan
    w = np.linalg.solve(L, np.asarray(v))
    r = float(w @ w) / n
    return r if math.isfinite(r) else math.nan


def gain(n: int, settings: AdaptSettings) -> float:
    """The step of the ``n``-th fix epoch (n ≥ 1): 1/clamp(n, W_min, W). The first epochs
    average (a running mean learns a short surfaced period quickly), W_min = ``START_WINDOW``
    keeps one early blunder from moving λ by more than e^{(c−1)/W_min} (10 %)."""
    return 1.0 / min(max(float(n), min(START_WINDOW, settings.window)), settings.window)


START_WINDOW = 30.0
"""W_min of :func:`gain` (fix epochs)."""


def _step(log_value: float, statistic: float, dof: int, factor: float, step: float,
          settings: AdaptSettings) -> tuple[float, bool]:
    """One step of ℓ from ``statistic`` (its χ²_dof/dof expectation 1 with the right VCV),
    normalised by the factor in force, with gain ``step``; returns (ℓ, clipped). ℓ is held
    within the bounds' logarithms (anti-windup: a long spell at a bound cannot wind it up)."""
    c = settings.clip
    r = statistic / factor
    clipped = r >= c
    if clipped:
        r = c
    log_value += (r - clipped_chi2_mean(dof, c)) * step
    lo, hi = _log_bounds(settings.fix_min, settings.fix_max)
    return (lo if log_value < lo else hi if log_value > hi else log_value), clipped


@lru_cache(maxsize=16)
def _log_bounds(lo: float, hi: float) -> tuple[float, float]:
    """(ln lo, ln hi)."""
    return math.log(lo), math.log(hi)


def learn_fix(state: AdaptState, settings: AdaptSettings, *, nis: float | None = None,
              nis_rows: int = 2, s2: float | None = None,
              s2_dof: int = 0) -> tuple[AdaptState, str | None]:
    """One fix epoch's step of λ (module docstring) from the fix update's NIS per row ``nis``
    relative to the a-priori VCV (:func:`fix_nis_ratio` × the factor the update's fix VCV
    carried: its expectation is then λ_true, as S²'s is; over ``nis_rows`` rows; None: no fix
    update) and the fix's S²
    with ``s2_dof`` > 0 degrees of freedom (None or 0 dof: no redundancy). Returns the new
    state and a message when a statistic was not finite (ignored) or λ has just reached its
    upper bound (clamped)."""
    log_s2, log_nis, clipped = state.log_s2, state.log_nis, state.clipped
    factor = state.fix_factor
    bad = []
    used = False
    w = settings.window  # gain(state.n + 1, settings) inline
    k = float(state.n + 1)
    step = 1.0 / min(max(k, min(START_WINDOW, w)), w)
    if nis is not None:
        if math.isfinite(nis) and nis >= 0.0:
            log_nis, c = _step(log_nis, nis, nis_rows, factor, step, settings)
            clipped += c
            used = True
        else:
            bad.append(f"NIS {nis!r}")
    if s2 is not None and s2_dof > 0:
        if math.isfinite(s2) and s2 >= 0.0:
            log_s2, c = _step(log_s2, s2, s2_dof, factor, step, settings)
            clipped += c
            used = True
        else:
            bad.append(f"S² {s2!r}")
    msg = None
    if bad:
        msg = f"Fix noise factor: {', '.join(bad)} not finite, not learnt"
    if not used:
        return state, msg
    hi = _log_bounds(settings.fix_min, settings.fix_max)[1]
    ell = log_s2 if log_s2 > log_nis else log_nis
    at_bound = ell >= hi
    if at_bound and not state.at_bound:
        msg = (f"Fix noise factor at its bound {settings.fix_max:g} (σ × "
               f"{math.sqrt(settings.fix_max):.3g}): the fixes are far worse than their VCV; "
               "check the systems")
    new = AdaptState(log_s2, log_nis, max(settings.fix_min, math.exp(ell)), state.n + 1,
                     clipped, state.source, at_bound)
    return new, msg
