"""Pool of Errors (engine/filter/poe.py; THEORY §10, eq. 2.1, D47) against hand calculations."""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta

import numpy as np
import pytest

from engine.filter.poe import (
    PoeSample,
    circle_polygon,
    circle_segment_polygon,
    drms,
    expanding_circle_radius,
    poe_radii,
    poe_states,
    segment_polygon,
)


def test_expanding_circle_worked_example() -> None:
    """a = 36.1 m, ε = 1800 m/h, Δt = 48.3 min: R = 36.1 + 1800·48.3/60 = 36.1 + 1449 = 1485.1 m."""
    assert expanding_circle_radius(36.1, 1800.0, 48.3 * 60.0) == pytest.approx(1485.1, abs=1e-9)


def test_expanding_circle_is_linear_in_time() -> None:
    """900 m/h: +15 m a minute, +900 m an hour; Δt = 0 gives a."""
    assert expanding_circle_radius(20.0, 900.0, 0.0) == 20.0
    assert expanding_circle_radius(20.0, 900.0, 60.0) == pytest.approx(35.0)
    assert expanding_circle_radius(20.0, 900.0, 3600.0) == pytest.approx(920.0)


@pytest.mark.parametrize("args", [(-1.0, 1800.0, 10.0), (10.0, -5.0, 10.0), (10.0, 1800.0, -1.0),
                                  (math.nan, 1800.0, 1.0), (1.0, math.inf, 1.0)])
def test_expanding_circle_rejects_bad_arguments(args: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError):
        expanding_circle_radius(*args)


def test_drms_is_root_of_the_trace() -> None:
    """d_rms = sqrt(σx² + σy²): 900 + 400 m² → 36.06 m (the covariance term does not count)."""
    assert drms(np.array([[900.0, 120.0], [120.0, 400.0]])) == pytest.approx(math.sqrt(1300.0))


def test_radius_per_epoch_by_hand() -> None:
    """1800 m/h = 0.5 m/s. LSE (a = 30) at 0 s, none at 60 and 120 s, LSE (a = 20) at 180 s, none
    at 240 s: R = 30, 60, 90, 20, 50 m."""
    seq = [(0.0, True, 30.0), (60.0, False, math.nan), (120.0, False, math.nan),
           (180.0, True, 20.0), (240.0, False, math.nan)]
    assert poe_radii(seq, 1800.0) == pytest.approx([30.0, 60.0, 90.0, 20.0, 50.0])
    states = poe_states(seq, 1800.0)
    assert [s.fix_index for s in states if s is not None] == [0, 0, 0, 3, 3]
    assert states[2] is not None and states[2].dt_s == 120.0 and states[2].a_m == 30.0


def test_no_radius_before_the_first_lse_and_bad_lse_ignored() -> None:
    """Epochs before any LSE have no POE; an LSE with a NaN d_rms does not reset it."""
    seq = [PoeSample(0.0, False), PoeSample(10.0, True, 12.0), PoeSample(20.0, True, math.nan),
           PoeSample(30.0, False)]
    r = poe_radii(seq, 3600.0)  # 1 m/s
    assert r[0] is None
    assert r[1:] == pytest.approx([12.0, 22.0, 32.0])


def test_datetime_epochs() -> None:
    """Times may be datetimes: 48.3 min after the fix gives the worked example."""
    t0 = datetime(1992, 9, 17, 10, 0, tzinfo=UTC)
    seq = [PoeSample(t0, True, 36.1), PoeSample(t0 + timedelta(minutes=48.3), False)]
    assert poe_radii(seq, 1800.0)[-1] == pytest.approx(1485.1)


def test_bad_sequences_raise() -> None:
    """Decreasing time, mixed time kinds and a negative rate are errors."""
    with pytest.raises(ValueError):
        poe_radii([(10.0, True, 1.0), (5.0, False, math.nan)])
    t0 = datetime(1992, 9, 17, tzinfo=UTC)
    with pytest.raises(ValueError):
        poe_radii([(t0, True, 1.0), (5.0, False, math.nan)])  # type: ignore[list-item]
    with pytest.raises(ValueError):
        poe_radii([(0.0, True, 1.0)], -1.0)


def _area(poly: list[tuple[float, float]]) -> float:
    return 0.5 * sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1],
                                                                    strict=True))


def test_circle_polygon() -> None:
    pts = circle_polygon((100.0, -50.0), 10.0, 36)
    assert len(pts) == 36
    assert all(math.hypot(x - 100.0, y + 50.0) == pytest.approx(10.0) for x, y in pts)
    assert _area(pts) > 0.0  # counter-clockwise


def test_segment_without_circle_is_the_bare_segment() -> None:
    """R = 0, set 090°, d = 1000 m, α = 30°: apex at the centre, reaching 1000 m east and
    ±500 m north/south (d·sin 30°)."""
    poly = circle_segment_polygon((0.0, 0.0), 0.0, 90.0, 1000.0, 30.0)
    xs = [p[0] for p in poly]
    ys = [p[1] for p in poly]
    assert min(xs) == pytest.approx(0.0, abs=1e-9)
    assert max(xs) == pytest.approx(1000.0)
    assert max(ys) == pytest.approx(500.0)
    assert min(ys) == pytest.approx(-500.0)
    assert _area(poly) > 0.0
    raw = segment_polygon((0.0, 0.0), 90.0, 1000.0, 30.0)
    assert raw[0] == (0.0, 0.0) and len(raw) == 26


def test_circle_segment_combination_by_hand() -> None:
    """R = 100 m with the segment above: d + R = 1100 m along the set (east), R = 100 m against
    it, d·sin α + R = 600 m across; the area exceeds the circle's and the segment's."""
    poly = circle_segment_polygon((10.0, 20.0), 100.0, 90.0, 1000.0, 30.0)
    xs = [p[0] - 10.0 for p in poly]
    ys = [p[1] - 20.0 for p in poly]
    assert max(xs) == pytest.approx(1100.0)
    assert min(xs) == pytest.approx(-100.0)
    assert max(ys) == pytest.approx(600.0)
    assert min(ys) == pytest.approx(-600.0)
    sector = math.pi * 1000.0**2 * (60.0 / 360.0)
    assert _area(poly) > sector + math.pi * 100.0**2 * 0.5


def test_circle_segment_orientation_follows_the_set() -> None:
    """Set 030°: the far point lies along azimuth 030° at d + R."""
    poly = circle_segment_polygon((0.0, 0.0), 50.0, 30.0, 400.0, 10.0)
    far = max(poly, key=lambda p: math.hypot(*p))
    assert math.hypot(*far) == pytest.approx(450.0, rel=1e-3)
    assert math.degrees(math.atan2(far[0], far[1])) == pytest.approx(30.0, abs=1.0)


def test_zero_depth_is_the_expanding_circle() -> None:
    poly = circle_segment_polygon((0.0, 0.0), 250.0, 45.0, 0.0, 20.0)
    assert all(math.hypot(*p) == pytest.approx(250.0) for p in poly)


@pytest.mark.parametrize("kw", [{"depth_m": -1.0}, {"half_width_deg": 95.0},
                                {"half_width_deg": -1.0}, {"radius_m": -5.0}])
def test_circle_segment_rejects_bad_geometry(kw: dict[str, float]) -> None:
    args = {"radius_m": 10.0, "set_deg": 0.0, "depth_m": 100.0, "half_width_deg": 20.0} | kw
    with pytest.raises(ValueError):
        circle_segment_polygon((0.0, 0.0), **args)
