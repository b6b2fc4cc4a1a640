"""Test statistics of a least-squares fix (thesis ch. 5.4): w-test, reliability, unit variance.

The bottom of ``engine.lsq``: imports only numpy/SciPy and is used by the adjustment core
(:mod:`engine.lsq.adjustment`), the robust estimator and the data-snooping driver
(:mod:`engine.lsq.snooping`). Baarda's data snooping statistics ("B-method", eq. 5.7–5.10) on the
FULL (correlated) matrices, the reliability factor τ (5.11), the variance factor VF (5.12),
redundancy numbers, minimal detectable bias and its effect on the position (not in the thesis,
THEORY §6.3), the unit-variance χ² test (5.13–5.17) and the cumulative unit variance (5.18).

Everything here works on metric quantities (m, m²) but is unit-agnostic: any consistent units do.
Quantiles are computed once per argument set (``functools.lru_cache``); the normal quantiles come
from :class:`statistics.NormalDist`, the χ² quantiles from a table (SciPy only outside it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from statistics import NormalDist
from typing import Any, TypeVar

import numpy as np

from engine.lsq.chi2_table import CHI2_QUANTILES

#: The fixed rejection bound of the thesis, |w| > 2.576 (N(0,1) quantile 0.995, thesis L6665).
REJECT_BOUND = 2.576

_NORMAL = NormalDist()

_T = TypeVar("_T")


def frozen_instance(cls: type[_T], values: dict[str, Any]) -> _T:
    """The instance ``cls(**values)`` of a frozen dataclass without ``__slots__`` or
    ``__post_init__``, made without the generated ``__init__``'s ``object.__setattr__`` per
    field (a fix makes several such results per epoch). ``values`` names every field, in order,
    and becomes the instance's ``__dict__`` (a new dict the caller does not keep).
    """
    obj = object.__new__(cls)
    _set_dict(obj, "__dict__", values)  # ``values`` becomes the instance dict (no copy)
    return obj


_set_dict = object.__setattr__


# --------------------------------------------------------------------------------------------
# Critical values (cached per argument)


@lru_cache(maxsize=64)
def w_critical(alpha: float) -> float:
    """Two-sided N(0,1) critical value k_α = z_{1−α/2} of the w-test (eq. 5.10a, corrected).

    ``alpha`` is ReliabInterval/100, e.g. 0.05 → 1.960, 0.01 → 2.576.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    return _NORMAL.inv_cdf(1.0 - alpha / 2.0)


@lru_cache(maxsize=64)
def delta0(alpha: float, power: float = 0.80) -> float:
    """Baarda's non-centrality bound δ0 = z_{1−α/2} + z_{power} (2.80 at α 0.05, power 0.80)."""
    if not 0.0 < power < 1.0:
        raise ValueError(f"power must be in (0, 1), got {power}")
    return w_critical(alpha) + _NORMAL.inv_cdf(power)


@lru_cache(maxsize=256)
def chi2_quantile(p: float, dof: int) -> float:
    """The χ²_dof quantile x with P(χ²_dof ≤ x) = ``p``: from :mod:`engine.lsq.chi2_table`, else
    2·P⁻¹(dof/2, p) from ``scipy.special`` (what ``scipy.stats.chi2.ppf`` computes, same bits)."""
    row = CHI2_QUANTILES.get(p)
    if row is not None and 1 <= dof <= len(row):
        return row[dof - 1]
    if dof <= 0:
        return math.nan
    from scipy.special import gammaincinv  # cold path: p or dof outside the table

    return float(2 * gammaincinv(dof / 2, p))


@lru_cache(maxsize=256)
def chi2_bounds(alpha: float, dof: int, significant: int | None = None) -> tuple[float, float]:
    """Two-sided acceptance region (χ²_{α/2, dof}, χ²_{1−α/2, dof}) of a χ² test of size α.

    The one χ² bound of the engine: the unit-variance test (5.15–5.17), the filter's LOM test
    (6.38–6.40) and the NEES bands of the accuracy assessment. ``significant``: round both to
    that many significant digits (the filter's printed table, see engine.filter.update).
    """
    lo, hi = chi2_quantile(alpha / 2.0, dof), chi2_quantile(1.0 - alpha / 2.0, dof)
    if significant is None:
        return lo, hi
    return float(f"{lo:.{significant}g}"), float(f"{hi:.{significant}g}")


def classify_w(w: float, alpha: float = 0.05, bound: float = REJECT_BOUND) -> str:
    """Verdict of one w-test (thesis L6665–6669): "reject" (|w| > bound, the rejection loop's
    bound, whatever α), "monitor" (k_α < |w| ≤ bound), "accept" otherwise; "" when w was not
    computed (NaN). For α < 1 % (k_α > 2.576) the monitor band is empty."""
    if math.isnan(w):
        return ""
    aw = abs(w)
    if aw > bound:
        return "reject"
    return "monitor" if aw > w_critical(alpha) else "accept"


# --------------------------------------------------------------------------------------------
# Per-slot statistics


@dataclass(frozen=True, eq=False)
class SlotStatistics:
    """Per-slot test and reliability quantities; NaN for unused slots or when r < 1.

    ``sigma_d`` [m] (5.8b), ``w`` [-] (5.8c), ``tau`` [-] (5.11), ``vf`` [-] (5.12),
    ``redundancy`` r_i = (C_v W)_ii [-], ``mdb`` [m] = δ0·σ_d (internal reliability),
    ``ext`` (n, u) [m] = C_x̂ Aᵀ W e_i·MDB_i (external reliability), ``ext_h`` [m] its
    horizontal norm (first two parameters).
    """

    sigma_d: np.ndarray
    w: np.ndarray
    tau: np.ndarray
    vf: np.ndarray
    redundancy: np.ndarray
    mdb: np.ndarray
    ext: np.ndarray
    ext_h: np.ndarray


def used_statistics(
    Au: np.ndarray,
    Clu: np.ndarray,
    Wu: np.ndarray,
    cov_x: np.ndarray,
    vu: np.ndarray,
    d0: float,
    gain: np.ndarray | None = None,
    wv: np.ndarray | None = None,
    atw: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Statistics on the USED sub-block (m rows), as one (7 + u, m) array with rows
    σ_d, w, τ, VF, r_i, MDB, |∇x̂|_h, then the u components of ∇x̂ (units as in SlotStatistics);
    written into ``out`` (a (7 + u, m) float64 array or view) when given.

    With G = C_x̂ Aᵀ W (``gain``, u × m) and C_v = C_l − A C_x̂ Aᵀ (5.5b corrected):
    σ_d = (e_iᵀ W C_v W e_i)^(−1/2) = (W_ii − (AᵀW)_·i·G_·i)^(−1/2) (5.8b);
    w = −(e_iᵀ W v)·σ_d (5.8c, ``wv`` = W v); τ = σ_d/σ_i (5.11);
    VF = (A C_x̂ Aᵀ)_ii/(C_l)_ii = (C_l − C_v)_ii/(C_l)_ii (5.12); r_i = (C_v W)_ii = 1 − (A G)_ii;
    MDB = δ0·σ_d; ∇x̂_i = G e_i·MDB_i. Full (correlated) matrices throughout. ``gain``, ``wv``
    and ``atw`` = AᵀW may be passed in when the caller already has them.
    The caller guarantees redundancy ≥ 1. An observation no other one checks (r_i ≈ 0, i.e.
    e_iᵀWC_vWe_i ≤ 1e-10·W_ii) gets σ_d = τ = MDB = inf and w = ∇x̂ = NaN (not testable).
    """
    m, u = Au.shape
    if out is None:
        out = np.empty((7 + u, m))
    if atw is None:
        atw = Au.T.dot(Wu)
    if gain is None:
        gain = cov_x.dot(atw)
    if wv is None:
        wv = Wu.dot(vu)
    add = np.add.reduce
    wdiag = Wu.diagonal()
    q = wdiag - add(atw * gain, axis=0)  # diag(W C_v W) = diag(W − Wᵀ A C_x̂ Aᵀ W)
    any_bad = not (np.minimum.reduce(q / wdiag) > 1e-10)
    if any_bad:
        bad = q <= 1e-10 * wdiag
        q[bad] = np.inf
    sd = out[0]
    np.power(q, -0.5, out=sd)  # σ_d (5.8b); inf → 0, fixed below
    var_l = Clu.diagonal()
    np.multiply(wv, sd, out=out[1])
    np.negative(out[1], out=out[1])  # w (5.8c)
    np.divide(sd, np.sqrt(var_l), out=out[2])  # τ (5.11)
    np.divide(add(Au * Au.dot(cov_x), axis=1), var_l, out=out[3])  # VF (5.12)
    np.subtract(1.0, add(Au * gain.T, axis=1), out=out[4])  # r_i = (C_v W)_ii
    np.multiply(sd, d0, out=out[5])  # MDB
    ext = out[7:]
    np.multiply(gain, out[5], out=ext)  # columns: C_x̂ Aᵀ W e_i·MDB_i
    if u >= 2:
        np.hypot(ext[0], ext[1], out=out[6])
    else:
        np.abs(ext[0], out=out[6])
    if any_bad:
        out[0, bad] = np.inf
        out[2, bad] = np.inf
        out[5, bad] = np.inf
        out[1, bad] = np.nan
        out[6:, bad] = np.nan
    return out


def w_tests(
    A: np.ndarray,
    Cl: np.ndarray,
    W: np.ndarray,
    cov_x: np.ndarray,
    v: np.ndarray,
    used: np.ndarray,
    *,
    alpha: float = 0.05,
    power: float = 0.80,
) -> SlotStatistics:
    """Per-slot w-tests and reliability (eq. 5.5b, 5.8b–c, 5.11, 5.12) over all n slots.

    ``A`` (n, u) metric design, ``Cl`` (n, n) a priori VCV [m²], ``W`` (n, n) weights (only the
    used block is read), ``cov_x`` (u, u) the a priori C_x̂ [m²] (unscaled), ``v`` (n,) residuals
    [m], ``used`` (n,) bool. Slots not used, or all slots when the redundancy is < 1
    (categories I/II), get NaN (the screens' 999.99). MDB uses δ0(α, power).
    """
    used = np.asarray(used, dtype=bool)
    n = used.size
    u = np.asarray(A).shape[1]
    idx = np.flatnonzero(used)
    if idx.size - u < 1:
        return nan_statistics(n, u)
    sub = np.ix_(idx, idx)
    block = used_statistics(
        np.asarray(A, float)[idx],
        np.asarray(Cl, float)[sub],
        np.asarray(W, float)[sub],
        np.asarray(cov_x, float),
        np.asarray(v, float)[idx],
        delta0(alpha, power),
    )
    return scatter_statistics(block, idx, n)


def nan_statistics(n: int, u: int) -> SlotStatistics:
    """All-NaN per-slot statistics for n slots and u parameters (nothing computed)."""
    return statistics_view(np.full((7 + u, n), np.nan))


def statistics_view(block: np.ndarray) -> SlotStatistics:
    """SlotStatistics viewing the rows of a (7 + u, n) block laid out as in used_statistics."""
    return SlotStatistics(
        block[0], block[1], block[2], block[3], block[4], block[5], block[7:].T, block[6]
    )


def scatter_statistics(block: np.ndarray, idx: np.ndarray, n: int) -> SlotStatistics:
    """Per-slot statistics for n slots from the used-block result of :func:`used_statistics`."""
    if idx.size == n:
        return statistics_view(block)
    full = np.full((block.shape[0], n), np.nan)
    full[:, idx] = block
    return statistics_view(full)


# --------------------------------------------------------------------------------------------
# Unit variance


@dataclass(frozen=True)
class UnitVarianceTest:
    """Two-sided χ² test of S² (eq. 5.15–5.17): T = dof·S²/σ0² ~ χ²_dof.

    ``statistic`` = T; ``lower``/``upper`` are the acceptance bounds on S² itself
    (σ0²·χ²_{α/2}/dof, σ0²·χ²_{1−α/2}/dof); ``accepted`` = lower < S² < upper; ``dof`` used.
    """

    statistic: float
    lower: float
    upper: float
    accepted: bool
    dof: int


def unit_variance_test(
    s2: float, r: int, alpha: float = 0.05, s02: float = 1.0, thesis_dof: bool = False
) -> UnitVarianceTest | None:
    """Test H0: σ0² = s02 for the sample unit variance S² with redundancy r (THEORY §6.4).

    Default dof = r (correct for known σ0²); ``thesis_dof=True`` uses the printed (r − 1) of
    eq. 5.16–5.17. Returns None when dof < 1 (no test possible). Sample: r = 2, α = 0.05 →
    0.0253 < S² < 3.689.
    """
    dof = int(r) - 1 if thesis_dof else int(r)
    if dof < 1 or not math.isfinite(s2):
        return None
    try:
        lower, upper = _variance_bounds(dof, alpha, s02)
    except TypeError:  # an unhashable argument: the same numbers, not remembered
        lower, upper = _variance_bounds.__wrapped__(dof, alpha, s02)
    return frozen_instance(UnitVarianceTest, {
        "statistic": dof * s2 / s02, "lower": lower, "upper": upper,
        "accepted": bool(lower < s2 < upper), "dof": dof})


@lru_cache(maxsize=256, typed=True)
def _variance_bounds(dof: int, alpha: float, s02: float) -> tuple[float, float]:
    """The acceptance bounds (lower, upper) on S² of :func:`unit_variance_test` (remembered:
    every fix of a run has the same few)."""
    lo, hi = chi2_bounds(float(alpha), dof)
    return s02 * lo / dof, s02 * hi / dof


@dataclass(frozen=True)
class CumulativeVariance:
    """Cumulative unit variance σ̂² and cumulative redundancy R (eq. 5.18; σ̂²_0 = 0, R_0 = 0)."""

    sigma2: float = 0.0
    R: int = 0

    def update(self, s2: float | None, r: int) -> CumulativeVariance:
        """Fold in one fix: R' = R + r; σ̂²' = σ̂² + (r/R')(S² − σ̂²). No-op when r < 1."""
        if s2 is None or r < 1 or not math.isfinite(s2):
            return self
        big_r = self.R + int(r)
        return frozen_instance(CumulativeVariance,  # once per fix: no generated __init__
                               {"sigma2": self.sigma2 + (r / big_r) * (s2 - self.sigma2),
                                "R": big_r})
