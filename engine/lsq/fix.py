"""One least-squares position fix from the navigation systems' LOPs (thesis ch. 5, A5).

Everything is on the TM grid of the working datum (metres, x = easting, y = northing); every
observation row is metric (THEORY §4.1), so the design matrix is dimensionless and the VCV in m².
The observation vector is the concatenation of the slots of the systems in the registry
(``engine.systems.registry``, docs/SYSTEMS.md; THEORY §5.3, Pg 821/830)::

    0 GPS "Lat" (northing)   1 GPS "Lon" (easting)      — or the filter's two position LOPs
    2 Decca Red   3 Decca Green   4 Decca Purple
    5..9  up to five bearing / distance observations (BRR), in input order

This module only assembles: each system yields its rows and page data behind one interface.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np

from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.lsq.adjustment import (
    Adjustment,
    Linearisation,
)
from engine.lsq.confidence import Ellipse, eigenvalues_2x2, error_ellipse
from engine.lsq.snooping import TestedAdjustment, adjust_with_testing
from engine.lsq.statistics import (
    REJECT_BOUND,
    frozen_instance,
    w_critical,
)
from engine.systems import registry
from engine.systems.base import (
    EVAL_ERRORS,
    LopReading,
    NavSystem,
    ObservationError,
    ObservationSet,
    Point,
    PositionPrior,
)
from engine.systems.decca import (
    DECCA,
    DECCA_PATTERN_NAMES,
    DeccaGeometry,
    DeccaObservations,
    DeccaReading,
)
from engine.systems.gps import GPS, GPS_VAR_CA_M2, GPS_VAR_P_M2, GpsFix, PriorObservations
from engine.systems.manual import MANUAL, MAX_BRR, ManualObservation
from engine.systems.registry import N_SLOTS, owner_of, slots_of

SLOT_GPS_LAT, SLOT_GPS_LON = slots_of(GPS.name)
SLOT_DECCA = tuple(slots_of(DECCA.name))
SLOT_BRR0 = slots_of(MANUAL.name).start


def lop_name(slot: int, *, system: str = "GPS",
             manual: Sequence[ManualObservation] = ()) -> str:
    """The name of LOP ``slot`` as the tables and dialogs give it, for operator messages.

    ``GPS Lat``/``GPS Lon`` (``system`` "KF" when the filter's prediction stands in for GPS on
    the too-few-LOPs path), ``Decca Red``/``Grn``/``Prp``, and for an Obs-menu observation its
    sensor, ``Brg`` or ``Dist`` and the station as typed (``periscope Brg Heiloo``). Each
    system names its own rows (``NavSystem.row_name``).
    """
    owner = owner_of(slot)
    if owner is not None:
        values: dict[str, Any] = {GPS.name: system, MANUAL.name: manual}
        name = owner[0].row_name(owner[1], values.get(owner[0].name))
        if name is not None:
            return name
    return f"slot {slot}"


@dataclass(frozen=True, slots=True)
class LsqSettings:
    """LS parameters of A8.2: break-off ``epsilon_m``, ``s02``, ``LOPReject`` policy, α in %,
    ``ScaleVCV``, the estimator ("lsq", "huber", "danish") and the confidence level (%)."""

    epsilon_m: float = 1.0
    s02: float = 1.0
    lop_reject: str = "A"
    reliab_interval: float = 5.0
    scale_vcv: bool = False
    estimator: str = "lsq"
    conf_region: float = 95.0
    max_iter: int = 10


@dataclass(frozen=True, slots=True)
class LopRow:
    """One row of the LOP tables (Pg 631/633): what was read, corrected, computed and tested.

    ``read``/``calc`` are degrees for GPS rows, lanes for Decca, degrees (bearing) or metres
    (distance) for BRR rows; ``v_m`` the metric residual; ``az_deg`` the LOP azimuth; ``sigma_d``
    (m), ``w``, ``tau``, ``vf`` the test quantities (NaN when not computed: the screens' 999.99).
    """

    slot: int
    system: str
    pattern: str
    read: float
    correction: float
    calc: float
    v_m: float
    az_deg: float
    used: bool
    sigma_d: float = math.nan
    w: float = math.nan
    tau: float = math.nan
    vf: float = math.nan
    verdict: str = ""


@dataclass(frozen=True)
class FixResult:
    """The outcome of one LS fix: position, precision, per-LOP table and the raw adjustment.

    ``messages``: operator texts of this fix (Decca half-zone warnings, the tests' verdicts,
    a robust estimator's down-weighting or fall-back); ``reason`` says why when ``ok`` is False.
    """

    ok: bool
    reason: str | None
    x_m: float
    y_m: float
    lat_deg: float
    lon_deg: float
    cov: np.ndarray
    ellipse: Ellipse | None
    category: str
    n_used: int
    rms_m: float
    s2: float | None
    lops: tuple[LopRow, ...]
    tested: TestedAdjustment | None
    decca_observed: tuple[float | None, float | None, float | None] = (None, None, None)
    decca_geometry: DeccaGeometry | None = None
    rejected_slots: tuple[int, ...] = ()
    candidate_slot: int | None = None
    uses_prior: bool = False
    messages: tuple[str, ...] = field(default=())
    raw_lops: RawLops | None = None

    @property
    def lse_ok(self) -> bool:
        """A usable fix of the LOPs alone: ``ok`` and not the hybrid fix with the filter's
        prediction as two LOPs (``uses_prior``), which is the filter's to test."""
        return self.ok and not self.uses_prior

    def rows_of(self, system: str) -> tuple[LopRow, ...]:
        """The LOP table rows of one system ("gps", "decca", "manual"; the GPS slots hold the
        filter's prediction on the hybrid path), in slot order."""
        slots = slots_of(system)
        return tuple(row for row in self.lops if row.slot in slots)

    def apriori_vcv(self, system: str) -> np.ndarray | None:
        """The a priori VCV block (m²) of one system's slots in the final adjustment (Pg 611,
        Pg 615), None when there was no adjustment."""
        if self.tested is None:
            return None
        s = slots_of(system)
        return self.tested.adjustment.Cl[s.start:s.stop, s.start:s.stop]


@dataclass(frozen=True)
class RawLops:
    """The real LOPs of a too-few-LOPs fix, linearised at the filter's prediction ``x_ref``
    (grid m): metric rows ``A`` (k×2), O − C ``omc_m`` (k,) and VCV ``Cl`` (k×k, m²), for the
    filter update that must not see the hybrid LSE (THEORY §9.3, D20)."""

    A: np.ndarray
    omc_m: np.ndarray
    Cl: np.ndarray
    x_ref: np.ndarray
    slots: tuple[int, ...]


@dataclass(slots=True)
class _Problem:
    """The observation sets of one fix by system name (registry order), which slots are used,
    whether the filter's prediction stands in for GPS, the operator texts so far, the
    registry's slot layout (``registry.layout()``), its number of slots, each system's
    (first slot, end) by name (``spans``, the layout's ranges as pairs of ints) and each
    set with its first slot in ``sets`` order (``parts``, :class:`_Model`'s)."""

    sets: dict[str, ObservationSet]
    used: list[bool]
    uses_prior: bool
    messages: list[str]
    layout: Mapping[str, range]
    n_slots: int
    spans: dict[str, tuple[int, int]]
    parts: tuple[tuple[int, ObservationSet], ...] | None = None


class _Model:
    """The linearisation callback for the adjustment core (A5.9–A5.27): each system writes the
    rows of its slots."""

    __slots__ = ("_eye", "geodesic", "grid", "n_slots", "parts")

    def __init__(self, grid: TMGrid, geodesic: GeodesicSolver,
                 sets: Mapping[str, ObservationSet],
                 layout: Mapping[str, range] | None = None, n_slots: int | None = None,
                 parts: tuple[tuple[int, ObservationSet], ...] | None = None) -> None:
        """``parts``: (first slot, set) of each of ``sets`` in order, when the caller has it
        (:func:`_gather`)."""
        self.grid = grid
        self.geodesic = geodesic
        slots = registry.layout() if layout is None else layout
        if parts is None:
            parts = tuple([(slots[name].start, obs) for name, obs in sets.items()])
        self.parts = parts
        self.n_slots = sum(len(r) for r in slots.values()) if n_slots is None else n_slots
        self._eye = _eye(self.n_slots)  # copied per linearisation (cheaper than np.eye)

    def __call__(self, x: np.ndarray) -> Linearisation:
        """Design matrix, O − C (m) and a priori VCV (m²) at grid point ``x`` = (E, N)."""
        A, b, Cl = self.arrays(x)
        return frozen_instance(Linearisation, {"A": A, "b": b, "Cl": Cl})

    def arrays(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`__call__`'s A (n, 2), b (n,) and C_l (n, n) as a tuple (the adjustment core
        takes them so, :func:`engine.lsq.adjustment.gauss_newton`): :meth:`rows` converted
        once."""
        A, b, Cl = self.rows(x)
        return np.array(A).reshape(self.n_slots, 2), np.array(b), Cl

    def rows(self, x: np.ndarray) -> tuple[list[float], list[float], np.ndarray]:
        """:meth:`arrays` before the conversion: A as a row-major list of 2n floats (∂/∂x,
        ∂/∂y of each slot), b (m) as a list of n floats and C_l (m²) as an (n, n) array.

        C_l starts as the identity (unused slots: variance 1, Pg 821) with the system blocks
        written in.
        """
        n = self.n_slots
        A = [0.0] * (2 * n)  # row-major (n, 2): ∂/∂x, ∂/∂y of each slot
        b = [0.0] * n
        Cl = self._eye.copy()
        x0, y0 = x.tolist() if isinstance(x, np.ndarray) else (float(x[0]), float(x[1]))
        p = Point(self.grid, self.geodesic, x0, y0)
        for slot0, obs in self.parts:
            obs.linearise(p, slot0, A, b, Cl)
        return A, b, Cl


@lru_cache(maxsize=8)
def _eye(n: int) -> np.ndarray:
    """A read-only n×n identity (the start of C_l, copied per linearisation)."""
    eye = np.eye(n)
    eye.setflags(write=False)
    return eye


_N_SLOTS: list[Any] = [None, 0, (), {}]
"""[the registry layout last seen by :func:`_gather` (None: none yet), its number of slots,
(system, name, first slot) of each system in registry order, name -> (first slot, end)]."""


def _gather(
    p0: Point,
    values: Mapping[str, Any],
    prior: PositionPrior | None,
    excluded_slots: Sequence[int],
    systems: tuple[NavSystem, ...] | None = None,
) -> _Problem:
    """Every system's observations of ``values`` at the provisional point ``p0``; the filter's
    ``prior`` takes the GPS slots when GPS is absent and fewer than two LOPs are available
    (table 5.1 category I, THEORY §4.6). ``systems``: the run's (default the registry's).
    Raises ObservationError (with the texts so far)."""
    if systems is None:
        systems = registry.SYSTEMS
    layout = registry.layout(systems)
    sets: dict[str, ObservationSet] = {}
    memo = _N_SLOTS
    if memo[0] is layout:  # the layout is the registry's (cached per SYSTEMS)
        n_slots, order, spans = memo[1], memo[2], memo[3]
    else:
        n_slots = sum(len(r) for r in layout.values())
        order = tuple((s, s.name, layout[s.name].start) for s in systems)
        spans = {name: (r.start, r.stop) for name, r in layout.items()}
        memo[:] = [layout, n_slots, order, spans]
    used = [False] * n_slots
    messages: list[str] = []
    parts: list[tuple[int, ObservationSet]] = []
    for system, name, first in order:
        try:
            obs = system.observations(values.get(name), p0)
        except ObservationError as exc:
            raise ObservationError(exc.reason, messages + list(exc.messages)) from exc
        if obs is None:
            continue
        sets[name] = obs
        parts.append((first, obs))
        messages.extend(obs.messages)
        available = obs.available()
        used[first:first + len(available)] = available
    for slot in excluded_slots:
        used[slot] = False
    uses_prior = False
    if GPS.name not in sets and prior is not None and 0 < sum(used) < 2:
        for slot in layout[GPS.name]:
            used[slot] = True
        sets[GPS.name] = PriorObservations(prior)
        uses_prior = True
        sets = {s.name: sets[s.name] for s in systems if s.name in sets}
        return _Problem(sets, used, uses_prior, messages, layout, n_slots, spans)
    return _Problem(sets, used, uses_prior, messages, layout, n_slots, spans, tuple(parts))


def compute_fix(
    grid: TMGrid,
    geodesic: GeodesicSolver,
    x0: tuple[float, float],
    *,
    gps: GpsFix | None = None,
    decca: DeccaReading | None = None,
    manual: Sequence[ManualObservation] = (),
    prior: PositionPrior | None = None,
    settings: LsqSettings = LsqSettings(),
    excluded_slots: Sequence[int] = (),
    readings: Mapping[str, Any] | None = None,
    systems: tuple[NavSystem, ...] | None = None,
) -> FixResult:
    """Compute the LSE from the available LOPs, starting at provisional grid point ``x0`` (m).

    ``gps``, ``decca``, ``manual`` and ``readings`` (any system's reading by registry name,
    docs/SYSTEMS.md) are the systems' inputs (``systems``: the run's, default the registry's,
    :data:`engine.systems.registry.SYSTEMS`). The rejection policy, tests and estimator follow
    ``settings`` (THEORY §6; with a robust estimator nothing is rejected and there is no
    candidate); ``excluded_slots`` are slots the operator discarded (LOPReject 'A'). ``prior``
    (the filter's prediction) is used as two position LOPs only when GPS is absent (table 5.1
    category I, THEORY §4.6); that hybrid fix is always plain LSQ with policy 'N'.

    Never raises for bad geometry or data (a non-finite or far-off ``x0``, nearly parallel
    LOPs, a point where the models cannot be evaluated): a failed fix has ``ok=False`` and a
    reason. Besides the core's checks (engine.lsq.adjustment: scaled condition number, axis ratio),
    a fix whose standard semi-major axis reaches the nearest station of a used bearing,
    distance or Decca LOP is refused: each such LOP curves around its station (a circle, a
    ray ending there, a hyperbola with the station as focus), so the linearised model and its
    VCV do not describe an ellipse that large (not applied to the hybrid fix, whose LOPs the
    filter linearises itself). ValueError only for invalid ``settings`` (programming errors).
    """
    values = {GPS.name: gps, DECCA.name: decca, MANUAL.name: manual, **(readings or {})}
    setup = _setup(grid, geodesic, x0, values, prior, settings, excluded_slots, systems)
    if type(setup) is not _Setup:
        return setup
    problem, model, policy, estimator, manual = setup
    x_start = np.array(x0, dtype=float)
    uses_prior = problem.uses_prior
    tested = adjust_with_testing(
        model,
        x_start,
        problem.used,
        policy=policy,
        alpha=settings.reliab_interval / 100.0,
        epsilon=settings.epsilon_m,
        max_iter=settings.max_iter,
        s02=settings.s02,
        scale_vcv=settings.scale_vcv,
        estimator=estimator,
        lop_name=lambda slot: lop_name(slot, system="KF" if uses_prior else "GPS",
                                       manual=manual),
    )
    return _conclude(grid, geodesic, x0, x_start, problem, model, tested, settings)


class _Setup(NamedTuple):
    """What :func:`compute_fix` adjusts: the gathered problem, its model, the rejection policy
    and estimator in force, and the manual observations taken (at most :data:`MAX_BRR`)."""

    problem: _Problem
    model: _Model
    policy: str
    estimator: str
    manual: tuple[ManualObservation, ...]


def _setup(grid: TMGrid, geodesic: GeodesicSolver, x0: tuple[float, float],
           values: dict[str, Any], prior: PositionPrior | None, settings: LsqSettings,
           excluded_slots: Sequence[int],
           systems: tuple[NavSystem, ...] | None) -> _Setup | FixResult:
    """:func:`compute_fix` up to the adjustment: the systems' observations gathered at ``x0``
    and the model, or the failed fix (no finite start, observations that cannot be formed,
    fewer than two LOPs)."""
    manual = values[MANUAL.name] = tuple(values[MANUAL.name] or ())[:MAX_BRR]
    if not (math.isfinite(x0[0]) and math.isfinite(x0[1])):
        return _no_fix(grid, x0, "provisional position not finite", 0)
    try:
        problem = _gather(Point(grid, geodesic, x0[0], x0[1]), values, prior, excluded_slots,
                          systems)
    except ObservationError as exc:
        return _no_fix(grid, x0, exc.reason, 0, messages=exc.messages)
    n_avail = sum(problem.used)
    if n_avail < 2:
        return _no_fix(grid, x0, f"Not enough LOPs for a fix ! ({n_avail})", n_avail,
                       messages=problem.messages)
    model = _Model(grid, geodesic, problem.sets, problem.layout, problem.n_slots, problem.parts)
    uses_prior = problem.uses_prior
    return _Setup(problem, model, "N" if uses_prior else settings.lop_reject,
                  "lsq" if uses_prior else settings.estimator, manual)


def _conclude(grid: TMGrid, geodesic: GeodesicSolver, x0: tuple[float, float],
              x_start: np.ndarray, problem: _Problem, model: _Model, tested: TestedAdjustment,
              settings: LsqSettings) -> FixResult:
    """:func:`compute_fix` after the adjustment: the failed fix, or the fix at the estimate
    (:func:`_at_estimate`)."""
    messages = problem.messages
    messages.extend(tested.messages)
    adj = tested.adjustment
    if not adj.ok:
        return _no_fix(grid, x0, adj.reason or "no fix", adj.n_used, tested, messages)
    return _at_estimate(grid, geodesic, x0, x_start, problem, model, tested, settings)


def _at_estimate(
    grid: TMGrid,
    geodesic: GeodesicSolver,
    x0: tuple[float, float],
    x_start: np.ndarray,
    problem: _Problem,
    model: _Model,
    tested: TestedAdjustment,
    settings: LsqSettings,
    used: list[bool] | None = None,
) -> FixResult:
    """The fix at the adjusted point: geodetic position, ellipse, linear-range check, the raw
    LOPs of a hybrid fix and the LOP table; a failed fix where the models cannot be evaluated.
    ``used``: the final adjustment's used slots as a list when the caller has it."""
    adj = tested.adjustment
    messages = problem.messages
    try:
        xe, yn = adj.x.tolist()
        lat, lon = grid.inverse(xe, yn)
        p_hat = Point(grid, geodesic, xe, yn, (lat, lon))
        decca = problem.sets.get(DECCA.name)
        geom = decca.geometry_at(p_hat) if isinstance(decca, DeccaObservations) else None
        ellipse = error_ellipse(adj.cov_x)
        if used is None:
            used = adj.used.tolist()
        # the ellipse of C_x̂ as displayed is that of the a priori one unless scaled by S²
        l1 = ellipse.eigenvalues[0] if adj.cov_x is adj.cov_x_apriori else None
        alpha = settings.reliab_interval / 100.0
        if problem.uses_prior:  # no linear-range check; the raw LOPs before the table
            raw = _raw_lops(model, adj, x_start)
            check = False
        else:
            raw = None
            check = True
        # the linear-range check, then the table (a string: beyond the range, the reason)
        lops = _tail(adj, problem, p_hat, used, check, l1, alpha)
        if type(lops) is str:
            return _no_fix(grid, x0, lops, adj.n_used, tested, messages)
    except EVAL_ERRORS as exc:
        return _no_fix(grid, x0, f"model evaluation failed at the estimate: {exc}", adj.n_used,
                       tested, messages)
    return frozen_instance(FixResult, {
        "ok": True,
        "reason": None,
        "x_m": xe,
        "y_m": yn,
        "lat_deg": lat,
        "lon_deg": lon,
        "cov": adj.cov_x,
        "ellipse": ellipse,
        "category": adj.category,
        "n_used": adj.n_used,
        "rms_m": adj.rms_m,
        "s2": adj.s2,
        "lops": tuple(lops),
        "tested": tested,
        "decca_observed": (decca.raw if isinstance(decca, DeccaObservations)
                           else (None, None, None)),
        "decca_geometry": geom,
        "rejected_slots": tuple([s for s, _w in tested.rejected]) if tested.rejected else (),
        "candidate_slot": tested.candidate,
        "uses_prior": problem.uses_prior,
        "messages": tuple(messages),
        "raw_lops": raw,
    })




def _raw_lops(model: _Model, adj: Adjustment, x_start: np.ndarray) -> RawLops:
    """The real LOPs of a hybrid fix (all used slots but the prior's) at the prediction."""
    lin0 = model(x_start)
    gps = slots_of(GPS.name)
    idx = np.flatnonzero(adj.used)
    idx = idx[(idx < gps.start) | (idx >= gps.stop)]
    return RawLops(lin0.A[idx], lin0.b[idx], lin0.Cl[np.ix_(idx, idx)], x_start,
                   tuple(int(i) for i in idx))


def _beyond_linear_range(
    adj: Adjustment, sets: Mapping[str, ObservationSet], p_hat: Point,
    used: list[bool] | None = None, layout: Mapping[str, range] | None = None,
    l1: float | None = None,
) -> str | None:
    """The "no fix" reason when the standard semi-major axis (a priori C_x̂) reaches the nearest
    station of a used LOP (see :func:`compute_fix`), else None. ``used``: ``adj.used`` as a
    list; ``layout``: ``registry.layout()``; ``l1``: the larger eigenvalue of the a priori
    C_x̂[:2, :2] (m², :func:`eigenvalues_2x2`); each computed here when not given."""
    if used is None:
        used = adj.used.tolist()
    if layout is None:
        layout = registry.layout()
    near = math.inf
    for name, obs in sets.items():
        slots = layout[name]
        near = min(near, obs.nearest_station_m(p_hat, used[slots.start:slots.stop]))
    if near == math.inf:
        return None
    return _linear_range_reason(adj, near, l1)


def _linear_range_reason(adj: Adjustment, near: float, l1: float | None) -> str | None:
    """:func:`_beyond_linear_range` once the nearest station of a used LOP is known: ``near``
    (m, finite or NaN), ``l1`` as there."""
    if l1 is None:
        (sxx, sxy), (_, syy) = adj.cov_x_apriori[:2, :2].tolist()
        l1 = eigenvalues_2x2(sxx, sxy, syy)[0]
    a = math.sqrt(max(l1, 0.0))
    if a < near:
        return None
    return (f"ill-conditioned geometry: the error ellipse's semi-major axis {a / 1000:.3g} km "
            f"reaches the nearest station ({near / 1000:.3g} km; the linearised model does not "
            "hold)")


def _no_fix(
    grid: TMGrid,
    x0: tuple[float, float],
    reason: str,
    n_used: int,
    tested: TestedAdjustment | None = None,
    messages: Sequence[str] = (),
) -> FixResult:
    """A failed fix at the provisional point; its geodetic position is NaN where the grid
    cannot be inverted there (non-finite or far-off ``x0``)."""
    try:
        lat, lon = grid.inverse(float(x0[0]), float(x0[1]))
    except EVAL_ERRORS:
        lat = lon = math.nan
    return FixResult(
        ok=False,
        reason=reason,
        x_m=float(x0[0]),
        y_m=float(x0[1]),
        lat_deg=lat,
        lon_deg=lon,
        cov=np.full((2, 2), np.nan),
        ellipse=None,
        category="I",
        n_used=n_used,
        rms_m=math.nan,
        s2=None,
        lops=(),
        tested=tested,
        messages=tuple(messages),
    )


def _tail(adj: Adjustment, problem: _Problem, p_hat: Point, used: list[bool],
          check: bool, l1: float | None, alpha: float) -> tuple[LopRow, ...] | str:
    """With ``check``, :func:`_beyond_linear_range`'s reason (returned as the string) when
    there is one; then :func:`_lop_rows` of the systems' readings at ``p_hat`` as a tuple."""
    if check:
        reason = _beyond_linear_range(adj, problem.sets, p_hat, used, problem.layout, l1)
        if reason is not None:
            return reason
    return tuple(_lop_rows(adj, problem.sets, p_hat, alpha, used, problem.layout))


def _lop_rows(adj: Adjustment, sets: Mapping[str, ObservationSet], p_hat: Point,
              alpha: float, used: list[bool] | None = None,
              layout: Mapping[str, range] | None = None) -> list[LopRow]:
    """The Pg 631/633 table rows: each system's page data with the final adjustment's tests
    (``used``/``layout`` as in :func:`_beyond_linear_range`)."""
    if layout is None:
        layout = registry.layout()
    groups = [(layout[name].start, obs.readings(p_hat)) for name, obs in sets.items()]
    sigma_d, w_all, tau, vf = adj.stats_block[:4].tolist()
    if used is None:
        used = adj.used.tolist()
    v = adj.v.tolist()
    k = w_critical(alpha)
    rows: list[LopRow] = []
    for first, readings in groups:
        for r in readings:
            slot = first + r.index
            w = w_all[slot]
            if w != w:  # _verdict inline: NaN, not computed
                verdict = ""
            else:
                aw = abs(w)
                verdict = ("reject" if aw > REJECT_BOUND
                           else ("monitor" if aw > k else "accept"))
            rows.append(LopRow(slot, r.system, r.pattern, r.read, r.correction, r.calc,
                               v[slot], r.az_deg, used[slot], sigma_d[slot], w, tau[slot],
                               vf[slot], verdict))
    return rows


def _verdict(w: float, k: float, bound: float = REJECT_BOUND) -> str:
    """:func:`engine.lsq.statistics.classify_w` with the critical value ``k`` = k_α looked up
    once per table."""
    if w != w:  # NaN: not computed
        return ""
    aw = abs(w)
    if aw > bound:
        return "reject"
    return "monitor" if aw > k else "accept"


__all__ = [
    "DECCA_PATTERN_NAMES",
    "GPS_VAR_CA_M2",
    "GPS_VAR_P_M2",
    "MAX_BRR",
    "N_SLOTS",
    "SLOT_BRR0",
    "SLOT_DECCA",
    "SLOT_GPS_LAT",
    "SLOT_GPS_LON",
    "DeccaGeometry",
    "DeccaReading",
    "FixResult",
    "GpsFix",
    "LopReading",
    "LopRow",
    "LsqSettings",
    "ManualObservation",
    "PositionPrior",
    "RawLops",
    "compute_fix",
    "lop_name",
    "slots_of",
]
