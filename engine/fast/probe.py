"""First-use probes of the compiled systems: a few numbers computed both ways must agree.

:func:`systems` places a Decca chain (the Frisian Islands chain 9B of the thesis, its stations
to the second of arc) on a compiled and a reference grid and compares, at points around the
chain, the lane geometry, the rows of one LSQ iteration, the page rows, the nearest station,
a tracked record's lane totals and the GPS rows. Agreement is the tolerance contract of
docs/PERFORMANCE.md: 1e-9 relative, or 1e-6 m / 1e-9 of a lane (or radian) absolute.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np

from engine.geodesy.ellipsoid import Ellipsoid
from engine.geodesy.ellipsoidal import GeodesicSolver
from engine.geodesy.tmgrid import TMGrid
from engine.io.deccafile import DeccaChain, DeccaStation
from engine.systems import decca
from engine.systems.base import LopReading, Point
from engine.systems.gps import GpsFix

REL, ABS = 1e-9, 1e-6
"""The probes' tolerances: relative, and absolute (m, lanes, radians)."""

_CHAIN = DeccaChain(
    "9B", "Frisian Islands",
    DeccaStation("master", "Finsterwolde", 53.2034, 7.1002, 85.72),
    DeccaStation("red", "Hoyer", 55.0186, 8.6940, 114.293),
    DeccaStation("green", "Heiloo", 52.5917, 4.7298, 128.58),
    DeccaStation("purple", "Zeven", 53.2853, 9.2636, 71.4333),
    "ED50", (30.0, 30.0, 30.0), 299.65,
)
_INTL = Ellipsoid("INTERNATIONAL", 6378388.0, 297.0)
_OFFSETS = ((-40e3, 25e3), (10e3, -60e3), (75e3, 5e3))
"""Points (m from the master) the probe evaluates at."""


def _same(a: Any, b: Any) -> bool:
    """Numbers (nested lists, tuples, arrays, None) equal within the probe's tolerances."""
    if a is None or b is None:
        return a is b
    fa = np.asarray(a, dtype=float).ravel()
    fb = np.asarray(b, dtype=float).ravel()
    return fa.shape == fb.shape and bool(np.all(
        (fa == fb) | np.isclose(fa, fb, rtol=REL, atol=ABS) | (np.isnan(fa) & np.isnan(fb))))


def _rows(obs: Any, p: Point) -> tuple[list[float], list[float], np.ndarray]:
    A, b, Cl = [0.0] * 20, [0.0] * 10, np.eye(10)
    obs.linearise(p, 2, A, b, Cl)
    return A, b, Cl


def _page(rows: list[LopReading]) -> list[Any]:
    return [(r.index, r.system, r.pattern, r.read, r.correction, r.calc, r.az_deg)
            for r in rows]


def _geodesics() -> tuple[GeodesicSolver, GeodesicSolver]:
    """(the compiled side's, the reference side's) geodesic of the systems' and the fix's
    probes. The compiled geodesic, where in use, serves both sides: it has its own first-use
    check (:meth:`engine.fast.geodesy.FastGeodesicSolver.native`, against the reference's
    recorded numbers), so these probes check the systems and the fix given the geodesic, and a
    compiled run does not import pyproj for them (~50 ms of start-up)."""
    from engine.fast.geodesy import FastGeodesicSolver

    fast = FastGeodesicSolver(_INTL)
    return (fast, fast) if fast.native() is not None else (fast, GeodesicSolver(_INTL))


def systems(fast_decca: Any, fast_gps: Any) -> str | None:
    """Why the compiled systems are not used (None: they agree with the reference)."""
    from engine.fast import decca as fdecca
    from engine.fast.geodesy import FastTMGrid

    grids = FastTMGrid(_INTL, 7.0), TMGrid(_INTL, 7.0)
    geods = _geodesics()
    placed = [decca.place_chain(_CHAIN, g) for g in grids]
    t0 = datetime(1992, 9, 17, 12, 0, tzinfo=UTC)
    mx, my = placed[1].station_xy_m[0].tolist()
    for dx, dy in _OFFSETS:
        x, y = mx + dx, my + dy
        geom = [fdecca.decca_geometry(placed[0], x, y, geods[0]),
                decca.decca_geometry(placed[1], x, y, geods[1])]
        for name in decca.DeccaGeometry.__slots__:
            if not _same(getattr(geom[0], name), getattr(geom[1], name)):
                return f"first-use probe failed (Decca geometry, {name})"
        fractions = tuple(float(n % 1.0) for n in geom[1].n_calc.tolist())
        track = tuple((float(n), t0) for n in geom[1].n_calc.tolist())
        t1 = t0 + timedelta(seconds=1)
        lanes = [fdecca.tracked_totals(placed[0], geods[0], track, fractions, t1, None),
                 decca.decca_totals(placed[1], geods[1], ((0, 0),) * 3, track, fractions, t1,
                                   (x, y), None, None)]
        if lanes[0] is not None and not _same(lanes[0].totals, lanes[1].totals):
            return "first-use probe failed (Decca lane totals)"
        values = [decca.DeccaReading(pl, fractions, (None,) * 3, (True,) * 3,
                                     (0.01, -0.02, 0.0), 64.0, lanes[1].totals)
                  for pl in placed]
        obs = [fast_decca.observations(values[0], Point(grids[0], geods[0], x, y)),
               decca.DECCA.observations(values[1], Point(grids[1], geods[1], x, y))]
        pts = [Point(grids[0], geods[0], x + 10.0, y - 20.0),
               Point(grids[1], geods[1], x + 10.0, y - 20.0)]
        if not all(_same(r0, r1) for r0, r1 in zip(_rows(obs[0], pts[0]), _rows(obs[1], pts[1]),
                                                     strict=True)):
            return "first-use probe failed (Decca rows)"
        page = [_page(o.readings(p)) for o, p in zip(obs, pts, strict=True)]
        if ([r[:3] for r in page[0]] != [r[:3] for r in page[1]]
                or not _same([r[3:] for r in page[0]], [r[3:] for r in page[1]])):
            return "first-use probe failed (Decca page rows)"
        used = (True, False, True)
        if not _same(obs[0].nearest_station_m(pts[0], used),
                     obs[1].nearest_station_m(pts[1], used)):
            return "first-use probe failed (Decca nearest station)"
        fix = GpsFix(52.5, 5.0, x - 5.0, y + 7.0, 2500.0, 1.5, -2.5)
        g_obs = [fast_gps.observations(fix, pts[0]), decca_gps_reference(fix)]
        if not all(_same(r0, r1) for r0, r1 in zip(_rows(g_obs[0], pts[0]),
                                                     _rows(g_obs[1], pts[1]), strict=True)):
            return "first-use probe failed (GPS rows)"
    if not math.isfinite(mx):
        return "first-use probe failed (chain placement)"
    return None


def decca_gps_reference(fix: GpsFix) -> Any:
    """The reference GPS system's observations of ``fix``."""
    from engine.systems.gps import GPS

    return GPS.observations(fix, None)  # type: ignore[arg-type]


def fix(fast_compute_fix: Any) -> str | None:
    """Why the compiled fix is not used (None: a GPS + Decca fix agrees with the reference's:
    position, VCV, S², and every LOP row's numbers and verdict)."""
    from engine.fast.decca import FAST_DECCA
    from engine.fast.geodesy import FastTMGrid
    from engine.fast.gps import FAST_GPS
    from engine.lsq.fix import compute_fix
    from engine.systems.gps import GPS
    from engine.systems.manual import MANUAL

    grids = FastTMGrid(_INTL, 7.0), TMGrid(_INTL, 7.0)
    geods = _geodesics()
    placed = [decca.place_chain(_CHAIN, g) for g in grids]
    mx, my = placed[1].station_xy_m[0].tolist()
    systems = ((FAST_GPS, FAST_DECCA, MANUAL), (GPS, decca.DECCA, MANUAL))
    for dx, dy in _OFFSETS:
        x, y = mx + dx, my + dy
        n = decca.decca_geometry(placed[1], x + 30.0, y - 45.0, geods[1]).n_calc.tolist()
        totals = (n[0] + 0.02, n[1] - 0.01, n[2] + 0.005)
        fixes = []
        for i in (0, 1):
            reading = decca.DeccaReading(placed[i], tuple(t % 1.0 for t in totals), (None,) * 3,
                                         (True,) * 3, (0.0, 0.0, 0.0), 64.0, totals)
            gps = GpsFix(52.5, 5.0, x + 20.0, y - 40.0, 2500.0, 0.0, 0.0)
            f = (fast_compute_fix, compute_fix)[i]
            fixes.append(f(grids[i], geods[i], (x, y), gps=gps, decca=reading,
                           systems=systems[i]))
        a, b = fixes
        if (a.ok, a.reason, a.category, a.n_used, len(a.lops)) != \
                (b.ok, b.reason, b.category, b.n_used, len(b.lops)):
            return "first-use probe failed (fix: outcome)"
        if not _same([a.x_m, a.y_m, a.rms_m, a.s2], [b.x_m, b.y_m, b.rms_m, b.s2]) or \
                not _same(a.cov, b.cov):
            return "first-use probe failed (fix: position)"
        for ra, rb in zip(a.lops, b.lops, strict=True):
            if (ra.slot, ra.used, ra.verdict) != (rb.slot, rb.used, rb.verdict) or not _same(
                    [ra.v_m, ra.w, ra.sigma_d, ra.calc], [rb.v_m, rb.w, rb.sigma_d, rb.calc]):
                return "first-use probe failed (fix: LOP rows)"
    return None
