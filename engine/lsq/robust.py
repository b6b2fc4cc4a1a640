"""Robust (M-estimation) option for the LS fix by iteratively reweighted least squares.

Czaplewski & Waż (seed 003, eq. 6): damp suspect observations with P̂ = T(v)·P, T diagonal with
0 ≤ T_ii ≤ 1 (THEORY §5.8). The weights come from the standardised residuals
ŵ_i = w_i of the UNDAMPED a priori model at the current estimate (for uncorrelated observations
ŵ_i = −v_i/(σ_i·sqrt(r_i))): Huber T = 1 if |ŵ| ≤ c else c/|ŵ|; "Danish" T = 1 if |ŵ| ≤ c else
exp(1 − ŵ²/c²). Correlated C_l is damped symmetrically, W' = T^½ W T^½. Standardising with the
undamped model keeps a damped blunder exposed: its residual is compared with the redundancy the
observation has when fully weighted, not with the inflated one of its damped variance.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from engine.lsq.adjustment import (
    COND_MAX,
    MAX_AXIS_RATIO,
    Adjustment,
    Linearisation,
    gauss_newton,
)

_DEFAULT_C = {"huber": 1.5, "danish": 2.0}
#: Smallest weight factor used, so that W' stays invertible (a damped blunder is ~invisible).
T_FLOOR = 1e-12


def psi_weight(wstd: np.ndarray, psi: str, c: float) -> np.ndarray:
    """Weight factors T_ii in [T_FLOOR, 1] for standardised residuals ``wstd`` (NaN → 1).

    Huber: 1 if |ŵ| ≤ c else c/|ŵ|. Danish: 1 if |ŵ| ≤ c else exp(1 − ŵ²/c²).
    """
    aw = np.abs(np.nan_to_num(np.asarray(wstd, dtype=float), nan=0.0))
    out = np.ones_like(aw)
    big = aw > c
    if psi == "huber":
        out[big] = c / aw[big]
    elif psi == "danish":
        out[big] = np.exp(1.0 - (aw[big] / c) ** 2)
    else:
        raise ValueError(f"psi must be 'huber' or 'danish', got {psi!r}")
    return np.maximum(out, T_FLOOR)


def standardised_residuals(adj: Adjustment) -> np.ndarray:
    """ŵ_i = −(e_iᵀ W v)/sqrt(e_iᵀ W C_v W e_i) with W = C_l⁻¹ of the UNDAMPED a priori model
    (the w-test statistic, eq. 5.8c) at the last linearisation of ``adj``, for the residuals v
    of ``adj``; NaN for unused slots, untestable slots or redundancy < 1."""
    n = adj.used.size
    out = np.full(n, np.nan)
    if adj.redundancy < 1 or adj.s2 is None:
        return out
    Au, vu = adj.A_used, adj.v[adj.used]
    Clu = adj.Cl_used
    if adj.damping is not None:  # undo the damping: C_l' = T^-½ C_l T^-½ → C_l = T^½ C_l' T^½
        sq = np.sqrt(adj.damping[adj.used])
        Clu = Clu * np.outer(sq, sq)
    Wu = np.linalg.inv(Clu)
    atw = Au.T @ Wu
    cx = np.linalg.inv(atw @ Au)
    q = Wu.diagonal() - np.add.reduce(atw * (cx @ atw), axis=0)
    ok = q > 1e-10 * Wu.diagonal()
    wstd = np.full(q.shape, np.nan)
    wstd[ok] = -(Wu @ vu)[ok] / np.sqrt(q[ok])
    out[adj.used] = wstd
    return out


@dataclass(frozen=True, eq=False)
class RobustAdjustment:
    """Outcome of :func:`robust_adjust`.

    ``ok``/``reason``; ``x`` [m] and ``cov_x`` [m²] of the final damped adjustment (C_x̂ of the
    damped model, displayed like LSQ); ``weights`` T_ii per slot (NaN unused); ``standardised``
    ŵ per slot at the final estimate; ``iterations`` outer IRLS steps; ``converged`` (weights
    changed < tol); ``n_effective`` = Σ T_ii over the used slots; ``adjustment`` the final
    (damped) Adjustment; ``lsq`` the plain least-squares start; ``psi``, ``c`` as used.
    """

    ok: bool
    reason: str | None
    x: np.ndarray
    cov_x: np.ndarray
    weights: np.ndarray
    standardised: np.ndarray
    iterations: int
    converged: bool
    n_effective: float
    adjustment: Adjustment
    lsq: Adjustment
    psi: str
    c: float


def robust_adjust(
    linearise: Callable[[np.ndarray], Linearisation],
    x0: np.ndarray,
    used: np.ndarray,
    *,
    psi: str = "huber",
    c: float | None = None,
    max_outer: int = 30,
    tol: float = 0.01,
    epsilon: float = 1.0,
    max_iter: int = 10,
    s02: float = 1.0,
    scale_vcv: bool = False,
    cond_max: float = COND_MAX,
    max_axis_ratio: float | None = MAX_AXIS_RATIO,
    alpha: float = 0.05,
) -> RobustAdjustment:
    """IRLS M-estimation of the fix (seed 003 eq. 6, THEORY §5.8).

    Starts from plain LSQ (T = I); each outer step recomputes T_ii = ψ(ŵ_i) (``psi`` "huber",
    c = 1.5, or "danish", c = 2.0, unless ``c`` is given) and re-adjusts from the current
    estimate with W' = T^½ W T^½, until max |ΔT| < ``tol`` or ``max_outer`` steps. The
    settings ``epsilon``, ``max_iter``, ``s02``, ``scale_vcv``, ``cond_max``, ``max_axis_ratio``
    and ``alpha`` are passed to every :func:`engine.lsq.adjustment.gauss_newton` call. Requires
    Σ T_ii ≥ u + 1 effective observations and a well-conditioned damped normal matrix (else
    ok=False with a reason; the last good adjustment is returned; if the weights are still
    moving after ``max_outer`` steps, ok=False and ``adjustment`` is the last damped one). With
    redundancy 0 every residual is zero, so the M-estimate IS the LSQ one (ok, weights 1).
    When every |ŵ| ≤ c the result is the LSQ adjustment itself. Never raises for bad geometry;
    ValueError for an unknown ``psi`` or invalid settings (programming errors).
    """
    if psi not in _DEFAULT_C:
        raise ValueError(f"psi must be 'huber' or 'danish', got {psi!r}")
    cc = float(_DEFAULT_C[psi] if c is None else c)
    kw = dict(epsilon=epsilon, max_iter=max_iter, s02=s02, scale_vcv=scale_vcv,
              cond_max=cond_max, max_axis_ratio=max_axis_ratio, alpha=alpha)
    used_b = np.array(used, dtype=bool)
    lsq = gauss_newton(linearise, x0, used_b, **kw)  # type: ignore[arg-type]
    out = _Outcome(lsq, used_b, psi, cc)
    t = np.ones(used_b.size)
    nan_n = np.full(used_b.size, np.nan)
    if not lsq.ok:
        return out.result(lsq, t, lsq.reason, 0, False, nan_n)
    if lsq.redundancy < 1:  # v̂ = 0: nothing to down-weight, M-estimate = LSQ
        return out.result(lsq, t, None, 0, True, nan_n)
    return _irls(linearise, out, max_outer, tol, kw)


@dataclass(frozen=True, eq=False)
class _Outcome:
    """Internal: what every RobustAdjustment of one :func:`robust_adjust` call shares."""

    lsq: Adjustment
    used: np.ndarray
    psi: str
    c: float

    def result(self, adj: Adjustment, t: np.ndarray, reason: str | None, it: int, conv: bool,
               wstd: np.ndarray) -> RobustAdjustment:
        """The RobustAdjustment of ``adj`` with weights ``t`` (NaN for unused slots)."""
        weights = np.where(self.used, t, np.nan)
        return RobustAdjustment(
            ok=reason is None, reason=reason, x=adj.x, cov_x=adj.cov_x, weights=weights,
            standardised=wstd, iterations=it, converged=conv,
            n_effective=float(np.nansum(weights)), adjustment=adj, lsq=self.lsq, psi=self.psi,
            c=self.c,
        )

    def weights(self, adj: Adjustment) -> tuple[np.ndarray, np.ndarray]:
        """(ŵ, T) at ``adj``: standardised residuals and ψ weights (1 for unused slots)."""
        wstd = standardised_residuals(adj)
        return wstd, np.where(self.used, psi_weight(wstd, self.psi, self.c), 1.0)


def _irls(
    linearise: Callable[[np.ndarray], Linearisation],
    out: _Outcome,
    max_outer: int,
    tol: float,
    kw: dict[str, object],
) -> RobustAdjustment:
    """The outer IRLS loop from the LSQ start: reweight, re-adjust, until T settles."""
    adj, used_b = out.lsq, out.used
    t = np.ones(used_b.size)
    for it in range(1, max_outer + 1):
        wstd, t_new = out.weights(adj)
        if float(np.max(np.abs(t_new - t))) < tol:
            return out.result(adj, t, None, it, True, wstd)
        n_eff = float(np.sum(t_new[used_b]))
        if n_eff < adj.u + 1:
            reason = f"too few effective observations ({n_eff:.2f} < {adj.u + 1})"
            return out.result(adj, t, reason, it, False, wstd)
        new = gauss_newton(linearise, adj.x, used_b, damping=t_new, **kw)  # type: ignore[arg-type]
        if not new.ok:
            return out.result(adj, t, f"robust step failed: {new.reason}", it, False, wstd)
        t, adj = t_new, new
    wstd, t_last = out.weights(adj)
    change = float(np.max(np.abs(t_last - t)))
    return out.result(adj, t, f"robust weights did not settle (max |ΔT| = {change:.3f})",
                      max_outer, False, wstd)
