"""Data snooping: adjust, test, reject and re-adjust (thesis ch. 5.4, THEORY §6.1, LOPReject).

The driver above the adjustment core (:mod:`engine.lsq.adjustment`), the robust estimator
(:mod:`engine.lsq.robust`) and the test statistics (:mod:`engine.lsq.statistics`): it runs a fix,
applies Baarda's w-test with the operator's rejection policy and finishes with the unit-variance
test and the operator messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from engine.lsq.adjustment import Adjustment, Linearisation, gauss_newton
from engine.lsq.robust import RobustAdjustment, robust_adjust
from engine.lsq.statistics import (
    REJECT_BOUND,
    UnitVarianceTest,
    frozen_instance,
    unit_variance_test,
    w_critical,
)


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


def _monitor(w: np.ndarray, k: float, bound: float) -> tuple[int, ...]:
    """The slots with k_α < |w| ≤ ``bound`` (NaN compares False: unused slots are never in
    the band)."""
    return tuple(i for i, wi in enumerate(w.tolist()) if k < abs(wi) <= bound)


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
    first: Adjustment | None = None,
) -> TestedAdjustment:
    """Adjust, then run the thesis' data-snooping loop (THEORY §6.1, LOPReject).

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

    ``first``: the plain LSQ adjustment of ``x0`` and ``used`` with these settings when the
    caller has already made it (``gauss_newton``'s result; the fix's one-call path,
    :func:`engine.lsq.fix.compute_fix`): it is not made again (estimator "lsq" only).
    """
    if policy not in ("Y", "N", "A"):
        raise ValueError(f"policy must be 'Y', 'N' or 'A', got {policy!r}")
    if estimator not in ("lsq", "huber", "danish"):
        raise ValueError(f"estimator must be 'lsq', 'huber' or 'danish', got {estimator!r}")
    kw = dict(epsilon=epsilon, max_iter=max_iter, s02=s02, scale_vcv=scale_vcv, alpha=alpha)
    cur = np.array(used, dtype=bool)
    if estimator == "lsq":
        adj = (gauss_newton(linearise, x0, cur, **kw)  # type: ignore[arg-type]
               if first is None else first)
        prog = _Progress(adj, [])
    else:
        prog = _robust_start(linearise, x0, cur, estimator, kw, lop_name)
        if prog.robust is not None and prog.robust.ok:
            return _finish(prog, policy, estimator, alpha, reject_bound, s02, thesis_dof)
    _snoop(linearise, prog, cur, policy, reject_bound, kw, lop_name)
    return _finish(prog, policy, estimator, alpha, reject_bound, s02, thesis_dof)


@dataclass(eq=False)
class _Progress:
    """Internal running state of :func:`adjust_with_testing` (fields as in TestedAdjustment)."""

    adj: Adjustment
    messages: list[str]
    robust: RobustAdjustment | None = None
    rejected: list[tuple[int, float]] = field(default_factory=list)
    flagged: list[int] = field(default_factory=list)
    candidate: int | None = None
    candidate_w: float | None = None
    not_identifiable: bool = False


def _robust_start(
    linearise: Callable[[np.ndarray], Linearisation],
    x0: np.ndarray,
    used: np.ndarray,
    estimator: str,
    kw: dict[str, float | int | bool],
    name: Callable[[int], str],
) -> _Progress:
    """The M-estimate (nothing to snoop when it succeeds) or, if it failed, the plain LSQ fix
    with a message saying why (then tested as usual)."""
    rob = robust_adjust(linearise, x0, used, psi=estimator, **kw)  # type: ignore[arg-type]
    messages: list[str] = []
    if rob.ok:
        low = [int(k) for k in np.flatnonzero(rob.weights < 0.5)]
        if low:
            messages.append(f"robust ({estimator}): down-weighted "
                            f"{', '.join(f'LOP {name(k)}' for k in low)}")
        return _Progress(rob.adjustment, messages, rob)
    if rob.lsq.ok:  # the M-estimation failed, the plain fix did not: use it, tested as usual
        messages.append(f"robust ({estimator}) not used: {rob.reason}; "
                        "plain least squares with data snooping")
    return _Progress(rob.lsq, messages, rob)


def _snoop(
    linearise: Callable[[np.ndarray], Linearisation],
    prog: _Progress,
    cur: np.ndarray,
    policy: str,
    bound: float,
    kw: dict[str, float | int | bool],
    name: Callable[[int], str],
) -> None:
    """The reject-and-recompute loop: while testable and max |w| > ``bound``, stop at the
    policy's verdict or exclude the worst slot and re-adjust from the current x̂."""
    adj = prog.adj
    while adj.ok and adj.redundancy >= 1:
        slot, w = _worst(adj)
        if abs(w) <= bound or _stops_here(prog, adj, slot, w, policy, bound, name):
            break
        trial = cur.copy()
        trial[slot] = False
        new = gauss_newton(linearise, adj.x, trial, **kw)  # type: ignore[arg-type]
        if not new.ok:
            prog.flagged.append(slot)
            prog.messages.append(f"LOP {name(slot)}: w = {w:.2f}, rejection leaves no fix "
                                 f"({new.reason})")
            break
        prog.rejected.append((slot, w))
        prog.messages.append(f"LOP {name(slot)} rejected (w = {w:.2f})")
        cur, adj = trial, new
    prog.adj = adj


def _stops_here(
    prog: _Progress,
    adj: Adjustment,
    slot: int,
    w: float,
    policy: str,
    bound: float,
    name: Callable[[int], str],
) -> bool:
    """True (with the flag, candidate and message noted) when ``slot`` is not rejected:
    category III (not identifiable), policy "N" (flag) or "A" (ask the operator)."""
    if adj.category == "III":
        prog.not_identifiable = True
        prog.flagged.append(slot)
        prog.messages.append(f"outlier detected, not identifiable (|w| = {abs(w):.2f})")
        return True
    if policy == "N":
        prog.flagged.append(slot)
        prog.messages.append(f"LOP {name(slot)}: w = {w:.2f} exceeds {bound}, not rejected")
        return True
    if policy == "A":
        prog.candidate, prog.candidate_w = slot, w
        prog.messages.append(f"LOP {name(slot)}: w = {w:.2f} exceeds {bound}, reject ?")
        return True
    return False


def _finish(
    prog: _Progress,
    policy: str,
    estimator: str,
    alpha: float,
    bound: float,
    s02: float,
    thesis_dof: bool,
) -> TestedAdjustment:
    """Monitor band, unit-variance test and advisory messages for the final adjustment."""
    adj, messages = prog.adj, prog.messages
    monitor: tuple[int, ...] = ()
    vt: UnitVarianceTest | None = None
    if adj.ok and adj.s2 is not None:
        k = w_critical(alpha)
        monitor = _monitor(adj.w, k, bound)
        vt = (unit_variance_test(adj.s2, adj.redundancy, alpha, s02, thesis_dof)
              if thesis_dof else adj.variance_test)
        if vt is not None and not vt.accepted:
            messages.append(
                f"unit variance rejected: S² = {adj.s2:.3f} outside "
                f"({vt.lower:.4f}, {vt.upper:.3f})"
            )
            if not prog.flagged and prog.candidate is None and adj.category == "IV":
                messages.append("advice: scale the a priori VCV by S²")
    return frozen_instance(TestedAdjustment, {
        "adjustment": adj,
        "rejected": tuple(prog.rejected),
        "candidate": prog.candidate,
        "candidate_w": prog.candidate_w,
        "flagged": tuple(prog.flagged),
        "monitor": monitor,
        "not_identifiable": prog.not_identifiable,
        "variance_test": vt,
        "messages": tuple(messages),
        "policy": policy,
        "estimator": estimator,
        "robust": prog.robust,
    })
