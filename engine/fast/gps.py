"""GPS on the compiled kernels: the record's position in one call, the fix's two rows in one.

:class:`FastGpsSystem` is :class:`engine.systems.gps.GpsSystem` whose GPS input (datum shifts,
WGS84 ECEF, grid position and record) is ``gps_input`` of ``engine.native.tmgrid`` on the
grid's packed constants (:class:`engine.fast.geodesy.FastTMGrid`), and whose observations'
rows are ``gps_rows`` of ``engine.native.decca``. Where a kernel declines, the reference runs.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from engine import native
from engine.fast.decca import maker
from engine.systems import gps as ref
from engine.systems.base import CycleInputs, LopReading, Point
from engine.systems.gps import (
    ROW_LAT,
    ROW_LON,
    GpsFix,
    GpsInput,
    GpsSystem,
    _GpsObservations,
    gps_weight,
)

TMGRID: Any = native.kernel("tmgrid")
"""``engine.native.tmgrid`` (its ``gps_input``), or None."""
DECCA: Any = native.kernel("decca")
"""``engine.native.decca`` (its ``gps_rows``), or None."""

_new_input = maker(GpsInput)
_new_lop = maker(LopReading)


class _ShiftArgs:
    """What the kernel's gps_input needs of the run's datum shifts (None: no shift), for the
    last pair seen (a run has one): each one's point call, ``(lat, lon, h) → (lat, lon, h)``
    (a :class:`FastDatumShift`'s compiled ``point``, else the shift's ``transform``)."""

    __slots__ = ("s_point", "shift", "to_wgs", "w_point")

    def __init__(self, shift: Any, to_wgs: Any) -> None:
        self.shift, self.to_wgs = shift, to_wgs
        self.s_point = None if shift is None else getattr(shift, "point", shift.transform)
        self.w_point = None if to_wgs is None else getattr(to_wgs, "point", to_wgs.transform)


class FastGpsObservations(_GpsObservations):
    """:class:`_GpsObservations` whose rows are written by one compiled call."""

    __slots__ = ("_north_east",)

    def __init__(self, gps: GpsFix) -> None:
        super().__init__(gps)
        self._north_east = (gps.y_m + gps.corr_north_m, gps.x_m + gps.corr_east_m)
        """The corrected grid position (northing, easting; m), the minuends of O − C."""

    def linearise(self, p: Point, slot0: int, A: list[float], b: list[float],
                  Cl: np.ndarray) -> None:
        north, east = self._north_east
        if DECCA.gps_rows(A, b, Cl, slot0, north, east, p.x, p.y, self.gps.var_m2) is None:
            return
        super().linearise(p, slot0, A, b, Cl)

    def readings(self, p: Point) -> list[LopReading]:
        """The reference's "Lat"/"Lon" page rows, each made in one compiled call."""
        g = self.gps
        lat_hat, lon_hat = p.latlon
        return [_new_lop(ROW_LAT, "GPS", "Lat", g.lat_deg, g.corr_north_m, lat_hat, 90.0),
                _new_lop(ROW_LON, "GPS", "Lon", g.lon_deg, g.corr_east_m, lon_hat, 180.0)]


class FastGpsSystem(GpsSystem):
    """:class:`GpsSystem` on the compiled kernels."""

    def __init__(self) -> None:
        self._shifts: _ShiftArgs | None = None
        if DECCA is not None and hasattr(DECCA, "gps_rows"):
            self.observations_class = FastGpsObservations

    def gps_input(self, inputs: CycleInputs) -> GpsInput | None:
        """:func:`engine.systems.gps.gps_input` in one compiled call (``gps_input``)."""
        ctx, rec = inputs.context, inputs.record
        packed = getattr(inputs.grid, "_packed", None)
        if (TMGRID is None or packed is None or not inputs.config.gps.on
                or rec.gps_lat_deg is None or rec.gps_lon_deg is None):
            return super().gps_input(inputs)
        sa = self._shifts
        if sa is None or sa.shift is not ctx.gps_shift or sa.to_wgs is not ctx.gps_to_wgs84:
            sa = self._shifts = _ShiftArgs(ctx.gps_shift, ctx.gps_to_wgs84)
        out = TMGRID.gps_input(packed, sa.s_point, sa.w_point, rec.gps_lat_deg,
                               rec.gps_lon_deg, ref._WGS84_A, ref._WGS84_E2, _new_input,
                               gps_weight(inputs.config, rec))
        return super().gps_input(inputs) if out is None else out  # type: ignore[no-any-return]


FAST_GPS = FastGpsSystem()
"""The GPS system of a run on the compiled path."""
