"""Confidence regions of a fix (thesis ch. 5.5): error ellipse, error ellipsoid, drms.

Axes convention: x = East, y = North (, z = Up), all in metres; azimuths from grid North
clockwise in degrees. Expansion factors are exact quantiles, k = sqrt(χ²_dim(p)), cached per
(p, dim); in 2-D k = sqrt(−2 ln(1 − p)) (eq. 5.24–5.25), in 3-D from SciPy (eq. 5.29).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from engine.lsq.statistics import chi2_quantile, frozen_instance

_F64 = np.dtype(np.float64)


@lru_cache(maxsize=64)
def k_factor(p: float, dim: int) -> float:
    """Expansion factor k with P(χ²_dim ≤ k²) = p: 2-D 0.95 → 2.4477, 0.999 → 3.7169;
    3-D 0.95 → 2.7955, 0.999 → 4.0331 (Tables 5.2/5.3; Table 5.3 prints 4.0332)."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"probability must be in (0, 1), got {p}")
    if dim == 2:
        return math.sqrt(-2.0 * math.log1p(-p))
    if dim < 1:
        raise ValueError(f"dimension must be ≥ 1, got {dim}")
    return math.sqrt(chi2_quantile(p, dim))


@dataclass(frozen=True, eq=False)
class Ellipse:
    """Standard error ellipse of a 2×2 position VCV (eq. 5.22–5.23, 5.28 about z).

    ``a_m`` ≥ ``b_m`` standard semi-axes [m] (sqrt of the eigenvalues); ``az_deg`` azimuth of
    the major axis from grid North clockwise, in [0, 180); ``eigenvalues`` (λ1 ≥ λ2) [m²];
    ``eigenvectors`` (2×2, columns (East, North) of the major and minor axis, a proper rotation
    R_z(φ)); ``phi_deg`` its rotation angle φ = atan2(e_N, e_E) of the major axis (= 90° − Az).
    Sample (Pg 840): λ 935.48/76.21, Az 112.0°, φ −22.00°.
    """

    a_m: float
    b_m: float
    az_deg: float
    eigenvalues: tuple[float, float]
    eigenvectors: np.ndarray
    phi_deg: float

    def scaled(self, p: float) -> tuple[float, float]:
        """Semi-axes (k·a, k·b) [m] of the ellipse holding the position with probability p."""
        k = k_factor(p, 2)
        return k * self.a_m, k * self.b_m


def eigenvalues_2x2(sxx: float, sxy: float, syy: float) -> tuple[float, float]:
    """Eigenvalues λ1 ≥ λ2 of the symmetric 2×2 [[sxx, sxy], [sxy, syy]], closed form
    λ1,2 = ½(sxx + syy) ± ½·sqrt((sxx − syy)² + 4 sxy²) (eq. 5.22–5.23), units of the input."""
    half = 0.5 * (sxx + syy)
    root = math.hypot(0.5 * (sxx - syy), sxy)
    return half + root, half - root


def error_ellipse(C2: np.ndarray) -> Ellipse:
    """Error ellipse of a 2×2 VCV [[σx², σxy], [σxy, σy²]] (x East, y North) [m²], closed form.

    λ1,2 = ½(σx²+σy²) ± ½·sqrt((σx²−σy²)² + 4σxy²) (5.22–5.23); the major eigenvector's sign is
    chosen so that its azimuth lies in [0°, 180°); the minor one is it turned +90° (det E = +1).
    An isotropic VCV gives Az = 90° (major axis East, φ = 0). Raises ValueError if not finite.
    """
    if type(C2) is np.ndarray and C2.shape == (2, 2) and C2.dtype == _F64:
        (sxx, sxy), (_, syy) = C2.tolist()  # the usual case: no conversion, no slicing
    else:
        (sxx, sxy), (_, syy) = np.asarray(C2, dtype=float)[:2, :2].tolist()
    if not (math.isfinite(sxx) and math.isfinite(sxy) and math.isfinite(syy)):
        raise ValueError("error_ellipse: non-finite covariance")
    half = 0.5 * (sxx + syy)  # eigenvalues_2x2, inlined
    root = math.hypot(0.5 * (sxx - syy), sxy)
    l1, l2 = half + root, half - root
    if sxy == 0.0 and 0.5 * (sxx - syy) == 0.0:  # isotropic (the square root is 0)
        ee, en = 1.0, 0.0
    elif sxx >= syy:  # (λ1 − σy², σxy) is the better-conditioned eigenvector form here
        ee, en = l1 - syy, sxy
    else:
        ee, en = sxy, l1 - sxx
    norm = math.hypot(ee, en)
    ee, en = ee / norm, en / norm
    if ee < 0.0 or (ee == 0.0 and en < 0.0):
        ee, en = -ee, -en
    az = math.degrees(math.atan2(ee, en)) % 180.0
    phi = math.degrees(math.atan2(en, ee))
    vecs = np.array(((ee, -en), (en, ee)))
    return frozen_instance(Ellipse, {
        "a_m": math.sqrt(max(l1, 0.0)), "b_m": math.sqrt(max(l2, 0.0)), "az_deg": az,
        "eigenvalues": (l1, l2), "eigenvectors": vecs, "phi_deg": phi})


@dataclass(frozen=True, eq=False)
class Ellipsoid3:
    """Standard error ellipsoid of a 3×3 VCV (x East, y North, z Up) (THEORY §7.2, eq. 5.28).

    ``axes`` (a ≥ b ≥ c) [m]; ``eigenvalues`` [m²]; ``E`` proper rotation (det +1) whose
    columns are the unit axes a, b, c, with E = R_z(φ)·R_y(θ)·R_x(ρ); ``az_deg`` (from North,
    [0, 180)) and ``elev_deg`` of the major axis; ``rho_deg``, ``theta_deg``, ``phi_deg`` the
    rotation angles (θ = −asin E31, φ = atan2(E21, E11), ρ = atan2(E32, E33)).
    """

    axes: tuple[float, float, float]
    eigenvalues: tuple[float, float, float]
    E: np.ndarray
    az_deg: float
    elev_deg: float
    rho_deg: float
    theta_deg: float
    phi_deg: float

    def scaled(self, p: float) -> tuple[float, float, float]:
        """Semi-axes (k·a, k·b, k·c) [m] of the ellipsoid holding the point with probability p."""
        k = k_factor(p, 3)
        a, b, c = self.axes
        return k * a, k * b, k * c


def error_ellipsoid(C3: np.ndarray) -> Ellipsoid3:
    """Error ellipsoid of a 3×3 VCV [m²] from ``numpy.linalg.eigh`` (THEORY §7.2).

    Sign conventions: the major axis is turned so that its azimuth atan2(E11, E21) lies in
    [0°, 180°) (vertical: pointing up); the minor axis so that E33 ≥ 0; the middle axis is
    c × a, which makes det E = +1. A horizontal 2-D case embedded in 3-D gives ρ = θ = 0 and
    the 2-D φ. Raises ValueError if not finite.
    """
    c3 = np.asarray(C3, dtype=float)
    if c3.shape != (3, 3) or not np.isfinite(c3).all():
        raise ValueError("error_ellipsoid: need a finite 3×3 covariance")
    lam, vec = np.linalg.eigh(0.5 * (c3 + c3.T))
    lam = lam[::-1]
    vec = vec[:, ::-1]
    a = vec[:, 0]
    if a[0] < 0.0 or (a[0] == 0.0 and (a[1] < 0.0 or (a[1] == 0.0 and a[2] < 0.0))):
        a = -a
    c = vec[:, 2]
    if c[2] < 0.0:
        c = -c
    b = np.cross(c, a)
    e = np.column_stack((a, b, c))
    theta = -math.asin(max(-1.0, min(1.0, float(e[2, 0]))))
    phi = math.atan2(float(e[1, 0]), float(e[0, 0]))
    rho = math.atan2(float(e[2, 1]), float(e[2, 2]))
    az = math.degrees(math.atan2(float(e[0, 0]), float(e[1, 0]))) % 180.0
    ls = tuple(float(x) for x in lam)
    return Ellipsoid3(
        axes=tuple(math.sqrt(max(x, 0.0)) for x in ls),  # type: ignore[arg-type]
        eigenvalues=ls,  # type: ignore[arg-type]
        E=e,
        az_deg=az,
        elev_deg=-math.degrees(theta),
        rho_deg=math.degrees(rho),
        theta_deg=math.degrees(theta),
        phi_deg=math.degrees(phi),
    )


def drms(C: np.ndarray) -> float:
    """Distance root-mean-square d_rms = sqrt(trace C) [m] (eq. 5.30); sample 31.81 m."""
    return math.sqrt(max(float(np.trace(np.asarray(C, dtype=float))), 0.0))


def two_drms(C: np.ndarray) -> float:
    """2drms = 2·d_rms [m] (eq. 5.30); sample 63.6 m."""
    return 2.0 * drms(C)

