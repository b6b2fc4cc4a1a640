"""Angle wrapping: the one place where the engine folds an angle into its principal range.

Radians: :func:`wrap_pi` for differences (innovations, residuals, smoother corrections) and
:func:`wrap_2pi` for directions kept in [0, 2π) (the filter's grid heading). Degrees:
:func:`wrap_180_deg` for longitudes and longitude differences. The formulas are fixed: the
``.OUT`` logs are reproducible to the last bit, so every caller must get the same rounding.
"""

from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi
"""2π [rad]."""


def wrap_pi(angle_rad: float) -> float:
    """The angle [rad] wrapped into (−π, π] (a difference of two directions).

    Computed as fmod(a + π, 2π) − π (fmod is exact; the two additions round, so an angle
    already in range may change in its last bit).
    """
    a = math.fmod(angle_rad + math.pi, TWO_PI)
    if a <= 0.0:
        a += TWO_PI
    return a - math.pi


def wrap_2pi(angle_rad: float) -> float:
    """The angle [rad] wrapped into [0, 2π) (a direction, e.g. a grid heading).

    Python's float modulo: a tiny negative angle may round up to 2π itself.
    """
    return angle_rad % TWO_PI


def wrap_180_deg(angle_deg: float) -> float:
    """The angle [deg] wrapped into (−180, 180] (a longitude or longitude difference); −0 → 0."""
    w = math.remainder(angle_deg, 360.0)
    return 180.0 if w == -180.0 else w + 0.0
