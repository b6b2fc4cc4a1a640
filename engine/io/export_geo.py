"""Positions and 95 % ellipses of a replay log on WGS84, for the exports (docs/EXPORT.md).

GPX, GeoJSON (RFC 7946) and KML are WGS84 by definition; a run's positions are on its working
datum (ED50 in the bundled runs). Each point is transformed with the run's own datum parameters
from ``TO_WGS84.DAT`` (:class:`engine.geodesy.ellipsoidal.DatumShift`, THEORY §2.1, D1), at
ellipsoidal height 0 on the working datum (the positions are at the sea surface; a 40 m error in
that height moves the horizontal result by about 1 mm).

**Ellipses.** The log gives the 95 % ellipse in the TM calculating grid of the cycle (THEORY
§2.3): semi-axes a ≥ b in grid metres and the major-axis azimuth from **grid** north. Its outline
is built in the grid — ``n`` points (x, y) = centre + a·cos t·u + b·sin t·v with u = (sin Az,
cos Az) and v = (−cos Az, sin Az), counter-clockwise in (east, north) — and each point is taken
back to geodetic coordinates by the inverse of the same grid (the cycle's CM, the working
datum's ellipsoid), then to WGS84. The grid's meridian convergence γ (true azimuth of grid north,
≈ (λ − CM)·sin φ, ~0.4° in the demo) and its point scale (1 + 1.4e-5 half a degree off the CM)
are thereby applied exactly; ``az_true_deg`` = Az + γ is reported alongside ``az_grid_deg``.

The grid of a point is found from its own coordinates: the cycle's CM when the logged (x, y)
agrees with the forward projection of (lat, lon) on it, else the whole-degree CM near the
longitude that does (smoothed positions are on the run's final CM, not the cycle's).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from engine.errors import InputError
from engine.geodesy.ellipsoid import WGS84, Datum, Ellipsoid
from engine.geodesy.ellipsoidal import DatumShift
from engine.geodesy.tmgrid import TMGrid, central_meridian_deg
from engine.io.datumfile import DatumFile
from engine.io.export_read import ExportEpoch, ExportLog, TrackPoint

__all__ = [
    "ELLIPSE_POINTS",
    "TRACKS",
    "TRACK_TITLES",
    "ExportData",
    "build_export",
    "GRID_MATCH_M",
    "GeoPoint",
    "Wgs84Converter",
    "ellipse_grid_ring",
    "ellipse_grid_rings",
]

ELLIPSE_POINTS = 72
"""Vertices of an ellipse outline (every 5°): the inscribed polygon's area is
72·sin(5°)/(2π) = 0.99873 of π·a·b."""
FloatArray = npt.NDArray[np.float64]
GRID_MATCH_M = 0.05
"""Largest distance (m) between a logged grid position and the projection of its logged
latitude/longitude for the grid to count as the point's grid (JSON rounds to 1 mm)."""


@dataclass(frozen=True, slots=True)
class GeoPoint:
    """A point on WGS84 for the exports: latitude, longitude (degrees), elevation (m, = −depth,
    relative to the sea surface; None when the estimate has no depth), the 95 % ellipse (semi-axes
    m, azimuths from grid and from true north in degrees) with its outline as a closed
    counter-clockwise ring of (lon, lat) degrees, and the grid of the working datum (east and
    north m, CM degrees) as logged."""

    lat_deg: float
    lon_deg: float
    elevation_m: float | None
    depth_m: float | None
    east_m: float | None
    north_m: float | None
    cm_deg: float | None
    a95_m: float | None
    b95_m: float | None
    az_grid_deg: float | None
    az_true_deg: float | None
    ring: tuple[tuple[float, float], ...] | None


def _wrap_lon(lon_deg: float) -> float:
    """A longitude into [−180°, 180°] (unchanged when already inside)."""
    return lon_deg if -180.0 <= lon_deg <= 180.0 else (lon_deg + 180.0) % 360.0 - 180.0


def ellipse_grid_rings(x_m: npt.ArrayLike, y_m: npt.ArrayLike, a_m: npt.ArrayLike,
                       b_m: npt.ArrayLike, az_grid_deg: npt.ArrayLike,
                       n: int = ELLIPSE_POINTS) -> tuple[FloatArray, FloatArray]:
    """Outlines of m ellipses in grid metres: arrays X, Y of shape (m, n), x east, y north;
    each counter-clockwise from the major axis' end in direction ``az_grid_deg`` (not
    closed): centre + a·cos t·u + b·sin t·v, u = (sin Az, cos Az), v = (−cos Az, sin Az)
    (u turned 90° counter-clockwise)."""
    t = 2.0 * np.pi * np.arange(n) / n
    az = np.radians(np.asarray(az_grid_deg, dtype=np.float64))[:, None]
    ux, uy = np.sin(az), np.cos(az)
    ca = np.asarray(a_m, dtype=np.float64)[:, None] * np.cos(t)[None, :]
    sb = np.asarray(b_m, dtype=np.float64)[:, None] * np.sin(t)[None, :]
    x = np.asarray(x_m, dtype=np.float64)[:, None]
    y = np.asarray(y_m, dtype=np.float64)[:, None]
    return x + ca * ux - sb * uy, y + ca * uy + sb * ux


def ellipse_grid_ring(x_m: float, y_m: float, a_m: float, b_m: float, az_grid_deg: float,
                      n: int = ELLIPSE_POINTS) -> list[tuple[float, float]]:
    """One outline of :func:`ellipse_grid_rings` as ``n`` (x, y) points in grid metres."""
    xs, ys = ellipse_grid_rings([x_m], [y_m], [a_m], [b_m], [az_grid_deg], n)
    return list(zip(xs[0].tolist(), ys[0].tolist(), strict=True))


class Wgs84Converter:
    """Working-datum positions → WGS84 (module docstring). ``datums``: the run's datum file
    (None: only positions already on WGS84 can be converted). One transformer per datum and
    one grid per (datum, CM), built on first use."""

    def __init__(self, datums: DatumFile | None, datum_file: str | None = None) -> None:
        self._datums = datums
        self._file = datum_file
        self._shifts: dict[str, DatumShift | None] = {}
        self._grids: dict[tuple[str, float], TMGrid] = {}
        self._datum_of: dict[str, Datum] = {}

    def datum(self, name: str) -> Datum:
        """The datum called ``name`` (WGS84 needs no file); InputError if unknown."""
        d = self._datum_of.get(name)
        if d is not None:
            return d
        if self._datums is not None:
            try:
                d = self._datums.datum(name)
            except InputError as exc:
                raise InputError(exc.message, file=self._file, field="datum",
                                 text=name) from None
        elif name.replace(" ", "").upper() == "WGS84":
            d = WGS84
        else:
            raise InputError(f"Positions are on {name}, not WGS84: give the run's datum file "
                             "(--datum-file TO_WGS84.DAT) !", field="datum", text=name)
        self._datum_of[name] = d
        return d

    def _shift(self, name: str) -> DatumShift | None:
        if name not in self._shifts:
            d = self.datum(name)
            same = (d.ellipsoid.a_m == WGS84.ellipsoid.a_m
                    and d.ellipsoid.inv_f == WGS84.ellipsoid.inv_f and d.is_three_parameter
                    and d.dx_m == d.dy_m == d.dz_m == 0.0)
            self._shifts[name] = None if same else DatumShift(d, WGS84)
        return self._shifts[name]

    def to_wgs84(self, datum: str, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """(lat, lon) degrees on ``datum`` (height 0) → (lat, lon) degrees on WGS84."""
        shift = self._shift(datum)
        if shift is None:
            return lat_deg, lon_deg
        lat, lon, _h = shift.transform(lat_deg, lon_deg, 0.0)
        return lat, lon

    def _grid(self, ell: Ellipsoid, datum: str, cm: float) -> TMGrid:
        key = (datum, cm)
        g = self._grids.get(key)
        if g is None:
            g = self._grids[key] = TMGrid(ell, cm)
        return g

    def grid_of(self, datum: str, p: TrackPoint, cm_hint: float | None) -> TMGrid | None:
        """The TM grid (working datum, whole-degree CM) on which ``p``'s logged (x, y) are, or
        None when no candidate CM reproduces them to :data:`GRID_MATCH_M`."""
        if p.x_m is None or p.y_m is None:
            return None
        ell = self.datum(datum).ellipsoid
        base = central_meridian_deg(p.lon_deg)
        candidates: list[float] = [] if cm_hint is None else [cm_hint]
        candidates += [base, base - 1.0, base + 1.0]
        for cm in candidates:
            g = self._grid(ell, datum, cm)
            x, y = g.forward(p.lat_deg, p.lon_deg)
            if math.hypot(x - p.x_m, y - p.y_m) <= GRID_MATCH_M:
                return g
        return None

    def to_wgs84_array(self, datum: str, lat_deg: FloatArray,
                       lon_deg: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Vectorised :meth:`to_wgs84` (arrays of degrees, height 0 on ``datum``)."""
        shift = self._shift(datum)
        if shift is None:
            return lat_deg, lon_deg
        la, lo = shift.transform_array(lat_deg, lon_deg, np.zeros_like(lat_deg))
        return np.asarray(la, dtype=np.float64), np.asarray(lo, dtype=np.float64)

    def point(self, datum: str, p: TrackPoint, cm_hint: float | None, *,
              with_depth: bool = True, ring_points: int = ELLIPSE_POINTS) -> GeoPoint:
        """``p`` on WGS84 (:meth:`points` of one point)."""
        out = self.points([datum], [p], [cm_hint], with_depth=with_depth,
                          ring_points=ring_points)[0]
        assert out is not None
        return out

    def points(self, datum: Sequence[str], pts: Sequence[TrackPoint | None],
               cms: Sequence[float | None], *, with_depth: bool = True,
               ring_points: int = ELLIPSE_POINTS) -> list[GeoPoint | None]:
        """Each present point on WGS84 (None stays None), with its ellipse outline when it has
        an ellipse and its grid is known (``ring_points`` < 3: no outline). ``with_depth``
        False drops the depth (a 2-D fix logs depth 0). Vectorised per datum and grid."""
        idx = [i for i, p in enumerate(pts) if p is not None]
        present: dict[int, TrackPoint] = {i: pts[i] for i in idx}  # type: ignore[misc]
        grids = {i: self.grid_of(datum[i], present[i], cms[i]) for i in idx}
        centre: dict[int, tuple[float, float]] = {}
        for d in dict.fromkeys(datum[i] for i in idx):
            ii = [i for i in idx if datum[i] == d]
            la, lo = self.to_wgs84_array(
                d, np.array([present[i].lat_deg for i in ii]),
                np.array([present[i].lon_deg for i in ii]))
            centre.update(zip(ii, zip(la.tolist(), lo.tolist(), strict=True), strict=True))
        rings: dict[int, tuple[tuple[float, float], ...]] = {}
        if ring_points >= 3:
            groups: dict[tuple[str, float], list[int]] = {}
            for i in idx:
                if grids[i] is None or not present[i].has_ellipse:
                    continue
                groups.setdefault((datum[i], grids[i].cm_deg), []).append(i)  # type: ignore[union-attr]
            for (d, _cm), ii in groups.items():
                grid = grids[ii[0]]
                assert grid is not None
                q = [present[i] for i in ii]
                xs, ys = ellipse_grid_rings([p.x_m for p in q], [p.y_m for p in q],
                                            [p.a95_m for p in q], [p.b95_m for p in q],
                                            [p.az_grid_deg for p in q], ring_points)
                with np.errstate(all="ignore"):  # a damaged log: checked just below
                    la, lo = grid.inverse_array(xs.ravel(), ys.ravel())
                    la, lo = self.to_wgs84_array(d, la, lo)
                la, lo = la.reshape(xs.shape), lo.reshape(xs.shape)
                good = np.isfinite(la).all(axis=1) & np.isfinite(lo).all(axis=1)
                for k, i in enumerate(ii):
                    if not good[k]:
                        continue
                    ring = list(zip([_wrap_lon(x) for x in lo[k].tolist()], la[k].tolist(),
                                    strict=True))
                    ring.append(ring[0])
                    rings[i] = tuple(ring)
        out: list[GeoPoint | None] = [None] * len(pts)
        for i in idx:
            p, grid = present[i], grids[i]
            az_true = None
            if grid is not None and p.has_ellipse:
                assert p.az_grid_deg is not None
                az_true = (p.az_grid_deg + grid.convergence_deg(p.lat_deg, p.lon_deg)) % 360.0
            depth = p.depth_m if with_depth else None
            lat, lon = centre[i]
            lon = _wrap_lon(lon)
            out[i] = GeoPoint(lat, lon, None if depth is None else 0.0 - depth, depth, p.x_m,
                              p.y_m, None if grid is None else grid.cm_deg, p.a95_m, p.b95_m,
                              p.az_grid_deg, az_true, rings.get(i))
        return out


TRACKS = ("mpp", "lse", "gps", "smoothed")
"""Tracks an export can hold: the MPP (most probable position, the console's position), the
LSE (least-squares fix of the LOPs alone, not the hybrid with the filter's prediction), the
GPS input (``.OUT`` only) and the RTS-smoothed positions (``--smoothed``)."""
TRACK_TITLES = {
    "mpp": "MPP (most probable position)",
    "lse": "LSE (least-squares fix)",
    "gps": "GPS input",
    "smoothed": "Smoothed (RTS)",
}
_DEPTH_TRACKS = frozenset({"mpp", "smoothed"})
"""Tracks whose depth is an estimate (the LSE is a 2-D fix logged at depth 0, GPS has none)."""


@dataclass(frozen=True)
class ExportData:
    """What the writers need: the log's cycles and, per selected track in order, each cycle's
    point on WGS84 (None where the cycle has no such estimate)."""

    source: str
    epochs: tuple[ExportEpoch, ...]
    tracks: dict[str, list[GeoPoint | None]]
    datums: tuple[str, ...]


def build_export(log: ExportLog, tracks: Sequence[str], converter: Wgs84Converter,
                 smoothed: Sequence[TrackPoint | None] | None = None,
                 ring_points: int = ELLIPSE_POINTS) -> ExportData:
    """Convert the selected ``tracks`` of ``log`` to WGS84 (``smoothed``: the aligned smoothed
    points, required for the ``smoothed`` track; on the run's final CM, found per point)."""
    epochs = log.epochs
    datums = [e.datum for e in epochs]
    out: dict[str, list[GeoPoint | None]] = {}
    for name in tracks:
        if name == "smoothed":
            if smoothed is None:
                raise InputError("The smoothed track needs --smoothed FILE !", field="--tracks",
                                 text=name)
            # Session.iter_smoothed: on the grid and working datum of the run's end
            pts: Sequence[TrackPoint | None] = smoothed
            cms: list[float | None] = [epochs[-1].cm_deg] * len(epochs)
            track_datums = [epochs[-1].datum] * len(epochs)
        elif name in ("mpp", "lse", "gps"):
            pts = [getattr(e, name) for e in epochs]
            cms = [e.cm_deg for e in epochs]
            track_datums = datums
        else:
            raise InputError(f"Unknown track (one of {', '.join(TRACKS)}) !", field="--tracks",
                             text=name)
        try:
            out[name] = converter.points(track_datums, pts, cms,
                                         with_depth=name in _DEPTH_TRACKS, ring_points=ring_points)
        except InputError as exc:
            if exc.field != "datum":
                raise
            # The datum name comes from the log (a damaged or foreign log): name the log.
            raise InputError(exc.message, file=log.path, field="datum", text=exc.text) from None
    return ExportData(log.path, epochs, out, tuple(dict.fromkeys(datums)))
