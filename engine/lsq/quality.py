"""Quality control of a least-squares fix (thesis ch. 5.4): w-test, reliability, unit variance.

Baarda's data snooping ("B-method", eq. 5.7–5.10) on the FULL (correlated) matrices, the
reliability factor τ (5.11), the variance factor VF (5.12), redundancy numbers, minimal detectable
bias and its effect on the position (not in the thesis, lsq.md §8.4), the unit-variance χ² test
(5.13–5.17), the cumulative unit variance (5.18) and the reject-and-recompute loop (lsq.md §8.1).

Everything here works on metric quantities (m, m²) but is unit-agnostic: any consistent units do.
Quantiles are computed once per argument set (``functools.lru_cache``); the normal quantiles come
from :class:`statistics.NormalDist`, the χ² quantiles from SciPy (imported lazily, cold path only).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from statistics import NormalDist
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover - typing only (engine.lsq.adjustment imports this module)
    from engine.lsq.adjustment import Adjustment, Linearisation

#: The fixed rejection bound of the thesis, |w| > 2.576 (N(0,1) quantile 0.995, thesis L6665).
REJECT_BOUND = 2.576

_NORMAL = NormalDist()


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
def _chi2_bounds(alpha: float, dof: int) -> tuple[float, float]:
    """χ²_{α/2, dof} and χ²_{1−α/2, dof} (two-sided acceptance region)."""
    from scipy.stats import chi2  # cold path: once per (alpha, dof)

    return float(chi2.ppf(alpha / 2.0, dof)), float(chi2.ppf(1.0 - alpha / 2.0, dof))


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
) -> np.ndarray:
    """Statistics on the USED sub-block (m rows), as one (7 + u, m) array with rows
    σ_d, w, τ, VF, r_i, MDB, |∇x̂|_h, then the u components of ∇x̂ (units as in SlotStatistics).

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
    """Test H0: σ0² = s02 for the sample unit variance S² with redundancy r (lsq.md §8.5).

    Default dof = r (correct for known σ0²); ``thesis_dof=True`` uses the printed (r − 1) of
    eq. 5.16–5.17. Returns None when dof < 1 (no test possible). Sample: r = 2, α = 0.05 →
    0.0253 < S² < 3.689.
    """
    dof = int(r) - 1 if thesis_dof else int(r)
    if dof < 1 or not math.isfinite(s2):
        return None
    lo, hi = _chi2_bounds(float(alpha), dof)
    lower = s02 * lo / dof
    upper = s02 * hi / dof
    return UnitVarianceTest(dof * s2 / s02, lower, upper, bool(lower < s2 < upper), dof)


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
        return CumulativeVariance(self.sigma2 + (r / big_r) * (s2 - self.sigma2), big_r)


# --------------------------------------------------------------------------------------------
# Reject-and-recompute loop


@dataclass(frozen=True, eq=False)
class TestedAdjustment:
    """Outcome of :func:`adjust_with_testing`.

    ``adjustment``: the final Adjustment; ``rejected``: (slot, w) in rejection order;
    ``candidate``/``candidate_w``: the slot to reject under policy "A" (None otherwise);
    ``flagged``: slots with |w| > bound that were not rejected (policy "N", category III);
    ``monitor``: slots in the band k_α < |w| ≤ bound; ``not_identifiable``: category III with
    |w| > bound; ``variance_test``: unit-variance test of the final fix; ``messages``: operator
    texts; ``policy``/``estimator`` as requested; ``robust``: the RobustAdjustment when an
    M-estimator was requested (``robust.ok`` False: it failed and ``adjustment`` is the
    tested plain LSQ fix, a message says so).
    """

    adjustment: Adjustment
    rejected: tuple[tuple[int, float], ...]
    candidate: int | None
    candidate_w: float | None
    flagged: tuple[int, ...]
    monitor: tuple[int, ...]
    not_identifiable: bool
    variance_test: UnitVarianceTest | None
    messages: tuple[str, ...]
    policy: str
    estimator: str
    robust: object | None = None


def _worst(adj: Adjustment) -> tuple[int, float]:
    """Slot and value of the largest |w| among the used slots (w is NaN elsewhere)."""
    w = adj.w.tolist()
    k, best = 0, -1.0
    for i, wi in enumerate(w):
        if abs(wi) > best:  # NaN (unused / untestable slots) never wins; ties: the first
            k, best = i, abs(wi)
    return k, w[k]


def adjust_with_testing(
    linearise: Callable[[np.ndarray], Linearisation],
    x0: np.ndarray,
    used: np.ndarray,
    *,
    policy: str = "Y",
    alpha: float = 0.05,
    reject_bound: float = REJECT_BOUND,
    epsilon: float = 1.0,
    max_iter: int = 10,
    s02: float = 1.0,
    scale_vcv: bool = False,
    estimator: str = "lsq",
    thesis_dof: bool = False,
    lop_name: Callable[[int], str] = str,
) -> TestedAdjustment:
    """Adjust, then run the thesis' data-snooping loop (lsq.md §8.1, LOPReject).

    ``lop_name`` names an observation slot in the messages (``LOP Decca Grn``, as the console's
    dialogs name it; the slot number by default).

    Category IV and max |w| > ``reject_bound``: policy "Y" excludes that slot and re-adjusts
    from the current x̂, repeating while category IV; "N" only flags it; "A" returns it as
    ``candidate`` (the caller asks the operator and calls again with the slot excluded).
    Category III with |w| > bound: "outlier detected, not identifiable", nothing rejected.
    ``estimator`` "huber"/"danish" replaces hard rejection by IRLS M-estimation (engine.lsq.robust,
    with the same ε, max_iter, σ0², ScaleVCV and α): nothing is rejected and there is no
    candidate; if the M-estimation fails while plain LSQ succeeds, a message says so and the
    LSQ fix goes through the rejection loop above (``robust`` then holds the failed attempt).
    Never raises for bad geometry: failures are in ``adjustment.ok``/``reason``. ValueError for
    an unknown policy or estimator and for invalid settings (programming errors).
    """
    from engine.lsq.adjustment import (
        gauss_newton,  # local: engine.lsq.adjustment imports this module
    )

    if policy not in ("Y", "N", "A"):
        raise ValueError(f"policy must be 'Y', 'N' or 'A', got {policy!r}")
    if estimator not in ("lsq", "huber", "danish"):
        raise ValueError(f"estimator must be 'lsq', 'huber' or 'danish', got {estimator!r}")
    messages: list[str] = []
    name = lop_name
    robust_result: object | None = None
    kw = dict(epsilon=epsilon, max_iter=max_iter, s02=s02, scale_vcv=scale_vcv, alpha=alpha)
    cur = np.array(used, dtype=bool)
    if estimator != "lsq":
        from engine.lsq.robust import robust_adjust

        rob = robust_adjust(linearise, x0, cur, psi=estimator, **kw)  # type: ignore[arg-type]
        robust_result = rob
        if rob.ok:
            low = [int(k) for k in np.flatnonzero(rob.weights < 0.5)]
            if low:
                messages.append(f"robust ({estimator}): down-weighted "
                                f"{', '.join(f'LOP {name(k)}' for k in low)}")
            return _finish(rob.adjustment, (), None, None, [], False, messages, policy,
                           estimator, alpha, reject_bound, s02, thesis_dof, robust_result)
        adj = rob.lsq
        if adj.ok:  # the M-estimation failed, the plain fix did not: use it, tested as usual
            messages.append(f"robust ({estimator}) not used: {rob.reason}; "
                            "plain least squares with data snooping")
    else:
        adj = gauss_newton(linearise, x0, cur, **kw)  # type: ignore[arg-type]
    rejected: list[tuple[int, float]] = []
    flagged: list[int] = []
    candidate: int | None = None
    candidate_w: float | None = None
    not_identifiable = False
    while adj.ok and adj.redundancy >= 1:
        slot, w = _worst(adj)
        if abs(w) <= reject_bound:
            break
        if adj.category == "III":
            not_identifiable = True
            flagged.append(slot)
            messages.append(f"outlier detected, not identifiable (|w| = {abs(w):.2f})")
            break
        if policy == "N":
            flagged.append(slot)
            messages.append(f"LOP {name(slot)}: w = {w:.2f} exceeds {reject_bound}, not rejected")
            break
        if policy == "A":
            candidate, candidate_w = slot, w
            messages.append(f"LOP {name(slot)}: w = {w:.2f} exceeds {reject_bound}, reject ?")
            break
        trial = cur.copy()
        trial[slot] = False
        new = gauss_newton(linearise, adj.x, trial, **kw)  # type: ignore[arg-type]
        if not new.ok:
            flagged.append(slot)
            messages.append(f"LOP {name(slot)}: w = {w:.2f}, rejection leaves no fix "
                            f"({new.reason})")
            break
        rejected.append((slot, w))
        messages.append(f"LOP {name(slot)} rejected (w = {w:.2f})")
        cur, adj = trial, new
    return _finish(adj, tuple(rejected), candidate, candidate_w, flagged, not_identifiable,
                   messages, policy, estimator, alpha, reject_bound, s02, thesis_dof,
                   robust_result)


def _finish(
    adj: Adjustment,
    rejected: tuple[tuple[int, float], ...],
    candidate: int | None,
    candidate_w: float | None,
    flagged: list[int],
    not_identifiable: bool,
    messages: list[str],
    policy: str,
    estimator: str,
    alpha: float,
    bound: float,
    s02: float,
    thesis_dof: bool,
    robust: object | None,
) -> TestedAdjustment:
    """Monitor band, unit-variance test and advisory messages for the final adjustment."""
    monitor: tuple[int, ...] = ()
    vt: UnitVarianceTest | None = None
    if adj.ok and adj.s2 is not None:
        k = w_critical(alpha)
        # NaN compares False: unused slots are never in the band
        monitor = tuple(i for i, w in enumerate(adj.w.tolist()) if k < abs(w) <= bound)
        vt = (unit_variance_test(adj.s2, adj.redundancy, alpha, s02, thesis_dof)
              if thesis_dof else adj.variance_test)
        if vt is not None and not vt.accepted:
            messages.append(
                f"unit variance rejected: S² = {adj.s2:.3f} outside "
                f"({vt.lower:.4f}, {vt.upper:.3f})"
            )
            if not flagged and candidate is None and adj.category == "IV":
                messages.append("advice: scale the a priori VCV by S²")
    return TestedAdjustment(
        adjustment=adj,
        rejected=rejected,
        candidate=candidate,
        candidate_w=candidate_w,
        flagged=tuple(flagged),
        monitor=monitor,
        not_identifiable=not_identifiable,
        variance_test=vt,
        messages=tuple(messages),
        policy=policy,
        estimator=estimator,
        robust=robust,
    )
