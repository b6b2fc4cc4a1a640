"""The fix on the compiled LSQ kernel (``engine.native.lsq``).

:func:`compute_fix` is :func:`engine.lsq.fix.compute_fix` whose usual fix (plain LSQ, nothing
to reject, flag or ask) is adjusted, tested and concluded in two compiled calls:
``adjust_tested`` (Gauss–Newton with its tests, on the model's rows) and ``estimate`` (the
geodetic position, the ellipse, the linear-range check and the LOP table). Anything else (a
rejection, a robust estimator, settings it does not take, a case it declines) runs the
reference from where the kernel left it.

The kernel is bound on first use (:func:`kernel`) to the Python objects it builds and calls:
the result classes and numpy's ``power``/``hypot`` ufuncs. Its small-matrix code is its own
(``engine/native/uvn_linalg.h``); it agrees with the reference to the tolerance contract of
docs/PERFORMANCE.md, which the run's first-use probe checks (``engine.fast.probe.fix``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

import numpy as np

from engine import native
from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.lsq import fix as ref
from engine.lsq.adjustment import COND_MAX, MAX_AXIS_RATIO, Adjustment, _settings_ok, _Solution
from engine.lsq.confidence import Ellipse
from engine.lsq.fix import FixResult, LopRow, LsqSettings, _Setup
from engine.lsq.snooping import TestedAdjustment, adjust_with_testing
from engine.lsq.statistics import (
    REJECT_BOUND,
    UnitVarianceTest,
    _variance_bounds,
    delta0,
    frozen_instance,
    unit_variance_test,
    w_critical,
)
from engine.systems.base import NavSystem, Point, PositionPrior
from engine.systems.decca import DECCA, DeccaObservations
from engine.systems.gps import GPS, GpsFix
from engine.systems.manual import MANUAL, ManualObservation

POWER = 0.80
"""The power of the MDB's δ0 (``gauss_newton``'s default, which adjust_with_testing keeps)."""


@cache
def kernel() -> Any:
    """``engine.native.lsq`` bound and usable, or None: not built, stale, declined by its
    ``_probe``, ``UVNAV_PURE=1``."""
    mod = native.kernel("lsq")
    if mod is None:
        return None
    # the first argument once carried OpenBLAS routine addresses; the kernel ignores it now
    mod._bind(None, math.hypot, _Solution, Ellipse, np.power, np.hypot)
    mod._bind_fix(Adjustment, TestedAdjustment, UnitVarianceTest, _variance_bounds, Point,
                  DeccaObservations, FixResult, DECCA.name, np.dtype(bool))
    mod._bind_row(LopRow, tuple(f for f in LopRow.__dataclass_fields__))
    return mod


def quick_settings(settings: LsqSettings) -> tuple[float, float, int, float, bool, float,
                                                   float] | None:
    """(α, ε, max_iter, σ0², ScaleVCV, δ0, k_α) of ``settings`` for the one-call path:
    settings ``gauss_newton`` accepts (the default COND_MAX, MAX_AXIS_RATIO and power) as
    floats and an int (the kernel's C types); None otherwise (the reference then says what
    is wrong). Remembered per (frozen) settings object."""
    memo = _QUICK
    if memo[0] is settings:
        return memo[1]  # type: ignore[no-any-return]
    alpha = settings.reliab_interval / 100.0
    eps, max_iter, s02 = settings.epsilon_m, settings.max_iter, settings.s02
    try:
        _settings_ok(eps, max_iter, s02, COND_MAX, MAX_AXIS_RATIO, alpha, POWER)
        ok = (type(eps) is float and type(max_iter) is int and type(COND_MAX) is float
              and type(MAX_AXIS_RATIO) is float)
        hash((alpha, s02))  # unit_variance_test's bounds are remembered by them
        quick = ((alpha, eps, max_iter, s02, settings.scale_vcv, delta0(alpha, POWER),
                  w_critical(alpha)) if ok else None)
    except Exception:  # noqa: BLE001 - the reference raises it again, with its message
        quick = None
    memo[:] = [settings, quick]
    return quick


DEFAULT_SETTINGS = LsqSettings()
"""The settings of a fix that names none (the reference's default)."""
_QUICK: list[Any] = [None, None]
"""[the LsqSettings :func:`quick_settings` saw last (None: none yet), its values]."""


def spec(model: ref._Model) -> tuple[Any, ...]:
    """What the kernel's ``adjust`` takes of the fix's model: what ``_Model.rows`` uses (each
    system's first slot and observations, the Point class, grid, geodesic, the identity C_l
    starts as), so it does what ``rows`` does (each system's ``linearise`` in order) itself."""
    return (model.parts, Point, model.grid, model.geodesic, model._eye)


def first_adjustment(state: dict[str, Any], alpha: float, s02: float) -> Adjustment:
    """The Adjustment of the compiled ``adjust``'s fields (``state``, variance_test None, as
    ``gauss_newton`` leaves it) with its unit-variance test (α, σ0² of the settings)."""
    s2 = state["s2"]
    if s2 is not None:
        state["variance_test"] = unit_variance_test(s2, state["redundancy"], alpha, s02)
    return frozen_instance(Adjustment, state)


def tested_quiet(first: Adjustment, k_alpha: float, policy: str, estimator: str,
                 k: Any) -> TestedAdjustment | None:
    """adjust_with_testing's result for a fix with nothing to reject, flag or ask (the
    kernel's ``quiet`` finds the monitor band, :func:`quiet` builds it); None when the
    reference has more to do."""
    if first.ok and first.redundancy >= 1:
        monitor = k.quiet(first.stats_block, k_alpha, REJECT_BOUND)
        if monitor is not None:
            return quiet(first, monitor, policy, estimator)
    return None


def quiet(adj: Adjustment, monitor: tuple[int, ...], policy: str,
           estimator: str) -> TestedAdjustment:
    """:func:`_finish` of a plain LSQ fix whose largest |w| is within the bound (nothing
    rejected, flagged or asked; ``monitor`` the band as the kernel's ``quiet`` found it)."""
    messages: list[str] = []
    vt = adj.variance_test
    if vt is not None and not vt.accepted:
        messages.append(
            f"unit variance rejected: S² = {adj.s2:.3f} outside "
            f"({vt.lower:.4f}, {vt.upper:.3f})"
        )
        if adj.category == "IV":
            messages.append("advice: scale the a priori VCV by S²")
    res = object.__new__(TestedAdjustment)
    object.__setattr__(res, "__dict__", {  # frozen_instance written out (every quiet fix)
        "adjustment": adj,
        "rejected": (),
        "candidate": None,
        "candidate_w": None,
        "flagged": (),
        "monitor": monitor,
        "not_identifiable": False,
        "variance_test": vt,
        "messages": tuple(messages),
        "policy": policy,
        "estimator": estimator,
        "robust": None,
    })
    return res





def compute_fix(
    grid: TMGrid,
    geodesic: GeodesicSolver,
    x0: tuple[float, float],
    *,
    gps: GpsFix | None = None,
    decca: Any = None,
    manual: Sequence[ManualObservation] = (),
    prior: PositionPrior | None = None,
    settings: LsqSettings = DEFAULT_SETTINGS,
    excluded_slots: Sequence[int] = (),
    readings: Mapping[str, Any] | None = None,
    systems: tuple[NavSystem, ...] | None = None,
) -> FixResult:
    """:func:`engine.lsq.fix.compute_fix` with its usual fix in the compiled kernel."""
    values = {GPS.name: gps, DECCA.name: decca, MANUAL.name: manual, **(readings or {})}
    setup = ref._setup(grid, geodesic, x0, values, prior, settings, excluded_slots, systems)
    if type(setup) is not _Setup:
        return setup  # type: ignore[return-value]
    problem, model, policy, estimator, manual = setup
    uses_prior = problem.uses_prior
    k = kernel()
    quick = None if k is None or estimator != "lsq" else quick_settings(settings)
    first = tested = None
    if quick is not None and policy in ("Y", "N", "A"):
        alpha, eps, max_iter, s02, scale_vcv, d0, k_alpha = quick
        state = k.adjust_tested(spec(model), x0, problem.used, eps, max_iter, COND_MAX,
                                MAX_AXIS_RATIO, scale_vcv, d0, alpha, s02, k_alpha,
                                REJECT_BOUND, policy, estimator)
        if type(state) is dict:  # the kernel left the tests to the Python
            state = first_adjustment(state, alpha, s02)
        if type(state) is Adjustment:
            first = state
            tested = tested_quiet(first, k_alpha, policy, estimator, k)
        elif type(state) is TestedAdjustment:
            first, tested = state.adjustment, state
    if tested is None:
        tested = adjust_with_testing(
            model, np.array(x0, dtype=float), problem.used, policy=policy,
            alpha=settings.reliab_interval / 100.0, epsilon=settings.epsilon_m,
            max_iter=settings.max_iter, s02=settings.s02, scale_vcv=settings.scale_vcv,
            estimator=estimator,
            lop_name=lambda slot: ref.lop_name(slot, system="KF" if uses_prior else "GPS",
                                               manual=manual),
            first=first)
    messages = problem.messages
    messages.extend(tested.messages)
    adj = tested.adjustment
    if not adj.ok:
        return ref._no_fix(grid, x0, adj.reason or "no fix", adj.n_used, tested, messages)
    if adj is first and not uses_prior:
        # the fix at the estimate in one compiled call; None: the reference
        fix = k.estimate(grid, geodesic, tested, problem.sets, problem.spans, problem.used,
                         messages, quick[6], REJECT_BOUND)  # type: ignore[index]
        if fix is not None:
            return fix  # type: ignore[no-any-return]
    return ref._at_estimate(grid, geodesic, x0, np.array(x0, dtype=float), problem, model,
                            tested, settings, problem.used if adj is first else None)
