"""Ellipsoidal geodesy for the LSQ engine and the filter (THEORY §2, thesis A5, A8.4).

* geodetic ↔ ECEF (Earth-centred, Earth-fixed, metres) on any :class:`Ellipsoid`;
* datum transformations (Bursa–Wolf, position-vector convention, X_WGS84 = X_datum + (dX, dY,
  dZ) + rotations/scale, THEORY D1) as explicit PROJ pipelines built from the :class:`Datum`
  parameters, with a pure-Python cross-check;
* the GPS convention of THEORY §2.1–2.2 (WGS84 fix converted with h_WGS84 = 0);
* geodesic inverse (pyproj/Karney), first-order Andoyer–Lambert distance (THEORY §2.5);
* line scale factor and spheroidal distance from grid coordinates (A5.10, A5.13, THEORY §2.4).

Angles are degrees unless a name says otherwise; lengths are metres. The per-point datum shift of a
run (:meth:`DatumShift.transform`) goes to pyproj's libproj without importing pyproj (start-up
time); pyproj itself is imported by the calls that need it (arrays, inverses, geodesics), on
first use.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cache
from typing import Any

from engine.geodesy.ellipsoid import WGS84, WGS84_ELLIPSOID, Datum, Ellipsoid

__all__ = [
    "DatumShift",
    "GeodesicSolver",
    "andoyer_lambert_m",
    "bursa_wolf_from_wgs84",
    "bursa_wolf_to_wgs84",
    "datum_shift",
    "datum_shift_python",
    "ecef_to_geodetic",
    "geodesic_inverse",
    "geodetic_to_ecef",
    "helmert_pipeline",
    "line_scale_factor",
    "load_proj",
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
    """Pinned PROJ pipeline: geodetic (lat, lon deg, h m) on ``src`` → the same on ``dst``.

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


PJ_FWD = 1
"""PROJ's ``PJ_FWD``: the direction :attr:`DatumShift._point` takes."""


@cache
def _proj_library() -> Any:
    """pyproj's bundled libproj (``ctypes.CDLL``, the library pyproj's own calls go to) with
    the prototypes :class:`_ProjPoint` uses, loaded without importing pyproj (about 0.1 s of
    start-up: pyproj's import brings its CRS, network and metadata modules, none of which a
    run uses); None where pyproj is not a wheel with its own libproj, or it cannot be loaded.
    The libraries bundled beside it are loaded first: libproj finds its dependencies by their
    names once they are loaded (pyproj's extension modules find them by their RPATH)."""
    import ctypes
    import importlib.util
    from pathlib import Path

    spec = importlib.util.find_spec("pyproj")
    if spec is None or spec.origin is None:
        return None
    folder = Path(spec.origin).parent.parent / "pyproj.libs"
    libs = sorted(folder.glob("libproj*.so*"))
    if len(libs) != 1:
        return None
    pending = sorted(p for p in folder.glob("*.so*") if p != libs[0]) + libs
    lib = None
    while pending:  # in dependency order: a library whose dependency is not loaded yet waits
        waiting = []
        for path in pending:
            try:
                loaded = ctypes.CDLL(str(path))
            except OSError:
                waiting.append(path)
                continue
            if path == libs[0]:
                lib = loaded
        if len(waiting) == len(pending):
            return None
        pending = waiting
    if lib is None:
        return None
    try:
        vp, c_int = ctypes.c_void_p, ctypes.c_int
        lib.proj_context_create.restype = vp
        lib.proj_context_create.argtypes = []
        lib.proj_context_set_search_paths.restype = None
        lib.proj_context_set_search_paths.argtypes = [vp, c_int,
                                                      ctypes.POINTER(ctypes.c_char_p)]
        lib.proj_context_destroy.restype = vp
        lib.proj_context_destroy.argtypes = [vp]
        lib.proj_create.restype = vp
        lib.proj_create.argtypes = [vp, ctypes.c_char_p]
        lib.proj_destroy.restype = vp
        lib.proj_destroy.argtypes = [vp]
        lib.proj_angular_input.restype = c_int
        lib.proj_angular_input.argtypes = [vp, c_int]
        lib.proj_angular_output.restype = c_int
        lib.proj_angular_output.argtypes = [vp, c_int]
        lib.proj_trans_array.restype = c_int
        lib.proj_trans_array.argtypes = [vp, c_int, ctypes.c_size_t,
                                         ctypes.POINTER(_ProjCoord.ctype())]
    except AttributeError:
        return None
    data = Path(spec.origin).parent / "proj_dir" / "share" / "proj"
    lib.uvnav_search_paths = (ctypes.c_char_p * 1)(str(data).encode()) if data.is_dir() else None
    return lib


def load_proj() -> bool:
    """Load pyproj's libproj for the run's PROJ calls (:func:`_proj_library`), as the first
    :class:`DatumShift` would: for a caller that prepares a run ahead of time (the console,
    while the operator reads its first dialog). True if it could be loaded."""
    return _proj_library() is not None


class _ProjCoord:
    """PROJ's ``PJ_COORD`` (a union of four doubles: x, y, z, t) as a ctypes structure."""

    @staticmethod
    @cache
    def ctype() -> Any:
        """The ctypes structure (made on first use: ctypes is imported only then)."""
        import ctypes

        class PJCoord(ctypes.Structure):
            _fields_ = [("x", ctypes.c_double), ("y", ctypes.c_double),
                        ("z", ctypes.c_double), ("t", ctypes.c_double)]

        return PJCoord


class _ProjPoint:
    """One PROJ transformation made by ``proj_create`` from a pipeline string in its own PROJ
    context (as pyproj's ``Transformer.from_pipeline`` makes it), called through ctypes:
    :meth:`point` is pyproj's ``_Transformer._transform_point`` for what the engine passes it
    (floats, no time, degrees, no error check): the same ``proj_trans`` call on the same
    numbers, so the same bits (``tests/geodesy/test_geodesy.py`` compares the two). The point
    goes through ``proj_trans_array`` on one ``PJ_COORD`` kept here (it resets PROJ's error
    state and calls ``proj_trans``, as pyproj does; cheaper through ctypes than ``proj_trans``
    with its coordinate passed and returned by value: ~12.4k instead of ~13.7k instructions a
    call, pyproj's ~7.0k)."""

    __slots__ = ("_lib", "_ctx", "_pj", "_deg_in", "_deg_out", "_coord", "point")

    def __init__(self, lib: Any, pipeline: str) -> None:
        self._lib = lib
        self._pj = None
        self._ctx = lib.proj_context_create()
        if not self._ctx:
            raise OSError("proj_context_create failed")
        if lib.uvnav_search_paths is not None:
            lib.proj_context_set_search_paths(self._ctx, 1, lib.uvnav_search_paths)
        self._pj = lib.proj_create(self._ctx, pipeline.encode())
        if not self._pj:
            raise ValueError(f"PROJ cannot make the pipeline {pipeline!r}")
        # pyproj multiplies by its _DG2RAD / _RAD2DG where PROJ wants radians (not for a
        # pipeline that converts its own units, as the engine's do)
        self._deg_in = bool(lib.proj_angular_input(self._pj, PJ_FWD))
        self._deg_out = bool(lib.proj_angular_output(self._pj, PJ_FWD))
        self.point = self._make_point()

    def _make_point(self) -> Any:
        """The point call: pyproj's ``_transform_point`` signature (x, y, z, t, direction,
        radians, errcheck) for t None, radians and errcheck False, x, y, z floats."""
        trans, pj = self._lib.proj_trans_array, self._pj
        c = self._coord = _ProjCoord.ctype()()
        inf = math.inf
        if self._deg_in or self._deg_out:
            dg2rad, rad2dg = math.radians(1.0), math.degrees(1.0)
            deg_in, deg_out = self._deg_in, self._deg_out

            def point_scaled(x: float, y: float, z: float, t: None, direction: int,
                             radians: bool, errcheck: bool) -> tuple[float, float, float]:
                if deg_in:
                    x *= dg2rad
                    y *= dg2rad
                c.x = x
                c.y = y
                c.z = z
                c.t = inf
                trans(pj, direction, 1, c)
                if deg_out:
                    return c.x * rad2dg, c.y * rad2dg, c.z
                return c.x, c.y, c.z

            return point_scaled

        def point(x: float, y: float, z: float, t: None, direction: int, radians: bool,
                  errcheck: bool) -> tuple[float, float, float]:
            c.x = x
            c.y = y
            c.z = z
            c.t = inf
            trans(pj, direction, 1, c)
            return c.x, c.y, c.z

        return point

    def definition(self) -> str | None:
        """The pipeline PROJ runs (``proj_pj_info(pj).definition``, as pyproj's
        ``Transformer.definition``): ``proj_create`` rewrites the string it is given (steps that
        undo each other go, a pipeline of such steps becomes ``proj=noop``); None if unknown."""
        import ctypes

        class PJProjInfo(ctypes.Structure):
            _fields_ = [("id", ctypes.c_char_p), ("description", ctypes.c_char_p),
                        ("definition", ctypes.c_char_p), ("has_inverse", ctypes.c_int),
                        ("accuracy", ctypes.c_double)]

        try:
            info = self._lib.proj_pj_info
        except AttributeError:
            return None
        info.restype = PJProjInfo
        info.argtypes = [ctypes.c_void_p]
        text = info(self._pj).definition
        return None if text is None else text.decode("utf-8", "replace")

    def __del__(self) -> None:
        lib = self._lib
        if self._pj:
            lib.proj_destroy(self._pj)
        if self._ctx:
            lib.proj_context_destroy(self._ctx)


class DatumShift:
    """Geodetic transformation ``src`` → ``dst`` through a pinned PROJ pipeline.

    Build once per datum pair; coordinates are latitude and longitude in degrees and
    ellipsoidal height in metres. The per-point call (:meth:`transform`, through ``_point``)
    goes to PROJ's ``proj_trans`` in pyproj's libproj through ctypes (:class:`_ProjPoint`),
    without importing pyproj (start-up time); pyproj's ``Transformer`` of the same pipeline is
    made on first use by the array and inverse calls, and serves every call where libproj
    cannot be loaded that way. Not thread-safe (PROJ objects should not be shared between
    threads).
    """

    __slots__ = ("src", "dst", "pipeline", "_tr_obj", "_proj", "_point", "_forward")

    def __init__(self, src: Datum, dst: Datum) -> None:
        self.src = src
        self.dst = dst
        self.pipeline = helmert_pipeline(src, dst)
        self._tr_obj: Any = None
        lib = _proj_library()
        try:
            self._proj = None if lib is None else _ProjPoint(lib, self.pipeline)
        except (OSError, ValueError):  # pyproj's Transformer then (and its error, if any)
            self._proj = None
        if self._proj is not None:
            self._point: Any = self._proj.point
            self._forward: Any = PJ_FWD
        else:
            from pyproj.enums import TransformDirection

            # Transformer.transform hands a scalar point to its _transformer._transform_point
            # (one proj_trans call); calling that directly skips the wrapper's argument
            # handling: the same PROJ call, the same bits. None where a pyproj lacks it.
            self._point = getattr(getattr(self._tr, "_transformer", None),
                                  "_transform_point", None)
            self._forward = TransformDirection.FORWARD

    @property
    def _tr(self) -> Any:
        """pyproj's ``Transformer`` of :attr:`pipeline` (made, and pyproj imported, on first
        use)."""
        tr = self._tr_obj
        if tr is None:
            from pyproj import Transformer

            tr = self._tr_obj = Transformer.from_pipeline(self.pipeline)
        return tr

    def __reduce__(self) -> tuple[Any, tuple[Datum, Datum]]:
        """Pickled (and copied) as its two datums: a copy makes its own PROJ objects."""
        return DatumShift, (self.src, self.dst)

    def transform(
        self, lat_deg: float, lon_deg: float, h_m: float = 0.0
    ) -> tuple[float, float, float]:
        """Geodetic on ``src`` → geodetic on ``dst`` (degrees, degrees, metres)."""
        point = self._point
        if point is not None and type(lat_deg) is float and type(lon_deg) is float \
                and type(h_m) is float:
            # positionally: (inx, iny, inz, intime, direction, radians, errcheck)
            lat, lon, h = point(lat_deg, lon_deg, h_m, None, self._forward, False, False)
        else:
            lat, lon, h = self._tr.transform(lat_deg, lon_deg, h_m)
        return float(lat), float(lon), float(h)

    def transform_array(self, lat_deg: Any, lon_deg: Any, h_m: Any = 0.0) -> tuple[Any, Any]:
        """Vectorised :meth:`transform` of numpy arrays (degrees, metres) → (lat, lon) arrays
        in degrees on ``dst`` (the heights are dropped)."""
        lat, lon, _h = self._tr.transform(lat_deg, lon_deg, h_m)
        return lat, lon

    def inverse(
        self, lat_deg: float, lon_deg: float, h_m: float = 0.0
    ) -> tuple[float, float, float]:
        """Geodetic on ``dst`` → geodetic on ``src`` (degrees, degrees, metres)."""
        from pyproj.enums import TransformDirection

        lat, lon, h = self._tr.transform(
            lat_deg, lon_deg, h_m, direction=TransformDirection.INVERSE
        )
        return float(lat), float(lon), float(h)

    def __repr__(self) -> str:
        return f"DatumShift({self.src.name!r} -> {self.dst.name!r})"


def datum_shift(src: Datum, dst: Datum) -> DatumShift:
    """Factory: a :class:`DatumShift` from ``src`` to ``dst`` (build once, reuse)."""
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


def datum_shift_python(
    lat_deg: float, lon_deg: float, h_m: float, src: Datum, dst: Datum
) -> tuple[float, float, float]:
    """Pure-Python rigorous geocentric shift ``src`` → ``dst`` (degrees, degrees, metres).

    geodetic → ECEF (src ellipsoid) → Bursa–Wolf to WGS84 → inverse to dst → geodetic (dst
    ellipsoid). The verified GPS path of THEORY §2.1–2.2; used to cross-check :class:`DatumShift`.
    """
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
    height 0 on the datum). ``shift`` (WGS84 → datum) selects the PROJ pipeline; by default the
    pure-Python path is used (the two agree to well below 1 mm).
    """
    if shift is not None:
        if shift.src != WGS84 or shift.dst != datum:
            raise ValueError(f"{shift!r} is not WGS84 -> {datum.name}")
        return shift.transform(lat_deg, lon_deg, 0.0)
    return datum_shift_python(lat_deg, lon_deg, 0.0, WGS84, datum)


def wgs84_fix_ecef(lat_deg: float, lon_deg: float, h_datum_m: float) -> tuple[float, float, float]:
    """WGS84 ECEF (metres) of the GPS fix as on Pg 100: of (φ, λ, h = −h_datum) on WGS84."""
    return geodetic_to_ecef(lat_deg, lon_deg, -h_datum_m, WGS84_ELLIPSOID)


# --------------------------------------------------------------------------- geodesics
class GeodesicSolver:
    """Exact geodesic problems on one ellipsoid (Karney's algorithm through ``pyproj.Geod``).

    Build once per ellipsoid; :meth:`inverse` is then cheap. The per-epoch azimuths
    (:meth:`forward_azimuths_rad`) take pyproj's scalar inverse (PROJ's ``geod_inverse``).
    pyproj's ``Geod`` is made (and pyproj imported) on first use of a call that needs it.
    """

    __slots__ = ("ellipsoid", "_geod_obj", "_inv")

    def __init__(self, ell: Ellipsoid) -> None:
        self.ellipsoid = ell
        self._geod_obj: Any = None
        self._inv: Any = None

    @property
    def _geod(self) -> Any:
        """pyproj's ``Geod(a, f)`` of the ellipsoid (made on first use)."""
        geod = self._geod_obj
        if geod is None:
            from pyproj import Geod

            geod = self._geod_obj = Geod(a=self.ellipsoid.a_m, f=self.ellipsoid.f)
        return geod

    @property
    def _inv_point(self) -> Any:
        """The scalar path that ``Geod.inv`` itself takes for float input (same C
        ``geod_inverse``, the same bits), called without the wrapper's frame;
        :meth:`_inv_fallback` where pyproj lacks it."""
        inv = self._inv
        if inv is None:
            point = getattr(self._geod, "_inv_point", None)
            inv = self._inv = point if point is not None else self._inv_fallback
        return inv

    def __reduce__(self) -> tuple[Any, tuple[Ellipsoid]]:
        """Pickled (and copied) as its ellipsoid: a copy builds its own Geod."""
        return type(self), (self.ellipsoid,)

    def _inv_fallback(self, lon1: float, lat1: float, lon2: float, lat2: float,
                      radians: bool, back: bool) -> tuple[float, float, float]:
        """``Geod._inv_point``'s signature on ``Geod.inv`` (pyproj without the scalar path)."""
        az12, az21, dist = self._geod.inv(lon1, lat1, lon2, lat2, radians=radians,
                                          return_back_azimuth=back)
        return float(az12), float(az21), float(dist)

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
        try:
            az12, _az21, dist = self._inv_point(lon1_deg, lat1_deg, lon2_deg, lat2_deg, False,
                                                False)
        except TypeError:  # not a Python/numpy float or int: Geod.inv converts it
            az12, _az21, dist = self._geod.inv(lon1_deg, lat1_deg, lon2_deg, lat2_deg)
        return float(az12) % 360.0, float(dist)

    def forward_azimuths_deg(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        """Forward azimuths (degrees, [0, 360)) from one point to each (lat, lon) of ``points``
        (degrees): :meth:`azimuth_distance`'s azimuths in one call (the Decca geometry's ship →
        station azimuths, four per evaluation), through pyproj's scalar inverse."""
        inv = self._inv_point
        return [inv(lon1_deg, lat1_deg, lon2, lat2, False, False)[0] % 360.0
                for lat2, lon2 in points]

    def forward_azimuths_rad(
        self, lat1_deg: float, lon1_deg: float, points: Sequence[tuple[float, float]]
    ) -> list[float]:
        """:meth:`forward_azimuths_deg` in radians (``math.radians`` of each, [0, 2π])."""
        inv = self._inv_point
        radians = math.radians
        return [radians(inv(lon1_deg, lat1_deg, lon2, lat2, False, False)[0] % 360.0)
                for lat2, lon2 in points]


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
