"""Transverse Mercator calculating grid of the least-squares engine and the filter.

Thesis L6482–6490 (THEORY §2.3, §8.4): TM on the working-datum ellipsoid, scale
k0 = 1.0000 on the central meridian (CM), origin (φ = 0°, λ = CM) → (0, 0), no false easting or
northing; x = grid easting (negative west of the CM), y = grid northing, both in metres.
The CM is the MPP longitude rounded to the nearest whole degree (:func:`central_meridian_deg`).

Formulas: Krüger's n-series to order n⁶ with the coefficients of C.F.F. Karney (2011),
"Transverse Mercator with an accuracy of a few nanometres", J. Geodesy 85:475–485, eqs. (7)–(9)
(conformal latitude), (10)–(12) (Gauss–Schreiber), (35)–(36) (α, β) and (25)–(28) (convergence
and scale), summed with Clenshaw's method on complex arguments. Within a few degrees of the CM
the truncation error is of the order of nanometres; the series degrades far from the CM and is
not meant for |λ − CM| beyond ~30°.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from engine.geodesy.angles import wrap_180_deg
from engine.geodesy.ellipsoid import Ellipsoid

__all__ = ["TMGrid", "central_meridian_deg"]

FloatArray = npt.NDArray[np.float64]

_INVERSE_MEMO = 8
"""How many recently inverted grid points a :class:`TMGrid` remembers (a cycle inverts ~6)."""

# Karney (2011) eq. (35): α_j as polynomials in n, lowest power first; the entry for j holds the
# coefficients of n^j, n^(j+1), ..., n^6.
_F = Fraction
_ALPHA: tuple[tuple[Fraction, ...], ...] = (
    (_F(1, 2), _F(-2, 3), _F(5, 16), _F(41, 180), _F(-127, 288), _F(7891, 37800)),
    (_F(13, 48), _F(-3, 5), _F(557, 1440), _F(281, 630), _F(-1983433, 1935360)),
    (_F(61, 240), _F(-103, 140), _F(15061, 26880), _F(167603, 181440)),
    (_F(49561, 161280), _F(-179, 168), _F(6601661, 7257600)),
    (_F(34729, 80640), _F(-3418889, 1995840)),
    (_F(212378941, 319334400),),
)
# Karney (2011) eq. (36): β_j, same layout.
_BETA: tuple[tuple[Fraction, ...], ...] = (
    (_F(1, 2), _F(-2, 3), _F(37, 96), _F(-1, 360), _F(-81, 512), _F(96199, 604800)),
    (_F(1, 48), _F(1, 15), _F(-437, 1440), _F(46, 105), _F(-1118711, 3870720)),
    (_F(17, 480), _F(-37, 840), _F(-209, 4480), _F(5569, 90720)),
    (_F(4397, 161280), _F(-11, 504), _F(-830251, 7257600)),
    (_F(4583, 161280), _F(-108847, 3991680)),
    (_F(20648693, 638668800),),
)


def _series(coeffs: tuple[tuple[Fraction, ...], ...], n: float) -> tuple[float, ...]:
    """Evaluate the α or β polynomials in the third flattening n."""
    out = []
    for j, poly in enumerate(coeffs, start=1):
        out.append(sum(float(c) * n ** (j + i) for i, c in enumerate(poly)))
    return tuple(out)


def central_meridian_deg(lon_deg: float) -> float:
    """Central meridian (degrees) for a longitude (degrees): the nearest whole degree.

    Thesis L6484. Rounds half away from zero like Pascal ``Round`` (4.5 → 5, −4.5 → −5), not
    Python's banker's ``round``; the result is wrapped into (−180, 180].
    """
    cm = math.copysign(math.floor(abs(lon_deg) + 0.5), lon_deg)
    return wrap_180_deg(cm)


def _clenshaw(coeffs: tuple[float, ...], s2: Any, c2: Any) -> tuple[Any, Any]:
    """Clenshaw sums S = Σ c_j sin(2jζ) and D = Σ 2j c_j cos(2jζ) (= dS/dζ).

    ``s2``, ``c2`` are sin(2ζ), cos(2ζ) for complex ζ (Python complex or numpy complex arrays).
    """
    a = 2.0 * c2
    y1: Any = 0.0
    y2: Any = 0.0
    z1: Any = 0.0
    z2: Any = 0.0
    for j in range(len(coeffs), 0, -1):
        cj = coeffs[j - 1]
        y1, y2 = a * y1 - y2 + cj, y1
        z1, z2 = a * z1 - z2 + 2.0 * j * cj, z1
    return s2 * y1, c2 * z1 - z2


def _clenshaw_sum(coeffs: tuple[float, ...], s2: complex, c2: complex) -> complex:
    """S = Σ c_j sin(2jζ) alone for a complex scalar ζ: the y recurrence of :func:`_clenshaw`
    without the derivative sum (forward and inverse positions need no convergence or scale)."""
    a = 2.0 * c2
    y1: complex | float = 0.0
    y2: complex | float = 0.0
    for cj in reversed(coeffs):
        y1, y2 = a * y1 - y2 + cj, y1
    return s2 * y1


@dataclass(frozen=True)
class TMGrid:
    """TM grid with k0 = 1 and no false origin on ``ellipsoid``, central meridian ``cm_deg``.

    x = easting, y = northing (metres); geodetic coordinates in degrees on the datum of the
    ellipsoid. Series coefficients are computed once per instance (``__post_init__``).
    Grid convergence γ (degrees) is the grid azimuth of true north taken negatively, i.e. the
    true azimuth of grid north: ψ_grid = ψ_true − γ, with γ ≈ (λ − CM)·sin φ (positive east of
    the CM in the northern hemisphere), THEORY §8.4.
    """

    ellipsoid: Ellipsoid
    cm_deg: float
    _e: float = field(init=False, repr=False, compare=False)
    _e2m: float = field(init=False, repr=False, compare=False)
    _A: float = field(init=False, repr=False, compare=False)
    _alpha: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _beta: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _inverted: dict[tuple[float, float], tuple[float, float]] = field(
        init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        f = self.ellipsoid.f
        n = f / (2.0 - f)
        e2 = f * (2.0 - f)
        # Rectifying radius A = a/(1+n)·(1 + n²/4 + n⁴/64 + n⁶/256), Karney (2011) eq. (14).
        n2 = n * n
        big_a = self.ellipsoid.a_m / (1.0 + n) * (1.0 + n2 * (0.25 + n2 * (1 / 64 + n2 / 256)))
        object.__setattr__(self, "_e", math.sqrt(e2))
        object.__setattr__(self, "_e2m", 1.0 - e2)
        object.__setattr__(self, "_A", big_a)
        object.__setattr__(self, "_alpha", _series(_ALPHA, n))
        object.__setattr__(self, "_beta", _series(_BETA, n))
        object.__setattr__(self, "_inverted", {})

    @classmethod
    def for_longitude(cls, ellipsoid: Ellipsoid, lon_deg: float) -> TMGrid:
        """Grid whose CM is ``lon_deg`` (degrees) rounded by :func:`central_meridian_deg`."""
        return cls(ellipsoid, central_meridian_deg(lon_deg))

    # ---------------------------------------------------------------- scalar (plain math)
    def _taup(self, tau: float) -> float:
        """tan of the conformal latitude from τ = tan φ (Karney eqs. 7–9)."""
        e = self._e
        tau1 = math.hypot(1.0, tau)
        sig = math.sinh(e * math.atanh(e * tau / tau1))
        return tau * math.hypot(1.0, sig) - sig * tau1

    def forward_full(self, lat_deg: float, lon_deg: float) -> tuple[float, float, float, float]:
        """Geodetic (degrees) → (x m, y m, convergence γ degrees, point scale k) in one pass."""
        lam = math.radians(wrap_180_deg(lon_deg - self.cm_deg))
        phi = math.radians(lat_deg)
        sphi = math.sin(phi)
        cphi = math.cos(phi)
        clam = math.cos(lam)
        slam = math.sin(lam)
        if cphi <= 0.0:  # at a pole: ξ' = ±π/2, η' = 0
            taup = math.copysign(math.inf, sphi)
            xip = math.copysign(math.pi / 2, sphi)
            etap = 0.0
            gam_p = lam if sphi > 0.0 else -lam
            k_sphere = self._e2m**0.5 * math.exp(self._e * math.atanh(self._e))
        else:
            tau = sphi / cphi
            taup = self._taup(tau)
            xip = math.atan2(taup, clam)
            etap = math.asinh(slam / math.hypot(taup, clam))
            gam_p = math.atan2(slam * taup, clam * math.hypot(1.0, taup))
            # Gauss–Schreiber scale times the ellipsoid→conformal-sphere scale (eq. 25).
            k_sphere = (
                math.sqrt(1.0 - self._e**2 * sphi * sphi)
                * math.hypot(1.0, tau)
                / math.hypot(taup, clam)
            )
        zp = complex(xip, etap)
        s, d = _clenshaw(self._alpha, cmath.sin(2.0 * zp), cmath.cos(2.0 * zp))
        z = zp + s
        dz = 1.0 + d  # dζ/dζ' = p' − i q'
        gamma = gam_p - cmath.phase(dz)
        k = self._A / self.ellipsoid.a_m * abs(dz) * k_sphere
        return self._A * z.imag, self._A * z.real, math.degrees(gamma), k

    def forward(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """Geodetic (degrees, on this ellipsoid) → grid (x easting m, y northing m):
        :meth:`forward_full`'s position, with :func:`wrap_180_deg`, :meth:`_taup` and
        :func:`_clenshaw_sum` written out (the same operations: this runs every cycle)."""
        w = math.remainder(lon_deg - self.cm_deg, 360.0)  # wrap_180_deg
        lam = math.radians(180.0 if w == -180.0 else w + 0.0)
        phi = math.radians(lat_deg)
        cphi = math.cos(phi)
        clam = math.cos(lam)
        if cphi <= 0.0:
            xip = math.copysign(math.pi / 2, lat_deg)
            etap = 0.0
        else:
            tau = math.sin(phi) / cphi
            e = self._e
            tau1 = math.hypot(1.0, tau)  # τ' (Karney eqs. 7–9), as _taup
            sig = math.sinh(e * math.atanh(e * tau / tau1))
            taup = tau * math.hypot(1.0, sig) - sig * tau1
            xip = math.atan2(taup, clam)
            etap = math.asinh(math.sin(lam) / math.hypot(taup, clam))
        zp = complex(xip, etap)
        s2 = cmath.sin(2.0 * zp)
        a = 2.0 * cmath.cos(2.0 * zp)
        y1: complex | float = 0.0
        y2: complex | float = 0.0
        for cj in reversed(self._alpha):  # Clenshaw, as _clenshaw_sum
            y1, y2 = a * y1 - y2 + cj, y1
        z = zp + s2 * y1
        big_a = self._A
        return big_a * z.imag, big_a * z.real

    def inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        """Grid (x easting m, y northing m) → geodetic (lat, lon) in degrees on this ellipsoid.

        Longitude is returned wrapped into (−180, 180]. The last few points inverted are
        remembered: within one cycle the same point is inverted more than once (the filter's
        prediction is the fix's provisional point), and the inverse is a pure function of
        (x, y). Only Python floats other than zero are looked up (0.0 == −0.0 as a key, but the
        sign of a zero northing reaches the latitude's).
        """
        if type(x_m) is float and type(y_m) is float and x_m and y_m:
            memo = self._inverted
            key = (x_m, y_m)
            hit = memo.get(key)
            if hit is not None:
                return hit
            out = self._inverse(x_m, y_m)
            if len(memo) >= _INVERSE_MEMO:
                try:  # forget the oldest (insertion order)
                    del memo[next(iter(memo))]
                except (KeyError, RuntimeError, StopIteration):  # changed by another thread
                    memo.clear()
            memo[key] = out
            return out
        return self._inverse(x_m, y_m)

    def _inverse(self, x_m: float, y_m: float) -> tuple[float, float]:
        """:meth:`inverse` computed, without the memo (Karney 2011 eqs. 11, 19–21, 36), with
        :func:`_clenshaw_sum`, :meth:`_tau_from_taup` and :func:`wrap_180_deg` written out (the
        same operations: this runs several times a cycle)."""
        big_a = self._A
        z = complex(y_m / big_a, x_m / big_a)
        s2 = cmath.sin(2.0 * z)
        a = 2.0 * cmath.cos(2.0 * z)
        y1: complex | float = 0.0
        y2: complex | float = 0.0
        for cj in reversed(self._beta):  # Clenshaw, as _clenshaw_sum
            y1, y2 = a * y1 - y2 + cj, y1
        zp = z - s2 * y1
        xip = zp.real
        etap = zp.imag
        sxi = math.sin(xip)
        cxi = math.cos(xip)
        she = math.sinh(etap)
        r = math.hypot(she, cxi)
        w = math.remainder(self.cm_deg + math.degrees(math.atan2(she, cxi)), 360.0)
        lon = 180.0 if w == -180.0 else w + 0.0  # wrap_180_deg
        if r == 0.0:
            return math.copysign(90.0, sxi), lon
        taup = sxi / r
        # τ = tan φ from τ' by Newton, as _tau_from_taup.
        e2m = self._e2m
        e = self._e
        hypot = math.hypot
        tau = taup / e2m
        tol = 1e-15 * max(1.0, abs(taup))
        for _ in range(6):
            tau1 = hypot(1.0, tau)
            sig = math.sinh(e * math.atanh(e * tau / tau1))
            taupa = tau * hypot(1.0, sig) - sig * tau1
            dtau = (taup - taupa) * (1.0 + e2m * tau * tau) / (e2m * tau1 * hypot(1.0, taupa))
            tau += dtau
            if abs(dtau) <= tol:
                break
        return math.degrees(math.atan(tau)), lon

    def _tau_from_taup(self, taup: float) -> float:
        """Invert τ' (tan conformal latitude) → τ = tan φ by Newton (Karney eqs. 19–21)."""
        e2m = self._e2m
        e = self._e
        hypot = math.hypot
        tau = taup / e2m
        tol = 1e-15 * max(1.0, abs(taup))
        for _ in range(6):
            tau1 = hypot(1.0, tau)  # τ'(τ) as in _taup, inlined (hot path)
            sig = math.sinh(e * math.atanh(e * tau / tau1))
            taupa = tau * hypot(1.0, sig) - sig * tau1
            dtau = (taup - taupa) * (1.0 + e2m * tau * tau) / (e2m * tau1 * hypot(1.0, taupa))
            tau += dtau
            if abs(dtau) <= tol:
                break
        return tau

    def convergence_deg(self, lat_deg: float, lon_deg: float) -> float:
        """Grid convergence γ (degrees) at a geodetic point (degrees), Karney eq. (26)–(28).

        ψ_grid = ψ_true − γ; γ ≈ (λ − CM)·sin φ, positive east of the CM in the north.
        """
        return self.forward_full(lat_deg, lon_deg)[2]

    def point_scale(self, lat_deg: float, lon_deg: float) -> float:
        """Point scale factor k (grid length / ellipsoid length) at a geodetic point (degrees)."""
        return self.forward_full(lat_deg, lon_deg)[3]

    # ---------------------------------------------------------------- arrays (numpy)
    def _taup_array(self, tau: FloatArray) -> FloatArray:
        e = self._e
        tau1 = np.hypot(1.0, tau)
        sig = np.sinh(e * np.arctanh(e * tau / tau1))
        return tau * np.hypot(1.0, sig) - sig * tau1

    def forward_array(
        self, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Vectorised :meth:`forward`: arrays of geodetic degrees → arrays (x m, y m)."""
        lat = np.asarray(lat_deg, dtype=np.float64)
        dlon = np.remainder(np.asarray(lon_deg, dtype=np.float64) - self.cm_deg + 180.0, 360.0)
        lam = np.radians(dlon - 180.0)
        phi = np.radians(lat)
        cphi = np.cos(phi)
        clam = np.cos(lam)
        pole = cphi <= 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            taup = self._taup_array(np.sin(phi) / np.where(pole, 1.0, cphi))
            xip = np.where(pole, np.copysign(np.pi / 2, lat), np.arctan2(taup, clam))
            etap = np.where(pole, 0.0, np.arcsinh(np.sin(lam) / np.hypot(taup, clam)))
        zp = xip + 1j * etap
        s, _ = _clenshaw(self._alpha, np.sin(2.0 * zp), np.cos(2.0 * zp))
        z = zp + s
        return self._A * np.imag(z), self._A * np.real(z)

    def inverse_array(
        self, x_m: npt.ArrayLike, y_m: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """Vectorised :meth:`inverse`: arrays of grid metres → arrays (lat, lon) in degrees."""
        x = np.asarray(x_m, dtype=np.float64)
        y = np.asarray(y_m, dtype=np.float64)
        z = y / self._A + 1j * (x / self._A)
        s, _ = _clenshaw(self._beta, np.sin(2.0 * z), np.cos(2.0 * z))
        zp = z - s
        xip = np.real(zp)
        etap = np.imag(zp)
        she = np.sinh(etap)
        cxi = np.cos(xip)
        r = np.hypot(she, cxi)
        lam = np.arctan2(she, cxi)
        with np.errstate(divide="ignore", invalid="ignore"):
            taup = np.sin(xip) / r
        e2m = self._e2m
        tau = taup / e2m
        for _ in range(5):
            taupa = self._taup_array(tau)
            with np.errstate(invalid="ignore"):
                dtau = (
                    (taup - taupa)
                    * (1.0 + e2m * tau * tau)
                    / (e2m * np.hypot(1.0, tau) * np.hypot(1.0, taupa))
                )
            tau = np.where(np.isfinite(tau), tau + np.nan_to_num(dtau), tau)
        lat = np.degrees(np.arctan(tau))
        lon = np.remainder(self.cm_deg + np.degrees(lam) + 180.0, 360.0) - 180.0
        lon = np.where(lon == -180.0, 180.0, lon)
        return lat, lon
