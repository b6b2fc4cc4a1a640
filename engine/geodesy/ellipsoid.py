"""Reference ellipsoids and geodetic datums as read from ``TO_WGS84.DAT``."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Ellipsoid:
    """A reference ellipsoid: semi-major axis ``a_m`` (metres) and inverse flattening ``inv_f``."""

    name: str
    a_m: float
    inv_f: float

    @property
    def f(self) -> float:
        """Flattening (dimensionless); 0 for a sphere (``inv_f`` = 0 or inf)."""
        return 0.0 if self.inv_f == 0 or math.isinf(self.inv_f) else 1.0 / self.inv_f

    @property
    def e2(self) -> float:
        """First eccentricity squared, e² = f(2 − f)."""
        f = self.f
        return f * (2.0 - f)

    @property
    def b_m(self) -> float:
        """Semi-minor axis (metres)."""
        return self.a_m * (1.0 - self.f)


@dataclass(frozen=True, slots=True)
class Datum:
    """A geodetic datum and its transformation to WGS84 (thesis A8.4, THEORY §13.1, D1).

    X_WGS84 = X_datum + (dx, dy, dz) [m], extended to a 7-parameter Bursa–Wolf (position-vector
    convention) with rotations ``rx/ry/rz`` in arc-seconds and ``scale_ppm`` in parts per million.
    """

    name: str
    ellipsoid: Ellipsoid
    dx_m: float = 0.0
    dy_m: float = 0.0
    dz_m: float = 0.0
    rx_arcsec: float = 0.0
    ry_arcsec: float = 0.0
    rz_arcsec: float = 0.0
    scale_ppm: float = 0.0

    @property
    def is_three_parameter(self) -> bool:
        """True when rotations and scale are all zero (a pure geocentric shift)."""
        return self.rx_arcsec == self.ry_arcsec == self.rz_arcsec == self.scale_ppm == 0.0


A_RANGE_M = (6_376_000.0, 6_379_000.0)
"""Semi-major axes of Earth reference ellipsoids in use (m): Everest 1830 6 377 276.345 to
International 1924 6 378 388 lie inside (docs/DATAFILES.md)."""
INV_F_RANGE = (290.0, 310.0)
"""Inverse flattenings of Earth reference ellipsoids in use: Clarke 1880 293.465 to Everest
300.8017 lie inside (docs/DATAFILES.md)."""
SHIFT_MAX_M = 1000.0
"""Largest |dX|, |dY|, |dZ| of a datum → WGS84 shift accepted (m)."""
ROTATION_MAX_ARCSEC = 30.0
"""Largest |Rx|, |Ry|, |Rz| accepted (arc-seconds; 30″ moves a surface point ≈ 930 m)."""
SCALE_MAX_PPM = 50.0
"""Largest |scale| accepted (ppm; 50 ppm ≈ 320 m at the Earth's surface)."""

WGS84_ELLIPSOID = Ellipsoid("WGS84", 6378137.0, 298.257223563)
WGS84 = Datum("WGS84", WGS84_ELLIPSOID)
