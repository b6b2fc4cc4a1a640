"""Pool of Errors (THEORY §10, thesis chapter 2, eq. 2.1; D47): pure functions.

The traditional submarine estimate of the maximum likely position error, drawn by the console
next to the Kalman filter's confidence ellipse so that the navigator sees why the thesis replaced
the one with the other.

* **Expanding circle** (eq. 2.1, L289–300): ``R = a + ε·Δt`` (m), centred on the current DR
  position (the MPP), with ``a`` the d_rms = sqrt(σx² + σy²) (m) of the last least-squares fix,
  ``ε`` the expansion rate (m/h, typically 900–1800 m/h) and ``Δt`` the time since that fix.
  Growth is linear in time.
* **Circle segment** (L302–309, figure 2.2 lost, THEORY D47): the expanding circle (with ε
  reduced to the log and gyro errors) combined with a circular segment for the tidal-stream and
  current uncertainty: apex at the DR position, oriented along the current set, depth ``d`` (m,
  the radius of the segment) and half-width ``α`` (degrees either side of the set).  The
  combination is the Minkowski sum segment ⊕ disc(R), returned as a polygon.

Frames and units: grid metres, x east and y north (the TM grid of the cycle's CM); azimuths and
sets in degrees clockwise from grid north; times in seconds (floats) or as ``datetime``.  The
console's default is the expanding circle (A17).  Nothing here prints or imports the UI.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime

import numpy as np

SECONDS_PER_HOUR = 3600.0
DEFAULT_RATE_M_H = 1800.0
"""Default expansion rate ε (m/h): the conservative end of the traditional 900–1800 m/h."""

Point = tuple[float, float]
"""A grid point (x east, y north) in metres."""


@dataclass(frozen=True, slots=True)
class PoeSample:
    """One epoch of the input sequence: time (s or datetime), whether the epoch has a proper
    least-squares estimate and, if so, its d_rms (m)."""

    t: float | datetime
    has_lse: bool
    lse_drms_m: float = math.nan


@dataclass(frozen=True, slots=True)
class PoeState:
    """The Pool of Errors at one epoch: radius ``radius_m`` (m) = ``a_m`` (m, d_rms of the last
    LSE) + ε·``dt_s`` (s since that LSE); ``fix_index`` is the index of that LSE in the input."""

    radius_m: float
    a_m: float
    dt_s: float
    fix_index: int


def drms(cov: np.ndarray | Sequence[Sequence[float]]) -> float:
    """d_rms = sqrt(σx² + σy²) (m) of a horizontal VCV (m², order x, y) (eq. 5.30)."""
    c = np.asarray(cov, dtype=float)
    return math.sqrt(max(float(c[0, 0]) + float(c[1, 1]), 0.0))


def expanding_circle_radius(a_m: float, rate_m_h: float, dt_s: float) -> float:
    """Eq. 2.1: ``R = a + ε·Δt`` in metres, from ``a_m`` (m), ``rate_m_h`` ε (m/h) and ``dt_s`` Δt
    (s).  Example: a = 36.1 m, ε = 1800 m/h, Δt = 48.3 min → 1485.1 m.

    Raises ValueError for a negative or non-finite argument.
    """
    for name, v in (("a", a_m), ("rate", rate_m_h), ("dt", dt_s)):
        if not math.isfinite(v) or v < 0.0:
            raise ValueError(f"expanding_circle_radius: {name} must be finite and >= 0, got {v}")
    return a_m + rate_m_h * dt_s / SECONDS_PER_HOUR


def _seconds(t: float | datetime, origin: datetime | None) -> float:
    """``t`` in seconds: a float as is, a datetime since ``origin`` (the first epoch's time)."""
    if isinstance(t, datetime):
        if origin is None:
            raise ValueError("poe_states: times must be all seconds or all datetimes")
        return (t - origin).total_seconds()
    if origin is not None:
        raise ValueError("poe_states: times must be all seconds or all datetimes")
    return float(t)


def _unpack(s: PoeSample | tuple[float | datetime, bool, float]
            ) -> tuple[float | datetime, bool, float]:
    if isinstance(s, PoeSample):
        return s.t, s.has_lse, s.lse_drms_m
    return s[0], bool(s[1]), float(s[2])


def poe_states(
    samples: Iterable[PoeSample | tuple[float | datetime, bool, float]],
    rate_m_h: float = DEFAULT_RATE_M_H,
) -> list[PoeState | None]:
    """The expanding-circle POE at every epoch of ``samples`` (time, has_lse, lse d_rms m).

    Each epoch uses the last LSE at or before it (an epoch with an LSE has Δt = 0, R = a);
    epochs before the first LSE give None.  An LSE whose d_rms is not finite is ignored.  Times
    are seconds or datetimes (not mixed) and must not decrease; ε ``rate_m_h`` is in m/h.
    """
    if not math.isfinite(rate_m_h) or rate_m_h < 0.0:
        raise ValueError(f"poe_states: rate must be finite and >= 0, got {rate_m_h}")
    per_s = rate_m_h / SECONDS_PER_HOUR
    out: list[PoeState | None] = []
    origin: datetime | None = None
    fix_t = math.nan
    fix_a = math.nan
    fix_i = -1
    prev_t = -math.inf
    for i, raw in enumerate(samples):
        when, has_lse, a = _unpack(raw)
        if i == 0 and isinstance(when, datetime):
            origin = when
        t = _seconds(when, origin)
        if not t >= prev_t:
            raise ValueError(f"poe_states: time decreases (or is NaN) at epoch {i}")
        prev_t = t
        if has_lse and a >= 0.0 and math.isfinite(a):
            fix_t, fix_a, fix_i = t, a, i
        if fix_i < 0:
            out.append(None)
            continue
        dt = t - fix_t
        out.append(PoeState(fix_a + per_s * dt, fix_a, dt, fix_i))
    return out


def poe_radii(
    samples: Iterable[PoeSample | tuple[float | datetime, bool, float]],
    rate_m_h: float = DEFAULT_RATE_M_H,
) -> list[float | None]:
    """Radius R (m) of the expanding circle per epoch (None before the first LSE); see
    :func:`poe_states`."""
    return [None if s is None else s.radius_m for s in poe_states(samples, rate_m_h)]


def circle_polygon(centre: Point, radius_m: float, n: int = 72) -> list[Point]:
    """``n`` points (counter-clockwise from east) on the circle of ``radius_m`` (m) about
    ``centre`` (grid m)."""
    if n < 3:
        raise ValueError("circle_polygon: n must be >= 3")
    cx, cy = centre
    return [(cx + radius_m * math.cos(2.0 * math.pi * k / n),
             cy + radius_m * math.sin(2.0 * math.pi * k / n)) for k in range(n)]


def _convex_hull(points: Iterable[Point]) -> list[Point]:
    """Andrew's monotone chain: the hull counter-clockwise, no repeated first point."""
    pts = sorted(set(points))
    if len(pts) <= 2:
        return pts

    def cross(o: Point, a: Point, b: Point) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[Point] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0.0:
            lower.pop()
        lower.append(p)
    upper: list[Point] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0.0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def segment_polygon(centre: Point, set_deg: float, depth_m: float,
                    half_width_deg: float, n_arc: int = 24) -> list[Point]:
    """The circle segment alone: apex at ``centre`` (grid m), radius ``depth_m`` d (m), spanning
    ``set_deg`` ± ``half_width_deg`` α (degrees from grid north, clockwise); apex first, then the
    arc from set − α to set + α."""
    _check_segment(depth_m, half_width_deg)
    cx, cy = centre
    pts: list[Point] = [(cx, cy)]
    for k in range(n_arc + 1):
        az = math.radians(set_deg - half_width_deg + 2.0 * half_width_deg * k / n_arc)
        pts.append((cx + depth_m * math.sin(az), cy + depth_m * math.cos(az)))
    return pts


def _check_segment(depth_m: float, half_width_deg: float) -> None:
    if not math.isfinite(depth_m) or depth_m < 0.0:
        raise ValueError(f"circle segment: depth must be finite and >= 0, got {depth_m}")
    if not 0.0 <= half_width_deg <= 90.0:
        raise ValueError(f"circle segment: half-width must be in [0, 90] deg, got {half_width_deg}")


def circle_segment_polygon(
    centre: Point,
    radius_m: float,
    set_deg: float,
    depth_m: float,
    half_width_deg: float,
    *,
    n_arc: int = 24,
    n_circle: int = 72,
) -> list[Point]:
    """The circle-segment POE (A17) as a convex polygon (grid m, counter-clockwise, not closed).

    The segment (apex at the DR ``centre``, depth ``depth_m`` d along the current set
    ``set_deg``, half-width ``half_width_deg`` α ≤ 90°) is convex, so its Minkowski sum with the
    expanding circle of ``radius_m`` R is the convex hull of the circles of radius R about the
    segment's apex and arc points.  It reaches d + R along the set, R against it.  With d = 0 it
    is the expanding circle; with R = 0 the bare segment.
    """
    _check_segment(depth_m, half_width_deg)
    if not math.isfinite(radius_m) or radius_m < 0.0:
        raise ValueError(f"circle_segment_polygon: radius must be finite and >= 0, got {radius_m}")
    seg = segment_polygon(centre, set_deg, depth_m, half_width_deg, n_arc)
    if radius_m == 0.0:
        return _convex_hull(seg)
    pts: list[Point] = []
    for p in seg:
        pts.extend(circle_polygon(p, radius_m, n_circle))
    return _convex_hull(pts)


__all__ = [
    "DEFAULT_RATE_M_H",
    "PoeSample",
    "PoeState",
    "circle_polygon",
    "circle_segment_polygon",
    "drms",
    "expanding_circle_radius",
    "poe_radii",
    "poe_states",
    "segment_polygon",
]
