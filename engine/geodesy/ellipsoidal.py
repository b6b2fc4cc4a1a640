"""Ellipsoidal geodesy for the LSQ engine and the filter (THEORY §2, thesis A5, A8.4).

* geodetic ↔ ECEF (Earth-centred, Earth-fixed, metres) on any :class:`Ellipsoid`;
* datum transformations through WGS84 ECEF (Bursa–Wolf, position-vector convention,
  X_WGS84 = X_datum + (dX, dY, dZ) + rotations/scale, thesis A8.4, THEORY §2.2 and D1), written
  out from the :class:`Datum` parameters; :func:`helmert_pipeline` states the same
  transformation as a PROJ pipeline, which the tests run in pyproj to check it;
* the GPS convention of THEORY §2.1–2.2 (WGS84 fix converted with h_WGS84 = 0);
* geodesic inverse (pyproj/Karney), first-order Andoyer–Lambert distance (THEORY §2.5);
* line scale factor and spheroidal distance from grid coordinates (A5.10, A5.13, THEORY §2.4).

Angles are degrees unless a name says otherwise; lengths are metres. pyproj is imported only by
the geodesic calls that need it (:class:`GeodesicSolver`), on first use.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from engine.geodesy.ellipsoid import WGS84, WGS84_ELLIPSOID, Datum, Ellipsoid

__all__ = [
    "DatumShift",
    "GeodesicSolver",
    "andoyer_lambert_m",
    "bursa_wolf_from_wgs84",
    "bursa_wolf_to_wgs84",
    "datum_shift",
    "ecef_to_geodetic",
    "geodesic_inverse",
    "geocentric_datum_shift",
    "geodetic_to_ecef",
    "helmert_pipeline",
    "line_scale_factor",
    "mean_radius_sq",
    "spheroidal_distance",
    "wgs84_fix_ecef",
    "wgs84_fix_to_datum",
]

_ARCSEC = math.pi / (180.0 * 3600.0)


# --------------------------------------------------------------------------- ECEF
def geodetic_to_ecef(
    lat_deg: float, lon_deg: float, h_m: float, ell: Ellipsoid
) -> tuple[float, float, float]:
    """Geodetic (degrees, ellipsoidal height m) on ``ell`` → ECEF (X, Y, Z) in metres."""
    phi = math.radians(lat_deg)
    lam = math.radians(lon_deg)
    sphi = math.sin(phi)
    cphi = math.cos(phi)
    e2 = ell.e2
    nu = ell.a_m / math.sqrt(1.0 - e2 * sphi * sphi)
    r = (nu + h_m) * cphi
    return r * math.cos(lam), r * math.sin(lam), (nu * (1.0 - e2) + h_m) * sphi


def ecef_to_geodetic(
    x_m: float, y_m: float, z_m: float, ell: Ellipsoid
) -> tuple[float, float, float]:
    """ECEF (metres) → geodetic (lat, lon degrees, ellipsoidal height m) on ``ell``.

    Bowring's formula iterated on the parametric latitude until it changes by < 1e-14 rad
    (≈ 0.1 nm); one or two iterations suffice near the Earth's surface.
    """
    a = ell.a_m
    f = ell.f
    b = a * (1.0 - f)
    e2 = ell.e2
    ep2 = e2 / (1.0 - e2)
    p = math.hypot(x_m, y_m)
    lon = math.degrees(math.atan2(y_m, x_m))
    if p == 0.0:
        return math.copysign(90.0, z_m), lon, abs(z_m) - b
    beta = math.atan2(z_m, (1.0 - f) * p)
    phi = beta
    for _ in range(8):
        sb = math.sin(beta)
        cb = math.cos(beta)
        phi = math.atan2(z_m + ep2 * b * sb * sb * sb, p - e2 * a * cb * cb * cb)
        beta_new = math.atan2((1.0 - f) * math.sin(phi), math.cos(phi))
        done = abs(beta_new - beta) < 1e-14
        beta = beta_new
        if done:
            break
    sphi = math.sin(phi)
    h = p * math.cos(phi) + z_m * sphi - a * math.sqrt(1.0 - e2 * sphi * sphi)
    return math.degrees(phi), lon, h


# --------------------------------------------------------------------------- datums
def _is_identity(d: Datum) -> bool:
    return (
        d.dx_m == d.dy_m == d.dz_m == 0.0
        and d.rx_arcsec == d.ry_arcsec == d.rz_arcsec == d.scale_ppm == 0.0
    )


def _ell_args(ell: Ellipsoid) -> str:
    a = float(ell.a_m)
    if ell.f == 0.0:
        return f"+a={a!r} +b={a!r}"
    return f"+a={a!r} +rf={float(ell.inv_f)!r}"


def _helmert_args(d: Datum) -> str:
    return (
        f"+proj=helmert +x={float(d.dx_m)!r} +y={float(d.dy_m)!r} +z={float(d.dz_m)!r}"
        f" +rx={float(d.rx_arcsec)!r} +ry={float(d.ry_arcsec)!r} +rz={float(d.rz_arcsec)!r}"
        f" +s={float(d.scale_ppm)!r} +convention=position_vector"
    )


def helmert_pipeline(src: Datum, dst: Datum) -> str:
    """:class:`DatumShift`'s transformation as a PROJ pipeline: geodetic (lat, lon deg, h m) on
    ``src`` → the same on ``dst``, for pyproj's public ``Transformer.from_pipeline`` (the tests
    check the engine's own formulas against it; the engine never runs it).

    Steps: axis swap and degrees→radians; ``cart`` on the source ellipsoid (→ ECEF); the source's
    Bursa–Wolf to WGS84 (position-vector convention, so a positive rz increases longitude);
    the destination's Bursa–Wolf inverted (WGS84 → dst); inverse ``cart`` on the destination
    ellipsoid; back to degrees, (lat, lon) order. All-zero Helmert steps (WGS84 itself) are
    omitted. Built only from the :class:`Datum` numbers, never from an EPSG code.
    """
    steps = [
        "+proj=pipeline",
        "+step +proj=axisswap +order=2,1",
        "+step +proj=unitconvert +xy_in=deg +xy_out=rad",
        f"+step +proj=cart {_ell_args(src.ellipsoid)}",
    ]
    if not _is_identity(src):
        steps.append(f"+step {_helmert_args(src)}")
    if not _is_identity(dst):
        steps.append(f"+step +inv {_helmert_args(dst)}")
    steps += [
        f"+step +inv +proj=cart {_ell_args(dst.ellipsoid)}",
        "+step +proj=unitconvert +xy_in=rad +xy_out=deg",
        "+step +proj=axisswap +order=2,1",
    ]
    return " ".join(steps)


class DatumShift:
    """Geodetic transformation ``src`` → ``dst`` through WGS84 geocentric coordinates.

    The transformation of thesis §5.3 and A8.4 (``TO_WGS84.DAT``: dX, dY, dZ, the corrections
    to a datum's Cartesian coordinates that give WGS84's), written out as docs/THEORY.md §2.1–2.2
    and D1 state it: geodetic on ``src`` → ECEF on its ellipsoid (:func:`geodetic_to_ecef`) →
    the source's Bursa–Wolf to WGS84 (:func:`bursa_wolf_to_wgs84`; the 3-parameter translation
    where rotations and scale are zero) → the destination's reversed
    (:func:`bursa_wolf_from_wgs84`) → geodetic on the destination ellipsoid
    (:func:`ecef_to_geodetic`). Steps whose seven parameters are all zero (WGS84) are left out.
    Latitude and longitude in degrees, ellipsoidal height in metres. Pure Python: no PROJ call;
    tests/geodesy/test_geodesy.py checks it against pyproj's public ``Transformer`` running
    :func:`helmert_pipeline` (within 1e-9° and 1e-5 m; measured ≤ 1e-11° and ≤ 2e-6 m).
    """

    __slots__ = ("src", "dst")

    def __init__(self, src: Datum, dst: Datum) -> None:
        self.src = src
        self.dst = dst

    def __reduce__(self) -> tuple[Any, tuple[Datum, Datum]]:
        return type(self), (self.src, self.dst)

    def transform(
        self, lat_deg: float, lon_deg: float, h_m: float = 0.0
    ) -> tuple[float, float, float]:
        """Geodetic on ``src`` → geodetic on ``dst`` (degrees, degrees, metres)."""
        return geocentric_datum_shift(lat_deg, lon_deg, h_m, self.src, self.dst)

    def transform_array(self, lat_deg: Any, lon_deg: Any, h_m: Any = 0.0) -> tuple[Any, Any]:
        """:meth:`transform` of each point of numpy arrays (degrees, metres; broadcast) →
        (lat, lon) arrays in degrees on ``dst`` (the heights are dropped)."""
        import numpy as np

        lat_a, lon_a, h_a = np.broadcast_arrays(np.asarray(lat_deg, dtype=float),
                                                np.asarray(lon_deg, dtype=float),
                                                np.asarray(h_m, dtype=float))
        out = np.array([self.transform(float(a), float(b), float(c))[:2]
                        for a, b, c in zip(lat_a.ravel(), lon_a.ravel(), h_a.ravel(),
                                           strict=True)], dtype=float).reshape(-1, 2)
        return out[:, 0].reshape(lat_a.shape), out[:, 1].reshape(lat_a.shape)

    def inverse(
        self, lat_deg: float, lon_deg: float, h_m: float = 0.0
    ) -> tuple[float, float, float]:
        """Geodetic on ``dst`` → geodetic on ``src`` (degrees, degrees, metres): the steps
        of :meth:`transform` reversed."""
        return geocentric_datum_shift(lat_deg, lon_deg, h_m, self.dst, self.src)

    def __repr__(self) -> str:
        return f"DatumShift({self.src.name!r} -> {self.dst.name!r})"


def datum_shift(src: Datum, dst: Datum) -> DatumShift:
    """Factory: a :class:`DatumShift` from ``src`` to ``dst``."""
    return DatumShift(src, dst)


def bursa_wolf_to_wgs84(
    x_m: float, y_m: float, z_m: float, datum: Datum
) -> tuple[float, float, float]:
    """ECEF on ``datum`` → ECEF on WGS84 (metres), small-angle Bursa–Wolf, position vector.

    X' = T + (1 + s)·R·X with R = [[1, −rz, ry], [rz, 1, −rx], [−ry, rx, 1]] (A8.4, A2);
    with zero rotations/scale this is the verified 3-parameter shift X_WGS84 = X + (dX, dY, dZ).
    """
    rx = datum.rx_arcsec * _ARCSEC
    ry = datum.ry_arcsec * _ARCSEC
    rz = datum.rz_arcsec * _ARCSEC
    m = 1.0 + datum.scale_ppm * 1e-6
    return (
        datum.dx_m + m * (x_m - rz * y_m + ry * z_m),
        datum.dy_m + m * (rz * x_m + y_m - rx * z_m),
        datum.dz_m + m * (-ry * x_m + rx * y_m + z_m),
    )


def bursa_wolf_from_wgs84(
    x_m: float, y_m: float, z_m: float, datum: Datum
) -> tuple[float, float, float]:
    """ECEF on WGS84 → ECEF on ``datum`` (metres): X = Rᵀ(X' − T)/(1 + s).

    Uses the transpose of the small-angle R as PROJ's ``+inv +proj=helmert`` does (the
    residual of that approximation is ~(rotation)²·R_earth < 0.1 mm for DMA WGS72).
    """
    rx = datum.rx_arcsec * _ARCSEC
    ry = datum.ry_arcsec * _ARCSEC
    rz = datum.rz_arcsec * _ARCSEC
    m = 1.0 + datum.scale_ppm * 1e-6
    u = x_m - datum.dx_m
    v = y_m - datum.dy_m
    w = z_m - datum.dz_m
    return (
        (u + rz * v - ry * w) / m,
        (-rz * u + v + rx * w) / m,
        (ry * u - rx * v + w) / m,
    )


def geocentric_datum_shift(
    lat_deg: float, lon_deg: float, h_m: float, src: Datum, dst: Datum
) -> tuple[float, float, float]:
    """Rigorous geocentric shift ``src`` → ``dst`` (degrees, degrees, metres): geodetic → ECEF
    (src ellipsoid) → Bursa–Wolf to WGS84 → reversed to dst → geodetic (dst ellipsoid). The
    verified GPS path of THEORY §2.1–2.2 (Pg 611 to the millimetre); :class:`DatumShift`."""
    x, y, z = geodetic_to_ecef(lat_deg, lon_deg, h_m, src.ellipsoid)
    if not _is_identity(src):
        x, y, z = bursa_wolf_to_wgs84(x, y, z, src)
    if not _is_identity(dst):
        x, y, z = bursa_wolf_from_wgs84(x, y, z, dst)
    return ecef_to_geodetic(x, y, z, dst.ellipsoid)


def wgs84_fix_to_datum(
    lat_deg: float, lon_deg: float, datum: Datum, shift: DatumShift | None = None
) -> tuple[float, float, float]:
    """GPS WGS84 fix (degrees) → (lat deg, lon deg, h_datum m) on ``datum`` (THEORY §2.1–2.2).

    The horizontal transformation uses h_WGS84 = 0 (thesis GPS convention, verified on Pg 611).
    The WGS84 height the program displays is Hg = −h_datum (the WGS84 height of the point at
    height 0 on the datum). ``shift`` (WGS84 → datum, e.g. the compiled path's) computes it
    where given; else :func:`geocentric_datum_shift`.
    """
    if shift is not None:
        if shift.src != WGS84 or shift.dst != datum:
            raise ValueError(f"{shift!r} is not WGS84 -> {datum.name}")
        return shift.transform(lat_deg, lon_deg, 0.0)
    return geocentric_datum_shift(lat_deg, lon_deg, 0.0, WGS84, datum)


def wgs84_fix_ecef(lat_deg: float, lon_deg: float, h_datum_m: float) -> tuple[float, float, float]:
    """WGS84 ECEF (metres) of the GPS fix as on Pg 100: of (φ, λ, h = −h_datum) on WGS84."""
    return geodetic_to_ecef(lat_deg, lon_deg, -h_datum_m, WGS84_ELLIPSOID)


# --------------------------------------------------------------------------- geodesics
class GeodesicSolver:
    """Exact geodesic problems on one ellipsoid: Karney's algorithm through pyproj's public
    ``Geod(a=, f=).inv`` (THEORY §2.5).

    Build once per ellipsoid; pyproj's ``Geod`` is made (and pyproj imported) on first use.
    """

    __slots__ = ("ellipsoid", "_geod_obj")

    def __init__(self, ell: Ellipsoid) -> None:
        self.ellipsoid = ell
        self._geod_obj: Any = None

    @property
    def _geod(self) -> Any:
        """pyproj's ``Geod(a, f)`` of the ellipsoid (made on first use)."""
        geod = self._geod_obj
        if geod is None:
            from pyproj import Geod

            geod = self._geod_obj = Geod(a=self.ellipsoid.a_m, f=self.ellipsoid.f)
        return geod

    def __reduce__(self) -> tuple[Any, tuple[Ellipsoid]]:
        """Pickled (and copied) as its ellipsoid: a copy builds its own Geod."""
        return type(self), (self.ellipsoid,)

    def inverse(
        self, lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float
    ) -> tuple[float, float, float]:
        """(forward azimuth at 1 → 2, back azimuth at 2 → 1, distance m); azimuths in degrees
        clockwise from true north in (−180, 180]."""
        az12, az21, dist = self._geod.inv(lon1_deg, lat1_deg, lon2_deg, lat2_deg)
        return float(az12), float(az21), float(dist)

    def azimuth_distance(
        self, lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float
    ) -> tuple[float, float]:
        """(forward azimuth 1 → 2 in degrees [0, 360), distance in metres)."""
        az12, _az21, dist = self._geod.inv(lon1_deg, lat1_deg, lon2_deg, lat2_deg)
        return float(az12) % 360.0, float(dist)

    def forward_azimuths_deg(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        """Forward azimuths (degrees, [0, 360)) from one point to each (lat, lon) of ``points``
        (degrees): :meth:`azimuth_distance`'s azimuths in one call (the Decca geometry's ship →
        station azimuths, four per evaluation)."""
        inv = self._geod.inv
        return [float(inv(lon1_deg, lat1_deg, lon2, lat2)[0]) % 360.0 for lat2, lon2 in points]

    def forward_azimuths_rad(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        """:meth:`forward_azimuths_deg` in radians (``math.radians`` of each, [0, 2π])."""
        return [math.radians(az) for az in self.forward_azimuths_deg(lat1_deg, lon1_deg, points)]


def geodesic_inverse(
    ell: Ellipsoid, lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float
) -> tuple[float, float, float]:
    """(forward azimuth deg, back azimuth deg, distance m) of the geodesic 1 → 2 on ``ell``.

    Convenience wrapper that builds a :class:`GeodesicSolver` per call; keep a solver in loops.
    """
    return GeodesicSolver(ell).inverse(lat1_deg, lon1_deg, lat2_deg, lon2_deg)


def andoyer_lambert_m(
    ell: Ellipsoid, lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float
) -> float:
    """First-order Andoyer–Lambert distance (metres) between two geodetic points (degrees).

    THEORY §2.5 (the program's Decca baselines B, verified to 1 cm on Pg 810): with
    β = atan((1−f) tan φ), P = (β1+β2)/2, Q = (β2−β1)/2, σ the spherical angle between the
    reduced-latitude points, X = (σ − sin σ) sin²P cos²Q / cos²(σ/2),
    Y = (σ + sin σ) cos²P sin²Q / sin²(σ/2), s = a(σ − f/2·(X + Y)).
    """
    f = ell.f
    b1 = math.atan((1.0 - f) * math.tan(math.radians(lat1_deg)))
    b2 = math.atan((1.0 - f) * math.tan(math.radians(lat2_deg)))
    dlam = math.radians(lon2_deg - lon1_deg)
    cos_sig = math.sin(b1) * math.sin(b2) + math.cos(b1) * math.cos(b2) * math.cos(dlam)
    sig = math.acos(max(-1.0, min(1.0, cos_sig)))
    if sig == 0.0:
        return 0.0
    p = 0.5 * (b1 + b2)
    q = 0.5 * (b2 - b1)
    sin_sig = math.sin(sig)
    x = (sig - sin_sig) * math.sin(p) ** 2 * math.cos(q) ** 2 / math.cos(0.5 * sig) ** 2
    y = (sig + sin_sig) * math.cos(p) ** 2 * math.sin(q) ** 2 / math.sin(0.5 * sig) ** 2
    return ell.a_m * (sig - 0.5 * f * (x + y))


# --------------------------------------------------------------------------- grid → spheroid
def mean_radius_sq(ell: Ellipsoid, lat1_deg: float, lat2_deg: float) -> float:
    """R_m² = ρ·ν (m²) at the mean geodetic latitude of two points (degrees), THEORY §2.4.

    ρ = a(1−e²)/W³ (meridian radius), ν = a/W (prime vertical), W = √(1 − e² sin²φ).
    """
    e2 = ell.e2
    s = math.sin(math.radians(0.5 * (lat1_deg + lat2_deg)))
    w2 = 1.0 - e2 * s * s
    a = ell.a_m
    return a * a * (1.0 - e2) / (w2 * w2)


def line_scale_factor(x0_m: float, xi_m: float, rm2_m2: float) -> float:
    """Line scale factor L = 1 + (x0² + x0·xi + xi²)/(6 R_m²) of a TM (k0 = 1) grid line.

    Thesis A5.10 (copy-1 form, L4575); x0, xi are grid eastings (m), ``rm2_m2`` = R_m² (m²).
    """
    return 1.0 + (x0_m * x0_m + x0_m * xi_m + xi_m * xi_m) / (6.0 * rm2_m2)


def spheroidal_distance(x0_m: float, y0_m: float, xi_m: float, yi_m: float, rm2_m2: float) -> float:
    """Spheroidal distance D = d/L (metres) from the grid chord d (A5.13) and A5.10's L."""
    return math.hypot(x0_m - xi_m, y0_m - yi_m) / line_scale_factor(x0_m, xi_m, rm2_m2)
