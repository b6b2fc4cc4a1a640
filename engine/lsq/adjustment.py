"""Generic least-squares adjustment core (thesis ch. 5.3, eq. 5.1a–g), model-agnostic.

The caller supplies ``linearise(x) -> Linearisation``: the metric design matrix A (n, u), the
misclosures b = O − C at x [m] and the a priori VCV C_l (n, n) [m²] for all n observation slots.
A boolean ``used`` mask selects the slots; excluded slots are handled as in THEORY §5.3 (the
used sub-block of C_l is inverted, equivalent to the thesis' var = 1 / cov = 0 / W_ii = 0 trick).
It knows nothing about GPS or Decca and works for 2 or 3 (or more) parameters.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import NamedTuple

import numpy as np

try:  # the gufunc behind numpy.linalg.inv: the same LAPACK call without the wrapper's checks
    from numpy.linalg import _umath_linalg as _ULA
except ImportError:  # pragma: no cover - another numpy layout: the public function
    _ULA = None

from engine.lsq.statistics import (
    SlotStatistics,
    UnitVarianceTest,
    delta0,
    frozen_instance,
    statistics_view,
    unit_variance_test,
    used_statistics,
)

NOT_ENOUGH = "Not enough LOPs for a fix !"
_MODEL_ERRORS = (ValueError, ArithmeticError, np.linalg.LinAlgError)

COND_MAX = 1e10
"""Bound on the condition number of the parameter-scaled normal matrix D^-½ N D^-½ (D = diag N).

Numerical guard, independent of the parameters' units (metres, radians of an orientation
unknown, …): the solve of (AᵀWA) δx̂ = AᵀWb and (AᵀWA)⁻¹ lose about log10 κ of the 16 significant
digits of double precision (the 2×2 inverse cancels exactly there: det/(N11·N22) = 1 − ρ²), and
the w-test subtracts A C_x̂ Aᵀ from C_l. κ ≤ 1e10 keeps ≥ 6 correct digits (κ·ε ≈ 1e-6).
Jacobi scaling is the near-optimal diagonal scaling (van der Sluis 1969), so κ does not depend
on the units chosen for each parameter. For a 2-D position κ = (1 + |ρ|)/(1 − |ρ|) with ρ the
correlation of x̂ and ŷ. It is not rotation-invariant, hence the geometric test below.
"""

MAX_AXIS_RATIO = 1e4
"""Bound on the axis ratio a/b of the standard error ellipse of the first two parameters (the
horizontal position, both in metres): the geometric test for nearly parallel LOPs.

a/b = sqrt(λmax/λmin) of C_x̂[:2, :2] is dimensionless, rotation-invariant and independent of the
overall σ level; for a 2-D fix it is sqrt(cond(AᵀWA)). Two LOPs of equal σ crossing at an angle
θ give a/b = cot(θ/2), so 1e4 is a crossing angle of 0.011°; even with a 12 m minor axis (a
periscope bearing at 1 km, about the best a non-GPS LOP gives) the major axis would be 120 km.
Legitimate fixes stay far below: the demo (GPS + Decca) ≤ 3.5, the thesis sample 3.5, radar
bearing + range at 90 km 12.7, bearings at 1 km and 50 km 50, Decca Green + Purple on a winter
night outside the 9B coverage 126. Three bearings along one meridian give 2.9e5.
"""


@dataclass(frozen=True, eq=False)
class Linearisation:
    """One evaluation of the observation equations at x (eq. 5.1b, metric form THEORY §4.1)."""

    A: np.ndarray  # (n, u) metric design matrix [m/m]
    b: np.ndarray  # (n,) observed minus computed at x [m]
    Cl: np.ndarray  # (n, n) a priori VCV [m²]


def category(n_used: int, u: int) -> str:
    """Table 5.1 category from the redundancy r = n − u: I (r < 0), II (0), III (1), IV (≥ 2)."""
    r = n_used - u
    return "I" if r < 0 else ("II" if r == 0 else ("III" if r == 1 else "IV"))


@dataclass(frozen=True, eq=False)
class Adjustment:
    """Result of :func:`gauss_newton` (eq. 5.1c–g, 5.5, 5.8, 5.11–5.13).

    ``x`` [m] is the final estimate (includes the last δx̂). ``cov_x`` [m²] is C_x̂ as displayed
    (× S² when ``scale_vcv`` and r ≥ 1, then ``scaled`` is True), ``cov_x_apriori`` the unscaled
    (AᵀWA)⁻¹ (5.1e). ``v`` [m] = A δx̂ − b (5.1f), NaN for unused slots. ``s2`` = vᵀWv/r (5.13),
    None if r < 1. ``rms_m`` = sqrt(Σv²/n_used) (the "RMS" status field). ``steps``: |δx̂| per
    iteration [m]. ``drms_m`` = sqrt(trace cov_x) (5.30). ``variance_test``: χ²_r test of S²
    against σ0² (5.15–5.17), None if r < 1. ``damping``: the IRLS factors T_ii when this is a
    robust iteration (Cl/W are then the damped model), else None.

    Per-slot statistics (attributes viewing the rows of ``stats_block``, laid out as in
    ``statistics.used_statistics``): ``sigma_d`` [m], ``w``, ``tau``, ``vf``,
    ``redundancy_numbers``, ``mdb`` [m], ``ext`` (n, u) [m], ``ext_h`` [m]; NaN for unused slots
    and for categories I/II.

    The matrices are those of the LAST iteration (A and b evaluated at the point before the last
    correction). ``A_used``, ``b_used``, ``Cl_used``, ``W_used`` hold the used rows/block; the
    properties ``A``, ``b``, ``Cl``, ``W`` lay them out over all n slots as the thesis program
    does: unused rows of A and b zero, unused rows/columns of C_l zero with variance 1, of W zero
    (Pg 821/830). ``cov_v`` / ``cov_lhat`` (and their ``_used`` blocks) are the a posteriori VCVs
    of the residuals and of the adjusted observations (5.5b–c, corrected), C_l̂ + C_v = C_l.
    """

    ok: bool
    reason: str | None
    x: np.ndarray
    cov_x: np.ndarray
    cov_x_apriori: np.ndarray
    used: np.ndarray
    n_used: int
    u: int
    redundancy: int
    category: str
    iterations: int
    converged: bool
    steps: tuple[float, ...]
    dx: np.ndarray
    v: np.ndarray
    s2: float | None
    rms_m: float
    drms_m: float
    stats_block: np.ndarray
    A_used: np.ndarray
    b_used: np.ndarray
    Cl_used: np.ndarray
    W_used: np.ndarray
    variance_test: UnitVarianceTest | None = None
    scaled: bool = False
    damping: np.ndarray | None = None

    @property
    def r(self) -> int:
        """Redundancy r = n_used − u (alias of ``redundancy``)."""
        return self.redundancy

    @property
    def stats(self) -> SlotStatistics:
        """All per-slot statistics as one SlotStatistics (views of ``stats_block``)."""
        return statistics_view(self.stats_block)

    @property
    def sigma_d(self) -> np.ndarray:
        """σ_d per slot [m] (5.8b)."""
        return self.stats_block[0]

    @property
    def w(self) -> np.ndarray:
        """w-test statistic per slot (5.8c)."""
        return self.stats_block[1]

    @property
    def tau(self) -> np.ndarray:
        """Reliability factor τ = σ_d/σ per slot (5.11)."""
        return self.stats_block[2]

    @property
    def vf(self) -> np.ndarray:
        """Variance factor VF per slot (5.12)."""
        return self.stats_block[3]

    @property
    def redundancy_numbers(self) -> np.ndarray:
        """Redundancy numbers r_i = (C_v W)_ii per slot (Σ r_i = n_used − u)."""
        return self.stats_block[4]

    @property
    def mdb(self) -> np.ndarray:
        """Minimal detectable bias δ0·σ_d per slot [m] (internal reliability)."""
        return self.stats_block[5]

    @property
    def ext_h(self) -> np.ndarray:
        """Horizontal norm of the external reliability ∇x̂_i per slot [m]."""
        return self.stats_block[6]

    @property
    def ext(self) -> np.ndarray:
        """External reliability ∇x̂_i = C_x̂ Aᵀ W e_i·MDB_i, shape (n, u) [m]."""
        return self.stats_block[7:].T

    @cached_property
    def A(self) -> np.ndarray:
        """Design matrix over all n slots (n, u); unused rows zero (Pg 821)."""
        out = np.zeros((self.used.size, self.u))
        out[self.used] = self.A_used
        return out

    @cached_property
    def b(self) -> np.ndarray:
        """Misclosures O − C over all n slots [m]; unused slots zero (Pg 821)."""
        out = np.zeros(self.used.size)
        out[self.used] = self.b_used
        return out

    @cached_property
    def Cl(self) -> np.ndarray:
        """A priori VCV over all n slots [m²]; unused: variance 1, covariances 0 (Pg 615/821)."""
        out = np.eye(self.used.size)
        sub = np.ix_(self.used, self.used)
        out[sub] = self.Cl_used
        return out

    @cached_property
    def W(self) -> np.ndarray:
        """Weight matrix over all n slots [1/m²]; unused rows/columns zero (Pg 830)."""
        out = np.zeros((self.used.size, self.used.size))
        out[np.ix_(self.used, self.used)] = self.W_used
        return out

    @cached_property
    def cov_lhat_used(self) -> np.ndarray:
        """C_l̂ = A C_x̂ Aᵀ over the used slots [m²] (5.5c corrected): VCV of the adjusted
        observations, a priori form (C_x̂ = (AᵀWA)⁻¹ unscaled; × S² for the scaled one)."""
        return self.A_used @ self.cov_x_apriori @ self.A_used.T

    @cached_property
    def cov_v_used(self) -> np.ndarray:
        """C_v = C_l − A C_x̂ Aᵀ over the used slots [m²] (5.5b corrected): VCV of the
        residuals, a priori form. diag(C_v W) are the redundancy numbers (Σ = n_used − u)."""
        return self.Cl_used - self.cov_lhat_used

    @cached_property
    def cov_lhat(self) -> np.ndarray:
        """C_l̂ over all n slots [m²]; rows/columns of unused slots NaN."""
        return self._spread(self.cov_lhat_used)

    @cached_property
    def cov_v(self) -> np.ndarray:
        """C_v over all n slots [m²]; rows/columns of unused slots NaN."""
        return self._spread(self.cov_v_used)

    def _spread(self, block: np.ndarray) -> np.ndarray:
        out = np.full((self.used.size, self.used.size), np.nan)
        out[np.ix_(self.used, self.used)] = block
        return out


def gauss_newton(
    linearise: Callable[[np.ndarray], Linearisation],
    x0: np.ndarray,
    used: np.ndarray,
    *,
    epsilon: float = 1.0,
    max_iter: int = 10,
    s02: float = 1.0,
    scale_vcv: bool = False,
    cond_max: float = COND_MAX,
    max_axis_ratio: float | None = MAX_AXIS_RATIO,
    alpha: float = 0.05,
    power: float = 0.80,
    damping: np.ndarray | None = None,
) -> Adjustment:
    """Iterated least squares, eq. 5.1a–g: δx̂ = (AᵀWA)⁻¹AᵀWb over the used slots, x ← x + δx̂.

    A ``linearise`` object may also offer ``linearise.arrays(x) -> (A, b, C_l)``: the same
    numbers as float64 ndarrays in a tuple, without the Linearisation (the fix's model does);
    it is then called instead.

    Stops when every |δx̂_j| < ``epsilon`` (thesis ε, default 1 m, in the parameters' units), at
    most ``max_iter`` iterations. Statistics come from the last linearisation. ``alpha``/``power``
    set δ0 of the MDB and the level of the unit-variance test against σ0² = ``s02``. ``damping``
    (n,) in (0, 1] gives M-estimation weights T: W' = T^½ W T^½. The first two parameters are
    the horizontal position in metres (East, North); further ones (height, clock, orientation
    unknowns) may have other units.

    Never raises for bad geometry or data; returns ok=False with ``reason`` for: n_used < u
    ("Not enough LOPs for a fix !"); a non-finite start point; a singular normal matrix or one
    whose parameter-scaled condition number exceeds ``cond_max`` (:data:`COND_MAX`, checked in
    every iteration); a horizontal error ellipse with a/b > ``max_axis_ratio``
    (:data:`MAX_AXIS_RATIO`, nearly parallel LOPs, checked at the final point; None switches it
    off); a non-invertible C_l; non-finite values; ValueError/ArithmeticError/LinAlgError raised
    by ``linearise``; "no convergence" (the last x is kept). Raises ValueError only for
    programming errors: inconsistent shapes, ``max_iter`` < 1, ``epsilon``/``s02`` not positive
    and finite, ``cond_max`` ≤ 1, ``max_axis_ratio`` < 1, ``alpha``/``power`` outside (0, 1), a
    ``damping`` of the wrong length.
    """
    _settings_ok(epsilon, max_iter, s02, cond_max, max_axis_ratio, alpha, power)
    x = np.array(x0, dtype=float)
    used_b = np.array(used, dtype=bool)
    arrays = getattr(linearise, "arrays", None)
    run = _Run(x if x.ndim == 1 else x.reshape(-1),
               used_b if used_b.ndim == 1 else used_b.reshape(-1), arrays)
    u = run.x.size
    sq = None if damping is None else _damping_roots(damping, run.idx, run.used.size)
    try:
        if run.idx.size < u:
            raise _Stop(NOT_ENOUGH)
        if not all(map(math.isfinite, run.x.tolist())):
            raise _Stop("provisional point not finite")
        sol = _iterate(linearise, run, sq, epsilon, max_iter, cond_max)
        if max_axis_ratio is not None and u >= 2:
            _check_axis_ratio(sol.cx2, max_axis_ratio)
    except _Stop as stop:
        return _failed(stop.reason, run.x, run.used, run.used.size, u, run.it, run.steps,
                       damping)
    return _adjustment(run, sol, s02, scale_vcv, alpha, power, damping)


class _Stop(Exception):
    """Internal: the adjustment cannot go on; ``reason`` becomes Adjustment.reason."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class _Run:
    """Internal progress of :func:`gauss_newton`: the current x, the used slots, the iteration
    count, the step lengths [m] and whether it converged."""

    __slots__ = ("x", "used", "idx", "slots", "block", "it", "steps", "converged", "arrays")

    def __init__(self, x: np.ndarray, used: np.ndarray,
                 arrays: Callable[[np.ndarray], tuple[np.ndarray, ...]] | None = None) -> None:
        self.arrays = arrays
        self.x = x
        self.used = used
        self.idx = used.nonzero()[0]
        slots = self.slots = self.idx.tolist()  # the same slots as Python ints
        m = len(slots)
        first = slots[0] if m else 0
        # the used slots as one slice when they are consecutive (GPS and Decca), else None
        self.block = slice(first, first + m) if m and slots[-1] - first == m - 1 else None
        self.it = 0
        self.steps: list[float] = []
        self.converged = False


class _Solution(NamedTuple):
    """One solved linearisation over the used slots (the matrices of 5.1c–e)."""

    Au: np.ndarray  # (m, u) design rows
    bu: np.ndarray  # (m,) misclosures [m]
    Clu: np.ndarray  # (m, m) a priori (damped) VCV [m²]
    Wu: np.ndarray  # (m, m) weights C_l⁻¹
    atw: np.ndarray  # AᵀW
    cx: np.ndarray  # C_x̂ = (AᵀWA)⁻¹ (5.1e)
    gain: np.ndarray  # G = C_x̂ AᵀW
    dx: np.ndarray  # δx̂ = G b (5.1c)
    cx2: tuple[float, float, float]  # (C_x̂[0, 0], C_x̂[0, 1], C_x̂[1, 1]) as floats


def _damping_roots(damping: np.ndarray | None, idx: np.ndarray, n: int) -> np.ndarray | None:
    """T^½ over the used slots for an M-estimation step (None without damping)."""
    if damping is None:
        return None
    t = np.asarray(damping, dtype=float).reshape(-1)
    if t.size != n:
        raise ValueError(f"damping has {t.size} entries, expected {n}")
    return np.sqrt(np.clip(t[idx], 1e-300, 1.0))


def _iterate(
    linearise: Callable[[np.ndarray], Linearisation],
    run: _Run,
    sq: np.ndarray | None,
    epsilon: float,
    max_iter: int,
    cond_max: float,
) -> _Solution:
    """The Gauss–Newton loop (5.1c–d): re-linearise, solve, step, until converged or
    ``max_iter``; returns the last solution (``run`` holds x, the count and the steps)."""
    while True:
        run.it += 1
        sol = _solve(*_evaluate(linearise, run, sq), cond_max)
        big = _step(run, sol)
        if big < epsilon:
            run.converged = True
            return sol
        if run.it >= max_iter:
            return sol


def _step(run: _Run, sol: _Solution) -> float:
    """x ← x + δx̂ (5.1d) and its length |δx̂| [m] noted; returns max |δx̂_j| (_Stop when it is
    not finite)."""
    dxl = sol.dx.tolist()
    big = max(map(abs, dxl))
    if not math.isfinite(big):
        raise _Stop("non-finite linearisation")
    run.x = run.x + sol.dx  # (5.1d)
    run.steps.append(math.hypot(*dxl))
    return big


def _evaluate(
    linearise: Callable[[np.ndarray], Linearisation], run: _Run, sq: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A, b, C_l at the current x restricted to the used slots (C_l damped by T^-½ if given)."""
    arrays = run.arrays
    try:
        if arrays is not None:  # the model's float64 arrays as a tuple (see gauss_newton)
            A, b, Cl = arrays(run.x)
        else:
            lin = linearise(run.x)
    except _MODEL_ERRORS as exc:
        raise _Stop(f"model evaluation failed: {exc}") from None
    if arrays is None:
        A = np.asarray(lin.A, dtype=float)
        b = np.asarray(lin.b, dtype=float)
        Cl = np.asarray(lin.Cl, dtype=float)
    return _used_rows(run, A, b, Cl, sq)


def _used_rows(run: _Run, A: np.ndarray, b: np.ndarray, Cl: np.ndarray,
               sq: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_evaluate`'s used rows of a linearisation's arrays, after the shape check."""
    n, u = run.used.size, run.x.size
    if A.shape != (n, u) or b.shape != (n,) or Cl.shape != (n, n):
        raise ValueError(
            f"linearisation shapes A{A.shape} b{b.shape} Cl{Cl.shape} do not match "
            f"n = {n} slots and u = {u} parameters"
        )
    idx, blk = run.idx, run.block
    if idx.size == n:
        Au, bu, Clu = A, b, Cl
    elif blk is not None:  # views: the same numbers, A and b rows still contiguous
        Au, bu, Clu = A[blk], b[blk], Cl[blk, blk]
    else:
        Au, bu, Clu = A.take(idx, 0), b.take(idx), Cl.take(idx, 0).take(idx, 1)
    if sq is not None:
        Clu = Clu / np.outer(sq, sq)
    return Au, bu, Clu


def _inv(m: np.ndarray) -> np.ndarray:
    """``numpy.linalg.inv`` of a float64 square matrix (the same LAPACK gesv call, so the same
    bits) without the wrapper's type checks; LinAlgError when singular, as there."""
    if _ULA is None:  # pragma: no cover
        return np.linalg.inv(m)
    with np.errstate(call=_singular, invalid="call", over="ignore", divide="ignore",
                     under="ignore"):
        return _ULA.inv(m, signature="d->d")


def _singular(err: object, flag: object) -> None:
    raise np.linalg.LinAlgError("Singular matrix")


def _solve(Au: np.ndarray, bu: np.ndarray, Clu: np.ndarray, cond_max: float) -> _Solution:
    """W = C_l⁻¹, C_x̂ = (AᵀWA)⁻¹ with the conditioning guard, δx̂ = C_x̂ AᵀW b (5.1c, 5.1e)."""
    try:
        Wu = _inv(Clu)
    except np.linalg.LinAlgError:
        raise _Stop("a priori VCV not invertible") from None
    atw = Au.T.dot(Wu)
    cx, cond, cx2 = _inv_normal(atw.dot(Au))
    if not cond <= cond_max:  # also catches NaN
        if not (np.isfinite(Au).all() and np.isfinite(Clu).all()):
            raise _Stop("non-finite linearisation")
        if math.isinf(cond) or math.isnan(cond):
            raise _Stop("singular normal matrix")
        raise _Stop(f"ill-conditioned normal matrix (scaled condition number {cond:.3g} "
                    f"> {cond_max:.3g})")
    if not math.isfinite(float(np.add.reduce(bu))):
        raise _Stop("non-finite linearisation")
    gain = cx.dot(atw)  # G = C_x̂ Aᵀ W
    return _Solution(Au, bu, Clu, Wu, atw, cx, gain, gain.dot(bu), cx2)  # δx̂ (5.1c)


def _check_axis_ratio(cx2: tuple[float, float, float], max_axis_ratio: float) -> None:
    """_Stop when the horizontal error ellipse is too elongated (see :data:`MAX_AXIS_RATIO`);
    ``cx2`` = (C_x̂[0, 0], C_x̂[0, 1], C_x̂[1, 1])."""
    ratio = _axis_ratio2(*cx2)
    if not ratio <= max_axis_ratio:
        raise _Stop(f"ill-conditioned geometry: the LOPs are nearly parallel (error ellipse "
                    f"axis ratio a/b = {ratio:.3g} > {max_axis_ratio:.3g})")


def _adjustment(
    run: _Run,
    sol: _Solution,
    s02: float,
    scale_vcv: bool,
    alpha: float,
    power: float,
    damping: np.ndarray | None,
) -> Adjustment:
    """The Adjustment of the last solution: residuals (5.1f), S² (5.13), the per-slot
    statistics and the unit-variance test."""
    Au, bu, Wu, cx = sol.Au, sol.bu, sol.Wu, sol.cx
    idx, n, u = run.idx, run.used.size, run.x.size
    m = idx.size
    vu = Au.dot(sol.dx) - bu  # (5.1f)
    wv = Wu.dot(vu)
    r = m - u
    s2 = float(vu.dot(wv)) / r if r >= 1 else None  # (5.13)
    scaled = bool(scale_vcv and s2 is not None)
    if scaled:
        cov = cx * s2
        trace = sum(cov.diagonal().tolist())
    else:
        cov = cx
        trace = sum((sol.cx2[0], sol.cx2[2])) if u == 2 else sum(cx.diagonal().tolist())
    return frozen_instance(Adjustment, {
        "ok": run.converged,
        "reason": None if run.converged else "no convergence",
        "x": run.x,
        "cov_x": cov,
        "cov_x_apriori": cx,
        "used": run.used,
        "n_used": m,
        "u": u,
        "redundancy": r,
        "category": category(m, u),
        "iterations": run.it,
        "converged": run.converged,
        "steps": tuple(run.steps),
        "dx": sol.dx,
        "v": _spread_slots(vu, idx, n, run.block),
        "s2": s2,
        "rms_m": math.sqrt(float(vu.dot(vu)) / m),
        "drms_m": math.sqrt(max(trace, 0.0)),
        "stats_block": _statistics_block(sol, vu, wv, idx, run.block, n, r, alpha, power),
        "A_used": Au,
        "b_used": bu,
        "Cl_used": sol.Clu,
        "W_used": Wu,
        "variance_test": unit_variance_test(s2, r, alpha, s02) if s2 is not None else None,
        "scaled": scaled,
        "damping": None if damping is None else np.asarray(damping, dtype=float).copy(),
    })


def _spread_slots(vu: np.ndarray, idx: np.ndarray, n: int,
                  block: slice | None = None) -> np.ndarray:
    """A used-slot vector laid out over all n slots, NaN for the unused ones (``block``: the
    used slots ``idx`` as a slice when consecutive)."""
    if idx.size == n:
        return vu
    v = np.empty(n)
    v.fill(np.nan)
    v[idx if block is None else block] = vu
    return v


def _statistics_block(
    sol: _Solution,
    vu: np.ndarray,
    wv: np.ndarray,
    idx: np.ndarray,
    block: slice | None,
    n: int,
    r: int,
    alpha: float,
    power: float,
) -> np.ndarray:
    """The (7 + u, n) per-slot statistics (statistics.used_statistics), NaN for unused slots
    and for r < 1; ``block``: the used slots ``idx`` as a slice when consecutive."""
    u = sol.cx.shape[0]
    m = idx.size
    if r < 1:
        return np.full((7 + u, n), np.nan)
    d0 = delta0(alpha, power)
    if m == n:
        return used_statistics(sol.Au, sol.Clu, sol.Wu, sol.cx, vu, d0, sol.gain, wv, sol.atw)
    full = np.empty((7 + u, n))
    full.fill(np.nan)
    if block is not None:  # consecutive slots (GPS and Decca): write in place
        used_statistics(sol.Au, sol.Clu, sol.Wu, sol.cx, vu, d0, sol.gain, wv, sol.atw,
                        out=full[:, block])
    else:
        full[:, idx] = used_statistics(sol.Au, sol.Clu, sol.Wu, sol.cx, vu, d0, sol.gain, wv,
                                       sol.atw)
    return full


def _settings_ok(
    epsilon: float,
    max_iter: int,
    s02: float,
    cond_max: float,
    max_axis_ratio: float | None,
    alpha: float,
    power: float,
) -> None:
    """:func:`_check_settings`, remembered for settings already found valid (every fix of a
    run has the same ones)."""
    try:
        _check_settings_cached(epsilon, max_iter, s02, cond_max, max_axis_ratio, alpha, power)
    except TypeError:  # an unhashable value: check it plainly (its error)
        _check_settings(epsilon, max_iter, s02, cond_max, max_axis_ratio, alpha, power)


def _check_settings(
    epsilon: float,
    max_iter: int,
    s02: float,
    cond_max: float,
    max_axis_ratio: float | None,
    alpha: float,
    power: float,
) -> None:
    """ValueError for settings no adjustment can run with (programming errors, not data)."""
    if isinstance(max_iter, bool) or not isinstance(max_iter, int | np.integer) or max_iter < 1:
        raise ValueError(f"max_iter must be an integer ≥ 1, got {max_iter!r}")
    for name, val in (("epsilon", epsilon), ("s02", s02)):
        if not (isinstance(val, int | float) and math.isfinite(val) and val > 0.0):
            raise ValueError(f"{name} must be positive and finite, got {val!r}")
    if not cond_max > 1.0:
        raise ValueError(f"cond_max must be > 1, got {cond_max!r}")
    if max_axis_ratio is not None and not max_axis_ratio >= 1.0:
        raise ValueError(f"max_axis_ratio must be ≥ 1 or None, got {max_axis_ratio!r}")
    for name, val in (("alpha", alpha), ("power", power)):
        if not 0.0 < val < 1.0:
            raise ValueError(f"{name} must be in (0, 1), got {val!r}")


_check_settings_cached = lru_cache(maxsize=32, typed=True)(_check_settings)


def _axis_ratio(cx: np.ndarray) -> float:
    """a/b of the standard ellipse of the first two parameters of C_x̂ (inf if degenerate)."""
    (a, c), (_, d) = cx[:2, :2].tolist()
    return _axis_ratio2(a, c, d)


def _axis_ratio2(a: float, c: float, d: float) -> float:
    """:func:`_axis_ratio` of [[a, c], [c, d]]."""
    lmax = 0.5 * (a + d) + math.hypot(0.5 * (a - d), c)
    det = a * d - c * c
    if not (lmax > 0.0 and det > 0.0):
        return math.inf
    return lmax / math.sqrt(det)  # sqrt(λmax/λmin) with λmin = det/λmax (no cancellation)


def _inv_normal(nmat: np.ndarray) -> tuple[np.ndarray, float, tuple[float, float, float]]:
    """(AᵀWA)⁻¹, the condition number of the parameter-scaled D^-½ N D^-½ (D = diag N; see
    :data:`COND_MAX`; inf when singular or not positive definite, NaN when non-finite) and the
    floats (C_x̂[0, 0], C_x̂[0, 1], C_x̂[1, 1]) of the inverse (NaN when there is none).

    Closed form for 2×2 (the usual 2-D fix); ``numpy.linalg`` otherwise.
    """
    if nmat.shape == (2, 2):
        (a, c), (_, d) = nmat.tolist()
        det = a * d - c * c
        if not (a > 0.0 and d > 0.0 and det > 0.0):
            bad = math.isfinite(a) and math.isfinite(d) and math.isfinite(det)
            return nmat, (math.inf if bad else math.nan), _NAN3
        # scaled matrix [[1, ρ], [ρ, 1]], ρ = c/sqrt(ad): κ = (1 + |ρ|)/(1 − |ρ|)
        # = (1 + |ρ|)²·ad/det, which avoids the cancellation of 1 − |ρ|
        ad = a * d
        rho = abs(c) / math.sqrt(ad)
        i00, i01, i11 = d / det, -c / det, a / det
        inv = np.array(((i00, i01), (i01, i11)))
        return inv, (1.0 + rho) ** 2 * ad / det, (i00, i01, i11)
    cond = _cond_sym(nmat)
    if not cond < math.inf:
        return nmat, cond, _NAN3
    inv = np.linalg.inv(nmat)
    (i00, i01), (_, i11) = inv[:2, :2].tolist()
    return inv, cond, (i00, i01, i11)


_NAN3 = (math.nan, math.nan, math.nan)


def _cond_sym(nmat: np.ndarray) -> float:
    """Condition number of the Jacobi-scaled symmetric normal matrix; inf if not positive
    definite, NaN if not finite."""
    if not np.isfinite(nmat).all():
        return math.nan
    dg = nmat.diagonal()
    if not (dg > 0.0).all():
        return math.inf
    s = 1.0 / np.sqrt(dg)
    lam = np.linalg.eigvalsh(nmat * np.outer(s, s))
    if lam[0] <= 0.0:
        return math.inf
    return float(lam[-1] / lam[0])


def _failed(
    reason: str,
    x: np.ndarray,
    used: np.ndarray,
    n: int,
    u: int,
    iterations: int,
    steps: list[float] | tuple[float, ...],
    damping: np.ndarray | None,
) -> Adjustment:
    """An ok=False Adjustment with NaN statistics and matrices (the x passed in is kept)."""
    m = int(used.sum())
    nan_uu = np.full((u, u), np.nan)
    return Adjustment(
        ok=False,
        reason=reason,
        x=x,
        cov_x=nan_uu,
        cov_x_apriori=nan_uu.copy(),
        used=used,
        n_used=m,
        u=u,
        redundancy=m - u,
        category=category(m, u),
        iterations=iterations,
        converged=False,
        steps=tuple(steps),
        dx=np.full(u, np.nan),
        v=np.full(n, np.nan),
        s2=None,
        rms_m=math.nan,
        drms_m=math.nan,
        stats_block=np.full((7 + u, n), np.nan),
        A_used=np.full((m, u), np.nan),
        b_used=np.full(m, np.nan),
        Cl_used=np.full((m, m), np.nan),
        W_used=np.full((m, m), np.nan),
        damping=None if damping is None else np.asarray(damping, dtype=float).copy(),
    )

