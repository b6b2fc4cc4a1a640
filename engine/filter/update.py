"""Measurement update of the filter (6.21, Joseph form) and its innovation tests: the Local
Overall Model test (6.38–6.40, THEORY D30) and the Local Slippage w-statistics (6.41).

This is the reference (numpy and SciPy's LAPACK/BLAS); the compiled update of the cycle is
``engine.fast.filter``, which agrees with it to the tolerance contract of docs/PERFORMANCE.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from engine.filter.lazy_scipy import blas, lapack
from engine.filter.measurements import (
    Measurement,
    SensorLayout,
    distinct_key_tuple,
    h_template,
    rows_measurement,
    stack_measurements,
)
from engine.filter.params import FilterParams, read_only, symmetrised
from engine.filter.state import IPSI, N_NAV, FilterState, add_fix_states
from engine.geodesy.angles import wrap_2pi, wrap_pi
from engine.lsq.statistics import chi2_bounds

_EYES = tuple(read_only(np.eye(k)) for k in range(21))  # identities up to 20×20


def _eye(k: int) -> np.ndarray:
    """The k×k identity (read-only, shared for k ≤ 20: rows of an update, states)."""
    return _EYES[k] if k < len(_EYES) else np.eye(k)


LS_MONITOR = 1.960  # |t| above this: accept but monitor (thesis L1871–L1879)

LS_REJECT = 2.576  # |t| above this: reject


class FilterDivergence(ArithmeticError):
    """The filter produced a non-positive variance or a non-PD innovation covariance.

    ``state`` is kept for logging: the updated state with the bad variance, or the input
    state when S = HPHᵀ + R was not positive definite.
    """

    def __init__(self, message: str, state: FilterState) -> None:
        super().__init__(message)
        self.state = state


@dataclass(frozen=True)
class LomTest:
    """Local Overall Model test (6.38–6.40, THEORY D30):
    T = v̂ᵀS⁻¹v̂/p in [χ²_p(α/2)/p, χ²_p(1−α/2)/p]."""

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
    rejects (THEORY §8.14). Computed on access, so the per-cycle update stays cheap.
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


LOM_TABLE_DOF = 20
"""At the default α = 0.05 and up to this many rows the LOM bounds are the χ² quantiles to 6
significant digits: the printed table the filter used before (kept, so the .OUT logs stay
byte-identical); other α or more rows use the full-precision quantiles."""


def lom_bounds(p: int, alpha: float) -> tuple[float, float]:
    """χ²_p bounds (α/2, 1 − α/2) of the LOM test on p rows (before the division by p)."""
    digits = 6 if alpha == 0.05 and p <= LOM_TABLE_DOF else None
    return chi2_bounds(alpha, p, digits)


@lru_cache(maxsize=64)
def _lom_limits(p: int, alpha: float) -> tuple[float, float]:
    """The LOM bounds on T = v̂ᵀS⁻¹v̂/p: the χ²_p bounds of :func:`lom_bounds` divided by p."""
    lo, hi = lom_bounds(p, alpha)
    return lo / p, hi / p


def _lom_from_nis(nis: float, p: int, alpha: float) -> LomTest:
    lim = _LIMITS.get((p, alpha))
    if lim is None:
        if len(_LIMITS) >= 64:
            _LIMITS.clear()
        lim = _LIMITS[(p, alpha)] = _lom_limits(p, alpha)
    lower, upper = lim
    t = nis / p
    verdict = "reject" if t > upper else ("too small" if t < lower else "accept")
    lom = _new(LomTest)
    lom.__dict__.update(t=t, lower=lower, upper=upper, dof=p, verdict=verdict)
    return lom


_LIMITS: dict[tuple[int, float], tuple[float, float]] = {}
"""(p, α) → :func:`_lom_limits` (a dict lookup, cheaper than the lru_cache's call per update)."""


_new = object.__new__
"""Hot path: the per-update results are built by filling the instance dict of a bare instance
(the frozen dataclasses have no __post_init__), not through their __init__."""


def _factor_solve(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """L⁻¹B with L the Cholesky factor of S (raises LinAlgError if S is not PD)."""
    L, info = lapack.dpotrf(np.asarray(S, dtype=float), lower=1, clean=1)
    if info != 0:
        raise np.linalg.LinAlgError("matrix is not positive definite")
    B2 = np.asfortranarray(np.asarray(B, dtype=float).reshape(L.shape[0], -1))
    return blas.dtrsm(1.0, L, B2, lower=1).reshape(np.shape(B))


def lom_test(v: np.ndarray, S: np.ndarray, alpha: float = 0.05) -> LomTest:
    """LOM test of any innovation v (p,) with covariance S (p×p), THEORY D30 bounds χ²_p/p."""
    w = _factor_solve(S, np.asarray(v, dtype=float))
    return _lom_from_nis(float(w @ w), len(w), alpha)


def innovation_distance(result: UpdateResult, rows: slice = slice(None)) -> float:
    """Mahalanobis length √(v̂ᵀ S⁻¹ v̂) of the innovation ``rows`` of an update (in σ; inf when
    that block of S is not positive definite).

    Under H0 its square is χ²_p; a length of tens of σ is no statistical question any more but
    a gross error (a fix thousands of km away), which the cycle keeps out of the filter.
    """
    v = np.asarray(result.innovation[rows], dtype=float)
    if v.shape[0] == 0:
        return 0.0
    S = np.asarray(result.S[rows, rows], dtype=float)
    L, info = lapack.dpotrf(S, 1, 1)  # S = L Lᵀ (lower, clean)
    if info != 0:
        return math.inf
    w = blas.dtrsm(1.0, L, v.reshape(-1, 1), 0, 1).reshape(-1)  # w = L⁻¹v̂ (side=0, lower=1)
    d2 = float(w @ w)
    return math.sqrt(d2) if d2 >= 0.0 else math.inf


def ls_test(v: np.ndarray, S: np.ndarray, lom_reject: bool) -> LsTest:
    """LS statistics t_i = (S⁻¹v)_i / √(S⁻¹)_ii (eq. 6.41) of any innovation v with covariance S."""
    p = len(v)
    Y = _factor_solve(S, np.column_stack([np.asarray(v, dtype=float), np.eye(p)]))
    return LsTest(Y[:, 1:], Y[:, 0], lom_reject)


def _with_bias_columns(
    state: FilterState, rows: Measurement, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """Add missing fix-error states named by ``rows.bias_keys`` and the 1s of b in H."""
    keys = rows.bias_keys
    if len(keys) != rows.z.shape[0]:
        raise ValueError("bias_keys needs one entry per measurement row")
    dk = distinct_key_tuple(keys)
    fs0 = state.fix_states  # all of dk already there (the usual case): nothing is missing
    missing = [] if dk == fs0 else [i for i, k in enumerate(dk) if k not in fs0]
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
    n = state.x.shape[0]
    fs = state.fix_states
    cols = rows._cols
    if cols is not None:  # H is a template: so is H with the 1s of b
        return state, _bias_h(cols, keys, fs, n)
    H = np.zeros((rows.z.shape[0], n))
    H[:, :rows.H.shape[1]] = rows.H
    for i, k in enumerate(keys):
        if k is not None:
            H[i, N_NAV + fs.index(k)] = 1.0
    return state, H


@lru_cache(maxsize=64)
def _bias_h(cols: tuple[tuple[int, ...], ...], keys: tuple[str | None, ...],
            fix_states: tuple[str, ...], n: int) -> np.ndarray:
    """The template H (:func:`h_template`) of rows ``cols`` plus the 1 of each row's fix-error
    state ``keys[i]`` among ``fix_states`` (columns 11…), over n states."""
    return h_template(tuple(c if k is None else (*c, N_NAV + fix_states.index(k))
                            for c, k in zip(cols, keys, strict=True)), n)


def update(state: FilterState, rows: Measurement, params: FilterParams) -> UpdateResult:
    """Measurement update (6.21a–c) with the innovation tests (6.37–6.41).

    S = H P Hᵀ + R is Cholesky-factorised (S = L Lᵀ) and one triangular solve L Y = [HP | v̂ | I]
    gives L⁻¹HP, L⁻¹v̂ and L⁻¹, so K = (L⁻¹HP)ᵀ L⁻¹ and T_LOM·p = |L⁻¹v̂|²; neither S nor P is
    inverted. P by the Joseph form (or the thesis (I − KH)P with ``params.joseph=False``),
    symmetrised; heading wrapped to [0, 2π). Rows with fix-error keys first add any missing
    Gauss–Markov states (so the returned state may be larger than the input). Raises
    :class:`FilterDivergence` if S is not PD or a variance becomes ≤ 0 (or non-finite).
    """
    z = rows.z
    p = z.shape[0]
    if p == 0:
        return _empty_update(state)
    state, H = _full_width(state, rows, params)
    x, P, R = state.x, state.P, rows.R
    v = z - H.dot(x)
    for i in rows.angle_rows:
        v[i] = wrap_pi(v[i])
    HP = H.dot(P)
    S = HP.dot(H.T)
    S += R
    # Cholesky S = L Lᵀ (LAPACK potrf) and one forward substitution L Y = [HP | v | I] (BLAS
    # trsm): numpy has neither a Cholesky solve nor a triangular solve for small matrices.
    # (f2py arguments by position: lower=1, clean=1; a keyword costs ~0.3 µs to parse.)
    L, info = lapack.dpotrf(S, 1, 1)
    if info != 0:
        raise FilterDivergence("innovation covariance S is not positive definite", state)
    LiHPt, w, Li = _whitened(L, HP, v)
    K = LiHPt.dot(Li)  # P Hᵀ S⁻¹ = (L⁻¹HP)ᵀ L⁻¹
    xn = x + LiHPt.dot(w)
    xn[IPSI] = wrap_2pi(xn[IPSI])
    Pn = _updated_cov(P, K, H, HP, R, params.joseph)
    new = state._with(state.t, xn, Pn)
    nis = float(w.dot(w))
    # min(diag) > 0, NaN failing as np.minimum.reduce's NaN would.
    if not (all(map(_POSITIVE, Pn.diagonal().tolist())) and math.isfinite(nis)):
        raise FilterDivergence("non-positive or non-finite variance after update", new)
    lom = _lom_from_nis(nis, p, params.alpha)
    ls = _new(LsTest)
    ls.__dict__.update(l_inv=Li, w=w, lom_reject=lom.verdict == "reject")
    result = _new(UpdateResult)
    result.__dict__.update(state=new, innovation=v, S=S, K=K, labels=rows.labels, lom=lom,
                           ls=ls)
    return result


_POSITIVE = (0.0).__lt__
"""x ↦ 0 < x (False for NaN)."""


def _empty_update(state: FilterState) -> UpdateResult:
    """The result of an update without rows: the state unchanged, no test."""
    lom = LomTest(float("nan"), float("nan"), float("nan"), 0, "none")
    empty = np.zeros(0)
    return UpdateResult(state, empty, np.zeros((0, 0)), np.zeros((state.n, 0)), (), lom,
                        LsTest(np.zeros((0, 0)), empty, False))


def _full_width(
    state: FilterState, rows: Measurement, params: FilterParams
) -> tuple[FilterState, np.ndarray]:
    """The state (with any fix-error states the rows need added) and H over all its columns."""
    if rows.bias_keys:
        return _with_bias_columns(state, rows, params)
    H = rows.H
    n = state.x.shape[0]
    if H.shape[1] < n:
        cols = rows._cols
        if cols is not None:
            return state, h_template(cols, n)
        Hp = np.zeros((H.shape[0], n))
        Hp[:, :H.shape[1]] = H
        return state, Hp
    return state, H


def _whitened(
    L: np.ndarray, HP: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(L⁻¹HP)ᵀ, L⁻¹v̂ and L⁻¹ from one triangular solve L Y = [HP | v̂ | I].

    B = [HP | v̂ | I] is built as the C-ordered transpose [HPᵀ; v̂ᵀ; I] (one concatenation),
    whose transpose is the Fortran-ordered B trsm solves in place."""
    p, n = HP.shape
    B = np.concatenate((HP.T, v[None], _eye(p))).T
    Y = blas.dtrsm(1.0, L, B, 0, 1, 0, 0, 1)  # side=0, lower=1, trans_a=0, diag=0, overwrite_b=1
    return Y[:, :n].T, Y[:, n], Y[:, n + 1:]


def _updated_cov(
    P: np.ndarray, K: np.ndarray, H: np.ndarray, HP: np.ndarray, R: np.ndarray, joseph: bool
) -> np.ndarray:
    """P after the update (6.21c): Joseph form (I − KH)P(I − KH)ᵀ + KRKᵀ or the thesis'
    (I − KH)P = P − K HP, symmetrised."""
    if joseph:
        A = _eye(P.shape[0]) - K.dot(H)
        Pn = A.dot(P).dot(A.T)
        Pn += K.dot(R).dot(K.T)
    else:
        Pn = P - K.dot(HP)
    return symmetrised(Pn)


def update_rows(state: FilterState, zs: list[float], var: list[float], layout: SensorLayout,
                params: FilterParams) -> UpdateResult:
    """The update with independent rows: values ``zs``, variances ``var`` and the ``layout`` of
    ``engine.filter.measurements.sensor_rows`` (the sensors' rows of a cycle)."""
    return update(state, rows_measurement(zs, var, layout), params)


def update_rows_gated(state: FilterState, zs: list[float], var: list[float],
                      layout: SensorLayout, b: Measurement,
                      params: FilterParams) -> tuple[UpdateResult, float]:
    """One update with the independent rows ``zs``/``var``/``layout`` (the pressure depth)
    stacked before the rows ``b`` (the fix), and the Mahalanobis length of ``b``'s innovation
    (:func:`innovation_distance`): what the cycle's gross-error gate decides on."""
    result = update(state, stack_measurements(rows_measurement(zs, var, layout), b), params)
    return result, innovation_distance(result, slice(len(zs), None))
