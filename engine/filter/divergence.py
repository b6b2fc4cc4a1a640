"""Recovery from filter divergence: persistent innovation-test failure on consistent fixes
(THEORY §8.18).

A filter whose position has left its own ellipse (a long dive on a wrong current, a log scale
error) computes S = HPHᵀ + R far too small for the fixes that would correct it: their innovation
(LOM) test rejects epoch after epoch while the gain, set by the tight P, lets them move the
estimate only slowly; the fix-error states even take up part of the offset as "fix bias". The
filter is then confident and wrong, the worst failure of a navigator.

**Detection** (Teunissen & Salzmann 1989, "A recursive slippage test for use in state-space
filtering", manuscripta geodaetica 14: a persistent model error shows in consecutive epochs, a
blunder in one): the watch counts LSE fix updates in a row whose fix rows fail the innovation
(LOM) test (:func:`fix_rows_test`), whose LSE passed its own tests (the fix is good by its own
redundancy), and that agree with each other
after the dead-reckoned motion between them is taken out (:func:`consistent`: the motion of the
fixes minus the filter's motion between the two epochs, tested against the sum of the two fix
VCVs at χ²₂(0.99)). A single blunder breaks the run (the next fix is accepted, or disagrees with
it) and is never acted on. After ``epochs`` such rejections in a row the filter, not the fixes,
is taken to be wrong — provided the run began after ``gap_s`` without a fix update (a dive):
a filter that has been taking fixes all along does not diverge from them in a few epochs,
whereas a fix error slower and larger than its VCV (night sky-wave) does look like this.

**Remedy**, ``filter.recover`` (docs/CONFIG.md):

* ``"reset"``: re-initialise the position from the fix, as at the start of a run (THEORY D22):
  position = LSE with its VCV, no covariance with the other states, the fix-error states at zero
  with their stationary VCV (Brown & Hwang, *Introduction to Random Signals and Applied Kalman
  Filtering*, 4th ed. 2012, on filter divergence: re-initialise when the residuals show the
  filter has lost the truth). The dead-reckoning states that let the position drift away are
  not left tight: each current component's variance gets (|ν| / Δt)² added, ν the innovation of
  the fix and Δt the time since the filter last accepted one — the current error that would
  have produced the offset over that time (:func:`current_inflation`), at most (1 m/s)².
* ``"fade"``: fading memory (Fagin 1964, "Recursive linear regression theory, optimal filter
  theory and error analysis of optimal systems", IEEE Int. Conv. Rec.; Sorenson & Sacks 1971,
  Inf. Sci. 3; the adaptive factor of Xia, Rao, Ying & Shen 1994, Automatica 30): the prior P
  is multiplied by λ = T / T_upper (≥ 1), the factor that brings the LOM statistic to its test
  bound, and the fix is taken with the inflated P; repeated at each epoch of the run of
  rejections until one is accepted.
* ``"off"``: neither (``preset = "thesis"``: the thesis takes the fix and flags it, eq. 6.38–6.40).

Pure functions and a small frozen state; no printing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from engine.filter.update import lom_bounds

CONSISTENT_CHI2 = 9.2103
"""χ²₂(0.99): two fixes agree when their motion differs from the dead-reckoned motion by less
than this (Mahalanobis², against the sum of their VCVs)."""

CURRENT_ADD_MAX = 1.0
"""The largest variance (m²/s²) a reset adds to each current component: (1 m/s)², the thesis'
tidal current amplitude V_cm (§6.6), so a large offset after a short gap cannot make the
current free."""


@dataclass(frozen=True, slots=True)
class RecoverSettings:
    """``filter.recover`` (a mode of :data:`engine.run.config.RECOVER_MODES`, not "off"),
    ``filter.recover_epochs`` (consecutive consistent rejections before the remedy) and
    ``filter.recover_gap_s`` (s without a fix update before the run of rejections starts)."""

    mode: str
    epochs: int
    gap_s: float = 240.0


@dataclass(frozen=True, slots=True)
class DivergenceWatch:
    """The run of consistent innovation-test rejections so far.

    ``streak``: LSE fix updates in a row rejected by the LOM test, consistent with each other;
    ``fix_xy``/``fix_cov``: the last such fix (grid m, m²) and ``post_xy`` the filter position
    after that epoch's update (grid m); ``cm_deg`` their grid's central meridian;
    ``last_ok_s``: the time (s) of the last fix update the test accepted (None: none yet);
    ``acted``: the remedy has acted in this run of rejections (reported once);
    ``last_update_s``: the time (s) of the last LSE fix update, whatever its verdict;
    ``gap_s``: the time (s) without a fix update before this run's first rejection."""

    streak: int = 0
    fix_xy: tuple[float, float] | None = None
    fix_cov: np.ndarray | None = None
    post_xy: tuple[float, float] | None = None
    cm_deg: float | None = None
    last_ok_s: float | None = None
    acted: bool = False
    last_update_s: float | None = None
    gap_s: float = 0.0


def consistent(prev: DivergenceWatch, fix_xy: tuple[float, float], fix_cov: np.ndarray,
               prior_xy: tuple[float, float], cm_deg: float) -> bool:
    """Whether this fix agrees with the previous rejected one once the dead-reckoned motion
    between them is taken out: d = (z_k − z_{k−1}) − (x̂⁻_k − x̂⁺_{k−1}) tested as
    dᵀ(C_k + C_{k−1})⁻¹d ≤ χ²₂(0.99) (grid m). False without a previous one on this grid."""
    if prev.fix_xy is None or prev.post_xy is None or prev.fix_cov is None \
            or prev.cm_deg != cm_deg:
        return False
    d = np.array([(fix_xy[0] - prev.fix_xy[0]) - (prior_xy[0] - prev.post_xy[0]),
                  (fix_xy[1] - prev.fix_xy[1]) - (prior_xy[1] - prev.post_xy[1])])
    C = np.asarray(fix_cov, dtype=float) + np.asarray(prev.fix_cov, dtype=float)
    try:
        m2 = float(d @ np.linalg.solve(C, d))
    except np.linalg.LinAlgError:
        return False
    return math.isfinite(m2) and m2 <= CONSISTENT_CHI2


@lru_cache(maxsize=8)
def fix_rows_upper(alpha: float) -> float:
    """The LOM test's upper bound on T = v̂ᵀS⁻¹v̂/2 for the LSE's two rows at level ``alpha``
    (χ²₂(1 − α/2)/2: 3.69 at α = 0.05)."""
    return lom_bounds(2, alpha)[1] / 2.0


def fix_rows_test(innovation: np.ndarray, S: np.ndarray, labels: tuple[str, ...],
                  upper: float) -> tuple[str, float]:
    """The innovation test of the LSE's two rows alone (``x_LSE``, ``y_LSE``; the depth row
    stacked with them does not enter): (verdict, T) with T = v_fᵀS_f⁻¹v_f / 2 and the verdict
    "reject" when T exceeds ``upper`` (the LOM bound for p = 2), "accept" otherwise, ("", NaN)
    without those rows or a usable S_f."""
    if "x_LSE" not in labels:
        return "", math.nan
    i = labels.index("x_LSE")
    v0, v1 = float(innovation[i]), float(innovation[i + 1])
    s00, s01 = float(S[i][i]), float(S[i][i + 1])
    s10, s11 = float(S[i + 1][i]), float(S[i + 1][i + 1])
    det = s00 * s11 - s01 * s10
    if not det > 0.0:  # S_f of a proper update is positive definite: no usable test else
        return "", math.nan
    # vᵀS_f⁻¹v by the 2×2 inverse (a cheap closed form, once per fix epoch)
    t = (v0 * (s11 * v0 - s01 * v1) + v1 * (s00 * v1 - s10 * v0)) / det / 2.0
    if not math.isfinite(t):
        return "", math.nan
    return ("reject" if t > upper else "accept"), t


def observe(prev: DivergenceWatch, *, t_s: float, verdict: str, fix_good: bool,
            fix_xy: tuple[float, float], fix_cov: np.ndarray, prior_xy: tuple[float, float],
            cm_deg: float) -> DivergenceWatch:
    """The watch after one LSE fix update whose fix rows' test (:func:`fix_rows_test`) says
    ``verdict``. ``fix_good``: the LSE passed its own tests; ``fix_cov``: its a-priori VCV (m²,
    not scaled by a learnt factor: fixes that scatter beyond it are not "consistent"). A
    rejected good fix extends the run when it is consistent with the previous one
    (:func:`consistent`), else starts a new run of one; anything else ends it (an accepted
    update also dates ``last_ok_s``). ``post_xy`` is left for :func:`settle`."""
    if verdict != "reject" or not fix_good:
        return DivergenceWatch(last_ok_s=t_s if verdict == "accept" else prev.last_ok_s,
                               last_update_s=t_s)
    if prev.streak > 0 and consistent(prev, fix_xy, fix_cov, prior_xy, cm_deg):
        streak, acted, gap = prev.streak + 1, prev.acted, prev.gap_s
    else:
        streak, acted = 1, False
        gap = 0.0 if prev.last_update_s is None else t_s - prev.last_update_s
    return DivergenceWatch(streak, fix_xy, np.asarray(fix_cov, dtype=float), None, cm_deg,
                           prev.last_ok_s, acted, t_s, gap)


def settle(w: DivergenceWatch, post_xy: tuple[float, float], acted: bool) -> DivergenceWatch:
    """The watch with the filter position after this epoch's update and whether the remedy
    acted (a reset ends the run: the next rejection starts a new one)."""
    if w.streak == 0:
        return w
    return DivergenceWatch(w.streak, w.fix_xy, w.fix_cov, post_xy, w.cm_deg, w.last_ok_s,
                           w.acted or acted, w.last_update_s, w.gap_s)


def due(w: DivergenceWatch, settings: RecoverSettings) -> bool:
    """Whether the remedy acts at this epoch: ``epochs`` consistent rejections in a row, the
    first of them after at least ``gap_s`` without a fix update (a dive, an outage: the time
    dead reckoning needs to diverge; within it a disagreement is as likely the fixes' own slow
    error, which the fix-error states model)."""
    return w.streak >= settings.epochs and w.gap_s >= settings.gap_s


def fade_factor(t: float, upper: float) -> float:
    """λ = T / T_upper, at least 1: the factor on the prior P that brings the LOM statistic
    T = v̂ᵀS⁻¹v̂/p to its upper bound when the fix's R is small beside HPHᵀ (Fagin 1964)."""
    if not (math.isfinite(t) and math.isfinite(upper)) or upper <= 0.0:
        return 1.0
    return max(1.0, t / upper)


def current_inflation(innovation_m: float, since_ok_s: float | None) -> float:
    """The variance (m²/s²) added to each current component on a reset: (|ν| / Δt)², the
    current error that carries the position |ν| (m) away in the Δt (s) since the filter last
    accepted a fix; 0 when there was none or Δt ≤ 0."""
    if since_ok_s is None or not since_ok_s > 0.0 or not math.isfinite(innovation_m):
        return 0.0
    return min((innovation_m / since_ok_s) ** 2, CURRENT_ADD_MAX)


def message(mode: str, streak: int, offset_m: float, since_s: float | None) -> str:
    """The one message of a remedy: what happened and what to do."""
    what = ("position re-initialised from the LSE, current uncertainty widened" if mode == "reset"
            else "filter covariance inflated until the fixes are accepted")
    when = "" if since_s is None else f" after {since_s / 60.0:.0f} min without an accepted fix"
    return (f"Filter diverged: {streak} consistent fixes in a row rejected by the innovation "
            f"test, {offset_m:.0f} m from the filter{when}; {what}. Check the current, log and "
            "gyro entries")
