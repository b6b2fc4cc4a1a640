"""Decca on the compiled lane model (``engine.native.decca``).

:class:`FastDeccaSystem` is :class:`engine.systems.decca.DeccaSystem` whose usual record (every
pattern tracked, no lane slip) has its lane totals made in one compiled call (``tracked``), and
whose observations are :class:`FastDeccaObservations`: the rows of each LSQ iteration
(``linearise_at``/``linearise``), the geometry, the page rows and the nearest station in one
call each. Anything the kernel declines (NotImplemented: a first reading, a gap, a slip, an
argument it does not read) goes to the reference.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache
from typing import Any

import numpy as np

from engine import native
from engine.fast import lanes as fast_lanes
from engine.fast.geodesy import _UNSET as _UNSET_GEODESIC
from engine.fast.geodesy import FastGeodesicSolver
from engine.fast.make import slots_maker as maker
from engine.systems import decca
from engine.systems.base import CycleInputs, LopReading, Point
from engine.systems.decca import (
    DECCA_PATTERN_NAMES,
    DECCA_TRACK_GAP_S,
    LANE_SIGMA_MAX,
    LANE_STEP_MAX,
    PATTERNS,
    ChainOnGrid,
    DeccaGeometry,
    DeccaObservations,
    DeccaReading,
    DeccaSystem,
    LaneRule,
    LaneSource,
    LaneTotals,
)

KERNEL: Any = native.kernel("decca")
"""``engine.native.decca``, or None."""
TMGRID: Any = native.kernel("tmgrid")
"""``engine.native.tmgrid`` (its ``inverse``, which the lane kernels call), or None."""


_new_geometry = maker(DeccaGeometry)
_new_totals = maker(LaneTotals)
_new_lop = maker(LopReading)


def geodesic_kernel(geodesic: Any) -> Any:
    """The solver's compiled geodesic (:meth:`FastGeodesicSolver.native`), or None (the
    reference solver, or one whose kernel declined). Several times a cycle: its resolved
    geodesic read first."""
    g = getattr(geodesic, "_native", None)
    if g is None or KERNEL is None:
        return None
    if g is _UNSET_GEODESIC:
        g = geodesic.native() if isinstance(geodesic, FastGeodesicSolver) else None
    return g


@cache
def lane_sigma_kernel() -> Any:
    """The kernel's ``lane_sigma`` (its own 2×2 products, engine/native/uvn_linalg.h), or None
    (no kernel)."""
    return None if KERNEL is None else KERNEL.lane_sigma


def decca_geometry(placed: ChainOnGrid, x_m: float, y_m: float, geodesic: Any,
                   latlon_deg: tuple[float, float] | None = None) -> DeccaGeometry:
    """:func:`engine.systems.decca.decca_geometry` in one compiled call (``geometry_new``)."""
    kg = geodesic_kernel(geodesic)
    if kg is not None:
        lat0, lon0 = placed.grid.inverse(x_m, y_m) if latlon_deg is None else latlon_deg
        r = KERNEL.geometry_new(placed._scalars, kg, x_m, y_m, lat0, lon0, _new_geometry,
                                placed.baseline_m)
        if r is not NotImplemented:
            return r  # type: ignore[no-any-return]
    return decca.decca_geometry(placed, x_m, y_m, geodesic, latlon_deg)


def tracked_totals(placed: ChainOnGrid, geodesic: Any,
                   track: Sequence[Any], fractions: Sequence[float | None], time: Any,
                   gps: Any) -> LaneTotals | None:
    """:func:`engine.systems.decca.decca_totals` in one compiled call (``tracked``) for the
    usual record: every pattern read is tracked (its last total within
    :data:`DECCA_TRACK_GAP_S`) and GPS (``gps``, a :class:`engine.systems.gps.GpsFix`, its
    corrections added; None: no GPS) finds no lane slip, and no reading moved more than
    :data:`LANE_STEP_MAX` from its track. None for anything else: then the reference runs."""
    kg = geodesic_kernel(geodesic)
    packed = getattr(placed.grid, "_packed", None)
    if kg is None or TMGRID is None or packed is None or lane_sigma_kernel() is None:
        return None
    if _big_step(track, fractions):
        return None  # under lane_check = "dia" the count is identified again
    if gps is None:
        r = KERNEL.tracked(placed._scalars, kg, TMGRID.inverse, packed, track, fractions, time,
                           None, None, None, DECCA_TRACK_GAP_S, LANE_SIGMA_MAX, LaneTotals)
    else:
        r = KERNEL.tracked(placed._scalars, kg, TMGRID.inverse, packed, track, fractions, time,
                           gps.x_m + gps.corr_east_m, gps.y_m + gps.corr_north_m, gps.var_m2,
                           DECCA_TRACK_GAP_S, LANE_SIGMA_MAX, LaneTotals)
    return None if r is NotImplemented else r  # type: ignore[no-any-return]


def gap_totals(placed: ChainOnGrid, geodesic: Any, track: Sequence[Any],
               fractions: Sequence[float | None], time: Any, position: LaneSource | None,
               gps: Any, gps_source: LaneSource | None, rule: LaneRule) -> LaneTotals | None:
    """:func:`engine.systems.decca.decca_totals` under ``rule`` for a record whose patterns
    read are tracked or after a gap, where no lane is taken: the tracked patterns by the
    compiled ``tracked`` (:func:`tracked_totals`, GPS ``gps`` finding no slip), the others by
    the reference's ``_identify_gap`` on :mod:`engine.fast.lanes`' scalars (GPS as
    ``gps_source``, then ``position``). None for anything else (a first reading, no gap, a
    slip, a lane taken, a decision within the error bound): then the reference runs."""
    kg = geodesic_kernel(geodesic)
    packed = getattr(placed.grid, "_packed", None)
    if kg is None or TMGRID is None or packed is None or not hasattr(KERNEL, "lanes"):
        return None
    gap: list[int] = []
    last_time = None
    last_s = 0.0
    for i in range(3):  # decca_totals' gap test
        if fractions[i] is None:
            continue
        prev = track[i]
        if prev is None:
            return None  # a first reading: the operator's zone/lane
        t_prev = prev[1]
        if t_prev is not last_time:
            last_s = (time - t_prev).total_seconds()
            last_time = t_prev
        if not last_s <= DECCA_TRACK_GAP_S:
            gap.append(i)
    if not gap:
        return None
    masked = tuple(None if i in gap else f for i, f in enumerate(fractions))
    lanes = tracked_totals(placed, geodesic, track, masked, time, gps)
    if lanes is None:
        return None
    totals = list(lanes.totals)
    new_track = list(lanes.track)
    notes: list[str] = []
    at = fast_lanes.Sources(placed, KERNEL, kg, TMGRID.inverse, packed)
    try:
        decca._identify_gap(at, gap, fractions, totals, new_track, time, (gps_source, position),
                            rule, notes, floats=fast_lanes.floats_at, fix=fast_lanes.fix_lanes)
    except fast_lanes.Declined:
        return None
    return _new_totals((totals[0], totals[1], totals[2]), tuple(new_track), tuple(notes), 0)


class FastDeccaObservations(DeccaObservations):
    """:class:`DeccaObservations` with its per-iteration work in the compiled lane model."""

    __slots__ = ()

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        """The rows in one compiled call (``linearise_at``, which also sets ``p.latlon`` by
        the tmgrid kernel's inverse, else ``linearise``), where the model's own
        :func:`engine.systems.decca.decca_vcv_m2` is in place."""
        kg = geodesic_kernel(p.geodesic)
        if kg is not None and decca.decca_vcv_m2 is decca._DECCA_VCV_M2:
            placed = self.reading.placed
            grid = placed.grid
            packed = getattr(grid, "_packed", None)
            s = slice(slot0, slot0 + len(PATTERNS))
            if TMGRID is not None and packed is not None:
                r = KERNEL.linearise_at(placed._scalars, kg, TMGRID.inverse, packed, grid, p,
                                        self.observed, slot0, A, b, Cl, self.reading.cf)
                if r is None:
                    return
                if r is not NotImplemented:  # Cl is not a float64 buffer: numpy assigns it
                    Cl[s, s] = r
                    return
            lat0, lon0 = p.latlon if p.grid is grid else grid.inverse(p.x, p.y)
            r = KERNEL.linearise(placed._scalars, kg, p.x, p.y, lat0, lon0, self.observed,
                                 slot0, A, b, Cl, self.reading.cf)
            if r is None:
                return
            if r is not NotImplemented:
                Cl[s, s] = r
                return
        super().linearise(p, slot0, A, b, Cl)

    def geometry_at(self, p: Point) -> DeccaGeometry:
        if self._at is None or self._at[0] is not p:
            self._at = (p, decca_geometry(self.reading.placed, p.x, p.y, p.geodesic, p.latlon))
        return self._at[1]

    def readings(self, p: Point) -> list[LopReading]:
        """The page rows in one compiled call (``page``)."""
        at = self._at  # self.geometry_at(p), its computed case looked up here
        geom = at[1] if at is not None and at[0] is p else self.geometry_at(p)
        if KERNEL is not None:
            rows = KERNEL.page(geom.n_calc, geom.lop_azimuth_rad, self.raw,
                               self.reading.corrections_lanes, DECCA_PATTERN_NAMES, "Decca",
                               _new_lop)
            if rows is not NotImplemented:
                return rows  # type: ignore[no-any-return]
        return super().readings(p)

    def nearest_station_m(self, p: Point, used: Sequence[bool]) -> float:
        """The nearest station in one compiled call (``nearest``)."""
        at = self._at  # self.geometry_at(p), its computed case looked up here
        geom = at[1] if at is not None and at[0] is p else self.geometry_at(p)
        if KERNEL is not None:
            near = KERNEL.nearest(geom.d_master_m, geom.d_slave_m, used)
            if near is not NotImplemented:
                return near  # type: ignore[no-any-return]
        return super().nearest_station_m(p, used)


def _big_step(track: Sequence[Any], fractions: Sequence[float | None]) -> bool:
    """A pattern whose reading moved more than :data:`LANE_STEP_MAX` lanes from its tracked
    count (:func:`engine.systems.decca.decca_totals` identifies it again under ``[decca]
    lane_check = "dia"``; the kernel would track it, so it is not asked)."""
    floor = math.floor
    for prev, frac in zip(track, fractions, strict=True):
        if prev is None or frac is None:
            continue
        p0 = prev[0]
        if not isinstance(p0, float) or not math.isfinite(p0):
            continue
        d = frac - (p0 - floor(p0))
        if not abs(d - floor(d + 0.5)) <= LANE_STEP_MAX:
            return True
    return False


class FastDeccaSystem(DeccaSystem):
    """:class:`DeccaSystem` on the compiled lane model."""

    observations_class = FastDeccaObservations

    def lane_totals(self, inputs: CycleInputs, placed: ChainOnGrid, gps: Any) -> LaneTotals:
        """The usual record by :func:`tracked_totals`; one with patterns after a gap under
        the bootstrap lane rule by :func:`gap_totals`; the rest by the reference."""
        ctx, nav, rec = inputs.context, inputs.nav, inputs.record
        lanes = tracked_totals(placed, ctx.geodesic, nav.decca_track, rec.decca, rec.time, gps)
        if lanes is None:
            rule = self._rule(inputs.config, self._epoch_cf(inputs)[0])
            if rule is not None:
                prior = inputs.prior
                lanes = gap_totals(
                    placed, ctx.geodesic, nav.decca_track, rec.decca, rec.time,
                    None if prior is None else LaneSource("the DR position", *inputs.x_start,
                                                           prior.cov),
                    gps,
                    None if gps is None else LaneSource("GPS", gps.x_m + gps.corr_east_m,
                                                        gps.y_m + gps.corr_north_m,
                                                        self._gps_cov(gps.var_m2)),
                    rule)
        return super().lane_totals(inputs, placed, gps) if lanes is None else lanes


    def observations(self, value: DeccaReading | None, p0: Point) -> DeccaObservations | None:
        """Tracked totals' lists in one compiled call (``observed``)."""
        if value is not None and value.totals is not None and KERNEL is not None:
            lists = KERNEL.observed(value.totals, value.fractions, value.corrections_lanes,
                                    value.selected, math.nan)
            if lists is not NotImplemented:
                return FastDeccaObservations(value, *lists, [])
        return super().observations(value, p0)


FAST_DECCA = FastDeccaSystem()
"""The Decca system of a run on the compiled path."""
