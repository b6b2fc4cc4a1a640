"""Rauch–Tung–Striebel fixed-interval smoother over a completed filter run (kalman.md §12.5).

The thesis lists smoothing as "not implemented" (L2109, L5406); this is the standard RTS pass:

    C_k     = P_k|k Φ_kᵀ P_k+1|k⁻¹                (solved with a Cholesky factor, no inverse)
    x̂_k|N  = x̂_k|k + C_k (x̂_k+1|N − x̂_k+1|k)
    P_k|N   = P_k|k + C_k (P_k+1|N − P_k+1|k) C_kᵀ

States and units are those of :mod:`engine.kalman` (TM grid, m, m/s, rad). Heading differences
are wrapped to (−π, π] and the smoothed heading is kept in [0, 2π). Fix-error states added
during the run (``add_fix_states``) are handled: when epoch k+1 carries more states than the
prediction from k, the smoothed k+1 estimate is marginalised to the predicted states, which is
exact because the new states enter with a prior independent of everything before.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from engine.kalman import IPSI, FilterState

__all__ = ["SmootherRecord", "rts_smooth"]

TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class SmootherRecord:
    """One epoch of a filter run: x̂_k|k, P_k|k (``filtered``), the prediction x̂_k+1|k, P_k+1|k
    (``predicted_next``) and the Φ_k used for it. The last epoch has no prediction (None)."""

    filtered: FilterState
    predicted_next: FilterState | None = None
    phi: np.ndarray | None = None


def _as_record(r: SmootherRecord | tuple) -> SmootherRecord:
    return r if isinstance(r, SmootherRecord) else SmootherRecord(*r)


def rts_smooth(records: Sequence[SmootherRecord | tuple]) -> list[FilterState]:
    """Smoothed states x̂_k|N, P_k|N for every record, oldest first (same t and metadata).

    ``records`` are :class:`SmootherRecord` or (filtered, predicted_next, Φ) tuples in time
    order; each ``predicted_next.t`` must equal the next record's ``filtered.t`` (s).
    """
    recs = [_as_record(r) for r in records]
    if not recs:
        return []
    out: list[FilterState] = [recs[-1].filtered]
    for k in range(len(recs) - 2, -1, -1):
        rec = recs[k]
        f, pr, Phi = rec.filtered, rec.predicted_next, rec.phi
        if pr is None or Phi is None:
            raise ValueError(f"record {k} has no prediction to the next epoch")
        nxt = out[-1]
        if abs(pr.t - nxt.t) > 1e-9 * max(1.0, abs(nxt.t)):
            raise ValueError(f"record {k}: prediction time {pr.t} s != next epoch {nxt.t} s")
        m = pr.n
        if nxt.n < m or nxt.fix_states[: len(pr.fix_states)] != pr.fix_states:
            raise ValueError(f"record {k}: next epoch does not extend the predicted state")
        xs_next, Ps_next = nxt.x[:m], nxt.P[:m, :m]
        # C_kᵀ = P_k+1|k⁻¹ Φ P_k|k  (P_k+1|k symmetric), via Cholesky
        Ct = cho_solve(cho_factor(pr.P, lower=True, check_finite=False),
                       Phi.dot(f.P), check_finite=False)
        dx = xs_next - pr.x
        dx[IPSI] = math.pi - (math.pi - dx[IPSI]) % TWO_PI
        x = f.x + Ct.T.dot(dx)
        x[IPSI] %= TWO_PI
        P = f.P + Ct.T.dot(Ps_next - pr.P).dot(Ct)
        P = 0.5 * (P + P.T)
        out.append(FilterState(f.t, x, P, f.fix_states, f.fix_tau_s, f.fix_cov))
    out.reverse()
    return out
