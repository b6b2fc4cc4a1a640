"""The geodesy of a run on the compiled kernels: TM grid, datum shift, geodesic azimuths.

* :class:`FastTMGrid` is :class:`engine.geodesy.tmgrid.TMGrid` (the reference) whose forward,
  inverse and convergence call ``engine.native.tmgrid`` on a packed copy of the grid's
  constants (``_packed``, :func:`engine.native.tmgrid.pack`). Where the kernel declines (a
  central meridian that is no float, a non-float argument, a math error) the reference runs.
* :class:`FastDatumShift` is :class:`engine.geodesy.ellipsoidal.DatumShift` whose point call
  is ``engine.native.datum.Shift`` (the reference's geocentric shift, compiled), where it
  agrees with the reference on :data:`SHIFT_PROBES` within the tolerance contract.
* :class:`FastGeodesicSolver` is :class:`engine.geodesy.ellipsoidal.GeodesicSolver` whose
  per-epoch azimuths are ``engine.native.decca``'s own ``Geodesic`` (Vincenty's inverse with
  Karney's integrals; pyproj's public ``Geod.inv`` for the lines it does not take), where it
  agrees with the reference's (pyproj's ``Geod.inv``) on :data:`GEOD_PROBES` within the
  tolerance contract.

The tolerance contract (docs/PERFORMANCE.md): 1e-9 relative, or 1e-9° and 1e-6 m absolute.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from engine import native
from engine.geodesy.ellipsoid import Datum, Ellipsoid
from engine.geodesy.ellipsoidal import DatumShift, GeodesicSolver, _is_identity
from engine.geodesy.tmgrid import TMGrid

KERNEL: Any = native.kernel("tmgrid")
"""``engine.native.tmgrid``, or None (not built, stale, ``UVNAV_PURE=1``)."""


class FastTMGrid(TMGrid):
    """:class:`TMGrid` on the compiled kernel (the constants packed once per grid)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "_packed", self._pack())

    def _pack(self) -> bytearray | None:
        """The kernel's state (the constants and an empty memo of inverses), or None. Each
        constant is the float the reference computes: ``self._e**2``, the pole scale, ``A/a``,
        the factors of :func:`math.radians`/:func:`math.degrees`. A central meridian that is
        not a float or an int gets None (the reference runs)."""
        if KERNEL is None or not isinstance(self.cm_deg, (float, int)):
            return None
        try:
            cm = float(self.cm_deg)
        except OverflowError:  # an int beyond floats: the reference raises where it is used
            return None
        e, e2m = self._e, self._e2m
        k_pole = e2m**0.5 * math.exp(e * math.atanh(e))
        return KERNEL.pack((cm, e, e2m, self._A, self._A / self.ellipsoid.a_m,  # type: ignore[no-any-return]
                            e**2, k_pole, math.radians(1.0), math.degrees(1.0),
                            *self._alpha, *self._beta))

    def forward_full(self, lat_deg: float, lon_deg: float) -> tuple[float, float, float, float]:
        out = KERNEL.forward_full(self._packed, lat_deg, lon_deg)
        return super().forward_full(lat_deg, lon_deg) if out is None else out  # type: ignore[no-any-return]

    def forward(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        out = KERNEL.forward(self._packed, lat_deg, lon_deg)
        return super().forward(lat_deg, lon_deg) if out is None else out  # type: ignore[no-any-return]

    def inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        """The kernel keeps its own memo (a ring in ``_packed``, the reference's rule)."""
        out = KERNEL.inverse(self._packed, x_m, y_m)
        return super().inverse(x_m, y_m) if out is None else out  # type: ignore[no-any-return]

    def _inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        out = KERNEL.inverse(self._packed, x_m, y_m, False)
        return super()._inverse(x_m, y_m) if out is None else out  # type: ignore[no-any-return]

    def convergence_deg(self, lat_deg: float, lon_deg: float) -> float:
        out = KERNEL.forward_full(self._packed, lat_deg, lon_deg)
        return super().convergence_deg(lat_deg, lon_deg) if out is None else out[2]  # type: ignore[no-any-return]


# --------------------------------------------------------------------------- datum shift
DATUM: Any = native.kernel("datum")
"""``engine.native.datum``, or None."""

SHIFT_PROBES: tuple[tuple[float, float, float], ...] = (
    (52.0, 3.0, 0.0), (57.7, -1.25, -45.5), (-33.9, 151.2, 100.0), (0.0, 0.0, 0.0),
    (89.99999, -179.9, -5000.0), (-90.0, 0.0, 0.0), (0.0, 180.0, 10000.0),
    (-45.0, -180.0, -10000.0), (10.0, -45.0, 1e-9),
)
"""(lat, lon degrees, h m) on which the compiled datum shift must agree with the reference
before it replaces it: near the chart's area, poles, ±180°, heights ±10 km."""


def _ell(e: Ellipsoid) -> tuple[float, float]:
    """(a m, 1/f; 0.0 for a sphere): the kernel's ellipsoid arguments."""
    return float(e.a_m), 0.0 if e.f == 0.0 else float(e.inv_f)


def _helmert(d: Datum) -> tuple[float, ...] | None:
    """The datum's seven Bursa–Wolf numbers, or None (all zero: the step is left out)."""
    if _is_identity(d):
        return None
    return (float(d.dx_m), float(d.dy_m), float(d.dz_m), float(d.rx_arcsec),
            float(d.ry_arcsec), float(d.rz_arcsec), float(d.scale_ppm))


def compiled_point(reference: DatumShift) -> Any:
    """``engine.native.datum.Shift`` of ``reference``'s datums (it hands what it does not cover
    to ``reference.transform``) where the kernel is built and agrees with the reference on
    :data:`SHIFT_PROBES` (1e-9 relative, or 1e-9° and 1e-6 m); else ``reference.transform``."""
    k, src, dst = DATUM, reference.src, reference.dst
    if k is None:
        return reference.transform
    try:
        shift = k.Shift(reference.transform, *_ell(src.ellipsoid), _helmert(src),
                        *_ell(dst.ellipsoid), _helmert(dst))
    except (TypeError, ValueError):
        return reference.transform
    for q in SHIFT_PROBES:  # the tolerance contract (docs/PERFORMANCE.md)
        got = shift.forward(*q)
        if got is None:  # declined there: the reference answers that point
            continue
        want = reference.transform(*q)
        if any(not abs(g - w) <= max(1e-9 * abs(w), floor)
               for g, w, floor in zip(got, want, (1e-9, 1e-9, 1e-6), strict=True)):
            return reference.transform
    return shift


class FastDatumShift(DatumShift):
    """:class:`DatumShift` whose point call is the compiled geocentric shift
    (:func:`compiled_point`); everything else is the reference's."""

    __slots__ = ("point",)

    def __init__(self, src: Datum, dst: Datum) -> None:
        super().__init__(src, dst)
        self.point: Any = compiled_point(DatumShift(src, dst))
        """``(lat deg, lon deg, h m) → (lat, lon, h)`` on the destination: the kernel, or the
        reference's :meth:`DatumShift.transform`."""

    def transform(
        self, lat_deg: float, lon_deg: float, h_m: float = 0.0
    ) -> tuple[float, float, float]:
        return self.point(lat_deg, lon_deg, h_m)  # type: ignore[no-any-return]


def fast_datum_shift(src: Datum, dst: Datum) -> DatumShift:
    """:func:`engine.geodesy.ellipsoidal.datum_shift` with the compiled point call."""
    return FastDatumShift(src, dst)


# --------------------------------------------------------------------------- geodesics
DECCA: Any = native.kernel("decca")
"""``engine.native.decca`` (its ``Geodesic``: the kernel's own geodesic inverse), or None."""

_UNSET: Any = object()
"""A :class:`FastGeodesicSolver`'s compiled geodesic before it is resolved (first use)."""

GEOD_PROBES: tuple[tuple[float, float, float, float], ...] = (
    (3.1, 53.2, 4.9, 52.4), (-1.25, 57.7, 2.0, 58.9), (5.0, 0.0, 5.0, 0.0),
    (0.0, 0.0, 179.5, 0.5), (-179.9, 89.9, 179.9, -89.9), (10.0, -45.0, -170.0, 45.0),
    (0.0, 90.0, 33.0, 10.0), (1e-9, 52.0, -1e-9, 52.0), (120.0, -33.8, 151.2, -33.9),
)
"""(lon1, lat1, lon2, lat2) degrees on which the compiled geodesic must agree with the
reference's: near and far lines, a zero-length line, near-antipodal and polar ones."""


GEOD_VERIFIED: dict[tuple[float, float], tuple[tuple[float, float, float], ...]] = {
    # WGS84
    (6378137.0, 0.0033528106647474805): (
        (125.53319725030951, -53.03297069077158, 150540.59254372408),
        (53.58066053545707, -123.65384650385022, 232730.84638031755),
        (180.0, 0.0, 0.0),
        (25.67187286829188, -25.672914530058392, 19936288.578965314),
        (-179.89999892617044, 0.10000107382956003, 19981592.6969672),
        (-180.0, 180.0, 20003931.458625447),
        (147.0, 0.0, 8896110.896078352),
        (-89.999999999212, 89.999999999212, 0.0001373560321585971),
        (99.05530700973107, -98.62608036309709, 2876195.2288347227),
    ),
    # International 1924 (Hayford 1909)
    (6378388.0, 0.003367003367003367): (
        (125.5329116104044, -53.03325632998212, 150547.32312447956),
        (53.580873311027275, -123.65363372586397, 232741.79296442436),
        (180.0, 0.0, 0.0),
        (25.617491241179774, -25.618530342349572, 19936959.069935113),
        (-179.89999892225964, 0.10000107774035882, 19982236.639089204),
        (-180.0, 180.0, 20004576.59797889),
        (147.0, 0.0, 8896420.969898032),
        (-89.999999999212, 89.999999999212, 0.00013736264912275523),
        (99.05530569180989, -98.6260876414219, 2876321.0607580077),
    ),
}
"""The reference's (forward azimuth, back azimuth, distance m) on :data:`GEOD_PROBES` for the
ellipsoids of the bundled runs, (a m, f) → one row per probe: Karney's geodesic through
pyproj's public ``Geod.inv``, recorded so that a compiled run's first-use check needs no pyproj
(its import is ~50 ms of start-up); tests/native/test_decca.py checks that the reference still
gives these numbers. Any other ellipsoid is checked against the reference itself."""


def _same_azimuth(got: float, want: float) -> bool:
    """Two azimuths (degrees) within the tolerance contract (1e-9 relative or 1e-9°), angles
    that differ by a multiple of 360° being one direction."""
    d = abs(got - want) % 360.0
    return min(d, 360.0 - d) <= max(1e-9 * abs(want), 1e-9)


def _agrees(got: tuple[float, float, float], want: tuple[float, float, float]) -> bool:
    """The kernel's ``own_point`` (forward azimuths at 1 and at 2, degrees; distance m) against
    the reference's :meth:`GeodesicSolver.inverse` (forward azimuth, back azimuth at 2,
    distance) within the tolerance contract (1e-9 relative, or 1e-9° and 1e-6 m)."""
    return (_same_azimuth(got[0], want[0]) and _same_azimuth(got[1], want[1] + 180.0)
            and abs(got[2] - want[2]) <= max(1e-9 * abs(want[2]), 1e-6))


class FastGeodesicSolver(GeodesicSolver):
    """:class:`GeodesicSolver` whose per-epoch azimuths are the compiled geodesic's
    (:meth:`native`)."""

    __slots__ = ("_native",)

    def __init__(self, ell: Ellipsoid) -> None:
        super().__init__(ell)
        self._native: Any = _UNSET

    def native(self) -> Any:
        """The compiled geodesic (``engine.native.decca.Geodesic`` of the ellipsoid's a and f:
        Vincenty's inverse, pyproj's where that is not used), or None where the kernel is not
        available or its forward azimuths on :data:`GEOD_PROBES` differ from the reference's
        (:meth:`GeodesicSolver.inverse`) by more than the tolerance contract (1e-9 relative or
        1e-9°). Resolved on first use."""
        g = self._native
        if g is _UNSET:
            g = None
            k = DECCA
            if k is not None:
                a, f = float(self.ellipsoid.a_m), float(self.ellipsoid.f)
                cand = k.Geodesic(a, f)
                want = GEOD_VERIFIED.get((a, f))
                if want is None:
                    reference = GeodesicSolver(self.ellipsoid)
                    want = tuple(reference.inverse(q[1], q[0], q[3], q[2]) for q in GEOD_PROBES)
                own = [cand.own_point(*q) for q in GEOD_PROBES]  # None: pyproj's line
                if all(_agrees(got, w) for got, w in zip(own, want, strict=True)
                       if got is not None):
                    g = cand
            self._native = g
        return g

    def forward_azimuths_deg(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        g = self._native
        if g is _UNSET:
            g = self.native()
        if g is not None:
            return g.forward_azimuths_deg(lat1_deg, lon1_deg, points)  # type: ignore[no-any-return]
        return super().forward_azimuths_deg(lat1_deg, lon1_deg, points)

    def forward_azimuths_rad(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        g = self._native
        if g is _UNSET:
            g = self.native()
        if g is not None:
            return g.forward_azimuths_rad(lat1_deg, lon1_deg, points)  # type: ignore[no-any-return]
        return super().forward_azimuths_rad(lat1_deg, lon1_deg, points)
